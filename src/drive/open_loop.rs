//! Open loop (I/f start): a current of fixed magnitude along the d axis of a frame at angle
//! θ_ol whose frequency ramps; the rotor follows it, lagging by `asin(τ/(N ψ_f I_ol))`. The
//! frame is kept as sin/cos of θ_ol, turned by `N ω_ol T` each step (no trigonometry on the
//! step's path). Half-way to the hand-over speed the observers are restarted at θ_ol; above
//! it, supervision hands over to sensorless control once the primary follows θ_ol.

use super::schedule::Slot;
use super::sensorless::Sensorless;
use super::supervision::{HandOver, HandOverCount};
use super::{Drive, ModeState, ObserverStates, Outcome};
use crate::foc::{Reference, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::math::clamp;
use crate::observer::Observer;
use crate::units::{RAD_S_PER_RPM, RPM_PER_RAD_S};
use core::hint::cold_path;

/// Open loop's per-step coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// Magnitude of the I/f current \[A].
    pub(super) current_a: f32,
    /// N·T \[s]: θ_ol's advance per step per rad/s of ω_ol.
    pub(super) n_ts: f32,
    /// The hand-over speed \[rpm]: the observers restart at half of it.
    pub(super) handover_rpm: f32,
}

/// The state of [`Mode::OpenLoop`](super::Mode::OpenLoop).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct OpenLoop {
    /// sin/cos of θ_ol [rad, electrical]: turned by `step_rot` every step.
    frame: SinCos,
    /// sin/cos of θ_ol's advance per step, `N ω_ol T`, kept while the ramp holds (1 kHz).
    step_rot: SinCos,
    /// sin/cos of the output angle's lead over θ_ol at ω_ol (`Foc::output_rotation`).
    out_rot: SinCos,
    /// ω_ol [rpm, mechanical].
    speed_rpm: f32,
    /// cos(θ̂_primary − θ_ol) at the last [`Slot::AngleReadOut`] sample.
    ol_cos: f32,
    /// The hand-over's counts.
    hand_over: HandOverCount,
}

impl OpenLoop {
    /// At rest at θ_e = 0 (after the alignment).
    pub(super) const AT_REST: Self = Self {
        frame: SinCos::ZERO,
        step_rot: SinCos::ZERO,
        out_rot: SinCos::ZERO,
        speed_rpm: 0.0,
        ol_cos: 1.0,
        hand_over: HandOverCount::ZERO,
    };

    /// sin/cos of θ_ol.
    pub(super) fn frame(&self) -> SinCos {
        self.frame
    }

    /// ω_ol [rpm, mechanical].
    pub(super) fn speed_rpm(&self) -> f32 {
        self.speed_rpm
    }
}

impl<P: Observer, M: Observer> Drive<P, M> {
    /// The open loop at θ_ol = angle of `frame` and ω_ol = `omega_m` \[rad/s] (the hand-back).
    // Out of line, like the other mode changes: rare, kept off the every-step path.
    #[inline(never)]
    pub(super) fn open_loop_at(&self, frame: SinCos, omega_m: f32) -> OpenLoop {
        let mut ol = OpenLoop {
            frame,
            speed_rpm: omega_m * RPM_PER_RAD_S,
            ..OpenLoop::AT_REST
        };
        self.set_open_loop_speed(&mut ol);
        ol
    }

    /// The rotations for the speed `speed_rpm` just set: θ_ol's advance per step and the
    /// output angle's lead.
    #[inline(always)]
    fn set_open_loop_speed(&self, ol: &mut OpenLoop) {
        let omega_m = ol.speed_rpm * RAD_S_PER_RPM;
        ol.step_rot = SinCos::of_small(self.open_loop.n_ts * omega_m);
        ol.out_rot = self.foc.output_rotation(omega_m);
    }

    /// One open-loop step: the ramp (in [`Slot::SpeedLoop`]), the frame turned, the
    /// observers' restart half-way to the hand-over speed, the stop at zero, the hand-over
    /// check (in [`Slot::Supervision`]); the request is the I/f current in θ_ol's frame.
    #[inline(always)]
    pub(super) fn open_loop_step(
        &self,
        ol: &mut OpenLoop,
        obs: &mut ObserverStates<P::State, M::State>,
        slot: Slot,
        cmd_rpm: f32,
        i_ab: AlphaBeta,
    ) -> Outcome {
        let s = &self.open_loop;
        // The I/f frequency ramp moves at the speed loop's rate (1 kHz); θ_ol advances by
        // N ω_ol T every step, as the rotation `step_rot` of its sin/cos.
        let before = ol.speed_rpm;
        if slot == Slot::SpeedLoop {
            ol.speed_rpm = slew(before, cmd_rpm, self.slew_per_slot_cycle_rpm);
            self.set_open_loop_speed(ol);
        }
        let omega_m = ol.speed_rpm * RAD_S_PER_RPM;
        ol.frame = ol.frame.rotated(ol.step_rot);
        let mut next = None;
        match slot {
            Slot::SpeedLoop => {
                let half = 0.5 * s.handover_rpm;
                if before.abs() < half && ol.speed_rpm.abs() >= half {
                    // Half-way to the hand-over speed the rotor turns with θ_ol (behind it by
                    // the load angle): restart the observers there, where they can see it.
                    self.reset_observers(obs, i_ab, ol.frame, omega_m);
                }
                if cmd_rpm == 0.0 && ol.speed_rpm == 0.0 {
                    return Outcome::Stopped;
                }
            }
            // The primary's angle against θ_ol, at the sample the angles are kept at.
            Slot::AngleReadOut => {
                let p = self.primary.sin_cos(&obs.primary);
                ol.ol_cos = p.cos * ol.frame.cos + p.sin * ol.frame.sin;
            }
            Slot::Supervision => {
                let views = self.sample_views(obs);
                match self
                    .supervision
                    .hand_over(&mut ol.hand_over, &views, ol.speed_rpm, ol.ol_cos)
                {
                    HandOver::Wait => {}
                    HandOver::Go => {
                        let s = self.enter_sensorless(ol, obs, views.omega_primary);
                        next = Some(ModeState::Sensorless(s));
                    }
                    HandOver::Stall => return Outcome::Fault(super::Fault::Stall),
                }
            }
            // The four rotations since the last time moved its length by a few 1e-7.
            Slot::SpeedReadOut => ol.frame = ol.frame.renormalized(),
        }
        let request = Request {
            frame: ol.frame,
            frame_out: ol.frame.rotated(ol.out_rot),
            omega_m,
            reference: Reference::Current(Dq::new(s.current_a, 0.0)),
        };
        match next {
            Some(mode) => Outcome::Switch(request, mode, super::Reason::HandOver),
            None => Outcome::Run(request),
        }
    }

    /// The hand-over: the speed loop starts from the torque the open-loop current makes in the
    /// primary's frame, the reference from its speed `omega_m` \[rad/s].
    // Out of line, like the other mode changes: rare, kept off the every-step path.
    #[inline(never)]
    fn enter_sensorless(
        &self,
        ol: &OpenLoop,
        obs: &ObserverStates<P::State, M::State>,
        omega_m: f32,
    ) -> Sensorless {
        cold_path();
        // sin(θ_ol − θ̂) of this sample.
        let p = self.primary.sin_cos(&obs.primary);
        let sin_load_angle = ol.frame.sin * p.cos - ol.frame.cos * p.sin;
        Sensorless::new(
            omega_m * RPM_PER_RAD_S,
            self.open_loop.current_a * sin_load_angle,
            self.foc.output_rotation(omega_m),
        )
    }
}

/// `x` moved toward `target` by at most `step`.
pub(super) fn slew(x: f32, target: f32, step: f32) -> f32 {
    x + clamp(target - x, -step, step)
}
