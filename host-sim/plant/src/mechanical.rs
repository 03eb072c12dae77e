//! The mechanical part: the rotor with its inertia and viscous friction, driven by the
//! electromagnetic torque against the load torque, Horng & Chin eqs (18)-(19); a blocked
//! shaft holds θ and ω.

/// Load torque \[N·m] as a function of time from the start of the period \[s] and of speed
/// [rad/s, mechanical]; positive opposes positive rotation (τ_L of eq (19)).
pub trait Load: Fn(f64, f64) -> f64 {}
impl<F: Fn(f64, f64) -> f64> Load for F {}

/// The rotor (f64, SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rotor {
    /// Inertia \[kg·m²].
    pub j: f64,
    /// Viscous friction \[N·m·s/rad].
    pub b: f64,
    /// The shaft is blocked: θ and ω stay as they are.
    pub blocked: bool,
}

impl Rotor {
    /// `(dθ/dt, dω/dt)` at speed `omega_m` \[rad/s] under the electromagnetic torque
    /// `torque_nm` and the load torque `tau_l` \[N·m]: eqs (18)-(19).
    pub fn derivative(&self, omega_m: f64, torque_nm: f64, tau_l: f64) -> (f64, f64) {
        if self.blocked {
            return (0.0, 0.0);
        }
        (omega_m, (torque_nm - self.b * omega_m - tau_l) / self.j) // (18), (19)
    }

    /// Friction loss `B ω²` \[W].
    pub fn friction_loss(&self, omega_m: f64) -> f64 {
        self.b * omega_m * omega_m
    }
}
