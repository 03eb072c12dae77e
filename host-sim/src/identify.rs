//! `pmsm-sim identify`: the core's identification (`pmsm_sensorless::drive::identify`) run
//! against the plant, as a board runs it: the user's pole pairs and ratings only, the drive
//! built on a placeholder motor (`identify::placeholder`), the sensor with its noise and
//! offsets, the inverter with its dead time. Faults of the motor for the identification's
//! plausibility checks: an open phase, a shorted winding, a blocked rotor.

use crate::inverter::{CurrentSensor, HeldDuties, Inverter};
use crate::plant::{DiodeBridge, Plant, PlantParams, Supply};
use crate::sim::fault_name;
use pmsm_sensorless::drive::identify::placeholder;
use pmsm_sensorless::drive::{
    Command, DriveConfig, DriveInput, Fault, Identified, IdentifyError, Mode, Transition,
};
use pmsm_sensorless::motor::{Motor, MotorParams};
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;
use serde_json::json;

/// A fault of the motor (the plant), for the identification's checks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotorFault {
    /// Phase `0..3` (a, b, c) not connected: its current is zero, its terminal floats.
    OpenPhase(usize),
    /// Phase `0..3`'s winding short-circuited (its terminal at the star point).
    ShortedPhase(usize),
    /// The shaft cannot turn.
    BlockedRotor,
}

impl MotorFault {
    /// From `open-a`, `shorted-b`, `blocked`, ….
    pub fn parse(s: &str) -> anyhow::Result<Self> {
        let phase = |p: &str| match p {
            "a" => Ok(0),
            "b" => Ok(1),
            "c" => Ok(2),
            _ => anyhow::bail!("--motor-fault = {s}: the phase must be a, b or c"),
        };
        match s.split_once('-') {
            Some(("open", p)) => Ok(Self::OpenPhase(phase(p)?)),
            Some(("shorted", p)) => Ok(Self::ShortedPhase(phase(p)?)),
            None if s == "blocked" => Ok(Self::BlockedRotor),
            _ => anyhow::bail!("--motor-fault = {s}: one of open-a|b|c, shorted-a|b|c, blocked"),
        }
    }
}

/// Everything one identification run needs.
#[derive(Clone, Debug)]
pub struct IdentifyRun {
    /// The motor on the bench (its parameters are the truth; the drive sees only its pole
    /// pairs and ratings).
    pub motor: Motor,
    /// DC bus \[V].
    pub bus_v: f64,
    /// Current-sensor noise, standard deviation per phase \[A].
    pub noise_sigma_a: f64,
    /// Current-sensor offsets per phase \[A].
    pub offset_a: [f64; 3],
    /// ADC step \[A] (0: none).
    pub adc_lsb_a: f64,
    /// Noise seed.
    pub seed: u64,
    /// Inverter dead time \[s] (compensated by the drive with the same figure).
    pub dead_time_s: f64,
    /// PWM frequency \[Hz].
    pub pwm_hz: f64,
    /// The board's current sensing range \[A] (default: the drive's, twice its trip level).
    pub sense_range_a: Option<f64>,
    /// A fault of the motor.
    pub fault: Option<MotorFault>,
    /// Give up after this long \[s].
    pub max_s: f64,
}

impl IdentifyRun {
    /// The board's defaults (20 kHz PWM, 500 ns dead time), 1 % of rated current noise, a 2 %
    /// offset on phase a, seed 1, the motor's bus.
    pub fn board_defaults(motor: Motor) -> Self {
        let rated = f64::from(motor.ratings.current_a);
        Self {
            motor,
            bus_v: f64::from(motor.ratings.bus_v),
            noise_sigma_a: 0.01 * rated,
            offset_a: [0.02 * rated, 0.0, 0.0],
            adc_lsb_a: 0.0,
            seed: 1,
            dead_time_s: 500e-9,
            pwm_hz: 20_000.0,
            sense_range_a: None,
            fault: None,
            max_s: 30.0,
        }
    }
}

/// What a run found.
#[derive(Clone, Debug)]
pub struct IdentifyOutcome {
    /// The motor on the bench.
    pub truth: Motor,
    /// The results, when every measurement ended well.
    pub identified: Option<Identified>,
    /// The drive's fault, when one ended it.
    pub fault: Option<Fault>,
    /// Simulated time from the command to the result (or the fault) \[s].
    pub duration_s: f64,
    /// Every mode change with its time \[s].
    pub transitions: Vec<(f64, Transition)>,
}

/// The inverter's voltage as a faulty winding sees it.
struct Faulty<'a> {
    inner: HeldDuties<'a>,
    fault: Option<MotorFault>,
    r: f64,
}

/// Unit vector of phase `k`'s axis in the stationary frame (amplitude-invariant Clarke).
fn axis(k: usize) -> (f64, f64) {
    let th = k as f64 * 2.0 * std::f64::consts::PI / 3.0;
    (th.cos(), th.sin())
}

impl Supply for Faulty<'_> {
    fn v_alpha_beta(&self, i: (f64, f64), e: (f64, f64)) -> (f64, f64) {
        let v = self.inner.v_alpha_beta(i, e);
        match self.fault {
            // The floating terminal takes the voltage that keeps the phase's current at zero:
            // along its axis u, u·v = R u·i − u·e (the plant's `L di/dt = v − R i + e`).
            Some(MotorFault::OpenPhase(k)) => {
                let u = axis(k);
                let along = u.0 * v.0 + u.1 * v.1;
                let keep = self.r * (u.0 * i.0 + u.1 * i.1) - (u.0 * e.0 + u.1 * e.1);
                (v.0 + (keep - along) * u.0, v.1 + (keep - along) * u.1)
            }
            // Winding k shorted: its terminal at the star point. The other two windings take
            // the line voltages to k; in the αβ model, v' = (I + 2 u uᵀ) v (the conductance
            // along u tripled; at standstill exact, the shorted winding's EMF and torque
            // kept: the identification's checks find it at standstill).
            Some(MotorFault::ShortedPhase(k)) => {
                let u = axis(k);
                let along = u.0 * v.0 + u.1 * v.1;
                (v.0 + 2.0 * along * u.0, v.1 + 2.0 * along * u.1)
            }
            _ => v,
        }
    }
}

/// Runs the identification; errors name a bad setting.
pub fn run(cfg: &IdentifyRun) -> anyhow::Result<IdentifyOutcome> {
    let truth = cfg.motor;
    let user = placeholder(truth.params.pole_pairs, truth.ratings);
    let mut dc = DriveConfig::new(&user);
    dc.power_stage.pwm_hz = cfg.pwm_hz as f32;
    dc.power_stage.dead_time_s = cfg.dead_time_s as f32;
    if let Some(r) = cfg.sense_range_a {
        dc.identify.sense_range_a = r as f32;
    }
    dc.identify.sense_lsb_a = cfg.adc_lsb_a as f32;
    let drive = dc
        .build_flux_primary()
        .map_err(|e| anyhow::anyhow!("drive configuration: {e}"))?;
    let mut st = pmsm_sensorless::drive::StateOf::<FluxPll, SlidingObserver>::default();
    let mut sensor = CurrentSensor::new(cfg.offset_a, cfg.noise_sigma_a, cfg.adc_lsb_a, cfg.seed)?;
    let mut plant = Plant::new(PlantParams::from(&truth.params), 0.0, 0.0);
    plant.locked = cfg.fault == Some(MotorFault::BlockedRotor);
    let inverter = Inverter {
        v_bus: cfg.bus_v,
        dead_time_s: cfg.dead_time_s,
        pwm_hz: cfg.pwm_hz,
    };
    let rate = f64::from(dc.rate_hz);
    let ts = 1.0 / rate;
    let n_sub = 25;
    let h = ts / n_sub as f64;
    let cmd = Command {
        enable: true,
        speed_rpm: 0.0,
        clear_fault: false,
    };
    let mut transitions = Vec::new();
    if let Some(tr) = drive.start_identification(&mut st) {
        transitions.push((0.0, tr));
    }
    let steps = (cfg.max_s * rate).round() as usize;
    let mut k = 0;
    while k < steps {
        let t = k as f64 * ts;
        let i_abc = sensor.measure(plant.i_abc());
        let out = drive.step(
            &mut st,
            &DriveInput {
                i_abc,
                v_bus: cfg.bus_v as f32,
                v_ab_terminal: None,
                overrun: false,
            },
            &cmd,
        );
        let tick = if st.tick_due() {
            drive.tick(&mut st, &cmd)
        } else {
            None
        };
        for tr in [out.transition, tick].into_iter().flatten() {
            transitions.push((t, tr));
        }
        let r = truth.params.r_ohm as f64;
        match out.duties {
            Some(d) => plant.advance(
                &Faulty {
                    inner: inverter.hold(d),
                    fault: cfg.fault,
                    r,
                },
                |_, _| 0.0,
                h,
                n_sub,
            ),
            None => {
                plant.advance_off(&DiodeBridge { v_bus: cfg.bus_v }, |_, _| 0.0, h, n_sub);
            }
        }
        k += 1;
        if matches!(st.mode(), Mode::Identified | Mode::Fault) {
            break;
        }
    }
    Ok(IdentifyOutcome {
        truth,
        identified: st.identified(),
        fault: st.fault(),
        duration_s: k as f64 * ts,
        transitions,
    })
}

/// Snake-case name of an identification error.
pub fn error_name(e: IdentifyError) -> &'static str {
    match e {
        IdentifyError::CurrentNotSensable => "current_not_sensable",
        IdentifyError::OpenPhase => "open_phase",
        IdentifyError::ShortedPhase => "shorted_phase",
        IdentifyError::BlockedRotor => "blocked_rotor",
        IdentifyError::LostRotor => "lost_rotor",
        IdentifyError::ResistanceOutOfRange => "resistance_out_of_range",
        IdentifyError::InductanceOutOfRange => "inductance_out_of_range",
        IdentifyError::FluxOutOfRange => "flux_out_of_range",
        IdentifyError::InertiaOutOfRange => "inertia_out_of_range",
    }
}

/// The identified motor with the user's pole pairs and ratings, validated by the core.
pub fn identified_motor(o: &IdentifyOutcome) -> anyhow::Result<Option<Motor>> {
    let Some(id) = o.identified else {
        return Ok(None);
    };
    let params = id
        .params(o.truth.params.pole_pairs)
        .map_err(|e| anyhow::anyhow!("identified motor: {e}"))?;
    Ok(Some(Motor { params, ..o.truth }))
}

/// The motor file `--motor-file` loads: the identified parameters, the user's ratings.
pub fn motor_toml(name: &str, m: &MotorParams, o: &IdentifyOutcome, id: &Identified) -> String {
    let r = o.truth.ratings;
    format!(
        "# Identified by `pmsm-sim identify` (l_d_h = {:e}, l_q_h = {:e}; l_h is their mean).\n\
         name = \"{name}\"\npole_pairs = {}\nr_ohm = {:e}\nl_h = {:e}\nflux_wb = {:e}\n\
         j_kgm2 = {:e}\nb_nms = {:e}\n\n[ratings]\nbus_v = {}\ncurrent_a = {}\ntorque_nm = {}\n\
         speed_rpm = {}\npower_w = {}\n",
        id.l_d_h,
        id.l_q_h,
        m.pole_pairs,
        m.r_ohm,
        m.l_h,
        m.flux_wb,
        m.j_kgm2,
        m.b_nms,
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
        "r_ohm": t.r_ohm, "l_h": t.l_h, "l_d_h": t.l_h, "l_q_h": t.l_h,
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
                "l_d_h": err_pct(id.l_d_h, t.l_h), "l_q_h": err_pct(id.l_q_h, t.l_h),
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
