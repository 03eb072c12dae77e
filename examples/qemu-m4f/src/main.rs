//! The drive on an emulated Cortex-M4F (QEMU `mps2-an386`), run by the shared control loop
//! (`pmsm_sensorless::control`: the step, then the 1 kHz task when due), against the host
//! simulator's plant (`pmsm-plant`, no_std, f64) as its power stage, running in the same
//! emulator: start from standstill to 1000 rpm, a
//! 0.1 N·m brake at 1.5 s, 2.5 s in all, once with each observer feeding the controller. Logs
//! with defmt over semihosting and exits 0 only if both runs meet their checks.
//!
//! `cargo emu` (alias in .cargo/config.toml) builds it and runs it under QEMU, decoding the
//! log with defmt-print (`.cargo/qemu-run.sh`, relative to the workspace root). `cargo emu-m0`
//! builds this same program for an emulated Cortex-M0 (`examples/qemu-m0`, QEMU `microbit`,
//! thumbv6m: no FPU, the f32 core in software floating point) with the same checks, and a
//! third run there (its feature `fixed-step`): the fixed-point step (issue #30) taking the
//! rotor over from the f32 drive 0.3 s into sensorless control, with the same checks.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!("qemu-m4f is firmware: run it with `cargo emu` (thumbv7em-none-eabihf under QEMU)");
}

#[cfg(target_os = "none")]
mod firmware {
    use cortex_m_rt::entry;
    use cortex_m_semihosting::debug::{self, EXIT_FAILURE, EXIT_SUCCESS};
    use defmt_semihosting as _;
    use panic_probe as _;
    use pmsm_plant::{Inverter, Plant, PlantParams, StiffBus};
    use pmsm_sensorless::control::{Commands, Control};
    use pmsm_sensorless::drive::{Drive, DriveConfig, DriveInput, Mode, Reason};
    use pmsm_sensorless::frames::Abc;
    use pmsm_sensorless::math::wrap_pi;
    use pmsm_sensorless::motor::HORNG_SINANO;
    use pmsm_sensorless::observer::Observer;
    use pmsm_sensorless::power_stage::PowerStage;
    use pmsm_sensorless::svpwm::Duties;

    const RATE_HZ: f32 = 4000.0;
    /// RK4 sub-steps of the plant per control period (25 µs at 4 kHz).
    const SUBSTEPS: usize = 10;
    const BUS_V: f64 = 48.0;
    const DURATION_S: f32 = 2.5;
    const SPEED_CMD_RPM: f32 = 1000.0;
    const BRAKE_NM: f64 = 0.1;
    const BRAKE_AT_S: f32 = 1.5;
    const WINDOW_S: (f32, f32) = (2.0, 2.5);
    use pmsm_sensorless::units::{DEG_PER_RAD, RAD_S_PER_RPM};

    /// The simulator's plant (`pmsm-plant`, host-sim's: the papers' motor in f64, RK4) with
    /// the Sinano motor of Horng & Chin's Table 1 behind an ideal inverter on a stiff 48 V
    /// bus; with every switch off, the inverter's diode bridge.
    struct Bench {
        plant: Plant,
        inverter: Inverter,
        /// The duties held over the coming period (`None`: all switches off).
        duties: Option<Duties>,
    }

    impl PowerStage for Bench {
        fn sample(&mut self) -> DriveInput {
            let i = self.plant.i_abc();
            DriveInput {
                i_abc: Abc::new(i[0] as f32, i[1] as f32, i[2] as f32),
                v_bus: BUS_V as f32,
                v_ab_terminal: None,
                overrun: false,
                stage_fault: None,
            }
        }

        fn apply(&mut self, duties: Option<Duties>) {
            self.duties = duties;
        }
    }

    impl Bench {
        /// One control period from `t` \[s] with the duties held, under a brake of
        /// [`BRAKE_NM`] from [`BRAKE_AT_S`] on (opposing the motion, fading below 30 rpm).
        fn advance(&mut self, t: f32) {
            let brake = if t >= BRAKE_AT_S { BRAKE_NM } else { 0.0 };
            let fade_rad_s = f64::from(30.0 * RAD_S_PER_RPM);
            let load = move |_: f64, omega_m: f64| brake * (omega_m / fade_rad_s).clamp(-1.0, 1.0);
            let h = 1.0 / (f64::from(RATE_HZ) * SUBSTEPS as f64);
            match self.duties {
                Some(d) => self
                    .plant
                    .advance(&self.inverter.hold(d), load, h, SUBSTEPS),
                None => self.plant.advance_off(load, h, SUBSTEPS),
            };
        }

        /// The rotor's speed [rpm, mechanical] and electrical angle [rad, in (−π, π]].
        fn rotor(&self) -> (f32, f32) {
            let s = &self.plant.state;
            let theta_e = libm::remainder(s.theta_e(&self.plant.params), core::f64::consts::TAU);
            ((s.omega_m as f32) / RAD_S_PER_RPM, theta_e as f32)
        }
    }

    /// `drive` on the Sinano motor, the rotor at rest 0.3 rad (electrical) from the align axis,
    /// and the run's command.
    fn at_rest<P: Observer, M: Observer>(drive: Drive<P, M>) -> (Control<P, M, Bench>, Commands) {
        let params = PlantParams::from(&HORNG_SINANO.params);
        let bench = Bench {
            plant: Plant::new(params, StiffBus { v_bus: BUS_V }, 0.3 / params.n, 0.0),
            inverter: Inverter {
                dead_time_s: 0.0,
                pwm_hz: 20_000.0,
            },
            duties: None,
        };
        let cmd = Commands {
            enable: true,
            speed_rpm: SPEED_CMD_RPM,
            ..Commands::default()
        };
        (Control::new(drive, bench), cmd)
    }

    /// One run of `drive` (`name` in the log) on the shared control loop (the step, then the
    /// 1 kHz task when due); returns whether it met its checks.
    fn run<P: Observer, M: Observer>(name: &str, drive: Drive<P, M>) -> bool {
        let (mut control, cmd) = at_rest(drive);
        let steps = (DURATION_S * RATE_HZ) as u32;
        let (mut n, mut speed_err, mut angle_err, mut handovers) = (0u32, 0.0f32, 0.0f32, 0u32);
        for k in 0..steps {
            let t = k as f32 / RATE_HZ;
            let (stepped, ticked) = control.run(&cmd);
            for tr in stepped.transition.into_iter().chain(ticked.transitions()) {
                defmt::info!("t = {=f32} s: {} -> {} ({})", t, tr.from, tr.to, tr.reason);
                if tr.reason == Reason::ResistanceRefused {
                    defmt::warn!(
                        "the start's resistance refused, the model's kept: {}",
                        control.state().resistance_refused()
                    );
                }
                if tr.to == Mode::Sensorless && tr.from != Mode::Sensorless {
                    handovers += 1;
                }
            }
            let tel = control.telemetry();
            if k % 2000 == 0 {
                defmt::info!("{}", tel);
            }
            let bench = control.stage_mut();
            if t >= WINDOW_S.0 && t < WINDOW_S.1 {
                let (speed_rpm, theta_e) = bench.rotor();
                n += 1;
                speed_err += speed_rpm - SPEED_CMD_RPM;
                angle_err += wrap_pi(tel.theta_e_primary - theta_e).abs();
            }
            bench.advance(t);
        }
        let st = control.state();
        let speed_err = speed_err / n.max(1) as f32;
        let angle_err_deg = angle_err / n.max(1) as f32 * DEG_PER_RAD;
        let ok = st.fault().is_none()
            && st.mode() == Mode::Sensorless
            && handovers == 1
            && (speed_err / SPEED_CMD_RPM).abs() < 0.01
            && angle_err_deg < 2.0;
        defmt::info!(
            "{=str}: fault {}, mean speed error {=f32} rpm, mean |angle error| {=f32} deg (e) in {=f32}..{=f32} s -> {}",
            name,
            st.fault(),
            speed_err,
            angle_err_deg,
            WINDOW_S.0,
            WINDOW_S.1,
            if ok { "PASS" } else { "FAIL" }
        );
        ok
    }

    /// The fixed-point step and task (`pmsm_sensorless::fixed::step`, issue #30) on the same
    /// bench: the f32 flux-primary drive starts the rotor (alignment, I/f, the hand-over) and,
    /// 0.3 s into sensorless control, the fixed-point drive takes it over (seeded at the f32
    /// drive's flux estimate, last voltage and adapted model) through the rest of the run,
    /// the brake included; the same checks as the f32 runs, and no fault of the fixed step.
    #[cfg(feature = "fixed-step")]
    fn run_fixed(cfg: &DriveConfig) -> bool {
        use pmsm_sensorless::fixed::pu::to_q15;
        use pmsm_sensorless::fixed::step::{FixedDrive, FixedInput};
        use pmsm_sensorless::fixed::svpwm::duty_f32;
        use pmsm_sensorless::fixed::AbcQ15;
        let (Ok(drive), Ok(nominal)) = (cfg.build_flux_primary(), FixedDrive::build(cfg)) else {
            defmt::error!("the fixed-point drive does not build");
            return false;
        };
        let (mut control, cmd) = at_rest(drive);
        let steps = (DURATION_S * RATE_HZ) as u32;
        let steps_per_tick = (RATE_HZ / 1000.0) as u32;
        let pu = *nominal.per_unit();
        let to_fixed = |i: Abc, v_bus: f32, bus_base: f32| FixedInput {
            i_abc: AbcQ15 {
                a: pu.current(i.a),
                b: pu.current(i.b),
                c: pu.current(i.c),
            },
            v_bus: to_q15(v_bus / bus_base),
        };
        let w_cmd = pu.speed(SPEED_CMD_RPM * RAD_S_PER_RPM * HORNG_SINANO.params.n());
        let mut fixed = None;
        let mut sensorless_since = None;
        let (mut n, mut speed_err, mut angle_err, mut fault) = (0u32, 0.0f32, 0.0f32, None);
        for k in 0..steps {
            let t = k as f32 / RATE_HZ;
            match &mut fixed {
                None => {
                    let (stepped, ticked) = control.run(&cmd);
                    let ticked_now = stepped.tick_due;
                    for tr in stepped.transition.into_iter().chain(ticked.transitions()) {
                        defmt::info!("t = {=f32} s: {} -> {} ({})", t, tr.from, tr.to, tr.reason);
                    }
                    let tel = control.telemetry();
                    if tel.mode == Mode::Sensorless {
                        sensorless_since.get_or_insert(t);
                    } else {
                        sensorless_since = None;
                    }
                    // The take-over at the next sample, 0.3 s into sensorless control, just
                    // after a task.
                    if sensorless_since.is_some_and(|s| t >= s + 0.3) && ticked_now {
                        let mut adapted = *cfg;
                        adapted.motor.r_ohm = tel.r_ohm;
                        adapted.motor.flux_wb = tel.flux_wb;
                        let Ok(f) = FixedDrive::build_in(&adapted, &pu) else {
                            defmt::error!(
                                "the fixed-point drive does not build on the adapted model"
                            );
                            return false;
                        };
                        let v_last = control.state().v_ab_applied();
                        let x_hat = control.state().primary().flux.x_hat;
                        control.stage_mut().advance(t);
                        let input = control.stage_mut().sample();
                        let fin = to_fixed(input.i_abc, input.v_bus, f.bus_base_v());
                        let omega_e = tel.speed_rpm * RAD_S_PER_RPM * HORNG_SINANO.params.n();
                        let st = f.seed(
                            fin.i_abc,
                            tel.theta_e_control,
                            omega_e,
                            tel.i_q,
                            v_last,
                            Some(x_hat),
                        );
                        defmt::info!("t = {=f32} s: the fixed-point step takes over", t);
                        fixed = Some((f, st, Some(fin), 0u32));
                        continue;
                    }
                }
                Some((f, st, pending, count)) => {
                    let fin = match pending.take() {
                        Some(x) => x,
                        None => {
                            let input = control.stage_mut().sample();
                            to_fixed(input.i_abc, input.v_bus, f.bus_base_v())
                        }
                    };
                    let out = f.step(st, &fin);
                    *count += 1;
                    if *count % steps_per_tick == 0 {
                        f.tick(st, w_cmd);
                    }
                    if fault.is_none() && st.fault.is_some() {
                        fault = st.fault;
                        defmt::error!(
                            "t = {=f32} s: the fixed-point step faulted: {}",
                            t,
                            st.fault
                        );
                    }
                    control.stage_mut().apply(out.duties.map(|d| Duties {
                        a: duty_f32(d.a),
                        b: duty_f32(d.b),
                        c: duty_f32(d.c),
                    }));
                    let bench = control.stage_mut();
                    if t >= WINDOW_S.0 && t < WINDOW_S.1 {
                        let (speed_rpm, theta_e) = bench.rotor();
                        n += 1;
                        speed_err += speed_rpm - SPEED_CMD_RPM;
                        angle_err += wrap_pi(st.theta_e() - theta_e).abs();
                    }
                    if k % 2000 == 0 {
                        let (speed_rpm, _) = bench.rotor();
                        defmt::info!(
                            "t = {=f32} s: fixed point: speed {=f32} rpm, i_q ref {=i16}, omega {=i16} (Q15)",
                            t,
                            speed_rpm,
                            st.i_ref.q,
                            st.omega
                        );
                    }
                }
            }
            control.stage_mut().advance(t);
        }
        let speed_err = speed_err / n.max(1) as f32;
        let angle_err_deg = angle_err / n.max(1) as f32 * DEG_PER_RAD;
        let ok = fixed.is_some()
            && fault.is_none()
            && n > 0
            && (speed_err / SPEED_CMD_RPM).abs() < 0.01
            && angle_err_deg < 2.0;
        defmt::info!(
            "Fixed (fixed-point step, flux primary, sliding monitor): fault {}, mean speed error {=f32} rpm, mean |angle error| {=f32} deg (e) in {=f32}..{=f32} s -> {}",
            fault,
            speed_err,
            angle_err_deg,
            WINDOW_S.0,
            WINDOW_S.1,
            if ok { "PASS" } else { "FAIL" }
        );
        ok
    }

    #[entry]
    fn main() -> ! {
        let mut cfg = DriveConfig::new(&HORNG_SINANO);
        // The plant's inverter is ideal: no dead time to compensate (compensating the board's
        // 500 ns on it makes the observers see 0.6 V that is not there, and the start-up
        // stalls).
        cfg.power_stage.dead_time_s = 0.0;
        let ok = match (cfg.build_sliding_primary(), cfg.build_flux_primary()) {
            (Ok(sliding), Ok(flux)) => {
                let ok = run("SlidingTorque", sliding) & run("Flux", flux);
                #[cfg(feature = "fixed-step")]
                let ok = ok & run_fixed(&cfg);
                ok
            }
            (Err(e), _) | (_, Err(e)) => {
                defmt::error!("configuration: {}", e.field());
                false
            }
        };
        debug::exit(if ok { EXIT_SUCCESS } else { EXIT_FAILURE });
        loop {
            cortex_m::asm::wfi();
        }
    }
}
