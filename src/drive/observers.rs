//! The drive's two observers as the modes see them: both states, the angles of one sample and
//! their health; the driving observer's estimate ([`Drive::driving`]), the health check
//! (`supervision.rs`) with the seeds it asks for, and the seeds of a mode change.

use super::io::{Reason, Role};
use super::mode::Driving;
use super::supervision::{Health, Seed, Verdict, Views};
use super::{adaptation, Drive};
use crate::frames::{AlphaBeta, SinCos};
use crate::math::atan2;
use crate::observer::{Observer, Rotor};
use core::hint::cold_path;

/// Both observers' states, the angles of one sample and their health (which drives).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct ObserverStates<PS, MS> {
    pub(super) primary: PS,
    pub(super) monitor: MS,
    /// The angles the last [`Drive::tick`] read out.
    pub(super) sample: AngleSample,
    /// Each observer's lock, which drives.
    pub(super) health: Health,
    /// The adapted motor model the observers take their inputs through (`adaptation.rs`);
    /// kept from one run to the next.
    pub(super) model: adaptation::Model,
}

/// The angles the 1 kHz comparisons take, all of one sample (the last tick's
/// step's) [rad, electrical].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct AngleSample {
    pub(super) theta_primary: f32,
    pub(super) theta_monitor: f32,
}

impl<P: Observer, M: Observer> Drive<P, M> {
    /// The observers' estimates: the angles of the last tick's sample, the
    /// speeds and residuals now, their speed ranges.
    #[inline(always)]
    pub(super) fn views(&self, obs: &ObserverStates<P::State, M::State>) -> Views {
        Views {
            theta_primary: obs.sample.theta_primary,
            omega_primary: self.primary.omega_m(&obs.primary),
            residual_primary: self.primary.residual(&obs.primary),
            min_speed_primary: self.primary.min_speed_m(),
            theta_monitor: obs.sample.theta_monitor,
            omega_monitor: self.monitor.omega_m(&obs.monitor),
            residual_monitor: self.monitor.residual(&obs.monitor),
            min_speed_monitor: self.monitor.min_speed_m(),
        }
    }

    /// The driving observer's frame now, its output frame turned by `lead`, its speed
    /// [rad/s, mechanical] and its load-torque estimate \[N·m], if it has one.
    #[inline(always)]
    pub(super) fn driving(
        &self,
        obs: &ObserverStates<P::State, M::State>,
        lead: SinCos,
    ) -> (SinCos, SinCos, f32, Option<f32>) {
        let (frame, frame_out, omega_m, load) = match obs.health.driving {
            Role::Primary => estimate(&self.primary, &obs.primary, lead),
            Role::Monitor => estimate(&self.monitor, &obs.monitor, lead),
        };
        let load_nm = load.map(|t| obs.model.torque_from_observer(t));
        (frame, frame_out, omega_m, load_nm)
    }

    /// The driving observer's frame now, its speed [rad/s, mechanical] and its load-torque
    /// estimate \[N·m] if it has one: [`Drive::driving`] for the 1 kHz task (inlined there:
    /// one call, after the health check) and the mode changes.
    #[inline(always)]
    pub(super) fn driving_now(&self, obs: &ObserverStates<P::State, M::State>) -> Driving {
        let (frame, _, omega_m, load_nm) = self.driving(obs, SinCos::ZERO);
        Driving {
            frame,
            omega_m,
            load_nm,
        }
    }

    /// The health check of [`Drive::tick`] (`supervision.rs`) and the seeds it asks
    /// for: a seeded observer starts at the driving one's angle now, speed and load (its
    /// own estimate, else `load_nm` \[N·m], the torque the controller makes). Returns the
    /// verdict and, when the driving observer changed, why.
    // Inlined: one call, the 1 kHz task's, for every mode that has the check (out of line,
    // the call's saving and restoring of registers weighed on the task's budget).
    #[inline(always)]
    pub(super) fn supervise(
        &self,
        obs: &mut ObserverStates<P::State, M::State>,
        i_ab: AlphaBeta,
        load_nm: f32,
    ) -> (Verdict, Option<Reason>) {
        let views = self.views(obs);
        let (verdict, seed) = self.supervision.check(&mut obs.health, &views);
        if seed != Seed::default() {
            self.seed_from_driving(obs, seed, i_ab, load_nm);
        }
        let reason = match (verdict, obs.health.driving) {
            (Verdict::Switched, Role::Monitor) => Some(Reason::Failover),
            (Verdict::Switched, Role::Primary) => Some(Reason::PrimaryDrives),
            _ => None,
        };
        (verdict, reason)
    }

    /// Seeds the observers `seed` names from the driving one (see [`Drive::supervise`]).
    // Out of line, like the mode changes: rare, kept off the every-step path.
    #[inline(never)]
    fn seed_from_driving(
        &self,
        obs: &mut ObserverStates<P::State, M::State>,
        seed: Seed,
        i_ab: AlphaBeta,
        load_nm: f32,
    ) {
        cold_path();
        let d = self.driving_now(obs);
        let rotor = Rotor {
            theta_e: atan2(d.frame.sin, d.frame.cos),
            omega_m: d.omega_m,
            load_nm: d.load_nm.unwrap_or(load_nm),
        };
        self.seed_observers(obs, seed, i_ab, rotor);
    }

    /// A flying start's seed (`catch.rs`): both observers at the back-EMF's `rotor`, `i_ab`
    /// the currents now \[A], both to lock on their own evidence.
    // Out of line, like the other mode changes: once per start.
    #[inline(never)]
    pub(super) fn seed_caught(
        &self,
        obs: &mut ObserverStates<P::State, M::State>,
        i_ab: AlphaBeta,
        rotor: Rotor,
    ) {
        self.seed_observers(obs, Seed::BOTH, i_ab, rotor);
        obs.health.primary.seeded();
        obs.health.monitor.seeded();
    }

    /// Restarts the observers `seed` names at the rotor state `rotor`, `i_ab` the currents
    /// now \[A] (both taken through the adapted model).
    // Out of line, like the other mode changes: rare, kept off the every-step path.
    #[inline(never)]
    pub(super) fn seed_observers(
        &self,
        obs: &mut ObserverStates<P::State, M::State>,
        seed: Seed,
        i_ab: AlphaBeta,
        rotor: Rotor,
    ) {
        let (i_ab, _) = obs.model.observer_input(i_ab, AlphaBeta::default());
        let rotor = Rotor {
            load_nm: obs.model.torque_to_observer(rotor.load_nm),
            ..rotor
        };
        if seed.primary {
            self.primary.seed(&mut obs.primary, i_ab, rotor);
        }
        if seed.monitor {
            self.monitor.seed(&mut obs.monitor, i_ab, rotor);
        }
    }
}

/// `o`'s frame now, its output frame turned by `lead`, its speed [rad/s, mechanical] and its
/// load-torque estimate \[N·m], if it has one.
#[inline(always)]
fn estimate<O: Observer>(o: &O, st: &O::State, lead: SinCos) -> (SinCos, SinCos, f32, Option<f32>) {
    let frame = o.sin_cos(st);
    (
        frame,
        o.sin_cos_output(st, frame, lead),
        o.omega_m(st),
        o.load_nm(st),
    )
}
