//! What goes into and out of the drive: the sample, the command, the output, the modes as the
//! outside sees them, faults, transitions and the log record.

use crate::svpwm::Duties;

/// Operating mode.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// PWM off, waiting for enable.
    #[default]
    Idle,
    /// PWM off, the observers watching the terminal voltage: is the rotor turning?
    Catch,
    /// d-axis current at θ_e = 0 pulls the rotor to a known angle.
    Align,
    /// Current-controlled open loop with a frequency ramp.
    OpenLoop,
    /// FOC on the configured observer.
    Sensorless,
    /// PWM off, latched until cleared.
    Fault,
    /// PWM off: the current sensors' offsets measured before an identification.
    Calibrate,
    /// The motor measured (`identify/`).
    Identify,
    /// Identification done: PWM off, the results held until the enable is withdrawn.
    Identified,
}

/// Why the drive stopped switching.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// A phase current beyond `i_trip_a`.
    Overcurrent,
    /// Bus below `bus_min_v`.
    BusUndervoltage,
    /// Bus above `bus_max_v`.
    BusOvervoltage,
    /// A non-finite sample, a current beyond the sensing range, or, while catching, a
    /// terminal voltage that is not finite or longer than `bus_max_v`.
    InvalidInput,
    /// No observer healthy for `loss_time_s` while sensorless above the hand-back speed, the
    /// two healthy observers contradicting each other for that long, or an observer that could
    /// not update (its state would have become non-finite).
    ObserverLoss,
    /// No observer locked within the open loop's time limit, or the speed collapsed at the
    /// current limit (a locked rotor, a load beyond the motor).
    Stall,
    /// The caller reported that the previous step overran its period.
    Overrun,
    /// A current sensor's offset, measured with the PWM off, is beyond a twentieth of the
    /// sensing range: a broken sensing path, or a current flowing.
    AdcOffset,
    /// The power stage's hardware over-current protection switched it off
    /// ([`StageFault::HardwareOvercurrent`] in [`DriveInput::stage_fault`]).
    ///
    /// [`StageFault::HardwareOvercurrent`]: crate::power_stage::StageFault::HardwareOvercurrent
    /// [`DriveInput::stage_fault`]: crate::power_stage::DriveInput::stage_fault
    HardwareOvercurrent,
    /// The power stage is too hot ([`StageFault::OverTemperature`] in
    /// [`DriveInput::stage_fault`]).
    ///
    /// [`StageFault::OverTemperature`]: crate::power_stage::StageFault::OverTemperature
    /// [`DriveInput::stage_fault`]: crate::power_stage::DriveInput::stage_fault
    OverTemperature,
    /// The drive's 1 kHz task ([`Drive::tick`]) did not run for more than
    /// [`STEPS_WITHOUT_TICK_MAX`] steps while the drive switched (or caught a rotor): the
    /// main loop stalled, the interrupt still running, so the speed loop, the supervision and
    /// its stall and loss checks stopped with it.
    ///
    /// [`Drive::tick`]: super::Drive::tick
    /// [`STEPS_WITHOUT_TICK_MAX`]: crate::schedule::STEPS_WITHOUT_TICK_MAX
    TaskStall,
    /// The driving observer's speed, while it is locked in sensorless control, beyond the
    /// speed whose back-EMF the field weakening no longer holds within the bus the drive
    /// measures (filtered) with the whole current limit on the d axis (beyond the speed whose
    /// line-to-line back-EMF peak reaches the bus: the diodes conduct with the PWM off), for
    /// `loss_time_s`, unless the speed is falling back: a load drives the rotor beyond what
    /// the current limit can brake.
    Overspeed,
    /// The three phase-current samples do not sum to zero: their sum beyond `i_sum_max_a` =
    /// 12.4 % of the rated current (+ 1.5 ADC steps) on 4 more samples than within it
    /// (`plausibility.rs`). A current sensor stuck, reading zero or off by a gain while current
    /// flows (its error is the sum), or a broken sensing path.
    CurrentSensor,
    /// The alignment's current did not follow its reference (less than half the step between
    /// its two levels flowed on the d axis, or a mean q current beyond a quarter of the
    /// alignment's where none was asked): the motor does not carry the start's current. A
    /// phase or the whole motor not connected (a broken wire, a loose connector), or a
    /// winding whose resistance the bus cannot drive the alignment's current through. The
    /// start is refused at the alignment's end, PWM off, instead of an open loop that cannot
    /// make its torque (`adaptation.rs`).
    OpenWinding,
    /// The identification stopped: why (with the feature `identify`).
    #[cfg(feature = "identify")]
    Identify(super::identify::IdentifyError),
}

/// Why the mode changed.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// Enable command.
    Enabled,
    /// The terminal voltage showed a turning rotor and an observer locked on it: closed loop
    /// without alignment (flying start).
    Caught,
    /// The rotor is at rest (or too slow to see): align it.
    AtRest,
    /// Alignment time elapsed (the resistance it measured taken).
    Aligned,
    /// An observer is healthy on its own evidence: closed loop on it.
    HandOver,
    /// The rotor turned against the command in the start (an active load beyond the
    /// alignment's or the open loop's current drags it): closed loop at once, braking it at
    /// the current limit before it follows the command.
    AgainstCommand,
    /// The rotor turned while being aligned (a load the alignment's current does not hold):
    /// its back-EMF measured with the currents regulated to zero (`catch_zero.rs`), then
    /// closed loop.
    Turning,
    /// No observer healthy at low speed: back to open loop.
    HandBack,
    /// Stopped at zero speed (estimated) with a zero command.
    Stopped,
    /// The primary observer lost its health: the healthy monitor drives (within the mode).
    Failover,
    /// The primary observer is healthy (again): it drives (within the mode).
    PrimaryDrives,
    /// Enable withdrawn.
    Disabled,
    /// A fault.
    Fault(Fault),
    /// Fault cleared by command.
    Cleared,
    /// Identification requested.
    Identify,
    /// The offsets measured.
    Calibrated,
    /// Every identification measurement done.
    Identified,
    /// Alignment time elapsed, the resistance it measured refused: beyond the motor's range,
    /// or not measured (the rotor not at rest). The drive starts on the resistance it had (a
    /// warning, not a fault: `adaptation.rs`); what was measured and the range:
    /// [`DriveState::resistance_refused`](super::DriveState::resistance_refused).
    ResistanceRefused,
}

/// An alignment's stator-resistance measurement the drive did not take
/// ([`Reason::ResistanceRefused`]): what was measured and the range it is taken in. The drive
/// kept the resistance it had ([`Telemetry::r_ohm`]).
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResistanceRefused {
    /// The alignment's `Δv/Δi` \[Ω]; `None`: nothing measured, the rotor was not at rest.
    pub measured_ohm: Option<f32>,
    /// The lowest resistance taken, `R₀/3` \[Ω] (`R₀` the configured).
    pub min_ohm: f32,
    /// The highest resistance taken, `3 R₀` \[Ω].
    pub max_ohm: f32,
}

/// One mode change, for the log.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transition {
    /// Mode before.
    pub from: Mode,
    /// Mode after.
    pub to: Mode,
    /// Why.
    pub reason: Reason,
}

/// Which observer feeds the controller.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Role {
    /// The primary (the configured one).
    #[default]
    Primary,
    /// The monitor, while the primary is not healthy.
    Monitor,
}

/// What the user asks for.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Command {
    /// Run (true) or stop switching (false). From idle the drive starts when enabled with a
    /// non-zero speed command.
    pub enable: bool,
    /// Speed command [rpm, mechanical]; the drive slews to it.
    pub speed_rpm: f32,
    /// Clear a latched fault (back to idle); the drive then starts again only after `enable`
    /// has been low.
    pub clear_fault: bool,
}

/// Small fixed-size record for the log, read at a low rate with [`Drive::telemetry`](super::Drive::telemetry) (the
/// 4 kHz step does not build it).
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Telemetry {
    /// Mode.
    pub mode: Mode,
    /// Latched fault, if any.
    pub fault: Option<Fault>,
    /// Slewed speed reference \[rpm].
    pub speed_ref_rpm: f32,
    /// Speed used by the controller \[rpm] (primary estimate, or the open-loop speed).
    pub speed_rpm: f32,
    /// Primary observer's electrical angle \[rad].
    pub theta_e_primary: f32,
    /// Monitor observer's electrical angle \[rad].
    pub theta_e_monitor: f32,
    /// Angle used by the controller (θ_ol in open loop) \[rad].
    pub theta_e_control: f32,
    /// Measured d current (the observers' last sample) in the controller's frame \[A].
    pub i_d: f32,
    /// Measured q current (the observers' last sample) in the controller's frame \[A].
    pub i_q: f32,
    /// The primary observer's load-torque estimate \[N·m], if it has one.
    pub load_nm: Option<f32>,
    /// Which observer drives (in sensorless control).
    pub driving: Role,
    /// Health: the primary's and the monitor's residual, each observer's own evidence of lock
    /// (below 1 consistent with the measurements; see `Observer::residual`).
    pub residual_primary: f32,
    /// See `residual_primary`.
    pub residual_monitor: f32,
    /// Health: |θ̂_primary − θ̂_monitor| [deg, electrical].
    pub disagreement_deg: f32,
    /// Health: |ω̂_primary − ω̂_monitor| \[rpm].
    pub speed_disagreement_rpm: f32,
    /// The drive's stator resistance \[Ω]: measured at each start and while running where its
    /// drop is at least 0.6 of the back-EMF, bounded (`adaptation.rs`); 0 before the first enable.
    pub r_ohm: f32,
    /// The drive's magnet flux linkage \[Wb]: adapted while running fast, bounded.
    pub flux_wb: f32,
    /// The current loop's voltage was at its limit through the last millisecond (the speed
    /// loop's integrator held against more motoring current, field weakening acting).
    pub voltage_limited: bool,
}

/// Result of one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveOutput {
    /// Duties to load, each in [0, 1]; `None`: all switches off.
    pub duties: Option<Duties>,
    /// With `duties` `None` (a fault): hold the active short circuit, every low-side switch
    /// on ([`PowerStage::short_circuit`](crate::power_stage::PowerStage::short_circuit)),
    /// instead of every switch off, where the fault and the motor allow it (the drive's
    /// `safe_state.rs`).
    pub short_circuit: bool,
    /// The brake chopper's gate, for a stage with a brake resistor
    /// ([`PowerStage::brake`](crate::power_stage::PowerStage::brake)): on while the bus is
    /// high (the drive's `regen.rs`).
    pub brake: bool,
    /// The mode change this step made, if any.
    pub transition: Option<Transition>,
}
