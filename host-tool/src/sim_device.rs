//! A device on the host ([`SimDevice`]): the real core drive (`Drive::step`, `Drive::tick`
//! and `Drive::background`, as `pmsm_sensorless::control::Control::run` calls them) stepping the host
//! simulator's plant on its simulated board (`pmsm_host_sim::board::BoardStage`) in
//! simulated time, implementing the link's [`Device`] as a firmware does: settings applied
//! by rebuilding the drive, a "flash" that keeps the saved settings across
//! [`SimDevice::reset`], the identification on a drive built from the placeholder motor of
//! the configured pole pairs and ratings (`identify::placeholder`, as
//! `pmsm-sim identify` and the commissioning firmware build it). It takes the emulated
//! firmware's place in the tests; [`crate::serve`] serves it on any `embedded-io` stream.

use pmsm_host_sim::board::{BoardStage, SimBoard};
use pmsm_host_sim::plant::PlantParams;
use pmsm_host_sim::sim::SimConfig;
use pmsm_link::{Device, DeviceError, Settings};
use pmsm_sensorless::drive::identify::{placeholder, SPIN_SPEED_SHARE};
use pmsm_sensorless::drive::{Command, Drive, Identified, Mode, StateOf, Telemetry, Transition};
use pmsm_sensorless::motor::Motor;
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;
use pmsm_sensorless::power_stage::PowerStage;
use pmsm_sensorless::rate::{control_rate, CpuBudget};
use std::collections::VecDeque;

type SimDrive = Drive<FluxPll, SlidingObserver>;

/// The simulated device (module doc).
pub struct SimDevice {
    /// The motor on the bench (the plant's truth).
    truth: Motor,
    board: SimBoard,
    /// The settings in force (`None`: none, or none valid, loaded at the last reset).
    settings: Option<Settings>,
    /// The non-volatile store: the settings last saved.
    flash: Option<Settings>,
    /// The drive built from the settings (or from the identification's placeholder).
    drive: Option<SimDrive>,
    state: StateOf<FluxPll, SlidingObserver>,
    stage: BoardStage,
    cmd: Command,
    /// A clear-fault request, taken by the next step.
    clear: bool,
    /// The drive is the identification's (built on the placeholder motor).
    identifying: bool,
    /// Step rate of the drive in force \[Hz] and plant sub-steps.
    rate_hz: f64,
    substeps: usize,
    /// Simulated time \[s].
    t_s: f64,
    transitions: VecDeque<Transition>,
    /// The load torque on the shaft \[N·m].
    pub load_nm: f64,
}

impl SimDevice {
    /// `truth` on an ideal board ([`SimBoard::ideal`]: exact sensing, no dead time), its flash
    /// holding `flash` (`None`: empty), powered up ([`SimDevice::reset`]).
    pub fn new(truth: Motor, flash: Option<Settings>) -> anyhow::Result<Self> {
        let board = SimBoard::ideal(&truth);
        let stage = BoardStage::new(&board, PlantParams::from(&truth.params), 0.0, 0.0)?;
        let mut d = Self {
            truth,
            board,
            settings: None,
            flash,
            drive: None,
            state: StateOf::<FluxPll, SlidingObserver>::default(),
            stage,
            cmd: Command::default(),
            clear: false,
            identifying: false,
            rate_hz: 4000.0,
            substeps: SimConfig::substeps_at(4000.0),
            t_s: 0.0,
            transitions: VecDeque::new(),
            load_nm: 0.0,
        };
        d.reset();
        Ok(d)
    }

    /// A power cycle: the flash's settings loaded if the core validates them (else none: the
    /// drive refuses to run), the drive idle, the commands off. The plant (the motor) keeps
    /// turning as it was.
    pub fn reset(&mut self) {
        self.settings = self.flash.filter(|s| s.validate().is_ok());
        self.cmd = Command::default();
        self.clear = false;
        self.identifying = false;
        self.transitions.clear();
        self.rebuild(true);
    }

    /// The flash, as the board's store would hold it.
    pub fn flash(&self) -> Option<Settings> {
        self.flash
    }

    /// Writes `flash` into the store (a test's corrupt or foreign record: `None`).
    pub fn set_flash(&mut self, flash: Option<Settings>) {
        self.flash = flash;
    }

    /// Simulated time \[s].
    pub fn t_s(&self) -> f64 {
        self.t_s
    }

    /// The plant's mechanical speed \[rpm] (the truth).
    pub fn plant_speed_rpm(&self) -> f64 {
        self.stage.plant().state.omega_m * 30.0 / std::f64::consts::PI
    }

    /// The drive for the settings in force (or none), at their rate; the drive's state kept
    /// unless `restart` (a locked setting changed: the drive is not running).
    fn rebuild(&mut self, restart: bool) {
        let built = self
            .settings
            .and_then(|s| s.drive_config().build_flux_primary().ok());
        self.drive = built;
        if let Some(s) = self.settings {
            self.set_rate(f64::from(s.rate_hz));
        }
        if restart {
            self.state = StateOf::<FluxPll, SlidingObserver>::default();
        }
    }

    fn set_rate(&mut self, rate_hz: f64) {
        self.rate_hz = rate_hz;
        self.substeps = SimConfig::substeps_at(rate_hz);
    }

    /// Runs the drive and the plant for `dt_s` of simulated time.
    pub fn advance(&mut self, dt_s: f64) {
        let end = self.t_s + dt_s;
        while self.t_s < end {
            self.step();
        }
    }

    /// One control period: sample, step, apply, the 1 kHz task when due, the plant.
    fn step(&mut self) {
        let ts = 1.0 / self.rate_hz;
        if let Some(drive) = &self.drive {
            let input = self.stage.sample();
            let cmd = Command {
                clear_fault: self.clear,
                ..self.cmd
            };
            self.clear = false;
            let out = drive.step(&mut self.state, &input, &cmd);
            if out.short_circuit {
                self.stage.short_circuit();
            } else {
                self.stage.apply(out.duties);
            }
            self.stage.brake(out.brake);
            self.transitions.extend(out.transition);
            if self.state.tick_due() {
                let tick = Command {
                    clear_fault: false,
                    ..cmd
                };
                self.transitions.extend(drive.tick(&mut self.state, &tick));
                drive.background(&mut self.state);
            }
        } else {
            self.stage.apply(None);
        }
        // The identification over and its enable withdrawn: the configured drive again.
        if self.identifying && self.state.mode() == Mode::Idle {
            self.identifying = false;
            self.rebuild(true);
        }
        let load = self.load_nm;
        self.stage
            .advance(move |_, _| load, ts / self.substeps as f64, self.substeps);
        self.t_s += ts;
    }
}

impl Device for SimDevice {
    fn settings(&self) -> Option<Settings> {
        self.settings
    }

    fn apply(&mut self, settings: &Settings) -> Result<(), DeviceError> {
        let restart = !self.running()
            && self
                .settings
                .is_none_or(|s| s.motor != settings.motor || s.rate_hz != settings.rate_hz);
        self.settings = Some(*settings);
        if !self.identifying {
            self.rebuild(restart);
        }
        Ok(())
    }

    fn defaults_for(&self, motor: &Motor) -> Settings {
        // The board's power stage and sensing (the ideal board's when none is in force).
        let board = self.settings.unwrap_or_else(|| {
            let mut c = pmsm_sensorless::drive::DriveConfig::new(motor);
            self.board.configure_drive(&mut c);
            Settings::from(&c)
        });
        Settings::for_motor(motor, Some(&board))
    }

    fn save(&mut self) -> Result<(), DeviceError> {
        self.flash = self.settings;
        Ok(())
    }

    fn running(&self) -> bool {
        self.cmd.enable
            || !matches!(
                self.state.mode(),
                Mode::Idle | Mode::Fault | Mode::Identified
            )
    }

    fn enable(&mut self, on: bool) -> Result<(), DeviceError> {
        self.cmd.enable = on;
        Ok(())
    }

    fn set_speed(&mut self, rpm: f32) -> Result<(), DeviceError> {
        self.cmd.speed_rpm = rpm;
        Ok(())
    }

    fn start_identification(&mut self) -> Result<(), DeviceError> {
        if self.running() {
            return Err(DeviceError::Refused(
                "the identification starts from idle, disabled",
            ));
        }
        // The drive of the placeholder motor of the configured (or the bench motor's) pole
        // pairs and ratings, at the identification's rate (`pmsm_host_sim::identify`).
        let (pole_pairs, ratings, torque) = match self.settings {
            Some(s) => {
                let m = s.motor();
                (m.params.pole_pairs, m.ratings, m.params.torque)
            }
            None => (
                self.truth.params.pole_pairs,
                self.truth.ratings,
                self.truth.params.torque,
            ),
        };
        let user = placeholder(pole_pairs, ratings, torque);
        let mut dc = pmsm_sensorless::drive::DriveConfig::new(&user);
        self.board.configure_drive(&mut dc);
        let spin_rpm = SPIN_SPEED_SHARE * ratings.speed_rpm;
        dc.rate_hz = control_rate(
            pole_pairs,
            spin_rpm,
            self.board.pwm_hz as f32,
            &CpuBudget::BOARD,
        )
        .rate_hz;
        let drive = dc.build_flux_primary().map_err(DeviceError::Rejected)?;
        self.state = StateOf::<FluxPll, SlidingObserver>::default();
        self.transitions
            .extend(drive.start_identification(&mut self.state));
        self.drive = Some(drive);
        self.set_rate(f64::from(dc.rate_hz));
        self.identifying = true;
        // Held enabled with a zero command until the result is read and the enable withdrawn.
        self.cmd = Command {
            enable: true,
            speed_rpm: 0.0,
            clear_fault: false,
        };
        Ok(())
    }

    fn identified(&self) -> Option<pmsm_sensorless::drive::Identified> {
        self.state.identified().map(|i: Identified| i)
    }

    fn restart(&mut self) -> Result<(), DeviceError> {
        // The simulated power-up: the settings from the store, the drive idle.
        self.reset();
        Ok(())
    }

    fn clear_fault(&mut self) -> Result<(), DeviceError> {
        // Taken by the next step, run now: the answer that follows sees it (a board's next
        // step is 250 µs away).
        self.clear = true;
        self.step();
        Ok(())
    }

    fn telemetry(&self) -> Telemetry {
        match &self.drive {
            Some(d) => d.telemetry(&self.state),
            None => Telemetry::default(),
        }
    }

    fn now_ms(&self) -> u32 {
        (self.t_s * 1000.0) as u64 as u32
    }

    fn next_transition(&mut self) -> Option<Transition> {
        self.transitions.pop_front()
    }
}
