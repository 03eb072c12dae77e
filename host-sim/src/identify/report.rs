//! What an identification found, as the user reads it: the identified motor, the motor file
//! `identify --out` writes, the JSON summary with the errors against the truth.

use super::IdentifyOutcome;
use crate::names::fault_name;
use pmsm_sensorless::drive::Identified;
use pmsm_sensorless::motor::{Motor, MotorParams, TorqueConvention};
use serde_json::json;

/// The identified motor with the user's pole pairs and ratings, validated by the core.
pub fn identified_motor(o: &IdentifyOutcome) -> anyhow::Result<Option<Motor>> {
    let Some(id) = o.identified else {
        return Ok(None);
    };
    let params = id
        .params(o.truth.params.pole_pairs, o.truth.params.torque)
        .map_err(|e| anyhow::anyhow!("identified motor: {e}"))?;
    Ok(Some(Motor { params, ..o.truth }))
}

/// The motor file `--motor-file` loads: the identified parameters, the user's ratings.
pub fn motor_toml(name: &str, m: &MotorParams, o: &IdentifyOutcome, id: &Identified) -> String {
    let r = o.truth.ratings;
    // Salient as the parameters written are (`Identified::params` made them so).
    let salient = m.is_salient();
    format!(
        "# Identified by `pmsm-sim identify` (l_d_h = {:e}, l_q_h = {:e}; {}).\n\
         name = \"{name}\"\npole_pairs = {}\nr_ohm = {:e}\n{}flux_wb = {:e}\n\
         j_kgm2 = {:e}\nb_nms = {:e}\n{}\n[ratings]\nbus_v = {}\ncurrent_a = {}\ntorque_nm = {}\n\
         speed_rpm = {}\npower_w = {}\n",
        id.l_d_h,
        id.l_q_h,
        if salient {
            "salient: apart by more than 10 % of their mean"
        } else {
            "l_h is their mean: within 10 % of it, the motor is taken as non-salient"
        },
        m.pole_pairs,
        m.r_ohm,
        if salient {
            format!("l_d_h = {:e}\nl_q_h = {:e}\n", m.l_d_h(), m.l_q_h())
        } else {
            format!("l_h = {:e}\n", m.l_h)
        },
        m.flux_wb,
        m.j_kgm2,
        m.b_nms,
        match m.torque {
            TorqueConvention::ThreePhase => "",
            TorqueConvention::Papers => "torque_convention = \"papers\"\n",
        },
        r.bus_v,
        r.current_a,
        r.torque_nm,
        r.speed_rpm,
        r.power_w
    )
}

/// `(identified − truth)/truth` in % (`None` for a zero truth).
fn err_pct(id: f32, truth: f32) -> Option<f64> {
    (truth != 0.0).then(|| 100.0 * (f64::from(id) - f64::from(truth)) / f64::from(truth))
}

/// The JSON summary: `{"identified", "truth", "error_pct", "duration_s", "error"}`.
pub fn summary_json(name: &str, o: &IdentifyOutcome) -> serde_json::Value {
    let t = o.truth.params;
    let truth = json!({
        "r_ohm": t.r_ohm, "l_h": t.l_h, "l_d_h": t.l_d_h(), "l_q_h": t.l_q_h(),
        "flux_wb": t.flux_wb, "j_kgm2": t.j_kgm2, "b_nms": t.b_nms,
    });
    let (identified, error_pct) = match o.identified {
        Some(id) => (
            json!({
                "r_ohm": id.r_ohm, "l_h": id.l_h(), "l_d_h": id.l_d_h, "l_q_h": id.l_q_h,
                "flux_wb": id.flux_wb, "j_kgm2": id.j_kgm2, "b_nms": id.b_nms,
            }),
            json!({
                "r_ohm": err_pct(id.r_ohm, t.r_ohm), "l_h": err_pct(id.l_h(), t.l_h),
                "l_d_h": err_pct(id.l_d_h, t.l_d_h()), "l_q_h": err_pct(id.l_q_h, t.l_q_h()),
                "flux_wb": err_pct(id.flux_wb, t.flux_wb), "j_kgm2": err_pct(id.j_kgm2, t.j_kgm2),
                "b_nms": err_pct(id.b_nms, t.b_nms),
            }),
        ),
        None => (serde_json::Value::Null, serde_json::Value::Null),
    };
    json!({
        "motor": name,
        "identified": identified,
        "truth": truth,
        "error_pct": error_pct,
        "duration_s": o.duration_s,
        "error": o.fault.map(fault_name),
    })
}
