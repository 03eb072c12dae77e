//! Reference frames and the transforms between them.
//!
//! Convention (both papers): the αβ model is the amplitude-invariant Clarke transform of the
//! phase quantities, and the rotor (dq) frame is rotated by the *electrical* angle `theta_e`
//! (Ortega Remark 1: `x_dq = e^{-Jθ} x_αβ`; Horng & Chin step 6: `i_a = i_d cos Nθ − i_q sin Nθ`).
//! A positive `q` current produces positive torque.

/// Three phase quantities (currents in A or voltages in V).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Abc {
    /// Phase a.
    pub a: f32,
    /// Phase b.
    pub b: f32,
    /// Phase c.
    pub c: f32,
}

/// Stationary-frame quantities (A or V).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AlphaBeta {
    /// α component, aligned with phase a.
    pub alpha: f32,
    /// β component, 90° ahead of α.
    pub beta: f32,
}

/// Rotor-frame quantities (A or V), d aligned with the magnet flux.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Dq {
    /// Direct axis, along the magnet flux.
    pub d: f32,
    /// Quadrature axis, 90° electrical ahead of d; produces torque.
    pub q: f32,
}

/// `sin` and `cos` of one angle, computed once and shared by Park and inverse Park.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SinCos {
    /// `sin θ`.
    pub sin: f32,
    /// `cos θ`.
    pub cos: f32,
}

impl SinCos {
    /// `sin`/`cos` of θ = 0.
    pub const ZERO: Self = Self { sin: 0.0, cos: 1.0 };

    /// `sin`/`cos` of `theta` (rad) with the core's f32 polynomial (see [`crate::math::sin_cos`]).
    pub fn of(theta: f32) -> Self {
        let (sin, cos) = crate::math::sin_cos(theta);
        Self { sin, cos }
    }

    /// `sin`/`cos` of `θ + delta` from these, the `sin`/`cos` of some θ (rad): the rotation by
    /// `delta` (see [`crate::math::advance`]).
    #[inline]
    pub fn advanced(self, delta: f32) -> Self {
        let (sin, cos) = crate::math::advance((self.sin, self.cos), delta);
        Self { sin, cos }
    }

    /// `sin`/`cos` of a small angle `delta` (rad), see [`crate::math::sin_cos_small`].
    #[inline]
    pub fn of_small(delta: f32) -> Self {
        let (sin, cos) = crate::math::sin_cos_small(delta);
        Self { sin, cos }
    }

    /// These scaled back to unit length by one Newton step of `1/√(sin² + cos²)` from 1: a
    /// length `1 + ε` becomes `1 + O(ε²)` (for pairs turned by a few rotations, |ε| ~ 1e-7).
    #[inline(always)]
    pub fn renormalized(self) -> Self {
        let k = 1.5 - 0.5 * (self.sin * self.sin + self.cos * self.cos);
        Self {
            sin: self.sin * k,
            cos: self.cos * k,
        }
    }

    /// `sin`/`cos` of `θ + δ` from these (of θ) and `by` (of δ): the rotation by δ.
    #[inline(always)]
    pub fn rotated(self, by: SinCos) -> Self {
        let (sin, cos) = crate::math::rotate((self.sin, self.cos), (by.sin, by.cos));
        Self { sin, cos }
    }
}

const SQRT3_OVER_2: f32 = 0.866_025_4;

impl AlphaBeta {
    /// A stationary-frame vector.
    pub const fn new(alpha: f32, beta: f32) -> Self {
        Self { alpha, beta }
    }

    /// Euclidean magnitude `|x_αβ|` (amplitude of the phase quantity).
    pub fn magnitude(self) -> f32 {
        crate::math::sqrt(self.alpha * self.alpha + self.beta * self.beta)
    }

    /// Park transform `x_dq = e^{-Jθ} x_αβ` (Ortega Remark 1).
    pub fn to_dq(self, sc: SinCos) -> Dq {
        Dq {
            d: sc.cos * self.alpha + sc.sin * self.beta,
            q: -sc.sin * self.alpha + sc.cos * self.beta,
        }
    }

    /// Inverse Clarke: phase quantities of a balanced (zero-sequence free) set.
    pub fn to_abc(self) -> Abc {
        let a = self.alpha;
        let b = -0.5 * self.alpha + SQRT3_OVER_2 * self.beta;
        Abc { a, b, c: -a - b }
    }
}

impl Dq {
    /// A rotor-frame vector.
    pub const fn new(d: f32, q: f32) -> Self {
        Self { d, q }
    }

    /// Inverse Park `x_αβ = e^{Jθ} x_dq` (Ortega Sec V ii).
    pub fn to_alpha_beta(self, sc: SinCos) -> AlphaBeta {
        AlphaBeta {
            alpha: sc.cos * self.d - sc.sin * self.q,
            beta: sc.sin * self.d + sc.cos * self.q,
        }
    }

    /// Euclidean magnitude `|x_dq|`, equal to `|x_αβ|`.
    pub fn magnitude(self) -> f32 {
        crate::math::sqrt(self.d * self.d + self.q * self.q)
    }
}

impl Abc {
    /// Three phase values.
    pub const fn new(a: f32, b: f32, c: f32) -> Self {
        Self { a, b, c }
    }

    /// Amplitude-invariant Clarke transform; the zero-sequence part `(a+b+c)/3` is discarded.
    /// `α = (2a − b − c)/3`, `β = (b − c)/√3`.
    pub fn to_alpha_beta(self) -> AlphaBeta {
        AlphaBeta {
            alpha: (2.0 * self.a - self.b - self.c) * (1.0 / 3.0),
            beta: (self.b - self.c) * crate::math::INV_SQRT3,
        }
    }

    /// True when every phase value is finite.
    pub fn is_finite(self) -> bool {
        self.a.is_finite() && self.b.is_finite() && self.c.is_finite()
    }
}
