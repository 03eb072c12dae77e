//! The DC-link current the converter draws balances the power the windings take: on a stiff
//! bus the charge drawn times the bus voltage is the electrical energy in, driving and
//! braking (through the diodes, when the charge goes back into the bus). The DC link with its
//! capacitor ([`DcLink`]): its energy balance in a plant that drives and then brakes, the bus
//! rising when the motor brakes into a supply that cannot sink, the brake chopper clamping
//! it, the supply's sink limit, and the exact integration's stability with a small capacitor
//! and large currents.

use pmsm_plant::{Chopper, DcLink, Inverter, Plant, PlantParams, Source, StiffBus, Supply};
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

/// The speed whose line back-EMF peak is twice the bus: the diodes brake hard [rad/s].
fn fast(p: &PlantParams) -> f64 {
    2.0 * BUS_V / (3f64.sqrt() * p.n * p.flux)
}

/// 40 ms of the inverter holding duties that drive the motor (0.5 µs dead time, 20 kHz).
fn drive<S: Supply>(plant: &mut Plant<S>) {
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
}

#[test]
fn charge_times_bus_is_energy_in_driving() {
    let mut plant = Plant::new(sinano(), Metered::default(), 0.3, 0.0);
    drive(&mut plant);
    let s = plant.state;
    assert!(s.e_in > 0.1, "{}", s.e_in);
    assert!((s.q_dc * BUS_V - s.e_in).abs() < 1e-9 * s.e_in);
    assert!((plant.supply.charge_c - s.q_dc).abs() < 1e-9 * s.q_dc.abs());
}

#[test]
fn the_diodes_give_the_charge_back_when_braking() {
    let p = sinano();
    let mut plant = Plant::new(p, StiffBus { v_bus: BUS_V }, 0.3, fast(&p));
    for _ in 0..100 {
        plant.advance_off(|_, _| 0.0, 1e-5, 100);
    }
    let s = plant.state;
    assert!(s.e_in < 0.0, "{}", s.e_in);
    assert!((s.q_dc * BUS_V - s.e_in).abs() < 1e-9 * s.e_in.abs());
}

/// A supply of `BUS_V` behind 0.5 Ω that sinks at most `sink_a`.
fn source(sink_a: f64) -> Source {
    Source {
        v_open: BUS_V,
        r_ohm: 0.5,
        sink_a,
    }
}

/// The link's balance: supply energy in = capacitor energy change + losses + converter's.
fn imbalance(link: &DcLink, e_c0: f64) -> f64 {
    let e = link.energy;
    e.source - (link.stored_energy() - e_c0) - e.source_loss - e.brake - e.converter
}

#[test]
fn the_energy_balances_driving_and_braking_with_chopper_and_sink() {
    let chopper = Chopper {
        r_ohm: 20.0,
        v_on: 52.0,
        v_off: 50.0,
    };
    let link = DcLink::new(100e-6, source(0.2), Some(chopper));
    let e_c0 = link.stored_energy();
    let mut plant = Plant::new(sinano(), link, 0.3, 0.0);
    drive(&mut plant);
    let driven = plant.supply;
    assert!(driven.energy.converter > 0.1, "{:?}", driven.energy);
    assert!(driven.energy.source_loss > 0.0);
    plant.state.omega_m = fast(&plant.params);
    let e_in0 = plant.state.e_in;
    for _ in 0..400 {
        plant.advance_off(|_, _| 0.0, 1e-5, 25);
    }
    let link = plant.supply;
    let e = link.energy;
    assert!(e.brake > 0.01, "the chopper ran: {e:?}");
    assert!(link.v_peak > chopper.v_on - 1e-9 && link.v_peak <= chopper.v_on);
    assert!(e.source < driven.energy.source, "the supply sank: {e:?}");
    let scale = e.source.abs() + e.converter.abs() + e.brake;
    assert!(imbalance(&link, e_c0).abs() < 1e-12 * scale, "{e:?}");
    // The plant's electrical energy integrates the power at the voltage held over each
    // sub-step; the link's, at its exact voltage: the same to the bus's change per sub-step.
    let regen = plant.state.e_in - e_in0;
    let link_regen = e.converter - driven.energy.converter;
    assert!(regen < -0.1, "{regen}");
    assert!(
        (link_regen - regen).abs() < 2e-3 * regen.abs(),
        "{link_regen} {regen}"
    );
}

#[test]
fn the_bus_rises_when_the_motor_brakes_into_a_supply_that_cannot_sink() {
    let p = sinano();
    let c = 100e-6;
    let mut plant = Plant::new(p, DcLink::new(c, source(0.0), None), 0.3, fast(&p));
    let e_k0 = plant.state.stored_energy(&p);
    let e_c0 = plant.supply.stored_energy();
    for _ in 0..100 {
        plant.advance_off(|_, _| 0.0, 1e-5, 25);
    }
    let link = plant.supply;
    // The rotor's energy went into the capacitor and the copper; the supply gave nothing.
    assert!(link.v_c > 1.5 * BUS_V, "{}", link.v_c);
    assert!(link.v_peak >= link.v_c);
    assert_eq!(link.energy.source, 0.0);
    assert_eq!(link.energy.source_loss, 0.0);
    let into_c = link.stored_energy() - e_c0;
    assert!((into_c + link.energy.converter).abs() < 1e-12 * into_c);
    let s = plant.state;
    let rotor_gave = e_k0 - s.stored_energy(&p) - s.e_friction;
    assert!(into_c > 0.0 && into_c < rotor_gave - s.e_copper + 1e-3 * rotor_gave);
}

#[test]
fn a_held_regenerative_current_ramps_the_bus_exactly() {
    let c = 100e-6;
    let mut link = DcLink::new(c, source(0.0), None);
    for _ in 0..100 {
        link.draw(-2.0, 1e-5);
    }
    let want = BUS_V + 2.0 * 1e-3 / c;
    assert!((link.v_c - want).abs() < 1e-9 * want, "{} {want}", link.v_c);
}

#[test]
fn the_chopper_clamps_the_bus_at_its_switch_on_voltage() {
    let chopper = Chopper {
        r_ohm: 10.0,
        v_on: 55.0,
        v_off: 53.0,
    };
    // 4 A back into the link, more than the supply sinks (none): the chopper's 5.3-5.5 A
    // in its band takes it, the bus cycles between V_off and V_on.
    let mut link = DcLink::new(50e-6, source(0.0), Some(chopper));
    let mut lowest_after_on = f64::INFINITY;
    for _ in 0..2000 {
        link.draw(-4.0, 1e-5);
        if link.v_peak >= chopper.v_on {
            lowest_after_on = lowest_after_on.min(link.v_c);
        }
        assert!(link.v_c <= chopper.v_on, "{}", link.v_c);
    }
    assert_eq!(link.v_peak, chopper.v_on);
    assert!(lowest_after_on >= chopper.v_off, "{lowest_after_on}");
    // Beyond the brake's capacity it does not clamp: 6 A back needs 60 V on 10 Ω, the bus
    // settles there with the chopper on.
    let mut link = DcLink::new(50e-6, source(0.0), Some(chopper));
    for _ in 0..20_000 {
        link.draw(-6.0, 1e-5);
    }
    assert!(link.brake_on);
    assert!((link.v_c - 60.0).abs() < 1e-6, "{}", link.v_c);
}

#[test]
fn the_supply_sinks_up_to_its_limit() {
    let c = 100e-6;
    // 1 A back, the supply sinks up to 2 A through 0.5 Ω: the bus settles 0.5 V above V_s.
    let mut link = DcLink::new(c, source(2.0), None);
    for _ in 0..10_000 {
        link.draw(-1.0, 1e-5);
    }
    assert!((link.v_c - (BUS_V + 0.5)).abs() < 1e-9, "{}", link.v_c);
    // 3 A back: the supply takes its 2 A at the knee (V_s + 1 V), the rest charges C.
    let mut link = DcLink::new(c, source(2.0), None);
    for _ in 0..1000 {
        link.draw(-3.0, 1e-5);
    }
    let knee = BUS_V + 1.0;
    assert!(link.v_c > knee + 0.9 * 1e-2 / c, "{}", link.v_c);
    assert!(link.v_c < knee + 1e-2 / c);
}

#[test]
fn a_small_capacitor_and_large_currents_stay_exact_and_stable() {
    // R_s C = 0.5 µs, R_b C = 1 µs against a 10 µs sub-step.
    let chopper = Chopper {
        r_ohm: 1.0,
        v_on: 52.0,
        v_off: 51.0,
    };
    let mut coarse = DcLink::new(1e-6, source(0.0), Some(chopper));
    let mut fine = coarse;
    for i_dc in [60.0, -40.0, 20.0, -30.0] {
        for _ in 0..20 {
            coarse.draw(i_dc, 1e-5);
            for _ in 0..100 {
                fine.draw(i_dc, 1e-7);
            }
            assert!(coarse.v_c.is_finite() && coarse.v_c >= 0.0);
            assert!(coarse.v_c <= chopper.v_on);
            assert!((coarse.v_c - fine.v_c).abs() < 1e-6, "{coarse:?} {fine:?}");
        }
    }
    // Driving 60 A for one sub-step, 20 time constants: the bus at V_s − R_s · 60 A
    // within 30 V · e^−20.
    let mut link = DcLink::new(1e-6, source(0.0), None);
    link.draw(60.0, 1e-5);
    assert!((link.v_c - (BUS_V - 30.0)).abs() < 1e-7, "{}", link.v_c);
}
