//! `abba serve`: the HTTP service over a person store, and `abba token`:
//! a new admin (or person) token, printed once.
use std::io::Write;
use std::path::PathBuf;

use anyhow::{bail, Context, Result};

/// Arguments of `abba serve`.
#[derive(clap::Args, Debug)]
pub struct ServeArgs {
    /// The store file (created if missing).
    #[arg(long, value_name = "FILE")]
    pub db: PathBuf,
    /// Address to listen on (port 0: any free port, printed).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8080")]
    pub listen: String,
}

/// Runs `abba serve` until SIGTERM or Ctrl-C.
pub fn serve(a: ServeArgs) -> Result<()> {
    abba_service::serve(&a.db, &a.listen, |addr| {
        println!(
            "abba serve: listening on http://{addr} (store {})",
            a.db.display()
        );
        println!("{}", abba_api::NOTICE);
        // Whoever started us may wait for this line.
        let _ = std::io::stdout().flush();
    })
    .with_context(|| format!("serving {}", a.db.display()))?;
    println!("abba serve: stopped");
    Ok(())
}

/// Arguments of `abba token`.
#[derive(clap::Args, Debug)]
pub struct TokenArgs {
    /// The store file (created if missing).
    #[arg(long, value_name = "FILE")]
    pub db: PathBuf,
    /// A clinic (admin) token: creates persons, sets bounds, issues tokens.
    #[arg(long)]
    pub admin: bool,
    /// A token for this person only.
    #[arg(long, value_name = "NAME", conflicts_with = "admin")]
    pub person: Option<String>,
}

/// Runs `abba token`: prints the token once (only its hash is stored).
pub fn token(a: TokenArgs) -> Result<()> {
    let (id, token) = match (&a.person, a.admin) {
        (Some(name), false) => abba_service::new_person_token(&a.db, name)?,
        (None, true) => abba_service::new_admin_token(&a.db)?,
        _ => bail!("say which token: --admin or --person NAME"),
    };
    eprintln!(
        "token {id} issued; it is shown only now (the store keeps its SHA-256). Revoke with DELETE /v1/tokens/{id}."
    );
    println!("{token}");
    Ok(())
}
