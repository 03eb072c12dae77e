//! Link-time proof that the drive's `step` cannot panic: this binary's panic handler calls a
//! function that exists nowhere, so the link fails if any panic path survives optimisation
//! anywhere in what it calls — `DriveConfig::build` and, in the loop, `Drive::step` on inputs
//! the compiler cannot see. Built in CI (`cargo build ... --bin no-panic`); never run.
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!("no-panic is a link-time check for thumbv7em-none-eabihf");
}

#[cfg(target_os = "none")]
mod firmware {
    use core::ptr::{addr_of, addr_of_mut};
    use cortex_m_rt::entry;
    use pmsm_sensorless::drive::{Command, DriveConfig, DriveInput, DriveState, Primary};
    use pmsm_sensorless::frames::Abc;
    use pmsm_sensorless::motor::HORNG_SINANO;

    extern "C" {
        /// Deliberately undefined: referenced only if a panic can happen.
        fn the_drive_step_can_panic() -> !;
    }

    #[panic_handler]
    fn panic(_: &core::panic::PanicInfo) -> ! {
        // SAFETY: never executed in a binary that links; its only purpose is to fail the link.
        unsafe { the_drive_step_can_panic() }
    }

    /// Inputs the compiler cannot know (written by a debugger, say).
    static mut INPUT: [f32; 6] = [0.0; 6];
    static mut DUTY_SUM: f32 = 0.0;

    #[entry]
    fn main() -> ! {
        let drive = match DriveConfig::new(&HORNG_SINANO, Primary::SlidingTorque).build() {
            Ok(d) => d,
            Err(_) => loop {
                cortex_m::asm::wfi();
            },
        };
        let mut st = DriveState::default();
        loop {
            // SAFETY: single-threaded, no interrupt touches these; volatile so nothing is
            // assumed about their values.
            let x = unsafe { core::ptr::read_volatile(addr_of!(INPUT)) };
            let input = DriveInput {
                i_abc: Abc::new(x[0], x[1], x[2]),
                v_bus: x[3],
                overrun: x[4] > 0.0,
            };
            let cmd = Command {
                enable: x[5] != 0.0,
                speed_rpm: x[5],
                clear_fault: x[4] < 0.0,
            };
            let out = drive.step(&mut st, &input, &cmd);
            let sum = out.duties.map_or(0.0, |d| d.a + d.b + d.c);
            // SAFETY: as above.
            unsafe { core::ptr::write_volatile(addr_of_mut!(DUTY_SUM), sum) };
        }
    }
}
