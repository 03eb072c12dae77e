//! Horng & Chin's sliding observers in fixed point (`pmsm_sensorless::fixed::sliding`, issue
//! #30) behind the core's [`Observer`] trait, for the papers' bare-observer experiments
//! (`pmsm-sim run horng-ramp-brake --observer sliding-torque --fixed-point`): each sample's
//! currents and voltage rounded to Q15 of the bases (as the ADC and the fixed-point step give
//! them), the fixed-point observer run on them, its estimates read back in SI units for the
//! controller and the figures. The controller (the bare loop's FOC) stays f32: what is
//! compared is the observer.
//!
//! Bases ([`PerUnit`]): `I_b` the drive's sensing range and `V_b` its highest bus over √3
//! ([`PerUnit::of_drive`] of the motor's default configuration), at the run's rate. A salient
//! motor is refused (`SlidingObserverQ::build`).

use super::encoder::Diagnostics;
use super::SlidingDiag;
use pmsm_sensorless::fixed::pu::{to_q15, PerUnit};
use pmsm_sensorless::fixed::sliding::{SlidingObserverQ, SlidingStateQ};
use pmsm_sensorless::fixed::{AlphaBetaQ15, Angle};
use pmsm_sensorless::frames::{AlphaBeta, SinCos};
use pmsm_sensorless::observer::sliding::{SlidingConfig, SlidingObserver};
use pmsm_sensorless::observer::{Observer, Rotor};
use pmsm_sensorless::param::ParamError;

/// 2³¹: Q31's one.
const Q31: f32 = 2_147_483_648.0;
/// 2¹⁵: Q15's one.
const Q15: f32 = 32_768.0;

/// The fixed-point sliding observer (torque or velocity, as its [`SlidingConfig`]) with its
/// bases and the factors that turn its per-unit state into SI units; and the f32 observer of
/// the same settings, whose residual and gain formulas it reads its state with.
#[derive(Clone, Copy, Debug)]
pub struct SlidingQ {
    obs: SlidingObserverQ,
    f32_obs: SlidingObserver,
    pu: PerUnit,
    /// Pole pairs.
    n: f32,
    /// `τ_b = K N I_b` of the paper's model \[N·m], times the motor's torque convention's
    /// factor (the f32 observer's `torque_factor`): the load state's base in the user's N·m.
    tau_b_nm: f32,
    /// The torque observer (λτ > 0): it has a load estimate.
    torque: bool,
}

impl SlidingQ {
    /// The fixed-point observer of `cfg` in the bases `pu`; errors name the setting the
    /// fixed-point observer refuses (a `K_s` per speed, a coefficient beyond its format).
    pub fn build(cfg: &SlidingConfig, pu: PerUnit) -> Result<Self, ParamError> {
        let obs = SlidingObserverQ::build(cfg, &pu)?;
        let m = cfg.motor;
        let paper = m.papers_model();
        Ok(Self {
            obs,
            f32_obs: cfg.build()?,
            pu,
            n: m.n(),
            tau_b_nm: paper.flux_wb * paper.n() * pu.i_base_a * m.torque.factor(),
            torque: cfg.lambda_tau_hz > 0.0,
        })
    }

    /// `i_ab` \[A] in Q15 of `I_b`, rounded and saturated as an ADC reads it.
    fn currents(&self, i_ab: AlphaBeta) -> AlphaBetaQ15 {
        AlphaBetaQ15 {
            alpha: self.pu.current(i_ab.alpha),
            beta: self.pu.current(i_ab.beta),
        }
    }
}

impl Observer for SlidingQ {
    type State = SlidingStateQ;

    /// The fixed-point sample on the Q15-rounded current and voltage; always accepted (the
    /// rounding saturates: no input is refused in fixed point).
    fn update(&self, st: &mut SlidingStateQ, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {
        let v = AlphaBetaQ15 {
            alpha: self.pu.voltage(v_ab.alpha),
            beta: self.pu.voltage(v_ab.beta),
        };
        self.obs.update(st, self.currents(i_ab), v);
        true
    }

    fn theta_e(&self, st: &SlidingStateQ) -> f32 {
        st.theta_e.to_rad()
    }

    fn sin_cos(&self, st: &SlidingStateQ) -> SinCos {
        SinCos {
            sin: f32::from(st.sc.0) / Q15,
            cos: f32::from(st.sc.1) / Q15,
        }
    }

    /// `Ω ω_b / N` \[rad/s, mechanical].
    fn omega_m(&self, st: &SlidingStateQ) -> f32 {
        st.omega as f32 / Q31 * self.pu.omega_base_e / self.n
    }

    fn load_nm(&self, st: &SlidingStateQ) -> Option<f32> {
        self.torque.then(|| st.load as f32 / Q31 * self.tau_b_nm)
    }

    fn seed(&self, st: &mut SlidingStateQ, i_ab: AlphaBeta, rotor: Rotor) {
        let load = if self.torque {
            to_q15(rotor.load_nm / self.tau_b_nm)
        } else {
            0
        };
        self.obs.reset(
            st,
            self.currents(i_ab),
            Angle::from_rad(rotor.theta_e),
            self.pu.speed(rotor.omega_m * self.n),
            load,
        );
    }

    /// The f32 observer's residual ([`SlidingObserver::residual_of`]) of the fixed-point
    /// state: its innovation `K_s σ`, its `S` and its speed.
    fn residual(&self, st: &SlidingStateQ) -> f32 {
        let omega_m = self.omega_m(st);
        let ks = self.f32_obs.sliding_gain(omega_m);
        let w = AlphaBeta::new(
            ks * f32::from(st.sigma.alpha) / Q15,
            ks * f32::from(st.sigma.beta) / Q15,
        );
        self.f32_obs.residual_of(w, self.s_ab(st), omega_m)
    }

    fn min_speed_m(&self) -> f32 {
        self.f32_obs.min_speed_m()
    }
}

impl SlidingQ {
    /// `S = î − i` \[A].
    fn s_ab(&self, st: &SlidingStateQ) -> AlphaBeta {
        let a = |x: i32| x as f32 / Q31 * self.pu.i_base_a;
        AlphaBeta::new(a(st.s.alpha), a(st.s.beta))
    }
}

impl Diagnostics for SlidingQ {
    fn sliding_diag(&self, st: &SlidingStateQ) -> Option<SlidingDiag> {
        Some(SlidingDiag {
            s_ab: self.s_ab(st),
            ks: self.f32_obs.sliding_gain(self.omega_m(st)),
        })
    }
}
