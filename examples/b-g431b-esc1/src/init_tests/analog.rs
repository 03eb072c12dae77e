//! The analog front end on zeroed blocks: the pins (with GPIO_BEMF), the OPAMPs, ADC1/ADC2
//! (clock, calibration, sample times, the injected sequences and their trigger, the
//! sampling window after the low side turns on, A/LSB, V/LSB, the phase-voltage dividers),
//! and the over-current trip's DAC3 and comparators (RM0440 GPIO, OPAMP, ADC, DAC, COMP
//! register maps).

use super::{field, peek, Board, Zeroed};
use crate::adc;
use crate::config::{BoardConfig, SETTINGS as S};
use crate::drive_settings::drive_config;
use crate::hw::{Hw, InitError, Wait};
use crate::overcurrent;
use stm32g4::stm32g431 as pac;

type AdcBlock = Zeroed<pac::adc1::RegisterBlock>;

/// ADC sample times of the SMP codes in ADC clock cycles (RM0440 ADC_SMPRx).
const SMP_CYCLES: [f64; 8] = [2.5, 6.5, 12.5, 24.5, 47.5, 92.5, 247.5, 640.5];

/// The SMP code of `channel` in SMPR1/SMPR2 (3 bits per channel, 0..9 and 10..18).
fn smp(adc: &pac::adc1::RegisterBlock, channel: u32) -> u32 {
    if channel < 10 {
        field(peek(adc.smpr1()), 3 * channel, 3)
    } else {
        field(peek(adc.smpr2()), 3 * (channel - 10), 3)
    }
}

/// The injected sequence of a JSQR word: its channels, JL + 1 of them.
fn jsq(jsqr: u32) -> Vec<u32> {
    let n = field(jsqr, 0, 2) + 1;
    [9, 15, 21, 27][..n as usize]
        .iter()
        .map(|&lo| field(jsqr, lo, 5))
        .collect()
}

/// The analog pins: PA0..3, PA5..7, PB0..2 (bus, op-amps), PB14 (NTC), PA4, PC4, PB11 (the
/// phase-voltage dividers) in analog mode; PB5 (GPIO_BEMF) a push-pull output driven low,
/// which connects the dividers' lower resistors to ground.
#[test]
fn analog_pins_and_gpio_bemf() {
    let a = Zeroed::<pac::gpioa::RegisterBlock>::new();
    let b = Zeroed::<pac::gpiob::RegisterBlock>::new();
    let c = Zeroed::<pac::gpioc::RegisterBlock>::new();
    adc::init_pins(a.rb(), b.rb(), c.rb());
    let (ma, mb, mc) = (
        peek(a.rb().moder()),
        peek(b.rb().moder()),
        peek(c.rb().moder()),
    );
    for pin in [0, 1, 2, 3, 4, 5, 6, 7] {
        assert_eq!(field(ma, 2 * pin, 2), 0b11, "PA{pin} analog");
    }
    for pin in [0, 1, 2, 11, 14] {
        assert_eq!(field(mb, 2 * pin, 2), 0b11, "PB{pin} analog");
    }
    assert_eq!(field(mc, 8, 2), 0b11, "PC4 analog");
    assert_eq!(field(mb, 10, 2), 0b01, "PB5 output");
    assert_eq!(field(peek(b.rb().otyper()), 5, 1), 0, "PB5 push-pull");
    assert_eq!(field(peek(b.rb().odr()), 5, 1), 0, "PB5 low: dividers on");
}

/// OPAMP1..3: enabled, VINP0, PGA mode with the gain code 01011 (gain 16, RM0440 PGA_GAIN:
/// 2^(code[2:0] + 1)), high-speed, output on the pin (the ADC's input), factory trim; then
/// the amplifiers' start-up time before any conversion.
#[test]
fn opamps() {
    let o = Zeroed::<pac::opamp::RegisterBlock>::new();
    let mut hw = Board::default();
    adc::init_opamps(o.rb(), &mut hw);
    for w in [
        peek(o.rb().opamp1_csr()),
        peek(o.rb().opamp2_csr()),
        peek(o.rb().opamp3_csr()),
    ] {
        assert_eq!(field(w, 0, 1), 1, "OPAEN");
        assert_eq!(field(w, 2, 2), 0b00, "VP_SEL VINP0");
        assert_eq!(field(w, 4, 1), 0, "USERTRIM off");
        assert_eq!(field(w, 5, 2), 0b10, "VM_SEL PGA");
        assert_eq!(field(w, 7, 1), 1, "OPAHSM");
        assert_eq!(field(w, 8, 1), 0, "OPAINTOEN: VOUT pin");
        assert_eq!(field(w, 14, 5), 0b01011, "PGA_GAIN");
        assert_eq!(1 << (field(w, 14, 3) + 1), 16, "gain 16");
        assert_eq!(field(w, 31, 1), 0, "not locked");
    }
    // ≥ some µs at 170 MHz.
    assert!(hw.delayed.get() >= 1_700);
}

/// A board whose converters answer: currents at mid-scale plus `di`, the bus at `bus`, the
/// NTC at `ntc`, the phase voltages at `bemf`.
fn answering<'a>(
    adc1: &'a pac::adc1::RegisterBlock,
    adc2: &'a pac::adc1::RegisterBlock,
    offset: u32,
    bus: u32,
    bemf: [u32; 3],
) -> Board<'a> {
    Board {
        adc1: Some(adc1),
        adc2: Some(adc2),
        jdr: [
            [offset, offset, bus, 1741],
            [offset, bemf[0], bemf[1], bemf[2]],
        ],
        dr: 620,
        ..Board::default()
    }
}

/// `adc::init`: the synchronous clock HCLK/4 = 42.5 MHz (≤ 60 MHz), out of deep power-down,
/// regulator on, single-ended calibration, enabled; 12-bit right-aligned; the sample
/// times; both sequences on TIM1_TRGO's rising edge; ADC1's end-of-sequence interrupt; the
/// samples' window after the low side turns on; the offsets, the bus, A/LSB, V/LSB and the
/// terminal voltage of the phase-voltage dividers from the converted codes.
#[test]
fn adc_init_and_scaling() {
    let (common, a1, a2) = (
        Zeroed::<pac::adc12_common::RegisterBlock>::new(),
        AdcBlock::new(),
        AdcBlock::new(),
    );
    let (adc1, adc2) = (a1.rb(), a2.rb());
    let mut hw = answering(adc1, adc2, 2040, 2850, [0, 0, 0]);
    let (mut conv, start) = adc::init(common.rb(), adc1, adc2, &mut hw).expect("started");

    let ccr = peek(common.rb().ccr());
    assert_eq!(field(ccr, 16, 2), 0b11, "CKMODE HCLK/4");
    assert_eq!(field(ccr, 0, 5), 0, "DUAL independent");
    let f_adc = 170e6 / 4.0;
    assert!(f_adc <= 60e6, "DS12589 f_ADC");
    for adc in [adc1, adc2] {
        let cr = peek(adc.cr());
        assert_eq!(field(cr, 29, 1), 0, "DEEPPWD off");
        assert_eq!(field(cr, 28, 1), 1, "ADVREGEN");
        assert_eq!(field(cr, 30, 1), 0, "ADCALDIF single-ended");
        assert_eq!(field(cr, 3, 1), 1, "JADSTART");
        let cfgr = peek(adc.cfgr());
        assert_eq!(field(cfgr, 3, 2), 0, "RES 12 bits");
        assert_eq!(field(cfgr, 15, 1), 0, "ALIGN right");
        assert_eq!(field(cfgr, 31, 1), 1, "JQDIS");
        let jsqr = peek(adc.jsqr());
        assert_eq!(field(jsqr, 2, 5), 0, "JEXTSEL TIM1_TRGO");
        assert_eq!(field(jsqr, 7, 2), 0b01, "JEXTEN rising");
    }
    // ADEN set before ADRDY is awaited (the ADC sets ADRDY only then): ADC1 at the first
    // poll, ADC2 at the second (each poll records both converters' CR).
    assert_eq!(hw.adc_cr_at_ready.len(), 4);
    for cr in [hw.adc_cr_at_ready[0], hw.adc_cr_at_ready[3]] {
        assert_eq!(field(cr, 0, 1), 1, "ADEN");
        assert_eq!(field(cr, 31, 1), 0, "ADCAL done");
    }
    // t_ADCVREG_STUP = 20 µs at 170 MHz before the calibration.
    assert!(hw.delayed.get() >= 20 * 170);
    assert!(hw.polls.contains(&Wait::AdcCalibrated));
    assert_eq!(jsq(peek(adc1.jsqr())), [3, 12, 1, 5], "U, W, bus, NTC");
    assert_eq!(jsq(peek(adc2.jsqr())), [3, 17, 5, 14], "V, BEMF U, V, W");
    assert_eq!(field(peek(adc1.ier()), 6, 1), 1, "JEOSIE on ADC1");
    assert_eq!(peek(adc2.ier()), 0, "no interrupt on ADC2");
    assert_eq!(
        (smp(adc1, 3), smp(adc1, 12), smp(adc2, 3)),
        (1, 1, 1),
        "6.5 cycles"
    );
    assert_eq!((smp(adc1, 1), smp(adc1, 5)), (6, 6), "247.5 cycles");
    for ch in [17, 5, 14] {
        assert_eq!(smp(adc2, ch), 4, "47.5 cycles on ADC2_IN{ch}");
    }

    // The sampling window (RM0440 conversion time: sample + 12.5 cycles): U and V start at
    // the trigger (the counter peak), W after U; they end before the low side turns off
    // and start at least the settling time after it turned on, at the largest duty.
    let t_conv = |code: u32| (SMP_CYCLES[code as usize] + 12.5) / f_adc * 1e9;
    let w_end_ns = t_conv(smp(adc1, 3)) + SMP_CYCLES[smp(adc1, 12) as usize] / f_adc * 1e9;
    let half_low_ns = (1.0 - f64::from(S.duty_max)) * 0.5e9 / 20e3;
    let dead_ns = 800.0;
    let cfg = BoardConfig::ESC1;
    assert!(
        half_low_ns - dead_ns >= f64::from(cfg.settle_ns) - 0.5,
        "settled before the peak"
    );
    assert!(
        half_low_ns >= w_end_ns,
        "sampled before the low side turns off"
    );
    assert!(
        (w_end_ns - f64::from(S.sample_end_ns)).abs() < 1.0,
        "the settings' window"
    );
    // ADC2's sequence ends before ADC1's, whose end starts the step.
    let seq = |adc: &pac::adc1::RegisterBlock| -> f64 {
        jsq(peek(adc.jsqr()))
            .iter()
            .map(|&ch| t_conv(smp(adc, ch)))
            .sum()
    };
    assert!(seq(adc2) < seq(adc1), "{} vs {} ns", seq(adc2), seq(adc1));

    // Scaling: A/LSB = Vref/4096 / (R_shunt·G), V/LSB = Vref/4096·(R1 + R2)/R2.
    assert_eq!(conv.offsets(), [2040.0; 3]);
    let a_per_lsb = 3.3 / 4096.0 / (0.003 * -9.14);
    let v_per_lsb = 3.3 / 4096.0 * (169e3 + 18e3) / 18e3;
    assert!((f64::from(start.v_bus) - 2850.0 * v_per_lsb).abs() < 1e-3);
    assert!((f64::from(start.comparator_inputs[0]) - 620.0 * 3.3 / 4096.0).abs() < 1e-4);
    assert_eq!(start.ntc_raw, 1741.0);

    // One step's sample: U +100 LSB, V −50, W −50; the phase voltages of a coasting rotor.
    hw.jdr = [[2140, 1990, 2850, 1741], [1990, 400, 1200, 0]];
    hw.poll(Wait::AdcInjectedEnd);
    let s = conv.read();
    assert!((f64::from(s.i_abc.a) - 100.0 * a_per_lsb).abs() < 1e-5);
    assert!((f64::from(s.i_abc.b) + 50.0 * a_per_lsb).abs() < 1e-5);
    assert!((f64::from(s.v_bus) - 2850.0 * v_per_lsb).abs() < 1e-3);
    let k = 3.3 / 4096.0 * (10e3 + 2.2e3) / 2.2e3;
    let (va, vb, vc) = (400.0 * k, 1200.0 * k, 0.0);
    let alpha = (2.0 * va - vb - vc) / 3.0;
    let beta = (vb - vc) / 3f64.sqrt();
    assert!((f64::from(s.v_ab_terminal.alpha) - alpha).abs() < 1e-4);
    assert!((f64::from(s.v_ab_terminal.beta) - beta).abs() < 1e-4);

    // ADC2's sequence missing: V's current and the terminal voltage are not numbers.
    hw.poll(Wait::AdcInjectedEnd);
    super::poke(adc2.isr(), 0);
    let s = conv.read();
    assert!(s.i_abc.b.is_nan() && s.v_ab_terminal.alpha.is_nan());
    assert!(s.i_abc.a.is_finite());
}

/// An offset outside the plausible window (a floating or saturated amplifier) is refused
/// by name; a converter that never ends a conversion too, after its bounded polls.
#[test]
fn adc_refusals() {
    let (common, a1, a2) = (
        Zeroed::<pac::adc12_common::RegisterBlock>::new(),
        AdcBlock::new(),
        AdcBlock::new(),
    );
    let mut hw = answering(a1.rb(), a2.rb(), 4000, 2850, [0; 3]);
    assert!(matches!(
        adc::init(common.rb(), a1.rb(), a2.rb(), &mut hw),
        Err(InitError::CurrentOffset(o)) if o == 4000.0
    ));
    let mut silent = Board {
        silent: true,
        ..Board::default()
    };
    assert!(matches!(
        adc::init(common.rb(), a1.rb(), a2.rb(), &mut silent),
        Err(InitError::Timeout(Wait::AdcCalibrated))
    ));
}

/// The hardware trip: DAC3 both channels to the comparators (MODE 011, HFSEL above
/// 160 MHz), enabled, thresholds `(v0 + k·1.5·i_trip)/Vref·4096` rounded up (COMP2 and
/// COMP4 share channel 2: the higher); COMP1/2/4 enabled on INP0 against DAC3, not
/// inverted, 20 mV hysteresis, locked; the system break sources to BRK, and the HSE's clock
/// security.
#[test]
fn overcurrent_trip() {
    let rcc = Zeroed::<pac::rcc::RegisterBlock>::new();
    let dac3 = Zeroed::<pac::dac1::RegisterBlock>::new();
    let comp = Zeroed::<pac::comp::RegisterBlock>::new();
    let syscfg = Zeroed::<pac::syscfg::RegisterBlock>::new();
    let mut hw = Board::default();
    let v0 = [1.0_f32, 1.1, 1.2];
    let i_trip = drive_config().limits.i_trip_a;
    let trips = overcurrent::init(rcc.rb(), dac3.rb(), comp.rb(), v0, i_trip, &mut hw)
        .expect("comparators low");
    assert_eq!(field(peek(rcc.rb().ahb2enr()), 18, 1), 1, "DAC3EN");
    let mcr = peek(dac3.rb().mcr());
    assert_eq!((field(mcr, 0, 3), field(mcr, 16, 3)), (0b011, 0b011));
    assert_eq!(field(mcr, 14, 2), 0b10, "HFSEL");
    let cr = peek(dac3.rb().cr());
    assert_eq!((field(cr, 0, 1), field(cr, 16, 1)), (1, 1), "EN1, EN2");
    let code = |v: f32| ((v + 0.003 * 9.14 / 16.0 * 1.5 * i_trip) / 3.3 * 4096.0).ceil() as u32;
    assert_eq!(peek(dac3.rb().dhr12r(0)), code(v0[0]));
    assert_eq!(
        peek(dac3.rb().dhr12r(1)),
        code(v0[2]),
        "the higher of V and W"
    );
    for (k, csr) in [comp.rb().c1csr(), comp.rb().c2csr(), comp.rb().c4csr()]
        .into_iter()
        .enumerate()
    {
        let w = peek(csr);
        assert_eq!(field(w, 0, 1), 1, "EN");
        assert_eq!(field(w, 4, 3), 0b100, "INMSEL DAC3");
        assert_eq!(field(w, 8, 1), 0, "INPSEL INP0");
        assert_eq!(field(w, 15, 1), 0, "POL");
        assert_eq!(field(w, 16, 3), 2, "HYST 20 mV");
        assert_eq!(field(w, 19, 5), 0, "no blanking");
        assert_eq!(field(w, 31, 1), 1, "LOCK");
        assert!(trips[k] >= 1.5 * i_trip - 1e-3, "{k}: {} A", trips[k]);
    }
    overcurrent::system_break(syscfg.rb(), rcc.rb(), true);
    let cfgr2 = peek(syscfg.rb().cfgr2());
    assert_eq!(field(cfgr2, 0, 2), 0b11, "CLL, SPL");
    assert_eq!(field(cfgr2, 3, 1), 1, "ECCL");
    assert_eq!(field(peek(rcc.rb().cr()), 19, 1), 1, "CSSON");
}
