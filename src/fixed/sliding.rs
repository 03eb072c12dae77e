//! Horng & Chin's sliding torque observer in fixed point: the f32
//! [`crate::observer::sliding::SlidingObserver`] (eqs (20)-(22), (34), (35), the boundary layer
//! `sat(S/ε)` of Sec 4, the low-speed floor `ω̂_low` of Sec 5, the back-EMF at the middle of the
//! period; the same forward-Euler step and order of operations) in the [`PerUnit`] bases.
//! A constant `K_s` only (the drive's); `SlidingGain::PerSpeed` is refused.
//!
//! Per unit: currents of `I_b`, voltages of `V_b`, the speed as the electrical `Ω = N ω/ω_b`
//! (`ω_b = V_b/ψ_f`, so the back-EMF `K N ω` is `Ω` volts per unit), the load torque of
//! `τ_b = K N I_b` (the paper's model, `τ = K N i_q`). One sample, with `σ = sat(S/ε)`,
//! `P = c σ_a + s σ_b`, `Q = s σ_a − c σ_b` (angle θ̂_e), `R = 1/Ω_g` (`Ω_g`: `Ω` floored at
//! `±Ω_low = N ω_low/ω_b`), `î_d = î_a c + î_b s`:
//!
//! ```text
//! î  += −(TR/L) î + (T V_b/(L I_b)) (Ω s_mid + v_a) − (K_s T/I_b) σ_a       (20); β: −Ω c_mid (21)
//! θ̂_e += Δ = Ω ω_b T                                                       (22), wrapping
//! Ω  += −(TB/H) Ω − k_t (î_a s − î_b c) − k_t τ + (c1 î_d − c2 + c3 R) P R + c4 Q     (35)
//! τ  += c5 (P + Q) R                                                         (34)
//! ```
//! with `k_t = T K N² I_b/(H ω_b)`, `c1 = T L I_b K_s N²/(H ω_b²)`, `c2 = T L K2 K_s/(K ω_b²)`,
//! `c3 = T L K3 K_s/(K ω_b³)`, `c4 = T L (B/H − K1) K_s/(K ω_b)`,
//! `c5 = T H L K3 K_s/(K² N² I_b ω_b)` (the f32 observer's `EulerStep` in these bases; `K1..K3`
//! its gain factors, H and B the paper's model's).
//!
//! Formats and ranges:
//! - `î`, `Ω`, `τ`: Q31 (`i32`), saturating at ±1 pu. Their increments are formed from the
//!   Q31 states themselves: each coefficient a [`Coef`] (15-bit mantissa, any exponent,
//!   relative rounding 2⁻¹⁵) applied to an `i32` by [`mul_hi`] (a 32×16 product from two
//!   16×16 ones, to 2⁻¹⁶ of it; no 64-bit arithmetic), then one rounding shift, saturating: a
//!   sample's increment is resolved to 2⁻³¹ pu. (`K_s T/I_b` up to 0.06 and `T V_b/(L I_b)`
//!   up to 1.03 on the zoo: a voltage beyond the current's range saturates `î`, it does not
//!   wrap.)
//! - `θ̂_e`: [`Angle`], wrapping; `Δ = Ω ω_b T` from `Ω` in Q31, saturating at half a turn
//!   per sample.
//! - `σ`: Q15 within ±32 767, from `S = î − i` in Q31 shifted so that the boundary layer `ε`
//!   spans 2¹⁴..2¹⁵ LSB before its coefficient (a layer of 10⁻³ `I_b`, the EMRAX's, still
//!   resolved to 2⁻¹⁴ of `ε`).
//! - `R = 1/Ω_g`: `r·2^(e−13)` with `r` in (2¹³, 2¹⁴] (Q13: 1/m for the normalised
//!   `m = Ω_g 2^e` in [½, 1), from the linear start `48/17 − 32/17 m` within 1/17 and two
//!   Newton steps, 1.2·10⁻⁵) and `e` the leading zeros of `Ω_g` in Q31 less one. No division.
//! - `P R`, `(P + Q) R` (the exact products `p r`, within 2³⁰), `P R²`, `î_d P R` (through
//!   [`mul_hi`]): each an integer times a power of two that goes with `e`; its coefficient
//!   applies that power with its own exponent. (Taking `P R` to 16 bits first, as a first
//!   version did, left the gain terms resolved to 10⁻³ pu of speed a sample at a tenth of the
//!   rated speed, and the observer lost the Sinano's rotor there.)
//! - sin, cos: Q15 ([`Angle::sin_cos`], within 8 LSB; the f32 observer's polynomial is within
//!   10⁻⁶), of `θ̂_e` and of the EMF angle `θ̂_e + a Δ`.
//!
//! Checked against the f32 observer on the plant's samples (`tests/fixed_blocks.rs`).

use super::flux::AlphaBetaQ31;
use super::pu::PerUnit;
use super::{AlphaBetaQ15, Angle, Q15};
use crate::observer::sliding::{SlidingConfig, SlidingGain};
use crate::param::{Allowed, ParamError};
use core::f32::consts::TAU;

/// A coefficient `m·2⁻ᵏ` with a 15-bit mantissa (`m` in [2¹⁴, 2¹⁵), or 0) and any exponent:
/// applied to `|x| ≤ 2¹⁶` with an extra power of two, rounded once, saturating.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Coef {
    m: i32,
    k: i32,
}

impl Coef {
    /// The coefficient nearest `value` (≥ 0; relative rounding 2⁻¹⁵). Configuration only.
    pub fn new(field: &'static str, value: f32) -> Result<Self, ParamError> {
        Allowed::NON_NEGATIVE
            .because("a fixed-point coefficient is non-negative")
            .check(field, value)?;
        if value == 0.0 {
            return Ok(Self { m: 0, k: 0 });
        }
        let (mut v, mut k) = (value, 0i32);
        while v >= 32_768.0 {
            v *= 0.5;
            k -= 1;
        }
        while v < 16_384.0 {
            v *= 2.0;
            k += 1;
        }
        let mut m = libm::roundf(v) as i32;
        if m == 32_768 {
            m = 16_384;
            k -= 1;
        }
        Ok(Self { m, k })
    }

    /// `x·c·2^up`, rounded to the nearest integer, saturated to `i32`; `|x| ≤ 2¹⁶`.
    #[inline(always)]
    pub fn apply(self, x: i32, up: i32) -> i32 {
        shift_round(x * self.m, self.k - up)
    }

    /// `x·c·2^up` for any `x` (`i32`): `x·m` formed as `(x·m)/2¹⁶` from two 16×16 products
    /// ([`mul_hi`], within 1 of it), then rounded once and saturated.
    #[inline(always)]
    pub fn apply_wide(self, x: i32, up: i32) -> i32 {
        shift_round(mul_hi(x, self.m), self.k - up - 16)
    }

    /// The value (tests: f32).
    pub fn value(self) -> f32 {
        self.m as f32 * libm::exp2f(-(self.k as f32))
    }
}

/// `x·2^(−sh)`: rounded (ties up) for `sh > 0`, saturated for `sh < 0`.
#[inline(always)]
fn shift_round(x: i32, sh: i32) -> i32 {
    // The usual case first, in one unsigned compare: 1 ≤ sh ≤ 31.
    let r = sh.wrapping_sub(1) as u32;
    if r < 31 {
        // x >> (sh − 1) is below 2³¹ − 1 (|x| < 2³¹ − 2¹⁶: a Coef's product): no overflow.
        ((x >> r) + 1) >> 1
    } else if sh > 0 {
        // sh > 31.
        0
    } else {
        let up = (-sh) as u32;
        if up == 0 {
            x
        } else if up > 30 || x.unsigned_abs() > (i32::MAX as u32 >> up) {
            if x > 0 {
                i32::MAX
            } else if x < 0 {
                i32::MIN + 1
            } else {
                0
            }
        } else {
            x << up
        }
    }
}

/// `⌊a·b/2¹⁶⌋` for any `a` and `|b| < 2¹⁵` without a 64-bit product: `a = a_h 2¹⁶ + a_l`
/// (`a_l` in [0, 2¹⁶)), `a_h b + ⌊a_l b/2¹⁶⌋` (each product below 2³¹).
#[inline(always)]
pub fn mul_hi(a: i32, b: i32) -> i32 {
    let (hi, lo) = (a >> 16, a & 0xFFFF);
    hi * b + ((lo * b) >> 16)
}

/// Q31 to Q15, rounded (within ±2¹⁵).
#[inline(always)]
fn q15(x: i32) -> i32 {
    ((x >> 15) + 1) >> 1
}

/// `1/Ω_g` for `Ω_g` in Q31 (positive): `(r, e)` with `1/Ω_g = r·2^(e−13)`, `r` in
/// (2¹³, 2¹⁴] (module doc).
#[inline(always)]
fn reciprocal(omega_q31: u32) -> (i32, i32) {
    let lz = omega_q31.leading_zeros().max(1);
    // n in [2³⁰, 2³¹): m = n/2³¹ in [½, 1); Ω_g = m·2^−(lz−1).
    let n = omega_q31 << (lz - 1);
    let m15 = (n >> 16) as i32;
    // 1/m in Q14: 48/17 − 32/17 m, then two Newton steps y ← y (2 − m y).
    let mut y = 46_261 - ((30_840 * m15) >> 15);
    for _ in 0..2 {
        let t = (2 << 29) - m15 * y;
        y = (y * (t >> 14)) >> 15;
    }
    (y >> 1, lz as i32 - 1)
}

/// The fixed-point sliding torque observer (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SlidingObserverQ {
    ri: Coef,
    kv: Coef,
    kw: Coef,
    inc: Coef,
    inc_mid: Coef,
    kb: Coef,
    kt: Coef,
    c1: Coef,
    c2: Coef,
    c3: Coef,
    /// |c4| and its sign (c4 < 0 when K1 > B/H, as on every motor).
    c4: Coef,
    c4_negative: bool,
    c5: Coef,
    /// `Ω_low` in Q31.
    omega_low: u32,
    /// `S` (Q31) shifted right by this before `c_sigma`.
    s_sigma: u32,
    /// `2^(s−16)/ε_pu`: the shifted `S` to Q15 of `ε`.
    c_sigma: Coef,
}

/// Running state of [`SlidingObserverQ`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct SlidingStateQ {
    /// `î`, Q31 of `I_b`.
    pub i_hat: AlphaBetaQ31,
    /// `θ̂_e`.
    pub theta_e: Angle,
    /// `Ω` (electrical speed), Q31 of `ω_b`.
    pub omega: i32,
    /// `τ̂_L` of the paper's model, Q31 of `τ_b = K N I_b`.
    pub load: i32,
    /// `σ = sat(S/ε)`, Q15 within ±32 767.
    pub sigma: AlphaBetaQ15,
    /// `S = î − i`, Q31 of `I_b`, saturated.
    pub s: AlphaBetaQ31,
    /// `(sin, cos)` of `θ̂_e`, Q15.
    pub sc: (Q15, Q15),
    /// `(sin, cos)` of the coming period's EMF angle `θ̂_e + a Δ`, Q15.
    pub sc_mid: (Q15, Q15),
    /// False until the first sample.
    pub started: bool,
}

impl SlidingObserverQ {
    /// The observer `cfg` (validated as [`SlidingConfig::build`] does) in the bases `pu`;
    /// refused: a `K_s` per speed, a salient motor (the f32 observer's active-flux terms are
    /// not in fixed point; its `L` would be the mean of `L_d`, `L_q`).
    pub fn build(cfg: &SlidingConfig, pu: &PerUnit) -> Result<Self, ParamError> {
        cfg.build()?;
        Allowed::between(1.0, 1.0)
            .because("the fixed-point sliding observer is for non-salient motors (L_d = L_q)")
            .check("motor.saliency", cfg.motor.saliency)?;
        let ks = match cfg.ks {
            SlidingGain::Constant(k) => k,
            // Refused: a slope is never inside the empty range [0, 0] of slopes allowed.
            SlidingGain::PerSpeed { per_rad_s, .. } => Allowed::between(0.0, 0.0)
                .because("the fixed-point sliding observer takes a constant K_s")
                .check("ks.per_rad_s", per_rad_s + 1.0)?,
        };
        let m = cfg.motor.validate()?.papers_model();
        let t = 1.0 / cfg.rate_hz;
        let n = m.n();
        let (l, r, k, h, b) = (m.l_h, m.r_ohm, m.flux_wb, m.j_kgm2, m.b_nms);
        let (lt, lo, lta) = (
            TAU * cfg.lambda_theta_hz,
            TAU * cfg.lambda_omega_hz,
            TAU * cfg.lambda_tau_hz,
        );
        let k1 = lt + lo + lta;
        let k2 = lt * lo + lo * lta + lta * lt;
        let k3 = lt * lo * lta;
        let (ib, vb, wb) = (pu.i_base_a, pu.v_base_v, pu.omega_base_e);
        let inc_b = wb * t * (4_294_967_296.0 / TAU);
        let c4 = t * l * (b / h - k1) * ks / (k * wb);
        let eps = cfg.epsilon_a / ib;
        // ε in Q31 shifted by s: within [2¹⁴, 2¹⁵).
        let mut s_sigma = 0u32;
        while s_sigma < 31 && eps * 2_147_483_648.0 / (1u64 << (s_sigma + 1)) as f32 >= 16_384.0 {
            s_sigma += 1;
        }
        Ok(Self {
            ri: Coef::new("fixed sliding: T R/L", t * r / l)?,
            kv: Coef::new("fixed sliding: T V_b/(L I_b)", t * vb / (l * ib))?,
            kw: Coef::new("fixed sliding: K_s T/I_b", ks * t / ib)?,
            inc: Coef::new("fixed sliding: omega_b T 2^32/(2 pi)", inc_b)?,
            inc_mid: Coef::new(
                "fixed sliding: a omega_b T 2^32/(2 pi)",
                cfg.emf_advance_periods.max(0.0) * inc_b,
            )?,
            kb: Coef::new("fixed sliding: T B/H", t * b / h)?,
            kt: Coef::new(
                "fixed sliding: T K N^2 I_b/(H omega_b)",
                t * k * n * n * ib / (h * wb),
            )?,
            c1: Coef::new("fixed sliding: c1", t * l * ib * ks * n * n / (h * wb * wb))?,
            c2: Coef::new("fixed sliding: c2", t * l * k2 * ks / (k * wb * wb))?,
            c3: Coef::new("fixed sliding: c3", t * l * k3 * ks / (k * wb * wb * wb))?,
            c4: Coef::new("fixed sliding: |c4|", c4.abs())?,
            c4_negative: c4 < 0.0,
            c5: Coef::new(
                "fixed sliding: c5",
                t * h * l * k3 * ks / (k * k * n * n * ib * wb),
            )?,
            omega_low: libm::roundf(
                (n * cfg.omega_low_rad_s / wb * 2_147_483_648.0).min(2_147_483_520.0),
            )
            .max(1.0) as u32,
            s_sigma,
            c_sigma: Coef::new(
                "fixed sliding: 2^(s-16)/eps",
                (1u64 << s_sigma) as f32 / 65_536.0 / eps,
            )?,
        })
    }

    /// Restarts at a known rotor state: `î = i`, `θ̂_e`, `Ω` (Q15 of `ω_b`), `τ̂_L` (Q15 of
    /// `τ_b`).
    pub fn reset(
        &self,
        st: &mut SlidingStateQ,
        i_ab: AlphaBetaQ15,
        theta_e: Angle,
        omega: Q15,
        load: Q15,
    ) {
        let omega = i32::from(omega) << 16;
        *st = SlidingStateQ {
            i_hat: AlphaBetaQ31 {
                alpha: i32::from(i_ab.alpha) << 16,
                beta: i32::from(i_ab.beta) << 16,
            },
            theta_e,
            omega,
            load: i32::from(load) << 16,
            sc: theta_e.sin_cos(),
            sc_mid: self.emf_angle(theta_e, omega),
            started: true,
            ..SlidingStateQ::default()
        };
    }

    /// The EMF angle `θ̂_e + a Δ`, its sin and cos.
    #[inline(always)]
    fn emf_angle(&self, theta: Angle, omega: i32) -> (Q15, Q15) {
        let mid = self.inc_mid.apply_wide(omega, -31);
        theta.advanced(Angle(mid as u32)).sin_cos()
    }

    /// One sample (module doc; as the f32 `update`): `i_ab` measured now (Q15 of `I_b`),
    /// `v_ab` the voltage applied over the period that just ended (Q15 of `V_b`).
    #[inline(always)]
    pub fn update(&self, st: &mut SlidingStateQ, i_ab: AlphaBetaQ15, v_ab: AlphaBetaQ15) {
        if st.started {
            self.propagate(st, v_ab);
        } else {
            st.i_hat = AlphaBetaQ31 {
                alpha: i32::from(i_ab.alpha) << 16,
                beta: i32::from(i_ab.beta) << 16,
            };
            st.started = true;
        }
        let s = |hat: i32, i: Q15| hat.saturating_sub(i32::from(i) << 16);
        st.s = AlphaBetaQ31 {
            alpha: s(st.i_hat.alpha, i_ab.alpha),
            beta: s(st.i_hat.beta, i_ab.beta),
        };
        let sat = |s: i32| {
            let x = (s >> self.s_sigma).clamp(-65_536, 65_536);
            self.c_sigma.apply(x, 0).clamp(-32_767, 32_767) as i16
        };
        st.sigma = AlphaBetaQ15 {
            alpha: sat(st.s.alpha),
            beta: sat(st.s.beta),
        };
    }

    /// Forward-Euler step of eqs (20)-(22), (34), (35) with the stored `σ` (module doc).
    #[inline(always)]
    fn propagate(&self, st: &mut SlidingStateQ, v_ab: AlphaBetaQ15) {
        let (s, c) = (i32::from(st.sc.0), i32::from(st.sc.1));
        let (sm, cm) = (i32::from(st.sc_mid.0), i32::from(st.sc_mid.1));
        let (sa, sb) = (i32::from(st.sigma.alpha), i32::from(st.sigma.beta));
        let (ia, ib) = (st.i_hat.alpha, st.i_hat.beta);
        let w = st.omega;
        // (20), (21) in Q29: Ω s_mid + v (each within ±1 pu).
        let emf_a = (mul_hi(w, sm) >> 1) + (i32::from(v_ab.alpha) << 14);
        let emf_b = -(mul_hi(w, cm) >> 1) + (i32::from(v_ab.beta) << 14);
        let di_a = self
            .kv
            .apply_wide(emf_a, 2)
            .saturating_sub(self.ri.apply_wide(ia, 0))
            .saturating_sub(self.kw.apply(sa, 16));
        let di_b = self
            .kv
            .apply_wide(emf_b, 2)
            .saturating_sub(self.ri.apply_wide(ib, 0))
            .saturating_sub(self.kw.apply(sb, 16));
        // (22): Δ = Ω ω_b T in angle units.
        let delta = self.inc.apply_wide(w, -31);
        // The gains at the old state: P, Q (Q15), R = r 2^(e−13) signed as Ω.
        let p = (c * sa + s * sb) >> 15;
        let q = (s * sa - c * sb) >> 15;
        let (r, e) = reciprocal(w.unsigned_abs().max(self.omega_low));
        let sgn = |x: i32| if w < 0 { -x } else { x };
        // P R = pr 2^(e−28) (pr = p r, within 2³⁰, exact).
        let pr = p * r;
        // î_d, î_a s − î_b c in Q29.
        let i_d = (mul_hi(ia, c) >> 1) + (mul_hi(ib, s) >> 1);
        let d = (mul_hi(ia, s) >> 1) - (mul_hi(ib, c) >> 1);
        // î_d P R = z1 2^(e−27) (z1 = pr î_d15/2¹⁶); P R² = z3 2^(2e−25) (z3 = pr r/2¹⁶).
        let z1 = mul_hi(sgn(pr), (i_d >> 14).clamp(-32_767, 32_767));
        let z3 = mul_hi(pr, r);
        // (35): Q31 increments, each `c·x·2^up`.
        let t1 = self.c1.apply_wide(z1, 4 + e);
        let t2 = self.c2.apply_wide(sgn(pr), 3 + e);
        let t3 = self.c3.apply_wide(z3, 6 + 2 * e);
        let t4 = self.c4.apply(q, 16);
        let t4 = if self.c4_negative { -t4 } else { t4 };
        let dw = t1
            .saturating_sub(t2)
            .saturating_add(t3)
            .saturating_add(t4)
            .saturating_sub(self.kb.apply_wide(w, 0))
            .saturating_sub(self.kt.apply_wide(d, 2))
            .saturating_sub(self.kt.apply_wide(st.load, 0));
        // (34): c5 (P + Q) R = c5 pq 2^(e−28).
        let dtau = self.c5.apply_wide(sgn((p + q) * r), 3 + e);
        st.i_hat.alpha = st.i_hat.alpha.saturating_add(di_a);
        st.i_hat.beta = st.i_hat.beta.saturating_add(di_b);
        st.theta_e = st.theta_e.advanced(Angle(delta as u32));
        st.omega = st.omega.saturating_add(dw);
        st.load = st.load.saturating_add(dtau);
        st.sc = st.theta_e.sin_cos();
        st.sc_mid = self.emf_angle(st.theta_e, st.omega);
    }

    /// `Ω` in Q15 of `ω_b`, rounded.
    #[inline(always)]
    pub fn omega_q15(&self, st: &SlidingStateQ) -> Q15 {
        super::sat_q15(q15(st.omega))
    }
}
