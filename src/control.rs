//! The control loop every image runs: one drive, its state and its power stage ([`Control`]);
//! the step (sample, [`Drive::step`], apply, events out), the drive's 1 kHz task when due
//! ([`DriveState::tick_due`], [`Drive::tick`]), the user's commands ([`Commands`]) in and the
//! events ([`Stepped`], [`Ticked`]: transitions, a telemetry record every N steps, the
//! identified motor) out. No registers, no log: the firmware images and the host simulator
//! call it and log or queue what it returns.
//!
//! Two ways to run it:
//! - one context ([`Control::run`]: the step, then the tick when due and the drive's slower
//!   work after it, [`Drive::background`]): the emulated M4F's image, the host simulator;
//! - the tick preempted by the step (the B-G431B-ESC1: the step in the ADC interrupt, the tick
//!   in an interrupt of lower priority): [`Control::step`] in the step's context and a
//!   [`TickCopy`] in the tick's, which runs [`Drive::tick`] on a copy of the state taken
//!   between two steps and puts it back only if no step ran meanwhile. The step is held off
//!   only while the state is copied (two short critical sections, the board's), never for a
//!   whole tick, and the tick still acts between two steps, as [`Drive::tick`] requires.
//!   Its [`Drive::background`] runs on such a copy too ([`TickCopy::background`], take,
//!   tick, background, give), after the task.
//!
//! [`DriveState::tick_due`]: crate::drive::DriveState::tick_due

use crate::drive::{Command, Drive, Identified, StateOf, Telemetry, Transition};
use crate::frames::Abc;
use crate::observer::Observer;
use crate::power_stage::PowerStage;

/// What the user asks for: read by each step and each tick.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Commands {
    /// Run (true) or stop switching (false); see [`Command::enable`].
    pub enable: bool,
    /// Speed command [rpm, mechanical].
    pub speed_rpm: f32,
    /// Clear a latched fault: taken by the step ([`Command::clear_fault`]), not by the tick.
    pub clear_fault: bool,
    /// Start the identification from idle ([`Drive::start_identification`]): taken by the
    /// tick; without the feature `identify` nothing is started.
    pub identify: bool,
}

impl Commands {
    /// The drive's command of this step or tick.
    #[inline(always)]
    fn drive(&self) -> Command {
        Command {
            enable: self.enable,
            speed_rpm: self.speed_rpm,
            clear_fault: self.clear_fault,
        }
    }
}

/// A telemetry record: the drive's log record with the sample it was taken on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Record {
    /// [`Drive::telemetry`] after the step.
    pub telemetry: Telemetry,
    /// The step's phase currents \[A].
    pub i_abc: Abc,
    /// The step's bus voltage \[V].
    pub v_bus: f32,
}

/// What one step reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stepped {
    /// The step's number: steps before it since the control was built (wraps at 2³²).
    pub step: u32,
    /// The step's mode change.
    pub transition: Option<Transition>,
    /// Every [`Control::with_telemetry_every`] steps (the first step's included): the record.
    pub record: Option<Record>,
    /// The drive's 1 kHz task is due now ([`Control::tick`], or a [`TickCopy`]).
    pub tick_due: bool,
}

/// What one 1 kHz task reports.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Ticked {
    /// The identification's start, on the [`Commands::identify`] request.
    pub started: Option<Transition>,
    /// The task's mode change (or change of the driving observer).
    pub transition: Option<Transition>,
    /// The identified motor, with the transition that ended the identification (the
    /// commissioning firmware writes its motor file from it).
    pub identified: Option<Identified>,
}

impl Ticked {
    /// The task's transitions, in order: the identification's start, then the task's own.
    pub fn transitions(&self) -> impl Iterator<Item = Transition> {
        [self.started, self.transition].into_iter().flatten()
    }
}

/// The drive on its power stage: everything the step owns.
pub struct Control<P: Observer, M: Observer, S> {
    drive: Drive<P, M>,
    state: StateOf<P, M>,
    stage: S,
    /// Steps done (wraps).
    steps: u32,
    /// A record every this many steps (0: none).
    record_every: u32,
    /// Steps until the next record (0: this one's).
    to_record: u32,
}

impl<P: Observer, M: Observer, S> Control<P, M, S> {
    /// The drive `drive` on `stage`, idle, no step done, no telemetry record.
    pub fn new(drive: Drive<P, M>, stage: S) -> Self {
        Self {
            drive,
            state: StateOf::<P, M>::default(),
            stage,
            steps: 0,
            record_every: 0,
            to_record: 0,
        }
    }

    /// The same from the state `state` (e.g. [`Drive::running_state`]).
    pub fn with_state(self, state: StateOf<P, M>) -> Self {
        Self { state, ..self }
    }

    /// Puts `drive` in place of the control's (new settings, a motor loaded or identified),
    /// from the idle state unless `keep_state` (settings changed while the drive runs, which
    /// leave its state valid); the stage, the step count and the records stay. Between two
    /// steps only.
    pub fn set_drive(&mut self, drive: Drive<P, M>, keep_state: bool) {
        self.drive = drive;
        if !keep_state {
            self.state = StateOf::<P, M>::default();
        }
    }

    /// A telemetry record ([`Stepped::record`]) every `steps` steps, from the next step on
    /// (0: none).
    pub fn with_telemetry_every(self, steps: u32) -> Self {
        Self {
            record_every: steps,
            to_record: 0,
            ..self
        }
    }

    /// The drive.
    pub fn drive(&self) -> &Drive<P, M> {
        &self.drive
    }

    /// The drive's state.
    pub fn state(&self) -> &StateOf<P, M> {
        &self.state
    }

    /// The power stage.
    pub fn stage(&self) -> &S {
        &self.stage
    }

    /// The power stage, e.g. for a simulator's plant or a board's end of the step.
    #[inline(always)]
    pub fn stage_mut(&mut self) -> &mut S {
        &mut self.stage
    }

    /// Steps done since the control was built (wraps at 2³²).
    #[inline(always)]
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// [`Drive::telemetry`] of the state now.
    pub fn telemetry(&self) -> Telemetry {
        self.drive.telemetry(&self.state)
    }

    /// The drive's 1 kHz task on the state, in place: call it when [`Stepped::tick_due`]
    /// says, never while a step runs, and [`Control::background`] after it, before the next
    /// step (one context: [`Control::run`]; a step that preempts its tick: [`TickCopy`]).
    pub fn tick(&mut self, cmd: &Commands) -> Ticked {
        tick(&self.drive, &mut self.state, cmd)
    }

    /// [`Drive::background`]: the task's slower work, after the task.
    pub fn background(&mut self) {
        self.drive.background(&mut self.state);
    }
}

impl<P: Observer, M: Observer, S: PowerStage> Control<P, M, S> {
    /// One control period: the stage's sample, [`Drive::step`], its duties (or PWM off)
    /// applied, the events. Inlined into its caller, with [`Drive::step`]: a firmware puts
    /// the whole step into its interrupt's code (the B-G431B-ESC1: into CCM SRAM).
    #[inline(always)]
    pub fn step(&mut self, cmd: &Commands) -> Stepped {
        let input = self.stage.sample();
        let out = self.drive.step(&mut self.state, &input, &cmd.drive());
        if out.short_circuit {
            self.stage.short_circuit();
        } else {
            self.stage.apply(out.duties);
        }
        self.stage.brake(out.brake);
        let step = self.steps;
        self.steps = step.wrapping_add(1);
        let record = if self.to_record > 0 {
            self.to_record -= 1;
            None
        } else if self.record_every > 0 {
            self.to_record = self.record_every - 1;
            Some(Record {
                telemetry: self.drive.telemetry(&self.state),
                i_abc: input.i_abc,
                v_bus: input.v_bus,
            })
        } else {
            None
        };
        Stepped {
            step,
            transition: out.transition,
            record,
            tick_due: self.state.tick_due(),
        }
    }

    /// One period in one context: [`Control::step`], then [`Control::tick`] and
    /// [`Control::background`] when due (the default [`Ticked`], nothing, when not).
    pub fn run(&mut self, cmd: &Commands) -> (Stepped, Ticked) {
        let stepped = self.step(cmd);
        let ticked = if stepped.tick_due {
            let ticked = self.tick(cmd);
            self.background();
            ticked
        } else {
            Ticked::default()
        };
        (stepped, ticked)
    }
}

/// The drive's 1 kHz task for an image whose step preempts it: [`Drive::tick`] on a copy of
/// the control's state, so that the step can run while the task computes, and the task still
/// acts between two steps.
///
/// In the tick's context: [`TickCopy::take`] with the step held off (a critical section:
/// one copy of the state, a few hundred cycles), then [`TickCopy::tick`] and
/// [`TickCopy::background`] with the step free to run, then [`TickCopy::give`] with the step
/// held off again (the same copy back). If a
/// step ran between take and give, give refuses (the copy is stale) and the caller takes
/// again: the task then acts after that step, as a late tick always did.
pub struct TickCopy<P: Observer, M: Observer> {
    /// The control's drive, copied (it never changes once built: step and tick take it by
    /// `&self`).
    drive: Drive<P, M>,
    state: StateOf<P, M>,
    /// The control's step count at the take.
    steps: u32,
}

impl<P: Observer, M: Observer> TickCopy<P, M> {
    /// The task of `control`'s drive (a copy of it).
    pub fn new<S>(control: &Control<P, M, S>) -> Self
    where
        Drive<P, M>: Clone,
    {
        Self {
            drive: control.drive.clone(),
            state: control.state,
            steps: control.steps,
        }
    }

    /// Copies `control`'s state. Only while no step can run.
    pub fn take<S>(&mut self, control: &Control<P, M, S>) {
        self.state = control.state;
        self.steps = control.steps;
    }

    /// [`Drive::tick`] (and the identification's start) on the copy; the step may run
    /// meanwhile.
    pub fn tick(&mut self, cmd: &Commands) -> Ticked {
        tick(&self.drive, &mut self.state, cmd)
    }

    /// [`Drive::background`] on the copy: the task's slower work, after the task and before
    /// the give (a firmware runs it after every task, or the motor model does not adapt and
    /// the speed loop's checks wait).
    pub fn background(&mut self) {
        self.drive.background(&mut self.state);
    }

    /// The step count at the last take: the steps done before this task.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Puts the ticked copy back into `control` if no step ran since the take (returns
    /// true); else leaves `control` as it is (false: take and tick again). Only while no step
    /// can run.
    pub fn give<S>(&self, control: &mut Control<P, M, S>) -> bool {
        let fresh = control.steps == self.steps;
        if fresh {
            control.state = self.state;
        }
        fresh
    }
}

/// The 1 kHz task: the identification's start when asked, [`Drive::tick`], and the identified
/// motor when the identification ends.
fn tick<P: Observer, M: Observer>(
    drive: &Drive<P, M>,
    state: &mut StateOf<P, M>,
    cmd: &Commands,
) -> Ticked {
    #[cfg(feature = "identify")]
    let started = if cmd.identify {
        drive.start_identification(state)
    } else {
        None
    };
    #[cfg(not(feature = "identify"))]
    let started = None;
    let cmd = Command {
        clear_fault: false,
        ..cmd.drive()
    };
    let transition = drive.tick(state, &cmd);
    Ticked {
        started,
        transition,
        identified: transition.and_then(|_| state.identified()),
    }
}
