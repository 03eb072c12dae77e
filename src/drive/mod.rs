//! The drive: the one function the 4 kHz interrupt calls, [`Drive::step`].
//!
//! It takes the sampled phase currents and bus voltage and returns the three duties, or `None`
//! for PWM off. Inside it, in this order:
//! 1. the input checks (`protection.rs`): a fault turns the PWM off in the
//!    same step and is latched until cleared (the terminal voltage is checked where it is
//!    read, while catching);
//! 2. the commands: enable, disable, clear a fault; then, in a running mode, the count of
//!    steps since the last 1 kHz task: beyond
//!    [`STEPS_WITHOUT_TICK_MAX`](crate::schedule::STEPS_WITHOUT_TICK_MAX) the task has
//!    stalled (`Fault::TaskStall`), PWM off; then the phase currents' sum
//!    (`plausibility.rs`): a failed current sensor (`Fault::CurrentSensor`), PWM off;
//! 3. both observers ([`Observer`]) every step while the inverter is on, the primary feeding
//!    the controller and the monitor watching it (their read-outs are the 1 kHz task's);
//! 4. the mode's step, each mode in a file of its own with its state in its variant of the
//!    mode: idle → `catch.rs` (PWM off: is the rotor turning? a flying start goes straight
//!    to sensorless control) → `align.rs` → `open_loop.rs` start (I/f) → `sensorless.rs`
//!    control, through zero speed on the observer → stopped at zero → idle; back to open loop
//!    only where no observer is healthy at low speed; fault from anywhere. Each mode is a
//!    settings struct built once from the [`DriveConfig`] (`&self`) and its state (`&mut`, in
//!    its variant of the mode), idsp's shape: its `step` returns a [`Request`] (a frame and a
//!    current or voltage reference), its `tick` what it asks for (`mode.rs`: carry on, a mode
//!    change with its reason, a fault); the drive builds the next mode's state, so no mode
//!    reaches into another;
//! 5. the one FOC call site, [`Foc::run`]: current loop, dead-time compensation
//!    ([`crate::dead_time`], the board's figures in [`PowerStageConfig`]) and SVPWM.
//!
//! The 1 kHz work is spread over the four steps of each millisecond
//! (`crate::schedule`); the checks of supervision
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
mod applied;
mod catch;
mod catch_zero;
mod config;
mod config_observers;
mod config_rate;
mod derating;
pub mod identify;
#[cfg(feature = "injection")]
mod inject;
mod io;
mod mode;
mod observers;
mod open_loop;
mod plausibility;
mod protection;
mod ramp;
mod regen;
mod report;
mod safe_state;
mod sensorless;
mod speed_gain;
mod state;
mod supervision;
mod telemetry;

pub use crate::power_stage::DriveInput;
pub use crate::schedule::{Schedule, SLOTS};
pub use config::{DriveConfig, HealthConfig, Limits, PowerStageConfig, StartConfig};
pub use identify::{Identified, IdentifyConfig, IdentifyError, IdentifyPhase};
#[cfg(feature = "injection")]
pub use inject::{Declined, HANDOVER_CHECKS};
pub use io::{
    Command, DriveOutput, Fault, Mode, Reason, ResistanceRefused, Role, Telemetry, Transition,
};
pub use report::{Derived, DerivedRow, Warning};
pub use safe_state::{allows_short_circuit, SafeState};
pub use state::{DriveState, StateOf};

use crate::foc::{Foc, Request};
use crate::frames::{AlphaBeta, Dq};
use crate::observer::{Observer, ReadOut, Rotor};
use align::{Align, Measured};
use catch::{Catch, Seen};
use catch_zero::{CatchZero, Probe};
use core::hint::cold_path;
use mode::{against, Entry, Next};
use observers::AngleSample;
use open_loop::OpenLoop;
use state::ModeState;
use supervision::{Health, Seed, Verdict};

/// A built drive: the observers, the FOC and every mode's settings. `P` feeds the controller,
/// `M` watches it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Drive<P, M> {
    primary: P,
    monitor: M,
    foc: Foc,
    limits: Limits,
    /// Steps per 1 kHz task; the task-stall count.
    schedule: crate::schedule::Schedule,
    /// The update delay in control periods ([`PowerStageConfig::update_delay_s`] times the
    /// rate): the observers' voltage is the last two periods' blend.
    delay_periods: f32,
    /// The motor model's adaptation (R, ψ_f).
    adaptation: adaptation::Settings,
    catch: catch::Settings,
    align: align::Settings,
    open_loop: open_loop::Settings,
    sensorless: sensorless::Settings,
    supervision: supervision::Settings,
    /// The current sensors' phase-sum check (after the settings that were here before it:
    /// their offsets from `self` stay as they were).
    sensing: plausibility::Settings,
    /// The safe state per fault on this motor (`safe_state.rs`).
    safe_state: safe_state::Settings,
    /// The identification's coefficients (`identify/`); last, after everything the running
    /// drive's step reads (their offsets from `self` stay as they were).
    #[cfg(feature = "identify")]
    identify: identify::Settings,
    /// An offset beyond this is implausible (`Fault::AdcOffset`) \[A].
    identify_offset_limit_a: f32,
    /// The catch without terminal sensing, and the alignment's watch of the back-EMF (last,
    /// like the identification's: the running drive's step reads none of it).
    catch_zero: catch_zero::Settings,
    /// The board senses the terminal voltage (`PowerStageConfig::terminal_sensing`).
    terminal_sensing: bool,
    /// The start through high-frequency injection (`inject.rs`), or why not; last, like the
    /// identification's settings.
    #[cfg(feature = "injection")]
    inject: Result<inject::Settings, Declined>,
}

/// What a mode's step decided.
enum Outcome {
    /// Apply the request.
    Run(Request),
    /// Apply the request, and switch to the mode for the next step.
    Switch(Request, ModeState, Reason),
    /// Stop switching: a fault.
    Fault(Fault),
    /// PWM off in this step (catching), with the mode change's reason if any.
    Off(Option<Reason>),
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
        st.arming.see(cmd);
        let starting =
            from == Mode::Idle && cmd.enable && st.arming.armed() && cmd.speed_rpm != 0.0;
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
                st.arming.disarm();
                reason = Some(Reason::Cleared);
            }
            ModeState::Fault(_) => {}
            ModeState::Idle if starting => {
                cold_path();
                if st.offsets.implausible() {
                    // The idle samples' offsets are no amplifier's: refuse the start.
                    reason = Some(enter_fault(st, Fault::AdcOffset));
                } else {
                    // With the terminal voltage sensed, first see whether the rotor turns; on a
                    // board that does not sense it at every speed, with the currents
                    // regulated to zero.
                    let mode = if input.v_ab_terminal.is_some() {
                        ModeState::Catch(Catch::default())
                    } else if !self.terminal_sensing {
                        ModeState::CatchZero(CatchZero::default())
                    } else {
                        self.at_rest()
                    };
                    st.restart(mode);
                    self.adaptation.ensure(&mut st.obs.model);
                    reason = Some(Reason::Enabled);
                }
            }
            ModeState::Idle => {}
            ModeState::Catch(_)
            | ModeState::CatchZero(_)
            | ModeState::Align(_)
            | ModeState::OpenLoop(_)
            | ModeState::Sensorless(_)
            | ModeState::Calibrate
            | ModeState::Identify
            | ModeState::Identified => {
                if !cmd.enable {
                    cold_path();
                    st.restart(ModeState::Idle);
                    reason = Some(Reason::Disabled);
                }
            }
            #[cfg(feature = "injection")]
            ModeState::Inject => {
                if !cmd.enable {
                    cold_path();
                    st.restart(ModeState::Idle);
                    reason = Some(Reason::Disabled);
                }
            }
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
            ModeState::Catch(_)
            | ModeState::CatchZero(_)
            | ModeState::Align(_)
            | ModeState::OpenLoop(_)
            | ModeState::Sensorless(_) => {
                // The 1 kHz task stalled (`STEPS_WITHOUT_TICK_MAX` steps without it): its
                // speed loop, supervision and checks stopped with it; stop switching. Counted
                // while catching too (PWM off): the catch's hand-over is the task's.
                if st.task_stalled(&self.schedule) {
                    reason = Some(enter_fault(st, Fault::TaskStall));
                    None
                } else if self.sensing.implausible(&mut st.sum_count, input.i_abc) {
                    // The phase currents do not sum to zero: a current sensor failed
                    // (`plausibility.rs`); stop switching in this step.
                    reason = Some(enter_fault(st, Fault::CurrentSensor));
                    None
                } else {
                    // The samples as the board delivers them (its own offsets taken off: the
                    // B-G431B-ESC1 measures them at boot); the drive's offsets correct the
                    // identification's samples and refuse an implausible sensor at the enable.
                    // (Taking them off here too costs 6 cycles the step does not have.)
                    let i_ab = input.i_abc.to_alpha_beta();
                    // PWM off (catching): the voltage is the terminals'.
                    let v_ab = match (&st.mode, input.v_ab_terminal) {
                        (ModeState::Catch(_), Some(v)) => v,
                        _ => st.last.v_ab(),
                    };
                    let ok = self.observe(st, i_ab, v_ab);
                    let (duties, r) = self.control(st, input, i_ab, cmd.speed_rpm, ok);
                    if r.is_some() {
                        reason = r;
                    }
                    duties
                }
            }
            // The injection's start (`inject.rs`): the same checks, observers and FOC.
            #[cfg(feature = "injection")]
            ModeState::Inject => {
                if st.task_stalled(&self.schedule) {
                    reason = Some(enter_fault(st, Fault::TaskStall));
                    None
                } else if self.sensing.implausible(&mut st.sum_count, input.i_abc) {
                    reason = Some(enter_fault(st, Fault::CurrentSensor));
                    None
                } else {
                    // The observers do not run (they are seeded at the hand-over, `inject.rs`).
                    let i_ab = input.i_abc.to_alpha_beta();
                    st.i_ab_last = i_ab;
                    let (duties, r) = self.control(st, input, i_ab, cmd.speed_rpm, true);
                    if r.is_some() {
                        reason = r;
                    }
                    duties
                }
            }
        };
        st.slot = self.schedule.next_slot(st.slot);
        // The brake chopper's gate from the bus, in every mode (`regen.rs`).
        st.brake = self.sensorless.regen.brake(st.brake, input.v_bus);
        let faulted = matches!(st.mode, ModeState::Fault(_));
        DriveOutput {
            duties: if faulted { None } else { duties },
            short_circuit: faulted && self.short_circuit(st),
            brake: st.brake,
            // The mode's name only where a step reports a transition.
            transition: reason.and_then(|reason| {
                let to = st.mode();
                (to != from).then_some(Transition { from, to, reason })
            }),
        }
    }

    /// The 1 kHz task's slower work, after the task and before its results are given to the
    /// step ([`Control::run`](crate::control::Control::run): after the task in one context;
    /// [`TickCopy`](crate::control::TickCopy): on the task's copy before it is given back):
    /// the motor model's check of the operating point the task kept (`adaptation.rs`: a
    /// square root and up to three divisions), and the speed loop's checks' block and
    /// interval ends (`speed_gain.rs`: the inertia's regression, the gain set), every 16 and
    /// 100 tasks; bounded (`pmsm-sim cycles`). Run it after every task: not run, the model
    /// does not adapt, the checks wait and the gain stays.
    #[inline(never)]
    pub fn background(&self, st: &mut StateOf<P, M>) {
        self.adaptation.track_kept(&mut st.obs.model);
        self.sensorless.speed_gain.background(&mut st.speed_gain);
    }

    /// For the cycle bench (`examples/qemu-m4f`): the model's check and the speed loop's
    /// checks set so that the next [`Drive::background`] runs its costliest path
    /// (`adaptation.rs`, `speed_gain.rs`).
    #[doc(hidden)]
    pub fn bench_background_worst(&self, st: &mut StateOf<P, M>) {
        self.adaptation.bench_worst(&mut st.obs.model);
        #[cfg(feature = "speed-gain")]
        st.speed_gain.bench_worst();
    }

    /// The drive's 1 kHz task: call it once after every `rate_hz/1000`-th [`Drive::step`] (when
    /// [`DriveState::tick_due`]), never while a step runs; on a board from a
    /// context the step's interrupt cannot preempt in the middle of it (a critical section
    /// in the main loop: a few µs of interrupt latency). It runs the observers' read-outs
    /// (the flux observer's arctangent, the PLL), the health check and its seeds and failover
    /// (`supervision.rs`), each mode's decisions (hand-over, hand-back, stall, stop, the
    /// open-loop ramp) and the speed loop. The step applies its results from the next sample
    /// on: a fault found here turns the PWM off there. Returns the mode change or the change
    /// of the driving observer it made. Its slower work follows it, [`Drive::background`].
    ///
    /// Split from the step as a drive's medium-frequency task is from its current loop (ST's
    /// motor-control SDK runs its speed loop and state machine so): the 4 kHz interrupt keeps
    /// only what every sample needs.
    #[inline(never)]
    pub fn tick(&self, st: &mut StateOf<P, M>, cmd: &Command) -> Option<Transition> {
        st.ticked();
        st.obs.model.drop_kept();
        let from = st.mode();
        // The modes with a health check (`supervision.rs`) and the torque a seeded observer
        // starts at (`Drive::supervise`): the controller's; a catch not yet seeded has none.
        let seed_load_nm = match &st.mode {
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
            #[cfg(feature = "injection")]
            ModeState::Inject => return self.inject_tick(st, cmd),
            ModeState::Catch(c) if !c.seeded() => None,
            ModeState::CatchZero(c) if !c.seeded() => None,
            ModeState::Catch(_) | ModeState::CatchZero(_) | ModeState::OpenLoop(_) => Some(0.0),
            ModeState::Sensorless(s) => Some(self.foc.torque_for_current(s.torque_current())),
        };
        st.last.close_millisecond(&self.schedule);
        let obs = &mut st.obs;
        self.primary.read_out(&mut obs.primary, ReadOut::Angle);
        self.monitor.read_out(&mut obs.monitor, ReadOut::Angle);
        obs.sample = AngleSample {
            theta_primary: self.primary.theta_e(&obs.primary),
            theta_monitor: self.monitor.theta_e(&obs.monitor),
        };
        self.primary.read_out(&mut obs.primary, ReadOut::Speed);
        self.monitor.read_out(&mut obs.monitor, ReadOut::Speed);
        let i_ab = st.i_ab_last;
        let cmd_rpm = cmd.speed_rpm;
        // The health check and the driving observer's estimate after it, once here for every
        // mode that has them (inlined: one copy in the task).
        let checked = seed_load_nm.map(|load_nm| {
            let health = self.supervise(obs, i_ab, load_nm);
            (health, self.driving_now(obs))
        });
        let next = match (&mut st.mode, checked) {
            (ModeState::Catch(c), Some((_, d))) => {
                let driving = obs.health.usable().then_some(d);
                self.catch.tick(c, &self.foc, driving, cmd_rpm)
            }
            (ModeState::CatchZero(c), Some((_, d))) => {
                let driving = obs.health.usable().then_some(d);
                self.catch_zero.tick(c, &self.foc, driving, cmd_rpm)
            }
            (ModeState::OpenLoop(ol), Some(((verdict, _), d))) => {
                let driving = obs.health.usable().then_some(d);
                self.open_loop
                    .tick(ol, &self.foc, verdict, driving, &obs.health, cmd_rpm)
            }
            (ModeState::Sensorless(s), Some((health, d))) => {
                let applied = st.last.applied(&self.foc);
                if health.0 == Verdict::Drive {
                    // The flux linkage or the resistance from the back-EMF while the driving
                    // observer is locked (`adaptation.rs`), checked after the task (`background`).
                    obs.model.keep(adaptation::Pending {
                        sample: (i_ab, applied.v_ab),
                        omega_m: d.omega_m,
                        i_q_ref_a: s.i_q_ref(),
                    });
                } else {
                    st.speed_gain.restart(health.0 == Verdict::Switched);
                }
                let [r_primary, r_monitor] = obs.health.residuals();
                let residual = match obs.health.driving {
                    Role::Primary => r_primary,
                    Role::Monitor => r_monitor,
                };
                (self.sensorless).tick(
                    s,
                    &self.foc,
                    (health, residual),
                    d,
                    cmd_rpm,
                    applied,
                    i_ab,
                    &mut st.speed_gain,
                )
            }
            // A catch not yet seeded (no check); the other modes returned above.
            _ => Next::Stay,
        };
        let reason = match next {
            Next::Stay => return None,
            Next::Note(reason) => reason,
            Next::Sensorless(entry, reason) => {
                st.mode = ModeState::Sensorless(self.sensorless.enter(&self.foc, entry));
                st.speed_gain.restart(false);
                reason
            }
            Next::OpenLoop {
                frame,
                omega_m,
                i_q_a,
            } => {
                let ol = self.open_loop.at(&self.foc, frame, omega_m, i_q_a);
                st.mode = ModeState::OpenLoop(ol);
                Reason::HandBack
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
        let d = self.driving_now(&st.obs);
        let entry = mode::Entry {
            omega_m: rotor.omega_m,
            i_dq: Dq::new(0.0, i_q),
            load_nm: d.load_nm,
            ref_omega_m: rotor.omega_m,
        };
        st.mode = ModeState::Sensorless(self.sensorless.enter(&self.foc, entry));
        st
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
        input: &DriveInput,
        i_ab: AlphaBeta,
        cmd_rpm: f32,
        observers_ok: bool,
    ) -> (Option<crate::svpwm::Duties>, Option<Reason>) {
        let v_bus = input.v_bus;
        let outcome = match &mut st.mode {
            ModeState::Sensorless(s) if observers_ok => {
                let (frame, frame_out, _, _) = self.driving(&st.obs, s.out_rot());
                Outcome::Run(self.sensorless.step(s, frame, frame_out, v_bus))
            }
            ModeState::Sensorless(_) => Outcome::Fault(Fault::ObserverLoss),
            ModeState::OpenLoop(ol) => Outcome::Run(self.open_loop.step(ol)),
            // The catch and the alignment: out of line, off the running drive's path.
            ModeState::Catch(_) | ModeState::CatchZero(_) | ModeState::Align(_) => {
                self.starting(st, input, i_ab, cmd_rpm, observers_ok)
            }
            #[cfg(feature = "injection")]
            ModeState::Inject => self.starting(st, input, i_ab, cmd_rpm, observers_ok),
            // Not running: `Drive::step` does not call this in these modes.
            ModeState::Idle
            | ModeState::Fault(_)
            | ModeState::Calibrate
            | ModeState::Identify
            | ModeState::Identified => return (None, None),
        };
        let (request, reason) = match outcome {
            Outcome::Run(request) => (request, None),
            Outcome::Switch(request, mode, reason) => {
                cold_path();
                st.mode = mode;
                (request, Some(reason))
            }
            Outcome::Fault(f) => return (None, Some(enter_fault(st, f))),
            Outcome::Off(reason) => return (None, reason),
        };
        let out = self.foc.run(&mut st.current, &request, i_ab, v_bus);
        st.last.record(&out, v_bus, self.delay_periods);
        (Some(out.duties), reason)
    }

    /// The safe state the drive holds the stage in while faulted (`safe_state.rs`): every
    /// switch off, or the active short circuit where the fault and the motor allow it.
    pub fn safe_state(&self, st: &StateOf<P, M>) -> Option<SafeState> {
        st.fault().map(|f| self.safe_state.for_fault(f))
    }

    /// The safe state this drive chooses for `fault` on its motor (`safe_state.rs`).
    pub fn safe_state_for(&self, fault: Fault) -> SafeState {
        self.safe_state.for_fault(fault)
    }
}

impl<P: Observer, M: Observer> Drive<P, M> {
    /// The step of the catch (PWM off on the terminal voltage, or the currents regulated to
    /// zero without it) and of the alignment (watching for a rotor the current does not
    /// hold). Out of line: the running drive's step stays short.
    #[inline(never)]
    fn starting(
        &self,
        st: &mut StateOf<P, M>,
        input: &DriveInput,
        i_ab: AlphaBeta,
        cmd_rpm: f32,
        observers_ok: bool,
    ) -> Outcome {
        let v_terminal = input.v_ab_terminal;
        match &mut st.mode {
            ModeState::Catch(c) => {
                // PWM off; the observers ran on the terminal voltage (their update refuses a
                // non-finite one), checked before the catch reads it (`protection.rs`).
                if !protection::terminal_valid(&self.limits, v_terminal) {
                    return Outcome::Fault(Fault::InvalidInput);
                }
                let Some(v_ab) = v_terminal else {
                    // The terminal voltage no longer sensed (a board's dividers clipped): the
                    // catch goes on with the currents regulated to zero.
                    st.mode = ModeState::CatchZero(CatchZero::default());
                    st.watch = catch_zero::Watch::default();
                    return Outcome::Off(None);
                };
                st.last.record_off(self.catch.next_period(c, v_ab));
                match self.catch.step(c, v_ab) {
                    Seen::AtRest => {
                        st.mode = self.at_rest();
                        return Outcome::Off(Some(Reason::AtRest));
                    }
                    Seen::Rotor(rotor) => self.seed_caught(&mut st.obs, i_ab, rotor),
                    Seen::Wait => {}
                }
                if observers_ok {
                    Outcome::Off(None)
                } else {
                    Outcome::Fault(Fault::InvalidInput)
                }
            }
            ModeState::CatchZero(_) if !observers_ok => Outcome::Fault(Fault::ObserverLoss),
            ModeState::CatchZero(c) => {
                match self
                    .catch_zero
                    .probe(c, &mut st.watch, i_ab, st.last.v_ab())
                {
                    Probe::Run(request) => Outcome::Run(request),
                    Probe::AtRest => {
                        st.mode = self.at_rest();
                        st.watch = catch_zero::Watch::default();
                        Outcome::Off(Some(Reason::AtRest))
                    }
                    Probe::Rotor(rotor, request) => {
                        let driven = c.is_driven();
                        self.caught_probe(st, i_ab, rotor, cmd_rpm, driven, request)
                    }
                }
            }
            ModeState::Align(a) => {
                // A rotor the current does not hold: caught, then closed loop.
                self.catch_zero.watch(&mut st.watch, i_ab, st.last.v_ab());
                let turning = st.watch.turn().abs() >= catch_zero::TURN_ALIGN;
                let (request, done) = self.align.step(a, i_ab, st.last.v_ab());
                if turning {
                    cold_path();
                    let c = CatchZero::driven();
                    Outcome::Switch(request, ModeState::CatchZero(c), Reason::Turning)
                } else if done {
                    cold_path();
                    // The resistance of this start: taken if plausible, else the model's kept
                    // and the refusal reported; a winding that did not carry the current
                    // refuses the start (`adaptation.rs`).
                    let r_ohm = match self.align.resistance(a) {
                        Measured::NotFollowed => {
                            st.resistance_refused = None;
                            return Outcome::Fault(Fault::OpenWinding);
                        }
                        Measured::NotAtRest => None,
                        Measured::Ohm(r) => Some(r),
                    };
                    let taken = self.adaptation.take_resistance(&mut st.obs.model, r_ohm);
                    st.resistance_refused = taken.err();
                    let reason = match taken {
                        Ok(()) => Reason::Aligned,
                        Err(_) => Reason::ResistanceRefused,
                    };
                    // Rotor at θ_e = 0, at rest: start the observers there, both locked.
                    self.seed_observers(&mut st.obs, Seed::BOTH, i_ab, Rotor::default());
                    st.obs.health = Health::AT_KNOWN_STATE;
                    Outcome::Switch(request, ModeState::OpenLoop(OpenLoop::AT_REST), reason)
                } else {
                    Outcome::Run(request)
                }
            }
            #[cfg(feature = "injection")]
            ModeState::Inject => match &self.inject {
                Ok(settings) => {
                    let (s, current) = (&mut st.inject, &mut st.current);
                    Outcome::Run(settings.step(s, &self.foc, current, i_ab, input.v_bus))
                }
                Err(_) => Outcome::Fault(Fault::InvalidInput),
            },
            // `control` calls this in the modes above only.
            _ => Outcome::Off(None),
        }
    }
}

impl<P: Observer, M: Observer> Drive<P, M> {
    /// The probe saw the rotor `rotor` (`i_ab` the currents now \[A], `request` this step's
    /// voltage): a rotor turning with the command waits at zero current for an observer to
    /// lock on its own evidence; one turning against the command `cmd_rpm` \[rpm], or
    /// `driven` by a load (seen turning in the alignment), is taken over in closed loop now,
    /// the observers trusted at the probe's estimate (as at the aligned rotor) and the speed
    /// reference from zero (`Entry::reference`): a load is fought within the current limit,
    /// not left to drag the rotor while the observers lock.
    // Out of line, like the other mode changes: once per start.
    #[inline(never)]
    fn caught_probe(
        &self,
        st: &mut StateOf<P, M>,
        i_ab: AlphaBeta,
        rotor: Rotor,
        cmd_rpm: f32,
        driven: bool,
        request: Request,
    ) -> Outcome {
        let backwards = against(rotor.omega_m, cmd_rpm);
        if !(driven || backwards) {
            self.seed_caught(&mut st.obs, i_ab, rotor);
            return Outcome::Run(request);
        }
        self.seed_observers(&mut st.obs, Seed::BOTH, i_ab, rotor);
        st.obs.health = Health::AT_KNOWN_STATE;
        let entry = Entry {
            omega_m: rotor.omega_m,
            i_dq: Dq::default(),
            load_nm: None,
            ref_omega_m: Entry::reference(rotor.omega_m, cmd_rpm),
        };
        let mode = ModeState::Sensorless(self.sensorless.enter(&self.foc, entry));
        let reason = if backwards {
            Reason::AgainstCommand
        } else {
            Reason::Caught
        };
        Outcome::Switch(request, mode, reason)
    }
}

impl<P: Observer, M: Observer> Drive<P, M> {
    /// A faulted state's safe state is the active short circuit (`safe_state.rs`).
    // Out of line: only a faulted step asks.
    #[inline(never)]
    fn short_circuit(&self, st: &StateOf<P, M>) -> bool {
        matches!(st.mode, ModeState::Fault(f) if self.safe_state.for_fault(f) == SafeState::ShortCircuit)
    }
}

/// Latches `fault`: PWM off until cleared.
fn enter_fault<PS, MS>(st: &mut DriveState<PS, MS>, fault: Fault) -> Reason {
    cold_path();
    st.mode = ModeState::Fault(fault);
    Reason::Fault(fault)
}

impl<P: Observer, M: Observer> Drive<P, M> {
    /// The mode of a start from a rotor found at rest: the alignment, or with the feature
    /// `injection` on a salient motor the injection's start (`inject.rs`).
    #[inline(always)]
    fn at_rest(&self) -> ModeState {
        #[cfg(feature = "injection")]
        if self.inject.is_ok() {
            // `DriveState::inject` is fresh: every start restarts the state.
            return ModeState::Inject;
        }
        ModeState::Align(Align::default())
    }

    /// This drive, starting a rotor found at rest with the alignment and the open loop also
    /// on a salient motor, where the drive built with the feature `injection` starts it
    /// through high-frequency injection (`inject.rs`): [`Drive::injection`] then says
    /// `Declined::TurnedOff`.
    #[cfg(feature = "injection")]
    pub fn without_injection(mut self) -> Self {
        self.inject = Err(Declined::TurnedOff);
        self
    }

    /// Whether this drive starts a rotor at rest through high-frequency injection (feature
    /// `injection`, `inject.rs`: on a salient motor, unless [`Drive::without_injection`]), or
    /// why not: turned off, a motor without the saliency, ...; it then starts with the
    /// alignment and the open loop.
    #[cfg(feature = "injection")]
    pub fn injection(&self) -> Result<(), Declined> {
        self.inject.map(|_| ())
    }

    /// The injection start's 1 kHz work: its speed loop, and the hand-over to sensorless
    /// control with the observers seeded at its rotor state.
    #[cfg(feature = "injection")]
    #[inline(never)]
    fn inject_tick(&self, st: &mut StateOf<P, M>, cmd: &Command) -> Option<Transition> {
        let from = st.mode();
        let (ModeState::Inject, Ok(settings)) = (&st.mode, &self.inject) else {
            return None;
        };
        st.last.close_millisecond(&self.schedule);
        if st.inject.phase() == crate::injection::Phase::Unresolved {
            // The magnet's direction not resolved (`injection.rs`): today's start. (The
            // injection's state fresh again: a later start at rest begins it anew.)
            st.mode = ModeState::Align(Align::default());
            st.current = crate::foc::CurrentLoopState::default();
            st.inject = inject::Inject::default();
            return Some(Transition {
                from,
                to: st.mode(),
                reason: Reason::AtRest,
            });
        }
        let s = &mut st.inject;
        let mtpa = self.sensorless.mtpa.as_ref();
        let Next::Sensorless(entry, reason) = settings.tick(s, &self.foc, mtpa, cmd.speed_rpm)
        else {
            return None;
        };
        let (theta_e, _) = s.estimate();
        let rotor = Rotor {
            theta_e,
            omega_m: entry.omega_m,
            load_nm: 0.0,
        };
        self.seed_observers(&mut st.obs, Seed::BOTH, st.i_ab_last, rotor);
        st.obs.health = Health::AT_KNOWN_STATE;
        st.mode = ModeState::Sensorless(self.sensorless.enter(&self.foc, entry));
        Some(Transition {
            from,
            to: st.mode(),
            reason,
        })
    }
}
