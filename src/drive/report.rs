//! What the drive derives from its configuration, for `pmsm-sim gains` and a board's start-up
//! log: every gain and limit, from the same functions the drive is built with, as a struct
//! and as named rows with units and formulas, and the warnings of a configuration that builds
//! but will struggle.

use super::DriveConfig;
use crate::bounds::{ks_max_e2, ks_max_t};
use crate::foc::FocGains;
use crate::observer::flux::{gamma_max_discrete, gamma_max_single_equilibrium};
use crate::observer::sliding::SlidingGain;
use crate::param::ParamError;
use crate::units::RAD_S_PER_RPM;
use core::f32::consts::SQRT_2;

/// Every gain and limit of a drive (SI units; speeds mechanical).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Derived {
    /// Current-loop bandwidth ω_c/2π \[Hz] and the speed loop's ω_s/2π \[Hz]: the PI inputs.
    pub current_bandwidth_hz: f32,
    /// Speed-loop bandwidth \[Hz].
    pub speed_bandwidth_hz: f32,
    /// The current and speed PI gains.
    pub foc: FocGains,
    /// Sliding gain `K_s` \[A/s] (Horng & Chin Sec 5: 1000π).
    pub ks_a_per_s: f32,
    /// Boundary layer ε \[A].
    pub epsilon_a: f32,
    /// `(K_s,max)_T = ε(2/T − R/L)` \[A/s] at the step rate.
    pub ks_max_t_a_per_s: f32,
    /// `(K_s,max)_E2 = (√2 K N |ω| − R ε)/L` \[A/s] at the rated speed.
    pub ks_max_e2_rated_a_per_s: f32,
    /// `(K_s,max)_E2` at the hand-over speed \[A/s].
    pub ks_max_e2_handover_a_per_s: f32,
    /// The speed above which `K_s ≤ (K_s,max)_E2`: below it the (unstable) second
    /// equilibrium exists \[rpm].
    pub ks_e2_speed_rpm: f32,
    /// Flux observer gain γ \[1/(Wb²·s)] (Ortega et al. eq (9)).
    pub gamma: f32,
    /// `γ_max = 2/(Φ² T)` of the discrete step \[1/(Wb²·s)].
    pub gamma_max_discrete: f32,
    /// `γ_max = 4 n_P |ω|/Φ²` for one equilibrium at the hand-back speed (Proposition 4)
    /// \[1/(Wb²·s)].
    pub gamma_max_single_equilibrium: f32,
    /// PLL gains `Kp = 2ζω_n` \[1/s] and `Ki = ω_n²` \[1/s²].
    pub pll_kp: f32,
    /// See `pll_kp`.
    pub pll_ki: f32,
    /// The PLL's natural frequency \[Hz] and damping, the inputs of its gains.
    pub pll_bandwidth_hz: f32,
    /// See `pll_bandwidth_hz`.
    pub pll_damping: f32,
    /// Hand-over to the observer above this speed \[rpm].
    pub handover_rpm: f32,
    /// Back to open loop below this speed \[rpm].
    pub handback_rpm: f32,
    /// The speed whose back-EMF `N ψ_f ω` equals `bus_min_v/√3` \[rpm]: the most the lowest
    /// bus drives.
    pub bus_limited_rpm: f32,
    /// The current of rated torque, `τ/(N ψ_f)` \[A].
    pub rated_torque_current_a: f32,
    /// The speed loop's current limit, the trip level and the sensing range \[A].
    pub i_max_a: f32,
    /// Phase-current trip \[A].
    pub i_trip_a: f32,
    /// Sensing range \[A].
    pub i_sense_max_a: f32,
    /// Align and open-loop currents \[A].
    pub align_current_a: f32,
    /// Open-loop (I/f) current \[A].
    pub open_loop_current_a: f32,
    /// The dead time's average pole-voltage error on the rated bus, `t_d·f_pwm·V_bus` \[V]
    /// (Choi & Sul; what the compensation adds per phase, [`crate::dead_time`]).
    pub dead_time_voltage_v: f32,
    /// The largest phase voltage the current loop commands on the rated bus,
    /// `(1 − 2·t_d·f_pwm)·V_bus/√3` \[V]: SVPWM's `V_bus/√3` less the room the dead-time
    /// compensation needs ([`crate::dead_time::DeadTimeConfig::v_max_per_bus`]).
    pub v_max_v: f32,
    /// The voltage rated torque at rated speed needs, `|R i + jω_e(L i) + ω_e ψ_f|` \[V].
    pub v_rated_point_v: f32,
    /// The speed up to which the rated bus drives rated torque, field weakening included
    /// (`DriveConfig::torque_speed_limit_rpm`) \[rpm]: below rated speed, the derating.
    pub rated_torque_speed_rpm: f32,
    /// What will struggle, each once.
    pub warnings: [Option<Warning>; 4],
}

/// A setting the drive accepts but will struggle with: the setting, its value, the limit it
/// breaks, and what happens.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Warning {
    /// The user's field.
    pub field: &'static str,
    /// Its value.
    pub value: f32,
    /// The limit it breaks.
    pub limit: f32,
    /// What happens beyond the limit.
    pub what: &'static str,
}

impl DriveConfig {
    /// Every gain and limit the drive derives; the configuration is validated first (the
    /// error names the field, its value and its range).
    pub fn derived(&self) -> Result<Derived, ParamError> {
        let m = self.validate()?;
        let (l, s) = (self.limits, self.start);
        let kt = m.torque_constant();
        let sliding = self.sliding_config();
        let ks = match sliding.ks {
            SlidingGain::Constant(k) => k,
            SlidingGain::PerSpeed { min, .. } => min,
        };
        let eps = sliding.epsilon_a;
        let rpm = |omega_m: f32| omega_m / RAD_S_PER_RPM;
        // (K_s,max)_E2 = K_s solved for the speed.
        let ks_e2_speed_rpm = rpm((ks * m.l_h + m.r_ohm * eps) / (SQRT_2 * m.emf_constant()));
        let pll = self.pll_config();
        let (pll_kp, pll_ki) = pll.gains();
        let i_rated = self.ratings.torque_nm / kt;
        let dead_time = self.dead_time_config();
        let v_max = self.ratings.bus_v * dead_time.v_max_per_bus();
        let speed_rated = self.ratings.speed_rpm * RAD_S_PER_RPM;
        let v_rated_point = voltage(&m, i_rated, speed_rated);
        let rated_torque_speed_rpm =
            self.torque_speed_limit_rpm(self.ratings.torque_nm, self.ratings.bus_v);
        let rate = self.rate_choice();
        let warnings = [
            (s.handover_rpm < ks_e2_speed_rpm).then_some(Warning {
                field: "start.handover_rpm",
                value: s.handover_rpm,
                limit: ks_e2_speed_rpm,
                what: "below this speed K_s is above (K_s,max)_E2: the sliding observer's \
                       unstable second equilibrium exists (Horng & Chin Sec 4)",
            }),
            // K_s outside its window: the sliding observer cannot be trusted anywhere.
            self.sliding_torque().err().map(|e| Warning {
                field: "ks",
                value: e.value,
                limit: if e.value > e.allowed.max {
                    e.allowed.max
                } else {
                    e.allowed.min
                },
                what: "outside its window (Horng & Chin Sec 4): the sliding observer never \
                       drives; the flux observer runs alone (build_flux_primary), a sliding \
                       primary is refused",
            }),
            (rated_torque_speed_rpm < self.ratings.speed_rpm).then_some(Warning {
                field: "ratings.speed_rpm",
                value: self.ratings.speed_rpm,
                limit: rated_torque_speed_rpm,
                what: "derated: above this speed rated torque does not fit the largest phase \
                       voltage (bus_v/sqrt(3) less the dead time's) even with field weakening \
                       within i_max; the drive holds less torque there (telemetry `derated`)",
            }),
            // Fewer than 20 samples per electrical period at rated speed (`crate::rate`).
            (self.rate_hz < rate.wanted_hz).then_some(Warning {
                field: "rate_hz",
                value: self.rate_hz,
                limit: rate.wanted_hz,
                what: match rate.bound {
                    Some(b) if rate.rate_hz >= self.rate_hz => b.what(),
                    _ => {
                        "below 20 samples per electrical period at rated speed (20 N n/60): \
                         the configuration's rate would give more"
                    }
                },
            }),
        ];
        Ok(Derived {
            current_bandwidth_hz: self.current_bandwidth_hz,
            speed_bandwidth_hz: self.speed_bandwidth_hz,
            foc: self.foc_config().gains(),
            ks_a_per_s: ks,
            epsilon_a: eps,
            ks_max_t_a_per_s: ks_max_t(&m, self.rate_hz, eps),
            ks_max_e2_rated_a_per_s: ks_max_e2(&m, speed_rated, eps),
            ks_max_e2_handover_a_per_s: ks_max_e2(&m, s.handover_rpm * RAD_S_PER_RPM, eps),
            ks_e2_speed_rpm,
            gamma: self.flux_config().gamma,
            gamma_max_discrete: gamma_max_discrete(m.flux_wb, self.rate_hz),
            gamma_max_single_equilibrium: gamma_max_single_equilibrium(
                m.flux_wb,
                m.n(),
                s.handback_rpm * RAD_S_PER_RPM,
            ),
            pll_kp,
            pll_ki,
            pll_bandwidth_hz: pll.bandwidth_hz,
            pll_damping: pll.damping,
            handover_rpm: s.handover_rpm,
            handback_rpm: s.handback_rpm,
            bus_limited_rpm: m.bus_limited_rpm(l.bus_min_v),
            rated_torque_current_a: i_rated,
            i_max_a: l.i_max_a,
            i_trip_a: l.i_trip_a,
            i_sense_max_a: l.i_sense_max_a,
            align_current_a: s.align_current_a,
            open_loop_current_a: s.open_loop_current_a,
            dead_time_voltage_v: dead_time.duty() * self.ratings.bus_v,
            v_max_v: v_max,
            v_rated_point_v: v_rated_point,
            rated_torque_speed_rpm,
            warnings,
        })
    }
}

/// One line of [`Derived::rows`]: what it is, its value and unit, and how it follows from the
/// configuration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DerivedRow {
    /// What it is.
    pub name: &'static str,
    /// Its value, in `unit`.
    pub value: f32,
    /// Its unit.
    pub unit: &'static str,
    /// The papers' formula, or the setting it is (its symbols are the motor's parameters and
    /// the configuration's inputs).
    pub formula: &'static str,
    /// For a setting: the quantity it is chosen against, and that quantity's value.
    pub of: Option<(&'static str, f32)>,
}

impl Derived {
    /// Every gain and limit as a named row, in the order of a report; `config` is the one
    /// these were derived from (its ratings and power stage name the settings' references).
    pub fn rows(&self, config: &DriveConfig) -> [DerivedRow; 29] {
        let row = |name, value, unit, formula| DerivedRow {
            name,
            value,
            unit,
            formula,
            of: None,
        };
        let setting = |name, value, unit, formula, of: (&'static str, f32)| DerivedRow {
            of: Some(of),
            ..row(name, value, unit, formula)
        };
        let rated_speed = ("rated speed", config.ratings.speed_rpm);
        let rated_current = ("rated-torque current", self.rated_torque_current_a);
        let gamma_limit = self
            .gamma_max_discrete
            .min(self.gamma_max_single_equilibrium);
        [
            row("current PI kp", self.foc.current_kp, "V/A", "L ω_c"),
            row("current PI ki", self.foc.current_ki, "V/(A·s)", "R ω_c"),
            row("speed PI kp", self.foc.speed_kp, "A·s/rad", "J ω_s/(N ψ_f)"),
            row("speed PI ki", self.foc.speed_ki, "A/rad", "kp ω_s/4"),
            row(
                "K_s",
                self.ks_a_per_s,
                "A/s",
                "the paper's setting, Horng & Chin Sec 5",
            ),
            row(
                "ε",
                self.epsilon_a,
                "A",
                "boundary layer, Horng & Chin Sec 5",
            ),
            row("(K_s,max)_T", self.ks_max_t_a_per_s, "A/s", "ε(2/T − R/L)"),
            row(
                "(K_s,max)_E2 at rated speed",
                self.ks_max_e2_rated_a_per_s,
                "A/s",
                "(√2 K N ω − R ε)/L at the rated speed",
            ),
            row(
                "(K_s,max)_E2 at hand-over",
                self.ks_max_e2_handover_a_per_s,
                "A/s",
                "(√2 K N ω − R ε)/L at the hand-over speed",
            ),
            row(
                "K_s = (K_s,max)_E2 at",
                self.ks_e2_speed_rpm,
                "rpm",
                "(K_s L + R ε)/(√2 K N)",
            ),
            setting(
                "γ",
                self.gamma,
                "1/(Wb²·s)",
                "Ortega eq (9); salient: × (ψ_f/ψ_a)², ψ_a at the MTPA's current limit",
                ("the smaller γ_max", gamma_limit),
            ),
            row(
                "γ_max, discrete step",
                self.gamma_max_discrete,
                "1/(Wb²·s)",
                "2/(Φ² T)",
            ),
            row(
                "γ_max, one equilibrium",
                self.gamma_max_single_equilibrium,
                "1/(Wb²·s)",
                "4 n_P |ω|/Φ² at the hand-back speed (Proposition 4)",
            ),
            row("PLL Kp", self.pll_kp, "1/s", "2ζω_n"),
            row("PLL Ki", self.pll_ki, "1/s²", "ω_n²"),
            setting(
                "hand-over speed",
                self.handover_rpm,
                "rpm",
                "start.handover_rpm",
                rated_speed,
            ),
            setting(
                "hand-back speed",
                self.handback_rpm,
                "rpm",
                "start.handback_rpm",
                rated_speed,
            ),
            row(
                "speed the lowest bus drives",
                self.bus_limited_rpm,
                "rpm",
                "(bus_min_v/√3)/(N ψ_f)",
            ),
            row(
                "rated-torque current",
                self.rated_torque_current_a,
                "A",
                "τ/(N ψ_f)",
            ),
            setting(
                "current command limit i_max",
                self.i_max_a,
                "A",
                "limits.i_max_a",
                rated_current,
            ),
            setting(
                "current trip",
                self.i_trip_a,
                "A",
                "limits.i_trip_a",
                ("i_max", self.i_max_a),
            ),
            setting(
                "sensing range",
                self.i_sense_max_a,
                "A",
                "limits.i_sense_max_a",
                ("trip", self.i_trip_a),
            ),
            setting(
                "align current",
                self.align_current_a,
                "A",
                "start.align_current_a",
                rated_current,
            ),
            setting(
                "open-loop current",
                self.open_loop_current_a,
                "A",
                "start.open_loop_current_a",
                rated_current,
            ),
            row(
                "dead-time voltage",
                self.dead_time_voltage_v,
                "V",
                "t_d f_pwm bus_v per phase, compensated by the current's sign",
            ),
            setting(
                "dead-time sign band",
                config.power_stage.dead_time_band_a,
                "A",
                "power_stage.dead_time_band_a",
                rated_current,
            ),
            row(
                "largest phase voltage",
                self.v_max_v,
                "V",
                "(1 − 2 t_d f_pwm) bus_v/√3",
            ),
            row(
                "voltage of rated torque at rated speed",
                self.v_rated_point_v,
                "V",
                "|(R i, −ω_e L i) + (0, ω_e ψ_f)|, dq",
            ),
            row(
                "rated torque up to",
                self.rated_torque_speed_rpm,
                "rpm",
                "where it needs more than 0.95 x that voltage, i_d down to -sqrt(i_max^2 - i_q^2)",
            ),
        ]
    }
}

/// Steady-state phase voltage \[V] at `i_q` \[A] and mechanical speed `omega_m` \[rad/s], dq
/// model (Ortega eq (3)) with `i_d = 0`: `v_d = −ω_e L i_q`, `v_q = R i_q + ω_e ψ_f`.
fn voltage(m: &crate::motor::MotorParams, i_q: f32, omega_m: f32) -> f32 {
    let w_e = m.n() * omega_m;
    let v_d = -w_e * m.l_h * i_q;
    let v_q = m.r_ohm * i_q + w_e * m.flux_wb;
    crate::math::sqrt_call(v_d * v_d + v_q * v_q)
}
