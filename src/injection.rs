//! High-frequency signal injection for salient motors (`L_q > L_d`): the rotor angle at zero
//! and low speed from the motor's saliency, the magnet's polarity from the d axis'
//! saturation. Behind the cargo feature `injection` (the board images do not enable it).
//!
//! **Method.** Square-wave (pulsating) voltage injection on the estimated d axis at the
//! control rate, demodulated by the difference of consecutive current samples, with no
//! filters: Yoon, Sul, Morimoto, Ide, "High-bandwidth sensorless algorithm for AC machines
//! based on square-wave-type voltage injection", IEEE Trans. Ind. Appl. 47(3), 2011. A voltage
//! `s·V_h` (`s = ±1`, alternating every period) on the estimated d axis of a motor whose
//! estimate lags the rotor by `Δθ = θ_e − θ̂_e` changes the current over one period by (the dq
//! model with the incremental inductances; Yoon et al. eq (7)–(9))
//! ```text
//! Δi_d̂ = s V_h T (cos²Δθ/L_d + sin²Δθ/L_q)                 (the d response, η)
//! Δi_q̂ = s V_h T (1/L_d − 1/L_q) sin Δθ cos Δθ              (the error signal, ε)
//! ```
//! so `s·Δi_q̂ / (s·Δi_d̂ · (1 − L_d/L_q)) = sinΔθ cosΔθ / (cos²Δθ + (L_d/L_q) sin²Δθ)`, which
//! is `Δθ` near zero: the tracking error in radians, whatever the voltage the inverter
//! actually applied (the update delay's blend of two periods, the dead time) because the
//! measured d response `η` (low-passed) normalises it. The response is taken as the
//! second difference of three samples, `s (i_k − 2 i_{k−1} + i_{k−2})/2` (the last period's
//! step against the one before, which had the other sign): a fundamental current that changes
//! at a steady rate drops out. The fundamental current is the mean of
//! two consecutive samples (the square wave's response alternates around it), the current
//! loop's feedback. The error drives a type-2 tracking loop (a PLL: `ω̂_e += ω_o² T e`,
//! `θ̂_e += T ω̂_e + 2ω_o T e`) through the lock, the polarity test and a start to speed.
//! While the drive holds the rotor at zero speed ([`InjectionState::motion_model`], set by
//! the position hold of `drive/inject.rs`) it drives a tracking observer with the rotor's
//! mechanical model instead,
//! Yoon et al. Sec. III's angle observer (the motion observer of Lorenz, Van Patten,
//! "High-resolution velocity estimation for all-digital, AC servo drives", IEEE Trans. Ind.
//! Appl. 27(4), 1991): the acceleration the commanded torque makes, `u = N K_t i_τ/J`, is fed
//! forward and the load's deceleration `â` estimated,
//! ```text
//! θ̂_e += T ω̂_e + 3ω_o T e,    ω̂_e += T (u − â_e) + 3ω_o² T e,    â_e −= ω_o³ T e
//! ```
//! (the error's poles all at `−ω_o`; `e` the error above). With the torque fed forward the
//! speed and the load come without the lag of a PLL's: the position hold feeds `â` forward
//! and damps on `ω̂`. (Not through the start: its larger first gain and third state lost the
//! Caruso's start under a rated brake at a quarter of the voltage, and on the bench's
//! voltage-limited case at 20 kHz cost the step 60 cycles, over its budget.)
//!
//! The saliency gives the axis, not its direction: the loop locks at `Δθ = 0` or `π`. The
//! polarity comes from the d axis' magnetic saturation (Jeong, Lorenz, Jahns, Sul,
//! "Initial rotor position estimation of an interior permanent-magnet synchronous machine
//! using carrier-frequency injection methods", IEEE Trans. Ind. Appl. 41(1), 2005): a d
//! current that adds to the magnet's flux saturates the d axis and lowers its incremental
//! inductance, so the injection's d response `η` is larger under a positive d-current bias
//! than under a negative one of the same size on the true d axis, and the other way round on
//! the flipped estimate. After the lock the block holds `+I_p` then `−I_p` on the estimated d
//! axis and compares the mean responses; a smaller response under `+I_p` flips `θ̂` by `π`.
//! The comparison is a test against the noise the samples themselves show, repeated with a
//! fixed boundary: the two sums must differ by [`POLARITY_SIGMAS`] standard deviations, or
//! the halves are repeated and summed, up to [`POLARITY_ROUNDS`]; a test still within its
//! noise then is [`Phase::Unresolved`], and the drive aligns instead (`drive/inject.rs`).
//! (Eight looks at a noise estimated from few samples: on a motor without any contrast
//! about 0.1 % of starts still resolve, half of them the wrong way, in a Monte-Carlo
//! estimate of the review; one look at a known noise would be 6e-5.) Before, the sign was
//! taken whatever the margin: on the Zou traction motor at 4 kHz with the board's noise one
//! round is 1.8 σ (a start against the magnet in 4 % of starts), and on a d axis that does
//! not saturate the sign is the noise's, a start against the magnet in half of them.
//!
//! **Scaled from the motor** (never tuned to one):
//! - injection voltage `V_h = min(R_h · I_τ · L_d / (T |1 − 2δ|), V_s)`, `δ` the board's
//!   update delay in periods (the square wave applied is `(1 − 2δ)` of the commanded, its sign
//!   taken into the demodulation; declined where `|1 − 2δ| <` [`GAIN_MIN`]): the d current's swing per
//!   period is `R_h = 0.3` ([`RIPPLE`]) of the rated-torque current `I_τ`, unless that takes
//!   more than the injection's share `V_s` of the inverter's `V_max = V_bus/√3`: what the
//!   current loop leaves, `V_max − V_loop` (`V_loop = R I_max + ω_e (ψ_f + L_q I_max)`, its
//!   fundamental's most up to the hand-over speed), within a quarter and a half of `V_max`
//!   ([`VOLTAGE_SHARE_MIN`], [`VOLTAGE_SHARE_MAX`]). (A quarter alone left the Caruso IPM at
//!   310 V and 5 kHz a swing of 0.9 A against its 0.085 A of sensor noise, an angle error of
//!   104° RMS holding rated torque: the hold lost it.)
//! - the tracking observer's pole `ω_o = 2π f_s / 80` ([`PLL_DIVIDER`]; 50 Hz at 4 kHz):
//!   `ω_o T = 0.079`, `3ω_o T = 0.24` the motion observer's largest gain, well inside the
//!   discrete loop's stability (at `2π f_s/40`, with the motion observer through the lock,
//!   its first steps swung the AMK's frame into an over-current);
//! - the lock time `12/ω_o` (38 ms at 4 kHz), each polarity half `POLARITY_S` (8 ms: about
//!   15 time constants of the 300 Hz current loop), averaged over its second half, with the
//!   bias `I_p = I_τ/2` ([`POLARITY_BIAS`]); the test's noise from its own samples;
//! - the response's low-pass `1 − e^{−T/τ_η}`, `τ_η = 4/ω_o`.
//!
//! **Declined** ([`Declined`]) where it cannot work: a saliency `L_q/L_d` below
//! [`SALIENCY_MIN`] (the error signal at 45°, `η(1 − L_d/L_q)/2`, would be at most a tenth of
//! the d swing: buried in the board's 1 % current noise), or a swing below [`RIPPLE_MIN`] of
//! `I_τ` at a quarter of the inverter's voltage.

use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::math::{max, min, sin_cos_wrapped, wrap_pi};
use core::f32::consts::{PI, TAU};

/// The smallest saliency `L_q/L_d` the drive injects on.
pub const SALIENCY_MIN: f32 = 1.25;

/// The d current's swing per period, a fraction of the rated-torque current.
pub const RIPPLE: f32 = 0.3;

/// The tracking observer's pole is the control rate over this (in rad/s: `2π f_s/80`).
pub const PLL_DIVIDER: f32 = 80.0;

/// The polarity test's d-current bias, a fraction of the rated-torque current.
pub const POLARITY_BIAS: f32 = 0.5;

/// Each half of the polarity test \[s].
pub const POLARITY_S: f32 = 0.008;

/// The largest injection voltage, a fraction of the inverter's `V_bus/√3`, where the current
/// loop needs little of it.
pub const VOLTAGE_SHARE_MAX: f32 = 0.5;

/// The injection voltage the drive allows whatever the current loop needs, a fraction of the
/// inverter's `V_bus/√3`.
pub const VOLTAGE_SHARE_MIN: f32 = 0.25;

/// The smallest d swing per period the drive injects with (where the injection's share of the
/// voltage, at most [`VOLTAGE_SHARE_MAX`], cuts
/// `V_h`), a fraction of the rated-torque current: five times the board's current noise (1 %
/// of the rated current, `DESIGN.md`).
pub const RIPPLE_MIN: f32 = 0.05;

/// The polarity test's confidence: the difference of its two sums must exceed this many
/// standard deviations of the noise in it, as the test's own samples show it (module doc);
/// below it the direction is [`Phase::Unresolved`].
pub const POLARITY_SIGMAS: f32 = 4.0;

/// The polarity test's most rounds (each a `+I_p` and a `−I_p` half, summed over all): it
/// ends at the first round whose sums differ beyond [`POLARITY_SIGMAS`]; the margin grows as
/// `√rounds`, so a contrast at 1.8σ in one round is at 4σ after five on average (the Zou
/// traction motor's at 4 kHz with the board's noise, its injection's swing cut to 5 % of its
/// rated current by the voltage share: it resolves in one to six rounds). At most 128 ms at
/// 8 ms a half.
pub const POLARITY_ROUNDS: u32 = 8;

/// The variance of the difference of the polarity test's two sums of `N` responses per
/// mean square of successive responses' differences, per `N`: with white sensor noise of
/// variance `σ²` the square wave's alternating sign gives each sample the weight 2 in a sum
/// (`4 N σ²` a sum, `8 N σ²` the difference of two), and one response less the one before,
/// `s_k (n_k − n_{k−1} − n_{k−2} + n_{k−3})/2`, has `σ²`. Successive differences leave out
/// what changes slowly in a window (the current settling on the bias), which is no noise.
const DIFFERENCE_VARIANCE_FACTOR: f32 = 8.0;

/// The smallest share of the square wave the update delay may leave, `|1 − 2δ|`.
pub const GAIN_MIN: f32 = 0.25;

/// Why the drive does not start through the injection: turned off, or this motor, bus, rate
/// or update delay (it starts as without the injection: align and open loop).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Declined {
    /// Turned off (`Drive::without_injection`).
    TurnedOff,
    /// `L_q/L_d` (the ratio given) below [`SALIENCY_MIN`]: no usable saliency.
    NotSalient {
        /// The motor's `L_q/L_d`.
        ratio: f32,
    },
    /// The injection voltage `V_h`, cut to the injection's share of the inverter's `v_max`
    /// \[V], swings the d current by less than [`RIPPLE_MIN`] of the rated-torque current.
    Voltage {
        /// The d swing per period at that voltage \[A].
        swing_a: f32,
        /// `V_bus/√3` \[V].
        v_max: f32,
    },
    /// The update delay `δ` (in periods) leaves less than [`GAIN_MIN`] of the square wave:
    /// its gain `|1 − 2δ|` given.
    Delay {
        /// `|1 − 2δ|`.
        gain: f32,
    },
    /// A parameter not finite or not positive (the name given).
    Parameter(&'static str),
}

/// The injection's settings in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InjectionConfig {
    /// d-axis inductance \[H].
    pub l_d_h: f32,
    /// q-axis inductance \[H].
    pub l_q_h: f32,
    /// Rated-torque current `I_τ` \[A].
    pub current_a: f32,
    /// Nominal bus \[V].
    pub bus_v: f32,
    /// Control rate \[Hz] (one injection period per step).
    pub rate_hz: f32,
    /// The voltage the current loop keeps \[V]: the most its fundamental needs up to the
    /// hand-over speed at the current limit, `R I_max + ω_e (ψ_f + L_q I_max)` at the hand-over
    /// speed's `ω_e`.
    pub v_loop: f32,
    /// The board's update delay in control periods, 0..=1 (`PowerStageConfig::update_delay_s`
    /// times the rate): the voltage over a period is `(1 − δ)` of its command and `δ` of the
    /// one before.
    pub delay_periods: f32,
}

/// The injection's per-step coefficients ([`InjectionConfig::build`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Injection {
    /// `V_h` \[V].
    v_h: f32,
    /// The sign of the square wave's gain through the update delay, `sgn(1 − 2δ)`.
    demod_sign: f32,
    /// `T` \[s].
    ts: f32,
    /// The lock's and the polarity test's PLL gains times `T`: `2ω_o T` \[1], `ω_o² T`
    /// \[1/s].
    kp_ts: f32,
    ki_ts: f32,
    /// The tracking observer's gains times `T`: `3ω_o T` \[1], `3ω_o² T` \[1/s], `ω_o³ T`
    /// \[1/s²].
    l1_ts: f32,
    l2_ts: f32,
    l3_ts: f32,
    /// `1/(1 − L_d/L_q)`.
    inv_ks: f32,
    /// The response's low-pass gain per step.
    eta_gain: f32,
    /// The nominal d response `V_h T/L_d` \[A] (the low-pass's start) and its floor, a tenth.
    eta_nominal: f32,
    /// Steps of the lock, and of each polarity half.
    lock_steps: u32,
    half_steps: u32,
    /// The polarity bias `I_p` \[A].
    bias_a: f32,
}

/// Where the injection is ([`InjectionState::phase`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Phase {
    /// The tracking loop locking on the saliency (axis known, direction not).
    #[default]
    Lock,
    /// The polarity test, `+I_p` on the estimated d axis.
    Positive,
    /// The polarity test, `−I_p`.
    Negative,
    /// Angle and polarity known: tracking.
    Track,
    /// The polarity test ended within its noise ([`POLARITY_SIGMAS`]): the axis is known,
    /// its direction not (a motor whose d axis barely saturates at `I_p`). The drive starts
    /// with the alignment instead; the estimate keeps tracking at zero current meanwhile.
    Unresolved,
}

/// The injection's running state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct InjectionState {
    /// θ̂_e in (−π, π] \[rad, electrical].
    pub theta_e: f32,
    /// ω̂_e \[rad/s, electrical].
    pub omega_e: f32,
    /// The tracking observer with the rotor's mechanical model (set by the caller: the
    /// position hold's), else the PLL.
    pub motion_model: bool,
    /// The load's deceleration `â_e = N τ_L/J` \[rad/s², electrical]: what the rotor's
    /// acceleration falls short of the torque's.
    pub accel_load_e: f32,
    /// The sign of the injection commanded last (0 before the first).
    sign: f32,
    /// The last sample's currents and the one's before \[A].
    i_prev: AlphaBeta,
    i_prev2: AlphaBeta,
    /// The low-passed d response `η` \[A].
    eta: f32,
    /// The phase and its steps.
    phase: Phase,
    steps: u32,
    /// Sums of `η` over the polarity halves' averaging windows \[A].
    sum_pos: f32,
    sum_neg: f32,
    /// Σ(`η_k − η_{k−1}`)² within the windows \[A²] (the test's noise), and the last `η`.
    sum_dsq: f32,
    eta_last: f32,
    /// The polarity test's rounds done.
    rounds: u32,
    /// The polarity test's contrast `(η₊ − η₋)/(η₊ + η₋)` on the estimate before any flip
    /// (positive: the lock was on the magnet's north).
    pub contrast: f32,
    /// The estimate was flipped by π.
    pub flipped: bool,
}

/// One step's result ([`Injection::step`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tracked {
    /// sin/cos of θ̂_e: the frame of the current loop.
    pub frame: SinCos,
    /// The fundamental current (the mean of this and the last sample) in that frame \[A].
    pub i_dq: Dq,
    /// The injection voltage to add to the d voltage over the coming period \[V].
    pub v_d: f32,
}

impl InjectionConfig {
    /// The coefficients (module doc), or why the drive declines to inject.
    pub fn build(&self) -> Result<Injection, Declined> {
        let p = |name, x: f32| {
            if x.is_finite() && x > 0.0 {
                Ok(x)
            } else {
                Err(Declined::Parameter(name))
            }
        };
        let l_d = p("l_d_h", self.l_d_h)?;
        let l_q = p("l_q_h", self.l_q_h)?;
        let i_tau = p("current_a", self.current_a)?;
        let bus = p("bus_v", self.bus_v)?;
        let rate = p("rate_hz", self.rate_hz)?;
        let ratio = l_q / l_d;
        // (The parameters are finite and positive here: no NaN compares.)
        if ratio < SALIENCY_MIN {
            return Err(Declined::NotSalient { ratio });
        }
        let delay = self.delay_periods;
        if !(0.0..=1.0).contains(&delay) {
            return Err(Declined::Parameter("delay_periods"));
        }
        // The square wave through the update delay: `(1 − δ) s_k + δ s_{k−1} = (1 − 2δ) s_k`.
        let gain = 1.0 - 2.0 * delay;
        if libm::fabsf(gain) < GAIN_MIN {
            return Err(Declined::Delay {
                gain: libm::fabsf(gain),
            });
        }
        let ts = 1.0 / rate;
        let v_max = bus * crate::math::INV_SQRT3;
        // What the current loop leaves, within the two shares.
        let v_share = max(
            min(v_max - self.v_loop, VOLTAGE_SHARE_MAX * v_max),
            VOLTAGE_SHARE_MIN * v_max,
        );
        let v_h = min(RIPPLE * i_tau * l_d / (ts * libm::fabsf(gain)), v_share);
        let swing = v_h * libm::fabsf(gain) * ts / l_d;
        if swing < RIPPLE_MIN * i_tau {
            return Err(Declined::Voltage {
                swing_a: swing,
                v_max,
            });
        }
        let w_o = TAU * rate / PLL_DIVIDER;
        let lock_s = 12.0 / w_o;
        Ok(Injection {
            v_h,
            demod_sign: if gain > 0.0 { 1.0 } else { -1.0 },
            ts,
            kp_ts: 2.0 * w_o * ts,
            ki_ts: w_o * w_o * ts,
            l1_ts: 3.0 * w_o * ts,
            l2_ts: 3.0 * w_o * w_o * ts,
            l3_ts: w_o * w_o * w_o * ts,
            inv_ks: 1.0 / (1.0 - l_d / l_q),
            eta_gain: 1.0 - libm::expf(-ts * w_o / 4.0),
            eta_nominal: swing,
            lock_steps: libm::ceilf(lock_s * rate) as u32,
            half_steps: libm::ceilf(POLARITY_S * rate) as u32,
            bias_a: POLARITY_BIAS * i_tau,
        })
    }
}

impl Injection {
    /// The tracking observer's pole `ω_o` \[rad/s].
    pub fn omega_o(&self) -> f32 {
        self.l1_ts / (3.0 * self.ts)
    }

    /// The injection voltage `V_h` \[V].
    pub fn v_h(&self) -> f32 {
        self.v_h
    }

    /// The state to start from at the estimate `theta_e` \[rad, electrical] (e.g. 0), the
    /// currents `i_ab` measured now \[A].
    pub fn start(&self, theta_e: f32, i_ab: AlphaBeta) -> InjectionState {
        InjectionState {
            theta_e: wrap_pi(theta_e),
            i_prev: i_ab,
            i_prev2: i_ab,
            eta: self.eta_nominal,
            ..InjectionState::default()
        }
    }

    /// Steps from the start to the end of the polarity test's first round (each further
    /// round `2 · half` more, up to [`POLARITY_ROUNDS`]: [`Injection::start_steps_max`]).
    pub fn start_steps(&self) -> u32 {
        self.lock_steps + 2 * self.half_steps
    }

    /// Steps from the start to the end of the polarity test's last round.
    pub fn start_steps_max(&self) -> u32 {
        self.lock_steps + 2 * POLARITY_ROUNDS * self.half_steps
    }

    /// The d-current reference of the lock and the polarity test (0, `+I_p`, `−I_p`), or
    /// `None` while tracking (the caller's own).
    pub fn bias(&self, st: &InjectionState) -> Option<f32> {
        match st.phase {
            Phase::Lock => Some(0.0),
            Phase::Positive => Some(self.bias_a),
            Phase::Negative => Some(-self.bias_a),
            Phase::Unresolved => Some(0.0),
            Phase::Track => None,
        }
    }

    /// One control period: the currents `i_ab` measured now \[A] demodulated against the
    /// injection applied over the period that just ended, the tracking observer (`accel_e`:
    /// the acceleration the torque asked for over that period makes, `N K_t i_τ/J` \[rad/s²,
    /// electrical]), the polarity
    /// test's bookkeeping; the frame and fundamental current for the current loop and the
    /// injection voltage for the coming period. Non-finite currents leave the estimate as it
    /// was (the drive's input checks fault on them).
    #[inline(always)]
    pub fn step(&self, st: &mut InjectionState, i_ab: AlphaBeta, accel_e: f32) -> Tracked {
        if st.sign == 0.0 {
            // A fresh state (`InjectionState::default()`, θ̂ = 0): its first sample.
            core::hint::cold_path();
            *st = self.start(st.theta_e, i_ab);
        }
        let (sin, cos) = sin_cos_wrapped(st.theta_e);
        let frame = SinCos { sin, cos };
        // The second difference (i_k − 2 i_{k−1} + i_{k−2})/2: the square wave's response
        // alternates, so it is `s·ΔI` of the last period, and a fundamental current changing
        // at a steady rate (a torque ramp, the back-EMF) drops out.
        let d_ab = AlphaBeta::new(
            0.5 * (i_ab.alpha - 2.0 * st.i_prev.alpha + st.i_prev2.alpha),
            0.5 * (i_ab.beta - 2.0 * st.i_prev.beta + st.i_prev2.beta),
        );
        let m_ab = AlphaBeta::new(
            0.5 * (i_ab.alpha + st.i_prev.alpha),
            0.5 * (i_ab.beta + st.i_prev.beta),
        );
        let di = d_ab.to_dq(frame);
        let i_dq = m_ab.to_dq(frame);
        let s = st.sign * self.demod_sign;
        let eta = s * di.d;
        let eps = s * di.q;
        // Yoon et al.: the error in radians near lock, normalised by the measured d response
        // (floored at a tenth of the nominal: a response that vanished gives no error).
        let err = eps * self.inv_ks / max(st.eta, 0.1 * self.eta_nominal);
        if s != 0.0 && err.is_finite() && eta.is_finite() {
            st.eta += self.eta_gain * (eta - st.eta);
            if st.motion_model {
                st.theta_e = wrap_pi(st.theta_e + self.ts * st.omega_e + self.l1_ts * err);
                st.omega_e += self.ts * (accel_e - st.accel_load_e) + self.l2_ts * err;
                st.accel_load_e -= self.l3_ts * err;
            } else {
                st.omega_e += self.ki_ts * err;
                st.theta_e = wrap_pi(st.theta_e + self.ts * st.omega_e + self.kp_ts * err);
            }
            self.polarity(st, eta);
        }
        if d_ab.alpha.is_finite() && d_ab.beta.is_finite() {
            st.i_prev2 = st.i_prev;
            st.i_prev = i_ab;
        }
        let next = if st.sign > 0.0 { -1.0 } else { 1.0 };
        st.sign = next;
        Tracked {
            frame,
            i_dq,
            v_d: next * self.v_h,
        }
    }

    /// The phases' count and the polarity test (module doc).
    #[inline(always)]
    fn polarity(&self, st: &mut InjectionState, eta: f32) {
        st.steps = st.steps.saturating_add(1);
        let half = self.half_steps;
        let averaging = st.steps > half / 2;
        match st.phase {
            Phase::Lock if st.steps >= self.lock_steps => {
                st.phase = Phase::Positive;
                st.steps = 0;
            }
            Phase::Positive | Phase::Negative if averaging => {
                if st.steps > half / 2 + 1 {
                    let d = eta - st.eta_last;
                    st.sum_dsq += d * d;
                }
                st.eta_last = eta;
                if st.phase == Phase::Positive {
                    st.sum_pos += eta;
                } else {
                    st.sum_neg += eta;
                }
                if st.steps >= half {
                    if st.phase == Phase::Positive {
                        st.phase = Phase::Negative;
                    } else {
                        self.decide(st);
                    }
                    st.steps = 0;
                }
            }
            Phase::Lock | Phase::Positive | Phase::Negative | Phase::Track | Phase::Unresolved => {}
        }
    }

    /// The end of a round of the polarity test: the estimate flipped by π if the response
    /// under `+I_p` was the smaller; another round, or after [`POLARITY_ROUNDS`]
    /// [`Phase::Unresolved`], where the two sums differ by less than
    /// [`POLARITY_SIGMAS`] standard deviations of their difference's noise, from the
    /// windows' own samples: the mean square of successive responses' differences within
    /// each window, times `8 N` ([`DIFFERENCE_VARIANCE_FACTOR`]). (Where nothing saturates,
    /// the contrast is noise: the sign a coin's, the start half the time against the magnet,
    /// the rotor pulled round by up to 180°.)
    // Out of line: once per round of the test.
    #[inline(never)]
    fn decide(&self, st: &mut InjectionState) {
        let (p, n) = (st.sum_pos, st.sum_neg);
        st.contrast = (p - n) / max(p + n, f32::MIN_POSITIVE);
        st.rounds += 1;
        // Samples per sign: the steps after each half's first half (`polarity`).
        let per_window = (self.half_steps - self.half_steps / 2) as f32;
        let count = st.rounds as f32 * per_window;
        let mssd = st.sum_dsq / max(2.0 * st.rounds as f32 * (per_window - 1.0), 1.0);
        let noise = crate::math::sqrt_or_zero(DIFFERENCE_VARIANCE_FACTOR * count * mssd);
        // No noise seen (`sqrt_or_zero`'s 0 for 0, NaN or ∞: a constant response, a stuck
        // sensor) or a NaN sum: not resolved.
        let resolved = noise > 0.0 && libm::fabsf(p - n) >= POLARITY_SIGMAS * noise;
        if !resolved {
            st.phase = if st.rounds < POLARITY_ROUNDS {
                Phase::Positive
            } else {
                Phase::Unresolved
            };
            return;
        }
        if p < n {
            st.flipped = true;
            st.theta_e = wrap_pi(st.theta_e + PI);
        }
        st.phase = Phase::Track;
    }
}

impl InjectionState {
    /// The phase.
    pub fn phase(&self) -> Phase {
        self.phase
    }

    /// The low-passed d response `η` \[A].
    pub fn response_a(&self) -> f32 {
        self.eta
    }
}
