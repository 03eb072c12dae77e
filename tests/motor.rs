//! Motor parameter validation and presets.

use pmsm_sensorless::motor::{self, MotorParams};
use pmsm_sensorless::param::ParamError;

fn ok() -> [f32; 5] {
    [2.5, 5.97e-3, 5.795e-2, 6.45e-5, 8.06e-5]
}

fn build(v: [f32; 5]) -> Result<MotorParams, ParamError> {
    MotorParams::new(4, v[0], v[1], v[2], v[3], v[4])
}

#[test]
fn every_bad_field_is_named_with_its_value_and_range() {
    let names = ["r_ohm", "l_h", "flux_wb", "j_kgm2", "b_nms"];
    for (k, name) in names.iter().enumerate() {
        // Non-numbers, negatives, and values no motor has (the ones that built with infinite
        // coefficients: j = 1e-45, flux = 1e-45; r = 1e30).
        for bad in [
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -1.0,
            1e-45,
            1e30,
        ] {
            let mut v = ok();
            v[k] = bad;
            if *name == "b_nms" && bad == 1e-45 {
                assert!(build(v).is_ok(), "tiny friction is allowed");
                continue;
            }
            let e = build(v).unwrap_err();
            assert_eq!(e.field(), *name, "{bad} in {name}");
            assert_eq!(e.value.to_bits(), bad.to_bits(), "{e}");
            assert!(e.to_string().starts_with(&format!("{name} = ")), "{e}");
        }
        let mut v = ok();
        v[k] = 0.0;
        if *name == "b_nms" {
            assert!(build(v).is_ok(), "zero friction is allowed");
        } else {
            assert_eq!(build(v).unwrap_err().field(), *name);
        }
    }
    for n in [0, 65, 100_000, u32::MAX] {
        let e = MotorParams::new(n, 2.5, 5.97e-3, 5.795e-2, 6.45e-5, 0.0).unwrap_err();
        assert_eq!(e.field(), "pole_pairs");
    }
    let e = MotorParams::new(0, 2.5, 5.97e-3, 5.795e-2, 6.45e-5, 0.0).unwrap_err();
    assert_eq!(e.to_string(), "pole_pairs = 0: allowed [1, 64]");
    let e: ParamError = build([2.5, 5.97e-3, 1e-45, 6.45e-5, 0.0]).unwrap_err();
    assert_eq!(e.to_string(), "flux_wb = 1e-45: allowed [1e-5, 10]");
}

#[test]
fn ratings_are_validated_and_consistent_with_the_parameters() {
    let base = motor::HORNG_SINANO;
    type Case = (fn(&mut motor::Ratings), &'static str);
    let cases: [Case; 6] = [
        (|r| r.current_a = f32::NAN, "ratings.current_a"),
        (|r| r.bus_v = 0.0, "ratings.bus_v"),
        (|r| r.speed_rpm = -1.0, "ratings.speed_rpm"),
        // 3 N·m at 3 A where N ψ_f I = 0.70 N·m.
        (|r| r.torque_nm = 3.0, "ratings.torque_nm"),
        // Rated torque at 10 A: the torque of the current is 3.3 times too large.
        (|r| r.current_a = 10.0, "ratings.torque_nm"),
        (|r| r.power_w = 500.0, "ratings.power_w"),
    ];
    for (mutate, field) in cases {
        let mut m = base;
        mutate(&mut m.ratings);
        let e = m.validate().unwrap_err();
        assert_eq!(e.field(), field, "{e}");
    }
}

#[test]
fn presets_are_valid_and_named_uniquely() {
    for m in motor::PRESETS {
        assert_eq!(m.params.validate(), Ok(m.params), "{}", m.name);
        assert_eq!(m.ratings.validate(), Ok(m.ratings), "{}", m.name);
        assert_eq!(m.validate(), Ok(m), "{}", m.name);
        assert_eq!(motor::preset(m.name), Some(m));
    }
    assert_eq!(motor::preset("nope"), None);
    // Horng & Chin Table 1 and Ortega Table I values as printed.
    let s = motor::HORNG_SINANO.params;
    assert_eq!(
        (s.pole_pairs, s.r_ohm, s.l_h, s.flux_wb),
        (4, 2.5, 5.97e-3, 5.795e-2)
    );
    assert_eq!((s.j_kgm2, s.b_nms), (6.45e-5, 8.06e-5));
    let t = motor::ORTEGA_TEST_0P3KW;
    assert_eq!(
        (
            t.params.pole_pairs,
            t.params.flux_wb,
            t.params.l_h,
            t.params.r_ohm
        ),
        (4, 0.11, 1.14e-3, 0.675)
    );
    assert_eq!(
        (
            t.ratings.bus_v,
            t.ratings.torque_nm,
            t.ratings.speed_rpm,
            t.ratings.current_a
        ),
        (200.0, 3.0, 1000.0, 6.82)
    );
}
