//! Issue #17's supervision cases (`host-sim/scenarios/sup-*.toml`) with the board's defaults:
//! 20 kHz PWM, 500 ns dead time, 1 % of rated current noise, both primaries, both drive motors
//! (Sinano and Ortega's test motor). Each run must pass its scenario's verdict (no unexpected
//! fault, no loss of lock by the driving observer while sensorless, every window within 2 %)
//! and the property its case names.

mod board;

use board::{board_run, MOTORS, PRIMARIES};
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, Run, SimConfig};
use pmsm_sensorless::drive::{DriveConfig, Mode, Reason};
use pmsm_sensorless::motor::preset;

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

/// The largest |true speed − command| from `t0` on \[rpm].
fn peak_speed_error_rpm(r: &Run, t0: f64) -> f64 {
    r.rows
        .iter()
        .filter(|row| row.t >= t0)
        .map(|row| (row.speed_rpm - row.speed_cmd_rpm).abs())
        .fold(0.0, f64::max)
}

/// A case the Sinano motor cannot hold at rated speed on its 48 V bus (rated torque needs
/// 32.6 V there of the 27.2 V the bus gives less the dead time, `pmsm-sim gains`; field
/// weakening within the 4.5 A current limit still needs 27.8 V): on it no
/// fault, no loss of lock, every window but the `loaded` one within 2 %, and in that one the
/// speed the bus allows at rated torque (`Derived::rated_torque_speed_rpm`) within 5 %; on
/// Ortega's test motor (200 V) the full verdict. `steps_from` \[s]: print the peak speed error
/// from then on (load steps).
fn every_cell_bus_limited(scenario: &str, loaded: &str, steps_from: Option<f64>) {
    for motor in MOTORS {
        for observer in PRIMARIES {
            let r = board_run(scenario, motor, observer);
            let label = format!("{scenario} {motor} {}", observer.name());
            let s = Summary::of(&r);
            let m = preset(motor).unwrap();
            let mut cfg = DriveConfig::new(&m);
            cfg.power_stage.dead_time_s = 0.5e-6;
            let bus_rpm = f64::from(cfg.derived().unwrap().rated_torque_speed_rpm);
            let w = s.windows[loaded].as_ref().unwrap();
            let speed = w.speed_cmd_mean_rpm + w.speed_err_mean_rpm;
            println!("{label}: {loaded} at {speed:.0} rpm, the bus allows {bus_rpm:.0} rpm at rated torque");
            if let Some(t0) = steps_from {
                println!(
                    "  peak speed error from {t0} s: {:.0} rpm",
                    peak_speed_error_rpm(&r, t0)
                );
            }
            if bus_rpm >= f64::from(m.ratings.speed_rpm) {
                assert!(s.pass, "{label}: {:?}", s.reasons);
                continue;
            }
            assert!(
                s.fault.is_none() && !s.lost_lock,
                "{label}: {:?}",
                s.reasons
            );
            let others_pass = s
                .reasons
                .iter()
                .all(|why| why.starts_with(&format!("window {loaded}:")));
            assert!(others_pass, "{label}: {:?}", s.reasons);
            assert!(
                speed >= 0.95 * bus_rpm,
                "{label}: {speed} rpm, bus {bus_rpm} rpm"
            );
        }
    }
}

/// 100 % of rated torque applied and removed at once at rated speed (no fault, no loss of
/// lock; within 2 % 0.2 s after each step where the bus allows it).
#[test]
fn a_rated_load_step_at_rated_speed_keeps_the_motor() {
    every_cell_bus_limited("sup-load-steps-100", "applied", Some(1.6));
}

/// Starts from standstill to rated speed under a brake of 100 % of rated torque (what the bus
/// allows, above) and lifting an active load of 50 % (field weakening holds rated speed on
/// the Sinano motor: 25.4 V at i_d = −1.5 A).
#[test]
fn a_loaded_start_reaches_rated_speed() {
    every_cell_bus_limited("sup-start-brake-100", "rated", None);
    every_cell("sup-start-active-50", |label, r| {
        let backwards = r.rows.iter().map(|row| row.speed_rpm).fold(0.0, f64::min);
        println!("{label}: slowest {backwards:.1} rpm");
    });
}

/// 3 % of rated speed under a 50 % rated active load, sensorless on the flux observer: within
/// 2 % of max(command, 5 % of rated) and never in open loop in the window; the largest angle
/// error is printed.
#[test]
fn three_percent_of_rated_speed_holds_sensorless_under_load() {
    for motor in MOTORS {
        let r = board_run("sup-low-speed-3", motor, ObserverKind::Flux);
        let s = Summary::of(&r);
        assert!(s.pass, "{motor}: {:?}", s.reasons);
        let w = s.windows["low"].as_ref().unwrap();
        let sensorless = r
            .rows
            .iter()
            .filter(|row| row.t >= w.t0 && row.t < w.t1)
            .all(|row| row.mode == Some(Mode::Sensorless));
        println!(
            "{motor}: max angle error {:.2}° e, mean speed error {:.2} rpm",
            w.theta_err_max_abs_deg_e, w.speed_err_mean_rpm
        );
        assert!(sensorless, "{motor}: not sensorless throughout the window");
    }
}

/// +20 % → −20 % of rated speed under a 30 % brake, commanded at once at 2 s: no fault, and
/// within 2 % of the new command in under 1 s, sensorless throughout.
#[test]
fn a_reversal_under_a_brake_takes_under_a_second() {
    every_cell("sup-reverse-20", |label, r| {
        // The first time from which the speed stays within 2 % of −20 % to the end.
        let target = r.rows.last().unwrap().speed_cmd_rpm;
        let tol = 0.02 * target.abs();
        let settled = r
            .rows
            .iter()
            .rev()
            .take_while(|row| (row.speed_rpm - target).abs() <= tol)
            .last()
            .map(|row| row.t)
            .unwrap();
        println!(
            "{label}: within 2 % of {target} rpm from {:.3} s (commanded at 2 s)",
            settled
        );
        assert!(settled - 2.0 < 1.0, "{label}: {settled}");
        let open_loop = r
            .rows
            .iter()
            .any(|row| row.t > 1.0 && row.mode != Some(Mode::Sensorless));
        assert!(!open_loop, "{label}: left sensorless control");
    });
}

/// A command beyond the ratings is limited to the rated speed.
#[test]
fn a_command_beyond_the_ratings_is_limited() {
    for observer in PRIMARIES {
        let m = preset("sinano").unwrap();
        let mut spec = Spec::built_in("sup-catch-50")
            .unwrap()
            .build("sinano", m)
            .unwrap();
        spec.speed_cmd_rpm = pmsm_host_sim::scenario::profile::Pwl::constant(1e30);
        spec.initial_speed_rpm = 0.0;
        spec.windows.clear();
        spec.duration_s = 2.5;
        let r = run(SimConfig::new(spec, observer)).unwrap();
        let fastest = r.rows.iter().map(|row| row.speed_rpm).fold(0.0, f64::max);
        println!(
            "{}: fastest {fastest:.1} rpm for a 1e30 rpm command",
            observer.name()
        );
        assert!(r.drive_fault.is_none(), "{:?}", r.drive_fault);
        assert!(
            fastest <= 1.02 * f64::from(m.ratings.speed_rpm),
            "{fastest}"
        );
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
        println!(
            "{label}: peak speed error {:.1} rpm",
            peak_speed_error_rpm(r, 1.6)
        );
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
