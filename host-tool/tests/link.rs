//! The host tool's functions against a simulated device over TCP (the core drive stepping the
//! host simulator's plant, `pmsm_tool::sim_device`): a motor set, saved, kept across a reset
//! and read back; three speed commands held within 2 % after the transient; a fault raised
//! and cleared through the link; every bad input answered and changing nothing.

// The tool's error carries the device's answer (a few hundred bytes), returned once per
// command: no cost worth a box.
#![allow(clippy::result_large_err)]

use pmsm_link::frame::{self, MAX_FRAME};
use pmsm_link::wire::{self, Mode};
use pmsm_link::{DeviceMsg, Event, HostMsg, Key, LinkError, Request, Settings, PROTOCOL_VERSION};
use pmsm_sensorless::motor::{Motor, HORNG_SINANO, ORTEGA_TEST_0P3KW};
use pmsm_tool::client::{connect, Client, Target, ToolError};
use pmsm_tool::ops;
use pmsm_tool::serve::{Pace, Served};
use pmsm_tool::sim_device::SimDevice;
use std::path::Path;
use std::time::{Duration, Instant};

type Link = Client<Box<dyn pmsm_tool::client::Transport>>;

/// `truth` on the simulated bench, its flash holding the core's defaults for it on the
/// simulated board (`configured`) or nothing.
fn device(truth: Motor, configured: bool) -> Served {
    let mut d = SimDevice::new(truth, None).unwrap();
    if configured {
        let s = pmsm_link::Device::defaults_for(&d, &truth);
        d.set_flash(Some(s));
        d.reset();
    }
    Served::spawn(d, Pace::default()).unwrap()
}

fn link(served: &Served) -> Link {
    connect(&Target::Tcp(served.addr.clone()), Duration::from_secs(5)).unwrap()
}

/// The device's state as the link cannot see it changed: settings, flash, mode, fault.
fn snapshot(served: &Served) -> (Option<Settings>, Option<Settings>, bool) {
    let d = served.device.lock().unwrap();
    (
        pmsm_link::Device::settings(&*d),
        d.flash(),
        pmsm_link::Device::running(&*d),
    )
}

#[test]
fn a_motor_set_and_saved_is_read_back_after_a_reset() {
    let served = device(HORNG_SINANO, false);
    let mut c = link(&served);
    assert!(!c.configured, "an empty flash: no configuration");
    // Without one the drive refuses to run.
    assert!(matches!(
        ops::start(&mut c, 300.0),
        Err(ToolError::Device(LinkError::NotConfigured))
    ));
    let file =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../host-sim/motors/datasheet-example.toml");
    let name = ops::load_motor(&mut c, &file).unwrap();
    assert_eq!(name, "57bl-48v-datasheet");
    let i_max = 0.9 * ops::settings(&mut c).unwrap().limits.i_max_a;
    ops::config_set(&mut c, "limits.i_max_a", &format!("{i_max}")).unwrap();
    let set = ops::settings(&mut c).unwrap();
    let (_, motor) = pmsm_host_sim::motor_file::load(&file).unwrap();
    assert_eq!(set.motor, (&motor).into());
    assert_eq!(set.limits.i_max_a, i_max);
    ops::config_save(&mut c).unwrap();
    drop(c);
    // A power cycle: the flash's settings, validated, in force.
    served.device.lock().unwrap().reset();
    let mut c = link(&served);
    assert!(c.configured);
    assert_eq!(ops::settings(&mut c).unwrap(), set);
    let all = ops::config_get(&mut c, None).unwrap();
    assert_eq!(all.len(), Key::ALL.len());
    assert_eq!(
        ops::config_get(&mut c, Some("limits.i_max_a")).unwrap(),
        vec![(Key::IMaxA, i_max)]
    );
    // A restart asked over the link: an unsaved change is gone, the saved settings back;
    // refused while the drive runs.
    ops::config_set(&mut c, "limits.i_max_a", &format!("{}", 1.05 * i_max)).unwrap();
    assert!(ops::restart(&mut c, Duration::from_secs(5)).unwrap());
    assert_eq!(ops::settings(&mut c).unwrap(), set);
    ops::start(&mut c, 300.0).unwrap();
    assert!(matches!(
        ops::restart(&mut c, Duration::from_secs(5)),
        Err(ToolError::Device(LinkError::Refused(_)))
    ));
    ops::stop(&mut c).unwrap();
    // A corrupt record in the flash (one the core refuses): no configuration at the reset.
    // (The device serves one connection at a time.)
    drop(c);
    let mut bad = set;
    bad.motor.l_h = -1.0;
    {
        let mut d = served.device.lock().unwrap();
        d.set_flash(Some(bad));
        d.reset();
    }
    let c = link(&served);
    assert!(!c.configured);
}

#[test]
fn three_speed_commands_are_held_within_two_percent() {
    let served = device(HORNG_SINANO, true);
    let mut c = link(&served);
    let r_ref_ohm = ops::settings(&mut c).unwrap().motor.r_ohm;
    for rpm in [300.0f32, 600.0, -450.0] {
        // The transient: the ramp (rated speed in a second) and the speed loop's settling.
        ops::run(&mut c, rpm, 1.5, 20).unwrap();
        let records = ops::record(&mut c, 100, 1.0).unwrap();
        assert!(records.len() >= 100, "{}", records.len());
        for r in &records {
            assert_eq!(r.mode, Mode::Sensorless, "{rpm}: {r:?}");
            let err = (r.speed_rpm - rpm).abs() / rpm.abs();
            assert!(
                err < 0.02,
                "{rpm} rpm: {} rpm at {} ms",
                r.speed_rpm,
                r.t_ms
            );
        }
        // The plant's speed (the truth) too.
        let truth = served.device.lock().unwrap().plant_speed_rpm();
        assert!(
            ((truth - f64::from(rpm)) / f64::from(rpm)).abs() < 0.02,
            "{truth}"
        );
        let mut csv = Vec::new();
        ops::write_csv(&mut csv, &records, r_ref_ohm).unwrap();
        let text = String::from_utf8(csv).unwrap();
        assert_eq!(text.lines().count(), records.len() + 1);
        assert_eq!(text.lines().next().unwrap().split(',').count(), 20);
        // The winding's temperature rise: the plant's winding is at the configured
        // resistance's temperature, and the start measured it within a few per cent (1 % is
        // 2.5 K), so within ±15 K.
        for line in text.lines().skip(1) {
            let rise: f32 = line.rsplit(',').next().unwrap().parse().unwrap();
            assert!(rise.abs() < 15.0, "{rise} K: {line}");
        }
    }
    ops::stop(&mut c).unwrap();
}

#[test]
fn a_fault_is_raised_and_cleared_through_the_link() {
    // Ortega's 0.3 kW test motor: its rated speed leaves room under 0.9 of its bus.
    let served = device(ORTEGA_TEST_0P3KW, true);
    let mut c = link(&served);
    assert_eq!(ops::fault(&mut c).unwrap(), None);
    let bus = ops::settings(&mut c).unwrap().motor.ratings.bus_v;
    // The over-voltage trip set below the bus the board has: the drive trips at once.
    ops::config_set(&mut c, "limits.bus_max_v", &format!("{}", 0.9 * bus)).unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    let mut event = None;
    while event.is_none() && Instant::now() < deadline {
        if let Some(Event::Fault(f)) = c.next_event(Duration::from_millis(100)).unwrap() {
            event = Some(f);
        }
    }
    assert_eq!(event, Some(wire::Fault::BusOvervoltage));
    assert_eq!(
        ops::fault(&mut c).unwrap(),
        Some(wire::Fault::BusOvervoltage)
    );
    // Cleared while the cause remains: latched again.
    let again = ops::fault_clear(&mut c, Duration::from_millis(50)).unwrap();
    assert_eq!(again, Some(wire::Fault::BusOvervoltage));
    // The trip back at its default, then cleared.
    ops::config_set(&mut c, "limits.bus_max_v", &format!("{}", 1.25 * bus)).unwrap();
    assert_eq!(
        ops::fault_clear(&mut c, Duration::from_millis(50)).unwrap(),
        None
    );
    // And the drive runs again.
    ops::run(&mut c, 300.0, 1.0, 20).unwrap();
    ops::stop(&mut c).unwrap();
}

#[test]
fn a_refused_start_resistance_reaches_the_host() {
    let served = device(ORTEGA_TEST_0P3KW, true);
    let mut c = link(&served);
    // The drive told a fifth of the motor's resistance: its start measures five times it,
    // beyond 3 R₀.
    let r0 = ORTEGA_TEST_0P3KW.params.r_ohm / 5.0;
    ops::config_set(&mut c, "r_ohm", &format!("{r0}")).unwrap();
    let run = ops::run(&mut c, 300.0, 0.5, 20).unwrap();
    let refused = wire::Transition {
        from: Mode::Align,
        to: Mode::OpenLoop,
        reason: wire::Reason::ResistanceRefused,
    };
    assert!(run.transitions.contains(&refused), "{:?}", run.transitions);
    assert_eq!(
        ops::transition_text(&refused),
        "Align -> OpenLoop (ResistanceRefused)"
    );
    // The model kept: the drive runs on R₀.
    let last = run.records.last().unwrap();
    assert_eq!(last.r_ohm, r0);
    assert!(ops::refused_warning(last.r_ohm).contains(&format!("r_ohm = {r0} Ω")));
    ops::stop(&mut c).unwrap();
    // The motor's own resistance (a device of the defaults for it): taken.
    let served = device(ORTEGA_TEST_0P3KW, true);
    let mut c = link(&served);
    let r_motor = ORTEGA_TEST_0P3KW.params.r_ohm;
    let run = ops::run(&mut c, 300.0, 0.5, 20).unwrap();
    let aligned = run.transitions.iter().find(|t| t.from == Mode::Align);
    assert_eq!(
        aligned.map(|t| t.reason),
        Some(wire::Reason::Aligned),
        "{:?}",
        run.transitions
    );
    let r = run.records.last().unwrap().r_ohm;
    assert!((r / r_motor - 1.0).abs() < 0.02, "R {r} Ω");
    ops::stop(&mut c).unwrap();
}

/// Sends `bytes`, returns the device's first message (events skipped).
fn raw_answer(c: &mut Link, bytes: &[u8]) -> DeviceMsg {
    c.send_bytes(bytes).unwrap();
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        match c.read_msg(deadline).unwrap() {
            Some(DeviceMsg::Event(_)) => {}
            Some(m) => return m,
            None => panic!("no answer"),
        }
    }
}

fn with_crc(payload: &[u8]) -> Vec<u8> {
    let mut raw = payload.to_vec();
    let crc = crc::Crc::<u16>::new(&crc::CRC_16_KERMIT).checksum(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    raw
}

fn cobs_frame(raw: &[u8]) -> Vec<u8> {
    let mut out = cobs::encode_vec(raw);
    out.push(0);
    out
}

#[test]
fn bad_input_over_the_link_changes_nothing() {
    let served = device(HORNG_SINANO, true);
    let mut c = link(&served);
    let before = snapshot(&served);
    // A corrupt frame.
    assert_eq!(
        raw_answer(&mut c, &[0x09, 0x01, 0x00]),
        DeviceMsg::FrameError(LinkError::Malformed)
    );
    // A wrong checksum on a request that would change r_ohm.
    let set = HostMsg {
        seq: 40,
        req: Request::Set {
            key: Key::ROhm,
            value: 2.6,
        },
    };
    let mut raw = with_crc(&postcard::to_allocvec(&set).unwrap());
    raw[3] ^= 0x01;
    assert_eq!(
        raw_answer(&mut c, &cobs_frame(&raw)),
        DeviceMsg::FrameError(LinkError::BadChecksum)
    );
    // An unknown message.
    assert_eq!(
        raw_answer(&mut c, &cobs_frame(&with_crc(&[41, 0x7f]))),
        DeviceMsg::Response {
            seq: 41,
            result: Err(LinkError::UnknownMessage)
        }
    );
    // A frame too long.
    let mut long = vec![0x33; 2 * MAX_FRAME];
    long.push(0);
    assert_eq!(
        raw_answer(&mut c, &long),
        DeviceMsg::FrameError(LinkError::TooLong)
    );
    // A value out of range, named.
    match ops::config_set(&mut c, "l_h", "-1e-3") {
        Err(ToolError::Device(LinkError::Rejected { field, .. })) => assert_eq!(field, "l_h"),
        other => panic!("{other:?}"),
    }
    match ops::config_set(&mut c, "limits.i_trip_a", "1e9") {
        Err(ToolError::Device(LinkError::Rejected { field, .. })) => {
            assert_eq!(field, "limits.i_trip_a")
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(snapshot(&served), before);
    // While running: the motor's parameters and the rate are refused, and stay.
    ops::start(&mut c, 300.0).unwrap();
    let running = snapshot(&served);
    for (key, value) in [("r_ohm", "2.6"), ("rate_hz", "8000"), ("pole_pairs", "5")] {
        match ops::config_set(&mut c, key, value) {
            Err(ToolError::Device(LinkError::BusyWhileRunning { field })) => assert_eq!(field, key),
            other => panic!("{key}: {other:?}"),
        }
    }
    let file =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../host-sim/motors/datasheet-example.toml");
    assert!(matches!(
        ops::load_motor(&mut c, &file),
        Err(ToolError::Device(LinkError::BusyWhileRunning { .. }))
    ));
    assert_eq!(snapshot(&served), running);
    ops::stop(&mut c).unwrap();
    // The link still answers.
    assert_eq!(ops::fault(&mut c).unwrap(), None);
}

#[test]
fn a_wrong_version_a_missing_port_and_a_silent_board_are_clear_errors() {
    let served = device(HORNG_SINANO, true);
    let mut c = link(&served);
    let before = snapshot(&served);
    match c.request(Request::Hello { version: 999 }) {
        Err(e @ ToolError::Version { device, host: 999 }) if device == PROTOCOL_VERSION => {
            assert_eq!(e.exit_code(), 4)
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(snapshot(&served), before);
    // The device serves one connection at a time.
    drop(c);
    let tool = env!("CARGO_BIN_EXE_pmsm-tool");
    // A missing serial port.
    let out = std::process::Command::new(tool)
        .args(["--port", "/dev/pmsm-no-such-port", "fault"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(3), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("/dev/pmsm-no-such-port"));
    // A board that does not answer: a socket that accepts and stays silent.
    let silent = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = silent.local_addr().unwrap().to_string();
    let out = std::process::Command::new(tool)
        .args(["--tcp", &addr, "--timeout", "0.3", "fault"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(5), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("did not answer"));
    drop(silent);
    // The binary against the device: a setting read, a bad one refused (exit 6, named).
    let out = std::process::Command::new(tool)
        .args(["--tcp", &served.addr, "config", "get", "ratings.bus_v"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{out:?}");
    assert_eq!(
        String::from_utf8_lossy(&out.stdout).trim(),
        "ratings.bus_v = 48"
    );
    let out = std::process::Command::new(tool)
        .args(["--tcp", &served.addr, "config", "set", "r_ohm", "-3"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(6), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("r_ohm = -3"));
}

#[test]
fn every_request_fits_the_device_buffer() {
    let s = Settings::for_motor(&ORTEGA_TEST_0P3KW, None);
    let mut buf = [0u8; MAX_FRAME];
    let n = frame::encode(
        &HostMsg {
            seq: u16::MAX,
            req: Request::SetSettings(s),
        },
        &mut buf,
    )
    .unwrap();
    assert!(n <= MAX_FRAME);
}

/// Identified within the bounds `host-sim/tests/identify.rs` holds the core's identification
/// to (R and ψ_f 3 %, L 5 %, J 10 %), over the link; the motor file written is one
/// `pmsm-sim --motor-file` reads, and loaded and saved it is the device's configuration.
#[test]
fn the_motor_is_identified_over_the_link_and_saved() {
    let served = device(HORNG_SINANO, true);
    let mut c = link(&served);
    let motor = ops::identify(&mut c, Duration::from_secs(120)).unwrap();
    let (t, m) = (HORNG_SINANO.params, motor.params);
    let pct = |id: f32, truth: f32| 100.0 * (id - truth) / truth;
    eprintln!(
        "identified over the link: R {:+.2} %, L {:+.2} %, flux {:+.2} %, J {:+.2} %",
        pct(m.r_ohm, t.r_ohm),
        pct(m.l_h, t.l_h),
        pct(m.flux_wb, t.flux_wb),
        pct(m.j_kgm2, t.j_kgm2)
    );
    assert!(pct(m.r_ohm, t.r_ohm).abs() < 3.0, "R {m:?}");
    assert!(pct(m.l_h, t.l_h).abs() < 5.0, "L {m:?}");
    assert!(pct(m.flux_wb, t.flux_wb).abs() < 3.0, "flux {m:?}");
    assert!(pct(m.j_kgm2, t.j_kgm2).abs() < 10.0, "J {m:?}");
    let text = ops::motor_toml("sinano-identified", &motor);
    let (name, parsed) = pmsm_host_sim::motor_file::parse(&text).unwrap();
    assert_eq!(name, "sinano-identified");
    assert_eq!(parsed.params, motor.params);
    assert_eq!(parsed.ratings, motor.ratings);
    // The drive idle again, configured as before; the identified motor loaded and saved.
    let dir = std::env::temp_dir().join(format!("pmsm-tool-identify-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("identified.toml");
    std::fs::write(&file, &text).unwrap();
    ops::load_motor(&mut c, &file).unwrap();
    ops::config_save(&mut c).unwrap();
    let saved = served.device.lock().unwrap().flash().unwrap();
    assert_eq!(saved.motor, (&parsed).into());
    // And it runs on it.
    ops::run(&mut c, 500.0, 1.5, 20).unwrap();
    let records = ops::record(&mut c, 50, 0.5).unwrap();
    assert!(records
        .iter()
        .all(|r| ((r.speed_rpm - 500.0) / 500.0).abs() < 0.02));
    ops::stop(&mut c).unwrap();
    std::fs::remove_dir_all(&dir).unwrap();
}
