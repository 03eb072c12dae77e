//! Supervision, apart from control: each observer's health from its own evidence
//! ([`Observer::residual`](crate::observer::Observer::residual)), which observer drives, which
//! is re-seeded, and the checks that end in an observer loss, each once a
//! millisecond in the drive's 1 kHz task (`Drive::tick`) on the estimates of one sample. (The
//! stall check is sensorless control's, `sensorless.rs`.)
//!
//! The rules, for any pair of observers:
//! - an observer is *healthy* after `lock_checks` checks in a row with the running mean of its
//!   residual (about 8 ms) below ¼, and lost after `failover_checks` in a row with it at or
//!   above ½ (hysteresis: noise around one threshold does not flip it; the mean: a residual
//!   that swings, as an observer whose model no longer fits it does, still counts). The
//!   levels are measured: locked, with 1 % current noise and 500 ns of uncompensated dead
//!   time, the mean stays below 0.2 (Sinano) to 0.4 (Ortega's test motor); a sliding observer
//!   losing lock on a load release reaches 5, a flux observer whose motor lost half its flux
//!   swings between 0.35 and 1;
//! - it is *usable* when healthy and its |ω̂| is at least its `min_speed_m` (the sliding
//!   observer is unobservable at zero speed);
//! - the primary drives when usable, else the usable monitor (failover), else nothing: after
//!   `loss_checks` without a usable observer, back to open loop at low speed or an observer
//!   loss above it; a sick monitor never trips a usable primary;
//! - a lost observer is re-seeded from the driving one once the driving one's speed is in its
//!   range, and again every `reseed_checks` while it does not lock;
//! - two usable observers that contradict each other (angle or speed beyond the limits) for
//!   `loss_checks` re-seed the one whose residual's mean is the larger from the other, which
//!   drives (not the driving one taken as right: [`contradiction`]); the third such
//!   contradiction within a run of agreement is an observer loss: the model no longer holds
//!   (e.g. the magnets' flux is gone) and neither can be told right.
//!
//! The health of an observer is judged as fault-detection practice does with residuals: a
//! signal that is near zero when the model fits the measurements, a threshold, and a
//! persistence count (Isermann, *Fault-Diagnosis Systems*, Springer 2006, ch. 10 and 14).

use super::io::Role;
use crate::math::wrap_pi;
use crate::observer::EDGE_OF_LOCK;
use crate::units::RPM_PER_RAD_S;
use core::hint::cold_path;

/// The weight of a check's residual in its running mean.
const MEAN_WEIGHT: f32 = 1.0 / 8.0;
/// A healthy observer whose mean residual stays at or above this is lost: half way to the
/// edge of lock ([`EDGE_OF_LOCK`], an observer's residual 1), before the estimate is wrong.
const LOST: f32 = 0.5 * EDGE_OF_LOCK;
/// An observer whose mean residual stays below this has locked: a quarter of the edge.
const LOCKED: f32 = 0.25 * EDGE_OF_LOCK;
/// Residuals are taken up to this (a NaN or infinite one counts as this).
const RESIDUAL_CAP: f32 = 100.0;

/// Supervision's thresholds, in the units and counts the checks use.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// Checks with the mean residual below ¼ (`LOCKED`) before an observer is healthy.
    pub(super) lock_checks: u32,
    /// Checks with the mean residual at or above ½ (`LOST`) before a healthy observer is lost.
    pub(super) failover_checks: u32,
    /// Checks between two seeds of an observer that does not lock.
    pub(super) reseed_checks: u32,
    /// Checks without a usable observer (or of contradiction) before acting.
    pub(super) loss_checks: u32,
    /// Largest tolerated angle disagreement of two usable observers [rad, electrical].
    pub(super) max_disagreement: f32,
    /// Largest tolerated speed disagreement of two usable observers \[rpm].
    pub(super) max_speed_disagreement_rpm: f32,
}

/// One observer's health, counted over the checks.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Lock {
    /// Healthy: locked on its own evidence.
    healthy: bool,
    /// Consecutive checks toward the other state (good ones while unhealthy, bad ones while
    /// healthy).
    count: u32,
    /// Checks since the last seed (saturating).
    since_seed: u32,
    /// Running mean of the residual.
    mean: f32,
}

impl Lock {
    /// Healthy from the start: an observer seeded at a known rotor state (the aligned rotor).
    pub(super) const SEEDED_AT_KNOWN_STATE: Self = Self {
        healthy: true,
        count: 0,
        since_seed: 0,
        mean: 0.0,
    };

    /// Seeded now from another estimate: unhealthy until it has shown lock.
    pub(super) fn seeded(&mut self) {
        *self = Self::default();
    }
}

/// What the health of both observers says, once per check.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Health {
    /// The primary's and the monitor's lock.
    pub(super) primary: Lock,
    /// See `primary`.
    pub(super) monitor: Lock,
    /// Which drives.
    pub(super) driving: Role,
    /// Consecutive checks without a usable observer.
    no_lock: u32,
    /// Consecutive checks of contradiction between two usable observers.
    contradict: u32,
    /// Contradictions resolved by a re-seed since the observers last agreed for long.
    strikes: u32,
    /// Consecutive checks of agreement (resets the strikes).
    agree: u32,
    /// At the last check, an observer was usable (it is `driving`).
    usable: bool,
    /// The residuals of the last check: the primary's, the monitor's.
    residuals: [f32; 2],
}

impl Health {
    /// Both observers seeded at a known rotor state (the aligned rotor): healthy, the primary
    /// driving.
    pub(super) const AT_KNOWN_STATE: Self = Self {
        primary: Lock::SEEDED_AT_KNOWN_STATE,
        monitor: Lock::SEEDED_AT_KNOWN_STATE,
        driving: Role::Primary,
        no_lock: 0,
        contradict: 0,
        strikes: 0,
        agree: 0,
        usable: true,
        residuals: [0.0; 2],
    };

    /// The residuals of the last check: the primary's, the monitor's.
    pub(super) fn residuals(&self) -> [f32; 2] {
        self.residuals
    }

    /// The driving observer's residual at the last check is below `LOST`, the level whose
    /// running mean loses an observer: its own residual, not only its mean, is within that
    /// (an observer seeded healthy at the aligned rotor is judged on its mean over about 8 ms).
    pub(super) fn driving_residual_below_lost(&self) -> bool {
        let r = match self.driving {
            Role::Primary => self.residuals[0],
            Role::Monitor => self.residuals[1],
        };
        r < LOST
    }

    /// At the last check, the driving observer was usable.
    pub(super) fn usable(&self) -> bool {
        self.usable
    }
}

/// Both observers' estimates of one check: the angles of one sample [rad, electrical], the
/// speeds now [rad/s, mechanical], the residuals, each observer's lowest usable speed
/// [rad/s, mechanical].
#[derive(Clone, Copy, Debug)]
pub(super) struct Views {
    pub(super) theta_primary: f32,
    pub(super) omega_primary: f32,
    pub(super) residual_primary: f32,
    pub(super) min_speed_primary: f32,
    pub(super) theta_monitor: f32,
    pub(super) omega_monitor: f32,
    pub(super) residual_monitor: f32,
    pub(super) min_speed_monitor: f32,
}

impl Views {
    /// |θ̂_primary − θ̂_monitor| wrapped to [0, π] [rad, electrical].
    pub(super) fn disagreement(&self) -> f32 {
        wrap_pi(self.theta_primary - self.theta_monitor).abs()
    }

    /// |ω̂_primary − ω̂_monitor| \[rpm].
    pub(super) fn speed_disagreement_rpm(&self) -> f32 {
        (self.omega_primary - self.omega_monitor).abs() * RPM_PER_RAD_S
    }

    /// The angle estimate of `role` [rad, electrical].
    pub(super) fn theta(&self, role: Role) -> f32 {
        match role {
            Role::Primary => self.theta_primary,
            Role::Monitor => self.theta_monitor,
        }
    }

    /// The speed estimate of `role` [rad/s, mechanical].
    pub(super) fn omega(&self, role: Role) -> f32 {
        match role {
            Role::Primary => self.omega_primary,
            Role::Monitor => self.omega_monitor,
        }
    }
}

/// What one health check decided.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Verdict {
    /// Carry on with `driving`.
    Drive,
    /// The driving observer changed (reason: failover, or the primary back).
    Switched,
    /// No usable observer for `loss_checks`.
    NoLock,
    /// Two usable observers contradicted each other three times: neither can be trusted.
    Contradiction,
}

/// Which observers to seed (from the driving one, as the health check asks).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(super) struct Seed {
    /// Seed the primary.
    pub(super) primary: bool,
    /// Seed the monitor.
    pub(super) monitor: bool,
}

impl Seed {
    /// Both.
    pub(super) const BOTH: Self = Self {
        primary: true,
        monitor: true,
    };
}

impl Settings {
    /// One observer's lock from this check's residual (module doc): its mean over the last
    /// few checks (`r̄ += (r − r̄)/8`, about 8 ms), lost at `LOST` or more for `failover_checks`
    /// checks in a row, locked below `LOCKED` for `lock_checks` in a row.
    #[inline(always)]
    fn judge(&self, lock: &mut Lock, residual: f32) {
        lock.since_seed = lock.since_seed.saturating_add(1);
        // A non-finite residual is no evidence of lock.
        let r = if residual < RESIDUAL_CAP {
            residual
        } else {
            RESIDUAL_CAP
        };
        lock.mean += (r - lock.mean) * MEAN_WEIGHT;
        let toward = if lock.healthy {
            lock.mean >= LOST
        } else {
            lock.mean < LOCKED
        };
        lock.count = consecutive(lock.count, toward);
        let needed = if lock.healthy {
            self.failover_checks
        } else {
            self.lock_checks
        };
        if lock.count >= needed {
            cold_path();
            lock.healthy = !lock.healthy;
            lock.count = 0;
        }
    }

    /// The health check: both observers judged, the driving one chosen, the seeds asked for
    /// (module doc). `h.driving` is the observer to drive after it.
    #[inline(always)]
    pub(super) fn check(&self, h: &mut Health, v: &Views) -> (Verdict, Seed) {
        h.residuals = [v.residual_primary, v.residual_monitor];
        self.judge(&mut h.primary, v.residual_primary);
        self.judge(&mut h.monitor, v.residual_monitor);
        let in_range = |omega: f32, min: f32| omega.abs() >= min;
        let p_usable = h.primary.healthy && in_range(v.omega_primary, v.min_speed_primary);
        let m_usable = h.monitor.healthy && in_range(v.omega_monitor, v.min_speed_monitor);
        let before = h.driving;
        h.driving = match (p_usable, m_usable) {
            (true, _) => Role::Primary,
            (false, true) => Role::Monitor,
            (false, false) => before,
        };
        let mut verdict = if h.driving == before {
            Verdict::Drive
        } else {
            Verdict::Switched
        };
        h.usable = p_usable || m_usable;
        h.no_lock = consecutive(h.no_lock, !h.usable);
        if h.no_lock >= self.loss_checks {
            cold_path();
            return (Verdict::NoLock, Seed::default());
        }
        // Seeds: the one not healthy, from the driving one, within its speed range.
        let omega = v.omega(h.driving);
        let wants = |lock: &Lock, min: f32| {
            !lock.healthy && in_range(omega, min) && lock.since_seed >= self.reseed_checks
        };
        let mut seed = Seed {
            primary: h.driving == Role::Monitor && wants(&h.primary, v.min_speed_primary),
            monitor: h.driving == Role::Primary && wants(&h.monitor, v.min_speed_monitor),
        };
        // Two usable observers must agree.
        let contradict = p_usable
            && m_usable
            && (v.disagreement() > self.max_disagreement
                || v.speed_disagreement_rpm() > self.max_speed_disagreement_rpm);
        h.contradict = consecutive(h.contradict, contradict);
        h.agree = consecutive(h.agree, p_usable && m_usable && !contradict);
        if h.agree >= 10 * self.loss_checks {
            h.strikes = 0;
        }
        if h.contradict >= self.loss_checks {
            verdict = contradiction(h, &mut seed, before);
        }
        if seed.primary {
            cold_path();
            h.primary.seeded();
        }
        if seed.monitor {
            cold_path();
            h.monitor.seeded();
        }
        (verdict, seed)
    }
}

/// Two usable observers contradicted each other for `loss_checks`: a strike (the third within a
/// run of agreement is [`Verdict::Contradiction`]), and the one whose residual's mean is the
/// larger (its model fits its measurements less) re-seeded from the other, which drives:
/// residual-based isolation (Isermann 2006, ch. 14), not the driving one taken as right. On
/// the simulated board the sliding primary of a high-resistance gimbal (`gimbal-high-r`), caught
/// in a swing the alignment gave it, drifted 60° off while its mean residual rose to 0.5 and
/// the flux monitor's stayed at 0.03 and tracked the rotor: re-seeding the monitor from the
/// primary lost the rotor (`tests/identify.rs`' start-stop-reverse). `before`: the driving
/// observer before this check; returns the check's verdict. Out of line: rare, kept off the
/// 1 kHz task's path.
#[inline(never)]
fn contradiction(h: &mut Health, seed: &mut Seed, before: Role) -> Verdict {
    cold_path();
    h.contradict = 0;
    h.strikes += 1;
    if h.primary.mean > h.monitor.mean {
        h.driving = Role::Monitor;
        seed.primary = true;
    } else {
        h.driving = Role::Primary;
        seed.monitor = true;
    }
    if h.strikes >= 3 {
        Verdict::Contradiction
    } else if h.driving == before {
        Verdict::Drive
    } else {
        Verdict::Switched
    }
}

/// A count of consecutive checks in which a condition held: one more if it holds, else 0.
#[inline(always)]
pub(super) fn consecutive(count: u32, holds: bool) -> u32 {
    if holds {
        count.saturating_add(1)
    } else {
        0
    }
}
