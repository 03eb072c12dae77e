//! `pmsm-sim run`: a scenario on the simulated board, its summary and verdict; `prepare`
//! turns the flags into the simulation's configuration (`sweep` runs its cells through it).

use crate::args::{parse_mismatch, BoardArgs, DcLinkArgs, MotorArg};
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::output;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::{self, LoadKind};
use pmsm_host_sim::sim::{self, Mismatch, SimConfig};
use pmsm_host_sim::{motor_file, number, table};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct RunArgs {
    /// Built-in scenario (see `pmsm-sim list`).
    #[arg(
        required_unless_present = "scenario_file",
        conflicts_with = "scenario_file"
    )]
    scenario: Option<String>,
    /// Scenario TOML file (format: `host-sim/src/scenario.rs`, examples in
    /// `host-sim/scenarios/`).
    #[arg(long, value_name = "FILE.toml")]
    scenario_file: Option<PathBuf>,
    /// What gives the controller θ̂_e and ω̂_m.
    #[arg(long, default_value = "encoder")]
    observer: String,
    /// The motor replacing the scenario's.
    #[command(flatten)]
    motor: MotorArg,
    /// Load level (N·m): the scenario's load profile scaled so that its largest value is this.
    #[arg(long, allow_negative_numbers = true)]
    load_nm: Option<f64>,
    /// DC bus voltage (V) (default: the motor's).
    #[arg(long, allow_negative_numbers = true)]
    bus_v: Option<f64>,
    /// DC bus voltage in % of the motor's rated bus (instead of --bus-v).
    #[arg(long, conflicts_with = "bus_v", allow_negative_numbers = true)]
    bus_pct: Option<f64>,
    /// The simulated board (the board's conditions unless --ideal or the scenario's
    /// `ideal = true`).
    #[command(flatten)]
    board: BoardArgs,
    /// The board senses the terminal voltage (`true` or `false`; the B-G431B-ESC1's
    /// firmware passes none): without it an enable cannot watch a coasting rotor with the PWM
    /// off and catches it with the currents regulated to zero (default: the scenario's
    /// `terminal_sensing`, else true).
    #[arg(long, value_name = "BOOL", num_args = 0..=1, default_missing_value = "true")]
    terminal_sensing: Option<bool>,
    /// The board's DC link (default: the scenario's `[dc_link]`, else a stiff bus).
    #[command(flatten)]
    dc_link: DcLinkArgs,
    /// Controller parameter factors, e.g. `r=1.2,l=0.9` (keys r, l, flux, j, b).
    #[arg(long, value_parser = parse_mismatch, default_value = "")]
    mismatch: Mismatch,
    /// The controller's motor parameters from this file (e.g. written by `identify --out`),
    /// the plant staying the --motor / --motor-file one (instead of --mismatch).
    #[arg(long, value_name = "FILE.toml", conflicts_with = "mismatch")]
    drive_motor_file: Option<PathBuf>,
    /// Identify the motor on the same board first (`pmsm-sim identify`: its pole pairs,
    /// ratings and torque convention only) and drive with the identified parameters
    /// (instead of --mismatch or --drive-motor-file); an identification that fails fails the
    /// run, named.
    #[arg(long, conflicts_with_all = ["mismatch", "drive_motor_file"])]
    identified: bool,
    /// The load's kind, replacing the scenario's `load_kind`: a brake opposes the motion,
    /// an active load is a signed torque (a hanging mass).
    #[arg(long, value_enum)]
    load_kind: Option<LoadKindArg>,
    /// Control (current-loop and observer) rate (Hz), a multiple of 1000 for the drive (the
    /// speed loop and the drive's task run at 1 kHz); default: the configuration's for the
    /// motor (20 samples per electrical period at rated speed, a divisor of the PWM
    /// frequency, 4 kHz at least; `pmsm-sim gains` prints it).
    #[arg(long)]
    rate_hz: Option<f64>,
    /// The time from a sample to its duties taking effect (µs), modelled by the plant and
    /// compensated by the drive (`PowerStageConfig::update_delay_s`); at most one control
    /// period. The B-G431B-ESC1 loads its duties at the next PWM update: 50 µs. Default 0.
    #[arg(long)]
    update_delay_us: Option<f64>,
    /// Run on the encoder until this speed (rpm), then sensorless (a stand-in for a start-up
    /// sequence; default: sensorless from t = 0).
    #[arg(long)]
    sensorless_from_rpm: Option<f64>,
    /// The sliding observer in fixed point (`pmsm_sensorless::fixed::sliding`, the Cortex-M0's
    /// arithmetic; its currents and voltage rounded to Q15): bare-observer scenarios with
    /// `sliding-torque` or `sliding-velocity` only.
    #[arg(long)]
    fixed_point: bool,
    /// Start a rotor found at rest with the alignment and the open loop on a salient motor
    /// too (default: through high-frequency injection, `src/drive/inject.rs`; a motor without
    /// the saliency declines it).
    #[arg(long)]
    no_injection: bool,
    /// Write run.csv and run.png into this directory (nothing is written without it).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Print the JSON summary on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LoadKindArg {
    Brake,
    Active,
}

/// What `run` simulates: the scenario on the chosen motor and board, with every flag
/// applied and checked (errors name the flag and the allowed values).
pub fn prepare(args: &RunArgs) -> anyhow::Result<SimConfig> {
    let spec = match (&args.scenario, &args.scenario_file) {
        (_, Some(path)) => scenario::Spec::load(path)?,
        (Some(name), None) => scenario::Spec::built_in(name)?,
        (None, None) => anyhow::bail!("give a scenario name or --scenario-file"),
    };
    let observer = ObserverKind::from_name(&args.observer)?;
    let (motor_name, m, inductances) = args.motor.resolve_plant_or(spec.default_motor()?)?;
    let mut sc = spec.build(&motor_name, m)?;
    sc.load_kind = match (args.load_kind, sc.load_kind) {
        (None, kind) => kind,
        (Some(LoadKindArg::Active), _) => LoadKind::Active,
        (Some(LoadKindArg::Brake), LoadKind::Active) => LoadKind::Brake {
            sat_rpm: scenario::BRAKE_FADE * f64::from(m.ratings.speed_rpm),
        },
        (Some(LoadKindArg::Brake), brake) => brake,
    };
    // The plant's own settings stay within what a test of this motor means: a load up to
    // 10 times its rated torque, a bus up to twice its rated bus.
    let rated_bus = f64::from(m.ratings.bus_v);
    if let Some(x) = args.load_nm {
        let max = 10.0 * m.ratings.torque_nm;
        anyhow::ensure!(
            x.is_finite() && x.abs() <= f64::from(max),
            "--load-nm = {}: load allowed [-{max}, {max}] N·m (10 x the motor's rated torque)",
            number(x)
        );
        sc.load_nm = x;
    }
    let mut board = args.board.resolve(spec.is_ideal(), &m)?;
    if let Some(v) = args.bus_v {
        let max = 2.0 * m.ratings.bus_v;
        anyhow::ensure!(
            v.is_finite() && v > 0.0 && v <= f64::from(max),
            "--bus-v = {}: bus voltage allowed (0, {max}] V (2 x the motor's rated bus)",
            number(v)
        );
        board.bus_v = v;
    }
    if let Some(p) = args.bus_pct {
        anyhow::ensure!(
            p.is_finite() && p > 0.0 && p <= 200.0,
            "--bus-pct = {}: bus voltage allowed (0, 200] % of the motor's rated bus",
            number(p)
        );
        board.bus_v = 0.01 * p * rated_bus;
    }
    board.dc_link = args.dc_link.resolve(spec.dc_link(&m)?, &m)?;
    let mut cfg = SimConfig::on(board, sc, observer);
    if let Some(sensed) = args.terminal_sensing {
        cfg.board.sense_terminal_voltage = sensed;
    }
    cfg.mismatch = args.mismatch;
    cfg.plant_inductances = inductances;
    if let Some(path) = &args.drive_motor_file {
        let (_, d) = motor_file::load(path)?;
        anyhow::ensure!(
            d.params.pole_pairs == m.params.pole_pairs,
            "--drive-motor-file {}: pole_pairs = {}, the motor's are {}",
            path.display(),
            d.params.pole_pairs,
            m.params.pole_pairs
        );
        cfg.mismatch = Mismatch::between(&m.params, &d.params);
    }
    cfg.identify_first = args.identified;
    cfg.injection = !args.no_injection;
    if let Some(rate_hz) = args.rate_hz {
        anyhow::ensure!(
            rate_hz.is_finite() && (1000.0..=100_000.0).contains(&rate_hz),
            "--rate-hz must be between 1000 and 100000"
        );
        // Keeps the plant's sub-step at 10 µs or less.
        cfg.set_rate(rate_hz);
    } else {
        // The configuration's for the board as the options set it (its PWM frequency).
        cfg.set_rate(SimConfig::rate_for(&cfg.board, &cfg.scenario.motor));
    }
    if let Some(us) = args.update_delay_us {
        let max_us = 1e6 / cfg.rate_hz;
        anyhow::ensure!(
            us.is_finite() && (0.0..=max_us).contains(&us),
            "--update-delay-us = {}: allowed [0, {}] (one control period)",
            number(us),
            number(max_us)
        );
        cfg.board.update_delay_s = 1e-6 * us;
    }
    cfg.fixed_point = args.fixed_point;
    if let Some(x) = args.sensorless_from_rpm {
        anyhow::ensure!(
            cfg.scenario.drive.is_none(),
            "--sensorless-from-rpm is for bare-observer scenarios; the drive starts itself"
        );
        anyhow::ensure!(
            x.is_finite() && x >= 0.0,
            "--sensorless-from-rpm must be a finite number >= 0"
        );
        cfg.sensorless_from_rpm = Some(x);
    }
    Ok(cfg)
}

/// `run`: the text (or JSON) to print, and whether the run passed.
pub fn run(args: RunArgs) -> anyhow::Result<(String, bool)> {
    let mut out = String::new();
    let run = sim::run(prepare(&args)?)?;
    let summary = Summary::of(&run);
    let files = match &args.out {
        Some(dir) => Some(output::write_all(&run, dir)?),
        None => None,
    };
    if args.json {
        return Ok((serde_json::to_string(&summary)? + "\n", summary.pass));
    }
    outln!(
        out,
        "{} | motor {} | observer {} | {} Hz | lost lock: {} | fault: {}",
        summary.scenario,
        summary.motor,
        summary.observer,
        summary.rate_hz,
        summary
            .lost_lock_at_s
            .map_or("no".to_string(), |t| format!("at {t:.4} s")),
        summary.fault.as_deref().unwrap_or("none")
    );
    let b = &run.config.board;
    outln!(
        out,
        "board: noise {} A, offsets {} A, dead time {} µs at {} Hz, {} ms idle{}",
        number(b.noise_sigma_a),
        b.offset_a.map(number).join(", "),
        number(b.dead_time_s * 1e6),
        b.pwm_hz,
        number(b.idle_s * 1e3),
        if b.noise_sigma_a == 0.0 && b.dead_time_s == 0.0 && b.offset_a == [0.0; 3] {
            " (the ideal plant)"
        } else {
            ""
        }
    );
    let mut windows = table(
        &[
            "window",
            "cmd rpm",
            "err mean rpm",
            "err max rpm",
            "θ err mean °e",
            "θ err max °e",
            "τ̂ N·m",
        ],
        &[1, 2, 3, 4, 5, 6],
    );
    for (name, m) in &summary.windows {
        match m {
            Some(m) => windows.add_row([
                name.clone(),
                format!("{:.1}", m.speed_cmd_mean_rpm),
                format!("{:.4}", m.speed_err_mean_rpm),
                format!("{:.3}", m.speed_err_max_abs_rpm),
                format!("{:.3}", m.theta_err_mean_deg_e),
                format!("{:.3}", m.theta_err_max_abs_deg_e),
                m.torque_hat_mean_nm
                    .map_or_else(|| "-".into(), |x| format!("{x:.4}")),
            ]),
            None => windows.add_row([name.as_str(), "not reached"]),
        };
    }
    outln!(out, "{windows}");
    for (name, m) in &summary.windows {
        if let Some(x) = m.as_ref().and_then(|m| m.derated_to_rpm) {
            outln!(
                out,
                "window {name}: derated by the bus to {x:.1} rpm (its load torque does not fit \
                 at the command: `pmsm-sim gains`, rated torque up to), scored against it"
            );
        }
    }
    for tr in &summary.transitions {
        outln!(
            out,
            "{:>9.4} s  {} -> {} ({})",
            tr.t,
            tr.from,
            tr.to,
            tr.reason
        );
    }
    if let Some(k) = summary.fault_step {
        outln!(out, "fault {} steps after its cause", k);
    }
    if let Some(v) = summary.lowest_sensorless_rpm {
        outln!(out, "lowest sensorless speed {v:.1} rpm");
    }
    if let Some(a) = &summary.adapted {
        outln!(
            out,
            "adapted model: R {:.4} Ω ({:+.2} % of the plant's), ψ_f {:.5} Wb ({:+.2} %)",
            a.r_ohm,
            a.r_err_pct,
            a.flux_wb,
            a.flux_err_pct
        );
    }
    if let Some(v) = summary.bus_peak_v {
        outln!(out, "DC link: bus peak {v:.2} V");
    }
    if let Some((csv, png)) = files {
        outln!(out, "plot: {}", png.display());
        outln!(out, "csv:  {}", csv.display());
    }
    outln!(
        out,
        "simulated {:.2} s in {:.3} s wall ({:.0}× real time; output files not included)",
        run.rows.len() as f64 / run.config.rate_hz,
        run.wall_s,
        summary.real_time_factor
    );
    if summary.pass {
        outln!(out, "PASS");
    } else {
        outln!(out, "FAIL");
        for r in &summary.reasons {
            outln!(out, "  {r}");
        }
    }
    Ok((out, summary.pass))
}
