//! Scenario files, the verdict of `run` (exit 3 on a failed run) and `sweep`.

mod common;
use common::{run_json, sim};

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// A fresh directory for one test.
fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pmsm-sim-scn-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Writes `text` as `name` in `dir`.
fn write(dir: &Path, name: &str, text: &str) -> String {
    let p = dir.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_string_lossy().into_owned()
}

fn assert_error(out: &Output, needle: &str) {
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(needle), "{err:?} lacks {needle:?}");
    assert!(!err.contains("panicked"), "{err}");
}

/// The torque observer loses lock when the paper's 0.2 N·m brake is removed at once (5 s,
/// `README` "Findings"). With the post-brake window left out, every window is fine: the run
/// must fail all the same, with the time lock was lost, and exit 3.
#[test]
fn a_run_that_loses_lock_between_windows_fails() {
    let dir = tmp_dir("lock");
    let text = include_str!("../scenarios/horng-ramp-brake.toml").replace(
        r#"["brake", 3.5, 5.0], ["post_brake", 5.5, 6.0]]"#,
        r#"["brake", 3.5, 5.0]]"#,
    );
    assert!(!text.contains("post_brake"));
    let file = write(&dir, "no-post-brake.toml", &text);
    let (v, code) = run_json(&[
        "run",
        "--ideal",
        "--scenario-file",
        &file,
        "--observer",
        "sliding-torque",
    ]);
    println!("{}", v["reasons"]);
    assert_eq!(code, Some(3));
    assert_eq!(v["pass"], false);
    assert_eq!(v["lost_lock"], true);
    let t = v["lost_lock_at_s"].as_f64().unwrap();
    assert!((5.0..5.5).contains(&t), "{t}");
    assert!(v["reasons"][0].as_str().unwrap().contains("lost lock"));
    for (_, w) in v["windows"].as_object().unwrap() {
        assert!(w["theta_err_max_abs_deg_e"].as_f64().unwrap() < 90.0);
    }
    // The same observer up to the brake's release passes (exit 0).
    let (v, code) = run_json(&[
        "run",
        "--ideal",
        "--scenario-file",
        &write(
            &dir,
            "until-release.toml",
            &text.replace("duration_s = 6.0", "duration_s = 5.0"),
        ),
        "--observer",
        "sliding-torque",
    ]);
    assert_eq!(
        (code, &v["pass"]),
        (Some(0), &serde_json::Value::Bool(true))
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// The format of the issue: fractions of the ratings, a step, a brake and its release, the
/// enable schedule, a coasting start; the same file on another motor scales with its ratings.
#[test]
fn scenario_files_scale_to_the_motor_and_switch_the_drive() {
    let dir = tmp_dir("format");
    let file = write(
        &dir,
        "half.toml",
        r#"
duration_s = 3.0
speed = [[0.0, 0.0], [0.5, 0.5], [2.0, 0.5], [2.0, -0.3]]
load  = [[0.0, 0.0], [1.0, 0.2], [1.5, 0.2], [1.5, 0.0]]
load_kind = "brake"
windows = [["loaded", 1.2, 1.5], ["released", 1.7, 2.0]]
enable = [[0.0, false], [0.25, true]]
"#,
    );
    for (motor, rated_rpm) in [("sinano", 1000.0), ("ortega-test-0.3kw", 1000.0)] {
        let (v, code) = run_json(&[
            "run",
            "--ideal",
            "--scenario-file",
            &file,
            "--observer",
            "flux",
            "--motor",
            motor,
        ]);
        println!("{motor}: {}", v["reasons"]);
        assert_eq!(v["scenario"], "half");
        assert_eq!(v["motor"], motor);
        assert_eq!(code, Some(0), "{motor}: {}", v["reasons"]);
        let w = &v["windows"]["loaded"];
        assert!((w["speed_cmd_mean_rpm"].as_f64().unwrap() - 0.5 * rated_rpm).abs() < 1e-9);
        // Enabled at 0.25 s: the first transition, to Catch (the board senses the terminal
        // voltage); the rotor is at rest, so it aligns next.
        let tr = &v["transitions"][0];
        assert_eq!(
            (tr["to"].as_str(), tr["reason"].as_str()),
            (Some("Catch"), Some("Enabled"))
        );
        let tr1 = &v["transitions"][1];
        assert_eq!(
            (tr1["to"].as_str(), tr1["reason"].as_str()),
            (Some("Align"), Some("AtRest"))
        );
        assert!((tr["t"].as_f64().unwrap() - 0.25).abs() < 1e-9);
    }
    // A rotor coasting at 30 % of rated speed and a drive never enabled: no transition, the
    // speed holds but for friction.
    let coast = write(
        &dir,
        "coast.toml",
        "duration_s = 0.5\ninitial_speed = 0.3\nenable = [[0.0, false]]\nwindows = []\n",
    );
    let (v, code) = run_json(&[
        "run",
        "--ideal",
        "--scenario-file",
        &coast,
        "--observer",
        "flux",
    ]);
    assert_eq!(code, Some(0), "{}", v["reasons"]);
    assert!(v.get("transitions").is_none(), "{}", v["transitions"]);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A scenario that expects a fault passes when it comes (the built-in fault scenarios), and
/// fails when it does not.
#[test]
fn an_expected_fault_passes_and_a_missing_one_fails() {
    let (v, code) = run_json(&["run", "--ideal", "fault-overcurrent", "--observer", "flux"]);
    assert_eq!(
        (code, &v["fault"]),
        (Some(0), &serde_json::json!("overcurrent"))
    );
    let dir = tmp_dir("expect");
    let file = write(
        &dir,
        "quiet.toml",
        "duration_s = 1.0\nspeed = [[0.0, 0.5]]\nwindows = []\nexpect_fault = \"stall\"\n",
    );
    let (v, code) = run_json(&[
        "run",
        "--ideal",
        "--scenario-file",
        &file,
        "--observer",
        "flux",
    ]);
    assert_eq!(code, Some(3));
    assert!(v["reasons"][0]
        .as_str()
        .unwrap()
        .contains("stall did not happen"));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_scenario_files_name_the_key() {
    let dir = tmp_dir("bad");
    let ok = "duration_s = 2.0\nspeed = [[0.0, 0.5]]\nwindows = [[\"w\", 1.0, 2.0]]\n";
    for (text, needle) in [
        (
            ok.replace("duration_s = 2.0", "duration_s = -1.0"),
            "duration_s",
        ),
        (
            ok.replace("[[0.0, 0.5]]", "[[1.0, 0.5], [0.5, 0.2]]"),
            "speed: times",
        ),
        (
            ok.replace("[[0.0, 0.5]]", "[[0.0, 50.0]]"),
            "beyond 2× the rating",
        ),
        (
            format!("{ok}speed_rpm = [[0.0, 100.0]]\n"),
            "speed or speed_rpm",
        ),
        (ok.replace("1.0, 2.0]", "1.0, 3.0]"), "window \"w\""),
        (format!("{ok}load_kind = \"spring\"\n"), "load_kind"),
        (format!("{ok}expect_fault = \"gremlins\"\n"), "expect_fault"),
        (format!("{ok}colour = 3\n"), "unknown field `colour`"),
        (
            format!("{ok}[inject]\nt = 1.0\nkind = \"bus\"\n"),
            "inject.bus",
        ),
        (
            format!("{ok}[inject]\nt = 1.0\nuntil = 0.5\nkind = \"plant\"\nr = 1.5\n"),
            "inject.until",
        ),
        (
            format!("{ok}[inject]\nt = 1.0\nuntil = 1.5\nkind = \"plant\"\nl = 0.9\n"),
            "inject.l",
        ),
        (
            format!("{ok}drive = false\nenable = [[0.0, true]]\n"),
            "enable",
        ),
    ] {
        let file = write(&dir, "bad.toml", &text);
        assert_error(
            &sim(&["run", "--scenario-file", &file, "--observer", "flux"]),
            needle,
        );
    }
    assert_error(
        &sim(&[
            "run",
            "start-stop-reverse",
            "--observer",
            "flux",
            "--sensorless-from-rpm",
            "50",
        ]),
        "--sensorless-from-rpm",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Without --out a run writes nothing.
#[test]
fn a_run_writes_files_only_when_asked() {
    let dir = tmp_dir("files");
    let out = Command::new(env!("CARGO_BIN_EXE_pmsm-sim"))
        .args(["run", "--ideal", "ortega-ramp", "--observer", "flux"])
        .current_dir(&dir)
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
    let _ = std::fs::remove_dir_all(&dir);
}

/// A small matrix: the product of its axes, a table value setting two flags, the JSON, the
/// files, and exit 1 for a failed cell.
#[test]
fn a_sweep_runs_the_product_and_reports_every_cell() {
    let dir = tmp_dir("sweep");
    let matrix = write(
        &dir,
        "m.toml",
        r#"
scenario = "ortega-ramp"
[axes]
observer = ["flux", "encoder"]
case = [{ name = "nominal" }, { name = "noisy", noise-a = 0.01, seed = 2 }]
"#,
    );
    let out_dir = dir.join("out");
    let out = sim(&[
        "sweep",
        "--matrix",
        &matrix,
        "--json",
        "--jobs",
        "2",
        "--out",
        out_dir.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(
        (v["total"].as_u64(), v["passed"].as_u64()),
        (Some(4), Some(4))
    );
    let cell = &v["cells"][1];
    assert_eq!(
        cell["params"],
        serde_json::json!({"observer": "flux", "case": "noisy"})
    );
    for k in [
        "pass",
        "reasons",
        "fault",
        "lost_lock",
        "worst_speed_err_pct",
        "theta_err_max_deg_e",
    ] {
        assert!(cell.get(k).is_some(), "{k}");
    }
    let csv = std::fs::read_to_string(out_dir.join("sweep.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5);
    assert_eq!(
        &std::fs::read(out_dir.join("heatmap.png")).unwrap()[1..4],
        b"PNG"
    );
    // A cell that fails: the torque observer through the paper's brake release.
    let failing = write(
        &dir,
        "f.toml",
        "scenario = \"horng-ramp-brake\"\n[axes]\nobserver = [\"encoder\", \"sliding-torque\"]\n",
    );
    let out = sim(&["sweep", "--matrix", &failing]);
    assert_eq!(out.status.code(), Some(1));
    let table = String::from_utf8_lossy(&out.stdout);
    assert!(table.contains("1 of 2 cells passed"), "{table}");
    let _ = std::fs::remove_dir_all(&dir);
}
