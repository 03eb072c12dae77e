//! The current sensors' offsets, measured with the PWM off: while the drive is idle (every
//! window of samples; the last one is taken off every sample from the enable on, and an
//! implausible one refuses the enable), and in mode `Calibrate` before an identification.
//!
//! With every switch off and the rotor at rest or slow (its back-EMF below the bus), no
//! current flows: the mean of each phase's samples is its amplifier's offset. The standard
//! start-up calibration of drive firmware (ST's MC SDK `RCM`/`R3_x_CurrentReadingCalibration`,
//! TI's InstaSPIN offset estimation): `offset_k = (1/n) Σ i_k` over `n` samples \[A]. An offset
//! beyond a plausible range (a twentieth of the sensing range) is not an amplifier's offset but
//! a broken sensing path or a current flowing: the named fault [`Fault::AdcOffset`].
//!
//! [`Fault::AdcOffset`]: crate::drive::Fault::AdcOffset

use crate::frames::{Abc, AlphaBeta};

/// Samples averaged: 64 (16 ms at 4 kHz); the mean of 1 %-of-rated-current noise is then
/// within 0.13 % of it (1σ).
pub(in crate::drive) const SAMPLES: u32 = 64;

/// A window of samples with the PWM off: the state of
/// [`Mode::Calibrate`](crate::drive::Mode::Calibrate), and of the watch kept while idle.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(in crate::drive) struct Calibrate {
    sum: Abc,
    n: u32,
}

impl Calibrate {
    /// Adds one sample (PWM off) \[A]; once [`SAMPLES`] are in, the offsets in the stationary
    /// frame \[A], or `None` when a phase's mean is beyond `limit_a` \[A] (implausible).
    /// `Some(Ok(..))` ends the calibration.
    #[inline(always)]
    pub(in crate::drive) fn step(&mut self, i: Abc, limit_a: f32) -> Option<Option<AlphaBeta>> {
        self.sum = Abc::new(self.sum.a + i.a, self.sum.b + i.b, self.sum.c + i.c);
        self.n += 1;
        if self.n < SAMPLES {
            return None;
        }
        let k = 1.0 / SAMPLES as f32;
        let mean = Abc::new(self.sum.a * k, self.sum.b * k, self.sum.c * k);
        let ok = mean.a.abs() <= limit_a && mean.b.abs() <= limit_a && mean.c.abs() <= limit_a;
        // The zero-sequence part (the sum of the three offsets) drops out of the Clarke
        // transform: only the αβ offset matters to the drive.
        Some(ok.then(|| mean.to_alpha_beta()))
    }
}

/// The offsets the drive measured with the PWM off, and the watch that renews them while idle:
/// written here ([`Offsets::watch`], [`Offsets::calibrated`]), read by the enable
/// ([`Offsets::implausible`]) and the identification ([`Offsets::ab`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(in crate::drive) struct Offsets {
    /// In the stationary frame \[A].
    ab: AlphaBeta,
    /// The samples' window.
    window: Calibrate,
    /// The last idle window's offsets were implausible: an enable faults (`AdcOffset`).
    implausible: bool,
}

impl Offsets {
    /// The offsets in the stationary frame \[A].
    pub(in crate::drive) fn ab(&self) -> AlphaBeta {
        self.ab
    }

    /// The last idle window's offsets were implausible: the enable is refused.
    pub(in crate::drive) fn implausible(&self) -> bool {
        self.implausible
    }

    /// The offsets kept, a new window: a restart in another mode.
    pub(in crate::drive) fn kept(&self) -> Self {
        Self {
            ab: self.ab,
            window: Calibrate::default(),
            implausible: self.implausible,
        }
    }

    /// The offsets kept, a new window, nothing implausible: the identification's start (its
    /// calibration measures them again).
    pub(in crate::drive) fn for_identification(&self) -> Self {
        Self {
            ab: self.ab,
            ..Self::default()
        }
    }

    /// While idle (PWM off): the sample `i` \[A] summed into the window; each full window
    /// renews the offsets the next enable takes (or marks them implausible, beyond `limit_a`).
    #[inline(always)]
    pub(in crate::drive) fn watch(&mut self, i: Abc, limit_a: f32) {
        if let Some(r) = self.window.step(i, limit_a) {
            self.implausible = r.is_none();
            if let Some(ab) = r {
                self.ab = ab;
            }
            self.window = Calibrate::default();
        }
    }

    /// Mode `Calibrate`'s sample `i` \[A]: `None` until the window is full; then `Some(true)`
    /// with the offsets kept, or `Some(false)` (implausible, beyond `limit_a`: the offset
    /// fault).
    #[inline(always)]
    pub(in crate::drive) fn calibrated(&mut self, i: Abc, limit_a: f32) -> Option<bool> {
        let offset = self.window.step(i, limit_a)?;
        self.window = Calibrate::default();
        if let Some(ab) = offset {
            self.ab = ab;
        }
        Some(offset.is_some())
    }
}
