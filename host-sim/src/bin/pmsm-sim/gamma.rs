//! `pmsm-sim gamma`: the limits on the flux observer's gain γ (Ortega et al. eq (9),
//! Proposition 4) and the observer's default.

use crate::args::MotorArg;
use pmsm_host_sim::table;
use std::fmt::Write as _;

#[derive(clap::Args)]
pub struct GammaArgs {
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

/// `gamma`: the table (or JSON).
pub fn gamma(args: GammaArgs) -> anyhow::Result<String> {
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
        return Ok(out);
    }
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
    Ok(out)
}
