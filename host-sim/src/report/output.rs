//! Files written by `pmsm-sim run`: the CSV time series and the PNG plot (its panels, and the
//! drive's modes, transitions and faults marked on them).

use crate::names::fault_name;
use crate::plot::{plot_panels_marked, Band, Event, Marks, Panel, Series};
use crate::sim::Run;
use anyhow::Context;
use pmsm_sensorless::drive::{Mode, Reason};
use std::path::{Path, PathBuf};

/// Column names of the CSV, with units.
pub const CSV_HEADER: [&str; 24] = [
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
    "s_a_a",
    "ks_a_per_s",
    "ks_min_a_per_s",
    "mode",
    "theta_e_monitor_deg",
    "driving",
    "residual_primary",
    "residual_monitor",
    "r_hat_ohm",
    "flux_hat_wb",
    "voltage_limited",
    "transition",
];

/// The column a run on a DC link adds after [`CSV_HEADER`]: the bus voltage at the sample.
pub const CSV_BUS: &str = "v_bus_v";

/// Writes the time series; optional columns (`load_hat_nm`, the sliding observers'
/// `s_a_a`, `ks_a_per_s`, `ks_min_a_per_s`, the drive's `driving`, residuals and
/// `transition`) are empty when the run has no such value; a run on a DC link has the bus
/// voltage last ([`CSV_BUS`]).
pub fn write_csv(run: &Run, path: &Path) -> anyhow::Result<()> {
    let mut w =
        csv::Writer::from_path(path).with_context(|| format!("creating {}", path.display()))?;
    let link = run.config.board.dc_link.is_some();
    let mut header = CSV_HEADER.to_vec();
    if link {
        header.push(CSV_BUS);
    }
    w.write_record(&header)?;
    for r in &run.rows {
        let opt = |x: Option<f64>| x.map(|x| format!("{x:.6}")).unwrap_or_default();
        let mut record = vec![
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
            opt(r.load_hat_nm),
            opt(r.s_a),
            opt(r.ks),
            opt(r.ks_min),
            r.mode.map(|m| format!("{m:?}")).unwrap_or_default(),
            opt(r.theta_e_monitor_deg),
            r.health
                .map(|h| format!("{:?}", h.driving))
                .unwrap_or_default(),
            opt(r.health.map(|h| h.residual_primary)),
            opt(r.health.map(|h| h.residual_monitor)),
            opt(r.health.map(|h| h.r_ohm)),
            opt(r.health.map(|h| h.flux_wb)),
            r.health
                .map(|h| u8::from(h.voltage_limited).to_string())
                .unwrap_or_default(),
            r.transition
                .map(|t| format!("{:?}->{:?}: {:?}", t.from, t.to, t.reason))
                .unwrap_or_default(),
        ];
        if link {
            record.push(format!("{:.4}", r.v_bus));
        }
        w.write_record(&record)?;
    }
    w.flush()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// Writes the overview plot: speeds, angle error, dq currents, load torque; the drive's modes
/// shaded, its transitions and faults marked ([`marks`]).
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
    let monitor_err = col(&|r| {
        r.theta_e_monitor_deg
            .map_or(f64::NAN, |m| crate::sim::wrap_deg(m - r.theta_e_deg))
    });
    let mut angle_series = vec![Series {
        label: "θ_e error",
        x: &t,
        y: &theta_err,
    }];
    if rows.iter().any(|r| r.theta_e_monitor_deg.is_some()) {
        angle_series[0].label = "configured observer";
        angle_series.push(Series {
            label: "monitor observer",
            x: &t,
            y: &monitor_err,
        });
    }
    let ks = col(&|r| r.ks.unwrap_or(f64::NAN));
    let ks_min = col(&|r| r.ks_min.unwrap_or(f64::NAN));
    let s_a = col(&|r| r.s_a.unwrap_or(f64::NAN));
    let mut panels = vec![
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
            series: angle_series,
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
    if rows.iter().any(|r| r.ks_min.is_some()) {
        panels.push(Panel {
            title: "Lower bound K_s,min of eq (28) and K_s (Horng & Chin Figs 7, 8)",
            y_label: "A/s",
            series: vec![
                Series {
                    label: "K_s,min",
                    x: &t,
                    y: &ks_min,
                },
                Series {
                    label: "K_s",
                    x: &t,
                    y: &ks,
                },
            ],
        });
        panels.push(Panel {
            title: "Sliding surface S_a = î_a − i_a (Horng & Chin Figs 9, 10)",
            y_label: "A",
            series: vec![Series {
                label: "S_a",
                x: &t,
                y: &s_a,
            }],
        });
    }
    let sc = &run.config.scenario;
    let figures = if sc.figures.is_empty() {
        String::new()
    } else {
        format!(" ({})", sc.figures)
    };
    let title = format!(
        "{}{figures} — motor {} — observer {}",
        sc.name,
        sc.motor_name,
        run.config.observer.name()
    );
    plot_panels_marked(path, &title, "t [s]", &panels, &marks(run))
}

/// The mode's name and its colour in the plot (the same in every plot).
fn mode_mark(mode: Mode) -> (&'static str, usize) {
    match mode {
        Mode::Idle => ("Idle", 0),
        Mode::Catch => ("Catch", 1),
        Mode::Align => ("Align", 2),
        Mode::OpenLoop => ("OpenLoop", 3),
        Mode::Sensorless => ("Sensorless", 4),
        Mode::Fault => ("Fault", 5),
        Mode::Calibrate => ("Calibrate", 6),
        Mode::Identify => ("Identify", 7),
        Mode::Identified => ("Identified", 8),
    }
}

/// The run's marks: a band per stretch of one mode, an event per transition (named by its
/// reason; a fault by its name), the loss of lock and the run's own stop (a plant gone
/// non-finite), the last two in red as faults.
pub fn marks(run: &Run) -> Marks<'static> {
    let rows = &run.rows;
    let dt = 1.0 / run.config.rate_hz;
    let mut bands: Vec<Band<'static>> = Vec::new();
    for r in rows {
        let Some(mode) = r.mode else { continue };
        let (label, shade) = mode_mark(mode);
        match bands.last_mut() {
            Some(b) if b.label == label => b.x1 = r.t + dt,
            _ => bands.push(Band {
                x0: r.t,
                x1: r.t + dt,
                label,
                shade,
            }),
        }
    }
    let mut events: Vec<Event> = run
        .transitions
        .iter()
        .map(|(t, tr)| match tr.reason {
            Reason::Fault(f) => Event {
                x: *t,
                label: format!("fault: {}", fault_name(f)),
                fault: true,
            },
            reason => Event {
                x: *t,
                label: format!("{reason:?}"),
                fault: false,
            },
        })
        .collect();
    if let Some(t) = crate::report::summary::Summary::of(run).lost_lock_at_s {
        events.push(Event {
            x: t,
            label: "lost lock".into(),
            fault: true,
        });
    }
    if let (Some(why), None, Some(last)) = (&run.fault, run.drive_fault, rows.last()) {
        events.push(Event {
            x: last.t,
            label: why.clone(),
            fault: true,
        });
    }
    Marks { bands, events }
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
