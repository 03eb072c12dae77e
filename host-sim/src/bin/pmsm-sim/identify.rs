//! `pmsm-sim identify`: the drive measures the simulated motor on the simulated board (R, L,
//! flux linkage, J, B) from its pole pairs and ratings; the table or JSON, and the motor file.

use crate::args::{BoardArgs, MotorArg};
use pmsm_host_sim::{motor_file, number, table};
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct IdentifyArgs {
    /// The motor on the bench (the truth).
    #[command(flatten)]
    motor: MotorArg,
    /// DC bus voltage (V) (default: the motor's).
    #[arg(long)]
    bus_v: Option<f64>,
    /// The simulated board (the board's conditions unless --ideal; the identification
    /// measures the offsets itself, so --idle-ms is `run`'s only).
    #[command(flatten)]
    board: BoardArgs,
    /// The board's current sensing range (A) (default: twice the drive's trip level).
    #[arg(long)]
    sense_range_a: Option<f64>,
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
pub fn identify(args: IdentifyArgs) -> anyhow::Result<(String, bool)> {
    use pmsm_host_sim::identify as id;
    let (name, m) = args.motor.resolve()?;
    anyhow::ensure!(
        args.board.idle_ms.is_none(),
        "--idle-ms is for run: the identification measures the offsets itself"
    );
    let mut cfg = id::IdentifyRun::board_defaults(m);
    cfg.board = args.board.resolve(false, &m)?;
    if let Some(v) = args.bus_v {
        let max = 2.0 * f64::from(m.ratings.bus_v);
        anyhow::ensure!(
            v.is_finite() && v > 0.0 && v <= max,
            "--bus-v = {}: bus voltage allowed (0, {max}] V (2 x the motor's rated bus)",
            number(v)
        );
        cfg.board.bus_v = v;
    }
    cfg.board.sense_range_a = args.sense_range_a;
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
        outln!(out, "ERROR: {}", pmsm_host_sim::names::fault_name(f));
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
