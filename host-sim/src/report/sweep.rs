//! `pmsm-sim sweep`: a matrix of runs, in parallel on every core.
//!
//! A matrix file names the scenario and the axes; every key of `[axes]` is a `run` flag (or
//! `scenario` / `scenario_file`) and its list the values; the sweep runs their product. A
//! value that is a table sets several flags at once (its `name` key, if any, labels it):
//!
//! ```toml
//! scenario = "start-stop-reverse"        # or scenario_file = "..." (relative to this file)
//! [fixed]                                # flags of every cell
//! noise-pct = 1.0
//! [axes]
//! observer = ["sliding-torque", "flux"]
//! seed = [1, 2, 3]
//! mismatch = ["", "r=1.5", "flux=0.85,l=1.3"]   # "" leaves the flag out
//! case = [{ name = "nominal" }, { name = "1 µs", dead-time-us = 1.0 }]
//! ```
//!
//! Each cell is a `run` without output files; the sweep reports the pass counts per axis
//! value, every cell (CSV and JSON) and a heat map of the pass fraction over the first two
//! axes.
//!
//! Nothing runs before the whole matrix is known good: the file's size is capped before it is
//! read ([`MAX_MATRIX_BYTES`]), the product of the axes' lengths before the cells are expanded
//! ([`MAX_CELLS`]), and every cell's flags are prepared into its run (the checks `run`
//! applies) before the first cell is simulated; a matrix with an invalid cell is refused,
//! naming the cell and its reason.

use super::summary::{Adapted, Summary};
use anyhow::{bail, ensure, Context};
use indexmap::IndexMap;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// One value of an axis: its label and the flags it sets.
#[derive(Clone, Debug, PartialEq)]
pub struct AxisValue {
    /// Shown in tables, CSV, JSON and the heat map.
    pub label: String,
    /// `(flag, value)`; a value of `None` is a switch without a value.
    pub flags: Vec<(String, Option<String>)>,
}

/// A parsed matrix.
#[derive(Clone, Debug, PartialEq)]
pub struct Matrix {
    /// Flags of every cell (the scenario among them).
    pub fixed: Vec<(String, Option<String>)>,
    /// The axes in file order.
    pub axes: Vec<(String, Vec<AxisValue>)>,
}

/// One cell: its label per axis and its `run` arguments.
#[derive(Clone, Debug, PartialEq)]
pub struct Cell {
    /// Axis name → value label.
    pub params: IndexMap<String, String>,
    /// Arguments after `run`.
    pub args: Vec<String>,
}

/// What a cell reports.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CellResult {
    /// Axis name → value label.
    pub params: IndexMap<String, String>,
    /// The run's verdict.
    pub pass: bool,
    /// Why it failed (or why it could not run).
    pub reasons: Vec<String>,
    /// The drive's fault, if any.
    pub fault: Option<String>,
    /// Lock lost while sensorless.
    pub lost_lock: bool,
    /// Largest window mean speed error, % of max(|command|, 5 % of rated speed).
    pub worst_speed_err_pct: Option<f64>,
    /// Largest |θ̂_e − θ_e| in the windows [deg, electrical].
    pub theta_err_max_deg_e: Option<f64>,
    /// Drive runs: the adapted motor model at the end, against the plant's.
    pub adapted: Option<Adapted>,
}

/// The sweep's answer.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Report {
    /// Cells run.
    pub total: usize,
    /// Cells that passed.
    pub passed: usize,
    /// Every cell, in the order of the product (the last axis fastest).
    pub cells: Vec<CellResult>,
}

/// Pass counts of one axis: its name and `(value label, passed, total)` per value.
pub type AxisCounts = (String, Vec<(String, usize, usize)>);

/// Pass counts over two axes.
#[derive(Clone, Debug, PartialEq)]
pub struct Grid {
    /// Labels of the first axis (columns).
    pub x: Vec<String>,
    /// Labels of the second axis (rows).
    pub y: Vec<String>,
    /// `cells[y][x] = (passed, total)`.
    pub cells: Vec<Vec<(usize, usize)>>,
}

/// Most cells a matrix may have.
pub const MAX_CELLS: usize = 100_000;

/// Largest matrix file \[bytes], checked before the file is read.
pub const MAX_MATRIX_BYTES: u64 = 1 << 20;

/// The number of cells of axes of `lengths` values, refused beyond [`MAX_CELLS`] (from the
/// lengths alone: nothing is expanded).
fn cell_count(lengths: &[usize]) -> anyhow::Result<usize> {
    let n = lengths
        .iter()
        .try_fold(1usize, |n, &len| n.checked_mul(len))
        .filter(|&n| n <= MAX_CELLS);
    n.ok_or_else(|| {
        let factors: Vec<_> = lengths.iter().map(|l| l.to_string()).collect();
        anyhow::anyhow!(
            "the matrix has more than {MAX_CELLS} cells (axes of {} values)",
            factors.join(" x ")
        )
    })
}

/// A TOML value as a flag value.
fn flag_value(key: &str, v: &toml::Value) -> anyhow::Result<Option<String>> {
    Ok(Some(match v {
        toml::Value::String(s) => s.clone(),
        toml::Value::Integer(i) => i.to_string(),
        toml::Value::Float(x) => x.to_string(),
        toml::Value::Boolean(true) => return Ok(None),
        // A flag that takes a value (`terminal-sensing = [true, false]`).
        toml::Value::Boolean(false) => "false".into(),
        other => bail!(
            "{key}: a value must be a string, a number or a boolean, not {}",
            other.type_str()
        ),
    }))
}

/// `(flag, value)` pairs of a key and its value; an empty string drops the flag, a path of a
/// scenario file is taken relative to `dir`.
fn flags_of(
    key: &str,
    v: &toml::Value,
    dir: &Path,
) -> anyhow::Result<Vec<(String, Option<String>)>> {
    let value = flag_value(key, v)?;
    if value.as_deref() == Some("") {
        return Ok(Vec::new());
    }
    let value = match (key, value) {
        ("scenario_file", Some(p)) => Some(dir.join(p).to_string_lossy().into_owned()),
        (_, v) => v,
    };
    Ok(vec![(key.to_string(), value)])
}

impl Matrix {
    /// Parses a matrix file's text; `dir` is the directory scenario files are relative to.
    pub fn parse(text: &str, dir: &Path) -> anyhow::Result<Self> {
        let doc: toml::Table = crate::from_toml(text)?;
        // The size first, from the lists' lengths (a value that is no list is refused below).
        if let Some(toml::Value::Table(axes)) = doc.get("axes") {
            let lengths: Vec<_> = axes
                .values()
                .map(|v| v.as_array().map_or(1, Vec::len))
                .collect();
            cell_count(&lengths)?;
        }
        let mut fixed = Vec::new();
        let mut axes = Vec::new();
        for (key, v) in &doc {
            match (key.as_str(), v) {
                ("scenario" | "scenario_file", _) => fixed.extend(flags_of(key, v, dir)?),
                ("fixed", toml::Value::Table(t)) => {
                    for (k, v) in t {
                        fixed.extend(flags_of(k, v, dir)?);
                    }
                }
                ("axes", toml::Value::Table(t)) => {
                    for (axis, values) in t {
                        let toml::Value::Array(values) = values else {
                            bail!("axes.{axis}: must be a list of values");
                        };
                        ensure!(!values.is_empty(), "axes.{axis}: the list is empty");
                        let mut vals = Vec::new();
                        for v in values {
                            vals.push(match v {
                                toml::Value::Table(t) => {
                                    let mut flags = Vec::new();
                                    let mut label = None;
                                    for (k, v) in t {
                                        if k == "name" {
                                            label = flag_value(k, v)?;
                                        } else {
                                            flags.extend(flags_of(k, v, dir)?);
                                        }
                                    }
                                    let label = label.unwrap_or_else(|| {
                                        let parts: Vec<_> = flags
                                            .iter()
                                            .map(|(k, v)| match v {
                                                Some(v) => format!("{k}={v}"),
                                                None => k.clone(),
                                            })
                                            .collect();
                                        if parts.is_empty() {
                                            "-".into()
                                        } else {
                                            parts.join(" ")
                                        }
                                    });
                                    AxisValue { label, flags }
                                }
                                v => {
                                    let flags = flags_of(axis, v, dir)?;
                                    let label = match flag_value(axis, v)? {
                                        Some(s) if s.is_empty() => "-".into(),
                                        Some(s) => s,
                                        None => "true".into(),
                                    };
                                    AxisValue { label, flags }
                                }
                            });
                        }
                        axes.push((axis.clone(), vals));
                    }
                }
                (k, _) => {
                    bail!("'{k}': a matrix has scenario or scenario_file, [fixed] and [axes]")
                }
            }
        }
        ensure!(
            !axes.is_empty(),
            "a matrix needs at least one axis in [axes]"
        );
        Ok(Self { fixed, axes })
    }

    /// Reads a matrix file: refused by its size (over [`MAX_MATRIX_BYTES`]) before it is read.
    pub fn load(path: &Path) -> anyhow::Result<Self> {
        let text =
            read_capped(path).with_context(|| format!("reading matrix {}", path.display()))?;
        let dir = path.parent().unwrap_or(Path::new("."));
        Self::parse(&text, dir).with_context(|| format!("matrix {}", path.display()))
    }

    /// The number of cells, refused beyond [`MAX_CELLS`].
    pub fn cell_count(&self) -> anyhow::Result<usize> {
        let lengths: Vec<_> = self.axes.iter().map(|(_, v)| v.len()).collect();
        cell_count(&lengths)
    }

    /// Every cell of the product, the last axis fastest (check [`Matrix::cell_count`] first:
    /// a parsed matrix has).
    pub fn cells(&self) -> Vec<Cell> {
        let mut cells = vec![Cell {
            params: IndexMap::new(),
            args: Vec::new(),
        }];
        for (axis, values) in &self.axes {
            cells = cells
                .into_iter()
                .flat_map(|c| {
                    values.iter().map(move |v| {
                        let mut c = c.clone();
                        c.params.insert(axis.clone(), v.label.clone());
                        c.args.extend(args_of(&v.flags));
                        c
                    })
                })
                .collect();
        }
        let fixed = args_of(&self.fixed);
        for c in &mut cells {
            let mut args = fixed.clone();
            args.append(&mut c.args);
            c.args = args;
        }
        cells
    }
}

/// `run` arguments of flags: `scenario` is the positional name, every other key `--key`.
fn args_of(flags: &[(String, Option<String>)]) -> Vec<String> {
    let mut args = Vec::new();
    for (k, v) in flags {
        match (k.as_str(), v) {
            ("scenario", Some(v)) => args.push(v.clone()),
            (k, v) => {
                args.push(format!("--{}", k.replace('_', "-")));
                args.extend(v.clone());
            }
        }
    }
    args
}

/// The text of `path`, refused when over [`MAX_MATRIX_BYTES`]: by its size before reading,
/// and by what was read (a file that grew, a pipe) without reading more than one byte past
/// the limit.
fn read_capped(path: &Path) -> anyhow::Result<String> {
    use std::io::Read as _;
    let over = |n: u64| {
        anyhow::anyhow!(
            "{n} bytes: a matrix file may have at most {MAX_MATRIX_BYTES} bytes \
             (and {MAX_CELLS} cells)"
        )
    };
    let file = std::fs::File::open(path)?;
    let len = file.metadata()?.len();
    if len > MAX_MATRIX_BYTES {
        return Err(over(len));
    }
    let mut text = String::new();
    file.take(MAX_MATRIX_BYTES + 1).read_to_string(&mut text)?;
    if text.len() as u64 > MAX_MATRIX_BYTES {
        return Err(over(text.len() as u64));
    }
    Ok(text)
}

/// A cell for messages: its place in the product and its value per axis.
fn describe(k: usize, total: usize, params: &IndexMap<String, String>) -> String {
    let params: Vec<_> = params.iter().map(|(a, v)| format!("{a} = {v}")).collect();
    format!("cell {} of {total} ({})", k + 1, params.join(", "))
}

/// Failed cells the table lists (every cell is in the JSON and the CSV).
const LISTED: usize = 20;

/// Runs every cell of `matrix` on `jobs` threads (all cores when `None`), with a progress bar
/// on stderr. `prepare` turns a cell's arguments into its run (checking them), `run` the run
/// into its summary. Every cell is prepared before any runs: a matrix with a cell that
/// `prepare` refuses is refused whole, naming its first such cell and why, and how many there
/// are.
pub fn run<T>(
    matrix: &Matrix,
    jobs: Option<usize>,
    prepare: impl Fn(&[String]) -> anyhow::Result<T> + Sync,
    run: impl Fn(T) -> anyhow::Result<Summary> + Sync,
) -> anyhow::Result<Report> {
    let total = matrix.cell_count()?;
    let cells = matrix.cells();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs.unwrap_or(0))
        .build()
        .context("thread pool")?;
    let invalid: Vec<(usize, anyhow::Error)> = pool.install(|| {
        cells
            .par_iter()
            .enumerate()
            .filter_map(|(k, cell)| prepare(&cell.args).err().map(|e| (k, e)))
            .collect()
    });
    if let Some((k, e)) = invalid.first() {
        bail!(
            "{} of {total} cells invalid, none run; the first, {}: {e:#}",
            invalid.len(),
            describe(*k, total, &cells[*k].params)
        );
    }
    let bar = ProgressBar::new(cells.len() as u64);
    bar.set_style(
        ProgressStyle::with_template("{bar:40} {pos}/{len} cells, {elapsed} elapsed, ETA {eta}")
            .context("progress bar template")?,
    );
    let results: Vec<CellResult> = pool.install(|| {
        cells
            .par_iter()
            .map(|cell| {
                let r = match prepare(&cell.args).and_then(&run) {
                    Ok(s) => CellResult {
                        params: cell.params.clone(),
                        pass: s.pass,
                        reasons: s.reasons,
                        fault: s.fault,
                        lost_lock: s.lost_lock,
                        worst_speed_err_pct: s.worst_speed_err_pct,
                        theta_err_max_deg_e: s.theta_err_max_deg_e,
                        adapted: s.adapted,
                    },
                    Err(e) => CellResult {
                        params: cell.params.clone(),
                        pass: false,
                        reasons: vec![format!("could not run: {e:#}")],
                        fault: None,
                        lost_lock: false,
                        worst_speed_err_pct: None,
                        theta_err_max_deg_e: None,
                        adapted: None,
                    },
                };
                bar.inc(1);
                r
            })
            .collect()
    });
    bar.finish_and_clear();
    Ok(Report {
        total: results.len(),
        passed: results.iter().filter(|c| c.pass).count(),
        cells: results,
    })
}

impl Report {
    /// Pass counts per axis value.
    pub fn counts(&self, matrix: &Matrix) -> Vec<AxisCounts> {
        matrix
            .axes
            .iter()
            .map(|(axis, values)| {
                let rows = values
                    .iter()
                    .map(|v| {
                        let of = self
                            .cells
                            .iter()
                            .filter(|c| c.params.get(axis) == Some(&v.label));
                        let (p, n) = of.fold((0, 0), |(p, n), c| (p + usize::from(c.pass), n + 1));
                        (v.label.clone(), p, n)
                    })
                    .collect();
                (axis.clone(), rows)
            })
            .collect()
    }

    /// The table of pass counts per axis value, then the failed cells with their reasons (the
    /// first 20).
    pub fn table(&self, matrix: &Matrix) -> String {
        let mut t = crate::table(&["axis", "value", "passed", "of", "%"], &[2, 3, 4]);
        for (axis, rows) in self.counts(matrix) {
            for (label, p, n) in rows {
                t.add_row([
                    axis.clone(),
                    label,
                    p.to_string(),
                    n.to_string(),
                    format!("{:.0}", 100.0 * p as f64 / n.max(1) as f64),
                ]);
            }
        }
        for k in 2..5 {
            if let Some(c) = t.column_mut(k) {
                c.set_cell_alignment(comfy_table::CellAlignment::Right);
            }
        }
        let mut out = format!("{t}\n{} of {} cells passed\n", self.passed, self.total);
        // Why cells failed (a run that could not start says so).
        let failed = self.cells.iter().enumerate().filter(|(_, c)| !c.pass);
        for (k, c) in failed.clone().take(LISTED) {
            let why = match (c.reasons.is_empty(), &c.fault) {
                (false, _) => c.reasons.join("; "),
                (true, Some(f)) => format!("fault {f}"),
                (true, None) => "failed".into(),
            };
            out += &format!("  {}: {why}\n", describe(k, self.total, &c.params));
        }
        let more = failed.count().saturating_sub(LISTED);
        if more > 0 {
            out += &format!(
                "  and {more} more failed cells (every cell: --json, or --out's sweep.csv)\n"
            );
        }
        out
    }

    /// Every cell as CSV: the axes, then the verdict's columns.
    pub fn csv(&self, matrix: &Matrix) -> anyhow::Result<String> {
        let mut w = csv::Writer::from_writer(Vec::new());
        let mut header: Vec<String> = matrix.axes.iter().map(|(a, _)| a.clone()).collect();
        header.extend(
            [
                "pass",
                "fault",
                "lost_lock",
                "worst_speed_err_pct",
                "theta_err_max_deg_e",
                "r_err_pct",
                "flux_err_pct",
                "reasons",
            ]
            .map(String::from),
        );
        w.write_record(&header)?;
        let opt = |x: Option<f64>| x.map_or(String::new(), |x| format!("{x:.6}"));
        for c in &self.cells {
            let mut row: Vec<String> = c.params.values().cloned().collect();
            row.extend([
                c.pass.to_string(),
                c.fault.clone().unwrap_or_default(),
                c.lost_lock.to_string(),
                opt(c.worst_speed_err_pct),
                opt(c.theta_err_max_deg_e),
                opt(c.adapted.as_ref().map(|a| a.r_err_pct)),
                opt(c.adapted.as_ref().map(|a| a.flux_err_pct)),
                c.reasons.join("; "),
            ]);
            w.write_record(&row)?;
        }
        Ok(String::from_utf8(w.into_inner()?)?)
    }

    /// The pass counts over the first two axes (summed over every other axis), for the heat
    /// map.
    pub fn grid(&self, matrix: &Matrix) -> Grid {
        let labels = |k: usize| -> (Option<&String>, Vec<String>) {
            matrix
                .axes
                .get(k)
                .map_or((None, vec!["all".into()]), |(a, v)| {
                    (Some(a), v.iter().map(|x| x.label.clone()).collect())
                })
        };
        let (xa, xs) = labels(0);
        let (ya, ys) = labels(1);
        let mut grid = vec![vec![(0, 0); xs.len()]; ys.len()];
        for c in &self.cells {
            let find = |axis: Option<&String>, ls: &[String]| {
                axis.map_or(Some(0), |a| {
                    ls.iter().position(|l| Some(l) == c.params.get(a))
                })
            };
            if let (Some(x), Some(y)) = (find(xa, &xs), find(ya, &ys)) {
                grid[y][x].0 += usize::from(c.pass);
                grid[y][x].1 += 1;
            }
        }
        Grid {
            x: xs,
            y: ys,
            cells: grid,
        }
    }

    /// Writes `sweep.csv`, `sweep.json` and `heatmap.png` into `dir`; returns their paths.
    pub fn write(&self, matrix: &Matrix, dir: &Path, title: &str) -> anyhow::Result<[PathBuf; 3]> {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let csv = dir.join("sweep.csv");
        std::fs::write(&csv, self.csv(matrix)?)
            .with_context(|| format!("writing {}", csv.display()))?;
        let json = dir.join("sweep.json");
        std::fs::write(&json, serde_json::to_string_pretty(self)?)
            .with_context(|| format!("writing {}", json.display()))?;
        let png = dir.join("heatmap.png");
        let g = self.grid(matrix);
        let axis = |k: usize| matrix.axes.get(k).map_or("", |(a, _)| a.as_str());
        crate::plot::heat_map(&png, title, (axis(0), &g.x), (axis(1), &g.y), &g.cells)?;
        Ok([csv, json, png])
    }
}
