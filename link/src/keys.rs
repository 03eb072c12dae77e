//! Each setting by name ([`Key`]): the names are the core's field names (`"r_ohm"`,
//! `"ratings.bus_v"`, `"limits.i_trip_a"`: those a `ParamError` names), so a refusal's field
//! is the key the user typed. Values are numbers (`f32`); `pole_pairs` takes a whole number,
//! `torque_convention` 0 (three-phase) or 1 (papers), `power_stage.terminal_sensing` 0 (no)
//! or 1 (yes).
//!
//! A setting that shapes the built drive's schedule, model or stage ([`Key::locked_while_running`]:
//! the motor's parameters and ratings, the control rate, the power stage and the current
//! sensing) is refused while the drive runs; loop bandwidths, limits, start and supervision
//! settings may change while it runs.

use crate::settings::{Convention, Settings};
use serde::de::{self, SeqAccess, Visitor};
use serde::ser::SerializeTuple;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Why a value does not fit its key's type (before the core's validation).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum KeyError {
    /// `pole_pairs` must be a whole number from 1 to 2³².
    NotWhole,
    /// `torque_convention` must be 0 (three-phase) or 1 (papers).
    NotConvention,
    /// `power_stage.terminal_sensing` must be 0 (no) or 1 (yes).
    NotFlag,
}

macro_rules! keys {
    ($( $variant:ident = $name:literal => $($field:ident).+ , $locked:literal ;)*) => {
        /// A setting (module doc).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
        pub enum Key {
            /// Pole pairs `N`, a whole number.
            PolePairs,
            /// Torque convention: 0 three-phase, 1 papers.
            TorqueConvention,
            /// `power_stage.terminal_sensing`: 0 no, 1 yes.
            TerminalSensing,
            $(
                #[doc = concat!("`", $name, "`.")]
                $variant,
            )*
        }

        impl Key {
            /// Every key, in the order of [`Settings`] (`power_stage.terminal_sensing` last).
            pub const ALL: &'static [Key] = &[
                Key::PolePairs,
                Key::TorqueConvention,
                $(Key::$variant,)*
                Key::TerminalSensing,
            ];

            /// The setting's name (the core's field name).
            pub const fn name(self) -> &'static str {
                match self {
                    Key::PolePairs => "pole_pairs",
                    Key::TorqueConvention => "torque_convention",
                    Key::TerminalSensing => "power_stage.terminal_sensing",
                    $(Key::$variant => $name,)*
                }
            }

            /// Refused while the drive runs (module doc).
            pub const fn locked_while_running(self) -> bool {
                match self {
                    Key::PolePairs | Key::TorqueConvention | Key::TerminalSensing => true,
                    $(Key::$variant => $locked,)*
                }
            }

            /// The `f32` this key names in `s` (`None` for the two non-`f32` keys).
            fn slot(self, s: &mut Settings) -> Option<&mut f32> {
                match self {
                    Key::PolePairs | Key::TorqueConvention | Key::TerminalSensing => None,
                    $(Key::$variant => Some(&mut s.$($field).+),)*
                }
            }
        }
    };
}

keys! {
    ROhm = "r_ohm" => motor.r_ohm, true;
    LH = "l_h" => motor.l_h, true;
    FluxWb = "flux_wb" => motor.flux_wb, true;
    JKgm2 = "j_kgm2" => motor.j_kgm2, true;
    BNms = "b_nms" => motor.b_nms, true;
    BusV = "ratings.bus_v" => motor.ratings.bus_v, true;
    CurrentA = "ratings.current_a" => motor.ratings.current_a, true;
    TorqueNm = "ratings.torque_nm" => motor.ratings.torque_nm, true;
    SpeedRpm = "ratings.speed_rpm" => motor.ratings.speed_rpm, true;
    PowerW = "ratings.power_w" => motor.ratings.power_w, true;
    RateHz = "rate_hz" => rate_hz, true;
    CurrentBandwidthHz = "current_bandwidth_hz" => current_bandwidth_hz, false;
    SpeedBandwidthHz = "speed_bandwidth_hz" => speed_bandwidth_hz, false;
    IMaxA = "limits.i_max_a" => limits.i_max_a, false;
    ITripA = "limits.i_trip_a" => limits.i_trip_a, false;
    ISenseMaxA = "limits.i_sense_max_a" => limits.i_sense_max_a, false;
    BusMinV = "limits.bus_min_v" => limits.bus_min_v, false;
    BusMaxV = "limits.bus_max_v" => limits.bus_max_v, false;
    AlignCurrentA = "start.align_current_a" => start.align_current_a, false;
    AlignTimeS = "start.align_time_s" => start.align_time_s, false;
    OpenLoopCurrentA = "start.open_loop_current_a" => start.open_loop_current_a, false;
    AccelRpmPerS = "start.accel_rpm_per_s" => start.accel_rpm_per_s, false;
    HandoverRpm = "start.handover_rpm" => start.handover_rpm, false;
    HandbackRpm = "start.handback_rpm" => start.handback_rpm, false;
    HandoverTimeoutS = "start.handover_timeout_s" => start.handover_timeout_s, false;
    StopRpm = "start.stop_rpm" => start.stop_rpm, false;
    LockTimeS = "health.lock_time_s" => health.lock_time_s, false;
    FailoverTimeS = "health.failover_time_s" => health.failover_time_s, false;
    MaxDisagreementDeg = "health.max_disagreement_deg" => health.max_disagreement_deg, false;
    MaxSpeedDisagreementRpm = "health.max_speed_disagreement_rpm" => health.max_speed_disagreement_rpm, false;
    LossTimeS = "health.loss_time_s" => health.loss_time_s, false;
    StallTimeS = "health.stall_time_s" => health.stall_time_s, false;
    PwmHz = "power_stage.pwm_hz" => power_stage.pwm_hz, true;
    DeadTimeS = "power_stage.dead_time_s" => power_stage.dead_time_s, true;
    DeadTimeBandA = "power_stage.dead_time_band_a" => power_stage.dead_time_band_a, true;
    DutyMax = "power_stage.duty_max" => power_stage.duty_max, true;
    UpdateDelayS = "power_stage.update_delay_s" => power_stage.update_delay_s, true;
    SenseRangeA = "identify.sense_range_a" => identify.sense_range_a, true;
    SenseLsbA = "identify.sense_lsb_a" => identify.sense_lsb_a, true;
}

impl Key {
    /// The key called `name`.
    pub fn from_name(name: &str) -> Option<Key> {
        Self::ALL.iter().copied().find(|k| k.name() == name)
    }

    /// Its value in `s`.
    pub fn get(self, s: &Settings) -> f32 {
        match self {
            Key::PolePairs => s.motor.pole_pairs as f32,
            Key::TorqueConvention => match s.motor.torque {
                Convention::ThreePhase => 0.0,
                Convention::Papers => 1.0,
            },
            Key::TerminalSensing => f32::from(u8::from(s.power_stage.terminal_sensing)),
            _ => {
                let mut c = *s;
                self.slot(&mut c).map_or(0.0, |v| *v)
            }
        }
    }

    /// Sets its value in `s` (unvalidated but for the key's type: a whole number of pole
    /// pairs, a convention 0 or 1; the core's validation is [`Settings::validate`]).
    pub fn set(self, s: &mut Settings, value: f32) -> Result<(), KeyError> {
        match self {
            Key::PolePairs => {
                // Whole and within u32: the core's range check follows.
                // Whole and within u32 (the cast back is exact): the core's range check follows.
                let n = value as u32;
                if !(value.is_finite() && (0.0..4.0e9).contains(&value) && n as f32 == value) {
                    return Err(KeyError::NotWhole);
                }
                s.motor.pole_pairs = n;
            }
            Key::TorqueConvention => {
                s.motor.torque = if value == 0.0 {
                    Convention::ThreePhase
                } else if value == 1.0 {
                    Convention::Papers
                } else {
                    return Err(KeyError::NotConvention);
                };
            }
            Key::TerminalSensing => {
                s.power_stage.terminal_sensing = if value == 0.0 {
                    false
                } else if value == 1.0 {
                    true
                } else {
                    return Err(KeyError::NotFlag);
                };
            }
            _ => {
                if let Some(v) = self.slot(s) {
                    *v = value;
                }
            }
        }
        Ok(())
    }
}

/// [`Settings`] on the wire: every key's value (`f32`) in the order of [`Key::ALL`].
impl Serialize for Settings {
    fn serialize<S: Serializer>(&self, ser: S) -> Result<S::Ok, S::Error> {
        let mut t = ser.serialize_tuple(Key::ALL.len())?;
        for k in Key::ALL {
            t.serialize_element(&k.get(self))?;
        }
        t.end()
    }
}

/// Reads [`Settings`] as [`Key::ALL`]'s values. A value that does not fit its key's type
/// (pole pairs not whole, a convention or flag not 0 or 1) leaves that setting at zero (the
/// core's validation then names it: no pole pairs, ...) rather than failing the frame.
impl<'de> Deserialize<'de> for Settings {
    fn deserialize<D: Deserializer<'de>>(de: D) -> Result<Self, D::Error> {
        struct Values;
        impl<'de> Visitor<'de> for Values {
            type Value = Settings;
            fn expecting(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
                f.write_str("every setting's value")
            }
            fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Settings, A::Error> {
                let mut s = Settings::default();
                for k in Key::ALL {
                    let v: f32 = seq
                        .next_element()?
                        .ok_or_else(|| de::Error::custom("too few settings"))?;
                    // A value of the wrong type: the setting stays at zero (doc above).
                    let _ = k.set(&mut s, v);
                }
                Ok(s)
            }
        }
        de.deserialize_tuple(Key::ALL.len(), Values)
    }
}
