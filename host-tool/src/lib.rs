//! `pmsm-tool`: the host tool of a drive that speaks the `pmsm-link` protocol (issue #28),
//! over a serial port or TCP (the emulator):
//! - [`client`]: the link's host side and the tool's errors with their exit codes;
//! - [`ops`]: what each subcommand does (config, identify, run, record, fault), as library
//!   functions;
//! - [`watch`]: live plots in the terminal;
//! - [`sim_device`] and [`serve`]: a device on the host, the core drive on the simulator's
//!   plant, served on a socket (the tests' device, and `pmsm-tool sim`).

// The tool's error carries the device's answer (a few hundred bytes), returned once per
// command: no cost worth a box.
#![allow(clippy::result_large_err)]

pub mod client;
pub mod ops;
pub mod serve;
pub mod sim_device;
pub mod watch;

pub use client::{connect, Client, Target, ToolError};
