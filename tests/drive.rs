//! The drive: start from standstill, stop and reverse, faults, and a property test of `step`.

use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::profile::Pwl;
use pmsm_host_sim::scenario::{self, Scenario};
use pmsm_host_sim::sim::{run, SimConfig};
use pmsm_sensorless::drive::{
    Command, Drive, DriveConfig, DriveInput, DriveState, Fault, Mode, StateOf,
};
use pmsm_sensorless::frames::{Abc, AlphaBeta};
use pmsm_sensorless::motor::HORNG_SINANO;
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;
use pmsm_sensorless::observer::Observer;
use pmsm_sensorless::power_stage::StageFault;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed, TestCaseError};

fn summary(sc: Scenario, kind: ObserverKind, noise_a: f64) -> Summary {
    let mut cfg = SimConfig::new(sc, kind);
    cfg.board.noise_sigma_a = noise_a;
    Summary::of(&run(cfg).unwrap())
}

/// The drive on the Sinano motor with its defaults, sliding torque observer primary.
fn sinano_drive() -> Drive<SlidingObserver, FluxPll> {
    DriveConfig::new(&HORNG_SINANO)
        .build_sliding_primary()
        .unwrap()
}

/// The drive on the Sinano motor with its defaults, flux observer primary.
fn sinano_flux_drive() -> Drive<FluxPll, SlidingObserver> {
    DriveConfig::new(&HORNG_SINANO)
        .build_flux_primary()
        .unwrap()
}

/// A sample with no current on a 48 V bus.
fn no_current_48v() -> DriveInput {
    DriveInput {
        i_abc: Abc::default(),
        v_bus: 48.0,
        v_ab_terminal: None,
        overrun: false,
        stage_fault: None,
    }
}

/// Enabled, at `speed_rpm`, no fault to clear.
fn running_at(speed_rpm: f32) -> Command {
    Command {
        enable: true,
        speed_rpm,
        clear_fault: false,
    }
}

#[test]
fn start_stop_reverse_and_test_motor_with_both_observers() {
    for sc in [scenario::start_stop_reverse(), scenario::start_test_motor()] {
        for kind in [ObserverKind::SlidingTorque, ObserverKind::Flux] {
            for noise in [0.0, 0.01] {
                let s = summary(sc.clone(), kind, noise);
                println!(
                    "{} {} noise {noise}: hand-overs at {:?} s, lowest sensorless speed {:.1} rpm",
                    sc.name,
                    kind.name(),
                    s.handovers_s,
                    s.lowest_sensorless_rpm.unwrap_or(f64::NAN)
                );
                assert_eq!(s.fault, None, "{} {} {noise}", sc.name, kind.name());
                assert!(!s.lost_lock, "{} {} {noise}", sc.name, kind.name());
                for (name, w) in &s.windows {
                    let w = w.as_ref().unwrap();
                    let rel = w.speed_err_mean_rpm / w.speed_cmd_mean_rpm;
                    println!(
                        "  {name}: speed error {:+.4} %, mean |θ err| {:.3}°",
                        100.0 * rel,
                        w.theta_err_mean_abs_deg_e
                    );
                    assert!(
                        rel.abs() < 0.01,
                        "{} {} {noise} {name}: {rel}",
                        sc.name,
                        kind.name()
                    );
                }
            }
        }
    }
}

#[test]
fn faults_turn_the_pwm_off_in_time() {
    // Overcurrent, bus and invalid samples within one step of the cause; observer loss within
    // the time without a healthy observer (20 ms = 80 steps) after both were lost: each
    // observer's mean residual (8 ms time constant) must reach ½ and stay there 3 checks
    // (10 ms = 40 steps, supervision.rs).
    let cases = [
        (scenario::fault_overcurrent(), "overcurrent", 1),
        (scenario::fault_bus_undervoltage(), "bus_undervoltage", 1),
        (scenario::fault_nan_current(), "invalid_input", 1),
        (scenario::fault_observer_loss(), "observer_loss", 80 + 40),
    ];
    for (sc, fault, max_steps) in cases {
        for kind in [ObserverKind::SlidingTorque, ObserverKind::Flux] {
            let r = run(SimConfig::new(sc.clone(), kind)).unwrap();
            let s = Summary::of(&r);
            println!(
                "{} {}: fault {:?} after {:?} steps",
                sc.name,
                kind.name(),
                s.fault,
                s.fault_step
            );
            assert_eq!(
                s.fault.as_deref(),
                Some(fault),
                "{} {}",
                sc.name,
                kind.name()
            );
            assert!(
                s.fault_step.unwrap() <= max_steps,
                "{}: {:?}",
                sc.name,
                s.fault_step
            );
            // PWM stays off from the fault on: no voltage applied.
            let t_fault = s.transitions.last().unwrap().t;
            assert!(r
                .rows
                .iter()
                .filter(|x| x.t > t_fault)
                .all(|x| x.v_alpha == 0.0 && x.v_beta == 0.0));
        }
    }
}

/// A reversal 500 → −500 rpm commanded at once goes through zero speed in sensorless
/// control, on the flux observer (the sliding observer hands over to it below its range and
/// back above it): no open loop, no alignment, no fault, no loss of lock.
#[test]
fn direct_reversal_stays_sensorless_through_zero() {
    let mut sc = scenario::start_stop_reverse();
    sc.speed_cmd_rpm = Pwl::new(vec![(0.0, 500.0), (1.5, 500.0), (1.5, -500.0)]);
    sc.duration_s = 3.5;
    sc.windows = vec![
        scenario::Window::new("w500", 1.0, 1.5),
        scenario::Window::new("w_neg500_loaded", 3.0, 3.5),
    ];
    for kind in [ObserverKind::SlidingTorque, ObserverKind::Flux] {
        let s = summary(sc.clone(), kind, 0.0);
        let reasons: Vec<_> = s.transitions.iter().map(|t| t.reason.as_str()).collect();
        println!("{}: {reasons:?}", kind.name());
        let after_start: Vec<_> = s
            .transitions
            .iter()
            .skip_while(|t| t.reason != "HandOver")
            .skip(1)
            .collect();
        assert!(
            after_start
                .iter()
                .all(|t| t.reason == "Failover" || t.reason == "PrimaryDrives"),
            "{reasons:?}"
        );
        assert!(!s.lost_lock && s.fault.is_none());
        for w in s.windows.values() {
            let w = w.as_ref().unwrap();
            assert!((w.speed_err_mean_rpm / w.speed_cmd_mean_rpm).abs() < 0.01);
        }
    }
}

#[test]
fn a_locked_rotor_is_a_stall() {
    let mut sc = scenario::start_stop_reverse();
    sc.load_shape = Pwl::constant(1.0);
    sc.load_nm = 5.0; // far beyond what the open-loop current can move
    sc.duration_s = 2.0;
    let s = summary(sc, ObserverKind::Flux, 0.0);
    assert_eq!(s.fault.as_deref(), Some("stall"));
}

#[test]
fn a_speed_collapse_under_load_is_a_stall() {
    // The load rises slowly to 5 N·m, more than the test motor's 1.5× current limit can
    // make (4.5 N·m): the speed sags at the current limit while the observers still agree.
    let mut sc = scenario::start_test_motor();
    sc.load_shape = Pwl::ramp(1.5, 0.0, 2.5, 1.0);
    sc.load_nm = 5.0;
    sc.duration_s = 3.5;
    let s = summary(sc, ObserverKind::Flux, 0.0);
    println!("{:?}", s.transitions.last());
    assert_eq!(s.fault.as_deref(), Some("stall"));
}

/// A fault of the power stage's own protection (the board's hardware over-current break, its
/// over-temperature) faults the drive by name, the PWM off in the same step, latched until
/// cleared.
#[test]
fn a_stage_fault_is_named_and_latched() {
    let drive = sinano_drive();
    let ok = no_current_48v();
    let run = running_at(500.0);
    for (f, named) in [
        (StageFault::HardwareOvercurrent, Fault::HardwareOvercurrent),
        (StageFault::OverTemperature, Fault::OverTemperature),
    ] {
        let mut st = DriveState::default();
        assert!(drive.step(&mut st, &ok, &run).duties.is_some());
        let tripped = DriveInput {
            stage_fault: Some(f),
            ..ok
        };
        let out = drive.step(&mut st, &tripped, &run);
        assert!(out.duties.is_none());
        assert_eq!(st.mode(), Mode::Fault);
        assert_eq!(st.fault(), Some(named));
        for _ in 0..10 {
            assert!(drive.step(&mut st, &ok, &run).duties.is_none(), "latched");
        }
    }
}

#[test]
fn a_fault_latches_until_cleared() {
    let drive = sinano_drive();
    let mut st = DriveState::default();
    let ok = no_current_48v();
    let run = running_at(500.0);
    assert!(drive.step(&mut st, &ok, &run).duties.is_some());
    let out = drive.step(
        &mut st,
        &DriveInput {
            overrun: true,
            ..ok
        },
        &run,
    );
    assert!(out.duties.is_none());
    assert_eq!(st.mode(), Mode::Fault);
    for _ in 0..10 {
        assert!(drive.step(&mut st, &ok, &run).duties.is_none(), "latched");
    }
    let out = drive.step(
        &mut st,
        &ok,
        &Command {
            clear_fault: true,
            ..run
        },
    );
    assert!(out.duties.is_none());
    assert_eq!(st.mode(), Mode::Idle);
    assert!(
        drive.step(&mut st, &ok, &run).duties.is_none(),
        "no restart while enable is held"
    );
    drive.step(
        &mut st,
        &ok,
        &Command {
            enable: false,
            ..run
        },
    );
    assert!(
        drive.step(&mut st, &ok, &run).duties.is_some(),
        "runs again after enable cycles"
    );
}

#[test]
fn a_fault_found_in_the_step_that_asks_to_clear_stays_latched() {
    let drive = sinano_flux_drive();
    let mut st = DriveState::default();
    let ok = no_current_48v();
    let run = Command {
        enable: true,
        speed_rpm: 500.0,
        clear_fault: true,
    };
    drive.step(&mut st, &ok, &run);
    let over = DriveInput {
        i_abc: Abc::new(10.0, -5.0, -5.0),
        ..ok
    }; // above the 6.75 A trip
    let out = drive.step(&mut st, &over, &run);
    assert!(out.duties.is_none());
    assert_eq!(st.fault(), Some(pmsm_sensorless::drive::Fault::Overcurrent));
    assert_eq!(st.mode(), Mode::Fault);
}

#[test]
fn starting_on_a_low_bus_or_with_a_bad_command_is_a_fault() {
    use pmsm_sensorless::drive::Fault;
    let drive = sinano_flux_drive();
    let ok = no_current_48v();
    let run = running_at(500.0);
    let mut st = DriveState::default();
    let out = drive.step(&mut st, &DriveInput { v_bus: 0.0, ..ok }, &run);
    assert!(out.duties.is_none());
    assert_eq!(st.fault(), Some(Fault::BusUndervoltage));
    let mut st = DriveState::default();
    let out = drive.step(
        &mut st,
        &ok,
        &Command {
            speed_rpm: f32::NAN,
            ..run
        },
    );
    assert!(out.duties.is_none());
    assert_eq!(st.fault(), Some(Fault::InvalidInput));
    // Idle with a low bus and no start request is not a fault.
    let mut st = DriveState::default();
    drive.step(
        &mut st,
        &DriveInput { v_bus: 0.0, ..ok },
        &Command {
            enable: false,
            ..run
        },
    );
    assert_eq!(st.fault(), None);
}

fn wild_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => -10.0f32..10.0,
        1 => -1e3f32..1e3,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(0.0f32),
        1 => Just(f32::MAX),
        1 => Just(-f32::MAX),
        1 => Just(f32::MIN_POSITIVE),
    ]
}

fn bus() -> impl Strategy<Value = f32> {
    prop_oneof![4 => Just(48.0f32), 2 => 0.0f32..100.0, 1 => wild_f32()]
}

fn step_input() -> impl Strategy<Value = (DriveInput, Command)> {
    (
        wild_f32(),
        wild_f32(),
        wild_f32(),
        bus(),
        prop::bool::weighted(0.01),
        wild_f32(),
        prop::bool::weighted(0.9),
        prop::bool::weighted(0.05),
        prop::option::of((wild_f32(), wild_f32())),
    )
        .prop_map(
            |(a, b, c, v_bus, overrun, speed_rpm, enable, clear_fault, v_t)| {
                (
                    DriveInput {
                        i_abc: Abc::new(a, b, c),
                        v_bus,
                        v_ab_terminal: v_t.map(|(alpha, beta)| AlphaBeta::new(alpha, beta)),
                        overrun,
                        stage_fault: None,
                    },
                    Command {
                        enable,
                        speed_rpm,
                        clear_fault,
                    },
                )
            },
        )
}

proptest! {
    #![proptest_config(Config {
        cases: 10_000,
        rng_seed: RngSeed::Fixed(0xd21e),
        failure_persistence: None,
        ..Config::default()
    })]

    /// 10,000 random sequences of samples and commands, NaN, ±Inf, huge values and zero bus
    /// included: `step` never panics and never returns a duty outside [0, 1].
    #[test]
    fn step_never_panics_and_duties_stay_in_range(seq in prop::collection::vec(step_input(), 1..60), flux_primary in prop::bool::ANY) {
        if flux_primary {
            check_sequence(&sinano_flux_drive(), &seq)?;
        } else {
            check_sequence(&sinano_drive(), &seq)?;
        }
    }
}

/// `drive` from idle through `seq`: every duty in [0, 1], none while faulted.
fn check_sequence<P: Observer, M: Observer>(
    drive: &Drive<P, M>,
    seq: &[(DriveInput, Command)],
) -> Result<(), TestCaseError> {
    let mut st = StateOf::<P, M>::default();
    for (input, cmd) in seq {
        let out = drive.step(&mut st, input, cmd);
        if st.tick_due() {
            drive.tick(&mut st, cmd);
            drive.background(&mut st);
        }
        if let Some(d) = out.duties {
            for x in [d.a, d.b, d.c] {
                prop_assert!((0.0..=1.0).contains(&x), "duty {x}");
            }
        }
        if st.mode() == Mode::Fault {
            prop_assert!(out.duties.is_none());
        }
    }
    Ok(())
}

#[test]
fn telemetry_is_a_small_fixed_size_record() {
    let size = std::mem::size_of::<pmsm_sensorless::drive::Telemetry>();
    println!("Telemetry: {size} bytes");
    assert!(size <= 64, "{size}");
}

#[test]
fn telemetry_reads_the_state_the_step_left() {
    use pmsm_sensorless::drive::Telemetry;
    use pmsm_sensorless::frames::AlphaBeta;
    use pmsm_sensorless::observer::Rotor;
    let drive = sinano_drive();
    let mut st = DriveState::default();
    // PWM off: only the mode.
    assert_eq!(drive.telemetry(&st), Telemetry::default());
    let input = no_current_48v();
    let cmd = running_at(500.0);
    drive.step(&mut st, &input, &cmd);
    let tel = drive.telemetry(&st);
    assert_eq!(tel.mode, Mode::Align);
    assert_eq!((tel.theta_e_control, tel.speed_rpm), (0.0, 0.0));
    // Sensorless at a rotor state the observers are seeded with: the record shows their
    // estimates.
    let rotor = Rotor {
        theta_e: 0.5,
        omega_m: 50.0,
        load_nm: 0.1,
    };
    let st = drive.running_state(AlphaBeta::default(), rotor);
    let tel = drive.telemetry(&st);
    assert_eq!(tel.mode, Mode::Sensorless);
    assert_eq!((tel.theta_e_primary, tel.load_nm), (0.5, Some(0.1)));
    assert_eq!(tel.theta_e_control, tel.theta_e_primary);
    assert_eq!(tel.theta_e_primary, st.primary().theta_e);
    // The flux observer's angle is read out of its rotor-flux vector Φ·(cos 0.5, sin 0.5).
    assert!(
        (tel.theta_e_monitor - 0.5).abs() < 1e-6,
        "{}",
        tel.theta_e_monitor
    );
    assert!((tel.speed_rpm - 50.0 * pmsm_sensorless::units::RPM_PER_RAD_S).abs() < 1e-3);
}

/// The open-loop frame is kept as the sin/cos of θ_ol, turned by `N ω_ol T` every step: over a
/// long open-loop run (50 s without current after the alignment, so no observer locks and the
/// drive stays in open loop, its time limit set past that) its
/// length stays 1 and its angle follows the f64 integral of `N ω_ol T`.
#[test]
fn open_loop_frame_turns_at_the_ramp_speed_and_stays_unit_length() {
    let mut cfg = DriveConfig::new(&HORNG_SINANO);
    // The open loop's time limit past the 50 s (no current: no observer locks).
    cfg.start.handover_timeout_s = 60.0;
    let drive = cfg.build_sliding_primary().unwrap();
    let n = f64::from(HORNG_SINANO.params.n());
    let ts = 1.0 / f64::from(cfg.rate_hz);
    let mut st = DriveState::default();
    let input = no_current_48v();
    let cmd = running_at(0.5 * cfg.start.handover_rpm);
    let (mut theta_ref, mut worst_angle, mut worst_len) = (0.0f64, 0.0f64, 0.0f64);
    // The alignment on a winding at rest, `L di/dt = v − R i` (forward Euler over a step):
    // its current follows the drive's voltage, as the alignment checks (else
    // `Fault::OpenWinding`); then no current.
    let p = HORNG_SINANO.params;
    let per_step = p.r_ohm * ts as f32 / p.l_h;
    let mut i_winding = AlphaBeta::default();
    let steps = 50 * 4000;
    for _ in 0..steps {
        // The 1 kHz task between steps (it sets the ramp's speed the coming steps turn at).
        if st.tick_due() {
            drive.tick(&mut st, &cmd);
        }
        let was_open_loop = st.mode() == Mode::OpenLoop;
        let sample = if st.mode() == Mode::Align {
            let v = st.v_ab_applied();
            i_winding = AlphaBeta::new(
                i_winding.alpha + per_step * (v.alpha / p.r_ohm - i_winding.alpha),
                i_winding.beta + per_step * (v.beta / p.r_ohm - i_winding.beta),
            );
            DriveInput {
                i_abc: i_winding.to_abc(),
                ..input
            }
        } else {
            input
        };
        drive.step(&mut st, &sample, &cmd);
        if st.mode() != Mode::OpenLoop {
            assert!(!was_open_loop, "left open loop: {:?}", st.mode());
            continue;
        }
        if was_open_loop {
            // The open-loop speed ω_ol [rpm], which telemetry reports as the reference.
            let speed_ol_rpm = drive.telemetry(&st).speed_ref_rpm;
            theta_ref += n * f64::from(speed_ol_rpm) * pmsm_host_sim::RAD_S_PER_RPM * ts;
        }
        let theta = f64::from(drive.telemetry(&st).theta_e_control);
        let err = (theta - theta_ref + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        worst_angle = worst_angle.max(err.abs());
        let frame = st.open_loop_frame().unwrap();
        let (s, c) = (f64::from(frame.sin), f64::from(frame.cos));
        worst_len = worst_len.max((s.hypot(c) - 1.0).abs());
    }
    println!(
        "open loop at {} rpm for 50 s ({theta_ref:.1} rad): worst angle error {worst_angle:.2e} rad, \
         worst |length − 1| {worst_len:.2e}",
        cmd.speed_rpm
    );
    assert_eq!(st.mode(), Mode::OpenLoop);
    // 1e-4 rad over 1042 rad: a frequency error of 1e-7 relative would reach it; the f32
    // rounding of one rotation (a few 1e-8 rad) does not accumulate to that.
    assert!(worst_angle < 1e-4, "{worst_angle}");
    assert!(worst_len < 1e-6, "{worst_len}");
}
