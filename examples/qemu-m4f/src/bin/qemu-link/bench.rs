//! The plant the link firmware drives: the simulator's (`pmsm-plant`, host-sim's: the
//! papers' motor in f64, RK4) with the Sinano motor of Horng & Chin's Table 1 behind an
//! ideal inverter on a stiff 48 V bus, no load; the same bench as `qemu-m4f`'s (src/main.rs),
//! run for as long as the firmware runs, whatever drive the link configures: the motor is the
//! bench's, the drive's settings the user's.

use pmsm_plant::{Inverter, Plant, PlantParams, StiffBus};
use pmsm_sensorless::drive::DriveInput;
use pmsm_sensorless::frames::Abc;
use pmsm_sensorless::motor::HORNG_SINANO;
use pmsm_sensorless::power_stage::PowerStage;
use pmsm_sensorless::svpwm::Duties;
use pmsm_sensorless::units::RAD_S_PER_RPM;

/// RK4 sub-steps of the plant per control period.
const SUBSTEPS: usize = 10;
const BUS_V: f64 = 48.0;

/// The plant as the drive's power stage.
pub struct Bench {
    plant: Plant,
    inverter: Inverter,
    /// The duties held over the coming period (`None`: all switches off).
    duties: Option<Duties>,
    /// The control period \[s].
    h_s: f64,
}

impl Bench {
    /// The rotor at rest, 0.3 rad (electrical) from the align axis; control at `rate_hz`.
    pub fn new(rate_hz: f32) -> Self {
        let params = PlantParams::from(&HORNG_SINANO.params);
        Bench {
            plant: Plant::new(params, StiffBus { v_bus: BUS_V }, 0.3 / params.n, 0.0),
            inverter: Inverter {
                dead_time_s: 0.0,
                pwm_hz: 20_000.0,
            },
            duties: None,
            h_s: 1.0 / f64::from(rate_hz),
        }
    }

    /// The control period follows a rebuilt drive's rate \[Hz] (the plant keeps its state).
    pub fn set_rate(&mut self, rate_hz: f32) {
        self.h_s = 1.0 / f64::from(rate_hz);
    }

    /// One control period with the duties held.
    pub fn advance(&mut self) {
        let no_load = |_: f64, _: f64| 0.0;
        let h = self.h_s / SUBSTEPS as f64;
        match self.duties {
            Some(d) => self
                .plant
                .advance(&self.inverter.hold(d), no_load, h, SUBSTEPS),
            None => self.plant.advance_off(no_load, h, SUBSTEPS),
        };
    }

    /// The rotor's speed \[rpm, mechanical].
    pub fn speed_rpm(&self) -> f32 {
        (self.plant.state.omega_m as f32) / RAD_S_PER_RPM
    }
}

impl PowerStage for Bench {
    fn sample(&mut self) -> DriveInput {
        let i = self.plant.i_abc();
        DriveInput {
            i_abc: Abc::new(i[0] as f32, i[1] as f32, i[2] as f32),
            v_bus: BUS_V as f32,
            v_ab_terminal: None,
            overrun: false,
            stage_fault: None,
        }
    }

    fn apply(&mut self, duties: Option<Duties>) {
        self.duties = duties;
    }
}
