//! The drive: the one function the 4 kHz interrupt calls, [`Drive::step`].
//!
//! It takes the sampled phase currents and bus voltage and returns the three duties, or `None`
//! for PWM off. Inside it, in this order:
//! 1. the input checks (`protection.rs`): a fault turns the PWM off in the
//!    same step and is latched until cleared;
//! 2. the commands: enable, disable, clear a fault;
//! 3. both observers ([`Observer`]) every step while the inverter is on, the primary feeding
//!    the controller and the monitor watching it (their read-outs are the 1 kHz task's);
//! 4. the mode's step, each mode in a file of its own with its state in its variant of the
//!    mode: idle → `catch.rs` (PWM off: is the rotor turning? a flying start goes straight
//!    to sensorless control) → `align.rs` → `open_loop.rs` start (I/f) → `sensorless.rs`
//!    control, through zero speed on the observer → stopped at zero → idle; back to open loop
//!    only where no observer is healthy at low speed; fault from anywhere. Each mode returns a
//!    [`Request`] (a frame and a current or voltage reference) and, rarely, the mode to switch
//!    to;
//! 5. the one FOC call site, [`Foc::run`]: current loop, dead-time compensation
//!    ([`crate::dead_time`], the board's figures in [`PowerStageConfig`]) and SVPWM.
//!
//! The 1 kHz work is spread over the four steps of each millisecond
//! (`schedule.rs`); the checks of supervision
//! (`supervision.rs`: each observer's health from its own evidence, which one drives, which
//! is re-seeded) take the estimates of one sample.
//!
//! The drive is generic over its two observers (`Drive<P, M>`, monomorphised): the step
//! compiles to one function, with no per-block register save and restore and no structs
//! passed through memory (measured: 1566 → 1296 cycles on the emulated M4F, `pmsm-sim
//! cycles`, when this was introduced). The log record is not built here: [`Drive::telemetry`]
//! reads it from the state at the log's rate.

mod adaptation;
mod align;
mod catch;
mod config;
pub mod identify;
mod io;
mod open_loop;
mod protection;
mod report;
mod schedule;
mod sensorless;
mod supervision;

pub use config::{DriveConfig, HealthConfig, Limits, PowerStageConfig, StartConfig};
pub use identify::{Identified, IdentifyConfig, IdentifyError, IdentifyPhase};
pub use io::{Command, DriveInput, DriveOutput, Fault, Mode, Reason, Role, Telemetry, Transition};
pub use report::{Derived, DerivedRow, Warning};
pub use schedule::{Slot, SLOTS};

use crate::foc::{CurrentLoopState, Foc, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::load_observer::LoadObserver;
use crate::math::atan2;
use crate::math::clamp;
use crate::observer::{Observer, ReadOut, Rotor};
use crate::power_stage::PowerStage;
use crate::units::{DEG_PER_RAD, RAD_S_PER_RPM, RPM_PER_RAD_S};
use align::Align;
use catch::Catch;
use core::hint::cold_path;
use identify::offset::Calibrate;
#[cfg(feature = "identify")]
use identify::Identify;
use open_loop::OpenLoop;
use sensorless::Sensorless;
use supervision::{Health, Seed, Verdict, Views};

/// A built drive: the observers, the FOC and every mode's per-step coefficients. `P` feeds the
/// controller, `M` watches it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drive<P, M> {
    primary: P,
    monitor: M,
    foc: Foc,
    /// Speed-reference slew per slot cycle (the speed loop's period), also the open-loop
    /// frequency ramp \[rpm].
    slew_per_slot_cycle_rpm: f32,
    /// The speed loop's load-torque observer, for a driving observer without one.
    load_observer: LoadObserver,
    /// The speed command is limited to ± this \[rpm] (the rated speed).
    max_speed_rpm: f32,
    /// Field weakening.
    field_weakening: sensorless::FieldWeakening,
    /// The hand-over's d current decays by this factor per millisecond.
    handover_decay: f32,
    limits: Limits,
    /// The motor model's adaptation (R, ψ_f).
    adaptation: adaptation::Settings,
    catch: catch::Settings,
    align: align::Settings,
    open_loop: open_loop::Settings,
    supervision: supervision::Settings,
    /// The identification's coefficients (`identify/`); last, after everything the running
    /// drive's step reads (their offsets from `self` stay as they were).
    #[cfg(feature = "identify")]
    identify: identify::Settings,
    /// An offset beyond this is implausible (`Fault::AdcOffset`) \[A].
    identify_offset_limit_a: f32,
}

/// The running state of a [`Drive<P, M>`]: `DriveState<P::State, M::State>`.
pub type StateOf<P, M> = DriveState<<P as Observer>::State, <M as Observer>::State>;

/// Running state of the drive (`PS`, `MS`: the primary's and the monitor's observer state).
/// `Default` is idle, armed.
#[derive(Clone, Copy, Debug, PartialEq)]
// In declaration order (C layout): what the running step reads first, the identification's
// state last, so that adding it does not move the hot fields' offsets.
#[repr(C)]
pub struct DriveState<PS, MS> {
    mode: ModeState,
    slot: Slot,
    obs: ObserverStates<PS, MS>,
    current: CurrentLoopState,
    /// The currents of the last sample the observers took \[A].
    i_ab_last: AlphaBeta,
    /// Voltage applied over the period that just ended \[V].
    v_ab_last: AlphaBeta,
    /// The bus voltage of the last sample \[V].
    v_bus_last: f32,
    /// Steps of this millisecond in which the current loop cut its voltage to the limit.
    voltage_cut_steps: u8,
    /// ... in every step of the last millisecond ([`Drive::tick`] sets it): the voltage at its
    /// limit, not a noise spike on one sample.
    voltage_limited: bool,
    /// False after a fault is cleared until the enable command has been seen low.
    armed: bool,
    /// The current sensors' offsets in the stationary frame, measured with the PWM off
    /// (`identify/offset.rs`), taken off the identification's samples \[A].
    offset_ab: AlphaBeta,
    /// The idle samples' window for the offsets.
    idle_window: Calibrate,
    /// The last idle window's offsets were implausible: an enable faults (`AdcOffset`).
    offset_implausible: bool,
    /// Mode `Identify`'s state (`identify/`).
    #[cfg(feature = "identify")]
    identify: Identify,
}

impl<PS: Default, MS: Default> Default for DriveState<PS, MS> {
    fn default() -> Self {
        Self {
            mode: ModeState::Idle,
            slot: Slot::First,
            obs: ObserverStates::default(),
            current: CurrentLoopState::default(),
            i_ab_last: AlphaBeta::default(),
            v_ab_last: AlphaBeta::default(),
            v_bus_last: 0.0,
            voltage_cut_steps: 0,
            voltage_limited: false,
            armed: true,
            offset_ab: AlphaBeta::default(),
            idle_window: Calibrate::default(),
            offset_implausible: false,
            #[cfg(feature = "identify")]
            identify: Identify::new(),
        }
    }
}

impl<PS: Default, MS: Default> DriveState<PS, MS> {
    /// Starts afresh in `mode`, the adapted motor model and the offsets measured kept.
    // Out of line: a mode change (enable, disable, stop, clear), one copy for all of them.
    #[inline(never)]
    fn restart(&mut self, mode: ModeState) {
        let model = self.obs.model;
        *self = DriveState {
            mode,
            offset_ab: self.offset_ab,
            offset_implausible: self.offset_implausible,
            ..DriveState::default()
        };
        self.obs.model = model;
    }
}

impl<PS, MS> DriveState<PS, MS> {
    /// The mode.
    pub fn mode(&self) -> Mode {
        match self.mode {
            ModeState::Idle => Mode::Idle,
            ModeState::Catch(_) => Mode::Catch,
            ModeState::Align(_) => Mode::Align,
            ModeState::OpenLoop(_) => Mode::OpenLoop,
            ModeState::Sensorless(_) => Mode::Sensorless,
            ModeState::Fault(_) => Mode::Fault,
            ModeState::Calibrate => Mode::Calibrate,
            ModeState::Identify => Mode::Identify,
            ModeState::Identified => Mode::Identified,
        }
    }

    /// The identified motor, once the identification is done (mode `Identified`).
    pub fn identified(&self) -> Option<Identified> {
        match self.mode {
            #[cfg(feature = "identify")]
            ModeState::Identified => Some(self.identify.result),
            _ => None,
        }
    }

    /// The identification's running measurement, in mode `Identify`.
    pub fn identify_phase(&self) -> Option<IdentifyPhase> {
        match &self.mode {
            #[cfg(feature = "identify")]
            ModeState::Identify => Some(self.identify.which()),
            _ => None,
        }
    }

    /// The current sensors' offsets the drive measured with the PWM off (while idle, or
    /// before an identification), in the stationary frame \[A]: taken off the
    /// identification's samples; a board that does not take its own offsets off its samples
    /// can take these.
    pub fn offset_ab(&self) -> AlphaBeta {
        self.offset_ab
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        match self.mode {
            ModeState::Fault(f) => Some(f),
            _ => None,
        }
    }

    /// The slot of the coming step.
    pub fn slot(&self) -> Slot {
        self.slot
    }

    /// The last step was the [`SLOTS`]th of its millisecond: [`Drive::tick`] is due now.
    pub fn tick_due(&self) -> bool {
        self.slot == Slot::First
    }

    /// The voltage the last step's duties apply over the period \[V] (what the observers take
    /// next step), the inverter's dead time included ([`crate::foc::FocOutput::v_ab`]); zero
    /// before the first switching step.
    pub fn v_ab_applied(&self) -> AlphaBeta {
        self.v_ab_last
    }

    /// The primary observer's state.
    pub fn primary(&self) -> &PS {
        &self.obs.primary
    }

    /// The monitor observer's state.
    pub fn monitor(&self) -> &MS {
        &self.obs.monitor
    }

    /// Which observer drives the controller.
    pub fn driving(&self) -> Role {
        self.obs.health.driving
    }

    /// sin/cos of the open-loop angle θ_ol, in open loop.
    pub fn open_loop_frame(&self) -> Option<SinCos> {
        match &self.mode {
            ModeState::OpenLoop(ol) => Some(ol.frame()),
            _ => None,
        }
    }
}

/// The mode and the state it owns.
#[derive(Clone, Copy, Debug, PartialEq)]
// Without the feature `identify`, Calibrate, Identify and Identified are never entered.
#[cfg_attr(not(feature = "identify"), allow(dead_code))]
enum ModeState {
    /// PWM off, waiting for enable.
    Idle,
    /// PWM off, the observers on the terminal voltage.
    Catch(Catch),
    /// Rotor alignment.
    Align(Align),
    /// Open-loop start.
    OpenLoop(OpenLoop),
    /// Sensorless control.
    Sensorless(Sensorless),
    /// PWM off, latched until cleared.
    Fault(Fault),
    /// PWM off, the current sensors' offsets measured (the samples' window:
    /// `DriveState::idle_window`). Entered only with the feature `identify`.
    Calibrate,
    /// The identification's measurements (their state: `DriveState::identify`, kept out of
    /// this enum so that its size, which every mode change moves, stays the running modes').
    Identify,
    /// The identification's results (`DriveState::identify`), PWM off.
    Identified,
}

/// Both observers' states, the angles of one sample and their health (which drives).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct ObserverStates<PS, MS> {
    primary: PS,
    monitor: MS,
    /// The angles the last [`Drive::tick`] read out.
    sample: AngleSample,
    /// Each observer's lock, which drives.
    health: Health,
    /// The adapted motor model the observers take their inputs through (`adaptation.rs`);
    /// kept from one run to the next.
    model: adaptation::Model,
}

/// The angles the 1 kHz comparisons take, all of one sample (the last tick's
/// step's) [rad, electrical].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct AngleSample {
    theta_primary: f32,
    theta_monitor: f32,
}

/// What a mode's step decided.
enum Outcome {
    /// Apply the request.
    Run(Request),
    /// Apply the request, and switch to the mode for the next step.
    Switch(Request, ModeState, Reason),
    /// Stop switching: a fault.
    Fault(Fault),
}

/// What a mode's [`Drive::tick`] decided.
enum Next {
    /// Carry on.
    Stay,
    /// Carry on; within the mode, the driving observer changed.
    Note(Reason),
    /// Switch to the mode from the next step on.
    Switch(ModeState, Reason),
    /// Stop switching: a fault.
    Fault(Fault),
    /// Stopped at zero speed with a zero command (back to idle).
    Stopped,
}

impl<P: Observer, M: Observer> Drive<P, M> {
    /// One control period. Never panics, never returns a duty outside [0, 1]; any fault turns
    /// the PWM off in the same step.
    // A hint, so a firmware can take the whole step into its own interrupt code.
    #[inline]
    pub fn step(&self, st: &mut StateOf<P, M>, input: &DriveInput, cmd: &Command) -> DriveOutput {
        let from = st.mode();
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
            if let Some(f) = protection::check_input(&self.limits, from, starting, input, cmd) {
                reason = Some(enter_fault(st, f));
                new_fault = true;
            }
        }
        // 2. Commands.
        match st.mode {
            ModeState::Fault(_) if cmd.clear_fault && !new_fault => {
                cold_path();
                st.restart(ModeState::Idle);
                st.armed = false;
                reason = Some(Reason::Cleared);
            }
            ModeState::Fault(_) => {}
            ModeState::Idle if starting => {
                cold_path();
                if st.offset_implausible {
                    // The idle samples' offsets are no amplifier's: refuse the start.
                    reason = Some(enter_fault(st, Fault::AdcOffset));
                } else {
                    // With the terminal voltage sensed, first see whether the rotor turns.
                    let mode = if input.v_ab_terminal.is_some() {
                        ModeState::Catch(Catch::default())
                    } else {
                        ModeState::Align(Align::default())
                    };
                    st.restart(mode);
                    self.adaptation.ensure(&mut st.obs.model);
                    reason = Some(Reason::Enabled);
                }
            }
            ModeState::Idle => {}
            _ if !cmd.enable => {
                cold_path();
                st.restart(ModeState::Idle);
                reason = Some(Reason::Disabled);
            }
            _ => {}
        }
        // 3.-5. Observers, the mode's step, FOC.
        let duties = match st.mode {
            ModeState::Fault(_) | ModeState::Identified => None,
            // Idle (its offsets' watch), the calibration and the identification: out of line,
            // off the running drive's path (`identify/`).
            ModeState::Idle | ModeState::Calibrate | ModeState::Identify => {
                cold_path();
                let (duties, r) = self.commissioning(st, input);
                if r.is_some() {
                    reason = r;
                }
                duties
            }
            _ => {
                // The samples as the board delivers them (its own offsets taken off: the
                // B-G431B-ESC1 measures them at boot); the drive's offsets (`offset_ab`)
                // correct the identification's samples and refuse an implausible sensor at
                // the enable. (Taking them off here too costs 6 cycles the step does not have.)
                let i_ab = input.i_abc.to_alpha_beta();
                // PWM off (catching): the voltage is the terminals'.
                let v_ab = match (&st.mode, input.v_ab_terminal) {
                    (ModeState::Catch(_), Some(v)) => v,
                    _ => st.v_ab_last,
                };
                let ok = self.observe(st, i_ab, v_ab);
                let (duties, r) = self.control(st, input.v_bus, i_ab, input.v_ab_terminal, ok);
                if r.is_some() {
                    reason = r;
                }
                duties
            }
        };
        st.slot = st.slot.next();
        let to = st.mode();
        DriveOutput {
            duties: if to == Mode::Fault { None } else { duties },
            transition: reason
                .filter(|_| to != from)
                .map(|reason| Transition { from, to, reason }),
        }
    }

    /// The drive's 1 kHz task: call it once after every [`SLOTS`]th [`Drive::step`] (when
    /// [`DriveState::tick_due`]), never while a step runs; on a board from a
    /// context the step's interrupt cannot preempt in the middle of it (a critical section
    /// in the main loop: a few µs of interrupt latency). It runs the observers' read-outs
    /// (the flux observer's arctangent, the PLL), the health check and its seeds and failover
    /// (`supervision.rs`), each mode's decisions (hand-over, hand-back, stall, stop, the
    /// open-loop ramp) and the speed loop. The step applies its results from the next sample
    /// on: a fault found here turns the PWM off there. Returns the mode change or the change
    /// of the driving observer it made.
    ///
    /// Split from the step as a drive's medium-frequency task is from its current loop (ST's
    /// motor-control SDK runs its speed loop and state machine so): the 4 kHz interrupt keeps
    /// only what every sample needs.
    #[inline(never)]
    pub fn tick(&self, st: &mut StateOf<P, M>, cmd: &Command) -> Option<Transition> {
        let from = st.mode();
        match st.mode {
            ModeState::Idle
            | ModeState::Fault(_)
            | ModeState::Align(_)
            | ModeState::Calibrate
            | ModeState::Identified => return None,
            #[cfg(feature = "identify")]
            ModeState::Identify => return self.identify_tick(st),
            // Without the feature `identify` the mode is never entered.
            #[cfg(not(feature = "identify"))]
            ModeState::Identify => return None,
            _ => {}
        }
        st.voltage_limited = core::mem::take(&mut st.voltage_cut_steps) >= SLOTS as u8;
        let obs = &mut st.obs;
        self.primary.read_out(&mut obs.primary, ReadOut::Angle);
        self.monitor.read_out(&mut obs.monitor, ReadOut::Angle);
        obs.sample = AngleSample {
            theta_primary: self.primary.theta_e(&obs.primary),
            theta_monitor: self.monitor.theta_e(&obs.monitor),
        };
        self.primary.read_out(&mut obs.primary, ReadOut::Speed);
        self.monitor.read_out(&mut obs.monitor, ReadOut::Speed);
        // The command within the ratings.
        let cmd_rpm = clamp(cmd.speed_rpm, -self.max_speed_rpm, self.max_speed_rpm);
        let i_ab = st.i_ab_last;
        let next = match &mut st.mode {
            ModeState::Catch(c) => self.catch_tick(c, obs, i_ab),
            ModeState::OpenLoop(ol) => self.open_loop_tick(ol, obs, cmd_rpm, i_ab),
            ModeState::Sensorless(s) => {
                let applied = sensorless::Applied {
                    v_ab: st.v_ab_last,
                    v_max: self.foc.v_max(st.v_bus_last),
                    limited: st.voltage_limited,
                };
                self.sensorless_tick(s, obs, cmd_rpm, i_ab, applied)
            }
            _ => Next::Stay,
        };
        let reason = match next {
            Next::Stay => return None,
            Next::Note(reason) => reason,
            Next::Switch(mode, reason) => {
                st.mode = mode;
                reason
            }
            Next::Fault(f) => enter_fault(st, f),
            Next::Stopped => {
                st.restart(ModeState::Idle);
                Reason::Stopped
            }
        };
        Some(Transition {
            from,
            to: st.mode(),
            reason,
        })
    }

    /// One period on a power stage: its sample, [`Drive::step`], the duties (or PWM off)
    /// applied.
    #[inline]
    pub fn step_on<S: PowerStage>(
        &self,
        st: &mut StateOf<P, M>,
        stage: &mut S,
        cmd: &Command,
    ) -> DriveOutput {
        let input = stage.sample();
        let out = self.step(st, &input, cmd);
        stage.apply(out.duties);
        out
    }

    /// A state already in sensorless control at a known rotor state `rotor`, `i_ab` the
    /// currents measured now \[A]: both observers seeded there, the speed reference at the
    /// rotor's speed, the speed loop's integrator at the current of its load torque. For a
    /// start from a rotor state known otherwise (an encoder at commissioning, a flying-start
    /// estimate) and for benches.
    pub fn running_state(&self, i_ab: AlphaBeta, rotor: Rotor) -> StateOf<P, M> {
        let mut st = StateOf::<P, M>::default();
        self.adaptation.ensure(&mut st.obs.model);
        self.seed_observers(&mut st.obs, Seed::BOTH, i_ab, rotor);
        st.obs.sample = AngleSample {
            theta_primary: self.primary.theta_e(&st.obs.primary),
            theta_monitor: self.monitor.theta_e(&st.obs.monitor),
        };
        st.obs.health = Health::AT_KNOWN_STATE;
        let i_q = self.foc.current_for_torque(rotor.load_nm);
        let (_, _, load_nm) = self.driving_now(&st.obs);
        let s = self.sensorless_at(rotor.omega_m, Dq::new(0.0, i_q), load_nm);
        st.mode = ModeState::Sensorless(s);
        st
    }

    /// The log record of the state the last [`Drive::step`] left. Built on demand (at the log's
    /// rate, not the control rate); the observer values are those of the last step they ran,
    /// everything else is zero while the PWM is off.
    // Not inlined: it belongs to the log path, not the control path.
    #[inline(never)]
    pub fn telemetry(&self, st: &StateOf<P, M>) -> Telemetry {
        let model = &st.obs.model;
        let off = Telemetry {
            mode: st.mode(),
            fault: st.fault(),
            r_ohm: model.r_ohm,
            flux_wb: model.flux_wb,
            ..Telemetry::default()
        };
        // The angles of this very sample (the 1 kHz task reads them out once a millisecond),
        // the residuals of the last health check.
        let (mut ps, mut ms) = (st.obs.primary, st.obs.monitor);
        self.primary.read_out(&mut ps, ReadOut::Angle);
        self.monitor.read_out(&mut ms, ReadOut::Angle);
        let health = &st.obs.health;
        let [residual_primary, residual_monitor] = health.residuals();
        let v = Views {
            theta_primary: self.primary.theta_e(&ps),
            omega_primary: self.primary.omega_m(&ps),
            residual_primary,
            min_speed_primary: self.primary.min_speed_m(),
            theta_monitor: self.monitor.theta_e(&ms),
            omega_monitor: self.monitor.omega_m(&ms),
            residual_monitor,
            min_speed_monitor: self.monitor.min_speed_m(),
        };
        let driving = health.driving;
        let (theta_d, omega_d) = (v.theta(driving), v.omega(driving));
        let (theta, omega_m, speed_ref_rpm) = match &st.mode {
            ModeState::Idle
            | ModeState::Fault(_)
            | ModeState::Calibrate
            | ModeState::Identified => return off,
            ModeState::Align(_) | ModeState::Identify => (0.0, 0.0, 0.0),
            ModeState::Catch(_) => (theta_d, omega_d, 0.0),
            ModeState::OpenLoop(ol) => {
                let f = ol.frame();
                let speed = ol.speed_rpm();
                (atan2(f.sin, f.cos), speed * RAD_S_PER_RPM, speed)
            }
            ModeState::Sensorless(s) => (theta_d, omega_d, s.speed_ref_rpm()),
        };
        let i_dq = st.i_ab_last.to_dq(SinCos::of(theta));
        Telemetry {
            speed_ref_rpm,
            speed_rpm: omega_m * RPM_PER_RAD_S,
            theta_e_primary: v.theta_primary,
            theta_e_monitor: v.theta_monitor,
            theta_e_control: theta,
            i_d: i_dq.d,
            i_q: i_dq.q,
            load_nm: self
                .primary
                .load_nm(&ps)
                .map(|t| model.torque_from_observer(t)),
            voltage_limited: st.voltage_limited,
            driving,
            residual_primary,
            residual_monitor,
            disagreement_deg: v.disagreement() * DEG_PER_RAD,
            speed_disagreement_rpm: v.speed_disagreement_rpm(),
            ..off
        }
    }

    /// Runs both observers' state equations on this sample (`i_ab` measured now, `v` applied
    /// over the period that just ended); false if either could not update. Their read-outs
    /// are [`Drive::tick`]'s.
    #[inline(always)]
    fn observe(&self, st: &mut StateOf<P, M>, i_ab: AlphaBeta, v: AlphaBeta) -> bool {
        st.i_ab_last = i_ab;
        let obs = &mut st.obs;
        // Through the adapted model (`adaptation.rs`).
        let (i_ab, v) = obs.model.observer_input(i_ab, v);
        let ok_p = self.primary.update(&mut obs.primary, i_ab, v);
        let ok_m = self.monitor.update(&mut obs.monitor, i_ab, v);
        ok_p && ok_m
    }

    /// The mode's step and the one FOC call site; returns the duties and a mode-change
    /// reason.
    #[inline(always)]
    fn control(
        &self,
        st: &mut StateOf<P, M>,
        v_bus: f32,
        i_ab: AlphaBeta,
        v_terminal: Option<AlphaBeta>,
        observers_ok: bool,
    ) -> (Option<crate::svpwm::Duties>, Option<Reason>) {
        let outcome = match &mut st.mode {
            ModeState::Catch(c) => {
                // PWM off; the observers ran on the terminal voltage.
                let v_ab = v_terminal.unwrap_or_default();
                return match self.catch_step(c, &mut st.obs, i_ab, v_ab) {
                    None if observers_ok => (None, None),
                    None => (None, Some(enter_fault(st, Fault::InvalidInput))),
                    Some(mode) => {
                        st.mode = mode;
                        (None, Some(Reason::AtRest))
                    }
                };
            }
            ModeState::Align(a) => {
                let (request, done) = self.align.step(a, i_ab, st.v_ab_last);
                if done {
                    cold_path();
                    // The resistance of this start (kept unless implausible).
                    let r_ohm = self.align.resistance(a);
                    self.adaptation.take_resistance(&mut st.obs.model, r_ohm);
                    // Rotor at θ_e = 0, at rest: start the observers there, both locked.
                    self.seed_observers(&mut st.obs, Seed::BOTH, i_ab, Rotor::default());
                    st.obs.health = Health::AT_KNOWN_STATE;
                    Outcome::Switch(
                        request,
                        ModeState::OpenLoop(OpenLoop::AT_REST),
                        Reason::Aligned,
                    )
                } else {
                    Outcome::Run(request)
                }
            }
            ModeState::OpenLoop(ol) => Outcome::Run(self.open_loop_step(ol)),
            ModeState::Sensorless(s) if observers_ok => {
                Outcome::Run(self.sensorless_step(s, &st.obs))
            }
            ModeState::Sensorless(_) => Outcome::Fault(Fault::ObserverLoss),
            _ => return (None, None),
        };
        let (request, reason) = match outcome {
            Outcome::Run(request) => (request, None),
            Outcome::Switch(request, mode, reason) => {
                cold_path();
                st.mode = mode;
                (request, Some(reason))
            }
            Outcome::Fault(f) => return (None, Some(enter_fault(st, f))),
        };
        let out = self.foc.run(&mut st.current, &request, i_ab, v_bus);
        st.voltage_cut_steps = st.voltage_cut_steps.saturating_add(u8::from(out.saturated));
        st.v_ab_last = out.v_ab;
        st.v_bus_last = v_bus;
        (Some(out.duties), reason)
    }

    /// The observers' estimates: the angles of the last tick's sample, the
    /// speeds and residuals now, their speed ranges.
    #[inline(always)]
    fn views(&self, obs: &ObserverStates<P::State, M::State>) -> Views {
        Views {
            theta_primary: obs.sample.theta_primary,
            omega_primary: self.primary.omega_m(&obs.primary),
            residual_primary: self.primary.residual(&obs.primary),
            min_speed_primary: self.primary.min_speed_m(),
            theta_monitor: obs.sample.theta_monitor,
            omega_monitor: self.monitor.omega_m(&obs.monitor),
            residual_monitor: self.monitor.residual(&obs.monitor),
            min_speed_monitor: self.monitor.min_speed_m(),
        }
    }

    /// The driving observer's frame now, its output frame turned by `lead`, its speed
    /// [rad/s, mechanical] and its load-torque estimate \[N·m], if it has one.
    #[inline(always)]
    fn driving(
        &self,
        obs: &ObserverStates<P::State, M::State>,
        lead: SinCos,
    ) -> (SinCos, SinCos, f32, Option<f32>) {
        let (frame, frame_out, omega_m, load) = match obs.health.driving {
            Role::Primary => estimate(&self.primary, &obs.primary, lead),
            Role::Monitor => estimate(&self.monitor, &obs.monitor, lead),
        };
        let load_nm = load.map(|t| obs.model.torque_from_observer(t));
        (frame, frame_out, omega_m, load_nm)
    }

    /// The driving observer's frame now, its speed [rad/s, mechanical] and its load-torque
    /// estimate \[N·m] if it has one: [`Drive::driving`] for the 1 kHz task and the mode
    /// changes, out of line (one copy for all of them, not one inlined at each).
    #[inline(never)]
    fn driving_now(&self, obs: &ObserverStates<P::State, M::State>) -> (SinCos, f32, Option<f32>) {
        let (frame, _, omega_m, load_nm) = self.driving(obs, SinCos::ZERO);
        (frame, omega_m, load_nm)
    }

    /// The health check of [`Drive::tick`] (`supervision.rs`) and the seeds it asks
    /// for: a seeded observer starts at the driving one's angle now, speed and load (its
    /// own estimate, else `load_nm` \[N·m], the torque the controller makes). Returns the
    /// verdict and, when the driving observer changed, why.
    // Out of line: a thousandth of a second's work, called from three modes.
    #[inline(never)]
    fn supervise(
        &self,
        obs: &mut ObserverStates<P::State, M::State>,
        i_ab: AlphaBeta,
        load_nm: f32,
    ) -> (Verdict, Option<Reason>) {
        let views = self.views(obs);
        let (verdict, seed) = self.supervision.check(&mut obs.health, &views);
        if seed != Seed::default() {
            self.seed_from_driving(obs, seed, i_ab, load_nm);
        }
        let reason = match (verdict, obs.health.driving) {
            (Verdict::Switched, Role::Monitor) => Some(Reason::Failover),
            (Verdict::Switched, Role::Primary) => Some(Reason::PrimaryDrives),
            _ => None,
        };
        (verdict, reason)
    }

    /// Seeds the observers `seed` names from the driving one (see [`Drive::supervise`]).
    // Out of line, like the mode changes: rare, kept off the every-step path.
    #[inline(never)]
    fn seed_from_driving(
        &self,
        obs: &mut ObserverStates<P::State, M::State>,
        seed: Seed,
        i_ab: AlphaBeta,
        load_nm: f32,
    ) {
        cold_path();
        let (frame, omega_m, load) = self.driving_now(obs);
        let rotor = Rotor {
            theta_e: atan2(frame.sin, frame.cos),
            omega_m,
            load_nm: load.unwrap_or(load_nm),
        };
        self.seed_observers(obs, seed, i_ab, rotor);
    }

    /// Restarts the observers `seed` names at the rotor state `rotor`, `i_ab` the currents
    /// now \[A] (both taken through the adapted model).
    // Out of line, like the other mode changes: rare, kept off the every-step path.
    #[inline(never)]
    fn seed_observers(
        &self,
        obs: &mut ObserverStates<P::State, M::State>,
        seed: Seed,
        i_ab: AlphaBeta,
        rotor: Rotor,
    ) {
        let (i_ab, _) = obs.model.observer_input(i_ab, AlphaBeta::default());
        let rotor = Rotor {
            load_nm: obs.model.torque_to_observer(rotor.load_nm),
            ..rotor
        };
        if seed.primary {
            self.primary.seed(&mut obs.primary, i_ab, rotor);
        }
        if seed.monitor {
            self.monitor.seed(&mut obs.monitor, i_ab, rotor);
        }
    }
}

/// `o`'s frame now, its output frame turned by `lead`, its speed [rad/s, mechanical] and its
/// load-torque estimate \[N·m], if it has one.
#[inline(always)]
fn estimate<O: Observer>(o: &O, st: &O::State, lead: SinCos) -> (SinCos, SinCos, f32, Option<f32>) {
    let frame = o.sin_cos(st);
    (
        frame,
        o.sin_cos_output(st, frame, lead),
        o.omega_m(st),
        o.load_nm(st),
    )
}

/// Latches `fault`: PWM off until cleared.
fn enter_fault<PS, MS>(st: &mut DriveState<PS, MS>, fault: Fault) -> Reason {
    cold_path();
    st.mode = ModeState::Fault(fault);
    Reason::Fault(fault)
}
