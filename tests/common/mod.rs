//! What the core's integration tests share.

use pmsm_host_sim::motor_file;
use pmsm_sensorless::motor::Motor;

/// Every zoo motor (`host-sim/motors/zoo/*.toml`, by file name) and the presets, by name.
#[allow(dead_code)] // not every test uses it
pub fn all_motors() -> Vec<(String, Motor)> {
    let dir = format!("{}/host-sim/motors/zoo", env!("CARGO_MANIFEST_DIR"));
    let mut all: Vec<(String, Motor)> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .filter_map(|p| {
            let m = motor_file::load(&p).ok()?.1;
            Some((p.file_stem()?.to_string_lossy().into_owned(), m))
        })
        .collect();
    all.sort_by(|a, b| a.0.cmp(&b.0));
    for m in pmsm_sensorless::motor::PRESETS {
        all.push((m.name.to_string(), m));
    }
    all
}

/// A seeded generator in [−1, 1] (deterministic): a 64-bit LCG (Knuth's MMIX constants) read
/// at 53 bits as an f64 or at 24 bits as an f32.
pub struct Lcg(pub u64);

impl Lcg {
    fn step(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        self.0
    }

    /// The next value as an f64 (53 bits).
    #[allow(dead_code)] // not every test uses both widths
    pub fn next_f64(&mut self) -> f64 {
        (self.step() >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }

    /// The next value as an f32 (24 bits).
    #[allow(dead_code)]
    pub fn next_f32(&mut self) -> f32 {
        (self.step() >> 40) as f32 / (1u64 << 24) as f32 * 2.0 - 1.0
    }
}
