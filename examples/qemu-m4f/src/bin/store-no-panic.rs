//! Link-time proof that the configuration store (`pmsm-store`) cannot panic: as `no-panic`
//! for the drive, this binary's panic handler calls a function that exists nowhere, so the
//! link fails if any panic path survives optimisation in a load, a save or a summary. The
//! flash holds bytes the compiler cannot know (read through volatile loads, as a debugger
//! could have written them), with the STM32G431's geometry, and the region, the version and
//! the payload's length are unknown too. Built in CI (`cargo build ... --bin
//! store-no-panic`); never run.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!("store-no-panic is a link-time check for thumbv7em-none-eabihf");
}

#[cfg(target_os = "none")]
mod firmware {
    use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};
    use cortex_m_rt::entry;
    use embedded_storage::nor_flash::{ErrorType, NorFlash, NorFlashErrorKind, ReadNorFlash};
    use pmsm_store::{Store, MAX_LEN};

    extern "C" {
        /// Deliberately undefined: referenced only if a panic can happen.
        fn the_store_can_panic() -> !;
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        // SAFETY: never executed in a binary that links; its only purpose is to fail the link.
        unsafe { the_store_can_panic() }
    }

    const SIZE: usize = 4 * 2048;
    static mut MEM: [u8; SIZE] = [0xFF; SIZE];
    /// Region base, page count, version, payload length, and whether each call is made.
    static mut ARGS: [u32; 5] = [0; 5];
    static mut PAYLOAD: [u8; MAX_LEN + 8] = [0; MAX_LEN + 8];
    static mut SINK: u32 = 0;

    fn unknown<T: Copy>(p: *const T) -> T {
        // SAFETY: single-threaded, no interrupt; volatile so nothing is assumed of the value.
        unsafe { read_volatile(p) }
    }

    fn sink(x: u32) {
        // SAFETY: as above.
        unsafe { write_volatile(addr_of_mut!(SINK), x) };
    }

    /// Flash of the STM32G431's geometry over `MEM`, every byte unknown.
    struct Unknown;

    impl ErrorType for Unknown {
        type Error = NorFlashErrorKind;
    }

    impl ReadNorFlash for Unknown {
        const READ_SIZE: usize = 1;

        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), NorFlashErrorKind> {
            let at = offset as usize;
            if at.checked_add(bytes.len()).is_none_or(|end| end > SIZE) {
                return Err(NorFlashErrorKind::OutOfBounds);
            }
            for (i, b) in bytes.iter_mut().enumerate() {
                // SAFETY: within MEM (checked above).
                *b = unknown(unsafe { addr_of!(MEM).cast::<u8>().add(at + i) });
            }
            Ok(())
        }

        fn capacity(&self) -> usize {
            SIZE
        }
    }

    impl NorFlash for Unknown {
        const WRITE_SIZE: usize = 8;
        const ERASE_SIZE: usize = 2048;

        fn erase(&mut self, from: u32, to: u32) -> Result<(), NorFlashErrorKind> {
            if to as usize > SIZE || from > to {
                return Err(NorFlashErrorKind::OutOfBounds);
            }
            for at in from as usize..to as usize {
                // SAFETY: within MEM (checked above).
                unsafe { write_volatile(addr_of_mut!(MEM).cast::<u8>().add(at), 0xFF) };
            }
            Ok(())
        }

        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), NorFlashErrorKind> {
            let at = offset as usize;
            if at.checked_add(bytes.len()).is_none_or(|end| end > SIZE) {
                return Err(NorFlashErrorKind::OutOfBounds);
            }
            for (i, b) in bytes.iter().enumerate() {
                // SAFETY: within MEM (checked above).
                unsafe { write_volatile(addr_of_mut!(MEM).cast::<u8>().add(at + i), *b) };
            }
            Ok(())
        }
    }

    #[entry]
    fn main() -> ! {
        let a: [u32; 5] = unknown(addr_of!(ARGS));
        let store = Store::new(a[0], a[1], a[2] as u16);
        let mut flash = Unknown;
        let payload: [u8; MAX_LEN + 8] = unknown(addr_of!(PAYLOAD));
        let len = (a[3] as usize).min(payload.len());
        loop {
            if a[4] & 1 != 0 {
                if let Ok(Some(r)) = store.load(&mut flash) {
                    sink(r.seq() ^ u32::from(r.skipped()));
                    sink(r.bytes().iter().map(|&b| u32::from(b)).sum());
                }
            }
            if a[4] & 2 != 0 {
                if let Some(p) = payload.get(..len) {
                    sink(store.save(&mut flash, p).unwrap_or(0));
                }
            }
            if a[4] & 4 != 0 {
                if let Ok(s) = store.summary(&mut flash) {
                    sink(u32::from(s.valid) + u32::from(s.skipped));
                }
            }
        }
    }
}
