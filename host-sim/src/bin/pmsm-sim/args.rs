//! Argument groups several subcommands share: the motor (`--motor | --motor-file`), the
//! simulated board (`BoardArgs`: the board's conditions by default, `--ideal` for the ideal
//! plant; `DcLinkArgs`: its DC link) and the value parsers and checks behind them.

use anyhow::Context;
use pmsm_host_sim::board::{DcLinkSpec, SimBoard};
use pmsm_host_sim::motor_file;
use pmsm_host_sim::number;
use pmsm_host_sim::sim::Mismatch;
use pmsm_plant::{Chopper, Inductances};
use pmsm_sensorless::motor::{self, Motor};
use std::path::PathBuf;

/// `--motor NAME | --motor-file F` (default: the Sinano motor).
#[derive(clap::Args)]
pub struct MotorArg {
    /// Motor preset (see `pmsm-sim list`; default: the scenario's, else sinano).
    #[arg(long, conflicts_with = "motor_file")]
    motor: Option<String>,
    /// Motor TOML file (format: README, host-sim/motors/).
    #[arg(long, value_name = "FILE.toml")]
    motor_file: Option<PathBuf>,
}

impl MotorArg {
    /// The motor's name and the motor; without either flag, `default`.
    pub fn resolve_or(&self, default: motor::Motor) -> anyhow::Result<(String, motor::Motor)> {
        self.resolve_plant_or(default).map(|(name, m, _)| (name, m))
    }

    /// As [`MotorArg::resolve_or`], with the plant's own inductances of a salient or
    /// saturating motor file (`motor_file::Loaded::inductances`; a preset has none).
    pub fn resolve_plant_or(
        &self,
        default: motor::Motor,
    ) -> anyhow::Result<(String, motor::Motor, Option<Inductances>)> {
        let m = match (&self.motor, &self.motor_file) {
            (_, Some(path)) => {
                let l = motor_file::load_full(path)?;
                return Ok((l.name, l.motor, l.inductances));
            }
            (Some(name), None) => preset(name)?,
            (None, None) => default,
        };
        Ok((m.name.to_string(), m, None))
    }

    /// As [`MotorArg::resolve_or`], the Sinano motor by default.
    pub fn resolve(&self) -> anyhow::Result<(String, motor::Motor)> {
        self.resolve_or(motor::HORNG_SINANO)
    }
}

fn preset(name: &str) -> anyhow::Result<motor::Motor> {
    motor::preset(name).ok_or_else(|| {
        let names: Vec<_> = motor::PRESETS.iter().map(|m| m.name).collect();
        anyhow::anyhow!("unknown motor '{name}' (known: {})", names.join(", "))
    })
}

/// The simulated board's flags: the board's conditions ([`SimBoard::board_defaults`]) unless
/// `--ideal` (or a scenario with `ideal = true`: [`SimBoard::ideal`]); every flag given
/// replaces its part of either.
#[derive(clap::Args, Clone, Debug)]
pub struct BoardArgs {
    /// The ideal plant: no noise, no offsets, no dead time, no idle (default: the board's
    /// 1 % noise, 2 % offset on phase a, 0.5 µs dead time, 20 ms idle).
    #[arg(long, conflicts_with = "board")]
    pub ideal: bool,
    /// The board's conditions even where the scenario asks for the ideal plant.
    #[arg(long)]
    pub board: bool,
    /// Current-sensor noise, standard deviation per phase (A) (adds to --noise-pct).
    #[arg(long, allow_negative_numbers = true)]
    pub noise_a: Option<f64>,
    /// Current-sensor noise in % of the motor's rated current (default: board 1, ideal 0).
    #[arg(long, allow_negative_numbers = true)]
    pub noise_pct: Option<f64>,
    /// Current-sensor offsets per phase (A), `a,b,c` (adds to --offset-pct).
    #[arg(long, value_parser = parse_offsets, allow_negative_numbers = true)]
    pub offset_a: Option<[f64; 3]>,
    /// Current-sensor offsets per phase in % of the motor's rated current, `a,b,c` (default:
    /// board 2,0,0, ideal 0,0,0).
    #[arg(long, value_parser = parse_offsets, allow_negative_numbers = true)]
    pub offset_pct: Option<[f64; 3]>,
    /// ADC quantisation step of the current measurement (A) (0 = none).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    pub adc_lsb_a: f64,
    /// Inverter dead time (µs), compensated by the drive; its averaged error is
    /// sign(i)·t_dead·f_pwm·V_bus per phase (default: board 0.5, ideal 0).
    #[arg(long, allow_negative_numbers = true)]
    pub dead_time_us: Option<f64>,
    /// PWM frequency (Hz) (default: the B-G431B-ESC1 firmware's 20000).
    #[arg(long, allow_negative_numbers = true)]
    pub pwm_hz: Option<f64>,
    /// Drive runs: the board idle this long before t = 0 (PWM off; the drive measures the
    /// current sensors' offsets from it, and the board takes them off its samples) (ms)
    /// (default: board 20, ideal 0).
    #[arg(long)]
    pub idle_ms: Option<f64>,
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

impl BoardArgs {
    /// The board for `motor`: the flags over [`SimBoard::board_defaults`], or over
    /// [`SimBoard::ideal`] with `--ideal` or when `scenario_ideal` (and not `--board`), checked;
    /// errors name the flag.
    pub fn resolve(&self, scenario_ideal: bool, motor: &Motor) -> anyhow::Result<SimBoard> {
        let mut board = if self.ideal || (scenario_ideal && !self.board) {
            SimBoard::ideal(motor)
        } else {
            SimBoard::board_defaults(motor)
        };
        let rated_a = f64::from(motor.ratings.current_a);
        // Noise and offsets: the flags given replace the base's, and add to each other.
        if self.noise_a.is_some() || self.noise_pct.is_some() {
            let noise_pct = self.noise_pct.unwrap_or(0.0);
            anyhow::ensure!(
                noise_pct.is_finite() && noise_pct >= 0.0,
                "--noise-pct = {}: must be a finite percentage >= 0",
                number(noise_pct)
            );
            board.noise_sigma_a = self.noise_a.unwrap_or(0.0) + 0.01 * noise_pct * rated_a;
        }
        if self.offset_a.is_some() || self.offset_pct.is_some() {
            let (offset_a, offset_pct) = (
                self.offset_a.unwrap_or([0.0; 3]),
                self.offset_pct.unwrap_or([0.0; 3]),
            );
            board.offset_a = std::array::from_fn(|k| offset_a[k] + 0.01 * offset_pct[k] * rated_a);
        }
        board.pwm_hz = self.pwm_hz.unwrap_or(board.pwm_hz);
        check_power_stage(
            board.pwm_hz,
            self.dead_time_us.unwrap_or(board.dead_time_s * 1e6),
        )?;
        if let Some(us) = self.dead_time_us {
            board.dead_time_s = us * 1e-6;
        }
        if let Some(idle_ms) = self.idle_ms {
            anyhow::ensure!(
                idle_ms.is_finite() && (0.0..=10_000.0).contains(&idle_ms),
                "--idle-ms = {}: allowed [0, 10000] ms",
                number(idle_ms)
            );
            board.idle_s = idle_ms * 1e-3;
        }
        board.adc_lsb_a = self.adc_lsb_a;
        board.seed = self.seed;
        Ok(board)
    }
}

/// The DC link's flags: any of them puts the board on a DC link (the scenario's `[dc_link]`,
/// or the defaults scaled from the motor, `DcLinkSpec::for_motor`), replacing its part.
#[derive(clap::Args, Clone, Debug)]
pub struct DcLinkArgs {
    /// A DC link of this capacitance (µF) instead of the stiff bus.
    #[arg(long, allow_negative_numbers = true)]
    pub dc_link_uf: Option<f64>,
    /// A DC link whose supply takes back at most this current (A) (0: it cannot sink).
    #[arg(long, allow_negative_numbers = true)]
    pub supply_sink_a: Option<f64>,
    /// A DC link with a brake chopper of this resistance (Ω), on at 1.15 and off at 1.10 of
    /// the motor's rated bus unless the scenario's `[dc_link]` says otherwise.
    #[arg(long, allow_negative_numbers = true)]
    pub brake_ohm: Option<f64>,
}

impl DcLinkArgs {
    /// The board's DC link: `base` (the scenario's) with the flags over it; errors name the
    /// value out of range.
    pub fn resolve(
        &self,
        base: Option<DcLinkSpec>,
        motor: &Motor,
    ) -> anyhow::Result<Option<DcLinkSpec>> {
        if self.dc_link_uf.is_none() && self.supply_sink_a.is_none() && self.brake_ohm.is_none() {
            return Ok(base);
        }
        let mut spec = base.unwrap_or_else(|| DcLinkSpec::for_motor(motor));
        if let Some(uf) = self.dc_link_uf {
            spec.capacitance_f = uf * 1e-6;
        }
        spec.sink_a = self.supply_sink_a.unwrap_or(spec.sink_a);
        if let Some(r) = self.brake_ohm {
            let ch = spec
                .chopper
                .unwrap_or_else(|| DcLinkSpec::default_chopper(motor, r));
            spec.chopper = Some(Chopper { r_ohm: r, ..ch });
        }
        spec.check()
            .context("--dc-link-uf, --supply-sink-a, --brake-ohm")?;
        Ok(Some(spec))
    }
}

/// `--pwm-hz` \[Hz] and `--dead-time-us` \[µs] checked.
fn check_power_stage(pwm_hz: f64, dead_time_us: f64) -> anyhow::Result<()> {
    anyhow::ensure!(
        pwm_hz.is_finite() && (1e3..=2e5).contains(&pwm_hz),
        "--pwm-hz = {}: allowed [1000, 200000] Hz",
        number(pwm_hz)
    );
    // A dead time is a small part of the PWM period: at most a tenth of it.
    let dead_max_us = 0.1e6 / pwm_hz;
    anyhow::ensure!(
        dead_time_us.is_finite() && (0.0..=dead_max_us).contains(&dead_time_us),
        "--dead-time-us = {}: allowed [0, {dead_max_us}] µs (a tenth of the {} Hz PWM period)",
        number(dead_time_us),
        pwm_hz
    );
    Ok(())
}

/// `a,b,c`: three finite numbers.
fn parse_offsets(s: &str) -> Result<[f64; 3], String> {
    let v: Vec<f64> = s
        .split(',')
        .map(|x| {
            x.trim()
                .parse::<f64>()
                .map_err(|_| format!("'{x}' is not a number"))
        })
        .collect::<Result<_, _>>()?;
    match v[..] {
        [a, b, c] if v.iter().all(|x| x.is_finite()) => Ok([a, b, c]),
        _ => Err("expected three finite numbers a,b,c".into()),
    }
}

/// `r=1.2,l=0.9`: the controller's parameter factors.
pub fn parse_mismatch(s: &str) -> Result<Mismatch, String> {
    let mut m = Mismatch::default();
    for kv in s.split(',').filter(|kv| !kv.trim().is_empty()) {
        let (k, v) = kv
            .split_once('=')
            .ok_or_else(|| format!("'{kv}' is not key=factor"))?;
        let v: f64 = v
            .trim()
            .parse()
            .map_err(|_| format!("'{v}' is not a number"))?;
        if !(v.is_finite() && v > 0.0) {
            return Err(format!("factor for '{k}' must be > 0"));
        }
        match k.trim() {
            "r" => m.r = v,
            "l" => m.l = v,
            "flux" => m.flux = v,
            "j" => m.j = v,
            "b" => m.b = v,
            other => return Err(format!("unknown parameter '{other}' (r, l, flux, j, b)")),
        }
    }
    Ok(m)
}
