//! The drive as this board runs it: the motor and the command, the drive built for the board's
//! rate and limits, what the control step reports, and the control step itself. The only
//! module that uses the drive's API.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

#[cfg(feature = "identify")]
use pmsm_sensorless::drive::Identified;
use pmsm_sensorless::drive::{Command, Drive, DriveConfig, Mode, StateOf, Telemetry, Transition};
use pmsm_sensorless::frames::Abc;
use pmsm_sensorless::motor::{Motor, Ratings, HORNG_SINANO};
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;
use pmsm_sensorless::power_stage::PowerStage;

use crate::adc::{AMPS_PER_LSB, I_ADC_RANGE_A};
use crate::power_stage::Esc1;
use crate::protection::{Watchdog, BOARD_BUS_MAX_V};
use crate::pwm::CONTROL_HZ;
use crate::telemetry::{seconds, Sender, TELEMETRY_EVERY};

// -------------------------------------------------------------------------------------------
// User settings
// -------------------------------------------------------------------------------------------

/// The board's default motor: Horng & Chin's Sinano motor ([`HORNG_SINANO`], R, L, K, N,
/// J, B of their Table 1) with its bus rating moved from 48 V to 24 V, the bus this board
/// takes (UM2516: up to 6S LiPo). Everything else is the preset's (its 1000 rpm rating
/// stays, as the sliding-gain bounds are checked there; at 24 V the motor's back-EMF
/// limits it to about 570 rpm, hence [`SPEED_CMD_RPM`]). Replace this with your motor.
pub const MOTOR: Motor = Motor {
    name: "sinano-24v",
    params: HORNG_SINANO.params,
    ratings: Ratings {
        bus_v: 24.0,
        ..HORNG_SINANO.ratings
    },
};

/// The observer feeding the controller (Horng & Chin's sliding torque observer) and the one
/// watching it (Ortega et al.'s flux observer with its PLL). To swap them, swap these two and
/// call `DriveConfig::build_flux_primary` in [`build_drive`].
type Primary = SlidingObserver;
type Monitor = FluxPll;

/// The drive this board runs.
pub type BoardDrive = Drive<Primary, Monitor>;

/// Speed command while enabled [rpm, mechanical].
pub const SPEED_CMD_RPM: f32 = 400.0;

// -------------------------------------------------------------------------------------------
// Command path
// -------------------------------------------------------------------------------------------

/// Run command, written by the main loop (button), read by the interrupt.
pub static ENABLE: AtomicBool = AtomicBool::new(false);
/// Clear-fault request, set by the main loop, consumed (swapped to false) by the interrupt.
pub static CLEAR_FAULT: AtomicBool = AtomicBool::new(false);
/// Control steps done, for the main loop's timing.
pub static STEPS: AtomicU32 = AtomicU32::new(0);
/// Identification request (the user button held), set by the main loop, consumed by
/// [`Control::tick`]: the drive measures the motor from idle (issue #19) and the log prints the
/// motor file.
pub static IDENTIFY: AtomicBool = AtomicBool::new(false);
/// Set by the step when the drive's 1 kHz task ([`Control::tick`]) is due; the main loop runs
/// it.
pub static TICK_DUE: AtomicBool = AtomicBool::new(false);

/// What the interrupt sends to the main loop.
pub enum Event {
    Telemetry {
        step: u32,
        tel: Telemetry,
        i_abc: Abc,
        v_bus: f32,
    },
    Transition {
        step: u32,
        tr: Transition,
    },
    /// The identification's results: the motor file's lines (the commissioning firmware).
    #[cfg(feature = "identify")]
    Identified(Identified),
}

impl Event {
    /// Whether the drive is in `Fault` after this event.
    pub fn faulted(&self) -> bool {
        let mode = match self {
            Event::Telemetry { tel, .. } => tel.mode,
            Event::Transition { tr, .. } => tr.to,
            #[cfg(feature = "identify")]
            Event::Identified(_) => Mode::Identified,
        };
        mode == Mode::Fault
    }
}

/// The log line of an event.
impl defmt::Format for Event {
    fn format(&self, f: defmt::Formatter) {
        match self {
            Event::Transition { step, tr } => defmt::write!(
                f,
                "t = {=f32} s: {} -> {} ({})",
                seconds(*step),
                tr.from,
                tr.to,
                tr.reason
            ),
            // The motor file `pmsm-sim run --motor-file` loads (README, "Your motor"), with the
            // pole pairs and ratings of `MOTOR`.
            #[cfg(feature = "identify")]
            Event::Identified(m) => defmt::write!(
                f,
                "identified motor file:\nname = \"identified\"\npole_pairs = {=u32}\nr_ohm = {=f32}\nl_h = {=f32}\nflux_wb = {=f32}\nj_kgm2 = {=f32}\nb_nms = {=f32}\n# l_d_h = {=f32}, l_q_h = {=f32}\n[ratings]\nbus_v = {=f32}\ncurrent_a = {=f32}\ntorque_nm = {=f32}\nspeed_rpm = {=f32}",
                MOTOR.params.pole_pairs,
                m.r_ohm,
                m.l_h(),
                m.flux_wb,
                m.j_kgm2,
                m.b_nms,
                m.l_d_h,
                m.l_q_h,
                MOTOR.ratings.bus_v,
                MOTOR.ratings.current_a,
                MOTOR.ratings.torque_nm,
                MOTOR.ratings.speed_rpm
            ),
            Event::Telemetry {
                step,
                tel,
                i_abc,
                v_bus,
            } => defmt::write!(
                f,
                "t = {=f32} s: bus {=f32} V, i_abc [{=f32}, {=f32}, {=f32}] A, {}",
                seconds(*step),
                *v_bus,
                i_abc.a,
                i_abc.b,
                i_abc.c,
                tel
            ),
        }
    }
}

/// The drive for [`MOTOR`] at [`CONTROL_HZ`], its limits narrowed to the board's: bus trip at
/// most [`BOARD_BUS_MAX_V`], sensing range at most the ADC's ([`I_ADC_RANGE_A`]).
pub fn build_drive() -> BoardDrive {
    let mut cfg = DriveConfig::new(&MOTOR);
    cfg.rate_hz = CONTROL_HZ as f32;
    cfg.limits.bus_max_v = cfg.limits.bus_max_v.min(BOARD_BUS_MAX_V);
    cfg.limits.i_sense_max_a = cfg.limits.i_sense_max_a.min(I_ADC_RANGE_A);
    // What the identification checks a motor's rated current against.
    cfg.identify.sense_range_a = I_ADC_RANGE_A;
    cfg.identify.sense_lsb_a = AMPS_PER_LSB.abs();
    let drive = match cfg.build_sliding_primary() {
        Ok(d) => d,
        Err(e) => defmt::panic!(
            "drive configuration rejected: {=str} = {=f32}, allowed {=f32}..{=f32}",
            e.field,
            e.value,
            e.allowed.min,
            e.allowed.max
        ),
    };
    defmt::info!(
        "motor {=str}, primary {=str}, speed command {=f32} rpm, trip {=f32} A, bus {=f32}..{=f32} V",
        MOTOR.name,
        core::any::type_name::<Primary>(),
        SPEED_CMD_RPM,
        cfg.limits.i_trip_a,
        cfg.limits.bus_min_v,
        cfg.limits.bus_max_v
    );
    drive
}

/// Everything the 4 kHz interrupt owns.
pub struct Control {
    drive: BoardDrive,
    state: StateOf<Primary, Monitor>,
    stage: Esc1,
    watchdog: Watchdog,
    telemetry: Sender,
    step: u32,
}

impl Control {
    pub fn new(drive: BoardDrive, stage: Esc1, watchdog: Watchdog, telemetry: Sender) -> Self {
        Self {
            drive,
            state: StateOf::<Primary, Monitor>::default(),
            stage,
            watchdog,
            telemetry,
            step: 0,
        }
    }

    /// One control period: read the samples, step the drive, load the timer, push telemetry.
    ///
    /// Runs from CCM SRAM (`.ramfunc`, ramfunc.x), with `Drive::step` and everything it
    /// inlines (observers, FOC, SVPWM) inlined into it: flash needs 4 wait states at
    /// 170 MHz and the ART's 1 KiB instruction cache cannot hold the ~9 KiB step. The
    /// sliding observer's sin/cos table sits beside it; `math::sin_cos` and the other cold
    /// paths (mode changes, far angle wraps) stay in flash. The board's parts of the step
    /// (sample, apply, queue, watchdog) are `#[inline(always)]` for the same reason. An
    /// overrun is reported to the drive (it faults with `Overrun`).
    // Not `unsafe`, but `#[link_section]` trips the `unsafe_code` lint: the section is one
    // ramfunc.x defines and `load_ramfunc` fills before the interrupt is enabled.
    #[link_section = ".ramfunc.control_step"]
    #[inline(never)]
    pub fn step(&mut self) {
        let input = self.stage.sample();
        let cmd = Command {
            enable: ENABLE.load(Ordering::Relaxed),
            speed_rpm: SPEED_CMD_RPM,
            clear_fault: CLEAR_FAULT.swap(false, Ordering::Relaxed),
        };
        let out = self.drive.step(&mut self.state, &input, &cmd);
        self.stage.apply(out.duties);

        if let Some(tr) = out.transition {
            self.telemetry.send(Event::Transition {
                step: self.step,
                tr,
            });
        }
        if self.step.is_multiple_of(TELEMETRY_EVERY) {
            self.telemetry.send(Event::Telemetry {
                step: self.step,
                tel: self.drive.telemetry(&self.state),
                i_abc: input.i_abc,
                v_bus: input.v_bus,
            });
        }
        self.step = self.step.wrapping_add(1);
        STEPS.store(self.step, Ordering::Relaxed);
        if self.state.tick_due() {
            TICK_DUE.store(true, Ordering::Relaxed);
        }
        self.watchdog.feed();
        self.stage.end_step();
    }

    /// The drive's 1 kHz task (`Drive::tick`: the observers' read-outs, the speed loop,
    /// supervision, the mode decisions), run by the main loop once the step has set
    /// [`TICK_DUE`], inside a critical section (the step's interrupt waits the few µs it
    /// takes). In flash: it runs a thousand times a second, not four.
    #[inline(never)]
    pub fn tick(&mut self) {
        let cmd = Command {
            enable: ENABLE.load(Ordering::Relaxed),
            speed_rpm: SPEED_CMD_RPM,
            clear_fault: false,
        };
        // The commissioning firmware (`cargo fw-identify`) only.
        #[cfg(feature = "identify")]
        if IDENTIFY.swap(false, Ordering::Relaxed) {
            if let Some(tr) = self.drive.start_identification(&mut self.state) {
                self.telemetry.send(Event::Transition {
                    step: self.step,
                    tr,
                });
            }
        }
        if let Some(tr) = self.drive.tick(&mut self.state, &cmd) {
            self.telemetry.send(Event::Transition {
                step: self.step,
                tr,
            });
            #[cfg(feature = "identify")]
            if let Some(m) = self.state.identified() {
                // Done: the motor file in the log; the drive back to idle.
                self.telemetry.send(Event::Identified(m));
                ENABLE.store(false, Ordering::Relaxed);
            }
        }
    }
}
