//! Tests of the plots: decimation, ranges, tick labels and PNGs from odd data.

use super::axis::{axis_range, tick_formatter};
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
fn plot_panels_marked_writes_bands_events_and_a_fault() {
    let t: Vec<f64> = (0..2000).map(|i| i as f64 * 1e-3).collect();
    let y: Vec<f64> = t.iter().map(|t| t.sin()).collect();
    let panels = [Panel {
        title: "marked",
        y_label: "y",
        series: vec![Series {
            label: "y",
            x: &t,
            y: &y,
        }],
    }];
    let event = |x: f64, label: &str, fault| Event {
        x,
        label: label.into(),
        fault,
    };
    let marks = Marks {
        bands: vec![
            Band {
                x0: 0.0,
                x1: 1.0,
                label: "Align",
                shade: 2,
            },
            Band {
                x0: 1.0,
                x1: 1.5,
                label: "Sensorless",
                shade: 4,
            },
            Band {
                x0: 1.5,
                x1: 2.0,
                label: "Fault",
                shade: 5,
            },
        ],
        events: vec![
            event(0.0, "Enabled", false),
            event(1.0, "HandOver", false),
            event(1.5, "fault: overcurrent", true),
            // Beyond the data: clamped to the axis, never a panic.
            event(1e300, "far", false),
        ],
    };
    let path = temp_png("marked");
    plot_panels_marked(&path, "marked", "t", &panels, &marks).unwrap();
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
