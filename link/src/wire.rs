//! The core's drive types as the link carries them: `Mode`, `Fault` (with the
//! identification's `IdentifyError`), `Reason`, `Role`, `Transition`, `Telemetry` and
//! `Identified` (`pmsm_sensorless::drive`), field for field and variant for variant, with
//! conversions both ways. The core's types stay free of serde; these carry its derives.

use pmsm_sensorless::drive as core_drive;
use serde::{Deserialize, Serialize};

/// Mirrors a unit-only enum of the core (each variant of the same name), with conversions.
macro_rules! mirror {
    ($(#[$m:meta])* $name:ident = $core:path { $($v:ident),* $(,)? }) => {
        $(#[$m])*
        #[allow(missing_docs)]
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
        pub enum $name { $($v,)* }

        impl From<$core> for $name {
            fn from(x: $core) -> Self {
                use $core as C;
                match x { $(C::$v => Self::$v,)* }
            }
        }

        impl From<$name> for $core {
            fn from(x: $name) -> Self {
                use $core as C;
                match x { $($name::$v => C::$v,)* }
            }
        }
    };
}

mirror! {
    /// `drive::Mode`.
    Mode = core_drive::Mode {
        Idle, Catch, Align, OpenLoop, Sensorless, Fault, Calibrate, Identify, Identified,
    }
}

mirror! {
    /// `drive::IdentifyError`.
    IdentifyError = core_drive::IdentifyError {
        CurrentNotSensable, OpenPhase, ShortedPhase, BlockedRotor, SpinNotFollowed, LostRotor,
        ResistanceOutOfRange, InductanceOutOfRange, FluxOutOfRange, InertiaOutOfRange,
    }
}

mirror! {
    /// `drive::Role`.
    Role = core_drive::Role { Primary, Monitor }
}

/// `drive::Fault`.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Fault {
    Overcurrent,
    BusUndervoltage,
    BusOvervoltage,
    InvalidInput,
    ObserverLoss,
    Stall,
    Overrun,
    AdcOffset,
    HardwareOvercurrent,
    OverTemperature,
    TaskStall,
    Overspeed,
    CurrentSensor,
    Identify(IdentifyError),
    OpenWinding,
}

impl From<core_drive::Fault> for Fault {
    fn from(f: core_drive::Fault) -> Self {
        use core_drive::Fault as C;
        match f {
            C::Overcurrent => Self::Overcurrent,
            C::BusUndervoltage => Self::BusUndervoltage,
            C::BusOvervoltage => Self::BusOvervoltage,
            C::InvalidInput => Self::InvalidInput,
            C::ObserverLoss => Self::ObserverLoss,
            C::Stall => Self::Stall,
            C::Overrun => Self::Overrun,
            C::AdcOffset => Self::AdcOffset,
            C::HardwareOvercurrent => Self::HardwareOvercurrent,
            C::OverTemperature => Self::OverTemperature,
            C::TaskStall => Self::TaskStall,
            C::Overspeed => Self::Overspeed,
            C::CurrentSensor => Self::CurrentSensor,
            C::Identify(e) => Self::Identify(e.into()),
            C::OpenWinding => Self::OpenWinding,
        }
    }
}

impl From<Fault> for core_drive::Fault {
    fn from(f: Fault) -> Self {
        use Fault as W;
        match f {
            W::Overcurrent => Self::Overcurrent,
            W::BusUndervoltage => Self::BusUndervoltage,
            W::BusOvervoltage => Self::BusOvervoltage,
            W::InvalidInput => Self::InvalidInput,
            W::ObserverLoss => Self::ObserverLoss,
            W::Stall => Self::Stall,
            W::Overrun => Self::Overrun,
            W::AdcOffset => Self::AdcOffset,
            W::HardwareOvercurrent => Self::HardwareOvercurrent,
            W::OverTemperature => Self::OverTemperature,
            W::TaskStall => Self::TaskStall,
            W::Overspeed => Self::Overspeed,
            W::CurrentSensor => Self::CurrentSensor,
            W::Identify(e) => Self::Identify(e.into()),
            W::OpenWinding => Self::OpenWinding,
        }
    }
}

/// `drive::Reason`.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum Reason {
    Enabled,
    Caught,
    AtRest,
    Aligned,
    HandOver,
    AgainstCommand,
    Turning,
    HandBack,
    Stopped,
    Failover,
    PrimaryDrives,
    Disabled,
    Fault(Fault),
    Cleared,
    Identify,
    Calibrated,
    Identified,
    ResistanceRefused,
}

impl From<core_drive::Reason> for Reason {
    fn from(r: core_drive::Reason) -> Self {
        use core_drive::Reason as C;
        match r {
            C::Enabled => Self::Enabled,
            C::Caught => Self::Caught,
            C::AtRest => Self::AtRest,
            C::Aligned => Self::Aligned,
            C::HandOver => Self::HandOver,
            C::AgainstCommand => Self::AgainstCommand,
            C::Turning => Self::Turning,
            C::HandBack => Self::HandBack,
            C::Stopped => Self::Stopped,
            C::Failover => Self::Failover,
            C::PrimaryDrives => Self::PrimaryDrives,
            C::Disabled => Self::Disabled,
            C::Fault(f) => Self::Fault(f.into()),
            C::Cleared => Self::Cleared,
            C::Identify => Self::Identify,
            C::Calibrated => Self::Calibrated,
            C::Identified => Self::Identified,
            C::ResistanceRefused => Self::ResistanceRefused,
        }
    }
}

/// `drive::Transition`.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Transition {
    pub from: Mode,
    pub to: Mode,
    pub reason: Reason,
}

impl From<core_drive::Transition> for Transition {
    fn from(t: core_drive::Transition) -> Self {
        Self {
            from: t.from.into(),
            to: t.to.into(),
            reason: t.reason.into(),
        }
    }
}

/// `drive::Identified`.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Identified {
    pub r_ohm: f32,
    pub l_d_h: f32,
    pub l_q_h: f32,
    pub flux_wb: f32,
    pub j_kgm2: f32,
    pub b_nms: f32,
}

impl From<core_drive::Identified> for Identified {
    fn from(i: core_drive::Identified) -> Self {
        Self {
            r_ohm: i.r_ohm,
            l_d_h: i.l_d_h,
            l_q_h: i.l_q_h,
            flux_wb: i.flux_wb,
            j_kgm2: i.j_kgm2,
            b_nms: i.b_nms,
        }
    }
}

impl From<Identified> for core_drive::Identified {
    fn from(i: Identified) -> Self {
        Self {
            r_ohm: i.r_ohm,
            l_d_h: i.l_d_h,
            l_q_h: i.l_q_h,
            flux_wb: i.flux_wb,
            j_kgm2: i.j_kgm2,
            b_nms: i.b_nms,
        }
    }
}

/// `drive::Telemetry`, every field, with the device's time of the record.
#[allow(missing_docs)]
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Telemetry {
    /// The device's time of the record \[ms] (its uptime; the emulated and the simulated
    /// devices' simulated time), wrapping at 2³².
    pub t_ms: u32,
    pub mode: Mode,
    pub fault: Option<Fault>,
    pub speed_ref_rpm: f32,
    pub speed_rpm: f32,
    pub theta_e_primary: f32,
    pub theta_e_monitor: f32,
    pub theta_e_control: f32,
    pub i_d: f32,
    pub i_q: f32,
    pub load_nm: Option<f32>,
    pub driving: Role,
    pub residual_primary: f32,
    pub residual_monitor: f32,
    pub disagreement_deg: f32,
    pub speed_disagreement_rpm: f32,
    pub r_ohm: f32,
    pub flux_wb: f32,
    pub voltage_limited: bool,
}

impl Telemetry {
    /// The core's record `t` taken at `t_ms`.
    pub fn from_core(t_ms: u32, t: &core_drive::Telemetry) -> Self {
        Self {
            t_ms,
            mode: t.mode.into(),
            fault: t.fault.map(Into::into),
            speed_ref_rpm: t.speed_ref_rpm,
            speed_rpm: t.speed_rpm,
            theta_e_primary: t.theta_e_primary,
            theta_e_monitor: t.theta_e_monitor,
            theta_e_control: t.theta_e_control,
            i_d: t.i_d,
            i_q: t.i_q,
            load_nm: t.load_nm,
            driving: t.driving.into(),
            residual_primary: t.residual_primary,
            residual_monitor: t.residual_monitor,
            disagreement_deg: t.disagreement_deg,
            speed_disagreement_rpm: t.speed_disagreement_rpm,
            r_ohm: t.r_ohm,
            flux_wb: t.flux_wb,
            voltage_limited: t.voltage_limited,
        }
    }
}
