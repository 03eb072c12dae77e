//! The board's settings, computed from one configuration and tested on the host: every
//! timer, ADC, op-amp, clock and watchdog value the firmware (`main.rs`, built for
//! `thumbv7em-none-eabihf`) writes, and what the drive is told about the power stage (PWM
//! frequency, dead time, control rate, the largest duty). No registers here: the firmware's
//! init functions write the values [`config::SETTINGS`] holds; `cargo test --manifest-path
//! examples/b-g431b-esc1/Cargo.toml --lib` checks them against RM0440's and DS12589's
//! formulas and ranges.
//!
//! `config` (the configuration and everything derived from it), `break_filter` (TIM1's
//! break input filters), `dead_time` (TIM1's
//! dead-time generator, BDTR.DTG and CR1.CKD), `pll` (the PLL's dividers within the
//! datasheet's ranges), `tim1` (TIM1's register words: PWM, preload, break, BDTR),
//! `ocp` (the hardware over-current trip: comparators, DAC3 thresholds), `ntc` (the power
//! stage's temperature, its derating and trip), `drive_settings`
//! (the motor, the command, the drive's configuration on this board).
#![cfg_attr(not(test), no_std)]

pub mod break_filter;
pub mod config;
pub mod dead_time;
pub mod drive_settings;
pub mod ntc;
pub mod ocp;
pub mod pll;
pub mod tim1;
