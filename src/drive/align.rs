//! Align: a d-axis current at θ_e = 0 pulls the rotor to a known angle, at rest, for the
//! open-loop start.

use crate::foc::{Reference, Request};
use crate::frames::{Dq, SinCos};

/// Align's per-step coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// d-axis current \[A].
    pub(super) current_a: f32,
    /// Steps to hold it.
    pub(super) steps: u32,
}

/// The state of [`Mode::Align`](super::Mode::Align).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Align {
    /// Steps taken before this one.
    steps_done: u32,
}

impl Settings {
    /// This step's request, and whether the alignment time is over (the enabling step is the
    /// first).
    #[inline(always)]
    pub(super) fn step(&self, a: &mut Align) -> (Request, bool) {
        let done = a.steps_done >= self.steps;
        a.steps_done = a.steps_done.saturating_add(1);
        let req = Request {
            frame: SinCos::ZERO,
            frame_out: SinCos::ZERO,
            omega_m: 0.0,
            reference: Reference::Current(Dq::new(self.current_a, 0.0)),
        };
        (req, done)
    }
}
