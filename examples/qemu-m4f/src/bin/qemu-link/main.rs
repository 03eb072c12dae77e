//! The drive on the emulated Cortex-M4F with its configuration in flash and the link on the
//! UART (issue #28): at boot the settings are loaded from the store (`pmsm-store`, two pages
//! of emulated STM32G431 flash kept in a host file, [`flash`]) and validated by the core
//! ([`config`]); with none, or a corrupt one, or one of another format version, there is no
//! drive (it refuses to run) and the link still answers. The control loop ([`device`]: the
//! core's `Control` on the simulator's plant, [`bench`]) runs one step at a time; between two
//! steps the link's server (`pmsm_link::Server`) is polled on UART0 ([`uart`], a host TCP
//! socket: `.cargo/qemu-link.sh`), never within a step. The host tool (`pmsm-tool --tcp`)
//! configures, saves, identifies, runs, records and clears faults through it
//! (`scripts/link_e2e.py` tests it end to end).
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!(
        "qemu-link is firmware: run it with .cargo/qemu-link.sh (thumbv7em-none-eabihf under QEMU)"
    );
}

#[cfg(target_os = "none")]
mod bench;
#[cfg(target_os = "none")]
mod config;
#[cfg(target_os = "none")]
mod device;
#[cfg(target_os = "none")]
mod flash;
#[cfg(target_os = "none")]
mod uart;

#[cfg(target_os = "none")]
mod firmware {
    use cortex_m_rt::entry;
    use cortex_m_semihosting::debug::{self, EXIT_FAILURE};
    use defmt_semihosting as _;
    use panic_probe as _;
    use pmsm_link::{Server, Settings};

    use crate::config::{decode, STORE};
    use crate::device::Firmware;
    use crate::flash::SemihostedFlash;
    use crate::uart::CmsdkUart;

    const BAUD: u32 = 115_200;

    /// The settings stored, or why the drive does not run.
    fn load_settings(flash: &mut SemihostedFlash) -> Option<Settings> {
        match STORE.load(flash) {
            Ok(Some(rec)) => {
                defmt::info!(
                    "configuration: record {=u32}, {=usize} bytes ({=u16} bad records skipped)",
                    rec.seq(),
                    rec.bytes().len(),
                    rec.skipped()
                );
                match decode(rec.bytes()) {
                    Ok(s) => Some(s),
                    Err(e) => {
                        defmt::error!("configuration refused: {}; the drive will not run", e);
                        None
                    }
                }
            }
            Ok(None) => {
                let skipped = STORE.summary(flash).map(|s| s.skipped).unwrap_or(0);
                defmt::warn!(
                    "no valid configuration stored ({=u16} bad records); the drive will not run",
                    skipped
                );
                None
            }
            Err(e) => {
                defmt::error!(
                    "configuration store: {=str}; the drive will not run",
                    e.name()
                );
                None
            }
        }
    }

    #[entry]
    fn main() -> ! {
        // SAFETY: the only handle on UART0.
        let mut uart = unsafe { CmsdkUart::uart0(BAUD) };
        let Some((mut flash, opened)) = SemihostedFlash::open() else {
            defmt::error!(
                "flash image {=str}: cannot open it on the host",
                crate::flash::FLASH_FILE.trim_end_matches(char::from(0))
            );
            debug::exit(EXIT_FAILURE);
            loop {
                cortex_m::asm::wfi();
            }
        };
        defmt::info!("flash image: {}", opened);
        let settings = load_settings(&mut flash);
        let mut dev = Firmware::new(settings, flash);
        defmt::info!(
            "link on UART0 at {=u32} bit/s; drive {=str}",
            BAUD,
            if dev.has_drive() {
                "configured"
            } else {
                "refused"
            }
        );
        let mut server = Server::new();
        loop {
            dev.step();
            // Between two steps, never within one: the UART's Error is Infallible.
            let Ok(()) = server.poll(&mut uart, &mut dev);
            if dev.restart_due() {
                // The answer on the wire first, then a system reset (SYSRESETREQ: QEMU
                // restarts the machine from the image; the flash file stays).
                defmt::info!("restart asked over the link");
                let Ok(()) = embedded_io::Write::flush(&mut uart);
                cortex_m::peripheral::SCB::sys_reset();
            }
        }
    }
}
