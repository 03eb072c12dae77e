//! The user button and the LED against embedded-hal 1.0's digital traits
//! (`embedded_hal::digital::{InputPin, OutputPin}`), so a second board or an emulator reuses
//! the logic with its own pins, and the host tests drive it with a mock pin: [`Button`] (the
//! button's rules, moved here unchanged from the firmware's main loop), [`StatusLed`], and
//! the board's pins as those traits on GPIO registers ([`GpioIn`], [`GpioOut`]).
//!
//! The pins (NuttX's `boards/arm/stm32/b-g431b-esc1` and ST's stm32duino variant for the
//! board): the user button B1 on PC10, the user LED on PC6 (NuttX: green LD2; stm32duino
//! calls it `LED_RED`; active high is inferred from NuttX driving it as a push-pull output
//! cleared at reset, not read from UM2516's schematic).

use core::convert::Infallible;

use embedded_hal::digital::{ErrorType, InputPin, OutputPin};
use stm32g4::stm32g431 as pac;

/// One pin of a GPIO port as an input (reads IDR).
pub struct GpioIn<'a> {
    port: &'a pac::gpioc::RegisterBlock,
    pin: u8,
}

/// One pin of a GPIO port as an output (writes BSRR: atomic, no read-modify-write).
pub struct GpioOut<'a> {
    port: &'a pac::gpioc::RegisterBlock,
    pin: u8,
}

impl<'a> GpioIn<'a> {
    /// Pin `pin` (0..15) of `port`, already configured as an input.
    pub fn new(port: &'a pac::gpioc::RegisterBlock, pin: u8) -> Self {
        Self { port, pin }
    }
}

impl<'a> GpioOut<'a> {
    /// Pin `pin` (0..15) of `port`, already configured as an output.
    pub fn new(port: &'a pac::gpioc::RegisterBlock, pin: u8) -> Self {
        Self { port, pin }
    }
}

impl ErrorType for GpioIn<'_> {
    type Error = Infallible;
}

impl ErrorType for GpioOut<'_> {
    type Error = Infallible;
}

impl InputPin for GpioIn<'_> {
    fn is_high(&mut self) -> Result<bool, Infallible> {
        Ok(self.port.idr().read().bits() >> self.pin & 1 != 0)
    }

    fn is_low(&mut self) -> Result<bool, Infallible> {
        self.is_high().map(|h| !h)
    }
}

impl OutputPin for GpioOut<'_> {
    fn set_high(&mut self) -> Result<(), Infallible> {
        // SAFETY: BSRR's low half sets, its high half resets; other pins' bits are 0 (no
        // effect).
        self.port.bsrr().write(|w| unsafe { w.bits(1 << self.pin) });
        Ok(())
    }

    fn set_low(&mut self) -> Result<(), Infallible> {
        // SAFETY: as for `set_high`.
        self.port
            .bsrr()
            .write(|w| unsafe { w.bits(1 << (self.pin + 16)) });
        Ok(())
    }
}

/// The user LED PC6 as a push-pull output, off.
pub fn init_led(gpioc: &pac::gpioc::RegisterBlock) {
    // SAFETY: BSRR bit 16 + 6 resets PC6 only.
    gpioc.bsrr().write(|w| unsafe { w.bits(1 << (6 + 16)) });
    gpioc.moder().modify(|_, w| w.moder6().output());
}

/// What a button release asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ButtonAction {
    /// Pressed in `Fault`: clear the fault, the drive stays disabled.
    ClearFault,
    /// Held `identify_hold_steps` with the drive disabled (commissioning firmware only).
    Identify,
    /// Else: the run command toggled to this.
    Enable(bool),
}

/// The button's rules (the firmware's main loop before embedded-hal, unchanged): sampled
/// every `poll_steps` control steps (longer than contact bounce), pressed while its level
/// differs from the one read at start-up (so its polarity does not matter), acted on at
/// the release.
pub struct Button<P> {
    pin: P,
    idle: bool,
    was_pressed: bool,
    /// The step count at the press, while the button is down.
    pressed_at: u32,
    last_poll: u32,
    poll_steps: u32,
    identify_hold_steps: u32,
    identify: bool,
}

impl<P: InputPin> Button<P> {
    /// The button on `pin`, its idle level read now (a read error counts as low). `identify`:
    /// the commissioning firmware's hold-to-identify is on.
    pub fn new(mut pin: P, poll_steps: u32, identify_hold_steps: u32, identify: bool) -> Self {
        let idle = pin.is_high().unwrap_or(false);
        Self {
            pin,
            idle,
            was_pressed: false,
            pressed_at: 0,
            last_poll: 0,
            poll_steps,
            identify_hold_steps,
            identify,
        }
    }

    /// Called from the main loop with the step count `now`, whether the drive is in
    /// `Fault` and its run command: the action at a release, if any. A pin that cannot be
    /// read keeps its last state.
    pub fn poll(&mut self, now: u32, faulted: bool, enabled: bool) -> Option<ButtonAction> {
        if now.wrapping_sub(self.last_poll) < self.poll_steps {
            return None;
        }
        self.last_poll = now;
        let pressed = match self.pin.is_high() {
            Ok(level) => level != self.idle,
            Err(_) => self.was_pressed,
        };
        if pressed && !self.was_pressed {
            self.pressed_at = now;
        }
        let mut action = None;
        if !pressed && self.was_pressed {
            let held = now.wrapping_sub(self.pressed_at);
            action = Some(if faulted {
                ButtonAction::ClearFault
            } else if self.identify && held >= self.identify_hold_steps && !enabled {
                ButtonAction::Identify
            } else {
                ButtonAction::Enable(!enabled)
            });
        }
        self.was_pressed = pressed;
        action
    }
}

/// The LED: blinking (`blink_steps` on, as many off) while the drive is in `Fault`, lit
/// while the servo input is armed, else off. Written only when its level changes.
pub struct StatusLed<P> {
    pin: P,
    lit: Option<bool>,
    blink_steps: u32,
}

impl<P: OutputPin> StatusLed<P> {
    /// The LED on `pin`, blinking with half-period `blink_steps` (> 0).
    pub fn new(pin: P, blink_steps: u32) -> Self {
        Self {
            pin,
            lit: None,
            blink_steps: blink_steps.max(1),
        }
    }

    /// Shows the state at step `now`.
    pub fn show(&mut self, now: u32, faulted: bool, servo_armed: bool) {
        let lit = if faulted {
            (now / self.blink_steps).is_multiple_of(2)
        } else {
            servo_armed
        };
        if self.lit != Some(lit) {
            let r = if lit {
                self.pin.set_high()
            } else {
                self.pin.set_low()
            };
            // A failed write is tried again at the next call.
            self.lit = r.ok().map(|_| lit);
        }
    }
}

#[cfg(test)]
mod tests;
