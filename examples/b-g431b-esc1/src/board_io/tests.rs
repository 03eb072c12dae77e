//! The button's rules and the LED on hand-made embedded-hal mock pins (embedded-hal-mock is
//! not a dependency: two small pins do), and the board's GPIO wrappers on a zeroed GPIOC.

use std::cell::{Cell, RefCell};
use std::rc::Rc;

use embedded_hal::digital::{Error, ErrorKind, ErrorType, InputPin, OutputPin};

use super::*;
use crate::init_tests::{peek, poke, Zeroed};

#[derive(Debug)]
struct PinError;

impl Error for PinError {
    fn kind(&self) -> ErrorKind {
        ErrorKind::Other
    }
}

/// An input whose level (or a read error) the test sets.
#[derive(Clone)]
struct MockIn(Rc<Cell<Option<bool>>>);

impl ErrorType for MockIn {
    type Error = PinError;
}

impl InputPin for MockIn {
    fn is_high(&mut self) -> Result<bool, PinError> {
        self.0.get().ok_or(PinError)
    }

    fn is_low(&mut self) -> Result<bool, PinError> {
        self.is_high().map(|h| !h)
    }
}

/// An output recording every write.
#[derive(Clone, Default)]
struct MockOut(Rc<RefCell<Vec<bool>>>);

impl ErrorType for MockOut {
    type Error = PinError;
}

impl OutputPin for MockOut {
    fn set_high(&mut self) -> Result<(), PinError> {
        self.0.borrow_mut().push(true);
        Ok(())
    }

    fn set_low(&mut self) -> Result<(), PinError> {
        self.0.borrow_mut().push(false);
        Ok(())
    }
}

/// The firmware's numbers: a poll every 40 steps (10 ms), 2 s = 8000 steps to identify.
const POLL: u32 = 40;
const HOLD: u32 = 8000;

/// A button idle at `idle`, its level, and a clock in steps.
struct Rig {
    level: Rc<Cell<Option<bool>>>,
    idle: bool,
    button: Button<MockIn>,
    now: u32,
}

impl Rig {
    fn new(idle: bool, identify: bool) -> Self {
        let level = Rc::new(Cell::new(Some(idle)));
        let button = Button::new(MockIn(level.clone()), POLL, HOLD, identify);
        Self {
            level,
            idle,
            button,
            now: 0,
        }
    }

    /// Holds the button `pressed` for `steps`, calling `poll` every step as the main loop
    /// does at most; the actions seen.
    fn hold(
        &mut self,
        pressed: bool,
        steps: u32,
        faulted: bool,
        enabled: bool,
    ) -> Vec<ButtonAction> {
        self.level.set(Some(pressed != self.idle));
        let mut seen = Vec::new();
        for _ in 0..steps {
            self.now = self.now.wrapping_add(1);
            seen.extend(self.button.poll(self.now, faulted, enabled));
        }
        seen
    }

    /// A press of `steps` and the release (with time to see it).
    fn click(&mut self, steps: u32, faulted: bool, enabled: bool) -> Vec<ButtonAction> {
        let mut seen = self.hold(true, steps, faulted, enabled);
        seen.extend(self.hold(false, 2 * POLL, faulted, enabled));
        seen
    }
}

/// A click toggles the run command, acted on at the release, whatever the button's idle
/// level (read at start-up).
#[test]
fn click_toggles_enable() {
    for idle in [true, false] {
        let mut r = Rig::new(idle, false);
        assert_eq!(r.hold(true, 400, false, false), [], "nothing while held");
        assert_eq!(
            r.hold(false, 80, false, false),
            [ButtonAction::Enable(true)]
        );
        assert_eq!(r.click(200, false, true), [ButtonAction::Enable(false)]);
    }
}

/// In `Fault` a click clears the fault (the drive stays disabled), whatever the run
/// command and however long it was held.
#[test]
fn click_in_fault_clears() {
    let mut r = Rig::new(true, true);
    assert_eq!(r.click(200, true, true), [ButtonAction::ClearFault]);
    assert_eq!(r.click(HOLD + 400, true, false), [ButtonAction::ClearFault]);
}

/// Held 2 s with the drive disabled: the identification, in the commissioning firmware
/// only; shorter, or with the drive enabled, or without the feature: the toggle.
#[test]
fn hold_identifies() {
    let mut r = Rig::new(true, true);
    assert_eq!(r.click(HOLD + POLL, false, false), [ButtonAction::Identify]);
    assert_eq!(
        r.click(HOLD - 2 * POLL, false, false),
        [ButtonAction::Enable(true)]
    );
    assert_eq!(
        r.click(HOLD + POLL, false, true),
        [ButtonAction::Enable(false)]
    );
    let mut r = Rig::new(true, false);
    assert_eq!(
        r.click(HOLD + POLL, false, false),
        [ButtonAction::Enable(true)]
    );
}

/// Sampled every 40 steps: a bounce shorter than a poll between two samples is not seen,
/// and the step counter's wrap does not matter.
#[test]
fn sampled_every_poll() {
    let mut r = Rig::new(true, false);
    r.hold(false, 2 * POLL, false, false);
    // Between two samples (the last at a multiple of POLL steps from the start).
    r.hold(false, 5, false, false);
    assert_eq!(r.hold(true, 10, false, false), []);
    assert_eq!(r.hold(false, 3 * POLL, false, false), []);
    let mut r = Rig::new(true, false);
    r.now = u32::MAX - 100;
    r.button.last_poll = r.now;
    assert_eq!(r.click(300, false, false), [ButtonAction::Enable(true)]);
}

/// A pin that cannot be read keeps its last state: no action from an error.
#[test]
fn read_error_keeps_state() {
    let mut r = Rig::new(true, false);
    r.hold(true, 200, false, false);
    r.level.set(None);
    let mut seen = Vec::new();
    for _ in 0..400 {
        r.now += 1;
        seen.extend(r.button.poll(r.now, false, false));
    }
    assert_eq!(seen, []);
    assert_eq!(
        r.hold(false, 80, false, false),
        [ButtonAction::Enable(true)]
    );
}

/// The LED: lit while armed, off otherwise, blinking with half-period 500 steps in
/// `Fault`; written only at a change.
#[test]
fn status_led() {
    let out = MockOut::default();
    let mut led = StatusLed::new(out.clone(), 500);
    led.show(0, false, false);
    led.show(1, false, false);
    led.show(2, false, true);
    led.show(3, false, true);
    led.show(4, false, false);
    assert_eq!(*out.0.borrow(), [false, true, false]);
    out.0.borrow_mut().clear();
    for now in 0..2000 {
        led.show(now, true, true);
    }
    assert_eq!(*out.0.borrow(), [true, false, true, false]);
}

/// The board's pins on a zeroed GPIOC: the input reads its IDR bit, the output writes
/// its set or reset bit in BSRR only; `init_led` resets PC6 and makes it an output.
#[test]
fn gpio_wrappers() {
    let gpioc = Zeroed::<pac::gpioc::RegisterBlock>::new();
    let g = gpioc.rb();
    let mut button = GpioIn::new(g, 10);
    assert_eq!(button.is_high(), Ok(false));
    poke(g.idr(), 1 << 10);
    assert_eq!(button.is_high(), Ok(true));
    assert_eq!(button.is_low(), Ok(false));
    poke(g.idr(), !(1 << 10));
    assert_eq!(button.is_high(), Ok(false));

    init_led(g);
    assert_eq!(peek(g.bsrr()), 1 << 22);
    assert_eq!((peek(g.moder()) >> 12) & 0b11, 0b01, "PC6 output");
    let mut led = GpioOut::new(g, 6);
    led.set_high().unwrap();
    assert_eq!(peek(g.bsrr()), 1 << 6);
    led.set_low().unwrap();
    assert_eq!(peek(g.bsrr()), 1 << 22);
}
