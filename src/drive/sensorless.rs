//! Sensorless control: FOC on the primary observer's angle and speed, the speed loop with the
//! primary's load-torque estimate fed forward (Horng & Chin Fig 4), supervision of both
//! observers (in [`Slot::Supervision`]), and the hand-back to open loop at low speed.

use super::open_loop::slew;
use super::schedule::Slot;
use super::supervision::{Health, HealthCount};
use super::{Drive, Fault, ModeState, ObserverStates, Outcome, Reason};
use crate::foc::{Reference, Request};
use crate::frames::{Dq, SinCos};
use crate::observer::Observer;
use crate::pi::PiState;
use crate::units::RAD_S_PER_RPM;

/// The state of [`Mode::Sensorless`](super::Mode::Sensorless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Sensorless {
    /// Slewed speed reference [rpm, mechanical].
    speed_ref_rpm: f32,
    /// The speed PI's integrator \[A].
    speed_pi: PiState,
    /// The speed loop's i_q command \[A].
    i_q_ref: f32,
    /// sin/cos of the output angle's lead at the primary's speed (`Foc::output_rotation`),
    /// renewed in [`Slot::SpeedReadOut`] (the speed read-outs move at 1 kHz).
    out_rot: SinCos,
    /// The health counts.
    health: HealthCount,
}

impl Sensorless {
    /// Sensorless control from the reference `speed_ref_rpm`, with the speed loop's integrator
    /// (and command) at `i_q_a` \[A] and the output lead `out_rot`.
    pub(super) fn new(speed_ref_rpm: f32, i_q_a: f32, out_rot: SinCos) -> Self {
        Self {
            speed_ref_rpm,
            speed_pi: PiState { integral: i_q_a },
            i_q_ref: i_q_a,
            out_rot,
            health: HealthCount::default(),
        }
    }

    /// Slewed speed reference \[rpm].
    pub(super) fn speed_ref_rpm(&self) -> f32 {
        self.speed_ref_rpm
    }
}

impl<P: Observer, M: Observer> Drive<P, M> {
    /// One sensorless step: the speed loop (in [`Slot::SpeedLoop`]), supervision (in
    /// [`Slot::Supervision`]), the output lead at the new speed (in [`Slot::SpeedReadOut`]); the
    /// request is the speed loop's i_q in the primary's frame. An observer that could not
    /// update (`observers_ok` false) is an observer loss.
    #[inline(always)]
    pub(super) fn sensorless_step(
        &self,
        s: &mut Sensorless,
        obs: &ObserverStates<P::State, M::State>,
        slot: Slot,
        cmd_rpm: f32,
        observers_ok: bool,
    ) -> Outcome {
        if !observers_ok {
            return Outcome::Fault(Fault::ObserverLoss);
        }
        let omega_m = self.primary.omega_m(&obs.primary);
        let mut next = None;
        match slot {
            Slot::SpeedLoop => {
                s.speed_ref_rpm = slew(s.speed_ref_rpm, cmd_rpm, self.slew_per_slot_cycle_rpm);
                let omega_m_ref = s.speed_ref_rpm * RAD_S_PER_RPM;
                let ff = self.primary.load_nm(&obs.primary).unwrap_or(0.0);
                s.i_q_ref = self
                    .foc
                    .speed_step(&mut s.speed_pi, omega_m_ref, omega_m, ff);
            }
            Slot::Supervision => {
                let views = self.sample_views(obs);
                match self
                    .supervision
                    .health(&mut s.health, &views, s.speed_ref_rpm, s.i_q_ref)
                {
                    Health::Good => {}
                    Health::ObserverLoss => return Outcome::Fault(Fault::ObserverLoss),
                    Health::Stall => return Outcome::Fault(Fault::Stall),
                    Health::HandBack => {
                        let frame = self.primary.sin_cos(&obs.primary);
                        let ol = self.open_loop_at(frame, views.omega_primary);
                        next = Some(ModeState::OpenLoop(ol));
                    }
                }
            }
            Slot::SpeedReadOut => s.out_rot = self.foc.output_rotation(omega_m),
            Slot::AngleReadOut => {}
        }
        let frame = self.primary.sin_cos(&obs.primary);
        let request = Request {
            frame,
            frame_out: self.primary.sin_cos_output(&obs.primary, frame, s.out_rot),
            omega_m,
            reference: Reference::Current(Dq::new(0.0, s.i_q_ref)),
        };
        match next {
            Some(mode) => Outcome::Switch(request, mode, Reason::HandBack),
            None => Outcome::Run(request),
        }
    }
}
