//! Inertia and viscous friction from the speed response to torque steps.
//!
//! Method: acceleration under a known torque (the inertia step of drive self-commissioning,
//! e.g. ST's profiler's and TI InstaSPIN's inertia identification; B from the steady-state
//! balance of the same equation). The frame is locked on the rotor by a PLL on the back-EMF
//! (the `e = v − R i − L di/dt` of `flux.rs`, whose angle in the frame is the angle error),
//! i_d = 0, and a q current `+I_t` accelerates the rotor from 30 % to 60 % of rated speed,
//! then `−I_t` brakes it back. The mechanical equation (Horng & Chin eq (19), no load)
//!
//! ```text
//! J dω_m/dt + B ω_m = N ψ_f i_q
//! ```
//!
//! holds on each segment with its mean acceleration `α` (a least-squares line through the
//! PLL's speed, first 20 ms dropped), mean speed `ω̄` and mean measured `i_q`: two equations,
//! `J α_up + B ω̄_up = τ_up`, `J α_dn + B ω̄_dn = τ_dn`, solved for `J` \[kg·m²] and `B`
//! \[N·m·s/rad]. `I_t` starts at 2 % of the rated current and doubles (up to the rated
//! current) until a segment moves the speed by a third of the range in its 300 ms, and
//! halves when a segment is over in less than 60 ms (a braking segment after an
//! accelerating one that ran its whole 300 ms halves only the braking current: on a motor
//! whose friction is a large part of the torque, braking with the accelerating torque and the
//! friction is over long before accelerating against it; the two
//! equations take each segment's own mean `i_q`); so any inertia the rated torque can move
//! is measured at a torque it notices. The back-EMF more than 0.6 rad off the frame for 20 ms
//! is a lost rotor.
//!
//! The PLL follows the segment's acceleration ([`Tracking::new`]). A critically damped type-2
//! PLL (`ω_e = ω_i − k_p δ`, `ω_i −= k_i T δ`, `k_p = 2ω_n`, `k_i = ω_n²`) lags a constant
//! electrical acceleration `α_e` by `δ = α_e/ω_n²` and meets a step of it without overshoot
//! (F. M. Gardner, *Phaselock Techniques*, 3rd ed., Wiley 2005, ch. 2, the second-order loop's
//! steady-state errors). The fastest segment the steps accept runs the range
//! `Δω_m = ω_high − ω_low` in `T_short`, so `α_e ≤ N Δω_m/T_short`; its lag is held to
//! `δ_acc` = 0.3 rad, half of the lost rotor's 0.6:
//!
//! ```text
//! ω_n     = clamp( √(N Δω_m / (T₀ δ_acc)),  2π·40 Hz,  0.5/T_tick )     T₀ = 60 ms
//! T_short = max( T₀,  N Δω_m / (δ_acc ω_n²) )
//! ```
//!
//! 40 Hz and 60 ms serve every motor up to `N Δω_m = δ_acc T₀ (2π·40)²` = 1137 rad/s
//! (600 Hz electrical at rated speed: every zoo motor but the drone and the EMRAX keeps them). The
//! sampled loop (the EMF averaged over the 1 kHz tick's millisecond) has a double pole at
//! `1 − ω_n T` without the averaging; with it the loop's damping falls above `ω_n T` ≈ 0.6 and it
//! is unstable at 0.7: `ω_n T ≤ 0.5` (80 Hz). Where that bound holds `ω_n`, the shortest segment
//! grows instead: the drone (N Δω_m = 7540 rad/s) at 80 Hz accepts segments of 100 ms or
//! more, whose lag stays within `δ_acc` (at 40 Hz and 60 ms its fastest accepted segment lagged
//! 2 rad, its rotor was lost and its current loop, fed the EMF on the wrong axis, tripped
//! over-current).

use super::inverter::dead_time_applied;
use super::{back_emf, Identified, IdentifyError, Progress, Settings};
use crate::dead_time::DeadTime;
use crate::foc::{Foc, Reference, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::motor::MotorParams;
use core::f32::consts::TAU;

/// The PLL's lowest natural frequency \[rad/s] (40 Hz, critically damped) at 1 kHz.
const PLL_WN_MIN: f32 = TAU * 40.0;
/// The PLL's highest `ω_n T` at the 1 kHz tick (module doc).
const PLL_WN_T_MAX: f32 = 0.5;
/// The PLL's lag allowed under the fastest accepted segment's acceleration \[rad].
const LAG_ACC: f32 = 0.3;
/// Each segment's first milliseconds are not fitted; its longest duration \[ms].
const SKIP_MS: u32 = 20;
const SEGMENT_MS: u32 = 300;
/// Fewest fitted milliseconds of a segment, at the PLL's lowest natural frequency (`T₀` =
/// 60 ms with the skipped ones).
const MIN_POINTS: u32 = 40;

/// The PLL's gains and the shortest segment, from the motor's torque-step range (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::drive) struct Tracking {
    /// `k_p = 2ω_n` \[1/s] and `k_i T = ω_n² · 1 ms` \[1/s].
    kp: f32,
    ki_t: f32,
    /// Fewest fitted milliseconds of a segment (`T_short` less the skipped ones).
    min_points: f32,
}

impl Tracking {
    /// For `n` pole pairs and the torque steps' speed range `range_m` [rad/s, mechanical].
    pub(super) fn new(n: f32, range_m: f32) -> Self {
        let range_e = n * range_m;
        let t0_s = (SKIP_MS + MIN_POINTS) as f32 * 1e-3;
        let wn_max = PLL_WN_T_MAX * crate::schedule::TICK_HZ;
        let wn_acc = crate::math::sqrt_or_zero(range_e / (t0_s * LAG_ACC));
        let wn = crate::math::clamp(wn_acc, PLL_WN_MIN, wn_max);
        let t_short_s = crate::math::max(t0_s, range_e / (LAG_ACC * wn * wn));
        let t_short_ms = t_short_s * 1e3;
        // Whole milliseconds, rounded up; MIN_POINTS where T₀ holds.
        let min_points = crate::math::max(
            MIN_POINTS as f32,
            crate::math::max(t_short_ms - SKIP_MS as f32 + 0.999, 0.0) as u32 as f32,
        );
        Self {
            kp: 2.0 * wn,
            ki_t: wn * wn * 1e-3,
            min_points,
        }
    }
}
/// Attempts at finding the torque.
const ATTEMPTS: u32 = 16;

/// Least-squares line through (t, ω).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Fit {
    n: f32,
    t: f32,
    tt: f32,
    w: f32,
    tw: f32,
    /// Σ i_q \[A].
    iq: f32,
}

impl Fit {
    fn add(&mut self, t: f32, w: f32, iq: f32) {
        self.n += 1.0;
        self.t += t;
        self.tt += t * t;
        self.w += w;
        self.tw += t * w;
        self.iq += iq;
    }

    /// Slope \[rad/s²], mean speed \[rad/s], mean i_q \[A], speed change over the fit \[rad/s].
    fn result(&self) -> (f32, f32, f32, f32) {
        let n = self.n;
        let slope = (n * self.tw - self.t * self.w) / (n * self.tt - self.t * self.t);
        let span = slope * (n - 1.0) * 1e-3;
        (slope, self.w / n, self.iq / n, span)
    }
}

/// The state of the inertia and friction measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::drive) struct Mechanics {
    frame: SinCos,
    step_rot: SinCos,
    out_rot: SinCos,
    /// The PLL's integrator and output [rad/s, electrical].
    omega_i_e: f32,
    omega_e: f32,
    i_prev: AlphaBeta,
    e_sum: Dq,
    iq_sum: f32,
    n: u32,
    r_ohm: f32,
    l_over_t: f32,
    /// Torque current \[A]; accelerating (else braking).
    i_t: f32,
    /// The braking current's fraction of `i_t` (halved by a braking segment over too soon).
    brake: f32,
    /// The last accelerating segment ran its whole time without reaching its speed.
    up_long: bool,
    up: bool,
    ms: u32,
    fit: Fit,
    /// The accelerating segment's (slope, mean speed, mean i_q).
    up_result: (f32, f32, f32),
    /// `up_result` is of the torque now.
    up_valid: bool,
    attempts: u32,
    lost_ms: u32,
}

impl Mechanics {
    /// In the rotor's frame `rotor` at speed `omega_m` [rad/s, mechanical], `i_prev` the last
    /// sample \[A].
    pub(in crate::drive) fn new(
        s: &Settings,
        m: &Identified,
        rotor: SinCos,
        omega_m: f32,
        i_prev: AlphaBeta,
    ) -> Self {
        let omega_e = s.n * omega_m;
        Self {
            frame: rotor,
            step_rot: SinCos::of_small(omega_e * s.ts),
            out_rot: SinCos::ZERO,
            omega_i_e: omega_e,
            omega_e,
            i_prev,
            e_sum: Dq::default(),
            iq_sum: 0.0,
            n: 0,
            r_ohm: m.r_ohm,
            l_over_t: m.l_h() / s.ts,
            i_t: 0.02 * s.i_test_a,
            brake: 1.0,
            up_long: false,
            up: true,
            ms: 0,
            fit: Fit::default(),
            up_result: (0.0, 0.0, 0.0),
            up_valid: false,
            attempts: 0,
            lost_ms: 0,
        }
    }

    /// One step: the back-EMF summed in the frame, the frame turned, the torque current
    /// requested.
    #[inline(always)]
    pub(in crate::drive) fn step(
        &mut self,
        i_ab: AlphaBeta,
        v_ab: AlphaBeta,
        dt: &DeadTime,
        v_bus: f32,
        n: f32,
    ) -> Request {
        let v_ab = dead_time_applied(v_ab, i_ab, self.i_prev, dt, v_bus);
        let e = back_emf(v_ab, i_ab, self.i_prev, self.r_ohm, self.l_over_t).to_dq(self.frame);
        self.i_prev = i_ab;
        self.e_sum = Dq::new(self.e_sum.d + e.d, self.e_sum.q + e.q);
        self.iq_sum += i_ab.to_dq(self.frame).q;
        self.n += 1;
        self.frame = self.frame.rotated(self.step_rot);
        let i_q = if self.up {
            self.i_t
        } else {
            -self.brake * self.i_t
        };
        Request {
            frame: self.frame,
            frame_out: self.frame.rotated(self.out_rot),
            omega_m: self.omega_e / n,
            reference: Reference::Current(Dq::new(0.0, i_q)),
        }
    }

    /// The 1 kHz work: the PLL, the segments, the result.
    pub(in crate::drive) fn tick(
        &mut self,
        s: &Settings,
        foc: &Foc,
        result: &mut Identified,
    ) -> Progress {
        let k = 1.0 / (self.n.max(1) as f32);
        let e = Dq::new(self.e_sum.d * k, self.e_sum.q * k);
        let iq = self.iq_sum * k;
        self.e_sum = Dq::default();
        self.iq_sum = 0.0;
        self.n = 0;
        // The PLL: δ = θ_frame − θ_e.
        let delta = crate::math::atan2(e.d, e.q);
        self.lost_ms = if delta.abs() > 0.6 {
            self.lost_ms + 1
        } else {
            0
        };
        if self.lost_ms > 20 || !delta.is_finite() {
            return Progress::Fail(IdentifyError::LostRotor);
        }
        let pll = &s.tracking;
        self.omega_i_e -= pll.ki_t * delta;
        self.omega_e = self.omega_i_e - pll.kp * delta;
        self.step_rot = SinCos::of_small(self.omega_e * s.ts);
        self.out_rot = foc.output_rotation(self.omega_e / s.n);
        self.frame = self.frame.renormalized();
        // The segment.
        self.ms += 1;
        let w = self.omega_i_e / s.n;
        if self.ms > SKIP_MS {
            self.fit.add(self.ms as f32 * 1e-3, w, iq);
        }
        let reached = if self.up {
            w >= s.omega_high_m
        } else {
            w <= s.omega_low_m
        };
        if !(reached || self.ms >= SEGMENT_MS || w < 0.5 * s.omega_low_m) {
            return Progress::Stay;
        }
        let fit = self.fit;
        self.fit = Fit::default();
        self.ms = 0;
        let too_short = fit.n < pll.min_points;
        let (slope, w_mean, iq_mean, span) = if too_short {
            (0.0, 0.0, 0.0, 0.0)
        } else {
            fit.result()
        };
        // The PLL integrator lags a steady acceleration by kp/ki·α: the mean speed corrected.
        let w_mean = w_mean + pll.kp / (pll.ki_t * 1e3) * slope;
        let range = s.omega_high_m - s.omega_low_m;
        let small = span.abs() < range / 3.0;
        self.attempts += 1;
        if self.attempts > ATTEMPTS {
            return Progress::Fail(IdentifyError::InertiaOutOfRange);
        }
        if self.up {
            if too_short {
                // Over too soon: brake with half the torque, then a new pair.
                self.i_t *= 0.5;
                self.up_valid = false;
                self.up = false;
            } else if small && 2.0 * self.i_t <= s.i_test_a {
                // Too little motion: accelerate on with twice the torque.
                self.i_t *= 2.0;
            } else {
                self.up_result = (slope, w_mean, iq_mean);
                self.up_long = !reached;
                self.up_valid = true;
                self.up = false;
            }
            return Progress::Stay;
        }
        // Braked: a new pair, or the result.
        self.up = true;
        if !self.up_valid {
            return Progress::Stay;
        }
        if too_short {
            // Braked too soon. After a long acceleration (the whole segment: friction is a
            // large part of the torque and adds to the braking) a new pair with half the
            // braking current, the same accelerating one; else with half of both.
            if self.up_long {
                self.brake *= 0.5;
            } else {
                self.i_t *= 0.5;
            }
            self.up_valid = false;
            return Progress::Stay;
        }
        let (a_up, w_up, iq_up) = self.up_result;
        let kt = s.torque_factor * s.n * result.flux_wb;
        let (t_up, t_dn) = (kt * iq_up, kt * iq_mean);
        let det = a_up * w_mean - slope * w_up;
        let j_kgm2 = (t_up * w_mean - t_dn * w_up) / det;
        let b_nms = (a_up * t_dn - slope * t_up) / det;
        if MotorParams::J_KGM2.check("j_kgm2", j_kgm2).is_err() {
            return Progress::Fail(IdentifyError::InertiaOutOfRange);
        }
        result.j_kgm2 = j_kgm2;
        // Friction is reported as measured; one within noise below zero is none.
        result.b_nms = if b_nms.is_finite() {
            b_nms.max(0.0)
        } else {
            0.0
        };
        Progress::Done
    }
}
