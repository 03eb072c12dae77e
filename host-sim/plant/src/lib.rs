//! `pmsm-plant`: the PMSM plant of the papers in f64, `no_std`, made of parts the way
//! gym-electric-motor composes its physical systems (motor, mechanical load, converter,
//! voltage supply; the sensors and their noise are the board's, in `pmsm-host-sim`):
//!
//! - [`electrical`]: the stator windings in the stationary frame, Horng & Chin eqs (16)-(17)
//!   (Ortega et al. (1)), and the electromagnetic torque (Ortega (2)); a salient machine
//!   (`L_d ≠ L_q`) or a saturating one by the dq model with the reluctance torque;
//! - [`inductance`]: each axis' inductance and its magnetic saturation;
//! - [`mechanical`]: the rotor with its inertia and friction, a blocked shaft, the load
//!   torque, eqs (18)-(19);
//! - [`converter`]: what feeds the windings from the DC link: the averaged two-level inverter
//!   with dead time, the diode bridge with every switch off, and the DC-link current either
//!   draws;
//! - [`supply`]: the DC bus, which owns its voltage and takes the DC-link current: a stiff
//!   bus, or a DC link (its capacitor, a supply behind a diode, a brake chopper);
//! - [`plant`]: the composition, integrated with RK4 on fixed sub-steps, with the energy
//!   integrals that check the power balance.
//!
//! θ and ω are mechanical throughout; the electrical angle is `Nθ`.
//! ```text
//! di_α/dt = −R/L i_α + (ψN/L) ω sin Nθ + v_α/L                  (16)
//! di_β/dt = −R/L i_β − (ψN/L) ω cos Nθ + v_β/L                  (17)
//! dθ/dt   = ω                                                   (18)
//! dω/dt   = −(ψN/J)(i_α sin Nθ − i_β cos Nθ) − B/J ω − τ_L/J    (19)
//! ```
//! The math is `num_traits::Float`'s: libm's without std, std's when a crate in the build
//! enables num-traits' `std` feature (the host simulator does, for results identical to the
//! bit with its earlier plant).

#![cfg_attr(not(test), no_std)]

pub mod converter;
pub mod electrical;
pub mod frames;
pub mod inductance;
pub mod mechanical;
pub mod params;
pub mod plant;
pub mod state;
pub mod supply;

pub use converter::{Converter, DiodeBridge, HeldDuties, Inverter, ShortCircuit};
pub use electrical::Pmsm;
pub use frames::{clarke, inverse_clarke};
pub use inductance::{AxisInductance, Saturates, Saturation};
pub use mechanical::{Load, Rotor};
pub use params::{Inductances, PlantParams};
pub use plant::Plant;
pub use state::PlantState;
pub use supply::{Chopper, DcLink, LinkEnergy, Source, StiffBus, Supply};
