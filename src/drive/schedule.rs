//! The 1 kHz schedule: the work that need not run every 250 µs step is spread over the four
//! steps of each millisecond, one part per step, so that no step carries all of it.

/// Steps per millisecond-slot cycle: each [`Slot`] comes every 4th step (1 kHz at 4 kHz).
pub const SLOTS: u32 = 4;

/// The part of the 1 kHz work a step does besides the every-step work (the observers' state
/// equations, the current loop and the PWM).
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum Slot {
    /// The observers' angle read-outs (the flux observer's arctangent, Ortega Sec V), kept as
    /// the angles of one sample for the comparisons of the next slot; in open loop also the
    /// primary's angle against the open-loop angle.
    #[default]
    AngleReadOut,
    /// Supervision: in sensorless control observer health, stall and the hand-back; in open
    /// loop the hand-over check.
    Supervision,
    /// The observers' speed read-outs (the PLL, the I&I observer) and the output-angle lead
    /// at the new speed; in open loop the renormalisation of its frame.
    SpeedReadOut,
    /// Speed-reference slew and the speed PI; in open loop the I/f frequency ramp.
    SpeedLoop,
}

impl Slot {
    /// The slot of the next step: the discriminant plus one, modulo four (an add and a mask).
    pub(super) fn next(self) -> Self {
        match (self as u8 + 1) % SLOTS as u8 {
            0 => Slot::AngleReadOut,
            1 => Slot::Supervision,
            2 => Slot::SpeedReadOut,
            _ => Slot::SpeedLoop,
        }
    }
}
