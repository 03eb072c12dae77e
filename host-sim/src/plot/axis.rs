//! Axes: ranges from finite data, tick labels, the y label area's width and data-to-pixel
//! mapping.

use super::style::tick_style;
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::*;

/// Largest magnitude considered when computing ranges; keeps spans finite.
pub(super) const MAX_MAG: f64 = 1e300;

/// Axis range `(lo, hi)` with `lo < hi` from the finite values of `values`,
/// widened by `margin` (fraction of the span) on both sides.
///
/// Empty input gives `(0, 1)`; a (numerically) constant input `v` gives
/// `v ± 1` for `v == 0`, otherwise `v ± |v|·0.1`.
pub(super) fn axis_range(values: impl Iterator<Item = f64>, margin: f64) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite()) {
        let v = v.clamp(-MAX_MAG, MAX_MAG);
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if lo > hi {
        return (0.0, 1.0);
    }
    let span = hi - lo;
    let mag = lo.abs().max(hi.abs());
    if span <= mag * 1e-9 || span == 0.0 {
        let c = 0.5 * (lo + hi);
        let d = if c == 0.0 { 1.0 } else { c.abs() * 0.1 };
        return (c - d, c + d);
    }
    (lo - span * margin, hi + span * margin)
}

/// Tick label formatter adapted to the axis range and to the tick positions
/// plotters will actually use for `n_labels` labels: fixed-point with just
/// enough decimals for the tick spacing, scientific notation (same number of
/// significant digits on every tick) for very large or very small magnitudes.
pub(super) fn tick_formatter((lo, hi): (f64, f64), n_labels: usize) -> impl Fn(&f64) -> String {
    let span = (hi - lo).abs();
    let ticks = RangedCoordf64::from(lo..hi).key_points(n_labels);
    let step = match ticks.as_slice() {
        [a, b, ..] if b > a => b - a,
        _ => span / n_labels.max(1) as f64,
    };
    // Small epsilon so that e.g. log10(0.1) = -0.99999.. still counts as -1.
    let step_exp = (step.log10() + 1e-9).floor();
    let mag = ticks
        .iter()
        .fold(0.0f64, |m, t| m.max(t.abs()))
        .max(f64::MIN_POSITIVE);
    let sci = !(1e-3..1e5).contains(&mag);
    let (sci_decimals, fixed_decimals) = if sci {
        let mag_exp = (mag.log10() + 1e-9).floor();
        (((mag_exp - step_exp).max(0.0) as usize).min(6), 0)
    } else {
        (0, ((-step_exp).max(0.0) as usize).min(9))
    };
    move |v: &f64| {
        // Snap values that are zero up to rounding ("-0.000", "1.2e-17").
        let v = if v.abs() < span * 1e-9 { 0.0 } else { *v };
        if sci && v != 0.0 {
            format!("{v:.sci_decimals$e}")
        } else {
            format!("{v:.fixed_decimals$}")
        }
    }
}

/// Backend pixel of a data point, clamped to the axis ranges.
///
/// plotters' `RangedCoordf64::map` adds `f64 as i32` pixel offsets with plain
/// `+`, which overflows (a panic in debug builds) for values far outside the
/// range; clamping also keeps lines from leaking into neighbouring panels, as
/// plotters does not clip elements to the plotting area.
pub(super) fn to_px<'a, DB: DrawingBackend + 'a>(
    chart: &ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    (x, y): (f64, f64),
) -> (i32, i32) {
    let xr = chart.x_range();
    let yr = chart.y_range();
    chart.backend_coord(&(x.clamp(xr.start, xr.end), y.clamp(yr.start, yr.end)))
}

/// Width of the y label area: widest tick label over `ranges` plus tick
/// marks, gap and the rotated axis description.
pub(super) fn y_label_area(ranges: &[(f64, f64)], n_labels: usize) -> u32 {
    let font = tick_style().font;
    let widest = ranges
        .iter()
        .flat_map(|&r| {
            let fmt = tick_formatter(r, n_labels);
            RangedCoordf64::from(r.0..r.1)
                .key_points(n_labels)
                .into_iter()
                .map(move |v| fmt(&v))
        })
        .map(|l| {
            font.box_size(&l)
                .map(|(w, _)| w)
                .unwrap_or(9 * l.len() as u32)
        })
        .max()
        .unwrap_or(0);
    // 2 x tick size (plotters' label distance) + gap + description + margin.
    (widest + 10 + 12 + 20 + 4).clamp(50, 200)
}
