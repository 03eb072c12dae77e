//! What the current loop applied: the last period's voltage and bus (the observers' input, the
//! identification's), and whether the voltage was at its limit through the last millisecond
//! (the field weakening's anti-windup). Written by the step's FOC call ([`LastPeriod::record`])
//! and the 1 kHz task ([`LastPeriod::close_millisecond`]), read through [`LastPeriod::applied`].
//!
//! With an update delay `d` (`PowerStageConfig::update_delay_s`, `δ = d/T` periods) the
//! duties of sample `k` hold over `[t_k + d, t_{k+1} + d)`: between samples `k` and `k+1` the
//! motor sees `v_{k−1}` for `d` and `v_k` for the rest, so the voltage the observers take
//! next step is `δ v_{k−1} + (1 − δ) v_k` (the mean over the period of the two held voltages; `δ = 0`: `v_k`, as before).

use crate::foc::{Foc, FocOutput};
use crate::frames::AlphaBeta;
use crate::schedule::Schedule;

/// What the current loop applied over the last millisecond, for the 1 kHz task.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Applied {
    /// The voltage of the last period \[V].
    pub(super) v_ab: AlphaBeta,
    /// The current loop's voltage limit \[V].
    pub(super) v_max: f32,
    /// The bus measured in the last period \[V].
    pub(super) v_bus: f32,
    /// The voltage was at its limit through the last millisecond.
    pub(super) limited: bool,
}

/// The current loop's last period and its voltage limit over the millisecond.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct LastPeriod {
    /// Voltage applied over the period that just ended \[V] (the observers' input).
    v_ab: AlphaBeta,
    /// The voltage the last step computed \[V]: with an update delay, part of it falls in the
    /// next period.
    v_cmd: AlphaBeta,
    /// The bus voltage of the last sample \[V].
    v_bus: f32,
    /// Steps of this millisecond in which the current loop cut its voltage to the limit.
    cut_steps: u8,
    /// ... in every step of the last millisecond ([`LastPeriod::close_millisecond`]): the
    /// voltage at its limit, not a noise spike on one sample.
    limited: bool,
}

impl LastPeriod {
    /// A period of the running drive: the FOC's output `out` on the bus `v_bus` \[V], applied
    /// `delay` periods after the sample (module doc).
    #[inline(always)]
    pub(super) fn record(&mut self, out: &FocOutput, v_bus: f32, delay: f32) {
        self.cut_steps = self.cut_steps.saturating_add(u8::from(out.saturated));
        self.push(out.v_ab, delay);
        self.v_bus = v_bus;
    }

    /// A period of the identification (no voltage-limit count): `v_ab` computed \[V] on
    /// `v_bus` \[V], applied `delay` periods after the sample.
    #[inline(always)]
    #[cfg_attr(not(feature = "identify"), allow(dead_code))]
    pub(super) fn record_voltage(&mut self, v_ab: AlphaBeta, v_bus: f32, delay: f32) {
        self.push(v_ab, delay);
        self.v_bus = v_bus;
    }

    /// The voltage `v_ab` just computed: the coming period's mean, `δ v_prev + (1 − δ) v_ab`.
    #[inline(always)]
    fn push(&mut self, v_ab: AlphaBeta, delay: f32) {
        self.v_ab = if delay == 0.0 {
            v_ab
        } else {
            AlphaBeta::new(
                self.v_cmd.alpha * delay + v_ab.alpha * (1.0 - delay),
                self.v_cmd.beta * delay + v_ab.beta * (1.0 - delay),
            )
        };
        self.v_cmd = v_ab;
    }

    /// A period with the PWM off on a board that senses the terminals: their voltage `v_ab`
    /// \[V] (a catch's, the back-EMF), the observers' input should the PWM start at the next
    /// step (the catch's hand-over): with none recorded, a rotor at 72° electrical per period
    /// (the T-motor drone motor at 20 kHz) froze the observers for one, and tripped.
    pub(super) fn record_off(&mut self, v_ab: AlphaBeta) {
        self.v_ab = v_ab;
        self.v_cmd = v_ab;
    }

    /// The bus `v_bus` \[V] sampled with the PWM off.
    #[cfg_attr(not(feature = "identify"), allow(dead_code))]
    pub(super) fn record_bus(&mut self, v_bus: f32) {
        self.v_bus = v_bus;
    }

    /// The 1 kHz task: the voltage was at its limit in every step of the millisecond.
    #[inline(always)]
    pub(super) fn close_millisecond(&mut self, schedule: &Schedule) {
        self.limited = u32::from(core::mem::take(&mut self.cut_steps)) >= schedule.steps_per_tick();
    }

    /// The voltage applied over the period that just ended \[V].
    pub(super) fn v_ab(&self) -> AlphaBeta {
        self.v_ab
    }

    /// The bus voltage of the last sample \[V].
    #[cfg_attr(not(feature = "identify"), allow(dead_code))]
    pub(super) fn v_bus(&self) -> f32 {
        self.v_bus
    }

    /// The voltage was at its limit through the last millisecond.
    pub(super) fn limited(&self) -> bool {
        self.limited
    }

    /// What the 1 kHz task takes: the last voltage, `foc`'s limit on the last bus, the limit
    /// flag.
    #[inline(always)]
    pub(super) fn applied(&self, foc: &Foc) -> Applied {
        Applied {
            v_ab: self.v_ab,
            v_max: foc.v_max(self.v_bus),
            v_bus: self.v_bus,
            limited: self.limited,
        }
    }
}
