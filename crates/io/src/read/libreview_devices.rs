//! One sensor's history uploaded by two devices. LibreView keeps the
//! historic glucose each device (reader, phone) uploads under its serial
//! number: a second phone that reads the same sensor adds a second series
//! at the first one's times, a minute or so apart and a few mg/dL
//! different (a real export of an account in Taiwan shows eight hours of
//! it). Read as CGM both would double the readings of that stretch. The
//! series of the device with the most historic rows is read; another
//! device's historic row closer to one of its readings than half its
//! sampling period (the same sample) is counted, not read, and reported
//! with its lines and times. Rows of another device outside the first's
//! series (a phone changed) are read as they are.

use std::collections::{BTreeMap, HashSet};

use jiff::civil::DateTime;

use super::table::Table;
use crate::error::IoError;
use crate::time::{parse_wall, DateOrder};

/// What a second device's duplicate historic row is counted as.
pub const SECOND_DEVICE: &str = "historic glucose of a second device at the first device's times";

/// The historic rows (by line) to count rather than read, and a note per
/// device that had any.
#[derive(Default)]
pub struct Duplicates {
    /// The lines of the rows to count, not read as CGM.
    pub lines: HashSet<u64>,
    /// One note per device that has such rows.
    pub notes: Vec<String>,
}

/// Finds the historic rows of devices other than the main one that repeat
/// the main one's samples. `t` is a fresh table at its first row; a row
/// whose time does not parse is left to the reader (it reports it).
pub fn find(
    t: &mut Table<'_>,
    serial: usize,
    time: usize,
    record_type: usize,
    historic: usize,
    order: DateOrder,
) -> Result<Duplicates, IoError> {
    // Per serial, in file order: (wall time, line).
    let mut series: BTreeMap<String, (usize, Vec<(DateTime, u64)>)> = BTreeMap::new();
    let mut rank = 0usize;
    while let Some(line) = t.next_row()? {
        let rtype = t.cell(record_type);
        let is_historic = !rtype.is_empty() && rtype.bytes().all(|b| b == b'0');
        if !is_historic || t.cell(historic).is_empty() {
            continue;
        }
        let Some(wall) = parse_wall(t.cell(time), order) else {
            continue;
        };
        let entry = series.entry(t.cell(serial).to_string()).or_insert_with(|| {
            rank += 1;
            (rank, Vec::new())
        });
        entry.1.push((wall, line));
    }
    let mut out = Duplicates {
        lines: HashSet::new(),
        notes: Vec::new(),
    };
    if series.len() < 2 {
        return Ok(out);
    }
    // The main device: the most historic rows, the first in the file on a tie.
    let Some(main) = series
        .iter()
        .max_by_key(|(_, (rank, rows))| (rows.len(), std::cmp::Reverse(*rank)))
        .map(|(s, _)| s.clone())
    else {
        return Ok(out);
    };
    let mut times: Vec<DateTime> = series[&main].1.iter().map(|r| r.0).collect();
    times.sort();
    let mut gaps: Vec<i64> = times
        .windows(2)
        .map(|w| w[1].duration_since(w[0]).as_secs())
        .filter(|&g| g > 0)
        .collect();
    if gaps.is_empty() {
        return Ok(out);
    }
    gaps.sort_unstable();
    let period = gaps[gaps.len() / 2];
    for (serial, (_, rows)) in series.iter().filter(|(s, _)| **s != main) {
        let same: Vec<&(DateTime, u64)> = rows
            .iter()
            .filter(|(wall, _)| {
                let i = times.partition_point(|t| t < wall);
                [i.checked_sub(1), Some(i)]
                    .into_iter()
                    .flatten()
                    .filter_map(|j| times.get(j))
                    .any(|t| 2 * wall.duration_since(*t).as_secs().abs() < period)
            })
            .collect();
        if same.is_empty() {
            continue;
        }
        out.lines.extend(same.iter().map(|r| r.1));
        let lines = same.iter().map(|r| r.1);
        let (first, last) = (lines.clone().min().unwrap_or(0), lines.max().unwrap_or(0));
        let walls = same.iter().map(|r| r.0);
        let (from, to) = (
            walls.clone().min().unwrap_or_default(),
            walls.max().unwrap_or_default(),
        );
        out.notes.push(format!(
            "{} historic glucose rows of device \"{serial}\" (lines {first}-{last}, {} to {}) \
             repeat the readings of device \"{main}\" (each within half its {}-minute period \
             of one of them: the same sensor's history uploaded by two devices): the device \
             with the most historic rows, \"{main}\", is read; those rows are counted, not \
             read as CGM",
            same.len(),
            from.strftime("%Y-%m-%d %H:%M"),
            to.strftime("%Y-%m-%d %H:%M"),
            period / 60,
        ));
    }
    Ok(out)
}
