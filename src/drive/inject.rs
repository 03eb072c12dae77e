//! The start from standstill through high-frequency injection on a salient motor (feature
//! `injection`, [`crate::injection`] for the method and its literature): instead of the
//! alignment and the open loop, the rotor found at rest is tracked by the injection, its
//! magnet's polarity tested, and then driven in closed loop on the injection's angle and
//! speed from zero speed: the speed loop (the FOC's PI, the MTPA's currents) toward a
//! commanded speed, or at a zero command the position hold (below), either up to the current
//! limit; above the hand-over speed (the open loop's,
//! [`StartConfig::handover_rpm`](super::StartConfig::handover_rpm)) for
//! [`HANDOVER_CHECKS`] checks the observers are seeded at the injection's rotor state and
//! sensorless control takes over (`Reason::HandOver`).
//!
//! A zero command at zero speed holds the rotor where it is (torque at standstill is what the
//! injection is for): the torque current is a PD on the rotor's travel since the hold began
//! and on its speed, with the load fed forward, all from the injection's motion observer
//! (`crate::injection`, switched on while the hold runs: the commanded torque fed forward,
//! the load's deceleration `â` estimated; Lorenz & Van Patten 1991's observer-based motion
//! control):
//! ```text
//! i_τ = (J/K_t) (â_m − ω_c² θ_m − 2ω_c ω̂_m)
//! ```
//! the travel `θ_m` and the speed `ω̂_m` mechanical, the speed and `â` averaged over the
//! millisecond's steps (not the last step's: the task samples once for many steps), `â`
//! low-passed at `ω_c`. A load ramping at `ρ` N·m/s is met by `â`, which lags it by about
//! `3/ω_o` and its low-pass `1/ω_c` more; the PD's double pole at `−ω_c` takes the rest: the
//! rotor moves by about `ρ/J · (3/ω_o + 1/ω_c)/ω_c²` while the load ramps (and the task's
//! averaging and ramp add about a millisecond's lag) and comes back once it is constant.
//! `ω_c = min(ω_o/2, 2π · 1 kHz/35)` ([`HOLD_BANDWIDTH_PER_OBSERVER`],
//! [`HOLD_TICK_DIVIDER`]): below the observer, and with the task's millisecond 10° of phase
//! at `ω_c`. The torque current asked for is ramped to over the millisecond's steps: a step
//! in the fundamental current enters the injection's second difference as an angle error
//! (with steps, the loop oscillated at `ω_c` on the AMK); a steady ramp drops out of it.
//! (Before: a position loop as the reference of the FOC's 20 Hz speed PI, the P–PI cascade
//! at `K_θ = 0.1 ω_s`, had moved the AMK's rotor by 131° mechanical when a rated load ramped
//! in 0.3 s reached it; now 4°, `host-sim/tests/injection.rs`.) The drive stops with the enable.
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

/// The position hold's bandwidth `ω_c` per the injection observer's pole `ω_o` (module doc).
pub const HOLD_BANDWIDTH_PER_OBSERVER: f32 = 0.5;

/// The position hold's bandwidth is at most the task's rate over this (in rad/s:
/// `2π · 1 kHz/35`, 180 rad/s): the task's millisecond is then 10° of phase at `ω_c`.
pub const HOLD_TICK_DIVIDER: f32 = 35.0;

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
    /// The position hold (module doc).
    pub(super) hold: HoldSettings,
    /// Steps per millisecond and its inverse.
    pub(super) steps_per_tick: u32,
    pub(super) inv_steps: f32,
}

/// The position hold's settings: a PD on the injection's estimates of the rotor's travel and
/// speed with its load estimate fed forward (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct HoldSettings {
    /// `J/(N K_t)` \[A per rad/s², electrical]: the torque current of an acceleration.
    pub(super) amps_per_accel_e: f32,
    /// Its inverse `N K_t/J` \[rad/s², electrical, per A]: the acceleration of a torque
    /// current (a multiplication where the step and the tick would divide).
    pub(super) accel_per_amp_e: f32,
    /// The PD's gains `ω_c²` \[1/s²] and `2ω_c` \[1/s].
    pub(super) kp: f32,
    pub(super) kd: f32,
    /// The current limit \[A].
    pub(super) i_max_a: f32,
    /// The load estimate's low-pass gain per millisecond.
    pub(super) load_gain: f32,
}

/// The position hold's state: the rotor's travel since the hold began as the injection
/// measures it \[rad, electrical] and the angle it was last taken from.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Hold {
    travel_e: f32,
    last_e: f32,
    /// The load's deceleration low-passed \[rad/s², electrical].
    accel_load_e: f32,
}

impl HoldSettings {
    /// From the motor, the injection's observer pole `ω_o` \[rad/s] and the current limit.
    pub(super) fn new(m: &crate::motor::MotorParams, omega_o: f32, i_max_a: f32) -> Self {
        let t = 1.0 / crate::schedule::TICK_HZ;
        let w_c = crate::math::min(
            HOLD_BANDWIDTH_PER_OBSERVER * omega_o,
            core::f32::consts::TAU * crate::schedule::TICK_HZ / HOLD_TICK_DIVIDER,
        );
        // `N K_t`: the electrical acceleration per ampere times `J`.
        let n_kt = m.n() * m.torque_constant();
        Self {
            amps_per_accel_e: m.j_kgm2 / n_kt,
            accel_per_amp_e: n_kt / m.j_kgm2,
            kp: w_c * w_c,
            kd: 2.0 * w_c,
            i_max_a,
            load_gain: 1.0 - libm::expf(-w_c * t),
        }
    }

    /// One millisecond of the hold: the torque current \[A] from the injection's state.
    fn update(&self, h: &mut Hold, theta_e: f32, omega_e: f32, accel_load_e: f32) -> f32 {
        h.travel_e += wrap_pi(theta_e - h.last_e);
        h.last_e = theta_e;
        h.accel_load_e += self.load_gain * (accel_load_e - h.accel_load_e);
        let accel_e = h.accel_load_e - self.kp * h.travel_e - self.kd * omega_e;
        clamp(accel_e * self.amps_per_accel_e, -self.i_max_a, self.i_max_a)
    }
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
    /// The current reference the millisecond ramps to \[A].
    i_target: Dq,
    /// Checks above the hand-over speed.
    above: u32,
    /// The position hold; `None` while a speed is asked for.
    hold: Option<Hold>,
    /// The torque current asked for last \[A].
    i_tau: f32,
    /// The torque current of this step's reference and its change per step \[A]: the
    /// injection's observer's input, as the acceleration `N K_t i_τ/J` it makes.
    i_tau_now: f32,
    i_tau_slope: f32,
    /// The current reference applied this step, its change per step and the steps it still
    /// changes for \[A].
    i_now: Dq,
    i_slope: Dq,
    ramp_steps: u32,
    /// Sums over the millisecond's steps of ω̂_e and â_e, and their count.
    sum_omega_e: f32,
    sum_accel_e: f32,
    sum_n: f32,
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
        // The acceleration the last step's current asked for (MTPA's currents make `K_t i_τ`).
        let accel_e = s.i_tau_now * self.hold.accel_per_amp_e;
        let t = self.injection.step(&mut s.inj, i_ab, accel_e);
        s.sum_omega_e += s.inj.omega_e;
        s.sum_accel_e += s.inj.accel_load_e;
        s.sum_n += 1.0;
        // The current reference: the bias of the lock and the polarity test, else the
        // tick's, ramped to over the millisecond's steps (a step in the fundamental current
        // would enter the injection's second difference as an angle error; a steady ramp
        // drops out of it).
        let i_ref = match self.injection.bias(&s.inj) {
            Some(b) => Dq::new(b, 0.0),
            None => {
                if s.ramp_steps > 0 {
                    s.ramp_steps -= 1;
                    s.i_now = Dq::new(s.i_now.d + s.i_slope.d, s.i_now.q + s.i_slope.q);
                    s.i_tau_now += s.i_tau_slope;
                }
                s.i_now
            }
        };
        let omega_m = s.inj.omega_e * self.inv_n;
        // The current loop within what the injection leaves of the inverter's voltage (a
        // quarter of it at least: on a bus sagged far below what the share was sized on, the
        // sum is then SVPWM's to cut), its vector cut along itself (below the hand-over speed
        // the d axis needs no first claim).
        let v_inverter = foc.v_max(v_bus);
        let v_max = crate::math::max(v_inverter - self.injection.v_h(), 0.25 * v_inverter);
        let out = foc
            .current_loop()
            .update_cut_along(current, t.i_dq, i_ref, s.inj.omega_e, v_max);
        Request {
            frame: t.frame,
            frame_out: foc.output_angle(t.frame, omega_m),
            omega_m,
            reference: Reference::Voltage(Dq::new(out.v_dq.d + t.v_d, out.v_dq.q)),
        }
    }

    /// The 1 kHz work once the polarity is known: the speed loop on the injection's speed, or
    /// at a zero command the position hold; the hand-over above the hand-over speed. Returns
    /// the hand-over's entry (the observers to be seeded at the injection's rotor state
    /// first).
    // Out of line: the start's, not the running drive's.
    #[inline(never)]
    pub(super) fn tick(
        &self,
        s: &mut Inject,
        foc: &Foc,
        mtpa: Option<&Mtpa>,
        cmd_rpm: f32,
    ) -> Next {
        // The millisecond's mean speed and load (module doc).
        let (omega_e, accel_load_e) = if s.sum_n > 0.0 {
            (s.sum_omega_e / s.sum_n, s.sum_accel_e / s.sum_n)
        } else {
            (s.inj.omega_e, s.inj.accel_load_e)
        };
        (s.sum_omega_e, s.sum_accel_e, s.sum_n) = (0.0, 0.0, 0.0);
        if s.inj.phase() != Phase::Track {
            return Next::Stay;
        }
        s.omega_m += self.speed_gain * (omega_e * self.inv_n - s.omega_m);
        let target = self.ramp.command(cmd_rpm);
        s.speed_ref_rpm = self.ramp.slew(s.speed_ref_rpm, target);
        // The position hold (module doc): at a zero command once the reference is there.
        let theta_e = s.inj.theta_e;
        let reference = s.speed_ref_rpm * RAD_S_PER_RPM;
        let holding = target == 0.0 && s.speed_ref_rpm == 0.0;
        s.inj.motion_model = holding;
        let i_tau = if holding {
            let (hold, accel_load_e) = match &mut s.hold {
                Some(hold) => (hold, accel_load_e),
                None => {
                    // Bumpless: at a steady speed the load's deceleration is what the torque
                    // held asks for (the PLL before the hold estimated none).
                    let seeded = s.i_tau * self.hold.accel_per_amp_e;
                    s.inj.accel_load_e = seeded;
                    let hold = s.hold.insert(Hold {
                        travel_e: 0.0,
                        last_e: theta_e,
                        accel_load_e: seeded,
                    });
                    (hold, seeded)
                }
            };
            self.hold.update(hold, theta_e, omega_e, accel_load_e)
        } else {
            if s.hold.take().is_some() {
                // Bumpless: the speed loop's integrator takes the current the hold held.
                s.speed_pi.integral = s.i_tau;
            }
            foc.speed_step(&mut s.speed_pi, (reference, s.omega_m), 0.0, None)
        };
        s.i_tau = i_tau;
        s.i_target = match mtpa {
            Some(m) => m.split(i_tau, s.i_target.d, 0.0),
            None => Dq::new(0.0, i_tau),
        };
        s.i_slope = Dq::new(
            (s.i_target.d - s.i_now.d) * self.inv_steps,
            (s.i_target.q - s.i_now.q) * self.inv_steps,
        );
        s.i_tau_slope = (i_tau - s.i_tau_now) * self.inv_steps;
        s.ramp_steps = self.steps_per_tick;
        let fast = libm::fabsf(s.omega_m * RPM_PER_RAD_S) >= self.handover_rpm
            && libm::fabsf(s.speed_ref_rpm) >= self.handover_rpm;
        s.above = if fast { s.above.saturating_add(1) } else { 0 };
        if s.above >= HANDOVER_CHECKS {
            let entry = Entry {
                omega_m: s.omega_m,
                i_dq: s.i_target,
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
