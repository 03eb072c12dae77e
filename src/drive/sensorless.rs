//! Sensorless control: FOC on the driving observer's angle and speed (the primary, or the
//! monitor while the primary is not healthy) every step; at 1 kHz ([`Drive::tick`]) the speed
//! loop with its load-torque estimate fed forward (Horng & Chin Fig 4), the health check of
//! both observers (`supervision.rs`), the stall check, the stop at zero, and the hand-back to
//! open loop where no observer is healthy at low speed.

use super::applied::Applied;
use super::mode::{Driving, Entry, Next};
use super::ramp::Ramp;
use super::regen;
use super::speed_gain;
use super::supervision::{consecutive, Verdict};
use super::{Fault, Reason};
use crate::foc::{Foc, Reference, Request};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::load_observer::{LoadObserver, LoadObserverState};
use crate::math::{clamp, max, min, sqrt_or_zero};
use crate::mtpa::Mtpa;
use crate::pi::{Held, PiState};
use crate::units::{RAD_S_PER_RPM, RPM_PER_RAD_S};
use core::hint::cold_path;

/// The driving observer's residual (1: the edge of lock, `observer::EDGE_OF_LOCK`) above
/// which a reversal inside the hand-over band hands the rotor to the open loop: half-way.
const THROUGH_ZERO_RESIDUAL: f32 = 0.5;

/// An over-speed is not counted as lost while the speed has fallen this share below its peak
/// above the bound: the drive is bringing it back (five times the flux observer's speed noise
/// at the test motor's 2,500 rpm bound with the board's 1 % current noise, ±40 rpm).
pub(super) const RECOVERING: f32 = 0.05;

/// Sensorless control's coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// The command's limit and the speed reference's slew.
    pub(super) ramp: Ramp,
    /// The speed loop's load-torque observer, for a driving observer without one.
    pub(super) load_observer: LoadObserver,
    /// Field weakening.
    pub(super) field_weakening: FieldWeakening,
    /// Maximum torque per ampere of a motor with `L_q > L_d` (`crate::mtpa`; `None`: not
    /// salient, or inversely, and the d current is the field weakening's alone).
    pub(super) mtpa: Option<Mtpa>,
    /// The braking side's limit of the speed loop's output (a torque current, `crate::mtpa`)
    /// \[A]: the current limit `i_max`, on a salient motor the MTPA's torque current there
    /// (so that the limit a speed estimate's sign picks does not change with its noise on a
    /// rotor at rest).
    pub(super) braking_max_a: f32,
    /// The hand-over's d current decays by this factor per millisecond (under a command below
    /// the hand-over speed, `through_zero_rpm`, down to `low_speed_d_a`).
    pub(super) handover_decay: f32,
    /// The d current held under a command below the hand-over speed (see [`Settings::enter`])
    /// \[A]: twice the dead-time compensation's band (`PowerStageConfig::dead_time_band_a`), as
    /// the catch holds (`catch_zero::Settings::i_hold_a`), so that every phase current but
    /// near its zero crossings has a sign the compensation knows.
    pub(super) low_speed_d_a: f32,
    /// Below this |reference| \[rpm], and above the hand-over speed, the d current is held at
    /// `low_speed_d_a` while the q current the speed loop last asked for is smaller: the
    /// speed where the inverter's dead-time voltage is a twentieth of the back-EMF (see
    /// [`Settings::enter`]).
    pub(super) dead_time_rpm: f32,
    /// The same under a zero command (a stop): where it is a tenth
    /// ([`DriveConfig::low_speed_hold_stopping_rpm`](super::DriveConfig::low_speed_hold_stopping_rpm)).
    pub(super) dead_time_stop_rpm: f32,
    /// Without a usable observer, below this |speed| and |reference| open loop takes over
    /// again \[rpm].
    pub(super) handback_rpm: f32,
    /// A nonzero |command| below this is carried by the I/f, supervised, once |reference| and
    /// |speed| are below it too \[rpm] (`DriveConfig::if_held_below_rpm`, `open_loop.rs`).
    pub(super) held_below_rpm: f32,
    /// On the way through zero speed, below this |speed| and |reference| open loop takes
    /// over \[rpm]: the hand-over speed, where the observers were trusted to take over at the
    /// start (the hand-back speed is where they are already failing).
    pub(super) through_zero_rpm: f32,
    /// With a zero command, stopped below this estimated |speed| \[rpm].
    pub(super) stop_rpm: f32,
    /// The driving observer's |speed| above this many rpm per volt of the filtered measured
    /// bus is an over-speed: `m/(√3 N (ψ_f − L i_max))` in rpm, the speed whose back-EMF the
    /// field weakening no longer holds within its voltage target (`m` = 0.95 of the bus's
    /// phase voltage) even with the whole current limit on the d axis: the drive no longer
    /// controls the current, and the rotor is beyond the speed whose line-to-line back-EMF
    /// reaches the bus (above it the diodes conduct with the PWM off and brake the rotor into
    /// the bus, uncontrolled; a bus raised by regeneration raises the bound with it).
    /// `ψ_f − L i_max` is floored at `ψ_f/2`: a motor whose field weakening would reach
    /// further is bounded at twice its bus-limited speed (0.95 of it). Sinano: 2,023 rpm at
    /// its 48 V; Ortega's test motor: 2,562 rpm at 200 V (its current trips `overcurrent`
    /// about 2,900 rpm, beyond its field weakening) ...
    pub(super) overspeed_rpm_per_v: f32,
    /// The bus's low-pass filter for the over-speed bound: its gain per millisecond (1 ms over
    /// its time constant, `BUS_FILTER_S`), so the PWM's and the sampling's noise do not move
    /// the bound.
    pub(super) bus_filter: f32,
    /// ... for this many checks in a row (the supervision's loss time, `loss_time_s`, 20 ms
    /// by default, the time the drive gives any transient before it faults), unless the
    /// drive is winning: the speed fallen more than [`RECOVERING`] below its peak since it
    /// passed the bound. An overhauling load reversed at rated speed on the Sinano motor
    /// (`overhaul-hold`: ±0.8 of rated torque, 165 rpm per ms on its small rotor) takes the
    /// rotor to 1,730 rpm (1,770 with the sliding primary), above the bound at its 48 V (1,142 rpm) for 20 ms, while the
    /// speed loop brings it back; a load beyond the current limit raises the speed to the
    /// end.
    pub(super) overspeed_checks: u32,
    /// The stall check.
    pub(super) stall: Stall,
    /// The regeneration's limit from the bus (`regen.rs`).
    pub(super) regen: regen::Settings,
    /// The speed loop's gain checks (`speed_gain.rs`).
    pub(super) speed_gain: speed_gain::Settings,
}

/// Sensorless stall: the driving observer's speed below half the slewed reference (or turning
/// the wrong way) for `checks` in a row with the speed loop's command at its limit, and not
/// gaining `gain_rpm` toward the reference over them: a rotor taken over turning against the
/// command (`Reason::AgainstCommand`) is braked at the limit for longer than that, but it
/// gains; a blocked one does not. (A rotor blocked before it turned never leaves the open
/// loop: it is not seen following the ramp.)
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Stall {
    /// Checks of collapsed speed at the current limit before a stall.
    pub(super) checks: u32,
    /// |torque current command| (the speed loop's output, `crate::mtpa`; the i_q command of
    /// a non-salient motor) at or above this is the speed loop at its limit \[A].
    pub(super) i_limit_a: f32,
    /// The speed a rotor that has not stalled gains toward the reference over `checks`
    /// \[rpm]: the hand-back speed.
    pub(super) gain_rpm: f32,
}

/// The stall check's state: consecutive checks of collapsed speed, and the speed along the
/// reference at the first of them \[rpm].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct StallCount {
    count: u32,
    along_from_rpm: f32,
}

impl Stall {
    /// One check: the speed `omega_m` [rad/s] of the driving observer, the slewed reference
    /// `speed_ref_rpm`, the speed loop's command `i_q_ref_a` (its torque current); true once
    /// stalled.
    #[inline(always)]
    pub(super) fn stalled(
        &self,
        c: &mut StallCount,
        omega_m: f32,
        speed_ref_rpm: f32,
        i_q_ref_a: f32,
    ) -> bool {
        let speed = omega_m * RPM_PER_RAD_S;
        let along = if speed_ref_rpm < 0.0 { -speed } else { speed };
        let at_limit = i_q_ref_a.abs() >= self.i_limit_a;
        c.count = consecutive(c.count, along < 0.5 * speed_ref_rpm.abs() && at_limit);
        if c.count == 1 {
            c.along_from_rpm = along;
        }
        if c.count < self.checks {
            return false;
        }
        if along - c.along_from_rpm >= self.gain_rpm {
            // Gaining on the reference: not stalled; judged again from here.
            c.count = 0;
            return false;
        }
        true
    }
}

/// Field weakening by voltage feedback (Kim & Sul, "Speed control of interior permanent
/// magnet synchronous motor drives in the flux weakening region", IEEE Trans. Ind. Appl.
/// 33(1), 1997): at 1 kHz a negative `i_d` grows while the voltage the current loop applies is
/// beyond `margin` of its limit and shrinks back to 0 below it, within the current limit
/// (`i_q` is held to `√(i_max² − i_d²)`). Above the speed where the back-EMF and `R i` use the
/// bus, `−ω_e L i_d` takes back voltage from the q axis: the rated point holds on a bus that
/// cannot carry it with `i_d = 0` (a bus 15 % low, the Sinano motor at rated speed under a
/// part load).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct FieldWeakening {
    /// Fraction of the current loop's voltage limit the loop holds the voltage at.
    pub(super) margin: f32,
    /// `i_d` step per volt of excess per millisecond \[A/V]: `0.2/(ω_e L)` at rated speed, a
    /// fifth of the way to the voltage target each millisecond there.
    pub(super) gain_a_per_v: f32,
    /// The speed loop's current limit `i_max` \[A]: `|i_d|` up to it, `|i| ≤ i_max`.
    pub(super) i_max_a: f32,
    /// The field weakening's minimum-voltage end and the torque's ceiling, on a non-salient
    /// motor (on a salient one, `Settings::mtpa`, the MTPA's d current comes first, and its
    /// end is left at `−i_max`).
    pub(super) end: VoltageEnd,
}

impl FieldWeakening {
    /// The new `i_d` \[A] from `i_d` \[A], the voltage `v_ab` applied \[V] and the current loop's
    /// limit `v_max` \[V]: the excess over `margin·v_max`, linearised from the squares,
    /// `(|v|² − (m v_max)²)/(2 m v_max)`; and that excess \[V].
    #[inline(always)]
    fn i_d(&self, i_d: f32, v_ab: AlphaBeta, v_max: f32) -> (f32, f32) {
        let target = self.margin * v_max;
        let v2 = v_ab.alpha * v_ab.alpha + v_ab.beta * v_ab.beta;
        let excess_v = (v2 - target * target) / (2.0 * target);
        let i_d = i_d - self.gain_a_per_v * excess_v;
        // Within [−i_max, 0]; a bus at zero (the division's NaN, which fails `< 0`) ends the
        // field weakening. (One compare for the upper bound and the NaN.)
        if i_d < 0.0 {
            (max(i_d, -self.i_max_a), excess_v)
        } else {
            (0.0, excess_v)
        }
    }
}

/// The field weakening's end where it is inside the current limit, and the torque's ceiling
/// from the voltage there (a non-salient motor).
///
/// The end is the minimum-voltage d current: from the steady-state stator voltage (Ortega
/// et al. eq (3), Horng & Chin eqs (16)-(17) in the rotor frame), `v_d = R i_d − ω_e L i_q`,
/// `v_q = R i_q + ω_e (ψ_f + L i_d)`, `∂|v|²/∂i_d = 0` at
/// `i_d* = −ω_e² L ψ_f/(R² + ω_e² L²) = −(ψ_f/L) ω_m²/((R/(N L))² + ω_m²)`, whatever `i_q`
/// (the vertex the derating's envelope already takes, `derating.rs`). Beyond it a more
/// negative d current needs more voltage, not less. The field weakening of the voltage-limit
/// circle (Morimoto, Takeda, Hirasa, Taniguchi, "Expansion of operating limits for permanent
/// magnet motor by current vector control considering inverter capacity", IEEE Trans. Ind.
/// Appl. 26(5), 1990) neglects `R`, where `i_d* = −ψ_f/L`, beyond the current limit of most
/// motors; where `R` is not small against `ω_e L` (a winding of few turns on a low bus: the
/// Nanotec DF45 at 2,400 rpm, `ω_e L = 0.4 Ω` against `R = 0.6 Ω`, `i_d* = −5.8 A` of its
/// 13.6 A limit) the loop, which sees only the voltage above its target, ran past `i_d*` on
/// to the current limit, the q current lost its voltage and the rotor under rated load
/// collapsed every 40 ms (`sup-start-brake-100`: 2,650 to 600 rpm in 2 ms).
///
/// At that end the voltage above the target is the torque's: the q current is what is left
/// to take it off, as the current limit does where the d current reaches `−i_max`
/// (`√(i_max² − i_d²)`). The ceiling falls while the voltage is above the target there and
/// rises back to `i_max` while it is below; the speed loop's motoring command stays under it.
/// The drive then holds the load at the speed of the derating's envelope (the same voltage
/// target and `i_d*`), not at the current loop's saturation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct VoltageEnd {
    /// `ψ_f/L` \[A].
    pub(super) psi_per_l_a: f32,
    /// `(R/(N L))²` \[rad²/s²]: the square of the mechanical speed where `ω_e L = R`.
    pub(super) corner_rad2_s2: f32,
}

impl VoltageEnd {
    /// Holds `s.i_d_fw` at or above the end at `omega_m` \[rad/s] (within `−i_max` of `fw`)
    /// and moves the ceiling `s.i_q_v` by the voltage's excess `excess_v` \[V], at the d
    /// current's gain (`FieldWeakening::gain_a_per_v`, `0.2/(ω_e L)` at rated speed: with
    /// `|∂|v|/∂i_q| ≤ |R + j ω_e L|`, at most `0.2 |R + j ω_e L|/(ω_e L)` of the way each
    /// millisecond, 0.27 on the DF45). Run only while the field weakening acts or the ceiling
    /// is below `i_max`.
    // Out of line: the running drive's tick below the voltage target pays two compares.
    #[inline(never)]
    fn apply(&self, s: &mut Sensorless, excess_v: f32, omega_m: f32, fw: &FieldWeakening) {
        let i_max_a = fw.i_max_a;
        let w2 = omega_m * omega_m;
        let end = max(
            -self.psi_per_l_a * w2 / (self.corner_rad2_s2 + w2),
            -i_max_a,
        );
        let at_end = s.i_d_fw <= end;
        s.i_d_fw = max(s.i_d_fw, end);
        // (False for a NaN excess, as for the d current's.)
        if at_end || excess_v < 0.0 {
            s.i_q_v = clamp(s.i_q_v - fw.gain_a_per_v * excess_v, 0.0, i_max_a);
        }
    }
}

/// Braking before field weakening: a braking command `s.i_q_ref` beyond what the field
/// weakening's d current leaves of the current limit `i_max_a` \[A] keeps it, and the d
/// current (the field weakening's, and with it the hand-over's) is cut to what the braking
/// leaves, `|i_d| ≤ √(i_max² − i_q²)`: `|i| ≤ i_max` still, and the field weakening's
/// integrator starts again from there (no wind-up).
///
/// Why braking may take the current first (while motoring gets only what the field weakening
/// leaves, Kim & Sul 1997): the stator voltage, Horng & Chin eqs (16)-(17) / Ortega eq (1)
/// in the rotor frame at steady state, `v_d = R i_d − ω_e L i_q`, `v_q = R i_q + ω_e (ψ_f + L i_d)`, gives
/// `|v|² = |v|²(i_q = 0) + 2 R ω_e ψ_f i_q + (R² + ω_e² L²) i_q²` (the cross terms in `i_d`
/// cancel): a q current against the rotation (`ω_e i_q < 0`) needs `4 R |ω_e| ψ_f |i_q|`
/// less of `|v|²` than the same current motoring, on every motor, and it slows the rotor,
/// which lowers the back-EMF the field weakening answers. Left behind the field weakening,
/// an overhauling load that accelerates the rotor faster than the speed loop answers
/// (`overhaul-hold` on the Sinano motor: 165 rpm per ms after the load reverses) raises the
/// back-EMF, the field weakening takes the whole current limit and the braking command is
/// clamped to zero: the load runs the rotor away (to 2,448 rpm and `overspeed` with the
/// sliding primary, whose speed estimate lags the rotor by 350 rpm and its angle then by 65°).
#[inline(always)]
fn braking_first(s: &mut Sensorless, i_max_a: f32) {
    let i_d_max = sqrt_or_zero(i_max_a * i_max_a - s.i_q_ref * s.i_q_ref);
    s.i_d_fw = max(s.i_d_fw, -i_d_max);
    s.i_d_handover = clamp(s.i_d_handover, -i_d_max, i_d_max);
    s.i_d_ref = clamp(s.i_d_fw + s.i_d_handover, -i_d_max, i_d_max);
}

/// MTPA's currents for the speed loop's torque current `i_tau` \[A] (`crate::mtpa`) on a
/// salient motor: the d current the more negative of the MTPA's for this torque and the field
/// weakening's, the q current that makes the torque with it (one Newton step from the last q
/// current, [`Mtpa::split`]), the hand-over's d current added; motoring within what the d
/// current leaves of the limit `i_max_a` \[A] (a step not yet on the curve may ask for more),
/// the rotor at `omega_m` \[rad/s]. Sets `s.i_d_ref`, `s.i_q_ref`, `s.i_tau`; returns the q
/// current's limit, `√(i_max² − i_d_ref²)` \[A], where the q current reaches it (else
/// infinity: the square root only where it is needed).
// Out of line: a non-salient motor's tick pays one branch.
#[inline(never)]
fn mtpa_currents(m: &Mtpa, s: &mut Sensorless, i_tau: f32, i_max_a: f32, omega_m: f32) -> f32 {
    let i_dq = m.split(i_tau, s.i_d_ref - s.i_d_handover, s.i_d_fw);
    s.i_d_ref = i_dq.d + s.i_d_handover;
    let room = i_max_a * i_max_a - s.i_d_ref * s.i_d_ref;
    let mut i_q_max = f32::INFINITY;
    s.i_q_ref = i_dq.q;
    // (False for a NaN q current: it is limited.)
    let within = i_dq.q * i_dq.q <= room;
    if !within {
        i_q_max = sqrt_or_zero(room);
        s.i_q_ref = if omega_m >= 0.0 {
            min(i_dq.q, i_q_max)
        } else {
            max(i_dq.q, -i_q_max)
        };
    }
    s.i_tau = m.torque_current(Dq::new(i_dq.d, s.i_q_ref));
    i_q_max
}

/// The state of [`Mode::Sensorless`](super::Mode::Sensorless).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Sensorless {
    /// Slewed speed reference [rpm, mechanical].
    speed_ref_rpm: f32,
    /// The speed PI's integrator \[A].
    speed_pi: PiState,
    /// The speed loop's i_q command \[A].
    i_q_ref: f32,
    /// The torque current the commands make \[A] (`crate::mtpa`: `τ/(c N ψ_f)`, the speed
    /// loop's output): `i_q_ref` on a non-salient motor.
    i_tau: f32,
    /// The field-weakening i_d \[A] (≤ 0).
    i_d_fw: f32,
    /// The motoring torque current's ceiling from the voltage \[A] ([`VoltageEnd`]; ∞ until it
    /// first acts).
    i_q_v: f32,
    /// The open loop's d current at the hand-over, decaying \[A] (see
    /// [`Settings::enter`]).
    i_d_handover: f32,
    /// The d current command \[A]: their sum, or the MTPA's d current (where it is more
    /// negative than the field weakening's) and the hand-over's.
    i_d_ref: f32,
    /// The driving observer's speed at the last 1 kHz task \[rad/s]: the current loop's
    /// decoupling and back-EMF feed-forward until the next (see [`Settings::step`]).
    omega_m: f32,
    /// sin/cos of the output angle's lead at the driving observer's speed
    /// (`Foc::output_rotation`), renewed by the 1 kHz task (the speed read-outs move at
    /// 1 kHz).
    out_rot: SinCos,
    /// Consecutive checks of a collapsed speed at the current limit.
    stall: StallCount,
    /// Consecutive checks of an over-speed.
    overspeed: u32,
    /// The highest |speed| since it passed the over-speed bound (0 below it) \[rpm].
    overspeed_peak_rpm: f32,
    /// The speed loop's load-torque observer (`load_observer.rs`).
    load: LoadObserverState,
    /// The load torque fed forward last \[N·m].
    ff_nm: f32,
    /// The measured bus, low-passed at 1 kHz (0 before the first run) \[V].
    bus_v: f32,
    /// The least bound on the braking |i_q| the regeneration's limit set since the last
    /// speed-loop run \[A] (∞: none): the speed loop's limit at its next run.
    regen_iq_a: f32,
}

impl Sensorless {
    /// Slewed speed reference \[rpm].
    pub(super) fn speed_ref_rpm(&self) -> f32 {
        self.speed_ref_rpm
    }

    /// The speed loop's i_q command \[A].
    pub(super) fn i_q_ref(&self) -> f32 {
        self.i_q_ref
    }

    /// The torque current the commands make, `τ/(c N ψ_f)` \[A] (`crate::mtpa`): the speed
    /// loop's output; the q current on a non-salient motor.
    pub(super) fn torque_current(&self) -> f32 {
        self.i_tau
    }

    /// sin/cos of the output angle's lead at the driving observer's speed.
    pub(super) fn out_rot(&self) -> SinCos {
        self.out_rot
    }
}

impl Settings {
    /// Sensorless control of a rotor at `e.omega_m` \[rad/s] carrying the current `e.i_dq` \[A]
    /// in the driving observer's frame, `e.load_nm` its load estimate \[N·m] if it has one:
    /// the reference at `e.ref_omega_m` (the rotor's speed, or zero against the command), the command at `i_dq.q`, the load-torque observer at the torque
    /// it makes, the speed PI's integrator at what the feed-forward (the driving observer's
    /// load, else the load-torque observer's) leaves of the command. A d current (the
    /// open loop's, at the hand-over) is kept and decays over `handover_decay`'s
    /// time: the current vector does not jump when the frame changes, so an angle error of
    /// the observer at the hand-over does not turn into a torque step; the speed loop takes
    /// the torque over as the d current fades (the smooth I/f transition of Fatu, Teodorescu,
    /// Boldea, Andreescu & Blaabjerg, "I-F starting method with smooth transition to EMF based
    /// motion-sensorless vector control of PM synchronous motor/generator", IEEE PESC 2008).
    ///
    /// Under a speed reference below the hand-over speed (one the open loop handed over at, a
    /// reversal's or a catch's on its way through zero, a stop's once it is that low; not a
    /// stop's on its way down from speed) the d current fades only down
    /// to `low_speed_d_a`, and is held there. An unloaded rotor there needs almost no
    /// current, and phase currents near zero leave the inverter's dead-time voltage
    /// `t_d f_pwm V_bus` unknown in sign (its compensation follows the current's sign: Choi &
    /// Sul, "Inverter output voltage synthesis using novel dead time compensation", IEEE
    /// Trans. Power Electron. 11(2), 1996), while the back-EMF the voltage-model observers
    /// integrate, `N ψ_f ω`, is of the same size at a few % of rated (Nanotec DF45: 0.24 V
    /// against 0.29 V at 3 %; the T-motor drone motor: 0.17 V against 0.23 V). With the
    /// current gone the flux observer's angle drifted a quarter turn in 0.1 s (on the ideal
    /// inverter it does not); with twice the compensation's band held on the d axis it stays
    /// within a few degrees. Not more: a d current makes a torque `∝ i_d sin(θ − θ̂)` about the
    /// observer's angle, a spring that shook the Delta servo's rotor by ±70 rpm at 90 rpm with
    /// the whole I/f current held.
    ///
    /// Above the hand-over speed too, up to where the dead-time voltage is a twentieth of the
    /// back-EMF (a tenth under a zero command: `dead_time_rpm`, `dead_time_stop_rpm`,
    /// [`DriveConfig::low_speed_hold`](super::DriveConfig::low_speed_hold)),
    /// while the speed loop last asked for less q current than the hold: on Ortega's test
    /// motor (2 V of dead-time voltage against 4.6 V of back-EMF at its hand-over speed) a
    /// stop's way down from 300 to 140 rpm, the speed loop asking for almost no current,
    /// threw both observers 20° off and ended in `observer_loss` in 14 of 120 seeded stops
    /// (`host-sim/tests/regen.rs`' scenarios; none with the hold).
    // Out of line, like the other mode changes: rare, kept off the every-step path.
    #[inline(never)]
    pub(super) fn enter(&self, foc: &Foc, e: Entry) -> Sensorless {
        let (omega_m, i_dq) = (e.omega_m, e.i_dq);
        let mut load = LoadObserverState::default();
        let torque = foc.torque_for_current(i_dq.q);
        self.load_observer.reset(&mut load, torque, omega_m);
        let ff_nm = e.load_nm.unwrap_or(torque);
        let ff_a = foc.current_for_torque(ff_nm);
        Sensorless {
            speed_ref_rpm: e.ref_omega_m * RPM_PER_RAD_S,
            speed_pi: PiState {
                integral: i_dq.q - ff_a,
            },
            i_q_ref: i_dq.q,
            i_tau: i_dq.q,
            i_d_fw: 0.0,
            // (Unbounded until `VoltageEnd` first acts, which bounds it by `i_max`: a salient
            // motor's torque current may exceed `i_max`, `crate::mtpa`.)
            i_q_v: f32::INFINITY,
            i_d_handover: i_dq.d,
            i_d_ref: i_dq.d,
            omega_m,
            out_rot: foc.output_rotation(omega_m),
            stall: StallCount::default(),
            overspeed: 0,
            overspeed_peak_rpm: 0.0,
            load,
            ff_nm,
            bus_v: 0.0,
            regen_iq_a: f32::INFINITY,
        }
    }

    /// One sensorless step: the speed loop's currents in the driving observer's frame `frame`
    /// (sin/cos of θ̂_e), applied at its output angle `frame_out` (`frame` turned by
    /// [`Sensorless::out_rot`], or the observer's own); limited by the regeneration's limit
    /// on the bus `v_bus` \[V] where it is high (`regen.rs`).
    ///
    /// The rotor's speed for the decoupling and the back-EMF fed forward is the driving
    /// observer's at the last 1 kHz task, held until the next, as the speed loop's is (and
    /// the output angle's lead, [`Sensorless::out_rot`], where the observer gives no EMF angle
    /// of its own). Not the sliding torque observer's own, which moves every step with the
    /// torque current through its model's inertia `J₀` (`observer::sliding`, eq (35)): fed
    /// forward, its change beyond the rotor's, `N ψ_f K_t (1/J₀ − 1/J)` volts per
    /// ampere-second of current, is a positive integral feedback on the current against the
    /// current PI's negative one, `R ω_c` (`crate::foc`); above it the current loop runs
    /// away, up to the observer's correction. Zero at the rotor's inertia; the Delta servo
    /// told a tenth of it: 26,900 against 1,461 V/(A·s) (`overcurrent` at 2.1 and 3.1 s of its
    /// `start-stop-reverse` and `ramp-brake-drive`, sliding primary), the two Anaheims 1.75
    /// and 1.8 times their PI's. Issue #26's `zoo-inertia.toml`: 19 runs of the sliding primary
    /// pass that failed (16 told a tenth of the inertia, 3 ten times), 2 fail that passed; no
    /// other matrix of the zoo's changes beyond its seeds' spread. The price: between two
    /// tasks the fed-forward back-EMF lags an accelerating rotor's, by up to `N ψ_f α` × 1 ms
    /// (0.6 V on the T-motor drone motor at its rated torque, of 9.7 V), as it always has
    /// under the flux primary, whose PLL speed moves only at the task.
    #[inline(always)]
    pub(super) fn step(
        &self,
        s: &mut Sensorless,
        frame: SinCos,
        frame_out: SinCos,
        v_bus: f32,
    ) -> Request {
        let mut i_dq = Dq::new(s.i_d_ref, s.i_q_ref);
        let k = self.regen.share(v_bus);
        if k < 1.0 {
            cold_path();
            let (limited, bound) = self.regen.limit(k, i_dq, s.omega_m);
            i_dq = limited;
            s.regen_iq_a = min(s.regen_iq_a, bound);
        }
        Request {
            frame,
            frame_out,
            omega_m: s.omega_m,
            reference: Reference::Current(i_dq),
        }
    }

    /// Derated by the bus (`derating.rs`): the field weakening acting and the current at the
    /// limit it shares with the torque (`|i_dq ref| ≥ 0.99 i_max`) or the torque current under
    /// the voltage's ceiling ([`VoltageEnd`], below 0.99 i_max), the rotor at `omega_m`
    /// \[rad/s] short of the speed reference: the load's torque does not fit at the reference
    /// on this bus.
    pub(super) fn derated(&self, s: &Sensorless, omega_m: f32) -> bool {
        let i_max = 0.99 * self.field_weakening.i_max_a;
        let i2 = s.i_d_ref * s.i_d_ref + s.i_q_ref * s.i_q_ref;
        let short = (omega_m * RPM_PER_RAD_S).abs() < s.speed_ref_rpm.abs();
        s.i_d_fw < 0.0 && (i2 >= i_max * i_max || s.i_q_v < i_max) && short
    }

    /// Sensorless control's 1 kHz work ([`Drive::tick`](super::Drive::tick)), after the
    /// health check (its `verdict`, and `note` when the driving observer changed; `d` the
    /// driving observer's estimate now): the hand-back where no observer is healthy at low
    /// speed or where the reference passes through zero, observer loss, over-speed, the stop at zero, the output lead at the new speed,
    /// the speed loop toward the user's `cmd_rpm` with the load torque fed forward, the stall
    /// check.
    /// `applied`: what the current loop applied over the last millisecond; `speed_gain` the
    /// speed loop's gain and its checks (`speed_gain.rs`).
    #[inline(always)]
    #[allow(clippy::too_many_arguments)]
    pub(super) fn tick(
        &self,
        s: &mut Sensorless,
        foc: &Foc,
        ((verdict, note), residual): ((Verdict, Option<Reason>), f32),
        d: Driving,
        cmd_rpm: f32,
        applied: Applied,
        i_ab: AlphaBeta,
        speed_gain: &mut speed_gain::State,
    ) -> Next {
        let cmd_rpm = self.ramp.command(cmd_rpm);
        let (omega_m, load_nm) = (d.omega_m, d.load_nm);
        let speed_rpm = omega_m * RPM_PER_RAD_S;
        let handback = self.handback_rpm;
        match verdict {
            Verdict::Drive | Verdict::Switched => {}
            // Without an observer at low speed, open loop carries the rotor on.
            Verdict::NoLock if s.speed_ref_rpm.abs() < handback && speed_rpm.abs() < handback => {
                return Next::OpenLoop {
                    frame: d.frame,
                    omega_m,
                    i_q_a: 0.0,
                };
            }
            Verdict::NoLock | Verdict::Contradiction => return Next::Fault(Fault::ObserverLoss),
        }
        // Through zero speed: the speed reference on its way to a command on the other side of
        // zero (a reversal, not a load pushing the rotor back; the reference beyond the stop
        // speed, not one seeded at a standing rotor), the rotor and the reference below the
        // hand-over speed, and the driving observer past half-way to the edge of lock. The
        // observers carry most reversals through zero (issue #17's under a brake; a direct
        // reversal, `tests/drive.rs`); where one drifts (a rotor lingering near zero speed),
        // the I/f open loop carries the rotor through from the driving observer's frame and
        // speed and hands over again on the other side.
        //
        // The stop (a zero command) the same way, whatever the residual: the reference on its
        // way down hands the rotor to the I/f open loop below the hand-over speed, which ramps
        // it to zero and stops (`open_loop.rs`), the start's sequence backwards; a reference
        // already at zero (a hand-over at a zero command) stops below the stop speed. Below the
        // hand-over speed a model error is no longer small against the back-EMF: a resistance
        // off by ΔR moves the back-EMF the observers see by ΔR |i|, a share
        // ΔR |i|/(ψ_f ω_e) of it that grows as 1/ω_e, and the drive measures R at a start and,
        // while running, only above a tenth of rated speed where R |i| is at least the
        // back-EMF (`adaptation.rs`). The residual does not show it (the observer fits the
        // model it is given). Issue #26's warm winding (R × 1.5 after the start) on the
        // identified Teknic M-2310P under its brake, flux primary (measured before R was
        // tracked while running; unloaded at rated speed it still is not): ΔR |i| = 0.18 Ω ×
        // 2 A = 0.36 V, 22 % of the back-EMF at 600 rpm (angle error 7°), the angle 28° off at
        // 270 rpm and 90° (lost) at 3.95 s, the rotor at 30 rpm, while the residual stayed at
        // most 0.40; handed to the I/f at 400 rpm, the stop keeps the rotor (the 60 mm servo
        // and the gimbal alike). The I/f current holds the rotor whatever R: the current loop
        // drives it, and its torque needs no model. (One test on the running path,
        // `cmd · ref ≤ 0`, for both.)
        let along = cmd_rpm * s.speed_ref_rpm;
        if along <= 0.0 {
            let stopping = cmd_rpm == 0.0;
            if stopping && s.speed_ref_rpm == 0.0 && speed_rpm.abs() < self.stop_rpm {
                return Next::Stopped;
            }
            let band = self.through_zero_rpm;
            let failing = stopping || residual > THROUGH_ZERO_RESIDUAL;
            let (ref_abs, speed_abs) = (s.speed_ref_rpm.abs(), speed_rpm.abs());
            if failing && ref_abs > self.stop_rpm && ref_abs < band && speed_abs < band {
                return Next::OpenLoop {
                    frame: d.frame,
                    omega_m,
                    i_q_a: 0.0,
                };
            }
        }
        // A locked observer's speed beyond the bound, persistently: a rotor the drive no
        // longer holds.
        s.bus_v = if s.bus_v == 0.0 {
            applied.v_bus
        } else {
            s.bus_v + self.bus_filter * (applied.v_bus - s.bus_v)
        };
        let overspeed_rpm = self.overspeed_rpm_per_v * s.bus_v;
        let above = speed_rpm.abs() > overspeed_rpm;
        s.overspeed = consecutive(s.overspeed, above);
        s.overspeed_peak_rpm = if above {
            max(s.overspeed_peak_rpm, speed_rpm.abs())
        } else {
            0.0
        };
        if s.overspeed >= self.overspeed_checks {
            // (Judged only then: the running drive's tick skips it.)
            cold_path();
            let recovering = speed_rpm.abs() < (1.0 - RECOVERING) * s.overspeed_peak_rpm;
            if !recovering {
                return Next::Fault(Fault::Overspeed);
            }
        }
        // The hand-over's d current: fading, held under a speed reference below the hand-over
        // speed, and below the dead-time speed while the q current asked for is smaller (`enter`).
        let decayed = s.i_d_handover * self.handover_decay;
        // (The speed reference, not the command, below the hand-over speed: on a stop's way down
        // from speed a held d current stands in the braking's way (the stop into a supply that
        // cannot sink, `host-sim/tests/dc_link.rs`); on a reversal's or a catch's way through
        // zero, the command beyond it, the dead-time voltage near zero current threw the
        // observers off (issue #26's zoo: 21 through-zero cells of 8 motors that pass on an
        // inverter without dead time).)
        let ref_abs = s.speed_ref_rpm.abs();
        let dead_time_rpm = if cmd_rpm == 0.0 {
            self.dead_time_stop_rpm
        } else {
            self.dead_time_rpm
        };
        let low = ref_abs < self.through_zero_rpm
            || (ref_abs < dead_time_rpm && s.i_q_ref.abs() < self.low_speed_d_a);
        s.i_d_handover = if low {
            // (Laid out of the way: the running drive's tick falls through.)
            cold_path();
            // A command lowered below the speed held in the I/f (`open_loop.rs`: there a model
            // error is no longer small against the back-EMF; at most the hand-back speed, below
            // the hand-over speed, so within `low`): once the reference and the rotor are there too, the I/f
            // carries the rotor on at the speed reference (smooth, where the estimate is
            // noisy) with the torque current asked for (its frame ahead of the observer's
            // angle: a load does not pull the rotor back while the load angle builds), as a
            // start to that command does.
            let held = self.held_below_rpm;
            if cmd_rpm != 0.0 && max(cmd_rpm.abs(), max(ref_abs, speed_rpm.abs())) < held {
                return Next::OpenLoop {
                    frame: d.frame,
                    omega_m: s.speed_ref_rpm * RAD_S_PER_RPM,
                    i_q_a: s.i_q_ref,
                };
            }
            max(decayed, self.low_speed_d_a)
        } else {
            decayed
        };
        s.omega_m = omega_m;
        s.out_rot = foc.output_rotation(omega_m);
        s.speed_ref_rpm = self.ramp.slew(s.speed_ref_rpm, cmd_rpm);
        let omega_m_ref = s.speed_ref_rpm * RAD_S_PER_RPM;
        // The driving observer's load estimate fed forward, else the speed loop's own. When
        // the driving observer changes, so may the feed-forward: the integrator takes the
        // step, so the command does not jump (bumpless transfer).
        let own = self.load_observer.update(&mut s.load, omega_m, s.i_tau);
        let ff_nm = load_nm.unwrap_or(own);
        if note.is_some() {
            s.speed_pi.integral += foc.current_for_torque(s.ff_nm - ff_nm);
        }
        s.ff_nm = ff_nm;
        // The field-weakening i_d, and i_q within what it leaves of the current limit.
        let fw = &self.field_weakening;
        let (i_d_fw, excess_v) = fw.i_d(s.i_d_fw, applied.v_ab, applied.v_max);
        s.i_d_fw = i_d_fw;
        // The minimum-voltage end and the torque's ceiling (`VoltageEnd`), while the field
        // weakening acts or the ceiling is down. (Laid out of the way: the running drive's
        // tick below the voltage target falls through.)
        if self.mtpa.is_none() && (i_d_fw < 0.0 || s.i_q_v < fw.i_max_a) {
            cold_path();
            fw.end.apply(s, excess_v, omega_m, fw);
        }
        s.i_d_ref = s.i_d_fw + s.i_d_handover;
        let mut i_q_max = sqrt_or_zero(fw.i_max_a * fw.i_max_a - s.i_d_ref * s.i_d_ref);
        // The speed loop's output is a torque current (`crate::mtpa`), the q current itself on
        // a non-salient motor; on a salient one its limit is the torque at the current limit
        // with the MTPA's d current there, or the field weakening's where more negative.
        // (The salient branches laid out of the way, `cold_path`: a non-salient motor's
        // tick falls through them.)
        let i_tau_max = match &self.mtpa {
            None => i_q_max,
            Some(m) => {
                cold_path();
                m.torque_limit(s.i_d_fw, i_q_max)
            }
        };
        // Anti-windup at both limits: the speed PI's output and integrator within i_q_max;
        // and at the voltage limit with the field weakening at its end (all of i_max on the d
        // axis: nothing frees voltage any more), the integrator held against more motoring
        // current, which would need voltage the loop does not have. While the field weakening
        // still has room, it answers the voltage, not the speed loop. Braking current
        // (against the rotation) lowers the voltage and stays free.
        // (At its end: all of i_max on the d axis, or the torque's ceiling down, which only
        // falls at the minimum-voltage end, `VoltageEnd`.)
        let exhausted = applied.limited && (s.i_d_fw <= -fw.i_max_a || s.i_q_v < fw.i_max_a);
        let held = match (exhausted, omega_m >= 0.0) {
            (false, _) => Held::No,
            (true, true) => Held::Up,
            (true, false) => Held::Down,
        };
        // Braking before field weakening: the braking side of the command may take the whole
        // current limit, within the regeneration's bound (∞ unless the bus was high since the
        // last run); the field weakening's d current gets what the braking leaves
        // ([`braking_first`]).
        let braking_max = min(
            self.braking_max_a,
            core::mem::replace(&mut s.regen_iq_a, f32::INFINITY),
        );
        let motoring_max = min(i_tau_max, s.i_q_v);
        let bounds = if omega_m >= 0.0 {
            (-braking_max, motoring_max)
        } else {
            (-motoring_max, braking_max)
        };
        let i_tau = foc.speed_step_scaled(
            &mut s.speed_pi,
            (omega_m_ref, omega_m),
            speed_gain.gain(),
            ff_nm,
            Some((bounds, held)),
        );
        if let Some(m) = &self.mtpa {
            cold_path();
            i_q_max = mtpa_currents(m, s, i_tau, fw.i_max_a, omega_m);
        } else {
            s.i_q_ref = i_tau;
            s.i_tau = i_tau;
        }
        if s.i_q_ref.abs() > i_q_max {
            // Braking first only where it can hold the rotor within the current limit: the
            // load the speed loop's own observer estimates within it, and the current loop
            // keeping the measured current within it (the voltage still controls it). Else
            // the field weakening's d current comes first, as for motoring: the current stays
            // controlled and a load beyond the limit takes the rotor to the over-speed bound.
            let i2 = i_ab.alpha * i_ab.alpha + i_ab.beta * i_ab.beta;
            let i_max2 = fw.i_max_a * fw.i_max_a;
            let load_a = foc.current_for_torque(own);
            if i2 > i_max2 || load_a * load_a > i_max2 {
                s.i_q_ref = clamp(s.i_q_ref, -i_q_max, i_q_max);
                s.speed_pi.integral = clamp(s.speed_pi.integral, -i_tau_max, i_tau_max);
            } else {
                // (On a salient motor the MTPA's d current goes with the field weakening's.)
                braking_first(s, fw.i_max_a);
            }
            s.i_tau = match &self.mtpa {
                None => s.i_q_ref,
                Some(m) => m.torque_current(Dq::new(s.i_d_ref - s.i_d_handover, s.i_q_ref)),
            };
        }
        if (self.stall).stalled(&mut s.stall, omega_m, s.speed_ref_rpm, s.i_tau) {
            return Next::Fault(Fault::Stall);
        }
        // The speed loop's gain checks (`speed_gain.rs`: a fast oscillation at the limit, a
        // slow one's inertia; `Drive::tick` restarts them where the driving observer is not
        // locked, the fast one where it switched, and this run counts toward the next); not
        // on a salient motor, whose task has no room for them (`DEVELOPERS.md`).
        if self.mtpa.is_none() {
            let at_limit = s.i_tau.abs() >= self.stall.i_limit_a;
            let error = omega_m_ref - omega_m;
            (self.speed_gain).check(speed_gain, error, at_limit, omega_m, s.i_tau);
        }
        match note {
            Some(reason) => Next::Note(reason),
            None => Next::Stay,
        }
    }
}
