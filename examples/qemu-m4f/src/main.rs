//! The drive on an emulated Cortex-M4F (QEMU `mps2-an386`), run by the shared control loop
//! (`pmsm_sensorless::control`: the step, then the 1 kHz task when due), against an f32 plant
//! model (its power stage) running in the same emulator: start from standstill to 1000 rpm, a
//! 0.1 N·m brake at 1.5 s, 2.5 s in all, once with each observer feeding the controller. Logs
//! with defmt over semihosting and exits 0 only if both runs meet their checks.
//!
//! `cargo emu` (alias in .cargo/config.toml) builds it and runs it under QEMU, decoding the
//! log with defmt-print (`.cargo/qemu-run.sh`, relative to the workspace root).
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
    use pmsm_sensorless::control::{Commands, Control};
    use pmsm_sensorless::drive::{Drive, DriveConfig, DriveInput, Mode};
    use pmsm_sensorless::frames::{Abc, AlphaBeta};
    use pmsm_sensorless::math::{sin_cos, wrap_pi};
    use pmsm_sensorless::motor::HORNG_SINANO;
    use pmsm_sensorless::observer::Observer;
    use pmsm_sensorless::power_stage::PowerStage;
    use pmsm_sensorless::svpwm::Duties;

    const RATE_HZ: f32 = 4000.0;
    const SUBSTEPS: usize = 10;
    const BUS_V: f32 = 48.0;
    const DURATION_S: f32 = 2.5;
    const SPEED_CMD_RPM: f32 = 1000.0;
    const BRAKE_NM: f32 = 0.1;
    const BRAKE_AT_S: f32 = 1.5;
    const WINDOW_S: (f32, f32) = (2.0, 2.5);
    use pmsm_sensorless::units::{DEG_PER_RAD, RAD_S_PER_RPM};

    /// The Sinano motor of Horng & Chin's Table 1 (eqs (16)-(19)), f32, θ electrical, behind
    /// an ideal inverter on a 48 V bus.
    struct Plant {
        i_ab: AlphaBeta,
        theta_e: f32,
        omega_m: f32,
        /// The duties held over the coming period (`None`: all switches off).
        duties: Option<Duties>,
    }

    impl PowerStage for Plant {
        fn sample(&mut self) -> DriveInput {
            DriveInput {
                i_abc: self.i_ab.to_abc(),
                v_bus: BUS_V,
                v_ab_terminal: None,
                overrun: false,
            }
        }

        fn apply(&mut self, duties: Option<Duties>) {
            self.duties = duties;
        }
    }

    impl Plant {
        /// Brake torque: opposes the motion, fading below 30 rpm.
        fn load(&self, t: f32) -> f32 {
            if t < BRAKE_AT_S {
                return 0.0;
            }
            let x = self.omega_m / (30.0 * RAD_S_PER_RPM);
            BRAKE_NM * x.clamp(-1.0, 1.0)
        }

        /// d/dt of (i_α, i_β, θ_e, ω_m) for the stator voltage `v` (None: open circuit).
        fn derivative(
            &self,
            i: AlphaBeta,
            theta_e: f32,
            omega: f32,
            v: Option<AlphaBeta>,
            tau_l: f32,
        ) -> [f32; 4] {
            let p = HORNG_SINANO.params;
            let kn = p.flux_wb * p.n();
            let (s, c) = sin_cos(theta_e);
            let e = AlphaBeta::new(kn * omega * s, -kn * omega * c);
            let v = v.unwrap_or(AlphaBeta::new(-e.alpha, -e.beta));
            [
                (-p.r_ohm * i.alpha + e.alpha + v.alpha) / p.l_h,
                (-p.r_ohm * i.beta + e.beta + v.beta) / p.l_h,
                p.n() * omega,
                (kn * (i.beta * c - i.alpha * s) - p.b_nms * omega - tau_l) / p.j_kgm2,
            ]
        }

        /// One control period with the duties held (midpoint rule on `SUBSTEPS` sub-steps).
        fn advance(&mut self, t: f32) {
            let v = self
                .duties
                .map(|d| Abc::new(d.a * BUS_V, d.b * BUS_V, d.c * BUS_V).to_alpha_beta());
            if v.is_none() {
                self.i_ab = AlphaBeta::default();
            }
            let h = 1.0 / (RATE_HZ * SUBSTEPS as f32);
            let tau = self.load(t);
            for _ in 0..SUBSTEPS {
                let k1 = self.derivative(self.i_ab, self.theta_e, self.omega_m, v, tau);
                let mid = AlphaBeta::new(
                    self.i_ab.alpha + 0.5 * h * k1[0],
                    self.i_ab.beta + 0.5 * h * k1[1],
                );
                let k2 = self.derivative(
                    mid,
                    self.theta_e + 0.5 * h * k1[2],
                    self.omega_m + 0.5 * h * k1[3],
                    v,
                    tau,
                );
                self.i_ab = AlphaBeta::new(self.i_ab.alpha + h * k2[0], self.i_ab.beta + h * k2[1]);
                self.theta_e = wrap_pi(self.theta_e + h * k2[2]);
                self.omega_m += h * k2[3];
            }
        }
    }

    /// One run of `drive` (`name` in the log) on the shared control loop (the step, then the
    /// 1 kHz task when due); returns whether it met its checks.
    fn run<P: Observer, M: Observer>(name: &str, drive: Drive<P, M>) -> bool {
        let plant = Plant {
            i_ab: AlphaBeta::default(),
            theta_e: 0.3,
            omega_m: 0.0,
            duties: None,
        };
        let mut control = Control::new(drive, plant);
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
                if tr.to == Mode::Sensorless && tr.from != Mode::Sensorless {
                    handovers += 1;
                }
            }
            let tel = control.telemetry();
            if k % 2000 == 0 {
                defmt::info!("{}", tel);
            }
            let plant = control.stage_mut();
            if t >= WINDOW_S.0 && t < WINDOW_S.1 {
                n += 1;
                speed_err += plant.omega_m / RAD_S_PER_RPM - SPEED_CMD_RPM;
                angle_err += wrap_pi(tel.theta_e_primary - plant.theta_e).abs();
            }
            plant.advance(t);
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
