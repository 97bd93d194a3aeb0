//! Insulin on board and insulin activity as oref0's autotune sees them
//! (lib/iob/history.js, total.js, oref0 0.7.1): boluses as they are, and
//! every temporary basal turned into 0.05 U pieces of its difference from
//! the profile's scheduled rate, after cutting it where the next temp starts,
//! into pieces of at most 30 minutes and at the profile's basal break
//! points.

use super::curve::InsulinModel;
use super::js;
use super::profile::Profile;
use super::{Insulin, LocalClock};

/// An amount of insulin at an instant (ms since the epoch, fractional for
/// the pieces of a temp).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dose {
    /// When.
    pub at_ms: f64,
    /// Units (negative: basal withheld below the scheduled rate).
    pub units: f64,
}

#[derive(Debug, Clone, Copy)]
struct Temp {
    at_ms: i64,
    rate: f64,
    duration_min: f64,
}

/// Splits `e` at a basal break point `s` (minutes of the day) or after 30
/// minutes, as oref0's splitTimespanWithOneSplitter does.
fn split_one(e: Temp, s: f64, clock: &dyn LocalClock) -> Option<(Temp, Temp)> {
    let start = f64::from(clock.minute_of_day(e.at_ms));
    let end = start + e.duration_min;
    if !(e.duration_min > 30.0 || (start < s && end > s) || (end > 1440.0 && s < end - 1440.0)) {
        return None;
    }
    let first = if e.duration_min > 30.0 {
        30.0
    } else {
        let point = if end > 1440.0 { 1440.0 } else { s };
        point - start
    };
    // oref0 writes the second part's start with moment's format(): whole seconds.
    let second_ms = ((e.at_ms as f64 + first * 60_000.0) / 1000.0).floor() as i64 * 1000;
    Some((
        Temp {
            duration_min: first,
            ..e
        },
        Temp {
            at_ms: second_ms,
            rate: e.rate,
            duration_min: e.duration_min - first,
        },
    ))
}

/// oref0's splitTimespan, including its quirk: within one pass, once a piece
/// has been split, the later pieces of that pass that need no split are
/// dropped (choice 6 of the module doc).
fn split(e: Temp, splitters: &[f64], clock: &dyn LocalClock) -> Vec<Temp> {
    let mut results = vec![e];
    loop {
        let mut out = Vec::with_capacity(results.len() + 1);
        let mut found = false;
        for o in results {
            for &s in splitters {
                if let Some((a, b)) = split_one(o, s, clock) {
                    out.push(a);
                    out.push(b);
                    found = true;
                    break;
                }
            }
            if !found {
                out.push(o);
            }
        }
        results = out;
        if !found {
            return results;
        }
    }
}

/// The doses of `history` (newest first, as Nightscout lists them) as seen
/// at `now_ms` (temps running past `now_ms` + 1 min end there, as oref0's
/// zero-temp cancel makes them; `None`: nothing is cut).
pub fn doses(
    history: &[&Insulin],
    profile: &Profile,
    now_ms: Option<i64>,
    clock: &dyn LocalClock,
) -> Vec<Dose> {
    let mut out = Vec::new();
    let mut temps = Vec::new();
    for rec in history {
        match **rec {
            Insulin::Bolus { at_ms, units } => {
                if units != 0.0 {
                    out.push(Dose {
                        at_ms: at_ms as f64,
                        units,
                    });
                }
            }
            Insulin::Temp {
                at_ms,
                rate,
                duration_min,
            } => temps.push(Temp {
                at_ms,
                rate,
                duration_min,
            }),
        }
    }
    if let (Some(now), false) = (now_ms, history.is_empty()) {
        temps.push(Temp {
            at_ms: now + 60_000,
            rate: 0.0,
            duration_min: 0.0,
        });
    }
    temps.sort_by_key(|t| t.at_ms);
    for i in 0..temps.len().saturating_sub(1) {
        let next = temps[i + 1].at_ms;
        if temps[i].at_ms as f64 + temps[i].duration_min * 60_000.0 > next as f64 {
            temps[i].duration_min = (next - temps[i].at_ms) as f64 / 60_000.0;
        }
    }
    let splitters: Vec<f64> = profile.basal.iter().map(|b| f64::from(b.minutes)).collect();
    let mut pieces: Vec<Temp> = temps
        .into_iter()
        .flat_map(|t| split(t, &splitters, clock))
        .collect();
    pieces.sort_by_key(|t| t.at_ms);
    for p in pieces {
        if p.duration_min <= 0.0 {
            continue;
        }
        let scheduled = profile.basal_at(clock.minute_of_day(p.at_ms));
        let net = p.rate - scheduled;
        let size = if net < 0.0 { -0.05 } else { 0.05 };
        let amount = js::round(net * p.duration_min * 10.0 / 6.0) / 100.0;
        let count = js::round(amount / size);
        if !matches!(
            count.partial_cmp(&1.0),
            Some(std::cmp::Ordering::Greater | std::cmp::Ordering::Equal)
        ) {
            continue;
        }
        let spacing = p.duration_min / count;
        for j in 0..count as i64 {
            out.push(Dose {
                at_ms: p.at_ms as f64 + j as f64 * spacing * 60_000.0,
                units: size,
            });
        }
    }
    // oref0 sorts all doses by time (stably) before summing.
    out.sort_by(|a, b| a.at_ms.total_cmp(&b.at_ms));
    out
}

/// (insulin on board in U rounded to 0.001, activity in U/min rounded to
/// 0.0001) at `t_ms`, as oref0's iob/total.js sums them.
pub fn iob_at(doses: &[Dose], model: &InsulinModel, t_ms: i64) -> (f64, f64) {
    let now = t_ms as f64;
    let dia_ago = now - model.dia_h * 3_600_000.0;
    let (mut iob, mut activity) = (0.0, 0.0);
    for d in doses {
        if d.at_ms <= now && d.at_ms > dia_ago {
            // new Date(fractional ms) keeps the integer part.
            let mins_ago = js::round((now - d.at_ms.trunc()) / 60_000.0);
            let (a, i) = model.at(d.units, mins_ago);
            iob += i;
            activity += a;
        }
    }
    (js::round_to(iob, 3), js::round_to(activity, 4))
}

/// Insulin delivered in (`start_ms`, `end_ms`] (boluses and the temps'
/// net pieces), rounded to 0.001 U (oref0's autotune-prep/dosed.js).
pub fn dosed(doses: &[Dose], start_ms: i64, end_ms: i64) -> f64 {
    let total: f64 = doses
        .iter()
        .filter(|d| d.at_ms > start_ms as f64 && d.at_ms <= end_ms as f64)
        .map(|d| d.units)
        .sum();
    js::round_to(total, 3)
}
