//! The observer slot of the simulated drive: whatever gives the controller θ̂_e and ω̂_m.

use pmsm_sensorless::frames::AlphaBeta;

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
}

/// Observers selectable with `--observer`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ObserverKind {
    /// Ideal encoder: the sensored baseline.
    Encoder,
}

impl ObserverKind {
    /// Every observer, in listing order.
    pub const ALL: [ObserverKind; 1] = [ObserverKind::Encoder];

    /// Name on the command line.
    pub fn name(self) -> &'static str {
        match self {
            ObserverKind::Encoder => "encoder",
        }
    }

    /// One line for `pmsm-sim list`.
    pub fn description(self) -> &'static str {
        match self {
            ObserverKind::Encoder => "ideal encoder (sensored FOC baseline): true θ_e and ω_m",
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

    /// A fresh observer of this kind.
    pub fn build(self) -> Box<dyn Observer> {
        match self {
            ObserverKind::Encoder => Box::new(Encoder),
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
}

/// The ideal encoder.
struct Encoder;

impl Observer for Encoder {
    fn update(&mut self, input: &SlotInput) -> Estimate {
        Estimate {
            theta_e: input.encoder_theta_e,
            omega_m: input.encoder_omega_m,
            load_nm: None,
        }
    }
}
