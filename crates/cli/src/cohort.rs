//! `abba cohort`.
use anyhow::{bail, Result};

/// Arguments of `abba cohort`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs `abba cohort`.
pub fn run(_args: Args) -> Result<()> {
    bail!("abba cohort is not implemented yet")
}
