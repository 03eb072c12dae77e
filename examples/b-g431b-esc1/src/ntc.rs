//! The power stage's temperature: the board's NTC divider on PB14 (ADC1_IN5: UM2516's pin
//! table as published, "temperature feedback"; the ADC channel from ST's pin map for this
//! board, stm32duino's `PeripheralPins_B_G431B_ESC1.c`), converted with the linear model ST's
//! motor-control tools use for a board's NTC (`T = T0 + (V − V0)/(dV/dT)`), the derating of
//! the speed command as it warms, and the over-temperature trip.
//!
//! The model's figures (UNVERIFIED: neither the NTC's beta nor the divider was at hand):
//! ST's generated code for this board maps the ADC's full scale linearly to −49..125 °C
//! (as reported on the SimpleFOC forum, "Temperature monitoring on B-G431B-ESC1"):
//! V0 = 1.403 V at 25 °C, 18.97 mV/°C on a 3.3 V reference. An NTC is not linear; the model
//! is meant for the range around the trip, where it must be checked on the bench.

/// The linear model and the limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NtcConfig {
    /// Voltage at `t0_c` \[V].
    pub v0_v: f32,
    /// Reference temperature \[°C].
    pub t0_c: f32,
    /// Slope \[V/°C].
    pub dv_dt: f32,
    /// The speed command is derated above this \[°C] ...
    pub derate_c: f32,
    /// ... to [`NtcConfig::derated_scale`] at the trip temperature, where the drive faults
    /// \[°C].
    pub trip_c: f32,
    /// The command's share left at the trip temperature.
    pub derated_scale: f32,
    /// A reading below this is a broken sensor (a short to ground reads −49 °C), and faults
    /// as an over-temperature would \[°C].
    pub plausible_min_c: f32,
    /// Low-pass time constant of the reading \[s].
    pub filter_s: f32,
}

impl NtcConfig {
    /// The B-G431B-ESC1 (see the module doc): derating from 80 °C, the trip at 100 °C with
    /// half the speed command left, readings below −30 °C implausible, 0.1 s filter.
    pub const ESC1: Self = Self {
        v0_v: 1.403,
        t0_c: 25.0,
        dv_dt: 0.018_97,
        derate_c: 80.0,
        trip_c: 100.0,
        derated_scale: 0.5,
        plausible_min_c: -30.0,
        filter_s: 0.1,
    };

    /// The temperature of a 12-bit reading `raw` on a reference of `vref_v` \[°C].
    pub fn temp_c(&self, raw: f32, vref_v: f32) -> f32 {
        self.t0_c + (raw * vref_v / 4096.0 - self.v0_v) / self.dv_dt
    }

    /// The reading of `temp_c` \[LSB].
    pub fn raw(&self, temp_c: f32, vref_v: f32) -> f32 {
        (self.v0_v + (temp_c - self.t0_c) * self.dv_dt) / vref_v * 4096.0
    }

    /// The share of the speed command left at `temp_c`: 1 up to `derate_c`, falling
    /// linearly to `derated_scale` at `trip_c`, never below it.
    pub fn speed_scale(&self, temp_c: f32) -> f32 {
        let x = ((temp_c - self.derate_c) / (self.trip_c - self.derate_c)).clamp(0.0, 1.0);
        1.0 - x * (1.0 - self.derated_scale)
    }

    /// Whether `temp_c` (filtered) is a fault: at or above the trip, below the plausible
    /// minimum, or not a number.
    pub fn fault(&self, temp_c: f32) -> bool {
        !(self.plausible_min_c..self.trip_c).contains(&temp_c)
    }

    /// The low-pass filter's gain per sample at `rate_hz`.
    pub fn filter_gain(&self, rate_hz: f32) -> f32 {
        (1.0 / (self.filter_s * rate_hz)).min(1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const N: NtcConfig = NtcConfig::ESC1;

    /// ST's mapping: 0 → −49 °C, full scale → 125 °C, 25 °C at 1.403 V.
    #[test]
    fn linear_model() {
        assert!((N.temp_c(0.0, 3.3) + 48.96).abs() < 0.1);
        assert!((N.temp_c(4096.0, 3.3) - 125.0).abs() < 0.1);
        assert!((N.temp_c(1.403 / 3.3 * 4096.0, 3.3) - 25.0).abs() < 1e-3);
        for t in [-30.0_f32, 0.0, 25.0, 80.0, 100.0, 120.0] {
            assert!((N.temp_c(N.raw(t, 3.3), 3.3) - t).abs() < 1e-3, "{t}");
        }
    }

    #[test]
    fn derating_and_trip() {
        assert_eq!(N.speed_scale(25.0), 1.0);
        assert_eq!(N.speed_scale(80.0), 1.0);
        assert!((N.speed_scale(90.0) - 0.75).abs() < 1e-6);
        assert!((N.speed_scale(100.0) - 0.5).abs() < 1e-6);
        assert!((N.speed_scale(150.0) - 0.5).abs() < 1e-6);
        assert!(!N.fault(99.9));
        assert!(N.fault(100.0));
        assert!(N.fault(-40.0), "a shorted sensor");
        assert!(N.fault(f32::NAN));
        assert!(!N.fault(-29.0));
        assert!((N.filter_gain(4000.0) - 0.0025).abs() < 1e-7);
    }
}
