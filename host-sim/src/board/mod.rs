//! The simulated board: one description of it ([`SimBoard`]: PWM, dead time, current
//! sensing, bus, idle time, terminal-voltage sensing) shared by `run`, `sweep` and
//! `identify`; its DC bus, stiff or a DC link ([`bus`]); its sensors ([`sensors`]); the
//! faults of the motor on it ([`motor_fault`]); and the board around the plant as the core's
//! `PowerStage` ([`stage`]).

pub mod bus;
pub mod motor_fault;
pub mod sensors;
pub mod stage;

pub use bus::{BoardBus, DcLinkSpec};
pub use motor_fault::MotorFault;
pub use sensors::SensorFault;
pub use stage::{BoardPlant, BoardStage};

use pmsm_sensorless::drive::DriveConfig;
use pmsm_sensorless::motor::Motor;

/// The board a simulation runs on: its power stage, its sensing, and what it does before
/// t = 0.
#[derive(Clone, Debug, PartialEq)]
pub struct SimBoard {
    /// DC bus voltage \[V] (with a DC link: its supply's open-circuit voltage).
    pub bus_v: f64,
    /// The DC link between the supply and the inverter (`None`: a stiff bus at `bus_v`).
    pub dc_link: Option<DcLinkSpec>,
    /// PWM frequency \[Hz]: the averaged dead-time error per phase is
    /// `sign(i)·t_dead·f_pwm·V_bus`.
    pub pwm_hz: f64,
    /// Inverter dead time \[s]; the drive is told the same figure and compensates it (an
    /// ideal inverter, 0, gets no compensation).
    pub dead_time_s: f64,
    /// Current-sensor noise per phase, standard deviation \[A].
    pub noise_sigma_a: f64,
    /// Current-sensor offset per phase \[A].
    pub offset_a: [f64; 3],
    /// ADC quantisation step of the current measurement \[A] (0 = none).
    pub adc_lsb_a: f64,
    /// The current-sensing range \[A] the identification checks its currents against
    /// (`None`: the drive's default, twice its trip level).
    pub sense_range_a: Option<f64>,
    /// Seed of the sensors' noise.
    pub seed: u64,
    /// Drive runs: the time the board is idle (drive disabled, PWM off) before t = 0 \[s], as
    /// a board powered up before its enable: the idle drive measures the current sensors'
    /// offsets, and the board takes those off every later sample, as the B-G431B-ESC1 takes
    /// off the ones it measures at boot. The plant does not move meanwhile. An
    /// identification does not use it: it measures the offsets itself, first, PWM off.
    pub idle_s: f64,
    /// The board senses the terminal voltage (the B-G431B-ESC1's back-EMF dividers): the
    /// drive gets it while its PWM is off and can catch a turning rotor.
    pub sense_terminal_voltage: bool,
    /// The time from a sample to the duties computed from it taking effect \[s], at most one
    /// control period: the plant holds the last period's duties that long
    /// ([`BoardStage::advance`]) and the drive is told the same figure
    /// (`PowerStageConfig::update_delay_s`). 0 (the default): sample, computation and update
    /// at one instant, the timing of every run before the control rate followed the motor;
    /// the B-G431B-ESC1 loads its duties at the next PWM update, 50 µs
    /// (`pmsm-sim run --update-delay-us 50`).
    pub update_delay_s: f64,
}

impl SimBoard {
    /// An ideal board for `motor`: its rated bus, stiff, 20 kHz PWM without dead time, exact
    /// current sensing, no idle time, the terminal voltage sensed.
    pub fn ideal(motor: &Motor) -> Self {
        Self {
            bus_v: f64::from(motor.ratings.bus_v),
            dc_link: None,
            pwm_hz: 20_000.0,
            dead_time_s: 0.0,
            noise_sigma_a: 0.0,
            offset_a: [0.0; 3],
            adc_lsb_a: 0.0,
            sense_range_a: None,
            seed: 1,
            idle_s: 0.0,
            sense_terminal_voltage: true,
            update_delay_s: 0.0,
        }
    }

    /// The B-G431B-ESC1 with `motor`: its rated bus, 20 kHz PWM with 500 ns dead time
    /// (compensated by the drive), current-sensor noise of 1 % of the rated current, an
    /// offset of 2 % of it on phase a, 20 ms idle before t = 0 in which the offsets are
    /// measured, the terminal voltage sensed; seed 1.
    pub fn board_defaults(motor: &Motor) -> Self {
        let rated = f64::from(motor.ratings.current_a);
        Self {
            dead_time_s: 500e-9,
            noise_sigma_a: 0.01 * rated,
            offset_a: [0.02 * rated, 0.0, 0.0],
            idle_s: 0.02,
            ..Self::ideal(motor)
        }
    }

    /// Errors unless the bus voltage is a finite number > 0 V and the DC link's values, if
    /// any, are in their ranges.
    pub fn check_bus(&self) -> anyhow::Result<()> {
        anyhow::ensure!(
            self.bus_v.is_finite() && self.bus_v > 0.0,
            "bus voltage must be a finite number > 0 V, got {}",
            self.bus_v
        );
        self.dc_link.as_ref().map_or(Ok(()), DcLinkSpec::check)
    }

    /// The bus the plant runs on: stiff at `bus_v`, or the DC link charged to it.
    pub fn bus(&self) -> BoardBus {
        match &self.dc_link {
            None => BoardBus::Stiff(pmsm_plant::StiffBus { v_bus: self.bus_v }),
            Some(spec) => BoardBus::Link(spec.link(self.bus_v)),
        }
    }

    /// The board's power stage as the drive is told it: its PWM frequency, dead time and
    /// update delay, whether it senses the terminal voltage.
    pub fn configure_drive(&self, cfg: &mut DriveConfig) {
        cfg.power_stage.pwm_hz = self.pwm_hz as f32;
        cfg.power_stage.dead_time_s = self.dead_time_s as f32;
        cfg.power_stage.update_delay_s = self.update_delay_s as f32;
        cfg.power_stage.terminal_sensing = self.sense_terminal_voltage;
    }

    /// Samples the board is idle before t = 0 at the control rate `rate_hz`.
    pub fn idle_steps(&self, rate_hz: f64) -> usize {
        (self.idle_s * rate_hz).round() as usize
    }
}
