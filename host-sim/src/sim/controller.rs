//! What computes the duties of a run: the complete drive of the core, run by the core's
//! control loop as every firmware image runs it (`pmsm_sensorless::control::Control`: the
//! step, then the 1 kHz task when due), or the papers' FOC on one observer
//! ([`crate::observer::Bare`]).

use super::config::SimConfig;
use super::row::RowHealth;
use crate::board::BoardStage;
use crate::observer::{Bare, BareInput, Estimate, ObserverKind, ObserverSetup};
use crate::RAD_S_PER_RPM;
use pmsm_sensorless::control::{Commands, Control, Ticked};
use pmsm_sensorless::dead_time::DeadTimeConfig;
use pmsm_sensorless::drive::{Drive, DriveConfig, DriveInput, Limits, Mode, Telemetry, Transition};
use pmsm_sensorless::fixed::pu::PerUnit;
use pmsm_sensorless::foc::FocConfig;
use pmsm_sensorless::frames::{Abc, AlphaBeta};
use pmsm_sensorless::motor::{Motor, MotorParams};
use pmsm_sensorless::observer::{Observer, Rotor};
use pmsm_sensorless::power_stage::PowerStage;
use pmsm_sensorless::svpwm::Duties;

/// What computes the duties.
pub(super) enum Controller {
    /// FOC on one observer (the papers' experiments).
    Bare {
        /// The loop.
        bare: Box<Bare>,
        /// The voltage it applied over the period that just ended \[V].
        v_ab_last: AlphaBeta,
    },
    /// The complete drive of the core.
    Drive {
        /// The drive and its state.
        drive: Box<dyn SimDrive>,
        /// Its protection limits.
        limits: Limits,
    },
}

/// The core's control loop on the board, whatever its observers.
pub(super) trait SimDrive {
    /// One period on `stage` ([`Control::run`]: its sample, the step, its duties applied,
    /// then the 1 kHz task when due; with `tick` false, [`Control::step`] alone: the task
    /// stalled): the step's transition and the task's.
    fn run(
        &mut self,
        stage: &mut BoardStage,
        cmd: &Commands,
        tick: bool,
    ) -> [Option<Transition>; 2];
    /// [`Drive::telemetry`](pmsm_sensorless::drive::Drive::telemetry).
    fn telemetry(&self) -> Telemetry;
    /// [`Drive::derated`](pmsm_sensorless::drive::Drive::derated).
    fn derated(&self) -> bool;
    /// The voltage the last step's duties apply \[V].
    fn v_ab_applied(&self) -> AlphaBeta;
    /// The current sensors' offsets the drive measured [A, αβ].
    fn offset_ab(&self) -> AlphaBeta;
    /// The injection's estimate in its start (`DriveState::injection`).
    fn injection(&self) -> Option<(f32, f32, bool)>;
}

/// The board's sample of a period handed to the control loop, and the duties the loop
/// applied: the loop owns its power stage, the simulator owns the board ([`BoardStage`], which
/// the papers' bare loop uses too), so each period the one is handed to the other.
#[derive(Default)]
struct Latch {
    input: Option<DriveInput>,
    duties: Option<Duties>,
    short_circuit: bool,
    brake: bool,
}

impl PowerStage for Latch {
    fn sample(&mut self) -> DriveInput {
        // Set before every step (`Running::run`).
        self.input.take().unwrap_or(DriveInput {
            i_abc: Abc::new(f32::NAN, f32::NAN, f32::NAN),
            v_bus: f32::NAN,
            v_ab_terminal: None,
            overrun: false,
            stage_fault: None,
        })
    }
    fn apply(&mut self, duties: Option<Duties>) {
        self.duties = duties;
        self.short_circuit = false;
    }
    fn short_circuit(&mut self) {
        self.duties = None;
        self.short_circuit = true;
    }
    fn brake(&mut self, on: bool) {
        self.brake = on;
    }
}

impl<P: Observer, M: Observer> SimDrive for Control<P, M, Latch> {
    fn run(
        &mut self,
        stage: &mut BoardStage,
        cmd: &Commands,
        tick: bool,
    ) -> [Option<Transition>; 2] {
        self.stage_mut().input = Some(stage.sample());
        let (stepped, ticked) = if tick {
            Control::run(self, cmd)
        } else {
            (Control::step(self, cmd), Ticked::default())
        };
        let latch = self.stage();
        if latch.short_circuit {
            stage.short_circuit();
        } else {
            stage.apply(latch.duties);
        }
        stage.brake(latch.brake);
        [stepped.transition, ticked.transition]
    }
    fn telemetry(&self) -> Telemetry {
        Control::telemetry(self)
    }
    fn derated(&self) -> bool {
        self.drive().derated(self.state())
    }
    fn v_ab_applied(&self) -> AlphaBeta {
        self.state().v_ab_applied()
    }
    fn injection(&self) -> Option<(f32, f32, bool)> {
        self.state().injection()
    }
    fn offset_ab(&self) -> AlphaBeta {
        self.state().offset_ab()
    }
}

/// The drive with `drive`'s observers, idle.
fn running<P: Observer + 'static, M: Observer + 'static>(drive: Drive<P, M>) -> Box<dyn SimDrive> {
    Box::new(Control::new(drive, Latch::default()))
}

/// What one control period asks of the controller.
pub(super) struct Period {
    /// Speed command \[rpm].
    pub speed_cmd_rpm: f64,
    /// Drive runs: the enable command.
    pub enable: bool,
    /// Drive runs: the command to clear a latched fault.
    pub clear_fault: bool,
    /// The true rotor (the bare loop's encoder), load unknown (0).
    pub truth: Rotor,
    /// Bare runs: from this |true speed| on the observer runs on its own \[rad/s].
    pub sensorless_from: f32,
    /// Drive runs: the 1 kHz task stalled (an injection): the step alone.
    pub task_stalled: bool,
}

/// What the controller did in one control period.
pub(super) struct PeriodOut {
    /// The estimate the controller ran on.
    pub est: Estimate,
    /// The voltage its duties apply \[V].
    pub v_ab: AlphaBeta,
    /// Drive runs: the mode, the monitor's angle \[deg], the health figures.
    pub drive: Option<(Mode, f64, RowHealth)>,
    /// Drive runs: the step's transition, then the 1 kHz task's.
    pub transitions: [Option<Transition>; 2],
}

impl Controller {
    /// The controller `config` asks for, on the controller's copy of the motor (with the
    /// mismatch factors); errors name the bad setting.
    pub(super) fn new(config: &SimConfig) -> anyhow::Result<Self> {
        let sc = &config.scenario;
        let controller_motor = config
            .mismatch
            .apply(&sc.motor.params)
            .map_err(|e| anyhow::anyhow!("controller motor parameters: {e}"))?;
        if sc.drive.is_some() {
            anyhow::ensure!(
                !config.fixed_point,
                "fixed point: the papers' bare-observer experiments only (the drive's step in \
                 fixed point runs beside the f32 drive in `tests/fixed_step.rs`)"
            );
            Self::drive(config, controller_motor)
        } else {
            Self::bare(config, controller_motor)
        }
    }

    /// The complete drive with `config.observer` primary.
    fn drive(config: &SimConfig, params: MotorParams) -> anyhow::Result<Self> {
        let motor = Motor {
            params,
            ..config.scenario.motor
        };
        let mut cfg = DriveConfig::new(&motor);
        cfg.rate_hz = config.rate_hz as f32;
        // The board's figures as the user configures them: the plant's own (an ideal
        // plant, dead time 0, gets no compensation).
        config.board.configure_drive(&mut cfg);
        cfg.mtpa = config.mtpa;
        let err = |e| anyhow::anyhow!("drive configuration: {e}");
        let drive = match config.observer {
            ObserverKind::SlidingTorque => {
                let d = cfg.build_sliding_primary().map_err(err)?;
                running(if config.injection {
                    d
                } else {
                    d.without_injection()
                })
            }
            ObserverKind::Flux => {
                let d = cfg.build_flux_primary().map_err(err)?;
                running(if config.injection {
                    d
                } else {
                    d.without_injection()
                })
            }
            other => anyhow::bail!(
                "drive scenarios run with --observer sliding-torque or flux, not '{}'",
                other.name()
            ),
        };
        Ok(Self::Drive {
            drive,
            limits: cfg.limits,
        })
    }

    /// FOC on `config.observer`.
    fn bare(config: &SimConfig, params: MotorParams) -> anyhow::Result<Self> {
        let sc = &config.scenario;
        anyhow::ensure!(
            config.board.update_delay_s == 0.0,
            "the bare observer runs (the papers' timing) take no update delay"
        );
        let mut foc_cfg = FocConfig::new(params, sc.i_max_a() as f32);
        foc_cfg.current_rate_hz = config.rate_hz as f32;
        // The speed loop at 1 kHz, as the drive's task.
        foc_cfg.speed_divider = (config.rate_hz / 1000.0).round().max(1.0) as u32;
        // The plant's dead time compensated, as the drive does (the drive's smooth-sign
        // band: 5 % of the rated-torque current).
        let band_a = DriveConfig::new(&sc.motor).power_stage.dead_time_band_a;
        foc_cfg.dead_time = DeadTimeConfig {
            dead_time_s: config.board.dead_time_s as f32,
            pwm_hz: config.board.pwm_hz as f32,
            band_a,
            duty_max: 1.0,
        };
        let foc = foc_cfg
            .build()
            .map_err(|e| anyhow::anyhow!("controller configuration: {e}"))?;
        // A fixed-point observer's bases: the drive's for the controller's motor at the run's
        // rate (its sensing range, its highest bus over √3).
        let fixed_point = if config.fixed_point {
            let motor = Motor { params, ..sc.motor };
            let drive = DriveConfig {
                rate_hz: config.rate_hz as f32,
                ..DriveConfig::new(&motor)
            };
            let pu =
                PerUnit::of_drive(&drive).map_err(|e| anyhow::anyhow!("fixed-point bases: {e}"))?;
            Some(pu)
        } else {
            None
        };
        let mut bare = config.observer.bare(
            &ObserverSetup {
                motor: params,
                rate_hz: config.rate_hz as f32,
                sliding: config.sliding,
                min_speed_rpm: sc.min_speed_rpm as f32,
                gamma: config.gamma,
                fixed_point,
            },
            foc,
        )?;
        if config.cold_start {
            bare.start_cold();
        }
        Ok(Self::Bare {
            bare: Box::new(bare),
            v_ab_last: AlphaBeta::default(),
        })
    }

    /// Drive runs: the protection limits.
    pub(super) fn limits(&self) -> Option<&Limits> {
        match self {
            Self::Drive { limits, .. } => Some(limits),
            Self::Bare { .. } => None,
        }
    }

    /// Drive runs: `steps` samples with the drive disabled before t = 0, the plant sampled
    /// as it is; then the board takes the offsets the drive measured off its samples.
    pub(super) fn idle(&mut self, stage: &mut BoardStage, steps: usize) {
        let Self::Drive { drive, .. } = self else {
            return;
        };
        let off = Commands::default();
        for _ in 0..steps {
            drive.run(stage, &off, true);
        }
        if steps > 0 {
            stage.take_offsets(drive.offset_ab().to_abc());
        }
    }

    /// One control period on `stage`: sample, compute the duties, load them.
    pub(super) fn step(&mut self, stage: &mut BoardStage, period: &Period) -> PeriodOut {
        match self {
            Self::Bare { bare, v_ab_last } => {
                let input = stage.sample();
                let (out, est) = bare.step(&BareInput {
                    i_abc: input.i_abc,
                    v_bus: input.v_bus,
                    v_ab_last: *v_ab_last,
                    truth: period.truth,
                    omega_m_ref: (period.speed_cmd_rpm * RAD_S_PER_RPM) as f32,
                    sensorless_from: period.sensorless_from,
                });
                stage.apply(Some(out.duties));
                *v_ab_last = out.v_ab;
                PeriodOut {
                    est,
                    v_ab: out.v_ab,
                    drive: None,
                    transitions: [None; 2],
                }
            }
            Self::Drive { drive, .. } => {
                let cmd = Commands {
                    enable: period.enable,
                    speed_rpm: period.speed_cmd_rpm as f32,
                    clear_fault: period.clear_fault,
                    ..Commands::default()
                };
                let transitions = drive.run(stage, &cmd, !period.task_stalled);
                let tel = drive.telemetry();
                let health = RowHealth {
                    driving: tel.driving,
                    residual_primary: tel.residual_primary as f64,
                    residual_monitor: tel.residual_monitor as f64,
                    r_ohm: tel.r_ohm as f64,
                    flux_wb: tel.flux_wb as f64,
                    voltage_limited: tel.voltage_limited,
                    derated: drive.derated(),
                    injection_tracking: drive.injection().map(|(_, _, tracking)| tracking),
                };
                // The angle the controller runs on: the driving observer's while sensorless.
                let sensorless = tel.mode == Mode::Sensorless;
                // In the injection's start, its estimate.
                let injecting = drive.injection().is_some();
                let est = Estimate {
                    theta_e: if sensorless || injecting {
                        tel.theta_e_control
                    } else {
                        tel.theta_e_primary
                    },
                    omega_m: tel.speed_rpm * pmsm_sensorless::units::RAD_S_PER_RPM,
                    load_nm: tel.load_nm,
                    sliding: None,
                    sensorless,
                };
                let monitor_deg = (tel.theta_e_monitor as f64).to_degrees();
                PeriodOut {
                    est,
                    v_ab: drive.v_ab_applied(),
                    drive: Some((tel.mode, monitor_deg, health)),
                    transitions,
                }
            }
        }
    }
}
