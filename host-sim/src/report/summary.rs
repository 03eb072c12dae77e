//! Metrics over a run's windows, the verdict, and the JSON summary of `pmsm-sim run --json`.
//!
//! The verdict is honest: a run fails on any fault the scenario does not expect (or when the
//! fault it expects does not come), on loss of lock anywhere while the controller runs on an
//! observer (|θ̂_e − θ_e| > 90° electrical: a positive i_q then brakes instead of driving), and
//! on a window whose mean speed error is beyond the scenario's tolerance of
//! max(|command|, 5 % of rated speed).

use crate::names::fault_name;
use crate::sim::{Row, Run};
use indexmap::IndexMap;
use pmsm_sensorless::drive::{DriveConfig, Fault, Mode, Reason};
use serde::Serialize;

/// Angle error beyond which the controller's `i_q` no longer produces torque in the intended
/// direction: a run that sees it while sensorless has lost lock [deg, electrical].
pub const LOST_LOCK_DEG_E: f64 = 90.0;

/// The speed below which a window's speed error is judged against this fraction of rated
/// speed instead of its command.
pub const SPEED_ERROR_FLOOR: f64 = 0.05;

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
    /// Derated by the bus (issue #26): the drive reported itself derated through most of the
    /// window, and the window is scored against the speed up to which the window's load
    /// torque fits the bus \[rpm] (`DriveConfig::torque_speed_limit_rpm` of the plant's motor
    /// on the window's mean bus), where that is below the command. Absent otherwise.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub derated_to_rpm: Option<f64>,
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
    /// The verdict: no unexpected fault, no loss of lock, every window within tolerance.
    pub pass: bool,
    /// Why the run failed, one line each (empty when it passed).
    pub reasons: Vec<String>,
    /// `|θ̂_e − θ_e| > 90°` electrical while sensorless, anywhere in the run.
    pub lost_lock: bool,
    /// When lock was first lost \[s].
    pub lost_lock_at_s: Option<f64>,
    /// The largest window mean speed error, in % of max(|command|, 5 % of rated speed).
    pub worst_speed_err_pct: Option<f64>,
    /// The largest `|θ̂_e − θ_e|` in the windows [deg, electrical].
    pub theta_err_max_deg_e: Option<f64>,
    /// Simulated time over wall-clock time.
    pub real_time_factor: f64,
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
    /// Drive scenarios: the drive's adapted motor model at the end of the run.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub adapted: Option<Adapted>,
    /// Runs on a DC link: the highest bus voltage, idle time included \[V] (absent on a
    /// stiff bus).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bus_peak_v: Option<f64>,
}

/// The drive's adapted motor model (`Telemetry::r_ohm`, `flux_wb`) against the plant's.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Adapted {
    /// Stator resistance \[Ω].
    pub r_ohm: f64,
    /// Flux linkage \[Wb].
    pub flux_wb: f64,
    /// `100 (R̂ − R)/R` \[%] against the plant's.
    pub r_err_pct: f64,
    /// `100 (ψ̂ − ψ)/ψ` \[%].
    pub flux_err_pct: f64,
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
        derated_to_rpm: None,
    })
}

/// The speed \[rpm] the bus holds the window's load at, when the drive reported itself
/// derated through at least half of the window's rows and that speed is below the command's:
/// the plant's motor and the board's limits, the window's mean load torque plus the plant's
/// friction at the window's speed, on the window's mean bus.
fn derated_reference(run: &Run, m: &WindowMetrics) -> Option<f64> {
    let w: Vec<&Row> = run
        .rows
        .iter()
        .filter(|r| r.t >= m.t0 && r.t < m.t1)
        .collect();
    let derated = w
        .iter()
        .filter(|r| r.health.is_some_and(|h| h.derated))
        .count();
    if w.is_empty() || 2 * derated < w.len() {
        return None;
    }
    let n = w.len() as f64;
    let motor = run.config.scenario.motor;
    let speed_rpm = w.iter().map(|r| r.speed_rpm.abs()).sum::<f64>() / n;
    let friction_nm = f64::from(motor.params.b_nms) * speed_rpm * crate::RAD_S_PER_RPM;
    let load_nm = (w.iter().map(|r| r.load_nm).sum::<f64>() / n).abs() + friction_nm;
    let bus_v = w.iter().map(|r| r.v_bus).sum::<f64>() / n;
    let mut cfg = DriveConfig::new(&motor);
    run.config.board.configure_drive(&mut cfg);
    let limit = f64::from(cfg.torque_speed_limit_rpm(load_nm as f32, bus_v as f32));
    (limit < m.speed_cmd_mean_rpm.abs()).then_some(limit)
}

impl Summary {
    /// Summarises a finished run and gives its verdict.
    pub fn of(run: &Run) -> Self {
        let sc = &run.config.scenario;
        let mut reasons = fault_reasons(run);
        let lost = lost_lock(run);
        if let Some(r) = lost {
            reasons.push(format!(
                "lost lock at t = {:.4} s: |θ̂_e − θ_e| = {:.1}° electrical while sensorless",
                r.t,
                r.theta_err_deg().abs()
            ));
        }
        let windows = Windows::of(run, &mut reasons);
        let sim_s = run.rows.len() as f64 / run.config.rate_hz;
        let sensorless = run.rows.iter().filter(|r| r.mode == Some(Mode::Sensorless));
        Summary {
            scenario: sc.name.to_string(),
            motor: sc.motor_name.clone(),
            observer: run.config.observer.name().to_string(),
            rate_hz: run.config.rate_hz,
            pass: reasons.is_empty(),
            reasons,
            lost_lock: lost.is_some(),
            lost_lock_at_s: lost.map(|r| r.t),
            worst_speed_err_pct: windows.worst_pct,
            theta_err_max_deg_e: windows.theta_max,
            real_time_factor: sim_s / run.wall_s,
            fault: run.fault.clone(),
            windows: windows.metrics,
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
            adapted: adapted(run),
            bus_peak_v: run.plant.supply.link().map(|l| l.v_peak),
        }
    }

    /// The metrics of window `name`, if the run reached it.
    pub fn window(&self, name: &str) -> Option<&WindowMetrics> {
        self.windows.get(name)?.as_ref()
    }
}

/// The verdict on faults: the drive's unless the scenario expects it, the expected one that
/// did not come, or the plant's state leaving the finite numbers.
fn fault_reasons(run: &Run) -> Vec<String> {
    let mut reasons = Vec::new();
    let expected = run
        .config
        .scenario
        .drive
        .as_ref()
        .and_then(|d| d.expect_fault);
    let fault_time = |f: Fault| {
        run.transitions
            .iter()
            .find(|(_, tr)| tr.reason == Reason::Fault(f))
            .map_or(f64::NAN, |(t, _)| *t)
    };
    match (run.drive_fault, expected) {
        (Some(f), Some(e)) if f == e => {}
        (Some(f), e) => reasons.push(format!(
            "fault {} at t = {:.4} s{}",
            fault_name(f),
            fault_time(f),
            e.map(|e| format!(" (expected {})", fault_name(e)))
                .unwrap_or_default()
        )),
        (None, Some(e)) => reasons.push(format!(
            "the expected fault {} did not happen",
            fault_name(e)
        )),
        (None, None) => {}
    }
    if run.drive_fault.is_none() {
        if let Some(f) = &run.fault {
            reasons.push(f.clone());
        }
    }
    reasons
}

/// The first row that lost lock while sensorless; in a run whose expected fault came, what
/// follows its injected cause (a blocked shaft: from the start) is that fault's business.
fn lost_lock(run: &Run) -> Option<&Row> {
    let sc = &run.config.scenario;
    let expected = sc.drive.as_ref().and_then(|d| d.expect_fault);
    let cause_from_start = if sc.locked_rotor { 0.0 } else { f64::INFINITY };
    let lock_until = match (expected, run.drive_fault) {
        (Some(e), Some(f)) if e == f => sc
            .drive
            .as_ref()
            .and_then(|d| d.injection)
            .map_or(cause_from_start, |i| i.t()),
        _ => f64::INFINITY,
    };
    run.rows.iter().find(|r| {
        let e = r.theta_err_deg().abs();
        r.sensorless && r.t < lock_until && (e.is_nan() || e > LOST_LOCK_DEG_E)
    })
}

/// The scenario's windows: each one's metrics, the worst speed error and angle error.
struct Windows {
    metrics: IndexMap<String, Option<WindowMetrics>>,
    worst_pct: Option<f64>,
    theta_max: Option<f64>,
}

impl Windows {
    /// The windows of `run`; a window beyond the speed tolerance, or not reached, adds its
    /// reason.
    fn of(run: &Run, reasons: &mut Vec<String>) -> Self {
        let sc = &run.config.scenario;
        let rated_rpm = f64::from(sc.motor.ratings.speed_rpm);
        let mut windows = IndexMap::new();
        let (mut worst_pct, mut theta_max) = (None::<f64>, None::<f64>);
        for w in &sc.windows {
            let mut m = window_metrics(&run.rows, w.t0, w.t1);
            if let Some(m) = &mut m {
                m.derated_to_rpm = derated_reference(run, m);
            }
            match &m {
                Some(m) => {
                    // Against the command, or the speed the bus holds the load at (derated).
                    let (reference, err) = match m.derated_to_rpm {
                        Some(limit) => {
                            let cmd = m.speed_cmd_mean_rpm;
                            let speed_along_cmd = (cmd + m.speed_err_mean_rpm) * cmd.signum();
                            (limit, speed_along_cmd - limit)
                        }
                        None => (m.speed_cmd_mean_rpm.abs(), m.speed_err_mean_rpm),
                    };
                    let scale = reference.max(SPEED_ERROR_FLOOR * rated_rpm);
                    let pct = 100.0 * err.abs() / scale;
                    // NaN propagates: a window of non-finite speeds is the worst.
                    worst_pct =
                        Some(
                            worst_pct.map_or(pct, |w| if pct.is_nan() { pct } else { w.max(pct) }),
                        );
                    theta_max = Some(theta_max.map_or(m.theta_err_max_abs_deg_e, |x| {
                        x.max(m.theta_err_max_abs_deg_e)
                    }));
                    // NaN fails too.
                    let within = pct <= 100.0 * sc.speed_tolerance;
                    let derated = m.derated_to_rpm.map_or(String::new(), |x| {
                        format!(" (derated by the bus to {x:.1} rpm)")
                    });
                    if !within {
                        reasons.push(format!(
                            "window {}: mean speed error {:+.3} rpm is {:.2} % of {:.1} rpm (limit {} %){derated}",
                            w.name, err, pct, scale, 100.0 * sc.speed_tolerance
                        ));
                    }
                }
                None => reasons.push(format!("window {}: not reached", w.name)),
            }
            windows.insert(w.name.to_string(), m);
        }
        Self {
            metrics: windows,
            worst_pct,
            theta_max,
        }
    }
}

/// Drive runs: the adapted motor model at the end (the last row with an adapted resistance),
/// against the plant's at that row (after a plant injection's factors, `Injection::Plant`).
fn adapted(run: &Run) -> Option<Adapted> {
    let plant = &run.config.scenario.motor.params;
    let (t, h) = run
        .rows
        .iter()
        .rev()
        .filter_map(|r| r.health.map(|h| (r.t, h)))
        .find(|(_, h)| h.r_ohm > 0.0)?;
    let (r_factor, flux_factor) = run
        .config
        .scenario
        .drive
        .as_ref()
        .and_then(|d| d.injection)
        .and_then(|i| i.plant_factors_at(t))
        .unwrap_or((1.0, 1.0));
    let err = |x: f64, truth: f64| 100.0 * (x / truth - 1.0);
    Some(Adapted {
        r_ohm: h.r_ohm,
        flux_wb: h.flux_wb,
        r_err_pct: err(h.r_ohm, plant.r_ohm as f64 * r_factor),
        flux_err_pct: err(h.flux_wb, plant.flux_wb as f64 * flux_factor),
    })
}
