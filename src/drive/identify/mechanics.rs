//! Inertia and viscous friction from the speed response to torque steps.
//!
//! Method: acceleration under a known torque (the inertia step of drive self-commissioning,
//! e.g. ST's profiler's and TI InstaSPIN's inertia identification; B from the same equation).
//! The frame is locked on the rotor by a PLL on the back-EMF (the `e = v − R i − L di/dt` of
//! `flux.rs`, whose angle in the frame is the angle error), i_d = 0, and a q current `+I_t`
//! accelerates the rotor from 30 % to 60 % of rated speed, then `−I_t` brakes it back. The
//! mechanical equation (Horng & Chin eq (19), no load), with `k_t = c N ψ_f` (`c` the torque
//! convention's factor, 3/2 for the amplitude-invariant transform), integrated from a
//! segment's start:
//!
//! ```text
//! J dω_m/dt + B ω_m = k_t i_q      ⇒      ω_m(t) = ω_s + (k_t/J) Q(t) − (B/J) W(t)
//! Q(t) = ∫ i_q dt  [A·s]           W(t) = ∫ ω_m dt  [rad]
//! ```
//!
//! is fitted by least squares over every millisecond of every accepted segment, each segment
//! with its own `ω_s` (the sums taken about each segment's means: Frisch & Waugh, Econometrica
//! 1(4), 1933; the integral form of the equation is the "momentum" or impulse form of the
//! inertia test). Each side is what the rotor did, not what the loop followed:
//!
//! - The speed `ω̃` at each millisecond's boundary is the frame's turn less the change of the
//!   measured angle error: `ω̃ = (ω_frame,k−1 + ω_frame,k)/2 − (δ_k − δ_k−1)/T`, the rotor's
//!   angle `θ = θ_frame − δ` differentiated; it has none of the PLL's lag.
//! - The torque current is the current along the back-EMF (the rotor's q axis, wherever the
//!   frame is): `i_q = (i·e)/|e|`, with `i` the mean of each period's two samples, as `e` is the
//!   period's mean. The EMF of a period lies half a period on from the frame it is taken in;
//!   the PLL's `δ` is taken at the period's middle (`atan2(e_d, e_q) + ω_e T_s/2`), so the frame
//!   is on the rotor at the samples.
//! - `ω̃`, `Q` and `W` pass through the same two first-order low-passes at the PLL's `ω_n`
//!   before the fit: a linear relation between signals holds between the same filter's outputs
//!   (the state-variable-filter method of continuous-time identification: P. C. Young,
//!   "Parameter estimation for continuous-time models — a survey", Automatica 17(1), 1981), and
//!   the difference noise of `ω̃` is smoothed away. The filters start from the PLL's speed
//!   (the first difference of the angle error is the spin's hand-over) and the fit takes its
//!   points from `T_short` on (five or more of their time constants).
//!
//! Measured on main before (torque steps on the segment's mean acceleration of the PLL's speed
//! against the mean frame `i_q`, 20 ms dropped, segments of 60 ms or more): J from +5 % to
//! −13 % on the Nanotec flat motor (seeds 1–8), −25 % to +12.5 % on the NEMA-23 at a tenth of
//! its J, −5.5 to −8.3 % on the drone. Three causes, each seen against the plant's own speed and
//! current in a trace: (1) the 60 ms segments held the torque current of light rotors at
//! 0.5 % of the rated current, half the current sensors' 1 % noise; the current loop passes
//! the noise's mean over a segment into the winding, `σ/√(f_s T)`: 6–14 % of the torque per
//! segment; (2) the frame lags the rotor by `δ` (up to 0.7 rad in the first steps) and its
//! `i_q` is `1/cos δ` of the rotor's; on the drone (9 samples per electrical period) the EMF,
//! half a period off the samples, put the current 0.5 rad ahead of the rotor's q axis, 12 %
//! less torque than measured; (3) a segment's least-squares slope weighs its middle, its mean
//! `i_q` every millisecond alike, and the PLL's speed lags through the first milliseconds.
//! With the plant's own current the old fit's spread on the Nanotec was −4…+7 % (−15…+3 %
//! with the measured one).
//!
//! `I_t` starts at 2 % of the rated current and doubles (up to the rated current) until a
//! segment moves the speed by a third of the range in its 300 ms, and halves when a segment is
//! over in less than `T_short` or the frame lags the rotor by more than `2 δ_acc` for 5 ms (a
//! braking segment after an accelerating one that ran its whole 300 ms halves only the braking
//! current: on a motor whose friction is a large part of the torque, braking with the
//! accelerating torque and the friction is over long before accelerating against it). A
//! braking segment reaches its low speed only after `T_short` (the reversal of the current
//! kicks the PLL's speed down for a few of its time constants). A pair whose two segments do
//! not tell inertia from friction (`Q` and `W` nearly proportional in both: a variance
//! inflation factor `1/(1 − r²)` above 10, the usual bound of regression diagnostics: Kutner,
//! Nachtsheim, Neter & Li, *Applied Linear Statistical Models*, 5th ed., 2005, §10.5) is not
//! fitted; after a long acceleration the next runs with twice the torque (below the test
//! current) or else half the braking current, after a short one with half of both. Pairs are added until the noise of the
//! fitted impulse is at most 2 % of it (1σ), at most 16 pairs:
//!
//! ```text
//! (Σ_ms n σ_ms² T_s²) · VIF  ≤  (0.02 Σ_seg |ΔQ|)²
//! ```
//!
//! with `σ_ms²` the variance of the millisecond's `n` current samples about their mean (the
//! sensing noise, measured), `VIF` of all fitted pairs. The impulse's noise falls as `1/I_t`
//! per unit of time (`I_t T` is fixed by the speed range), so the steps run at the largest
//! current the PLL tracks and repeat. The back-EMF more than 0.6 rad off the frame for 20 ms
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
//! ω_n     = clamp( √(N Δω_m / (T₀ δ_acc)),  2π·40 Hz,  0.5/T_tick )     T₀ = 20 ms
//! T_short = max( T₀,  N Δω_m / (δ_acc ω_n²) )
//! ```
//!
//! `T₀` = 20 ms is five time constants `1/ω_n` of the slowest PLL (the fit needs no settled
//! PLL: both sides are filtered alike); 40 Hz and 20 ms serve every motor up to
//! `N Δω_m = δ_acc T₀ (2π·40)²` = 379 rad/s. The sampled loop (the EMF averaged over the 1 kHz
//! tick's millisecond) has a double pole at `1 − ω_n T` without the averaging; with it the
//! loop's damping falls above `ω_n T` ≈ 0.6 and it is unstable at 0.7: `ω_n T ≤ 0.5` (80 Hz).
//! Where that bound holds `ω_n`, the shortest segment grows instead: the drone
//! (N Δω_m = 7540 rad/s) at 80 Hz accepts segments of 100 ms or more, whose lag stays within
//! `δ_acc` (at 40 Hz and 60 ms its fastest accepted segment lagged 2 rad, its rotor was lost
//! and its current loop, fed the EMF on the wrong axis, tripped over-current).

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
/// A segment's longest duration \[ms].
const SEGMENT_MS: u32 = 300;
/// Fewest milliseconds of a segment at the PLL's lowest natural frequency (`T₀`, module doc).
const MIN_POINTS: u32 = 20;
/// The torque steps' target: the impulse's noise at most this share of the impulse (1σ).
const NOISE_SHARE: f32 = 0.02;
/// Milliseconds of a lag beyond 2 `δ_acc` that end a segment as too short (the EMF's noise
/// alone is not that long beyond it).
const LAG_MS: u32 = 5;
/// The largest variance inflation of a pair's impulse and angle (module doc).
const INFLATION_MAX: f32 = 10.0;
/// Most pairs of segments fitted.
const PAIRS: u32 = 16;
/// Segments run at finding the torque, besides those of the fitted pairs.
const ATTEMPTS: u32 = 16;

/// The PLL's gains and the shortest segment, from the motor's torque-step range (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::drive) struct Tracking {
    /// `k_p = 2ω_n` \[1/s] and `k_i T = ω_n² · 1 ms` \[1/s].
    kp: f32,
    ki_t: f32,
    /// Fewest milliseconds of a segment (`T_short`).
    min_points: f32,
    /// The fit's low-pass: `x += g (u − x)` at the 1 kHz tick, `g = ω_n T/(1 + ω_n T)`.
    filter_gain: f32,
}

impl Tracking {
    /// For `n` pole pairs and the torque steps' speed range `range_m` [rad/s, mechanical].
    pub(super) fn new(n: f32, range_m: f32) -> Self {
        let range_e = n * range_m;
        let t0_s = MIN_POINTS as f32 * 1e-3;
        let wn_max = PLL_WN_T_MAX * crate::schedule::TICK_HZ;
        let wn_acc = crate::math::sqrt_or_zero(range_e / (t0_s * LAG_ACC));
        let wn = crate::math::clamp(wn_acc, PLL_WN_MIN, wn_max);
        let t_short_s = crate::math::max(t0_s, range_e / (LAG_ACC * wn * wn));
        let t_short_ms = t_short_s * 1e3;
        // Whole milliseconds, rounded up; MIN_POINTS where T₀ holds.
        let min_points = crate::math::max(
            MIN_POINTS as f32,
            crate::math::max(t_short_ms + 0.999, 0.0) as u32 as f32,
        );
        Self {
            kp: 2.0 * wn,
            ki_t: wn * wn * 1e-3,
            min_points,
            filter_gain: wn * 1e-3 / (1.0 + wn * 1e-3),
        }
    }
}

/// One segment's sums for the least squares of `ω̃ = c + a Q − b W` (module doc), each
/// variable taken from its value at the segment's start.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Segment {
    n: f32,
    q: f32,
    w: f32,
    y: f32,
    qq: f32,
    ww: f32,
    qw: f32,
    qy: f32,
    wy: f32,
}

impl Segment {
    fn add(&mut self, q: f32, w: f32, y: f32) {
        self.n += 1.0;
        self.q += q;
        self.w += w;
        self.y += y;
        self.qq += q * q;
        self.ww += w * w;
        self.qw += q * w;
        self.qy += q * y;
        self.wy += w * y;
    }
}

/// The normal equations of all fitted segments, each segment's own intercept taken out
/// (the sums about the segment's means).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Normal {
    qq: f32,
    ww: f32,
    qw: f32,
    qy: f32,
    wy: f32,
}

impl Normal {
    fn add(&mut self, g: &Segment) {
        let k = 1.0 / g.n;
        self.qq += g.qq - g.q * g.q * k;
        self.ww += g.ww - g.w * g.w * k;
        self.qw += g.qw - g.q * g.w * k;
        self.qy += g.qy - g.q * g.y * k;
        self.wy += g.wy - g.w * g.y * k;
    }

    /// The variance inflation factor of `Q` and `W`: `1/(1 − r²)`, `r` their correlation.
    fn inflation(&self) -> f32 {
        self.qq * self.ww / (self.qq * self.ww - self.qw * self.qw)
    }

    /// `(a, b)` of `ω̃ = c + a Q − b W`.
    fn solve(&self) -> (f32, f32) {
        let det = self.qq * self.ww - self.qw * self.qw;
        let a = (self.qy * self.ww - self.wy * self.qw) / det;
        let b = -(self.qq * self.wy - self.qw * self.qy) / det;
        (a, b)
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
    i_sum: Dq,
    iq_sum: f32,
    iq2_sum: f32,
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
    /// The last millisecond's angle error and frame speed [rad, rad/s electrical]; `None`
    /// before the first.
    last: Option<(f32, f32)>,
    /// The rotor's torque current's impulse `Q = ∫ i_q dt` \[A·s] and angle `W = ∫ ω̃ dt`
    /// [rad, mechanical] since the start.
    q_as: f32,
    w_rad: f32,
    /// At the segment's start: `Q`, `W`, `ω̃`.
    start: (f32, f32, f32),
    seg: Segment,
    /// `Q`, `W`, `ω̃` through the first and the second low-pass; milliseconds they ran.
    filtered: [[f32; 3]; 2],
    filtered_ms: u32,
    /// The segment's noise variance of `Q` \[(A·s)²].
    seg_var: f32,
    /// The accelerating segment just measured, its `Q` variance and `|ΔQ|`.
    up_seg: Option<(Segment, f32, f32)>,
    normal: Normal,
    /// Σ |ΔQ| over the fitted segments \[A·s] and the variance of their noise \[(A·s)²].
    impulse: f32,
    impulse_var: f32,
    pairs: u32,
    attempts: u32,
    lost_ms: u32,
    lag_ms: u32,
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
            step_rot: super::rotation(omega_e * s.ts),
            out_rot: SinCos::ZERO,
            omega_i_e: omega_e,
            omega_e,
            i_prev,
            e_sum: Dq::default(),
            i_sum: Dq::default(),
            iq_sum: 0.0,
            iq2_sum: 0.0,
            n: 0,
            r_ohm: m.r_ohm,
            l_over_t: m.l_h() / s.ts,
            i_t: 0.02 * s.i_test_a,
            brake: 1.0,
            up_long: false,
            up: true,
            ms: 0,
            last: None,
            q_as: 0.0,
            w_rad: 0.0,
            start: (0.0, 0.0, 0.0),
            seg: Segment::default(),
            filtered: [[0.0; 3]; 2],
            filtered_ms: 0,
            seg_var: 0.0,
            up_seg: None,
            normal: Normal::default(),
            impulse: 0.0,
            impulse_var: 0.0,
            pairs: 0,
            attempts: 0,
            lost_ms: 0,
            lag_ms: 0,
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
        // The period's mean current (of its two samples), as the EMF is the period's.
        let i_mid = AlphaBeta::new(
            0.5 * (i_ab.alpha + self.i_prev.alpha),
            0.5 * (i_ab.beta + self.i_prev.beta),
        )
        .to_dq(self.frame);
        self.i_prev = i_ab;
        self.e_sum = Dq::new(self.e_sum.d + e.d, self.e_sum.q + e.q);
        self.i_sum = Dq::new(self.i_sum.d + i_mid.d, self.i_sum.q + i_mid.q);
        let iq = i_ab.to_dq(self.frame).q;
        self.iq_sum += iq;
        self.iq2_sum += iq * iq;
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
        let n_steps = self.n.max(1) as f32;
        let k = 1.0 / n_steps;
        let e = Dq::new(self.e_sum.d * k, self.e_sum.q * k);
        let i = Dq::new(self.i_sum.d * k, self.i_sum.q * k);
        // The i_q samples' variance about their mean in this millisecond (the sensing noise).
        let iq_mean = self.iq_sum * k;
        let iq_var = crate::math::max(self.iq2_sum * k - iq_mean * iq_mean, 0.0);
        self.e_sum = Dq::default();
        self.i_sum = Dq::default();
        self.iq_sum = 0.0;
        self.iq2_sum = 0.0;
        self.n = 0;
        // The PLL: δ = θ_frame − θ_e, the frame at the periods' middles (where the EMF is), half
        // a period on from the frame the EMF was taken in.
        let delta = crate::math::atan2(e.d, e.q) + 0.5 * self.omega_e * s.ts;
        self.lost_ms = if delta.abs() > 0.6 {
            self.lost_ms + 1
        } else {
            0
        };
        if self.lost_ms > 20 || !delta.is_finite() {
            return Progress::Fail(IdentifyError::LostRotor);
        }
        // The rotor's speed over the millisecond's boundary, without the PLL's lag: the frame's
        // turn less the change of the angle error; the torque current: the current along the
        // back-EMF (the rotor's q axis).
        let omega_frame = self.omega_e;
        let e_mag = crate::math::sqrt_or_zero(e.d * e.d + e.q * e.q);
        let iq_rotor = if e_mag > 0.0 {
            (i.d * e.d + i.q * e.q) / e_mag
        } else {
            i.q
        };
        let pll = &s.tracking;
        self.omega_i_e -= pll.ki_t * delta;
        self.omega_e = self.omega_i_e - pll.kp * delta;
        self.step_rot = super::rotation(self.omega_e * s.ts);
        self.out_rot = foc.output_rotation(self.omega_e / s.n);
        self.frame = self.frame.renormalized();
        let dt = 1e-3;
        let Some((delta_last, omega_last)) = self.last.replace((delta, omega_frame)) else {
            return Progress::Stay;
        };
        let y = (0.5 * (omega_last + omega_frame) - (delta - delta_last) / dt) / s.n;
        // The same low-pass on the speed, the impulse and the angle (module doc), from the
        // first speed on.
        let raw = [self.q_as, self.w_rad, y];
        if self.filtered_ms == 0 {
            // From the PLL's speed (the first difference of the angle error is the spin's).
            let start = [self.q_as, self.w_rad, self.omega_i_e / s.n];
            self.filtered = [start; 2];
        }
        self.filtered_ms += 1;
        let g = pll.filter_gain;
        let [first, second] = &mut self.filtered;
        for ((x1, x2), u) in first.iter_mut().zip(second.iter_mut()).zip(raw) {
            *x1 += g * (u - *x1);
            *x2 += g * (*x1 - *x2);
        }
        let [qf, wf, yf] = self.filtered[1];
        // The segment: the point at this millisecond's start, then its impulse and angle.
        if self.ms == 0 {
            self.start = (qf, wf, yf);
        }
        self.ms += 1;
        let (q0, w0, y0) = self.start;
        if self.filtered_ms as f32 > pll.min_points {
            // Past the filters' start (at least five of their time constants).
            self.seg.add(qf - q0, wf - w0, yf - y0);
        }
        self.q_as += iq_rotor * dt;
        self.w_rad += y * dt;
        let y = yf;
        if self.ms > 2 {
            // The impulse's noise: n samples of variance σ² over the millisecond (not in the
            // first two, where the current still steps).
            self.seg_var += iq_var * n_steps * s.ts * s.ts;
        }
        let w = self.omega_i_e / s.n;
        // Braking ends at the low speed only after the shortest segment: the current's
        // reversal kicks the PLL's speed down (the EMF's transient) for a few of its time
        // constants, and after a long acceleration that barely left the low speed the kick
        // alone would reach it.
        let reached = if self.up {
            w >= s.omega_high_m
        } else {
            self.ms as f32 >= pll.min_points && w <= s.omega_low_m
        };
        // A lag twice the PLL's design (`δ_acc`) for LAG_MS: the torque accelerates the
        // rotor faster than the shortest segment allows; the segment ends as too short.
        self.lag_ms = if delta.abs() > 2.0 * LAG_ACC {
            self.lag_ms + 1
        } else {
            0
        };
        let lagging = self.lag_ms >= LAG_MS;
        let beyond = lagging || w < 0.5 * s.omega_low_m;
        if !(reached || beyond || self.ms >= SEGMENT_MS) {
            return Progress::Stay;
        }
        let seg = self.seg;
        let seg_var = self.seg_var;
        self.seg = Segment::default();
        self.seg_var = 0.0;
        let too_short = (self.ms as f32) < pll.min_points || lagging;
        self.ms = 0;
        let span = (y - y0).abs();
        let dq = (self.q_as - q0).abs();
        let small = span < (s.omega_high_m - s.omega_low_m) / 3.0;
        self.attempts += 1;
        if self.attempts > ATTEMPTS + 2 * PAIRS {
            return Progress::Fail(IdentifyError::InertiaOutOfRange);
        }
        if self.up {
            if too_short {
                // Over too soon: brake with half the torque, then a new pair.
                self.i_t *= 0.5;
                self.up_seg = None;
                self.up = false;
            } else if small && 2.0 * self.i_t <= s.i_test_a && self.pairs == 0 {
                // Too little motion: accelerate on with twice the torque.
                self.i_t *= 2.0;
            } else {
                self.up_seg = Some((seg, seg_var, dq));
                self.up_long = !reached;
                self.up = false;
            }
            return Progress::Stay;
        }
        // Braked: a new pair, or the result.
        self.up = true;
        let Some((up_seg, up_var, up_dq)) = self.up_seg.take() else {
            return Progress::Stay;
        };
        if too_short {
            // Braked too soon. After a long acceleration (the whole segment: friction is a
            // large part of the torque and adds to the braking) a new pair with half the
            // braking current, the same accelerating one; else with half of both.
            if self.up_long {
                self.brake *= 0.5;
            } else {
                self.i_t *= 0.5;
            }
            return Progress::Stay;
        }
        // A pair: both segments into the least squares.
        let mut pair = Normal::default();
        pair.add(&up_seg);
        pair.add(&seg);
        let inflation = pair.inflation();
        if inflation.is_nan() || inflation > INFLATION_MAX {
            // The pair does not tell inertia from friction: the speed hardly changed in one
            // of its segments. After a long acceleration, more torque (a larger part of it
            // accelerates) or, at the test current, a longer braking; else less of both.
            if self.up_long && 2.0 * self.i_t <= s.i_test_a {
                self.i_t *= 2.0;
            } else if self.up_long {
                self.brake *= 0.5;
            } else {
                self.i_t *= 0.5;
            }
            return Progress::Stay;
        }
        self.normal.add(&up_seg);
        self.normal.add(&seg);
        self.impulse += up_dq + dq;
        self.impulse_var += up_var + seg_var;
        self.pairs += 1;
        let (a, b) = self.normal.solve();
        let kt = s.torque_factor * s.n * result.flux_wb;
        let j_kgm2 = kt / a;
        let b_nms = b * j_kgm2;
        // The impulse's noise as a share of the impulse that moved the speed.
        let share2 = self.impulse_var * self.normal.inflation()
            / crate::math::max(self.impulse * self.impulse, 1e-30);
        if share2 > NOISE_SHARE * NOISE_SHARE && self.pairs < PAIRS {
            return Progress::Stay;
        }
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
