//! How the core is driven, on the host: the FOC block alone (one call per 250 µs period with
//! the sampled currents, bus voltage and a rotor estimate), then the whole drive, whose
//! `Drive::step` is what a firmware's control interrupt calls (the emulated Cortex-M4F in
//! `examples/qemu-m4f/`, the B-G431B-ESC1 board under `examples/`).
//!
//! `cargo run --example foc_quickstart`

use pmsm_sensorless::drive::{Command, DriveConfig, DriveInput, DriveState};
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
    let out = state.step(&foc, &input);
    println!("i_dq = {:?}, i_dq_ref = {:?}", out.i_dq, out.i_dq_ref);
    println!("v_ab = {:?}, duties = {:?}", out.v_ab, out.duties);

    // Bad input never panics and never gives duties outside [0, 1]: a NaN current gives zero
    // volts (all duties 0.5) and leaves the integrators untouched.
    let bad = FocInput {
        i_abc: Abc::new(f32::NAN, 0.0, 0.0),
        ..input
    };
    let out = state.step(&foc, &bad);
    println!("NaN current -> duties = {:?}", out.duties);

    // Impossible parameters are an error naming the field.
    let mut wrong = config;
    wrong.current_bandwidth_hz = 5000.0;
    if let Err(e) = wrong.build() {
        println!("5 kHz current loop at 4 kHz -> error: {e}");
    }

    // The drive: enabled with a speed command it starts with the alignment; every mode change
    // comes back as a transition, the log record is read when wanted.
    let drive = DriveConfig::new(&motor)
        .build_sliding_primary()
        .expect("preset parameters are valid");
    let mut st = DriveState::default();
    let sample = DriveInput {
        i_abc: Abc::default(),
        v_bus: 48.0,
        v_ab_terminal: None,
        overrun: false,
        stage_fault: None,
    };
    let run = Command {
        enable: true,
        speed_rpm: 500.0,
        clear_fault: false,
    };
    let out = drive.step(&mut st, &sample, &run);
    println!("drive: {:?}, duties {:?}", out.transition, out.duties);
    println!("telemetry: {:?}", drive.telemetry(&st));
}
