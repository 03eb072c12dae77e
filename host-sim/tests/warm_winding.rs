//! Issue #26's resistance tracked while running (`src/drive/adaptation.rs`): the winding warms
//! under load (`warm-winding-loaded`: R rising to 1.5× from 2 s to 4 s at 15 % of rated speed
//! under 90 % of the rated torque, the board's defaults), both primaries. The run must pass its
//! verdict, and R̂ must end within 5 % of the plant's warm resistance: well inside what the
//! observers lost the rotor at without tracking (13 % and more); the stated margin,
//! `3.3 δψ/ψ`, allows up to 14 % with the 4.3 % ψ_f error of one of these runs.
//!
//! Measured: R̂ within 0.6 % (the Sinano motor) and 3.5 % (the zoo's eight: the drone motor's
//! −3.5 % with its ψ_f +3.3 %, the others within 2.0 %) of the plant's.
//! Without R tracked while running (the model keeping the start's R), every one of these runs
//! faults `observer_loss` between 2.5 and 3.7 s, the plant's R then 1.13–1.42 × the model's.
//! The zoo's motors here are those whose resistive drop at that point is at least 0.6 of the
//! back-EMF (the range where R is measured); on the others R stays at the start's.

mod common;
use common::run_json;

fn check(motor: &[&str], identified: bool, observer: &str, seed: &str) {
    let mut args = vec![
        "run",
        "warm-winding-loaded",
        "--observer",
        observer,
        "--seed",
        seed,
    ];
    args.extend_from_slice(motor);
    if identified {
        args.push("--identified");
    }
    let (v, code) = run_json(&args);
    let label = format!("{motor:?} {observer} seed {seed}");
    assert_eq!(code, Some(0), "{label}: {}", v["reasons"]);
    let err = v["adapted"]["r_err_pct"].as_f64().unwrap();
    assert!(
        err.abs() < 5.0,
        "{label}: R̂ {err:+.2} % of the plant's warm R"
    );
}

#[test]
fn the_resistance_is_tracked_on_the_sinano_motor() {
    for observer in ["flux", "sliding-torque"] {
        for seed in ["1", "2"] {
            check(&["--motor", "sinano"], false, observer, seed);
        }
    }
}

#[test]
fn the_resistance_is_tracked_on_identified_zoo_motors() {
    let dir = env!("CARGO_MANIFEST_DIR");
    for motor in [
        "drone-tmotor-f60pro-v-2550kv",
        "gimbal-ipower-gm4108h-120t",
        "hoverboard-6.5in-hub-odrive",
        "nema23-teknic-m2310p",
        "servo-maxon-645106",
        "servo60-d60m-r6430",
        "small-anaheim-bly171d-24v-4000",
        "small-anaheim-bly172s-24v-4000",
    ] {
        let file = format!("{dir}/motors/zoo/{motor}.toml");
        for observer in ["flux", "sliding-torque"] {
            check(&["--motor-file", &file], true, observer, "1");
        }
    }
}
