//! iglu's 5-min interpolation grid (R iglu `CGMS2DayByDay` with `dt0 = 5`)
//! and the cutting of the grid into segments at long gaps (R iglu
//! `mage_ma_single`, step 4).

use crate::error::CoreError;
use crate::time::MINUTES_PER_DAY;

/// Spacing of iglu's interpolation grid, in minutes (5 min, its `dt0`
/// default for CGM data).
pub const GRID_MINUTES: f64 = 5.0;

/// Glucose on iglu's grid: the points midnight + 5k min (k ≥ 1, counted from
/// midnight of the first reading's day) that lie between the first and the
/// last reading, linearly interpolated between the two readings around each
/// point; NaN where those two readings are more than `inter_gap_min` apart
/// (a point that coincides with a reading keeps the reading). Leading and
/// trailing missing points are dropped, so the grid starts and ends with a
/// value (or is empty).
pub(super) fn iglu_grid(
    times_min: &[f64],
    glucose_mg_dl: &[f64],
    inter_gap_min: f64,
) -> Result<Vec<f64>, CoreError> {
    if times_min.len() != glucose_mg_dl.len() {
        return Err(CoreError::Metric {
            metric: "MAGE",
            reason: format!(
                "{} times but {} glucose values",
                times_min.len(),
                glucose_mg_dl.len()
            ),
        });
    }
    validate_times(times_min)?;
    let (Some(&t_first), Some(&t_last)) = (times_min.first(), times_min.last()) else {
        return Ok(Vec::new());
    };
    let day_min = MINUTES_PER_DAY as f64;
    let midnight = (t_first / day_min).floor() * day_min;
    let k_first = (((t_first - midnight) / GRID_MINUTES).ceil() as i64).max(1);
    let k_last = ((t_last - midnight) / GRID_MINUTES).floor() as i64;
    if k_last < k_first {
        return Ok(Vec::new());
    }
    let mut grid = Vec::with_capacity((k_last - k_first + 1) as usize);
    let mut r = 0usize; // times_min[r] <= t < times_min[r + 1] (or t = last)
    for k in k_first..=k_last {
        let t = midnight + k as f64 * GRID_MINUTES;
        while r + 1 < times_min.len() && times_min[r + 1] <= t {
            r += 1;
        }
        let (t0, g0) = (times_min[r], glucose_mg_dl[r]);
        let value = if t == t0 {
            g0
        } else {
            // t0 < t < t1 here, since t <= t_last.
            let (t1, g1) = (times_min[r + 1], glucose_mg_dl[r + 1]);
            if t1 - t0 > inter_gap_min {
                f64::NAN
            } else {
                g0 + (g1 - g0) * ((t - t0) / (t1 - t0))
            }
        };
        grid.push(value);
    }
    let start = grid.iter().position(|g| !g.is_nan()).unwrap_or(grid.len());
    let end = grid
        .iter()
        .rposition(|g| !g.is_nan())
        .map_or(start, |e| e + 1);
    grid.truncate(end);
    grid.drain(..start);
    Ok(grid)
}

/// Checks that times are finite and strictly increasing.
pub(super) fn validate_times(times_min: &[f64]) -> Result<(), CoreError> {
    for (index, &t) in times_min.iter().enumerate() {
        if !t.is_finite() {
            return Err(CoreError::BadReading {
                index,
                what: "time (min)",
                expected: "a finite number",
                got: t,
            });
        }
        if index > 0 && t <= times_min[index - 1] {
            return Err(CoreError::UnsortedTimes {
                index,
                previous: times_min[index - 1],
                got: t,
            });
        }
    }
    Ok(())
}

/// The grid cut at every run of missing points whose length × 5 min exceeds
/// `max_gap_min` (R iglu's rule); the runs themselves are dropped. Each
/// segment starts and ends with a value.
pub(super) fn grid_segments(grid: &[f64], max_gap_min: f64) -> Vec<&[f64]> {
    let mut segments = Vec::new();
    let mut seg_start = 0usize;
    let mut i = 0usize;
    while i < grid.len() {
        if grid[i].is_nan() {
            let run_start = i;
            while i < grid.len() && grid[i].is_nan() {
                i += 1;
            }
            if (i - run_start) as f64 * GRID_MINUTES > max_gap_min {
                segments.push(&grid[seg_start..run_start]);
                seg_start = i;
            }
        } else {
            i += 1;
        }
    }
    if seg_start < grid.len() {
        segments.push(&grid[seg_start..]);
    }
    segments
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn grid_starts_after_midnight_and_interpolates() {
        // Readings at 00:00, 00:07, 00:20 of day 3 (minutes from an epoch midnight).
        let day = 2.0 * 1440.0;
        let t = [day, day + 7.0, day + 20.0];
        let g = [100.0, 114.0, 140.0];
        let grid = iglu_grid(&t, &g, 45.0).unwrap();
        // Grid points 00:05, 00:10, 00:15, 00:20; midnight itself is not one.
        assert_eq!(grid.len(), 4);
        assert!((grid[0] - 110.0).abs() < 1e-12, "got {}", grid[0]);
        assert!((grid[1] - 120.0).abs() < 1e-12, "got {}", grid[1]);
        assert!((grid[2] - 130.0).abs() < 1e-12, "got {}", grid[2]);
        assert_eq!(grid[3], 140.0);
    }

    #[test]
    fn long_gaps_are_missing_and_cut() {
        // 00:05..01:00 every 5 min, then nothing until 05:00 (a 240 min gap).
        let mut t: Vec<f64> = (1..=12).map(|k| 5.0 * k as f64).collect();
        t.extend((60..=72).map(|k| 5.0 * k as f64));
        let g = vec![100.0; t.len()];
        let grid = iglu_grid(&t, &g, 45.0).unwrap();
        assert_eq!(grid.len(), 72);
        assert_eq!(grid.iter().filter(|g| g.is_nan()).count(), 47);
        let segs = grid_segments(&grid, 180.0);
        assert_eq!(
            segs.iter().map(|s| s.len()).collect::<Vec<_>>(),
            vec![12, 13]
        );
        // A 45-min gap is still interpolated, a 50-min one is not.
        let grid = iglu_grid(&[5.0, 50.0, 100.0], &[100.0, 190.0, 100.0], 45.0).unwrap();
        assert_eq!(grid.len(), 20);
        assert!((grid[1] - 110.0).abs() < 1e-12);
        assert!(grid[10..19].iter().all(|g| g.is_nan()));
        // A missing run of exactly 180 min stays inside the segment.
        let mut g = vec![1.0; 10];
        g.extend(vec![f64::NAN; 36]);
        g.extend(vec![1.0; 10]);
        assert_eq!(grid_segments(&g, 180.0).len(), 1);
        g.insert(20, f64::NAN);
        assert_eq!(grid_segments(&g, 180.0).len(), 2);
    }
}
