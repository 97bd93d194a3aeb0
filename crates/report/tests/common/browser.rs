//! Opens a page in real headless Chromium (Debian's `chromium` package):
//! records the console messages, the document's scroll and client widths
//! at A4 width (794 CSS px), a screenshot, and the smallest text of any
//! figure as printed on A4 (the page laid out at A4's text width). Used by the HTML tests of
//! abba-report and abba-trial (`#[path]`-included there).
//!
//! Without a browser the tests skip with a message, except in CI
//! (`CI=true`), where a missing browser is a failure (`.ci/run` installs it).

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::path::{Path, PathBuf};
use std::process::Command;

/// A4 width at 96 CSS px per inch (210 mm).
pub const A4_WIDTH_PX: u32 = 794;
/// A4 height at 96 CSS px per inch (297 mm).
pub const A4_HEIGHT_PX: u32 = 1123;

/// What the browser saw.
#[derive(Debug)]
pub struct Rendered {
    /// `document.documentElement.scrollWidth`.
    pub scroll_width: u32,
    /// `document.documentElement.clientWidth`.
    pub client_width: u32,
    /// Console messages and page errors (the browser's log lines).
    pub console: Vec<String>,
    /// The smallest figure text as printed on A4 (pt), with its text;
    /// none when the page has no figure text.
    pub smallest_figure_text: Option<(f64, String)>,
}

/// A4's text width (210 mm less the report's two 12 mm print margins), in
/// CSS px: the width the page's print style lays the content out at.
pub const A4_TEXT_WIDTH_PX: f64 = (210.0 - 2.0 * 12.0) / 25.4 * 96.0;

/// The smallest text a figure may print at (pt).
pub const MIN_FIGURE_TEXT_PT: f64 = 9.0;

/// The browser binary, or `None` (after saying so) when it is absent
/// outside CI.
pub fn chromium() -> Option<PathBuf> {
    for name in ["chromium", "chromium-browser", "google-chrome"] {
        if Command::new(name)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
        {
            return Some(PathBuf::from(name));
        }
    }
    assert!(
        std::env::var("CI").as_deref() != Ok("true"),
        "CI=true but no chromium is installed (.ci/run installs Debian's chromium package)"
    );
    eprintln!("SKIPPED: browser test, chromium is not installed (apt-get install chromium)");
    None
}

fn base_args(profile: &Path) -> Vec<String> {
    [
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--disable-quic",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--hide-scrollbars",
        "--enable-logging=stderr",
        "--v=0",
    ]
    .iter()
    .map(|s| (*s).to_string())
    .chain([
        format!("--user-data-dir={}", profile.display()),
        format!("--window-size={A4_WIDTH_PX},{A4_HEIGHT_PX}"),
    ])
    .collect()
}

fn console_lines(stderr: &[u8]) -> Vec<String> {
    String::from_utf8_lossy(stderr)
        .lines()
        .filter(|l| l.contains("CONSOLE") || l.contains("Uncaught") || l.contains(":ERROR:CONSOLE"))
        .map(str::to_string)
        .collect()
}

/// Opens `page` at A4 width: a screenshot to `screenshot`, then the widths
/// measured on a probe copy of the page (the page itself has no script; the
/// probe adds one line that writes the widths into the DOM, read back with
/// `--dump-dom`).
pub fn open_at_a4(browser: &Path, page: &Path, screenshot: &Path) -> Rendered {
    let work = page.with_extension("browser");
    let _ = std::fs::remove_dir_all(&work);
    std::fs::create_dir_all(&work).unwrap();
    let url = |p: &Path| format!("file://{}", std::fs::canonicalize(p).unwrap().display());

    let shot = Command::new(browser)
        .args(base_args(&work.join("profile-shot")))
        .arg(format!("--screenshot={}", screenshot.display()))
        .arg(url(page))
        .output()
        .unwrap();
    assert!(
        shot.status.success(),
        "chromium --screenshot failed: {}",
        String::from_utf8_lossy(&shot.stderr)
    );
    assert!(
        screenshot.metadata().unwrap().len() > 1000,
        "empty screenshot"
    );
    let mut console = console_lines(&shot.stderr);

    let html = std::fs::read_to_string(page).unwrap();
    let probe_script = "<script>var e=document.documentElement;\
        e.setAttribute('data-scroll-width',String(e.scrollWidth));\
        e.setAttribute('data-client-width',String(e.clientWidth));</script></body>";
    let probe = work.join("probe.html");
    std::fs::write(&probe, html.replacen("</body>", probe_script, 1)).unwrap();
    let (dom, more) = dump_dom(browser, &work.join("profile-dom"), &probe);
    console.extend(more);
    let attr = |name: &str| -> u32 { dom_attr(&dom, name).parse().unwrap() };
    let scroll_width = attr("data-scroll-width");
    let client_width = attr("data-client-width");
    let (smallest_figure_text, more) = smallest_figure_text(browser, &work, &html);
    console.extend(more);
    Rendered {
        scroll_width,
        client_width,
        console,
        smallest_figure_text,
    }
}

/// The page laid out as printed on A4 (its content exactly
/// [`A4_TEXT_WIDTH_PX`] wide, as under the print style's 12 mm margins):
/// the smallest rendered size of any `<text>` of an inline SVG, in pt
/// (its font size times the SVG's scale to the page), and the browser's
/// console lines.
fn smallest_figure_text(
    browser: &Path,
    work: &Path,
    html: &str,
) -> (Option<(f64, String)>, Vec<String>) {
    let style = format!(
        "<style>body{{max-width:none!important;width:{A4_TEXT_WIDTH_PX:.2}px!important;\
         padding:0!important;margin:0!important}}</style></head>"
    );
    let script = "<script>var e=document.documentElement,min=-1,what='';\
        document.querySelectorAll('svg text').forEach(function(t){\
        var m=t.getScreenCTM();if(!m||!t.getClientRects().length)return;\
        var px=parseFloat(getComputedStyle(t).fontSize)*Math.sqrt(m.a*m.a+m.b*m.b);\
        if(min<0||px<min){min=px;what=t.textContent;}});\
        e.setAttribute('data-min-text-px',String(min));\
        e.setAttribute('data-min-text',what.replace(/[\"<>&]/g,' '));</script></body>";
    let probe = work.join("print-probe.html");
    std::fs::write(
        &probe,
        html.replacen("</head>", &style, 1)
            .replacen("</body>", script, 1),
    )
    .unwrap();
    let (dom, console) = dump_dom(browser, &work.join("profile-print"), &probe);
    let attr = |name: &str| dom_attr(&dom, name);
    let px: f64 = attr("data-min-text-px").parse().unwrap();
    let smallest = (px >= 0.0).then(|| (px * 0.75, attr("data-min-text")));
    (smallest, console)
}

/// The DOM of `page` after its scripts ran (`--dump-dom`), and the
/// browser's console lines.
fn dump_dom(browser: &Path, profile: &Path, page: &Path) -> (String, Vec<String>) {
    let url = format!("file://{}", std::fs::canonicalize(page).unwrap().display());
    let dump = Command::new(browser)
        .args(base_args(profile))
        .arg("--dump-dom")
        .arg(url)
        .output()
        .unwrap();
    assert!(
        dump.status.success(),
        "chromium --dump-dom failed: {}",
        String::from_utf8_lossy(&dump.stderr)
    );
    (
        String::from_utf8_lossy(&dump.stdout).into_owned(),
        console_lines(&dump.stderr),
    )
}

/// The value of the attribute `name` (the first one) in a dumped DOM.
fn dom_attr(dom: &str, name: &str) -> String {
    let key = format!("{name}=\"");
    let i = dom
        .find(&key)
        .unwrap_or_else(|| panic!("{name} not in the dumped DOM"))
        + key.len();
    dom[i..dom[i..].find('"').unwrap() + i].to_string()
}

/// Opens the page and asserts: no console message, no horizontal overflow
/// at A4 width, no figure text below 9 pt as printed on A4. Returns the
/// screenshot's path (a test output under target/).
pub fn assert_renders_at_a4(page: &Path) -> Option<PathBuf> {
    let browser = chromium()?;
    let screenshot = page.with_extension("a4.png");
    let r = open_at_a4(&browser, page, &screenshot);
    assert!(
        r.console.is_empty(),
        "console messages for {}:\n{}",
        page.display(),
        r.console.join("\n")
    );
    assert!(
        r.client_width > 0 && r.client_width <= A4_WIDTH_PX,
        "viewport {} px, expected at most {A4_WIDTH_PX}",
        r.client_width
    );
    assert!(
        r.scroll_width <= r.client_width,
        "{} overflows at A4 width: scrollWidth {} > clientWidth {}",
        page.display(),
        r.scroll_width,
        r.client_width
    );
    let (pt, text) = r
        .smallest_figure_text
        .as_ref()
        .map_or((f64::INFINITY, ""), |(pt, text)| (*pt, text.as_str()));
    eprintln!(
        "{}: smallest figure text {text:?} prints at {pt:.2} pt on A4",
        page.display()
    );
    assert!(
        pt >= MIN_FIGURE_TEXT_PT - 0.01, // (the browser's float rounding)
        "{}: the figure text {text:?} prints at {pt:.2} pt on A4 (at least {MIN_FIGURE_TEXT_PT})",
        page.display()
    );
    Some(screenshot)
}

/// Validates with HTML Tidy (the Debian `tidy` package) when it is there:
/// no errors and no warnings. In CI (`CI=true`) tidy must be installed.
pub fn validate_with_tidy(path: &Path) {
    let found = std::process::Command::new("tidy")
        .arg("-v")
        .output()
        .is_ok();
    if !found {
        assert!(
            std::env::var("CI").as_deref() != Ok("true"),
            "CI=true but the HTML validator `tidy` is not installed (.ci/run installs it)"
        );
        eprintln!("SKIPPED: HTML validation, `tidy` is not installed (apt-get install tidy)");
        return;
    }
    let out = std::process::Command::new("tidy")
        .args([
            "-errors",
            "-quiet",
            "--show-warnings",
            "yes",
            "--drop-empty-elements",
            "no",
        ])
        .arg(path)
        .output()
        .unwrap();
    let report = String::from_utf8_lossy(&out.stderr);
    assert!(
        report.trim().is_empty(),
        "tidy finds problems in {}:\n{report}",
        path.display()
    );
}
