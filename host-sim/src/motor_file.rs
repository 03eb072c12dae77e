//! Motors from TOML files (`--motor-file FILE.toml`), validated by the core.
//!
//! ```toml
//! name = "my-motor"
//! pole_pairs = 4
//! r_ohm = 2.5
//! l_h = 5.97e-3
//! flux_wb = 5.795e-2   # Horng's K = Ortega's Φ
//! j_kgm2 = 6.45e-5
//! b_nms = 8.06e-5      # may be 0
//! [ratings]
//! bus_v = 48.0
//! current_a = 3.0
//! torque_nm = 0.695
//! speed_rpm = 1000.0
//! power_w = 73.0
//! ```

use pmsm_sensorless::motor::{Motor, MotorParams, Ratings};
use serde::Deserialize;
use std::path::Path;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MotorFile {
    name: String,
    pole_pairs: i64,
    r_ohm: f64,
    l_h: f64,
    flux_wb: f64,
    j_kgm2: f64,
    b_nms: f64,
    ratings: RatingsFile,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RatingsFile {
    bus_v: f64,
    current_a: f64,
    torque_nm: f64,
    speed_rpm: f64,
    power_w: f64,
}

/// Parses and validates a motor file's text; the error is one line naming the bad field.
pub fn parse(text: &str) -> anyhow::Result<(String, Motor)> {
    let f: MotorFile = toml::from_str(text).map_err(|e| {
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
    })?;
    let pole_pairs = u32::try_from(f.pole_pairs)
        .ok()
        .filter(|&n| n > 0)
        .ok_or_else(|| anyhow::anyhow!("pole_pairs: must be a positive integer"))?;
    let params = MotorParams::new(
        pole_pairs,
        f.r_ohm as f32,
        f.l_h as f32,
        f.flux_wb as f32,
        f.j_kgm2 as f32,
        f.b_nms as f32,
    )
    .map_err(|e| anyhow::anyhow!("{e}"))?;
    let r = &f.ratings;
    let ratings = Ratings {
        bus_v: r.bus_v as f32,
        current_a: r.current_a as f32,
        torque_nm: r.torque_nm as f32,
        speed_rpm: r.speed_rpm as f32,
        power_w: r.power_w as f32,
    }
    .validate()
    .map_err(|e| anyhow::anyhow!("ratings.{e}"))?;
    Ok((
        f.name,
        Motor {
            name: "file",
            params,
            ratings,
        },
    ))
}

/// Reads and validates a motor file.
pub fn load(path: &Path) -> anyhow::Result<(String, Motor)> {
    let text =
        std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    parse(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}
