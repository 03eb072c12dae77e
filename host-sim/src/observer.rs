//! The observer slot of the simulated drive: whatever gives the controller θ̂_e and ω̂_m.

use pmsm_sensorless::frames::{AlphaBeta, SinCos};
use pmsm_sensorless::motor::MotorParams;
use pmsm_sensorless::observer::flux::{FluxConfig, FluxObserver, FluxState};
use pmsm_sensorless::observer::ii::{IiConfig, IiObserver, IiState};
use pmsm_sensorless::observer::pll::{Pll, PllConfig, PllState};
use pmsm_sensorless::observer::sliding::{SlidingConfig, SlidingObserver, SlidingState};

/// What the slot sees each control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlotInput {
    /// Measured stator current [A].
    pub i_ab: AlphaBeta,
    /// Stator voltage applied over the previous period [V].
    pub v_ab_last: AlphaBeta,
    /// Ideal encoder: true electrical angle at the sample instant, wrapped to (−π, π] [rad].
    pub encoder_theta_e: f32,
    /// Ideal encoder: true mechanical speed [rad/s].
    pub encoder_omega_m: f32,
}

impl SlotInput {
    /// The ideal encoder's reading as an estimate.
    pub fn encoder(&self) -> Estimate {
        Estimate {
            theta_e: self.encoder_theta_e,
            omega_m: self.encoder_omega_m,
            load_nm: None,
            sliding: None,
        }
    }
}

/// What the slot gives the controller.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Electrical angle [rad].
    pub theta_e: f32,
    /// Mechanical speed [rad/s].
    pub omega_m: f32,
    /// Load torque [N·m], for observers that estimate it.
    pub load_nm: Option<f32>,
    /// Sliding-observer internals, for the paper's figures.
    pub sliding: Option<SlidingDiag>,
}

/// What a sliding observer shows of itself each sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SlidingDiag {
    /// Sliding variable `S = î − i` [A].
    pub s_ab: AlphaBeta,
    /// Sliding gain in use [A/s].
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
    /// Update rate [Hz].
    pub rate_hz: f32,
    /// Settings replacing the paper's defaults of a sliding observer.
    pub sliding: Option<SlidingConfig>,
    /// Lowest operating speed the flux observer's γ is chosen for (Proposition 4) [rpm].
    pub min_speed_rpm: f32,
    /// γ replacing the recommended one.
    pub gamma: Option<f32>,
}

/// PLL natural frequency [Hz] and damping for the `flux` observer's speed.
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

    /// The paper's default settings for this kind (`None` for the encoder).
    pub fn sliding_config(self, motor: MotorParams, rate_hz: f32) -> Option<SlidingConfig> {
        let cfg = match self {
            ObserverKind::Encoder | ObserverKind::Flux | ObserverKind::FluxIi => return None,
            ObserverKind::SlidingVelocity => SlidingConfig::velocity(motor),
            ObserverKind::SlidingTorque => SlidingConfig::torque(motor),
        };
        Some(SlidingConfig { rate_hz, ..cfg })
    }

    /// A fresh observer of this kind; errors name the bad setting.
    pub fn build(self, setup: &ObserverSetup) -> anyhow::Result<Box<dyn Observer>> {
        let err =
            |what: &str, e: pmsm_sensorless::motor::ParamError| anyhow::anyhow!("{what}: {e}");
        Ok(match self {
            ObserverKind::Encoder => Box::new(Encoder),
            ObserverKind::SlidingVelocity | ObserverKind::SlidingTorque => {
                let cfg = setup
                    .sliding
                    .or_else(|| self.sliding_config(setup.motor, setup.rate_hz))
                    .ok_or_else(|| anyhow::anyhow!("no sliding settings"))?;
                Box::new(Sliding::new(&cfg)?)
            }
            ObserverKind::Flux => Box::new(FluxPll {
                flux: setup
                    .flux_config()
                    .build()
                    .map_err(|e| err("flux observer", e))?,
                flux_state: FluxState::default(),
                pll: PllConfig {
                    rate_hz: setup.rate_hz,
                    bandwidth_hz: PLL_BANDWIDTH_HZ,
                    damping: PLL_DAMPING,
                }
                .build()
                .map_err(|e| err("PLL", e))?,
                pll_state: PllState::default(),
                n: setup.motor.n(),
            }),
            ObserverKind::FluxIi => Box::new(FluxIi {
                flux: setup
                    .flux_config()
                    .build()
                    .map_err(|e| err("flux observer", e))?,
                flux_state: FluxState::default(),
                ii: IiConfig::new(setup.motor, setup.rate_hz)
                    .build()
                    .map_err(|e| err("I&I observer", e))?,
                ii_state: IiState::default(),
                torque_constant: setup.motor.torque_constant(),
                torque_last: 0.0,
            }),
        })
    }
}

/// An observer in the slot.
pub trait Observer {
    /// One control period: the estimate the controller uses for this period.
    fn update(&mut self, input: &SlotInput) -> Estimate;
    /// Whether the speed loop feeds forward the estimated load torque (Horng Fig 4).
    fn compensates_load(&self) -> bool {
        false
    }
    /// Sets the estimate to the encoder's reading (a hand-over from a sensored start).
    fn reset(&mut self, _input: &SlotInput) {}
}

/// The ideal encoder.
struct Encoder;

impl Observer for Encoder {
    fn update(&mut self, input: &SlotInput) -> Estimate {
        input.encoder()
    }
}

/// A Horng & Chin sliding observer in the slot.
pub struct Sliding {
    observer: SlidingObserver,
    state: SlidingState,
    torque: bool,
}

impl Sliding {
    /// Builds the observer; errors name the bad setting.
    pub fn new(cfg: &SlidingConfig) -> anyhow::Result<Self> {
        Ok(Self {
            observer: cfg
                .build()
                .map_err(|e| anyhow::anyhow!("sliding observer: {e}"))?,
            state: SlidingState::default(),
            torque: cfg.lambda_tau_hz > 0.0,
        })
    }
}

impl Observer for Sliding {
    fn update(&mut self, input: &SlotInput) -> Estimate {
        self.observer
            .update(&mut self.state, input.i_ab, input.v_ab_last);
        let st = &self.state;
        Estimate {
            theta_e: st.theta_e,
            omega_m: st.omega_m,
            load_nm: self.torque.then_some(st.load_nm),
            sliding: Some(SlidingDiag {
                s_ab: st.s,
                ks: self.observer.sliding_gain(st.omega_m),
            }),
        }
    }

    fn compensates_load(&self) -> bool {
        self.torque
    }

    fn reset(&mut self, input: &SlotInput) {
        self.observer.reset(
            &mut self.state,
            input.i_ab,
            input.encoder_theta_e,
            input.encoder_omega_m,
        );
    }
}

/// Ortega's flux observer with the PLL speed estimator.
struct FluxPll {
    flux: FluxObserver,
    flux_state: FluxState,
    pll: Pll,
    pll_state: PllState,
    n: f32,
}

impl Observer for FluxPll {
    fn update(&mut self, input: &SlotInput) -> Estimate {
        self.flux
            .update(&mut self.flux_state, input.i_ab, input.v_ab_last);
        let omega_e = self
            .pll
            .update(&mut self.pll_state, self.flux_state.theta_e);
        Estimate {
            theta_e: self.flux_state.theta_e,
            omega_m: omega_e / self.n,
            load_nm: None,
            sliding: None,
        }
    }

    fn reset(&mut self, input: &SlotInput) {
        self.flux
            .reset(&mut self.flux_state, input.i_ab, input.encoder_theta_e);
        self.pll.reset(
            &mut self.pll_state,
            input.encoder_theta_e,
            input.encoder_omega_m * self.n,
        );
    }
}

/// Ortega's flux observer for the angle and the I&I observer for speed and load torque.
struct FluxIi {
    flux: FluxObserver,
    flux_state: FluxState,
    ii: IiObserver,
    ii_state: IiState,
    torque_constant: f32,
    /// Electromagnetic torque `N Φ i_q` at the previous sample [N·m].
    torque_last: f32,
}

impl Observer for FluxIi {
    fn update(&mut self, input: &SlotInput) -> Estimate {
        self.flux
            .update(&mut self.flux_state, input.i_ab, input.v_ab_last);
        let sc = SinCos::of(self.flux_state.theta_e);
        // Forward Euler over the period that just ended uses the torque at its start.
        self.ii
            .update(&mut self.ii_state, (sc.sin, sc.cos), self.torque_last);
        self.torque_last = self.torque_constant * input.i_ab.to_dq(sc).q;
        let est = self.ii.estimate(&self.ii_state);
        Estimate {
            theta_e: self.flux_state.theta_e,
            omega_m: est.omega_m,
            load_nm: Some(est.load_nm),
            sliding: None,
        }
    }

    fn compensates_load(&self) -> bool {
        true
    }

    fn reset(&mut self, input: &SlotInput) {
        self.flux
            .reset(&mut self.flux_state, input.i_ab, input.encoder_theta_e);
        let sc = SinCos::of(input.encoder_theta_e);
        self.ii.reset(
            &mut self.ii_state,
            (sc.sin, sc.cos),
            input.encoder_omega_m,
            0.0,
        );
        self.torque_last = self.torque_constant * input.i_ab.to_dq(sc).q;
    }
}
