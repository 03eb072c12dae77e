//! Motors from TOML files (`--motor-file FILE.toml`), validated by the core, straight from a
//! datasheet, in physical units.
//!
//! ```toml
//! name = "my-motor"
//! pole_pairs = 4         # or poles = 8 (magnet poles)
//! r_ohm = 2.5            # phase (wye) resistance, or r_ohm_ll = 5.0 line-to-line
//! l_h = 5.97e-3          # phase inductance, or l_h_ll = 11.94e-3 line-to-line; a salient
//! # motor gives l_d_h and l_q_h (or l_d_h_ll, l_q_h_ll) instead
//! flux_wb = 5.795e-2     # Horng's K = Ortega's Φ; or kv_rpm_per_v, or ke_v_per_krpm, with
//! # ke_form = "ll-peak" (the default) | "ll-rms": which voltage the datasheet's Kv or Ke is of
//! j_kgm2 = 6.45e-5
//! b_nms = 8.06e-5        # may be 0; 0 when left out
//! # torque_convention = "three-phase" (the default) | "papers"
//! [ratings]
//! bus_v = 48.0
//! current_a = 3.0        # peak phase current (current_a_rms: × √2)
//! torque_nm = 1.04       # default: the torque at current_a, 1.5·pole_pairs·flux_wb·current_a
//! speed_rpm = 1000.0     # default: 80 % of the speed whose back-EMF is bus_v/√3
//! power_w = 109.0        # default: torque_nm × speed
//! [saturation.d]         # optional (default: none, L_d constant): L_d falls as a current
//! i_sat_a = 300.0        # adds to the magnet's flux, L_d(i_d) = L_d/(1 + (i_d/i_sat_a)^exponent)
//! exponent = 1.0         # for i_d > 0 (0 < exponent ≤ 1, default 1: Fröhlich's curve)
//! [saturation.q]         # optional (default: none): L_q(i_q) = L_q/(1 + (|i_q|/i_sat_a)^exponent)
//! i_sat_a = 200.0
//! ```
//!
//! Salient motors (`l_d_h`, `l_q_h`; `pmsm_plant::inductance` for the saturation model):
//! the plant runs on `L_d`, `L_q` and the saturation ([`Loaded::inductances`]); the drive is
//! given both unsaturated ones, as their mean `l_h` ([`Inductances::non_salient_l_h`], the one
//! `L` of the blocks written for a non-salient motor) and their ratio `saliency`
//! ([`Inductances::saliency`]; `MotorParams::l_d_h`, `MotorParams::l_q_h`). `l_h` alone means `L_d = L_q = l_h`. Each inductance must be within the
//! core's range for `l_h`, and `L_q/L_d` within [`SALIENCY`] (inverse-saliency machines
//! reach about 0.5, interior-magnet ones 1.5 to 4, PM-assisted synchronous reluctance
//! machines up to about 10); a saturation needs `i_sat_a` > 0 A and `exponent` in (0, 1].
//!
//! Conversions (a wye-connected, non-salient motor; the amplitude-invariant αβ model,
//! phase-peak back-EMF `N ψ_f ω_m`):
//! - `ψ_f = K_e,ll,peak / (√3 N)`, with `K_e,ll,peak` \[V·s/rad] = `60/(2π Kv)` for Kv in rpm/V
//!   and = `Ke·60/(2π·1000)` for Ke in V/krpm; an rms Kv or Ke is first made peak (× √2 on
//!   the voltage: `K_e,peak = √2 K_e,rms`). Without `ke_form` a Kv or Ke is line-to-line peak,
//!   the hobby convention (a motor spun open-circuit, its peak line voltage per rpm; ODrive's
//!   `torque_constant = 8.27/Kv` assumes it: 8.27 = (3/2)·60/(2π√3), the torque constant
//!   `(3/2) N ψ_f` of a Kv of 1 rpm/V line-to-line peak). Write `ke_form = "ll-rms"` when
//!   the datasheet names rms.
//! - `R = R_ll/2`, `L = L_ll/2` (`L_d`, `L_q` the same: the line-to-line inductance with the
//!   rotor's d or q axis on the measuring axis).
//! - Torque (`pmsm_sensorless::motor::TorqueConvention`): physical N·m, `τ = (3/2) N ψ_f i_q`
//!   with `i_q` the phase-peak current, for J, B, the ratings and every load torque;
//!   `torque_convention = "papers"` reads them in the papers' `τ = N ψ_f i_q` instead (the
//!   papers' presets and the made-up motors written in it).

use crate::number;
use pmsm_plant::{Inductances, Saturation};
use pmsm_sensorless::motor::{Motor, MotorParams, Ratings, TorqueConvention};
use pmsm_sensorless::param::{Allowed, ParamError};
use serde::Deserialize;
use std::f64::consts::{PI, SQRT_2};
use std::path::Path;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MotorFile {
    name: String,
    pole_pairs: Option<i64>,
    poles: Option<i64>,
    r_ohm: Option<f64>,
    r_ohm_ll: Option<f64>,
    l_h: Option<f64>,
    l_h_ll: Option<f64>,
    l_d_h: Option<f64>,
    l_d_h_ll: Option<f64>,
    l_q_h: Option<f64>,
    l_q_h_ll: Option<f64>,
    flux_wb: Option<f64>,
    kv_rpm_per_v: Option<f64>,
    ke_v_per_krpm: Option<f64>,
    ke_form: Option<String>,
    j_kgm2: f64,
    b_nms: Option<f64>,
    torque_convention: Option<String>,
    ratings: RatingsFile,
    saturation: Option<SaturationFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SaturationFile {
    d: Option<AxisSaturationFile>,
    q: Option<AxisSaturationFile>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AxisSaturationFile {
    i_sat_a: f64,
    exponent: Option<f64>,
}

/// `L_q/L_d` allowed in a motor file (module doc).
pub const SALIENCY: (f64, f64) = (0.5, 10.0);

/// A motor file as loaded: its name, the drive's motor, and the plant's own inductances.
#[derive(Clone, Debug)]
pub struct Loaded {
    /// The file's `name`.
    pub name: String,
    /// The motor as the drive knows it (one inductance `l_h`).
    pub motor: Motor,
    /// The plant's `L_d`, `L_q` and saturation when the file gives `l_d_h`/`l_q_h` or a
    /// `[saturation]`; `None`: `L_d = L_q = l_h`, no saturation.
    pub inductances: Option<Inductances>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RatingsFile {
    bus_v: f64,
    current_a: Option<f64>,
    current_a_rms: Option<f64>,
    torque_nm: Option<f64>,
    speed_rpm: Option<f64>,
    power_w: Option<f64>,
}

/// A value as the file gave it: the key, the value written, and the value in the model's
/// terms.
type Given = (&'static str, f64, f64);

/// The one of two alternative keys given: `a` as is, `b` through `convert`.
fn one_of(
    (a, va): (&'static str, Option<f64>),
    (b, vb): (&'static str, Option<f64>),
    convert: impl Fn(f64) -> f64,
) -> anyhow::Result<Given> {
    match (va, vb) {
        (Some(v), None) => Ok((a, v, v)),
        (None, Some(v)) => Ok((b, v, convert(v))),
        (Some(_), Some(_)) => anyhow::bail!("give {a} or {b}, not both"),
        (None, None) => anyhow::bail!("missing field: {a} (or {b})"),
    }
}

/// The error of the core in the file's terms: the key the user wrote and the value as
/// written (`r_ohm_ll = 1e300: gives r_ohm = inf, ...`, not only the phase value in f32).
fn in_file_terms(e: ParamError, given: &[(&str, Given)]) -> anyhow::Error {
    let Some((_, (key, v, _))) = given.iter().find(|(field, _)| *field == e.field) else {
        return anyhow::anyhow!("{e}");
    };
    let range = if v.is_finite() {
        format!("allowed {}", e.allowed)
    } else {
        format!("must be a finite number in {}", e.allowed)
    };
    if *key == e.field {
        anyhow::anyhow!("{key} = {}: {range}", number(*v))
    } else {
        let model = e.to_string();
        let model = model.split_once(": ").map_or(model.as_str(), |(fv, _)| fv);
        anyhow::anyhow!("{key} = {}: gives {model}, {range}", number(*v))
    }
}

/// Parses and validates a motor file's text; the error is one line naming the bad key, its
/// value and the range allowed.
pub fn parse(text: &str) -> anyhow::Result<(String, Motor)> {
    parse_full(text).map(|l| (l.name, l.motor))
}

/// As [`parse`], with the plant's own inductances ([`Loaded`]).
pub fn parse_full(text: &str) -> anyhow::Result<Loaded> {
    let f: MotorFile = crate::from_toml(text)?;
    let n = match (f.pole_pairs, f.poles) {
        (Some(n), None) => n,
        (None, Some(p)) => {
            anyhow::ensure!(
                p % 2 == 0,
                "poles = {p}: must be even (magnets come in pairs)"
            );
            p / 2
        }
        (Some(_), Some(_)) => anyhow::bail!("give pole_pairs or poles, not both"),
        (None, None) => anyhow::bail!("missing field: pole_pairs (or poles)"),
    };
    let pole_pairs = u32::try_from(n)
        .ok()
        .filter(|n| MotorParams::POLE_PAIRS.contains(*n as f32))
        .ok_or_else(|| anyhow::anyhow!("pole_pairs = {n}: allowed {}", MotorParams::POLE_PAIRS))?;
    let r = one_of(("r_ohm", f.r_ohm), ("r_ohm_ll", f.r_ohm_ll), |v| v / 2.0)?;
    let (l, inductances) = inductances(&f)?;
    let flux = flux_wb(&f, pole_pairs)?;
    let b_nms = f.b_nms.unwrap_or(0.0);
    let given = [
        ("r_ohm", r),
        ("l_h", l),
        ("flux_wb", flux),
        ("j_kgm2", ("j_kgm2", f.j_kgm2, f.j_kgm2)),
        ("b_nms", ("b_nms", b_nms, b_nms)),
    ];
    let torque = match f.torque_convention.as_deref() {
        None | Some("three-phase") => TorqueConvention::ThreePhase,
        Some("papers") => TorqueConvention::Papers,
        Some(other) => {
            anyhow::bail!("torque_convention = \"{other}\": allowed \"three-phase\" or \"papers\"")
        }
    };
    let params = MotorParams::new(
        pole_pairs,
        r.2 as f32,
        l.2 as f32,
        flux.2 as f32,
        f.j_kgm2 as f32,
        b_nms as f32,
    )
    .map_err(|e| in_file_terms(e, &given))?
    .with_torque(torque);
    // The drive is given both inductances: `l_h` their mean, `saliency` their ratio
    // (`MotorParams::l_d_h`, `MotorParams::l_q_h`); a non-salient file keeps saliency 1.
    let params = match &inductances {
        Some(own) => MotorParams {
            saliency: own.saliency() as f32,
            ..params
        }
        .validate()
        .map_err(|e| in_file_terms(e, &given))?,
        None => params,
    };
    let rf = &f.ratings;
    let current = one_of(
        ("ratings.current_a", rf.current_a),
        ("ratings.current_a_rms", rf.current_a_rms),
        |v| v * SQRT_2,
    )?;
    let kt = f64::from(params.torque_constant());
    let torque_nm = rf.torque_nm.unwrap_or(kt * current.2);
    let bus_rpm = f64::from(params.bus_limited_rpm(rf.bus_v as f32));
    let speed_rpm = rf.speed_rpm.unwrap_or(0.8 * bus_rpm);
    let power_w = rf
        .power_w
        .unwrap_or(torque_nm * speed_rpm * 2.0 * PI / 60.0);
    let motor = Motor {
        name: "file",
        params,
        ratings: Ratings {
            bus_v: rf.bus_v as f32,
            current_a: current.2 as f32,
            torque_nm: torque_nm as f32,
            speed_rpm: speed_rpm as f32,
            power_w: power_w as f32,
        },
    };
    let given = [
        ("ratings.bus_v", ("ratings.bus_v", rf.bus_v, rf.bus_v)),
        ("ratings.current_a", current),
    ];
    let motor = motor.validate().map_err(|e| in_file_terms(e, &given))?;
    Ok(Loaded {
        name: f.name,
        motor,
        inductances,
    })
}

/// The drive's one inductance (the key it came from) and the plant's own inductances: `l_h`
/// (or `l_h_ll`) alone, or `l_d_h` and `l_q_h` (or their `_ll` forms), with the optional
/// `[saturation]` (module doc).
fn inductances(f: &MotorFile) -> anyhow::Result<(Given, Option<Inductances>)> {
    let half = |v: f64| v / 2.0;
    let salient = [f.l_d_h, f.l_d_h_ll, f.l_q_h, f.l_q_h_ll]
        .iter()
        .any(Option::is_some);
    let saturation_d = axis_saturation(
        "saturation.d",
        f.saturation.as_ref().and_then(|s| s.d.as_ref()),
    )?;
    let saturation_q = axis_saturation(
        "saturation.q",
        f.saturation.as_ref().and_then(|s| s.q.as_ref()),
    )?;
    let saturates = saturation_d.is_some() || saturation_q.is_some();
    if !salient {
        let l = one_of(("l_h", f.l_h), ("l_h_ll", f.l_h_ll), half)?;
        let own = saturates.then_some(Inductances {
            l_d_h: l.2,
            l_q_h: l.2,
            saturation_d,
            saturation_q,
        });
        return Ok((l, own));
    }
    anyhow::ensure!(
        f.l_h.is_none() && f.l_h_ll.is_none(),
        "give l_h (or l_h_ll) or l_d_h and l_q_h (or l_d_h_ll, l_q_h_ll), not both"
    );
    let l_d = one_of(("l_d_h", f.l_d_h), ("l_d_h_ll", f.l_d_h_ll), half)?;
    let l_q = one_of(("l_q_h", f.l_q_h), ("l_q_h_ll", f.l_q_h_ll), half)?;
    for (key, v, phase_h) in [l_d, l_q] {
        let allowed = MotorParams::L_H;
        let range = if key.ends_with("_ll") {
            "gives a phase inductance outside the allowed"
        } else {
            "allowed"
        };
        anyhow::ensure!(
            phase_h.is_finite() && allowed.contains(phase_h as f32),
            "{key} = {}: {range} {allowed} H",
            number(v)
        );
    }
    let ratio = l_q.2 / l_d.2;
    anyhow::ensure!(
        (SALIENCY.0..=SALIENCY.1).contains(&ratio),
        "{} / {} = {}: allowed [{}, {}] (L_q/L_d of real machines)",
        l_q.0,
        l_d.0,
        number(ratio),
        SALIENCY.0,
        SALIENCY.1
    );
    let own = Inductances {
        l_d_h: l_d.2,
        l_q_h: l_q.2,
        saturation_d,
        saturation_q,
    };
    let l_h = own.non_salient_l_h();
    Ok((("l_h", l_h, l_h), Some(own)))
}

/// One axis' `[saturation.d]` or `[saturation.q]`, checked; errors name the key.
fn axis_saturation(
    table: &str,
    s: Option<&AxisSaturationFile>,
) -> anyhow::Result<Option<Saturation>> {
    let Some(s) = s else {
        return Ok(None);
    };
    anyhow::ensure!(
        s.i_sat_a.is_finite() && s.i_sat_a > 0.0,
        "{table}.i_sat_a = {}: must be a finite number > 0 A",
        number(s.i_sat_a)
    );
    let exponent = s.exponent.unwrap_or(Saturation::EXPONENT_MAX);
    anyhow::ensure!(
        exponent.is_finite() && exponent > 0.0 && exponent <= Saturation::EXPONENT_MAX,
        "{table}.exponent = {}: allowed (0, {}] (beyond it the flux would fall as the current rises)",
        number(exponent),
        Saturation::EXPONENT_MAX
    );
    Ok(Some(Saturation {
        i_sat_a: s.i_sat_a,
        exponent,
    }))
}

/// `flux_wb` from whichever of `flux_wb`, `kv_rpm_per_v`, `ke_v_per_krpm` the file gives
/// (module doc): the key used and the flux linkage \[Wb].
fn flux_wb(f: &MotorFile, pole_pairs: u32) -> anyhow::Result<Given> {
    let given: Vec<_> = [
        ("flux_wb", f.flux_wb),
        ("kv_rpm_per_v", f.kv_rpm_per_v),
        ("ke_v_per_krpm", f.ke_v_per_krpm),
    ]
    .into_iter()
    .filter_map(|(k, v)| v.map(|v| (k, v)))
    .collect();
    let (key, v) = match given[..] {
        [one] => one,
        [] => anyhow::bail!("missing field: flux_wb (or kv_rpm_per_v, or ke_v_per_krpm)"),
        _ => anyhow::bail!("give one of flux_wb, kv_rpm_per_v, ke_v_per_krpm"),
    };
    if key == "flux_wb" {
        anyhow::ensure!(
            f.ke_form.is_none(),
            "ke_form is for kv_rpm_per_v or ke_v_per_krpm"
        );
        return Ok(("flux_wb", v, v));
    }
    let peak = match f.ke_form.as_deref() {
        None | Some("ll-peak") => 1.0,
        Some("ll-rms") => SQRT_2,
        Some(other) => anyhow::bail!("ke_form = \"{other}\": allowed \"ll-peak\" or \"ll-rms\""),
    };
    Allowed::POSITIVE
        .check(key, v as f32)
        .map_err(|e| anyhow::anyhow!("{key} = {}: allowed {}", number(v), e.allowed))?;
    // Line-to-line back-EMF constant [V·s/rad] as given, then made peak.
    let ke_ll = if key == "kv_rpm_per_v" {
        60.0 / (2.0 * PI * v)
    } else {
        v * 60.0 / (2.0 * PI * 1000.0)
    };
    Ok((key, v, peak * ke_ll / (3f64.sqrt() * f64::from(pole_pairs))))
}

/// Reads and validates a motor file.
pub fn load(path: &Path) -> anyhow::Result<(String, Motor)> {
    load_full(path).map(|l| (l.name, l.motor))
}

/// As [`load`], with the plant's own inductances ([`Loaded`]).
pub fn load_full(path: &Path) -> anyhow::Result<Loaded> {
    let text =
        std::fs::read_to_string(path).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    parse_full(&text).map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))
}
