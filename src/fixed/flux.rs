//! Ortega et al.'s gradient flux observer, eq (9), in fixed point: the f32
//! [`crate::observer::flux::FluxObserver::integrate`] (same discretisation: the flux
//! integral of `y12 = v − R i` exact for a held voltage and a linear current, the gradient
//! term a forward-Euler step at sample `k−1`) in the [`PerUnit`] bases, and the rotor-flux
//! angle as a unit vector by the division-free normalisation [`unit_q15`] (no arctangent:
//! the FOC's Park transform takes sin and cos, which are `η̂/|η̂|`, Ortega Sec V iii).
//! Non-salient motors only (`L_d = L_q`); a salient motor is refused.
//!
//! Per unit of `ψ_b` (flux), `V_b`, `I_b`, one sample:
//!
//! ```text
//! g   = (γT ψ_b²/2)(Φ² − |η̂|²)                        eq (9)'s gradient factor, Q15, ≥ −1
//! x̂  += (T V_b/ψ_b) v − (T R I_b/(2ψ_b)) (i_{k−1} + i_k) + g η̂_{k−1}     eqs (7), (9), Q31
//! η̂  = x̂ − (L I_b/ψ_b) i_k                            eq (4): the rotor flux, Q15
//! (cos θ̂_e, sin θ̂_e) = η̂/|η̂|                          Sec V iii, Q15
//! ```
//!
//! Formats and ranges:
//! - `x̂`: Q31 of `ψ_b` (an `i32`, saturating at ±1 pu, twice the largest flux the motor
//!   has at the sensing limit). A sample's increment is at most a quarter of the range (the
//!   flux base's rule) and is resolved to 2⁻³¹ pu: at the lowest speeds `T v` is a few 10⁻⁵
//!   pu, which Q15 could not integrate.
//! - `η̂`: Q15 of `ψ_b`, within ±32 767 (so `|η̂|²` < 2³¹ in Q30); `|η̂| = Φ/ψ_b` locked, at
//!   least 1/4 on every motor whose `L I_b ≤ Φ` (then the angle's LSB is 1/8 192 rad or less).
//! - `Φ²` and `|η̂|²`: Q30; their difference to Q15 before its gain (½ LSB: a dead band of
//!   `2⁻¹⁶/Φ_pu²` relative on the radius, along `η̂`: no angle error).
//! - `g`: Q15, saturated to `[−1, 1)`. `γΦ²T ≤ 1` (the f32 observer's own bound for a
//!   default γ; the build refuses `γΦ²T ≥ 2`) keeps `g ≤ ½`; `g < −1` would take `η̂` through
//!   zero in one step, where `|η̂|² > Φ² + 2/(γT)`, a state the f32 observer reaches only
//!   already diverging.
//! - Coefficients: [`Gain`]s, each within its 14-bit mantissa; the flux base makes the voltage
//!   and resistance ones at most ¼ and ⅛ (into Q31), `L I_b/ψ_b ≤ ½`.

use super::pu::{unit_q15, Gain, PerUnit};
use super::{sat_q15, AlphaBetaQ15, Angle, Q15};
use crate::observer::flux::FluxConfig;
use crate::param::{Allowed, ParamError};

/// The fixed-point flux observer (module doc).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FluxObserverQ {
    /// `T V_b/ψ_b · 2¹⁶`: Q15 volts to a Q31 flux increment.
    k_v: Gain,
    /// `T R I_b/(2ψ_b) · 2¹⁶`: a Q15 sum of two currents to a Q31 flux increment.
    k_r: Gain,
    /// `L I_b/ψ_b`: Q15 current to Q15 flux.
    k_l: Gain,
    /// `γ T ψ_b²/2`: the Q15 gradient error to the Q15 factor `g`.
    g0: Gain,
    /// `(Φ/ψ_b)²` in Q30.
    phi2: i32,
    /// `Φ/ψ_b` in Q15.
    phi: i32,
    /// `(ψ_b/Φ)²`: the Q15 `|η̂|²` to the Q15 ratio `|η̂|²/Φ²`.
    inv_phi2: Gain,
}

/// A stator-frame vector in Q31 (the flux estimate).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct AlphaBetaQ31 {
    /// α.
    pub alpha: i32,
    /// β.
    pub beta: i32,
}

/// Running state of [`FluxObserverQ`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FluxStateQ {
    /// `x̂`, Q31 of `ψ_b`.
    pub x_hat: AlphaBetaQ31,
    /// The current at the last sample, Q15 of `I_b`.
    pub i_last: AlphaBetaQ15,
    /// `η̂ = x̂ − L i` at the last sample, Q15 of `ψ_b`, components within ±32 767.
    pub rotor_flux: AlphaBetaQ15,
    /// False until the first sample.
    pub started: bool,
}

impl FluxStateQ {
    /// `(sin θ̂_e, cos θ̂_e)` in Q15: the rotor flux `η̂` normalised ([`unit_q15`]); `None`
    /// while `η̂ = 0` (before the first sample).
    #[inline(always)]
    pub fn sin_cos(&self) -> Option<(Q15, Q15)> {
        let eta = self.rotor_flux;
        unit_q15(i32::from(eta.alpha), i32::from(eta.beta)).map(|(c, s)| (s, c))
    }
}

impl FluxObserverQ {
    /// The observer `cfg` (validated as [`FluxConfig::build`] does) in the bases `pu`.
    /// Refused: a salient motor; a coefficient outside its format (named).
    pub fn build(cfg: &FluxConfig, pu: &PerUnit) -> Result<Self, ParamError> {
        cfg.build()?;
        let m = cfg.motor;
        Allowed::between(1.0, 1.0)
            .because("the fixed-point flux observer is for non-salient motors (L_d = L_q)")
            .check("motor.saliency", m.saliency)?;
        let ts = 1.0 / cfg.rate_hz;
        let psi_b = pu.flux_base_wb;
        let phi_pu = m.flux_wb / psi_b;
        let q16 = 65_536.0;
        Ok(Self {
            k_v: Gain::new(
                "fixed flux: T V_b/psi_b 2^16",
                ts * pu.v_base_v / psi_b * q16,
            )?,
            k_r: Gain::new(
                "fixed flux: T R I_b/(2 psi_b) 2^16",
                ts * m.r_ohm * pu.i_base_a / (2.0 * psi_b) * q16,
            )?,
            k_l: Gain::new("fixed flux: L I_b/psi_b", m.l_q_h() * pu.i_base_a / psi_b)?,
            g0: Gain::new(
                "fixed flux: gamma T psi_b^2/2",
                0.5 * cfg.gamma * ts * psi_b * psi_b,
            )?,
            phi2: libm::roundf(phi_pu * phi_pu * 1_073_741_824.0) as i32,
            phi: libm::roundf(phi_pu * 32_768.0) as i32,
            inv_phi2: Gain::new("fixed flux: (psi_b/Phi)^2", 1.0 / (phi_pu * phi_pu))?,
        })
    }

    /// One sample (module doc): `i_ab` measured now (Q15 of `I_b`), `v_ab` the voltage applied
    /// over the period that just ended (Q15 of `V_b`). `x̂` and `η̂`; the angle is
    /// [`FluxStateQ::sin_cos`].
    #[inline(always)]
    pub fn integrate(&self, st: &mut FluxStateQ, i_ab: AlphaBetaQ15, v_ab: AlphaBetaQ15) {
        let mut x = st.x_hat;
        if st.started {
            // Gradient term of eq (9) at sample k−1: g = (γT/2)(Φ² − |η̂|²).
            let (ea, eb) = (
                i32::from(st.rotor_flux.alpha),
                i32::from(st.rotor_flux.beta),
            );
            let mag2 = ea * ea + eb * eb;
            let diff = self.phi2 - mag2;
            let e15 = ((diff >> 14) + 1) >> 1;
            let g = self.g0.apply(e15).clamp(-32_768, 32_767);
            // ∫ y12 dt over the period, eq (7): T v − T R (i_{k−1} + i_k)/2.
            let (ia, ib) = (i32::from(i_ab.alpha), i32::from(i_ab.beta));
            let (la, lb) = (i32::from(st.i_last.alpha), i32::from(st.i_last.beta));
            let da = self
                .k_v
                .apply(i32::from(v_ab.alpha))
                .saturating_sub(self.k_r.apply(la + ia))
                .saturating_add((g * ea) << 1);
            let db = self
                .k_v
                .apply(i32::from(v_ab.beta))
                .saturating_sub(self.k_r.apply(lb + ib))
                .saturating_add((g * eb) << 1);
            x.alpha = x.alpha.saturating_add(da);
            x.beta = x.beta.saturating_add(db);
        }
        st.x_hat = x;
        st.rotor_flux = self.rotor_flux(x, i_ab);
        st.i_last = i_ab;
        st.started = true;
    }

    /// `η̂ = x̂ − L i` (eq (4)) in Q15, within ±32 767.
    #[inline(always)]
    fn rotor_flux(&self, x: AlphaBetaQ31, i_ab: AlphaBetaQ15) -> AlphaBetaQ15 {
        let q15 = |x: i32| ((x >> 15) + 1) >> 1;
        let sym = |v: i32| sat_q15(v).max(-32_767);
        AlphaBetaQ15 {
            alpha: sym(q15(x.alpha) - self.k_l.apply(i32::from(i_ab.alpha))),
            beta: sym(q15(x.beta) - self.k_l.apply(i32::from(i_ab.beta))),
        }
    }

    /// `|η̂|²/Φ²` in Q15 (the f32 observer's `magnitude_residual` is `|this − 1|`): 1.0 =
    /// 32 768 on the circle eq (9) pulls `η̂` to.
    #[inline(always)]
    pub fn magnitude_ratio_q15(&self, st: &FluxStateQ) -> i32 {
        let (ea, eb) = (
            i32::from(st.rotor_flux.alpha),
            i32::from(st.rotor_flux.beta),
        );
        let mag2_q15 = ((ea * ea + eb * eb) >> 14).saturating_add(1) >> 1;
        self.inv_phi2.apply(mag2_q15.min(65_537))
    }

    /// Sets the estimate to a known `x̂` (Q31 of `ψ_b`; an f32 observer's, at a take-over):
    /// `η̂ = x̂ − L i` (eq (4)) with `i_ab` this sample.
    pub fn reset_x_hat(&self, st: &mut FluxStateQ, i_ab: AlphaBetaQ15, x_hat: AlphaBetaQ31) {
        *st = FluxStateQ {
            x_hat,
            i_last: i_ab,
            rotor_flux: self.rotor_flux(x_hat, i_ab),
            started: true,
        };
    }

    /// Sets the estimate to a known rotor angle: `x̂ = L i + Φ c(θ_e)` (eq (4)).
    pub fn reset(&self, st: &mut FluxStateQ, i_ab: AlphaBetaQ15, theta_e: Angle) {
        let (s, c) = theta_e.sin_cos();
        let eta = AlphaBetaQ15 {
            alpha: sat_q15((self.phi * i32::from(c) + (1 << 14)) >> 15),
            beta: sat_q15((self.phi * i32::from(s) + (1 << 14)) >> 15),
        };
        let l_i = |i: Q15| self.k_l.apply(i32::from(i));
        let x = |e: Q15, i: Q15| (i32::from(e) + l_i(i)).clamp(-32_768, 32_767) << 16;
        *st = FluxStateQ {
            x_hat: AlphaBetaQ31 {
                alpha: x(eta.alpha, i_ab.alpha),
                beta: x(eta.beta, i_ab.beta),
            },
            i_last: i_ab,
            rotor_flux: eta,
            started: true,
        };
    }
}
