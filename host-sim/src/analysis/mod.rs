//! Analyses beside the runs: the discrete-time bounds of the sliding gain (Horng & Chin
//! Sec 4, [`bounds`]) and the core's cycle counts on the emulated Cortex-M4F with the
//! firmware's flash and RAM ([`cycles`]), at each control rate ([`rate_cycles`]).

pub mod bounds;
pub mod cycles;
pub mod rate_cycles;
