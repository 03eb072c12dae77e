//! TIM2's PWM-input mode and PA15 on zeroed blocks (RM0440 TIM2..5, GPIO and RCC register
//! maps), and the polled capture on flags set as the timer would.

use super::{field, peek, poke, Zeroed};
use crate::config::SETTINGS as S;
use crate::servo::{Capture, PulseCapture};
use crate::servo_capture::{self, ServoCapture, TICK_HZ};
use stm32g4::stm32g431 as pac;

/// The counter at 1 MHz from SYSCLK (APB1 /1), 32 bits free-running; IC1 = TI1 rising
/// (period), IC2 = TI1 falling (width), both filtered 8 samples at f_DTS/32; the slave
/// controller resets on TI1FP1; counting; TIM2's clock on; PA15 in AF1 with a pull-down.
#[test]
fn tim2_pwm_input() {
    let rcc = Zeroed::<pac::rcc::RegisterBlock>::new();
    let gpioa = Zeroed::<pac::gpioa::RegisterBlock>::new();
    let tim2 = Zeroed::<pac::tim2::RegisterBlock>::new();
    servo_capture::init(rcc.rb(), gpioa.rb(), tim2.rb());
    let t = tim2.rb();

    let psc = peek(t.psc());
    assert_eq!(S.sysclk_hz / (psc + 1), TICK_HZ);
    assert_eq!(S.sysclk_hz % (psc + 1), 0, "exact µs ticks");
    assert_eq!(peek(t.arr()), u32::MAX);

    let ccmr1 = peek(t.ccmr1_input());
    assert_eq!(field(ccmr1, 0, 2), 0b01, "CC1S: IC1 on TI1");
    assert_eq!(field(ccmr1, 8, 2), 0b10, "CC2S: IC2 on TI1");
    assert_eq!(field(ccmr1, 4, 4), 0b1111, "IC1F");
    assert_eq!(field(ccmr1, 12, 4), 0b1111, "IC2F");
    // IC1F = 1111: f_SAMPLING = f_DTS/32, N = 8 (CKD = 0: f_DTS = f_CK_INT).
    let filter_us = 8.0 * 32.0 / f64::from(S.sysclk_hz) * 1e6;
    assert!(filter_us < 2.0 && filter_us > 1.0, "{filter_us} µs");
    assert_eq!(field(peek(t.cr1()), 8, 2), 0, "CKD");

    let ccer = peek(t.ccer());
    assert_eq!(field(ccer, 0, 4), 0b0001, "CC1E, rising (CC1P = CC1NP = 0)");
    assert_eq!(
        field(ccer, 4, 4),
        0b0011,
        "CC2E, falling (CC2P = 1, CC2NP = 0)"
    );

    let smcr = peek(t.smcr());
    let ts = field(smcr, 4, 3) | field(smcr, 20, 2) << 3;
    let sms = field(smcr, 0, 3) | field(smcr, 16, 1) << 3;
    assert_eq!(ts, 0b00101, "TS: TI1FP1");
    assert_eq!(sms, 0b0100, "SMS: reset mode");

    assert_eq!(field(peek(t.egr()), 0, 1), 1, "UG: prescaler loaded");
    assert_eq!(field(peek(t.cr1()), 0, 1), 1, "CEN");
    assert_eq!(peek(t.dier()), 0, "polled: no interrupt");

    assert_eq!(field(peek(rcc.rb().apb1enr1()), 0, 1), 1, "TIM2EN");
    let g = gpioa.rb();
    assert_eq!(field(peek(g.moder()), 30, 2), 0b10, "PA15 alternate");
    assert_eq!(field(peek(g.afrh()), 28, 4), 1, "PA15 AF1 = TIM2_CH1");
    assert_eq!(field(peek(g.pupdr()), 30, 2), 0b10, "PA15 pull-down");
}

/// The poll: nothing without CC1IF; the first capture dropped (its period counts from the
/// start); then CCR1 = period, CCR2 = width; an overcapture flag cleared.
#[test]
fn capture_poll() {
    let tim2 = Zeroed::<pac::tim2::RegisterBlock>::new();
    let t = tim2.rb();
    let mut cap = ServoCapture::new(t);
    assert_eq!(cap.capture(), None);
    let edge = |period: u32, width: u32, flags: u32| {
        poke(t.ccr1(), period);
        poke(t.ccr2(), width);
        poke(t.sr(), servo_capture::SR_CC1IF | flags);
    };
    edge(3_000_000, 1500, 0);
    assert_eq!(cap.capture(), None, "the first capture");
    edge(20_000, 1500, 0);
    let c = Capture {
        period_us: 20_000,
        width_us: 1500,
    };
    assert_eq!(cap.capture(), Some(c));
    edge(2040, 1900, servo_capture::SR_OVERCAPTURE);
    assert_eq!(
        cap.capture(),
        Some(Capture {
            period_us: 2040,
            width_us: 1900
        })
    );
    assert_eq!(peek(t.sr()) & servo_capture::SR_OVERCAPTURE, 0);
}
