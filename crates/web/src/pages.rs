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
        }
    }

    /// The same layout naming who is signed in.
    pub fn signed_in_as(mut self, name: &str) -> Self {
        self.who = Some(crate::texts::fill(EN.signed_in_as, &[("name", name)]));
        self
    }

    /// The same layout with a status message.
    pub fn with_status(mut self, status: Option<String>) -> Self {
        self.status = status;
        self
    }
}

/// A page that only says something (a refusal, an explanation).
#[derive(Debug, Clone, Serialize)]
pub struct Message {
    /// The text.
    pub text: String,
    /// A link to go on with (href, text).
    pub link: Option<(String, String)>,
}

/// The sign-in page of a link.
#[derive(Debug, Clone, Serialize)]
pub struct Signin {
    /// The link's secret (the hidden `link` field).
    pub link: String,
    /// The double-submit token (the hidden `csrf` field, also a cookie).
    pub csrf: String,
}

/// A field's error, shown beside it.
#[derive(Debug, Clone, Serialize)]
pub struct FieldError {
    /// The field's name (the error's id is `{name}-error`).
    pub field: String,
    /// What was wrong and what is expected.
    pub message: String,
}

/// An open suggestion, or the latest decision of a setting.
#[derive(Debug, Clone, Serialize)]
pub struct SuggestionCard {
    /// The suggestion's id (`suggestion_id`).
    pub sid: u64,
    /// The suggested value with its unit.
    pub value: String,
    /// Its change, in words (`+4.0 %`).
    pub change: String,
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
}

/// One setting on Today.
#[derive(Debug, Clone, Serialize)]
pub struct SettingCard {
    /// `basal`, `breakfast`, `lunch` or `dinner` (the section is `setting-{key}`).
    pub key: &'static str,
    /// Its name.
    pub title: &'static str,
    /// The value in force with its unit.
    pub in_force: String,
    /// The latest suggestion, when there is one.
    pub suggestion: Option<SuggestionCard>,
    /// "No change today", "No suggestion yet" and the like.
    pub note: Option<String>,
}

/// Today.
#[derive(Debug, Clone, Serialize)]
pub struct Today {
    /// The first-week countdown (`#first-week`).
    pub first_week: Option<String>,
    /// What abba was not designed for (`#not-designed-for`).
    pub not_designed_for: Option<String>,
    /// The four settings.
    pub settings: Vec<SettingCard>,
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

/// The log.
#[derive(Debug, Clone, Serialize)]
pub struct Log {
    /// An import-fed person: no forms, this says why.
    pub import_fed: Option<String>,
    /// The glucose label with the person's unit.
    pub glucose_label: String,
    /// The glucose field's `step`.
    pub glucose_step: &'static str,
    /// The meal slots, the default one selected.
    pub slots: Vec<Choice>,
    /// Values typed, kept after an error (glucose, carbs).
    pub glucose: String,
    /// Carbohydrate typed.
    pub carbs: String,
    /// The glucose field's error, beside it.
    pub glucose_error: Option<String>,
    /// The carbohydrate field's error, beside it.
    pub carbs_error: Option<String>,
    /// After a main meal: the ratio, the bolus and the suggestion to answer.
    pub meal_advice: Option<MealAdvice>,
    /// After a bedtime reading: tomorrow's basal.
    pub tomorrow_basal: Option<String>,
    /// The status message (moved into the layout's `#status`).
    pub status: Option<String>,
    /// The person's name (moved into the layout).
    pub name: String,
}

/// The answer to a main meal.
#[derive(Debug, Clone, Serialize)]
pub struct MealAdvice {
    /// The ratio to use, in words.
    pub ratio: String,
    /// The bolus it implies, in words.
    pub bolus: String,
    /// The open suggestion, if any (the same form as on Today).
    pub suggestion: Option<SuggestionCard>,
}

/// A link of a choice (the Glucose page's ranges).
#[derive(Debug, Clone, Serialize)]
pub struct LinkChoice {
    /// Where.
    pub href: &'static str,
    /// Its text.
    pub label: &'static str,
    /// True for the one shown (`aria-current`).
    pub current: bool,
}

/// One line of the Glucose page's summary.
#[derive(Debug, Clone, Serialize)]
pub struct SummaryItem {
    /// What.
    pub label: String,
    /// Its value in words.
    pub value: String,
}

/// The Glucose page.
#[derive(Debug, Clone, Serialize)]
pub struct Glucose {
    /// The ranges (24 h, 14 days).
    pub ranges: Vec<LinkChoice>,
    /// The chart's accessible name.
    pub chart_title: String,
    /// The chart (none: no reading in the range).
    pub chart: Option<crate::chart::Chart>,
    /// The summary (time in ranges, mean, readings).
    pub summary: Vec<SummaryItem>,
    /// A note under the summary (finger sticks: shares of readings).
    pub summary_note: Option<String>,
    /// The chart's readings as a table (by hour over a day, by day over
    /// two weeks), oldest first.
    pub table: Vec<GlucoseRow>,
    /// The table's caption.
    pub table_caption: String,
    /// The table's first column's name (hour or day).
    pub table_period: &'static str,
}

/// One row of the Glucose page's table.
#[derive(Debug, Clone, Serialize)]
pub struct GlucoseRow {
    /// The hour or the day.
    pub period: String,
    /// How many readings.
    pub readings: usize,
    /// Their mean, in the person's unit.
    pub mean: String,
    /// The lowest.
    pub lowest: String,
    /// The highest.
    pub highest: String,
    /// The share in the target range.
    pub in_range: String,
}

/// One row of the History table.
#[derive(Debug, Clone, Serialize)]
pub struct HistoryRow {
    /// The local date of the day it is for.
    pub day: String,
    /// The setting's name.
    pub setting: String,
    /// Local date and time of the decision.
    pub decided: String,
    /// The value before, with its unit.
    pub from: String,
    /// The suggestion with its change (or "no change").
    pub suggested: String,
    /// The answer in words.
    pub answer: String,
    /// The value in force after it, with its unit.
    pub in_force: String,
    /// The reason in plain words.
    pub reason: String,
}

/// The History page.
#[derive(Debug, Clone, Serialize)]
pub struct History {
    /// Every decision, newest first.
    pub rows: Vec<HistoryRow>,
}
