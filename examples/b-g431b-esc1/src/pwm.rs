//! TIM1: centre-aligned complementary PWM with dead time on the three half-bridges, the
//! update event that paces the control step, and duties → compare registers.

use stm32g4::stm32g431 as pac;

use pmsm_sensorless::svpwm::Duties;

use pmsm_b_g431b_esc1::config::SETTINGS;

/// Half a PWM period in timer clocks (centre-aligned: one period is 2·ARR clocks).
const PWM_ARR: u32 = SETTINGS.tim1_arr;
/// Largest duty loaded into the timer, `SETTINGS.duty_max`: the low-side interval (where
/// the currents are sampled) keeps room for the amplifiers to settle after the dead time
/// and for both samples. The drive's voltage limit is computed from the same value
/// (`PowerStageConfig::duty_max`), so this clamp only catches rounding.
const DUTY_MAX: f32 = SETTINGS.duty_max;

/// Where the update event (and so the current sample) falls in the PWM period; decides
/// how duties map to compare values (see [`configure_pwm_edge`]).
#[derive(Clone, Copy, defmt::Format)]
enum SampleAt {
    /// Counter peak: PWM mode 1, CCR = d·ARR.
    Peak,
    /// Counter valley: PWM mode 2, CCR = (1 − d)·ARR.
    Valley,
}

/// The running timer, owned by the control step.
pub struct Pwm {
    tim1: pac::TIM1,
    sample_at: SampleAt,
}

impl Pwm {
    /// Duties in [0, 1] → CCR1..3 (preload off: they take effect now, see [`init_tim1`]).
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

    /// Main output enable: the six outputs follow the compare registers.
    #[inline(always)]
    pub fn outputs_on(&self) {
        self.tim1.bdtr().modify(|_, w| w.moe().enabled());
    }

    /// See [`outputs_off`].
    #[inline(always)]
    pub fn outputs_off(&self) {
        outputs_off(&self.tim1);
    }
}

/// MOE = 0: all six outputs to their idle (off) level at once (OSSI = 1, idle levels low).
#[inline(always)]
pub fn outputs_off(tim1: &pac::tim1::RegisterBlock) {
    tim1.bdtr().modify(|_, w| w.moe().disabled_idle());
}

/// TIM1: centre-aligned PWM with complementary outputs and dead time (RM0440 §28,
/// "Complementary outputs and dead-time insertion"), TRGO = update event for the ADCs
/// (TIMx_CR2.MMS), repetition counter for the 4 kHz update ("Repetition counter"). Outputs enabled per channel but MOE = 0 with OSSI = 1, so
/// all six pins sit at their idle (inactive = low) level until the drive asks for PWM.
/// Polarities: active high on both CHx and CHxN, as the L6387 inputs need (NuttX port).
pub fn init_tim1(tim1: &pac::TIM1) {
    // SAFETY: CKD 0..2 (`DeadTime::at_least`).
    tim1.cr1().write(|w| unsafe {
        w.cms()
            .center_aligned1()
            .arpe()
            .enabled()
            .ckd()
            .bits(SETTINGS.dead_time.ckd)
    });
    tim1.psc().write(|w| w.psc().set(0));
    tim1.arr().write(|w| w.arr().set(PWM_ARR));
    // Written before the counter starts: RM0440 ("Repetition counter") says the update
    // then falls on the overflow (counter peak). `configure_pwm_edge` checks it and copes either way.
    tim1.rcr().write(|w| w.rep().set(SETTINGS.tim1_rcr));
    // Compare preload off (OCxPE = 0): a CCR written by the step acts at once instead of at
    // the next update one control period later, so the voltage over a period is the one
    // the drive computed last (its `v_ab_last`), less the step's own latency. Price: at
    // most one asymmetric pulse per control period; dead time is still inserted.
    tim1.ccmr1_output()
        .write(|w| w.oc1m().pwm_mode1().oc2m().pwm_mode1());
    tim1.ccmr2_output().write(|w| w.oc3m().pwm_mode1());
    for ccr in [tim1.ccr1(), tim1.ccr2(), tim1.ccr3()] {
        ccr.write(|w| w.ccr().set(PWM_ARR / 2));
    }
    tim1.ccer().write(|w| {
        w.cc1e()
            .enabled()
            .cc1ne()
            .set_bit()
            .cc2e()
            .enabled()
            .cc2ne()
            .set_bit()
            .cc3e()
            .enabled()
            .cc3ne()
            .set_bit()
    });
    // OISx = OISxN = 0 (reset): idle level low on all six outputs.
    // SAFETY: MMS = 0b010 selects "Update" as TRGO, a value defined for this 3-bit field
    // (RM0440 TIMx_CR2; the PAC has no enumeration for it).
    tim1.cr2().write(|w| unsafe { w.mms().bits(0b010) });
    tim1.bdtr().write(|w| {
        w.dtg()
            .set(SETTINGS.dead_time.dtg)
            .ossi()
            .idle_level()
            .ossr()
            .set_bit()
            .moe()
            .disabled_idle()
    });
    // Load PSC/ARR/RCR now; the flag this sets is cleared.
    tim1.egr().write(|w| w.ug().update());
    tim1.sr().write(|w| w.uif().clear());
}

/// Starts the counter (outputs still off: MOE = 0), finds where its update lands, then locks
/// the timer's setup.
pub fn start(tim1: pac::TIM1) -> Pwm {
    tim1.cr1().modify(|_, w| w.cen().enabled());
    let sample_at = configure_pwm_edge(&tim1);
    // Timer setup done: lock the dead time, break and idle-state bits (LOCK level 1,
    // RM0440 TIMx_BDTR). MOE stays writable.
    tim1.bdtr().modify(|_, w| w.lock().level1());
    defmt::info!(
        "TIM1: {=u32} Hz centre-aligned, ARR {=u32}, dead time {=f32} ns (DTG {=u8:#x}, CKD {=u8}), update every {=u32} periods at the counter {}",
        SETTINGS.pwm_hz,
        PWM_ARR,
        SETTINGS.dead_time.ns,
        SETTINGS.dead_time.dtg,
        SETTINGS.dead_time.ckd,
        SETTINGS.pwm_per_step,
        sample_at
    );
    Pwm { tim1, sample_at }
}

/// Waits for an update event and reads the counting direction: just after the peak the
/// counter counts down. The PWM mode is chosen so that the update, hence the ADC trigger,
/// falls in the middle of the low-side conduction interval either way (PWM mode 1: high
/// side on while CNT < CCR, off around the peak; PWM mode 2: the opposite, off around the
/// valley; RM0440 §28, "PWM mode").
fn configure_pwm_edge(tim1: &pac::TIM1) -> SampleAt {
    tim1.sr().write(|w| w.uif().clear());
    let mut waited = 0u32;
    while tim1.sr().read().uif().bit_is_clear() {
        waited += 1;
        if waited > 1_000_000 {
            defmt::panic!("TIM1 produces no update event");
        }
    }
    let at = if tim1.cr1().read().dir().is_down() {
        SampleAt::Peak
    } else {
        SampleAt::Valley
    };
    tim1.sr().write(|w| w.uif().clear());
    if let SampleAt::Valley = at {
        tim1.ccmr1_output()
            .write(|w| w.oc1m().pwm_mode2().oc2m().pwm_mode2());
        tim1.ccmr2_output().write(|w| w.oc3m().pwm_mode2());
    }
    at
}

/// USB-C dead-battery behaviour off (RM0440 PWR_CR3.UCPD1_DBDIS): its DBCC pins are
/// PA9/PA10 (DS12589), the V and W high-side outputs here.
pub fn release_dead_battery_pins(pwr: &pac::PWR) {
    pwr.cr3().modify(|_, w| w.ucpd1_dbdis().set_bit());
}

/// TIM1's six outputs to their alternate functions (UM2516 pin assignment, via the NuttX
/// port; AF numbers from DS12589).
pub fn init_pins(gpioa: &pac::GPIOA, gpiob: &pac::GPIOB, gpioc: &pac::GPIOC) {
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
