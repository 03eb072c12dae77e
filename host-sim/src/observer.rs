//! The observer slot of the simulated drive: whatever gives the controller θ̂_e and ω̂_m.

use pmsm_sensorless::frames::AlphaBeta;
use pmsm_sensorless::motor::MotorParams;
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
}

impl ObserverKind {
    /// Every observer, in listing order.
    pub const ALL: [ObserverKind; 3] = [
        ObserverKind::Encoder,
        ObserverKind::SlidingVelocity,
        ObserverKind::SlidingTorque,
    ];

    /// Name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ObserverKind::Encoder => "encoder",
            ObserverKind::SlidingVelocity => "sliding-velocity",
            ObserverKind::SlidingTorque => "sliding-torque",
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
            ObserverKind::Encoder => return None,
            ObserverKind::SlidingVelocity => SlidingConfig::velocity(motor),
            ObserverKind::SlidingTorque => SlidingConfig::torque(motor),
        };
        Some(SlidingConfig { rate_hz, ..cfg })
    }

    /// A fresh observer of this kind, using the controller's motor model at `rate_hz`;
    /// `sliding` replaces the paper's default settings of a sliding observer.
    pub fn build(
        self,
        motor: MotorParams,
        rate_hz: f32,
        sliding: Option<SlidingConfig>,
    ) -> anyhow::Result<Box<dyn Observer>> {
        match (sliding, self.sliding_config(motor, rate_hz)) {
            (_, None) => Ok(Box::new(Encoder)),
            (Some(cfg), Some(_)) | (None, Some(cfg)) => Ok(Box::new(Sliding::new(&cfg)?)),
        }
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
        Estimate {
            theta_e: input.encoder_theta_e,
            omega_m: input.encoder_omega_m,
            load_nm: None,
            sliding: None,
        }
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
