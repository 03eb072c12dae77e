//! Catch without terminal sensing (flying start with the currents regulated to zero): a board
//! that senses no terminal voltage (the B-G431B-ESC1's firmware passes
//! [`DriveInput::v_ab_terminal`](super::DriveInput) `None`;
//! `PowerStageConfig::terminal_sensing` false) cannot watch a coasting rotor with the PWM
//! off, so the drive switches and holds the stator currents at zero: the voltage that does so
//! is the back-EMF, which gives the rotor's angle and speed with no torque made meanwhile, and
//! the observers run on that commanded voltage until they lock. This is the flying start of
//! TI's InstaSPIN-FOC ("InstaSPIN-FOC and InstaSPIN-MOTION User's Guide", SPRUHJ1, Texas
//! Instruments, "Flying start": the current controllers regulate I_d and I_q to zero while
//! the estimator runs on the commanded voltage, then the speed controller takes over at the
//! estimated speed) and of ST's motor-control SDK ("on-the-fly start-up").
//!
//! The current loop here is a deadbeat one in the stationary frame, which needs no estimate of
//! the rotor (mode [`Mode::Catch`](super::Mode::Catch) throughout):
//! - each step the back-EMF of the period that just ended follows from the R-L-E model,
//!   `e = v − R ī − L Δi/T` (`v` the voltage applied over it, `ī` its mean current, `Δi` its
//!   change), and the next voltage is the one that brings the current to its reference by the
//!   next sample, `v = e⁺ + R i + L (i_ref − i)/T`, `e⁺` the last `e` turned by its mean turn
//!   per step (the predictive current control of an R-L-E load: Holmes & Martin,
//!   "Implementation of a direct digital predictive current controller for single and three
//!   phase voltage source inverters", IEEE IAS 1996). The reference is zero, or once the
//!   back-EMF is measurable a small d current at right angles to it (`i_hold_a`, twice the
//!   dead-time compensation's band: no torque, and phase currents whose sign the
//!   compensation knows, so that the voltage the observers take is the one applied). The
//!   first period applies zero volts (nothing is known yet): the current rises by up to
//!   `N ψ_f |ω_m| T/L` in it, the one current a catch without terminal sensing cannot avoid
//!   at this control rate (9.6 A on Ortega's test motor at rated speed, against its 6.8 A
//!   rated-torque current; the next periods bring it back to the reference);
//! - on a salient motor the stationary frame sees `L_d` along the magnet and `L_q` across it,
//!   at an angle the probe does not know, so one `L` serves both axes: the smaller of the
//!   two. With `L` in both the estimate and the voltage, a current error on an axis of
//!   inductance `L_x` evolves (quasi-statically: the axes turn by `ω_e T` a step) as
//!   `z² − (2 − 2a) z + (1 − a)` with `a = L/L_x`: roots of modulus `√(1 − a)` for
//!   `0 < a ≤ 1` (deadbeat at `a = 1`, a decay per step of `√(1 − L_d/L_q)` on the q axis:
//!   0.87 at `L_q/L_d = 4`), unstable from `a = 4/3` on (`a = 2`: a root at −2.4). The mean
//!   inductance put `a = (1 + ξ)/2` on the d axis (`ξ = L_q/L_d`), unstable from `ξ = 5/3`
//!   on (on the q axis `a = (1 + ξ)/(2ξ)`, from `ξ = 3/5` down): the AMK's, the Brusa's and
//!   the Zou's probe currents grew until the over-current trip (catches without terminal
//!   sensing, `host-sim/tests/salient.rs`). The round motor's `L` is the same either way;
//! - the turn of `e` is summed while it is measurable (the unwrapped angle: the endpoints'
//!   noise only), each step's within what a rotor turns ([`TURN_STEP_MAX`]). Once it has
//!   turned by [`TURN_MIN`], the direction is its sign, `|ω_m| = |ē|/(N ψ_f)` (`ē` the
//!   running mean of its length) and `θ_e = ∠e ∓ 90°`; both observers are seeded there. A
//!   back-EMF not measurable in the first [`REST_STEPS`], or not turning so far in
//!   `max_steps` (the time the slowest measurable rotor takes), is a rotor at rest: the
//!   alignment follows;
//! - a rotor turning with the command is then held so until an observer is usable on its own
//!   evidence (`supervision.rs`): closed loop at its speed, as the catch with terminal
//!   sensing (`catch.rs`); one turning against the command, or `driven` by a load (seen
//!   turning in the alignment, `align.rs`), is taken over in closed loop at once at the
//!   probe's estimate, its speed reference from zero (`Drive::caught_probe`).
//!
//! The measurable back-EMF ([`Settings::v_min`], [`Settings::new`]): the largest of the
//! hand-back speed's back-EMF (the slowest rotor a flying start catches), [`NOISE_SIGMAS`]
//! standard deviations of the estimate's noise per axis, `√(4/3) (L/T) σ_i` with `σ_i` the
//! board's 1 %-of-rated current noise ([`SENSE_NOISE`]; `L/T` multiplies the noise of two
//! samples in `L Δi/T`), and twice the dead time's voltage `t_d f_pwm V_bus` (at zero current
//! the inverter's dead-time error takes the sign of a current that is not there). Below it a
//! rotor is at rest for practical purposes and the alignment's current holds it: 3.3 V on the
//! Sinano motor (13.6 % of its rated speed), 4.0 V on Ortega's test motor (8.7 %).

use super::mode::{Driving, Next};
use crate::foc::{Foc, Reference, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::math::{atan2, rsqrt_normal};
use crate::motor::MotorParams;
use crate::observer::Rotor;
use crate::units::RAD_S_PER_RPM;
use core::f32::consts::FRAC_PI_2;

/// The turn of the back-EMF that ends the probe [rad, electrical]: four times the noise of
/// its angle at the measurable back-EMF (a quarter of a radian at `v_min`, its endpoints'
/// noise: the turn is summed), and at least two steps of [`TURN_STEP_MAX`], so that noise
/// alone reaches it only through three measurable samples in a row.
pub(super) const TURN_MIN: f32 = 1.0;

/// The weight of a step's `|e|` and turn in the probe's running means: their noise to
/// about 0.4 (`√(w/(2 − w))`), their lag behind an accelerating rotor about four steps.
const EMF_WEIGHT: f32 = 0.25;

/// Probe steps after which a back-EMF never measurable is a rotor at rest: the first
/// estimate comes with the second sample, so three estimates.
pub(super) const REST_STEPS: u32 = 4;

/// The turn of the back-EMF by which the alignment's watch takes the rotor as not held (an
/// active load dragging it): half an electrical turn in one direction, past the point
/// opposite the aligned angle where the alignment's torque reverses. A rotor pulled in from
/// within half a turn of it turns less (its speed passes zero where the sum starts again);
/// one pulled in from the very opposite angle may reach it, and is then caught in closed loop
/// like a dragged one, harmlessly.
pub(super) const TURN_ALIGN: f32 = core::f32::consts::PI;

/// The current sensing's noise the measurable back-EMF is set against, a fraction of the
/// rated-torque current: the 1 % a board's sensing has (`DESIGN.md`, the dead-time band of
/// `DriveConfig::new`).
pub(super) const SENSE_NOISE: f32 = 0.01;

/// The largest turn of the back-EMF between two steps that a rotor makes [rad, electrical]:
/// an eighth of a turn per step, an electrical frequency of an eighth of the control rate
/// (500 Hz at 4 kHz), beyond any rotor within its over-speed bound; the turn between two
/// estimates of noise alone is anywhere in ±π, so a run of them that sums to [`TURN_MIN`]
/// needs several measurable noise samples in a row, each within it.
const TURN_STEP_MAX: f32 = core::f32::consts::FRAC_PI_4;

/// The measurable back-EMF in standard deviations of its estimate's noise: a sample of noise
/// alone beyond it has the probability `exp(−4²/2)` = 3.4e-4 (the estimate is
/// two-dimensional: its length is Rayleigh-distributed).
const NOISE_SIGMAS: f32 = 4.0;

/// √(4/3): the noise of a back-EMF estimate per axis per unit of `(L/T) σ_i` (`Settings::new`).
const SQRT_4_3: f32 = 1.154_700_5;

/// What [`Settings::new`] takes of the drive's configuration.
pub(super) struct From {
    /// The step rate \[Hz].
    pub(super) rate_hz: f32,
    /// The rated torque \[N·m] and bus \[V].
    pub(super) rated_torque_nm: f32,
    pub(super) bus_v: f32,
    /// The hand-back speed \[rpm].
    pub(super) handback_rpm: f32,
    /// The power stage's dead time \[s], PWM frequency \[Hz] and dead-time band \[A].
    pub(super) dead_time_s: f32,
    pub(super) pwm_hz: f32,
    pub(super) dead_time_band_a: f32,
    /// Checks for an observer to lock before an observer loss.
    pub(super) timeout_checks: u32,
}

/// The catch's coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// The smallest measurable back-EMF \[V] (module doc).
    pub(super) v_min: f32,
    /// The drive's model: R \[Ω] ...
    pub(super) r_ohm: f32,
    /// ... and L/T \[V/A], `L` the smaller of `L_d` and `L_q` (module doc).
    pub(super) l_over_t: f32,
    /// The d current held while the back-EMF is measurable \[A]: twice the dead-time
    /// compensation's band (`PowerStageConfig::dead_time_band_a`), so that every phase
    /// current but near its zero crossings has a sign the compensation knows.
    pub(super) i_hold_a: f32,
    /// 1/(N ψ_f): ω_m per volt of back-EMF \[rad/(s·V)].
    pub(super) omega_m_per_v: f32,
    /// N T/2 \[s]: the rotation from the middle of the last period to now per rad/s of ω_m.
    pub(super) half_n_ts: f32,
    /// Steps of probe before a rotor that did not turn by [`TURN_MIN`] is taken as at rest:
    /// the time the slowest measurable rotor (`v_min`) takes to turn so far.
    pub(super) max_steps: u32,
    /// Checks for an observer to lock before an observer loss.
    pub(super) timeout_checks: u32,
}

/// The back-EMF watched step by step (the probe's, and the alignment's motion check): the
/// last current and estimate, the turn summed while measurable.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Watch {
    /// The current of the last sample \[A].
    i_prev: AlphaBeta,
    /// The last back-EMF estimate \[V] (zero before the first).
    e_prev: AlphaBeta,
    /// The back-EMF's turn summed while measurable [rad, electrical].
    turn: f32,
    /// Steps summed in `turn`.
    counted: u32,
    /// The running mean of the turn per step (weight [`EMF_WEIGHT`]) [rad, electrical].
    rho: f32,
    /// The running mean of `|e|` over them (weight [`EMF_WEIGHT`]: the last few steps, so
    /// that a rotor a load accelerates is seen at its speed now) \[V].
    emf: f32,
    /// A voltage known to have been applied over the last period (an estimate can be made).
    primed: bool,
}

impl Watch {
    /// The turn summed while measurable [rad, electrical].
    pub(super) fn turn(&self) -> f32 {
        self.turn
    }
}

/// The state of the catch without terminal sensing.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct CatchZero {
    /// Probe steps taken.
    steps: u32,
    /// Entered from a rotor seen turning under a load (the alignment's watch): closed loop
    /// as soon as the probe has seen it, the observers trusted at its estimate.
    driven: bool,
    /// The observers have been seeded.
    seeded: bool,
    /// Checks since the seed.
    checks: u32,
}

/// What a probe step decided.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Probe {
    /// Apply this request.
    Run(Request),
    /// The rotor at rest: align it.
    AtRest,
    /// The back-EMF's rotor: seed both observers there; apply the request.
    Rotor(Rotor, Request),
}

impl CatchZero {
    /// The observers have been seeded.
    pub(super) fn seeded(&self) -> bool {
        self.seeded
    }

    /// A probe entered from the alignment, whose watch saw the rotor turning (driven by a
    /// load): it goes on from there (the watch is the drive's, `DriveState::watch`).
    pub(super) fn driven() -> Self {
        Self {
            driven: true,
            ..Self::default()
        }
    }

    /// Entered from a rotor seen turning under a load.
    pub(super) fn is_driven(&self) -> bool {
        self.driven
    }
}

/// `v` turned by the angle whose sine is `s` and cosine `c`.
#[inline(always)]
fn turned(v: AlphaBeta, s: f32, c: f32) -> AlphaBeta {
    AlphaBeta::new(c * v.alpha - s * v.beta, s * v.alpha + c * v.beta)
}

impl Settings {
    /// The settings for the drive's motor model `m` and `c` (from `DriveConfig`): the
    /// measurable back-EMF
    /// `v_min = max(N ψ_f ω_handback, NOISE_SIGMAS √(4/3) (L/T) σ_i, 2 t_d f_pwm V_bus)`
    /// (`σ_i` = [`SENSE_NOISE`] of the rated-torque current, `V_bus` the rated bus; module
    /// doc); the probe's length, the time a rotor at `v_min` takes to turn by `TURN_MIN`,
    /// `TURN_MIN ψ_f/(v_min T)` steps, plus [`REST_STEPS`].
    pub(super) fn new(m: &MotorParams, c: &From) -> Self {
        let rate = c.rate_hz;
        let i_rated = c.rated_torque_nm / m.torque_constant();
        let ke = m.emf_constant();
        let l_over_t = m.l_d_h() * crate::math::min(1.0, m.saliency) * rate;
        let v_handback = ke * c.handback_rpm * RAD_S_PER_RPM;
        // Per axis: the difference of two samples (√2) of the phase currents' noise in α or β
        // (√(2/3) of a phase's, amplitude-invariant Clarke), times L/T.
        let sigma_e = SQRT_4_3 * l_over_t * SENSE_NOISE * i_rated;
        let v_noise = NOISE_SIGMAS * sigma_e;
        let v_dead = 2.0 * c.dead_time_s * c.pwm_hz * c.bus_v;
        let v_min = v_handback.max(v_noise).max(v_dead);
        let probe_steps = TURN_MIN * m.flux_wb * rate / v_min;
        Settings {
            v_min,
            r_ohm: m.r_ohm,
            l_over_t,
            i_hold_a: 2.0 * c.dead_time_band_a,
            omega_m_per_v: 1.0 / ke,
            half_n_ts: 0.5 * m.n() / rate,
            max_steps: (probe_steps as u32).saturating_add(REST_STEPS),
            timeout_checks: c.timeout_checks,
        }
    }

    /// One step of the watch: `i_ab` measured now \[A], `v_ab` applied over the period that
    /// just ended \[V]; returns this period's back-EMF estimate \[V] (zero before a period
    /// with a known voltage), its turn summed while it is measurable.
    // Out of line: the start's (the alignment's and the catch's), not the running drive's.
    #[inline(never)]
    pub(super) fn watch(&self, w: &mut Watch, i_ab: AlphaBeta, v_ab: AlphaBeta) -> AlphaBeta {
        let i_prev = w.i_prev;
        w.i_prev = i_ab;
        // The period that just ended: e = v − R ī − L Δi/T.
        let e = if w.primed {
            let (r, lt) = (0.5 * self.r_ohm, self.l_over_t);
            AlphaBeta::new(
                v_ab.alpha - r * (i_ab.alpha + i_prev.alpha) - lt * (i_ab.alpha - i_prev.alpha),
                v_ab.beta - r * (i_ab.beta + i_prev.beta) - lt * (i_ab.beta - i_prev.beta),
            )
        } else {
            AlphaBeta::default()
        };
        w.primed = true;
        let emf2 = e.alpha * e.alpha + e.beta * e.beta;
        let prev = w.e_prev;
        let emf2_prev = prev.alpha * prev.alpha + prev.beta * prev.beta;
        w.e_prev = e;
        let v_min2 = self.v_min * self.v_min;
        // Both measurable (false for a NaN too): the turn between them, if a rotor can turn
        // so far in a step (noise turns anywhere).
        let turn = if emf2 >= v_min2 && emf2_prev >= v_min2 {
            let cross = prev.alpha * e.beta - prev.beta * e.alpha;
            let dot = prev.alpha * e.alpha + prev.beta * e.beta;
            atan2(cross, dot)
        } else {
            f32::NAN
        };
        // (false for the NaN)
        if turn.abs() <= TURN_STEP_MAX {
            w.turn += turn;
            w.rho = if w.counted == 0 {
                turn
            } else {
                w.rho + (turn - w.rho) * EMF_WEIGHT
            };
            let emf = emf2 * rsqrt_normal(emf2, 3);
            w.emf = if w.counted == 0 {
                emf
            } else {
                w.emf + (emf - w.emf) * EMF_WEIGHT
            };
            w.counted += 1;
        } else {
            // Not measurable: the turn starts again (a rotor at rest shows noise only).
            w.turn = 0.0;
            w.counted = 0;
            w.emf = 0.0;
        }
        e
    }

    /// One probe step: `i_ab` measured now \[A], `v_ab` applied over the period that just
    /// ended \[V] (module doc, phase 1).
    // Out of line, like the mode changes: only between an enable and the start.
    #[inline(never)]
    pub(super) fn probe(
        &self,
        c: &mut CatchZero,
        w: &mut Watch,
        i_ab: AlphaBeta,
        v_ab: AlphaBeta,
    ) -> Probe {
        c.steps = c.steps.saturating_add(1);
        let e = self.watch(w, i_ab, v_ab);
        // The next period's back-EMF: this one turned by the mean turn per step.
        let rho = w.rho;
        let e_next = turned(e, rho, 1.0 - 0.5 * rho * rho);
        // Deadbeat: the current to its reference by the next sample, a d current of
        // `i_hold_a` (at right angles to the back-EMF, no torque) once it is measurable, else
        // zero.
        let emf2 = e_next.alpha * e_next.alpha + e_next.beta * e_next.beta;
        let i_ref = if emf2 >= self.v_min * self.v_min {
            let scale = self.i_hold_a * rsqrt_normal(emf2, 3);
            AlphaBeta::new(-e_next.beta * scale, e_next.alpha * scale)
        } else {
            AlphaBeta::default()
        };
        let (r, lt) = (self.r_ohm, self.l_over_t);
        let v = AlphaBeta::new(
            e_next.alpha + r * i_ab.alpha + lt * (i_ref.alpha - i_ab.alpha),
            e_next.beta + r * i_ab.beta + lt * (i_ref.beta - i_ab.beta),
        );
        let request = Request {
            frame: SinCos::ZERO,
            frame_out: SinCos::ZERO,
            omega_m: 0.0,
            reference: Reference::Voltage(Dq::new(v.alpha, v.beta)),
        };
        if c.seeded {
            // Seeded: the currents held while the observers lock.
            return Probe::Run(request);
        }
        if w.turn.abs() >= TURN_MIN && w.counted > 0 {
            let sign = if w.turn < 0.0 { -1.0 } else { 1.0 };
            let omega_m = sign * w.emf * self.omega_m_per_v;
            let theta_mid = atan2(e.beta, e.alpha) - sign * FRAC_PI_2;
            c.seeded = true;
            let rotor = Rotor {
                theta_e: theta_mid + self.half_n_ts * omega_m,
                omega_m,
                load_nm: 0.0,
            };
            return Probe::Rotor(rotor, request);
        }
        // Nothing measurable after the first estimates, or no turn in the time the slowest
        // measurable rotor takes: at rest.
        let quiet = w.counted == 0 && c.steps > REST_STEPS;
        if quiet || c.steps >= self.max_steps {
            return Probe::AtRest;
        }
        Probe::Run(request)
    }

    /// The 1 kHz work after the seed, `driving` the driving observer's estimate once one is usable:
    /// closed loop at its speed with the current of its load estimate (zero without one), the
    /// speed reference from the rotor's speed, or from zero for a rotor turning against the
    /// command `cmd_rpm` (`Entry::reference`, as every other hand-over), or an observer loss
    /// at the time limit.
    #[inline(always)]
    pub(super) fn tick(
        &self,
        c: &mut CatchZero,
        foc: &Foc,
        driving: Option<Driving>,
        cmd_rpm: f32,
    ) -> Next {
        Next::caught(foc, driving, cmd_rpm, &mut c.checks, self.timeout_checks)
    }
}
