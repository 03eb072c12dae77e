//! The plots' look: image layout in pixels, the embedded font, text styles and the line
//! palette.

use anyhow::anyhow;
use plotters::prelude::*;
use plotters::style::{register_font, FontStyle, RGBColor};
use std::sync::OnceLock;

pub(super) const FONT_FAMILY: &str = "sans-serif";
pub(super) const TITLE_HEIGHT: u32 = 44;
/// Extra height of the bottom panel that holds the shared x-axis label.
pub(super) const X_DESC_HEIGHT: u32 = 26;
pub(super) const LIGHT_LINES: usize = 4;
pub(super) const X_LABEL_AREA: u32 = 30;
pub(super) const MARGIN_RIGHT: u32 = 24;
pub(super) const X_LABELS: usize = 12;
pub(super) const POINT_RADIUS: i32 = 3;
pub(super) const LEGEND_FONT_SIZE: u32 = 15;
pub(super) const LEGEND_MARGIN: u32 = 10;
pub(super) const LEGEND_AREA: u32 = 32;
pub(super) const PANEL_Y_LABELS: usize = 6;
/// Upper bound on panels per image (keeps the pixel buffer < ~100 MB).
pub(super) const MAX_PANELS: usize = 100;
pub(super) const XY_Y_LABELS: usize = 12;

/// Distinct, colour-blind-friendly-ish line colours (Matplotlib "tab10").
pub(super) const PALETTE: [RGBColor; 10] = [
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
pub(super) fn series_color(i: usize) -> RGBColor {
    PALETTE[i % PALETTE.len()]
}

/// Registers the embedded DejaVu Sans font with plotters exactly once.
///
/// `plotters` with the `ab_glyph` feature has no font until one is registered;
/// drawing any text before that fails with `FontUnavailable`.
pub(super) fn ensure_fonts() -> anyhow::Result<()> {
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

pub(super) fn title_style() -> TextStyle<'static> {
    (FONT_FAMILY, 26)
        .into_font()
        .style(FontStyle::Bold)
        .color(&BLACK)
}

pub(super) fn caption_style() -> TextStyle<'static> {
    (FONT_FAMILY, 19).into_font().color(&BLACK)
}

pub(super) fn label_style() -> TextStyle<'static> {
    (FONT_FAMILY, 16).into_font().color(&BLACK)
}

pub(super) fn tick_style() -> TextStyle<'static> {
    (FONT_FAMILY, 14).into_font().color(&RGBColor(40, 40, 40))
}

pub(super) fn legend_style() -> TextStyle<'static> {
    (FONT_FAMILY, LEGEND_FONT_SIZE).into_font().color(&BLACK)
}
