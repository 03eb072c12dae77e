//! Files written by `pmsm-sim run`: the CSV time series and the PNG plot.

use crate::plot::{plot_panels, Panel, Series};
use crate::sim::Run;
use anyhow::Context;
use std::path::{Path, PathBuf};

/// Column names of the CSV, with units.
pub const CSV_HEADER: [&str; 12] = [
    "t_s",
    "speed_cmd_rpm",
    "omega_m_rpm",
    "omega_m_hat_rpm",
    "theta_e_deg",
    "theta_e_hat_deg",
    "i_d_a",
    "i_q_a",
    "v_alpha_v",
    "v_beta_v",
    "load_nm",
    "load_hat_nm",
];

/// Writes the time series; `load_hat_nm` is empty for observers without a torque estimate.
pub fn write_csv(run: &Run, path: &Path) -> anyhow::Result<()> {
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    w.write_record(CSV_HEADER)?;
    for r in &run.rows {
        let load_hat = r.load_hat_nm.map(|x| format!("{x:.6}")).unwrap_or_default();
        w.write_record([
            format!("{:.6}", r.t),
            format!("{:.4}", r.speed_cmd_rpm),
            format!("{:.4}", r.speed_rpm),
            format!("{:.4}", r.speed_hat_rpm),
            format!("{:.4}", r.theta_e_deg),
            format!("{:.4}", r.theta_e_hat_deg),
            format!("{:.6}", r.i_d),
            format!("{:.6}", r.i_q),
            format!("{:.5}", r.v_alpha),
            format!("{:.5}", r.v_beta),
            format!("{:.6}", r.load_nm),
            load_hat,
        ])?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Writes the overview plot: speeds, angle error, dq currents, load torque.
pub fn write_plot(run: &Run, path: &Path) -> anyhow::Result<()> {
    let rows = &run.rows;
    let col = |f: &dyn Fn(&crate::sim::Row) -> f64| rows.iter().map(f).collect::<Vec<f64>>();
    let t = col(&|r| r.t);
    let cmd = col(&|r| r.speed_cmd_rpm);
    let speed = col(&|r| r.speed_rpm);
    let speed_hat = col(&|r| r.speed_hat_rpm);
    let theta_err = col(&|r| r.theta_err_deg());
    let i_d = col(&|r| r.i_d);
    let i_q = col(&|r| r.i_q);
    let load = col(&|r| r.load_nm);
    let load_hat = col(&|r| r.load_hat_nm.unwrap_or(f64::NAN));
    let mut torque_series = vec![Series {
        label: "load τ_L",
        x: &t,
        y: &load,
    }];
    if rows.iter().any(|r| r.load_hat_nm.is_some()) {
        torque_series.push(Series {
            label: "estimated τ_L",
            x: &t,
            y: &load_hat,
        });
    }
    let panels = [
        Panel {
            title: "Speed",
            y_label: "rpm",
            series: vec![
                Series {
                    label: "command",
                    x: &t,
                    y: &cmd,
                },
                Series {
                    label: "actual ω_m",
                    x: &t,
                    y: &speed,
                },
                Series {
                    label: "estimated ω_m",
                    x: &t,
                    y: &speed_hat,
                },
            ],
        },
        Panel {
            title: "Position error: estimated − true θ_e",
            y_label: "deg (electrical)",
            series: vec![Series {
                label: "θ_e error",
                x: &t,
                y: &theta_err,
            }],
        },
        Panel {
            title: "Stator current, true rotor frame",
            y_label: "A",
            series: vec![
                Series {
                    label: "i_d",
                    x: &t,
                    y: &i_d,
                },
                Series {
                    label: "i_q",
                    x: &t,
                    y: &i_q,
                },
            ],
        },
        Panel {
            title: "Load torque",
            y_label: "N·m",
            series: torque_series,
        },
    ];
    let sc = &run.config.scenario;
    let title = format!(
        "{} — motor {} — observer {}",
        sc.name,
        sc.motor_name,
        run.config.observer.name()
    );
    plot_panels(path, &title, "t [s]", &panels)
}

/// Writes `run.csv` and `run.png` into `dir` (created if needed); returns their paths.
pub fn write_all(run: &Run, dir: &Path) -> anyhow::Result<(PathBuf, PathBuf)> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let csv = dir.join("run.csv");
    let png = dir.join("run.png");
    write_csv(run, &csv)?;
    write_plot(run, &png)?;
    Ok((csv, png))
}
