//! The server against a mock device: every request's answer, and every bad input (a corrupt
//! frame, a wrong checksum, an unknown message, a frame too long, a value out of range, a
//! write while running of a setting that must not change then, a wrong protocol version)
//! answered and changing nothing.

#![allow(clippy::result_large_err)] // The wire error, as the server answers it.

use pmsm_link::frame::{self, MAX_FRAME, MAX_PAYLOAD};
use pmsm_link::msg::{Event, FieldName, MAX_STREAM_HZ};
use pmsm_link::settings::MotorSettings;
use pmsm_link::wire::{self, Mode};
use pmsm_link::DeviceError;
use pmsm_link::*;
use pmsm_sensorless::drive::{self as core_drive, Fault, Reason, Transition};
use pmsm_sensorless::motor::{HORNG_SINANO, ORTEGA_TEST_0P3KW};
use std::collections::VecDeque;

/// A device that records what it is asked.
#[derive(Clone, Debug, PartialEq)]
struct Mock {
    settings: Option<Settings>,
    applied: usize,
    saved: Option<Settings>,
    enabled: bool,
    speed_rpm: f32,
    cleared: usize,
    identify: usize,
    now_ms: u32,
    fault: Option<Fault>,
    transitions: VecDeque<Transition>,
    restarts: usize,
}

impl Mock {
    fn configured() -> Self {
        Self {
            settings: Some(Settings::for_motor(&HORNG_SINANO, None)),
            applied: 0,
            saved: None,
            enabled: false,
            speed_rpm: 0.0,
            cleared: 0,
            identify: 0,
            now_ms: 0,
            fault: None,
            transitions: VecDeque::new(),
            restarts: 0,
        }
    }
}

impl Device for Mock {
    fn settings(&self) -> Option<Settings> {
        self.settings
    }
    fn apply(&mut self, s: &Settings) -> Result<(), DeviceError> {
        self.settings = Some(*s);
        self.applied += 1;
        Ok(())
    }
    fn save(&mut self) -> Result<(), DeviceError> {
        self.saved = self.settings;
        Ok(())
    }
    fn running(&self) -> bool {
        self.enabled
    }
    fn enable(&mut self, on: bool) -> Result<(), DeviceError> {
        self.enabled = on;
        Ok(())
    }
    fn set_speed(&mut self, rpm: f32) -> Result<(), DeviceError> {
        self.speed_rpm = rpm;
        Ok(())
    }
    fn start_identification(&mut self) -> Result<(), DeviceError> {
        self.identify += 1;
        Ok(())
    }
    fn identified(&self) -> Option<core_drive::Identified> {
        None
    }
    fn clear_fault(&mut self) -> Result<(), DeviceError> {
        self.cleared += 1;
        self.fault = None;
        Ok(())
    }
    fn telemetry(&self) -> core_drive::Telemetry {
        core_drive::Telemetry {
            fault: self.fault,
            mode: if self.fault.is_some() {
                core_drive::Mode::Fault
            } else {
                core_drive::Mode::Idle
            },
            ..Default::default()
        }
    }
    fn now_ms(&self) -> u32 {
        self.now_ms
    }
    fn next_transition(&mut self) -> Option<Transition> {
        self.transitions.pop_front()
    }
    fn restart(&mut self) -> Result<(), DeviceError> {
        self.restarts += 1;
        Ok(())
    }
}

/// The device's output.
#[derive(Default)]
struct Sink(Vec<u8>);

impl embedded_io::ErrorType for Sink {
    type Error = core::convert::Infallible;
}

impl embedded_io::Write for Sink {
    fn write(&mut self, buf: &[u8]) -> Result<usize, Self::Error> {
        self.0.extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

fn encode<T: serde::Serialize>(msg: &T) -> Vec<u8> {
    let mut buf = [0u8; MAX_FRAME];
    let n = frame::encode(msg, &mut buf).unwrap();
    buf[..n].to_vec()
}

fn req(seq: u16, req: Request) -> Vec<u8> {
    encode(&HostMsg { seq, req })
}

/// Feeds `bytes` to a server on `dev`; the messages it answered.
fn feed(server: &mut Server, dev: &mut Mock, bytes: &[u8]) -> Vec<DeviceMsg> {
    let mut out = Sink::default();
    server.receive(bytes, dev, &mut out).unwrap();
    server.send_events(dev, &mut out).unwrap();
    out.0
        .split(|&b| b == 0)
        .filter(|f| !f.is_empty())
        .map(|f| frame::decode::<DeviceMsg>(&mut f.to_vec()).unwrap())
        .collect()
}

fn one(server: &mut Server, dev: &mut Mock, bytes: &[u8]) -> DeviceMsg {
    let msgs = feed(server, dev, bytes);
    assert_eq!(msgs.len(), 1, "{msgs:?}");
    msgs.into_iter().next().unwrap()
}

fn answer(dev: &mut Mock, r: Request) -> Result<Response, LinkError> {
    match one(&mut Server::new(), dev, &req(7, r)) {
        DeviceMsg::Response { seq: 7, result } => result,
        other => panic!("{other:?}"),
    }
}

fn name(s: &str) -> FieldName {
    pmsm_link::msg::field_name(s)
}

#[test]
fn hello_gives_the_version_and_a_wrong_one_is_named() {
    let mut dev = Mock::configured();
    let before = dev.clone();
    assert_eq!(
        answer(
            &mut dev,
            Request::Hello {
                version: PROTOCOL_VERSION
            }
        ),
        Ok(Response::Hello {
            version: PROTOCOL_VERSION,
            configured: true
        })
    );
    assert_eq!(
        answer(&mut dev, Request::Hello { version: 99 }),
        Err(LinkError::VersionMismatch {
            device: PROTOCOL_VERSION,
            host: 99
        })
    );
    assert_eq!(dev, before);
}

#[test]
fn every_message_fits_a_frame() {
    let s = Settings::for_motor(&HORNG_SINANO, None);
    let big = DeviceMsg::Response {
        seq: u16::MAX,
        result: Ok(Response::Settings(s)),
    };
    let n = postcard::to_allocvec(&big).unwrap().len();
    assert!(n <= MAX_PAYLOAD, "{n}");
    let rejected = DeviceMsg::Response {
        seq: u16::MAX,
        result: Err(LinkError::Rejected {
            field: name(&"x".repeat(40)),
            value: f32::NAN,
            allowed: pmsm_link::msg::Range::between(f32::MIN, f32::MAX, &"y".repeat(200)),
        }),
    };
    assert!(postcard::to_allocvec(&rejected).unwrap().len() <= MAX_PAYLOAD);
    // And the host's largest request.
    let set = HostMsg {
        seq: u16::MAX,
        req: Request::SetSettings(s),
    };
    assert!(postcard::to_allocvec(&set).unwrap().len() <= MAX_PAYLOAD);
}

#[test]
fn a_corrupt_frame_is_answered_and_changes_nothing() {
    let mut dev = Mock::configured();
    let before = dev.clone();
    let mut s = Server::new();
    // A COBS code byte pointing past the frame's end.
    let msg = one(&mut s, &mut dev, &[0x09, 0x01, 0x02, 0x00]);
    assert_eq!(msg, DeviceMsg::FrameError(LinkError::Malformed));
    // Shorter than its checksum.
    let msg = one(&mut s, &mut dev, &[0x02, 0x05, 0x00]);
    assert_eq!(msg, DeviceMsg::FrameError(LinkError::Malformed));
    assert_eq!(dev, before);
    // The next good frame is read.
    let ok = req(3, Request::GetFault);
    assert!(matches!(
        one(&mut s, &mut dev, &ok),
        DeviceMsg::Response {
            seq: 3,
            result: Ok(Response::Fault(None))
        }
    ));
}

#[test]
fn a_wrong_checksum_is_answered_and_changes_nothing() {
    let mut dev = Mock::configured();
    let before = dev.clone();
    // A frame that would set r_ohm, one payload bit flipped after the checksum was taken.
    let set = HostMsg {
        seq: 5,
        req: Request::Set {
            key: Key::ROhm,
            value: 2.6,
        },
    };
    let mut raw = postcard::to_allocvec(&set).unwrap();
    let crc = crc::Crc::<u16>::new(&crc::CRC_16_KERMIT).checksum(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    let last = raw.len() - 3;
    raw[last] ^= 0x10;
    let mut wire = cobs::encode_vec(&raw);
    wire.push(0);
    let msg = one(&mut Server::new(), &mut dev, &wire);
    assert_eq!(msg, DeviceMsg::FrameError(LinkError::BadChecksum));
    assert_eq!(dev, before);
}

#[test]
fn an_unknown_message_is_answered_under_its_number_and_changes_nothing() {
    let mut dev = Mock::configured();
    let before = dev.clone();
    // seq 0x0102 as a varint, then a request variant this version does not have.
    let mut raw = vec![0x82, 0x02, 0x7f, 1, 2, 3];
    let crc = crc::Crc::<u16>::new(&crc::CRC_16_KERMIT).checksum(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    let mut wire = cobs::encode_vec(&raw);
    wire.push(0);
    let msg = one(&mut Server::new(), &mut dev, &wire);
    assert_eq!(
        msg,
        DeviceMsg::Response {
            seq: 0x0102,
            result: Err(LinkError::UnknownMessage)
        }
    );
    // Not even a number: unknown, without one.
    let mut raw = vec![0xff];
    let crc = crc::Crc::<u16>::new(&crc::CRC_16_KERMIT).checksum(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    let mut wire = cobs::encode_vec(&raw);
    wire.push(0);
    let msg = one(&mut Server::new(), &mut dev, &wire);
    assert_eq!(msg, DeviceMsg::FrameError(LinkError::UnknownMessage));
    assert_eq!(dev, before);
}

#[test]
fn a_frame_too_long_is_dropped_once_and_the_next_is_read() {
    let mut dev = Mock::configured();
    let before = dev.clone();
    let mut bytes = vec![0x55; 3 * MAX_FRAME];
    bytes.push(0);
    bytes.extend(req(9, Request::GetFault));
    let msgs = feed(&mut Server::new(), &mut dev, &bytes);
    assert_eq!(msgs[0], DeviceMsg::FrameError(LinkError::TooLong));
    assert!(matches!(msgs[1], DeviceMsg::Response { seq: 9, .. }));
    assert_eq!(msgs.len(), 2);
    assert_eq!(dev, before);
}

#[test]
fn noise_never_panics_and_changes_nothing() {
    let mut dev = Mock::configured();
    let before = dev.clone();
    let mut s = Server::new();
    // A fixed linear congruential sequence, zeros included (frame ends).
    let mut x: u32 = 12345;
    let bytes: Vec<u8> = (0..200_000)
        .map(|_| {
            x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (x >> 24) as u8
        })
        .collect();
    let msgs = feed(&mut s, &mut dev, &bytes);
    assert!(!msgs.is_empty());
    assert!(msgs.iter().all(|m| matches!(m, DeviceMsg::FrameError(_))));
    assert_eq!(dev, before);
}

#[test]
fn a_value_out_of_range_is_named_and_changes_nothing() {
    let mut dev = Mock::configured();
    let before = dev.clone();
    for (key, value, field) in [
        (Key::ROhm, -1.0, "r_ohm"),
        (Key::ROhm, f32::NAN, "r_ohm"),
        (Key::LH, f32::INFINITY, "l_h"),
        (Key::PolePairs, 2.5, "pole_pairs"),
        (Key::PolePairs, 0.0, "pole_pairs"),
        (Key::TorqueConvention, 2.0, "torque_convention"),
        (Key::TerminalSensing, 0.5, "power_stage.terminal_sensing"),
        (Key::ITripA, 0.1, "limits.i_trip_a"),
        (Key::RateHz, 3500.0, "rate_hz"),
        // r_ohm within its own range, but the bus no longer drives rated torque through it.
        (Key::ROhm, 500.0, "ratings.torque_nm"),
    ] {
        match answer(&mut dev, Request::Set { key, value }) {
            Err(LinkError::Rejected { field: f, .. }) => assert_eq!(f, name(field), "{key:?}"),
            other => panic!("{key:?} = {value}: {other:?}"),
        }
    }
    match answer(&mut dev, Request::Speed(f32::NAN)) {
        Err(LinkError::Rejected { field, .. }) => assert_eq!(field, name("speed_rpm")),
        other => panic!("{other:?}"),
    }
    match answer(&mut dev, Request::Speed(1e6)) {
        Err(LinkError::Rejected { field, .. }) => assert_eq!(field, name("speed_rpm")),
        other => panic!("{other:?}"),
    }
    match answer(&mut dev, Request::Stream(MAX_STREAM_HZ + 1)) {
        Err(LinkError::Rejected { field, .. }) => assert_eq!(field, name("stream_hz")),
        other => panic!("{other:?}"),
    }
    let mut bad = MotorSettings::from(&HORNG_SINANO);
    bad.l_h = 0.0;
    match answer(&mut dev, Request::SetMotor(bad)) {
        Err(LinkError::Rejected { field, .. }) => assert_eq!(field, name("l_h")),
        other => panic!("{other:?}"),
    }
    assert_eq!(dev, before);
}

#[test]
fn a_setting_locked_while_running_is_refused_then_and_others_are_taken() {
    let mut dev = Mock::configured();
    dev.enabled = true;
    let before = dev.clone();
    for key in [
        Key::ROhm,
        Key::PolePairs,
        Key::RateHz,
        Key::BusV,
        Key::PwmHz,
    ] {
        let value = key.get(&dev.settings.unwrap());
        assert_eq!(
            answer(&mut dev, Request::Set { key, value }),
            Err(LinkError::BusyWhileRunning {
                field: name(key.name())
            })
        );
    }
    let mut s = dev.settings.unwrap();
    s.rate_hz = 8000.0;
    assert_eq!(
        answer(&mut dev, Request::SetSettings(s)),
        Err(LinkError::BusyWhileRunning {
            field: name("rate_hz")
        })
    );
    assert_eq!(
        answer(&mut dev, Request::SetMotor((&ORTEGA_TEST_0P3KW).into())),
        Err(LinkError::BusyWhileRunning {
            field: name("motor")
        })
    );
    assert_eq!(dev, before);
    // A limit may change while running.
    let i_max = dev.settings.unwrap().limits.i_max_a;
    assert_eq!(
        answer(
            &mut dev,
            Request::Set {
                key: Key::IMaxA,
                value: 0.9 * i_max
            }
        ),
        Ok(Response::Ok)
    );
    assert_eq!(dev.settings.unwrap().limits.i_max_a, 0.9 * i_max);
}

/// A restart is answered, then done by the device; while the drive runs it is refused and
/// nothing happens.
#[test]
fn a_restart_is_answered_and_refused_while_running() {
    let mut dev = Mock::configured();
    dev.enabled = true;
    let before = dev.clone();
    assert!(matches!(
        answer(&mut dev, Request::Restart),
        Err(LinkError::Refused(_))
    ));
    assert_eq!(dev, before);
    dev.enabled = false;
    assert_eq!(answer(&mut dev, Request::Restart), Ok(Response::Ok));
    assert_eq!(dev.restarts, 1);
}

#[test]
fn settings_are_read_written_and_saved() {
    let mut dev = Mock::configured();
    let s0 = dev.settings.unwrap();
    assert_eq!(
        answer(&mut dev, Request::GetSettings),
        Ok(Response::Settings(s0))
    );
    for &key in Key::ALL {
        assert_eq!(
            answer(&mut dev, Request::Get(key)),
            Ok(Response::Setting {
                key,
                value: key.get(&s0)
            })
        );
        assert_eq!(Key::from_name(key.name()), Some(key));
    }
    assert_eq!(
        answer(
            &mut dev,
            Request::Set {
                key: Key::ROhm,
                value: 2.6
            }
        ),
        Ok(Response::Ok)
    );
    assert_eq!(dev.settings.unwrap().motor.r_ohm, 2.6);
    assert_eq!(answer(&mut dev, Request::Save), Ok(Response::Ok));
    assert_eq!(dev.saved, dev.settings);
    // A new motor: the core's defaults for it, on the device's power stage.
    assert_eq!(
        answer(&mut dev, Request::SetMotor((&ORTEGA_TEST_0P3KW).into())),
        Ok(Response::Ok)
    );
    let s = dev.settings.unwrap();
    assert_eq!(s.motor, MotorSettings::from(&ORTEGA_TEST_0P3KW));
    assert_eq!(s, Settings::for_motor(&ORTEGA_TEST_0P3KW, Some(&s0)));
    assert!(s.validate().is_ok());
}

#[test]
fn without_a_configuration_the_drive_is_not_enabled() {
    let mut dev = Mock::configured();
    dev.settings = None;
    let before = dev.clone();
    for r in [
        Request::Enable(true),
        Request::GetSettings,
        Request::Get(Key::LH),
        Request::Save,
    ] {
        assert_eq!(answer(&mut dev, r), Err(LinkError::NotConfigured));
    }
    assert_eq!(
        answer(
            &mut dev,
            Request::Set {
                key: Key::LH,
                value: 1e-3
            }
        ),
        Err(LinkError::NotConfigured)
    );
    assert_eq!(dev, before);
    // The identification is the device's to allow.
    assert_eq!(answer(&mut dev, Request::Identify), Ok(Response::Ok));
    assert_eq!(dev.identify, 1);
}

#[test]
fn commands_reach_the_device() {
    let mut dev = Mock::configured();
    assert_eq!(answer(&mut dev, Request::Enable(true)), Ok(Response::Ok));
    assert_eq!(answer(&mut dev, Request::Speed(-500.0)), Ok(Response::Ok));
    assert!(dev.enabled);
    assert_eq!(dev.speed_rpm, -500.0);
    dev.fault = Some(Fault::Stall);
    assert_eq!(
        answer(&mut dev, Request::GetFault),
        Ok(Response::Fault(Some(wire::Fault::Stall)))
    );
    assert_eq!(answer(&mut dev, Request::ClearFault), Ok(Response::Ok));
    assert_eq!(dev.cleared, 1);
    assert_eq!(
        answer(&mut dev, Request::GetIdentified),
        Ok(Response::Identify {
            mode: Mode::Idle,
            result: None
        })
    );
}

#[test]
fn telemetry_streams_at_the_rate_asked_and_transitions_are_events() {
    let mut dev = Mock::configured();
    let mut s = Server::new();
    let mut records = Vec::new();
    let msgs = feed(&mut s, &mut dev, &req(1, Request::Stream(100)));
    assert!(matches!(
        msgs[0],
        DeviceMsg::Response {
            seq: 1,
            result: Ok(Response::Ok)
        }
    ));
    // The first record at once.
    assert!(matches!(msgs[1], DeviceMsg::Event(Event::Telemetry(r)) if r.t_ms == 0));
    records.push(0);
    for t in 1..=999 {
        dev.now_ms = t;
        for m in feed(&mut s, &mut dev, &[]) {
            if let DeviceMsg::Event(Event::Telemetry(r)) = m {
                records.push(r.t_ms);
            }
        }
    }
    // One every 10 ms over the second.
    assert_eq!(records.len(), 100);
    assert!(records.windows(2).all(|w| w[1] - w[0] == 10));
    let fault = Transition {
        from: core_drive::Mode::Sensorless,
        to: core_drive::Mode::Fault,
        reason: Reason::Fault(Fault::Overcurrent),
    };
    dev.transitions.push_back(fault);
    let msgs = feed(&mut s, &mut dev, &req(2, Request::Stream(0)));
    assert_eq!(msgs.len(), 3, "{msgs:?}");
    assert_eq!(msgs[1], DeviceMsg::Event(Event::Transition(fault.into())));
    assert_eq!(
        msgs[2],
        DeviceMsg::Event(Event::Fault(wire::Fault::Overcurrent))
    );
    dev.now_ms += 100;
    assert!(feed(&mut s, &mut dev, &[]).is_empty());
}

#[test]
fn a_refused_start_resistance_and_an_open_winding_are_events() {
    let mut dev = Mock::configured();
    let mut s = Server::new();
    // The alignment refused its measurement: the transition names it, no fault.
    let refused = Transition {
        from: core_drive::Mode::Align,
        to: core_drive::Mode::OpenLoop,
        reason: Reason::ResistanceRefused,
    };
    // A winding that does not carry the current: the start refused with its fault.
    let open = Transition {
        from: core_drive::Mode::Align,
        to: core_drive::Mode::Fault,
        reason: Reason::Fault(Fault::OpenWinding),
    };
    dev.transitions.extend([refused, open]);
    let msgs = feed(&mut s, &mut dev, &[]);
    assert_eq!(
        msgs,
        [
            DeviceMsg::Event(Event::Transition(wire::Transition {
                from: Mode::Align,
                to: Mode::OpenLoop,
                reason: wire::Reason::ResistanceRefused,
            })),
            DeviceMsg::Event(Event::Transition(wire::Transition {
                from: Mode::Align,
                to: Mode::Fault,
                reason: wire::Reason::Fault(wire::Fault::OpenWinding),
            })),
            DeviceMsg::Event(Event::Fault(wire::Fault::OpenWinding)),
        ]
    );
}

#[test]
fn the_core_types_convert_both_ways() {
    use pmsm_sensorless::drive::IdentifyError;
    for f in [
        Fault::Overcurrent,
        Fault::CurrentSensor,
        Fault::Identify(IdentifyError::InertiaOutOfRange),
        Fault::OpenWinding,
    ] {
        let w: wire::Fault = f.into();
        assert_eq!(Fault::from(w), f);
    }
    let m: Mode = core_drive::Mode::Identified.into();
    assert_eq!(core_drive::Mode::from(m), core_drive::Mode::Identified);
    let s = Settings::for_motor(&ORTEGA_TEST_0P3KW, None);
    assert_eq!(Settings::from(&s.drive_config()), s);
    assert_eq!(
        s.motor(),
        pmsm_sensorless::motor::Motor {
            name: "link",
            ..ORTEGA_TEST_0P3KW
        }
    );
}

#[test]
fn a_refusal_prints_as_the_core_prints_it() {
    let mut s = Settings::for_motor(&HORNG_SINANO, None);
    for (key, value) in [(Key::ROhm, -3.0), (Key::ITripA, 1e9), (Key::LH, 1e-12)] {
        key.set(&mut s, value).unwrap();
        let core = s.validate().unwrap_err();
        let link = pmsm_link::server::rejected(&core);
        assert_eq!(link.to_string(), format!("rejected: {core}"));
        key.set(&mut s, key.get(&Settings::for_motor(&HORNG_SINANO, None)))
            .unwrap();
    }
}

#[test]
fn an_explanation_is_cut_at_its_capacity_on_a_character_boundary() {
    use pmsm_link::msg::{reason, Reason};
    let cap = Reason::new().capacity();
    // Short: whole.
    assert_eq!(reason("allowed [0, 1]").as_str(), "allowed [0, 1]");
    // Long ASCII: its first `cap` bytes.
    let long = "x".repeat(cap + 10);
    assert_eq!(reason(&long).as_str(), &long[..cap]);
    // A two-byte character across the capacity: cut before it, never inside.
    let straddling = format!("{}Ω tail", "a".repeat(cap - 1));
    assert_eq!(reason(&straddling).as_str(), &straddling[..cap - 1]);
    // Ending exactly at the capacity on a boundary: kept.
    let exact = format!("{}Ω", "a".repeat(cap - 2));
    assert_eq!(reason(&exact).as_str(), exact.as_str());
    // Empty: empty.
    assert_eq!(reason("").as_str(), "");
    // A four-byte character across the capacity (at each of its three inner bytes): cut
    // before it.
    for before in 1..=3 {
        let text = format!("{}🜂 tail", "a".repeat(cap - before));
        assert_eq!(reason(&text).as_str(), &text[..cap - before]);
    }
    // The field names likewise, at their own capacity.
    assert_eq!(name("limits.i_trip_a").as_str(), "limits.i_trip_a");
    let cap_name = FieldName::new().capacity();
    let long_name = format!("{}é", "k".repeat(cap_name - 1));
    assert_eq!(name(&long_name).as_str(), &long_name[..cap_name - 1]);
}
