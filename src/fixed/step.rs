//! The fixed-point control step (issue #30): the blocks of [`crate::fixed`] assembled into one
//! call per control period, [`FixedDrive::step`], taking the sampled phase currents and bus in
//! per unit (the ADC's counts scaled once, [`FixedInput`]) and returning the three duties, or
//! `None` with the PWM off; and its 1 kHz task, [`FixedDrive::tick`] (the PLL, the speed loop,
//! the monitor's check), in fixed point too.
//!
//! It runs the sensorless running mode only: the start (alignment, I/f, the hand-over) is the
//! f32 drive's, and [`FixedDrive::seed`] takes the rotor over from it (as
//! [`crate::drive::Drive::running_state`] does for the f32 drive). The f32 drive stays the
//! reference: `tests/fixed_step.rs` runs the two side by side on the plant.
//!
//! One step, in the order of the f32 [`crate::drive::Drive::step`]:
//! 1. input checks: a phase current at or beyond the sensing range's clip (`±1` pu: the ADC
//!    saturated, no reading) is `Fault::InvalidInput`, beyond the trip level
//!    `Fault::Overcurrent`; the bus beyond its limits `Fault::BusOvervoltage` /
//!    `Fault::BusUndervoltage`; the phase sum beyond the f32 drive's bound for four samples
//!    (the f32 `plausibility.rs` count) `Fault::CurrentSensor`; the 1 kHz task not run for
//!    `TICKS_MISSED_MAX` task periods `Fault::TaskStall`. A fault latches the safe state (PWM
//!    off) until [`FixedDrive::seed`] starts again; no input panics the step;
//! 2. both observers on this sample (the three-phase Clarke of the currents, the f32 drive's:
//!    an offset left in one sensor is a zero sequence, discarded): Ortega et al.'s flux
//!    observer eq (9) (the primary, its angle `η̂/|η̂|`, Sec V iii) and Horng & Chin's sliding
//!    torque observer eqs (20)-(22), (34), (35) (the monitor), each fed the voltage applied
//!    over the period that ended; the PLL here where the rotor turns too far per task period
//!    for it (below);
//! 3. the current loop on the flux observer's frame (Ortega Sec V iv with the dq model (3):
//!    PI, decoupling `−ω_e L i_q`, `ω_e L i_d`, back-EMF `ω_e ψ_f` fed forward), the voltage
//!    cut to the circle the bus allows;
//! 4. the output at the angle the voltage is applied at (the frame turned by the speed's lead
//!    over half a period and the update delay, as [`crate::foc::Foc::output_rotation`]), the
//!    dead time compensated (Choi & Sul's average-voltage compensation,
//!    [`crate::dead_time`]), SVPWM ([`super::svpwm::svpwm_limited_q15`]).
//!
//! The task: the PLL on the flux observer's angle (Ortega Sec V iii: its phase detector the
//! cross product `sin(θ̂ − z1)` of the two unit vectors, taken as the angle: exact to
//! `e³/6`, 10⁻⁵ rad at 2°; in the step instead where 1.5 times the rated speed turns the rotor
//! half a turn per task period, the most the PLL's `Δ` holds), the output lead at the new
//! speed, the speed reference slewed as the f32 ramp, the speed loop's load observer
//! ([`crate::load_observer`]) fed forward and the speed PI (the f32 `Pi::update_within`
//! without its held directions) to the q current; the monitor's disagreement with the primary
//! above the sliding observer's lowest speed (the hand-over speed, Horng & Chin Sec 5) for the
//! loss time is a strike and re-seeds the monitor from the primary, the third strike within a
//! run of agreement `Fault::ObserverLoss` (the f32 supervision's contradiction; the f32 drive
//! re-seeds the observer whose residual is the larger and may drive on the monitor, this one
//! always drives on the flux observer).
//!
//! Not in it (the f32 drive has them): field weakening and MTPA (a salient motor is refused),
//! the hand-back to open loop and the stop at zero, over-speed and stall, the observers'
//! failover, the model's adaptation (the take-over hands over the f32 drive's adapted model:
//! [`FixedDrive::build_in`]).
//!
//! Formats: the bases of [`PerUnit`] (currents of `I_b`, voltages of `V_b`, speeds of `ω_b`);
//! the bus in Q15 of twice the highest bus ([`FixedDrive::bus_base_v`]); duties Q15 unsigned.
//! No division, no f32 on the step or the task (f32 at build and seed only).

use super::current::{CurrentLoopQ, CurrentLoopStateQ};
use super::flux::{FluxObserverQ, FluxStateQ};
use super::pll::{PllQ, PllStateQ};
use super::pu::{Gain, PerUnit};
use super::sliding::{Coef, SlidingObserverQ, SlidingStateQ};
use super::svpwm::{svpwm_limited_q15, DutiesQ15};
use super::{sat_q15, AbcQ15, AlphaBetaQ15, Angle, DqQ15, Q15};
use crate::drive::{DriveConfig, Fault};
use crate::param::{Allowed, ParamError};
use core::hint::cold_path;

/// `2³²/(2π)/2¹⁵`: a Q15 sine (the small-angle error) to angle units, rounded.
const SIN_TO_ANGLE: i32 = 20_861;

/// √3/2 in Q15, rounded.
const SQRT3_OVER_2_Q15: i32 = 28_378;

/// `1/(2√3)` in Q15 (0.288 675 × 32 768 = 9 459.3): the bus scale's constant.
const INV_2_SQRT3_Q15: i32 = 9_459;

/// Phase-sum checks in a row (with a count down per good one) before a current sensor is
/// judged failed (the f32 `plausibility::SUM_COUNT_MAX`).
const SUM_COUNT_MAX: u8 = 4;

/// One sample in per unit (the ADC's counts scaled by the board once: a gain and an offset).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FixedInput {
    /// The three phase currents, Q15 of `I_b` (the sensing range: ±32 767 is the ADC's
    /// clip).
    pub i_abc: AbcQ15,
    /// The bus, Q15 of [`FixedDrive::bus_base_v`] (twice the highest bus the drive accepts).
    pub v_bus: Q15,
}

/// The step's result.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FixedOutput {
    /// The duties, or `None`: PWM off (the safe state while faulted).
    pub duties: Option<DutiesQ15>,
    /// The fault found in this very step.
    pub fault: Option<Fault>,
}

/// The fixed-point drive's settings: the blocks and every coefficient, built once from the
/// f32 drive's configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FixedDrive {
    pu: PerUnit,
    flux: FluxObserverQ,
    /// The monitor, where the f32 drive judges its sliding observer and its settings have a
    /// fixed-point form (else the flux observer runs alone, as the f32 drive's does).
    sliding: Option<SlidingObserverQ>,
    pll: PllQ,
    current: CurrentLoopQ,
    /// `I_trip` in Q15 of `I_b`.
    i_trip: i32,
    /// The phase sum's bound, Q15 of `I_b`.
    i_sum_max: i32,
    /// The bus limits, Q15 of the bus base.
    bus_min: i32,
    bus_max: i32,
    /// The bus (Q15 of its base) to the current loop's `v_max` (Q15 of `V_b`):
    /// `2√3 · v_max_per_bus`.
    v_max_of_bus: Gain,
    /// A phase current (Q15 of `I_b`) to its smoothed sign in Q15: `I_b/band`.
    dt_sign: Gain,
    /// The compensation per unit sign, Q15 of the bus: `t_d f_pwm/3 · 2` (on half sums).
    dt_u: Gain,
    /// The update delay `δ` in periods (0..1): the observers' voltage `v + δ (v_prev − v)`.
    delay: Gain,
    delayed: bool,
    /// The output lead: `Δ` (angle units per task period) `>> lead_shift` to the lead in
    /// angle units (`advance/steps · 2^lead_shift`).
    lead: Gain,
    lead_shift: u32,
    /// The PLL runs in the step (else in the task).
    pll_in_step: bool,
    /// Strikes of the monitor's disagreement (each re-seeds it) before `Fault::ObserverLoss`,
    /// and the tasks of agreement that clear them (the f32 supervision's: 3, and ten loss
    /// times).
    strikes_max: u8,
    /// `R I_b/V_b`: the current loop's steady-state integrator at a seed (configuration).
    r_pu: f32,
    /// The speed PI: error (Q15 of `ω_b`) to current (Q15 of `I_b`), and to the integrator's
    /// increment (Q31 of `I_b`).
    speed_kp: Gain,
    speed_ki: Gain,
    /// The speed loop's load observer ([`crate::load_observer`], the f32 drive's
    /// feed-forward) on its estimate `τ̂_L/K_t` (in current units), not on the f32 state
    /// `z = τ̂_L + gJω` (the same recursion: the comment in `tick`): `gT` on the estimate (Q31)
    /// and on the torque current, the speed's change's `gJ(1 − gT)/K_t · ω_b/(N I_b)`, the
    /// speed's `gTB/K_t · ω_b/(N I_b)`.
    lo_gt: Coef,
    lo_dw: Coef,
    lo_b: Coef,
    /// The current limit, Q15 of `I_b`, and in Q31.
    i_max: i32,
    i_max_q31: i32,
    /// The speed reference's limit (rated) and slew per task, Q15 of `ω_b`; the slew in Q31.
    speed_max: i32,
    speed_step_q31: i32,
    /// The f32 drive's low-speed d current ([`DriveConfig::low_speed_hold`]), Q15 of `I_b`,
    /// held while the speed reference is below `hold_below_q31` (Q31 of `ω_b`) and the q
    /// current asked for is smaller.
    hold_d: i32,
    hold_below_q31: i32,
    /// The monitor is judged above this |speed| (Q15 of `ω_b`): its lowest speed.
    monitor_from: i32,
    /// `cos` of the largest disagreement, Q15.
    cos_disagree: i32,
    /// Tasks of disagreement before a fault (the loss time).
    loss_ticks: u16,
    /// Steps per task; beyond `TICKS_MISSED_MAX` tasks' worth without a task: a stall.
    steps: u16,
    steps_max: u16,
}

/// The fixed-point drive's running state.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FixedState {
    /// The latched fault (PWM off), if any.
    pub fault: Option<Fault>,
    /// The flux observer (the primary).
    pub flux: FluxStateQ,
    /// The sliding observer (the monitor).
    pub sliding: SlidingStateQ,
    /// The PLL on the flux observer's angle.
    pub pll: PllStateQ,
    /// The current loop's integrators.
    pub current: CurrentLoopStateQ,
    /// The speed estimate, Q15 of `ω_b` (the PLL's, at the last task).
    pub omega: Q15,
    /// sin/cos of the output lead, Q15.
    pub lead_sc: (Q15, Q15),
    /// The voltage computed in the last step, Q15 of `V_b`.
    pub v_cmd: AlphaBetaQ15,
    /// The voltage applied over the period that ended (the observers' input), Q15 of `V_b`.
    pub v_obs: AlphaBetaQ15,
    /// The current reference, Q15 of `I_b`.
    pub i_ref: DqQ15,
    /// The measured currents in the control frame, Q15 of `I_b` (telemetry).
    pub i_dq: DqQ15,
    /// The speed reference (slewed), Q31 of `ω_b`.
    pub speed_ref: i32,
    /// The speed PI's integrator, Q31 of `I_b`.
    pub speed_integral: i32,
    /// The load observer's estimate `τ̂_L/K_t`, Q31 of `I_b` (the feed-forward).
    pub load: i32,
    /// The phase-sum check's count.
    pub sum_count: u8,
    /// Tasks in a row of the monitor's disagreement.
    pub disagree: u16,
    /// Tasks in a row of the monitor's agreement.
    pub agree: u16,
    /// The monitor's strikes (re-seeds) since a run of agreement.
    pub strikes: u8,
    /// Steps since the last task.
    pub steps: u16,
}

impl FixedState {
    /// The flux observer's angle (tests and telemetry: f32).
    pub fn theta_e(&self) -> f32 {
        let (s, c) = self.flux.sin_cos().unwrap_or((0, 0));
        libm::atan2f(f32::from(s), f32::from(c))
    }
}

impl FixedDrive {
    /// The fixed-point drive of the f32 drive's configuration `cfg` (its motor, limits, power
    /// stage, gains and observers' settings). Refused, named: what the blocks refuse (a
    /// salient motor, a coefficient outside its format).
    pub fn build(cfg: &DriveConfig) -> Result<Self, ParamError> {
        Self::build_in(cfg, &PerUnit::of_drive(cfg)?)
    }

    /// [`FixedDrive::build`] in given bases `pu` (a model adapted since the bases were chosen:
    /// the f32 drive's resistance and flux linkage at a take-over, in the bases of its
    /// nominal model, so that the board's scaling of its samples stays).
    pub fn build_in(cfg: &DriveConfig, pu: &PerUnit) -> Result<Self, ParamError> {
        Self::build_with(cfg, pu, None)
    }

    /// [`FixedDrive::build`] with the PLL in the step whatever the motor's speed (a bench's
    /// worst case; a drive that wants its speed estimate every step).
    pub fn build_pll_in_step(cfg: &DriveConfig) -> Result<Self, ParamError> {
        Self::build_with(cfg, &PerUnit::of_drive(cfg)?, Some(true))
    }

    /// The build; `pll_in_step` forced, or chosen from the motor's rated speed (`None`).
    fn build_with(
        cfg: &DriveConfig,
        pu: &PerUnit,
        pll_in_step: Option<bool>,
    ) -> Result<Self, ParamError> {
        let pu = *pu;
        let flux = FluxObserverQ::build(&cfg.flux_config(), &pu)?;
        // The monitor: where the f32 drive's is judged (its K_s window not empty,
        // `DriveConfig::sliding_monitor`), and its settings have a fixed-point form.
        let sliding = if cfg.sliding_torque().is_ok() {
            SlidingObserverQ::build(&cfg.sliding_config(), &pu).ok()
        } else {
            None
        };
        // The PLL at the task's rate (the f32 drive's), or at the step's where the rotor turns
        // more than half a turn per task period at 1.5 times its rated speed: `Δ`, a turn per
        // sample in an `i32`, holds half a turn at most (an f32 drive takes its aided PLL
        // there, `observer::pll`).
        let steps_f = cfg.steps_per_tick();
        let rated_e = cfg.ratings.speed_rpm * crate::units::RAD_S_PER_RPM * cfg.motor.n();
        let pll_in_step =
            pll_in_step.unwrap_or(1.5 * rated_e * steps_f / cfg.rate_hz >= core::f32::consts::PI);
        let pll_cfg = if pll_in_step {
            crate::observer::pll::PllConfig {
                rate_hz: cfg.rate_hz,
                ..cfg.pll_config()
            }
        } else {
            cfg.pll_config()
        };
        let pll = PllQ::build(&pll_cfg, &pu)?;
        let foc = cfg.foc_config();
        let current = CurrentLoopQ::build(&foc, &pu)?;
        let l = &cfg.limits;
        let bus_base = 2.0 * l.bus_max_v;
        let q15 = |x: f32| libm::roundf(x * 32_768.0) as i32;
        let (hold_a, hold_below_rpm) = cfg.low_speed_hold();
        let dt = foc.dead_time;
        let delay = cfg.delay_periods();
        Allowed::between(0.0, 1.0)
            .because("an update delay within one period")
            .check("power_stage.update_delay_s * rate_hz", delay)?;
        let steps = cfg.steps_per_tick();
        let n = cfg.motor.n();
        let w_mech_b = pu.omega_base_e / n;
        let g = foc.gains();
        let tick_s = steps / cfg.rate_hz;
        let rpm_to_q15 =
            |rpm: f32| rpm * crate::units::RAD_S_PER_RPM * n / pu.omega_base_e * 32_768.0;
        let i_sum = (0.02 + 6.0 * 0.01 * 1.732_050_8) * cfg.ratings.current_a
            + 1.5 * cfg.identify.sense_lsb_a.max(pu.i_base_a / 32_768.0);
        let i_max = l.i_max_a / pu.i_base_a;
        let lo = cfg.load_observer_config();
        lo.build()?;
        let (g_lo, kt) = (core::f32::consts::TAU * lo.bandwidth_hz, lo.torque_constant);
        let gt = g_lo * tick_s;
        let lo_dw = g_lo * lo.j_kgm2 * (1.0 - gt) / kt * w_mech_b / pu.i_base_a;
        let lo_b = gt * lo.b_nms / kt * w_mech_b / pu.i_base_a;
        // The lead per PLL increment, advance/steps, as a gain on Δ >> s: the largest s ≤ 16
        // that keeps it below 2^14 (Δ >> 16 resolves 2^-16 turn per task).
        let lead_per_delta = foc.angle_advance_periods / if pll_in_step { 1.0 } else { steps };
        let mut lead_shift = 16u32;
        while lead_shift > 0 && lead_per_delta * (1u32 << lead_shift) as f32 >= 16_000.0 {
            lead_shift -= 1;
        }
        Ok(Self {
            flux,
            sliding,
            pll,
            current,
            i_trip: q15(l.i_trip_a / pu.i_base_a).min(32_766),
            i_sum_max: q15(i_sum / pu.i_base_a),
            bus_min: q15(l.bus_min_v / bus_base),
            bus_max: q15(l.bus_max_v / bus_base),
            v_max_of_bus: Gain::new(
                "fixed step: 2 sqrt3 v_max_per_bus",
                2.0 * 1.732_050_8 * dt.v_max_per_bus(),
            )?,
            dt_sign: Gain::new("fixed step: I_b/band", pu.i_base_a / dt.band_a)?,
            dt_u: Gain::new("fixed step: t_d f_pwm 2/3", dt.duty() * 2.0 / 3.0)?,
            delay: Gain::new("fixed step: delay periods", delay)?,
            delayed: delay > 0.0,
            lead: Gain::new(
                "fixed step: lead per task speed 2^s",
                lead_per_delta * (1u32 << lead_shift) as f32,
            )?,
            lead_shift,
            pll_in_step,
            strikes_max: 3,
            r_pu: cfg.motor.r_ohm * pu.i_base_a / pu.v_base_v,
            speed_kp: Gain::new(
                "fixed step: speed kp omega_b/(N I_b)",
                g.speed_kp * w_mech_b / pu.i_base_a,
            )?,
            speed_ki: Gain::new(
                "fixed step: speed ki T omega_b/(N I_b) 2^16",
                g.speed_ki * tick_s * w_mech_b / pu.i_base_a * 65_536.0,
            )?,
            lo_gt: Coef::new("fixed step: load observer g T", gt)?,
            lo_dw: Coef::new("fixed step: load observer g J (1 - g T)/K_t", lo_dw)?,
            lo_b: Coef::new("fixed step: load observer g T B/K_t", lo_b)?,
            i_max: q15(i_max).min(32_767),
            i_max_q31: (q15(i_max).min(32_767)) << 16,
            speed_max: libm::roundf(rpm_to_q15(cfg.ratings.speed_rpm)).min(32_767.0) as i32,
            speed_step_q31: libm::roundf(rpm_to_q15(cfg.start.accel_rpm_per_s * tick_s) * 65_536.0)
                .min(2.0e9) as i32,
            hold_d: q15(hold_a / pu.i_base_a).min(32_767),
            hold_below_q31: libm::roundf(rpm_to_q15(hold_below_rpm) * 65_536.0).min(2.0e9) as i32,
            monitor_from: libm::roundf(rpm_to_q15(cfg.start.handover_rpm)).min(32_767.0) as i32,
            cos_disagree: q15(libm::cosf(cfg.health.max_disagreement_deg.to_radians())),
            // (A NaN loss time reads as one task.)
            loss_ticks: (libm::roundf(cfg.health.loss_time_s * 1000.0).clamp(1.0, 60_000.0) as u16)
                .max(1),
            steps: steps as u16,
            steps_max: (steps as u32 * crate::schedule::TICKS_MISSED_MAX).min(60_000) as u16,
            pu,
        })
    }

    /// The per-unit bases.
    pub fn per_unit(&self) -> &PerUnit {
        &self.pu
    }

    /// The bus's base \[V]: Q15 of it is [`FixedInput::v_bus`] (twice the highest bus, so an
    /// over-voltage is read, not clipped).
    pub fn bus_base_v(&self) -> f32 {
        // V_b = V_bus,max/√3: twice the highest bus is 2√3 V_b.
        2.0 * 1.732_050_8 * self.pu.v_base_v
    }

    /// Whether the sliding monitor runs (its settings have a fixed-point form).
    pub fn has_monitor(&self) -> bool {
        self.sliding.is_some()
    }

    /// A state in sensorless control at a known rotor: `theta_e` \[rad], `omega_e` [rad/s,
    /// electrical], the q current `i_q_a` \[A] (the load observer's estimate), `i_abc` this
    /// sample (Q15), `v_ab_v` the voltage applied over the period that ends at it \[V] (the
    /// observers' first input: a flux observer given a wrong voltage keeps the flux it
    /// integrated wrong as an offset of its circle, an angle error at the electrical
    /// frequency that eq (9)'s gradient removes only slowly), `x_hat_wb` the f32 flux
    /// observer's `x̂` \[Wb] where the take-over has it (else `x̂` from the angle, whose
    /// error stays as such an offset). Both observers seeded there,
    /// the speed reference at the speed, the current loop's q integrator at the steady-state
    /// `R i_q` (configuration: f32). The first task is due after `steps_per_tick` steps.
    pub fn seed(
        &self,
        i_abc: AbcQ15,
        theta_e: f32,
        omega_e: f32,
        i_q_a: f32,
        v_ab_v: crate::frames::AlphaBeta,
        x_hat_wb: Option<crate::frames::AlphaBeta>,
    ) -> FixedState {
        let i_ab = i_abc.to_alpha_beta_3();
        let th = Angle::from_rad(theta_e);
        let w = self.pu.speed(omega_e);
        let mut st = FixedState::default();
        match x_hat_wb {
            Some(x) => {
                let q31 = |wb: f32| {
                    let v = libm::roundf(wb / self.pu.flux_base_wb * 2_147_483_648.0);
                    if v >= 2_147_483_520.0 {
                        i32::MAX
                    } else if v <= -2_147_483_520.0 {
                        -i32::MAX
                    } else {
                        v as i32
                    }
                };
                let x_hat = super::flux::AlphaBetaQ31 {
                    alpha: q31(x.alpha),
                    beta: q31(x.beta),
                };
                self.flux.reset_x_hat(&mut st.flux, i_ab, x_hat);
            }
            None => self.flux.reset(&mut st.flux, i_ab, th),
        }
        if let Some(s) = &self.sliding {
            s.reset(&mut st.sliding, i_ab, th, w, 0);
        }
        // The PLL's angle is the prediction for its next update, the first task after
        // `steps_per_tick` steps from this sample on: θ + ω_e T (steps − 1).
        self.pll.reset(
            &mut st.pll,
            Angle::from_rad(theta_e + omega_e * self.pu.ts_s * self.seed_lead_steps()),
            w,
        );
        st.omega = w;
        st.v_obs = AlphaBetaQ15 {
            alpha: self.pu.voltage(v_ab_v.alpha),
            beta: self.pu.voltage(v_ab_v.beta),
        };
        st.v_cmd = st.v_obs;
        st.lead_sc = self.lead_of(st.pll.delta);
        let iq = self
            .pu
            .current(i_q_a)
            .max(-self.i_max as i16)
            .min(self.i_max as i16);
        st.i_ref = DqQ15 { d: 0, q: iq };
        st.speed_ref = i32::from(w) << 16;
        // The load observer at the load's current (its estimate = i_q), the speed loop's
        // integrator at zero.
        st.load = i32::from(iq) << 16;
        st.current.integral_q = self
            .current
            .integral_of(self.r_pu * f32::from(iq) / 32_768.0);
        st
    }

    /// Steps from a seed's sample to the sample of the PLL's first update, whose angle the
    /// PLL's `z1` predicts: the next step's in the step, the task's (`steps − 1` on) in it.
    fn seed_lead_steps(&self) -> f32 {
        if self.pll_in_step {
            1.0
        } else {
            f32::from(self.steps) - 1.0
        }
    }

    /// The PLL (Ortega Sec V iii) on the flux observer's angle: the phase detector
    /// `sin(θ̂ − z1)`, the cross product of the two unit vectors, taken as the angle (a
    /// quarter turn beyond ±90°).
    #[inline(always)]
    fn track(&self, st: &mut FixedState, (s, c): (Q15, Q15)) {
        let (s, c) = (i32::from(s), i32::from(c));
        let (sz, cz) = st.pll.z1.sin_cos();
        let (sz, cz) = (i32::from(sz), i32::from(cz));
        let cross = (s * cz - c * sz) >> 15;
        let dot = (c * cz + s * sz) >> 15;
        let err = if dot >= 0 {
            cross * SIN_TO_ANGLE
        } else if cross >= 0 {
            1 << 30
        } else {
            -(1 << 30)
        };
        let theta = st.pll.z1.advanced(Angle(err as u32));
        self.pll.update(&mut st.pll, theta);
    }

    /// sin/cos of the output lead at the PLL's increment `delta` (angle units per task).
    #[inline(always)]
    fn lead_of(&self, delta: i32) -> (Q15, Q15) {
        let half = (1i32 << self.lead_shift) >> 1;
        let x = delta.saturating_add(half) >> self.lead_shift;
        Angle(self.lead.apply(x.clamp(-65_536, 65_536)) as u32).sin_cos()
    }

    /// One control period (module doc). Never panics; the duties are within `[0, DUTY_ONE]`.
    #[inline(always)]
    pub fn step(&self, st: &mut FixedState, input: &FixedInput) -> FixedOutput {
        if st.fault.is_some() {
            cold_path();
            return FixedOutput {
                duties: None,
                fault: None,
            };
        }
        // 1. Input checks.
        let i = input.i_abc;
        let (a, b, c) = (i32::from(i.a), i32::from(i.b), i32::from(i.c));
        let peak = a.abs().max(b.abs()).max(c.abs());
        let v_bus = i32::from(input.v_bus);
        st.steps = st.steps.saturating_add(1);
        let fault = if peak > self.i_trip {
            Some(if peak >= 32_767 {
                Fault::InvalidInput
            } else {
                Fault::Overcurrent
            })
        } else if v_bus > self.bus_max {
            Some(Fault::BusOvervoltage)
        } else if v_bus < self.bus_min {
            Some(Fault::BusUndervoltage)
        } else if st.steps > self.steps_max {
            Some(Fault::TaskStall)
        } else {
            let beyond = (a + b + c).abs() > self.i_sum_max;
            st.sum_count = if beyond {
                st.sum_count.saturating_add(1)
            } else {
                st.sum_count.saturating_sub(1)
            };
            (st.sum_count >= SUM_COUNT_MAX).then_some(Fault::CurrentSensor)
        };
        if let Some(f) = fault {
            cold_path();
            st.fault = Some(f);
            return FixedOutput {
                duties: None,
                fault: Some(f),
            };
        }
        // 2. Both observers on this sample, with the voltage applied over the period that
        //    ended (Ortega eq (9); Horng & Chin eqs (20)-(22), (34), (35)).
        // The three-phase Clarke (the f32 drive's): a sensor's offset left in one phase is a
        // zero sequence, discarded.
        let i_ab = i.to_alpha_beta_3();
        self.flux.integrate(&mut st.flux, i_ab, st.v_obs);
        if let Some(s) = &self.sliding {
            s.update(&mut st.sliding, i_ab, st.v_obs);
        }
        // The frame: η̂/|η̂| (Ortega Sec V iii); none (η̂ = 0, a state the seed never leaves
        // the observer in): the previous output is held at zero volts.
        let Some(frame) = st.flux.sin_cos() else {
            cold_path();
            st.fault = Some(Fault::ObserverLoss);
            return FixedOutput {
                duties: None,
                fault: Some(Fault::ObserverLoss),
            };
        };
        if self.pll_in_step {
            self.track(st, frame);
        }
        // 3. The current loop (Ortega Sec V iv, dq model (3)), v_max from the bus.
        let i_dq = i_ab.to_dq(frame);
        st.i_dq = i_dq;
        let v_max = sat_q15(self.v_max_of_bus.apply(v_bus));
        let out = self
            .current
            .update(&mut st.current, i_dq, st.i_ref, st.omega, v_max);
        // 4. At the output angle: the frame turned by the lead (sin(a+l), cos(a+l)).
        let (s, c) = (i32::from(frame.0), i32::from(frame.1));
        let (sl, cl) = (i32::from(st.lead_sc.0), i32::from(st.lead_sc.1));
        let out_sc = (
            sat_q15((s * cl + c * sl + (1 << 14)) >> 15),
            sat_q15((c * cl - s * sl + (1 << 14)) >> 15),
        );
        let v_cmd = out.v_dq.to_alpha_beta(out_sc);
        // To Q15 of the bus: v V_b/V_bus = v/(2√3 b), b the bus in Q15 of 2 V_bus,max; 1/b
        // by Newton's steps (no division).
        let (r, e) = reciprocal_q15(v_bus);
        let k = (INV_2_SQRT3_Q15 * r) >> 13; // K/m in Q15 (≤ 18 919)
        let sh = (15 - e).max(0) as u32;
        let to_bus = |x: Q15| (i32::from(x) * k + ((1 << sh) >> 1)) >> sh;
        // The dead time's average error in the bus's units (Choi & Sul; `crate::dead_time`):
        // the smoothed signs of the phase currents, q_k = sat(i_k/band).
        let ph = i_ab.to_abc();
        let sign = |x: Q15| self.dt_sign.apply(i32::from(x)).clamp(-32_767, 32_767);
        let (qa, qb, qc) = (sign(ph.a), sign(ph.b), sign(ph.c));
        let e_a = self.dt_u.apply(((qa + qa) - (qb + qc)) >> 1);
        let e_b = (self.dt_u.apply((qb - qc) >> 1) * (2 * SQRT3_OVER_2_Q15) + (1 << 14)) >> 15;
        let v_pwm = AlphaBetaQ15 {
            alpha: sat_q15(to_bus(v_cmd.alpha) + e_a),
            beta: sat_q15(to_bus(v_cmd.beta) + e_b),
        };
        let pwm = svpwm_limited_q15(v_pwm);
        // The voltage the inverter applies, for the observers: the command; where SVPWM cut
        // it, the cut vector less the compensation, back in V_b (× 2√3 b).
        let applied = if pwm.saturated || !out.valid {
            cold_path();
            let back = |x: Q15, e: i32| {
                let x = i32::from(x) - e;
                sat_q15((((x * v_bus) >> 13) * 28_378 + (1 << 14)) >> 15)
            };
            AlphaBetaQ15 {
                alpha: back(pwm.v_ab_applied.alpha, e_a),
                beta: back(pwm.v_ab_applied.beta, e_b),
            }
        } else {
            v_cmd
        };
        st.v_obs = if self.delayed {
            let mix = |now: Q15, prev: Q15| {
                let (now, prev) = (i32::from(now), i32::from(prev));
                sat_q15(now + self.delay.apply(prev - now))
            };
            AlphaBetaQ15 {
                alpha: mix(applied.alpha, st.v_cmd.alpha),
                beta: mix(applied.beta, st.v_cmd.beta),
            }
        } else {
            applied
        };
        st.v_cmd = applied;
        FixedOutput {
            duties: Some(pwm.duties),
            fault: None,
        }
    }

    /// The 1 kHz task (module doc): `speed_cmd` the user's command, Q15 of `ω_b` (electrical).
    /// Returns the fault it found, if any (the step applies it from the next sample).
    #[inline(never)]
    pub fn tick(&self, st: &mut FixedState, speed_cmd: Q15) -> Option<Fault> {
        st.steps = 0;
        if st.fault.is_some() {
            return None;
        }
        let frame = st.flux.sin_cos().unwrap_or((0, 32_767));
        if !self.pll_in_step {
            self.track(st, frame);
        }
        // The speed in per unit at the task's rate wherever the PLL runs (the f32 drive's
        // current loop takes it so).
        let w = self.pll.omega_q15(&st.pll);
        let w_prev = core::mem::replace(&mut st.omega, w);
        let (s, c) = (i32::from(frame.0), i32::from(frame.1));
        st.lead_sc = self.lead_of(st.pll.delta);
        // The speed reference: the command within the rated speed, slewed. (Bounds from the
        // settings by `max`/`min`: `clamp`'s check of its bounds is a panic path.)
        let cmd = i32::from(speed_cmd)
            .max(-self.speed_max)
            .min(self.speed_max)
            << 16;
        let step = (cmd.saturating_sub(st.speed_ref))
            .max(-self.speed_step_q31)
            .min(self.speed_step_q31);
        st.speed_ref = st.speed_ref.saturating_add(step);
        // The speed PI (the f32 `Pi::update_within`): the integrator moves unless the output is
        // at a limit and the error pushes further.
        let e = ((st.speed_ref >> 15) + 1) >> 1;
        let e = (e - i32::from(w)).clamp(-65_536, 65_536);
        // The load observer (`crate::load_observer`) on the last torque current: its estimate
        // fed forward, as the f32 drive's speed loop does.
        // On its estimate `L = τ̂_L/K_t`, not on the f32 state `z = τ̂_L + gJω`: at the rated
        // speed `gJω/K_t` exceeds the current's base on a motor of large inertia (Ortega's
        // 40 kW machine: z saturated its Q31 above 1 200 rpm, the feed-forward 100 A short,
        // the speed PI making it up at its pace). The f32 recursion `z' = (1 − gT) z +
        // (g²JT − gTB) ω' + gT K_t i`, `τ̂' = z' − gJω'`, is in `τ̂`:
        // `τ̂' = (1 − gT) τ̂ + gT (K_t i − B ω') − gJ (1 − gT)(ω' − ω)`, bounded as the load is.
        let wi = i32::from(w);
        let dw = (wi - i32::from(w_prev)).clamp(-65_536, 65_536);
        st.load = st
            .load
            .saturating_sub(self.lo_gt.apply_wide(st.load, 0))
            .saturating_add(self.lo_gt.apply(i32::from(st.i_ref.q), 16))
            .saturating_sub(self.lo_b.apply(wi, 16))
            .saturating_sub(self.lo_dw.apply(dw, 16));
        let ff = ((st.load >> 15) + 1) >> 1;
        let p = self.speed_kp.apply(e) + ff;
        let candidate = st
            .speed_integral
            .saturating_add(self.speed_ki.apply(e))
            .max(-self.i_max_q31)
            .min(self.i_max_q31);
        let unclamped = p + (candidate >> 16);
        let further = (unclamped > self.i_max && e > 0) || (unclamped < -self.i_max && e < 0);
        if !further {
            st.speed_integral = candidate;
        }
        let i_q = (p + (st.speed_integral >> 16))
            .max(-self.i_max)
            .min(self.i_max);
        // The f32 drive's low-speed d current (`sensorless.rs`): at a low speed reference,
        // while the q current last asked for is smaller, so that the phase currents keep a
        // sign the dead-time compensation knows.
        let held = st.speed_ref.saturating_abs() < self.hold_below_q31
            && i32::from(st.i_ref.q).abs() < self.hold_d;
        st.i_ref = DqQ15 {
            d: if held { self.hold_d as i16 } else { 0 },
            q: i_q as i16,
        };
        // The monitor: the sliding observer's angle against the flux observer's, above its
        // lowest speed.
        if self.sliding.is_some() && i32::from(w).abs() >= self.monitor_from {
            let (ss, cs) = st.sliding.sc;
            let agree = (c * i32::from(cs) + s * i32::from(ss)) >> 15;
            let disagrees = agree < self.cos_disagree;
            st.disagree = if disagrees {
                st.disagree.saturating_add(1)
            } else {
                0
            };
            st.agree = if disagrees {
                0
            } else {
                st.agree.saturating_add(1)
            };
            if st.agree >= self.loss_ticks.saturating_mul(10) {
                st.strikes = 0;
            }
            if st.disagree >= self.loss_ticks {
                // The f32 supervision's contradiction: a strike, and the monitor re-seeded from
                // the primary, which drives (the f32 drive re-seeds the one whose residual is
                // the larger; here the primary always drives); the third strike within a run
                // of agreement is the fault.
                cold_path();
                st.disagree = 0;
                st.strikes = st.strikes.saturating_add(1);
                if st.strikes >= self.strikes_max {
                    st.fault = Some(Fault::ObserverLoss);
                    return Some(Fault::ObserverLoss);
                }
                if let Some(m) = &self.sliding {
                    m.reset(&mut st.sliding, st.flux.i_last, st.pll.z1, w, 0);
                }
            }
        } else {
            st.disagree = 0;
        }
        None
    }
}

/// `1/b` for a positive Q15 `b`: `(r, e)` with `1/b = r·2^(e−13)` (as pu, `b/2¹⁵`), `r` in
/// (2¹³, 2¹⁴]: `b = m·2^−e` with `m` in [½, 1), `1/m` from `48/17 − 32/17 m` and two Newton
/// steps `y ← y (2 − m y)` (as the sliding observer's `1/Ω`). `b ≤ 0` reads as the least
/// positive value (the bus check refuses it before).
#[inline(always)]
fn reciprocal_q15(b: i32) -> (i32, i32) {
    let b = b.max(1) as u32;
    // b < 2¹⁵: lz ≥ 17; m15 = b << (lz − 17) in [2¹⁴, 2¹⁵), e = lz − 17.
    let lz = b.leading_zeros();
    let e = lz as i32 - 17;
    let m15 = (b << (lz - 17)) as i32;
    let mut y = 46_261 - ((30_840 * m15) >> 15);
    for _ in 0..2 {
        let t = (2 << 29) - m15 * y;
        y = (y * (t >> 14)) >> 15;
    }
    (y >> 1, e)
}
