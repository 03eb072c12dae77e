//! The drive's configuration: an impossible setting is refused with its field, value and
//! range; no value switches a protection off; ratings the bus cannot drive are refused.

use pmsm_sensorless::drive::DriveConfig;
use pmsm_sensorless::motor::HORNG_SINANO;

/// The error of `c`: its field and value as given, and a range that excludes that value.
fn refused(c: DriveConfig, field: &str, value: f32) -> String {
    let e = c.build_flux_primary().unwrap_err();
    assert_eq!(e.field, field, "{e}");
    assert_eq!(e.value.to_bits(), value.to_bits(), "{e}");
    assert!(!e.allowed.contains(value), "{e}");
    e.to_string()
}

#[test]
fn impossible_settings_name_the_field_value_and_range() {
    let base = DriveConfig::new(&HORNG_SINANO);
    assert!(base.build_flux_primary().is_ok());
    assert!(base.build_sliding_primary().is_ok());
    let i_max = base.limits.i_max_a;
    type Case = (fn(&mut DriveConfig), &'static str, f32);
    let cases: [Case; 5] = [
        (
            |c| c.limits.i_trip_a = 0.5 * c.limits.i_max_a,
            "limits.i_trip_a",
            0.5 * i_max,
        ),
        (|c| c.start.handover_rpm = 10.0, "start.handover_rpm", 10.0),
        // Longer than a second: an observer would hardly ever count as healthy.
        (|c| c.health.lock_time_s = 2.0, "health.lock_time_s", 2.0),
        (|c| c.motor.l_h = f32::NAN, "l_h", f32::NAN),
        (|c| c.rate_hz = 0.0, "rate_hz", 0.0),
    ];
    for (mutate, field, value) in cases {
        let mut c = base;
        mutate(&mut c);
        refused(c, field, value);
    }
    // K_s = 1000π above (K_s,max)_E2 = 2456 A/s at a rated speed of 500 rpm (and the rated
    // power with it, 0.695 N·m × 500 rpm): the paper's gain is outside the window, and the
    // sliding observer takes the paper's place in this motor's window instead (ε = 1 A, the
    // paper's third of the rated 3 A; K_s = 1000π/5331.46 of E2 = 1447 A/s), without a K_s
    // warning.
    let mut c = base;
    c.ratings.speed_rpm = 500.0;
    c.ratings.power_w = 36.0;
    assert!(c.build_sliding_primary().is_ok());
    assert!(c.build_flux_primary().is_ok());
    let d = c.derived().unwrap();
    assert!(
        (d.ks_a_per_s - 2456.0 * 1000.0 * core::f32::consts::PI / 5331.46).abs() < 2.0,
        "{}",
        d.ks_a_per_s
    );
    assert!(d.warnings.iter().flatten().all(|w| w.field != "ks"));
    // At 60 rpm rated, √2 K N ω (2.06 V) is below R ε (2.5 V): (K_s,max)_E2 is negative, no
    // K_s > 0 is in the window. A sliding primary is refused naming the bound; the flux
    // primary runs alone, with a warning naming K_s and its limit.
    let mut slow = HORNG_SINANO;
    slow.ratings.speed_rpm = 60.0;
    slow.ratings.power_w = 4.3;
    let c = DriveConfig::new(&slow);
    let ks = 1000.0 * core::f32::consts::PI;
    let e = c.build_sliding_primary().unwrap_err();
    assert_eq!((e.field, e.value), ("ks", ks), "{e}");
    let msg = e.to_string();
    assert!(msg.contains("(K_s,max)_E2"), "{msg}");
    assert!(c.build_flux_primary().is_ok());
    let w = c.derived().unwrap().warnings;
    let w = w
        .iter()
        .flatten()
        .find(|w| w.field == "ks")
        .expect("a K_s warning");
    assert_eq!(w.value, ks);
    assert!(w.limit < 0.0, "{w:?}");
}

#[test]
fn a_protection_cannot_be_switched_off_by_a_value() {
    let base = DriveConfig::new(&HORNG_SINANO);
    type Case = (fn(&mut DriveConfig), &'static str);
    let cases: [Case; 7] = [
        (
            |c| c.health.max_disagreement_deg = 1e30,
            "health.max_disagreement_deg",
        ),
        (|c| c.health.loss_time_s = 1e30, "health.loss_time_s"),
        (|c| c.health.stall_time_s = 1e30, "health.stall_time_s"),
        (
            |c| c.health.max_speed_disagreement_rpm = 1e30,
            "health.max_speed_disagreement_rpm",
        ),
        (|c| c.limits.bus_max_v = 1e30, "limits.bus_max_v"),
        (|c| c.limits.i_trip_a = 1e30, "limits.i_trip_a"),
        (
            |c| c.start.handover_timeout_s = 1e30,
            "start.handover_timeout_s",
        ),
    ];
    for (mutate, field) in cases {
        let mut c = base;
        mutate(&mut c);
        let msg = refused(c, field, 1e30);
        assert!(
            msg.starts_with(&format!("{field} = 1e30: allowed ")),
            "{msg}"
        );
    }
}

#[test]
fn ratings_the_bus_cannot_drive_are_refused() {
    // 5000 rpm on 48 V: the back-EMF 4·0.05795·524 = 121 V is above 48/√3 = 27.7 V.
    let mut fast = HORNG_SINANO;
    fast.ratings.speed_rpm = 5000.0;
    fast.ratings.power_w = 364.0;
    let e = fast.validate().unwrap_err();
    assert_eq!(e.field, "ratings.speed_rpm", "{e}");
    assert!((e.allowed.max - 1142.0).abs() < 1.0, "{e}");
    // 50 N·m: 2.5 Ω × 50/(4·0.05795) A = 539 V at standstill.
    let mut strong = HORNG_SINANO;
    strong.ratings.torque_nm = 50.0;
    strong.ratings.current_a = 216.0;
    strong.ratings.power_w = 5236.0;
    let e = strong.validate().unwrap_err();
    assert_eq!(e.field, "ratings.torque_nm", "{e}");
    assert!(e.to_string().contains("standstill"), "{e}");
    // The drive's configuration refuses both: the rated speed beyond even the highest bus
    // (60 V: 1427 rpm), and 50 N·m's align current, 108 A through 2.5 Ω, 270 V, beyond the
    // lowest bus's 20.8 V phase voltage.
    let mut c = DriveConfig::new(&HORNG_SINANO);
    c.ratings = fast.ratings;
    assert_eq!(
        c.build_flux_primary().unwrap_err().field,
        "ratings.speed_rpm"
    );
    let e = DriveConfig::new(&strong).build_flux_primary().unwrap_err();
    assert_eq!(e.field, "start.align_current_a", "{e}");
    // The controller's parameters are its belief: a flux linkage 15 % off the nameplate's
    // (whose torque then disagrees with N ψ_f I by more than 10 %) still builds.
    let mut c = DriveConfig::new(&HORNG_SINANO);
    c.motor.flux_wb *= 0.85;
    assert!(c.build_flux_primary().is_ok());
}

/// The low-speed d current's bands (`DriveConfig::low_speed_hold`): held below the speed where
/// the dead-time voltage's fundamental `(4/π) t_d f_pwm V_bus` is a twentieth of the back-EMF
/// `N ψ_f ω_m` while the command holds a speed, a tenth on a stop; both at least the hand-over
/// speed. On the board's 0.5 µs at 20 kHz both are above it on the Sinano and on Ortega's
/// 300 W test motor: the running band twice the stop's.
#[test]
fn the_low_speed_hold_bands_follow_the_dead_time_voltage() {
    use pmsm_sensorless::motor::ORTEGA_TEST_0P3KW;
    use std::f32::consts::PI;
    for m in [HORNG_SINANO, ORTEGA_TEST_0P3KW] {
        let mut c = DriveConfig::new(&m);
        c.power_stage.dead_time_s = 0.5e-6;
        c.power_stage.pwm_hz = 20_000.0;
        let v_dt = 4.0 / PI * 0.5e-6 * 20_000.0 * m.ratings.bus_v;
        let rpm_of = |ratio: f32| ratio * v_dt / m.params.emf_constant() * 30.0 / PI;
        let handover = c.start.handover_rpm;
        let (hold_a, running) = c.low_speed_hold();
        let stopping = c.low_speed_hold_stopping_rpm();
        println!(
            "{}: running {running} rpm, stopping {stopping} rpm, hand-over {handover} rpm",
            m.name
        );
        assert_eq!(hold_a, 2.0 * c.power_stage.dead_time_band_a);
        assert!((running - rpm_of(20.0).max(handover)).abs() <= 1e-4 * running);
        assert!((stopping - rpm_of(10.0).max(handover)).abs() <= 1e-4 * stopping);
        assert!(stopping > handover && (running - 2.0 * stopping).abs() <= 1e-4 * running);
    }
}

/// The speed below which a command is held in the I/f (`DriveConfig::if_held_below_rpm`):
/// where a resistance 5 % off at the I/f current moves the back-EMF by tan 30° of itself,
/// `ψ_f N ω_m tan 30° = 0.05 R I_ol`. Below the 3 % of rated that issue #17 runs in closed
/// loop on both drive motors; proportional to R.
#[test]
fn a_command_is_held_in_the_i_f_where_a_resistance_error_would_turn_the_angle_30_degrees() {
    use pmsm_sensorless::motor::ORTEGA_TEST_0P3KW;
    use std::f32::consts::PI;
    for m in [HORNG_SINANO, ORTEGA_TEST_0P3KW] {
        let c = DriveConfig::new(&m);
        let held = c.if_held_below_rpm();
        let delta_v = 0.05 * m.params.r_ohm * c.start.open_loop_current_a;
        let omega_m = delta_v / ((PI / 6.0).tan() * m.params.emf_constant());
        println!("{}: held below {held} rpm", m.name);
        assert!((held - omega_m * 30.0 / PI).abs() <= 1e-4 * held);
        assert!(held < 0.03 * m.ratings.speed_rpm);
        let mut warm = c;
        warm.motor.r_ohm *= 2.0;
        assert!((warm.if_held_below_rpm() - 2.0 * held).abs() <= 1e-4 * held);
    }
}
