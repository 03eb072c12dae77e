//! The windings' inductances along the rotor's axes: `L_d` and `L_q`, each with an optional
//! magnetic saturation.
//!
//! Each axis links the flux `ψ(i) = L(i)·i` (plus the magnet's ψ_f on the d axis), `L(i)`
//! the secant (apparent) inductance. Saturation follows the Fröhlich magnetisation curve
//! (O. Fröhlich, Elektrotechnische Zeitschrift 2, 1881, `B = H/(a + b|H|)`; the
//! Fröhlich–Kennelly law, D. Jiles, *Introduction to Magnetism and Magnetic Materials*,
//! 3rd ed., 2016), carried from the iron's B(H) to the axis' ψ(i) and generalised with an
//! exponent `k`:
//! ```text
//! L(i)   = L0 / (1 + x^k),                   x = i_s/i_sat, i_s ≥ 0 the saturating current
//! dψ/di  = L0 (1 + (1 − k) x^k) / (1 + x^k)²  (the incremental inductance)
//! ```
//! `k = 1` is Fröhlich's curve: `L` halves at `i_sat`, the flux tends to `L0·i_sat`. For
//! `0 < k ≤ 1` the flux rises with the current at every current (`dψ/di > 0`), which a
//! lossless magnetic circuit needs; for `k > 1` it would fall beyond
//! `x^k = 1/(k − 1)`, so `k` is limited to (0, 1] ([`Saturation::EXPONENT_MAX`]).
//!
//! Which current saturates an axis is the machine's ([`crate::electrical::Pmsm`]): on the d
//! axis only a current that adds to the magnet's flux (`i_d > 0`; a demagnetising current
//! leaves `L_d` at `L_d0`), on the q axis `|i_q|`. The axes do not saturate each other (no
//! cross-saturation) and the flux does not depend on the rotor angle, so the torque is
//! exactly `c N (ψ_d i_q − ψ_q i_d)` with the secant inductances, and the magnetic energy is
//! `c ∫ i dψ` per axis.

use num_traits::Float;

/// One axis' saturation: the Fröhlich-type secant inductance `L(i) = L0 / (1 + (i/i_sat)^k)`
/// (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Saturation {
    /// Saturating current at which the secant inductance is half of `L0` \[A] (> 0).
    pub i_sat_a: f64,
    /// Exponent `k` (0 < k ≤ 1; 1: Fröhlich's curve).
    pub exponent: f64,
}

impl Saturation {
    /// The largest exponent with a flux that rises with the current everywhere.
    pub const EXPONENT_MAX: f64 = 1.0;

    /// `x^k` for the saturating current `i_s` \[A] (≥ 0).
    fn xk(&self, i_s: f64) -> f64 {
        Float::powf(i_s / self.i_sat_a, self.exponent)
    }

    /// `L(i)/L0` at the saturating current `i_s` \[A] (≥ 0).
    pub fn secant_factor(&self, i_s: f64) -> f64 {
        1.0 / (1.0 + self.xk(i_s))
    }

    /// `(dψ/di)/L0` at the saturating current `i_s` \[A] (≥ 0).
    pub fn incremental_factor(&self, i_s: f64) -> f64 {
        let xk = self.xk(i_s);
        (1.0 + (1.0 - self.exponent) * xk) / ((1.0 + xk) * (1.0 + xk))
    }
}

/// Which current saturates an axis.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Saturates {
    /// Only a positive current (the d axis: a current adding to the magnet's flux).
    Positive,
    /// The current's magnitude (the q axis).
    Magnitude,
}

impl Saturates {
    /// The saturating current `i_s ≥ 0` of the axis current `i` \[A].
    pub fn current(self, i: f64) -> f64 {
        match self {
            Self::Positive => i.max(0.0),
            Self::Magnitude => i.abs(),
        }
    }
}

/// One axis' inductance: unsaturated `l0_h`, and how it saturates.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisInductance {
    /// Unsaturated inductance `L0` \[H].
    pub l0_h: f64,
    /// Saturation (`None`: `L = L0` at every current).
    pub saturation: Option<Saturation>,
    /// Which current saturates the axis.
    pub saturates: Saturates,
}

impl AxisInductance {
    /// Secant inductance `L(i) = ψ_i/i` \[H] at the axis current `i` \[A].
    pub fn secant_h(&self, i: f64) -> f64 {
        match self.saturation {
            None => self.l0_h,
            Some(s) => self.l0_h * s.secant_factor(self.saturates.current(i)),
        }
    }

    /// Incremental inductance `dψ/di` \[H] at the axis current `i` \[A].
    pub fn incremental_h(&self, i: f64) -> f64 {
        match self.saturation {
            None => self.l0_h,
            Some(s) => self.l0_h * s.incremental_factor(self.saturates.current(i)),
        }
    }

    /// The flux the current links, `L(i)·i` \[Wb] (without the magnet's).
    pub fn flux_wb(&self, i: f64) -> f64 {
        self.secant_h(i) * i
    }

    /// Magnetic energy `∫₀ⁱ i' dψ(i')` \[J] per unit `c` at the axis current `i` \[A]:
    /// `L0 i²/2` unsaturated; with saturation Simpson's rule on `i' dψ/di'` over 512
    /// intervals (a diagnostic for the power balance, not on the integration path).
    pub fn energy_j(&self, i: f64) -> f64 {
        if self.saturation.is_none() {
            return 0.5 * self.l0_h * i * i;
        }
        const N: usize = 512;
        let h = i / N as f64;
        let f = |u: f64| u * self.incremental_h(u);
        let mut sum = f(0.0) + f(i);
        for k in 1..N {
            let w = if k % 2 == 1 { 4.0 } else { 2.0 };
            sum += w * f(k as f64 * h);
        }
        sum * h / 3.0
    }
}
