//! `pmsm-link`: the link between a drive and its host tool (issue #28), `no_std`, no heap.
//!
//! - [`frame`]: one message per frame, COBS-framed with a CRC-16 inside (Cheshire & Baker,
//!   1999, "Consistent Overhead Byte Stuffing");
//! - [`msg`]: the messages, postcard-serialised, and their errors; the protocol version
//!   [`msg::PROTOCOL_VERSION`] checked by a hello exchange;
//! - [`settings`] and [`keys`]: every setting of a drive (the core's `Motor` and
//!   `DriveConfig`) as the link carries it, by name, validated by the core;
//! - [`wire`]: the core's drive types (mode, fault, transition, telemetry, identified motor)
//!   as the link carries them;
//! - [`server`]: the device's side, generic over an `embedded-io` stream and the firmware's
//!   [`server::Device`].
//!
//! The host's side (a client over a serial port or TCP) is the `pmsm-tool` crate's.
#![no_std]
#![deny(missing_docs)]

pub mod frame;
pub mod keys;
pub mod msg;
pub mod server;
pub mod settings;
pub mod wire;

pub use keys::Key;
pub use msg::{DeviceMsg, Event, HostMsg, LinkError, Request, Response, PROTOCOL_VERSION};
pub use server::{identification_motor, Device, DeviceError, Server};
pub use settings::Settings;
