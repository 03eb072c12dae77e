//! The angle-tracking PLL of Ortega et al. Sec V iii in fixed point: the f32
//! [`crate::observer::pll::Pll`] (same loop, same forward-Euler discretisation, same order of
//! operations) on a wrapping binary angle, as quartiq/idsp's `pll.rs` keeps its phase:
//!
//! ```text
//! e   = θ − z1                        wrapping i32 difference: exactly the error on the circle
//! I  += (Ki T²) e                     the integral term, a phase increment per sample
//! Δ   = (Kp T) e + I                  ω̂ T: the tracked angle's increment per sample
//! z1 += Δ                             wrapping u32: no wrap_pi, no branch
//! ```
//!
//! with `Kp = 2ζω_n`, `Ki = ω_n²` ([`PllConfig::gains`]) and `T` the PLL's own period (its
//! `rate_hz`: the drive runs it in the 1 kHz task). The f32 PLL's integral `Ki·z2` [rad/s] is
//! `I·2π/(2³² T)` here, its ω̂ is `Δ·2π/(2³² T)`.
//!
//! Formats and ranges:
//! - `θ`, `z1`: [`Angle`], one turn = 2³² (`u32`, wrapping).
//! - `e`: `i32`, one turn = 2³², in [−π, π) (the wrapping difference of two angles). Before its
//!   gains it is rounded to `x = e/2¹⁵` (one LSB 2⁻¹⁷ turn = 4.8·10⁻⁵ rad = 0.0027°, `|x| ≤
//!   2¹⁶`, what a [`Gain`] takes).
//! - `Kp T`: in (0, 1) (the build's `Kp T < 1`), a [`Gain`] `Kp T·2¹³` on `x`, its result ×4
//!   (`Kp T·2¹⁵ x`, within ±2³¹: clamped to ±(2²⁹ − 1) before the ×4 for the mantissa's
//!   rounding).
//! - `Ki T²`: in (0, ¼) (`ω_n T < ½`), a [`Gain`] `Ki T²·2¹⁵` on `x`. Below one LSB of the
//!   increment (`|Ki T² e| < ½·2⁻³² turn`) the integral does not move: a dead band of
//!   `1/(2¹⁵ Ki T²)` LSB of `x`, at most 0.003° on the drive's PLL (1 kHz, 50 Hz).
//! - `I`, `Δ`: `i32`, one turn per sample = 2³², saturating at ±2³¹ (half a turn per sample:
//!   beyond it the sampled angle aliases anyway). Resolution 2π/(2³² T) rad/s, 1.5·10⁻⁶ rad/s
//!   at 1 kHz.
//! - Speed out ([`PllQ::omega_q15`]): Q15 of the electrical base speed `ω_b` ([`PerUnit`]),
//!   saturated at ±1 pu: `Δ` shifted right by `s` (the least shift that puts `ω_b` within
//!   2¹⁶), then a coefficient in [½, 1) with a 16-bit mantissa: within 1.5 LSB.
//!
//! No division, no wrap, no branch on the update; the gains are computed at build time.

use super::pu::{Gain, PerUnit};
use super::{sat_q15, Angle, Q15};
use crate::observer::pll::PllConfig;
use crate::param::{Allowed, ParamError};
use core::f32::consts::TAU;

/// One turn in angle units, 2³² (configuration: f32).
const TURN: f32 = 4_294_967_296.0;

/// The fixed-point PLL (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PllQ {
    /// `Kp T·2¹³`: the rounded error `x` to a quarter of the proportional increment.
    kp: Gain,
    /// `Ki T²·2¹⁵`: the rounded error `x` to the integral's increment.
    ki: Gain,
    /// The shift `s` of the speed read-out: the least `s ≤ 15` with `Δ_b ≤ 2^(16+s)` (`Δ_b`
    /// the base speed's increment per sample, `ω_b T 2³²/(2π)`).
    s_out: u32,
    /// `c = 2^(15+s)/Δ_b`, in [½, 1) (below ½ where `s` is capped), as `c·2¹⁶ < 2¹⁶`:
    /// `Δ >> s` to Q15 of `ω_b`.
    m_out: u32,
    /// `Δ_b/2^(15+s)·2¹⁵`, in (2¹⁵, 2¹⁶] (beyond where `s` is capped): a Q15 speed `ω` to
    /// `Δ = ω·Δ_b/2¹⁵ = ω·m_in >> (15 − s)`.
    m_in: u32,
    /// The largest |Q15 speed| whose `Δ` is below 2³¹ (half a turn per sample).
    w_in_max: u32,
    /// `T` \[s] (tests and telemetry only).
    ts: f32,
}

/// Running state of [`PllQ`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PllStateQ {
    /// The tracked angle `z1`.
    pub z1: Angle,
    /// The integral term `I` (`Ki·z2·T` of the f32 PLL), angle units per sample.
    pub integral: i32,
    /// The speed estimate `Δ = ω̂ T`, angle units (2³² a turn) per sample.
    pub delta: i32,
    /// The phase error `θ − z1` of the last update, angle units, in [−π, π).
    pub error: i32,
}

impl PllStateQ {
    /// |error| over 90° in Q15 of 1 (the f32 `FluxPll` residual's PLL part,
    /// `|error|/(π/2)`), saturated at 2.0 (a full ±π error).
    #[inline(always)]
    pub fn error_over_quarter_q15(&self) -> i32 {
        // A quarter turn is 2³⁰; |e| ≤ 2³¹, so |e| >> 15 ≤ 2¹⁶ (= 2.0 in Q15).
        (self.error.unsigned_abs() >> 15) as i32
    }
}

impl PllQ {
    /// The PLL `cfg` (validated as [`PllConfig::build`] does) with its speed read out in the
    /// bases `pu` (their electrical base speed `ω_b`). Refused, naming it, where a coefficient
    /// leaves its format (a base speed below 2⁻¹⁶ turn per sample).
    pub fn build(cfg: &PllConfig, pu: &PerUnit) -> Result<Self, ParamError> {
        cfg.build()?;
        let ts = 1.0 / cfg.rate_hz;
        let (kp, ki) = cfg.gains();
        // ω_b in angle units per sample, Δ_b.
        let inc_b = pu.omega_base_e * ts * (TURN / TAU);
        let mut s_out = 0u32;
        while s_out < 15 && inc_b > (1u64 << (16 + s_out)) as f32 {
            s_out += 1;
        }
        let unit = (1u64 << (15 + s_out)) as f32;
        let m_out = libm::roundf(unit / inc_b * 65_536.0);
        Allowed::from_below(0.0, 65_536.0)
            .because("a base speed of at least 2^15 angle units (2^-17 turn) per sample")
            .check("fixed pll: 2^(15+s)/(omega_b T 2^32/(2 pi)) 2^16", m_out)?;
        let m_in = libm::roundf(inc_b / unit * 32_768.0).max(1.0);
        Ok(Self {
            kp: Gain::new("fixed pll: Kp T 2^13", kp * ts * 8_192.0)?,
            ki: Gain::new("fixed pll: Ki T^2 2^15", ki * ts * ts * 32_768.0)?,
            s_out,
            m_out: m_out as u32,
            m_in: m_in as u32,
            w_in_max: ((2_147_483_647.0 / m_in) as u32).min(32_768),
            ts,
        })
    }

    /// One sample of the input angle `theta`; returns the speed estimate `Δ` (angle units per
    /// sample; [`PllQ::omega_q15`] in per unit).
    #[inline(always)]
    pub fn update(&self, st: &mut PllStateQ, theta: Angle) -> i32 {
        // The error on the circle: the wrapping difference (Ortega Sec V iii, θ̂ − z1).
        let e = theta.0.wrapping_sub(st.z1.0) as i32;
        // Rounded to 2⁻¹⁷ turn: x in [−2¹⁶, 2¹⁶] (e >> 14 is within ±2¹⁷: no overflow).
        let x = ((e >> 14) + 1) >> 1;
        st.error = e;
        st.integral = st.integral.saturating_add(self.ki.apply(x));
        // Kp T e: the gain's result is below 2²⁹ but for its mantissa's rounding.
        let p = self.kp.apply(x).clamp(-(1 << 29), (1 << 29) - 1) << 2;
        st.delta = p.saturating_add(st.integral);
        st.z1 = st.z1.advanced(Angle(st.delta as u32));
        st.delta
    }

    /// The speed estimate in Q15 of `ω_b`, saturated at ±1 pu: `Δ` rounded to `x = Δ/2ˢ`
    /// (held within ±2¹⁶, beyond 1 pu), times `c < 1` with a 16-bit mantissa in `u32`
    /// (`|x|·m < 2³²`). Within 1.5 LSB: `x`'s rounding (½ LSB of `x`, times `c`), the
    /// mantissa's (2⁻¹⁷ on `c`, times `|x| ≤ 2¹⁶`), the result's (½).
    #[inline(always)]
    pub fn omega_q15(&self, st: &PllStateQ) -> Q15 {
        let half = (1i32 << self.s_out) >> 1;
        let x = (st.delta.saturating_add(half) >> self.s_out).clamp(-65_536, 65_536);
        let mag = ((x.unsigned_abs() * self.m_out + (1 << 15)) >> 16) as i32;
        sat_q15(if x < 0 { -mag } else { mag })
    }

    /// Starts tracking at `theta` with the speed `omega_e` (Q15 of `ω_b`; a speed beyond half
    /// a turn per sample starts at that, as `Δ` saturates there). `Δ = ω·Δ_b/2¹⁵` with a
    /// 16-bit mantissa: within ½ LSB of Q15 beside the exact value.
    pub fn reset(&self, st: &mut PllStateQ, theta: Angle, omega_e: Q15) {
        let w = i32::from(omega_e);
        // |w|·m_in ≤ 2³¹ − 1 (w_in_max), so the rounding cannot overflow a u32.
        let prod = w.unsigned_abs().min(self.w_in_max) * self.m_in;
        let sh = 15 - self.s_out;
        let mag = ((prod + ((1u32 << sh) >> 1)) >> sh) as i32;
        let delta = if w < 0 { -mag } else { mag };
        *st = PllStateQ {
            z1: theta,
            integral: delta,
            delta,
            error: 0,
        };
    }

    /// `Δ` in rad/s (tests and telemetry only: f32).
    pub fn omega_rad_s(&self, delta: i32) -> f32 {
        delta as f32 * (TAU / TURN) / self.ts
    }
}
