//! Where a step is in its millisecond: the drive's 1 kHz task ([`Drive::tick`]) runs once after
//! every `steps_per_tick`-th step ([`DriveState::tick_due`]); the FOC's speed loop without the
//! drive ([`FocState`]) runs in the first. The one decimator of the control step, whatever its
//! rate: [`Schedule`] holds the steps per millisecond, `rate_hz / 1000`, an integer (the
//! control rate is a multiple of 1 kHz, `crate::rate`), and the slot is a count of the steps
//! since the task, `0..steps_per_tick`.
//!
//! [`Drive::tick`]: crate::drive::Drive::tick
//! [`DriveState::tick_due`]: crate::drive::DriveState::tick_due
//! [`FocState`]: crate::foc::FocState

use crate::param::{Allowed, ParamError};

/// The drive's task rate \[Hz]: the speed loop, the observers' read-outs, supervision.
pub const TICK_HZ: f32 = 1000.0;

/// Steps per millisecond at the 4 kHz step of the papers and of the motors up to 200 Hz
/// electrical at rated speed (`crate::rate`): the 1 kHz task comes after every 4th step.
pub const SLOTS: u32 = 4;

/// Due runs of the 1 kHz task that may be missed before the step faults
/// ([`Fault::TaskStall`]): 4, at any control rate (a count of milliseconds). A task late by
/// up to three of its periods (a main loop held by a long critical section, a tick on a copy
/// of the state redone after a step: the board's `TickCopy`) is tolerated; a task stalled
/// with the interrupt still running (the speed loop, the supervision and the stall and loss
/// checks stopped, the current loop still driving the last current reference) is found after
/// 4 missed runs, within 5 ms of the stall (issue #27): see
/// [`Schedule::steps_without_tick_max`].
///
/// [`Fault::TaskStall`]: crate::drive::Fault::TaskStall
pub const TICKS_MISSED_MAX: u32 = 4;

/// [`Schedule::steps_without_tick_max`] at the 4 kHz step: `SLOTS · TICKS_MISSED_MAX` = 16
/// steps; the 17th step after the last run faults, 4.25 ms after it.
pub const STEPS_WITHOUT_TICK_MAX: u32 = SLOTS * TICKS_MISSED_MAX;

/// The largest step rate a schedule takes \[Hz]: [`Schedule::steps_without_tick_max`] must
/// count in the drive's `u16` (and its slot in a `u8`).
pub const RATE_MAX_HZ: f32 = 100_000.0;

/// The control step's millisecond: how many steps it holds.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    /// Steps per run of the 1 kHz task, `rate_hz / 1000` (1..=100).
    steps_per_tick: u8,
    /// [`Schedule::steps_without_tick_max`], kept (the step compares with it).
    stall_steps: u16,
}

impl Default for Schedule {
    /// The 4 kHz step: [`SLOTS`] steps per millisecond.
    fn default() -> Self {
        Self {
            steps_per_tick: SLOTS as u8,
            stall_steps: STEPS_WITHOUT_TICK_MAX as u16,
        }
    }
}

impl Schedule {
    /// The schedule of a step at `rate_hz`: a whole number of steps per millisecond, from 1
    /// (1 kHz) to 100 (100 kHz). The error names `field` and the multiple of 1 kHz nearest.
    pub fn at(field: &'static str, rate_hz: f32) -> Result<Self, ParamError> {
        Allowed::between(TICK_HZ, RATE_MAX_HZ).check(field, rate_hz)?;
        let steps = libm::roundf(rate_hz / TICK_HZ);
        let whole = steps * TICK_HZ;
        Allowed::between(whole, whole)
            .because("a multiple of 1000 Hz: whole steps per 1 kHz task")
            .check(field, rate_hz)?;
        Ok(Self {
            steps_per_tick: steps as u8,
            stall_steps: (steps as u32 * TICKS_MISSED_MAX) as u16,
        })
    }

    /// Steps per run of the 1 kHz task.
    #[inline(always)]
    pub fn steps_per_tick(&self) -> u32 {
        u32::from(self.steps_per_tick)
    }

    /// Steps since the last run of the 1 kHz task beyond which a switching step faults:
    /// [`TICKS_MISSED_MAX`] missed runs, `steps_per_tick · TICKS_MISSED_MAX` steps; the next
    /// step after them faults, `TICKS_MISSED_MAX` ms and one step after the last run, so at
    /// most that long after the stall began (the stall begins after the last run): 4.25 ms
    /// at 4 kHz, 4.05 ms at 20 kHz.
    #[inline(always)]
    pub fn steps_without_tick_max(&self) -> u32 {
        u32::from(self.stall_steps)
    }

    /// [`Schedule::steps_without_tick_max`] as the step compares it.
    #[inline(always)]
    pub(crate) fn stall_steps(&self) -> u16 {
        self.stall_steps
    }

    /// The slot of the step after one in `slot` (0: the first step after the 1 kHz task;
    /// `steps_per_tick − 1`: the last, the task follows it).
    #[inline(always)]
    pub fn next_slot(&self, slot: u8) -> u8 {
        let next = slot.wrapping_add(1);
        if next >= self.steps_per_tick {
            0
        } else {
            next
        }
    }
}
