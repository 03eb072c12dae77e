//! Issue #26's physical torque units: a motor file's N·m are a three-phase machine's,
//! `τ = (3/2) N ψ_f i_q` (`pmsm_sensorless::motor::TorqueConvention`).
//! - The drive's load estimates are the plant's load torque in those units: a real motor from
//!   the zoo (Teknic M-2310P, three-phase) under its rated torque, the sliding torque observer.
//! - The two conventions are the same dynamics: the motor in the papers' convention with `J`,
//!   `B` and its rated torque divided by 3/2 runs the same speed and currents.

use pmsm_host_sim::motor_file;
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, Run, SimConfig};
use pmsm_sensorless::motor::{Motor, TorqueConvention};

const PRIMARIES: [ObserverKind; 2] = [ObserverKind::SlidingTorque, ObserverKind::Flux];

fn teknic() -> Motor {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/motors/zoo/nema23-teknic-m2310p.toml"
    );
    let (_, m) = motor_file::load(std::path::Path::new(path)).unwrap();
    assert_eq!(m.params.torque, TorqueConvention::ThreePhase);
    m
}

/// `sup-load-steps-50` (rated torque on at 2 s, off at 3 s, half rated speed), ideal plant.
fn load_steps(m: Motor, observer: ObserverKind) -> Run {
    let sc = Spec::built_in("sup-load-steps-50")
        .unwrap()
        .build("m", m)
        .unwrap();
    run(SimConfig::new(sc, observer)).unwrap()
}

#[test]
fn the_load_estimate_is_the_plants_load_in_physical_newton_metres() {
    let m = teknic();
    let rated = f64::from(m.ratings.torque_nm);
    // The primary whose τ̂_L reaches the telemetry (the flux primary reports none).
    let observer = ObserverKind::SlidingTorque;
    let r = load_steps(m, observer);
    // The second half of the loaded window: the estimate has converged.
    let w: Vec<_> = r
        .rows
        .iter()
        .filter(|row| (2.6..3.0).contains(&row.t))
        .collect();
    let load = w.iter().map(|row| row.load_nm).sum::<f64>() / w.len() as f64;
    let est = w.iter().filter_map(|row| row.load_hat_nm).sum::<f64>() / w.len() as f64;
    println!(
        "{}: load {load:.4} N·m, estimate {est:.4} N·m",
        observer.name()
    );
    assert!((load - rated).abs() < 1e-9 * rated, "{load}");
    // Within 3 % of rated torque (a 3/2 error would be 33 %).
    assert!(
        (est - load).abs() < 0.03 * rated,
        "{}: {est} vs {load}",
        observer.name()
    );
}

#[test]
fn the_papers_convention_with_j_b_and_torque_over_three_halves_is_the_same_motor() {
    let m = teknic();
    let mut p = m;
    p.params = p.params.with_torque(TorqueConvention::Papers);
    p.params.j_kgm2 /= 1.5;
    p.params.b_nms /= 1.5;
    p.ratings.torque_nm /= 1.5;
    p.ratings.power_w /= 1.5;
    let p = p.validate().unwrap();
    for observer in PRIMARIES {
        let (a, b) = (load_steps(m, observer), load_steps(p, observer));
        assert_eq!(a.rows.len(), b.rows.len());
        let rated_rpm = f64::from(m.ratings.speed_rpm);
        let i_rated = f64::from(m.rated_torque_current_a());
        let (mut dw, mut di) = (0.0f64, 0.0f64);
        for (x, y) in a.rows.iter().zip(&b.rows) {
            dw = dw.max((x.speed_rpm - y.speed_rpm).abs());
            di = di.max((x.i_q - y.i_q).abs());
        }
        println!("{}: |Δω| {dw:.2e} rpm, |Δi_q| {di:.2e} A", observer.name());
        // The same dynamics up to f32 rounding: 0.01 % of rated speed and current.
        assert!(dw < 1e-4 * rated_rpm, "{}: {dw} rpm", observer.name());
        assert!(di < 1e-4 * i_rated, "{}: {di} A", observer.name());
    }
}
