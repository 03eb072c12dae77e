//! The interrupts → main-loop queues and the log (defmt over RTT): the control step queues its
//! events (every mode transition, a telemetry record at 10 Hz), the 1 kHz task its own (its
//! transitions, the identified motor), each in a queue of its own (one producer each); the
//! main loop logs both, in the order of their step stamps.

use core::sync::atomic::{AtomicU32, Ordering};

use defmt_rtt as _;
use heapless::spsc::{Consumer, Producer, Queue};
#[cfg(feature = "identify")]
use pmsm_sensorless::drive::Identified;
use pmsm_sensorless::drive::{Mode, ResistanceRefused, Telemetry, Transition};
use pmsm_sensorless::frames::Abc;

use pmsm_b_g431b_esc1::config::SETTINGS;
#[cfg(all(feature = "identify", not(feature = "link")))]
use pmsm_b_g431b_esc1::drive_settings::MOTOR;

/// One telemetry record every this many steps (400 steps = 10 Hz).
pub const TELEMETRY_EVERY: u32 = 400;
/// Capacity of the step → main-loop queue (one slot is kept free by heapless).
const STEP_QUEUE_LEN: usize = 16;
/// Capacity of the 1 kHz task → main-loop queue (transitions only: a few a second at most).
const TICK_QUEUE_LEN: usize = 8;

/// Records an interrupt could not queue (queue full).
static DROPPED: AtomicU32 = AtomicU32::new(0);

/// What the interrupts send to the main loop, stamped with the steps done before it.
pub enum Event {
    Telemetry {
        step: u32,
        tel: Telemetry,
        i_abc: Abc,
        v_bus: f32,
    },
    Transition {
        step: u32,
        tr: Transition,
        /// With `Reason::ResistanceRefused`: what the alignment measured and the range.
        refused: Option<ResistanceRefused>,
    },
    /// The identification's results: the motor file's lines (the commissioning firmware).
    #[cfg(feature = "identify")]
    Identified { step: u32, motor: Identified },
}

impl Event {
    /// Whether the drive is in `Fault` after this event.
    pub fn faulted(&self) -> bool {
        let mode = match self {
            Event::Telemetry { tel, .. } => tel.mode,
            Event::Transition { tr, .. } => tr.to,
            #[cfg(feature = "identify")]
            Event::Identified { .. } => Mode::Identified,
        };
        mode == Mode::Fault
    }

    /// The event's step stamp.
    fn step(&self) -> u32 {
        match self {
            Event::Telemetry { step, .. } | Event::Transition { step, .. } => *step,
            #[cfg(feature = "identify")]
            Event::Identified { step, .. } => *step,
        }
    }
}

/// The log line of an event.
impl defmt::Format for Event {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Event::Transition { step, tr, refused } => {
                defmt::write!(
                    f,
                    "t = {=f32} s: {} -> {} ({})",
                    seconds(*step),
                    tr.from,
                    tr.to,
                    tr.reason
                );
                if let Some(r) = refused {
                    defmt::write!(f, "; the model's resistance kept, refused: {}", r);
                }
            }
            // The motor file `pmsm-sim run --motor-file` loads (README, "Your motor"), with the
            // pole pairs and ratings of `MOTOR`.
            #[cfg(all(feature = "identify", not(feature = "link")))]
            Event::Identified { motor: m, .. } => defmt::write!(
                f,
                "identified motor file:\nname = \"identified\"\npole_pairs = {=u32}\nr_ohm = {=f32}\nl_h = {=f32}\nflux_wb = {=f32}\nj_kgm2 = {=f32}\nb_nms = {=f32}\n# l_d_h = {=f32}, l_q_h = {=f32}\n[ratings]\nbus_v = {=f32}\ncurrent_a = {=f32}\ntorque_nm = {=f32}\nspeed_rpm = {=f32}",
                MOTOR.params.pole_pairs,
                m.r_ohm,
                m.l_h(),
                m.flux_wb,
                m.j_kgm2,
                m.b_nms,
                m.l_d_h,
                m.l_q_h,
                MOTOR.ratings.bus_v,
                MOTOR.ratings.current_a,
                MOTOR.ratings.torque_nm,
                MOTOR.ratings.speed_rpm
            ),
            // The link firmware has no motor compiled in: the measured lines (`pmsm-tool
            // identify` writes the whole file with the settings' pole pairs and ratings).
            #[cfg(feature = "link")]
            Event::Identified { motor: m, .. } => defmt::write!(
                f,
                "identified: r_ohm = {=f32}, l_h = {=f32}, flux_wb = {=f32}, j_kgm2 = {=f32}, b_nms = {=f32}",
                m.r_ohm,
                m.l_h(),
                m.flux_wb,
                m.j_kgm2,
                m.b_nms
            ),
            Event::Telemetry {
                step,
                tel,
                i_abc,
                v_bus,
            } => defmt::write!(
                f,
                "t = {=f32} s: bus {=f32} V, i_abc [{=f32}, {=f32}, {=f32}] A, {}",
                seconds(*step),
                *v_bus,
                i_abc.a,
                i_abc.b,
                i_abc.c,
                tel
            ),
        }
    }
}

/// An interrupt's end of its queue.
pub struct Sender(Producer<'static, Event>);

impl Sender {
    /// Queues an event; a full queue drops it and counts the loss.
    #[inline(always)]
    pub fn send(&mut self, ev: Event) {
        if self.0.enqueue(ev).is_err() {
            DROPPED.fetch_add(1, Ordering::Relaxed);
        }
    }
}

/// The main loop's end of both queues.
pub struct Receiver {
    step: Consumer<'static, Event>,
    tick: Consumer<'static, Event>,
}

impl Receiver {
    /// Logs every queued event in the order of their stamps (after `each` has looked at it),
    /// then how many were dropped since the last call. Of equal stamps the task's goes first:
    /// it ran before the step of that stamp.
    pub fn log(&mut self, mut each: impl FnMut(&Event)) {
        loop {
            let tick_first = match (self.tick.peek(), self.step.peek()) {
                (Some(t), Some(s)) => (t.step().wrapping_sub(s.step()) as i32) <= 0,
                (t, _) => t.is_some(),
            };
            let next = if tick_first {
                self.tick.dequeue()
            } else {
                self.step.dequeue()
            };
            let Some(ev) = next else { break };
            each(&ev);
            defmt::info!("{}", ev);
        }
        let dropped = DROPPED.swap(0, Ordering::Relaxed);
        if dropped > 0 {
            defmt::warn!("{=u32} log records dropped (queue full)", dropped);
        }
    }
}

/// The queues (statics, created once): the step's sender, the 1 kHz task's, the main loop's
/// receiver.
pub fn queues() -> (Sender, Sender, Receiver) {
    let Some(step) = cortex_m::singleton!(: Queue<Event, STEP_QUEUE_LEN> = Queue::new()) else {
        defmt::panic!("queue taken twice");
    };
    let Some(tick) = cortex_m::singleton!(: Queue<Event, TICK_QUEUE_LEN> = Queue::new()) else {
        defmt::panic!("queue taken twice");
    };
    let (step_tx, step_rx) = step.split();
    let (tick_tx, tick_rx) = tick.split();
    (
        Sender(step_tx),
        Sender(tick_tx),
        Receiver {
            step: step_rx,
            tick: tick_rx,
        },
    )
}

/// Control steps → seconds since the control interrupt started.
pub fn seconds(step: u32) -> f32 {
    step as f32 / SETTINGS.control_hz as f32
}
