//! Issue #26's speed loop on current-sensor noise. The Brusa HSM1 (L I/ψ_f ≈ 2.9, J 0.039
//! kg·m²) at 3 % of rated speed with the board's 1 %-of-rated noise: at the default 20 Hz speed
//! loop on a 50 Hz PLL the flux observer's angle noise (`L_q σ_i/ψ_f`) came through the PLL's
//! proportional path and the speed PI as ±1.5× rated torque current (noise gain 41, every other
//! zoo motor below 1.2), and the mean speed was 10–16 % low. The default speed loop and its PLL
//! are lowered until the gain is 10 (`src/drive/config_observers.rs`).

mod common;
use common::run_json;

#[test]
fn a_noisy_high_armature_reaction_motor_holds_three_percent_speed() {
    let dir = env!("CARGO_MANIFEST_DIR");
    let scenario = format!("{dir}/scenarios/sup-low-speed-3.toml");
    let motor = format!("{dir}/motors/zoo/traction-ipm-brusa-hsm1-6.17.12.toml");
    for observer in ["flux", "sliding-torque"] {
        for seed in ["1", "2"] {
            let (v, code) = run_json(&[
                "run",
                "--scenario-file",
                &scenario,
                "--motor-file",
                &motor,
                "--observer",
                observer,
                "--seed",
                seed,
            ]);
            // The scenario's window: the mean speed within 2 % of the rated-speed share, no
            // fault, no lost lock (`pmsm-sim run` exits 3 otherwise).
            assert_eq!(code, Some(0), "{observer} seed {seed}: {}", v["reasons"]);
            assert_eq!(v["lost_lock"], false, "{observer} seed {seed}");
        }
    }
}
