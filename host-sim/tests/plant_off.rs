//! With every switch off the plant's currents go through the inverter's freewheeling diodes
//! into the bus (`pmsm_plant::DiodeBridge`): below the speed whose line-to-line back-EMF peak
//! equals the bus the motor coasts without current; above it the bridge brakes it into the
//! bus, so an assisting load cannot run it away.

use pmsm_host_sim::plant::{Plant, PlantParams, StiffBus};
use pmsm_sensorless::motor::HORNG_SINANO;

const BUS_V: f64 = 48.0;
const H: f64 = 1e-5;

fn sinano() -> PlantParams {
    PlantParams::from(&HORNG_SINANO.params)
}

/// The speed \[rad/s] whose line-to-line back-EMF peak, `√3 N ψ_f ω`, equals the bus.
fn conduction_speed(p: &PlantParams) -> f64 {
    BUS_V / (3f64.sqrt() * p.n * p.flux)
}

/// Runs `seconds` with the switches off and load torque `load_nm`; the speed \[rad/s] and
/// the current's magnitude \[A] every millisecond.
fn coast(plant: &mut Plant, load_nm: f64, seconds: f64) -> (Vec<f64>, Vec<f64>) {
    let mut speeds = Vec::new();
    let mut currents = Vec::new();
    for _ in 0..(seconds * 1000.0).round() as usize {
        plant.advance_off(|_, _| load_nm, H, 100);
        speeds.push(plant.state.omega_m);
        currents.push(plant.state.i_alpha.hypot(plant.state.i_beta));
    }
    (speeds, currents)
}

fn largest(x: &[f64]) -> f64 {
    x.iter().copied().fold(0.0, f64::max)
}

#[test]
fn below_the_bus_the_motor_coasts_without_current() {
    let p = sinano();
    let w0 = 0.9 * conduction_speed(&p);
    let mut plant = Plant::new(p, StiffBus { v_bus: BUS_V }, 0.3, w0);
    let (speeds, currents) = coast(&mut plant, 0.0, 1.0);
    assert_eq!(largest(&currents), 0.0, "a diode conducted below the bus");
    // Only friction: ω(t) = ω0 e^{−B t/J}.
    let expected = w0 * (-p.b / p.j * 1.0).exp();
    let w = *speeds.last().unwrap();
    assert!((w - expected).abs() < 1e-6 * w0, "{w} vs {expected}");
}

#[test]
fn above_the_bus_the_diodes_brake_the_rotor_down_to_the_bus() {
    let p = sinano();
    let w_th = conduction_speed(&p);
    let mut plant = Plant::new(p, StiffBus { v_bus: BUS_V }, 0.3, 2.0 * w_th);
    let (speeds, currents) = coast(&mut plant, 0.0, 1.0);
    assert!(largest(&currents) > 1.0, "no current through the diodes");
    // The energy went into the bus: the electrical energy into the motor is negative.
    assert!(plant.state.e_in < 0.0, "{}", plant.state.e_in);
    // Braked until the back-EMF is down to the bus: when the last diode stops conducting the
    // speed is within 2 % above the conduction speed; from there friction alone slows it.
    let last = currents.iter().rposition(|i| *i > 0.0).unwrap();
    assert!(last < 500, "still conducting after {last} ms");
    let w = speeds[last];
    assert!(w > w_th && w < 1.02 * w_th, "{w} vs {w_th}");
}

/// The case: an assisting load that would run the rotor away (0.1 N·m on 6.45e-5
/// kg·m² is 1550 rad/s², 23 krpm within 1.6 s) is held near the conduction speed: the
/// diodes' braking torque grows with the excess back-EMF until it balances the load.
#[test]
fn an_assisting_load_cannot_run_the_motor_away_with_pwm_off() {
    let p = sinano();
    let w_th = conduction_speed(&p);
    let load_nm = -0.1; // assisting: negative load torque in eq (19)
    let mut plant = Plant::new(p, StiffBus { v_bus: BUS_V }, 0.3, 0.5 * w_th);
    let (speeds, currents) = coast(&mut plant, load_nm, 3.0);
    let i_max = largest(&currents);
    let w_end = *speeds.last().unwrap();
    let w_peak = largest(&speeds);
    assert!(w_end > w_th, "{w_end} vs {w_th}");
    // At 0.1 N·m, 1/7 of rated torque, the excess back-EMF needed is small: the level is
    // within 20 % above the conduction speed (the measured level is printed below).
    assert!(w_peak < 1.2 * w_th, "peak {w_peak} rad/s vs {w_th}");
    // Level: over the last second the diodes cancel the load's acceleration |τ|/J to 0.1 %.
    let w_1s_before = speeds[speeds.len() - 1001];
    let free_gain = load_nm.abs() / p.j * 1.0;
    assert!(
        (w_end - w_1s_before).abs() < 1e-3 * free_gain,
        "{w_1s_before} -> {w_end}"
    );
    // The current the load pushes into the bus: mean torque N ψ_f i_q balances the load.
    assert!(i_max > 0.1, "{i_max}");
    println!(
        "levels off at {:.1} rpm, conduction from {:.1} rpm, peak current {i_max:.2} A",
        w_end * 30.0 / std::f64::consts::PI,
        w_th * 30.0 / std::f64::consts::PI
    );
}

/// `run --load-kind` replaces the scenario's load kind: with the drive off, 30 % of rated
/// torque on a rotor at rest holds it as a brake, and as an active load (a hanging mass)
/// turns it backwards until the diodes hold it just above the conduction speed.
#[test]
fn load_kind_flag_brake_holds_active_turns_the_rotor_until_the_diodes_hold_it() {
    let dir = std::env::temp_dir().join(format!("pmsm-sim-off-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("hold.toml");
    std::fs::write(
        &file,
        "description = \"drive off, 30 % rated torque on a rotor at rest\"\nduration_s = 2.0\nspeed = [[0.0, 0.0]]\nload = [[0.0, 0.3]]\nload_kind = \"brake\"\nenable = [[0.0, false]]\nwindows = [[\"held\", 1.5, 2.0]]\n",
    )
    .unwrap();
    let mean_rpm = |kind: &str| {
        let out = std::process::Command::new(env!("CARGO_BIN_EXE_pmsm-sim"))
            .args([
                "run",
                "--ideal",
                "--scenario-file",
                file.to_str().unwrap(),
                "--observer",
                "flux",
            ])
            .args(["--load-kind", kind, "--json"])
            .output()
            .unwrap();
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        v["windows"]["held"]["speed_err_mean_rpm"].as_f64().unwrap()
    };
    assert_eq!(mean_rpm("brake"), 0.0);
    let th_rpm = conduction_speed(&sinano()) * 30.0 / std::f64::consts::PI;
    let w = mean_rpm("active");
    assert!(
        w < -th_rpm && w > -1.3 * th_rpm,
        "{w} rpm vs conduction at {th_rpm} rpm"
    );
}
