//! The hardware over-current trip: COMP1, COMP2 and COMP4 compare the shunt amplifiers'
//! non-inverting inputs (PA1, PA7, PB0: COMPx_INP0, the wiring of ST's reference design for
//! this board) with thresholds from DAC3 (COMP1: DAC3_CH1; COMP2 and COMP4: DAC3_CH2; RM0440
//! COMP chapter, INMSEL = 100) and break TIM1 through BRK2 ([`crate::tim1::AF2`]).
//!
//! The comparator input moves `comp_v_per_a` per ampere (`BoardConfig`) from its level at
//! zero current, which the firmware measures at start-up with the ADC (PA1 = ADC1_IN2,
//! PA7 = ADC2_IN4, PB0 = ADC1_IN15). A low-side shunt carries the phase current only while
//! the low side conducts, and a comparator sees one polarity: it trips on current flowing
//! down through the low side (out of the motor, and every shoot-through); a large current
//! into the motor shows as currents out of it in the other phases.
//!
//! The threshold is `hw_trip_factor` × the drive's software trip (`i_trip_a`): the software
//! names an ordinary over-current from its samples; the hardware catches what falls between
//! two samples (a short, a shoot-through) within the break filter's time.

use crate::config::Settings;

/// COMPx_CSR: enabled, INMSEL = 100 (DAC3: channel 1 for COMP1, channel 2 for COMP2 and
/// COMP4), INPSEL = 0 (INP0: PA1, PA7, PB0), not inverted, hysteresis code `hyst` (0..7:
/// none, 10..70 mV), no blanking, LOCK (read-only until reset).
pub const fn comp_csr(hyst: u32) -> u32 {
    1 | 0b100 << 4 | (hyst & 0b111) << 16 | 1 << 31
}

/// DAC3_MCR: both channels to on-chip peripherals, buffer off (MODEx = 011, DAC3 has no
/// pin), high-frequency interface for an AHB clock above 160 MHz (HFSEL = 10).
pub const DAC3_MCR: u32 = 0b011 | 0b011 << 16 | 0b10 << 14;

/// DAC3_CR: both channels enabled.
pub const DAC3_CR: u32 = 1 | 1 << 16;

/// The DAC code of the threshold for a comparator input at `v0_v` with no current, to trip
/// at `i_trip_a` × the board's `hw_trip_factor`: `(v0 + k·i)/Vref·4096`, rounded up,
/// at most 4095.
pub fn dac_code(s: &Settings, v0_v: f32, i_trip_a: f32) -> u16 {
    let v = v0_v + s.comp_v_per_a * s.hw_trip_factor * i_trip_a;
    let x = (v / s.vref_v * 4096.0).clamp(0.0, 4095.0);
    // Rounded up (the cast truncates a non-negative value).
    let code = x as u16;
    if f32::from(code) < x {
        code + 1
    } else {
        code
    }
}

/// The current a threshold `code` trips at for an input at `v0_v` with no current \[A].
pub fn trip_current_a(s: &Settings, v0_v: f32, code: u16) -> f32 {
    (f32::from(code) * s.vref_v / 4096.0 - v0_v) / s.comp_v_per_a
}
