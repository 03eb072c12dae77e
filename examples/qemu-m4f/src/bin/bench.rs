//! Per-call instruction counts on the emulated Cortex-M4F: each measured call sits between
//! a `bench_begin_<name>()` and a `bench_end_<name>()` marker; `pmsm-sim cycles` runs this under QEMU with
//! `-d exec,nochain -singlestep` (one trace line per executed instruction) and counts the
//! instructions between the markers, weighting them with the Cortex-M4 timing table.
//!
//! The drive starts in sensorless control at 1000 rpm on the Sinano motor
//! (`Drive::running_state`: both observers seeded at that rotor state), so the measured `step`
//! takes the sensorless branch with both observers live; it is measured with the sliding and
//! the flux observer primary (its PLL plain and aided), in open loop (start-up, reached from
//! idle through the alignment), with the voltage at its limit (bus at its under-voltage trip,
//! 37 V), and with the angles crossing ±π; after every fourth step the drive's 1 kHz task
//! (`Drive::tick`) is measured too, each sensorless case unloaded and with its speed loop at
//! the current limit, motoring and braking. Every case runs a full electrical turn (64 steps); each measured call is a
//! function of its own, as the firmware's interrupt and main loop call them.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!("bench is firmware: `pmsm-sim cycles` runs it under QEMU");
}

#[cfg(target_os = "none")]
mod firmware {
    use core::hint::black_box;
    use cortex_m_rt::entry;
    use cortex_m_semihosting::debug::{self, EXIT_SUCCESS};
    use defmt_semihosting as _;
    use panic_probe as _;
    use pmsm_sensorless::drive::{
        Command, Drive, DriveConfig, DriveInput, DriveOutput, Identified, IdentifyPhase, Mode,
        StateOf,
    };
    use pmsm_sensorless::fixed::current::{CurrentLoopOutputQ, CurrentLoopQ, CurrentLoopStateQ};
    use pmsm_sensorless::fixed::flux::{FluxObserverQ, FluxStateQ};
    use pmsm_sensorless::fixed::pll::{PllQ, PllStateQ};
    use pmsm_sensorless::fixed::pu::PerUnit;
    use pmsm_sensorless::fixed::sliding::{SlidingObserverQ, SlidingStateQ};
    #[cfg(feature = "fixed-step")]
    use pmsm_sensorless::fixed::step::{FixedDrive, FixedInput, FixedOutput, FixedState};
    use pmsm_sensorless::fixed::svpwm::{svpwm_limited_q15, SvpwmQ15};
    use pmsm_sensorless::fixed::{AbcQ15, AlphaBetaQ15, Angle, DqQ15, Q15};
    use pmsm_sensorless::foc::{CurrentLoopState, Foc, FocConfig, FocInput, FocOutput, Reference};
    use pmsm_sensorless::frames::{AlphaBeta, Dq};
    use pmsm_sensorless::motor::HORNG_SINANO;
    use pmsm_sensorless::observer::flux::{FluxConfig, FluxObserver, FluxState};
    use pmsm_sensorless::observer::flux_speed::FluxPll;
    use pmsm_sensorless::observer::pll::{Pll, PllConfig, PllState};
    use pmsm_sensorless::observer::sliding::{SlidingConfig, SlidingObserver, SlidingState};
    use pmsm_sensorless::observer::{Observer, Rotor};

    /// Defines the begin/end markers of one measured section; the trace is cut at the first
    /// instruction of each (their symbol names are what `pmsm-sim cycles` looks for).
    /// Each body differs (its own constant), so the linker cannot fold them into one.
    macro_rules! markers {
        ($($begin:ident, $end:ident, $id:literal;)*) => {$(
            #[inline(never)]
            #[no_mangle]
            pub extern "C" fn $begin() {
                black_box($id);
            }
            #[inline(never)]
            #[no_mangle]
            pub extern "C" fn $end() {
                black_box($id + 100);
            }
        )*};
    }

    markers! {
        bench_begin_step, bench_end_step, 1u32;
        bench_begin_step_open_loop, bench_end_step_open_loop, 9u32;
        bench_begin_step_saturated, bench_end_step_saturated, 10u32;
        bench_begin_step_seam, bench_end_step_seam, 11u32;
        bench_begin_sliding, bench_end_sliding, 3u32;
        bench_begin_flux_pll, bench_end_flux_pll, 4u32;
        bench_begin_foc_svpwm, bench_end_foc_svpwm, 5u32;
        bench_begin_step_flux_primary, bench_end_step_flux_primary, 6u32;
        bench_begin_tick, bench_end_tick, 12u32;
        bench_begin_tick_flux_primary, bench_end_tick_flux_primary, 13u32;
        bench_begin_tick_open_loop, bench_end_tick_open_loop, 14u32;
        bench_begin_step_calibrate, bench_end_step_calibrate, 15u32;
        bench_begin_step_identify_resistance, bench_end_step_identify_resistance, 16u32;
        bench_begin_step_identify_inductance, bench_end_step_identify_inductance, 17u32;
        bench_begin_step_identify_flux, bench_end_step_identify_flux, 18u32;
        bench_begin_step_identify_mechanics, bench_end_step_identify_mechanics, 19u32;
        bench_begin_tick_identify, bench_end_tick_identify, 20u32;
        bench_begin_fixed_frames, bench_end_fixed_frames, 21u32;
        bench_begin_fixed_flux, bench_end_fixed_flux, 22u32;
        bench_begin_fixed_current, bench_end_fixed_current, 23u32;
        bench_begin_fixed_pll, bench_end_fixed_pll, 24u32;
        bench_begin_fixed_svpwm, bench_end_fixed_svpwm, 25u32;
        bench_begin_fixed_sliding, bench_end_fixed_sliding, 26u32;
        bench_begin_step_salient, bench_end_step_salient, 27u32;
        bench_begin_tick_salient, bench_end_tick_salient, 28u32;
        bench_begin_step_inject, bench_end_step_inject, 29u32;
        bench_begin_tick_inject, bench_end_tick_inject, 30u32;
        bench_begin_background, bench_end_background, 35u32;
    }

    // The fixed-point step's cases: in the M0's bench only (its package's feature
    // `fixed-step`), so that the M4F's bench, whose step cases have no headroom, is compiled
    // as before (with these cases in its binary LTO moved its f32 step cases by 1 to 4
    // cycles).
    #[cfg(feature = "fixed-step")]
    markers! {
        bench_begin_fixed_step, bench_end_fixed_step, 31u32;
        bench_begin_fixed_step_pll, bench_end_fixed_step_pll, 32u32;
        bench_begin_fixed_tick, bench_end_fixed_tick, 33u32;
        bench_begin_fixed_step_limited, bench_end_fixed_step_limited, 34u32;
    }

    /// Steps measured per case.
    const STEPS: u32 = 64;

    /// One control step as the board firmware's interrupt runs it (`Control::step` in
    /// `examples/b-g431b-esc1/src/control.rs`, the shared `pmsm_sensorless::control` step
    /// inlined into it): `Drive::step` inlined into a function of its own, so the count includes that function's register saves and returns, and none of the
    /// bench loop's own register pressure.
    #[inline(never)]
    fn control_step<P: Observer, M: Observer>(
        drive: &Drive<P, M>,
        st: &mut StateOf<P, M>,
        input: &DriveInput,
        cmd: &Command,
    ) -> DriveOutput {
        drive.step(st, input, cmd)
    }

    /// A measured section's begin and end markers.
    type Markers = (extern "C" fn(), extern "C" fn());

    /// [`control_step`] between `markers`, in a function of its own: the window holds the
    /// markers' returns, the call's argument moves and the step, and none of the calling
    /// loop's register spills (which moved by up to six instructions with unrelated code
    /// elsewhere in this bench's `main`).
    #[inline(never)]
    fn timed_step<P: Observer, M: Observer>(
        markers: Markers,
        drive: &Drive<P, M>,
        st: &mut StateOf<P, M>,
        input: &DriveInput,
        cmd: &Command,
    ) -> DriveOutput {
        markers.0();
        let out = control_step(drive, st, input, cmd);
        markers.1();
        // (After the end marker: its call is not a tail call after this function's
        // epilogue, which would be counted.)
        black_box(&out);
        out
    }

    /// [`control_tick`] between `markers`, as [`timed_step`].
    #[inline(never)]
    fn timed_tick<P: Observer, M: Observer>(
        markers: Markers,
        drive: &Drive<P, M>,
        st: &mut StateOf<P, M>,
        cmd: &Command,
    ) {
        markers.0();
        control_tick(drive, st, cmd);
        markers.1();
        black_box(());
    }

    /// The drive's slower work after the 1 kHz task ([`Drive::background`]) between
    /// `markers`, as [`timed_step`].
    #[inline(never)]
    fn timed_background<P: Observer, M: Observer>(
        markers: Markers,
        drive: &Drive<P, M>,
        st: &mut StateOf<P, M>,
    ) {
        markers.0();
        drive.background(st);
        markers.1();
        black_box(());
    }

    /// The drive's 1 kHz task as the board's task interrupt runs it (`Tick::run`, on a copy
    /// of the state; the copies are not counted).
    #[inline(never)]
    fn control_tick<P: Observer, M: Observer>(
        drive: &Drive<P, M>,
        st: &mut StateOf<P, M>,
        cmd: &Command,
    ) {
        black_box(drive.tick(st, cmd));
    }

    /// The blocks alone, each in a function of its own like [`control_step`].
    #[inline(never)]
    fn sliding_update(
        obs: &SlidingObserver,
        st: &mut SlidingState,
        i_ab: AlphaBeta,
        v_ab: AlphaBeta,
    ) -> bool {
        obs.update(st, i_ab, v_ab)
    }

    /// The fixed-point blocks (issue #30), each in a function of its own: the frames (sin/cos,
    /// Clarke, Park, inverse Park), Ortega's flux observer eq (9), the current loop, the PLL
    /// of Sec V iii with its speed in per unit, the SVPWM (the FOC's limited form: a vector
    /// inside the circle, one between the circle and the hexagon, one beyond it, cut), Horng
    /// & Chin's sliding torque observer.
    #[inline(never)]
    fn fixed_frames(abc: AbcQ15, angle: Angle, v: DqQ15) -> (DqQ15, AlphaBetaQ15) {
        let sc = angle.sin_cos();
        (abc.to_alpha_beta().to_dq(sc), v.to_alpha_beta(sc))
    }

    #[inline(never)]
    fn fixed_flux(
        obs: &FluxObserverQ,
        st: &mut FluxStateQ,
        i: AlphaBetaQ15,
        v: AlphaBetaQ15,
    ) -> Option<(Q15, Q15)> {
        obs.integrate(st, i, v);
        st.sin_cos()
    }

    #[inline(never)]
    fn fixed_current(
        cl: &CurrentLoopQ,
        st: &mut CurrentLoopStateQ,
        (i, i_ref): (DqQ15, DqQ15),
        omega_e: Q15,
        v_max: Q15,
    ) -> CurrentLoopOutputQ {
        cl.update(st, i, i_ref, omega_e, v_max)
    }

    #[inline(never)]
    fn fixed_pll(pll: &PllQ, st: &mut PllStateQ, theta: Angle) -> (i32, Q15) {
        (pll.update(st, theta), pll.omega_q15(st))
    }

    #[inline(never)]
    fn fixed_sliding(
        obs: &SlidingObserverQ,
        st: &mut SlidingStateQ,
        i: AlphaBetaQ15,
        v: AlphaBetaQ15,
    ) -> Q15 {
        obs.update(st, i, v);
        obs.omega_q15(st)
    }

    #[inline(never)]
    fn fixed_svpwm(v_ab: AlphaBetaQ15) -> SvpwmQ15 {
        svpwm_limited_q15(v_ab)
    }

    /// The fixed-point step and task (`pmsm_sensorless::fixed::step`), each in a function of
    /// its own like [`control_step`].
    #[cfg(feature = "fixed-step")]
    #[inline(never)]
    fn fixed_step(drive: &FixedDrive, st: &mut FixedState, input: &FixedInput) -> FixedOutput {
        drive.step(st, input)
    }

    #[cfg(feature = "fixed-step")]
    #[inline(never)]
    fn fixed_tick(drive: &FixedDrive, st: &mut FixedState, speed_cmd: Q15) {
        black_box(drive.tick(st, speed_cmd));
    }

    #[inline(never)]
    fn flux_pll_update(
        (flux, pll): (&FluxObserver, &Pll),
        (f_state, p_state): (&mut FluxState, &mut PllState),
        i_ab: AlphaBeta,
        v_ab: AlphaBeta,
    ) -> (bool, f32) {
        let ok = flux.update(f_state, i_ab, v_ab);
        (ok, pll.update(p_state, f_state.theta_e))
    }

    #[inline(never)]
    fn foc_step(foc: &Foc, st: &mut CurrentLoopState, input: &FocInput, i_dq_ref: Dq) -> FocOutput {
        let req = input.request(foc, Reference::Current(i_dq_ref));
        foc.run(st, &req, input.i_ab(), input.v_bus)
    }

    /// Plausible samples at 1000 rpm (θ_e advancing 0.1047 rad per step from `theta0`), small
    /// load.
    fn sample_from(theta0: f32, k: u32) -> (f32, AlphaBeta) {
        let theta = pmsm_sensorless::math::wrap_pi(theta0 + 0.10472 * k as f32);
        let (s, c) = pmsm_sensorless::math::sin_cos(theta);
        (theta, AlphaBeta::new(-0.5 * s, 0.5 * c))
    }

    fn sample(k: u32) -> (f32, AlphaBeta) {
        sample_from(0.3, k)
    }

    /// A salient rotor at rest at `theta_e` for the injection's start (its lock and polarity
    /// test need a motor that answers the injection: the synthetic samples do not): its dq
    /// currents under the voltage the duties apply, blended over the update delay of
    /// `delay` periods, by forward Euler over a period `ts`; `L_d` falling as a d current adds
    /// to the magnet's flux, `L_d / (1 + i_d/i_sat)` with `i_sat` three times the
    /// rated-torque current (host-sim's injection tests take the same saturation, whose
    /// incremental inductance `L_d / (1 + i_d/i_sat)²` gives about twice this contrast:
    /// enough without noise).
    struct RotorAtRest {
        frame: pmsm_sensorless::frames::SinCos,
        r_ohm: f32,
        l_d_h: f32,
        l_q_h: f32,
        i_sat_a: f32,
        ts: f32,
        delay: f32,
        i: Dq,
        v_last: Dq,
    }

    impl RotorAtRest {
        fn i_abc(&self) -> pmsm_sensorless::frames::Abc {
            self.i.to_alpha_beta(self.frame).to_abc()
        }

        fn apply(&mut self, duties: Option<pmsm_sensorless::svpwm::Duties>, v_bus: f32) {
            let v_ab = duties.map_or(AlphaBeta::default(), |d| {
                let (a, b, c) = (d.a * v_bus, d.b * v_bus, d.c * v_bus);
                AlphaBeta::new(
                    (2.0 * a - b - c) / 3.0,
                    (b - c) * pmsm_sensorless::math::INV_SQRT3,
                )
            });
            let v = v_ab.to_dq(self.frame);
            let applied = Dq::new(
                (1.0 - self.delay) * v.d + self.delay * self.v_last.d,
                (1.0 - self.delay) * v.q + self.delay * self.v_last.q,
            );
            self.v_last = v;
            let l_d = self.l_d_h / (1.0 + self.i.d.max(0.0) / self.i_sat_a);
            self.i = Dq::new(
                self.i.d + self.ts / l_d * (applied.d - self.r_ohm * self.i.d),
                self.i.q + self.ts / self.l_q_h * (applied.q - self.r_ohm * self.i.q),
            );
        }
    }

    #[entry]
    fn main() -> ! {
        let m = HORNG_SINANO;
        // The control rate: the configuration's (4 kHz for this motor), or the one
        // `pmsm-sim cycles` builds the bench for (`PMSM_BENCH_RATE_HZ`), with the board's
        // update delay of one PWM period (the blended observer voltage, the output angle
        // turned apart from the sliding observer's EMF angle).
        let mut cfg = DriveConfig::new(&m);
        if let Some(r) = option_env!("PMSM_BENCH_RATE_HZ").and_then(|s| s.parse::<f32>().ok()) {
            cfg.rate_hz = r;
            cfg.power_stage.update_delay_s = 1.0 / cfg.power_stage.pwm_hz;
        }
        let rate = cfg.rate_hz;
        let steps_per_ms = (rate / 1000.0) as u32;
        let drive = cfg.build_sliding_primary().ok();
        let drive_flux = cfg.build_flux_primary().ok();
        let sliding = SlidingConfig {
            rate_hz: rate,
            ..SlidingConfig::torque(m.params)
        }
        .build()
        .ok();
        let flux = FluxConfig::new(m.params, rate, 60.0).build().ok();
        let pll = PllConfig {
            rate_hz: rate,
            bandwidth_hz: 50.0,
            damping: 1.0,
        }
        .build()
        .ok();
        let foc = FocConfig {
            current_rate_hz: rate,
            speed_divider: steps_per_ms,
            ..FocConfig::new(m.params, 4.5)
        }
        .build()
        .ok();
        let (Some(drive), Some(drive_flux), Some(sliding), Some(flux), Some(pll), Some(foc)) =
            (drive, drive_flux, sliding, flux, pll, foc)
        else {
            defmt::error!("configuration failed");
            debug::exit(debug::EXIT_FAILURE);
            loop {
                cortex_m::asm::wfi();
            }
        };
        let omega_m = 104.72;
        let (theta0, i0) = sample(0);
        // Sensorless at 1000 rpm at angle `start` under `load_nm`.
        let rotor = |start: f32, load_nm: f32| Rotor {
            theta_e: start,
            omega_m,
            load_nm,
        };
        let input = |start, k| DriveInput {
            i_abc: sample_from(start, k).1.to_abc(),
            v_bus: 48.0,
            v_ab_terminal: None,
            overrun: false,
            stage_fault: None,
        };
        let cmd = Command {
            enable: true,
            speed_rpm: 1000.0,
            clear_fault: false,
        };
        // One electrical turn and more (64 steps of 0.105 rad, every quadrant of the angles)
        // of `drive` from `st` on the samples from angle `start`, each step between the
        // `markers`, each 1 kHz task (after every fourth step) between the `tick_markers`.
        fn run<P: Observer, M: Observer>(
            name: &str,
            drive: &Drive<P, M>,
            mut st: StateOf<P, M>,
            (start, v_bus, cmd): (f32, f32, &Command),
            markers: Markers,
            tick_markers: Markers,
        ) {
            for k in 1..=STEPS {
                let input = DriveInput {
                    i_abc: sample_from(start, k).1.to_abc(),
                    v_bus,
                    v_ab_terminal: None,
                    overrun: false,
                    stage_fault: None,
                };
                let out = timed_step(markers, drive, &mut st, &input, cmd);
                if st.tick_due() {
                    timed_tick(tick_markers, drive, &mut st, cmd);
                }
                defmt::info!(
                    "{=str} step {}: mode {}, duties {}",
                    name,
                    k,
                    st.mode(),
                    out.duties.map(|d| [d.a, d.b, d.c])
                );
            }
        }
        // [`run`] from each of `states` in turn: one case unloaded and at the current limit.
        fn run_each<P: Observer, M: Observer>(
            name: &str,
            drive: &Drive<P, M>,
            states: [StateOf<P, M>; 3],
            args: (f32, f32, &Command),
            markers: Markers,
            tick_markers: Markers,
        ) {
            for st in states {
                run(name, drive, st, args, markers, tick_markers);
            }
        }
        let at_48v = (theta0, 48.0, &cmd);
        // Each sensorless case runs unloaded, then under twice the rated torque either way,
        // seeded into the speed loop's integrator and the load observer: the torque command
        // at the current limit, motoring and braking (the task's limited path,
        // `sensorless.rs`: the clamp, or braking first with its square root).
        let loads = [0.0, 2.0 * m.ratings.torque_nm, -2.0 * m.ratings.torque_nm];
        run_each(
            "sliding primary",
            &drive,
            loads.map(|load| drive.running_state(i0, rotor(theta0, load))),
            at_48v,
            (bench_begin_step, bench_end_step),
            (bench_begin_tick, bench_end_tick),
        );
        // The task's slower work after it at its costliest (`adaptation.rs`: ψ_f measured
        // inside the dead-time band; `speed_gain.rs`: a block's end with the slow check's
        // interval and a raise, the fast check's interval with a halving), after each task
        // of a sliding-primary run.
        let mut st = drive.running_state(i0, rotor(theta0, 0.0));
        for k in 1..=STEPS {
            black_box(control_step(&drive, &mut st, &input(theta0, k), &cmd));
            if st.tick_due() {
                control_tick(&drive, &mut st, &cmd);
                drive.bench_background_worst(&mut st);
                let markers: Markers = (bench_begin_background, bench_end_background);
                timed_background(markers, &drive, &mut st);
            }
        }
        // The flux observer feeding the controller (the sliding observer as the monitor).
        run_each(
            "flux primary",
            &drive_flux,
            loads.map(|load| drive_flux.running_state(i0, rotor(theta0, load))),
            at_48v,
            (bench_begin_step_flux_primary, bench_end_step_flux_primary),
            (bench_begin_tick_flux_primary, bench_end_tick_flux_primary),
        );
        // The same with the PLL aided (`observer::pll`, "Aided"), as the drive
        // runs it on the motors whose acceleration the plain PLL would slip under
        // (`DriveConfig::pll_aided`: the zoo's drone motor, the DF45, the Delta servo), into
        // the same sections.
        let aided = match (
            cfg.flux_config().build(),
            cfg.pll_config().build(),
            cfg.sliding_monitor(),
        ) {
            (Ok(flux), Ok(pll), Ok(monitor)) => cfg
                .build(FluxPll::new(flux, pll.aided(), m.params.n()), monitor)
                .ok(),
            _ => None,
        };
        let Some(drive_aided) = aided else {
            defmt::error!("aided-PLL configuration failed");
            debug::exit(debug::EXIT_FAILURE);
            loop {
                cortex_m::asm::wfi();
            }
        };
        run_each(
            "flux primary, aided PLL",
            &drive_aided,
            loads.map(|load| drive_aided.running_state(i0, rotor(theta0, load))),
            at_48v,
            (bench_begin_step_flux_primary, bench_end_step_flux_primary),
            (bench_begin_tick_flux_primary, bench_end_tick_flux_primary),
        );
        // A salient motor (issue #29): the Sinano's with `L_q/L_d = 2` about its `L`, so the
        // flux observer's active-flux terms, the FOC's two inductances and the MTPA's split of
        // the torque current run; both primaries, each step and task into one section.
        let salient = pmsm_sensorless::motor::Motor {
            params: m
                .params
                .with_inductances(2.0 / 3.0 * m.params.l_h, 4.0 / 3.0 * m.params.l_h)
                .ok()
                .filter(|p| p.is_salient())
                .unwrap_or_else(|| {
                    defmt::error!("salient motor refused");
                    debug::exit(debug::EXIT_FAILURE);
                    m.params
                }),
            ..m
        };
        let cfg_salient = DriveConfig {
            rate_hz: cfg.rate_hz,
            power_stage: cfg.power_stage,
            ..DriveConfig::new(&salient)
        };
        match (
            cfg_salient.build_sliding_primary(),
            cfg_salient.build_flux_primary(),
        ) {
            (Ok(sliding_primary), Ok(flux_primary)) => {
                run_each(
                    "salient, sliding primary",
                    &sliding_primary,
                    loads.map(|load| sliding_primary.running_state(i0, rotor(theta0, load))),
                    at_48v,
                    (bench_begin_step_salient, bench_end_step_salient),
                    (bench_begin_tick_salient, bench_end_tick_salient),
                );
                run_each(
                    "salient, flux primary",
                    &flux_primary,
                    loads.map(|load| flux_primary.running_state(i0, rotor(theta0, load))),
                    at_48v,
                    (bench_begin_step_salient, bench_end_step_salient),
                    (bench_begin_tick_salient, bench_end_tick_salient),
                );
            }
            _ => {
                defmt::error!("salient configuration failed");
                debug::exit(debug::EXIT_FAILURE);
            }
        }
        // The start through high-frequency injection on that salient motor (feature
        // `injection`, issue #29), flux primary: from idle to the injection's tracking (its
        // lock and polarity test, 55 ms at 4 kHz and 16 ms more a further round, not
        // measured, on a rotor at rest that answers the injection), then its steps and tasks,
        // the injection's speed loop running.
        match cfg_salient.build_flux_primary() {
            Ok(inject) if inject.injection().is_ok() => {
                let inject_cmd = Command {
                    speed_rpm: 60.0,
                    ..cmd
                };
                let mut st = StateOf::<FluxPll, SlidingObserver>::default();
                let p = salient.params;
                let mut rotor_at_rest = RotorAtRest {
                    frame: pmsm_sensorless::frames::SinCos::of(theta0),
                    r_ohm: p.r_ohm,
                    l_d_h: p.l_d_h(),
                    l_q_h: p.l_q_h(),
                    i_sat_a: 3.0 * salient.rated_torque_current_a(),
                    ts: 1.0 / cfg_salient.rate_hz,
                    delay: cfg_salient.power_stage.update_delay_s * cfg_salient.rate_hz,
                    i: Dq::default(),
                    v_last: Dq::default(),
                };
                for _ in 0..200 * steps_per_ms {
                    let at_rest = DriveInput {
                        i_abc: rotor_at_rest.i_abc(),
                        ..input(theta0, 0)
                    };
                    let out = control_step(&inject, &mut st, &at_rest, &inject_cmd);
                    rotor_at_rest.apply(out.duties, 48.0);
                    if st.tick_due() {
                        control_tick(&inject, &mut st, &inject_cmd);
                    }
                }
                if !st.injection().is_some_and(|(_, _, tracking)| tracking) {
                    defmt::error!("not tracking by injection: {}", st.mode());
                    debug::exit(debug::EXIT_FAILURE);
                }
                run(
                    "injection, flux primary",
                    &inject,
                    st,
                    (theta0, 48.0, &inject_cmd),
                    (bench_begin_step_inject, bench_end_step_inject),
                    (bench_begin_tick_inject, bench_end_tick_inject),
                );
            }
            // Declined at some of the board's rates (10 kHz: the update delay half a period,
            // the square wave does not reach the motor): no case at that rate. (At 20 kHz the
            // swing at a quarter of the 48 V bus was too small; the injection's share is now
            // what the current loop leaves, up to a half.) At the bench's own rate the case is
            // required (`pmsm-sim cycles` finds its section).
            Ok(_) => defmt::warn!("injection declined at this rate"),
            Err(_) => {
                defmt::error!("injection configuration failed");
                debug::exit(debug::EXIT_FAILURE);
            }
        }
        // Start-up: open loop at 60 rpm, past half the hand-over speed (the observers have
        // restarted), below the hand-over: reached from idle through the alignment (0.2 s)
        // and the ramp (60 ms), not measured. The alignment's samples are a winding's at
        // rest, `L di/dt = v − R i` (forward Euler over a step): the current follows the
        // drive's voltage, as the alignment checks (`Fault::OpenWinding`); then those of a
        // turning rotor.
        let open_loop_cmd = Command {
            speed_rpm: 60.0,
            ..cmd
        };
        let mut open_loop = StateOf::<SlidingObserver, FluxPll>::default();
        let (r, per_step) = (m.params.r_ohm, m.params.r_ohm / (m.params.l_h * rate));
        let mut i_winding = AlphaBeta::default();
        for k in 0..300 * steps_per_ms {
            let sample = if open_loop.mode() == Mode::Align {
                let v = open_loop.v_ab_applied();
                i_winding = AlphaBeta::new(
                    i_winding.alpha + per_step * (v.alpha / r - i_winding.alpha),
                    i_winding.beta + per_step * (v.beta / r - i_winding.beta),
                );
                DriveInput {
                    i_abc: i_winding.to_abc(),
                    ..input(theta0, k)
                }
            } else {
                input(theta0, k)
            };
            control_step(&drive, &mut open_loop, &sample, &open_loop_cmd);
            if open_loop.tick_due() {
                control_tick(&drive, &mut open_loop, &open_loop_cmd);
            }
        }
        if open_loop.mode() != Mode::OpenLoop {
            defmt::error!("not in open loop: {}", open_loop.mode());
            debug::exit(debug::EXIT_FAILURE);
        }
        run(
            "open loop",
            &drive,
            open_loop,
            (theta0, 48.0, &open_loop_cmd),
            (bench_begin_step_open_loop, bench_end_step_open_loop),
            (bench_begin_tick_open_loop, bench_end_tick_open_loop),
        );
        // The voltage at its limit: at 1000 rpm the back-EMF alone is ~24 V and the bus gives
        // 37/√3 = 21.4 V; with 1.5 A of i_q command (the load's current) the current loop asks
        // for more still.
        let load_1a5 = 1.5 * m.params.torque_constant();
        run(
            "saturated",
            &drive,
            drive.running_state(i0, rotor(theta0, load_1a5)),
            (theta0, 37.0, &cmd),
            (bench_begin_step_saturated, bench_end_step_saturated),
            (bench_begin_tick, bench_end_tick),
        );
        // The angles crossing ±π: the sliding observer's θ̂ (eq (22)) wraps in each step of a
        // millisecond in turn, the PLL's angle in the task.
        for j in 0..4u8 {
            let start = core::f32::consts::PI - 0.05 - 0.10472 * f32::from(j);
            let (_, i_start) = sample_from(start, 0);
            run(
                "seam",
                &drive,
                drive.running_state(i_start, rotor(start, 0.0)),
                (start, 48.0, &cmd),
                (bench_begin_step_seam, bench_end_step_seam),
                (bench_begin_tick, bench_end_tick),
            );
        }
        // Identification (issue #19): the offset calibration from idle (64 steps, PWM off),
        // then each measurement's step from its start, the ones before it taken as the
        // Sinano motor's values (the samples do not follow the voltage: the decisions of the
        // 1 kHz task take their paths, a fault among them, as they come).
        let mut calibrating = StateOf::<SlidingObserver, FluxPll>::default();
        black_box(drive.start_identification(&mut calibrating));
        run(
            "calibrate",
            &drive,
            calibrating,
            at_48v,
            (bench_begin_step_calibrate, bench_end_step_calibrate),
            (bench_begin_tick_identify, bench_end_tick_identify),
        );
        let p = m.params;
        let known = Identified {
            r_ohm: p.r_ohm,
            l_d_h: p.l_h,
            l_q_h: p.l_h,
            flux_wb: p.flux_wb,
            j_kgm2: p.j_kgm2,
            b_nms: p.b_nms,
        };
        let phases: [(IdentifyPhase, extern "C" fn(), extern "C" fn()); 4] = [
            (
                IdentifyPhase::Resistance,
                bench_begin_step_identify_resistance,
                bench_end_step_identify_resistance,
            ),
            (
                IdentifyPhase::Inductance,
                bench_begin_step_identify_inductance,
                bench_end_step_identify_inductance,
            ),
            (
                IdentifyPhase::Flux,
                bench_begin_step_identify_flux,
                bench_end_step_identify_flux,
            ),
            (
                IdentifyPhase::Mechanics,
                bench_begin_step_identify_mechanics,
                bench_end_step_identify_mechanics,
            ),
        ];
        for (phase, begin, end) in phases {
            run(
                "identify",
                &drive,
                drive.identification_state(phase, known),
                at_48v,
                (begin, end),
                (bench_begin_tick_identify, bench_end_tick_identify),
            );
        }
        let mut s_state = SlidingState::default();
        sliding.reset(&mut s_state, i0, theta0, omega_m);
        let mut f_state = FluxState::default();
        flux.reset(&mut f_state, i0, theta0);
        let mut p_state = PllState::default();
        pll.reset(&mut p_state, theta0, 4.0 * omega_m);
        let mut c_state = CurrentLoopState::default();
        let v = AlphaBeta::new(20.0, 10.0);
        for k in 1..4u32 {
            let (theta, i) = sample(k);
            bench_begin_sliding();
            black_box(sliding_update(&sliding, &mut s_state, i, v));
            bench_end_sliding();
            bench_begin_flux_pll();
            black_box(flux_pll_update(
                (&flux, &pll),
                (&mut f_state, &mut p_state),
                i,
                v,
            ));
            bench_end_flux_pll();
            let input = FocInput {
                i_abc: i.to_abc(),
                v_bus: 48.0,
                theta_e: theta,
                omega_m,
                omega_m_ref: omega_m,
                torque_ff_nm: 0.0,
            };
            bench_begin_foc_svpwm();
            let out = foc_step(&foc, &mut c_state, &input, Dq::new(0.0, 0.5));
            black_box(&out);
            bench_end_foc_svpwm();
        }
        // The fixed-point blocks on the same motor and settings (per unit from the drive's; the
        // PLL as the drive's, in its 1 kHz task).
        let pll_q_cfg = PllConfig {
            rate_hz: rate / steps_per_ms.max(1) as f32,
            bandwidth_hz: 50.0,
            damping: 1.0,
        };
        let fixed = PerUnit::of_drive(&cfg).and_then(|pu| {
            Ok((
                pu,
                FluxObserverQ::build(&cfg.flux_config(), &pu)?,
                CurrentLoopQ::build(&cfg.foc_config(), &pu)?,
                PllQ::build(&pll_q_cfg, &pu)?,
                SlidingObserverQ::build(&cfg.sliding_config(), &pu)?,
            ))
        });
        if let Ok((pu, flux_q, current_q, pll_q, sliding_q)) = fixed {
            let mut sliding_state = SlidingStateQ::default();
            let mut pll_state = PllStateQ::default();
            pll_q.reset(
                &mut pll_state,
                Angle::from_rad(theta0),
                pu.speed(4.0 * omega_m),
            );
            let mut f_state = FluxStateQ::default();
            let mut c_state = CurrentLoopStateQ::default();
            let i_ab = AlphaBetaQ15 {
                alpha: pu.current(0.5),
                beta: pu.current(-0.3),
            };
            flux_q.reset(&mut f_state, i_ab, Angle::from_rad(theta0));
            sliding_q.reset(
                &mut sliding_state,
                i_ab,
                Angle::from_rad(theta0),
                pu.speed(4.0 * omega_m),
                0,
            );
            let v_ab = AlphaBetaQ15 {
                alpha: 6000,
                beta: 3000,
            };
            for k in 1..4u32 {
                let angle = Angle(k.wrapping_mul(0x2345_6789));
                let abc = AbcQ15 {
                    a: pu.current(0.5),
                    b: pu.current(-0.2),
                    c: pu.current(-0.3),
                };
                bench_begin_fixed_frames();
                black_box(fixed_frames(abc, angle, DqQ15 { d: 100, q: 9000 }));
                bench_end_fixed_frames();
                bench_begin_fixed_flux();
                black_box(fixed_flux(&flux_q, &mut f_state, i_ab, v_ab));
                bench_end_fixed_flux();
                bench_begin_fixed_current();
                black_box(fixed_current(
                    &current_q,
                    &mut c_state,
                    (DqQ15 { d: 50, q: 3000 }, DqQ15 { d: 0, q: 8000 }),
                    9000,
                    20_000,
                ));
                bench_end_fixed_current();
                bench_begin_fixed_pll();
                black_box(fixed_pll(&pll_q, &mut pll_state, angle));
                bench_end_fixed_pll();
                // Q15 of the bus: inside the circle (0.35), towards a hexagon's corner beyond
                // the circle (0.62), beyond the hexagon (0.9): cut.
                let v_bus_q15 = [
                    AlphaBetaQ15 {
                        alpha: 10_000,
                        beta: -6_000,
                    },
                    AlphaBetaQ15 {
                        alpha: 20_000,
                        beta: 1_000,
                    },
                    AlphaBetaQ15 {
                        alpha: -25_000,
                        beta: 17_000,
                    },
                ];
                let v_svpwm = v_bus_q15[(k as usize - 1) % 3];
                bench_begin_fixed_sliding();
                black_box(fixed_sliding(&sliding_q, &mut sliding_state, i_ab, v_ab));
                bench_end_fixed_sliding();
                bench_begin_fixed_svpwm();
                black_box(fixed_svpwm(black_box(v_svpwm)));
                bench_end_fixed_svpwm();
            }
        } else {
            defmt::error!("the fixed-point blocks do not build for the bench's motor");
        }
        // The fixed-point step and its task on the same motor, in sensorless control at
        // 1000 rpm (seeded there), a full electrical turn each: the PLL in the task (the
        // Sinano's drive); the PLL in the step (as a motor turning more than half a turn per
        // millisecond at 1.5 times its rated speed has it, the drone's or the EMRAX's); and
        // the PLL in the step with the bus at its under-voltage trip, where the back-EMF takes
        // the current loop to its voltage limit (the radial cut).
        #[cfg(feature = "fixed-step")]
        for case in 0..3u32 {
            let built = if case == 0 {
                FixedDrive::build(&cfg)
            } else {
                FixedDrive::build_pll_in_step(&cfg)
            };
            let Ok(fixed) = built else {
                defmt::error!("the fixed-point step does not build for the bench's motor");
                continue;
            };
            let pu = *fixed.per_unit();
            let bus_v = if case == 2 {
                cfg.limits.bus_min_v + 0.5
            } else {
                m.ratings.bus_v
            };
            let bus = (bus_v / fixed.bus_base_v() * 32_768.0) as i16;
            let input = |k: u32| {
                let (_, i_ab) = sample(k);
                let abc = i_ab.to_abc();
                FixedInput {
                    i_abc: AbcQ15 {
                        a: pu.current(abc.a),
                        b: pu.current(abc.b),
                        c: pu.current(abc.c),
                    },
                    v_bus: bus,
                }
            };
            let omega_e = 4.0 * omega_m;
            let mut st = fixed.seed(
                input(0).i_abc,
                sample(0).0,
                omega_e,
                if case == 2 { 5.0 } else { 0.5 },
                AlphaBeta::new(2.0, 1.0),
                None,
            );
            let cmd = pu.speed(omega_e);
            for k in 1..=STEPS {
                let x = input(k);
                match case {
                    0 => {
                        bench_begin_fixed_step();
                        black_box(fixed_step(&fixed, &mut st, &x));
                        bench_end_fixed_step();
                    }
                    1 => {
                        bench_begin_fixed_step_pll();
                        black_box(fixed_step(&fixed, &mut st, &x));
                        bench_end_fixed_step_pll();
                    }
                    _ => {
                        bench_begin_fixed_step_limited();
                        black_box(fixed_step(&fixed, &mut st, &x));
                        bench_end_fixed_step_limited();
                    }
                }
                if k % steps_per_ms.max(1) == 0 {
                    bench_begin_fixed_tick();
                    fixed_tick(&fixed, &mut st, cmd);
                    bench_end_fixed_tick();
                }
            }
            if st.fault.is_some() {
                defmt::error!("the fixed-point step faulted in the bench");
            }
        }
        debug::exit(EXIT_SUCCESS);
        loop {
            cortex_m::asm::wfi();
        }
    }
}
