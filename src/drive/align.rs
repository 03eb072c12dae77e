//! Align: a d-axis current at θ_e = 0 pulls the rotor to a known angle, at rest, for the
//! open-loop start; meanwhile the stator resistance is measured (`adaptation.rs`).
//!
//! The time is split in quarters: the full current for two (the rotor pulls in and settles),
//! a lower level for one, the full current again for one. Over the second half of each of
//! the last two (after the current loop and the rotor have settled) the drive averages the d
//! voltage it applies and the d current it measures; `R = Δv/Δi` between them. The
//! lower level is [`LOW_LEVEL`] of the full: against an active load that the full current
//! holds at 30° of load angle (half the torque of a rated-torque current) it holds the rotor at
//! 49°, so the rotor moves by 19° and stays at rest.
//!
//! The measurement checks that the rotor was at rest: a turning rotor's back-EMF shows in the
//! q voltage (`ω_e ψ_f cos θ`, the current loop holding i_q at 0), and it would also bias the d
//! voltage. With the windows' RMS q voltage above the back-EMF of [`REST_SPEED`] of the rated
//! speed (a rotor pulled in late from 180°, where the current makes no torque, and still
//! swinging), the measurement is refused. The current loop's answer to 1 % current noise is
//! far below it (about 0.3 V on the Sinano motor, against 1.2 V).
//!
//! A rotor the current does not hold (an active load beyond the alignment's torque drags it)
//! shows a back-EMF that turns on in one direction: the drive watches it every step
//! (`catch_zero::Watch`, `DriveState::watch`) and, after a full electrical turn while measurable
//! (`catch_zero::TURN_ALIGN`), catches the rotor with the currents regulated to zero and takes
//! it over in closed loop (`Reason::Turning`), instead of starting an open loop the rotor does
//! not follow.

use crate::foc::{Reference, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};

/// The lower current level, a fraction of the full.
pub(super) const LOW_LEVEL: f32 = 2.0 / 3.0;

/// At rest: the q voltage's RMS in the windows below the back-EMF of this fraction of the
/// rated speed.
pub(super) const REST_SPEED: f32 = 0.05;

/// Align's per-step coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// d-axis current \[A].
    pub(super) current_a: f32,
    /// A sixteenth of the steps to hold it (the phases below in sixteenths).
    pub(super) sixteenth: u32,
    /// The largest mean square q voltage of a rotor at rest \[V²] ([`REST_SPEED`]).
    pub(super) rest_vq2: f32,
}

/// The state of [`Mode::Align`](super::Mode::Align).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Align {
    /// Steps taken before this one.
    steps_done: u32,
    /// Sums of the applied d voltage \[V] and measured d current \[A] over each level's
    /// averaging window: `[low, full]`.
    sum_v: [f32; 2],
    sum_i: [f32; 2],
    /// Sum of the squared q voltage over both windows \[V²].
    sum_vq2: f32,
}

impl Settings {
    /// This step's request, and whether the alignment time is over (the enabling step is the
    /// first). `i_ab` is measured now \[A], `v_ab` the voltage applied over the period that
    /// ended with it \[V] (θ_e = 0: their α parts are d).
    #[inline(always)]
    pub(super) fn step(&self, a: &mut Align, i_ab: AlphaBeta, v_ab: AlphaBeta) -> (Request, bool) {
        let n = a.steps_done;
        let sixteenth = self.sixteenth;
        let done = n >= 16 * sixteenth;
        // In sixteenths of the time: full current 0..8, low 8..12 (averaged over 10..12),
        // full 12..16 (averaged over 14..16). A sample closes the period before it, of the
        // same phase inside a window.
        let low = n >= 8 * sixteenth && n < 12 * sixteenth;
        let window = if n >= 14 * sixteenth && !done {
            Some(1)
        } else if n >= 10 * sixteenth && low {
            Some(0)
        } else {
            None
        };
        if let Some(w) = window {
            a.sum_v[w] += v_ab.alpha;
            a.sum_i[w] += i_ab.alpha;
            a.sum_vq2 += v_ab.beta * v_ab.beta;
        }
        a.steps_done = n.saturating_add(1);
        let level = if low { LOW_LEVEL } else { 1.0 };
        let req = Request {
            frame: SinCos::ZERO,
            frame_out: SinCos::ZERO,
            omega_m: 0.0,
            reference: Reference::Current(Dq::new(level * self.current_a, 0.0)),
        };
        (req, done)
    }

    /// The resistance measured \[Ω]: `Δv/Δi` of the two levels' means (equal windows); NaN if
    /// the currents did not differ by at least half the intended step (an open phase, a
    /// current the loop could not drive) or the rotor turned (see the module's doc).
    pub(super) fn resistance(&self, a: &Align) -> f32 {
        let di = a.sum_i[1] - a.sum_i[0];
        let samples = (2 * self.sixteenth) as f32;
        let intended = (1.0 - LOW_LEVEL) * self.current_a * samples;
        let at_rest = a.sum_vq2 <= self.rest_vq2 * (2.0 * samples);
        if di.abs() >= 0.5 * intended && at_rest {
            (a.sum_v[1] - a.sum_v[0]) / di
        } else {
            f32::NAN
        }
    }
}
