//! The bare-observer loop of the papers' experiments: FOC on one core observer
//! ([`pmsm_sensorless::observer::Observer`]), held at the encoder's state until the run is
//! sensorless, no drive modes around it.

use super::encoder::{Diagnostics, Encoder};
use super::fixed::SlidingQ;
use super::{Estimate, ObserverKind, ObserverSetup, PLL_BANDWIDTH_HZ, PLL_DAMPING};
use pmsm_sensorless::foc::{Foc, FocInput, FocState};
use pmsm_sensorless::frames::{Abc, AlphaBeta, SinCos};
use pmsm_sensorless::observer::flux_speed::{FluxIi, FluxPll};
use pmsm_sensorless::observer::ii::IiConfig;
use pmsm_sensorless::observer::pll::PllConfig;
use pmsm_sensorless::observer::sliding::SlidingObserver;
use pmsm_sensorless::observer::{Observer, ReadOut, Rotor};
use pmsm_sensorless::param::ParamError;

impl ObserverKind {
    /// The bare-observer loop on a fresh observer of this kind with `foc`; errors name the
    /// bad setting.
    pub fn bare(self, setup: &ObserverSetup, foc: Foc) -> anyhow::Result<Bare> {
        let err = |what: &str, e: ParamError| anyhow::anyhow!("{what}: {e}");
        let flux = || {
            setup
                .flux_config()
                .build()
                .map_err(|e| err("flux observer", e))
        };
        let sliding = matches!(
            self,
            ObserverKind::SlidingVelocity | ObserverKind::SlidingTorque
        );
        anyhow::ensure!(
            sliding || setup.fixed_point.is_none(),
            "fixed point: the sliding observers only (sliding-torque, sliding-velocity), not {}",
            self.name()
        );
        Ok(match self {
            ObserverKind::Encoder => Bare::Encoder(BareLoop::new(Encoder, foc)),
            ObserverKind::SlidingVelocity | ObserverKind::SlidingTorque => {
                let cfg = setup
                    .sliding
                    .or_else(|| self.sliding_config(setup.motor, setup.rate_hz))
                    .ok_or_else(|| anyhow::anyhow!("no sliding settings"))?;
                match setup.fixed_point {
                    Some(pu) => {
                        let obs = SlidingQ::build(&cfg, pu)
                            .map_err(|e| err("fixed-point sliding observer", e))?;
                        Bare::SlidingQ(BareLoop::new(obs, foc))
                    }
                    None => {
                        let obs = cfg.build().map_err(|e| err("sliding observer", e))?;
                        Bare::Sliding(BareLoop::new(obs, foc))
                    }
                }
            }
            ObserverKind::Flux => {
                let pll = PllConfig {
                    rate_hz: setup.rate_hz,
                    bandwidth_hz: PLL_BANDWIDTH_HZ,
                    damping: PLL_DAMPING,
                }
                .build()
                .map_err(|e| err("PLL", e))?;
                Bare::FluxPll(BareLoop::new(
                    FluxPll::new(flux()?, pll, setup.motor.n()),
                    foc,
                ))
            }
            ObserverKind::FluxIi => {
                let ii = IiConfig::new(setup.motor, setup.rate_hz)
                    .build()
                    .map_err(|e| err("I&I observer", e))?;
                Bare::FluxIi(BareLoop::new(
                    FluxIi::new(flux()?, ii, setup.motor.torque_constant()),
                    foc,
                ))
            }
        })
    }
}

/// FOC on one observer: the speed loop every fourth sample on its speed (with its load
/// estimate fed forward, Horng & Chin Fig 4, where it has one), the current loop in its
/// frame, the voltage at its output angle.
#[derive(Clone, Copy, Debug)]
pub struct BareLoop<O: Observer> {
    observer: O,
    state: O::State,
    foc: Foc,
    foc_state: FocState,
    /// Sensorless: the observer runs on its own; before, it is held at the true state.
    sensorless: bool,
}

/// One sample of the bare loop.
#[derive(Clone, Copy, Debug)]
pub struct BareInput {
    /// Measured phase currents \[A].
    pub i_abc: Abc,
    /// Bus \[V].
    pub v_bus: f32,
    /// Voltage applied over the period that just ended \[V].
    pub v_ab_last: AlphaBeta,
    /// The true rotor state (ideal encoder), load unknown (0).
    pub truth: Rotor,
    /// Speed command \[rad/s].
    pub omega_m_ref: f32,
    /// From this |true speed| on the observer runs on its own \[rad/s].
    pub sensorless_from: f32,
}

impl<O: Diagnostics> BareLoop<O> {
    fn new(observer: O, foc: Foc) -> Self {
        Self {
            observer,
            state: O::State::default(),
            foc,
            foc_state: FocState::default(),
            sensorless: false,
        }
    }

    /// One period: the observer (update and both read-outs) or, before the run is
    /// sensorless, the observer seeded at the true state; then FOC on its estimate.
    fn step(&mut self, input: &BareInput) -> (pmsm_sensorless::foc::FocOutput, Estimate) {
        let o = &self.observer;
        let i_ab = input.i_abc.to_alpha_beta();
        let sensorless = self.sensorless;
        if sensorless {
            o.update(&mut self.state, i_ab, input.v_ab_last);
            o.read_out(&mut self.state, ReadOut::Angle);
            o.read_out(&mut self.state, ReadOut::Speed);
        } else {
            o.seed(&mut self.state, i_ab, input.truth);
            self.sensorless = input.truth.omega_m.abs() >= input.sensorless_from;
        }
        let st = &self.state;
        let est = Estimate {
            theta_e: o.theta_e(st),
            omega_m: o.omega_m(st),
            load_nm: o.load_nm(st),
            sliding: o.sliding_diag(st),
            sensorless,
        };
        // The papers' controller takes θ̂ itself: sin/cos of it by the core's polynomial (an
        // observer's own sin/cos of θ̂ differs from it by rounding, which a run that has lost
        // lock amplifies), the output angle turned by the controller's lead.
        let sc = SinCos::of(est.theta_e);
        let sc_out = self.foc.output_angle(sc, est.omega_m);
        let out = self.foc_state.step_at(
            &self.foc,
            &FocInput {
                i_abc: input.i_abc,
                v_bus: input.v_bus,
                theta_e: est.theta_e,
                omega_m: est.omega_m,
                omega_m_ref: input.omega_m_ref,
                torque_ff_nm: est.load_nm.unwrap_or(0.0),
            },
            sc,
            sc_out,
        );
        (out, est)
    }
}

/// The bare loop on any of the observers.
#[derive(Clone, Debug)]
pub enum Bare {
    /// The ideal encoder (never sensorless).
    Encoder(BareLoop<Encoder>),
    /// A Horng & Chin sliding observer.
    Sliding(BareLoop<SlidingObserver>),
    /// A Horng & Chin sliding observer in fixed point.
    SlidingQ(BareLoop<SlidingQ>),
    /// The flux observer with the PLL.
    FluxPll(BareLoop<FluxPll>),
    /// The flux observer with the I&I observer.
    FluxIi(BareLoop<FluxIi>),
}

impl Bare {
    /// Starts the observer on its own from the first sample (a cold start from its zero
    /// state; the encoder stays the encoder).
    pub fn start_cold(&mut self) {
        match self {
            Bare::Encoder(_) => {}
            Bare::Sliding(b) => b.sensorless = true,
            Bare::SlidingQ(b) => b.sensorless = true,
            Bare::FluxPll(b) => b.sensorless = true,
            Bare::FluxIi(b) => b.sensorless = true,
        }
    }

    /// One period (see [`BareLoop`]).
    pub fn step(&mut self, input: &BareInput) -> (pmsm_sensorless::foc::FocOutput, Estimate) {
        match self {
            Bare::Encoder(b) => {
                // Held at the encoder's reading every sample.
                b.sensorless = false;
                b.step(input)
            }
            Bare::Sliding(b) => b.step(input),
            Bare::SlidingQ(b) => b.step(input),
            Bare::FluxPll(b) => b.step(input),
            Bare::FluxIi(b) => b.step(input),
        }
    }
}
