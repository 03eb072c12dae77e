//! Analog front end: the shunt amplifiers (OPAMP1..3 in PGA mode), ADC1/ADC2 injected
//! conversions triggered by TIM1 (the phase-voltage dividers on ADC2, [`crate::bemf`]), the
//! current offsets measured at start-up, and the scaling of raw codes to amperes and volts.
//! The converters are any references to their register blocks: the firmware's `pac::ADC1`
//! and `pac::ADC2`, zeroed blocks in the host tests (`init_tests::analog`).

use core::ops::Deref;

use stm32g4::stm32g431 as pac;

use pmsm_sensorless::frames::{Abc, AlphaBeta};

use crate::bemf;
use crate::config::SETTINGS;
use crate::hw::{wait_for, Hw, InitError, Wait, POLLS_MAX};

/// An ADC's register block (ADC1 and ADC2 share it).
pub type AdcRegs = pac::adc1::RegisterBlock;

/// Phase current per ADC count \[A/LSB] (about −0.0294; `BoardConfig::ESC1` names the
/// shunt, gain and reference, all UNVERIFIED against UM2516's schematic; the sign
/// convention, positive = into the motor, must be checked on the bench: in `Align` the
/// telemetry's `i_d` must come out positive).
const AMPS_PER_LSB: f32 = SETTINGS.amps_per_lsb;
/// Bus voltage per ADC count \[V/LSB] (about 0.0084).
const VOLTS_PER_LSB: f32 = SETTINGS.volts_per_lsb;
/// SYSCLK \[Hz], for busy-wait delays.
const SYSCLK_HZ: u32 = SETTINGS.sysclk_hz;
/// Conversions averaged for the current offsets at start-up, PWM off.
const OFFSET_SAMPLES: u32 = 1024;
/// A measured offset outside this window means the amplifier path is not working
/// (floating or saturated output); the firmware then refuses to start.
const OFFSET_WINDOW_LSB: (f32, f32) = (512.0, 3584.0);

/// One period's conversions, scaled.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Phase currents \[A] (positive into the motor); NaN in V if ADC2's is missing.
    pub i_abc: Abc,
    /// Bus voltage \[V].
    pub v_bus: f32,
    /// The NTC's reading \[LSB].
    pub ntc_raw: f32,
    /// The terminal voltage from the phase-voltage dividers \[V] ([`bemf::terminal_v_ab`]:
    /// NaN if clipped or if ADC2's sequence is missing); meaningful only with the PWM off.
    pub v_ab_terminal: AlphaBeta,
}

/// The running converters and the measured offsets, owned by the control step.
pub struct Adc<A1: Deref<Target = AdcRegs>, A2: Deref<Target = AdcRegs>> {
    adc1: A1,
    adc2: A2,
    /// Current-channel offsets U, V, W \[LSB], measured with PWM off.
    offsets: [f32; 3],
}

impl<A1: Deref<Target = AdcRegs>, A2: Deref<Target = AdcRegs>> Adc<A1, A2> {
    /// This period's sample. Acknowledges the interrupt.
    #[inline(always)]
    pub fn read(&mut self) -> Sample {
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
        let missing = if adc2_done { 0.0 } else { f32::NAN };
        let raw_phase = [
            f32::from(self.adc2.jdr2().read().jdata().bits()) + missing,
            f32::from(self.adc2.jdr3().read().jdata().bits()) + missing,
            f32::from(self.adc2.jdr4().read().jdata().bits()) + missing,
        ];
        Sample {
            i_abc: Abc::new(
                (raw_u - self.offsets[0]) * AMPS_PER_LSB,
                (raw_v - self.offsets[1]) * AMPS_PER_LSB + missing,
                (raw_w - self.offsets[2]) * AMPS_PER_LSB,
            ),
            v_bus: raw_bus * VOLTS_PER_LSB,
            ntc_raw: raw_ntc,
            v_ab_terminal: bemf::terminal_v_ab(raw_phase, SETTINGS.bemf_volts_per_lsb),
        }
    }

    /// The current offsets U, V, W measured at start-up \[LSB].
    pub fn offsets(&self) -> [f32; 3] {
        self.offsets
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
fn acknowledge(adc: &AdcRegs) {
    adc.isr().write(|w| w.jeos().clear().jeoc().clear());
}

/// The analog pins to analog mode (their reset state on the G4 already, RM0440 GPIO chapter):
/// bus voltage, OPAMP1 (+, out, −), OPAMP2 (−, out, +), OPAMP3 (+, out, −), the NTC (PB14),
/// the phase-voltage dividers (PA4, PC4, PB11); GPIO_BEMF (PB5) a push-pull output driven
/// low: the dividers' lower resistors to ground, the dividers on ([`crate::bemf`]).
pub fn init_pins(
    gpioa: &pac::gpioa::RegisterBlock,
    gpiob: &pac::gpiob::RegisterBlock,
    gpioc: &pac::gpioc::RegisterBlock,
) {
    // The phase-voltage dividers.
    gpioa.moder().modify(|_, w| w.moder4().analog());
    gpioc.moder().modify(|_, w| w.moder4().analog());
    gpiob.moder().modify(|_, w| w.moder11().analog());
    gpiob.odr().modify(|_, w| w.odr5().clear_bit());
    gpiob.otyper().modify(|_, w| w.ot5().clear_bit());
    gpiob.moder().modify(|_, w| w.moder5().output());
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
pub fn init_opamps(opamp: &pac::opamp::RegisterBlock, hw: &mut impl Hw) {
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
    hw.delay_cycles(SYSCLK_HZ / 100_000);
}

/// Sets up and starts both converters (`init_adcs`), then measures the current offsets
/// with the bridge off and refuses to go on if one is implausible. Also returns the
/// over-current comparators' inputs with no current (PA1, PA7, PB0 for U, V, W) \[V] and
/// the NTC's reading \[LSB] and the bus voltage \[V].
pub fn init<A1: Deref<Target = AdcRegs>, A2: Deref<Target = AdcRegs>>(
    common: &pac::adc12_common::RegisterBlock,
    adc1: A1,
    adc2: A2,
    hw: &mut impl Hw,
) -> Result<(Adc<A1, A2>, Start), InitError> {
    let comparator_inputs = init_adcs(common, &adc1, &adc2, hw)?;
    let (offsets, v_bus, ntc_raw) = measure_offsets(&adc1, &adc2, hw)?;
    for o in offsets {
        if !(OFFSET_WINDOW_LSB.0..=OFFSET_WINDOW_LSB.1).contains(&o) {
            return Err(InitError::CurrentOffset(o));
        }
    }
    Ok((
        Adc {
            adc1,
            adc2,
            offsets,
        },
        Start {
            comparator_inputs,
            ntc_raw,
            v_bus,
        },
    ))
}

/// What [`init`] measured besides the offsets.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Start {
    /// The over-current comparators' inputs with no current, U, V, W \[V].
    pub comparator_inputs: [f32; 3],
    /// The NTC's reading \[LSB].
    pub ntc_raw: f32,
    /// The bus voltage \[V].
    pub v_bus: f32,
}

/// Conversions averaged for each comparator input.
const COMPARATOR_SAMPLES: u32 = 64;

/// The average of [`COMPARATOR_SAMPLES`] software-started regular conversions of `channel`
/// \[V] (RM0440 ADC: SQR1.L = 0, one conversion; ADSTART, EOC, DR). Before the injected
/// conversions are started.
fn convert_regular(adc: &AdcRegs, channel: u8, hw: &mut impl Hw) -> Result<f32, InitError> {
    // SAFETY: L = 0 (one conversion); `channel` is one of the ADC's inputs (the callers'
    // pin table).
    adc.sqr1()
        .write(|w| unsafe { w.l().bits(0).sq1().bits(channel) });
    let mut sum = 0u32;
    for _ in 0..COMPARATOR_SAMPLES {
        adc.cr().modify(|_, w| w.adstart().set_bit());
        wait_for(hw, Wait::AdcRegularEnd, POLLS_MAX, || {
            adc.isr().read().eoc().bit_is_set()
        })?;
        // Reading DR clears EOC.
        sum += u32::from(adc.dr().read().rdata().bits());
    }
    Ok(sum as f32 / COMPARATOR_SAMPLES as f32 * SETTINGS.vref_v / 4096.0)
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
/// * ADC2: JSQ1 = IN3 (OPAMP2 out, phase V), simultaneous with ADC1's first rank; then the
///   phase-voltage dividers JSQ2..4 = IN17 (PA4, U), IN5 (PC4, V), IN14 (PB11, W).
///
/// Sample times: 6.5 cycles for the amplifier outputs (low impedance; NuttX uses 2.5),
/// 247.5 cycles for the ~16 kΩ divider, `SETTINGS.bemf_smp` for the phase-voltage dividers
/// (ADC2's sequence ends before ADC1's: `BoardConfig::derive`). ADC1's
/// end-of-injected-sequence is the control interrupt; ADC2 has no interrupt.
fn init_adcs(
    common: &pac::adc12_common::RegisterBlock,
    adc1: &AdcRegs,
    adc2: &AdcRegs,
    hw: &mut impl Hw,
) -> Result<[f32; 3], InitError> {
    let both: [&AdcRegs; 2] = [adc1, adc2];
    // SAFETY: CKMODE 1..3 are the synchronous clocks HCLK/1, /2, /4 (`Settings::adc_ckmode`).
    common
        .ccr()
        .modify(|_, w| unsafe { w.ckmode().bits(SETTINGS.adc_ckmode).dual().independent() });
    for adc in both {
        adc.cr().modify(|_, w| w.deeppwd().disabled());
        adc.cr().modify(|_, w| w.advregen().enabled());
    }
    // t_ADCVREG_STUP = 20 µs (DS12589).
    hw.delay_cycles(SYSCLK_HZ / 1_000_000 * 25);
    for adc in both {
        adc.cr()
            .modify(|_, w| w.adcaldif().clear_bit().adcal().start_calibration());
        wait_for(hw, Wait::AdcCalibrated, POLLS_MAX, || {
            adc.cr().read().adcal().bit_is_clear()
        })?;
    }
    // ADEN may not be set within 4 ADC clocks after calibration.
    hw.delay_cycles(100);
    for adc in both {
        // 12-bit, right-aligned, injected queue disabled (JSQR written only when idle).
        adc.cfgr()
            .modify(|_, w| w.res().bits12().align().right().jqdis().disabled());
        adc.isr().write(|w| w.adrdy().clear());
        adc.cr().modify(|_, w| w.aden().enabled());
        wait_for(hw, Wait::AdcReady, POLLS_MAX, || {
            adc.isr().read().adrdy().bit_is_set()
        })?;
    }
    let (current, bus) = (SETTINGS.current_smp, SETTINGS.bus_smp);
    // SAFETY: SMP codes are 0..7 (checked by `BoardConfig::derive`).
    unsafe {
        adc1.smpr1()
            .modify(|_, w| w.smp1().bits(bus).smp3().bits(current).smp5().bits(bus));
        adc1.smpr2().modify(|_, w| w.smp12().bits(current));
        adc2.smpr1().modify(|_, w| w.smp3().bits(current));
        let phase = SETTINGS.bemf_smp;
        adc2.smpr1().modify(|_, w| w.smp5().bits(phase));
        adc2.smpr2()
            .modify(|_, w| w.smp14().bits(phase).smp17().bits(phase));
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
        convert_regular(adc1, 2, hw)?,
        convert_regular(adc2, 4, hw)?,
        convert_regular(adc1, 15, hw)?,
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
    // SAFETY: as above; 17, 5 and 14 are ADC2's IN17 (PA4), IN5 (PC4) and IN14 (PB11)
    // (`bemf::ADC2_CHANNELS`).
    let [bemf_u, bemf_v, bemf_w] = bemf::ADC2_CHANNELS;
    adc2.jsqr().write(|w| unsafe {
        on_tim1_trgo(w)
            .jl()
            .set(3)
            .jsq1()
            .bits(3)
            .jsq2()
            .bits(bemf_u)
            .jsq3()
            .bits(bemf_v)
            .jsq4()
            .bits(bemf_w)
    });
    adc1.ier().write(|w| w.jeosie().enabled());
    for adc in both {
        acknowledge(adc);
        adc.cr().modify(|_, w| w.jadstart().set_bit());
    }
    Ok(comparator_inputs)
}

/// Averages `OFFSET_SAMPLES` triggered conversions with the bridge off (MOE = 0): the
/// current channels' zero \[LSB], the bus voltage \[V] and the NTC's reading \[LSB]. Polls the
/// flags; the control interrupt is still masked in the NVIC.
fn measure_offsets(
    adc1: &AdcRegs,
    adc2: &AdcRegs,
    hw: &mut impl Hw,
) -> Result<([f32; 3], f32, f32), InitError> {
    let mut wait = |adc: &AdcRegs| {
        wait_for(hw, Wait::AdcInjectedEnd, 10 * POLLS_MAX, || {
            adc.isr().read().jeos().bit_is_set()
        })?;
        acknowledge(adc);
        Ok(())
    };
    // Let the amplifiers and the ADCs settle: discard the first conversions.
    for _ in 0..16 {
        wait(adc1)?;
        wait(adc2)?;
    }
    let (mut u, mut v, mut w, mut bus, mut ntc) = (0u32, 0u32, 0u32, 0u32, 0u32);
    for _ in 0..OFFSET_SAMPLES {
        wait(adc1)?;
        wait(adc2)?;
        u += u32::from(adc1.jdr1().read().jdata().bits());
        w += u32::from(adc1.jdr2().read().jdata().bits());
        bus += u32::from(adc1.jdr3().read().jdata().bits());
        v += u32::from(adc2.jdr1().read().jdata().bits());
        ntc += u32::from(adc1.jdr4().read().jdata().bits());
    }
    let n = OFFSET_SAMPLES as f32;
    Ok((
        [u as f32 / n, v as f32 / n, w as f32 / n],
        bus as f32 / n * VOLTS_PER_LSB,
        ntc as f32 / n,
    ))
}
