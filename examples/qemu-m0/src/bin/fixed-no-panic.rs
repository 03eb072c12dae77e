//! Link-time proof that the fixed-point step cannot panic on the Cortex-M0 (issue #30), as
//! `examples/qemu-m4f/src/bin/no-panic.rs` proves it for the f32 drive on the M4F: this
//! binary's panic handler calls a function that exists nowhere, so the link fails if any panic
//! path survives optimisation in what it calls. The fixed-point drive is built from a motor,
//! and seeded, stepped and tasked with samples and commands, that the compiler cannot know
//! (each value read from memory a debugger could write). Built in CI (`cargo build ... --bin
//! fixed-no-panic --target thumbv6m-none-eabi`); never run.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!("fixed-no-panic is a link-time check for thumbv6m-none-eabi");
}

#[cfg(target_os = "none")]
mod firmware {
    use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};
    use cortex_m_rt::entry;
    use pmsm_sensorless::drive::DriveConfig;
    use pmsm_sensorless::fixed::pu::PerUnit;
    use pmsm_sensorless::fixed::step::{FixedDrive, FixedInput};
    use pmsm_sensorless::fixed::AbcQ15;
    use pmsm_sensorless::frames::AlphaBeta;
    use pmsm_sensorless::motor::{Motor, MotorParams, Ratings, TorqueConvention};

    extern "C" {
        /// Deliberately undefined: referenced only if a panic can happen.
        fn the_fixed_step_can_panic() -> !;
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        // SAFETY: never executed in a binary that links; its only purpose is to fail the link.
        unsafe { the_fixed_step_can_panic() }
    }

    /// Values the compiler cannot know: the motor and its ratings, the seed, the samples and
    /// the command.
    static mut MOTOR: [f32; 12] = [0.0; 12];
    static mut POLE_PAIRS: u32 = 0;
    static mut SEED: [f32; 7] = [0.0; 7];
    static mut SAMPLE: [i16; 5] = [0; 5];
    static mut FLAGS: [bool; 4] = [false; 4];
    static mut SINK: i32 = 0;

    /// Reads a value through a volatile load.
    fn unknown<T: Copy>(p: *const T) -> T {
        // SAFETY: single-threaded, no interrupt touches these statics; volatile so nothing is
        // assumed about their values.
        unsafe { read_volatile(p) }
    }

    /// Keeps `x` alive.
    fn sink(x: i32) {
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

    /// The fixed-point drive built each way (its own bases; given bases, an adapted model;
    /// the PLL in the step), seeded at an unknown rotor and run on unknown samples.
    fn exercise(cfg: &DriveConfig) {
        let flags = unknown(addr_of!(FLAGS));
        let built = if flags[0] {
            FixedDrive::build(cfg)
        } else if flags[1] {
            PerUnit::of_drive(cfg).and_then(|pu| FixedDrive::build_in(cfg, &pu))
        } else {
            FixedDrive::build_pll_in_step(cfg)
        };
        let Ok(fixed) = built else {
            return;
        };
        let seed = || {
            let s = unknown(addr_of!(SEED));
            let i = unknown(addr_of!(SAMPLE));
            let flags = unknown(addr_of!(FLAGS));
            fixed.seed(
                AbcQ15 {
                    a: i[0],
                    b: i[1],
                    c: i[2],
                },
                s[0],
                s[1],
                s[2],
                AlphaBeta::new(s[3], s[4]),
                flags[2].then_some(AlphaBeta::new(s[5], s[6])),
            )
        };
        let mut st = seed();
        loop {
            let i = unknown(addr_of!(SAMPLE));
            let flags = unknown(addr_of!(FLAGS));
            let input = FixedInput {
                i_abc: AbcQ15 {
                    a: i[0],
                    b: i[1],
                    c: i[2],
                },
                v_bus: i[3],
            };
            let out = fixed.step(&mut st, &input);
            sink(
                out.duties
                    .map_or(-1, |d| i32::from(d.a) + i32::from(d.b) + i32::from(d.c)),
            );
            if flags[3] {
                sink(fixed.tick(&mut st, i[4]).map_or(0, |_| 1));
            }
            if flags[0] && flags[1] {
                st = seed();
            }
            if flags[2] && flags[1] {
                break;
            }
        }
    }

    #[entry]
    fn main() -> ! {
        exercise(&config());
        loop {
            cortex_m::asm::wfi();
        }
    }
}
