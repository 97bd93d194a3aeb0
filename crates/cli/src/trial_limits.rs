//! Trial sizes refused before any work, with the limit named: a trial that
//! cannot finish should say so at once, not after hours of simulation.

use abba_sim::cohort::MAX_COHORT_SIZE;
use abba_trial::TrialConfig;
use anyhow::{bail, Result};

const MINUTES_PER_DAY: i64 = 1440;

/// Refuses `--days` beyond the advisors' clock and `--patients` beyond the
/// largest cohort.
///
/// The advisors refuse an event later than `max_timestamp_min` (100 years
/// by default) as implausible, so a longer trial would fail at that day
/// after simulating every day before it (36,500 days of every patient).
pub fn check(c: &TrialConfig) -> Result<()> {
    let clock = [
        ("abba.limits", c.abba.limits.max_timestamp_min),
        ("r2r.limits", c.r2r.limits.max_timestamp_min),
        ("fixed_limits", c.fixed_limits.max_timestamp_min),
    ];
    for (field, max_min) in clock {
        let max_days = max_min / MINUTES_PER_DAY;
        if i64::from(c.days) > max_days {
            bail!(
                "days: {} is above the limit of {max_days} days: the advisors' clock ends at \
                 {field}.max_timestamp_min = {max_min} minutes, and later events are refused as \
                 implausible",
                c.days
            );
        }
    }
    if c.patients > MAX_COHORT_SIZE {
        bail!(
            "patients: {} is above the limit of {MAX_COHORT_SIZE} (the largest cohort abba \
             generates; see `abba cohort --help`)",
            c.patients
        );
    }
    Ok(())
}
