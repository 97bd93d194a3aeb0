//! The page models: what each page shows, already in the person's units
//! and words (abba-service builds them from the store). Field names are
//! the templates' names.

use crate::texts::EN;
use serde::Serialize;

/// One link of the navigation.
#[derive(Debug, Clone, Serialize)]
pub struct NavItem {
    /// Where.
    pub href: &'static str,
    /// Its text.
    pub label: &'static str,
    /// True on its own page (`aria-current="page"`).
    pub current: bool,
}

/// What every page has: the title, the navigation, the session's CSRF
/// token (for the sign-out form and every other form), a status message.
#[derive(Debug, Clone, Serialize)]
pub struct Layout {
    /// The page's title and `<h1>`.
    pub title: String,
    /// The navigation (empty without a session).
    pub nav: Vec<NavItem>,
    /// The session's CSRF token (none: signed out).
    pub csrf: Option<String>,
    /// A message for `#status` (`role="status"`).
    pub status: Option<String>,
    /// Who is signed in, in words (`Signed in as NAME`).
    pub who: Option<String>,
    /// The one-time key of this page's forms that write (the hidden
    /// `submission` field, random for every page shown): the same form
    /// sent twice is recognised and stores nothing twice.
    pub submission: Option<String>,
}

impl Layout {
    /// A page without navigation.
    pub fn new(title: &str, csrf: Option<String>) -> Self {
        Self {
            title: title.to_string(),
            nav: Vec::new(),
            csrf,
            status: None,
            who: None,
            submission: None,
        }
    }

    /// A page of the person's app; `current` is its path.
    pub fn person(title: &str, csrf: &str, current: &str) -> Self {
        let items = [
            ("/", EN.nav_today),
            ("/log", EN.nav_log),
            ("/glucose", EN.nav_glucose),
            ("/history", EN.nav_history),
        ];
        Self {
            title: title.to_string(),
            nav: items
                .iter()
                .map(|&(href, label)| NavItem {
                    href,
                    label,
                    current: href == current,
                })
                .collect(),
            csrf: Some(csrf.to_string()),
            status: None,
            who: None,
            submission: None,
        }
    }

    /// A page of the clinic; `current` is its path.
    pub fn clinic(title: &str, csrf: &str, current: &str) -> Self {
        Self {
            title: title.to_string(),
            nav: vec![NavItem {
                href: "/clinic",
                label: EN.nav_clinic,
                current: current == "/clinic",
            }],
            csrf: Some(csrf.to_string()),
            status: None,
            who: None,
            submission: None,
        }
    }

    /// The same layout naming who is signed in.
    pub fn signed_in_as(mut self, name: &str) -> Self {
        self.who = Some(crate::texts::fill(EN.signed_in_as, &[("name", name)]));
        self
    }

    /// The same layout with the one-time key of its forms.
    pub fn with_submission(mut self, key: String) -> Self {
        self.submission = Some(key);
        self
    }

    /// The same layout with a status message.
    /// The page's status line (an error's message quotes the value it
    /// refuses: cut at [`MAX_MESSAGE_CHARS`]).
    pub fn with_status(mut self, status: Option<String>) -> Self {
        self.status = status.map(|s| shortened(&s, MAX_MESSAGE_CHARS));
        self
    }
}

/// The longest message a page or an error body carries (characters): a
/// message quotes the value it refuses, and a service probe's 900 KB body
/// with a bad instant came back as a 300 KB message.
pub const MAX_MESSAGE_CHARS: usize = 1000;

/// `text` cut to `max` characters, saying how much was left out.
pub fn shortened(text: &str, max: usize) -> String {
    let n = text.chars().count();
    if n <= max {
        return text.to_string();
    }
    let kept: String = text.chars().take(max).collect();
    format!("{kept}… ({} more characters left out)", n - max)
}

/// A page that only says something (a refusal, an explanation).
#[derive(Debug, Clone, Serialize)]
pub struct Message {
    /// The text.
    pub text: String,
    /// A link to go on with (href, text).
    pub link: Option<(String, String)>,
}

/// An open suggestion, or the latest decision of a setting.
#[derive(Debug, Clone, Serialize)]
pub struct SuggestionCard {
    /// The suggestion's id (`suggestion_id`).
    pub sid: u64,
    /// What the value is: "Suggested" while open, else the last
    /// suggestion (answered, replaced).
    pub label: &'static str,
    /// The suggested value with its unit.
    pub value: String,
    /// Its change, in words (`+4.0 %`).
    pub change: String,
    /// When it was made (local time) and the data it rests on (`.made`),
    /// as `abba advise` says them: a suggestion shown days after its data
    /// says so.
    pub made: String,
    /// The reason in plain words (the advisor's first sentence: what the
    /// data showed).
    pub reason: String,
    /// The rest of the explanation (safety rules, the clamp, the pump's
    /// step), shown on request.
    pub details: Vec<String>,
    /// True when it can be answered.
    pub open: bool,
    /// What was answered, in words (answered suggestions).
    pub answered: Option<String>,
    /// The refused own value's error, shown beside the input.
    pub value_error: Option<String>,
    /// The own value the person typed (kept after a refusal).
    pub own_value: String,
    /// The own value's unit.
    pub unit: String,
    /// The predicted effect on the person's twin, or why there is none
    /// (`.effect`).
    pub effect: Option<String>,
    /// The twin check's outcome in words (`.twin-check`).
    pub twin_check: Option<String>,
    /// True when the twin check held the suggestion back (no accept
    /// button; keeping the value in force is the answer offered first).
    pub held_back: bool,
    /// A basal rate for a schedule: the suggested schedule in words
    /// (`.schedule`); `value` is its mean.
    pub schedule: Option<String>,
}

/// An option of a select.
#[derive(Debug, Clone, Serialize)]
pub struct Choice {
    /// Its value.
    pub value: &'static str,
    /// Its text.
    pub label: &'static str,
    /// Selected.
    pub selected: bool,
}

#[cfg(test)]
mod shortened_tests {
    use super::*;

    /// A page's status line quotes what it refuses, cut at the limit and
    /// saying how much was left out (a probe's 200,000-character column
    /// name came back whole on the clinic's import page).
    #[test]
    fn a_long_status_is_cut_and_says_so() {
        let long = format!("unknown column \"{}\"", "x".repeat(200_000));
        let cut = shortened(&long, MAX_MESSAGE_CHARS);
        assert!(cut.chars().count() < MAX_MESSAGE_CHARS + 60);
        let left = long.chars().count() - MAX_MESSAGE_CHARS;
        assert!(
            cut.ends_with(&format!("({left} more characters left out)")),
            "{cut:.40}"
        );
        assert_eq!(shortened("short", MAX_MESSAGE_CHARS), "short");
    }
}
