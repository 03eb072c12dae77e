//! Lines in pixel space: polylines drawn segment by segment, dashes, finite runs of a series
//! and min/max decimation per pixel column.

use plotters::coord::Shift;
use plotters::prelude::*;

/// Draws a polyline given in backend pixel coordinates on `area` (whose origin
/// must be the backend origin).
///
/// plotters turns a wide (> 1 px) polyline into one polygon with mitred joins,
/// which produces long spikes and fill artefacts for dense, zig-zagging data.
/// Drawing each segment on its own avoids that (joins of 2 px segments are
/// visually seamless); 1 px lines are rasterised segment-wise by plotters anyway.
///
/// Pixels along the line (sampled every few pixels) are appended to `occupied`
/// for legend placement.
pub(super) fn draw_polyline_px<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    pts: impl IntoIterator<Item = (i32, i32)>,
    style: ShapeStyle,
    occupied: &mut Vec<(i32, i32)>,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let mut px: Vec<(i32, i32)> = pts.into_iter().collect();
    px.dedup();
    occupied.extend(px.first().copied());
    for w in px.windows(2) {
        let (dx, dy) = (f64::from(w[1].0 - w[0].0), f64::from(w[1].1 - w[0].1));
        let n = (dx.abs().max(dy.abs()) / 4.0).ceil().min(1e4) as i32;
        for i in 1..=n {
            let t = f64::from(i) / f64::from(n);
            let x = f64::from(w[0].0) + t * dx;
            let y = f64::from(w[0].1) + t * dy;
            occupied.push((x.round() as i32, y.round() as i32));
        }
    }
    if style.stroke_width <= 1 {
        if px.len() >= 2 {
            area.draw(&PathElement::new(px, style))?;
        } else if let Some(&p) = px.first() {
            area.draw_pixel(p, &style.color)?;
        }
        return Ok(());
    }
    if let [p] = px.as_slice() {
        let r = (style.stroke_width / 2).max(1) as i32;
        area.draw(&Circle::new(*p, r, style.color.filled()))?;
    }
    for w in px.windows(2) {
        area.draw(&PathElement::new(vec![w[0], w[1]], style))?;
    }
    Ok(())
}

/// Splits a pixel polyline into dashes of length `on` separated by gaps `off`
/// (measured along the line, continuing across vertices).
pub(super) fn dash_px(px: &[(i32, i32)], on: f64, off: f64) -> Vec<Vec<(i32, i32)>> {
    let to_i = |(x, y): (f64, f64)| (x.round() as i32, y.round() as i32);
    let mut dashes = Vec::new();
    let mut cur: Vec<(i32, i32)> = Vec::new();
    let mut drawing = true;
    let mut left = on; // length left in the current dash or gap
    for w in px.windows(2) {
        let a = (f64::from(w[0].0), f64::from(w[0].1));
        let b = (f64::from(w[1].0), f64::from(w[1].1));
        let len = ((b.0 - a.0).powi(2) + (b.1 - a.1).powi(2)).sqrt();
        if len == 0.0 {
            continue;
        }
        let at = |d: f64| (a.0 + (b.0 - a.0) * d / len, a.1 + (b.1 - a.1) * d / len);
        if drawing && cur.is_empty() {
            cur.push(to_i(a));
        }
        let mut pos = 0.0;
        while len - pos > left {
            pos += left;
            if drawing {
                cur.push(to_i(at(pos)));
                dashes.push(std::mem::take(&mut cur));
                left = off;
            } else {
                cur.push(to_i(at(pos)));
                left = on;
            }
            drawing = !drawing;
        }
        left -= len - pos;
        if drawing {
            cur.push(to_i(b));
        }
    }
    if cur.len() > 1 {
        dashes.push(cur);
    }
    dashes
}

/// Splits `(x[i], y[i])` pairs into runs of consecutive finite points.
/// Non-finite points are dropped and act as separators (gaps in the line).
pub(super) fn finite_segments(x: &[f64], y: &[f64]) -> Vec<Vec<(f64, f64)>> {
    let mut out = Vec::new();
    let mut cur = Vec::new();
    for (&xi, &yi) in x.iter().zip(y) {
        if xi.is_finite() && yi.is_finite() {
            cur.push((xi, yi));
        } else if !cur.is_empty() {
            out.push(std::mem::take(&mut cur));
        }
    }
    if !cur.is_empty() {
        out.push(cur);
    }
    out
}

/// Min/max decimation for drawing: `points` (finite, x normally ascending) are
/// grouped into `columns` equal-width x bins over `[x_lo, x_hi]`; each run of
/// consecutive points falling into the same bin is reduced to its first,
/// minimum-y, maximum-y and last point, kept in original order. The line drawn
/// through the result covers exactly the same pixels column by column, so
/// spikes of a single sample survive.
///
/// Inputs with at most `4 * columns` points are returned unchanged. Works for
/// unsorted x as well (runs are just shorter), never panics.
pub fn decimate_min_max(
    points: &[(f64, f64)],
    x_lo: f64,
    x_hi: f64,
    columns: usize,
) -> Vec<(f64, f64)> {
    let columns = columns.max(1);
    if points.len() <= 4 * columns {
        return points.to_vec();
    }
    let width = x_hi - x_lo;
    let scale = if width.is_finite() && width > 0.0 {
        columns as f64 / width
    } else {
        0.0
    };
    let bin = |x: f64| -> usize {
        let b = ((x - x_lo) * scale).floor();
        if b.is_nan() || b < 0.0 {
            0
        } else {
            (b as usize).min(columns - 1)
        }
    };

    let mut out = Vec::with_capacity(4 * columns + 4);
    let mut start = 0;
    while start < points.len() {
        let b = bin(points[start].0);
        let mut end = start + 1;
        while end < points.len() && bin(points[end].0) == b {
            end += 1;
        }
        let run = &points[start..end];
        let (mut imin, mut imax) = (0, 0);
        for (i, p) in run.iter().enumerate() {
            if p.1 < run[imin].1 {
                imin = i;
            }
            if p.1 > run[imax].1 {
                imax = i;
            }
        }
        let mut idx = [0, imin, imax, run.len() - 1];
        idx.sort_unstable();
        let mut prev = usize::MAX;
        for i in idx {
            if i != prev {
                out.push(run[i]);
                prev = i;
            }
        }
        start = end;
    }
    out
}
