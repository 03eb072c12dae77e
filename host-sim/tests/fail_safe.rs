//! Issue #27's fail-safe cases with the board's defaults (20 kHz PWM, 500 ns dead time, 1 % of
//! rated current noise), both primaries, the Sinano motor, Ortega's test motor and the EMRAX
//! 228 (`board::FAIL_SAFE_MOTORS`):
//! - a stalled task (`host-sim/scenarios/fault-task-stall.toml`): the drive's 1 kHz task stops
//!   at 1.8 s (the main loop stuck, the interrupt running: the control loop runs only its
//!   step), at rated speed under half the rated load. The drive faults `task_stall` within
//!   5 ms of the stall (4 missed runs of the task,
//!   `pmsm_sensorless::schedule::STEPS_WITHOUT_TICK_MAX`), and the PWM is off from that step
//!   on;
//! - an overhauling load beyond the current limit (`host-sim/scenarios/fault-overspeed.toml`):
//!   1.7 × rated torque driving the rotor at rated speed from 1.5 s; the drive faults
//!   `overspeed` and the PWM is off from the next step on (the Sinano motor).

mod board;

use board::{board_run, FAIL_SAFE_MOTORS as MOTORS, PRIMARIES};
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::sim::Run;
use pmsm_sensorless::drive::{Fault, Mode, Reason};

/// The bound: a fault within 5 ms of the stall \[s].
const LATENCY_MAX_S: f64 = 5e-3;

#[test]
fn a_stalled_task_faults_within_5_ms_and_the_pwm_stays_off() {
    for motor in MOTORS {
        for observer in PRIMARIES {
            let r = board_run("fault-task-stall", motor, observer);
            let label = format!("{motor} {}", observer.name());
            let s = Summary::of(&r);
            assert!(s.pass, "{label}: {:?}", s.reasons);
            assert_eq!(r.drive_fault, Some(Fault::TaskStall), "{label}");
            let t_stall = r
                .config
                .scenario
                .drive
                .as_ref()
                .unwrap()
                .injection
                .unwrap()
                .t();
            // The only fault, after the stall.
            let faults: Vec<f64> = r
                .transitions
                .iter()
                .filter(|(_, tr)| matches!(tr.reason, Reason::Fault(_)))
                .map(|&(t, _)| t)
                .collect();
            assert_eq!(faults.len(), 1, "{label}: {:?}", r.transitions);
            let t_fault = faults[0];
            let latency_s = t_fault - t_stall;
            let steps = r.fault_step.unwrap();
            println!(
                "{label}: task_stall {:.2} ms after the stall ({steps} steps)",
                1e3 * latency_s
            );
            assert!(
                (0.0..=LATENCY_MAX_S).contains(&latency_s),
                "{label}: {latency_s} s"
            );
            // Found in the step: off in that step.
            assert_pwm_off_from(&r, t_fault, &label);
        }
    }
}

/// PWM off from the sample at `t` \[s] on: faulted, no voltage applied.
fn assert_pwm_off_from(r: &Run, t: f64, label: &str) {
    for row in r.rows.iter().filter(|row| row.t >= t) {
        assert_eq!(row.mode, Some(Mode::Fault), "{label} at {} s", row.t);
        assert_eq!(
            (row.v_alpha, row.v_beta),
            (0.0, 0.0),
            "{label} at {}",
            row.t
        );
    }
}

/// On the Sinano motor (Ortega's test motor, with the bound from the bus the drive measures:
/// `tests/overhaul.rs`).
#[test]
fn an_overhauling_load_beyond_the_current_limit_is_an_overspeed_with_the_pwm_off() {
    for motor in ["sinano"] {
        for observer in PRIMARIES {
            let r = board_run("fault-overspeed", motor, observer);
            let label = format!("{motor} {}", observer.name());
            let s = Summary::of(&r);
            assert!(s.pass, "{label}: {:?}", s.reasons);
            assert_eq!(r.drive_fault, Some(Fault::Overspeed), "{label}");
            let (t_fault, _) = *r
                .transitions
                .iter()
                .find(|(_, tr)| matches!(tr.reason, Reason::Fault(_)))
                .unwrap();
            let at_fault = r.rows.iter().find(|row| row.t >= t_fault).unwrap();
            let rated = r.config.scenario.motor.ratings.speed_rpm as f64;
            println!(
                "{label}: overspeed at {t_fault:.4} s, true speed {:.0} rpm ({:.2} x rated)",
                at_fault.speed_rpm,
                at_fault.speed_rpm / rated
            );
            assert!(at_fault.speed_rpm > rated, "{label}");
            // Found in the 1 kHz task: off from the next step.
            assert_pwm_off_from(&r, t_fault + 1.0 / r.config.rate_hz, &label);
        }
    }
}
