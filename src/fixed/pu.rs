//! Per-unit bases, gains as a mantissa and a shift, and the division-free normalisation of a
//! Q15 vector: the arithmetic the fixed-point blocks share (issue #30).
//!
//! **Bases** ([`PerUnit`]), chosen once at configuration from the motor and the drive's
//! ranges (f32 allowed there), so that every signal the drive meets is below 1 per unit:
//! - current `I_b`: the drive's sensing range (`limits.i_sense_max_a` of the drive's
//!   configuration, 4.5 × the rated-torque current by default): the ADC clips there;
//! - voltage `V_b = V_bus,max/√3`: the largest phase-voltage amplitude SVPWM applies on the
//!   highest bus the drive accepts;
//! - electrical speed `ω_b = V_b/ψ_f`: the speed at which the back-EMF alone takes `V_b`;
//!   then the back-EMF feed-forward `ω_e ψ_f` in units of `V_b` is `ω_e` in units of `ω_b`,
//!   with no coefficient (a faster rotor, driven by its load, saturates at ±1: its voltage
//!   is beyond what the inverter applies anyway);
//! - flux `ψ_b = max(2 (ψ_f + L_max I_b), 4 T max(V_b, R I_b))`: twice the largest stator
//!   flux `|L i + ψ_f c(θ)|` at the sensing limit (headroom for an estimate in transient),
//!   and at least four times what one sample of the largest voltage adds (so that one
//!   sample's flux increment is at most a quarter of the range and its coefficient a
//!   [`Gain`] into Q31).
//!
//! **Gains** ([`Gain`]): a non-negative coefficient `c = m·2⁻ˢ` with a 14-bit mantissa
//! `m < 2¹⁴` (relative rounding at most 2⁻¹⁴ = 6.1·10⁻⁵ for `c ≥ 2⁻¹⁷`), applied to an
//! integer `|x| ≤ 2¹⁶ + 1` (a Q15 value, or a sum or difference of two) as
//! `(x·m + 2ˢ⁻¹) >> s`: the product stays below 2³⁰, so the rounding cannot overflow. One
//! multiply and one shift on the Cortex-M0+; no division anywhere in the step.

use crate::fixed::{sat_q15, Q15};
use crate::motor::MotorParams;
use crate::param::{Allowed, Checks, ParamError};

/// The largest gain a [`Gain`] holds (exclusive): `m < 2¹⁴` with `s = 0`.
pub const GAIN_MAX: f32 = 16_384.0;

/// A coefficient `m·2⁻ˢ` applied to `|x| ≤ 2¹⁶ + 1` (module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Gain {
    m: i32,
    s: u32,
    round: i32,
}

impl Gain {
    /// The gain nearest `value` (in `[0, 2¹⁴)`): the largest shift `s ≤ 30` with
    /// `round(value·2ˢ) < 2¹⁴`. Configuration only (f32). A value outside is refused naming
    /// `field`.
    pub fn new(field: &'static str, value: f32) -> Result<Self, ParamError> {
        Allowed::from_below(0.0, GAIN_MAX)
            .because("a fixed-point gain in [0, 2^14): the per-unit bases leave it too large")
            .check(field, value)?;
        let mut s = 30u32;
        while s > 0 && libm::roundf(value * (1u32 << s) as f32) >= GAIN_MAX {
            s -= 1;
        }
        let m = libm::roundf(value * (1u32 << s) as f32) as i32;
        // At s = 0 the check above left value < 2^14, and round(value) may reach 2^14 only
        // for value in [16 383.5, 16 384): refused likewise.
        Allowed::from_below(0.0, GAIN_MAX)
            .because("a fixed-point gain in [0, 2^14)")
            .check(field, m as f32)?;
        Ok(Self {
            m,
            s,
            round: if s == 0 { 0 } else { 1 << (s - 1) },
        })
    }

    /// `x·c`, rounded to the nearest integer (ties up); `|x| ≤ 2¹⁶ + 1`.
    #[inline(always)]
    pub fn apply(self, x: i32) -> i32 {
        (x * self.m + self.round) >> self.s
    }

    /// The coefficient this gain applies (tests and reports: f32).
    pub fn value(self) -> f32 {
        self.m as f32 / (1u64 << self.s) as f32
    }
}

/// The per-unit bases of one motor on one drive (module doc). Configuration and tests only.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PerUnit {
    /// `I_b` \[A].
    pub i_base_a: f32,
    /// `V_b` \[V].
    pub v_base_v: f32,
    /// `ω_b = V_b/ψ_f` [rad/s, electrical].
    pub omega_base_e: f32,
    /// `ψ_b` \[Wb].
    pub flux_base_wb: f32,
    /// The control period `T` \[s] the flux base was chosen for.
    pub ts_s: f32,
}

impl PerUnit {
    /// The bases for `motor` with the sensing range `i_base_a` \[A], the largest phase
    /// voltage `v_base_v` \[V] and the control rate `rate_hz` \[Hz] (module doc).
    pub fn new(
        motor: &MotorParams,
        i_base_a: f32,
        v_base_v: f32,
        rate_hz: f32,
    ) -> Result<Self, ParamError> {
        let m = motor.validate()?;
        let mut c = Checks::new();
        c.check("i_base_a", i_base_a, Allowed::POSITIVE);
        c.check("v_base_v", v_base_v, Allowed::POSITIVE);
        c.check("rate_hz", rate_hz, Allowed::POSITIVE);
        c.done()?;
        let ts = 1.0 / rate_hz;
        let l_max = m.l_d_h().max(m.l_q_h());
        let flux =
            (2.0 * (m.flux_wb + l_max * i_base_a)).max(4.0 * ts * v_base_v.max(m.r_ohm * i_base_a));
        Ok(Self {
            i_base_a,
            v_base_v,
            omega_base_e: v_base_v / m.flux_wb,
            flux_base_wb: flux,
            ts_s: ts,
        })
    }

    /// The bases of a drive's configuration: `I_b` its sensing range, `V_b` its highest bus
    /// over √3, at its control rate.
    pub fn of_drive(cfg: &crate::drive::DriveConfig) -> Result<Self, ParamError> {
        Self::new(
            &cfg.motor,
            cfg.limits.i_sense_max_a,
            cfg.limits.bus_max_v * crate::math::INV_SQRT3,
            cfg.rate_hz,
        )
    }

    /// `a` \[A] in Q15 of `I_b`, rounded, saturated (configuration, tests).
    pub fn current(&self, a: f32) -> Q15 {
        to_q15(a / self.i_base_a)
    }

    /// `v` \[V] in Q15 of `V_b`, rounded, saturated.
    pub fn voltage(&self, v: f32) -> Q15 {
        to_q15(v / self.v_base_v)
    }

    /// `omega_e` [rad/s, electrical] in Q15 of `ω_b`, rounded, saturated.
    pub fn speed(&self, omega_e: f32) -> Q15 {
        to_q15(omega_e / self.omega_base_e)
    }
}

/// A per-unit value in Q15, rounded, saturated (configuration, tests).
pub fn to_q15(pu: f32) -> Q15 {
    libm::roundf((pu * 32_768.0).clamp(-32_768.0, 32_767.0)) as Q15
}

/// 1/√n′ for `n′ = n/2³⁰` at the middle of each of the 24 eighths of `[1, 4)` (`n >> 27` in
/// 8..32), in Q15: the starting value of [`unit_q15`]'s Newton steps, within 3.1 % of
/// 1/√n′ over its eighth. Checked by `tests/fixed_control.rs`.
const RSQRT_START_Q15: [u16; 24] = [
    31831, 30101, 28627, 27350, 26230, 25238, 24350, 23550, 22825, 22162, 21554, 20993, 20475,
    19992, 19543, 19122, 18727, 18356, 18007, 17676, 17363, 17066, 16784, 16515,
];

/// The unit vector along `(x, y)` in Q15, without division: `|x|, |y| ≤ 32 767`, `None` for
/// the zero vector. `|(x, y)|²` is shifted by an even `k` into `[2³⁰, 2³²)`, 1/√ of it
/// starts from `RSQRT_START_Q15` (within 3.1 %) and takes two Newton steps
/// `u ← u (3 − n′u²)/2` (relative error 1.5·e² each: 1.4·10⁻³, then 2.9·10⁻⁶, below the
/// Q15 rounding of `u`), then `(x, y)·u` is shifted back by `15 − k/2`. The direction is
/// that of `(x, y)` to the rounding of each component (½ LSB) and the length 1 within a few
/// LSB (`tests/fixed_control.rs`).
#[inline(always)]
pub fn unit_q15(x: i32, y: i32) -> Option<(Q15, Q15)> {
    // ≤ 2·32 767² < 2³¹.
    let mag2 = (x * x + y * y) as u32;
    if mag2 == 0 {
        return None;
    }
    // Even, 0..=30 (mag2 < 2³¹ has a leading zero).
    let k = mag2.leading_zeros() & !1;
    let n = mag2 << k;
    let start = RSQRT_START_Q15.get(((n >> 27) as usize).wrapping_sub(8));
    let mut u = u32::from(start.copied().unwrap_or(16_384));
    // n′ in Q14, in [2¹⁴, 2¹⁶).
    let n14 = n >> 16;
    for _ in 0..2 {
        // n′u² in Q29 (< 2³¹: u ≤ 31 831 and n′u² ≤ 1.07 from the start on).
        let p = n14 * ((u * u) >> 15);
        // (3 − n′u²) in Q15, then u (3 − n′u²)/2 in Q15 (≤ 3·2³⁰ < 2³²).
        let t = ((3u32 << 29).saturating_sub(p)) >> 14;
        u = (u * t) >> 16;
    }
    let shift = 15 - k / 2;
    let round = (1i32 << shift) >> 1;
    let u = u as i32;
    Some((
        sat_q15((x * u + round) >> shift),
        sat_q15((y * u + round) >> shift),
    ))
}
