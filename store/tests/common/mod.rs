//! A RAM NOR flash for the store's host tests, with the STM32G431's geometry (RM0440 §3.3:
//! 2 KiB pages, 64-bit double-word programming, each double-word programmable once after an
//! erase): counts erases per page, cuts the power after a given number of programmed
//! bytes (a torn write), flips bits.
#![allow(dead_code)]

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

pub const PAGE: usize = 2048;
pub const DWORD: usize = 8;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MockError {
    NotAligned,
    OutOfBounds,
    /// A double-word programmed twice without an erase (the STM32's PROGERR).
    NotErased,
    /// The power was cut (the simulated torn write).
    PowerCut,
}

impl NorFlashError for MockError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            MockError::NotAligned => NorFlashErrorKind::NotAligned,
            MockError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            _ => NorFlashErrorKind::Other,
        }
    }
}

/// `PAGES` pages of RAM flash.
pub struct RamFlash<const PAGES: usize> {
    pub mem: Vec<u8>,
    /// Erases per page.
    pub erases: [u32; PAGES],
    /// Double-words programmed.
    pub writes: u32,
    /// Bytes that may still be programmed before the power is cut (`None`: no cut).
    pub budget: Option<usize>,
    /// What a double-word caught by the cut holds: its first bytes programmed and the rest
    /// erased (`false`), or garbage (`true`, the STM32's undefined torn double-word).
    pub torn_garbage: bool,
    /// The next erase is cut half-way: the page's first half erased, the rest as it was.
    pub cut_erase: bool,
}

impl<const PAGES: usize> RamFlash<PAGES> {
    pub fn new() -> Self {
        RamFlash {
            mem: vec![0xFF; PAGES * PAGE],
            erases: [0; PAGES],
            writes: 0,
            budget: None,
            torn_garbage: false,
            cut_erase: false,
        }
    }

    pub fn total_erases(&self) -> u32 {
        self.erases.iter().sum()
    }

    /// Flips bit `bit` of byte `at`.
    pub fn flip(&mut self, at: usize, bit: u8) {
        self.mem[at] ^= 1 << bit;
    }

    /// The power comes back: no cut pending.
    pub fn restore_power(&mut self) {
        self.budget = None;
        self.cut_erase = false;
    }
}

impl<const PAGES: usize> ErrorType for RamFlash<PAGES> {
    type Error = MockError;
}

impl<const PAGES: usize> ReadNorFlash for RamFlash<PAGES> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), MockError> {
        let at = offset as usize;
        let src = self
            .mem
            .get(at..at + bytes.len())
            .ok_or(MockError::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        PAGES * PAGE
    }
}

impl<const PAGES: usize> NorFlash for RamFlash<PAGES> {
    const WRITE_SIZE: usize = DWORD;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), MockError> {
        let (from, to) = (from as usize, to as usize);
        if !from.is_multiple_of(PAGE) || !to.is_multiple_of(PAGE) || from > to {
            return Err(MockError::NotAligned);
        }
        if to > self.mem.len() {
            return Err(MockError::OutOfBounds);
        }
        for p in from / PAGE..to / PAGE {
            if self.budget == Some(0) {
                return Err(MockError::PowerCut);
            }
            if self.cut_erase {
                self.cut_erase = false;
                self.mem[p * PAGE..p * PAGE + PAGE / 2].fill(0xFF);
                return Err(MockError::PowerCut);
            }
            self.mem[p * PAGE..(p + 1) * PAGE].fill(0xFF);
            self.erases[p] += 1;
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), MockError> {
        let at = offset as usize;
        if !at.is_multiple_of(DWORD) || !bytes.len().is_multiple_of(DWORD) {
            return Err(MockError::NotAligned);
        }
        if at + bytes.len() > self.mem.len() {
            return Err(MockError::OutOfBounds);
        }
        for (k, dw) in bytes.chunks_exact(DWORD).enumerate() {
            let a = at + k * DWORD;
            if self.mem[a..a + DWORD].iter().any(|&b| b != 0xFF) {
                return Err(MockError::NotErased);
            }
            if let Some(left) = self.budget {
                if left == 0 {
                    return Err(MockError::PowerCut);
                }
                if left < DWORD {
                    // The cut falls inside this double-word.
                    for (i, b) in dw.iter().enumerate() {
                        self.mem[a + i] = if i < left {
                            *b
                        } else if self.torn_garbage {
                            (a as u8).wrapping_mul(37).wrapping_add(i as u8) & *b
                        } else {
                            0xFF
                        };
                    }
                    self.budget = Some(0);
                    return Err(MockError::PowerCut);
                }
                self.budget = Some(left - DWORD);
            }
            self.mem[a..a + DWORD].copy_from_slice(dw);
            self.writes += 1;
        }
        Ok(())
    }
}
