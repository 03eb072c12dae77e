//! A scenario file as written ([`ScenarioFile`], its format in the module doc of
//! [`crate::scenario`]), and a scenario by name with its file ([`Spec`]).

use anyhow::Context;
use pmsm_sensorless::motor::{self, Motor};
use serde::Deserialize;
use std::path::Path;

/// A scenario file as written (see the module doc).
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScenarioFile {
    pub(super) description: Option<String>,
    pub(super) figures: Option<String>,
    pub(super) motor: Option<String>,
    pub(super) drive: Option<bool>,
    pub(super) duration_s: f64,
    pub(super) speed: Option<Vec<(f64, f64)>>,
    pub(super) speed_rpm: Option<Vec<(f64, f64)>>,
    pub(super) load: Option<Vec<(f64, f64)>>,
    pub(super) load_nm: Option<Vec<(f64, f64)>>,
    pub(super) load_kind: Option<String>,
    pub(super) brake_fade: Option<f64>,
    pub(super) brake_fade_rpm: Option<f64>,
    pub(super) windows: Vec<(String, f64, f64)>,
    pub(super) initial_speed: Option<f64>,
    pub(super) initial_speed_rpm: Option<f64>,
    pub(super) enable: Option<Vec<(f64, bool)>>,
    pub(super) clear_fault: Option<Vec<f64>>,
    pub(super) terminal_sensing: Option<bool>,
    pub(super) min_speed: Option<f64>,
    pub(super) min_speed_rpm: Option<f64>,
    pub(super) i_max_a: Option<f64>,
    pub(super) inject: Option<InjectFile>,
    pub(super) expect_fault: Option<String>,
    pub(super) speed_tolerance: Option<f64>,
    pub(super) locked_rotor: Option<bool>,
    pub(super) ideal: Option<bool>,
    pub(super) dc_link: Option<DcLinkFile>,
}

/// `[inject]` of a scenario file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct InjectFile {
    pub(super) t: f64,
    pub(super) kind: String,
    pub(super) r: Option<f64>,
    pub(super) l: Option<f64>,
    pub(super) flux: Option<f64>,
    pub(super) bus: Option<f64>,
    pub(super) until: Option<f64>,
    pub(super) phase: Option<String>,
    pub(super) gain: Option<f64>,
}

/// `[dc_link]` of a scenario file.
#[derive(Clone, Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(super) struct DcLinkFile {
    pub(super) capacitance_uf: Option<f64>,
    pub(super) source_ohm: Option<f64>,
    pub(super) sink_a: Option<f64>,
    pub(super) brake_ohm: Option<f64>,
    pub(super) brake_on: Option<f64>,
    pub(super) brake_off: Option<f64>,
    pub(super) brake_by_drive: Option<bool>,
}

/// A scenario: its name and its file.
#[derive(Clone, Debug)]
pub struct Spec {
    /// Identifier (the file's stem).
    pub name: String,
    /// The file's contents.
    pub file: ScenarioFile,
}

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
}
