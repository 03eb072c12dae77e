//! `pmsm-sim sweep`: a matrix of `run` cells in parallel, its table or JSON and its files.

use crate::run::{prepare, RunArgs};
use clap::Parser;
use pmsm_host_sim::report::summary::Summary;
use pmsm_host_sim::sim;
use std::fmt::Write as _;
use std::path::PathBuf;

#[derive(clap::Args)]
pub struct SweepArgs {
    /// Matrix TOML file (format: host-sim/src/report/sweep.rs; host-sim/matrices/).
    #[arg(long, value_name = "M.toml")]
    matrix: PathBuf,
    /// Print the cells as JSON on stdout instead of the table.
    #[arg(long)]
    json: bool,
    /// Write sweep.csv, sweep.json and heatmap.png into this directory.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Threads (default: every core).
    #[arg(long)]
    jobs: Option<usize>,
}

/// A cell's flags: those of `run`.
#[derive(Parser)]
#[command(name = "pmsm-sim run")]
struct Cell {
    #[command(flatten)]
    run: RunArgs,
}

/// `sweep`: the table (or JSON) and whether every cell passed.
pub fn sweep(args: SweepArgs) -> anyhow::Result<(String, bool)> {
    use pmsm_host_sim::report::sweep::{self, Matrix};
    let matrix = Matrix::load(&args.matrix)?;
    if let Some(j) = args.jobs {
        anyhow::ensure!(j > 0, "--jobs must be at least 1");
    }
    // A cell's flags into its run, with every check of `run`: every cell is prepared so
    // before any runs.
    let prepare_cell = |cell: &[String]| {
        let cli = Cell::try_parse_from(
            std::iter::once("pmsm-sim run".to_string()).chain(cell.iter().cloned()),
        )
        .map_err(|e| {
            let e = e.to_string();
            let first = e.lines().next().unwrap_or("");
            anyhow::anyhow!("{}", first.strip_prefix("error: ").unwrap_or(first))
        })?;
        anyhow::ensure!(
            cli.run.out.is_none(),
            "a sweep cell writes no files (--out)"
        );
        prepare(&cli.run)
    };
    let report = sweep::run(&matrix, args.jobs, prepare_cell, |cfg| {
        Ok(Summary::of(&sim::run(cfg)?))
    })?;
    let mut out = if args.json {
        serde_json::to_string(&report)? + "\n"
    } else {
        report.table(&matrix)
    };
    if let Some(dir) = &args.out {
        let title = format!(
            "{}: {} of {} cells passed",
            args.matrix.display(),
            report.passed,
            report.total
        );
        let files = report.write(&matrix, dir, &title)?;
        if !args.json {
            for f in files {
                outln!(out, "{}", f.display());
            }
        }
    }
    Ok((out, report.passed == report.total))
}
