//! Load-torque observer of the speed loop: the reduced-order disturbance observer of the
//! mechanical equation, for a driving observer that estimates no load torque (the flux
//! observer with its PLL). Its estimate is fed forward into the speed loop as the sliding
//! torque observer's is (Horng & Chin Fig 4), so that a load that changes faster than the speed
//! PI's integrator can follow (a ramp of rated torque per second needs a steady speed error of
//! 26 rpm on the Sinano motor) does not stop the rotor.
//!
//! Mechanics (Horng & Chin eq (19), Ortega eq (2)), ω mechanical: `J dω/dt = K_t i_q − B ω − τ_L`.
//! With `τ̂ = z − g J ω̂` and `dz/dt = −g z + g² J ω̂ + g (K_t i_q − B ω̂)` the error obeys
//! `d(τ̂ − τ_L)/dt = −g (τ̂ − τ_L)` for a constant load: a first-order estimate of bandwidth g
//! without differentiating the speed (Ohishi, Ohnishi, Miyachi, "Torque-speed regulation of DC
//! motor based on load torque estimation", IPEC Tokyo 1983; the form of Lorenz & Van Patten,
//! IEEE Trans. Ind. Appl. 27(4), 1991). Stepped with forward Euler at the speed loop's rate.

use crate::param::{Allowed, Checks, ParamError};

/// Settings in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadObserverConfig {
    /// Inertia J \[kg·m²].
    pub j_kgm2: f32,
    /// Viscous friction B \[N·m·s/rad].
    pub b_nms: f32,
    /// Torque constant K_t = N ψ_f \[N·m/A].
    pub torque_constant: f32,
    /// Bandwidth g/2π \[Hz], at most a tenth of the rate.
    pub bandwidth_hz: f32,
    /// Update rate \[Hz] (the speed loop's).
    pub rate_hz: f32,
}

/// A built load-torque observer: per-sample coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LoadObserver {
    /// 1 − g T.
    a: f32,
    /// g² J T \[N·m·s/rad].
    b_omega: f32,
    /// g T.
    g_ts: f32,
    /// g J \[N·m·s/rad].
    g_j: f32,
    /// K_t \[N·m/A], B \[N·m·s/rad].
    kt: f32,
    b_nms: f32,
}

/// Running state: `z` \[N·m].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LoadObserverState {
    z: f32,
}

impl LoadObserverConfig {
    /// Validates and precomputes.
    pub fn build(&self) -> Result<LoadObserver, ParamError> {
        let mut c = Checks::new();
        c.check("j_kgm2", self.j_kgm2, Allowed::POSITIVE);
        c.check("b_nms", self.b_nms, Allowed::NON_NEGATIVE);
        c.check("torque_constant", self.torque_constant, Allowed::POSITIVE);
        c.check("rate_hz", self.rate_hz, Allowed::POSITIVE);
        let bw = Allowed::above_up_to(0.0, 0.1 * self.rate_hz).because("rate/10");
        c.check("bandwidth_hz", self.bandwidth_hz, bw);
        c.done()?;
        let g = core::f32::consts::TAU * self.bandwidth_hz;
        let ts = 1.0 / self.rate_hz;
        Ok(LoadObserver {
            a: 1.0 - g * ts,
            b_omega: g * g * self.j_kgm2 * ts,
            g_ts: g * ts,
            g_j: g * self.j_kgm2,
            kt: self.torque_constant,
            b_nms: self.b_nms,
        })
    }
}

impl LoadObserver {
    /// The estimate τ̂_L \[N·m] at speed `omega_m` \[rad/s].
    #[inline(always)]
    pub fn load_nm(&self, st: &LoadObserverState, omega_m: f32) -> f32 {
        st.z - self.g_j * omega_m
    }

    /// One sample: `omega_m` the speed estimate \[rad/s], `i_q_a` the q current commanded over
    /// the period that ends \[A]. Returns τ̂_L \[N·m]. A non-finite input leaves the state.
    #[inline(always)]
    pub fn update(&self, st: &mut LoadObserverState, omega_m: f32, i_q_a: f32) -> f32 {
        let z = self.a * st.z
            + self.b_omega * omega_m
            + self.g_ts * (self.kt * i_q_a - self.b_nms * omega_m);
        if z.is_finite() {
            st.z = z;
        }
        self.load_nm(st, omega_m)
    }

    /// Starts at the estimate `load_nm` \[N·m] at speed `omega_m` \[rad/s].
    pub fn reset(&self, st: &mut LoadObserverState, load_nm: f32, omega_m: f32) {
        st.z = load_nm + self.g_j * omega_m;
    }
}
