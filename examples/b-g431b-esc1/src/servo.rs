//! The servo-PWM speed input (issue #28): measured pulses (width and period, as a timer in
//! PWM-input mode captures them: `servo_capture`) turned into a speed command the way
//! hobby ESCs are commanded — a 1–2 ms pulse repeated at 50–490 Hz. Pure and `no_std`: the
//! caller gives each new capture (or none) and the time since its last call, the decoder
//! gives the throttle (0..1, slew-limited) and whether the drive may run.
//!
//! # The rules, and where they come from
//!
//! - **One direction.** Pulse widths from the calibrated low end [`ServoConfig::low_us`]
//!   (1000 µs) to the high end [`ServoConfig::high_us`] (2000 µs) map to 0..1 of the motor's
//!   rated speed, forward only. This is the default of the drone ESC firmwares: AM32
//!   (`Src/signal.c`, `computeServoInput`: without `bi_direction` the low..high thresholds
//!   map to throttle 47..2047) and VESC's PPM app in its `*_NOREV` modes (Vedder,
//!   `applications/app_ppm.c`). A dead band around a 1.5 ms neutral (AM32's `bi_direction`,
//!   VESC's `pulse_center`) would command reverse, which this drive reaches only through a
//!   stop and a new start; and this board is a drone ESC, whose propellers turn one way.
//! - **A zero band at the low end**, [`ServoConfig::zero_band_us`]: widths up to `low_us +
//!   zero_band_us` are exactly zero throttle (the stop, and the only widths that arm); above
//!   it the mapping starts from zero, so there is no step. AM32 zeroes the lowest 48 of 2047
//!   (2.3 % of the span), VESC's `hyst` defaults to 15 %; the board takes 5 %
//!   (`zero_band_us = span / 20`), ≥ 25 capture ticks of 1 µs so that a tick of quantisation
//!   and a receiver's jitter of a few µs cannot leave the band.
//! - **Pulses out of range are rejected and counted**: a width outside
//!   [`ServoConfig::width_min_us`]..=[`ServoConfig::width_max_us`] (800..2200 µs, AM32's
//!   window in `computeServoInput`), or a period outside the 50–490 Hz frame rates ±10 %
//!   ([`ServoConfig::period_min_us`], [`ServoConfig::period_max_us`]) or not longer than
//!   its pulse. A rejected pulse changes neither the command nor the loss timer, and
//!   resets the arming count (AM32 resets `zero_input_count` on an out-of-range pulse).
//! - **Loss of signal stops the drive**: no valid pulse for [`ServoConfig::timeout_us`]
//!   (100 ms = 5 frames at the slowest 50 Hz: `timeout = 5 / f_min`) drops the throttle to
//!   zero at once (no slew) and disarms; the drive is disabled. VESC's PPM app gives no power
//!   after its timeout (`servodec_get_time_since_update() > timeout`); AM32 counts
//!   `signaltimeout`, reset only by a pulse in range.
//! - **Re-armed only at zero**: after power-up or a loss, the decoder arms only after
//!   [`ServoConfig::arm_pulses`] consecutive valid pulses in the zero band (50, VESC's
//!   `MIN_PULSES_WITHOUT_POWER` with `safe_start`; AM32 arms after a run of zero inputs,
//!   `zero_input_count`): a signal returning at full throttle does not start the motor.
//! - **Slew-limited command**: the throttle moves towards the pulse's value by at most
//!   [`ServoConfig::slew_per_s`] of full scale per second (VESC's `ramp_time_pos/neg`,
//!   AM32's `max_servo_deviation` per pulse); on the board `slew_per_s =
//!   start.accel_rpm_per_s / ratings.speed_rpm`, the drive's own configured acceleration,
//!   so the command never runs ahead of what the drive accelerates.
//!
//! Widths and periods are in µs (the board's capture counts at 1 MHz); a capture's ±1 tick
//! (the counter's reset on the edge) is 0.1 % of the span, far inside the zero band.

/// One captured pulse: the time between two rising edges and the high time inside it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Capture {
    /// Rising edge to rising edge \[µs].
    pub period_us: u32,
    /// Rising edge to falling edge \[µs].
    pub width_us: u32,
}

/// A source of captured pulses: the board's timer (`servo_capture::ServoCapture`), an
/// emulator's, a test's. embedded-hal 1.0 has no input-capture trait (its `pwm` module is
/// output only), so the servo input is written against this one.
pub trait PulseCapture {
    /// The pulse completed since the last call, if any.
    fn capture(&mut self) -> Option<Capture>;
}

/// The decoder's settings (see the module's doc for each rule's source).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServoConfig {
    /// Calibrated zero-throttle width \[µs].
    pub low_us: u32,
    /// Calibrated full-throttle width \[µs].
    pub high_us: u32,
    /// Widths up to `low_us + zero_band_us` are zero throttle \[µs].
    pub zero_band_us: u32,
    /// Shortest valid width \[µs].
    pub width_min_us: u32,
    /// Longest valid width \[µs].
    pub width_max_us: u32,
    /// Shortest valid period \[µs].
    pub period_min_us: u32,
    /// Longest valid period \[µs].
    pub period_max_us: u32,
    /// No valid pulse for this long is a loss of signal \[µs].
    pub timeout_us: u32,
    /// Consecutive valid zero-throttle pulses that arm the decoder.
    pub arm_pulses: u32,
    /// Largest throttle change \[full scale per s].
    pub slew_per_s: f32,
}

/// Frame rates of servo-PWM ESC inputs \[Hz]: 50 Hz (analog servos) to 490 Hz (multirotor
/// flight controllers' PWM output).
pub const FRAME_HZ: (u32, u32) = (50, 490);

impl ServoConfig {
    /// The standard 1000–2000 µs servo signal at [`FRAME_HZ`], with the decoder's rules
    /// from the module's doc; `slew_per_s` is the caller's (the drive's acceleration).
    pub const fn standard(slew_per_s: f32) -> Self {
        let (low_us, high_us) = (1000, 2000);
        // ±10 % on the frame rates: 1/490 Hz / 1.1 = 1855 µs, 1/50 Hz · 1.1 = 22 000 µs.
        let period_min_us = 1_000_000 * 10 / (FRAME_HZ.1 * 11);
        let period_max_us = 1_000_000 * 11 / (FRAME_HZ.0 * 10);
        Self {
            low_us,
            high_us,
            zero_band_us: (high_us - low_us) / 20,
            width_min_us: 800,
            width_max_us: 2200,
            period_min_us,
            period_max_us,
            // 5 frames at the slowest rate.
            timeout_us: 5 * 1_000_000 / FRAME_HZ.0,
            arm_pulses: 50,
            slew_per_s,
        }
    }

    /// The throttle of a valid width: 0 up to the zero band's top, then linear to 1 at
    /// `high_us`, 1 above.
    pub fn throttle_of(&self, width_us: u32) -> f32 {
        let zero_top = self.low_us + self.zero_band_us;
        if width_us <= zero_top {
            return 0.0;
        }
        let span = self.high_us.saturating_sub(zero_top).max(1);
        ((width_us - zero_top) as f32 / span as f32).min(1.0)
    }
}

/// Why a pulse was rejected.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Reject {
    /// Width below `width_min_us`.
    WidthShort,
    /// Width above `width_max_us`.
    WidthLong,
    /// Period outside the frame rates, or not longer than the width.
    Period,
}

/// What the decoder tells the drive after each update.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ServoOutput {
    /// Slew-limited throttle, 0..1 of full scale (0 unless armed).
    pub throttle: f32,
    /// A valid pulse within the timeout.
    pub present: bool,
    /// Armed: seen at zero since power-up or the last loss, and not lost since.
    pub armed: bool,
    /// The drive may run: armed, and the throttle (or the pulse's value) above zero.
    pub enable: bool,
}

/// The decoder's state.
#[derive(Clone, Copy, Debug)]
pub struct ServoDecoder {
    cfg: ServoConfig,
    armed: bool,
    present: bool,
    /// Consecutive valid pulses in the zero band.
    zero_pulses: u32,
    /// Time since the last valid pulse \[µs] (saturating).
    since_valid_us: u32,
    /// The last valid pulse's throttle.
    target: f32,
    throttle: f32,
    /// Pulses rejected for their width.
    pub rejected_width: u32,
    /// Pulses rejected for their period.
    pub rejected_period: u32,
    /// Losses of signal (a present signal gone for `timeout_us`).
    pub losses: u32,
}

impl ServoDecoder {
    /// Disarmed, no signal yet.
    pub const fn new(cfg: ServoConfig) -> Self {
        Self {
            cfg,
            armed: false,
            present: false,
            zero_pulses: 0,
            since_valid_us: u32::MAX,
            target: 0.0,
            throttle: 0.0,
            rejected_width: 0,
            rejected_period: 0,
            losses: 0,
        }
    }

    /// The settings.
    pub const fn config(&self) -> &ServoConfig {
        &self.cfg
    }

    /// Sets the slew rate \[1/s] (per unit of throttle): a new motor's rated speed or
    /// acceleration (the link's firmware).
    pub fn set_slew_per_s(&mut self, slew_per_s: f32) {
        self.cfg.slew_per_s = slew_per_s;
    }

    /// Checks a pulse against the windows.
    pub fn check(&self, c: Capture) -> Result<u32, Reject> {
        let cfg = &self.cfg;
        if c.width_us < cfg.width_min_us {
            Err(Reject::WidthShort)
        } else if c.width_us > cfg.width_max_us {
            Err(Reject::WidthLong)
        } else if c.period_us < cfg.period_min_us
            || c.period_us > cfg.period_max_us
            || c.period_us <= c.width_us
        {
            Err(Reject::Period)
        } else {
            Ok(c.width_us)
        }
    }

    /// One update: `capture` is the pulse completed since the last call (if any), `dt_us`
    /// the time since the last call.
    pub fn update(&mut self, capture: Option<Capture>, dt_us: u32) -> ServoOutput {
        self.since_valid_us = self.since_valid_us.saturating_add(dt_us);
        if let Some(c) = capture {
            match self.check(c) {
                Ok(width_us) => {
                    self.since_valid_us = 0;
                    self.present = true;
                    self.target = self.cfg.throttle_of(width_us);
                    if self.target == 0.0 {
                        self.zero_pulses = self.zero_pulses.saturating_add(1);
                        if self.zero_pulses >= self.cfg.arm_pulses {
                            self.armed = true;
                        }
                    } else {
                        self.zero_pulses = 0;
                    }
                }
                Err(r) => {
                    self.zero_pulses = 0;
                    match r {
                        Reject::WidthShort | Reject::WidthLong => {
                            self.rejected_width = self.rejected_width.saturating_add(1);
                        }
                        Reject::Period => {
                            self.rejected_period = self.rejected_period.saturating_add(1);
                        }
                    }
                }
            }
        }
        if self.since_valid_us > self.cfg.timeout_us {
            if self.present {
                self.losses = self.losses.saturating_add(1);
            }
            self.present = false;
            self.armed = false;
            self.zero_pulses = 0;
            self.target = 0.0;
        }
        if self.armed {
            let step = self.cfg.slew_per_s * dt_us as f32 * 1e-6;
            // (`max`/`min`, not `f32::clamp`: its check of its bounds is a panic path in the
            // image, the string and the code 150 B of the commissioning firmware's flash.)
            let d = (self.target - self.throttle).max(-step).min(step);
            self.throttle = (self.throttle + d).clamp(0.0, 1.0);
        } else {
            self.throttle = 0.0;
        }
        self.output()
    }

    /// The output of the last update.
    pub fn output(&self) -> ServoOutput {
        ServoOutput {
            throttle: self.throttle,
            present: self.present,
            armed: self.armed,
            enable: self.armed && (self.throttle > 0.0 || self.target > 0.0),
        }
    }
}

impl ServoOutput {
    /// The run command to write when it changes from `prev`: the servo owns the drive's
    /// enable only at its own edges (armed or enable changed), so without a signal the
    /// button's enable stands as before, and a loss or a disarm always disables.
    pub fn enable_change(&self, prev: &ServoOutput) -> Option<bool> {
        (self.armed != prev.armed || self.enable != prev.enable).then_some(self.enable)
    }

    /// The speed command \[rpm]: the throttle times `full_rpm` while armed, else `fallback_rpm`
    /// (the button's constant command).
    pub fn speed_rpm(&self, full_rpm: f32, fallback_rpm: f32) -> f32 {
        if self.armed {
            self.throttle * full_rpm
        } else {
            fallback_rpm
        }
    }
}

#[cfg(test)]
mod tests;
