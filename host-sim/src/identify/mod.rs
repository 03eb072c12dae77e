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
use pmsm_plant::{Inductances, PlantParams};
use pmsm_sensorless::control::{Commands, Control};
use pmsm_sensorless::drive::identify::{placeholder, SPIN_SPEED_SHARE};
use pmsm_sensorless::drive::{DriveConfig, Fault, Identified, Mode, Transition};
use pmsm_sensorless::motor::Motor;
use pmsm_sensorless::rate::{control_rate, CpuBudget};

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
    /// The motor's own inductances where it is salient or saturates (a motor file's,
    /// `crate::motor_file::Loaded::inductances`); `None`: `L_d = L_q` = its `l_h`.
    pub inductances: Option<Inductances>,
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
            inductances: None,
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
    /// What was measured before the end (zeros for the measurements not reached): R and L of
    /// a run that ended in the spin.
    pub so_far: Identified,
    /// Simulated time from the command to the result (or the fault) \[s].
    pub duration_s: f64,
    /// Every mode change with its time \[s].
    pub transitions: Vec<(f64, Transition)>,
}

/// RK4 sub-steps per control period (10 µs at 4 kHz).
const SUBSTEPS: usize = 25;

/// The drive's configuration for identifying `motor` on `board`, as a board has it: built on
/// the placeholder motor of its pole pairs and ratings (`identify::placeholder`), with the
/// board's PWM, dead time and current sensing, at the identification's control rate (20
/// samples per electrical period at its spin speed, `identify::SPIN_SPEED_SHARE`).
pub fn drive_config(motor: &Motor, board: &SimBoard) -> DriveConfig {
    let user = placeholder(motor.params.pole_pairs, motor.ratings, motor.params.torque);
    let mut dc = DriveConfig::new(&user);
    board.configure_drive(&mut dc);
    let spin_rpm = SPIN_SPEED_SHARE * motor.ratings.speed_rpm;
    let pole_pairs = motor.params.pole_pairs;
    dc.rate_hz = control_rate(pole_pairs, spin_rpm, board.pwm_hz as f32, &CpuBudget::BOARD).rate_hz;
    if let Some(r) = board.sense_range_a {
        dc.identify.sense_range_a = r as f32;
    }
    dc.identify.sense_lsb_a = board.adc_lsb_a as f32;
    dc
}

/// Runs the identification; errors name a bad setting.
pub fn run(cfg: &IdentifyRun) -> anyhow::Result<IdentifyOutcome> {
    let truth = cfg.motor;
    let board = &cfg.board;
    let dc = drive_config(&truth, board);
    let drive = dc
        .build_flux_primary()
        .map_err(|e| anyhow::anyhow!("drive configuration: {e}"))?;
    let mut stage = BoardStage::new(
        board,
        PlantParams::with_inductances(&truth.params, cfg.inductances.as_ref()),
        0.0,
        0.0,
    )?;
    stage.set_motor_fault(cfg.fault);
    // The core's control loop, as the commissioning firmware runs it.
    let mut control = Control::new(drive, stage);
    let rate = f64::from(dc.rate_hz);
    let ts = 1.0 / rate;
    let h = ts / SUBSTEPS as f64;
    let cmd = Commands {
        enable: true,
        ..Commands::default()
    };
    // The identification asked for before the first step (its calibration's task does
    // nothing, so the start falls on step 0 and not on the first due task).
    let mut transitions: Vec<(f64, Transition)> = control
        .tick(&Commands {
            identify: true,
            ..cmd
        })
        .transitions()
        .map(|tr| (0.0, tr))
        .collect();
    let steps = (cfg.max_s * rate).round() as usize;
    let mut k = 0;
    while k < steps {
        let t = k as f64 * ts;
        let (stepped, ticked) = control.run(&cmd);
        for tr in [stepped.transition, ticked.transition]
            .into_iter()
            .flatten()
        {
            transitions.push((t, tr));
        }
        control.stage_mut().advance(|_, _| 0.0, h, SUBSTEPS);
        k += 1;
        if matches!(control.state().mode(), Mode::Identified | Mode::Fault) {
            break;
        }
    }
    let st = control.state();
    Ok(IdentifyOutcome {
        truth,
        identified: st.identified(),
        fault: st.fault(),
        so_far: st.identified_so_far(),
        duration_s: k as f64 * ts,
        transitions,
    })
}
