//! The inverter's dead time as the identification's measurements see it: the voltage the
//! inverter applied over a period ([`dead_time_applied`], for the back-EMF of the spin and the
//! torque steps) and a compensation that does not follow each sample
//! ([`hold_signs`], for the DC tests of resistance and inductance). The averaged dead-time
//! model and its compensation are [`crate::dead_time`]'s (Choi & Sul 1995; Muñoz & Lipo 1999);
//! the two-point DC test's insensitivity to a constant inverter error is the argument of
//! H.-W. Kim, M.-J. Youn, K.-Y. Cho, H.-S. Kim, "Nonlinearity estimation and compensation of
//! PWM VSI for PMSM under resistance and flux linkage uncertainty", IEEE Trans. Control Syst.
//! Technol. 14(4), 2006.

use crate::dead_time::DeadTime;
use crate::foc::{Reference, Request};
use crate::frames::{AlphaBeta, Dq};

/// The voltage the inverter applied over the period that just ended \[V]: the command `v_ab`
/// whose dead time was compensated by the signs of the sample `i_prev` at the period's start
/// ([`crate::dead_time`]), less the error the inverter made with the signs of the current
/// that flowed, taken at the period's middle `(i_prev + i_ab)/2`: `v_ab + E(i_prev) − E(i_mid)`
/// on the bus `v_bus` of the period.
///
/// Why (issue #26: ψ_f +0.2 to +2.8 % on every motor with dead time, 0.05 % without): while
/// the frame turns, the compensation's signs lag the phase currents by half a period, so each
/// zero crossing leaves a pulse of `±2 t_d f_pwm V_bus` of width `ω_e T/2` whose fundamental,
/// `(4/π) t_d f_pwm V_bus · ω_e T/2`, lies 90° ahead of the current: along the back-EMF of
/// the spin (current on d, EMF on q), in the same direction whichever the motor. As the EMF it
/// grows with `ω_e`, so the two speeds of `flux.rs` cannot tell it from `ψ_f`: a bias of
/// `(4/π) t_d f_pwm V_bus (T/2)/ψ_f`, positive, largest on low-ψ_f motors on high buses
/// (maxon 645106 on 24 V: +1.5 %). The correction's cost is two dead-time errors per step
/// (≈ 60 cycles), in the identification's steps only. Zero (exactly) without dead time.
#[inline(always)]
pub(in crate::drive) fn dead_time_applied(
    v_ab: AlphaBeta,
    i_ab: AlphaBeta,
    i_prev: AlphaBeta,
    dt: &DeadTime,
    v_bus: f32,
) -> AlphaBeta {
    let mid = AlphaBeta::new(
        0.5 * (i_ab.alpha + i_prev.alpha),
        0.5 * (i_ab.beta + i_prev.beta),
    );
    let e_comp = dt.error(i_prev, v_bus);
    let e_true = dt.error(mid, v_bus);
    AlphaBeta::new(
        v_ab.alpha + (e_comp.alpha - e_true.alpha),
        v_ab.beta + (e_comp.beta - e_true.beta),
    )
}

/// A voltage `request` whose dead time is to be compensated with the signs of the phase
/// voltages of `v_dir` (the DC voltage of the resistance and inductance tests, whose phase
/// currents have these signs) rather than those of the measured `i_ab`: the FOC adds
/// `E(i_ab)` ([`crate::dead_time`]), so the reference gets `E(v_dir) − E(i_ab)` (resistance.rs
/// says why: the measured signs are a negative resistance within the band). Each phase's sign
/// of `v_dir` is that of its component scaled far beyond the band (`10⁹` A/V); a phase with no
/// voltage gets none. Unchanged (exactly) without dead time, and where every measured current
/// is beyond the band with the voltages' signs.
#[inline(always)]
pub(in crate::drive) fn hold_signs(
    request: Request,
    dt: &DeadTime,
    v_dir: AlphaBeta,
    i_ab: AlphaBeta,
    v_bus: f32,
) -> Request {
    let Reference::Voltage(v) = request.reference else {
        return request;
    };
    let e_fix = dt.error(AlphaBeta::new(1e9 * v_dir.alpha, 1e9 * v_dir.beta), v_bus);
    let e_meas = dt.error(i_ab, v_bus);
    Request {
        reference: Reference::Voltage(Dq::new(
            v.d + (e_fix.alpha - e_meas.alpha),
            v.q + (e_fix.beta - e_meas.beta),
        )),
        ..request
    }
}
