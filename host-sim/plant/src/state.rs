//! The plant's state: the stator currents and the rotor, and the integrals the simulator
//! reads (the energies of the power balance, ∫ i_q dt, the DC-link charge).

use crate::params::PlantParams;
use num_traits::Float;

/// Plant state (and energy integrals, all in J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlantState {
    /// Stator current α \[A].
    pub i_alpha: f64,
    /// Stator current β \[A].
    pub i_beta: f64,
    /// Rotor angle, mechanical, not wrapped \[rad].
    pub theta_m: f64,
    /// Rotor speed, mechanical \[rad/s].
    pub omega_m: f64,
    /// ∫ v·i dt: electrical energy in.
    pub e_in: f64,
    /// ∫ R|i|² dt: copper loss.
    pub e_copper: f64,
    /// ∫ B ω² dt: friction loss.
    pub e_friction: f64,
    /// ∫ τ_L ω dt: energy delivered to the load.
    pub e_load: f64,
    /// ∫ i_q dt \[A·s], for exact time averages of the torque current.
    pub iq_dt: f64,
    /// ∫ i_dc dt: the charge drawn from the DC link \[C] (negative: fed back into it).
    pub q_dc: f64,
}

/// Length of the state as the integrator sees it.
pub(crate) const DIM: usize = 10;

/// Index of ω in the integrator's array.
pub(crate) const OMEGA: usize = 3;

/// Index of the DC-link charge in the integrator's array.
pub(crate) const Q_DC: usize = 9;

impl PlantState {
    pub(crate) fn to_array(self) -> [f64; DIM] {
        [
            self.i_alpha,
            self.i_beta,
            self.theta_m,
            self.omega_m,
            self.e_in,
            self.e_copper,
            self.e_friction,
            self.e_load,
            self.iq_dt,
            self.q_dc,
        ]
    }

    pub(crate) fn from_array(x: [f64; DIM]) -> Self {
        Self {
            i_alpha: x[0],
            i_beta: x[1],
            theta_m: x[2],
            omega_m: x[3],
            e_in: x[4],
            e_copper: x[5],
            e_friction: x[6],
            e_load: x[7],
            iq_dt: x[8],
            q_dc: x[9],
        }
    }

    /// Electrical angle Nθ, not wrapped \[rad].
    pub fn theta_e(&self, p: &PlantParams) -> f64 {
        p.n * self.theta_m
    }

    /// Currents in the true rotor frame `(i_d, i_q)` \[A].
    pub fn i_dq(&self, p: &PlantParams) -> (f64, f64) {
        let (s, c) = Float::sin_cos(self.theta_e(p));
        (
            c * self.i_alpha + s * self.i_beta,
            -s * self.i_alpha + c * self.i_beta,
        )
    }

    /// Electromagnetic torque \[N·m]: `c N (ψ_d i_q − ψ_q i_d)`, `c ψN i_q` for a non-salient
    /// machine (Ortega (2) with c = 1) ([`crate::electrical::Pmsm::torque_dq`]).
    pub fn torque(&self, p: &PlantParams) -> f64 {
        let (i_d, i_q) = self.i_dq(p);
        p.electrical().torque_dq(i_d, i_q)
    }

    /// Energy stored in the inductances (`c ∫ i dψ` per axis, `c L |i|²/2` non-salient)
    /// and the rotor \[J].
    pub fn stored_energy(&self, p: &PlantParams) -> f64 {
        let (i_d, i_q) = self.i_dq(p);
        p.electrical().magnetic_energy(i_d, i_q) + 0.5 * p.j * self.omega_m * self.omega_m
    }
}
