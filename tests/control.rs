//! The shared control loop (`pmsm_sensorless::control`): one period in one context is the
//! drive's step then its tick when due, bit for bit; the tick on a copy acts as the tick in
//! place, and a copy a step has made stale is refused; a telemetry record every N steps.

use pmsm_sensorless::control::{Commands, Control, TickCopy, Ticked};
use pmsm_sensorless::drive::{Command, Drive, DriveConfig, DriveInput, Mode, StateOf};
use pmsm_sensorless::frames::AlphaBeta;
use pmsm_sensorless::math::{sin_cos, wrap_pi};
use pmsm_sensorless::motor::HORNG_SINANO;
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;
use pmsm_sensorless::observer::Rotor;
use pmsm_sensorless::power_stage::PowerStage;
use pmsm_sensorless::svpwm::Duties;

type SinanoDrive = Drive<SlidingObserver, FluxPll>;
type Sinano = StateOf<SlidingObserver, FluxPll>;

fn sinano_drive() -> SinanoDrive {
    DriveConfig::new(&HORNG_SINANO)
        .build_sliding_primary()
        .unwrap()
}

/// Samples of a current vector turning at 1000 rpm (θ_e advancing 0.1047 rad per step) on a
/// 48 V bus; the duties applied are kept.
#[derive(Clone, Debug, Default)]
struct Turning {
    k: u32,
    duties: Option<Duties>,
}

impl PowerStage for Turning {
    fn sample(&mut self) -> DriveInput {
        let (s, c) = sin_cos(wrap_pi(0.3 + 0.10472 * self.k as f32));
        self.k += 1;
        DriveInput {
            i_abc: AlphaBeta::new(-0.5 * s, 0.5 * c).to_abc(),
            v_bus: 48.0,
            v_ab_terminal: None,
            overrun: false,
            stage_fault: None,
        }
    }

    fn apply(&mut self, duties: Option<Duties>) {
        self.duties = duties;
    }
}

fn enabled() -> Commands {
    Commands {
        enable: true,
        speed_rpm: 1000.0,
        ..Commands::default()
    }
}

/// Sensorless at 1000 rpm, both observers seeded.
fn running(drive: &SinanoDrive) -> Sinano {
    let rotor = Rotor {
        theta_e: 0.3,
        omega_m: 104.72,
        load_nm: 0.0,
    };
    drive.running_state(
        AlphaBeta::new(-0.5 * 0.3f32.sin(), 0.5 * 0.3f32.cos()),
        rotor,
    )
}

/// `Control::run` against the drive's own step, tick and background, from idle (the start's
/// transitions) and from sensorless control (the tick's work), 2000 steps each.
#[test]
fn run_is_the_step_then_the_tick_when_due() {
    let drive = sinano_drive();
    for start in [Sinano::default(), running(&drive)] {
        let mut control = Control::new(drive, Turning::default()).with_state(start);
        let (mut st, mut stage) = (start, Turning::default());
        let cmd = Command {
            enable: true,
            speed_rpm: 1000.0,
            clear_fault: false,
        };
        let mut transitions = 0;
        for k in 0..2000 {
            let (stepped, ticked) = control.run(&enabled());
            let input = stage.sample();
            let out = drive.step(&mut st, &input, &cmd);
            stage.apply(out.duties);
            let tick = if st.tick_due() {
                let tick = drive.tick(&mut st, &cmd);
                drive.background(&mut st);
                tick
            } else {
                None
            };
            assert_eq!(stepped.step, k);
            assert_eq!(stepped.transition, out.transition, "step {k}");
            assert_eq!(ticked.transition, tick, "step {k}");
            assert_eq!(control.state(), &st, "step {k}");
            assert_eq!(control.stage().duties, stage.duties, "step {k}");
            transitions += usize::from(out.transition.is_some()) + usize::from(tick.is_some());
        }
        assert!(transitions > 0 || start != Sinano::default());
    }
}

/// The tick on a copy taken after the step and given back before the next: the same state
/// and events as the tick in place, every millisecond of 500.
#[test]
fn a_tick_on_a_copy_acts_as_the_tick_in_place() {
    let drive = sinano_drive();
    for start in [Sinano::default(), running(&drive)] {
        let mut in_place = Control::new(drive, Turning::default()).with_state(start);
        let mut split = Control::new(drive, Turning::default()).with_state(start);
        let mut copy = TickCopy::new(&split);
        for k in 0..2000 {
            let (stepped, ticked) = in_place.run(&enabled());
            let stepped_split = split.step(&enabled());
            assert_eq!(stepped, stepped_split);
            let ticked_split = if stepped_split.tick_due {
                copy.take(&split);
                let ticked = copy.tick(&enabled());
                assert_eq!(copy.steps(), k + 1);
                // (The slower work after the task, on the copy before it is given back.)
                copy.background();
                assert!(copy.give(&mut split));
                ticked
            } else {
                Ticked::default()
            };
            assert_eq!(ticked, ticked_split, "step {k}");
            assert_eq!(in_place.state(), split.state(), "step {k}");
        }
        assert_eq!(split.state().mode(), in_place.state().mode());
    }
}

/// A step between the take and the give makes the copy stale: the give leaves the control
/// as the step left it; taken again, the tick acts after that step.
#[test]
fn a_copy_a_step_made_stale_is_refused() {
    let drive = sinano_drive();
    let mut control = Control::new(drive, Turning::default()).with_state(running(&drive));
    let mut copy = TickCopy::new(&control);
    let stepped = (0..4).map(|_| control.step(&enabled())).last().unwrap();
    assert!(stepped.tick_due);
    copy.take(&control);
    copy.tick(&enabled());
    control.step(&enabled());
    let stepped_only = *control.state();
    assert!(!copy.give(&mut control));
    assert_eq!(control.state(), &stepped_only);
    copy.take(&control);
    copy.tick(&enabled());
    assert!(copy.give(&mut control));
    assert_eq!(control.state().mode(), Mode::Sensorless);
}

/// Records on the first step and every Nth after it; none unless asked.
#[test]
fn a_record_every_n_steps() {
    let drive = sinano_drive();
    let mut control = Control::new(drive, Turning::default()).with_telemetry_every(3);
    let recorded: Vec<u32> = (0..10)
        .map(|_| control.step(&enabled()))
        .filter(|s| s.record.is_some())
        .map(|s| s.step)
        .collect();
    assert_eq!(recorded, [0, 3, 6, 9]);
    let mut quiet = Control::new(drive, Turning::default());
    assert!((0..10).all(|_| quiet.step(&enabled()).record.is_none()));
}

/// The step counts the steps since the last tick: in sensorless control, a tick late by up to
/// `TICKS_MISSED_MAX` runs is tolerated; without one the step after
/// `STEPS_WITHOUT_TICK_MAX` steps faults `TaskStall`, PWM off, latched. Idle, nothing counts.
#[test]
fn a_stalled_tick_is_a_task_stall_after_its_bound() {
    use pmsm_sensorless::drive::{Fault, Reason};
    use pmsm_sensorless::schedule::{SLOTS, STEPS_WITHOUT_TICK_MAX, TICKS_MISSED_MAX};
    assert_eq!(STEPS_WITHOUT_TICK_MAX, SLOTS * TICKS_MISSED_MAX);
    let drive = sinano_drive();
    // A late tick resets the count: 16 steps, a tick, 16 steps again.
    let mut control = Control::new(drive, Turning::default()).with_state(running(&drive));
    for _ in 0..2 {
        for _ in 0..STEPS_WITHOUT_TICK_MAX {
            assert!(control.step(&enabled()).transition.is_none());
            assert!(control.stage().duties.is_some());
        }
        control.tick(&enabled());
    }
    // Stalled: the next 16 steps switch, the 17th faults.
    let mut control = Control::new(drive, Turning::default()).with_state(running(&drive));
    for k in 1..=STEPS_WITHOUT_TICK_MAX {
        let stepped = control.step(&enabled());
        assert!(stepped.transition.is_none(), "step {k}");
        assert!(control.stage().duties.is_some(), "step {k}");
    }
    let stepped = control.step(&enabled());
    let tr = stepped.transition.expect("a fault");
    assert_eq!(
        (tr.from, tr.to, tr.reason),
        (
            Mode::Sensorless,
            Mode::Fault,
            Reason::Fault(Fault::TaskStall)
        )
    );
    assert!(control.stage().duties.is_none());
    // Latched: a tick now does not clear it.
    control.tick(&enabled());
    for _ in 0..10 {
        control.step(&enabled());
        assert!(control.stage().duties.is_none());
    }
    assert_eq!(control.state().fault(), Some(Fault::TaskStall));
    // Idle (enable low), no tick: no fault.
    let mut idle = Control::new(drive, Turning::default());
    for _ in 0..100 {
        idle.step(&Commands::default());
    }
    assert_eq!(idle.state().mode(), Mode::Idle);
}

/// A new drive put in place: from idle unless the state is kept; the steps counted go on.
#[test]
fn a_drive_put_in_place_starts_idle_or_keeps_the_state() {
    let drive = sinano_drive();
    let mut control = Control::new(drive, Turning::default()).with_state(running(&drive));
    (0..5).for_each(|_| {
        control.step(&enabled());
    });
    let mut faster = DriveConfig::new(&HORNG_SINANO);
    faster.speed_bandwidth_hz *= 2.0;
    let other = faster.build_sliding_primary().unwrap();
    let state = *control.state();
    control.set_drive(other, true);
    assert_eq!(control.state(), &state);
    assert_eq!(control.steps(), 5);
    control.set_drive(other, false);
    assert_eq!(control.state().mode(), Mode::Idle);
    assert_eq!(control.steps(), 5);
}
