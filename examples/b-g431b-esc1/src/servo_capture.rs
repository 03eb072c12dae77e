//! The servo-PWM input's timer: TIM2 in PWM-input mode on PA15 (RM0440, general-purpose
//! timers TIM2/TIM3/TIM4/TIM5, "PWM input mode"): TI1 feeds both capture channels, IC1 on
//! the rising edge (the period: the slave controller resets the counter on the same edge,
//! TS = TI1FP1, SMS = reset), IC2 on the falling edge (the width). The counter runs at
//! 1 MHz, so the captures are in µs; 32 bits never wrap between two edges. Polled
//! ([`ServoCapture`], no interrupt): a new capture is CC1IF, cleared by reading CCR1.
//!
//! The pin: PA15 is the board's "PWM" input (stm32duino's variant for this board,
//! `variant_B_G431B_ESC1.h`: `PA15 // PWM`, written by ST; the same pin in the SimpleFOC
//! community's B-G431B-ESC1 pinout); TIM2_CH1 is its AF1 (DS12589's alternate-function
//! table, as generated into stm32duino's `PeripheralPins_B_G431B_ESC1.c`). UM2516's own
//! connector table was not at hand: check the pin against it. The pull-down is this
//! firmware's choice (an unconnected input stays low: no edges, a loss of signal), not
//! read from the schematic.

use crate::config::SETTINGS;
use crate::servo::{Capture, PulseCapture};
use stm32g4::stm32g431 as pac;

/// The capture clock \[Hz]: µs ticks.
pub const TICK_HZ: u32 = 1_000_000;
/// TIMx_PSC: TIM2's kernel clock (APB1 undivided: SYSCLK) down to [`TICK_HZ`].
pub const PSC: u32 = SETTINGS.sysclk_hz / TICK_HZ - 1;
/// TIMx_CCMR1 (input): CC1S = 01 (IC1 on TI1), CC2S = 10 (IC2 on TI1), IC1F = IC2F = 1111
/// (f_DTS/32, N = 8: an edge must hold 8·32/170 MHz = 1.5 µs; both edges are delayed
/// alike, so the width is not).
pub const CCMR1: u32 = 0b01 | 0b1111 << 4 | 0b10 << 8 | 0b1111 << 12;
/// TIMx_CCER: CC1E, CC1P = 0 (rising); CC2E, CC2P = 1 (falling).
pub const CCER: u32 = 1 | 1 << 4 | 1 << 5;
/// TIMx_SMCR: TS = 00101 (TI1FP1; TS\[2:0] at bits 6:4), SMS = 0100 (reset mode).
pub const SMCR: u32 = 0b101 << 4 | 0b100;
/// TIMx_SR: CC1IF (a rising edge captured).
pub const SR_CC1IF: u32 = 1 << 1;
/// TIMx_SR: CC1OF, CC2OF (a capture overwritten before it was read).
pub const SR_OVERCAPTURE: u32 = 1 << 9 | 1 << 10;

/// TIM2's clock, PA15 to TIM2_CH1 (AF1, pull-down), and TIM2 counting in PWM-input mode.
pub fn init(
    rcc: &pac::rcc::RegisterBlock,
    gpioa: &pac::gpioa::RegisterBlock,
    tim2: &pac::tim2::RegisterBlock,
) {
    rcc.apb1enr1().modify(|_, w| w.tim2en().set_bit());
    gpioa.afrh().modify(|_, w| w.afrh15().af1());
    gpioa.pupdr().modify(|_, w| w.pupdr15().pull_down());
    gpioa.moder().modify(|_, w| w.moder15().alternate());
    // SAFETY (all `bits` below): the words are RM0440's fields for TIM2 (constants above).
    tim2.psc().write(|w| unsafe { w.bits(PSC) });
    tim2.arr().write(|w| unsafe { w.bits(u32::MAX) });
    tim2.ccmr1_input().write(|w| unsafe { w.bits(CCMR1) });
    tim2.smcr().write(|w| unsafe { w.bits(SMCR) });
    tim2.ccer().write(|w| unsafe { w.bits(CCER) });
    // Load the prescaler (UG), drop the flags that raised.
    tim2.egr().write(|w| w.ug().set_bit());
    tim2.sr().write(|w| unsafe { w.bits(0) });
    tim2.cr1().modify(|_, w| w.cen().set_bit());
}

/// The polled capture of TIM2 (after [`init`]). The first capture after the start is
/// dropped: its period counts from the timer's start, not from an edge.
pub struct ServoCapture<'a> {
    tim2: &'a pac::tim2::RegisterBlock,
    primed: bool,
}

impl<'a> ServoCapture<'a> {
    /// The capture of `tim2`.
    pub fn new(tim2: &'a pac::tim2::RegisterBlock) -> Self {
        Self {
            tim2,
            primed: false,
        }
    }
}

impl PulseCapture for ServoCapture<'_> {
    fn capture(&mut self) -> Option<Capture> {
        let sr = self.tim2.sr().read().bits();
        if sr & SR_CC1IF == 0 {
            return None;
        }
        // CCR2 holds the falling edge of the pulse that this rising edge ends the period of;
        // reading CCR1 clears CC1IF.
        let width_us = self.tim2.ccr2().read().bits();
        let period_us = self.tim2.ccr1().read().bits();
        if sr & SR_OVERCAPTURE != 0 {
            // rc_w0: zeros clear, ones leave the other flags.
            self.tim2.sr().write(|w| unsafe { w.bits(!SR_OVERCAPTURE) });
        }
        let first = !self.primed;
        self.primed = true;
        (!first).then_some(Capture {
            period_us,
            width_us,
        })
    }
}
