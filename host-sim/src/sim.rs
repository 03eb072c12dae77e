//! The closed loop: plant + inverter + current sensor + observer slot + the core's FOC.
//!
//! Timing of one control period `k` (`T = 1/rate_hz`, 250 µs at 4 kHz): the currents and the
//! encoder are sampled at `t_k`, the core computes the duties at once, and the inverter holds
//! them over `[t_k, t_k + T)` while the plant is integrated with RK4 on `substeps` sub-steps.

use crate::inverter::{CurrentSensor, Inverter};
use crate::observer::{Bare, BareInput, Estimate, ObserverKind, ObserverSetup};
use crate::plant::DiodeBridge;
use crate::plant::{Plant, PlantParams};
use crate::scenario::Injection;
use crate::scenario::Scenario;
use pmsm_sensorless::bounds::ks_min;
use pmsm_sensorless::dead_time::DeadTimeConfig;
use pmsm_sensorless::drive::{
    Command, Drive, DriveConfig, DriveInput, DriveOutput, Fault, Limits, Mode, Reason, Role,
    StateOf, Telemetry, Transition,
};
use pmsm_sensorless::foc::FocConfig;
use pmsm_sensorless::frames::AlphaBeta;
use pmsm_sensorless::motor::{Motor, MotorParams};
use pmsm_sensorless::observer::sliding::SlidingConfig;
use pmsm_sensorless::observer::{Observer, Rotor};
use pmsm_sensorless::param::ParamError;
use std::f64::consts::PI;

/// rad/s per rpm.
pub const RAD_S_PER_RPM: f64 = PI / 30.0;

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
    /// DC bus voltage \[V].
    pub bus_v: f64,
    /// Current-sensor noise per phase, standard deviation \[A].
    pub noise_sigma_a: f64,
    /// Current-sensor offset per phase \[A].
    pub offset_a: [f64; 3],
    /// ADC quantisation step \[A] (0 = none).
    pub adc_lsb_a: f64,
    /// Noise seed.
    pub seed: u64,
    /// Inverter dead time \[s].
    pub dead_time_s: f64,
    /// PWM frequency \[Hz] (the board's 20 kHz): the averaged dead-time error per phase is
    /// `sign(i)·t_dead·f_pwm·V_bus`.
    pub pwm_hz: f64,
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
    /// The board senses the terminal voltage (the B-G431B-ESC1's back-EMF dividers): the
    /// drive gets it while its PWM is off and can catch a turning rotor.
    pub sense_terminal_voltage: bool,
    /// Drive runs: samples the drive takes idle (disabled, PWM off) before t = 0, as a board
    /// powered up before its enable: the idle drive measures the sensors' offsets from them,
    /// and the board (this simulator) takes those offsets off every later sample, as the
    /// B-G431B-ESC1 takes off the ones it measures at boot. The plant does not move meanwhile
    /// (it is sampled as it is at t = 0). Default 0 (no offset taken off).
    pub idle_steps_before: usize,
}

impl SimConfig {
    /// Defaults: the scenario's motor bus, no noise, ideal inverter, exact parameters,
    /// 4 kHz control, 25 sub-steps (10 µs).
    pub fn new(scenario: Scenario, observer: ObserverKind) -> Self {
        let bus_v = scenario.motor.ratings.bus_v as f64;
        Self {
            scenario,
            observer,
            bus_v,
            noise_sigma_a: 0.0,
            offset_a: [0.0; 3],
            adc_lsb_a: 0.0,
            seed: 1,
            dead_time_s: 0.0,
            pwm_hz: 20_000.0,
            mismatch: Mismatch::default(),
            rate_hz: 4000.0,
            substeps: 25,
            theta_m0: 0.0,
            sliding: None,
            sensorless_from_rpm: None,
            cold_start: false,
            gamma: None,
            sense_terminal_voltage: true,
            idle_steps_before: 0,
        }
    }
}

/// One control period of the trace (values at the sample instant `t`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Row {
    /// Time \[s].
    pub t: f64,
    /// Speed command \[rpm].
    pub speed_cmd_rpm: f64,
    /// True speed \[rpm].
    pub speed_rpm: f64,
    /// Estimated speed \[rpm].
    pub speed_hat_rpm: f64,
    /// True electrical angle, wrapped to (−180°, 180°] \[deg].
    pub theta_e_deg: f64,
    /// Estimated electrical angle, wrapped \[deg].
    pub theta_e_hat_deg: f64,
    /// True-frame d current \[A].
    pub i_d: f64,
    /// True-frame q current \[A].
    pub i_q: f64,
    /// Applied α voltage over the following period \[V].
    pub v_alpha: f64,
    /// Applied β voltage \[V].
    pub v_beta: f64,
    /// Load torque \[N·m].
    pub load_nm: f64,
    /// Estimated load torque \[N·m], if the observer has one.
    pub load_hat_nm: Option<f64>,
    /// Sliding observers: `S_a = î_a − i_a` \[A] (Horng Figs 9, 10).
    pub s_a: Option<f64>,
    /// Sliding observers: the sliding gain in use \[A/s].
    pub ks: Option<f64>,
    /// Sliding observers: the lower bound K_s,min of eq (28) from the true and estimated
    /// states \[A/s] (Horng Figs 7, 8).
    pub ks_min: Option<f64>,
    /// Drive scenarios: the drive's mode.
    pub mode: Option<Mode>,
    /// Drive scenarios: the monitor observer's angle [deg, electrical, wrapped].
    pub theta_e_monitor_deg: Option<f64>,
    /// The controller ran on its observer's estimate (the drive in `Sensorless`; a bare run
    /// after its hand-over from the encoder; never for the encoder itself).
    pub sensorless: bool,
    /// Drive runs: which observer drives, and each one's residual (`Observer::residual`).
    pub health: Option<RowHealth>,
    /// Drive runs: the transition this step made.
    pub transition: Option<Transition>,
}

/// The drive's health figures of one row.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RowHealth {
    /// Which observer drives.
    pub driving: Role,
    /// The primary's residual (1: the edge of lock).
    pub residual_primary: f64,
    /// The monitor's residual.
    pub residual_monitor: f64,
    /// The drive's adapted stator resistance \[Ω] (0 before the first enable).
    pub r_ohm: f64,
    /// The drive's adapted flux linkage \[Wb].
    pub flux_wb: f64,
    /// The current loop's voltage was at its limit in the last millisecond.
    pub voltage_limited: bool,
}

impl Row {
    /// `θ̂_e − θ_e` wrapped to (−180°, 180°] \[deg].
    pub fn theta_err_deg(&self) -> f64 {
        wrap_deg(self.theta_e_hat_deg - self.theta_e_deg)
    }

    /// `ω_m − command` \[rpm].
    pub fn speed_err_rpm(&self) -> f64 {
        self.speed_rpm - self.speed_cmd_rpm
    }
}

/// Wraps `x` to (−period/2, period/2].
fn wrap(x: f64, period: f64) -> f64 {
    let y = x - period * (x / period).round();
    if y <= -0.5 * period {
        y + period
    } else {
        y
    }
}

/// Wraps an angle to (−180°, 180°].
pub fn wrap_deg(x: f64) -> f64 {
    wrap(x, 360.0)
}

/// Wraps an angle to (−π, π].
pub fn wrap_rad(x: f64) -> f64 {
    wrap(x, 2.0 * PI)
}

/// A finished run.
pub struct Run {
    /// The configuration it ran with.
    pub config: SimConfig,
    /// One row per control period.
    pub rows: Vec<Row>,
    /// The plant at the end (energy integrals included).
    pub plant: Plant,
    /// Why the run stopped early (plant not finite) or the drive's fault, if any.
    pub fault: Option<String>,
    /// Drive scenarios: every mode change with its time \[s].
    pub transitions: Vec<(f64, Transition)>,
    /// Drive scenarios: steps from the fault's cause to PWM off.
    pub fault_step: Option<usize>,
    /// Drive scenarios: the drive's latched fault, if any.
    pub drive_fault: Option<Fault>,
    /// Wall-clock time of the simulation \[s] (a measurement, for the real-time factor).
    pub wall_s: f64,
}

/// What computes the duties.
enum Controller {
    /// FOC on one observer (the papers' experiments).
    Bare(Box<Bare>),
    /// The complete drive of the core.
    Drive {
        drive: Box<dyn SimDrive>,
        limits: Limits,
    },
}

/// The core's drive and its state, whatever its observers.
trait SimDrive {
    /// [`Drive::step`].
    fn step(&mut self, input: &DriveInput, cmd: &Command) -> DriveOutput;
    /// [`Drive::tick`] when it is due after the last step (once a millisecond).
    fn tick(&mut self, cmd: &Command) -> Option<Transition>;
    /// [`Drive::telemetry`].
    fn telemetry(&self) -> Telemetry;
    /// The voltage the last step's duties apply \[V].
    fn v_ab_applied(&self) -> AlphaBeta;
    /// The current sensors' offsets the drive measured [A, αβ].
    fn offset_ab(&self) -> AlphaBeta;
}

struct Running<P: Observer, M: Observer> {
    drive: Drive<P, M>,
    state: StateOf<P, M>,
}

impl<P: Observer, M: Observer> SimDrive for Running<P, M> {
    fn step(&mut self, input: &DriveInput, cmd: &Command) -> DriveOutput {
        self.drive.step(&mut self.state, input, cmd)
    }
    fn tick(&mut self, cmd: &Command) -> Option<Transition> {
        if self.state.tick_due() {
            self.drive.tick(&mut self.state, cmd)
        } else {
            None
        }
    }
    fn telemetry(&self) -> Telemetry {
        self.drive.telemetry(&self.state)
    }
    fn v_ab_applied(&self) -> AlphaBeta {
        self.state.v_ab_applied()
    }
    fn offset_ab(&self) -> AlphaBeta {
        self.state.offset_ab()
    }
}

/// The drive with `drive`'s observers, idle.
fn running<P: Observer + 'static, M: Observer + 'static>(drive: Drive<P, M>) -> Box<dyn SimDrive> {
    Box::new(Running {
        drive,
        state: StateOf::<P, M>::default(),
    })
}

/// Steps at which a fault's possible causes first appeared.
#[derive(Default)]
struct Causes {
    injection: Option<usize>,
    over_trip: Option<usize>,
    bus_out: Option<usize>,
    fault: Option<(usize, Fault)>,
}

/// The closed loop, one control period at a time.
pub struct Sim {
    config: SimConfig,
    controller: Controller,
    plant: Plant,
    inverter: Inverter,
    sensor: CurrentSensor,
    v_ab_last: AlphaBeta,
    /// The terminal voltage of the period that just ended (the plant's with the PWM off, the
    /// commanded one with it on) \[V].
    v_terminal: AlphaBeta,
    k: usize,
    ts: f64,
    /// The offsets the board takes off its samples (the drive's, after the idle pre-roll)
    /// [A, per phase].
    board_offset: pmsm_sensorless::frames::Abc,
    transitions: Vec<(f64, Transition)>,
    causes: Causes,
}

impl Sim {
    /// Builds plant, sensor, observer and controller; errors name the bad setting.
    pub fn new(config: SimConfig) -> anyhow::Result<Self> {
        let sc = &config.scenario;
        anyhow::ensure!(
            config.bus_v.is_finite() && config.bus_v > 0.0,
            "bus voltage must be a finite number > 0 V, got {}",
            config.bus_v
        );
        anyhow::ensure!(
            config.rate_hz.is_finite() && config.rate_hz > 0.0,
            "rate must be > 0 Hz"
        );
        anyhow::ensure!(config.substeps > 0, "substeps must be > 0");
        let params = sc.motor.params;
        let controller_motor = config
            .mismatch
            .apply(&params)
            .map_err(|e| anyhow::anyhow!("controller motor parameters: {e}"))?;
        let controller = if sc.drive.is_some() {
            let motor = Motor {
                params: controller_motor,
                ..sc.motor
            };
            let mut cfg = DriveConfig::new(&motor);
            cfg.rate_hz = config.rate_hz as f32;
            // The board's figures as the user configures them: the plant's own (an ideal
            // plant, dead time 0, gets no compensation).
            cfg.power_stage.pwm_hz = config.pwm_hz as f32;
            cfg.power_stage.dead_time_s = config.dead_time_s as f32;
            let err = |e| anyhow::anyhow!("drive configuration: {e}");
            let drive = match config.observer {
                ObserverKind::SlidingTorque => running(cfg.build_sliding_primary().map_err(err)?),
                ObserverKind::Flux => running(cfg.build_flux_primary().map_err(err)?),
                other => anyhow::bail!(
                    "drive scenarios run with --observer sliding-torque or flux, not '{}'",
                    other.name()
                ),
            };
            Controller::Drive {
                drive,
                limits: cfg.limits,
            }
        } else {
            let mut foc_cfg = FocConfig::new(controller_motor, sc.i_max_a() as f32);
            foc_cfg.current_rate_hz = config.rate_hz as f32;
            // The plant's dead time compensated, as the drive does (the drive's smooth-sign
            // band: 5 % of the rated-torque current).
            let band_a = DriveConfig::new(&sc.motor).power_stage.dead_time_band_a;
            foc_cfg.dead_time = DeadTimeConfig {
                dead_time_s: config.dead_time_s as f32,
                pwm_hz: config.pwm_hz as f32,
                band_a,
            };
            let foc = foc_cfg
                .build()
                .map_err(|e| anyhow::anyhow!("controller configuration: {e}"))?;
            let mut bare = config.observer.bare(
                &ObserverSetup {
                    motor: controller_motor,
                    rate_hz: config.rate_hz as f32,
                    sliding: config.sliding,
                    min_speed_rpm: sc.min_speed_rpm as f32,
                    gamma: config.gamma,
                },
                foc,
            )?;
            if config.cold_start {
                bare.start_cold();
            }
            Controller::Bare(Box::new(bare))
        };
        let sensor = CurrentSensor::new(
            config.offset_a,
            config.noise_sigma_a,
            config.adc_lsb_a,
            config.seed,
        )?;
        let mut plant = Plant::new(
            PlantParams::from(&params),
            config.theta_m0,
            sc.initial_speed_rpm * RAD_S_PER_RPM,
        );
        plant.locked = sc.locked_rotor;
        Ok(Self {
            controller,
            plant,
            inverter: Inverter {
                v_bus: config.bus_v,
                dead_time_s: config.dead_time_s,
                pwm_hz: config.pwm_hz,
            },
            sensor,
            v_ab_last: AlphaBeta::default(),
            v_terminal: AlphaBeta::default(),
            k: 0,
            ts: 1.0 / config.rate_hz,
            board_offset: pmsm_sensorless::frames::Abc::new(0.0, 0.0, 0.0),
            transitions: Vec::new(),
            causes: Causes::default(),
            config,
        })
    }

    /// The drive's samples before t = 0 (`SimConfig::idle_steps_before`): disabled, PWM off,
    /// the plant sampled as it is.
    fn idle_before(&mut self) {
        let Controller::Drive { drive, .. } = &mut self.controller else {
            return;
        };
        let off = Command::default();
        for _ in 0..self.config.idle_steps_before {
            let i_abc = self.sensor.measure(self.plant.i_abc());
            drive.step(
                &DriveInput {
                    i_abc,
                    v_bus: self.inverter.v_bus as f32,
                    v_ab_terminal: None,
                    overrun: false,
                },
                &off,
            );
            drive.tick(&off);
        }
        if self.config.idle_steps_before > 0 {
            self.board_offset = drive.offset_ab().to_abc();
        }
    }

    /// Time of the next sample \[s].
    pub fn t(&self) -> f64 {
        self.k as f64 * self.ts
    }

    /// The plant (state, energy integrals, parameters).
    pub fn plant(&self) -> &Plant {
        &self.plant
    }

    /// Applies the scenario's injection when its time comes; returns whether the phase-b
    /// current sample is to read NaN.
    fn inject(&mut self, t: f64) -> bool {
        let Some(inj) = self
            .config
            .scenario
            .drive
            .as_ref()
            .and_then(|d| d.injection)
        else {
            return false;
        };
        if t + 0.5 * self.ts < inj.t() {
            return false;
        }
        let first = self.causes.injection.is_none();
        if first {
            self.causes.injection = Some(self.k);
        }
        match inj {
            Injection::Plant { r, l, flux, .. } if first => {
                let p = &mut self.plant.params;
                p.r *= r;
                p.l *= l;
                p.flux *= flux;
                false
            }
            Injection::Bus { v, .. } => {
                self.inverter.v_bus = v;
                false
            }
            Injection::NanCurrent { .. } => true,
            Injection::Plant { .. } => false,
        }
    }

    /// One control period: sample, estimate, control, then integrate the plant over the
    /// period. Errors if the plant state stops being finite.
    pub fn step(&mut self) -> Result<Row, String> {
        let t = self.t();
        let nan_current = self.inject(t);
        let p = self.plant.params;
        let theta_e = wrap_rad(self.plant.state.theta_e(&p));
        let omega_m = self.plant.state.omega_m;
        let mut i_abc = self.sensor.measure(self.plant.i_abc());
        let o = self.board_offset;
        i_abc = pmsm_sensorless::frames::Abc::new(i_abc.a - o.a, i_abc.b - o.b, i_abc.c - o.c);
        if nan_current {
            i_abc.b = f32::NAN;
        }
        let v_bus = self.inverter.v_bus;
        let speed_cmd_rpm = self.config.scenario.speed_cmd_rpm.at(t);
        let (mut health, mut transition) = (None, None);
        let (duties, est, mode, monitor) = match &mut self.controller {
            Controller::Bare(bare) => {
                let (out, est) = bare.step(&BareInput {
                    i_abc,
                    v_bus: v_bus as f32,
                    v_ab_last: self.v_ab_last,
                    truth: Rotor {
                        theta_e: theta_e as f32,
                        omega_m: omega_m as f32,
                        load_nm: 0.0,
                    },
                    omega_m_ref: (speed_cmd_rpm * RAD_S_PER_RPM) as f32,
                    sensorless_from: (self.config.sensorless_from_rpm.unwrap_or(0.0)
                        * RAD_S_PER_RPM) as f32,
                });
                self.v_ab_last = out.v_ab;
                (Some(out.duties), est, None, None)
            }
            Controller::Drive { drive, limits } => {
                let script = self.config.scenario.drive.as_ref();
                let cmd = Command {
                    enable: script.is_some_and(|d| d.enable_at(t + 0.5 * self.ts)),
                    speed_rpm: speed_cmd_rpm as f32,
                    clear_fault: false,
                };
                let i_peak = i_abc.a.abs().max(i_abc.b.abs()).max(i_abc.c.abs());
                if i_peak > limits.i_trip_a {
                    self.causes.over_trip.get_or_insert(self.k);
                }
                let bus = v_bus as f32;
                if !(limits.bus_min_v..=limits.bus_max_v).contains(&bus) {
                    self.causes.bus_out.get_or_insert(self.k);
                }
                let out = drive.step(
                    &DriveInput {
                        i_abc,
                        v_bus: bus,
                        v_ab_terminal: self
                            .config
                            .sense_terminal_voltage
                            .then_some(self.v_terminal),
                        overrun: false,
                    },
                    &cmd,
                );
                // The step, then the 1 kHz task when due (as a board runs it after the
                // interrupt).
                for tr in [out.transition, drive.tick(&cmd)].into_iter().flatten() {
                    transition = Some(tr);
                    self.transitions.push((t, tr));
                    if let Reason::Fault(f) = tr.reason {
                        self.causes.fault.get_or_insert((self.k, f));
                    }
                }
                let tel = drive.telemetry();
                health = Some(RowHealth {
                    driving: tel.driving,
                    residual_primary: tel.residual_primary as f64,
                    residual_monitor: tel.residual_monitor as f64,
                    r_ohm: tel.r_ohm as f64,
                    flux_wb: tel.flux_wb as f64,
                    voltage_limited: tel.voltage_limited,
                });
                // The angle the controller runs on: the driving observer's while sensorless.
                let sensorless = tel.mode == Mode::Sensorless;
                let est = Estimate {
                    theta_e: if sensorless {
                        tel.theta_e_control
                    } else {
                        tel.theta_e_primary
                    },
                    omega_m: tel.speed_rpm * pmsm_sensorless::units::RAD_S_PER_RPM,
                    load_nm: tel.load_nm,
                    sliding: None,
                    sensorless,
                };
                self.v_ab_last = drive.v_ab_applied();
                let monitor = (tel.theta_e_monitor as f64).to_degrees();
                (out.duties, est, Some(tel.mode), Some(monitor))
            }
        };
        let sc = &self.config.scenario;
        let (i_d, i_q) = self.plant.state.i_dq(&p);
        let v_ab = if duties.is_some() {
            self.v_ab_last
        } else {
            AlphaBeta::default()
        };
        let row = Row {
            t,
            speed_cmd_rpm,
            speed_rpm: omega_m / RAD_S_PER_RPM,
            speed_hat_rpm: est.omega_m as f64 / RAD_S_PER_RPM,
            theta_e_deg: theta_e.to_degrees(),
            theta_e_hat_deg: wrap_deg((est.theta_e as f64).to_degrees()),
            i_d,
            i_q,
            v_alpha: v_ab.alpha as f64,
            v_beta: v_ab.beta as f64,
            load_nm: sc.load_at(t, omega_m),
            load_hat_nm: est.load_nm.map(f64::from),
            s_a: est.sliding.map(|d| d.s_ab.alpha as f64),
            ks: est.sliding.map(|d| d.ks as f64),
            ks_min: est.sliding.map(|_| {
                ks_min(
                    (p.flux * p.n / p.l) as f32,
                    est.omega_m,
                    est.theta_e,
                    omega_m as f32,
                    theta_e as f32,
                ) as f64
            }),
            mode,
            theta_e_monitor_deg: monitor,
            sensorless: est.sensorless,
            health,
            transition,
        };
        let n_sub = self.config.substeps;
        let h = self.ts / n_sub as f64;
        let load = |dt: f64, w: f64| sc.load_at(t + dt, w);
        self.v_terminal = match duties {
            Some(d) => {
                self.plant.advance(&self.inverter.hold(d), load, h, n_sub);
                self.v_ab_last
            }
            None => {
                // All switches off: the currents flow through the freewheeling diodes into
                // the bus until they die out, and a back-EMF above the bus brakes the rotor.
                let bridge = DiodeBridge {
                    v_bus: self.inverter.v_bus,
                };
                let v = self.plant.advance_off(&bridge, load, h, n_sub);
                AlphaBeta::new(v.0 as f32, v.1 as f32)
            }
        };
        self.k += 1;
        let s = &self.plant.state;
        if [s.i_alpha, s.i_beta, s.theta_m, s.omega_m]
            .iter()
            .all(|x| x.is_finite())
        {
            Ok(row)
        } else {
            Err(format!("plant state not finite at t = {:.4} s", self.t()))
        }
    }

    /// Steps from the cause of the drive's fault to PWM off: from the first sample beyond
    /// the trip level (overcurrent), outside the bus limits (bus faults), or from the
    /// injection (others).
    fn fault_step(&self) -> Option<usize> {
        let (k, f) = self.causes.fault?;
        let cause = match f {
            Fault::Overcurrent => self.causes.over_trip,
            Fault::BusUndervoltage | Fault::BusOvervoltage => self.causes.bus_out,
            _ => self.causes.injection,
        }?;
        Some(k.saturating_sub(cause))
    }

    /// The drive's latched fault, if any.
    fn drive_fault(&self) -> Option<Fault> {
        self.causes.fault.map(|(_, f)| f)
    }
}

/// Snake-case name of a drive fault, as in the JSON summary.
pub fn fault_name(f: Fault) -> &'static str {
    match f {
        Fault::Overcurrent => "overcurrent",
        Fault::BusUndervoltage => "bus_undervoltage",
        Fault::BusOvervoltage => "bus_overvoltage",
        Fault::InvalidInput => "invalid_input",
        Fault::ObserverLoss => "observer_loss",
        Fault::Stall => "stall",
        Fault::Overrun => "overrun",
        Fault::AdcOffset => "adc_offset",
        Fault::Identify(e) => crate::identify::error_name(e),
    }
}

/// Runs the closed loop for the scenario's duration.
pub fn run(config: SimConfig) -> anyhow::Result<Run> {
    let wall = std::time::Instant::now();
    let mut sim = Sim::new(config)?;
    sim.idle_before();
    let steps = (sim.config.scenario.duration_s * sim.config.rate_hz).round() as usize;
    let mut rows = Vec::with_capacity(steps);
    let mut fault = None;
    for _ in 0..steps {
        match sim.step() {
            Ok(row) => rows.push(row),
            Err(e) => {
                fault = Some(e);
                break;
            }
        }
    }
    let fault_step = sim.fault_step();
    let drive_fault = sim.drive_fault();
    let fault = fault.or_else(|| drive_fault.map(|f| fault_name(f).to_string()));
    Ok(Run {
        rows,
        plant: sim.plant,
        fault,
        transitions: sim.transitions,
        fault_step,
        drive_fault,
        wall_s: wall.elapsed().as_secs_f64(),
        config: sim.config,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapping_is_half_open() {
        assert_eq!(wrap_deg(180.0), 180.0);
        assert_eq!(wrap_deg(-180.0), 180.0);
        assert_eq!(wrap_deg(540.0), 180.0);
        assert!((wrap_deg(-190.0) - 170.0).abs() < 1e-12);
        assert!((wrap_rad(3.0 * PI) - PI).abs() < 1e-12);
        assert!((wrap_rad(-0.5) + 0.5).abs() < 1e-15);
    }
}
