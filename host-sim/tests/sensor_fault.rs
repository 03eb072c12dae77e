//! Issue #27's failed current sensors, with the board's defaults (`SimBoard::board_defaults`:
//! 20 kHz PWM, 500 ns dead time, 1 % of rated current noise, a 2 % offset on phase a, the
//! offsets measured in 20 ms of idle), both primaries, the Sinano motor, Ortega's test motor
//! and the EMRAX 228 (`board::FAIL_SAFE_MOTORS`), at rated speed under 0.8 of the rated load (a brake), phase a's sensor failing at
//! 2.0 s:
//! - stuck at its last reading (`host-sim/scenarios/fault-sensor-stuck.toml`) or reading zero
//!   (`fault-sensor-zero.toml`): the drive faults `current_sensor` (the phase currents' sum,
//!   `src/drive/plausibility.rs`) before the plant's true current reaches the trip, and the
//!   PWM is off from that step on;
//! - reading 10 % low (`fault-sensor-gain.toml`): where a tenth of the phase current passes
//!   the check's threshold (the Sinano motor, at its current limit under this load), the same
//!   fault before the trip; where it does not (Ortega's test motor), the drive keeps the motor:
//!   no fault, the speed within 2 % after it, the true current within the current limit.
//!
//! Each case prints the fault's latency and the true current's peak (`--nocapture`).

mod board;

use pmsm_host_sim::board::SimBoard;
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, Run, SimConfig};
use pmsm_sensorless::drive::{DriveConfig, Fault, Limits, Mode, Reason};
use pmsm_sensorless::motor::preset;

/// The Sinano motor, Ortega's test motor and the EMRAX 228.
use board::FAIL_SAFE_MOTORS as MOTORS;
/// Both primaries.
const PRIMARIES: [ObserverKind; 2] = [ObserverKind::SlidingTorque, ObserverKind::Flux];

/// `scenario` on `motor` with `observer` primary on the board's defaults (seed 1), and the
/// drive's limits.
fn board_default_run(scenario: &str, motor: &str, observer: ObserverKind) -> (Run, Limits) {
    let m = board::motor(motor);
    let sc = Spec::built_in(scenario).unwrap().build(motor, m).unwrap();
    let cfg = SimConfig::on(SimBoard::board_defaults(&m), sc, observer);
    (run(cfg).unwrap(), DriveConfig::new(&m).limits)
}

/// The injection's time \[s].
fn t_inject(r: &Run) -> f64 {
    r.config
        .scenario
        .drive
        .as_ref()
        .unwrap()
        .injection
        .unwrap()
        .t()
}

/// The largest true stator current |i_dq| = |i_αβ| over the samples in `[t0, t1]` \[A]: the
/// peak of every phase current (amplitude-invariant frames), so above each phase's sample.
fn true_peak_a(r: &Run, t0: f64, t1: f64) -> f64 {
    r.rows
        .iter()
        .filter(|row| (t0..=t1).contains(&row.t))
        .map(|row| row.i_d.hypot(row.i_q))
        .fold(0.0, f64::max)
}

/// Where the kept motor's speed is judged after a failure: from 0.2 s after it to the end
/// \[s].
const SETTLE_S: f64 = 0.2;
/// The kept motor's mean speed error, a fraction of the command (the scenarios' 2 %).
const SPEED_TOLERANCE: f64 = 0.02;

/// What a failed sensor led to.
enum Outcome {
    /// `current_sensor` this long after the failure \[s], in this many steps.
    Fault { latency_s: f64, steps: usize },
    /// No fault: the motor kept.
    Kept,
}

/// `scenario` on every motor and primary: before the failure the drive holds the speed (the
/// window `before`); after it, either `current_sensor` (the only fault) with the true current
/// below the trip to the end of the run and the PWM off from the fault's step on, or no fault
/// with the speed held (mean error within 2 % from 0.2 s after the failure) and the true
/// current within the current limit. `must_fault`: the kept motor is no outcome here.
/// Prints the outcome, its latency and the true current's peak.
fn every_cell(scenario: &str, must_fault: bool) {
    for motor in MOTORS {
        for observer in PRIMARIES {
            let (r, l) = board_default_run(scenario, motor, observer);
            let label = format!("{scenario} {motor} {}", observer.name());
            let s = Summary::of(&r);
            assert!(
                !s.lost_lock && !s.reasons.iter().any(|w| w.starts_with("window before")),
                "{label}: {:?}",
                s.reasons
            );
            let t0 = t_inject(&r);
            let faults: Vec<(f64, Reason)> = r
                .transitions
                .iter()
                .filter(|(_, tr)| matches!(tr.reason, Reason::Fault(_)))
                .map(|&(t, tr)| (t, tr.reason))
                .collect();
            let outcome = match faults.as_slice() {
                [] => Outcome::Kept,
                [(t_fault, reason)] => {
                    assert_eq!(*reason, Reason::Fault(Fault::CurrentSensor), "{label}");
                    assert_eq!(r.drive_fault, Some(Fault::CurrentSensor), "{label}");
                    // Found in the step: off in that step.
                    for row in r.rows.iter().filter(|row| row.t >= *t_fault) {
                        assert_eq!(row.mode, Some(Mode::Fault), "{label} at {} s", row.t);
                        assert_eq!(
                            (row.v_alpha, row.v_beta),
                            (0.0, 0.0),
                            "{label} at {}",
                            row.t
                        );
                    }
                    Outcome::Fault {
                        latency_s: t_fault - t0,
                        steps: r.fault_step.unwrap(),
                    }
                }
                more => panic!("{label}: more than one fault: {more:?}"),
            };
            let before = true_peak_a(&r, t0 - 0.4, t0);
            let after = true_peak_a(&r, t0, f64::INFINITY);
            let limits = format!("trip {:.2} A, limit {:.2} A", l.i_trip_a, l.i_max_a);
            match outcome {
                Outcome::Fault { latency_s, steps } => {
                    let to_fault = true_peak_a(&r, t0, t0 + latency_s);
                    eprintln!(
                        "{label}: current_sensor {:.2} ms after the failure ({steps} steps); \
                         true |i| peak {to_fault:.2} A to the fault, {after:.2} A to the end \
                         ({before:.2} A before the failure); {limits}",
                        1e3 * latency_s
                    );
                    assert!(latency_s >= 0.0, "{label}: {latency_s} s");
                    assert!(after < f64::from(l.i_trip_a), "{label}: {after} A");
                }
                Outcome::Kept => {
                    let speed_err = mean_speed_error(&r, t0 + SETTLE_S);
                    eprintln!(
                        "{label}: kept, no fault; true |i| peak {after:.2} A after the failure \
                         ({before:.2} A before it); {limits}; mean speed error from {:.1} s \
                         {:.2} %",
                        t0 + SETTLE_S,
                        100.0 * speed_err
                    );
                    assert!(!must_fault, "{label}: no fault");
                    assert!(after <= f64::from(l.i_max_a), "{label}: {after} A");
                    assert!(speed_err.abs() <= SPEED_TOLERANCE, "{label}: {speed_err}");
                }
            }
        }
    }
}

/// The mean of (true speed − command)/|command| from `t0` on.
fn mean_speed_error(r: &Run, t0: f64) -> f64 {
    let rows: Vec<_> = r.rows.iter().filter(|row| row.t >= t0).collect();
    rows.iter()
        .map(|row| (row.speed_rpm - row.speed_cmd_rpm) / row.speed_cmd_rpm.abs())
        .sum::<f64>()
        / rows.len() as f64
}

#[test]
fn a_stuck_sensor_faults_before_the_trip() {
    every_cell("fault-sensor-stuck", true);
}

#[test]
fn a_zeroed_sensor_faults_before_the_trip() {
    every_cell("fault-sensor-zero", true);
}

/// 10 % low: a fault before the trip where a tenth of the phase current passes the threshold
/// (the Sinano motor, at its current limit under this load), a kept motor within the current
/// limit where it does not (Ortega's test motor).
#[test]
fn a_sensor_10_percent_low_faults_before_the_trip_or_keeps_the_motor() {
    every_cell("fault-sensor-gain", false);
}

/// The injection's keys are checked: a gain needs `gain`, a phase is a, b or c, a stuck
/// sensor takes no gain.
#[test]
fn the_sensor_injection_keys_are_checked() {
    let base = "duration_s = 1.0\nspeed = [[0.0, 1.0]]\nwindows = []\n[inject]\nt = 0.5\n";
    let m = preset("sinano").unwrap();
    let build = |extra: &str| {
        let spec = Spec::parse("x", &format!("{base}{extra}")).unwrap();
        spec.build("sinano", m)
            .map(|_| ())
            .map_err(|e| format!("{e:#}"))
    };
    assert!(build("kind = \"sensor_zero\"\n").is_ok());
    assert!(build("kind = \"sensor_stuck\"\nphase = \"c\"\n").is_ok());
    assert!(build("kind = \"sensor_gain\"\nphase = \"b\"\ngain = 0.9\n").is_ok());
    let e = build("kind = \"sensor_gain\"\n").unwrap_err();
    assert!(e.contains("inject.gain"), "{e}");
    let e = build("kind = \"sensor_zero\"\nphase = \"d\"\n").unwrap_err();
    assert!(e.contains("inject.phase"), "{e}");
    let e = build("kind = \"sensor_stuck\"\ngain = 0.9\n").unwrap_err();
    assert!(e.contains("inject.gain"), "{e}");
}
