//! `clocks::init` and `enable_peripherals` on zeroed RCC, PWR and FLASH blocks (RM0440 RCC,
//! PWR, FLASH register maps; the PLL's ranges of DS12589).

use super::{field, peek, Board, Zeroed};
use crate::clocks::{self, ClockSource};
use crate::hw::{InitError, Wait};
use crate::pll::{INPUT_HZ, VCO_HZ};
use stm32g4::stm32g431 as pac;

/// SYSCLK from the PLL word as RM0440 defines it: `f_ref / M × N / R` with M = PLLM + 1,
/// N = PLLN, R = 2·(PLLR + 1), the reference by PLLSRC (2 = HSI16, 3 = HSE); the input and
/// VCO frequencies too.
fn pll_hz(pllcfgr: u32, hse_hz: u32) -> (u32, u32, u32) {
    let f_ref = match field(pllcfgr, 0, 2) {
        2 => 16_000_000,
        3 => hse_hz,
        src => panic!("PLLSRC {src}"),
    };
    let m = field(pllcfgr, 4, 4) + 1;
    let n = field(pllcfgr, 8, 7);
    let r = 2 * (field(pllcfgr, 25, 2) + 1);
    let input = f_ref / m;
    (input, input * n, input * n / r)
}

struct Blocks {
    rcc: Zeroed<pac::rcc::RegisterBlock>,
    pwr: Zeroed<pac::pwr::RegisterBlock>,
    flash: Zeroed<pac::flash::RegisterBlock>,
}

fn blocks() -> Blocks {
    Blocks {
        rcc: Zeroed::new(),
        pwr: Zeroed::new(),
        flash: Zeroed::new(),
    }
}

/// From the crystal: 8 MHz / 2 × 85 / 2 = 170 MHz, the PLL input (4 MHz) and VCO (340 MHz)
/// within DS12589's ranges; 4 flash wait states (RM0440: HCLK ≤ 34 MHz per wait state in
/// range 1 boost) with prefetch and caches; range 1 boost (R1MODE = 0); SYSCLK = PLL with
/// HCLK = PCLK1 = PCLK2 (HPRE restored to /1 after the switch).
#[test]
fn pll_from_the_crystal() {
    let b = blocks();
    let mut hw = Board {
        rcc: Some(b.rcc.rb()),
        hse_starts: true,
        ..Board::default()
    };
    let source = clocks::init(b.rcc.rb(), b.pwr.rb(), b.flash.rb(), &mut hw);
    assert_eq!(source, Ok(ClockSource::Hse));

    let acr = peek(b.flash.rb().acr());
    assert_eq!(field(acr, 0, 4), 4, "LATENCY");
    assert_eq!(field(acr, 0, 4), (170_000_000 - 1) / 34_000_000);
    assert_eq!(field(acr, 8, 3), 0b111, "PRFTEN, ICEN, DCEN");

    let pllcfgr = peek(b.rcc.rb().pllcfgr());
    assert_eq!(field(pllcfgr, 0, 2), 3, "PLLSRC = HSE");
    assert_eq!(field(pllcfgr, 24, 1), 1, "PLLREN");
    assert_eq!(field(pllcfgr, 16, 1), 0, "PLLPEN off");
    assert_eq!(field(pllcfgr, 20, 1), 0, "PLLQEN off");
    let (input, vco, out) = pll_hz(pllcfgr, 8_000_000);
    assert_eq!((input, vco, out), (4_000_000, 340_000_000, 170_000_000));
    assert!((INPUT_HZ.0..=INPUT_HZ.1).contains(&input));
    assert!((VCO_HZ.0..=VCO_HZ.1).contains(&vco));
    // N within 8..127 (RM0440 PLLN).
    assert!((8..=127).contains(&field(pllcfgr, 8, 7)));

    let cr = peek(b.rcc.rb().cr());
    assert_eq!(field(cr, 16, 1), 1, "HSEON");
    assert_eq!(field(cr, 24, 1), 1, "PLLON");
    let cfgr = peek(b.rcc.rb().cfgr());
    assert_eq!(field(cfgr, 0, 2), 3, "SW = PLL");
    assert_eq!(field(cfgr, 4, 4), 0, "HPRE /1 again");
    assert_eq!(field(cfgr, 8, 3), 0, "PPRE1 /1");
    assert_eq!(field(cfgr, 11, 3), 0, "PPRE2 /1");
    assert_eq!(
        field(peek(b.pwr.rb().cr5()), 8, 1),
        0,
        "R1MODE = 0: range 1 boost"
    );
    // RM0440 §6.1.5: ≥ 1 µs at HCLK/2 = 85 MHz before the AHB prescaler goes back to /1.
    assert!(hw.delayed.get() >= 85);
}

/// No crystal: 100 polls 1 ms apart (100 ms at HSI16), then HSE off and the PLL from
/// HSI16 / 4 × 85 / 2 = 170 MHz, the same input and VCO.
#[test]
fn hsi16_fallback() {
    let b = blocks();
    let mut hw = Board {
        rcc: Some(b.rcc.rb()),
        ..Board::default()
    };
    let source = clocks::init(b.rcc.rb(), b.pwr.rb(), b.flash.rb(), &mut hw);
    assert_eq!(source, Ok(ClockSource::HsiFallback));
    assert_eq!(
        hw.polls.iter().filter(|w| **w == Wait::HseReady).count(),
        100
    );
    assert!(hw.delayed.get() >= 100 * 16_000, "100 ms at 16 MHz");
    let pllcfgr = peek(b.rcc.rb().pllcfgr());
    assert_eq!(field(pllcfgr, 0, 2), 2, "PLLSRC = HSI16");
    assert_eq!(
        pll_hz(pllcfgr, 8_000_000),
        (4_000_000, 340_000_000, 170_000_000)
    );
    assert_eq!(field(peek(b.rcc.rb().cr()), 16, 1), 0, "HSEON cleared");
}

/// A block nothing drives: the PLL never locks, and `init` returns the named timeout after
/// its bounded polls instead of hanging.
#[test]
fn a_silent_block_does_not_hang() {
    let b = blocks();
    let mut hw = Board {
        rcc: Some(b.rcc.rb()),
        silent: true,
        ..Board::default()
    };
    let r = clocks::init(b.rcc.rb(), b.pwr.rb(), b.flash.rb(), &mut hw);
    assert_eq!(r, Err(InitError::Timeout(Wait::PllReady)));
    assert_eq!(
        hw.polls.iter().filter(|w| **w == Wait::PllReady).count() as u32,
        crate::hw::POLLS_MAX
    );
}

/// The peripheral clocks: GPIOA..C and ADC1/2 on AHB2, TIM1 and SYSCFG (the OPAMPs' and
/// COMPs' registers) on APB2.
#[test]
fn peripheral_clocks() {
    let rcc = Zeroed::<pac::rcc::RegisterBlock>::new();
    clocks::enable_peripherals(rcc.rb());
    let ahb2 = peek(rcc.rb().ahb2enr());
    assert_eq!(field(ahb2, 0, 3), 0b111, "GPIOAEN, GPIOBEN, GPIOCEN");
    assert_eq!(field(ahb2, 13, 1), 1, "ADC12EN");
    let apb2 = peek(rcc.rb().apb2enr());
    assert_eq!(field(apb2, 11, 1), 1, "TIM1EN");
    assert_eq!(field(apb2, 0, 1), 1, "SYSCFGEN");
}
