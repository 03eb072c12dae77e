//! The interrupt → main-loop queue and the log (defmt over RTT): the control step queues its
//! events (every mode transition, a telemetry record at 10 Hz), the main loop logs them.

use core::sync::atomic::{AtomicU32, Ordering};

use defmt_rtt as _;
use heapless::spsc::{Consumer, Producer, Queue};

use crate::control::Event;
use crate::pwm::CONTROL_HZ;

/// One telemetry record every this many steps (400 steps = 10 Hz).
pub const TELEMETRY_EVERY: u32 = 400;
/// Capacity of the interrupt → main-loop queue (one slot is kept free by heapless).
const QUEUE_LEN: usize = 16;

/// Records the interrupt could not queue (queue full).
static DROPPED: AtomicU32 = AtomicU32::new(0);

/// The interrupt's end of the queue.
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

/// The main loop's end of the queue.
pub struct Receiver(Consumer<'static, Event>);

impl Receiver {
    /// Logs every queued event (after `each` has looked at it), then how many were dropped
    /// since the last call.
    pub fn log(&mut self, mut each: impl FnMut(&Event)) {
        while let Some(ev) = self.0.dequeue() {
            each(&ev);
            defmt::info!("{}", ev);
        }
        let dropped = DROPPED.swap(0, Ordering::Relaxed);
        if dropped > 0 {
            defmt::warn!("{=u32} log records dropped (queue full)", dropped);
        }
    }
}

/// The queue (a static, created once).
pub fn queue() -> (Sender, Receiver) {
    let Some(queue) = cortex_m::singleton!(: Queue<Event, QUEUE_LEN> = Queue::new()) else {
        defmt::panic!("queue taken twice");
    };
    let (producer, consumer) = queue.split();
    (Sender(producer), Receiver(consumer))
}

/// Control steps → seconds since the control interrupt started.
pub fn seconds(step: u32) -> f32 {
    step as f32 / CONTROL_HZ as f32
}
