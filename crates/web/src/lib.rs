//! abba-web: the HTML of abba's pages, the person's app and the clinic's
//! page (issue 24), with no HTTP in it: abba-service owns the routes,
//! sessions and the store; this crate turns page models into HTML.
//!
//! - Templates are the minijinja files of `templates/`, embedded by
//!   `build.rs` (minijinja-embed: a new page is one more file); every
//!   template name ends in `.html`, so every value is HTML-escaped unless
//!   a template says otherwise (only the QR code's SVG, made by [`qr`]
//!   with its one text escaped there): a person named
//!   `<script>alert(1)</script>` is shown as those characters. Values are
//!   data, never templates: `{{ 7*7 }}` in a name stays text.
//! - Every English text is in [`texts`], so a translation is one more
//!   table.
//! - [`qr`] draws a QR code (encoded by the `qrcode` crate) and [`chart`]
//!   the glucose chart as inline SVG: the pages fetch nothing from
//!   elsewhere, and the stylesheet [`STYLE`] is served by abba itself.
//!
//! abba is research software, not a medical device.

#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used))]

pub mod chart;
pub mod pages;
pub mod qr;
pub mod texts;

use serde::Serialize;
use std::sync::OnceLock;

/// The stylesheet, served at [`STYLE_PATH`].
pub const STYLE: &str = include_str!("../static/abba.css");
/// The icon, served at `/favicon.ico` (a browser asks for it on its own,
/// also for the report, a self-contained document that links nothing).
pub const ICON_SVG: &str = "<svg xmlns=\"http://www.w3.org/2000/svg\" viewBox=\"0 0 16 16\"><circle cx=\"8\" cy=\"8\" r=\"7\" fill=\"#0b4f8a\"/></svg>";
/// Where the pages link the stylesheet.
pub const STYLE_PATH: &str = "/static/abba.css";

/// The Content-Security-Policy of every page: nothing but abba's own
/// stylesheet and inline (`data:`) images; no script at all.
pub const CSP: &str = "default-src 'none'; style-src 'self'; img-src 'self' data:; form-action 'self'; frame-ancestors 'none'; base-uri 'none'";

/// A template could not be rendered (a fault of abba, not of the input).
#[derive(Debug, thiserror::Error)]
#[error("rendering the page {page}: {source}")]
pub struct RenderError {
    /// The template.
    pub page: &'static str,
    /// What minijinja said.
    pub source: minijinja::Error,
}

/// Every file of templates/, compiled in by build.rs (minijinja-embed's
/// generated calls panic on a broken template; the tests render every
/// page, so none ships).
#[allow(clippy::expect_used)]
fn add_templates(mut env: minijinja::Environment<'static>) -> minijinja::Environment<'static> {
    minijinja_embed::load_templates!(&mut env);
    env
}

fn env() -> &'static minijinja::Environment<'static> {
    static ENV: OnceLock<minijinja::Environment<'static>> = OnceLock::new();
    ENV.get_or_init(|| {
        let mut env = minijinja::Environment::new();
        // Escape by the name's ending (.html: HTML), the default, named
        // here so that nobody turns it off by accident.
        env.set_auto_escape_callback(minijinja::default_auto_escape_callback);
        env.set_formatter(shown_formatter);
        env.add_function("first_invalid", first_invalid);
        env.add_function("had_invalid", had_invalid);
        add_templates(env)
    })
}

/// minijinja's escaping formatter, with each character of a text that
/// shows nothing or reorders the text around it (a right-to-left
/// override, a zero-width space, a control character: `abba_core::text`)
/// written as its code point first: a device's, a profile's or a file's
/// name read from an export is shown as it is, never reversed or hidden
/// (`evil\u{202E}gpj.csv` showed as `evilvsc.jpg`). Markup a template
/// marks safe (the QR code's SVG) is written as it is.
fn shown_formatter(
    out: &mut minijinja::Output,
    state: &minijinja::State,
    value: &minijinja::Value,
) -> Result<(), minijinja::Error> {
    if let Some(text) = value.as_str().filter(|_| !value.is_safe()) {
        if let std::borrow::Cow::Owned(shown) = abba_core::text::shown(text) {
            return minijinja::escape_formatter(out, state, &minijinja::Value::from(shown));
        }
    }
    minijinja::escape_formatter(out, state, value)
}

/// True for the first field in error of a page (or Today's refused
/// answer), false after: the macros give that field `autofocus`, so that the page a refused form comes back
/// as puts the keyboard's focus there (and a screen reader reads its label
/// and, through `aria-describedby`, its error) with or without script,
/// instead of at the top of a page that looks unchanged. One per render
/// (a minijinja temp): HTML allows one `autofocus` per document.
/// base.html renders the content first, then asks once more for the
/// status message (a saved form's "Saved: ..."), which gets the focus
/// when no field did.
fn first_invalid(state: &minijinja::State) -> bool {
    state
        .set_temp("first_invalid", minijinja::Value::from(true))
        .is_none()
}

/// True when a field in error has claimed the focus (the title then says
/// the form was not saved).
fn had_invalid(state: &minijinja::State) -> bool {
    state.get_temp("first_invalid").is_some()
}

/// Renders the page `page` (a template name) with the layout and its model.
pub fn render(
    page: &'static str,
    layout: &pages::Layout,
    model: &impl Serialize,
) -> Result<String, RenderError> {
    let tmpl = env()
        .get_template(page)
        .map_err(|source| RenderError { page, source })?;
    tmpl.render(minijinja::context! {
        t => texts::EN,
        c => texts::CLINIC_EN,
        layout => layout,
        page => model,
    })
    .map_err(|source| RenderError { page, source })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What a template shows besides its markup and expressions.
    fn literal_text(src: &str) -> String {
        let mut out = String::new();
        let mut rest = src;
        while !rest.is_empty() {
            let next = ["{{", "{%", "{#", "<"]
                .iter()
                .filter_map(|o| rest.find(o).map(|i| (i, *o)))
                .min();
            let Some((i, open)) = next else {
                out.push_str(rest);
                break;
            };
            out.push_str(&rest[..i]);
            let close = match open {
                "{{" => "}}",
                "{%" => "%}",
                "{#" => "#}",
                _ => ">",
            };
            rest = &rest[i + open.len()..];
            rest = rest.find(close).map_or("", |j| &rest[j + close.len()..]);
        }
        out
    }

    #[test]
    fn every_text_of_every_page_comes_from_the_texts() {
        let mut seen = 0;
        for (name, tmpl) in env().templates() {
            seen += 1;
            let left: String = literal_text(tmpl.source())
                .split_whitespace()
                // (attribute fragments a macro writes inside a tag)
                .filter(|w| !w.contains('='))
                .filter(|w| w.chars().any(char::is_alphabetic))
                .collect::<Vec<_>>()
                .join(" ");
            assert!(left.is_empty(), "{name} writes its own words: {left:?}");
        }
        // Every file of templates/ is embedded (none forgotten by the build).
        let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/templates");
        let files = std::fs::read_dir(dir).unwrap().count();
        assert_eq!(seen, files, "templates embedded against files in {dir}");
        assert!(seen >= 10, "{seen} templates");
    }

    #[test]
    fn a_hostile_name_is_text_on_a_page() {
        let name = "<script>alert(1)</script>\"' {{ 7*7 }}";
        let layout = pages::Layout::new(name, None);
        let html = render(
            "message.html",
            &layout,
            &pages::Message {
                text: name.into(),
                link: None,
            },
        )
        .unwrap();
        assert!(!html.contains("<script>"), "{html}");
        // minijinja escapes `/` too.
        assert!(
            html.contains("&lt;script&gt;alert(1)&lt;&#x2f;script&gt;&quot;&#x27; {{ 7*7 }}"),
            "{html}"
        );
        assert!(html.contains("{{ 7*7 }}"));
        assert!(!html.contains("49"));
        assert!(html.contains(texts::EN.notice));
    }

    #[test]
    fn a_page_without_navigation_has_no_empty_list() {
        let message = pages::Message {
            text: "x".into(),
            link: None,
        };
        let html = render(
            "message.html",
            &pages::Layout::new("Sign in", None),
            &message,
        )
        .unwrap();
        let nav = &html[html.find("<nav").unwrap()..html.find("</nav>").unwrap()];
        assert!(
            !nav.contains("<ul"),
            "no empty list (HTML Tidy trims it): {nav}"
        );
        let layout = pages::Layout::person("Today", "c", "/");
        let html = render("message.html", &layout, &message).unwrap();
        assert!(
            html.contains("<li><a href=\"&#x2f;\" aria-current=\"page\">"),
            "{html}"
        );
    }
}
