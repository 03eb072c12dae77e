//! The speed loop's gain lowered where the loop oscillates: a configured inertia above the
//! rotor's (issue #26: a datasheet's inertia with a load assumed on the shaft, a rotor-only
//! figure mistaken for another motor's) makes the speed loop's gain `kp = J ω_s/K_t`
//! (`crate::foc`) as many times too high, its crossover beyond the speed estimate's filter
//! (the PLL, `observer::pll`), and the loop limit-cycles: the torque command banging between
//! its limits tens of times a second, the rotor's mean speed off its command, and on some
//! motors the observers lost.
//!
//! Measured on the zoo's motors (`host-sim/matrices/zoo-inertia.toml`, the drive told ten
//! times the rotor's inertia, then a tenth): with the speed loop's gain at the rotor's
//! inertia and everything else at the wrong one, 336 of the 384 cells pass, against 163 with
//! the configured one: the speed loop's gain is what the mismatch breaks.
//!
//! **The check.** Over intervals of 0.1 s of the speed loop's runs (1 kHz), the speed error
//! `ω_ref − ω̂` crossing from beyond `+b` to beyond `−b` or back at least
//! [`Settings::crossings`] times (`b` = 2 % of rated speed, the verdict's tolerance;
//! `crossings` = an oscillation at twice the speed loop's bandwidth or faster, at least 8
//! crossings, 40 Hz), with the torque command at 0.99 of the current limit (the stall check's
//! test; a limit cycle against a lower bound, the field weakening's, the voltage's or the
//! regeneration's, is not counted) in at least as many of the runs beyond the band: a limit
//! cycle (the speed estimate's noise alone does not take the command to its limit; a step's
//! overshoot crosses once or twice), in two intervals in a row. Then the gain is halved, down
//! to [`GAIN_MIN`] (an inertia configured 16 times too high). Commercial servo drives detect
//! such vibration and lower their gain or raise an alarm (e.g. Yaskawa Σ-7's vibration
//! detection, parameters Pn310–Pn312). Not on a salient motor: its task has no room for the
//! check (`DEVELOPERS.md`'s budget), so its gain stays.
//!
//! Behind the core's cargo feature `speed-gain` (default; the simulator, its tests and the
//! emulated bench have it): the board images, built without the default features, do not
//! (their 64 KiB flash budget had 188 B left, and the check took 428 B of it; issue #28).
//!
//! The gain scales the speed PI's error ([`Foc::speed_step_scaled`](crate::foc::Foc)), so the
//! integrator's current does not step. It is kept from one run to the next, and never raised
//! again: a configured inertia below the rotor's (a loop too slow, not oscillating) is not
//! seen here; issue #26's note gives the measurement tried for it and why it did not land.

use crate::units::RAD_S_PER_RPM;
use core::hint::cold_path;

/// Intervals in a row that oscillate halve the gain: a limit cycle lasts, a burst of a noisy
/// speed estimate at low speed does not (with one, the gimbal motor's sliding observer at
/// 150 rpm under a warm winding, and the drone motor's reversal under a brake, lowered the gain
/// of a loop that was right, and failed).
const INTERVALS: u8 = 2;

/// The least speed-loop gain factor.
pub(super) const GAIN_MIN: f32 = 1.0 / 16.0;

/// The speed loop's runs (1 kHz) per interval: 0.1 s.
const INTERVAL: u16 = 100;

/// The least crossings of the band an interval that halve the gain: 8, a 40 Hz oscillation.
const CROSSINGS_MIN: u16 = 8;

/// The check's settings (from the motor's rated speed and the speed loop's bandwidth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// The speed error's band \[rad/s].
    pub(super) band: f32,
    /// Crossings of it in one interval, and checks beyond it with the command at its limit,
    /// that halve the gain.
    pub(super) crossings: u16,
}

impl Settings {
    /// The check for a motor of rated speed `rated_rpm` and a speed loop of
    /// `speed_bandwidth_hz` (module doc): the band 2 % of rated speed, the crossings of an
    /// oscillation at twice the bandwidth or faster (at least 8).
    pub(super) fn new(rated_rpm: f32, speed_bandwidth_hz: f32) -> Self {
        if !cfg!(feature = "speed-gain") {
            return Self {
                band: 0.0,
                crossings: 0,
            };
        }
        // 4 f_s crossings a second, over an interval of `INTERVAL` ms; at most half the
        // interval's runs (a speed loop above 125 Hz: an oscillation at the task's rate over
        // four).
        let crossings = (speed_bandwidth_hz * (4e-3 * INTERVAL as f32)) as u16;
        Self {
            band: 0.02 * rated_rpm * RAD_S_PER_RPM,
            crossings: crossings.clamp(CROSSINGS_MIN, INTERVAL / 2),
        }
    }
}

/// The speed loop's gain factor and the check's state, in the drive's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct State {
    /// The gain factor, 1 at the configured inertia; kept across runs.
    pub(super) gain: f32,
    /// Checks into this interval.
    count: u16,
    /// The side of the band the speed error was last beyond: +1, −1, 0 (none yet this run).
    side: i8,
    /// Crossings of the band in this interval.
    crossings: u16,
    /// Checks beyond the band with the command at the limit in this interval.
    at_limit: u16,
    /// Intervals in a row that oscillated.
    oscillating: u8,
}

impl Default for State {
    fn default() -> Self {
        Self {
            gain: 1.0,
            count: 0,
            side: 0,
            crossings: 0,
            at_limit: 0,
            oscillating: 0,
        }
    }
}

impl State {
    /// The speed loop's gain factor: 1 without the cargo feature `speed-gain`.
    #[inline(always)]
    pub(super) fn gain(&self) -> f32 {
        if cfg!(feature = "speed-gain") {
            self.gain
        } else {
            1.0
        }
    }

    /// Sensorless control entered, or the driving observer not locked (or just switched): the
    /// interval begins again (that run's check is its first).
    pub(super) fn restart(&mut self) {
        if !cfg!(feature = "speed-gain") {
            return;
        }
        self.count = 0;
        self.side = 0;
        self.crossings = 0;
        self.at_limit = 0;
        self.oscillating = 0;
    }
}

impl Settings {
    /// One run of the speed loop in sensorless control: `error_rad_s` the
    /// speed error `ω_ref − ω̂` \[rad/s], `at_limit` the speed loop's torque current command
    /// at 0.99 of the current limit (the stall check's).
    #[inline(always)]
    pub(super) fn check(&self, s: &mut State, error_rad_s: f32, at_limit: bool) {
        if !cfg!(feature = "speed-gain") {
            return;
        }
        if error_rad_s.abs() > self.band {
            let side = if error_rad_s > 0.0 { 1 } else { -1 };
            s.crossings += u16::from(side == -s.side);
            s.side = side;
            s.at_limit += u16::from(at_limit);
        }
        s.count += 1;
        if s.count < INTERVAL {
            return;
        }
        // The interval's verdict: a limit cycle halves the gain.
        cold_path();
        let oscillating = s.crossings >= self.crossings && s.at_limit >= self.crossings;
        s.oscillating = if oscillating { s.oscillating + 1 } else { 0 };
        if s.oscillating >= INTERVALS {
            s.gain = (0.5 * s.gain).max(GAIN_MIN);
            s.oscillating = 0;
        }
        s.count = 0;
        s.crossings = 0;
        s.at_limit = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SETTINGS: Settings = Settings {
        band: 6.0,
        crossings: 8,
    };

    /// The gain after `checks` checks of a square-wave speed error of ±10 rad/s with
    /// `half_period` checks per half, the command at ±`i_a`.
    fn after(checks: u32, half_period: u32, i_a: f32) -> f32 {
        let mut s = State::default();
        for k in 0..checks {
            let sign = if (k / half_period).is_multiple_of(2) {
                1.0
            } else {
                -1.0
            };
            SETTINGS.check(&mut s, 10.0 * sign, i_a >= 9.0);
        }
        s.gain
    }

    #[test]
    fn a_fast_limit_cycle_halves_the_gain_each_interval_down_to_the_least() {
        // 20 crossings an interval; halved every second interval.
        assert_eq!(after(100, 5, 10.0), 1.0);
        assert_eq!(after(200, 5, 10.0), 0.5);
        assert_eq!(after(400, 5, 10.0), 0.25);
        assert_eq!(after(2000, 5, 10.0), GAIN_MIN);
    }

    #[test]
    fn a_slow_oscillation_noise_or_a_small_one_leave_the_gain() {
        // 4 crossings an interval (a 20 Hz oscillation): the loop's own response, not a gain
        // too high.
        assert_eq!(after(1000, 25, 10.0), 1.0);
        // Fast, the command far from its limit: the speed estimate's noise.
        assert_eq!(after(1000, 5, 2.0), 1.0);
        // Fast at the limit, within the band.
        let mut s = State::default();
        for k in 0..1000 {
            let sign = if (k / 5u32).is_multiple_of(2) {
                1.0
            } else {
                -1.0
            };
            SETTINGS.check(&mut s, 5.0 * sign, true);
        }
        assert_eq!(s.gain, 1.0);
    }
}
