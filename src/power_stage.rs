//! The board's side of the drive: a power stage takes the period's sample and applies the
//! duties the drive returns. A firmware implements it on its registers (the B-G431B-ESC1 crate
//! under `examples/`), the simulators on their plant models; [`crate::drive::Drive::step`]
//! stays the same in all of them.

use crate::drive::DriveInput;
use crate::svpwm::Duties;

/// Three half-bridges with phase-current and bus sensing.
pub trait PowerStage {
    /// The sample of this period: phase currents \[A] (positive into the motor), bus voltage
    /// \[V], and whether the previous period's step overran.
    fn sample(&mut self) -> DriveInput;

    /// Loads the duties for the coming period (each in [0, 1]), or turns every switch off
    /// (`None`) at once.
    fn apply(&mut self, duties: Option<Duties>);
}
