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
//! The threshold `i_sum_max_a` = max((`i_trip_a` − `i_max_a`)/2, `i_sense_max_a`/20):
//! - half the gap between the current limit and the trip: a single-sensor error the check lets
//!   through is below it, so no phase carries more than its reading plus half that gap (the
//!   current loop keeps the readings at `i_max_a`, so the true current stays half way to the
//!   trip), and a failed sensor is found once its phase's true current passes it, well before
//!   the trip;
//! - at least a twentieth of the sensing range, the largest offset the drive accepts from a
//!   sensing path (`Fault::AdcOffset`), for limits set with a narrow gap.
//!
//! At the defaults (`DriveConfig::new`: `i_max` = 1.5 `i_rated`, `i_trip` = 1.5 `i_max`,
//! `i_sense_max` = 2 `i_trip`) it is 0.375 `i_rated`. A board's sensing (`DESIGN.md`): 1 % of the rated
//! current of Gaussian noise per phase, σ_Σ = √3 · 1 % = 1.7 % of it on the sum, and a 2 %
//! offset on one phase where the board does not take it off: a healthy residual beyond
//! 2 % + 6 σ_Σ = 12.4 % of the rated current has a probability below 10⁻⁸ per sample; the
//! threshold is 21 σ_Σ above the offset.
//!
//! Persistence: an up/down count of the samples beyond the threshold (up by one beyond it,
//! down by one, to zero, within it) faults at [`SUM_COUNT_MAX`] (4 samples, one millisecond
//! at the 4 kHz step): a single corrupt sample does not fault, and a failed sensor's residual
//! (a sinusoid of the phase's current, beyond the threshold over more than half of each
//! electrical period once the amplitude passes √2 times it) faults within the first half
//! period beyond it. Checked in the modes that run the inverter or catch a rotor (`Catch`,
//! `Align`, `OpenLoop`, `Sensorless`); PWM off in the same step (`Fault::CurrentSensor`).

use crate::frames::Abc;

/// The count of samples beyond the threshold at which the drive faults: 4.
pub(super) const SUM_COUNT_MAX: u8 = 4;

/// The check's threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// |i_a + i_b + i_c| beyond this counts \[A].
    pub(super) i_sum_max_a: f32,
}

impl Settings {
    /// From the limits (`Limits`: the current limit, the trip and the sensing range \[A];
    /// see the module doc).
    pub(super) fn new(i_max_a: f32, i_trip_a: f32, i_sense_max_a: f32) -> Self {
        Self {
            i_sum_max_a: (0.5 * (i_trip_a - i_max_a)).max(i_sense_max_a / 20.0),
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
