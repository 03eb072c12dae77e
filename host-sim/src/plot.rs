//! Small PNG plotting helpers for simulation time series and x–y plots.
//!
//! Rendering uses `plotters` with its `ab_glyph` text backend and the DejaVu
//! Sans font embedded via the `dejavu` crate, so no system fonts (fontconfig,
//! freetype, ...) are needed. The font is registered once per process under
//! the family name `"sans-serif"`.
//!
//! Design notes:
//! * Axis ranges are computed from the finite values only (NaN / ±inf are
//!   ignored), with a small margin; empty or constant data gets a sane
//!   fallback range, so no input can make the plotting panic.
//! * Non-finite samples break a line into separate segments (a visible gap).
//! * Long time series are decimated by min/max per pixel column before drawing
//!   ([`decimate_min_max`]) so single-sample spikes are preserved.
//! * `x` and `y` of a [`Series`] are paired with `zip`, so a length mismatch
//!   silently uses the shorter of the two.

use std::collections::HashSet;
use std::path::Path;
use std::sync::OnceLock;

use anyhow::{anyhow, bail, Context};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::{register_font, FontStyle, RGBColor};

/// One named data series (`x[i]`, `y[i]` pairs).
#[derive(Debug, Clone, Copy)]
pub struct Series<'a> {
    pub label: &'a str,
    pub x: &'a [f64],
    pub y: &'a [f64],
}

/// One stacked sub-plot of [`plot_panels`].
#[derive(Debug, Clone)]
pub struct Panel<'a> {
    pub title: &'a str,
    pub y_label: &'a str,
    pub series: Vec<Series<'a>>,
}

/// Image width in pixels.
pub const WIDTH: u32 = 1200;
/// Height of one panel of [`plot_panels`] in pixels.
pub const PANEL_HEIGHT: u32 = 300;
/// Height of the x–y plot of [`plot_xy`] in pixels.
pub const XY_HEIGHT: u32 = 900;

const FONT_FAMILY: &str = "sans-serif";
const TITLE_HEIGHT: u32 = 44;
/// Extra height of the bottom panel that holds the shared x-axis label.
const X_DESC_HEIGHT: u32 = 26;
const LIGHT_LINES: usize = 4;
const X_LABEL_AREA: u32 = 30;
const MARGIN_RIGHT: u32 = 24;
const X_LABELS: usize = 12;
const POINT_RADIUS: i32 = 3;
const LEGEND_FONT_SIZE: u32 = 15;
const LEGEND_MARGIN: u32 = 10;
const LEGEND_AREA: u32 = 32;
const PANEL_Y_LABELS: usize = 6;
/// Upper bound on panels per image (keeps the pixel buffer < ~100 MB).
const MAX_PANELS: usize = 100;
const XY_Y_LABELS: usize = 12;

/// Distinct, colour-blind-friendly-ish line colours (Matplotlib "tab10").
const PALETTE: [RGBColor; 10] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
];

/// Colour of series number `i` (cycles through the palette).
fn series_color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Registers the embedded DejaVu Sans font with plotters exactly once.
///
/// `plotters` with the `ab_glyph` feature has no font until one is registered;
/// drawing any text before that fails with `FontUnavailable`.
fn ensure_fonts() -> anyhow::Result<()> {
    static REGISTERED: OnceLock<Result<(), String>> = OnceLock::new();
    REGISTERED
        .get_or_init(|| {
            // `InvalidFont` implements neither Debug nor Error, hence map_err.
            register_font(FONT_FAMILY, FontStyle::Normal, dejavu::sans::regular())
                .map_err(|_| "DejaVu Sans regular".to_string())?;
            register_font(FONT_FAMILY, FontStyle::Bold, dejavu::sans::bold())
                .map_err(|_| "DejaVu Sans bold".to_string())?;
            Ok(())
        })
        .clone()
        .map_err(|which| anyhow!("failed to register embedded font {which} with plotters"))
}

/// Writes a PNG with the panels stacked vertically, sharing the x range and the
/// x-axis label `x_label` (shown under the bottom panel).
///
/// Each panel gets its own y range and y label; a legend is drawn when a panel
/// holds more than one series. Non-finite samples are skipped (they split the
/// line), empty series and panels are allowed (an empty panel shows "no data").
/// Errors if `panels` is empty or has more than 100 entries, or if the file
/// cannot be written (the error message names `path`).
pub fn plot_panels(
    path: &Path,
    title: &str,
    x_label: &str,
    panels: &[Panel],
) -> anyhow::Result<()> {
    draw_panels(path, title, x_label, panels)
        .with_context(|| format!("failed to write plot {}", path.display()))
}

/// Writes a PNG with an x–y plot (e.g. a root locus).
///
/// With `points_only` every series is drawn as small filled markers, otherwise
/// as lines (non-finite points split the line). `circles` are
/// `(centre_x, centre_y, radius, label)` drawn as dashed outlines in data
/// coordinates (so they appear as ellipses unless the axes happen to have
/// equal scale); a non-empty label adds a legend entry. A legend is drawn
/// when there is more than one labelled item.
pub fn plot_xy(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    circles: &[(f64, f64, f64, &str)],
    points_only: bool,
) -> anyhow::Result<()> {
    draw_xy(path, title, x_label, y_label, series, circles, points_only)
        .with_context(|| format!("failed to write plot {}", path.display()))
}

// ---------------------------------------------------------------------------
// Drawing
// ---------------------------------------------------------------------------

fn title_style() -> TextStyle<'static> {
    (FONT_FAMILY, 26)
        .into_font()
        .style(FontStyle::Bold)
        .color(&BLACK)
}

fn caption_style() -> TextStyle<'static> {
    (FONT_FAMILY, 19).into_font().color(&BLACK)
}

fn label_style() -> TextStyle<'static> {
    (FONT_FAMILY, 16).into_font().color(&BLACK)
}

fn tick_style() -> TextStyle<'static> {
    (FONT_FAMILY, 14).into_font().color(&RGBColor(40, 40, 40))
}

fn legend_style() -> TextStyle<'static> {
    (FONT_FAMILY, LEGEND_FONT_SIZE).into_font().color(&BLACK)
}

fn draw_panels(path: &Path, title: &str, x_label: &str, panels: &[Panel]) -> anyhow::Result<()> {
    ensure_fonts()?;
    if panels.is_empty() {
        bail!("no panels to plot");
    }
    if panels.len() > MAX_PANELS {
        bail!("too many panels ({} > {MAX_PANELS})", panels.len());
    }
    let n = panels.len() as u32; // <= MAX_PANELS
    let height = n * PANEL_HEIGHT + TITLE_HEIGHT + X_DESC_HEIGHT;

    let root = BitMapBackend::new(path, (WIDTH, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let body = titled(&root, title)?;

    // Shared x range over all panels.
    let x_range = axis_range(
        panels
            .iter()
            .flat_map(|p| p.series.iter())
            .flat_map(|s| s.x.iter().zip(s.y).map(|(&x, _)| x)),
        0.0,
    );

    // Equal panel heights; the bottom one is taller by the x-description strip.
    let breaks: Vec<u32> = (1..n).map(|i| i * PANEL_HEIGHT).collect();
    let areas = body.split_by_breakpoints([] as [u32; 0], breaks);

    let y_ranges: Vec<(f64, f64)> = panels
        .iter()
        .map(|panel| {
            axis_range(
                panel
                    .series
                    .iter()
                    .flat_map(|s| s.x.iter().zip(s.y).map(|(_, &y)| y)),
                0.06,
            )
        })
        .collect();
    // Same label-area width on every panel so the x axes line up.
    let y_area = y_label_area(&y_ranges, PANEL_Y_LABELS);

    for (i, ((panel, area), &y_range)) in panels.iter().zip(&areas).zip(&y_ranges).enumerate() {
        let is_last = i + 1 == panels.len();
        let mut chart = ChartBuilder::on(area)
            .caption(panel.title, caption_style())
            .margin_top(4)
            .margin_bottom(6)
            .margin_left(8)
            .margin_right(MARGIN_RIGHT)
            .x_label_area_size(X_LABEL_AREA + if is_last { X_DESC_HEIGHT } else { 0 })
            .y_label_area_size(y_area)
            .build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)?;

        let x_fmt = tick_formatter(x_range, X_LABELS);
        let y_fmt = tick_formatter(y_range, PANEL_Y_LABELS);
        let mut mesh = chart.configure_mesh();
        mesh.x_labels(X_LABELS)
            .y_labels(PANEL_Y_LABELS)
            .x_label_formatter(&x_fmt)
            .y_label_formatter(&y_fmt)
            .label_style(tick_style())
            .axis_desc_style(label_style())
            .y_desc(panel.y_label)
            .max_light_lines(LIGHT_LINES)
            .light_line_style(RGBColor(240, 240, 240))
            .bold_line_style(RGBColor(215, 215, 215));
        if is_last {
            mesh.x_desc(x_label);
        }
        mesh.draw()?;

        // Width of the plotting area in pixels = number of decimation columns.
        let columns = chart.plotting_area().dim_in_pixel().0.max(1) as usize;
        let mut labels = Vec::new();
        let mut occupied = Vec::new();
        for (k, s) in panel.series.iter().enumerate() {
            let color = series_color(k);
            if !s.label.is_empty() {
                labels.push(s.label);
                legend_entry(&mut chart, s.label, color, LegendMark::Line)?;
            }
            for seg in finite_segments(s.x, s.y) {
                let pts = decimate_min_max(&seg, x_range.0, x_range.1, columns);
                let px = pts.iter().map(|&p| to_px(&chart, p));
                draw_polyline_px(&root, px, color.stroke_width(2), &mut occupied)?;
            }
        }
        if occupied.is_empty() {
            draw_no_data(&chart)?;
        }
        if panel.series.len() > 1 && !labels.is_empty() {
            draw_legend(&mut chart, &labels, &occupied)?;
        }
    }

    root.present()?;
    Ok(())
}

fn draw_xy(
    path: &Path,
    title: &str,
    x_label: &str,
    y_label: &str,
    series: &[Series],
    circles: &[(f64, f64, f64, &str)],
    points_only: bool,
) -> anyhow::Result<()> {
    ensure_fonts()?;
    let root = BitMapBackend::new(path, (WIDTH, XY_HEIGHT)).into_drawing_area();
    root.fill(&WHITE)?;
    let body = titled(&root, title)?;

    // Circles: polylines in data coordinates (only finite, non-negative radii).
    let circle_pts: Vec<(Vec<(f64, f64)>, &str)> = circles
        .iter()
        .filter(|(cx, cy, r, _)| cx.is_finite() && cy.is_finite() && r.is_finite() && *r >= 0.0)
        .map(|&(cx, cy, r, label)| {
            const N: usize = 360;
            let pts = (0..=N)
                .map(|i| {
                    let t = std::f64::consts::TAU * i as f64 / N as f64;
                    (cx + r * t.cos(), cy + r * t.sin())
                })
                .collect();
            (pts, label)
        })
        .collect();

    let pairs = || {
        series
            .iter()
            .flat_map(|s| s.x.iter().copied().zip(s.y.iter().copied()))
    };
    let circ = || circle_pts.iter().flat_map(|(p, _)| p.iter().copied());
    let x_range = axis_range(pairs().map(|p| p.0).chain(circ().map(|p| p.0)), 0.05);
    let y_range = axis_range(pairs().map(|p| p.1).chain(circ().map(|p| p.1)), 0.05);

    let mut chart = ChartBuilder::on(&body)
        .margin_top(8)
        .margin_bottom(8)
        .margin_left(8)
        .margin_right(MARGIN_RIGHT)
        .x_label_area_size(X_LABEL_AREA + X_DESC_HEIGHT)
        .y_label_area_size(y_label_area(&[y_range], XY_Y_LABELS))
        .build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)?;

    let x_fmt = tick_formatter(x_range, X_LABELS);
    let y_fmt = tick_formatter(y_range, XY_Y_LABELS);
    chart
        .configure_mesh()
        .x_labels(X_LABELS)
        .y_labels(XY_Y_LABELS)
        .x_label_formatter(&x_fmt)
        .y_label_formatter(&y_fmt)
        .label_style(tick_style())
        .axis_desc_style(label_style())
        .x_desc(x_label)
        .y_desc(y_label)
        .max_light_lines(LIGHT_LINES)
        .light_line_style(RGBColor(240, 240, 240))
        .bold_line_style(RGBColor(215, 215, 215))
        .draw()?;

    // Thin zero axes when zero lies inside the view (helps for root loci).
    let axis_style = RGBColor(110, 110, 110).stroke_width(1);
    if x_range.0 < 0.0 && x_range.1 > 0.0 {
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(0.0, y_range.0), (0.0, y_range.1)],
            axis_style,
        )))?;
    }
    if y_range.0 < 0.0 && y_range.1 > 0.0 {
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(x_range.0, 0.0), (x_range.1, 0.0)],
            axis_style,
        )))?;
    }

    let mut labels = Vec::new();
    let mut occupied = Vec::new();
    for (k, (pts, label)) in circle_pts.iter().enumerate() {
        let color = if k == 0 {
            RGBColor(70, 70, 70)
        } else {
            series_color(series.len() + k)
        };
        let px: Vec<_> = pts.iter().map(|&p| to_px(&chart, p)).collect();
        for dash in dash_px(&px, 9.0, 6.0) {
            draw_polyline_px(&root, dash, color.stroke_width(2), &mut occupied)?;
        }
        if !label.is_empty() {
            labels.push(*label);
            legend_entry(&mut chart, label, color, LegendMark::Dashed)?;
        }
    }

    for (k, s) in series.iter().enumerate() {
        let color = series_color(k);
        if !s.label.is_empty() {
            labels.push(s.label);
            let mark = if points_only {
                LegendMark::Point
            } else {
                LegendMark::Line
            };
            legend_entry(&mut chart, s.label, color, mark)?;
        }
        if points_only {
            // Skip points that land on an already drawn pixel (large data sets).
            let mut seen = HashSet::new();
            let finite = s.x.iter().copied().zip(s.y.iter().copied());
            let finite = finite.filter(|(x, y)| x.is_finite() && y.is_finite());
            for p in finite {
                let c = to_px(&chart, p);
                if seen.insert(c) {
                    occupied.push(c);
                    root.draw(&Circle::new(c, POINT_RADIUS, color.filled()))?;
                }
            }
        } else {
            // Arbitrary (non-monotonic) x: no per-column decimation; consecutive
            // points on the same pixel are merged by draw_polyline_px.
            for seg in finite_segments(s.x, s.y) {
                let px = seg.iter().map(|&p| to_px(&chart, p));
                draw_polyline_px(&root, px, color.stroke_width(2), &mut occupied)?;
            }
        }
    }
    if occupied.is_empty() {
        draw_no_data(&chart)?;
    }
    if labels.len() > 1 {
        draw_legend(&mut chart, &labels, &occupied)?;
    }

    root.present()?;
    Ok(())
}

/// Fills the title strip and returns the area below it.
fn titled<'a>(
    root: &DrawingArea<BitMapBackend<'a>, Shift>,
    title: &str,
) -> anyhow::Result<DrawingArea<BitMapBackend<'a>, Shift>> {
    let (top, body) = root.split_vertically(TITLE_HEIGHT);
    let (w, h) = top.dim_in_pixel();
    let style = title_style().pos(Pos::new(HPos::Center, VPos::Center));
    top.draw_text(title, &style, ((w / 2) as i32, (h / 2 + 4) as i32))?;
    Ok(body)
}

/// Grey "no data" note in the middle of an empty plotting area.
fn draw_no_data<'a, DB: DrawingBackend + 'a>(
    chart: &ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let area = chart.plotting_area().strip_coord_spec();
    let (w, h) = area.dim_in_pixel();
    let style = (FONT_FAMILY, 18)
        .into_font()
        .color(&RGBColor(150, 150, 150))
        .pos(Pos::new(HPos::Center, VPos::Center));
    area.draw_text("no data", &style, ((w / 2) as i32, (h / 2) as i32))?;
    Ok(())
}

#[derive(Clone, Copy)]
enum LegendMark {
    Line,
    Dashed,
    Point,
}

/// Registers a legend entry by drawing an empty series carrying the label
/// (the data itself is drawn separately in pixel space).
fn legend_entry<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    label: &str,
    color: RGBColor,
    mark: LegendMark,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let anno = chart.draw_series(std::iter::empty::<PathElement<(f64, f64)>>())?;
    anno.label(label);
    // One `legend` call per concrete element type: returning a `DynElement`
    // from the closure would force the backend lifetime to be 'static.
    match mark {
        LegendMark::Line => anno.legend(move |(x, y)| {
            PathElement::new(vec![(x, y), (x + 24, y)], color.stroke_width(3))
        }),
        LegendMark::Dashed => anno.legend(move |(x, y)| {
            DashedPathElement::new(vec![(x, y), (x + 24, y)], 7, 5, color.stroke_width(2))
        }),
        LegendMark::Point => {
            anno.legend(move |(x, y)| Circle::new((x + 12, y), POINT_RADIUS + 1, color.filled()))
        }
    };
    Ok(())
}

/// Draws the legend in the corner of the plotting area that covers the fewest
/// drawn pixels (`occupied`, backend coordinates), like Matplotlib's "best".
fn draw_legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    labels: &[&str],
    occupied: &[(i32, i32)],
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    // Legend box size, mirroring plotters' SeriesLabelStyle::draw layout.
    let font = legend_style().font;
    let text_w = labels
        .iter()
        .map(|l| {
            font.box_size(l)
                .map(|(w, _)| w as i32)
                .unwrap_or(9 * l.len() as i32)
        })
        .max()
        .unwrap_or(0);
    let line_h = LEGEND_FONT_SIZE as f64 * 1.25;
    let text_h = ((labels.len().max(1) - 1) as f64 * line_h) as i32 + LEGEND_FONT_SIZE as i32;
    let (w, h) = (
        text_w + LEGEND_AREA as i32 + 2 * LEGEND_MARGIN as i32,
        text_h + 2 * LEGEND_MARGIN as i32,
    );

    let area = chart.plotting_area();
    let (bx, by) = area.get_base_pixel();
    let (aw, ah) = area.dim_in_pixel();
    let (aw, ah) = (aw as i32, ah as i32);
    let candidates = [
        (SeriesLabelPosition::UpperRight, (aw - w - 5, 5)),
        (SeriesLabelPosition::UpperLeft, (5, 5)),
        (SeriesLabelPosition::LowerRight, (aw - w - 5, ah - h - 5)),
        (SeriesLabelPosition::LowerLeft, (5, ah - h - 5)),
    ];
    let covered = |(x0, y0): (i32, i32)| {
        let (x0, y0) = (bx + x0, by + y0);
        occupied
            .iter()
            .filter(|&&(x, y)| x >= x0 && x <= x0 + w && y >= y0 && y <= y0 + h)
            .count()
    };
    let position = candidates
        .into_iter()
        .map(|(pos, origin)| (covered(origin), pos))
        .min_by_key(|(n, _)| *n) // first of equal minima wins
        .map(|(_, pos)| pos)
        .unwrap_or(SeriesLabelPosition::UpperRight);

    chart
        .configure_series_labels()
        .position(position)
        .margin(LEGEND_MARGIN)
        .legend_area_size(LEGEND_AREA)
        .label_font(legend_style())
        .background_style(WHITE.mix(0.85))
        .border_style(RGBColor(150, 150, 150))
        .draw()
        .map_err(|e| anyhow!("drawing legend: {e}"))
}

// ---------------------------------------------------------------------------
// Data helpers
// ---------------------------------------------------------------------------

/// Largest magnitude considered when computing ranges; keeps spans finite.
const MAX_MAG: f64 = 1e300;

/// Axis range `(lo, hi)` with `lo < hi` from the finite values of `values`,
/// widened by `margin` (fraction of the span) on both sides.
///
/// Empty input gives `(0, 1)`; a (numerically) constant input `v` gives
/// `v ± 1` for `v == 0`, otherwise `v ± |v|·0.1`.
fn axis_range(values: impl Iterator<Item = f64>, margin: f64) -> (f64, f64) {
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
fn tick_formatter((lo, hi): (f64, f64), n_labels: usize) -> impl Fn(&f64) -> String {
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
fn to_px<'a, DB: DrawingBackend + 'a>(
    chart: &ChartContext<'a, DB, Cartesian2d<RangedCoordf64, RangedCoordf64>>,
    (x, y): (f64, f64),
) -> (i32, i32) {
    let xr = chart.x_range();
    let yr = chart.y_range();
    chart.backend_coord(&(x.clamp(xr.start, xr.end), y.clamp(yr.start, yr.end)))
}

/// Width of the y label area: widest tick label over `ranges` plus tick
/// marks, gap and the rotated axis description.
fn y_label_area(ranges: &[(f64, f64)], n_labels: usize) -> u32 {
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
fn draw_polyline_px<DB: DrawingBackend>(
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
fn dash_px(px: &[(i32, i32)], on: f64, off: f64) -> Vec<Vec<(i32, i32)>> {
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
fn finite_segments(x: &[f64], y: &[f64]) -> Vec<Vec<(f64, f64)>> {
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

/// Width of a heat map's label column and height of its label row in pixels.
const HEAT_LABEL: u32 = 220;
/// Size of one heat-map cell in pixels (at most).
const HEAT_CELL: u32 = 110;

/// Colour of a pass fraction: red (none passed) through yellow to green (all passed); grey
/// for a cell without runs.
fn pass_color((passed, total): (usize, usize)) -> RGBColor {
    if total == 0 {
        return RGBColor(200, 200, 200);
    }
    let f = passed as f64 / total as f64;
    let (r, g) = if f < 0.5 {
        (1.0, 2.0 * f)
    } else {
        (2.0 * (1.0 - f), 1.0)
    };
    RGBColor((40.0 + 200.0 * r) as u8, (40.0 + 170.0 * g) as u8, 60)
}

/// Writes a PNG heat map of pass counts: `cells[y][x] = (passed, total)` over the labels of
/// the x axis (`x.1`, named `x.0`) and the y axis; each cell shows `passed/total`.
pub fn heat_map(
    path: &Path,
    title: &str,
    x: (&str, &[String]),
    y: (&str, &[String]),
    cells: &[Vec<(usize, usize)>],
) -> anyhow::Result<()> {
    ensure_fonts()?;
    let (nx, ny) = (x.1.len().max(1) as u32, y.1.len().max(1) as u32);
    let cell = HEAT_CELL.min(2000 / nx).max(24);
    let (w, h) = (
        HEAT_LABEL + nx * cell + MARGIN_RIGHT,
        TITLE_HEIGHT + HEAT_LABEL / 2 + ny * cell + 20,
    );
    let root = BitMapBackend::new(path, (w, h)).into_drawing_area();
    root.fill(&WHITE)?;
    let body = titled(&root, title)?;
    let center = Pos::new(HPos::Center, VPos::Center);
    let right = Pos::new(HPos::Right, VPos::Center);
    let top = HEAT_LABEL as i32 / 2;
    body.draw_text(
        &format!("{} →", x.0),
        &label_style().pos(Pos::new(HPos::Left, VPos::Center)),
        (HEAT_LABEL as i32, 14),
    )?;
    body.draw_text(
        &format!("{} ↓", y.0),
        &label_style().pos(right),
        (HEAT_LABEL as i32 - 8, 14),
    )?;
    for (i, label) in x.1.iter().enumerate() {
        let cx = (HEAT_LABEL + i as u32 * cell + cell / 2) as i32;
        let text: String = label.chars().take(18).collect();
        body.draw_text(
            &text,
            &tick_style()
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Left, VPos::Center)),
            (cx, top - 4),
        )?;
    }
    for (j, row) in cells.iter().enumerate() {
        let y0 = top + (j as u32 * cell) as i32;
        let label: String =
            y.1.get(j)
                .map_or("", |s| s.as_str())
                .chars()
                .take(30)
                .collect();
        body.draw_text(
            &label,
            &tick_style().pos(right),
            (HEAT_LABEL as i32 - 8, y0 + cell as i32 / 2),
        )?;
        for (i, &pt) in row.iter().enumerate() {
            let x0 = (HEAT_LABEL + i as u32 * cell) as i32;
            body.draw(&Rectangle::new(
                [
                    (x0 + 1, y0 + 1),
                    (x0 + cell as i32 - 1, y0 + cell as i32 - 1),
                ],
                pass_color(pt).filled(),
            ))?;
            body.draw_text(
                &format!("{}/{}", pt.0, pt.1),
                &tick_style().pos(center),
                (x0 + cell as i32 / 2, y0 + cell as i32 / 2),
            )?;
        }
    }
    root.present()
        .with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;
    use std::sync::atomic::{AtomicUsize, Ordering};

    fn temp_png(name: &str) -> PathBuf {
        static COUNTER: AtomicUsize = AtomicUsize::new(0);
        let n = COUNTER.fetch_add(1, Ordering::Relaxed);
        std::env::temp_dir().join(format!(
            "pmsm_plot_test_{}_{}_{n}_{name}.png",
            std::process::id(),
            std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map(|d| d.as_nanos())
                .unwrap_or(0)
        ))
    }

    fn assert_png(path: &Path) {
        let bytes = std::fs::read(path).expect("png written");
        assert!(bytes.len() > 1000, "png suspiciously small");
        assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
        let _ = std::fs::remove_file(path);
    }

    #[test]
    fn decimation_keeps_extremes() {
        let n = 100_000;
        let mut pts: Vec<(f64, f64)> = (0..n)
            .map(|i| {
                let t = i as f64 * 1e-4;
                (t, (t * 50.0).sin())
            })
            .collect();
        pts[12_345].1 = 25.0; // single-sample positive spike
        pts[77_777].1 = -40.0; // single-sample negative spike
        let (lo, hi) = (pts[0].0, pts[n - 1].0);
        let d = decimate_min_max(&pts, lo, hi, 1000);
        assert!(d.len() <= 4 * 1000 + 4, "len {}", d.len());
        assert!(d.len() >= 1000);
        assert!(d.contains(&pts[12_345]));
        assert!(d.contains(&pts[77_777]));
        assert_eq!(d.first(), pts.first());
        assert_eq!(d.last(), pts.last());
        // Order is preserved.
        assert!(d.windows(2).all(|w| w[0].0 <= w[1].0));
        // Per-bin extremes are all kept.
        let max_y = d.iter().map(|p| p.1).fold(f64::MIN, f64::max);
        let min_y = d.iter().map(|p| p.1).fold(f64::MAX, f64::min);
        assert_eq!((min_y, max_y), (-40.0, 25.0));
    }

    #[test]
    fn decimation_short_and_degenerate_inputs() {
        let pts = [(0.0, 1.0), (1.0, 2.0)];
        assert_eq!(decimate_min_max(&pts, 0.0, 1.0, 100), pts.to_vec());
        assert!(decimate_min_max(&[], 0.0, 1.0, 0).is_empty());
        // All x equal / zero-width range: everything in one bin -> <= 4 points.
        let pts: Vec<_> = (0..1000).map(|i| (1.0, i as f64)).collect();
        let d = decimate_min_max(&pts, 1.0, 1.0, 10);
        assert_eq!(d, vec![(1.0, 0.0), (1.0, 999.0)]);
    }

    #[test]
    fn ranges_ignore_non_finite_and_have_fallbacks() {
        assert_eq!(axis_range(std::iter::empty(), 0.05), (0.0, 1.0));
        assert_eq!(
            axis_range([f64::NAN, f64::INFINITY].into_iter(), 0.05),
            (0.0, 1.0)
        );
        assert_eq!(axis_range([0.0, 0.0].into_iter(), 0.05), (-1.0, 1.0));
        let (lo, hi) = axis_range([5.0, 5.0, f64::NAN].into_iter(), 0.05);
        assert!(lo < 5.0 && hi > 5.0);
        let (lo, hi) = axis_range([0.0, f64::NAN, 10.0, f64::NEG_INFINITY].into_iter(), 0.1);
        assert!((lo + 1.0).abs() < 1e-12 && (hi - 11.0).abs() < 1e-12);
        let (lo, hi) = axis_range([-f64::MAX, f64::MAX].into_iter(), 0.1);
        assert!(lo.is_finite() && hi.is_finite() && lo < hi);
    }

    #[test]
    fn tick_labels() {
        let f = tick_formatter((0.0, 1.0), 10);
        assert_eq!(f(&0.3), "0.3");
        let f = tick_formatter((-1e-6, 1e-6), 10);
        assert_eq!(f(&5e-7), "5.0e-7");
        let f = tick_formatter((0.0, 3000.0), 10);
        assert_eq!(f(&1500.0), "1500");
        assert_eq!(f(&-1e-13), "0");
    }

    #[test]
    fn plot_panels_writes_png_with_nan_and_empty_series() {
        let t: Vec<f64> = (0..5000).map(|i| i as f64 * 1e-3).collect();
        let mut a: Vec<f64> = t.iter().map(|t| (t * 10.0).sin()).collect();
        a[100] = f64::NAN;
        a[2000] = f64::INFINITY;
        let b: Vec<f64> = t.iter().map(|t| (t * 10.0).cos()).collect();
        let nan = vec![f64::NAN; t.len()];
        let panels = [
            Panel {
                title: "Currents",
                y_label: "i [A]",
                series: vec![
                    Series {
                        label: "a",
                        x: &t,
                        y: &a,
                    },
                    Series {
                        label: "b",
                        x: &t,
                        y: &b,
                    },
                    Series {
                        label: "empty",
                        x: &[],
                        y: &[],
                    },
                ],
            },
            Panel {
                title: "All NaN",
                y_label: "nan",
                series: vec![Series {
                    label: "nan",
                    x: &t,
                    y: &nan,
                }],
            },
        ];
        let path = temp_png("panels");
        plot_panels(&path, "Test", "t [s]", &panels).unwrap();
        assert_png(&path);

        // Completely empty panel and constant data must not fail either.
        let c = vec![3.0; 10];
        let panels = [
            Panel {
                title: "empty",
                y_label: "",
                series: vec![],
            },
            Panel {
                title: "const",
                y_label: "",
                series: vec![Series {
                    label: "c",
                    x: &c,
                    y: &c,
                }],
            },
        ];
        let path = temp_png("panels_degenerate");
        plot_panels(&path, "", "", &panels).unwrap();
        assert_png(&path);

        // Extreme magnitudes must neither panic nor hang.
        let x = [0.0, 1e-300, 2e-300];
        let huge = [-f64::MAX, f64::MAX, 0.0];
        let tiny = [1.0, 1.0 + f64::EPSILON, f64::MIN_POSITIVE];
        let panels = [
            Panel {
                title: "huge",
                y_label: "",
                series: vec![Series {
                    label: "h",
                    x: &x,
                    y: &huge,
                }],
            },
            Panel {
                title: "tiny",
                y_label: "",
                series: vec![Series {
                    label: "t",
                    x: &huge,
                    y: &tiny,
                }],
            },
        ];
        let path = temp_png("panels_extreme");
        plot_panels(&path, "extreme", "x", &panels).unwrap();
        assert_png(&path);
    }

    #[test]
    fn plot_panels_reports_path_on_error() {
        let path = std::env::temp_dir()
            .join("pmsm_plot_no_such_dir_4b1d")
            .join("x.png");
        let panels = [Panel {
            title: "",
            y_label: "",
            series: vec![],
        }];
        let err = plot_panels(&path, "t", "x", &panels).unwrap_err();
        assert!(format!("{err:#}").contains("x.png"), "{err:#}");
        assert!(plot_panels(&temp_png("none"), "t", "x", &[]).is_err());
    }

    #[test]
    fn plot_xy_writes_png_with_circles() {
        let th: Vec<f64> = (0..200).map(|i| i as f64 * 0.01).collect();
        let re1: Vec<f64> = th.iter().map(|k| 0.9 * (k * 0.5).cos()).collect();
        let im1: Vec<f64> = th.iter().map(|k| 0.9 * (k * 0.5).sin()).collect();
        let im2: Vec<f64> = im1.iter().map(|v| -v).collect();
        let series = [
            Series {
                label: "pole 1",
                x: &re1,
                y: &im1,
            },
            Series {
                label: "pole 2",
                x: &re1,
                y: &im2,
            },
        ];
        let circles = [(0.0, 0.0, 1.0, "unit circle"), (0.5, 0.0, f64::NAN, "bad")];
        let path = temp_png("xy_points");
        plot_xy(&path, "Root locus", "Re", "Im", &series, &circles, true).unwrap();
        assert_png(&path);
        let path = temp_png("xy_lines");
        plot_xy(&path, "Lines", "x", "y", &series, &circles, false).unwrap();
        assert_png(&path);
        let path = temp_png("xy_empty");
        plot_xy(&path, "Empty", "x", "y", &[], &[], true).unwrap();
        assert_png(&path);

        // Extreme magnitudes and near-constant data.
        let x = [0.0, 1e-300, 2e-300, f64::NAN];
        let y = [1.0, 1.0 + 1e-12, f64::MAX, -f64::MAX];
        let series = [Series {
            label: "odd",
            x: &x,
            y: &y,
        }];
        let circles = [(0.0, 0.0, 1e308, "huge"), (f64::INFINITY, 0.0, 1.0, "")];
        for points_only in [true, false] {
            let path = temp_png("xy_extreme");
            plot_xy(&path, "Extreme", "x", "y", &series, &circles, points_only).unwrap();
            assert_png(&path);
        }
    }

    /// Renders example images for visual inspection:
    /// `cargo test -p pmsm-host-sim plot::tests::render_example -- --ignored`
    #[test]
    #[ignore]
    fn render_example() {
        let n = 100_000;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * 1e-5).collect();
        let w = 2.0 * std::f64::consts::PI * 50.0;
        let ia: Vec<f64> = t.iter().map(|t| 10.0 * (w * t).sin()).collect();
        let ib: Vec<f64> = t.iter().map(|t| 10.0 * (w * t - 2.094).sin()).collect();
        let mut ic: Vec<f64> = t.iter().map(|t| 10.0 * (w * t + 2.094).sin()).collect();
        ic[43_210] = 18.0;
        for v in &mut ic[60_000..61_000] {
            *v = f64::NAN;
        }
        let speed: Vec<f64> = t
            .iter()
            .map(|t| 3000.0 * (1.0 - (-t * 8.0).exp()))
            .collect();
        let est: Vec<f64> = speed
            .iter()
            .enumerate()
            .map(|(i, s)| s + 40.0 * ((i as f64) * 0.013).sin())
            .collect();
        let err: Vec<f64> = t.iter().map(|t| 2e-6 * (w * t).cos()).collect();
        let panels = [
            Panel {
                title: "Phase currents",
                y_label: "current [A]",
                series: vec![
                    Series {
                        label: "i_a",
                        x: &t,
                        y: &ia,
                    },
                    Series {
                        label: "i_b",
                        x: &t,
                        y: &ib,
                    },
                    Series {
                        label: "i_c (spike + NaN gap)",
                        x: &t,
                        y: &ic,
                    },
                ],
            },
            Panel {
                title: "Speed",
                y_label: "speed [rpm]",
                series: vec![
                    Series {
                        label: "true",
                        x: &t,
                        y: &speed,
                    },
                    Series {
                        label: "estimated",
                        x: &t,
                        y: &est,
                    },
                ],
            },
            Panel {
                title: "Tiny error",
                y_label: "error [rad]",
                series: vec![Series {
                    label: "err",
                    x: &t,
                    y: &err,
                }],
            },
        ];
        plot_panels(
            Path::new("/tmp/plot_example.png"),
            "PMSM start-up",
            "time [s]",
            &panels,
        )
        .unwrap();

        let k: Vec<f64> = (0..400).map(|i| i as f64 * 0.005).collect();
        let re: Vec<f64> = k.iter().map(|k| 0.95 - 0.6 * k).collect();
        let im1: Vec<f64> = k.iter().map(|k| 0.5 * k.sqrt()).collect();
        let im2: Vec<f64> = im1.iter().map(|v| -v).collect();
        let series = [
            Series {
                label: "branch 1",
                x: &re,
                y: &im1,
            },
            Series {
                label: "branch 2",
                x: &re,
                y: &im2,
            },
        ];
        plot_xy(
            Path::new("/tmp/plot_example_xy.png"),
            "Root locus (z-plane)",
            "Re z",
            "Im z",
            &series,
            &[(0.0, 0.0, 1.0, "unit circle")],
            true,
        )
        .unwrap();

        // Degenerate inputs: empty panel, all-NaN series, constant data, big values.
        let c = vec![3.0; 10];
        let x: Vec<f64> = (0..10).map(f64::from).collect();
        let big: Vec<f64> = x.iter().map(|v| 1e7 + v * 1e5).collect();
        let nan = vec![f64::NAN; 10];
        let panels = [
            Panel {
                title: "Empty panel",
                y_label: "none",
                series: vec![],
            },
            Panel {
                title: "Constant + all NaN",
                y_label: "const",
                series: vec![
                    Series {
                        label: "constant 3",
                        x: &x,
                        y: &c,
                    },
                    Series {
                        label: "all NaN",
                        x: &x,
                        y: &nan,
                    },
                ],
            },
            Panel {
                title: "Large values",
                y_label: "big",
                series: vec![Series {
                    label: "big",
                    x: &x,
                    y: &big,
                }],
            },
        ];
        plot_panels(
            Path::new("/tmp/plot_example_degenerate.png"),
            "Degenerate data",
            "sample",
            &panels,
        )
        .unwrap();
    }
}
