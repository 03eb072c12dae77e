//! Field-oriented control: d/q current loops with decoupling and back-EMF feed-forward, and the
//! speed loop that commands `i_q`, run at a decimated rate inside the current-loop step.
//!
//! Gains come from the motor parameters and requested bandwidths (defaults of Horng & Chin
//! Sec 5: current loop 300 Hz at 4 kHz, speed loop 20 Hz at 1 kHz):
//! - current PI, pole-zero cancellation of `1/(R + sL)`: `kp = L ω_c`, `ki = R ω_c`, so the
//!   closed loop is `ω_c/(s + ω_c)`;
//! - speed PI on `N ψ_f/(J s + B)`: `kp = J ω_s/(N ψ_f)`, `ki = kp ω_s/4` (integral zero a
//!   quarter of the crossover, ≈ 76° phase margin before sample and current-loop delays).
//!
//! Decoupling and back-EMF feed-forward, Ortega Sec V iv (dq model (3)):
//! `v_d = PI_d − ω_e L i_q`, `v_q = PI_q + ω_e L i_d + ω_e ψ_f`.
//!
//! The inverter's dead time is compensated between the loop and SVPWM ([`crate::dead_time`]):
//! the voltage it takes is added to the command, and the voltage reported for the observers
//! is what the inverter applies. The loop's voltage limit is the circle the compensated
//! inverter applies in every direction, `(1 − 2·t_d·f_pwm)·V_bus/√3` (`V_bus/√3` without
//! dead time, [`DeadTimeConfig::v_max_per_bus`]): a command on it plus the compensation stays
//! inside SVPWM's linear range, so the vector is applied as the loop computed it and its
//! anti-windup knows when it is cut.

use crate::dead_time::{DeadTime, DeadTimeConfig};
use crate::frames::{Abc, AlphaBeta, Dq, SinCos};
use crate::math::all_finite;
use crate::motor::MotorParams;
use crate::param::{Allowed, Checks, ParamError};
use crate::pi::{Held, Pi, PiConfig, PiState};
use crate::svpwm::{svpwm_limited, Duties, Svpwm};
use core::f32::consts::TAU;
use core::hint::cold_path;

/// The current loop cuts its voltage to at most this fraction of `v_max`, 1 − 2⁻¹⁸.
const CUT_INSIDE: f32 = 1.0 - 1.0 / 262_144.0;

/// FOC settings in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FocConfig {
    /// Motor model the gains are computed from (the controller's belief, may differ from the plant).
    pub motor: MotorParams,
    /// Current-loop rate \[Hz]; the step runs at this rate. Default 4000.
    pub current_rate_hz: f32,
    /// Current-loop bandwidth \[Hz], at most `current_rate_hz / (2π)`. Default 300.
    pub current_bandwidth_hz: f32,
    /// The speed loop runs every `speed_divider` steps (default 4: 1 kHz at 4 kHz), ≥ 1.
    pub speed_divider: u32,
    /// Speed-loop bandwidth \[Hz], at most a fifth of the current-loop bandwidth. Default 20.
    pub speed_bandwidth_hz: f32,
    /// Limit of the `i_q` command \[A], > 0.
    pub i_max_a: f32,
    /// The voltage is held for one period while the rotor turns; the inverse Park uses
    /// `θ_e + advance·ω_e·Ts`. Default 0.5 (the middle of the period in which it is applied).
    pub angle_advance_periods: f32,
    /// The inverter's dead time, compensated. Default [`DeadTimeConfig::NONE`] (an ideal
    /// inverter).
    pub dead_time: DeadTimeConfig,
}

impl FocConfig {
    /// Defaults of Horng & Chin Sec 5 for `motor` with current limit `i_max_a`.
    pub fn new(motor: MotorParams, i_max_a: f32) -> Self {
        Self {
            motor,
            current_rate_hz: 4000.0,
            current_bandwidth_hz: 300.0,
            speed_divider: 4,
            speed_bandwidth_hz: 20.0,
            i_max_a,
            angle_advance_periods: 0.5,
            dead_time: DeadTimeConfig::NONE,
        }
    }

    /// The PI gains (module doc): current `kp = L ω_c` \[V/A], `ki = R ω_c` \[V/(A·s)]; speed
    /// `kp = J ω_s/(N ψ_f)` \[A·s/rad], `ki = kp ω_s/4` \[A/rad]. Unvalidated: [`FocConfig::build`]
    /// checks the settings first.
    pub fn gains(&self) -> FocGains {
        let m = &self.motor;
        let w_c = TAU * self.current_bandwidth_hz;
        let w_s = TAU * self.speed_bandwidth_hz;
        let speed_kp = m.j_kgm2 * w_s / m.torque_constant();
        FocGains {
            current_kp: m.l_h * w_c,
            current_ki: m.r_ohm * w_c,
            speed_kp,
            speed_ki: speed_kp * w_s / 4.0,
        }
    }

    /// Validates and turns the settings into per-sample coefficients.
    pub fn build(&self) -> Result<Foc, ParamError> {
        let motor = self.motor.validate()?;
        let (rate, i_max) = (self.current_rate_hz, self.i_max_a);
        let mut c = Checks::new();
        c.check("current_rate_hz", rate, Allowed::POSITIVE);
        let current = Allowed::above_up_to(0.0, rate / TAU).because("w_c T <= 1");
        c.check("current_bandwidth_hz", self.current_bandwidth_hz, current);
        let divider = Allowed::between(1.0, 1000.0);
        c.check("speed_divider", self.speed_divider as f32, divider);
        let speed = Allowed::above_up_to(0.0, self.current_bandwidth_hz / 5.0).because("current/5");
        c.check("speed_bandwidth_hz", self.speed_bandwidth_hz, speed);
        c.check("i_max_a", i_max, Allowed::POSITIVE);
        c.check(
            "angle_advance_periods",
            self.angle_advance_periods,
            Allowed::FINITE,
        );
        let dead = [
            "dead_time.pwm_hz",
            "dead_time.dead_time_s",
            "dead_time.band_a",
        ];
        self.dead_time.check(&mut c, dead);
        c.done()?;
        let ts = 1.0 / rate;
        let kt = motor.torque_constant();
        let g = self.gains();
        let speed = PiConfig {
            kp: g.speed_kp,
            ki: g.speed_ki,
            out_min: -i_max,
            out_max: i_max,
        }
        .build(ts * self.speed_divider as f32)?;
        Ok(Foc {
            current: CurrentLoop {
                kp: g.current_kp,
                ki_ts: g.current_ki * ts,
                l_h: motor.l_h,
                flux_wb: motor.flux_wb,
            },
            speed,
            inv_kt: 1.0 / kt,
            pole_pairs: motor.n(),
            speed_divider: self.speed_divider,
            advance_s: self.angle_advance_periods * ts,
            v_max_per_bus: self.dead_time.v_max_per_bus(),
            dead_time: DeadTime::new(&self.dead_time),
        })
    }
}

/// The PI gains [`FocConfig::gains`] derives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FocGains {
    /// Current PI proportional gain `L ω_c` \[V/A].
    pub current_kp: f32,
    /// Current PI integral gain `R ω_c` \[V/(A·s)].
    pub current_ki: f32,
    /// Speed PI proportional gain `J ω_s/(N ψ_f)` \[A·s/rad].
    pub speed_kp: f32,
    /// Speed PI integral gain `kp ω_s/4` \[A/rad].
    pub speed_ki: f32,
}

/// d/q current PIs with decoupling, back-EMF feed-forward and voltage-vector saturation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentLoop {
    kp: f32,
    ki_ts: f32,
    l_h: f32,
    flux_wb: f32,
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
    /// The command was cut to (just inside) `v_max`; the integrators were held.
    pub saturated: bool,
    /// The inputs were usable (finite, `v_max` in range), so `v_dq` is the loop's command;
    /// false: zero volts.
    pub valid: bool,
}

impl CurrentLoop {
    /// One update at the current-loop rate.
    /// `i_dq`, `i_dq_ref` \[A]; `omega_e` electrical speed \[rad/s]; `v_max` the largest
    /// voltage magnitude the inverter can apply \[V], positive, 1.1e-19..1.8e19 (its square a
    /// normal f32). Anti-windup: when the vector is cut to `v_max`, neither integrator moves.
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
        // Ortega Sec V iv: decoupling and back-EMF feed-forward.
        let v_d = self.kp * e_d + int_d - omega_e * self.l_h * i_dq.q;
        let v_q = self.kp * e_q + int_q + omega_e * (self.l_h * i_dq.d + self.flux_wb);
        let out = limit(Dq::new(v_d, v_q), v_max);
        // Anti-windup: the integrators move only while the vector is inside the circle.
        if !out.saturated {
            state.integral_d = int_d;
            state.integral_q = int_q;
        }
        out
    }
}

/// `v_dq` \[V] limited to the circle of radius `v_max` \[V] (positive, 1.1e-19..1.8e19 V, its
/// square a normal f32); non-finite inputs or a `v_max` outside that range give zero volts,
/// `valid` false.
#[inline(always)]
fn limit(v_dq: Dq, v_max: f32) -> CurrentLoopOutput {
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

/// What a drive mode asks of the FOC for one period: the frame, and a current or a voltage
/// in it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Request {
    /// sin/cos of the frame's angle at the sample [rad, electrical]: the Park transform of the
    /// currents.
    pub frame: SinCos,
    /// sin/cos of the angle the voltage is applied at (the frame's angle advanced over the
    /// coming period, see [`Foc::output_angle`]): the inverse Park transform.
    pub frame_out: SinCos,
    /// The frame's speed for the current loop's decoupling [rad/s, mechanical].
    pub omega_m: f32,
    /// What to apply in the frame.
    pub reference: Reference,
}

/// The reference of a [`Request`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Reference {
    /// Current command \[A]: the current loop.
    Current(Dq),
    /// Voltage command \[V], applied as it is (limited to the bus) with the current loop's
    /// integrators held.
    Voltage(Dq),
}

/// The FOC block: current loop every step, speed loop every `speed_divider` steps, SVPWM.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Foc {
    current: CurrentLoop,
    speed: Pi,
    inv_kt: f32,
    pole_pairs: f32,
    speed_divider: u32,
    advance_s: f32,
    /// The current loop's voltage limit per volt of bus, `(1 − 2·t_d·f_pwm)/√3`
    /// ([`DeadTimeConfig::v_max_per_bus`]).
    v_max_per_bus: f32,
    dead_time: DeadTime,
}

/// Running state of [`Foc`].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FocState {
    /// Current-loop integrators.
    pub current: CurrentLoopState,
    /// Speed-loop integrator \[A].
    pub speed: PiState,
    /// Latest `i_q` command from the speed loop \[A].
    pub i_q_ref: f32,
    /// Steps since the last speed-loop update.
    pub tick: u32,
}

/// Inputs of one FOC step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FocInput {
    /// Sampled phase currents \[A].
    pub i_abc: Abc,
    /// DC bus voltage \[V].
    pub v_bus: f32,
    /// Rotor electrical angle used for the transforms \[rad] (encoder or observer).
    pub theta_e: f32,
    /// Rotor mechanical speed used by the loops \[rad/s] (encoder or observer).
    pub omega_m: f32,
    /// Speed command [rad/s, mechanical].
    pub omega_m_ref: f32,
    /// Load-torque feed-forward \[N·m] (estimated load torque; 0 without a torque observer).
    pub torque_ff_nm: f32,
}

/// What one current-loop period needs of the sample, the currents already in the stationary
/// frame (see [`Foc::current_step_at`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CurrentSample {
    /// Measured currents in the stationary frame \[A].
    pub i_ab: AlphaBeta,
    /// DC bus voltage \[V].
    pub v_bus: f32,
    /// Rotor mechanical speed used by the decoupling \[rad/s].
    pub omega_m: f32,
}

impl CurrentSample {
    /// The current-loop part of `input`: its phase currents through the Clarke transform.
    pub fn of(input: &FocInput) -> Self {
        Self {
            i_ab: input.i_abc.to_alpha_beta(),
            v_bus: input.v_bus,
            omega_m: input.omega_m,
        }
    }
}

/// Outputs of one FOC step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FocOutput {
    /// PWM duties, each in `[0, 1]`.
    pub duties: Duties,
    /// The stator voltage these duties apply on average over the period \[V] (for observers),
    /// the inverter's dead time included (to the accuracy of its smooth sign,
    /// [`crate::dead_time`]); zero volts when the loop's inputs were unusable.
    pub v_ab: AlphaBeta,
    /// Measured currents in the stationary frame \[A].
    pub i_ab: AlphaBeta,
    /// Measured currents in the rotor frame of `theta_e` \[A].
    pub i_dq: Dq,
    /// Current command \[A].
    pub i_dq_ref: Dq,
    /// The voltage vector was limited.
    pub saturated: bool,
}

impl Foc {
    /// One current-loop period; every `speed_divider`-th call also runs the speed loop first.
    pub fn step(&self, state: &mut FocState, input: &FocInput) -> FocOutput {
        let sc = SinCos::of(input.theta_e);
        let sc_out = self.output_angle(sc, input.omega_m);
        self.step_at(state, input, sc, sc_out)
    }

    /// sin/cos of the angle the voltage of this period is applied at, `θ_e + advance·ω_e·Ts`
    /// (see [`FocConfig::angle_advance_periods`]), from `sc` = sin/cos of `θ_e`.
    pub fn output_angle(&self, sc: SinCos, omega_m: f32) -> SinCos {
        sc.rotated(self.output_rotation(omega_m))
    }

    /// sin/cos of the output angle's lead over `θ_e`, `advance·ω_e·Ts`, at speed `omega_m`
    /// [rad/s, mechanical]: [`Foc::output_angle`] is `sc` rotated by it, so a caller whose speed
    /// changes less often than every period can keep it.
    #[inline]
    pub fn output_rotation(&self, omega_m: f32) -> SinCos {
        SinCos::of_small(self.pole_pairs * omega_m * self.advance_s)
    }

    /// [`Foc::step`] with the sin/cos of `input.theta_e` (`sc`, for the Park transform of the
    /// currents) and of the output angle (`sc_out`, for the inverse Park of the voltage, see
    /// [`Foc::output_angle`]) already known, e.g. kept by the observer that estimated the
    /// angle, which saves the trig evaluations.
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn step_at(
        &self,
        state: &mut FocState,
        input: &FocInput,
        sc: SinCos,
        sc_out: SinCos,
    ) -> FocOutput {
        if state.tick == 0 {
            state.i_q_ref = self.speed_step(
                &mut state.speed,
                input.omega_m_ref,
                input.omega_m,
                input.torque_ff_nm,
            );
        }
        state.tick = state.tick.saturating_add(1);
        if state.tick >= self.speed_divider {
            state.tick = 0;
        }
        let i_dq_ref = Dq::new(0.0, state.i_q_ref);
        self.current_step_at(
            &mut state.current,
            &CurrentSample::of(input),
            sc,
            sc_out,
            i_dq_ref,
        )
    }

    /// One speed-loop update (at `current_rate_hz / speed_divider`): the `i_q` command \[A]
    /// from the speed error [rad/s, mechanical] with the load-torque feed-forward
    /// `torque_ff_nm` \[N·m].
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn speed_step(
        &self,
        speed: &mut PiState,
        omega_m_ref: f32,
        omega_m: f32,
        torque_ff_nm: f32,
    ) -> f32 {
        let ff_a = torque_ff_nm * self.inv_kt;
        self.speed.update(speed, omega_m_ref - omega_m, ff_a)
    }

    /// This FOC with its current loop's gains replaced: `kp` \[V/A], `ki_ts` = `ki T` \[V/A],
    /// the decoupling inductance `l_h` \[H] and the flux linkage fed forward `flux_wb` \[Wb]
    /// (the identification's loop, from the parameters it measured).
    pub fn with_current_gains(&self, kp: f32, ki_ts: f32, l_h: f32, flux_wb: f32) -> Self {
        Self {
            current: CurrentLoop {
                kp,
                ki_ts,
                l_h,
                flux_wb,
            },
            ..*self
        }
    }

    /// [`Foc::speed_step`] with the `i_q` command within `limits` \[A] this update (inside the
    /// current limit) and the integrator held where `held` says (anti-windup,
    /// [`Pi::update_within`]).
    #[inline(always)]
    pub fn speed_step_within(
        &self,
        speed: &mut PiState,
        (omega_m_ref, omega_m): (f32, f32),
        torque_ff_nm: f32,
        (limits, held): ((f32, f32), Held),
    ) -> f32 {
        let ff_a = torque_ff_nm * self.inv_kt;
        (self.speed).update_within(speed, omega_m_ref - omega_m, ff_a, limits, held)
    }

    /// The dead-time compensation this FOC applies ([`crate::dead_time`]).
    pub fn dead_time(&self) -> &DeadTime {
        &self.dead_time
    }

    /// The q current that makes `torque_nm` \[N·m] in the papers' model, `τ/(N ψ_f)` \[A].
    pub fn current_for_torque(&self, torque_nm: f32) -> f32 {
        torque_nm * self.inv_kt
    }

    /// The largest voltage the current loop applies on a bus of `v_bus` \[V]: `V_bus/√3` less the
    /// dead time's margin \[V].
    pub fn v_max(&self, v_bus: f32) -> f32 {
        v_bus * self.v_max_per_bus
    }

    /// The torque the q current `i_q_a` \[A] makes in the papers' model, `N ψ_f i_q` \[N·m].
    pub fn torque_for_current(&self, i_q_a: f32) -> f32 {
        i_q_a / self.inv_kt
    }

    /// One period of a drive mode's [`Request`]: the current loop on a current reference, or
    /// the voltage reference limited to the bus; then SVPWM. `i_ab` the measured currents \[A],
    /// `v_bus` \[V].
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn run(
        &self,
        state: &mut CurrentLoopState,
        req: &Request,
        i_ab: AlphaBeta,
        v_bus: f32,
    ) -> FocOutput {
        let sample = CurrentSample {
            i_ab,
            v_bus,
            omega_m: req.omega_m,
        };
        match req.reference {
            Reference::Current(i_dq_ref) => {
                self.current_step_at(state, &sample, req.frame, req.frame_out, i_dq_ref)
            }
            Reference::Voltage(v_dq) => {
                cold_path();
                let v_max = v_bus * self.v_max_per_bus;
                self.modulate(
                    limit(v_dq, v_max),
                    &sample,
                    req.frame_out,
                    i_ab.to_dq(req.frame),
                )
            }
        }
    }

    /// One current-loop period with an explicit current command (no speed loop).
    pub fn current_step(
        &self,
        state: &mut CurrentLoopState,
        input: &FocInput,
        i_dq_ref: Dq,
    ) -> FocOutput {
        let sc = SinCos::of(input.theta_e);
        let sc_out = self.output_angle(sc, input.omega_m);
        self.current_step_at(state, &CurrentSample::of(input), sc, sc_out, i_dq_ref)
    }

    /// [`Foc::current_step`] with the angles of [`Foc::step_at`] already known and the
    /// currents already in the stationary frame (a caller that has them saves the Clarke
    /// transform).
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn current_step_at(
        &self,
        state: &mut CurrentLoopState,
        input: &CurrentSample,
        sc: SinCos,
        sc_out: SinCos,
        i_dq_ref: Dq,
    ) -> FocOutput {
        let i_dq = input.i_ab.to_dq(sc);
        let omega_e = self.pole_pairs * input.omega_m;
        let v_max = input.v_bus * self.v_max_per_bus;
        let out = self.current.update(state, i_dq, i_dq_ref, omega_e, v_max);
        FocOutput {
            i_dq_ref,
            ..self.modulate(out, input, sc_out, i_dq)
        }
    }

    /// SVPWM of the loop's output `out` at the output angle `sc_out`, the dead time
    /// compensated; `i_dq` the measured currents in the control frame, reported.
    #[inline(always)]
    fn modulate(
        &self,
        out: CurrentLoopOutput,
        input: &CurrentSample,
        sc_out: SinCos,
        i_dq: Dq,
    ) -> FocOutput {
        let v_ab_cmd = out.v_dq.to_alpha_beta(sc_out);
        // The loop has limited the vector to the circle and found the bus usable: SVPWM need
        // not check either again (`svpwm_limited`): the limit leaves room for the compensation
        // `e` inside the hexagon (`DeadTimeConfig::v_max_per_bus`), and a vector beyond it
        // would take SVPWM's own cut.
        let (pwm, v_ab) = if out.valid {
            // Average-voltage compensation (Choi & Sul; Muñoz & Lipo): modulate `v + E` so
            // that the inverter, which takes `E`, applies `v`; it applies what SVPWM applies
            // less `E`.
            let e = self.dead_time.error(input.i_ab, input.v_bus);
            let v = AlphaBeta::new(v_ab_cmd.alpha + e.alpha, v_ab_cmd.beta + e.beta);
            let pwm = svpwm_limited(v, input.v_bus);
            // Not cut: SVPWM applied `v` itself, the inverter `v_cmd` (exactly).
            let applied = if pwm.saturated {
                cold_path();
                let a = pwm.v_ab_applied;
                AlphaBeta::new(a.alpha - e.alpha, a.beta - e.beta)
            } else {
                v_ab_cmd
            };
            (pwm, applied)
        } else {
            cold_path();
            (Svpwm::OFF, AlphaBeta::default())
        };
        FocOutput {
            duties: pwm.duties,
            v_ab,
            i_ab: input.i_ab,
            i_dq,
            i_dq_ref: Dq::default(),
            saturated: out.saturated || pwm.saturated,
        }
    }
}
