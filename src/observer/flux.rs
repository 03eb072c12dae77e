//! Ortega, Praly, Astolfi, Lee, Nam: the gradient flux observer, eq (9), with the position
//! read-out of Sec V iii; in the active-flux form for a salient motor.
//!
//! ```text
//! dx̂/dt = y12 + (γ/2)(x̂ − L i)(Φ² − |x̂ − L i|²),   y12 = v − R i          (9), (7)
//! θ̂_e = atan2(x̂2 − L i_β, x̂1 − L i_α)                                    (Sec V iii)
//! ```
//! `x` is the stator flux linkage in αβ \[Wb], `Φ` the magnet flux, θ electrical.
//!
//! **Salient motors (`L_d ≠ L_q`): the active flux.** The stator flux of a salient PMSM is
//! `x = L_q i + ψ_a c(θ)`, `ψ_a = ψ_f + (L_d − L_q) i_d`: the "active flux" `η = x − L_q i`
//! lies along the rotor's d axis with the length `ψ_a` (Boldea, Paicu, Andreescu, "Active flux
//! concept for motion-sensorless unified AC drives", IEEE Trans. Power Electron. 23(5), 2008:
//! their `ψ_d^a = ψ_s − L_q i_s`; the form the IPMSM observer of Ortega, Yi, Vukosavic, Nam,
//! Choi, "A globally exponentially stable position observer for interior permanent magnet
//! synchronous motors", Automatica 125, 2021, starts from). It is eq (4) with `L` → `L_q`
//! and `Φ` → `ψ_a`, and `ẋ = y12` (eq (6)) is unchanged, so the observer here is eq (9) with
//! `η̂ = x̂ − L_q i` and `ψ_a²` in place of `Φ²`:
//!
//! ```text
//! dx̂/dt = y12 + (γ/2) η̂ (ψ̂_a² − |η̂|²),   η̂ = x̂ − L_q i,   ψ̂_a = ψ_f + (L_d − L_q) î_d
//! θ̂_e = atan2(η̂₂, η̂₁)
//! ```
//!
//! `î_d = i·η̂/|η̂|` is the measured current's d component in the observer's own frame (the
//! frame the FOC runs in while the observer is primary), not the d-current reference: during
//! align, the open-loop start and a catch the reference is in another frame (the open loop's),
//! and at the voltage limit the current does not follow it, while `î_d` is the current the
//! motor carries along the axis the observer estimates. Once the angle has converged
//! `î_d = i_d` and the equations are the motor's; the `ψ̂_a²` term is then no longer the exact
//! gradient of `|η̂|²`'s distance to a fixed circle (its radius moves with `θ̂`), so the
//! global convergence of the paper's Proposition 1 is not claimed for it: it is the local
//! behaviour, with `Φ` → `ψ_a`, of the paper's observer, and the global IPMSM result is that of
//! Ortega, Yi et al. 2021 (a different observer, not built here). Bounds with ψ_a: every bound
//! on γ below holds with `γψ_a²` in place of `γΦ²`: the radial step multiplies by `1 − γψ_a²T`,
//! and Proposition 4's `Ω0 = −2 n_P ω/(γψ_a²)`. With `ψ_a` twice `ψ_f` (the Brusa HSM1's MTPA
//! at 138 A: `i_d` = −80 A) `γψ_a²` is four times the value γ was chosen for, and `|Ω0|` falls
//! below ½ under twice the lowest speed, where eq (17) has more than one equilibrium. Measured:
//! the Brusa's reversal under a 30 % brake, with d currents of −160 to −200 A (the MTPA's
//! Newton overshoot, since cut: `crate::mtpa`), `ψ_a` 3 to 3.5 `ψ_f`, lost its angle between
//! 230 and 530 rpm (its hand-back speed 180 rpm). So a salient motor's γ is chosen for the
//! largest `ψ_a` its low-speed currents make ([`FluxConfig::for_active_flux_up_to`]; the drive
//! takes the MTPA's currents at its current limit). A worst case, chosen on purpose: on the
//! Brusa (`i_max` 360 A, `ψ_a` 3.96 `ψ_f` there) γ is a sixteenth of the non-salient design's,
//! and at light load, where `ψ_a ≈ ψ_f`, the radial rate `γψ_f²` falls from 113 to 7.2 s⁻¹ (a
//! 140 ms time constant). Field weakening's larger d currents (down to `−i_max`) come at speeds
//! where `|Ω0|` is large; there `γψ_a²` can exceed the value chosen by less than 2× (the active
//! fluxes' ratio is below √2), which keeps the discrete step stable (`γψ_a²T < 2`) but not the
//! default's margin against its overshoot (`≤ 1`): with the default hand-back speed (6 % of
//! rated) and the rate rule's 20 samples per electrical period at rated speed, the
//! single-equilibrium limit is the smaller by 26× or more, so `γψ_a²T` stays far below 1.
//! (Scaling γ by `Φ²/|η̂|²` each sample keeps the design's rate at every current and passes the
//! same salient zoo cells with smaller angle errors, but costs the step 12 to 16 cycles, over
//! its budget.) A positive `i_d` above `ψ_f/|L_d − L_q|` (an align current on a strongly
//! salient motor) turns `ψ_a` negative and the read-out by π. With `L_d = L_q` (`saliency` 1)
//! the equations and the code path are exactly eq (9) (bit for bit: the salient terms run only
//! for a salient motor).
//!
//! Discretisation at the control period T, between the samples `k−1` and `k`:
//! - the flux integral of `y12` is exact for a voltage held over the period and a current
//!   linear in between: `T (v_{k−1} − R (i_{k−1} + i_k)/2)` (trapezoid for `R i`);
//! - the gradient term is a forward-Euler step at sample `k−1` (`ψ̂_a` from `i_{k−1}` and
//!   `η̂_{k−1}`). Its radial linearisation is
//!   `ṙ = −γΦ² r`, so the step multiplies a radial error by `1 − γΦ²T`: stable for
//!   `γΦ²T < 2` ([`gamma_max_discrete`]), without overshoot for `γΦ²T ≤ 1` (half of it, where
//!   the default γ stays).
//!
//! The read-out uses `x̂_k − L i_k` at the sample instant, so the angle belongs to `t_k`: no
//! half-period lag.

use crate::frames::{AlphaBeta, SinCos};
use crate::math::{all_finite, atan2, is_normal_positive, max, rsqrt_normal};
use crate::motor::MotorParams;
use crate::param::{Allowed, Checks, ParamError};
use core::hint::cold_path;

/// Largest γ \[1/(Wb²·s)] for which the forward-Euler gradient step of eq (9) is stable:
/// `γΦ²T < 2`, i.e. `γ < 2·rate_hz/Φ²`. Above it a radial error of `x̂ − L i` grows by
/// `|1 − γΦ²T| > 1` each sample.
pub fn gamma_max_discrete(flux_wb: f32, rate_hz: f32) -> f32 {
    2.0 * rate_hz / (flux_wb * flux_wb)
}

/// Largest γ for which eq (17) has the origin as its only equilibrium down to the speed
/// `omega_m_min` [rad/s, mechanical] (Proposition 4: `|Ω0| > 1/2` with
/// `Ω0 = −2 n_P ω/(γΦ²)`, i.e. `γ < 4 n_P |ω_m|/Φ²`).
pub fn gamma_max_single_equilibrium(flux_wb: f32, pole_pairs: f32, omega_m_min: f32) -> f32 {
    4.0 * pole_pairs * omega_m_min.abs() / (flux_wb * flux_wb)
}

/// The default γ: the smaller of the two limits above, times `margin` (< 1; the default 0.5
/// keeps the discrete step free of overshoot and |Ω0| ≥ 1 at the lowest speed).
pub fn gamma_recommended(
    flux_wb: f32,
    pole_pairs: f32,
    rate_hz: f32,
    omega_m_min: f32,
    margin: f32,
) -> f32 {
    margin
        * gamma_max_discrete(flux_wb, rate_hz).min(gamma_max_single_equilibrium(
            flux_wb,
            pole_pairs,
            omega_m_min,
        ))
}

/// Settings of the flux observer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FluxConfig {
    /// Motor model (R, L_d, L_q, Φ are used).
    pub motor: MotorParams,
    /// Update rate \[Hz].
    pub rate_hz: f32,
    /// Gradient gain γ \[1/(Wb²·s)], in `(0, gamma_max_discrete)`.
    pub gamma: f32,
}

impl FluxConfig {
    /// γ from [`gamma_recommended`] with margin 0.5 for a lowest speed `min_speed_rpm`.
    pub fn new(motor: MotorParams, rate_hz: f32, min_speed_rpm: f32) -> Self {
        let omega_min = min_speed_rpm * crate::units::RAD_S_PER_RPM;
        Self {
            motor,
            rate_hz,
            gamma: gamma_recommended(motor.flux_wb, motor.n(), rate_hz, omega_min, 0.5),
        }
    }

    /// γ for a salient motor whose active flux reaches `psi_a_max_wb` \[Wb] (module doc): scaled
    /// by `(Φ/ψ_a,max)²` where `ψ_a,max > Φ`, so that `γ ψ_a²` stays within the value γ was
    /// chosen for with `Φ` at every `ψ_a` up to it; unchanged otherwise (and for a NaN).
    pub fn for_active_flux_up_to(self, psi_a_max_wb: f32) -> Self {
        let phi = self.motor.flux_wb;
        if psi_a_max_wb > phi {
            let ratio = phi / psi_a_max_wb;
            Self {
                gamma: self.gamma * ratio * ratio,
                ..self
            }
        } else {
            self
        }
    }

    /// Validates; γ must keep the discrete step stable (`γΦ²T < 2`); a larger γ is accepted
    /// only by [`FluxConfig::build_unchecked_gamma`] (for the tests that show the limit).
    pub fn build(&self) -> Result<FluxObserver, ParamError> {
        let observer = self.build_unchecked_gamma()?;
        Allowed::strictly_between(0.0, gamma_max_discrete(self.motor.flux_wb, self.rate_hz))
            .because("gamma Phi^2 T < 2")
            .check("gamma", self.gamma)?;
        Ok(observer)
    }

    /// As [`FluxConfig::build`] but without the discrete-stability check on γ.
    pub fn build_unchecked_gamma(&self) -> Result<FluxObserver, ParamError> {
        let m = self.motor.validate()?;
        let (rate, gamma) = (self.rate_hz, self.gamma);
        let mut c = Checks::new();
        c.check("rate_hz", rate, Allowed::POSITIVE);
        c.check("gamma", gamma, Allowed::POSITIVE);
        c.done()?;
        let phi2 = m.flux_wb * m.flux_wb;
        let ts = 1.0 / rate;
        Ok(FluxObserver {
            ts,
            r_ohm: m.r_ohm,
            l_h: m.l_q_h(),
            phi: m.flux_wb,
            phi2,
            inv_phi2: 1.0 / phi2,
            half_gamma_ts: 0.5 * gamma * ts,
            l_d_minus_l_q: m.l_d_minus_l_q_h(),
            salient: m.is_salient(),
            psi_a2_min: ACTIVE_FLUX_MIN * ACTIVE_FLUX_MIN * phi2,
        })
    }
}

/// The active flux's length below which the magnitude residual takes it as this share of
/// `ψ_f` (its square divides the residual).
const ACTIVE_FLUX_MIN: f32 = 1e-3;

/// A built flux observer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FluxObserver {
    ts: f32,
    r_ohm: f32,
    /// `L_q` \[H] (`L` of a non-salient motor): `η̂ = x̂ − L_q i`.
    l_h: f32,
    phi: f32,
    phi2: f32,
    inv_phi2: f32,
    half_gamma_ts: f32,
    /// `L_d − L_q` \[H], 0 for a non-salient motor.
    l_d_minus_l_q: f32,
    /// `L_d ≠ L_q`: the active-flux terms run (module doc).
    salient: bool,
    /// `(10⁻³ ψ_f)²` \[Wb²]: the least `ψ̂_a²` the magnitude residual divides by.
    psi_a2_min: f32,
}

/// Running state of the flux observer.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FluxState {
    /// Flux estimate x̂ at the last sample \[Wb].
    pub x_hat: AlphaBeta,
    /// Current at the last sample \[A].
    pub i_last: AlphaBeta,
    /// Rotor-flux estimate `x̂ − L i` at the last sample \[Wb] (its angle is θ̂_e).
    pub rotor_flux: AlphaBeta,
    /// `1/|rotor_flux|` \[1/Wb], 0 where `|rotor_flux|²` is not a normal f32 (before the first
    /// sample): [`inv_magnitude`], taken once a sample for [`FluxState::sin_cos`] and the
    /// next sample's active flux.
    pub inv_mag: f32,
    /// Electrical angle estimate \[rad], in (−π, π]: the angle of `rotor_flux` as of the last
    /// [`FluxObserver::update`] or [`FluxState::update_angle`].
    pub theta_e: f32,
    /// False until the first sample.
    pub started: bool,
}

impl FluxState {
    /// θ̂_e = arctan((x̂₂ − L i_β)/(x̂₁ − L i_α)) (Ortega Sec V), four-quadrant, from the rotor
    /// flux of the last sample.
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn update_angle(&mut self) {
        self.theta_e = atan2(self.rotor_flux.beta, self.rotor_flux.alpha);
    }

    /// sin/cos of θ̂_e without trigonometry: the rotor-flux estimate `x̂ − L i` normalised
    /// (its angle is θ̂_e, Ortega Sec V) by the inverse length its sample kept (`inv_mag`:
    /// one square root a sample serves this and the next sample's active flux), or of
    /// `theta_e` when that vector is too small to normalise (before the first sample).
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn sin_cos(&self) -> SinCos {
        let (eta, inv) = (self.rotor_flux, self.inv_mag);
        if inv > 0.0 {
            SinCos {
                sin: eta.beta * inv,
                cos: eta.alpha * inv,
            }
        } else {
            cold_path();
            SinCos::of(self.theta_e)
        }
    }
}

impl FluxObserver {
    /// One sample: `i_ab` measured now \[A], `v_ab` the voltage applied over the period that just
    /// ended \[V]: [`FluxObserver::integrate`], then θ̂_e by the arctangent of Sec V.
    /// Returns false, leaving the state untouched, on non-finite input or output.
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn update(&self, st: &mut FluxState, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {
        let ok = self.integrate(st, i_ab, v_ab);
        if ok {
            st.update_angle();
        }
        ok
    }

    /// The observer's state equations for one sample, eqs (7), (9): `x̂` and the rotor flux
    /// `x̂ − L i`, whose angle is θ̂_e; `theta_e` is left as it was (the drive takes the
    /// arctangent at 1 kHz, [`FluxState::update_angle`]). Returns false, leaving the state
    /// untouched, on non-finite input or output.
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn integrate(&self, st: &mut FluxState, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {
        if !all_finite([i_ab.alpha, i_ab.beta, v_ab.alpha, v_ab.beta]) {
            cold_path();
            return false;
        }
        let mut x = st.x_hat;
        if st.started {
            // Gradient term of eq (9) at sample k−1.
            let eta = st.rotor_flux;
            let mag2 = eta.alpha * eta.alpha + eta.beta * eta.beta;
            // Φ², or ψ̂_a² of a salient motor at sample k−1 (module doc).
            let psi2 = if self.salient {
                self.active_flux2(eta, st.inv_mag, st.i_last)
            } else {
                self.phi2
            };
            let g = self.half_gamma_ts * (psi2 - mag2);
            // ∫ y12 dt over the period, eq (7).
            let r_half = 0.5 * self.r_ohm;
            x.alpha +=
                self.ts * (v_ab.alpha - r_half * (st.i_last.alpha + i_ab.alpha)) + g * eta.alpha;
            x.beta += self.ts * (v_ab.beta - r_half * (st.i_last.beta + i_ab.beta)) + g * eta.beta;
        }
        let eta = AlphaBeta::new(
            x.alpha - self.l_h * i_ab.alpha,
            x.beta - self.l_h * i_ab.beta,
        );
        if !all_finite([x.alpha, x.beta]) {
            cold_path();
            return false;
        }
        *st = FluxState {
            x_hat: x,
            i_last: i_ab,
            rotor_flux: eta,
            inv_mag: inv_magnitude(eta),
            started: true,
            ..*st
        };
        true
    }

    /// `ψ̂_a² = (ψ_f + (L_d − L_q) î_d)²` \[Wb²] for the active-flux estimate `eta` (`inv_mag`
    /// its [`inv_magnitude`]) and the current `i_ab` of the same sample, `î_d = i·η̂/|η̂|`
    /// (module doc); `î_d = 0` where `η̂` is too short to normalise.
    #[inline(always)]
    fn active_flux2(&self, eta: AlphaBeta, inv_mag: f32, i_ab: AlphaBeta) -> f32 {
        let i_d = (i_ab.alpha * eta.alpha + i_ab.beta * eta.beta) * inv_mag;
        let psi_a = self.phi + self.l_d_minus_l_q * i_d;
        psi_a * psi_a
    }

    /// `| |x̂ − L i|²/Φ² − 1 |`: how far the rotor-flux estimate is off the circle of radius Φ
    /// that eq (9)'s gradient term pulls it to (eqs (4), (5)). Locked, it is on it; an error
    /// `x̃` perpendicular to the true flux puts it at `tan²θ̃_e` (1 at 45° electrical), and an
    /// angle error that persists while the rotor turns shows here as the flux turns away from
    /// it. Also 1 when the motor's flux is not Φ at all (|x − L i| = 0 or √2 Φ).
    ///
    /// Of a salient motor the same on the active flux: `| |x̂ − L_q i|²/ψ̂_a² − 1 |`, `ψ̂_a` of
    /// the last sample's current in the observer's frame (module doc), at least `10⁻³ ψ_f`.
    #[inline(always)]
    pub fn magnitude_residual(&self, st: &FluxState) -> f32 {
        let eta = st.rotor_flux;
        let mag2 = eta.alpha * eta.alpha + eta.beta * eta.beta;
        if self.salient {
            let psi_a2 = max(
                self.active_flux2(eta, st.inv_mag, st.i_last),
                self.psi_a2_min,
            );
            (mag2 / psi_a2 - 1.0).abs()
        } else {
            (mag2 * self.inv_phi2 - 1.0).abs()
        }
    }

    /// Sets the estimate to a known rotor angle: `x̂ = L i + Φ c(θ_e)` (eq (4)); of a salient
    /// motor `x̂ = L_q i + ψ_a c(θ_e)` with `ψ_a = ψ_f + (L_d − L_q) i_d` of `i_ab` at `θ_e`
    /// (module doc).
    pub fn reset(&self, st: &mut FluxState, i_ab: AlphaBeta, theta_e: f32) {
        let (s, c) = crate::math::sin_cos(theta_e);
        let phi = if self.salient {
            self.phi + self.l_d_minus_l_q * (i_ab.alpha * c + i_ab.beta * s)
        } else {
            self.phi
        };
        let eta = AlphaBeta::new(phi * c, phi * s);
        *st = FluxState {
            x_hat: AlphaBeta::new(
                self.l_h * i_ab.alpha + eta.alpha,
                self.l_h * i_ab.beta + eta.beta,
            ),
            i_last: i_ab,
            rotor_flux: eta,
            inv_mag: inv_magnitude(eta),
            theta_e: crate::math::wrap_pi(theta_e),
            started: true,
        };
    }
}

/// `1/|eta|` \[1/Wb] by three Newton steps from the bit-level guess ([`rsqrt_normal`]: f32
/// rounding), or 0 where `|eta|²` is not a normal f32 (zero, subnormal, ∞ or NaN).
#[inline(always)]
pub fn inv_magnitude(eta: AlphaBeta) -> f32 {
    let mag2 = eta.alpha * eta.alpha + eta.beta * eta.beta;
    if is_normal_positive(mag2) {
        rsqrt_normal(mag2, 3)
    } else {
        cold_path();
        0.0
    }
}
