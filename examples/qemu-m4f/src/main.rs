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
//! thumbv6m: no FPU, the f32 core in software floating point) with the same checks.
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

    /// One run of `drive` (`name` in the log) on the shared control loop (the step, then the
    /// 1 kHz task when due); returns whether it met its checks.
    fn run<P: Observer, M: Observer>(name: &str, drive: Drive<P, M>) -> bool {
        // The rotor at rest, 0.3 rad (electrical) from the align axis.
        let params = PlantParams::from(&HORNG_SINANO.params);
        let bench = Bench {
            plant: Plant::new(params, StiffBus { v_bus: BUS_V }, 0.3 / params.n, 0.0),
            inverter: Inverter {
                dead_time_s: 0.0,
                pwm_hz: 20_000.0,
            },
            duties: None,
        };
        let mut control = Control::new(drive, bench);
        let cmd = Commands {
            enable: true,
            speed_rpm: SPEED_CMD_RPM,
            ..Commands::default()
        };
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

    #[entry]
    fn main() -> ! {
        let mut cfg = DriveConfig::new(&HORNG_SINANO);
        // The plant's inverter is ideal: no dead time to compensate (compensating the board's
        // 500 ns on it makes the observers see 0.6 V that is not there, and the start-up
        // stalls).
        cfg.power_stage.dead_time_s = 0.0;
        let ok = match (cfg.build_sliding_primary(), cfg.build_flux_primary()) {
            (Ok(sliding), Ok(flux)) => run("SlidingTorque", sliding) & run("Flux", flux),
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
