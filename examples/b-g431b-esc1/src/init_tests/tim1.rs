//! TIM1 on a zeroed block: `pwm::init_tim1`, `pwm::start` (BDTR once, with LOCK), the step's
//! use of MOE around a break, the bootstrap pre-charge, and TIM1's pins (RM0440 TIM1 and
//! GPIO register maps).

use super::{field, peek, poke, Board, Zeroed};
use crate::config::SETTINGS as S;
use crate::hw::{InitError, Wait};
use crate::pwm::{self, SampleAt};
use crate::tim1::{MOE, SR_BREAK_FLAGS};
use pmsm_sensorless::svpwm::Duties;
use stm32g4::stm32g431 as pac;

type Tim1 = Zeroed<pac::tim1::RegisterBlock>;

/// The dead time of a BDTR word and CR1 word by RM0440's formula \[ns]: t_DTS = 2^CKD /
/// f_CK_INT; DTG\[7:5] = 0xx: DTG·t_DTS; 10x: (64 + DTG\[5:0])·2·t_DTS; 110: (32 +
/// DTG\[4:0])·8·t_DTS; 111: (32 + DTG\[4:0])·16·t_DTS.
fn dead_time_ns(bdtr: u32, cr1: u32, f_hz: f64) -> f64 {
    let dtg = field(bdtr, 0, 8);
    let t_dts = f64::from(1u32 << field(cr1, 8, 2)) / f_hz;
    let steps = if dtg >> 7 == 0 {
        f64::from(dtg)
    } else if dtg >> 6 == 0b10 {
        f64::from(64 + (dtg & 0x3F)) * 2.0
    } else if dtg >> 5 == 0b110 {
        f64::from(32 + (dtg & 0x1F)) * 8.0
    } else {
        f64::from(32 + (dtg & 0x1F)) * 16.0
    };
    steps * t_dts * 1e9
}

/// The break filter of a BKF/BK2F code by RM0440's table \[ns] at f_DTS = f_CK_INT (CKD 0).
fn break_filter_ns(code: u32, f_hz: f64) -> f64 {
    let (div, n) = [
        (0, 0),
        (1, 2),
        (1, 4),
        (1, 8),
        (2, 6),
        (2, 8),
        (4, 6),
        (4, 8),
        (8, 6),
        (8, 8),
        (16, 5),
        (16, 6),
        (16, 8),
        (32, 5),
        (32, 6),
        (32, 8),
    ][code as usize];
    f64::from(div * n) / f_hz * 1e9
}

/// `init_tim1`: centre-aligned mode 1 with ARR preloaded, 20 kHz (f = f_CK / (2·ARR)), an
/// update every period (RCR = 1: (RCR + 1)/2 periods), PWM mode 1 with compare preload on
/// every channel, CCRx at half the period, all six outputs enabled active high, TRGO =
/// update; BDTR not yet written; the counter not yet running.
#[test]
fn tim1_base() {
    let t = Tim1::new();
    let tim1 = t.rb();
    pwm::init_tim1(tim1);
    let cr1 = peek(tim1.cr1());
    assert_eq!(field(cr1, 0, 1), 0, "CEN: not yet");
    assert_eq!(field(cr1, 5, 2), 0b01, "CMS centre-aligned 1");
    assert_eq!(field(cr1, 7, 1), 1, "ARPE");
    assert_eq!(field(cr1, 8, 2), 0, "CKD: t_DTS = t_CK_INT");
    assert_eq!(peek(tim1.psc()), 0);
    let arr = peek(tim1.arr());
    assert_eq!(170_000_000 / (2 * arr), 20_000, "f_PWM = f_CK / (2 ARR)");
    assert_eq!(peek(tim1.rcr()), 1, "an update every (1 + 1)/2 = 1 period");
    let ccmr1 = peek(tim1.ccmr1_output());
    for (oc_m, oc_pe, name) in [(4, 3, "OC1"), (12, 11, "OC2")] {
        assert_eq!(field(ccmr1, oc_m, 3), 0b110, "{name}M PWM mode 1");
        assert_eq!(field(ccmr1, oc_pe, 1), 1, "{name}PE");
    }
    assert_eq!(field(ccmr1, 16, 1) | field(ccmr1, 24, 1), 0, "OCxM[3]");
    assert_eq!(field(ccmr1, 0, 2) | field(ccmr1, 8, 2), 0, "CCxS output");
    let ccmr2 = peek(tim1.ccmr2_output());
    assert_eq!(field(ccmr2, 4, 3), 0b110, "OC3M PWM mode 1");
    assert_eq!(field(ccmr2, 3, 1), 1, "OC3PE");
    for ccr in [tim1.ccr1(), tim1.ccr2(), tim1.ccr3()] {
        assert_eq!(peek(ccr), arr / 2, "zero volts");
    }
    let ccer = peek(tim1.ccer());
    for ch in 0..3 {
        assert_eq!(
            field(ccer, 4 * ch, 4),
            0b0101,
            "CC{}E, CC{}NE, active high",
            ch + 1,
            ch + 1
        );
    }
    assert_eq!(field(peek(tim1.cr2()), 4, 3), 0b010, "MMS: TRGO = update");
    assert_eq!(field(peek(tim1.cr2()), 8, 6), 0, "idle levels low");
    assert_eq!(peek(tim1.bdtr()), 0, "BDTR waits for start");
    assert_eq!(peek(tim1.egr()) & 1, 1, "UG: the values loaded");
}

/// `start`: BDTR written once, complete: dead time 800 ns from DTG and CKD (ST's value for this
/// power stage), LOCK level 3, OSSI = OSSR = 1, BRK and BRK2 enabled active high with a
/// ≥ 500 ns filter, AOE = 0 and MOE = 0; BRK2 fed by COMP1, COMP2, COMP4, BRK by nothing
/// but the system break; the counter running; the break flags cleared.
#[test]
fn bdtr_once_with_lock() {
    let t = Tim1::new();
    let tim1 = t.rb();
    pwm::init_tim1(tim1);
    let mut hw = Board {
        tim1: Some(tim1),
        update_at_peak: true,
        ..Board::default()
    };
    let p = pwm::start(tim1, &mut hw).expect("started");
    assert_eq!(p.sample_at(), SampleAt::Peak);
    let cr1 = peek(tim1.cr1());
    assert_eq!(cr1 & 1, 1, "CEN");
    let bdtr = peek(tim1.bdtr());
    let dt = dead_time_ns(bdtr, cr1, 170e6);
    assert!((dt - 800.0).abs() < 0.01, "{dt} ns");
    assert!(dt >= f64::from(crate::config::BoardConfig::ESC1.dead_time_ns) - 1e-6);
    assert_eq!(field(bdtr, 8, 2), 0b11, "LOCK level 3");
    assert_eq!(field(bdtr, 10, 2), 0b11, "OSSI, OSSR");
    assert_eq!(field(bdtr, 12, 2), 0b11, "BKE, BKP active high");
    assert_eq!(field(bdtr, 14, 2), 0, "AOE = 0, MOE = 0");
    assert_eq!(field(bdtr, 24, 2), 0b11, "BK2E, BK2P active high");
    assert_eq!(field(bdtr, 26, 4), 0, "no bidirectional break, no disarm");
    for lo in [16, 20] {
        let f = break_filter_ns(field(bdtr, lo, 4), 170e6);
        assert!((500.0..600.0).contains(&f), "BKF/BK2F {f} ns");
    }
    assert_eq!(peek(tim1.af1()), 0, "BRK: no pin, no comparator");
    let af2 = peek(tim1.af2());
    assert_eq!(field(af2, 0, 1), 0, "BKIN2 pin off");
    assert_eq!(field(af2, 1, 4), 0b1011, "BK2CMP1E, BK2CMP2E, BK2CMP4E");
    assert_eq!(field(af2, 9, 4), 0, "comparators not inverted");
    assert_eq!(peek(tim1.sr()) & SR_BREAK_FLAGS, 0, "break flags cleared");
    // The update falls at the peak: PWM mode 1 stays.
    assert_eq!(field(peek(tim1.ccmr1_output()), 4, 3), 0b110);
}

/// The update found at the valley: PWM mode 2 (before the lock freezes the modes), and the
/// compare values mirrored so that the same duty results.
#[test]
fn update_at_the_valley() {
    let t = Tim1::new();
    let tim1 = t.rb();
    pwm::init_tim1(tim1);
    let mut hw = Board {
        tim1: Some(tim1),
        ..Board::default()
    };
    let p = pwm::start(tim1, &mut hw).expect("started");
    assert_eq!(p.sample_at(), SampleAt::Valley);
    let (c1, c2) = (peek(tim1.ccmr1_output()), peek(tim1.ccmr2_output()));
    assert_eq!(
        (field(c1, 4, 3), field(c1, 12, 3), field(c2, 4, 3)),
        (0b111, 0b111, 0b111)
    );
    p.load(Duties {
        a: 0.25,
        b: 0.5,
        c: 0.75,
    });
    let arr = S.tim1_arr;
    assert_eq!(peek(tim1.ccr1()), arr - arr / 4);
    assert_eq!(peek(tim1.ccr3()), arr - 3 * arr / 4);
}

/// A silent timer (no update ever): `start` returns the named timeout.
#[test]
fn no_update_is_a_named_error() {
    let t = Tim1::new();
    let tim1 = t.rb();
    pwm::init_tim1(tim1);
    let mut hw = Board {
        tim1: Some(tim1),
        silent: true,
        ..Board::default()
    };
    assert!(matches!(
        pwm::start(tim1, &mut hw),
        Err(InitError::Timeout(Wait::Tim1Update))
    ));
}

/// The step after a break: the duties' compare values (d·ARR, clamped at `duty_max`, a NaN
/// to 0), MOE set only while no break is latched; a break (BRK2 flag, MOE cleared by the
/// hardware) is latched, reported, and MOE is not set again by any later step until the
/// fault is cleared. No step rewrites BDTR's locked fields (the word of `start`, MOE aside).
#[test]
fn moe_after_a_break() {
    let t = Tim1::new();
    let tim1 = t.rb();
    pwm::init_tim1(tim1);
    let mut hw = Board {
        tim1: Some(tim1),
        update_at_peak: true,
        ..Board::default()
    };
    let mut p = pwm::start(tim1, &mut hw).expect("started");
    let locked = peek(tim1.bdtr());
    let arr = S.tim1_arr;
    let check_locked = || assert_eq!(peek(tim1.bdtr()) & !MOE, locked, "BDTR rewritten");

    p.load(Duties {
        a: 0.5,
        b: 1.0,
        c: f32::NAN,
    });
    p.outputs_on();
    assert_eq!(peek(tim1.bdtr()) & MOE, MOE);
    assert!(p.outputs_are_on());
    assert_eq!(peek(tim1.ccr1()), arr / 2);
    assert_eq!(
        peek(tim1.ccr2()),
        (S.duty_max * arr as f32) as u32,
        "clamped"
    );
    assert_eq!(peek(tim1.ccr3()), 0, "NaN: high side off");
    check_locked();

    // The comparators trip: B2IF set, MOE cleared by the hardware.
    poke(tim1.sr(), 1 << 8);
    poke(tim1.bdtr(), peek(tim1.bdtr()) & !MOE);
    assert!(p.break_latched());
    assert!(!p.outputs_are_on());
    for _ in 0..3 {
        p.load(Duties::NEUTRAL);
        p.outputs_on();
        assert_eq!(peek(tim1.bdtr()) & MOE, 0, "MOE set again after a break");
        assert!(p.break_latched());
    }
    p.outputs_off();
    check_locked();

    // The flag gone and the fault cleared by the user: the step may switch again.
    poke(tim1.sr(), 0);
    p.clear_break();
    assert_eq!(peek(tim1.sr()) & SR_BREAK_FLAGS, 0, "break flags written 0");
    assert!(!p.break_latched());
    p.outputs_on();
    assert_eq!(peek(tim1.bdtr()) & MOE, MOE);
    check_locked();

    // A break flag still set when the step enables: MOE taken back at once.
    p.outputs_off();
    poke(tim1.sr(), 1 << 7);
    p.outputs_on();
    assert_eq!(peek(tim1.bdtr()) & MOE, 0);
    assert!(p.break_latched());
    check_locked();
}

/// The bootstrap pre-charge: all three low sides on (compare 0 in PWM mode 1: the high sides
/// never on) for `precharge_periods` update periods (1 ms = 20 at 20 kHz), then MOE off and
/// the compare values back at half the period.
#[test]
fn bootstrap_precharge() {
    let t = Tim1::new();
    let tim1 = t.rb();
    pwm::init_tim1(tim1);
    let mut hw = Board {
        tim1: Some(tim1),
        update_at_peak: true,
        ..Board::default()
    };
    let mut p = pwm::start(tim1, &mut hw).expect("started");
    hw.updates.clear();
    p.precharge_bootstrap(S.precharge_periods, &mut hw)
        .expect("pre-charged");
    assert_eq!(S.precharge_periods, 20);
    // The first update loads the zeros (MOE still off); then the periods with MOE on.
    let on: Vec<_> = hw.updates.iter().filter(|u| u.0).collect();
    assert_eq!(on.len() as u32, S.precharge_periods);
    for u in &on {
        assert_eq!((u.1, u.2, u.3), (0, 0, 0), "high sides off");
    }
    assert_eq!(peek(tim1.bdtr()) & MOE, 0, "off after");
    assert!(!p.outputs_are_on());
    for ccr in [tim1.ccr1(), tim1.ccr2(), tim1.ccr3()] {
        assert_eq!(peek(ccr), S.tim1_arr / 2);
    }
}

/// TIM1's pins: PA8/PA9/PA10 (CH1..3) and PA12 (CH2N) on AF6, PB15 (CH3N) and PC13 (CH1N)
/// on AF4, alternate-function mode, high speed; the UCPD dead-battery pull-downs (PA9, PA10)
/// released; the button PC10 a floating input.
#[test]
fn pwm_pins() {
    let a = Zeroed::<pac::gpioa::RegisterBlock>::new();
    let b = Zeroed::<pac::gpiob::RegisterBlock>::new();
    let c = Zeroed::<pac::gpioc::RegisterBlock>::new();
    let pwr = Zeroed::<pac::pwr::RegisterBlock>::new();
    pwm::init_pins(a.rb(), b.rb(), c.rb());
    pwm::init_button(c.rb());
    pwm::release_dead_battery_pins(pwr.rb());
    let (moder_a, afrh_a, ospeed_a) = (
        peek(a.rb().moder()),
        peek(a.rb().afrh()),
        peek(a.rb().ospeedr()),
    );
    for pin in [8, 9, 10, 12] {
        assert_eq!(field(moder_a, 2 * pin, 2), 0b10, "PA{pin} AF mode");
        assert_eq!(field(afrh_a, 4 * (pin - 8), 4), 6, "PA{pin} AF6");
        assert_eq!(field(ospeed_a, 2 * pin, 2), 0b10, "PA{pin} high speed");
    }
    assert_eq!(field(peek(b.rb().moder()), 30, 2), 0b10);
    assert_eq!(field(peek(b.rb().afrh()), 28, 4), 4, "PB15 AF4");
    assert_eq!(field(peek(c.rb().moder()), 26, 2), 0b10);
    assert_eq!(field(peek(c.rb().afrh()), 20, 4), 4, "PC13 AF4");
    assert_eq!(field(peek(c.rb().moder()), 20, 2), 0b00, "PC10 input");
    assert_eq!(field(peek(c.rb().pupdr()), 20, 2), 0b00, "PC10 floating");
    assert_eq!(field(peek(pwr.rb().cr3()), 14, 1), 1, "UCPD1_DBDIS");
}
