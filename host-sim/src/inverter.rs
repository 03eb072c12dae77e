//! Averaged inverter and current sensing models.

use crate::plant::Supply;
use pmsm_sensorless::frames::Abc;
use pmsm_sensorless::svpwm::Duties;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, Normal};

/// Averaged two-level inverter: the pole voltage of a phase is `d·V_dc` over the period, less
/// the dead-time error `sign(i)·t_dead·f_pwm·V_dc`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inverter {
    /// DC bus voltage \[V].
    pub v_bus: f64,
    /// Dead time per switching transition \[s] (0 = ideal).
    pub dead_time_s: f64,
    /// PWM (switching) frequency \[Hz]; only matters with dead time.
    pub pwm_hz: f64,
}

/// The inverter holding one set of duties over a control period.
pub struct HeldDuties<'a> {
    /// Inverter.
    pub inverter: &'a Inverter,
    /// Duties held over the period.
    pub duties: [f64; 3],
    /// The αβ voltage without dead time (constant over the period) \[V].
    v_ab_ideal: (f64, f64),
}

impl HeldDuties<'_> {
    /// Phase-to-neutral average voltages for currents `i_abc` \[V].
    pub fn phase_voltages(&self, i_abc: [f64; 3]) -> [f64; 3] {
        let inv = self.inverter;
        let v_dt = inv.dead_time_s * inv.pwm_hz * inv.v_bus;
        let pole: [f64; 3] = std::array::from_fn(|k| {
            let sign = if i_abc[k] > 0.0 {
                1.0
            } else if i_abc[k] < 0.0 {
                -1.0
            } else {
                0.0
            };
            self.duties[k] * inv.v_bus - sign * v_dt
        });
        let mean = (pole[0] + pole[1] + pole[2]) / 3.0;
        pole.map(|v| v - mean)
    }
}

/// Amplitude-invariant Clarke in f64.
pub fn clarke(x: [f64; 3]) -> (f64, f64) {
    (
        (2.0 * x[0] - x[1] - x[2]) / 3.0,
        (x[1] - x[2]) / 3f64.sqrt(),
    )
}

/// Inverse amplitude-invariant Clarke in f64.
pub fn inverse_clarke(alpha: f64, beta: f64) -> [f64; 3] {
    let s3 = 3f64.sqrt() / 2.0;
    [alpha, -0.5 * alpha + s3 * beta, -0.5 * alpha - s3 * beta]
}

impl Supply for HeldDuties<'_> {
    fn v_alpha_beta(&self, i: (f64, f64), _e: (f64, f64)) -> (f64, f64) {
        if self.inverter.dead_time_s == 0.0 {
            return self.v_ab_ideal;
        }
        clarke(self.phase_voltages(inverse_clarke(i.0, i.1)))
    }
}

impl Inverter {
    /// Holds `duties` for a period.
    pub fn hold(&self, duties: Duties) -> HeldDuties<'_> {
        let duties = [duties.a as f64, duties.b as f64, duties.c as f64];
        let pole = duties.map(|d| d * self.v_bus);
        HeldDuties {
            inverter: self,
            duties,
            v_ab_ideal: clarke(pole),
        }
    }
}

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
