//! Faults that a sample (and the command) alone show: overrun, invalid samples, over-current,
//! bus out of range. Checked first in every step; a fault turns the PWM off in the same step.
//! And the arming: after a fault is cleared, no start until the enable has been seen low.
//!
//! The terminal voltage ([`DriveInput::v_ab_terminal`]) is read only while catching (the PWM
//! off, the observers and the catch running on it), so it is checked there, in every catch
//! step before the catch reads it ([`terminal_valid`]; the observers' update refuses a
//! non-finite input and leaves their state as it was): a non-finite one, or one longer than
//! the highest bus allows, is [`Fault::InvalidInput`] like any other such sample. Not
//! ignored: a catch on a sensor that reads garbage would seed the observers from it (a
//! back-EMF whose square overflows gives a NaN rotor), and a sensing path that fails is a
//! board fault to report before the PWM starts. In the other modes nothing reads it (PWM on,
//! the voltage is the inverter's; idle, the PWM off and no catch), so it is not checked there:
//! no cycles on the running step, and no stop of a running motor for a reading the drive does
//! not use.

use super::config::Limits;
use super::io::{Command, Fault, Mode};
use crate::frames::AlphaBeta;
use crate::math::{all_finite, max};
use crate::power_stage::{DriveInput, StageFault};
use core::hint::cold_path;

/// The fault `input` shows, if any. `starting`: this step leaves idle.
#[inline(always)]
pub(super) fn check_input(
    l: &Limits,
    mode: Mode,
    starting: bool,
    input: &DriveInput,
    cmd: &Command,
) -> Option<Fault> {
    let i = input.i_abc;
    if let Some(f) = input.stage_fault {
        return found(match f {
            StageFault::HardwareOvercurrent => Fault::HardwareOvercurrent,
            StageFault::OverTemperature => Fault::OverTemperature,
        });
    }
    if input.overrun {
        return found(Fault::Overrun);
    }
    if !all_finite([i.a, i.b, i.c, input.v_bus, cmd.speed_rpm]) {
        return found(Fault::InvalidInput);
    }
    let i_peak = max(max(i.a.abs(), i.b.abs()), i.c.abs());
    // One compare on the usual path: `i_sense_max_a` > `i_trip_a` (`DriveConfig::build`).
    if i_peak > l.i_trip_a {
        return found(if i_peak > l.i_sense_max_a {
            Fault::InvalidInput
        } else {
            Fault::Overcurrent
        });
    }
    if input.v_bus > l.bus_max_v {
        return found(Fault::BusOvervoltage);
    }
    // Under-voltage only matters while switching, or about to.
    if (mode != Mode::Idle || starting) && input.v_bus < l.bus_min_v {
        return found(Fault::BusUndervoltage);
    }
    None
}

/// The terminal voltage `v_ab_terminal` is one a catch may read: absent (the board does not
/// sense it), or finite with `|v_ab|` at most the highest bus `bus_max_v` (the phase voltages with
/// the PWM off lie between the rails; an αβ vector longer than the bus is no terminal
/// voltage). False for NaN and ±∞ (the comparison fails).
#[inline(always)]
pub(super) fn terminal_valid(l: &Limits, v_ab_terminal: Option<AlphaBeta>) -> bool {
    match v_ab_terminal {
        None => true,
        Some(v) => v.alpha * v.alpha + v.beta * v.beta <= l.bus_max_v * l.bus_max_v,
    }
}

/// A fault found by a check: the rare path, laid out off the straight-line step.
fn found(fault: Fault) -> Option<Fault> {
    cold_path();
    Some(fault)
}

/// Whether a start may follow: false after a fault is cleared until the enable command has
/// been seen low. Written by the step's commands ([`Arming::see`], [`Arming::disarm`]), read
/// by the starts ([`Arming::armed`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) struct Arming(bool);

impl Default for Arming {
    /// Armed.
    fn default() -> Self {
        Self(true)
    }
}

impl Arming {
    /// The command of this step: an enable seen low arms.
    #[inline(always)]
    pub(super) fn see(&mut self, cmd: &Command) {
        if !cmd.enable {
            self.0 = true;
        }
    }

    /// A fault cleared: disarmed until the enable is seen low.
    pub(super) fn disarm(&mut self) {
        self.0 = false;
    }

    /// A start may follow.
    #[inline(always)]
    pub(super) fn armed(&self) -> bool {
        self.0
    }
}
