//! `pmsm-sim gains`: the rows of the drive's report (`Derived::rows`, every gain and limit
//! the drive derives for a motor, with its formula) and its warnings, with the inputs the
//! formulas name; as a table or JSON.

use crate::args::MotorArg;
use pmsm_host_sim::table;
use pmsm_sensorless::drive::{DerivedRow, DriveConfig};
use std::fmt::Write as _;

#[derive(clap::Args)]
pub struct GainsArgs {
    #[command(flatten)]
    motor: MotorArg,
    /// Control rate (Hz); default: the configuration's for the motor on the PWM
    /// (`pmsm_sensorless::rate`: 20 samples per electrical period at rated speed, a divisor
    /// of the PWM frequency and a multiple of 1 kHz, 4 kHz at least, within the CPU budget).
    #[arg(long)]
    rate_hz: Option<f64>,
    /// The power stage's dead time (µs) the drive compensates (default: the B-G431B-ESC1's
    /// 0.5).
    #[arg(long)]
    dead_time_us: Option<f64>,
    /// The power stage's PWM frequency (Hz) (default: the B-G431B-ESC1's 20000).
    #[arg(long)]
    pwm_hz: Option<f64>,
    /// Print JSON: `{"motor", "inputs": {name: value}, "values": [{"name", "value", "unit",
    /// "formula"}], "warnings": [{"field", "value", "limit", "what"}]}`.
    #[arg(long)]
    json: bool,
}

/// A symbol of the formulas, its value and its unit.
type Input = (&'static str, f32, &'static str);

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

/// The row's formula, and for a setting its share of what it is chosen against:
/// `start.handover_rpm = 0.1 × rated speed`.
fn formula(row: &DerivedRow) -> String {
    match row.of {
        Some((name, of)) => {
            let ratio = format!("{:.3}", row.value / of);
            let ratio = ratio.trim_end_matches('0').trim_end_matches('.');
            format!("{} = {ratio} × {name}", row.formula)
        }
        None => row.formula.to_string(),
    }
}

/// `gains`: the table (or JSON) and the warnings.
pub fn gains(args: GainsArgs) -> anyhow::Result<String> {
    let (name, m) = args.motor.resolve()?;
    let mut cfg = DriveConfig::new(&m);
    if let Some(us) = args.dead_time_us {
        cfg.power_stage.dead_time_s = (us * 1e-6) as f32;
    }
    if let Some(hz) = args.pwm_hz {
        cfg.power_stage.pwm_hz = hz as f32;
    }
    cfg.choose_rate();
    if let Some(hz) = args.rate_hz {
        cfg.rate_hz = hz as f32;
    }
    let d = cfg.derived().map_err(|e| anyhow::anyhow!("{name}: {e}"))?;
    let (p, r, ps) = (m.params, m.ratings, cfg.power_stage);
    // The symbols the formulas use, with their values, in three groups.
    let inputs: [(&str, Vec<Input>); 3] = [
        (
            "motor",
            vec![
                ("R", p.r_ohm, "Ω"),
                ("L", p.l_h, "H"),
                ("ψ_f = Φ = K", p.flux_wb, "Wb"),
                ("J", p.j_kgm2, "kg·m²"),
                ("N = n_P", p.pole_pairs as f32, ""),
                ("τ rated", r.torque_nm, "N·m"),
                ("rated speed", r.speed_rpm, "rpm"),
                ("bus_v", r.bus_v, "V"),
            ],
        ),
        (
            "loops",
            vec![
                ("1/T", cfg.rate_hz, "Hz"),
                ("ω_c/2π", d.current_bandwidth_hz, "Hz"),
                ("ω_s/2π", d.speed_bandwidth_hz, "Hz"),
                ("ω_n/2π (PLL)", d.pll_bandwidth_hz, "Hz"),
                ("ζ (PLL)", d.pll_damping, ""),
            ],
        ),
        (
            "board",
            vec![
                ("bus_min_v", cfg.limits.bus_min_v, "V"),
                // To the picosecond: the f32 setting read back is 499.99998 ns.
                (
                    "t_d",
                    ((f64::from(ps.dead_time_s) * 1e12).round() / 1e3) as f32,
                    "ns",
                ),
                ("f_pwm", ps.pwm_hz, "Hz"),
            ],
        ),
    ];
    let rows = d.rows(&cfg);
    let choice = cfg.rate_choice();
    let f_e = p.pole_pairs as f32 * r.speed_rpm / 60.0;
    let warnings: Vec<_> = d.warnings.iter().flatten().collect();
    let mut out = String::new();
    if args.json {
        let inputs: serde_json::Map<_, _> = inputs
            .iter()
            .flat_map(|(_, group)| group)
            .map(|(k, v, _)| (k.to_string(), serde_json::json!(f64::from(*v))))
            .collect();
        let values: Vec<_> = rows
            .iter()
            .map(|row| {
                serde_json::json!({"name": row.name, "value": f64::from(row.value),
                    "unit": row.unit, "formula": formula(row)})
            })
            .collect();
        let warnings: Vec<_> = warnings
            .iter()
            .map(|w| {
                serde_json::json!({"field": w.field, "value": f64::from(w.value),
                    "limit": f64::from(w.limit), "what": w.what})
            })
            .collect();
        let rate = serde_json::json!({"rate_hz": f64::from(cfg.rate_hz),
            "chosen_hz": f64::from(choice.rate_hz), "wanted_hz": f64::from(choice.wanted_hz),
            "f_e_rated_hz": f64::from(f_e),
            "samples_per_period": f64::from(cfg.rate_hz / f_e),
            "bound": choice.bound.map(|b| format!("{b:?}"))});
        let v = serde_json::json!({ "motor": name, "inputs": inputs, "values": values,
            "warnings": warnings, "rate": rate });
        outln!(out, "{v}");
        return Ok(out);
    }
    outln!(out, "{name} at {} Hz", cfg.rate_hz);
    outln!(
        out,
        "control rate: {} Hz, {:.1} samples per electrical period at rated speed (f_e = N n/60 = {} Hz); \
         the rule's: the smallest multiple of 1 kHz dividing f_pwm, from 4 kHz up, within the CPU \
         budget, at or above 20 f_e = {} Hz: {} Hz",
        cfg.rate_hz,
        cfg.rate_hz / f_e,
        significant(f_e.into()),
        significant(choice.wanted_hz.into()),
        choice.rate_hz
    );
    for (group, values) in &inputs {
        let values: Vec<String> = values
            .iter()
            .map(|(k, v, unit)| format!("{k} = {v} {unit}").trim_end().to_string())
            .collect();
        outln!(out, "{group}: {}", values.join(", "));
    }
    let mut t = table(&["", "value", "unit", "formula"], &[1]);
    for row in &rows {
        t.add_row([
            row.name.to_string(),
            significant(row.value.into()),
            row.unit.to_string(),
            formula(row),
        ]);
    }
    outln!(out, "{t}");
    for w in warnings {
        outln!(
            out,
            "warning: {} = {}: limit {}: {}",
            w.field,
            significant(w.value.into()),
            significant(w.limit.into()),
            w.what
        );
    }
    Ok(out)
}
