//! The d/q current loop: PIs with decoupling and back-EMF feed-forward (Ortega Sec V iv,
//! dq model (3), with `L_d`, `L_q` for a salient motor), and the voltage vector's limit to the
//! circle the inverter applies.

use crate::frames::Dq;
use crate::math::all_finite;
use core::hint::cold_path;

/// The current loop cuts its voltage to at most this fraction of `v_max`, 1 − 2⁻¹⁸.
const CUT_INSIDE: f32 = 1.0 - 1.0 / 262_144.0;

/// d/q current PIs with decoupling, back-EMF feed-forward and voltage-vector saturation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentLoop {
    /// Proportional gains of the d and q PIs, `L_d ω_c`, `L_q ω_c` \[V/A].
    pub(super) kp_d: f32,
    pub(super) kp_q: f32,
    pub(super) ki_ts: f32,
    /// `L_d`, `L_q` \[H] of the decoupling (`L` on both of a non-salient motor).
    pub(super) l_d_h: f32,
    pub(super) l_q_h: f32,
    pub(super) flux_wb: f32,
}

/// Integrators of the current loop \[V].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CurrentLoopState {
    /// d-axis integral term \[V].
    pub integral_d: f32,
    /// q-axis integral term \[V].
    pub integral_q: f32,
}

/// Output of one current-loop update.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentLoopOutput {
    /// Voltage command in the rotor frame \[V], `|v_dq| ≤ v_max` (a cut vector is between
    /// 1 − 1e-5 and 1 − 2⁻¹⁸ of `v_max` long, to f32 rounding).
    pub v_dq: Dq,
    /// The command was cut to (just inside) `v_max`; the integrators were held (but the q
    /// one under a braking command, [`CurrentLoop::update`]).
    pub saturated: bool,
    /// The inputs were usable (finite, `v_max` in range), so `v_dq` is the loop's command;
    /// false: zero volts.
    pub valid: bool,
}

impl CurrentLoop {
    /// One update at the current-loop rate.
    /// `i_dq`, `i_dq_ref` \[A]; `omega_e` electrical speed \[rad/s]; `v_max` the largest
    /// voltage magnitude the inverter can apply \[V], positive, 1.1e-19..1.8e19 (its square a
    /// normal f32). Anti-windup: when the vector is cut to `v_max`, neither integrator moves,
    /// but the q one under a braking command where its step shortens `v_q`.
    /// Non-finite inputs, or a `v_max` outside that range, give zero volts (`saturated`).
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn update(
        &self,
        state: &mut CurrentLoopState,
        i_dq: Dq,
        i_dq_ref: Dq,
        omega_e: f32,
        v_max: f32,
    ) -> CurrentLoopOutput {
        let e_d = i_dq_ref.d - i_dq.d;
        let e_q = i_dq_ref.q - i_dq.q;
        let int_d = state.integral_d + self.ki_ts * e_d;
        let int_q = state.integral_q + self.ki_ts * e_q;
        // Ortega Sec V iv: decoupling and back-EMF feed-forward, with `L_d`, `L_q` of the
        // salient dq model `v_d = R i_d + L_d di_d/dt − ω_e L_q i_q`,
        // `v_q = R i_q + L_q di_q/dt + ω_e (L_d i_d + ψ_f)` (eq (3) when `L_d = L_q`).
        let v_d = self.kp_d * e_d + int_d - omega_e * self.l_q_h * i_dq.q;
        let v_q = self.kp_q * e_q + int_q + omega_e * (self.l_d_h * i_dq.d + self.flux_wb);
        let out = limit(Dq::new(v_d, v_q), v_max);
        // Anti-windup: the integrators move only while the vector is inside the circle, but
        // the q one under a braking command (`i_q*` against the rotation, `i_q* ω_e < 0`)
        // where its step shortens `v_q` (`e_q v_q < 0`): conditional integration (Åström &
        // Hägglund, "Advanced PID Control", ISA 2006, Sec 3.5) where the command brakes.
        // Braking needs less voltage than motoring, `4 R |ω_e| ψ_f |i_q|` less of `|v|²`
        // (`drive/sensorless.rs`, `braking_first`), so the vector stays on the circle then
        // only because the q integrator still holds a motoring voltage: held, it kept the
        // `R i_q` of rated motoring current (5.4 V of the Nanotec DF45's 13.6 V) in the
        // command while the back-EMF of a rotor its load had let go of took the rest, no
        // braking current flowed, and the rotor ran to 5,900 rpm against a 1,590 rpm command
        // until the observers lost it and the drive turned it backwards (issue #26's zoo,
        // `sup-load-steps-*`). While motoring both stay held: the field weakening answers the
        // voltage there, and a q integrator let down on the circle took the torque the load
        // needed (the DF45 under its rated brake at the bus's limit, `sup-start-brake-100`).
        // (Two stores under two conditions, not an `else if`: the compiler selects, where a
        // third branch cost the step 9 cycles of register spills.)
        // (`v_q` as cut, of the same sign: an unusable input's zero volts holds both.)
        let release = i_dq_ref.q * omega_e < 0.0 && e_q * out.v_dq.q < 0.0;
        if !out.saturated {
            state.integral_d = int_d;
        }
        if !out.saturated || release {
            state.integral_q = int_q;
        }
        out
    }
}

/// `v_dq` \[V] limited to the circle of radius `v_max` \[V] (positive, 1.1e-19..1.8e19 V, its
/// square a normal f32); non-finite inputs or a `v_max` outside that range give zero volts,
/// `valid` false.
#[inline(always)]
pub(super) fn limit(v_dq: Dq, v_max: f32) -> CurrentLoopOutput {
    let (v_d, v_q) = (v_dq.d, v_dq.q);
    let mag2 = v_d * v_d + v_q * v_q;
    let v_max2 = v_max * v_max;
    // `v_max` positive and its square normal (1.1e-19..1.8e19 V): then a vector to cut has
    // a normal |v|².
    if !(v_max > 0.0 && v_max2 >= f32::MIN_POSITIVE && all_finite([mag2, v_max2])) {
        cold_path();
        return CurrentLoopOutput {
            v_dq: Dq::default(),
            saturated: true,
            valid: false,
        };
    }
    // Squares compared: the square root only when the vector must be cut.
    if mag2 <= v_max2 {
        return CurrentLoopOutput {
            v_dq,
            saturated: false,
            valid: true,
        };
    }
    // Cut a little inside the circle (1 − 2⁻¹⁸, 0.08 mV at 21 V): |v|² after the rotation to
    // αβ carries a few 1e-7 of rounding, and a vector found just outside the circle would make
    // SVPWM cut it a second time (a division and a square root more). Two Newton steps of
    // 1/|v| land at most 5e-6 below it and above it only by rounding (`math::rsqrt_normal`),
    // so the cut vector is 1e-5 inside at the most.
    let scale = (v_max * CUT_INSIDE) * crate::math::rsqrt_normal(mag2, 2);
    CurrentLoopOutput {
        v_dq: Dq::new(v_d * scale, v_q * scale),
        saturated: true,
        valid: true,
    }
}
