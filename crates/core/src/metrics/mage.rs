//! MAGE, iglu's default moving-average algorithm ("ma"; Fernandes et al.,
//! "Open-source algorithm to calculate mean amplitude of glycemic excursions
//! using short and long moving averages", J Diabetes Sci Technol 2022;
//! implemented in R iglu's `mage_ma_single`). Our own code; the steps follow
//! R iglu 4.x and are numbered as in its source:
//!
//! 1. Readings are linearly interpolated on a 5-min grid (iglu's
//!    `CGMS2DayByDay` with `dt0 = 5`): grid points are midnight of the first
//!    reading's day + 5, 10, 15 ... min (midnight itself is *not* a grid point),
//!    kept from the first to the last reading; points inside a gap of more
//!    than `inter_gap_min` (45) between two readings are missing.
//! 2. The grid is cut into segments at every run of missing points longer
//!    than `max_gap_min` (180): run length × 5 min > 180 min. Each segment is
//!    measured on its own.
//! 3. In a segment (skipped when it has fewer than 7 points or fewer than
//!    `long_ma` points): short (5) and long (32) right-aligned moving averages,
//!    missing points left out of a window; the first `w` values of an average
//!    of width `w` are set to its `w`-th value. Δ = short − long.
//! 4. Crossings: the first point, every point where Δ changes sign between two
//!    valid neighbours (or, after a zero or a gap, differs in sign from Δ at
//!    the last crossing), and the last point. Between consecutive crossings
//!    the extreme reading (min where Δ turns negative, max where it turns
//!    positive) is a turning point; each search starts at the previous
//!    turning point.
//! 5. Excursions: with SD the sample SD of the segment's grid values, MAGE+
//!    walks the turning points collecting nadir→peak rises of at least SD
//!    (riding the peak up until a fall of more than SD, or the end), MAGE−
//!    likewise peak→nadir falls. The segment's MAGE+ (MAGE−) is the mean
//!    height of its rises (falls). A segment with neither is skipped.
//! 6. Over segments, values are averaged with weights = segment duration;
//!    "avg" averages all MAGE+ and MAGE− values of all segments this way (so
//!    in one segment it is (MAGE+ + MAGE−)/2).
//!
//! Where R iglu and iglu-python differ we follow R iglu (the reference
//! implementation): the SD threshold is inclusive (≥ SD), a later equal
//! peak/nadir does not move the turning point, segments shorter than the
//! long window are skipped, a long gap is a run of missing grid points whose
//! length × 5 min exceeds `max_gap_min` (Python compares the time between the
//! readings around it), and a crossing needs valid readings on both sides.
//! On the team's fixture and on iglu's example subject (real Dexcom data, 5
//! segments) our values equal iglu-python 0.4.3's within 1e-6 in every
//! direction (`tests/metrics_fixture.rs`). Deliberate differences from both: a segment
//! whose grid values are all equal is skipped (R iglu would loop forever), a
//! direction with no value in some segment is averaged over the segments
//! that have one (R returns NA, Python under-weights it), and `long_ma ≤
//! short_ma` is an error rather than silently swapped.

use crate::error::CoreError;

use super::grid::{grid_segments, iglu_grid, GRID_MINUTES};
use super::validate_glucose;

/// Which MAGE to report (iglu's `direction`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MageDirection {
    /// Mean of MAGE+ and MAGE− (iglu's default).
    Avg,
    /// Per segment, the direction of the first countable excursion (Service 1970).
    Service,
    /// Per segment, the larger of MAGE+ and MAGE−.
    Max,
    /// Nadir-to-peak excursions only.
    Plus,
    /// Peak-to-nadir excursions only.
    Minus,
}

/// Knobs of the moving-average MAGE; [`Default`] gives iglu's defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MageOptions {
    /// Width of the short moving average, in grid points (iglu: 5).
    pub short_ma: usize,
    /// Width of the long moving average, in grid points (iglu: 32).
    pub long_ma: usize,
    /// Longest gap between readings that is interpolated, minutes (iglu: 45).
    pub inter_gap_min: f64,
    /// Longest run of missing grid time kept inside one segment, minutes (iglu: 180).
    pub max_gap_min: f64,
}

impl Default for MageOptions {
    fn default() -> Self {
        Self {
            short_ma: 5,
            long_ma: 32,
            inter_gap_min: 45.0,
            max_gap_min: 180.0,
        }
    }
}

impl MageOptions {
    fn validate(&self) -> Result<(), CoreError> {
        let bad = |reason: String| CoreError::Metric {
            metric: "MAGE",
            reason,
        };
        if self.short_ma == 0 || self.long_ma <= self.short_ma {
            return Err(bad(format!(
                "need 0 < short_ma < long_ma, got short_ma {} and long_ma {}",
                self.short_ma, self.long_ma
            )));
        }
        if !(self.inter_gap_min.is_finite() && self.inter_gap_min >= GRID_MINUTES) {
            return Err(bad(format!(
                "inter_gap_min must be finite and >= {GRID_MINUTES}, got {}",
                self.inter_gap_min
            )));
        }
        if !(self.max_gap_min.is_finite() && self.max_gap_min >= 0.0) {
            return Err(bad(format!(
                "max_gap_min must be finite and >= 0, got {}",
                self.max_gap_min
            )));
        }
        Ok(())
    }
}

/// MAGE of a series in every direction, mg/dL; `None` where no segment holds
/// an excursion of that direction.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Mage {
    /// Mean of MAGE+ and MAGE− (iglu's default, the protocol's `mage`).
    pub avg: Option<f64>,
    /// Direction of the first countable excursion, per segment.
    pub service: Option<f64>,
    /// Larger of MAGE+ and MAGE−, per segment.
    pub max: Option<f64>,
    /// Nadir-to-peak excursions.
    pub plus: Option<f64>,
    /// Peak-to-nadir excursions (reported as a positive amplitude).
    pub minus: Option<f64>,
    /// Segments the grid was cut into.
    pub segments: usize,
    /// Segments that held at least one countable excursion.
    pub segments_with_excursions: usize,
}

impl Mage {
    /// The value for one direction.
    pub fn value(&self, direction: MageDirection) -> Option<f64> {
        match direction {
            MageDirection::Avg => self.avg,
            MageDirection::Service => self.service,
            MageDirection::Max => self.max,
            MageDirection::Plus => self.plus,
            MageDirection::Minus => self.minus,
        }
    }
}

/// MAGE of a gap-free series sampled every 5 min (mg/dL); the series itself
/// is the grid (one segment).
pub fn mage_regular(glucose_mg_dl: &[f64], options: &MageOptions) -> Result<Mage, CoreError> {
    options.validate()?;
    validate_glucose(glucose_mg_dl)?;
    let mut acc = Combiner::default();
    if !glucose_mg_dl.is_empty() {
        acc.add(segment_mage(glucose_mg_dl, options));
    }
    Ok(acc.finish())
}

/// MAGE of timestamped readings: `times_min` in minutes from a midnight
/// (iglu's grid is anchored at midnight of the first reading's day), strictly
/// increasing; glucose in mg/dL.
pub fn mage_timed(
    times_min: &[f64],
    glucose_mg_dl: &[f64],
    options: &MageOptions,
) -> Result<Mage, CoreError> {
    options.validate()?;
    validate_glucose(glucose_mg_dl)?;
    let grid = iglu_grid(times_min, glucose_mg_dl, options.inter_gap_min)?;
    let mut acc = Combiner::default();
    for seg in grid_segments(&grid, options.max_gap_min) {
        acc.add(segment_mage(seg, options));
    }
    Ok(acc.finish())
}

/// MAGE of one segment (step 3-5), or why it was skipped.
#[derive(Debug, Clone, Copy, PartialEq)]
struct SegmentMage {
    /// Duration from the first to the last grid point, minutes (the weight).
    duration_min: f64,
    /// Mean nadir-to-peak height, if any rise counted.
    plus: Option<f64>,
    /// Mean peak-to-nadir height (positive), if any fall counted.
    minus: Option<f64>,
    /// Whether the first countable excursion is a rise (for "service").
    plus_first: bool,
}

/// Duration-weighted averages over segments (step 6).
#[derive(Default)]
struct Combiner {
    segments: usize,
    with_excursions: usize,
    sums: [(f64, f64); 5], // (Σ w·value, Σ w) for avg, service, max, plus, minus
}

impl Combiner {
    fn add(&mut self, seg: Option<SegmentMage>) {
        self.segments += 1;
        let Some(s) = seg else { return };
        if s.plus.is_none() && s.minus.is_none() {
            return;
        }
        self.with_excursions += 1;
        let w = s.duration_min;
        let mut put = |slot: usize, v: f64| {
            self.sums[slot].0 += w * v;
            self.sums[slot].1 += w;
        };
        for v in [s.plus, s.minus].into_iter().flatten() {
            put(0, v);
        }
        let service = if s.plus_first { s.plus } else { s.minus };
        if let Some(v) = service {
            put(1, v);
        }
        let max = match (s.plus, s.minus) {
            (Some(p), Some(m)) => p.max(m),
            (Some(v), None) | (None, Some(v)) => v,
            (None, None) => return,
        };
        put(2, max);
        if let Some(v) = s.plus {
            put(3, v);
        }
        if let Some(v) = s.minus {
            put(4, v);
        }
    }

    fn finish(self) -> Mage {
        let value = |(sum, weight): (f64, f64)| (weight > 0.0).then(|| sum / weight);
        Mage {
            avg: value(self.sums[0]),
            service: value(self.sums[1]),
            max: value(self.sums[2]),
            plus: value(self.sums[3]),
            minus: value(self.sums[4]),
            segments: self.segments,
            segments_with_excursions: self.with_excursions,
        }
    }
}

/// Right-aligned moving average of width `w` at grid point `i`, leaving out
/// missing (NaN) points; the first `w` points take the value at `w − 1`
/// (0-based). NaN when the window holds no reading. Summed in window order so
/// that integer data give exact means (a zero Δ stays exactly zero).
fn moving_average(gl: &[f64], w: usize, i: usize) -> f64 {
    let end = i.max(w - 1);
    let (mut sum, mut n) = (0.0, 0usize);
    for &g in &gl[end + 1 - w..=end] {
        if !g.is_nan() {
            sum += g;
            n += 1;
        }
    }
    if n == 0 {
        f64::NAN
    } else {
        sum / n as f64
    }
}

/// [`moving_average`] at every point of `gl`, the same values bit for bit.
/// Without missing points each window is summed in the same order with
/// sixteen (then four) windows in flight at once: the sums are independent chains of
/// additions, and one at a time left the processor waiting on each add (the
/// moving averages were most of MAGE's cost, and MAGE ~5 % of a trial).
fn moving_averages(gl: &[f64], w: usize) -> Vec<f64> {
    let n = gl.len();
    if w == 0 || n < w || gl.iter().any(|g| g.is_nan()) {
        return (0..n).map(|i| moving_average(gl, w, i)).collect();
    }
    let start = |i: usize| i.max(w - 1) + 1 - w;
    let mut out = vec![0.0; n];
    let mut i = 0;
    // Sixteen points at a time where their windows start one after the
    // other: sixteen independent sums in order, which the core adds side
    // by side (each sum is a chain of w dependent additions).
    if n >= w {
        while i < w - 1 && i < n {
            out[i] = moving_average(gl, w, i);
            i += 1;
        }
        while i + 16 <= n {
            let s = i + 1 - w;
            let mut sum = [0.0; 16];
            for k in 0..w {
                let row = &gl[s + k..s + k + 16];
                for j in 0..16 {
                    sum[j] += row[j];
                }
            }
            for j in 0..16 {
                out[i + j] = sum[j] / w as f64;
            }
            i += 16;
        }
    }
    while i + 4 <= n {
        let s = [start(i), start(i + 1), start(i + 2), start(i + 3)];
        let mut sum = [0.0; 4];
        for k in 0..w {
            for j in 0..4 {
                sum[j] += gl[s[j] + k];
            }
        }
        for j in 0..4 {
            out[i + j] = sum[j] / w as f64;
        }
        i += 4;
    }
    for (k, v) in out.iter_mut().enumerate().skip(i) {
        *v = moving_average(gl, w, k);
    }
    out
}

/// Kind of turning point searched for after a crossing.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Turn {
    Min,
    Max,
}

/// Steps 3-5 on one segment: NaN marks missing grid points; the first and
/// last points are readings. `None` when the segment is too short or flat.
fn segment_mage(gl: &[f64], o: &MageOptions) -> Option<SegmentMage> {
    let n = gl.len();
    if n < 7 || n < o.long_ma {
        return None;
    }
    let (short, long) = (
        moving_averages(gl, o.short_ma),
        moving_averages(gl, o.long_ma),
    );
    let delta = |i: usize| short[i] - long[i];

    // Step 4: crossings (position, kind of turning point after it, Δ there).
    let d0 = delta(0);
    let kind = |d: f64| if d > 0.0 { Turn::Max } else { Turn::Min };
    let mut crosses: Vec<(usize, Turn)> = vec![(0, kind(d0))];
    let mut d_last_cross = d0;
    let mut d_prev = d0;
    for i in 1..n {
        let d = delta(i);
        if !gl[i].is_nan() && !gl[i - 1].is_nan() && !d.is_nan() && !d_prev.is_nan() {
            let against = if d * d_prev < 0.0 {
                Some(d_prev)
            } else if d * d_last_cross < 0.0 {
                Some(d_last_cross)
            } else {
                None
            };
            if let Some(before) = against {
                crosses.push((i, if d < before { Turn::Min } else { Turn::Max }));
                d_last_cross = d;
            }
        }
        d_prev = d;
    }
    crosses.push((n - 1, kind(d_prev)));

    // Turning points between consecutive crossings.
    let mut extrema: Vec<f64> = Vec::with_capacity(crosses.len() - 1);
    let mut last_at = crosses[0].0;
    for w in crosses.windows(2) {
        let (from, to) = (last_at, w[1].0);
        let mut best: Option<(usize, f64)> = None;
        for (k, &g) in gl.iter().enumerate().take(to + 1).skip(from) {
            if g.is_nan() {
                continue;
            }
            let better = match (best, w[0].1) {
                (None, _) => true,
                (Some((_, b)), Turn::Min) => g < b,
                (Some((_, b)), Turn::Max) => g > b,
            };
            if better {
                best = Some((k, g));
            }
        }
        // Both ends of a search are readings, so `best` is always found.
        let (at, value) = best.unwrap_or((from, gl[from]));
        extrema.push(value);
        last_at = at;
    }

    // Step 5: excursions of at least one SD of the segment.
    let sd = sample_sd_skipping_nan(gl);
    if sd.is_nan() || sd <= 0.0 {
        return None;
    }
    let (plus_sum, plus_n, plus_first_peak) = rises(&extrema, sd);
    let (minus_sum, minus_n, minus_first_peak) = falls(&extrema, sd);
    if plus_n == 0 && minus_n == 0 {
        return None;
    }
    let plus_first = plus_n > 0 && (minus_n == 0 || plus_first_peak <= minus_first_peak);
    Some(SegmentMage {
        duration_min: (n - 1) as f64 * GRID_MINUTES,
        plus: (plus_n > 0).then(|| plus_sum / plus_n as f64),
        minus: (minus_n > 0).then(|| (minus_sum / minus_n as f64).abs()),
        plus_first,
    })
}

/// Sample SD (n − 1) of the non-missing values.
fn sample_sd_skipping_nan(gl: &[f64]) -> f64 {
    let (mut n, mut sum) = (0usize, 0.0);
    for &g in gl.iter().filter(|g| !g.is_nan()) {
        n += 1;
        sum += g;
    }
    if n < 2 {
        return f64::NAN;
    }
    let mean = sum / n as f64;
    let ss: f64 = gl
        .iter()
        .filter(|g| !g.is_nan())
        .map(|g| (g - mean) * (g - mean))
        .sum();
    (ss / (n - 1) as f64).sqrt()
}

/// MAGE+ walk over the turning points `a`: returns (Σ heights, count, index
/// of the first excursion's peak). For each `j` the largest rise into `a[j]`
/// from the turning points since the last excursion is tested against SD;
/// once found, the peak rides up while no fall of more than SD follows.
fn rises(a: &[f64], sd: f64) -> (f64, usize, usize) {
    let n = a.len();
    let (mut sum, mut count, mut first_peak) = (0.0, 0usize, usize::MAX);
    let (mut j, mut prev_j) = (0usize, 0usize);
    while j < n {
        // First index of the lowest turning point in prev_j..=j.
        let mut i = prev_j;
        for c in prev_j..=j {
            if a[c] < a[i] {
                i = c;
            }
        }
        if a[j] - a[i] >= sd {
            // Ride the peak: `peak` moves to any higher point until a fall of
            // more than SD after it, or the last turning point.
            let mut peak = j;
            for k in j..n {
                if a[k] > a[peak] {
                    peak = k;
                }
                if a[k] - a[peak] < -sd || k == n - 1 {
                    sum += a[peak] - a[i];
                    if count == 0 {
                        first_peak = peak;
                    }
                    count += 1;
                    prev_j = k;
                    break;
                }
            }
            j = prev_j;
        } else {
            j += 1;
        }
    }
    (sum, count, first_peak)
}

/// MAGE− walk, the mirror of [`rises`]: returns (Σ heights (negative), count,
/// index of the first excursion's peak). As in iglu, the next search starts
/// at the nadir of the last fall.
fn falls(a: &[f64], sd: f64) -> (f64, usize, usize) {
    let n = a.len();
    let (mut sum, mut count, mut first_peak) = (0.0, 0usize, usize::MAX);
    let (mut j, mut prev_j) = (0usize, 0usize);
    while j < n {
        // First index of the highest turning point in prev_j..=j.
        let mut i = prev_j;
        for c in prev_j..=j {
            if a[c] > a[i] {
                i = c;
            }
        }
        if a[j] - a[i] <= -sd {
            // Ride the nadir down until a rise of more than SD after it, or
            // the last turning point; the next search starts at the nadir.
            let mut nadir = j;
            let mut end = n - 1;
            for k in j..n {
                if a[k] < a[nadir] {
                    nadir = k;
                }
                if a[k] - a[nadir] > sd || k == n - 1 {
                    sum += a[nadir] - a[i];
                    if count == 0 {
                        first_peak = i;
                    }
                    count += 1;
                    end = k;
                    break;
                }
            }
            prev_j = nadir;
            j = end;
        } else {
            j += 1;
        }
    }
    (sum, count, first_peak)
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn seg(gl: &[f64]) -> Option<SegmentMage> {
        segment_mage(gl, &MageOptions::default())
    }

    #[test]
    fn short_or_flat_segments_are_skipped() {
        assert_eq!(seg(&[100.0; 31]), None, "shorter than the long window");
        assert_eq!(seg(&[100.0; 300]), None, "flat: no excursion, no hang");
        let m = mage_regular(&[120.0; 10], &MageOptions::default()).unwrap();
        assert_eq!(m.avg, None);
        assert_eq!(m.segments, 1);
        assert_eq!(m.segments_with_excursions, 0);
    }

    #[test]
    fn sine_wave_has_its_peak_to_trough_amplitude() {
        // 150 ± 50 mg/dL with an 8-h period, trough to trough over two days:
        // every excursion is 100 (iglu also counts half excursions at the ends,
        // so the series must start and end at an extreme for this to hold).
        let gl: Vec<f64> = (0..=576)
            .map(|i| 150.0 - 50.0 * (2.0 * std::f64::consts::PI * i as f64 / 96.0).cos())
            .collect();
        let m = mage_regular(&gl, &MageOptions::default()).unwrap();
        for (name, v) in [("avg", m.avg), ("plus", m.plus), ("minus", m.minus)] {
            let v = v.unwrap();
            assert!((v - 100.0).abs() < 1e-9, "{name}: expected 100, got {v}");
        }
        assert_eq!(m.segments_with_excursions, 1);
    }

    #[test]
    fn walks_match_hand_worked_turning_points() {
        // Turning points 100, 200, 120, 260, 90 with SD 50: rises 100 (100→200)
        // and 140 (120→260); falls 80 (200→120) and 170 (260→90).
        let a = [100.0, 200.0, 120.0, 260.0, 90.0];
        let (s, n, first) = rises(&a, 50.0);
        assert_eq!((s, n, first), (240.0, 2, 1));
        let (s, n, first) = falls(&a, 50.0);
        assert_eq!((s, n, first), (-250.0, 2, 1));
        // A small wiggle (< SD) inside a rise is ridden over: 100→150→140→230.
        let a = [100.0, 150.0, 140.0, 230.0, 100.0];
        assert_eq!(rises(&a, 50.0), (130.0, 1, 3));
        assert_eq!(falls(&a, 50.0), (-130.0, 1, 3));
    }

    #[test]
    fn moving_averages_equal_one_at_a_time_bit_for_bit() {
        // Irregular values (sums that round), with and without a gap.
        let mut gl: Vec<f64> = (0..203)
            .map(|i| 100.0 + 37.3 * (i as f64 * 0.37).sin() + 1e-7 * i as f64)
            .collect();
        for _ in 0..2 {
            for w in [1, 5, 32, 203] {
                let all = moving_averages(&gl, w);
                for (i, v) in all.iter().enumerate() {
                    assert_eq!(
                        v.to_bits(),
                        moving_average(&gl, w, i).to_bits(),
                        "w {w} i {i}"
                    );
                }
            }
            gl[50] = f64::NAN;
        }
    }

    #[test]
    fn moving_average_fills_the_start_and_skips_missing() {
        let gl = [1.0, 2.0, 3.0, f64::NAN, 5.0];
        assert_eq!(moving_average(&gl, 3, 0), 2.0);
        assert_eq!(moving_average(&gl, 3, 2), 2.0);
        assert_eq!(moving_average(&gl, 3, 3), 2.5);
        assert_eq!(moving_average(&gl, 3, 4), 4.0);
        assert!(moving_average(&[f64::NAN, f64::NAN], 2, 1).is_nan());
    }

    #[test]
    fn options_are_checked() {
        let o = MageOptions {
            short_ma: 32,
            long_ma: 5,
            ..MageOptions::default()
        };
        assert!(mage_regular(&[100.0; 50], &o).is_err());
    }
}
