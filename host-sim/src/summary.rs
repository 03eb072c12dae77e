//! Metrics over a run's windows and the JSON summary of `pmsm-sim run --json`.

use crate::sim::{Row, Run};
use indexmap::IndexMap;
use pmsm_sensorless::drive::{Mode, Reason};
use serde::Serialize;

/// Angle error beyond which the controller's `i_q` no longer produces torque in the intended
/// direction: a run whose metric windows see it has lost lock [deg, electrical].
pub const LOST_LOCK_DEG_E: f64 = 90.0;

/// Metrics of one window.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct WindowMetrics {
    /// Start \[s].
    pub t0: f64,
    /// End \[s].
    pub t1: f64,
    /// Mean speed command \[rpm].
    pub speed_cmd_mean_rpm: f64,
    /// Mean of `ω_m − command` \[rpm].
    pub speed_err_mean_rpm: f64,
    /// Largest `|ω_m − command|` \[rpm].
    pub speed_err_max_abs_rpm: f64,
    /// Mean of `θ̂_e − θ_e` wrapped to (−180°, 180°] [deg, electrical].
    pub theta_err_mean_deg_e: f64,
    /// Mean of `|θ̂_e − θ_e|` [deg, electrical].
    pub theta_err_mean_abs_deg_e: f64,
    /// Largest `|θ̂_e − θ_e|` [deg, electrical].
    pub theta_err_max_abs_deg_e: f64,
    /// Mean estimated load torque \[N·m], `null` without a torque estimate.
    pub torque_hat_mean_nm: Option<f64>,
    /// Largest K_s,min of Horng & Chin eq (28) \[A/s], `null` for non-sliding observers.
    pub ks_min_max: Option<f64>,
}

/// The summary object.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// Motor name.
    pub motor: String,
    /// Observer name.
    pub observer: String,
    /// Control rate \[Hz].
    pub rate_hz: f64,
    /// Some window saw `|θ̂_e − θ_e| > 90°` electrical.
    pub lost_lock: bool,
    /// Why the run stopped or faulted, if it did.
    pub fault: Option<String>,
    /// Metrics per window, in the scenario's order (`null` for a window the run never reached).
    pub windows: IndexMap<String, Option<WindowMetrics>>,
    /// Drive scenarios: steps from the fault's cause to PWM off (`null` without a fault).
    pub fault_step: Option<usize>,
    /// Drive scenarios: every mode change.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub transitions: Vec<TransitionRecord>,
    /// Drive scenarios: times of the hand-overs to sensorless \[s].
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub handovers_s: Vec<f64>,
    /// Drive scenarios: lowest |true speed| while sensorless \[rpm].
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lowest_sensorless_rpm: Option<f64>,
}

/// One mode change of the drive.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct TransitionRecord {
    /// Time \[s].
    pub t: f64,
    /// Mode before.
    pub from: String,
    /// Mode after.
    pub to: String,
    /// Why.
    pub reason: String,
}

/// Metrics of the rows with `t0 ≤ t < t1`; `None` if there are none.
pub fn window_metrics(rows: &[Row], t0: f64, t1: f64) -> Option<WindowMetrics> {
    let w: Vec<&Row> = rows.iter().filter(|r| r.t >= t0 && r.t < t1).collect();
    if w.is_empty() {
        return None;
    }
    let n = w.len() as f64;
    let mean = |f: &dyn Fn(&Row) -> f64| w.iter().map(|r| f(r)).sum::<f64>() / n;
    let max_abs = |f: &dyn Fn(&Row) -> f64| w.iter().map(|r| f(r).abs()).fold(0.0, f64::max);
    let torque_hat_mean_nm = if w.iter().all(|r| r.load_hat_nm.is_some()) {
        Some(mean(&|r| r.load_hat_nm.unwrap_or(f64::NAN)))
    } else {
        None
    };
    let ks_min_max = if w.iter().all(|r| r.ks_min.is_some()) {
        Some(max_abs(&|r| r.ks_min.unwrap_or(f64::NAN)))
    } else {
        None
    };
    Some(WindowMetrics {
        t0,
        t1,
        speed_cmd_mean_rpm: mean(&|r| r.speed_cmd_rpm),
        speed_err_mean_rpm: mean(&|r| r.speed_err_rpm()),
        speed_err_max_abs_rpm: max_abs(&|r| r.speed_err_rpm()),
        theta_err_mean_deg_e: mean(&|r| r.theta_err_deg()),
        theta_err_mean_abs_deg_e: mean(&|r| r.theta_err_deg().abs()),
        theta_err_max_abs_deg_e: max_abs(&|r| r.theta_err_deg()),
        torque_hat_mean_nm,
        ks_min_max,
    })
}

impl Summary {
    /// Summarises a finished run.
    pub fn of(run: &Run) -> Self {
        let sc = &run.config.scenario;
        let mut windows = IndexMap::new();
        let mut lost_lock = false;
        for w in &sc.windows {
            let m = window_metrics(&run.rows, w.t0, w.t1);
            if let Some(m) = &m {
                let e = m.theta_err_max_abs_deg_e;
                lost_lock |= e.is_nan() || e > LOST_LOCK_DEG_E;
            }
            windows.insert(w.name.to_string(), m);
        }
        let expected = (sc.duration_s * run.config.rate_hz).round() as usize;
        let stopped_early = run.rows.len() < expected;
        let sensorless = run.rows.iter().filter(|r| r.mode == Some(Mode::Sensorless));
        Summary {
            scenario: sc.name.to_string(),
            motor: sc.motor_name.clone(),
            observer: run.config.observer.name().to_string(),
            rate_hz: run.config.rate_hz,
            lost_lock: lost_lock || stopped_early,
            fault: run.fault.clone(),
            windows,
            fault_step: run.fault_step,
            transitions: run
                .transitions
                .iter()
                .map(|(t, tr)| TransitionRecord {
                    t: *t,
                    from: format!("{:?}", tr.from),
                    to: format!("{:?}", tr.to),
                    reason: format!("{:?}", tr.reason),
                })
                .collect(),
            handovers_s: run
                .transitions
                .iter()
                .filter(|(_, tr)| tr.reason == Reason::HandOver)
                .map(|(t, _)| *t)
                .collect(),
            lowest_sensorless_rpm: sensorless.map(|r| r.speed_rpm.abs()).reduce(f64::min),
        }
    }

    /// The metrics of window `name`, if the run reached it.
    pub fn window(&self, name: &str) -> Option<&WindowMetrics> {
        self.windows.get(name)?.as_ref()
    }
}
