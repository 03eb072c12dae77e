//! Issue #27: the sweep refuses a bad matrix before it runs anything. A cell whose flags
//! `run` would refuse is named with its reason and nothing runs; a matrix over the cell cap is
//! refused from its axes' lengths, before its cells are expanded; a file over the size cap by
//! its size, before it is read. Cells that fail list their reasons under the table.

mod common;
use common::sim;

use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::report::sweep::{self, Matrix, MAX_CELLS, MAX_MATRIX_BYTES};
use std::path::{Path, PathBuf};

/// A fresh directory of this test process.
fn tmp_dir(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("pmsm-sim-sweep-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// `text` written as `name` in a fresh directory.
fn matrix_file(name: &str, text: &str) -> PathBuf {
    let path = tmp_dir(name).join("m.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The failure's stderr: not a success, one line, no panic.
fn one_line_error(args: &[&str]) -> String {
    let out = sim(args);
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr).into_owned();
    assert_eq!(err.trim_end().lines().count(), 1, "not one line: {err:?}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.stdout.is_empty(), "printed a result: {out:?}");
    err
}

#[test]
fn an_invalid_cell_is_named_with_its_reason_and_nothing_runs() {
    // The issue's case: one cell, its flags invalid (it printed only "0 of 1 cells passed").
    let one = matrix_file(
        "one",
        "scenario = \"start-stop-reverse\"\n[axes]\nbus-v = [-1]\n",
    );
    let err = one_line_error(&["sweep", "--matrix", one.to_str().unwrap()]);
    for needle in [
        "1 of 1 cells invalid",
        "none run",
        "cell 1 of 1 (bus-v = -1)",
        "--bus-v = -1: bus voltage allowed",
    ] {
        assert!(err.contains(needle), "{err:?} lacks {needle:?}");
    }
    // Among valid cells (which would take seconds each to run): the first invalid one named,
    // the count of them; flags clap refuses and `run`'s own checks alike.
    let mixed = matrix_file(
        "mixed",
        r#"
scenario = "start-stop-reverse"
[axes]
observer = ["flux", "no-such-observer"]
case = [{ name = "fine" }, { name = "fast", rate-hz = 1e9 }, { name = "typo", bus-vv = 3 }]
"#,
    );
    let err = one_line_error(&["sweep", "--matrix", mixed.to_str().unwrap(), "--json"]);
    for needle in [
        "5 of 6 cells invalid",
        "cell 2 of 6 (observer = flux, case = fast)",
        "--rate-hz must be between 1000 and 100000",
    ] {
        assert!(err.contains(needle), "{err:?} lacks {needle:?}");
    }
    // The library's refusal runs no cell at all.
    let m = Matrix::load(&mixed).unwrap();
    let e = sweep::run(
        &m,
        Some(1),
        |args| {
            if args.iter().any(|a| a == "--bus-vv") {
                anyhow::bail!("a typo")
            }
            Ok(())
        },
        |()| -> anyhow::Result<_> { panic!("a cell ran") },
    );
    let e = format!("{:#}", e.unwrap_err());
    assert!(
        e.contains("cell 3 of 6 (observer = flux, case = typo): a typo"),
        "{e}"
    );
}

#[test]
fn a_matrix_over_the_cell_cap_is_refused_before_its_cells_are_expanded() {
    // 10²⁰ cells: more than a usize counts, far more than memory holds.
    let mut text = String::from("scenario = \"start-stop-reverse\"\n[axes]\n");
    for k in 0..20 {
        text += &format!("a{k} = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9]\n");
    }
    let e = Matrix::parse(&text, Path::new(".")).unwrap_err();
    let e = format!("{e:#}");
    assert!(e.contains(&format!("more than {MAX_CELLS} cells")), "{e}");
    assert!(e.contains("10 x 10 x 10"), "{e}");
    // Just over: 100,001 cells (an axis of 100,001 values is refused alike).
    let text = format!(
        "scenario = \"start-stop-reverse\"\n[axes]\nseed = [{}]\n",
        (0..=MAX_CELLS)
            .map(|k| k.to_string())
            .collect::<Vec<_>>()
            .join(",")
    );
    let e = Matrix::parse(&text, Path::new(".")).unwrap_err();
    assert!(
        format!("{e:#}").contains("(axes of 100001 values)"),
        "{e:#}"
    );
    // On the command line.
    let path = matrix_file("cap", &text);
    let err = one_line_error(&["sweep", "--matrix", path.to_str().unwrap()]);
    assert!(err.contains("more than 100000 cells"), "{err}");
}

#[test]
fn an_oversized_matrix_file_is_refused_by_its_size() {
    // A sparse file one byte over the limit (zeros: no TOML at all, never read).
    let path = tmp_dir("size").join("m.toml");
    let f = std::fs::File::create(&path).unwrap();
    f.set_len(MAX_MATRIX_BYTES + 1).unwrap();
    let e = format!("{:#}", Matrix::load(&path).unwrap_err());
    let needle = format!(
        "{} bytes: a matrix file may have at most {MAX_MATRIX_BYTES} bytes",
        MAX_MATRIX_BYTES + 1
    );
    assert!(e.contains(&needle), "{e}");
    // The issue's 78 MB on the command line.
    f.set_len(78_000_000).unwrap();
    let err = one_line_error(&["sweep", "--matrix", path.to_str().unwrap()]);
    assert!(err.contains("78000000 bytes"), "{err}");
}

#[test]
fn cells_that_fail_list_their_reasons_under_the_table() {
    let m = Matrix::parse(
        "scenario = \"start-stop-reverse\"\n[axes]\nseed = [1, 2, 3]\n",
        Path::new("."),
    )
    .unwrap();
    // Every cell prepares; the second cannot run.
    let report = sweep::run(
        &m,
        Some(1),
        |args| Ok(args.to_vec()),
        |args| {
            anyhow::ensure!(!args.contains(&"2".to_string()), "the plant diverged");
            Ok(passing())
        },
    )
    .unwrap();
    assert_eq!((report.passed, report.total), (2, 3));
    let table = report.table(&m);
    assert!(table.contains("2 of 3 cells passed"), "{table}");
    assert!(
        table.contains("cell 2 of 3 (seed = 2): could not run: the plant diverged"),
        "{table}"
    );
}

/// A run's summary that passed.
fn passing() -> Summary {
    Summary {
        scenario: "s".into(),
        motor: "m".into(),
        observer: "o".into(),
        rate_hz: 4000.0,
        pass: true,
        reasons: vec![],
        lost_lock: false,
        lost_lock_at_s: None,
        worst_speed_err_pct: None,
        theta_err_max_deg_e: None,
        real_time_factor: 1.0,
        fault: None,
        windows: Default::default(),
        fault_step: None,
        transitions: vec![],
        handovers_s: vec![],
        lowest_sensorless_rpm: None,
        adapted: None,
        bus_peak_v: None,
    }
}

// The matrix format (moved here from the library module's unit tests).

#[test]
fn the_product_in_order_with_tables_and_empty_values() {
    let m = Matrix::parse(
        r#"
scenario = "start-stop-reverse"
[fixed]
noise-pct = 1.0
[axes]
observer = ["sliding-torque", "flux"]
mismatch = ["", "r=1.5"]
case = [{ name = "dead", dead-time-us = 1.0, seed = 3 }, {}]
"#,
        Path::new("."),
    )
    .unwrap();
    let cells = m.cells();
    assert_eq!(cells.len(), 8);
    assert_eq!(
        cells[0].args,
        [
            "start-stop-reverse",
            "--noise-pct",
            "1",
            "--observer",
            "sliding-torque",
            "--dead-time-us",
            "1",
            "--seed",
            "3"
        ]
    );
    assert_eq!(cells[1].params["case"], "-");
    assert_eq!(cells[2].params["mismatch"], "r=1.5");
    assert_eq!(
        cells[7].args[3..],
        ["--observer", "flux", "--mismatch", "r=1.5"]
    );
}

#[test]
fn bad_matrices_are_refused_with_the_key() {
    for (text, needle) in [
        ("[axes]\n", "at least one axis"),
        ("[axes]\nseed = 3\n", "axes.seed"),
        ("[axes]\nseed = []\n", "empty"),
        ("oops = 1\n[axes]\nseed = [1]\n", "'oops'"),
        ("[axes]\nseed = [[1]]\n", "seed"),
    ] {
        let e = Matrix::parse(text, Path::new(".")).unwrap_err();
        assert!(format!("{e:#}").contains(needle), "{text}: {e:#}");
    }
}
