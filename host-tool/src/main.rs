//! `pmsm-tool`: configure, identify, run, record and watch a drive over its link.

// The tool's error carries the device's answer (a few hundred bytes), returned once per
// command: no cost worth a box.
#![allow(clippy::result_large_err)]

use clap::{Args, Parser, Subcommand};
use pmsm_tool::client::{connect, Target, ToolError};
use pmsm_tool::ops;
use pmsm_tool::serve::{Pace, Served};
use pmsm_tool::sim_device::SimDevice;
use std::path::PathBuf;
use std::time::Duration;

#[derive(Parser)]
#[command(
    name = "pmsm-tool",
    version,
    about = "Configure, identify, run, record and watch a pmsm-sensorless drive over its link"
)]
struct Cli {
    #[command(flatten)]
    link: LinkArgs,
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Args)]
struct LinkArgs {
    /// Serial port of the board (the ST-LINK virtual COM port, e.g. /dev/ttyACM0).
    #[arg(long, global = true, conflicts_with = "tcp")]
    port: Option<String>,
    /// Baud rate of the serial port.
    #[arg(long, global = true, default_value_t = 115_200)]
    baud: u32,
    /// TCP address of an emulated or simulated device (host:port).
    #[arg(long, global = true)]
    tcp: Option<String>,
    /// How long to wait for an answer [s].
    #[arg(long, global = true, default_value_t = 2.0)]
    timeout: f64,
}

#[derive(Subcommand)]
enum Cmd {
    /// Settings: get, set, save, load a motor file.
    #[command(subcommand)]
    Config(ConfigCmd),
    /// Identify the motor (R, L, flux, J, B) and write the motor file `pmsm-sim --motor-file` reads.
    Identify {
        /// The motor file to write.
        #[arg(long)]
        out: PathBuf,
        /// The motor's name in the file.
        #[arg(long, default_value = "identified")]
        name: String,
        /// Also load the identified motor into the device and save it.
        #[arg(long)]
        save: bool,
        /// Give up after this long [s].
        #[arg(long, default_value_t = 120.0)]
        limit: f64,
    },
    /// Run at a speed command for a time (of the device's clock), then stop.
    Run {
        #[arg(long, allow_hyphen_values = true)]
        speed_rpm: f32,
        #[arg(long, default_value_t = 5.0)]
        seconds: f64,
        /// Keep running after (no stop).
        #[arg(long)]
        keep: bool,
    },
    /// Record the telemetry to CSV.
    Record {
        #[arg(long)]
        out: PathBuf,
        #[arg(long, default_value_t = 100)]
        rate_hz: u16,
        #[arg(long, default_value_t = 5.0)]
        seconds: f64,
    },
    /// Show the latched fault; `fault clear` clears it.
    Fault {
        #[arg(value_parser = ["clear"])]
        action: Option<String>,
    },
    /// Restart the device (a system reset; refused while the drive runs) and wait until it
    /// answers again: what was not saved is gone.
    Restart {
        /// Give up waiting after this long [s].
        #[arg(long, default_value_t = 10.0)]
        limit: f64,
    },
    /// Live plots of speed, currents, residuals and mode.
    Watch {
        #[arg(long, default_value_t = 50)]
        rate_hz: u16,
    },
    /// Serve a simulated device (the core drive on the host simulator's plant) on a TCP port,
    /// for trying the tool without a board.
    Sim {
        /// Address to listen on.
        #[arg(long, default_value = "127.0.0.1:7878")]
        listen: String,
        /// The motor on the simulated bench: a preset name or a motor file.
        #[arg(long, default_value = "sinano")]
        motor: String,
        /// Start configured with that motor (else with an empty store).
        #[arg(long)]
        configured: bool,
    },
}

#[derive(Subcommand)]
enum ConfigCmd {
    /// Print every setting, or one.
    Get { key: Option<String> },
    /// Set one setting (validated by the drive).
    Set {
        key: String,
        #[arg(allow_hyphen_values = true)]
        value: String,
    },
    /// Save the settings in the device's flash.
    Save,
    /// Load a motor file (the `pmsm-sim --motor-file` format); the other settings become the
    /// drive's defaults for it.
    LoadMotor { file: PathBuf },
}

fn main() {
    let cli = Cli::parse();
    if let Err(e) = run(cli) {
        eprintln!("pmsm-tool: {e}");
        std::process::exit(e.exit_code());
    }
}

fn target(l: &LinkArgs) -> Result<Target, ToolError> {
    match (&l.port, &l.tcp) {
        (Some(p), _) => Ok(Target::Serial(p.clone(), l.baud)),
        (None, Some(t)) => Ok(Target::Tcp(t.clone())),
        (None, None) => Err(ToolError::Port(
            "no link given: --port /dev/ttyX or --tcp host:port".into(),
        )),
    }
}

fn run(cli: Cli) -> Result<(), ToolError> {
    if let Cmd::Sim {
        listen,
        motor,
        configured,
    } = &cli.cmd
    {
        return sim(listen, motor, *configured);
    }
    let timeout = Duration::from_secs_f64(cli.link.timeout.max(0.01));
    let mut c = connect(&target(&cli.link)?, timeout)?;
    match cli.cmd {
        Cmd::Config(ConfigCmd::Get { key }) => {
            for (k, v) in ops::config_get(&mut c, key.as_deref())? {
                println!("{} = {}", k.name(), ops::show_value(k, v));
            }
        }
        Cmd::Config(ConfigCmd::Set { key, value }) => ops::config_set(&mut c, &key, &value)?,
        Cmd::Config(ConfigCmd::Save) => ops::config_save(&mut c)?,
        Cmd::Config(ConfigCmd::LoadMotor { file }) => {
            let name = ops::load_motor(&mut c, &file)?;
            println!("loaded motor {name:?} (not saved: pmsm-tool config save)");
        }
        Cmd::Identify {
            out,
            name,
            save,
            limit,
        } => {
            let motor = ops::identify(&mut c, Duration::from_secs_f64(limit))?;
            std::fs::write(&out, ops::motor_toml(&name, &motor))
                .map_err(|e| ToolError::Other(anyhow::anyhow!("{}: {e}", out.display())))?;
            println!("wrote {}", out.display());
            if save {
                ops::load_motor(&mut c, &out)?;
                ops::config_save(&mut c)?;
                println!("loaded and saved on the device");
            }
        }
        Cmd::Run {
            speed_rpm,
            seconds,
            keep,
        } => {
            let run = ops::run(&mut c, speed_rpm, seconds, 10)?;
            if !keep {
                ops::stop(&mut c)?;
            }
            for t in &run.transitions {
                println!("{}", ops::transition_text(t));
            }
            let records = run.records;
            for r in records.iter().step_by(10) {
                println!(
                    "t {:>7.2} s  {:?}  speed {:>8.1} rpm  ref {:>8.1}  i_q {:>6.2} A",
                    f64::from(r.t_ms.wrapping_sub(records[0].t_ms)) / 1000.0,
                    r.mode,
                    r.speed_rpm,
                    r.speed_ref_rpm,
                    r.i_q
                );
            }
            let refused = run
                .transitions
                .iter()
                .any(|t| t.reason == pmsm_link::wire::Reason::ResistanceRefused);
            if let (true, Some(last)) = (refused, records.last()) {
                eprintln!("warning: {}", ops::refused_warning(last.r_ohm));
            }
        }
        Cmd::Record {
            out,
            rate_hz,
            seconds,
        } => {
            let r_ref_ohm = ops::settings(&mut c)?.motor.r_ohm;
            let records = ops::record(&mut c, rate_hz, seconds)?;
            let mut f = std::fs::File::create(&out)
                .map_err(|e| ToolError::Other(anyhow::anyhow!("{}: {e}", out.display())))?;
            ops::write_csv(&mut f, &records, r_ref_ohm).map_err(ToolError::Io)?;
            println!("{} records in {}", records.len(), out.display());
        }
        Cmd::Fault { action } => {
            let f = if action.is_some() {
                ops::fault_clear(&mut c, Duration::from_millis(100))?
            } else {
                ops::fault(&mut c)?
            };
            println!("{}", f.map_or("no fault", ops::name_of));
        }
        Cmd::Restart { limit } => {
            let configured = ops::restart(&mut c, Duration::from_secs_f64(limit))?;
            println!(
                "restarted: {}",
                if configured {
                    "configured from its store"
                } else {
                    "not configured (no valid settings stored)"
                }
            );
        }
        Cmd::Watch { rate_hz } => pmsm_tool::watch::watch(&mut c, rate_hz)?,
        Cmd::Sim { .. } => {}
    }
    Ok(())
}

/// `pmsm-tool sim`: serves a simulated device until killed.
fn sim(listen: &str, motor: &str, configured: bool) -> Result<(), ToolError> {
    let m = match pmsm_sensorless::motor::preset(motor) {
        Some(m) => m,
        None => pmsm_host_sim::motor_file::load(std::path::Path::new(motor))?.1,
    };
    let mut device = SimDevice::new(m, None)?;
    if configured {
        // The motor with the core's defaults on the simulated board's power stage.
        let s = pmsm_link::Device::defaults_for(&device, &m);
        device.set_flash(Some(s));
        device.reset();
    }
    let listener = std::net::TcpListener::bind(listen)
        .map_err(|e| ToolError::Port(format!("{listen}: {e}")))?;
    let _served = Served::spawn_on(listener, device, Pace::default())?;
    println!("simulated device on {listen} (Ctrl-C stops)");
    loop {
        std::thread::sleep(Duration::from_secs(3600));
    }
}
