//! What a mode's 1 kHz work asks of the drive ([`Next`]) and what it is given of the driving
//! observer ([`Driving`]): the modes return their requests and their mode changes with a
//! reason, and the drive (`mod.rs`) builds the next mode's state, so no mode reaches into
//! another.

use super::io::{Fault, Reason};
use crate::frames::{Dq, SinCos};

/// The driving observer's estimate now (`Drive::driving_now`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Driving {
    /// sin/cos of θ̂_e.
    pub(super) frame: SinCos,
    /// ω̂_m [rad/s, mechanical].
    pub(super) omega_m: f32,
    /// Its load-torque estimate \[N·m], if it has one.
    pub(super) load_nm: Option<f32>,
}

/// Sensorless control entered at a known rotor (`sensorless::Settings::enter`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Entry {
    /// The rotor's speed [rad/s, mechanical].
    pub(super) omega_m: f32,
    /// The current it carries in the driving observer's frame \[A].
    pub(super) i_dq: Dq,
    /// The driving observer's load estimate \[N·m], if it has one.
    pub(super) load_nm: Option<f32>,
    /// Where the speed reference starts [rad/s, mechanical]: the rotor's speed, or zero for a
    /// rotor turning against the command (braked at the current limit first, never carried
    /// on in reverse).
    pub(super) ref_omega_m: f32,
}

impl Entry {
    /// The reference's start for a rotor at `omega_m` \[rad/s] under the command `cmd_rpm`:
    /// zero if the rotor turns against it ([`against`]), else its speed.
    pub(super) fn reference(omega_m: f32, cmd_rpm: f32) -> f32 {
        if against(omega_m, cmd_rpm) {
            0.0
        } else {
            omega_m
        }
    }
}

impl Next {
    /// A catch's 1 kHz work after its seed (both catches', `catch.rs`, `catch_zero.rs`),
    /// `driving` the driving observer's estimate once one is usable: closed loop at its speed
    /// with the current of its load estimate (zero without one, `foc`'s torque constant), the
    /// speed reference from the rotor's speed, or from zero for a rotor turning against the
    /// command `cmd_rpm` ([`Entry::reference`], as every other hand-over: braked at the current
    /// limit, not carried on in reverse at the ramp's pace); else one more of the `checks`,
    /// and an observer loss at `timeout_checks`.
    // Out of line: one copy for both catches.
    #[inline(never)]
    pub(super) fn caught(
        foc: &crate::foc::Foc,
        driving: Option<Driving>,
        cmd_rpm: f32,
        checks: &mut u32,
        timeout_checks: u32,
    ) -> Next {
        if let Some(d) = driving {
            let back = against(d.omega_m, cmd_rpm);
            let entry = Entry {
                omega_m: d.omega_m,
                i_dq: Dq::new(0.0, foc.current_for_torque(d.load_nm.unwrap_or(0.0))),
                load_nm: d.load_nm,
                // (`Entry::reference`.)
                ref_omega_m: if back { 0.0 } else { d.omega_m },
            };
            let reason = if back {
                Reason::AgainstCommand
            } else {
                Reason::Caught
            };
            return Next::Sensorless(entry, reason);
        }
        *checks = checks.saturating_add(1);
        if *checks >= timeout_checks {
            return Next::Fault(Fault::ObserverLoss);
        }
        Next::Stay
    }
}

/// The rotor at `omega_m` \[rad/s] turns against the command `cmd_rpm` (a zero command has no
/// direction).
pub(super) fn against(omega_m: f32, cmd_rpm: f32) -> bool {
    (omega_m < 0.0 && cmd_rpm > 0.0) || (omega_m > 0.0 && cmd_rpm < 0.0)
}

/// What a mode's 1 kHz work decided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Next {
    /// Carry on.
    Stay,
    /// Carry on; within the mode, the driving observer changed.
    Note(Reason),
    /// Sensorless control from the next step on (a flying start caught, the hand-over).
    Sensorless(Entry, Reason),
    /// Back to the open loop at the driving observer's frame and speed (the hand-back).
    OpenLoop {
        /// sin/cos of θ̂_e.
        frame: SinCos,
        /// ω̂_m [rad/s, mechanical].
        omega_m: f32,
        /// The torque current the I/f carries on from the start \[A] (its frame ahead of θ̂
        /// by `asin(i_q/I_ol)`): 0 but for a command held in the I/f (`sensorless.rs`).
        i_q_a: f32,
    },
    /// Stop switching: a fault.
    Fault(Fault),
    /// Stopped at zero speed with a zero command (back to idle).
    Stopped,
}
