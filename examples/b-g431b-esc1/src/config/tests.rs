//! Host tests of the derived settings against RM0440's and DS12589's formulas and ranges.

use super::*;
use crate::drive_settings::drive_config;
use crate::pll::{INPUT_HZ, VCO_HZ};
use pmsm_sensorless::frames::AlphaBeta;
use pmsm_sensorless::svpwm::svpwm;

const S: Settings = SETTINGS;

#[test]
fn clocks() {
    for p in [S.pll_hse, S.pll_hsi] {
        assert_eq!(p.out_hz, 170_000_000);
        assert!((INPUT_HZ.0..=INPUT_HZ.1).contains(&p.input_hz));
        assert!((VCO_HZ.0..=VCO_HZ.1).contains(&p.vco_hz));
    }
    assert_eq!(S.flash_wait_states, 4);
    assert_eq!(S.adc_hz, 42_500_000);
    const { assert!(S.adc_hz <= ADC_MAX_HZ) };
    assert_eq!(S.adc_ckmode, 3);
}

/// ARR and RCR give the PWM and control rates: one PWM period is 2·ARR clocks, one update
/// event every (RCR + 1) half periods.
#[test]
fn pwm_and_control_rates() {
    assert_eq!(S.tim1_arr, 4250);
    assert_eq!(S.sysclk_hz / (2 * S.tim1_arr), 20_000);
    // An update (ADC trigger, compare preload transfer) every PWM period; a step every 5th.
    assert_eq!(S.tim1_rcr, 1);
    let update_hz = S.sysclk_hz / (S.tim1_arr * (u32::from(S.tim1_rcr) + 1));
    assert_eq!(update_hz, S.pwm_hz);
    assert_eq!(update_hz / S.pwm_per_step, S.control_hz);
    assert_eq!(S.control_hz, 4000);
}

/// The sampling window: the amplifiers settle for `settle_ns` after the low side turns on
/// at the largest duty, and the two current samples end before it turns off.
#[test]
fn sampling_window() {
    let c = BoardConfig::ESC1;
    // 6.5 + 12.5 + 6.5 cycles at 42.5 MHz.
    assert!((S.sample_end_ns - 600.0).abs() < 0.01);
    let w = S.settle_window_ns(S.duty_max);
    assert!((w - c.settle_ns as f32).abs() < 0.5, "window {w} ns");
    let half_low_ns = (1.0 - S.duty_max) * 0.5e9 / S.pwm_hz as f32;
    assert!(half_low_ns >= S.sample_end_ns);
    // 1 − 2·(t_dead + settle)·f_pwm = 1 − 2·2.1 µs·20 kHz.
    let expected = 1.0 - 2.0 * (S.dead_time.ns + 1300.0) * 1e-9 * 20_000.0;
    assert!((S.duty_max - expected).abs() < 1e-6, "{}", S.duty_max);
    assert!((S.duty_max - 0.916).abs() < 1e-5);
    println!(
        "dead time {} ns, largest duty {}, samples end {} ns after the peak, settle window {} ns",
        S.dead_time.ns,
        S.duty_max,
        S.sample_end_ns,
        S.settle_window_ns(S.duty_max)
    );
}

/// A per LSB and V per LSB: Vref/4096 through the shunt and amplifier, and the divider.
#[test]
fn scaling() {
    let a = 3.3 / 4096.0 / (0.003 * -9.14);
    assert!((S.amps_per_lsb - a).abs() < 1e-7);
    assert!((S.amps_per_lsb + 0.02938).abs() < 1e-4);
    assert!((S.i_adc_range_a - 0.95 * 2048.0 * a.abs()).abs() < 1e-4);
    let v = 3.3 / 4096.0 * 187.0 / 18.0;
    assert!((S.volts_per_lsb - v).abs() < 1e-7);
    // Full scale of the divider: 34.3 V, above the 25.2 V trip.
    const { assert!(4095.0 * S.volts_per_lsb > 34.0) };
}

/// The watchdog: 10 ms at 32 kHz (/4, 80 counts); 9.4..10.8 ms over the LSI's range.
#[test]
fn watchdog() {
    assert_eq!(S.watchdog, Watchdog { pr: 0, rl: 79 });
    assert!((S.watchdog.timeout_ms(LSI_HZ.1) - 10.0).abs() < 1e-3);
    assert!(S.watchdog.timeout_ms(LSI_HZ.2) > 9.4);
    assert!(S.watchdog.timeout_ms(LSI_HZ.0) < 10.9);
    // Longer timeouts take coarser prescalers: 1 s is /8, reload 3999 at 32 kHz.
    assert_eq!(
        Watchdog::for_timeout(1000, 32_000),
        Some(Watchdog { pr: 1, rl: 3999 })
    );
    assert_eq!(Watchdog::for_timeout(40_000, 32_000), None);
}

/// Configurations out of range are refused by name.
#[test]
fn refusals() {
    let bad = |f: fn(&mut BoardConfig)| {
        let mut c = BoardConfig::ESC1;
        f(&mut c);
        c.derive().unwrap_err()
    };
    assert!(bad(|c| c.pwm_hz = 30_001).contains("multiple"));
    assert!(bad(|c| c.dead_time_ns = 30_000).contains("dead"));
    assert!(bad(|c| c.adc_clock_div = 3).contains("adc_clock_div"));
    assert!(bad(|c| c.sysclk_hz = 180_000_000).contains("170"));
    assert!(bad(|c| c.settle_ns = 13_000).contains("no voltage"));
    assert!(bad(|c| c.watchdog_ms = 0).contains("watchdog"));
}

/// The board's dead time: 800 ns, exactly (DTG 0x84, CKD 0).
#[test]
fn dead_time() {
    assert_eq!(
        (S.dead_time.dtg, S.dead_time.ckd, S.dead_time.clocks),
        (0x84, 0, 136)
    );
    assert!((S.dead_time.ns - 800.0).abs() < 0.01);
    assert!((S.dead_time_s() - 800e-9).abs() < 1e-12);
}

/// The drive is told the board's rate, PWM frequency, dead time and largest duty, and its
/// voltage limit keeps every duty it computes within `[1 − d_max, d_max]`: the board's
/// clamp never cuts one.
#[test]
fn drive_told_the_same() {
    // The motor as a user's file would be checked (the link's `SetMotor`, `pmsm-sim
    // --motor-file`): ratings consistent with the parameters.
    if let Err(e) = crate::drive_settings::MOTOR.validate() {
        panic!("the board's motor is refused: {e:?}");
    }
    let cfg = drive_config();
    assert_eq!(cfg.rate_hz, S.control_hz as f32);
    assert_eq!(cfg.power_stage.pwm_hz, S.pwm_hz as f32);
    assert_eq!(cfg.power_stage.dead_time_s, S.dead_time.ns * 1e-9);
    assert_eq!(cfg.power_stage.duty_max, S.duty_max);
    if let Err(e) = cfg.build_flux_primary() {
        panic!("the board's drive is refused: {e:?}");
    }

    // The largest command in every direction plus the largest dead-time compensation
    // (`E` of signs ±1, towards the hexagon's corners), on a 24 V bus.
    let td_f = S.dead_time.ns * 1e-9 * S.pwm_hz as f32;
    let v_bus = 24.0;
    let v_max = v_bus * pmsm_sensorless::math::INV_SQRT3 * (2.0 * S.duty_max - 1.0 - 2.0 * td_f);
    for k in 0..360 {
        let th = k as f32 * core::f32::consts::PI / 180.0;
        for (sa, sb, sc) in [(1.0, -1.0, -1.0), (1.0, 1.0, -1.0), (-1.0, 1.0, 1.0)] {
            let e = AlphaBeta::new(
                td_f * v_bus * (2.0 * sa - sb - sc) / 3.0,
                td_f * v_bus * (sb - sc) / 3.0_f32.sqrt(),
            );
            let v = AlphaBeta::new(v_max * th.cos() + e.alpha, v_max * th.sin() + e.beta);
            let d = svpwm(v, v_bus).duties;
            for x in [d.a, d.b, d.c] {
                assert!(x <= S.duty_max + 1e-5, "{x} at {k} deg");
                assert!(x >= 1.0 - S.duty_max - 1e-5, "{x} at {k} deg");
            }
        }
    }
}

/// TIM1's register words, field by field (RM0440 TIM1 register map).
#[test]
fn tim1_words() {
    use crate::tim1::*;
    let cr1 = cr1(&S);
    assert_eq!((cr1 >> 5) & 0b11, 0b01, "CMS centre-aligned 1");
    assert_eq!((cr1 >> 7) & 1, 1, "ARPE");
    assert_eq!((cr1 >> 8) & 0b11, u32::from(S.dead_time.ckd), "CKD");
    assert_eq!(cr1 & 1, 0, "CEN later");
    for mode in [PWM_MODE_1, PWM_MODE_2] {
        let c1 = ccmr1(mode);
        assert_eq!((c1 >> 4) & 0b111, mode);
        assert_eq!((c1 >> 12) & 0b111, mode);
        assert_eq!((c1 >> 3) & 1, 1, "OC1PE");
        assert_eq!((c1 >> 11) & 1, 1, "OC2PE");
        assert_eq!(c1 & 0b11, 0, "CC1S output");
        assert_eq!((c1 >> 8) & 0b11, 0, "CC2S output");
        assert_eq!(ccmr2(mode), (mode << 4) | 1 << 3);
    }
    assert_eq!(CCER, 0x555);
    assert_eq!(CR2, 0x20);
    assert_eq!(AF2, 0b1_0110);
    let b = bdtr(&S, S.break_filter);
    assert_eq!(b & 0xFF, u32::from(S.dead_time.dtg), "DTG");
    assert_eq!((b >> 8) & 0b11, 3, "LOCK level 3");
    assert_eq!((b >> 10) & 0b11, 0b11, "OSSI, OSSR");
    assert_eq!((b >> 12) & 0b11, 0b11, "BKE, BKP high");
    assert_eq!((b >> 14) & 0b11, 0, "AOE = 0, MOE = 0");
    assert_eq!((b >> 16) & 0xF, S.break_filter, "BKF");
    assert_eq!((b >> 20) & 0xF, S.break_filter, "BK2F");
    assert_eq!((b >> 24) & 0b11, 0b11, "BK2E, BK2P high");
    assert_eq!(b >> 26, 0, "no bidirectional break, no disarm");
    assert_eq!(b & MOE, 0);
}

/// The break filter: the shortest of at least 500 ns is /16 × 6 samples = 565 ns; every
/// request gets the shortest filter at least as long.
#[test]
fn break_filters() {
    use crate::break_filter::{break_filter, BREAK_FILTERS};
    assert_eq!(S.break_filter, 11);
    assert!((S.break_filter_ns - 564.7).abs() < 0.1);
    for ns in (0..2800).step_by(13) {
        let (code, t) = break_filter(ns, S.sysclk_hz);
        if ns as f32 <= 1505.9 {
            assert!(t >= ns as f32 - 1e-3, "{ns} -> {code} {t}");
            for (k, &(d, n)) in BREAK_FILTERS.iter().enumerate().skip(1) {
                let tk = (d * n) as f32 * 1e9 / S.sysclk_hz as f32;
                assert!(
                    tk < ns as f32 - 1e-3 || tk >= t - 1e-3,
                    "{k} shorter than {code}"
                );
            }
        } else {
            assert_eq!(code, 15);
        }
    }
}

/// The comparators' thresholds: the DAC code for the drive's trip, and back.
#[test]
fn over_current_thresholds() {
    use crate::ocp::*;
    let cfg = drive_config();
    let i_trip = cfg.limits.i_trip_a;
    // 3 mΩ × 9.14/16 = 1.714 mV/A; one DAC step (0.806 mV) = 0.47 A.
    assert!((S.comp_v_per_a - 1.714e-3).abs() < 1e-6);
    for v0 in [0.2_f32, 1.0, 1.65, 2.5] {
        let code = dac_code(&S, v0, i_trip);
        let i = trip_current_a(&S, v0, code);
        let lsb_a = S.vref_v / 4096.0 / S.comp_v_per_a;
        assert!(i >= 1.5 * i_trip - 1e-3, "{v0} V: {i} A");
        assert!(i < 1.5 * i_trip + lsb_a + 1e-3, "{v0} V: {i} A");
    }
    let lsb_a = S.vref_v / 4096.0 / S.comp_v_per_a;
    println!(
        "software trip {i_trip} A, hardware trip {} A, comparator {} mV/A, one DAC step {lsb_a} A",
        S.hw_trip_factor * i_trip,
        S.comp_v_per_a * 1e3
    );
    // An input near the top of the range clamps at full scale.
    assert_eq!(dac_code(&S, 3.29, 100.0), 4095);
    let w = comp_csr(2);
    assert_eq!(w & 1, 1, "EN");
    assert_eq!((w >> 4) & 0b111, 0b100, "INMSEL DAC3");
    assert_eq!((w >> 8) & 1, 0, "INPSEL INP0");
    assert_eq!((w >> 15) & 1, 0, "not inverted");
    assert_eq!((w >> 16) & 0b111, 2, "HYST");
    assert_eq!(w >> 31, 1, "LOCK");
    assert_eq!(DAC3_MCR & 0b111, 0b011);
    assert_eq!((DAC3_MCR >> 16) & 0b111, 0b011);
    assert_eq!((DAC3_MCR >> 14) & 0b11, 0b10, "HFSEL above 160 MHz");
}
