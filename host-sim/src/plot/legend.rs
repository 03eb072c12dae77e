//! Titles, legends (placed in the emptiest corner) and the "no data" note.

use super::style::{
    legend_style, title_style, FONT_FAMILY, LEGEND_AREA, LEGEND_FONT_SIZE, LEGEND_MARGIN,
    POINT_RADIUS, TITLE_HEIGHT,
};
use anyhow::anyhow;
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::RGBColor;

/// Fills the title strip and returns the area below it.
pub(super) fn titled<'a>(
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
pub(super) fn draw_no_data<'a, DB: DrawingBackend + 'a>(
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
pub(super) enum LegendMark {
    Line,
    Dashed,
    Point,
}

/// Registers a legend entry by drawing an empty series carrying the label
/// (the data itself is drawn separately in pixel space).
pub(super) fn legend_entry<'a, DB: DrawingBackend + 'a>(
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
pub(super) fn draw_legend<'a, DB: DrawingBackend + 'a>(
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
