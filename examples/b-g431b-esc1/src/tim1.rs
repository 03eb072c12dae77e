//! TIM1's register words (RM0440 TIM1 chapter) as functions of the board's [`Settings`]:
//! the firmware writes exactly these, and the host tests check them field by field.
//!
//! The PWM: centre-aligned mode 1, compare preload on (OCxPE: RM0440 "PWM mode": the
//! preload must be on for PWM, else a compare written mid-period gives an asymmetric, a
//! missing or an extra pulse). A compare value written by the step takes effect at the next
//! update event. The repetition counter makes that update every PWM period at the counter
//! peak (RCR = 1, odd and written before the counter starts: the update falls on the
//! overflow): all three high sides are off there (PWM mode 1: high side on while
//! CNT < CCR), so both edges of every pulse come from one compare value (symmetric pulses,
//! never a missed or a doubled edge), and the duties the step computes from the sample taken
//! at a peak are applied from the next peak, 50 µs later, for one control period (the
//! update is also the ADC trigger: the step runs on every `pwm_per_step`-th sample). With
//! the update only every 5 periods the duties would wait a whole control period (250 µs) for
//! it.
//!
//! The break: BRK (system break: core lockup, SRAM parity, flash ECC, clock failure) and BRK2
//! (the over-current comparators COMP1, COMP2, COMP4) clear MOE in hardware, outputs to
//! their idle level (low: both switches of each half-bridge off); the automatic output
//! enable is off (AOE = 0): only software sets MOE again, and the firmware does so only
//! after the user has cleared the fault. BDTR is written once, complete, with LOCK level 3
//! (dead time, break, off-states, polarities and output modes frozen until reset).

use crate::config::Settings;

/// TIMx_CCMRx.OCxM for PWM mode 1 (active while CNT < CCR).
pub const PWM_MODE_1: u32 = 0b110;
/// TIMx_CCMRx.OCxM for PWM mode 2 (active while CNT > CCR).
pub const PWM_MODE_2: u32 = 0b111;

/// TIMx_CR1: centre-aligned mode 1 (CMS = 01), ARR preloaded (ARPE), the dead-time clock
/// (CKD); the counter not yet enabled.
pub const fn cr1(s: &Settings) -> u32 {
    1 << 5 | 1 << 7 | (s.dead_time.ckd as u32) << 8
}

/// TIMx_CR2: TRGO = update event (MMS = 010: the ADC trigger); idle levels OISx = OISxN = 0
/// (low).
pub const CR2: u32 = 0b010 << 4;

/// TIMx_CCMR1 (output): channels 1 and 2 in PWM mode `mode`, compare preload on (OC1PE,
/// OC2PE).
pub const fn ccmr1(mode: u32) -> u32 {
    mode << 4 | 1 << 3 | mode << 12 | 1 << 11
}

/// TIMx_CCMR2 (output): channel 3 in PWM mode `mode`, compare preload on (OC3PE).
pub const fn ccmr2(mode: u32) -> u32 {
    mode << 4 | 1 << 3
}

/// TIMx_CCER: CH1..3 and CH1N..3N enabled, active high (the L6387's inputs).
pub const CCER: u32 = 1 | 1 << 2 | 1 << 4 | 1 << 6 | 1 << 8 | 1 << 10;

/// TIMx_AF1: nothing on BRK but the system break (BKINE = 0, no comparator).
pub const AF1: u32 = 0;

/// TIMx_AF2: COMP1, COMP2 and COMP4 on BRK2 (BK2CMP1E, BK2CMP2E, BK2CMP4E), not inverted;
/// the BKIN2 pin off (BK2INE = 0).
pub const AF2: u32 = 1 << 1 | 1 << 2 | 1 << 4;

/// TIMx_BDTR, written once: the dead time (DTG), LOCK level 3, OSSI = OSSR = 1 (off-state
/// outputs at their idle level), BRK on, active high (the system break), BRK2 on, active
/// high (the comparators), both filtered (`filter`, BKF and BK2F), AOE = 0, MOE = 0.
pub const fn bdtr(s: &Settings, filter: u32) -> u32 {
    s.dead_time.dtg as u32
        | 0b11 << 8
        | 1 << 10
        | 1 << 11
        | 1 << 12
        | 1 << 13
        | filter << 16
        | filter << 20
        | 1 << 24
        | 1 << 25
}

/// TIMx_BDTR.MOE.
pub const MOE: u32 = 1 << 15;

/// TIMx_SR: break (BIF), break 2 (B2IF) and system break (SBIF) flags.
pub const SR_BREAK_FLAGS: u32 = 1 << 7 | 1 << 8 | 1 << 13;
