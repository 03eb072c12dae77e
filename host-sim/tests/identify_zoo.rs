//! Issue #26: identification that works on any motor and never misnames. Every motor of the zoo
//! (`host-sim/motors/zoo/`, real motors from public sources) is identified on the board's
//! defaults (20 kHz PWM, 0.5 µs dead time, 1 % of rated current noise, 2 % offset on phase a),
//! two seeds, within R 3 %, L 5 %, ψ_f 3 %, J 10 %; the motors that do not identify yet end in
//! the error that names what happened (listed in `KNOWN`, each with its cause). The drone
//! (4 kHz electrical at rated speed, J 6.5e-7 kg·m²) identifies since the torque steps' PLL
//! follows the motor's acceleration (`mechanics.rs`, `Tracking`; before, it tripped
//! `overcurrent` in the torque steps); at a tenth of its J it ends in `lost_rotor`, named. A made-up
//! 470 V, 17 mΩ motor (`tests/motors/`) identifies with 0.5 and 1 µs of dead time, and the
//! 7 mΩ EMRAX 228's resistance and inductance tests hold their current (no `overcurrent`) and
//! measure within R 3 %, L 5 % at both dead times.

use pmsm_host_sim::identify::{run, IdentifyOutcome, IdentifyRun, MotorFault};
use pmsm_host_sim::motor_file;
use pmsm_sensorless::drive::{Fault, Identified, IdentifyError};
use pmsm_sensorless::motor::Motor;
use std::path::Path;

/// Zoo motors that do not identify within the bounds yet, each with the error it may end in
/// (`None`: any fault, the name still wrong) or else completes with R, L and ψ_f within the
/// bounds (J not yet), and why. Before the spin, R and L are always asserted.
const KNOWN: [(&str, Option<IdentifyError>, &str); 0] = [
    // (The EMRAX 228 ended in spin_not_followed in half the seeds until the spin's second ramp
    // ran at the test current: `flux.rs`.)
];

fn load(path: &Path) -> Motor {
    let (_, mut m) = motor_file::load(path).unwrap();
    let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
    m.name = Box::leak(stem.into_boxed_str());
    m
}

fn zoo() -> Vec<Motor> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("motors/zoo");
    let mut files: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    files.sort();
    files.iter().map(|p| load(p)).collect()
}

fn identify(m: Motor, seed: u64, dead_time_s: f64) -> IdentifyOutcome {
    let mut cfg = IdentifyRun::board_defaults(m);
    cfg.board.seed = seed;
    cfg.board.dead_time_s = dead_time_s;
    run(&cfg).unwrap()
}

fn pct(id: f32, truth: f32) -> f32 {
    100.0 * (id - truth) / truth
}

/// R within 3 %, L (mean, d and q) within 5 %.
fn assert_r_l(label: &str, id: &Identified, m: &Motor) {
    let t = m.params;
    let e_r = pct(id.r_ohm, t.r_ohm);
    assert!(e_r.abs() < 3.0, "{label}: R {e_r:+.2} %");
    for (what, l, truth) in [
        ("L", id.l_h(), t.l_h),
        ("L_d", id.l_d_h, t.l_d_h()),
        ("L_q", id.l_q_h, t.l_q_h()),
    ] {
        let e = pct(l, truth);
        assert!(e.abs() < 5.0, "{label}: {what} {e:+.2} %");
    }
}

/// The bounds: R 3 %, L 5 %, ψ_f 3 %, J 10 %, B finite and not negative.
fn assert_all(label: &str, o: &IdentifyOutcome, m: &Motor) {
    let id = o
        .identified
        .unwrap_or_else(|| panic!("{label}: ended with {:?}", o.fault));
    assert_r_l(label, &id, m);
    let t = m.params;
    let e_flux = pct(id.flux_wb, t.flux_wb);
    let e_j = pct(id.j_kgm2, t.j_kgm2);
    assert!(e_flux.abs() < 3.0, "{label}: flux {e_flux:+.2} %");
    assert!(e_j.abs() < 10.0, "{label}: J {e_j:+.2} %");
    assert!(
        id.b_nms.is_finite() && id.b_nms >= 0.0,
        "{label}: B {}",
        id.b_nms
    );
}

#[test]
fn every_zoo_motor_identifies_within_the_bounds_or_names_why_not() {
    let motors = zoo();
    assert!(motors.len() >= 12, "{} zoo motors", motors.len());
    for m in motors {
        let known = KNOWN.iter().find(|(n, _, _)| *n == m.name);
        for seed in [1, 2] {
            let label = format!("{} seed {seed}", m.name);
            let o = identify(m, seed, 0.5e-6);
            match known {
                None => assert_all(&label, &o, &m),
                Some((_, e, why)) => match o.identified {
                    Some(id) => {
                        assert_r_l(&label, &id, &m);
                        let e_flux = pct(id.flux_wb, m.params.flux_wb);
                        assert!(e_flux.abs() < 3.0, "{label}: flux {e_flux:+.2} %");
                    }
                    None => {
                        if let Some(e) = e {
                            assert_eq!(o.fault, Some(Fault::Identify(*e)), "{label} ({why})");
                        }
                        assert!(o.fault.is_some(), "{label} ({why}): no result, no fault");
                        // Every measurement before the spin was made, and is right.
                        assert_r_l(&label, &o.so_far, &m);
                    }
                },
            }
        }
    }
}

#[test]
fn a_470_v_17_mohm_motor_identifies_with_half_and_one_microsecond_of_dead_time() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/motors/hv-470v-17mohm-made-up.toml");
    let m = load(&path);
    for dead_time_s in [0.5e-6, 1e-6] {
        for seed in [1, 2] {
            let label = format!("{} {dead_time_s:e} s seed {seed}", m.name);
            assert_all(&label, &identify(m, seed, dead_time_s), &m);
        }
    }
}

#[test]
fn the_7_mohm_emrax_resistance_and_inductance_tests_hold_their_current() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("motors/zoo/axial-emrax-228-mv.toml");
    let m = load(&path);
    for dead_time_s in [0.5e-6, 1e-6] {
        let label = format!("{} {dead_time_s:e} s", m.name);
        let o = identify(m, 1, dead_time_s);
        // Past R and L, never an overcurrent.
        assert_ne!(o.fault, Some(Fault::Overcurrent), "{label}");
        assert!(
            o.so_far.l_q_h > 0.0,
            "{label}: ended before L_q: {:?}",
            o.fault
        );
        assert_r_l(&label, &o.so_far, &m);
    }
}

#[test]
fn inertia_ten_times_above_or_below_the_datasheets_identifies() {
    // The hub motor at 10× its J (0.076 kg·m²) and the NEMA-23 servo at a tenth of its J
    // (7.1e-7 kg·m²): the spin watches the rotor follow, the torque steps find their torque.
    // (The drone at a tenth: `a_drone_at_a_tenth_of_its_inertia_ends_named`.)
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("motors/zoo");
    for (file, k) in [
        ("hoverboard-6.5in-hub-odrive.toml", 10.0),
        ("nema23-teknic-m2310p.toml", 0.1),
    ] {
        let mut m = load(&dir.join(file));
        m.params.j_kgm2 *= k;
        for seed in [1, 2] {
            let label = format!("{} J x{k} seed {seed}", m.name);
            assert_all(&label, &identify(m, seed, 0.5e-6), &m);
        }
    }
}

#[test]
fn a_drone_at_a_tenth_of_its_inertia_ends_named() {
    // The drone at J/10 (6.5e-8 kg·m²): its first torque step (2 % of rated current)
    // accelerates it at ~2.6e5 rad/s² electrical, a lag of ~1 rad behind the torque steps'
    // 80 Hz PLL: the rotor is lost, and the error says so (never `overcurrent`).
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("motors/zoo");
    let mut m = load(&dir.join("drone-tmotor-f60pro-v-2550kv.toml"));
    m.params.j_kgm2 *= 0.1;
    for seed in [1, 2] {
        let label = format!("{} J x0.1 seed {seed}", m.name);
        let o = identify(m, seed, 0.5e-6);
        match o.identified {
            Some(_) => assert_all(&label, &o, &m),
            None => {
                assert!(
                    matches!(o.fault, Some(Fault::Identify(_))),
                    "{label}: {:?}",
                    o.fault
                );
                assert_r_l(&label, &o.so_far, &m);
                let e_flux = pct(o.so_far.flux_wb, m.params.flux_wb);
                assert!(e_flux.abs() < 3.0, "{label}: flux {e_flux:+.2} %");
            }
        }
    }
}

/// Issue #29: a salient motor's L_d and L_q measured as they are whatever angle the DC current
/// holds its rotor at (`inductance.rs`: the eigenvalues of the 2×2 ripple response, each
/// average taken with the rotor at rest), the saliency's share taken off the back-EMF before
/// ψ_f (`flux.rs`), and the identified motor salient. The Aalto 2.2 kW IPM (L_q/L_d 1.42) and
/// the Caruso 2019 IPM (1.53), the Zou 350 kW PMa-SynRM (2.67) and AMK's DD5 hub motor (2.0),
/// two seeds each, within R 3 %, L_d and L_q 5 %, ψ_f 3 %, J 10 %. (Before: the Aalto's and the
/// Caruso's L_d and L_q within 1 % of each axis, but the drive took their mean; ψ_f −2.4 % and
/// −7.7 %, J −9 % on the Caruso; the Zou ended in `shorted_phase`; the AMK in
/// `spin_not_followed` until the identification's current loop took each axis's inductance,
/// `drive/identify/mod.rs`, `Gains`.)
#[test]
fn salient_ipms_identify_both_axes() {
    for file in [
        "motors/zoo/salient/industrial-ipm-aalto-2.2kw.toml",
        "motors/zoo/salient/industrial-ipm-caruso-2019.toml",
        "motors/zoo/salient/traction-pmasynrm-zou-350kw.toml",
        "motors/zoo/salient/fs-ipm-amk-dd5-14-10-pow.toml",
    ] {
        let m = load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(file));
        for seed in [1, 2] {
            let label = format!("{} seed {seed}", m.name);
            let o = identify(m, seed, 0.5e-6);
            assert_all(&label, &o, &m);
            let id = o.identified.unwrap();
            let p = id.params(m.params.pole_pairs, m.params.torque).unwrap();
            let e = pct(p.saliency, m.params.saliency);
            assert!(
                id.salient() && e.abs() < 10.0,
                "{label}: saliency {} ({e:+.2} %)",
                p.saliency
            );
        }
    }
}

/// Issue #26: a winding whose lag is beyond what the resistance test's level controller damps
/// (the Zou PMa-SynRM's non-salient twin, `τ = L/R` = 143 ms) identifies within the bounds on
/// two seeds (it ended in `shorted_phase` on seed 1, R −3.5 % on seed 2, until the settling
/// set the voltage from where its current was going: `resistance.rs`).
#[test]
fn a_143_ms_winding_identifies() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("motors/zoo/salient/twins/traction-pmasynrm-zou-350kw-twin.toml");
    let m = load(&path);
    for seed in [1, 2] {
        assert_all(
            &format!("{} seed {seed}", m.name),
            &identify(m, seed, 0.5e-6),
            &m,
        );
    }
}

/// Issue #29: the Brusa IPM (L_q/L_d 3.24), whose rotor rests 48° off the DC current at half its
/// rated current (`(L_q − L_d) I > ψ_f`) and swings when the winding check's third level moves
/// it, is not misnamed (it ended in `shorted_phase` on the ideal plant and on seed 2) and its
/// axes are not swapped (L_d +54 %, L_q −53 % on seed 1): the identification completes within
/// R 3 %, L_d and L_q 5 %, ψ_f 3 %, J 10 %, on the ideal plant and two seeds. (ψ_f came out
/// −11 to −17 % with the board's noise on seeds 1 and 2, J with it, while the flux spin measured at 30 % of the
/// rated current, where the saliency's flux is nine tenths of the magnet's and the rotor barely
/// held in the frame: the spin speed's measurement now holds the current that keeps the rotor
/// stiffest, `flux.rs`.)
#[test]
fn a_strongly_salient_rotor_held_off_its_axis_is_measured_not_misnamed() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("motors/zoo/salient/traction-ipm-brusa-hsm1-6.17.12-salient.toml");
    let m = load(&path);
    let mut ideal = IdentifyRun::board_defaults(m);
    ideal.board = pmsm_host_sim::board::SimBoard::ideal(&m);
    let runs = [
        ("ideal", run(&ideal).unwrap()),
        ("seed 1", identify(m, 1, 0.5e-6)),
        ("seed 2", identify(m, 2, 0.5e-6)),
    ];
    for (label, o) in runs {
        assert_all(label, &o, &m);
        assert!(
            o.identified.is_some_and(|id| id.salient()),
            "{label}: not salient"
        );
    }
}

/// A salient rotor that cannot turn is not identified: the flux spin's check of the EMF's
/// growth with the speed stops it, however far the salient holding current drops (`flux.rs`,
/// `stiffest_hold`: at a tenth and a third of it the blocked AMK and Zou passed the check and
/// the torque steps ran against the shaft, ending in `overcurrent` or
/// `inertia_out_of_range`), and names it `blocked_rotor`: its EMF grows with the speed as a
/// turning rotor's does, but its trace turned by twice the frame's angle holds still
/// (`flux.rs`, `BLOCKED_TRACE`; before, the AMK and the Zou were named `spin_not_followed`,
/// the Brusa either). Every salient zoo motor, seeds 1 and 2.
#[test]
fn a_blocked_salient_rotor_fails_the_flux_spin() {
    for file in [
        "motors/zoo/salient/fs-ipm-amk-dd5-14-10-pow.toml",
        "motors/zoo/salient/traction-pmasynrm-zou-350kw.toml",
        "motors/zoo/salient/traction-ipm-brusa-hsm1-6.17.12-salient.toml",
        "motors/zoo/salient/industrial-ipm-aalto-2.2kw.toml",
        "motors/zoo/salient/industrial-ipm-caruso-2019.toml",
    ] {
        let m = load(&Path::new(env!("CARGO_MANIFEST_DIR")).join(file));
        for seed in [1, 2] {
            let mut cfg = IdentifyRun::board_defaults(m);
            cfg.board.seed = seed;
            cfg.fault = Some(MotorFault::BlockedRotor);
            let o = run(&cfg).unwrap();
            assert!(
                o.fault == Some(Fault::Identify(IdentifyError::BlockedRotor))
                    && o.identified.is_none(),
                "{} seed {seed}: {:?}",
                m.name,
                o.fault
            );
        }
    }
}
