//! Space-vector PWM by min–max (zero-sequence) injection.
//!
//! The αβ voltage command is turned into phase voltages (inverse Clarke), the common mode
//! `−(max + min)/2` is added so the three poles are centred in the DC bus, and each is divided
//! by the bus voltage. This is linear up to `|v_αβ| = v_bus/√3`, the circle inscribed in the
//! inverter's voltage hexagon; larger commands are scaled back onto that circle.

use crate::frames::{Abc, AlphaBeta};
use crate::math::{all_finite, clamp, max, min, rsqrt_normal, INV_SQRT3};
use core::hint::cold_path;

/// Duty cycles of the three half bridges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Duties {
    /// Phase a: fraction of the PWM period its high-side switch is on, in [0, 1].
    pub a: f32,
    /// Phase b: fraction of the PWM period its high-side switch is on, in [0, 1].
    pub b: f32,
    /// Phase c: fraction of the PWM period its high-side switch is on, in [0, 1].
    pub c: f32,
}

impl Duties {
    /// All three duties at 0.5: zero phase-to-neutral voltage.
    pub const NEUTRAL: Self = Self {
        a: 0.5,
        b: 0.5,
        c: 0.5,
    };
}

/// Result of [`svpwm`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Svpwm {
    /// Duty cycles to load into the timer, each in [0, 1], never NaN.
    pub duties: Duties,
    /// True when the command was outside the linear range (or invalid) and was reduced.
    pub saturated: bool,
    /// The αβ voltage (V) the duties produce on average: the command itself in the linear
    /// range, the command scaled to magnitude `v_bus/√3` when saturated, zero when invalid.
    pub v_ab_applied: AlphaBeta,
}

impl Svpwm {
    /// All switches at 50 %: zero volts, reported as saturated (the answer to an invalid input).
    pub const OFF: Self = Self {
        duties: Duties::NEUTRAL,
        saturated: true,
        v_ab_applied: AlphaBeta::new(0.0, 0.0),
    };
}

/// Duty cycles for the αβ voltage command `v_ab` (V) on a DC bus of `v_bus` (V, > 0).
///
/// Linear (exact to f32 rounding) for `|v_ab| <= v_bus/√3`. Above it the vector is scaled
/// down to that magnitude, keeping its angle, and `saturated` is set. If `v_bus` is not a
/// number in [1e-18, 1e19] V (where `v_bus²/3` is a normal f32), or `v_ab` is not finite, the result is 0.5 on all phases (zero
/// volts), `saturated = true` and `v_ab_applied = 0`. Duties are always within [0, 1], never NaN.
// Inlined: the 4 kHz step compiles to one function (see `drive`).
#[inline(always)]
pub fn svpwm(v_ab: AlphaBeta, v_bus: f32) -> Svpwm {
    // One division for the three duties. The bus range keeps 1/v_bus and (v_bus/√3)² normal
    // numbers, so the squares below compare what they mean (a wider range let v_max² overflow
    // and a huge command through uncut: NaN duties), and makes the rounding of subnormal
    // voltages negligible against the bus.
    let inv_bus = 1.0 / v_bus;
    if !((BUS_MIN_V..=BUS_MAX_V).contains(&v_bus) && all_finite([v_ab.alpha, v_ab.beta])) {
        cold_path();
        return Svpwm::OFF;
    }
    let v_max = v_bus * INV_SQRT3;
    // Squares compared (no square root in the linear range); never NaN here (finite
    // inputs); +inf when the squares overflow, which saturates.
    let saturated = v_ab.alpha * v_ab.alpha + v_ab.beta * v_ab.beta > v_max * v_max;
    let v_ab_applied = if saturated {
        // Normalise by the larger component first so huge commands cannot overflow.
        let inv_m = 1.0 / max(libm::fabsf(v_ab.alpha), libm::fabsf(v_ab.beta));
        let unit = AlphaBeta::new(v_ab.alpha * inv_m, v_ab.beta * inv_m);
        // |unit|² is in [1, 2]: normal, no check needed.
        let k = v_max * rsqrt_normal(unit.alpha * unit.alpha + unit.beta * unit.beta, 3);
        AlphaBeta::new(unit.alpha * k, unit.beta * k)
    } else {
        v_ab
    };
    if let Some(duties) = unclamped_duties(v_ab_applied, v_bus, inv_bus) {
        return Svpwm {
            duties,
            saturated,
            v_ab_applied,
        };
    }
    // Only a vector on the circle at the hexagon's corners (30° + k·60°) comes this close to
    // the bus: its duties are 0 or 1 but for rounding.
    cold_path();
    let limit = |d: f32| clamp(0.5 + d, 0.0, 1.0);
    let d = min_max_injection(v_ab_applied, inv_bus).0;
    Svpwm {
        duties: Duties {
            a: limit(d.a),
            b: limit(d.b),
            c: limit(d.c),
        },
        saturated,
        v_ab_applied,
    }
}

/// [`svpwm`] of a vector its caller has already limited to the circle `v_bus/√3` on a bus it
/// has already checked (the current loop's output, `foc`: `v_bus²/3` a normal f32, so 1/v_bus
/// is finite). Checks only that `v_ab` is finite (else zero volts). A vector the PWM can make
/// (inside the hexagon, as the limited vector is but for rounding) is applied as it is, not
/// flagged `saturated`: a longer one (a caller's output rotation longer than 1) only up to the
/// hexagon, 2/√3 of the circle. A vector beyond the hexagon, or any vector on a bus that is not
/// positive, takes [`svpwm`] (cut to the circle, or zero volts). Duties are always within
/// [0, 1], never NaN.
#[inline(always)]
pub(crate) fn svpwm_limited(v_ab: AlphaBeta, v_bus: f32) -> Svpwm {
    let inv_bus = 1.0 / v_bus;
    if !all_finite([v_ab.alpha, v_ab.beta]) {
        cold_path();
        return Svpwm::OFF;
    }
    match unclamped_duties(v_ab, v_bus, inv_bus) {
        Some(duties) => Svpwm {
            duties,
            saturated: false,
            v_ab_applied: v_ab,
        },
        None => {
            cold_path();
            svpwm(v_ab, v_bus)
        }
    }
}

/// Min–max injection: each phase's voltage plus the common mode `−(max + min)/2`, per volt of
/// bus (`inv_bus` = 1/v_bus), centred on 0; and the phase-voltage span (max − min) \[V].
#[inline(always)]
fn min_max_injection(v_ab: AlphaBeta, inv_bus: f32) -> (Abc, f32) {
    let v = v_ab.to_abc();
    let (hi, lo) = (max(max(v.a, v.b), v.c), min(min(v.a, v.b), v.c));
    let v0 = -0.5 * (hi + lo);
    let centred = |x: f32| (x + v0) * inv_bus;
    (Abc::new(centred(v.a), centred(v.b), centred(v.c)), hi - lo)
}

/// The duties of `v_ab` on a bus of `v_bus` (`inv_bus` its inverse) when no clamp is needed:
/// each |x + v0| is at most (hi − lo)/2 but for a few roundings (relative 2⁻²⁴ each), so with
/// hi − lo at most (1 − 2⁻²⁰)·v_bus every duty is inside [0, 1]. `None` above that span, for a
/// NaN, and for any vector on a bus that is not positive (the span is never negative).
#[inline(always)]
fn unclamped_duties(v_ab: AlphaBeta, v_bus: f32, inv_bus: f32) -> Option<Duties> {
    let (d, span) = min_max_injection(v_ab, inv_bus);
    if span <= SPAN_UNCLAMPED * v_bus {
        Some(Duties {
            a: 0.5 + d.a,
            b: 0.5 + d.b,
            c: 0.5 + d.c,
        })
    } else {
        None
    }
}

/// Bus range \[V] `svpwm` accepts.
const BUS_MIN_V: f32 = 1e-18;
const BUS_MAX_V: f32 = 1e19;

/// Largest phase-voltage span per volt of bus whose duties need no clamp, 1 − 2⁻²⁰.
const SPAN_UNCLAMPED: f32 = 1.0 - 1.0 / 1_048_576.0;

/// Average phase-to-neutral voltages (V) produced by duties `d` on a bus of `v_bus` (V):
/// pole voltages `d·v_bus` minus their mean (the floating star point removes the common mode).
pub fn duties_to_phase_voltages(d: Duties, v_bus: f32) -> Abc {
    let (a, b, c) = (d.a * v_bus, d.b * v_bus, d.c * v_bus);
    let mean = (a + b + c) * (1.0 / 3.0);
    Abc::new(a - mean, b - mean, c - mean)
}
