//! The emulated board's configuration flash: two pages of the STM32G431's geometry (RM0440
//! §3.3: 2 KiB pages erased to `0xFF`, programmed one 64-bit double-word at a time, each
//! double-word once after an erase) held in RAM and written through to a file on the host
//! with semihosting (ARM Ltd., "Semihosting for AArch32 and AArch64", 2.0: SYS_OPEN,
//! SYS_SEEK, SYS_READ, SYS_WRITE, SYS_FLEN), so a reset or a restart of QEMU finds what the
//! store wrote. The file is [`FLASH_FILE`] in QEMU's working directory; absent or of another
//! size, the flash starts erased and the file is created. Each write or erase goes to the
//! file at once, only the bytes it changes: QEMU killed mid-save leaves a torn record, as a
//! power cut on the board would.

use cortex_m_semihosting::{nr, syscall};
use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// The host file holding the flash image, relative to QEMU's working directory
/// (`.cargo/qemu-link.sh` runs QEMU in its state directory).
pub const FLASH_FILE: &str = "qemu-link-flash.bin\0";
/// The STM32G431's page (erase unit) \[bytes].
pub const PAGE: usize = 2048;
/// The STM32G431's programming unit, a double-word \[bytes].
pub const DWORD: usize = 8;
/// The region: two pages, the configuration store's ring.
pub const SIZE: usize = 2 * PAGE;

/// Why a flash operation failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum FlashError {
    /// Not on the double-word (write) or page (erase) grid.
    NotAligned,
    /// Past the region.
    OutOfBounds,
    /// A double-word programmed twice without an erase (the STM32's PROGERR).
    NotErased,
    /// The host file could not be written.
    Host,
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::NotAligned => NorFlashErrorKind::NotAligned,
            FlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            FlashError::NotErased | FlashError::Host => NorFlashErrorKind::Other,
        }
    }
}

/// The flash region, in RAM, backed by the host file.
pub struct SemihostedFlash {
    mem: [u8; SIZE],
    fd: usize,
}

/// How the flash image came up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, defmt::Format)]
pub enum Opened {
    /// Read from the existing file.
    Loaded,
    /// No file (or one of another size): created, erased.
    Created,
}

impl SemihostedFlash {
    /// Opens (or creates) [`FLASH_FILE`] and loads the image; `None` if the host refuses
    /// the file (no semihosting, no write permission).
    pub fn open() -> Option<(Self, Opened)> {
        let mut f = SemihostedFlash {
            mem: [0xFF; SIZE],
            fd: 0,
        };
        // "r+b": the image as it was.
        if let Some(fd) = host_open(FLASH_FILE, nr::open::RW_BINARY) {
            f.fd = fd;
            // SAFETY: SYS_FLEN takes the handle only.
            let len = unsafe { syscall!(FLEN, fd) };
            if len == SIZE && f.host_read_all() {
                return Some((f, Opened::Loaded));
            }
            host_close(fd);
        }
        // "w+b": a new image, erased.
        f.fd = host_open(FLASH_FILE, nr::open::RW_TRUNC_BINARY)?;
        f.mem.fill(0xFF);
        f.host_write(0, SIZE).ok()?;
        Some((f, Opened::Created))
    }

    fn host_read_all(&mut self) -> bool {
        // SAFETY: SYS_SEEK with the handle and a position; SYS_READ into `mem`, which
        // outlives the call, with its length.
        unsafe {
            syscall!(SEEK, self.fd, 0) == 0
                && syscall!(READ, self.fd, self.mem.as_mut_ptr(), SIZE) == 0
        }
    }

    /// Writes `mem[at..at + len]` to the file at the same position.
    fn host_write(&mut self, at: usize, len: usize) -> Result<(), FlashError> {
        let bytes = self.mem.get(at..at + len).ok_or(FlashError::OutOfBounds)?;
        // SAFETY: SYS_SEEK as above; SYS_WRITE from `bytes`, alive for the call, with its
        // length (the call returns the count not written).
        let ok = unsafe {
            syscall!(SEEK, self.fd, at) == 0
                && syscall!(WRITE, self.fd, bytes.as_ptr(), bytes.len()) == 0
        };
        if ok {
            Ok(())
        } else {
            Err(FlashError::Host)
        }
    }
}

fn host_open(name: &str, mode: usize) -> Option<usize> {
    // The name ends with a NUL; SYS_OPEN takes its length without it.
    let len = name.len().checked_sub(1)?;
    // SAFETY: SYS_OPEN with a NUL-terminated name alive for the call.
    let fd = unsafe { syscall!(OPEN, name.as_ptr(), mode, len) } as isize;
    (fd >= 0).then_some(fd as usize)
}

fn host_close(fd: usize) {
    // SAFETY: SYS_CLOSE takes the handle only.
    unsafe { syscall!(CLOSE, fd) };
}

impl ErrorType for SemihostedFlash {
    type Error = FlashError;
}

impl ReadNorFlash for SemihostedFlash {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
        let at = offset as usize;
        let src = self
            .mem
            .get(at..at + bytes.len())
            .ok_or(FlashError::OutOfBounds)?;
        bytes.copy_from_slice(src);
        Ok(())
    }

    fn capacity(&self) -> usize {
        SIZE
    }
}

impl NorFlash for SemihostedFlash {
    const WRITE_SIZE: usize = DWORD;
    const ERASE_SIZE: usize = PAGE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
        let (from, to) = (from as usize, to as usize);
        if !from.is_multiple_of(PAGE) || !to.is_multiple_of(PAGE) || from > to {
            return Err(FlashError::NotAligned);
        }
        self.mem
            .get_mut(from..to)
            .ok_or(FlashError::OutOfBounds)?
            .fill(0xFF);
        self.host_write(from, to - from)
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
        let at = offset as usize;
        if !at.is_multiple_of(DWORD) || !bytes.len().is_multiple_of(DWORD) {
            return Err(FlashError::NotAligned);
        }
        let dst = self
            .mem
            .get_mut(at..at + bytes.len())
            .ok_or(FlashError::OutOfBounds)?;
        // Every double-word erased before any is programmed (the STM32 checks each).
        if dst.iter().any(|&b| b != 0xFF) {
            return Err(FlashError::NotErased);
        }
        dst.copy_from_slice(bytes);
        self.host_write(at, bytes.len())
    }
}
