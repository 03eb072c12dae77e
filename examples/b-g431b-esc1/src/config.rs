//! The board's one configuration ([`BoardConfig`]: clocks, PWM frequency, dead time,
//! control-rate divider, current and bus sensing, watchdog) and everything derived from it
//! ([`Settings`]): the register values the firmware writes and what the drive is told.
//! [`SETTINGS`] is derived at compile time; an invalid configuration does not compile.
//!
//! References: RM0440 (STM32G4 reference manual: TIM1, ADC, IWDG, RCC, FLASH chapters),
//! DS12589 (STM32G431xx datasheet: PLL, ADC and LSI characteristics), UM2516 (the board).

use crate::dead_time::DeadTime;
use crate::pll::Pll;

/// ADC sample times (RM0440 ADC_SMPRx.SMPx codes 0..7) in half ADC clock cycles: 2.5, 6.5,
/// 12.5, 24.5, 47.5, 92.5, 247.5, 640.5 cycles.
pub const SAMPLE_HALF_CYCLES: [u32; 8] = [5, 13, 25, 49, 95, 185, 495, 1281];
/// A 12-bit conversion after the sampling: 12.5 ADC clock cycles (RM0440 ADC, "Conversion
/// time"), in half cycles.
pub const CONVERSION_HALF_CYCLES: u32 = 25;
/// Highest ADC clock \[Hz] (DS12589, f_ADC).
pub const ADC_MAX_HZ: u32 = 60_000_000;
/// HCLK per flash wait state in range 1 boost mode \[Hz] (RM0440 FLASH, number of wait
/// states versus HCLK: 0 WS up to 34 MHz, ... 4 WS up to 170 MHz).
pub const FLASH_HZ_PER_WS: u32 = 34_000_000;
/// LSI frequency range \[Hz] (DS12589, LSI oscillator: 29.5..34 kHz, 32 kHz typical).
pub const LSI_HZ: (u32, u32, u32) = (29_500, 32_000, 34_000);

/// The board's configuration: everything else is derived from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoardConfig {
    /// The HSE crystal \[Hz] (8 MHz on this board).
    pub hse_hz: u32,
    /// SYSCLK = HCLK = PCLK1/2 = TIM1's clock \[Hz].
    pub sysclk_hz: u32,
    /// PWM (switching) frequency \[Hz].
    pub pwm_hz: u32,
    /// PWM periods per control step (the control rate is `pwm_hz / pwm_per_step`).
    pub pwm_per_step: u32,
    /// Dead time asked for \[ns] (TIM1 makes at least this, [`DeadTime::at_least`]).
    pub dead_time_ns: u32,
    /// Settling time of the shunt amplifiers after the low-side switch turns on \[ns]: the
    /// first sample starts no earlier.
    pub settle_ns: u32,
    /// ADC clock = HCLK / this (1, 2 or 4: ADC12_CCR.CKMODE synchronous).
    pub adc_clock_div: u32,
    /// Sample time of the current channels (SMP code, [`SAMPLE_HALF_CYCLES`]).
    pub current_smp: u8,
    /// Sample time of the bus divider (SMP code).
    pub bus_smp: u8,
    /// ADC reference VREF+ \[V].
    pub vref_v: f32,
    /// Shunt resistance \[Ω].
    pub r_shunt_ohm: f32,
    /// Shunt voltage → ADC input voltage (op-amp and network; negative: inverting).
    pub current_gain: f32,
    /// Bus divider: upper resistor \[Ω].
    pub bus_r_top_ohm: f32,
    /// Bus divider: lower resistor \[Ω].
    pub bus_r_bottom_ohm: f32,
    /// Independent watchdog timeout at the typical LSI \[ms].
    pub watchdog_ms: u32,
    /// TIM1's break inputs ignore pulses shorter than this \[ns] (the comparators' view of
    /// the switching edges' ringing).
    pub break_filter_ns: u32,
    /// The over-current comparators' input per ampere of phase current \[V/A] ([`crate::ocp`]).
    pub comp_v_per_a: f32,
    /// The hardware trip over the drive's software trip (`i_trip_a`).
    pub hw_trip_factor: f32,
    /// Bootstrap pre-charge before the first enable: all low sides on this long \[µs].
    pub precharge_us: u32,
    /// Phase-voltage (back-EMF) dividers: upper resistor \[Ω] ([`crate::bemf`]).
    pub bemf_r_top_ohm: f32,
    /// Phase-voltage dividers: lower resistor, to the GPIO_BEMF pin \[Ω].
    pub bemf_r_bottom_ohm: f32,
    /// Sample time of the phase-voltage channels (SMP code).
    pub bemf_smp: u8,
}

impl BoardConfig {
    /// The B-G431B-ESC1 as this firmware runs it. Sources per value:
    /// - 8 MHz HSE crystal: NuttX board port (`STM32_BOARD_XTAL`), UM2516 pin table (PF0/PF1
    ///   "HSE crystal 8 MHz").
    /// - 20 kHz PWM, a control step every 5 periods (4 kHz: the drive's rate).
    /// - Dead time 800 ns, ST's value for this power stage (the reading of ST's
    ///   reference design; NuttX's port used 500 ns, marked "REVISIT"). The L6387E gate
    ///   driver interlocks its inputs (HIN and LIN both high: both outputs low) but inserts
    ///   no dead time of its own (datasheet DocID13990, "Input logic"); it sinks 650 mA and
    ///   sources 400 mA, 30/50 ns fall/rise into 1 nF. The STL180N6F7 MOSFETs (60 V,
    ///   ~1.9 mΩ, PowerFLAT 5x6) carry a gate charge of order 100 nC (UNVERIFIED: their
    ///   datasheet was not at hand, nor the board's gate resistors): discharged by 0.65 A,
    ///   some 150 ns to turn off, plus the driver's propagation delays and their mismatch
    ///   (UNVERIFIED) and the resistors. 500 ns leaves little margin against shoot-through
    ///   that nothing here can measure; 800 ns costs 0.6 % of the bus in the voltage limit
    ///   (`2·t_d·f_pwm`, compensated by the drive, which is told the same value) and 0.012 of
    ///   the largest duty. TIM1 makes exactly 800 ns (136 clocks, DTG 0x84).
    /// - Amplifier settling 1.3 µs after a switching edge: measured on this board by the
    ///   FOC-Stim project (diglet48/FOC-Stim). UNVERIFIED here.
    /// - ADC at HCLK/4 = 42.5 MHz, 6.5 cycles for the op-amp outputs (low impedance),
    ///   247.5 for the ~16 kΩ bus divider.
    /// - VREF+ = VDDA = 3.3 V, shunt 3 mΩ, gain −9.14 (NuttX port / ST MC SDK board
    ///   description), bus divider 169 kΩ / 18 kΩ (NuttX port): UNVERIFIED against UM2516's
    ///   schematic.
    /// - Watchdog 10 ms: 40 control periods.
    /// - Break filter 500 ns (TIM1 makes 565 ns: BK2F = 1011).
    /// - Comparator input 1.71 mV/A: the shunt's 3 mΩ × 9.14/16, the share of the overall
    ///   gain before the op-amp's internal gain of 16 (PGA mode), assuming the whole shunt
    ///   signal reaches the non-inverting input: UNVERIFIED against UM2516's schematic.
    /// - Hardware trip at 1.5 × the drive's software trip.
    /// - Bootstrap pre-charge 1 ms (20 periods): the L6387's bootstrap capacitor charges
    ///   through its internal diode while the low side conducts (time constant not
    ///   checked against UM2516's component values: UNVERIFIED).
    /// - Phase-voltage dividers 10 kΩ / 2.2 kΩ (ratio 5.545; ST gives 5.54 for this board:
    ///   [`crate::bemf`], the resistors themselves UNVERIFIED), 47.5 ADC cycles (1.1 µs) for
    ///   their 1.8 kΩ source: RM0440's `t_s ≥ (R_ain + R_adc)·C_adc·ln(2^14)` is some 0.15 µs
    ///   with DS12589's C_adc ≈ 5 pF and R_adc ≈ 1 kΩ.
    pub const ESC1: Self = Self {
        hse_hz: 8_000_000,
        sysclk_hz: 170_000_000,
        pwm_hz: 20_000,
        pwm_per_step: 5,
        dead_time_ns: 800,
        settle_ns: 1300,
        adc_clock_div: 4,
        current_smp: 1,
        bus_smp: 6,
        vref_v: 3.3,
        r_shunt_ohm: 0.003,
        current_gain: -9.14,
        bus_r_top_ohm: 169_000.0,
        bus_r_bottom_ohm: 18_000.0,
        watchdog_ms: 10,
        break_filter_ns: 500,
        comp_v_per_a: 0.003 * 9.14 / 16.0,
        hw_trip_factor: 1.5,
        precharge_us: 1000,
        bemf_r_top_ohm: 10_000.0,
        bemf_r_bottom_ohm: 2_200.0,
        bemf_smp: 4,
    };

    /// Everything derived from this configuration, or the first thing that is out of range.
    pub const fn derive(&self) -> Result<Settings, &'static str> {
        if self.sysclk_hz > 170_000_000 {
            return Err("sysclk_hz above 170 MHz");
        }
        let Some(pll_hse) = Pll::exact(self.hse_hz, self.sysclk_hz) else {
            return Err("no PLL setting gives sysclk_hz from hse_hz");
        };
        let Some(pll_hsi) = Pll::exact(16_000_000, self.sysclk_hz) else {
            return Err("no PLL setting gives sysclk_hz from HSI16");
        };
        // TIM1: centre-aligned, one PWM period = 2·ARR timer clocks (RM0440 TIM1,
        // "Center-aligned mode (up/down counting)").
        if self.pwm_hz == 0 || !self.sysclk_hz.is_multiple_of(2 * self.pwm_hz) {
            return Err("sysclk_hz is not a multiple of 2 x pwm_hz");
        }
        let tim1_arr = self.sysclk_hz / (2 * self.pwm_hz);
        if tim1_arr > 0xFFFF {
            return Err("ARR above 16 bits: pwm_hz too low");
        }
        if self.pwm_per_step == 0 || self.pwm_per_step > 128 {
            return Err("pwm_per_step outside 1..128");
        }
        let Some(dead_time) = DeadTime::at_least(self.dead_time_ns, self.sysclk_hz) else {
            return Err("dead_time_ns beyond the dead-time generator");
        };
        if self.adc_clock_div != 1 && self.adc_clock_div != 2 && self.adc_clock_div != 4 {
            return Err("adc_clock_div not 1, 2 or 4");
        }
        let adc_hz = self.sysclk_hz / self.adc_clock_div;
        if adc_hz > ADC_MAX_HZ {
            return Err("ADC clock above 60 MHz");
        }
        if self.current_smp > 7 || self.bus_smp > 7 || self.bemf_smp > 7 {
            return Err("sample-time code above 7");
        }
        // ADC1: U, W, bus, NTC; ADC2: V, the three phase voltages. The step starts at ADC1's
        // end of sequence and reads ADC2: its sequence must end first.
        let adc1_half_cycles = 2 * SAMPLE_HALF_CYCLES[self.current_smp as usize]
            + 2 * SAMPLE_HALF_CYCLES[self.bus_smp as usize]
            + 4 * CONVERSION_HALF_CYCLES;
        let adc2_half_cycles = SAMPLE_HALF_CYCLES[self.current_smp as usize]
            + 3 * SAMPLE_HALF_CYCLES[self.bemf_smp as usize]
            + 4 * CONVERSION_HALF_CYCLES;
        if adc2_half_cycles >= adc1_half_cycles {
            return Err("ADC2's sequence does not end before ADC1's");
        }
        if !(self.bemf_r_top_ohm > 0.0 && self.bemf_r_bottom_ohm > 0.0) {
            return Err("bemf divider resistors not positive");
        }
        // ADC1 converts U (rank 1, ADC2's V simultaneously), then W (rank 2): the last
        // current sample ends after two sample times and one conversion.
        let smp = SAMPLE_HALF_CYCLES[self.current_smp as usize];
        let sample_end_ns = (2 * smp + CONVERSION_HALF_CYCLES) as f32 * 0.5e9 / adc_hz as f32;
        // The low side conducts (1 − d)·T centred on the counter peak (the sampling
        // instant), less the dead time at its start: the amplifiers settle before the
        // peak, the samples end before the low side turns off.
        let period_ns = 1e9 / self.pwm_hz as f32;
        let before_ns = dead_time.ns + self.settle_ns as f32;
        let half_low_ns = if before_ns > sample_end_ns {
            before_ns
        } else {
            sample_end_ns
        };
        let duty_max = 1.0 - 2.0 * half_low_ns / period_ns;
        let dead_duty = dead_time.ns / period_ns;
        if duty_max <= 0.5 + dead_duty {
            return Err("no voltage left: dead time and sampling take the whole period");
        }
        let amps_per_lsb = self.vref_v / 4096.0 / (self.r_shunt_ohm * self.current_gain);
        let abs_amps_per_lsb = if amps_per_lsb < 0.0 {
            -amps_per_lsb
        } else {
            amps_per_lsb
        };
        let volts_per_lsb = self.vref_v / 4096.0 * (self.bus_r_top_ohm + self.bus_r_bottom_ohm)
            / self.bus_r_bottom_ohm;
        let Some(watchdog) = Watchdog::for_timeout(self.watchdog_ms, LSI_HZ.1) else {
            return Err("watchdog_ms beyond the IWDG's range");
        };
        let control_hz = (self.pwm_hz / self.pwm_per_step) as f32;
        if watchdog.timeout_ms(LSI_HZ.2) * control_hz < 4.0 * 1000.0 {
            return Err("watchdog shorter than 4 control periods at the fastest LSI");
        }
        let comparators_ok = self.comp_v_per_a > 0.0 && self.hw_trip_factor >= 1.0;
        if !comparators_ok {
            return Err("comp_v_per_a not positive or hw_trip_factor below 1");
        }
        let break_filter = crate::break_filter::break_filter(self.break_filter_ns, self.sysclk_hz);
        Ok(Settings {
            sysclk_hz: self.sysclk_hz,
            pll_hse,
            pll_hsi,
            flash_wait_states: (self.sysclk_hz - 1) / FLASH_HZ_PER_WS,
            pwm_hz: self.pwm_hz,
            control_hz: self.pwm_hz / self.pwm_per_step,
            pwm_per_step: self.pwm_per_step,
            tim1_arr,
            // One update event every PWM period (`crate::tim1`).
            tim1_rcr: 1,
            dead_time,
            adc_hz,
            adc_ckmode: match self.adc_clock_div {
                1 => 1,
                2 => 2,
                _ => 3,
            },
            current_smp: self.current_smp,
            bus_smp: self.bus_smp,
            sample_end_ns,
            duty_max,
            amps_per_lsb,
            i_adc_range_a: 0.95 * 2048.0 * abs_amps_per_lsb,
            volts_per_lsb,
            watchdog,
            break_filter: break_filter.0,
            break_filter_ns: break_filter.1,
            vref_v: self.vref_v,
            comp_v_per_a: self.comp_v_per_a,
            hw_trip_factor: self.hw_trip_factor,
            precharge_periods: (self.precharge_us as u64 * self.pwm_hz as u64).div_ceil(1_000_000)
                as u32,
            bemf_smp: self.bemf_smp,
            // As the bus divider's: Vref/4096 × (R_top + R_bottom)/R_bottom.
            bemf_volts_per_lsb: self.vref_v / 4096.0
                * (self.bemf_r_top_ohm + self.bemf_r_bottom_ohm)
                / self.bemf_r_bottom_ohm,
            adc1_sequence_ns: adc1_half_cycles as f32 * 0.5e9 / adc_hz as f32,
            adc2_sequence_ns: adc2_half_cycles as f32 * 0.5e9 / adc_hz as f32,
        })
    }
}

/// The IWDG's prescaler and reload (RM0440 IWDG: counter clock `f_LSI / (4·2^PR)`, the
/// counter runs down from RL to 0: timeout `4·2^PR·(RL + 1)/f_LSI`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Watchdog {
    /// IWDG_PR.PR (0..6: /4../256).
    pub pr: u8,
    /// IWDG_RLR.RL (0..4095).
    pub rl: u16,
}

impl Watchdog {
    /// The finest prescaler whose 12-bit reload reaches `ms` at `lsi_hz` (rounded to the
    /// nearest count); `None` beyond /256 × 4096.
    pub const fn for_timeout(ms: u32, lsi_hz: u32) -> Option<Self> {
        let mut pr = 0u8;
        while pr <= 6 {
            let div = 4u64 << pr;
            let counts = (ms as u64 * lsi_hz as u64 + 500 * div) / (1000 * div);
            if counts >= 1 && counts <= 4096 {
                return Some(Self {
                    pr,
                    rl: (counts - 1) as u16,
                });
            }
            pr += 1;
        }
        None
    }

    /// The timeout at `lsi_hz` \[ms].
    pub const fn timeout_ms(&self, lsi_hz: u32) -> f32 {
        ((4u32 << self.pr) * (self.rl as u32 + 1)) as f32 * 1000.0 / lsi_hz as f32
    }
}

/// Everything derived from a [`BoardConfig`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// SYSCLK \[Hz].
    pub sysclk_hz: u32,
    /// The PLL from the HSE crystal.
    pub pll_hse: Pll,
    /// The PLL from HSI16 (the fallback when the crystal does not start).
    pub pll_hsi: Pll,
    /// FLASH_ACR.LATENCY.
    pub flash_wait_states: u32,
    /// PWM frequency \[Hz].
    pub pwm_hz: u32,
    /// Control (drive step) rate \[Hz].
    pub control_hz: u32,
    /// PWM periods per control step.
    pub pwm_per_step: u32,
    /// TIM1_ARR: half a PWM period in timer clocks.
    pub tim1_arr: u32,
    /// TIM1_RCR: in centre-aligned mode the repetition counter counts overflows and
    /// underflows (RM0440 TIM1, "Repetition counter"): RCR + 1 = 2 × PWM periods per update
    /// event. 1: an update (the compare preload's transfer and the ADC trigger) every PWM
    /// period, at the counter peak; the step runs on every `pwm_per_step`-th sample.
    pub tim1_rcr: u16,
    /// The dead time TIM1 makes.
    pub dead_time: DeadTime,
    /// ADC clock \[Hz].
    pub adc_hz: u32,
    /// ADC12_CCR.CKMODE (1: HCLK/1, 2: HCLK/2, 3: HCLK/4).
    pub adc_ckmode: u8,
    /// SMP code of the current channels.
    pub current_smp: u8,
    /// SMP code of the bus channel.
    pub bus_smp: u8,
    /// The last current sample ends this long after the trigger \[ns].
    pub sample_end_ns: f32,
    /// The largest duty: the low side conducts long enough for the amplifiers to settle
    /// before the sample and for the samples to end before it turns off.
    pub duty_max: f32,
    /// Phase current per ADC count \[A/LSB] (negative: the amplifier inverts).
    pub amps_per_lsb: f32,
    /// Largest current the ADC represents around a mid-scale offset, 5 % margin \[A].
    pub i_adc_range_a: f32,
    /// Bus voltage per ADC count \[V/LSB].
    pub volts_per_lsb: f32,
    /// The independent watchdog.
    pub watchdog: Watchdog,
    /// TIMx_BDTR.BKF/BK2F code.
    pub break_filter: u32,
    /// The break filter's time \[ns].
    pub break_filter_ns: f32,
    /// ADC and DAC reference \[V].
    pub vref_v: f32,
    /// See [`BoardConfig::comp_v_per_a`].
    pub comp_v_per_a: f32,
    /// See [`BoardConfig::hw_trip_factor`].
    pub hw_trip_factor: f32,
    /// PWM periods of the bootstrap pre-charge.
    pub precharge_periods: u32,
    /// SMP code of the phase-voltage channels.
    pub bemf_smp: u8,
    /// Phase voltage per ADC count \[V/LSB] ([`crate::bemf`]).
    pub bemf_volts_per_lsb: f32,
    /// ADC1's injected sequence (U, W, bus, NTC) from the trigger to its end \[ns].
    pub adc1_sequence_ns: f32,
    /// ADC2's (V, the three phase voltages) \[ns]: shorter than ADC1's.
    pub adc2_sequence_ns: f32,
}

impl Settings {
    /// The time from the low side's turn-on to the sampling instant (the counter peak) at
    /// duty `d` \[ns]: `(1 − d)·T/2 − t_dead`.
    pub fn settle_window_ns(&self, d: f32) -> f32 {
        (1.0 - d) * 0.5e9 / self.pwm_hz as f32 - self.dead_time.ns
    }

    /// The dead time as the drive compensates it \[s].
    pub fn dead_time_s(&self) -> f32 {
        self.dead_time.ns * 1e-9
    }
}

/// The settings of [`BoardConfig::ESC1`], derived at compile time.
pub const SETTINGS: Settings = match BoardConfig::ESC1.derive() {
    Ok(s) => s,
    Err(e) => panic!("{}", e),
};

#[cfg(test)]
mod tests;
