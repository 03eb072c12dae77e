//! What each subcommand does over a [`Client`], as library functions (the binary and the
//! tests call these): settings by name, a motor file loaded, the identification and the motor
//! file it gives, the speed command, telemetry collected over a span of the device's time and
//! written as CSV, the fault read and cleared.

use crate::client::{Client, ToolError};
use pmsm_host_sim::names::fault_name;
use pmsm_link::settings::MotorSettings;
use pmsm_link::wire::{Fault, Mode, Reason, Telemetry, Transition};
use pmsm_link::{Event, Key, Request, Response, Settings};
use pmsm_sensorless::drive as core_drive;
use pmsm_sensorless::motor::{Motor, TorqueConvention};
use std::io::{Read, Write};
use std::path::Path;
use std::time::{Duration, Instant};

/// An unexpected answer as an error.
fn unexpected(r: Response) -> ToolError {
    ToolError::Other(anyhow::anyhow!("unexpected answer: {r:?}"))
}

/// Every setting, or the one called `key`.
pub fn config_get<T: Read + Write>(
    c: &mut Client<T>,
    key: Option<&str>,
) -> Result<Vec<(Key, f32)>, ToolError> {
    match key {
        None => {
            let s = settings(c)?;
            Ok(Key::ALL.iter().map(|&k| (k, k.get(&s))).collect())
        }
        Some(name) => {
            let key = parse_key(name)?;
            match c.request(Request::Get(key))? {
                Response::Setting { key, value } => Ok(vec![(key, value)]),
                r => Err(unexpected(r)),
            }
        }
    }
}

/// Every setting.
pub fn settings<T: Read + Write>(c: &mut Client<T>) -> Result<Settings, ToolError> {
    match c.request(Request::GetSettings)? {
        Response::Settings(s) => Ok(s),
        r => Err(unexpected(r)),
    }
}

/// The key called `name`; the error lists the names.
pub fn parse_key(name: &str) -> Result<Key, ToolError> {
    Key::from_name(name).ok_or_else(|| {
        let names: Vec<_> = Key::ALL.iter().map(|k| k.name()).collect();
        ToolError::Other(anyhow::anyhow!(
            "unknown setting {name:?}; the settings are: {}",
            names.join(", ")
        ))
    })
}

/// A value as typed: a number, or for `torque_convention` also `three-phase` / `papers`, for
/// `power_stage.terminal_sensing` `yes` / `no`.
pub fn parse_value(key: Key, text: &str) -> Result<f32, ToolError> {
    match (key, text) {
        (Key::TorqueConvention, "three-phase") => Ok(0.0),
        (Key::TorqueConvention, "papers") => Ok(1.0),
        (Key::TerminalSensing, "no" | "false") => Ok(0.0),
        (Key::TerminalSensing, "yes" | "true") => Ok(1.0),
        _ => text.trim().parse::<f32>().map_err(|_| {
            ToolError::Other(anyhow::anyhow!("{}: {text:?} is not a number", key.name()))
        }),
    }
}

/// A value as printed (`torque_convention` by name).
pub fn show_value(key: Key, value: f32) -> String {
    match key {
        Key::TorqueConvention if value == 0.0 => "three-phase".into(),
        Key::TorqueConvention => "papers".into(),
        Key::TerminalSensing if value == 0.0 => "no".into(),
        Key::TerminalSensing => "yes".into(),
        _ => format!("{value}"),
    }
}

/// Sets the setting `key` to `value` (as typed).
pub fn config_set<T: Read + Write>(
    c: &mut Client<T>,
    key: &str,
    value: &str,
) -> Result<(), ToolError> {
    let key = parse_key(key)?;
    let value = parse_value(key, value)?;
    ok(c.request(Request::Set { key, value })?)
}

/// `Ok` expected.
fn ok(r: Response) -> Result<(), ToolError> {
    match r {
        Response::Ok => Ok(()),
        r => Err(unexpected(r)),
    }
}

/// Saves the settings in the device's store.
pub fn config_save<T: Read + Write>(c: &mut Client<T>) -> Result<(), ToolError> {
    ok(c.request(Request::Save)?)
}

/// Sends the motor of a motor file (the `pmsm-sim --motor-file` format, read by the
/// simulator's own loader): the device takes it with the core's defaults for every other
/// setting. Returns the motor's name.
pub fn load_motor<T: Read + Write>(c: &mut Client<T>, path: &Path) -> Result<String, ToolError> {
    let (name, motor) = pmsm_host_sim::motor_file::load(path)?;
    ok(c.request(Request::SetMotor(MotorSettings::from(&motor)))?)?;
    Ok(name)
}

/// The latched fault.
pub fn fault<T: Read + Write>(c: &mut Client<T>) -> Result<Option<Fault>, ToolError> {
    match c.request(Request::GetFault)? {
        Response::Fault(f) => Ok(f),
        r => Err(unexpected(r)),
    }
}

/// Clears the latched fault; the fault after (`None` once cleared), read `settle` later.
pub fn fault_clear<T: Read + Write>(
    c: &mut Client<T>,
    settle: Duration,
) -> Result<Option<Fault>, ToolError> {
    ok(c.request(Request::ClearFault)?)?;
    std::thread::sleep(settle);
    fault(c)
}

/// Restarts the device (refused while the drive runs) and waits, within `limit`, until it
/// answers again as at power-up; whether it came back configured (settings in its store).
pub fn restart<T: Read + Write>(c: &mut Client<T>, limit: Duration) -> Result<bool, ToolError> {
    ok(c.request(Request::Restart)?)?;
    let deadline = Instant::now() + limit;
    let timeout = c.timeout;
    c.timeout = Duration::from_millis(200).min(timeout);
    let back = loop {
        std::thread::sleep(Duration::from_millis(100));
        match c.hello() {
            Ok(()) => break Ok(c.configured),
            Err(ToolError::Timeout(_)) if Instant::now() < deadline => {}
            Err(e) => break Err(e),
        }
    };
    c.timeout = timeout;
    back
}

/// A fault's snake-case name (as `pmsm-sim` prints it).
pub fn name_of(f: Fault) -> &'static str {
    fault_name(core_drive::Fault::from(f))
}

/// Enables the drive at `speed_rpm`.
pub fn start<T: Read + Write>(c: &mut Client<T>, speed_rpm: f32) -> Result<(), ToolError> {
    ok(c.request(Request::Speed(speed_rpm))?)?;
    ok(c.request(Request::Enable(true))?)
}

/// A zero command and the enable withdrawn.
pub fn stop<T: Read + Write>(c: &mut Client<T>) -> Result<(), ToolError> {
    ok(c.request(Request::Speed(0.0))?)?;
    ok(c.request(Request::Enable(false))?)
}

/// What a recording saw: the telemetry records and the mode changes, each in order.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Recording {
    /// The telemetry records.
    pub records: Vec<Telemetry>,
    /// The transitions (mode changes, changes of the driving observer).
    pub transitions: Vec<Transition>,
}

/// Telemetry streamed at `rate_hz` over `seconds` of the device's time (its records' `t_ms`:
/// a simulated or emulated device's time runs at its own pace), the stream stopped after.
pub fn record<T: Read + Write>(
    c: &mut Client<T>,
    rate_hz: u16,
    seconds: f64,
) -> Result<Vec<Telemetry>, ToolError> {
    c.clear_events();
    Ok(collect(c, rate_hz, seconds)?.records)
}

/// [`record`], with the transitions: those received since the last events were taken
/// included.
fn collect<T: Read + Write>(
    c: &mut Client<T>,
    rate_hz: u16,
    seconds: f64,
) -> Result<Recording, ToolError> {
    ok(c.request(Request::Stream(rate_hz))?)?;
    let mut out = Recording::default();
    let wait = c.timeout;
    let span_ms = (seconds * 1000.0).round() as u32;
    loop {
        match c.next_event(wait)? {
            Some(Event::Telemetry(t)) => {
                let done = out
                    .records
                    .first()
                    .is_some_and(|f| t.t_ms.wrapping_sub(f.t_ms) >= span_ms);
                out.records.push(t);
                if done {
                    break;
                }
            }
            Some(Event::Transition(t)) => out.transitions.push(t),
            Some(Event::Fault(_)) => {}
            None => return Err(ToolError::Timeout("telemetry stream".into())),
        }
    }
    ok(c.request(Request::Stream(0))?)?;
    c.clear_events();
    Ok(out)
}

/// Runs at `speed_rpm` for `seconds` of the device's time: the telemetry at `rate_hz` and
/// every transition from the start on.
pub fn run<T: Read + Write>(
    c: &mut Client<T>,
    speed_rpm: f32,
    seconds: f64,
    rate_hz: u16,
) -> Result<Recording, ToolError> {
    c.clear_events();
    start(c, speed_rpm)?;
    collect(c, rate_hz, seconds)
}

/// A transition as a line: `Align -> OpenLoop (Aligned)`, a fault by its name.
pub fn transition_text(t: &Transition) -> String {
    match t.reason {
        Reason::Fault(f) => format!("{:?} -> {:?} (fault {})", t.from, t.to, name_of(f)),
        r => format!("{:?} -> {:?} ({r:?})", t.from, t.to),
    }
}

/// The warning of a start whose resistance measurement the drive refused
/// (`Reason::ResistanceRefused`), `r_ohm` the resistance it runs on (the telemetry's).
pub fn refused_warning(r_ohm: f32) -> String {
    format!(
        "the start's resistance measurement was refused (beyond R0/3..3 R0 of the configured \
         r_ohm, or the rotor not at rest): the drive runs on r_ohm = {r_ohm} Ω; the value \
         measured is in the device's log"
    )
}

/// The CSV header of [`write_csv`].
pub const CSV_HEADER: &str = "t_s,mode,fault,speed_ref_rpm,speed_rpm,theta_e_primary,theta_e_monitor,theta_e_control,i_d,i_q,load_nm,driving,residual_primary,residual_monitor,disagreement_deg,speed_disagreement_rpm,r_ohm,flux_wb,voltage_limited,winding_rise_k";

/// Telemetry as CSV (every field; time from the first record \[s]), and the winding's
/// temperature rise \[K] from the resistance over `r_ref_ohm`, the configured one
/// (`pmsm_sensorless::units::winding_rise_k`).
pub fn write_csv(
    out: &mut impl Write,
    records: &[Telemetry],
    r_ref_ohm: f32,
) -> std::io::Result<()> {
    writeln!(out, "{CSV_HEADER}")?;
    let t0 = records.first().map_or(0, |r| r.t_ms);
    for r in records {
        writeln!(
            out,
            "{},{:?},{},{},{},{},{},{},{},{},{},{:?},{},{},{},{},{},{},{},{}",
            f64::from(r.t_ms.wrapping_sub(t0)) / 1000.0,
            r.mode,
            r.fault.map_or("", name_of),
            r.speed_ref_rpm,
            r.speed_rpm,
            r.theta_e_primary,
            r.theta_e_monitor,
            r.theta_e_control,
            r.i_d,
            r.i_q,
            r.load_nm.map_or(String::new(), |v| v.to_string()),
            r.driving,
            r.residual_primary,
            r.residual_monitor,
            r.disagreement_deg,
            r.speed_disagreement_rpm,
            r.r_ohm,
            r.flux_wb,
            r.voltage_limited,
            pmsm_sensorless::units::winding_rise_k(r.r_ohm, r_ref_ohm),
        )?;
    }
    Ok(())
}

/// The identification over the link: started, waited for (up to `limit` of wall-clock
/// time), the enable withdrawn. Returns the identified motor (the device's pole pairs,
/// ratings and torque convention, validated by the core), or the fault that ended it.
pub fn identify<T: Read + Write>(c: &mut Client<T>, limit: Duration) -> Result<Motor, ToolError> {
    let s = settings(c)?;
    ok(c.request(Request::Identify)?)?;
    let end = Instant::now() + limit;
    let result = loop {
        match c.request(Request::GetIdentified)? {
            Response::Identify {
                mode: Mode::Identified,
                result: Some(id),
            } => break id,
            Response::Identify {
                mode: Mode::Fault, ..
            } => {
                let f = fault(c)?.map_or("unknown", name_of);
                stop(c)?;
                return Err(ToolError::Other(anyhow::anyhow!(
                    "the identification stopped: {f}"
                )));
            }
            _ => {}
        }
        if Instant::now() > end {
            stop(c)?;
            return Err(ToolError::Timeout("identification".into()));
        }
        c.clear_events();
        std::thread::sleep(Duration::from_millis(50));
    };
    stop(c)?;
    let m = s.motor();
    let params = core_drive::Identified::from(result)
        .params(m.params.pole_pairs, m.params.torque)
        .map_err(|e| ToolError::Other(anyhow::anyhow!("identified motor: {e}")))?;
    Ok(Motor { params, ..m })
}

/// The motor file `pmsm-sim --motor-file` reads: `motor`'s parameters and ratings.
pub fn motor_toml(name: &str, motor: &Motor) -> String {
    let (m, r) = (motor.params, motor.ratings);
    format!(
        "# Identified over the link by `pmsm-tool identify`.\n\
         name = \"{name}\"\npole_pairs = {}\nr_ohm = {:e}\nl_h = {:e}\nflux_wb = {:e}\n\
         j_kgm2 = {:e}\nb_nms = {:e}\n{}\n[ratings]\nbus_v = {}\ncurrent_a = {}\ntorque_nm = {}\n\
         speed_rpm = {}\npower_w = {}\n",
        m.pole_pairs,
        m.r_ohm,
        m.l_h,
        m.flux_wb,
        m.j_kgm2,
        m.b_nms,
        match m.torque {
            TorqueConvention::ThreePhase => "",
            TorqueConvention::Papers => "torque_convention = \"papers\"\n",
        },
        r.bus_v,
        r.current_a,
        r.torque_nm,
        r.speed_rpm,
        r.power_w
    )
}
