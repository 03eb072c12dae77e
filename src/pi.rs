//! Discrete PI controller with output clamp and clamping (conditional-integration) anti-windup.

use crate::math::{all_finite, clamp};
use crate::param::{Allowed, Checks, ParamError};
use core::hint::cold_path;

/// PI settings in SI units: `u = kp·e + ki·∫e dt`, clamped to `[out_min, out_max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiConfig {
    /// Proportional gain [output unit / error unit], ≥ 0.
    pub kp: f32,
    /// Integral gain [output unit / (error unit · s)], ≥ 0.
    pub ki: f32,
    /// Lower output limit.
    pub out_min: f32,
    /// Upper output limit, > `out_min`.
    pub out_max: f32,
}

/// A PI ready to run at a fixed sample period (coefficients precomputed).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pi {
    kp: f32,
    ki_ts: f32,
    out_min: f32,
    out_max: f32,
}

/// Which way a limit downstream of a [`Pi`] holds its integrator ([`Pi::update_within`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Held {
    /// Free both ways.
    No,
    /// It may not grow.
    Up,
    /// It may not shrink.
    Down,
}

/// Running state of a [`Pi`]: the integrator, in output units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PiState {
    /// Integral term `ki·∫e dt`, always within the output limits.
    pub integral: f32,
}

impl PiConfig {
    /// Precomputes the per-sample integral gain for period `ts_s` \[s].
    pub fn build(&self, ts_s: f32) -> Result<Pi, ParamError> {
        let mut c = Checks::new();
        c.check("ts_s", ts_s, Allowed::POSITIVE);
        c.check("kp", self.kp, Allowed::NON_NEGATIVE);
        c.check("ki", self.ki, Allowed::NON_NEGATIVE);
        c.check("out_min", self.out_min, Allowed::FINITE);
        let out_max = Allowed::above_up_to(self.out_min, f32::INFINITY).because("above out_min");
        c.check("out_max", self.out_max, out_max);
        c.done()?;
        let ts = ts_s;
        Ok(Pi {
            kp: self.kp,
            ki_ts: self.ki * ts,
            out_min: self.out_min,
            out_max: self.out_max,
        })
    }
}

impl Pi {
    /// One sample: `u = clamp(ff + kp·e + I)`, with `I += ki·Ts·e` only when that does not push
    /// a saturated output further into saturation. `ff` is a feed-forward added before the clamp.
    /// If `error` or `ff` is not finite, both are ignored: the integrator is left untouched and
    /// the output is the clamped integral alone (bounded and finite).
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn update(&self, state: &mut PiState, error: f32, ff: f32) -> f32 {
        self.update_within(state, error, ff, (self.out_min, self.out_max), Held::No)
    }

    /// [`Pi::update`] within this sample's limits `(lo, hi)` instead of the configured ones (a
    /// limit that moves: the current field weakening leaves), both within the configured
    /// ones, `lo ≤ hi`; and with the integrator held where `held` says (a limit downstream,
    /// the voltage's, that this output does not see).
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn update_within(
        &self,
        state: &mut PiState,
        error: f32,
        ff: f32,
        (lo, hi): (f32, f32),
        held: Held,
    ) -> f32 {
        if !all_finite([error, ff]) {
            cold_path();
            return clamp(state.integral, lo, hi);
        }
        let candidate = state.integral + self.ki_ts * error;
        let unclamped = ff + self.kp * error + candidate;
        let pushing_further = (unclamped > hi && error > 0.0)
            || (unclamped < lo && error < 0.0)
            || (held == Held::Up && error > 0.0)
            || (held == Held::Down && error < 0.0);
        if !pushing_further {
            state.integral = clamp(candidate, lo, hi);
        }
        clamp(ff + self.kp * error + state.integral, lo, hi)
    }
}
