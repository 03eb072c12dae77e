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
            Window {
                name: "ramp",
                t0: 0.2,
                t1: 1.5,
            },
            Window {
                name: "pre_brake",
                t0: 2.0,
                t1: 3.0,
            },
            Window {
                name: "brake",
                t0: 3.5,
                t1: 5.0,
            },
            Window {
                name: "post_brake",
                t0: 5.5,
                t1: 6.0,
            },
        ],
    }
}

/// Every scenario, in listing order.
pub fn all() -> Vec<Scenario> {
    vec![horng_ramp_brake()]
}

/// The scenario called `name`.
pub fn by_name(name: &str) -> anyhow::Result<Scenario> {
    all().into_iter().find(|s| s.name == name).ok_or_else(|| {
        let names: Vec<_> = all().iter().map(|s| s.name).collect();
        anyhow::anyhow!("unknown scenario '{name}' (known: {})", names.join(", "))
    })
}
