//! The drive's own motor model: stator resistance `R` and magnet flux linkage `ψ_f`, adapted
//! online and bounded, for the observers.
//!
//! - **R at every start, at standstill** (`align.rs`): the rotor held by a d-axis current at
//!   two levels, `R = (v₂ − v₁)/(i₂ − i₁)`. The difference cancels what does not scale with
//!   the current: the inverter's dead-time voltage (what its compensation leaves) and the
//!   current sensors' offsets. The standstill DC test of drive self-commissioning (e.g.
//!   Khambadkone & Holtz, "Vector-controlled induction motor drive with a self-commissioning
//!   scheme", IEEE Trans. Ind. Electron. 38(5), 1991; ST's motor profiler), run before each
//!   open-loop start so that a warm winding's resistance is the one the start uses.
//! - **ψ_f and R while running** (sensorless control's 1 kHz task keeps its operating point,
//!   [`Drive::background`](super::Drive::background) checks it after the task): the back-EMF's length,
//!   `|ω_e| ψ_f = |v − R i − jω_e L i|` (stator equation in steady state, the current turning
//!   at ω_e). The length does not depend on the estimated angle, so an angle error does not
//!   bias it. One equation, two unknowns: each is taken where the other's error moves it
//!   little, the split of Piippo, Hinkkanen & Luomi, "Adaptation of motor parameters in
//!   sensorless PMSM drives", IEEE Trans. Ind. Appl. 45(1), 2009 (ψ_f at high speed, R at low
//!   speed), both low-pass filtered:
//!   - ψ_f where `R |i_q|` is at most [`Settings::flux_max_r_share`] of the back-EMF
//!     `ψ_f ω_e` (the model's R and ψ_f, the commanded torque current: fast and lightly
//!     loaded): an `R` error `δR` moves it by `δR |i_q|/ω_e`, that share of `δR/R`.
//!   - R where `R |i_q|` is at least 0.6 of the back-EMF (share `k` = [`R_MIN_SHARE`]: slow and
//!     loaded), above ψ_f's lowest speed (a tenth of rated, the default hand-over speed:
//!     below it the observers' speed, and with it `|ω_e| ψ_f`, is not sound): the root of
//!     `|u − R i| = |ω_e| ψ_f`, `u = v − jω_e L i`, nearest the model's, by one Newton step
//!     from it, `R + (|e| − |ω_e| ψ_f) |e|/(e·i)`, where the current's angle φ to `e` has
//!     `|cos φ| ≥ ½` (braking too: `e·i < 0`).
//!
//!     **Its margin.** A flux linkage off by `δψ/ψ` moves it by `(ψ ω_e/(R |i| |cos φ|)) δψ/ψ`,
//!     at most `2 δψ/ψ / k`; a speed estimate off by `δω/ω` likewise. A voltage error `δv`
//!     along the current by `δv/|i|`: the dead-time compensation's residual, up to the
//!     dead-time voltage `V_dt` where a phase current crosses zero inside its band, at most
//!     `V_dt/(k ψ ω_e)` of R in one sample (at a tenth of rated speed the back-EMF is about a
//!     twentieth of the bus and `V_dt = (4/π) t_d f_pwm V_bus` an eightieth at the board's
//!     0.5 µs and 20 kHz: a quarter of R at the instant a phase crosses zero; its mean over
//!     the electrical period, which the 0.25 s filter takes, is far less, as measured below
//!     with the board's dead time); the applied voltage's timing error ε (rad) by
//!     `ε ω_e L |i|/|i|`, `ε ω_e L`, small against R at these speeds.
//!
//!     Measured on the simulated board, R × 1.5 over 2 s under 90 % of the rated torque at 15 % of
//!     rated speed (`host-sim/tests/warm_winding.rs`): R̂ within 0.6 % of the plant's on the Sinano
//!     motor, 3.5 % on eight identified zoo motors; the model keeping the start's R, every one of
//!     those runs lost its observers. Below the hand-over speed the speed estimate, and with it
//!     `|ω_e| ψ_f`, is not sound: taken down to standstill (and from half the back-EMF), R walked
//!     4 % off on the zoo's 60 mm servo at 3 % of rated speed and its observers lost the rotor; 64
//!     of the zoo matrix's 960 cells, the low-speed profiles, failed so. Between the two ranges
//!     neither moves. The copper's temperature follows from R (`units::winding_rise_k`, from the
//!     telemetry's `r_ohm`).
//!
//! Both stay within bounds around the configured values ([`Settings`]): a measurement beyond
//! them is refused, so no disturbance walks the model away.
//!
//! **A start's resistance that is not taken is reported, never dropped silently.** The
//! alignment's measurement (`align.rs`) comes to one of three ends:
//! - `R` within `R₀/3 ..= 3 R₀` (`config.rs`: a copper winding from −40 °C to 150 °C spans
//!   1.75×, a datasheet's line-to-line figure taken for the phase's is 2× off): taken; the
//!   transition `Align → OpenLoop` says [`Reason::Aligned`](super::Reason::Aligned).
//! - `R` beyond that range, or none (the rotor not at rest): refused, the model kept, the start
//!   goes on, and the transition says
//!   [`Reason::ResistanceRefused`](super::Reason::ResistanceRefused); the state holds what was
//!   measured and the range
//!   ([`DriveState::resistance_refused`](super::DriveState::resistance_refused)) from then on, for
//!   the log, until an alignment's measurement is taken. (Not in the transition: a payload in
//!   `Reason`, 8 bytes or more instead of 1, costs every step 12 to 15 cycles on the emulated
//!   Cortex-M4F, measured; nor in the telemetry record, at its 64 bytes.) A warning, not a fault:
//!   the current followed its reference, so the winding carries current, and the start is
//!   current-controlled (alignment, I/f open loop): it makes its torque whatever `R`. `R` enters
//!   only the observers, whose error from it grows as the speed falls (`R i` against the back-EMF);
//!   whether the motor runs on the kept model is the supervision's to judge on the observers' own
//!   evidence (health, stall and loss faults, `supervision.rs`). The drive cannot tell a disturbed
//!   measurement (a load moving the rotor within the at-rest bound, a bus sag between the levels)
//!   from a motor file that is wrong, and the configured value is the one its gains and limits were
//!   validated with. Drives that re-measure `R_s` at each start (TI InstaSPIN-FOC's `R_s`
//!   recalibration) update a configured model so, and Piippo, Hinkkanen & Luomi bound the adapted
//!   parameters likewise; a value out of range *at commissioning*, where no model exists to fall
//!   back on, is an error instead (ODrive's calibration, `ERROR_PHASE_RESISTANCE_OUT_OF_RANGE`;
//!   this drive's `IdentifyError::ResistanceOutOfRange`). On the simulated board
//!   (`host-sim/tests/start_resistance.rs`, 1 s at half the rated speed), the motor file's `R` a
//!   fifth of the plant's, or the plant's a quarter of the file's: some starts run on, the others
//!   end in the supervision's `Stall` or `ObserverLoss`.
//! - The current did not follow its reference (less than half the level step on the d axis,
//!   or a mean q current beyond a quarter of the alignment's where none was asked): the start
//!   is refused with [`Fault::OpenWinding`](super::Fault::OpenWinding), PWM off. No number
//!   came out: the winding does not carry the current. A phase or the motor not connected (an
//!   open phase b or c lets the current flow only along the line of the other two, 30° off
//!   the d axis), or a resistance the bus cannot drive the alignment's current through. An
//!   open loop on it cannot make its torque: on the simulated board, running on ended in
//!   `Stall` at the open loop's time limit, or in an `Overcurrent` trip when the wound-up
//!   current loop met a direction that conducts (Ortega's test motor). This is the usual
//!   open-phase diagnosis, the phase current departing from the reference the controller
//!   drives it to (the identification tells an open phase by the conductance in two
//!   directions, `IdentifyError::OpenPhase`). A short between terminals is the over-current
//!   trip's; a winding shorted to its star point reads `R/3` along its axis, which one axis
//!   cannot tell from a smaller winding (the identification's conductance check names it):
//!   refused and reported if beyond the range, like any other value.
//!
//! **How the observers take the model.** The observers keep the configured model
//! (`R₀`, `ψ₀`, their coefficients precomputed, the papers' equations unchanged). The stator
//! equation `v = R i + L di/dt + e(ψ_f)` is linear in `(v, i, ψ_f)`: the motor with
//! `(R, ψ_f)` measured as `i' = s i`, `v' = s (v − (R − R₀) i)` with `s = ψ₀/ψ_f` is the
//! configured one. The drive hands the observers `(i', v')`. Their angle and speed are the
//! motor's; a torque in their units is `s²` times the motor's ([`Model::torque_from_observer`]).

use super::io::ResistanceRefused;
use crate::frames::AlphaBeta;
use crate::math::{clamp, sqrt_or_zero};

/// R is measured while running where `R |i_q|` is at least this share `k` of the back-EMF
/// `ψ_f ω_e` (the model's R and ψ_f; module doc): a flux linkage off by `δ` moves it by `2δ/k`
/// = 3.3 δ at most (ψ_f adapted within 1–3 % on most of the zoo's motors). At 1, three zoo
/// motors whose drop is 0.9 of the back-EMF at 15 % of rated speed under 90 % of rated torque
/// (the hoverboard hub, both Anaheim motors) were not tracked and lost their observers as
/// their windings warmed (`warm-winding-loaded`); at 0.8 the T-motor drone motor (a drop of
/// 0.66 there) was not, and lost them too; at 0.6 it is tracked, R̂ −3.5 % with its ψ_f
/// +3.3 %. At 0.5, before ψ_f's dead-time lag was taken off ([`Settings::track`]), the Nanotec
/// DF45 under field weakening took R 3 % low (its ψ_f +1.1 % over a share of 0.66) and lost
/// them; at 0.6 with it, the zoo matrix's 960 cells give the same verdicts as at 0.8.
pub(super) const R_MIN_SHARE: f32 = 0.6;

/// The adaptation's settings (from the configured motor).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// Configured resistance R₀ \[Ω] and flux linkage ψ₀ \[Wb].
    pub(super) r0_ohm: f32,
    pub(super) flux0_wb: f32,
    /// Accepted ranges \[Ω], \[Wb].
    pub(super) r_range: (f32, f32),
    pub(super) flux_range: (f32, f32),
    /// Inductance \[H], pole pairs.
    pub(super) l_h: f32,
    pub(super) pole_pairs: f32,
    /// Half a step period \[s]: the applied voltage is that of the period's middle.
    pub(super) half_ts: f32,
    /// ψ_f's and R's low-pass gain per 1 kHz check, `T/τ`.
    pub(super) gain: f32,
    /// ψ_f or R is taken once the operating point has been inside its range this many checks
    /// running, and from then on while it stays.
    pub(super) steady_checks: u16,
    /// ψ_f is measured above this electrical speed \[rad/s] ...
    pub(super) flux_min_omega_e: f32,
    /// ... where `R |i_q|` (R's first-order part of `|e|`, the model's R) is at most this
    /// fraction of the back-EMF `ψ_f ω_e` ...
    pub(super) flux_max_r_share: f32,
    /// ... and `|i_q|` at most this \[A]: `ω_e L_q |i_q|` the same fraction of it (the same
    /// share of `ψ₀ ω_e`: `flux_max_r_share ψ₀/L_q`). That term is at right angles to the
    /// back-EMF, so a voltage turned by `ε` (a timing error of the applied voltage against the
    /// sampled current: at 0.27 rad per period, a fraction of a period is tenths of a radian)
    /// moves `|e|` by `ε ω_e L_q |i_q|`: measured, the Caruso IPM's non-salient twin under its
    /// rated torque at rated speed, `ω_e L i_q` 0.8 of the back-EMF, walked ψ_f 18 % down in
    /// 0.5 s with its angle within 3°, and the residual that followed faulted `observer_loss`.
    pub(super) flux_max_i_q_a: f32,
    /// The inverter's dead-time voltage, its fundamental `(4/π) t_d f_pwm V_bus` at the rated
    /// bus \[V], and the current vector \[A] below which its compensation does not know its
    /// sign: sensorless control's held d current
    /// ([`DriveConfig::low_speed_hold`](super::DriveConfig::low_speed_hold), twice the
    /// compensation's band). There a measurement is `ψ_f` within
    /// `± dead_time_v/ω_e` only, and moves the model only as far as it proves it wrong by more
    /// ([`Settings::track`]).
    pub(super) flux_dead_time_v: f32,
    pub(super) flux_dead_time_i_a: f32,
}

/// Which parameter a 1 kHz check's operating point measures (module doc).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
enum Measures {
    /// Neither: below ψ_f's lowest speed, or between the two ranges.
    #[default]
    None,
    /// ψ_f: fast and lightly loaded.
    Flux,
    /// R: slow and loaded.
    Resistance,
}

/// The adapted model and the observers' input transform; `Default` is unset (the drive
/// starts it at the configured values, [`Settings::ensure`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Model {
    /// Stator resistance \[Ω].
    pub(super) r_ohm: f32,
    /// Magnet flux linkage \[Wb].
    pub(super) flux_wb: f32,
    /// `s = ψ₀/ψ_f`.
    scale: f32,
    /// `s (R − R₀)` \[Ω].
    scaled_dr_ohm: f32,
    /// Consecutive 1 kHz checks inside `range`.
    steady_checks: u16,
    /// The operating range of the last check.
    range: Measures,
    /// The last task's operating point, for the check after it ([`Settings::track_kept`]).
    pending: Option<Pending>,
}

/// One 1 kHz task's operating point for the check of [`Settings::track`]: the task keeps it,
/// [`Drive::background`](super::Drive::background) checks it before the next step (a square
/// root and up to three divisions off the task's budget; `pmsm-sim cycles` measures it after
/// the task), so the model moves as the task's own check moved it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Pending {
    /// The current sampled \[A] and the voltage of the period that starts with it \[V].
    pub(super) sample: (AlphaBeta, AlphaBeta),
    /// The driving observer's speed [rad/s, mechanical].
    pub(super) omega_m: f32,
    /// The q current commanded \[A].
    pub(super) i_q_ref_a: f32,
}

impl Model {
    /// The observers' inputs `(i', v')` from the measured current `i_ab` \[A] and the applied
    /// voltage `v_ab` \[V] (see the module's doc).
    #[inline(always)]
    pub(super) fn observer_input(
        &self,
        i_ab: AlphaBeta,
        v_ab: AlphaBeta,
    ) -> (AlphaBeta, AlphaBeta) {
        let (s, dr) = (self.scale, self.scaled_dr_ohm);
        (
            AlphaBeta::new(s * i_ab.alpha, s * i_ab.beta),
            AlphaBeta::new(
                s * v_ab.alpha - dr * i_ab.alpha,
                s * v_ab.beta - dr * i_ab.beta,
            ),
        )
    }

    /// A motor torque \[N·m] in the observers' units.
    #[inline(always)]
    pub(super) fn torque_to_observer(&self, torque_nm: f32) -> f32 {
        torque_nm * self.scale * self.scale
    }

    /// An observer's torque estimate in the motor's \[N·m].
    #[inline(always)]
    pub(super) fn torque_from_observer(&self, torque_nm: f32) -> f32 {
        torque_nm / (self.scale * self.scale)
    }

    /// Keeps the task's operating point for the check after it (see [`Pending`]).
    #[inline(always)]
    pub(super) fn keep(&mut self, pending: Pending) {
        self.pending = Some(pending);
    }

    /// Drops an operating point a task kept and no check took (a caller that ran no
    /// [`Drive::background`](super::Drive::background) after it): a task's point is checked
    /// after that task or not at all, never after later steps.
    #[inline(always)]
    pub(super) fn drop_kept(&mut self) {
        self.pending = None;
    }
}

impl Settings {
    /// The check of the operating point the last task kept, if any ([`Settings::track`]).
    pub(super) fn track_kept(&self, m: &mut Model) {
        if let Some(p) = m.pending.take() {
            self.track(m, p.sample, p.omega_m, p.i_q_ref_a);
        }
    }

    /// For the cycle bench: `m` kept steady in ψ_f's range and an operating point that
    /// measures it at twice ψ_f's lowest speed, with no current (inside the dead-time band:
    /// the band's division too) and the model's back-EMF: [`Settings::track_kept`]'s costliest
    /// path (a square root, three divisions).
    pub(super) fn bench_worst(&self, m: &mut Model) {
        let omega_e = 2.0 * self.flux_min_omega_e;
        m.range = Measures::Flux;
        m.steady_checks = self.steady_checks;
        m.keep(Pending {
            sample: (
                AlphaBeta::default(),
                AlphaBeta::new(0.0, omega_e * m.flux_wb),
            ),
            omega_m: omega_e / self.pole_pairs,
            i_q_ref_a: 0.0,
        });
    }

    /// Sets the configured model into `m` if it has never been set.
    pub(super) fn ensure(&self, m: &mut Model) {
        if m.scale.is_nan() || m.scale <= 0.0 {
            self.set(m, self.r0_ohm, self.flux0_wb);
        }
    }

    /// `m` at `r_ohm`, `flux_wb`, with its input transform.
    fn set(&self, m: &mut Model, r_ohm: f32, flux_wb: f32) {
        m.r_ohm = r_ohm;
        m.flux_wb = flux_wb;
        m.scale = self.flux0_wb / flux_wb;
        m.scaled_dr_ohm = m.scale * (r_ohm - self.r0_ohm);
    }

    /// Takes a standstill measurement of R \[Ω] (`align.rs`; `None`: the rotor was not at
    /// rest, nothing measured). One beyond the range (a disturbed or impossible measurement,
    /// or a motor unlike its configuration) is refused, the model kept, and the refusal
    /// returned for the log (module doc).
    pub(super) fn take_resistance(
        &self,
        m: &mut Model,
        r_ohm: Option<f32>,
    ) -> Result<(), ResistanceRefused> {
        let (lo, hi) = self.r_range;
        match r_ohm {
            // (false for NaN)
            Some(r) if r >= lo && r <= hi => {
                self.set(m, r, m.flux_wb);
                Ok(())
            }
            measured_ohm => Err(ResistanceRefused {
                measured_ohm,
                min_ohm: lo,
                max_ohm: hi,
            }),
        }
    }

    /// One 1 kHz check of ψ_f or R in steady running (module doc): `i_ab` the current sampled
    /// now \[A], `v_ab` the voltage of the period that starts with it \[V] (the one the last
    /// step computed, `LastPeriod`: the 1 kHz task runs after the step), `omega_m` the speed
    /// [rad/s, mechanical], `i_q_ref_a` the q current commanded \[A] (R's error moves `|e|` by
    /// itself times the current along the back-EMF, to first order; a d current, at right
    /// angles to it, only to second order). Outside the operating ranges where they are
    /// measured, the model stays. The samples are taken only after the operating point has
    /// stayed in one range for [`Settings::steady_checks`] running, never picked one by one: a
    /// ripple (an offset's, at the electrical frequency, which the speed loop answers) that
    /// moved a sample in and out of range would choose which are taken, and bias their mean
    /// (measured: −5 % with a 2 % offset under load).
    #[inline(always)]
    fn track(
        &self,
        m: &mut Model,
        (i_ab, v_ab): (AlphaBeta, AlphaBeta),
        omega_m: f32,
        i_q_ref_a: f32,
    ) {
        let omega_e = self.pole_pairs * omega_m;
        let w = omega_e.abs();
        let i_q = i_q_ref_a.abs();
        let (r_drop, emf) = (m.r_ohm * i_q, m.flux_wb * w);
        let measures = if w < self.flux_min_omega_e {
            Measures::None
        } else if r_drop <= self.flux_max_r_share * emf && i_q <= self.flux_max_i_q_a {
            Measures::Flux
        } else if r_drop >= R_MIN_SHARE * emf {
            Measures::Resistance
        } else {
            Measures::None
        };
        // (A change of range restarts the count: from R's to ψ_f's, the current may still be
        // settling.)
        m.steady_checks = match measures {
            Measures::None => 0,
            _ if measures == m.range => m.steady_checks.saturating_add(1),
            _ => 1,
        };
        m.range = measures;
        if m.steady_checks < self.steady_checks {
            return;
        }
        let i2 = i_ab.alpha * i_ab.alpha + i_ab.beta * i_ab.beta;
        // The period's mean voltage at the sample: the period's middle is half a period
        // after the sample, and a vector turning at ω_e averages over a period to
        // sinc x = sin x/x of its length at the middle, x = ω_e T/2. Under steady sinusoidal
        // running, the mean turned back by x and divided by sinc x is `R i + jω_e L i + e` at
        // the sample: (c, s) = (x cot x, −x), x cot x ≈ 1 − x²/3 − x⁴/45 (error 1.3e-4 at
        // x = 0.63 rad, the T-motor drone motor at rated speed, 5 samples per electrical
        // period; 20 samples give 0.16 rad). Turned forward by x without the sinc (the
        // period taken as the one ending at the sample), that motor's ψ_f came out 10 % low
        // under load and it lost its observers. Not `SinCos::of_small`: its higher terms and
        // its fallback cost flash the commissioning firmware does not have.
        let x = omega_e * self.half_ts;
        let x2 = x * x;
        let (c, s) = (1.0 - x2 * (1.0 / 3.0 + x2 * (1.0 / 45.0)), -x);
        let v = AlphaBeta::new(
            c * v_ab.alpha - s * v_ab.beta,
            s * v_ab.alpha + c * v_ab.beta,
        );
        // e = v − R i − jω_e L i.
        let wl = omega_e * self.l_h;
        let e = AlphaBeta::new(
            v.alpha - m.r_ohm * i_ab.alpha + wl * i_ab.beta,
            v.beta - m.r_ohm * i_ab.beta - wl * i_ab.alpha,
        );
        let e2 = e.alpha * e.alpha + e.beta * e.beta;
        let e_len = sqrt_or_zero(e2);
        if measures == Measures::Resistance {
            // The root of |u − R i| = |ω_e| ψ_f nearest the model's R, one Newton step from
            // it: d|e|/dR = −(e·i)/|e|. Only where the current has a part along e (|cos| ≥ ½):
            // at right angles, R does not move |e| to first order.
            let e_dot_i = e.alpha * i_ab.alpha + e.beta * i_ab.beta;
            let measured = m.r_ohm + (e_len - w * m.flux_wb) * e_len / e_dot_i;
            let (lo, hi) = self.r_range;
            if e_dot_i * e_dot_i >= 0.25 * e2 * i2 && measured >= lo && measured <= hi {
                let r = m.r_ohm + self.gain * (measured - m.r_ohm);
                self.set(m, r, m.flux_wb);
            }
            return;
        }
        let measured = e_len / w;
        // With the phase currents inside the dead-time compensation's band, the inverter's
        // error voltage, of unknown sign there, is up to `dead_time_v` of `|e|`: the
        // measurement is a band `measured ± u`, u = dead_time_v/ω_e, and the model moves only
        // to its nearer edge (a model inside it stays). The gimbal motor unloaded, slowing
        // through 150–30 rpm (0.26 V against 1–3 V of back-EMF), walked ψ_f 6–10 % low and lost
        // its observers through zero; a model 15 % off (the robustness matrix's ψ_f × 0.85 on
        // the Sinano motor) is still pulled in.
        // Beyond the band the compensation's signs lag the phase currents by half a step, so
        // each zero crossing leaves a pulse whose fundamental, `dead_time_v ω_e T/2`, lies
        // along the back-EMF (`identify/inverter.rs`, the same inverter): `ψ_f` measured
        // `dead_time_v T/2` high on every motor, taken off (the T-motor drone motor, 1.7 %
        // of its ψ_f: adapted +3.1 % before at half rated speed, +1.4 % after; the zoo
        // matrix's median adapted error 0.9 → 0.2 % on the Delta servo, 0.6 → 0.3 % on the
        // maxon).
        let (measured, u) = if i2 < self.flux_dead_time_i_a * self.flux_dead_time_i_a {
            (measured, self.flux_dead_time_v / w)
        } else {
            (measured - self.flux_dead_time_v * self.half_ts, 0.0)
        };
        let target = clamp(m.flux_wb, measured - u, measured + u);
        let (lo, hi) = self.flux_range;
        if measured >= lo && measured <= hi {
            let flux = m.flux_wb + self.gain * (target - m.flux_wb);
            self.set(m, m.r_ohm, flux);
        }
    }
}
