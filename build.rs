//! Linker scripts for the board firmware example (thumbv7em-none-eabihf only): `memory.x` of
//! the STM32G431CB at the package root (found in the linker's working directory), then
//! cortex-m-rt's `link.x` and defmt's `defmt.x`. Host builds are left alone.

fn main() {
    println!("cargo:rerun-if-changed=memory.x");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        println!("cargo:rustc-link-arg-examples=-Tlink.x");
        println!("cargo:rustc-link-arg-examples=-Tdefmt.x");
    }
}
