//! Issue #28: a start's stator-resistance measurement (the alignment's two-level DC test,
//! `src/drive/align.rs`) is judged, never dropped silently (`src/drive/adaptation.rs`). On the
//! board's defaults (20 kHz PWM, 500 ns dead time, 1 % noise, a 2 % offset on phase a taken
//! off after the idle time), the Sinano motor and Ortega's test motor, flux observer primary
//! (the link firmware's):
//! - a plausible measurement is taken as before: the winding as the motor file says, or twice
//!   as resistive (a datasheet's line-to-line figure taken for the phase's): the model's `R`
//!   within 2 % of the plant's, the transition `Aligned`, no refusal in the state;
//! - one beyond `R₀/3 ..= 3 R₀` (the motor file's `R₀` a fifth of the plant's, the plant's a
//!   quarter of the file's):
//!   refused, the transition `Align → OpenLoop` with the reason `ResistanceRefused`, the
//!   state holding the measured value (within 2 % of the plant's) and the range
//!   (`DriveState::resistance_refused`); the model keeps `R₀` (the supervision judges whether
//!   the motor runs on it), and the refusal stays after the drive stopped (a fault cleared);
//! - a winding that does not carry the alignment's current (phase a, b or c not connected, or
//!   a resistance the bus cannot drive the current through): the start is refused at the
//!   alignment's end with `Fault::OpenWinding`, PWM off, never an open loop.

mod board;

use board::MOTORS;
use pmsm_host_sim::board::{BoardStage, MotorFault, SimBoard};
use pmsm_plant::PlantParams;
use pmsm_sensorless::control::{Commands, Control};
use pmsm_sensorless::drive::{
    DriveConfig, Fault, Mode, Reason, ResistanceRefused, Telemetry, Transition,
};
use pmsm_sensorless::motor::{Motor, MotorParams};

/// What a start came to.
struct Start {
    /// Every transition and its time \[s] from the enable.
    transitions: Vec<(f64, Transition)>,
    /// The telemetry at the end of the run, and the refusal the state holds then and after
    /// the enable was withdrawn (a fault cleared).
    end: Telemetry,
    refused: Option<ResistanceRefused>,
    refused_stopped: Option<ResistanceRefused>,
    stopped_mode: Mode,
    /// A mode seen after the first transition into `Fault`.
    after_fault: Vec<Mode>,
    /// The board's duties stayed off from the fault on.
    off_after_fault: bool,
}

/// Enables the drive at half the rated speed for 1 s: the drive built from `told` (the motor
/// file), the plant `truth` on the board's defaults with `fault`; then the enable withdrawn.
fn start(truth: &Motor, told: MotorParams, fault: Option<MotorFault>) -> Start {
    let board = SimBoard::board_defaults(truth);
    let mut dc = DriveConfig::new(&Motor {
        params: told,
        ..*truth
    });
    board.configure_drive(&mut dc);
    let drive = dc.build_flux_primary().unwrap();
    let mut stage = BoardStage::new(&board, PlantParams::from(&truth.params), 0.0, 0.0).unwrap();
    stage.set_motor_fault(fault);
    let ts = 1.0 / f64::from(dc.rate_hz);
    let mut control = Control::new(drive, stage);
    let step = |control: &mut Control<_, _, BoardStage>, cmd: &Commands| {
        let (s, t) = control.run(cmd);
        control.stage_mut().advance(|_, _| 0.0, ts / 25.0, 25);
        s.transition
            .into_iter()
            .chain(t.transitions())
            .collect::<Vec<_>>()
    };
    // The idle time: the drive measures the offsets, the board takes them off.
    let idle = Commands::default();
    for _ in 0..board.idle_steps(1.0 / ts) {
        step(&mut control, &idle);
    }
    let offset = control.state().offset_ab().to_abc();
    control.stage_mut().take_offsets(offset);
    let run = Commands {
        enable: true,
        speed_rpm: 0.5 * truth.ratings.speed_rpm,
        ..Commands::default()
    };
    let (mut transitions, mut after_fault, mut off_after_fault) = (vec![], vec![], true);
    for k in 0..(1.0 / ts) as usize {
        let faulted = transitions
            .iter()
            .any(|(_, tr): &(f64, Transition)| tr.to == Mode::Fault);
        for tr in step(&mut control, &run) {
            transitions.push((k as f64 * ts, tr));
        }
        if faulted {
            after_fault.push(control.state().mode());
            off_after_fault &= control.stage().duties().is_none();
        }
    }
    let (end, refused) = (control.telemetry(), control.state().resistance_refused());
    // Stopped: the enable withdrawn, a fault cleared.
    let stop = Commands {
        clear_fault: true,
        ..idle
    };
    step(&mut control, &stop);
    Start {
        transitions,
        end,
        refused,
        refused_stopped: control.state().resistance_refused(),
        stopped_mode: control.state().mode(),
        after_fault,
        off_after_fault,
    }
}

/// The transition out of the alignment.
fn aligned(s: &Start) -> Transition {
    let (_, tr) = s
        .transitions
        .iter()
        .find(|(_, tr)| tr.from == Mode::Align)
        .unwrap_or_else(|| panic!("no alignment: {:?}", s.transitions));
    *tr
}

#[test]
fn a_plausible_start_resistance_is_taken() {
    for name in MOTORS {
        let m = board::motor(name);
        for factor in [1.0f32, 2.0] {
            let truth = Motor {
                params: MotorParams {
                    r_ohm: factor * m.params.r_ohm,
                    ..m.params
                },
                ..m
            };
            let s = start(&truth, m.params, None);
            let label = format!("{name}, R x{factor}");
            let r_plant = truth.params.r_ohm;
            println!(
                "{label}: R {} Ω (plant {r_plant} Ω), {:?}",
                s.end.r_ohm, s.transitions
            );
            assert_eq!(aligned(&s).reason, Reason::Aligned, "{label}");
            assert!(
                (s.end.r_ohm / r_plant - 1.0).abs() < 0.02,
                "{label}: R {} Ω",
                s.end.r_ohm
            );
            assert_eq!(s.refused, None, "{label}");
            assert_eq!(s.end.mode, Mode::Sensorless, "{label}");
        }
    }
}

#[test]
fn an_implausible_start_resistance_is_refused_and_reported_with_its_value() {
    for name in MOTORS {
        let m = board::motor(name);
        // The motor file's R a fifth of the plant's (the measurement 5 R₀), and the plant's a
        // quarter of the file's (R₀/4): both beyond R₀/3..3 R₀.
        for (told, plant) in [(0.2f32, 1.0f32), (1.0, 0.25)] {
            let r0 = told * m.params.r_ohm;
            let params = MotorParams {
                r_ohm: r0,
                ..m.params
            };
            let truth = Motor {
                params: MotorParams {
                    r_ohm: plant * m.params.r_ohm,
                    ..m.params
                },
                ..m
            };
            let s = start(&truth, params, None);
            let label = format!("{name}, R₀ x{told}, plant R x{plant}");
            let tr = aligned(&s);
            println!("{label}: {:?}; {:?}", s.refused, s.transitions);
            assert_eq!(
                (tr.to, tr.reason),
                (Mode::OpenLoop, Reason::ResistanceRefused),
                "{label}"
            );
            let Some(ResistanceRefused {
                measured_ohm: Some(measured),
                min_ohm,
                max_ohm,
            }) = s.refused
            else {
                panic!("{label}: {:?}", s.refused);
            };
            let r_plant = truth.params.r_ohm;
            assert!(
                (measured / r_plant - 1.0).abs() < 0.02,
                "{label}: measured {measured} Ω, the plant's {r_plant} Ω"
            );
            assert!(
                (min_ohm * 3.0 / r0 - 1.0).abs() < 1e-6
                    && (max_ohm / (3.0 * r0) - 1.0).abs() < 1e-6,
                "{label}: [{min_ohm}, {max_ohm}] Ω for R₀ {r0} Ω"
            );
            assert!(!(min_ohm..=max_ohm).contains(&measured), "{label}");
            // The model kept R₀ (the drive ran, or the supervision stopped it: its call).
            assert_eq!(s.end.r_ohm, r0, "{label}");
            // Kept for the log after the stop.
            assert_eq!(s.refused_stopped, s.refused, "{label}");
            assert_eq!(s.stopped_mode, Mode::Idle, "{label}");
        }
    }
}

#[test]
fn a_winding_that_does_not_carry_the_current_refuses_the_start() {
    for name in MOTORS {
        let m = board::motor(name);
        let mut cases: Vec<(String, Motor, Option<MotorFault>)> = (0..3)
            .map(|k| (format!("open phase {k}"), m, Some(MotorFault::OpenPhase(k))))
            .collect();
        // A resistance the bus cannot drive the alignment's current through: the current at
        // the whole phase voltage below the lower level's.
        let dc = DriveConfig::new(&m);
        let v_max = m.ratings.bus_v / 3f32.sqrt();
        let r_high = 2.0 * v_max / dc.start.align_current_a;
        let high = Motor {
            params: MotorParams {
                r_ohm: r_high,
                ..m.params
            },
            ..m
        };
        cases.push((format!("R {r_high} Ω"), high, None));
        for (case, truth, fault) in cases {
            let label = format!("{name}, {case}");
            let s = start(&truth, m.params, fault);
            println!("{label}: {:?}", s.transitions);
            let tr = aligned(&s);
            assert_eq!(
                (tr.to, tr.reason),
                (Mode::Fault, Reason::Fault(Fault::OpenWinding)),
                "{label}"
            );
            assert_eq!(s.end.fault, Some(Fault::OpenWinding), "{label}");
            assert!(s.after_fault.iter().all(|&m| m == Mode::Fault), "{label}");
            assert!(s.off_after_fault, "{label}: switching after the fault");
            let open_loop = s.transitions.iter().any(|(_, t)| t.to == Mode::OpenLoop);
            assert!(!open_loop, "{label}: {:?}", s.transitions);
            // A fault, not a refused measurement: the model as configured.
            assert_eq!(s.refused, None, "{label}");
            assert_eq!(s.end.r_ohm, m.params.r_ohm, "{label}");
        }
    }
}
