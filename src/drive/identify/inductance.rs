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
//! A salient rotor need not rest with its d axis on the DC current: the reluctance torque
//! `c N (L_d − L_q) i_d i_q` moves the equilibrium off it once `(L_q − L_d) I > ψ_f` (at
//! `cos δ = ψ_f/((L_q − L_d) I)`: 48° on the Brusa traction motor at half its rated current),
//! so the ripple along α alone is not `L_d`'s. Each injection's ripple is therefore taken along
//! both axes: the two columns, over `2 V_h/R`, form `X`, whose symmetric part has the
//! eigenvalues `x_d`, `x_q` (each axis an R-L circuit of its own, the resistance being the same
//! in every direction) whatever the rotor's angle: the saliency-based position estimate of
//! HF injection (M. J. Corley, R. D. Lorenz, "Rotor position and velocity estimation for a
//! salient-pole PMSM at standstill and high speeds", IEEE Trans. Ind. Appl. 34(4), 1998),
//! here at rest. The d axis is the eigen-axis nearer α, where the DC current holds the magnet
//! (within 45° while `(L_q − L_d) I < √2 ψ_f`); eigen-axes of a salient rotor more than 20°
//! off α and β say it is held off its d axis, and the test is repeated with half the DC
//! current (at most three times), which returns the rotor to `δ = 0` once
//! `(L_q − L_d) I < ψ_f`. A rotor still swinging to its rest turns the axes under the
//! injection and pulls the two eigenvalues together (on the Brusa, L_d +7 %, L_q −15 %): a
//! measurement whose DC current's two halves differ (the swing's back-EMF) is repeated after
//! a wait. Only on a salient rotor: a non-salient one's swing turns nothing that matters,
//! its back-EMF cancels between the signs.
//!
//! `Δ` is the mean of `sign(v_{k−1}) (i_k − i_{k−1})` over 100 ms (slow disturbances such as
//! the back-EMF of a rotor still swinging cancel between the signs). `V_h` starts at 2 % of
//! the rated current's `R I` and doubles until the ripple is a tenth of the rated current (or
//! the inverter's limit), so a motor of any `L` gets a ripple well above the sensing noise.

use super::flux::FluxSpin;
use super::{halves_agree, Identified, IdentifyError, Phase, Progress, Settings, REST, SALIENT};
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
/// A rotor held off its d axis (module doc): the DC voltage halved at most this many times,
/// each followed by this wait for the rotor to settle \[ms] (the resistance test's settling).
const MAX_HALVINGS: u32 = 3;
const RESETTLE_MS: u32 = 100;
/// A salient rotor's two measurements repeated at most this many times while a DC current's
/// halves differ by more than [`REST`] of it (module doc).
const MAX_REPEATS: u32 = 20;
/// Axes more than 20° off α and β: `tan 40°`.
const TAN_TWICE_OFF_AXIS: f32 = 0.839;

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
    /// The response to the injection along α (the first column of `X`, module doc), once
    /// measured.
    x_alpha: AlphaBeta,
    /// Times the DC voltage was halved for a rotor held off its d axis (module doc).
    halvings: u32,
    /// The currents summed since the last tick, or over the measurement \[A]; over the
    /// measurement's first half, and their count.
    dc_sum: AlphaBeta,
    dc_first_half: (AlphaBeta, u32),
    /// A measurement's DC current moved (the rotor was not at rest), and the measurements
    /// repeated so.
    moved: bool,
    repeats: u32,
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
            x_alpha: AlphaBeta::default(),
            halvings: 0,
            dc_sum: AlphaBeta::default(),
            dc_first_half: (AlphaBeta::default(), 0),
            moved: false,
            repeats: 0,
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
        self.dc_sum = AlphaBeta::new(self.dc_sum.alpha + i_ab.alpha, self.dc_sum.beta + i_ab.beta);
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
                if ms == MEASURE_MS / 2 + 1 {
                    self.dc_first_half = (self.dc_sum, self.n);
                }
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
                let base = super::sqrt(
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
        self.moved |= !self.at_rest();
        // Measured: this injection's column of `X`, the ripple along α and β over `2 V_h/R`.
        let n = self.n.max(1) as f32;
        let x = |acc: f32| self.r_ohm * (acc / n) / (2.0 * self.v_h);
        let column = AlphaBeta::new(x(self.acc.alpha), x(self.acc.beta));
        self.clear();
        if !self.on_q {
            self.x_alpha = column;
            self.on_q = true;
            self.v_h = 0.02 * self.r_ohm * s.i_test_a;
            self.stage = Stage::Adapt(SETTLE_MS);
            return Progress::Stay;
        }
        let x = Axes::of(self.x_alpha, column);
        let off_alpha = x.off_alpha() && self.halvings < MAX_HALVINGS;
        let moved = x.salient() && self.moved && self.repeats < MAX_REPEATS;
        if off_alpha || moved {
            if off_alpha {
                // The rotor rests off the DC current by the reluctance torque: half the
                // current.
                self.halvings += 1;
                self.base = AlphaBeta::new(0.5 * self.base.alpha, 0.5 * self.base.beta);
            } else {
                self.repeats += 1;
            }
            // The rotor let settle, both axes again.
            self.on_q = false;
            self.moved = false;
            self.v_h = 0.02 * self.r_ohm * s.i_test_a;
            self.stage = Stage::Adapt(RESETTLE_MS);
            return Progress::Stay;
        }
        let (x_d, x_q) = x.d_q();
        let (Some(l_d_h), Some(l_q_h)) = (
            inductance(x_d, self.r_ohm, s.ts),
            inductance(x_q, self.r_ohm, s.ts),
        ) else {
            return Progress::Fail(IdentifyError::InductanceOutOfRange);
        };
        result.l_d_h = l_d_h;
        result.l_q_h = l_q_h;
        Progress::Next(Phase::Flux(FluxSpin::new(s, result)))
    }

    /// Sums cleared.
    fn clear(&mut self) {
        self.acc = AlphaBeta::default();
        self.dc_sum = AlphaBeta::default();
        self.n = 0;
    }

    /// The DC current's means over the measurement's two halves agree within [`REST`] of it:
    /// no back-EMF of a rotor still moving in the currents.
    fn at_rest(&self) -> bool {
        // The first half's mean DC current, squared \[A²].
        let (sum, n) = self.dc_first_half;
        let k = 1.0 / (n.max(1) as f32);
        let dc_sq = k * k * (sum.alpha * sum.alpha + sum.beta * sum.beta);
        halves_agree(
            self.dc_first_half,
            (self.dc_sum, self.n),
            REST * REST * dc_sq,
        )
    }
}

/// `X`'s symmetric part (module doc): its diagonal, the mean of its eigenvalues, half their
/// difference (`spread`) and half the diagonal's (`half_diff`), and its off-diagonal element.
struct Axes {
    alpha: f32,
    beta: f32,
    mean: f32,
    spread: f32,
    half_diff: f32,
    cross: f32,
}

impl Axes {
    /// From the columns of `X` measured by the injections along α (`x_alpha`) and β
    /// (`x_beta`).
    fn of(x_alpha: AlphaBeta, x_beta: AlphaBeta) -> Self {
        let (alpha, beta) = (x_alpha.alpha, x_beta.beta);
        let cross = 0.5 * (x_alpha.beta + x_beta.alpha);
        let half_diff = 0.5 * (alpha - beta);
        Self {
            alpha,
            beta,
            mean: 0.5 * (alpha + beta),
            spread: super::sqrt(half_diff * half_diff + cross * cross),
            half_diff,
            cross,
        }
    }

    /// A salient rotor: eigenvalues apart (twice the spread) by more than [`SALIENT`] of
    /// their mean, as [`Identified::salient`] asks of the inductances.
    fn salient(&self) -> bool {
        2.0 * self.spread > SALIENT * self.mean
    }

    /// A salient rotor whose axes lie more than 20° off α and β (`tan 2φ = cross/half_diff`).
    fn off_alpha(&self) -> bool {
        self.salient() && self.cross.abs() > TAN_TWICE_OFF_AXIS * self.half_diff.abs()
    }

    /// The d and q axes' `x`: of a salient rotor the eigenvalues, the d axis the eigen-axis
    /// nearer α, where the DC current holds the magnet (the larger `x`, the smaller inductance,
    /// when `X_αα > X_ββ`); else the diagonal, the responses along α and β (the off-diagonal
    /// element is noise, which would only push the eigenvalues apart).
    fn d_q(&self) -> (f32, f32) {
        if !self.salient() {
            return (self.alpha, self.beta);
        }
        let spread = if self.half_diff >= 0.0 {
            self.spread
        } else {
            -self.spread
        };
        (self.mean + spread, self.mean - spread)
    }
}

/// The inductance \[H] of an axis whose ripple is `x` (module doc) at `r_ohm` \[Ω] and the
/// step `ts` \[s]; `None` outside the model's range or [`MotorParams::L_H`]. Out of line: the
/// 1 kHz work calls it twice, at the end of the test.
#[inline(never)]
fn inductance(x: f32, r_ohm: f32, ts: f32) -> Option<f32> {
    if !(x > 1e-6 && x < 0.99) {
        return None;
    }
    let l_h = r_ohm * ts / super::ln((1.0 + x) / (1.0 - x));
    MotorParams::L_H.check("l_h", l_h).ok().map(|_| l_h)
}
