//! What the board-default scenario tests share (`supervision.rs` and issue #27's tests): a built-in
//! scenario run with the board's defaults and 1 % noise, the motors (a preset or a zoo file) and
//! primaries they run; each test crate uses a part of it (`allow(dead_code)`).

use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, Run, SimConfig};
use pmsm_sensorless::motor::{preset, Motor};

/// The drive motors: the Sinano motor and Ortega's test motor.
#[allow(dead_code)]
pub const MOTORS: [&str; 2] = ["sinano", "ortega-test-0.3kw"];
/// Issue #27's motors: the two drive motors and the largest zoo motor (EMRAX 228, 64.5 kW,
/// 7 mΩ, 520 V; `host-sim/motors/zoo/axial-emrax-228-mv.toml`).
#[allow(dead_code)]
pub const FAIL_SAFE_MOTORS: [&str; 3] = ["sinano", "ortega-test-0.3kw", "zoo:axial-emrax-228-mv"];

/// A preset by name, or `zoo:FILE`: `host-sim/motors/zoo/FILE.toml`.
pub fn motor(name: &str) -> Motor {
    match name.strip_prefix("zoo:") {
        Some(file) => {
            let path = format!("{}/motors/zoo/{file}.toml", env!("CARGO_MANIFEST_DIR"));
            pmsm_host_sim::motor_file::load(std::path::Path::new(&path))
                .unwrap()
                .1
        }
        None => preset(name).unwrap(),
    }
}
/// Both primaries.
#[allow(dead_code)]
pub const PRIMARIES: [ObserverKind; 2] = [ObserverKind::SlidingTorque, ObserverKind::Flux];

/// `scenario` on `motor` with `observer` primary, the board's defaults and 1 % noise (seed 1).
#[allow(dead_code)]
pub fn board_run(scenario: &str, motor: &str, observer: ObserverKind) -> Run {
    board_run_spec(&Spec::built_in(scenario).unwrap(), motor, observer)
}

/// [`board_run`] of a scenario given as its `spec`.
#[allow(dead_code)]
pub fn board_run_spec(spec: &Spec, motor: &str, observer: ObserverKind) -> Run {
    let m = self::motor(motor);
    let sc = spec.build(motor, m).unwrap();
    let mut cfg = SimConfig::new(sc, observer);
    cfg.board.noise_sigma_a = 0.01 * f64::from(m.rated_torque_current_a());
    cfg.board.dead_time_s = 0.5e-6;
    cfg.board.pwm_hz = 20_000.0;
    run(cfg).unwrap()
}
