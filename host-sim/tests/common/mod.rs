//! What the command-line tests share.

use std::process::{Command, Output};

/// `pmsm-sim ARGS`, run to its end.
pub fn sim(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_pmsm-sim"))
        .args(args)
        .output()
        .expect("pmsm-sim runs")
}
