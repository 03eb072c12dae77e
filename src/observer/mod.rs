//! Rotor observers: angle, speed and load torque from the stator currents and voltages, behind
//! one trait, [`Observer`], that the drive is generic over.
//!
//! | observer | file | paper |
//! |---|---|---|
//! | [`SlidingObserver`](sliding::SlidingObserver) (velocity or torque) | `sliding.rs` | Horng & Chin eqs (20)-(23), (34), (35) |
//! | [`FluxPll`](flux_speed::FluxPll) | `flux.rs`, `pll.rs`, `flux_speed.rs` | Ortega et al. eq (9), Sec V iii |
//! | [`FluxIi`](flux_speed::FluxIi) | `flux.rs`, `ii.rs`, `flux_speed.rs` | Ortega et al. eqs (9), (26)-(30) |

use crate::frames::{AlphaBeta, SinCos};

pub mod flux;
pub mod flux_speed;
pub mod ii;
pub mod pll;
pub mod sliding;

/// An observer's [`Observer::residual`] at the edge of lock: below it the observer's model fits
/// the measurements, above it the estimate is lost. The drive's supervision judges lock on
/// fractions of it (`drive/supervision.rs`: locked below ¼, lost at ½).
pub const EDGE_OF_LOCK: f32 = 1.0;

/// The parts of an observer's read-out that a drive may run at a lower rate than its state
/// equations (the drive runs them at 1 kHz in its 1 kHz task, `Drive::tick`); a caller that
/// wants the estimates every sample runs both after each [`Observer::update`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReadOut {
    /// The angle read-out (an arctangent, for the flux observers).
    Angle,
    /// The speed (and load) estimator that follows the angle (PLL, I&I).
    Speed,
}

/// A known rotor state, to seed an observer with.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Rotor {
    /// Electrical angle θ_e \[rad].
    pub theta_e: f32,
    /// Mechanical speed ω_m \[rad/s].
    pub omega_m: f32,
    /// Load torque τ_L \[N·m] (used by the observers that estimate it).
    pub load_nm: f32,
}

/// A rotor observer: settings (`self`, built once, per-sample coefficients) apart from its
/// running state ([`Observer::State`]).
///
/// Each sample the drive calls [`Observer::update`] with the currents measured now and the
/// voltage applied over the period that just ended, and the [`ReadOut`]s at 1 kHz; the
/// estimates are read with the other methods. Angles electrical, speeds mechanical.
pub trait Observer {
    /// Running state; `Default` is the state before the first sample.
    type State: Copy + Default + core::fmt::Debug + PartialEq;

    /// One sample: `i_ab` measured now \[A], `v_ab` applied over the period that just ended
    /// \[V]. Returns false, leaving the state untouched, when an input is not finite or the
    /// update would not be.
    fn update(&self, st: &mut Self::State, i_ab: AlphaBeta, v_ab: AlphaBeta) -> bool;

    /// One [`ReadOut`] (nothing, for observers whose estimates come out of `update`).
    fn read_out(&self, _st: &mut Self::State, _part: ReadOut) {}

    /// θ̂_e \[rad] in (−π, π], as of the last angle read-out.
    fn theta_e(&self, st: &Self::State) -> f32;

    /// sin/cos of θ̂_e at the last sample.
    fn sin_cos(&self, st: &Self::State) -> SinCos;

    /// sin/cos of the angle the coming period's voltage is applied at: `frame` (this
    /// observer's [`Observer::sin_cos`], which the caller has) turned by `lead` (the
    /// controller's output rotation at its speed, `Foc::output_rotation`). An observer that
    /// keeps that angle itself returns its own.
    fn sin_cos_output(&self, _st: &Self::State, frame: SinCos, lead: SinCos) -> SinCos {
        frame.rotated(lead)
    }

    /// ω̂_m \[rad/s].
    fn omega_m(&self, st: &Self::State) -> f32;

    /// τ̂_L \[N·m], for the observers that estimate the load torque.
    fn load_nm(&self, _st: &Self::State) -> Option<f32> {
        None
    }

    /// Restarts the observer at a known rotor state, `i_ab` the currents measured now \[A].
    fn seed(&self, st: &mut Self::State, i_ab: AlphaBeta, rotor: Rotor);

    /// The observer's own evidence of lock, from its own signals (not from another
    /// estimate): 0 when its model fits the measurements, 1 at the edge of lock, above it lost
    /// (each observer's implementation says what its 1 means). As of the last sample.
    fn residual(&self, st: &Self::State) -> f32;

    /// The lowest |ω̂_m| \[rad/s] at which this observer's estimate may drive the controller;
    /// below it the drive neither uses nor judges it (0: any speed; infinite: never).
    fn min_speed_m(&self) -> f32 {
        0.0
    }
}
