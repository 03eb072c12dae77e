//! The observers the simulator runs, and the bare-observer loop of the papers' experiments:
//! FOC on one core observer ([`pmsm_sensorless::observer::Observer`]), started at the
//! encoder's state, no drive modes around it.

use pmsm_sensorless::foc::{Foc, FocInput, FocState};
use pmsm_sensorless::frames::{Abc, AlphaBeta, SinCos};
use pmsm_sensorless::motor::MotorParams;
use pmsm_sensorless::observer::flux::FluxConfig;
use pmsm_sensorless::observer::flux_speed::{FluxIi, FluxPll};
use pmsm_sensorless::observer::ii::IiConfig;
use pmsm_sensorless::observer::pll::PllConfig;
use pmsm_sensorless::observer::sliding::{SlidingConfig, SlidingObserver};
use pmsm_sensorless::observer::{Observer, ReadOut, Rotor};
use pmsm_sensorless::param::ParamError;

/// What the controller used this period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Electrical angle \[rad].
    pub theta_e: f32,
    /// Mechanical speed \[rad/s].
    pub omega_m: f32,
    /// Load torque \[N·m], for observers that estimate it.
    pub load_nm: Option<f32>,
    /// Sliding-observer internals, for the paper's figures.
    pub sliding: Option<SlidingDiag>,
    /// The estimate is the observer's own (not a seed from the true state).
    pub sensorless: bool,
}

/// What a sliding observer shows of itself each sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlidingDiag {
    /// Sliding variable `S = î − i` \[A].
    pub s_ab: AlphaBeta,
    /// Sliding gain in use \[A/s].
    pub ks: f32,
}

/// Observers selectable with `--observer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObserverKind {
    /// Ideal encoder: the sensored baseline.
    Encoder,
    /// Horng & Chin velocity observer, eqs (20)-(23).
    SlidingVelocity,
    /// Horng & Chin torque observer, eqs (20)-(22), (34), (35), with load compensation.
    SlidingTorque,
    /// Ortega et al. gradient flux observer, eq (9), with the PLL of Sec V iii for speed.
    Flux,
    /// Ortega et al. flux observer for the angle, I&I observer (30) for speed and load
    /// torque, with load compensation.
    FluxIi,
}

/// What an observer is built from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObserverSetup {
    /// The controller's motor model.
    pub motor: MotorParams,
    /// Update rate \[Hz].
    pub rate_hz: f32,
    /// Settings replacing the paper's defaults of a sliding observer.
    pub sliding: Option<SlidingConfig>,
    /// Lowest operating speed the flux observer's γ is chosen for (Proposition 4) \[rpm].
    pub min_speed_rpm: f32,
    /// γ replacing the recommended one.
    pub gamma: Option<f32>,
}

/// PLL natural frequency \[Hz] and damping for the `flux` observer's speed.
pub const PLL_BANDWIDTH_HZ: f32 = 50.0;
/// PLL damping.
pub const PLL_DAMPING: f32 = 1.0;

impl ObserverSetup {
    /// The flux observer's settings.
    pub fn flux_config(&self) -> FluxConfig {
        let mut cfg = FluxConfig::new(self.motor, self.rate_hz, self.min_speed_rpm);
        if let Some(g) = self.gamma {
            cfg.gamma = g;
        }
        cfg
    }
}

impl ObserverKind {
    /// Every observer, in listing order.
    pub const ALL: [ObserverKind; 5] = [
        ObserverKind::Encoder,
        ObserverKind::SlidingVelocity,
        ObserverKind::SlidingTorque,
        ObserverKind::Flux,
        ObserverKind::FluxIi,
    ];

    /// Name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ObserverKind::Encoder => "encoder",
            ObserverKind::SlidingVelocity => "sliding-velocity",
            ObserverKind::SlidingTorque => "sliding-torque",
            ObserverKind::Flux => "flux",
            ObserverKind::FluxIi => "flux-ii",
        }
    }

    /// One line for `pmsm-sim list`.
    pub fn description(self) -> &'static str {
        match self {
            ObserverKind::Encoder => "ideal encoder (sensored FOC baseline): true θ_e and ω_m",
            ObserverKind::SlidingVelocity => {
                "Horng & Chin velocity observer, eqs (20)-(23): θ̂, ω̂ (sensorless)"
            }
            ObserverKind::SlidingTorque => {
                "Horng & Chin torque observer, eqs (20)-(22), (34), (35): θ̂, ω̂, τ̂_L, load compensated"
            }
            ObserverKind::Flux => "Ortega et al. gradient flux observer, eq (9): θ̂; PLL (Sec V iii): ω̂",
            ObserverKind::FluxIi => {
                "Ortega et al. flux observer (9): θ̂; I&I observer (30): ω̂, τ̂_L, load compensated"
            }
        }
    }

    /// The observer called `name`.
    pub fn from_name(name: &str) -> anyhow::Result<Self> {
        Self::ALL
            .into_iter()
            .find(|o| o.name() == name)
            .ok_or_else(|| {
                let names: Vec<_> = Self::ALL.iter().map(|o| o.name()).collect();
                anyhow::anyhow!("unknown observer '{name}' (known: {})", names.join(", "))
            })
    }

    /// The paper's default settings for this kind (`None` for the others).
    pub fn sliding_config(self, motor: MotorParams, rate_hz: f32) -> Option<SlidingConfig> {
        let cfg = match self {
            ObserverKind::Encoder | ObserverKind::Flux | ObserverKind::FluxIi => return None,
            ObserverKind::SlidingVelocity => SlidingConfig::velocity(motor),
            ObserverKind::SlidingTorque => SlidingConfig::torque(motor),
        };
        Some(SlidingConfig { rate_hz, ..cfg })
    }

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
        Ok(match self {
            ObserverKind::Encoder => Bare::Encoder(BareLoop::new(Encoder, foc)),
            ObserverKind::SlidingVelocity | ObserverKind::SlidingTorque => {
                let cfg = setup
                    .sliding
                    .or_else(|| self.sliding_config(setup.motor, setup.rate_hz))
                    .ok_or_else(|| anyhow::anyhow!("no sliding settings"))?;
                let obs = cfg.build().map_err(|e| err("sliding observer", e))?;
                Bare::Sliding(BareLoop::new(obs, foc))
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
            Bare::FluxPll(b) => b.step(input),
            Bare::FluxIi(b) => b.step(input),
        }
    }
}
