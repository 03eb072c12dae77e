//! The configuration's flash: the STM32G431CB's last two 2 KiB pages (pages 62 and 63 of its
//! 128 KiB, from 0x0801_F000; `memory.x` gives the program the flash below them) as an
//! `embedded-storage` `NorFlash` ([`ConfigFlash`]) for the configuration store
//! (`pmsm-store`), written through the FLASH peripheral as RM0440 §3.3 prescribes:
//!
//! - unlock: KEY1 = 0x4567_0123 then KEY2 = 0xCDEF_89AB into FLASH_KEYR (§3.3.5); locked
//!   again (CR.LOCK) after each operation;
//! - before each operation: no BSY, the error flags of an earlier one cleared (SR, write 1);
//! - page erase (§3.3.7): CR.PER, CR.PNB = the page, CR.STRT, wait for BSY to clear;
//! - programming (§3.3.8): CR.PG, one double-word written as two words (low address
//!   first), wait for BSY to clear; a double-word is programmed once after an erase (else
//!   PROGERR), which the store respects (it appends).
//!
//! While the flash erases or programs, a read of it stalls the CPU (one bank): the vector
//! table and the flash-resident code wait (a page erase takes 22 ms typical, DS12589): the
//! firmware writes only with the drive idle (`link::Board::save`); see that doc for the
//! watchdog.
//!
//! The register sequence is tested on the host on a zeroed FLASH block and a RAM region
//! (`tests`): the double-words land in RAM as the flash would hold them, and the words the
//! sequence left in KEYR and CR are checked; the bounds and alignments are checked before any
//! register is touched.

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};
use stm32g4::stm32g431 as pac;

/// The page (erase unit) \[bytes].
pub const PAGE: usize = 2048;
/// The programming unit, a double-word \[bytes].
pub const DWORD: usize = 8;
/// The configuration region: two pages.
pub const SIZE: usize = 2 * PAGE;
/// The region's address: the last two pages of the 128 KiB flash.
pub const BASE_ADDR: usize = 0x0800_0000 + 128 * 1024 - SIZE;
/// The region's first page number (CR.PNB).
pub const FIRST_PAGE: u32 = ((BASE_ADDR - 0x0800_0000) / PAGE) as u32;

/// FLASH_KEYR's unlock sequence (RM0440 §3.3.5).
pub const KEY1: u32 = 0x4567_0123;
/// See [`KEY1`].
pub const KEY2: u32 = 0xCDEF_89AB;

const CR_PG: u32 = 1 << 0;
const CR_PER: u32 = 1 << 1;
const CR_PNB_SHIFT: u32 = 3;
const CR_STRT: u32 = 1 << 16;
const CR_LOCK: u32 = 1 << 31;
const SR_BSY: u32 = 1 << 16;
/// SR's error flags: OPERR, PROGERR, WRPERR, PGAERR, SIZERR, PGSERR, MISERR, FASTERR,
/// RDERR, OPTVERR (bits 1, 3-9, 14, 15).
const SR_ERRORS: u32 = 0b1100_0011_1111_1010;
/// Polls of BSY before a timeout: far beyond a page erase's 40 ms maximum (DS12589) at a
/// few cycles a poll at 170 MHz.
const BUSY_POLLS: u32 = 50_000_000;

/// Why a flash operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlashError {
    /// Not on the double-word (write) or page (erase) grid.
    NotAligned,
    /// Past the region.
    OutOfBounds,
    /// The peripheral reported an error (SR's error flags).
    Hardware(u32),
    /// BSY did not clear.
    Timeout,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::NotAligned => NorFlashErrorKind::NotAligned,
            FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            FlashError::Hardware(_) | FlashError::Timeout => NorFlashErrorKind::Other,
        }
    }
}

/// The configuration region through the FLASH peripheral.
pub struct ConfigFlash<'a> {
    regs: &'a pac::flash::RegisterBlock,
    /// The region's first byte as the CPU reads it ([`BASE_ADDR`] on the board).
    base: *mut u8,
}

impl<'a> ConfigFlash<'a> {
    /// The board's region ([`BASE_ADDR`]).
    pub fn board(regs: &'a pac::flash::RegisterBlock) -> Self {
        Self {
            regs,
            base: BASE_ADDR as *mut u8,
        }
    }

    /// The region at `base` (host tests: a RAM buffer of [`SIZE`] bytes, 8-byte aligned).
    ///
    /// # Safety
    /// `base` points to [`SIZE`] bytes, readable and writable with word accesses, for as
    /// long as the value lives.
    pub unsafe fn at(regs: &'a pac::flash::RegisterBlock, base: *mut u8) -> Self {
        Self { regs, base }
    }

    fn cr(&self, v: u32) {
        // SAFETY: FLASH_CR's raw word (RM0440 §3.7.5).
        self.regs.cr().write(|w| unsafe { w.bits(v) });
    }

    /// Waits for BSY to clear, then reads (and clears) the error flags.
    fn finish(&self) -> Result<(), FlashError> {
        let mut polls = 0;
        while self.regs.sr().read().bits() & SR_BSY != 0 {
            polls += 1;
            if polls >= BUSY_POLLS {
                return Err(FlashError::Timeout);
            }
        }
        let errors = self.regs.sr().read().bits() & SR_ERRORS;
        if errors != 0 {
            // SAFETY: write 1 to clear the flags read.
            self.regs.sr().write(|w| unsafe { w.bits(errors) });
            return Err(FlashError::Hardware(errors));
        }
        Ok(())
    }

    /// Unlocks CR (if locked), runs `op` with BSY and the old errors cleared, locks again.
    fn unlocked(
        &mut self,
        op: impl FnOnce(&Self) -> Result<(), FlashError>,
    ) -> Result<(), FlashError> {
        if self.regs.cr().read().bits() & CR_LOCK != 0 {
            // SAFETY: KEYR takes the two keys (RM0440 §3.3.5).
            self.regs.keyr().write(|w| unsafe { w.bits(KEY1) });
            self.regs.keyr().write(|w| unsafe { w.bits(KEY2) });
        }
        // An earlier operation's errors would block this one (PGSERR).
        let _ = self.finish();
        let r = op(self);
        self.cr(CR_LOCK);
        r
    }
}

/// The little-endian word of up to four bytes.
fn le_word(b: &[u8]) -> u32 {
    b.iter().rev().fold(0, |w, &x| (w << 8) | u32::from(x))
}

/// `[at, at + len)` within the region, or why not.
pub fn check_range(at: u32, len: usize, grid: usize) -> Result<usize, FlashError> {
    let at = at as usize;
    if !at.is_multiple_of(grid) || !len.is_multiple_of(grid) {
        return Err(FlashError::NotAligned);
    }
    match at.checked_add(len) {
        Some(end) if end <= SIZE => Ok(at),
        _ => Err(FlashError::OutOfBounds),
    }
}

impl ErrorType for ConfigFlash<'_> {
    type Error = FlashError;
}

impl ReadNorFlash for ConfigFlash<'_> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        let at = check_range(offset, bytes.len(), 1)?;
        for (i, b) in bytes.iter_mut().enumerate() {
            // SAFETY: within the region (`check_range`), readable (`board`/`at`).
            *b = unsafe { self.base.add(at + i).read_volatile() };
        }
        Ok(())
    }

    fn capacity(&self) -> usize {
        SIZE
    }
}

impl NorFlash for ConfigFlash<'_> {
    const WRITE_SIZE: usize = DWORD;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        let len = (to as usize)
            .checked_sub(from as usize)
            .ok_or(FlashError::NotAligned)?;
        let at = check_range(from, len, PAGE)?;
        let first = FIRST_PAGE + (at / PAGE) as u32;
        for page in first..first + (len / PAGE) as u32 {
            self.unlocked(|f| {
                f.cr(CR_PER | (page << CR_PNB_SHIFT));
                f.cr(CR_PER | (page << CR_PNB_SHIFT) | CR_STRT);
                let r = f.finish();
                f.cr(0);
                r
            })?;
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let at = check_range(offset, bytes.len(), DWORD)?;
        let base = self.base;
        self.unlocked(|f| {
            f.cr(CR_PG);
            let mut r = Ok(());
            for (i, dw) in bytes.chunks_exact(DWORD).enumerate() {
                let (lo, hi) = dw.split_at(DWORD / 2);
                // SAFETY: a double-word within the region (`check_range`), 8-byte aligned
                // there (`at` on the grid, the region on a page); the low word first.
                unsafe {
                    let p = base.add(at + i * DWORD) as *mut u32;
                    p.write_volatile(le_word(lo));
                    p.add(1).write_volatile(le_word(hi));
                }
                r = f.finish();
                if r.is_err() {
                    break;
                }
            }
            f.cr(0);
            r
        })
    }
}

#[cfg(test)]
#[path = "flash_tests.rs"]
mod tests;
