//! d- and q-axis inductance by square-wave voltage injection.
//!
//! Method: high-frequency injection at standstill (the voltage-pulse / HF tests of
//! self-commissioning: ST's MC SDK profiler, SimpleFOC's and VESC's `L_d`/`L_q` measurement;
//! for a salient rotor the d- and q-axis responses at the aligned position). On top of the DC
//! voltage `V0` of the resistance test's first level (half the rated current on the α axis,
//! which holds the rotor at θ_e = 0 and keeps every phase current's sign, so the dead-time
//! error is a constant), a voltage `±V_h` alternates every step along the d axis (α), then
//! the q axis (β). In the periodic steady state of the sampled R-L circuit
//! (`i_{k+1} = a i_k + (1 − a)(v_k − …)/R`, `a = e^{−RT/L}`) the current rises and falls by
//!
//! ```text
//! Δ = (2 V_h / R) · tanh(R T / (2 L))   ⇒   L = R T / ln((1 + x)/(1 − x)),  x = R Δ/(2 V_h)
//! ```
//!
//! exact for any `L/R` against `T` (not only `L/R ≫ T`), with `R` from the resistance test.
//! `Δ` is the mean of `sign(v_{k−1}) (i_k − i_{k−1})` over 100 ms (slow disturbances such as
//! the back-EMF of a rotor still swinging cancel between the signs). `V_h` starts at 2 % of
//! the rated current's `R I` and doubles until the ripple is a tenth of the rated current (or
//! the inverter's limit), so a motor of any `L` gets a ripple well above the sensing noise.

use super::flux::FluxSpin;
use super::{Identified, IdentifyError, Phase, Progress, Settings};
use crate::foc::{Reference, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::motor::MotorParams;

/// The ripple aimed at, a fraction of the rated current.
const RIPPLE: f32 = 0.1;
/// Wait after each change of `V_h` \[ms], and before the measurement.
const SETTLE_MS: u32 = 5;
const PRE_MEASURE_MS: u32 = 20;
/// Averaging time \[ms].
const MEASURE_MS: u32 = 100;

/// Where the measurement is (milliseconds left).
#[derive(Clone, Copy, Debug, PartialEq)]
enum Stage {
    /// Settling after a change of `V_h`, then doubling it while the ripple is small.
    Adapt(u32),
    /// The amplitude chosen: settling before the measurement.
    Wait(u32),
    /// The ripple summed.
    Measure(u32),
}

/// The state of the inductance measurement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(in crate::drive) struct Inductance {
    /// Injecting on the q axis (β) (else d, α).
    on_q: bool,
    /// The DC voltage \[V].
    base: AlphaBeta,
    /// Injected amplitude \[V].
    v_h: f32,
    /// Sign of the injection over the period that just ended.
    sign: f32,
    /// The last sample \[A].
    i_prev: AlphaBeta,
    /// Σ sign·Δi since the last tick, or over the measurement \[A].
    acc: AlphaBeta,
    n: u32,
    stage: Stage,
    /// The resistance \[Ω].
    r_ohm: f32,
    /// The d-axis result \[H], once measured.
    l_d_h: f32,
}

impl Inductance {
    /// Starts on the d axis with the DC voltage `base` \[V], `r_ohm` measured.
    pub(in crate::drive) fn new(s: &Settings, base: AlphaBeta, r_ohm: f32) -> Self {
        Self {
            on_q: false,
            base,
            v_h: 0.02 * r_ohm * s.i_test_a,
            sign: 1.0,
            i_prev: AlphaBeta::default(),
            acc: AlphaBeta::default(),
            n: 0,
            stage: Stage::Adapt(SETTLE_MS),
            r_ohm,
            l_d_h: 0.0,
        }
    }

    /// One step: the ripple of the sample `i_ab` \[A] summed; the injection's sign reversed.
    #[inline(always)]
    /// With the request, the DC voltage, whose signs the dead time's compensation takes
    /// ([`super::inverter::hold_signs`]).
    pub(in crate::drive) fn step(&mut self, i_ab: AlphaBeta) -> (Request, AlphaBeta) {
        let sg = self.sign;
        self.acc = AlphaBeta::new(
            self.acc.alpha + sg * (i_ab.alpha - self.i_prev.alpha),
            self.acc.beta + sg * (i_ab.beta - self.i_prev.beta),
        );
        self.n += 1;
        self.i_prev = i_ab;
        let sg = -sg;
        self.sign = sg;
        let h = sg * self.v_h;
        let v = if self.on_q {
            Dq::new(self.base.alpha, self.base.beta + h)
        } else {
            Dq::new(self.base.alpha + h, self.base.beta)
        };
        let request = Request {
            frame: SinCos::ZERO,
            frame_out: SinCos::ZERO,
            omega_m: 0.0,
            reference: Reference::Voltage(v),
        };
        (request, self.base)
    }

    /// The 1 kHz work: the amplitude, the measurement, the result. `v_max` \[V] the largest
    /// voltage the inverter applies now.
    pub(in crate::drive) fn tick(
        &mut self,
        s: &Settings,
        v_max: f32,
        result: &mut Identified,
    ) -> Progress {
        let along = if self.on_q {
            self.acc.beta
        } else {
            self.acc.alpha
        };
        let ripple = along / (self.n.max(1) as f32);
        match self.stage {
            Stage::Measure(ms) if ms > 1 => {
                self.stage = Stage::Measure(ms - 1);
                return Progress::Stay;
            }
            Stage::Measure(_) => {}
            Stage::Adapt(ms) if ms > 0 => {
                self.clear();
                self.stage = Stage::Adapt(ms - 1);
                return Progress::Stay;
            }
            Stage::Adapt(_) => {
                self.clear();
                let base = crate::math::sqrt(
                    self.base.alpha * self.base.alpha + self.base.beta * self.base.beta,
                );
                self.stage = if ripple < RIPPLE * s.i_test_a && 2.0 * self.v_h + base <= v_max {
                    self.v_h *= 2.0;
                    Stage::Adapt(SETTLE_MS)
                } else {
                    Stage::Wait(PRE_MEASURE_MS)
                };
                return Progress::Stay;
            }
            Stage::Wait(ms) => {
                self.clear();
                self.stage = if ms > 0 {
                    Stage::Wait(ms - 1)
                } else {
                    Stage::Measure(MEASURE_MS)
                };
                return Progress::Stay;
            }
        }
        // Measured: L from the ripple.
        let x = self.r_ohm * ripple / (2.0 * self.v_h);
        self.clear();
        if !(x > 1e-6 && x < 0.99) {
            return Progress::Fail(IdentifyError::InductanceOutOfRange);
        }
        let l_h = self.r_ohm * s.ts / super::ln((1.0 + x) / (1.0 - x));
        if MotorParams::L_H.check("l_h", l_h).is_err() {
            return Progress::Fail(IdentifyError::InductanceOutOfRange);
        }
        if !self.on_q {
            self.l_d_h = l_h;
            self.on_q = true;
            self.v_h = 0.02 * self.r_ohm * s.i_test_a;
            self.stage = Stage::Adapt(SETTLE_MS);
            return Progress::Stay;
        }
        result.l_d_h = self.l_d_h;
        result.l_q_h = l_h;
        Progress::Next(Phase::Flux(FluxSpin::new(s, result)))
    }

    /// Sums cleared.
    fn clear(&mut self) {
        self.acc = AlphaBeta::default();
        self.n = 0;
    }
}
