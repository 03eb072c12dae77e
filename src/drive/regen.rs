//! Regeneration limited from the measured bus voltage, and the brake-resistor output.
//!
//! A drive on a supply that cannot take current back (a diode rectifier, a battery at its
//! charge limit) charges its DC-link capacitor with every joule it brakes out of the rotor
//! beyond its losses. The drive watches the bus it samples every step and, as the bus rises
//! into a band below the over-voltage trip, (1) takes less regenerative power and (2)
//! dissipates more in the winding's copper with a negative d current (it makes no torque on
//! a surface-magnet motor and lowers the voltage), the loss-increasing braking of Jiang &
//! Holtz, "An efficient braking method for controlled AC drives with a diode rectifier front
//! end", IEEE Trans. Ind. Appl. 37(5), 2001 (there by the flux of an induction motor, here by
//! the d current of a PMSM). The band, from the rated bus `V_n` to the trip `V_max`:
//!
//! ```text
//! V_start = V_n + 0.6 (V_max − V_n)      the limit begins        (Sinano: 55.2 V of a 60 V trip)
//! V_full  = V_n + 0.9 (V_max − V_n)      no regenerative power   (Sinano: 58.8 V)
//! k       = clamp((V_full − v_bus)/(V_full − V_start), 0, 1)
//! i_d     ≤ −(1 − k) i_max                                   copper loss R i_d² (the papers' model)
//! |i_q|   ≤ min(√(i_max² − i_d²), (k P_n + R i_d²)/(N ψ_f |ω̂_m|))   while braking (i_q ω̂_m < 0)
//! ```
//!
//! `P_n` the rated power: at `V_start` the drive brakes at up to its rated power into the
//! bus, at `V_full` at none beyond what the copper takes (the mechanical power `N ψ_f ω i_q`
//! less the copper's `R |i|²` is the power into the bus, so the bound on |i_q| ignoring
//! `R i_q²` is conservative). Between the two, k falls linearly: a proportional bus-voltage
//! regulator, its equilibrium where the copper and the allowed power take what the braking
//! returns. Above `V_full` k = 0: the whole current limit on the d axis, no braking torque, and
//! the copper draws from the bus until it falls back into the band. The bound on braking
//! |i_q| is also the speed loop's limit at its next run (the integrator does not wind up
//! against it). Above `V_full` the margin to the trip, a tenth of the band, takes the current
//! loop's response (a quarter of a millisecond at 300 Hz).
//!
//! Below `V_start` nothing changes (one subtraction and one compare per step).
//!
//! **Brake resistor.** Where the power stage has a brake chopper, its gate
//! ([`DriveOutput::brake`](super::DriveOutput::brake)) is on above `V_n + 0.3 (V_max − V_n)`
//! and off below `V_n + 0.2 (V_max − V_n)` (Sinano: 51.6 V, 50.4 V), in every mode (a rotor
//! driven by its load with the PWM off charges the bus through the diodes too): below the
//! band, so a stage with a resistor brakes at full torque and the limit above never acts.

use crate::frames::Dq;
use crate::math::{max, min, sqrt_or_zero};

/// Where the limit begins, as a fraction of the way from the rated bus to the trip: with the
/// default trip at 1.25 of the rated bus, at 1.15 of it, where a stage's own brake chopper
/// commonly switches on (the simulator's default chopper's threshold): such a chopper takes
/// the energy before the drive reduces its braking.
pub(super) const START: f32 = 0.6;
/// Where no regenerative power is left.
pub(super) const FULL: f32 = 0.9;
/// The brake chopper's gate on ...
pub(super) const BRAKE_ON: f32 = 0.3;
/// ... and off.
pub(super) const BRAKE_OFF: f32 = 0.2;

/// The limit's coefficients (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Settings {
    /// `V_full` \[V].
    pub(super) v_full: f32,
    /// `1/(V_full − V_start)` \[1/V].
    pub(super) inv_band: f32,
    /// The rated power `P_n` \[W].
    pub(super) p_rated_w: f32,
    /// The copper loss per A² of the dq current, `c R` \[Ω] (`c` of the motor's torque
    /// convention: the power of three phases through the amplitude-invariant transform).
    pub(super) r_ohm: f32,
    /// The torque constant `c N ψ_f` \[N·m/A]: the mechanical power per amp per rad/s.
    pub(super) kt: f32,
    /// The current limit \[A].
    pub(super) i_max_a: f32,
    /// The brake chopper's gate on above ... \[V]
    pub(super) brake_on_v: f32,
    /// ... off below \[V].
    pub(super) brake_off_v: f32,
}

impl Settings {
    /// From the rated bus `v_rated`, the trip `v_max`, the rated power, the copper loss per
    /// A² `c R`, the torque constant `c N ψ_f`, and the current limit.
    pub(super) fn new(
        v_rated: f32,
        v_max: f32,
        p_rated_w: f32,
        r_ohm: f32,
        kt: f32,
        i_max_a: f32,
    ) -> Self {
        let at = |f: f32| v_rated + f * (v_max - v_rated);
        Self {
            v_full: at(FULL),
            inv_band: 1.0 / (at(FULL) - at(START)),
            p_rated_w,
            r_ohm,
            kt,
            i_max_a,
            brake_on_v: at(BRAKE_ON),
            brake_off_v: at(BRAKE_OFF),
        }
    }

    /// `k` at the bus `v_bus` \[V], unclamped: 1 or more below the band (no limit).
    #[inline(always)]
    pub(super) fn share(&self, v_bus: f32) -> f32 {
        (self.v_full - v_bus) * self.inv_band
    }

    /// The current command `i_dq` \[A] limited at the share `k` (< 1) for the rotor at
    /// `omega_m` \[rad/s]; and the bound on the braking |i_q| \[A] (∞ when not braking).
    #[inline(never)]
    pub(super) fn limit(&self, k: f32, i_dq: Dq, omega_m: f32) -> (Dq, f32) {
        let k = max(k, 0.0);
        let i_max = self.i_max_a;
        let i_d = min(i_dq.d, -(1.0 - k) * i_max);
        let circle = sqrt_or_zero(i_max * i_max - i_d * i_d);
        let braking = i_dq.q * omega_m < 0.0;
        let bound = if braking {
            let p_w = k * self.p_rated_w + self.r_ohm * i_d * i_d;
            let per_a = self.kt * omega_m.abs();
            if per_a * circle > p_w {
                p_w / per_a
            } else {
                circle
            }
        } else {
            f32::INFINITY
        };
        let lim = min(circle, bound);
        let i_q = if i_dq.q > lim {
            lim
        } else if i_dq.q < -lim {
            -lim
        } else {
            i_dq.q
        };
        (Dq::new(i_d, i_q), bound)
    }

    /// The brake chopper's gate after this step's bus `v_bus` \[V], `on` before.
    #[inline(always)]
    pub(super) fn brake(&self, on: bool, v_bus: f32) -> bool {
        if on {
            v_bus > self.brake_off_v
        } else {
            v_bus > self.brake_on_v
        }
    }
}
