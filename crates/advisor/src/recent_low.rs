//! The SMBG readings that the recent-low rules still need
//! (`update.smbg_recent_low_basal`, `update.smbg_recent_low_carb_ratios`):
//! with four finger-sticks a day, a low reading at one hour says that the
//! settings leave unseen lows at other hours, so for a while no update may
//! add insulin, whatever window the reading fell in.
//!
//! Only readings below a rule's threshold are kept, and only as long as the
//! longest rule looks back: at four readings a day and four weeks at most,
//! about a hundred pairs.

use crate::config::RecentLow;
use abba_core::Timestamp;
use serde::{Deserialize, Serialize};

/// Low readings (time, mg/dL), oldest first.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct RecentLows(Vec<(Timestamp, f64)>);

impl RecentLows {
    /// True when no reading is kept.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }

    /// Records a reading if a rule of `rules` counts it as low, and forgets
    /// what no rule can reach any more.
    pub fn push(&mut self, at: Timestamp, g_mg_dl: f64, rules: [Option<RecentLow>; 2]) {
        let rules = rules.iter().flatten();
        let below = rules
            .clone()
            .map(|r| r.below_mg_dl)
            .fold(f64::NEG_INFINITY, f64::max);
        let Some(hours) = rules.map(|r| r.hours).max() else {
            return;
        };
        let oldest = at.minutes() - i64::from(hours) * 60;
        self.0.retain(|(t, _)| t.minutes() > oldest);
        if g_mg_dl < below {
            self.0.push((at, g_mg_dl));
        }
    }

    /// Whether a reading below `rule.below_mg_dl` was taken in the
    /// `rule.hours` hours before `at` (a reading at `at` counts).
    pub fn any_within(&self, at: Timestamp, rule: RecentLow) -> bool {
        let oldest = at.minutes() - i64::from(rule.hours) * 60;
        self.0
            .iter()
            .any(|(t, g)| *g < rule.below_mg_dl && t.minutes() > oldest && *t <= at)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(hours: i64) -> Timestamp {
        Timestamp(hours * 60)
    }

    const LOW_80_2D: RecentLow = RecentLow {
        below_mg_dl: 80.0,
        hours: 48,
    };
    const LOW_70_4D: RecentLow = RecentLow {
        below_mg_dl: 70.0,
        hours: 96,
    };

    #[test]
    fn a_low_holds_for_its_hours_and_not_a_minute_more() {
        let mut l = RecentLows::default();
        l.push(at(10), 75.0, [Some(LOW_80_2D), None]);
        assert!(l.any_within(at(10), LOW_80_2D));
        assert!(l.any_within(Timestamp(at(58).0 - 1), LOW_80_2D));
        assert!(!l.any_within(at(58), LOW_80_2D), "48 h later it is over");
        assert!(!l.any_within(at(9), LOW_80_2D), "not before it was taken");
    }

    #[test]
    fn each_rule_sees_only_readings_below_its_own_threshold() {
        let mut l = RecentLows::default();
        let rules = [Some(LOW_80_2D), Some(LOW_70_4D)];
        l.push(at(0), 75.0, rules);
        assert!(l.any_within(at(1), LOW_80_2D));
        assert!(!l.any_within(at(1), LOW_70_4D), "75 is not below 70");
        l.push(at(2), 65.0, rules);
        // Three days on: only the four-day rule still sees the 65.
        assert!(!l.any_within(at(74), LOW_80_2D));
        assert!(l.any_within(at(74), LOW_70_4D));
    }

    #[test]
    fn in_range_readings_are_not_kept_and_old_lows_are_forgotten() {
        let mut l = RecentLows::default();
        let rules = [Some(LOW_80_2D), None];
        l.push(at(0), 120.0, rules);
        assert!(l.is_empty());
        l.push(at(1), 60.0, rules);
        l.push(at(100), 130.0, rules);
        assert!(l.is_empty(), "the 60 is past every rule's look-back");
        l.push(at(101), 50.0, [None, None]);
        assert!(l.is_empty(), "no rule, nothing kept");
    }
}
