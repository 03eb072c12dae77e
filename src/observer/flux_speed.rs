//! Ortega et al.'s flux observer, eq (9), with a speed estimator on its angle: the PLL of
//! Sec V iii ([`FluxPll`]) or the immersion-and-invariance speed and load-torque observer of
//! Sec IV, eq (30) ([`FluxIi`]).
//!
//! [`Observer::update`] integrates the flux observer's state equations every sample; the
//! angle read-out (an arctangent) and the speed estimator are the two [`ReadOut`]s, which the
//! drive runs at 1 kHz and a bare-observer run after every sample. Each speed estimator is
//! built for the rate it is run at.

use crate::frames::{AlphaBeta, SinCos};
use crate::math::max;
use crate::observer::flux::{FluxObserver, FluxState};
use crate::observer::ii::{IiObserver, IiState};
use crate::observer::pll::{Pll, PllState};
use crate::observer::{Observer, ReadOut, Rotor};
use core::f32::consts::FRAC_PI_2;

/// The flux observer for θ̂_e and the PLL on its angle for ω̂.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FluxPll {
    /// The flux observer, eq (9).
    pub flux: FluxObserver,
    /// The PLL, built for the rate [`ReadOut::Speed`] is run at.
    pub pll: Pll,
    /// N.
    n: f32,
    /// 1/N.
    inv_n: f32,
}

/// State of [`FluxPll`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FluxPllState {
    /// The flux observer's state.
    pub flux: FluxState,
    /// The PLL's state (electrical angle and speed).
    pub pll: PllState,
}

impl FluxPll {
    /// The two blocks for a motor of `pole_pairs`.
    pub fn new(flux: FluxObserver, pll: Pll, pole_pairs: f32) -> Self {
        Self {
            flux,
            pll,
            n: pole_pairs,
            inv_n: 1.0 / pole_pairs,
        }
    }
}

impl Observer for FluxPll {
    type State = FluxPllState;

    #[inline(always)]
    fn update(&self, st: &mut FluxPllState, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {
        self.flux.integrate(&mut st.flux, i_ab, v_ab)
    }

    #[inline(always)]
    fn read_out(&self, st: &mut FluxPllState, part: ReadOut) {
        match part {
            ReadOut::Angle => st.flux.update_angle(),
            // The hint of the turn over the period: the one the last update predicted
            // (`pll.rs`, "Aided").
            ReadOut::Speed if self.pll.is_aided() => {
                let hint = self.pll.predicted_turn(&st.pll);
                self.pll.update_aided(&mut st.pll, st.flux.theta_e, hint);
            }
            ReadOut::Speed => {
                self.pll.update(&mut st.pll, st.flux.theta_e);
            }
        }
    }

    #[inline(always)]
    fn theta_e(&self, st: &FluxPllState) -> f32 {
        st.flux.theta_e
    }

    #[inline(always)]
    fn sin_cos(&self, st: &FluxPllState) -> SinCos {
        st.flux.sin_cos()
    }

    #[inline(always)]
    fn omega_m(&self, st: &FluxPllState) -> f32 {
        st.pll.omega * self.inv_n
    }

    /// The larger of the flux magnitude's residual ([`FluxObserver::magnitude_residual`]) and
    /// the PLL's error at its last update over 90°: the angle is the flux observer's, the
    /// PLL only differentiates it, so its error says the speed estimate is slipping, not that
    /// the angle is wrong. Its tracking error under an acceleration α is `α/ω_n²`: 25° for
    /// rated torque applied at once to the Sinano motor (4.3e4 rad/s² electrical), 0.2° on
    /// the 1000 rpm/s ramp; a slipping PLL swings through ±180°. An aided PLL
    /// ([`Pll::update_aided`]) has no lag under a constant acceleration, and its error is
    /// unwrapped: it stays large while the speed estimate is off by more than the loop pulls
    /// in.
    #[inline(always)]
    fn residual(&self, st: &FluxPllState) -> f32 {
        let pll_error = st.pll.error.abs() * (1.0 / FRAC_PI_2);
        max(self.flux.magnitude_residual(&st.flux), pll_error)
    }

    fn seed(&self, st: &mut FluxPllState, i_ab: AlphaBeta, rotor: Rotor) {
        self.flux.reset(&mut st.flux, i_ab, rotor.theta_e);
        self.pll
            .reset(&mut st.pll, rotor.theta_e, rotor.omega_m * self.n);
    }
}

/// The flux observer for θ̂_e and the I&I observer (30) for ω̂ and τ̂_L.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FluxIi {
    /// The flux observer, eq (9).
    pub flux: FluxObserver,
    /// The I&I observer, built for the rate [`ReadOut::Speed`] is run at.
    pub ii: IiObserver,
    /// N ψ_f \[N·m/A].
    torque_constant: f32,
}

/// State of [`FluxIi`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FluxIiState {
    /// The flux observer's state.
    pub flux: FluxState,
    /// The I&I observer's state.
    pub ii: IiState,
    /// Electromagnetic torque `N ψ_f i_q` at the previous speed update \[N·m]: forward Euler
    /// over the period that ends at the next one uses the torque at its start.
    pub torque_last_nm: f32,
}

impl FluxIi {
    /// The two blocks; `torque_constant` = N ψ_f \[N·m/A].
    pub fn new(flux: FluxObserver, ii: IiObserver, torque_constant: f32) -> Self {
        Self {
            flux,
            ii,
            torque_constant,
        }
    }
}

impl Observer for FluxIi {
    type State = FluxIiState;

    #[inline(always)]
    fn update(&self, st: &mut FluxIiState, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool {
        self.flux.integrate(&mut st.flux, i_ab, v_ab)
    }

    #[inline(always)]
    fn read_out(&self, st: &mut FluxIiState, part: ReadOut) {
        match part {
            ReadOut::Angle => st.flux.update_angle(),
            ReadOut::Speed => {
                let sc = SinCos::of(st.flux.theta_e);
                self.ii
                    .update(&mut st.ii, (sc.sin, sc.cos), st.torque_last_nm);
                st.torque_last_nm = self.torque_constant * st.flux.i_last.to_dq(sc).q;
            }
        }
    }

    #[inline(always)]
    fn theta_e(&self, st: &FluxIiState) -> f32 {
        st.flux.theta_e
    }

    #[inline(always)]
    fn sin_cos(&self, st: &FluxIiState) -> SinCos {
        st.flux.sin_cos()
    }

    #[inline(always)]
    fn omega_m(&self, st: &FluxIiState) -> f32 {
        self.ii.estimate(&st.ii).omega_m
    }

    #[inline(always)]
    fn load_nm(&self, st: &FluxIiState) -> Option<f32> {
        Some(self.ii.estimate(&st.ii).load_nm)
    }

    /// The flux magnitude's residual ([`FluxObserver::magnitude_residual`]).
    #[inline(always)]
    fn residual(&self, st: &FluxIiState) -> f32 {
        self.flux.magnitude_residual(&st.flux)
    }

    fn seed(&self, st: &mut FluxIiState, i_ab: AlphaBeta, rotor: Rotor) {
        self.flux.reset(&mut st.flux, i_ab, rotor.theta_e);
        let sc = SinCos::of(rotor.theta_e);
        self.ii
            .reset(&mut st.ii, (sc.sin, sc.cos), rotor.omega_m, rotor.load_nm);
        st.torque_last_nm = self.torque_constant * i_ab.to_dq(sc).q;
    }
}
