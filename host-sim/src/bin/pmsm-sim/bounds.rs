//! `pmsm-sim bounds`: the sliding gain's bounds of Horng & Chin Sec 4 at an operating point,
//! the eigenvalues at (K_s,max)_T, and the root locus over K_s.

use crate::args::MotorArg;
use pmsm_host_sim::analysis::bounds::{self, Equilibrium, OperatingPoint};
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::table;
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct BoundsArgs {
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

/// `bounds`: the table (or JSON), and the root loci's files with `--out`.
pub fn bounds(args: BoundsArgs) -> anyhow::Result<String> {
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
    let op = OperatingPoint::paper(&motor.params, omega, args.load_nm, torque);
    let report = bounds::report(&motor.params, &op, args.rate_hz);
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
                || format!("none stable up to {}", bounds::KS_SCAN_MAX),
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
        // The paper's Figs 2 and 3 run K_s from 0 to 8000 A/s.
        let ks_end = report.ks_max_t.unwrap_or(8000.0).max(8000.0);
        let mut which = vec![Equilibrium::First];
        if torque {
            which.push(Equilibrium::Second);
        }
        for eq in which {
            let (csv, png) = bounds::write_root_locus(&op, eq, ks_end, &[args.rate_hz], dir)?;
            if !args.json {
                outln!(out, "root locus: {} and {}", csv.display(), png.display());
            }
        }
    }
    Ok(out)
}
