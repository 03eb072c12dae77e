//! The B-G431B-ESC1 firmware image: the reset entry, which runs the firmware
//! (`pmsm_b_g431b_esc1_firmware::run`, `../firmware`), and the panic handler (probe-rs
//! prints the panic and stops). What the firmware does, and how to build and flash it:
//! `../firmware/src/lib.rs` and `../README.md`.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!(
        "b-g431b-esc1 is firmware: build it with `cargo fw` (thumbv7em-none-eabihf), flash it with `cargo flash-esc1`"
    );
}

#[cfg(target_os = "none")]
use panic_probe as _;

#[cfg(target_os = "none")]
#[cortex_m_rt::entry]
fn main() -> ! {
    pmsm_b_g431b_esc1_firmware::run()
}
