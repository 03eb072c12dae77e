//! Per-call instruction counts on the emulated Cortex-M4F: each measured call sits between
//! a `bench_begin_<name>()` and a `bench_end_<name>()` marker; `pmsm-sim cycles` runs this under QEMU with
//! `-d exec,nochain -singlestep` (one trace line per executed instruction) and counts the
//! instructions between the markers, weighting them with the Cortex-M4 timing table.
//!
//! The drive is put straight into a sensorless state at 1000 rpm on the Sinano motor (the
//! state's fields are public), so the measured `step` takes the sensorless branch with both
//! observers live; it is measured on a step with the speed loop (every 4th) and without.
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
    use pmsm_sensorless::drive::{Command, DriveConfig, DriveInput, DriveState, Mode, Primary};
    use pmsm_sensorless::foc::{CurrentLoopState, FocConfig, FocInput};
    use pmsm_sensorless::frames::{AlphaBeta, Dq};
    use pmsm_sensorless::motor::HORNG_SINANO;
    use pmsm_sensorless::observer::flux::{FluxConfig, FluxState};
    use pmsm_sensorless::observer::pll::{PllConfig, PllState};
    use pmsm_sensorless::observer::sliding::{SlidingConfig, SlidingState};

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
        bench_begin_step_speed_loop, bench_end_step_speed_loop, 1u32;
        bench_begin_step, bench_end_step, 2u32;
        bench_begin_sliding, bench_end_sliding, 3u32;
        bench_begin_flux_pll, bench_end_flux_pll, 4u32;
        bench_begin_foc_svpwm, bench_end_foc_svpwm, 5u32;
        bench_begin_step_flux_primary, bench_end_step_flux_primary, 6u32;
    }

    /// Plausible samples at 1000 rpm (θ_e advancing 0.1047 rad per step), small load.
    fn sample(k: u32) -> (f32, AlphaBeta) {
        let theta = 0.3 + 0.10472 * k as f32;
        let (s, c) = pmsm_sensorless::math::sin_cos(theta);
        (theta, AlphaBeta::new(-0.5 * s, 0.5 * c))
    }

    #[entry]
    fn main() -> ! {
        let m = HORNG_SINANO;
        let rate = 4000.0;
        let drive = DriveConfig::new(&m, Primary::SlidingTorque).build().ok();
        let drive_flux = DriveConfig::new(&m, Primary::Flux).build().ok();
        let sliding = SlidingConfig::torque(m.params).build().ok();
        let flux = FluxConfig::new(m.params, rate, 60.0).build().ok();
        let pll = PllConfig {
            rate_hz: rate,
            bandwidth_hz: 50.0,
            damping: 1.0,
        }
        .build()
        .ok();
        let foc = FocConfig::new(m.params, 4.5).build().ok();
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
        // A drive already sensorless at 1000 rpm, and its input at step k.
        let sensorless = || {
            let mut st = DriveState {
                mode: Mode::Sensorless,
                speed_ref_rpm: 1000.0,
                ..DriveState::default()
            };
            sliding.reset(&mut st.sliding, i0, theta0, omega_m);
            flux.reset(&mut st.flux, i0, theta0);
            pll.reset(&mut st.pll, theta0, 4.0 * omega_m);
            st
        };
        let input = |k| DriveInput {
            i_abc: sample(k).1.to_abc(),
            v_bus: 48.0,
            overrun: false,
        };
        let mut st = sensorless();
        let cmd = Command {
            enable: true,
            speed_rpm: 1000.0,
            clear_fault: false,
        };
        for k in 1..6u32 {
            let input = input(k);
            let with_speed_loop = st.foc.tick == 0;
            if with_speed_loop {
                bench_begin_step_speed_loop();
            } else {
                bench_begin_step();
            }
            // The output is written in place (returned through a pointer); `black_box` of a
            // reference keeps it without the copy a `black_box` by value would add.
            let out = drive.step(&mut st, black_box(&input), black_box(&cmd));
            black_box(&out);
            if with_speed_loop {
                bench_end_step_speed_loop();
            } else {
                bench_end_step();
            }
            defmt::info!(
                "step {}: mode {}, duties {}",
                k,
                st.mode,
                out.duties.is_some()
            );
        }
        // The same with the flux observer feeding the controller (its angle's sin/cos and the
        // output angle computed in the step, the sliding observer as the monitor): the step
        // with the speed loop.
        let mut st = sensorless();
        for k in 1..6u32 {
            let input = input(k);
            let with_speed_loop = st.foc.tick == 0;
            if with_speed_loop {
                bench_begin_step_flux_primary();
            }
            let out = drive_flux.step(&mut st, black_box(&input), black_box(&cmd));
            black_box(&out);
            if with_speed_loop {
                bench_end_step_flux_primary();
            }
            defmt::info!("flux primary step {}: mode {}", k, st.mode);
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
            black_box(sliding.update(&mut s_state, black_box(i), black_box(v)));
            bench_end_sliding();
            bench_begin_flux_pll();
            black_box(flux.update(&mut f_state, black_box(i), black_box(v)));
            black_box(pll.update(&mut p_state, f_state.theta_e));
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
            black_box(foc.current_step(
                &mut c_state,
                black_box(&input),
                black_box(Dq::new(0.0, 0.5)),
            ));
            bench_end_foc_svpwm();
        }
        debug::exit(EXIT_SUCCESS);
        loop {
            cortex_m::asm::wfi();
        }
    }
}
