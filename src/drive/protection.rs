//! Faults that a sample (and the command) alone show: overrun, invalid samples, over-current,
//! bus out of range. Checked first in every step; a fault turns the PWM off in the same step.
//! And the arming: after a fault is cleared, no start until the enable has been seen low.

use super::config::Limits;
use super::io::{Command, Fault, Mode};
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
