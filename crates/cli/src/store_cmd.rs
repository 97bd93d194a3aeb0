//! `abba store check` (what in a store cannot be right), `abba store
//! remove-future` (the documented repair of events dated in the future)
//! and `abba store copy` (a whole store into another backend).
use std::path::PathBuf;

use abba_store::check::{CheckReport, FutureEvent};
use anyhow::{bail, Result};

/// Arguments of `abba store`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    pub what: What,
}

/// What to do with the store.
#[derive(clap::Subcommand, Debug)]
pub enum What {
    /// Check the file (SQLite's integrity check) and list events dated more
    /// than 10 minutes after this computer's clock; exit 1 when anything is
    /// wrong.
    Check {
        /// The store: a file, or a postgres:// URL.
        #[arg(long, value_name = "FILE")]
        db: PathBuf,
    },
    /// Delete every event dated more than 10 minutes after this computer's
    /// clock (with the answers to suggestions after it; stored suggestions
    /// are rebuilt). Prints what it deleted. Stop `abba serve` first or not:
    /// it notices the change.
    RemoveFuture {
        /// The store: a file, or a postgres:// URL.
        #[arg(long, value_name = "FILE")]
        db: PathBuf,
        /// Really delete (without it: only list what would go).
        #[arg(long)]
        yes: bool,
    },
    /// Copy every person with the whole log, answers, tokens, links and
    /// sessions into an empty store: an SQLite file into a PostgreSQL
    /// database (`--to postgres://USER@HOST/DB`) or back. One transaction:
    /// the copy is whole or absent. Stop `abba serve` on the source first.
    Copy {
        /// The store to copy (a file, or a postgres:// URL).
        #[arg(long, value_name = "FILE|URL")]
        from: PathBuf,
        /// The empty store to copy into (created if missing).
        #[arg(long, value_name = "FILE|URL")]
        to: PathBuf,
    },
}

fn line(f: &FutureEvent) -> String {
    format!(
        "  {} (id {}): {} {} {} at {}",
        f.person, f.person_id, f.origin, f.id, f.kind, f.at
    )
}

fn print_report(r: &CheckReport) {
    println!("store check at {} (clock of this computer)", r.now);
    if r.integrity == ["ok"] {
        println!("integrity: ok");
    } else {
        println!("integrity: NOT ok");
        for l in &r.integrity {
            println!("  {l}");
        }
    }
    if r.future.is_empty() {
        println!("events in the future: none");
    } else {
        println!(
            "events in the future: {} (more than {} minutes after the clock; remove with `abba store remove-future --db FILE --yes`)",
            r.future.len(),
            abba_core::limits::FUTURE_SKEW_MINUTES
        );
        for f in &r.future {
            println!("{}", line(f));
        }
    }
}

/// Runs `abba store`.
pub fn run(a: Args) -> Result<()> {
    eprintln!("{}", abba_advisor::words::NOTICE);
    let now = jiff::Timestamp::now();
    match a.what {
        What::Check { db } => {
            let store = crate::store_args::open(&db)?;
            let r = store.check(now)?;
            print_report(&r);
            if !r.ok() {
                bail!("{}: the check found problems (listed above)", db.display());
            }
        }
        What::RemoveFuture { db, yes } => {
            let mut store = crate::store_args::open(&db)?;
            if !yes {
                let r = store.check(now)?;
                print_report(&r);
                if !r.future.is_empty() {
                    println!("nothing deleted: add --yes to delete these events");
                }
                return Ok(());
            }
            let gone = store.remove_future(now)?;
            println!("deleted {} events dated in the future:", gone.len());
            for f in &gone {
                println!("{}", line(f));
            }
        }
        What::Copy { from, to } => {
            let mut src = crate::store_args::open(&from)?;
            let mut dst = crate::store_args::open(&to)?;
            let summary = src.copy_into(&mut dst)?;
            println!(
                "copied {} ({}) into {} ({}):",
                abba_store::backend::shown(&from),
                src.backend(),
                abba_store::backend::shown(&to),
                dst.backend()
            );
            for (table, rows) in &summary.tables {
                println!("  {table}: {rows} rows");
            }
        }
    }
    Ok(())
}
