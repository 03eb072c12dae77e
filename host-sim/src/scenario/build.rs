//! A scenario file turned into a [`Scenario`] for one motor: fractions of its ratings into
//! speeds and torques, every value checked; the errors name the key.

use super::file::{DcLinkFile, InjectFile, ScenarioFile, Spec};
use super::profile::Pwl;
use super::{DriveScript, Injection, LoadKind, Scenario, Window, BRAKE_FADE};
use crate::board::{DcLinkSpec, SensorFault};
use crate::names::{fault_name, FAULTS};
use anyhow::{bail, ensure, Context};
use pmsm_sensorless::drive::Fault;
use pmsm_sensorless::motor::Motor;

impl Spec {
    /// The scenario on its own motor.
    pub fn build_default(&self) -> anyhow::Result<Scenario> {
        let m = self.default_motor()?;
        self.build(m.name, m)
    }

    /// The scenario for `motor` (shown as `motor_name`): fractions of its ratings turned into
    /// speeds and torques, every value checked; errors name the key.
    pub fn build(&self, motor_name: &str, motor: Motor) -> anyhow::Result<Scenario> {
        self.build_inner(motor_name, motor)
            .with_context(|| format!("scenario {}", self.name))
    }

    fn build_inner(&self, motor_name: &str, motor: Motor) -> anyhow::Result<Scenario> {
        let f = &self.file;
        let rated_rpm = motor.ratings.speed_rpm as f64;
        let rated_nm = motor.ratings.torque_nm as f64;
        ensure!(
            f.duration_s.is_finite() && f.duration_s > 0.0 && f.duration_s <= MAX_DURATION_S,
            "duration_s = {}: must be in (0, {MAX_DURATION_S}] s",
            f.duration_s
        );
        let speed = profile(
            "speed",
            &f.speed,
            "speed_rpm",
            &f.speed_rpm,
            rated_rpm,
            MAX_SPEED_FRACTION,
        )?
        .unwrap_or_else(|| vec![(0.0, 0.0)]);
        let (load_shape, load_nm) = load(f, rated_nm)?;
        let load_kind = load_kind(f, rated_rpm)?;
        let windows = windows(f)?;
        let (initial_speed_rpm, min_speed_rpm) = speeds(f, rated_rpm, &speed)?;
        if let Some(i) = f.i_max_a {
            ensure!(i.is_finite() && i > 0.0, "i_max_a = {i}: must be > 0 A");
        }
        let speed_tolerance = f.speed_tolerance.unwrap_or(0.02);
        ensure!(
            speed_tolerance.is_finite() && speed_tolerance > 0.0,
            "speed_tolerance = {speed_tolerance}: must be > 0"
        );
        let drive = self.drive_script(&motor)?;
        if let Some(d) = &f.dc_link {
            dc_link(d, &motor)?;
        }
        Ok(Scenario {
            name: self.name.clone(),
            description: self.description().to_string(),
            motor_name: motor_name.to_string(),
            motor,
            duration_s: f.duration_s,
            speed_cmd_rpm: Pwl::new(speed),
            load_shape,
            load_nm,
            windows,
            initial_speed_rpm,
            min_speed_rpm,
            i_max_a: f.i_max_a,
            figures: f.figures.clone().unwrap_or_default(),
            load_kind,
            drive,
            speed_tolerance,
            locked_rotor: f.locked_rotor.unwrap_or(false),
        })
    }

    /// The scenario's `[dc_link]` for `motor`: its keys over the defaults scaled from the
    /// motor's ratings ([`DcLinkSpec::for_motor`]), checked; `None` without the table (a
    /// stiff bus). It belongs to the board (`SimBoard::dc_link`), where `run` puts it.
    pub fn dc_link(&self, motor: &Motor) -> anyhow::Result<Option<DcLinkSpec>> {
        let link = self.file.dc_link.as_ref().map(|d| dc_link(d, motor));
        link.transpose()
            .with_context(|| format!("scenario {}", self.name))
    }

    /// Drive scenarios: the enable schedule, the injection and the fault expected; the other
    /// scenarios take none of them.
    fn drive_script(&self, motor: &Motor) -> anyhow::Result<Option<DriveScript>> {
        let f = &self.file;
        if !self.is_drive() {
            for (key, set) in [
                ("enable", f.enable.is_some()),
                ("clear_fault", f.clear_fault.is_some()),
                ("terminal_sensing", f.terminal_sensing.is_some()),
                ("inject", f.inject.is_some()),
                ("expect_fault", f.expect_fault.is_some()),
            ] {
                ensure!(!set, "{key}: only drive scenarios (drive = true) take it");
            }
            return Ok(None);
        }
        let mut script = DriveScript::enabled();
        if let Some(e) = &f.enable {
            check_times("enable", e.iter().map(|p| p.0))?;
            script.enable = e.clone();
        }
        if let Some(c) = &f.clear_fault {
            check_times("clear_fault", c.iter().copied())?;
            script.clear_fault = c.clone();
        }
        script.terminal_sensing = f.terminal_sensing;
        if let Some(i) = &f.inject {
            script.injection = Some(injection(i, motor, f.duration_s)?);
        }
        if let Some(name) = &f.expect_fault {
            script.expect_fault = Some(fault_by_name(name)?);
        }
        Ok(Some(script))
    }
}

/// The load profile as a shape (largest |value| 1) and its level \[N·m].
fn load(f: &ScenarioFile, rated_nm: f64) -> anyhow::Result<(Pwl, f64)> {
    let load = profile(
        "load",
        &f.load,
        "load_nm",
        &f.load_nm,
        rated_nm,
        MAX_LOAD_FRACTION,
    )?
    .unwrap_or_else(|| vec![(0.0, 0.0)]);
    let load_nm = load.iter().map(|p| p.1.abs()).fold(0.0, f64::max);
    let load_shape = if load_nm > 0.0 {
        Pwl::new(load.iter().map(|&(t, v)| (t, v / load_nm)).collect())
    } else {
        Pwl::constant(0.0)
    };
    Ok((load_shape, load_nm))
}

/// `load_kind`, a brake with its fade speed.
fn load_kind(f: &ScenarioFile, rated_rpm: f64) -> anyhow::Result<LoadKind> {
    let fade_rpm = one_of(
        "brake_fade",
        f.brake_fade,
        "brake_fade_rpm",
        f.brake_fade_rpm,
        rated_rpm,
    )?
    .unwrap_or(BRAKE_FADE * rated_rpm);
    ensure!(
        fade_rpm.is_finite() && fade_rpm > 0.0,
        "brake_fade: must be a speed > 0, got {fade_rpm} rpm"
    );
    Ok(match f.load_kind.as_deref().unwrap_or("brake") {
        "brake" => LoadKind::Brake { sat_rpm: fade_rpm },
        "active" => LoadKind::Active,
        other => bail!("load_kind = \"{other}\": must be \"brake\" or \"active\""),
    })
}

/// The metric windows, within the run and named once each.
fn windows(f: &ScenarioFile) -> anyhow::Result<Vec<Window>> {
    let mut windows = Vec::new();
    for (name, t0, t1) in &f.windows {
        ensure!(
            t0.is_finite() && t1.is_finite() && 0.0 <= *t0 && t0 < t1 && *t1 <= f.duration_s,
            "window \"{name}\" = [{t0}, {t1}]: must satisfy 0 ≤ t0 < t1 ≤ duration_s ({})",
            f.duration_s
        );
        ensure!(
            !windows.iter().any(|w: &Window| &w.name == name),
            "window \"{name}\" is named twice"
        );
        windows.push(Window::new(name.clone(), *t0, *t1));
    }
    Ok(windows)
}

/// The rotor's speed at t = 0 and the lowest operating speed \[rpm] (default: the smallest
/// non-zero command of `speed`).
fn speeds(f: &ScenarioFile, rated_rpm: f64, speed: &[(f64, f64)]) -> anyhow::Result<(f64, f64)> {
    let initial_speed_rpm = one_of(
        "initial_speed",
        f.initial_speed,
        "initial_speed_rpm",
        f.initial_speed_rpm,
        rated_rpm,
    )?
    .unwrap_or(0.0);
    ensure!(
        initial_speed_rpm.is_finite() && initial_speed_rpm.abs() <= MAX_SPEED_FRACTION * rated_rpm,
        "initial_speed: {initial_speed_rpm} rpm is beyond {MAX_SPEED_FRACTION}× the rated speed"
    );
    let lowest_command = speed
        .iter()
        .map(|p| p.1.abs())
        .filter(|&v| v > 0.0)
        .fold(f64::INFINITY, f64::min);
    let min_speed_rpm = one_of(
        "min_speed",
        f.min_speed,
        "min_speed_rpm",
        f.min_speed_rpm,
        rated_rpm,
    )?
    .unwrap_or(if lowest_command.is_finite() {
        lowest_command
    } else {
        0.06 * rated_rpm
    });
    ensure!(
        min_speed_rpm.is_finite() && min_speed_rpm > 0.0,
        "min_speed: must be > 0, got {min_speed_rpm} rpm"
    );
    Ok((initial_speed_rpm, min_speed_rpm))
}

/// Longest scenario \[s].
const MAX_DURATION_S: f64 = 3600.0;
/// Largest speed command, as a fraction of rated speed.
const MAX_SPEED_FRACTION: f64 = 2.0;
/// Largest load, as a fraction of rated torque.
const MAX_LOAD_FRACTION: f64 = 10.0;

/// The profile given either as fractions of `rated` (`key`) or absolute (`abs_key`), checked:
/// times finite, ≥ 0 and in order, values finite and within `max_fraction` of `rated`.
fn profile(
    key: &str,
    fractions: &Option<Vec<(f64, f64)>>,
    abs_key: &str,
    absolute: &Option<Vec<(f64, f64)>>,
    rated: f64,
    max_fraction: f64,
) -> anyhow::Result<Option<Vec<(f64, f64)>>> {
    let points: Vec<(f64, f64)> = match (fractions, absolute) {
        (Some(_), Some(_)) => bail!("give {key} or {abs_key}, not both"),
        (Some(p), None) => p.iter().map(|&(t, v)| (t, v * rated)).collect(),
        (None, Some(p)) => p.clone(),
        (None, None) => return Ok(None),
    };
    ensure!(!points.is_empty(), "{key}: needs at least one [t, value]");
    check_times(key, points.iter().map(|p| p.0))?;
    for &(t, v) in &points {
        ensure!(
            v.is_finite() && v.abs() <= max_fraction * rated,
            "{key} at t = {t} s: {v} is beyond {max_fraction}× the rating ({rated})"
        );
    }
    Ok(Some(points))
}

/// Times of a profile: finite, ≥ 0, non-decreasing.
fn check_times(key: &str, times: impl Iterator<Item = f64>) -> anyhow::Result<()> {
    let mut last = 0.0;
    for t in times {
        ensure!(
            t.is_finite() && t >= last,
            "{key}: times must be finite, ≥ 0 and in order (t = {t} s after {last} s)"
        );
        last = t;
    }
    Ok(())
}

/// A value given either as a fraction of `rated` (`key`) or absolute (`abs_key`).
fn one_of(
    key: &str,
    fraction: Option<f64>,
    abs_key: &str,
    absolute: Option<f64>,
    rated: f64,
) -> anyhow::Result<Option<f64>> {
    match (fraction, absolute) {
        (Some(_), Some(_)) => bail!("give {key} or {abs_key}, not both"),
        (Some(x), None) => Ok(Some(x * rated)),
        (None, x) => Ok(x),
    }
}

/// `[inject]` checked and turned into an injection for `motor`.
fn injection(i: &InjectFile, motor: &Motor, duration_s: f64) -> anyhow::Result<Injection> {
    ensure!(
        i.t.is_finite() && 0.0 <= i.t && i.t <= duration_s,
        "inject.t = {}: must be within the run (0..{duration_s} s)",
        i.t
    );
    let factor = |key: &str, v: Option<f64>| -> anyhow::Result<f64> {
        let v = v.unwrap_or(1.0);
        ensure!(
            v.is_finite() && v > 0.0,
            "inject.{key} = {v}: a factor must be > 0"
        );
        Ok(v)
    };
    let only = |allowed: &[&str]| -> anyhow::Result<()> {
        for (key, set) in [
            ("r", i.r.is_some()),
            ("l", i.l.is_some()),
            ("flux", i.flux.is_some()),
            ("bus", i.bus.is_some()),
            ("until", i.until.is_some()),
            ("phase", i.phase.is_some()),
            ("gain", i.gain.is_some()),
        ] {
            ensure!(
                !set || allowed.contains(&key),
                "inject.{key}: not a key of kind \"{}\"",
                i.kind
            );
        }
        Ok(())
    };
    Ok(match i.kind.as_str() {
        "plant" => {
            only(&["r", "l", "flux", "until"])?;
            if let Some(u) = i.until {
                ensure!(
                    u.is_finite() && i.t < u && u <= duration_s,
                    "inject.until = {u}: must be after inject.t ({}) and within the run",
                    i.t
                );
                ensure!(
                    i.l.is_none(),
                    "inject.l: a step only (with inject.until, r and flux change gradually)"
                );
            }
            Injection::Plant {
                t: i.t,
                r: factor("r", i.r)?,
                l: factor("l", i.l)?,
                flux: factor("flux", i.flux)?,
                until: i.until,
            }
        }
        "bus" => {
            only(&["bus", "until"])?;
            let bus = i
                .bus
                .ok_or_else(|| anyhow::anyhow!("inject.bus: kind \"bus\" needs it"))?;
            ensure!(
                (0.0..=10.0).contains(&bus),
                "inject.bus = {bus}: a fraction of the rated bus in [0, 10]"
            );
            if let Some(u) = i.until {
                ensure!(
                    u.is_finite() && i.t < u && u <= duration_s,
                    "inject.until = {u}: must be after inject.t ({}) and within the run",
                    i.t
                );
            }
            Injection::Bus {
                t: i.t,
                v: bus * motor.ratings.bus_v as f64,
                until: i.until,
            }
        }
        "nan_current" => {
            only(&[])?;
            Injection::NanCurrent { t: i.t }
        }
        "task_stall" => {
            only(&[])?;
            Injection::TaskStall { t: i.t }
        }
        "sensor_stuck" | "sensor_zero" => {
            only(&["phase"])?;
            Injection::CurrentSensor {
                t: i.t,
                phase: sensor_phase(i.phase.as_deref())?,
                fault: if i.kind == "sensor_stuck" {
                    SensorFault::Stuck
                } else {
                    SensorFault::Zero
                },
            }
        }
        "sensor_gain" => {
            only(&["phase", "gain"])?;
            let gain = i
                .gain
                .ok_or_else(|| anyhow::anyhow!("inject.gain: kind \"sensor_gain\" needs it"))?;
            ensure!(
                gain.is_finite() && (0.0..=10.0).contains(&gain),
                "inject.gain = {gain}: a factor in [0, 10]"
            );
            Injection::CurrentSensor {
                t: i.t,
                phase: sensor_phase(i.phase.as_deref())?,
                fault: SensorFault::Gain(gain),
            }
        }
        other => bail!(
            "inject.kind = \"{other}\": must be \"plant\", \"bus\", \"nan_current\", \"task_stall\", \"sensor_stuck\", \"sensor_zero\" or \"sensor_gain\""
        ),
    })
}

/// `inject.phase`: "a" (the default), "b" or "c", as 0..3.
fn sensor_phase(phase: Option<&str>) -> anyhow::Result<usize> {
    match phase.unwrap_or("a") {
        "a" => Ok(0),
        "b" => Ok(1),
        "c" => Ok(2),
        other => bail!("inject.phase = \"{other}\": must be \"a\", \"b\" or \"c\""),
    }
}

/// `[dc_link]` for `motor`: the keys given over [`DcLinkSpec::for_motor`], checked.
fn dc_link(d: &DcLinkFile, motor: &Motor) -> anyhow::Result<DcLinkSpec> {
    let mut spec = DcLinkSpec::for_motor(motor);
    if let Some(uf) = d.capacitance_uf {
        spec.capacitance_f = uf * 1e-6;
    }
    spec.source_ohm = d.source_ohm.unwrap_or(spec.source_ohm);
    spec.sink_a = d.sink_a.unwrap_or(spec.sink_a);
    match d.brake_ohm {
        Some(r) => {
            let mut ch = DcLinkSpec::default_chopper(motor, r);
            let bus = f64::from(motor.ratings.bus_v);
            ch.v_on = d.brake_on.map_or(ch.v_on, |x| x * bus);
            ch.v_off = d.brake_off.map_or(ch.v_off, |x| x * bus);
            spec.chopper = Some(ch);
        }
        None => ensure!(
            d.brake_on.is_none() && d.brake_off.is_none() && d.brake_by_drive.is_none(),
            "dc_link.brake_on, brake_off, brake_by_drive: only with dc_link.brake_ohm"
        ),
    }
    spec.chopper_by_drive = d.brake_by_drive.unwrap_or(false);
    spec.check().context("[dc_link]")?;
    Ok(spec)
}

/// The fault called `name` (as in the JSON summary).
fn fault_by_name(name: &str) -> anyhow::Result<Fault> {
    FAULTS
        .into_iter()
        .find(|&f| fault_name(f) == name)
        .ok_or_else(|| {
            let names: Vec<_> = FAULTS.iter().map(|&f| fault_name(f)).collect();
            anyhow::anyhow!(
                "expect_fault = \"{name}\": unknown fault (known: {})",
                names.join(", ")
            )
        })
}
