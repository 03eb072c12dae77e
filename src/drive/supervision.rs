//! Supervision, apart from control: the hand-over from open loop to sensorless control and the
//! sensorless health checks (observer loss, stall, hand-back), each once per slot cycle
//! (1 kHz) on the angles of one sample.

use crate::math::wrap_pi;
use crate::units::RPM_PER_RAD_S;
use core::hint::cold_path;

/// Supervision's thresholds, in the units and counts the checks use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// Hand-over is allowed above this |open-loop speed| \[rpm].
    pub(super) handover_rpm: f32,
    /// cos of the hand-over angle tolerance.
    pub(super) handover_cos: f32,
    /// Checks in agreement before the hand-over.
    pub(super) handover_checks: u32,
    /// Checks above the hand-over speed before a stall.
    pub(super) handover_timeout_checks: u32,
    /// Back to open loop below this |speed| and |reference| \[rpm].
    pub(super) handback_rpm: f32,
    /// Largest tolerated angle disagreement [rad, electrical].
    pub(super) max_disagreement: f32,
    /// Largest tolerated speed disagreement \[rpm].
    pub(super) max_speed_disagreement_rpm: f32,
    /// Checks of disagreement before an observer loss.
    pub(super) loss_checks: u32,
    /// Checks of collapsed speed before a stall.
    pub(super) stall_checks: u32,
    /// |i_q command| at or above this is the speed loop at its limit \[A].
    pub(super) i_limit_a: f32,
}

/// Both observers' estimates of the rotor, the angles of one sample [rad, electrical] and the
/// speeds now [rad/s, mechanical].
#[derive(Clone, Copy, Debug)]
pub(super) struct Views {
    pub(super) theta_primary: f32,
    pub(super) omega_primary: f32,
    pub(super) theta_monitor: f32,
    pub(super) omega_monitor: f32,
}

impl Views {
    /// |θ̂_primary − θ̂_monitor| wrapped to [0, π] [rad, electrical].
    pub(super) fn disagreement(&self) -> f32 {
        wrap_pi(self.theta_primary - self.theta_monitor).abs()
    }

    /// |ω̂_primary − ω̂_monitor| \[rpm].
    pub(super) fn speed_disagreement_rpm(&self) -> f32 {
        (self.omega_primary - self.omega_monitor).abs() * RPM_PER_RAD_S
    }
}

/// The hand-over's counts, kept by the open loop.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct HandOverCount {
    /// Consecutive checks in agreement.
    agree: u32,
    /// Checks since the ramp passed the hand-over speed.
    waiting: u32,
}

impl HandOverCount {
    /// No check yet.
    pub(super) const ZERO: Self = Self {
        agree: 0,
        waiting: 0,
    };
}

/// The health counts, kept by sensorless control.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct HealthCount {
    /// Consecutive checks with the observers in disagreement.
    disagree: u32,
    /// Consecutive checks with the speed collapsed.
    collapse: u32,
}

/// What the hand-over check found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum HandOver {
    /// Stay in open loop.
    Wait,
    /// Hand over to sensorless control.
    Go,
    /// No agreement within the time limit.
    Stall,
}

/// What the health check found.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Health {
    /// Carry on.
    Good,
    /// The observers disagree for too long.
    ObserverLoss,
    /// The speed collapsed at the current limit.
    Stall,
    /// Speed and reference are low: back to open loop.
    HandBack,
}

impl Settings {
    /// The hand-over check: above the hand-over speed, sensorless once the primary has
    /// followed θ_ol (`ol_cos` = cos(θ̂_primary − θ_ol), and the monitor agreed with it within
    /// half the sensorless health limits) for `handover_checks` checks in a row; a stall when
    /// that has not happened within `handover_timeout_checks`.
    #[inline(always)]
    pub(super) fn hand_over(
        &self,
        c: &mut HandOverCount,
        views: &Views,
        speed_ol_rpm: f32,
        ol_cos: f32,
    ) -> HandOver {
        let fast_enough = speed_ol_rpm.abs() >= self.handover_rpm;
        let agrees = ol_cos > self.handover_cos
            && views.disagreement() < 0.5 * self.max_disagreement
            && views.speed_disagreement_rpm() < 0.5 * self.max_speed_disagreement_rpm;
        c.agree = consecutive(c.agree, fast_enough && agrees);
        c.waiting = consecutive(c.waiting, fast_enough);
        if c.agree >= self.handover_checks {
            cold_path();
            return HandOver::Go;
        }
        if c.waiting >= self.handover_timeout_checks {
            cold_path();
            return HandOver::Stall;
        }
        HandOver::Wait
    }

    /// The sensorless health check: observer loss after `loss_checks` consecutive
    /// disagreements, a stall after `stall_checks` at the current limit below half the
    /// reference; the hand-back when speed and reference are both low. `speed_ref_rpm` the
    /// slewed reference, `i_q_ref_a` the speed loop's command.
    #[inline(always)]
    pub(super) fn health(
        &self,
        c: &mut HealthCount,
        views: &Views,
        speed_ref_rpm: f32,
        i_q_ref_a: f32,
    ) -> Health {
        let speed = views.omega_primary * RPM_PER_RAD_S;
        let disagree = views.disagreement() > self.max_disagreement
            || views.speed_disagreement_rpm() > self.max_speed_disagreement_rpm;
        c.disagree = consecutive(c.disagree, disagree);
        if c.disagree >= self.loss_checks {
            cold_path();
            return Health::ObserverLoss;
        }
        // Stall: the speed loop is at its current limit and the speed has fallen below half
        // the reference (the load is more than the motor can carry).
        let at_limit = i_q_ref_a.abs() >= self.i_limit_a;
        // Measured along the reference's direction: turning the wrong way counts too.
        let along = if speed_ref_rpm < 0.0 { -speed } else { speed };
        let collapsed = at_limit && along < 0.5 * speed_ref_rpm.abs();
        c.collapse = consecutive(c.collapse, collapsed);
        if c.collapse >= self.stall_checks {
            cold_path();
            return Health::Stall;
        }
        if speed_ref_rpm.abs() < self.handback_rpm && speed.abs() < self.handback_rpm {
            cold_path();
            return Health::HandBack;
        }
        Health::Good
    }
}

/// A count of consecutive checks in which a condition held: one more if it holds, else 0.
#[inline(always)]
fn consecutive(count: u32, holds: bool) -> u32 {
    if holds {
        count.saturating_add(1)
    } else {
        0
    }
}
