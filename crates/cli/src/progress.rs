//! Progress of long commands on standard error, fed by the libraries'
//! callbacks (the libraries never print): a bar with an estimate of the
//! time left on a terminal; otherwise (a log file, CI) a plain line every
//! [`LINE_EVERY`], so a long run still says where it is without filling the
//! log; nothing with `--quiet`.

use indicatif::{ProgressBar, ProgressStyle};
use std::io::IsTerminal;
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How often a plain progress line is printed when standard error is not a
/// terminal.
pub const LINE_EVERY: Duration = Duration::from_secs(5);

/// Progress of one command, shown as its situation allows.
pub struct Progress {
    shown: Shown,
}

enum Shown {
    Bar(ProgressBar),
    Lines(Mutex<Lines>),
    Nothing,
}

impl Progress {
    /// Progress of `what` (e.g. `abba trial`) counted in `unit`s (e.g.
    /// `patient-runs`); nothing is shown when `quiet`.
    pub fn new(what: &str, unit: &str, quiet: bool) -> Self {
        let shown = if quiet {
            Shown::Nothing
        } else if std::io::stderr().is_terminal() {
            let template =
                format!("{what}: {{elapsed_precise}} [{{bar:40}}] {{pos}}/{{len}} {unit} (about {{eta}} left)");
            let bar = ProgressBar::new(0);
            if let Ok(style) = ProgressStyle::with_template(&template) {
                bar.set_style(style.progress_chars("=> "));
            }
            Shown::Bar(bar)
        } else {
            Shown::Lines(Mutex::new(Lines::new(
                what,
                unit,
                Instant::now(),
                LINE_EVERY,
            )))
        };
        Self { shown }
    }

    /// `done` of `total` steps are finished.
    pub fn update(&self, done: usize, total: usize) {
        match &self.shown {
            Shown::Bar(bar) => {
                bar.set_length(total as u64);
                bar.set_position(done as u64);
            }
            Shown::Lines(lines) => {
                if let Ok(mut lines) = lines.lock() {
                    if let Some(line) = lines.line(Instant::now(), done, total) {
                        eprintln!("{line}");
                    }
                }
            }
            Shown::Nothing => {}
        }
    }

    /// Removes the bar (the command prints its own summary).
    pub fn finish(&self) {
        if let Shown::Bar(bar) = &self.shown {
            bar.finish_and_clear();
        }
    }
}

impl abba_trial::runner::Progress for Progress {
    fn update(&self, done: usize, total: usize) {
        Progress::update(self, done, total);
    }
}

/// The plain lines: at most one per `every`, each with the share done, the
/// time spent and an estimate of the time left (the time spent per step so
/// far times the steps left).
struct Lines {
    what: String,
    unit: String,
    started: Instant,
    every: Duration,
    next: Instant,
}

impl Lines {
    fn new(what: &str, unit: &str, started: Instant, every: Duration) -> Self {
        Self {
            what: what.into(),
            unit: unit.into(),
            started,
            every,
            next: started + every,
        }
    }

    /// The line to print at `now`, if one is due.
    fn line(&mut self, now: Instant, done: usize, total: usize) -> Option<String> {
        if now < self.next || done == 0 || total == 0 {
            return None;
        }
        self.next = now + self.every;
        let spent = now.duration_since(self.started).as_secs_f64();
        let left = spent / done as f64 * total.saturating_sub(done) as f64;
        Some(format!(
            "{}: {done}/{total} {} ({:.0} %), {} spent, about {} left",
            self.what,
            self.unit,
            100.0 * done as f64 / total as f64,
            duration(spent),
            duration(left)
        ))
    }
}

/// `42 s`, `3 min 05 s`, `2 h 07 min`.
fn duration(seconds: f64) -> String {
    let s = seconds.round() as u64;
    match s {
        0..=59 => format!("{s} s"),
        60..=3599 => format!("{} min {:02} s", s / 60, s % 60),
        _ => format!("{} h {:02} min", s / 3600, s % 3600 / 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plain_lines_come_every_few_seconds_with_an_estimate() {
        let t0 = Instant::now();
        let mut lines = Lines::new("abba trial", "patient-runs", t0, Duration::from_secs(5));
        let at = |s: u64| t0 + Duration::from_secs(s);
        assert_eq!(lines.line(at(1), 10, 1200), None);
        assert_eq!(lines.line(at(4), 40, 1200), None);
        assert_eq!(
            lines.line(at(6), 100, 1200).as_deref(),
            Some("abba trial: 100/1200 patient-runs (8 %), 6 s spent, about 1 min 06 s left")
        );
        assert_eq!(lines.line(at(9), 150, 1200), None);
        assert_eq!(
            lines.line(at(11), 600, 1200).as_deref(),
            Some("abba trial: 600/1200 patient-runs (50 %), 11 s spent, about 11 s left")
        );
    }

    #[test]
    fn durations_read_naturally() {
        assert_eq!(duration(42.4), "42 s");
        assert_eq!(duration(185.0), "3 min 05 s");
        assert_eq!(duration(7620.0), "2 h 07 min");
    }
}
