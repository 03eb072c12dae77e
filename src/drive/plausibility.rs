//! Current-sensor plausibility: the phase-sum parity check. The motor's three windings are
//! star-connected without a neutral, so their currents sum to zero (Kirchhoff's current law);
//! the board measures all three, so the sum of the three samples is the sum of the three
//! sensors' errors, a parity equation in the sense of Isermann (2006, *Fault-Diagnosis
//! Systems: An Introduction from Fault Detection to Fault Tolerance*, Springer, ch. 10:
//! parity equations from hardware redundancy, a residual against a threshold).
//!
//! One sensor failing (stuck at its last reading, reading zero, off by a gain) puts its whole
//! error `e = i_measured − i_true` of its phase into the residual `r = i_a + i_b + i_c`
//! whenever current flows, whatever the failure; a healthy board's residual is the sensors'
//! noise and what is left of their offsets.
//!
//! The threshold, from the board's sensing as `DESIGN.md` states it (1 % of the rated current
//! `I_rated` of Gaussian noise per phase, σ each, and an offset of 2 % of it on a phase where
//! the board does not take it off) and the ADC's step `sense_lsb_a` (three roundings):
//!
//! `i_sum_max_a` = (2 % + 6 · √3 · 1 %) · `I_rated` + 1.5 · `sense_lsb_a` = 12.4 % of
//! `I_rated` (+ 1.5 LSB):
//!
//! the offset plus six standard deviations of the sum's noise (σ_Σ = √3 σ): a healthy sample
//! beyond it has a probability below 10⁻⁸. At the defaults (`DriveConfig::new`: `i_max` = 1.5
//! `I_rated`, `i_trip` = 1.5 `i_max`, `i_sense_max` = 2 `i_trip`) it is a sixth of the gap
//! between the current limit and the trip (0.75 `I_rated`) and 2.8 % of the sensing range: a
//! single-sensor error the check lets through is below it, so no phase carries more than its
//! reading plus a sixth of that gap, and a stuck or zeroed sensor is found once its phase's
//! true current passes 12.4 % of the rated current, long before the trip. A gain error
//! `g` is found where `|g − 1|` times the phase current's peak passes it (10 % low at the
//! current limit: 15 % of `I_rated`).
//!
//! Persistence: an up/down count of the samples beyond the threshold (up by one beyond it,
//! down by one, to zero, within it) faults at [`SUM_COUNT_MAX`] (4 samples, one millisecond
//! at the 4 kHz step): a single corrupt sample does not fault; a failed sensor's residual, a
//! sinusoid of its phase's current, faults within the first stretch of 4 samples beyond the
//! threshold (at rated speed, 60 samples an electrical period on the drive motors, a peak
//! 1.2 times the threshold stays beyond it for 11). Checked in the modes that run the
//! inverter or catch a rotor (`Catch`, `Align`, `OpenLoop`, `Sensorless`); PWM off in the
//! same step (`Fault::CurrentSensor`).

use crate::frames::Abc;
use crate::math::INV_SQRT3;

/// The offset a board may leave on a phase, a fraction of the rated current: 2 %.
const OFFSET: f32 = 0.02;
/// The standard deviation of a board's noise per phase, a fraction of the rated current: 1 %.
const NOISE: f32 = 0.01;

/// The count of samples beyond the threshold at which the drive faults: 4.
pub(super) const SUM_COUNT_MAX: u8 = 4;

/// The check's threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// |i_a + i_b + i_c| beyond this counts \[A].
    pub(super) i_sum_max_a: f32,
}

impl Settings {
    /// From the rated current `i_rated_a` (the motor's nameplate, `Ratings::current_a`) and
    /// the ADC's step `sense_lsb_a` (0: none) \[A]; see the module doc.
    pub(super) fn new(i_rated_a: f32, sense_lsb_a: f32) -> Self {
        Self {
            i_sum_max_a: (OFFSET + 6.0 * NOISE / INV_SQRT3) * i_rated_a + 1.5 * sense_lsb_a,
        }
    }

    /// Counts this sample `i_abc` \[A] (finite: the input checks come first) into `count`;
    /// true when the count has reached [`SUM_COUNT_MAX`]: a current sensor has failed.
    #[inline(always)]
    pub(super) fn implausible(&self, count: &mut u8, i_abc: Abc) -> bool {
        let beyond = (i_abc.a + i_abc.b + i_abc.c).abs() > self.i_sum_max_a;
        *count = if beyond {
            count.saturating_add(1)
        } else {
            count.saturating_sub(1)
        };
        *count >= SUM_COUNT_MAX
    }
}
