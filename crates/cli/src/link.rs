//! `abba link`: a person's link to their Nightscout site (`link
//! nightscout`, `link --list`, `link remove`), and `abba sync`: what is new
//! there into the store, then the day's advice. No credential is ever
//! printed.
use std::io::BufRead;
use std::path::PathBuf;

use crate::advice_text::advice_text;
use abba_nightscout::{site, sync::Check, write_back, ClientOptions, SyncOptions};
use abba_store::{ProfileResolution, NOTICE};
use anyhow::{bail, Context, Result};

/// Arguments of `abba link`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// What to do.
    #[command(subcommand)]
    pub command: Option<Cmd>,
    /// List the links: person, site, credential kind, last sync and error.
    #[arg(long)]
    pub list: bool,
    /// The store: a file, or a postgres:// URL (with --list).
    #[arg(long, value_name = "FILE")]
    pub db: Option<PathBuf>,
    /// Print the list as JSON.
    #[arg(long)]
    pub json: bool,
}

/// The link commands.
#[derive(clap::Subcommand, Debug)]
pub enum Cmd {
    /// Link a person to their Nightscout site (checked: status and a read).
    Nightscout(NightscoutArgs),
    /// Remove a person's link (the records stay).
    Remove(RemoveArgs),
}

/// Arguments of `abba link nightscout`.
#[derive(clap::Args, Debug)]
pub struct NightscoutArgs {
    #[command(flatten)]
    pub who: crate::store_args::PersonArgs,
    /// The site (https://...; plain http only to this machine).
    #[arg(long, value_name = "URL")]
    pub url: String,
    /// An access token from the site's Admin tools (role readable; careportal and admin to write back). `-`: read it from stdin.
    #[arg(
        long,
        value_name = "TOKEN",
        conflicts_with = "api_secret",
        required_unless_present = "api_secret"
    )]
    pub token: Option<String>,
    /// The site's API_SECRET (only its SHA-1 is stored). `-`: read it from stdin.
    #[arg(long, value_name = "SECRET")]
    pub api_secret: Option<String>,
    /// Write each suggestion back as a Note and today's settings as a profile named abba (never the default, never a Profile Switch).
    #[arg(long)]
    pub write_back: bool,
}

/// Arguments of `abba link remove`.
#[derive(clap::Args, Debug)]
pub struct RemoveArgs {
    #[command(flatten)]
    pub who: crate::store_args::PersonArgs,
    /// Also remove from the site what abba wrote there (its Notes, its profile).
    #[arg(long)]
    pub delete_written: bool,
}

/// Arguments of `abba sync`.
#[derive(clap::Args, Debug)]
pub struct SyncArgs {
    /// The store: a file, or a postgres:// URL.
    #[arg(long, value_name = "FILE")]
    pub db: PathBuf,
    /// The person [default: every linked person].
    #[arg(long, value_name = "NAME")]
    pub person: Option<String>,
    /// When the site's pump profile differs from the therapy the store holds: put the profile in force.
    #[arg(long, conflicts_with = "keep_therapy")]
    pub adopt_profile: bool,
    /// When the site's pump profile differs from the therapy the store holds: keep the store's values.
    #[arg(long)]
    pub keep_therapy: bool,
    /// Print the reports as JSON.
    #[arg(long)]
    pub json: bool,
}

fn from_stdin(v: &str, what: &str) -> Result<String> {
    if v != "-" {
        return Ok(v.to_string());
    }
    let mut line = String::new();
    std::io::stdin()
        .lock()
        .read_line(&mut line)
        .with_context(|| format!("reading the {what} from stdin"))?;
    Ok(line.trim_end_matches(['\r', '\n']).to_string())
}

/// Runs `abba link`.
pub fn run(a: Args) -> Result<()> {
    match (a.command, a.list) {
        (Some(Cmd::Nightscout(n)), false) => nightscout(n),
        (Some(Cmd::Remove(r)), false) => remove(r),
        (None, true) => {
            let Some(db) = a.db else {
                bail!("abba link --list: give the store with --db FILE");
            };
            list(&db, a.json)
        }
        _ => bail!("say what to do: `abba link nightscout ...`, `abba link --list --db FILE` or `abba link remove ...`"),
    }
}

fn nightscout(n: NightscoutArgs) -> Result<()> {
    let token = n
        .token
        .as_deref()
        .map(|t| from_stdin(t, "token"))
        .transpose()?;
    let secret = n
        .api_secret
        .as_deref()
        .map(|s| from_stdin(s, "API secret"))
        .transpose()?;
    let credential = site::credential(token.as_deref(), secret.as_deref())?;
    let mut store = n.who.open()?;
    let (link, check) = abba_nightscout::link(
        &mut store,
        &n.who.person,
        &n.url,
        credential,
        n.write_back,
        &ClientOptions::default(),
    )?;
    let Check {
        name,
        version,
        v3,
        newest_entry,
        write_unverified,
    } = check;
    println!(
        "Linked {} to {} ({name} {version}; API v3 {}), with {}{}.",
        link.person,
        link.url,
        if v3 { "used for deletions" } else { "not used" },
        match link.credential.kind() {
            "token" => "an access token",
            _ => "the API secret's SHA-1",
        },
        if link.write_back {
            "; suggestions are written back as Notes and a profile named abba"
        } else {
            ""
        }
    );
    if let Some(why) = write_unverified {
        println!("Write-back not checked: {why}.");
    }
    match newest_entry {
        Some(t) => println!(
            "The newest entry there: {t}. Run `abba sync --db {} --person {}`.",
            n.who.db.display(),
            link.person
        ),
        None => println!("The site holds no entries yet."),
    }
    println!("{NOTICE}");
    Ok(())
}

fn list(db: &std::path::Path, json: bool) -> Result<()> {
    let store = crate::store_args::open(db)?;
    let views: Vec<_> = store.links()?.iter().map(|l| l.view()).collect();
    if json {
        println!("{}", serde_json::to_string_pretty(&views)?);
        return Ok(());
    }
    if views.is_empty() {
        println!("No links in {}.", db.display());
    }
    for v in &views {
        println!(
            "{}: {} ({}{}); last sync: {}{}",
            v.person,
            v.url,
            v.credential_kind,
            if v.write_back { ", write-back" } else { "" },
            v.last_sync_at.as_deref().unwrap_or("never"),
            match &v.last_error {
                Some(e) => format!(", failed ({} in a row): {e}", v.failures),
                None => String::new(),
            }
        );
        for w in &v.warnings {
            println!("  not looked for by the last sync (what it read is in): {w}");
        }
    }
    println!("{NOTICE}");
    Ok(())
}

fn remove(r: RemoveArgs) -> Result<()> {
    let mut store = r.who.open()?;
    let Some(link) = store.link(&r.who.person)? else {
        bail!("{} has no Nightscout link", r.who.person);
    };
    if r.delete_written {
        let client = abba_nightscout::sync::client_of(&link, &ClientOptions::default())?;
        let n = write_back::delete_written(&mut store, &client, &r.who.person)?;
        println!("Removed {n} documents abba wrote to {}.", link.url);
    }
    store.remove_link(&r.who.person)?;
    println!(
        "Removed the link of {} to {}; the records stay.",
        r.who.person, link.url
    );
    Ok(())
}

/// Runs `abba sync`.
pub fn sync(a: SyncArgs) -> Result<()> {
    let mut store = crate::store_args::open(&a.db)?;
    let persons = match &a.person {
        Some(p) => vec![p.clone()],
        None => store.links()?.into_iter().map(|l| l.person).collect(),
    };
    if persons.is_empty() {
        bail!(
            "no person in {} has a Nightscout link (make one with `abba link nightscout`)",
            a.db.display()
        );
    }
    let opts = SyncOptions {
        resolve: match (a.adopt_profile, a.keep_therapy) {
            (true, _) => ProfileResolution::Adopt,
            (_, true) => ProfileResolution::Keep,
            _ => ProfileResolution::Stop,
        },
        ..SyncOptions::default()
    };
    let mut failed = Vec::new();
    let mut write_back_failed = Vec::new();
    for p in &persons {
        match abba_nightscout::sync(&mut store, p, &opts) {
            Ok(r) => {
                if a.json {
                    println!("{}", serde_json::to_string_pretty(&r)?);
                    continue;
                }
                let parts: Vec<String> = r
                    .collections
                    .iter()
                    .map(|c| {
                        let mut s =
                            format!("{} {} documents in {} pages", c.name, c.documents, c.pages);
                        if c.late > 0 {
                            s += &format!(
                                " ({} uploaded late: dated before the window read again, inserted or changed since)",
                                c.late
                            );
                        }
                        s
                    })
                    .collect();
                println!("Synced {} from {}: {}.", r.person, r.site, parts.join(", "));
                match &r.import.import {
                    Some(s) => crate::import::print_summary(s, p),
                    None => println!("Nothing to import."),
                }
                if r.import.deleted > 0 {
                    println!(
                        "{} records removed: their documents were deleted on the site.",
                        r.import.deleted
                    );
                }
                if !r.gone.is_empty() {
                    let shown: Vec<&str> = r.gone.iter().take(5).map(String::as_str).collect();
                    println!(
                        "{} documents abba holds are no longer on the site ({}{}): deleted through API v1, which leaves no trace of why; their records are kept.",
                        r.gone.len(),
                        shown.join(", "),
                        if r.gone.len() > shown.len() { ", ..." } else { "" }
                    );
                }
                for w in &r.warnings {
                    println!("Not checked: {w}.");
                }
                if let Some(w) = &r.write_back {
                    println!(
                        "Written back: {} new Notes, {} updated{}.",
                        w.notes_created,
                        w.notes_updated,
                        match (&w.profile_skipped, w.profile_written) {
                            (Some(why), _) => format!("; the abba profile not written: {why}"),
                            (None, true) => "; the abba profile updated".into(),
                            (None, false) => String::new(),
                        }
                    );
                }
                let glucose = store.person(p)?.settings.units;
                print!("{}", advice_text(&store.advise(p)?, glucose));
            }
            // The records of this sync are in; only writing back failed.
            Err(e @ abba_nightscout::NsError::WriteBack(_)) => {
                eprintln!("{p}: {e}");
                write_back_failed.push(p.clone());
            }
            Err(e) => {
                eprintln!("{p}: the sync failed: {e}");
                failed.push(p.clone());
            }
        }
    }
    if !failed.is_empty() || !write_back_failed.is_empty() {
        let mut parts = Vec::new();
        if !failed.is_empty() {
            parts.push(format!(
                "the sync failed for {}; the store holds what earlier syncs brought",
                failed.join(", ")
            ));
        }
        if !write_back_failed.is_empty() {
            parts.push(format!(
                "writing back failed for {}; this sync's records are in the store",
                write_back_failed.join(", ")
            ));
        }
        bail!("{}", parts.join("; "));
    }
    Ok(())
}
