//! The snake-case names of the core's faults and identification errors, as the JSON
//! summaries print them and scenario files (`expect_fault`) name them.

use pmsm_sensorless::drive::{Fault, IdentifyError};

/// Every drive fault but the identification's, in the order `pmsm-sim` lists them.
pub const FAULTS: [Fault; 14] = [
    Fault::Overcurrent,
    Fault::BusUndervoltage,
    Fault::BusOvervoltage,
    Fault::InvalidInput,
    Fault::ObserverLoss,
    Fault::Stall,
    Fault::Overrun,
    Fault::AdcOffset,
    Fault::HardwareOvercurrent,
    Fault::OverTemperature,
    Fault::TaskStall,
    Fault::Overspeed,
    Fault::CurrentSensor,
    Fault::OpenWinding,
];

/// Snake-case name of a drive fault, as in the JSON summary.
pub fn fault_name(f: Fault) -> &'static str {
    match f {
        Fault::Overcurrent => "overcurrent",
        Fault::BusUndervoltage => "bus_undervoltage",
        Fault::BusOvervoltage => "bus_overvoltage",
        Fault::InvalidInput => "invalid_input",
        Fault::ObserverLoss => "observer_loss",
        Fault::Stall => "stall",
        Fault::Overrun => "overrun",
        Fault::AdcOffset => "adc_offset",
        Fault::HardwareOvercurrent => "hardware_overcurrent",
        Fault::OverTemperature => "over_temperature",
        Fault::TaskStall => "task_stall",
        Fault::Overspeed => "overspeed",
        Fault::CurrentSensor => "current_sensor",
        Fault::OpenWinding => "open_winding",
        Fault::Identify(e) => error_name(e),
    }
}

/// Snake-case name of an identification error.
pub fn error_name(e: IdentifyError) -> &'static str {
    match e {
        IdentifyError::CurrentNotSensable => "current_not_sensable",
        IdentifyError::OpenPhase => "open_phase",
        IdentifyError::ShortedPhase => "shorted_phase",
        IdentifyError::BlockedRotor => "blocked_rotor",
        IdentifyError::SpinNotFollowed => "spin_not_followed",
        IdentifyError::LostRotor => "lost_rotor",
        IdentifyError::ResistanceOutOfRange => "resistance_out_of_range",
        IdentifyError::InductanceOutOfRange => "inductance_out_of_range",
        IdentifyError::FluxOutOfRange => "flux_out_of_range",
        IdentifyError::InertiaOutOfRange => "inertia_out_of_range",
    }
}
