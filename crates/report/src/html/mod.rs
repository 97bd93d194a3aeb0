//! The HTML pages: the trial report (`report.html` beside the other report
//! files, [`trial_page`]) and the person report ([`person`]). Each is one
//! self-contained file: inline CSS and SVG, no script, no font or image
//! fetched, printable on A4 and Letter.
//!
//! The pages are laid out by minijinja templates (`crates/report/templates/`,
//! compiled into the binary with `include_str!`): minijinja needs only
//! serde, escapes every value of an `.html` template by default, and keeps
//! the page structure in plain template files instead of strings glued in
//! code. Rust computes the numbers and draws the figures ([`svg`]); the
//! templates only place them.

pub mod person;
pub mod profile;
pub mod svg;
pub mod trial_page;

use minijinja::Environment;
use serde::Serialize;

use crate::error::ReportError;

/// The research-software notice every page carries.
pub const DISCLAIMER: &str = "abba is research software, not a medical device. Its suggestions \
     and this report are not medical advice: do not change insulin therapy without your \
     diabetes care team.";

/// The page style (inline in every page).
const CSS: &str = include_str!("../../templates/report.css");

/// The templates, by name.
const TEMPLATES: [(&str, &str); 4] = [
    ("base.html", include_str!("../../templates/base.html")),
    ("macros.html", include_str!("../../templates/macros.html")),
    ("person.html", include_str!("../../templates/person.html")),
    ("trial.html", include_str!("../../templates/trial.html")),
];

/// One row of a table, its cells as text (escaped by the template).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Row {
    /// The cells.
    pub cells: Vec<String>,
}

impl Row {
    /// A row from its cells.
    pub fn of<const N: usize>(cells: [&str; N]) -> Row {
        Row {
            cells: cells.iter().map(|c| (*c).to_string()).collect(),
        }
    }
}

/// A titled table another part of the trial can add to the trial page
/// (for example the W1 sensitivity block).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct HtmlSection {
    /// Section heading.
    pub title: String,
    /// A sentence saying what the table shows.
    pub note: String,
    /// Column headers.
    pub headers: Vec<String>,
    /// Rows.
    pub rows: Vec<Row>,
}

/// Renders template `name` with `ctx` (plus the style and the disclaimer).
pub(crate) fn render_page(
    name: &'static str,
    page: &'static str,
    ctx: minijinja::Value,
) -> Result<String, ReportError> {
    let err = |e: minijinja::Error| ReportError::Template {
        page,
        reason: format!("{e:#}"),
    };
    let mut env = Environment::new();
    // HTML escaping of the five characters that matter (minijinja's own
    // also escapes `/`, which would turn every "mg/dL" into "mg&#x2f;dL").
    env.set_formatter(|out, _state, value| {
        if value.is_none() || value.is_undefined() {
            return Ok(());
        }
        let text = value.to_string();
        if value.is_safe() {
            out.write_str(&text)?;
        } else {
            // A name read from an export with a right-to-left override
            // or a zero-width character is shown with its code point.
            out.write_str(&svg::esc(&abba_core::text::shown(&text)))?;
        }
        Ok(())
    });
    for (n, source) in TEMPLATES {
        env.add_template(n, source).map_err(err)?;
    }
    let ctx = minijinja::context! { css => CSS, disclaimer => DISCLAIMER, ..ctx };
    env.get_template(name)
        .map_err(err)?
        .render(ctx)
        .map_err(err)
}
