//! Accuracy and range tests of `pmsm_sensorless::math` against f64 `std`.
//!
//! The bounds asserted here are the ones documented on each function.

use core::f32::consts::{PI, TAU};
use core::f64::consts::{PI as PI64, TAU as TAU64};
use pmsm_sensorless::math::{self, atan2, sin_cos, wrap_2pi, wrap_pi};

/// Documented bounds (see the doc comments in `src/math.rs`).
const SIN_COS_MAX_ERR: f64 = 1.2e-7;
const ATAN2_MAX_ERR: f64 = 4e-7;
const WRAP_PI_MAX_ERR: f64 = 5e-7;
const WRAP_2PI_MAX_ERR: f64 = 6e-7;

/// Largest f32 below `PI`.
const PI_BELOW: f32 = 3.141_592_5;

/// `n` evenly spaced f32 angles over `[lo, hi]` (computed in f64, then rounded).
fn sweep(lo: f64, hi: f64, n: u32) -> impl Iterator<Item = f32> {
    (0..n).map(move |i| (lo + (hi - lo) * f64::from(i) / f64::from(n - 1)) as f32)
}

/// Distance between two angles modulo 2π, in [0, π].
fn angle_dist(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(TAU64);
    d.min(TAU64 - d)
}

/// Max |error| of `sin_cos` against f64 over the given angles.
fn sin_cos_max_err(thetas: impl Iterator<Item = f32>) -> f64 {
    let mut worst = 0.0f64;
    for t in thetas {
        let (s, c) = sin_cos(t);
        let (s64, c64) = f64::from(t).sin_cos();
        worst = worst
            .max((f64::from(s) - s64).abs())
            .max((f64::from(c) - c64).abs());
    }
    worst
}

/// `sin_cos_wrapped` against f64: every f32 in [−4, 4] from 1e-3 up (both signs), a dense sweep
/// through zero, the tabulated angles and the midpoints between them; beyond 4 rad it is
/// `sin_cos`.
#[test]
fn sin_cos_wrapped_matches_f64() {
    let err = |ts: &mut dyn Iterator<Item = f32>| {
        ts.map(|t| {
            let (s, c) = math::sin_cos_wrapped(t);
            let (s64, c64) = f64::from(t).sin_cos();
            (f64::from(s) - s64).abs().max((f64::from(c) - c64).abs())
        })
        .fold(0.0f64, f64::max)
    };
    let every = (1e-3f32.to_bits()..=4.0f32.to_bits())
        .step_by(3)
        .flat_map(|b| [f32::from_bits(b), -f32::from_bits(b)]);
    let table = (-82..=82).map(|h| (f64::from(h) * PI64 / 64.0) as f32);
    let worst = err(&mut every.chain(sweep(-1e-3, 1e-3, 100_001)).chain(table));
    println!("sin_cos_wrapped max abs error, |x| <= 4: {worst:.3e}");
    assert!(worst <= SIN_COS_MAX_ERR, "{worst:e}");
    for t in [4.5f32, -100.0, 1e4, f32::NAN, f32::INFINITY] {
        let (a, b) = (math::sin_cos_wrapped(t), sin_cos(t));
        assert!(
            a == b || (a.0.is_nan() && b.0.is_nan()),
            "{t}: {a:?} vs {b:?}"
        );
    }
}

#[test]
fn sin_cos_dense_sweep_pm1000() {
    let err = sin_cos_max_err(sweep(-1000.0, 1000.0, 2_000_001));
    println!("sin_cos max abs error over [-1000, 1000]: {err:.3e}");
    assert!(err <= SIN_COS_MAX_ERR, "{err:e}");
}

#[test]
fn sin_cos_sweep_small_and_up_to_1e4() {
    let small = sin_cos_max_err(sweep(-7.0, 7.0, 1_000_001));
    let large = sin_cos_max_err(sweep(-1.0e4, 1.0e4, 2_000_001));
    // Every f32 in the top binade [8192, 1e4], both signs, exercises the largest quadrant counts.
    let top = sin_cos_max_err(
        (8192.0f32.to_bits()..=1.0e4f32.to_bits())
            .flat_map(|b| [f32::from_bits(b), -f32::from_bits(b)]),
    );
    println!(
        "sin_cos max abs error: |x|<=7 {small:.3e}, |x|<=1e4 {large:.3e}, [8192,1e4] {top:.3e}"
    );
    assert!(small.max(large).max(top) <= SIN_COS_MAX_ERR);
}

#[test]
fn sin_cos_exact_points_and_identity() {
    assert_eq!(sin_cos(0.0), (0.0, 1.0));
    for t in sweep(-50.0, 50.0, 100_001) {
        let (s, c) = sin_cos(t);
        assert!((s * s + c * c - 1.0).abs() < 1e-6, "{t}");
    }
}

#[test]
fn sin_cos_never_panics_and_stays_bounded() {
    // Finite inputs far outside the accurate range, incl. subnormals and f32::MAX.
    let stride = 65_537u32;
    for bits in (0..=u32::MAX).step_by(stride as usize) {
        let t = f32::from_bits(bits);
        let (s, c) = sin_cos(t);
        if t.is_finite() {
            assert!(
                (-1.0..=1.0).contains(&s) && (-1.0..=1.0).contains(&c),
                "{t:e}"
            );
        } else {
            assert!(s.is_nan() && c.is_nan());
        }
    }
    for t in [
        f32::MAX,
        f32::MIN,
        f32::MIN_POSITIVE,
        1e-45,
        3e9,
        -3e9,
        1e20,
    ] {
        let (s, c) = sin_cos(t);
        assert!(s.abs() <= 1.0 && c.abs() <= 1.0, "{t:e}");
    }
    for t in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        let (s, c) = sin_cos(t);
        assert!(s.is_nan() && c.is_nan());
    }
}

/// Max angular error of `atan2` against f64, asserting the (−π, π] range on the way.
fn atan2_max_err(points: impl Iterator<Item = (f32, f32)>) -> f64 {
    let mut worst = 0.0f64;
    for (y, x) in points {
        let a = atan2(y, x);
        assert!(a > -PI && a <= PI, "atan2({y:e}, {x:e}) = {a}");
        let e = angle_dist(f64::from(a), f64::from(y).atan2(f64::from(x)));
        worst = worst.max(e);
    }
    worst
}

#[test]
fn atan2_dense_polar_grid() {
    let radii = [
        1e-40, 1e-30, 1e-6, 0.01, 0.5, 1.0, 3.0, 47.0, 1e3, 1e6, 1e20, 3e38,
    ];
    let n = 400_000;
    let pts = radii.iter().flat_map(|&r: &f64| {
        (0..n).map(move |i| {
            let phi = -PI64 + TAU64 * (f64::from(i) + 0.5) / f64::from(n);
            ((r * phi.sin()) as f32, (r * phi.cos()) as f32)
        })
    });
    let err = atan2_max_err(pts);
    println!("atan2 max abs error on polar grid: {err:.3e}");
    assert!(err <= ATAN2_MAX_ERR, "{err:e}");
}

#[test]
fn atan2_cartesian_grid_and_axes() {
    let vals: Vec<f32> = sweep(-3.0, 3.0, 1201).collect();
    let grid = vals.iter().flat_map(|&y| vals.iter().map(move |&x| (y, x)));
    let err = atan2_max_err(grid);
    println!("atan2 max abs error on cartesian grid: {err:.3e}");
    assert!(err <= ATAN2_MAX_ERR, "{err:e}");

    assert_eq!(atan2(0.0, 0.0), 0.0);
    assert_eq!(atan2(-0.0, 0.0), 0.0);
    assert_eq!(atan2(0.0, -0.0), 0.0);
    assert_eq!(atan2(-0.0, -0.0), 0.0);
    for r in [1e-45f32, 1e-20, 1.0, 5.0, 1e30, f32::MAX] {
        assert_eq!(atan2(0.0, r), 0.0);
        assert_eq!(atan2(-0.0, r), 0.0);
        assert_eq!(atan2(0.0, -r), PI);
        assert_eq!(atan2(-0.0, -r), PI);
        assert!((f64::from(atan2(r, 0.0)) - PI64 / 2.0).abs() <= ATAN2_MAX_ERR);
        assert!((f64::from(atan2(-r, 0.0)) + PI64 / 2.0).abs() <= ATAN2_MAX_ERR);
        assert!((f64::from(atan2(r, r)) - PI64 / 4.0).abs() <= ATAN2_MAX_ERR);
        assert!((f64::from(atan2(-r, -r)) + 3.0 * PI64 / 4.0).abs() <= ATAN2_MAX_ERR);
    }
    // Just below the negative x axis: the exact result rounds to -PI, which is excluded.
    assert_eq!(atan2(-1e-10, -1.0), -PI_BELOW);
    assert!(atan2(f32::NAN, 1.0).is_nan());
    assert!(atan2(1.0, f32::NAN).is_nan());
    assert!(atan2(f32::NAN, 0.0).is_nan());
}

/// Reference wrap of an f32 angle in f64, to (−π, π].
fn wrap_pi_ref(t: f32) -> f64 {
    let t = f64::from(t);
    let r = t - TAU64 * (t / TAU64).round();
    if r <= -PI64 {
        r + TAU64
    } else if r > PI64 {
        r - TAU64
    } else {
        r
    }
}

#[test]
fn wrap_accuracy_up_to_1e4() {
    let mut err_pi = 0.0f64;
    let mut err_2pi = 0.0f64;
    let all = sweep(-1.0e4, 1.0e4, 2_000_001).chain(sweep(-20.0, 20.0, 400_001));
    for t in all {
        let r = wrap_pi_ref(t);
        err_pi = err_pi.max(angle_dist(f64::from(wrap_pi(t)), r));
        err_2pi = err_2pi.max(angle_dist(f64::from(wrap_2pi(t)), r));
    }
    println!("wrap_pi max abs error {err_pi:.3e}, wrap_2pi {err_2pi:.3e}");
    assert!(err_pi <= WRAP_PI_MAX_ERR && err_2pi <= WRAP_2PI_MAX_ERR);
}

#[test]
fn wrap_boundaries() {
    assert_eq!(wrap_pi(PI), PI);
    assert_eq!(wrap_pi(-PI), PI_BELOW);
    assert_eq!(wrap_pi(0.0), 0.0);
    assert_eq!(wrap_pi(1.0), 1.0);
    assert_eq!(wrap_pi(-3.0), -3.0);
    assert_eq!(wrap_pi(PI_BELOW), PI_BELOW);
    assert_eq!(wrap_pi(-PI_BELOW), -PI_BELOW);
    assert!((wrap_pi(TAU)).abs() <= 1e-6);
    // Odd multiples of the f32 PI land near ±π; compare with the f64 wrap of the same input.
    for k in [3.0f32, 5.0, -3.0, 101.0, -999.0, 3183.0] {
        let t = k * PI;
        let w = wrap_pi(t);
        assert!(
            angle_dist(f64::from(w), wrap_pi_ref(t)) <= WRAP_PI_MAX_ERR,
            "{k}pi -> {w}"
        );
        assert!(PI - w.abs() <= 1e-3, "{k}pi -> {w}");
    }
    assert!((f64::from(wrap_pi(1000.0)) - (1000.0 - 159.0 * TAU64)).abs() <= WRAP_PI_MAX_ERR);

    assert_eq!(wrap_2pi(0.0), 0.0);
    assert_eq!(wrap_2pi(-0.0), 0.0);
    assert_eq!(wrap_2pi(PI), PI);
    // The f32 TAU lies 1.75e-7 above 2π.
    assert!((f64::from(wrap_2pi(TAU)) - (f64::from(TAU) - TAU64)).abs() <= 1e-9);
    assert!(wrap_2pi(-1e-9) < TAU);
    assert!((f64::from(wrap_2pi(-PI)) - PI64).abs() <= WRAP_2PI_MAX_ERR);
    assert!((f64::from(wrap_2pi(-1000.0)) - (-1000.0 + 160.0 * TAU64)).abs() <= WRAP_2PI_MAX_ERR);
}

/// An angle one turn out (an observer's angle advanced past ±π, the step's usual wrap) comes
/// back correctly rounded: every f32 with π < |θ| < 9 gives the f32 nearest θ ∓ 2π.
#[test]
fn wrap_pi_one_turn_is_correctly_rounded() {
    let mut checked = 0u32;
    for sign in [1.0f32, -1.0] {
        let mut t = PI;
        while t < 9.0 {
            t = f32::from_bits(t.to_bits() + 1);
            let x = sign * t;
            let exact = (f64::from(x) - f64::from(sign) * TAU64) as f32;
            let w = wrap_pi(x);
            assert_eq!(w, exact, "wrap_pi({x:e})");
            assert!(w > -PI && w <= PI, "wrap_pi({x:e}) = {w}");
            checked += 1;
        }
    }
    assert!(checked > 20_000_000);
}

#[test]
fn wrap_in_range_for_every_finite_input() {
    let specials = [
        f32::MAX,
        f32::MIN,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        1e-45,
        6.7e7,
        1e30,
    ];
    let sampled = (0..=u32::MAX).step_by(4099).map(f32::from_bits);
    for t in sampled.chain(specials) {
        let (p, q) = (wrap_pi(t), wrap_2pi(t));
        if t.is_finite() {
            assert!(p > -PI && p <= PI, "wrap_pi({t:e}) = {p}");
            assert!((0.0..TAU).contains(&q), "wrap_2pi({t:e}) = {q}");
        } else {
            assert!(p.is_nan() && q.is_nan(), "{t}");
        }
    }
}

/// `advance` (rotation by δ: a polynomial for |δ| ≤ 0.3, `sin_cos(δ)` beyond) against f64
/// `sin_cos(θ + δ)`.
#[test]
fn advance_matches_f64() {
    let mut worst = 0.0f64;
    for i in 0..2000 {
        let theta = -std::f64::consts::PI + std::f64::consts::TAU * i as f64 / 2000.0;
        for j in 0..=120 {
            let delta = if j <= 60 {
                -0.3 + 0.6 * j as f64 / 60.0
            } else {
                (-3.0 + 6.0 * (j - 61) as f64 / 59.0).clamp(-3.0, 3.0)
            };
            let sc = pmsm_sensorless::math::sin_cos(theta as f32);
            let (s, c) = pmsm_sensorless::math::advance(sc, delta as f32);
            let (s64, c64) = (theta as f32 as f64 + delta as f32 as f64).sin_cos();
            worst = worst
                .max((s as f64 - s64).abs())
                .max((c as f64 - c64).abs());
        }
    }
    println!("advance: max error {worst:.2e}");
    assert!(worst < 3e-7, "{worst}");
}

#[test]
fn all_finite_and_finite_sum_flag_every_non_finite_value() {
    use pmsm_sensorless::math::{all_finite, finite_sum};
    // Finite, and so is their sum in this order.
    let finite = [
        0.0,
        -0.0,
        1.0,
        -f32::MAX,
        f32::MAX,
        f32::MIN_POSITIVE,
        1e-45,
    ];
    assert!(all_finite(finite) && finite_sum(finite));
    assert!(all_finite::<0>([]) && finite_sum::<0>([]));
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
        for k in 0..finite.len() {
            let mut xs = finite;
            xs[k] = bad;
            assert!(!all_finite(xs) && !finite_sum(xs), "{bad} at {k}");
        }
    }
    // +∞ and −∞ together must not cancel.
    let opposite = [f32::INFINITY, f32::NEG_INFINITY];
    assert!(!all_finite(opposite) && !finite_sum(opposite));
    // Finite values whose sum is beyond f32::MAX: `finite_sum` flags them (its documented
    // difference), `all_finite` does not.
    assert!(all_finite([f32::MAX, f32::MAX]) && !finite_sum([f32::MAX, f32::MAX]));
}

/// Relative error of `rsqrt` and `sqrt` against f64 over every 97th f32 bit pattern of the
/// normal positive range (8.7e7 values), and the special inputs.
/// The one-compare bit test agrees with `is_normal() && x > 0` on every 7th bit pattern and
/// at the edges.
#[test]
fn is_normal_positive_matches_std() {
    let edges = [
        0.0f32,
        -0.0,
        f32::MIN_POSITIVE,
        f32::from_bits(f32::MIN_POSITIVE.to_bits() - 1),
        f32::MAX,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        -f32::MIN_POSITIVE,
        -1.0,
        1.0,
    ];
    for x in (0..=u32::MAX).step_by(7).map(f32::from_bits).chain(edges) {
        assert_eq!(
            math::is_normal_positive(x),
            x.is_normal() && x > 0.0,
            "{x:e}"
        );
    }
}

/// Every 97th positive normal f32, from `f32::MIN_POSITIVE`.
fn every_97th_normal() -> impl Iterator<Item = f32> {
    (f32::MIN_POSITIVE.to_bits()..=f32::MAX.to_bits())
        .step_by(97)
        .map(f32::from_bits)
}

/// Two Newton steps (`rsqrt_normal(x, 2)`, the current loop's voltage cut): at most 5e-6
/// relative below 1/√x and never above it by more than f32 rounding, over every 97th normal f32.
#[test]
fn rsqrt_with_two_newton_steps_stays_just_below() {
    let (mut below, mut above) = (0.0f64, 0.0f64);
    for x in every_97th_normal() {
        let r = math::rsqrt_normal(x, 2) as f64 * (x as f64).sqrt() - 1.0;
        below = below.max(-r);
        above = above.max(r);
    }
    println!("rsqrt_normal(x, 2): {below:.2e} below, {above:.2e} above");
    assert!(below < 5e-6, "{below:e}");
    assert!(above < 2.5e-7, "{above:e}");
}

#[test]
fn rsqrt_and_sqrt_match_f64() {
    let (mut worst_r, mut worst_s) = (0.0f64, 0.0f64);
    for x in every_97th_normal() {
        let exact = (x as f64).sqrt();
        worst_r = worst_r.max((math::rsqrt(x) as f64 * exact - 1.0).abs());
        worst_s = worst_s.max((math::sqrt(x) as f64 / exact - 1.0).abs());
    }
    assert!(worst_r < 4e-7, "rsqrt relative error {worst_r:e}");
    assert!(worst_s < 5e-7, "sqrt relative error {worst_s:e}");
    assert_eq!(math::rsqrt(0.0), f32::INFINITY);
    assert_eq!(math::rsqrt(f32::INFINITY), 0.0);
    assert!(math::rsqrt(-1.0).is_nan() && math::rsqrt(f32::NAN).is_nan());
    assert_eq!(math::sqrt(0.0), 0.0);
    assert_eq!(math::sqrt(f32::INFINITY), f32::INFINITY);
    assert!(math::sqrt(-1.0).is_nan() && math::sqrt(f32::NAN).is_nan());
    let tiny = f32::from_bits(1); // subnormal: the library path
    assert!((math::sqrt(tiny) as f64 / (tiny as f64).sqrt() - 1.0).abs() < 1e-6);
}

#[test]
fn a_winding_half_again_its_resistance_is_127_k_warmer() {
    use pmsm_sensorless::units::winding_rise_k;
    // Copper: R(T) = R(T_ref)(1 + α (T − T_ref)), α = 1/254.5 K at 20 °C.
    assert!((winding_rise_k(1.5, 1.0) - 127.25).abs() < 1e-3);
    assert_eq!(winding_rise_k(2.5, 2.5), 0.0);
    assert!(winding_rise_k(0.8, 1.0) < 0.0);
    assert!(winding_rise_k(1.0, 0.0).is_nan());
}
