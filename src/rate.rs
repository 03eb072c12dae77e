//! The control rate from the motor: the current-loop/observer step's rate
//! ([`DriveConfig::rate_hz`](crate::drive::DriveConfig::rate_hz)) chosen from the motor's
//! rated electrical frequency, the board's PWM frequency and the CPU's budget
//! ([`control_rate`]).
//!
//! The rule, with `f_e = N · n_rated / 60` the electrical frequency at rated speed \[Hz]:
//! ```text
//! candidates  R = { f : f divides f_pwm, f is a multiple of 1 kHz, f_min <= f <= f_cpu }
//! f_cpu       = (s · f_clk − c_tick · 1 kHz) / c_step      the CPU's budget
//! f_s         = min { f in R : f >= 20 f_e }               20 samples per electrical period
//!             = max R                                      where no candidate gives 20: the bound is named
//! ```
//! `f_min` = 4 kHz (the papers' rate, which every motor up to 200 Hz electrical at rated speed
//! keeps); `s` = 15 % of the board's `f_clk` = 170 MHz (the STM32G431), `c_step` = 1100 and
//! `c_tick` = 1500 cycles (the CI's budget of one step and one 1 kHz task, `pmsm-sim cycles`):
//! `f_cpu` = 21.8 kHz, so on the B-G431B-ESC1 (20 kHz PWM) the candidates are 4, 5, 10 and
//! 20 kHz and the CPU allows all of them (13.8 % at 20 kHz). A multiple of 1 kHz keeps a whole
//! number of steps in each run of the 1 kHz task (`crate::schedule`).
//!
//! Why 20 samples: the sampled current loop and the observers' Euler steps see the rotor turn
//! `360°/20` = 18° electrical per period; at 5 samples per period (a drone motor at its rated
//! 800 Hz on a 4 kHz step) the turn per period is 72° and a flying start at full speed trips
//! over-current (issue #26). The discretisation error of a forward-Euler step on a rotating
//! vector grows as `(ω_e T)²/2` (Franklin, Powell & Workman 1998, *Digital Control of Dynamic
//! Systems*, 3rd ed., ch. 11, "Sample rate selection": 20 to 40 samples per period of the fastest signal).

/// Samples per electrical period the rule asks for at rated speed.
pub const SAMPLES_PER_PERIOD_MIN: f32 = 20.0;

/// The lowest control rate the rule chooses \[Hz]: the papers' 4 kHz.
pub const RATE_MIN_HZ: f32 = 4000.0;

/// The control rates are multiples of this \[Hz]: the 1 kHz task's
/// ([`crate::schedule::TICK_HZ`]).
pub const RATE_STEP_HZ: f32 = crate::schedule::TICK_HZ;

/// The CPU's budget for the drive: the share of its clock the step and the 1 kHz task may
/// take, and their worst-case cycles.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CpuBudget {
    /// Core clock \[Hz].
    pub clock_hz: f32,
    /// The drive's share of it (0..1).
    pub share: f32,
    /// The step's worst case \[cycles].
    pub step_cycles: f32,
    /// The 1 kHz task's worst case \[cycles].
    pub tick_cycles: f32,
}

impl CpuBudget {
    /// The B-G431B-ESC1's STM32G431 at 170 MHz, 15 % of it for the drive, the CI's budget of
    /// 1100 cycles per step and 1500 per 1 kHz task (`pmsm-sim cycles`, DEVELOPERS.md).
    pub const BOARD: Self = Self {
        clock_hz: 170e6,
        share: 0.15,
        step_cycles: 1100.0,
        tick_cycles: 1500.0,
    };

    /// The highest step rate within the budget, `(s f_clk − c_tick · 1 kHz)/c_step` \[Hz].
    pub fn rate_max_hz(&self) -> f32 {
        (self.share * self.clock_hz - self.tick_cycles * RATE_STEP_HZ) / self.step_cycles
    }

    /// The drive's share of the CPU at the step rate `rate_hz` for `step_cycles` per step and
    /// `tick_cycles` per 1 kHz task: `(c_step f_s + c_tick · 1 kHz)/f_clk`.
    pub fn share_at(&self, rate_hz: f32, step_cycles: f32, tick_cycles: f32) -> f32 {
        (step_cycles * rate_hz + tick_cycles * RATE_STEP_HZ) / self.clock_hz
    }
}

/// What bounds a rate below the 20 samples per period the rule asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RateBound {
    /// The PWM frequency: no divisor of it is higher.
    Pwm,
    /// The CPU's budget ([`CpuBudget::rate_max_hz`]): a higher divisor of the PWM frequency
    /// exists but would take more than the drive's share.
    Cpu,
    /// No multiple of 1 kHz from 4 kHz up divides the PWM frequency within the budget: the
    /// rate is the papers' 4 kHz, which the drive then runs on a PWM it does not divide.
    NoDivisor,
}

impl RateBound {
    /// What the bound is, for a warning.
    pub fn what(self) -> &'static str {
        match self {
            RateBound::Pwm => {
                "below 20 samples per electrical period at rated speed: the highest control \
                 rate is the PWM frequency (a step every PWM period)"
            }
            RateBound::Cpu => {
                "below 20 samples per electrical period at rated speed: a higher divisor of \
                 the PWM frequency is beyond the CPU budget (15 % of 170 MHz, 1100 cycles a \
                 step, 1500 a tick)"
            }
            RateBound::NoDivisor => {
                "no multiple of 1 kHz from 4 kHz up divides the PWM frequency within the CPU \
                 budget: the papers' 4 kHz"
            }
        }
    }
}

/// The rate [`control_rate`] chose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RateChoice {
    /// The control (step) rate \[Hz].
    pub rate_hz: f32,
    /// The rate 20 samples per electrical period at rated speed need, `20 f_e` \[Hz].
    pub wanted_hz: f32,
    /// Samples per electrical period at rated speed at `rate_hz`, `rate_hz / f_e`.
    pub samples_per_period: f32,
    /// `Some` when `rate_hz < wanted_hz`: what bounds it.
    pub bound: Option<RateBound>,
}

/// The control rate for a motor of `pole_pairs` rated at `speed_rpm` on a PWM of `pwm_hz`
/// within `cpu` (the module's rule).
pub fn control_rate(pole_pairs: u32, speed_rpm: f32, pwm_hz: f32, cpu: &CpuBudget) -> RateChoice {
    let f_e = pole_pairs as f32 * speed_rpm.abs() / 60.0;
    let wanted_hz = SAMPLES_PER_PERIOD_MIN * f_e;
    let f_cpu = cpu.rate_max_hz();
    // Multiples of 1 kHz that divide the PWM frequency, from 4 kHz up, ascending.
    let top = if pwm_hz.is_finite() && pwm_hz > 0.0 {
        (pwm_hz / RATE_STEP_HZ) as u32
    } else {
        0
    };
    let mut chosen: Option<f32> = None;
    let mut over_cpu = false;
    let mut bound = None;
    for m in (RATE_MIN_HZ / RATE_STEP_HZ) as u32..=top {
        let f = m as f32 * RATE_STEP_HZ;
        let k = libm::roundf(pwm_hz / f);
        if k < 1.0 || (k * f - pwm_hz).abs() > 1e-3 * f {
            continue;
        }
        if f > f_cpu {
            over_cpu = true;
            break;
        }
        chosen = Some(f);
        if f >= wanted_hz {
            break;
        }
    }
    let rate_hz = match chosen {
        Some(f) => {
            if f < wanted_hz {
                bound = Some(if over_cpu {
                    RateBound::Cpu
                } else {
                    RateBound::Pwm
                });
            }
            f
        }
        None => {
            if RATE_MIN_HZ < wanted_hz {
                bound = Some(RateBound::NoDivisor);
            }
            RATE_MIN_HZ
        }
    };
    RateChoice {
        rate_hz,
        wanted_hz,
        samples_per_period: if f_e > 0.0 {
            rate_hz / f_e
        } else {
            f32::INFINITY
        },
        bound,
    }
}

/// The smallest rate of [`control_rate`]'s set (a multiple of 1 kHz from 4 kHz up that divides
/// `pwm_hz`, within `cpu`) at or above `floor_hz`, else the highest of the set \[Hz]: the rule
/// for a one-pole-pair motor whose 20 samples per period are `floor_hz`.
pub fn rate_at_least(floor_hz: f32, pwm_hz: f32, cpu: &CpuBudget) -> f32 {
    let speed_rpm = floor_hz / SAMPLES_PER_PERIOD_MIN * 60.0;
    control_rate(1, speed_rpm, pwm_hz, cpu).rate_hz
}
