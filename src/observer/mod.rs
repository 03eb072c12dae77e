//! Rotor observers: angle, speed and load torque from the stator currents and voltages.

pub mod sliding;
