//! Scenarios: what the simulated drive is asked to do, as TOML files.
//!
//! A scenario file gives the speed command and the load over time, the metric windows, and
//! optionally the enable schedule, an injected fault cause and the fault it expects. Speeds and
//! loads are fractions of the motor's rated speed and torque (`speed`, `load`,
//! `initial_speed`), so one scenario serves every motor, or absolute (`speed_rpm`, `load_nm`,
//! `initial_speed_rpm`) for the papers' experiments on their own motors:
//!
//! ```toml
//! description = "what it does, one line"
//! motor = "sinano"                # the default motor (--motor / --motor-file replace it)
//! drive = true                    # the complete drive (default); false: FOC on one observer
//! duration_s = 6.0
//! speed = [[0.0, 0.0], [1.0, 0.5], [4.0, 0.5], [4.0, -0.5]]  # [t s, fraction of rated speed]; linear between, a repeated t is a step
//! load  = [[0.0, 0.0], [2.0, 0.5], [3.0, 0.5], [3.0, 0.0]]   # [t s, fraction of rated torque]
//! load_kind = "brake"             # "brake" opposes the motion; "active" is a signed torque
//! windows = [["loaded", 2.5, 3.0], ["released", 3.5, 4.0]]   # [name, t0, t1]
//! initial_speed = 0.0             # the rotor coasts at this fraction of rated speed at t = 0
//! enable = [[0.0, true], [3.0, false], [3.5, true]]          # enabled throughout by default
//! expect_fault = "stall"          # the run passes only if the drive faults so
//! [inject]                        # a fault cause: kind = "plant" (factors r, l, flux),
//! t = 1.8                         # "bus" (bus, a fraction of the rated bus) or "nan_current"
//! kind = "plant"
//! r = 0.1
//! ```
//!
//! Further keys: `figures` (the papers' figures, in the plot title), `brake_fade` (a brake
//! fades linearly to zero below this fraction of rated speed, default 0.03) or
//! `brake_fade_rpm`, `min_speed_rpm` or `min_speed` (bare-observer runs: the lowest operating
//! speed the flux observer's γ is chosen for; default the smallest non-zero speed command),
//! `i_max_a` (bare-observer runs: the speed loop's current limit), `speed_tolerance` (a window
//! passes when its mean speed error is within this fraction of max(|command|, 5 % of rated
//! speed); default 0.02), `locked_rotor = true` (the shaft is blocked throughout).
//!
//! The built-in scenarios are the files in `host-sim/scenarios/`, compiled in.

use crate::profile::Pwl;
use crate::sim::fault_name;
use anyhow::{bail, ensure, Context};
use pmsm_sensorless::drive::Fault;
use pmsm_sensorless::motor::{self, Motor};
use serde::Deserialize;
use std::path::Path;

/// A named interval over which metrics are computed \[s].
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    /// Name used in the JSON summary.
    pub name: String,
    /// Start \[s].
    pub t0: f64,
    /// End \[s].
    pub t1: f64,
}

impl Window {
    /// A window named `name` from `t0` to `t1` \[s].
    pub fn new(name: impl Into<String>, t0: f64, t1: f64) -> Self {
        Self {
            name: name.into(),
            t0,
            t1,
        }
    }
}

/// A simulated experiment, built for one motor.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Identifier on the command line (the file's stem).
    pub name: String,
    /// One line for `pmsm-sim list`.
    pub description: String,
    /// Motor name as shown in summaries.
    pub motor_name: String,
    /// The plant's motor (the controller's copy may carry mismatch factors).
    pub motor: Motor,
    /// Simulated duration \[s].
    pub duration_s: f64,
    /// Speed command \[rpm, mechanical].
    pub speed_cmd_rpm: Pwl,
    /// Load torque shape, scaled by `load_nm` \[dimensionless], largest |value| 1.
    pub load_shape: Pwl,
    /// Load torque level \[N·m] (positive opposes positive rotation).
    pub load_nm: f64,
    /// Metric windows.
    pub windows: Vec<Window>,
    /// Rotor speed at t = 0 \[rpm].
    pub initial_speed_rpm: f64,
    /// Lowest operating speed \[rpm]: the bare flux observer's γ is chosen for it
    /// (Proposition 4).
    pub min_speed_rpm: f64,
    /// Limit of the bare-observer runs' i_q \[A]; default 1.5× the current of rated torque.
    pub i_max_a: Option<f64>,
    /// The paper's figures this scenario reproduces (shown in the plot title).
    pub figures: String,
    /// How the load torque depends on speed.
    pub load_kind: LoadKind,
    /// Run the complete drive (start-up, modes, faults) instead of FOC on an observer.
    pub drive: Option<DriveScript>,
    /// A window passes when its mean speed error is within this fraction of
    /// max(|command|, 5 % of rated speed).
    pub speed_tolerance: f64,
    /// The rotor is held throughout (a blocked shaft).
    pub locked_rotor: bool,
}

/// A brake's torque fades to zero below this fraction of rated speed, unless the scenario
/// says otherwise (`brake_fade`).
pub const BRAKE_FADE: f64 = 0.03;

/// How the load torque depends on speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LoadKind {
    /// A signed torque opposing positive rotation (the papers' τ_L, eq (33)): a hanging mass;
    /// it drives a motor at rest backwards.
    Active,
    /// A brake: the level opposes the motion, fading linearly to zero below `sat_rpm`.
    Brake {
        /// Speed below which the brake torque fades \[rpm].
        sat_rpm: f64,
    },
}

/// What the drive is told, and what goes wrong, during a drive scenario.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveScript {
    /// The enable command: `(t [s], enabled)`, each holding until the next; enabled before
    /// the first.
    pub enable: Vec<(f64, bool)>,
    /// A fault cause injected during the run.
    pub injection: Option<Injection>,
    /// The fault the scenario expects (the run fails without it).
    pub expect_fault: Option<Fault>,
}

impl DriveScript {
    /// Enabled throughout, nothing injected, no fault expected.
    pub fn enabled() -> Self {
        Self {
            enable: Vec::new(),
            injection: None,
            expect_fault: None,
        }
    }

    /// The enable command at `t` \[s].
    pub fn enable_at(&self, t: f64) -> bool {
        self.enable
            .iter()
            .rev()
            .find(|&&(tk, _)| tk <= t)
            .is_none_or(|&(_, on)| on)
    }
}

/// A fault cause.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Injection {
    /// The plant's R, L and flux are multiplied by these factors at `t` (a winding short, a
    /// demagnetisation).
    Plant {
        /// Time \[s].
        t: f64,
        /// Factor on R.
        r: f64,
        /// Factor on L.
        l: f64,
        /// Factor on the flux linkage.
        flux: f64,
    },
    /// The DC bus steps to `v` at `t`.
    Bus {
        /// Time \[s].
        t: f64,
        /// New bus voltage \[V].
        v: f64,
    },
    /// The current sample of phase b reads NaN from `t` on.
    NanCurrent {
        /// Time \[s].
        t: f64,
    },
}

impl Injection {
    /// When it happens \[s].
    pub fn t(&self) -> f64 {
        match *self {
            Injection::Plant { t, .. } | Injection::Bus { t, .. } | Injection::NanCurrent { t } => {
                t
            }
        }
    }
}

/// Default overload factor of the current limit over the current of rated torque.
pub const OVERLOAD: f64 = 1.5;

impl Scenario {
    /// The bare-observer runs' current limit \[A].
    pub fn i_max_a(&self) -> f64 {
        self.i_max_a
            .unwrap_or(OVERLOAD * self.motor.rated_torque_current_a() as f64)
    }

    /// Load torque at `t` and speed `omega_m` \[rad/s] \[N·m].
    pub fn load_at(&self, t: f64, omega_m: f64) -> f64 {
        let level = self.load_nm * self.load_shape.at(t);
        match self.load_kind {
            LoadKind::Active => level,
            LoadKind::Brake { sat_rpm } => {
                let x = omega_m / (sat_rpm * crate::sim::RAD_S_PER_RPM);
                level * x.clamp(-1.0, 1.0)
            }
        }
    }
}

/// A scenario file as written (see the module doc).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    description: Option<String>,
    figures: Option<String>,
    motor: Option<String>,
    drive: Option<bool>,
    duration_s: f64,
    speed: Option<Vec<(f64, f64)>>,
    speed_rpm: Option<Vec<(f64, f64)>>,
    load: Option<Vec<(f64, f64)>>,
    load_nm: Option<Vec<(f64, f64)>>,
    load_kind: Option<String>,
    brake_fade: Option<f64>,
    brake_fade_rpm: Option<f64>,
    windows: Vec<(String, f64, f64)>,
    initial_speed: Option<f64>,
    initial_speed_rpm: Option<f64>,
    enable: Option<Vec<(f64, bool)>>,
    min_speed: Option<f64>,
    min_speed_rpm: Option<f64>,
    i_max_a: Option<f64>,
    inject: Option<InjectFile>,
    expect_fault: Option<String>,
    speed_tolerance: Option<f64>,
    locked_rotor: Option<bool>,
    ideal: Option<bool>,
}

/// `[inject]` of a scenario file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct InjectFile {
    t: f64,
    kind: String,
    r: Option<f64>,
    l: Option<f64>,
    flux: Option<f64>,
    bus: Option<f64>,
}

/// Longest scenario \[s].
const MAX_DURATION_S: f64 = 3600.0;
/// Largest speed command, as a fraction of rated speed.
const MAX_SPEED_FRACTION: f64 = 2.0;
/// Largest load, as a fraction of rated torque.
const MAX_LOAD_FRACTION: f64 = 10.0;

/// A scenario: its name and its file.
#[derive(Clone, Debug)]
pub struct Spec {
    /// Identifier (the file's stem).
    pub name: String,
    /// The file's contents.
    pub file: ScenarioFile,
}

/// The built-in scenario files, in listing order.
const BUILT_IN: [(&str, &str); 25] = [
    (
        "horng-ramp-brake",
        include_str!("../scenarios/horng-ramp-brake.toml"),
    ),
    (
        "ortega-steps",
        include_str!("../scenarios/ortega-steps.toml"),
    ),
    (
        "ortega-load-200",
        include_str!("../scenarios/ortega-load-200.toml"),
    ),
    (
        "ortega-load-800",
        include_str!("../scenarios/ortega-load-800.toml"),
    ),
    ("ortega-ramp", include_str!("../scenarios/ortega-ramp.toml")),
    (
        "start-stop-reverse",
        include_str!("../scenarios/start-stop-reverse.toml"),
    ),
    (
        "start-test-motor",
        include_str!("../scenarios/start-test-motor.toml"),
    ),
    (
        "ramp-brake-drive",
        include_str!("../scenarios/ramp-brake-drive.toml"),
    ),
    (
        "fault-overcurrent",
        include_str!("../scenarios/fault-overcurrent.toml"),
    ),
    (
        "fault-bus-undervoltage",
        include_str!("../scenarios/fault-bus-undervoltage.toml"),
    ),
    (
        "fault-nan-current",
        include_str!("../scenarios/fault-nan-current.toml"),
    ),
    (
        "fault-observer-loss",
        include_str!("../scenarios/fault-observer-loss.toml"),
    ),
    (
        "sup-load-steps-50",
        include_str!("../scenarios/sup-load-steps-50.toml"),
    ),
    (
        "sup-load-steps-100",
        include_str!("../scenarios/sup-load-steps-100.toml"),
    ),
    (
        "sup-start-brake-100",
        include_str!("../scenarios/sup-start-brake-100.toml"),
    ),
    (
        "sup-start-active-50",
        include_str!("../scenarios/sup-start-active-50.toml"),
    ),
    (
        "sup-catch-50",
        include_str!("../scenarios/sup-catch-50.toml"),
    ),
    (
        "sup-catch-neg50",
        include_str!("../scenarios/sup-catch-neg50.toml"),
    ),
    (
        "sup-catch-100",
        include_str!("../scenarios/sup-catch-100.toml"),
    ),
    (
        "sup-catch-neg100",
        include_str!("../scenarios/sup-catch-neg100.toml"),
    ),
    (
        "sup-low-speed-3",
        include_str!("../scenarios/sup-low-speed-3.toml"),
    ),
    (
        "sup-locked-rated",
        include_str!("../scenarios/sup-locked-rated.toml"),
    ),
    (
        "sup-locked-slow",
        include_str!("../scenarios/sup-locked-slow.toml"),
    ),
    (
        "sup-reverse-20",
        include_str!("../scenarios/sup-reverse-20.toml"),
    ),
    (
        "warm-winding",
        include_str!("../scenarios/warm-winding.toml"),
    ),
];

impl Spec {
    /// Parses a scenario file's text; errors say the line and the key.
    pub fn parse(name: &str, text: &str) -> anyhow::Result<Self> {
        let file: ScenarioFile = crate::from_toml(text)?;
        Ok(Self {
            name: name.to_string(),
            file,
        })
    }

    /// Reads a scenario file; its name is the file's stem.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text = std::fs::read_to_string(path)
            .with_context(|| format!("reading scenario file {}", path.display()))?;
        let name = path
            .file_stem()
            .map_or("scenario".into(), |s| s.to_string_lossy().into_owned());
        Self::parse(&name, &text).with_context(|| format!("scenario file {}", path.display()))
    }

    /// The built-in scenario called `name`.
    pub fn built_in(name: &str) -> anyhow::Result<Self> {
        let (name, text) = BUILT_IN.iter().find(|(n, _)| *n == name).ok_or_else(|| {
            let names: Vec<_> = BUILT_IN.iter().map(|(n, _)| *n).collect();
            anyhow::anyhow!("unknown scenario '{name}' (known: {})", names.join(", "))
        })?;
        Self::parse(name, text).with_context(|| format!("built-in scenario {name}"))
    }

    /// Every built-in scenario.
    pub fn all_built_in() -> anyhow::Result<Vec<Self>> {
        BUILT_IN.iter().map(|(n, _)| Self::built_in(n)).collect()
    }

    /// One line for `pmsm-sim list`.
    pub fn description(&self) -> &str {
        self.file.description.as_deref().unwrap_or("")
    }

    /// Whether the scenario asks for the ideal plant (`ideal = true`: the papers'
    /// experiments): `run` then simulates no noise, offsets, dead time or idle unless told.
    pub fn is_ideal(&self) -> bool {
        self.file.ideal.unwrap_or(false)
    }

    /// Whether the scenario runs the complete drive.
    pub fn is_drive(&self) -> bool {
        self.file.drive.unwrap_or(true)
    }

    /// The scenario's own motor (default: the Sinano motor).
    pub fn default_motor(&self) -> anyhow::Result<Motor> {
        let name = self.file.motor.as_deref().unwrap_or("sinano");
        motor::preset(name)
            .ok_or_else(|| anyhow::anyhow!("scenario {}: unknown motor '{name}'", self.name))
    }

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
        let load_kind = match f.load_kind.as_deref().unwrap_or("brake") {
            "brake" => LoadKind::Brake { sat_rpm: fade_rpm },
            "active" => LoadKind::Active,
            other => bail!("load_kind = \"{other}\": must be \"brake\" or \"active\""),
        };
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
        let initial_speed_rpm = one_of(
            "initial_speed",
            f.initial_speed,
            "initial_speed_rpm",
            f.initial_speed_rpm,
            rated_rpm,
        )?
        .unwrap_or(0.0);
        ensure!(
            initial_speed_rpm.is_finite()
                && initial_speed_rpm.abs() <= MAX_SPEED_FRACTION * rated_rpm,
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
        if let Some(i) = f.i_max_a {
            ensure!(i.is_finite() && i > 0.0, "i_max_a = {i}: must be > 0 A");
        }
        let speed_tolerance = f.speed_tolerance.unwrap_or(0.02);
        ensure!(
            speed_tolerance.is_finite() && speed_tolerance > 0.0,
            "speed_tolerance = {speed_tolerance}: must be > 0"
        );
        let is_drive = self.is_drive();
        let drive = if is_drive {
            let mut script = DriveScript::enabled();
            if let Some(e) = &f.enable {
                check_times("enable", e.iter().map(|p| p.0))?;
                script.enable = e.clone();
            }
            if let Some(i) = &f.inject {
                script.injection = Some(injection(i, &motor, f.duration_s)?);
            }
            if let Some(name) = &f.expect_fault {
                script.expect_fault = Some(fault_by_name(name)?);
            }
            Some(script)
        } else {
            for (key, set) in [
                ("enable", f.enable.is_some()),
                ("inject", f.inject.is_some()),
                ("expect_fault", f.expect_fault.is_some()),
            ] {
                ensure!(!set, "{key}: only drive scenarios (drive = true) take it");
            }
            None
        };
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
}

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
            only(&["r", "l", "flux"])?;
            Injection::Plant {
                t: i.t,
                r: factor("r", i.r)?,
                l: factor("l", i.l)?,
                flux: factor("flux", i.flux)?,
            }
        }
        "bus" => {
            only(&["bus"])?;
            let bus = i
                .bus
                .ok_or_else(|| anyhow::anyhow!("inject.bus: kind \"bus\" needs it"))?;
            ensure!(
                (0.0..=10.0).contains(&bus),
                "inject.bus = {bus}: a fraction of the rated bus in [0, 10]"
            );
            Injection::Bus {
                t: i.t,
                v: bus * motor.ratings.bus_v as f64,
            }
        }
        "nan_current" => {
            only(&[])?;
            Injection::NanCurrent { t: i.t }
        }
        other => bail!("inject.kind = \"{other}\": must be \"plant\", \"bus\" or \"nan_current\""),
    })
}

/// Every drive fault, by its snake-case name.
pub const FAULTS: [Fault; 8] = [
    Fault::Overcurrent,
    Fault::BusUndervoltage,
    Fault::BusOvervoltage,
    Fault::InvalidInput,
    Fault::ObserverLoss,
    Fault::Stall,
    Fault::Overrun,
    Fault::AdcOffset,
];

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

/// The built-in scenario called `name`, on its own motor.
pub fn by_name(name: &str) -> anyhow::Result<Scenario> {
    Spec::built_in(name)?.build_default()
}

/// Every built-in scenario on its own motor, in listing order.
pub fn all() -> anyhow::Result<Vec<Scenario>> {
    Spec::all_built_in()?
        .iter()
        .map(Spec::build_default)
        .collect()
}

/// A built-in scenario the tests use by name; it is compiled in and checked by the tests, so
/// a failure here is a broken file in `host-sim/scenarios/`.
fn built_in(name: &str) -> Scenario {
    match by_name(name) {
        Ok(s) => s,
        Err(e) => panic!("built-in scenario {name}: {e:#}"),
    }
}

/// Horng & Chin Sec 5 (`scenarios/horng-ramp-brake.toml`).
pub fn horng_ramp_brake() -> Scenario {
    built_in("horng-ramp-brake")
}

/// Ortega et al. Fig 5 (`scenarios/ortega-steps.toml`).
pub fn ortega_steps() -> Scenario {
    built_in("ortega-steps")
}

/// Ortega et al. Fig 8a (`scenarios/ortega-load-200.toml`).
pub fn ortega_load_200() -> Scenario {
    built_in("ortega-load-200")
}

/// Ortega et al. Fig 8b (`scenarios/ortega-load-800.toml`).
pub fn ortega_load_800() -> Scenario {
    built_in("ortega-load-800")
}

/// Ortega et al. Fig 9 (`scenarios/ortega-ramp.toml`).
pub fn ortega_ramp() -> Scenario {
    built_in("ortega-ramp")
}

/// The drive from standstill, stop and reverse (`scenarios/start-stop-reverse.toml`).
pub fn start_stop_reverse() -> Scenario {
    built_in("start-stop-reverse")
}

/// The drive on Ortega's test motor (`scenarios/start-test-motor.toml`).
pub fn start_test_motor() -> Scenario {
    built_in("start-test-motor")
}

/// A winding short → overcurrent (`scenarios/fault-overcurrent.toml`).
pub fn fault_overcurrent() -> Scenario {
    built_in("fault-overcurrent")
}

/// The bus halves → under-voltage (`scenarios/fault-bus-undervoltage.toml`).
pub fn fault_bus_undervoltage() -> Scenario {
    built_in("fault-bus-undervoltage")
}

/// A NaN current sample → invalid input (`scenarios/fault-nan-current.toml`).
pub fn fault_nan_current() -> Scenario {
    built_in("fault-nan-current")
}

/// Half the flux → observer loss (`scenarios/fault-observer-loss.toml`).
pub fn fault_observer_loss() -> Scenario {
    built_in("fault-observer-loss")
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The drive scenarios are written in fractions of the ratings: they build for every
    /// motor; the papers' experiments (absolute speeds and loads) on their own.
    #[test]
    fn every_built_in_scenario_builds() {
        for spec in Spec::all_built_in().unwrap() {
            spec.build_default().unwrap();
            if spec.is_drive() {
                for m in motor::PRESETS {
                    spec.build(m.name, m).unwrap();
                }
            }
        }
    }
}
