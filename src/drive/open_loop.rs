//! Open loop (I/f start): a current of fixed magnitude along the d axis of a frame at angle
//! θ_ol whose frequency ramps; the rotor follows it, lagging by `asin(τ/(N ψ_f I_ol))`. The
//! frame is kept as sin/cos of θ_ol, turned by `N ω_ol T` each step (no trigonometry on the
//! step's path).
//!
//! Supervised by the observers (the flux observer, seeded at the aligned rotor, sees the rotor
//! from the first turn; `supervision.rs`): closed loop on the first usable observer once the
//! ramp has reached the hand-over speed (or the command, if lower but at least
//! `held_below_rpm`) with the rotor seen following it (the observer's speed within half of
//! ω_ol for the lock time, or its angle within a quarter turn of θ_ol while θ_ol turns a whole
//! turn: at a few % of rated the speed estimate is noisy and a heavy rotor hunts about the I/f
//! frame, while a blocked rotor is outside that quarter turn for half of every turn), at once
//! when that observer sees the rotor pulled out of the ramp above the hand-back speed (its
//! speed off ω_ol by half: the load is more than the I/f current carries, and the speed loop
//! has up to `i_max_a`); a stall when no hand-over came within the time limit, at any speed (a
//! blocked rotor at a small command); stopped when the ramp is at zero with a zero command.
//!
//! A nonzero command below `held_below_rpm` is held in the I/f, supervised (issue #26's
//! low-speed profiles): the rotor seen following restarts the time limit, so a rotor that is
//! blocked or left behind ends in `Stall` within it; a command raised above that speed hands
//! over as a start does, and sensorless control hands a command lowered below it back to the
//! I/f (`sensorless.rs`). That speed (`DriveConfig::if_held_below_rpm`, at most the hand-back
//! speed) is where a resistance 5 % off at the I/f current moves the back-EMF the observers
//! see by the health check's largest disagreement (30°): below it a model error is no longer
//! small against the back-EMF, and the observers fit the model they are given, so their
//! residual does not show it. It is 4.7 % of rated on the Nanotec DF45 and on the made-up
//! `gimbal-high-r`, 3.7 % on the iPower gimbal, 2.7 % on the Sinano motor and 0.06–2.4 % on
//! the other zoo motors and presets, whose 3 % runs stay in closed loop (issue #17). Measured
//! on the DF45 (identified, board defaults, `profile-slow-ramp-3`, 3 % of rated under a 50 %
//! active load): at 95 rpm its back-EMF is 0.30 V against R|i| = 2.7 V and the dead-time
//! voltage's 0.61 V. Handed over at the command, the driving flux observer's angle drifted
//! to −70° within 0.6 s while its residual stayed healthy (R within 0.3 %), i_d rose to 13 A
//! and the drive tripped `Overcurrent`. Held in the I/f, the command is reached and held on
//! every zoo motor, both primaries, five seeds (`host-sim/matrices/zoo-profiles.toml`).
//!
//! The stop: sensorless control hands a rotor stopping on a zero command back below the
//! hand-over speed (`sensorless.rs`: there a model error, a winding warmer than the start
//! measured, is no longer small against the back-EMF), and the I/f ramp carries it to zero, the
//! start backwards. With a zero command a rotor seen following the ramp is not handed over
//! again; one pulled out of it (a load beyond the I/f current) or turning against it is, with
//! its speed reference at zero: the speed loop brakes it to the stop.
//!
//! Never handed over in reverse: a usable observer that sees the rotor turn against the
//! ramp's direction above the hand-back speed (an active load beyond the I/f current drags
//! it backwards) for `reverse_checks` checks at which its residual is below the level whose
//! mean loses an observer (not a seeded observer's first swings), takes over in closed loop at
//! once
//! (`Reason::AgainstCommand`), its speed reference starting at zero so that the speed loop
//! brakes the rotor with up to `i_max_a` before it follows the command; any hand-over of a
//! rotor turning against the command starts the reference at zero too (`Entry::reference`).

use super::mode::{against, Driving, Entry, Next};
use super::ramp::Ramp;
use super::supervision::{consecutive, Health, Verdict};
use super::{Fault, Reason};
use crate::foc::{Foc, Reference, Request};
use crate::frames::{Dq, SinCos};
use crate::math::{clamp, sqrt_or_zero};
use crate::units::{RAD_S_PER_RPM, RPM_PER_RAD_S};

/// Open loop's per-step coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// Magnitude of the I/f current \[A].
    pub(super) current_a: f32,
    /// N·T \[s]: θ_ol's advance per step per rad/s of ω_ol.
    pub(super) n_ts: f32,
    /// The hand-over speed \[rpm].
    pub(super) handover_rpm: f32,
    /// Checks in open loop before a stall: the ramp to the hand-over speed and the hand-over
    /// time limit.
    pub(super) timeout_checks: u32,
    /// Checks of a rotor pulled out of the ramp, or following it, before the hand-over.
    pub(super) pullout_checks: u32,
    /// The sum of |ω_ol| \[rpm] over consecutive checks that turns θ_ol by an electrical
    /// turn, `2π/(N T_check)` in rpm: a rotor within a quarter turn of θ_ol while it turned
    /// this far follows the ramp.
    pub(super) turn_rpm_checks: f32,
    /// Checks of a rotor turning against the ramp before the closed loop takes it: the
    /// supervision's failover time (a change the health check trusts that fast).
    pub(super) reverse_checks: u32,
    /// Above this |ω_ol| a rotor off the ramp has pulled out (below it a rotor still
    /// accelerating from rest lags the ramp too) \[rpm]: the hand-back speed.
    pub(super) handback_rpm: f32,
    /// A nonzero |command| below this is held in the I/f, supervised \[rpm]
    /// (`DriveConfig::if_held_below_rpm`).
    pub(super) held_below_rpm: f32,
    /// The command's limit and the frequency ramp.
    pub(super) ramp: Ramp,
}

/// The state of [`Mode::OpenLoop`](super::Mode::OpenLoop).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct OpenLoop {
    /// sin/cos of θ_ol [rad, electrical]: turned by `step_rot` every step.
    frame: SinCos,
    /// sin/cos of θ_ol's advance per step, `N ω_ol T`, kept while the ramp holds (1 kHz).
    step_rot: SinCos,
    /// sin/cos of the output angle's lead over θ_ol at ω_ol (`Foc::output_rotation`).
    out_rot: SinCos,
    /// ω_ol [rpm, mechanical].
    speed_rpm: f32,
    /// Checks in open loop.
    checks: u32,
    /// Consecutive checks with the rotor pulled out of the ramp.
    pulled_out: u32,
    /// Consecutive checks with the rotor following the ramp.
    following: u32,
    /// The sum of |ω_ol| \[rpm] over the consecutive checks with the rotor within a quarter
    /// turn of θ_ol (θ_ol's turn since, in units of `N T_check` rad).
    within_rpm_checks: f32,
    /// The user's command at the last check \[rpm] (infinite before the first: no rise).
    last_cmd_rpm: f32,
    /// Consecutive checks with the rotor turning against the ramp.
    reversed: u32,
}

impl OpenLoop {
    /// At rest at θ_e = 0 (after the alignment).
    pub(super) const AT_REST: Self = Self {
        frame: SinCos::ZERO,
        step_rot: SinCos::ZERO,
        out_rot: SinCos::ZERO,
        speed_rpm: 0.0,
        checks: 0,
        pulled_out: 0,
        following: 0,
        within_rpm_checks: 0.0,
        last_cmd_rpm: f32::INFINITY,
        reversed: 0,
    };

    /// sin/cos of θ_ol.
    pub(super) fn frame(&self) -> SinCos {
        self.frame
    }

    /// ω_ol [rpm, mechanical].
    pub(super) fn speed_rpm(&self) -> f32 {
        self.speed_rpm
    }
}

impl Settings {
    /// The open loop at θ_ol = angle of `frame` and ω_ol = `omega_m` \[rad/s] (the hand-back),
    /// θ_ol ahead by `asin(i_q_a/I_ol)` so that its current carries the torque current
    /// `i_q_a` \[A] at once.
    // Out of line, like the other mode changes: rare, kept off the every-step path.
    #[inline(never)]
    pub(super) fn at(&self, foc: &Foc, frame: SinCos, omega_m: f32, i_q_a: f32) -> OpenLoop {
        // (A zero or NaN torque current leaves the frame as it is.)
        let frame = if i_q_a.abs() > 0.0 {
            let sin = clamp(i_q_a / self.current_a, -1.0, 1.0);
            frame.rotated(SinCos {
                sin,
                cos: sqrt_or_zero(1.0 - sin * sin),
            })
        } else {
            frame
        };
        let mut ol = OpenLoop {
            frame,
            speed_rpm: omega_m * RPM_PER_RAD_S,
            ..OpenLoop::AT_REST
        };
        self.set_speed(&mut ol, foc);
        ol
    }

    /// The rotations for the speed `speed_rpm` just set: θ_ol's advance per step and the
    /// output angle's lead.
    #[inline(always)]
    fn set_speed(&self, ol: &mut OpenLoop, foc: &Foc) {
        let omega_m = ol.speed_rpm * RAD_S_PER_RPM;
        ol.step_rot = SinCos::of_small(self.n_ts * omega_m);
        ol.out_rot = foc.output_rotation(omega_m);
    }

    /// One open-loop step: the frame turned by `N ω_ol T`; the request is the I/f current in
    /// θ_ol's frame.
    #[inline(always)]
    pub(super) fn step(&self, ol: &mut OpenLoop) -> Request {
        ol.frame = ol.frame.rotated(ol.step_rot);
        Request {
            frame: ol.frame,
            frame_out: ol.frame.rotated(ol.out_rot),
            omega_m: ol.speed_rpm * RAD_S_PER_RPM,
            reference: Reference::Current(Dq::new(self.current_a, 0.0)),
        }
    }

    /// The open loop's 1 kHz work ([`Drive::tick`](super::Drive::tick)), after the health
    /// check (its `verdict`, the `health` it left; `driving` the driving observer's estimate
    /// when one is usable):
    /// the hand-over, the time limit, the frame's length renewed, the ramp toward the user's
    /// `cmd_rpm` and the stop at zero.
    // Out of line (in flash on a board whose step runs from RAM): the start-up's, not the
    // running drive's.
    #[inline(never)]
    pub(super) fn tick(
        &self,
        ol: &mut OpenLoop,
        foc: &Foc,
        verdict: Verdict,
        driving: Option<Driving>,
        health: &Health,
        cmd_rpm: f32,
    ) -> Next {
        let cmd_rpm = self.ramp.command(cmd_rpm);
        let omega_m = ol.speed_rpm * RAD_S_PER_RPM;
        // The time limit waits while a command below the hand-over speed is still rising: a
        // slow ramp to a low speed is followed as long as it lasts (the observers see the
        // rotor follow only once it turns fast enough, and the command ends its rise at the
        // latest at the hand-over speed); every other check counts.
        let rising_low = cmd_rpm.abs() > ol.last_cmd_rpm.abs() && cmd_rpm.abs() < self.handover_rpm;
        ol.last_cmd_rpm = cmd_rpm;
        if !rising_low {
            ol.checks = ol.checks.saturating_add(1);
        }
        if verdict == Verdict::Contradiction {
            return Next::Fault(Fault::ObserverLoss);
        }
        if let Some(d) = driving {
            // Pulled out: the rotor is not where the ramp is (above the hand-back speed: below
            // it a rotor still accelerating from rest lags the ramp too).
            let off = (d.omega_m - omega_m).abs() > 0.5 * omega_m.abs();
            let fast = ol.speed_rpm.abs() >= self.handback_rpm;
            ol.pulled_out = consecutive(ol.pulled_out, off && fast);
            // Seen following the ramp at the hand-over speed (or the command, if lower): below
            // it a blocked rotor shows no back-EMF, so the observer must see it turn with the
            // I/f current's frame, which it does even at a standstill.
            let reached = ol.speed_rpm.abs() >= self.handover_rpm.min(cmd_rpm.abs());
            ol.following = consecutive(ol.following, !off && ol.speed_rpm != 0.0);
            // Or within a quarter turn of θ_ol (cos(θ_ol − θ̂) > 0) while θ_ol turned a whole
            // turn: a blocked rotor is outside that quarter turn on either side of θ_ol for
            // half of any turn. The angle, not the speed: the observer's speed at a few % of
            // rated is noisy, and a rotor hunting about the I/f frame (undamped, ±70 % of
            // ω_ol on a heavy rotor) is still in it.
            let cos_load_angle = ol.frame.cos * d.frame.cos + ol.frame.sin * d.frame.sin;
            ol.within_rpm_checks = if cos_load_angle > 0.0 {
                ol.within_rpm_checks + ol.speed_rpm.abs()
            } else {
                0.0
            };
            let seen_following =
                ol.following >= self.pullout_checks || ol.within_rpm_checks >= self.turn_rpm_checks;
            // A low command (a zero one too: `held_below_rpm` > 0) is not handed over: it
            // stays with the I/f (module doc), and the rotor seen following it restarts the
            // time limit.
            let low_command = cmd_rpm.abs() < self.held_below_rpm;
            if seen_following && low_command {
                ol.checks = 0;
            }
            // Turning against the ramp (or the command, at the ramp's start) above the
            // hand-back speed: the closed loop takes it now, braking it first.
            let direction = if ol.speed_rpm != 0.0 {
                ol.speed_rpm
            } else {
                cmd_rpm
            };
            // On an estimate whose residual at this check is below the level whose mean loses
            // an observer (a check above it restarts the count): after the align both
            // observers are seeded healthy, and a sliding observer at rest swung to 1,200 to
            // 4,900 rpm in its first milliseconds (residual 1.4 to 4.3) on the Caruso IPM,
            // handing a resting rotor to sensorless control on a wrong angle. (Counting on
            // through such checks, or up to the edge of lock, took real reversals sooner, on
            // observers less converged: the hoverboard's J × 10 active-load start passed 9 of
            // 16 runs, against 12 so and 11 without the check.)
            let backwards = health.driving_residual_below_lost()
                && against(d.omega_m, direction)
                && d.omega_m.abs() * RPM_PER_RAD_S >= self.handback_rpm;
            ol.reversed = consecutive(ol.reversed, backwards);
            let reason = if ol.reversed >= self.reverse_checks {
                Some(Reason::AgainstCommand)
            } else if (reached && seen_following && !low_command)
                || ol.pulled_out >= self.pullout_checks
            {
                Some(Reason::HandOver)
            } else {
                None
            };
            if let Some(reason) = reason {
                // Never carried on in reverse: against the command, the reference from zero.
                // A zero command's (a stop the open loop could not carry): the reference at
                // zero, the speed loop brakes the rotor to the stop.
                let ref_omega_m = if cmd_rpm == 0.0 {
                    0.0
                } else {
                    Entry::reference(d.omega_m, cmd_rpm)
                };
                let entry = Entry {
                    ref_omega_m,
                    ..self.handover(ol, d)
                };
                return Next::Sensorless(entry, reason);
            }
        }
        // No hand-over within the time limit, at any speed.
        if ol.checks >= self.timeout_checks {
            return Next::Fault(Fault::Stall);
        }
        // The rotations since the last time moved the frame's length by a few 1e-7.
        ol.frame = ol.frame.renormalized();
        // The I/f frequency ramp.
        ol.speed_rpm = self.ramp.slew(ol.speed_rpm, cmd_rpm);
        self.set_speed(ol, foc);
        if cmd_rpm == 0.0 && ol.speed_rpm == 0.0 {
            return Next::Stopped;
        }
        Next::Stay
    }

    /// The hand-over: the open-loop current in the driving observer's frame `d` (its q part
    /// the speed loop's start, its d part fading, `sensorless::Settings::enter`), the
    /// reference from its speed.
    // Out of line, like the other mode changes: rare, kept off the every-step path.
    #[inline(never)]
    fn handover(&self, ol: &OpenLoop, d: Driving) -> Entry {
        core::hint::cold_path();
        let p = d.frame;
        // cos and sin(θ_ol − θ̂) of this sample.
        let cos_load_angle = ol.frame.cos * p.cos + ol.frame.sin * p.sin;
        let sin_load_angle = ol.frame.sin * p.cos - ol.frame.cos * p.sin;
        let i = self.current_a;
        Entry {
            omega_m: d.omega_m,
            i_dq: Dq::new(i * cos_load_angle, i * sin_load_angle),
            load_nm: d.load_nm,
            ref_omega_m: d.omega_m,
        }
    }
}
