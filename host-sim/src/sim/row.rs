//! One control period of a run's trace ([`Row`]), the drive's health figures in it, and the
//! angle wrapping the rows use.

use pmsm_sensorless::drive::{Mode, Role, Transition};
use std::f64::consts::PI;

/// One control period of the trace (values at the sample instant `t`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// Time \[s].
    pub t: f64,
    /// Speed command \[rpm].
    pub speed_cmd_rpm: f64,
    /// True speed \[rpm].
    pub speed_rpm: f64,
    /// Estimated speed \[rpm].
    pub speed_hat_rpm: f64,
    /// True electrical angle, wrapped to (−180°, 180°] \[deg].
    pub theta_e_deg: f64,
    /// Estimated electrical angle, wrapped \[deg].
    pub theta_e_hat_deg: f64,
    /// True-frame d current \[A].
    pub i_d: f64,
    /// True-frame q current \[A].
    pub i_q: f64,
    /// Applied α voltage over the following period \[V].
    pub v_alpha: f64,
    /// Applied β voltage \[V].
    pub v_beta: f64,
    /// Load torque \[N·m].
    pub load_nm: f64,
    /// The DC bus's voltage at the sample \[V].
    pub v_bus: f64,
    /// Estimated load torque \[N·m], if the observer has one.
    pub load_hat_nm: Option<f64>,
    /// Sliding observers: `S_a = î_a − i_a` \[A] (Horng Figs 9, 10).
    pub s_a: Option<f64>,
    /// Sliding observers: the sliding gain in use \[A/s].
    pub ks: Option<f64>,
    /// Sliding observers: the lower bound K_s,min of eq (28) from the true and estimated
    /// states \[A/s] (Horng Figs 7, 8).
    pub ks_min: Option<f64>,
    /// Drive scenarios: the drive's mode.
    pub mode: Option<Mode>,
    /// Drive scenarios: the monitor observer's angle [deg, electrical, wrapped].
    pub theta_e_monitor_deg: Option<f64>,
    /// The controller ran on its observer's estimate (the drive in `Sensorless`; a bare run
    /// after its hand-over from the encoder; never for the encoder itself).
    pub sensorless: bool,
    /// Drive runs: which observer drives, and each one's residual (`Observer::residual`).
    pub health: Option<RowHealth>,
    /// Drive runs: the transition this step made.
    pub transition: Option<Transition>,
}

/// The drive's health figures of one row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowHealth {
    /// Which observer drives.
    pub driving: Role,
    /// The primary's residual (1: the edge of lock).
    pub residual_primary: f64,
    /// The monitor's residual.
    pub residual_monitor: f64,
    /// The drive's adapted stator resistance \[Ω] (0 before the first enable).
    pub r_ohm: f64,
    /// The drive's adapted flux linkage \[Wb].
    pub flux_wb: f64,
    /// The current loop's voltage was at its limit in the last millisecond.
    pub voltage_limited: bool,
    /// The drive derated by the bus (`Telemetry::derated`).
    pub derated: bool,
    /// In the injection's start (`DriveState::injection`): whether it tracks with the
    /// polarity known (false in its lock and polarity test); `None` outside it.
    pub injection_tracking: Option<bool>,
}

impl Row {
    /// `θ̂_e − θ_e` wrapped to (−180°, 180°] \[deg].
    pub fn theta_err_deg(&self) -> f64 {
        wrap_deg(self.theta_e_hat_deg - self.theta_e_deg)
    }

    /// `ω_m − command` \[rpm].
    pub fn speed_err_rpm(&self) -> f64 {
        self.speed_rpm - self.speed_cmd_rpm
    }
}

/// Wraps `x` to (−period/2, period/2].
fn wrap(x: f64, period: f64) -> f64 {
    let y = x - period * (x / period).round();
    if y <= -0.5 * period {
        y + period
    } else {
        y
    }
}

/// Wraps an angle to (−180°, 180°].
pub fn wrap_deg(x: f64) -> f64 {
    wrap(x, 360.0)
}

/// Wraps an angle to (−π, π].
pub fn wrap_rad(x: f64) -> f64 {
    wrap(x, 2.0 * PI)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapping_is_half_open() {
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
        assert_eq!(wrap_deg(540.0), 180.0);
        assert!((wrap_deg(-190.0) - 170.0).abs() < 1e-12);
        assert!((wrap_rad(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_rad(-0.5) + 0.5).abs() < 1e-15);
    }
}
