//! Linker scripts for the emulator binary (thumbv6m-none-eabi only): this package's
//! memory.x is found in the linker's working directory; cortex-m-rt's link.x and defmt's
//! defmt.x complete it. Host builds (the stub `main`) are left alone.

fn main() {
    println!("cargo:rerun-if-changed=memory.x");
    if std::env::var("CARGO_CFG_TARGET_OS").as_deref() == Ok("none") {
        println!("cargo:rustc-link-arg-bins=-Tlink.x");
        println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
    }
}
