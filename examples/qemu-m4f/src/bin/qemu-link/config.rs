//! The configuration the link firmware runs with: the record the store keeps (the link's
//! serialised settings) turned into the drive's configuration, or refused.
//!
//! TODO(lead, issue #28): the record is `pmsm_link::Settings` serialised with postcard;
//! [`drive_config`] is to decode it (`postcard::from_bytes`), validate it
//! (`Settings::validate`: the core's `Motor::validate` and `DriveConfig` checks) and build the
//! `DriveConfig` from it, and [`CONFIG_VERSION`] is to be the link's settings format version.
//! Until then any non-empty record of [`CONFIG_VERSION`] gives the built-in Sinano bench
//! configuration, so that the store, the refusal and the persistence are tested end to end.

use pmsm_sensorless::drive::DriveConfig;
use pmsm_sensorless::motor::HORNG_SINANO;

/// The format version of the stored record (the store's header carries it; a record of
/// another version is refused by `Store::load` with `StoreError::FormatVersion`).
pub const CONFIG_VERSION: u16 = 1;

/// Why a stored record does not give a configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum ConfigError {
    /// The record is empty.
    Empty,
}

/// The drive's configuration from the stored `record` (module doc: a placeholder until the
/// link's settings are decoded here).
pub fn drive_config(record: &[u8]) -> Result<DriveConfig, ConfigError> {
    if record.is_empty() {
        return Err(ConfigError::Empty);
    }
    let mut cfg = DriveConfig::new(&HORNG_SINANO);
    // The bench's inverter is ideal: no dead time to compensate (as in `qemu-m4f`).
    cfg.power_stage.dead_time_s = 0.0;
    Ok(cfg)
}
