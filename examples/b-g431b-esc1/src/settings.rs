//! The user's settings of this board: the motor, the observers, the speed command, and the
//! drive built from them for the board's rate and limits.

use pmsm_sensorless::drive::{Drive, DriveConfig};
use pmsm_sensorless::motor::{Motor, Ratings, HORNG_SINANO};
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;

use crate::adc::{AMPS_PER_LSB, I_ADC_RANGE_A};
use crate::protection::BOARD_BUS_MAX_V;
use crate::pwm::CONTROL_HZ;

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
pub type Primary = SlidingObserver;
/// See [`Primary`].
pub type Monitor = FluxPll;

/// The drive this board runs.
pub type BoardDrive = Drive<Primary, Monitor>;

/// Speed command while enabled [rpm, mechanical].
pub const SPEED_CMD_RPM: f32 = 400.0;

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
