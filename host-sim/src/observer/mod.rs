//! The observers the simulator runs ([`ObserverKind`], built from an [`ObserverSetup`]), and
//! what the controller used of one each period ([`Estimate`]). The ideal encoder and the
//! simulator's view of an observer's internals are in [`encoder`]; the bare-observer loop of
//! the papers' experiments (FOC on one core observer, started at the encoder's state, no
//! drive modes around it) in [`bare`].

pub mod bare;
pub mod encoder;
pub mod fixed;

pub use bare::{Bare, BareInput, BareLoop};
pub use encoder::{Diagnostics, Encoder, EncoderState};

use pmsm_sensorless::fixed::pu::PerUnit;
use pmsm_sensorless::frames::AlphaBeta;
use pmsm_sensorless::motor::MotorParams;
use pmsm_sensorless::observer::flux::FluxConfig;
use pmsm_sensorless::observer::sliding::SlidingConfig;

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
    /// A sliding observer in fixed point in these bases (`fixed`); `None`: f32.
    pub fixed_point: Option<PerUnit>,
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
}
