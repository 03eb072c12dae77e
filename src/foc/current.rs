//! The d/q current loop: PIs with decoupling and back-EMF feed-forward (Ortega Sec V iv,
//! dq model (3), with `L_d`, `L_q` for a salient motor), and the voltage vector's limit to the
//! circle the inverter applies.
//!
//! The limit on a salient motor with `L_q > L_d` while motoring gives the d axis the first
//! claim on the circle: the d voltage kept up to [`D_SHARE_MAX`] of it (held there beyond),
//! the q axis what remains: N. P. Quang, J.-A. Dittrich, "Vector Control of Three-Phase AC
//! Machines", Springer 2015 (its space-vector limitation: the d axis first where `i_q` and
//! `ω_e` have the same sign); ST's motor control SDK's circle limitation holds the d voltage at
//! its `MaxVd` (95 % of the circle) and gives the q axis the rest the same way.
//! There the d current is the MTPA's and the field weakening's, large and negative, and no
//! torque ceiling keeps the speed loop off the circle (`drive/sensorless.rs`: `VoltageEnd` is
//! a non-salient motor's). A vector cut along itself takes its share from the d voltage too:
//! with `v_d = R i_d + L_d di_d/dt − ω_e L_q i_q` held short of `−ω_e L_q i_q` the d current
//! rises, the back-EMF `ω_e (ψ_f + L_d i_d)` with it, and the vector stays cut. On the Zou
//! 350 kW PMa-SynRM at its derated speed under its rated torque (issue #29's
//! `sup-load-steps-100`) the d current ran from −150 A to +90 A within 20 ms and the speed
//! from 1,490 to 880 rpm and back, every 0.3 s (4–8 % slow); with the d axis first it holds
//! within 2 % (`host-sim/matrices/zoo-salient.toml`: 158 → 160 of 160 with the identified
//! files, 156 → 160 with the true ones). A braking command and every other motor: the vector
//! cut along itself. While braking the d axis first let the Zou's d current run to 440 A when
//! its load let go (the q voltage starved, the rotor overran); on the non-salient motors,
//! whose field weakening ends where the voltage is least and whose torque ceiling holds the
//! voltage (`VoltageEnd`), it lost 4 to 10 cells of the zoo (issue #26: the drone's load
//! removals after a 100 % step, the Nanotec DF45's load removals and starts under a brake).

use crate::frames::Dq;
use crate::math::{all_finite, clamp};
use core::hint::cold_path;

/// The current loop cuts its voltage to at most this fraction of `v_max`, 1 − 2⁻¹⁸.
const CUT_INSIDE: f32 = 1.0 - 1.0 / 262_144.0;

/// The d voltage's largest share of the circle where the d axis comes first (module doc): the
/// q axis keeps at least `√(1 − 0.95²)` = 31 % of it.
pub const D_SHARE_MAX: f32 = 0.95;

/// `√(1 − D_SHARE_MAX²)` to f32's precision (its rounding inside the cut's 4e-6 margin): the
/// q voltage's share where the d voltage holds its largest.
const Q_SHARE_MIN: f32 = 0.312_249_9;

/// The radius a vector is cut to: a little inside the circle of radius `v_max` \[V] (below).
#[inline(always)]
fn radius_of(v_max: f32) -> f32 {
    v_max * CUT_INSIDE
}

/// [`CurrentLoop`]'s `d_share2` for inductances `l_d_h`, `l_q_h` \[H]: `D_SHARE_MAX²` where
/// `L_q > L_d`, −1 (the vector cut along itself) on any other motor.
pub(super) fn d_share2(l_d_h: f32, l_q_h: f32) -> f32 {
    if l_q_h > l_d_h {
        D_SHARE_MAX * D_SHARE_MAX
    } else {
        -1.0
    }
}

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
    /// The square of the d voltage's share of the circle that comes first while motoring:
    /// [`d_share2`] (module doc).
    pub(super) d_share2: f32,
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
    /// Voltage command in the rotor frame \[V], `|v_dq| ≤ v_max` (a vector cut along itself
    /// is between 1 − 1e-5 and 1 − 2⁻¹⁸ of `v_max` long, to f32 rounding; one cut with the d
    /// axis first between 1 − 1.8e-3 and 1 − 2⁻¹⁸).
    pub v_dq: Dq,
    /// The command was cut to (just inside) `v_max`; the integrators were held (but the q
    /// one under a braking command, [`CurrentLoop::update`]), the d one also where the d
    /// axis came first and kept its voltage.
    pub saturated: bool,
    /// The inputs were usable (finite, `v_max` in range), so `v_dq` is the loop's command;
    /// false: zero volts.
    pub valid: bool,
}

impl CurrentLoop {
    /// One update at the current-loop rate.
    /// `i_dq`, `i_dq_ref` \[A]; `omega_e` electrical speed \[rad/s]; `v_max` the largest
    /// voltage magnitude the inverter can apply \[V], positive, 1.1e-19..1.8e19 (its square a
    /// normal f32). The cut: on a salient motor (`L_q > L_d`) while motoring the d voltage
    /// first, else along the vector (module doc). Anti-windup: when the vector is cut to
    /// `v_max`, neither integrator moves, but the q one under a braking command where its
    /// step shortens `v_q` (the d one held where the d axis came first too: as on any cut,
    /// a release there not measured).
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
        self.update_with(state, i_dq, i_dq_ref, omega_e, v_max, true)
    }

    /// [`CurrentLoop::update`] with the vector always cut along itself, whatever the motor:
    /// for a loop that runs below the speed where the d axis' claim on the voltage matters
    /// (the injection's start, `drive/inject.rs`).
    #[inline(always)]
    pub fn update_cut_along(
        &self,
        state: &mut CurrentLoopState,
        i_dq: Dq,
        i_dq_ref: Dq,
        omega_e: f32,
        v_max: f32,
    ) -> CurrentLoopOutput {
        self.update_with(state, i_dq, i_dq_ref, omega_e, v_max, false)
    }

    /// [`CurrentLoop::update`]; `d_first` false: the vector always cut along itself (the
    /// identification's loop, `Foc::run_cut_along`).
    #[inline(always)]
    pub(super) fn update_with(
        &self,
        state: &mut CurrentLoopState,
        i_dq: Dq,
        i_dq_ref: Dq,
        omega_e: f32,
        v_max: f32,
        d_first: bool,
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
        // The d axis first on a salient motor while motoring, `i_q* ω_e ≥ 0` (module doc),
        // asked only where the vector is cut; `i_q* ω_e` once, for the q integrator's release
        // below too.
        let iq_ref_omega_e = i_dq_ref.q * omega_e;
        let share2_now = || {
            if iq_ref_omega_e >= 0.0 {
                self.d_share2
            } else {
                -1.0
            }
        };
        let out = limit_d_first(Dq::new(v_d, v_q), v_max, d_first, share2_now);
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
        let release = iq_ref_omega_e < 0.0 && e_q * out.v_dq.q < 0.0;
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
    limit_d_first(v_dq, v_max, false, || -1.0)
}

/// [`limit`], with the d axis first where `d_first` (a constant where it is inlined: false
/// compiles the branch out), the vector is cut and `share2_now()` is positive, the square of
/// the d voltage's share (module doc): a `v_d` within that share of the circle's radius `r`
/// kept, and `v_q` of its sign and the length the circle leaves, `√(r² − v_d²)`, at least
/// `√(1 − 0.95²) r` (a normal square for a `v_max` above 4e-19 V); one Newton step of 1/√
/// from `rsqrt_normal`'s guess lands below that root by at most 0.18 %, inside the circle
/// (the vector was outside it, so `|v_q|` was longer). A `v_d` beyond its share is held at it
/// and `v_q` within `√(1 − 0.95²) r`: the cut is continuous in `v_d` (to the Newton step's
/// 0.18 % of `v_q` at the share's edge).
#[inline(always)]
fn limit_d_first(
    v_dq: Dq,
    v_max: f32,
    d_first: bool,
    share2_now: impl FnOnce() -> f32,
) -> CurrentLoopOutput {
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
    let (r2, v_d2) = (v_max2 * (CUT_INSIDE * CUT_INSIDE), v_d * v_d);
    let share2 = if d_first { share2_now() } else { -1.0 };
    // (`d_first` first: a constant false folds both branches away.)
    let v_dq = if d_first && v_d2 <= share2 * r2 {
        let room2 = r2 - v_d2;
        let room = room2 * crate::math::rsqrt_normal(room2, 1);
        Dq::new(v_d, room.copysign(v_q))
    } else if d_first && share2 > 0.0 {
        cold_path();
        d_held_at_share(v_d, v_q, v_max)
    } else {
        // Cut a little inside the circle (1 − 2⁻¹⁸, 0.08 mV at 21 V): |v|² after the rotation
        // to αβ carries a few 1e-7 of rounding, and a vector found just outside the circle
        // would make SVPWM cut it a second time (a division and a square root more). Two
        // Newton steps of 1/|v| land at most 5e-6 below it and above it only by rounding
        // (`math::rsqrt_normal`), so the cut vector is 1e-5 inside at the most.
        let scale = radius_of(v_max) * crate::math::rsqrt_normal(mag2, 2);
        Dq::new(v_d * scale, v_q * scale)
    };
    CurrentLoopOutput {
        v_dq,
        saturated: true,
        valid: true,
    }
}

/// A d voltage `v_d` \[V] beyond its share of the circle of radius `v_max` \[V] held at
/// [`D_SHARE_MAX`] of it, `v_q` \[V] within the rest, `√(1 − 0.95²)` of it (module doc): the
/// d axis first where the d voltage alone would take the circle.
#[inline(always)]
fn d_held_at_share(v_d: f32, v_q: f32, v_max: f32) -> Dq {
    let (d_max, q_max) = (
        D_SHARE_MAX * radius_of(v_max),
        Q_SHARE_MIN * radius_of(v_max),
    );
    Dq::new(d_max.copysign(v_d), clamp(v_q, -q_max, q_max))
}
