//! The averaged two-level inverter: over a PWM period the pole voltage of a phase is
//! `d·V_dc`, less the dead-time error `sign(i)·t_dead·f_pwm·V_dc`.

use super::Converter;
use crate::frames::{clarke, inverse_clarke};
use pmsm_sensorless::svpwm::Duties;

/// Averaged two-level inverter: the pole voltage of a phase is `d·V_dc` over the period, less
/// the dead-time error `sign(i)·t_dead·f_pwm·V_dc`. The DC-link voltage is the supply's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inverter {
    /// Dead time per switching transition \[s] (0 = ideal).
    pub dead_time_s: f64,
    /// PWM (switching) frequency \[Hz]; only matters with dead time.
    pub pwm_hz: f64,
}

/// The inverter holding one set of duties over a control period.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldDuties {
    /// Inverter.
    pub inverter: Inverter,
    /// Duties held over the period.
    pub duties: [f64; 3],
}

impl Inverter {
    /// Holds `duties` for a period.
    pub fn hold(&self, duties: Duties) -> HeldDuties {
        HeldDuties {
            inverter: *self,
            duties: [duties.a as f64, duties.b as f64, duties.c as f64],
        }
    }
}

impl HeldDuties {
    /// Phase-to-neutral average voltages on the DC link `v_dc` \[V] for currents `i_abc`
    /// \[A].
    pub fn phase_voltages(&self, v_dc: f64, i_abc: [f64; 3]) -> [f64; 3] {
        let inv = self.inverter;
        let v_dt = inv.dead_time_s * inv.pwm_hz * v_dc;
        let pole: [f64; 3] = core::array::from_fn(|k| {
            let sign = if i_abc[k] > 0.0 {
                1.0
            } else if i_abc[k] < 0.0 {
                -1.0
            } else {
                0.0
            };
            self.duties[k] * v_dc - sign * v_dt
        });
        let mean = (pole[0] + pole[1] + pole[2]) / 3.0;
        pole.map(|v| v - mean)
    }
}

impl Converter for HeldDuties {
    fn v_alpha_beta(&self, v_dc: f64, i: (f64, f64), _e: (f64, f64)) -> (f64, f64) {
        if self.inverter.dead_time_s == 0.0 {
            // Without dead time the voltage does not depend on the currents.
            return clarke(self.duties.map(|d| d * v_dc));
        }
        clarke(self.phase_voltages(v_dc, inverse_clarke(i.0, i.1)))
    }
}
