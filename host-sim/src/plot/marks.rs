//! Marks on stacked panels (the run plot's drive modes): bands shaded behind every panel and
//! named in a strip under the title, events (transitions with their reasons, faults with
//! their names) as vertical lines through every panel, labelled in the strip.

use super::lines::{dash_px, draw_polyline_px};
use super::style::{tick_style, FONT_FAMILY};
use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::RGBColor;

/// A stretch of the x axis in one state (a drive mode).
#[derive(Clone, Debug, PartialEq)]
pub struct Band<'a> {
    /// Start and end (x units).
    pub x0: f64,
    /// See `x0`.
    pub x1: f64,
    /// The state's name, in the strip and its legend.
    pub label: &'a str,
    /// Its colour: an index into the mark palette (one per state, the same in every plot).
    pub shade: usize,
}

/// An instant: a transition and its reason, or a fault and its name.
#[derive(Clone, Debug, PartialEq)]
pub struct Event {
    /// When (x units).
    pub x: f64,
    /// What happened.
    pub label: String,
    /// A fault: drawn in red, solid.
    pub fault: bool,
}

/// What [`super::plot_panels_marked`] marks.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Marks<'a> {
    /// Shaded stretches, in x order.
    pub bands: Vec<Band<'a>>,
    /// Vertical lines.
    pub events: Vec<Event>,
}

/// Colours of the bands (the strip's; the panels' are these, faded).
const SHADES: [RGBColor; 10] = [
    RGBColor(190, 190, 190),
    RGBColor(120, 200, 230),
    RGBColor(250, 200, 90),
    RGBColor(240, 150, 80),
    RGBColor(130, 200, 130),
    RGBColor(230, 80, 80),
    RGBColor(180, 150, 220),
    RGBColor(150, 120, 200),
    RGBColor(200, 180, 150),
    RGBColor(160, 160, 220),
];
/// How much of a band's colour the panels show behind their lines.
const PANEL_SHADE: f64 = 0.2;
const FAULT_RED: RGBColor = RGBColor(200, 0, 0);
const EVENT_GREY: RGBColor = RGBColor(90, 90, 90);
/// Heights in the strip: the band row, one row of event labels, the legend row.
const BAND_ROW: i32 = 24;
const LABEL_ROW: i32 = 17;
const LEGEND_ROW: i32 = 24;
/// At most this many rows of event labels (beyond, labels overlap).
const MAX_LABEL_ROWS: usize = 4;
/// Events closer than this (pixels) share one label.
const MERGE_PX: i32 = 3;

fn shade(i: usize) -> RGBColor {
    SHADES[i % SHADES.len()]
}

/// The panels' shared x axis in backend pixels.
#[derive(Clone, Copy, Debug)]
pub(super) struct XMap {
    /// Data range.
    pub lo: f64,
    /// See `lo`.
    pub hi: f64,
    /// Pixels of `lo` and `hi`.
    pub px_lo: i32,
    /// See `px_lo`.
    pub px_hi: i32,
}

impl XMap {
    fn px(&self, x: f64) -> i32 {
        let f = if self.hi > self.lo {
            ((x - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0)
        } else {
            0.0
        };
        self.px_lo + (f * f64::from(self.px_hi - self.px_lo)).round() as i32
    }
}

/// One event label placed: its row, its left pixel, the line's pixel, the text, a fault.
struct Placed {
    row: usize,
    left: i32,
    at: i32,
    text: String,
    fault: bool,
}

fn text_width(text: &str) -> i32 {
    tick_style()
        .font
        .box_size(text)
        .map_or(8 * text.len() as i32, |(w, _)| w as i32)
}

/// The event labels in rows: events within [`MERGE_PX`] share one label; each goes to the
/// first row where it does not overlap the label before it (the emptiest row when none).
fn place(marks: &Marks, map: XMap, rows: usize) -> Vec<Placed> {
    let mut events: Vec<&Event> = marks.events.iter().collect();
    events.sort_by(|a, b| a.x.total_cmp(&b.x));
    let mut merged: Vec<(i32, String, bool)> = Vec::new();
    for e in events {
        let at = map.px(e.x);
        match merged.last_mut() {
            Some((last, text, fault)) if at - *last <= MERGE_PX => {
                text.push_str(", ");
                text.push_str(&e.label);
                *fault |= e.fault;
            }
            _ => merged.push((at, e.label.clone(), e.fault)),
        }
    }
    let mut row_end = vec![i32::MIN; rows.max(1)];
    merged
        .into_iter()
        .map(|(at, text, fault)| {
            let w = text_width(&text);
            // Right of its line, or left of it where the axis ends.
            let left = if at + 3 + w > map.px_hi {
                at - 3 - w
            } else {
                at + 3
            };
            let row = (0..row_end.len())
                .find(|&r| row_end[r] + 6 <= left)
                .unwrap_or_else(|| (0..row_end.len()).min_by_key(|&r| row_end[r]).unwrap_or(0));
            row_end[row] = row_end[row].max(left + w);
            Placed {
                row,
                left,
                at,
                text,
                fault,
            }
        })
        .collect()
}

/// Rows of event labels the strip needs, laid out on `map`; `None` without marks (no strip).
pub(super) fn strip_rows(marks: &Marks, map: XMap) -> Option<usize> {
    if marks.bands.is_empty() && marks.events.is_empty() {
        return None;
    }
    let placed = place(marks, map, MAX_LABEL_ROWS);
    Some(placed.iter().map(|p| p.row + 1).max().unwrap_or(0))
}

/// Heights of the band row and of the legend row: none without bands (a bare run's strip
/// holds its events only).
fn band_rows(marks: &Marks) -> (i32, i32) {
    if marks.bands.is_empty() {
        (4, 0)
    } else {
        (BAND_ROW, LEGEND_ROW)
    }
}

/// Height of the strip with `rows` rows of event labels (0: no strip).
pub(super) fn strip_height(marks: &Marks, rows: Option<usize>) -> u32 {
    let (band, legend) = band_rows(marks);
    rows.map_or(0, |r| (band + LABEL_ROW * r as i32 + legend + 6) as u32)
}

/// Draws the strip whose top is at backend pixel `top`: the bands with their names where
/// they fit, the event labels in `rows` rows, the legend of the bands' names.
pub(super) fn draw_strip<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    marks: &Marks,
    map: XMap,
    top: i32,
    rows: usize,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    let left_of_axis = tick_style().pos(Pos::new(HPos::Right, VPos::Center));
    let (band_row, legend_row) = band_rows(marks);
    if !marks.bands.is_empty() {
        root.draw_text("mode", &left_of_axis, (map.px_lo - 6, top + BAND_ROW / 2))?;
    }
    let centred = tick_style().pos(Pos::new(HPos::Center, VPos::Center));
    for b in &marks.bands {
        let (x0, x1) = (map.px(b.x0), map.px(b.x1));
        root.draw(&Rectangle::new(
            [(x0, top), (x1, top + BAND_ROW - 2)],
            shade(b.shade).filled(),
        ))?;
        if text_width(b.label) + 6 < x1 - x0 {
            root.draw_text(b.label, &centred, ((x0 + x1) / 2, top + BAND_ROW / 2 - 1))?;
        }
    }
    let labels_top = top + band_row;
    let placed = place(marks, map, rows);
    if !placed.is_empty() {
        root.draw_text(
            "events",
            &left_of_axis,
            (map.px_lo - 6, labels_top + LABEL_ROW / 2),
        )?;
    }
    // The lines first, then the labels on white, so that no line crosses a label.
    for p in &placed {
        let color = if p.fault { FAULT_RED } else { EVENT_GREY };
        let y = labels_top + LABEL_ROW * p.row as i32;
        root.draw(&PathElement::new(
            vec![(p.at, top), (p.at, y + LABEL_ROW - 2)],
            color.mix(0.6).stroke_width(1),
        ))?;
    }
    for p in &placed {
        let color = if p.fault { FAULT_RED } else { EVENT_GREY };
        let y = labels_top + LABEL_ROW * p.row as i32;
        root.draw(&Rectangle::new(
            [
                (p.left - 1, y + 1),
                (p.left + text_width(&p.text) + 1, y + LABEL_ROW - 2),
            ],
            WHITE.filled(),
        ))?;
        let style = (FONT_FAMILY, 13)
            .into_font()
            .color(&color)
            .pos(Pos::new(HPos::Left, VPos::Top));
        root.draw_text(&p.text, &style, (p.left, y + 1))?;
    }
    // The legend: every band's name once, in order of appearance.
    let legend_y = labels_top + LABEL_ROW * rows as i32 + legend_row / 2;
    let mut x = map.px_lo;
    let mut seen: Vec<&str> = Vec::new();
    let name = tick_style().pos(Pos::new(HPos::Left, VPos::Center));
    for b in &marks.bands {
        if seen.contains(&b.label) {
            continue;
        }
        seen.push(b.label);
        root.draw(&Rectangle::new(
            [(x, legend_y - 7), (x + 14, legend_y + 7)],
            shade(b.shade).filled(),
        ))?;
        root.draw_text(b.label, &name, (x + 19, legend_y))?;
        x += 19 + text_width(b.label) + 16;
    }
    Ok(())
}

/// What [`mark_panel`] draws: the bands behind the lines, or the events over them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Layer {
    /// The bands, shaded.
    Behind,
    /// The events' vertical lines: dashed grey, faults solid red.
    Over,
}

/// Draws `layer` of the marks over the plotting area `y` (backend pixels, top to bottom).
pub(super) fn mark_panel<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    marks: &Marks,
    map: XMap,
    (y0, y1): (i32, i32),
    layer: Layer,
) -> anyhow::Result<()>
where
    DB::ErrorType: 'static,
{
    if layer == Layer::Behind {
        for b in &marks.bands {
            root.draw(&Rectangle::new(
                [(map.px(b.x0), y0), (map.px(b.x1), y1)],
                shade(b.shade).mix(PANEL_SHADE).filled(),
            ))?;
        }
        return Ok(());
    }
    let mut unused = Vec::new();
    for e in &marks.events {
        let x = map.px(e.x);
        if e.fault {
            root.draw(&PathElement::new(
                vec![(x, y0), (x, y1)],
                FAULT_RED.stroke_width(2),
            ))?;
        } else {
            for dash in dash_px(&[(x, y0), (x, y1)], 5.0, 4.0) {
                draw_polyline_px(root, dash, EVENT_GREY.stroke_width(1), &mut unused)?;
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map() -> XMap {
        XMap {
            lo: 0.0,
            hi: 10.0,
            px_lo: 100,
            px_hi: 1100,
        }
    }

    fn event(x: f64, label: &str) -> Event {
        Event {
            x,
            label: label.into(),
            fault: false,
        }
    }

    #[test]
    fn close_events_share_a_label_and_crowded_ones_take_rows() {
        let marks = Marks {
            bands: vec![],
            events: vec![
                event(0.0, "Enabled"),
                event(0.0005, "AtRest"),
                event(0.2, "Aligned"),
                event(0.3, "HandOver"),
                event(5.0, "Stopped"),
            ],
        };
        let placed = place(&marks, map(), MAX_LABEL_ROWS);
        assert_eq!(placed.len(), 4);
        assert_eq!(placed[0].text, "Enabled, AtRest");
        assert_eq!(
            placed.iter().map(|p| p.row).collect::<Vec<_>>(),
            [0, 1, 2, 0]
        );
        assert_eq!(strip_rows(&marks, map()), Some(3));
        assert_eq!(strip_rows(&Marks::default(), map()), None);
        assert_eq!(strip_height(&marks, None), 0);
    }
}
