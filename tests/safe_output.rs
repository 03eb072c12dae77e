//! The drive's outputs for the safe state and the brake resistor (`src/drive/safe_state.rs`,
//! `src/drive/regen.rs`): a fault that allows the active short circuit on a motor that allows
//! it asks the stage for it (duties still `None`); any other fault, or a motor whose
//! short-circuit current ψ_f/L is beyond its current limit, turns every switch off; the
//! brake output follows the bus with its hysteresis in every mode.

use pmsm_sensorless::drive::{Command, DriveConfig, DriveInput, Fault, SafeState, StateOf};
use pmsm_sensorless::frames::Abc;
use pmsm_sensorless::motor::{Motor, HORNG_SINANO, ORTEGA_SIM_40KW};
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;

fn input(v_bus: f32, i_a: f32) -> DriveInput {
    DriveInput {
        i_abc: Abc::new(i_a, -0.5 * i_a, -0.5 * i_a),
        v_bus,
        v_ab_terminal: None,
        overrun: false,
        stage_fault: None,
    }
}

/// The first step's fault and outputs on `motor` for the sample `sample`.
fn fault_on(motor: &Motor, sample: DriveInput) -> (Option<Fault>, bool, bool) {
    let drive = DriveConfig::new(motor).build_flux_primary().unwrap();
    let mut st = StateOf::<FluxPll, SlidingObserver>::default();
    let out = drive.step(&mut st, &sample, &Command::default());
    assert!(out.duties.is_none());
    assert_eq!(
        drive.safe_state(&st).map(|s| s == SafeState::ShortCircuit),
        st.fault().map(|_| out.short_circuit)
    );
    (st.fault(), out.short_circuit, out.brake)
}

#[test]
fn an_over_voltage_shorts_the_motor_only_where_its_short_circuit_current_allows() {
    for (motor, asc) in [(ORTEGA_SIM_40KW, true), (HORNG_SINANO, false)] {
        let bus = motor.ratings.bus_v;
        let (fault, short, brake) = fault_on(&motor, input(1.3 * bus, 0.0));
        assert_eq!(fault, Some(Fault::BusOvervoltage), "{}", motor.name);
        assert_eq!(short, asc, "{}", motor.name);
        // The bus is high: the brake resistor's gate is on, whatever the mode.
        assert!(brake, "{}", motor.name);
        // An over-current (the stage's own) never shorts.
        let i_trip = DriveConfig::new(&motor).limits.i_trip_a;
        let (fault, short, _) = fault_on(&motor, input(bus, 1.1 * i_trip));
        assert_eq!(fault, Some(Fault::Overcurrent), "{}", motor.name);
        assert!(!short, "{}", motor.name);
    }
}

#[test]
fn the_brake_output_switches_on_at_0_3_and_off_at_0_2_of_the_way_to_the_trip() {
    let m = HORNG_SINANO;
    let drive = DriveConfig::new(&m).build_flux_primary().unwrap();
    let mut st = StateOf::<FluxPll, SlidingObserver>::default();
    let cmd = Command::default();
    // 48 V rated, 60 V trip: on above 51.6 V, off below 50.4 V.
    for (v, on) in [
        (48.0, false),
        (51.5, false),
        (51.7, true),
        (50.5, true),
        (50.3, false),
        (51.0, false),
    ] {
        let out = drive.step(&mut st, &input(v, 0.0), &cmd);
        assert_eq!(out.brake, on, "{v} V");
        assert!(!out.short_circuit && out.duties.is_none(), "{v} V");
    }
}
