//! The board's sensors: the phase currents with offset, seeded Gaussian noise and ADC
//! quantisation ([`CurrentSensor`]); the bus and terminal voltages, read exactly
//! ([`VoltageSensors`]).

use pmsm_sensorless::frames::{Abc, AlphaBeta};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Phase-current measurement: offset, seeded Gaussian noise, then quantisation.
#[derive(Clone, Debug)]
pub struct CurrentSensor {
    /// Offset added to each phase \[A].
    pub offset_a: [f64; 3],
    /// Noise standard deviation per phase \[A] (0 = none).
    pub noise_sigma_a: f64,
    /// Quantisation step \[A] (0 = none).
    pub lsb_a: f64,
    rng: ChaCha8Rng,
    normal: Option<Normal<f64>>,
}

impl CurrentSensor {
    /// A sensor; `seed` fixes the noise sequence. Errors if `noise_sigma_a` is negative or
    /// not finite.
    pub fn new(
        offset_a: [f64; 3],
        noise_sigma_a: f64,
        lsb_a: f64,
        seed: u64,
    ) -> anyhow::Result<Self> {
        anyhow::ensure!(
            noise_sigma_a.is_finite() && noise_sigma_a >= 0.0,
            "noise sigma must be a finite number >= 0 A, got {noise_sigma_a}"
        );
        anyhow::ensure!(
            lsb_a.is_finite() && lsb_a >= 0.0,
            "ADC step must be a finite number >= 0 A, got {lsb_a}"
        );
        let normal = if noise_sigma_a > 0.0 {
            Some(Normal::new(0.0, noise_sigma_a)?)
        } else {
            None
        };
        Ok(Self {
            offset_a,
            noise_sigma_a,
            lsb_a,
            rng: ChaCha8Rng::seed_from_u64(seed),
            normal,
        })
    }

    /// The sampled phase currents the controller sees.
    pub fn measure(&mut self, i_abc: [f64; 3]) -> Abc {
        let m: [f64; 3] = std::array::from_fn(|k| {
            let mut x = i_abc[k] + self.offset_a[k];
            if let Some(n) = &self.normal {
                x += n.sample(&mut self.rng);
            }
            if self.lsb_a > 0.0 {
                x = (x / self.lsb_a).round() * self.lsb_a;
            }
            x
        });
        Abc::new(m[0] as f32, m[1] as f32, m[2] as f32)
    }
}

/// The board's voltage sensing: the DC bus always, the terminals where the board has the
/// dividers; both exact (to f32).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VoltageSensors {
    /// The terminal voltage is sensed.
    pub terminal: bool,
}

impl VoltageSensors {
    /// The bus voltage reading \[V].
    pub fn bus(&self, v_dc: f64) -> f32 {
        v_dc as f32
    }

    /// The terminal voltage reading `v_ab` \[V], where the board senses it.
    pub fn terminal(&self, v_ab: AlphaBeta) -> Option<AlphaBeta> {
        self.terminal.then_some(v_ab)
    }
}
