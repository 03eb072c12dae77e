//! Issue #26's command profiles (`host-sim/scenarios/profile-*.toml`) with the board's defaults
//! (20 kHz PWM, 0.5 µs dead time, 1 % noise, 2 % offset on phase a), both primaries, the
//! configuration's control rate: a slow ramp (1 s) and a step to 3 % of rated speed under a
//! 50 % active load. On the Sinano motor and three zoo motors of different classes (a NEMA-23
//! servo, a 0.4 kW servo, a hoverboard hub motor with 150× the servo's inertia). Each run must
//! pass its verdict: no fault, no loss of lock while sensorless, every window within 2 %.
//! The zoo matrix (`host-sim/matrices/zoo.toml`) runs them on every zoo motor and seed.

use pmsm_host_sim::board::SimBoard;
use pmsm_host_sim::motor_file;
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, SimConfig};
use pmsm_sensorless::motor::{preset, Motor};

/// The low-speed profiles. The reversal and the catch at −50 % with +30 % run in the zoo
/// matrix: the observers carry them through zero unless the driving one drifts (its residual
/// past half-way), and on the Sinano motor the catch-and-reverse still faults
/// `observer_loss` (0.58 s, sliding primary): not asserted here yet.
const PROFILES: [&str; 2] = ["profile-slow-ramp-3", "profile-step-3"];

fn zoo(file: &str) -> Motor {
    let path = format!("{}/motors/zoo/{file}.toml", env!("CARGO_MANIFEST_DIR"));
    motor_file::load(std::path::Path::new(&path)).unwrap().1
}

#[test]
fn every_profile_is_followed_on_four_motors_with_both_primaries() {
    let motors = [
        ("sinano", preset("sinano").unwrap()),
        ("teknic-m2310p", zoo("nema23-teknic-m2310p")),
        ("maxon-645106", zoo("servo-maxon-645106")),
        ("hoverboard-hub", zoo("hoverboard-6.5in-hub-odrive")),
    ];
    for (name, m) in motors {
        for scenario in PROFILES {
            for observer in [ObserverKind::SlidingTorque, ObserverKind::Flux] {
                let sc = Spec::built_in(scenario).unwrap().build(name, m).unwrap();
                let cfg = SimConfig::on(SimBoard::board_defaults(&m), sc, observer);
                let rate = cfg.rate_hz;
                let r = run(cfg).unwrap();
                let s = Summary::of(&r);
                let label = format!("{scenario} {name} {} at {rate} Hz", observer.name());
                println!("{label}: worst window {:?} %", s.worst_speed_err_pct);
                assert!(s.pass, "{label}: {:?}", s.reasons);
            }
        }
    }
}
