//! The drive's running state ([`DriveState`]): the mode and the state it owns ([`ModeState`],
//! one variant per mode), the observers', the current loop's, the last period's, the arming
//! and the offsets; and what the outside reads of it.

use super::align::Align;
use super::applied::LastPeriod;
use super::catch::Catch;
use super::catch_zero::{CatchZero, Watch};
use super::identify::offset::Offsets;
#[cfg(feature = "identify")]
use super::identify::Identify;
use super::identify::{Identified, IdentifyPhase};
#[cfg(feature = "injection")]
use super::inject::Inject;
use super::io::{Fault, Mode, ResistanceRefused, Role};
use super::observers::ObserverStates;
use super::open_loop::OpenLoop;
use super::protection::Arming;
use super::sensorless::Sensorless;
use super::speed_gain;
use crate::foc::CurrentLoopState;
use crate::frames::{AlphaBeta, SinCos};
use crate::observer::Observer;
use crate::schedule::Schedule;

/// The running state of a [`Drive<P, M>`](super::Drive): `DriveState<P::State, M::State>`.
pub type StateOf<P, M> = DriveState<<P as Observer>::State, <M as Observer>::State>;

/// Running state of the drive (`PS`, `MS`: the primary's and the monitor's observer state).
/// `Default` is idle, armed.
#[derive(Clone, Copy, Debug, PartialEq)]
// In declaration order (C layout): what the running step reads first, the identification's
// state last, so that adding it does not move the hot fields' offsets.
#[repr(C)]
pub struct DriveState<PS, MS> {
    pub(super) mode: ModeState,
    /// The coming step's place in its millisecond: steps since the 1 kHz task,
    /// `0..steps_per_tick` ([`Schedule::next_slot`]).
    pub(super) slot: u8,
    /// Steps since the last run of the 1 kHz task, counted by the running modes' steps
    /// ([`DriveState::task_stalled`]), reset by [`Drive::tick`](super::Drive::tick): beyond
    /// [`Schedule::steps_without_tick_max`], `Fault::TaskStall`.
    pub(super) since_tick: u16,
    /// The up/down count of samples whose phase currents do not sum to zero
    /// (`plausibility.rs`): at its limit, `Fault::CurrentSensor`.
    pub(super) sum_count: u8,
    pub(super) obs: ObserverStates<PS, MS>,
    pub(super) current: CurrentLoopState,
    /// The currents of the last sample the observers took \[A].
    pub(super) i_ab_last: AlphaBeta,
    /// The current loop's last period and its voltage limit (`applied.rs`).
    pub(super) last: LastPeriod,
    /// No start after a cleared fault until the enable was low (`protection.rs`).
    pub(super) arming: Arming,
    /// The brake chopper's gate (`regen.rs`).
    pub(super) brake: bool,
    /// The current sensors' offsets measured with the PWM off (`identify/offset.rs`), taken
    /// off the identification's samples; an implausible one refuses the enable.
    pub(super) offsets: Offsets,
    /// Mode `Identify`'s state (`identify/`).
    #[cfg(feature = "identify")]
    pub(super) identify: Identify,
    /// The back-EMF watched in the alignment and the catch without terminal sensing
    /// (`catch_zero.rs`); last, so that it moves none of the fields before it.
    pub(super) watch: Watch,
    /// The last alignment's resistance measurement, if refused (`adaptation.rs`), for the
    /// log; kept across restarts like the model. After everything the step reads.
    pub(super) resistance_refused: Option<ResistanceRefused>,
    /// The speed loop's gain, kept across restarts, and sensorless control's checks of its
    /// oscillation (`speed_gain.rs`); after everything the step reads, so that it moves none
    /// of those fields (a measurement's state in the mode's took the step 20 cycles).
    pub(super) speed_gain: speed_gain::State,
    /// The injection start's state (`inject.rs`), in mode `ModeState::Inject`; last.
    #[cfg(feature = "injection")]
    pub(super) inject: Inject,
}

impl<PS: Default, MS: Default> Default for DriveState<PS, MS> {
    fn default() -> Self {
        Self {
            mode: ModeState::Idle,
            slot: 0,
            since_tick: 0,
            sum_count: 0,
            obs: ObserverStates::default(),
            current: CurrentLoopState::default(),
            i_ab_last: AlphaBeta::default(),
            last: LastPeriod::default(),
            arming: Arming::default(),
            brake: false,
            offsets: Offsets::default(),
            #[cfg(feature = "identify")]
            identify: Identify::new(),
            watch: Watch::default(),
            resistance_refused: None,
            speed_gain: speed_gain::State::default(),
            #[cfg(feature = "injection")]
            inject: Inject::default(),
        }
    }
}

impl<PS: Default, MS: Default> DriveState<PS, MS> {
    /// Starts afresh in `mode`, the adapted motor model, the offsets measured and the last
    /// alignment's refused resistance kept.
    // Out of line: a mode change (enable, disable, stop, clear), one copy for all of them.
    #[inline(never)]
    pub(super) fn restart(&mut self, mode: ModeState) {
        let (model, gain) = (self.obs.model, self.speed_gain.gain);
        *self = DriveState {
            mode,
            offsets: self.offsets.kept(),
            resistance_refused: self.resistance_refused,
            ..DriveState::default()
        };
        self.obs.model = model;
        self.speed_gain.gain = gain;
    }
}

impl<PS, MS> DriveState<PS, MS> {
    /// A step of a running mode, counted since the last run of the 1 kHz task: true when the
    /// count is beyond [`Schedule::steps_without_tick_max`] (the task has missed
    /// [`TICKS_MISSED_MAX`](crate::schedule::TICKS_MISSED_MAX) runs: it stalled).
    #[inline(always)]
    pub(super) fn task_stalled(&mut self, schedule: &Schedule) -> bool {
        self.since_tick = self.since_tick.saturating_add(1);
        self.since_tick > schedule.stall_steps()
    }

    /// The 1 kHz task ran: the count of [`DriveState::task_stalled`] starts again.
    #[inline(always)]
    pub(super) fn ticked(&mut self) {
        self.since_tick = 0;
    }

    /// The mode.
    pub fn mode(&self) -> Mode {
        match self.mode {
            ModeState::Idle => Mode::Idle,
            ModeState::Catch(_) | ModeState::CatchZero(_) => Mode::Catch,
            ModeState::Align(_) => Mode::Align,
            #[cfg(feature = "injection")]
            ModeState::Inject => Mode::Align,
            ModeState::OpenLoop(_) => Mode::OpenLoop,
            ModeState::Sensorless(_) => Mode::Sensorless,
            ModeState::Fault(_) => Mode::Fault,
            ModeState::Calibrate => Mode::Calibrate,
            ModeState::Identify => Mode::Identify,
            ModeState::Identified => Mode::Identified,
        }
    }

    /// What the identification has measured so far, also after it ended in an error (the
    /// measurements not reached are 0): for a report of how far it got. The results proper
    /// are [`DriveState::identified`].
    #[cfg(feature = "identify")]
    pub fn identified_so_far(&self) -> Identified {
        self.identify.result
    }

    /// The identified motor, once the identification is done (mode `Identified`).
    pub fn identified(&self) -> Option<Identified> {
        match self.mode {
            #[cfg(feature = "identify")]
            ModeState::Identified => Some(self.identify.result),
            #[cfg(not(feature = "identify"))]
            ModeState::Identified => None,
            ModeState::Idle
            | ModeState::Catch(_)
            | ModeState::CatchZero(_)
            | ModeState::Align(_)
            | ModeState::OpenLoop(_)
            | ModeState::Sensorless(_)
            | ModeState::Fault(_)
            | ModeState::Calibrate
            | ModeState::Identify => None,
            #[cfg(feature = "injection")]
            ModeState::Inject => None,
        }
    }

    /// The identification's running measurement, in mode `Identify`.
    pub fn identify_phase(&self) -> Option<IdentifyPhase> {
        match &self.mode {
            #[cfg(feature = "identify")]
            ModeState::Identify => Some(self.identify.which()),
            #[cfg(not(feature = "identify"))]
            ModeState::Identify => None,
            ModeState::Idle
            | ModeState::Catch(_)
            | ModeState::CatchZero(_)
            | ModeState::Align(_)
            | ModeState::OpenLoop(_)
            | ModeState::Sensorless(_)
            | ModeState::Fault(_)
            | ModeState::Calibrate
            | ModeState::Identified => None,
            #[cfg(feature = "injection")]
            ModeState::Inject => None,
        }
    }

    /// The current sensors' offsets the drive measured with the PWM off (while idle, or
    /// before an identification), in the stationary frame \[A]: taken off the
    /// identification's samples; a board that does not take its own offsets off its samples
    /// can take these.
    pub fn offset_ab(&self) -> AlphaBeta {
        self.offsets.ab()
    }

    /// The last alignment's stator-resistance measurement, if the drive refused it (beyond
    /// `R₀/3 ..= 3 R₀`, or none: the rotor not at rest): what was measured and the range. The
    /// drive kept the resistance it had ([`Telemetry::r_ohm`](super::Telemetry::r_ohm)); the
    /// transition out of that alignment said
    /// [`Reason::ResistanceRefused`](super::Reason::ResistanceRefused). Kept across restarts
    /// (stop, disable, a fault cleared) for the log; `None` once an alignment's measurement is
    /// taken or its current did not flow (`Fault::OpenWinding`), and before the first. Not in
    /// the telemetry record, which stays at its 64 bytes.
    pub fn resistance_refused(&self) -> Option<ResistanceRefused> {
        self.resistance_refused
    }

    /// The latched fault, if any.
    pub fn fault(&self) -> Option<Fault> {
        match self.mode {
            ModeState::Fault(f) => Some(f),
            ModeState::Idle
            | ModeState::Catch(_)
            | ModeState::CatchZero(_)
            | ModeState::Align(_)
            | ModeState::OpenLoop(_)
            | ModeState::Sensorless(_)
            | ModeState::Calibrate
            | ModeState::Identify
            | ModeState::Identified => None,
            #[cfg(feature = "injection")]
            ModeState::Inject => None,
        }
    }

    /// The slot of the coming step: steps since the 1 kHz task (0: the first after it).
    pub fn slot(&self) -> u8 {
        self.slot
    }

    /// The last step was the last of its millisecond (the `rate_hz/1000`-th): [`Drive::tick`](super::Drive::tick) is due now.
    pub fn tick_due(&self) -> bool {
        self.slot == 0
    }

    /// The voltage the last step's duties apply over the period \[V] (what the observers take
    /// next step), the inverter's dead time included ([`crate::foc::FocOutput::v_ab`]); zero
    /// before the first switching step.
    pub fn v_ab_applied(&self) -> AlphaBeta {
        self.last.v_ab()
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

    /// The injection's estimate in its start (feature `injection`, `inject.rs`): θ̂_e \[rad,
    /// electrical] and ω̂_e \[rad/s, electrical], and whether its polarity test is done.
    #[cfg(feature = "injection")]
    pub fn injection(&self) -> Option<(f32, f32, bool)> {
        match &self.mode {
            ModeState::Inject => {
                let i = &self.inject;
                let (theta, omega) = i.estimate();
                Some((theta, omega, i.phase() == crate::injection::Phase::Track))
            }
            _ => None,
        }
    }

    /// sin/cos of the open-loop angle θ_ol, in open loop.
    pub fn open_loop_frame(&self) -> Option<SinCos> {
        match &self.mode {
            ModeState::OpenLoop(ol) => Some(ol.frame()),
            ModeState::Idle
            | ModeState::Catch(_)
            | ModeState::CatchZero(_)
            | ModeState::Align(_)
            | ModeState::Sensorless(_)
            | ModeState::Fault(_)
            | ModeState::Calibrate
            | ModeState::Identify
            | ModeState::Identified => None,
            #[cfg(feature = "injection")]
            ModeState::Inject => None,
        }
    }
}

/// The mode and the state it owns. Every match on it lists every mode (no `_` arm): a new mode
/// does not compile until each place has decided what it does in it.
#[derive(Clone, Copy, Debug, PartialEq)]
// Without the feature `identify`, Calibrate, Identify and Identified are never entered.
#[cfg_attr(not(feature = "identify"), allow(dead_code))]
pub(super) enum ModeState {
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
    /// `DriveState::offsets`). Entered only with the feature `identify`.
    Calibrate,
    /// The identification's measurements (their state: `DriveState::identify`, kept out of
    /// this enum so that its size, which every mode change moves, stays the running modes').
    Identify,
    /// The identification's results (`DriveState::identify`), PWM off.
    Identified,
    /// Without terminal sensing: the currents regulated to zero, the observers on the
    /// commanded voltage (`catch_zero.rs`). Last, so that the variants before it keep the
    /// order of [`Mode`] and [`DriveState::mode`] stays a table look-up (6 cycles more in
    /// every step on the emulated Cortex-M4F otherwise).
    CatchZero(CatchZero),
    /// The start through high-frequency injection on a salient motor (`inject.rs`; feature
    /// `injection`), reported as [`Mode::Align`]. Last, after the variants of [`Mode`]'s order.
    #[cfg(feature = "injection")]
    Inject,
}
