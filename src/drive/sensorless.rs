//! Sensorless control: FOC on the driving observer's angle and speed (the primary, or the
//! monitor while the primary is not healthy), the speed loop with its load-torque estimate fed
//! forward (Horng & Chin Fig 4), the health check of both observers (in [`Slot::Supervision`],
//! `supervision.rs`), the stall check, the stop at zero, and the hand-back to open loop where
//! no observer is healthy at low speed.

use super::open_loop::slew;
use super::schedule::Slot;
use super::supervision::Verdict;
use super::{Drive, Fault, ModeState, ObserverStates, Outcome, Reason};
use crate::foc::{Reference, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::load_observer::LoadObserverState;
use crate::observer::Observer;
use crate::pi::PiState;
use crate::units::{RAD_S_PER_RPM, RPM_PER_RAD_S};

/// The state of [`Mode::Sensorless`](super::Mode::Sensorless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Sensorless {
    /// Slewed speed reference [rpm, mechanical].
    speed_ref_rpm: f32,
    /// The speed PI's integrator \[A].
    speed_pi: PiState,
    /// The speed loop's i_q command \[A].
    i_q_ref: f32,
    /// sin/cos of the output angle's lead at the driving observer's speed
    /// (`Foc::output_rotation`), renewed in [`Slot::SpeedReadOut`] (the speed read-outs move at
    /// 1 kHz).
    out_rot: SinCos,
    /// Consecutive checks of a collapsed speed at the current limit.
    stall: u32,
    /// The speed loop's load-torque observer (`load_observer.rs`).
    load: LoadObserverState,
}

impl Sensorless {
    /// Slewed speed reference \[rpm].
    pub(super) fn speed_ref_rpm(&self) -> f32 {
        self.speed_ref_rpm
    }
}

impl<P: Observer, M: Observer> Drive<P, M> {
    /// Sensorless control of a rotor at `omega_m` \[rad/s]: the reference there, the speed
    /// loop's integrator (and command) at `i_q_a` \[A], the load-torque observer at the torque
    /// it makes.
    // Out of line, like the other mode changes: rare, kept off the every-step path.
    #[inline(never)]
    pub(super) fn sensorless_at(&self, omega_m: f32, i_q_a: f32) -> Sensorless {
        let mut load = LoadObserverState::default();
        let torque = self.foc.torque_for_current(i_q_a);
        self.load_observer.reset(&mut load, torque, omega_m);
        Sensorless {
            speed_ref_rpm: omega_m * RPM_PER_RAD_S,
            speed_pi: PiState { integral: i_q_a },
            i_q_ref: i_q_a,
            out_rot: self.foc.output_rotation(omega_m),
            stall: 0,
            load,
        }
    }

    /// One sensorless step: the speed loop (in [`Slot::SpeedLoop`]), supervision (in
    /// [`Slot::Supervision`]), the output lead at the new speed (in [`Slot::SpeedReadOut`]); the
    /// request is the speed loop's i_q in the driving observer's frame. An observer that could
    /// not update (`observers_ok` false) is an observer loss.
    #[inline(always)]
    pub(super) fn sensorless_step(
        &self,
        s: &mut Sensorless,
        obs: &mut ObserverStates<P::State, M::State>,
        slot: Slot,
        cmd_rpm: f32,
        i_ab: AlphaBeta,
        observers_ok: bool,
    ) -> Outcome {
        if !observers_ok {
            return Outcome::Fault(Fault::ObserverLoss);
        }
        let (frame, frame_out, omega_m, load_nm) = self.driving(obs, s.out_rot);
        let mut note = None;
        match slot {
            Slot::SpeedLoop => {
                s.speed_ref_rpm = slew(s.speed_ref_rpm, cmd_rpm, self.slew_per_slot_cycle_rpm);
                let omega_m_ref = s.speed_ref_rpm * RAD_S_PER_RPM;
                // The driving observer's load estimate fed forward, else the speed loop's own.
                let own = self.load_observer.update(&mut s.load, omega_m, s.i_q_ref);
                let ff_nm = load_nm.unwrap_or(own);
                s.i_q_ref = self
                    .foc
                    .speed_step(&mut s.speed_pi, omega_m_ref, omega_m, ff_nm);
            }
            Slot::Supervision => {
                let torque = self.foc.torque_for_current(s.i_q_ref);
                let (verdict, reason) = self.supervise(obs, i_ab, torque);
                note = reason;
                let speed_rpm = omega_m * RPM_PER_RAD_S;
                let handback = self.supervision.handback_rpm;
                match verdict {
                    Verdict::Drive | Verdict::Switched => {}
                    // Without an observer at low speed, open loop carries the rotor on.
                    Verdict::NoLock
                        if s.speed_ref_rpm.abs() < handback && speed_rpm.abs() < handback =>
                    {
                        let ol = self.open_loop_at(frame, omega_m);
                        return Outcome::Switch(
                            self.request(frame, frame_out, omega_m, s.i_q_ref),
                            ModeState::OpenLoop(ol),
                            Reason::HandBack,
                        );
                    }
                    Verdict::NoLock | Verdict::Contradiction => {
                        return Outcome::Fault(Fault::ObserverLoss)
                    }
                }
                if self
                    .supervision
                    .stalled(&mut s.stall, omega_m, s.speed_ref_rpm, s.i_q_ref)
                {
                    return Outcome::Fault(Fault::Stall);
                }
                if cmd_rpm == 0.0
                    && s.speed_ref_rpm == 0.0
                    && speed_rpm.abs() < self.supervision.stop_rpm
                {
                    return Outcome::Stopped;
                }
            }
            Slot::SpeedReadOut => s.out_rot = self.foc.output_rotation(omega_m),
            Slot::AngleReadOut => {}
        }
        let request = self.request(frame, frame_out, omega_m, s.i_q_ref);
        match note {
            Some(reason) => Outcome::Note(request, reason),
            None => Outcome::Run(request),
        }
    }

    /// The current command `(0, i_q)` \[A] in the frame at sin/cos `frame`, applied at
    /// `frame_out`, `omega_m` the frame's speed \[rad/s].
    #[inline(always)]
    fn request(&self, frame: SinCos, frame_out: SinCos, omega_m: f32, i_q: f32) -> Request {
        Request {
            frame,
            frame_out,
            omega_m,
            reference: Reference::Current(Dq::new(0.0, i_q)),
        }
    }
}
