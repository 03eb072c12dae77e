//! Named scenarios: motor, speed command, load profile, metric windows.

use crate::profile::Pwl;
use pmsm_sensorless::motor::{self, Motor};

/// A named interval over which metrics are computed [s].
#[derive(Clone, Debug, PartialEq)]
pub struct Window {
    /// Name used in the JSON summary.
    pub name: &'static str,
    /// Start [s].
    pub t0: f64,
    /// End [s].
    pub t1: f64,
}

impl Window {
    /// A window named `name` from `t0` to `t1` [s].
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
    /// Simulated duration [s].
    pub duration_s: f64,
    /// Speed command [rpm, mechanical].
    pub speed_cmd_rpm: Pwl,
    /// Load torque shape, scaled by `load_nm` [dimensionless].
    pub load_shape: Pwl,
    /// Load torque level [N·m] (positive opposes positive rotation).
    pub load_nm: f64,
    /// Metric windows.
    pub windows: Vec<Window>,
    /// Rotor speed at t = 0 [rpm].
    pub initial_speed_rpm: f64,
    /// Lowest operating speed [rpm]: the flux observer's γ is chosen for it (Proposition 4).
    pub min_speed_rpm: f64,
    /// Limit of the speed loop's i_q [A]; default 1.5× the current of rated torque.
    pub i_max_a: Option<f64>,
    /// The paper's figures this scenario reproduces (shown in the plot title).
    pub figures: &'static str,
}

/// Default overload factor of the current limit over the current of rated torque.
pub const OVERLOAD: f64 = 1.5;

impl Scenario {
    /// The speed loop's current limit [A].
    pub fn i_max_a(&self) -> f64 {
        self.i_max_a
            .unwrap_or(OVERLOAD * self.motor.rated_torque_current_a() as f64)
    }
}

impl Scenario {
    /// Load torque at `t` [N·m].
    pub fn load_at(&self, t: f64) -> f64 {
        self.load_nm * self.load_shape.at(t)
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
    }
}

/// [`ortega_load`] at 200 rpm.
pub fn ortega_load_200() -> Scenario {
    ortega_load(
        "ortega-load-200",
        "Ortega Fig 8a: test motor, 3 N·m load step at 200 rpm",
        200.0,
    )
}

/// [`ortega_load`] at 800 rpm.
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
    }
}

/// Every scenario, in listing order.
pub fn all() -> Vec<Scenario> {
    vec![
        horng_ramp_brake(),
        ortega_steps(),
        ortega_load_200(),
        ortega_load_800(),
        ortega_ramp(),
    ]
}

/// The scenario called `name`.
pub fn by_name(name: &str) -> anyhow::Result<Scenario> {
    all().into_iter().find(|s| s.name == name).ok_or_else(|| {
        let names: Vec<_> = all().iter().map(|s| s.name).collect();
        anyhow::anyhow!("unknown scenario '{name}' (known: {})", names.join(", "))
    })
}
