//! Field-oriented control: d/q current loops with decoupling and back-EMF feed-forward
//! (`current.rs`), and the speed loop that commands `i_q`. Its interface is two calls:
//! [`Foc::run`] each step (a drive mode's [`Request`]: current loop or voltage, dead-time
//! compensation, SVPWM) and [`Foc::speed_step`] at the caller's slower rate (the drive's 1 kHz
//! task; [`FocState`] for the FOC on a given angle without the drive, `bare.rs`).
//!
//! Gains come from the motor parameters and requested bandwidths (defaults of Horng & Chin
//! Sec 5: current loop 300 Hz at 4 kHz, speed loop 20 Hz at 1 kHz):
//! - current PI, pole-zero cancellation of `1/(R + sL)`: `kp = L ω_c`, `ki = R ω_c`, so the
//!   closed loop is `ω_c/(s + ω_c)`; of a salient motor each axis on its own inductance,
//!   `kp_d = L_d ω_c`, `kp_q = L_q ω_c` with the one `ki = R ω_c`: the PI's zero `R/L_d`
//!   (`R/L_q`) cancels that axis' pole, so both axes close at `ω_c`;
//! - speed PI on `N ψ_f/(J s + B)`: `kp = J ω_s/(N ψ_f)`, `ki = kp ω_s/4` (integral zero a
//!   quarter of the crossover, ≈ 76° phase margin before sample and current-loop delays).
//!
//! Decoupling and back-EMF feed-forward, Ortega Sec V iv (dq model (3)):
//! `v_d = PI_d − ω_e L i_q`, `v_q = PI_q + ω_e L i_d + ω_e ψ_f`; of a salient motor
//! `v_d = PI_d − ω_e L_q i_q`, `v_q = PI_q + ω_e L_d i_d + ω_e ψ_f` (the dq model with
//! `L_d`, `L_q`; the same when `L_d = L_q`).
//!
//! The inverter's dead time is compensated between the loop and SVPWM ([`crate::dead_time`]):
//! the voltage it takes is added to the command, and the voltage reported for the observers
//! is what the inverter applies. The loop's voltage limit is the circle the compensated
//! inverter applies in every direction, `(1 − 2·t_d·f_pwm)·V_bus/√3` (`V_bus/√3` without
//! dead time, [`DeadTimeConfig::v_max_per_bus`]): a command on it plus the compensation stays
//! inside SVPWM's linear range, so the vector is applied as the loop computed it and its
//! anti-windup knows when it is cut.

mod bare;
mod current;

pub use bare::{FocInput, FocState};
pub use current::{CurrentLoop, CurrentLoopOutput, CurrentLoopState};

use crate::dead_time::{DeadTime, DeadTimeConfig};
use crate::frames::{AlphaBeta, Dq, SinCos};
use crate::motor::MotorParams;
use crate::param::{Allowed, Checks, ParamError};
use crate::pi::{Held, Pi, PiConfig, PiState};
use crate::schedule::{Schedule, SLOTS};
use crate::svpwm::{svpwm_limited, Duties, Svpwm};
use core::f32::consts::TAU;
use core::hint::cold_path;
use current::limit;

/// FOC settings in SI units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FocConfig {
    /// Motor model the gains are computed from (the controller's belief, may differ from the plant).
    pub motor: MotorParams,
    /// Current-loop rate \[Hz]; the step runs at this rate. Default 4000.
    pub current_rate_hz: f32,
    /// Current-loop bandwidth \[Hz], at most `current_rate_hz / (2π)`. Default 300.
    pub current_bandwidth_hz: f32,
    /// The speed loop runs every `speed_divider` steps: `current_rate_hz / 1000` (the 1 kHz
    /// task; [`SLOTS`] = 4 at 4 kHz), the one schedule of the drive and of [`FocState`]; the
    /// speed PI's period.
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
            speed_divider: SLOTS,
            speed_bandwidth_hz: 20.0,
            i_max_a,
            angle_advance_periods: 0.5,
            dead_time: DeadTimeConfig::NONE,
        }
    }

    /// The PI gains (module doc): current `kp = L ω_c` \[V/A] (`L_d ω_c`, `L_q ω_c` per axis of
    /// a salient motor), `ki = R ω_c` \[V/(A·s)]; speed
    /// `kp = J ω_s/(N ψ_f)` \[A·s/rad], `ki = kp ω_s/4` \[A/rad]. Unvalidated: [`FocConfig::build`]
    /// checks the settings first.
    pub fn gains(&self) -> FocGains {
        let m = &self.motor;
        let w_c = TAU * self.current_bandwidth_hz;
        let w_s = TAU * self.speed_bandwidth_hz;
        let speed_kp = m.j_kgm2 * w_s / m.torque_constant();
        FocGains {
            current_kp: m.l_d_h() * w_c,
            current_kp_q: m.l_q_h() * w_c,
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
        // The caller's schedule runs the speed loop once a millisecond (`FocState`, the drive).
        let per_tick = libm::roundf(rate / crate::schedule::TICK_HZ);
        let divider = Allowed::between(per_tick, per_tick).because("current_rate_hz/1000");
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
            "dead_time.duty_max",
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
        let schedule = Schedule::at("current_rate_hz", rate)?;
        Ok(Foc {
            schedule,
            current: CurrentLoop {
                kp_d: g.current_kp,
                kp_q: g.current_kp_q,
                ki_ts: g.current_ki * ts,
                l_d_h: motor.l_d_h(),
                l_q_h: motor.l_q_h(),
                flux_wb: motor.flux_wb,
                d_share2: current::d_share2(motor.l_d_h(), motor.l_q_h()),
            },
            speed,
            inv_kt: 1.0 / kt,
            pole_pairs: motor.n(),
            advance_s: self.angle_advance_periods * ts,
            v_max_per_bus: self.dead_time.v_max_per_bus(),
            dead_time: DeadTime::new(&self.dead_time),
        })
    }
}

/// The PI gains [`FocConfig::gains`] derives.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FocGains {
    /// Current PI proportional gain `L ω_c` \[V/A]; of a salient motor the d axis', `L_d ω_c`.
    pub current_kp: f32,
    /// The q-axis PI's proportional gain `L_q ω_c` \[V/A] (`current_kp` when `L_d = L_q`).
    pub current_kp_q: f32,
    /// Current PI integral gain `R ω_c` \[V/(A·s)].
    pub current_ki: f32,
    /// Speed PI proportional gain `J ω_s/(N ψ_f)` \[A·s/rad].
    pub speed_kp: f32,
    /// Speed PI integral gain `kp ω_s/4` \[A/rad].
    pub speed_ki: f32,
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

/// The FOC block: [`Foc::run`] every step (current loop, dead-time compensation, SVPWM) and
/// [`Foc::speed_step`] every `speed_divider` steps (the caller's schedule: the drive's
/// [`Schedule`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Foc {
    current: CurrentLoop,
    /// The speed loop's place among the steps ([`FocState`]).
    pub(crate) schedule: Schedule,
    speed: Pi,
    inv_kt: f32,
    pole_pairs: f32,
    advance_s: f32,
    /// The current loop's voltage limit per volt of bus, `(1 − 2·t_d·f_pwm)/√3`
    /// ([`DeadTimeConfig::v_max_per_bus`]).
    v_max_per_bus: f32,
    dead_time: DeadTime,
}

/// What one current-loop period needs of the sample, the currents already in the stationary
/// frame.
#[derive(Clone, Copy, Debug, PartialEq)]
struct CurrentSample {
    /// Measured currents in the stationary frame \[A].
    i_ab: AlphaBeta,
    /// DC bus voltage \[V].
    v_bus: f32,
    /// Rotor mechanical speed used by the decoupling \[rad/s].
    omega_m: f32,
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
        self.run_with(state, req, i_ab, v_bus, true)
    }

    /// [`Foc::run`] with the current loop's voltage always cut along itself, never the d axis
    /// first (`current.rs`): the identification's loop, at the speeds and currents of its
    /// tests, where no field weakening holds a d current. (Compiled without the d axis' cut:
    /// with it, 744 B more of the commissioning image's flash, over its budget.)
    #[inline(always)]
    pub fn run_cut_along(
        &self,
        state: &mut CurrentLoopState,
        req: &Request,
        i_ab: AlphaBeta,
        v_bus: f32,
    ) -> FocOutput {
        self.run_with(state, req, i_ab, v_bus, false)
    }

    /// [`Foc::run`], the d axis first on the circle where `d_first`.
    #[inline(always)]
    fn run_with(
        &self,
        state: &mut CurrentLoopState,
        req: &Request,
        i_ab: AlphaBeta,
        v_bus: f32,
        d_first: bool,
    ) -> FocOutput {
        let sample = CurrentSample {
            i_ab,
            v_bus,
            omega_m: req.omega_m,
        };
        match req.reference {
            Reference::Current(i_dq_ref) => self.current(
                state,
                &sample,
                (req.frame, req.frame_out),
                i_dq_ref,
                d_first,
            ),
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

    /// One speed-loop update (at `current_rate_hz / speed_divider`, the drive's 1 kHz task):
    /// the `i_q` command \[A] from the speed error [rad/s, mechanical] with the load-torque
    /// feed-forward `torque_ff_nm` \[N·m]. `bounds`: the command's limits this update \[A]
    /// (inside the current limit) and where the integrator is held (anti-windup,
    /// [`Pi::update_within`]); `None`: the configured ±`i_max_a`, nothing held.
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn speed_step(
        &self,
        speed: &mut PiState,
        speeds: (f32, f32),
        torque_ff_nm: f32,
        bounds: Option<((f32, f32), Held)>,
    ) -> f32 {
        self.speed_step_scaled(speed, speeds, 1.0, torque_ff_nm, bounds)
    }

    /// [`Foc::speed_step`] with both PI gains scaled by `gain` (the gains of an inertia `gain`
    /// times the configured one: `kp = J ω_s/K_t`, `ki = kp ω_s/4`), as the error scaled: the
    /// integrator holds a current, so a new gain does not step it (the proportional part
    /// moves by `kp (g' − g) e`).
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    pub fn speed_step_scaled(
        &self,
        speed: &mut PiState,
        (omega_m_ref, omega_m): (f32, f32),
        gain: f32,
        torque_ff_nm: f32,
        bounds: Option<((f32, f32), Held)>,
    ) -> f32 {
        let ff_a = torque_ff_nm * self.inv_kt;
        let error = gain * (omega_m_ref - omega_m);
        match bounds {
            None => self.speed.update(speed, error, ff_a),
            Some((limits, held)) => (self.speed).update_within(speed, error, ff_a, limits, held),
        }
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

    /// This FOC with its current loop's gains replaced: `kp` = (`kp_d`, `kp_q`) \[V/A], `ki_ts`
    /// = `ki T` \[V/A], the decoupling inductances `l_dq_h` = (`L_d`, `L_q`) \[H] and the flux
    /// linkage fed forward `flux_wb` \[Wb] (the identification's loop, from the parameters it
    /// measured).
    pub fn with_current_gains(
        &self,
        kp: (f32, f32),
        ki_ts: f32,
        l_dq_h: (f32, f32),
        flux_wb: f32,
    ) -> Self {
        Self {
            current: CurrentLoop {
                kp_d: kp.0,
                kp_q: kp.1,
                ki_ts,
                l_d_h: l_dq_h.0,
                l_q_h: l_dq_h.1,
                flux_wb,
                d_share2: current::d_share2(l_dq_h.0, l_dq_h.1),
            },
            ..*self
        }
    }

    /// The d/q current loop (the reference the fixed-point loop, `crate::fixed::current`, is
    /// checked against).
    pub fn current_loop(&self) -> &CurrentLoop {
        &self.current
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

    /// One current-loop period on the current command `i_dq_ref` \[A] in the frame `sc`
    /// (sin/cos of its angle), the voltage applied at `sc_out` (see [`Foc::output_angle`]);
    /// `d_first` as [`CurrentLoop::update_with`].
    // Inlined: the 4 kHz step compiles to one function (see `drive`).
    #[inline(always)]
    fn current(
        &self,
        state: &mut CurrentLoopState,
        input: &CurrentSample,
        (sc, sc_out): (SinCos, SinCos),
        i_dq_ref: Dq,
        d_first: bool,
    ) -> FocOutput {
        let i_dq = input.i_ab.to_dq(sc);
        let omega_e = self.pole_pairs * input.omega_m;
        let v_max = input.v_bus * self.v_max_per_bus;
        let out = (self.current).update_with(state, i_dq, i_dq_ref, omega_e, v_max, d_first);
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
