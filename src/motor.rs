//! Motor parameters, their validation, and the papers' motor presets.
//!
//! The model is the papers' stationary-frame PMSM, Horng & Chin eqs (16)-(19) (equivalently
//! Ortega eqs (1)-(2)):
//!
//! ```text
//! L di_αβ/dt = −R i_αβ + N ω_m ψ_f [sin θ_e, −cos θ_e] + v_αβ
//! J dω_m/dt  = N ψ_f (i_β cos θ_e − i_α sin θ_e) − B ω_m − τ_L,     θ_e = N θ_m
//! ```
//!
//! Horng & Chin's motor constant `K` \[V·s/rad] and Ortega's rotor flux `Φ` \[Wb] are the same
//! quantity, the permanent-magnet flux linkage, here `flux_wb`.
//!
//! Torque: both papers print `τ = N ψ_f i_q` (their αβ model is the machine). A three-phase
//! machine described by the amplitude-invariant Clarke transform (the one used here: `i_αβ`
//! has the phase current's peak amplitude) makes `τ = (3/2) N ψ_f i_q` (Krause, Wasynczuk,
//! Sudhoff, Pekarek, *Analysis of Electric Machinery and Drive Systems*, 3rd ed., Wiley 2013,
//! the permanent-magnet ac machine's `T_e = (3/2)(P/2) λ'_m i_qs`; the 3/2 is three phases'
//! power seen through a transform that keeps amplitudes).
//! [`TorqueConvention`] says which one a motor's N·m are in: the papers' presets keep their
//! printed convention ([`TorqueConvention::Papers`]); a motor file and every motor a user
//! writes is physical ([`TorqueConvention::ThreePhase`]). The two are the same dynamics with
//! `J`, `B` and every torque divided by 3/2 ([`MotorParams::papers_model`]), so a block
//! written in the papers' model (the sliding observer) runs on that equivalent.

use crate::math::INV_SQRT3;
use crate::param::{Allowed, Checks, ParamError};
use crate::units::RAD_S_PER_RPM;

/// Which torque per amp a motor's N·m (its `J`, `B`, rated torque, load torques and the
/// drive's torque estimates) are in (module doc).
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum TorqueConvention {
    /// `τ = (3/2) N ψ_f i_q`: a three-phase machine, physical N·m (the default).
    #[default]
    ThreePhase,
    /// `τ = N ψ_f i_q` as printed in both papers; their experiments' figures are in it.
    Papers,
}

impl TorqueConvention {
    /// The factor `c` in `τ = c N ψ_f i_q`: 3/2 or 1.
    pub const fn factor(self) -> f32 {
        match self {
            Self::ThreePhase => 1.5,
            Self::Papers => 1.0,
        }
    }
}

/// Electrical and mechanical parameters of a PMSM (SI units): surface-mounted (`L_d = L_q`,
/// `saliency` 1, the papers' model) or salient (interior magnets, `saliency = L_q/L_d ≠ 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotorParams {
    /// Pole pairs `N` (Horng) / `n_P` (Ortega); `θ_e = N θ_m`. At least 1.
    pub pole_pairs: u32,
    /// Stator phase resistance `R` \[Ω], > 0.
    pub r_ohm: f32,
    /// Stator inductance `L` \[H], > 0: of a non-salient motor (`saliency` 1) its one
    /// inductance, `L_d = L_q = l_h`; of a salient one the mean `(L_d + L_q)/2`, the one `L`
    /// a block written for the non-salient model is given (and what an identification that
    /// measures both axes gives). [`MotorParams::l_d_h`], [`MotorParams::l_q_h`].
    pub l_h: f32,
    /// Saliency `ξ = L_q/L_d`, in [`MotorParams::SALIENCY`]: 1 for a non-salient motor (then
    /// `L_d = L_q = l_h` exactly), 1.5 to 4 for interior-magnet motors.
    pub saliency: f32,
    /// Permanent-magnet flux linkage `K` = `Φ` [Wb = V·s/rad], > 0.
    pub flux_wb: f32,
    /// Rotor inertia `H` = `J` \[kg·m²], > 0.
    pub j_kgm2: f32,
    /// Viscous friction `B` = `f` \[N·m·s/rad], ≥ 0.
    pub b_nms: f32,
    /// Which torque per amp `j_kgm2`, `b_nms` and every torque of this motor are in.
    pub torque: TorqueConvention,
}

impl MotorParams {
    /// Pole pairs accepted: 1 to 64.
    pub const POLE_PAIRS: Allowed = Allowed::between(1.0, 64.0);
    /// Phase resistance accepted \[Ω]: 0.1 mΩ (a 40 kW machine has tens of mΩ) to 1 kΩ.
    pub const R_OHM: Allowed = Allowed::between(1e-4, 1e3);
    /// Phase inductance accepted \[H]: 0.1 µH to 10 H.
    pub const L_H: Allowed = Allowed::between(1e-7, 10.0);
    /// Flux linkage accepted \[Wb]: 10 µWb (a 0.1 mN·m/A hobby motor) to 10 Wb.
    pub const FLUX_WB: Allowed = Allowed::between(1e-5, 10.0);
    /// Inertia accepted \[kg·m²]: 10⁻⁹ (a micro motor's rotor) to 10³.
    pub const J_KGM2: Allowed = Allowed::between(1e-9, 1e3);
    /// Viscous friction accepted \[N·m·s/rad]: 0 to 10³.
    pub const B_NMS: Allowed = Allowed::between(0.0, 1e3);
    /// Saliency `L_q/L_d` accepted: 0.5 (inverse-saliency machines) to 10 (PM-assisted
    /// synchronous reluctance machines); interior-magnet motors are 1.5 to 4.
    pub const SALIENCY: Allowed = Allowed::between(0.5, 10.0);

    /// Validated parameters of a three-phase motor in physical N·m
    /// ([`TorqueConvention::ThreePhase`]; [`MotorParams::with_torque`] for the papers'); the
    /// error names the first bad field, its value and its range.
    pub fn new(
        pole_pairs: u32,
        r_ohm: f32,
        l_h: f32,
        flux_wb: f32,
        j_kgm2: f32,
        b_nms: f32,
    ) -> Result<Self, ParamError> {
        let mut c = Checks::new();
        c.check("pole_pairs", pole_pairs as f32, Self::POLE_PAIRS);
        c.check("r_ohm", r_ohm, Self::R_OHM);
        c.check("l_h", l_h, Self::L_H);
        c.check("flux_wb", flux_wb, Self::FLUX_WB);
        c.check("j_kgm2", j_kgm2, Self::J_KGM2);
        c.check("b_nms", b_nms, Self::B_NMS);
        c.done()?;
        Ok(Self {
            pole_pairs,
            r_ohm,
            l_h,
            flux_wb,
            j_kgm2,
            b_nms,
            saliency: 1.0,
            torque: TorqueConvention::ThreePhase,
        })
    }

    /// The same parameters with their N·m in `torque`'s convention.
    pub const fn with_torque(self, torque: TorqueConvention) -> Self {
        Self { torque, ..self }
    }

    /// The salient motor of inductances `l_d_h`, `l_q_h` \[H] with these parameters
    /// otherwise: `l_h` their mean, `saliency` their ratio; the error names the bad one.
    pub fn with_inductances(self, l_d_h: f32, l_q_h: f32) -> Result<Self, ParamError> {
        let mut c = Checks::new();
        c.check("l_d_h", l_d_h, Self::L_H);
        c.check("l_q_h", l_q_h, Self::L_H);
        c.done()?;
        Self {
            l_h: 0.5 * (l_d_h + l_q_h),
            saliency: l_q_h / l_d_h,
            ..self
        }
        .validate()
    }

    /// Re-checks a value built field by field (e.g. after scaling).
    pub fn validate(self) -> Result<Self, ParamError> {
        Self::SALIENCY.check("saliency", self.saliency)?;
        Ok(Self {
            saliency: self.saliency,
            ..Self::new(
                self.pole_pairs,
                self.r_ohm,
                self.l_h,
                self.flux_wb,
                self.j_kgm2,
                self.b_nms,
            )?
            .with_torque(self.torque)
        })
    }

    /// d-axis inductance `L_d = 2 l_h/(1 + ξ)` \[H] (along the magnet): `l_h` exactly for a
    /// non-salient motor (ξ = 1).
    #[inline]
    pub fn l_d_h(&self) -> f32 {
        self.l_h * (2.0 / (1.0 + self.saliency))
    }

    /// q-axis inductance `L_q = ξ L_d` \[H]: `l_h` exactly for a non-salient motor.
    #[inline]
    pub fn l_q_h(&self) -> f32 {
        self.saliency * self.l_d_h()
    }

    /// `L_d − L_q` \[H] (negative for an interior-magnet motor), 0 exactly for a non-salient
    /// one: the reluctance torque's `(3/2) N (L_d − L_q) i_d i_q` and the active flux's
    /// `ψ_f + (L_d − L_q) i_d` ([`crate::observer::flux`]).
    #[inline]
    pub fn l_d_minus_l_q_h(&self) -> f32 {
        self.l_d_h() - self.l_q_h()
    }

    /// The d current along which a salient rotor ([`stiffest_holding_current_a`]) is held
    /// stiffest \[A], or `None` for `L_q ≤ L_d`.
    #[inline]
    pub fn stiffest_holding_current_a(&self) -> Option<f32> {
        stiffest_holding_current_a(self.flux_wb, self.l_d_minus_l_q_h())
    }

    /// The motor is salient: `L_d ≠ L_q`.
    #[inline]
    pub fn is_salient(&self) -> bool {
        self.saliency != 1.0
    }

    /// The papers' model of this motor, `τ = N ψ_f i_q`: the same electrical part, `J` and `B`
    /// divided by the torque factor `c`, so that `(J/c) dω_m/dt = N ψ_f i_q − (B/c) ω_m − τ_L/c`
    /// is this motor's mechanical equation divided by `c`. A block written in the papers'
    /// model runs on it and multiplies its torques by `c` ([`TorqueConvention::factor`]).
    pub fn papers_model(&self) -> Self {
        let c = self.torque.factor();
        Self {
            j_kgm2: self.j_kgm2 / c,
            b_nms: self.b_nms / c,
            torque: TorqueConvention::Papers,
            ..*self
        }
    }

    /// Pole pairs as f32.
    pub fn n(&self) -> f32 {
        self.pole_pairs as f32
    }

    /// Back-EMF constant `N ψ_f` [V·s/rad]: the phase back-EMF's peak is `N ψ_f ω_m`.
    pub fn emf_constant(&self) -> f32 {
        self.n() * self.flux_wb
    }

    /// Torque constant `c N ψ_f` \[N·m/A]: `τ = c N ψ_f i_q`, `c` of [`Self::torque`].
    pub fn torque_constant(&self) -> f32 {
        self.torque.factor() * self.emf_constant()
    }

    /// The speed \[rpm, mechanical] whose back-EMF `N ψ_f ω_m` is the largest phase voltage
    /// SVPWM makes from `bus_v` \[V], `bus_v/√3`: the most that bus drives without current.
    pub fn bus_limited_rpm(&self, bus_v: f32) -> f32 {
        bus_v * INV_SQRT3 / self.emf_constant() / RAD_S_PER_RPM
    }
}

/// Nameplate ratings used for limits and scenarios.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ratings {
    /// DC bus voltage \[V], > 0.
    pub bus_v: f32,
    /// Rated phase current \[A] as printed by the source (see each preset), > 0.
    pub current_a: f32,
    /// Rated torque \[N·m], > 0.
    pub torque_nm: f32,
    /// Rated speed [rpm, mechanical], > 0.
    pub speed_rpm: f32,
    /// Rated output power \[W], > 0.
    pub power_w: f32,
}

impl Ratings {
    /// Bus voltage accepted \[V].
    pub const BUS_V: Allowed = Allowed::between(1.0, 1500.0);
    /// Rated current accepted \[A].
    pub const CURRENT_A: Allowed = Allowed::above_up_to(0.0, 5000.0);
    /// Rated torque accepted \[N·m].
    pub const TORQUE_NM: Allowed = Allowed::above_up_to(0.0, 1e5);
    /// Rated speed accepted \[rpm].
    pub const SPEED_RPM: Allowed = Allowed::above_up_to(0.0, 2e5);
    /// Rated power accepted \[W].
    pub const POWER_W: Allowed = Allowed::above_up_to(0.0, 1e7);

    /// Validated ratings; the error names the first bad field, its value and its range.
    pub fn validate(self) -> Result<Self, ParamError> {
        Self::BUS_V.check("ratings.bus_v", self.bus_v)?;
        Self::CURRENT_A.check("ratings.current_a", self.current_a)?;
        Self::TORQUE_NM.check("ratings.torque_nm", self.torque_nm)?;
        Self::SPEED_RPM.check("ratings.speed_rpm", self.speed_rpm)?;
        Self::POWER_W.check("ratings.power_w", self.power_w)?;
        Ok(self)
    }
}

/// A named motor: parameters plus ratings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motor {
    /// Short identifier used on the command line.
    pub name: &'static str,
    /// Model parameters.
    pub params: MotorParams,
    /// Nameplate ratings.
    pub ratings: Ratings,
}

impl Motor {
    /// Parameters and ratings validated, and the ratings checked against the parameters (each
    /// bound with the motor's torque constant `K_t = c N ψ_f`, peak phase amplitudes):
    /// - the rated torque is what the rated current makes, `K_t I`, within −50 %..+10 %
    ///   (a datasheet's rms current, or a torque in the other convention, is off by √2 or
    ///   3/2);
    /// - the bus drives the rated speed: back-EMF `N ψ_f ω_m ≤ V_bus/√3` (the largest phase
    ///   voltage of SVPWM);
    /// - the bus drives the rated torque's current at standstill: `R τ/K_t ≤ V_bus/√3`;
    /// - the rated power is rated torque times rated speed within a factor 1.5.
    pub fn validate(self) -> Result<Self, ParamError> {
        let p = self.params.validate()?;
        let r = self.ratings.validate()?;
        let kt = p.torque_constant();
        let v_max = r.bus_v * INV_SQRT3;
        let torque_of_current = kt * r.current_a;
        Allowed::between(0.5 * torque_of_current, 1.1 * torque_of_current)
            .because("0.5 to 1.1 x the torque of the rated current, c*pole_pairs*flux_wb*current_a (c = 1.5 three-phase, 1 papers)")
            .check("ratings.torque_nm", r.torque_nm)?;
        Allowed::above_up_to(0.0, p.bus_limited_rpm(r.bus_v))
            .because("back-EMF pole_pairs*flux_wb*omega_m within bus_v/sqrt(3)")
            .check("ratings.speed_rpm", r.speed_rpm)?;
        Allowed::above_up_to(0.0, v_max / p.r_ohm * kt)
            .because("r_ohm*torque/(c*pole_pairs*flux_wb) within bus_v/sqrt(3) at standstill")
            .check("ratings.torque_nm", r.torque_nm)?;
        let mech_power = r.torque_nm * r.speed_rpm * RAD_S_PER_RPM;
        Allowed::between(mech_power / 1.5, 1.5 * mech_power)
            .because("torque_nm x rated speed within a factor 1.5")
            .check("ratings.power_w", r.power_w)?;
        Ok(self)
    }

    /// The `i_q` that makes rated torque, `τ_rated/K_t` \[A]: the
    /// current limit of the speed loop.
    pub fn rated_torque_current_a(&self) -> f32 {
        self.ratings.torque_nm / self.params.torque_constant()
    }
}

/// Horng & Chin Table 1: Sinano #7CB30-2SE6F.
///
/// R, L, K, N, H, B are the table's. Not in the paper, and assumed here: the 48 V bus (the
/// bus the foundation issue specifies; at 1000 rpm the back-EMF amplitude K·N·ω = 24.3 V fits
/// under 48/√3 = 27.7 V), a 3 A current rating, rated torque = K·N·3 A = 0.70 N·m, and
/// 1000 rpm (the paper's test speed; about the most the 48 V bus allows).
pub const HORNG_SINANO: Motor = Motor {
    name: "sinano",
    params: MotorParams {
        pole_pairs: 4,
        r_ohm: 2.5,
        l_h: 5.97e-3,
        flux_wb: 5.795e-2,
        j_kgm2: 6.45e-5,
        b_nms: 8.06e-5,
        saliency: 1.0,
        torque: TorqueConvention::Papers,
    },
    ratings: Ratings {
        bus_v: 48.0,
        current_a: 3.0,
        torque_nm: 0.695,
        speed_rpm: 1000.0,
        power_w: 73.0,
    },
};

/// Ortega et al. Table I, first column: the 40 kW simulation motor.
///
/// Electrical data and ratings are the table's except the current: Table I's 216 A is, like
/// the test motor's, an rms current of a (3/2)·n_P·Φ·i torque convention
/// (1.5·3·0.146·216·√2 = 200 N·m ≈ 180 N·m); in the papers' model the rated 180 N·m takes
/// 180/(3·0.146) = 411 A, the rating given here. The table gives no inertia or friction;
/// assumed: J = 0.1 kg·m² (rotor of a 180 N·m industrial PMSM, order of catalogue values) and
/// f = 0.01 N·m·s/rad (friction torque 2.3 N·m = 1.3 % of rated torque at rated speed).
pub const ORTEGA_SIM_40KW: Motor = Motor {
    name: "ortega-sim-40kw",
    params: MotorParams {
        pole_pairs: 3,
        r_ohm: 0.065,
        l_h: 0.655e-3,
        flux_wb: 0.146,
        j_kgm2: 0.1,
        b_nms: 0.01,
        saliency: 1.0,
        torque: TorqueConvention::Papers,
    },
    ratings: Ratings {
        bus_v: 240.0,
        current_a: 411.0,
        torque_nm: 180.0,
        speed_rpm: 2200.0,
        power_w: 40.0e3,
    },
};

/// Ortega et al. Table I, second column: the 0.3 kW test motor.
///
/// Electrical data and ratings are the table's. Note: Table I's currents are consistent with
/// a three-phase machine of torque (3/2)·n_P·Φ·i_q and rms ratings (1.5·4·0.11·3·√2 = 2.8 N·m
/// ≈ 3.0 N·m); in the papers' model (torque n_P·Φ·i_q, peak amplitudes) the rated 3 N·m takes
/// 3/(4·0.11) = 6.8 A, the rating given here (Table I: 3 A). Assumed (the table gives none):
/// J = 1.0e-3 kg·m² (test rotor plus the coupled dynamo rotor of the bench, catalogue order
/// of magnitude for 3 N·m and 8 N·m servo motors) and f = 1.0e-3 N·m·s/rad (0.1 N·m, 3.5 % of
/// rated torque, at rated speed).
pub const ORTEGA_TEST_0P3KW: Motor = Motor {
    name: "ortega-test-0.3kw",
    params: MotorParams {
        pole_pairs: 4,
        r_ohm: 0.675,
        l_h: 1.14e-3,
        flux_wb: 0.11,
        j_kgm2: 1.0e-3,
        b_nms: 1.0e-3,
        saliency: 1.0,
        torque: TorqueConvention::Papers,
    },
    ratings: Ratings {
        bus_v: 200.0,
        current_a: 6.82,
        torque_nm: 3.0,
        speed_rpm: 1000.0,
        power_w: 300.0,
    },
};

/// Ortega et al. Table I, third column: the 1.0 kW dynamo motor.
///
/// Electrical data and ratings are the table's except the current, converted to the papers'
/// model as for the test motor: the rated 8.3 N·m takes 8.3/(4·0.099) = 21.0 A (Table I:
/// 10.7 A). Assumed (the table gives none): J = 1.0e-3 kg·m² and f = 1.0e-3 N·m·s/rad, as for the test motor it is coupled to.
pub const ORTEGA_DYNAMO_1KW: Motor = Motor {
    name: "ortega-dynamo-1kw",
    params: MotorParams {
        pole_pairs: 4,
        r_ohm: 0.825,
        l_h: 2.6e-3,
        flux_wb: 0.099,
        j_kgm2: 1.0e-3,
        b_nms: 1.0e-3,
        saliency: 1.0,
        torque: TorqueConvention::Papers,
    },
    ratings: Ratings {
        bus_v: 200.0,
        current_a: 21.0,
        torque_nm: 8.3,
        speed_rpm: 1500.0,
        power_w: 1.0e3,
    },
};

/// Every preset, for listing and lookup by name.
pub const PRESETS: [Motor; 4] = [
    HORNG_SINANO,
    ORTEGA_SIM_40KW,
    ORTEGA_TEST_0P3KW,
    ORTEGA_DYNAMO_1KW,
];

/// The preset called `name`, if any.
pub fn preset(name: &str) -> Option<Motor> {
    PRESETS.iter().copied().find(|m| m.name == name)
}

/// The d current `I` along which a salient rotor (`L_q > L_d`) is held stiffest \[A]: a
/// current along its d axis makes the active flux `ψ_f + (L_d − L_q) I`, the rotor's holding
/// stiffness `I (ψ_f + (L_d − L_q) I)` is largest at `I = ψ_f / (2 (L_q − L_d))`, where the
/// active flux is half the magnet's, and gone at twice it (the rotor then settles off the
/// current's axis). `None` for `L_q ≤ L_d`, whose stiffness grows with the current.
/// `flux_wb` \[Wb], `l_d_minus_l_q_h` \[H]. (The alignment's and open loop's current cap,
/// `DriveConfig::new`; the identification's flux spin, `drive/identify/flux.rs`.)
#[inline]
pub fn stiffest_holding_current_a(flux_wb: f32, l_d_minus_l_q_h: f32) -> Option<f32> {
    let l_q_minus_l_d = -l_d_minus_l_q_h;
    (l_q_minus_l_d > 0.0).then(|| flux_wb / (2.0 * l_q_minus_l_d))
}
