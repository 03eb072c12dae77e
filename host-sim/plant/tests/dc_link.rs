//! The DC-link current the converter draws balances the power the windings take: on a stiff
//! bus the charge drawn times the bus voltage is the electrical energy in, driving and
//! braking (through the diodes, when the charge goes back into the bus).

use pmsm_plant::{Inverter, Plant, PlantParams, StiffBus, Supply};
use pmsm_sensorless::motor::HORNG_SINANO;
use pmsm_sensorless::svpwm::Duties;

const BUS_V: f64 = 48.0;

/// A bus that records the current it gave.
#[derive(Default)]
struct Metered {
    charge_c: f64,
}

impl Supply for Metered {
    fn v_dc(&self) -> f64 {
        BUS_V
    }
    fn draw(&mut self, i_dc: f64, h: f64) {
        self.charge_c += i_dc * h;
    }
}

fn sinano() -> PlantParams {
    PlantParams::from(&HORNG_SINANO.params)
}

#[test]
fn charge_times_bus_is_energy_in_driving() {
    let mut plant = Plant::new(sinano(), Metered::default(), 0.3, 0.0);
    let inverter = Inverter {
        dead_time_s: 0.5e-6,
        pwm_hz: 20_000.0,
    };
    let held = inverter.hold(Duties {
        a: 0.6,
        b: 0.45,
        c: 0.45,
    });
    for _ in 0..400 {
        plant.advance(&held, |_, _| 0.0, 1e-5, 25);
    }
    let s = plant.state;
    assert!(s.e_in > 0.1, "{}", s.e_in);
    assert!((s.q_dc * BUS_V - s.e_in).abs() < 1e-9 * s.e_in);
    assert!((plant.supply.charge_c - s.q_dc).abs() < 1e-9 * s.q_dc.abs());
}

#[test]
fn the_diodes_give_the_charge_back_when_braking() {
    let p = sinano();
    let fast = 2.0 * BUS_V / (3f64.sqrt() * p.n * p.flux);
    let mut plant = Plant::new(p, StiffBus { v_bus: BUS_V }, 0.3, fast);
    for _ in 0..100 {
        plant.advance_off(|_, _| 0.0, 1e-5, 100);
    }
    let s = plant.state;
    assert!(s.e_in < 0.0, "{}", s.e_in);
    assert!((s.q_dc * BUS_V - s.e_in).abs() < 1e-9 * s.e_in.abs());
}
