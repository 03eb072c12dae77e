//! The fixed-point current loop and flux observer (`pmsm_sensorless::fixed::{current, flux}`,
//! issue #30) against their f32 references on the Sinano preset and a small and a large zoo
//! motor, in the per-unit bases each motor's drive configuration gives (`PerUnit::of_drive`).
//! Bounds are in Q15 LSB of the base, or degrees, and derived in each test.

mod common;
use common::Lcg;
use pmsm_host_sim::motor_file;
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::scenario::Scenario;
use pmsm_host_sim::sim::{wrap_rad, Sim, SimConfig};
use pmsm_sensorless::drive::DriveConfig;
use pmsm_sensorless::fixed::current::{CurrentLoopQ, CurrentLoopStateQ};
use pmsm_sensorless::fixed::flux::{FluxObserverQ, FluxStateQ};

use pmsm_sensorless::fixed::pu::{unit_q15, Gain, PerUnit};
use pmsm_sensorless::fixed::{AlphaBetaQ15, Angle, DqQ15, Q15};
use pmsm_sensorless::foc::CurrentLoopState;
use pmsm_sensorless::frames::{Abc, AlphaBeta, Dq};
use pmsm_sensorless::motor::{Motor, HORNG_SINANO};
use pmsm_sensorless::observer::flux::FluxState;

const LSB: f32 = 32_768.0;

fn zoo(file: &str) -> Motor {
    let path = format!(
        "{}/host-sim/motors/zoo/{file}.toml",
        env!("CARGO_MANIFEST_DIR")
    );
    motor_file::load(std::path::Path::new(&path)).unwrap().1
}

/// The Sinano preset, a small zoo motor (Anaheim BLY171D, 24 V, 0.75 Ω, 1 mH) and a large
/// one (EMRAX 228, 10 pole pairs, axial flux).
fn motors() -> Vec<(&'static str, Motor)> {
    vec![
        ("sinano", HORNG_SINANO),
        ("anaheim-bly171d", zoo("small-anaheim-bly171d-24v-4000")),
        ("emrax-228", zoo("axial-emrax-228-mv")),
    ]
}

fn f(x: Q15) -> f32 {
    f32::from(x) / LSB
}

/// Gains hold their value to the 14-bit mantissa: relative 2⁻¹⁴ for values ≥ 2⁻¹⁷, and
/// apply it rounded to ½ LSB.
#[test]
fn gains_round_to_their_mantissa() {
    let mut g = Lcg(7);
    for _ in 0..10_000 {
        let value = 10f32.powf(g.next_f32() * 5.0 - 0.9).min(16_000.0);
        let gain = Gain::new("test", value).unwrap();
        assert!(
            value < 1.0 / 131_072.0 || ((gain.value() - value) / value).abs() <= 1.0 / 16_384.0,
            "{value}: {}",
            gain.value()
        );
        let x = (g.next_f32() * 65_536.0) as i32;
        let exact = f64::from(x) * f64::from(gain.value());
        if exact.abs() < 2.0f64.powi(30) {
            assert!(
                (f64::from(gain.apply(x)) - exact).abs() <= 0.5,
                "{value} {x}"
            );
        }
    }
    assert!(Gain::new("test", 16_384.0).is_err());
    assert!(Gain::new("test", -1.0).is_err());
}

/// The division-free unit vector over 10⁵ seeded vectors of 16..32 767 LSB length: the
/// direction within the rounding of the two components (½ LSB each: √2/2/32 768 rad =
/// 2.2·10⁻⁵ rad, with 10 % for the reference's own f32), the length within 3 LSB of 1
/// (Newton's 2.9·10⁻⁶ = 0.1 LSB, the Q15 truncations of u in each step, 1 LSB each, the
/// final rounding, ½ LSB).
#[test]
fn unit_vectors_without_division() {
    let mut g = Lcg(11);
    let (mut worst_dir, mut worst_len) = (0.0f64, 0.0f64);
    for k in 0..100_000 {
        let len = if k % 2 == 0 {
            32_767.0
        } else {
            16.0 + 32_751.0 * g.next_f32().abs()
        };
        let th = g.next_f32() * std::f32::consts::PI;
        let (x, y) = (
            (len * th.cos()).round() as i32,
            (len * th.sin()).round() as i32,
        );
        let (x, y) = (x.clamp(-32_767, 32_767), y.clamp(-32_767, 32_767));
        let (c, s) = unit_q15(x, y).unwrap();
        let want = f64::from(y).atan2(f64::from(x));
        let got = f64::from(s).atan2(f64::from(c));
        let d = (got - want + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
            - std::f64::consts::PI;
        worst_dir = worst_dir.max(d.abs());
        worst_len = worst_len.max((f64::from(c).hypot(f64::from(s)) - 32_768.0).abs());
    }
    println!("unit_q15: direction {worst_dir:.2e} rad, length {worst_len:.2} LSB");
    assert!(
        worst_dir <= 1.1 * 0.5 * 2f64.sqrt() / 32_768.0 * 1.0001,
        "{worst_dir}"
    );
    assert!(worst_len <= 3.0, "{worst_len}");
    assert_eq!(unit_q15(0, 0), None);
    assert_eq!(unit_q15(1, 0), Some((32_767, 0)));
}

/// Every non-salient zoo motor and the presets: the bases and whether each fixed-point block
/// builds on its drive's configuration (printed); the three motors of these tests must.
#[test]
fn bases_and_formats_of_the_zoo() {
    let all = common::all_motors();
    for (name, motor) in &all {
        let cfg = DriveConfig::new(motor);
        let pu = PerUnit::of_drive(&cfg).unwrap();
        let cl = CurrentLoopQ::build(&cfg.foc_config(), &pu);
        let fl = FluxObserverQ::build(&cfg.flux_config(), &pu);
        println!(
            "{name:40} {:6.0} Hz I_b {:8.2} A V_b {:7.2} V w_b {:8.0} rad/s psi_b {:.4} Wb (Phi/psi_b {:.3}): current loop {}, flux {}",
            cfg.rate_hz,
            pu.i_base_a,
            pu.v_base_v,
            pu.omega_base_e,
            pu.flux_base_wb,
            motor.params.flux_wb / pu.flux_base_wb,
            match &cl {
                Ok(c) => format!("Q{} integrators", 15 + c.integrator_bits()),
                Err(e) => format!("refused ({e})"),
            },
            match &fl {
                Ok(_) => "ok".to_string(),
                Err(e) => format!("refused ({e})"),
            },
        );
    }
    for (name, motor) in motors() {
        let cfg = DriveConfig::new(&motor);
        let pu = PerUnit::of_drive(&cfg).unwrap();
        assert!(
            CurrentLoopQ::build(&cfg.foc_config(), &pu).is_ok(),
            "{name}"
        );
        assert!(
            FluxObserverQ::build(&cfg.flux_config(), &pu).is_ok(),
            "{name}"
        );
    }
}

/// One update of the fixed-point current loop against the f32 loop from the same state on
/// the same (Q15) inputs, 2·10⁵ seeded samples a motor over the range its drive reaches:
/// currents and references within ±i_trip (1.5 i_max), speed within ±1.2× the rated
/// electrical speed, bus between its limits, integrators within ±v_max.
///
/// Bound, inside the circle, in LSB of V_b: each gained term rounds once (½ LSB) and carries
/// its mantissa's 2⁻¹⁴ relative; the integrator rounds to Q15 (½); `ω i` rounds to Q16
/// (½ LSB of Q16 through the gain `c/2`, `c = L I_b/ψ_f`: c/4): `1.5 + c/4 +
/// 2⁻¹⁴ (|k_p e| + |c ω i|)`, and 2⁻²⁰ of the terms for the f32 reference's own rounding.
/// On the circle: that error's direction share (at most the same), the unit vector's 3 LSB
/// and its ½ LSB rounding, the cut's 4 LSB, 2 LSB for the shift of a vector beyond 1 pu:
/// bound + 10. The integrators (Q15 LSB): 2⁻¹⁴ |k_i T e| + 2⁻¹⁶. The two loops agree on
/// saturation except within the bound of the circle.
#[test]
fn current_loop_matches_the_f32_loop() {
    for (name, motor) in motors() {
        let cfg = DriveConfig::new(&motor);
        let pu = PerUnit::of_drive(&cfg).unwrap();
        let foc_cfg = cfg.foc_config();
        let foc = foc_cfg.build().unwrap();
        let reference = foc.current_loop();
        let q = CurrentLoopQ::build(&foc_cfg, &pu).unwrap();
        let g = foc_cfg.gains();
        let ts = 1.0 / foc_cfg.current_rate_hz;
        let z = pu.i_base_a / pu.v_base_v;
        let c_l = motor.params.l_h * pu.i_base_a / motor.params.flux_wb;
        let omega_rated = motor.ratings.speed_rpm * motor.params.n() * std::f32::consts::TAU / 60.0;
        let i_trip = cfg.limits.i_trip_a;
        let mut rng = Lcg(0xc0ffee);
        let (mut worst_in, mut worst_cut, mut worst_int, mut ratio_in, mut ratio_cut) =
            (0.0f32, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
        let (mut n_cut, mut n_disagree, mut n_released) = (0, 0, 0);
        let int_scale = (1u64 << (15 + q.integrator_bits())) as f32;
        for _ in 0..200_000 {
            let i = DqQ15 {
                d: pu.current(rng.next_f32() * i_trip),
                q: pu.current(rng.next_f32() * i_trip),
            };
            let r = DqQ15 {
                d: pu.current(rng.next_f32() * i_trip),
                q: pu.current(rng.next_f32() * i_trip),
            };
            let w = pu.speed(rng.next_f32() * 1.2 * omega_rated);
            let v_bus = cfg.limits.bus_min_v
                + (cfg.limits.bus_max_v - cfg.limits.bus_min_v) * rng.next_f32().abs();
            let v_max = pu.voltage(foc.v_max(v_bus));
            let mut st = CurrentLoopStateQ {
                integral_d: q.integral_of(rng.next_f32() * f(v_max)),
                integral_q: q.integral_of(rng.next_f32() * f(v_max)),
            };
            let mut st_f = CurrentLoopState {
                integral_d: st.integral_d as f32 / int_scale * pu.v_base_v,
                integral_q: st.integral_q as f32 / int_scale * pu.v_base_v,
            };
            let (int_q0, int_q0_f) = (st.integral_q, st_f.integral_q);
            let out = q.update(&mut st, i, r, w, v_max);
            let i_f = Dq::new(f(i.d) * pu.i_base_a, f(i.q) * pu.i_base_a);
            let r_f = Dq::new(f(r.d) * pu.i_base_a, f(r.q) * pu.i_base_a);
            let w_f = f(w) * pu.omega_base_e;
            let out_f = reference.update(&mut st_f, i_f, r_f, w_f, f(v_max) * pu.v_base_v);
            assert!(out.valid && out_f.valid);
            // Bound of the terms (LSB of V_b).
            let (e_d, e_q) = (f(r.d) - f(i.d), f(r.q) - f(i.q));
            let kp_e = (g.current_kp * z * e_d.abs()).max(g.current_kp_q * z * e_q.abs()) * LSB;
            let w_i = c_l * f(w).abs() * f(i.d).abs().max(f(i.q).abs()) * LSB;
            let terms = kp_e + w_i + f(w).abs() * LSB + f(v_max) * LSB;
            let bound = 1.5 + c_l / 4.0 + (kp_e + w_i) / 16_384.0 + terms / 1_048_576.0;
            let err = ((f(out.v_dq.d) - out_f.v_dq.d / pu.v_base_v).abs())
                .max((f(out.v_dq.q) - out_f.v_dq.q / pu.v_base_v).abs())
                * LSB;
            // |v| before the cut, from the f32 loop's terms.
            if out.saturated != out_f.saturated {
                n_disagree += 1;
                let mag = out_f.v_dq.d.hypot(out_f.v_dq.q) / pu.v_base_v * LSB;
                assert!(
                    (mag - f32::from(v_max)).abs() <= bound + 10.0,
                    "{name}: saturation differs away from the circle: {mag} vs {v_max}"
                );
                continue;
            }
            if out.saturated {
                n_cut += 1;
                // On the circle the q integrator moves only under a braking command where
                // its step shortens v_q (`foc/current.rs`): both loops decide alike but where
                // v_q, whose sign the cut keeps, is within the bound of zero.
                let (moved, moved_f) = (st.integral_q != int_q0, st_f.integral_q != int_q0_f);
                n_released += usize::from(moved);
                if moved != moved_f {
                    let v_q_lsb = out_f.v_dq.q.abs() / pu.v_base_v * LSB;
                    assert!(
                        v_q_lsb <= bound + 10.0,
                        "{name}: the q integrator moved {moved} (f32 {moved_f}) at v_q {v_q_lsb} LSB"
                    );
                }
                worst_cut = worst_cut.max(err);
                ratio_cut = ratio_cut.max(err / (bound + 10.0));
                let (d, qq) = (i32::from(out.v_dq.d), i32::from(out.v_dq.q));
                assert!(
                    d * d + qq * qq <= i32::from(v_max).pow(2),
                    "{name}: outside the circle"
                );
            } else {
                worst_in = worst_in.max(err);
                ratio_in = ratio_in.max(err / bound);
                let ki_e = g.current_ki * ts * z * e_d.abs().max(e_q.abs()) * LSB;
                // The fixed loop holds its integrators within ±2 pu (module doc). In f64: the
                // f32 reference's own roundings (its state converted from the fixed one, two;
                // its update, two: 2⁻²⁴ of its value each) are added to the bound.
                let v_b = f64::from(pu.v_base_v);
                let clamped = |x: f32| (f64::from(x) / v_b).clamp(-2.0, 2.0);
                let fixed = |x: i32| f64::from(x) / f64::from(int_scale);
                let int_err = ((fixed(st.integral_d) - clamped(st_f.integral_d)).abs())
                    .max((fixed(st.integral_q) - clamped(st_f.integral_q)).abs())
                    * f64::from(LSB);
                let ulp = f64::from(st_f.integral_d.abs().max(st_f.integral_q.abs())) / v_b
                    * f64::from(LSB)
                    / 16_777_216.0;
                let int_err = int_err as f32;
                assert!(
                    f64::from(int_err) <= f64::from(ki_e) / 16_384.0 + 1.0 / 65_536.0 + 4.0 * ulp,
                    "{name}: integrator {int_err}: {st:?} {st_f:?} f {} ki_e {ki_e}",
                    q.integrator_bits()
                );
                worst_int = worst_int.max(int_err);
            }
        }
        println!(
            "{name}: inside the circle worst {worst_in:.2} LSB ({:.0} % of its bound), cut {worst_cut:.2} LSB ({:.0} %, {n_cut} samples, the q integrator released on {n_released}), integrators {worst_int:.4} LSB, saturation differs on {n_disagree} samples at the circle",
            100.0 * ratio_in,
            100.0 * ratio_cut
        );
        assert!(ratio_in <= 1.0, "{name}: {ratio_in}");
        assert!(ratio_cut <= 1.0, "{name}: {ratio_cut}");
        assert!(n_released > 0, "{name}: no braking sample on the circle");
    }
}

/// A motor held at `rpm` by the sensored controller under `load` of its rated torque.
fn constant_speed(motor: Motor, rpm: f64, load: f64, duration_s: f64) -> Scenario {
    let load_nm = load * f64::from(motor.ratings.torque_nm);
    Scenario::constant_speed("test-fixed-flux", motor, rpm, load_nm, duration_s)
}

fn wrap_deg(x: f64) -> f64 {
    wrap_rad(x.to_radians()).to_degrees()
}

/// Worst angle differences of one run, degrees (after `settle_s`).
#[derive(Default, Debug)]
struct Diff {
    /// Fixed against f32, both fed the same Q15-rounded samples.
    same_inputs: f64,
    /// Fixed against f32 fed the plant's f32 samples (the input rounding included).
    raw_inputs: f64,
    /// Fixed against the plant's true angle; the f32 observer's against it.
    fixed_true: f64,
    f32_true: f64,
}

/// The plant of `motor` on its drive's rate, held at `rpm` under `load` by the encoder; the
/// f32 observer (`cfg.flux_config()`) and the fixed one fed its currents and voltages: twice
/// the f32 observer (once on the Q15-rounded samples, once on the raw ones). `start_zero`:
/// both start from `x̂ = 0` (else from the true angle).
fn flux_run(motor: Motor, rpm: f64, load: f64, start_zero: bool, settle_s: f64) -> Diff {
    let cfg = DriveConfig::new(&motor);
    let pu = PerUnit::of_drive(&cfg).unwrap();
    let flux_cfg = cfg.flux_config();
    let obs = flux_cfg.build().unwrap();
    let q = FluxObserverQ::build(&flux_cfg, &pu).unwrap();
    let rate = f64::from(cfg.rate_hz);
    let sc = constant_speed(motor, rpm, load, settle_s + 0.1);
    let mut sim_cfg = SimConfig::new(sc, ObserverKind::Encoder);
    sim_cfg.rate_hz = rate;
    sim_cfg.substeps = (sim_cfg.substeps as f64 * 4000.0 / rate).ceil().max(1.0) as usize;
    let steps = (sim_cfg.scenario.duration_s * rate) as usize;
    let mut sim = Sim::new(sim_cfg).unwrap();
    let (mut st, mut st_raw, mut st_q) = (
        FluxState::default(),
        FluxState::default(),
        FluxStateQ::default(),
    );
    let mut v_last = AlphaBeta::default();
    let mut d = Diff::default();
    let deq = |x: AlphaBetaQ15, base: f32| AlphaBeta::new(f(x.alpha) * base, f(x.beta) * base);
    for k in 0..steps {
        let p = sim.plant();
        let i = p.i_abc();
        let i_ab = Abc::new(i[0] as f32, i[1] as f32, i[2] as f32).to_alpha_beta();
        let theta = wrap_rad(p.state.theta_e(&p.params));
        let t = sim.t();
        let i_q = AlphaBetaQ15 {
            alpha: pu.current(i_ab.alpha),
            beta: pu.current(i_ab.beta),
        };
        let v_q = AlphaBetaQ15 {
            alpha: pu.voltage(v_last.alpha),
            beta: pu.voltage(v_last.beta),
        };
        let (i_r, v_r) = (deq(i_q, pu.i_base_a), deq(v_q, pu.v_base_v));
        if k == 0 {
            if start_zero {
                obs.integrate(&mut st, i_r, v_r);
                obs.integrate(&mut st_raw, i_ab, v_last);
                q.integrate(&mut st_q, i_q, v_q);
            } else {
                obs.reset(&mut st, i_r, theta as f32);
                obs.reset(&mut st_raw, i_ab, theta as f32);
                q.reset(&mut st_q, i_q, Angle::from_rad(theta as f32));
            }
        } else {
            obs.integrate(&mut st, i_r, v_r);
            obs.integrate(&mut st_raw, i_ab, v_last);
            q.integrate(&mut st_q, i_q, v_q);
        }
        if t >= settle_s {
            let angle =
                |x: &FluxState| f64::from(x.rotor_flux.beta).atan2(f64::from(x.rotor_flux.alpha));
            let (s, c) = st_q.sin_cos().unwrap();
            let fixed = f64::from(s).atan2(f64::from(c));
            let deg = |a: f64, b: f64| wrap_deg((a - b).to_degrees()).abs();
            d.same_inputs = d.same_inputs.max(deg(fixed, angle(&st)));
            d.raw_inputs = d.raw_inputs.max(deg(fixed, angle(&st_raw)));
            d.fixed_true = d.fixed_true.max(deg(fixed, theta));
            d.f32_true = d.f32_true.max(deg(angle(&st_raw), theta));
        }
        let row = sim.step().unwrap();
        v_last = AlphaBeta::new(row.v_alpha as f32, row.v_beta as f32);
    }
    d
}

/// The fixed-point flux observer beside the f32 one on the plant's currents and voltages of
/// a sensored run, at 10 %, 50 % and 100 % of rated speed under half the rated torque, from
/// the true angle and from `x̂ = 0` (then compared after 0.2 s), on the three motors.
///
/// Bound: the fixed observer's angle is that of `η̂`, whose components round to ½ LSB with
/// the current's term `k_l i` (½ LSB) and carry the gains' 2⁻¹⁴: within 1.5 LSB of `η̂`'s
/// f32 value at a sample, which is `Φ/ψ_b·32 768` LSB long: `1.5·√2/(Φ/ψ_b·32 768)` rad;
/// the unit vector's direction adds 2.2·10⁻⁵ rad. What a sample's rounding leaves in `x̂`
/// is forgotten at the observer's radial rate and turned with the rotor: allowed ×4 of one
/// sample's error, with the f32 observer's own rounding (2⁻²⁴ of `|x̂|` a sample, over
/// 1/(γΦ²T) samples): `4·(1.5·√2·ψ_b/(Φ·32 768) + 2.2·10⁻⁵) + 2⁻²⁴/(γΦ²T)` rad.
/// Against the f32 observer fed the raw samples, the input rounding (½ LSB of V_b, I_b on
/// each sample) enters as well; that comparison and both observers' error to the true angle
/// are printed, and the fixed observer's error to the true angle is held within the f32
/// observer's plus that bound plus the raw comparison.
#[test]
fn flux_observer_matches_the_f32_observer_on_the_plant() {
    for (name, motor) in motors() {
        let cfg = DriveConfig::new(&motor);
        let pu = PerUnit::of_drive(&cfg).unwrap();
        let flux_cfg = cfg.flux_config();
        let phi_pu = f64::from(motor.params.flux_wb / pu.flux_base_wb);
        let g_phi2_t = f64::from(flux_cfg.gamma * motor.params.flux_wb.powi(2) / flux_cfg.rate_hz);
        let bound_rad = 4.0 * (1.5 * 2f64.sqrt() / (phi_pu * 32_768.0) + 2.2e-5)
            + 1.0 / 16_777_216.0 / g_phi2_t;
        let bound = bound_rad.to_degrees();
        for frac in [0.1, 0.5, 1.0] {
            for start_zero in [false, true] {
                let rpm = frac * f64::from(motor.ratings.speed_rpm);
                let settle = if start_zero { 0.2 } else { 0.0 };
                let d = flux_run(motor, rpm, 0.5, start_zero, settle);
                println!(
                    "{name} {rpm:7.0} rpm {}: fixed vs f32 {:.4}° (same inputs; bound {bound:.4}°), {:.4}° (raw inputs); to the true angle: fixed {:.3}°, f32 {:.3}°",
                    if start_zero { "from x=0 " } else { "from true" },
                    d.same_inputs,
                    d.raw_inputs,
                    d.fixed_true,
                    d.f32_true
                );
                assert!(d.same_inputs <= bound, "{name} {rpm}: {d:?}");
                assert!(
                    d.fixed_true <= d.f32_true + bound + d.raw_inputs,
                    "{name} {rpm}: {d:?}"
                );
            }
        }
    }
}
