//! `pmsm-sim list`: the built-in scenarios, the motor presets and the observers.

use pmsm_host_sim::observer::ObserverKind;
use pmsm_host_sim::{scenario, table};
use pmsm_sensorless::motor;

/// `list`: three tables.
pub fn list() -> anyhow::Result<String> {
    let table = |header: &[&str]| table(header, &[]);
    let mut scenarios = table(&["scenario (host-sim/scenarios/)", "what it does"]);
    for s in scenario::Spec::all_built_in()? {
        scenarios.add_row([s.name.as_str(), s.description()]);
    }
    let mut motors = table(&[
        "motor",
        "N",
        "R Ω",
        "L H",
        "ψ_f Wb",
        "J kg·m²",
        "B N·m·s/rad",
        "bus V",
        "rated",
    ]);
    for m in motor::PRESETS {
        let (p, r) = (m.params, m.ratings);
        motors.add_row([
            m.name.to_string(),
            p.pole_pairs.to_string(),
            p.r_ohm.to_string(),
            p.l_h.to_string(),
            p.flux_wb.to_string(),
            p.j_kgm2.to_string(),
            p.b_nms.to_string(),
            r.bus_v.to_string(),
            format!(
                "{} N·m, {} rpm, {} A",
                r.torque_nm, r.speed_rpm, r.current_a
            ),
        ]);
    }
    let mut observers = table(&["observer", "what it is"]);
    for o in ObserverKind::ALL {
        observers.add_row([o.name(), o.description()]);
    }
    Ok(format!("{scenarios}\n{motors}\n{observers}\n"))
}
