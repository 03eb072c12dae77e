//! Identification: the drive measures the motor it is connected to — phase resistance,
//! inductance (d and q axis), permanent-magnet flux linkage, inertia and viscous friction —
//! from the user's pole pairs and ratings alone, in the same 4 kHz step and 1 kHz tick as the
//! rest of the drive (no heap, no panic, no f64). [`Drive::start_identification`] runs, from
//! idle, the offset calibration (`offset.rs`) and then one measurement after another, each a
//! phase of the mode `Identify` with its own state:
//!
//! 1. `resistance.rs`: two DC current levels on the α axis (rotor held at θ_e = 0),
//!    `R = ΔV/ΔI` (dead time and offsets cancel), and a third level on the β axis that checks
//!    the winding: the DC conductance of a healthy machine is the same in every direction;
//!    an open phase leaves a direction without current, a shorted winding triples one.
//! 2. `inductance.rs`: a square-wave voltage on top of the first level's DC voltage, on the
//!    d axis then the q axis: `L` from the current ripple.
//! 3. `flux.rs`: an I/f spin at a known electrical speed: `ψ_f = |v − R i − L di/dt|/ω_e`.
//! 4. `mechanics.rs`: torque steps with the frame locked on the back-EMF: `J` and `B` from the
//!    accelerations.
//!
//! Every measurement checks its own plausibility and ends with a named
//! [`IdentifyError`] (as [`Fault::Identify`]: PWM off, latched like any fault), never a
//! silent number: an open phase, a shorted phase, a blocked rotor during the spin, a result
//! out of the range of [`MotorParams`], a motor whose rated current the board cannot sense.
//! The results are read with [`DriveState::identified`] once the mode is `Identified`; the
//! drive then stays with its PWM off until the enable command is withdrawn. The gains follow
//! from the identified motor as from any other ([`DriveConfig::new`]).
//!
//! The drive's own motor parameters (its gains, its observers) play no part: the measurements
//! use voltages until `R` and `L` are known, then a current loop re-derived from them
//! (`kp = L ω_c`, `ki = R ω_c`, as [`crate::foc`]). Pole pairs cannot be measured without a
//! sensor: the user gives them, and the ratings give the limits (test currents from
//! `current_a`, speeds from `speed_rpm`, voltages from the bus sampled).
//!
//! [`Drive::start_identification`]: super::Drive::start_identification
//! [`DriveState::identified`]: super::DriveState::identified
//! [`Fault::Identify`]: super::Fault::Identify
//! [`DriveConfig::new`]: super::DriveConfig::new
//! [`MotorParams`]: crate::motor::MotorParams
// Without the feature `identify` the modes are never entered and their code is unused.
#![cfg_attr(not(feature = "identify"), allow(dead_code, unused_imports))]

pub(super) mod flux;
pub(super) mod inductance;
pub(super) mod inverter;
pub(super) mod mechanics;
pub(super) mod offset;
pub(super) mod resistance;

use crate::foc::Foc;
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::motor::{MotorParams, Ratings, TorqueConvention};
use crate::param::{Allowed, ParamError};
use core::f32::consts::TAU;
use flux::FluxSpin;
use inductance::Inductance;
use inverter::hold_signs;
use mechanics::Mechanics;
use resistance::Resistance;

/// Why an identification stopped (the drive's [`Fault::Identify`]).
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IdentifyError {
    /// The board's current sensing cannot measure this motor: the trip current
    /// (2.25 × `current_a`) beyond the sensing range, or the rated current below 100 LSB.
    CurrentNotSensable,
    /// A direction of the stator takes (almost) no current: a phase is not connected.
    OpenPhase,
    /// The DC conductance differs between directions: a shorted winding (or phases shorted
    /// together).
    ShortedPhase,
    /// No back-EMF while the current's frame spins: the rotor does not turn, not even at the
    /// start of the spin; or, on a salient motor, the apparent EMF of a rotor at rest, told by
    /// its trace (`flux.rs`).
    BlockedRotor,
    /// The rotor turned with the spin at its start (a back-EMF growing with the frame's
    /// speed) but not at the measuring speed: it lags or slips (an inertia or a load the
    /// spin's acceleration and current do not move, or a motor too fast for the control rate),
    /// it is not blocked.
    SpinNotFollowed,
    /// The back-EMF left the frame during the torque steps (the rotor was lost).
    LostRotor,
    /// The measured resistance is outside [`MotorParams::R_OHM`], or the bus cannot drive the
    /// test current through it.
    ResistanceOutOfRange,
    /// The measured inductance is outside [`MotorParams::L_H`] (or the ripple does not fit an
    /// R-L circuit).
    InductanceOutOfRange,
    /// The measured flux linkage is outside [`MotorParams::FLUX_WB`].
    FluxOutOfRange,
    /// The measured inertia is outside [`MotorParams::J_KGM2`], or the torque steps did not
    /// move the rotor measurably within the rated current.
    InertiaOutOfRange,
}

/// Which measurement runs.
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum IdentifyPhase {
    /// Resistance and the winding check.
    Resistance,
    /// d- and q-axis inductance.
    Inductance,
    /// Flux linkage.
    Flux,
    /// Inertia and friction.
    Mechanics,
}

/// The identified motor (SI units, amplitude-invariant αβ; `j_kgm2` and `b_nms` in the torque
/// convention of the drive's motor, [`MotorParams::torque`]).
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Identified {
    /// Phase resistance \[Ω].
    pub r_ohm: f32,
    /// Inductance on the axis of the aligned rotor (d) \[H].
    pub l_d_h: f32,
    /// Inductance on the axis at 90° electrical to it (q) \[H].
    pub l_q_h: f32,
    /// Permanent-magnet flux linkage \[Wb].
    pub flux_wb: f32,
    /// Rotor inertia \[kg·m²].
    pub j_kgm2: f32,
    /// Viscous friction \[N·m·s/rad] (a negative estimate, within noise of zero, is 0).
    pub b_nms: f32,
}

/// `L_d` and `L_q` apart by more than this share of their mean: a salient motor (twice the
/// 5 % the identification answers for on each inductance); closer, the motor is taken as
/// non-salient with their mean.
pub(super) const SALIENT: f32 = 0.1;

/// Two halves of an average apart by more than this share of what is measured: the rotor
/// still moves, its back-EMF in the currents (`resistance.rs`, `inductance.rs`; a hundred times
/// the noise of a 50 ms mean at the board's 1 % noise).
pub(super) const REST: f32 = 0.01;

/// The means of a sum's two halves \[A], the first half `first` and the whole `total` (each a
/// sum and its count), differ by no more than `√tolerance_sq` \[A] (as a vector). Out of
/// line: the 1 kHz work of two measurements calls it.
#[inline(never)]
pub(super) fn halves_agree(
    first: (AlphaBeta, u32),
    total: (AlphaBeta, u32),
    tolerance_sq: f32,
) -> bool {
    let ((sum1, n1), (sum, n)) = (first, total);
    let (k1, k2) = (n1.max(1) as f32, n.saturating_sub(n1).max(1) as f32);
    let d_alpha = (sum.alpha - sum1.alpha) / k2 - sum1.alpha / k1;
    let d_beta = (sum.beta - sum1.beta) / k2 - sum1.beta / k1;
    d_alpha * d_alpha + d_beta * d_beta <= tolerance_sq
}

/// `√x` out of line ([`crate::math::sqrt_call`]): the measurements' 1 kHz work is not the
/// step.
pub(super) use crate::math::sqrt_call as sqrt;

/// `|x_dq|` ([`Dq::magnitude`]) out of line, for the same reason.
#[inline(never)]
pub(super) fn magnitude(x: Dq) -> f32 {
    x.magnitude()
}

/// [`SinCos::of_small`] out of line, for the same reason (about 180 B a copy).
#[inline(never)]
pub(super) fn rotation(delta: f32) -> SinCos {
    SinCos::of_small(delta)
}

impl Identified {
    /// The inductance of a non-salient model: the mean of `l_d_h` and `l_q_h` \[H].
    pub fn l_h(&self) -> f32 {
        0.5 * (self.l_d_h + self.l_q_h)
    }

    /// `L_d` and `L_q` measured apart by more than 10 % of their mean (twice the 5 % the
    /// identification answers for on each).
    pub fn salient(&self) -> bool {
        (self.l_d_h - self.l_q_h).abs() > SALIENT * self.l_h()
    }

    /// The model's inductances `(L_d, L_q)` \[H]: as measured where [`Identified::salient`],
    /// else their mean on both axes.
    pub fn l_dq_h(&self) -> (f32, f32) {
        if self.salient() {
            (self.l_d_h, self.l_q_h)
        } else {
            (self.l_h(), self.l_h())
        }
    }

    /// The motor parameters with the user's `pole_pairs`, validated, in the convention
    /// `torque` the identification ran in: salient with `l_d_h` and `l_q_h` where
    /// [`Identified::salient`], else with their mean.
    pub fn params(
        &self,
        pole_pairs: u32,
        torque: TorqueConvention,
    ) -> Result<MotorParams, ParamError> {
        let m = MotorParams::new(
            pole_pairs,
            self.r_ohm,
            self.l_h(),
            self.flux_wb,
            self.j_kgm2,
            self.b_nms,
        )?
        .with_torque(torque);
        if self.salient() {
            m.with_inductances(self.l_d_h, self.l_q_h)
        } else {
            Ok(m)
        }
    }
}

/// The board's current sensing, as the identification checks a motor against it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifyConfig {
    /// Largest phase current the sensing reports \[A] (the ADC's full scale through the
    /// amplifier), > 0.
    pub sense_range_a: f32,
    /// The current of one ADC step \[A], ≥ 0 (0: not limiting).
    pub sense_lsb_a: f32,
}

impl IdentifyConfig {
    /// The settings checked; the error names the bad field.
    pub(super) fn check(&self) -> Result<(), ParamError> {
        Allowed::POSITIVE.check("identify.sense_range_a", self.sense_range_a)?;
        Allowed::between(0.0, 1e3).check("identify.sense_lsb_a", self.sense_lsb_a)?;
        Ok(())
    }
}

/// The flux linkage's spin turns at this share of rated speed (and the torque steps run
/// between it and twice it). A drive that identifies runs at the control rate that gives
/// this speed 20 samples per electrical period (`crate::rate::control_rate` at it), at least
/// 4 kHz: the rated speed's rate is not needed, and on a motor whose rated speed asks for the
/// PWM's own frequency the spin is not followed (measured on the EMRAX 228: J −1.1 % at
/// 10 kHz, `spin_not_followed` at 20 kHz, the cause not found yet).
pub const SPIN_SPEED_SHARE: f32 = 0.3;

/// A placeholder motor for a drive that is to identify its motor: the user's pole pairs,
/// ratings and torque convention, a flux linkage whose torque at `current_a` is the rated
/// torque, a resistance whose
/// rated current takes a tenth of the bus's phase voltage and a 1 ms electrical time constant.
/// Only the limits and the observers' construction use it; the identification's measurements
/// do not (module doc).
pub fn placeholder(
    pole_pairs: u32,
    ratings: Ratings,
    torque: TorqueConvention,
) -> crate::motor::Motor {
    let n = pole_pairs.max(1) as f32;
    let r_ohm = 0.1 * ratings.bus_v * crate::math::INV_SQRT3 / ratings.current_a;
    crate::motor::Motor {
        name: "placeholder",
        params: MotorParams {
            pole_pairs,
            r_ohm,
            l_h: 1e-3 * r_ohm,
            flux_wb: ratings.torque_nm / (torque.factor() * n * ratings.current_a),
            j_kgm2: 1e-3,
            b_nms: 0.0,
            saliency: 1.0,
            torque,
        },
        ratings,
    }
}

/// The identification's coefficients, derived once ([`Settings::new`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// The test current, the user's rated current \[A].
    pub(super) i_test_a: f32,
    /// The motor's current can be measured by the board (checked at the start).
    pub(super) sensable: bool,
    /// The rated bus's phase voltage `V_bus/√3` \[V] (the resistance ramp's scale).
    pub(super) v_phase_rated: f32,
    /// Step period T \[s].
    pub(super) ts: f32,
    /// Current-loop bandwidth ω_c \[rad/s] and ω_c T.
    pub(super) w_c: f32,
    pub(super) w_c_ts: f32,
    /// Pole pairs N.
    pub(super) n: f32,
    /// `c` of the motor's torque convention, `τ = c N ψ_f i_q`.
    pub(super) torque_factor: f32,
    /// N T \[s]: the frame's advance per step per rad/s of mechanical speed.
    pub(super) n_ts: f32,
    /// Spin speed for the flux linkage, the lower speed of the torque steps [rad/s,
    /// mechanical]: 30 % of rated.
    pub(super) omega_low_m: f32,
    /// The upper speed of the torque steps [rad/s, mechanical]: 60 % of rated.
    pub(super) omega_high_m: f32,
    /// The spin's acceleration per millisecond [rad/s, mechanical]: rated speed in a second.
    pub(super) accel_per_ms: f32,
    /// The torque steps' PLL and shortest segment (`mechanics.rs`).
    pub(super) tracking: mechanics::Tracking,
}

impl Settings {
    /// From the ratings, the drive's rate and current bandwidth, and the board's sensing.
    pub(super) fn new(
        ratings: &Ratings,
        pole_pairs: f32,
        torque: TorqueConvention,
        rate_hz: f32,
        current_bandwidth_hz: f32,
        cfg: &IdentifyConfig,
    ) -> Self {
        let ts = 1.0 / rate_hz;
        let i = ratings.current_a;
        let rated_m = ratings.speed_rpm * crate::units::RAD_S_PER_RPM;
        let w_c = TAU * current_bandwidth_hz;
        let (omega_low_m, omega_high_m) = (SPIN_SPEED_SHARE * rated_m, 0.6 * rated_m);
        Self {
            i_test_a: i,
            sensable: 2.25 * i <= cfg.sense_range_a && i >= 100.0 * cfg.sense_lsb_a,
            v_phase_rated: ratings.bus_v * crate::math::INV_SQRT3,
            ts,
            w_c,
            w_c_ts: w_c * ts,
            n: pole_pairs,
            torque_factor: torque.factor(),
            n_ts: pole_pairs * ts,
            omega_low_m,
            omega_high_m,
            accel_per_ms: rated_m * 1e-3,
            tracking: mechanics::Tracking::new(pole_pairs, omega_high_m - omega_low_m),
        }
    }
}

/// What a measurement's 1 kHz work decided. (`Next` carries the next measurement's state, the
/// torque steps' 288 bytes with their least squares: no heap to box it in, and it moves once
/// per measurement.)
#[allow(clippy::large_enum_variant)]
pub(super) enum Progress {
    /// Carry on.
    Stay,
    /// The next measurement.
    Next(Phase),
    /// All measured.
    Done,
    /// Stop: the named error.
    Fail(IdentifyError),
}

/// The running measurement and its state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Phase {
    /// `resistance.rs`.
    Resistance(Resistance),
    /// `inductance.rs`.
    Inductance(Inductance),
    /// `flux.rs`.
    Flux(FluxSpin),
    /// `mechanics.rs`.
    Mechanics(Mechanics),
}

/// The current loop's gains re-derived from the identified motor (`kp = L ω_c`,
/// `ki T = R ω_c T`, the decoupling `L` and the flux linkage fed forward); zero until `R` and
/// `L` are known (voltage references meanwhile). On a salient result
/// ([`Identified::salient`]) each axis takes its own inductance, `L_d` on d and `L_q` on q, as
/// the running drive's loop does: the measurements that turn the rotor run in a frame whose d
/// axis is near the rotor's (the spin's current on it, `flux.rs`; the torque steps' frame on
/// the rotor by their PLL, `mechanics.rs`), where one mean inductance on both axes was off by
/// `|L_d − L_q|/2` on each. On AMK's DD5 hub motor (L_q/L_d 2) the decoupling's error
/// `ω_e |L_d − L_q|/2` at the spin's 3,600 rpm was a third of the mean `kp` (0.34 Ω, with
/// `ω_e` = `ω_c` = 1885 rad/s): at the holding current (16 A) the d current swung between
/// −46 and +86 A, the rotor fell out of the spin, and the identification ended in
/// `spin_not_followed` on every seed. (Where `(L_q − L_d) I > ψ_f` at the spin's test current
/// `I`, the rotor rests off the current's axis during the ramp, at `cos δ = ψ_f/((L_q − L_d) I)`,
/// and neither inductance is the frame's there; at the holding current it is aligned.)
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Gains {
    kp: (f32, f32),
    ki_ts: f32,
    l_dq_h: (f32, f32),
    flux_wb: f32,
}

impl Gains {
    /// For the motor identified so far, `k`, at the bandwidth of `s`.
    fn of(s: &Settings, k: &Identified) -> Self {
        let l_dq_h = k.l_dq_h();
        Self {
            kp: (l_dq_h.0 * s.w_c, l_dq_h.1 * s.w_c),
            ki_ts: k.r_ohm * s.w_c_ts,
            l_dq_h,
            flux_wb: k.flux_wb,
        }
    }

    /// `foc` with these gains.
    fn foc(&self, foc: &Foc) -> Foc {
        foc.with_current_gains(self.kp, self.ki_ts, self.l_dq_h, self.flux_wb)
    }
}

/// The state of [`Mode::Identify`](super::Mode::Identify): the measurement running, the
/// results so far and the current loop's gains re-derived from them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Identify {
    pub(super) phase: Phase,
    pub(super) result: Identified,
    pub(super) gains: Gains,
}

impl Identify {
    /// The first measurement.
    pub(super) fn new() -> Self {
        Self {
            phase: Phase::Resistance(Resistance::default()),
            result: Identified::default(),
            gains: Gains::default(),
        }
    }

    /// Which measurement runs.
    pub(super) fn which(&self) -> IdentifyPhase {
        match self.phase {
            Phase::Resistance(_) => IdentifyPhase::Resistance,
            Phase::Inductance(_) => IdentifyPhase::Inductance,
            Phase::Flux(_) => IdentifyPhase::Flux,
            Phase::Mechanics(_) => IdentifyPhase::Mechanics,
        }
    }
}

/// The back-EMF over the period that just ended [V]: `e = v − R i_mid − L (i − i_prev)/T`, the
/// stator equation of the papers' model (Horng & Chin eqs (16), (17)) solved for the EMF, with
/// `v_ab` the voltage applied over the period, `i_mid` the mean of its two current samples.
#[inline(always)]
pub(super) fn back_emf(
    v_ab: AlphaBeta,
    i_ab: AlphaBeta,
    i_prev: AlphaBeta,
    r_ohm: f32,
    l_over_t: f32,
) -> AlphaBeta {
    let half_r = 0.5 * r_ohm;
    AlphaBeta::new(
        v_ab.alpha - half_r * (i_ab.alpha + i_prev.alpha) - l_over_t * (i_ab.alpha - i_prev.alpha),
        v_ab.beta - half_r * (i_ab.beta + i_prev.beta) - l_over_t * (i_ab.beta - i_prev.beta),
    )
}

/// Natural logarithm of a positive normal `x` (f32, no tables): `x = m 2^e`, `m ∈ [1, 2)`,
/// `ln x = e ln 2 + 2 atanh((m − 1)/(m + 1))`, the series to the 11th power (|u| ≤ 1/3:
/// error below 2e-7 relative). For the 1 kHz work only.
pub(super) fn ln(x: f32) -> f32 {
    let bits = x.to_bits();
    let e = ((bits >> 23) & 0xff) as i32 - 127;
    let m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    let u = (m - 1.0) / (m + 1.0);
    let u2 = u * u;
    let series =
        u * (1.0 + u2 * (1.0 / 3.0 + u2 * (0.2 + u2 * (1.0 / 7.0 + u2 * (1.0 / 9.0 + u2 / 11.0)))));
    e as f32 * core::f32::consts::LN_2 + 2.0 * series
}

use super::{
    enter_fault, Drive, DriveInput, DriveState, Fault, ModeState, Reason, StateOf, Transition,
};
use crate::observer::Observer;
use crate::svpwm::Duties;
use core::hint::cold_path;

impl<P: Observer, M: Observer> Drive<P, M> {
    /// Starts the identification from idle (armed): the offsets, then every measurement in
    /// turn, while the enable command stays high (its speed command is not used); `None` and
    /// nothing done in any other mode. Read the results with
    /// [`DriveState::identified`](super::DriveState::identified) once the mode is
    /// `Identified`.
    #[cfg(feature = "identify")]
    pub fn start_identification(&self, st: &mut StateOf<P, M>) -> Option<Transition> {
        if !(matches!(st.mode, ModeState::Idle) && st.arming.armed()) {
            return None;
        }
        *st = DriveState {
            mode: ModeState::Calibrate,
            offsets: st.offsets.for_identification(),
            ..DriveState::default()
        };
        Some(Transition {
            from: super::Mode::Idle,
            to: super::Mode::Calibrate,
            reason: Reason::Identify,
        })
    }

    /// A state in the identification's measurement `phase` at its start, the measurements
    /// before it taken as `known` (a rotor at rest at θ_e = 0; for the flux's spin and the
    /// torque steps, the frame at θ_e = 0 turning at 30 % of rated speed): for benches and
    /// tests that measure one phase's step without running the ones before.
    #[cfg(feature = "identify")]
    pub fn identification_state(&self, phase: IdentifyPhase, known: Identified) -> StateOf<P, M> {
        let s = &self.identify;
        let k = known;
        let phase = match phase {
            IdentifyPhase::Resistance => Phase::Resistance(Resistance::default()),
            IdentifyPhase::Inductance => Phase::Inductance(Inductance::new(
                s,
                AlphaBeta::new(0.5 * k.r_ohm * s.i_test_a, 0.0),
                k.r_ohm,
            )),
            IdentifyPhase::Flux => Phase::Flux(FluxSpin::new(s, &k)),
            IdentifyPhase::Mechanics => Phase::Mechanics(Mechanics::new(
                s,
                &k,
                crate::frames::SinCos::ZERO,
                s.omega_low_m,
                AlphaBeta::default(),
            )),
        };
        let mut id = Identify::new();
        id.gains = Gains::of(s, &k);
        id.phase = phase;
        id.result = k;
        let mut st = DriveState {
            mode: ModeState::Identify,
            identify: id,
            ..DriveState::default()
        };
        // The lowest bus the drive runs on, as if sampled.
        st.last.record_bus(self.limits.bus_min_v);
        st
    }

    /// The step of modes `Idle` (the offsets' watch), `Calibrate` and `Identify`: the duties
    /// and the reason of a mode change.
    #[inline(never)]
    pub(super) fn commissioning(
        &self,
        st: &mut StateOf<P, M>,
        input: &DriveInput,
    ) -> (Option<Duties>, Option<Reason>) {
        match st.mode {
            ModeState::Idle => {
                self.watch_offset(st, input);
                (None, None)
            }
            #[cfg(feature = "identify")]
            ModeState::Calibrate => (None, self.calibrate(st, input)),
            #[cfg(feature = "identify")]
            ModeState::Identify => self.identify_control(st, input),
            // Without the feature `identify` its modes are never entered.
            #[cfg(not(feature = "identify"))]
            ModeState::Calibrate | ModeState::Identify => (None, None),
            // Not commissioning: `Drive::step` does not call this in these modes.
            ModeState::Catch(_)
            | ModeState::CatchZero(_)
            | ModeState::Align(_)
            | ModeState::OpenLoop(_)
            | ModeState::Sensorless(_)
            | ModeState::Fault(_)
            | ModeState::Identified => (None, None),
            #[cfg(feature = "injection")]
            ModeState::Inject => (None, None),
        }
    }

    /// Mode `Calibrate`'s step (PWM off): the sample summed; at the end the offsets kept and
    /// the identification entered, or the offset fault.
    #[inline(always)]
    #[cfg(feature = "identify")]
    pub(super) fn calibrate(&self, st: &mut StateOf<P, M>, input: &DriveInput) -> Option<Reason> {
        let plausible = st
            .offsets
            .calibrated(input.i_abc, self.identify_offset_limit_a)?;
        cold_path();
        if !plausible {
            return Some(enter_fault(st, Fault::AdcOffset));
        }
        st.last.record_bus(input.v_bus);
        if !self.identify.sensable {
            return Some(enter_fault(
                st,
                Fault::Identify(IdentifyError::CurrentNotSensable),
            ));
        }
        st.mode = ModeState::Identify;
        // Field by field: the whole of `Identify::new()` moved in is a copy of the largest
        // measurement's state (the torque steps', `mechanics.rs`): 220 cycles more.
        st.identify.phase = Phase::Resistance(Resistance::default());
        st.identify.result = Identified::default();
        st.identify.gains = Gains::default();
        Some(Reason::Calibrated)
    }

    /// While idle (PWM off): the sample summed into the offsets' window; each full window
    /// renews the offsets the next enable takes (or marks them implausible).
    #[inline(always)]
    pub(super) fn watch_offset(&self, st: &mut StateOf<P, M>, input: &DriveInput) {
        (st.offsets).watch(input.i_abc, self.identify_offset_limit_a);
    }

    /// Mode `Identify`'s step: the measurement's request through its FOC (no observers run).
    #[inline(always)]
    #[cfg(feature = "identify")]
    pub(super) fn identify_control(
        &self,
        st: &mut StateOf<P, M>,
        input: &DriveInput,
    ) -> (Option<Duties>, Option<Reason>) {
        let i_raw = input.i_abc.to_alpha_beta();
        let offset_ab = st.offsets.ab();
        let i_ab = AlphaBeta::new(i_raw.alpha - offset_ab.alpha, i_raw.beta - offset_ab.beta);
        st.i_ab_last = i_ab;
        let id = &mut st.identify;
        let v_last = st.last.v_ab();
        let v_bus_last = st.last.v_bus();
        let dt = self.foc.dead_time();
        let request = match &mut id.phase {
            Phase::Resistance(r) => {
                let (request, v_dir) = r.step(i_ab);
                hold_signs(request, dt, v_dir, i_ab, input.v_bus)
            }
            Phase::Inductance(l) => {
                let (request, v_dir) = l.step(i_ab);
                hold_signs(request, dt, v_dir, i_ab, input.v_bus)
            }
            Phase::Flux(f) => f.step(i_ab, v_last, dt, v_bus_last),
            Phase::Mechanics(m) => m.step(i_ab, v_last, dt, v_bus_last, self.identify.n),
        };
        // (The vector cut along itself: no field weakening in the tests, `Foc::run_cut_along`.)
        let out =
            id.gains
                .foc(&self.foc)
                .run_cut_along(&mut st.current, &request, i_ab, input.v_bus);
        st.last
            .record_voltage(out.v_ab, input.v_bus, self.delay_periods);
        (Some(out.duties), None)
    }

    /// Mode `Identify`'s 1 kHz work: the measurement's decisions; the next measurement, the
    /// results, or the named error.
    #[inline(never)]
    #[cfg(feature = "identify")]
    pub(super) fn identify_tick(&self, st: &mut StateOf<P, M>) -> Option<Transition> {
        let v_max = self.foc.v_max(st.last.v_bus());
        let id = &mut st.identify;
        let s = &self.identify;
        let result = &mut id.result;
        let progress = match &mut id.phase {
            Phase::Resistance(r) => r.tick(s, v_max, result),
            Phase::Inductance(l) => l.tick(s, v_max, result),
            Phase::Flux(f) => f.tick(s, &self.foc, result),
            Phase::Mechanics(m) => m.tick(s, &self.foc, result),
        };
        let (to, reason) = match progress {
            Progress::Stay => return None,
            Progress::Next(phase) => {
                cold_path();
                // The current loop from what is known now; its integrators from zero.
                id.gains = Gains::of(s, &id.result);
                id.phase = phase;
                st.current = Default::default();
                return None;
            }
            Progress::Done => {
                st.mode = ModeState::Identified;
                (super::Mode::Identified, Reason::Identified)
            }
            Progress::Fail(e) => (super::Mode::Fault, enter_fault(st, Fault::Identify(e))),
        };
        Some(Transition {
            from: super::Mode::Identify,
            to,
            reason,
        })
    }
}
