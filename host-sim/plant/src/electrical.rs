//! The electrical part: the stator windings in the stationary frame, the back-EMF and the
//! electromagnetic torque, θ mechanical.
//!
//! A non-salient, unsaturated machine (`L_d = L_q = L`, no saturation: [`Pmsm::is_round`])
//! is the papers' model, Horng & Chin eqs (16)-(17) (Ortega et al. (1)) and the torque of
//! Ortega (2), evaluated as they print it. Any other machine is the standard dq model of
//! the salient PMSM in the rotor frame (Krause, Wasynczuk, Sudhoff, Pekarek, *Analysis of
//! Electric Machinery and Drive Systems*, 3rd ed., 2013, ch. 15), with each axis' flux
//! `ψ_d = ψ_f + L_d(i_d)·i_d`, `ψ_q = L_q(i_q)·i_q` ([`crate::inductance`]):
//! ```text
//! v_d = R i_d + L_dd(i_d) di_d/dt − ω_e ψ_q        L_dd = dψ_d/di_d (incremental)
//! v_q = R i_q + L_qq(i_q) di_q/dt + ω_e ψ_d        L_qq = dψ_q/di_q
//! τ   = c N (ψ_d i_q − ψ_q i_d) = c N (ψ_f + (L_d(i_d) − L_q(i_q)) i_d) i_q
//! ```
//! integrated in the stationary frame (`i_α = i_d cos Nθ − i_q sin Nθ`, so
//! `di_α/dt = cos Nθ di_d/dt − sin Nθ di_q/dt − ω_e i_β`, `di_β/dt = sin Nθ di_d/dt +
//! cos Nθ di_q/dt + ω_e i_α`). With `L_d = L_q` and no saturation the two forms are the same
//! equations; the first is kept for that case so the papers' runs stay the same to the bit.

use crate::inductance::AxisInductance;
use num_traits::Float;

/// The windings' parameters (f64, SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pmsm {
    /// Pole pairs N.
    pub n: f64,
    /// Resistance \[Ω].
    pub r: f64,
    /// d-axis inductance (along the magnet).
    pub l_d: AxisInductance,
    /// q-axis inductance.
    pub l_q: AxisInductance,
    /// Flux linkage of the magnet ψ_f \[Wb].
    pub flux: f64,
    /// `c` of the torque `c N (ψ_d i_q − ψ_q i_d)` (`c ψN i_q` non-salient) and of the
    /// power `c v·i`: 3/2 for a three-phase machine seen through the amplitude-invariant
    /// transform, 1 for the papers' model (its αβ model is the machine);
    /// `pmsm_sensorless::motor::TorqueConvention`.
    pub c: f64,
}

/// `(sin Nθ, cos Nθ)`.
pub type SinCos = (f64, f64);

impl Pmsm {
    /// `L_d = L_q` and neither saturates: the papers' non-salient model.
    pub fn is_round(&self) -> bool {
        self.l_d.saturation.is_none()
            && self.l_q.saturation.is_none()
            && self.l_d.l0_h == self.l_q.l0_h
    }

    /// `(sin Nθ, cos Nθ)` and the magnet's back-EMF term `e = ψ_f Nω (sin Nθ, −cos Nθ)` of
    /// eqs (16)-(17) \[V] at rotor angle `theta_m` \[rad] and speed `omega_m` \[rad/s]
    /// (mechanical): the stator voltage is `−e` at zero current, salient or not.
    pub fn back_emf(&self, theta_m: f64, omega_m: f64) -> (SinCos, (f64, f64)) {
        let (s, c) = Float::sin_cos(self.n * theta_m);
        let kn = self.flux * self.n;
        ((s, c), (kn * omega_m * s, -kn * omega_m * c))
    }

    /// `di_αβ/dt` \[A/s] for the currents `i` and the stator voltage `v` \[V] at the angle
    /// `sc` and speed `omega_m` \[rad/s, mechanical], `e` the back-EMF term of
    /// [`Pmsm::back_emf`] there: eqs (16)-(17), or the dq model (module doc).
    pub fn di_dt(
        &self,
        i: (f64, f64),
        sc: SinCos,
        omega_m: f64,
        e: (f64, f64),
        v: (f64, f64),
    ) -> (f64, f64) {
        if self.is_round() {
            let l = self.l_d.l0_h;
            return (
                (-self.r * i.0 + e.0 + v.0) / l, // (16)
                (-self.r * i.1 + e.1 + v.1) / l, // (17)
            );
        }
        let (s, c) = sc;
        let omega_e = self.n * omega_m;
        let (i_d, i_q) = to_dq(i, sc);
        let (v_d, v_q) = to_dq(v, sc);
        let (psi_d, psi_q) = self.flux_dq(i_d, i_q);
        let di_d = (v_d - self.r * i_d + omega_e * psi_q) / self.l_d.incremental_h(i_d);
        let di_q = (v_q - self.r * i_q - omega_e * psi_d) / self.l_q.incremental_h(i_q);
        (
            c * di_d - s * di_q - omega_e * i.1,
            s * di_d + c * di_q + omega_e * i.0,
        )
    }

    /// The stator flux `(ψ_d, ψ_q)` \[Wb] at the currents `(i_d, i_q)` \[A].
    pub fn flux_dq(&self, i_d: f64, i_q: f64) -> (f64, f64) {
        (self.flux + self.l_d.flux_wb(i_d), self.l_q.flux_wb(i_q))
    }

    /// Electromagnetic torque \[N·m] at the currents `i` and the angle `sc` (from
    /// [`Pmsm::back_emf`]): `−c ψN (i_α sin Nθ − i_β cos Nθ)` (the first term of eq (19)
    /// times J, c = 1 in the papers) for a round machine, else `c N (ψ_d i_q − ψ_q i_d)`.
    pub fn torque(&self, i: (f64, f64), sc: SinCos) -> f64 {
        if self.is_round() {
            let kn = self.flux * self.n;
            return -self.c * kn * (i.0 * sc.0 - i.1 * sc.1);
        }
        let (i_d, i_q) = to_dq(i, sc);
        self.torque_dq(i_d, i_q)
    }

    /// Electromagnetic torque `c N (ψ_d i_q − ψ_q i_d)` \[N·m] at the currents `(i_d, i_q)`
    /// \[A]: `c N (ψ_f + (L_d(i_d) − L_q(i_q)) i_d) i_q`, the magnet's torque and the
    /// reluctance torque.
    pub fn torque_dq(&self, i_d: f64, i_q: f64) -> f64 {
        let (psi_d, psi_q) = self.flux_dq(i_d, i_q);
        self.c * self.n * (psi_d * i_q - psi_q * i_d)
    }

    /// Magnetic energy in the windings `c (∫ i_d dψ_d + ∫ i_q dψ_q)` \[J] at the currents
    /// `(i_d, i_q)` \[A] (`c L |i|²/2` for a round machine).
    pub fn magnetic_energy(&self, i_d: f64, i_q: f64) -> f64 {
        self.c * (self.l_d.energy_j(i_d) + self.l_q.energy_j(i_q))
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

/// `x_αβ` in the rotor frame at the angle `sc`: `(x_d, x_q)`.
pub fn to_dq(x: (f64, f64), (s, c): SinCos) -> (f64, f64) {
    (c * x.0 + s * x.1, -s * x.0 + c * x.1)
}
