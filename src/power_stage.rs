//! The board's side of the drive: a power stage takes the period's sample ([`DriveInput`]) and
//! applies the duties the drive returns. A firmware implements it on its registers (the
//! B-G431B-ESC1 crate under `examples/`), the simulators on their plant models;
//! [`crate::drive::Drive::step`] stays the same in all of them. The lower layer: the drive
//! depends on it, not it on the drive.

use crate::frames::{Abc, AlphaBeta};
use crate::svpwm::Duties;

/// Samples of one period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveInput {
    /// Phase currents \[A].
    pub i_abc: Abc,
    /// DC bus voltage \[V].
    pub v_bus: f32,
    /// The stator voltage over the period that just ended, measured at the terminals (αβ of
    /// the phase voltages, common mode removed) \[V], on boards that sense it (the
    /// B-G431B-ESC1's back-EMF dividers); `None` elsewhere. Read only while the PWM is off:
    /// with it the drive catches a turning rotor without current (mode `Catch`); without it an
    /// enable always aligns.
    pub v_ab_terminal: Option<AlphaBeta>,
    /// The previous step did not finish within its period.
    pub overrun: bool,
    /// The power stage's own protection has stopped it (`None` on a board without one):
    /// the drive faults by this name, and the board keeps its switches off until the fault
    /// is cleared.
    pub stage_fault: Option<StageFault>,
}

/// What a power stage's own protection found ([`DriveInput::stage_fault`]).
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageFault {
    /// The hardware over-current protection (comparators on the shunts into the timer's
    /// break input) switched every output off within the PWM period, before any sample.
    HardwareOvercurrent,
    /// The power stage's temperature is beyond its limit.
    OverTemperature,
}

/// Three half-bridges with phase-current and bus sensing.
pub trait PowerStage {
    /// The sample of this period: phase currents \[A] (positive into the motor), bus voltage
    /// \[V], and whether the previous period's step overran.
    fn sample(&mut self) -> DriveInput;

    /// Loads the duties for the coming period (each in [0, 1]), or turns every switch off
    /// (`None`) at once.
    fn apply(&mut self, duties: Option<Duties>);

    /// Holds the active short circuit from the coming period on: every low-side switch on,
    /// every high-side one off (the drive's safe state where the fault and the motor allow
    /// it, [`DriveOutput::short_circuit`](crate::drive::DriveOutput::short_circuit)). On a
    /// stage of three half-bridges that is duty 0 on every phase with the outputs on, the
    /// default; a stage whose duties do not reach 0 (a duty clamp, a bootstrap refresh) must
    /// implement it on its registers, or turn every switch off.
    fn short_circuit(&mut self) {
        self.apply(Some(Duties {
            a: 0.0,
            b: 0.0,
            c: 0.0,
        }));
    }

    /// The brake chopper's gate (a resistor across the bus), on a stage that has one
    /// ([`DriveOutput::brake`](crate::drive::DriveOutput::brake)); nothing by default.
    fn brake(&mut self, _on: bool) {}
}
