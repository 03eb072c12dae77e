//! The configuration the link firmware keeps: the link's settings (`pmsm_link::Settings`,
//! every setting of a drive) serialised with postcard as the store's record, decoded and
//! validated by the core at boot ([`decode`]: `Settings::validate`, i.e. `Motor::validate`
//! and the drive's construction), written by the link's save ([`encode`]); and the emulated
//! board's own power stage ([`board_defaults`]) for a motor loaded when none is in force.

use pmsm_link::Settings;
use pmsm_sensorless::drive::DriveConfig;
use pmsm_sensorless::motor::Motor;
use pmsm_sensorless::param::ParamError;
use pmsm_store::MAX_LEN;

/// The format version of the stored record: the link's settings as postcard encodes them
/// (every key's value in `Key::ALL` order). The store's header carries it; a record of
/// another version is refused by `Store::load` with `StoreError::FormatVersion`. Raise it
/// when `Key::ALL` changes.
pub const CONFIG_VERSION: u16 = 2;

/// Why a stored record does not give a configuration.
#[derive(Debug, Clone, Copy, PartialEq, defmt::Format)]
pub enum ConfigError {
    /// The record is not the settings postcard encodes (cut, or of other fields).
    Malformed,
    /// The settings decode but the core refuses one: its field.
    Rejected(&'static str),
}

/// The settings of the stored `record`, validated by the core.
pub fn decode(record: &[u8]) -> Result<Settings, ConfigError> {
    let s: Settings = postcard::from_bytes(record).map_err(|_| ConfigError::Malformed)?;
    s.validate()
        .map_err(|e: ParamError| ConfigError::Rejected(e.field))?;
    Ok(s)
}

/// `settings` as the store's record in `buf`: the bytes written.
pub fn encode<'a>(settings: &Settings, buf: &'a mut [u8; MAX_LEN]) -> Option<&'a [u8]> {
    postcard::to_slice(settings, buf).ok().map(|b| &*b)
}

/// The core's defaults for `motor` on the emulated board's power stage: the bench's ideal
/// inverter (no dead time to compensate, as in `qemu-m4f`) at the core's PWM frequency, the
/// rate chosen for the motor on it.
pub fn board_defaults(motor: &Motor) -> Settings {
    let mut c = DriveConfig::new(motor);
    c.power_stage.dead_time_s = 0.0;
    c.choose_rate();
    Settings::from(&c)
}

/// The store: the emulated flash region's two pages.
pub const STORE: pmsm_store::Store = pmsm_store::Store::new(0, 2, CONFIG_VERSION);
