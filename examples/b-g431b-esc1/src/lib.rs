//! The board's settings, computed from one configuration, and the init functions that write
//! them, all tested on the host: every timer, ADC, op-amp, clock and watchdog value the
//! firmware (`firmware/`, built for `thumbv7em-none-eabihf`) writes, what the drive is told
//! about the power stage (PWM frequency, dead time, control rate, the largest duty), and the
//! functions that write the peripherals. Those take the register blocks by reference (the
//! firmware's `pac::TIM1` and the like, or zeroed blocks on the host) and the CPU's part
//! through [`hw::Hw`] (busy-waits, bounded polls); `cargo test --manifest-path
//! examples/b-g431b-esc1/Cargo.toml --lib` checks the settings against RM0440's and DS12589's
//! formulas and ranges, and runs the init functions on zeroed register blocks and asserts
//! what they wrote (`init_tests`).
//!
//! The settings: `config` (the configuration and everything derived from it), `break_filter`
//! (TIM1's break input filters), `dead_time` (TIM1's dead-time generator, BDTR.DTG and
//! CR1.CKD), `pll` (the PLL's dividers within the datasheet's ranges), `tim1` (TIM1's
//! register words: PWM, preload, break, BDTR), `ocp` (the hardware over-current trip:
//! comparators, DAC3 thresholds), `ntc` (the power stage's temperature, its derating and
//! trip), `bemf` (the phase-voltage dividers: the terminal voltage for the flying start),
//! `drive_settings` (the motor, the command, the drive's configuration on this board).
//!
//! The init functions: `hw` (the CPU's part, the init errors), `clocks` (RCC, PWR, FLASH),
//! `pwm` (TIM1 and its pins, the running PWM), `adc` (OPAMPs, ADC1/ADC2, the analog pins and
//! GPIO_BEMF, the running converters), `overcurrent` (DAC3, COMP1/2/4, the system break),
//! `watchdog` (IWDG, the debug halt), `usart` (USART2 on the ST-LINK's virtual COM port, the
//! link's byte stream), `flash` (the configuration's two flash pages as a `NorFlash`),
//! `stored` (feature `link`: the settings' record in them, decoded and checked),
//! `servo_capture` (TIM2's PWM-input capture on PA15). The main loop's inputs and outputs:
//! `servo` (the servo-PWM decoder), `board_io` (the button's rules and the status LED on
//! embedded-hal's digital traits).
#![cfg_attr(not(test), no_std)]

pub mod adc;
pub mod bemf;
pub mod board_io;
pub mod break_filter;
pub mod clocks;
pub mod config;
pub mod dead_time;
pub mod drive_settings;
pub mod flash;
pub mod hw;
pub mod ntc;
pub mod ocp;
pub mod overcurrent;
pub mod pll;
pub mod pwm;
pub mod servo;
pub mod servo_capture;
#[cfg(feature = "link")]
pub mod stored;
pub mod tim1;
pub mod usart;
pub mod watchdog;

#[cfg(test)]
mod init_tests;
