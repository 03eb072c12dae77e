//! The drive: the one function the 4 kHz interrupt calls.
//!
//! [`Drive::step`] takes the sampled phase currents and bus voltage and returns the three
//! duties, or `None` for PWM off. Inside it: input checks and faults, the mode machine
//! (idle → align → open-loop start → sensorless → back to open loop through zero speed →
//! idle; fault from anywhere), both observers (Horng & Chin's sliding torque observer and
//! Ortega et al.'s flux observer with its PLL) every step while the inverter is on, one of them
//! feeding the controller and the other watching it, and the FOC with its 1 kHz speed loop.
//!
//! The 1 kHz work is spread over the four steps of each millisecond ([`Slot`]), one part per
//! step, so that no step carries all of it: the flux observer's angle (an arctangent), kept
//! with the other angles of that sample; the comparisons of those angles (sensorless
//! supervision, or the open-loop hand-over check); the PLL; the speed loop (or the open-loop
//! ramp). The observers' state equations, the current loop and the PWM run every step.
//!
//! Open-loop start (I/f): a current of fixed magnitude is driven along the d axis of a frame at
//! angle `θ_ol` whose frequency ramps; the rotor follows it, lagging by `asin(τ/(Nψ I_ol))`.
//! The frame is kept as sin/cos of `θ_ol`, turned by `N ω_ol T` each step (no trigonometry
//! on the step's path). Hand-over when the speed is above the observable range and the
//! configured observer agrees with `θ_ol`; the speed loop then starts from the torque the
//! open-loop current was making.
//!
//! Cost: the blocks' per-sample functions (observers, PLL, FOC, PI, SVPWM) are
//! `#[inline(always)]`, so the step compiles to one function: no per-block register save and
//! restore, no structs passed through memory (measured: 1566 → 1296 cycles on the emulated
//! M4F, `pmsm-sim cycles`). The log record is not built here: [`Drive::telemetry`] reads it
//! from the state at the log's rate.

use crate::foc::{CurrentSample, Foc, FocConfig, FocState};
use crate::frames::{Abc, AlphaBeta, Dq, SinCos};
use crate::math::{all_finite, atan2, clamp, max, wrap_pi};
use crate::motor::{positive, Motor, MotorParams, ParamError};
use crate::observer::flux::{FluxConfig, FluxObserver, FluxState};
use crate::observer::pll::{Pll, PllConfig, PllState};
use crate::observer::sliding::{SlidingConfig, SlidingObserver, SlidingState};
use crate::svpwm::Duties;
use core::f32::consts::PI;
use core::hint::cold_path;

const RAD_S_PER_RPM: f32 = PI / 30.0;
const RAD_PER_DEG: f32 = PI / 180.0;
// Multiplications on the step path: a VDIV costs 14 cycles on the M4F.
const RPM_PER_RAD_S: f32 = 30.0 / PI;
const DEG_PER_RAD: f32 = 180.0 / PI;

/// Which observer feeds the controller; the other one runs beside it as a monitor.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Primary {
    /// Horng & Chin torque observer: θ̂, ω̂ and τ̂_L (fed forward in the speed loop).
    SlidingTorque,
    /// Ortega et al. flux observer for θ̂, PLL for ω̂.
    Flux,
}

/// Protection limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Limit of the speed loop's current command [A].
    pub i_max_a: f32,
    /// Phase-current trip level [A], > `i_max_a`.
    pub i_trip_a: f32,
    /// Largest current the sensing path can report [A]; beyond it a sample is invalid.
    pub i_sense_max_a: f32,
    /// Bus under-voltage trip [V].
    pub bus_min_v: f32,
    /// Bus over-voltage trip [V].
    pub bus_max_v: f32,
}

/// Open-loop start and hand-over settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartConfig {
    /// d-axis current while aligning the rotor to θ_e = 0 [A].
    pub align_current_a: f32,
    /// Alignment time [s].
    pub align_time_s: f32,
    /// Magnitude of the open-loop (I/f) current [A].
    pub open_loop_current_a: f32,
    /// Speed-reference slew rate, also the open-loop frequency ramp [rpm/s].
    pub accel_rpm_per_s: f32,
    /// Hand-over to the observer is allowed above this |speed| [rpm].
    pub handover_rpm: f32,
    /// The observer's angle must agree with θ_ol within this [deg, electrical]...
    pub handover_tol_deg: f32,
    /// ...for this long [s].
    pub handover_hold_s: f32,
    /// Back to open loop when both |speed reference| and |ω̂| are below this [rpm].
    pub handback_rpm: f32,
    /// Stall if no hand-over within this time after the ramp passed `handover_rpm` [s].
    pub handover_timeout_s: f32,
}

/// Health supervision settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HealthConfig {
    /// Largest tolerated angle disagreement between the two observers [deg, electrical].
    pub max_disagreement_deg: f32,
    /// Largest tolerated speed disagreement [rpm].
    pub max_speed_disagreement_rpm: f32,
    /// A disagreement must last this long to be an observer loss [s].
    pub loss_time_s: f32,
    /// Speed collapse: the speed loop at its current limit with |ω̂| below half the reference
    /// for this long is a stall [s].
    pub stall_time_s: f32,
}

/// Everything the drive is built from. [`DriveConfig::new`] derives it from a motor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveConfig {
    /// The controller's motor model.
    pub motor: MotorParams,
    /// Step rate [Hz] (4000).
    pub rate_hz: f32,
    /// Current-loop bandwidth [Hz] (300).
    pub current_bandwidth_hz: f32,
    /// Speed-loop bandwidth [Hz] (20), run every 4th step.
    pub speed_bandwidth_hz: f32,
    /// Observer feeding the controller.
    pub primary: Primary,
    /// Protection limits.
    pub limits: Limits,
    /// Start-up and hand-over.
    pub start: StartConfig,
    /// Health supervision.
    pub health: HealthConfig,
    /// Rated speed [rpm]: the sliding gain must stay below (K_s,max)_E2 there.
    pub rated_speed_rpm: f32,
}

impl DriveConfig {
    /// Defaults from the motor's ratings: current command limit 1.5× the current of rated
    /// torque, trip at 1.5× that, sensing range 2× the trip; bus trips at 0.75 and 1.25 of the
    /// rated bus; align and open-loop currents 0.5 and 0.6 of the rated-torque current for
    /// 0.2 s and up the ramp; ramp 1000 rpm/s; hand-over above 10 % of rated speed when the
    /// angle agrees within 30° for 20 ms; hand-back below 6 %; observer loss after 30° or
    /// 10 % of rated speed disagreement for 20 ms; stall after 1 s without hand-over or
    /// 0.1 s at the current limit below half the speed reference.
    pub fn new(motor: &Motor, primary: Primary) -> Self {
        let i_rated = motor.rated_torque_current_a();
        let i_max = 1.5 * i_rated;
        let i_trip = 1.5 * i_max;
        let bus = motor.ratings.bus_v;
        let speed = motor.ratings.speed_rpm;
        Self {
            motor: motor.params,
            rate_hz: 4000.0,
            current_bandwidth_hz: 300.0,
            speed_bandwidth_hz: 20.0,
            primary,
            limits: Limits {
                i_max_a: i_max,
                i_trip_a: i_trip,
                i_sense_max_a: 2.0 * i_trip,
                bus_min_v: 0.75 * bus,
                bus_max_v: 1.25 * bus,
            },
            start: StartConfig {
                align_current_a: 0.5 * i_rated,
                align_time_s: 0.2,
                open_loop_current_a: 0.6 * i_rated,
                accel_rpm_per_s: 1000.0,
                handover_rpm: 0.1 * speed,
                handover_tol_deg: 30.0,
                handover_hold_s: 0.02,
                handback_rpm: 0.06 * speed,
                handover_timeout_s: 1.0,
            },
            health: HealthConfig {
                max_disagreement_deg: 30.0,
                max_speed_disagreement_rpm: 0.1 * speed,
                loss_time_s: 0.02,
                stall_time_s: 0.1,
            },
            rated_speed_rpm: speed,
        }
    }

    /// Validates every setting and derives all gains: FOC, the paper's sliding torque
    /// observer, the flux observer's γ for the lowest sensorless speed (`handback_rpm`), a
    /// 50 Hz PLL. The error names the bad field.
    pub fn build(&self) -> Result<Drive, ParamError> {
        let m = self.motor.validate()?;
        let rate = positive("rate_hz", self.rate_hz)?;
        let l = self.limits;
        let s = self.start;
        let h = self.health;
        positive("i_max_a", l.i_max_a)?;
        positive("i_trip_a - i_max_a", l.i_trip_a - l.i_max_a)?;
        positive("i_sense_max_a - i_trip_a", l.i_sense_max_a - l.i_trip_a)?;
        positive("bus_min_v", l.bus_min_v)?;
        positive("bus_max_v - bus_min_v", l.bus_max_v - l.bus_min_v)?;
        positive("align_current_a", s.align_current_a)?;
        positive("align_time_s", s.align_time_s)?;
        positive("open_loop_current_a", s.open_loop_current_a)?;
        if s.align_current_a > l.i_max_a || s.open_loop_current_a > l.i_max_a {
            return Err(ParamError::OutOfRange("open_loop_current_a"));
        }
        positive("accel_rpm_per_s", s.accel_rpm_per_s)?;
        positive("handback_rpm", s.handback_rpm)?;
        positive(
            "handover_rpm - handback_rpm",
            s.handover_rpm - s.handback_rpm,
        )?;
        positive("handover_tol_deg", s.handover_tol_deg)?;
        positive("handover_hold_s", s.handover_hold_s)?;
        positive(
            "handover_timeout_s - handover_hold_s",
            s.handover_timeout_s - s.handover_hold_s,
        )?;
        if s.align_time_s * rate < 2.0 {
            return Err(ParamError::OutOfRange("align_time_s"));
        }
        positive("rated_speed_rpm", self.rated_speed_rpm)?;
        positive("max_disagreement_deg", h.max_disagreement_deg)?;
        positive("max_speed_disagreement_rpm", h.max_speed_disagreement_rpm)?;
        positive("loss_time_s", h.loss_time_s)?;
        positive("stall_time_s", h.stall_time_s)?;
        let sliding_cfg = SlidingConfig {
            rate_hz: rate,
            ..SlidingConfig::torque(m)
        };
        // The controller applies its voltage at the sliding observer's back-EMF angle (the
        // middle of the period), so it can use the sin/cos the observer keeps of it.
        let foc = FocConfig {
            current_bandwidth_hz: self.current_bandwidth_hz,
            speed_bandwidth_hz: self.speed_bandwidth_hz,
            current_rate_hz: rate,
            speed_divider: SLOTS,
            angle_advance_periods: sliding_cfg.emf_advance_periods,
            ..FocConfig::new(m, l.i_max_a)
        }
        .build()?;
        let sliding = sliding_cfg.build()?;
        // K_s inside its bounds (Horng & Chin Sec 4): below the discrete-time bound, whose
        // binding eigenvalue is −(R/L + K_s/ε) ((K_s,max)_T = ε(2/T − R/L)), and below
        // (K_s,max)_E2 at the rated speed. E2 grows with speed: the paper's constant
        // K_s = 1000π exceeds it below about 620 rpm on the Sinano motor, where the (always
        // unstable) second equilibrium exists, as in the paper's own experiment.
        if let crate::observer::sliding::SlidingGain::Constant(ks) = sliding_cfg.ks {
            let eps = sliding_cfg.epsilon_a;
            let ks_max_t = eps * (2.0 * rate - m.r_ohm / m.l_h);
            let ks_max_e2 = crate::bounds::ks_max_e2(&m, self.rated_speed_rpm * RAD_S_PER_RPM, eps);
            if ks >= ks_max_t || ks > ks_max_e2 {
                return Err(ParamError::OutOfRange("ks"));
            }
        }
        let flux = FluxConfig::new(m, rate, s.handback_rpm).build()?;
        let pll = PllConfig {
            rate_hz: rate / SLOTS as f32,
            bandwidth_hz: 50.0,
            damping: 1.0,
        }
        .build()?;
        let ts = 1.0 / rate;
        let steps = |t: f32| (t * rate) as u32;
        let slot_cycles = |t: f32| (t * rate / SLOTS as f32) as u32;
        Ok(Drive {
            foc,
            sliding,
            flux,
            pll,
            primary: self.primary,
            ts,
            n: m.n(),
            inv_n: 1.0 / m.n(),
            inv_kt: 1.0 / m.torque_constant(),
            limits: l,
            align_current_a: s.align_current_a,
            align_steps: steps(s.align_time_s).max(1),
            open_loop_current_a: s.open_loop_current_a,
            accel_per_slot_cycle: s.accel_rpm_per_s * ts * SLOTS as f32,
            handover_rpm: s.handover_rpm,
            handover_cos: SinCos::of(s.handover_tol_deg * RAD_PER_DEG).cos,
            handover_checks: slot_cycles(s.handover_hold_s).max(1),
            handback_rpm: s.handback_rpm,
            handover_timeout_checks: slot_cycles(s.handover_timeout_s).max(1),
            max_disagreement: h.max_disagreement_deg * RAD_PER_DEG,
            max_speed_disagreement_rpm: h.max_speed_disagreement_rpm,
            loss_checks: slot_cycles(h.loss_time_s).max(1),
            stall_checks: slot_cycles(h.stall_time_s).max(1),
        })
    }
}

/// Operating mode.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Mode {
    /// PWM off, waiting for enable.
    #[default]
    Idle,
    /// d-axis current at θ_e = 0 pulls the rotor to a known angle.
    Align,
    /// Current-controlled open loop with a frequency ramp.
    OpenLoop,
    /// FOC on the configured observer.
    Sensorless,
    /// PWM off, latched until cleared.
    Fault,
}

/// Steps per millisecond-slot cycle: each [`Slot`] comes every 4th step (1 kHz at 4 kHz).
pub const SLOTS: u32 = 4;

/// The part of the 1 kHz work a step does besides the every-step work (see the module doc).
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[repr(u8)]
pub enum Slot {
    /// The flux observer's θ̂ (Ortega Sec V arctangent), kept with the sliding observer's θ̂
    /// and θ_ol of the same sample ([`AngleSample`]) for the comparisons of the next slot.
    #[default]
    MonitorAngle,
    /// Sensorless health (observer loss, stall) and the hand-back; in open loop the hand-over
    /// check.
    Supervision,
    /// The PLL speed estimate on the flux observer's θ̂.
    Pll,
    /// Speed-reference slew and the speed PI; in open loop the I/f frequency ramp.
    SpeedLoop,
}

impl Slot {
    /// The slot of the next step: the discriminant plus one, modulo four (an add and a mask).
    fn next(self) -> Self {
        match (self as u8 + 1) % SLOTS as u8 {
            0 => Slot::MonitorAngle,
            1 => Slot::Supervision,
            2 => Slot::Pll,
            _ => Slot::SpeedLoop,
        }
    }
}

/// Why the drive stopped switching.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Fault {
    /// A phase current beyond `i_trip_a`.
    Overcurrent,
    /// Bus below `bus_min_v`.
    BusUndervoltage,
    /// Bus above `bus_max_v`.
    BusOvervoltage,
    /// A non-finite sample, or a current beyond the sensing range.
    InvalidInput,
    /// The observers disagreed beyond the limits for longer than `loss_time_s`, or one of them
    /// could not update (its state would have become non-finite) while sensorless.
    ObserverLoss,
    /// No hand-over after the ramp, or the speed collapsed under load.
    Stall,
    /// The caller reported that the previous step overran its period.
    Overrun,
}

/// Why the mode changed.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reason {
    /// Enable command.
    Enabled,
    /// Alignment time elapsed.
    Aligned,
    /// The observer agreed with the open-loop angle above the observable speed.
    HandOver,
    /// Speed and reference fell below the hand-back speed (stop or reversal).
    HandBack,
    /// The open-loop ramp reached zero speed with a zero command.
    Stopped,
    /// Enable withdrawn.
    Disabled,
    /// A fault.
    Fault(Fault),
    /// Fault cleared by command.
    Cleared,
}

/// One mode change, for the log.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Transition {
    /// Mode before.
    pub from: Mode,
    /// Mode after.
    pub to: Mode,
    /// Why.
    pub reason: Reason,
}

/// Samples of one period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveInput {
    /// Phase currents [A].
    pub i_abc: Abc,
    /// DC bus voltage [V].
    pub v_bus: f32,
    /// The previous step did not finish within its period.
    pub overrun: bool,
}

/// What the user asks for.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Command {
    /// Run (true) or stop switching (false). From idle the drive starts when enabled with a
    /// non-zero speed command.
    pub enable: bool,
    /// Speed command [rpm, mechanical]; the drive slews to it.
    pub speed_rpm: f32,
    /// Clear a latched fault (back to idle); the drive then starts again only after `enable`
    /// has been low.
    pub clear_fault: bool,
}

/// Small fixed-size record for the log, read at a low rate with [`Drive::telemetry`] (the
/// 4 kHz step does not build it).
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Telemetry {
    /// Mode.
    pub mode: Mode,
    /// Latched fault, if any.
    pub fault: Option<Fault>,
    /// Slewed speed reference [rpm].
    pub speed_ref_rpm: f32,
    /// Speed used by the controller [rpm] (primary estimate, or the open-loop speed).
    pub speed_rpm: f32,
    /// Primary observer's electrical angle [rad].
    pub theta_e_primary: f32,
    /// Monitor observer's electrical angle [rad].
    pub theta_e_monitor: f32,
    /// Angle used by the controller (θ_ol in open loop) [rad].
    pub theta_e_control: f32,
    /// Measured d current (the observers' last sample) in the controller's frame [A].
    pub i_d: f32,
    /// Measured q current (the observers' last sample) in the controller's frame [A].
    pub i_q: f32,
    /// Load-torque estimate of the sliding observer [N·m].
    pub load_nm: f32,
    /// max(|w_a|, |w_b|) of the sliding observer [A/s]: while it slides this is the bracket of
    /// eq (28) (the equivalent injection (29)-(30)), i.e. K_s,min; it cannot exceed K_s, so a
    /// value at K_s means the sliding mode is lost.
    pub ks_min_est: f32,
    /// Health: |θ̂_primary − θ̂_monitor| [deg, electrical].
    pub disagreement_deg: f32,
    /// Health: |ω̂_primary − ω̂_monitor| [rpm].
    pub speed_disagreement_rpm: f32,
}

/// Result of one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveOutput {
    /// Duties to load, each in [0, 1]; `None`: all switches off.
    pub duties: Option<Duties>,
    /// The mode change this step made, if any.
    pub transition: Option<Transition>,
}

/// A built drive (all coefficients per step).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drive {
    foc: Foc,
    sliding: SlidingObserver,
    flux: FluxObserver,
    pll: Pll,
    primary: Primary,
    ts: f32,
    n: f32,
    inv_n: f32,
    /// 1/(N ψ_f) [A/(N·m)].
    inv_kt: f32,
    limits: Limits,
    align_current_a: f32,
    align_steps: u32,
    open_loop_current_a: f32,
    /// Speed slew per slot cycle (the speed loop's period) [rpm].
    accel_per_slot_cycle: f32,
    handover_rpm: f32,
    /// cos of the hand-over angle tolerance.
    handover_cos: f32,
    /// Hand-over checks (1 kHz) in agreement before sensorless.
    handover_checks: u32,
    handback_rpm: f32,
    /// Hand-over checks (1 kHz) above the hand-over speed before a stall.
    handover_timeout_checks: u32,
    max_disagreement: f32,
    max_speed_disagreement_rpm: f32,
    /// Supervision checks (1 kHz) of disagreement before an observer loss.
    loss_checks: u32,
    /// Supervision checks (1 kHz) of collapsed speed before a stall.
    stall_checks: u32,
}

/// Running state of the drive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveState {
    /// Mode.
    pub mode: Mode,
    /// Latched fault.
    pub fault: Option<Fault>,
    /// Align steps taken before this one (counted in [`Mode::Align`] only).
    pub align_steps_done: u32,
    /// FOC integrators.
    pub foc: FocState,
    /// Sliding observer.
    pub sliding: SlidingState,
    /// Flux observer.
    pub flux: FluxState,
    /// PLL on the flux observer's angle.
    pub pll: PllState,
    /// sin/cos of the open-loop angle θ_ol [rad, electrical], the open loop's state: turned by
    /// `ol_rot` every step (θ_ol itself is never needed on the step's path).
    pub sc_ol: SinCos,
    /// sin/cos of θ_ol's advance per step, `N ω_ol T`, kept while the ramp holds (1 kHz).
    pub ol_rot: SinCos,
    /// Open-loop speed [rpm, mechanical].
    pub speed_ol_rpm: f32,
    /// Slewed speed reference [rpm].
    pub speed_ref_rpm: f32,
    /// Voltage applied over the period that just ended [V].
    pub v_ab_last: AlphaBeta,
    /// Consecutive hand-over checks (1 kHz) in agreement.
    pub agree_checks: u32,
    /// Hand-over checks (1 kHz) since the ramp passed the hand-over speed.
    pub waiting_checks: u32,
    /// Consecutive supervision checks (1 kHz) with the observers in disagreement.
    pub disagree_checks: u32,
    /// Consecutive supervision checks (1 kHz) with the speed collapsed.
    pub collapse_checks: u32,
    /// This step's part of the 1 kHz work.
    pub slot: Slot,
    /// The angles of the last [`Slot::MonitorAngle`] step's sample.
    pub sample: AngleSample,
    /// sin/cos of the output angle's lead over the control angle at the controller's speed
    /// ([`Foc::output_rotation`]), kept while that speed holds: in open loop (the ramp moves at
    /// 1 kHz) and with the flux observer primary (the PLL's speed moves at 1 kHz).
    pub out_rot: SinCos,
    /// False after a fault is cleared until the enable command has been seen low.
    pub armed: bool,
}

impl Default for DriveState {
    fn default() -> Self {
        Self {
            mode: Mode::Idle,
            fault: None,
            align_steps_done: 0,
            foc: FocState::default(),
            sliding: SlidingState::default(),
            flux: FluxState::default(),
            pll: PllState::default(),
            sc_ol: SinCos::ZERO,
            ol_rot: SinCos::ZERO,
            speed_ol_rpm: 0.0,
            speed_ref_rpm: 0.0,
            v_ab_last: AlphaBeta::default(),
            agree_checks: 0,
            waiting_checks: 0,
            disagree_checks: 0,
            collapse_checks: 0,
            slot: Slot::MonitorAngle,
            sample: AngleSample::default(),
            out_rot: SinCos::ZERO,
            armed: true,
        }
    }
}

/// The angles the 1 kHz comparisons take, all of one sample (the [`Slot::MonitorAngle`]
/// step's) [rad, electrical]. The flux observer's is [`FluxState::theta_e`] itself: its
/// arctangent is taken only at that step.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AngleSample {
    /// The sliding observer's θ̂_e.
    pub theta_sliding: f32,
    /// cos(θ̂_primary − θ_ol) (in open loop).
    pub ol_cos: f32,
}

/// Both observers' estimates of the rotor: the primary's and the monitor's.
#[derive(Clone, Copy, Debug)]
struct Views {
    theta_primary: f32,
    omega_primary: f32,
    theta_monitor: f32,
    omega_monitor: f32,
}

impl Views {
    /// |θ̂_primary − θ̂_monitor| wrapped to [0, π] [rad, electrical].
    fn disagreement(&self) -> f32 {
        wrap_pi(self.theta_primary - self.theta_monitor).abs()
    }

    /// |ω̂_primary − ω̂_monitor| [rpm].
    fn speed_disagreement_rpm(&self) -> f32 {
        (self.omega_primary - self.omega_monitor).abs() * RPM_PER_RAD_S
    }
}

/// A fault found by a check: the rare path, laid out off the straight-line step.
fn found(fault: Fault) -> Option<Fault> {
    cold_path();
    Some(fault)
}

/// `x` moved toward `target` by at most `step`.
fn slew(x: f32, target: f32, step: f32) -> f32 {
    x + clamp(target - x, -step, step)
}

impl Drive {
    /// One control period. Never panics, never returns a duty outside [0, 1]; any fault turns
    /// the PWM off in the same step.
    // A hint, so a firmware can take the whole step into its own interrupt code (the B-G431B-ESC1
    // firmware runs that from RAM).
    #[inline]
    pub fn step(&self, st: &mut DriveState, input: &DriveInput, cmd: &Command) -> DriveOutput {
        let from = st.mode;
        let mut reason = None;
        // A start needs the enable command to have been low since the last fault was cleared.
        if !cmd.enable {
            st.armed = true;
        }
        let starting = from == Mode::Idle && cmd.enable && st.armed && cmd.speed_rpm != 0.0;
        // 1. Input checks (a fault is latched until cleared; a fault found in this very step
        //    is never cleared by it).
        let mut new_fault = false;
        if from != Mode::Fault {
            if let Some(f) = self.check_input(from, starting, input, cmd) {
                reason = Some(self.enter_fault(st, f));
                new_fault = true;
            }
        }
        // 2. Commands.
        match st.mode {
            Mode::Fault if cmd.clear_fault && !new_fault => {
                cold_path();
                *st = DriveState {
                    armed: false,
                    ..DriveState::default()
                };
                reason = Some(Reason::Cleared);
            }
            Mode::Fault => {}
            Mode::Idle if starting => {
                cold_path();
                *st = DriveState {
                    mode: Mode::Align,
                    ..DriveState::default()
                };
                reason = Some(Reason::Enabled);
            }
            Mode::Idle => {}
            _ if !cmd.enable => {
                cold_path();
                *st = DriveState::default();
                reason = Some(Reason::Disabled);
            }
            _ => {}
        }
        // 3. Control.
        let i_ab = input.i_abc.to_alpha_beta();
        let duties = match st.mode {
            Mode::Idle | Mode::Fault => None,
            Mode::Align | Mode::OpenLoop | Mode::Sensorless => {
                let ok = self.observe(st, i_ab);
                let (duties, r) = self.control(st, input, cmd, i_ab, ok);
                if r.is_some() {
                    reason = r;
                }
                duties
            }
        };
        st.slot = st.slot.next();
        DriveOutput {
            duties: if st.mode == Mode::Fault { None } else { duties },
            transition: reason.filter(|_| st.mode != from).map(|reason| Transition {
                from,
                to: st.mode,
                reason,
            }),
        }
    }

    /// The log record of the state the last [`Drive::step`] left. Built on demand (at the log's
    /// rate, not the control rate); the observer values are those of the last step they ran,
    /// everything else is zero while the PWM is off.
    // Not inlined: it belongs to the log path, not the control path.
    #[inline(never)]
    pub fn telemetry(&self, st: &DriveState) -> Telemetry {
        let off = Telemetry {
            mode: st.mode,
            fault: st.fault,
            ..Telemetry::default()
        };
        // The flux angle of this very sample (the step takes it at 1 kHz).
        let mut flux = st.flux;
        flux.update_angle();
        let v = self.views(st, st.sliding.theta_e, flux.theta_e);
        let (theta, omega_m) = match st.mode {
            Mode::Idle | Mode::Fault => return off,
            Mode::Align => (0.0, 0.0),
            Mode::OpenLoop => (
                atan2(st.sc_ol.sin, st.sc_ol.cos),
                st.speed_ol_rpm * RAD_S_PER_RPM,
            ),
            Mode::Sensorless => (v.theta_primary, v.omega_primary),
        };
        let i_dq = st.flux.i_last.to_dq(SinCos::of(theta));
        Telemetry {
            speed_ref_rpm: st.speed_ref_rpm,
            speed_rpm: omega_m * RPM_PER_RAD_S,
            theta_e_primary: v.theta_primary,
            theta_e_monitor: v.theta_monitor,
            theta_e_control: theta,
            i_d: i_dq.d,
            i_q: i_dq.q,
            load_nm: st.sliding.load_nm,
            ks_min_est: max(st.sliding.w.alpha.abs(), st.sliding.w.beta.abs()),
            disagreement_deg: v.disagreement() * DEG_PER_RAD,
            speed_disagreement_rpm: v.speed_disagreement_rpm(),
            ..off
        }
    }

    /// Faults that a sample (and the command) alone show. `starting`: this step leaves idle.
    fn check_input(
        &self,
        mode: Mode,
        starting: bool,
        input: &DriveInput,
        cmd: &Command,
    ) -> Option<Fault> {
        let i = input.i_abc;
        let l = &self.limits;
        if input.overrun {
            return found(Fault::Overrun);
        }
        if !all_finite([i.a, i.b, i.c, input.v_bus, cmd.speed_rpm]) {
            return found(Fault::InvalidInput);
        }
        let i_peak = max(max(i.a.abs(), i.b.abs()), i.c.abs());
        // One compare on the usual path: `i_sense_max_a` > `i_trip_a` (`DriveConfig::build`).
        if i_peak > l.i_trip_a {
            return found(if i_peak > l.i_sense_max_a {
                Fault::InvalidInput
            } else {
                Fault::Overcurrent
            });
        }
        if input.v_bus > l.bus_max_v {
            return found(Fault::BusOvervoltage);
        }
        // Under-voltage only matters while switching, or about to.
        if (mode != Mode::Idle || starting) && input.v_bus < l.bus_min_v {
            return found(Fault::BusUndervoltage);
        }
        None
    }

    fn enter_fault(&self, st: &mut DriveState, fault: Fault) -> Reason {
        cold_path();
        st.mode = Mode::Fault;
        st.fault = Some(fault);
        Reason::Fault(fault)
    }

    /// Runs both observers on this sample, and the flux angle and the PLL in their slots;
    /// false if either observer could not update.
    fn observe(&self, st: &mut DriveState, i_ab: AlphaBeta) -> bool {
        let v = st.v_ab_last;
        let ok_sliding = self.sliding.update(&mut st.sliding, i_ab, v);
        let ok_flux = self.flux.integrate(&mut st.flux, i_ab, v);
        match st.slot {
            Slot::MonitorAngle => {
                st.flux.update_angle();
                st.sample.theta_sliding = st.sliding.theta_e;
            }
            Slot::Pll => {
                self.pll.update(&mut st.pll, st.flux.theta_e);
                // The controller's speed when the flux observer feeds it.
                if self.primary == Primary::Flux && st.mode == Mode::Sensorless {
                    st.out_rot = self.foc.output_rotation(st.pll.omega * self.inv_n);
                }
            }
            Slot::Supervision | Slot::SpeedLoop => {}
        }
        ok_sliding && ok_flux
    }

    /// The observers' estimates, primary and monitor: the angles given (`theta_sliding`,
    /// `theta_flux`, of one sample) and the speeds now.
    fn views(&self, st: &DriveState, theta_sliding: f32, theta_flux: f32) -> Views {
        let sl = (theta_sliding, st.sliding.omega_m);
        let fl = (theta_flux, st.pll.omega * self.inv_n);
        let (p, m) = match self.primary {
            Primary::SlidingTorque => (sl, fl),
            Primary::Flux => (fl, sl),
        };
        Views {
            theta_primary: p.0,
            omega_primary: p.1,
            theta_monitor: m.0,
            omega_monitor: m.1,
        }
    }

    /// [`Drive::views`] with the angles of the last [`Slot::MonitorAngle`] sample.
    fn sample_views(&self, st: &DriveState) -> Views {
        self.views(st, st.sample.theta_sliding, st.flux.theta_e)
    }

    /// The speed loop's load-torque feed-forward: the sliding torque observer's τ̂_L when it is
    /// the primary [N·m].
    fn torque_ff_nm(&self, st: &DriveState) -> f32 {
        match self.primary {
            Primary::SlidingTorque => st.sliding.load_nm,
            Primary::Flux => 0.0,
        }
    }

    /// sin/cos of the primary observer's angle at this sample: the one the sliding observer
    /// keeps, or the flux observer's rotor-flux vector normalised.
    #[inline(always)]
    fn primary_sin_cos(&self, st: &DriveState) -> SinCos {
        match self.primary {
            Primary::SlidingTorque => st.sliding.sc,
            Primary::Flux => st.flux.sin_cos(),
        }
    }

    /// The open loop's rotations for the speed `speed_ol_rpm` just set: θ_ol's advance per step
    /// and the output angle's lead.
    #[inline(always)]
    fn set_open_loop_speed(&self, st: &mut DriveState) {
        let omega_m = st.speed_ol_rpm * RAD_S_PER_RPM;
        st.ol_rot = SinCos::of_small(self.n * omega_m * self.ts);
        st.out_rot = self.foc.output_rotation(omega_m);
    }

    /// Restarts both observers at a known rotor state (`sc`: sin/cos of θ_e, `omega_m`).
    // Out of line, like the other mode changes: rare, and the interrupt's code must fit the
    // B-G431B-ESC1's 10 KiB of CCM SRAM.
    #[inline(never)]
    fn reset_observers(&self, st: &mut DriveState, i_ab: AlphaBeta, sc: SinCos, omega_m: f32) {
        let theta_e = atan2(sc.sin, sc.cos);
        self.sliding.reset(&mut st.sliding, i_ab, theta_e, omega_m);
        self.flux.reset(&mut st.flux, i_ab, theta_e);
        self.pll.reset(&mut st.pll, theta_e, omega_m * self.n);
    }

    /// Mode logic and the current/speed loops; returns the duties and a mode-change reason.
    fn control(
        &self,
        st: &mut DriveState,
        input: &DriveInput,
        cmd: &Command,
        i_ab: AlphaBeta,
        observers_ok: bool,
    ) -> (Option<Duties>, Option<Reason>) {
        // Finite: `check_input` passed this step (control runs only then).
        let cmd_rpm = cmd.speed_rpm;
        let mut reason = None;
        // (sin/cos of the angle and of the output angle, speed [rad/s], current command) for
        // the current loop this step.
        let ((sc, sc_out), omega_m, i_ref) = match st.mode {
            Mode::Align => {
                // `align_steps` done (the enabling step is the first).
                if st.align_steps_done >= self.align_steps {
                    // Rotor at θ_e = 0, at rest: start the observers there.
                    self.reset_observers(st, i_ab, SinCos::ZERO, 0.0);
                    st.mode = Mode::OpenLoop;
                    st.sc_ol = SinCos::ZERO;
                    st.ol_rot = SinCos::ZERO;
                    st.out_rot = SinCos::ZERO;
                    st.speed_ol_rpm = 0.0;
                    reason = Some(Reason::Aligned);
                }
                st.align_steps_done = st.align_steps_done.saturating_add(1);
                (
                    (SinCos::ZERO, SinCos::ZERO),
                    0.0,
                    Dq::new(self.align_current_a, 0.0),
                )
            }
            Mode::OpenLoop => {
                // The I/f frequency ramp moves at the speed loop's rate (1 kHz); θ_ol advances
                // by N ω_ol T every step, as the rotation `ol_rot` of its sin/cos.
                let before = st.speed_ol_rpm;
                if st.slot == Slot::SpeedLoop {
                    st.speed_ol_rpm = slew(before, cmd_rpm, self.accel_per_slot_cycle);
                    st.speed_ref_rpm = st.speed_ol_rpm;
                    self.set_open_loop_speed(st);
                }
                let omega = st.speed_ol_rpm * RAD_S_PER_RPM;
                st.sc_ol = st.sc_ol.rotated(st.ol_rot);
                match st.slot {
                    Slot::SpeedLoop => {
                        let half = 0.5 * self.handover_rpm;
                        if before.abs() < half && st.speed_ol_rpm.abs() >= half {
                            // Half-way to the hand-over speed the rotor turns with θ_ol (behind
                            // it by the load angle): restart the observers there, where they
                            // can see it.
                            self.reset_observers(st, i_ab, st.sc_ol, omega);
                        }
                        if cmd_rpm == 0.0 && st.speed_ol_rpm == 0.0 {
                            *st = DriveState::default();
                            return (None, Some(Reason::Stopped));
                        }
                    }
                    // The primary's angle against θ_ol, at the sample the angles are kept at.
                    Slot::MonitorAngle => {
                        let p = self.primary_sin_cos(st);
                        st.sample.ol_cos = p.cos * st.sc_ol.cos + p.sin * st.sc_ol.sin;
                    }
                    Slot::Supervision => match self.hand_over(st) {
                        Some(r @ Reason::Fault(_)) => return (None, Some(r)),
                        r @ Some(_) => reason = r,
                        None => {}
                    },
                    // The four rotations since the last time moved its length by a few 1e-7.
                    Slot::Pll => st.sc_ol = st.sc_ol.renormalized(),
                }
                (
                    (st.sc_ol, st.sc_ol.rotated(st.out_rot)),
                    omega,
                    Dq::new(self.open_loop_current_a, 0.0),
                )
            }
            Mode::Sensorless => {
                // Both observers must update.
                if !observers_ok {
                    return (None, Some(self.enter_fault(st, Fault::ObserverLoss)));
                }
                // The primary's speed (the PLL's moves at 1 kHz).
                let omega_m = self.sample_views(st).omega_primary;
                match st.slot {
                    Slot::SpeedLoop => {
                        st.speed_ref_rpm =
                            slew(st.speed_ref_rpm, cmd_rpm, self.accel_per_slot_cycle);
                        let omega_m_ref = st.speed_ref_rpm * RAD_S_PER_RPM;
                        let ff = self.torque_ff_nm(st);
                        self.foc.speed_step(&mut st.foc, omega_m_ref, omega_m, ff);
                    }
                    Slot::Supervision => match self.supervise(st) {
                        Some(r @ Reason::Fault(_)) => return (None, Some(r)),
                        r @ Some(_) => reason = r,
                        None => {}
                    },
                    Slot::MonitorAngle | Slot::Pll => {}
                }
                // The sliding observer keeps the sin/cos of its angle and of the output angle.
                let angles = match self.primary {
                    Primary::SlidingTorque => (st.sliding.sc, st.sliding.sc_mid),
                    Primary::Flux => {
                        let sc = self.primary_sin_cos(st);
                        (sc, sc.rotated(st.out_rot))
                    }
                };
                (angles, omega_m, Dq::new(0.0, st.foc.i_q_ref))
            }
            Mode::Idle | Mode::Fault => return (None, reason),
        };
        let sample = CurrentSample {
            i_ab,
            v_bus: input.v_bus,
            omega_m,
        };
        let out = self
            .foc
            .current_step_at(&mut st.foc.current, &sample, sc, sc_out, i_ref);
        st.v_ab_last = out.v_ab;
        (Some(out.duties), reason)
    }

    /// The open-loop hand-over check, once per slot cycle (1 kHz): above the hand-over speed,
    /// sensorless once the configured observer has followed `θ_ol` (and the monitor agreed
    /// with it within half the sensorless health limits) for `handover_checks` checks in a
    /// row; a stall when that has not happened within `handover_timeout_checks`. The angles
    /// are those of the last [`Slot::MonitorAngle`] sample.
    fn hand_over(&self, st: &mut DriveState) -> Option<Reason> {
        let views = self.sample_views(st);
        let fast_enough = st.speed_ol_rpm.abs() >= self.handover_rpm;
        let agrees = st.sample.ol_cos > self.handover_cos
            && views.disagreement() < 0.5 * self.max_disagreement
            && views.speed_disagreement_rpm() < 0.5 * self.max_speed_disagreement_rpm;
        st.agree_checks = if fast_enough && agrees {
            st.agree_checks + 1
        } else {
            0
        };
        st.waiting_checks = if fast_enough {
            st.waiting_checks.saturating_add(1)
        } else {
            0
        };
        if st.agree_checks >= self.handover_checks {
            cold_path();
            return Some(self.enter_sensorless(st, views));
        }
        if st.waiting_checks >= self.handover_timeout_checks {
            return Some(self.enter_fault(st, Fault::Stall));
        }
        None
    }

    /// The hand-over: the speed loop starts from the torque the open-loop current makes in the
    /// observer's frame, the reference from the observed speed.
    // Out of line: see `reset_observers`.
    #[inline(never)]
    fn enter_sensorless(&self, st: &mut DriveState, views: Views) -> Reason {
        // sin(θ_ol − θ̂) of this sample.
        let (ol, p) = (st.sc_ol, self.primary_sin_cos(st));
        let sin_load_angle = ol.sin * p.cos - ol.cos * p.sin;
        st.foc.speed.integral = self.open_loop_current_a * sin_load_angle;
        st.foc.i_q_ref = st.foc.speed.integral;
        st.speed_ref_rpm = views.omega_primary * RPM_PER_RAD_S;
        st.out_rot = self.foc.output_rotation(views.omega_primary);
        st.mode = Mode::Sensorless;
        st.disagree_checks = 0;
        st.collapse_checks = 0;
        Reason::HandOver
    }

    /// The sensorless health checks and the hand-back, once per slot cycle (1 kHz): observer
    /// loss after `loss_checks` consecutive disagreements (the angles those of the last
    /// [`Slot::MonitorAngle`] sample), a stall after `stall_checks` at the current limit below
    /// half the reference; back to open loop when speed and reference are both low.
    fn supervise(&self, st: &mut DriveState) -> Option<Reason> {
        let views = self.sample_views(st);
        let speed = views.omega_primary * RPM_PER_RAD_S;
        let disagree = views.disagreement() > self.max_disagreement
            || views.speed_disagreement_rpm() > self.max_speed_disagreement_rpm;
        st.disagree_checks = if disagree {
            st.disagree_checks.saturating_add(1)
        } else {
            0
        };
        if st.disagree_checks >= self.loss_checks {
            return Some(self.enter_fault(st, Fault::ObserverLoss));
        }
        // Stall: the speed loop is at its current limit and the speed has fallen below
        // half the reference (the load is more than the motor can carry).
        let at_limit = st.foc.i_q_ref.abs() >= 0.99 * self.limits.i_max_a;
        // Measured along the reference's direction: turning the wrong way counts too.
        let along = if st.speed_ref_rpm < 0.0 {
            -speed
        } else {
            speed
        };
        let collapsed = at_limit && along < 0.5 * st.speed_ref_rpm.abs();
        st.collapse_checks = if collapsed {
            st.collapse_checks.saturating_add(1)
        } else {
            0
        };
        if st.collapse_checks >= self.stall_checks {
            return Some(self.enter_fault(st, Fault::Stall));
        }
        if st.speed_ref_rpm.abs() < self.handback_rpm && speed.abs() < self.handback_rpm {
            cold_path();
            return Some(self.enter_open_loop(st, views.omega_primary));
        }
        None
    }

    /// The hand-back: open loop takes over at the primary's angle of this sample and its speed
    /// `omega_m` [rad/s].
    // Out of line: see `reset_observers`.
    #[inline(never)]
    fn enter_open_loop(&self, st: &mut DriveState, omega_m: f32) -> Reason {
        st.mode = Mode::OpenLoop;
        st.sc_ol = self.primary_sin_cos(st);
        st.speed_ol_rpm = omega_m * RPM_PER_RAD_S;
        self.set_open_loop_speed(st);
        st.agree_checks = 0;
        st.waiting_checks = 0;
        Reason::HandBack
    }
}
