//! `abba report`: a person's AGP-style report as one self-contained HTML
//! page (and, with `--pdf`, a PDF printed by headless Chromium).
use std::path::{Path, PathBuf};
use std::process::Command;

use abba_core::units::GlucoseUnit;
use abba_report::html::person::person_report_html;
use anyhow::{bail, Context, Result};

/// Arguments of `abba report`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(flatten)]
    pub who: crate::store_args::PersonArgs,
    /// Days in the report, ending at the last day with data.
    #[arg(long, default_value_t = 14, value_name = "N")]
    pub days: u32,
    /// Glucose unit of the page: mg/dL or mmol/L [default: the person's unit]
    #[arg(long, value_name = "UNIT")]
    pub units: Option<GlucoseUnit>,
    /// The HTML file to write.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// Also print the page to PDF (same name, .pdf) with headless Chromium.
    #[arg(long)]
    pub pdf: bool,
    /// The twin check on the open suggestions (on, off), as `abba advise`.
    #[arg(long, value_name = "ON|OFF", default_value = "on")]
    pub twin_check: String,
}

/// Runs `abba report`.
pub fn run(a: Args) -> Result<()> {
    if !a.who.db.is_file() {
        bail!("--db {}: no such store file", a.who.db.display());
    }
    let check = crate::twin_effect::twin_check(&a.twin_check)?;
    let mut store = a.who.open()?;
    // The page, its reasons and notes in one unit: the person's unless asked.
    let unit = match a.units {
        Some(u) => u,
        None => store.person(&a.who.person)?.settings.units,
    };
    let mut input = abba_store::report::person_input(&mut store, &a.who.person, a.days, unit)?;
    // Each open suggestion's predicted effect on the person's twin.
    let twin = crate::twin_effect::TwinPredictor::new(&a.who.db);
    let advice = store.advise_with(
        &a.who.person,
        Some(abba_store::effect::Effects {
            predictor: &twin,
            check,
        }),
    )?;
    for s in &advice.settings {
        if let (Some(e), Some(v)) = (&s.effect, &s.latest) {
            let name = crate::advice_text::setting_name(s.setting).to_lowercase();
            let head = format!(
                "Open suggestion for the {name}, {:.3} -> {:.3} {}:",
                v.previous, v.suggested, s.unit
            );
            let lines = crate::advice_text::effect_lines(&name, s.unit, s.in_force, e, unit);
            input.notes.push(format!("{head} {}", lines.join(" ")));
        }
    }
    let html = person_report_html(&input)?;
    std::fs::write(&a.out, &html).with_context(|| format!("cannot write {}", a.out.display()))?;
    eprintln!(
        "abba report: {} ({} days, {} suggestions) written to {} ({} bytes)",
        a.who.person,
        input.days.len(),
        input.suggestions.len(),
        a.out.display(),
        html.len()
    );
    if a.pdf {
        let pdf = a.out.with_extension("pdf");
        print_pdf(&a.out, &pdf)?;
        eprintln!("abba report: PDF written to {}", pdf.display());
    }
    Ok(())
}

/// Prints `page` to `pdf` with Debian's chromium (headless, no network).
fn print_pdf(page: &Path, pdf: &Path) -> Result<()> {
    let browser = ["chromium", "chromium-browser", "google-chrome"]
        .into_iter()
        .find(|b| {
            Command::new(b)
                .arg("--version")
                .output()
                .is_ok_and(|o| o.status.success())
        })
        .context("--pdf needs Chromium (apt-get install chromium); the HTML page was written")?;
    let profile = std::env::temp_dir().join(format!("abba-pdf-{}", std::process::id()));
    let page = std::fs::canonicalize(page)?;
    let status = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--no-pdf-header-footer",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--print-to-pdf={}", pdf.display()))
        .arg(format!("file://{}", page.display()))
        .output()
        .context("running chromium")?;
    let _ = std::fs::remove_dir_all(&profile);
    if !status.status.success() || !pdf.is_file() {
        bail!(
            "chromium could not print {} to PDF: {}",
            page.display(),
            String::from_utf8_lossy(&status.stderr)
                .lines()
                .last()
                .unwrap_or("")
        );
    }
    Ok(())
}
