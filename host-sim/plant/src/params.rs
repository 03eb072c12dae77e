//! The motor's parameters in f64 SI units, in one place; each part of the plant takes its
//! share ([`PlantParams::electrical`], [`PlantParams::mechanical`]).

use crate::electrical::Pmsm;
use crate::mechanical::Rotor;
use pmsm_sensorless::motor::MotorParams;

/// Plant parameters in f64 (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantParams {
    /// Pole pairs N.
    pub n: f64,
    /// Resistance \[Ω].
    pub r: f64,
    /// Inductance \[H].
    pub l: f64,
    /// Flux linkage ψ = K = Φ \[Wb].
    pub flux: f64,
    /// Inertia \[kg·m²].
    pub j: f64,
    /// Viscous friction \[N·m·s/rad].
    pub b: f64,
    /// Torque and power factor `c` ([`Pmsm::c`]).
    pub c: f64,
}

impl From<&MotorParams> for PlantParams {
    fn from(m: &MotorParams) -> Self {
        Self {
            n: m.pole_pairs as f64,
            r: m.r_ohm as f64,
            l: m.l_h as f64,
            flux: m.flux_wb as f64,
            j: m.j_kgm2 as f64,
            b: m.b_nms as f64,
            c: m.torque.factor() as f64,
        }
    }
}

impl PlantParams {
    /// The electrical part: N, R, L, ψ.
    pub fn electrical(&self) -> Pmsm {
        Pmsm {
            n: self.n,
            r: self.r,
            l: self.l,
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
}
