//! What the board-default scenario tests share (`supervision.rs`, `fail_safe.rs`): a built-in
//! scenario run with the board's defaults and 1 % noise, and the motors and primaries they run.

use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, Run, SimConfig};
use pmsm_sensorless::motor::preset;

/// The drive motors: the Sinano motor and Ortega's test motor.
pub const MOTORS: [&str; 2] = ["sinano", "ortega-test-0.3kw"];
/// Both primaries.
pub const PRIMARIES: [ObserverKind; 2] = [ObserverKind::SlidingTorque, ObserverKind::Flux];

/// `scenario` on `motor` with `observer` primary, the board's defaults and 1 % noise (seed 1).
pub fn board_run(scenario: &str, motor: &str, observer: ObserverKind) -> Run {
    let m = preset(motor).unwrap();
    let sc = Spec::built_in(scenario).unwrap().build(motor, m).unwrap();
    let mut cfg = SimConfig::new(sc, observer);
    cfg.board.noise_sigma_a = 0.01 * f64::from(m.rated_torque_current_a());
    cfg.board.dead_time_s = 0.5e-6;
    cfg.board.pwm_hz = 20_000.0;
    run(cfg).unwrap()
}
