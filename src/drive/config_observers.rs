//! The observers' settings from the drive's configuration: Horng & Chin's sliding torque
//! observer with its `K_s` checked inside its window (Sec 4), Ortega et al.'s flux observer
//! with the PLL on its angle.

use super::DriveConfig;
use crate::bounds::{ks_max_e2, ks_max_t};
use crate::math::min;
use crate::motor::MotorParams;
use crate::observer::flux::FluxConfig;
use crate::observer::flux_speed::FluxPll;
use crate::observer::pll::PllConfig;
use crate::observer::sliding::{SlidingConfig, SlidingGain, SlidingObserver};
use crate::param::{Allowed, ParamError};
use crate::units::RAD_S_PER_RPM;
use core::f32::consts::TAU;

/// The sliding observer's back-EMF angle leads the sample by half a period of rotation: the
/// middle of the period between two samples (the back-EMF's mean over it). The controller's
/// output angle leads it by this plus the update delay in periods
/// ([`PowerStageConfig::update_delay_s`]): the middle of the period the voltage is applied
/// over.
pub(super) const ADVANCE_PERIODS: f32 = 0.5;

/// Natural frequency \[Hz] and damping of the PLL on the flux observer's angle, with the
/// speed loop at its default bandwidth [`SPEED_BANDWIDTH_HZ`] or faster ([`pll_bandwidth_hz`]).
pub(super) const PLL_BANDWIDTH_HZ: f32 = 50.0;
pub(super) const PLL_DAMPING: f32 = 1.0;

/// The speed loop's default bandwidth \[Hz] ([`default_speed_bandwidth_hz`]).
pub(super) const SPEED_BANDWIDTH_HZ: f32 = 20.0;

/// The most torque-command current the speed loop may make of each ampere of current-sensor
/// noise ([`speed_noise_gain`]): at the 1 %-of-rated-current noise a board's sensing has
/// (`DESIGN.md`) the command's noise then stays within 10 % of the rated current, three
/// standard deviations within 30 %, clear of the current limit (150 %). Measured on the
/// zoo: the Brusa HSM1 (gain 41 at 20/50 Hz) saturated its torque command at ±1.5× rated
/// at 3 % speed on that noise, its mean speed 10–16 % low; every other zoo motor is below 1.2.
pub(super) const SPEED_NOISE_GAIN_MAX: f32 = 10.0;

/// The PLL's natural frequency \[Hz] for a speed loop of `speed_bandwidth_hz`: the paper's
/// [`PLL_BANDWIDTH_HZ`] with the default speed loop or a faster one; with a slower one lowered
/// with it, at the same ratio (2.5): the speed estimate filtered at the pace the speed loop
/// needs. An unusable `speed_bandwidth_hz` leaves the paper's (the FOC's check names it).
pub(super) fn pll_bandwidth_hz(speed_bandwidth_hz: f32) -> f32 {
    if speed_bandwidth_hz > 0.0 && speed_bandwidth_hz < SPEED_BANDWIDTH_HZ {
        PLL_BANDWIDTH_HZ * speed_bandwidth_hz / SPEED_BANDWIDTH_HZ
    } else {
        PLL_BANDWIDTH_HZ
    }
}

/// The speed loop's noise gain: torque-command current per ampere of current-sensor noise
/// \[A/A], through the flux observer's angle (its flux estimate `λ − L_q i` carries the
/// noise as `L_q σ_i`, the angle as `σ_θ = L_q σ_i/ψ_f` rad electrical), the PLL's
/// proportional path (speed `2ζω_n σ_θ/N` rad/s mechanical) and the speed PI's proportional
/// gain `J ω_s/K_t` (`crate::foc`):
/// `G = 2ζ ω_n · J ω_s/K_t · L_q/(N ψ_f)`, with ω_n, ω_s in rad/s.
pub(super) fn speed_noise_gain(
    m: &MotorParams,
    speed_bandwidth_hz: f32,
    pll_bandwidth_hz: f32,
) -> f32 {
    let kp_speed = m.j_kgm2 * TAU * speed_bandwidth_hz / m.torque_constant();
    2.0 * PLL_DAMPING * TAU * pll_bandwidth_hz * kp_speed * m.l_q_h() / (m.n() * m.flux_wb)
}

/// The speed loop's default bandwidth \[Hz] for the motor: [`SPEED_BANDWIDTH_HZ`], lowered
/// where the speed loop's noise gain there ([`speed_noise_gain`], with the PLL at
/// [`PLL_BANDWIDTH_HZ`]) exceeds [`SPEED_NOISE_GAIN_MAX`]. The gain goes with the product of
/// the two bandwidths and the PLL follows the speed loop ([`pll_bandwidth_hz`]), so both
/// are lowered by `√(G_max/G)`, keeping the speed loop's phase margin (their ratio).
pub(super) fn default_speed_bandwidth_hz(m: &MotorParams) -> f32 {
    let gain = speed_noise_gain(m, SPEED_BANDWIDTH_HZ, PLL_BANDWIDTH_HZ);
    if gain > SPEED_NOISE_GAIN_MAX {
        SPEED_BANDWIDTH_HZ * crate::math::sqrt_call(SPEED_NOISE_GAIN_MAX / gain)
    } else {
        SPEED_BANDWIDTH_HZ
    }
}
/// The plain PLL's phase lag \[rad] under the motor's largest acceleration above which it is
/// aided ([`DriveConfig::pll_aided`]): π, where its phase error, wrapped to ±π, turns
/// ambiguous and the loop slips a cycle. Below it the plain loop lags but recovers, and
/// filters the angle's noise at its ω_n, which the aided loop's feed-forward does not
/// (measured on the zoo with π/4: the two Anaheim motors and the Teknic, 1.4 to 2.3 rad,
/// lost 17 cells to the feed-forward's noise at 3 % speed).
pub(super) const PLL_LAG_MAX: f32 = core::f32::consts::PI;

/// The sliding torque observer's lag under the motor's largest acceleration, `α/(λθ λω)`
/// \[rad], above which its two fast eigenvalues are raised ([`DriveConfig::sliding_config`]):
/// the paper's own margin, 2.73 rad on its Sinano motor at the drive's current limit (1.5 ×
/// the rated-torque current, `α` = 64 650 rad/s² electrical) with its λθ = 10 Hz, λω = 60 Hz
/// (`λθ λω` = 23 687 rad²/s²), rounded up so that the paper's motor keeps the paper's gains.
pub(super) const SLIDING_LAG_MAX: f32 = 2.75;

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

impl DriveConfig {
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
    /// (`handback_rpm`, Proposition 4; of a salient motor for its active flux,
    /// [`DriveConfig::flux_config`]), with a 50 Hz critically damped PLL run at the speed
    /// loop's rate (1 kHz).
    pub fn flux_pll(&self) -> Result<FluxPll, ParamError> {
        let m = self.validate()?;
        let flux = self.flux_config().build()?;
        let pll = self.pll_config().build()?;
        let pll = if self.pll_aided() { pll.aided() } else { pll };
        Ok(FluxPll::new(flux, pll, m.n()))
    }

    /// The largest electrical acceleration \[rad/s²] the current limit gives the unloaded
    /// rotor: `N · c N ψ_f i_max / J`.
    pub fn max_acceleration_e(&self) -> f32 {
        let m = &self.motor;
        m.n() * m.torque_constant() * self.limits.i_max_a / m.j_kgm2
    }

    /// Whether the PLL on the flux observer's angle is aided by the angle's own turn (its
    /// feed-forward, `observer::pll` "Aided"): where the plain PLL's phase lag `α/ω_n²` under
    /// the motor's largest acceleration ([`DriveConfig::max_acceleration_e`]) would reach
    /// `PLL_LAG_MAX`.
    pub fn pll_aided(&self) -> bool {
        let (_, ki) = self.pll_config().gains();
        self.max_acceleration_e() > PLL_LAG_MAX * ki
    }

    /// The sliding torque observer's settings (unvalidated): it drives above the hand-over
    /// speed. The paper's `K_s` = 1000π and ε = 1 A where that `K_s` lies inside this motor's
    /// window (Sec 4: below `(K_s,max)_T` and `(K_s,max)_E2` at the rated speed); else both
    /// scaled from the motor as the paper placed them on its own (`scaled_sliding`).
    ///
    /// Its eigenvalues are the paper's (Sec 5: λθ = 10, λω = 60, λτ = 2 Hz) where they follow
    /// the motor's largest acceleration `α` ([`DriveConfig::max_acceleration_e`]) as they
    /// follow the paper's motor: a torque step the observer does not know yet (a load, before
    /// λτ takes it up) leaves its speed estimate behind by about `α/λω` and its angle by
    /// `α/(λθ λω)` \[rad], whatever `K_s`, which sets only the sliding mode's reach (Sec 4).
    /// Where that lag is above the paper's, `SLIDING_LAG_MAX` (2.75 rad), λθ and λω are raised
    /// together (their ratio kept) by `k = √(α/(SLIDING_LAG_MAX λθ λω))`, up to λω at half the current
    /// loop's bandwidth (the observer's estimate is the current loop's frame; a faster one
    /// brings the current-sensor noise into it). Measured on the zoo (issue #26): the Anaheim
    /// BLY171D (`α` 1.4e5 rad/s², 2.2 × the paper's) lost lock under rated torque applied at
    /// once at 2,000 rpm, the angle 91° behind 11 ms after the step while the flux monitor
    /// stayed within 1°; with λθ, λω × 1.47 it holds it (`sup-load-steps-50`). Uncapped, the
    /// Nanotec DF45's `k` = 7.6 (λω 460 Hz) let the noise through: overcurrent at 3 % speed.
    pub fn sliding_config(&self) -> SlidingConfig {
        let mut paper = SlidingConfig {
            rate_hz: self.rate_hz,
            emf_advance_periods: ADVANCE_PERIODS,
            output_advance_periods: ADVANCE_PERIODS + self.delay_periods(),
            min_speed_rad_s: self.start.handover_rpm * RAD_S_PER_RPM,
            ..SlidingConfig::torque(self.motor)
        };
        let lambdas = TAU * TAU * paper.lambda_theta_hz * paper.lambda_omega_hz;
        let k2 = self.max_acceleration_e() / (SLIDING_LAG_MAX * lambdas);
        let cap = 0.5 * self.current_bandwidth_hz / paper.lambda_omega_hz;
        // (False for a NaN: an unusable motor keeps the paper's, which its check names.)
        if k2 > 1.0 && cap > 1.0 {
            let k = min(crate::math::sqrt_call(k2), cap);
            paper.lambda_theta_hz *= k;
            paper.lambda_omega_hz *= k;
        }
        match paper.ks {
            SlidingGain::Constant(ks) if ks > self.ks_window(paper.epsilon_a) => {
                scaled_sliding(paper, self.ratings.current_a, |eps| self.ks_window(eps))
            }
            _ => paper,
        }
    }

    /// The top of the `K_s` window for the boundary layer `epsilon_a` \[A]:
    /// `min((K_s,max)_T, (K_s,max)_E2 at the rated speed)` \[A/s] (Horng & Chin Sec 4).
    fn ks_window(&self, epsilon_a: f32) -> f32 {
        let rated = self.ratings.speed_rpm * RAD_S_PER_RPM;
        let e2 = ks_max_e2(&self.motor, rated, epsilon_a);
        let t = ks_max_t(&self.motor, self.rate_hz, epsilon_a);
        if e2 < t {
            e2
        } else {
            t
        }
    }

    /// The flux observer's settings (unvalidated): γ for ψ_f at the hand-back speed, or, on a
    /// salient motor with MTPA, for the active flux of the MTPA's currents at the current
    /// limit (the low speeds' largest, `FluxConfig::for_active_flux_up_to`).
    pub fn flux_config(&self) -> FluxConfig {
        let c = FluxConfig::new(self.motor, self.rate_hz, self.start.handback_rpm);
        match self.mtpa_of(&self.motor) {
            Some(m) => c.for_active_flux_up_to(self.motor.flux_wb * m.active_flux_ratio_at_max()),
            None => c,
        }
    }

    /// The PLL's settings (unvalidated).
    pub fn pll_config(&self) -> PllConfig {
        PllConfig {
            rate_hz: self.rate_hz / self.steps_per_tick(),
            bandwidth_hz: pll_bandwidth_hz(self.speed_bandwidth_hz),
            damping: PLL_DAMPING,
        }
    }
}

/// The paper's boundary layer over its motor's rated current: ε = 1 A on the Sinano's 3 A
/// (Horng & Chin Sec 5, Table 1; the preset's rating).
pub(super) const EPSILON_PER_RATED_A: f32 = 1.0 / 3.0;

/// The paper's `K_s` over the top of its window: 1000π of `(K_s,max)_E2` = 5331.46 A/s
/// (Sec 5, E2 binding at 1000 rpm; `(K_s,max)_T` = 7590).
pub(super) const KS_PER_WINDOW: f32 = 1000.0 * core::f32::consts::PI / 5331.46;

/// The sliding observer scaled to a motor on which the paper's constant `K_s` is refused:
/// ε the paper's share of the rated current `rated_a` (a boundary layer of 1 A is twice the
/// rated current of a 0.5 A gimbal motor, and its `R ε/L` alone closes the E2 window), and
/// `K_s` at the paper's place in the window `top(ε)` (`KS_PER_WINDOW` of it): inside both
/// upper bounds, `K_s,min` of eq (28) covered up to an EMF error of `KS_PER_WINDOW` of the
/// window's. On the Sinano both are the paper's own (ε = 1 A, K_s = 1000π).
fn scaled_sliding(paper: SlidingConfig, rated_a: f32, top: impl Fn(f32) -> f32) -> SlidingConfig {
    let epsilon_a = EPSILON_PER_RATED_A * rated_a;
    let ks = KS_PER_WINDOW * top(epsilon_a);
    if ks > 0.0 && epsilon_a > 0.0 {
        SlidingConfig {
            epsilon_a,
            ks: SlidingGain::Constant(ks),
            ..paper
        }
    } else {
        // No window on this motor either: the paper's, refused by the check, named.
        paper
    }
}
