//! The sweep's heat map: pass counts over two axes, red through green.

use super::legend::titled;
use super::style::{ensure_fonts, label_style, tick_style, MARGIN_RIGHT, TITLE_HEIGHT};
use anyhow::Context;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters::style::RGBColor;
use std::path::Path;

/// Width of a heat map's label column and height of its label row in pixels.
pub(super) const HEAT_LABEL: u32 = 220;
/// Size of one heat-map cell in pixels (at most).
pub(super) const HEAT_CELL: u32 = 110;

/// Colour of a pass fraction: red (none passed) through yellow to green (all passed); grey
/// for a cell without runs.
pub(super) fn pass_color((passed, total): (usize, usize)) -> RGBColor {
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
