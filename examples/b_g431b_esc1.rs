//! Firmware for ST's B-G431B-ESC1 Discovery kit (STM32G431CBU6, Cortex-M4F at 170 MHz):
//! the drive's `Drive::step` at 4 kHz on the board's three half-bridges.
//!
//! Build and flash (runner `probe-rs run --chip STM32G431CBUx` in `.cargo/config.toml`):
//!
//! ```text
//! cargo run --release --example b_g431b_esc1 --features board --target thumbv7em-none-eabihf
//! ```
//!
//! # Use
//!
//! The motor is the constant `MOTOR` below (edit it for yours), the speed command the constant
//! `SPEED_CMD_RPM`. The user button toggles `enable`; pressed while the drive is
//! in `Fault` it clears the fault and leaves the drive disabled (press again to restart). The
//! log (defmt over RTT) shows every mode transition and a telemetry record at 10 Hz.
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
//! | User button              | PC10 | GPIO input                                  |
//!
//! Timing: TIM1 centre-aligned at 20 kHz, the repetition counter makes one update event
//! (UEV) every 5 PWM periods = 4 kHz, at the counter peak where all low-side switches
//! conduct (should the silicon put the UEV on the valley instead, start-up detects it and
//! switches to PWM mode 2, which puts the low-side interval there). TRGO = UEV starts the injected conversions of ADC1 (U, W, bus) and ADC2 (V) at
//! that instant; ADC1's end-of-injected-sequence interrupt runs the drive step and writes
//! CCR1..3. PWM outputs stay off (MOE = 0) until the drive returns duties, and MOE is
//! cleared in the same step in which it returns `None`.
//!
//! # Safety nets
//!
//! The drive's software trip (`i_trip_a`) is the only over-current protection configured
//! here: the board's hardware protection path (comparators / TIM1 break, UM2516) is not set
//! up. An independent watchdog (about 10 ms) is fed by the control interrupt only, so a
//! stalled control loop — e.g. the main loop stuck inside a defmt-rtt write with interrupts
//! masked, which happens in probe-rs's blocking RTT mode when the host stops reading —
//! resets the MCU and releases the gate-driver inputs. A HardFault (also the end of every
//! panic, through panic-probe) clears MOE first. With a debugger halting the core, TIM1's
//! outputs are forced to their inactive level (DBGMCU `DBG_TIM1_STOP`, OSSI = 1).
#![cfg_attr(target_os = "none", no_std, no_main)]

#[cfg(not(target_os = "none"))]
fn main() {
    println!(
        "b_g431b_esc1 is firmware: build it with `--features board --target thumbv7em-none-eabihf`"
    );
}

#[cfg(target_os = "none")]
mod firmware {
    use core::cell::RefCell;
    use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

    use cortex_m::interrupt::Mutex;
    use cortex_m::peripheral::NVIC;
    use cortex_m_rt::{entry, exception, ExceptionFrame};
    use defmt_rtt as _;
    use heapless::spsc::{Producer, Queue};
    use panic_probe as _;
    use pmsm_sensorless::drive::{
        Command, Drive, DriveConfig, DriveInput, Mode, StateOf, Telemetry, Transition,
    };
    use pmsm_sensorless::frames::Abc;
    use pmsm_sensorless::motor::{Motor, Ratings, HORNG_SINANO};
    use pmsm_sensorless::svpwm::Duties;
    use stm32g4::stm32g431::{self as pac, interrupt, Interrupt};

    // ---------------------------------------------------------------------------------------
    // User settings
    // ---------------------------------------------------------------------------------------

    /// The board's default motor: Horng & Chin's Sinano motor ([`HORNG_SINANO`], R, L, K, N,
    /// J, B of their Table 1) with its bus rating moved from 48 V to 24 V, the bus this board
    /// takes (UM2516: up to 6S LiPo). Everything else is the preset's (its 1000 rpm rating
    /// stays, as the sliding-gain bounds are checked there; at 24 V the motor's back-EMF
    /// limits it to about 570 rpm, hence [`SPEED_CMD_RPM`]). Replace this with your motor.
    pub const MOTOR: Motor = Motor {
        name: "sinano-24v",
        params: HORNG_SINANO.params,
        ratings: Ratings {
            bus_v: 24.0,
            ..HORNG_SINANO.ratings
        },
    };

    /// Observer feeding the controller, and the one that monitors it.
    type Primary = pmsm_sensorless::observer::sliding::SlidingObserver;
    type Monitor = pmsm_sensorless::observer::flux_speed::FluxPll;

    /// Speed command while enabled [rpm, mechanical].
    pub const SPEED_CMD_RPM: f32 = 400.0;

    /// Bus over-voltage trip of this board \[V]: a full 6S LiPo (UM2516: "up to 6S"; NuttX's
    /// board port gives 25 V as Vbus max). The drive's own default (1.25 × rated bus) is
    /// lowered to this if higher.
    const BOARD_BUS_MAX_V: f32 = 25.2;

    // ---------------------------------------------------------------------------------------
    // Clocks and PWM timing
    // ---------------------------------------------------------------------------------------

    /// SYSCLK = HCLK = PCLK1 = PCLK2 = TIM1 kernel clock \[Hz].
    const SYSCLK_HZ: u32 = 170_000_000;
    /// Switching frequency \[Hz].
    const PWM_HZ: u32 = 20_000;
    /// Control (drive step) rate \[Hz]; must equal the drive's `rate_hz`.
    const CONTROL_HZ: u32 = 4_000;
    /// Centre-aligned: one PWM period is 2·ARR timer clocks (RM0440 §28, "Center-aligned mode
    /// (up/down counting)").
    const PWM_ARR: u32 = SYSCLK_HZ / (2 * PWM_HZ);
    /// PWM periods per control step.
    const PWM_PER_STEP: u32 = PWM_HZ / CONTROL_HZ;
    /// In centre-aligned mode the repetition counter counts both overflows and underflows
    /// (RM0440 §28, "Repetition counter"): RCR + 1 = 2 × periods per update event.
    const TIM1_RCR: u16 = (2 * PWM_PER_STEP - 1) as u16;
    /// Dead time [ns]. The L6387 gate driver interlocks its two inputs but, to my knowledge,
    /// inserts no dead time of its own; 500 ns is the value NuttX uses for this board ("REVISIT" there): NOT
    /// derived from the STL180N6F7 switching times.
    const DEAD_TIME_NS: u32 = 500;
    /// DTG\[7:0] with DTG\[7] = 0: dead time = DTG × t_DTS, t_DTS = 1/170 MHz (CKD = 0),
    /// at most 127 steps = 747 ns (RM0440 TIMx_BDTR).
    const DTG: u8 = (DEAD_TIME_NS * (SYSCLK_HZ / 1_000_000) / 1000) as u8;
    /// Largest duty loaded into the timer. Currents are sampled in the middle of the low-side
    /// conduction interval, which lasts (1 − d)·50 µs at 20 kHz; the
    /// shunt amplifiers need about 1.3 µs to settle after a switching edge (measured by the
    /// FOC-Stim project, diglet48/FOC-Stim, on this board) plus dead time and the ~0.5 µs conversion of the first
    /// two ranks: 0.92 leaves 2 µs each side of the sample. An engineering estimate.
    const DUTY_MAX: f32 = 0.92;

    const _: () = assert!(
        PWM_HZ.is_multiple_of(CONTROL_HZ) && DEAD_TIME_NS * (SYSCLK_HZ / 1_000_000) / 1000 <= 127
    );

    // ---------------------------------------------------------------------------------------
    // Analog front end
    // ---------------------------------------------------------------------------------------

    /// ADC reference: VDDA = VREF+ = 3.3 V on this board. UNVERIFIED against the UM2516
    /// schematic (the whole scaling below is proportional to it).
    const VREF_V: f32 = 3.3;
    /// 12-bit conversions.
    const ADC_COUNTS: f32 = 4096.0;
    /// Shunt resistance \[Ω] (NuttX board port and ST's motor-control SDK settings for this
    /// board: 3 mΩ).
    const R_SHUNT_OHM: f32 = 0.003;
    /// Shunt voltage → ADC input voltage: OPAMPx in PGA mode (internal gain 16, VINM0 used as
    /// the input/bias pin) together with the board's resistor network gives −9.14 overall; the
    /// sign is negative (the amplifier inverts the phase current). Value from the NuttX port /
    /// ST MC SDK board description, UNVERIFIED against UM2516's schematic; the sign convention
    /// (positive = into the motor) must be checked on the bench: in `Align` the telemetry's
    /// `i_d` must come out positive.
    const CURRENT_SENSE_GAIN: f32 = -9.14;
    /// Phase current per ADC count \[A/LSB] (about −0.0294).
    const AMPS_PER_LSB: f32 = VREF_V / ADC_COUNTS / (R_SHUNT_OHM * CURRENT_SENSE_GAIN);
    /// Bus divider 169 kΩ over 18 kΩ (NuttX board port: "Vbus sense gain = 18k/(18k+169k)").
    /// UNVERIFIED against UM2516's schematic.
    const VBUS_DIVIDER: f32 = (169.0 + 18.0) / 18.0;
    /// Bus voltage per ADC count \[V/LSB] (about 0.0084).
    const VOLTS_PER_LSB: f32 = VREF_V / ADC_COUNTS * VBUS_DIVIDER;
    /// Largest current the ADC can represent around a mid-scale offset, with 5 % margin \[A];
    /// the drive's sensing range (`i_sense_max_a`) is capped to it.
    const I_ADC_RANGE_A: f32 = 0.95 * 2048.0 * AMPS_PER_LSB.abs();
    /// Conversions averaged for the current offsets at start-up, PWM off.
    const OFFSET_SAMPLES: u32 = 1024;
    /// A measured offset outside this window means the amplifier path is not working
    /// (floating or saturated output); the firmware then refuses to start.
    const OFFSET_WINDOW_LSB: (f32, f32) = (512.0, 3584.0);

    // ---------------------------------------------------------------------------------------
    // Logging and command path
    // ---------------------------------------------------------------------------------------

    /// One telemetry record every this many steps (400 steps = 10 Hz).
    const TELEMETRY_EVERY: u32 = 400;
    /// The button is sampled every this many steps (40 steps = 10 ms, longer than contact
    /// bounce).
    const BUTTON_POLL_STEPS: u32 = 40;
    /// Capacity of the interrupt → main-loop queue (one slot is kept free by heapless).
    const QUEUE_LEN: usize = 16;
    /// Watchdog reload: LSI (~32 kHz) / 4 → 8 kHz, 80 counts ≈ 10 ms = 40 control steps.
    const IWDG_RELOAD: u16 = 80;

    /// Run command, written by the main loop (button), read by the interrupt.
    static ENABLE: AtomicBool = AtomicBool::new(false);
    /// Clear-fault request, set by the main loop, consumed (swapped to false) by the interrupt.
    static CLEAR_FAULT: AtomicBool = AtomicBool::new(false);
    /// Control steps done, for the main loop's timing.
    static STEPS: AtomicU32 = AtomicU32::new(0);
    /// Records the interrupt could not queue (queue full).
    static DROPPED: AtomicU32 = AtomicU32::new(0);
    /// The control context, handed from `main` to the interrupt once.
    static CONTROL: Mutex<RefCell<Option<Control>>> = Mutex::new(RefCell::new(None));

    /// What the interrupt sends to the main loop.
    enum Event {
        Telemetry {
            step: u32,
            tel: Telemetry,
            i_abc: Abc,
            v_bus: f32,
        },
        Transition {
            step: u32,
            tr: Transition,
        },
    }

    /// Where the update event (and so the current sample) falls in the PWM period; decides
    /// how duties map to compare values (see [`configure_pwm_edge`]).
    #[derive(Clone, Copy, defmt::Format)]
    enum SampleAt {
        /// Counter peak: PWM mode 1, CCR = d·ARR.
        Peak,
        /// Counter valley: PWM mode 2, CCR = (1 − d)·ARR.
        Valley,
    }

    #[derive(Clone, Copy, defmt::Format)]
    enum ClockSource {
        /// 8 MHz HSE crystal → PLL.
        Hse,
        /// HSE did not start: HSI16 → PLL (same 170 MHz, RC accuracy ±1 %).
        HsiFallback,
    }

    /// Everything the 4 kHz interrupt owns.
    struct Control {
        drive: Drive<Primary, Monitor>,
        state: StateOf<Primary, Monitor>,
        tim1: pac::TIM1,
        adc1: pac::ADC1,
        adc2: pac::ADC2,
        iwdg: pac::IWDG,
        /// Current-channel offsets U, V, W [LSB], measured with PWM off.
        offsets: [f32; 3],
        sample_at: SampleAt,
        producer: Producer<'static, Event>,
        step: u32,
        /// The previous step overran its period.
        overrun: bool,
    }

    impl Control {
        /// One control period: read the samples, step the drive, load the timer.
        ///
        /// Runs from CCM SRAM (`.ramfunc`, memory.x), with `Drive::step` and everything it
        /// inlines (observers, FOC, SVPWM) inlined into it: flash needs 4 wait states at
        /// 170 MHz and the ART's 1 KiB instruction cache cannot hold the ~9 KiB step. The
        /// sliding observer's sin/cos table sits beside it; `math::sin_cos` and the other cold
        /// paths (mode changes, far angle wraps) stay in flash. An overrun is reported to the
        /// drive (it faults with `Overrun`).
        // Not `unsafe`, but `#[link_section]` trips the `unsafe_code` lint: the section is one
        // memory.x defines and `load_ramfunc` fills before the interrupt is enabled.
        #[link_section = ".ramfunc.control_step"]
        #[inline(never)]
        fn step(&mut self) {
            // Acknowledge the interrupt source first (RM0440 ADC_ISR: write 1 to clear).
            self.adc1.isr().write(|w| w.jeos().clear().jeoc().clear());
            // ADC2 converts one channel against ADC1's three from the same trigger, so it is
            // done; a missing flag means its sample is stale and is reported as invalid.
            let adc2_done = self.adc2.isr().read().jeos().bit_is_set();
            self.adc2.isr().write(|w| w.jeos().clear().jeoc().clear());

            let raw_u = f32::from(self.adc1.jdr1().read().jdata().bits());
            let raw_w = f32::from(self.adc1.jdr2().read().jdata().bits());
            let raw_bus = f32::from(self.adc1.jdr3().read().jdata().bits());
            let raw_v = f32::from(self.adc2.jdr1().read().jdata().bits());
            let i_abc = Abc::new(
                (raw_u - self.offsets[0]) * AMPS_PER_LSB,
                if adc2_done {
                    (raw_v - self.offsets[1]) * AMPS_PER_LSB
                } else {
                    f32::NAN
                },
                (raw_w - self.offsets[2]) * AMPS_PER_LSB,
            );
            let v_bus = raw_bus * VOLTS_PER_LSB;

            let input = DriveInput {
                i_abc,
                v_bus,
                overrun: self.overrun,
            };
            let cmd = Command {
                enable: ENABLE.load(Ordering::Relaxed),
                speed_rpm: SPEED_CMD_RPM,
                clear_fault: CLEAR_FAULT.swap(false, Ordering::Relaxed),
            };
            let out = self.drive.step(&mut self.state, &input, &cmd);

            match out.duties {
                Some(d) => {
                    self.load_duties(d);
                    self.tim1.bdtr().modify(|_, w| w.moe().enabled());
                }
                None => {
                    self.tim1.bdtr().modify(|_, w| w.moe().disabled_idle());
                }
            }

            if let Some(tr) = out.transition {
                self.send(Event::Transition {
                    step: self.step,
                    tr,
                });
            }
            if self.step.is_multiple_of(TELEMETRY_EVERY) {
                self.send(Event::Telemetry {
                    step: self.step,
                    tel: self.drive.telemetry(&self.state),
                    i_abc,
                    v_bus,
                });
            }
            self.step = self.step.wrapping_add(1);
            STEPS.store(self.step, Ordering::Relaxed);
            self.iwdg.kr().write(|w| w.key().feed());

            // Another injected sequence completed while this step ran: it overran its period.
            self.overrun = self.adc1.isr().read().jeos().bit_is_set();
        }

        /// Duties in [0, 1] → CCR1..3 (preload off: they take effect now, see `init_tim1`).
        fn load_duties(&self, d: Duties) {
            let ccr = |x: f32| {
                // High-side on-time in timer counts; the saturating cast maps a NaN to 0
                // (high side off) in both modes.
                let on = (x.clamp(0.0, DUTY_MAX) * PWM_ARR as f32) as u32;
                match self.sample_at {
                    SampleAt::Peak => on,
                    SampleAt::Valley => PWM_ARR - on,
                }
            };
            self.tim1.ccr1().write(|w| w.ccr().set(ccr(d.a)));
            self.tim1.ccr2().write(|w| w.ccr().set(ccr(d.b)));
            self.tim1.ccr3().write(|w| w.ccr().set(ccr(d.c)));
        }

        fn send(&mut self, ev: Event) {
            if self.producer.enqueue(ev).is_err() {
                DROPPED.fetch_add(1, Ordering::Relaxed);
            }
        }
    }

    /// The control interrupt: ADC1 end of injected sequence (ADC1 and ADC2 share the vector).
    #[interrupt]
    fn ADC1_2() {
        static mut CTX: Option<Control> = None;
        let ctl = match CTX {
            Some(ctl) => ctl,
            None => match cortex_m::interrupt::free(|cs| CONTROL.borrow(cs).borrow_mut().take()) {
                Some(ctl) => CTX.insert(ctl),
                // Cannot happen (main installs the context before unmasking); never spin.
                None => {
                    NVIC::mask(Interrupt::ADC1_2);
                    return;
                }
            },
        };
        ctl.step();
    }

    /// Every panic ends here (panic-probe: `udf`), as does any fault: switch the bridge off
    /// first, then wait for the watchdog to reset the MCU.
    #[exception]
    // SAFETY (of the signature): cortex-m-rt requires HardFault handlers to be `unsafe fn`;
    // this one only touches TIM1's BDTR and never returns.
    unsafe fn HardFault(_frame: &ExceptionFrame) -> ! {
        // SAFETY: nothing else runs after a HardFault (it is the highest-priority handler
        // short of NMI and never returns); clearing MOE is a single read-modify-write of
        // TIM1_BDTR that forces the outputs to their idle (off) level.
        let tim1 = unsafe { pac::TIM1::steal() };
        tim1.bdtr().modify(|_, w| w.moe().disabled_idle());
        loop {
            cortex_m::asm::nop();
        }
    }

    /// Copies the control path (`.ramfunc`, see memory.x) from its load image in flash to CCM
    /// SRAM. Must run before anything in it is called.
    fn load_ramfunc() {
        extern "C" {
            static mut __sramfunc: u32;
            static mut __eramfunc: u32;
            static __siramfunc: u32;
        }
        // SAFETY: the three symbols come from memory.x: a word-aligned region of CCM SRAM that
        // nothing else uses and its image in flash, of the same length. Nothing in the region
        // runs before this copy (it is the first thing `main` does; no interrupt is enabled).
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

    #[entry]
    fn main() -> ! {
        load_ramfunc();
        let Some(dp) = pac::Peripherals::take() else {
            defmt::panic!("peripherals taken twice");
        };

        // Core and PWR clocks first: the voltage range is in PWR.
        dp.RCC.apb1enr1().modify(|_, w| w.pwren().set_bit());
        let clock = init_clocks(&dp.RCC, &dp.PWR, &dp.FLASH);
        defmt::info!("B-G431B-ESC1: SYSCLK 170 MHz from {}", clock);

        // Debug halt: TIM1 stops with its outputs forced inactive (OSSI = 1), IWDG freezes.
        dp.DBGMCU
            .apb2_fz()
            .modify(|_, w| w.dbg_tim1_stop().set_bit());
        dp.DBGMCU
            .apb1l_fz()
            .modify(|_, w| w.dbg_iwdg_stop().set_bit());

        dp.RCC.ahb2enr().modify(|_, w| {
            w.gpioaen()
                .set_bit()
                .gpioben()
                .set_bit()
                .gpiocen()
                .set_bit()
                .adc12en()
                .set_bit()
        });
        // OPAMP registers sit in the SYSCFG address block and are clocked by SYSCFGEN
        // (RM0440 §25; NuttX's port also requires SYSCFG for them).
        dp.RCC
            .apb2enr()
            .modify(|_, w| w.tim1en().set_bit().syscfgen().set_bit());
        // USB-C dead-battery behaviour off (RM0440 PWR_CR3.UCPD1_DBDIS): its DBCC pins are
        // PA9/PA10 (DS12589), the V and W high-side outputs here.
        dp.PWR.cr3().modify(|_, w| w.ucpd1_dbdis().set_bit());

        init_tim1(&dp.TIM1);
        init_gpio(&dp.GPIOA, &dp.GPIOB, &dp.GPIOC);
        init_opamps(&dp.OPAMP);

        // Start the timer (outputs still off: MOE = 0) and find where its update lands.
        dp.TIM1.cr1().modify(|_, w| w.cen().enabled());
        let sample_at = configure_pwm_edge(&dp.TIM1);
        // Timer setup done: lock the dead time, break and idle-state bits (LOCK level 1,
        // RM0440 TIMx_BDTR). MOE stays writable.
        dp.TIM1.bdtr().modify(|_, w| w.lock().level1());
        defmt::info!(
            "TIM1: {=u32} Hz centre-aligned, ARR {=u32}, dead time {=u8} x 5.9 ns, update every {=u32} periods at the counter {}",
            PWM_HZ,
            PWM_ARR,
            DTG,
            PWM_PER_STEP,
            sample_at
        );

        init_adcs(&dp.ADC12_COMMON, &dp.ADC1, &dp.ADC2);
        let (offsets, v_bus) = measure_offsets(&dp.ADC1, &dp.ADC2);
        defmt::info!(
            "current offsets U V W = {=f32} {=f32} {=f32} LSB, bus {=f32} V",
            offsets[0],
            offsets[1],
            offsets[2],
            v_bus
        );
        for o in offsets {
            if !(OFFSET_WINDOW_LSB.0..=OFFSET_WINDOW_LSB.1).contains(&o) {
                defmt::panic!(
                    "current-sense offset {=f32} LSB outside the plausible window: check the amplifiers",
                    o
                );
            }
        }

        let mut cfg = DriveConfig::new(&MOTOR);
        cfg.rate_hz = CONTROL_HZ as f32;
        cfg.limits.bus_max_v = cfg.limits.bus_max_v.min(BOARD_BUS_MAX_V);
        cfg.limits.i_sense_max_a = cfg.limits.i_sense_max_a.min(I_ADC_RANGE_A);
        let drive = match cfg.build_sliding_primary() {
            Ok(d) => d,
            Err(e) => defmt::panic!("drive configuration rejected: {=str}", e.field()),
        };
        defmt::info!(
            "motor {=str}, primary {=str}, speed command {=f32} rpm, trip {=f32} A, bus {=f32}..{=f32} V",
            MOTOR.name,
            core::any::type_name::<Primary>(),
            SPEED_CMD_RPM,
            cfg.limits.i_trip_a,
            cfg.limits.bus_min_v,
            cfg.limits.bus_max_v
        );

        let Some(queue) = cortex_m::singleton!(: Queue<Event, QUEUE_LEN> = Queue::new()) else {
            defmt::panic!("queue taken twice");
        };
        let (producer, mut consumer) = queue.split();

        start_watchdog(&dp.IWDG);
        // Drop any sequence that completed since the calibration, so the first step starts on
        // a fresh sample (a stale one could make the first step look like an overrun).
        for adc in [&*dp.ADC1, &*dp.ADC2] {
            adc.isr().write(|w| w.jeos().clear().jeoc().clear());
        }
        cortex_m::interrupt::free(|cs| {
            CONTROL.borrow(cs).replace(Some(Control {
                drive,
                state: StateOf::<Primary, Monitor>::default(),
                tim1: dp.TIM1,
                adc1: dp.ADC1,
                adc2: dp.ADC2,
                iwdg: dp.IWDG,
                offsets,
                sample_at,
                producer,
                step: 0,
                overrun: false,
            }));
        });
        NVIC::unpend(Interrupt::ADC1_2);
        // SAFETY: the handler's context is installed above; unmasking cannot break a
        // critical section (none is active here) and ADC1_2 is the only interrupt enabled.
        unsafe { NVIC::unmask(Interrupt::ADC1_2) };

        let gpioc = dp.GPIOC;
        let button_idle = gpioc.idr().read().idr(10).bit();
        let mut was_pressed = false;
        let mut last_poll = 0u32;
        let mut mode = Mode::Idle;
        defmt::info!("running; press the user button (PC10) to enable/disable");

        loop {
            while let Some(ev) = consumer.dequeue() {
                match ev {
                    Event::Transition { step, tr } => {
                        mode = tr.to;
                        defmt::info!(
                            "t = {=f32} s: {} -> {} ({})",
                            seconds(step),
                            tr.from,
                            tr.to,
                            tr.reason
                        );
                    }
                    Event::Telemetry {
                        step,
                        tel,
                        i_abc,
                        v_bus,
                    } => {
                        mode = tel.mode;
                        defmt::info!(
                            "t = {=f32} s: bus {=f32} V, i_abc [{=f32}, {=f32}, {=f32}] A, {}",
                            seconds(step),
                            v_bus,
                            i_abc.a,
                            i_abc.b,
                            i_abc.c,
                            tel
                        );
                    }
                }
            }
            let dropped = DROPPED.swap(0, Ordering::Relaxed);
            if dropped > 0 {
                defmt::warn!("{=u32} log records dropped (queue full)", dropped);
            }

            // The button's idle level was read at boot, so its polarity does not matter.
            let now = STEPS.load(Ordering::Relaxed);
            if now.wrapping_sub(last_poll) >= BUTTON_POLL_STEPS {
                last_poll = now;
                let pressed = gpioc.idr().read().idr(10).bit() != button_idle;
                if pressed && !was_pressed {
                    if mode == Mode::Fault {
                        ENABLE.store(false, Ordering::Relaxed);
                        CLEAR_FAULT.store(true, Ordering::Relaxed);
                        defmt::info!("button: clear fault (drive stays disabled)");
                    } else {
                        let enable = !ENABLE.load(Ordering::Relaxed);
                        ENABLE.store(enable, Ordering::Relaxed);
                        defmt::info!("button: enable = {=bool}", enable);
                    }
                }
                was_pressed = pressed;
            }
            // Woken by the next control interrupt at the latest.
            cortex_m::asm::wfi();
        }
    }

    fn seconds(step: u32) -> f32 {
        step as f32 / CONTROL_HZ as f32
    }

    /// SYSCLK = 170 MHz from PLLR, in range 1 boost mode (RM0440 §6.1.5, §7.2.7).
    ///
    /// HSE: the board's 8 MHz crystal (NuttX board port: `STM32_BOARD_XTAL 8000000`, "Y2 on
    /// board"; crystal mode, not bypass: UNVERIFIED against UM2516). PLL input 4 MHz
    /// (HSE/2 or HSI16/4), VCO ×85 = 340 MHz, R /2 = 170 MHz. If the HSE is not ready
    /// within ~100 ms the PLL runs from HSI16 instead (same frequencies, ±1 % accuracy).
    fn init_clocks(rcc: &pac::RCC, pwr: &pac::PWR, flash: &pac::FLASH) -> ClockSource {
        // Flash: 4 wait states for HCLK ≤ 170 MHz in range 1 boost (RM0440 FLASH chapter,
        // "Read access latency", wait states versus HCLK table), prefetch and both caches on,
        // before any frequency increase (more wait states than needed are always safe).
        flash.acr().modify(|_, w| {
            w.latency()
                .wait4()
                .prften()
                .set_bit()
                .icen()
                .set_bit()
                .dcen()
                .set_bit()
        });
        while !flash.acr().read().latency().is_wait4() {}

        rcc.cr().modify(|_, w| w.hseon().set_bit());
        let mut hse_ready = false;
        for _ in 0..100 {
            if rcc.cr().read().hserdy().bit_is_set() {
                hse_ready = true;
                break;
            }
            cortex_m::asm::delay(16_000); // 1 ms at the reset clock (HSI16)
        }
        let source = if hse_ready {
            ClockSource::Hse
        } else {
            rcc.cr().modify(|_, w| w.hseon().clear_bit());
            ClockSource::HsiFallback
        };

        // PLL is off after reset; configure, enable, wait for lock.
        rcc.pllcfgr().write(|w| {
            let w = match source {
                ClockSource::Hse => w.pllsrc().hse().pllm().div2(),
                ClockSource::HsiFallback => w.pllsrc().hsi16().pllm().div4(),
            };
            w.plln().div85().pllr().div2().pllren().set_bit()
        });
        rcc.cr().modify(|_, w| w.pllon().set_bit());
        while rcc.cr().read().pllrdy().bit_is_clear() {}

        // Range 1 boost (R1MODE = 0) is needed above 150 MHz. RM0440 §6.1.5 (and §7.2.7 for
        // the AHB prescaler): (1) halve HCLK with the AHB prescaler, (2) clear R1MODE,
        // (3) wait states for the target (done above), (4) switch SYSCLK, (5) after ≥ 1 µs
        // restore the AHB prescaler.
        rcc.cfgr().modify(|_, w| w.hpre().div2());
        pwr.cr5().modify(|_, w| w.r1mode().clear_bit());
        // APB1 = APB2 = HCLK (reset value, written for clarity); SYSCLK = PLLR.
        rcc.cfgr()
            .modify(|_, w| w.ppre1().div1().ppre2().div1().sw().pll());
        while !rcc.cfgr().read().sws().is_pll() {}
        cortex_m::asm::delay(200); // > 1 µs at HCLK = 85 MHz
        rcc.cfgr().modify(|_, w| w.hpre().div1());
        source
    }

    /// TIM1: centre-aligned PWM with complementary outputs and dead time (RM0440 §28,
    /// "Complementary outputs and dead-time insertion"), TRGO = update event for the ADCs
    /// (TIMx_CR2.MMS), repetition counter for the 4 kHz update ("Repetition counter"). Outputs enabled per channel but MOE = 0 with OSSI = 1, so
    /// all six pins sit at their idle (inactive = low) level until the drive asks for PWM.
    /// Polarities: active high on both CHx and CHxN, as the L6387 inputs need (NuttX port).
    fn init_tim1(tim1: &pac::TIM1) {
        tim1.cr1()
            .write(|w| w.cms().center_aligned1().arpe().enabled());
        tim1.psc().write(|w| w.psc().set(0));
        tim1.arr().write(|w| w.arr().set(PWM_ARR));
        // Written before the counter starts: RM0440 ("Repetition counter") says the update
        // then falls on the overflow (counter peak). `configure_pwm_edge` checks it and copes either way.
        tim1.rcr().write(|w| w.rep().set(TIM1_RCR));
        // Compare preload off (OCxPE = 0): a CCR written by the step acts at once instead of at
        // the next update one control period later, so the voltage over a period is the one
        // the drive computed last (its `v_ab_last`), less the step's own latency. Price: at
        // most one asymmetric pulse per control period; dead time is still inserted.
        tim1.ccmr1_output()
            .write(|w| w.oc1m().pwm_mode1().oc2m().pwm_mode1());
        tim1.ccmr2_output().write(|w| w.oc3m().pwm_mode1());
        for ccr in [tim1.ccr1(), tim1.ccr2(), tim1.ccr3()] {
            ccr.write(|w| w.ccr().set(PWM_ARR / 2));
        }
        tim1.ccer().write(|w| {
            w.cc1e()
                .enabled()
                .cc1ne()
                .set_bit()
                .cc2e()
                .enabled()
                .cc2ne()
                .set_bit()
                .cc3e()
                .enabled()
                .cc3ne()
                .set_bit()
        });
        // OISx = OISxN = 0 (reset): idle level low on all six outputs.
        // SAFETY: MMS = 0b010 selects "Update" as TRGO, a value defined for this 3-bit field
        // (RM0440 TIMx_CR2; the PAC has no enumeration for it).
        tim1.cr2().write(|w| unsafe { w.mms().bits(0b010) });
        tim1.bdtr().write(|w| {
            w.dtg()
                .set(DTG)
                .ossi()
                .idle_level()
                .ossr()
                .set_bit()
                .moe()
                .disabled_idle()
        });
        // Load PSC/ARR/RCR now; the flag this sets is cleared.
        tim1.egr().write(|w| w.ug().update());
        tim1.sr().write(|w| w.uif().clear());
    }

    /// Waits for an update event and reads the counting direction: just after the peak the
    /// counter counts down. The PWM mode is chosen so that the update, hence the ADC trigger,
    /// falls in the middle of the low-side conduction interval either way (PWM mode 1: high
    /// side on while CNT < CCR, off around the peak; PWM mode 2: the opposite, off around the
    /// valley; RM0440 §28, "PWM mode").
    fn configure_pwm_edge(tim1: &pac::TIM1) -> SampleAt {
        tim1.sr().write(|w| w.uif().clear());
        let mut waited = 0u32;
        while tim1.sr().read().uif().bit_is_clear() {
            waited += 1;
            if waited > 1_000_000 {
                defmt::panic!("TIM1 produces no update event");
            }
        }
        let at = if tim1.cr1().read().dir().is_down() {
            SampleAt::Peak
        } else {
            SampleAt::Valley
        };
        tim1.sr().write(|w| w.uif().clear());
        if let SampleAt::Valley = at {
            tim1.ccmr1_output()
                .write(|w| w.oc1m().pwm_mode2().oc2m().pwm_mode2());
            tim1.ccmr2_output().write(|w| w.oc3m().pwm_mode2());
        }
        at
    }

    /// Pins (UM2516 pin assignment, via the NuttX port; AF numbers from DS12589):
    /// TIM1 outputs to their alternate functions, analog pins to analog mode (their reset
    /// state on the G4 already, RM0440 GPIO chapter), the button as a floating input (the board
    /// provides its level; NuttX configures it floating too).
    fn init_gpio(gpioa: &pac::GPIOA, gpiob: &pac::GPIOB, gpioc: &pac::GPIOC) {
        // Alternate function numbers before the mode switch.
        gpioa
            .afrh()
            .modify(|_, w| w.afrh8().af6().afrh9().af6().afrh10().af6().afrh12().af6());
        gpiob.afrh().modify(|_, w| w.afrh15().af4());
        gpioc.afrh().modify(|_, w| w.afrh13().af4());
        gpioa.ospeedr().modify(|_, w| {
            w.ospeedr8()
                .high_speed()
                .ospeedr9()
                .high_speed()
                .ospeedr10()
                .high_speed()
                .ospeedr12()
                .high_speed()
        });
        gpiob.ospeedr().modify(|_, w| w.ospeedr15().high_speed());
        // PC13 is a backup-domain pin with limited speed/drive (DS12589); it is the board's
        // U low-side input nonetheless.
        gpioc.ospeedr().modify(|_, w| w.ospeedr13().high_speed());

        gpioa.moder().modify(|_, w| {
            w.moder8()
                .alternate()
                .moder9()
                .alternate()
                .moder10()
                .alternate()
                .moder12()
                .alternate()
                // Bus voltage, OPAMP1 (+, out, −), OPAMP2 (−, out, +).
                .moder0()
                .analog()
                .moder1()
                .analog()
                .moder2()
                .analog()
                .moder3()
                .analog()
                .moder5()
                .analog()
                .moder6()
                .analog()
                .moder7()
                .analog()
        });
        gpiob.moder().modify(|_, w| {
            w.moder15()
                .alternate()
                // OPAMP3 (+, out, −).
                .moder0()
                .analog()
                .moder1()
                .analog()
                .moder2()
                .analog()
        });
        gpioc
            .moder()
            .modify(|_, w| w.moder13().alternate().moder10().input());
        gpioc.pupdr().modify(|_, w| w.pupdr10().floating());
    }

    /// OPAMP1..3 in PGA mode, as NuttX configures them for this board (RM0440 §25, PGA mode;
    /// PGA_GAIN "gain 16, input/bias connected to VINM0 or inverting gain"): VINP0 non-inverting input,
    /// VM_SEL = PGA, PGA_GAIN = 0b01011 (gain 16 / −15 with VINM0), high-speed mode, output on
    /// the VOUT pin (OPAINTOEN = 0) which is also the ADC input. Factory trim (USERTRIM = 0).
    /// Enabled in a second write, after the configuration.
    fn init_opamps(opamp: &pac::OPAMP) {
        macro_rules! pga {
            ($csr:expr) => {{
                $csr.write(|w| {
                    w.vp_sel()
                        .vinp0()
                        .vm_sel()
                        .pga()
                        .pga_gain()
                        .gain16_input_vinm0()
                        .opahsm()
                        .high_speed()
                });
                $csr.modify(|_, w| w.opaen().enabled());
            }};
        }
        pga!(opamp.opamp1_csr());
        pga!(opamp.opamp2_csr());
        pga!(opamp.opamp3_csr());
        // Start-up time of the amplifiers (a few µs, DS12589) before anything is sampled.
        cortex_m::asm::delay(SYSCLK_HZ / 100_000);
    }

    /// ADC1 and ADC2 (RM0440 §21: "Deep-power-down mode and ADC voltage regulator",
    /// "Calibration", "Conversion on external trigger", injected channel management):
    /// synchronous clock HCLK/4 = 42.5 MHz (≤ 60 MHz), out of
    /// deep power-down, regulator on, single-ended calibration, enable; then the injected
    /// sequences, hardware-triggered by TIM1_TRGO on its rising edge (JEXTSEL 0, RM0440
    /// "ADC1/2 external triggers for injected channels"):
    ///
    /// * ADC1: JSQ1 = IN3 (OPAMP1 out, phase U), JSQ2 = IN12 (OPAMP3 out, phase W),
    ///   JSQ3 = IN1 (bus divider). Currents first; the slow bus sample last.
    /// * ADC2: JSQ1 = IN3 (OPAMP2 out, phase V), simultaneous with ADC1's first rank.
    ///
    /// Sample times: 6.5 cycles for the amplifier outputs (low impedance; NuttX uses 2.5),
    /// 247.5 cycles for the ~16 kΩ divider. ADC1's end-of-injected-sequence is the control
    /// interrupt; ADC2 has no interrupt.
    fn init_adcs(common: &pac::ADC12_COMMON, adc1: &pac::ADC1, adc2: &pac::ADC2) {
        let both: [&pac::adc1::RegisterBlock; 2] = [adc1, adc2];
        common
            .ccr()
            .modify(|_, w| w.ckmode().sync_div4().dual().independent());
        for adc in both {
            adc.cr().modify(|_, w| w.deeppwd().disabled());
            adc.cr().modify(|_, w| w.advregen().enabled());
        }
        // t_ADCVREG_STUP = 20 µs (DS12589).
        cortex_m::asm::delay(SYSCLK_HZ / 1_000_000 * 25);
        for adc in both {
            adc.cr()
                .modify(|_, w| w.adcaldif().clear_bit().adcal().start_calibration());
            while adc.cr().read().adcal().bit_is_set() {}
        }
        // ADEN may not be set within 4 ADC clocks after calibration.
        cortex_m::asm::delay(100);
        for adc in both {
            // 12-bit, right-aligned, injected queue disabled (JSQR written only when idle).
            adc.cfgr()
                .modify(|_, w| w.res().bits12().align().right().jqdis().disabled());
            adc.isr().write(|w| w.adrdy().clear());
            adc.cr().modify(|_, w| w.aden().enabled());
            while adc.isr().read().adrdy().bit_is_clear() {}
        }
        adc1.smpr1()
            .modify(|_, w| w.smp1().cycles247_5().smp3().cycles6_5());
        adc1.smpr2().modify(|_, w| w.smp12().cycles6_5());
        adc2.smpr1().modify(|_, w| w.smp3().cycles6_5());
        // SAFETY: JSQx are 5-bit channel numbers; 3, 12 and 1 are ADC1 inputs IN3 (PA2),
        // IN12 (PB1) and IN1 (PA0) and 3 is ADC2's IN3 (PA6) (DS12589 pin table).
        adc1.jsqr().write(|w| unsafe {
            w.jl()
                .set(2)
                .jextsel()
                .tim1_trgo()
                .jexten()
                .rising_edge()
                .jsq1()
                .bits(3)
                .jsq2()
                .bits(12)
                .jsq3()
                .bits(1)
        });
        // SAFETY: as above.
        adc2.jsqr().write(|w| unsafe {
            w.jl()
                .set(0)
                .jextsel()
                .tim1_trgo()
                .jexten()
                .rising_edge()
                .jsq1()
                .bits(3)
        });
        adc1.ier().write(|w| w.jeosie().enabled());
        for adc in both {
            adc.isr().write(|w| w.jeos().clear().jeoc().clear());
            adc.cr().modify(|_, w| w.jadstart().set_bit());
        }
    }

    /// Averages `OFFSET_SAMPLES` triggered conversions with the bridge off (MOE = 0): the
    /// current channels' zero [LSB] and the bus voltage \[V]. Polls the flags; the control
    /// interrupt is still masked in the NVIC.
    fn measure_offsets(adc1: &pac::ADC1, adc2: &pac::ADC2) -> ([f32; 3], f32) {
        let wait = |adc: &pac::adc1::RegisterBlock| {
            let mut waited = 0u32;
            while adc.isr().read().jeos().bit_is_clear() {
                waited += 1;
                if waited > 10_000_000 {
                    defmt::panic!("no injected conversion: check TIM1 TRGO / ADC setup");
                }
            }
            adc.isr().write(|w| w.jeos().clear().jeoc().clear());
        };
        // Let the amplifiers and the ADCs settle: discard the first conversions.
        for _ in 0..16 {
            wait(adc1);
            wait(adc2);
        }
        let (mut u, mut v, mut w, mut bus) = (0u32, 0u32, 0u32, 0u32);
        for _ in 0..OFFSET_SAMPLES {
            wait(adc1);
            wait(adc2);
            u += u32::from(adc1.jdr1().read().jdata().bits());
            w += u32::from(adc1.jdr2().read().jdata().bits());
            bus += u32::from(adc1.jdr3().read().jdata().bits());
            v += u32::from(adc2.jdr1().read().jdata().bits());
        }
        let n = OFFSET_SAMPLES as f32;
        (
            [u as f32 / n, v as f32 / n, w as f32 / n],
            bus as f32 / n * VOLTS_PER_LSB,
        )
    }

    /// Independent watchdog (RM0440 IWDG chapter): LSI/4, reload `IWDG_RELOAD` ≈ 10 ms; fed only by the
    /// control step.
    fn start_watchdog(iwdg: &pac::IWDG) {
        iwdg.kr().write(|w| w.key().start());
        iwdg.kr().write(|w| w.key().unlock());
        iwdg.pr().write(|w| w.pr().divide_by4());
        iwdg.rlr().write(|w| w.rl().set(IWDG_RELOAD));
        while iwdg.sr().read().bits() != 0 {}
        iwdg.kr().write(|w| w.key().feed());
    }
}
