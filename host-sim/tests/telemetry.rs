//! Issue #27: no NaN in the telemetry. Every field of the drive's log record is finite at
//! every step of an identification with either primary (observers that do not run there
//! report 0), and a terminal voltage that is not finite (or longer than any bus) is refused
//! as an invalid input where the drive reads it, while catching.

use pmsm_host_sim::board::{BoardStage, SimBoard};
use pmsm_host_sim::identify::drive_config;
use pmsm_plant::PlantParams;
use pmsm_sensorless::control::{Commands, Control};
use pmsm_sensorless::drive::{Command, Drive, DriveConfig, DriveInput, Fault, Mode, Telemetry};
use pmsm_sensorless::frames::{Abc, AlphaBeta};
use pmsm_sensorless::motor::{preset, Motor};
use pmsm_sensorless::observer::{Observer, Rotor};

/// The record's numbers by name (an absent load estimate reads 0).
fn fields(t: &Telemetry) -> [(&'static str, f32); 14] {
    [
        ("speed_ref_rpm", t.speed_ref_rpm),
        ("speed_rpm", t.speed_rpm),
        ("theta_e_primary", t.theta_e_primary),
        ("theta_e_monitor", t.theta_e_monitor),
        ("theta_e_control", t.theta_e_control),
        ("i_d", t.i_d),
        ("i_q", t.i_q),
        ("load_nm", t.load_nm.unwrap_or(0.0)),
        ("residual_primary", t.residual_primary),
        ("residual_monitor", t.residual_monitor),
        ("disagreement_deg", t.disagreement_deg),
        ("speed_disagreement_rpm", t.speed_disagreement_rpm),
        ("r_ohm", t.r_ohm),
        ("flux_wb", t.flux_wb),
    ]
}

/// Panics naming the first non-finite field of `t`.
fn assert_finite(t: &Telemetry, at: &str) {
    for (name, x) in fields(t) {
        assert!(x.is_finite(), "{at}: {name} = {x} in {t:?}");
    }
}

/// Runs the identification of `motor` with `drive` (built on the placeholder motor) on the
/// board's defaults, checking the telemetry after every step; returns the final mode and the
/// modes seen.
fn identify_checking<P: Observer, M: Observer>(
    motor: &Motor,
    board: &SimBoard,
    drive: Drive<P, M>,
) -> (Mode, Vec<Mode>) {
    let stage = BoardStage::new(board, PlantParams::from(&motor.params), 0.0, 0.0).unwrap();
    let mut control = Control::new(drive, stage);
    let cmd = Commands {
        enable: true,
        ..Commands::default()
    };
    control.tick(&Commands {
        identify: true,
        ..cmd
    });
    let ts = 1.0 / 4000.0;
    let mut modes = vec![];
    for k in 0..(30.0 / ts) as usize {
        control.run(&cmd);
        let t = control.telemetry();
        if modes.last() != Some(&t.mode) {
            modes.push(t.mode);
        }
        assert_finite(&t, &format!("{} step {k} ({:?})", motor.name, t.mode));
        control.stage_mut().advance(|_, _| 0.0, ts / 25.0, 25);
        if matches!(t.mode, Mode::Identified | Mode::Fault) {
            return (t.mode, modes);
        }
    }
    (control.state().mode(), modes)
}

#[test]
fn identification_telemetry_is_finite_with_either_primary() {
    for name in ["sinano", "ortega-test-0.3kw"] {
        let motor = preset(name).unwrap();
        let board = SimBoard::board_defaults(&motor);
        let dc = drive_config(&motor, &board);
        let (end, modes) = identify_checking(&motor, &board, dc.build_sliding_primary().unwrap());
        assert_eq!(end, Mode::Identified, "{name}, sliding primary: {modes:?}");
        assert!(modes.contains(&Mode::Identify), "{name}: {modes:?}");
        let (end, modes) = identify_checking(&motor, &board, dc.build_flux_primary().unwrap());
        assert_eq!(end, Mode::Identified, "{name}, flux primary: {modes:?}");
    }
}

/// A sample with the PWM off: no current, the nominal bus, terminal voltage `v`.
fn sample(v_bus: f32, v: Option<AlphaBeta>) -> DriveInput {
    DriveInput {
        i_abc: Abc::new(0.0, 0.0, 0.0),
        v_bus,
        v_ab_terminal: v,
        overrun: false,
        stage_fault: None,
    }
}

/// The command of the terminal-voltage tests: enabled, 500 rpm.
const ENABLED_500_RPM: Command = Command {
    enable: true,
    speed_rpm: 500.0,
    clear_fault: false,
};

#[test]
fn a_bad_terminal_voltage_is_an_invalid_input_where_it_is_read() {
    let motor = preset("sinano").unwrap();
    let dc = DriveConfig::new(&motor);
    let v_bus = motor.ratings.bus_v;
    let drive = dc.build_sliding_primary().unwrap();
    let run = ENABLED_500_RPM;
    // Not finite, or longer than any bus (a finite square that overflows to ∞ included).
    let too_long = 10.0 * v_bus;
    for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, too_long] {
        for v in [AlphaBeta::new(bad, 0.0), AlphaBeta::new(1.0, bad)] {
            // Catching: the step that sees it faults, the PWM stays off, the record finite.
            let mut st = Default::default();
            let turning = Some(AlphaBeta::new(0.5 * v_bus, 0.0));
            let out = drive.step(&mut st, &sample(v_bus, turning), &run);
            assert_eq!(st.mode(), Mode::Catch);
            assert!(out.duties.is_none());
            let out = drive.step(&mut st, &sample(v_bus, Some(v)), &run);
            assert_eq!(st.fault(), Some(Fault::InvalidInput), "{v:?}");
            assert!(out.duties.is_none());
            assert_finite(&drive.telemetry(&st), &format!("{v:?}"));
            // The enable's own step catches on it: refused there, before any switching.
            let mut st = Default::default();
            let out = drive.step(&mut st, &sample(v_bus, Some(v)), &run);
            assert_eq!(st.fault(), Some(Fault::InvalidInput), "enable, {v:?}");
            assert!(out.duties.is_none());
            // Idle and running, nothing reads it: ignored.
            let mut st = Default::default();
            drive.step(&mut st, &sample(v_bus, Some(v)), &Command::default());
            assert_eq!(st.mode(), Mode::Idle, "idle, {v:?}");
            let rotor = Rotor {
                theta_e: 0.0,
                omega_m: 50.0,
                load_nm: 0.0,
            };
            let mut st = drive.running_state(AlphaBeta::default(), rotor);
            let out = drive.step(&mut st, &sample(v_bus, Some(v)), &run);
            assert_eq!(st.mode(), Mode::Sensorless, "running, {v:?}");
            assert!(out.duties.is_some());
            assert_finite(&drive.telemetry(&st), &format!("running, {v:?}"));
        }
    }
}

/// A board whose terminal sensing stops (the B-G431B-ESC1's dividers clip at 18.3 V, and its
/// firmware then passes none): the catch goes on with the currents regulated to zero
/// (`catch_zero.rs`), switching, never a catch on a voltage it does not have. An enable
/// without one catches so on a board that does not sense it at every speed
/// (`terminal_sensing` false, the B-G431B-ESC1's setting), and aligns on one that does.
#[test]
fn a_terminal_voltage_that_stops_leaves_the_catch_to_the_zero_current_probe() {
    let motor = preset("sinano").unwrap();
    let dc = DriveConfig::new(&motor);
    assert!(dc.power_stage.terminal_sensing);
    let v_bus = motor.ratings.bus_v;
    let drive = dc.build_sliding_primary().unwrap();
    let run = ENABLED_500_RPM;
    let mut st = Default::default();
    let turning = Some(AlphaBeta::new(0.5 * v_bus, 0.0));
    let out = drive.step(&mut st, &sample(v_bus, turning), &run);
    assert_eq!(st.mode(), Mode::Catch);
    assert!(out.duties.is_none());
    // The reading stops: PWM off in this step, no fault.
    let out = drive.step(&mut st, &sample(v_bus, None), &run);
    assert_eq!(st.mode(), Mode::Catch);
    assert!(out.duties.is_none() && out.transition.is_none());
    // The zero-current probe switches from the next step on.
    let out = drive.step(&mut st, &sample(v_bus, None), &run);
    assert_eq!(st.mode(), Mode::Catch);
    assert!(out.duties.is_some());
    assert_finite(&drive.telemetry(&st), "catch without the terminal voltage");
    // An enable without a reading: aligned where the board senses at every speed, the probe
    // at once where it does not.
    let mut st = Default::default();
    drive.step(&mut st, &sample(v_bus, None), &run);
    assert_eq!(st.mode(), Mode::Align);
    let mut dc = DriveConfig::new(&motor);
    dc.power_stage.terminal_sensing = false;
    let drive = dc.build_sliding_primary().unwrap();
    let mut st = Default::default();
    let out = drive.step(&mut st, &sample(v_bus, None), &run);
    assert_eq!(st.mode(), Mode::Catch);
    assert!(out.duties.is_some());
}
