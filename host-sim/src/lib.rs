//! `pmsm-host-sim`: the PMSM plant simulator that runs the `pmsm-sensorless` core on the host.
//!
//! f64 plant (Horng & Chin eqs (16)-(19)) integrated with RK4, averaged inverter, current
//! sensor with seeded noise, scenarios of both papers, metrics, CSV/PNG/JSON output.

pub mod bounds;
pub mod cycles;
pub mod identify;
pub mod inverter;
pub mod motor_file;
pub mod observer;
pub mod output;
pub mod plant;
pub mod plot;
pub mod profile;
pub mod scenario;
pub mod sim;
pub mod summary;
pub mod sweep;

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
