//! `abba trial`.
use anyhow::{bail, Result};

/// Arguments of `abba trial`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs `abba trial`.
pub fn run(_args: Args) -> Result<()> {
    bail!("abba trial is not implemented yet")
}
