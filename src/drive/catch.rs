//! Catch (flying start): the PWM stays off while the observers watch the terminal voltage.
//! With no current the stator voltage is the back-EMF, the rotor flux's derivative
//! (Ortega et al. eqs (1), (4) with `i = 0`): `v = ω_e ψ_f [−sin θ_e, cos θ_e]`. Its length
//! gives |ω_e|, the turn between two samples the direction, its angle θ_e ∓ 90°; both observers
//! are seeded there and must then lock on their own evidence (`supervision.rs`) before
//! closed loop starts at the observed speed with zero current (the current loop's back-EMF
//! feed-forward applies the rotor's own voltage: no current step). A rotor whose back-EMF is
//! below that of the slowest catch speed is taken as at rest and aligned. Needs a board that
//! senses the terminal voltage ([`DriveInput::v_ab_terminal`](super::DriveInput)); without it
//! an enable aligns, or, on a board configured without terminal sensing
//! (`PowerStageConfig::terminal_sensing` false), catches the rotor with its currents
//! regulated to zero (`catch_zero.rs`).
//!
//! Reading the back-EMF of a coasting motor through the phase-voltage dividers before the
//! switches start is the usual flying-start of sensorless drives (e.g. ST's motor-control
//! SDK "on-the-fly start-up", VESC's observer on the sensed phase voltages).

use super::mode::{Driving, Next};
use crate::foc::Foc;
use crate::frames::AlphaBeta;
use crate::math::{atan2, rsqrt_normal};
use crate::observer::Rotor;
use core::f32::consts::FRAC_PI_2;

/// Catch's coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// A back-EMF below this is a rotor at rest \[V].
    pub(super) v_min: f32,
    /// 1/(N ψ_f): ω_m per volt of back-EMF \[rad/(s·V)].
    pub(super) omega_m_per_v: f32,
    /// N T/2 \[s]: the rotation from the middle of the last period to now per rad/s of ω_m.
    pub(super) half_n_ts: f32,
    /// Checks for an observer to lock before an observer loss.
    pub(super) timeout_checks: u32,
}

/// The state of [`Mode::Catch`](super::Mode::Catch).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Catch {
    /// Steps taken.
    steps: u32,
    /// The terminal voltage of the previous step \[V].
    v_prev: AlphaBeta,
    /// The observers have been seeded.
    seeded: bool,
    /// Checks since the seed.
    checks: u32,
}

/// What a catch step saw.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Seen {
    /// Nothing yet (or the observers already seeded).
    Wait,
    /// The rotor at rest: align it.
    AtRest,
    /// The back-EMF's rotor: seed both observers there.
    Rotor(Rotor),
}

impl Catch {
    /// The observers have been seeded.
    pub(super) fn seeded(&self) -> bool {
        self.seeded
    }
}

impl Settings {
    /// The terminal voltage over the coming period with the PWM off \[V]: `v_ab`, this
    /// period's, turned on as far as it turned since the last (the back-EMF turns at ω_e:
    /// `v_ab · v_ab/v_prev` as complex numbers), or `v_ab` itself before a last one above
    /// `v_min`. The observers take it should the catch hand over at the next step.
    pub(super) fn next_period(&self, c: &Catch, v_ab: AlphaBeta) -> AlphaBeta {
        let p = c.v_prev;
        let p2 = p.alpha * p.alpha + p.beta * p.beta;
        // (False for a NaN sample too.)
        let seen = p2 >= self.v_min * self.v_min;
        if !seen {
            return v_ab;
        }
        // The turn `v_ab/v_prev` = v_ab · conj(v_prev)/|v_prev|².
        let (c_re, c_im) = (
            (v_ab.alpha * p.alpha + v_ab.beta * p.beta) / p2,
            (v_ab.beta * p.alpha - v_ab.alpha * p.beta) / p2,
        );
        AlphaBeta::new(
            v_ab.alpha * c_re - v_ab.beta * c_im,
            v_ab.alpha * c_im + v_ab.beta * c_re,
        )
    }

    /// One catch step with the PWM off, `v_ab` the terminal voltage of the period that just
    /// ended \[V]. Before the seed: two samples of back-EMF above `v_min` in a row (a first
    /// sample taken before any period was measured reads zero), or the rotor at rest; then the
    /// back-EMF's rotor, once (the drive seeds both observers there).
    // Out of line, like the mode changes: only between an enable and the start.
    #[inline(never)]
    pub(super) fn step(&self, c: &mut Catch, v_ab: AlphaBeta) -> Seen {
        c.steps = c.steps.saturating_add(1);
        let prev = core::mem::replace(&mut c.v_prev, v_ab);
        if c.seeded {
            return Seen::Wait;
        }
        let emf2 = v_ab.alpha * v_ab.alpha + v_ab.beta * v_ab.beta;
        let emf2_prev = prev.alpha * prev.alpha + prev.beta * prev.beta;
        // A back-EMF seen (false for a NaN sample too); squares compared.
        let v_min2 = self.v_min * self.v_min;
        let (seen, seen_prev) = (emf2 >= v_min2, emf2_prev >= v_min2);
        if c.steps < 2 || !seen_prev {
            // A first sample, or the last one too small: the rotor at rest once two are.
            if c.steps >= 3 && !seen {
                return Seen::AtRest;
            }
            return Seen::Wait;
        }
        if !seen {
            return Seen::AtRest;
        }
        // The back-EMF turns with the rotor: its turn between the two samples is the sign.
        let turn = prev.alpha * v_ab.beta - prev.beta * v_ab.alpha;
        let sign = if turn < 0.0 { -1.0 } else { 1.0 };
        // |v| ≥ v_min > 0: a normal square.
        let emf = emf2 * rsqrt_normal(emf2, 3);
        let omega_m = sign * emf * self.omega_m_per_v;
        let theta_mid = atan2(v_ab.beta, v_ab.alpha) - sign * FRAC_PI_2;
        c.seeded = true;
        Seen::Rotor(Rotor {
            theta_e: theta_mid + self.half_n_ts * omega_m,
            omega_m,
            load_nm: 0.0,
        })
    }

    /// Catch's 1 kHz work after the seed, `driving` the driving observer's estimate once one is
    /// usable (the drive's health check ran): closed loop at its speed with the current of
    /// its load estimate (zero without one), the speed reference from the rotor's speed, or
    /// from zero for a rotor turning against the command `cmd_rpm` (`Entry::reference`, as
    /// every other hand-over: braked at the current limit, not carried on in reverse at the
    /// ramp's pace), or an observer loss at the time limit.
    #[inline(always)]
    pub(super) fn tick(
        &self,
        c: &mut Catch,
        foc: &Foc,
        driving: Option<Driving>,
        cmd_rpm: f32,
    ) -> Next {
        Next::caught(foc, driving, cmd_rpm, &mut c.checks, self.timeout_checks)
    }
}
