//! What the runs report: a run's metrics, verdict and JSON summary ([`summary`]), its CSV
//! time series and plot ([`output`]), and the matrices of runs ([`sweep`]).

pub mod output;
pub mod summary;
pub mod sweep;
