//! The d/q current loop in fixed point: the f32 [`crate::foc::CurrentLoop`] (PIs with
//! clamping anti-windup, decoupling and back-EMF feed-forward, Ortega Sec V iv with the
//! dq model (3); the voltage vector cut radially to the circle the inverter applies) in Q15
//! per unit of the [`PerUnit`] bases, with Q(15+f) integrators.
//!
//! Per unit (`x_pu = x/x_b`), the f32 loop's equations read
//!
//! ```text
//! e = i_ref − i                                                  Q15 (|e| ≤ 2 pu: i32)
//! I ← I + (k_i T I_b/V_b) e         while the vector is inside    Q(15+f), ±2 pu
//! v_d = (k_p,d I_b/V_b) e_d + I_d − (L_q I_b/ψ_f) ω i_q           Q15 (i32 until the cut)
//! v_q = (k_p,q I_b/V_b) e_q + I_q + (L_d I_b/ψ_f) ω i_d + ω       ω ψ_f/V_b = ω (ω_b = V_b/ψ_f)
//! |v| ≤ v_max: cut along v to v_max − 4 LSB                      Q15
//! ```
//! with `ω` the electrical speed in Q15 of `ω_b`. Every coefficient is a [`Gain`] (14-bit
//! mantissa); `ω i` is formed in Q30 and taken to Q16 before its gain. The integrators are
//! Q(15+f) with the most fractional bits `f ≤ 15` that keep `k_i T I_b/V_b·2^f` a gain
//! (`f = 15`, Q30, whenever `k_i T I_b/V_b < 1/2`): one sample's increment is resolved to
//! 2⁻³⁰ pu where the f32 loop has its own 2⁻²⁴ relative. They are held within ±2 pu (the f32
//! loop's are unbounded in principle; with the output within `v_max < 1` pu an integrator
//! beyond 2 pu needs a feed-forward beyond 1 pu, a back-EMF the bus cannot drive against). The sum before the cut is an `i32` that
//! saturates; the cut shifts a vector beyond ±1 pu down to Q15 first (its direction kept)
//! and normalises it with [`unit_q15`]: no division, no square root.

use super::pu::{unit_q15, Gain, PerUnit};
use super::{sat_q15, DqQ15, Q15};
use crate::foc::FocConfig;
use crate::param::ParamError;

/// The cut vector's length is at most `v_max` less this many LSB: [`unit_q15`]'s length
/// (within 3 LSB of 1) and the rounding of each component (½ LSB) cannot put it outside.
pub const CUT_INSIDE_LSB: i32 = 4;

/// The fixed-point current loop (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CurrentLoopQ {
    kp_d: Gain,
    kp_q: Gain,
    /// `k_i T I_b/V_b · 2^f`: Q15 error to Q(15+f) increment.
    ki: Gain,
    /// Fractional bits of the integrators beyond Q15, 1..=15.
    f: u32,
    /// 2 pu in Q(15+f), less one LSB.
    int_max: i32,
    /// `L_d I_b/ψ_f / 2`, `L_q I_b/ψ_f / 2`: Q16 `ω i` to Q15 volts.
    l_d: Gain,
    l_q: Gain,
}

/// The integrators of [`CurrentLoopQ`]: Q(15+f) per unit of `V_b` (`CurrentLoopQ::f`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CurrentLoopStateQ {
    /// d-axis integral term.
    pub integral_d: i32,
    /// q-axis integral term.
    pub integral_q: i32,
}

/// Output of one [`CurrentLoopQ::update`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CurrentLoopOutputQ {
    /// Voltage command, Q15 of `V_b`, `|v_dq| ≤ v_max`.
    pub v_dq: DqQ15,
    /// The command was cut to the circle; the integrators were held (but the q one under a
    /// braking command, as the f32 loop's).
    pub saturated: bool,
    /// `v_max` was positive, so `v_dq` is the loop's command; false: zero volts.
    pub valid: bool,
}

impl CurrentLoopQ {
    /// The gains of `foc` ([`FocConfig::gains`], validated by [`FocConfig::build`]) in the
    /// bases `pu`. Refused, naming the coefficient, where one leaves its format.
    pub fn build(foc: &FocConfig, pu: &PerUnit) -> Result<Self, ParamError> {
        foc.build()?;
        let m = foc.motor;
        let g = foc.gains();
        let ts = 1.0 / foc.current_rate_hz;
        let z = pu.i_base_a / pu.v_base_v;
        let ki_pu = g.current_ki * ts * z;
        // The most fractional bits (≤ 16) that keep ki_pu·2^f a gain.
        let mut f = 15u32;
        while f > 1 && ki_pu * (1u32 << f) as f32 >= super::pu::GAIN_MAX {
            f -= 1;
        }
        let l_scale = pu.i_base_a / m.flux_wb * 0.5;
        Ok(Self {
            kp_d: Gain::new("fixed current loop: kp_d I_b/V_b", g.current_kp * z)?,
            kp_q: Gain::new("fixed current loop: kp_q I_b/V_b", g.current_kp_q * z)?,
            ki: Gain::new(
                "fixed current loop: ki T I_b/V_b 2^f",
                ki_pu * (1u32 << f) as f32,
            )?,
            f,
            int_max: ((1i64 << (16 + f)) - 1) as i32,
            l_d: Gain::new("fixed current loop: L_d I_b/psi_f", m.l_d_h() * l_scale)?,
            l_q: Gain::new("fixed current loop: L_q I_b/psi_f", m.l_q_h() * l_scale)?,
        })
    }

    /// The integrators' fractional bits beyond Q15 (their format is Q(15+f)).
    pub fn integrator_bits(&self) -> u32 {
        self.f
    }

    /// An integrator in Q15, rounded (tests, telemetry).
    #[inline(always)]
    pub fn integral_q15(&self, integral: i32) -> i32 {
        (integral >> self.f) + ((integral >> (self.f - 1)) & 1)
    }

    /// An integral of `pu` per unit in the integrators' format (tests, seeding).
    pub fn integral_of(&self, pu: f32) -> i32 {
        // Comparisons, not `f32::clamp` (which has a panic path): NaN gives 0.
        let (v, m) = (
            libm::roundf(pu * (1u64 << (15 + self.f)) as f32),
            self.int_max as f32,
        );
        (if v > m {
            m
        } else if v < -m {
            -m
        } else {
            v
        }) as i32
    }

    /// One update (module doc): `i_dq`, `i_dq_ref` in Q15 of `I_b`; `omega_e` the electrical
    /// speed in Q15 of `ω_b`; `v_max` the largest voltage magnitude, Q15 of `V_b`. Anti-windup:
    /// when the vector is cut, neither integrator moves, but the q one under a braking
    /// command where its step shortens `v_q` (the f32 loop's rule, `foc/current.rs`).
    /// `v_max ≤ 0` gives zero volts.
    #[inline(always)]
    pub fn update(
        &self,
        st: &mut CurrentLoopStateQ,
        i_dq: DqQ15,
        i_dq_ref: DqQ15,
        omega_e: Q15,
        v_max: Q15,
    ) -> CurrentLoopOutputQ {
        let e_d = i32::from(i_dq_ref.d) - i32::from(i_dq.d);
        let e_q = i32::from(i_dq_ref.q) - i32::from(i_dq.q);
        let int_d = clamp_sym(
            st.integral_d.saturating_add(self.ki.apply(e_d)),
            self.int_max,
        );
        let int_q = clamp_sym(
            st.integral_q.saturating_add(self.ki.apply(e_q)),
            self.int_max,
        );
        let w = i32::from(omega_e);
        // ω i in Q16 (ω·i ≤ 2³⁰).
        let w_i_d = (w * i32::from(i_dq.d) + (1 << 13)) >> 14;
        let w_i_q = (w * i32::from(i_dq.q) + (1 << 13)) >> 14;
        // Ortega Sec V iv, dq model (3): v_d = PI_d − ω_e L_q i_q.
        let v_d = self
            .kp_d
            .apply(e_d)
            .saturating_add(self.integral_q15(int_d))
            .saturating_sub(self.l_q.apply(w_i_q));
        // v_q = PI_q + ω_e L_d i_d + ω_e ψ_f (the last is ω in these bases).
        let v_q = self
            .kp_q
            .apply(e_q)
            .saturating_add(self.integral_q15(int_q))
            .saturating_add(self.l_d.apply(w_i_d))
            .saturating_add(w);
        let out = limit(v_d, v_q, v_max);
        // Anti-windup (`foc/current.rs`): inside the circle both integrators move; on it the
        // q one only under a braking command (`i_q*` and `ω_e` of opposite signs) where its
        // error is against `v_q`: the f32 loop's `a·b < 0` as the sign bit of `a ^ b` with
        // neither zero (no product to overflow; an `e_q` of zero does not move it); `v_q` as
        // cut, of the same sign (a `v_max ≤ 0`'s zero volts holds both).
        let opposite = |a: i32, b: i32| (a ^ b) < 0 && a != 0 && b != 0;
        if !out.saturated {
            st.integral_d = int_d;
            st.integral_q = int_q;
        } else if opposite(i32::from(i_dq_ref.q), w) && opposite(e_q, i32::from(out.v_dq.q)) {
            st.integral_q = int_q;
        }
        out
    }
}

#[inline(always)]
fn clamp_sym(x: i32, max: i32) -> i32 {
    // `max`/`min`, not `clamp` (whose bound check is a panic path).
    x.max(-max).min(max)
}

/// `(v_d, v_q)` (Q15 of `V_b`, any `i32`) limited to the circle of radius `v_max` (Q15):
/// inside it unchanged, outside cut along itself to `v_max − CUT_INSIDE_LSB`.
#[inline(always)]
pub fn limit(v_d: i32, v_q: i32, v_max: Q15) -> CurrentLoopOutputQ {
    if v_max <= 0 {
        return CurrentLoopOutputQ {
            v_dq: DqQ15::default(),
            saturated: true,
            valid: false,
        };
    }
    // A vector beyond ±1 pu (outside the circle: v_max < 1) shifted down to ±32 767, its
    // direction kept to the shift's rounding.
    let big = v_d.unsigned_abs().max(v_q.unsigned_abs());
    let (x, y) = if big > 32_767 {
        let sh = 17 - big.leading_zeros();
        (v_d >> sh, v_q >> sh)
    } else {
        (v_d, v_q)
    };
    let (x, y) = (x.clamp(-32_767, 32_767), y.clamp(-32_767, 32_767));
    let v_max = i32::from(v_max);
    if big <= 32_767 && x * x + y * y <= v_max * v_max {
        return CurrentLoopOutputQ {
            v_dq: DqQ15 {
                d: x as i16,
                q: y as i16,
            },
            saturated: false,
            valid: true,
        };
    }
    let (c, s) = unit_q15(x, y).unwrap_or((0, 0));
    let r = (v_max - CUT_INSIDE_LSB).max(0);
    CurrentLoopOutputQ {
        v_dq: DqQ15 {
            d: sat_q15((i32::from(c) * r + (1 << 14)) >> 15),
            q: sat_q15((i32::from(s) * r + (1 << 14)) >> 15),
        },
        saturated: true,
        valid: true,
    }
}
