//! Stacked time-series panels sharing the x axis, with the marks of [`super::Marks`].

use super::axis::{axis_range, tick_formatter, to_px, y_label_area};
use super::legend::{draw_legend, draw_no_data, legend_entry, titled, LegendMark};
use super::lines::{decimate_min_max, draw_polyline_px, finite_segments};
use super::marks::{draw_strip, mark_panel, strip_height, strip_rows, Layer, XMap};
use super::style::*;
use super::{Marks, Panel, PANEL_HEIGHT, WIDTH};
use anyhow::{bail, Context};
use plotters::prelude::*;
use plotters::style::RGBColor;
use std::path::Path;

/// As [`super::plot_panels`], with `marks`: its bands shaded behind every panel and named in a
/// strip under the title, its events as vertical lines through every panel labelled in the
/// strip (faults in red). No strip without marks.
pub fn plot_panels_marked(
    path: &Path,
    title: &str,
    x_label: &str,
    panels: &[Panel],
    marks: &Marks,
) -> anyhow::Result<()> {
    let draw = || -> anyhow::Result<()> {
        ensure_fonts()?;
        if panels.is_empty() {
            bail!("no panels to plot");
        }
        if panels.len() > MAX_PANELS {
            bail!("too many panels ({} > {MAX_PANELS})", panels.len());
        }
        let n = panels.len() as u32; // <= MAX_PANELS

        // Shared x range over all panels.
        let x_range = axis_range(
            panels
                .iter()
                .flat_map(|p| p.series.iter())
                .flat_map(|s| s.x.iter().zip(s.y).map(|(&x, _)| x)),
            0.0,
        );
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
        // The plotting area's x pixels, as the chart builder will lay them out (left margin 8).
        let mut map = XMap {
            lo: x_range.0,
            hi: x_range.1,
            px_lo: 8 + y_area as i32,
            px_hi: (WIDTH - MARGIN_RIGHT) as i32,
        };
        let rows = strip_rows(marks, map);
        let strip = strip_height(marks, rows);
        let height = n * PANEL_HEIGHT + TITLE_HEIGHT + X_DESC_HEIGHT + strip;

        let root = BitMapBackend::new(path, (WIDTH, height)).into_drawing_area();
        root.fill(&WHITE)?;
        let body = titled(&root, title)?;
        let (_, body) = body.split_vertically(strip);

        // Equal panel heights; the bottom one is taller by the x-description strip.
        let breaks: Vec<u32> = (1..n).map(|i| i * PANEL_HEIGHT).collect();
        let areas = body.split_by_breakpoints([] as [u32; 0], breaks);

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
            let (x_px, y_px) = chart.plotting_area().get_pixel_range();
            let y_px = (y_px.start, y_px.end - 1);
            if i == 0 {
                // The exact pixels, for the marks.
                (map.px_lo, map.px_hi) = (x_px.start, x_px.end - 1);
                if let Some(rows) = rows {
                    draw_strip(&root, marks, map, TITLE_HEIGHT as i32, rows)?;
                }
            }
            mark_panel(&root, marks, map, y_px, Layer::Behind)?;

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
            mark_panel(&root, marks, map, y_px, Layer::Over)?;
            if occupied.is_empty() {
                draw_no_data(&chart)?;
            }
            if panel.series.len() > 1 && !labels.is_empty() {
                draw_legend(&mut chart, &labels, &occupied)?;
            }
        }

        root.present()?;
        Ok(())
    };
    draw().with_context(|| format!("failed to write plot {}", path.display()))
}
