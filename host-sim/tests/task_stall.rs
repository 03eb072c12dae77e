//! Issue #27's stalled task (`host-sim/scenarios/fault-task-stall.toml`): the drive's 1 kHz
//! task stops at 1.8 s (the main loop stuck, the interrupt running: the control loop runs only
//! its step), at rated speed under half the rated load, with the board's defaults (20 kHz
//! PWM, 500 ns dead time, 1 % of rated current noise), both primaries, the Sinano motor and
//! Ortega's test motor. The drive faults `task_stall` within 5 ms of the stall (4 missed runs
//! of the task, `pmsm_sensorless::schedule::STEPS_WITHOUT_TICK_MAX`), and the PWM is off from
//! that step on.

use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, Run, SimConfig};
use pmsm_sensorless::drive::{Fault, Mode, Reason};
use pmsm_sensorless::motor::preset;

const MOTORS: [&str; 2] = ["sinano", "ortega-test-0.3kw"];
const PRIMARIES: [ObserverKind; 2] = [ObserverKind::SlidingTorque, ObserverKind::Flux];

/// The bound: a fault within 5 ms of the stall \[s].
const LATENCY_MAX_S: f64 = 5e-3;

/// The stall scenario on `motor` with `observer` primary, the board's defaults and 1 % noise.
fn board_run(motor: &str, observer: ObserverKind) -> Run {
    let m = preset(motor).unwrap();
    let sc = Spec::built_in("fault-task-stall")
        .unwrap()
        .build(motor, m)
        .unwrap();
    let mut cfg = SimConfig::new(sc, observer);
    cfg.board.noise_sigma_a = 0.01 * f64::from(m.rated_torque_current_a());
    cfg.board.dead_time_s = 0.5e-6;
    cfg.board.pwm_hz = 20_000.0;
    run(cfg).unwrap()
}

#[test]
fn a_stalled_task_faults_within_5_ms_and_the_pwm_stays_off() {
    for motor in MOTORS {
        for observer in PRIMARIES {
            let r = board_run(motor, observer);
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
            // PWM off from the fault's step on: faulted, no voltage applied.
            for row in r.rows.iter().filter(|row| row.t >= t_fault) {
                assert_eq!(row.mode, Some(Mode::Fault), "{label} at {} s", row.t);
                assert_eq!(
                    (row.v_alpha, row.v_beta),
                    (0.0, 0.0),
                    "{label} at {}",
                    row.t
                );
            }
        }
    }
}
