//! What one run is configured with ([`SimConfig`]): the scenario, the observer, the board,
//! the controller's parameter mismatch ([`Mismatch`]), the control rate and the plant's
//! sub-steps.

use crate::board::SimBoard;
use crate::observer::ObserverKind;
use crate::scenario::Scenario;
use pmsm_plant::Inductances;
use pmsm_sensorless::drive::DriveConfig;
use pmsm_sensorless::motor::{Motor, MotorParams};
use pmsm_sensorless::observer::sliding::SlidingConfig;
use pmsm_sensorless::param::ParamError;

/// Controller parameters as multiples of the plant's (1.0 = exact knowledge).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mismatch {
    /// Resistance factor.
    pub r: f64,
    /// Inductance factor.
    pub l: f64,
    /// Flux-linkage factor.
    pub flux: f64,
    /// Inertia factor.
    pub j: f64,
    /// Friction factor.
    pub b: f64,
}

impl Default for Mismatch {
    fn default() -> Self {
        Self {
            r: 1.0,
            l: 1.0,
            flux: 1.0,
            j: 1.0,
            b: 1.0,
        }
    }
}

impl Mismatch {
    /// The factors that make the controller's copy of `plant` the parameters `controller`
    /// (e.g. an identified motor driving the real one).
    pub fn between(plant: &MotorParams, controller: &MotorParams) -> Self {
        let f = |c: f32, p: f32| {
            if p == 0.0 {
                1.0
            } else {
                f64::from(c) / f64::from(p)
            }
        };
        Self {
            r: f(controller.r_ohm, plant.r_ohm),
            l: f(controller.l_h, plant.l_h),
            flux: f(controller.flux_wb, plant.flux_wb),
            j: f(controller.j_kgm2, plant.j_kgm2),
            b: f(controller.b_nms, plant.b_nms),
        }
    }

    /// The controller's copy of `m`.
    pub fn apply(&self, m: &MotorParams) -> Result<MotorParams, ParamError> {
        MotorParams {
            r_ohm: m.r_ohm * self.r as f32,
            l_h: m.l_h * self.l as f32,
            flux_wb: m.flux_wb * self.flux as f32,
            j_kgm2: m.j_kgm2 * self.j as f32,
            b_nms: m.b_nms * self.b as f32,
            ..*m
        }
        .validate()
    }
}

/// Everything one run needs.
#[derive(Clone, Debug)]
pub struct SimConfig {
    /// The experiment.
    pub scenario: Scenario,
    /// What fills the observer slot.
    pub observer: ObserverKind,
    /// The board the drive runs on.
    pub board: SimBoard,
    /// Controller-vs-plant parameter factors.
    pub mismatch: Mismatch,
    /// Control (current-loop) rate \[Hz].
    pub rate_hz: f64,
    /// RK4 sub-steps per control period.
    pub substeps: usize,
    /// Initial rotor angle [rad, mechanical].
    pub theta_m0: f64,
    /// Settings replacing the paper's defaults when the observer is a sliding one.
    pub sliding: Option<SlidingConfig>,
    /// Stand-in for a start-up sequence: below this |speed| \[rpm] the controller uses the
    /// encoder and the observer is held at the encoder's state; from the sample after the
    /// first one at or above it, the run is sensorless. `None`: the observer is set to the
    /// encoder's state at t = 0 and the run is sensorless from the second sample on.
    pub sensorless_from_rpm: Option<f64>,
    /// Start the observer from its own zero state instead of the encoder's (a wrong initial
    /// estimate), sensorless from t = 0.
    pub cold_start: bool,
    /// Flux-observer γ replacing the recommended one \[1/(Wb²·s)].
    pub gamma: Option<f32>,
    /// The drive's motor model from an identification of the plant's motor on the same board
    /// first (`crate::identify`: the user's pole pairs, ratings and torque convention only),
    /// replacing `mismatch`: identify, then drive with the identified motor (issue #26).
    pub identify_first: bool,
    /// The plant's own inductances (a salient or saturating motor file's,
    /// `crate::motor_file::Loaded::inductances`); `None`: `L_d = L_q` = the scenario motor's
    /// `l_h`, no saturation. The drive's motor keeps its one `l_h` either way.
    pub plant_inductances: Option<Inductances>,
    /// The drive's maximum torque per ampere on a salient motor (`DriveConfig::mtpa`; true).
    pub mtpa: bool,
    /// The drive starts a rotor at rest through high-frequency injection on a salient motor
    /// (true, the core's default with its feature `injection`; false:
    /// `Drive::without_injection`, the alignment and the open loop).
    pub injection: bool,
    /// A bare run's sliding observer in fixed point (`crate::observer::fixed`, issue #30;
    /// false: f32). The drive's runs and the other observers refuse it.
    pub fixed_point: bool,
}

impl SimConfig {
    /// Defaults: an ideal board ([`SimBoard::ideal`]: the scenario's motor's bus, no noise,
    /// ideal inverter), exact parameters, the control rate the drive's configuration chooses
    /// for the motor on the board ([`SimConfig::rate_for`]: 4 kHz up to 200 Hz electrical at
    /// rated speed), sub-steps of at most 10 µs (25 at 4 kHz).
    pub fn new(scenario: Scenario, observer: ObserverKind) -> Self {
        let board = SimBoard::ideal(&scenario.motor);
        Self::on(board, scenario, observer)
    }

    /// The defaults of [`SimConfig::new`] on `board`, the scenario's `terminal_sensing`
    /// over the board's.
    pub fn on(mut board: SimBoard, scenario: Scenario, observer: ObserverKind) -> Self {
        if let Some(sensed) = scenario.drive.as_ref().and_then(|d| d.terminal_sensing) {
            board.sense_terminal_voltage = sensed;
        }
        let rate_hz = Self::rate_for(&board, &scenario.motor);
        Self {
            scenario,
            observer,
            board,
            mismatch: Mismatch::default(),
            rate_hz,
            substeps: Self::substeps_at(rate_hz),
            theta_m0: 0.0,
            sliding: None,
            sensorless_from_rpm: None,
            cold_start: false,
            gamma: None,
            identify_first: false,
            plant_inductances: None,
            mtpa: true,
            injection: true,
            fixed_point: false,
        }
    }
}

impl SimConfig {
    /// The control rate the drive's configuration chooses for `motor` on `board`'s PWM
    /// ([`DriveConfig::choose_rate`], `pmsm_sensorless::rate`) \[Hz].
    pub fn rate_for(board: &SimBoard, motor: &Motor) -> f64 {
        let mut cfg = DriveConfig::new(motor);
        board.configure_drive(&mut cfg);
        cfg.choose_rate();
        f64::from(cfg.rate_hz)
    }

    /// RK4 sub-steps of at most 10 µs per control period at `rate_hz`: `⌈100 kHz/rate⌉`.
    pub fn substeps_at(rate_hz: f64) -> usize {
        (1e5 / rate_hz).ceil().max(1.0) as usize
    }

    /// The control rate `rate_hz` \[Hz] and its sub-steps ([`SimConfig::substeps_at`]).
    pub fn set_rate(&mut self, rate_hz: f64) {
        self.rate_hz = rate_hz;
        self.substeps = Self::substeps_at(rate_hz);
    }
}
