//! The built-in scenarios: the files in `host-sim/scenarios/`, compiled in, in listing
//! order, and the ones the tests use by name.

use super::file::Spec;
use super::Scenario;
use anyhow::Context;

/// The built-in scenario files, in listing order.
const BUILT_IN: [(&str, &str); 49] = [
    (
        "horng-ramp-brake",
        include_str!("../../scenarios/horng-ramp-brake.toml"),
    ),
    (
        "ortega-steps",
        include_str!("../../scenarios/ortega-steps.toml"),
    ),
    (
        "ortega-load-200",
        include_str!("../../scenarios/ortega-load-200.toml"),
    ),
    (
        "ortega-load-800",
        include_str!("../../scenarios/ortega-load-800.toml"),
    ),
    (
        "ortega-ramp",
        include_str!("../../scenarios/ortega-ramp.toml"),
    ),
    (
        "start-stop-reverse",
        include_str!("../../scenarios/start-stop-reverse.toml"),
    ),
    (
        "start-test-motor",
        include_str!("../../scenarios/start-test-motor.toml"),
    ),
    (
        "ramp-brake-drive",
        include_str!("../../scenarios/ramp-brake-drive.toml"),
    ),
    (
        "fault-overcurrent",
        include_str!("../../scenarios/fault-overcurrent.toml"),
    ),
    (
        "fault-bus-undervoltage",
        include_str!("../../scenarios/fault-bus-undervoltage.toml"),
    ),
    (
        "fault-nan-current",
        include_str!("../../scenarios/fault-nan-current.toml"),
    ),
    (
        "fault-observer-loss",
        include_str!("../../scenarios/fault-observer-loss.toml"),
    ),
    (
        "sup-load-steps-50",
        include_str!("../../scenarios/sup-load-steps-50.toml"),
    ),
    (
        "sup-load-steps-100",
        include_str!("../../scenarios/sup-load-steps-100.toml"),
    ),
    (
        "sup-start-brake-100",
        include_str!("../../scenarios/sup-start-brake-100.toml"),
    ),
    (
        "sup-start-active-50",
        include_str!("../../scenarios/sup-start-active-50.toml"),
    ),
    (
        "sup-catch-50",
        include_str!("../../scenarios/sup-catch-50.toml"),
    ),
    (
        "sup-catch-neg50",
        include_str!("../../scenarios/sup-catch-neg50.toml"),
    ),
    (
        "sup-catch-100",
        include_str!("../../scenarios/sup-catch-100.toml"),
    ),
    (
        "sup-catch-neg100",
        include_str!("../../scenarios/sup-catch-neg100.toml"),
    ),
    (
        "sup-low-speed-3",
        include_str!("../../scenarios/sup-low-speed-3.toml"),
    ),
    (
        "sup-locked-rated",
        include_str!("../../scenarios/sup-locked-rated.toml"),
    ),
    (
        "sup-locked-slow",
        include_str!("../../scenarios/sup-locked-slow.toml"),
    ),
    (
        "sup-reverse-20",
        include_str!("../../scenarios/sup-reverse-20.toml"),
    ),
    (
        "warm-winding",
        include_str!("../../scenarios/warm-winding.toml"),
    ),
    (
        "warm-winding-150",
        include_str!("../../scenarios/warm-winding-150.toml"),
    ),
    (
        "warm-winding-loaded",
        include_str!("../../scenarios/warm-winding-loaded.toml"),
    ),
    (
        "profile-slow-ramp-3",
        include_str!("../../scenarios/profile-slow-ramp-3.toml"),
    ),
    (
        "profile-step-3",
        include_str!("../../scenarios/profile-step-3.toml"),
    ),
    (
        "profile-down-3",
        include_str!("../../scenarios/profile-down-3.toml"),
    ),
    (
        "profile-catch-neg50-pos30",
        include_str!("../../scenarios/profile-catch-neg50-pos30.toml"),
    ),
    (
        "profile-reversal",
        include_str!("../../scenarios/profile-reversal.toml"),
    ),
    (
        "stop-regen",
        include_str!("../../scenarios/stop-regen.toml"),
    ),
    (
        "fault-task-stall",
        include_str!("../../scenarios/fault-task-stall.toml"),
    ),
    (
        "fault-overspeed",
        include_str!("../../scenarios/fault-overspeed.toml"),
    ),
    (
        "fault-sensor-stuck",
        include_str!("../../scenarios/fault-sensor-stuck.toml"),
    ),
    (
        "fault-sensor-zero",
        include_str!("../../scenarios/fault-sensor-zero.toml"),
    ),
    (
        "fault-sensor-gain",
        include_str!("../../scenarios/fault-sensor-gain.toml"),
    ),
    (
        "overhaul-hold",
        include_str!("../../scenarios/overhaul-hold.toml"),
    ),
    (
        "fault-hanging-load",
        include_str!("../../scenarios/fault-hanging-load.toml"),
    ),
    (
        "stop-regen-brake",
        include_str!("../../scenarios/stop-regen-brake.toml"),
    ),
    (
        "catch-no-terminal-50",
        include_str!("../../scenarios/catch-no-terminal-50.toml"),
    ),
    (
        "catch-no-terminal-neg50",
        include_str!("../../scenarios/catch-no-terminal-neg50.toml"),
    ),
    (
        "catch-no-terminal-100",
        include_str!("../../scenarios/catch-no-terminal-100.toml"),
    ),
    (
        "catch-no-terminal-neg100",
        include_str!("../../scenarios/catch-no-terminal-neg100.toml"),
    ),
    (
        "start-active-80",
        include_str!("../../scenarios/start-active-80.toml"),
    ),
    (
        "start-active-120",
        include_str!("../../scenarios/start-active-120.toml"),
    ),
    (
        "fault-clear-recatch",
        include_str!("../../scenarios/fault-clear-recatch.toml"),
    ),
    (
        "enable-storm",
        include_str!("../../scenarios/enable-storm.toml"),
    ),
];

impl Spec {
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

/// The 1 kHz task stalls → task stall (`scenarios/fault-task-stall.toml`).
pub fn fault_task_stall() -> Scenario {
    built_in("fault-task-stall")
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmsm_sensorless::motor;

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
