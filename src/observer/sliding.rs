//! Horng & Chin's sliding observers: the velocity observer, eqs (20)-(23), and the torque
//! observer, eqs (20)-(22), (34), (35), with the boundary layer `sat(S, ε)` of Sec 4 in place
//! of `sgn(S)` and the low-speed substitution `ω̂_low` of Sec 5.
//!
//! States (θ, ω mechanical as in the paper; the angle is kept electrical, `θ̂_e = N θ̂`):
//! ```text
//! dî_a/dt = −R/L î_a + (KN/L) ω̂ sin θ̂_e + v_a/L − w_a                      (20)
//! dî_b/dt = −R/L î_b − (KN/L) ω̂ cos θ̂_e + v_b/L − w_b                      (21)
//! dθ̂_e/dt = N ω̂                                                           (22)
//! dω̂/dt  = −(KN/H)(î_a sin θ̂_e − î_b cos θ̂_e) − B/H ω̂ − τ̂_L/H + G1 w_a + G2 w_b   (35)
//! dτ̂_L/dt = G3 w_a + G4 w_b                                                (34)
//! w = K_s sat(S/ε),  S = î − i
//! ```
//! The velocity observer is the torque observer with λτ = 0 (Sec 4): `τ̂_L` stays 0 and the
//! gains reduce to those after eq (32).
//!
//! Salient motors (`L_d ≠ L_q`): the observer runs the same equations on the motor's
//! *active flux* model (Boldea, Paicu, Andreescu, "Active flux concept for motion-sensorless
//! unified AC drives", IEEE Trans. Power Electron. 23(5), 2008): the stator flux is
//! `L_q i + ψ_a e^{jθ_e}` with `ψ_a = ψ_f + (L_d − L_q) i_d` along the rotor's d axis, so
//! (20)-(21) hold with `L = L_q` and `K = ψ_a` (the term `dψ_a/dt`, the extended EMF's
//! `(L_d − L_q) di_d/dt` of Chen, Tomita, Doki, Okuma, IEEE TIE 50(2), 2003, left out as it
//! is there in the steady state). `ψ_a` is taken each period at the estimate's own `î_d`:
//! without it the back-EMF's length `N ω ψ_a` is read as speed over `ψ_f`, and MTPA's
//! negative `i_d` on an IPM biases `ω̂` high by `(L_d − L_q) i_d/ψ_f` (measured: the Aalto
//! IPM's speed 7 % low at 1000 rpm, `host-sim/matrices/zoo-salient.toml`). The gains are the
//! paper's with `L = L_q`, `ψ_a` taken as constant over the observer's time constants; the
//! `K_s` window the drive chooses `K_s` in (`crate::bounds`, `drive/config_observers.rs`) is
//! computed with `L_q` too (with the mean `L` before: the same 160 cells of
//! `host-sim/matrices/zoo-salient.toml` passed either way); the mechanical equation (35) keeps `K = ψ_f` (the reluctance torque is a
//! load to it, which τ̂_L takes up). With `L_d = L_q`, `ψ_a = ψ_f` exactly: the paper's
//! equations to the bit.
//!
//! Discretisation: forward Euler at the control rate, i.e. the delta operator of Sec 4, so the
//! paper's discrete-time bound `(K_s,max)_T` applies to this code as it is. One change: the
//! back-EMF term of (20)-(21) is evaluated at the angle in the middle of the period,
//! `θ̂_e + ½ N ω̂ T`, because the applied voltage is the average over the period (the inverse
//! Park of the controller uses the same advance). Evaluated at the start of the period, the
//! observer carries a steady angle bias of about half a sample of rotation
//! (`½ N ω T` = 3.0° electrical at 1000 rpm and 4 kHz on the Sinano motor).

use crate::frames::{AlphaBeta, SinCos};
use crate::math::{all_finite, clamp, finite_sum, sin_cos_wrapped, wrap_pi};
use crate::motor::MotorParams;
use crate::observer::{Observer, Rotor};
use crate::param::{Allowed, Checks, ParamError};
use core::f32::consts::TAU;
use core::hint::cold_path;

/// How the sliding gain `K_s` \[A/s] is chosen each step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SlidingGain {
    /// A fixed `K_s` \[A/s]. The paper's experiment uses 1000π.
    Constant(f32),
    /// `K_s = per_rad_s · |ω̂|`, not below `min` (Sec 5: `K_s = 30·ω`).
    PerSpeed {
        /// Slope [A/s per rad/s].
        per_rad_s: f32,
        /// Floor \[A/s], > 0.
        min: f32,
    },
}

/// Settings of a sliding observer (SI units, eigenvalues in Hz as the paper quotes them).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlidingConfig {
    /// Motor model (K = `flux_wb`, H = `j_kgm2`); a three-phase motor's is turned into the
    /// paper's (`MotorParams::papers_model`: H and B over 3/2) and τ̂_L back.
    pub motor: MotorParams,
    /// Update rate \[Hz] (4 kHz in the paper).
    pub rate_hz: f32,
    /// λθ \[Hz], > 0 (paper: 10). Multiplied by 2π internally (see DESIGN notes).
    pub lambda_theta_hz: f32,
    /// λω \[Hz], > 0 (paper: 60).
    pub lambda_omega_hz: f32,
    /// λτ \[Hz]: 0 for the velocity observer, > 0 for the torque observer (paper: 2).
    pub lambda_tau_hz: f32,
    /// Boundary-layer width ε of `sat(S, ε)` \[A], > 0 (paper: 1).
    pub epsilon_a: f32,
    /// Sliding gain K_s.
    pub ks: SlidingGain,
    /// `|ω̂|` below this is replaced by it in the gains \[rad/s], > 0 (paper: 1).
    pub omega_low_rad_s: f32,
    /// The back-EMF angle is advanced by this many periods of rotation (0.5: middle of the
    /// period, matching a voltage held over the period; 0: the plain start-of-period Euler).
    pub emf_advance_periods: f32,
    /// A controller applies its voltage at `θ̂_e + a N ω̂ T` with `a` this (the middle of the
    /// period the voltage is applied over, which a computation and PWM delay moves later:
    /// `crate::drive::PowerStageConfig::update_delay_s`); equal to `emf_advance_periods`
    /// (0.5, no delay) the observer hands out its EMF angle ([`SlidingState::sc_mid`]), else
    /// the frame turned by the controller's lead.
    pub output_advance_periods: f32,
    /// A drive lets this observer drive only above this |ω̂| \[rad/s] (0: at any speed;
    /// infinite: never, for a motor whose K_s window is empty). Not the paper's: it is
    /// unobservable at ω = 0 (Sec 3, the gains divide by ω̂).
    pub min_speed_rad_s: f32,
}

impl SlidingConfig {
    /// The paper's velocity observer (Sec 5): λθ = 10 Hz, λω = 60 Hz, ε = 1 A, K_s = 1000π.
    pub fn velocity(motor: MotorParams) -> Self {
        Self {
            motor,
            rate_hz: 4000.0,
            lambda_theta_hz: 10.0,
            lambda_omega_hz: 60.0,
            lambda_tau_hz: 0.0,
            epsilon_a: 1.0,
            ks: SlidingGain::Constant(1000.0 * core::f32::consts::PI),
            omega_low_rad_s: 1.0,
            emf_advance_periods: 0.5,
            output_advance_periods: 0.5,
            min_speed_rad_s: 0.0,
        }
    }

    /// The paper's torque observer: the velocity observer's settings plus λτ = 2 Hz.
    pub fn torque(motor: MotorParams) -> Self {
        Self {
            lambda_tau_hz: 2.0,
            ..Self::velocity(motor)
        }
    }

    /// Validates and precomputes the per-step coefficients.
    pub fn build(&self) -> Result<SlidingObserver, ParamError> {
        let motor = self.motor.validate()?;
        // The paper's model, τ = K N i_q: the equations below as printed; τ̂_L times `c`.
        // On the active flux model (module doc): `L = L_q`, `K = ψ_f` and the term in `i_d`.
        let papers = motor.papers_model();
        let m = MotorParams {
            l_h: papers.l_q_h(),
            saliency: 1.0,
            ..papers
        };
        let mut c = Checks::new();
        c.check("rate_hz", self.rate_hz, Allowed::POSITIVE);
        c.check("lambda_theta_hz", self.lambda_theta_hz, Allowed::POSITIVE);
        c.check("lambda_omega_hz", self.lambda_omega_hz, Allowed::POSITIVE);
        c.check("lambda_tau_hz", self.lambda_tau_hz, Allowed::NON_NEGATIVE);
        c.check("epsilon_a", self.epsilon_a, Allowed::POSITIVE);
        match self.ks {
            SlidingGain::Constant(k) => c.check("ks", k, Allowed::POSITIVE),
            SlidingGain::PerSpeed { per_rad_s, min } => {
                c.check("ks.per_rad_s", per_rad_s, Allowed::NON_NEGATIVE);
                c.check("ks.min", min, Allowed::POSITIVE);
            }
        }
        c.check("omega_low_rad_s", self.omega_low_rad_s, Allowed::POSITIVE);
        if self.min_speed_rad_s != f32::INFINITY {
            c.check(
                "min_speed_rad_s",
                self.min_speed_rad_s,
                Allowed::NON_NEGATIVE,
            );
        }
        c.check(
            "emf_advance_periods",
            self.emf_advance_periods,
            Allowed::FINITE,
        );
        c.done()?;
        let ts = 1.0 / self.rate_hz;
        let (l_th, l_om) = (TAU * self.lambda_theta_hz, TAU * self.lambda_omega_hz);
        let l_ta = TAU * self.lambda_tau_hz;
        let (epsilon, ks, omega_low) = (self.epsilon_a, self.ks, self.omega_low_rad_s);
        let n = m.n();
        let kn = m.flux_wb * n;
        let factors = GainFactors {
            k1: l_th + l_om + l_ta,
            k2: l_th * l_om + l_om * l_ta + l_ta * l_th,
            k3: l_th * l_om * l_ta,
            b_over_h: m.b_nms / m.j_kgm2,
            l_over_h: m.l_h / m.j_kgm2,
            l_over_kn2: m.l_h / (kn * n),
            h: m.j_kgm2,
        };
        Ok(SlidingObserver {
            ts,
            n,
            euler: EulerStep::new(ts, &m, papers.l_d_minus_l_q_h(), &factors),
            factors,
            inv_epsilon: 1.0 / epsilon,
            ks,
            omega_low,
            min_speed: self.min_speed_rad_s,
            emf_residual_scale: m.l_h / (kn * 2.0 * libm::sinf(core::f32::consts::PI / 8.0)),
            emf_advance_s: self.emf_advance_periods * ts * n,
            output_at_emf: self.output_advance_periods == self.emf_advance_periods,
            torque_factor: motor.torque.factor(),
        })
    }
}

/// A built sliding observer: per-step coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlidingObserver {
    ts: f32,
    n: f32,
    /// The gains' factors, the paper's form ([`SlidingObserver::gains`]).
    factors: GainFactors,
    /// The same multiplied out with `T` for the Euler step.
    euler: EulerStep,
    inv_epsilon: f32,
    ks: SlidingGain,
    omega_low: f32,
    /// See [`SlidingConfig::min_speed_rad_s`].
    min_speed: f32,
    /// The motor's `c` in `τ = c K N i_q`: the paper's τ̂_L (in `SlidingState`) times it is
    /// the motor's load torque \[N·m].
    torque_factor: f32,
    /// `L/(K N · 2 sin(22.5°))` \[s/A·rad/s]: turns `|w|/|ω̂|` into the residual (see
    /// `Observer::residual`).
    emf_residual_scale: f32,
    /// a·T·N \[s]: the EMF angle leads θ̂_e by this times ω̂ \[rad].
    emf_advance_s: f32,
    /// The controller's output angle is the EMF angle (`SlidingConfig::output_advance_periods`).
    output_at_emf: bool,
}

/// The speed-free factors of the observer gains G1..G4 (Horng & Chin Secs 3.1, 3.2), from
/// which both [`SlidingObserver::gains`] and the Euler step's coefficients are formed.
#[derive(Clone, Copy, Debug, PartialEq)]
struct GainFactors {
    /// K1 = λθ + λω + λτ \[rad/s].
    k1: f32,
    /// K2 = λθλω + λωλτ + λτλθ \[rad²/s²].
    k2: f32,
    /// K3 = λθλωλτ \[rad³/s³] (0 for the velocity observer).
    k3: f32,
    /// B/H \[1/s].
    b_over_h: f32,
    /// L/H.
    l_over_h: f32,
    /// L/(K N²).
    l_over_kn2: f32,
    /// H \[kg·m²].
    h: f32,
}

impl GainFactors {
    /// H·L·K3/(K N²): G3, G4 are this over ω̂ times (sin ± cos).
    fn g34(&self) -> f32 {
        self.h * self.l_over_kn2 * self.k3
    }
}

/// The coefficients of one forward-Euler period of eqs (20)-(22), (34), (35), the period
/// `T` folded in (see [`SlidingObserver::propagate`]).
#[derive(Clone, Copy, Debug, PartialEq)]
struct EulerStep {
    /// 1 − T R/L.
    a_i: f32,
    /// T K N/L \[A/(rad/s)].
    t_kn_over_l: f32,
    /// `T K N/L · (L_d − L_q)/K` \[A/(rad/s) per A]: the active flux's `(L_d − L_q) i_d` in
    /// the EMF of (20)-(21) per ampere of `î_d` (module doc); 0 for a non-salient motor.
    t_kn_over_l_per_a: f32,
    /// T/L \[A/V].
    t_inv_l: f32,
    /// T N \[s]: θ̂_e advance per rad/s of ω̂.
    tn: f32,
    /// 1 − T B/H.
    a_omega: f32,
    /// T K N/H \[rad/(s·A)].
    t_kn_over_h: f32,
    /// T/H \[rad/(s·N·m)].
    t_inv_h: f32,
    /// T L/H.
    t_l_over_h: f32,
    /// T L K2/(K N²).
    t_lk2: f32,
    /// T L K3/(K N³).
    t_lk3: f32,
    /// T N·L(B/H − K1)/(K N²): the `N ω̂ y` term of G1, G2 (ω̂ cancels).
    t_cy: f32,
    /// T H L K3/(K N²).
    t_g34: f32,
}

impl EulerStep {
    /// The plant terms of eqs (20)-(22), (35) times `T`, and the gain factors `f` times `T`.
    /// `m` is the active flux model (`L = L_q`), `l_d_minus_l_q_h` the motor's `L_d − L_q`.
    fn new(ts: f32, m: &MotorParams, l_d_minus_l_q_h: f32, f: &GainFactors) -> Self {
        let n = m.n();
        let kn = m.flux_wb * n;
        Self {
            a_i: 1.0 - ts * m.r_ohm / m.l_h,
            t_kn_over_l: ts * kn / m.l_h,
            t_kn_over_l_per_a: ts * n * l_d_minus_l_q_h / m.l_h,
            t_inv_l: ts / m.l_h,
            tn: ts * n,
            a_omega: 1.0 - ts * f.b_over_h,
            t_kn_over_h: ts * kn / m.j_kgm2,
            t_inv_h: ts / m.j_kgm2,
            t_l_over_h: ts * f.l_over_h,
            t_lk2: ts * f.l_over_kn2 * f.k2,
            t_lk3: ts * f.l_over_kn2 * f.k3 / n,
            t_cy: ts * n * f.l_over_kn2 * (f.b_over_h - f.k1),
            t_g34: ts * f.g34(),
        }
    }
}

/// Running state of a sliding observer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlidingState {
    /// Current estimate î at the last sample \[A].
    pub i_hat: AlphaBeta,
    /// Electrical angle estimate θ̂_e = N θ̂, in (−π, π] \[rad].
    pub theta_e: f32,
    /// Mechanical speed estimate ω̂ \[rad/s].
    pub omega_m: f32,
    /// Load torque estimate τ̂_L of the paper's model \[N·m] (0 for the velocity observer):
    /// the motor's divided by its torque factor `c` (`MotorParams::papers_model`).
    pub load_nm: f32,
    /// Innovation `w = K_s sat(S/ε)` of the last sample \[A/s].
    pub w: AlphaBeta,
    /// Sliding variable `S = î − i` of the last sample \[A].
    pub s: AlphaBeta,
    /// `sin θ̂_e`, `cos θ̂_e` of the last sample (reused by the next propagation).
    pub sc: SinCos,
    /// sin/cos of the back-EMF angle of the coming period, `θ̂_e + a N ω̂ T` with
    /// `a` = [`SlidingConfig::emf_advance_periods`] (the middle of the period for a = ½): the
    /// next propagation's EMF angle, also the angle a controller applies its voltage at.
    pub sc_mid: SinCos,
    /// False until the first sample has been taken.
    pub started: bool,
}

impl Default for SlidingState {
    fn default() -> Self {
        Self {
            i_hat: AlphaBeta::default(),
            theta_e: 0.0,
            omega_m: 0.0,
            load_nm: 0.0,
            w: AlphaBeta::default(),
            s: AlphaBeta::default(),
            sc: SinCos::ZERO,
            sc_mid: SinCos::ZERO,
            started: false,
        }
    }
}

impl SlidingObserver {
    /// Observer gains `[G1, G2, G3, G4]` at observer state (`θ̂_e`, `ω̂`, `î`)
    /// (Horng & Chin Secs 3.1, 3.2):
    ///
    /// `[G1; G2] = [[cos, Nω̂ sin], [sin, −Nω̂ cos]] · [L/(Hω̂)(î_a cos + î_b sin) − Lλ3/(KN²ω̂);
    /// L/(KN²ω̂)(B/H − λ4)]`, `[G3; G4] = HLK3/(KN²ω̂) · [sin + cos; sin − cos]`, with
    /// `λ3 = K2 − K3/(Nω̂)`, `λ4 = K1`, angles `θ̂_e`, and `ω̂` replaced by `±ω̂_low` when
    /// `|ω̂| < ω̂_low` (Sec 5). G1, G2 in rad/(A·s) so that `G·w` is rad/s²; G3, G4 in N·m/A.
    /// For the velocity observer (λτ = 0) K3 = 0, G3 = G4 = 0 and these are the gains after
    /// eq (32).
    /// (Not on the step's path: the Euler step uses the same factors multiplied out with the
    /// period, `EulerStep`.)
    pub fn gains(&self, sc: SinCos, omega_m: f32, i_hat: AlphaBeta) -> [f32; 4] {
        let f = &self.factors;
        let w = self.gain_speed(omega_m);
        let (s, c) = (sc.sin, sc.cos);
        let lambda3 = f.k2 - f.k3 / (self.n * w);
        let lambda4 = f.k1;
        let x = f.l_over_h / w * (i_hat.alpha * c + i_hat.beta * s) - f.l_over_kn2 * lambda3 / w;
        let y = f.l_over_kn2 / w * (f.b_over_h - lambda4);
        let nw = self.n * w;
        let g34 = f.g34() / w;
        [
            c * x + nw * s * y,
            s * x - nw * c * y,
            g34 * (s + c),
            g34 * (s - c),
        ]
    }

    /// `ω̂` as used in the gains: `±ω̂_low` when `|ω̂| < ω̂_low` (sign kept, + at zero).
    fn gain_speed(&self, omega_m: f32) -> f32 {
        if omega_m.abs() >= self.omega_low {
            return omega_m;
        }
        // Below ω̂_low: start-up only.
        cold_path();
        if omega_m < 0.0 {
            -self.omega_low
        } else {
            self.omega_low
        }
    }

    /// [`Observer::residual`] of an innovation `w` \[A/s] and a sliding variable `s` \[A] at the
    /// speed estimate `omega_m` \[rad/s] (any state's: the fixed-point observer's too).
    #[inline(always)]
    pub fn residual_of(&self, w: AlphaBeta, s: AlphaBeta, omega_m: f32) -> f32 {
        let w_norm = crate::math::sqrt_or_zero(w.alpha * w.alpha + w.beta * w.beta);
        let relative = w_norm * self.emf_residual_scale / self.gain_speed(omega_m).abs();
        let layer = crate::math::max(s.alpha.abs(), s.beta.abs()) * self.inv_epsilon;
        crate::math::max(relative, layer)
    }

    /// Sliding gain `K_s` \[A/s] at speed estimate `omega_m`.
    pub fn sliding_gain(&self, omega_m: f32) -> f32 {
        match self.ks {
            SlidingGain::Constant(k) => k,
            SlidingGain::PerSpeed { per_rad_s, min } => {
                // (`math::max`, not `f32::max`: a library call, `fmaxf`, on thumbv7em; the
                // same value, `min` for a NaN speed too.)
                crate::math::max(per_rad_s * omega_m.abs(), min)
            }
        }
    }

    /// Restarts the observer at a known rotor state (e.g. after an open-loop start).
    pub fn reset(&self, state: &mut SlidingState, i_ab: AlphaBeta, theta_e: f32, omega_m: f32) {
        let theta_e = wrap_pi(theta_e);
        let sc = SinCos::of(theta_e);
        *state = SlidingState {
            i_hat: i_ab,
            theta_e,
            omega_m,
            sc,
            sc_mid: self.emf_angle(sc, omega_m),
            started: true,
            ..SlidingState::default()
        };
    }

    /// One sample. `i_ab`: currents measured now \[A]; `v_ab`: the voltage applied over the
    /// period that just ended \[V]. First propagates the estimate from the previous sample to
    /// now with forward Euler (the previous innovation, eqs (20)-(22), (34), (35)), then
    /// computes the new sliding variable and innovation. Returns false, leaving the state
    /// untouched, when an input is not finite or the update would not be.
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn update(&self, st: &mut SlidingState, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {
        if !all_finite([i_ab.alpha, i_ab.beta, v_ab.alpha, v_ab.beta]) {
            cold_path();
            return false;
        }
        let mut next = *st;
        if !st.started {
            cold_path();
            next.i_hat = i_ab;
            next.started = true;
        } else {
            self.propagate(&mut next, v_ab);
        }
        next.s = AlphaBeta::new(next.i_hat.alpha - i_ab.alpha, next.i_hat.beta - i_ab.beta);
        let ks = self.sliding_gain(next.omega_m);
        let sat = |x: f32| clamp(x * self.inv_epsilon, -1.0, 1.0);
        next.w = AlphaBeta::new(ks * sat(next.s.alpha), ks * sat(next.s.beta));
        // Non-finite gains in `propagate` show up in ω̂ or τ̂_L (w is finite and bounded).
        // θ̂_e is not summed: it is the last accepted θ̂_e (finite, or a seed's NaN, which the
        // EMF term carries into î at once) turned by `T N` times the last accepted ω̂.
        let ok = finite_sum([
            next.i_hat.alpha,
            next.i_hat.beta,
            next.omega_m,
            next.load_nm,
        ]);
        if ok {
            *st = next;
        } else {
            cold_path();
        }
        ok
    }

    /// Forward-Euler step of eqs (20)-(22), (34), (35) over one period with the stored
    /// innovation `w` and the gains at the state it was computed at.
    ///
    /// The period `T` is folded into the coefficients ([`EulerStep`]), and the gain terms are
    /// [`SlidingObserver::gains`] multiplied out with `w`: with `p = c w_a + s w_b`,
    /// `q = s w_a − c w_b` (angle θ̂_e, `ω̂` as in the gains),
    /// `G1 w_a + G2 w_b = x p + N ω̂ y q` where `N ω̂ y = N L(B/H − K1)/(K N²)` does not depend
    /// on ω̂, and `G3 w_a + G4 w_b = (H L K3/(K N² ω̂)) (p + q)`. The same values to rounding
    /// (`tests/sliding.rs` checks it against the gains).
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    fn propagate(&self, st: &mut SlidingState, v_ab: AlphaBeta) {
        let e = &self.euler;
        let (sc, emf) = (st.sc, st.sc_mid);
        let (i, w) = (st.i_hat, st.w);
        let inv_w = 1.0 / self.gain_speed(st.omega_m);
        let p = sc.cos * w.alpha + sc.sin * w.beta;
        let q = sc.sin * w.alpha - sc.cos * w.beta;
        // T x of the gains: T/ω̂ (L/H (î_a c + î_b s) − L λ3/(K N²)), λ3 = K2 − K3/(N ω̂).
        let i_d = i.alpha * sc.cos + i.beta * sc.sin;
        let t_x = inv_w * (e.t_l_over_h * i_d - e.t_lk2 + e.t_lk3 * inv_w);
        // T ψ_a N ω̂/L_q: the active flux's EMF (module doc).
        let emf_gain = (e.t_kn_over_l + e.t_kn_over_l_per_a * i_d) * st.omega_m;
        st.i_hat = AlphaBeta::new(
            e.a_i * i.alpha + emf_gain * emf.sin + e.t_inv_l * v_ab.alpha - self.ts * w.alpha, // (20)
            e.a_i * i.beta - emf_gain * emf.cos + e.t_inv_l * v_ab.beta - self.ts * w.beta, // (21)
        );
        st.theta_e = wrap_pi(st.theta_e + e.tn * st.omega_m); // (22)
        st.omega_m = e.a_omega * st.omega_m
            - e.t_kn_over_h * (i.alpha * sc.sin - i.beta * sc.cos)
            - e.t_inv_h * st.load_nm
            + t_x * p
            + e.t_cy * q; // (35)
        st.load_nm += e.t_g34 * inv_w * (p + q); // (34)

        // sin/cos fresh each period (rotating the stored pair would accumulate rounding);
        // the next period's EMF angle by a small rotation of it.
        let (sin, cos) = sin_cos_wrapped(st.theta_e);
        st.sc = SinCos { sin, cos };
        st.sc_mid = self.emf_angle(st.sc, st.omega_m);
    }

    /// sin/cos of `θ̂_e + a N ω̂ T` from `sc` = sin/cos of `θ̂_e` (see [`SlidingState::sc_mid`]).
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    fn emf_angle(&self, sc: SinCos, omega_m: f32) -> SinCos {
        sc.advanced(self.emf_advance_s * omega_m)
    }
}

impl Observer for SlidingObserver {
    type State = SlidingState;

    #[inline(always)]
    fn update(&self, st: &mut SlidingState, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {
        SlidingObserver::update(self, st, i_ab, v_ab)
    }

    #[inline(always)]
    fn theta_e(&self, st: &SlidingState) -> f32 {
        st.theta_e
    }

    #[inline(always)]
    fn sin_cos(&self, st: &SlidingState) -> SinCos {
        st.sc
    }

    /// The back-EMF angle of the coming period, [`SlidingState::sc_mid`], which the observer
    /// keeps, where the controller's advance is the same (no update delay: then it equals
    /// `frame` turned by `lead`); else `frame` turned by `lead`.
    #[inline(always)]
    fn sin_cos_output(&self, st: &SlidingState, frame: SinCos, lead: SinCos) -> SinCos {
        if self.output_at_emf {
            st.sc_mid
        } else {
            frame.rotated(lead)
        }
    }

    #[inline(always)]
    fn omega_m(&self, st: &SlidingState) -> f32 {
        st.omega_m
    }

    /// The equivalent injection against the back-EMF it corrects, and the boundary layer.
    /// Inside the layer (`|S| < ε`) the innovation `w = K_s S/ε` is the equivalent injection
    /// that holds the sliding manifold (Sec 3, eq (28)): `w = (KN/L)(ω̂ c(θ̂_e) − ω c(θ_e))`, the
    /// back-EMF error over L. Relative to the estimated back-EMF `(KN/L)|ω̂|` it is
    /// `2 sin(θ̃_e/2)` at equal speeds; scaled so that 45° electrical is 1. The absolute `|w|`
    /// alone says little at low speed (the EMF is small whatever the angle); the relative one
    /// does. At the layer's edge (`max |S_i|/ε ≥ 1`, `K_s < K_s,min`) the sliding mode is lost
    /// whatever the angle: the residual is at least 1. Below `ω̂_low` the speed is floored there.
    #[inline(always)]
    fn residual(&self, st: &SlidingState) -> f32 {
        self.residual_of(st.w, st.s, st.omega_m)
    }

    #[inline(always)]
    fn min_speed_m(&self) -> f32 {
        self.min_speed
    }

    /// τ̂_L of the torque observer; `None` for the velocity observer (λτ = 0).
    #[inline(always)]
    fn load_nm(&self, st: &SlidingState) -> Option<f32> {
        (self.factors.k3 > 0.0).then_some(st.load_nm * self.torque_factor)
    }

    /// [`SlidingObserver::reset`] at the rotor's angle and speed, τ̂_L at its load for the
    /// torque observer.
    fn seed(&self, st: &mut SlidingState, i_ab: AlphaBeta, rotor: Rotor) {
        self.reset(st, i_ab, rotor.theta_e, rotor.omega_m);
        if self.factors.k3 > 0.0 {
            st.load_nm = rotor.load_nm / self.torque_factor;
        }
    }
}
