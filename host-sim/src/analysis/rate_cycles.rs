//! The cycle budget at each control rate the board offers (issue #26): the bench of
//! [`super::cycles`] built for one rate, with the board's update delay of one PWM period, its
//! worst step and 1 kHz task over every case, and the drive's share of the CPU there
//! (`pmsm_sensorless::rate::CpuBudget`: `(c_step·f_s + c_tick·1 kHz)/170 MHz`, the task's
//! slower work after it, `Drive::background`, counted with the task).

use serde::Serialize;
use std::collections::HashMap;

/// The control rates the B-G431B-ESC1 offers (`pmsm_sensorless::rate`: multiples of 1 kHz
/// from 4 kHz that divide its 20 kHz PWM) \[Hz].
pub const BOARD_RATES_HZ: [u32; 4] = [4000, 5000, 10_000, 20_000];

/// The bench at one control rate, with the board's update delay (one PWM period).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct RateCycles {
    /// The control rate \[Hz].
    pub rate_hz: u32,
    /// The worst step of every measured step case (sensorless on either primary, open loop,
    /// saturated, the seam, calibration and identification) \[cycles].
    pub step_max_cycles_est: u64,
    /// The worst 1 kHz task of every case \[cycles].
    pub tick_max_cycles_est: u64,
    /// The drive's share of the 170 MHz CPU at this rate,
    /// `(step·f_s + (tick + background)·1 kHz)/f_clk` \[%].
    pub cpu_share_pct: f64,
}

/// The worst step and tick of every case in `found`, at `rate_hz`.
pub fn rate_cycles(found: &HashMap<String, Vec<(u64, u64)>>, rate_hz: u32) -> RateCycles {
    let max_of = |prefix: &str| {
        found
            .iter()
            .filter(|(k, _)| k.starts_with(prefix))
            .flat_map(|(_, v)| v.iter().map(|&(_, c)| c))
            .max()
            .unwrap_or(0)
    };
    let (step, tick) = (max_of("step"), max_of("tick"));
    // The task's slower work runs after it, at most once a task.
    let task = tick + max_of("background");
    let cpu = pmsm_sensorless::rate::CpuBudget::BOARD;
    RateCycles {
        rate_hz,
        step_max_cycles_est: step,
        tick_max_cycles_est: tick,
        cpu_share_pct: 100.0 * f64::from(cpu.share_at(rate_hz as f32, step as f32, task as f32)),
    }
}
