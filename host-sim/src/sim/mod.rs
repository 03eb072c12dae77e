//! The closed loop: the scenario's commands, the controller (the complete drive, or FOC on
//! one observer), the board around the plant ([`crate::board::BoardStage`]), one control
//! period at a time; its configuration ([`SimConfig`]) and its trace ([`Row`]).
//!
//! Timing of one control period `k` (`T = 1/rate_hz`, 250 µs at 4 kHz): the currents and the
//! encoder are sampled at `t_k`, the core computes the duties at once, and the inverter holds
//! them over `[t_k, t_k + T)` while the plant is integrated with RK4 on `substeps` sub-steps.

mod config;
mod controller;
mod row;

pub use config::{Mismatch, SimConfig};
pub use row::{wrap_deg, wrap_rad, Row, RowHealth};

use crate::board::{BoardPlant, BoardStage};
use crate::identify;
use crate::names::fault_name;
use crate::scenario::Injection;
use crate::RAD_S_PER_RPM;
use controller::{Controller, Period, PeriodOut};
use pmsm_plant::{PlantParams, Supply};
use pmsm_sensorless::bounds::ks_min;
use pmsm_sensorless::drive::{Fault, Reason, Transition};
use pmsm_sensorless::frames::AlphaBeta;
use pmsm_sensorless::observer::Rotor;

/// A finished run.
pub struct Run {
    /// The configuration it ran with.
    pub config: SimConfig,
    /// One row per control period.
    pub rows: Vec<Row>,
    /// The plant at the end (energy integrals included).
    pub plant: BoardPlant,
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

/// Steps at which a fault's possible causes first appeared.
#[derive(Default)]
struct Causes {
    injection: Option<usize>,
    over_trip: Option<usize>,
    bus_out: Option<usize>,
    fault: Option<(usize, Fault)>,
}

/// The true rotor at a sample.
#[derive(Clone, Copy)]
struct Truth {
    /// The plant's parameters (after any injection).
    params: PlantParams,
    /// Electrical angle, wrapped \[rad].
    theta_e: f64,
    /// Speed, mechanical \[rad/s].
    omega_m: f64,
}

/// The closed loop, one control period at a time.
pub struct Sim {
    config: SimConfig,
    controller: Controller,
    stage: BoardStage,
    k: usize,
    ts: f64,
    transitions: Vec<(f64, Transition)>,
    causes: Causes,
    /// A plant injection's R and flux at its start (`Injection::Plant`).
    plant_base: Option<(f64, f64)>,
}

impl Sim {
    /// Builds plant, board, observer and controller; errors name the bad setting.
    pub fn new(config: SimConfig) -> anyhow::Result<Self> {
        config.board.check_bus()?;
        anyhow::ensure!(
            config.rate_hz.is_finite() && config.rate_hz > 0.0,
            "rate must be > 0 Hz"
        );
        anyhow::ensure!(config.substeps > 0, "substeps must be > 0");
        let controller = Controller::new(&config)?;
        let sc = &config.scenario;
        let mut stage = BoardStage::new(
            &config.board,
            PlantParams::with_inductances(&sc.motor.params, config.plant_inductances.as_ref()),
            config.theta_m0,
            sc.initial_speed_rpm * RAD_S_PER_RPM,
        )?;
        stage.plant_mut().blocked = sc.locked_rotor;
        Ok(Self {
            controller,
            stage,
            k: 0,
            ts: 1.0 / config.rate_hz,
            transitions: Vec::new(),
            causes: Causes::default(),
            plant_base: None,
            config,
        })
    }

    /// Time of the next sample \[s].
    pub fn t(&self) -> f64 {
        self.k as f64 * self.ts
    }

    /// The plant (state, energy integrals, parameters).
    pub fn plant(&self) -> &BoardPlant {
        self.stage.plant()
    }

    /// Applies the scenario's injection when its time comes.
    fn inject(&mut self, t: f64) {
        let Some(inj) = self
            .config
            .scenario
            .drive
            .as_ref()
            .and_then(|d| d.injection)
        else {
            return;
        };
        if t + 0.5 * self.ts < inj.t() {
            return;
        }
        let first = self.causes.injection.is_none();
        if first {
            self.causes.injection = Some(self.k);
        }
        let back = self.config.board.bus_v;
        let half = 0.5 * self.ts;
        let plant = self.stage.plant_mut();
        match inj {
            Injection::Plant { l, .. } => {
                // R and flux from the plant's values at its start (kept at the first step),
                // stepped or gradually (`until`); L at once.
                let base = *self
                    .plant_base
                    .get_or_insert((plant.params.r, plant.params.flux));
                if first {
                    plant.params.scale_l(l);
                }
                let (r, flux) = inj.plant_factors_at(t + half).unwrap_or((1.0, 1.0));
                plant.params.r = base.0 * r;
                plant.params.flux = base.1 * flux;
            }
            Injection::Bus { v, until, .. } => {
                let recovered = until.is_some_and(|u| t + half >= u);
                plant.supply.set_supply_v(if recovered { back } else { v });
            }
            Injection::NanCurrent { .. } => self.stage.break_phase_b(),
            Injection::CurrentSensor { phase, fault, .. } if first => {
                self.stage.fail_current_sensor(phase, fault);
            }
            // The controller stops ticking (`Sim::step`).
            Injection::TaskStall { .. } | Injection::CurrentSensor { .. } => {}
        }
    }

    /// One control period: sample, estimate, control, then integrate the plant over the
    /// period. Errors if the plant state stops being finite.
    pub fn step(&mut self) -> Result<Row, String> {
        let t = self.t();
        self.inject(t);
        let truth = self.truth();
        let sc = &self.config.scenario;
        // From an injected task stall on (`inject` has seen its time), the step alone.
        let task_stalled = self.causes.injection.is_some()
            && sc
                .drive
                .as_ref()
                .is_some_and(|d| matches!(d.injection, Some(Injection::TaskStall { .. })));
        let period = Period {
            speed_cmd_rpm: sc.speed_cmd_rpm.at(t),
            enable: sc
                .drive
                .as_ref()
                .is_some_and(|d| d.enable_at(t + 0.5 * self.ts)),
            clear_fault: sc
                .drive
                .as_ref()
                .is_some_and(|d| d.clear_fault_in(t, self.ts)),
            truth: Rotor {
                theta_e: truth.theta_e as f32,
                omega_m: truth.omega_m as f32,
                load_nm: 0.0,
            },
            sensorless_from: (self.config.sensorless_from_rpm.unwrap_or(0.0) * RAD_S_PER_RPM)
                as f32,
            task_stalled,
        };
        let control = self.controller.step(&mut self.stage, &period);
        self.record(t, &control);
        let row = self.row(t, period.speed_cmd_rpm, &truth, &control);
        self.advance(t);
        self.k += 1;
        let s = &self.stage.plant().state;
        if [s.i_alpha, s.i_beta, s.theta_m, s.omega_m]
            .iter()
            .all(|x| x.is_finite())
        {
            Ok(row)
        } else {
            Err(format!("plant state not finite at t = {:.4} s", self.t()))
        }
    }

    /// The plant's rotor at the sample.
    fn truth(&self) -> Truth {
        let p = self.stage.plant();
        Truth {
            params: p.params,
            theta_e: wrap_rad(p.state.theta_e(&p.params)),
            omega_m: p.state.omega_m,
        }
    }

    /// Drive runs: the step's transitions with their time, and the first step of each
    /// possible cause of a fault (a sample beyond the trip level, a bus outside the limits,
    /// the fault itself).
    fn record(&mut self, t: f64, control: &PeriodOut) {
        let (Some(limits), Some(input)) = (self.controller.limits(), self.stage.last_sample())
        else {
            return;
        };
        let i = input.i_abc;
        if i.a.abs().max(i.b.abs()).max(i.c.abs()) > limits.i_trip_a {
            self.causes.over_trip.get_or_insert(self.k);
        }
        if !(limits.bus_min_v..=limits.bus_max_v).contains(&input.v_bus) {
            self.causes.bus_out.get_or_insert(self.k);
        }
        for tr in control.transitions.into_iter().flatten() {
            self.transitions.push((t, tr));
            if let Reason::Fault(f) = tr.reason {
                self.causes.fault.get_or_insert((self.k, f));
            }
        }
    }

    /// The trace's row of the sample at `t`.
    fn row(&self, t: f64, speed_cmd_rpm: f64, truth: &Truth, control: &PeriodOut) -> Row {
        let (p, est) = (&truth.params, &control.est);
        let (i_d, i_q) = self.stage.plant().state.i_dq(p);
        let v_ab = if self.stage.duties().is_some() {
            control.v_ab
        } else {
            AlphaBeta::default()
        };
        let (mode, monitor, health) = match control.drive {
            Some((mode, monitor, health)) => (Some(mode), Some(monitor), Some(health)),
            None => (None, None, None),
        };
        Row {
            t,
            speed_cmd_rpm,
            speed_rpm: truth.omega_m / RAD_S_PER_RPM,
            speed_hat_rpm: est.omega_m as f64 / RAD_S_PER_RPM,
            theta_e_deg: truth.theta_e.to_degrees(),
            theta_e_hat_deg: wrap_deg((est.theta_e as f64).to_degrees()),
            i_d,
            i_q,
            v_alpha: v_ab.alpha as f64,
            v_beta: v_ab.beta as f64,
            load_nm: self.config.scenario.load_at(t, truth.omega_m),
            v_bus: self.stage.plant().supply.v_dc(),
            load_hat_nm: est.load_nm.map(f64::from),
            s_a: est.sliding.map(|d| d.s_ab.alpha as f64),
            ks: est.sliding.map(|d| d.ks as f64),
            ks_min: est.sliding.map(|_| {
                ks_min(
                    (p.flux * p.n / p.inductances().non_salient_l_h()) as f32,
                    est.omega_m,
                    est.theta_e,
                    truth.omega_m as f32,
                    truth.theta_e as f32,
                ) as f64
            }),
            mode,
            theta_e_monitor_deg: monitor,
            sensorless: est.sensorless,
            health,
            transition: control.transitions.into_iter().flatten().last(),
        }
    }

    /// The plant over the period from `t` with the duties loaded, under the scenario's load.
    fn advance(&mut self, t: f64) {
        let sc = &self.config.scenario;
        let n_sub = self.config.substeps;
        let h = self.ts / n_sub as f64;
        self.stage
            .advance(|dt: f64, w: f64| sc.load_at(t + dt, w), h, n_sub);
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
}

/// The drive's model from an identification of the scenario's motor on the run's board
/// ([`SimConfig::identify_first`]); an identification that ends in a fault is the run's error,
/// named.
fn identified(mut config: SimConfig) -> anyhow::Result<SimConfig> {
    let truth = config.scenario.motor;
    let outcome = identify::run(&identify::IdentifyRun {
        board: config.board.clone(),
        inductances: config.plant_inductances,
        ..identify::IdentifyRun::board_defaults(truth)
    })?;
    let Some(m) = identify::identified_motor(&outcome)? else {
        anyhow::bail!(
            "identification ended in {} after {:.2} s",
            outcome.fault.map_or("no result", fault_name),
            outcome.duration_s
        );
    };
    config.mismatch = Mismatch::between(&truth.params, &m.params);
    Ok(config)
}

/// Runs the closed loop for the scenario's duration (after the board's idle time), after an
/// identification where the configuration asks for one.
pub fn run(config: SimConfig) -> anyhow::Result<Run> {
    let wall = std::time::Instant::now();
    let config = if config.identify_first {
        identified(config)?
    } else {
        config
    };
    let mut sim = Sim::new(config)?;
    let idle_steps = sim.config.board.idle_steps(sim.config.rate_hz);
    sim.controller.idle(&mut sim.stage, idle_steps);
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
    let drive_fault = sim.causes.fault.map(|(_, f)| f);
    let fault = fault.or_else(|| drive_fault.map(|f| fault_name(f).to_string()));
    Ok(Run {
        rows,
        plant: sim.stage.into_plant(),
        fault,
        transitions: sim.transitions,
        fault_step,
        drive_fault,
        wall_s: wall.elapsed().as_secs_f64(),
        config: sim.config,
    })
}
