//! The motor's parameters in f64 SI units, in one place; each part of the plant takes its
//! share ([`PlantParams::electrical`], [`PlantParams::mechanical`]).

use crate::electrical::Pmsm;
use crate::inductance::{AxisInductance, Saturates, Saturation};
use crate::mechanical::Rotor;
use pmsm_sensorless::motor::MotorParams;

/// Plant parameters in f64 (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantParams {
    /// Pole pairs N.
    pub n: f64,
    /// Resistance \[Ω].
    pub r: f64,
    /// d-axis inductance (along the magnet).
    pub l_d: AxisInductance,
    /// q-axis inductance.
    pub l_q: AxisInductance,
    /// Flux linkage ψ = K = Φ \[Wb].
    pub flux: f64,
    /// Inertia \[kg·m²].
    pub j: f64,
    /// Viscous friction \[N·m·s/rad].
    pub b: f64,
    /// Torque and power factor `c` ([`Pmsm::c`]).
    pub c: f64,
}

/// A machine's own inductances where they differ from the non-salient model's one `l_h`
/// (a salient motor file's): unsaturated `L_d` and `L_q`, and each axis' saturation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Inductances {
    /// Unsaturated d-axis inductance \[H].
    pub l_d_h: f64,
    /// Unsaturated q-axis inductance \[H].
    pub l_q_h: f64,
    /// d-axis saturation by a current adding to the magnet's flux (`None`: none).
    pub saturation_d: Option<Saturation>,
    /// q-axis saturation by `|i_q|` (`None`: none).
    pub saturation_q: Option<Saturation>,
}

impl Inductances {
    /// The one inductance a non-salient model of this machine is given: the mean of the
    /// unsaturated `L_d` and `L_q` \[H]. It is what the drive's identification gives the
    /// drive (`pmsm_sensorless::drive::identify::Identified::l_h`), so a drive given a
    /// salient motor file's parameters and one that identified the same motor start from the
    /// same L; between `L_d` (which the drive's d-axis current loop sees) and `L_q` (its
    /// q-axis loop), the mean errs by at most half the difference on either loop.
    pub fn non_salient_l_h(&self) -> f64 {
        0.5 * (self.l_d_h + self.l_q_h)
    }

    /// The saliency `L_q/L_d` of the unsaturated inductances (the drive's
    /// `MotorParams::saliency`).
    pub fn saliency(&self) -> f64 {
        self.l_q_h / self.l_d_h
    }
}

impl From<&MotorParams> for PlantParams {
    /// The unsaturated machine of the drive's parameters: `L_d`, `L_q` of `m`
    /// (`L_d = L_q = l_h` for a non-salient `m`).
    fn from(m: &MotorParams) -> Self {
        Self {
            n: m.pole_pairs as f64,
            r: m.r_ohm as f64,
            l_d: AxisInductance {
                l0_h: m.l_d_h() as f64,
                saturation: None,
                saturates: Saturates::Positive,
            },
            l_q: AxisInductance {
                l0_h: m.l_q_h() as f64,
                saturation: None,
                saturates: Saturates::Magnitude,
            },
            flux: m.flux_wb as f64,
            j: m.j_kgm2 as f64,
            b: m.b_nms as f64,
            c: m.torque.factor() as f64,
        }
    }
}

impl PlantParams {
    /// The machine of `m` with its own inductances `l` where given (else `m`'s `l_h` on
    /// both axes, unsaturated).
    pub fn with_inductances(m: &MotorParams, l: Option<&Inductances>) -> Self {
        let mut p = Self::from(m);
        if let Some(l) = l {
            p.l_d.l0_h = l.l_d_h;
            p.l_d.saturation = l.saturation_d;
            p.l_q.l0_h = l.l_q_h;
            p.l_q.saturation = l.saturation_q;
        }
        p
    }

    /// The electrical part: N, R, L_d, L_q, ψ.
    pub fn electrical(&self) -> Pmsm {
        Pmsm {
            n: self.n,
            r: self.r,
            l_d: self.l_d,
            l_q: self.l_q,
            flux: self.flux,
            c: self.c,
        }
    }

    /// The mechanical part: J, B, and whether the shaft is `blocked`.
    pub fn mechanical(&self, blocked: bool) -> Rotor {
        Rotor {
            j: self.j,
            b: self.b,
            blocked,
        }
    }

    /// The machine's inductances ([`Inductances::non_salient_l_h`]: its one L).
    pub fn inductances(&self) -> Inductances {
        Inductances {
            l_d_h: self.l_d.l0_h,
            l_q_h: self.l_q.l0_h,
            saturation_d: self.l_d.saturation,
            saturation_q: self.l_q.saturation,
        }
    }

    /// Both axes' unsaturated inductances scaled by `factor` (an injected fault).
    pub fn scale_l(&mut self, factor: f64) {
        self.l_d.l0_h *= factor;
        self.l_q.l0_h *= factor;
    }
}
