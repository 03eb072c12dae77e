//! `pmsm-sim`: run the pmsm-sensorless core against the simulated motor.

use clap::{Parser, Subcommand};
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::output;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::LoadKind;
use pmsm_host_sim::sim::{self, Mismatch, SimConfig};
use pmsm_host_sim::{motor_file, names, number, scenario, table};
use pmsm_sensorless::motor;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;

/// `writeln!` into a `String` (which cannot fail).
macro_rules! outln {
    ($out:expr, $($arg:tt)*) => {{
        let _ = writeln!($out, $($arg)*);
    }};
}
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "pmsm-sim",
    version,
    about = "PMSM plant simulator for the pmsm-sensorless core"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List scenarios, motors and observers.
    List,
    /// Run a scenario and give its verdict (exit 3 when it fails); with --out, write
    /// run.csv and run.png.
    Run(Box<RunArgs>),
    /// A matrix of runs in parallel (every key of the matrix's `[axes]` is a run flag); exit 1
    /// when a cell fails.
    Sweep(SweepArgs),
    /// Every gain and limit the drive derives for a motor, with warnings for what will
    /// struggle.
    Gains(GainsArgs),
    /// Sliding-gain bounds of Horng & Chin Sec 4 at an operating point.
    Bounds(BoundsArgs),
    /// Limits on the flux observer's gain γ (Ortega et al. eq (9), Proposition 4).
    Gamma(GammaArgs),
    /// Instruction and cycle counts of the core on the emulated Cortex-M4F, firmware size.
    Cycles(CyclesArgs),
    /// The drive identifies the simulated motor from its pole pairs and ratings (R, L, flux
    /// linkage, J, B); exit 3 when it ends in an error. With --out, write the motor file.
    Identify(IdentifyArgs),
}

#[derive(clap::Args)]
struct IdentifyArgs {
    /// The motor on the bench (the truth).
    #[command(flatten)]
    motor: MotorArg,
    /// DC bus voltage (V) (default: the motor's).
    #[arg(long)]
    bus_v: Option<f64>,
    /// Current-sensor noise in % of the motor's rated current.
    #[arg(long, default_value_t = 1.0)]
    noise_pct: f64,
    /// Current-sensor offsets per phase in % of the motor's rated current, `a,b,c`.
    #[arg(long, value_parser = parse_offsets, default_value = "2,0,0", allow_negative_numbers = true)]
    offset_pct: [f64; 3],
    /// ADC quantisation step of the current measurement (A) (0 = none).
    #[arg(long, default_value_t = 0.0)]
    adc_lsb_a: f64,
    /// The board's current sensing range (A) (default: twice the drive's trip level).
    #[arg(long)]
    sense_range_a: Option<f64>,
    /// Inverter dead time (µs), compensated by the drive.
    #[arg(long, default_value_t = 0.5)]
    dead_time_us: f64,
    /// PWM frequency (Hz).
    #[arg(long, default_value_t = 20_000.0)]
    pwm_hz: f64,
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// A fault of the motor: open-a|b|c (a phase not connected), shorted-a|b|c (a winding
    /// short-circuited), blocked (the shaft cannot turn).
    #[arg(long)]
    motor_fault: Option<String>,
    /// Write the identified motor file here (loads with --motor-file).
    #[arg(long, value_name = "FILE.toml")]
    out: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

/// `identify`: the text (or JSON), and whether the identification ended without error.
fn identify(args: IdentifyArgs) -> anyhow::Result<(String, bool)> {
    use pmsm_host_sim::identify as id;
    let (name, m) = args.motor.resolve()?;
    let mut cfg = id::IdentifyRun::board_defaults(m);
    let rated_a = f64::from(m.ratings.current_a);
    if let Some(v) = args.bus_v {
        let max = 2.0 * f64::from(m.ratings.bus_v);
        anyhow::ensure!(
            v.is_finite() && v > 0.0 && v <= max,
            "--bus-v = {}: bus voltage allowed (0, {max}] V (2 x the motor's rated bus)",
            number(v)
        );
        cfg.board.bus_v = v;
    }
    anyhow::ensure!(
        args.noise_pct.is_finite() && args.noise_pct >= 0.0,
        "--noise-pct = {}: must be a finite percentage >= 0",
        number(args.noise_pct)
    );
    cfg.board.noise_sigma_a = 0.01 * args.noise_pct * rated_a;
    cfg.board.offset_a = args.offset_pct.map(|p| 0.01 * p * rated_a);
    cfg.board.adc_lsb_a = args.adc_lsb_a;
    cfg.board.sense_range_a = args.sense_range_a;
    (cfg.board.pwm_hz, cfg.board.dead_time_s) = power_stage(args.pwm_hz, args.dead_time_us)?;
    cfg.board.seed = args.seed;
    cfg.fault = args
        .motor_fault
        .as_deref()
        .map(id::MotorFault::parse)
        .transpose()?;
    let o = id::run(&cfg)?;
    let motor = id::identified_motor(&o)?;
    if let (Some(path), Some(mm), Some(ident)) = (&args.out, &motor, &o.identified) {
        let stem = path
            .file_stem()
            .and_then(|s| s.to_str())
            .unwrap_or("identified");
        std::fs::write(path, id::motor_toml(stem, &mm.params, &o, ident))
            .map_err(|e| anyhow::anyhow!("--out {}: {e}", path.display()))?;
        // The file must load as any other.
        motor_file::load(path)?;
    }
    let ok = o.identified.is_some();
    let j = id::summary_json(&name, &o);
    if args.json {
        return Ok((format!("{j}\n"), ok));
    }
    let mut out = String::new();
    outln!(
        out,
        "identify: motor {name}, {:.3} s simulated",
        o.duration_s
    );
    if let Some(f) = o.fault {
        outln!(out, "ERROR: {}", names::fault_name(f));
    }
    let mut t = table(&["parameter", "identified", "truth", "error %"], &[1, 2, 3]);
    for key in [
        "r_ohm", "l_d_h", "l_q_h", "l_h", "flux_wb", "j_kgm2", "b_nms",
    ] {
        let f = |v: &serde_json::Value| v.get(key).and_then(|x| x.as_f64());
        let cell = |x: Option<f64>, p: usize| x.map_or("-".to_string(), |x| format!("{x:.p$e}"));
        t.add_row([
            key.to_string(),
            cell(f(&j["identified"]), 4),
            cell(f(&j["truth"]), 4),
            f(&j["error_pct"]).map_or("-".to_string(), |x| format!("{x:+.2}")),
        ]);
    }
    outln!(out, "{t}");
    Ok((out, ok))
}

#[derive(clap::Args)]
struct SweepArgs {
    /// Matrix TOML file (format: host-sim/src/sweep.rs; host-sim/matrices/).
    #[arg(long, value_name = "M.toml")]
    matrix: PathBuf,
    /// Print the cells as JSON on stdout instead of the table.
    #[arg(long)]
    json: bool,
    /// Write sweep.csv, sweep.json and heatmap.png into this directory.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Threads (default: every core).
    #[arg(long)]
    jobs: Option<usize>,
}

/// `sweep`: the table (or JSON) and whether every cell passed.
fn sweep(args: SweepArgs) -> anyhow::Result<(String, bool)> {
    use pmsm_host_sim::report::sweep::{self, Matrix};
    let matrix = Matrix::load(&args.matrix)?;
    if let Some(j) = args.jobs {
        anyhow::ensure!(j > 0, "--jobs must be at least 1");
    }
    let report = sweep::run(&matrix, args.jobs, |cell| {
        let cli = Cli::try_parse_from(
            ["pmsm-sim", "run"]
                .into_iter()
                .map(String::from)
                .chain(cell.iter().cloned()),
        )
        .map_err(|e| anyhow::anyhow!("{}", e.to_string().lines().next().unwrap_or("")))?;
        let Command::Run(args) = cli.command else {
            anyhow::bail!("not a run");
        };
        anyhow::ensure!(args.out.is_none(), "a sweep cell writes no files (--out)");
        Ok(Summary::of(&sim::run(prepare(&args)?)?))
    })?;
    let mut out = if args.json {
        serde_json::to_string(&report)? + "\n"
    } else {
        report.table(&matrix)
    };
    if let Some(dir) = &args.out {
        let title = format!(
            "{}: {} of {} cells passed",
            args.matrix.display(),
            report.passed,
            report.total
        );
        let files = report.write(&matrix, dir, &title)?;
        if !args.json {
            for f in files {
                outln!(out, "{}", f.display());
            }
        }
    }
    Ok((out, report.passed == report.total))
}

#[derive(clap::Args)]
struct CyclesArgs {
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

fn cycles(args: CyclesArgs) -> anyhow::Result<String> {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .ok_or_else(|| anyhow::anyhow!("no workspace root"))?;
    let r = pmsm_host_sim::analysis::cycles::measure(root)?;
    let mut out = String::new();
    if args.json {
        outln!(out, "{}", serde_json::to_string(&r)?);
    } else {
        outln!(out, "Cortex-M4F (QEMU mps2-an386, one trace line per instruction), cycles at zero wait states:");
        let mut t = table(&["measured call", "cycles est"], &[1]);
        for (what, c) in [
            (
                "step, both observers, sliding primary (worst over a turn)",
                r.step_cycles_est,
            ),
            ("  worst of four runs across ±π", r.step_seam_cycles_est),
            (
                "step, flux observer primary",
                r.step_flux_primary_cycles_est,
            ),
            ("step, open loop (start-up)", r.step_open_loop_cycles_est),
            ("step, voltage at its limit", r.step_saturated_cycles_est),
            (
                "1 kHz task (Drive::tick), sliding primary",
                r.tick_cycles_est,
            ),
            ("1 kHz task, flux primary", r.tick_flux_primary_cycles_est),
            ("1 kHz task, open loop", r.tick_open_loop_cycles_est),
            (
                "step, offset calibration (PWM off)",
                r.step_calibrate_cycles_est,
            ),
            (
                "step, identification: resistance",
                r.step_identify_resistance_cycles_est,
            ),
            (
                "step, identification: inductance",
                r.step_identify_inductance_cycles_est,
            ),
            (
                "step, identification: flux (I/f spin)",
                r.step_identify_flux_cycles_est,
            ),
            (
                "step, identification: J and B (torque steps)",
                r.step_identify_mechanics_cycles_est,
            ),
            (
                "1 kHz task, calibration and identification",
                r.tick_identify_cycles_est,
            ),
            ("sliding torque observer update", r.sliding_cycles_est),
            ("flux observer + PLL update", r.flux_cycles_est),
            ("FOC current loop + SVPWM", r.foc_svpwm_cycles_est),
        ] {
            t.add_row([what.to_string(), c.to_string()]);
        }
        outln!(out, "{t}");
        outln!(
            out,
            "sliding-primary step: {} instructions",
            r.step_instructions
        );
        outln!(
            out,
            "board firmware: flash {} bytes, static RAM {} bytes, control path in CCM SRAM {} bytes",
            r.flash_bytes,
            r.ram_bytes,
            r.ramfunc_bytes
        );
        outln!(
            out,
            "f64 soft-float routines linked: {:?}",
            r.f64_soft_float_symbols
        );
    }
    Ok(out)
}

#[derive(clap::Args)]
struct GainsArgs {
    #[command(flatten)]
    motor: MotorArg,
    /// Control rate (Hz).
    #[arg(long, default_value_t = 4000.0)]
    rate_hz: f64,
    /// The power stage's dead time (µs) the drive compensates (default: the B-G431B-ESC1's
    /// 0.5).
    #[arg(long)]
    dead_time_us: Option<f64>,
    /// The power stage's PWM frequency (Hz) (default: the B-G431B-ESC1's 20000).
    #[arg(long)]
    pwm_hz: Option<f64>,
    /// Print JSON: `{"motor", "values": [{"name", "value", "unit", "formula"}], "warnings":
    /// [{"field", "value", "limit", "what"}]}`.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct GainRow {
    name: &'static str,
    value: f64,
    unit: &'static str,
    formula: String,
}

#[derive(serde::Serialize)]
struct GainWarning {
    field: &'static str,
    value: f64,
    limit: f64,
    what: &'static str,
}

/// `v` to six significant digits, in exponent form outside 10⁻³..10⁷.
fn significant(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e7).contains(&a) {
        return format!("{v:.5e}");
    }
    let digits = if a == 0.0 {
        0
    } else {
        a.log10().floor() as i32
    };
    format!("{v:.*}", (5 - digits).max(0) as usize)
}

/// `x` as a multiple of `of`, named: "0.1 × rated speed".
fn share(x: f32, of: f32, name: &str) -> String {
    let ratio = format!("{:.3}", x / of);
    format!(
        "{} × {name}",
        ratio.trim_end_matches('0').trim_end_matches('.')
    )
}

/// `gains`: what `DriveConfig::derived` reports for the motor, as a table or JSON, and its
/// warnings.
fn gains(args: GainsArgs) -> anyhow::Result<String> {
    use pmsm_sensorless::drive::DriveConfig;
    let (name, m) = args.motor.resolve()?;
    let mut cfg = DriveConfig::new(&m);
    cfg.rate_hz = args.rate_hz as f32;
    if let Some(us) = args.dead_time_us {
        cfg.power_stage.dead_time_s = (us * 1e-6) as f32;
    }
    if let Some(hz) = args.pwm_hz {
        cfg.power_stage.pwm_hz = hz as f32;
    }
    let ps = cfg.power_stage;
    let d = cfg.derived().map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let p = m.params;
    let r = m.ratings;
    let wc = format!("ω_c = 2π·{} Hz", d.current_bandwidth_hz);
    let ws = format!("ω_s = 2π·{} Hz", d.speed_bandwidth_hz);
    let kt = format!("N ψ_f = {}·{} N·m/A", p.pole_pairs, p.flux_wb);
    let rows: Vec<(&'static str, f32, &'static str, String)> = vec![
        (
            "current PI kp",
            d.foc.current_kp,
            "V/A",
            format!("L ω_c; L = {} H, {wc}", p.l_h),
        ),
        (
            "current PI ki",
            d.foc.current_ki,
            "V/(A·s)",
            format!("R ω_c; R = {} Ω, {wc}", p.r_ohm),
        ),
        (
            "speed PI kp",
            d.foc.speed_kp,
            "A·s/rad",
            format!("J ω_s/(N ψ_f); J = {} kg·m², {ws}, {kt}", p.j_kgm2),
        ),
        (
            "speed PI ki",
            d.foc.speed_ki,
            "A/rad",
            format!("kp ω_s/4; {ws}"),
        ),
        (
            "K_s",
            d.ks_a_per_s,
            "A/s",
            "the paper's setting, Horng & Chin Sec 5".into(),
        ),
        (
            "ε",
            d.epsilon_a,
            "A",
            "boundary layer, Horng & Chin Sec 5".into(),
        ),
        (
            "(K_s,max)_T",
            d.ks_max_t_a_per_s,
            "A/s",
            format!("ε(2/T − R/L); T = 1/{} s", args.rate_hz),
        ),
        (
            "(K_s,max)_E2 at rated speed",
            d.ks_max_e2_rated_a_per_s,
            "A/s",
            format!("(√2 K N ω − R ε)/L; {} rpm", r.speed_rpm),
        ),
        (
            "(K_s,max)_E2 at hand-over",
            d.ks_max_e2_handover_a_per_s,
            "A/s",
            format!("(√2 K N ω − R ε)/L; {} rpm", d.handover_rpm),
        ),
        (
            "K_s = (K_s,max)_E2 at",
            d.ks_e2_speed_rpm,
            "rpm",
            "(K_s L + R ε)/(√2 K N)".into(),
        ),
        (
            "γ",
            d.gamma,
            "1/(Wb²·s)",
            share(
                d.gamma,
                d.gamma_max_discrete.min(d.gamma_max_single_equilibrium),
                "the smaller limit below (Ortega eq (9))",
            ),
        ),
        (
            "γ_max, discrete step",
            d.gamma_max_discrete,
            "1/(Wb²·s)",
            format!("2/(Φ² T); Φ = {} Wb", p.flux_wb),
        ),
        (
            "γ_max, one equilibrium",
            d.gamma_max_single_equilibrium,
            "1/(Wb²·s)",
            format!(
                "4 n_P |ω|/Φ² at hand-back {} rpm (Proposition 4)",
                d.handback_rpm
            ),
        ),
        (
            "PLL Kp",
            d.pll_kp,
            "1/s",
            format!(
                "2ζω_n; ω_n = 2π·{} Hz, ζ = {}",
                d.pll_bandwidth_hz, d.pll_damping
            ),
        ),
        ("PLL Ki", d.pll_ki, "1/s²", "ω_n²".into()),
        (
            "hand-over speed",
            d.handover_rpm,
            "rpm",
            share(d.handover_rpm, r.speed_rpm, "rated speed"),
        ),
        (
            "hand-back speed",
            d.handback_rpm,
            "rpm",
            share(d.handback_rpm, r.speed_rpm, "rated speed"),
        ),
        (
            "speed the lowest bus drives",
            d.bus_limited_rpm,
            "rpm",
            format!(
                "(bus_min_v/√3)/(N ψ_f); bus_min_v = {} V",
                cfg.limits.bus_min_v
            ),
        ),
        (
            "rated-torque current",
            d.rated_torque_current_a,
            "A",
            format!("τ/(N ψ_f); τ = {} N·m, {kt}", r.torque_nm),
        ),
        (
            "current command limit i_max",
            d.i_max_a,
            "A",
            share(d.i_max_a, d.rated_torque_current_a, "rated-torque current"),
        ),
        (
            "current trip",
            d.i_trip_a,
            "A",
            share(d.i_trip_a, d.i_max_a, "i_max"),
        ),
        (
            "sensing range",
            d.i_sense_max_a,
            "A",
            share(d.i_sense_max_a, d.i_trip_a, "trip"),
        ),
        (
            "align current",
            d.align_current_a,
            "A",
            share(
                d.align_current_a,
                d.rated_torque_current_a,
                "rated-torque current",
            ),
        ),
        (
            "open-loop current",
            d.open_loop_current_a,
            "A",
            share(
                d.open_loop_current_a,
                d.rated_torque_current_a,
                "rated-torque current",
            ),
        ),
        (
            "dead-time voltage",
            d.dead_time_voltage_v,
            "V",
            format!(
                "t_d f_pwm V_bus per phase, compensated by the current's sign; t_d = {} ns, \
                 f_pwm = {} Hz, bus_v = {} V",
                // To the picosecond: the f32 setting read back in f64 is 499.99998 ns.
                pmsm_host_sim::number((f64::from(ps.dead_time_s) * 1e12).round() / 1e3),
                ps.pwm_hz,
                r.bus_v
            ),
        ),
        (
            "dead-time sign band",
            ps.dead_time_band_a,
            "A",
            share(
                ps.dead_time_band_a,
                d.rated_torque_current_a,
                "rated-torque current",
            ),
        ),
        (
            "largest phase voltage",
            d.v_max_v,
            "V",
            format!("(1 − 2 t_d f_pwm) bus_v/√3; bus_v = {} V", r.bus_v),
        ),
        (
            "voltage of rated torque at rated speed",
            d.v_rated_point_v,
            "V",
            "|(R i, −ω_e L i) + (0, ω_e ψ_f)|, dq".into(),
        ),
        (
            "rated torque up to",
            d.rated_torque_speed_rpm,
            "rpm",
            "where that voltage reaches the largest phase voltage".into(),
        ),
    ];
    let rows: Vec<GainRow> = rows
        .into_iter()
        .map(|(name, value, unit, formula)| GainRow {
            name,
            value: f64::from(value),
            unit,
            formula,
        })
        .collect();
    let warnings: Vec<GainWarning> = d
        .warnings
        .iter()
        .flatten()
        .map(|w| GainWarning {
            field: w.field,
            value: f64::from(w.value),
            limit: f64::from(w.limit),
            what: w.what,
        })
        .collect();
    let mut out = String::new();
    if args.json {
        let v = serde_json::json!({ "motor": name, "values": rows, "warnings": warnings });
        outln!(out, "{v}");
        return Ok(out);
    }
    let mut t = table(&["", "value", "unit", "formula; inputs"], &[1]);
    for row in &rows {
        t.add_row([
            row.name.to_string(),
            significant(row.value),
            row.unit.to_string(),
            row.formula.clone(),
        ]);
    }
    outln!(out, "{name} at {} Hz", args.rate_hz);
    outln!(out, "{t}");
    for w in &warnings {
        outln!(
            out,
            "warning: {} = {}: limit {}: {}",
            w.field,
            significant(w.value),
            significant(w.limit),
            w.what
        );
    }
    Ok(out)
}

#[derive(clap::Args)]
struct GammaArgs {
    #[command(flatten)]
    motor: MotorArg,
    /// Observer update rate (Hz).
    #[arg(long)]
    rate_hz: f64,
    /// Lowest operating speed (rpm).
    #[arg(long)]
    min_speed_rpm: f64,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(serde::Serialize)]
struct GammaReport {
    gamma_max_discrete: f64,
    gamma_max_single_equilibrium: f64,
    gamma_recommended: f64,
}

fn gamma(args: GammaArgs) -> anyhow::Result<String> {
    use pmsm_sensorless::observer::flux::{self, FluxConfig};
    let (name, motor) = args.motor.resolve()?;
    anyhow::ensure!(
        args.rate_hz.is_finite() && args.rate_hz > 0.0,
        "--rate-hz must be a finite number > 0"
    );
    anyhow::ensure!(
        args.min_speed_rpm.is_finite() && args.min_speed_rpm >= 0.0,
        "--min-speed-rpm must be a finite number >= 0"
    );
    let p = motor.params;
    let omega = (args.min_speed_rpm * pmsm_host_sim::RAD_S_PER_RPM) as f32;
    let rate = args.rate_hz as f32;
    let report = GammaReport {
        gamma_max_discrete: flux::gamma_max_discrete(p.flux_wb, rate) as f64,
        gamma_max_single_equilibrium: flux::gamma_max_single_equilibrium(p.flux_wb, p.n(), omega)
            as f64,
        // The observer's default, from the same functions.
        gamma_recommended: FluxConfig::new(p, rate, args.min_speed_rpm as f32).gamma as f64,
    };
    let mut out = String::new();
    if args.json {
        outln!(out, "{}", serde_json::to_string(&report)?);
    } else {
        outln!(
            out,
            "{} at {} Hz, lowest speed {} rpm (Φ = {} Wb, n_P = {})",
            name,
            args.rate_hz,
            args.min_speed_rpm,
            p.flux_wb,
            p.pole_pairs
        );
        let mut t = table(&["limit on γ", "1/(Wb²·s)"], &[1]);
        for (what, v) in [
            ("γ_max, discrete step (γΦ²T < 2)", report.gamma_max_discrete),
            (
                "γ_max, one equilibrium (γ < 4n_P|ω|/Φ²)",
                report.gamma_max_single_equilibrium,
            ),
            (
                "γ recommended (0.5 × the smaller)",
                report.gamma_recommended,
            ),
        ] {
            t.add_row([what.to_string(), format!("{v:.1}")]);
        }
        outln!(out, "{t}");
    }
    Ok(out)
}

/// `--motor NAME | --motor-file F` (default: the Sinano motor).
#[derive(clap::Args)]
struct MotorArg {
    /// Motor preset (see `pmsm-sim list`; default: the scenario's, else sinano).
    #[arg(long, conflicts_with = "motor_file")]
    motor: Option<String>,
    /// Motor TOML file (format: README, host-sim/motors/).
    #[arg(long, value_name = "FILE.toml")]
    motor_file: Option<PathBuf>,
}

impl MotorArg {
    /// The motor's name and the motor; without either flag, `default`.
    fn resolve_or(&self, default: motor::Motor) -> anyhow::Result<(String, motor::Motor)> {
        let m = match (&self.motor, &self.motor_file) {
            (_, Some(path)) => return motor_file::load(path),
            (Some(name), None) => preset(name)?,
            (None, None) => default,
        };
        Ok((m.name.to_string(), m))
    }

    /// As [`MotorArg::resolve_or`], the Sinano motor by default.
    fn resolve(&self) -> anyhow::Result<(String, motor::Motor)> {
        self.resolve_or(motor::HORNG_SINANO)
    }
}

fn preset(name: &str) -> anyhow::Result<motor::Motor> {
    motor::preset(name).ok_or_else(|| {
        let names: Vec<_> = motor::PRESETS.iter().map(|m| m.name).collect();
        anyhow::anyhow!("unknown motor '{name}' (known: {})", names.join(", "))
    })
}

#[derive(clap::Args)]
struct BoundsArgs {
    #[command(flatten)]
    motor: MotorArg,
    /// Speed (rpm, mechanical), not 0.
    #[arg(long, allow_negative_numbers = true)]
    speed_rpm: f64,
    /// Sample rate of the observer (Hz).
    #[arg(long)]
    rate_hz: f64,
    /// Load torque (N·m).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    load_nm: f64,
    /// sliding-torque (5 states, the paper's analysis) or sliding-velocity (4 states).
    #[arg(long, default_value = "sliding-torque")]
    observer: String,
    /// Also write the root locus over K_s (CSV and PNG) here.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print JSON.
    #[arg(long)]
    json: bool,
}

#[derive(clap::Args)]
struct RunArgs {
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
    /// Current-sensor noise, standard deviation per phase (A).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    noise_a: f64,
    /// Current-sensor noise in % of the motor's rated current (adds to --noise-a).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    noise_pct: f64,
    /// Current-sensor offsets per phase (A), `a,b,c`.
    #[arg(long, value_parser = parse_offsets, default_value = "0,0,0", allow_negative_numbers = true)]
    offset_a: [f64; 3],
    /// Current-sensor offsets per phase in % of the motor's rated current, `a,b,c` (add to
    /// --offset-a).
    #[arg(long, value_parser = parse_offsets, default_value = "0,0,0", allow_negative_numbers = true)]
    offset_pct: [f64; 3],
    /// ADC quantisation step of the current measurement (A) (0 = none).
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    adc_lsb_a: f64,
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Controller parameter factors, e.g. `r=1.2,l=0.9` (keys r, l, flux, j, b).
    #[arg(long, value_parser = parse_mismatch, default_value = "")]
    mismatch: Mismatch,
    /// Drive runs: the board idle this long before t = 0 (PWM off; the drive measures the
    /// current sensors' offsets from it, and the board takes them off its samples) (ms).
    #[arg(long, default_value_t = 0.0)]
    idle_ms: f64,
    /// The controller's motor parameters from this file (e.g. written by `identify --out`),
    /// the plant staying the --motor / --motor-file one (instead of --mismatch).
    #[arg(long, value_name = "FILE.toml", conflicts_with = "mismatch")]
    drive_motor_file: Option<PathBuf>,
    /// Inverter dead time (µs); its averaged error is sign(i)·t_dead·f_pwm·V_bus per phase.
    #[arg(long, default_value_t = 0.0, allow_negative_numbers = true)]
    dead_time_us: f64,
    /// PWM frequency (Hz) (default: the B-G431B-ESC1 firmware's).
    #[arg(long, default_value_t = 20_000.0, allow_negative_numbers = true)]
    pwm_hz: f64,
    /// The load's kind, replacing the scenario's `load_kind`: a brake opposes the motion,
    /// an active load is a signed torque (a hanging mass).
    #[arg(long, value_enum)]
    load_kind: Option<LoadKindArg>,
    /// Control (current-loop and observer) rate (Hz); the speed loop runs at a quarter of it.
    #[arg(long, default_value_t = 4000.0)]
    rate_hz: f64,
    /// Run on the encoder until this speed (rpm), then sensorless (a stand-in for a start-up
    /// sequence; default: sensorless from t = 0).
    #[arg(long)]
    sensorless_from_rpm: Option<f64>,
    /// Write run.csv and run.png into this directory (nothing is written without it).
    #[arg(long)]
    out: Option<PathBuf>,
    /// Print the JSON summary on stdout.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, clap::ValueEnum)]
enum LoadKindArg {
    Brake,
    Active,
}

fn parse_mismatch(s: &str) -> Result<Mismatch, String> {
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

fn list() -> anyhow::Result<String> {
    let table = |header: &[&str]| table(header, &[]);
    let mut scenarios = table(&["scenario (host-sim/scenarios/)", "what it does"]);
    for s in scenario::Spec::all_built_in()? {
        scenarios.add_row([s.name.as_str(), s.description()]);
    }
    let mut motors = table(&[
        "motor",
        "N",
        "R Ω",
        "L H",
        "ψ_f Wb",
        "J kg·m²",
        "B N·m·s/rad",
        "bus V",
        "rated",
    ]);
    for m in motor::PRESETS {
        let (p, r) = (m.params, m.ratings);
        motors.add_row([
            m.name.to_string(),
            p.pole_pairs.to_string(),
            p.r_ohm.to_string(),
            p.l_h.to_string(),
            p.flux_wb.to_string(),
            p.j_kgm2.to_string(),
            p.b_nms.to_string(),
            r.bus_v.to_string(),
            format!(
                "{} N·m, {} rpm, {} A",
                r.torque_nm, r.speed_rpm, r.current_a
            ),
        ]);
    }
    let mut observers = table(&["observer", "what it is"]);
    for o in ObserverKind::ALL {
        observers.add_row([o.name(), o.description()]);
    }
    Ok(format!("{scenarios}\n{motors}\n{observers}\n"))
}

/// What `run` simulates: the scenario on the chosen motor, with every flag applied and
/// checked (errors name the flag and the allowed values).
fn prepare(args: &RunArgs) -> anyhow::Result<SimConfig> {
    let spec = match (&args.scenario, &args.scenario_file) {
        (_, Some(path)) => scenario::Spec::load(path)?,
        (Some(name), None) => scenario::Spec::built_in(name)?,
        (None, None) => anyhow::bail!("give a scenario name or --scenario-file"),
    };
    let observer = ObserverKind::from_name(&args.observer)?;
    let (motor_name, m) = args.motor.resolve_or(spec.default_motor()?)?;
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
    let rated_a = f64::from(m.ratings.current_a);
    let mut cfg = SimConfig::new(sc, observer);
    if let Some(v) = args.bus_v {
        let max = 2.0 * m.ratings.bus_v;
        anyhow::ensure!(
            v.is_finite() && v > 0.0 && v <= f64::from(max),
            "--bus-v = {}: bus voltage allowed (0, {max}] V (2 x the motor's rated bus)",
            number(v)
        );
        cfg.board.bus_v = v;
    }
    if let Some(p) = args.bus_pct {
        anyhow::ensure!(
            p.is_finite() && p > 0.0 && p <= 200.0,
            "--bus-pct = {}: bus voltage allowed (0, 200] % of the motor's rated bus",
            number(p)
        );
        cfg.board.bus_v = 0.01 * p * rated_bus;
    }
    anyhow::ensure!(
        args.noise_pct.is_finite() && args.noise_pct >= 0.0,
        "--noise-pct = {}: must be a finite percentage >= 0",
        args.noise_pct
    );
    cfg.board.noise_sigma_a = args.noise_a + 0.01 * args.noise_pct * rated_a;
    cfg.board.offset_a =
        std::array::from_fn(|k| args.offset_a[k] + 0.01 * args.offset_pct[k] * rated_a);
    cfg.board.adc_lsb_a = args.adc_lsb_a;
    cfg.board.seed = args.seed;
    cfg.mismatch = args.mismatch;
    anyhow::ensure!(
        args.idle_ms.is_finite() && (0.0..=10_000.0).contains(&args.idle_ms),
        "--idle-ms = {}: allowed [0, 10000] ms",
        number(args.idle_ms)
    );
    cfg.board.idle_s = args.idle_ms * 1e-3;
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
    anyhow::ensure!(
        args.rate_hz.is_finite() && (1000.0..=100_000.0).contains(&args.rate_hz),
        "--rate-hz must be between 1000 and 100000"
    );
    cfg.rate_hz = args.rate_hz;
    // Keep the plant's sub-step at 10 µs or less.
    cfg.substeps = (1e5 / args.rate_hz).ceil() as usize;
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
    (cfg.board.pwm_hz, cfg.board.dead_time_s) = power_stage(args.pwm_hz, args.dead_time_us)?;
    Ok(cfg)
}

/// `--pwm-hz` and `--dead-time-us` checked: the PWM frequency \[Hz] and the dead time \[s].
fn power_stage(pwm_hz: f64, dead_time_us: f64) -> anyhow::Result<(f64, f64)> {
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
    Ok((pwm_hz, dead_time_us * 1e-6))
}

/// `run`: the text (or JSON) to print, and whether the run passed.
fn run(args: RunArgs) -> anyhow::Result<(String, bool)> {
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

fn bounds(args: BoundsArgs) -> anyhow::Result<String> {
    let (name, motor) = args.motor.resolve()?;
    let torque = match ObserverKind::from_name(&args.observer)? {
        ObserverKind::SlidingTorque => true,
        ObserverKind::SlidingVelocity => false,
        other => anyhow::bail!("bounds are for sliding observers, not '{}'", other.name()),
    };
    anyhow::ensure!(
        args.speed_rpm.is_finite() && args.speed_rpm != 0.0,
        "--speed-rpm must be a finite, non-zero number (the system is unobservable at 0)"
    );
    anyhow::ensure!(
        args.rate_hz.is_finite() && args.rate_hz > 0.0,
        "--rate-hz must be a finite number > 0"
    );
    anyhow::ensure!(
        args.load_nm.is_finite(),
        "--load-nm must be a finite number"
    );
    let omega = args.speed_rpm * pmsm_host_sim::RAD_S_PER_RPM;
    let op = pmsm_host_sim::analysis::bounds::OperatingPoint::paper(
        &motor.params,
        omega,
        args.load_nm,
        torque,
    );
    let report = pmsm_host_sim::analysis::bounds::report(&motor.params, &op, args.rate_hz);
    let mut out = String::new();
    if args.json {
        outln!(out, "{}", serde_json::to_string(&report)?);
    } else {
        outln!(
            out,
            "{} at {} rpm, {} N·m, {} observer, {} Hz",
            name,
            args.speed_rpm,
            args.load_nm,
            args.observer,
            args.rate_hz
        );
        let mut t = table(&["bound", "A/s"], &[1]);
        t.add_row([
            "(K_s,max)_E2".to_string(),
            format!("{:.2}", report.ks_max_e2),
        ]);
        t.add_row([
            "(K_s,max)_T".to_string(),
            report.ks_max_t.map_or_else(
                || {
                    format!(
                        "none stable up to {}",
                        pmsm_host_sim::analysis::bounds::KS_SCAN_MAX
                    )
                },
                |k| format!("{k:.2}"),
            ),
        ]);
        outln!(out, "{t}");
        let mut e = table(
            &["eigenvalue at (K_s,max)_T", "re 1/s", "im rad/s"],
            &[1, 2],
        );
        for (k, [re, im]) in report.eigenvalues_at_ks_max_t.iter().enumerate() {
            e.add_row([
                format!("λ{}", k + 1),
                format!("{re:.3}"),
                format!("{im:+.3}"),
            ]);
        }
        outln!(out, "{e}");
    }
    if let Some(dir) = &args.out {
        use pmsm_host_sim::analysis::bounds::{write_root_locus, Equilibrium};
        // The paper's Figs 2 and 3 run K_s from 0 to 8000 A/s.
        let ks_end = report.ks_max_t.unwrap_or(8000.0).max(8000.0);
        let mut which = vec![Equilibrium::First];
        if torque {
            which.push(Equilibrium::Second);
        }
        for eq in which {
            let (csv, png) = write_root_locus(&op, eq, ks_end, &[args.rate_hz], dir)?;
            if !args.json {
                outln!(out, "root locus: {} and {}", csv.display(), png.display());
            }
        }
    }
    Ok(out)
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                print!("{e}");
                return ExitCode::SUCCESS;
            }
            // clap's own message: what is wrong, the usage, and where to find help.
            eprint!("{e}");
            return ExitCode::from(2);
        }
    };
    let result = match cli.command {
        Command::List => list(),
        Command::Run(args) => match run(*args) {
            // A run that faults, loses lock or misses a window exits 3 after its output.
            Ok((text, false)) => {
                let _ = std::io::stdout().write_all(text.as_bytes());
                return ExitCode::from(3);
            }
            r => r.map(|(text, _)| text),
        },
        Command::Sweep(args) => match sweep(args) {
            // A sweep with a failed cell exits 1 after its output.
            Ok((text, false)) => {
                let _ = std::io::stdout().write_all(text.as_bytes());
                return ExitCode::FAILURE;
            }
            r => r.map(|(text, _)| text),
        },
        Command::Gains(args) => gains(args),
        Command::Bounds(args) => bounds(args),
        Command::Gamma(args) => gamma(args),
        Command::Cycles(args) => cycles(args),
        Command::Identify(args) => match identify(args) {
            // An identification that ends in its named error exits 3 after its output.
            Ok((text, false)) => {
                let _ = std::io::stdout().write_all(text.as_bytes());
                return ExitCode::from(3);
            }
            r => r.map(|(text, _)| text),
        },
    };
    match result {
        Ok(text) => {
            // A closed pipe (`pmsm-sim list | head -1`) is not an error worth a panic.
            let _ = std::io::stdout().write_all(text.as_bytes());
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("error: {}", format!("{e:#}").replace('\n', " "));
            ExitCode::FAILURE
        }
    }
}
