//! Faults of the motor on the board, for the identification's plausibility checks: an open
//! phase and a shorted winding change the voltage the windings see ([`Faulty`]); a blocked
//! rotor is the plant's blocked shaft.

use pmsm_plant::Converter;

/// A fault of the motor (the plant).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MotorFault {
    /// Phase `0..3` (a, b, c) not connected: its current is zero, its terminal floats.
    OpenPhase(usize),
    /// Phase `0..3`'s winding short-circuited (its terminal at the star point).
    ShortedPhase(usize),
    /// The shaft cannot turn.
    BlockedRotor,
}

impl MotorFault {
    /// From `open-a`, `shorted-b`, `blocked`, ….
    pub fn parse(s: &str) -> anyhow::Result<Self> {
        let phase = |p: &str| match p {
            "a" => Ok(0),
            "b" => Ok(1),
            "c" => Ok(2),
            _ => anyhow::bail!("--motor-fault = {s}: the phase must be a, b or c"),
        };
        match s.split_once('-') {
            Some(("open", p)) => Ok(Self::OpenPhase(phase(p)?)),
            Some(("shorted", p)) => Ok(Self::ShortedPhase(phase(p)?)),
            None if s == "blocked" => Ok(Self::BlockedRotor),
            _ => anyhow::bail!("--motor-fault = {s}: one of open-a|b|c, shorted-a|b|c, blocked"),
        }
    }
}

/// The converter's voltage as a faulty winding sees it.
pub struct Faulty<C: Converter> {
    /// The converter.
    pub inner: C,
    /// The motor's fault.
    pub fault: Option<MotorFault>,
    /// The winding's resistance \[Ω].
    pub r: f64,
}

/// Unit vector of phase `k`'s axis in the stationary frame (amplitude-invariant Clarke).
fn axis(k: usize) -> (f64, f64) {
    let th = k as f64 * 2.0 * std::f64::consts::PI / 3.0;
    (th.cos(), th.sin())
}

impl<C: Converter> Converter for Faulty<C> {
    fn v_alpha_beta(&self, v_dc: f64, i: (f64, f64), e: (f64, f64)) -> (f64, f64) {
        let v = self.inner.v_alpha_beta(v_dc, i, e);
        match self.fault {
            // The floating terminal takes the voltage that keeps the phase's current at zero:
            // along its axis u, u·v = R u·i − u·e (the plant's `L di/dt = v − R i + e`).
            Some(MotorFault::OpenPhase(k)) => {
                let u = axis(k);
                let along = u.0 * v.0 + u.1 * v.1;
                let keep = self.r * (u.0 * i.0 + u.1 * i.1) - (u.0 * e.0 + u.1 * e.1);
                (v.0 + (keep - along) * u.0, v.1 + (keep - along) * u.1)
            }
            // Winding k shorted: its terminal at the star point. The other two windings take
            // the line voltages to k; in the αβ model, v' = (I + 2 u uᵀ) v (the conductance
            // along u tripled; at standstill exact, the shorted winding's EMF and torque
            // kept: the identification's checks find it at standstill).
            Some(MotorFault::ShortedPhase(k)) => {
                let u = axis(k);
                let along = u.0 * v.0 + u.1 * v.1;
                (v.0 + 2.0 * along * u.0, v.1 + 2.0 * along * u.1)
            }
            _ => v,
        }
    }
}
