//! The x–y plot (a root locus): lines or points, dashed circles, zero axes.

use super::axis::{axis_range, tick_formatter, to_px, y_label_area};
use super::legend::{draw_legend, draw_no_data, legend_entry, titled, LegendMark};
use super::lines::{dash_px, draw_polyline_px, finite_segments};
use super::style::*;
use super::{Series, WIDTH, XY_HEIGHT};
use anyhow::Context;
use plotters::prelude::*;
use plotters::style::RGBColor;
use std::collections::HashSet;
use std::path::Path;

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
    let draw = || -> anyhow::Result<()> {
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
    };
    draw().with_context(|| format!("failed to write plot {}", path.display()))
}
