//! Angle-tracking PLL speed estimator of Ortega et al. Sec V iii:
//!
//! ```text
//! ż1 = Kp(θ̂ − z1) + Ki z2,   ż2 = θ̂ − z1,   ω̂ = Kp(θ̂ − z1) + Ki z2
//! ```
//! The error `e = θ̂ − z1` obeys `ë + Kp ė + Ki e = θ̈̂`, so `Kp = 2ζω_n`, `Ki = ω_n²` give a
//! second-order loop of natural frequency ω_n and damping ζ. The angle difference is wrapped
//! to (−π, π], so the estimator lives on the circle. Forward Euler at the control rate; the
//! integral state is kept as `Ki·z2` \[rad/s].
//!
//! **Aided** ([`Pll::update_aided`]; the drive's choice per motor, `DriveConfig::pll_aided`).
//! Run at 1 kHz on a rotor that turns far per period and accelerates fast (a drone or a
//! low-inertia flat motor: 150° to 1400° of electrical angle per millisecond, 10⁵ to 10⁶
//! rad/s² electrical), the loop above fails twice: its phase error, wrapped to ±π, is
//! ambiguous once it exceeds half a turn (the PLL slips a cycle and its speed jumps by
//! `2π/T`), and its lag under an acceleration α, `α/ω_n²`, is radians (at ω_n = 2π·50 Hz,
//! 7e5 rad/s² lags 7 rad). The aided loop is the same type-2 loop with the input's own
//! turn as velocity feed-forward, as an aided tracking loop of a GNSS receiver takes the
//! carrier's Doppler (Kaplan & Hegarty (eds.), *Understanding GPS/GNSS*, 3rd ed., Artech
//! House 2017, the receiver's tracking loops: carrier-aided code loops): the loop then tracks
//! only the aid's error, not the motion.
//! - The turn `Δ_k` over the period: `θ_k − θ_{k−1}` on the branch within ±π of the
//!   caller's hint (the turn `T ω̂_{k−1}` the last update predicted): unambiguous while the
//!   speed estimate is within `π/T` of the rotor's (500 Hz electrical at 1 kHz).
//! - The phase error unwrapped: `e_k = e_{k−1} + Δ_k − T ω̂_{k−1}`, taken on the branch of
//!   `θ_k − z1_k` nearest it, so a lag beyond ±π is a lag, not a slipped cycle.
//! - The speed: `ω̂_k = (2Δ_k − Δ_{k−1})/T + Kp e_k + Ki z2`: the feed-forward is the mean
//!   speed over the period extrapolated by its last change to the middle of the coming
//!   period (the turn `z1` is advanced by). The error dynamics are the plain loop's
//!   (`e_{k+1} = (1 − Kp T) e_k − T·Ki z2 + (Δ_{k+1} − 2Δ_k + Δ_{k−1})`), driven by the
//!   second difference of the turn (the change of acceleration, `α̇ T³`) instead of the
//!   acceleration: no lag under a constant acceleration, `α T²` at its onset, decaying at
//!   the loop's ω_n. The integral starts at zero (the feed-forward carries the speed).
//! - The first update after a [`Pll::reset`] takes the turn it predicted (`T ω̂`) and a zero
//!   error: a reset may fall within a period, and the turn from its angle is of an unknown
//!   time.
//!
//! The cost is noise: the feed-forward differentiates the angle over one period, so the
//! speed carries the angle's noise `σ` as `√14 σ/T` (`2θ_k − 3θ_{k−1} + θ_{k−2}`)
//! unfiltered, where the plain loop filters it at ω_n; hence the aided loop only where the
//! plain one cannot follow the motor.

use crate::math::{all_finite, wrap_pi};
use crate::param::{Allowed, Checks, ParamError};
use core::f32::consts::TAU;
use core::hint::cold_path;

/// PLL settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PllConfig {
    /// Update rate \[Hz].
    pub rate_hz: f32,
    /// Natural frequency ω_n/2π \[Hz], below `rate_hz/(4π)` (so `ω_n·T < 0.5`).
    pub bandwidth_hz: f32,
    /// Damping ζ, > 0 (1 = critically damped), with `2ζω_n·T < 1`.
    pub damping: f32,
}

/// A built PLL.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pll {
    ts: f32,
    kp: f32,
    ki_ts: f32,
    /// `1/T` \[Hz].
    rate: f32,
    /// Run by [`Pll::update_aided`] (module doc, "Aided"): the integral starts at zero.
    aided: bool,
}

/// PLL state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PllState {
    /// Tracked angle z1 \[rad], in (−π, π] (of [`Pll::update`]; [`Pll::update_aided`] keeps
    /// `θ − z1` as its unwrapped `error` instead).
    pub z1: f32,
    /// Integral term `Ki·z2` \[rad/s].
    pub integral: f32,
    /// Speed estimate ω̂ \[rad/s] of the tracked angle (electrical if the input is).
    pub omega: f32,
    /// The phase error `θ − z1` of the last update \[rad], wrapped to (−π, π] by
    /// [`Pll::update`], unwrapped by [`Pll::update_aided`].
    pub error: f32,
    /// [`Pll::update_aided`]: the input angle of the last update \[rad].
    pub theta: f32,
    /// [`Pll::update_aided`]: the angle the input turned through over the last period \[rad].
    pub turn: f32,
    /// [`Pll::update_aided`]: false from a [`Pll::reset`] to the next update, which takes
    /// the turn it predicted instead of the input's (a reset may fall within a period: the
    /// turn from the reset's angle is of an unknown time).
    pub anchored: bool,
}

impl PllConfig {
    /// `(Kp, Ki) = (2ζω_n, ω_n²)` \[1/s, 1/s²], unvalidated.
    pub fn gains(&self) -> (f32, f32) {
        let w_n = TAU * self.bandwidth_hz;
        (2.0 * self.damping * w_n, w_n * w_n)
    }

    /// Validates and precomputes `Kp`, `Ki·T`.
    pub fn build(&self) -> Result<Pll, ParamError> {
        let rate = self.rate_hz;
        let mut c = Checks::new();
        c.check("rate_hz", rate, Allowed::POSITIVE);
        let bandwidth = Allowed::strictly_between(0.0, 0.5 * rate / TAU).because("w_n T < 0.5");
        c.check("bandwidth_hz", self.bandwidth_hz, bandwidth);
        // The proportional step Kp·T must stay below 1 for the discrete loop to be stable.
        let damping = Allowed::strictly_between(0.0, rate / (2.0 * TAU * self.bandwidth_hz))
            .because("Kp T < 1");
        c.check("damping", self.damping, damping);
        c.done()?;
        let ts = 1.0 / rate;
        let (kp, ki) = self.gains();
        Ok(Pll {
            ts,
            kp,
            ki_ts: ki * ts,
            rate,
            aided: false,
        })
    }
}

impl Pll {
    /// This PLL run by [`Pll::update_aided`] (module doc, "Aided").
    pub fn aided(self) -> Self {
        Self {
            aided: true,
            ..self
        }
    }

    /// Whether this PLL is run by [`Pll::update_aided`].
    pub fn is_aided(&self) -> bool {
        self.aided
    }

    /// One sample of the input angle `theta` \[rad]; returns ω̂ \[rad/s]. A non-finite input
    /// leaves the state untouched.
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn update(&self, st: &mut PllState, theta: f32) -> f32 {
        let e = wrap_pi(theta - st.z1);
        if !all_finite([e]) {
            cold_path();
            return st.omega;
        }
        st.error = e;
        st.integral += self.ki_ts * e;
        st.omega = self.kp * e + st.integral;
        st.z1 = wrap_pi(st.z1 + self.ts * st.omega);
        st.omega
    }

    /// One sample of the input angle `theta` \[rad] with the speed the input turned at over
    /// the period as feed-forward (module doc, "Aided"); returns ω̂ \[rad/s]. `turn_hint`
    /// \[rad]: the angle turned through since the last update, as far as the caller knows it
    /// within ±π (its own count of the turn, or `T ω̂` of the last update). A non-finite
    /// input leaves the state untouched.
    // Inlined into the 1 kHz task: out of line, the call cost the task 31 cycles on the
    // emulated Cortex-M4F (`pmsm-sim cycles`, the flux primary's aided case).
    #[inline(always)]
    pub fn update_aided(&self, st: &mut PllState, theta: f32, turn_hint: f32) -> f32 {
        let predicted = self.ts * st.omega;
        // The turn over the period: the input's own difference, on the branch of the hint;
        // the phase error carried over it (`z1` advanced by `T ω̂`, the input by the turn):
        // the unwrapped `θ − z1`. The first update after a reset takes the turn predicted.
        let (turn, e) = if st.anchored {
            let turn = turn_hint + wrap_pi(theta - st.theta - turn_hint);
            (turn, st.error + turn - predicted)
        } else {
            cold_path();
            (predicted, 0.0)
        };
        if !all_finite([theta, turn, e]) {
            cold_path();
            return st.omega;
        }
        // Feed-forward: the mean speed over the period, extrapolated by its last change.
        let feed_forward = (2.0 * turn - st.turn) * self.rate;
        st.error = e;
        st.theta = theta;
        st.turn = turn;
        st.anchored = true;
        st.integral += self.ki_ts * e;
        st.omega = feed_forward + self.kp * e + st.integral;
        st.omega
    }

    /// The turn `T ω̂` \[rad] the last update predicts over the coming period.
    #[inline(always)]
    pub fn predicted_turn(&self, st: &PllState) -> f32 {
        self.ts * st.omega
    }

    /// Starts tracking at angle `theta` and speed `omega`.
    pub fn reset(&self, st: &mut PllState, theta: f32, omega: f32) {
        *st = PllState {
            z1: wrap_pi(theta),
            // Aided, the feed-forward carries the speed and the integral its error.
            integral: if self.aided { 0.0 } else { omega },
            omega,
            error: 0.0,
            // Not read before the next update (`anchored`).
            theta: 0.0,
            turn: self.ts * omega,
            anchored: false,
        };
    }
}
