//! Property tests of the Clarke/Park transforms in `pmsm_sensorless::frames`
//! (deterministic seed, no persistence files).

use pmsm_sensorless::frames::{Abc, AlphaBeta, Dq, SinCos};
use proptest::prelude::*;
use proptest::test_runner::{Config, RngAlgorithm, RngSeed};
use std::f64::consts::{PI, TAU};

fn config() -> Config {
    Config {
        cases: 4096,
        failure_persistence: None,
        rng_algorithm: RngAlgorithm::ChaCha,
        rng_seed: RngSeed::Fixed(0x00F4_A3E5),
        ..Config::default()
    }
}

/// Relative tolerance of one f32 transform chain (a few ulp plus the sin/cos polynomial).
const REL: f64 = 2e-6;

fn close(x: f32, y: f64, scale: f64) -> bool {
    (f64::from(x) - y).abs() <= REL * scale
}

/// Distance between two angles modulo 2π.
fn angle_dist(a: f64, b: f64) -> f64 {
    let d = (a - b).rem_euclid(TAU);
    d.min(TAU - d)
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn clarke_then_inverse_clarke_round_trip(a in -1e3f32..1e3, b in -1e3f32..1e3) {
        let abc = Abc::new(a, b, -a - b); // balanced: no zero sequence
        let back = abc.to_alpha_beta().to_abc();
        let scale = 1.0 + f64::from(a.abs().max(b.abs()));
        prop_assert!(close(back.a, f64::from(abc.a), scale), "{:?} -> {:?}", abc, back);
        prop_assert!(close(back.b, f64::from(abc.b), scale), "{:?} -> {:?}", abc, back);
        prop_assert!(close(back.c, f64::from(abc.c), scale), "{:?} -> {:?}", abc, back);
    }

    #[test]
    fn inverse_clarke_then_clarke_round_trip(alpha in -1e3f32..1e3, beta in -1e3f32..1e3) {
        let ab = AlphaBeta::new(alpha, beta);
        let back = ab.to_abc().to_alpha_beta();
        let scale = 1.0 + f64::from(alpha.abs().max(beta.abs()));
        prop_assert!(close(back.alpha, f64::from(alpha), scale), "{:?} -> {:?}", ab, back);
        prop_assert!(close(back.beta, f64::from(beta), scale), "{:?} -> {:?}", ab, back);
    }

    #[test]
    fn clarke_discards_zero_sequence(a in -1e3f32..1e3, b in -1e3f32..1e3, z in -1e3f32..1e3) {
        let plain = Abc::new(a, b, -a - b).to_alpha_beta();
        let shifted = Abc::new(a + z, b + z, -a - b + z).to_alpha_beta();
        let scale = 1.0 + f64::from(a.abs().max(b.abs()).max(z.abs()));
        prop_assert!(close(shifted.alpha, f64::from(plain.alpha), scale));
        prop_assert!(close(shifted.beta, f64::from(plain.beta), scale));
    }

    #[test]
    fn balanced_sinusoid_has_amplitude_and_phase(amp in 1e-3f64..1e3, phi in -PI..PI) {
        // a = A cos φ, b = A cos(φ − 2π/3), c = A cos(φ + 2π/3)  =>  αβ = A (cos φ, sin φ).
        let abc = Abc::new(
            (amp * phi.cos()) as f32,
            (amp * (phi - TAU / 3.0).cos()) as f32,
            (amp * (phi + TAU / 3.0).cos()) as f32,
        );
        let ab = abc.to_alpha_beta();
        prop_assert!(close(ab.magnitude(), amp, amp), "{:?}: |ab| = {}", abc, ab.magnitude());
        let angle = f64::from(ab.beta).atan2(f64::from(ab.alpha));
        prop_assert!(angle_dist(angle, phi) <= REL * 2.0, "angle {} vs {}", angle, phi);
    }

    #[test]
    fn park_then_inverse_park_round_trip(
        alpha in -1e3f32..1e3,
        beta in -1e3f32..1e3,
        theta in -1e3f32..1e3,
    ) {
        let sc = SinCos::of(theta);
        let ab = AlphaBeta::new(alpha, beta);
        let back = ab.to_dq(sc).to_alpha_beta(sc);
        let scale = 1.0 + f64::from(alpha.abs().max(beta.abs()));
        prop_assert!(close(back.alpha, f64::from(alpha), scale), "{:?} -> {:?}", ab, back);
        prop_assert!(close(back.beta, f64::from(beta), scale), "{:?} -> {:?}", ab, back);
    }

    #[test]
    fn inverse_park_then_park_round_trip(d in -1e3f32..1e3, q in -1e3f32..1e3, theta in -1e3f32..1e3) {
        let sc = SinCos::of(theta);
        let dq = Dq::new(d, q);
        let back = dq.to_alpha_beta(sc).to_dq(sc);
        let scale = 1.0 + f64::from(d.abs().max(q.abs()));
        prop_assert!(close(back.d, f64::from(d), scale), "{:?} -> {:?}", dq, back);
        prop_assert!(close(back.q, f64::from(q), scale), "{:?} -> {:?}", dq, back);
    }

    #[test]
    fn park_preserves_magnitude(alpha in -1e3f32..1e3, beta in -1e3f32..1e3, theta in -1e3f32..1e3) {
        let ab = AlphaBeta::new(alpha, beta);
        let dq = ab.to_dq(SinCos::of(theta));
        let mag = f64::from(alpha).hypot(f64::from(beta));
        prop_assert!(close(dq.magnitude(), mag, 1.0 + mag), "{:?} -> {:?}", ab, dq);
        prop_assert!(close(ab.magnitude(), mag, 1.0 + mag));
    }

    #[test]
    fn park_of_vector_at_its_own_angle_is_on_d_axis(amp in 0.0f64..1e3, theta in -1e3f32..1e3) {
        let t = f64::from(theta);
        let ab = AlphaBeta::new((amp * t.cos()) as f32, (amp * t.sin()) as f32);
        let dq = ab.to_dq(SinCos::of(theta));
        prop_assert!(close(dq.d, amp, 1.0 + amp), "{:?} -> {:?}", ab, dq);
        prop_assert!(close(dq.q, 0.0, 1.0 + amp), "{:?} -> {:?}", ab, dq);
    }

    #[test]
    fn positive_q_leads_d_by_90_degrees(q in 1e-3f32..1e3, theta in -PI as f32..PI as f32) {
        // Pure q at rotor angle θ lies at θ + π/2 in the stationary frame.
        let ab = Dq::new(0.0, q).to_alpha_beta(SinCos::of(theta));
        let angle = f64::from(ab.beta).atan2(f64::from(ab.alpha));
        prop_assert!(angle_dist(angle, f64::from(theta) + PI / 2.0) <= 1e-6);
    }
}
