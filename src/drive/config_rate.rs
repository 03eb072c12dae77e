//! The drive's configuration as the control rate concerns it (issue #26): the board's power
//! stage with its update delay ([`PowerStageConfig`]), the rate the configuration chooses
//! from the motor (`crate::rate`) and the schedule that follows it.

use super::DriveConfig;
use crate::param::ParamError;
use crate::rate::{control_rate, rate_at_least, CpuBudget, RateChoice};
use crate::schedule::Schedule;
use crate::units::RAD_S_PER_RPM;

/// The board's power stage as the drive compensates it (see [`crate::dead_time`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowerStageConfig {
    /// PWM (switching) frequency \[Hz], positive.
    pub pwm_hz: f32,
    /// Dead time per switching edge \[s], in `[0, 0.1/pwm_hz]`; 0 for no compensation.
    pub dead_time_s: f32,
    /// Width of the compensation's smooth sign \[A], > 0: a phase current of this or more
    /// gets the full `t_d·f_pwm`.
    pub dead_time_band_a: f32,
    /// The largest duty the board applies, in `(0.5 + t_d·f_pwm, 1]`: the voltage limit keeps
    /// every duty within `[1 − duty_max, duty_max]`
    /// ([`DeadTimeConfig::v_max_per_bus`](crate::dead_time::DeadTimeConfig::v_max_per_bus)).
    pub duty_max: f32,
    /// The time from a sample to the duties computed from it taking effect \[s], in
    /// `[0, 1/rate_hz]`. The model: the duties of sample `k` hold over
    /// `[t_k + d, t_{k+1} + d)`, so the voltage between samples `k` and `k+1`, the
    /// observers' input, is `(d/T) v_{k−1} + (1 − d/T) v_k`
    /// ([`DriveState::v_ab_applied`](super::DriveState::v_ab_applied)), and the controller
    /// applies its voltage at `θ_e + (d/T + ½) ω_e T`, the middle of its interval. A board
    /// whose timer loads the compare registers at the PWM update after the sample has
    /// `d = 1/pwm_hz` (the B-G431B-ESC1: 50 µs; at a step every PWM period, `d = T`: 1.5
    /// periods from the sample to the middle of the voltage, 27° electrical at 20 samples per
    /// electrical period). Default 0: the sample, the computation and the update at one
    /// instant, the simulator's and the papers' timing.
    pub update_delay_s: f32,
    /// The board senses the terminal voltage while the PWM is off (phase-voltage dividers)
    /// at every speed the motor reaches: an enable passing
    /// [`DriveInput::v_ab_terminal`](crate::power_stage::DriveInput) watches a coasting rotor
    /// with the PWM off (`catch.rs`); one passing none aligns. `false`: a board without the
    /// sensing, or whose dividers clip within the motor's speeds (the B-G431B-ESC1's at
    /// 18.3 V): an enable passing none first regulates the currents to zero to see whether
    /// the rotor turns, and catches it so (`catch_zero.rs`), and the control rate is chosen
    /// for that catch too ([`DriveConfig::rate_choice`]). A catch whose terminal voltage stops
    /// goes on so on either board. Default true.
    pub terminal_sensing: bool,
}

impl DriveConfig {
    /// The rate [`crate::rate::control_rate`] chooses for this motor's pole pairs and rated
    /// speed on this power stage's PWM within the board's CPU budget
    /// ([`CpuBudget::BOARD`]): the rate, the rate 20 samples per electrical period at rated
    /// speed need, and what bounds it below that.
    ///
    /// A board without terminal sensing also needs the catch's first period bounded: it
    /// applies zero volts to a rotor not yet known (`catch_zero.rs`), and the current rises by
    /// `N ψ_f ω_m T/L`; at rated speed that stays within the rated-torque current `I_r` at
    /// `f ≥ N ψ_f ω_rated/(L I_r)`, the rate raised to the set's next one where needed.
    pub fn rate_choice(&self) -> RateChoice {
        let mut c = control_rate(
            self.motor.pole_pairs,
            self.ratings.speed_rpm,
            self.power_stage.pwm_hz,
            &CpuBudget::BOARD,
        );
        if !self.power_stage.terminal_sensing {
            let m = &self.motor;
            let i_rated = self.ratings.torque_nm / m.torque_constant();
            let emf_v = m.emf_constant() * self.ratings.speed_rpm * RAD_S_PER_RPM;
            let floor_hz = emf_v / (m.l_h * i_rated);
            let f = rate_at_least(floor_hz, self.power_stage.pwm_hz, &CpuBudget::BOARD);
            if f > c.rate_hz {
                c.samples_per_period *= f / c.rate_hz;
                c.rate_hz = f;
            }
        }
        c
    }

    /// Sets the step rate to [`DriveConfig::rate_choice`]'s (after a board has set its PWM
    /// frequency).
    pub fn choose_rate(&mut self) {
        self.rate_hz = self.rate_choice().rate_hz;
    }

    /// The steps per 1 kHz task at the step rate (the error names `rate_hz`).
    pub fn schedule(&self) -> Result<Schedule, ParamError> {
        Schedule::at("rate_hz", self.rate_hz)
    }

    /// The update delay in control periods, `update_delay_s · rate_hz`.
    pub(crate) fn delay_periods(&self) -> f32 {
        self.power_stage.update_delay_s * self.rate_hz
    }

    /// The steps per 1 kHz task, unvalidated (the rate rounded to whole kHz, at least one).
    pub(crate) fn steps_per_tick(&self) -> f32 {
        libm::roundf(self.rate_hz / crate::schedule::TICK_HZ).max(1.0)
    }
}
