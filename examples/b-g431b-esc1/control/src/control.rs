//! The drive's two tasks on this board, on the core's shared control loop
//! (`pmsm_sensorless::control`): the step in the ADC's interrupt (`ADC1_2`, the highest
//! priority, 4 kHz) and the drive's 1 kHz task in a spare interrupt below it ([`TICK_IRQ`],
//! pended by the step when the task is due); the commands the main loop gives them.
//!
//! # The two priorities
//!
//! The step owns the control (the drive, its state, the power stage), the watchdog and its
//! event queue; the task owns a [`TickCopy`] and its own queue. `Drive::tick` must never run
//! in the middle of a step, and the step must not wait for a whole task: the task runs on a
//! copy of the state. It takes the copy with interrupts off (`take`, one copy of the drive's
//! state), runs `Drive::tick` and its slower work after it, `Drive::background` (the motor
//! model's check), on it with interrupts on (the step preempts them freely), and puts it back
//! with interrupts off again (`give`, the same copy) if no step ran since the take; else it takes again, and so acts after that
//! step, as a late task always did. The task is pended at the end of every fourth step and
//! runs right after it (tail-chained), about 10 µs before the next step is due 250 µs later:
//! a retry needs the task held off for some 230 µs by something else (the main loop's
//! critical sections, each one defmt frame), and is counted in the log.
//!
//! Latency: the step waits at most for one of those two copies (a few hundred cycles, some
//! 2-3 µs at 170 MHz), where it waited for a whole `Drive::tick` (up to 1500 cycles, 9 µs)
//! when the main loop ran the task in a critical section; the main loop's own critical
//! sections (defmt-rtt's) are as before.

use core::cell::RefCell;
use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

use cortex_m::interrupt::Mutex;
use cortex_m::peripheral::NVIC;
use pmsm_sensorless::control::{Commands, TickCopy};
use pmsm_sensorless::drive::Reason;
use stm32g4::stm32g431::{interrupt, Interrupt};

use crate::power_stage::Esc1;
use crate::protection::{Watchdog, TICK_ALIVE};
use crate::telemetry::{Event, Sender, TELEMETRY_EVERY};
use pmsm_b_g431b_esc1::config::SETTINGS;
use pmsm_b_g431b_esc1::drive_settings::{BoardDrive, Monitor, Primary};

/// The step's interrupt: ADC1 end of injected sequence (ADC1 and ADC2 share the vector).
pub const STEP_IRQ: Interrupt = Interrupt::ADC1_2;
/// The 1 kHz task's interrupt: SPI3's vector, pended by software only (SPI3 is not used on
/// this board, its interrupt sources stay disabled).
pub const TICK_IRQ: Interrupt = Interrupt::SPI3;
/// NVIC priorities (the STM32G4 implements the top 4 bits; lower is more urgent): the step
/// preempts the task.
pub const STEP_PRIORITY: u8 = 0x00;
/// See [`STEP_PRIORITY`].
pub const TICK_PRIORITY: u8 = 0x10;

// -------------------------------------------------------------------------------------------
// Command path
// -------------------------------------------------------------------------------------------

/// Run command, written by the main loop (button, link), read by both interrupts.
pub static ENABLE: AtomicBool = AtomicBool::new(false);
/// Clear-fault request, set by the main loop, consumed (swapped to false) by the step.
pub static CLEAR_FAULT: AtomicBool = AtomicBool::new(false);
/// Control steps done, for the main loop's timing.
pub static STEPS: AtomicU32 = AtomicU32::new(0);
/// Identification request (the user button held, the link), set by the main loop, consumed
/// by the 1 kHz task: the drive measures the motor from idle (issue #19).
pub static IDENTIFY: AtomicBool = AtomicBool::new(false);
/// 1 kHz tasks taken again because a step ran while they computed (see the module's doc).
pub static TICK_RETRIES: AtomicU32 = AtomicU32::new(0);
/// The speed command of the last step, derated by the temperature [rpm] (f32 bits): the
/// 1 kHz task's command.
pub static SPEED_RPM: AtomicU32 = AtomicU32::new(0);
/// The power stage's temperature at the last step [°C] (f32 bits), for the log.
pub static STAGE_TEMP_C: AtomicU32 = AtomicU32::new(0);
/// The speed command before the temperature derating [rpm, mechanical] (f32 bits), read by
/// the step. Without feature `link` it starts at the constant
/// `drive_settings::SPEED_CMD_RPM` (the button's); with it at 0, written by the link
/// (`firmware/src/link.rs`). In both the servo input writes it while it is armed (main loop).
pub static SPEED_CMD: AtomicU32 = AtomicU32::new(SPEED_CMD_START_RPM.to_bits());

/// [`SPEED_CMD`]'s value at reset: the link's firmware runs no motor until told.
#[cfg(feature = "link")]
const SPEED_CMD_START_RPM: f32 = 0.0;
/// [`SPEED_CMD`]'s value at reset: the compiled-in command.
#[cfg(not(feature = "link"))]
const SPEED_CMD_START_RPM: f32 = pmsm_b_g431b_esc1::drive_settings::SPEED_CMD_RPM;

/// Drives put in place since the start (`set_drive`, with interrupts off): the 1 kHz task's
/// copy is of the drive of the generation it holds, and copies the new one when it changed.
static GENERATION: AtomicU32 = AtomicU32::new(0);

/// The core's control loop on this board's power stage.
type BoardControl = pmsm_sensorless::control::Control<Primary, Monitor, Esc1>;

/// The step's context, installed by [`start`]; the task reaches it for its two copies, with
/// interrupts off. A reference to a `singleton!` (zeroed `.bss`): an `Option<Control>` itself
/// would start as a `None` that is not all zeros and take its whole size of flash for the
/// initial value.
static CONTROL: Mutex<RefCell<Option<&'static mut Control>>> = Mutex::new(RefCell::new(None));
/// The task's context, installed by [`start`], moved into the task's interrupt on its first
/// run.
static TICK: Mutex<RefCell<Option<&'static mut Tick>>> = Mutex::new(RefCell::new(None));

/// Everything the step's interrupt owns.
pub struct Control {
    control: BoardControl,
    watchdog: Watchdog,
    events: Sender,
}

impl Control {
    pub fn new(drive: BoardDrive, stage: Esc1, watchdog: Watchdog, events: Sender) -> Self {
        Self {
            control: BoardControl::new(drive, stage).with_telemetry_every(TELEMETRY_EVERY),
            watchdog,
            events,
        }
    }

    /// One control period: the shared step (read the samples, step the drive, load the
    /// timer), its events queued, the task pended when due.
    ///
    /// Runs from CCM SRAM (`.ramfunc`, ramfunc.x), with the shared step, `Drive::step` and
    /// everything they inline (observers, FOC, SVPWM) inlined into it: flash needs 4 wait
    /// states at 170 MHz and the ART's 1 KiB instruction cache cannot hold the ~9 KiB step.
    /// The sliding observer's sin/cos table sits beside it; `math::sin_cos` and the other cold
    /// paths (mode changes, far angle wraps, the telemetry record) stay in flash. The board's
    /// parts of the step (sample, apply, queue, watchdog) are `#[inline(always)]` for the same
    /// reason. An overrun is reported to the drive (it faults with `Overrun`).
    // Not `unsafe`, but `#[link_section]` trips the `unsafe_code` lint: the section is one
    // ramfunc.x defines and `load_ramfunc` fills before the interrupt is enabled.
    #[link_section = ".ramfunc.control_step"]
    #[inline(never)]
    pub fn step(&mut self) {
        // The speed command derated by the power stage's temperature (`ntc`), shared with
        // the 1 kHz task.
        let stage = self.control.stage();
        let speed_rpm = f32::from_bits(SPEED_CMD.load(Ordering::Relaxed)) * stage.speed_scale();
        SPEED_RPM.store(speed_rpm.to_bits(), Ordering::Relaxed);
        STAGE_TEMP_C.store(stage.temp_c().to_bits(), Ordering::Relaxed);
        let cmd = Commands {
            enable: ENABLE.load(Ordering::Relaxed),
            speed_rpm,
            clear_fault: CLEAR_FAULT.swap(false, Ordering::Relaxed),
            identify: false,
        };
        if cmd.clear_fault {
            // The board's latched faults with the drive's.
            self.control.stage_mut().clear_faults();
        }
        let out = self.control.step(&cmd);
        if let Some(tr) = out.transition {
            // A start's resistance measurement refused: what was measured, for the log.
            let refused = (tr.reason == Reason::ResistanceRefused)
                .then(|| self.control.state().resistance_refused())
                .flatten();
            self.events.send(Event::Transition {
                step: out.step,
                tr,
                refused,
            });
        }
        if let Some(r) = out.record {
            self.events.send(Event::Telemetry {
                step: out.step,
                tel: r.telemetry,
                i_abc: r.i_abc,
                v_bus: r.v_bus,
            });
        }
        STEPS.store(self.control.steps(), Ordering::Relaxed);
        if out.tick_due {
            NVIC::pend(TICK_IRQ);
        }
        self.watchdog.feed();
        self.control.stage_mut().end_step();
    }
}

/// Everything the 1 kHz task's interrupt owns.
pub struct Tick {
    copy: TickCopy<Primary, Monitor>,
    events: Sender,
    /// The [`GENERATION`] of the drive the copy is of.
    generation: u32,
}

impl Tick {
    /// The task of `control`'s drive.
    pub fn new(control: &Control, events: Sender) -> Self {
        Self {
            copy: TickCopy::new(&control.control),
            events,
            generation: GENERATION.load(Ordering::Relaxed),
        }
    }

    /// The drive's 1 kHz task (`Drive::tick`: the observers' read-outs, the speed loop,
    /// supervision, the mode decisions) on a copy of the state (see the module's doc), and
    /// its events queued. In flash: it runs a thousand times a second, not four thousand.
    #[inline(never)]
    fn run(&mut self) {
        let cmd = Commands {
            enable: ENABLE.load(Ordering::Relaxed),
            speed_rpm: f32::from_bits(SPEED_RPM.load(Ordering::Relaxed)),
            clear_fault: false,
            // The commissioning and link firmware (`identify`) only.
            identify: cfg!(feature = "identify") && IDENTIFY.swap(false, Ordering::Relaxed),
        };
        let ticked = loop {
            let took = with_control(|ctl| {
                // A new drive since the last task: a copy of it.
                let gen = GENERATION.load(Ordering::Relaxed);
                if gen != self.generation {
                    self.copy = TickCopy::new(&ctl.control);
                    self.generation = gen;
                }
                self.copy.take(&ctl.control)
            });
            if took.is_none() {
                return;
            }
            let ticked = self.copy.tick(&cmd);
            // Its slower work (the motor model's check), on the copy before it is given back.
            self.copy.background();
            let gen = self.generation;
            if with_control(|ctl| {
                GENERATION.load(Ordering::Relaxed) == gen && self.copy.give(&mut ctl.control)
            }) == Some(true)
            {
                break ticked;
            }
            TICK_RETRIES.fetch_add(1, Ordering::Relaxed);
        };
        TICK_ALIVE.store(true, Ordering::Relaxed);
        let step = self.copy.steps();
        for tr in ticked.transitions() {
            self.events.send(Event::Transition {
                step,
                tr,
                refused: None,
            });
        }
        #[cfg(feature = "identify")]
        if let Some(motor) = ticked.identified {
            // Done: the motor file in the log; the drive back to idle.
            self.events.send(Event::Identified { step, motor });
            ENABLE.store(false, Ordering::Relaxed);
        }
    }
}

/// `f` on the step's context with interrupts off (the step held off); `None` before [`start`].
fn with_control<R>(f: impl FnOnce(&mut Control) -> R) -> Option<R> {
    cortex_m::interrupt::free(|cs| {
        // Never borrowed twice: the step's borrow is inside its own critical section, and the
        // step cannot run inside this one.
        let mut ctl = CONTROL.borrow(cs).try_borrow_mut().ok()?;
        ctl.as_mut().map(|ctl| f(ctl))
    })
}

#[cfg(feature = "link")]
/// Puts `drive` in place of the running control's (between two steps: interrupts off), from
/// idle unless `keep_state`; the 1 kHz task copies it at its next run. False before [`start`].
pub fn set_drive(drive: BoardDrive, keep_state: bool) -> bool {
    with_control(|ctl| {
        ctl.control.set_drive(drive, keep_state);
        GENERATION.fetch_add(1, Ordering::Relaxed);
    })
    .is_some()
}

/// Installs both contexts, sets the priorities and enables the two interrupts.
pub fn start(nvic: &mut NVIC, control: Control, tick: Tick) {
    let (Some(control), Some(tick)) = (
        cortex_m::singleton!(: Control = control),
        cortex_m::singleton!(: Tick = tick),
    ) else {
        defmt::panic!("control context taken twice");
    };
    cortex_m::interrupt::free(|cs| {
        CONTROL.borrow(cs).replace(Some(control));
        TICK.borrow(cs).replace(Some(tick));
    });
    NVIC::unpend(STEP_IRQ);
    NVIC::unpend(TICK_IRQ);
    // SAFETY: the handlers' contexts are installed above; changing priorities and unmasking
    // cannot break a critical section (none is active here), and these two are the only
    // interrupts enabled.
    unsafe {
        nvic.set_priority(STEP_IRQ, STEP_PRIORITY);
        nvic.set_priority(TICK_IRQ, TICK_PRIORITY);
        NVIC::unmask(TICK_IRQ);
        NVIC::unmask(STEP_IRQ);
    }
}

/// The step's interrupt ([`STEP_IRQ`], every PWM period: the ADCs convert at every update
/// event): [`Control::step`] on every `pwm_per_step`-th sample, the others' flags cleared.
#[interrupt]
fn ADC1_2() {
    // Samples to skip before the next step.
    static mut SKIP: u32 = 0;
    let step = *SKIP == 0;
    *SKIP = if step {
        SETTINGS.pwm_per_step - 1
    } else {
        *SKIP - 1
    };
    cortex_m::interrupt::free(|cs| {
        // Never borrowed twice (the task borrows it with interrupts off); no panic path
        // either way.
        if let Ok(mut ctl) = CONTROL.borrow(cs).try_borrow_mut() {
            if let Some(ctl) = ctl.as_mut() {
                if step {
                    ctl.step();
                } else {
                    ctl.control.stage().skip_sample();
                }
            }
        }
    });
}

/// The 1 kHz task's interrupt ([`TICK_IRQ`], pended by the step): [`Tick::run`].
#[interrupt]
fn SPI3() {
    static mut TASK: Option<&'static mut Tick> = None;
    if TASK.is_none() {
        *TASK = cortex_m::interrupt::free(|cs| TICK.borrow(cs).take());
    }
    if let Some(task) = TASK {
        task.run();
    }
}
