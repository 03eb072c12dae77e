//! Space-vector PWM by min–max (zero-sequence) injection in fixed point: the f32
//! [`crate::svpwm::svpwm`] and [`crate::svpwm`]'s limited form (the FOC's) on a voltage in
//! Q15 of the bus.
//!
//! The αβ command is taken to phase voltages (inverse Clarke), the common mode
//! `v0 = −(max + min)/2` is added so the three poles are centred in the bus, and each pole's
//! duty is `½ + (v_k + v0)/V_bus`. Linear up to `|v_αβ| = V_bus/√3` (the circle inscribed in
//! the inverter's hexagon); [`svpwm_q15`] cuts a longer command radially onto that circle (as
//! the f32 `svpwm`), [`svpwm_limited_q15`] applies any vector inside the hexagon as it is and
//! cuts only beyond it (as the f32 `svpwm_limited`). Both clamp each duty to [0, 1], as the
//! f32 block does for a vector on the circle at the hexagon's corners.
//!
//! Formats and ranges:
//! - In: `v_αβ` in Q15 **of the bus** (`v/V_bus`; the drive's voltages are in Q15 of
//!   `V_b = V_bus,max/√3`: the caller scales them by `V_b/V_bus` once a step). Any value; the
//!   circle is `|v| = 1/√3` = 18 918.6 LSB, the hexagon's corners `2/3` = 21 845.3 LSB.
//! - Inside: `α`, `β` in Q17 of the bus (the command shifted, or the cut vector); the phase
//!   voltages twice in Q17 (`i32`, `|v_k| < 2²⁰`, no overflow for any input), `b` with √3 in
//!   Q13 (relative 2.7·10⁻⁶) and one rounding (1/16 LSB of Q15): each phase within 0.11 LSB.
//! - Out: each duty in Q15 unsigned (`u16`, 0 = low side on, 32 768 = high side on the whole
//!   period, 16 384 = ½), `v_k − (max + min)/2` rounded once to Q15: within 0.75 LSB of the
//!   f32 duties where no cut is made (two phases' 0.11 each, the rounding's ½).
//! - The cut: the unit vector ([`unit_q15`]: its direction within 2.4·10⁻⁵ rad, its length
//!   within 3 LSB of 1), the radius `1/√3` in Q17 corrected for that length (one Newton step),
//!   the components in Q17: the cut vector within `δ` = 1.46 LSB (Q15) of the f32 one (the
//!   direction's 0.46 LSB at the circle, the radius's ⅛ + 0.11, the components' ⅛ each, 0.58
//!   for an input component at −32 768 taken as −32 767), and the duties within
//!   `1.5 δ + 0.75` = 2.9 LSB (a duty `v_k + v0` moves by at most 1.5 times the vector:
//!   `v_a − (v_b + v_c)/2 = 1.5 v_a`).
//!
//! No division; the saturation test compares squares (`u32`, Q30).

use super::pu::unit_q15;
use super::{sat_q15, AlphaBetaQ15, Q15};

/// 1/√3 in Q15, rounded down (18 918.6): the radius of the linear range.
const CIRCLE_Q15: i32 = 18_918;

/// 1/√3 in Q17, rounded down (75 674.4): the cut's radius.
const CIRCLE_Q17: i32 = 75_674;

/// (1/√3)² = 1/3 in Q30, rounded down: `|v|² ≤ this` is the linear range.
const CIRCLE2_Q30: u32 = 357_913_941;

/// √3 in Q13, rounded: 1.732 05 × 8 192 = 14 188.96.
const SQRT3_Q13: i32 = 14_189;

/// A duty of 1 in Q15 (the high side on for the whole period).
pub const DUTY_ONE: u16 = 32_768;

/// Duty cycles of the three half bridges, Q15 unsigned ([`DUTY_ONE`] = 1).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct DutiesQ15 {
    /// Phase a, in `[0, DUTY_ONE]`.
    pub a: u16,
    /// Phase b.
    pub b: u16,
    /// Phase c.
    pub c: u16,
}

impl DutiesQ15 {
    /// All three at ½: zero phase-to-neutral voltage.
    pub const NEUTRAL: Self = Self {
        a: DUTY_ONE / 2,
        b: DUTY_ONE / 2,
        c: DUTY_ONE / 2,
    };
}

/// Result of [`svpwm_q15`] and [`svpwm_limited_q15`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SvpwmQ15 {
    /// The duties, each in `[0, DUTY_ONE]`.
    pub duties: DutiesQ15,
    /// The command was outside the range applied as it is and was cut to the circle.
    pub saturated: bool,
    /// The αβ voltage the duties apply (Q15 of the bus): the command, or the cut vector.
    pub v_ab_applied: AlphaBetaQ15,
}

/// Duties for `v_ab` (Q15 of the bus), as the f32 [`crate::svpwm::svpwm`]: a command beyond the
/// circle `1/√3` is cut radially onto it (`saturated`); the duties by min–max injection,
/// clamped to `[0, DUTY_ONE]`.
#[inline(always)]
pub fn svpwm_q15(v_ab: AlphaBetaQ15) -> SvpwmQ15 {
    let (x, y) = (i32::from(v_ab.alpha), i32::from(v_ab.beta));
    // ≤ 2·2³⁰ = 2³¹: fits a u32.
    let mag2 = (x * x) as u32 + (y * y) as u32;
    if mag2 <= CIRCLE2_Q30 {
        return SvpwmQ15 {
            duties: injection(x << 2, y << 2).0,
            saturated: false,
            v_ab_applied: v_ab,
        };
    }
    let (x17, y17) = cut(x, y);
    let q15 = |v: i32| sat_q15((v + 2) >> 2);
    SvpwmQ15 {
        duties: injection(x17, y17).0,
        saturated: true,
        v_ab_applied: AlphaBetaQ15 {
            alpha: q15(x17),
            beta: q15(y17),
        },
    }
}

/// Duties for a vector its caller has already limited to the circle (the current loop's
/// output), as the f32 `svpwm_limited`: a vector inside the hexagon (its phase-voltage span at
/// most the bus) is applied as it is, not `saturated`; a longer one takes [`svpwm_q15`] (cut
/// to the circle).
#[inline(always)]
pub fn svpwm_limited_q15(v_ab: AlphaBetaQ15) -> SvpwmQ15 {
    let (x, y) = (i32::from(v_ab.alpha), i32::from(v_ab.beta));
    let (duties, span) = injection(x << 2, y << 2);
    if span <= 1 << 18 {
        SvpwmQ15 {
            duties,
            saturated: false,
            v_ab_applied: v_ab,
        }
    } else {
        svpwm_q15(v_ab)
    }
}

/// `(x, y)` (Q15, beyond the circle, so not zero) cut along itself to the circle, in Q17:
/// the unit vector `u` ([`unit_q15`], its length within 3 LSB of 1), then the radius corrected
/// for `u`'s own length by one Newton step for `1/|u|` about 1 (`r = (1/√3)(3 − |u|²)/2`, its
/// error `1.5 (|u|² − 1)²` below 10⁻⁸), in Q17 so that `|u_k|·r` fits a `u32`.
#[inline(always)]
fn cut(x: i32, y: i32) -> (i32, i32) {
    // −32 768 → −32 767 (unit_q15's range): a direction change below 2⁻¹⁵ rad.
    let (x, y) = (x.max(-32_767), y.max(-32_767));
    let (c, s) = unit_q15(x, y).unwrap_or((0, 0));
    let (c, s) = (i32::from(c), i32::from(s));
    // |u|² − 1 in Q30, within ±2¹⁸ (3 LSB of length: 2·3·2¹⁵; held there).
    let dev = ((c * c) as u32 + (s * s) as u32).wrapping_sub(1 << 30) as i32;
    let dev = dev.clamp(-(1 << 18), 1 << 18);
    // r = C (1 − dev/2³¹) in Q17: C_Q17 − C_Q15 (dev/2⁴)/2²⁵.
    let r = (CIRCLE_Q17 - ((CIRCLE_Q15 * (dev >> 4)) >> 25)) as u32;
    // |u_k| ≤ 32 767, r < 75 700: the product is below 2³²; Q32 to Q17.
    let scale = |u: i32| {
        let m = ((u.unsigned_abs() * r + (1 << 14)) >> 15) as i32;
        if u < 0 {
            -m
        } else {
            m
        }
    };
    (scale(c), scale(s))
}

/// Min–max injection of `(x, y)` in Q17 of the bus (`|x|, |y| ≤ 2¹⁷`): the three duties
/// (clamped to `[0, DUTY_ONE]`) and the phase-voltage span `max − min` in Q18 (2¹⁸ is the
/// bus).
#[inline(always)]
fn injection(x: i32, y: i32) -> (DutiesQ15, i32) {
    // Inverse Clarke, each phase twice in Q17 (Q18): a = α, b = −α/2 + (√3/2) β, c = −a − b.
    // |y|·√3_Q13 ≤ 2¹⁷·14 189 < 2³¹.
    let a = x << 1;
    let b = -x + ((y * SQRT3_Q13 + (1 << 12)) >> 13);
    let c = -a - b;
    let hi = a.max(b).max(c);
    let lo = a.min(b).min(c);
    let sum = hi + lo;
    // ½ + (v_k − (max + min)/2): Q19 of the bus to Q15, rounded once, clamped.
    let duty = |v: i32| {
        let d = (i32::from(DUTY_ONE) >> 1) + ((2 * v - sum + 8) >> 4);
        d.clamp(0, i32::from(DUTY_ONE)) as u16
    };
    (
        DutiesQ15 {
            a: duty(a),
            b: duty(b),
            c: duty(c),
        },
        hi - lo,
    )
}

/// A duty in Q15 as the f32 fraction (tests, telemetry).
pub fn duty_f32(d: u16) -> f32 {
    f32::from(d) / f32::from(DUTY_ONE)
}

/// Per unit of the bus: `Q15` of `v/V_bus` for tests and configuration.
pub fn of_bus(v: f32, v_bus: f32) -> Q15 {
    super::pu::to_q15(v / v_bus)
}
