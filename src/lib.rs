//! `pmsm-sensorless`: the `no_std` core of a sensorless field-oriented PMSM drive.
//!
//! Everything the 4 kHz interrupt runs lives here, in f32, without heap, without panics, and
//! without touching registers. The host simulator (`host-sim/`) runs this very code against a
//! plant model.
//!
//! Papers implemented: Horng & Chin, *sliding torque observer*; Ortega, Praly, Astolfi, Lee,
//! Nam, *gradient flux observer*. Equation numbers in comments refer to them. The inverter's
//! dead time is compensated as in Choi & Sul (1995) and Muñoz & Lipo (1999), see [`dead_time`].
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod bounds;
pub mod control;
pub mod dead_time;
pub mod drive;
pub mod fixed;
pub mod foc;
pub mod frames;
#[cfg(feature = "injection")]
pub mod injection;
pub mod load_observer;
pub mod math;
pub mod motor;
pub mod mtpa;
pub mod observer;
pub mod param;
pub mod pi;
pub mod power_stage;
pub mod rate;
pub mod schedule;

pub mod svpwm;
pub mod units;
