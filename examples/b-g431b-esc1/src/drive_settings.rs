//! The user's settings of this board (the motor, the observers, the speed command) and the
//! drive's configuration on it: its rate, PWM frequency, dead time and largest duty from the
//! board's [`SETTINGS`], its limits narrowed to the board's.

use pmsm_sensorless::drive::{Drive, DriveConfig};
use pmsm_sensorless::motor::{Motor, Ratings, HORNG_SINANO};
use pmsm_sensorless::observer::flux_speed::FluxPll;
use pmsm_sensorless::observer::sliding::SlidingObserver;

use crate::config::SETTINGS;

/// The board's default motor: Horng & Chin's Sinano motor ([`HORNG_SINANO`], R, L, K, N,
/// J, B of their Table 1) with its bus rating moved from 48 V to 24 V, the bus this board
/// takes (UM2516: up to 6S LiPo), and its rated speed to 560 rpm: at the board's 25.2 V
/// bus trip the motor's back-EMF limits it to 599 rpm, and the drive refuses a rated speed
/// beyond that (with the preset's 1000 rpm the firmware stopped at start-up:
/// `ratings.speed_rpm` rejected, found by the host test `drive_told_the_same`). Below about
/// 620 rpm the sliding observer's constant gain is outside its window (Horng & Chin Sec 4),
/// so the flux observer drives and the sliding observer watches. Its rated power follows the
/// rated speed: 0.695 N·m at 560 rpm is 40.8 W (the preset's 73 W is its 1000 rpm's, which
/// `Motor::validate` refuses beside 560 rpm: a factor 1.5 at most). Replace this with your
/// motor.
pub const MOTOR: Motor = Motor {
    name: "sinano-24v",
    params: HORNG_SINANO.params,
    ratings: Ratings {
        bus_v: 24.0,
        speed_rpm: 560.0,
        power_w: 40.8,
        ..HORNG_SINANO.ratings
    },
};

/// The observer feeding the controller (Ortega et al.'s flux observer with its PLL) and the
/// one watching it (Horng & Chin's sliding torque observer). To swap them, swap these two
/// and call `DriveConfig::build_sliding_primary` in the firmware's `settings::build_drive`,
/// whose log line names the primary (for a motor whose sliding gain window is not empty).
pub type Primary = FluxPll;
/// See [`Primary`].
pub type Monitor = SlidingObserver;

/// The drive this board runs.
pub type BoardDrive = Drive<Primary, Monitor>;

/// Speed command while enabled [rpm, mechanical].
pub const SPEED_CMD_RPM: f32 = 400.0;

/// Bus over-voltage trip of this board \[V]: a full 6S LiPo (UM2516: "up to 6S"; NuttX's
/// board port gives 25 V as Vbus max). The drive's own default (1.25 × rated bus) is
/// lowered to this if higher.
pub const BOARD_BUS_MAX_V: f32 = 25.2;

/// The drive's configuration for [`MOTOR`] on this board ([`on_board`]).
pub fn drive_config() -> DriveConfig {
    on_board(DriveConfig::new(&MOTOR))
}

/// `cfg` on this board: the step rate, PWM frequency, dead time and largest duty are
/// [`SETTINGS`]' (what TIM1 makes), the bus trip at most [`BOARD_BUS_MAX_V`], the sensing
/// range at most the ADC's. The firmware's defaults for a motor loaded over the link are
/// `on_board(DriveConfig::new(&motor))`.
pub fn on_board(mut cfg: DriveConfig) -> DriveConfig {
    let s = &SETTINGS;
    cfg.rate_hz = s.control_hz as f32;
    cfg.power_stage.pwm_hz = s.pwm_hz as f32;
    cfg.power_stage.dead_time_s = s.dead_time_s();
    cfg.power_stage.duty_max = s.duty_max;
    // The phase-voltage dividers clip at 18.3 V (`bemf.rs`), within a 24 V motor's speeds:
    // an enable without a reading catches with the currents regulated to zero.
    cfg.power_stage.terminal_sensing = false;
    cfg.limits.bus_max_v = cfg.limits.bus_max_v.min(BOARD_BUS_MAX_V);
    cfg.limits.i_sense_max_a = cfg.limits.i_sense_max_a.min(s.i_adc_range_a);
    // What the identification checks a motor's rated current against.
    cfg.identify.sense_range_a = s.i_adc_range_a;
    cfg.identify.sense_lsb_a = s.amps_per_lsb.abs();
    cfg
}

/// The first setting of `cfg` this board cannot run (its name), `None` if it can: what
/// [`on_board`] fixes must be as it fixes it (TIM1's rate, PWM, dead time and duty are built
/// in; the dividers do not read the terminals), and the limits within the board's.
// `#[inline]`: compiled in the main loop's crate, for size (this package is at 3 for the
// step's ADC and PWM functions; `Cargo.toml`), 232 B less of the link image.
#[inline]
pub fn board_mismatch(cfg: &DriveConfig) -> Option<&'static str> {
    let b = on_board(*cfg);
    let (p, q) = (&cfg.power_stage, &b.power_stage);
    [
        ("rate_hz", cfg.rate_hz == b.rate_hz),
        ("power_stage.pwm_hz", p.pwm_hz == q.pwm_hz),
        ("power_stage.dead_time_s", p.dead_time_s == q.dead_time_s),
        ("power_stage.duty_max", p.duty_max == q.duty_max),
        (
            "power_stage.terminal_sensing",
            p.terminal_sensing == q.terminal_sensing,
        ),
        (
            "limits.bus_max_v",
            cfg.limits.bus_max_v == b.limits.bus_max_v,
        ),
        (
            "limits.i_sense_max_a",
            cfg.limits.i_sense_max_a == b.limits.i_sense_max_a,
        ),
        (
            "identify.sense_range_a",
            cfg.identify.sense_range_a == b.identify.sense_range_a,
        ),
        (
            "identify.sense_lsb_a",
            cfg.identify.sense_lsb_a == b.identify.sense_lsb_a,
        ),
    ]
    .into_iter()
    .find(|(_, same)| !same)
    .map(|(name, _)| name)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_boards_own_configuration_fits_and_a_foreign_rate_is_named() {
        let cfg = drive_config();
        assert_eq!(board_mismatch(&cfg), None);
        let mut other = cfg;
        other.rate_hz = 8000.0;
        assert_eq!(board_mismatch(&other), Some("rate_hz"));
        let mut other = cfg;
        other.limits.bus_max_v = BOARD_BUS_MAX_V + 1.0;
        assert_eq!(board_mismatch(&other), Some("limits.bus_max_v"));
    }
}
