//! The control rate from the motor (issue #26, `pmsm_sensorless::rate`): the rule's choices
//! (4 kHz for the presets, 20 samples per electrical period where a divisor of the 20 kHz PWM
//! gives them, the bound named where none does), the schedule that follows the rate (steps
//! per 1 kHz task, the task-stall count in milliseconds), and a fast motor
//! (`host-sim/motors/outrunner-7pp-6900rpm.toml`, 805 Hz electrical at rated speed) caught at
//! ±100 % of rated speed on the board's defaults at the rate the configuration chooses
//! (20 kHz), with both primaries, with and without the B-G431B-ESC1's update delay of one PWM
//! period.

use pmsm_host_sim::motor_file;
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, SimConfig};
use pmsm_sensorless::drive::{DriveConfig, Mode};
use pmsm_sensorless::motor::{Motor, PRESETS};
use pmsm_sensorless::rate::{control_rate, CpuBudget, RateBound};
use pmsm_sensorless::schedule::{Schedule, STEPS_WITHOUT_TICK_MAX, TICKS_MISSED_MAX};
use std::path::PathBuf;

fn motor(file: &str) -> Motor {
    let p = PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("motors")
        .join(file);
    motor_file::load(&p).unwrap().1
}

/// The rule on the board's 20 kHz PWM: the smallest of 4, 5, 10, 20 kHz at or above 20 f_e.
#[test]
fn the_rate_follows_the_motor() {
    let cpu = CpuBudget::BOARD;
    // The budget allows the PWM rate: (0.15 · 170 MHz − 1500 · 1 kHz)/1100 = 21.8 kHz.
    assert!((cpu.rate_max_hz() - 21_818.18).abs() < 1.0);
    for (n, rpm, rate) in [
        (4, 1000.0, 4000.0),  // Sinano: 66.7 Hz electrical
        (2, 6000.0, 4000.0),  // 200 Hz: exactly 20 samples at 4 kHz
        (7, 1800.0, 5000.0),  // 210 Hz
        (5, 3000.0, 5000.0),  // 250 Hz
        (4, 4000.0, 10000.0), // 266.7 Hz: 5.33 kHz wanted, 10 kHz the next divisor
        (7, 6900.0, 20000.0), // 805 Hz
    ] {
        let c = control_rate(n, rpm, 20_000.0, &cpu);
        assert_eq!(c.rate_hz, rate, "N {n} at {rpm} rpm");
        assert!(c.samples_per_period >= 20.0, "N {n} at {rpm} rpm");
        assert_eq!(c.bound, None);
    }
    // 4 kHz electrical: 20 kHz gives 5 samples, the PWM bounds it.
    let drone = control_rate(7, 34_272.0, 20_000.0, &cpu);
    assert_eq!(drone.rate_hz, 20_000.0);
    assert!((drone.samples_per_period - 5.0).abs() < 0.01);
    assert_eq!(drone.bound, Some(RateBound::Pwm));
    // A 40 kHz PWM: 40 kHz would be 1760 cycles' worth at 15 %: the CPU bounds it at 20 kHz.
    let fast_pwm = control_rate(7, 34_272.0, 40_000.0, &cpu);
    assert_eq!(fast_pwm.rate_hz, 20_000.0);
    assert_eq!(fast_pwm.bound, Some(RateBound::Cpu));
    // Every preset keeps the papers' 4 kHz (their figures and the matrices unchanged).
    for m in PRESETS {
        assert_eq!(DriveConfig::new(&m).rate_hz, 4000.0, "{}", m.name);
    }
}

/// The drive's configuration: the drone motor builds at 20 kHz with a `rate_hz` warning
/// naming the bound; the fast outrunner at 20 kHz without one.
#[test]
fn the_configuration_says_where_20_samples_cannot_be_had() {
    let drone = DriveConfig::new(&motor("zoo/drone-tmotor-f60pro-v-2550kv.toml"));
    assert_eq!(drone.rate_hz, 20_000.0);
    let d = drone.derived().unwrap();
    let w = d.warnings.iter().flatten().find(|w| w.field == "rate_hz");
    let w = w.expect("a rate_hz warning");
    assert!((w.limit - 79_968.0).abs() < 10.0, "{w:?}");
    assert!(w.what.contains("PWM frequency"), "{w:?}");
    let fast = DriveConfig::new(&motor("outrunner-7pp-6900rpm.toml"));
    assert_eq!(fast.rate_hz, 20_000.0);
    let d = fast.derived().unwrap();
    assert!(d.warnings.iter().flatten().all(|w| w.field != "rate_hz"));
}

/// Steps per 1 kHz task and the task-stall count follow the rate; a rate that is not a
/// multiple of 1 kHz is refused by name.
#[test]
fn the_schedule_follows_the_rate() {
    assert_eq!(
        Schedule::default(),
        Schedule::at("rate_hz", 4000.0).unwrap()
    );
    assert_eq!(
        Schedule::default().steps_without_tick_max(),
        STEPS_WITHOUT_TICK_MAX
    );
    for (rate, steps) in [(4000.0, 4), (5000.0, 5), (10_000.0, 10), (20_000.0, 20)] {
        let s = Schedule::at("rate_hz", rate).unwrap();
        assert_eq!(s.steps_per_tick(), steps);
        assert_eq!(s.steps_without_tick_max(), steps * TICKS_MISSED_MAX);
        // The slot counts 0..steps and wraps.
        let mut slot = 0;
        for _ in 0..steps {
            slot = s.next_slot(slot);
        }
        assert_eq!(slot, 0);
    }
    let e = Schedule::at("rate_hz", 4500.0).unwrap_err();
    assert_eq!(e.field(), "rate_hz");
    let mut cfg = DriveConfig::new(&PRESETS[0]);
    cfg.rate_hz = 4500.0;
    assert_eq!(cfg.build_flux_primary().unwrap_err().field(), "rate_hz");
}

/// The fast outrunner caught at ±100 % of rated speed (805 Hz electrical) on the board's
/// defaults (20 kHz PWM, 500 ns dead time, 1 % noise, 2 % offset) at the configuration's
/// rate, 20 kHz: both primaries pass the scenario's verdict (closed loop within 50 ms, the
/// speed held within 2 %), without and with the update delay of one PWM period (50 µs,
/// modelled by the plant and compensated by the drive).
#[test]
fn a_fast_motor_is_caught_at_full_speed() {
    let m = motor("outrunner-7pp-6900rpm.toml");
    catch_at_full_speed(m, &[0.0, 50e-6]);
}

/// The zoo's T-motor drone motor, 4 kHz electrical at its rated speed: five samples per
/// electrical period at 20 kHz, 72° per step. The catch hands over with the terminal voltage of
/// the last PWM-off period extrapolated as the observers' input (`catch.rs`); with none, the
/// observers stood still for the first step and the current loop tripped over-current 0.1 ms
/// later, every primary and seed. Not yet with the B-G431B-ESC1's update delay of one PWM
/// period: the same trip (112° at the hand-over's second step), an open point.
#[test]
fn a_drone_motor_at_five_samples_per_period_is_caught_at_full_speed() {
    let m = motor("zoo/drone-tmotor-f60pro-v-2550kv.toml");
    catch_at_full_speed(m, &[0.0]);
}

fn catch_at_full_speed(m: Motor, delays_s: &[f64]) {
    for scenario in ["sup-catch-100", "sup-catch-neg100"] {
        for observer in [ObserverKind::SlidingTorque, ObserverKind::Flux] {
            for &delay_s in delays_s {
                let sc = Spec::built_in(scenario).unwrap().build(m.name, m).unwrap();
                let board = pmsm_host_sim::board::SimBoard {
                    update_delay_s: delay_s,
                    ..pmsm_host_sim::board::SimBoard::board_defaults(&m)
                };
                let cfg = SimConfig::on(board, sc, observer);
                assert_eq!(cfg.rate_hz, 20_000.0);
                let r = run(cfg).unwrap();
                let label = format!("{scenario} {} delay {delay_s}", observer.name());
                let s = Summary::of(&r);
                assert!(s.pass, "{label}: {:?}", s.reasons);
                assert!(r.drive_fault.is_none(), "{label}");
                let first_sensorless = r
                    .transitions
                    .iter()
                    .find(|(_, t)| t.to == Mode::Sensorless)
                    .map(|(t, _)| *t);
                let t = first_sensorless.expect("sensorless");
                assert!(t < 0.05, "{label}: sensorless at {t} s");
            }
        }
    }
}
