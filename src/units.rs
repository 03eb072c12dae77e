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
