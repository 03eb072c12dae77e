//! What the init functions need beyond the register blocks: a busy-wait of some core clocks
//! and the polls of the peripherals' ready flags ([`Hw`]). On the board both are the CPU's
//! (`cortex_m::asm::delay`, a plain spin); on the host a test implements them over zeroed
//! register blocks and answers each poll by setting the flag the hardware would set, so the
//! init functions run on the host and their register values can be asserted
//! (`init_tests`). Every wait is bounded ([`wait_for`]): a flag that never comes is a named
//! [`InitError`], never a hang, on the board and on a zeroed block alike.

/// A flag an init function waits for (RM0440's name for it in the comment).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wait {
    /// FLASH_ACR.LATENCY reads back the wait states written.
    FlashLatency,
    /// RCC_CR.HSERDY: the crystal oscillates.
    HseReady,
    /// RCC_CR.PLLRDY: the PLL is locked.
    PllReady,
    /// RCC_CFGR.SWS = PLL: SYSCLK switched.
    SysclkPll,
    /// TIMx_SR.UIF: an update event.
    Tim1Update,
    /// ADC_CR.ADCAL cleared: calibration done.
    AdcCalibrated,
    /// ADC_ISR.ADRDY: the converter is ready.
    AdcReady,
    /// ADC_ISR.EOC: a regular conversion ended.
    AdcRegularEnd,
    /// ADC_ISR.JEOS: an injected sequence ended.
    AdcInjectedEnd,
    /// IWDG_SR = 0: the prescaler and reload reached the watchdog's clock domain.
    IwdgUpdated,
}

/// An init function could not finish: the firmware stops with it in the log (its texts are
/// the firmware's `ok`, in defmt's table rather than in flash).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum InitError {
    /// A flag did not come within its bound.
    Timeout(Wait),
    /// A current-sense offset outside the plausible window \[LSB] (the amplifier path).
    CurrentOffset(f32),
    /// An over-current comparator's output is high with no current (its threshold is
    /// below its input: a wrong scale or a broken path); 0, 1, 2 = U, V, W.
    ComparatorHigh(usize),
}

/// The CPU's part of an init function.
pub trait Hw {
    /// Busy-waits about `cycles` core clocks.
    fn delay_cycles(&mut self, cycles: u32);
    /// Called before each poll of `what`. The board does nothing (the peripheral sets its
    /// flag); a host test sets the flag in its zeroed block, as the hardware would.
    fn poll(&mut self, what: Wait);
}

/// Polls of a ready flag before it is an [`InitError::Timeout`]: at least some ms on the
/// board (each poll is a volatile read and a branch, ≥ 4 cycles at ≤ 170 MHz: ≥ 23 ms),
/// far beyond any flag's time (the PLL locks in ~40 µs, an ADC calibration takes ~116 ADC
/// clocks, a PWM period is 50 µs; DS12589, RM0440).
pub const POLLS_MAX: u32 = 1_000_000;

/// Polls `done` (after [`Hw::poll`] each time) until it holds, at most `polls` times.
pub fn wait_for(
    hw: &mut impl Hw,
    what: Wait,
    polls: u32,
    mut done: impl FnMut() -> bool,
) -> Result<(), InitError> {
    for _ in 0..polls {
        hw.poll(what);
        if done() {
            return Ok(());
        }
    }
    Err(InitError::Timeout(what))
}
