//! The composed plant: the windings ([`Pmsm`]) and the rotor ([`Rotor`]) fed by a
//! [`Converter`] from a [`Supply`], integrated with RK4 on fixed sub-steps. The DC-link
//! voltage is held over a sub-step; after it the supply takes the sub-step's mean DC-link
//! current.

use crate::converter::{Clamped, Converter, DiodeBridge};
use crate::electrical::Pmsm;
use crate::frames::{clarke, inverse_clarke};
use crate::mechanical::{Load, Rotor};
use crate::params::PlantParams;
use crate::state::{PlantState, DIM, OMEGA, Q_DC};
use crate::supply::{StiffBus, Supply};

/// The plant: the motor's parameters, its state, its shaft and its DC supply.
#[derive(Clone, Debug)]
pub struct Plant<S: Supply = StiffBus> {
    /// Parameters.
    pub params: PlantParams,
    /// State.
    pub state: PlantState,
    /// The shaft is blocked: θ and ω stay as they are.
    pub blocked: bool,
    /// The DC bus.
    pub supply: S,
}

/// The parts as one sub-step sees them.
struct Parts {
    pmsm: Pmsm,
    rotor: Rotor,
    v_dc: f64,
}

impl Parts {
    /// d/dt of the state array for the converter `conv` and the load torque `tau_l`, and the
    /// stator voltage it applies \[V].
    fn derivative<C: Converter>(
        &self,
        x: &[f64; DIM],
        conv: &C,
        tau_l: f64,
    ) -> ([f64; DIM], (f64, f64)) {
        let (i, theta, omega) = ((x[0], x[1]), x[2], x[OMEGA]);
        let (sc, e) = self.pmsm.back_emf(theta, omega);
        let v = conv.v_alpha_beta(self.v_dc, i, e);
        let di = self.pmsm.di_dt(i, sc, omega, e, v); // (16), (17) or the dq model
        let torque = self.pmsm.torque(i, sc);
        let (dtheta, domega) = self.rotor.derivative(omega, torque, tau_l); // (18), (19)
        let p_stator = self.pmsm.power(v, i);
        let dx = [
            di.0,
            di.1,
            dtheta,
            domega,
            p_stator,
            self.pmsm.copper_loss(i),
            self.rotor.friction_loss(omega),
            tau_l * omega,
            i.1 * sc.1 - i.0 * sc.0,
            conv.i_dc(self.v_dc, p_stator),
        ];
        (dx, v)
    }
}

impl<S: Supply> Plant<S> {
    /// A plant on `supply` with zero current, rotor at `theta_m0` [rad, mechanical] turning at
    /// `omega_m0` \[rad/s].
    pub fn new(params: PlantParams, supply: S, theta_m0: f64, omega_m0: f64) -> Self {
        Self {
            params,
            state: PlantState {
                theta_m: theta_m0,
                omega_m: omega_m0,
                ..Default::default()
            },
            blocked: false,
            supply,
        }
    }

    /// Phase currents `(a, b, c)` \[A] (inverse amplitude-invariant Clarke).
    pub fn i_abc(&self) -> [f64; 3] {
        inverse_clarke(self.state.i_alpha, self.state.i_beta)
    }

    /// Advances by `n_sub` RK4 sub-steps of `h` seconds each fed by `converter`, with the
    /// load torque `tau_l(t_rel, ω)` evaluated at each stage (`t_rel` from the start of the
    /// call). Returns the stator voltage `(v_α, v_β)` \[V] over the call, the mean of each
    /// sub-step's at its start.
    pub fn advance<C: Converter>(
        &mut self,
        converter: &C,
        tau_l: impl Load,
        h: f64,
        n_sub: usize,
    ) -> (f64, f64) {
        let mut x = self.state.to_array();
        let mut v_sum = (0.0, 0.0);
        for k in 0..n_sub {
            let (next, v) = self.sub_step(converter, &tau_l, k as f64 * h, h, &x);
            v_sum = (v_sum.0 + v.0, v_sum.1 + v.1);
            x = next;
        }
        self.state = PlantState::from_array(x);
        mean(v_sum, n_sub)
    }

    /// Advances with every switch off ([`DiodeBridge`]): `n_sub` sub-steps of `h` seconds,
    /// each with the diode pattern of its start, the blocked diodes' currents zeroed after it.
    /// Returns the stator voltage `(v_α, v_β)` \[V] over the call, the mean of each sub-step's
    /// at its start: what a board's terminal-voltage sensing reads.
    pub fn advance_off(&mut self, tau_l: impl Load, h: f64, n_sub: usize) -> (f64, f64) {
        let mut v_sum = (0.0, 0.0);
        for k in 0..n_sub {
            let v_dc = self.supply.v_dc();
            let s = self.state;
            let (_, e) = self.params.electrical().back_emf(s.theta_m, s.omega_m);
            let pole = DiodeBridge::pattern(v_dc, self.i_abc(), inverse_clarke(e.0, e.1));
            let (next, v) =
                self.sub_step(&Clamped { pole }, &tau_l, k as f64 * h, h, &s.to_array());
            v_sum = (v_sum.0 + v.0, v_sum.1 + v.1);
            self.state = PlantState::from_array(next);
            let i = DiodeBridge::block(&pole, self.i_abc(), v_dc);
            (self.state.i_alpha, self.state.i_beta) = clarke(i);
        }
        mean(v_sum, n_sub)
    }

    /// One RK4 sub-step of `h` seconds from `x` at `t0` (from the start of the call) fed by
    /// `conv`; the supply then takes its mean DC-link current. The next state and the stator
    /// voltage at the sub-step's start.
    fn sub_step<C: Converter, L: Load>(
        &mut self,
        conv: &C,
        tau_l: &L,
        t0: f64,
        h: f64,
        x: &[f64; DIM],
    ) -> ([f64; DIM], (f64, f64)) {
        let parts = Parts {
            pmsm: self.params.electrical(),
            rotor: self.params.mechanical(self.blocked),
            v_dc: self.supply.v_dc(),
        };
        let add = |x: &[f64; DIM], d: &[f64; DIM], s: f64| -> [f64; DIM] {
            core::array::from_fn(|i| x[i] + s * d[i])
        };
        let stage = |x: &[f64; DIM], t: f64| parts.derivative(x, conv, tau_l(t, x[OMEGA]));
        let (k1, v) = stage(x, t0);
        let (k2, _) = stage(&add(x, &k1, 0.5 * h), t0 + 0.5 * h);
        let (k3, _) = stage(&add(x, &k2, 0.5 * h), t0 + 0.5 * h);
        let (k4, _) = stage(&add(x, &k3, h), t0 + h);
        let next: [f64; DIM] =
            core::array::from_fn(|i| x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        self.supply.draw((next[Q_DC] - x[Q_DC]) / h, h);
        (next, v)
    }
}

/// The mean of `n` summed voltages.
fn mean(sum: (f64, f64), n: usize) -> (f64, f64) {
    let n = n as f64;
    (sum.0 / n, sum.1 / n)
}
