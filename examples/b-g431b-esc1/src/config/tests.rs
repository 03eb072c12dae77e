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
    assert_eq!(S.tim1_rcr, 9);
    let update_hz = S.sysclk_hz / (S.tim1_arr * (u32::from(S.tim1_rcr) + 1));
    assert_eq!(update_hz, S.control_hz);
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
    // 1 − 2·(t_dead + settle)·f_pwm.
    let expected = 1.0 - 2.0 * (S.dead_time.ns + 1300.0) * 1e-9 * 20_000.0;
    assert!((S.duty_max - expected).abs() < 1e-6, "{}", S.duty_max);
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

/// The drive is told the board's rate, PWM frequency, dead time and largest duty, and its
/// voltage limit keeps every duty it computes within `[1 − d_max, d_max]`: the board's
/// clamp never cuts one.
#[test]
fn drive_told_the_same() {
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
