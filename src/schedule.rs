//! Where a step is in its millisecond: the drive's 1 kHz task ([`Drive::tick`]) runs once after
//! every fourth step ([`DriveState::tick_due`]); the FOC's speed loop without the drive
//! ([`FocState`]) runs in the first. The one decimator of the 4 kHz step.
//!
//! [`Drive::tick`]: crate::drive::Drive::tick
//! [`DriveState::tick_due`]: crate::drive::DriveState::tick_due
//! [`FocState`]: crate::foc::FocState

/// Steps per millisecond: the 1 kHz task comes after every 4th step (1 kHz at 4 kHz).
pub const SLOTS: u32 = 4;

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
