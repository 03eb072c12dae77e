//! PNG plots of the simulator: stacked time series (the run plot, with the drive's modes,
//! transitions and faults marked), x–y plots (root loci) and heat maps (sweeps).
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

mod axis;
mod heatmap;
mod legend;
mod lines;
mod marks;
mod panels;
mod style;
#[cfg(test)]
mod tests;
mod xy;

use std::path::Path;

pub use heatmap::heat_map;
pub use lines::decimate_min_max;
pub use marks::{Band, Event, Marks};
pub use panels::plot_panels_marked;
pub use xy::plot_xy;

/// One named data series (`x[i]`, `y[i]` pairs).
#[derive(Debug, Clone, Copy)]
pub struct Series<'a> {
    /// Legend text (none when empty).
    pub label: &'a str,
    /// x values.
    pub x: &'a [f64],
    /// y values, paired with `x`.
    pub y: &'a [f64],
}

/// One stacked sub-plot of [`plot_panels`].
#[derive(Debug, Clone)]
pub struct Panel<'a> {
    /// Caption above the panel.
    pub title: &'a str,
    /// The y axis's description.
    pub y_label: &'a str,
    /// The lines, in palette order.
    pub series: Vec<Series<'a>>,
}

/// Image width in pixels.
pub const WIDTH: u32 = 1200;
/// Height of one panel of [`plot_panels`] in pixels.
pub const PANEL_HEIGHT: u32 = 300;
/// Height of the x–y plot of [`plot_xy`] in pixels.
pub const XY_HEIGHT: u32 = 900;

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
    plot_panels_marked(path, title, x_label, panels, &Marks::default())
}
