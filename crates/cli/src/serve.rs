//! `abba serve`: the HTTP service over a person store, and `abba token`:
//! a new admin (or person) token, printed once.
use std::io::Write;
use std::path::PathBuf;
use std::time::Duration;

use abba_service::{ServeSettings, StoreSettings};

use anyhow::{bail, Context, Result};

/// Arguments of `abba serve`.
#[derive(clap::Args, Debug)]
pub struct ServeArgs {
    /// The store: a file (created if missing; a read-only one is refused), or a postgres:// URL.
    #[arg(long, value_name = "FILE")]
    pub db: PathBuf,
    /// Address to listen on (port 0: any free port, printed).
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1:8080")]
    pub listen: String,
    /// Close a connection that has not sent a whole request head this many
    /// seconds after it opened or after its last answer (keep-alive idle).
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    pub header_timeout: f64,
    /// 408 when a request body pauses longer than this many seconds.
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    pub body_timeout: f64,
    /// 408 when a request is not answered this many seconds after its head.
    #[arg(long, value_name = "S", default_value_t = 60.0)]
    pub request_timeout: f64,
    /// Close a connection whose answer makes no progress (the client reads
    /// none of it) for this many seconds.
    #[arg(long, value_name = "S", default_value_t = 20.0)]
    pub write_timeout: f64,
    /// Connections held at once; one more closes the connection idle (or
    /// with a head not yet whole) the longest, or, when every one has a
    /// request in flight, gets 503.
    #[arg(long, value_name = "N", default_value_t = 8192)]
    pub max_connections: usize,
    /// Connections held at once from one client address (loopback too,
    /// unless --behind-proxy); one more closes that client's connection
    /// idle the longest, or gets 503.
    #[arg(long, value_name = "N", default_value_t = 256)]
    pub max_connections_per_client: usize,
    /// Requests in flight at once (more get 503 with Retry-After).
    #[arg(long, value_name = "N", default_value_t = 256)]
    pub max_in_flight: usize,
    /// Requests in flight at once from one client address (more get 503).
    #[arg(long, value_name = "N", default_value_t = 64)]
    pub max_in_flight_per_client: usize,
    /// Requests in flight at once from one client with one token or
    /// session (more get 503).
    #[arg(long, value_name = "N", default_value_t = 16)]
    pub max_in_flight_per_token: usize,
    /// A reverse proxy on this host forwards every client: loopback peers
    /// get no per-address connection limit, and their requests count for
    /// the last address of X-Forwarded-For, which the proxy must append
    /// (nginx: $proxy_add_x_forwarded_for); its X-Forwarded-Proto: https
    /// makes the session cookies Secure. Without it neither header is read.
    #[arg(long)]
    pub behind_proxy: bool,
    /// Seconds requests in flight get to finish after SIGTERM or Ctrl-C.
    #[arg(long, value_name = "S", default_value_t = 10.0)]
    pub shutdown_grace: f64,
    /// SQLite connections in the pool.
    #[arg(long, value_name = "N", default_value_t = 8)]
    pub connections: u32,
    /// Seconds a write waits for another writer before the request gets 503.
    #[arg(long, value_name = "S", default_value_t = 5.0)]
    pub busy_timeout: f64,
    /// Live advisors kept in memory at most.
    #[arg(long, value_name = "N", default_value_t = 1000)]
    pub cache_persons: u64,
    /// Events the live advisors in memory may hold together (a person's
    /// advisor holds the person's whole log; about 80 bytes an event).
    #[arg(long, value_name = "N", default_value_t = 2_000_000)]
    pub cache_events: u64,
    /// Seconds a live advisor stays in memory unused.
    #[arg(long, value_name = "S", default_value_t = 1800.0)]
    pub cache_idle: f64,
    /// Failed authentications a client address may make per minute before
    /// it gets 429 for the rest of the minute.
    #[arg(long, value_name = "N", default_value_t = 30)]
    pub auth_failures: u32,
    /// The URL persons reach the service at (for example https://abba.clinic.example behind a TLS proxy): the clinic's sign-in links name it [default: the URL each request came to, from its Host header].
    #[arg(long, value_name = "URL")]
    pub public_url: Option<String>,
    /// Sync every linked Nightscout site this often in the background (`5m`, `300s`, `1h`); failures back off.
    #[arg(long, value_name = "DURATION")]
    pub sync_every: Option<String>,
    /// Background syncs at once.
    #[arg(long, value_name = "N", default_value_t = 2)]
    pub sync_concurrency: usize,
    /// The twin check: hold back a suggestion whose predicted time below
    /// 70 mg/dL rises by more than 1 point on the person's stored twin
    /// (on, off). Twins are first fitted by `abba twin fit`; the service
    /// refits a person's twin in the background when their log changes.
    #[arg(long, value_name = "ON|OFF", default_value = "on")]
    pub twin_check: String,
}

/// `--sync-every`: a duration of at least a minute.
fn sync_every(v: &str) -> Result<Duration> {
    let d: jiff::SignedDuration = v.parse().with_context(|| {
        format!("--sync-every \"{v}\": expected a duration such as 5m, 300s or 1h")
    })?;
    if d < jiff::SignedDuration::from_mins(1) {
        bail!("--sync-every {v}: at least 1m (Nightscout sites are shared; a CGM reads every 5 minutes)");
    }
    Duration::try_from(d).with_context(|| format!("--sync-every {v}"))
}

fn seconds(flag: &str, v: f64) -> Result<Duration> {
    if !(v.is_finite() && v > 0.0 && v <= 86_400.0) {
        bail!("--{flag}: expected seconds in (0, 86400], got {v}");
    }
    Ok(Duration::from_secs_f64(v))
}

fn count<T: PartialOrd + Default + std::fmt::Display + Copy>(flag: &str, v: T) -> Result<T> {
    if v <= T::default() {
        bail!("--{flag}: expected at least 1, got {v}");
    }
    Ok(v)
}

/// Checks `--public-url`: http:// or https:// and a host, no path, query
/// or spaces; a trailing slash is dropped.
fn public_url(text: &str) -> Result<String> {
    let t = text.trim().trim_end_matches('/');
    let rest = t
        .strip_prefix("https://")
        .or_else(|| t.strip_prefix("http://"))
        .ok_or_else(|| anyhow::anyhow!("--public-url {text}: expected http:// or https:// and a host, for example https://abba.clinic.example"))?;
    if rest.is_empty()
        || rest
            .chars()
            .any(|c| c.is_whitespace() || c.is_control() || matches!(c, '/' | '?' | '#' | '@'))
    {
        anyhow::bail!("--public-url {text}: expected a scheme and a host (and port), nothing after them, for example https://abba.clinic.example");
    }
    Ok(t.to_string())
}

impl ServeArgs {
    /// The service's settings, each checked.
    pub fn settings(&self) -> Result<ServeSettings> {
        let d = StoreSettings::default();
        Ok(ServeSettings {
            header_timeout: seconds("header-timeout", self.header_timeout)?,
            body_timeout: seconds("body-timeout", self.body_timeout)?,
            request_timeout: seconds("request-timeout", self.request_timeout)?,
            write_timeout: seconds("write-timeout", self.write_timeout)?,
            max_connections: count("max-connections", self.max_connections)?,
            max_connections_per_client: count(
                "max-connections-per-client",
                self.max_connections_per_client,
            )?,
            max_in_flight: count("max-in-flight", self.max_in_flight)?,
            max_in_flight_per_client: count(
                "max-in-flight-per-client",
                self.max_in_flight_per_client,
            )?,
            max_in_flight_per_token: count(
                "max-in-flight-per-token",
                self.max_in_flight_per_token,
            )?,
            behind_proxy: self.behind_proxy,
            shutdown_grace: seconds("shutdown-grace", self.shutdown_grace)?,
            store: StoreSettings {
                connections: count("connections", self.connections)?,
                busy_timeout: seconds("busy-timeout", self.busy_timeout)?,
                cache_persons: count("cache-persons", self.cache_persons)?,
                cache_events: count("cache-events", self.cache_events)?,
                cache_idle: seconds("cache-idle", self.cache_idle)?,
                auth_failures: count("auth-failures", self.auth_failures)?,
                public_url: self.public_url.as_deref().map(public_url).transpose()?,
                ..d
            },
        })
    }
}

/// The target of what `abba serve` says on stdout (its address, the
/// notice, its stop); every other event goes to stderr.
const OUT: &str = "abba::serve";

/// Logs through `tracing`: [`OUT`]'s lines to stdout as plain lines,
/// everything else to stderr (`RUST_LOG` chooses what, default info).
/// Neither writer's failure (a closed pipe) is an error: the service
/// never stops because nobody reads its output.
fn init_logging() {
    use tracing_subscriber::filter::filter_fn;
    use tracing_subscriber::prelude::*;
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new("info"));
    let out = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stdout)
        .without_time()
        .with_level(false)
        .with_target(false)
        .with_ansi(false)
        .log_internal_errors(false)
        .with_filter(filter_fn(|m| m.target() == OUT));
    let err = tracing_subscriber::fmt::layer()
        .with_writer(std::io::stderr)
        .with_ansi(false)
        .log_internal_errors(false)
        .with_filter(filter)
        .with_filter(filter_fn(|m| m.target() != OUT));
    // A second call (tests in one process) keeps the first subscriber.
    let _ = tracing_subscriber::registry()
        .with(out)
        .with(err)
        .try_init();
}

/// Runs `abba serve` until SIGTERM or Ctrl-C. Its address and stop are
/// said on stdout, logs (tracing) go to stderr; the background syncs
/// start once it listens.
pub fn serve(a: ServeArgs) -> Result<()> {
    let settings = a.settings()?;
    let effects = abba_service::EffectSource {
        predictor: std::sync::Arc::new(crate::twin_effect::TwinPredictor::new(&a.db)),
        check: crate::twin_effect::twin_check(&a.twin_check)?,
    };
    let background = match &a.sync_every {
        Some(v) => Some(abba_nightscout::background::Background {
            every: sync_every(v)?,
            concurrency: count("sync-concurrency", a.sync_concurrency)?,
            sync: abba_nightscout::SyncOptions::default(),
        }),
        None => None,
    };
    init_logging();
    // One refit at a time, on its own thread: the person's twin after their
    // log changed (abba_service::refit).
    let refits = abba_service::RefitQueue::start(
        &a.db,
        std::sync::Arc::new(crate::twin_effect::TwinRefits::new(&a.db)),
    )
    .context("starting the twin refit worker")?;
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let syncing = std::sync::Mutex::new(None);
    let to_refit = refits.clone();
    let served = abba_service::serve_with_twins(
        &a.db,
        &a.listen,
        &settings,
        Some(effects),
        Some(refits.clone()),
        |addr| {
            tracing::info!(
                target: OUT,
                "abba serve: listening on http://{addr} (store {})",
                a.db.display()
            );
            tracing::info!(target: OUT, "{}", abba_api::NOTICE);
            // Whoever started us may wait for that line.
            let _ = std::io::stdout().flush();
            if let Some(bg) = background {
                let (db, stop) = (a.db.clone(), std::sync::Arc::clone(&stop));
                let t = std::thread::spawn(move || {
                    abba_nightscout::background::run_with(&db, &bg, &stop, &|person| {
                        to_refit.schedule(person);
                    })
                });
                if let Ok(mut g) = syncing.lock() {
                    *g = Some(t);
                }
            }
        },
    )
    .with_context(|| format!("serving {}", a.db.display()));
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    refits.stop();
    if let Some(t) = syncing.lock().ok().and_then(|mut g| g.take()) {
        let _ = t.join();
    }
    served?;
    tracing::info!(target: OUT, "abba serve: stopped");
    Ok(())
}

/// Arguments of `abba token`.
#[derive(clap::Args, Debug)]
pub struct TokenArgs {
    /// The store: a file (created if missing), or a postgres:// URL.
    #[arg(long, value_name = "FILE")]
    pub db: PathBuf,
    /// A clinic (admin) token: creates persons, sets bounds, issues tokens.
    #[arg(long)]
    pub admin: bool,
    /// A token for this person only.
    #[arg(long, value_name = "NAME", conflicts_with = "admin")]
    pub person: Option<String>,
    /// Instead of a token, a one-time sign-in link for the web pages
    /// (15 minutes, works once): `<base-url>/signin/<secret>`.
    #[arg(long)]
    pub signin: bool,
    /// Where the service is reached (`https://abba.example.org`); without
    /// it the link is the path `/signin/<secret>`.
    #[arg(long, value_name = "URL", requires = "signin")]
    pub base_url: Option<String>,
}

/// Runs `abba token`: prints the token once (only its hash is stored).
pub fn token(a: TokenArgs) -> Result<()> {
    if a.signin {
        let secret = match (&a.person, a.admin) {
            (Some(name), false) => abba_service::new_signin_link(&a.db, Some(name))?,
            (None, true) => abba_service::new_signin_link(&a.db, None)?,
            _ => bail!("say whose sign-in link: --admin or --person NAME"),
        };
        let base = a.base_url.as_deref().unwrap_or("").trim_end_matches('/');
        println!("{base}/signin/{secret}");
        eprintln!(
            "a one-time sign-in link: it works once, for 15 minutes, and is shown only now (the store keeps its SHA-256). abba is research software, not a medical device."
        );
        return Ok(());
    }
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
