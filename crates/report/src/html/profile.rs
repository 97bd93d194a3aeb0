//! The glucose profile of an AGP-style page: the 5th, 25th, 50th, 75th and
//! 95th percentiles of glucose by time of day, pooled over days (and, for a
//! trial arm, over patients), in bins of a fixed width.

use serde::Serialize;

use crate::stats::quantile_sorted;

/// The five percentiles drawn, in order.
pub const PERCENTILES: [f64; 5] = [0.05, 0.25, 0.5, 0.75, 0.95];

/// Minutes in a day.
pub const DAY_MIN: u32 = 1440;

/// The percentiles of one time-of-day bin.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct ProfileBin {
    /// Start of the bin, minutes after midnight.
    pub start_min: u32,
    /// Readings pooled in the bin.
    pub n: usize,
    /// 5th, 25th, 50th, 75th, 95th percentiles (mg/dL, type-7 quantiles);
    /// `None` for a bin without readings.
    pub p: Option<[f64; 5]>,
}

/// Percentiles by time of day: `readings` are (minute of day, glucose
/// mg/dL) pairs, the minute taken modulo 1440; bins are `bin_min` wide
/// (1..=1440; the last bin may be shorter when it does not divide 1440), and
/// every bin pools all readings whose minute falls in it.
pub fn time_of_day_profile(
    readings: impl IntoIterator<Item = (u32, f64)>,
    bin_min: u32,
) -> Vec<ProfileBin> {
    let bin_min = bin_min.clamp(1, DAY_MIN);
    let n_bins = DAY_MIN.div_ceil(bin_min) as usize;
    let mut bins: Vec<Vec<f64>> = vec![Vec::new(); n_bins];
    for (minute, g) in readings {
        bins[((minute % DAY_MIN) / bin_min) as usize].push(g);
    }
    bins.into_iter()
        .enumerate()
        .map(|(i, mut values)| {
            // Unstable is enough: under total_cmp only equal bits tie.
            values.sort_unstable_by(f64::total_cmp);
            let p = (!values.is_empty()).then(|| PERCENTILES.map(|q| quantile_sorted(&values, q)));
            ProfileBin {
                start_min: i as u32 * bin_min,
                n: values.len(),
                p,
            }
        })
        .collect()
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn bins_pool_readings_by_time_of_day() {
        // Two days, readings at 00:10 and 01:10 each day.
        let readings = [(10, 100.0), (70, 200.0), (10, 120.0), (70, 220.0)];
        let bins = time_of_day_profile(readings, 60);
        assert_eq!(bins.len(), 24);
        assert_eq!(bins[0].n, 2);
        assert_eq!(bins[0].p.unwrap()[2], 110.0);
        assert_eq!(bins[1].p.unwrap()[0], 200.0 + 0.05 * 20.0);
        assert!(bins[2].p.is_none());
    }
}
