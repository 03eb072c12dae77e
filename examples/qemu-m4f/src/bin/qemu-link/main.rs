//! The drive on the emulated Cortex-M4F with its configuration in flash and a link on the
//! UART (issue #28): at boot the configuration is loaded from the store (`pmsm-store`, two
//! pages of emulated STM32G431 flash kept in a host file, [`flash`]); with none, or a
//! corrupt one, or one of another format version, the drive refuses to run and only the
//! link is served. With one, the drive runs the simulator's plant ([`bench`]) as `qemu-m4f`
//! does, at 1000 rpm, for as long as QEMU runs, and the link is polled between control
//! steps on UART0 ([`uart`], a host TCP socket: `.cargo/qemu-link.sh`).
//!
//! The link is a stand-in ([`placeholder`]) until the link crate's server replaces it: where
//! `Placeholder::poll` is called below, call `pmsm_link::Server::poll(&mut uart, &mut dev)`
//! with a `Device` over the control, the store and the flash (its `save` is
//! `Store::save(&mut flash, &postcard-serialised settings)`), and decode the record in
//! `config::drive_config`.
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
mod flash;
#[cfg(target_os = "none")]
mod placeholder;
#[cfg(target_os = "none")]
mod uart;

#[cfg(target_os = "none")]
mod firmware {
    use cortex_m_rt::entry;
    use cortex_m_semihosting::debug::{self, EXIT_FAILURE};
    use defmt_semihosting as _;
    use panic_probe as _;
    use pmsm_sensorless::control::{Commands, Control};
    use pmsm_sensorless::drive::{Drive, DriveConfig};
    use pmsm_sensorless::observer::Observer;
    use pmsm_store::Store;

    use crate::bench::Bench;
    use crate::config::{drive_config, CONFIG_VERSION};
    use crate::flash::SemihostedFlash;
    use crate::placeholder::{After, Placeholder, Status};
    use crate::uart::CmsdkUart;

    const RATE_HZ: f32 = 4000.0;
    const SPEED_CMD_RPM: f32 = 1000.0;
    const BAUD: u32 = 115_200;
    /// The store: the flash region's two pages.
    const STORE: Store = Store::new(0, 2, CONFIG_VERSION);
    /// A telemetry line in the log every this many steps (1 s).
    const LOG_EVERY: u32 = 4000;

    /// The configuration stored, or why the drive does not run.
    fn load_config(flash: &mut SemihostedFlash) -> Option<DriveConfig> {
        match STORE.load(flash) {
            Ok(Some(rec)) => {
                defmt::info!(
                    "configuration: record {=u32}, {=usize} bytes ({=u16} bad records skipped)",
                    rec.seq(),
                    rec.bytes().len(),
                    rec.skipped()
                );
                match drive_config(rec.bytes()) {
                    Ok(cfg) => Some(cfg),
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

    /// Runs the drive (if configured) and serves the link between its steps, forever.
    fn serve<P: Observer, M: Observer>(
        mut control: Option<Control<P, M, Bench>>,
        mut uart: CmsdkUart,
        mut flash: SemihostedFlash,
    ) -> ! {
        let cmd = Commands {
            enable: true,
            speed_rpm: SPEED_CMD_RPM,
            ..Commands::default()
        };
        let mut link = Placeholder::new();
        let mut k = 0u32;
        loop {
            let mut status = Status {
                driving: false,
                speed_rpm: 0.0,
                fault: false,
            };
            if let Some(control) = control.as_mut() {
                let (stepped, ticked) = control.run(&cmd);
                for tr in stepped.transition.into_iter().chain(ticked.transitions()) {
                    defmt::info!("step {=u32}: {} -> {} ({})", k, tr.from, tr.to, tr.reason);
                }
                if k.is_multiple_of(LOG_EVERY) {
                    defmt::info!("{}", control.telemetry());
                }
                control.stage_mut().advance();
                status = Status {
                    driving: true,
                    speed_rpm: control.stage_mut().speed_rpm(),
                    fault: control.state().fault().is_some(),
                };
                k = k.wrapping_add(1);
            }
            // TODO(lead, issue #28): `server.poll(&mut uart, &mut device)` (pmsm_link::Server).
            match link.poll(&mut uart, &mut flash, &STORE, &status) {
                Ok(After::Reset) => {
                    defmt::info!("link: reset");
                    cortex_m::peripheral::SCB::sys_reset();
                }
                Ok(After::Nothing) => {}
                Err(e) => match e {},
            }
        }
    }

    #[entry]
    fn main() -> ! {
        // SAFETY: the only handle on UART0.
        let uart = unsafe { CmsdkUart::uart0(BAUD) };
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
        let drive: Option<Drive<_, _>> = load_config(&mut flash).and_then(|cfg| {
            cfg.build_flux_primary()
                .map_err(|e| defmt::error!("configuration: {}", e.field()))
                .ok()
        });
        let control = drive.map(|d| Control::new(d, Bench::new(RATE_HZ)));
        defmt::info!(
            "link on UART0 at {=u32} bit/s; drive {=str}",
            BAUD,
            if control.is_some() {
                "running"
            } else {
                "refused"
            }
        );
        serve(control, uart, flash)
    }
}
