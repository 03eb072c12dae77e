//! The drive this board runs, built from the library's configuration
//! ([`pmsm_b_g431b_esc1::drive_settings`]: the motor, the observers, the speed command, the
//! board's rate, PWM, dead time and largest duty).

use pmsm_b_g431b_esc1::drive_settings::{drive_config, BoardDrive, MOTOR, SPEED_CMD_RPM};

/// The drive of [`drive_config`]; a configuration the drive refuses stops the firmware here
/// with its reason in the log (the host test `drive_told_the_same` builds the same one).
pub fn build_drive() -> BoardDrive {
    let cfg = drive_config();
    let drive = match cfg.build_flux_primary() {
        Ok(d) => d,
        Err(e) => defmt::panic!(
            "drive configuration rejected: {=str} = {=f32}, allowed {=f32}..{=f32}",
            e.field,
            e.value,
            e.allowed.min,
            e.allowed.max
        ),
    };
    // The primary named in the format string (kept in the log's table, not in flash):
    // `build_flux_primary` makes it the flux observer, `Primary`.
    defmt::info!(
        "motor {=str}, primary the flux observer (FluxPll), speed command {=f32} rpm, trip {=f32} A, bus {=f32}..{=f32} V",
        MOTOR.name,
        SPEED_CMD_RPM,
        cfg.limits.i_trip_a,
        cfg.limits.bus_min_v,
        cfg.limits.bus_max_v
    );
    drive
}
