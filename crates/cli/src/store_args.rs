//! `--db FILE --person NAME`, the arguments every person command starts
//! with (flattened into each command's arguments), and the store they open.
use std::path::{Path, PathBuf};

use abba_store::Store;
use anyhow::{Context, Result};

/// The store (a file or a PostgreSQL URL) and the person in it.
#[derive(clap::Args, Debug)]
pub struct PersonArgs {
    /// The store: a file, or a postgres:// URL.
    #[arg(long, value_name = "FILE")]
    pub db: PathBuf,
    /// The person.
    #[arg(long, value_name = "NAME")]
    pub person: String,
}

impl PersonArgs {
    /// Opens the store file.
    pub fn open(&self) -> Result<Store> {
        open(&self.db)
    }
}

/// Opens a store (a file, or a `postgres://` URL); the error names it
/// (a URL without its password).
pub fn open(db: &Path) -> Result<Store> {
    Store::open(db).with_context(|| format!("opening {}", abba_store::backend::shown(db)))
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// The person commands take `--db FILE` and `--person NAME` first,
    /// required, with the help they had before the flattening (clap drops
    /// the period of a one-line doc).
    #[test]
    fn every_person_command_takes_db_and_person_as_before() {
        let mut cli = crate::Cli::command();
        cli.build();
        let commands: [&[&str]; 8] = [
            &["import"],
            &["advise"],
            &["answer"],
            &["history"],
            &["report"],
            &["therapy", "set"],
            &["link", "nightscout"],
            &["link", "remove"],
        ];
        for path in commands {
            let mut c = &cli;
            for name in path {
                c = c.find_subcommand(name).expect("the subcommand exists");
            }
            let args: Vec<_> = c.get_arguments().take(2).collect();
            let got: Vec<_> = args
                .iter()
                .map(|a| {
                    (
                        a.get_long(),
                        a.get_value_names().map(|v| v[0].to_string()),
                        a.get_help().map(ToString::to_string),
                        a.is_required_set(),
                    )
                })
                .collect();
            let want = [
                (
                    Some("db"),
                    Some("FILE".to_string()),
                    Some("The store: a file, or a postgres:// URL".to_string()),
                    true,
                ),
                (
                    Some("person"),
                    Some("NAME".to_string()),
                    Some("The person".to_string()),
                    true,
                ),
            ];
            assert_eq!(got, want, "abba {}", path.join(" "));
        }
        cli.debug_assert();
    }
}
