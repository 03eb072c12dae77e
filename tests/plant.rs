//! Plant simulator checks: energy balance and the steady state of Horng & Chin step 6.

use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::scenario::profile::Pwl;
use pmsm_host_sim::scenario::{self, Scenario, Window};
use pmsm_host_sim::sim::{run, Sim, SimConfig};
use pmsm_host_sim::RAD_S_PER_RPM;

/// Electrical input = copper loss + friction + load work + Δ(stored magnetic + kinetic energy).
/// Returns (input J, relative residual).
fn energy_residual(cfg: SimConfig) -> (f64, f64) {
    let p0 = {
        let mut c = cfg.clone();
        c.scenario.duration_s = 0.0;
        run(c).unwrap().plant
    };
    let r = run(cfg).unwrap();
    assert!(r.fault.is_none());
    let (s, p) = (&r.plant.state, &r.plant.params);
    let stored = s.stored_energy(p) - p0.state.stored_energy(p);
    let out = s.e_copper + s.e_friction + s.e_load + stored;
    (s.e_in, (s.e_in - out).abs() / s.e_in)
}

#[test]
fn power_balance_within_0p1_percent() {
    // The whole Horng & Chin experiment: ramp, hold, brake on and off.
    let cfg = SimConfig::new(scenario::horng_ramp_brake(), ObserverKind::Encoder);
    let (e_in, rel) = energy_residual(cfg.clone());
    println!("ideal inverter: E_in = {e_in:.4} J, residual {rel:.3e}");
    assert!(e_in > 1.0);
    assert!(rel < 1e-3, "residual {rel:.3e}");
    // Discontinuous inputs: dead time, current noise and ADC quantisation.
    let mut harsh = cfg;
    harsh.board.dead_time_s = 1e-6;
    harsh.board.noise_sigma_a = 0.02;
    harsh.board.adc_lsb_a = 0.005;
    let (e_in, rel) = energy_residual(harsh);
    println!("dead time + noise: E_in = {e_in:.4} J, residual {rel:.3e}");
    assert!(rel < 1e-3, "residual {rel:.3e}");
}

/// A constant-speed scenario with a constant load, to read the steady state.
fn hold(speed_rpm: f64, load_nm: f64) -> Scenario {
    Scenario {
        name: "test-hold".into(),
        description: "ramp to a speed, hold under constant load".into(),
        speed_cmd_rpm: Pwl::ramp(0.0, 0.0, 0.5, speed_rpm),
        load_shape: Pwl::step(0.6, 1.0),
        load_nm,
        duration_s: 2.0,
        windows: vec![Window::new("steady", 1.5, 2.0)],
        ..scenario::horng_ramp_brake()
    }
}

#[test]
fn steady_state_iq_matches_horng_step_6() {
    for (speed_rpm, load_nm) in [(1000.0, 0.2), (500.0, 0.1), (-700.0, -0.15), (300.0, 0.0)] {
        let mut sim = Sim::new(SimConfig::new(
            hold(speed_rpm, load_nm),
            ObserverKind::Encoder,
        ))
        .unwrap();
        while sim.t() < 1.5 {
            sim.step().unwrap();
        }
        let s0 = sim.plant().state;
        let (t0, mut i_d_max) = (sim.t(), 0.0f64);
        while sim.t() < 2.0 {
            i_d_max = i_d_max.max(sim.step().unwrap().i_d.abs());
        }
        let (s1, p, dt) = (sim.plant().state, sim.plant().params, sim.t() - t0);
        // Exact time averages over the window, from the plant's integrals.
        let i_q = (s1.iq_dt - s0.iq_dt) / dt;
        let omega = (s1.theta_m - s0.theta_m) / dt;
        // Horng & Chin step 6: i_d = 0, i_q = (Bω + τ_L)/(KN).
        let expected = (p.b * omega + load_nm) / (p.flux * p.n);
        let rel = (i_q - expected).abs() / expected.abs();
        println!("{speed_rpm} rpm, {load_nm} N·m: i_q {i_q:.6} A vs {expected:.6} A (rel {rel:.1e}), |i_d| ≤ {i_d_max:.1e} A");
        // Left over: J Δω/Δt from the speed loop's residual motion, 1e-4 relative at most.
        assert!(rel < 1e-4, "i_q {i_q} vs {expected}");
        assert!(i_d_max < 0.05 * expected.abs(), "i_d {i_d_max}");
        assert!(
            (omega / RAD_S_PER_RPM - speed_rpm).abs() < 0.01,
            "speed {omega}"
        );
    }
}
