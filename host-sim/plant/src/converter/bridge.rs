//! The inverter with every switch off: a three-phase diode bridge into the DC link.

use super::Converter;
use crate::frames::{clarke, inverse_clarke};

/// The inverter with every switch off: each phase terminal is held by its freewheeling
/// diodes (a three-phase diode bridge into the DC link). A phase whose current flows into the
/// motor (`i > 0`) conducts through its low diode, terminal at 0 V; one whose current flows
/// out (`i < 0`) through its high diode, terminal at `V_dc`; a phase without current floats
/// at the potential the motor gives it, and starts conducting when that potential leaves
/// [0, V_dc] (Mohan, Undeland, Robbins, *Power Electronics*, 3rd ed., Sec 5-6, the
/// three-phase diode rectifier; here the back-EMF is the source). Below the bus the motor
/// coasts without current; above it the bridge brakes it into the bus.
///
/// Within a sub-step the conduction pattern is fixed ([`DiodeBridge::pattern`], from the
/// currents and back-EMF at its start, held by [`Clamped`]); after it, a diode whose current
/// has crossed zero blocks ([`DiodeBridge::block`]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DiodeBridge;

/// The terminal voltage of each conducting phase relative to the link's negative rail \[V]
/// (0 or `V_dc`); `None`: the phase floats with zero current.
pub type Pattern = [Option<f64>; 3];

impl DiodeBridge {
    /// Which diodes conduct on the DC link `v_dc` \[V] given the phase currents `i_abc` \[A]
    /// and the back-EMF term `e_abc` \[V] of eqs (16)-(17) per phase.
    pub fn pattern(v_dc: f64, i_abc: [f64; 3], e_abc: [f64; 3]) -> Pattern {
        let v = v_dc;
        let mut pole: Pattern = i_abc.map(|i| {
            if i > 0.0 {
                Some(0.0)
            } else if i < 0.0 {
                Some(v)
            } else {
                None
            }
        });
        if pole.iter().all(Option::is_none) {
            // Open circuit, phase voltages −e: the highest terminal reaches the high rail
            // and the lowest the low rail when their difference exceeds the bus.
            let w = e_abc.map(|e| -e);
            let hi = (0..3).fold(0, |m, k| if w[k] > w[m] { k } else { m });
            let lo = (0..3).fold(0, |m, k| if w[k] < w[m] { k } else { m });
            if w[hi] - w[lo] > v {
                pole[hi] = Some(v);
                pole[lo] = Some(0.0);
            }
        }
        if let Some(f) = (0..3).find(|&k| pole[k].is_none()) {
            if let Some(u) = Self::floating(&pole, f, e_abc[f]) {
                if u > v {
                    pole[f] = Some(v);
                } else if u < 0.0 {
                    pole[f] = Some(0.0);
                }
            }
        }
        pole
    }

    /// The potential of floating phase `f` when the other two conduct: zero current in it
    /// (`v_f = −e_f`) and the star point at the mean of the terminals give
    /// `u_f = (u_a + u_b)/2 − 3e_f/2`. `None` unless exactly the other two conduct.
    fn floating(pole: &Pattern, f: usize, e_f: f64) -> Option<f64> {
        let mut others = (0..3).filter(|&k| k != f).filter_map(|k| pole[k]);
        match (others.next(), others.next()) {
            (Some(u1), Some(u2)) => Some(0.5 * (u1 + u2) - 1.5 * e_f),
            _ => None,
        }
    }

    /// Currents after a sub-step on the DC link `v_dc`: a phase whose diode's current crossed
    /// zero, or that was floating, carries none; the rest keep a zero sum.
    pub fn block(pattern: &Pattern, i_abc: [f64; 3], v_dc: f64) -> [f64; 3] {
        let mut i: [f64; 3] = core::array::from_fn(|k| match pattern[k] {
            Some(u) if u == v_dc && i_abc[k] < 0.0 => i_abc[k],
            Some(u) if u == 0.0 && i_abc[k] > 0.0 => i_abc[k],
            _ => 0.0,
        });
        let live = i.iter().filter(|x| **x != 0.0).count();
        if live < 2 {
            return [0.0; 3];
        }
        let mean = i.iter().sum::<f64>() / live as f64;
        for x in i.iter_mut().filter(|x| **x != 0.0) {
            *x -= mean;
        }
        i
    }
}

/// A diode pattern held over a sub-step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Clamped {
    /// The pattern.
    pub pole: Pattern,
}

impl Converter for Clamped {
    fn v_alpha_beta(&self, _v_dc: f64, _i: (f64, f64), e: (f64, f64)) -> (f64, f64) {
        if self.pole.iter().all(Option::is_none) {
            return (-e.0, -e.1);
        }
        let e_abc = inverse_clarke(e.0, e.1);
        let u: [f64; 3] = core::array::from_fn(|k| {
            self.pole[k]
                .or_else(|| DiodeBridge::floating(&self.pole, k, e_abc[k]))
                .unwrap_or(0.0)
        });
        let star = (u[0] + u[1] + u[2]) / 3.0;
        clarke(u.map(|x| x - star))
    }
}
