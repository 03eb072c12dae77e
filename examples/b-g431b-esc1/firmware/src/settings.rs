//! The drive this board runs, built from the library's configuration
//! ([`pmsm_b_g431b_esc1::drive_settings`]: the motor, the observers, the speed command, the
//! board's rate, PWM, dead time and largest duty).

use pmsm_b_g431b_esc1::drive_settings::{drive_config, BoardDrive, Primary, MOTOR, SPEED_CMD_RPM};

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
    defmt::info!(
        "motor {=str}, primary {=str}, speed command {=f32} rpm, trip {=f32} A, bus {=f32}..{=f32} V",
        MOTOR.name,
        core::any::type_name::<Primary>(),
        SPEED_CMD_RPM,
        cfg.limits.i_trip_a,
        cfg.limits.bus_min_v,
        cfg.limits.bus_max_v
    );
    drive
}
