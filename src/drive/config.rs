//! The drive's configuration in SI units, its validation, and what it derives: the FOC gains,
//! the observers' settings, and each mode's per-step coefficients.

#[cfg(feature = "identify")]
use super::identify;
use super::identify::IdentifyConfig;
use super::open_loop;
use super::ramp::Ramp;
use super::supervision;
use super::{adaptation, align, catch, catch_zero, sensorless, Drive};
use crate::bounds::{ks_max_e2, ks_max_t};
use crate::dead_time::DeadTimeConfig;
use crate::foc::FocConfig;
use crate::load_observer::LoadObserverConfig;
use crate::math::INV_SQRT3;
use crate::motor::{Motor, MotorParams, Ratings};
use crate::observer::flux::FluxConfig;
use crate::observer::flux_speed::FluxPll;
use crate::observer::pll::PllConfig;
use crate::observer::sliding::{SlidingConfig, SlidingGain, SlidingObserver};
use crate::observer::Observer;
use crate::param::{Allowed, Checks, ParamError};
use crate::schedule::SLOTS;
use crate::units::{RAD_PER_DEG, RAD_S_PER_RPM};
use core::f32::consts::TAU;

/// The sliding observer's back-EMF angle and the controller's output angle lead the sample by
/// half a period of rotation: the middle of the period the voltage is held over.
const ADVANCE_PERIODS: f32 = 0.5;

/// Natural frequency \[Hz] and damping of the PLL on the flux observer's angle.
const PLL_BANDWIDTH_HZ: f32 = 50.0;
const PLL_DAMPING: f32 = 1.0;

/// The adapted resistance stays within R₀/3..3 R₀ (`adaptation.rs`): a copper winding from
/// −40 °C to 150 °C spans 1.75×, and a datasheet's line-to-line figure taken for the phase's
/// is 2× off.
const ADAPT_RANGE: f32 = 3.0;
/// The adapted flux linkage stays within ψ₀/1.5..1.5 ψ₀: NdFeB loses about 12 % per 100 K;
/// a back-EMF constant read as peak for RMS is √2 off.
const FLUX_ADAPT_RANGE: f32 = 1.5;
/// ψ_f's low-pass time constant \[s].
const FLUX_ADAPT_TIME_S: f32 = 0.25;
/// ψ_f is measured above this fraction of the rated speed (the hand-over's: a flux linkage
/// 15 % off must be corrected while the rotor is still slow, or both observers' residuals
/// reach their limit there, measured on Ortega's test motor) ...
const FLUX_ADAPT_MIN_SPEED: f32 = 0.1;
/// ... where `R |i_q|` is at most this share of the back-EMF: R just measured (within 1.2 % in
/// the robustness matrix) moves ψ_f by 0.4 % at most; a winding warmed 30 % since, by 9 %.
const FLUX_ADAPT_MAX_R_SHARE: f32 = 0.3;

/// Why the sliding torque observer was not built ([`DriveConfig::sliding_torque`]).
#[derive(Clone, Copy, Debug, PartialEq)]
enum SlidingRefused {
    /// Its constant `K_s` is outside the window of Horng & Chin Sec 4: at or above the
    /// discrete-time bound `(K_s,max)_T`, or above `(K_s,max)_E2` at the rated speed (where the
    /// unstable second equilibrium exists). The motor is run by the flux observer alone.
    KsWindow(ParamError),
    /// Another setting is invalid.
    Invalid(ParamError),
}

impl From<SlidingRefused> for ParamError {
    fn from(r: SlidingRefused) -> Self {
        match r {
            SlidingRefused::KsWindow(e) | SlidingRefused::Invalid(e) => e,
        }
    }
}

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
    /// (or the command, if lower; at once when the observer sees the rotor pulled out of the
    /// ramp) \[rpm]; the sliding observer drives only above it.
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

/// The board's power stage as the drive compensates it (see [`crate::dead_time`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PowerStageConfig {
    /// PWM (switching) frequency \[Hz], positive.
    pub pwm_hz: f32,
    /// Dead time per switching edge \[s], in `[0, 0.1/pwm_hz]`; 0 for no compensation.
    pub dead_time_s: f32,
    /// Width of the compensation's smooth sign \[A], > 0: a phase current of this or more
    /// gets the full `t_d·f_pwm`.
    pub dead_time_band_a: f32,
    /// The largest duty the board applies, in `(0.5 + t_d·f_pwm, 1]`: the voltage limit keeps
    /// every duty within `[1 − duty_max, duty_max]`
    /// ([`DeadTimeConfig::v_max_per_bus`](crate::dead_time::DeadTimeConfig::v_max_per_bus)).
    pub duty_max: f32,
    /// The board senses the terminal voltage while the PWM is off (phase-voltage dividers):
    /// an enable passing [`DriveInput::v_ab_terminal`](super::DriveInput) watches a
    /// coasting rotor with the PWM off (`catch.rs`); one without it aligns. `false`: the
    /// board has no such sensing (the B-G431B-ESC1's firmware passes none), and an enable
    /// first regulates the currents to zero to see whether the rotor turns, and catches it
    /// so (`catch_zero.rs`). Default true.
    pub terminal_sensing: bool,
}

/// Everything the drive is built from. [`DriveConfig::new`] derives it from a motor.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DriveConfig {
    /// The controller's motor model.
    pub motor: MotorParams,
    /// Step rate \[Hz] (4000).
    pub rate_hz: f32,
    /// Current-loop bandwidth \[Hz] (300).
    pub current_bandwidth_hz: f32,
    /// Speed-loop bandwidth \[Hz] (20), run every 4th step.
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
}

impl DriveConfig {
    /// Defaults from the motor's ratings: current command limit 1.5× the current of rated
    /// torque, trip at 1.5× that, sensing range 2× the trip; bus trips at 0.75 and 1.25 of the
    /// rated bus; align and open-loop currents the rated-torque current (they hold the rotor
    /// against an active load of half rated torque at 30° of load angle) for 0.2 s and up the
    /// ramp; the ramp climbs the rated speed in a second; hand-over at 10 %
    /// of rated speed; hand-back (without a healthy observer) below 6 %; stopped below 2 %;
    /// an observer healthy after 20 ms of mean residual below ¼, lost after 3 ms at ½;
    /// observer loss after 20 ms without a healthy one or of 30° or 10 % of rated speed
    /// contradiction; stall after 0.5 s of open loop without lock or 0.1 s at the current
    /// limit below half the speed reference. The power stage is the B-G431B-ESC1's (20 kHz
    /// PWM, 500 ns dead time); the dead-time
    /// compensation's smooth sign reaches full at 5 % of the rated-torque current: five
    /// standard deviations of the 1 %-of-rated-current noise a board's sensing has
    /// (`DESIGN.md`), so noise at a zero crossing moves the compensation by a fifth of it
    /// per sample, not from one sign to the other; and a phase current of rated-torque
    /// amplitude is below the band only 3 % of an electrical turn (|sin| < 0.05).
    pub fn new(motor: &Motor) -> Self {
        let i_rated = motor.rated_torque_current_a();
        let i_max = 1.5 * i_rated;
        let i_trip = 1.5 * i_max;
        let bus = motor.ratings.bus_v;
        let speed = motor.ratings.speed_rpm;
        Self {
            motor: motor.params,
            rate_hz: 4000.0,
            current_bandwidth_hz: 300.0,
            speed_bandwidth_hz: 20.0,
            limits: Limits {
                i_max_a: i_max,
                i_trip_a: i_trip,
                i_sense_max_a: 2.0 * i_trip,
                bus_min_v: 0.75 * bus,
                bus_max_v: 1.25 * bus,
            },
            start: StartConfig {
                align_current_a: i_rated,
                align_time_s: 0.2,
                open_loop_current_a: i_rated,
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
                pwm_hz: 20_000.0,
                dead_time_s: 500e-9,
                dead_time_band_a: 0.05 * i_rated,
                duty_max: 1.0,
                terminal_sensing: true,
            },
            ratings: motor.ratings,
            // The drive's own sensing range; a board sets its own.
            identify: IdentifyConfig {
                sense_range_a: 2.0 * i_trip,
                sense_lsb_a: 0.0,
            },
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

    /// Horng & Chin's torque observer with the paper's settings (Sec 5) at the drive's rate,
    /// its `K_s` checked inside its bounds (Sec 4): below the discrete-time bound
    /// `(K_s,max)_T` and below `(K_s,max)_E2` at the rated speed. E2 grows with speed: the
    /// paper's constant K_s = 1000π exceeds it below about 620 rpm on the Sinano motor, where
    /// the (always unstable) second equilibrium exists, as in the paper's own experiment.
    pub fn sliding_torque(&self) -> Result<SlidingObserver, ParamError> {
        self.checked_sliding(self.sliding_config())
            .map_err(ParamError::from)
    }

    /// The sliding observer as a monitor: [`DriveConfig::sliding_torque`], or, for a motor
    /// whose `K_s` window is empty, the observer built never to drive nor be judged
    /// (`min_speed_rad_s` infinite): the flux observer runs alone ([`Derived::warnings`]
    /// says so).
    ///
    /// [`Derived::warnings`]: super::Derived::warnings
    pub fn sliding_monitor(&self) -> Result<SlidingObserver, ParamError> {
        match self.checked_sliding(self.sliding_config()) {
            Ok(observer) => Ok(observer),
            Err(SlidingRefused::KsWindow(_)) => SlidingConfig {
                min_speed_rad_s: f32::INFINITY,
                ..self.sliding_config()
            }
            .build(),
            Err(SlidingRefused::Invalid(e)) => Err(e),
        }
    }

    /// `cfg` built, its `K_s` checked inside its window (see [`DriveConfig::sliding_torque`]).
    fn checked_sliding(&self, cfg: SlidingConfig) -> Result<SlidingObserver, SlidingRefused> {
        let m = self.validate().map_err(SlidingRefused::Invalid)?;
        if let SlidingGain::Constant(ks) = cfg.ks {
            let eps = cfg.epsilon_a;
            let rated = self.ratings.speed_rpm * RAD_S_PER_RPM;
            let e2 = ks_max_e2(&m, rated, eps);
            let window = |e: ParamError| SlidingRefused::KsWindow(e);
            Allowed::strictly_between(0.0, ks_max_t(&m, self.rate_hz, eps))
                .because("(K_s,max)_T")
                .check("ks", ks)
                .map_err(window)?;
            Allowed::above_up_to(0.0, e2)
                .because("(K_s,max)_E2 at rated speed")
                .check("ks", ks)
                .map_err(window)?;
        }
        cfg.build().map_err(SlidingRefused::Invalid)
    }

    /// Ortega et al.'s flux observer, γ recommended for the lowest sensorless speed
    /// (`handback_rpm`, Proposition 4), with a 50 Hz critically damped PLL run at the speed
    /// loop's rate (1 kHz).
    pub fn flux_pll(&self) -> Result<FluxPll, ParamError> {
        let m = self.validate()?;
        let flux = self.flux_config().build()?;
        let pll = self.pll_config().build()?;
        Ok(FluxPll::new(flux, pll, m.n()))
    }

    /// The sliding torque observer's settings (unvalidated): it drives above the hand-over
    /// speed.
    pub(super) fn sliding_config(&self) -> SlidingConfig {
        SlidingConfig {
            rate_hz: self.rate_hz,
            emf_advance_periods: ADVANCE_PERIODS,
            min_speed_rad_s: self.start.handover_rpm * RAD_S_PER_RPM,
            ..SlidingConfig::torque(self.motor)
        }
    }

    /// The flux observer's settings (unvalidated).
    pub(super) fn flux_config(&self) -> FluxConfig {
        FluxConfig::new(self.motor, self.rate_hz, self.start.handback_rpm)
    }

    /// The PLL's settings (unvalidated).
    pub(super) fn pll_config(&self) -> PllConfig {
        PllConfig {
            rate_hz: self.rate_hz / SLOTS as f32,
            bandwidth_hz: PLL_BANDWIDTH_HZ,
            damping: PLL_DAMPING,
        }
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
    /// its bandwidth a fifth of the PLL's (10 Hz): it works on the PLL's speed estimate, whose
    /// phase lag must stay small at its bandwidth (22° at a fifth of the PLL's natural
    /// frequency, 43° at 20 Hz, where the speed loop with it oscillated on Ortega's test
    /// motor after a flying start) (unvalidated).
    pub(super) fn load_observer_config(&self) -> LoadObserverConfig {
        LoadObserverConfig {
            j_kgm2: self.motor.j_kgm2,
            b_nms: self.motor.b_nms,
            torque_constant: self.motor.torque_constant(),
            bandwidth_hz: PLL_BANDWIDTH_HZ / 5.0,
            rate_hz: self.rate_hz / SLOTS as f32,
        }
    }

    /// The FOC's settings (unvalidated).
    pub(super) fn foc_config(&self) -> FocConfig {
        FocConfig {
            current_bandwidth_hz: self.current_bandwidth_hz,
            speed_bandwidth_hz: self.speed_bandwidth_hz,
            current_rate_hz: self.rate_hz,
            speed_divider: SLOTS,
            angle_advance_periods: ADVANCE_PERIODS,
            dead_time: self.dead_time_config(),
            ..FocConfig::new(self.motor, self.limits.i_max_a)
        }
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

    /// Validates every setting and derives the FOC gains and each mode's coefficients;
    /// `primary` feeds the controller, `monitor` watches it. The error names the bad field.
    pub fn build<P: Observer, M: Observer>(
        &self,
        primary: P,
        monitor: M,
    ) -> Result<Drive<P, M>, ParamError> {
        let m = self.validate()?;
        let rate = self.rate_hz;
        let (l, s, h) = (self.limits, self.start, self.health);
        let foc = self.foc_config().build()?;
        let ts = 1.0 / rate;
        let steps = |t: f32| (t * rate) as u32;
        let slot_cycles = |t: f32| (t * rate / SLOTS as f32) as u32;
        let ramp = Ramp {
            max_rpm: self.ratings.speed_rpm,
            step_rpm: s.accel_rpm_per_s * ts * SLOTS as f32,
        };
        Ok(Drive {
            primary,
            monitor,
            foc,
            limits: l,
            adaptation: adaptation::Settings {
                r0_ohm: m.r_ohm,
                flux0_wb: m.flux_wb,
                r_range: (m.r_ohm / ADAPT_RANGE, m.r_ohm * ADAPT_RANGE),
                flux_range: (m.flux_wb / FLUX_ADAPT_RANGE, m.flux_wb * FLUX_ADAPT_RANGE),
                l_h: m.l_h,
                pole_pairs: m.n(),
                half_ts: 0.5 * ts,
                flux_gain: SLOTS as f32 * ts / FLUX_ADAPT_TIME_S,
                // A fifth of its time constant (50 ms): an electrical period down to 20 Hz.
                steady_checks: slot_cycles(FLUX_ADAPT_TIME_S / 5.0).clamp(1, u16::MAX.into())
                    as u16,
                flux_min_omega_e: m.n()
                    * FLUX_ADAPT_MIN_SPEED
                    * self.ratings.speed_rpm
                    * RAD_S_PER_RPM,
                flux_max_r_share: FLUX_ADAPT_MAX_R_SHARE,
            },
            catch: catch::Settings {
                v_min: m.torque_constant() * s.handback_rpm * RAD_S_PER_RPM,
                omega_m_per_v: 1.0 / m.torque_constant(),
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
            #[cfg(feature = "identify")]
            identify: identify::Settings::new(
                &self.ratings,
                m.n(),
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
                    let emf_v = m.torque_constant() * rest_speed;
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
                reverse_checks: slot_cycles(h.failover_time_s).max(1),
                handback_rpm: s.handback_rpm,
                ramp,
            },
            sensorless: sensorless::Settings {
                ramp,
                load_observer: self.load_observer_config().build()?,
                field_weakening: sensorless::FieldWeakening {
                    margin: 0.95,
                    gain_a_per_v: 0.2 / (m.n() * self.ratings.speed_rpm * RAD_S_PER_RPM * m.l_h),
                    i_max_a: l.i_max_a,
                },
                // Five speed-loop time constants, 1/(2π f_speed) each: the speed loop takes the
                // torque over as the d current fades.
                handover_decay: 1.0 - SLOTS as f32 * ts * TAU * self.speed_bandwidth_hz / 5.0,
                handback_rpm: s.handback_rpm,
                stop_rpm: s.stop_rpm,
                overspeed_rpm: m.bus_limited_rpm(l.bus_max_v),
                overspeed_checks: slot_cycles(h.loss_time_s).max(1),
                stall: sensorless::Stall {
                    checks: slot_cycles(h.stall_time_s).max(1),
                    i_limit_a: 0.99 * l.i_max_a,
                    gain_rpm: s.handback_rpm,
                },
            },
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
