//! Unit conversions at the user's edge (rpm, degrees); inside the core speeds are rad/s and
//! angles rad.

use core::f32::consts::PI;

/// rad/s per rpm.
pub const RAD_S_PER_RPM: f32 = PI / 30.0;
/// rpm per rad/s (a multiplication on the step's path; a VDIV costs 14 cycles on the M4F).
pub const RPM_PER_RAD_S: f32 = 30.0 / PI;
/// rad per degree.
pub const RAD_PER_DEG: f32 = PI / 180.0;
/// Degrees per rad.
pub const DEG_PER_RAD: f32 = 180.0 / PI;

/// Copper's temperature coefficient of resistance at 20 °C \[1/K]: `1/(234.5 + 20)`, the
/// inferred-zero temperature of annealed copper, −234.5 °C (IEC 60028).
pub const ALPHA_CU_PER_K: f32 = 1.0 / (234.5 + 20.0);

/// The winding's temperature rise \[K] that turns its resistance `r_ref_ohm` (the
/// configured one, measured or read at the temperature the user configured it at) into
/// `r_ohm` (the drive's, measured at each start and tracked while running, `adaptation.rs`):
/// `(R/R_ref − 1)/α_Cu`, linear in the copper's resistance. NaN for a non-positive `r_ref_ohm`.
pub fn winding_rise_k(r_ohm: f32, r_ref_ohm: f32) -> f32 {
    if r_ref_ohm > 0.0 {
        (r_ohm / r_ref_ohm - 1.0) / ALPHA_CU_PER_K
    } else {
        f32::NAN
    }
}
