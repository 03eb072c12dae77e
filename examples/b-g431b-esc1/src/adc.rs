//! Analog front end: the shunt amplifiers (OPAMP1..3 in PGA mode), ADC1/ADC2 injected
//! conversions triggered by TIM1, the current offsets measured at start-up, and the scaling of
//! raw codes to amperes and volts.

use stm32g4::stm32g431 as pac;

use pmsm_sensorless::frames::Abc;

use pmsm_b_g431b_esc1::config::SETTINGS;

/// Phase current per ADC count [A/LSB] (about −0.0294; `BoardConfig::ESC1` names the
/// shunt, gain and reference, all UNVERIFIED against UM2516's schematic; the sign
/// convention, positive = into the motor, must be checked on the bench: in `Align` the
/// telemetry's `i_d` must come out positive).
const AMPS_PER_LSB: f32 = SETTINGS.amps_per_lsb;
/// Bus voltage per ADC count [V/LSB] (about 0.0084).
const VOLTS_PER_LSB: f32 = SETTINGS.volts_per_lsb;
/// SYSCLK [Hz], for busy-wait delays.
const SYSCLK_HZ: u32 = SETTINGS.sysclk_hz;
/// Conversions averaged for the current offsets at start-up, PWM off.
const OFFSET_SAMPLES: u32 = 1024;
/// A measured offset outside this window means the amplifier path is not working
/// (floating or saturated output); the firmware then refuses to start.
const OFFSET_WINDOW_LSB: (f32, f32) = (512.0, 3584.0);

/// The running converters and the measured offsets, owned by the control step.
pub struct Adc {
    adc1: pac::ADC1,
    adc2: pac::ADC2,
    /// Current-channel offsets U, V, W [LSB], measured with PWM off.
    offsets: [f32; 3],
}

impl Adc {
    /// This period's sample: phase currents [A] (positive into the motor), bus voltage
    /// [V] and the NTC's reading [LSB]. Acknowledges the interrupt. A V phase whose
    /// conversion is missing reads NaN.
    #[inline(always)]
    pub fn read(&mut self) -> (Abc, f32, f32) {
        // Acknowledge the interrupt source first.
        acknowledge(&self.adc1);
        // ADC2 converts one channel against ADC1's three from the same trigger, so it is
        // done; a missing flag means its sample is stale and is reported as invalid.
        let adc2_done = self.adc2.isr().read().jeos().bit_is_set();
        acknowledge(&self.adc2);

        let raw_u = f32::from(self.adc1.jdr1().read().jdata().bits());
        let raw_w = f32::from(self.adc1.jdr2().read().jdata().bits());
        let raw_bus = f32::from(self.adc1.jdr3().read().jdata().bits());
        let raw_v = f32::from(self.adc2.jdr1().read().jdata().bits());
        let raw_ntc = f32::from(self.adc1.jdr4().read().jdata().bits());
        let i_abc = Abc::new(
            (raw_u - self.offsets[0]) * AMPS_PER_LSB,
            if adc2_done {
                (raw_v - self.offsets[1]) * AMPS_PER_LSB
            } else {
                f32::NAN
            },
            (raw_w - self.offsets[2]) * AMPS_PER_LSB,
        );
        (i_abc, raw_bus * VOLTS_PER_LSB, raw_ntc)
    }

    /// Whether ADC1 has completed another injected sequence since [`Adc::read`]
    /// acknowledged the last one.
    #[inline(always)]
    pub fn next_sample_ready(&self) -> bool {
        self.adc1.isr().read().jeos().bit_is_set()
    }

    /// Drops any completed sequence (its flags), so the next interrupt comes from a fresh one.
    pub fn discard(&self) {
        for adc in [&*self.adc1, &*self.adc2] {
            acknowledge(adc);
        }
    }
}

/// Clears an ADC's end-of-injected-sequence and end-of-injected-conversion flags (RM0440
/// ADC_ISR: write 1 to clear).
#[inline(always)]
fn acknowledge(adc: &pac::adc1::RegisterBlock) {
    adc.isr().write(|w| w.jeos().clear().jeoc().clear());
}

/// The analog pins to analog mode (their reset state on the G4 already, RM0440 GPIO chapter):
/// bus voltage, OPAMP1 (+, out, −), OPAMP2 (−, out, +), OPAMP3 (+, out, −), the NTC (PB14).
pub fn init_pins(gpioa: &pac::GPIOA, gpiob: &pac::GPIOB) {
    gpioa.moder().modify(|_, w| {
        w.moder0()
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
    gpiob
        .moder()
        .modify(|_, w| w.moder0().analog().moder1().analog().moder2().analog());
    // The NTC.
    gpiob.moder().modify(|_, w| w.moder14().analog());
}

/// OPAMP1..3 in PGA mode, as NuttX configures them for this board (RM0440 §25, PGA mode;
/// PGA_GAIN "gain 16, input/bias connected to VINM0 or inverting gain"): VINP0 non-inverting input,
/// VM_SEL = PGA, PGA_GAIN = 0b01011 (gain 16 / −15 with VINM0), high-speed mode, output on
/// the VOUT pin (OPAINTOEN = 0) which is also the ADC input. Factory trim (USERTRIM = 0).
/// Enabled in a second write, after the configuration.
pub fn init_opamps(opamp: &pac::OPAMP) {
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

/// Sets up and starts both converters ([`init_adcs`]), then measures the current offsets
/// with the bridge off and refuses to go on if one is implausible. Also returns the
/// over-current comparators' inputs with no current (PA1, PA7, PB0 for U, V, W) \[V] and
/// the NTC's reading \[LSB].
pub fn init(common: &pac::ADC12_COMMON, adc1: pac::ADC1, adc2: pac::ADC2) -> (Adc, [f32; 3], f32) {
    let comparator_inputs = init_adcs(common, &adc1, &adc2);
    let (offsets, v_bus, ntc_raw) = measure_offsets(&adc1, &adc2);
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
    (
        Adc {
            adc1,
            adc2,
            offsets,
        },
        comparator_inputs,
        ntc_raw,
    )
}

/// Conversions averaged for each comparator input.
const COMPARATOR_SAMPLES: u32 = 64;

/// The average of [`COMPARATOR_SAMPLES`] software-started regular conversions of `channel`
/// \[V] (RM0440 ADC: SQR1.L = 0, one conversion; ADSTART, EOC, DR). Before the injected
/// conversions are started.
fn convert_regular(adc: &pac::adc1::RegisterBlock, channel: u8) -> f32 {
    // SAFETY: L = 0 (one conversion); `channel` is one of the ADC's inputs (the callers'
    // pin table).
    adc.sqr1()
        .write(|w| unsafe { w.l().bits(0).sq1().bits(channel) });
    let mut sum = 0u32;
    for _ in 0..COMPARATOR_SAMPLES {
        adc.cr().modify(|_, w| w.adstart().set_bit());
        let mut waited = 0u32;
        while adc.isr().read().eoc().bit_is_clear() {
            waited += 1;
            if waited > 1_000_000 {
                defmt::panic!("no regular conversion");
            }
        }
        // Reading DR clears EOC.
        sum += u32::from(adc.dr().read().rdata().bits());
    }
    sum as f32 / COMPARATOR_SAMPLES as f32 * SETTINGS.vref_v / 4096.0
}

/// ADC1 and ADC2 (RM0440 §21: "Deep-power-down mode and ADC voltage regulator",
/// "Calibration", "Conversion on external trigger", injected channel management):
/// synchronous clock `SETTINGS.adc_hz` (HCLK/4 = 42.5 MHz, ≤ 60 MHz), out of
/// deep power-down, regulator on, single-ended calibration, enable; then the injected
/// sequences, hardware-triggered by TIM1_TRGO on its rising edge (JEXTSEL 0, RM0440
/// "ADC1/2 external triggers for injected channels"):
///
/// * ADC1: JSQ1 = IN3 (OPAMP1 out, phase U), JSQ2 = IN12 (OPAMP3 out, phase W),
///   JSQ3 = IN1 (bus divider), JSQ4 = IN5 (the NTC, PB14). Currents first; the slow
///   samples last.
/// * ADC2: JSQ1 = IN3 (OPAMP2 out, phase V), simultaneous with ADC1's first rank.
///
/// Sample times: 6.5 cycles for the amplifier outputs (low impedance; NuttX uses 2.5),
/// 247.5 cycles for the ~16 kΩ divider. ADC1's end-of-injected-sequence is the control
/// interrupt; ADC2 has no interrupt.
fn init_adcs(common: &pac::ADC12_COMMON, adc1: &pac::ADC1, adc2: &pac::ADC2) -> [f32; 3] {
    let both: [&pac::adc1::RegisterBlock; 2] = [adc1, adc2];
    // SAFETY: CKMODE 1..3 are the synchronous clocks HCLK/1, /2, /4 (`Settings::adc_ckmode`).
    common
        .ccr()
        .modify(|_, w| unsafe { w.ckmode().bits(SETTINGS.adc_ckmode).dual().independent() });
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
    let (current, bus) = (SETTINGS.current_smp, SETTINGS.bus_smp);
    // SAFETY: SMP codes are 0..7 (checked by `BoardConfig::derive`).
    unsafe {
        adc1.smpr1()
            .modify(|_, w| w.smp1().bits(bus).smp3().bits(current).smp5().bits(bus));
        adc1.smpr2().modify(|_, w| w.smp12().bits(current));
        adc2.smpr1().modify(|_, w| w.smp3().bits(current));
    }
    // The comparator inputs (the op-amps' non-inverting inputs), regular conversions of
    // 247.5 cycles (the board's resistor network): PA1 = ADC1_IN2, PA7 = ADC2_IN4,
    // PB0 = ADC1_IN15 (DS12589 pin table, as in ST's stm32duino variant for this board).
    // SAFETY: SMP code 6 = 247.5 cycles.
    unsafe {
        adc1.smpr1().modify(|_, w| w.smp2().bits(6));
        adc1.smpr2().modify(|_, w| w.smp15().bits(6));
        adc2.smpr1().modify(|_, w| w.smp4().bits(6));
    }
    let comparator_inputs = [
        convert_regular(adc1, 2),
        convert_regular(adc2, 4),
        convert_regular(adc1, 15),
    ];
    // Both sequences start on TIM1_TRGO's rising edge.
    fn on_tim1_trgo(w: &mut pac::adc1::jsqr::W) -> &mut pac::adc1::jsqr::W {
        w.jextsel().tim1_trgo().jexten().rising_edge()
    }
    // SAFETY: JSQx are 5-bit channel numbers; 3, 12, 1 and 5 are ADC1 inputs IN3 (PA2),
    // IN12 (PB1), IN1 (PA0) and IN5 (PB14) and 3 is ADC2's IN3 (PA6) (DS12589 pin table).
    adc1.jsqr().write(|w| unsafe {
        on_tim1_trgo(w)
            .jl()
            .set(3)
            .jsq1()
            .bits(3)
            .jsq2()
            .bits(12)
            .jsq3()
            .bits(1)
            .jsq4()
            .bits(5)
    });
    // SAFETY: as above.
    adc2.jsqr()
        .write(|w| unsafe { on_tim1_trgo(w).jl().set(0).jsq1().bits(3) });
    adc1.ier().write(|w| w.jeosie().enabled());
    for adc in both {
        acknowledge(adc);
        adc.cr().modify(|_, w| w.jadstart().set_bit());
    }
    comparator_inputs
}

/// Averages `OFFSET_SAMPLES` triggered conversions with the bridge off (MOE = 0): the
/// current channels' zero [LSB], the bus voltage [V] and the NTC's reading [LSB]. Polls the
/// flags; the control interrupt is still masked in the NVIC.
fn measure_offsets(adc1: &pac::ADC1, adc2: &pac::ADC2) -> ([f32; 3], f32, f32) {
    let wait = |adc: &pac::adc1::RegisterBlock| {
        let mut waited = 0u32;
        while adc.isr().read().jeos().bit_is_clear() {
            waited += 1;
            if waited > 10_000_000 {
                defmt::panic!("no injected conversion: check TIM1 TRGO / ADC setup");
            }
        }
        acknowledge(adc);
    };
    // Let the amplifiers and the ADCs settle: discard the first conversions.
    for _ in 0..16 {
        wait(adc1);
        wait(adc2);
    }
    let (mut u, mut v, mut w, mut bus, mut ntc) = (0u32, 0u32, 0u32, 0u32, 0u32);
    for _ in 0..OFFSET_SAMPLES {
        wait(adc1);
        wait(adc2);
        u += u32::from(adc1.jdr1().read().jdata().bits());
        w += u32::from(adc1.jdr2().read().jdata().bits());
        bus += u32::from(adc1.jdr3().read().jdata().bits());
        v += u32::from(adc2.jdr1().read().jdata().bits());
        ntc += u32::from(adc1.jdr4().read().jdata().bits());
    }
    let n = OFFSET_SAMPLES as f32;
    (
        [u as f32 / n, v as f32 / n, w as f32 / n],
        bus as f32 / n * VOLTS_PER_LSB,
        ntc as f32 / n,
    )
}
