//! `abba metrics`.
use anyhow::{bail, Result};

/// Arguments of `abba metrics`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs `abba metrics`.
pub fn run(_args: Args) -> Result<()> {
    bail!("abba metrics is not implemented yet")
}
