//! CGM coverage: days, share of the expected readings, longest gap.

use serde::Serialize;

/// Coverage of a series of reading instants.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Coverage {
    /// Span from the first to the last reading, in days.
    pub days: f64,
    /// Readings found.
    pub readings: usize,
    /// Readings expected at the sensor's period over the span.
    pub expected: usize,
    /// Found / expected, in percent (at most 100).
    pub percent: f64,
    /// The sensor period used, in minutes (the median interval).
    pub period_min: f64,
    /// The longest interval between two readings, in minutes.
    pub longest_gap_min: f64,
}

/// The consensus asks for at least 70 % of the expected readings.
pub const MIN_COVERAGE_PERCENT: f64 = 70.0;

/// Coverage of sorted reading times given in minutes.
pub fn coverage(minutes: &[f64]) -> Option<Coverage> {
    if minutes.len() < 2 {
        return None;
    }
    let mut gaps: Vec<f64> = minutes.windows(2).map(|w| w[1] - w[0]).collect();
    let longest = gaps.iter().copied().fold(0.0, f64::max);
    gaps.sort_by(f64::total_cmp);
    let period = gaps[gaps.len() / 2].max(1.0);
    let span = minutes[minutes.len() - 1] - minutes[0];
    let expected = (span / period).round() as usize + 1;
    Some(Coverage {
        days: span / 1440.0,
        readings: minutes.len(),
        expected,
        percent: (100.0 * minutes.len() as f64 / expected as f64).min(100.0),
        period_min: period,
        longest_gap_min: longest,
    })
}
