//! The fixed-point frames (`pmsm_sensorless::fixed`, issue #30) against the f32 reference
//! (`pmsm_sensorless::frames`) over every angle and the full per-unit range. Bounds are in Q15
//! LSB (1/32 768 of the per-unit base) and derived in each test from the blocks' roundings.

use pmsm_sensorless::fixed::{AbcQ15, AlphaBetaQ15, Angle, DqQ15, ONE_Q15, Q15};
use pmsm_sensorless::frames::{Abc, AlphaBeta, Dq, SinCos};

fn q(x: f32) -> Q15 {
    (x * ONE_Q15 as f32).round().clamp(-32768.0, 32767.0) as Q15
}

fn f(x: Q15) -> f32 {
    f32::from(x) / ONE_Q15 as f32
}

/// LSB between a Q15 result and an f32 reference.
fn lsb(x: Q15, reference: f32) -> f32 {
    (f(x) - reference).abs() * ONE_Q15 as f32
}

/// A seeded generator of per-unit values in [−bound, bound] (deterministic).
struct Lcg(u64);

impl Lcg {
    fn next(&mut self, bound: f32) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        ((self.0 >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0) * bound
    }
}

/// The table's entries: sin(2πk/256) in Q15, rounded, ±1 stored as ±32 767.
#[test]
fn the_table_is_the_sine() {
    for k in 0..256u32 {
        let (s, c) = Angle(k << 24).sin_cos();
        let exact = (f64::from(k) * std::f64::consts::TAU / 256.0).sin();
        let want = (exact * 32768.0).round().clamp(-32767.0, 32767.0) as i16;
        assert_eq!(s, want, "entry {k}");
        let exact_c = (f64::from(k) * std::f64::consts::TAU / 256.0).cos();
        assert!(
            (f64::from(c) - exact_c * 32768.0).abs() <= 1.0,
            "cos at entry {k}: {c}"
        );
    }
}

/// Over 2²⁰ angles of one turn: within 4 LSB of the exact sine and cosine (the chord's sag
/// (2π/256)²/8 = 7.5·10⁻⁵ = 2.5 LSB, the table's ½ LSB, the interpolation's ½ LSB).
#[test]
fn sin_cos_within_four_lsb() {
    let mut worst = 0.0f64;
    for k in 0..(1u32 << 20) {
        let a = Angle(k << 12);
        let (s, c) = a.sin_cos();
        let th = f64::from(k) * std::f64::consts::TAU / f64::from(1u32 << 20);
        worst = worst
            .max((f64::from(s) - th.sin() * 32768.0).abs())
            .max((f64::from(c) - th.cos() * 32768.0).abs());
    }
    println!("sin/cos: worst error {worst:.2} LSB");
    assert!(worst <= 4.0, "{worst} LSB");
}

/// Radians in and out, the wrap at ±π exact.
#[test]
fn angles_wrap_at_a_turn() {
    for th in [-3.0f32, -1.0, 0.0, 0.5, 3.1, 7.0, -20.0] {
        let back = Angle::from_rad(th).to_rad();
        let want =
            (th + std::f32::consts::PI).rem_euclid(std::f32::consts::TAU) - std::f32::consts::PI;
        assert!((back - want).abs() < 1e-4, "{th}: {back} vs {want}");
    }
    let near_pi = Angle::from_rad(3.13);
    let step = Angle::from_rad(0.02);
    let past = near_pi.advanced(step).to_rad();
    assert!(
        (past - (3.15 - std::f32::consts::TAU)).abs() < 1e-4,
        "{past}"
    );
}

/// Clarke, Park and their inverses against the f32 blocks on 10⁵ seeded balanced sets of
/// amplitude up to 0.9 per unit at seeded angles. Bounds: Clarke's β rounds once (½ LSB) and
/// carries the rounding of 1/√3 to 18 919/32 768 (relative 2.1·10⁻⁵) on `a + 2b` of up to
/// √3·0.9 per unit (51 078 LSB): ½ + 1.08 = 1.58 LSB; Park's each output is `c·x ± s·y` with sin and cos within 4 LSB
/// (`sin_cos_within_four_lsb`) on |x|, |y| ≤ 0.9 and one rounding: 0.9·4·2 + ½ = 7.7 LSB;
/// the inverses the same.
#[test]
fn frames_match_the_f32_blocks() {
    let mut g = Lcg(0x5eed);
    let (mut worst_clarke, mut worst_park, mut worst_inv) = (0.0f32, 0.0f32, 0.0f32);
    for _ in 0..100_000 {
        let (amp, th_i, th) = (
            g.next(0.9).abs(),
            g.next(std::f32::consts::PI),
            g.next(std::f32::consts::PI),
        );
        // A balanced set, rounded to Q15 first (the samples the drive would have).
        let a = q(amp * th_i.cos());
        let b = q(amp * (th_i - 2.0943951).cos());
        let c = -a - b;
        let abc = AbcQ15 { a, b, c };
        let ab = abc.to_alpha_beta();
        let reference = Abc::new(f(a), f(b), f(c)).to_alpha_beta();
        worst_clarke = worst_clarke
            .max(lsb(ab.alpha, reference.alpha))
            .max(lsb(ab.beta, reference.beta));

        let angle = Angle::from_rad(th);
        let sc = SinCos::of(angle.to_rad());
        let dq = ab.to_dq(angle.sin_cos());
        let dq_ref = AlphaBeta::new(f(ab.alpha), f(ab.beta)).to_dq(sc);
        worst_park = worst_park.max(lsb(dq.d, dq_ref.d)).max(lsb(dq.q, dq_ref.q));

        let back = dq.to_alpha_beta(angle.sin_cos());
        let back_ref = Dq::new(f(dq.d), f(dq.q)).to_alpha_beta(sc);
        worst_inv = worst_inv
            .max(lsb(back.alpha, back_ref.alpha))
            .max(lsb(back.beta, back_ref.beta));

        let abc2 = ab.to_abc();
        let abc2_ref = AlphaBeta::new(f(ab.alpha), f(ab.beta)).to_abc();
        worst_inv = worst_inv
            .max(lsb(abc2.a, abc2_ref.a))
            .max(lsb(abc2.b, abc2_ref.b))
            .max(lsb(abc2.c, abc2_ref.c));
    }
    println!(
        "worst error: Clarke {worst_clarke:.2} LSB, Park {worst_park:.2} LSB, inverses {worst_inv:.2} LSB"
    );
    assert!(worst_clarke <= 1.58, "Clarke {worst_clarke}");
    assert!(worst_park <= 7.7, "Park {worst_park}");
    assert!(worst_inv <= 7.7, "inverse {worst_inv}");
}

/// Out-of-range sums saturate instead of wrapping: a vector at the corner of the Q15 square
/// turned by 45° stays at the rail.
#[test]
fn saturates_rather_than_wraps() {
    let corner = AlphaBetaQ15 {
        alpha: 32767,
        beta: 32767,
    };
    let dq = corner.to_dq(Angle::from_rad(std::f32::consts::FRAC_PI_4).sin_cos());
    // |(1, 1)| = √2 per unit along the 45° axis: d saturates at the rail, q stays near 0.
    assert_eq!(dq.d, 32767);
    assert!(dq.q.abs() <= 8, "{}", dq.q);
    assert_eq!(
        DqQ15 { d: 32767, q: 32767 }
            .to_alpha_beta(Angle::from_rad(std::f32::consts::FRAC_PI_4).sin_cos())
            .beta,
        32767
    );
}
