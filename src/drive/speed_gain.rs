//! The speed loop's gain set from how the loop oscillates, for a configured inertia `J₀` that
//! is not the rotor's `J` (issue #26: a datasheet's rotor inertia with a load on the shaft, a
//! figure with a load assumed that is not there, another motor's). The speed PI's gain is
//! `kp = J₀ ω_s/K_t` (`crate::foc`); the gain factor here scales it toward `J/J₀`.
//!
//! Measured on the zoo's motors (`host-sim/matrices/zoo-inertia.toml`, the drive told ten
//! times the rotor's inertia, then a tenth): with the speed loop's gain at the rotor's
//! inertia and everything else at the wrong one, 336 of the 384 cells pass, against 163 with
//! the configured one: the speed loop's gain is what the mismatch breaks. With the two
//! checks below, 296; 313 with the current loop's decoupling on the last task's speed
//! (`sensorless.rs`, `Settings::step`).
//!
//! **`J₀` too high: the fast check halves the gain.** The loop's crossover lies beyond the
//! speed estimate's filter (the PLL, `observer::pll`), and it limit-cycles: the torque
//! command banging between its limits tens of times a second, the rotor's mean speed off its
//! command, on some motors the observers lost. Over intervals of 0.1 s of the speed loop's
//! runs (1 kHz), the speed error `ω_ref − ω̂` crossing from beyond `+b` to beyond `−b` or back
//! at least [`Settings::crossings`] times (`b` = 2 % of rated speed, the verdict's tolerance;
//! `crossings` = an oscillation at twice the speed loop's bandwidth or faster, at least 8
//! crossings, 40 Hz), with the torque command at 0.99 of the current limit (the stall check's
//! test; a limit cycle against a lower bound, the field weakening's, the voltage's or the
//! regeneration's, is not counted) in at least as many of the runs beyond the band: a limit
//! cycle (the speed estimate's noise alone does not take the command to its limit; a step's
//! overshoot crosses once or twice), in two intervals in a row. Then the gain is halved, down
//! to [`GAIN_MIN`]. Commercial servo drives detect such vibration and lower their gain or
//! raise an alarm (e.g. Yaskawa Σ-7's vibration detection, parameters Pn310–Pn312).
//!
//! **`J₀` too low: the slow check measures `J`.** The loop is too slow, and with the
//! load-torque observer (`crate::load_observer`, bandwidth `g`) it oscillates slowly: the
//! observer's `J₀` makes the rotor look like `J₀` only below `g J₀/J` and like `J` above, and
//! between the two the speed PI sees a double integrator, `g/(J s²)`; its crossover falls
//! there, near `√(J₀/J · ω_s g)` (4.5 Hz at a tenth of the inertia with the default 20 Hz loop
//! and 10 Hz observer), with no phase margin (measured: the Teknic servo at its rated speed
//! swinging ±2,000 rpm at 6 Hz). The speed loop's runs are taken in blocks of 16 ms: each
//! block's mean speed's change from the last block's, `x`, against the mean of the two
//! blocks' torque currents times a block's time, `y`: `y = (J/K_t) x + c` for a constant load
//! `c` (low by `sinc(ωT_b)/sinc²(ωT_b/2)` for an oscillation at ω, the currents weighted evenly
//! where the speed means weight them as a triangle: 2 % at 5 Hz, 9 % at 10 Hz). Over 32
//! blocks (0.512 s) with the speed error crossing the band at least 4 times (an oscillation,
//! about 3 Hz or faster), a slope where the two least-squares slopes agree (the correlation squared
//! at least 0.8, and positive: a load that moves the speed makes a negative one) of at least
//! twice `J₀/K_t` raises the gain to `Ĵ/J₀`, at most [`GAIN_MAX`]. The oscillation excites
//! the rotor as the relay-feedback test of auto-tuning does (Åström & Hägglund, "Automatic
//! tuning of simple regulators with specifications on phase and amplitude margins",
//! Automatica 20(5), 1984), and the slope is the inertia identification of servo auto-tuning
//! from the mechanical equation (e.g. Yaskawa Σ-7's moment of inertia estimation, Pn103). A
//! switch of the driving observer does not restart it (the two estimate one speed; a
//! sliding primary with the wrong inertia hands over to the monitor and back every few tens
//! of milliseconds).
//!
//! **Not solved: `J₀` ten times the rotor's on the drone and the DF45** (32 of the 71 cells
//! `zoo-inertia.toml` fails). The loop's crossover lands at ten times its bandwidth, 200 Hz on
//! a 1 kHz loop, and the oscillation grows about twofold a period (110 to 200 Hz) from the
//! hand-over on: it crosses the fast check's band some 10 ms before the observers lose the
//! rotor, too late for two intervals of 0.1 s. The load-torque observer (`crate::load_observer`,
//! bandwidth `g`) is unstable there by itself: with `r = J₀/J` its loop is
//! `1 + (r − 1) Q(s) e^{−sτ}`, `Q = g/(s + g)`, `τ` the PLL's and the task's lag (about 4.7 ms,
//! an estimate), whose gain `(r − 1)|Q(jω₁₈₀)|` exceeds 1 for `r` above about 7 at
//! `g` = 2π·10 Hz (`ω₁₈₀` near 2π·60 Hz): the DF45 with the speed PI's gain at a sixteenth
//! still oscillated at 60 Hz. Tried in session 18, measured and not kept: a check on the
//! torque command's swings between the speed error's half-cycles (three in a row shorter than
//! an oscillation at twice the bandwidth, each 1.25 times the last, from a tenth of the current
//! limit up) cutting the gain to a quarter: the drone's unloaded and ramp cells passed (+8),
//! but the Brusa lost 8 cells of `zoo.toml` with its identified file (a correct `J₀`) and the
//! Anaheims 4 of `zoo-inertia.toml`; with the load-torque observer's inertia scaled by the gain
//! factor as well, the Anaheims' `J₀ = 10 J` cells all passed (16, 12 before) but the drone's
//! 8 were lost again; the observer's bandwidth halved alone: +4 of 64 cells (four motors) at
//! ten times the inertia, −4 of the 192 at a tenth. Measuring `J` before the loop closes (the
//! I/f start's current against its acceleration) is the way left open.
//!
//! Both checks count in the speed loop's run (the 1 kHz task, [`Settings::check`]: the
//! block's sums, the crossings, +21 cycles on the emulated Cortex-M4F); their block and
//! interval ends, the regression and the verdicts, run after it
//! ([`Drive::background`](super::Drive::background), [`Settings::background`]: once every 16
//! tasks at most; `pmsm-sim cycles` measures them with the motor model's check there), so
//! that the task keeps its budget. The gain scales the
//! speed PI's error ([`Foc::speed_step_scaled`](crate::foc::Foc)), so the integrator's
//! current does not step. It is kept from one run to the next. The load-torque observer and
//! the sliding torque observer keep `J₀`: the sliding observer carries it in every
//! coefficient of its model (`observer::sliding`), which are the drive's settings, built
//! once, and with a tenth of the rotor's inertia it loses the rotor where the flux observer
//! keeps it (`host-sim/tests/inertia_mismatch.rs`). Neither check runs on a salient motor:
//! its task has no room for them (`DEVELOPERS.md`'s budget), so its gain stays.
//!
//! Behind the core's cargo feature `speed-gain` (default; the simulator, its tests and the
//! emulated bench have it): the board images, built without the default features, do not
//! (their 64 KiB flash budget had 188 B left, and the fast check alone took 428 B; issue
//! #28).

// Without the cargo feature `speed-gain` only the gain (1) is left of this module.
#![cfg_attr(not(feature = "speed-gain"), allow(dead_code, unused_imports))]

use crate::math::{max, min, sqrt_call};
use crate::motor::MotorParams;
use crate::schedule::TICK_HZ;
use crate::units::RAD_S_PER_RPM;
use core::hint::cold_path;

/// Intervals in a row that oscillate halve the gain: a limit cycle lasts, a burst of a noisy
/// speed estimate at low speed does not (with one, the gimbal motor's sliding observer at
/// 150 rpm under a warm winding, and the drone motor's reversal under a brake, lowered the gain
/// of a loop that was right, and failed).
const INTERVALS: u8 = 2;

/// The least speed-loop gain factor.
pub(super) const GAIN_MIN: f32 = 1.0 / 16.0;

/// The greatest speed-loop gain factor.
pub(super) const GAIN_MAX: f32 = 16.0;

/// The speed loop's runs (1 kHz) per interval: 0.1 s.
const INTERVAL: u16 = 100;

/// The least crossings of the band an interval that halve the gain: 8, a 40 Hz oscillation.
const CROSSINGS_MIN: u16 = 8;

/// The speed loop's period \[s].
const TICK_S: f32 = 1.0 / TICK_HZ;

/// The speed loop's runs per block of the regression: 16 ms.
const BLOCK: u8 = 16;

/// The slow check's interval in blocks: 0.512 s.
const SLOW_BLOCKS: f32 = 32.0;

/// The least crossings of the band over the slow check's interval that are an oscillation:
/// one and a half periods or more in 0.512 s, about 3 Hz or faster.
const SLOW_CROSSINGS_MIN: u16 = 4;

/// The least square of the correlation of the blocks' speed change and charge that is an
/// inertia's: the two least-squares slopes within 20 % of each other.
const R2_MIN: f32 = 0.8;

/// The least ratio of the inertia measured to the configured one that raises the gain.
const RAISE_MIN: f32 = 2.0;

/// The check's settings (from the motor's rated speed and the speed loop's bandwidth).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// The speed error's band \[rad/s].
    pub(super) band: f32,
    /// Crossings of it in one interval, and checks beyond it with the command at its limit,
    /// that halve the gain.
    pub(super) crossings: u16,
    /// The configured inertia over the torque constant, `J₀/K_t` \[A·s/rad]: the charge of
    /// torque current that changes the speed by 1 rad/s at the configured inertia.
    pub(super) j0_a_s: f32,
}

impl Settings {
    /// The checks for the motor `m` of rated speed `rated_rpm` and a speed loop of
    /// `speed_bandwidth_hz` (module doc): the band 2 % of rated speed, the crossings of an
    /// oscillation at twice the bandwidth or faster (at least 8), and its `J₀/K_t`.
    pub(super) fn new(rated_rpm: f32, speed_bandwidth_hz: f32, m: &MotorParams) -> Self {
        if !cfg!(feature = "speed-gain") {
            return Self {
                band: 0.0,
                crossings: 0,
                j0_a_s: 0.0,
            };
        }
        // 4 f_s crossings a second, over an interval of `INTERVAL` ms; at most half the
        // interval's runs (a speed loop above 125 Hz: an oscillation at the task's rate over
        // four).
        let crossings = (speed_bandwidth_hz * (4e-3 * INTERVAL as f32)) as u16;
        Self {
            band: 0.02 * rated_rpm * RAD_S_PER_RPM,
            crossings: crossings.clamp(CROSSINGS_MIN, INTERVAL / 2),
            j0_a_s: m.j_kgm2 / m.torque_constant(),
        }
    }
}

/// The speed loop's gain factor and the checks' state, in the drive's state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct State {
    /// The gain factor, 1 at the configured inertia; kept across runs.
    pub(super) gain: f32,
    /// The fast check's.
    #[cfg(feature = "speed-gain")]
    fast: Fast,
    /// The slow check's.
    #[cfg(feature = "speed-gain")]
    slow: Slow,
}

/// The fast check's state.
#[cfg(feature = "speed-gain")]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Fast {
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

/// The slow check's state.
#[cfg(feature = "speed-gain")]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Slow {
    /// Crossings of the band in its interval.
    crossings: u16,
    /// Checks into this block, and the sums of its torque currents `Σ i_τ` \[A] and speeds
    /// `Σ ω` \[rad/s].
    block: u8,
    block_i_a: f32,
    block_omega: f32,
    /// The last block's mean torque current \[A] and speed \[rad/s] (none yet this run).
    last: Option<(f32, f32)>,
    /// The blocks of its interval.
    blocks: Regression,
}

/// Sums of the blocks' speed change `x` \[rad/s] and torque current charge `y` \[A·s] for
/// their regression, taken about the first block's (`origin`), so that a nearly constant `x`
/// (a steady ramp) leaves its small variance to the sums, not to the cancellation of large
/// ones.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Regression {
    origin: (f32, f32),
    n: f32,
    x: f32,
    y: f32,
    xx: f32,
    xy: f32,
    yy: f32,
}

impl Regression {
    /// Adds a block; the first (`n` zero) starts the sums afresh, so that a restart only
    /// clears `n`.
    fn add(&mut self, x: f32, y: f32) {
        if self.n == 0.0 {
            *self = Regression {
                origin: (x, y),
                ..Regression::default()
            };
        }
        let (x, y) = (x - self.origin.0, y - self.origin.1);
        self.n += 1.0;
        self.x += x;
        self.y += y;
        self.xx += x * x;
        self.xy += x * y;
        self.yy += y * y;
    }

    /// `Ĵ/J₀` from `y = (J/K_t) x + c` (a constant load, `c`) and `J₀/K_t` = `j0_a_s`
    /// \[A·s/rad]: the reduced major axis `√(var y/var x)`, between the two least-squares
    /// slopes (the speed change carries the estimate's noise, the charge the speed loop's
    /// answer to it), where they agree (the correlation's square at least [`R2_MIN`], and
    /// positive: a load that changes speeds the rotor the other way than the charge, and
    /// the correlation it adds is negative) and where it is at least [`RAISE_MIN`]; `None`
    /// otherwise. The tests on the sums times `n`, without a division: only a raise divides.
    fn raise(&self, j0_a_s: f32) -> Option<f32> {
        let n = self.n;
        let var_x = n * self.xx - self.x * self.x;
        let var_y = n * self.yy - self.y * self.y;
        let cov = n * self.xy - self.x * self.y;
        let agree = var_x > 0.0 && cov > 0.0 && cov * cov >= R2_MIN * var_x * var_y;
        let j_min = RAISE_MIN * j0_a_s;
        if !(agree && var_y >= j_min * j_min * var_x) {
            return None;
        }
        cold_path();
        let ratio = sqrt_call(var_y / var_x) / j0_a_s;
        ratio.is_finite().then_some(ratio)
    }
}

impl Default for State {
    fn default() -> Self {
        Self {
            gain: 1.0,
            #[cfg(feature = "speed-gain")]
            fast: Fast::default(),
            #[cfg(feature = "speed-gain")]
            slow: Slow::default(),
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

    /// Sensorless control entered, or the driving observer not locked, or just `switched`:
    /// the checks begin again (that run's check is their first); after a switch the slow
    /// check goes on (the two observers estimate one speed).
    #[cfg(feature = "speed-gain")]
    #[inline(never)]
    pub(super) fn restart(&mut self, switched: bool) {
        // (Field by field, the regression's sums left to its next first block: on the 1 kHz
        // task's path, cheaper than a copy of the whole state.)
        self.fast = Fast::default();
        if !switched {
            self.slow.crossings = 0;
            self.slow.block = 0;
            self.slow.block_i_a = 0.0;
            self.slow.block_omega = 0.0;
            self.slow.last = None;
            self.slow.blocks.n = 0.0;
        }
    }

    /// Without the cargo feature `speed-gain`: nothing to restart.
    #[cfg(not(feature = "speed-gain"))]
    pub(super) fn restart(&mut self, _switched: bool) {}

    /// For the cycle bench: the checks set so that [`Settings::background`] ends a block, the
    /// slow check's interval with a raise (blocks of a rotor far heavier than `J₀`) and the
    /// fast check's interval with a halving: its costliest run.
    #[cfg(feature = "speed-gain")]
    pub(super) fn bench_worst(&mut self) {
        let mut slow = Slow {
            crossings: SLOW_CROSSINGS_MIN,
            block: BLOCK,
            last: Some((0.0, 0.0)),
            ..Slow::default()
        };
        while slow.blocks.n < SLOW_BLOCKS - 1.0 {
            let x = if slow.blocks.n % 2.0 == 0.0 {
                1.0
            } else {
                -1.0
            };
            slow.blocks.add(x, 1e3 * x);
        }
        *self = State {
            gain: 1.0,
            fast: Fast {
                count: INTERVAL,
                side: 1,
                crossings: INTERVAL / 2,
                at_limit: INTERVAL / 2,
                oscillating: INTERVALS - 1,
            },
            slow,
        };
    }
}

impl Settings {
    /// One run of the speed loop in sensorless control: `error_rad_s` the speed error
    /// `ω_ref − ω̂` \[rad/s], `at_limit` the speed loop's torque current command at 0.99 of
    /// the current limit (the stall check's), `omega_m` the speed \[rad/s] and `i_tau_a` the
    /// torque current commanded until the next run \[A].
    #[cfg(feature = "speed-gain")]
    #[inline(always)]
    pub(super) fn check(
        &self,
        s: &mut State,
        error_rad_s: f32,
        at_limit: bool,
        omega_m: f32,
        i_tau_a: f32,
    ) {
        // (A full block or interval waits for `background`: its runs are not counted.)
        if s.slow.block < BLOCK {
            s.slow.block += 1;
            s.slow.block_i_a += i_tau_a;
            s.slow.block_omega += omega_m;
        }
        if s.fast.count >= INTERVAL {
            return;
        }
        s.fast.count += 1;
        if error_rad_s.abs() > self.band {
            let side = if error_rad_s > 0.0 { 1 } else { -1 };
            let crossed = u16::from(side == -s.fast.side);
            s.fast.crossings += crossed;
            s.slow.crossings = s.slow.crossings.saturating_add(crossed);
            s.fast.side = side;
            s.fast.at_limit += u16::from(at_limit);
        }
    }

    /// Without the cargo feature `speed-gain`: no check.
    #[cfg(not(feature = "speed-gain"))]
    #[inline(always)]
    pub(super) fn check(&self, _: &mut State, _: f32, _: bool, _: f32, _: f32) {}

    /// The checks' slower work, after the 1 kHz task ([`Drive::background`](super::Drive)):
    /// a full block's end and a full interval's end.
    #[cfg(feature = "speed-gain")]
    pub(super) fn background(&self, s: &mut State) {
        if s.slow.block >= BLOCK {
            self.block_end(s);
        }
        if s.fast.count >= INTERVAL {
            self.interval_end(s);
        }
    }

    /// Without the cargo feature `speed-gain`: nothing.
    #[cfg(not(feature = "speed-gain"))]
    pub(super) fn background(&self, _: &mut State) {}

    /// A block's end: its mean speed's change from the last block's, against the mean of
    /// their torque currents over a block's time, into the regression; at the end of the
    /// slow check's interval, a slow oscillation raises the gain to the inertia the
    /// regression shows.
    #[cfg(feature = "speed-gain")]
    #[inline(never)]
    fn block_end(&self, s: &mut State) {
        let per_block = 1.0 / f32::from(BLOCK);
        let (i_a, omega) = (s.slow.block_i_a * per_block, s.slow.block_omega * per_block);
        if let Some((last_i_a, last_omega)) = s.slow.last {
            let x = omega - last_omega;
            let y = 0.5 * (i_a + last_i_a) * (f32::from(BLOCK) * TICK_S);
            if x.is_finite() && y.is_finite() {
                s.slow.blocks.add(x, y);
            }
        }
        s.slow.last = Some((i_a, omega));
        s.slow.block = 0;
        s.slow.block_i_a = 0.0;
        s.slow.block_omega = 0.0;
        if s.slow.blocks.n < SLOW_BLOCKS {
            return;
        }
        if s.slow.crossings >= SLOW_CROSSINGS_MIN {
            if let Some(ratio) = s.slow.blocks.raise(self.j0_a_s) {
                s.gain = max(min(ratio, GAIN_MAX), s.gain);
            }
        }
        s.slow.crossings = 0;
        s.slow.blocks = Regression::default();
    }

    /// The interval's verdict: a limit cycle halves the gain.
    #[cfg(feature = "speed-gain")]
    #[inline(never)]
    fn interval_end(&self, s: &mut State) {
        let oscillating = s.fast.crossings >= self.crossings && s.fast.at_limit >= self.crossings;
        s.fast.oscillating = if oscillating {
            s.fast.oscillating + 1
        } else {
            0
        };
        if s.fast.oscillating >= INTERVALS {
            s.gain = max(0.5 * s.gain, GAIN_MIN);
            s.fast.oscillating = 0;
        }
        s.fast.count = 0;
        s.fast.crossings = 0;
        s.fast.at_limit = 0;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const SETTINGS: Settings = Settings {
        band: 6.0,
        crossings: 8,
        j0_a_s: 0.01,
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
            SETTINGS.check(&mut s, 10.0 * sign, i_a >= 9.0, 0.0, 0.0);
            SETTINGS.background(&mut s);
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
            SETTINGS.check(&mut s, 5.0 * sign, true, 0.0, 0.0);
            SETTINGS.background(&mut s);
        }
        assert_eq!(s.gain, 1.0);
    }

    /// Seeded uniform noise in \[−1, 1) (a linear congruential generator).
    fn uniform(seed: &mut u32) -> f32 {
        *seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        (*seed >> 8) as f32 / (1u32 << 24) as f32 * 2.0 - 1.0
    }

    /// The gain after `checks` runs on a rotor `j_ratio` times the configured inertia
    /// oscillating at 5 Hz by ±50 rad/s about the reference (a slow limit cycle), the torque
    /// current its inertia needs on top of `load_a`, plus `noise` = (current \[A], speed
    /// \[rad/s]) of seeded uniform noise; a switch of the driving observer every `every` runs
    /// (0: none).
    fn after_slow(checks: u32, j_ratio: f32, load_a: f32, noise: (f32, f32), every: u32) -> f32 {
        let mut s = State::default();
        let mut seed = 0x2545_f491_u32;
        let mut uniform = || uniform(&mut seed);
        let w = core::f32::consts::TAU * 5.0;
        for k in 0..checks {
            let t = k as f32 * TICK_S;
            // The speed at this run, and the current that makes the rotor's acceleration
            // until the next, `J dω/dt / K_t` (the mean over the period: `Δω/T`).
            let omega = 300.0 + 50.0 * libm::sinf(w * t);
            let next = 300.0 + 50.0 * libm::sinf(w * (t + TICK_S));
            let i_a = j_ratio * SETTINGS.j0_a_s * (next - omega) / TICK_S + load_a;
            let omega_hat = omega + noise.1 * uniform();
            if every > 0 && k % every == 0 {
                s.restart(true);
            }
            SETTINGS.check(
                &mut s,
                300.0 - omega_hat,
                false,
                omega_hat,
                i_a + noise.0 * uniform(),
            );
            SETTINGS.background(&mut s);
        }
        s.gain
    }

    #[test]
    fn a_slow_oscillation_raises_the_gain_to_the_inertia_it_shows() {
        // A slow check's interval (512 runs) and its first block's: raised once.
        assert_eq!(after_slow(500, 10.0, 0.5, (0.0, 0.0), 0), 1.0);
        // Low by the blocks' weighting at 5 Hz, `sinc(ωT_b)/sinc²(ωT_b/2)` = 0.978 (module
        // doc): within 3 %.
        let gain = after_slow(600, 10.0, 0.5, (0.0, 0.0), 0);
        assert!((gain / 10.0 - 1.0).abs() < 0.03, "{gain}");
        // With the speed estimate's noise (±20 rad/s) and the current's (±2 A, a fifth of the
        // oscillation's), and the driving observer switching every 20 runs.
        let gain = after_slow(600, 10.0, 0.5, (2.0, 20.0), 20);
        assert!((gain / 10.0 - 1.0).abs() < 0.1, "{gain}");
        // Beyond the greatest factor: there.
        assert_eq!(after_slow(600, 40.0, 0.5, (0.0, 0.0), 0), GAIN_MAX);
    }

    #[test]
    fn the_configured_inertia_or_noise_alone_leave_the_gain() {
        // The rotor at the configured inertia, or at 1.5 times it (below `RAISE_MIN`).
        assert_eq!(after_slow(3000, 1.0, 0.5, (0.0, 0.0), 0), 1.0);
        assert_eq!(after_slow(3000, 1.5, 0.5, (0.0, 0.0), 0), 1.0);
        // No oscillation: the speed estimate's noise and the current's, uncorrelated.
        let mut s = State::default();
        let mut seed = 7u32;
        for _ in 0..3000 {
            let u = 0.5 * uniform(&mut seed);
            SETTINGS.check(&mut s, 40.0 * u, false, 300.0 + 40.0 * u, 5.0 * u * u);
            SETTINGS.background(&mut s);
        }
        assert_eq!(s.gain, 1.0);
    }

    #[test]
    fn a_load_that_slows_the_rotor_is_not_an_inertia() {
        // A load's torque current in phase with the deceleration it causes (the correlation
        // negative): the rotor at the configured inertia, the load ±5 A at 5 Hz.
        let mut s = State::default();
        let w = core::f32::consts::TAU * 5.0;
        for k in 0..3000 {
            let t = k as f32 * TICK_S;
            let load_a = 5.0 * libm::sinf(w * t);
            // The speed loop answering with a fifth of it: `J₀ dω/dt = (0.2 − 1) × load`.
            let omega = 300.0 + 0.8 * 5.0 / (SETTINGS.j0_a_s * w) * libm::cosf(w * t);
            SETTINGS.check(&mut s, 300.0 - omega, false, omega, 0.2 * load_a);
            SETTINGS.background(&mut s);
        }
        assert_eq!(s.gain, 1.0);
    }

    #[test]
    fn a_restart_clears_the_slow_check_a_switch_does_not() {
        let mut s = State::default();
        s.slow.crossings = 5;
        s.slow.blocks.add(1.0, 1.0);
        s.restart(true);
        assert_eq!((s.slow.crossings, s.slow.blocks.n), (5, 1.0));
        s.gain = 4.0;
        s.restart(false);
        assert_eq!((s.slow.crossings, s.slow.blocks.n, s.gain), (0, 0.0, 4.0));
    }
}
