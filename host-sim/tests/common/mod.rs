//! What the tests share: the command line, the zoo's motor files.

use std::process::{Command, Output};

/// The zoo motor of `host-sim/motors/zoo/FILE.toml`.
#[allow(dead_code)] // not every test uses it
pub fn zoo(file: &str) -> pmsm_sensorless::motor::Motor {
    let path = format!("{}/motors/zoo/{file}.toml", env!("CARGO_MANIFEST_DIR"));
    pmsm_host_sim::motor_file::load(std::path::Path::new(&path))
        .unwrap()
        .1
}

/// `pmsm-sim ARGS`, run to its end.
#[allow(dead_code)] // not every test uses it
pub fn sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pmsm-sim"))
        .args(args)
        .output()
        .expect("pmsm-sim runs")
}

/// The JSON summary of `pmsm-sim ARGS --json`, and its exit code.
#[allow(dead_code)] // not every test uses it
pub fn run_json(args: &[&str]) -> (serde_json::Value, Option<i32>) {
    let out = sim(&[args, &["--json"]].concat());
    let v = serde_json::from_slice(&out.stdout).unwrap_or_else(|e| {
        panic!(
            "{e}: stdout {:?} stderr {:?}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )
    });
    (v, out.status.code())
}
