//! `pmsm-host-sim`: the PMSM plant simulator that runs the `pmsm-sensorless` core on the host.
//!
//! The plant is the `pmsm-plant` crate (f64, Horng & Chin eqs (16)-(19), RK4), re-exported as
//! [`plant`]; around it, by concern:
//! - [`board`]: the simulated board ([`board::SimBoard`]): its converter, its sensors with
//!   seeded noise, and the loop a firmware drives through the core's `PowerStage`;
//! - [`sim`]: one closed-loop run of a scenario: its configuration, the controller (the
//!   complete drive, or FOC on one observer), the trace's rows;
//! - [`observer`]: the observers of the papers' experiments and their bare FOC loop;
//! - [`scenario`]: what a run is asked to do, from TOML files (built in or the user's);
//! - [`identify`]: the core's identification run against the plant;
//! - [`analysis`]: the sliding gain's bounds and the firmware's cycle counts;
//! - [`report`]: the verdict and summary of a run, its CSV and plot, the sweeps;
//! - [`motor_file`], [`names`], [`plot`]: motor files, the names of faults, the plots.

pub mod analysis;
pub mod board;
pub mod identify;
pub mod motor_file;
pub mod names;
pub mod observer;
pub mod plot;
pub mod report;
pub mod scenario;
pub mod sim;

pub use pmsm_plant as plant;

/// rad/s per rpm.
pub const RAD_S_PER_RPM: f64 = std::f64::consts::PI / 30.0;

/// A number in a message as an engineer writes it: plain from 0.001 to 10⁶, else in
/// exponent form (`1e30`, not thirty zeros), the way the core's errors print theirs.
pub fn number(v: f64) -> String {
    let a = v.abs();
    if a == 0.0 || !a.is_finite() || (1e-3..1e6).contains(&a) {
        format!("{v}")
    } else {
        format!("{v:e}")
    }
}

/// A TOML file's text as `T`; the error is one line, the parser's message and its line.
pub fn from_toml<T: serde::de::DeserializeOwned>(text: &str) -> anyhow::Result<T> {
    toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| {
                format!(
                    " (line {})",
                    text[..s.start.min(text.len())].lines().count().max(1)
                )
            })
            .unwrap_or_default();
        anyhow::anyhow!("{}{line}", e.message().trim())
    })
}

/// A table of the CLI's one style, with `header`; columns `right` aligned right (numbers).
pub fn table(header: &[&str], right: &[usize]) -> comfy_table::Table {
    let mut t = comfy_table::Table::new();
    t.load_style(comfy_table::presets::UTF8_FULL_CONDENSED);
    t.set_header(header.to_vec());
    for &k in right {
        if let Some(c) = t.column_mut(k) {
            c.set_cell_alignment(comfy_table::CellAlignment::Right);
        }
    }
    t
}
