//! `pmsm-sim identify`: the core's identification (`pmsm_sensorless::drive::identify`) run
//! against the plant, as a board runs it: the user's pole pairs and ratings only, the drive
//! built on a placeholder motor (`identify::placeholder`) and stepped on the simulated board
//! ([`SimBoard`]: its sensors with their noise and offsets, its inverter with its dead time),
//! the motor possibly faulty ([`MotorFault`]: an open phase, a shorted winding, a blocked
//! rotor) for the identification's plausibility checks. What it found: [`report`].

pub mod report;

pub use report::{identified_motor, motor_toml, summary_json};

pub use crate::board::MotorFault;

use crate::board::{BoardStage, SimBoard};
use pmsm_plant::PlantParams;
use pmsm_sensorless::drive::identify::placeholder;
use pmsm_sensorless::drive::{Command, DriveConfig, Fault, Identified, Mode, Transition};
use pmsm_sensorless::motor::Motor;
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;

/// Everything one identification run needs.
#[derive(Clone, Debug)]
pub struct IdentifyRun {
    /// The motor on the bench (its parameters are the truth; the drive sees only its pole
    /// pairs and ratings).
    pub motor: Motor,
    /// The board (its idle time is not used: the identification measures the offsets
    /// itself, first, PWM off).
    pub board: SimBoard,
    /// A fault of the motor.
    pub fault: Option<MotorFault>,
    /// Give up after this long \[s].
    pub max_s: f64,
}

impl IdentifyRun {
    /// `motor` on the B-G431B-ESC1 ([`SimBoard::board_defaults`]), without fault, for at
    /// most 30 s.
    pub fn board_defaults(motor: Motor) -> Self {
        Self {
            motor,
            board: SimBoard::board_defaults(&motor),
            fault: None,
            max_s: 30.0,
        }
    }
}

/// What a run found.
#[derive(Clone, Debug)]
pub struct IdentifyOutcome {
    /// The motor on the bench.
    pub truth: Motor,
    /// The results, when every measurement ended well.
    pub identified: Option<Identified>,
    /// The drive's fault, when one ended it.
    pub fault: Option<Fault>,
    /// Simulated time from the command to the result (or the fault) \[s].
    pub duration_s: f64,
    /// Every mode change with its time \[s].
    pub transitions: Vec<(f64, Transition)>,
}

/// RK4 sub-steps per control period (10 µs at 4 kHz).
const SUBSTEPS: usize = 25;

/// Runs the identification; errors name a bad setting.
pub fn run(cfg: &IdentifyRun) -> anyhow::Result<IdentifyOutcome> {
    let truth = cfg.motor;
    let board = &cfg.board;
    let user = placeholder(truth.params.pole_pairs, truth.ratings);
    let mut dc = DriveConfig::new(&user);
    board.configure_drive(&mut dc);
    if let Some(r) = board.sense_range_a {
        dc.identify.sense_range_a = r as f32;
    }
    dc.identify.sense_lsb_a = board.adc_lsb_a as f32;
    let drive = dc
        .build_flux_primary()
        .map_err(|e| anyhow::anyhow!("drive configuration: {e}"))?;
    let mut st = pmsm_sensorless::drive::StateOf::<FluxPll, SlidingObserver>::default();
    let mut stage = BoardStage::new(board, PlantParams::from(&truth.params), 0.0, 0.0)?;
    stage.set_motor_fault(cfg.fault);
    let rate = f64::from(dc.rate_hz);
    let ts = 1.0 / rate;
    let h = ts / SUBSTEPS as f64;
    let cmd = Command {
        enable: true,
        speed_rpm: 0.0,
        clear_fault: false,
    };
    let mut transitions = Vec::new();
    if let Some(tr) = drive.start_identification(&mut st) {
        transitions.push((0.0, tr));
    }
    let steps = (cfg.max_s * rate).round() as usize;
    let mut k = 0;
    while k < steps {
        let t = k as f64 * ts;
        let out = drive.step_on(&mut st, &mut stage, &cmd);
        let tick = if st.tick_due() {
            drive.tick(&mut st, &cmd)
        } else {
            None
        };
        for tr in [out.transition, tick].into_iter().flatten() {
            transitions.push((t, tr));
        }
        stage.advance(|_, _| 0.0, h, SUBSTEPS);
        k += 1;
        if matches!(st.mode(), Mode::Identified | Mode::Fault) {
            break;
        }
    }
    Ok(IdentifyOutcome {
        truth,
        identified: st.identified(),
        fault: st.fault(),
        duration_s: k as f64 * ts,
        transitions,
    })
}
