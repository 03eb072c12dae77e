//! The independent watchdog and the debug halt on zeroed blocks (RM0440 IWDG and DBGMCU
//! register maps).

use super::{field, peek, Board, Zeroed};
use crate::config::LSI_HZ;
use crate::watchdog::{self, KEY_FEED};
use stm32g4::stm32g431 as pac;

/// IWDG: prescaler /4 (PR = 0) and reload 79: timeout `4·2^PR·(RL + 1)/f_LSI` = 10 ms at
/// the typical 32 kHz, 9.4..10.8 ms over DS12589's LSI range, at least 4 control periods
/// (1 ms) at the fastest; the last key written is the feed; the update flags polled.
#[test]
fn watchdog_start() {
    let iwdg = Zeroed::<pac::iwdg::RegisterBlock>::new();
    let mut hw = Board::default();
    watchdog::start(iwdg.rb(), &mut hw).expect("started");
    let pr = field(peek(iwdg.rb().pr()), 0, 3);
    let rl = field(peek(iwdg.rb().rlr()), 0, 12);
    assert_eq!((pr, rl), (0, 79));
    let timeout_ms = |lsi_hz: u32| f64::from((4 << pr) * (rl + 1)) * 1e3 / f64::from(lsi_hz);
    assert!((timeout_ms(LSI_HZ.1) - 10.0).abs() < 1e-9);
    assert!(timeout_ms(LSI_HZ.2) > 9.4 && timeout_ms(LSI_HZ.0) < 10.9);
    assert!(timeout_ms(LSI_HZ.2) >= 4.0 * 1e3 / 4000.0);
    assert_eq!(field(peek(iwdg.rb().kr()), 0, 16), u32::from(KEY_FEED));
    assert_eq!(hw.polls, [crate::hw::Wait::IwdgUpdated]);
}

/// A debug halt stops TIM1 (its outputs to their inactive level, OSSI = 1) and the IWDG.
#[test]
fn debug_halt() {
    let dbg = Zeroed::<pac::dbgmcu::RegisterBlock>::new();
    watchdog::freeze_on_debug_halt(dbg.rb());
    assert_eq!(field(peek(dbg.rb().apb2_fz()), 11, 1), 1, "DBG_TIM1_STOP");
    assert_eq!(field(peek(dbg.rb().apb1l_fz()), 12, 1), 1, "DBG_IWDG_STOP");
}
