//! Issue #19: the drive identifies its motor. With the board's defaults (20 kHz PWM, 500 ns
//! dead time), 1 % of rated current noise and a 2 % offset on phase a: the four presets and
//! two made-up motors that look nothing like them (a high-resistance gimbal motor, a
//! low-inductance high-speed one) within R 3 %, L 5 %, ψ_f 3 %, J 10 % (B reported), the
//! Sinano run under 10 s of simulated time; the identified motor file then drives
//! start-stop-reverse with both primaries; each bad case ends in its named error.

use pmsm_host_sim::identify::{
    identified_motor, motor_toml, run, IdentifyOutcome, IdentifyRun, MotorFault,
};
use pmsm_host_sim::motor_file;
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{self, Mismatch, SimConfig};
use pmsm_sensorless::drive::{Fault, IdentifyError, Mode, Reason};
use pmsm_sensorless::motor::{preset, Motor};

/// The six motors: the presets and the made-up ones in `host-sim/motors/`.
fn motors() -> Vec<Motor> {
    let mut v: Vec<Motor> = [
        "sinano",
        "ortega-sim-40kw",
        "ortega-test-0.3kw",
        "ortega-dynamo-1kw",
    ]
    .iter()
    .map(|n| preset(n).unwrap())
    .collect();
    for f in ["gimbal-high-r", "fast-low-l"] {
        let path = format!("{}/motors/{f}.toml", env!("CARGO_MANIFEST_DIR"));
        let (_, mut m) = motor_file::load(std::path::Path::new(&path)).unwrap();
        m.name = if f == "gimbal-high-r" {
            "gimbal-high-r"
        } else {
            "fast-low-l"
        };
        v.push(m);
    }
    v
}

fn identify(m: Motor, seed: u64, fault: Option<MotorFault>) -> IdentifyOutcome {
    let mut cfg = IdentifyRun::board_defaults(m);
    cfg.board.seed = seed;
    cfg.fault = fault;
    run(&cfg).unwrap()
}

fn pct(id: f32, truth: f32) -> f32 {
    100.0 * (id - truth) / truth
}

#[test]
fn six_motors_within_the_issues_tolerances() {
    for m in motors() {
        for seed in [1, 2] {
            let o = identify(m, seed, None);
            let label = format!("{} seed {seed}", m.name);
            let id = o
                .identified
                .unwrap_or_else(|| panic!("{label}: ended with {:?}", o.fault));
            let t = m.params;
            let e_r = pct(id.r_ohm, t.r_ohm);
            let e_ld = pct(id.l_d_h, t.l_h);
            let e_lq = pct(id.l_q_h, t.l_h);
            let e_l = pct(id.l_h(), t.l_h);
            let e_flux = pct(id.flux_wb, t.flux_wb);
            let e_j = pct(id.j_kgm2, t.j_kgm2);
            assert!(e_r.abs() < 3.0, "{label}: R {e_r:+.2} %");
            for (what, e) in [("L", e_l), ("L_d", e_ld), ("L_q", e_lq)] {
                assert!(e.abs() < 5.0, "{label}: {what} {e:+.2} %");
            }
            assert!(e_flux.abs() < 3.0, "{label}: flux {e_flux:+.2} %");
            assert!(e_j.abs() < 10.0, "{label}: J {e_j:+.2} %");
            assert!(
                id.b_nms.is_finite() && id.b_nms >= 0.0,
                "{label}: B {}",
                id.b_nms
            );
            // Every motor well within the Sinano motor's 10 s.
            assert!(o.duration_s < 10.0, "{label}: {} s", o.duration_s);
            // The mode sequence: calibrate, identify, identified.
            let reasons: Vec<_> = o.transitions.iter().map(|(_, tr)| tr.reason).collect();
            assert_eq!(
                reasons,
                [Reason::Identify, Reason::Calibrated, Reason::Identified],
                "{label}"
            );
        }
    }
}

#[test]
fn the_identified_file_drives_start_stop_reverse_with_both_primaries() {
    let dir = std::env::temp_dir().join(format!("pmsm-identify-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for m in motors() {
        let o = identify(m, 1, None);
        let id = o.identified.unwrap();
        let motor = identified_motor(&o).unwrap().unwrap();
        // The file `identify --out` writes loads with --motor-file, with the same parameters.
        let path = dir.join(format!("{}.toml", m.name));
        std::fs::write(&path, motor_toml(m.name, &motor.params, &o, &id)).unwrap();
        let (_, loaded) = motor_file::load(&path).unwrap();
        assert_eq!(loaded.params, motor.params, "{}", m.name);
        for observer in [ObserverKind::SlidingTorque, ObserverKind::Flux] {
            // The plant is the true motor; the drive's parameters are the identified ones.
            let sc = Spec::built_in("start-stop-reverse")
                .unwrap()
                .build(m.name, m)
                .unwrap();
            let mut cfg = SimConfig::new(sc, observer);
            let rated = f64::from(m.ratings.current_a);
            cfg.board.noise_sigma_a = 0.01 * rated;
            cfg.board.offset_a = [0.02 * rated, 0.0, 0.0];
            cfg.board.dead_time_s = 0.5e-6;
            cfg.board.pwm_hz = 20_000.0;
            cfg.mismatch = Mismatch::between(&m.params, &loaded.params);
            // The board idle for 20 ms before the enable: the drive measures the offsets, the
            // board takes them off its samples (as the B-G431B-ESC1 does with the ones it
            // measures at boot).
            cfg.board.idle_s = 0.02;
            let r = sim::run(cfg).unwrap();
            let s = Summary::of(&r);
            assert!(s.pass, "{} {}: {:?}", m.name, observer.name(), s.reasons);
        }
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// `fault` ends the identification of `m` with `expected`, PWM off.
fn ends_with(m: Motor, fault: MotorFault, expected: IdentifyError) {
    let o = identify(m, 1, Some(fault));
    assert_eq!(
        o.fault,
        Some(Fault::Identify(expected)),
        "{} {fault:?}",
        m.name
    );
    assert!(o.identified.is_none());
    let (_, last) = o.transitions.last().unwrap();
    assert_eq!(last.to, Mode::Fault, "{} {fault:?}", m.name);
}

#[test]
fn an_open_phase_ends_in_open_phase() {
    for m in motors() {
        for k in 0..3 {
            ends_with(m, MotorFault::OpenPhase(k), IdentifyError::OpenPhase);
        }
    }
}

#[test]
fn a_shorted_phase_ends_in_shorted_phase() {
    for m in motors() {
        for k in 0..3 {
            ends_with(m, MotorFault::ShortedPhase(k), IdentifyError::ShortedPhase);
        }
    }
}

#[test]
fn a_blocked_rotor_during_the_spin_ends_in_blocked_rotor() {
    for m in motors() {
        ends_with(m, MotorFault::BlockedRotor, IdentifyError::BlockedRotor);
    }
}

#[test]
fn a_motor_whose_rated_current_the_board_cannot_sense_ends_in_current_not_sensable() {
    let m = preset("ortega-dynamo-1kw").unwrap();
    // A board that reads up to 20 A: the 21 A motor's trip (47 A) is beyond it.
    let mut cfg = IdentifyRun::board_defaults(m);
    cfg.board.sense_range_a = Some(20.0);
    let o = run(&cfg).unwrap();
    assert_eq!(
        o.fault,
        Some(Fault::Identify(IdentifyError::CurrentNotSensable))
    );
    // A board whose ADC step is a fiftieth of the motor's rated current.
    let m = preset("sinano").unwrap();
    let mut cfg = IdentifyRun::board_defaults(m);
    cfg.board.adc_lsb_a = f64::from(m.ratings.current_a) / 50.0;
    let o = run(&cfg).unwrap();
    assert_eq!(
        o.fault,
        Some(Fault::Identify(IdentifyError::CurrentNotSensable))
    );
    // PWM never on: the check comes before the first measurement.
    assert!(o.duration_s < 0.02, "{}", o.duration_s);
}

#[test]
fn an_implausible_sensor_offset_ends_in_adc_offset() {
    for m in motors() {
        let mut cfg = IdentifyRun::board_defaults(m);
        // 30 % of rated current: beyond a twentieth of the sensing range (4.5 x rated).
        cfg.board.offset_a = [0.0, 0.3 * f64::from(m.ratings.current_a), 0.0];
        let o = run(&cfg).unwrap();
        assert_eq!(o.fault, Some(Fault::AdcOffset), "{}", m.name);
    }
}

/// While idle the drive measures the sensors' offsets (PWM off) and takes them off every
/// sample from the enable on; an implausible one refuses the enable with `AdcOffset`.
#[test]
fn idle_samples_give_the_offsets_an_enable_takes() {
    use pmsm_sensorless::drive::{Command, DriveConfig, DriveInput, DriveState};
    use pmsm_sensorless::frames::Abc;
    let m = preset("sinano").unwrap();
    let drive = DriveConfig::new(&m).build_flux_primary().unwrap();
    let idle = Command::default();
    let start = Command {
        enable: true,
        speed_rpm: 500.0,
        clear_fault: false,
    };
    for (offset_a, plausible) in [(0.06_f32, true), (1.0, false)] {
        let mut st = DriveState::default();
        let input = DriveInput {
            i_abc: Abc::new(offset_a, 0.0, 0.0),
            v_bus: 48.0,
            v_ab_terminal: None,
            overrun: false,
            stage_fault: None,
        };
        for _ in 0..100 {
            assert!(drive.step(&mut st, &input, &idle).duties.is_none());
        }
        let out = drive.step(&mut st, &input, &start);
        if plausible {
            // 60 mA on phase a: (2/3·60 mA, 0) in the stationary frame (Clarke).
            let ab = st.offset_ab();
            assert!((ab.alpha - 2.0 / 3.0 * offset_a).abs() < 1e-6, "{ab:?}");
            assert!(ab.beta.abs() < 1e-6);
            assert_eq!(st.mode(), Mode::Align);
            assert!(out.duties.is_some());
        } else {
            // 1 A: beyond a twentieth of the sensing range (4.5 x 3 A / 20 = 0.675 A).
            assert_eq!(st.fault(), Some(Fault::AdcOffset));
            assert!(out.duties.is_none());
        }
    }
}
