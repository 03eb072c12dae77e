//! Dead-time compensation: average-voltage compensation per phase by the sign of its current.
//!
//! Dead time `t_d` (both switches of a half bridge off after each edge, so that they never
//! conduct together) hands each switching edge to the freewheeling diode that the current
//! turns on: over a PWM period of `1/f_pwm` a phase whose current flows into the motor
//! (`i_k > 0`) loses `t_d·f_pwm` of its duty, one flowing out gains it. The averaged pole
//! voltage is
//!
//! ```text
//! v_k = (d_k − sign(i_k)·t_d·f_pwm)·V_bus
//! ```
//!
//! the averaged model of J.-W. Choi and S.-K. Sul, "A new compensation strategy reducing
//! voltage/current distortion in PWM VSI systems operating with low output voltages", IEEE
//! Trans. Ind. Appl. 31(5), 1995, and of A. R. Muñoz and T. A. Lipo, "On-line dead-time
//! compensation technique for open-loop PWM-VSI drives", IEEE Trans. Power Electron. 14(4),
//! 1999 (both also model the switches' on-state drops, which this block leaves to the current
//! loop); it is the plant's inverter model too (`host-sim/src/inverter.rs`). On the B-G431B-ESC1 (20 kHz, 500 ns) `t_d·f_pwm` is 1 % of
//! the period: 0.48 V on a 48 V bus, about the voltage the Sinano motor's resistance drops at
//! 0.2 A, and the error flips with each current zero crossing, six times per electrical turn.
//!
//! The compensation is the average-voltage one of both papers: add `s_k·t_d·f_pwm` to each
//! duty, `s_k` the sign of the phase current, so that the inverter applies the command on
//! average; and give the observers the voltage the inverter applies. Two choices:
//!
//! - **Smooth sign.** `s_k = clamp(i_k/band, −1, 1)` instead of `sign(i_k)`: a measured
//!   current dithering around zero by its noise moves the compensation by a fraction of it,
//!   not by `±t_d·f_pwm` from one sample to the next (the boundary layer `sat` that replaces
//!   `sgn` in the sliding observer, for the same reason). Within the band the observers'
//!   voltage differs from the inverter's by up to `(1 − |s_k|)·t_d·f_pwm·V_bus` per phase.
//! - **In the stationary frame.** The three duty offsets `s_k·t_d·f_pwm` are added as the
//!   voltage they make, `E = t_d·f_pwm·V_bus·Clarke(s)`, to the αβ command before SVPWM:
//!   [`crate::foc::Foc`] modulates `v_cmd + E`. The star point ignores the common mode, so the
//!   phase voltages are those of adding `s_k·t_d·f_pwm` to each duty; SVPWM's min–max
//!   injection re-centres the three duties (a duty pushed past a rail while another has room
//!   is shifted back, not clipped), and a vector beyond the hexagon is cut by SVPWM's own limit.
//!   The voltage the inverter applies, the Clarke transform of `(d_k − s_k·t_d·f_pwm)·V_bus`,
//!   is then SVPWM's applied vector less `E`: exactly the command in the linear range. No
//!   clamp or Clarke transform of the duties, and a zero dead time gives `E = 0` exactly,
//!   today's duties and voltages bit for bit.
//!
//! Cost: the smooth sign is one multiply and a saturating float → integer → float conversion
//! per phase (`VCVT` saturates in hardware; see [`DeadTime::error`]); the block is 27 FPU
//! instructions, 30 cycles, and the drive's step grows by 30 to 36 cycles on the emulated
//! Cortex-M4F (`pmsm-sim cycles`, register pressure included).

use crate::frames::{Abc, AlphaBeta};
use crate::math::INV_SQRT3;
use crate::param::{Allowed, Checks, ParamError};

/// 2³¹: the smooth sign is a saturating conversion to `i32` of the current at this scale
/// per `band` (see [`DeadTime::error`]).
const SAT_SCALE: f32 = 2_147_483_648.0;

/// √3/2.
const SQRT3_OVER_2: f32 = 0.866_025_4;

/// Dead-time compensation settings in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeadTimeConfig {
    /// Dead time per switching edge \[s], in `[0, 0.1/pwm_hz]` (at most a tenth of the PWM
    /// period). 0: an ideal inverter, no compensation.
    pub dead_time_s: f32,
    /// PWM (switching) frequency \[Hz], positive and finite.
    pub pwm_hz: f32,
    /// Width of the smooth sign \[A], > 0: a phase current of `band_a` or more gets the full
    /// compensation, a smaller one the fraction `i/band_a`.
    pub band_a: f32,
    /// The largest duty the power stage applies, in `(0.5 + t_d·f_pwm, 1]`: a board that
    /// samples its phase currents in the low-side interval keeps that interval long enough
    /// for the sample (`1 − d_max` of the period), so its duties stay in
    /// `[1 − d_max, d_max]`. The voltage limit [`DeadTimeConfig::v_max_per_bus`] keeps every
    /// duty the FOC computes there, so the board never clips one (the observers see the
    /// voltage applied). 1: the whole bus.
    pub duty_max: f32,
}

impl DeadTimeConfig {
    /// An ideal inverter: no dead time, no compensation (20 kHz, a 1 A band, neither of which
    /// matters then).
    pub const NONE: Self = Self {
        dead_time_s: 0.0,
        pwm_hz: 20_000.0,
        band_a: 1.0,
        duty_max: 1.0,
    };

    /// The dead time as a duty fraction, `t_d·f_pwm` (unvalidated).
    pub fn duty(&self) -> f32 {
        self.dead_time_s * self.pwm_hz
    }

    /// The largest voltage per volt of bus \[V/V] the compensated inverter applies in every
    /// direction, `(2·d_max − 1 − 2·t_d·f_pwm)/√3` (unvalidated): a command inside this circle
    /// plus the compensation `E` stays inside the inverter's hexagon shrunk to the duties
    /// `[1 − d_max, d_max]` (`max − min` of the phase voltages at most `(2·d_max − 1)·V_bus`;
    /// with `d_max = 1` SVPWM's linear range). `Clarke(s)` of signs in `[−1, 1]` lies in the
    /// hexagon of the six-step vectors, `4/3` long and pointing at the voltage hexagon's
    /// corners, so `E`'s component along any edge's normal is at most `(4/3)·cos 30°·t_d·f_pwm·
    /// V_bus = (2/√3)·t_d·f_pwm·V_bus`: the edges, `V_bus/√3` from the centre, move in by that
    /// much, and the circle they enclose is `(2·d_max − 1 − 2·t_d·f_pwm)·V_bus/√3`. Exactly
    /// `1/√3` without dead time and with `d_max = 1`.
    pub fn v_max_per_bus(&self) -> f32 {
        INV_SQRT3 * ((2.0 * self.duty_max - 1.0) - 2.0 * self.duty())
    }

    /// Validates the settings (the error names `dead_time_s`, `pwm_hz`, `band_a` or
    /// `duty_max`) and folds them into per-sample coefficients.
    pub fn build(&self) -> Result<DeadTime, ParamError> {
        let mut c = Checks::new();
        self.check(&mut c, ["pwm_hz", "dead_time_s", "band_a", "duty_max"]);
        c.done()?;
        Ok(DeadTime::new(self))
    }

    /// Adds the checks of these settings to `c` under the names `fields` (`pwm_hz`,
    /// `dead_time_s`, `band_a`, `duty_max` as the caller calls them): `pwm_hz` positive,
    /// `dead_time_s` in `[0, 0.1/pwm_hz]`, `band_a` positive, `duty_max` in
    /// `(0.5 + t_d·f_pwm, 1]` (a voltage limit above zero).
    pub fn check(&self, c: &mut Checks, fields: [&'static str; 4]) {
        let [pwm, dead, band, duty_max] = fields;
        c.check(pwm, self.pwm_hz, Allowed::POSITIVE);
        let tenth = Allowed::between(0.0, 0.1 / self.pwm_hz).because("a tenth of 1/pwm_hz");
        c.check(dead, self.dead_time_s, tenth);
        c.check(band, self.band_a, Allowed::POSITIVE);
        let duty = Allowed::above_up_to(0.5 + self.duty(), 1.0).because("0.5 + t_d f_pwm..1");
        c.check(duty_max, self.duty_max, duty);
    }
}

/// The compensation's per-sample coefficients, built by [`DeadTimeConfig::build`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DeadTime {
    /// `2³¹/band` \[1/A]: a current at the smooth sign's integer scale.
    gain: f32,
    /// `t_d·f_pwm·2⁻³¹/3`: from the integer-scaled signs to the error per volt of bus.
    per_bus: f32,
}

impl Default for DeadTime {
    /// No compensation.
    fn default() -> Self {
        Self::new(&DeadTimeConfig::NONE)
    }
}

impl DeadTime {
    /// The coefficients of `cfg`, validated by the caller ([`DeadTimeConfig::check`]).
    pub(crate) fn new(cfg: &DeadTimeConfig) -> Self {
        Self {
            gain: SAT_SCALE / cfg.band_a,
            per_bus: cfg.duty() / SAT_SCALE * (1.0 / 3.0),
        }
    }

    /// The smooth signs of the phase currents whose Clarke transform is `i_ab` \[A], each
    /// `s_k = clamp(i_k/band, −1, 1)` to f32 rounding (see [`DeadTime::error`]); 0 for a NaN.
    pub fn smooth_signs(&self, i_ab: AlphaBeta) -> Abc {
        let q = self.scaled_signs(i_ab);
        let s = |x: f32| x * (1.0 / SAT_SCALE);
        Abc::new(s(q.0), s(q.1), s(q.2))
    }

    /// The signs of [`DeadTime::smooth_signs`] at the scale 2³¹.
    #[inline(always)]
    fn scaled_signs(&self, i_ab: AlphaBeta) -> (f32, f32, f32) {
        // Inverse Clarke at the sign's scale: x_a = α, x_b,c = −α/2 ± (√3/2) β (the −1/2 and
        // √3/2 are SVPWM's too: one register each).
        let x_a = self.gain * i_ab.alpha;
        let y = (self.gain * i_ab.beta) * SQRT3_OVER_2;
        let h = -0.5 * x_a;
        (sat(x_a), sat(h + y), sat(h - y))
    }

    /// The average voltage the dead time takes from the command \[V]: `E = t_d·f_pwm·V_bus·
    /// Clarke(s)`, the Clarke transform of the pole-voltage errors `s_k·t_d·f_pwm·V_bus`
    /// (module doc) with the smooth signs `s_k` of the phase currents whose Clarke
    /// transform is `i_ab` \[A]. `v_bus` \[V]. The inverter applies `v − E` for duties of `v`:
    /// modulating `v_cmd + E` applies `v_cmd`. Zero (exactly) without dead time; finite for a
    /// NaN current (its sign is 0) and any finite bus.
    ///
    /// The clamp of each sign is a saturating conversion: `i_k·2³¹/band` converted to `i32`
    /// saturates at ±2³¹ (`as` saturates, and `VCVT` does in hardware: no compare, no
    /// branch) and back to f32 is `2³¹·clamp(i_k/band, −1, 1)` with a relative error of 2⁻²⁴
    /// (and the truncation toward zero of a current below `band·2⁻³¹`); at `|i_k| ≥ band` (by
    /// a rounding) it is ±2³¹ exactly.
    #[inline(always)]
    pub fn error(&self, i_ab: AlphaBeta, v_bus: f32) -> AlphaBeta {
        let (q_a, q_b, q_c) = self.scaled_signs(i_ab);
        // Clarke: α = (2a − b − c)/3, β = (b − c)/√3 = 2(b − c)(√3/2)/3; the 1/3, t_d·f_pwm
        // and 2⁻³¹ folded into one coefficient.
        let u = v_bus * self.per_bus;
        let alpha = (q_a + q_a) - (q_b + q_c);
        let beta = q_b - q_c;
        AlphaBeta::new(alpha * u, ((beta + beta) * u) * SQRT3_OVER_2)
    }
}

/// `x` clamped to `[−2³¹, 2³¹]` (NaN: 0) as a saturating conversion to `i32` and back: two
/// `VCVT` on the Cortex-M4F.
#[inline(always)]
fn sat(x: f32) -> f32 {
    // Deliberate: `as` saturates (and maps NaN to 0); that is the clamp.
    (x as i32) as f32
}
