//! Safety nets.
//!
//! The drive's software trip (`i_trip_a`) on every sample, and the hardware trip
//! (`overcurrent`: comparators into TIM1's BRK2) between samples; the system break (core
//! lockup, memory errors, clock failure) into TIM1's BRK. An independent watchdog (about
//! 10 ms) is fed by the control interrupt only when the main loop and the 1 kHz task have
//! both run since the last feed, so a stalled control loop, task or main loop — e.g. the
//! main loop stuck inside a defmt-rtt write, which happens in probe-rs's blocking RTT mode
//! when the host stops reading — resets the MCU and releases the gate-driver inputs. A
//! HardFault (also the end of every panic, through panic-probe), an NMI and every
//! unexpected interrupt (`DefaultHandler`) clear MOE first. With a debugger halting the
//! core, TIM1's outputs are forced to their inactive level (DBGMCU `DBG_TIM1_STOP`,
//! OSSI = 1).

use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m_rt::{exception, ExceptionFrame};
use stm32g4::stm32g431 as pac;

use pmsm_b_g431b_esc1::hw::{Hw, InitError};
use pmsm_b_g431b_esc1::{pwm, watchdog};

/// The main loop has run since the last feed (set by it, taken by [`Watchdog::feed`]).
pub static MAIN_ALIVE: AtomicBool = AtomicBool::new(false);
/// The drive's 1 kHz task has run since the last feed (set by it, taken by
/// [`Watchdog::feed`]).
pub static TICK_ALIVE: AtomicBool = AtomicBool::new(false);

/// The running independent watchdog, fed by the control step when the main loop and the
/// 1 kHz task have run too.
pub struct Watchdog {
    iwdg: pac::IWDG,
}

impl Watchdog {
    /// Independent watchdog ([`watchdog::start`]: `SETTINGS.watchdog`, 10 ms at the
    /// typical LSI); fed only by the control step.
    pub fn start(iwdg: pac::IWDG, hw: &mut impl Hw) -> Result<Self, InitError> {
        watchdog::start(&iwdg, hw)?;
        Ok(Self { iwdg })
    }

    /// Feeds the watchdog (from the control step: it has run) if the main loop and the
    /// 1 kHz task have both run since the last feed; else leaves it to bite: a stalled main
    /// loop or task resets the MCU within the timeout (the outputs off at reset).
    #[inline(always)]
    pub fn feed(&self) {
        if MAIN_ALIVE.load(Ordering::Relaxed) && TICK_ALIVE.load(Ordering::Relaxed) {
            MAIN_ALIVE.store(false, Ordering::Relaxed);
            TICK_ALIVE.store(false, Ordering::Relaxed);
            watchdog::feed(&self.iwdg);
        }
    }
}

/// Every panic ends here (panic-probe: `udf`), as does any fault: switch the bridge off
/// first, then wait for the watchdog to reset the MCU.
#[exception]
// SAFETY (of the signature): cortex-m-rt requires HardFault handlers to be `unsafe fn`;
// this one only touches TIM1's BDTR and never returns.
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    bridge_off_and_wait()
}

/// Every interrupt without a handler of its own (and every fault exception not enabled on
/// its own): the bridge off, then the watchdog's reset.
#[exception]
unsafe fn DefaultHandler(_irqn: i16) -> ! {
    bridge_off_and_wait()
}

/// The NMI (among others the HSE clock security system's, see `overcurrent::system_break`):
/// the bridge off, then the watchdog's reset.
#[exception]
unsafe fn NonMaskableInt() -> ! {
    bridge_off_and_wait()
}

/// MOE cleared (all six outputs to their idle, off, level), then nothing until the
/// watchdog resets the MCU.
fn bridge_off_and_wait() -> ! {
    // SAFETY: called only from the handlers above, which never return: nothing else runs
    // after them but higher-priority exceptions, and clearing MOE is a single
    // read-modify-write of TIM1_BDTR that forces the outputs to their idle (off) level.
    let tim1 = unsafe { pac::TIM1::steal() };
    pwm::outputs_off(&tim1);
    loop {
        cortex_m::asm::nop();
    }
}
