//! The B-G431B-ESC1 firmware's interrupt path (firmware only): the control step and the
//! drive's 1 kHz task (`control`), the core's power stage on TIM1 and the ADCs
//! (`power_stage`), the watchdog and the fault handlers (`protection`), the interrupts →
//! main-loop queues and their defmt records (`telemetry`).
//!
//! A package of its own so that it is compiled for speed while the start-up and the main
//! loop (`../firmware`) are compiled for size: Cargo's optimisation level is per package
//! (`../Cargo.toml`, `[profile.release.package]`).
#![no_std]

pub mod control;
pub mod power_stage;
pub mod protection;
pub mod telemetry;
