//! Issue #26's zoo on its light rotors, board defaults, true motor files: rated torque
//! applied and removed at once (`sup-load-steps-50`) on the Anaheim BLY171D (J = 24 g·cm²),
//! sliding primary, its eigenvalues raised with the motor's largest acceleration
//! (`DriveConfig::sliding_config`). With the paper's, its angle fell 91° behind 11 ms after
//! the step (lost lock) while the flux monitor stayed within 1°.
//!
//! And the Nanotec DF45 (J = 13 g·cm²: its rated torque moves it by 3,000 rpm per
//! millisecond) under its rated torque let go of at the voltage limit (`sup-load-steps-100`,
//! flux primary): the current loop's q integrator is released on the voltage circle under a
//! braking command (`src/foc/current.rs`). Held, it kept the `R i_q` of motoring current, no
//! braking current flowed, and the rotor ran to 5,900 rpm against its 1,590 rpm command and
//! was turned backwards (`removed` window 211 % off, then `stall`).
//!
//! Not asserted: the DF45's rated torque applied at once with the sliding primary, which stops
//! its rotor within a millisecond, faster than the 1 kHz speed loop acts (the zoo's remaining
//! failures).

mod common;
use common::zoo;
use pmsm_host_sim::board::SimBoard;
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, SimConfig};
use pmsm_sensorless::drive::DriveConfig;
use pmsm_sensorless::motor::{preset, Motor};

#[test]
fn rated_torque_at_once_on_a_light_rotor() {
    let (anaheim, nanotec) = (
        "small-anaheim-bly171d-24v-4000",
        "flat-nanotec-df45l024048-a",
    );
    let cases = [
        (anaheim, "sup-load-steps-50", ObserverKind::SlidingTorque, 1),
        (anaheim, "sup-load-steps-50", ObserverKind::SlidingTorque, 2),
        (nanotec, "sup-load-steps-100", ObserverKind::Flux, 1),
        (nanotec, "sup-load-steps-100", ObserverKind::Flux, 2),
    ];
    for (file, scenario, observer, seed) in cases {
        let m = zoo(file);
        let sc = Spec::built_in(scenario).unwrap().build(file, m).unwrap();
        let mut board = SimBoard::board_defaults(&m);
        board.seed = seed;
        let r = run(SimConfig::on(board, sc, observer)).unwrap();
        let s = Summary::of(&r);
        let label = format!("{scenario} {file} {} seed {seed}", observer.name());
        println!("{label}: worst window {:?} %", s.worst_speed_err_pct);
        assert!(s.pass, "{label}: {:?}", s.reasons);
    }
}

/// The paper's eigenvalues (λθ 10 Hz, λω 60 Hz, λτ 2 Hz) on the paper's motor; raised by
/// `√(α/(2.75 λθ λω))` on the BLY171D; capped at λω = half the current loop's bandwidth on
/// the DF45.
#[test]
fn the_sliding_observer_follows_the_motor_s_acceleration() {
    let eigen = |m: &Motor| {
        let c = DriveConfig::new(m).sliding_config();
        (c.lambda_theta_hz, c.lambda_omega_hz, c.lambda_tau_hz)
    };
    assert_eq!(eigen(&preset("sinano").unwrap()), (10.0, 60.0, 2.0));
    let m = zoo("small-anaheim-bly171d-24v-4000");
    let tau = std::f32::consts::TAU;
    let k = (DriveConfig::new(&m).max_acceleration_e() / (2.75 * tau * tau * 600.0)).sqrt();
    let (th, om, ta) = eigen(&m);
    assert!(k > 1.4 && k < 1.6, "{k}");
    assert!((th / 10.0 - k).abs() < 1e-4 && (om / 60.0 - k).abs() < 1e-4 && ta == 2.0);
    let m = zoo("flat-nanotec-df45l024048-a");
    let (th, om, _) = eigen(&m);
    let half = 0.5 * DriveConfig::new(&m).current_bandwidth_hz;
    assert!(
        (om - half).abs() < 1e-3 && (th - half / 6.0).abs() < 1e-3,
        "{th} {om}"
    );
}
