//! Salient and saturating plants (issue #29, the plant and the motor files): the dq model
//! with `L_d = L_q` against the papers' αβ model on the papers' experiments, the torque of
//! the salient zoo motors against the closed form, saturation, the power balance, and the
//! motor files' inductance keys.

use pmsm_host_sim::board::SimBoard;
use pmsm_host_sim::motor_file;
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::plant::{
    AxisInductance, Converter, HeldDuties, Inductances, Inverter, Plant, PlantParams, Saturates,
    Saturation, StiffBus,
};
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::{self, Scenario};
use pmsm_host_sim::sim::{run, Row, SimConfig};
use pmsm_host_sim::RAD_S_PER_RPM;
use pmsm_sensorless::svpwm::Duties;
use std::path::Path;

/// The salient zoo motors (`host-sim/matrices/zoo-salient.toml` drives them).
const SALIENT_ZOO: [&str; 5] = [
    "motors/zoo/salient/industrial-ipm-aalto-2.2kw.toml",
    "motors/zoo/salient/traction-ipm-brusa-hsm1-6.17.12-salient.toml",
    "motors/zoo/salient/fs-ipm-amk-dd5-14-10-pow.toml",
    "motors/zoo/salient/industrial-ipm-caruso-2019.toml",
    "motors/zoo/salient/traction-pmasynrm-zou-350kw.toml",
];

fn load(rel: &str) -> motor_file::Loaded {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join(rel);
    motor_file::load_full(&path).unwrap()
}

/// The built-in `scenario` on the motor of `loaded` (its own L_d and L_q in the plant), the
/// board's defaults with the noise of `seed`, `observer` driving.
fn run_on_board(
    loaded: &motor_file::Loaded,
    scenario: &str,
    observer: ObserverKind,
    seed: u64,
) -> pmsm_host_sim::sim::Run {
    let m = loaded.motor;
    let sc = scenario::Spec::built_in(scenario)
        .unwrap()
        .build(&loaded.name, m)
        .unwrap();
    let mut board = SimBoard::board_defaults(&m);
    board.seed = seed;
    let mut cfg = SimConfig::on(board, sc, observer);
    cfg.plant_inductances = loaded.inductances;
    run(cfg).unwrap()
}

/// A saturation that never acts (`L(i) = L0` exactly at every finite current): the plant
/// takes the dq model with the physics of the round machine.
const NEVER: Saturation = Saturation {
    i_sat_a: f64::INFINITY,
    exponent: 1.0,
};

/// The largest difference of `f` between two traces, relative to the largest |f| of `a`.
fn rel_diff(a: &[Row], b: &[Row], f: impl Fn(&Row) -> f64) -> f64 {
    assert_eq!(a.len(), b.len());
    let scale = a.iter().map(|r| f(r).abs()).fold(0.0, f64::max).max(1e-12);
    let diff = a
        .iter()
        .zip(b)
        .map(|(x, y)| (f(x) - f(y)).abs())
        .fold(0.0, f64::max);
    diff / scale
}

/// `[1.2e-3, ...]`.
fn sci(x: &[f64]) -> String {
    let v: Vec<String> = x.iter().map(|v| format!("{v:.1e}")).collect();
    format!("[{}]", v.join(", "))
}

/// A stator voltage held over a control period (the replay of a recorded run).
struct HeldVoltage((f64, f64));

impl Converter for HeldVoltage {
    fn v_alpha_beta(&self, _v_dc: f64, _i: (f64, f64), _e: (f64, f64)) -> (f64, f64) {
        self.0
    }
}

/// The papers' experiments, each run closed loop on the papers' plant; then the stator
/// voltages that run applied, period by period, fed open loop to the papers' αβ model and to
/// the dq model with `L_d = L_q = L` and a saturation that never acts (the same machine):
/// the two plants' currents, speed and angle stay within 1e-9 of their ranges over the
/// whole experiment (the model, compared on the scenario's own inputs, without the drive's
/// f32 arithmetic in between).
#[test]
fn dq_model_with_equal_inductances_is_the_papers_model_on_their_experiments() {
    let cases: [(Scenario, ObserverKind); 3] = [
        (scenario::horng_ramp_brake(), ObserverKind::SlidingTorque),
        (scenario::ortega_steps(), ObserverKind::Flux),
        (scenario::ortega_load_800(), ObserverKind::FluxIi),
    ];
    for (sc, observer) in cases {
        let cfg = SimConfig::new(sc, observer);
        let rec = run(cfg.clone()).unwrap();
        let sc = &cfg.scenario;
        let papers = PlantParams::from(&sc.motor.params);
        let l = papers.l_d.l0_h;
        let dq = PlantParams::with_inductances(
            &sc.motor.params,
            Some(&Inductances {
                l_d_h: l,
                l_q_h: l,
                saturation_d: Some(NEVER),
                saturation_q: None,
            }),
        );
        assert!(papers.electrical().is_round() && !dq.electrical().is_round());
        let new = |p| {
            Plant::new(
                p,
                StiffBus {
                    v_bus: cfg.board.bus_v,
                },
                cfg.theta_m0,
                sc.initial_speed_rpm * RAD_S_PER_RPM,
            )
        };
        let (mut a, mut b) = (new(papers), new(dq));
        let ts = 1.0 / cfg.rate_hz;
        let h = ts / cfg.substeps as f64;
        let (mut diff, mut scale) = ([0.0f64; 4], [0.0f64; 4]);
        for row in &rec.rows {
            let held = HeldVoltage((row.v_alpha, row.v_beta));
            let load = |dt: f64, w: f64| sc.load_at(row.t + dt, w);
            a.advance(&held, load, h, cfg.substeps);
            b.advance(&held, load, h, cfg.substeps);
            let (x, y) = (a.state, b.state);
            let pairs = [
                (x.i_alpha, y.i_alpha),
                (x.i_beta, y.i_beta),
                (x.omega_m, y.omega_m),
                (x.theta_m, y.theta_m),
            ];
            for (k, (u, v)) in pairs.into_iter().enumerate() {
                diff[k] = diff[k].max((u - v).abs());
                scale[k] = scale[k].max(u.abs());
            }
        }
        let rel: Vec<f64> = (0..4).map(|k| diff[k] / scale[k].max(1e-12)).collect();
        println!(
            "{}: {} periods replayed, largest relative differences (i_α, i_β, ω, θ) {}",
            sc.name,
            rec.rows.len(),
            sci(&rel)
        );
        assert!(scale[2] > 10.0, "{}: the rotor must turn", sc.name);
        for r in rel {
            assert!(r < 1e-9, "{}: {r:.2e}", sc.name);
        }
    }
}

/// The same experiments closed loop, the drive on the dq model with `L_d = L_q`: the same
/// verdict and window figures. The traces agree to the drive's f32 arithmetic: a last-bit
/// difference of the plant's f64 state rounds the drive's f32 samples differently now and
/// then, and the loop carries that on (measured: 3e-12 of range on Horng & Chin's run,
/// up to 4e-5 on Ortega's 40 kW steps), so the bound here is 1e-4 of each trace's range.
#[test]
fn dq_model_with_equal_inductances_gives_the_papers_verdicts() {
    let cases: [(Scenario, ObserverKind); 3] = [
        (scenario::horng_ramp_brake(), ObserverKind::SlidingTorque),
        (scenario::ortega_steps(), ObserverKind::Flux),
        (scenario::ortega_load_800(), ObserverKind::FluxIi),
    ];
    for (sc, observer) in cases {
        let name = sc.name.clone();
        let papers = SimConfig::new(sc, observer);
        let l = f64::from(papers.scenario.motor.params.l_h);
        let mut dq = papers.clone();
        dq.plant_inductances = Some(Inductances {
            l_d_h: l,
            l_q_h: l,
            saturation_d: Some(NEVER),
            saturation_q: None,
        });
        let (a, b) = (run(papers).unwrap(), run(dq).unwrap());
        assert!(!b.plant.params.electrical().is_round(), "{name}: dq model");
        assert_eq!(a.fault, b.fault, "{name}");
        let (sa, sb) = (Summary::of(&a), Summary::of(&b));
        assert_eq!(sa.pass, sb.pass, "{name}");
        assert_eq!(sa.lost_lock_at_s, sb.lost_lock_at_s, "{name}");
        let worst = [
            rel_diff(&a.rows, &b.rows, |r| r.speed_rpm),
            rel_diff(&a.rows, &b.rows, |r| r.speed_hat_rpm),
            rel_diff(&a.rows, &b.rows, |r| r.i_d),
            rel_diff(&a.rows, &b.rows, |r| r.i_q),
            rel_diff(&a.rows, &b.rows, |r| r.theta_e_deg.to_radians().sin()),
            rel_diff(&a.rows, &b.rows, |r| r.theta_e_hat_deg.to_radians().sin()),
            rel_diff(&a.rows, &b.rows, |r| r.v_alpha),
        ];
        println!(
            "{name}: relative differences (ω, ω̂, i_d, i_q, sin θ_e, sin θ̂_e, v_α) {}",
            sci(&worst)
        );
        for w in worst {
            assert!(w < 1e-4, "{name}: {w:.2e}");
        }
    }
}

/// A motor file without `l_d_h`/`l_q_h` or `[saturation]` is the round machine of
/// `l_h`: the papers' model, exactly as before.
#[test]
fn a_motor_file_with_l_h_alone_is_the_round_machine() {
    let l = load("motors/zoo/traction-ipm-brusa-hsm1-6.17.12.toml");
    assert!(l.inductances.is_none());
    let p = PlantParams::with_inductances(&l.motor.params, l.inductances.as_ref());
    assert_eq!(p, PlantParams::from(&l.motor.params));
    assert!(p.electrical().is_round());
}

/// The salient zoo motors: the plant's torque at several currents and rotor angles, through
/// the integrator's path (`Pmsm::torque` on αβ currents) and the state's, against the
/// closed form `(3/2) N (ψ_f + (L_d − L_q) i_d) i_q`; the drive's one L is the mean.
#[test]
fn salient_zoo_motors_give_the_closed_form_torque() {
    for file in SALIENT_ZOO {
        let loaded = load(file);
        let m = loaded.motor;
        let own = loaded.inductances.expect("a salient file");
        let p = PlantParams::with_inductances(&m.params, Some(&own));
        let pmsm = p.electrical();
        assert!(!pmsm.is_round(), "{file}");
        assert_eq!(p.c, 1.5, "{file}: three-phase torque");
        let l_mean = 0.5 * (own.l_d_h + own.l_q_h);
        assert!(
            (f64::from(m.params.l_h) - l_mean).abs() < 1e-6 * l_mean,
            "{file}"
        );
        let i_rated = f64::from(m.ratings.current_a);
        let (n, psi) = (p.n, p.flux);
        for (kd, kq) in [
            (0.0, 1.0),
            (-0.5, 0.8),
            (0.3, -1.0),
            (-1.0, -0.5),
            (0.7, 0.0),
        ] {
            let (i_d, i_q) = (kd * i_rated, kq * i_rated);
            let closed = 1.5 * n * (psi + (own.l_d_h - own.l_q_h) * i_d) * i_q;
            for theta_e in [0.3f64, 2.0, -1.2, 4.0] {
                let (s, c) = theta_e.sin_cos();
                let i_ab = (c * i_d - s * i_q, s * i_d + c * i_q);
                let mut plant = Plant::new(p, StiffBus { v_bus: 100.0 }, theta_e / n, 0.0);
                (plant.state.i_alpha, plant.state.i_beta) = i_ab;
                let via_state = plant.state.torque(&p);
                let (sc, _) = pmsm.back_emf(theta_e / n, 0.0);
                let via_integrator = pmsm.torque(i_ab, sc);
                let tol = 1e-9 * (1.5 * n * psi * i_rated);
                assert!(
                    (via_state - closed).abs() < tol && (via_integrator - closed).abs() < tol,
                    "{file} i_d {i_d} i_q {i_q} θ_e {theta_e}: {via_state} / {via_integrator} vs {closed}"
                );
            }
        }
        // The reluctance torque adds with i_d < 0 on these (L_q > L_d) machines.
        let i = 0.8 * i_rated;
        assert!(
            pmsm.torque_dq(-0.5 * i_rated, i) > pmsm.torque_dq(0.0, i),
            "{file}"
        );
        println!(
            "{file}: L_q/L_d {:.2}, drive's L {:.4e} H, torque at (−0.5, 0.8) I_rated {:.3} N·m vs {:.3} at i_d = 0",
            own.l_q_h / own.l_d_h,
            m.params.l_h,
            pmsm.torque_dq(-0.5 * i_rated, i),
            pmsm.torque_dq(0.0, i)
        );
    }
}

/// Saturation: `L_d` falls only with a current adding to the magnet's flux, `L_q` with
/// `|i_q|`; the secant inductance halves at `i_sat`; the flux rises with the current at every
/// current (positive incremental inductance) for exponents up to 1; the energy is `∫ i dψ`.
#[test]
fn saturation_follows_the_froehlich_curve() {
    for exponent in [0.5, 1.0] {
        let sat = Saturation {
            i_sat_a: 100.0,
            exponent,
        };
        let d = AxisInductance {
            l0_h: 1e-3,
            saturation: Some(sat),
            saturates: Saturates::Positive,
        };
        let q = AxisInductance {
            saturates: Saturates::Magnitude,
            ..d
        };
        assert_eq!(d.secant_h(-300.0), 1e-3, "a demagnetising i_d leaves L_d");
        assert_eq!(d.incremental_h(-300.0), 1e-3);
        assert!((d.secant_h(100.0) - 0.5e-3).abs() < 1e-15);
        assert!((q.secant_h(-100.0) - 0.5e-3).abs() < 1e-15);
        assert_eq!(q.secant_h(-250.0), q.secant_h(250.0));
        assert!(q.secant_h(50.0) > q.secant_h(150.0));
        let mut last = f64::NEG_INFINITY;
        for k in 0..=2000 {
            let i = -1000.0 + k as f64;
            let psi = q.flux_wb(i);
            assert!(psi > last, "exponent {exponent}: ψ must rise at {i} A");
            assert!(q.incremental_h(i) > 0.0);
            // dψ/di against a central difference.
            let h = 1e-4;
            let fd = (q.flux_wb(i + h) - q.flux_wb(i - h)) / (2.0 * h);
            if i.abs() > 1.0 {
                assert!((fd - q.incremental_h(i)).abs() < 1e-6 * q.l0_h, "{i} A");
            }
            last = psi;
        }
        // Energy: ∫ i dψ = i ψ(i) − ∫ ψ di, against a fine trapezoid of the co-energy.
        let i = 250.0;
        let steps = 200_000;
        let co: f64 = (0..steps)
            .map(|k| {
                let (a, b) = (
                    k as f64 * i / steps as f64,
                    (k + 1) as f64 * i / steps as f64,
                );
                0.5 * (q.flux_wb(a) + q.flux_wb(b)) * (b - a)
            })
            .sum();
        let w = i * q.flux_wb(i) - co;
        assert!(
            (q.energy_j(i) - w).abs() < 1e-6 * w,
            "{} vs {w}",
            q.energy_j(i)
        );
    }
}

/// With saturation, the torque is the closed form with the secant inductances at the
/// currents: `(3/2) N (ψ_f + (L_d(i_d) − L_q(i_q)) i_d) i_q`.
#[test]
fn saturated_torque_uses_the_secant_inductances() {
    let loaded = load(SALIENT_ZOO[1]);
    let mut own = loaded.inductances.unwrap();
    own.saturation_d = Some(Saturation {
        i_sat_a: 400.0,
        exponent: 1.0,
    });
    own.saturation_q = Some(Saturation {
        i_sat_a: 200.0,
        exponent: 0.8,
    });
    let p = PlantParams::with_inductances(&loaded.motor.params, Some(&own));
    let pmsm = p.electrical();
    for (i_d, i_q) in [(100.0, 300.0), (-200.0, 250.0), (50.0, -400.0)] {
        let l_d = if i_d > 0.0 {
            own.l_d_h / (1.0 + i_d / 400.0)
        } else {
            own.l_d_h
        };
        let l_q = own.l_q_h / (1.0 + (f64::abs(i_q) / 200.0).powf(0.8));
        let closed = 1.5 * p.n * (p.flux + (l_d - l_q) * i_d) * i_q;
        let t = pmsm.torque_dq(i_d, i_q);
        assert!((t - closed).abs() < 1e-12 * closed.abs(), "{t} vs {closed}");
    }
}

/// The power balance of a salient, saturating plant driven open loop through the
/// inverter into saturation: electrical energy in = copper loss + friction + load work
/// + Δ(magnetic + kinetic energy), within 0.1 %.
#[test]
fn a_salient_saturating_plant_keeps_the_power_balance() {
    let loaded = load(SALIENT_ZOO[1]);
    let mut own = loaded.inductances.unwrap();
    own.saturation_d = Some(Saturation {
        i_sat_a: 150.0,
        exponent: 1.0,
    });
    own.saturation_q = Some(Saturation {
        i_sat_a: 150.0,
        exponent: 0.7,
    });
    let mut p = PlantParams::with_inductances(&loaded.motor.params, Some(&own));
    p.b = 0.01;
    let v_bus = 400.0;
    let mut plant = Plant::new(p, StiffBus { v_bus }, 0.2, 30.0);
    let inverter = Inverter {
        dead_time_s: 0.0,
        pwm_hz: 20e3,
    };
    let e0 = plant.state.stored_energy(&p);
    let (ts, n_sub) = (1.0 / 16e3, 25);
    let mut peak_a = 0.0f64;
    for k in 0..4000 {
        let t = k as f64 * ts;
        // A voltage vector rotating at 50 Hz electrical, 20 V peak: hundreds of amperes.
        let angle = 2.0 * std::f64::consts::PI * 50.0 * t;
        let duty = |phase: f64| (0.5 + 20.0 / v_bus * (angle - phase).cos()) as f32;
        let tau = 2.0 * std::f64::consts::PI / 3.0;
        let held: HeldDuties = inverter.hold(Duties {
            a: duty(0.0),
            b: duty(tau),
            c: duty(-tau),
        });
        plant.advance(
            &held,
            |_, w: f64| 5.0 * w.signum(),
            ts / n_sub as f64,
            n_sub,
        );
        let i = plant.state.i_dq(&p);
        peak_a = peak_a.max(i.0.hypot(i.1));
    }
    let s = plant.state;
    let stored = s.stored_energy(&p) - e0;
    let out = s.e_copper + s.e_friction + s.e_load + stored;
    let rel = (s.e_in - out).abs() / s.e_in.abs().max(out.abs());
    println!(
        "E_in {:.3} J, copper {:.3}, friction {:.3}, load {:.3}, Δstored {:.3}; peak |i| {peak_a:.0} A; residual {rel:.2e}",
        s.e_in, s.e_copper, s.e_friction, s.e_load, stored
    );
    assert!(
        peak_a > 300.0,
        "the run must reach saturation ({peak_a:.0} A)"
    );
    assert!(rel < 1e-3, "residual {rel:.2e}");
}

/// The motor files' inductance keys: `_ll` forms halve, and bad values are refused with an
/// error naming the key.
#[test]
fn motor_files_take_l_d_and_l_q_and_refuse_bad_ones() {
    // The inductance keys, then any `[saturation.*]` table after the rest.
    let base = |keys: &str| {
        let (l, tables) = keys
            .split_once('[')
            .map_or((keys, String::new()), |(l, t)| (l, format!("[{t}")));
        format!(
            "name = \"t\"\npole_pairs = 4\nr_ohm = 0.1\n{l}\nflux_wb = 0.05\nj_kgm2 = 1e-3\n\
             [ratings]\nbus_v = 48.0\ncurrent_a = 10.0\n{tables}\n"
        )
    };
    let ok = motor_file::parse_full(&base("l_d_h_ll = 2e-3\nl_q_h_ll = 5e-3")).unwrap();
    let own = ok.inductances.unwrap();
    assert_eq!((own.l_d_h, own.l_q_h), (1e-3, 2.5e-3));
    assert_eq!(ok.motor.params.l_h, 1.75e-3);
    assert!(own.saturation_d.is_none() && own.saturation_q.is_none());
    let sat = motor_file::parse_full(&base(
        "l_h = 1e-3\n[saturation.q]\ni_sat_a = 30.0\nexponent = 0.5",
    ))
    .unwrap()
    .inductances
    .unwrap();
    assert_eq!((sat.l_d_h, sat.l_q_h), (1e-3, 1e-3));
    assert_eq!(
        sat.saturation_q,
        Some(Saturation {
            i_sat_a: 30.0,
            exponent: 0.5
        })
    );
    let sat_d = motor_file::parse_full(&base(
        "l_d_h = 1e-3\nl_q_h = 2e-3\n[saturation.d]\ni_sat_a = 30.0",
    ))
    .unwrap()
    .inductances
    .unwrap();
    assert_eq!(
        sat_d.saturation_d.unwrap().exponent,
        1.0,
        "default exponent"
    );
    for (keys, needle) in [
        ("l_d_h = -1e-3\nl_q_h = 2e-3", "l_d_h = -0.001"),
        ("l_d_h = 1e-3\nl_q_h = nan", "l_q_h = NaN"),
        ("l_d_h = 1e-3\nl_q_h = inf", "l_q_h"),
        ("l_d_h_ll = 0.0\nl_q_h = 2e-3", "l_d_h_ll = 0"),
        ("l_d_h = 1e-3\nl_q_h = 5e-2", "l_q_h / l_d_h = 50"),
        ("l_d_h = 1e-3\nl_q_h = 3e-4", "l_q_h / l_d_h = 0.3"),
        ("l_h = 1e-3\nl_d_h = 1e-3\nl_q_h = 2e-3", "not both"),
        ("l_d_h = 1e-3", "missing field: l_q_h"),
        (
            "l_d_h = 1e-3\nl_d_h_ll = 2e-3\nl_q_h = 2e-3",
            "give l_d_h or l_d_h_ll",
        ),
        (
            "l_h = 1e-3\n[saturation.q]\ni_sat_a = 30.0\nexponent = 2.0",
            "saturation.q.exponent = 2",
        ),
        (
            "l_h = 1e-3\n[saturation.d]\ni_sat_a = 0.0",
            "saturation.d.i_sat_a = 0",
        ),
        (
            "l_h = 1e-3\n[saturation.d]\ni_sat_a = nan",
            "saturation.d.i_sat_a",
        ),
        ("l_h = 1e-3\n[saturation.d]\ni_sat = 3.0", "i_sat"),
    ] {
        let err = motor_file::parse_full(&base(keys)).unwrap_err().to_string();
        assert!(err.contains(needle), "{keys:?}: {err:?} lacks {needle:?}");
    }
}

/// The sliding observer on the active flux (`observer/sliding.rs`): the Aalto IPM
/// (`L_q/L_d` 2.3), its true file, the board's defaults, the sliding torque observer driving,
/// start-stop-reverse with MTPA: every window within 2 % of its command. With `L` the mean and
/// `K = ψ_f`, MTPA's negative `i_d` read as speed (`(L_d − L_q) i_d/ψ_f`) left the rotor 7 %
/// slow at 1000 rpm (`host-sim/matrices/zoo-salient.toml`).
#[test]
fn the_sliding_observer_on_the_active_flux_holds_an_ipms_speed() {
    let loaded = load("motors/zoo/salient/industrial-ipm-aalto-2.2kw.toml");
    let r = run_on_board(
        &loaded,
        "start-stop-reverse",
        ObserverKind::SlidingTorque,
        1,
    );
    let s = Summary::of(&r);
    println!("worst window {:?} %", s.worst_speed_err_pct);
    assert!(s.pass, "{:?}", s.reasons);
}

/// The flux observer's γ on a salient motor (`observer/flux.rs`, "Bounds with ψ_a"): chosen so
/// that `γ ψ_a²` at the active flux of the MTPA's currents on the current limit is the
/// non-salient design's `γ ψ_f²`; and the Brusa HSM1 (`L_q/L_d` 3.2, its true file, the board's
/// defaults, the flux observer driving) reverses from +20 % to −20 % of its rated speed under
/// a 30 % brake on seeds 1 and 2 without losing its angle. With the design's γ for `ψ_f` (and
/// the MTPA's Newton step overshooting), the active flux, up to 3.5 `ψ_f` at 230–530 rpm, put
/// eq (17)'s `|Ω0|` below ½, and seed 1 ended in `observer_loss` at 0.46 s.
#[test]
fn a_strongly_salient_rotor_reverses_under_a_brake_on_the_active_flux() {
    use pmsm_sensorless::drive::DriveConfig;
    use pmsm_sensorless::mtpa::Mtpa;
    use pmsm_sensorless::observer::flux::FluxConfig;
    let loaded = load("motors/zoo/salient/traction-ipm-brusa-hsm1-6.17.12-salient.toml");
    let m = loaded.motor;
    let cfg = DriveConfig::new(&m);
    let psi_f = m.params.flux_wb;
    // The MTPA's d current on the current limit, and its active flux ψ_f + (L_d − L_q) i_d.
    let mtpa = Mtpa::new(&m.params, cfg.limits.i_max_a).expect("salient");
    let i_d = mtpa.i_d_for_current(cfg.limits.i_max_a);
    let psi_a_max = psi_f + m.params.l_d_minus_l_q_h() * i_d;
    let design = FluxConfig::new(m.params, cfg.rate_hz, cfg.start.handback_rpm).gamma;
    let gamma = cfg.flux_config().gamma;
    println!(
        "ψ_a at the current limit {:.2} ψ_f, γ {gamma} of {design}",
        psi_a_max / psi_f
    );
    assert!(psi_a_max > 2.0 * psi_f, "{psi_a_max}");
    let (scaled, designed) = (gamma * psi_a_max * psi_a_max, design * psi_f * psi_f);
    assert!(
        (scaled - designed).abs() <= 1e-5 * designed,
        "{scaled} {designed}"
    );
    for seed in [1, 2] {
        let r = run_on_board(&loaded, "sup-reverse-20", ObserverKind::Flux, seed);
        let s = Summary::of(&r);
        println!(
            "seed {seed}: worst window {:?} %, θ error at most {:?}° electrical",
            s.worst_speed_err_pct, s.theta_err_max_deg_e
        );
        assert!(s.pass && !s.lost_lock, "seed {seed}: {:?}", s.reasons);
    }
}

/// A rotor at rest after the align is not taken for one turning against the command: the
/// Caruso IPM (its true file, the board's defaults, the sliding observer driving, seed 2),
/// start-stop-reverse, whose second start (to −50 % of rated) aligns a resting rotor. Both
/// observers are seeded healthy there, and the sliding observer's estimate swung to 1,200 to
/// 4,900 rpm in its first milliseconds (residual 1.4 to 4.3): the open loop handed the rotor
/// to sensorless control (`AgainstCommand`) on that observer's wrong angle, 148° off, and the
/// run failed on a lost lock at 4.71 s. The open loop now counts a reversal only at checks
/// where the driving observer's residual is below `LOST` (`open_loop.rs`,
/// `Health::driving_residual_below_lost`).
#[test]
fn a_resting_rotor_after_the_align_is_not_taken_for_a_reversal() {
    use pmsm_sensorless::drive::Reason;
    let loaded = load("motors/zoo/salient/industrial-ipm-caruso-2019.toml");
    let r = run_on_board(
        &loaded,
        "start-stop-reverse",
        ObserverKind::SlidingTorque,
        2,
    );
    let s = Summary::of(&r);
    let against: Vec<f64> = r
        .transitions
        .iter()
        .filter(|(_, tr)| tr.reason == Reason::AgainstCommand)
        .map(|&(t, _)| t)
        .collect();
    println!(
        "worst window {:?} %, against the command at {against:?} s",
        s.worst_speed_err_pct
    );
    assert!(
        against.is_empty(),
        "handed over against the command at {against:?} s"
    );
    assert!(s.pass && !s.lost_lock, "{:?}", s.reasons);
}

/// The Zou 350 kW PMa-SynRM (its true file, the board's defaults, seeds 1 and 2, the flux
/// observer driving) holds a 100 % rated-torque step at its derated speed, where field
/// weakening and MTPA hold a negative d current at the voltage limit: within the verdict's
/// 2 % in every window, the vector on the circle in part of the loaded window and the d
/// current negative throughout it (below −50 A on average). Cut along itself on the circle,
/// the vector took that current's d voltage, the d current ran from −150 A to +90 A and the
/// speed swung 1,490 ↔ 880 rpm (4–8 % slow); the current loop now keeps the d voltage first
/// while motoring (`src/foc/current.rs`). (`host-sim/matrices/zoo-salient.toml` runs the
/// sliding primary too: its flux monitor drives there from the hand-over on.)
#[test]
fn the_zou_holds_its_rated_load_step_at_the_voltage_limit() {
    let loaded = load(SALIENT_ZOO[4]);
    for seed in [1, 2] {
        let r = run_on_board(&loaded, "sup-load-steps-100", ObserverKind::Flux, seed);
        let s = Summary::of(&r);
        // The window `applied` (2.2 to 3.0 s): the load on, after its step's transient.
        let loaded_rows: Vec<&Row> = r
            .rows
            .iter()
            .filter(|x| (2.2..3.0).contains(&x.t))
            .collect();
        let n = loaded_rows.len() as f64;
        let limited = (loaded_rows.iter())
            .filter(|x| x.health.is_some_and(|h| h.voltage_limited))
            .count() as f64
            / n;
        let i_d_max = loaded_rows.iter().map(|x| x.i_d).fold(f64::MIN, f64::max);
        let i_d_mean = loaded_rows.iter().map(|x| x.i_d).sum::<f64>() / n;
        println!(
            "seed {seed}: worst window {:?} %, θ error at most {:?}° electrical; loaded: on the \
             circle {:.1} % of samples, i_d mean {i_d_mean:.1} A, at most {i_d_max:.1} A",
            s.worst_speed_err_pct,
            s.theta_err_max_deg_e,
            100.0 * limited
        );
        assert!(s.pass && !s.lost_lock, "seed {seed}: {:?}", s.reasons);
        assert!(
            limited > 0.01,
            "seed {seed}: never on the circle ({limited})"
        );
        assert!(
            i_d_max < 0.0 && i_d_mean < -50.0,
            "seed {seed}: i_d {i_d_mean} .. {i_d_max}"
        );
    }
}

/// The salient zoo motors re-enabled on a rotor coasting at ±50 % and ±100 % of rated speed on
/// a board without terminal sensing (`catch-no-terminal-*`), both primaries: caught in closed
/// loop without an alignment, the verdict a pass, the probe's current (the plant's, at the
/// samples, in `Catch` from the second period on) below the rated-torque current. The probe's
/// deadbeat current loop takes the smaller of `L_d` and `L_q` (`src/drive/catch_zero.rs`):
/// with their mean, the AMK (`L_q/L_d = 2`), the Zou (2.7) and the Brusa (3.2) tripped on
/// over-current, an observer loss or a stall in 7 of these 20 flux-primary runs.
#[test]
fn a_coasting_salient_rotor_is_caught_without_terminal_sensing() {
    use pmsm_sensorless::drive::Mode;
    for file in SALIENT_ZOO {
        let loaded = load(file);
        let rated_a = f64::from(loaded.motor.rated_torque_current_a());
        for scenario in [
            "catch-no-terminal-50",
            "catch-no-terminal-neg50",
            "catch-no-terminal-100",
            "catch-no-terminal-neg100",
        ] {
            for observer in [ObserverKind::SlidingTorque, ObserverKind::Flux] {
                let r = run_on_board(&loaded, scenario, observer, 1);
                let s = Summary::of(&r);
                let label = format!("{} {scenario} {}", loaded.name, observer.name());
                // From the second period after the enable (0.05 s) on.
                let t0 = 0.05 + 2.0 / r.config.rate_hz;
                let peak = |catch: bool| {
                    (r.rows.iter())
                        .filter(|x| x.t >= t0 && (!catch || x.mode == Some(Mode::Catch)))
                        .map(|x| x.i_d.hypot(x.i_q))
                        .fold(0.0, f64::max)
                };
                let (probe, run) = (peak(true), peak(false));
                let aligned = r.transitions.iter().any(|(_, tr)| tr.to == Mode::Align);
                println!(
                    "{label}: {:?}, the probe's current {probe:.2} A ({:.0} % of the \
                     rated-torque current), the run's {run:.2} A; aligned {aligned}",
                    s.reasons,
                    100.0 * probe / rated_a
                );
                assert!(s.pass, "{label}: {:?} {:?}", s.reasons, r.transitions);
                assert!(!aligned, "{label}: {:?}", r.transitions);
                assert!(probe < rated_a, "{label}: {probe} A");
            }
        }
    }
}
