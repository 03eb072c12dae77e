//! Link-time proof that the drive cannot panic: this binary's panic handler calls a function
//! that exists nowhere, so the link fails if any panic path survives optimisation anywhere in
//! what it calls. Every pairing of the core's observers as primary and monitor is built from
//! parameters, and stepped with samples and commands, that the compiler cannot know: each
//! value is read from memory a debugger could write, so no branch of the step can be proved
//! unreachable and folded away. Built in CI (`cargo build ... --bin no-panic`); never run.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!("no-panic is a link-time check for thumbv7em-none-eabihf");
}

#[cfg(target_os = "none")]
mod firmware {
    use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};
    use cortex_m_rt::entry;
    use pmsm_sensorless::control::{Commands, Control, TickCopy};
    use pmsm_sensorless::drive::{Drive, DriveConfig, DriveInput, StateOf};
    use pmsm_sensorless::frames::{Abc, AlphaBeta};
    use pmsm_sensorless::motor::{Motor, MotorParams, Ratings, TorqueConvention};
    use pmsm_sensorless::observer::flux_speed::FluxIi;
    use pmsm_sensorless::observer::ii::IiConfig;
    use pmsm_sensorless::observer::{Observer, Rotor};
    use pmsm_sensorless::power_stage::{PowerStage, StageFault};
    use pmsm_sensorless::svpwm::Duties;

    extern "C" {
        /// Deliberately undefined: referenced only if a panic can happen.
        fn the_drive_step_can_panic() -> !;
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        // SAFETY: never executed in a binary that links; its only purpose is to fail the link.
        unsafe { the_drive_step_can_panic() }
    }

    /// Values the compiler cannot know (written by a debugger, say): the motor and its
    /// ratings, then the samples and the command.
    static mut MOTOR: [f32; 12] = [0.0; 12];
    static mut POLE_PAIRS: u32 = 0;
    static mut SAMPLE: [f32; 6] = [0.0; 6];
    static mut SPEED_RPM: f32 = 0.0;
    static mut FLAGS: [bool; 4] = [false; 4];
    static mut RECORD_EVERY: u32 = 0;
    static mut SINK: f32 = 0.0;

    /// Reads a value through a volatile load.
    fn unknown<T: Copy>(p: *const T) -> T {
        // SAFETY: single-threaded, no interrupt touches these statics; volatile so nothing is
        // assumed about their values.
        unsafe { read_volatile(p) }
    }

    /// Keeps `x` alive.
    fn sink(x: f32) {
        // SAFETY: as above.
        unsafe { write_volatile(addr_of_mut!(SINK), x) };
    }

    /// A drive configuration from unknown parameters.
    fn config() -> DriveConfig {
        let x = unknown(addr_of!(MOTOR));
        let motor = Motor {
            name: "unknown",
            params: MotorParams {
                pole_pairs: unknown(addr_of!(POLE_PAIRS)),
                r_ohm: x[0],
                l_h: x[1],
                flux_wb: x[2],
                j_kgm2: x[3],
                b_nms: x[4],
                saliency: x[11],
                torque: TorqueConvention::ThreePhase,
            },
            ratings: Ratings {
                bus_v: x[5],
                current_a: x[6],
                torque_nm: x[7],
                speed_rpm: x[8],
                power_w: x[9],
            },
        };
        let mut cfg = DriveConfig::new(&motor);
        cfg.rate_hz = x[10];
        cfg
    }

    /// The flux observer with the I&I speed and load observer, run at the speed loop's rate.
    fn flux_ii(cfg: &DriveConfig) -> Option<FluxIi> {
        let fp = cfg.flux_pll().ok()?;
        let ii = IiConfig::new(cfg.motor, cfg.rate_hz / 4.0).build().ok()?;
        Some(FluxIi::new(fp.flux, ii, cfg.motor.torque_constant()))
    }

    /// A power stage whose samples are unknown and whose duties are kept alive.
    struct Unknown;

    impl PowerStage for Unknown {
        fn sample(&mut self) -> DriveInput {
            let x = unknown(addr_of!(SAMPLE));
            let flags = unknown(addr_of!(FLAGS));
            DriveInput {
                i_abc: Abc::new(x[0], x[1], x[2]),
                v_bus: x[3],
                v_ab_terminal: flags[3].then_some(AlphaBeta::new(x[4], x[5])),
                overrun: flags[0],
                stage_fault: flags[2].then_some(StageFault::HardwareOvercurrent),
            }
        }

        fn apply(&mut self, duties: Option<Duties>) {
            sink(duties.map_or(0.0, |d| d.a + d.b + d.c));
        }
    }

    /// Builds the drive of `primary` and `monitor` and runs the shared control loop on unknown
    /// samples and commands (its step, its 1 kHz task in place and on a copy), from a state
    /// that is either idle or sensorless at an unknown rotor state; its telemetry too.
    fn exercise<P: Observer, M: Observer>(cfg: &DriveConfig, primary: P, monitor: M)
    where
        Drive<P, M>: Clone,
    {
        let Ok(drive): Result<Drive<P, M>, _> = cfg.build(primary, monitor) else {
            return;
        };
        let x = unknown(addr_of!(SAMPLE));
        let flags = unknown(addr_of!(FLAGS));
        let speed_rpm = unknown(addr_of!(SPEED_RPM));
        let st = if flags[0] {
            let rotor = Rotor {
                theta_e: x[0],
                omega_m: speed_rpm,
                load_nm: x[3],
            };
            drive.running_state(AlphaBeta::new(x[1], x[2]), rotor)
        } else {
            StateOf::<P, M>::default()
        };
        let mut control = Control::new(drive, Unknown)
            .with_state(st)
            .with_telemetry_every(unknown(addr_of!(RECORD_EVERY)));
        let mut copy = TickCopy::new(&control);
        loop {
            let flags = unknown(addr_of!(FLAGS));
            let cmd = Commands {
                enable: flags[1],
                speed_rpm: unknown(addr_of!(SPEED_RPM)),
                clear_fault: flags[2],
                // The identification (issue #19), started whenever the unknown flags ask.
                identify: flags[0] && flags[3],
            };
            let stepped = control.step(&cmd);
            sink(stepped.record.map_or(0.0, |r| r.telemetry.speed_rpm));
            // The 1 kHz task, whenever the unknown flag asks (any state it can see), in place
            // or on a copy.
            if flags[3] || stepped.tick_due {
                let ticked = if flags[1] {
                    control.tick(&cmd)
                } else {
                    copy.take(&control);
                    let ticked = copy.tick(&cmd);
                    copy.background();
                    sink(if copy.give(&mut control) { 1.0 } else { 0.0 });
                    ticked
                };
                sink(ticked.transitions().count() as f32);
                sink(ticked.identified.map_or(0.0, |m| m.r_ohm));
            }
            // The task's slower work, whenever the unknown flag asks.
            if flags[0] {
                control.background();
            }
            sink(control.telemetry().speed_rpm);
            if flags[2] && flags[1] {
                break;
            }
        }
    }

    #[entry]
    fn main() -> ! {
        let cfg = config();
        let sliding = cfg.sliding_torque();
        let flux = cfg.flux_pll();
        let ii = flux_ii(&cfg);
        if let (Ok(s), Ok(f), Some(i)) = (sliding, flux, ii) {
            // Every ordered pairing of the three observers (the sliding velocity and torque
            // observers are one type).
            exercise(&cfg, s, f);
            exercise(&cfg, f, s);
            exercise(&cfg, i, s);
            exercise(&cfg, s, i);
            exercise(&cfg, f, i);
            exercise(&cfg, i, f);
            exercise(&cfg, s, s);
            exercise(&cfg, f, f);
            exercise(&cfg, i, i);
        }
        loop {
            cortex_m::asm::wfi();
        }
    }
}
