//! Motor parameter validation and presets.

use pmsm_sensorless::motor::{self, MotorParams, ParamError};

fn ok() -> [f32; 5] {
    [2.5, 5.97e-3, 5.795e-2, 6.45e-5, 8.06e-5]
}

fn build(v: [f32; 5]) -> Result<MotorParams, ParamError> {
    MotorParams::new(4, v[0], v[1], v[2], v[3], v[4])
}

#[test]
fn every_bad_field_is_named() {
    let names = ["r_ohm", "l_h", "flux_wb", "j_kgm2", "b_nms"];
    for (k, name) in names.iter().enumerate() {
        for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -1.0] {
            let mut v = ok();
            v[k] = bad;
            let e = build(v).unwrap_err();
            assert_eq!(e.field(), *name, "{bad} in {name}");
        }
        let mut v = ok();
        v[k] = 0.0;
        if *name == "b_nms" {
            assert!(build(v).is_ok(), "zero friction is allowed");
        } else {
            assert_eq!(build(v).unwrap_err(), ParamError::NotPositive(name));
        }
    }
    let e = MotorParams::new(0, 2.5, 5.97e-3, 5.795e-2, 6.45e-5, 0.0).unwrap_err();
    assert_eq!(e.field(), "pole_pairs");
    assert_eq!(e.to_string(), "pole_pairs: must be greater than zero");
}

#[test]
fn presets_are_valid_and_named_uniquely() {
    for m in motor::PRESETS {
        assert_eq!(m.params.validate(), Ok(m.params), "{}", m.name);
        assert_eq!(m.ratings.validate(), Ok(m.ratings), "{}", m.name);
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
        (200.0, 3.0, 1000.0, 3.0)
    );
}
