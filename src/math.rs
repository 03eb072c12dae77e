//! f32 trigonometry for the control loop: `sin_cos`, `atan2` and angle wrapping.
//!
//! `libm::sinf`/`cosf`/`atan2f` are slow in software on the Cortex-M4F, so these are short
//! polynomials after an exact range reduction. The polynomial coefficients are the single
//! precision minimax sets of the Cephes library (S. L. Moshier, `sinf.c`, `cosf.c`,
//! `atanf.c`). Error bounds below were measured on the host against f64 `std`
//! (`tests/math.rs`, plus a one-off sweep of every third f32 in the stated range); the
//! code is plain IEEE f32 arithmetic (Rust never fuses into FMA), so the M4F gives the same bits.

use core::f32::consts::{FRAC_2_PI, FRAC_PI_2, FRAC_PI_4, PI, TAU};
use core::hint::cold_path;

/// π/2 split in three parts (Cody–Waite; the Cephes `DP1..DP3` for π/4, doubled).
/// `PIO2_HI` has 8 significant bits and `PIO2_MID` 11, so `n * PIO2_HI` and `n * PIO2_MID`
/// are exact for integer `|n| < 2^13`, i.e. `|theta| < ~1.28e4` rad.
const PIO2_HI: f32 = 1.570_312_5;
const PIO2_MID: f32 = 4.837_513e-4;
const PIO2_LO: f32 = 7.549_79e-8;

/// Largest |θ| \[rad] `sin_cos` reduces directly (quadrant count below 2^13).
const REDUCE_MAX: f32 = 1.28e4;

/// 1/√3: the largest phase voltage amplitude SVPWM makes is `v_bus/√3`; the Clarke transform's β
/// row.
pub const INV_SQRT3: f32 = 0.577_350_26;

/// Largest f32 below `PI` (the f32 `PI` lies above π, `-PI` below −π).
const PI_BELOW: f32 = 3.141_592_5;

/// `theta − n·π/2` for an integer-valued `n`, with π/2 carried to ~48 bits.
fn sub_quarter_turns(theta: f32, n: f32) -> f32 {
    ((theta - n * PIO2_HI) - n * PIO2_MID) - n * PIO2_LO
}

/// Sine and cosine of `theta` (rad), returned as `(sin, cos)`.
///
/// Accuracy: max absolute error 1.2e-7 (measured 7.8e-8, both outputs) for
/// |theta| <= 1e4 rad, against f64 `sin_cos` of the same f32 input. Beyond that the reduction
/// loses accuracy (measured 1.2e-6 up to 1e5 rad, 3e-2 up to 1e6 rad): keep angles wrapped.
/// For any finite input the results stay finite and within [-1, 1].
/// Non-finite input (NaN, ±inf) yields `(NaN, NaN)`: callers must check.
/// Cost: no division, no loop.
// Out of line: one copy for the callers off the hot path (the 4 kHz step's evaluation is
// `sin_cos_wrapped`), so the step's own code stays small.
#[inline(never)]
pub fn sin_cos(theta: f32) -> (f32, f32) {
    // One compare on the usual path; NaN, ±inf and angles beyond the exact reduction take
    // the other branch (large ones are wrapped into (−π, π] first).
    let theta = if libm::fabsf(theta) <= REDUCE_MAX {
        theta
    } else if theta.is_finite() {
        cold_path();
        wrap_pi(theta)
    } else {
        return (f32::NAN, f32::NAN);
    };
    let k = theta * FRAC_2_PI;
    let q = (if k >= 0.0 { k + 0.5 } else { k - 0.5 }) as i32;
    // |q| < 2^13, so the reduction is exact to ~48 bits and |r| <= π/4 (+ rounding).
    let r = sub_quarter_turns(theta, q as f32);
    let z = r * r;
    let s = r + r * z * ((-1.951_529_6e-4 * z + 8.332_161e-3) * z - 1.666_665_5e-1);
    let c = ((2.443_315_7e-5 * z - 1.388_731_6e-3) * z + 4.166_664_6e-2) * z * z - 0.5 * z + 1.0;
    quarter_turns(q, s, c)
}

/// `(sin, cos)` of `θ + q·π/2` from `s`, `c` = sin θ, cos θ: quadrant q mod 4, odd swaps sin
/// and cos (and negates the new cos), 2 and 3 negate both. Exact (swaps and signs).
#[inline(always)]
const fn quarter_turns(q: i32, s: f32, c: f32) -> (f32, f32) {
    let (s, c) = if q & 1 != 0 { (c, -s) } else { (s, c) };
    if q & 2 != 0 {
        (-s, -c)
    } else {
        (s, c)
    }
}

/// Sine and cosine of an angle already wrapped, |`theta`| ≤ 4 rad (e.g. in (−π, π]), returned as
/// `(sin, cos)`: the nearest of 64 tabulated angles `k·π/32` and a short series of the rest
/// `r` (|r| ≤ π/64: `sin r ≈ r − r³/6`, `cos r − 1 ≈ −r²/2 + r⁴/24`, truncation below 2.4e-9),
/// added to the table's pair as a small correction.
///
/// Accuracy: max absolute error 1.2e-7 (measured 6.2e-8, `tests/math.rs`) against f64 for
/// |theta| ≤ 4; other inputs take [`sin_cos`]. About two thirds of [`sin_cos`]'s cost: no
/// quadrant logic, no degree-8 polynomials.
#[inline(always)]
pub fn sin_cos_wrapped(theta: f32) -> (f32, f32) {
    let in_range = libm::fabsf(theta) <= 4.0; // false for NaN
    if !in_range {
        cold_path();
        return sin_cos(theta);
    }
    // k = round(θ·32/π) by the 1.5·2^23 shift (exact for |θ·32/π| < 2^22), |k| ≤ 41.
    let k = (theta * (32.0 / PI) + ROUND_SHIFT) - ROUND_SHIFT;
    // θ − k·π/32 with π/32 in two parts (k·PIO32_HI is exact, the subtraction exact by
    // Sterbenz's lemma).
    let r = (theta - k * PIO32_HI) - k * PIO32_LO;
    let [s_k, c_k] = SIN_COS_TABLE[(k as i32 & (TABLE_STEPS as i32 - 1)) as usize];
    let z = r * r;
    let sin_r = r + r * (z * (-1.0 / 6.0));
    let cos_r_m1 = z * (z * (1.0 / 24.0) - 0.5);
    (
        s_k + (s_k * cos_r_m1 + c_k * sin_r),
        c_k + (c_k * cos_r_m1 - s_k * sin_r),
    )
}

/// 1.5·2^23: adding and subtracting it rounds an f32 of magnitude below 2^22 to an integer.
const ROUND_SHIFT: f32 = 12_582_912.0;
/// π/32 in two parts: `PIO32_HI` has 17 significant bits, so `k·PIO32_HI` is exact for
/// |k| < 128.
const PIO32_HI: f32 = 102_944.0 / 1_048_576.0;
const PIO32_LO: f32 = -2.784_034_3e-7;
/// Tabulated angles per turn (a power of two: the index is `k mod 64`).
const TABLE_STEPS: usize = 64;

/// `[sin, cos]` of `k·2π/64`, k = 0..63, built at compile time from the first quarter turn by
/// the quadrant symmetries (exact: swaps and negations).
/// Read every step: a firmware that runs its step from RAM places it there too (its symbol
/// name is `SIN_COS_TABLE`).
static SIN_COS_TABLE: [[f32; 2]; TABLE_STEPS] = sin_cos_table();

/// sin(j·π/32), j = 0..=16: the f32 values nearest to them (`tests/math.rs` checks
/// `sin_cos_wrapped` at every tabulated angle against f64).
#[allow(clippy::excessive_precision)]
const SIN_QUARTER_TURN: [f32; 17] = [
    0.0,
    0.098_017_141_2,
    0.195_090_324,
    0.290_284_663,
    0.382_683_426,
    0.471_396_744,
    0.555_570_245,
    0.634_393_275,
    0.707_106_769,
    0.773_010_433,
    0.831_469_595,
    0.881_921_291,
    0.923_879_504,
    0.956_940_353,
    0.980_785_251,
    0.995_184_72,
    1.0,
];

const fn sin_cos_table() -> [[f32; 2]; TABLE_STEPS] {
    let mut table = [[0.0f32; 2]; TABLE_STEPS];
    let mut k = 0;
    while k < TABLE_STEPS {
        // k·π/32 = q·π/2 + j·π/32: sin and cos of j·π/32, then turned by q quarter turns.
        let j = k % 16;
        let (s, c) = quarter_turns(
            (k / 16) as i32,
            SIN_QUARTER_TURN[j],
            SIN_QUARTER_TURN[16 - j],
        );
        table[k] = [s, c];
        k += 1;
    }
    table
}

/// Four-quadrant arctangent of `y / x` in rad, in (−π, π], i.e. `[-3.1415925, PI]` in f32:
/// `-PI` is never returned, `atan2(-0.0, -1.0) == PI`, `atan2(±0, ±0) == 0`.
///
/// Accuracy: max absolute error 4e-7 rad (measured 2.7e-7) over all inputs tested (polar
/// grid with radii 1e-40..3e38, Cartesian grid, axes, every third f32 ratio in [0, 1] in all
/// octants), against f64 `atan2` of the same f32 inputs (angles compared modulo 2π).
/// Never divides by zero for finite input. NaN input gives NaN; ±inf input gives an
/// unspecified value in [−π, π] or NaN.
// Out of line: the 1 kHz task, the log and the mode changes each take it; one copy serves them.
#[inline(never)]
pub fn atan2(y: f32, x: f32) -> f32 {
    let (ax, ay) = (libm::fabsf(x), libm::fabsf(y));
    if ax == 0.0 && ay == 0.0 {
        return 0.0;
    }
    let swap = ay > ax;
    let (lo, hi) = if swap { (ax, ay) } else { (ay, ax) };
    // t = lo/hi in [0, 1]. One division: above tan(π/8), atan t = π/4 + atan((t−1)/(t+1))
    // = π/4 + atan((lo − hi)/(lo + hi)); scaled by 1/4 (exact) where lo + hi could overflow.
    let (lo, hi) = if hi > 1.0e38 {
        cold_path();
        (0.25 * lo, 0.25 * hi)
    } else {
        (lo, hi)
    };
    let (num, den, base) = if lo > 0.414_213_57 * hi {
        (lo - hi, lo + hi, FRAC_PI_4)
    } else {
        (lo, hi, 0.0)
    };
    let u = num / den;
    let z = u * u;
    let p = ((8.053_744_6e-2 * z - 1.387_768_5e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1;
    let mut a = base + (u + u * z * p);
    if swap {
        a = FRAC_PI_2 - a;
    }
    if x < 0.0 {
        a = PI - a;
    }
    if y < 0.0 {
        // −π is out of range (a = π for y = −0, x < 0); a compare and select (`f32::min` is a
        // library call on thumbv7em), NaN passes.
        -(if a > PI_BELOW { PI_BELOW } else { a })
    } else {
        a
    }
}

/// `theta` (rad) wrapped to (−π, π]: `wrap_pi(PI) == PI`; `wrap_pi(-PI)` is `PI_BELOW`
/// (3.1415925, the f32 nearest to `-PI + 2π`, since the f32 `-PI` lies just below −π).
///
/// Accuracy: max absolute error 5e-7 rad (measured 2.9e-7) for |theta| <= 1e4, against
/// `theta − 2πk` in f64; inputs already in (−π, π] are returned unchanged. Measured 1.3e-6
/// up to 1e5 rad, 3e-2 up to 1e6 rad. The result is in range for every finite input. NaN/±inf yield NaN. Floor-based, no loop.
// Inlined: the in-range test and the one-turn case are a few instructions; angles further out
// (and NaN) call `wrap_pi_far`.
#[inline(always)]
pub fn wrap_pi(theta: f32) -> f32 {
    let a = libm::fabsf(theta);
    // One compare on the usual path (±π themselves take the other; false for NaN).
    if a < PI {
        return theta;
    }
    // One turn out, an angle advanced past ±π (once per electrical turn on the step's paths):
    // θ ∓ 2π as (θ ∓ TAU) ± (TAU − 2π). The first difference is exact (Sterbenz: |θ| is
    // within [TAU/2, 2·TAU]), so the result is θ ∓ 2π with one rounding, and it lies in
    // (−π, π] without a clamp (θ just above `PI` gives −3.1415923, `-PI` gives `PI_BELOW`).
    // `PI` itself stays (it is in range).
    if a < ONE_TURN_OUT {
        if theta == PI {
            return PI;
        }
        return if theta > 0.0 {
            (theta - TAU) + TAU_EXCESS
        } else {
            (theta + TAU) - TAU_EXCESS
        };
    }
    cold_path();
    wrap_pi_far(theta)
}

/// Below this |θ| \[rad] (< 3π) one turn brings θ into (−π, π].
const ONE_TURN_OUT: f32 = 9.0;

/// The f32 `TAU` less 2π \[rad] (1.748 455 6e-7; `TAU` rounds 2π up).
const TAU_EXCESS: f32 = 1.748_455_6e-7;

/// [`wrap_pi`] of an angle more than a turn out of range, or not finite.
#[inline(never)]
fn wrap_pi_far(theta: f32) -> f32 {
    // k = ceil(theta/2π − 1/2), so that theta = π gives k = 0.
    let turns = -libm::floorf(0.5 - theta * (0.5 * core::f32::consts::FRAC_1_PI));
    let mut r = sub_quarter_turns(theta, 4.0 * turns);
    if r <= -PI {
        r += TAU;
    }
    if r > PI {
        r -= TAU;
    }
    r.clamp(-PI_BELOW, PI)
}

/// `theta` (rad) wrapped to [0, 2π) (2π maps to 0; the f32 `TAU`, 1.7e-7 above 2π, to 1.7e-7).
///
/// Accuracy: max absolute error 6e-7 rad (measured 4.1e-7) for |theta| <= 1e4, against
/// `theta − 2πk` in f64 (compared modulo 2π at the 0/2π seam); inputs already in [0, 2π)
/// are returned unchanged. Measured 1.4e-6 up to 1e5 rad, 3e-2 up to 1e6 rad. The result is in [0, 2π) for every finite input.
/// NaN/±inf yield NaN. Floor-based, no loop.
pub fn wrap_2pi(theta: f32) -> f32 {
    if (0.0..TAU).contains(&theta) {
        return theta;
    }
    let turns = libm::floorf(theta * (0.5 * core::f32::consts::FRAC_1_PI));
    let mut r = sub_quarter_turns(theta, 4.0 * turns);
    if r < 0.0 {
        r += TAU;
    }
    if r >= TAU {
        r -= TAU;
    }
    if (0.0..TAU).contains(&r) || r.is_nan() {
        r
    } else {
        0.0
    }
}

/// `1/√x` [same unit as `x`^-½] without a division or a library call: `libm::sqrtf` is a
/// software routine on thumbv7em (~60 cycles, and 480 B of flash with its table), and `core`
/// has no `f32::sqrt`.
///
/// For a normal positive `x` (≥ `f32::MIN_POSITIVE`, finite): the bit-level first guess
/// `0x5f37_5a86 − bits/2` (relative error below 3.5e-2), then three Newton steps
/// `y ← y (3/2 − x y²/2)`, each squaring the error (1.8e-3, 4.9e-6, 4e-11), so the result is
/// f32 rounding only: max relative error 4e-7 (measured 1.8e-7, `tests/math.rs`). Any other
/// input takes `1/`[`sqrt_special`]: +inf for ±0, 0 for +inf, NaN for NaN and negatives.
#[inline(always)]
pub fn rsqrt(x: f32) -> f32 {
    if is_normal_positive(x) {
        rsqrt_normal(x, 3)
    } else {
        cold_path();
        1.0 / sqrt_special(x)
    }
}

/// `√x` of what [`is_normal_positive`] leaves out, without `libm`: ±0 and +∞ themselves, a
/// positive subnormal scaled by 2²⁴ into the normal range (`√(2²⁴ x)/2¹²`, [`sqrt`]'s
/// relative error), NaN for negatives and NaN.
#[inline(never)]
pub fn sqrt_special(x: f32) -> f32 {
    cold_path();
    if x == 0.0 || x == f32::INFINITY {
        x
    } else if x > 0.0 {
        let scaled = x * 16_777_216.0;
        scaled * rsqrt_normal(scaled, 3) * (1.0 / 4096.0)
    } else {
        f32::NAN
    }
}

/// [`rsqrt`] of an `x` the caller knows to be normal and positive (no check; any other `x`
/// gives a wrong value, possibly infinite or NaN, never a panic), with `newton` Newton steps from the
/// bit-level guess (relative error 3.4e-2): 2 steps leave at most 5e-6, 3 steps f32 rounding
/// (4e-7). Each step lands at or below `1/√x` but for rounding (measured 1.8e-7 above at
/// most): `y(1.5 − x y²/2) √x = 1 − 3e²/2 − e³/2` for a guess `(1 + e)/√x`.
#[inline(always)]
pub fn rsqrt_normal(x: f32, newton: u32) -> f32 {
    // Wrapping: a negative `x` (sign bit set) would overflow the subtraction.
    let mut y = f32::from_bits(0x5f37_5a86_u32.wrapping_sub(x.to_bits() >> 1));
    let half_x = 0.5 * x;
    for _ in 0..newton {
        y *= 1.5 - half_x * y * y;
    }
    y
}

/// `√x` as `x · rsqrt(x)` for a normal positive `x` (max relative error 5e-7, measured 2.2e-7
/// in `tests/math.rs`); any other input [`sqrt_special`] (see [`rsqrt`]).
#[inline(always)]
pub fn sqrt(x: f32) -> f32 {
    if is_normal_positive(x) {
        x * rsqrt_normal(x, 3)
    } else {
        sqrt_special(x)
    }
}

/// [`sqrt`] out of line, for the work off the step (configuration, the measurements'
/// 1 kHz work): each inlined copy costs about 60 B of flash.
#[inline(never)]
pub fn sqrt_call(x: f32) -> f32 {
    sqrt(x)
}

/// `√x` for an `x` known not to be negative (a squared length): `x · rsqrt(x)` for a normal
/// `x` (relative error 5e-6, two Newton steps), 0 for 0, a subnormal or NaN — no `libm` call.
#[inline(always)]
pub fn sqrt_or_zero(x: f32) -> f32 {
    if is_normal_positive(x) {
        x * rsqrt_normal(x, 2)
    } else {
        0.0
    }
}

/// `f32::MIN_POSITIVE ≤ x ≤ f32::MAX` (false for NaN): one unsigned compare of the bits
/// (the positive normal numbers are the bit patterns 0x0080_0000..0x7F80_0000), which
/// [`rsqrt_normal`]'s guess moves to a core register anyway.
#[inline(always)]
pub fn is_normal_positive(x: f32) -> bool {
    x.to_bits().wrapping_sub(0x0080_0000) < 0x7F00_0000
}

/// True when every value is finite (no NaN, no ±∞).
///
/// `x − x` is +0 for a finite `x` and NaN for NaN or ±∞, so the sum is 0 exactly when all are
/// finite: two FPU instructions per value and one compare, where `f32::is_finite` moves each
/// value to a core register for a bit test and branches (the step checks some 30 values).
#[inline(always)]
pub fn all_finite<const N: usize>(xs: [f32; N]) -> bool {
    let mut acc = 0.0;
    for x in xs {
        // Deliberate: not 0 for NaN or ±∞.
        #[allow(clippy::eq_op)]
        let zero_if_finite = x - x;
        acc += zero_if_finite;
    }
    acc == 0.0
}

/// True when the values and their sum are finite: one FPU instruction per value fewer than
/// [`all_finite`], for a check where a sum beyond `f32::MAX` (3.4e38) is as wrong as a
/// non-finite value: an observer's state, whose values are no motor's long before that.
/// A NaN or ±∞ makes the sum NaN or ±∞ (+∞ and −∞ give NaN), and `s − s` is then NaN.
#[inline(always)]
pub fn finite_sum<const N: usize>(xs: [f32; N]) -> bool {
    let mut sum = 0.0;
    for x in xs {
        sum += x;
    }
    // Deliberate: not 0 for NaN or ±∞.
    #[allow(clippy::eq_op)]
    let zero_if_finite = sum - sum;
    zero_if_finite == 0.0
}

/// `x` limited to `[lo, hi]`, for bounds known only at run time: unlike `f32::clamp` it has no
/// panic path (that one asserts `lo <= hi`). With `lo > hi` the result is `lo` or `hi`; a NaN
/// `x` stays NaN.
#[inline]
pub fn clamp(x: f32, lo: f32, hi: f32) -> f32 {
    if x < lo {
        lo
    } else if x > hi {
        hi
    } else {
        x
    }
}

/// The larger of `a` and `b` as a compare-and-select (`f32::max` is a library call on
/// thumbv7em). For finite inputs; with a NaN the result is `b`.
#[inline]
pub fn max(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// The smaller of `a` and `b` as a compare-and-select. For finite inputs; with a NaN the
/// result is `b`.
#[inline]
pub fn min(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `(sin δ, cos δ)` for an angle known to be small: `sin δ ≈ δ − δ³/6 + δ⁵/120`,
/// `cos δ ≈ 1 − δ²/2 + δ⁴/24 − δ⁶/720` for |δ| ≤ 0.3 rad (truncation below 5e-8), [`sin_cos`]
/// for a larger one (and NaN).
#[inline(always)]
pub fn sin_cos_small(delta: f32) -> (f32, f32) {
    if libm::fabsf(delta) <= 0.3 {
        let d2 = delta * delta;
        (
            delta * (1.0 - d2 * (1.0 / 6.0) * (1.0 - d2 * (1.0 / 20.0))),
            1.0 - 0.5 * d2 * (1.0 - d2 * (1.0 / 12.0) * (1.0 - d2 * (1.0 / 30.0))),
        )
    } else {
        cold_path();
        sin_cos(delta)
    }
}

/// `(sin(θ + δ), cos(θ + δ))` from `(sin θ, cos θ)` and `(sin δ, cos δ)`: the rotation by δ.
#[inline(always)]
pub fn rotate(sin_cos_theta: (f32, f32), sin_cos_delta: (f32, f32)) -> (f32, f32) {
    let ((s, c), (sd, cd)) = (sin_cos_theta, sin_cos_delta);
    (s * cd + c * sd, c * cd - s * sd)
}

/// `(sin(θ + δ), cos(θ + δ))` from `(sin θ, cos θ)`: the rotation by `δ` \[rad] with
/// [`sin_cos_small`] of δ (the result is within 3e-7 of f64, measured in `tests/math.rs`).
#[inline(always)]
pub fn advance(sin_cos_theta: (f32, f32), delta: f32) -> (f32, f32) {
    rotate(sin_cos_theta, sin_cos_small(delta))
}
