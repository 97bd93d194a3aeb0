//! `abba simulate`.
use anyhow::{bail, Result};

/// Arguments of `abba simulate`.
#[derive(clap::Args, Debug)]
pub struct Args {}

/// Runs `abba simulate`.
pub fn run(_args: Args) -> Result<()> {
    bail!("abba simulate is not implemented yet")
}
