//! The drive's configuration in SI units, its validation, and what it derives: the FOC gains,
//! the observers' settings, and each mode's per-step coefficients.

use super::config_observers::{default_speed_bandwidth_hz, ADVANCE_PERIODS, PLL_BANDWIDTH_HZ};
pub use super::config_rate::PowerStageConfig;
use super::derating::FIELD_WEAKENING_MARGIN;
#[cfg(feature = "identify")]
use super::identify;
use super::identify::IdentifyConfig;
use super::open_loop;
use super::ramp::Ramp;
use super::speed_gain;
use super::supervision;
use super::{
    adaptation, align, catch, catch_zero, plausibility, regen, safe_state, sensorless, Drive,
};
use crate::dead_time::DeadTimeConfig;
use crate::foc::FocConfig;
use crate::load_observer::LoadObserverConfig;
use crate::math::INV_SQRT3;
use crate::motor::{Motor, MotorParams, Ratings};
use crate::mtpa::Mtpa;
use crate::observer::flux_speed::FluxPll;
use crate::observer::sliding::SlidingObserver;
use crate::observer::Observer;
use crate::param::{Allowed, Checks, ParamError};
use crate::rate::{control_rate, CpuBudget};
use crate::units::{RAD_PER_DEG, RAD_S_PER_RPM, RPM_PER_RAD_S};
use core::f32::consts::TAU;

/// The adapted resistance stays within R₀/3..3 R₀ (`adaptation.rs`): a copper winding from
/// −40 °C to 150 °C spans 1.75×, and a datasheet's line-to-line figure taken for the phase's
/// is 2× off.
const ADAPT_RANGE: f32 = 3.0;
/// The adapted flux linkage stays within ψ₀/1.5..1.5 ψ₀: NdFeB loses about 12 % per 100 K;
/// a back-EMF constant read as peak for RMS is √2 off.
const FLUX_ADAPT_RANGE: f32 = 1.5;
/// ψ_f's and R's low-pass time constant \[s] (a winding's thermal time constant is minutes).
const ADAPT_TIME_S: f32 = 0.25;
/// ψ_f is measured above this fraction of the rated speed (the hand-over's: a flux linkage
/// 15 % off must be corrected while the rotor is still slow, or both observers' residuals
/// reach their limit there, measured on Ortega's test motor) ...
const FLUX_ADAPT_MIN_SPEED: f32 = 0.1;
/// ... where `R |i_q|` and `ω_e L_q |i_q|` are each at most this share of the back-EMF: R just
/// measured (within 1.2 % in the robustness matrix) moves ψ_f by 0.4 % at most; a winding
/// warmed 30 % since, by 9 % (`adaptation.rs` for the inductive part).
const FLUX_ADAPT_MAX_R_SHARE: f32 = 0.3;
/// The share of R the drive may be off by at low speed, for `DriveConfig::if_held_below_rpm`:
/// the identification's error (at most 1.8 % on the zoo's motors) and a copper winding
/// warmed 8 K since (3 %), the tracking seeing R only above a tenth of rated speed
/// (`adaptation.rs`).
const R_UNCERTAINTY: f32 = 0.05;
/// tan 30°: the health check's default largest disagreement between the observers.
const TAN_30_DEG: f32 = 0.577_350_3;

/// The time constant of the measured bus's low-pass filter for the over-speed bound \[s]: half
/// the over-speed's persistence (`loss_time_s`, 20 ms), long against the PWM's and the
/// sampling's noise.
const BUS_FILTER_S: f32 = 0.01;
/// The B-G431B-ESC1's PWM frequency \[Hz], the default power stage's.
const PWM_HZ: f32 = 20_000.0;

/// Protection limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Limit of the speed loop's current command \[A].
    pub i_max_a: f32,
    /// Phase-current trip level \[A], > `i_max_a`.
    pub i_trip_a: f32,
    /// Largest current the sensing path can report \[A]; beyond it a sample is invalid.
    pub i_sense_max_a: f32,
    /// Bus under-voltage trip \[V].
    pub bus_min_v: f32,
    /// Bus over-voltage trip \[V].
    pub bus_max_v: f32,
}

/// Open-loop start and hand-over settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StartConfig {
    /// d-axis current while aligning the rotor to θ_e = 0 \[A].
    pub align_current_a: f32,
    /// Alignment time \[s].
    pub align_time_s: f32,
    /// Magnitude of the open-loop (I/f) current \[A].
    pub open_loop_current_a: f32,
    /// Speed-reference slew rate, also the open-loop frequency ramp \[rpm/s].
    pub accel_rpm_per_s: f32,
    /// The open loop hands over to a healthy observer once its ramp has reached this |speed|
    /// (or the command, if lower but at least [`DriveConfig::if_held_below_rpm`]; at once when
    /// the observer sees the rotor pulled out of the ramp) \[rpm]; the sliding observer drives
    /// only above it.
    pub handover_rpm: f32,
    /// Back to open loop only when no observer is healthy and both |speed reference| and
    /// |ω̂| are below this \[rpm]; the slowest rotor a flying start catches.
    pub handback_rpm: f32,
    /// Stall if no observer has locked this long after the ramp reached the hand-over speed
    /// \[s] (the open loop's time limit, whatever the speed).
    pub handover_timeout_s: f32,
    /// With a zero command, stopped (PWM off) when the estimated |speed| is below this \[rpm].
    pub stop_rpm: f32,
}

/// Health supervision settings (`supervision.rs`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HealthConfig {
    /// An observer is healthy after the running mean of its residual has stayed below ¼ this
    /// long \[s].
    pub lock_time_s: f32,
    /// A healthy observer is lost after the running mean of its residual has stayed at or
    /// above ½ (half way to its edge of lock) this long: the other one drives \[s].
    pub failover_time_s: f32,
    /// Largest tolerated angle disagreement between two healthy observers [deg, electrical].
    pub max_disagreement_deg: f32,
    /// Largest tolerated speed disagreement between two healthy observers \[rpm].
    pub max_speed_disagreement_rpm: f32,
    /// No healthy observer (or a contradiction) this long is an observer loss \[s].
    pub loss_time_s: f32,
    /// Speed collapse: the speed loop at its current limit with |ω̂| below half the reference
    /// for this long is a stall \[s].
    pub stall_time_s: f32,
}

/// Everything the drive is built from. [`DriveConfig::new`] derives it from a motor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveConfig {
    /// The controller's motor model.
    pub motor: MotorParams,
    /// Step rate \[Hz]: a multiple of 1 kHz (whole steps per 1 kHz task); chosen from the
    /// motor by [`DriveConfig::new`] ([`crate::rate`]: 4 kHz for every motor up to 200 Hz
    /// electrical at rated speed).
    pub rate_hz: f32,
    /// Current-loop bandwidth \[Hz] (300).
    pub current_bandwidth_hz: f32,
    /// Speed-loop bandwidth \[Hz] (20), run in the 1 kHz task.
    pub speed_bandwidth_hz: f32,
    /// Protection limits.
    pub limits: Limits,
    /// Start-up and hand-over.
    pub start: StartConfig,
    /// Health supervision.
    pub health: HealthConfig,
    /// The power stage's PWM frequency and dead time, compensated.
    pub power_stage: PowerStageConfig,
    /// The motor's ratings: the ranges of the limits are set from them, and the sliding gain
    /// must stay below (K_s,max)_E2 at the rated speed.
    pub ratings: Ratings,
    /// The board's current sensing, as the identification checks a motor against it.
    pub identify: IdentifyConfig,
    /// Maximum torque per ampere on a motor with `L_q > L_d` ([`crate::mtpa`]; true): the
    /// speed loop's d current the more negative of the MTPA's and the field weakening's.
    /// False: the field weakening's alone (`i_d = 0` below it), as on a non-salient motor.
    pub mtpa: bool,
}

impl DriveConfig {
    /// Defaults from the motor's ratings: current command limit 1.5× the current of rated
    /// torque, trip at 1.5× that, sensing range 2× the trip; bus trips at 0.75 and 1.25 of the
    /// rated bus; align and open-loop currents the rated-torque current (they hold the rotor
    /// against an active load of half rated torque at 30° of load angle), on a salient motor with
    /// `L_d < L_q` at most `ψ_f/(2 (L_q − L_d))` (the most holding stiffness), for 0.2 s and up
    /// the ramp; the ramp climbs the rated speed in a second; hand-over at 10 %
    /// of rated speed; hand-back (without a healthy observer) below 6 %; stopped below 2 %;
    /// an observer healthy after 20 ms of mean residual below ¼, lost after 3 ms at ½;
    /// observer loss after 20 ms without a healthy one or of 30° or 10 % of rated speed
    /// contradiction; stall after 0.5 s of open loop without lock or 0.1 s at the current
    /// limit below half the speed reference. The speed loop at 20 Hz, lower where it would make
    /// more than ten times the current sensors' noise of its torque command
    /// (`config_observers::default_speed_bandwidth_hz`). The power stage is the
    /// B-G431B-ESC1's (20 kHz PWM, 500 ns dead time); the dead-time
    /// compensation's smooth sign reaches full at 5 % of the rated-torque current: five
    /// standard deviations of the 1 %-of-rated-current noise a board's sensing has
    /// (`DESIGN.md`), so noise at a zero crossing moves the compensation by a fifth of it
    /// per sample, not from one sign to the other; and a phase current of rated-torque
    /// amplitude is below the band only 3 % of an electrical turn (|sin| < 0.05). The step
    /// rate is [`crate::rate::control_rate`]'s for the motor on this PWM and the board's CPU
    /// budget ([`DriveConfig::rate_choice`]).
    pub fn new(motor: &Motor) -> Self {
        let i_rated = motor.rated_torque_current_a();
        // A salient motor with L_d < L_q: align and open loop at most at the current that
        // holds its rotor stiffest (`motor::stiffest_holding_current_a`; at twice it the rotor
        // settles at ±90° and the flux observer's read-out turns by π,
        // `crate::observer::flux`). No cap for L_d ≥ L_q.
        let m = &motor.params;
        let i_start = m
            .stiffest_holding_current_a()
            .map_or(i_rated, |i| i_rated.min(i));
        let i_max = 1.5 * i_rated;
        let i_trip = 1.5 * i_max;
        let bus = motor.ratings.bus_v;
        let speed = motor.ratings.speed_rpm;
        Self {
            motor: motor.params,
            rate_hz: control_rate(motor.params.pole_pairs, speed, PWM_HZ, &CpuBudget::BOARD)
                .rate_hz,
            current_bandwidth_hz: 300.0,
            speed_bandwidth_hz: default_speed_bandwidth_hz(&motor.params),
            limits: Limits {
                i_max_a: i_max,
                i_trip_a: i_trip,
                i_sense_max_a: 2.0 * i_trip,
                bus_min_v: 0.75 * bus,
                bus_max_v: 1.25 * bus,
            },
            start: StartConfig {
                align_current_a: i_start,
                align_time_s: 0.2,
                open_loop_current_a: i_start,
                accel_rpm_per_s: speed,
                handover_rpm: 0.1 * speed,
                handback_rpm: 0.06 * speed,
                handover_timeout_s: 0.5,
                stop_rpm: 0.02 * speed,
            },
            health: HealthConfig {
                lock_time_s: 0.02,
                failover_time_s: 0.003,
                max_disagreement_deg: 30.0,
                max_speed_disagreement_rpm: 0.1 * speed,
                loss_time_s: 0.02,
                stall_time_s: 0.1,
            },
            power_stage: PowerStageConfig {
                pwm_hz: PWM_HZ,
                dead_time_s: 500e-9,
                dead_time_band_a: 0.05 * i_rated,
                duty_max: 1.0,
                update_delay_s: 0.0,
                terminal_sensing: true,
            },
            ratings: motor.ratings,
            // The drive's own sensing range; a board sets its own.
            identify: IdentifyConfig {
                sense_range_a: 2.0 * i_trip,
                sense_lsb_a: 0.0,
            },
            mtpa: true,
        }
    }

    /// The settings validated: the error names the bad field, its value and the range
    /// allowed. The ranges keep every protection on (no trip level, disagreement or time so
    /// large that it never acts) and the start-up within what the bus can drive. The
    /// parameters are the controller's belief and may differ from the nameplate's motor, so
    /// only [`Motor::validate`] holds the ratings to them; here the rated speed must be
    /// within the highest bus.
    pub(super) fn validate(&self) -> Result<MotorParams, ParamError> {
        let m = self.motor.validate()?;
        let rated = self.ratings.validate()?;
        let (l, s, h) = (self.limits, self.start, self.health);
        let mut c = Checks::new();
        c.check("rate_hz", self.rate_hz, Allowed::between(1000.0, 100_000.0));
        c.done()?;
        let mut c = Checks::new();
        self.schedule()?;
        let delay = Allowed::between(0.0, 1.0 / self.rate_hz).because("up to one step");
        c.check(
            "power_stage.update_delay_s",
            self.power_stage.update_delay_s,
            delay,
        );
        let i_rated = rated.torque_nm / m.torque_constant();
        let i_max = Allowed::above_up_to(0.0, 3.0 * i_rated).because("3 x rated-torque current");
        c.check("limits.i_max_a", l.i_max_a, i_max);
        let trip = Allowed::above_up_to(l.i_max_a, 4.0 * l.i_max_a).because("i_max_a..4 x it");
        c.check("limits.i_trip_a", l.i_trip_a, trip);
        let sense =
            Allowed::above_up_to(l.i_trip_a, 10.0 * l.i_trip_a).because("i_trip_a..10 x it");
        c.check("limits.i_sense_max_a", l.i_sense_max_a, sense);
        let bus_min =
            Allowed::from_below(0.25 * rated.bus_v, rated.bus_v).because("0.25..1 x bus_v");
        c.check("limits.bus_min_v", l.bus_min_v, bus_min);
        let bus_max = Allowed::strictly_between(l.bus_min_v, 1.5 * rated.bus_v)
            .because("bus_min_v..1.5 x bus_v");
        c.check("limits.bus_max_v", l.bus_max_v, bus_max);
        // Align and open-loop currents up to i_max_a, and through R within the lowest bus's
        // phase voltage.
        let start_current = Allowed::above_up_to(0.0, l.i_max_a).because("up to i_max_a");
        let through_r = Allowed::above_up_to(0.0, l.bus_min_v * INV_SQRT3 / m.r_ohm)
            .because("r_ohm x it < bus_min_v/sqrt3");
        for (field, i) in [
            ("start.align_current_a", s.align_current_a),
            ("start.open_loop_current_a", s.open_loop_current_a),
        ] {
            c.check(field, i, start_current);
            c.check(field, i, through_r);
        }
        let align_time = Allowed::between(2.0 / self.rate_hz, 10.0).because("2 steps to 10 s");
        c.check("start.align_time_s", s.align_time_s, align_time);
        let accel = Allowed::above_up_to(0.0, 100.0 * rated.speed_rpm).because("rated in 10 ms");
        c.check("start.accel_rpm_per_s", s.accel_rpm_per_s, accel);
        // The open loop must reach the hand-over speed on the lowest bus, and the rated speed
        // must be within the highest: back-EMF within bus/√3.
        let rated_speed = Allowed::above_up_to(0.0, m.bus_limited_rpm(l.bus_max_v))
            .because("EMF < bus_max_v/sqrt3");
        c.check("ratings.speed_rpm", rated.speed_rpm, rated_speed);
        let half_rated = 0.5 * rated.speed_rpm;
        let handback = Allowed::strictly_between(0.0, half_rated).because("rated/2");
        c.check("start.handback_rpm", s.handback_rpm, handback);
        let handover = Allowed::above_up_to(
            s.handback_rpm,
            half_rated.min(m.bus_limited_rpm(l.bus_min_v)),
        )
        .because("handback..rated/2, EMF < bus_min_v/sqrt3");
        c.check("start.handover_rpm", s.handover_rpm, handover);
        let stop = Allowed::above_up_to(0.0, s.handback_rpm).because("up to handback_rpm");
        c.check("start.stop_rpm", s.stop_rpm, stop);
        let check_time = Allowed::between(1.0 / 1000.0, 1.0).because("a check (1 ms) to 1 s");
        c.check("health.lock_time_s", h.lock_time_s, check_time);
        c.check("health.failover_time_s", h.failover_time_s, check_time);
        let timeout = Allowed::above_up_to(h.lock_time_s, 60.0).because("above lock_time_s, 60 s");
        c.check("start.handover_timeout_s", s.handover_timeout_s, timeout);
        let angle = Allowed::above_up_to(0.0, 90.0).because("lost lock");
        c.check("health.max_disagreement_deg", h.max_disagreement_deg, angle);
        let speed = Allowed::above_up_to(0.0, half_rated).because("rated/2");
        c.check(
            "health.max_speed_disagreement_rpm",
            h.max_speed_disagreement_rpm,
            speed,
        );
        c.check("health.loss_time_s", h.loss_time_s, check_time);
        c.check(
            "health.stall_time_s",
            h.stall_time_s,
            Allowed::above_up_to(0.0, 5.0),
        );
        self.dead_time_config().check(
            &mut c,
            [
                "power_stage.pwm_hz",
                "power_stage.dead_time_s",
                "power_stage.dead_time_band_a",
                "power_stage.duty_max",
            ],
        );
        c.done()?;
        #[cfg(feature = "identify")]
        self.identify.check()?;
        Ok(m)
    }

    /// The dead-time compensation's settings (unvalidated).
    pub(super) fn dead_time_config(&self) -> DeadTimeConfig {
        let p = self.power_stage;
        DeadTimeConfig {
            dead_time_s: p.dead_time_s,
            pwm_hz: p.pwm_hz,
            band_a: p.dead_time_band_a,
            duty_max: p.duty_max,
        }
    }

    /// The speed loop's load-torque observer: the motor's mechanics at the speed loop's rate,
    /// its bandwidth a fifth of the paper's PLL's (10 Hz): it works on the PLL's speed estimate,
    /// whose phase lag must stay small at its bandwidth (22° at a fifth of the PLL's natural
    /// frequency, 43° at 20 Hz, where the speed loop with it oscillated on Ortega's test
    /// motor after a flying start). Kept where the speed loop and its PLL are lowered for noise
    /// (`config_observers::pll_bandwidth_hz`): lowered with them on the Brusa HSM1, the salient
    /// motor lost two of its 20 must-show cells (reversal at 20 %) (unvalidated).
    pub(crate) fn load_observer_config(&self) -> LoadObserverConfig {
        LoadObserverConfig {
            j_kgm2: self.motor.j_kgm2,
            b_nms: self.motor.b_nms,
            torque_constant: self.motor.torque_constant(),
            bandwidth_hz: PLL_BANDWIDTH_HZ / 5.0,
            rate_hz: self.rate_hz / self.steps_per_tick(),
        }
    }

    /// The FOC's settings (unvalidated).
    pub fn foc_config(&self) -> FocConfig {
        FocConfig {
            current_bandwidth_hz: self.current_bandwidth_hz,
            speed_bandwidth_hz: self.speed_bandwidth_hz,
            current_rate_hz: self.rate_hz,
            speed_divider: self.steps_per_tick() as u32,
            angle_advance_periods: ADVANCE_PERIODS + self.delay_periods(),
            dead_time: self.dead_time_config(),
            ..FocConfig::new(self.motor, self.limits.i_max_a)
        }
    }

    /// The d current sensorless control holds where the speed loop asks for little q
    /// current at low speed \[A], and the |speed reference| below which it holds it \[rpm]
    /// (`sensorless::Settings::enter`): twice the dead-time compensation's band, as the
    /// catch holds (`catch_zero::Settings::i_hold_a`); below the speed where the dead-time
    /// voltage's fundamental `(4/π) t_d f_pwm V_bus` is a twentieth of the back-EMF
    /// `N ψ_f ω_m` (its fundamental alone an angle error up to tan⁻¹ 0.05 = 3° where the
    /// compensation does not know the current's sign), and at least below the hand-over
    /// speed. A tenth (6°) was not enough: the iPower GM4108H gimbal without load at 150 rpm,
    /// just above that speed (145 rpm), currents of 10 mA, its sliding observer's angle
    /// wandered ±13° and the rotor 2.16 % off its command after a reversal
    /// (`profile-reversal`, issue #26's zoo). A stop holds it below half that speed
    /// ([`DriveConfig::low_speed_hold_stopping_rpm`]).
    pub fn low_speed_hold(&self) -> (f32, f32) {
        let hold_a = 2.0 * self.power_stage.dead_time_band_a;
        (hold_a, self.dead_time_speed_rpm(20.0))
    }

    /// The |speed reference| below which a stop (a zero command) holds the low-speed d
    /// current \[rpm]: where the dead-time voltage's fundamental is a tenth of the back-EMF
    /// (6°), at least the hand-over speed. On a stop's way down the held d current dissipates
    /// the rotor's energy in the winding instead of braking it into the bus; held from the
    /// twentieth on, a stop into a supply that cannot sink raised the bus by 8.5 % instead of
    /// the 15.5 % of the stop from the tenth on (`host-sim/tests/dc_link.rs`, the Sinano
    /// motor, sliding primary), slower braking than the command asks for.
    pub fn low_speed_hold_stopping_rpm(&self) -> f32 {
        self.dead_time_speed_rpm(10.0)
    }

    /// A nonzero |command| below this is held in the I/f, supervised, instead of handed over
    /// (`open_loop.rs`) \[rpm]: where a resistance off by `R_UNCERTAINTY` at the I/f current
    /// moves the back-EMF the observers see by the health check's default largest
    /// disagreement, `ψ_f N ω_m tan 30° = ΔR I_ol`, at most the hand-back speed (above it the
    /// open loop's pull-out and reverse tests would hand a held command over, and sensorless
    /// control hand it back, in turn).
    // Out of line: the configuration's, not the step's (flash, `examples/README.md`).
    #[inline(never)]
    pub fn if_held_below_rpm(&self) -> f32 {
        const RPM_PER_V_S: f32 = R_UNCERTAINTY / TAN_30_DEG * RPM_PER_RAD_S;
        let r_i = self.motor.r_ohm * self.start.open_loop_current_a;
        (RPM_PER_V_S * r_i / self.motor.emf_constant()).min(self.start.handback_rpm)
    }

    /// The speed where the back-EMF is `ratio` times the dead-time voltage's fundamental, at
    /// least the hand-over speed \[rpm].
    fn dead_time_speed_rpm(&self, ratio: f32) -> f32 {
        let rpm = ratio * self.dead_time_v() / self.motor.emf_constant() * RPM_PER_RAD_S;
        rpm.max(self.start.handover_rpm)
    }

    /// The inverter's dead-time voltage at the rated bus, the fundamental of its square wave,
    /// `(4/π) t_d f_pwm V_bus` \[V].
    fn dead_time_v(&self) -> f32 {
        let p = &self.power_stage;
        4.0 / core::f32::consts::PI * p.dead_time_s * p.pwm_hz * self.ratings.bus_v
    }

    /// The drive with the sliding torque observer feeding the controller and the flux
    /// observer watching it.
    pub fn build_sliding_primary(&self) -> Result<Drive<SlidingObserver, FluxPll>, ParamError> {
        self.build(self.sliding_torque()?, self.flux_pll()?)
    }

    /// The drive with the flux observer (and its PLL) feeding the controller and the sliding
    /// torque observer watching it ([`DriveConfig::sliding_monitor`]: alone, for a motor whose
    /// `K_s` window is empty).
    pub fn build_flux_primary(&self) -> Result<Drive<FluxPll, SlidingObserver>, ParamError> {
        self.build(self.flux_pll()?, self.sliding_monitor()?)
    }

    /// MTPA for the motor `m` within the current limit where it is asked for (`mtpa`) and the
    /// motor is salient (`Mtpa::new`).
    pub(crate) fn mtpa_of(&self, m: &MotorParams) -> Option<Mtpa> {
        if self.mtpa {
            Mtpa::new(m, self.limits.i_max_a)
        } else {
            None
        }
    }

    /// Validates every setting and derives the FOC gains and each mode's coefficients;
    /// `primary` feeds the controller, `monitor` watches it. The error names the bad field.
    pub fn build<P: Observer, M: Observer>(
        &self,
        primary: P,
        monitor: M,
    ) -> Result<Drive<P, M>, ParamError> {
        let m = self.validate()?;
        let rate = self.rate_hz;
        let schedule = self.schedule()?;
        let slots = schedule.steps_per_tick() as f32;
        let (l, s, h) = (self.limits, self.start, self.health);
        let (hold_a, hold_below_rpm) = self.low_speed_hold();
        let if_held_below_rpm = self.if_held_below_rpm();
        let foc = self.foc_config().build()?;
        let ts = 1.0 / rate;
        let steps = |t: f32| (t * rate) as u32;
        let slot_cycles = |t: f32| (t * rate / slots) as u32;
        let mtpa = self.mtpa_of(&m);
        let ramp = Ramp {
            max_rpm: self.ratings.speed_rpm,
            step_rpm: s.accel_rpm_per_s * ts * slots,
        };
        Ok(Drive {
            schedule,
            delay_periods: self.delay_periods(),
            primary,
            monitor,
            foc,
            limits: l,
            sensing: plausibility::Settings::new(self.ratings.current_a, self.identify.sense_lsb_a),
            adaptation: adaptation::Settings {
                r0_ohm: m.r_ohm,
                flux0_wb: m.flux_wb,
                r_range: (m.r_ohm / ADAPT_RANGE, m.r_ohm * ADAPT_RANGE),
                flux_range: (m.flux_wb / FLUX_ADAPT_RANGE, m.flux_wb * FLUX_ADAPT_RANGE),
                l_h: m.l_h,
                pole_pairs: m.n(),
                half_ts: 0.5 * ts,
                gain: slots * ts / ADAPT_TIME_S,
                // A fifth of its time constant (50 ms): an electrical period down to 20 Hz.
                steady_checks: slot_cycles(ADAPT_TIME_S / 5.0).clamp(1, u16::MAX.into()) as u16,
                flux_min_omega_e: m.n()
                    * FLUX_ADAPT_MIN_SPEED
                    * self.ratings.speed_rpm
                    * RAD_S_PER_RPM,
                flux_max_r_share: FLUX_ADAPT_MAX_R_SHARE,
                flux_max_i_q_a: FLUX_ADAPT_MAX_R_SHARE * m.flux_wb / m.l_q_h(),
                flux_dead_time_v: self.dead_time_v(),
                flux_dead_time_i_a: hold_a,
            },
            catch: catch::Settings {
                v_min: m.emf_constant() * s.handback_rpm * RAD_S_PER_RPM,
                omega_m_per_v: 1.0 / m.emf_constant(),
                half_n_ts: 0.5 * m.n() * ts,
                timeout_checks: 5 * slot_cycles(h.lock_time_s).max(1),
            },
            catch_zero: catch_zero::Settings::new(
                &m,
                &catch_zero::From {
                    rate_hz: rate,
                    rated_torque_nm: self.ratings.torque_nm,
                    bus_v: self.ratings.bus_v,
                    handback_rpm: s.handback_rpm,
                    dead_time_s: self.power_stage.dead_time_s,
                    pwm_hz: self.power_stage.pwm_hz,
                    dead_time_band_a: self.power_stage.dead_time_band_a,
                    timeout_checks: 5 * slot_cycles(h.lock_time_s).max(1),
                },
            ),
            terminal_sensing: self.power_stage.terminal_sensing,
            // A salient motor's start (`inject.rs`), or why not.
            #[cfg(feature = "injection")]
            inject: self.inject_settings(ramp),
            #[cfg(feature = "identify")]
            identify: identify::Settings::new(
                &self.ratings,
                m.n(),
                m.torque,
                rate,
                self.current_bandwidth_hz,
                &self.identify,
            ),
            identify_offset_limit_a: 0.05 * l.i_sense_max_a,
            align: align::Settings {
                current_a: s.align_current_a,
                sixteenth: steps(s.align_time_s).div_ceil(16).max(1),
                rest_vq2: {
                    let rest_speed = align::REST_SPEED * self.ratings.speed_rpm * RAD_S_PER_RPM;
                    let emf_v = m.emf_constant() * rest_speed;
                    emf_v * emf_v
                },
            },
            open_loop: open_loop::Settings {
                current_a: s.open_loop_current_a,
                n_ts: m.n() * ts,
                handover_rpm: s.handover_rpm,
                timeout_checks: slot_cycles(
                    s.handover_rpm / s.accel_rpm_per_s + s.handover_timeout_s,
                )
                .max(1),
                pullout_checks: slot_cycles(h.lock_time_s).max(1),
                // 2π/(N T_check) rad/s in rpm: RPM_PER_RAD_S 2π rate/(N slots).
                turn_rpm_checks: RPM_PER_RAD_S * TAU * rate / (m.n() * slots),
                reverse_checks: slot_cycles(h.failover_time_s).max(1),
                handback_rpm: s.handback_rpm,
                held_below_rpm: if_held_below_rpm,
                ramp,
            },
            sensorless: sensorless::Settings {
                ramp,
                load_observer: self.load_observer_config().build()?,
                field_weakening: sensorless::FieldWeakening {
                    margin: FIELD_WEAKENING_MARGIN,
                    gain_a_per_v: 0.2 / (m.n() * self.ratings.speed_rpm * RAD_S_PER_RPM * m.l_h),
                    i_max_a: l.i_max_a,
                    // The minimum-voltage end `ψ_f/L_d`, `(R/(N L_d))²` (L_d: an inversely
                    // salient motor has no MTPA either; a salient one does not use it).
                    end: {
                        let psi_per_l_a = m.flux_wb / m.l_d_h();
                        let corner = m.r_ohm / (m.n() * m.flux_wb) * psi_per_l_a;
                        sensorless::VoltageEnd {
                            psi_per_l_a,
                            corner_rad2_s2: corner * corner,
                        }
                    },
                },
                mtpa,
                braking_max_a: mtpa.map_or(l.i_max_a, |m| m.torque_current_at_max()),
                // Five speed-loop time constants, 1/(2π f_speed) each: the speed loop takes the
                // torque over as the d current fades.
                handover_decay: 1.0 - slots * ts * TAU * self.speed_bandwidth_hz / 5.0,
                low_speed_d_a: hold_a,
                handback_rpm: s.handback_rpm,
                held_below_rpm: if_held_below_rpm,
                through_zero_rpm: s.handover_rpm,
                dead_time_rpm: hold_below_rpm,
                dead_time_stop_rpm: self.low_speed_hold_stopping_rpm(),
                stop_rpm: s.stop_rpm,
                // `FIELD_WEAKENING_MARGIN v_bus/(√3 N (ψ_f − L i_max))` per volt (`sensorless.rs`).
                overspeed_rpm_per_v: FIELD_WEAKENING_MARGIN * m.bus_limited_rpm(1.0) * m.flux_wb
                    / (m.flux_wb - m.l_h * l.i_max_a).max(0.5 * m.flux_wb),
                bus_filter: slots * ts / BUS_FILTER_S,
                overspeed_checks: slot_cycles(h.loss_time_s).max(1),
                stall: sensorless::Stall {
                    checks: slot_cycles(h.stall_time_s).max(1),
                    // The speed loop's output is a torque current (`crate::mtpa`): at the
                    // limit, on a salient motor, the MTPA's at the current limit.
                    i_limit_a: 0.99 * mtpa.map_or(l.i_max_a, |m| m.torque_current_at_max()),
                    gain_rpm: s.handback_rpm,
                },
                speed_gain: speed_gain::Settings::new(
                    self.ratings.speed_rpm,
                    self.speed_bandwidth_hz,
                    &m,
                ),
                regen: regen::Settings::new(
                    self.ratings.bus_v,
                    l.bus_max_v,
                    self.ratings.power_w,
                    m.torque.factor() * m.r_ohm,
                    m.torque_constant(),
                    l.i_max_a,
                ),
            },
            safe_state: safe_state::Settings::new(
                m.flux_wb,
                m.l_h,
                (l.i_max_a, l.i_trip_a, l.i_sense_max_a),
            ),
            supervision: supervision::Settings {
                lock_checks: slot_cycles(h.lock_time_s).max(1),
                failover_checks: slot_cycles(h.failover_time_s).max(1),
                reseed_checks: 2 * slot_cycles(h.lock_time_s).max(1),
                loss_checks: slot_cycles(h.loss_time_s).max(1),
                max_disagreement: h.max_disagreement_deg * RAD_PER_DEG,
                max_speed_disagreement_rpm: h.max_speed_disagreement_rpm,
            },
        })
    }
}

#[cfg(feature = "injection")]
impl DriveConfig {
    /// The injection start's settings (`inject.rs`), or why the drive declines it: the
    /// motor's saliency or the bus (`crate::injection`). The current scale is the
    /// rated-torque current, the rate the drive's, the update delay taken by the injection's
    /// normalisation; the speed estimate's low-pass a 5 ms time constant per millisecond (the
    /// speed loop's 20 Hz band passes it).
    pub(super) fn inject_settings(
        &self,
        ramp: Ramp,
    ) -> Result<super::inject::Settings, super::Declined> {
        let m = self
            .validate()
            .map_err(|_| super::Declined::Parameter("motor"))?;
        let steps = self
            .schedule()
            .map_err(|_| super::Declined::Parameter("rate_hz"))?
            .steps_per_tick();
        let injection = crate::injection::InjectionConfig {
            l_d_h: m.l_d_h(),
            l_q_h: m.l_q_h(),
            current_a: self.ratings.torque_nm / m.torque_constant(),
            bus_v: self.ratings.bus_v,
            rate_hz: self.rate_hz,
            v_loop: {
                let i_max = self.limits.i_max_a;
                let omega_e = m.n() * self.start.handover_rpm * RAD_S_PER_RPM;
                m.r_ohm * i_max + omega_e * (m.flux_wb + m.l_q_h() * i_max)
            },
            delay_periods: self.delay_periods(),
        }
        .build()?;
        Ok(super::inject::Settings {
            injection,
            inv_n: 1.0 / m.n(),
            handover_rpm: self.start.handover_rpm,
            ramp,
            speed_gain: 1.0 - libm::expf(-(1.0 / crate::schedule::TICK_HZ) / 0.005),
            hold: super::inject::HoldSettings::new(&m, injection.omega_o(), self.limits.i_max_a),
            steps_per_tick: steps,
            inv_steps: 1.0 / steps as f32,
        })
    }
}
