//! Closed-form bounds on the sliding gain `K_s` (Horng & Chin Secs 3.1, 4).
//!
//! The discrete-time bound `(K_s,max)_T` needs eigenvalues of the 5×5 linearised error
//! dynamics (46)-(50); it is computed on the host (`pmsm-sim bounds`).

use crate::motor::MotorParams;

/// Lower bound `K_s,min` of eq (28) [A/s]: the largest of
/// `|KN/L (ω̂ sin θ̂_e − ω sin θ_e)|` and `|KN/L (ω̂ cos θ̂_e − ω cos θ_e)|`.
/// `kn_over_l` = K·N/L [V·s/(rad·H)], speeds mechanical [rad/s], angles electrical [rad].
pub fn ks_min(kn_over_l: f32, omega_hat: f32, theta_e_hat: f32, omega: f32, theta_e: f32) -> f32 {
    let (sh, ch) = crate::math::sin_cos(theta_e_hat);
    let (s, c) = crate::math::sin_cos(theta_e);
    let a = kn_over_l * (omega_hat * sh - omega * s);
    let b = kn_over_l * (omega_hat * ch - omega * c);
    a.abs().max(b.abs())
}

/// Upper bound `(K_s,max)_E2 = (√2·K·N·|ω| − R·ε)/L` [A/s] above which the second, always
/// unstable, equilibrium (44)-(45) exists (Sec 4 step 4). `omega_m` mechanical [rad/s],
/// `epsilon_a` the boundary layer [A]. Negative when no `K_s > 0` avoids it.
pub fn ks_max_e2(motor: &MotorParams, omega_m: f32, epsilon_a: f32) -> f32 {
    let kn = motor.flux_wb * motor.n();
    (core::f32::consts::SQRT_2 * kn * omega_m.abs() - motor.r_ohm * epsilon_a) / motor.l_h
}
