//! Real headless Chromium for the web tests: Debian's `chromedriver`
//! started on a free loopback port, one browser session driven with
//! fantoccini, and the checks every page must pass at a phone's and a
//! desktop's size (a screenshot kept under `target/web-screens/`, axe-core
//! run in the page, no console error or CSP violation, no horizontal
//! scroll on the phone).
//!
//! Without chromium, chromedriver or axe-core the tests say SKIPPED and
//! pass, except with `CI=true` or `ABBA_REQUIRE_BROWSER=1`, where a missing
//! tool is a failure (`.ci/run` installs them).
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use fantoccini::wd::WebDriverCompatibleCommand;
use fantoccini::{Client, ClientBuilder, Locator};
use serde_json::{json, Value};
use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

/// The phone (390 × 844 CSS px) and the desktop (1280 × 800).
pub const VIEWPORTS: [(u32, u32); 2] = [(390, 844), (1280, 800)];

/// Debian's browser and driver.
const CHROMIUM: &str = "/usr/bin/chromium";
const CHROMEDRIVER: &str = "/usr/bin/chromedriver";

/// The programs and the script the browser tests need.
#[derive(Debug, Clone)]
pub struct Tools {
    /// The browser.
    pub chromium: PathBuf,
    /// Its WebDriver server.
    pub chromedriver: PathBuf,
    /// axe-core's `axe.min.js`.
    pub axe_js: PathBuf,
}

/// The workspace's root (two folders above this crate).
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// The target folder the `abba` binary was built in.
pub fn target_dir() -> PathBuf {
    Path::new(env!("CARGO_BIN_EXE_abba"))
        .parent()
        .and_then(Path::parent)
        .expect("the binary sits in target/<profile>/")
        .to_path_buf()
}

/// True when a missing tool must fail the test instead of skipping it.
pub fn browser_required() -> bool {
    std::env::var("CI").as_deref() == Ok("true")
        || std::env::var("ABBA_REQUIRE_BROWSER").as_deref() == Ok("1")
}

/// The tools, or `None` (after saying SKIPPED) when one is missing and
/// none is required.
pub fn tools() -> Option<Tools> {
    let axe_js = std::env::var_os("ABBA_AXE_JS").map_or_else(
        || workspace_root().join("target/npm/node_modules/axe-core/axe.min.js"),
        PathBuf::from,
    );
    let mut missing = Vec::new();
    for (path, what) in [
        (Path::new(CHROMIUM), "chromium (apt-get install chromium)"),
        (
            Path::new(CHROMEDRIVER),
            "chromedriver (apt-get install chromium-driver)",
        ),
        (
            axe_js.as_path(),
            "axe-core (npm install --no-save --prefix target/npm axe-core@4, or ABBA_AXE_JS=FILE)",
        ),
    ] {
        if !path.is_file() {
            missing.push(format!("{what}: no {}", path.display()));
        }
    }
    if missing.is_empty() {
        return Some(Tools {
            chromium: CHROMIUM.into(),
            chromedriver: CHROMEDRIVER.into(),
            axe_js,
        });
    }
    assert!(
        !browser_required(),
        "the browser test is required (CI=true or ABBA_REQUIRE_BROWSER=1) but tools are missing:\n  {}",
        missing.join("\n  ")
    );
    eprintln!(
        "SKIPPED: browser test, missing:\n  {}",
        missing.join("\n  ")
    );
    None
}

fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free loopback port")
}

/// True once `GET /status` of the driver answers that it is ready.
fn driver_ready(port: u16) -> bool {
    let Ok(mut s) = TcpStream::connect(("127.0.0.1", port)) else {
        return false;
    };
    let _ = s.set_read_timeout(Some(Duration::from_secs(2)));
    if write!(
        s,
        "GET /status HTTP/1.1\r\nHost: 127.0.0.1\r\nConnection: close\r\n\r\n"
    )
    .is_err()
    {
        return false;
    }
    let mut out = String::new();
    let _ = s.read_to_string(&mut out);
    out.contains("\"ready\":true") || out.contains("\"ready\": true")
}

/// A running chromedriver, killed on drop.
pub struct Driver {
    child: Child,
    /// Its URL (`http://127.0.0.1:PORT`).
    pub url: String,
    /// Its log file.
    pub log: PathBuf,
}

impl Driver {
    /// Starts chromedriver on a free loopback port (it accepts local
    /// connections only) and waits until it is ready.
    pub fn start(tools: &Tools, dir: &Path) -> Driver {
        let started = Instant::now();
        let log = dir.join("chromedriver.log");
        loop {
            let port = free_port();
            let mut child = Command::new(&tools.chromedriver)
                .arg(format!("--port={port}"))
                .arg(format!("--log-path={}", log.display()))
                .stdin(Stdio::null())
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .spawn()
                .expect("chromedriver starts");
            let wait = Instant::now();
            while wait.elapsed() < Duration::from_secs(10) {
                if driver_ready(port) {
                    return Driver {
                        child,
                        url: format!("http://127.0.0.1:{port}"),
                        log,
                    };
                }
                if child.try_wait().ok().flatten().is_some() {
                    break; // exited: the port was taken meanwhile?
                }
                std::thread::sleep(Duration::from_millis(50));
            }
            let _ = child.kill();
            let _ = child.wait();
            assert!(
                started.elapsed() < Duration::from_secs(30),
                "chromedriver did not become ready: {}",
                std::fs::read_to_string(&log).unwrap_or_default()
            );
        }
    }
}

impl Drop for Driver {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// chromedriver's browser log (`POST /session/{id}/se/log`): the console
/// messages, page errors and CSP violations since the last call.
#[derive(Debug)]
struct BrowserLog;

impl WebDriverCompatibleCommand for BrowserLog {
    fn endpoint(
        &self,
        base_url: &url::Url,
        session_id: Option<&str>,
    ) -> Result<url::Url, url::ParseError> {
        base_url.join(&format!("session/{}/se/log", session_id.unwrap_or("")))
    }

    fn method_and_body(&self, _request_url: &url::Url) -> (http::Method, Option<String>) {
        (
            http::Method::POST,
            Some(json!({"type": "browser"}).to_string()),
        )
    }
}

/// What went wrong on a page: the rule, the impact and where.
#[derive(Debug, Clone, serde::Deserialize)]
pub struct AxeViolation {
    /// axe's rule id.
    pub id: String,
    /// `minor`, `moderate`, `serious` or `critical`.
    pub impact: Option<String>,
    /// What the rule asks.
    pub help: String,
    /// The elements (CSS selectors) that break it.
    pub nodes: Vec<String>,
}

/// Runs axe in the page and hands its violations (rule, impact, the first
/// elements) to WebDriver's callback as JSON text.
const AXE_RUN: &str = r#"
const done = arguments[arguments.length - 1];
axe.run(document, { resultTypes: ['violations'] }).then(function (r) {
  done(JSON.stringify(r.violations.map(function (v) {
    return { id: v.id, impact: v.impact, help: v.help,
             nodes: v.nodes.slice(0, 8).map(function (n) { return n.target.join(' '); }) };
  })));
}).catch(function (e) { done('axe failed: ' + e); });
"#;

/// One browser session (one profile), the page checks and what they found.
pub struct Browser {
    /// The WebDriver session.
    pub client: Client,
    axe: String,
    screens: PathBuf,
    /// The service's base URL.
    pub base: String,
    /// Every failed page check so far (reported together at the end).
    pub problems: Vec<String>,
    /// The pages checked, by name.
    pub checked: Vec<String>,
    /// The window's size less its viewport's, as last measured.
    frame: std::sync::Mutex<(i64, i64)>,
}

impl Browser {
    /// Opens headless Chromium through `driver` with a fresh profile in
    /// `dir`, for the service at `base`.
    pub async fn open(tools: &Tools, driver: &Driver, dir: &Path, base: &str) -> Browser {
        Self::open_with(tools, driver, dir, base, true).await
    }

    /// [`Browser::open`] with JavaScript off (Chromium's content setting)
    /// when `js` is false: the pages must work as plain HTML; the page
    /// checks (axe, sizes) need JavaScript and are not for such a browser.
    pub async fn open_with(
        tools: &Tools,
        driver: &Driver,
        dir: &Path,
        base: &str,
        js: bool,
    ) -> Browser {
        let profile = dir.join(if js {
            "chromium-profile"
        } else {
            "chromium-profile-no-js"
        });
        std::fs::create_dir_all(&profile).unwrap();
        let prefs = if js {
            json!({})
        } else {
            json!({"profile.managed_default_content_settings.javascript": 2})
        };
        let caps = json!({
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": tools.chromium,
                "args": [
                    "--headless",
                    "--no-sandbox",
                    "--disable-gpu",
                    "--disable-quic",
                    "--no-first-run",
                    "--disable-background-networking",
                    "--disable-component-update",
                    "--disable-sync",
                    format!("--user-data-dir={}", profile.display()),
                ],
                "prefs": prefs,
            },
            "goog:loggingPrefs": {"browser": "ALL"},
        });
        let Value::Object(caps) = caps else {
            unreachable!()
        };
        let connector = hyper_util::client::legacy::connect::HttpConnector::new();
        let client = ClientBuilder::new(connector)
            .capabilities(caps)
            .connect(&driver.url)
            .await
            .unwrap_or_else(|e| {
                panic!(
                    "no browser session through chromedriver: {e}\n{}",
                    std::fs::read_to_string(&driver.log).unwrap_or_default()
                )
            });
        let screens = target_dir().join("web-screens");
        std::fs::create_dir_all(&screens).unwrap();
        Browser {
            client,
            axe: std::fs::read_to_string(&tools.axe_js).unwrap(),
            screens,
            base: base.trim_end_matches('/').to_string(),
            problems: Vec::new(),
            checked: Vec::new(),
            frame: std::sync::Mutex::new((0, 0)),
        }
    }

    /// The folder screenshots go to.
    pub fn screens(&self) -> &Path {
        &self.screens
    }

    /// `base` + `path` (a full URL is kept).
    pub fn url(&self, path: &str) -> String {
        if path.starts_with("http://") || path.starts_with("https://") {
            path.to_string()
        } else {
            format!("{}{path}", self.base)
        }
    }

    /// Opens `path` (or a full URL) and waits for the page.
    pub async fn goto(&self, path: &str) {
        let url = self.url(path);
        self.client
            .goto(&url)
            .await
            .unwrap_or_else(|e| panic!("GET {url}: {e}"));
    }

    /// The current path (with the query).
    pub async fn path(&self) -> String {
        let u = self.client.current_url().await.unwrap();
        match u.query() {
            Some(q) => format!("{}?{q}", u.path()),
            None => u.path().to_string(),
        }
    }

    /// The element `css`, or a failure naming it and the page.
    pub async fn find(&self, css: &str) -> fantoccini::elements::Element {
        match self.client.find(Locator::Css(css)).await {
            Ok(e) => e,
            Err(e) => panic!(
                "no `{css}` on {}: {e}\npage text:\n{}",
                self.path().await,
                self.body_text().await
            ),
        }
    }

    /// Every element matching `css`.
    pub async fn find_all(&self, css: &str) -> Vec<fantoccini::elements::Element> {
        self.client.find_all(Locator::Css(css)).await.unwrap()
    }

    /// True when an element matches `css`.
    pub async fn exists(&self, css: &str) -> bool {
        !self.find_all(css).await.is_empty()
    }

    /// The visible text of `css`, trimmed.
    pub async fn text(&self, css: &str) -> String {
        self.find(css)
            .await
            .text()
            .await
            .unwrap()
            .trim()
            .to_string()
    }

    /// The visible text of the whole page.
    pub async fn body_text(&self) -> String {
        match self.client.find(Locator::Css("body")).await {
            Ok(b) => b.text().await.unwrap_or_default(),
            Err(_) => String::new(),
        }
    }

    /// An attribute of `css`.
    pub async fn attr(&self, css: &str, name: &str) -> Option<String> {
        self.find(css).await.attr(name).await.unwrap()
    }

    /// Types `value` into the field `css` (cleared first).
    pub async fn fill(&self, css: &str, value: &str) {
        let e = self.find(css).await;
        e.clear().await.unwrap();
        e.send_keys(value).await.unwrap();
    }

    /// Chooses the option `value` of the select `css`.
    pub async fn select(&self, css: &str, value: &str) {
        self.find(css)
            .await
            .select_by_value(value)
            .await
            .unwrap_or_else(|e| panic!("select `{css}` = {value}: {e}"));
    }

    /// Gives the file input `css` the file `path` (as a person picking it).
    pub async fn attach(&self, css: &str, path: &Path) {
        let abs = std::fs::canonicalize(path).unwrap();
        self.find(css)
            .await
            .send_keys(&abs.display().to_string())
            .await
            .unwrap();
    }

    /// Clicks `css` and waits until the page it submits or follows has
    /// replaced the current one.
    pub async fn click_and_wait(&self, css: &str) {
        self.client
            .execute("window.__abbaOldPage = true;", vec![])
            .await
            .unwrap();
        self.find(css).await.click().await.unwrap();
        let started = Instant::now();
        loop {
            let fresh = self
                .client
                .execute(
                    "return window.__abbaOldPage !== true && document.readyState === 'complete';",
                    vec![],
                )
                .await
                .ok()
                .and_then(|v| v.as_bool())
                .unwrap_or(false);
            if fresh {
                return;
            }
            assert!(
                started.elapsed() < Duration::from_secs(30),
                "clicking `{css}` on {} led to no new page",
                self.path().await
            );
            tokio::time::sleep(Duration::from_millis(25)).await;
        }
    }

    /// Clicks the submit button of the form `form` (its first one).
    pub async fn submit(&self, form: &str) {
        self.click_and_wait(&format!(
            "{form} button[type=submit], {form} input[type=submit], {form} button:not([type])"
        ))
        .await;
    }

    /// The viewport's size (`innerWidth`, `innerHeight`).
    async fn viewport(&self) -> (i64, i64) {
        let v = self
            .client
            .execute("return [window.innerWidth, window.innerHeight];", vec![])
            .await
            .unwrap();
        (v[0].as_i64().unwrap_or(0), v[1].as_i64().unwrap_or(0))
    }

    /// Makes the page's viewport exactly `width` × `height` CSS px (the
    /// window is larger by the headless browser's own frame, measured once
    /// and kept). Chromium resizes a window after it answers the WebDriver
    /// command, so a size that is not the one wanted is read until it
    /// settles (on a loaded machine the first read can still show the old
    /// height) before the frame is measured from it.
    pub async fn set_viewport(&self, width: u32, height: u32) {
        let want = (i64::from(width), i64::from(height));
        let mut tries = 0;
        loop {
            let frame = *self.frame.lock().unwrap();
            let (w, h) = (want.0 + frame.0, want.1 + frame.1);
            let before = self.viewport().await;
            self.client
                .set_window_size(w as u32, h as u32)
                .await
                .unwrap();
            let seen = self.settled_viewport(want, before).await;
            if seen == want {
                return;
            }
            tries += 1;
            assert!(
                tries < 4,
                "cannot make the viewport {width}x{height}: it is {seen:?}"
            );
            *self.frame.lock().unwrap() = (w - seen.0, h - seen.1);
        }
    }

    /// The viewport once it is `want`, or once it has left `before` (its
    /// size before the resize) and read the same for 200 ms; at most 5 s.
    async fn settled_viewport(&self, want: (i64, i64), before: (i64, i64)) -> (i64, i64) {
        let start = Instant::now();
        let mut last = self.viewport().await;
        let mut same_since = Instant::now();
        while last != want && start.elapsed() < Duration::from_secs(5) {
            tokio::time::sleep(Duration::from_millis(25)).await;
            let now = self.viewport().await;
            if now != last {
                last = now;
                same_since = Instant::now();
            } else if last != before && same_since.elapsed() >= Duration::from_millis(200) {
                break;
            }
        }
        last
    }

    /// The browser's log since the last call: (level, message).
    pub async fn console(&self) -> Vec<(String, String)> {
        let v = self
            .client
            .issue_cmd(BrowserLog)
            .await
            .unwrap_or_else(|e| panic!("chromedriver's browser log: {e}"));
        v.as_array()
            .map(|a| {
                a.iter()
                    .map(|e| {
                        (
                            e["level"].as_str().unwrap_or("").to_string(),
                            e["message"].as_str().unwrap_or("").to_string(),
                        )
                    })
                    .collect()
            })
            .unwrap_or_default()
    }

    /// Runs axe-core in the current page: its violations.
    pub async fn axe(&self) -> Vec<AxeViolation> {
        let loaded = self
            .client
            .execute("return typeof window.axe === 'object';", vec![])
            .await
            .unwrap();
        if loaded != Value::Bool(true) {
            self.client.execute(&self.axe, vec![]).await.unwrap();
        }
        let out = self
            .client
            .execute_async(AXE_RUN, vec![])
            .await
            .unwrap_or_else(|e| panic!("axe.run: {e}"));
        let text = out.as_str().unwrap_or_default();
        serde_json::from_str(text).unwrap_or_else(|e| panic!("axe's answer {text:?}: {e}"))
    }

    /// The checks every page must pass, at each of [`VIEWPORTS`]: a
    /// screenshot `target/web-screens/NAME-WxH.png`; no axe violation of
    /// any impact; no SEVERE console message (a page answered with
    /// `status` other than 200 may log that status, nothing else); no
    /// horizontal scroll at 320 px, 390 px or 1280 px, and at 320 px no
    /// caption off the screen nor a chart label under 9 px
    /// ([`Browser::unreadable_at_320`]); the landmarks and
    /// the notice of the contract (`app_page`: every page but the printable
    /// report). Problems are collected in [`Browser::problems`].
    pub async fn check_page(&mut self, name: &str, status: u16, app_page: bool) {
        let path = self.path().await;
        let mut found = Vec::new();
        let severe: Vec<String> = self
            .console()
            .await
            .into_iter()
            .filter(|(level, msg)| {
                level == "SEVERE"
                    && !(status != 200
                        && msg.contains(&path)
                        && msg.contains(&format!("status of {status}")))
            })
            .map(|(_, msg)| msg)
            .collect();
        if !severe.is_empty() {
            found.push(format!(
                "console errors:\n      {}",
                severe.join("\n      ")
            ));
        }
        if app_page {
            for css in ["main#main", "nav", "#notice", "a[href='#main']"] {
                if !self.exists(css).await {
                    found.push(format!("no `{css}`"));
                }
            }
        }
        let body = self.body_text().await;
        if !body.contains("research software, not a medical device") {
            found.push("no \"research software, not a medical device\" notice".into());
        }
        // The narrowest phone (320 CSS px, also 1280 px at 400 % zoom):
        // no horizontal scroll either.
        self.set_viewport(320, 640).await;
        if let Some((sw, cw)) = self.sideways().await {
            found.push(format!(
                "320x640: horizontal scroll (scrollWidth {sw} > clientWidth {cw})"
            ));
        }
        found.extend(
            self.unreadable_at_320()
                .await
                .into_iter()
                .map(|f| format!("320x640: {f}")),
        );
        for (w, h) in VIEWPORTS {
            self.set_viewport(w, h).await;
            self.client
                .execute("window.scrollTo(0, 0);", vec![])
                .await
                .unwrap();
            let png = self.client.screenshot().await.unwrap();
            let file = self.screens.join(format!("{name}-{w}x{h}.png"));
            std::fs::write(&file, &png).unwrap();
            if png.len() < 2000 {
                found.push(format!("{w}x{h}: an empty screenshot"));
            }
            if let Some((sw, cw)) = self.sideways().await {
                found.push(format!(
                    "{w}x{h}: horizontal scroll (scrollWidth {sw} > clientWidth {cw})"
                ));
            }
            for v in self.axe().await {
                let impact = v.impact.clone().unwrap_or_default();
                let line = format!(
                    "{w}x{h}: axe {} ({impact}): {} at {}",
                    v.id,
                    v.help,
                    v.nodes.join(" | ")
                );
                // Every impact, minor and moderate too (a best practice
                // broken is still broken).
                found.push(line);
            }
        }
        let severe: Vec<String> = self
            .console()
            .await
            .into_iter()
            .filter(|(level, _)| level == "SEVERE")
            .map(|(_, msg)| msg)
            .collect();
        if !severe.is_empty() {
            found.push(format!(
                "console errors while resizing:\n      {}",
                severe.join("\n      ")
            ));
        }
        for f in found {
            self.problems.push(format!("{name} ({path}): {f}"));
        }
        self.checked.push(name.to_string());
    }

    /// What a phone's reader cannot read although the page does not
    /// scroll sideways: a table's caption running off the screen inside
    /// its scrolling region (a caption is as wide as its table), and the
    /// Glucose chart's labels drawn under 9 px high or over one another
    /// (the chart is 720 units wide, shrunk to the screen).
    pub async fn unreadable_at_320(&self) -> Vec<String> {
        let v = self
            .client
            .execute(
                r#"const out = [];
                 for (const c of document.querySelectorAll('caption')) {
                   const r = c.getBoundingClientRect();
                   if (r.width > 0 && (r.left < -1 || r.right > window.innerWidth + 1)) {
                     out.push('caption "' + c.textContent.slice(0, 40) + '" spans x ' + Math.round(r.left) + '-' + Math.round(r.right));
                   }
                 }
                 const shown = Array.from(document.querySelectorAll('#glucose-chart text'))
                   .filter((t) => t.getClientRects().length > 0);
                 for (const [i, t] of shown.entries()) {
                   const r = t.getBoundingClientRect();
                   if (r.height < 9) { out.push('chart label "' + t.textContent + '" ' + r.height.toFixed(1) + ' px high'); }
                   for (const u of shown.slice(i + 1)) {
                     const q = u.getBoundingClientRect();
                     if (r.left < q.right && q.left < r.right && r.top < q.bottom && q.top < r.bottom) {
                       out.push('chart labels "' + t.textContent + '" and "' + u.textContent + '" overlap');
                     }
                   }
                 }
                 return out;"#,
                vec![],
            )
            .await
            .unwrap();
        v.as_array()
            .map(|a| {
                a.iter()
                    .filter_map(|x| x.as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default()
    }

    /// The page's width and the viewport's when the page is wider (it
    /// scrolls sideways); `None` when it fits.
    pub async fn sideways(&self) -> Option<(u64, u64)> {
        let v = self
            .client
            .execute(
                "const e = document.documentElement; return [e.scrollWidth, e.clientWidth];",
                vec![],
            )
            .await
            .unwrap();
        let (sw, cw) = (v[0].as_u64().unwrap_or(0), v[1].as_u64().unwrap_or(0));
        (sw > cw).then_some((sw, cw))
    }

    /// Fails with every problem the page checks found.
    pub fn assert_no_problems(&self) {
        assert!(
            self.problems.is_empty(),
            "{} problem(s) on the pages (screenshots in {}):\n  {}",
            self.problems.len(),
            self.screens.display(),
            self.problems.join("\n  ")
        );
    }

    /// Ends the session.
    pub async fn close(self) {
        let _ = self.client.close().await;
    }
}
