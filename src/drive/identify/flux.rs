//! Flux linkage from the back-EMF of an open-loop (I/f) spin.
//!
//! Method: the back-EMF of a rotor turning at a known electrical speed (TI InstaSPIN's and
//! ST's profiler's flux/`K_e` step; the I/f start of [`super::super::open_loop`]): a current of
//! fixed magnitude along the d axis of a frame whose speed ramps (rated speed per second, the
//! drive's start-up ramp) to 15 % of rated speed, the rotor following it; the current is then
//! lowered to 30 % of rated (a turning rotor without load needs little; less on a salient motor,
//! below); the back-EMF is measured there and again at 30 % of rated speed, each after 200 ms
//! of settling. The ramp to
//! the second speed runs at the test current again (raised over 50 ms before it, lowered over
//! 50 ms after it, the settling shortened by both: the same total time): at 30 % of it the
//! 10-pole-pair EMRAX 228 (J 0.025 kg·m², 7 mΩ) swung about the frame undamped during the
//! ramp and slipped a pole in half the seeds (`spin_not_followed`, seeds 2, 4, 6, 8 of 1–8).
//!
//! The voltage in the EMF is the one the inverter applied: the command corrected for the
//! dead-time compensation's lag ([`super::inverter::dead_time_applied`]). What remains of the dead time's
//! error near each current zero crossing is not a function of the sampled currents (a phase
//! current held near zero by the dead time, "zero-current clamping", takes whatever error
//! keeps it there): it remains as a bias on |e| that grows faster than the dead time
//! (measured on the 310 V Delta servo without noise: +1.7 % at 0.5 µs, +5.5 % at 1 µs, −0.04 %
//! without dead time). The
//! back-EMF of every period is
//!
//! ```text
//! e_αβ = v_αβ − R (i_k + i_{k−1})/2 − L (i_k − i_{k−1})/T        (Horng & Chin (16), (17))
//! ```
//!
//! with `R`, `L` measured before; its magnitude is `N ω_m ψ_f`. On a salient motor (`L_d`,
//! `L_q` measured apart, [`Identified::salient`]) `L` is `L_q` and `e` the extended EMF
//! `N ω_m (ψ_f + (L_d − L_q) i_d)` along the rotor's q axis (Z. Chen, M. Tomita, S. Doki,
//! S. Okuma, "An extended electromotive force model for sensorless control of interior
//! permanent-magnet synchronous motors", IEEE Trans. Ind. Electron. 50(2), 2003; at constant
//! current in the rotor frame), `i_d` the current along the EMF turned back by 90°: the
//! saliency's share is taken off before ψ_f.
//!
//! The holding current of a salient motor: with no load the rotor's d axis settles on the
//! current, whose torque at a lag `λ` is `c N I sin λ (ψ_f − (L_q − L_d) I cos λ)`; its
//! stiffness there, `c N I (ψ_f − (L_q − L_d) I)`, is largest at `I = ψ_f / (2 (L_q − L_d))`,
//! where the extended EMF is half the magnet's. Beyond it the saliency's flux takes more of
//! the EMF and the rotor holds less firmly in the frame: on the Brusa traction motor (L_q/L_d
//! 3.24) 30 % of its rated current is nine tenths of the magnet's flux, the extended EMF a
//! tenth of the magnet's, buried in the sensing noise, and ψ_f came out 11–25 % low with the
//! board's 1 % noise. So the measurement at the spin speed holds that current wherever the
//! one at half of it shows the saliency's flux above half the magnet's (`ψ_f` from that
//! measurement, and at least half the holding current before, `stiffest_hold`): the Brusa's
//! ψ_f now +1.8 to +2.6 % on seeds 1–4, its J +0.9 to +1.8 %, from −11 to −25 %; the Zou
//! PMa-SynRM's holding current drops from 99 to 80 A, its ψ_f within 0.3 % on seeds 1–4 as
//! before within 0.8 %; elsewhere (the AMK, Aalto and Caruso IPMs, every non-salient motor) it
//! is the same, to the bit.
//!
//! Averaged per millisecond in the
//! frame (noise), then as a magnitude over 500 ms: the rotor turns on average at the frame's
//! speed however it swings about it, so `ψ_f = mean|e| / (N ω_m)` \[Wb]. A rotor that does not
//! turn shows no back-EMF: the same measurement first at half the spin speed, and an EMF
//! below a tenth of the applied voltage, or one that does not grow with the speed (less than
//! 1.6× at twice the speed: what remains of the voltage errors at standstill, the dead
//! time's mostly, does not), is a rotor that does not follow; a ψ_f outside
//! [`MotorParams::FLUX_WB`] is out of range.
//!
//! A blocked salient rotor shows an EMF too: the current `I` on the frame's d axis turning
//! at `ω_e` over a rotor at rest at `θ_r` links `L̄ i + ΔL e^{j2θ_r} ī` (`L̄`, `ΔL` the mean
//! and half difference of `L_d` and `L_q`, `ī` the conjugate), whose EMF in the frame, `L_q
//! di/dt` taken out, is `jω_e ΔL I (1 − e^{j2(θ_r − θ_f)})`: it grows with the speed as a
//! turning rotor's does (the start's watch below named the blocked AMK, Zou and Brusa
//! `spin_not_followed`; blocked Delta servos at `L_q/L_d = 2.3` and 4, held-out variants,
//! passed the checks above and ran on into the torque steps: `lost_rotor`,
//! `inertia_out_of_range`). Its trace,
//! `e − jω_e ΔL i` turned by `2θ_f`, is `−jω_e ΔL I e^{j2θ_r}`: it holds still, where a
//! turning rotor's (`e = jω_e(ψ_f e^{−jλ} + ΔL I (1 + e^{−j2λ}))`, `λ` its lag, steady in the
//! frame) turns at `2ω_e`. At half the spin speed the trace's mean against its mean length
//! ([`BLOCKED_TRACE`], on motors rated from 28 Hz electrical, [`TRACE_TURN_MIN`]) names a
//! blocked salient rotor ([`IdentifyError::BlockedRotor`]) where the spin's measurement is
//! evaluated.
//!
//! Which name: the start is watched. While the frame accelerates through `[1, 1.5)·w₁` and
//! `[2, 3)·w₁` (`w₁` = a quarter of the half spin speed, 3.75 % of rated speed), |e| and the
//! frame speed are summed per window; a rotor that turns with the frame has the same EMF per
//! speed in both (at least 0.8 of it) and an EMF of a tenth of the voltage. A rotor that
//! followed the start and not the measuring speed lags or slips
//! ([`IdentifyError::SpinNotFollowed`]: an inertia or load the spin's acceleration does not
//! move, a motor too fast for the control rate); one that never showed an EMF growing with the
//! speed is blocked ([`IdentifyError::BlockedRotor`]).
//!
//! The ramp watches the rotor follow (the frame's acceleration is fixed, rated speed per
//! second, whatever the inertia): while the EMF is a tenth of the voltage or more and lags the
//! frame's q axis by more than 0.6 rad (the rotor that far behind the current: its torque
//! `c N ψ_f I sin λ` short of what the acceleration needs), the frame holds its speed that
//! millisecond. A rotor of any inertia the current can move reaches the measuring speed (the
//! 10-pole-pair EMRAX 228, J 0.025 kg·m², lost it without; a hub motor at 10× its J follows),
//! at the acceleration it can take; the I/f start that adapts to the rotor's lag is the idea
//! of closed-loop I/f starting, e.g. M. Fatu, R. Teodorescu, I. Boldea, G.-D. Andreescu,
//! F. Blaabjerg, "I-F starting method with smooth transition to EMF based motion-sensorless
//! vector control of PM synchronous motor/generator", IEEE PESC 2008.

use super::inverter::dead_time_applied;
use super::mechanics::Mechanics;
use super::{back_emf, Identified, IdentifyError, Phase, Progress, Settings};
use crate::dead_time::DeadTime;
use crate::foc::{Foc, Reference, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::motor::MotorParams;

/// The current while measuring, a fraction of the rated current.
const HOLD: f32 = 0.3;
/// Time to lower the current, to settle, to measure \[ms].
const LOWER_MS: u32 = 100;
const SETTLE_MS: u32 = 200;
/// Time to raise the current before the second ramp, and to lower it after \[ms].
const SHIFT_MS: u32 = 50;
const MEASURE_MS: u32 = 500;
/// The largest lag of the rotor behind the frame the ramp accelerates on \[rad].
const LAG_MAX: f32 = 0.6;

/// The share of its mean length that the mean of a blocked salient rotor's trace keeps (module
/// doc), at least. A turning rotor's trace turns by `τ` a millisecond (`2θ_f`'s turn at half
/// the spin speed), and the mean of its 500 milliseconds is at most `1/(500 sin(τ/2))` of
/// its length: half this share or less where `τ` ≥ [`TRACE_TURN_MIN`] (measured: at most
/// 0.017, the Aalto IPM's). A blocked one's measured 0.20 (the Aalto's, `L_q/L_d = 1.42`,
/// its trace small against the noise) to 0.69 (the Brusa's); the zoo's and held-out salient
/// variants' on three seeds.
const BLOCKED_TRACE: f32 = 0.15;

/// The least turn of the trace a millisecond \[rad] for [`BLOCKED_TRACE`] to tell (`sin(τ/2)
/// ≥ 1/(500 · 0.075)`): a rated electrical frequency of 28 Hz and more (15 % of it at half the
/// spin speed, turned twice). Below it the start's watch names the rotor as before. Not
/// bounded above: past π a millisecond (a rated 1 667 Hz) a millisecond's mean shrinks a
/// blocked rotor's trace below `2/π` of it, which then may go unseen, and a turn near 2π (a
/// rated 3 333 Hz, six samples a period at the board's 20 kHz) would alias a turning rotor's
/// trace to a still one.
const TRACE_TURN_MIN: f32 = 0.054;

/// The start's watch: the first window's lowest frame speed, a fraction of the half spin
/// speed (module doc).
const WATCH_FROM: f32 = 0.25;

/// Σ|e|, Σω_m and Σ|v| over a window of the start's frame speeds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Window {
    e: f32,
    w: f32,
    v: f32,
}

impl Window {
    fn add(&mut self, e: f32, w: f32, v: f32) {
        self.e += e;
        self.w += w;
        self.v += v;
    }
}

/// Where the spin is (milliseconds left).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stage {
    /// The frame accelerates to the spin speed.
    Ramp,
    /// The current lowered to the holding current.
    Lower(u32),
    /// The current raised back to the test current before the second ramp.
    Raise(u32),
    /// Settling.
    Settle(u32),
    /// The back-EMF averaged.
    Measure(u32),
}

/// The state of the flux measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::drive) struct FluxSpin {
    stage: Stage,
    /// sin/cos of the frame's angle, turned by `step_rot` every step.
    frame: SinCos,
    step_rot: SinCos,
    /// The output angle's lead over the frame.
    out_rot: SinCos,
    /// The frame's speed [rad/s, mechanical].
    omega_m: f32,
    /// The current's magnitude \[A].
    i_ref: f32,
    /// The holding current while measuring \[A] (module doc).
    hold_a: f32,
    i_prev: AlphaBeta,
    /// Back-EMF and voltage in the frame, summed since the last tick \[V].
    e_sum: Dq,
    v_sum: Dq,
    /// The current in the frame, summed since the last tick \[A] (of a salient motor).
    i_sum: Dq,
    n: u32,
    /// Σ|e| and Σ|v| over the measurement's milliseconds \[V].
    e_mag_sum: f32,
    /// At half the spin speed, a blocked salient rotor's trace (module doc): Σ of the EMF
    /// less `jω_e ΔL i` turned by twice the frame's angle, and Σ of its length \[V].
    blocked_sum: AlphaBeta,
    blocked_abs: f32,
    /// The mean |e| at half the spin speed, once measured \[V].
    e_half: Option<f32>,
    v_mag_sum: f32,
    count: u32,
    /// The last millisecond's back-EMF in the frame \[V].
    e_last: Dq,
    /// The start watched: |e| at frame speeds `[1, 1.5)·w₁` and `[2, 3)·w₁`.
    watch: [Window; 2],
    /// R \[Ω] and L/T \[Ω] (of a salient motor `L_q/T`).
    r_ohm: f32,
    l_over_t: f32,
    /// `L_d − L_q` of a salient motor (module doc), else 0 \[H].
    l_d_minus_q_h: f32,
}

impl FluxSpin {
    /// At rest on the α axis (the rotor aligned there by the previous measurements).
    pub(in crate::drive) fn new(s: &Settings, m: &Identified) -> Self {
        Self {
            stage: Stage::Ramp,
            frame: SinCos::ZERO,
            step_rot: SinCos::ZERO,
            out_rot: SinCos::ZERO,
            omega_m: 0.0,
            i_ref: s.i_test_a,
            hold_a: HOLD * s.i_test_a,
            i_prev: AlphaBeta::default(),
            e_sum: Dq::default(),
            v_sum: Dq::default(),
            i_sum: Dq::default(),
            n: 0,
            e_mag_sum: 0.0,
            blocked_sum: AlphaBeta::default(),
            blocked_abs: 0.0,
            e_half: None,
            v_mag_sum: 0.0,
            count: 0,
            e_last: Dq::default(),
            watch: [Window::default(); 2],
            r_ohm: m.r_ohm,
            l_over_t: m.l_dq_h().1 / s.ts,
            l_d_minus_q_h: m.l_dq_h().0 - m.l_dq_h().1,
        }
    }

    /// One step: the back-EMF of the period that just ended (`v_ab` applied over it \[V],
    /// `i_ab` measured now \[A]) summed in the frame; the frame turned; the current requested.
    #[inline(always)]
    pub(in crate::drive) fn step(
        &mut self,
        i_ab: AlphaBeta,
        v_ab: AlphaBeta,
        dt: &DeadTime,
        v_bus: f32,
    ) -> Request {
        let v_ab = dead_time_applied(v_ab, i_ab, self.i_prev, dt, v_bus);
        let e = back_emf(v_ab, i_ab, self.i_prev, self.r_ohm, self.l_over_t).to_dq(self.frame);
        let v = v_ab.to_dq(self.frame);
        self.i_prev = i_ab;
        self.e_sum = Dq::new(self.e_sum.d + e.d, self.e_sum.q + e.q);
        self.v_sum = Dq::new(self.v_sum.d + v.d, self.v_sum.q + v.q);
        if self.l_d_minus_q_h != 0.0 {
            let i = i_ab.to_dq(self.frame);
            self.i_sum = Dq::new(self.i_sum.d + i.d, self.i_sum.q + i.q);
        }
        self.n += 1;
        self.frame = self.frame.rotated(self.step_rot);
        Request {
            frame: self.frame,
            frame_out: self.frame.rotated(self.out_rot),
            omega_m: self.omega_m,
            reference: Reference::Current(Dq::new(self.i_ref, 0.0)),
        }
    }

    /// The 1 kHz work: the ramp, the current, the measurement and the result. `foc` the
    /// identification's FOC (its output lead).
    pub(in crate::drive) fn tick(
        &mut self,
        s: &Settings,
        foc: &Foc,
        result: &mut Identified,
    ) -> Progress {
        let k = 1.0 / (self.n.max(1) as f32);
        let e = Dq::new(self.e_sum.d * k, self.e_sum.q * k);
        let v = Dq::new(self.v_sum.d * k, self.v_sum.q * k);
        let i = Dq::new(self.i_sum.d * k, self.i_sum.q * k);
        self.e_sum = Dq::default();
        self.v_sum = Dq::default();
        self.i_sum = Dq::default();
        self.n = 0;
        self.e_last = e;
        self.frame = self.frame.renormalized();
        let hold = self.hold_a;
        match self.stage {
            Stage::Ramp => {
                if self.e_half.is_none() {
                    // The start watched (the EMF of the frame speed of the last millisecond).
                    let w1 = WATCH_FROM * 0.5 * s.omega_low_m;
                    let w = self.omega_m;
                    let slot = if w >= w1 && w < 1.5 * w1 {
                        self.watch.get_mut(0)
                    } else if w >= 2.0 * w1 && w < 3.0 * w1 {
                        self.watch.get_mut(1)
                    } else {
                        None
                    };
                    if let Some(win) = slot {
                        win.add(super::magnitude(e), w, super::magnitude(v));
                    }
                }
                let target = if self.e_half.is_some() {
                    s.omega_low_m
                } else {
                    0.5 * s.omega_low_m
                };
                // The rotor watched: while its EMF lags the frame's q axis by more than
                // LAG_MAX (the rotor behind the current by that much), the frame holds its
                // speed and lets it catch up.
                let lagging = super::magnitude(e) >= 0.1 * super::magnitude(v)
                    && crate::math::atan2(e.d, e.q) > LAG_MAX;
                if !lagging {
                    self.omega_m = (self.omega_m + s.accel_per_ms).min(target);
                }
                self.step_rot = super::rotation(s.n_ts * self.omega_m);
                self.out_rot = foc.output_rotation(self.omega_m);
                if self.omega_m >= target {
                    self.stage = if self.e_half.is_some() {
                        Stage::Lower(SHIFT_MS)
                    } else {
                        Stage::Lower(LOWER_MS)
                    };
                }
            }
            Stage::Lower(ms) => {
                let (lower_ms, settle_ms) = if self.e_half.is_some() {
                    (SHIFT_MS, SETTLE_MS - 2 * SHIFT_MS)
                } else {
                    (LOWER_MS, SETTLE_MS)
                };
                let drop = (s.i_test_a - hold) / lower_ms as f32;
                self.i_ref = (self.i_ref - drop).max(hold);
                self.stage = if ms > 1 {
                    Stage::Lower(ms - 1)
                } else {
                    Stage::Settle(settle_ms)
                };
            }
            Stage::Raise(ms) => {
                // From the first measurement's holding current.
                let rise = (s.i_test_a - HOLD * s.i_test_a) / SHIFT_MS as f32;
                self.i_ref = (self.i_ref + rise).min(s.i_test_a);
                self.stage = if ms > 1 {
                    Stage::Raise(ms - 1)
                } else {
                    Stage::Ramp
                };
            }
            Stage::Settle(ms) => {
                self.stage = if ms > 1 {
                    Stage::Settle(ms - 1)
                } else {
                    Stage::Measure(MEASURE_MS)
                };
            }
            Stage::Measure(ms) => {
                self.e_mag_sum += self.magnet_emf(s, e, i);
                if self.e_half.is_none() {
                    self.trace_blocked(s, e, i);
                }
                self.v_mag_sum += super::magnitude(v);
                self.count += 1;
                if ms > 1 {
                    self.stage = Stage::Measure(ms - 1);
                } else if self.e_half.is_none() {
                    // Half speed measured: on to the spin speed.
                    let e_half = self.e_mag_sum / self.count as f32;
                    self.e_half = Some(e_half);
                    self.hold_a = self.stiffest_hold(e_half / (s.n * self.omega_m));
                    self.e_mag_sum = 0.0;
                    self.v_mag_sum = 0.0;
                    self.count = 0;
                    self.stage = Stage::Raise(SHIFT_MS);
                } else {
                    return self.evaluate(s, result);
                }
            }
        }
        Progress::Stay
    }

    /// The rotor followed the start: the EMF per frame speed of the second window at least
    /// 0.8 of the first's (a turning rotor's is the same; a residual voltage error's halves)
    /// and the EMF a tenth of the voltage, as at the measuring speeds.
    fn start_followed(&self) -> bool {
        let [a, b] = self.watch;
        // (Without the first window's samples its EMF per speed is NaN, and the test false.)
        b.e >= 0.8 * (a.e / a.w) * b.w && b.e >= 0.1 * b.v && b.w > 0.0
    }

    /// One millisecond of the trace of a blocked salient rotor (module doc): `e − jω_e ΔL i`
    /// (`e`, `i` in the frame, `ΔL = (L_d − L_q)/2`) turned by `2θ_f`.
    fn trace_blocked(&mut self, s: &Settings, e: Dq, i: Dq) {
        let w_dl = 0.5 * s.n * self.omega_m * self.l_d_minus_q_h;
        let r = Dq::new(e.d + w_dl * i.q, e.q - w_dl * i.d);
        let turned = r.to_alpha_beta(self.frame.rotated(self.frame));
        self.blocked_sum.alpha += turned.alpha;
        self.blocked_sum.beta += turned.beta;
        self.blocked_abs += super::magnitude(r);
    }

    /// A salient rotor that did not turn at half the spin speed: the mean of its trace at
    /// least [`BLOCKED_TRACE`] of its mean length, where the trace can tell (a frame that
    /// turns it by [`TRACE_TURN_MIN`] a millisecond or more).
    fn blocked_salient(&self, s: &Settings) -> bool {
        // |Σ| with the out-of-line square root (`AlphaBeta::magnitude` inlined is 80 B more).
        let sum = self.blocked_sum;
        // 2θ_f's turn a millisecond at half the spin speed, `N ω_low · 1 ms` [rad].
        s.n * s.omega_low_m >= TRACE_TURN_MIN * 1e3
            && super::sqrt(sum.alpha * sum.alpha + sum.beta * sum.beta)
                >= BLOCKED_TRACE * self.blocked_abs
    }

    /// The magnet's share of the back-EMF `e` \[V] with the current `i` \[A] (both in the
    /// frame): `|e|` less the saliency's `ω_e (L_d − L_q) i_d` (module doc), `i_d` the
    /// current's projection on the rotor's d axis, which lags the EMF by 90°.
    fn magnet_emf(&self, s: &Settings, e: Dq, i: Dq) -> f32 {
        let mag = super::magnitude(e);
        let i_d = if mag > 0.0 {
            (i.d * e.q - i.q * e.d) / mag
        } else {
            0.0
        };
        mag - s.n * self.omega_m * self.l_d_minus_q_h * i_d
    }

    /// The holding current for the spin speed's measurement \[A], from the magnet's flux
    /// `psi_wb` measured at half of it: the one now, unless the saliency's flux
    /// `(L_q − L_d) I` is more than half the magnet's, past the holding current that keeps the
    /// rotor stiffest in the frame, `ψ_f / (2 (L_q − L_d))` (module doc), which it then takes,
    /// but not below half the one now: a rotor that does not turn shows little EMF at half
    /// the speed, and the check of the EMF's growth with the speed ([`FluxSpin::evaluate`])
    /// must not compare it with one measured at a far smaller current (a blocked AMK and Zou
    /// passed it at a tenth and a third of it, and their torque steps ran on).
    fn stiffest_hold(&self, psi_wb: f32) -> f32 {
        match crate::motor::stiffest_holding_current_a(psi_wb, self.l_d_minus_q_h) {
            Some(stiffest) if psi_wb > 0.0 && stiffest < self.hold_a => {
                crate::math::max(stiffest, 0.5 * self.hold_a)
            }
            _ => self.hold_a,
        }
    }

    /// ψ_f from the mean back-EMF; the torque steps start in the frame of the rotor.
    fn evaluate(&self, s: &Settings, result: &mut Identified) -> Progress {
        let (e_mean, v_mean) = (self.e_mag_sum, self.v_mag_sum);
        let e_half = self.e_half.unwrap_or(0.0) * self.count as f32;
        // A turning rotor's EMF doubles with the speed; what remains of the voltage errors at
        // standstill (the dead time's, mostly) does not. A blocked salient rotor's doubles
        // too: its trace tells it (module doc).
        let blocked_salient = self.blocked_salient(s);
        if !(e_mean >= 0.1 * v_mean && e_mean >= 1.6 * e_half) || blocked_salient {
            return Progress::Fail(if self.start_followed() && !blocked_salient {
                IdentifyError::SpinNotFollowed
            } else {
                IdentifyError::BlockedRotor
            });
        }
        let flux_wb = e_mean / (self.count as f32 * s.n * self.omega_m);
        if MotorParams::FLUX_WB.check("flux_wb", flux_wb).is_err() {
            return Progress::Fail(IdentifyError::FluxOutOfRange);
        }
        result.flux_wb = flux_wb;
        // The back-EMF lies on the rotor's q axis: the frame turned back by its angle in the
        // frame, δ = atan2(e_d, e_q), is the rotor's (Park of e = ω_e ψ_f (−sin θ_e, cos θ_e)).
        let inv = crate::math::rsqrt(self.e_last.d * self.e_last.d + self.e_last.q * self.e_last.q);
        let back = SinCos {
            sin: -self.e_last.d * inv,
            cos: self.e_last.q * inv,
        };
        let rotor = if inv.is_finite() {
            self.frame.rotated(back)
        } else {
            self.frame
        };
        Progress::Next(Phase::Mechanics(Mechanics::new(
            s,
            result,
            rotor,
            self.omega_m,
            self.i_prev,
        )))
    }
}
