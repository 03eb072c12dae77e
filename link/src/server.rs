//! The device's side of the link: [`Server`] reads frames from an `embedded-io` stream,
//! answers each request through the firmware's [`Device`], and sends the events (telemetry at
//! the rate asked, transitions, faults). No heap; one frame buffer and one encoding buffer
//! of [`MAX_FRAME`] bytes; never panics on any input: a frame that cannot be read is answered
//! with a [`DeviceMsg::FrameError`] (or, for a message it does not know, with
//! [`LinkError::UnknownMessage`] under its sequence number) and changes nothing.
//!
//! Every change of a setting is validated by the core ([`Settings::validate`]) before the
//! device sees it, and refused while the drive runs for the settings that must not change
//! then ([`Key::locked_while_running`]).

use crate::frame::{self, FrameError, FrameReader, Pushed, MAX_FRAME};
use crate::keys::{Key, KeyError};
use crate::msg::{
    field_name, reason, DeviceMsg, Event, HostMsg, LinkError, Range, Request, Response,
    MAX_STREAM_HZ, PROTOCOL_VERSION,
};
use crate::settings::Settings;
use crate::wire::{Reason, Telemetry};
use embedded_io::{ReadReady, Write};
use pmsm_sensorless::drive as core_drive;
use pmsm_sensorless::motor::Motor;
use pmsm_sensorless::param::ParamError;

/// Why a [`Device`] did not do what it was asked (the server answers it as a [`LinkError`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum DeviceError {
    /// Not now, and why (the identification asked outside idle, ...).
    Refused(&'static str),
    /// The non-volatile store failed.
    Storage,
    /// No valid configuration.
    NotConfigured,
    /// A value the core refused.
    Rejected(ParamError),
}

impl From<DeviceError> for LinkError {
    fn from(e: DeviceError) -> Self {
        match e {
            DeviceError::Refused(why) => LinkError::Refused(reason(why)),
            DeviceError::Storage => LinkError::Storage,
            DeviceError::NotConfigured => LinkError::NotConfigured,
            DeviceError::Rejected(e) => rejected(&e),
        }
    }
}

/// What the firmware (or a simulated device) gives the link. Every method is called from the
/// server's context (the main loop), never from the control interrupt.
pub trait Device {
    /// The settings in force; `None` without a valid configuration (none stored, or a
    /// corrupt one): the drive then refuses to run.
    fn settings(&self) -> Option<Settings>;

    /// Puts `settings` in force (already validated by the core; while the drive runs they
    /// differ from those in force only in settings not [`Key::locked_while_running`]). Not
    /// saved until [`Device::save`].
    fn apply(&mut self, settings: &Settings) -> Result<(), DeviceError>;

    /// The settings for a new `motor` (validated): by default the core's defaults for it on
    /// the power stage and current sensing of the settings in force ([`Settings::for_motor`]).
    /// A board without settings in force gives its own stage here.
    fn defaults_for(&self, motor: &Motor) -> Settings {
        Settings::for_motor(motor, self.settings().as_ref())
    }

    /// Writes the settings in force to the non-volatile store.
    fn save(&mut self) -> Result<(), DeviceError>;

    /// The drive runs: enabled, or in any mode but idle, fault or identified.
    fn running(&self) -> bool;

    /// The enable command.
    fn enable(&mut self, on: bool) -> Result<(), DeviceError>;

    /// The speed command [rpm, mechanical] (finite, within the rated speed: checked).
    fn set_speed(&mut self, rpm: f32) -> Result<(), DeviceError>;

    /// Starts the identification (`Drive::start_identification` from idle).
    fn start_identification(&mut self) -> Result<(), DeviceError>;

    /// The identified motor, once the identification is done.
    fn identified(&self) -> Option<core_drive::Identified>;

    /// Clears a latched fault.
    fn clear_fault(&mut self) -> Result<(), DeviceError>;

    /// The drive's telemetry record now (`Drive::telemetry`).
    fn telemetry(&self) -> core_drive::Telemetry;

    /// The device's time \[ms] (wraps at 2³²).
    fn now_ms(&self) -> u32;

    /// The next mode change not yet reported, oldest first.
    fn next_transition(&mut self) -> Option<core_drive::Transition>;

    /// Restarts the device as at power-up (a system reset), after the answer to this request
    /// has been sent: a firmware notes it and resets once the server's poll has written the
    /// answer out. Called only while the drive does not run.
    fn restart(&mut self) -> Result<(), DeviceError>;
}

/// The motor an identification on `dev` starts from: the pole pairs, ratings and torque
/// convention of the settings in force, the rest the core's placeholder
/// (`drive::identify::placeholder`: the identification measures them). Refused, named, while
/// the drive runs or without settings in force (a firmware's [`Device::start_identification`]).
pub fn identification_motor(dev: &dyn Device) -> Result<Motor, DeviceError> {
    if dev.running() {
        return Err(DeviceError::Refused(
            "the identification starts from idle, disabled",
        ));
    }
    let m = dev
        .settings()
        .ok_or(DeviceError::Refused(
            "the identification needs the motor's pole pairs and ratings: load a motor",
        ))?
        .motor();
    Ok(core_drive::identify::placeholder(
        m.params.pole_pairs,
        m.ratings,
        m.params.torque,
    ))
}

/// The link's device side (module doc).
pub struct Server {
    rx: FrameReader,
    stream: Stream,
    /// A fault's transition was sent; its [`Event::Fault`] goes next.
    fault_pending: Option<crate::wire::Fault>,
}

/// Telemetry streaming.
#[derive(Clone, Copy, Debug, Default)]
struct Stream {
    /// Period \[ms]; 0 off.
    period_ms: u32,
    /// Time of the next record \[ms].
    next_ms: u32,
}

impl Default for Server {
    fn default() -> Self {
        Self::new()
    }
}

impl Server {
    /// A server with no frame begun and no telemetry streamed.
    pub const fn new() -> Self {
        Self {
            rx: FrameReader::new(),
            stream: Stream {
                period_ms: 0,
                next_ms: 0,
            },
            fault_pending: None,
        }
    }

    /// Reads what `io` has ready (without blocking), answers every complete frame, then sends
    /// the events due. Call it from the main loop.
    pub fn poll<T>(&mut self, io: &mut T, dev: &mut dyn Device) -> Result<(), T::Error>
    where
        T: embedded_io::Read + Write + ReadReady,
    {
        let mut chunk = [0u8; 64];
        while io.read_ready()? {
            let n = io.read(&mut chunk)?;
            if n == 0 {
                break;
            }
            self.receive(&chunk[..n], dev, io)?;
        }
        self.send_events(dev, io)
    }

    /// Takes `bytes` of the stream and answers every frame they complete on `out`.
    pub fn receive<W: Write>(
        &mut self,
        bytes: &[u8],
        dev: &mut dyn Device,
        out: &mut W,
    ) -> Result<(), W::Error> {
        let mut buf = [0u8; MAX_FRAME];
        for &b in bytes {
            let n = self.answer(b, dev, &mut buf);
            out.write_all(buf.get(..n).unwrap_or_default())?;
        }
        Ok(())
    }

    /// Takes one byte of the stream; when it completes a frame (or overruns one), encodes
    /// the answer into `buf` and returns its length (0: nothing to send).
    #[inline(never)] // Not generic: the link's bulk is compiled once, in this crate.
    fn answer(&mut self, byte: u8, dev: &mut dyn Device, buf: &mut [u8; MAX_FRAME]) -> usize {
        let msg = match self.rx.push(byte) {
            Pushed::More => return 0,
            Pushed::TooLong => DeviceMsg::FrameError(LinkError::TooLong),
            Pushed::Frame(f) => handle_frame(f, &mut self.stream, dev),
        };
        encode(&msg, buf)
    }

    /// Sends the events due: every transition the device has (a fault also as
    /// [`Event::Fault`]), and a telemetry record when the streaming period has passed.
    pub fn send_events<W: Write>(
        &mut self,
        dev: &mut dyn Device,
        out: &mut W,
    ) -> Result<(), W::Error> {
        let mut buf = [0u8; MAX_FRAME];
        loop {
            let n = self.next_event(dev, &mut buf);
            if n == 0 {
                return Ok(());
            }
            out.write_all(buf.get(..n).unwrap_or_default())?;
        }
    }

    /// Encodes the next event due into `buf` and returns its length (0: none due): a
    /// transition the device has (a fault then also as [`Event::Fault`]), else a telemetry
    /// record when the streaming period has passed.
    #[inline(never)] // Not generic: the link's bulk is compiled once, in this crate.
    fn next_event(&mut self, dev: &mut dyn Device, buf: &mut [u8; MAX_FRAME]) -> usize {
        if let Some(f) = self.fault_pending.take() {
            return encode(&DeviceMsg::Event(Event::Fault(f)), buf);
        }
        if let Some(t) = dev.next_transition() {
            let t: crate::wire::Transition = t.into();
            if let Reason::Fault(f) = t.reason {
                self.fault_pending = Some(f);
            }
            return encode(&DeviceMsg::Event(Event::Transition(t)), buf);
        }
        let s = &mut self.stream;
        if s.period_ms > 0 {
            let now = dev.now_ms();
            // Due when `now` is at or past `next_ms` (modulo the wrap).
            if now.wrapping_sub(s.next_ms) < u32::MAX / 2 {
                let late = now.wrapping_sub(s.next_ms) >= s.period_ms;
                s.next_ms = if late { now } else { s.next_ms }.wrapping_add(s.period_ms);
                let t = Telemetry::from_core(now, &dev.telemetry());
                return encode(&DeviceMsg::Event(Event::Telemetry(t)), buf);
            }
        }
        0
    }

    /// The telemetry period in force \[ms] (0: not streaming).
    pub fn stream_period_ms(&self) -> u32 {
        self.stream.period_ms
    }
}

/// Encodes one message as a frame into `buf` and returns its length. A message too long for
/// a frame cannot be built from this protocol's types (every one fits
/// [`frame::MAX_PAYLOAD`], `tests`); were one, it is dropped (0) rather than sent cut.
fn encode(msg: &DeviceMsg, buf: &mut [u8; MAX_FRAME]) -> usize {
    frame::encode(msg, buf).map_or(0, |n| n.min(MAX_FRAME))
}

/// The answer to one frame (module doc).
fn handle_frame(frame: &mut [u8], stream: &mut Stream, dev: &mut dyn Device) -> DeviceMsg {
    let n = match frame::payload(frame) {
        Ok(n) => n,
        Err(FrameError::BadChecksum) => return DeviceMsg::FrameError(LinkError::BadChecksum),
        Err(_) => return DeviceMsg::FrameError(LinkError::Malformed),
    };
    let Some(bytes) = frame.get(..n) else {
        return DeviceMsg::FrameError(LinkError::Malformed);
    };
    match postcard::from_bytes::<HostMsg>(bytes) {
        Ok(m) => DeviceMsg::Response {
            seq: m.seq,
            result: request(m.req, stream, dev),
        },
        // A good frame but no request of this version: answered under its number if it has
        // one.
        Err(_) => match postcard::take_from_bytes::<u16>(bytes) {
            Ok((seq, _)) => DeviceMsg::Response {
                seq,
                result: Err(LinkError::UnknownMessage),
            },
            Err(_) => DeviceMsg::FrameError(LinkError::UnknownMessage),
        },
    }
}

/// The core's refusal as the link's (its range as numbers: nothing formatted here).
pub fn rejected(e: &ParamError) -> LinkError {
    LinkError::Rejected {
        field: field_name(e.field),
        value: e.value,
        allowed: Range::from(&e.allowed),
    }
}

/// What a key of a non-number type accepts.
fn key_range(e: KeyError) -> Range {
    match e {
        KeyError::NotWhole => Range::between(1.0, 4.0e9, "a whole number"),
        KeyError::NotConvention => Range::between(0.0, 1.0, "0 three-phase or 1 papers"),
        KeyError::NotFlag => Range::between(0.0, 1.0, "0 no or 1 yes"),
    }
}

/// The settings in force, or [`LinkError::NotConfigured`].
#[allow(clippy::result_large_err)] // The wire's error, built once per request.
fn configured(dev: &dyn Device) -> Result<Settings, LinkError> {
    dev.settings().ok_or(LinkError::NotConfigured)
}

/// Validates `new` and puts it in force: while running, refused if a setting locked while
/// running differs from the one in force (`old`).
#[allow(clippy::result_large_err)] // The wire's error, built once per request.
fn change(dev: &mut dyn Device, old: Option<Settings>, new: &Settings) -> Result<(), LinkError> {
    if dev.running() {
        let changed = Key::ALL.iter().find(|k| {
            k.locked_while_running()
                && old.is_none_or(|o| k.get(&o).to_bits() != k.get(new).to_bits())
        });
        if let Some(k) = changed {
            return Err(LinkError::BusyWhileRunning {
                field: field_name(k.name()),
            });
        }
    }
    new.validate().map_err(|e| rejected(&e))?;
    dev.apply(new).map_err(LinkError::from)
}

/// Answers one request.
#[allow(clippy::result_large_err)] // The wire's error, built once per request.
fn request(req: Request, stream: &mut Stream, dev: &mut dyn Device) -> Result<Response, LinkError> {
    match req {
        Request::Hello { version } => {
            if version != PROTOCOL_VERSION {
                return Err(LinkError::VersionMismatch {
                    device: PROTOCOL_VERSION,
                    host: version,
                });
            }
            Ok(Response::Hello {
                version: PROTOCOL_VERSION,
                configured: dev.settings().is_some(),
            })
        }
        Request::GetSettings => configured(dev).map(Response::Settings),
        Request::Get(key) => configured(dev).map(|s| Response::Setting {
            key,
            value: key.get(&s),
        }),
        Request::Set { key, value } => {
            let old = configured(dev)?;
            if key.locked_while_running() && dev.running() {
                return Err(LinkError::BusyWhileRunning {
                    field: field_name(key.name()),
                });
            }
            let mut new = old;
            key.set(&mut new, value).map_err(|e| LinkError::Rejected {
                field: field_name(key.name()),
                value,
                allowed: key_range(e),
            })?;
            change(dev, Some(old), &new).map(|()| Response::Ok)
        }
        Request::SetSettings(new) => {
            let old = dev.settings();
            change(dev, old, &new).map(|()| Response::Ok)
        }
        Request::SetMotor(m) => {
            if dev.running() {
                return Err(LinkError::BusyWhileRunning {
                    field: field_name("motor"),
                });
            }
            let motor = m.motor().validate().map_err(|e| rejected(&e))?;
            let new = dev.defaults_for(&motor);
            let old = dev.settings();
            change(dev, old, &new).map(|()| Response::Ok)
        }
        Request::Save => {
            configured(dev)?;
            dev.save().map(|()| Response::Ok).map_err(LinkError::from)
        }
        Request::Enable(on) => {
            if on {
                configured(dev)?;
            }
            dev.enable(on)
                .map(|()| Response::Ok)
                .map_err(LinkError::from)
        }
        Request::Speed(rpm) => {
            let rated = configured(dev)?.motor.ratings.speed_rpm;
            if !(rpm.is_finite() && rpm.abs() <= rated) {
                return Err(LinkError::Rejected {
                    field: field_name("speed_rpm"),
                    value: rpm,
                    allowed: Range::between(-rated, rated, "the rated speed"),
                });
            }
            dev.set_speed(rpm)
                .map(|()| Response::Ok)
                .map_err(LinkError::from)
        }
        Request::Identify => dev
            .start_identification()
            .map(|()| Response::Ok)
            .map_err(LinkError::from),
        Request::GetIdentified => Ok(Response::Identify {
            mode: dev.telemetry().mode.into(),
            result: dev.identified().map(Into::into),
        }),
        Request::GetFault => Ok(Response::Fault(dev.telemetry().fault.map(Into::into))),
        Request::ClearFault => dev
            .clear_fault()
            .map(|()| Response::Ok)
            .map_err(LinkError::from),
        Request::Stream(hz) => {
            if hz > MAX_STREAM_HZ {
                return Err(LinkError::Rejected {
                    field: field_name("stream_hz"),
                    value: f32::from(hz),
                    allowed: Range::between(0.0, f32::from(MAX_STREAM_HZ), "0: off"),
                });
            }
            *stream = Stream {
                period_ms: if hz == 0 {
                    0
                } else {
                    (1000 / u32::from(hz)).max(1)
                },
                next_ms: dev.now_ms(),
            };
            Ok(Response::Ok)
        }
        Request::GetTelemetry => Ok(Response::Telemetry(Telemetry::from_core(
            dev.now_ms(),
            &dev.telemetry(),
        ))),
        Request::Restart => {
            if dev.running() {
                return Err(LinkError::Refused(reason(
                    "a restart while the drive runs: disable it first",
                )));
            }
            dev.restart()
                .map(|()| Response::Ok)
                .map_err(LinkError::from)
        }
    }
}
