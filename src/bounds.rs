//! The closed-form bounds on the sliding gain `K_s` (Horng & Chin Secs 3.1, 4), in one place:
//! the drive checks its `K_s` against them, `pmsm-sim bounds` reports them, and the host's
//! eigenvalue analysis of eqs (46)-(50) (`pmsm-sim bounds`, `host-sim/src/bounds.rs`) checks
//! the discrete-time one. `L` is `L_q`: the observer's own inductance, which on a salient
//! motor runs the paper's equations on the active flux model (`crate::observer::sliding`);
//! on a non-salient one `L_q = L`, the paper's.

use crate::math::sin_cos;
use crate::motor::MotorParams;

/// Lower bound `K_s,min` of eq (28) \[A/s]: the largest of
/// `|KN/L (ω̂ sin θ̂_e − ω sin θ_e)|` and `|KN/L (ω̂ cos θ̂_e − ω cos θ_e)|`.
/// `kn_over_l` = K·N/L \[V·s/(rad·H)], speeds mechanical \[rad/s], angles electrical \[rad].
pub fn ks_min(kn_over_l: f32, omega_hat: f32, theta_e_hat: f32, omega: f32, theta_e: f32) -> f32 {
    let (sh, ch) = sin_cos(theta_e_hat);
    let (s, c) = sin_cos(theta_e);
    let a = kn_over_l * (omega_hat * sh - omega * s);
    let b = kn_over_l * (omega_hat * ch - omega * c);
    a.abs().max(b.abs())
}

/// Upper bound `(K_s,max)_E2 = (√2·K·N·|ω| − R·ε)/L_q` \[A/s] above which the second, always
/// unstable, equilibrium (44)-(45) exists (Sec 4 step 4). `omega_m` mechanical \[rad/s],
/// `epsilon_a` the boundary layer \[A]. Negative when no `K_s > 0` avoids it.
pub fn ks_max_e2(motor: &MotorParams, omega_m: f32, epsilon_a: f32) -> f32 {
    let kn = motor.flux_wb * motor.n();
    (core::f32::consts::SQRT_2 * kn * omega_m.abs() - motor.r_ohm * epsilon_a) / motor.l_q_h()
}

/// Discrete-time upper bound `(K_s,max)_T = ε (2/T − R/L_q)` \[A/s] of the forward-Euler
/// observer at `rate_hz` (Sec 4, delta transform: an eigenvalue `p` is stable when
/// `(T/2)|p|² + Re p < 0`). Inside the boundary layer the current errors `S_a`, `S_b` have the
/// real eigenvalue `−(R/L + K_s/ε)`, which leaves that circle at `K_s = ε(2/T − R/L)`; this is
/// the eigenvalue that binds for the papers' tunings (the full 5×5 analysis of eqs (46)-(50)
/// on the host agrees to its scan tolerance, `tests/sliding.rs`).
pub fn ks_max_t(motor: &MotorParams, rate_hz: f32, epsilon_a: f32) -> f32 {
    epsilon_a * (2.0 * rate_hz - motor.r_ohm / motor.l_q_h())
}
