//! The board's power stage as the core sees it ([`PowerStage`]): the sample is the injected
//! conversions ADC1/ADC2 made at TIM1's update, scaled, with a latched break reported by
//! name and, while the outputs are off, the terminal voltage of the phase-voltage dividers
//! (`crate::bemf`: the drive's flying start); applying duties loads TIM1's
//! compare registers and sets MOE (unless a break is latched), applying `None` clears MOE.

use pmsm_sensorless::drive::DriveInput;
use pmsm_sensorless::power_stage::{PowerStage, StageFault};
use pmsm_sensorless::svpwm::Duties;

use stm32g4::stm32g431 as pac;

use pmsm_b_g431b_esc1::adc;
use pmsm_b_g431b_esc1::config::SETTINGS;
use pmsm_b_g431b_esc1::hw::{Hw, InitError};
use pmsm_b_g431b_esc1::ntc::NtcConfig;
use pmsm_b_g431b_esc1::pwm;

/// TIM1 as the firmware owns it.
pub type Pwm = pwm::Pwm<pac::TIM1>;
/// ADC1 and ADC2 as the firmware owns them.
pub type Adc = adc::Adc<pac::ADC1, pac::ADC2>;

/// The board's NTC, its derating and trip.
const NTC: NtcConfig = NtcConfig::ESC1;

/// TIM1's three half-bridges with the shunt and bus sensing of the B-G431B-ESC1.
pub struct Esc1 {
    pwm: Pwm,
    adc: Adc,
    /// The previous step overran its period.
    overrun: bool,
    /// The power stage's temperature, low-pass filtered \[°C].
    temp_c: f32,
    /// The filter's gain per step.
    temp_gain: f32,
    /// The latest unfiltered temperature \[°C].
    temp_now_c: f32,
    /// Over-temperature (or an implausible reading) latched until [`Esc1::clear_faults`].
    hot: bool,
}

impl Esc1 {
    /// The stage of `pwm` and `adc`, its temperature filter started at `temp_c` \[°C].
    pub fn new(pwm: Pwm, adc: Adc, temp_c: f32) -> Self {
        Self {
            pwm,
            adc,
            overrun: false,
            temp_c,
            temp_gain: NTC.filter_gain(SETTINGS.control_hz as f32),
            temp_now_c: temp_c,
            hot: false,
        }
    }

    /// The power stage's temperature, filtered \[°C].
    #[inline(always)]
    pub fn temp_c(&self) -> f32 {
        self.temp_c
    }

    /// The share of the speed command the temperature leaves ([`NtcConfig::speed_scale`]).
    #[inline(always)]
    pub fn speed_scale(&self) -> f32 {
        NTC.speed_scale(self.temp_c)
    }

    /// Drops any sequence that completed before the control interrupt is enabled.
    pub fn discard_samples(&self) {
        self.adc.discard();
    }

    /// A sample the step does not use (the ADC converts every PWM period, the step runs on
    /// every `pwm_per_step`-th): its flags cleared.
    #[inline(always)]
    pub fn skip_sample(&self) {
        self.adc.discard();
    }

    /// The user cleared the fault: the latched break too (reported again at once if the
    /// break is still active).
    pub fn clear_faults(&mut self) {
        self.pwm.clear_break();
        // The filter restarts from the latest reading (a NaN does not stay in it); a stage
        // still too hot faults again in the next sample.
        self.temp_c = self.temp_now_c;
        self.hot = false;
    }

    /// Bootstrap pre-charge before the first enable (see [`Pwm::precharge_bootstrap`]).
    pub fn precharge_bootstrap(&mut self, periods: u32, hw: &mut impl Hw) -> Result<(), InitError> {
        self.pwm.precharge_bootstrap(periods, hw)
    }

    /// Called last in each step: another injected sequence completed while this step ran,
    /// so it overran its period; the next sample reports it to the drive (it faults with
    /// `Overrun`).
    #[inline(always)]
    pub fn end_step(&mut self) {
        self.overrun = self.adc.next_sample_ready();
    }
}

impl PowerStage for Esc1 {
    #[inline(always)]
    fn sample(&mut self) -> DriveInput {
        let s = self.adc.read();
        self.temp_now_c = NTC.temp_c(s.ntc_raw, SETTINGS.vref_v);
        self.temp_c += self.temp_gain * (self.temp_now_c - self.temp_c);
        if NTC.fault(self.temp_c) {
            self.hot = true;
        }
        // First: a break found here also marks the outputs off.
        let stage_fault = if self.pwm.break_latched() {
            Some(StageFault::HardwareOvercurrent)
        } else if self.hot {
            Some(StageFault::OverTemperature)
        } else {
            None
        };
        DriveInput {
            i_abc: s.i_abc,
            v_bus: s.v_bus,
            // With the outputs off the phase voltages are the motor's (its back-EMF): the
            // drive catches a turning rotor with them. With the PWM on they are the PWM's,
            // and nothing reads them; a clipped reading (NaN, `bemf::terminal_v_ab`) is no
            // terminal voltage either, and the drive catches the rotor with its currents
            // regulated to zero instead (`catch_zero.rs`).
            v_ab_terminal: if self.pwm.outputs_are_on()
                || !(s.v_ab_terminal.alpha.is_finite() && s.v_ab_terminal.beta.is_finite())
            {
                None
            } else {
                Some(s.v_ab_terminal)
            },
            overrun: self.overrun,
            stage_fault,
        }
    }

    /// PWM outputs stay off (MOE = 0) until the drive returns duties, and MOE is cleared in
    /// the same step in which it returns `None`; a latched break keeps them off (the drive
    /// faulted on it in this step's sample, so it returns `None` anyway).
    #[inline(always)]
    fn apply(&mut self, duties: Option<Duties>) {
        match duties {
            Some(d) => {
                self.pwm.load(d);
                self.pwm.outputs_on();
            }
            None => self.pwm.outputs_off(),
        }
    }
}
