//! The DC link of a drive: a capacitor between the converter and a supply that feeds it
//! through a resistance and a diode (it cannot take current back, or takes at most a set
//! current), with an optional brake chopper, the standard DC-link model of a voltage-source
//! drive (Mohan, Undeland, Robbins, *Power Electronics*, 3rd ed., Sec 8-7 and 14-5: the
//! DC-link capacitor, regeneration and the dynamic-braking resistor; gym-electric-motor's
//! voltage supplies, `RCVoltageSupply`, are the same RC circuit without the diode).
//!
//! ```text
//! C dv/dt = i_s(v) − i_dc − i_b(v)
//! i_s(v)  = max((V_s − v)/R_s, −I_sink)       the supply, its diode or its sink limit
//! i_b(v)  = v/R_b while the chopper conducts  on at v ≥ V_on, off at v ≤ V_off (hysteresis)
//! ```
//!
//! **Integration.** The plant holds the DC-link current `i_dc` over a sub-step, so the
//! right-hand side is piecewise linear in `v`: `C dv/dt = a − g v` on each piece (the supply
//! conducting or at its sink limit, the chopper on or off). [`DcLink`] solves each piece
//! exactly, `v(t) = a/g + (v₀ − a/g) e^{−g t/C}` (a ramp where `g = 0`), and finds the time
//! the solution reaches the next piece's boundary (the supply's knee `V_s + R_s I_sink`, the
//! chopper's threshold) in closed form, then goes on from there. The exponential never
//! overshoots, so the scheme is stable for any `R_s C` and `R_b C` against the sub-step `h`
//! (a forward-Euler step would need `h < 2 R C`; with the defaults `R_s C` = 100 µs is ten
//! 10 µs sub-steps, but a small capacitor or a 1 Ω brake makes `R C` a few µs); the energy
//! integrals are the closed-form integrals of the same solution, so the link's energy balance
//! holds to rounding. The only approximation is the plant's: the converter's current is its
//! sub-step mean, at the voltage held over the sub-step.

use super::Supply;
use num_traits::Float;

/// The supply behind the link: an open-circuit voltage behind a resistance and a diode.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Source {
    /// Open-circuit voltage `V_s` \[V].
    pub v_open: f64,
    /// Series resistance `R_s` \[Ω], > 0.
    pub r_ohm: f64,
    /// The most current the supply takes back, `I_sink` \[A] (0: a diode, it cannot sink;
    /// a regenerative supply or a battery with a charge limit sinks up to this).
    pub sink_a: f64,
}

/// A brake chopper: a resistor across the link switched on above `v_on`, off below `v_off`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chopper {
    /// Resistance `R_b` \[Ω], > 0.
    pub r_ohm: f64,
    /// Switch-on voltage \[V].
    pub v_on: f64,
    /// Switch-off voltage \[V], below `v_on`.
    pub v_off: f64,
}

/// The link's energy integrals \[J], from its construction.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LinkEnergy {
    /// Delivered by the supply: `V_s ∫ i_s dt` while it conducts through `R_s`, `−I_sink ∫ v dt`
    /// at its sink limit (negative: taken back).
    pub source: f64,
    /// Lost in the supply's resistance: `R_s ∫ i_s² dt` (none at the sink limit, where the
    /// supply is a current sink at the link).
    pub source_loss: f64,
    /// Dissipated in the brake resistor: `∫ v²/R_b dt`.
    pub brake: f64,
    /// Taken by the converter: `∫ v i_dc dt` (negative: regenerated into the link).
    pub converter: f64,
}

/// A DC link: its parts ([`Source`], [`Chopper`]), the capacitor's voltage, the chopper's
/// state, the energy integrals and the highest voltage reached (module doc: the model and
/// its exact integration).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DcLink {
    /// Capacitance `C` \[F], > 0.
    pub capacitance_f: f64,
    /// The supply.
    pub source: Source,
    /// The brake chopper, if the board has one.
    pub chopper: Option<Chopper>,
    /// The capacitor's voltage \[V].
    pub v_c: f64,
    /// The chopper conducts.
    pub brake_on: bool,
    /// The chopper's gate driven from outside (the drive's brake output): `Some(on)` holds it
    /// on or off, its own thresholds unused; `None`: the chopper's hysteresis.
    pub gate: Option<bool>,
    /// Energy integrals.
    pub energy: LinkEnergy,
    /// The highest capacitor voltage reached \[V].
    pub v_peak: f64,
}

/// Most pieces one sub-step is cut into; beyond, the rest of the sub-step is solved on the
/// last piece. Each piece ends at a boundary: the supply's knee is crossed at most once per
/// sub-step (the solution is monotonic while the chopper holds its state), the rest are the
/// chopper crossing its hysteresis band, two per cycle. So this is reached only by a chopper
/// cycling 2,000 times in one sub-step (at 10 µs, a 200 MHz chopper: a band of 1 V crossed in
/// 5 ns, e.g. 1 µF against 200 A), far beyond any real one; the bound keeps the time of a
/// sub-step bounded whatever the settings.
const MAX_PIECES: usize = 4096;

/// One linear piece: `C dv/dt = a − g v`.
#[derive(Clone, Copy)]
struct Piece {
    a: f64,
    g: f64,
    /// The supply at its sink limit (otherwise it conducts through `R_s`).
    limited: bool,
}

/// The exact solution over `t`: the voltage at its end, `∫ v dt` and `∫ v² dt`.
fn solve(c: f64, p: Piece, v0: f64, t: f64) -> (f64, f64, f64) {
    if p.g > 0.0 {
        let tau = c / p.g;
        let w = p.a / p.g;
        let d = v0 - w;
        let x = t / tau;
        let e1 = -Float::exp_m1(-x);
        let e2 = -Float::exp_m1(-2.0 * x);
        let v = w + d * Float::exp(-x);
        (
            v,
            w * t + d * tau * e1,
            w * w * t + 2.0 * w * d * tau * e1 + d * d * 0.5 * tau * e2,
        )
    } else {
        let s = p.a / c;
        (
            v0 + s * t,
            v0 * t + 0.5 * s * t * t,
            v0 * v0 * t + v0 * s * t * t + s * s * t * t * t / 3.0,
        )
    }
}

/// When the solution from `v0` reaches `b` \[s], if it does (moving towards it).
fn reach(c: f64, p: Piece, v0: f64, b: f64) -> Option<f64> {
    if p.g > 0.0 {
        let w = p.a / p.g;
        let between = (v0 < b && b < w) || (w < b && b < v0);
        between.then(|| c / p.g * Float::ln((v0 - w) / (b - w)))
    } else {
        let t = c * (b - v0) / p.a;
        (t > 0.0 && t.is_finite()).then_some(t)
    }
}

impl DcLink {
    /// A link of `capacitance_f` \[F] on `source`, with `chopper` if any, charged to the
    /// supply's open-circuit voltage (at rest), the chopper off.
    pub fn new(capacitance_f: f64, source: Source, chopper: Option<Chopper>) -> Self {
        Self {
            capacitance_f,
            source,
            chopper,
            v_c: source.v_open,
            brake_on: false,
            gate: None,
            energy: LinkEnergy::default(),
            v_peak: source.v_open,
        }
    }

    /// Energy in the capacitor `C v²/2` \[J].
    pub fn stored_energy(&self) -> f64 {
        0.5 * self.capacitance_f * self.v_c * self.v_c
    }

    /// The supply's knee \[V]: above it the supply is at its sink limit.
    fn knee(&self) -> f64 {
        self.source.v_open + self.source.r_ohm * self.source.sink_a
    }

    /// The piece at the present voltage for the held `i_dc` (at the knee, the side the
    /// voltage moves to).
    fn piece(&self, i_dc: f64) -> Piece {
        let s = self.source;
        let g_brake = match self.chopper {
            Some(ch) if self.brake_on => 1.0 / ch.r_ohm,
            _ => 0.0,
        };
        let limited = Piece {
            a: -s.sink_a - i_dc,
            g: g_brake,
            limited: true,
        };
        let knee = self.knee();
        if self.v_c > knee || (self.v_c == knee && limited.a - limited.g * knee > 0.0) {
            limited
        } else {
            Piece {
                a: s.v_open / s.r_ohm - i_dc,
                g: 1.0 / s.r_ohm + g_brake,
                limited: false,
            }
        }
    }

    /// The chopper's hysteresis at the present voltage.
    fn switch_chopper(&mut self) {
        if let (Some(_), Some(on)) = (self.chopper, self.gate) {
            self.brake_on = on;
            return;
        }
        if let Some(ch) = self.chopper {
            if !self.brake_on && self.v_c >= ch.v_on {
                self.brake_on = true;
            } else if self.brake_on && self.v_c <= ch.v_off {
                self.brake_on = false;
            }
        }
    }

    /// The voltages at which a piece ends: the supply's knee, the chopper's next threshold
    /// (which one the solution reaches, if any, [`reach`] says).
    fn boundaries(&self) -> [Option<f64>; 2] {
        let chopper = self.chopper.filter(|_| self.gate.is_none()).map(|ch| {
            if self.brake_on {
                ch.v_off
            } else {
                ch.v_on
            }
        });
        [Some(self.knee()), chopper]
    }

    /// Adds one piece's energies over `t` given its `∫ v dt` and `∫ v² dt`.
    fn account(&mut self, p: Piece, i_dc: f64, t: f64, int_v: f64, int_v2: f64) {
        let s = self.source;
        let e = &mut self.energy;
        e.converter += i_dc * int_v;
        if let Some(ch) = self.chopper.filter(|_| self.brake_on) {
            e.brake += int_v2 / ch.r_ohm;
        }
        if p.limited {
            e.source -= s.sink_a * int_v;
        } else {
            e.source += s.v_open * (s.v_open * t - int_v) / s.r_ohm;
            e.source_loss += (s.v_open * s.v_open * t - 2.0 * s.v_open * int_v + int_v2) / s.r_ohm;
        }
    }
}

impl Supply for DcLink {
    fn v_dc(&self) -> f64 {
        self.v_c
    }

    /// Integrates `C dv/dt = i_s − i_dc − i_b` exactly over `h` with `i_dc` held, piece by
    /// piece (module doc).
    fn draw(&mut self, i_dc: f64, h: f64) {
        let c = self.capacitance_f;
        let mut left = h;
        for n in 0..MAX_PIECES {
            if left <= 0.0 {
                break;
            }
            self.switch_chopper();
            let p = self.piece(i_dc);
            let end = if n + 1 < MAX_PIECES {
                self.boundaries()
                    .into_iter()
                    .flatten()
                    .filter_map(|b| reach(c, p, self.v_c, b).map(|t| (t, b)))
                    .filter(|&(t, _)| t < left)
                    .reduce(|x, y| if y.0 < x.0 { y } else { x })
            } else {
                None
            };
            let t = end.map_or(left, |(t, _)| t);
            let (v, int_v, int_v2) = solve(c, p, self.v_c, t);
            self.account(p, i_dc, t, int_v, int_v2);
            self.v_c = end.map_or(v, |(_, b)| b);
            self.v_peak = self.v_peak.max(self.v_c);
            left -= t;
        }
    }
}
