//! The history: every suggestion, the answer and the value in force, by day.

use crate::advise::{SuggestionView, NOTICE};
use std::fmt::Write as _;

/// The history as text, one line per decision.
pub fn to_text(person: &str, rows: &[SuggestionView]) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "History of {person}\n{NOTICE}\n");
    if rows.is_empty() {
        let _ = writeln!(s, "No suggestion yet.");
    }
    let _ = writeln!(
        s,
        "{:>4}  {:<16}  {:<9}  {:>9} {:>9} {:>8}  {:<10}  {:>9}",
        "day", "decided", "setting", "previous", "suggested", "change", "answer", "in force"
    );
    for r in rows {
        let _ = writeln!(
            s,
            "D{:<3}  {:<16}  {:<9}  {:>9.3} {:>9.3} {:>+7.2}%  {:<10}  {:>9.3} {}",
            r.day,
            r.decided_at,
            r.setting,
            r.previous,
            r.suggested,
            r.change_percent,
            r.status,
            r.in_force,
            r.unit
        );
        if let Some(n) = &r.answer_note {
            let _ = writeln!(s, "      {n}");
        }
    }
    s
}
