//! Closed loop through the core's FOC: sensored baseline on Horng & Chin's experiment and the
//! current-loop bandwidth.

use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario;
use pmsm_host_sim::sim::{run, SimConfig};

#[test]
fn sensored_horng_ramp_brake_holds_speed() {
    let r = run(SimConfig::new(
        scenario::horng_ramp_brake(),
        ObserverKind::Encoder,
    ))
    .unwrap();
    let s = Summary::of(&r);
    println!("{s:#?}");
    assert!(!s.lost_lock);
    assert_eq!(s.fault, None);
    for w in ["pre_brake", "brake"] {
        let m = s.window(w).unwrap();
        assert!(
            m.speed_err_mean_rpm.abs() < 0.5,
            "{w}: {}",
            m.speed_err_mean_rpm
        );
        assert!(
            m.theta_err_max_abs_deg_e < 1e-3,
            "encoder angle is exact to f32"
        );
        assert_eq!(m.torque_hat_mean_nm, None);
    }
}

/// Locked rotor, `i_q` step of 1 A through the core's current loop: the plant current must
/// reach 63.2 % at `1/ω_c` (0.53 ms for 300 Hz) within one control period.
#[test]
fn current_loop_has_the_requested_bandwidth() {
    use pmsm_host_sim::plant::{Inverter, Plant, PlantParams, StiffBus};
    use pmsm_sensorless::foc::{CurrentLoopState, FocConfig, FocInput, Reference};
    use pmsm_sensorless::frames::Dq;
    use pmsm_sensorless::motor::HORNG_SINANO;

    let m = HORNG_SINANO;
    let cfg = FocConfig::new(m.params, 3.0);
    let foc = cfg.build().unwrap();
    let mut params = PlantParams::from(&m.params);
    params.j = 1e9; // locked rotor
    let mut plant = Plant::new(params, StiffBus { v_bus: 48.0 }, 0.3, 0.0);
    let inverter = Inverter {
        dead_time_s: 0.0,
        pwm_hz: 16e3,
    };
    let ts = 1.0 / cfg.current_rate_hz as f64;
    let n_sub = 25;
    let mut st = CurrentLoopState::default();
    let (mut t_cross, mut peak, mut t) = (None, 0.0f64, 0.0);
    for _ in 0..40 {
        let i = plant.i_abc();
        let theta_e = plant.state.theta_e(&plant.params) as f32;
        let input = FocInput {
            i_abc: pmsm_sensorless::frames::Abc::new(i[0] as f32, i[1] as f32, i[2] as f32),
            v_bus: 48.0,
            theta_e,
            omega_m: 0.0,
            omega_m_ref: 0.0,
            torque_ff_nm: 0.0,
        };
        let req = input.request(&foc, Reference::Current(Dq::new(0.0, 1.0)));
        let out = foc.run(&mut st, &req, input.i_ab(), input.v_bus);
        let held = inverter.hold(out.duties);
        for k in 0..n_sub {
            plant.advance(&held, |_, _| 0.0, ts / n_sub as f64, 1);
            let i_q = plant.state.i_dq(&plant.params).1;
            let tk = t + (k + 1) as f64 * ts / n_sub as f64;
            if t_cross.is_none() && i_q >= 1.0 - (-1.0f64).exp() {
                t_cross = Some(tk);
            }
            peak = peak.max(i_q);
        }
        t += ts;
    }
    let t_cross = t_cross.expect("never reached 63 %");
    let tau = 1.0 / (2.0 * std::f64::consts::PI * cfg.current_bandwidth_hz as f64);
    println!(
        "63 % at {:.3} ms (1/ω_c = {:.3} ms), peak {peak:.4} A",
        t_cross * 1e3,
        tau * 1e3
    );
    assert!(
        (t_cross - tau).abs() <= ts,
        "63 % at {t_cross} s, expected {tau} s ± {ts} s"
    );
    assert!(peak < 1.05, "overshoot: peak {peak} A");
    assert!((plant.state.i_dq(&plant.params).1 - 1.0).abs() < 1e-3);
}
