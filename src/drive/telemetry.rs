//! The log record ([`Telemetry`]), read from the drive's state at the log's rate, not built by
//! the control step.

use super::io::Telemetry;
use super::supervision::Views;
use super::{Drive, ModeState, StateOf};
use crate::frames::SinCos;
use crate::math::atan2;
use crate::observer::{Observer, ReadOut};
use crate::units::{DEG_PER_RAD, RAD_S_PER_RPM, RPM_PER_RAD_S};

impl<P: Observer, M: Observer> Drive<P, M> {
    /// The log record of the state the last [`Drive::step`] left. Built on demand (at the log's
    /// rate, not the control rate); the observer values are those of the last step they ran,
    /// everything else is zero while the PWM is off, and the observers' fields are zero
    /// during the identification (they do not run). Every number is finite.
    // Not inlined: it belongs to the log path, not the control path.
    #[inline(never)]
    pub fn telemetry(&self, st: &StateOf<P, M>) -> Telemetry {
        let model = &st.obs.model;
        let off = Telemetry {
            mode: st.mode(),
            fault: st.fault(),
            r_ohm: model.r_ohm,
            flux_wb: model.flux_wb,
            ..Telemetry::default()
        };
        match &st.mode {
            ModeState::Idle
            | ModeState::Fault(_)
            | ModeState::Calibrate
            | ModeState::Identified => return off,
            ModeState::Identify => {
                // No observer runs and no motor model is set (`identify/`): the observers'
                // fields read 0 and there is no load estimate (an unset model's torque would
                // be 0/0, NaN); the measured currents in the stator's frame (θ = 0).
                let i_dq = st.i_ab_last.to_dq(SinCos::of(0.0));
                return Telemetry {
                    i_d: i_dq.d,
                    i_q: i_dq.q,
                    voltage_limited: st.last.limited(),
                    ..off
                };
            }
            ModeState::Catch(_)
            | ModeState::CatchZero(_)
            | ModeState::Align(_)
            | ModeState::OpenLoop(_)
            | ModeState::Sensorless(_) => {}
            #[cfg(feature = "injection")]
            ModeState::Inject => {}
        }
        // The observers run in these modes (the motor model set at the enable). The angles of
        // this very sample (the 1 kHz task reads them out once a millisecond), the residuals
        // of the last health check.
        let (mut ps, mut ms) = (st.obs.primary, st.obs.monitor);
        self.primary.read_out(&mut ps, ReadOut::Angle);
        self.monitor.read_out(&mut ms, ReadOut::Angle);
        let health = &st.obs.health;
        let [residual_primary, residual_monitor] = health.residuals();
        let v = Views {
            theta_primary: self.primary.theta_e(&ps),
            omega_primary: self.primary.omega_m(&ps),
            residual_primary,
            min_speed_primary: self.primary.min_speed_m(),
            theta_monitor: self.monitor.theta_e(&ms),
            omega_monitor: self.monitor.omega_m(&ms),
            residual_monitor,
            min_speed_monitor: self.monitor.min_speed_m(),
        };
        let driving = health.driving;
        let (theta_d, omega_d) = (v.theta(driving), v.omega(driving));
        let (theta, omega_m, speed_ref_rpm) = match &st.mode {
            // Returned above.
            ModeState::Idle
            | ModeState::Fault(_)
            | ModeState::Calibrate
            | ModeState::Identify
            | ModeState::Identified => return off,
            ModeState::Align(_) => (0.0, 0.0, 0.0),
            ModeState::Catch(_) | ModeState::CatchZero(_) => (theta_d, omega_d, 0.0),
            ModeState::OpenLoop(ol) => {
                let f = ol.frame();
                let speed = ol.speed_rpm();
                (atan2(f.sin, f.cos), speed * RAD_S_PER_RPM, speed)
            }
            ModeState::Sensorless(s) => (theta_d, omega_d, s.speed_ref_rpm()),
            // The injection's estimate (`inject.rs`).
            #[cfg(feature = "injection")]
            ModeState::Inject => {
                let (theta, omega_e) = st.inject.estimate();
                (theta, omega_e / self.adaptation.pole_pairs, 0.0)
            }
        };
        let i_dq = st.i_ab_last.to_dq(SinCos::of(theta));
        Telemetry {
            speed_ref_rpm,
            speed_rpm: omega_m * RPM_PER_RAD_S,
            theta_e_primary: v.theta_primary,
            theta_e_monitor: v.theta_monitor,
            theta_e_control: theta,
            i_d: i_dq.d,
            i_q: i_dq.q,
            load_nm: self
                .primary
                .load_nm(&ps)
                .map(|t| model.torque_from_observer(t)),
            voltage_limited: st.last.limited(),
            driving,
            residual_primary,
            residual_monitor,
            disagreement_deg: v.disagreement() * DEG_PER_RAD,
            speed_disagreement_rpm: v.speed_disagreement_rpm(),
            ..off
        }
    }

    /// Derated by the bus (`derating.rs`): in sensorless control with the field weakening
    /// acting, the current at its limit and the speed short of its reference (not in
    /// [`Telemetry`], which stays a small record: a log asks for it beside).
    pub fn derated(&self, st: &StateOf<P, M>) -> bool {
        match &st.mode {
            ModeState::Sensorless(s) => {
                let mut ps = st.obs.primary;
                self.primary.read_out(&mut ps, ReadOut::Angle);
                let mut ms = st.obs.monitor;
                self.monitor.read_out(&mut ms, ReadOut::Angle);
                let omega_m = match st.obs.health.driving {
                    super::Role::Primary => self.primary.omega_m(&ps),
                    super::Role::Monitor => self.monitor.omega_m(&ms),
                };
                self.sensorless.derated(s, omega_m)
            }
            _ => false,
        }
    }
}
