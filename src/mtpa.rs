//! Maximum torque per ampere (MTPA) of an interior-magnet motor (`L_q > L_d`): the d current
//! that, with the q current, makes a torque with the least current magnitude.
//!
//! With the amplitude-invariant dq model the torque is (`c` the torque convention's factor,
//! [`crate::motor::TorqueConvention::factor`])
//!
//! ```text
//! τ = c N (ψ_f + (L_d − L_q) i_d) i_q
//! ```
//!
//! and for a current of magnitude `I` at the angle `β` from the q axis (`i_d = −I sin β`,
//! `i_q = I cos β`) it is largest where `∂τ/∂β = 0`:
//!
//! ```text
//! i_d = ψ_f/(2 (L_q − L_d)) − √(ψ_f²/(4 (L_q − L_d)²) + i_q²)              (for a given i_q)
//! i_d = (ψ_f − √(ψ_f² + 8 (L_q − L_d)² I²))/(4 (L_q − L_d))                  (for a given |i| = I)
//! ```
//!
//! (S. Morimoto, Y. Takeda, T. Hirasa, K. Taniguchi, "Expansion of operating limits for
//! permanent magnet motor by current vector control considering inverter capacity", IEEE
//! Trans. Ind. Appl. 26(5), 1990, the maximum-torque-per-current condition; T. M. Jahns,
//! G. B. Kliman, T. W. Neumann, "Interior permanent-magnet synchronous motors for
//! adjustable-speed drives", IEEE Trans. Ind. Appl. IA-22(4), 1986.) With
//! `k = 2 (L_q − L_d)/ψ_f` \[1/A] (`1/k` is the formula's `ψ_f/(2 (L_q − L_d))`) both are
//! written without a cancellation (the difference of two nearly equal terms of a weakly salient
//! motor, where `1/k` is far above the currents), as the drive computes them:
//!
//! ```text
//! i_d(i_q) = −k i_q²/(1 + √(1 + k² i_q²))
//! i_d(I)   = −k I²/(1 + √(1 + 2 k² I²))
//! τ        = c N ψ_f (1 − k i_d/2) i_q
//! ```
//!
//! **The torque current.** The speed loop commands a torque as the q current a non-salient
//! motor of the same `ψ_f` would need, `i_τ = τ/(c N ψ_f)` (the unit every torque of the drive
//! is in: the load observers' estimates fed forward, the speed PI's gains from `c N ψ_f`);
//! [`Mtpa::split`] turns it into the currents. The MTPA condition written as
//! `i_q² = i_d (i_d − 2/k)` (the quadratic whose root the closed form is) and the torque
//! `i_q (1 − k i_d/2) = i_τ` give, with `x = −i_d ≥ 0` and `u = 1 + k x/2`,
//!
//! ```text
//! h(x) = x u³ − k i_τ²/2 = 0,       h'(x) = u² (u + 3 k x/2)
//! ```
//!
//! increasing and convex in `x ≥ 0`: one Newton step per call from the last call's d current
//! lands at or above the root from any start, quadratically close to it near it (no square
//! root). From below the root the step overshoots, to `k i_τ²/2` from `x = 0`. So it is cut at
//! `|i_τ|/√2`, which lies beyond the root: on the MTPA curve the torque per ampere is at least
//! `i_d = 0`'s, so the current `I` is at most `|i_τ|`, and the current's angle from the q axis
//! is below 45°, so `|i_d| < I/√2`. (On the Brusa HSM1, for an `i_τ` of 128 A whose MTPA d
//! current is −49 A, the step from `x = 0` went to −206 A; cut, it goes to −91 A, then −64 and
//! −52 A the next two calls.) The d current is that `−x`, or the field weakening's where it is
//! more negative; then `i_q = i_τ/(1 − k i_d/2)`, so the torque is `c N ψ_f i_τ` whatever `i_d`
//! is (the Newton step's residual moves the point along the torque's curve, off the optimum to
//! second order, not the torque): the d current at or below the curve's, the q current rising
//! to the curve call by call. The speed loop's gain stays `c N ψ_f` per ampere of its output, as
//! its gains are computed for. At 1 kHz: two divisions, on salient motors only.
//!
//! Not salient (`L_d = L_q`): no MTPA, `i_d = 0` (`Mtpa::new` gives `None`, the drive skips it).
//! Inverse saliency (`L_q < L_d`): MTPA asks for a positive, magnetising d current; the drive's
//! d command is the more negative of the MTPA's and the field weakening's (≤ 0), and a
//! magnetising current saturates the d axis (the iron the magnet already drives), where the
//! linear model's optimum is not the machine's: no MTPA (`None`).

use crate::frames::Dq;
use crate::math::{max, min, sqrt_or_zero};
use crate::motor::MotorParams;
use core::f32::consts::FRAC_1_SQRT_2;

/// MTPA's coefficients (module doc), for a motor with `L_q > L_d`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mtpa {
    /// `k = 2 (L_q − L_d)/ψ_f` \[1/A].
    k: f32,
    /// `k²` \[1/A²].
    k2: f32,
    /// `k/2` \[1/A].
    half_k: f32,
    /// The MTPA d current at the current limit, `i_d(I = i_max)` \[A] (≤ 0).
    i_d_at_max: f32,
    /// The torque current at the current limit on the MTPA curve \[A] (≥ `i_max`).
    i_tau_at_max: f32,
}

impl Mtpa {
    /// MTPA for `m` within the current limit `i_max_a` \[A]: `None` for a non-salient motor
    /// (`L_d = L_q`: `i_d = 0` is the MTPA) and for inverse saliency (`L_q < L_d`: module doc),
    /// and for a `k` that is not a positive finite number (a NaN among the parameters).
    // Out of line: configuration, not the control path (each inlined copy costs flash).
    #[inline(never)]
    pub fn new(m: &MotorParams, i_max_a: f32) -> Option<Self> {
        if !m.is_salient() {
            return None;
        }
        let k = -2.0 * m.l_d_minus_l_q_h() / m.flux_wb;
        if !(k > 0.0 && k.is_finite()) {
            return None;
        }
        // (`sqrt_or_zero`, not `math::sqrt`: its fallback would link libm's square root into
        // the firmware; the argument is at least 1.)
        let i_d_at_max =
            -k * i_max_a * i_max_a / (1.0 + sqrt_or_zero(1.0 + 2.0 * k * k * i_max_a * i_max_a));
        let i_q_at_max = sqrt_or_zero(i_max_a * i_max_a - i_d_at_max * i_d_at_max);
        Some(Self {
            k,
            k2: k * k,
            half_k: 0.5 * k,
            i_d_at_max,
            i_tau_at_max: i_q_at_max * (1.0 - 0.5 * k * i_d_at_max),
        })
    }

    /// `k = 2 (L_q − L_d)/ψ_f` \[1/A]: `1/k` is Morimoto's `ψ_f/(2 (L_q − L_d))`.
    pub fn k(&self) -> f32 {
        self.k
    }

    /// The MTPA d current for the q current `i_q` \[A]: `−k i_q²/(1 + √(1 + k² i_q²))` =
    /// `ψ_f/(2 (L_q − L_d)) − √(ψ_f²/(4 (L_q − L_d)²) + i_q²)` \[A], ≤ 0; 0 for a NaN.
    #[inline(always)]
    pub fn i_d(&self, i_q: f32) -> f32 {
        let s = sqrt_or_zero(1.0 + self.k2 * i_q * i_q);
        min(-self.k * i_q * i_q / (1.0 + s), 0.0)
    }

    /// The MTPA d current for the current magnitude `i_a` \[A]: `−k I²/(1 + √(1 + 2 k² I²))` =
    /// `(ψ_f − √(ψ_f² + 8 (L_q − L_d)² I²))/(4 (L_q − L_d))` \[A], ≤ 0; 0 for a NaN.
    pub fn i_d_for_current(&self, i_a: f32) -> f32 {
        let s = sqrt_or_zero(1.0 + 2.0 * self.k2 * i_a * i_a);
        min(-self.k * i_a * i_a / (1.0 + s), 0.0)
    }

    /// The torque current of the currents `i_dq` \[A]: `i_q (1 − k i_d/2)`, the q current a
    /// non-salient motor of the same `ψ_f` makes their torque with \[A].
    #[inline(always)]
    pub fn torque_current(&self, i_dq: Dq) -> f32 {
        i_dq.q * (1.0 - self.half_k * i_dq.d)
    }

    /// `ψ_a/ψ_f = 1 − k i_d/2` at the MTPA's d current on the current limit: the active flux
    /// (`observer::flux`) of the largest currents the MTPA asks for, over the magnet's.
    pub fn active_flux_ratio_at_max(&self) -> f32 {
        1.0 - self.half_k * self.i_d_at_max
    }

    /// The torque current on the MTPA curve at the current limit \[A].
    pub fn torque_current_at_max(&self) -> f32 {
        self.i_tau_at_max
    }

    /// The most torque current within the current limit with the field weakening's d current
    /// `i_d_fw` \[A] (≤ 0): the MTPA's at the limit ([`Mtpa::torque_current_at_max`]), or,
    /// where the field weakening's d current is more negative than the MTPA's there, the
    /// torque current of that d current and the q current it leaves of the limit, `i_q_max_a`
    /// \[A] (`√(i_max² − i_d²)`, the caller's, with any other d current it adds).
    #[inline(always)]
    pub fn torque_limit(&self, i_d_fw: f32, i_q_max_a: f32) -> f32 {
        if i_d_fw < self.i_d_at_max {
            i_q_max_a * (1.0 - self.half_k * i_d_fw)
        } else {
            self.i_tau_at_max
        }
    }

    /// The currents for the torque current `i_tau` \[A] (module doc): one Newton step from
    /// the last d current `i_d_last` \[A] toward the MTPA's d current for this torque, or the
    /// field weakening's `i_d_fw` \[A] (≤ 0) where that is more negative, and the q current
    /// that makes the torque with it, `i_τ/(1 − k i_d/2)`. The MTPA's d current is within its
    /// value at the current limit and 0 (0 for a NaN), the field weakening's ≤ 0 and finite,
    /// so the divisions are by at least 1 and finite.
    // (The drive calls it from a function of its own, out of line: a non-salient motor's
    // tick pays a branch, not the registers and the flash of the salient one's arithmetic.)
    #[inline]
    pub fn split(&self, i_tau: f32, i_d_last: f32, i_d_fw: f32) -> Dq {
        // Newton on h(x) = x u³ − k i_τ²/2, u = 1 + k x/2, from x = −i_d_last within 0 and
        // the MTPA's at the current limit (the root is within them for a torque within the
        // limit; 0 for a NaN: `max` gives its second argument for a NaN first).
        let x = min(max(-i_d_last, 0.0), -self.i_d_at_max);
        let u = 1.0 + self.half_k * x;
        let u2 = u * u;
        let h = x * u2 * u - self.half_k * i_tau * i_tau;
        let x = x - h / (u2 * (u + 3.0 * self.half_k * x));
        // From below the root the step overshoots; `|i_τ|/√2` lies beyond the root and bounds
        // it (module doc).
        let x = min(x, FRAC_1_SQRT_2 * i_tau.abs());
        // The MTPA's d current within its value at the current limit and 0 (finite for any
        // start, 0 for a NaN: `min` gives its second argument for a NaN first).
        let i_d = min(i_d_fw, max(min(-x, 0.0), self.i_d_at_max));
        Dq::new(i_d, i_tau / (1.0 - self.half_k * i_d))
    }
}
