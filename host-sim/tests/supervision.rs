//! Issue #17's supervision cases (`host-sim/scenarios/sup-*.toml`) with the board's defaults:
//! 20 kHz PWM, 500 ns dead time, 1 % of rated current noise, both primaries, both drive motors
//! (Sinano and Ortega's test motor). Each run must pass its scenario's verdict (no unexpected
//! fault, no loss of lock by the driving observer while sensorless, every window within 2 %)
//! and the property its case names.

use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, Run, SimConfig};
use pmsm_host_sim::summary::Summary;
use pmsm_sensorless::drive::{Mode, Reason};
use pmsm_sensorless::motor::preset;

const MOTORS: [&str; 2] = ["sinano", "ortega-test-0.3kw"];
const PRIMARIES: [ObserverKind; 2] = [ObserverKind::SlidingTorque, ObserverKind::Flux];

/// `scenario` on `motor` with `observer` primary, the board's defaults and 1 % noise (seed 1).
fn board_run(scenario: &str, motor: &str, observer: ObserverKind) -> Run {
    let m = preset(motor).unwrap();
    let sc = Spec::built_in(scenario).unwrap().build(motor, m).unwrap();
    let mut cfg = SimConfig::new(sc, observer);
    cfg.noise_sigma_a = 0.01 * f64::from(m.rated_torque_current_a());
    cfg.dead_time_s = 0.5e-6;
    cfg.pwm_hz = 20_000.0;
    run(cfg).unwrap()
}

/// Runs `scenario` on every motor and primary, asserts the verdict, and hands each run to
/// `check` with its label.
fn every_cell(scenario: &str, check: impl Fn(&str, &Run)) {
    for motor in MOTORS {
        for observer in PRIMARIES {
            let r = board_run(scenario, motor, observer);
            let label = format!("{scenario} {motor} {}", observer.name());
            let s = Summary::of(&r);
            assert!(s.pass, "{label}: {:?}", s.reasons);
            check(&label, &r);
        }
    }
}

/// A flying start at ±50 % and ±100 % of rated speed: closed loop within 50 ms of the enable,
/// the phase current below the rated current all the while.
#[test]
fn a_coasting_rotor_is_caught_without_current() {
    for scenario in [
        "sup-catch-50",
        "sup-catch-neg50",
        "sup-catch-100",
        "sup-catch-neg100",
    ] {
        every_cell(scenario, |label, r| {
            let caught = r
                .transitions
                .iter()
                .find(|(_, t)| t.reason == Reason::Caught)
                .unwrap_or_else(|| panic!("{label}: never caught: {:?}", r.transitions));
            assert!(caught.0 <= 0.05, "{label}: closed loop at {} s", caught.0);
            assert!(
                !r.transitions.iter().any(|(_, t)| t.to == Mode::Align),
                "{label}: aligned into a turning rotor"
            );
            let rated = r.config.scenario.motor.ratings.current_a as f64;
            let peak = r
                .rows
                .iter()
                .map(|row| row.i_d.hypot(row.i_q))
                .fold(0.0, f64::max);
            println!(
                "{label}: closed loop at {:.1} ms, peak {peak:.2} A",
                1e3 * caught.0
            );
            assert!(
                peak < rated,
                "{label}: peak current {peak} A, rated {rated} A"
            );
        });
    }
}

/// 100 % of rated torque applied and removed at once at 50 % of rated speed: no fault, the
/// driving observer keeps lock, the speed within 2 % in the windows from 0.2 s after each
/// step; the peak speed error is printed.
#[test]
fn a_rated_load_step_at_half_speed_keeps_the_motor() {
    every_cell("sup-load-steps-50", |label, r| {
        let peak = r
            .rows
            .iter()
            .filter(|row| row.t >= 1.6)
            .map(|row| (row.speed_rpm - row.speed_cmd_rpm).abs())
            .fold(0.0, f64::max);
        println!("{label}: peak speed error {peak:.1} rpm");
    });
}

/// A blocked shaft ends in a stall fault within 1 s of the enable, at the rated command and
/// below the hand-over speed.
#[test]
fn a_locked_rotor_is_a_stall_within_a_second() {
    for scenario in ["sup-locked-rated", "sup-locked-slow"] {
        every_cell(scenario, |label, r| {
            let (t, _) = r
                .transitions
                .iter()
                .find(|(_, t)| t.to == Mode::Fault)
                .unwrap_or_else(|| panic!("{label}: no fault"));
            println!("{label}: stall at {t:.3} s");
            assert!(*t <= 1.0, "{label}: fault at {t} s");
        });
    }
}
