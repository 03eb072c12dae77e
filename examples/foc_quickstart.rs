//! How the core is driven: build the FOC from a motor preset, then call `step` once per
//! 250 µs control period with the sampled currents, bus voltage and rotor estimate.
//!
//! `cargo run --example foc_quickstart` (host). The firmware binaries for the B-G431B-ESC1 and
//! the emulated Cortex-M4F come with the firmware issue; they call the same `step`.

use pmsm_sensorless::foc::{FocConfig, FocInput, FocState};
use pmsm_sensorless::frames::Abc;
use pmsm_sensorless::motor::HORNG_SINANO;

fn main() {
    let motor = HORNG_SINANO;
    // Horng & Chin Sec 5 defaults: 300 Hz current loop at 4 kHz, 20 Hz speed loop at 1 kHz.
    let config = FocConfig::new(motor.params, motor.rated_torque_current_a());
    let foc = config.build().expect("preset parameters are valid");
    let mut state = FocState::default();

    let input = FocInput {
        i_abc: Abc::new(0.1, -0.05, -0.05),
        v_bus: 48.0,
        theta_e: 0.3,
        omega_m: 50.0,
        omega_m_ref: 104.7,
        torque_ff_nm: 0.0,
    };
    let out = foc.step(&mut state, &input);
    println!("i_dq = {:?}, i_dq_ref = {:?}", out.i_dq, out.i_dq_ref);
    println!("v_ab = {:?}, duties = {:?}", out.v_ab, out.duties);

    // Bad input never panics and never gives duties outside [0, 1]: a NaN current gives zero
    // volts (all duties 0.5) and leaves the integrators untouched.
    let bad = FocInput {
        i_abc: Abc::new(f32::NAN, 0.0, 0.0),
        ..input
    };
    let out = foc.step(&mut state, &bad);
    println!("NaN current -> duties = {:?}", out.duties);

    // Impossible parameters are an error naming the field.
    let mut wrong = config;
    wrong.current_bandwidth_hz = 5000.0;
    if let Err(e) = wrong.build() {
        println!("5 kHz current loop at 4 kHz -> error: {e}");
    }
}
