//! Issue #26's inertia mismatch (`src/drive/speed_gain.rs`). The board's defaults; the run
//! must pass its verdict.
//!
//! - The drive told ten times the rotor's inertia (`--mismatch j=10`), both primaries: the
//!   speed loop's gain `J ω_s/K_t` ten times too high limit-cycles (the torque command
//!   banging between its limits, the rotor's mean speed 4–20 % off its command in the loaded
//!   windows), until the drive finds the oscillation and halves the gain. Measured without
//!   the check (main at ebfab9a): 10 of these 12 runs failed their windows, the mean speed
//!   error in a loaded window −2.1 to −4.3 % of rated on the Delta servo, −12 to −18 % on the
//!   gimbal, −2.6 and −2.7 % on the Teknic's `start-stop-reverse` (its `sup-start-brake-100`
//!   passed).
//! - Told a tenth of it (`j=0.1`), the flux primary: the speed loop with the load-torque
//!   observer at a tenth of the inertia oscillates at a few hertz (the Teknic ±2,000 rpm at
//!   6 Hz at its rated 4,000 rpm), until the drive measures the inertia from the oscillation
//!   and raises the gain. Measured without the measurement (main at 6658e3c): these 6 runs
//!   failed their windows, the mean speed error in the worst window 4.2–10.3 % of rated
//!   (`zoo-inertia.toml`, seed 1).
//! - Told a tenth of it, the sliding primary: its model carries the configured inertia, and
//!   its speed moves every step with the torque current, ten times as fast as the rotor's;
//!   fed forward as back-EMF within the step, that made the current loop run away
//!   (`src/drive/sensorless.rs`, `Settings::step`). The current loop takes the speed of the
//!   last 1 kHz task. Measured before (main at 8eeabf3): 5 of these 6 runs failed
//!   (`overcurrent` on the Delta, a window 2.8–3.5 % off or `observer_loss` on the
//!   Anaheims). The sliding observer still disagrees with the rotor and hands over to the
//!   monitor and back (7 to 29 times a run). (The measurement of the inertia does not change
//!   the sliding observer's model: 16 of the zoo's 96 such runs still fail,
//!   `zoo-inertia.toml`.)

mod common;
use common::run_json;

/// Every run of `scenario` × `observers` on each zoo motor of `motors`, the drive told
/// `mismatch`, passes its verdict.
fn every_run_passes(motors: &[&str], scenarios: &[&str], mismatch: &str, observers: &[&str]) {
    let dir = env!("CARGO_MANIFEST_DIR");
    for motor in motors {
        let file = format!("{dir}/motors/zoo/{motor}.toml");
        for scenario in scenarios {
            for observer in observers {
                let args = [
                    "run",
                    scenario,
                    "--motor-file",
                    &file,
                    "--mismatch",
                    mismatch,
                    "--observer",
                    observer,
                ];
                let (v, code) = run_json(&args);
                assert_eq!(
                    code,
                    Some(0),
                    "{motor} {scenario} {mismatch} {observer}: {}",
                    v["reasons"]
                );
            }
        }
    }
}

#[test]
fn a_speed_loop_ten_times_too_stiff_is_calmed_on_zoo_motors() {
    every_run_passes(
        &[
            "acservo-delta-ecma-c20604rs",
            "gimbal-ipower-gm4108h-120t",
            "nema23-teknic-m2310p",
        ],
        &["sup-start-brake-100", "start-stop-reverse"],
        "j=10",
        &["flux", "sliding-torque"],
    );
}

#[test]
fn a_speed_loop_with_a_tenth_of_the_inertia_is_raised_on_zoo_motors() {
    every_run_passes(
        &[
            "acservo-delta-ecma-c20604rs",
            "nema23-teknic-m2310p",
            "servo60-d60m-r6430",
        ],
        &["start-stop-reverse", "ramp-brake-drive"],
        "j=0.1",
        &["flux"],
    );
}

#[test]
fn a_sliding_primary_with_a_tenth_of_the_inertia_passes_on_zoo_motors() {
    every_run_passes(
        &[
            "acservo-delta-ecma-c20604rs",
            "small-anaheim-bly171d-24v-4000",
            "small-anaheim-bly172s-24v-4000",
        ],
        &["start-stop-reverse", "ramp-brake-drive"],
        "j=0.1",
        &["sliding-torque"],
    );
}
