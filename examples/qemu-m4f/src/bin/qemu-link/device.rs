//! The firmware as the link's device (`pmsm_link::Device`): the control loop (the core's
//! `Control` on the simulator's plant, [`crate::bench`]) with the settings in force, the
//! commands the link gives it, the store that keeps the settings, the device's clock (the
//! emulated control time) and the transitions the loop returned, queued for the link.
//!
//! [`Firmware::step`] runs one control period (the drive's step, and its 1 kHz task when
//! due, `Control::run`); the main loop calls it and then the link's server, never the server
//! within a step. The link's requests only set the loop's `Commands` (`enable`, `speed_rpm`,
//! `clear_fault` taken by the next step, `identify` by the next tick) or rebuild the drive
//! between two steps (`apply`, the identification's start, its end).
//!
//! Without settings in force (none or a corrupt record at boot) there is no drive: the
//! bench's switches stay off, the link answers, enable and save are refused
//! (`NotConfigured`), and a motor loaded over the link (its pole pairs and ratings) allows the
//! identification: on the drive of the core's placeholder motor of those pole pairs and
//! ratings (`identify::placeholder`, its test currents from the rated current) at the rate
//! that gives its spin 20 samples per electrical period (`rate::control_rate` at
//! `SPIN_SPEED_SHARE` of rated speed), as `pmsm-tool`'s simulated device and the
//! commissioning firmware build it.

use heapless::Deque;
use pmsm_link::{identification_motor, Device, DeviceError, Settings};
use pmsm_sensorless::control::{Commands, Control};
use pmsm_sensorless::drive::identify::SPIN_SPEED_SHARE;
use pmsm_sensorless::drive::{Drive, Identified, Mode, Reason, Telemetry, Transition};
use pmsm_sensorless::motor::Motor;
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;
use pmsm_sensorless::power_stage::PowerStage;
use pmsm_sensorless::rate::{control_rate, CpuBudget};
use pmsm_store::MAX_LEN;

use crate::bench::Bench;
use crate::config::{board_defaults, encode, STORE};
use crate::flash::SemihostedFlash;

type FluxDrive = Drive<FluxPll, SlidingObserver>;
type Loop = Control<FluxPll, SlidingObserver, Bench>;

/// A telemetry line in the log every this many steps.
const LOG_EVERY: u32 = 4000;
/// Transitions kept for the link (the oldest dropped beyond).
const QUEUE: usize = 16;
/// The control rate of the bench without a drive \[Hz] (the plant coasts).
const IDLE_RATE_HZ: f32 = 4000.0;

/// The control loop, or the bench alone.
// One value for the firmware's life, not moved: the variants' sizes do not matter.
#[allow(clippy::large_enum_variant)]
enum Slot {
    Drive(Loop),
    Off(Bench),
}

/// The firmware's state (module doc).
pub struct Firmware {
    slot: Slot,
    /// The settings in force.
    settings: Option<Settings>,
    flash: SemihostedFlash,
    /// The loop's commands (`clear_fault` for one step, `identify` until a tick took it).
    cmd: Commands,
    /// The drive in the slot is the identification's.
    identifying: bool,
    /// Emulated control time \[ns] and the control period \[ns].
    t_ns: u64,
    period_ns: u64,
    transitions: Deque<Transition, QUEUE>,
    /// A restart was asked (done by the main loop once the answer is out).
    restart_due: bool,
}

impl Firmware {
    /// The bench (the rotor at rest), the settings loaded at boot (`None`: no drive).
    pub fn new(settings: Option<Settings>, flash: SemihostedFlash) -> Self {
        let mut f = Firmware {
            slot: Slot::Off(Bench::new(IDLE_RATE_HZ)),
            settings,
            flash,
            cmd: Commands::default(),
            identifying: false,
            t_ns: 0,
            period_ns: period_ns(IDLE_RATE_HZ),
            transitions: Deque::new(),
            restart_due: false,
        };
        f.rebuild(true);
        f
    }

    /// A restart was asked over the link ([`Device::restart`]): the main loop resets the
    /// emulated chip once the answer is out.
    pub fn restart_due(&self) -> bool {
        self.restart_due
    }

    /// Whether a drive is built (settings in force, or the identification's).
    pub fn has_drive(&self) -> bool {
        matches!(self.slot, Slot::Drive(_))
    }

    /// One control period: the drive's step (and 1 kHz task when due) on the bench, the
    /// transitions queued; or the bench with its switches off.
    pub fn step(&mut self) {
        match &mut self.slot {
            Slot::Drive(control) => {
                let (stepped, ticked) = control.run(&self.cmd);
                self.cmd.clear_fault = false;
                if stepped.tick_due {
                    self.cmd.identify = false;
                }
                for tr in stepped.transition.into_iter().chain(ticked.transitions()) {
                    defmt::info!(
                        "t {=u64} ms: {} -> {} ({})",
                        self.t_ns / 1_000_000,
                        tr.from,
                        tr.to,
                        tr.reason
                    );
                    if tr.reason == Reason::ResistanceRefused {
                        defmt::warn!(
                            "the start's resistance refused, the model's kept: {}",
                            control.state().resistance_refused()
                        );
                    }
                    if self.transitions.is_full() {
                        self.transitions.pop_front();
                    }
                    let _ = self.transitions.push_back(tr);
                }
                if stepped.step.is_multiple_of(LOG_EVERY) {
                    defmt::info!(
                        "plant {=f32} rpm; {}",
                        control.stage().speed_rpm(),
                        control.telemetry()
                    );
                }
                control.stage_mut().advance();
            }
            Slot::Off(bench) => {
                bench.apply(None);
                bench.advance();
            }
        }
        self.t_ns = self.t_ns.wrapping_add(self.period_ns);
        // The identification over and its enable withdrawn: the configured drive again.
        if self.identifying && !self.cmd.identify && self.mode() == Mode::Idle {
            self.identifying = false;
            defmt::info!("identification over: the configured drive");
            self.rebuild(true);
        }
    }

    fn mode(&self) -> Mode {
        match &self.slot {
            Slot::Drive(c) => c.state().mode(),
            Slot::Off(_) => Mode::Idle,
        }
    }

    /// The drive of the settings in force (none without), its state kept unless `restart`.
    fn rebuild(&mut self, restart: bool) {
        let built = self.settings.and_then(|s| {
            s.drive_config()
                .build_flux_primary()
                .map_err(|e| defmt::error!("settings refused: {=str}", e.field))
                .ok()
                .map(|d| (d, s.rate_hz))
        });
        self.install(built, restart);
    }

    /// Puts `drive` (at its rate) on the bench, the bench keeping its plant; the drive's
    /// state kept from the one before unless `restart`.
    fn install(&mut self, drive: Option<(FluxDrive, f32)>, restart: bool) {
        let old = core::mem::replace(&mut self.slot, Slot::Off(Bench::new(IDLE_RATE_HZ)));
        let (mut bench, state) = match old {
            Slot::Drive(mut c) => {
                let state = *c.state();
                let bench = core::mem::replace(c.stage_mut(), Bench::new(IDLE_RATE_HZ));
                (bench, Some(state))
            }
            Slot::Off(b) => (b, None),
        };
        let rate_hz = drive.as_ref().map_or(IDLE_RATE_HZ, |d| d.1);
        bench.set_rate(rate_hz);
        self.period_ns = period_ns(rate_hz);
        self.slot = match drive {
            Some((d, _)) => {
                let c = Control::new(d, bench);
                Slot::Drive(match state {
                    Some(s) if !restart => c.with_state(s),
                    _ => c,
                })
            }
            None => Slot::Off(bench),
        };
    }
}

/// The control period at `rate_hz` \[ns].
fn period_ns(rate_hz: f32) -> u64 {
    libm::round(1e9 / f64::from(rate_hz)) as u64
}

impl Device for Firmware {
    fn settings(&self) -> Option<Settings> {
        self.settings
    }

    fn apply(&mut self, settings: &Settings) -> Result<(), DeviceError> {
        // A locked setting changed (the server allows it only while not running): the drive
        // starts afresh; else it keeps its state.
        let restart = !self.running()
            && self
                .settings
                .is_none_or(|s| s.motor != settings.motor || s.rate_hz != settings.rate_hz);
        self.settings = Some(*settings);
        if !self.identifying {
            self.rebuild(restart);
        }
        Ok(())
    }

    fn defaults_for(&self, motor: &Motor) -> Settings {
        match &self.settings {
            Some(board) => Settings::for_motor(motor, Some(board)),
            None => board_defaults(motor),
        }
    }

    fn save(&mut self) -> Result<(), DeviceError> {
        let settings = self.settings.ok_or(DeviceError::NotConfigured)?;
        let mut buf = [0u8; MAX_LEN];
        let bytes = encode(&settings, &mut buf).ok_or(DeviceError::Storage)?;
        let len = bytes.len();
        match STORE.save(&mut self.flash, bytes) {
            Ok(seq) => {
                defmt::info!("link: record {=u32} saved ({=usize} bytes)", seq, len);
                Ok(())
            }
            Err(e) => {
                defmt::error!("link: save failed: {=str}", e.name());
                Err(DeviceError::Storage)
            }
        }
    }

    fn running(&self) -> bool {
        self.cmd.enable || !matches!(self.mode(), Mode::Idle | Mode::Fault | Mode::Identified)
    }

    fn enable(&mut self, on: bool) -> Result<(), DeviceError> {
        self.cmd.enable = on;
        Ok(())
    }

    fn set_speed(&mut self, rpm: f32) -> Result<(), DeviceError> {
        self.cmd.speed_rpm = rpm;
        Ok(())
    }

    fn start_identification(&mut self) -> Result<(), DeviceError> {
        let user = identification_motor(self)?;
        let board = self.settings.ok_or(DeviceError::NotConfigured)?;
        let m = board.motor();
        let mut dc = Settings::for_motor(&user, Some(&board)).drive_config();
        dc.rate_hz = control_rate(
            m.params.pole_pairs,
            SPIN_SPEED_SHARE * m.ratings.speed_rpm,
            dc.power_stage.pwm_hz,
            &CpuBudget::BOARD,
        )
        .rate_hz;
        let drive = dc.build_flux_primary().map_err(DeviceError::Rejected)?;
        defmt::info!("identification: placeholder drive at {=f32} Hz", dc.rate_hz);
        self.install(Some((drive, dc.rate_hz)), true);
        self.identifying = true;
        // Started by the next tick; held enabled with a zero command until the result is
        // read and the enable withdrawn.
        self.cmd = Commands {
            enable: true,
            speed_rpm: 0.0,
            clear_fault: false,
            identify: true,
        };
        Ok(())
    }

    fn identified(&self) -> Option<Identified> {
        match &self.slot {
            Slot::Drive(c) => c.state().identified(),
            Slot::Off(_) => None,
        }
    }

    fn restart(&mut self) -> Result<(), DeviceError> {
        self.restart_due = true;
        Ok(())
    }

    fn clear_fault(&mut self) -> Result<(), DeviceError> {
        self.cmd.clear_fault = true;
        Ok(())
    }

    fn telemetry(&self) -> Telemetry {
        match &self.slot {
            Slot::Drive(c) => c.telemetry(),
            Slot::Off(_) => Telemetry::default(),
        }
    }

    fn now_ms(&self) -> u32 {
        (self.t_ns / 1_000_000) as u32
    }

    fn next_transition(&mut self) -> Option<Transition> {
        self.transitions.pop_front()
    }
}
