//! The safe state a fault leaves the power stage in, chosen per fault and per motor: every
//! switch off, or the active short circuit (every low-side switch on, the three phases shorted
//! together: [`DriveOutput::short_circuit`](super::DriveOutput::short_circuit)).
//!
//! With every switch off a turning rotor whose line-to-line back-EMF is below the bus makes
//! no current and no torque: a hanging (active) load runs it away until its back-EMF passes
//! the bus, and then it charges the bus through the diodes, uncontrolled. Shorted, the motor
//! brakes itself at every speed: its steady-state short-circuit current at the electrical
//! speed `ω_e` is `ψ_f ω_e/√(R² + ω_e² L²)`, rising to the characteristic current
//! `I_ch = ψ_f/L` at high speed, with the braking torque `N ψ_f² ω_e R/(R² + ω_e² L²)`
//! (largest, `N ψ_f²/(2L)`, at `ω_e = R/L`), and nothing flows into the bus. Welchko, Jahns,
//! Soong & Nagashima, "IPM synchronous machine drive response to symmetrical and asymmetrical
//! short circuit faults", IEEE Trans. Energy Conversion 18(2), 2003: the symmetrical short is
//! the preferred response where the characteristic current is within what the machine and
//! the inverter carry continuously (machines built for field weakening, `I_ch` near rated),
//! and the transient after the short overshoots its steady state: in the dq plane the current
//! circles the steady-state point from the current at the fault, so its peak is at most
//! `|i_ss| + |i_0 − i_ss| ≤ 2 I_ch + |i_0|`. The rule here:
//!
//! ```text
//! short circuit allowed on the motor  ⇔  I_ch = ψ_f/L ≤ i_max_a                (steady state)
//!                                      and 2 I_ch + i_trip_a ≤ i_sense_max_a     (transient peak)
//! ```
//!
//! `i_max_a` is the current the drive runs the motor and the stage at continuously,
//! `i_trip_a` the most the current can be at the fault, `i_sense_max_a` the stage's sensing
//! range (its specified current). Sinano: `I_ch` = 9.7 A against `i_max_a` = 4.5 A, refused;
//! Ortega's test motor: 96 A against 6.8 A, refused; the 40 kW motor: 223 A against 617 A,
//! allowed (2·223 + 925 ≤ 1,851 A).
//!
//! And only for faults that leave the stage able to hold it: the drive's own loss of control
//! (`overspeed`, `stall`, `observer_loss`, `task_stall`) and an over-voltage (the short stops
//! the charging); never a fault of the stage or its sensing (`overcurrent`,
//! `hardware_overcurrent`, `invalid_input`: a shorted switch or winding; `over_temperature`;
//! `bus_undervoltage`: the gate drivers' supply may be short too; `overrun`, `adc_offset`, the
//! identification's): those turn every switch off.

use super::io::Fault;

/// The state a fault leaves the stage in.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SafeState {
    /// Every switch off.
    Off,
    /// Every low-side switch on (active short circuit).
    ShortCircuit,
}

/// Whether the motor allows the short circuit (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// The motor's short-circuit current is within the stage's and the motor's limits.
    pub(super) short_circuit_allowed: bool,
}

impl Settings {
    /// The rule of the module doc for a motor of flux linkage `flux_wb` \[Wb] and inductance
    /// `l_h` \[H] on the limits `(i_max_a, i_trip_a, i_sense_max_a)` \[A].
    pub(super) fn new(flux_wb: f32, l_h: f32, (i_max, i_trip, i_sense): (f32, f32, f32)) -> Self {
        let i_ch = flux_wb / l_h;
        Self {
            short_circuit_allowed: i_ch <= i_max && 2.0 * i_ch + i_trip <= i_sense,
        }
    }

    /// The safe state for `fault`.
    #[inline(always)]
    pub(super) fn for_fault(&self, fault: Fault) -> SafeState {
        if self.short_circuit_allowed && allows_short_circuit(fault) {
            SafeState::ShortCircuit
        } else {
            SafeState::Off
        }
    }
}

/// Whether `fault` leaves the stage able to hold the short circuit (module doc).
pub fn allows_short_circuit(fault: Fault) -> bool {
    match fault {
        Fault::Overspeed
        | Fault::Stall
        | Fault::ObserverLoss
        | Fault::TaskStall
        | Fault::BusOvervoltage => true,
        Fault::Overcurrent
        | Fault::HardwareOvercurrent
        | Fault::InvalidInput
        | Fault::OverTemperature
        | Fault::BusUndervoltage
        | Fault::Overrun
        | Fault::AdcOffset
        | Fault::CurrentSensor
        | Fault::OpenWinding => false,
        #[cfg(feature = "identify")]
        Fault::Identify(_) => false,
    }
}
