//! The fixed-point PLL, SVPWM and sliding observer (`pmsm_sensorless::fixed::{pll, svpwm,
//! sliding}`, issue #30) against their f32 references, on every zoo motor and the presets in
//! the per-unit bases of its drive configuration (`PerUnit::of_drive`), over the range of
//! speeds and voltages that motor reaches. Bounds are stated and derived in each test.

mod common;
use common::{all_motors, Lcg};
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::scenario::Scenario;
use pmsm_host_sim::sim::{Sim, SimConfig};
use pmsm_sensorless::drive::DriveConfig;
use pmsm_sensorless::fixed::pll::{PllQ, PllStateQ};
use pmsm_sensorless::fixed::pu::PerUnit;
use pmsm_sensorless::fixed::sliding::{SlidingObserverQ, SlidingStateQ};
use pmsm_sensorless::fixed::svpwm::{svpwm_limited_q15, svpwm_q15, DutiesQ15, DUTY_ONE};
use pmsm_sensorless::fixed::{AlphaBetaQ15, Angle};
use pmsm_sensorless::frames::{Abc, AlphaBeta};
use pmsm_sensorless::motor::Motor;
use pmsm_sensorless::observer::pll::{PllConfig, PllState};
use pmsm_sensorless::observer::sliding::SlidingState;
use pmsm_sensorless::observer::{Observer, Rotor};
use pmsm_sensorless::svpwm::svpwm;
use std::f64::consts::{PI, TAU};

/// An angle in turns (any real) as a binary angle, rounded to 2⁻³² turn.
fn angle_of_turns(turns: f64) -> Angle {
    Angle(((turns.rem_euclid(1.0) * 4_294_967_296.0).round() as u64) as u32)
}

fn wrap(x: f64) -> f64 {
    (x + PI).rem_euclid(TAU) - PI
}

/// The worst differences of one run: after the transients (0.1 s from the start and from the
/// angle step) and over the whole run.
#[derive(Default, Debug, Clone, Copy)]
struct PllDiff {
    /// |ω̂ fixed − ω̂ f32| \[rad/s], after the transients.
    speed: f64,
    /// |z1 fixed − z1 f32| \[°], after the transients.
    angle_deg: f64,
    /// The same over the whole run.
    speed_all: f64,
    angle_all_deg: f64,
    /// |omega_q15 − Δ in Q15 of ω_b| \[LSB] (where ω̂ is within ±1 pu).
    q15_lsb: f64,
}

impl PllDiff {
    fn max(self, o: Self) -> Self {
        Self {
            speed: self.speed.max(o.speed),
            angle_deg: self.angle_deg.max(o.angle_deg),
            speed_all: self.speed_all.max(o.speed_all),
            angle_all_deg: self.angle_all_deg.max(o.angle_all_deg),
            q15_lsb: self.q15_lsb.max(o.q15_lsb),
        }
    }
}

/// The input sequences: `(name, duration [s], ω(t) [rad/s], angle offset(t) [rad], noise [rad])`
/// with `w` the top speed.
type Sequence = (&'static str, f64, Box<dyn Fn(f64) -> f64>, f64, f64);

fn sequences(w: f64) -> Vec<Sequence> {
    vec![
        // A ramp from rest to the top speed in 1 s, held 0.5 s.
        (
            "ramp",
            1.5,
            Box::new(move |t: f64| w * t.min(1.0)),
            0.0,
            0.0,
        ),
        // A reversal through zero at a constant acceleration (−w to w in 2 s).
        (
            "reversal",
            2.0,
            Box::new(move |t: f64| w * (t - 1.0)),
            0.0,
            0.0,
        ),
        // Constant speed, the angle stepping by 60° at 0.5 s.
        ("step", 1.0, Box::new(move |_| w), 60f64.to_radians(), 0.0),
        // Half the top speed, ±2° of uniform noise on every sample (seeded).
        (
            "noise",
            1.0,
            Box::new(move |_| 0.5 * w),
            0.0,
            2f64.to_radians(),
        ),
        // A speed oscillating at 5 Hz between 0.2 and the top speed: accelerations of 2πf·0.4w.
        (
            "wobble",
            1.0,
            Box::new(move |t: f64| w * (0.6 + 0.4 * (TAU * 5.0 * t).sin())),
            0.0,
            0.0,
        ),
    ]
}

/// One sequence through the f32 and the fixed-point PLL: the same binary input angles (the
/// f32 PLL takes each as `Angle::to_rad`), both started at the sequence's first angle and
/// speed (the f32 one at the speed the fixed reset gives).
fn pll_run(cfg: &PllConfig, pu: &PerUnit, seq: &Sequence, seed: u64) -> PllDiff {
    let reference = cfg.build().unwrap();
    let q = PllQ::build(cfg, pu).unwrap();
    let ts = 1.0 / f64::from(cfg.rate_hz);
    let (_, duration, omega, step, noise) = seq;
    let mut rng = Lcg(seed);
    let n = (duration / ts) as usize;
    let mut turns = 0.0f64;
    let theta_at = |turns: f64, t: f64, rng: &mut Lcg| {
        let offset = if t >= 0.5 { *step } else { 0.0 } + noise * rng.next_f64();
        angle_of_turns(turns + offset / TAU)
    };
    let (mut st_q, mut st_f) = (PllStateQ::default(), PllState::default());
    let theta0 = theta_at(0.0, 0.0, &mut rng);
    q.reset(&mut st_q, theta0, pu.speed(omega(0.0) as f32));
    reference.reset(&mut st_f, theta0.to_rad(), q.omega_rad_s(st_q.delta));
    let mut d = PllDiff::default();
    let lsb = 32_768.0 / f64::from(pu.omega_base_e);
    for k in 1..n {
        let t = k as f64 * ts;
        // The angle integrates ω(t) (trapezoid).
        turns += 0.5 * (omega(t - ts) + omega(t)) * ts / TAU;
        let theta = theta_at(turns, t, &mut rng);
        let delta = q.update(&mut st_q, theta);
        reference.update(&mut st_f, theta.to_rad());
        let w_q = f64::from(q.omega_rad_s(delta));
        let speed = (w_q - f64::from(st_f.omega)).abs();
        let angle = wrap(f64::from(st_q.z1.to_rad()) - f64::from(st_f.z1))
            .abs()
            .to_degrees();
        d.speed_all = d.speed_all.max(speed);
        d.angle_all_deg = d.angle_all_deg.max(angle);
        if t >= 0.1 && !(0.5..0.6).contains(&t) {
            d.speed = d.speed.max(speed);
            d.angle_deg = d.angle_deg.max(angle);
        }
        // The read-out in Q15 against Δ's exact value (where it is inside ±1 pu).
        let exact = w_q * lsb;
        if exact.abs() < 32_767.0 {
            d.q15_lsb = d.q15_lsb.max((f64::from(q.omega_q15(&st_q)) - exact).abs());
        }
    }
    d
}

/// The fixed-point PLL against the f32 `Pll` on the same binary angle sequences (a ramp, a
/// reversal at constant acceleration, a 60° step, ±2° of seeded noise, an oscillating speed),
/// on every zoo motor and preset, scaled to its rated electrical speed `ω_r` (capped at a
/// fifth of a turn per PLL sample, where the sampled angle still tells the speed), with three
/// PLLs: the drive's (its 1 kHz task, 50 Hz, ζ = 1, as `DriveConfig`'s PLL), the same at the
/// control rate, and a faster, lightly damped one (200 Hz, ζ = 0.7) at the control rate.
///
/// Required (issue #30): the speeds within 0.5 % of `ω_r` and the angles within 0.1° after
/// the transients. What the fixed PLL's own roundings leave is far below: the error rounded
/// to 2⁻¹⁷ turn (2.4·10⁻⁵ rad at most) moves `Δ` by `Kp·2.4·10⁻⁵` rad/s through the
/// proportional path, and the loop, linear, turns a bounded error at its input into a bounded
/// difference of the same order; the figures are printed. The Q15 read-out is within 1.5 LSB
/// of `Δ`'s exact per-unit value (`PllQ::omega_q15`).
#[test]
fn pll_matches_the_f32_pll() {
    let mut worst_rel = (0.0f64, 0.0f64, 0.0f64);
    for (name, motor) in all_motors() {
        let cfg = DriveConfig::new(&motor);
        let pu = PerUnit::of_drive(&cfg).unwrap();
        let rated = f64::from(motor.ratings.speed_rpm * motor.params.n()) * TAU / 60.0;
        let tick_rate = cfg.rate_hz / (cfg.rate_hz / 1000.0).round().max(1.0);
        let plls = [
            ("drive (1 kHz task)", tick_rate, 50.0, 1.0),
            ("control rate", cfg.rate_hz, 50.0, 1.0),
            ("control rate, 200 Hz ζ 0.7", cfg.rate_hz, 200.0, 0.7),
        ];
        for (which, rate_hz, bandwidth_hz, damping) in plls {
            let pll_cfg = PllConfig {
                rate_hz,
                bandwidth_hz,
                damping,
            };
            let top = rated.min(0.2 * TAU * f64::from(rate_hz));
            let mut d = PllDiff::default();
            for (k, seq) in sequences(top).iter().enumerate() {
                let r = pll_run(&pll_cfg, &pu, seq, 17 + k as u64);
                d = d.max(r);
            }
            println!(
                "{name:34} {which:28} top {top:8.0} rad/s (rated {rated:8.0}): speed {:.4} rad/s ({:.2e} of rated; all {:.2e}), angle {:.5}° (all {:.5}°), Q15 read-out {:.2} LSB",
                d.speed,
                d.speed / rated,
                d.speed_all / rated,
                d.angle_deg,
                d.angle_all_deg,
                d.q15_lsb
            );
            worst_rel.0 = worst_rel.0.max(d.speed / rated);
            worst_rel.1 = worst_rel.1.max(d.angle_deg);
            worst_rel.2 = worst_rel.2.max(d.q15_lsb);
            assert!(d.speed <= 0.005 * rated, "{name} {which}: {d:?}");
            assert!(d.angle_deg <= 0.1, "{name} {which}: {d:?}");
            assert!(d.q15_lsb <= 1.5, "{name} {which}: {d:?}");
        }
    }
    println!(
        "worst: speed {:.2e} of rated, angle {:.5}°, Q15 read-out {:.2} LSB",
        worst_rel.0, worst_rel.1, worst_rel.2
    );
}

/// Reset and read-out: a speed set in Q15 reads back within 2 LSB (the reset's ½, the
/// read-out's 1.5: `PllQ::reset`, `PllQ::omega_q15`), the angle exactly; the
/// error wraps (an input half a turn away is ±π, never beyond).
#[test]
fn pll_reset_and_wrap() {
    for (name, motor) in all_motors() {
        let cfg = DriveConfig::new(&motor);
        let pu = PerUnit::of_drive(&cfg).unwrap();
        let pll_cfg = PllConfig {
            rate_hz: cfg.rate_hz,
            bandwidth_hz: 50.0,
            damping: 1.0,
        };
        let q = PllQ::build(&pll_cfg, &pu).unwrap();
        let mut st = PllStateQ::default();
        for w in [-32_768i16, -20_000, -1, 0, 1, 123, 16_384, 32_767] {
            q.reset(&mut st, Angle(0x8000_0000), w);
            assert_eq!(st.z1, Angle(0x8000_0000));
            let back = q.omega_q15(&st);
            // Δ saturates at half a turn per sample: a faster base speed reads back lower.
            let nyquist = pu.speed(std::f32::consts::PI * pll_cfg.rate_hz);
            let want = w.clamp(-nyquist, nyquist);
            assert!(
                (i32::from(back) - i32::from(want)).abs() <= 2,
                "{name}: {w} -> {back}"
            );
        }
        q.reset(&mut st, Angle(0), 0);
        q.update(&mut st, Angle(0x8000_0000));
        assert_eq!(st.error, i32::MIN, "{name}");
        assert_eq!(st.error_over_quarter_q15(), 65_536);
    }
}

/// The f32 duties of `v` (per unit of the bus) as min–max injection without any cut, in
/// f64 (the f32 `svpwm_limited` is the crate's own; this is its formula).
fn injection_f64(alpha: f64, beta: f64) -> [f64; 3] {
    let a = alpha;
    let b = -0.5 * alpha + 0.75f64.sqrt() * beta;
    let c = -a - b;
    let v0 = -0.5 * (a.max(b).max(c) + a.min(b).min(c));
    [a, b, c].map(|v| (0.5 + v + v0).clamp(0.0, 1.0))
}

/// The largest difference in Q15 LSB of the duty between the fixed duties and `want`.
fn duty_lsb(d: DutiesQ15, want: [f64; 3]) -> f64 {
    [d.a, d.b, d.c]
        .iter()
        .zip(want)
        .map(|(&q, w)| (f64::from(q) - w * 32_768.0).abs())
        .fold(0.0, f64::max)
}

/// The vectors of the SVPWM tests (per unit of the bus, as Q15): a grid over the whole Q15
/// square (step 1/256, the over-modulation region included), and rings at 4096 angles at and
/// about the circle (1/√3 ± 4 LSB) and the hexagon's corners (2/3 ± 4 LSB), and a ring at
/// the square's corner radius.
fn svpwm_vectors() -> Vec<AlphaBetaQ15> {
    let mut v = Vec::new();
    for i in -128..128 {
        for j in -128..128 {
            v.push(AlphaBetaQ15 {
                alpha: (i * 256) as i16,
                beta: (j * 256) as i16,
            });
        }
    }
    let circle = 32_768.0 / 3f64.sqrt();
    let corner = 32_768.0 * 2.0 / 3.0;
    for r in [
        circle - 4.0,
        circle - 1.0,
        circle,
        circle + 1.0,
        circle + 4.0,
        corner - 4.0,
        corner,
        corner + 4.0,
        32_767.0,
        46_000.0,
    ] {
        for k in 0..4096 {
            let th = k as f64 * TAU / 4096.0;
            let q = |x: f64| x.round().clamp(-32_768.0, 32_767.0) as i16;
            v.push(AlphaBetaQ15 {
                alpha: q(r * th.cos()),
                beta: q(r * th.sin()),
            });
        }
    }
    v
}

/// The fixed-point SVPWM (`svpwm_q15`) against the f32 `svpwm` on the same vectors (the Q15
/// vector times a 24 V bus), over `svpwm_vectors`.
///
/// Bounds, in Q15 LSB of a duty (`pmsm_sensorless::fixed::svpwm`'s module doc): in the
/// linear range 0.75 LSB (two phases' 0.11, one rounding's ½). Cut to the circle: the cut
/// vector within `δ` = 1.46 LSB of the f32 one (the unit vector's direction, 2.4·10⁻⁵ rad at
/// the circle: 0.46 LSB; the radius's Q17 rounding and its constant's, ⅛ + 0.11; the Q17
/// components' ⅛ each; 0.58 for a component at −32 768), its Q15 report within `δ + √2/2`,
/// and a duty `v_k + v0` moves by at most 1.5 `δ` (`v_a − (v_b + v_c)/2 = 1.5 v_a` for the
/// middle phase): `1.5 δ + 0.75` LSB. The two agree on saturation but within `δ` of the
/// circle.
#[test]
fn svpwm_matches_the_f32_svpwm() {
    let v_bus = 24.0f32;
    let (mut worst_lin, mut worst_cut, mut worst_applied) = (0.0f64, 0.0f64, 0.0f64);
    let (mut n_lin, mut n_cut, mut n_disagree) = (0, 0, 0);
    let delta = 0.46 + 0.125 + 0.11 + 2.0f64.sqrt() * 0.125 + 0.58;
    let circle = 32_768.0 / 3f64.sqrt();
    for v in svpwm_vectors() {
        let q = svpwm_q15(v);
        let va = AlphaBeta::new(
            f32::from(v.alpha) / 32_768.0 * v_bus,
            f32::from(v.beta) / 32_768.0 * v_bus,
        );
        let r = svpwm(va, v_bus);
        let want = [r.duties.a, r.duties.b, r.duties.c].map(f64::from);
        let err = duty_lsb(q.duties, want);
        for d in [q.duties.a, q.duties.b, q.duties.c] {
            assert!(d <= DUTY_ONE, "{v:?}: {d}");
        }
        if q.saturated != r.saturated {
            n_disagree += 1;
            let mag = f64::from(v.alpha).hypot(f64::from(v.beta));
            assert!((mag - circle).abs() <= delta, "{v:?}: {mag}");
            continue;
        }
        if q.saturated {
            n_cut += 1;
            worst_cut = worst_cut.max(err);
            let applied = (f64::from(q.v_ab_applied.alpha)
                - f64::from(r.v_ab_applied.alpha / v_bus) * 32_768.0)
                .hypot(
                    f64::from(q.v_ab_applied.beta)
                        - f64::from(r.v_ab_applied.beta / v_bus) * 32_768.0,
                );
            worst_applied = worst_applied.max(applied);
            assert!(
                applied <= delta + 0.5 * 2f64.sqrt(),
                "{v:?}: applied {applied}"
            );
            assert!(err <= 1.5 * delta + 0.75, "{v:?}: {err} LSB");
        } else {
            n_lin += 1;
            worst_lin = worst_lin.max(err);
            assert_eq!(q.v_ab_applied, v);
            assert!(err <= 0.75, "{v:?}: {err} LSB");
        }
    }
    println!(
        "svpwm: linear {worst_lin:.3} LSB ({n_lin} vectors), cut {worst_cut:.3} LSB (bound {:.2}; {n_cut} vectors, applied vector within {worst_applied:.2} LSB), saturation differs on {n_disagree} vectors at the circle",
        1.5 * delta + 0.75
    );
    assert_eq!(
        svpwm_q15(AlphaBetaQ15::default()).duties,
        DutiesQ15::NEUTRAL
    );
}

/// The limited form (`svpwm_limited_q15`, the FOC's) against min–max injection without a cut
/// (the f32 `svpwm_limited`'s formula, in f64) inside the hexagon, and against the f32
/// `svpwm` beyond it: the same bounds as `svpwm_matches_the_f32_svpwm`; the two differ on
/// whether a vector is inside only within an LSB of the hexagon (its span within 2 LSB of
/// the bus).
#[test]
fn svpwm_limited_matches_the_f32_formula() {
    let v_bus = 24.0f32;
    let (mut worst_in, mut worst_out, mut n_edge) = (0.0f64, 0.0f64, 0);
    let delta = 0.46 + 0.125 + 0.11 + 2.0f64.sqrt() * 0.125 + 0.58;
    for v in svpwm_vectors() {
        let q = svpwm_limited_q15(v);
        let (al, be) = (f64::from(v.alpha) / 32_768.0, f64::from(v.beta) / 32_768.0);
        let ph = [al, -0.5 * al + 0.75f64.sqrt() * be];
        let c = -ph[0] - ph[1];
        let span = (ph[0].max(ph[1]).max(c) - ph[0].min(ph[1]).min(c)) * 32_768.0;
        if (span - 32_768.0).abs() <= 2.0 {
            n_edge += 1;
            continue;
        }
        if span < 32_768.0 {
            assert!(!q.saturated, "{v:?}");
            let err = duty_lsb(q.duties, injection_f64(al, be));
            worst_in = worst_in.max(err);
            assert!(err <= 0.75, "{v:?}: {err} LSB");
        } else {
            assert!(q.saturated, "{v:?}");
            let r = svpwm(AlphaBeta::new(al as f32 * v_bus, be as f32 * v_bus), v_bus);
            let err = duty_lsb(
                q.duties,
                [r.duties.a, r.duties.b, r.duties.c].map(f64::from),
            );
            worst_out = worst_out.max(err);
            assert!(err <= 1.5 * delta + 0.75, "{v:?}: {err} LSB");
        }
    }
    println!(
        "svpwm limited: inside the hexagon {worst_in:.3} LSB, beyond it (cut) {worst_out:.3} LSB, {n_edge} vectors within 2 LSB of the hexagon not compared"
    );
}

/// A motor held at `rpm` by the sensored controller under `load` of its rated torque.
fn constant_speed(motor: Motor, rpm: f64, load: f64, duration_s: f64) -> Scenario {
    let load_nm = load * f64::from(motor.ratings.torque_nm);
    Scenario::constant_speed("test-fixed-sliding", motor, rpm, load_nm, duration_s)
}

/// Worst differences of one sliding-observer run after `settle_s`.
#[derive(Default, Debug, Clone, Copy)]
struct SlidingDiff {
    /// |θ̂_e fixed − θ̂_e f32| \[°].
    angle_deg: f64,
    /// |ω̂ fixed − ω̂ f32| over the rated speed.
    speed_rel: f64,
    /// |τ̂_L fixed − τ̂_L f32| over the rated torque.
    load_rel: f64,
    /// Each observer's error to the true angle \[°].
    fixed_true_deg: f64,
    f32_true_deg: f64,
}

/// The plant of `motor` at its drive's rate, held at `rpm` under `load` by the encoder; the
/// f32 sliding observer (`cfg.sliding_config()`) and the fixed one fed the same Q15-rounded
/// currents and voltages, both started at the true rotor state.
fn sliding_run(motor: Motor, rpm: f64, load: f64, duration_s: f64) -> SlidingDiff {
    let cfg = DriveConfig::new(&motor);
    let pu = PerUnit::of_drive(&cfg).unwrap();
    let s_cfg = cfg.sliding_config();
    let obs = s_cfg.build().unwrap();
    let q = SlidingObserverQ::build(&s_cfg, &pu).unwrap();
    let m = motor.params;
    let n = f64::from(m.n());
    let tau_b = m.flux_wb * m.n() * pu.i_base_a;
    let rate = f64::from(cfg.rate_hz);
    let sc = constant_speed(motor, rpm, load, duration_s);
    let mut sim_cfg = SimConfig::new(sc, ObserverKind::Encoder);
    sim_cfg.rate_hz = rate;
    sim_cfg.substeps = (sim_cfg.substeps as f64 * 4000.0 / rate).ceil().max(1.0) as usize;
    let steps = (duration_s * rate) as usize;
    let mut sim = Sim::new(sim_cfg).unwrap();
    let (mut st, mut st_q) = (SlidingState::default(), SlidingStateQ::default());
    let mut v_last = AlphaBeta::default();
    let mut d = SlidingDiff::default();
    let fq = |x: i16| f32::from(x) / 32_768.0;
    let rated_w = f64::from(motor.ratings.speed_rpm) * TAU / 60.0;
    for k in 0..steps {
        let p = sim.plant();
        let i = p.i_abc();
        let i_ab = Abc::new(i[0] as f32, i[1] as f32, i[2] as f32).to_alpha_beta();
        let theta = wrap(p.state.theta_e(&p.params));
        let omega_m = p.state.omega_m;
        let i_q = AlphaBetaQ15 {
            alpha: pu.current(i_ab.alpha),
            beta: pu.current(i_ab.beta),
        };
        let v_q = AlphaBetaQ15 {
            alpha: pu.voltage(v_last.alpha),
            beta: pu.voltage(v_last.beta),
        };
        let i_r = AlphaBeta::new(fq(i_q.alpha) * pu.i_base_a, fq(i_q.beta) * pu.i_base_a);
        let v_r = AlphaBeta::new(fq(v_q.alpha) * pu.v_base_v, fq(v_q.beta) * pu.v_base_v);
        if k == 0 {
            let rotor = Rotor {
                theta_e: theta as f32,
                omega_m: omega_m as f32,
                load_nm: (load * f64::from(motor.ratings.torque_nm)) as f32,
            };
            obs.seed(&mut st, i_r, rotor);
            q.reset(
                &mut st_q,
                i_q,
                Angle::from_rad(theta as f32),
                pu.speed(omega_m as f32 * m.n()),
                pmsm_sensorless::fixed::pu::to_q15(st.load_nm / tau_b),
            );
        }
        obs.update(&mut st, i_r, v_r);
        q.update(&mut st_q, i_q, v_q);
        if sim.t() >= 0.02 {
            let deg = |a: f64, b: f64| wrap(a - b).abs().to_degrees();
            let fixed = f64::from(st_q.theta_e.to_rad());
            d.angle_deg = d.angle_deg.max(deg(fixed, f64::from(st.theta_e)));
            d.fixed_true_deg = d.fixed_true_deg.max(deg(fixed, theta));
            d.f32_true_deg = d.f32_true_deg.max(deg(f64::from(st.theta_e), theta));
            let w_q = f64::from(st_q.omega) / 2_147_483_648.0 * f64::from(pu.omega_base_e) / n;
            d.speed_rel = d
                .speed_rel
                .max((w_q - f64::from(st.omega_m)).abs() / rated_w);
            let tau_q = f64::from(st_q.load) / 2_147_483_648.0 * f64::from(tau_b);
            d.load_rel = d
                .load_rel
                .max((tau_q - f64::from(st.load_nm)).abs() / f64::from(motor.ratings.torque_nm));
        }
        let row = sim.step().unwrap();
        v_last = AlphaBeta::new(row.v_alpha as f32, row.v_beta as f32);
    }
    d
}

/// The fixed-point sliding torque observer beside the f32 one on the plant's currents and
/// voltages of a sensored run (0.3 s), at 10 % (about the hand-over), 50 % and 100 % of rated
/// speed under half the rated torque, both started at the true rotor state, on every zoo motor and preset whose drive
/// accepts the sliding observer (`DriveConfig::sliding_torque`). Printed: the differences and
/// both observers' errors to the true angle.
///
/// Required where the f32 observer tracks the rotor (within 10° of the true angle: two locked
/// observers compared), as of the PLL (issue #30): the angles within 0.5°, the speeds within
/// 0.5 % of the rated speed, the load torques within 0.5 % of the rated torque. Where the f32
/// observer itself is lost (on this sensored run: the EMRAX and the drone at both speeds, the
/// salient Brusa and the 40 kW machine at rated speed) the two drift apart as two runs of a
/// chaotic system do: printed, not compared.
#[test]
fn sliding_observer_matches_the_f32_observer_on_the_plant() {
    let mut worst = Worst3::default();
    for (name, motor) in all_motors() {
        let cfg = DriveConfig::new(&motor);
        let pu = PerUnit::of_drive(&cfg).unwrap();
        let accepted = cfg.sliding_torque().is_ok();
        let built = SlidingObserverQ::build(&cfg.sliding_config(), &pu);
        if !accepted || built.is_err() {
            println!(
                "{name:34} drive accepts: {accepted}, fixed builds: {:?}",
                built.err()
            );
            continue;
        }
        for frac in [0.1, 0.5, 1.0] {
            let rpm = frac * f64::from(motor.ratings.speed_rpm);
            let d = sliding_run(motor, rpm, 0.5, 0.3);
            println!(
                "{name:34} {rpm:6.0} rpm: fixed vs f32: angle {:.4}°, speed {:.2e} of rated, load {:.2e} of rated; to the true angle: fixed {:.3}°, f32 {:.3}°",
                d.angle_deg, d.speed_rel, d.load_rel, d.fixed_true_deg, d.f32_true_deg
            );
            if d.f32_true_deg <= 10.0 {
                assert!(d.angle_deg <= 0.5, "{name} {rpm}: {d:?}");
                assert!(d.speed_rel <= 0.005, "{name} {rpm}: {d:?}");
                assert!(d.load_rel <= 0.005, "{name} {rpm}: {d:?}");
                worst = worst.max(d.angle_deg, d.speed_rel, d.load_rel);
            }
        }
    }
    println!(
        "worst where the f32 observer tracks: angle {:.4}°, speed {:.2e} of rated, load {:.2e} of rated",
        worst.0, worst.1, worst.2
    );
}

/// Running maxima of three figures.
#[derive(Default, Clone, Copy)]
struct Worst3(f64, f64, f64);

impl Worst3 {
    fn max(self, a: f64, b: f64, c: f64) -> Self {
        Self(self.0.max(a), self.1.max(b), self.2.max(c))
    }
}
