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
//! The measurement also checks that the current followed its reference: at least half the
//! step between the levels on the d axis, and a mean q current within [`Q_CURRENT_MAX`] of the
//! alignment's current (a current loop holds its reference's mean, whatever the noise or an
//! offset). An open phase a leaves no d current; an open phase b or c lets the current flow
//! only along the line of the other two, at ±30° from the d axis, a q current of
//! `tan 30° = 0.58` times the d current (on the simulated board every open phase of both
//! drive motors is caught, `host-sim/tests/start_resistance.rs`). Either way the start is
//! refused (`Fault::OpenWinding`, `adaptation.rs`).
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

/// The largest mean q current of the two windows, a fraction of the alignment's current.
pub(super) const Q_CURRENT_MAX: f32 = 0.25;

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
    /// Sum of the q current over both windows \[A].
    sum_iq: f32,
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
            a.sum_iq += i_ab.beta;
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

    /// What the alignment measured of the resistance: `Δv/Δi` of the two levels' means
    /// (equal windows) \[Ω], unless the current did not follow its reference
    /// ([`Measured::NotFollowed`]) or the rotor was not at rest ([`Measured::NotAtRest`]; see
    /// the module's doc).
    pub(super) fn resistance(&self, a: &Align) -> Measured {
        let di = a.sum_i[1] - a.sum_i[0];
        let samples = (2 * self.sixteenth) as f32;
        let intended = (1.0 - LOW_LEVEL) * self.current_a * samples;
        let at_rest = a.sum_vq2 <= self.rest_vq2 * (2.0 * samples);
        let q_held = a.sum_iq.abs() <= Q_CURRENT_MAX * self.current_a * (2.0 * samples);
        // (false for NaN: not followed.)
        if !(di.abs() >= 0.5 * intended && q_held) {
            Measured::NotFollowed
        } else if !at_rest {
            Measured::NotAtRest
        } else {
            Measured::Ohm((a.sum_v[1] - a.sum_v[0]) / di)
        }
    }
}

/// The alignment's measurement of the stator resistance ([`Settings::resistance`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Measured {
    /// `R = Δv/Δi` \[Ω], to be judged against the motor's range (`adaptation.rs`).
    Ohm(f32),
    /// The rotor was not at rest (a back-EMF in the q voltage): no measurement.
    NotAtRest,
    /// The current did not follow its reference: less than half the step between the levels
    /// flowed on the d axis, or a mean q current beyond [`Q_CURRENT_MAX`] of the alignment's
    /// where none was asked. The winding does not carry the alignment's current.
    NotFollowed,
}
