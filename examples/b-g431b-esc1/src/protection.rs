//! Safety nets.
//!
//! The drive's software trip (`i_trip_a`) is the only over-current protection configured
//! here: the board's hardware protection path (comparators / TIM1 break, UM2516) is not set
//! up. An independent watchdog (about 10 ms) is fed by the control interrupt only, so a
//! stalled control loop — e.g. the main loop stuck inside a defmt-rtt write with interrupts
//! masked, which happens in probe-rs's blocking RTT mode when the host stops reading —
//! resets the MCU and releases the gate-driver inputs. A HardFault (also the end of every
//! panic, through panic-probe) clears MOE first. With a debugger halting the core, TIM1's
//! outputs are forced to their inactive level (DBGMCU `DBG_TIM1_STOP`, OSSI = 1).

use cortex_m_rt::{exception, ExceptionFrame};
use stm32g4::stm32g431 as pac;

use crate::pwm;
use pmsm_b_g431b_esc1::config::SETTINGS;

/// The running independent watchdog, fed by the control step only.
pub struct Watchdog {
    iwdg: pac::IWDG,
}

impl Watchdog {
    /// Independent watchdog (RM0440 IWDG chapter): prescaler and reload of
    /// `SETTINGS.watchdog` (10 ms at the typical LSI); fed only by the control step.
    pub fn start(iwdg: pac::IWDG) -> Self {
        let w = SETTINGS.watchdog;
        iwdg.kr().write(|w| w.key().start());
        iwdg.kr().write(|w| w.key().unlock());
        // SAFETY: PR is 0..6 and RL 0..4095 by construction (`Watchdog::for_timeout`).
        iwdg.pr().write(|r| unsafe { r.pr().bits(w.pr) });
        iwdg.rlr().write(|r| r.rl().set(w.rl));
        while iwdg.sr().read().bits() != 0 {}
        let dog = Self { iwdg };
        dog.feed();
        dog
    }

    #[inline(always)]
    pub fn feed(&self) {
        self.iwdg.kr().write(|w| w.key().feed());
    }
}

/// Debug halt: TIM1 stops with its outputs forced inactive (OSSI = 1), IWDG freezes.
pub fn freeze_on_debug_halt(dbgmcu: &pac::DBGMCU) {
    dbgmcu.apb2_fz().modify(|_, w| w.dbg_tim1_stop().set_bit());
    dbgmcu.apb1l_fz().modify(|_, w| w.dbg_iwdg_stop().set_bit());
}

/// Every panic ends here (panic-probe: `udf`), as does any fault: switch the bridge off
/// first, then wait for the watchdog to reset the MCU.
#[exception]
// SAFETY (of the signature): cortex-m-rt requires HardFault handlers to be `unsafe fn`;
// this one only touches TIM1's BDTR and never returns.
unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
    // SAFETY: nothing else runs after a HardFault (it is the highest-priority handler
    // short of NMI and never returns); clearing MOE is a single read-modify-write of
    // TIM1_BDTR that forces the outputs to their idle (off) level.
    let tim1 = unsafe { pac::TIM1::steal() };
    pwm::outputs_off(&tim1);
    loop {
        cortex_m::asm::nop();
    }
}
