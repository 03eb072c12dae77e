//! The DC supply: the bus the converter switches. It owns the DC-link voltage and takes the
//! DC-link current the converter draws; a stiff bus ([`StiffBus`]) holds its voltage
//! whatever the current, a DC link ([`DcLink`], in [`dc_link`]) integrates it on its
//! capacitor, fed by a supply that cannot sink current (or sinks a set amount), with an
//! optional brake chopper.

pub mod dc_link;

pub use dc_link::{Chopper, DcLink, LinkEnergy, Source};

/// The DC bus as the plant sees it.
pub trait Supply {
    /// The DC-link voltage \[V], held over a sub-step.
    fn v_dc(&self) -> f64;

    /// The converter drew the mean DC-link current `i_dc` \[A] (positive out of the bus, into
    /// the converter) over the sub-step of `h` seconds that just ended.
    fn draw(&mut self, i_dc: f64, h: f64);
}

/// A stiff bus: its voltage whatever the current (a battery or a large, well-regulated
/// supply).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StiffBus {
    /// Bus voltage \[V].
    pub v_bus: f64,
}

impl Supply for StiffBus {
    fn v_dc(&self) -> f64 {
        self.v_bus
    }

    fn draw(&mut self, _i_dc: f64, _h: f64) {}
}
