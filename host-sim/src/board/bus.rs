//! The board's DC bus: stiff (the default, a bus that holds its voltage whatever the current)
//! or a DC link ([`DcLinkSpec`]: its capacitor, a supply that cannot sink current or sinks a
//! set amount, an optional brake chopper; the model is `pmsm_plant::DcLink`'s), and the
//! defaults of a link scaled from the motor's ratings ([`DcLinkSpec::for_motor`]).

use pmsm_plant::{Chopper, DcLink, Source, StiffBus, Supply};
use pmsm_sensorless::motor::Motor;

/// The time the default capacitor carries the rated DC-link current with a 1 % droop \[s]:
/// one period of the board's 20 kHz PWM.
pub const HOLD_S: f64 = 50e-6;

/// The default supply's droop at the rated DC-link current, as a fraction of the bus.
pub const SOURCE_DROOP: f64 = 0.02;

/// The default brake chopper's switch-on and switch-off voltages, as fractions of the rated
/// bus: below the drive's over-voltage trip (1.25).
pub const BRAKE_ON: f64 = 1.15;
/// See [`BRAKE_ON`].
pub const BRAKE_OFF: f64 = 1.10;

/// A DC link on the board (the supply's open-circuit voltage is the board's `bus_v`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DcLinkSpec {
    /// The link's capacitance \[F].
    pub capacitance_f: f64,
    /// The supply's series resistance \[Ω].
    pub source_ohm: f64,
    /// The most current the supply takes back \[A] (0: it cannot sink).
    pub sink_a: f64,
    /// The brake chopper, if any (its thresholds in volts).
    pub chopper: Option<Chopper>,
    /// The chopper's gate is the drive's brake output (its thresholds unused).
    pub chopper_by_drive: bool,
}

impl DcLinkSpec {
    /// The defaults for `motor`, from its rated bus `V` and rated power `P` (the rated DC-link
    /// current `I = P/V`): a capacitor that carries `I` for [`HOLD_S`] with a 1 % droop,
    /// `C = P·HOLD_S/(0.01·V²)` (Sinano: 158 µF); a supply that droops [`SOURCE_DROOP`] of
    /// the bus at `I`, `R_s = 0.02·V²/P` (Sinano: 0.63 Ω), so `R_s C = 2·HOLD_S = 100 µs` for
    /// every motor; it cannot sink; no brake chopper.
    pub fn for_motor(motor: &Motor) -> Self {
        let v = f64::from(motor.ratings.bus_v);
        let p = f64::from(motor.ratings.power_w);
        Self {
            capacitance_f: p * HOLD_S / (0.01 * v * v),
            source_ohm: SOURCE_DROOP * v * v / p,
            sink_a: 0.0,
            chopper: None,
            chopper_by_drive: false,
        }
    }

    /// A chopper of `r_ohm` switched on at [`BRAKE_ON`] and off at [`BRAKE_OFF`] of the
    /// motor's rated bus.
    pub fn default_chopper(motor: &Motor, r_ohm: f64) -> Chopper {
        let v = f64::from(motor.ratings.bus_v);
        Chopper {
            r_ohm,
            v_on: BRAKE_ON * v,
            v_off: BRAKE_OFF * v,
        }
    }

    /// Errors unless every value is a finite number in its range: C and R_s > 0, the sink
    /// ≥ 0, the chopper's R_b > 0 and 0 < V_off < V_on.
    pub fn check(&self) -> anyhow::Result<()> {
        let pos = |x: f64| x.is_finite() && x > 0.0;
        anyhow::ensure!(
            pos(self.capacitance_f),
            "DC link: the capacitance must be > 0, got {} F",
            self.capacitance_f
        );
        anyhow::ensure!(
            pos(self.source_ohm),
            "DC link: the supply's resistance must be > 0, got {} Ω",
            self.source_ohm
        );
        anyhow::ensure!(
            self.sink_a.is_finite() && self.sink_a >= 0.0,
            "DC link: the supply's sink limit must be >= 0, got {} A",
            self.sink_a
        );
        if let Some(ch) = self.chopper {
            anyhow::ensure!(
                pos(ch.r_ohm),
                "DC link: the brake resistor must be > 0, got {} Ω",
                ch.r_ohm
            );
            anyhow::ensure!(
                pos(ch.v_off) && ch.v_off < ch.v_on && ch.v_on.is_finite(),
                "DC link: the brake's thresholds must satisfy 0 < off < on, got on {} V, off {} V",
                ch.v_on,
                ch.v_off
            );
        }
        Ok(())
    }

    /// The link on a supply of `v_bus` \[V] open-circuit voltage, charged to it.
    pub fn link(&self, v_bus: f64) -> DcLink {
        let source = Source {
            v_open: v_bus,
            r_ohm: self.source_ohm,
            sink_a: self.sink_a,
        };
        let mut link = DcLink::new(self.capacitance_f, source, self.chopper);
        if self.chopper_by_drive && self.chopper.is_some() {
            link.gate = Some(false);
        }
        link
    }
}

/// The board's bus as the plant sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum BoardBus {
    /// A stiff bus.
    Stiff(StiffBus),
    /// A DC link.
    Link(DcLink),
}

impl BoardBus {
    /// The supply's voltage steps to `v` \[V] (a sag, or its recovery): the stiff bus's
    /// voltage, the link's supply's open-circuit voltage (the capacitor follows through R_s).
    pub fn set_supply_v(&mut self, v: f64) {
        match self {
            BoardBus::Stiff(bus) => bus.v_bus = v,
            BoardBus::Link(link) => link.source.v_open = v,
        }
    }

    /// The drive's brake output: the chopper's gate where the drive drives it.
    pub fn gate_brake(&mut self, on: bool) {
        if let BoardBus::Link(link) = self {
            if link.gate.is_some() {
                link.gate = Some(on);
            }
        }
    }

    /// The DC link, if the board has one.
    pub fn link(&self) -> Option<&DcLink> {
        match self {
            BoardBus::Stiff(_) => None,
            BoardBus::Link(link) => Some(link),
        }
    }
}

impl Supply for BoardBus {
    fn v_dc(&self) -> f64 {
        match self {
            BoardBus::Stiff(bus) => bus.v_dc(),
            BoardBus::Link(link) => link.v_dc(),
        }
    }

    fn draw(&mut self, i_dc: f64, h: f64) {
        match self {
            BoardBus::Stiff(bus) => bus.draw(i_dc, h),
            BoardBus::Link(link) => link.draw(i_dc, h),
        }
    }
}
