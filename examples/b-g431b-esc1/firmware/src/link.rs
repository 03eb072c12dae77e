//! The board as the link's device (`pmsm_link::Device`, as the emulated firmware's
//! `qemu-link/device.rs`): the settings in force, loaded at boot from the configuration
//! store in the last two flash pages (`pmsm-store` over [`ConfigFlash`]) and validated by
//! the core; the commands the link gives the control interrupts (`control`'s atomics); the
//! events they queued (the latest telemetry record, the transitions, the identified motor),
//! handed over by the main loop ([`Board::note`]). Served from the main loop, never from an
//! interrupt.
//!
//! No motor is compiled in. Without settings in force (none stored, a corrupt record, one
//! of another format, or one this board cannot run: `drive_settings::board_mismatch`) there
//! is no drive: PWM off, no watchdog, the link answers, enable and save refused. The control
//! interrupts (and the watchdog) start with the first enable or identification after a reset
//! ([`Board::start_drive`]), with the drive of the settings in force; settings put in force
//! later replace the drive between two steps (`control::set_drive`).
//! The hardware over-current trip keeps the threshold set at boot (the stored settings' trip
//! current, or the ADC's range without): a new motor's takes effect after a save and reset;
//! the drive's software trip is the new one at once.
//!
//! Saving: a page erase stalls every flash read for 22 ms typical (DS12589), longer than the
//! 10 ms watchdog the control step feeds once started, and `pmsm-store` does not tell in
//! advance whether a save erases. So the board saves only before the control interrupts
//! start, i.e. before the first enable or identification after a reset (load a motor or
//! change settings, save, then enable); after that, save is refused with its reason. Not yet
//! solved: saving an identified motor without a reset in between (a save carried across a
//! reset and done before the watchdog starts would do it).
//!
//! This image is built with the `link` feature (`cargo fw-link`); it is over the 64 KiB
//! flash budget today (examples/README.md, "The board's link image").

use core::sync::atomic::Ordering;

use heapless::Deque;
use pmsm_link::{identification_motor, Device, DeviceError, Settings};
use pmsm_sensorless::drive::{Identified, Mode, Telemetry, Transition};
use pmsm_sensorless::motor::Motor;
use pmsm_store::MAX_LEN;

use pmsm_b_g431b_esc1::config::SETTINGS;
use pmsm_b_g431b_esc1::drive_settings::{board_mismatch, on_board, BoardDrive};
use pmsm_b_g431b_esc1::flash::ConfigFlash;
use pmsm_b_g431b_esc1::stored::{decode, encode, STORE};
use pmsm_b_g431b_esc1_control::control::{self, CLEAR_FAULT, ENABLE, IDENTIFY, SPEED_CMD, STEPS};
use pmsm_b_g431b_esc1_control::telemetry::Event;

/// Transitions kept for the link (the oldest dropped beyond).
const QUEUE: usize = 8;

/// The settings stored in `flash`, or none (why in the log). Out of line (run once).
#[inline(never)]
pub fn load(flash: &mut ConfigFlash) -> Option<Settings> {
    match STORE.load(flash) {
        Ok(Some(rec)) => match decode(rec.bytes()) {
            Ok(s) => Some(s),
            Err(field) => {
                defmt::error!("stored configuration refused: {=str}; no drive", field);
                None
            }
        },
        Ok(None) => {
            defmt::warn!("no configuration stored; no drive until one is loaded over the link");
            None
        }
        Err(e) => {
            defmt::error!("configuration store: {=str}; no drive", e.name());
            None
        }
    }
}

/// The drive of `settings` on this board.
fn build(settings: &Settings) -> Result<BoardDrive, DeviceError> {
    settings
        .drive_config()
        .build_flux_primary()
        .map_err(DeviceError::Rejected)
}

/// What the control interrupts need to start, kept until the first drive.
pub type Start<'a> = &'a mut dyn FnMut(BoardDrive);

/// The board's state for the link (module doc).
pub struct Board<'a> {
    settings: Option<Settings>,
    flash: ConfigFlash<'a>,
    /// Starts the control interrupts with the first drive (`None` once they run).
    start: Option<Start<'a>>,
    /// The latest telemetry record and the mode after the latest event.
    telemetry: Telemetry,
    mode: Mode,
    transitions: Deque<Transition, QUEUE>,
    identified: Option<Identified>,
    /// The drive in place is the identification's.
    identifying: bool,
    /// A restart was asked (done by the main loop once the answer is out).
    restart_due: bool,
}

impl<'a> Board<'a> {
    /// The board with the settings loaded at boot; `start` starts the control interrupts.
    pub fn new(settings: Option<Settings>, flash: ConfigFlash<'a>, start: Start<'a>) -> Self {
        Board {
            settings,
            flash,
            start: Some(start),
            telemetry: Telemetry::default(),
            mode: Mode::Idle,
            transitions: Deque::new(),
            identified: None,
            identifying: false,
            restart_due: false,
        }
    }

    /// Whether the control interrupts run (a drive is in place).
    pub fn has_drive(&self) -> bool {
        self.start.is_none()
    }

    /// A restart was asked over the link ([`Device::restart`]): the main loop resets the chip
    /// once the answer is out.
    pub fn restart_due(&self) -> bool {
        self.restart_due
    }

    /// Starts the control interrupts with the drive of the settings in force if they do not
    /// run yet; whether a drive is in place now.
    #[inline(never)]
    pub fn start_drive(&mut self) -> bool {
        if !self.has_drive() {
            if let Some(s) = self.settings {
                if let Err(e) = self.install(&s, false) {
                    defmt::error!("settings refused: {=str}", LinkErr(e).name());
                }
            }
        }
        self.has_drive()
    }

    /// An event the interrupts queued (the main loop hands each over after logging it).
    pub fn note(&mut self, ev: &Event) {
        match ev {
            Event::Telemetry { tel, .. } => {
                self.telemetry = *tel;
                self.mode = tel.mode;
            }
            Event::Transition { tr, .. } => {
                self.mode = tr.to;
                if self.transitions.is_full() {
                    self.transitions.pop_front();
                }
                let _ = self.transitions.push_back(*tr);
            }
            Event::Identified { motor, .. } => self.identified = Some(*motor),
        }
        // The identification over and its enable withdrawn: the configured drive again.
        if self.identifying && !ENABLE.load(Ordering::Relaxed) && self.mode != Mode::Identify {
            self.identifying = false;
            if let Some(s) = self.settings {
                let _ = self.install(&s, false);
            }
        }
    }

    /// Puts the drive of `s` in place (starting the interrupts with the first one). Out of
    /// line: one copy for its four callers.
    #[inline(never)]
    fn install(&mut self, s: &Settings, keep_state: bool) -> Result<(), DeviceError> {
        let drive = build(s)?;
        self.settings = Some(*s);
        self.put(drive, keep_state);
        Ok(())
    }

    /// Puts `drive` in place: the control interrupts started with it, or the running one
    /// replaced.
    fn put(&mut self, drive: BoardDrive, keep_state: bool) {
        match self.start.take() {
            Some(start) => start(drive),
            None => {
                control::set_drive(drive, keep_state);
            }
        }
    }
}

/// A device error's name for the log.
struct LinkErr(DeviceError);

impl LinkErr {
    fn name(&self) -> &'static str {
        match self.0 {
            DeviceError::Refused(why) => why,
            DeviceError::Storage => "storage",
            DeviceError::NotConfigured => "not configured",
            DeviceError::Rejected(e) => e.field,
        }
    }
}

impl Device for Board<'_> {
    fn settings(&self) -> Option<Settings> {
        self.settings
    }

    fn apply(&mut self, settings: &Settings) -> Result<(), DeviceError> {
        if let Some(field) = board_mismatch(&settings.drive_config()) {
            return Err(DeviceError::Refused(field));
        }
        // In force now; the drive of them at the first enable, or in place of the running
        // one (after the identification: its end restores the settings' drive).
        if !self.has_drive() || self.identifying {
            build(settings)?;
            self.settings = Some(*settings);
            return Ok(());
        }
        // Locked settings change only while not running (the server's check): the drive
        // then starts from idle; else it keeps its state.
        let keep = self.running();
        self.install(settings, keep)
    }

    fn defaults_for(&self, motor: &Motor) -> Settings {
        Settings::from(&on_board(pmsm_sensorless::drive::DriveConfig::new(motor)))
    }

    fn save(&mut self) -> Result<(), DeviceError> {
        let settings = self.settings.ok_or(DeviceError::NotConfigured)?;
        if self.has_drive() {
            return Err(DeviceError::Refused(
                "a page erase outlasts the watchdog: save before the first enable after a reset",
            ));
        }
        let mut buf = [0u8; MAX_LEN];
        let bytes = encode(&settings, &mut buf).ok_or(DeviceError::Storage)?;
        match STORE.save(&mut self.flash, bytes) {
            Ok(seq) => {
                defmt::info!("configuration record {=u32} saved", seq);
                Ok(())
            }
            Err(e) => {
                defmt::error!("save failed: {=str}", e.name());
                Err(DeviceError::Storage)
            }
        }
    }

    fn running(&self) -> bool {
        ENABLE.load(Ordering::Relaxed)
            || !matches!(self.mode, Mode::Idle | Mode::Fault | Mode::Identified)
    }

    fn enable(&mut self, on: bool) -> Result<(), DeviceError> {
        if on && !self.start_drive() {
            return Err(DeviceError::NotConfigured);
        }
        ENABLE.store(on, Ordering::Relaxed);
        Ok(())
    }

    fn set_speed(&mut self, rpm: f32) -> Result<(), DeviceError> {
        SPEED_CMD.store(rpm.to_bits(), Ordering::Relaxed);
        Ok(())
    }

    fn start_identification(&mut self) -> Result<(), DeviceError> {
        let user = identification_motor(self)?;
        let drive = on_board(pmsm_sensorless::drive::DriveConfig::new(&user))
            .build_flux_primary()
            .map_err(DeviceError::Rejected)?;
        self.put(drive, false);
        self.identifying = true;
        self.identified = None;
        SPEED_CMD.store(0, Ordering::Relaxed);
        IDENTIFY.store(true, Ordering::Relaxed);
        ENABLE.store(true, Ordering::Relaxed);
        Ok(())
    }

    fn identified(&self) -> Option<Identified> {
        self.identified
    }

    fn restart(&mut self) -> Result<(), DeviceError> {
        self.restart_due = true;
        Ok(())
    }

    fn clear_fault(&mut self) -> Result<(), DeviceError> {
        CLEAR_FAULT.store(true, Ordering::Relaxed);
        Ok(())
    }

    fn telemetry(&self) -> Telemetry {
        self.telemetry
    }

    fn now_ms(&self) -> u32 {
        (u64::from(STEPS.load(Ordering::Relaxed)) * 1000 / u64::from(SETTINGS.control_hz)) as u32
    }

    fn next_transition(&mut self) -> Option<Transition> {
        self.transitions.pop_front()
    }
}
