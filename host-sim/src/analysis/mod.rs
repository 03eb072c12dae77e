//! Analyses beside the runs: the discrete-time bounds of the sliding gain (Horng & Chin
//! Sec 4, [`bounds`]) and the core's cycle counts on the emulated Cortex-M4F with the
//! firmware's flash and RAM ([`cycles`]), at each control rate ([`rate_cycles`]); the same
//! bench on an emulated Cortex-M0 ([`cycles_m0`]).

pub mod bounds;
pub mod cycles;
pub mod cycles_m0;
pub mod rate_cycles;
