//! PMSM plant in the stationary frame, f64, integrated with RK4 on a fixed sub-step.
//!
//! Horng & Chin eqs (16)-(19) (equivalently Ortega (1)-(2)), θ and ω mechanical:
//! ```text
//! di_α/dt = −R/L i_α + (ψN/L) ω sin Nθ + v_α/L            (16)
//! di_β/dt = −R/L i_β − (ψN/L) ω cos Nθ + v_β/L            (17)
//! dθ/dt   = ω                                             (18)
//! dω/dt   = −(ψN/J)(i_α sin Nθ − i_β cos Nθ) − B/J ω − τ_L/J   (19)
//! ```
//! The state also carries four energy integrals (input, copper, friction, load) so the power
//! balance can be checked to integration accuracy, and ∫ i_q dt for exact time averages.

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
        }
    }
}

/// Plant state (and energy integrals, all in J).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PlantState {
    /// Stator current α \[A].
    pub i_alpha: f64,
    /// Stator current β \[A].
    pub i_beta: f64,
    /// Rotor angle, mechanical, not wrapped \[rad].
    pub theta_m: f64,
    /// Rotor speed, mechanical \[rad/s].
    pub omega_m: f64,
    /// ∫ v·i dt: electrical energy in.
    pub e_in: f64,
    /// ∫ R|i|² dt: copper loss.
    pub e_copper: f64,
    /// ∫ B ω² dt: friction loss.
    pub e_friction: f64,
    /// ∫ τ_L ω dt: energy delivered to the load.
    pub e_load: f64,
    /// ∫ i_q dt \[A·s], for exact time averages of the torque current.
    pub iq_dt: f64,
}

const DIM: usize = 9;

impl PlantState {
    fn to_array(self) -> [f64; DIM] {
        [
            self.i_alpha,
            self.i_beta,
            self.theta_m,
            self.omega_m,
            self.e_in,
            self.e_copper,
            self.e_friction,
            self.e_load,
            self.iq_dt,
        ]
    }

    fn from_array(x: [f64; DIM]) -> Self {
        Self {
            i_alpha: x[0],
            i_beta: x[1],
            theta_m: x[2],
            omega_m: x[3],
            e_in: x[4],
            e_copper: x[5],
            e_friction: x[6],
            e_load: x[7],
            iq_dt: x[8],
        }
    }

    /// Electrical angle Nθ, not wrapped \[rad].
    pub fn theta_e(&self, p: &PlantParams) -> f64 {
        p.n * self.theta_m
    }

    /// Currents in the true rotor frame `(i_d, i_q)` \[A].
    pub fn i_dq(&self, p: &PlantParams) -> (f64, f64) {
        let (s, c) = self.theta_e(p).sin_cos();
        (
            c * self.i_alpha + s * self.i_beta,
            -s * self.i_alpha + c * self.i_beta,
        )
    }

    /// Electromagnetic torque `N ψ (i_β cos Nθ − i_α sin Nθ)` \[N·m] (Ortega (2)).
    pub fn torque(&self, p: &PlantParams) -> f64 {
        p.n * p.flux * self.i_dq(p).1
    }

    /// Energy stored in the inductance and the rotor \[J].
    pub fn stored_energy(&self, p: &PlantParams) -> f64 {
        0.5 * p.l * (self.i_alpha * self.i_alpha + self.i_beta * self.i_beta)
            + 0.5 * p.j * self.omega_m * self.omega_m
    }
}

/// What feeds the stator during a sub-step: its voltage as a function of the currents (the
/// inverter's dead time depends on their sign) and of the back-EMF term `e = KNω[sin, −cos]`
/// of eqs (16)-(17) (an open circuit is `v = −e` at zero current).
pub trait Supply {
    /// Stator voltage `(v_α, v_β)` \[V] given the currents `i` and the back-EMF term `e`.
    fn v_alpha_beta(&self, i: (f64, f64), e: (f64, f64)) -> (f64, f64);
}

/// The inverter with every switch off: each phase terminal is held by its freewheeling
/// diodes (a three-phase diode bridge into a stiff bus). A phase whose current flows into the
/// motor (`i > 0`) conducts through its low diode, terminal at 0 V; one whose current flows
/// out (`i < 0`) through its high diode, terminal at `V_bus`; a phase without current floats
/// at the potential the motor gives it, and starts conducting when that potential leaves
/// [0, V_bus] (Mohan, Undeland, Robbins, *Power Electronics*, 3rd ed., Sec 5-6, the
/// three-phase diode rectifier; here the back-EMF is the source). Below the bus the motor
/// coasts without current; above it the bridge brakes it into the bus.
///
/// Within a sub-step the conduction pattern is fixed (`DiodeBridge::pattern`, from the
/// currents and back-EMF at its start); after it, a diode whose current has crossed zero
/// blocks (`DiodeBridge::block`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DiodeBridge {
    /// DC bus voltage \[V].
    pub v_bus: f64,
}

/// The terminal voltage of each conducting phase relative to the bus's negative rail \[V]
/// (0 or `V_bus`); `None`: the phase floats with zero current.
type Pattern = [Option<f64>; 3];

impl DiodeBridge {
    /// Which diodes conduct given the phase currents `i_abc` \[A] and the back-EMF term
    /// `e_abc` \[V] of eqs (16)-(17) per phase.
    fn pattern(&self, i_abc: [f64; 3], e_abc: [f64; 3]) -> Pattern {
        let v = self.v_bus;
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
        let others: Vec<f64> = (0..3).filter(|&k| k != f).filter_map(|k| pole[k]).collect();
        match others[..] {
            [u1, u2] => Some(0.5 * (u1 + u2) - 1.5 * e_f),
            _ => None,
        }
    }

    /// Currents after a sub-step: a phase whose diode's current crossed zero, or that was
    /// floating, carries none; the rest keep a zero sum.
    fn block(pattern: &Pattern, i_abc: [f64; 3], v_bus: f64) -> [f64; 3] {
        let mut i: [f64; 3] = std::array::from_fn(|k| match pattern[k] {
            Some(u) if u == v_bus && i_abc[k] < 0.0 => i_abc[k],
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
struct Clamped {
    pole: Pattern,
}

impl Supply for Clamped {
    fn v_alpha_beta(&self, _i: (f64, f64), e: (f64, f64)) -> (f64, f64) {
        if self.pole.iter().all(Option::is_none) {
            return (-e.0, -e.1);
        }
        let e_abc = crate::inverter::inverse_clarke(e.0, e.1);
        let u: [f64; 3] = std::array::from_fn(|k| {
            self.pole[k]
                .or_else(|| DiodeBridge::floating(&self.pole, k, e_abc[k]))
                .unwrap_or(0.0)
        });
        let star = (u[0] + u[1] + u[2]) / 3.0;
        crate::inverter::clarke(u.map(|x| x - star))
    }
}

/// Load torque \[N·m] as a function of time from the start of the period \[s] and of speed
/// [rad/s, mechanical].
pub trait Load: Fn(f64, f64) -> f64 {}
impl<F: Fn(f64, f64) -> f64> Load for F {}

fn derivative<S: Supply>(
    p: &PlantParams,
    x: &[f64; DIM],
    supply: &S,
    tau_l: f64,
    locked: bool,
) -> [f64; DIM] {
    let (i_a, i_b, theta, omega) = (x[0], x[1], x[2], x[3]);
    let (s, c) = (p.n * theta).sin_cos();
    let kn = p.flux * p.n;
    let e = (kn * omega * s, -kn * omega * c);
    let (v_a, v_b) = supply.v_alpha_beta((i_a, i_b), e);
    let accel = (-kn * (i_a * s - i_b * c) - p.b * omega - tau_l) / p.j; // (19)
    [
        (-p.r * i_a + e.0 + v_a) / p.l,   // (16)
        (-p.r * i_b + e.1 + v_b) / p.l,   // (17)
        if locked { 0.0 } else { omega }, // (18)
        if locked { 0.0 } else { accel }, // (19)
        v_a * i_a + v_b * i_b,
        p.r * (i_a * i_a + i_b * i_b),
        p.b * omega * omega,
        tau_l * omega,
        i_b * c - i_a * s,
    ]
}

/// The plant: parameters and state.
#[derive(Clone, Debug)]
pub struct Plant {
    /// Parameters.
    pub params: PlantParams,
    /// State.
    pub state: PlantState,
    /// The rotor is held (a blocked shaft): θ and ω stay as they are.
    pub locked: bool,
}

impl Plant {
    /// A plant with zero current, rotor at `theta_m0` [rad, mechanical] turning at
    /// `omega_m0` \[rad/s].
    pub fn new(params: PlantParams, theta_m0: f64, omega_m0: f64) -> Self {
        Self {
            params,
            state: PlantState {
                theta_m: theta_m0,
                omega_m: omega_m0,
                ..Default::default()
            },
            locked: false,
        }
    }

    /// Advances by `n_sub` RK4 sub-steps of `h` seconds each, with the load torque
    /// `tau_l(t_rel, ω)` evaluated at each stage (`t_rel` from the start of the call).
    pub fn advance<S: Supply>(&mut self, supply: &S, tau_l: impl Load, h: f64, n_sub: usize) {
        let p = self.params;
        let mut x = self.state.to_array();
        for k in 0..n_sub {
            let t0 = k as f64 * h;
            let add = |x: &[f64; DIM], d: &[f64; DIM], s: f64| -> [f64; DIM] {
                std::array::from_fn(|i| x[i] + s * d[i])
            };
            let locked = self.locked;
            let stage = |x: &[f64; DIM], t: f64| derivative(&p, x, supply, tau_l(t, x[3]), locked);
            let k1 = stage(&x, t0);
            let k2 = stage(&add(&x, &k1, 0.5 * h), t0 + 0.5 * h);
            let k3 = stage(&add(&x, &k2, 0.5 * h), t0 + 0.5 * h);
            let k4 = stage(&add(&x, &k3, h), t0 + h);
            x = std::array::from_fn(|i| {
                x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])
            });
        }
        self.state = PlantState::from_array(x);
    }

    /// Advances with every switch off ([`DiodeBridge`]): `n_sub` sub-steps of `h` seconds,
    /// each with the diode pattern of its start, the blocked diodes' currents zeroed after it.
    /// Returns the stator voltage `(v_α, v_β)` \[V] over the call, the mean of each sub-step's
    /// at its start: what a board's terminal-voltage sensing reads.
    pub fn advance_off(
        &mut self,
        bridge: &DiodeBridge,
        tau_l: impl Load,
        h: f64,
        n_sub: usize,
    ) -> (f64, f64) {
        let p = self.params;
        let mut v_sum = (0.0, 0.0);
        for k in 0..n_sub {
            let x = &self.state;
            let (s, c) = x.theta_e(&p).sin_cos();
            let kn = p.flux * p.n;
            let e = (kn * x.omega_m * s, -kn * x.omega_m * c);
            let e_abc = crate::inverter::inverse_clarke(e.0, e.1);
            let pole = bridge.pattern(self.i_abc(), e_abc);
            let clamped = Clamped { pole };
            let v = clamped.v_alpha_beta((x.i_alpha, x.i_beta), e);
            v_sum = (v_sum.0 + v.0, v_sum.1 + v.1);
            let t0 = k as f64 * h;
            self.advance(&clamped, |t, w| tau_l(t0 + t, w), h, 1);
            let i = DiodeBridge::block(&pole, self.i_abc(), bridge.v_bus);
            (self.state.i_alpha, self.state.i_beta) = crate::inverter::clarke(i);
        }
        let n = n_sub as f64;
        (v_sum.0 / n, v_sum.1 / n)
    }

    /// Phase currents `(a, b, c)` \[A] (inverse amplitude-invariant Clarke).
    pub fn i_abc(&self) -> [f64; 3] {
        crate::inverter::inverse_clarke(self.state.i_alpha, self.state.i_beta)
    }
}
