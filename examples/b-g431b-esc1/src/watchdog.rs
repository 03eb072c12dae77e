//! The independent watchdog's start (RM0440 IWDG chapter: key register, prescaler, reload,
//! the status register's update flags) and the debug-halt behaviour (RM0440 DBGMCU). Register
//! blocks borrowed: the host tests run these on zeroed ones (`init_tests::safety`). Who feeds
//! it and when: the firmware's `protection` (the control step, when the main loop and the
//! 1 kHz task have run too).

use crate::config::SETTINGS;
use crate::hw::{wait_for, Hw, InitError, Wait, POLLS_MAX};
use stm32g4::stm32g431 as pac;

/// IWDG_KR: start the watchdog.
pub const KEY_START: u16 = 0xCCCC;
/// IWDG_KR: unlock PR and RLR.
pub const KEY_UNLOCK: u16 = 0x5555;
/// IWDG_KR: reload the counter (feed).
pub const KEY_FEED: u16 = 0xAAAA;

/// Starts the watchdog with `SETTINGS.watchdog`'s prescaler and reload (10 ms at the typical
/// LSI), waits until both reached its clock domain (IWDG_SR = 0), and feeds it once.
pub fn start(iwdg: &pac::iwdg::RegisterBlock, hw: &mut impl Hw) -> Result<(), InitError> {
    let w = SETTINGS.watchdog;
    iwdg.kr().write(|r| r.key().start());
    iwdg.kr().write(|r| r.key().unlock());
    // SAFETY: PR is 0..6 and RL 0..4095 by construction (`Watchdog::for_timeout`).
    iwdg.pr().write(|r| unsafe { r.pr().bits(w.pr) });
    iwdg.rlr().write(|r| r.rl().set(w.rl));
    wait_for(hw, Wait::IwdgUpdated, POLLS_MAX, || {
        iwdg.sr().read().bits() == 0
    })?;
    feed(iwdg);
    Ok(())
}

/// Reloads the counter.
#[inline(always)]
pub fn feed(iwdg: &pac::iwdg::RegisterBlock) {
    iwdg.kr().write(|r| r.key().feed());
}

/// Debug halt: TIM1 stops with its outputs forced inactive (OSSI = 1), IWDG freezes.
pub fn freeze_on_debug_halt(dbgmcu: &pac::dbgmcu::RegisterBlock) {
    dbgmcu.apb2_fz().modify(|_, w| w.dbg_tim1_stop().set_bit());
    dbgmcu.apb1l_fz().modify(|_, w| w.dbg_iwdg_stop().set_bit());
}
