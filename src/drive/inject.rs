//! The start from standstill through high-frequency injection on a salient motor (feature
//! `injection`, [`crate::injection`] for the method and its literature): instead of the
//! alignment and the open loop, the rotor found at rest is tracked by the injection, its
//! magnet's polarity tested, and then driven in closed loop on the injection's angle and
//! speed from zero speed: the speed loop (the FOC's PI, the MTPA's currents) holds any torque
//! up to the current limit at zero speed; above the hand-over speed (the open loop's,
//! [`StartConfig::handover_rpm`](super::StartConfig::handover_rpm)) for
//! [`HANDOVER_CHECKS`] checks the observers are seeded at the injection's rotor state and
//! sensorless control takes over (`Reason::HandOver`).
//!
//! A zero command at zero speed holds the rotor where it is (torque at standstill is what the
//! injection is for): a position loop on the injection's angle, the rotor's travel since the
//! hold began times `K_θ`, is the speed loop's reference (the P–PI cascade of servo drives,
//! e.g. Ellis, *Control System Design Guide*, 4th ed., ch. 17). With the speed PI of
//! [`FocConfig::gains`](crate::foc::FocConfig::gains) (`k_p = J ω_s/K_t`, zero at `ω_s/4`),
//! the loop's characteristic polynomial over `ω_s` is `x³ + x² + (k + ¼) x + k/4` for
//! `K_θ = k ω_s`. `k = 0.1`, the outer loop a decade below the inner as cascades are set
//! ([`HOLD_GAIN_PER_SPEED_BANDWIDTH`]): roots `(−0.45 ± 0.24j) ω_s` and `−0.095 ω_s`, damping
//! 0.88. (`k = ¼`, damping 0.69 on paper, shook the Zou traction motor ±10° mechanical on its
//! injection's noisy speed, whose 5 ms low-pass the polynomial leaves out.) A load torque
//! ramping at `ρ` N·m/s moves the rotor by `ρ/J · 4/(k ω_s³)` while it ramps (the final
//! value of the loop's response) and back once it is constant: the cascade is of type 2 in
//! the load. The drive stops with the enable.
//!
//! The drive built with the feature starts every salient motor this way. It declines to
//! inject ([`Declined`]) when it is turned off
//! ([`Drive::without_injection`](super::Drive::without_injection)), on a motor whose saliency
//! is too small or inverse, or with a bus, rate or update delay the injection cannot use: it
//! starts as without the feature (align, open loop), and
//! [`Drive::injection`](super::Drive::injection) says why. A polarity test that ends within
//! its noise ([`Phase::Unresolved`]: a d axis that barely saturates) hands the start to the
//! alignment (`Align`, `AtRest`), which finds the magnet by pulling it.

use super::mode::{Entry, Next};
use super::ramp::Ramp;
use super::Reason;
use crate::foc::{CurrentLoopState, Foc, Reference, Request};
use crate::frames::{AlphaBeta, Dq};
use crate::injection::{Injection, InjectionState, Phase};
use crate::math::{clamp, wrap_pi};
use crate::mtpa::Mtpa;
use crate::pi::PiState;
use crate::units::{RAD_S_PER_RPM, RPM_PER_RAD_S};

pub use crate::injection::Declined;

/// Checks (1 kHz) above the hand-over speed before sensorless control takes over.
pub const HANDOVER_CHECKS: u32 = 5;

/// The position hold's gain `K_θ` \[1/s] per speed-loop bandwidth `ω_s` \[rad/s] (module doc).
pub const HOLD_GAIN_PER_SPEED_BANDWIDTH: f32 = 0.1;

/// The injection start's settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    pub(super) injection: Injection,
    /// `1/N`.
    pub(super) inv_n: f32,
    /// The hand-over speed \[rpm].
    pub(super) handover_rpm: f32,
    /// The speed reference's limit and slew.
    pub(super) ramp: Ramp,
    /// The speed estimate's low-pass gain per millisecond.
    pub(super) speed_gain: f32,
    /// The position hold's `K_θ/N` \[1/s]: mechanical speed reference per electrical radian
    /// of travel.
    pub(super) hold_gain: f32,
    /// The position hold's largest speed reference \[rad/s, mechanical]: half the hand-over
    /// speed, so the hold never asks for the hand-over.
    pub(super) hold_max_omega_m: f32,
}

/// The state of the injection start (`DriveState::inject`, kept out of the mode's enum so
/// that its size, which every mode change moves, stays the running modes'). `Default`: θ̂ = 0,
/// the injection's first sample next.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Inject {
    pub(super) inj: InjectionState,
    speed_pi: PiState,
    speed_ref_rpm: f32,
    /// ω̂_m low-passed \[rad/s].
    omega_m: f32,
    /// The current reference while tracking \[A].
    i_ref: Dq,
    /// Checks above the hand-over speed.
    above: u32,
    /// The rotor's travel since the position hold began \[rad, electrical], and the angle it
    /// was last taken from; `None` while a speed is asked for.
    hold: Option<(f32, f32)>,
}

impl Settings {
    /// One step: the injection's demodulation and tracking, the current loop on its
    /// fundamental current in its frame, the injection voltage added on its d axis.
    #[inline(always)]
    pub(super) fn step(
        &self,
        s: &mut Inject,
        foc: &Foc,
        current: &mut CurrentLoopState,
        i_ab: AlphaBeta,
        v_bus: f32,
    ) -> Request {
        let t = self.injection.step(&mut s.inj, i_ab);
        let i_ref = match self.injection.bias(&s.inj) {
            Some(b) => Dq::new(b, 0.0),
            None => s.i_ref,
        };
        let omega_m = s.inj.omega_e * self.inv_n;
        let out =
            foc.current_loop()
                .update(current, t.i_dq, i_ref, s.inj.omega_e, foc.v_max(v_bus));
        Request {
            frame: t.frame,
            frame_out: foc.output_angle(t.frame, omega_m),
            omega_m,
            reference: Reference::Voltage(Dq::new(out.v_dq.d + t.v_d, out.v_dq.q)),
        }
    }

    /// The 1 kHz work: the speed loop on the injection's speed once the polarity is known,
    /// the hand-over above the hand-over speed. Returns the hand-over's entry (the observers
    /// to be seeded at the injection's rotor state first).
    // Out of line: the start's, not the running drive's.
    #[inline(never)]
    pub(super) fn tick(
        &self,
        s: &mut Inject,
        foc: &Foc,
        mtpa: Option<&Mtpa>,
        cmd_rpm: f32,
    ) -> Next {
        if s.inj.phase() != Phase::Track {
            return Next::Stay;
        }
        let omega_m = s.inj.omega_e * self.inv_n;
        s.omega_m += self.speed_gain * (omega_m - s.omega_m);
        let target = self.ramp.command(cmd_rpm);
        s.speed_ref_rpm = self.ramp.slew(s.speed_ref_rpm, target);
        // The position hold (module doc): at a zero command once the reference is there.
        let theta_e = s.inj.theta_e;
        s.hold = (target == 0.0 && s.speed_ref_rpm == 0.0).then(|| match s.hold {
            Some((travel_e, last_e)) => (travel_e + wrap_pi(theta_e - last_e), theta_e),
            None => (0.0, theta_e),
        });
        let hold_omega_m = s.hold.map_or(0.0, |(travel_e, _)| {
            let max = self.hold_max_omega_m;
            clamp(-self.hold_gain * travel_e, -max, max)
        });
        let reference = s.speed_ref_rpm * RAD_S_PER_RPM + hold_omega_m;
        let i_tau = foc.speed_step(&mut s.speed_pi, (reference, s.omega_m), 0.0, None);
        s.i_ref = match mtpa {
            Some(m) => m.split(i_tau, s.i_ref.d, 0.0),
            None => Dq::new(0.0, i_tau),
        };
        let fast = libm::fabsf(s.omega_m * RPM_PER_RAD_S) >= self.handover_rpm
            && libm::fabsf(s.speed_ref_rpm) >= self.handover_rpm;
        s.above = if fast { s.above.saturating_add(1) } else { 0 };
        if s.above >= HANDOVER_CHECKS {
            let entry = Entry {
                omega_m: s.omega_m,
                i_dq: s.i_ref,
                load_nm: None,
                ref_omega_m: reference,
            };
            return Next::Sensorless(entry, Reason::HandOver);
        }
        Next::Stay
    }
}

impl Inject {
    /// The injection's estimate: θ̂_e \[rad, electrical] and ω̂_e \[rad/s, electrical].
    pub(super) fn estimate(&self) -> (f32, f32) {
        (self.inj.theta_e, self.inj.omega_e)
    }

    /// The phase of the injection.
    pub(super) fn phase(&self) -> Phase {
        self.inj.phase()
    }
}
