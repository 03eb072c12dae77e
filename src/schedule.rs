//! Where a step is in its millisecond: the drive's 1 kHz task ([`Drive::tick`]) runs once after
//! every fourth step ([`DriveState::tick_due`]); the FOC's speed loop without the drive
//! ([`FocState`]) runs in the first. The one decimator of the 4 kHz step.
//!
//! [`Drive::tick`]: crate::drive::Drive::tick
//! [`DriveState::tick_due`]: crate::drive::DriveState::tick_due
//! [`FocState`]: crate::foc::FocState

/// Steps per millisecond: the 1 kHz task comes after every 4th step (1 kHz at 4 kHz).
pub const SLOTS: u32 = 4;

/// Due runs of the 1 kHz task that may be missed before the step faults
/// ([`Fault::TaskStall`]): 4. A task late by up to three of its periods (a main loop held
/// by a long critical section, a tick on a copy of the state redone after a step: the board's
/// `TickCopy`) is tolerated; a task stalled with the interrupt still running (the speed loop,
/// the supervision and the stall and loss checks stopped, the current loop still driving the
/// last current reference) is found after 4 missed runs, within 5 ms of the stall (issue #27):
/// see [`STEPS_WITHOUT_TICK_MAX`].
///
/// [`Fault::TaskStall`]: crate::drive::Fault::TaskStall
pub const TICKS_MISSED_MAX: u32 = 4;

/// Steps since the last run of the 1 kHz task beyond which a switching step faults: the task
/// is due after every [`SLOTS`]th step, so [`TICKS_MISSED_MAX`] missed runs are
/// `SLOTS · TICKS_MISSED_MAX` = 16 steps; the 17th step after the last run faults, 4.25 ms
/// after it at a 4 kHz step, so at most 4.25 ms after the stall began (the stall begins after
/// the last run).
pub const STEPS_WITHOUT_TICK_MAX: u32 = SLOTS * TICKS_MISSED_MAX;

/// A step's place in its millisecond.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum Slot {
    /// The first step after the 1 kHz task.
    #[default]
    First,
    /// The second.
    Second,
    /// The third.
    Third,
    /// The fourth: the 1 kHz task follows it.
    Fourth,
}

impl Slot {
    /// The slot of the next step: the discriminant plus one, modulo four (an add and a mask).
    pub fn next(self) -> Self {
        match (self as u8 + 1) % SLOTS as u8 {
            0 => Slot::First,
            1 => Slot::Second,
            2 => Slot::Third,
            _ => Slot::Fourth,
        }
    }
}
