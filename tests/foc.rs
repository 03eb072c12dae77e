//! FOC configuration errors and safe outputs on bad input.

use pmsm_sensorless::foc::{FocConfig, FocInput, FocState, Reference};
use pmsm_sensorless::frames::Abc;
use pmsm_sensorless::motor::HORNG_SINANO;
use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};

fn config() -> FocConfig {
    FocConfig::new(HORNG_SINANO.params, HORNG_SINANO.rated_torque_current_a())
}

#[test]
fn impossible_settings_name_the_field() {
    type Case = (fn(&mut FocConfig), &'static str, f32);
    let cases: [Case; 7] = [
        (
            |c| c.current_bandwidth_hz = 1000.0,
            "current_bandwidth_hz",
            1000.0,
        ),
        (
            |c| c.speed_bandwidth_hz = 100.0,
            "speed_bandwidth_hz",
            100.0,
        ),
        (
            |c| c.current_rate_hz = f32::NAN,
            "current_rate_hz",
            f32::NAN,
        ),
        (|c| c.speed_divider = 0, "speed_divider", 0.0),
        (|c| c.i_max_a = -1.0, "i_max_a", -1.0),
        (|c| c.motor.l_h = 0.0, "l_h", 0.0),
        (
            |c| c.angle_advance_periods = f32::INFINITY,
            "angle_advance_periods",
            f32::INFINITY,
        ),
    ];
    for (mutate, field, value) in cases {
        let mut c = config();
        mutate(&mut c);
        let e = c.build().unwrap_err();
        assert_eq!(e.field, field);
        assert_eq!(e.value.to_bits(), value.to_bits(), "{e}");
        assert!(!e.allowed.contains(value), "{e}");
    }
    assert!(config().build().is_ok());
}

fn any_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        -1e3f32..1e3,
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(f32::NEG_INFINITY),
        Just(0.0f32),
        Just(f32::MAX),
        Just(-f32::MAX),
    ]
}

proptest! {
    #![proptest_config(Config {
        cases: 2000,
        rng_seed: RngSeed::Fixed(0x5eed),
        failure_persistence: None,
        ..Config::default()
    })]

    /// Any input sequence, finite or not: no panic, duties in [0, 1], state stays finite.
    #[test]
    fn duties_stay_in_unit_interval(steps in proptest::collection::vec(proptest::array::uniform8(any_f32()), 1..40)) {
        let foc = config().build().unwrap();
        let mut st = FocState::default();
        for x in steps {
            let out = st.step(&foc, &FocInput {
                i_abc: Abc::new(x[0], x[1], x[2]),
                v_bus: x[3],
                theta_e: x[4],
                omega_m: x[5],
                omega_m_ref: x[6],
                torque_ff_nm: x[7],
            });
            for d in [out.duties.a, out.duties.b, out.duties.c] {
                prop_assert!((0.0..=1.0).contains(&d), "duty {d}");
            }
            // Bad samples never poison the controller's memory.
            for s in [st.i_q_ref, st.speed.integral, st.current.integral_d, st.current.integral_q] {
                prop_assert!(s.is_finite(), "state {st:?}");
            }
        }
    }
}

/// A voltage the current loop cuts lands just inside the inverter's circle (within 1e-5 of
/// `v_bus/√3`), so that after the rotation to αβ SVPWM finds it in its linear range and applies
/// it as it is: the applied vector, fed to SVPWM again, is never found saturated.
#[test]
fn a_cut_voltage_stays_inside_the_linear_range() {
    use pmsm_sensorless::foc::CurrentLoopState;
    use pmsm_sensorless::frames::{AlphaBeta, Dq};
    use pmsm_sensorless::svpwm::svpwm;
    let foc = config().build().unwrap();
    let (mut worst_low, mut found_outside) = (0.0f64, 0usize);
    for k in 0..20_000u32 {
        let theta = 0.000_314_2 * k as f32 - std::f32::consts::PI;
        let v_bus = 20.0 + (k % 97) as f32 * 0.5;
        let omega_m = (k % 13) as f32 * 40.0 - 240.0;
        let i = AlphaBeta::new(0.3 * (k % 7) as f32 - 1.0, 0.2 * (k % 5) as f32 - 0.4);
        let input = FocInput {
            i_abc: i.to_abc(),
            v_bus,
            theta_e: theta,
            omega_m,
            omega_m_ref: 0.0,
            torque_ff_nm: 0.0,
        };
        let mut st = CurrentLoopState::default();
        let req = input.request(&foc, Reference::Current(Dq::new(-40.0, 60.0)));
        let out = foc.run(&mut st, &req, input.i_ab(), input.v_bus);
        assert!(out.saturated);
        let v_max = f64::from(v_bus) / 3f64.sqrt();
        let mag = f64::from(out.v_ab.alpha).hypot(f64::from(out.v_ab.beta));
        assert!(mag <= v_max, "{mag} > {v_max}");
        worst_low = worst_low.max(1.0 - mag / v_max);
        if svpwm(out.v_ab, v_bus).saturated {
            found_outside += 1;
        }
    }
    println!("cut voltages: at most {worst_low:.2e} below v_bus/√3; {found_outside} re-cut");
    assert!(worst_low < 1e-5, "{worst_low}");
    assert_eq!(found_outside, 0);
}

proptest! {
    #![proptest_config(Config {
        cases: 3000,
        rng_seed: RngSeed::Fixed(0x5eed),
        failure_persistence: None,
        ..Config::default()
    })]

    /// The voltage the FOC reports as applied is the one its duties make, and the duties stay
    /// in [0, 1], also when the caller's output rotation is not a unit vector (the voltage then
    /// leaves the circle the current loop limited it to, up to or beyond the PWM's hexagon)
    /// and on a negative bus reading.
    #[test]
    fn applied_voltage_is_what_the_duties_make(
        theta in -3.2f32..3.2,
        out_scale in 0.0f32..4.0,
        out_angle in -3.2f32..3.2,
        i in proptest::array::uniform3(-5.0f32..5.0),
        v_bus in prop_oneof![10.0f32..100.0, -100.0f32..-1e-3],
        omega_m in -400.0f32..400.0,
        omega_m_ref in -400.0f32..400.0,
    ) {
        use pmsm_sensorless::frames::SinCos;
        use pmsm_sensorless::svpwm::duties_to_phase_voltages;
        let foc = config().build().unwrap();
        let mut st = FocState::default();
        let input = FocInput {
            i_abc: Abc::new(i[0], i[1], i[2]),
            v_bus,
            theta_e: theta,
            omega_m,
            omega_m_ref,
            torque_ff_nm: 0.0,
        };
        let sc = SinCos::of(theta);
        let rot = SinCos::of(out_angle);
        let sc_out = SinCos { sin: out_scale * rot.sin, cos: out_scale * rot.cos };
        for _ in 0..3 {
            let out = st.step_at(&foc, &input, sc, sc_out);
            for d in [out.duties.a, out.duties.b, out.duties.c] {
                prop_assert!((0.0..=1.0).contains(&d), "duty {d}");
            }
            let made = duties_to_phase_voltages(out.duties, v_bus).to_alpha_beta();
            let err = (made.alpha - out.v_ab.alpha).hypot(made.beta - out.v_ab.beta);
            prop_assert!(err <= 1e-5 * v_bus.abs(), "made {made:?}, reported {:?}", out.v_ab);
        }
    }
}

/// A negative bus reading gives zero volts and leaves the current loop's integrators where
/// they were: the next step on a good bus is the step a fresh loop would take.
#[test]
fn a_negative_bus_gives_zero_volts_and_holds_the_integrators() {
    use pmsm_sensorless::foc::CurrentLoopState;
    use pmsm_sensorless::frames::Dq;
    use pmsm_sensorless::svpwm::Duties;
    let foc = config().build().unwrap();
    let input = |v_bus| FocInput {
        i_abc: Abc::new(0.0, 0.0, 0.0),
        v_bus,
        theta_e: 0.3,
        omega_m: 50.0,
        omega_m_ref: 0.0,
        torque_ff_nm: 0.0,
    };
    let i_ref = Dq::new(0.0, 0.1);
    let step = |st: &mut CurrentLoopState, input: FocInput| {
        let req = input.request(&foc, Reference::Current(i_ref));
        foc.run(st, &req, input.i_ab(), input.v_bus)
    };
    let mut st = CurrentLoopState::default();
    for _ in 0..400 {
        let out = step(&mut st, input(-24.0));
        assert_eq!(out.duties, Duties::NEUTRAL);
        assert_eq!((out.v_ab.alpha, out.v_ab.beta), (0.0, 0.0));
    }
    assert_eq!(st, CurrentLoopState::default());
    let after = step(&mut st, input(24.0));
    let fresh = step(&mut CurrentLoopState::default(), input(24.0));
    assert_eq!(after, fresh);
}

/// On the voltage circle the current loop holds its integrators (anti-windup), but the q one
/// under a braking command (`i_q*` against the rotation), where it moves to shorten `v_q`
/// (`CurrentLoop::update`): a rotor its load let go of is braked, not held by a motoring
/// `R i_q`.
#[test]
fn on_the_circle_only_a_braking_command_releases_the_q_integrator() {
    use pmsm_sensorless::foc::CurrentLoopState;
    use pmsm_sensorless::frames::Dq;
    let foc = config().build().unwrap();
    let current = foc.current_loop();
    // The Sinano motor at 200 rad/s: 46 V of back-EMF against 3 V of limit.
    let (omega_e, v_max) = (4.0 * 200.0, 3.0);
    let before = CurrentLoopState {
        integral_d: 1.0,
        integral_q: 5.0,
    };
    let i = Dq::new(0.0, 1.0);
    for (i_q_ref, released) in [(3.0, false), (-3.0, true)] {
        let mut st = before;
        let out = current.update(&mut st, i, Dq::new(0.0, i_q_ref), omega_e, v_max);
        assert!(out.saturated && out.v_dq.q > 0.0, "{i_q_ref}: {out:?}");
        assert_eq!(st.integral_d, before.integral_d, "{i_q_ref}");
        if released {
            assert!(st.integral_q < before.integral_q, "{i_q_ref}: {st:?}");
        } else {
            assert_eq!(st, before, "{i_q_ref}");
        }
    }
    // Rotating backwards, everything mirrored: a positive command brakes.
    let mirrored = CurrentLoopState {
        integral_d: -before.integral_d,
        integral_q: -before.integral_q,
    };
    let mut st = mirrored;
    let out = current.update(
        &mut st,
        Dq::new(0.0, -1.0),
        Dq::new(0.0, 3.0),
        -omega_e,
        v_max,
    );
    assert!(out.saturated && out.v_dq.q < 0.0, "{out:?}");
    assert!(st.integral_q > mirrored.integral_q, "{st:?}");
    // An unusable limit (a negative bus reading): zero volts, both held under a braking
    // command too.
    let mut st = before;
    let out = current.update(&mut st, i, Dq::new(0.0, -3.0), omega_e, -v_max);
    assert!(!out.valid && out.v_dq == Dq::default(), "{out:?}");
    assert_eq!(st, before);
}

/// On the voltage circle a salient motor's current loop (`L_q > L_d`) gives the d axis the
/// first claim while motoring (`foc/current.rs`, Quang & Dittrich's limitation): `v_d` kept
/// as the loop computed it and `v_q` of its sign cut to what the circle leaves, the vector at
/// most 0.18 % inside the circle (one Newton step of 1/√); a `v_d` beyond 95 % of the circle
/// held at 95 % and `v_q` within the rest; a braking command and a non-salient motor: the
/// vector cut along itself, within 1e-5 of the circle. Over d errors of −2 to +2 A, q
/// commands both ways, both directions of rotation and circles from 0.3 to 0.99 of the
/// vector's length.
#[test]
fn a_salient_motor_keeps_its_d_voltage_first_on_the_circle_while_motoring() {
    use pmsm_sensorless::foc::CurrentLoopState;
    use pmsm_sensorless::frames::Dq;
    let m = HORNG_SINANO.params;
    let salient = m
        .with_inductances(2.0 / 3.0 * m.l_h, 4.0 / 3.0 * m.l_h)
        .unwrap();
    let i_max = HORNG_SINANO.rated_torque_current_a();
    let foc_salient = FocConfig::new(salient, i_max).build().unwrap();
    let foc_round = config().build().unwrap();
    let (mut d_first, mut held, mut along) = (0usize, 0usize, 0usize);
    for k in 0..4_000u32 {
        let i_d = -60.0 + 0.02 * k as f32;
        let omega_e = if k % 2 == 0 { 900.0 } else { -900.0 };
        let i_q_ref = if k % 3 == 0 { -4.0 } else { 4.0 };
        let i = Dq::new(i_d + (k % 5) as f32 - 2.0, 0.5 * i_q_ref);
        let reference = Dq::new(i_d, i_q_ref);
        let motoring = i_q_ref * omega_e >= 0.0;
        for (foc, is_salient) in [(&foc_salient, true), (&foc_round, false)] {
            let current = foc.current_loop();
            let unlimited =
                current.update(&mut CurrentLoopState::default(), i, reference, omega_e, 1e6);
            // A circle from 0.3 to 0.99 of the vector's length.
            let u_mag = unlimited.v_dq.d.hypot(unlimited.v_dq.q);
            let v_max = u_mag * (0.3 + 0.69 * ((k * 7_919) % 1_000) as f32 / 1_000.0);
            let out = current.update(
                &mut CurrentLoopState::default(),
                i,
                reference,
                omega_e,
                v_max,
            );
            let (v, u) = (out.v_dq, unlimited.v_dq);
            assert!(out.saturated, "{k}");
            let mag = v.d.hypot(v.q);
            assert!(mag <= v_max, "{k}: |v| {mag}");
            // (The cut's radius is 4e-6 inside `v_max`: the share's edge is blurred by it.)
            let share = 0.95 * v_max;
            if is_salient && motoring && u.d.abs() <= share * (1.0 - 4e-6) {
                d_first += 1;
                assert_eq!(v.d, u.d, "{k}: v_d");
                assert_eq!(v.q.signum(), u.q.signum(), "{k}: v_q's sign");
                assert!(mag > (1.0 - 1.8e-3) * v_max, "{k}: d first, |v| {mag}");
            } else if is_salient && motoring && u.d.abs() > share {
                held += 1;
                assert!((v.d.abs() - share).abs() < 1e-5 * v_max, "{k}: {v:?}");
                assert_eq!(v.d.signum(), u.d.signum(), "{k}: v_d's sign");
                assert!(v.q.abs() <= 0.3123 * v_max, "{k}: {v:?}");
                assert!(v.q == u.q || v.q.abs() > 0.312 * v_max, "{k}: {v:?} {u:?}");
            } else if !is_salient || !motoring {
                along += 1;
                let along_d = u.d * v_max / u.d.hypot(u.q);
                assert!(
                    (v.d - along_d).abs() < 1e-4 * v_max,
                    "{k}: {v:?} against {u:?}"
                );
                assert!(mag > (1.0 - 1e-5) * v_max, "{k}: along itself, |v| {mag}");
            }
        }
    }
    println!(
        "{d_first} vectors cut with the d axis first, {held} with it held at its share, \
         {along} along themselves"
    );
    assert!(
        d_first > 1_000 && held > 200 && along > 1_000,
        "{d_first} {held} {along}"
    );
}
