//! The real `abba serve` binary for tests: a fresh store with an admin
//! token, the server started on a free loopback port, killed with SIGKILL
//! and started again on the same port and store.
#![allow(dead_code)]

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The `abba` binary cargo built for these tests.
pub fn abba_bin() -> PathBuf {
    PathBuf::from(env!("CARGO_BIN_EXE_abba"))
}

/// A new admin token for the store `db` (`abba token --db DB --admin`).
pub fn admin_token(db: &Path) -> String {
    let out = Command::new(abba_bin())
        .args(["token", "--db"])
        .arg(db)
        .arg("--admin")
        .output()
        .expect("abba token runs");
    assert!(
        out.status.success(),
        "abba token failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let token = String::from_utf8(out.stdout).unwrap().trim().to_string();
    assert!(token.starts_with("abba_"), "token {token:?}");
    token
}

/// A running `abba serve`.
pub struct Server {
    db: PathBuf,
    child: Option<Child>,
    /// `127.0.0.1:PORT`.
    pub addr: String,
    /// Times started.
    pub starts: u32,
}

impl Server {
    /// Starts `abba serve --db DB --listen 127.0.0.1:0` and waits for the
    /// address it prints.
    pub fn start(db: &Path) -> Self {
        let mut s = Server {
            db: db.to_path_buf(),
            child: None,
            addr: "127.0.0.1:0".into(),
            starts: 0,
        };
        s.spawn();
        s
    }

    /// The base URL.
    pub fn url(&self) -> String {
        format!("http://{}", self.addr)
    }

    fn spawn(&mut self) {
        let started = Instant::now();
        loop {
            let mut child = Command::new(abba_bin())
                .args(["serve", "--db"])
                .arg(&self.db)
                .args(["--listen", &self.addr])
                .stdout(Stdio::piped())
                .stderr(Stdio::piped())
                .spawn()
                .expect("abba serve starts");
            let stdout = child.stdout.take().unwrap();
            let mut lines = BufReader::new(stdout).lines();
            let mut bound = None;
            for line in lines.by_ref() {
                let line = line.unwrap_or_default();
                if let Some(rest) = line.split("listening on http://").nth(1) {
                    bound = rest.split_whitespace().next().map(str::to_string);
                    break;
                }
            }
            // Keep draining the server's output so that it never blocks.
            std::thread::spawn(move || for _ in lines {});
            match bound {
                Some(addr) => {
                    self.addr = addr;
                    self.child = Some(child);
                    self.starts += 1;
                    return;
                }
                None => {
                    // It exited before binding (the port not free yet?).
                    let out = child.wait_with_output().unwrap();
                    assert!(
                        started.elapsed() < Duration::from_secs(20),
                        "abba serve did not start on {}: {}",
                        self.addr,
                        String::from_utf8_lossy(&out.stderr)
                    );
                    std::thread::sleep(Duration::from_millis(20));
                }
            }
        }
    }

    /// SIGKILL, and wait for the process to be gone.
    pub fn kill(&mut self) {
        if let Some(mut c) = self.child.take() {
            c.kill().unwrap();
            c.wait().unwrap();
        }
    }

    /// Starts again on the same port and store.
    pub fn restart(&mut self) {
        self.kill();
        self.spawn();
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        self.kill();
    }
}

/// A temporary directory removed on drop.
pub struct TempDir(pub PathBuf);

impl TempDir {
    /// A new empty directory under the target dir's tmp folder.
    pub fn new(tag: &str) -> Self {
        let p = std::env::temp_dir().join(format!("abba-{tag}-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// A CGM person made through the API (UTC, 1 U/h, 10 g/U at every meal;
/// `first_day` the service's default when `None`) and a token for them:
/// (person id, token).
pub fn new_cgm_person(
    admin: &abba_client::Client,
    name: &str,
    first_day: Option<&str>,
) -> (u64, String) {
    let p = admin
        .create_person(&abba_api::NewPersonBody {
            name: name.into(),
            tz: "UTC".into(),
            mode: abba_api::Mode::Cgm,
            first_day: first_day.map(Into::into),
            start: abba_api::TherapyBody {
                basal_units_per_hour: 1.0,
                carb_ratio_g_per_unit: [10.0; 3],
            },
            bounds: None,
            pump_steps: None,
            continuous_values: false,
            min_data: None,
            advisor: None,
            age_group: None,
        })
        .expect("the admin creates a person");
    let token = admin
        .issue_token(p.id)
        .expect("a token for the person")
        .token;
    (p.id, token)
}
