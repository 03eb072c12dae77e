//! The observer contract ([`Observer`]), checked on every observer the drive runs: the sliding
//! velocity and torque observers (Horng & Chin), the flux observer with its PLL and with the
//! I&I speed observer (Ortega et al.). The drive's supervision relies on it alone, whatever
//! the observer:
//! - seeded at a rotor state, it reads that state back;
//! - seeded at the true state of a running motor, it stays locked: its angle and speed on the
//!   motor's, its residual below ¼ of the edge of lock ([`EDGE_OF_LOCK`]), where supervision
//!   calls an observer locked;
//! - seeded with its angle far off (90° or 180° electrical), its residual rises beyond the
//!   edge of lock within the time supervision takes to judge lock (20 ms);
//! - a non-finite input is refused, the state untouched.
//!
//! The motor is simulated exactly: a constant speed with a constant q current, so the
//! currents are `i = j I_q e^{jθ}` and the stator voltage (the papers' model, Horng & Chin eqs
//! (16), (17); Ortega et al. eq (1)) is `v = e^{jθ} (−ω_e L I_q + j(R I_q + ω_e ψ_f))`, whose
//! mean over a period (what the observers take) is its value at mid-period times
//! `sin(ω_e T/2)/(ω_e T/2)`. The state equations run every 4 kHz step, the read-outs at the
//! rate each speed estimator is built for (the drive's PLL at 1 kHz).

use pmsm_sensorless::drive::{DriveConfig, SLOTS};
use pmsm_sensorless::frames::AlphaBeta;
use pmsm_sensorless::motor::{Motor, HORNG_SINANO, ORTEGA_TEST_0P3KW};
use pmsm_sensorless::observer::flux_speed::FluxIi;
use pmsm_sensorless::observer::ii::IiConfig;
use pmsm_sensorless::observer::sliding::SlidingConfig;
use pmsm_sensorless::observer::{Observer, ReadOut, Rotor, EDGE_OF_LOCK};
use pmsm_sensorless::units::RAD_S_PER_RPM;
use std::f64::consts::{FRAC_PI_2, PI};

/// The drive's step rate \[Hz].
const RATE_HZ: f64 = 4000.0;

/// A motor turning at a constant speed with a constant q current.
#[derive(Clone, Copy, Debug)]
struct Motion {
    motor: Motor,
    /// ω_m \[rad/s].
    omega_m: f64,
    /// i_q \[A].
    i_q: f64,
}

impl Motion {
    /// `speed` and `current` as fractions of the motor's rated speed and rated-torque current.
    fn of(motor: Motor, speed: f64, current: f64) -> Self {
        Self {
            motor,
            omega_m: speed * f64::from(motor.ratings.speed_rpm * RAD_S_PER_RPM),
            i_q: current * f64::from(motor.rated_torque_current_a()),
        }
    }

    fn omega_e(&self) -> f64 {
        f64::from(self.motor.params.pole_pairs) * self.omega_m
    }

    /// θ_e at step `k` [rad].
    fn theta_e(&self, k: u32) -> f64 {
        0.3 + self.omega_e() * f64::from(k) / RATE_HZ
    }

    /// The currents at step `k` \[A].
    fn i_ab(&self, k: u32) -> AlphaBeta {
        let th = self.theta_e(k);
        AlphaBeta::new((-self.i_q * th.sin()) as f32, (self.i_q * th.cos()) as f32)
    }

    /// The mean stator voltage over the period that ends at step `k` \[V] (module doc).
    fn v_ab(&self, k: u32) -> AlphaBeta {
        let p = &self.motor.params;
        let (r, l, psi) = (f64::from(p.r_ohm), f64::from(p.l_h), f64::from(p.flux_wb));
        let w = self.omega_e();
        let (c_re, c_im) = (-w * l * self.i_q, r * self.i_q + w * psi);
        let half = 0.5 * w / RATE_HZ;
        let sinc = if half == 0.0 { 1.0 } else { half.sin() / half };
        let mid = self.theta_e(k) - half;
        let (s, c) = mid.sin_cos();
        AlphaBeta::new(
            (sinc * (c_re * c - c_im * s)) as f32,
            (sinc * (c_re * s + c_im * c)) as f32,
        )
    }

    /// The load torque that holds the speed: the motor's torque less friction \[N·m].
    fn load_nm(&self) -> f64 {
        let p = &self.motor.params;
        f64::from(p.torque_constant()) * self.i_q - f64::from(p.b_nms) * self.omega_m
    }

    /// The rotor state at step `k`, its angle turned by `off` [rad].
    fn rotor(&self, k: u32, off: f64) -> Rotor {
        Rotor {
            theta_e: wrap(self.theta_e(k) + off) as f32,
            omega_m: self.omega_m as f32,
            load_nm: self.load_nm() as f32,
        }
    }
}

fn wrap(x: f64) -> f64 {
    (x + PI).rem_euclid(2.0 * PI) - PI
}

/// Supervision's time to judge lock (the drive's default `lock_time_s`), in steps.
const JUDGE_STEPS: u32 = (0.02 * RATE_HZ) as u32;

/// What a run of an observer showed after its seed.
#[derive(Debug, Default)]
struct Run {
    /// The largest residual read at a read-out.
    max_residual: f32,
    /// ... after [`JUDGE_STEPS`] (the seed's transient over).
    settled_residual: f32,
    /// The largest angle error at a read-out after [`JUDGE_STEPS`] [rad, electrical], and the
    /// largest speed error relative to the speed.
    settled_angle_err: f64,
    settled_speed_err: f64,
}

/// `o` seeded at step 0 with its angle `off` [rad] from the motor's, then run for `steps`, its
/// read-outs every `every` steps (the rate its speed estimator was built for).
fn run<O: Observer>(o: &O, m: &Motion, off: f64, steps: u32, every: u32) -> Run {
    let mut st = O::State::default();
    o.seed(&mut st, m.i_ab(0), m.rotor(0, off));
    let mut out = Run::default();
    for k in 1..=steps {
        assert!(
            o.update(&mut st, m.i_ab(k), m.v_ab(k)),
            "step {k}: update refused"
        );
        if k % every == 0 {
            o.read_out(&mut st, ReadOut::Angle);
            o.read_out(&mut st, ReadOut::Speed);
            let residual = o.residual(&st);
            out.max_residual = out.max_residual.max(residual);
            if k > JUDGE_STEPS {
                out.settled_residual = out.settled_residual.max(residual);
                let err = wrap(f64::from(o.theta_e(&st)) - m.theta_e(k)).abs();
                out.settled_angle_err = out.settled_angle_err.max(err);
                let speed_err = (f64::from(o.omega_m(&st)) - m.omega_m).abs() / m.omega_m.abs();
                out.settled_speed_err = out.settled_speed_err.max(speed_err);
            }
        }
    }
    out
}

/// The contract on one observer at one operating point, its read-outs every `every` steps.
fn contract<O: Observer>(name: &str, o: &O, every: u32, m: &Motion) {
    let what = format!("{name}, {} at {:.0} rad/s", m.motor.name, m.omega_m);
    // Seeded: the seed read back (angle to f32 rounding and the sin/cos polynomial's error).
    let mut st = O::State::default();
    let rotor = m.rotor(0, 0.0);
    o.seed(&mut st, m.i_ab(0), rotor);
    let err = wrap(f64::from(o.theta_e(&st) - rotor.theta_e)).abs();
    assert!(err < 1e-4, "{what}: seeded angle off by {err}");
    assert!(
        (o.omega_m(&st) - rotor.omega_m).abs() <= 1e-5 * rotor.omega_m.abs(),
        "{what}: seeded speed {} for {}",
        o.omega_m(&st),
        rotor.omega_m
    );
    // A non-finite sample is refused and leaves the state as it was.
    let before = st;
    let nan = AlphaBeta::new(f32::NAN, 0.0);
    assert!(
        !o.update(&mut st, nan, m.v_ab(1)),
        "{what}: NaN current taken"
    );
    assert!(
        !o.update(&mut st, m.i_ab(1), nan),
        "{what}: NaN voltage taken"
    );
    assert_eq!(st, before, "{what}: a refused update moved the state");

    // Seeded at the true state, 0.2 s: never near the loss threshold (½ of the edge), even in
    // the seed's transient (a PLL seeded at an angle sees, at its first update, the rotation
    // over its period as an error: a residual of ω_e·1 ms/(π/2), 0.27 at the rated speed);
    // once supervision has judged (20 ms), locked (below ¼) and on the motor.
    let steps = (0.2 * RATE_HZ) as u32;
    let seeded = run(o, m, 0.0, steps, every);
    println!("{what}: seeded true: {seeded:?}");
    assert!(
        seeded.max_residual < 0.5 * EDGE_OF_LOCK,
        "{what}: residual {} seeded at the true state",
        seeded.max_residual
    );
    assert!(
        seeded.settled_residual < 0.25 * EDGE_OF_LOCK,
        "{what}: residual {} after 20 ms",
        seeded.settled_residual
    );
    assert!(
        seeded.settled_angle_err < 5f64.to_radians(),
        "{what}: angle error {:.2}°",
        seeded.settled_angle_err.to_degrees()
    );
    assert!(
        seeded.settled_speed_err < 0.02,
        "{what}: speed error {:.4}",
        seeded.settled_speed_err
    );

    // Seeded far off: beyond the edge of lock within supervision's 20 ms lock time.
    for off in [FRAC_PI_2, PI] {
        let lost = run(o, m, off, JUDGE_STEPS, every);
        println!("{what}: seeded {:.0}° off: {lost:?}", off.to_degrees());
        assert!(
            lost.max_residual > EDGE_OF_LOCK,
            "{what}: residual at most {} seeded {:.0}° off",
            lost.max_residual,
            off.to_degrees()
        );
    }
}

/// Every observer, on `motor` at half its rated speed and half its rated-torque current, and
/// at half and at the rated speed without current.
fn every_observer(motor: Motor) {
    let cfg = DriveConfig::new(&motor);
    let params = motor.params;
    let velocity = SlidingConfig {
        rate_hz: RATE_HZ as f32,
        emf_advance_periods: 0.5,
        min_speed_rad_s: cfg.start.handover_rpm * RAD_S_PER_RPM,
        ..SlidingConfig::velocity(params)
    }
    .build()
    .unwrap();
    let torque = cfg.sliding_monitor().unwrap();
    let flux_pll = cfg.flux_pll().unwrap();
    let flux = cfg.flux_pll().unwrap().flux;
    // The I&I observer at the step rate, as the simulator's bare loop runs it.
    let ii = IiConfig::new(params, RATE_HZ as f32).build().unwrap();
    let flux_ii = FluxIi::new(flux, ii, params.torque_constant());
    let loaded = Motion::of(motor, 0.5, 0.5);
    for m in [
        loaded,
        Motion::of(motor, 0.5, 0.0),
        Motion::of(motor, 1.0, 0.0),
    ] {
        if m.i_q == 0.0 {
            contract("sliding velocity", &velocity, 1, &m);
        }
        contract("sliding torque", &torque, 1, &m);
        // The drive's PLL runs at 1 kHz (`DriveConfig::pll_config`).
        contract("flux + PLL", &flux_pll, SLOTS, &m);
        contract("flux + I&I", &flux_ii, 1, &m);
    }
    // Horng & Chin's velocity observer has no load estimate (λτ = 0): under a load its angle
    // lags (the torque observer's reason, their Sec 3), and its residual says so rather than
    // claim lock (measured: 32° and 0.62 on the Sinano motor, 12° and 1.37 on Ortega's).
    let lagging = run(&velocity, &loaded, 0.0, (0.2 * RATE_HZ) as u32, 1);
    println!("sliding velocity, {} loaded: {lagging:?}", motor.name);
    assert!(lagging.settled_angle_err > 5f64.to_radians(), "{lagging:?}");
    assert!(lagging.max_residual > 0.25 * EDGE_OF_LOCK, "{lagging:?}");
}

#[test]
fn every_observer_keeps_the_contract_on_the_sinano_motor() {
    every_observer(HORNG_SINANO);
}

#[test]
fn every_observer_keeps_the_contract_on_ortegas_test_motor() {
    every_observer(ORTEGA_TEST_0P3KW);
}
