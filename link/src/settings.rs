//! The drive's settings as the link carries them ([`Settings`]): the motor's parameters and
//! ratings (`pmsm_sensorless::motor::Motor`) and everything else a
//! `pmsm_sensorless::drive::DriveConfig` holds (control rate, loop bandwidths, limits, start,
//! health supervision, power stage, current sensing), field for field, with the conversions
//! to and from the core's types. Validation is the core's own ([`Settings::validate`]:
//! `Motor::validate` and the drive's construction), so the link accepts exactly what the
//! drive accepts and a refusal names the core's field. Each setting by name: [`crate::keys`].

use pmsm_sensorless::drive::{
    DriveConfig, HealthConfig, IdentifyConfig, Limits, PowerStageConfig, StartConfig,
};
use pmsm_sensorless::motor::{Motor, MotorParams, Ratings, TorqueConvention};
use pmsm_sensorless::param::ParamError;
use serde::{Deserialize, Serialize};

/// Which torque per amp the motor's N·m are in (`TorqueConvention`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Convention {
    /// `τ = (3/2) N ψ_f i_q`, physical N·m.
    #[default]
    ThreePhase,
    /// `τ = N ψ_f i_q`, the papers'.
    Papers,
}

impl From<TorqueConvention> for Convention {
    fn from(t: TorqueConvention) -> Self {
        match t {
            TorqueConvention::ThreePhase => Self::ThreePhase,
            TorqueConvention::Papers => Self::Papers,
        }
    }
}

impl From<Convention> for TorqueConvention {
    fn from(c: Convention) -> Self {
        match c {
            Convention::ThreePhase => Self::ThreePhase,
            Convention::Papers => Self::Papers,
        }
    }
}

/// The motor's nameplate (`Ratings`).
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct RatingsSettings {
    pub bus_v: f32,
    pub current_a: f32,
    pub torque_nm: f32,
    pub speed_rpm: f32,
    pub power_w: f32,
}

/// The motor: its parameters (`MotorParams`, SI units) and ratings.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MotorSettings {
    pub pole_pairs: u32,
    pub r_ohm: f32,
    pub l_h: f32,
    pub flux_wb: f32,
    pub j_kgm2: f32,
    pub b_nms: f32,
    pub torque: Convention,
    pub ratings: RatingsSettings,
}

/// `Limits`.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct LimitsSettings {
    pub i_max_a: f32,
    pub i_trip_a: f32,
    pub i_sense_max_a: f32,
    pub bus_min_v: f32,
    pub bus_max_v: f32,
}

/// `StartConfig`.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct StartSettings {
    pub align_current_a: f32,
    pub align_time_s: f32,
    pub open_loop_current_a: f32,
    pub accel_rpm_per_s: f32,
    pub handover_rpm: f32,
    pub handback_rpm: f32,
    pub handover_timeout_s: f32,
    pub stop_rpm: f32,
}

/// `HealthConfig`.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct HealthSettings {
    pub lock_time_s: f32,
    pub failover_time_s: f32,
    pub max_disagreement_deg: f32,
    pub max_speed_disagreement_rpm: f32,
    pub loss_time_s: f32,
    pub stall_time_s: f32,
}

/// `PowerStageConfig`.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PowerStageSettings {
    pub pwm_hz: f32,
    pub dead_time_s: f32,
    pub dead_time_band_a: f32,
    pub duty_max: f32,
    pub update_delay_s: f32,
    pub terminal_sensing: bool,
}

/// `IdentifyConfig`: the board's current sensing.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SensingSettings {
    pub sense_range_a: f32,
    pub sense_lsb_a: f32,
}

/// Every setting of a drive: a `Motor` and a `DriveConfig` (module doc). On the wire a
/// tuple of every key's value in the order of `Key::ALL` (`keys.rs`): one loop, not a
/// derived (de)serialiser per field, in the board's flash.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Settings {
    pub motor: MotorSettings,
    pub rate_hz: f32,
    pub current_bandwidth_hz: f32,
    pub speed_bandwidth_hz: f32,
    pub limits: LimitsSettings,
    pub start: StartSettings,
    pub health: HealthSettings,
    pub power_stage: PowerStageSettings,
    pub identify: SensingSettings,
}

impl From<&Motor> for MotorSettings {
    fn from(m: &Motor) -> Self {
        let (p, r) = (m.params, m.ratings);
        Self {
            pole_pairs: p.pole_pairs,
            r_ohm: p.r_ohm,
            l_h: p.l_h,
            flux_wb: p.flux_wb,
            j_kgm2: p.j_kgm2,
            b_nms: p.b_nms,
            torque: p.torque.into(),
            ratings: RatingsSettings {
                bus_v: r.bus_v,
                current_a: r.current_a,
                torque_nm: r.torque_nm,
                speed_rpm: r.speed_rpm,
                power_w: r.power_w,
            },
        }
    }
}

impl MotorSettings {
    /// The core's motor (named `"link"`), unvalidated.
    pub fn motor(&self) -> Motor {
        let r = self.ratings;
        Motor {
            name: "link",
            params: MotorParams {
                pole_pairs: self.pole_pairs,
                r_ohm: self.r_ohm,
                l_h: self.l_h,
                flux_wb: self.flux_wb,
                j_kgm2: self.j_kgm2,
                b_nms: self.b_nms,
                saliency: 1.0,
                torque: self.torque.into(),
            },
            ratings: Ratings {
                bus_v: r.bus_v,
                current_a: r.current_a,
                torque_nm: r.torque_nm,
                speed_rpm: r.speed_rpm,
                power_w: r.power_w,
            },
        }
    }
}

impl From<&DriveConfig> for Settings {
    fn from(c: &DriveConfig) -> Self {
        let motor = Motor {
            name: "link",
            params: c.motor,
            ratings: c.ratings,
        };
        let (l, s, h, p) = (c.limits, c.start, c.health, c.power_stage);
        Self {
            motor: (&motor).into(),
            rate_hz: c.rate_hz,
            current_bandwidth_hz: c.current_bandwidth_hz,
            speed_bandwidth_hz: c.speed_bandwidth_hz,
            limits: LimitsSettings {
                i_max_a: l.i_max_a,
                i_trip_a: l.i_trip_a,
                i_sense_max_a: l.i_sense_max_a,
                bus_min_v: l.bus_min_v,
                bus_max_v: l.bus_max_v,
            },
            start: StartSettings {
                align_current_a: s.align_current_a,
                align_time_s: s.align_time_s,
                open_loop_current_a: s.open_loop_current_a,
                accel_rpm_per_s: s.accel_rpm_per_s,
                handover_rpm: s.handover_rpm,
                handback_rpm: s.handback_rpm,
                handover_timeout_s: s.handover_timeout_s,
                stop_rpm: s.stop_rpm,
            },
            health: HealthSettings {
                lock_time_s: h.lock_time_s,
                failover_time_s: h.failover_time_s,
                max_disagreement_deg: h.max_disagreement_deg,
                max_speed_disagreement_rpm: h.max_speed_disagreement_rpm,
                loss_time_s: h.loss_time_s,
                stall_time_s: h.stall_time_s,
            },
            power_stage: PowerStageSettings {
                pwm_hz: p.pwm_hz,
                dead_time_s: p.dead_time_s,
                dead_time_band_a: p.dead_time_band_a,
                duty_max: p.duty_max,
                update_delay_s: p.update_delay_s,
                terminal_sensing: p.terminal_sensing,
            },
            identify: SensingSettings {
                sense_range_a: c.identify.sense_range_a,
                sense_lsb_a: c.identify.sense_lsb_a,
            },
        }
    }
}

impl Settings {
    /// The core's defaults for `motor` (`DriveConfig::new`), on the power stage and current
    /// sensing of `board` (a board's own figures, kept when the motor changes), the control
    /// rate chosen for the motor on that stage (`DriveConfig::choose_rate`).
    pub fn for_motor(motor: &Motor, board: Option<&Settings>) -> Self {
        let mut c = DriveConfig::new(motor);
        if let Some(b) = board {
            let p = b.power_stage;
            c.power_stage.pwm_hz = p.pwm_hz;
            c.power_stage.dead_time_s = p.dead_time_s;
            c.power_stage.duty_max = p.duty_max;
            c.power_stage.update_delay_s = p.update_delay_s;
            c.power_stage.terminal_sensing = p.terminal_sensing;
            c.identify = IdentifyConfig {
                sense_range_a: b.identify.sense_range_a,
                sense_lsb_a: b.identify.sense_lsb_a,
            };
            c.choose_rate();
        }
        Self::from(&c)
    }

    /// The core's motor, unvalidated.
    pub fn motor(&self) -> Motor {
        self.motor.motor()
    }

    /// The core's drive configuration, unvalidated.
    pub fn drive_config(&self) -> DriveConfig {
        let m = self.motor();
        let (l, s, h, p) = (self.limits, self.start, self.health, self.power_stage);
        DriveConfig {
            motor: m.params,
            rate_hz: self.rate_hz,
            current_bandwidth_hz: self.current_bandwidth_hz,
            speed_bandwidth_hz: self.speed_bandwidth_hz,
            limits: Limits {
                i_max_a: l.i_max_a,
                i_trip_a: l.i_trip_a,
                i_sense_max_a: l.i_sense_max_a,
                bus_min_v: l.bus_min_v,
                bus_max_v: l.bus_max_v,
            },
            start: StartConfig {
                align_current_a: s.align_current_a,
                align_time_s: s.align_time_s,
                open_loop_current_a: s.open_loop_current_a,
                accel_rpm_per_s: s.accel_rpm_per_s,
                handover_rpm: s.handover_rpm,
                handback_rpm: s.handback_rpm,
                handover_timeout_s: s.handover_timeout_s,
                stop_rpm: s.stop_rpm,
            },
            health: HealthConfig {
                lock_time_s: h.lock_time_s,
                failover_time_s: h.failover_time_s,
                max_disagreement_deg: h.max_disagreement_deg,
                max_speed_disagreement_rpm: h.max_speed_disagreement_rpm,
                loss_time_s: h.loss_time_s,
                stall_time_s: h.stall_time_s,
            },
            power_stage: PowerStageConfig {
                pwm_hz: p.pwm_hz,
                dead_time_s: p.dead_time_s,
                dead_time_band_a: p.dead_time_band_a,
                duty_max: p.duty_max,
                update_delay_s: p.update_delay_s,
                terminal_sensing: p.terminal_sensing,
            },
            ratings: m.ratings,
            identify: IdentifyConfig {
                sense_range_a: self.identify.sense_range_a,
                sense_lsb_a: self.identify.sense_lsb_a,
            },
            // Not a link setting: MTPA on a salient motor, `DriveConfig::new`'s.
            mtpa: true,
        }
    }

    /// Validated by the core: the motor by `Motor::validate` (its parameters, its ratings and
    /// the ratings against the parameters), then every drive setting by the drive's own
    /// construction (`DriveConfig::build_flux_primary`: both observers' settings too). The
    /// error names the first bad field, its value and its range.
    pub fn validate(&self) -> Result<(), ParamError> {
        self.motor().validate()?;
        self.drive_config().build_flux_primary().map(|_| ())
    }
}
