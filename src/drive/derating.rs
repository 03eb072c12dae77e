//! The torque-speed envelope the bus allows: the highest speed at which the drive makes a
//! torque within its current limit and voltage limit, field weakening included. A motor whose
//! rated torque does not fit at rated speed is derated: [`DriveConfig::torque_speed_limit_rpm`]
//! gives the speed where it still fits (`pmsm-sim gains` names it), and the telemetry's
//! `derated` says when the drive is there (the voltage limit reached with the field
//! weakening at its end: it holds less than the command).
//!
//! Model: the steady-state dq voltages of the non-salient PMSM (Ortega et al. eq (3)),
//! `v_d = R i_d − ω_e L i_q`, `v_q = R i_q + ω_e (L i_d + ψ_f)`, at the `i_q` of the torque and
//! the `i_d ∈ [−√(i_max² − i_q²), 0]` that minimises `|v|` (the vertex of `|v|²` in `i_d`,
//! `i_d* = −ω_e² L ψ_f/(R² + ω_e² L²)`, clipped), against the field weakening's voltage
//! target `margin · v_max`; the speed by bisection (`|v|min` grows with `ω_e` above the speed
//! where the torque fits). The standard construction of the field-weakening envelope
//! (Morimoto, Takeda, Hirasa, Taniguchi, "Expansion of operating limits for permanent magnet
//! motor by current vector control considering inverter capacity", IEEE Trans. Ind. Appl.
//! 26(5), 1990).

use super::DriveConfig;
use crate::motor::MotorParams;
use crate::units::RAD_S_PER_RPM;

/// Bisection steps: the speed to 2⁻⁴⁰ of the search range.
const STEPS: u32 = 40;

/// The smallest `|v|` \[V] that makes `i_q` \[A] at `omega_e` [rad/s, electrical] with
/// `|i_d| ≤ i_d_max` \[A] (module doc).
fn voltage_min(m: &MotorParams, i_q: f32, i_d_max: f32, omega_e: f32) -> f32 {
    let (r, wl) = (m.r_ohm, omega_e * m.l_h);
    let i_d = (-omega_e * wl * m.flux_wb / (r * r + wl * wl)).max(-i_d_max);
    let v_d = r * i_d - wl * i_q;
    let v_q = r * i_q + wl * i_d + omega_e * m.flux_wb;
    crate::math::sqrt_call(v_d * v_d + v_q * v_q)
}

/// The highest mechanical speed \[rad/s] at which `i_q` \[A] fits within `i_max` \[A] and the
/// voltage `v` \[V] (module doc); 0 when it does not fit at standstill.
pub(super) fn speed_limit_rad_s(m: &MotorParams, i_q: f32, i_max: f32, v: f32) -> f32 {
    let i_q = i_q.abs();
    if i_q > i_max || voltage_min(m, i_q, 0.0, 0.0) > v {
        return 0.0;
    }
    let i_d_max = crate::math::sqrt_call(i_max * i_max - i_q * i_q);
    // Above it even i_d = −i_max leaves more than v: the back-EMF of ψ_f − L i_max alone,
    // or, where L i_max ≥ ψ_f, the reactance of i_max alone.
    let flux_left = (m.flux_wb - m.l_h * i_d_max)
        .max(m.l_h * i_q)
        .max(1e-9 * m.flux_wb);
    let (mut lo, mut hi) = (0.0f32, 2.0 * v / flux_left);
    for _ in 0..STEPS {
        let mid = 0.5 * (lo + hi);
        if voltage_min(m, i_q, i_d_max, mid) <= v {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo / m.n()
}

impl DriveConfig {
    /// The highest speed \[rpm] at which the drive makes `torque_nm` \[N·m] on `bus_v` \[V]:
    /// within its current limit, the field weakening's voltage target (the SVPWM's
    /// `bus_v/√3` less the dead time's, times its margin), field weakening included (module
    /// doc). The motor is the drive's model.
    pub fn torque_speed_limit_rpm(&self, torque_nm: f32, bus_v: f32) -> f32 {
        let i_q = torque_nm / self.motor.torque_constant();
        let v = FIELD_WEAKENING_MARGIN * bus_v * self.dead_time_config().v_max_per_bus();
        speed_limit_rad_s(&self.motor, i_q, self.limits.i_max_a, v) / RAD_S_PER_RPM
    }
}

/// The fraction of the current loop's voltage limit the field weakening holds the voltage at.
pub(super) const FIELD_WEAKENING_MARGIN: f32 = 0.95;
