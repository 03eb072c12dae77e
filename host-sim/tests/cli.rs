//! The `pmsm-sim` command line: the JSON contract and one-line errors.

mod common;
use common::sim;

use std::process::Output;

fn tmp_dir(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("pmsm-sim-cli-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    d
}

/// A command-line syntax error: clap's whole message (what is wrong, the usage where clap
/// gives it, where to find help) and exit 2.
fn assert_usage_error(out: &Output, needle: &str) {
    assert_eq!(out.status.code(), Some(2), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains(needle), "{err:?} lacks {needle:?}");
    assert!(err.contains("help"), "{err:?} does not say where help is");
    assert!(!err.contains("panicked"), "{err}");
}

fn assert_one_line_error(out: &Output, needle: &str) {
    assert!(!out.status.success(), "expected failure");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err:?}");
    assert!(err.contains(needle), "{err:?} lacks {needle:?}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn list_names_everything() {
    let out = sim(&["list"]);
    assert!(out.status.success());
    let s = String::from_utf8_lossy(&out.stdout);
    for name in [
        "horng-ramp-brake",
        "sinano",
        "ortega-sim-40kw",
        "ortega-test-0.3kw",
        "ortega-dynamo-1kw",
        "encoder",
    ] {
        assert!(s.contains(name), "list lacks {name}");
    }
}

#[test]
fn run_json_contract_and_files() {
    let dir = tmp_dir("json");
    let out = sim(&[
        "run",
        "--ideal",
        "horng-ramp-brake",
        "--observer",
        "encoder",
        "--noise-a",
        "0.01",
        "--seed",
        "7",
        "--out",
        dir.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
    for k in [
        "scenario",
        "motor",
        "observer",
        "rate_hz",
        "lost_lock",
        "fault",
        "windows",
    ] {
        assert!(v.get(k).is_some(), "missing {k}");
    }
    assert_eq!(v["scenario"], "horng-ramp-brake");
    assert_eq!(v["observer"], "encoder");
    assert_eq!(v["rate_hz"], 4000.0);
    assert_eq!(v["lost_lock"], false);
    assert!(v["fault"].is_null());
    let windows = v["windows"].as_object().unwrap();
    let names: Vec<_> = windows.keys().cloned().collect();
    assert_eq!(names, ["ramp", "pre_brake", "brake", "post_brake"]);
    for (_, w) in windows {
        for k in [
            "t0",
            "t1",
            "speed_cmd_mean_rpm",
            "speed_err_mean_rpm",
            "speed_err_max_abs_rpm",
            "theta_err_mean_deg_e",
            "theta_err_mean_abs_deg_e",
            "theta_err_max_abs_deg_e",
        ] {
            assert!(w[k].is_number(), "{k}");
        }
        assert!(w["torque_hat_mean_nm"].is_null());
        assert!(w["ks_min_max"].is_null());
    }
    let csv = std::fs::read_to_string(dir.join("run.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(lines.next().unwrap(), "t_s,speed_cmd_rpm,omega_m_rpm,omega_m_hat_rpm,theta_e_deg,theta_e_hat_deg,i_d_a,i_q_a,v_alpha_v,v_beta_v,load_nm,load_hat_nm,s_a_a,ks_a_per_s,ks_min_a_per_s,mode,theta_e_monitor_deg,driving,residual_primary,residual_monitor,r_hat_ohm,flux_hat_wb,voltage_limited,transition");
    assert_eq!(lines.count(), 24_000);
    let png = std::fs::read(dir.join("run.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    // Same seed, same result.
    let again = sim(&[
        "run",
        "--ideal",
        "horng-ramp-brake",
        "--noise-a",
        "0.01",
        "--seed",
        "7",
        "--out",
        dir.to_str().unwrap(),
        "--json",
    ]);
    // Same simulation, to the bit; the real-time factor is a wall-clock measurement.
    let without_timing = |stdout: &[u8]| {
        let mut v: serde_json::Value = serde_json::from_slice(stdout).unwrap();
        let rtf = v.as_object_mut().unwrap().remove("real_time_factor");
        assert!(rtf.unwrap().as_f64().unwrap() > 0.0);
        v.to_string()
    };
    assert_eq!(without_timing(&out.stdout), without_timing(&again.stdout));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn motor_file_and_overrides() {
    let dir = tmp_dir("motor");
    std::fs::create_dir_all(&dir).unwrap();
    let good = dir.join("m.toml");
    std::fs::write(&good, "name = \"mine\"\npole_pairs = 4\nr_ohm = 2.5\nl_h = 5.97e-3\nflux_wb = 5.795e-2\nj_kgm2 = 6.45e-5\nb_nms = 0.0\n[ratings]\nbus_v = 48.0\ncurrent_a = 3.0\ntorque_nm = 0.695\nspeed_rpm = 1000.0\npower_w = 73.0\n").unwrap();
    let out = sim(&[
        "run",
        "--ideal",
        "horng-ramp-brake",
        "--motor-file",
        good.to_str().unwrap(),
        "--load-nm",
        "0.1",
        "--bus-v",
        "60",
        "--out",
        dir.to_str().unwrap(),
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["motor"], "mine");

    let bad = dir.join("bad.toml");
    std::fs::write(
        &bad,
        std::fs::read_to_string(&good)
            .unwrap()
            .replace("l_h = 5.97e-3", "l_h = -1.0"),
    )
    .unwrap();
    assert_one_line_error(
        &sim(&[
            "run",
            "horng-ramp-brake",
            "--motor-file",
            bad.to_str().unwrap(),
        ]),
        "l_h",
    );
    std::fs::write(&bad, "name = \"x\"\npole_pairs = 4\n").unwrap();
    assert_one_line_error(
        &sim(&[
            "run",
            "horng-ramp-brake",
            "--motor-file",
            bad.to_str().unwrap(),
        ]),
        "missing field",
    );
    std::fs::write(
        &bad,
        std::fs::read_to_string(&good)
            .unwrap()
            .replace("pole_pairs = 4", "pole_pairs = -2"),
    )
    .unwrap();
    assert_one_line_error(
        &sim(&[
            "run",
            "horng-ramp-brake",
            "--motor-file",
            bad.to_str().unwrap(),
        ]),
        "pole_pairs",
    );
    std::fs::write(&bad, "this is = = not toml").unwrap();
    assert_one_line_error(
        &sim(&[
            "run",
            "horng-ramp-brake",
            "--motor-file",
            bad.to_str().unwrap(),
        ]),
        "bad.toml",
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_arguments_get_one_line_errors() {
    assert_one_line_error(&sim(&["run", "no-such-scenario"]), "unknown scenario");
    assert_one_line_error(
        &sim(&["run", "horng-ramp-brake", "--observer", "magic"]),
        "unknown observer",
    );
    assert_one_line_error(
        &sim(&["run", "horng-ramp-brake", "--motor", "nope"]),
        "unknown motor",
    );
    assert_one_line_error(
        &sim(&[
            "run",
            "horng-ramp-brake",
            "--motor-file",
            "/nonexistent/m.toml",
        ]),
        "/nonexistent/m.toml",
    );
    assert_one_line_error(
        &sim(&["run", "horng-ramp-brake", "--bus-v", "-5"]),
        "bus voltage",
    );
    assert_one_line_error(
        &sim(&["run", "horng-ramp-brake", "--bus-v", "NaN"]),
        "bus voltage",
    );
    assert_one_line_error(
        &sim(&["run", "horng-ramp-brake", "--noise-a", "-1"]),
        "noise",
    );
    assert_one_line_error(
        &sim(&["run", "horng-ramp-brake", "--load-nm", "inf"]),
        "load",
    );
    // Fixed point: the bare sliding observers only.
    assert_one_line_error(
        &sim(&[
            "run",
            "horng-ramp-brake",
            "--observer",
            "flux",
            "--fixed-point",
        ]),
        "fixed point: the sliding observers only",
    );
    assert_one_line_error(
        &sim(&["run", "start-stop-reverse", "--fixed-point"]),
        "fixed point: the papers' bare-observer experiments only",
    );
    assert_usage_error(
        &sim(&["run", "horng-ramp-brake", "--seed", "x"]),
        "invalid value",
    );
    assert_usage_error(
        &sim(&["run", "horng-ramp-brake", "--mismatch", "q=2"]),
        "unknown parameter",
    );
    assert_usage_error(
        &sim(&["run", "horng-ramp-brake", "--frobnicate"]),
        "unexpected argument",
    );
    assert_usage_error(
        &sim(&["run", "horng-ramp-brake", "--offset-a", "0.1,0.2"]),
        "three",
    );
    assert_one_line_error(
        &sim(&["run", "horng-ramp-brake", "--adc-lsb-a", "-0.01"]),
        "ADC step",
    );
    assert_usage_error(&sim(&["fly"]), "unrecognized subcommand");
    assert_usage_error(&sim(&[]), "pmsm-sim");
    // The missing scenario is named, not cut to a first line.
    let out = sim(&["run"]);
    assert_usage_error(&out, "SCENARIO");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("required") && err.contains("Usage: pmsm-sim run"),
        "{err}"
    );
    // Help and version are not errors.
    for flag in ["--help", "--version"] {
        let out = sim(&[flag]);
        assert_eq!(out.status.code(), Some(0), "{flag}");
        assert!(!out.stdout.is_empty(), "{flag}");
    }
}
