//! Clocks: SYSCLK 170 MHz from the PLL (HSE crystal, HSI16 as fallback), and the peripheral
//! clocks the firmware uses.

use stm32g4::stm32g431 as pac;

/// SYSCLK = HCLK = PCLK1 = PCLK2 = TIM1 kernel clock [Hz].
pub const SYSCLK_HZ: u32 = 170_000_000;

#[derive(Clone, Copy, defmt::Format)]
pub enum ClockSource {
    /// 8 MHz HSE crystal → PLL.
    Hse,
    /// HSE did not start: HSI16 → PLL (same 170 MHz, RC accuracy ±1 %).
    HsiFallback,
}

/// SYSCLK = 170 MHz from PLLR, in range 1 boost mode (RM0440 §6.1.5, §7.2.7).
///
/// HSE: the board's 8 MHz crystal (NuttX board port: `STM32_BOARD_XTAL 8000000`, "Y2 on
/// board"; crystal mode, not bypass: UNVERIFIED against UM2516). PLL input 4 MHz
/// (HSE/2 or HSI16/4), VCO ×85 = 340 MHz, R /2 = 170 MHz. If the HSE is not ready
/// within ~100 ms the PLL runs from HSI16 instead (same frequencies, ±1 % accuracy).
pub fn init(rcc: &pac::RCC, pwr: &pac::PWR, flash: &pac::FLASH) -> ClockSource {
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

/// Clocks of GPIOA..C, ADC1/2, TIM1 and the OPAMPs.
pub fn enable_peripherals(rcc: &pac::RCC) {
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
