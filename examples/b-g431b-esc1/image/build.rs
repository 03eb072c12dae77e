//! Linker scripts for the firmware (thumbv7em-none-eabihf only): the STM32G431CB memory map
//! `memory.x` at the repository root (the product keeps it there; cortex-m-rt's `link.x`
//! includes it from the search path added here), the board's `ramfunc.x` (`../ramfunc.x`: the
//! control path in CCM SRAM), `link.x` and defmt's `defmt.x`. Host builds (the stub `main`) are left alone.
//!
//! `ramfunc.x` comes before `link.x`: the linker gives an input section to the first pattern
//! that matches it in script order, and `link.x`'s `.rodata.*` would otherwise keep the
//! sin/cos table in flash.

use std::path::PathBuf;

fn main() {
    let here = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").expect("set by cargo"));
    let board = here.join("..");
    let root = here.join("../../..");
    println!("cargo:rerun-if-changed={}", root.join("memory.x").display());
    println!(
        "cargo:rerun-if-changed={}",
        board.join("ramfunc.x").display()
    );
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        println!("cargo:rustc-link-search={}", root.display());
        println!("cargo:rustc-link-search={}", board.display());
        println!("cargo:rustc-link-arg-bins=-Tramfunc.x");
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}
