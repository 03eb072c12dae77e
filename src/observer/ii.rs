//! Immersion-and-invariance speed and load-torque observer of Ortega et al. Sec IV,
//! eq (30) with (26)-(29), driven by the flux observer's angle.
//!
//! Mechanical model in electrical speed (the paper normalises with n_P = 1; here
//! `J' = J/N`, `f' = B/N`, `ω = ω_e = N ω_m`): `J' ω̇ = τ − f'ω − τ_L`, `θ̇_e = ω`, and
//! `η = (ω, τ_L/J')`, `h = (sin θ_e, cos θ_e)`, `ḣ = Ψ(h) η` (eqs (23)-(25)).
//!
//! ```text
//! dĥ/dt = [h2; −h1] η̂1 − ρ1(r)(ĥ − h)
//! dξ/dt = [τ/J' − (f'/J') η̂1 − η̂2; 0] + [η̂1 (1 − hᵀĥ) + ρ1(r) ρ2(h, ĥ)] δ
//! dr/dt = −(k1/4)(r − 1) + (k2 k5/(2k1)) r (1 − hᵀĥ)²,     r(0) ≥ 1
//! η̂    = ξ + ρ2(h, ĥ) δ                                                   (30)
//! ρ1(r) = k4 + ½(k2 k5/k1 + k3) r²,   ρ2(h, ĥ) = h1 ĥ2 − ĥ1 h2
//! ```
//! Tuning: the poles of `A* = [[−a1, −1], [a2, 0]]` are given as two distinct rates p1 < p2
//! (`a1 = p1 + p2`, `a2 = p1 p2`, so `a1 > 2√a2`; eq (27) also asks `a1 > 4`), and `k4 > 0`.
//! `T` in (28) is built from unit-length left eigenvectors of `A*` (the paper leaves its
//! scale free; `k3` depends on it, `k5` does not).
//!
//! Discretisation at period T (the paper's T matrix is called `tm` here):
//! - `ĥ` is stored as the error `d = ĥ − h` (so `ρ2 = h1 d2 − d1 h2` has no cancellation in
//!   f32) and stepped implicitly in `ρ1`, which is stiff: `ρ1·T` is of order 1e5 with the
//!   default poles. The step is unconditionally stable for any `r`.
//! - The drift `Ψ(h)η̂1` of `ĥ` is integrated as the chord `R(η̂1T)h − h` (h turned by
//!   `η̂1·T`) rather than the tangent `TΨ(h)η̂1`: the tangent makes the innovation vanish at
//!   `η̂1 = tan(ω_eT)/T`, a speed bias of `(ω_eT)²/3` (3.6 rpm at 1000 rpm on the Sinano motor
//!   at 4 kHz, measured).
//! - The speed estimate after the update at `t_k` is that of the middle of the coming period,
//!   `t_k + T/2` (measured in `tests/flux.rs`): what the voltage applied next will meet.
//! - `ξ` is stepped with forward Euler; `r` semi-implicitly and kept in `[1, r_max]` (the proof
//!   bounds `r`; the clamp keeps f32 finite if a transient pushes it far).

use crate::math::{clamp, sin_cos};
use crate::motor::MotorParams;
use crate::param::{Allowed, Checks, ParamError};
use core::f32::consts::TAU;

/// I&I observer settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IiConfig {
    /// Motor model (J, B, N).
    pub motor: MotorParams,
    /// Update rate \[Hz].
    pub rate_hz: f32,
    /// Slower pole of `A*` \[Hz], > 0.
    pub pole_slow_hz: f32,
    /// Faster pole of `A*` \[Hz], > `pole_slow_hz`, and `2π·pole_fast_hz·T < 0.5`.
    pub pole_fast_hz: f32,
    /// High-gain injection k4 > 0 (keep small, Remark 5).
    pub k4: f32,
    /// Upper clamp of the dynamic scaling r, > 1.
    pub r_max: f32,
}

impl IiConfig {
    /// Defaults: poles 25 Hz and 100 Hz (faster than a 20 Hz speed loop), k4 = 1, r_max = 100.
    pub fn new(motor: MotorParams, rate_hz: f32) -> Self {
        Self {
            motor,
            rate_hz,
            pole_slow_hz: 25.0,
            pole_fast_hz: 100.0,
            k4: 1.0,
            r_max: 100.0,
        }
    }

    /// Validates and computes k1..k5, δ (eqs (26)-(29)).
    pub fn build(&self) -> Result<IiObserver, ParamError> {
        let m = self.motor.validate()?;
        let rate = self.rate_hz;
        let mut c = Checks::new();
        c.check("rate_hz", rate, Allowed::POSITIVE);
        c.check("pole_slow_hz", self.pole_slow_hz, Allowed::POSITIVE);
        // p2 > p1, a1 = p1 + p2 > 4 (eq (27)) and the fast pole inside the discrete range.
        let p2_min = self.pole_slow_hz.max(4.0 / TAU - self.pole_slow_hz);
        let fast = Allowed::strictly_between(p2_min, 0.5 * rate / TAU).because(
            "above pole_slow_hz, a1 = 2*pi*(slow + fast) above 4, 2*pi*fast/rate below 0.5",
        );
        c.check("pole_fast_hz", self.pole_fast_hz, fast);
        c.check("k4", self.k4, Allowed::POSITIVE);
        c.check(
            "r_max",
            self.r_max,
            Allowed::above_up_to(1.0, f32::INFINITY),
        );
        c.done()?;
        let ts = 1.0 / rate;
        let (p1, p2, k4) = (TAU * self.pole_slow_hz, TAU * self.pole_fast_hz, self.k4);
        let (a1, a2) = (p1 + p2, p1 * p2);
        let f_over_j = m.b_nms / m.j_kgm2;
        let delta = [a1 - f_over_j, -a2]; // (26)
        let k1 = p1; // ½(a1 − √(a1² − 4a2)) = the slower pole
        let k2 = delta[0] * delta[0] + delta[1] * delta[1];
        // Left eigenvectors of A* for λ = −p1, −p2 are [p, 1]; unit length rows of T (28).
        let row = |p: f32| {
            let n = crate::math::sqrt_call(p * p + 1.0);
            [p / n, 1.0 / n]
        };
        let (t1, t2) = (row(p1), row(p2));
        let tm = [[t1[0], t1[1]], [t2[0], t2[1]]];
        let det = tm[0][0] * tm[1][1] - tm[0][1] * tm[1][0];
        let inv = [
            [tm[1][1] / det, -tm[0][1] / det],
            [-tm[1][0] / det, tm[0][0] / det],
        ];
        let k3 = norm2(inv); // (29)
        let k5 = norm2(tm) * k3;
        Ok(IiObserver {
            ts,
            n: m.n(),
            torque_over_j: m.n() / m.j_kgm2,
            f_over_j,
            j_over_n: m.j_kgm2 / m.n(),
            delta,
            k1,
            c_r: k2 * k5 / (2.0 * k1),
            rho1_r2: 0.5 * (k2 * k5 / k1 + k3),
            k4,
            r_max: self.r_max,
        })
    }
}

/// Induced 2-norm (largest singular value) of a 2×2 matrix.
fn norm2(m: [[f32; 2]; 2]) -> f32 {
    let f2 = m[0][0] * m[0][0] + m[0][1] * m[0][1] + m[1][0] * m[1][0] + m[1][1] * m[1][1];
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let disc = crate::math::sqrt_call((f2 * f2 - 4.0 * det * det).max(0.0));
    crate::math::sqrt_call(0.5 * (f2 + disc))
}

/// A built I&I observer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IiObserver {
    ts: f32,
    n: f32,
    /// `1/J'` = N/J: τ/J' per N·m.
    torque_over_j: f32,
    /// f'/J' = B/J \[1/s].
    f_over_j: f32,
    /// J' = J/N, to turn η2 into a torque.
    j_over_n: f32,
    delta: [f32; 2],
    k1: f32,
    /// k2·k5/(2k1).
    c_r: f32,
    /// ½(k2k5/k1 + k3): ρ1 = k4 + rho1_r2·r².
    rho1_r2: f32,
    k4: f32,
    r_max: f32,
}

/// I&I observer state.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IiState {
    /// `h = (sin θ_e, cos θ_e)` of the last sample.
    pub h: [f32; 2],
    /// `d = ĥ − h`.
    pub d: [f32; 2],
    /// ξ of eq (30): [rad/s, rad/s²].
    pub xi: [f32; 2],
    /// Dynamic scaling r ≥ 1.
    pub r: f32,
    /// False until the first sample.
    pub started: bool,
}

impl Default for IiState {
    fn default() -> Self {
        Self {
            h: [0.0, 1.0],
            d: [0.0; 2],
            xi: [0.0; 2],
            r: 1.0,
            started: false,
        }
    }
}

/// Estimates of the I&I observer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IiEstimate {
    /// ω̂_m [rad/s, mechanical].
    pub omega_m: f32,
    /// τ̂_L \[N·m].
    pub load_nm: f32,
}

impl IiObserver {
    /// `η̂ = ξ + ρ2(h, ĥ) δ` for a state.
    fn eta(&self, st: &IiState) -> [f32; 2] {
        let rho2 = st.h[0] * st.d[1] - st.d[0] * st.h[1];
        [
            st.xi[0] + rho2 * self.delta[0],
            st.xi[1] + rho2 * self.delta[1],
        ]
    }

    /// The estimates of a state.
    pub fn estimate(&self, st: &IiState) -> IiEstimate {
        let eta = self.eta(st);
        IiEstimate {
            omega_m: eta[0] / self.n,
            load_nm: eta[1] * self.j_over_n,
        }
    }

    /// One sample: `sin_cos_theta_e` = (sin, cos) of the angle estimate now; `torque_nm` the
    /// electromagnetic torque `N Φ i_q` over the period that just ended \[N·m]. Returns false
    /// and leaves the state untouched on non-finite input or output.
    pub fn update(&self, st: &mut IiState, sin_cos_theta_e: (f32, f32), torque_nm: f32) -> bool {
        let h_new = [sin_cos_theta_e.0, sin_cos_theta_e.1];
        if !(h_new[0].is_finite() && h_new[1].is_finite() && torque_nm.is_finite()) {
            return false;
        }
        if !st.started {
            *st = IiState {
                h: h_new,
                started: true,
                ..IiState::default()
            };
            return true;
        }
        let t = self.ts;
        let eta = self.eta(st);
        let rho2 = st.h[0] * st.d[1] - st.d[0] * st.h[1];
        let one_minus_hth = -(st.h[0] * st.d[0] + st.h[1] * st.d[1]); // 1 − hᵀĥ, |h| = 1
        let rho1 = self.k4 + self.rho1_r2 * st.r * st.r;
        // ξ, forward Euler.
        let innov = eta[0] * one_minus_hth + rho1 * rho2;
        let xi = [
            st.xi[0]
                + t * (self.torque_over_j * torque_nm - self.f_over_j * eta[0] - eta[1]
                    + innov * self.delta[0]),
            st.xi[1] + t * innov * self.delta[1],
        ];
        // ĥ as d = ĥ − h, implicit in ρ1: d⁺ = (d + R(η̂1 T) h − h⁺)/(1 + ρ1 T), where the
        // chord R(φ)h − h (h turned by φ = η̂1·T) integrates Ψ(h)η̂1 over the period.
        let (sp, cp) = sin_cos(eta[0] * t);
        let h_turned = [st.h[0] * cp + st.h[1] * sp, st.h[1] * cp - st.h[0] * sp];
        let k = 1.0 / (1.0 + rho1 * t);
        let d = [
            (st.d[0] + h_turned[0] - h_new[0]) * k,
            (st.d[1] + h_turned[1] - h_new[1]) * k,
        ];
        // r: leakage implicit, growth explicit, kept in [1, r_max].
        let e = -(h_new[0] * d[0] + h_new[1] * d[1]);
        let a = 0.25 * self.k1 * t;
        let r = clamp(
            (st.r * (1.0 + t * self.c_r * e * e) + a) / (1.0 + a),
            1.0,
            self.r_max,
        );
        let next = IiState {
            h: h_new,
            d,
            xi,
            r,
            started: true,
        };
        let ok = xi.iter().chain(d.iter()).all(|x| x.is_finite()) && r.is_finite();
        if ok {
            *st = next;
        }
        ok
    }

    /// Starts at a known speed [rad/s mechanical] and load \[N·m], angle `sin_cos_theta_e`.
    pub fn reset(&self, st: &mut IiState, sin_cos_theta_e: (f32, f32), omega_m: f32, load_nm: f32) {
        *st = IiState {
            h: [sin_cos_theta_e.0, sin_cos_theta_e.1],
            d: [0.0; 2],
            xi: [omega_m * self.n, load_nm / self.j_over_n],
            r: 1.0,
            started: true,
        };
    }
}
