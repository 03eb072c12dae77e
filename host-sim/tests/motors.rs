//! Motor files (model and datasheet forms), `gains`, and the refusal of nonsense: every bad
//! value ends in a one-line error naming the field, the value and the range, and exit 1.

mod common;
use common::sim;

use std::path::PathBuf;
use std::process::Output;

const MODEL: &str = "name = \"mine\"\npole_pairs = 4\nr_ohm = 2.5\nl_h = 5.97e-3\nflux_wb = 5.795e-2\nj_kgm2 = 6.45e-5\nb_nms = 0.0\n[ratings]\nbus_v = 48.0\ncurrent_a = 3.0\ntorque_nm = 0.695\nspeed_rpm = 1000.0\npower_w = 73.0\n";

/// The committed datasheet example.
fn datasheet_example() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("motors/datasheet-example.toml")
}

/// `text` as a motor file in a fresh directory.
fn motor_file(name: &str, text: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pmsm-sim-motors-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    let p = d.join(format!("{name}.toml"));
    std::fs::write(&p, text).unwrap();
    p
}

/// Fails with exit 1 and one line of stderr containing every one of `needles`.
fn refused(out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err:?}");
    for n in needles {
        assert!(err.contains(n), "{err:?} lacks {n:?}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn a_motor_file_refuses_values_no_motor_has_naming_key_value_and_range() {
    let cases: [(&str, &str, &[&str]); 9] = [
        (
            "j_kgm2 = 6.45e-5",
            "j_kgm2 = 1e-45",
            &["j_kgm2 = 1e-45", "allowed [1e-9, 1000]"],
        ),
        (
            "pole_pairs = 4",
            "pole_pairs = 4294967295",
            &["pole_pairs = 4294967295", "allowed [1, 64]"],
        ),
        (
            "pole_pairs = 4",
            "pole_pairs = 100000",
            &["pole_pairs = 100000", "allowed [1, 64]"],
        ),
        (
            "r_ohm = 2.5",
            "r_ohm = 1e300",
            &["r_ohm = 1e300", "allowed [1e-4, 1000]"],
        ),
        (
            "flux_wb = 5.795e-2",
            "flux_wb = 1e-45",
            &["flux_wb = 1e-45", "allowed [1e-5, 10]"],
        ),
        (
            "current_a = 3.0",
            "current_a = nan",
            &["ratings.current_a = NaN", "finite"],
        ),
        // 3 N·m at 3 A where N ψ_f I = 0.70 N·m (Ortega's test motor as it was).
        (
            "torque_nm = 0.695",
            "torque_nm = 3.0",
            &["ratings.torque_nm = 3", "current_a"],
        ),
        // 5000 rpm on 48 V: back-EMF 121 V above 27.7 V.
        (
            "speed_rpm = 1000.0",
            "speed_rpm = 5000.0",
            &["ratings.speed_rpm = 5000", "bus_v/sqrt(3)"],
        ),
        (
            "bus_v = 48.0",
            "bus_v = 1e30",
            &["ratings.bus_v = 1e30", "allowed [1, 1500]"],
        ),
    ];
    for (good, bad, needles) in cases {
        assert!(MODEL.contains(good), "{good}");
        let f = motor_file("bad", &MODEL.replace(good, bad));
        refused(
            &sim(&["gains", "--motor-file", f.to_str().unwrap()]),
            needles,
        );
        refused(
            &sim(&[
                "run",
                "start-stop-reverse",
                "--motor-file",
                f.to_str().unwrap(),
            ]),
            needles,
        );
    }
    // 50 N·m on the Sinano motor: 2.5 Ω × 216 A = 539 V at standstill.
    let strong = MODEL
        .replace("torque_nm = 0.695", "torque_nm = 50.0")
        .replace("current_a = 3.0", "current_a = 216.0")
        .replace("power_w = 73.0", "power_w = 5236.0");
    let f = motor_file("strong", &strong);
    refused(
        &sim(&["gains", "--motor-file", f.to_str().unwrap()]),
        &["ratings.torque_nm = 50", "standstill"],
    );
}

#[test]
fn datasheet_keys_convert_and_conflicts_are_named() {
    // The model file written with line-to-line R and L and Kv gives the same gains.
    // ψ_f = 60/(2π Kv) / (√3 N) with Kv line-to-line peak: Kv = 60/(2π √3 N ψ_f).
    let kv = 60.0 / (2.0 * std::f64::consts::PI * 3f64.sqrt() * 4.0 * 5.795e-2);
    let ds = MODEL
        .replace("pole_pairs = 4", "poles = 8")
        .replace("r_ohm = 2.5", "r_ohm_ll = 5.0")
        .replace("l_h = 5.97e-3", "l_h_ll = 11.94e-3")
        .replace(
            "flux_wb = 5.795e-2",
            &format!("kv_rpm_per_v = {kv}\nke_form = \"ll-peak\""),
        );
    let json = |path: &PathBuf| {
        let out = sim(&["gains", "--json", "--motor-file", path.to_str().unwrap()]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["values"].clone()
    };
    let (a, b) = (
        json(&motor_file("model", MODEL)),
        json(&motor_file("ds", &ds)),
    );
    for (x, y) in a.as_array().unwrap().iter().zip(b.as_array().unwrap()) {
        let (x, y) = (x["value"].as_f64().unwrap(), y["value"].as_f64().unwrap());
        assert!((x - y).abs() <= 1e-5 * x.abs().max(1e-9), "{x} vs {y}");
    }
    // Ke in V/krpm rms: ψ_f = √2 Ke 60/(2π 1000) / (√3 N).
    let ke_rms =
        5.795e-2 * 3f64.sqrt() * 4.0 / (2f64.sqrt() * 60.0 / (2.0 * std::f64::consts::PI * 1000.0));
    let ke = MODEL.replace(
        "flux_wb = 5.795e-2",
        &format!("ke_v_per_krpm = {ke_rms}\nke_form = \"ll-rms\""),
    );
    let c = json(&motor_file("ke", &ke));
    assert!((a[0]["value"].as_f64().unwrap() - c[0]["value"].as_f64().unwrap()).abs() < 1e-6);
    // A Kv without ke_form is line-to-line peak, the hobby convention (motor_file's doc).
    let kv_bare = json(&motor_file(
        "kv-bare",
        &ds.replace("\nke_form = \"ll-peak\"", ""),
    ));
    assert_eq!(kv_bare, b);
    let cases: [(&str, &[&str]); 4] = [
        (
            &MODEL.replace(
                "b_nms = 0.0",
                "b_nms = 0.0\ntorque_convention = \"two-phase\"",
            ),
            &[
                "torque_convention = \"two-phase\"",
                "\"three-phase\" or \"papers\"",
            ],
        ),
        (
            &MODEL.replace("r_ohm = 2.5", "r_ohm = 2.5\nr_ohm_ll = 5.0"),
            &["give r_ohm or r_ohm_ll, not both"],
        ),
        (
            &MODEL.replace("pole_pairs = 4", "poles = 7"),
            &["poles = 7", "even"],
        ),
        (
            &MODEL.replace("r_ohm = 2.5", "r_ohm_ll = 1e300"),
            &["r_ohm_ll = 1e300", "r_ohm = inf", "allowed [1e-4, 1000]"],
        ),
    ];
    for (text, needles) in cases {
        refused(
            &sim(&[
                "gains",
                "--motor-file",
                motor_file("c", text).to_str().unwrap(),
            ]),
            needles,
        );
    }
}

/// Issue #26's datasheet: Kv 100 rpm/V (line-to-line peak), 4 A peak, 0.3 N·m. Physically
/// consistent, `(3/2) N ψ_f I` = 0.33 N·m = 8.27/Kv · I: accepted, in physical N·m (the
/// papers' `N ψ_f I` = 0.22 N·m would refuse it); with `torque_convention = "papers"` the
/// same file is refused naming the bound.
#[test]
fn a_physically_consistent_datasheet_is_accepted_in_physical_torque_units() {
    let text =
        "name = \"kv100\"\npoles = 14\nkv_rpm_per_v = 100.0\nr_ohm_ll = 0.2\nl_h_ll = 1e-4\n\
                j_kgm2 = 1e-4\n[ratings]\nbus_v = 24.0\ncurrent_a = 4.0\ntorque_nm = 0.3\n";
    let out = sim(&[
        "gains",
        "--motor-file",
        motor_file("kv100", text).to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let papers = text.replace(
        "j_kgm2 = 1e-4",
        "j_kgm2 = 1e-4\ntorque_convention = \"papers\"",
    );
    refused(
        &sim(&[
            "gains",
            "--motor-file",
            motor_file("kv100p", &papers).to_str().unwrap(),
        ]),
        &["ratings.torque_nm = 0.3", "c*pole_pairs*flux_wb*current_a"],
    );
}

#[test]
fn the_datasheet_example_runs_start_stop_reverse_and_gains_lists_it() {
    let f = datasheet_example();
    let f = f.to_str().unwrap();
    let out = sim(&["gains", "--motor-file", f]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    for row in [
        "current PI kp",
        "speed PI ki",
        "(K_s,max)_T",
        "γ_max, discrete step",
        "PLL Kp",
        "hand-over speed",
        "current trip",
    ] {
        assert!(text.contains(row), "{row} missing:\n{text}");
    }
    for observer in ["flux", "sliding-torque"] {
        let out = sim(&[
            "run",
            "--ideal",
            "start-stop-reverse",
            "--observer",
            observer,
            "--motor-file",
            f,
            "--json",
        ]);
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(v["pass"], true, "{observer}: {}", v["reasons"]);
        assert_eq!(out.status.code(), Some(0));
        // Scaled to its ratings: 80 % of the 2880 rpm its Kv gives on 48 V.
        let cmd = v["windows"]["w1000"]["speed_cmd_mean_rpm"]
            .as_f64()
            .unwrap();
        assert!((cmd - 0.8 * 60.0 * 48.0).abs() < 1.0, "{cmd}");
    }
}

#[test]
fn gains_warns_naming_the_parameter_its_value_and_the_limit() {
    let out = sim(&["gains", "--motor", "sinano", "--json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let w = v["warnings"].as_array().unwrap();
    // K_s = 1000π is above (K_s,max)_E2 below 619 rpm: the hand-over at 100 rpm is below.
    let ks = w
        .iter()
        .find(|w| w["field"] == "start.handover_rpm")
        .unwrap();
    assert_eq!(ks["value"], 100.0);
    assert!((ks["limit"].as_f64().unwrap() - 619.2).abs() < 0.5, "{ks}");
    let text = String::from_utf8_lossy(&sim(&["gains"]).stdout).to_string();
    assert!(text.contains("warning: start.handover_rpm = 100"), "{text}");
}

#[test]
fn bounds_and_gamma_take_a_motor_file() {
    let f = datasheet_example();
    let f = f.to_str().unwrap();
    for args in [
        vec![
            "bounds",
            "--motor-file",
            f,
            "--speed-rpm",
            "1000",
            "--rate-hz",
            "4000",
            "--json",
        ],
        vec![
            "gamma",
            "--motor-file",
            f,
            "--rate-hz",
            "4000",
            "--min-speed-rpm",
            "100",
            "--json",
        ],
    ] {
        let out = sim(&args);
        assert!(
            out.status.success(),
            "{args:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let _: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    }
}

#[test]
fn plant_flags_beyond_the_motor_are_refused() {
    let cases: [(&[&str], &[&str]); 7] = [
        (
            &["--pwm-hz", "0"],
            &["--pwm-hz = 0", "allowed [1000, 200000] Hz"],
        ),
        (&["--pwm-hz", "nan"], &["--pwm-hz = NaN"]),
        (
            &["--dead-time-us", "20"],
            &["--dead-time-us = 20", "a tenth of the 20000 Hz PWM period"],
        ),
        (&["--load-nm", "1e30"], &["--load-nm = 1e30", "N·m"]),
        (
            &["--bus-v", "1e30"],
            &["--bus-v = 1e30", "allowed (0, 96] V"],
        ),
        (&["--bus-pct", "1e30"], &["--bus-pct", "allowed (0, 200]"]),
        (&["--load-nm", "nan"], &["--load-nm = NaN"]),
    ];
    for (flags, needles) in cases {
        let mut args = vec!["run", "start-stop-reverse"];
        args.extend_from_slice(flags);
        refused(&sim(&args), needles);
    }
}
