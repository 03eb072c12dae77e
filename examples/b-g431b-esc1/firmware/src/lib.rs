//! Firmware for ST's B-G431B-ESC1 Discovery kit (STM32G431CBU6, Cortex-M4F at 170 MHz):
//! the drive's `Drive::step` at 4 kHz on the board's three half-bridges.
//!
//! Build and flash (runner `probe-rs run --chip STM32G431CBUx` in the repository's
//! `.cargo/config.toml`; aliases there), from the repository root:
//!
//! ```text
//! cargo fw            # build --release --manifest-path examples/b-g431b-esc1/image/Cargo.toml --target thumbv7em-none-eabihf
//! cargo flash-esc1    # the same with `run`: flash with probe-rs, print the defmt log
//! ```
//!
//! # Use
//!
//! The motor is the constant `drive_settings::MOTOR` of the library (`src/lib.rs`; edit it
//! for yours), the speed command the constant `drive_settings::SPEED_CMD_RPM`. The user button toggles `enable` (on its release);
//! pressed while the drive is in `Fault` it clears the fault and leaves the drive disabled
//! (press again to restart); held 2 s with the drive disabled, it starts the identification
//! (issue #19), whose end prints the motor file in the log.
//! The servo-PWM input (PA15, TIM2: `servo`, `servo_capture`; 1–2 ms pulses at 50–490 Hz)
//! commands the speed, one direction, 2 ms = the rated speed, once it has seen 50 pulses at
//! zero throttle; losing it (100 ms without a valid pulse) disables the drive, and it re-arms
//! only at zero again. Without a signal the button and the constant command are as before.
//! The LED (PC6) is lit while the servo input is armed and blinks in `Fault`.
//! The link firmware (feature `link`, `cargo fw-link`, `link.rs`) has no motor compiled in:
//! the speed command starts at 0 and the link sets it (the servo while armed, full throttle
//! the rated speed of the settings in force); the button and the servo refuse to enable
//! while no drive is loaded.
//! The log (defmt over RTT) shows every mode transition and a telemetry record at 10 Hz.
//!
//! # Modules
//!
//! The board's library (`../src/lib.rs`, host-tested): `config` computes every clock, timer, ADC and
//! watchdog value from one configuration and what the drive is told (PWM frequency, dead
//! time, control rate, largest duty); `drive_settings` holds the motor, the observers and
//! the speed command; its init functions write those values (run on zeroed register blocks
//! in its tests): `clocks` (170 MHz, peripheral clocks), `pwm` (TIM1: timing, dead time,
//! duties), `adc` (OPAMPs, ADCs, offsets, scaling, the phase-voltage dividers),
//! `overcurrent` (DAC3, COMP1/2/4), `watchdog` (IWDG, debug halt). The interrupt path
//! (`../control`, a package compiled for speed): `power_stage` (the core's `PowerStage` on
//! TIM1 and the ADCs), `control` (the core's shared control loop on this board: the step's
//! interrupt, the 1 kHz task's interrupt below it, the commands), `protection` (watchdog,
//! HardFault, debug halt, the board's bus limit), `telemetry` (the interrupts → main-loop
//! queues and the defmt log). This crate (compiled for size): `settings` (the drive built
//! from the library's configuration), `link` (feature `link`: the board as the link's device)
//! and this file, start-up and the main loop (the button, the servo input, the link, the log),
//! which the image (`../image`, the binary) runs.
//!
//! # Hardware map
//!
//! References: UM2516 (B-G431B-ESC1 user manual), RM0440 (STM32G4 reference manual),
//! DS12589 (STM32G431xx datasheet). The pin assignment below is the one published by the
//! board's NuttX port (`boards/arm/stm32/b-g431b-esc1`, which follows UM2516's pin table) and
//! by ST's stm32duino variant for this board; the alternate-function numbers are the
//! datasheet's (DS12589 alternate-function table, as generated into stm32duino's
//! `PeripheralPins.c` for STM32G431CBUx). UM2516 itself was not at hand when this was
//! written, so the board-level facts marked "UNVERIFIED" must be checked against its
//! schematic. Nor was RM0440: §6.1.5 and §7.2.7 are the sections named for the clock switch,
//! the chapter numbers (§21 ADC, §25 OPAMP, §28 TIM1/TIM8/TIM20) are Rev 8's from memory,
//! and subsections are cited by title; check them against your copy.
//!
//! | Function (UM2516)        | Pin  | Peripheral                                  |
//! |--------------------------|------|---------------------------------------------|
//! | Phase U high / low side  | PA8 / PC13 | TIM1_CH1 (AF6) / TIM1_CH1N (AF4)      |
//! | Phase V high / low side  | PA9 / PA12 | TIM1_CH2 (AF6) / TIM1_CH2N (AF6)      |
//! | Phase W high / low side  | PA10 / PB15 | TIM1_CH3 (AF6) / TIM1_CH3N (AF4)     |
//! | Shunt U (+ / −), output  | PA1 / PA3, PA2 | OPAMP1 VINP0 / VINM0, VOUT = ADC1_IN3 |
//! | Shunt V (+ / −), output  | PA7 / PA5, PA6 | OPAMP2 VINP0 / VINM0, VOUT = ADC2_IN3 |
//! | Shunt W (+ / −), output  | PB0 / PB2, PB1 | OPAMP3 VINP0 / VINM0, VOUT = ADC1_IN12 |
//! | Bus voltage divider      | PA0  | ADC1_IN1                                    |
//! | Phase voltages U, V, W (BEMF1..3) | PA4, PC4, PB11 | ADC2_IN17, ADC2_IN5, ADC2_IN14 |
//! | GPIO_BEMF (dividers on when low) | PB5 | GPIO output, low                  |
//! | User button              | PC10 | GPIO input                                  |
//! | User LED (inferred active high) | PC6 | GPIO output                         |
//! | PWM (servo) input (stm32duino's variant) | PA15 | TIM2_CH1 (AF1), PWM-input capture |
//!
//! Timing: TIM1 centre-aligned at 20 kHz, the repetition counter makes one update event
//! (UEV) every 5 PWM periods = 4 kHz, at the counter peak where all low-side switches
//! conduct (should the silicon put the UEV on the valley instead, start-up detects it and
//! switches to PWM mode 2, which puts the low-side interval there). TRGO = UEV starts the
//! injected conversions of ADC1 (U, W, bus) and ADC2 (V) at that instant; ADC1's
//! end-of-injected-sequence interrupt runs the drive step and writes CCR1..3; every fourth step
//! pends the drive's 1 kHz task, which runs in SPI3's (unused) vector at a lower priority
//! (`control`). PWM outputs stay off (MOE = 0) until the drive returns duties, and MOE is
//! cleared in the same step in which it returns `None`.
//!
//! Safety nets: see `protection` (the software trip on every sample, the hardware trip into
//! BRK2; watchdog fed by the control interrupt when the main loop and the 1 kHz task have
//! run; MOE cleared on HardFault, NMI, panic and any unexpected interrupt; outputs inactive
//! on debug halt).
#![no_std]

#[cfg(all(target_os = "none", feature = "link"))]
mod link;
#[cfg(all(target_os = "none", not(feature = "link")))]
mod settings;

#[cfg(target_os = "none")]
pub use firmware::run;

#[cfg(target_os = "none")]
mod firmware {
    use core::sync::atomic::Ordering;

    use stm32g4::stm32g431 as pac;

    #[cfg(feature = "link")]
    use crate::link::{self, Board};
    use pmsm_b_g431b_esc1::board_io::{self, Button, ButtonAction, GpioIn, GpioOut, StatusLed};
    use pmsm_b_g431b_esc1::config::SETTINGS;
    use pmsm_b_g431b_esc1::drive_settings::BoardDrive;
    #[cfg(not(feature = "link"))]
    use pmsm_b_g431b_esc1::drive_settings::{drive_config, MOTOR, SPEED_CMD_RPM};
    #[cfg(feature = "link")]
    use pmsm_b_g431b_esc1::flash::ConfigFlash;
    use pmsm_b_g431b_esc1::hw::{Hw, InitError, Wait};
    use pmsm_b_g431b_esc1::ntc::NtcConfig;
    use pmsm_b_g431b_esc1::servo::{PulseCapture, ServoConfig, ServoDecoder, ServoOutput};
    use pmsm_b_g431b_esc1::servo_capture::{self, ServoCapture};
    #[cfg(feature = "link")]
    use pmsm_b_g431b_esc1::usart::{self, Usart};
    use pmsm_b_g431b_esc1::{adc, clocks, overcurrent, pwm, watchdog};
    use pmsm_b_g431b_esc1_control::control::{
        self, Control, Tick, CLEAR_FAULT, ENABLE, IDENTIFY, SPEED_CMD, SPEED_RPM, STAGE_TEMP_C,
        STEPS, TICK_RETRIES,
    };
    use pmsm_b_g431b_esc1_control::power_stage::Esc1;
    use pmsm_b_g431b_esc1_control::protection::MAIN_ALIVE;
    use pmsm_b_g431b_esc1_control::{protection, telemetry};
    #[cfg(feature = "link")]
    use pmsm_link::Server;

    /// The CPU's part of the init functions: busy-waits of the core clock; the polls spin
    /// on the peripherals' own flags.
    struct Cpu;

    impl Hw for Cpu {
        fn delay_cycles(&mut self, cycles: u32) {
            cortex_m::asm::delay(cycles);
        }

        fn poll(&mut self, _what: Wait) {}
    }

    /// Whether the button may enable the drive: with the link, the control interrupts
    /// started with the settings in force (none: no drive); without, the compiled-in one.
    fn drive_ready(#[cfg(feature = "link")] board: &mut Board) -> bool {
        #[cfg(feature = "link")]
        return board.start_drive();
        #[cfg(not(feature = "link"))]
        return true;
    }

    /// With the link: the servo input's full throttle, the rated speed of the settings in
    /// force (none: the servo commands no speed), its slew set to their start acceleration
    /// (per unit of throttle: accel_rpm_per_s / full_rpm).
    #[cfg(feature = "link")]
    fn servo_scale(board: &Board, servo: &mut ServoDecoder) -> Option<f32> {
        let s = pmsm_link::Device::settings(board)?;
        let full_rpm = s.motor().ratings.speed_rpm;
        if full_rpm <= 0.0 {
            return None;
        }
        servo.set_slew_per_s(s.drive_config().start.accel_rpm_per_s / full_rpm);
        Some(full_rpm)
    }

    /// The value of an init function, or the firmware stops with what failed in the log (its
    /// text in defmt's table, not in flash).
    fn ok<T>(r: Result<T, InitError>) -> T {
        let e = match r {
            Ok(v) => return v,
            Err(e) => e,
        };
        match e {
            InitError::Timeout(Wait::FlashLatency) => {
                defmt::panic!("start-up: flash latency not taken")
            }
            InitError::Timeout(Wait::HseReady) => defmt::panic!("start-up: HSE not ready"),
            InitError::Timeout(Wait::PllReady) => defmt::panic!("start-up: PLL not locked"),
            InitError::Timeout(Wait::SysclkPll) => {
                defmt::panic!("start-up: SYSCLK not switched to the PLL")
            }
            InitError::Timeout(Wait::Tim1Update) => {
                defmt::panic!("start-up: TIM1 produces no update event")
            }
            InitError::Timeout(Wait::AdcCalibrated) => {
                defmt::panic!("start-up: ADC calibration did not end")
            }
            InitError::Timeout(Wait::AdcReady) => defmt::panic!("start-up: ADC not ready"),
            InitError::Timeout(Wait::AdcRegularEnd) => {
                defmt::panic!("start-up: no regular conversion")
            }
            InitError::Timeout(Wait::AdcInjectedEnd) => {
                defmt::panic!("start-up: no injected conversion: check TIM1 TRGO / ADC setup")
            }
            InitError::Timeout(Wait::IwdgUpdated) => {
                defmt::panic!("start-up: IWDG registers not updated")
            }
            InitError::CurrentOffset(lsb) => defmt::panic!(
                "start-up: current-sense offset outside the plausible window: check the amplifiers: {=f32} LSB",
                lsb
            ),
            InitError::ComparatorHigh(phase) => defmt::panic!(
                "start-up: an over-current comparator trips with no current: check its threshold: phase {=usize} (0 = U)",
                phase
            ),
        }
    }

    /// The button is sampled every this many steps (40 steps = 10 ms, longer than contact
    /// bounce).
    const BUTTON_POLL_STEPS: u32 = 40;
    /// A press held this long (2 s) with the drive disabled starts the identification.
    const IDENTIFY_HOLD_STEPS: u32 = 2 * pmsm_b_g431b_esc1::config::SETTINGS.control_hz;

    /// The servo input is polled every this many steps (4 steps = 1 ms, shorter than the
    /// shortest frame, 1/490 Hz = 2.04 ms: no pulse is missed).
    const SERVO_POLL_STEPS: u32 = pmsm_b_g431b_esc1::config::SETTINGS.control_hz / 1000;
    /// A control step \[µs].
    const US_PER_STEP: u32 = 1_000_000 / pmsm_b_g431b_esc1::config::SETTINGS.control_hz;

    /// Copies the control path (`.ramfunc`, placed by `ramfunc.x`) from its load image in
    /// flash to CCM SRAM. Must run before anything in it is called.
    fn load_ramfunc() {
        extern "C" {
            static mut __sramfunc: u32;
            static mut __eramfunc: u32;
            static __siramfunc: u32;
        }
        // SAFETY: the three symbols come from ramfunc.x: a word-aligned region of CCM SRAM
        // that nothing else uses and its image in flash, of the same length. Nothing in the
        // region runs before this copy (it is the first thing `main` does; no interrupt is
        // enabled).
        unsafe {
            let dst = core::ptr::addr_of_mut!(__sramfunc);
            let end = core::ptr::addr_of_mut!(__eramfunc);
            let src = core::ptr::addr_of!(__siramfunc);
            let words = (end as usize - dst as usize) / 4;
            core::ptr::copy_nonoverlapping(src, dst, words);
        }
        // The copied words are code: finish the writes before any is fetched.
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
    }

    /// The firmware: start-up, then the main loop (the image's entry calls it).
    pub fn run() -> ! {
        load_ramfunc();
        let (Some(dp), Some(mut cp)) = (pac::Peripherals::take(), cortex_m::Peripherals::take())
        else {
            defmt::panic!("peripherals taken twice");
        };

        // Core and PWR clocks first: the voltage range is in PWR.
        dp.RCC.apb1enr1().modify(|_, w| w.pwren().set_bit());
        let cpu = &mut Cpu;
        let clock = ok(clocks::init(&dp.RCC, &dp.PWR, &dp.FLASH, cpu));
        defmt::info!(
            "B-G431B-ESC1: SYSCLK 170 MHz from {=str}",
            match clock {
                clocks::ClockSource::Hse => "the HSE crystal",
                clocks::ClockSource::HsiFallback => "HSI16 (the crystal did not start)",
            }
        );

        watchdog::freeze_on_debug_halt(&dp.DBGMCU);
        clocks::enable_peripherals(&dp.RCC);
        overcurrent::system_break(
            &dp.SYSCFG,
            &dp.RCC,
            matches!(clock, clocks::ClockSource::Hse),
        );
        pwm::release_dead_battery_pins(&dp.PWR);

        pwm::init_tim1(&dp.TIM1);
        adc::init_pins(&dp.GPIOA, &dp.GPIOB, &dp.GPIOC);
        pwm::init_button(&dp.GPIOC);
        board_io::init_led(&dp.GPIOC);
        servo_capture::init(&dp.RCC, &dp.GPIOA, &dp.TIM2);
        adc::init_opamps(&dp.OPAMP, cpu);

        // Start the timer (outputs off: MOE = 0), find where its update lands, write BDTR
        // once (dead time, breaks, off-states, LOCK); only then the pins to the timer.
        let pwm = ok(pwm::start(dp.TIM1, cpu));
        defmt::info!(
            "TIM1: {=u32} Hz centre-aligned, ARR {=u32}, dead time {=f32} ns (DTG {=u8:#x}, CKD {=u8}), update every period at the counter {=str}, a step every {=u32}, break filter {=f32} ns",
            SETTINGS.pwm_hz,
            SETTINGS.tim1_arr,
            SETTINGS.dead_time.ns,
            SETTINGS.dead_time.dtg,
            SETTINGS.dead_time.ckd,
            match pwm.sample_at() {
                pwm::SampleAt::Peak => "peak",
                pwm::SampleAt::Valley => "valley",
            },
            SETTINGS.pwm_per_step,
            SETTINGS.break_filter_ns
        );
        pwm::init_pins(&dp.GPIOA, &dp.GPIOB, &dp.GPIOC);
        let (adc, start) = ok(adc::init(&dp.ADC12_COMMON, dp.ADC1, dp.ADC2, cpu));
        let offsets = adc.offsets();
        defmt::info!(
            "current offsets U V W = {=f32} {=f32} {=f32} LSB, bus {=f32} V",
            offsets[0],
            offsets[1],
            offsets[2],
            start.v_bus
        );
        let comparator_inputs = start.comparator_inputs;
        let temp_c = NtcConfig::ESC1.temp_c(start.ntc_raw, SETTINGS.vref_v);
        defmt::info!("power stage at {=f32} C (NTC, PB14)", temp_c);
        // The settings kept in flash (none: no drive until the link loads a motor).
        #[cfg(feature = "link")]
        let mut flash = ConfigFlash::board(&dp.FLASH);
        #[cfg(feature = "link")]
        let stored = link::load(&mut flash);
        // The hardware trip: the stored settings' trip current, else the ADC's range.
        #[cfg(feature = "link")]
        let i_trip_a = stored.map_or(SETTINGS.i_adc_range_a, |s| s.limits.i_trip_a);
        #[cfg(not(feature = "link"))]
        let i_trip_a = pmsm_b_g431b_esc1::drive_settings::drive_config()
            .limits
            .i_trip_a;
        let hw_trip = ok(overcurrent::init(
            &dp.RCC,
            &dp.DAC3,
            &dp.COMP,
            comparator_inputs,
            i_trip_a,
            cpu,
        ));
        defmt::info!(
            "hardware over-current trip (COMP1/2/4 -> TIM1 BRK2) at U {=f32} V {=f32} W {=f32} A (software trip {=f32} A); comparator inputs {=f32} {=f32} {=f32} V",
            hw_trip[0],
            hw_trip[1],
            hw_trip[2],
            i_trip_a,
            comparator_inputs[0],
            comparator_inputs[1],
            comparator_inputs[2]
        );
        let (step_events, tick_events, mut receiver) = telemetry::queues();

        let mut stage = Esc1::new(pwm, adc, temp_c);
        // A break flag set while the comparators started (none is high now: checked) is
        // not a fault.
        stage.clear_faults();
        // The control interrupts start with the first drive (at boot from the stored
        // settings, or when the link loads a motor).
        let mut parked = Some((stage, dp.IWDG, step_events, tick_events));
        let mut start = |drive: BoardDrive| {
            let Some((mut stage, iwdg, step_events, tick_events)) = parked.take() else {
                return;
            };
            // Before the first enable: the bootstrap capacitors charged through the low sides.
            ok(stage.precharge_bootstrap(SETTINGS.precharge_periods, &mut Cpu));
            let watchdog = ok(protection::Watchdog::start(iwdg, &mut Cpu));
            // Drop any sequence that completed since the calibration, so the first step
            // starts on a fresh sample (a stale one could look like an overrun).
            stage.discard_samples();
            let control = Control::new(drive, stage, watchdog, step_events);
            let tick = Tick::new(&control, tick_events);
            control::start(&mut cp.NVIC, control, tick);
            defmt::info!("drive built: control interrupts started");
        };
        #[cfg(not(feature = "link"))]
        start(crate::settings::build_drive());
        #[cfg(feature = "link")]
        let mut board = Board::new(stored, flash, &mut start);
        #[cfg(feature = "link")]
        let (mut uart, mut server) = {
            usart::init(&dp.RCC, &dp.GPIOB, &dp.USART2);
            let uart = Usart::new(&dp.USART2);
            defmt::info!(
                "link on USART2 (ST-LINK virtual COM port) at {=u32} bit/s; drive {=str}",
                usart::BAUD,
                if pmsm_link::Device::settings(&board).is_some() {
                    "configured (started at the first enable)"
                } else {
                    "refused"
                }
            );
            (uart, Server::new())
        };

        let identify = cfg!(feature = "identify");
        let pc10 = GpioIn::new(&dp.GPIOC, 10);
        let mut button = Button::new(pc10, BUTTON_POLL_STEPS, IDENTIFY_HOLD_STEPS, identify);
        let mut led = StatusLed::new(GpioOut::new(&dp.GPIOC, 6), SETTINGS.control_hz / 4);
        // The servo input (PA15, TIM2): full throttle is the rated speed, slewed at the
        // drive's own start acceleration (with the link: the settings in force, taken at
        // every poll, `servo_scale`).
        #[cfg(not(feature = "link"))]
        let full_rpm = MOTOR.ratings.speed_rpm;
        #[cfg(not(feature = "link"))]
        let slew_per_s = drive_config().start.accel_rpm_per_s / full_rpm;
        #[cfg(feature = "link")]
        let slew_per_s = 0.0;
        let mut servo = ServoDecoder::new(ServoConfig::standard(slew_per_s));
        let mut servo_in = ServoCapture::new(&dp.TIM2);
        let mut servo_out = ServoOutput::default();
        let mut last_servo = 0u32;
        let mut faulted = false;
        #[cfg(feature = "identify")]
        defmt::info!(
            "running; press the user button (PC10) to enable/disable, hold it 2 s to identify the motor"
        );
        #[cfg(not(feature = "identify"))]
        defmt::info!("running; press the user button (PC10) to enable/disable");

        let mut last_temp_log = 0u32;
        loop {
            // This loop has run: the control step may feed the watchdog.
            MAIN_ALIVE.store(true, Ordering::Relaxed);
            receiver.log(|_ev| {
                faulted = _ev.faulted();
                #[cfg(feature = "link")]
                board.note(_ev);
            });
            // Between the interrupts, never within one: the USART's Error is Infallible.
            #[cfg(feature = "link")]
            {
                let Ok(()) = server.poll(&mut uart, &mut board);
                if board.restart_due() {
                    // The answer on the wire first, then a system reset (the drive does not
                    // run: the link refuses a restart then). PWM is off from the reset on.
                    defmt::info!("restart asked over the link");
                    let Ok(()) = embedded_io::Write::flush(&mut uart);
                    cortex_m::peripheral::SCB::sys_reset();
                }
            }

            let retries = TICK_RETRIES.swap(0, Ordering::Relaxed);
            if retries > 0 {
                defmt::warn!(
                    "{=u32} 1 kHz tasks taken again (a step ran meanwhile)",
                    retries
                );
            }

            // The button's idle level was read at boot, so its polarity does not matter.
            let now = STEPS.load(Ordering::Relaxed);
            if now.wrapping_sub(last_temp_log) >= SETTINGS.control_hz {
                last_temp_log = now;
                defmt::info!(
                    "power stage {=f32} C, speed command {=f32} rpm",
                    f32::from_bits(STAGE_TEMP_C.load(Ordering::Relaxed)),
                    f32::from_bits(SPEED_RPM.load(Ordering::Relaxed))
                );
            }
            // Acted on at the release (`board_io::Button`): held for IDENTIFY_HOLD_STEPS
            // (2 s) with the drive disabled, the identification; else enable toggled (or the
            // fault cleared).
            match button.poll(now, faulted, ENABLE.load(Ordering::Relaxed)) {
                Some(ButtonAction::ClearFault) => {
                    ENABLE.store(false, Ordering::Relaxed);
                    CLEAR_FAULT.store(true, Ordering::Relaxed);
                    defmt::info!("button: clear fault (drive stays disabled)");
                }
                Some(ButtonAction::Identify | ButtonAction::Enable(_))
                    if !drive_ready(
                        #[cfg(feature = "link")]
                        &mut board,
                    ) =>
                {
                    defmt::warn!("button: no drive (load a motor over the link)");
                }
                Some(ButtonAction::Identify) => {
                    ENABLE.store(true, Ordering::Relaxed);
                    IDENTIFY.store(true, Ordering::Relaxed);
                    defmt::info!("button held: identification (the motor turns)");
                }
                Some(ButtonAction::Enable(enable)) => {
                    ENABLE.store(enable, Ordering::Relaxed);
                    defmt::info!("button: enable = {=bool}", enable);
                }
                None => {}
            }
            // The servo input every SERVO_POLL_STEPS (1 ms): the speed command while armed
            // (else the button's constant; with the link, 0 at the disarm and the link's
            // command after), the run command at its edges only (an enable refused without
            // a drive, as the button's).
            if now.wrapping_sub(last_servo) >= SERVO_POLL_STEPS {
                let dt_us = now.wrapping_sub(last_servo).saturating_mul(US_PER_STEP);
                last_servo = now;
                #[cfg(feature = "link")]
                let full_rpm = servo_scale(&board, &mut servo);
                let out = servo.update(servo_in.capture(), dt_us);
                if let Some(enable) = out.enable_change(&servo_out) {
                    if enable
                        && !drive_ready(
                            #[cfg(feature = "link")]
                            &mut board,
                        )
                    {
                        defmt::warn!("servo input: no drive (load a motor over the link)");
                    } else {
                        ENABLE.store(enable, Ordering::Relaxed);
                        defmt::info!(
                            "servo input: armed = {=bool}, enable = {=bool} (rejected {=u32}, lost {=u32})",
                            out.armed,
                            enable,
                            servo.rejected_width + servo.rejected_period,
                            servo.losses
                        );
                    }
                }
                #[cfg(not(feature = "link"))]
                SPEED_CMD.store(
                    out.speed_rpm(full_rpm, SPEED_CMD_RPM).to_bits(),
                    Ordering::Relaxed,
                );
                #[cfg(feature = "link")]
                match full_rpm {
                    Some(full_rpm) if out.armed => {
                        SPEED_CMD.store(out.speed_rpm(full_rpm, 0.0).to_bits(), Ordering::Relaxed);
                    }
                    _ if servo_out.armed => SPEED_CMD.store(0, Ordering::Relaxed),
                    _ => {}
                }
                servo_out = out;
            }
            led.show(now, faulted, servo_out.armed);
            // Woken by the next control interrupt at the latest.
            cortex_m::asm::wfi();
        }
    }
}
