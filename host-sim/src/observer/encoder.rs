//! The ideal encoder as an observer (the sensored baseline, and the state the bare loop
//! starts its observers at), and what the simulator shows of an observer beyond the core's
//! trait ([`Diagnostics`]: the sliding observer's internals for the paper's figures).

use super::SlidingDiag;
use pmsm_sensorless::frames::{AlphaBeta, SinCos};
use pmsm_sensorless::observer::flux_speed::{FluxIi, FluxPll};
use pmsm_sensorless::observer::sliding::SlidingObserver;
use pmsm_sensorless::observer::{Observer, Rotor};

/// The ideal encoder as an observer: its estimate is the rotor state it was last seeded with
/// (the bare-observer loop seeds it with the true state every sample).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Encoder;

/// The encoder's reading.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EncoderState {
    rotor: Rotor,
    sc: SinCos,
}

impl Default for EncoderState {
    fn default() -> Self {
        Self {
            rotor: Rotor::default(),
            sc: SinCos::ZERO,
        }
    }
}

impl Observer for Encoder {
    type State = EncoderState;
    fn update(&self, _st: &mut EncoderState, _i_ab: AlphaBeta, _v_ab: AlphaBeta) -> bool {
        true
    }
    fn theta_e(&self, st: &EncoderState) -> f32 {
        st.rotor.theta_e
    }
    fn sin_cos(&self, st: &EncoderState) -> SinCos {
        st.sc
    }
    fn omega_m(&self, st: &EncoderState) -> f32 {
        st.rotor.omega_m
    }
    /// The true rotor: no evidence against it.
    fn residual(&self, _st: &Self::State) -> f32 {
        0.0
    }

    fn seed(&self, st: &mut EncoderState, _i_ab: AlphaBeta, rotor: Rotor) {
        *st = EncoderState {
            rotor,
            sc: SinCos::of(rotor.theta_e),
        };
    }
}

/// What the simulator shows of an observer beyond the core trait (the paper's figures).
pub trait Diagnostics: Observer {
    /// The sliding observer's internals.
    fn sliding_diag(&self, _st: &Self::State) -> Option<SlidingDiag> {
        None
    }
}

impl Diagnostics for Encoder {}
impl Diagnostics for FluxPll {}
impl Diagnostics for FluxIi {}
impl Diagnostics for SlidingObserver {
    fn sliding_diag(&self, st: &Self::State) -> Option<SlidingDiag> {
        Some(SlidingDiag {
            s_ab: st.s,
            ks: self.sliding_gain(st.omega_m),
        })
    }
}
