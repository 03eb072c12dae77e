//! `pmsm-sim`: run the pmsm-sensorless core against the simulated motor. This file parses the
//! command line and dispatches; each subcommand is a module of its own.

/// `writeln!` into a `String` (which cannot fail).
macro_rules! outln {
    ($out:expr, $($arg:tt)*) => {{
        let _ = writeln!($out, $($arg)*);
    }};
}

mod args;
mod bounds;
mod cycles;
mod gains;
mod gamma;
mod identify;
mod list;
mod run;
mod sweep;

use clap::{Parser, Subcommand};
use std::io::Write as _;
use std::process::ExitCode;

#[derive(Parser)]
#[command(
    name = "pmsm-sim",
    version,
    about = "PMSM plant simulator for the pmsm-sensorless core"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List scenarios, motors and observers.
    List,
    /// Run a scenario and give its verdict (exit 3 when it fails); with --out, write
    /// run.csv and run.png. The board's conditions unless --ideal.
    Run(Box<run::RunArgs>),
    /// A matrix of runs in parallel (every key of the matrix's `[axes]` is a run flag); exit 1
    /// when a cell fails, or when the matrix is refused before any cell runs (an invalid
    /// cell, named with its reason; too many cells; too large a file).
    Sweep(sweep::SweepArgs),
    /// Every gain and limit the drive derives for a motor, with warnings for what will
    /// struggle.
    Gains(gains::GainsArgs),
    /// Sliding-gain bounds of Horng & Chin Sec 4 at an operating point.
    Bounds(bounds::BoundsArgs),
    /// Limits on the flux observer's gain γ (Ortega et al. eq (9), Proposition 4).
    Gamma(gamma::GammaArgs),
    /// Instruction and cycle counts of the core on the emulated Cortex-M4F, firmware size.
    Cycles(cycles::CyclesArgs),
    /// The drive identifies the simulated motor from its pole pairs and ratings (R, L, flux
    /// linkage, J, B); exit 3 when it ends in an error. With --out, write the motor file.
    Identify(Box<identify::IdentifyArgs>),
}

/// What a subcommand printed, and the exit code when it is not success.
type Outcome = anyhow::Result<(String, Option<u8>)>;

/// A text and whether the run (sweep, identification) passed: `failed` is its exit code.
fn verdict(r: anyhow::Result<(String, bool)>, failed: u8) -> Outcome {
    r.map(|(text, ok)| (text, (!ok).then_some(failed)))
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            use clap::error::ErrorKind;
            if matches!(e.kind(), ErrorKind::DisplayHelp | ErrorKind::DisplayVersion) {
                print!("{e}");
                return ExitCode::SUCCESS;
            }
            // clap's own message: what is wrong, the usage, and where to find help.
            eprint!("{e}");
            return ExitCode::from(2);
        }
    };
    let plain = |r: anyhow::Result<String>| r.map(|text| (text, None));
    let result: Outcome = match cli.command {
        Command::List => plain(list::list()),
        // A run that faults, loses lock or misses a window exits 3 after its output.
        Command::Run(args) => verdict(run::run(*args), 3),
        // A sweep with a failed cell exits 1 after its output.
        Command::Sweep(args) => verdict(sweep::sweep(args), 1),
        Command::Gains(args) => plain(gains::gains(args)),
        Command::Bounds(args) => plain(bounds::bounds(args)),
        Command::Gamma(args) => plain(gamma::gamma(args)),
        Command::Cycles(args) => plain(cycles::cycles(args)),
        // An identification that ends in its named error exits 3 after its output.
        Command::Identify(args) => verdict(identify::identify(*args), 3),
    };
    match result {
        Ok((text, code)) => {
            // A closed pipe (`pmsm-sim list | head -1`) is not an error worth a panic.
            let _ = std::io::stdout().write_all(text.as_bytes());
            code.map_or(ExitCode::SUCCESS, ExitCode::from)
        }
        Err(e) => {
            eprintln!("error: {}", format!("{e:#}").replace('\n', " "));
            ExitCode::FAILURE
        }
    }
}
