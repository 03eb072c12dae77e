//! The FOC on an angle given from outside (an encoder, one observer alone), without the drive:
//! the papers' bare loop (the speed loop on the estimated speed with the load estimate fed
//! forward, Horng & Chin Fig 4; the current loop in the estimated frame), for the simulator's
//! observer runs, the tests and the quick start. The speed loop runs in the first step of
//! each millisecond ([`crate::schedule::Schedule`]), as the drive's does in its 1 kHz task.

use super::{Foc, FocOutput, Reference, Request};
use crate::frames::{Abc, AlphaBeta, Dq, SinCos};
use crate::pi::PiState;

pub use super::current::CurrentLoopState;

/// Running state of the bare loop ([`FocState::step`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FocState {
    /// Current-loop integrators.
    pub current: CurrentLoopState,
    /// Speed-loop integrator \[A].
    pub speed: PiState,
    /// Latest `i_q` command from the speed loop \[A].
    pub i_q_ref: f32,
    /// The coming step's place in the speed loop's period, `0..speed_divider` (the speed loop
    /// runs in slot 0).
    pub slot: u8,
}

/// Inputs of one step of the bare loop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FocInput {
    /// Sampled phase currents \[A].
    pub i_abc: Abc,
    /// DC bus voltage \[V].
    pub v_bus: f32,
    /// Rotor electrical angle used for the transforms \[rad] (encoder or observer).
    pub theta_e: f32,
    /// Rotor mechanical speed used by the loops \[rad/s] (encoder or observer).
    pub omega_m: f32,
    /// Speed command [rad/s, mechanical].
    pub omega_m_ref: f32,
    /// Load-torque feed-forward \[N·m] (estimated load torque; 0 without a torque observer).
    pub torque_ff_nm: f32,
}

impl FocInput {
    /// The measured currents in the stationary frame \[A] (Clarke transform).
    pub fn i_ab(&self) -> AlphaBeta {
        self.i_abc.to_alpha_beta()
    }

    /// The request of `reference` in the frame of `theta_e`, the voltage applied at the
    /// output angle of `foc` ([`Foc::output_angle`]): for [`Foc::run`].
    pub fn request(&self, foc: &Foc, reference: Reference) -> Request {
        let sc = SinCos::of(self.theta_e);
        Request {
            frame: sc,
            frame_out: foc.output_angle(sc, self.omega_m),
            omega_m: self.omega_m,
            reference,
        }
    }
}

impl FocState {
    /// One current-loop period of `foc`; in the first slot of each cycle the speed loop runs
    /// first ([`Foc::speed_step`]).
    pub fn step(&mut self, foc: &Foc, input: &FocInput) -> FocOutput {
        let sc = SinCos::of(input.theta_e);
        let sc_out = foc.output_angle(sc, input.omega_m);
        self.step_at(foc, input, sc, sc_out)
    }

    /// [`FocState::step`] with the sin/cos of `input.theta_e` (`sc`, for the Park transform of
    /// the currents) and of the output angle (`sc_out`, for the inverse Park of the voltage,
    /// see [`Foc::output_angle`]) already known, e.g. kept by the observer that estimated the
    /// angle, which saves the trig evaluations.
    pub fn step_at(
        &mut self,
        foc: &Foc,
        input: &FocInput,
        sc: SinCos,
        sc_out: SinCos,
    ) -> FocOutput {
        if self.slot == 0 {
            let speeds = (input.omega_m_ref, input.omega_m);
            self.i_q_ref = foc.speed_step(&mut self.speed, speeds, input.torque_ff_nm, None);
        }
        self.slot = foc.schedule.next_slot(self.slot);
        let request = Request {
            frame: sc,
            frame_out: sc_out,
            omega_m: input.omega_m,
            reference: Reference::Current(Dq::new(0.0, self.i_q_ref)),
        };
        foc.run(&mut self.current, &request, input.i_ab(), input.v_bus)
    }
}
