//! Issue #26's command profiles (`host-sim/scenarios/profile-*.toml`) with the board's defaults
//! (20 kHz PWM, 0.5 µs dead time, 1 % noise, 2 % offset on phase a), both primaries, the
//! configuration's control rate: a slow ramp (1 s) and a step to 3 % of rated speed under a
//! 50 % active load, the same 3 % lowered to from 50 %, and a reversal through zero. On the
//! Sinano motor and three zoo motors of different classes (a NEMA-23 servo, a 0.4 kW servo, a
//! hoverboard hub motor with 150× the servo's inertia). Each run must pass its verdict: no
//! fault, no loss of lock while sensorless, every window within 2 %.
//! The zoo matrices (`host-sim/matrices/zoo.toml`, `zoo-profiles.toml`) run them on every zoo
//! motor and seed.

mod common;
use common::{run_json, zoo};
use pmsm_host_sim::board::SimBoard;
use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::scenario::Spec;
use pmsm_host_sim::sim::{run, SimConfig};
use pmsm_sensorless::motor::preset;

/// The low-speed profiles, and the reversal from +50 % to −50 % through zero, the speed
/// reference below the hand-over speed holding a d current against the dead time's unknown
/// sign (`src/drive/sensorless.rs`). The catch at −50 % with +30 % runs in the zoo matrix: on
/// the Teknic's true file with the sliding primary its reversed window is 2.10 % low (limit
/// 2 %), not asserted here.
const PROFILES: [&str; 4] = [
    "profile-slow-ramp-3",
    "profile-step-3",
    "profile-down-3",
    "profile-reversal",
];

#[test]
fn every_profile_is_followed_on_four_motors_with_both_primaries() {
    let motors = [
        ("sinano", preset("sinano").unwrap()),
        ("teknic-m2310p", zoo("nema23-teknic-m2310p")),
        ("maxon-645106", zoo("servo-maxon-645106")),
        ("hoverboard-hub", zoo("hoverboard-6.5in-hub-odrive")),
    ];
    for (name, m) in motors {
        for scenario in PROFILES {
            for observer in [ObserverKind::SlidingTorque, ObserverKind::Flux] {
                let sc = Spec::built_in(scenario).unwrap().build(name, m).unwrap();
                let cfg = SimConfig::on(SimBoard::board_defaults(&m), sc, observer);
                let rate = cfg.rate_hz;
                let r = run(cfg).unwrap();
                let s = Summary::of(&r);
                let label = format!("{scenario} {name} {} at {rate} Hz", observer.name());
                println!("{label}: worst window {:?} %", s.worst_speed_err_pct);
                assert!(s.pass, "{label}: {:?}", s.reasons);
            }
        }
    }
}

/// The reversal on the iPower GM4108H gimbal (identified, as the zoo matrix drives it), sliding
/// primary, seeds 1 and 2: no load at ±150 rpm, phase currents of 10 mA whose sign the
/// dead-time compensation does not know. With the low-speed d current held only up to where
/// the dead-time voltage is a tenth of the back-EMF (145 rpm on this motor), seed 2's reversed
/// window was 2.16 % off (the sliding observer's angle wandered ±13°); held up to a twentieth
/// (`DriveConfig::low_speed_hold`), it passes.
#[test]
fn a_gimbal_reverses_without_load_just_above_the_dead_time_speed() {
    let m = zoo("gimbal-ipower-gm4108h-120t");
    for seed in [1, 2] {
        let sc = Spec::built_in("profile-reversal")
            .unwrap()
            .build("gimbal", m)
            .unwrap();
        let mut board = SimBoard::board_defaults(&m);
        board.seed = seed;
        let mut cfg = SimConfig::on(board, sc, ObserverKind::SlidingTorque);
        cfg.identify_first = true;
        let s = Summary::of(&run(cfg).unwrap());
        println!("seed {seed}: worst window {:?} %", s.worst_speed_err_pct);
        assert!(s.pass, "seed {seed}: {:?}", s.reasons);
    }
}

/// A command below `DriveConfig::if_held_below_rpm` is held in the I/f, supervised (issue #26,
/// `src/drive/open_loop.rs`): on the Nanotec DF45 (identified, as the zoo matrix drives it;
/// the speed held in the I/f is 4.7 % of rated there) the low-speed profiles at 3 % of rated
/// pass, reached from standstill or lowered from 50 % (`profile-down-3`: sensorless control
/// hands the rotor to the I/f), the rotor carried by the I/f throughout their window, both
/// primaries, seeds 1 and 2;
/// and a blocked rotor at 2 % of rated still ends in `stall` within 1 s (`sup-locked-slow`'s
/// verdict). Handed over at the command, as before, 3 of the 8 runs of the two profiles from
/// standstill failed (2
/// tripping `overcurrent`, the driving observer's angle drifting while its residual stayed
/// healthy), and 15 of the 20 on seeds 1 to 5 (`host-sim/matrices/zoo-profiles.toml`).
#[test]
fn a_low_command_is_held_in_the_i_f_where_the_model_is_not_trusted() {
    use pmsm_sensorless::drive::Mode;
    let m = zoo("flat-nanotec-df45l024048-a");
    for scenario in [
        "profile-slow-ramp-3",
        "profile-step-3",
        "profile-down-3",
        "sup-locked-slow",
    ] {
        for observer in [ObserverKind::SlidingTorque, ObserverKind::Flux] {
            for seed in [1, 2] {
                let sc = Spec::built_in(scenario).unwrap().build("df45", m).unwrap();
                let windows = sc.windows.clone();
                let mut board = SimBoard::board_defaults(&m);
                board.seed = seed;
                let mut cfg = SimConfig::on(board, sc, observer);
                cfg.identify_first = true;
                let r = run(cfg).unwrap();
                let s = Summary::of(&r);
                let label = format!("{scenario} {} seed {seed}", observer.name());
                assert!(s.pass, "{label}: {:?}", s.reasons);
                for w in &windows {
                    let held = r
                        .rows
                        .iter()
                        .filter(|row| row.t >= w.t0 && row.t < w.t1)
                        .all(|row| row.mode == Some(Mode::OpenLoop));
                    assert!(held, "{label}: not in the I/f throughout window {}", w.name);
                }
            }
        }
    }
}

/// The held I/f's only stall test is the observers seeing the rotor follow it: a blocked rotor
/// at a held command (2 % of rated) whose winding's resistance then moves 30 % either way
/// (0.25 s, after the alignment measured it) must still end in a named fault within the run's
/// 1 s, not be taken for a rotor that follows (its observers seeing the R error's voltage turn
/// with the I/f current). Identified Nanotec DF45 and iPower gimbal (held below 4.7 % and
/// 3.7 % of rated), both primaries: `stall` at 0.8 s, or `observer_loss` (the gimbal at
/// R × 0.7).
#[test]
fn a_blocked_rotor_at_a_held_command_faults_whatever_its_resistance() {
    let dir = env!("CARGO_TARGET_TMPDIR");
    for r in ["1.3", "0.7"] {
        let file = format!("{dir}/locked-slow-r{r}.toml");
        let text = format!(
            "description = \"blocked shaft, 2 % rated commanded, R x{r} at 0.25 s\"\n\
             motor = \"sinano\"\nduration_s = 1.0\nlocked_rotor = true\n\
             speed = [[0.0, 0.02]]\nwindows = []\n\
             [inject]\nt = 0.25\nkind = \"plant\"\nr = {r}\n"
        );
        std::fs::write(&file, text).unwrap();
        for motor in ["flat-nanotec-df45l024048-a", "gimbal-ipower-gm4108h-120t"] {
            let motor_file = format!("{}/motors/zoo/{motor}.toml", env!("CARGO_MANIFEST_DIR"));
            for observer in ["flux", "sliding-torque"] {
                let args = [
                    "run",
                    "--scenario-file",
                    &file,
                    "--motor-file",
                    &motor_file,
                    "--identified",
                    "--observer",
                    observer,
                ];
                let (v, _) = run_json(&args);
                let fault = v["fault"].as_str().unwrap_or("none");
                println!("{motor} R x{r} {observer}: {fault}");
                assert!(
                    fault == "stall" || fault == "observer_loss",
                    "{motor} R x{r} {observer}: fault {fault}, {}",
                    v["reasons"]
                );
            }
        }
    }
}
