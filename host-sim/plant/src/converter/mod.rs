//! The converter between the DC link and the windings: what stator voltage it applies over a
//! sub-step ([`Converter`]), and the DC-link current it draws for it. Two of them: the
//! averaged two-level inverter holding the drive's duties ([`Inverter`], with its dead
//! time), and the same bridge with every switch off, its freewheeling diodes a three-phase
//! rectifier ([`DiodeBridge`]).

mod bridge;
mod inverter;

pub use bridge::{Clamped, DiodeBridge, Pattern};
pub use inverter::{HeldDuties, Inverter};

/// The bridge with every low-side switch on and every high-side one off (the active short
/// circuit): the three terminals on the link's negative rail, no switching, so no dead time;
/// the stator voltage is zero and no current flows in the link (Welchko, Jahns, Soong &
/// Nagashima, IEEE Trans. Energy Conversion 18(2), 2003: the symmetrical short circuit).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ShortCircuit;

impl Converter for ShortCircuit {
    fn v_alpha_beta(&self, _v_dc: f64, _i: (f64, f64), _e: (f64, f64)) -> (f64, f64) {
        (0.0, 0.0)
    }
}

/// What feeds the stator during a sub-step: its voltage as a function of the DC-link voltage,
/// of the currents (the inverter's dead time depends on their sign) and of the back-EMF
/// term `e = ψNω (sin Nθ, −cos Nθ)` of eqs (16)-(17) (an open circuit is `v = −e` at zero
/// current).
pub trait Converter {
    /// Stator voltage `(v_α, v_β)` \[V] on the DC link `v_dc` \[V], given the currents `i`
    /// \[A] and the back-EMF term `e` \[V].
    fn v_alpha_beta(&self, v_dc: f64, i: (f64, f64), e: (f64, f64)) -> (f64, f64);

    /// The DC-link current \[A] (positive out of the bus) while the stator takes the power
    /// `p_stator` \[W] from a DC link at `v_dc` \[V]: a lossless converter's balance
    /// `v_dc i_dc = p_stator`, the power in the papers' model's terms (`v_αβ · i_αβ`, as the
    /// plant's `e_in` integrates it). No current from a link at zero volts.
    fn i_dc(&self, v_dc: f64, p_stator: f64) -> f64 {
        if v_dc > 0.0 {
            p_stator / v_dc
        } else {
            0.0
        }
    }
}
