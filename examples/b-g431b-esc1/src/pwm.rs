//! TIM1: centre-aligned complementary PWM with dead time on the three half-bridges, the
//! update event that paces the control step, and duties → compare registers (RM0440 TIM1
//! chapter; the register words: [`crate::tim1`]). The timer is any reference to TIM1's
//! register block: the firmware's `pac::TIM1`, a zeroed block in the host tests
//! (`init_tests::tim1`), which run every function here and assert what it wrote.

use core::ops::Deref;

use stm32g4::stm32g431 as pac;

use pmsm_sensorless::svpwm::Duties;

use crate::config::SETTINGS;
use crate::hw::{wait_for, Hw, InitError, Wait, POLLS_MAX};
use crate::tim1;

/// TIM1's register block.
pub type Tim1Regs = pac::tim1::RegisterBlock;

/// Half a PWM period in timer clocks (centre-aligned: one period is 2·ARR clocks).
const PWM_ARR: u32 = SETTINGS.tim1_arr;
/// Largest duty loaded into the timer, `SETTINGS.duty_max`: the low-side interval (where
/// the currents are sampled) keeps room for the amplifiers to settle after the dead time
/// and for both samples. The drive's voltage limit is computed from the same value
/// (`PowerStageConfig::duty_max`), so this clamp only catches rounding.
const DUTY_MAX: f32 = SETTINGS.duty_max;

/// Where the update event (and so the current sample) falls in the PWM period; decides
/// how duties map to compare values (see `configure_pwm_edge`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleAt {
    /// Counter peak: PWM mode 1, CCR = d·ARR.
    Peak,
    /// Counter valley: PWM mode 2, CCR = (1 − d)·ARR.
    Valley,
}

/// The running timer, owned by the control step.
pub struct Pwm<T: Deref<Target = Tim1Regs>> {
    tim1: T,
    sample_at: SampleAt,
    /// MOE set by the step (the outputs follow the compare registers).
    on: bool,
    /// A break cleared MOE: latched until [`Pwm::clear_break`], MOE not set meanwhile.
    tripped: bool,
}

impl<T: Deref<Target = Tim1Regs>> Pwm<T> {
    /// Where the update event falls (found by [`start`]).
    pub fn sample_at(&self) -> SampleAt {
        self.sample_at
    }

    /// Whether the step has set MOE (and no break has cleared it since, as far as
    /// [`Pwm::break_latched`] has seen).
    #[inline(always)]
    pub fn outputs_are_on(&self) -> bool {
        self.on
    }

    /// Duties in [0, 1] → CCR1..3, preloaded: they take effect at the next update event, the
    /// next counter peak ([`crate::tim1`]).
    #[inline(always)]
    pub fn load(&self, d: Duties) {
        let ccr = |x: f32| {
            // High-side on-time in timer counts; the saturating cast maps a NaN to 0
            // (high side off) in both modes.
            let on = (x.clamp(0.0, DUTY_MAX) * PWM_ARR as f32) as u32;
            match self.sample_at {
                SampleAt::Peak => on,
                SampleAt::Valley => PWM_ARR - on,
            }
        };
        self.tim1.ccr1().write(|w| w.ccr().set(ccr(d.a)));
        self.tim1.ccr2().write(|w| w.ccr().set(ccr(d.b)));
        self.tim1.ccr3().write(|w| w.ccr().set(ccr(d.c)));
    }

    /// Main output enable: the six outputs follow the compare registers. Written only when
    /// the outputs are off and no break is latched: a break's MOE = 0 is never undone here.
    #[inline(always)]
    pub fn outputs_on(&mut self) {
        if self.on || self.tripped {
            return;
        }
        self.tim1.bdtr().modify(|_, w| w.moe().set_bit());
        self.on = true;
        // A break between the read and the write of BDTR would be undone by the write:
        // look again, and take MOE back if one came.
        if self.break_seen() {
            outputs_off(&self.tim1);
            self.on = false;
            self.tripped = true;
        }
    }

    /// See [`outputs_off`]. The compare values go back to half the period (zero volts), so
    /// that an enable, whose own duties wait for the next update, starts from them and not
    /// from the duties before the stop.
    #[inline(always)]
    pub fn outputs_off(&mut self) {
        outputs_off(&self.tim1);
        self.on = false;
        self.load(Duties::NEUTRAL);
    }

    /// Whether a break has cleared MOE since the last [`Pwm::clear_break`] (latched).
    #[inline(always)]
    pub fn break_latched(&mut self) -> bool {
        if !self.tripped && self.break_seen() {
            self.tripped = true;
            self.on = false;
        }
        self.tripped
    }

    /// The user cleared the fault: the break flags and the latch cleared. A break still
    /// active sets its flag again at once, and the next sample reports it.
    pub fn clear_break(&mut self) {
        // SAFETY: TIMx_SR is read/clear-by-writing-0: writing 1 elsewhere leaves the other
        // flags as they are.
        self.tim1
            .sr()
            .write(|w| unsafe { w.bits(!tim1::SR_BREAK_FLAGS) });
        self.tripped = false;
    }

    /// A break flag is set (BIF, B2IF or SBIF).
    #[inline(always)]
    fn break_seen(&self) -> bool {
        self.tim1.sr().read().bits() & tim1::SR_BREAK_FLAGS != 0
    }

    /// Bootstrap pre-charge: all three low sides on (compare 0: the high sides never on)
    /// for `periods` PWM periods, then every output off and the compare values back at
    /// half the period. Before the control interrupt is enabled.
    pub fn precharge_bootstrap(&mut self, periods: u32, hw: &mut impl Hw) -> Result<(), InitError> {
        for ccr in [self.tim1.ccr1(), self.tim1.ccr2(), self.tim1.ccr3()] {
            ccr.write(|w| w.ccr().set(self.off_compare()));
        }
        // The preloaded zeros take effect at the next update.
        let on = wait_updates(&self.tim1, 1, hw).and_then(|()| {
            self.outputs_on();
            wait_updates(&self.tim1, periods, hw)
        });
        // Off, the compare values back at half the period (loaded at the next update), also
        // when an update did not come.
        self.outputs_off();
        on.and_then(|()| wait_updates(&self.tim1, 1, hw))
    }

    /// The compare value that keeps the high side off for the whole period.
    fn off_compare(&self) -> u32 {
        match self.sample_at {
            SampleAt::Peak => 0,
            SampleAt::Valley => PWM_ARR,
        }
    }
}

/// MOE = 0: all six outputs to their idle (off) level at once (OSSI = 1, idle levels low).
#[inline(always)]
pub fn outputs_off(tim1: &Tim1Regs) {
    tim1.bdtr().modify(|_, w| w.moe().clear_bit());
}

/// Waits for `n` update events (polling UIF, cleared before each; the update interrupt is
/// not enabled, so UIF may stay set after the last).
fn wait_updates(tim1: &Tim1Regs, n: u32, hw: &mut impl Hw) -> Result<(), InitError> {
    for _ in 0..n {
        tim1.sr().write(|w| w.uif().clear());
        wait_for(hw, Wait::Tim1Update, POLLS_MAX, || {
            tim1.sr().read().uif().bit_is_set()
        })?;
    }
    Ok(())
}

/// TIM1: centre-aligned PWM with complementary outputs and dead time (RM0440 §28,
/// "Complementary outputs and dead-time insertion"), TRGO = update event for the ADCs,
/// repetition counter for an update every PWM period, compare preload on (the words of
/// [`crate::tim1`]). BDTR is not written here: [`start`] writes it once,
/// complete, before the pins are switched to the timer.
/// Polarities: active high on both CHx and CHxN, as the L6387 inputs need (NuttX port).
pub fn init_tim1(tim1: &Tim1Regs) {
    // SAFETY (every `bits` below): the words of `pmsm_b_g431b_esc1::tim1`, each field within
    // its range (host-tested field by field).
    tim1.cr1()
        .write(|w| unsafe { w.bits(tim1::cr1(&SETTINGS)) });
    tim1.psc().write(|w| w.psc().set(0));
    tim1.arr().write(|w| w.arr().set(PWM_ARR));
    // Written before the counter starts: RM0440 ("Repetition counter") says the update
    // then falls on the overflow (counter peak). `configure_pwm_edge` checks it and copes
    // either way.
    tim1.rcr().write(|w| w.rep().set(SETTINGS.tim1_rcr));
    tim1.ccmr1_output()
        .write(|w| unsafe { w.bits(tim1::ccmr1(tim1::PWM_MODE_1)) });
    tim1.ccmr2_output()
        .write(|w| unsafe { w.bits(tim1::ccmr2(tim1::PWM_MODE_1)) });
    for ccr in [tim1.ccr1(), tim1.ccr2(), tim1.ccr3()] {
        ccr.write(|w| w.ccr().set(PWM_ARR / 2));
    }
    tim1.ccer().write(|w| unsafe { w.bits(tim1::CCER) });
    tim1.cr2().write(|w| unsafe { w.bits(tim1::CR2) });
    // Load PSC/ARR/RCR and the compare values now; the flag this sets is cleared.
    tim1.egr().write(|w| w.ug().update());
    tim1.sr().write(|w| w.uif().clear());
}

/// Starts the counter (outputs off: MOE = 0), finds where its update lands and sets the PWM
/// mode for it, routes the comparators to BRK2 and writes BDTR once: dead time, breaks,
/// off-states and LOCK level 3 (RM0440 TIMx_BDTR: the LOCK bits are written once after
/// reset; level 3 freezes the dead time, the breaks, the off-states, the polarities and the
/// output modes; MOE stays writable).
pub fn start<T: Deref<Target = Tim1Regs>>(tim1: T, hw: &mut impl Hw) -> Result<Pwm<T>, InitError> {
    tim1.cr1().modify(|_, w| w.cen().enabled());
    let sample_at = configure_pwm_edge(&tim1, hw)?;
    // SAFETY: the words of `pmsm_b_g431b_esc1::tim1` (host-tested); AF1/AF2 before the lock.
    tim1.af1().write(|w| unsafe { w.bits(tim1::AF1) });
    tim1.af2().write(|w| unsafe { w.bits(tim1::AF2) });
    tim1.bdtr()
        .write(|w| unsafe { w.bits(tim1::bdtr(&SETTINGS, SETTINGS.break_filter)) });
    // SAFETY: as above (SR: clear by writing 0).
    tim1.sr()
        .write(|w| unsafe { w.bits(!tim1::SR_BREAK_FLAGS) });
    Ok(Pwm {
        tim1,
        sample_at,
        on: false,
        tripped: false,
    })
}

/// Waits for an update event and reads the counting direction: just after the peak the
/// counter counts down. The PWM mode is chosen so that the update, hence the ADC trigger,
/// falls in the middle of the low-side conduction interval either way (PWM mode 1: high
/// side on while CNT < CCR, off around the peak; PWM mode 2: the opposite, off around the
/// valley; RM0440 §28, "PWM mode"). Before BDTR's LOCK (level 3 freezes the modes).
fn configure_pwm_edge(tim1: &Tim1Regs, hw: &mut impl Hw) -> Result<SampleAt, InitError> {
    wait_updates(tim1, 1, hw)?;
    let at = if tim1.cr1().read().dir().is_down() {
        SampleAt::Peak
    } else {
        SampleAt::Valley
    };
    if let SampleAt::Valley = at {
        // SAFETY: the words of `pmsm_b_g431b_esc1::tim1` (host-tested).
        tim1.ccmr1_output()
            .write(|w| unsafe { w.bits(tim1::ccmr1(tim1::PWM_MODE_2)) });
        tim1.ccmr2_output()
            .write(|w| unsafe { w.bits(tim1::ccmr2(tim1::PWM_MODE_2)) });
    }
    Ok(at)
}

/// USB-C dead-battery behaviour off (RM0440 PWR_CR3.UCPD1_DBDIS): its DBCC pins are
/// PA9/PA10 (DS12589), the V and W high-side outputs here.
pub fn release_dead_battery_pins(pwr: &pac::pwr::RegisterBlock) {
    pwr.cr3().modify(|_, w| w.ucpd1_dbdis().set_bit());
}

/// TIM1's six outputs to their alternate functions (UM2516 pin assignment, via the NuttX
/// port; AF numbers from DS12589).
pub fn init_pins(
    gpioa: &pac::gpioa::RegisterBlock,
    gpiob: &pac::gpiob::RegisterBlock,
    gpioc: &pac::gpioc::RegisterBlock,
) {
    // Alternate function numbers before the mode switch.
    gpioa
        .afrh()
        .modify(|_, w| w.afrh8().af6().afrh9().af6().afrh10().af6().afrh12().af6());
    gpiob.afrh().modify(|_, w| w.afrh15().af4());
    gpioc.afrh().modify(|_, w| w.afrh13().af4());
    gpioa.ospeedr().modify(|_, w| {
        w.ospeedr8()
            .high_speed()
            .ospeedr9()
            .high_speed()
            .ospeedr10()
            .high_speed()
            .ospeedr12()
            .high_speed()
    });
    gpiob.ospeedr().modify(|_, w| w.ospeedr15().high_speed());
    // PC13 is a backup-domain pin with limited speed/drive (DS12589); it is the board's
    // U low-side input nonetheless.
    gpioc.ospeedr().modify(|_, w| w.ospeedr13().high_speed());

    gpioa.moder().modify(|_, w| {
        w.moder8()
            .alternate()
            .moder9()
            .alternate()
            .moder10()
            .alternate()
            .moder12()
            .alternate()
    });
    gpiob.moder().modify(|_, w| w.moder15().alternate());
    gpioc.moder().modify(|_, w| w.moder13().alternate());
}

/// The user button PC10 as a floating input (the board provides its level; NuttX
/// configures it floating too).
pub fn init_button(gpioc: &pac::gpioc::RegisterBlock) {
    gpioc.moder().modify(|_, w| w.moder10().input());
    gpioc.pupdr().modify(|_, w| w.pupdr10().floating());
}
