//! Named scenarios: motor, speed command, load profile, metric windows.

use crate::profile::Pwl;
use pmsm_sensorless::motor::{self, Motor};

/// A named interval over which metrics are computed \[s].
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    /// Name used in the JSON summary.
    pub name: &'static str,
    /// Start \[s].
    pub t0: f64,
    /// End \[s].
    pub t1: f64,
}

impl Window {
    /// A window named `name` from `t0` to `t1` \[s].
    pub const fn new(name: &'static str, t0: f64, t1: f64) -> Self {
        Self { name, t0, t1 }
    }
}

/// A simulated experiment.
#[derive(Clone, Debug)]
pub struct Scenario {
    /// Identifier on the command line.
    pub name: &'static str,
    /// One line for `pmsm-sim list`.
    pub description: &'static str,
    /// Motor name as shown in summaries.
    pub motor_name: String,
    /// The plant's motor (the controller's copy may carry mismatch factors).
    pub motor: Motor,
    /// Simulated duration \[s].
    pub duration_s: f64,
    /// Speed command [rpm, mechanical].
    pub speed_cmd_rpm: Pwl,
    /// Load torque shape, scaled by `load_nm` \[dimensionless].
    pub load_shape: Pwl,
    /// Load torque level \[N·m] (positive opposes positive rotation).
    pub load_nm: f64,
    /// Metric windows.
    pub windows: Vec<Window>,
    /// Rotor speed at t = 0 \[rpm].
    pub initial_speed_rpm: f64,
    /// Lowest operating speed \[rpm]: the flux observer's γ is chosen for it (Proposition 4).
    pub min_speed_rpm: f64,
    /// Limit of the speed loop's i_q \[A]; default 1.5× the current of rated torque.
    pub i_max_a: Option<f64>,
    /// The paper's figures this scenario reproduces (shown in the plot title).
    pub figures: &'static str,
    /// How the load torque depends on speed.
    pub load_kind: LoadKind,
    /// Run the complete drive (start-up, modes, faults) instead of FOC on an observer slot.
    pub drive: Option<DriveScript>,
}

/// How the load torque depends on speed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LoadKind {
    /// A constant torque opposing positive rotation (the papers' τ_L, eq (33)): it drives a
    /// motor at rest backwards.
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
    /// The enable command turns on at this time \[s]; the speed command is `speed_cmd_rpm`.
    pub enable_s: f64,
    /// A fault cause injected during the run.
    pub injection: Option<Injection>,
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
    /// The speed loop's current limit \[A].
    pub fn i_max_a(&self) -> f64 {
        self.i_max_a
            .unwrap_or(OVERLOAD * self.motor.rated_torque_current_a() as f64)
    }
}

impl Scenario {
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

/// Horng & Chin Sec 5: Sinano motor, 48 V bus, speed ramp 0 → 1000 rpm in 1.5 s then hold,
/// brake load 0.2 N·m from 3 s to 5 s, end at 6 s.
pub fn horng_ramp_brake() -> Scenario {
    Scenario {
        name: "horng-ramp-brake",
        description:
            "Horng & Chin Sec 5: Sinano motor, 0->1000 rpm ramp in 1.5 s, 0.2 N·m brake 3-5 s",
        motor_name: motor::HORNG_SINANO.name.to_string(),
        motor: motor::HORNG_SINANO,
        duration_s: 6.0,
        speed_cmd_rpm: Pwl::ramp(0.0, 0.0, 1.5, 1000.0),
        load_shape: Pwl::window(3.0, 5.0, 1.0),
        load_nm: 0.2,
        windows: vec![
            Window::new("ramp", 0.2, 1.5),
            Window::new("pre_brake", 2.0, 3.0),
            Window::new("brake", 3.5, 5.0),
            Window::new("post_brake", 5.5, 6.0),
        ],
        initial_speed_rpm: 0.0,
        min_speed_rpm: 100.0,
        i_max_a: None,
        figures: "Horng & Chin Figs 5-12",
        load_kind: LoadKind::Active,
        drive: None,
    }
}

/// Ortega et al. Sec V, Fig 5: the 40 kW simulation motor (240 V) with steps of speed
/// reference and load torque, current limited to the rated phase current (216 A rms → 305 A
/// peak = |i_αβ|, i.e. 134 N·m in the papers' model). Fig 5's exact step values are not in the
/// text; these are: 500 rpm at t = 0, reference 1500 rpm at 0.2 s, load 90 N·m (half the
/// rated torque) at 1.0 s, reference 1000 rpm at 2.0 s, load off at 2.8 s, end at 3.5 s.
pub fn ortega_steps() -> Scenario {
    let m = motor::ORTEGA_SIM_40KW;
    Scenario {
        name: "ortega-steps",
        description: "Ortega Fig 5: 40 kW motor, speed steps 500->1500->1000 rpm, 90 N·m load step",
        motor_name: m.name.to_string(),
        motor: m,
        duration_s: 3.5,
        speed_cmd_rpm: Pwl::new(vec![
            (0.2, 500.0),
            (0.2, 1500.0),
            (2.0, 1500.0),
            (2.0, 1000.0),
        ]),
        load_shape: Pwl::window(1.0, 2.8, 1.0),
        load_nm: 90.0,
        windows: vec![
            Window::new("w1500", 0.6, 1.0),
            Window::new("w1500_loaded", 1.5, 2.0),
            Window::new("w1000_loaded", 2.4, 2.8),
            Window::new("w1000", 3.2, 3.5),
        ],
        initial_speed_rpm: 500.0,
        min_speed_rpm: 500.0,
        i_max_a: Some(216.0 * std::f64::consts::SQRT_2),
        figures: "Ortega et al. Figs 5, 6",
        load_kind: LoadKind::Active,
        drive: None,
    }
}

/// Ortega et al. Sec V, Fig 8: the 0.3 kW test motor at `rpm` with a full-load (3 N·m) step at
/// 0.5 s; windows `before` and `loaded` (after the transient).
fn ortega_load(name: &'static str, description: &'static str, rpm: f64) -> Scenario {
    let m = motor::ORTEGA_TEST_0P3KW;
    Scenario {
        name,
        description,
        motor_name: m.name.to_string(),
        motor: m,
        duration_s: 2.0,
        speed_cmd_rpm: Pwl::constant(rpm),
        load_shape: Pwl::step(0.5, 1.0),
        load_nm: 3.0,
        windows: vec![
            Window::new("before", 0.2, 0.5),
            Window::new("loaded", 1.2, 2.0),
        ],
        initial_speed_rpm: rpm,
        min_speed_rpm: rpm,
        i_max_a: None,
        figures: "Ortega et al. Fig 8",
        load_kind: LoadKind::Active,
        drive: None,
    }
}

/// Ortega et al. Sec V, Fig 8a: the test motor at 200 rpm with a full-load (3 N·m) step at 0.5 s.
pub fn ortega_load_200() -> Scenario {
    ortega_load(
        "ortega-load-200",
        "Ortega Fig 8a: test motor, 3 N·m load step at 200 rpm",
        200.0,
    )
}

/// Ortega et al. Sec V, Fig 8b: the test motor at 800 rpm with a full-load (3 N·m) step at 0.5 s.
pub fn ortega_load_800() -> Scenario {
    ortega_load(
        "ortega-load-800",
        "Ortega Fig 8b: test motor, 3 N·m load step at 800 rpm",
        800.0,
    )
}

/// Ortega et al. Sec V, Fig 9: test motor, reference ramp 200 → 1000 rpm (0.5 s to 1.5 s),
/// no load.
pub fn ortega_ramp() -> Scenario {
    let m = motor::ORTEGA_TEST_0P3KW;
    Scenario {
        name: "ortega-ramp",
        description: "Ortega Fig 9: test motor, reference ramp 200->1000 rpm in 1 s",
        motor_name: m.name.to_string(),
        motor: m,
        duration_s: 2.5,
        speed_cmd_rpm: Pwl::ramp(0.5, 200.0, 1.5, 1000.0),
        load_shape: Pwl::constant(0.0),
        load_nm: 0.0,
        windows: vec![
            Window::new("w200", 0.2, 0.5),
            Window::new("ramp", 0.7, 1.5),
            Window::new("w1000", 2.0, 2.5),
        ],
        initial_speed_rpm: 200.0,
        min_speed_rpm: 200.0,
        i_max_a: None,
        figures: "Ortega et al. Fig 9",
        load_kind: LoadKind::Active,
        drive: None,
    }
}

/// The drive on the Sinano motor from standstill, no encoder at any time: 0 → 1000 rpm, a
/// 0.2 N·m brake from 2 s on, stop at 3 s, reverse to −500 rpm at 4.5 s, stop at 6 s.
/// The brake opposes the motion and fades below 30 rpm. Windows after each settle.
pub fn start_stop_reverse() -> Scenario {
    let m = motor::HORNG_SINANO;
    Scenario {
        name: "start-stop-reverse",
        description:
            "drive: Sinano from standstill to 1000 rpm, 0.2 N·m brake, stop, -500 rpm, stop",
        motor_name: m.name.to_string(),
        motor: m,
        duration_s: 7.0,
        speed_cmd_rpm: Pwl::new(vec![
            (0.0, 1000.0),
            (3.0, 1000.0),
            (3.0, 0.0),
            (4.5, 0.0),
            (4.5, -500.0),
            (6.0, -500.0),
            (6.0, 0.0),
        ]),
        load_shape: Pwl::step(2.0, 1.0),
        load_nm: 0.2,
        windows: vec![
            Window::new("w1000", 1.6, 2.0),
            Window::new("w1000_loaded", 2.5, 3.0),
            Window::new("w_neg500_loaded", 5.6, 6.0),
        ],
        initial_speed_rpm: 0.0,
        min_speed_rpm: 60.0,
        i_max_a: None,
        figures: "drive",
        load_kind: LoadKind::Brake { sat_rpm: 30.0 },
        drive: Some(DriveScript {
            enable_s: 0.0,
            injection: None,
        }),
    }
}

/// The drive on Ortega's test motor from standstill to 800 rpm; full load (3 N·m brake) at
/// 1.5 s, after the hand-over.
pub fn start_test_motor() -> Scenario {
    let m = motor::ORTEGA_TEST_0P3KW;
    Scenario {
        name: "start-test-motor",
        description: "drive: Ortega test motor from standstill to 800 rpm, 3 N·m at 1.5 s",
        motor_name: m.name.to_string(),
        motor: m,
        duration_s: 2.5,
        speed_cmd_rpm: Pwl::constant(800.0),
        load_shape: Pwl::step(1.5, 1.0),
        load_nm: 3.0,
        windows: vec![
            Window::new("w800", 1.1, 1.5),
            Window::new("w800_loaded", 2.0, 2.5),
        ],
        // Drive settings (brake load, start from standstill, enabled at 0) as there.
        ..start_stop_reverse()
    }
}

/// A fault scenario: the drive runs the Sinano motor up to 1000 rpm, then `injection` at
/// 1.8 s; the run ends at 2.2 s.
fn fault(name: &'static str, description: &'static str, injection: Injection) -> Scenario {
    Scenario {
        name,
        description,
        duration_s: 2.2,
        speed_cmd_rpm: Pwl::constant(1000.0),
        load_shape: Pwl::constant(0.0),
        load_nm: 0.0,
        windows: vec![Window::new("before", 1.4, 1.8)],
        drive: Some(DriveScript {
            enable_s: 0.0,
            injection: Some(injection),
        }),
        ..start_stop_reverse()
    }
}

/// A winding short (R and L to 10 %) at 1000 rpm: the current runs away → overcurrent.
pub fn fault_overcurrent() -> Scenario {
    fault(
        "fault-overcurrent",
        "drive fault: winding short (R, L to 10 %) at 1.8 s",
        Injection::Plant {
            t: 1.8,
            r: 0.1,
            l: 0.1,
            flux: 1.0,
        },
    )
}

/// The bus drops from 48 V to 24 V at 1.8 s → bus under-voltage.
pub fn fault_bus_undervoltage() -> Scenario {
    fault(
        "fault-bus-undervoltage",
        "drive fault: bus 48 V -> 24 V at 1.8 s",
        Injection::Bus { t: 1.8, v: 24.0 },
    )
}

/// The phase-b current sample reads NaN from 1.8 s → invalid input.
pub fn fault_nan_current() -> Scenario {
    fault(
        "fault-nan-current",
        "drive fault: phase-b current sample NaN from 1.8 s",
        Injection::NanCurrent { t: 1.8 },
    )
}

/// The magnets lose half their flux at 1.8 s (the model the observers use no longer holds)
/// → observer loss.
pub fn fault_observer_loss() -> Scenario {
    fault(
        "fault-observer-loss",
        "drive fault: flux linkage drops to 50 % at 1.8 s",
        Injection::Plant {
            t: 1.8,
            r: 1.0,
            l: 1.0,
            flux: 0.5,
        },
    )
}

/// Every scenario, in listing order.
pub fn all() -> Vec<Scenario> {
    vec![
        horng_ramp_brake(),
        ortega_steps(),
        ortega_load_200(),
        ortega_load_800(),
        ortega_ramp(),
        start_stop_reverse(),
        start_test_motor(),
        fault_overcurrent(),
        fault_bus_undervoltage(),
        fault_nan_current(),
        fault_observer_loss(),
    ]
}

/// The scenario called `name`.
pub fn by_name(name: &str) -> anyhow::Result<Scenario> {
    all().into_iter().find(|s| s.name == name).ok_or_else(|| {
        let names: Vec<_> = all().iter().map(|s| s.name).collect();
        anyhow::anyhow!("unknown scenario '{name}' (known: {})", names.join(", "))
    })
}
