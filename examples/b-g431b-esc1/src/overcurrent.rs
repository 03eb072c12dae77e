//! The hardware over-current trip on its registers: DAC3's two thresholds and COMP1, COMP2,
//! COMP4 (the values and the wiring: [`crate::ocp`]); TIM1 routes the
//! comparators to its BRK2 (`pwm::start`), the system break sources to BRK here. Register
//! blocks borrowed: the host tests run these on zeroed ones (`init_tests::analog`).

use crate::config::SETTINGS;
use crate::hw::{Hw, InitError};
use crate::ocp;
use stm32g4::stm32g431 as pac;

/// Comparator hysteresis code (20 mV, RM0440 COMPx_CSR.HYST).
const HYSTERESIS: u32 = 2;

/// DAC3 thresholds for the comparator inputs `v0_v` (U, V, W at zero current \[V]) to trip
/// at `hw_trip_factor` × `i_trip_a`, then the three comparators, locked. COMP2 (V) and COMP4
/// (W) share DAC3_CH2: its threshold is the higher of theirs (neither trips below its
/// current). Returns the trip currents of U, V, W \[A]. A comparator whose output is high
/// with no current (a threshold below its input: a wrong scale or a broken path) is an
/// [`InitError::ComparatorHigh`].
pub fn init(
    rcc: &pac::rcc::RegisterBlock,
    dac3: &pac::dac1::RegisterBlock,
    comp: &pac::comp::RegisterBlock,
    v0_v: [f32; 3],
    i_trip_a: f32,
    hw: &mut impl Hw,
) -> Result<[f32; 3], InitError> {
    rcc.ahb2enr().modify(|_, w| w.dac3en().set_bit());
    let code_u = ocp::dac_code(&SETTINGS, v0_v[0], i_trip_a);
    let code_vw = ocp::dac_code(&SETTINGS, v0_v[1], i_trip_a)
        .max(ocp::dac_code(&SETTINGS, v0_v[2], i_trip_a));
    // SAFETY: the words of `pmsm_b_g431b_esc1::ocp` (host-tested); 12-bit codes.
    unsafe {
        dac3.mcr().write(|w| w.bits(ocp::DAC3_MCR));
        dac3.dhr12r(0).write(|w| w.bits(u32::from(code_u)));
        dac3.dhr12r(1).write(|w| w.bits(u32::from(code_vw)));
        dac3.cr().write(|w| w.bits(ocp::DAC3_CR));
    }
    // DAC wake-up (DS12589 t_WAKEUP, some µs) before a comparator looks at it.
    hw.delay_cycles(SETTINGS.sysclk_hz / 50_000);
    let csr = ocp::comp_csr(HYSTERESIS);
    // SAFETY: as above.
    unsafe {
        comp.c1csr().write(|w| w.bits(csr));
        comp.c2csr().write(|w| w.bits(csr));
        comp.c4csr().write(|w| w.bits(csr));
    }
    // Comparator start-up (DS12589 t_START, some µs).
    hw.delay_cycles(SETTINGS.sysclk_hz / 50_000);
    for (phase, csr) in [comp.c1csr(), comp.c2csr(), comp.c4csr()]
        .into_iter()
        .enumerate()
    {
        if csr.read().value().bit_is_set() {
            return Err(InitError::ComparatorHigh(phase));
        }
    }
    Ok([
        ocp::trip_current_a(&SETTINGS, v0_v[0], code_u),
        ocp::trip_current_a(&SETTINGS, v0_v[1], code_vw),
        ocp::trip_current_a(&SETTINGS, v0_v[2], code_vw),
    ])
}

/// The system break sources to TIM1's BRK (RM0440 SYSCFG_CFGR2: core lockup, SRAM parity
/// error, flash ECC double error), locked until reset; the HSE clock security system (a
/// clock failure is a system break too, and an NMI) when the HSE runs.
pub fn system_break(syscfg: &pac::syscfg::RegisterBlock, rcc: &pac::rcc::RegisterBlock, hse: bool) {
    syscfg
        .cfgr2()
        .modify(|_, w| w.cll().set_bit().spl().set_bit().eccl().set_bit());
    if hse {
        rcc.cr().modify(|_, w| w.csson().set_bit());
    }
}
