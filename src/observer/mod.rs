//! Rotor observers: angle, speed and load torque from the stator currents and voltages.

pub mod flux;
pub mod ii;
pub mod pll;
pub mod sliding;
