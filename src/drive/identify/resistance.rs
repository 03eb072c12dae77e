//! Phase resistance by two DC levels, and the winding check.
//!
//! Method: the standard self-commissioning DC test (ST's MC SDK motor profiler; Kim, Sul et
//! al.'s offline parameter estimation; TI InstaSPIN's `R_s` step): with the rotor held on the
//! α axis (θ_e = 0) by the current itself, two DC voltages `V1`, `V2` on that axis give the
//! currents `I1`, `I2`; `R = (V2 − V1)/(I2 − I1)` \[Ω]. The inverter's dead-time error and any
//! current or voltage offset are the same at both levels (every phase current keeps its sign:
//! phase a carries `I`, b and c `−I/2`, all beyond the compensation's band) and cancel. The
//! levels are half the rated current and the rated current (each to within +25 %), each held
//! to settle (100 ms) and averaged (100 ms).
//!
//! Reaching a level on a motor of unknown resistance (a 470 V bus and 7 mΩ: the rated
//! current needs 1 % of the phase voltage, less than the dead time's error, so a ramp scaled
//! from the bus overshoots it many times over): the voltage grows geometrically, 10 % per
//! millisecond (γ = 0.05/ms) from `10⁻⁴` of the rated bus's phase voltage, until a tenth of
//! the level flows; a geometric ramp `e^{γt}` through the winding's lag `τ = L/R` gives the
//! current `v/(R (1 + γτ))`, so the voltage is never more than `1 + γτ` ahead of what flows
//! (1.3 at τ = 7 ms, 3.2 at the 44 ms of a 18 mΩ, 0.8 mH traction motor), whatever `R`. From
//! there an integral current controller whose gain is scaled from the measured resistance,
//! `Δv = G (1.1·level − i) · v/i` per millisecond (the secant `v/i`; the rise capped at
//! γ per ms, the fall at half the voltage): with the lag, `ω_n² = G/(τ·1 ms)` and `ζ = 1/(2 √(G τ/1 ms))`, so `G = 0.03`
//! keeps `ζ ≥ 0.5` up to τ = 33 ms (0.44 at 44 ms) and settles a τ → 0 winding in
//! `3·1 ms/G` = 100 ms; it lands the current in the window. The secant overestimates `R` by
//! the lag (`1 + γτ`) and the loop may overshoot: a level is averaged only when its current is
//! still in the window after the settling time, and kept only when the average's two halves
//! agree (a rotor still swinging puts its back-EMF in the current: it settles again), else the
//! ramp goes on (for at most 2 s, then
//! the level is taken where it is, and the winding check judges it). This is the
//! ramp-to-current of ODrive's resistance measurement (`Motor::measure_phase_resistance`,
//! an integrator `v += k_I (I_test − i) T`; ODrive fixes `k_I` at 1 V/(A·s), here it follows
//! the measured `v/i`) made scale-free.
//!
//! A winding slower than that left the controller swinging. On the Zou 350 kW PMa-SynRM's
//! non-salient twin (1.65 mH, 11.5 mΩ: `τ` = 143 ms, `ζ` 0.24) the third level's current
//! overshot to 400 A on a 99 A step and the 2 s limit ran out; the unsettled points made the
//! conductance's eigenvalue ratio 0.797, and the healthy winding was named `shorted_phase`
//! (seed 1; R −3.5 % on seed 2).
//!
//! So the settling also watches where its current is going: the current along the level's
//! axis over the settling's first, middle and last 10 ms, two steps `d₁`, `d₂` 45 ms apart.
//! Where the steps shrink as a first-order approach with a lag beyond the controller's does
//! (`d₂/d₁` from `e^{−45/33}` up to 0.9, a lag of 33 to 430 ms), the current's end is
//! extrapolated (`i∞ = i₃ + d₂²/(d₁ − d₂)`, Aitken's Δ²), the voltage scaled by the aim over
//! it, and the level settles again, its rest then judged at a quarter of the tolerance. The
//! end is `v/R` less what remains of the inverter's error, so the scaling is repeated until
//! the current settles in the window, not exact at once.
//!
//! A winding within the controller's damping takes the ramp as before: every zoo motor under
//! 33 ms identifies as it did, to the bit. The twin identifies within 0.9 % (R, L, ψ_f, J;
//! seeds 1 to 3), and the two other zoo motors beyond 33 ms measure R closer: the Brusa HSM1
//! (44 ms) −0.04 and −0.01 % (−1.81 and −1.87 % before, seeds 1 and 2), the Zou (78 ms on d)
//! +0.34 and −0.04 % (−0.53 and −0.18 %).
//!
//! The dead-time compensation by the sign of the measured current
//! ([`crate::dead_time`]) is a negative resistance of `t_d·f_pwm·V_bus/band` while a phase's
//! current is within the compensation's band: on a motor whose `R` is below it (the 7 mΩ
//! motor: ≈ 0.4 Ω) the current runs away as it crosses the band (`overcurrent`). The
//! resistance and inductance tests therefore compensate with signs that do not follow each
//! sample ([`super::inverter::hold_signs`]): those of the last millisecond's mean current once a tenth
//! of the rated current flows (a faulty winding's phase currents need not have the voltage's
//! signs), else those of the voltage commanded (the inductance test: of its DC voltage): the inverter's error is
//! then the constant that the two-level difference cancels (the inverter-nonlinearity
//! argument of the two-point DC test: Kim, Sul et al.; H.-W. Kim, M.-J. Youn, K.-Y. Cho,
//! H.-S. Kim, "Nonlinearity estimation and compensation of PWM VSI for PMSM under
//! resistance and flux linkage uncertainty", IEEE Trans. Control Syst. Technol. 14(4), 2006).
//!
//! The winding check: a third level adds 0.3 × rated current on the β axis (the rotor turns
//! by 17° electrical; a salient rotor held on an unstable equilibrium by the first levels,
//! where `(L_q − L_d) I > ψ_f`, swings to its reluctance-shifted one, 60° on the Brusa
//! traction motor), so that the 2×2 DC conductance
//! `G = ∂i_αβ/∂v_αβ` is known. A healthy machine's `G` is `I/R` whatever its saliency (the
//! resistance is the same in every direction); an open phase `k` leaves `G = w wᵀ/R` with
//! `w ⊥ u_k` (no current along the phase's axis `u_k`: eigenvalues 0 and 1/R); a shorted
//! winding `k` (its terminal at the star point) makes it `(I + 2 u_k u_kᵀ)/R` (3/R and 1/R).
//! Ratio of the eigenvalues of `G`'s symmetric part: below 0.15 an open phase, below 0.8 a
//! shorted one. A voltage ramp that reaches the inverter's limit without the level ends with
//! an open phase when the current stays below a quarter of the level or leaves the axis (an
//! open phase b or c lets it flow only at 30° off), else with the resistance out of range
//! (more than the bus can drive).

use super::inductance::Inductance;
use super::{halves_agree, Identified, IdentifyError, Phase, Progress, Settings, REST};
use crate::foc::{Reference, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::math::clamp;
use crate::motor::MotorParams;

/// Settling time after each level is reached \[ms].
const SETTLE_MS: u32 = 100;
/// A settling's three windows of its current's approach (module doc): 10 ms each, at its
/// start, middle and end (the settling's milliseconds count down from [`SETTLE_MS`]).
const WINDOW_MS: u32 = 10;
const FIRST_WINDOW: core::ops::RangeInclusive<u32> = SETTLE_MS - WINDOW_MS + 1..=SETTLE_MS;
const MIDDLE_WINDOW: core::ops::RangeInclusive<u32> =
    SETTLE_MS / 2 - WINDOW_MS / 2 + 1..=SETTLE_MS / 2 + WINDOW_MS / 2;
const LAST_WINDOW: core::ops::RangeInclusive<u32> = 1..=WINDOW_MS;
/// Averaging time of each level \[ms].
const AVERAGE_MS: u32 = 100;
/// Levels: fractions of the rated current (α, α, then added on β).
const LEVELS: [f32; 3] = [0.5, 1.0, 0.3];
/// The ramp's first voltage, a fraction of the rated bus's phase voltage (module doc).
const V_START: f32 = 1e-4;
/// Geometric growth per millisecond while the current is below `DETECT` of the level (γ).
const GROWTH: f32 = 0.05;
const DETECT: f32 = 0.1;
/// The integral controller's gain per millisecond (times the secant `v/i`) and its aim (a
/// fraction of the level: the window is `[1, 1.25]`).
const GAIN: f32 = 0.03;
const AIM: f32 = 1.1;
/// The ratio of two successive steps, 45 ms apart, of a first-order approach whose lag is
/// 33 ms, `e^{−45/33}`: the lag beyond which the level's integral controller no longer damps
/// the approach (`ζ = 1/(2√(G τ/1 ms))` = 0.5 at 33 ms, module doc). A settling whose steps
/// shrink more slowly sets the voltage from where the current is going
/// ([`Resistance::final_current`]).
const SLOW_STEP_RATIO: f32 = 0.256;
/// A level not held in its window within this time \[ms] is taken where its current is
/// (a faulty winding's current may not settle along the level's axis; the conductance check
/// then names the fault).
const RAMP_MAX_MS: u32 = 2000;

/// Where a level is.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
enum Sub {
    /// The voltage ramps until the current reaches the level.
    #[default]
    Ramp,
    /// The voltage held, milliseconds left.
    Settle(u32),
    /// The voltage held, the currents summed, milliseconds left.
    Average(u32),
}

/// The state of the resistance measurement.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(in crate::drive) struct Resistance {
    /// Level 0, 1 (α axis) or 2 (β added).
    level: usize,
    sub: Sub,
    /// The voltage applied \[V].
    v_ab: AlphaBeta,
    /// Currents summed since the last tick (or over the average) \[A].
    sum_i: AlphaBeta,
    n: u32,
    /// The direction whose phase signs the dead time's compensation takes: the last
    /// millisecond's mean current once a tenth of the rated current flows, else the voltage.
    sign_dir: AlphaBeta,
    /// Milliseconds this level has ramped (its settling included).
    ramp_ms: u32,
    /// The currents summed over the average's first half, and their count \[A].
    first_half: (AlphaBeta, u32),
    /// Each level's voltage and mean current [V], \[A].
    points: [(AlphaBeta, AlphaBeta); 3],
    /// The current along the level's axis over the settling's first, middle and last 10 ms,
    /// summed \[A] (a slow winding's approach, module doc).
    approach: [f32; 3],
    /// A winding found slower than the level's controller: its levels held to a tighter rest.
    slow: bool,
}

impl Resistance {
    /// One step: the sample `i_ab` \[A] summed; the voltage held, and the voltage whose signs
    /// the dead time's compensation takes (itself: [`super::inverter::hold_signs`]).
    #[inline(always)]
    pub(in crate::drive) fn step(&mut self, i_ab: AlphaBeta) -> (Request, AlphaBeta) {
        self.sum_i = AlphaBeta::new(self.sum_i.alpha + i_ab.alpha, self.sum_i.beta + i_ab.beta);
        self.n += 1;
        let request = Request {
            frame: SinCos::ZERO,
            frame_out: SinCos::ZERO,
            omega_m: 0.0,
            reference: Reference::Voltage(Dq::new(self.v_ab.alpha, self.v_ab.beta)),
        };
        let dir = if self.sign_dir.alpha == 0.0 && self.sign_dir.beta == 0.0 {
            self.v_ab
        } else {
            self.sign_dir
        };
        (request, dir)
    }

    /// The 1 kHz work: the ramp, the levels, the result. `v_max` \[V] the largest voltage the
    /// inverter applies now.
    pub(in crate::drive) fn tick(
        &mut self,
        s: &Settings,
        v_max: f32,
        result: &mut Identified,
    ) -> Progress {
        let k = 1.0 / (self.n.max(1) as f32);
        let mean = AlphaBeta::new(self.sum_i.alpha * k, self.sum_i.beta * k);
        let on_beta = self.level == 2;
        let level_a = LEVELS[self.level.min(2)] * s.i_test_a;
        // The current along the level's axis (on β, what the third level added).
        let base = self.points[1].1;
        let (along, across) = if on_beta {
            (mean.beta - base.beta, mean.alpha - base.alpha)
        } else {
            (mean.alpha, mean.beta)
        };
        let in_window = along >= level_a && along <= 1.25 * level_a;
        if self.n > 0 {
            let flows = mean.alpha * mean.alpha + mean.beta * mean.beta
                >= (DETECT * s.i_test_a) * (DETECT * s.i_test_a);
            self.sign_dir = if flows { mean } else { AlphaBeta::default() };
        }
        match self.sub {
            Sub::Ramp => {
                self.clear();
                self.ramp_ms += 1;
                if in_window || self.ramp_ms > RAMP_MAX_MS {
                    self.sub = Sub::Settle(SETTLE_MS);
                    return Progress::Stay;
                }
                // The voltage along the level's axis (on β, what the third level added).
                let v_along = if on_beta {
                    self.v_ab.beta
                } else {
                    self.v_ab.alpha
                };
                let v_next = if along < DETECT * level_a || v_along <= 0.0 {
                    if v_along > 0.0 {
                        v_along * (1.0 + GROWTH)
                    } else if on_beta {
                        // From a hundredth of the second level's voltage (the third level
                        // needs about 0.3 of it).
                        V_START * 1e2 * self.points[1].0.alpha
                    } else {
                        V_START * s.v_phase_rated
                    }
                } else {
                    // Integral control, its gain from the secant resistance.
                    let dv = GAIN * (AIM * level_a - along) * (v_along / along);
                    v_along + dv.max(-0.5 * v_along).min(GROWTH * v_along)
                };
                let mut v = self.v_ab;
                if on_beta {
                    v.beta = v_next;
                } else {
                    v.alpha = v_next;
                }
                let within = v.alpha * v.alpha + v.beta * v.beta <= v_max * v_max;
                if !within {
                    let open = along < 0.25 * level_a || across.abs() > 0.3 * along.abs();
                    return Progress::Fail(if open {
                        IdentifyError::OpenPhase
                    } else {
                        IdentifyError::ResistanceOutOfRange
                    });
                }
                self.v_ab = v;
            }
            Sub::Settle(0) => {
                self.clear();
                // Still in the window after settling; else a slow winding's current still on
                // its way (module doc) sets the voltage for where it is going; else on with
                // the ramp.
                self.sub = if in_window || self.ramp_ms > RAMP_MAX_MS {
                    Sub::Average(AVERAGE_MS)
                } else if let Some(i_final) = self.final_current(level_a) {
                    self.slow = true;
                    let scale = clamp(AIM * level_a / i_final, 0.25, 4.0);
                    let mut v = self.v_ab;
                    if on_beta {
                        v.beta *= scale;
                    } else {
                        v.alpha *= scale;
                    }
                    // Beyond what the inverter applies: the ramp's check names it.
                    if v.alpha * v.alpha + v.beta * v.beta <= v_max * v_max {
                        self.v_ab = v;
                        Sub::Settle(SETTLE_MS)
                    } else {
                        Sub::Ramp
                    }
                } else {
                    Sub::Ramp
                };
            }
            Sub::Settle(ms) => {
                self.clear();
                self.ramp_ms += 1;
                if ms == SETTLE_MS {
                    self.approach = [0.0; 3];
                }
                let third = [FIRST_WINDOW, MIDDLE_WINDOW, LAST_WINDOW]
                    .iter()
                    .position(|w| w.contains(&ms));
                if let Some(sum) = third.and_then(|k| self.approach.get_mut(k)) {
                    *sum += along;
                }
                self.sub = Sub::Settle(ms - 1);
            }
            Sub::Average(ms) if ms > 1 => {
                if ms == AVERAGE_MS / 2 + 1 {
                    self.first_half = (self.sum_i, self.n);
                }
                self.sub = Sub::Average(ms - 1);
            }
            Sub::Average(_) if !self.at_rest(level_a) && self.ramp_ms <= RAMP_MAX_MS => {
                // The rotor still moves (its EMF in the current): settle again.
                self.clear();
                self.sub = Sub::Settle(SETTLE_MS);
            }
            Sub::Average(_) => {
                if let Some(p) = self.points.get_mut(self.level) {
                    *p = (self.v_ab, mean);
                }
                self.clear();
                self.sub = Sub::Ramp;
                self.ramp_ms = 0;
                self.level += 1;
                if self.level == 3 {
                    return self.evaluate(s, result);
                }
            }
        }
        Progress::Stay
    }

    /// The average's two halves agree within [`REST`] of the level `level_a` \[A]: no
    /// back-EMF of a rotor still moving in the currents (module doc).
    fn at_rest(&self, level_a: f32) -> bool {
        // (A slow winding's current creeps: the average's offset from the current's end is
        // about three times the halves' difference at τ = 143 ms, within 1 % of the level at a
        // quarter of the tolerance.)
        let tolerance = if self.slow { 0.25 } else { 1.0 } * REST * level_a;
        halves_agree(self.first_half, (self.sum_i, self.n), tolerance * tolerance)
    }

    /// Where the settling's current along the level's axis is going \[A], from its three
    /// 10 ms means 45 ms apart: a first-order approach `i∞ − A e^{−t/τ}` (the winding's lag)
    /// steps by `d₁`, `d₂` of one sign, `d₂/d₁ = e^{−45 ms/τ}`, so `i∞ = i₃ + d₂²/(d₁ − d₂)`
    /// (Aitken's Δ² extrapolation). Only for a lag beyond what the level's controller damps
    /// ([`SLOW_STEP_RATIO`]); `None` where the current did not approach so (its first
    /// step within [`REST`] of the level `level_a` \[A]: at rest, or noise; steps that grow,
    /// turn, or shrink faster: a rotor moving, a fast winding) or the end is not a current
    /// along the level.
    fn final_current(&self, level_a: f32) -> Option<f32> {
        let [i1, i2, i3] = self.approach.map(|sum| sum / WINDOW_MS as f32);
        let (d1, d2) = (i2 - i1, i3 - i2);
        // (Up to a ratio of 0.9: nearer 1 the extrapolation multiplies the means' noise by
        // about `1/(1 − d₂/d₁)²`.)
        let approaching = d1.abs() > REST * level_a
            && d2 * d1 >= SLOW_STEP_RATIO * d1 * d1
            && d2.abs() <= 0.9 * d1.abs();
        let i_final = i3 + d2 * d2 / (d1 - d2);
        (approaching && i_final > 0.0 && i_final.is_finite()).then_some(i_final)
    }

    /// Sums cleared.
    fn clear(&mut self) {
        self.sum_i = AlphaBeta::default();
        self.n = 0;
    }

    /// `R` from the two α levels, the winding from `G`.
    fn evaluate(&self, s: &Settings, result: &mut Identified) -> Progress {
        let [(v0, i0), (v1, i1), (v2, i2)] = self.points;
        let dv_alpha = v1.alpha - v0.alpha;
        let dv_beta = v2.beta - v1.beta;
        // G's columns: the current per volt on α, on β [1/Ω].
        let g_a = AlphaBeta::new(
            (i1.alpha - i0.alpha) / dv_alpha,
            (i1.beta - i0.beta) / dv_alpha,
        );
        let g_b = AlphaBeta::new(
            (i2.alpha - i1.alpha) / dv_beta,
            (i2.beta - i1.beta) / dv_beta,
        );
        // Eigenvalues of the symmetric part.
        let (s11, s22, s12) = (g_a.alpha, g_b.beta, 0.5 * (g_a.beta + g_b.alpha));
        let half_tr = 0.5 * (s11 + s22);
        let disc = crate::math::sqrt_or_zero(half_tr * half_tr - (s11 * s22 - s12 * s12));
        let (l_max, l_min) = (half_tr + disc, half_tr - disc);
        // (A non-finite ratio fails both comparisons below: caught by the range check.)
        let ratio = l_min / l_max;

        if l_max <= 0.0 || ratio < 0.15 {
            return Progress::Fail(IdentifyError::OpenPhase);
        }
        if ratio < 0.8 {
            return Progress::Fail(IdentifyError::ShortedPhase);
        }
        let r_ohm = dv_alpha / (i1.alpha - i0.alpha);
        if MotorParams::R_OHM.check("r_ohm", r_ohm).is_err() {
            return Progress::Fail(IdentifyError::ResistanceOutOfRange);
        }
        result.r_ohm = r_ohm;
        Progress::Next(Phase::Inductance(Inductance::new(s, v0, r_ohm)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A settling whose current approaches `i_final` with the lag `tau_ms` from `i_start`
    /// (the three 10 ms means 45 ms apart, as [`Resistance`] sums them).
    fn settling(i_start: f32, i_final: f32, tau_ms: f32) -> Resistance {
        let mut r = Resistance::default();
        for (k, start_ms) in [0.0f32, 45.0, 90.0].into_iter().enumerate() {
            r.approach[k] = (0..10)
                .map(|ms| {
                    let t = start_ms + ms as f32 + 0.5;
                    i_final - (i_final - i_start) * libm::expf(-t / tau_ms)
                })
                .sum();
        }
        r
    }

    #[test]
    fn the_slow_step_ratio_is_that_of_a_33_ms_lag() {
        assert!((SLOW_STEP_RATIO - libm::expf(-45.0 / 33.0)).abs() < 1e-3);
    }

    #[test]
    fn a_slow_windings_current_is_extrapolated_to_where_it_goes() {
        // The Zou twin's 143 ms from a fifth of the level to four times it, rising or falling.
        for (start, end) in [(20.0, 400.0), (400.0, 110.0)] {
            let i = settling(start, end, 143.0).final_current(100.0).unwrap();
            assert!((i / end - 1.0).abs() < 1e-3, "{start} -> {end}: {i}");
        }
    }

    #[test]
    fn the_extrapolation_takes_lags_from_33_to_430_ms() {
        assert_eq!(settling(20.0, 110.0, 30.0).final_current(100.0), None);
        assert!(settling(20.0, 110.0, 36.0).final_current(100.0).is_some());
        assert!(settling(20.0, 110.0, 400.0).final_current(100.0).is_some());
        assert_eq!(settling(20.0, 110.0, 500.0).final_current(100.0), None);
    }

    #[test]
    fn a_fast_winding_a_settled_current_or_a_turning_one_is_left_to_the_ramp() {
        // 10 ms: within the controller's damping.
        assert_eq!(settling(20.0, 110.0, 10.0).final_current(100.0), None);
        // Steps that grow.
        let r = Resistance {
            approach: [1000.0, 1100.0, 1300.0],
            ..Resistance::default()
        };
        assert_eq!(r.final_current(100.0), None);
        // At rest within a hundredth of the level.
        assert_eq!(settling(110.0, 110.5, 143.0).final_current(100.0), None);
        // Steps that turn (a rotor swinging).
        let r = Resistance {
            approach: [1000.0, 1200.0, 1100.0],
            ..Resistance::default()
        };
        assert_eq!(r.final_current(100.0), None);
    }
}
