//! Host tests of the init functions: each runs on zeroed register blocks (the PAC's
//! `RegisterBlock` laid over zeroed memory) with a [`Board`] that answers the polls as the
//! hardware would, and the words it wrote are checked field by field at RM0440's bit
//! positions (read back as raw words, not through the PAC's names) against the manual's
//! formulas: the PLL's frequencies and ranges, the dead time from DTG and CKD, the ADC clock
//! and sampling window, the breaks, the watchdog's timeout.
//!
//! Memory is no peripheral: a flag register keeps what was written (a "clear" writes ones to
//! the other flags of TIMx_SR, ADC_ISR is write-1-to-clear, a `modify` of ADC_CR writes its
//! set-only bits as 0), so [`Board::poll`] sets the
//! whole flag register to what the hardware would show, and the tests set the flags a break
//! or a conversion would raise before the code reads them.

mod analog;
mod clocks;
mod safety;
mod servo;
mod tim1;

use std::cell::Cell;
use std::marker::PhantomData;

use stm32g4::stm32g431 as pac;

use crate::hw::{Hw, Wait};

/// A register block over zeroed memory.
pub(super) struct Zeroed<RB> {
    mem: Vec<u32>,
    _rb: PhantomData<RB>,
}

impl<RB> Zeroed<RB> {
    pub(super) fn new() -> Self {
        Self {
            mem: vec![0; core::mem::size_of::<RB>().div_ceil(4)],
            _rb: PhantomData,
        }
    }

    pub(super) fn rb(&self) -> &RB {
        // SAFETY: the memory is at least the block's size, 4-byte aligned (the registers are
        // u32 or narrower) and zero is a valid value of every register; the block is
        // accessed only through volatile cells and lives as long as the borrow.
        unsafe { &*(self.mem.as_ptr() as *const RB) }
    }
}

/// The word of a register (any, also write-only ones: memory keeps the last write).
pub(super) fn peek<R>(reg: &R) -> u32 {
    // SAFETY: the PAC's registers are a `u32` volatile cell each (the blocks here have no
    // narrower one that a test reads).
    unsafe { (reg as *const R as *const u32).read_volatile() }
}

/// Sets a register's word as the hardware would (flags, read-only data).
pub(super) fn poke<R>(reg: &R, v: u32) {
    // SAFETY: as for `peek`; the cell is interior-mutable (`UnsafeCell` inside).
    unsafe { (reg as *const R as *mut u32).write_volatile(v) }
}

/// `bits` of `w` from bit `lo`, `n` bits wide.
pub(super) fn field(w: u32, lo: u32, n: u32) -> u32 {
    (w >> lo) & ((1 << n) - 1)
}

/// The blocks a test's init functions poll, and how the hardware answers.
#[derive(Default)]
pub(super) struct Board<'a> {
    pub(super) rcc: Option<&'a pac::rcc::RegisterBlock>,
    /// The crystal starts.
    pub(super) hse_starts: bool,
    pub(super) tim1: Option<&'a pac::tim1::RegisterBlock>,
    /// TIM1 counts down after the update (the update at the counter peak).
    pub(super) update_at_peak: bool,
    /// TIMx_SR flags raised besides UIF (a break).
    pub(super) tim1_flags: u32,
    /// (MOE, CCR1, CCR2, CCR3) at each update event.
    pub(super) updates: Vec<(bool, u32, u32, u32)>,
    pub(super) adc1: Option<&'a pac::adc1::RegisterBlock>,
    pub(super) adc2: Option<&'a pac::adc1::RegisterBlock>,
    /// ADC1's injected data JDR1..4, ADC2's.
    pub(super) jdr: [[u32; 4]; 2],
    /// A regular conversion's DR.
    pub(super) dr: u32,
    /// ADC_CR of each converter when its ADRDY is polled (a later `modify` writes ADEN as 0,
    /// which the hardware ignores: ADC_CR's bits are set-only).
    pub(super) adc_cr_at_ready: Vec<u32>,
    /// Answer no poll at all (a block nothing drives).
    pub(super) silent: bool,
    /// Core clocks busy-waited.
    pub(super) delayed: Cell<u64>,
    /// Polls, per flag.
    pub(super) polls: Vec<Wait>,
}

impl Hw for Board<'_> {
    fn delay_cycles(&mut self, cycles: u32) {
        self.delayed.set(self.delayed.get() + u64::from(cycles));
    }

    fn poll(&mut self, what: Wait) {
        self.polls.push(what);
        if self.silent {
            return;
        }
        match what {
            Wait::FlashLatency | Wait::IwdgUpdated => {}
            Wait::HseReady => {
                if self.hse_starts {
                    let rcc = self.rcc.expect("RCC");
                    poke(rcc.cr(), peek(rcc.cr()) | 1 << 17);
                }
            }
            Wait::PllReady => {
                let rcc = self.rcc.expect("RCC");
                poke(rcc.cr(), peek(rcc.cr()) | 1 << 25);
            }
            Wait::SysclkPll => {
                let rcc = self.rcc.expect("RCC");
                // SWS follows SW.
                let cfgr = peek(rcc.cfgr());
                poke(rcc.cfgr(), (cfgr & !0b1100) | (cfgr & 0b11) << 2);
            }
            Wait::Tim1Update => {
                let tim1 = self.tim1.expect("TIM1");
                poke(tim1.sr(), 1 | self.tim1_flags);
                let cr1 = peek(tim1.cr1()) & !(1 << 4);
                poke(tim1.cr1(), cr1 | u32::from(self.update_at_peak) << 4);
                self.updates.push((
                    peek(tim1.bdtr()) & crate::tim1::MOE != 0,
                    peek(tim1.ccr1()),
                    peek(tim1.ccr2()),
                    peek(tim1.ccr3()),
                ));
            }
            Wait::AdcCalibrated => {
                for adc in [self.adc1, self.adc2].into_iter().flatten() {
                    poke(adc.cr(), peek(adc.cr()) & !(1 << 31));
                }
            }
            Wait::AdcReady | Wait::AdcRegularEnd | Wait::AdcInjectedEnd => {
                for (k, adc) in [self.adc1, self.adc2].into_iter().enumerate() {
                    let Some(adc) = adc else { continue };
                    if what == Wait::AdcReady {
                        self.adc_cr_at_ready.push(peek(adc.cr()));
                    }
                    // ADRDY, EOC, JEOC, JEOS.
                    poke(adc.isr(), 1 | 1 << 2 | 1 << 5 | 1 << 6);
                    poke(adc.dr(), self.dr);
                    let [a, b, c, d] = self.jdr[k];
                    poke(adc.jdr1(), a);
                    poke(adc.jdr2(), b);
                    poke(adc.jdr3(), c);
                    poke(adc.jdr4(), d);
                }
            }
        }
    }
}
