//! Clocks: SYSCLK 170 MHz from the PLL (HSE crystal, HSI16 as fallback), and the peripheral
//! clocks the firmware uses (RM0440 RCC, PWR and FLASH chapters). The register blocks are
//! borrowed, so a host test runs these on zeroed ones (`init_tests::clocks`).

use crate::config::SETTINGS;
use crate::hw::{wait_for, Hw, InitError, Wait, POLLS_MAX};
use crate::pll::{SRC_HSE, SRC_HSI16};
use stm32g4::stm32g431 as pac;

/// Polls of HSERDY, one per millisecond at the reset clock (HSI16): the crystal gets 100 ms.
const HSE_POLLS: u32 = 100;
/// One millisecond at the reset clock HSI16 \[cycles].
const HSI16_MS_CYCLES: u32 = 16_000;

/// Where SYSCLK's PLL takes its reference from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockSource {
    /// 8 MHz HSE crystal → PLL.
    Hse,
    /// HSE did not start: HSI16 → PLL (same 170 MHz, RC accuracy ±1 %).
    HsiFallback,
}

/// SYSCLK = 170 MHz from PLLR, in range 1 boost mode (RM0440 §6.1.5, §7.2.7).
///
/// HSE: the board's 8 MHz crystal (NuttX board port: `STM32_BOARD_XTAL 8000000`, "Y2 on
/// board"; crystal mode, not bypass: UNVERIFIED against UM2516). The PLL's dividers are
/// `SETTINGS.pll_hse` / `pll_hsi` (PLL input 4 MHz, HSE/2 or HSI16/4, VCO ×85 = 340 MHz,
/// R /2 = 170 MHz, within DS12589's ranges: host-tested). If the HSE is not ready
/// within ~100 ms the PLL runs from HSI16 instead (same frequencies, ±1 % accuracy).
pub fn init(
    rcc: &pac::rcc::RegisterBlock,
    pwr: &pac::pwr::RegisterBlock,
    flash: &pac::flash::RegisterBlock,
    hw: &mut impl Hw,
) -> Result<ClockSource, InitError> {
    // Flash: 4 wait states for HCLK ≤ 170 MHz in range 1 boost (RM0440 FLASH chapter,
    // "Read access latency", wait states versus HCLK table), prefetch and both caches on,
    // before any frequency increase (more wait states than needed are always safe).
    // SAFETY: LATENCY 0..15 wait states; `flash_wait_states` is 4 at 170 MHz (host-tested).
    flash.acr().modify(|_, w| unsafe {
        w.latency()
            .bits(SETTINGS.flash_wait_states as u8)
            .prften()
            .set_bit()
            .icen()
            .set_bit()
            .dcen()
            .set_bit()
    });
    wait_for(hw, Wait::FlashLatency, POLLS_MAX, || {
        u32::from(flash.acr().read().latency().bits()) == SETTINGS.flash_wait_states
    })?;

    rcc.cr().modify(|_, w| w.hseon().set_bit());
    let mut hse_ready = false;
    for _ in 0..HSE_POLLS {
        hw.poll(Wait::HseReady);
        if rcc.cr().read().hserdy().bit_is_set() {
            hse_ready = true;
            break;
        }
        hw.delay_cycles(HSI16_MS_CYCLES);
    }
    let source = if hse_ready {
        ClockSource::Hse
    } else {
        rcc.cr().modify(|_, w| w.hseon().clear_bit());
        ClockSource::HsiFallback
    };

    // PLL is off after reset; configure, enable, wait for lock.
    let word = match source {
        ClockSource::Hse => SETTINGS.pll_hse.pllcfgr(SRC_HSE),
        ClockSource::HsiFallback => SETTINGS.pll_hsi.pllcfgr(SRC_HSI16),
    };
    // SAFETY: the word's fields are within their ranges (`Pll::exact`, `Pll::pllcfgr`:
    // host-tested field by field); the PLL is off.
    rcc.pllcfgr().write(|w| unsafe { w.bits(word) });
    rcc.cr().modify(|_, w| w.pllon().set_bit());
    wait_for(hw, Wait::PllReady, POLLS_MAX, || {
        rcc.cr().read().pllrdy().bit_is_set()
    })?;

    // Range 1 boost (R1MODE = 0) is needed above 150 MHz. RM0440 §6.1.5 (and §7.2.7 for
    // the AHB prescaler): (1) halve HCLK with the AHB prescaler, (2) clear R1MODE,
    // (3) wait states for the target (done above), (4) switch SYSCLK, (5) after ≥ 1 µs
    // restore the AHB prescaler.
    rcc.cfgr().modify(|_, w| w.hpre().div2());
    pwr.cr5().modify(|_, w| w.r1mode().clear_bit());
    // APB1 = APB2 = HCLK (reset value, written for clarity); SYSCLK = PLLR.
    rcc.cfgr()
        .modify(|_, w| w.ppre1().div1().ppre2().div1().sw().pll());
    wait_for(hw, Wait::SysclkPll, POLLS_MAX, || {
        rcc.cfgr().read().sws().is_pll()
    })?;
    hw.delay_cycles(200); // > 1 µs at HCLK = 85 MHz
    rcc.cfgr().modify(|_, w| w.hpre().div1());
    Ok(source)
}

/// Clocks of GPIOA..C, ADC1/2, TIM1 and the OPAMPs.
pub fn enable_peripherals(rcc: &pac::rcc::RegisterBlock) {
    rcc.ahb2enr().modify(|_, w| {
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
    rcc.apb2enr()
        .modify(|_, w| w.tim1en().set_bit().syscfgen().set_bit());
}
