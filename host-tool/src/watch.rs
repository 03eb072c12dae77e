//! `pmsm-tool watch`: live plots in the terminal (ratatui) of the streamed telemetry: speed
//! and its reference, the d and q currents, both observers' residuals, with the mode, the
//! driving observer and the fault. `q` or Esc quits (the stream is stopped).

use crate::client::{Client, ToolError};
use crate::ops;
use pmsm_link::wire::{Mode, Reason, Telemetry};
use pmsm_link::{Event, Request};
use pmsm_sensorless::units::winding_rise_k;
use ratatui::crossterm::event::{self, Event as Key, KeyCode};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::Line;
use ratatui::widgets::{Axis, Block, Chart, Dataset, GraphType, Paragraph};
use ratatui::Frame;
use std::collections::VecDeque;
use std::io::{Read, Write};
use std::time::Duration;

/// The plotted window \[s].
const WINDOW_S: f64 = 10.0;

/// Watches until `q`: telemetry at `rate_hz`.
pub fn watch<T: Read + Write>(c: &mut Client<T>, rate_hz: u16) -> Result<(), ToolError> {
    // The configured resistance: the winding's temperature rise is the tracked one's over it.
    let r_ref_ohm = ops::settings(c)?.motor.r_ohm;
    c.request(Request::Stream(rate_hz))?;
    let mut terminal = ratatui::init();
    let result = watch_loop(c, &mut terminal, r_ref_ohm);
    ratatui::restore();
    c.request(Request::Stream(0))?;
    result
}

fn watch_loop<T: Read + Write>(
    c: &mut Client<T>,
    terminal: &mut ratatui::DefaultTerminal,
    r_ref_ohm: f32,
) -> Result<(), ToolError> {
    let mut records: VecDeque<Telemetry> = VecDeque::new();
    // The last alignment's resistance measurement refused (until an alignment's is taken).
    let mut refused = false;
    loop {
        while let Some(e) = c.next_event(Duration::from_millis(5))? {
            match e {
                Event::Telemetry(t) => records.push_back(t),
                Event::Transition(t) if t.from == Mode::Align => {
                    refused = t.reason == Reason::ResistanceRefused;
                }
                Event::Transition(_) | Event::Fault(_) => {}
            }
            if records.len() > 20_000 {
                records.pop_front();
            }
        }
        if let Some(last) = records.back().map(|r| r.t_ms) {
            while records
                .front()
                .is_some_and(|r| f64::from(last.wrapping_sub(r.t_ms)) / 1000.0 > WINDOW_S)
            {
                records.pop_front();
            }
        }
        terminal
            .draw(|f| draw(f, &records, refused, r_ref_ohm))
            .map_err(ToolError::Io)?;
        if event::poll(Duration::from_millis(30)).map_err(ToolError::Io)? {
            if let Key::Key(k) = event::read().map_err(ToolError::Io)? {
                if matches!(k.code, KeyCode::Char('q') | KeyCode::Esc) {
                    return Ok(());
                }
            }
        }
    }
}

/// One screen: the status line (the winding's temperature rise from the resistance over
/// `r_ref_ohm`, the configured one; under it, the warning of a start whose resistance
/// measurement was `refused`) and three plots.
fn draw(f: &mut Frame, records: &VecDeque<Telemetry>, refused: bool, r_ref_ohm: f32) {
    let [status, speed, currents, residuals] = Layout::vertical([
        Constraint::Length(2),
        Constraint::Percentage(40),
        Constraint::Percentage(30),
        Constraint::Percentage(30),
    ])
    .areas(f.area());
    let last = records.back();
    let text = match last {
        Some(t) => format!(
            "mode {:?}  driving {:?}  fault {}  speed {:.1} rpm (ref {:.1})  i_q {:.2} A  R {:.4} Ω (winding {:+.0} K)  ψ {:.5} Wb   [q quits]",
            t.mode,
            t.driving,
            t.fault.map_or("none", ops::name_of),
            t.speed_rpm,
            t.speed_ref_rpm,
            t.i_q,
            t.r_ohm,
            winding_rise_k(t.r_ohm, r_ref_ohm),
            t.flux_wb
        ),
        None => "waiting for telemetry ...   [q quits]".into(),
    };
    let warning = match (refused, last) {
        (true, Some(t)) => format!("warning: {}", ops::refused_warning(t.r_ohm)),
        _ => String::new(),
    };
    let lines = vec![
        Line::from(text),
        Line::styled(warning, Style::default().fg(Color::Yellow)),
    ];
    f.render_widget(Paragraph::new(lines), status);
    let t_end = last.map_or(0, |r| r.t_ms);
    let series = |pick: fn(&Telemetry) -> f32| -> Vec<(f64, f64)> {
        records
            .iter()
            .map(|r| {
                let age = f64::from(t_end.wrapping_sub(r.t_ms)) / 1000.0;
                (-age, f64::from(pick(r)))
            })
            .collect()
    };
    plot(
        f,
        speed,
        "speed [rpm]",
        &[
            ("ref", Color::Yellow, series(|r| r.speed_ref_rpm)),
            ("speed", Color::Cyan, series(|r| r.speed_rpm)),
        ],
    );
    plot(
        f,
        currents,
        "currents [A]",
        &[
            ("i_d", Color::Green, series(|r| r.i_d)),
            ("i_q", Color::Magenta, series(|r| r.i_q)),
        ],
    );
    plot(
        f,
        residuals,
        "residuals (below 1: locked)",
        &[
            ("primary", Color::Cyan, series(|r| r.residual_primary)),
            ("monitor", Color::Red, series(|r| r.residual_monitor)),
        ],
    );
}

/// A line chart of `lines` over the window, its y range from the data.
/// One plotted line: its name, colour and points (time \[s] before now, value).
type Series<'a> = (&'a str, Color, Vec<(f64, f64)>);

fn plot(f: &mut Frame, area: Rect, title: &str, lines: &[Series]) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for (_, _, pts) in lines {
        for &(_, y) in pts.iter().filter(|p| p.1.is_finite()) {
            lo = lo.min(y);
            hi = hi.max(y);
        }
    }
    if !lo.is_finite() {
        (lo, hi) = (-1.0, 1.0);
    }
    let pad = ((hi - lo) * 0.1).max(1e-3);
    let (lo, hi) = (lo - pad, hi + pad);
    let datasets = lines
        .iter()
        .map(|(name, color, pts)| {
            Dataset::default()
                .name(*name)
                .marker(Marker::Braille)
                .graph_type(GraphType::Line)
                .style(Style::default().fg(*color))
                .data(pts)
        })
        .collect();
    let chart = Chart::new(datasets)
        .block(Block::bordered().title(title.to_string()))
        .x_axis(
            Axis::default()
                .bounds([-WINDOW_S, 0.0])
                .labels(["-10 s", "-5 s", "now"]),
        )
        .y_axis(
            Axis::default()
                .bounds([lo, hi])
                .labels([format!("{lo:.1}"), format!("{hi:.1}")]),
        );
    f.render_widget(chart, area);
}

#[cfg(test)]
mod tests {
    use super::*;
    use pmsm_link::wire::Role;
    use ratatui::backend::TestBackend;
    use ratatui::Terminal;

    /// A screen drawn from a second of records shows the mode, the speed and the three plots.
    #[test]
    fn the_screen_shows_mode_speed_and_three_plots() {
        let records: VecDeque<Telemetry> = (0..100u32)
            .map(|k| Telemetry {
                t_ms: 10 * k,
                mode: Mode::Sensorless,
                fault: None,
                speed_ref_rpm: 500.0,
                speed_rpm: 500.0 + (k % 7) as f32,
                theta_e_primary: 0.0,
                theta_e_monitor: 0.0,
                theta_e_control: 0.0,
                i_d: 0.0,
                i_q: 0.3,
                load_nm: None,
                driving: Role::Primary,
                residual_primary: 0.1,
                residual_monitor: 0.2,
                disagreement_deg: 0.0,
                speed_disagreement_rpm: 0.0,
                r_ohm: 2.5,
                flux_wb: 0.058,
                voltage_limited: false,
            })
            .collect();
        let mut t = Terminal::new(TestBackend::new(200, 40)).unwrap();
        let screen = |t: &mut Terminal<TestBackend>, refused: bool| -> String {
            t.draw(|f| draw(f, &records, refused, 2.0)).unwrap();
            t.backend()
                .buffer()
                .content()
                .iter()
                .map(|c| c.symbol())
                .collect()
        };
        let plain = screen(&mut t, false);
        for text in [
            "mode Sensorless",
            "speed 501.0 rpm",
            // R 2.5 Ω against the configured 2 Ω: (1.25 − 1)/α_Cu = 64 K.
            "winding +64 K",
            "speed [rpm]",
            "currents [A]",
            "residuals",
        ] {
            assert!(plain.contains(text), "{text}");
        }
        assert!(!plain.contains("warning"));
        // A start whose resistance measurement was refused: the warning under the status,
        // with the resistance the drive runs on.
        let warned = screen(&mut t, true);
        assert!(
            warned.contains("warning: the start's resistance measurement was refused"),
            "{warned}"
        );
        assert!(warned.contains("r_ohm = 2.5 Ω"), "{warned}");
    }
}
