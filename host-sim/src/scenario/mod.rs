//! Scenarios: what the simulated drive is asked to do ([`Scenario`]), from TOML files
//! ([`Spec`]: the format in [`mod@file`], the checks and the conversion for one motor in [`build`],
//! the files compiled in in [`built_in`]; the time profiles in [`profile`]).
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
//! clear_fault = [2.0]             # a latched fault cleared in the period at each time
//! terminal_sensing = false        # the board senses no terminal voltage (default: it does)
//! expect_fault = "stall"          # the run passes only if the drive faults so
//! [inject]                        # a fault cause: kind = "plant" (factors r, l, flux; with
//!                                 # `until`, r and flux reached linearly from t to it),
//! t = 1.8                         # "bus" (bus, a fraction of the rated bus, and `until`, the
//! kind = "plant"                  # time it recovers: a sag), "nan_current", "task_stall",
//! r = 0.1                         # or a phase current sensor failed (`phase` = "a" (default),
//!                                 # "b" or "c"): "sensor_stuck" (holds its last reading),
//!                                 # "sensor_zero" (reads no current: its offset and noise
//!                                 # alone), "sensor_gain" (`gain`, e.g. 0.9: reads 90 %)
//! [dc_link]                       # a DC link instead of the stiff bus (every key optional)
//! capacitance_uf = 158.0          # default: P·50 µs/(0.01·V²), the rated DC-link current P/V
//!                                 # for one 20 kHz PWM period with a 1 % droop
//! source_ohm = 0.63               # the supply's resistance; default 0.02·V²/P (2 % droop at P)
//! sink_a = 0.0                    # the most current the supply takes back; default 0: a diode
//! brake_ohm = 20.0                # a brake chopper's resistor; default: none
//! brake_on = 1.15                 # its switch-on and switch-off voltages, fractions of the
//! brake_off = 1.10                # rated bus (defaults 1.15 and 1.10; the drive trips at 1.25)
//! brake_by_drive = false         # true: the chopper's gate is the drive's brake output
//!                                 # (`DriveOutput::brake`), its thresholds unused
//! ```
//!
//! With a `[dc_link]` (`V`, `P`: the motor's rated bus and power), the bus is a capacitor fed
//! by the supply at the rated bus through `source_ohm` and a diode (sinking at most `sink_a`),
//! with the chopper across it (the model: `pmsm_plant::supply::dc_link`): braking returns
//! energy into it and raises the bus. The run's CSV then has a `v_bus_v` column and its JSON
//! summary a `bus_peak_v`. `run --dc-link-uf`, `--supply-sink-a` and `--brake-ohm` set a link
//! (over the scenario's, or the defaults) from the command line.
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

pub mod build;
pub mod built_in;
pub mod file;
pub mod profile;

pub use built_in::{
    all, by_name, fault_bus_undervoltage, fault_nan_current, fault_observer_loss,
    fault_overcurrent, fault_task_stall, horng_ramp_brake, ortega_load_200, ortega_load_800,
    ortega_ramp, ortega_steps, start_stop_reverse, start_test_motor,
};
pub use file::{ScenarioFile, Spec};

use self::profile::Pwl;
use crate::board::SensorFault;
use pmsm_sensorless::drive::Fault;
use pmsm_sensorless::motor::Motor;

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
    /// The times \[s] at which a latched fault is cleared (the command `clear_fault` set for
    /// the period containing each).
    pub clear_fault: Vec<f64>,
    /// A fault cause injected during the run.
    pub injection: Option<Injection>,
    /// The fault the scenario expects (the run fails without it).
    pub expect_fault: Option<Fault>,
    /// The board senses the terminal voltage (`None`: as the board says,
    /// [`SimBoard::sense_terminal_voltage`](crate::board::SimBoard::sense_terminal_voltage));
    /// `run --terminal-sensing` replaces it.
    pub terminal_sensing: Option<bool>,
}

impl DriveScript {
    /// Enabled throughout, nothing injected, no fault expected.
    pub fn enabled() -> Self {
        Self {
            enable: Vec::new(),
            clear_fault: Vec::new(),
            injection: None,
            expect_fault: None,
            terminal_sensing: None,
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

    /// The command `clear_fault` in the period `[t, t + ts)` \[s]: one of the times is in it.
    pub fn clear_fault_in(&self, t: f64, ts: f64) -> bool {
        self.clear_fault.iter().any(|&tc| tc >= t && tc < t + ts)
    }
}

/// A fault cause.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Injection {
    /// The plant's R, L and flux are multiplied by these factors at `t` (a winding short, a
    /// demagnetisation), or R and flux reach theirs linearly from `t` to `until` (a winding
    /// warming).
    Plant {
        /// Time \[s].
        t: f64,
        /// Factor on R.
        r: f64,
        /// Factor on L.
        l: f64,
        /// Factor on the flux linkage.
        flux: f64,
        /// When the factors are reached \[s] (`None`: at `t`, a step).
        until: Option<f64>,
    },
    /// The DC bus (a DC link's supply) steps to `v` at `t`, and back to the board's at
    /// `until` if given (a sag and its recovery).
    Bus {
        /// Time \[s].
        t: f64,
        /// New bus voltage \[V].
        v: f64,
        /// When the bus recovers \[s] (`None`: never).
        until: Option<f64>,
    },
    /// The current sample of phase b reads NaN from `t` on.
    NanCurrent {
        /// Time \[s].
        t: f64,
    },
    /// The drive's 1 kHz task stalls from `t` on (a main loop stuck, the interrupt still
    /// running): the control loop runs only its step (`Control::step`), never the tick.
    TaskStall {
        /// Time \[s].
        t: f64,
    },
    /// One phase's current sensor fails from `t` on: stuck at its last reading, reading
    /// zero, or off by a gain ([`SensorFault`]).
    CurrentSensor {
        /// Time \[s].
        t: f64,
        /// The phase, 0..3 (a, b, c).
        phase: usize,
        /// How it fails.
        fault: SensorFault,
    },
}

impl Injection {
    /// A plant injection's factors on R and on the flux linkage at time `t` \[s] (1 before it
    /// happens; `None`: not a plant injection). The simulator asks at the middle of a period
    /// (`t + T/2`), as it decides whether an injection's time has come.
    pub fn plant_factors_at(&self, t: f64) -> Option<(f64, f64)> {
        let Injection::Plant {
            t: t0,
            r,
            flux,
            until,
            ..
        } = *self
        else {
            return None;
        };
        let k = match until {
            Some(u) => ((t - t0) / (u - t0)).clamp(0.0, 1.0),
            None if t >= t0 => 1.0,
            None => 0.0,
        };
        Some((1.0 + (r - 1.0) * k, 1.0 + (flux - 1.0) * k))
    }

    /// When it happens \[s].
    pub fn t(&self) -> f64 {
        match *self {
            Injection::Plant { t, .. }
            | Injection::Bus { t, .. }
            | Injection::NanCurrent { t }
            | Injection::TaskStall { t }
            | Injection::CurrentSensor { t, .. } => t,
        }
    }
}

/// Default overload factor of the current limit over the current of rated torque.
pub const OVERLOAD: f64 = 1.5;

impl Scenario {
    /// `motor` held at `rpm` by the sensored controller for `duration_s` \[s] under an active
    /// load of `load_nm` \[N·m], one window over the whole run: the observers' tests against
    /// the plant at constant speed.
    pub fn constant_speed(
        name: &str,
        motor: Motor,
        rpm: f64,
        load_nm: f64,
        duration_s: f64,
    ) -> Self {
        Scenario {
            name: name.into(),
            description: "constant speed, sensored".into(),
            motor_name: motor.name.to_string(),
            motor,
            duration_s,
            speed_cmd_rpm: Pwl::constant(rpm),
            load_shape: Pwl::constant(1.0),
            load_nm,
            windows: vec![Window::new("all", 0.0, duration_s)],
            initial_speed_rpm: rpm,
            min_speed_rpm: rpm,
            i_max_a: None,
            figures: String::new(),
            load_kind: LoadKind::Active,
            drive: None,
            speed_tolerance: 0.02,
            locked_rotor: false,
        }
    }

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
                let x = omega_m / (sat_rpm * crate::RAD_S_PER_RPM);
                level * x.clamp(-1.0, 1.0)
            }
        }
    }
}
