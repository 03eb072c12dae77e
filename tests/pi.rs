//! PI controller: clamp and anti-windup.

use pmsm_sensorless::pi::{Held, PiConfig, PiState};

#[test]
fn anti_windup_recovers_at_once_after_saturation() {
    let pi = PiConfig {
        kp: 0.5,
        ki: 100.0,
        out_min: -1.0,
        out_max: 1.0,
    }
    .build(1e-3)
    .unwrap();
    let mut s = PiState::default();
    // A long positive error saturates the output.
    for _ in 0..10_000 {
        let u = pi.update(&mut s, 10.0, 0.0);
        assert!((-1.0..=1.0).contains(&u));
    }
    assert!(
        s.integral <= 1.0,
        "integrator bounded by the clamp: {}",
        s.integral
    );
    // When the error reverses, the output leaves saturation within a few samples; a wound-up
    // integrator (10 s of error × ki) would hold it at the limit for about 100 samples.
    let mut steps = 0;
    while pi.update(&mut s, -1.0, 0.0) >= 1.0 {
        steps += 1;
        assert!(steps < 3, "still saturated after {steps} samples");
    }
}

#[test]
fn integral_action_removes_steady_error() {
    // Plant x[k+1] = x[k] + 0.1 (u − d): integrator must cancel the disturbance d.
    let pi = PiConfig {
        kp: 1.0,
        ki: 20.0,
        out_min: -5.0,
        out_max: 5.0,
    }
    .build(1e-2)
    .unwrap();
    let mut s = PiState::default();
    let (mut x, d, r) = (0.0f32, 0.7f32, 1.0f32);
    for _ in 0..2000 {
        let u = pi.update(&mut s, r - x, 0.0);
        x += 0.1 * (u - d);
    }
    assert!((x - r).abs() < 1e-4, "x = {x}");
    assert!((s.integral - d).abs() < 1e-3);
}

#[test]
fn bad_settings_and_inputs() {
    let cfg = PiConfig {
        kp: 1.0,
        ki: 1.0,
        out_min: 1.0,
        out_max: -1.0,
    };
    assert!(cfg.build(1e-3).is_err());
    assert_eq!(
        PiConfig {
            kp: f32::NAN,
            ..cfg
        }
        .build(1e-3)
        .unwrap_err()
        .field(),
        "kp"
    );
    let pi = PiConfig {
        kp: 1.0,
        ki: 1.0,
        out_min: -1.0,
        out_max: 1.0,
    }
    .build(1e-3)
    .unwrap();
    assert_eq!(
        PiConfig {
            kp: 1.0,
            ki: 1.0,
            out_min: -1.0,
            out_max: 1.0
        }
        .build(0.0)
        .unwrap_err()
        .field(),
        "ts_s"
    );
    let mut s = PiState { integral: 0.3 };
    assert_eq!(pi.update(&mut s, f32::NAN, 0.0), 0.3);
    assert_eq!(pi.update(&mut s, 1.0, f32::INFINITY), 0.3);
    assert_eq!(s.integral, 0.3);
}

/// A PI of limits ±1 (kp 0.5, ki 100 at 1 ms).
fn unit_pi() -> pmsm_sensorless::pi::Pi {
    PiConfig {
        kp: 0.5,
        ki: 100.0,
        out_min: -1.0,
        out_max: 1.0,
    }
    .build(1e-3)
    .unwrap()
}

#[test]
fn moving_limits_bound_the_output_and_the_integrator() {
    let pi = unit_pi();
    let mut s = PiState::default();
    // The field-weakening current limit: 0.6 instead of 1 for a long positive error.
    for _ in 0..1000 {
        let u = pi.update_within(&mut s, 10.0, 0.0, (-0.6, 0.6), Held::No);
        assert!(u <= 0.6, "{u}");
    }
    assert!(s.integral <= 0.6, "{}", s.integral);
    // The error reverses: out of the limit in the first sample.
    assert!(pi.update_within(&mut s, -1.0, 0.0, (-0.6, 0.6), Held::No) < 0.6);
}

#[test]
fn a_held_integrator_does_not_wind_but_the_output_still_answers() {
    let pi = unit_pi();
    let mut s = PiState::default();
    // A downstream limit (the voltage) holds it up: a positive error leaves the integrator,
    // the proportional part still acts; a negative error moves it down.
    for _ in 0..1000 {
        let u = pi.update_within(&mut s, 0.4, 0.0, (-1.0, 1.0), Held::Up);
        assert_eq!(u, 0.5 * 0.4);
    }
    assert_eq!(s.integral, 0.0);
    pi.update_within(&mut s, -0.4, 0.0, (-1.0, 1.0), Held::Up);
    assert!(s.integral < 0.0);
    // Held down: the mirror image.
    let mut s = PiState::default();
    pi.update_within(&mut s, -0.4, 0.0, (-1.0, 1.0), Held::Down);
    assert_eq!(s.integral, 0.0);
    pi.update_within(&mut s, 0.4, 0.0, (-1.0, 1.0), Held::Down);
    assert!(s.integral > 0.0);
}
