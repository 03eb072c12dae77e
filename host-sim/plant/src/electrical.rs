//! The electrical part: the stator windings of a non-salient PMSM in the stationary frame,
//! Horng & Chin eqs (16)-(17) (Ortega et al. (1)), the back-EMF and the electromagnetic
//! torque (Ortega (2)), θ mechanical.

use num_traits::Float;

/// The windings' parameters (f64, SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pmsm {
    /// Pole pairs N.
    pub n: f64,
    /// Resistance \[Ω].
    pub r: f64,
    /// Inductance \[H].
    pub l: f64,
    /// Flux linkage ψ \[Wb].
    pub flux: f64,
    /// `c` of the torque `c ψN i_q` and of the power `c v·i`: 3/2 for a three-phase machine
    /// seen through the amplitude-invariant transform, 1 for the papers' model (its αβ
    /// model is the machine); `pmsm_sensorless::motor::TorqueConvention`.
    pub c: f64,
}

/// `(sin Nθ, cos Nθ)`.
pub type SinCos = (f64, f64);

impl Pmsm {
    /// `(sin Nθ, cos Nθ)` and the back-EMF term `e = ψNω (sin Nθ, −cos Nθ)` of eqs (16)-(17)
    /// \[V] at rotor angle `theta_m` \[rad] and speed `omega_m` \[rad/s] (mechanical).
    pub fn back_emf(&self, theta_m: f64, omega_m: f64) -> (SinCos, (f64, f64)) {
        let (s, c) = Float::sin_cos(self.n * theta_m);
        let kn = self.flux * self.n;
        ((s, c), (kn * omega_m * s, -kn * omega_m * c))
    }

    /// `di_αβ/dt` \[A/s] for the currents `i`, the back-EMF term `e` and the stator voltage
    /// `v` \[V]: eqs (16)-(17).
    pub fn di_dt(&self, i: (f64, f64), e: (f64, f64), v: (f64, f64)) -> (f64, f64) {
        (
            (-self.r * i.0 + e.0 + v.0) / self.l, // (16)
            (-self.r * i.1 + e.1 + v.1) / self.l, // (17)
        )
    }

    /// Electromagnetic torque `−c ψN (i_α sin Nθ − i_β cos Nθ)` \[N·m] (the first term of eq
    /// (19) times J, c = 1 in the papers), `sc` from [`Pmsm::back_emf`].
    pub fn torque(&self, i: (f64, f64), sc: SinCos) -> f64 {
        let kn = self.flux * self.n;
        -self.c * kn * (i.0 * sc.0 - i.1 * sc.1)
    }

    /// Power into the windings `c v·i` \[W].
    pub fn power(&self, v: (f64, f64), i: (f64, f64)) -> f64 {
        self.c * (v.0 * i.0 + v.1 * i.1)
    }

    /// Copper loss `c R |i|²` \[W].
    pub fn copper_loss(&self, i: (f64, f64)) -> f64 {
        self.c * self.r * (i.0 * i.0 + i.1 * i.1)
    }
}
