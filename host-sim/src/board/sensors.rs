//! The board's sensors: the phase currents with offset, seeded Gaussian noise and ADC
//! quantisation ([`CurrentSensor`]), one of which may fail ([`SensorFault`]); the bus and
//! terminal voltages, read exactly ([`VoltageSensors`]).

use pmsm_sensorless::frames::{Abc, AlphaBeta};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// How one phase's current sensor fails (an injection, `[inject] kind = "sensor_*"`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SensorFault {
    /// The reading holds the last one taken before the failure (a frozen amplifier or ADC
    /// channel).
    Stuck,
    /// The sensor sees no current: its reading is its offset and noise alone (a shunt
    /// bypassed, an amplifier's input open).
    Zero,
    /// The sensor sees the current times this gain (a drifted shunt or amplifier gain).
    Gain(f64),
}

/// Phase-current measurement: offset, seeded Gaussian noise, then quantisation; one phase's
/// sensor possibly failed ([`CurrentSensor::fail`]).
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
    /// The failed phase (0..3) and how, if any.
    failed: Option<(usize, SensorFault)>,
    /// The last readings \[A] (a stuck sensor holds its own).
    last: [f64; 3],
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
            failed: None,
            last: [0.0; 3],
        })
    }

    /// From the next reading on, phase `phase`'s (0..3: a, b, c) sensor has failed so.
    pub fn fail(&mut self, phase: usize, fault: SensorFault) {
        self.failed = Some((phase.min(2), fault));
    }

    /// The sampled phase currents the controller sees.
    pub fn measure(&mut self, i_abc: [f64; 3]) -> Abc {
        let failed = self.failed;
        let seen = |k: usize| match failed {
            Some((p, SensorFault::Zero)) if p == k => 0.0,
            Some((p, SensorFault::Gain(g))) if p == k => g * i_abc[k],
            _ => i_abc[k],
        };
        // The noise is drawn for every phase, a stuck one too: the other phases' noise
        // sequence stays the healthy board's.
        let mut m: [f64; 3] = std::array::from_fn(|k| {
            let mut x = seen(k) + self.offset_a[k];
            if let Some(n) = &self.normal {
                x += n.sample(&mut self.rng);
            }
            if self.lsb_a > 0.0 {
                x = (x / self.lsb_a).round() * self.lsb_a;
            }
            x
        });
        if let Some((p, SensorFault::Stuck)) = failed {
            m[p] = self.last[p];
        }
        self.last = m;
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
