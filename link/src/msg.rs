//! The messages ([`HostMsg`] from the host, [`DeviceMsg`] from the device) and their errors
//! ([`LinkError`]). Protocol version [`PROTOCOL_VERSION`], checked by [`Request::Hello`].
//!
//! Versioning: postcard encodes an enum's variant by its index, so a later version adds
//! variants only at the end of an enum and fields only in new variants; a device that does
//! not know a message answers [`LinkError::UnknownMessage`] and changes nothing. A change that
//! breaks the layout of an existing message takes a new [`PROTOCOL_VERSION`].
//!
//! The core's drive types mirrored for the wire ([`crate::wire`]): `Mode`, `Fault`, `Reason`,
//! `Role`, `Transition`, `Telemetry`, `Identified`.

use crate::keys::Key;
use crate::settings::{MotorSettings, Settings};
use crate::wire::{Fault, Identified, Mode, Telemetry, Transition};
use heapless::String;
use serde::{Deserialize, Serialize};

/// The protocol's version: a host and a device talk only if theirs are equal. 2: the events
/// may carry `Reason::ResistanceRefused` and `Fault::OpenWinding` (appended to their enums; a
/// host of version 1 could not read such an event, so it is refused at the hello instead).
pub const PROTOCOL_VERSION: u16 = 2;

/// A field's name in an error (the longest setting's name is 33 bytes).
pub type FieldName = String<40>;

/// An explanation in an error (a range and where its bounds come from), cut at 96 bytes.
pub type Reason = String<96>;

/// One request, with the number the host gave it (the answer carries it back).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HostMsg {
    /// The host's sequence number.
    pub seq: u16,
    /// The request.
    pub req: Request,
}

/// What the host asks.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Request {
    /// The version exchange: the host's [`PROTOCOL_VERSION`]. Answer [`Response::Hello`], or
    /// [`LinkError::VersionMismatch`].
    Hello {
        /// The host's protocol version.
        version: u16,
    },
    /// Every setting. Answer [`Response::Settings`] (or [`LinkError::NotConfigured`]).
    GetSettings,
    /// One setting. Answer [`Response::Setting`].
    Get(Key),
    /// One setting changed, validated with the others by the core. Answer [`Response::Ok`], or
    /// [`LinkError::Rejected`] / [`LinkError::BusyWhileRunning`] (nothing changed).
    Set {
        /// The setting.
        key: Key,
        /// Its new value.
        value: f32,
    },
    /// Every setting at once (validated as a whole).
    SetSettings(Settings),
    /// A new motor: its parameters and ratings, every other setting the core's defaults for
    /// it on the device's power stage (`Settings::for_motor`). Refused while running.
    SetMotor(MotorSettings),
    /// Keep the settings in the device's non-volatile store.
    Save,
    /// Enable (true) or disable the drive.
    Enable(bool),
    /// Speed command [rpm, mechanical].
    Speed(f32),
    /// Start the identification (from idle, enabled with a zero speed command on the device).
    Identify,
    /// The identification's state and result. Answer [`Response::Identify`].
    GetIdentified,
    /// The latched fault. Answer [`Response::Fault`].
    GetFault,
    /// Clear a latched fault.
    ClearFault,
    /// Stream telemetry as events at this rate \[Hz] (0 stops; at most [`MAX_STREAM_HZ`]).
    Stream(u16),
    /// One telemetry record now. Answer [`Response::Telemetry`].
    GetTelemetry,
    /// Restart the device (a system reset): answered [`Response::Ok`] first, then the device
    /// restarts as at power-up and loads its settings from its store (what was not saved is
    /// gone). Refused while the drive runs ([`LinkError::BusyWhileRunning`]).
    Restart,
}

/// The highest telemetry rate \[Hz]: a record a millisecond, the drive's task rate.
pub const MAX_STREAM_HZ: u16 = 1000;

/// What the device says.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum DeviceMsg {
    /// The answer to the request numbered `seq`.
    Response {
        /// The request's number.
        seq: u16,
        /// Its answer.
        result: Result<Response, LinkError>,
    },
    /// Something that happened (streamed, unasked).
    Event(Event),
    /// A frame that could not be read (no sequence number known): why. Nothing changed.
    FrameError(LinkError),
}

/// An answer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Response {
    /// Done.
    Ok,
    /// The device's protocol version, and whether it holds a valid configuration.
    Hello {
        /// The device's [`PROTOCOL_VERSION`].
        version: u16,
        /// A valid configuration is loaded (without one the drive refuses to run).
        configured: bool,
    },
    /// Every setting.
    Settings(Settings),
    /// One setting.
    Setting {
        /// The setting.
        key: Key,
        /// Its value.
        value: f32,
    },
    /// The identification: the drive's mode and, once done, its result.
    Identify {
        /// The drive's mode.
        mode: Mode,
        /// The result (mode `Identified`).
        result: Option<Identified>,
    },
    /// The latched fault, if any.
    Fault(Option<Fault>),
    /// A telemetry record.
    Telemetry(Telemetry),
}

/// Something the device reports unasked.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub enum Event {
    /// A streamed telemetry record.
    Telemetry(Telemetry),
    /// A mode change (or change of the driving observer).
    Transition(Transition),
    /// A fault latched (also reported as the transition into `Fault`).
    Fault(Fault),
}

/// Why a request was not done. Every error leaves the device as it was.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum LinkError {
    /// A value the core refuses: the field (the core's name), the value and what is allowed.
    Rejected {
        /// The field the core named.
        field: FieldName,
        /// The value given (or derived).
        value: f32,
        /// What the field may be.
        allowed: Range,
    },
    /// A setting that must not change while the drive runs.
    BusyWhileRunning {
        /// The setting.
        field: FieldName,
    },
    /// A message this device does not know (checksum good).
    UnknownMessage,
    /// A frame whose checksum does not match.
    BadChecksum,
    /// A frame that is no COBS encoding, or shorter than its checksum.
    Malformed,
    /// A frame longer than the device's buffer.
    TooLong,
    /// The host's protocol version is not the device's.
    VersionMismatch {
        /// The device's.
        device: u16,
        /// The host's.
        host: u16,
    },
    /// No valid configuration: the drive refuses to run (identification only).
    NotConfigured,
    /// The device cannot do it now (the identification asked outside idle, a telemetry rate
    /// out of range, ...): why.
    Refused(Reason),
    /// The non-volatile store failed.
    Storage,
}

/// The values a setting may take (the core's `param::Allowed`), as numbers: the device
/// formats no float (its flash), the host prints it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Range {
    /// Lower bound (may be −∞).
    pub min: f32,
    /// Whether `min` itself is allowed.
    pub min_included: bool,
    /// Upper bound (may be +∞).
    pub max: f32,
    /// Whether `max` itself is allowed.
    pub max_included: bool,
    /// Where a bound comes from, or what the setting takes, else empty.
    pub why: Reason,
}

impl From<&pmsm_sensorless::param::Allowed> for Range {
    fn from(a: &pmsm_sensorless::param::Allowed) -> Self {
        Self {
            min: a.min,
            min_included: a.min_included,
            max: a.max,
            max_included: a.max_included,
            why: reason(a.why),
        }
    }
}

impl Range {
    /// `[min, max]` with `why`.
    pub fn between(min: f32, max: f32, why: &str) -> Self {
        Self {
            min,
            min_included: true,
            max,
            max_included: true,
            why: reason(why),
        }
    }
}

/// A number as the core prints it (`param.rs`): plain from 0.001 to 10⁶, else in exponent
/// form.
struct Num(f32);

impl core::fmt::Display for Num {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-3..1e6).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// As the core's `Allowed` prints: `[1e-4, 1000]`, `(3.5, 14] (i_max_a..4 x it)`.
impl core::fmt::Display for Range {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        let open = if self.min_included { '[' } else { '(' };
        let close = if self.max_included { ']' } else { ')' };
        if self.min == f32::NEG_INFINITY {
            write!(f, "(-inf, ")?;
        } else {
            write!(f, "{open}{}, ", Num(self.min))?;
        }
        if self.max == f32::INFINITY {
            write!(f, "inf)")?;
        } else {
            write!(f, "{}{close}", Num(self.max))?;
        }
        if !self.why.is_empty() {
            write!(f, " ({})", self.why)?;
        }
        Ok(())
    }
}

/// `text` in a [`Reason`], cut at its capacity (on a character boundary).
pub fn reason(text: &str) -> Reason {
    cut(text)
}

/// `text` in a [`FieldName`], cut at its capacity.
pub fn field_name(text: &str) -> FieldName {
    cut(text)
}

/// `text` in a `String<N>`, cut at `N` bytes or the character boundary before (copied whole,
/// not character by character: the board image's flash).
fn cut<const N: usize>(text: &str) -> String<N> {
    // (`str::floor_char_boundary` is 20 B more in the board's image.)
    let mut end = text.len().min(N);
    while !text.is_char_boundary(end) {
        end -= 1;
    }
    let mut r = String::new();
    // Within the capacity and on a boundary (0 is one): neither fails.
    let _ = r.push_str(text.get(..end).unwrap_or_default());
    r
}

impl core::fmt::Display for LinkError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Rejected {
                field,
                value,
                allowed,
            } => write!(f, "rejected: {field} = {}: allowed {allowed}", Num(*value)),
            Self::BusyWhileRunning { field } => {
                write!(f, "{field} cannot change while the drive runs: disable it first")
            }
            Self::UnknownMessage => write!(f, "the device does not know this message"),
            Self::BadChecksum => write!(f, "a frame's checksum did not match"),
            Self::Malformed => write!(f, "a malformed frame"),
            Self::TooLong => write!(f, "a frame longer than the device's buffer"),
            Self::VersionMismatch { device, host } => write!(
                f,
                "protocol version mismatch: the device speaks version {device}, this tool {host}"
            ),
            Self::NotConfigured => write!(
                f,
                "the device holds no valid configuration: load a motor (config load-motor) or identify it"
            ),
            Self::Refused(why) => write!(f, "refused: {why}"),
            Self::Storage => write!(f, "the device's configuration store failed"),
        }
    }
}
