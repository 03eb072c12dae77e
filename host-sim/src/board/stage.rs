//! The simulated board around the plant as the core's `PowerStage`: `sample()` reads its
//! sensors, `apply()` loads the duties, and [`BoardStage::advance`] lets the plant run the
//! control period with them, as a firmware's interrupt samples, steps the drive (the
//! core's `control::Control`) and leaves the PWM running until the next.

use super::bus::BoardBus;
use super::motor_fault::{Faulty, MotorFault};
use super::sensors::{CurrentSensor, SensorFault, VoltageSensors};
use super::SimBoard;
use pmsm_plant::{Inverter, Load, Plant, PlantParams, ShortCircuit, Supply};
use pmsm_sensorless::drive::DriveInput;
use pmsm_sensorless::frames::{Abc, AlphaBeta};
use pmsm_sensorless::power_stage::PowerStage;
use pmsm_sensorless::svpwm::Duties;

/// The plant on the board's bus.
pub type BoardPlant = Plant<BoardBus>;

/// The board around the plant: its inverter on its bus, its sensors, the duties loaded.
pub struct BoardStage {
    plant: BoardPlant,
    inverter: Inverter,
    current: CurrentSensor,
    voltage: VoltageSensors,
    /// The offsets the board takes off its current samples (the drive's, after the idle
    /// pre-roll) [A, per phase].
    offset_abc: Abc,
    /// Phase b's current sample reads NaN (a broken channel).
    nan_phase_b: bool,
    motor_fault: Option<MotorFault>,
    /// The duties loaded for the coming period (`None`: every switch off).
    duties: Option<Duties>,
    /// Every low-side switch on for the coming period (the active short circuit), instead of
    /// `duties`.
    short_circuit: bool,
    /// The duties in effect at the end of the last period: with an update delay, the
    /// coming period's first part.
    in_effect: Option<Duties>,
    /// The time from a sample to its duties taking effect \[s] ([`SimBoard::update_delay_s`]).
    update_delay_s: f64,
    /// The terminal voltage of the period that just ended \[V].
    v_terminal: AlphaBeta,
    /// The last sample taken.
    last: Option<DriveInput>,
}

impl BoardStage {
    /// `board` around a plant of `params` on its bus, rotor at `theta_m0` [rad, mechanical]
    /// turning at `omega_m0` \[rad/s], every switch off. Errors name a bad sensor setting.
    pub fn new(
        board: &SimBoard,
        params: PlantParams,
        theta_m0: f64,
        omega_m0: f64,
    ) -> anyhow::Result<Self> {
        let current = CurrentSensor::new(
            board.offset_a,
            board.noise_sigma_a,
            board.adc_lsb_a,
            board.seed,
        )?;
        board.check_bus()?;
        Ok(Self {
            plant: Plant::new(params, board.bus(), theta_m0, omega_m0),
            inverter: Inverter {
                dead_time_s: board.dead_time_s,
                pwm_hz: board.pwm_hz,
            },
            current,
            voltage: VoltageSensors {
                terminal: board.sense_terminal_voltage,
            },
            offset_abc: Abc::new(0.0, 0.0, 0.0),
            nan_phase_b: false,
            motor_fault: None,
            duties: None,
            short_circuit: false,
            in_effect: None,
            update_delay_s: board.update_delay_s,
            v_terminal: AlphaBeta::default(),
            last: None,
        })
    }

    /// The plant (state, energy integrals, parameters).
    pub fn plant(&self) -> &BoardPlant {
        &self.plant
    }

    /// The plant, to change it (a fault injected into the motor or the bus).
    pub fn plant_mut(&mut self) -> &mut BoardPlant {
        &mut self.plant
    }

    /// The plant at the end of the run.
    pub fn into_plant(self) -> BoardPlant {
        self.plant
    }

    /// The motor on the board has `fault` (a blocked rotor blocks the plant's shaft).
    pub fn set_motor_fault(&mut self, fault: Option<MotorFault>) {
        self.motor_fault = fault;
        self.plant.blocked = fault == Some(MotorFault::BlockedRotor);
    }

    /// From now on the board takes `offset` [A, per phase] off every current sample.
    pub fn take_offsets(&mut self, offset: Abc) {
        self.offset_abc = offset;
    }

    /// From now on phase b's current sample reads NaN.
    pub fn break_phase_b(&mut self) {
        self.nan_phase_b = true;
    }

    /// From the next sample on, phase `phase`'s (0..3: a, b, c) current sensor has failed so.
    pub fn fail_current_sensor(&mut self, phase: usize, fault: SensorFault) {
        self.current.fail(phase, fault);
    }

    /// The stage holds the active short circuit (every low-side switch on).
    pub fn shorted(&self) -> bool {
        self.short_circuit
    }

    /// The duties loaded for the coming period (`None`: every switch off).
    pub fn duties(&self) -> Option<Duties> {
        self.duties
    }

    /// The last sample taken, if any.
    pub fn last_sample(&self) -> Option<&DriveInput> {
        self.last.as_ref()
    }

    /// The control period: the plant integrated over `n_sub` sub-steps of `h` seconds with
    /// the duties loaded (or every switch off: the currents flow through the freewheeling
    /// diodes into the bus until they die out, and a back-EMF above the bus brakes the
    /// rotor), under the load torque `tau_l(t_rel, ω)`. The terminal voltage sensed next is
    /// this period's mean.
    ///
    /// With an update delay `d` ([`SimBoard::update_delay_s`], rounded to whole sub-steps),
    /// the duties in effect before (the last period's) hold for the first `d` of the period
    /// and the loaded ones from then on; switching off (`None`) is at once (the break clears
    /// the outputs without waiting for an update).
    pub fn advance(&mut self, tau_l: impl Load, h: f64, n_sub: usize) {
        let n_delay = ((self.update_delay_s / h).round() as usize).min(n_sub);
        if n_delay > 0 && self.duties.is_some() {
            let first = self.in_effect;
            let v0 = self.advance_with(first, &tau_l, 0.0, h, n_delay);
            let loaded = self.duties;
            let v1 = self.advance_with(loaded, &tau_l, n_delay as f64 * h, h, n_sub - n_delay);
            let (w0, w1) = (
                n_delay as f64 / n_sub as f64,
                (n_sub - n_delay) as f64 / n_sub as f64,
            );
            self.v_terminal = AlphaBeta::new(
                (w0 * v0.0 + w1 * v1.0) as f32,
                (w0 * v0.1 + w1 * v1.1) as f32,
            );
            self.in_effect = self.duties;
            return;
        }
        self.in_effect = self.duties;
        let v = match self.duties {
            _ if self.short_circuit => self.plant.advance(&ShortCircuit, tau_l, h, n_sub),
            Some(d) => {
                let faulty = Faulty {
                    inner: self.inverter.hold(d),
                    fault: self.motor_fault,
                    r: self.plant.params.r,
                };
                self.plant.advance(&faulty, tau_l, h, n_sub)
            }
            None => self.plant.advance_off(tau_l, h, n_sub),
        };
        self.v_terminal = AlphaBeta::new(v.0 as f32, v.1 as f32);
    }
}

impl BoardStage {
    /// `n` sub-steps of `h` with `duties` (`None`: every switch off), the load's time from
    /// `t0` into the period; the mean terminal voltage (0 V for no sub-step).
    fn advance_with(
        &mut self,
        duties: Option<Duties>,
        tau_l: &impl Load,
        t0: f64,
        h: f64,
        n: usize,
    ) -> (f64, f64) {
        if n == 0 {
            return (0.0, 0.0);
        }
        let load = |dt: f64, w: f64| tau_l(t0 + dt, w);
        match duties {
            Some(d) => {
                let faulty = Faulty {
                    inner: self.inverter.hold(d),
                    fault: self.motor_fault,
                    r: self.plant.params.r,
                };
                self.plant.advance(&faulty, load, h, n)
            }
            None => self.plant.advance_off(load, h, n),
        }
    }
}

impl PowerStage for BoardStage {
    fn sample(&mut self) -> DriveInput {
        let i = self.current.measure(self.plant.i_abc());
        let o = self.offset_abc;
        let mut i_abc = Abc::new(i.a - o.a, i.b - o.b, i.c - o.c);
        if self.nan_phase_b {
            i_abc.b = f32::NAN;
        }
        let input = DriveInput {
            i_abc,
            v_bus: self.voltage.bus(self.plant.supply.v_dc()),
            v_ab_terminal: self.voltage.terminal(self.v_terminal),
            overrun: false,
            stage_fault: None,
        };
        self.last = Some(input);
        input
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
        self.plant.supply.gate_brake(on);
    }
}
