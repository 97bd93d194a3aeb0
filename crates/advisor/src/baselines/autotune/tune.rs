//! The nightly step (oref0 0.7.1 lib/autotune/index.js): hourly basals from
//! the basal data's deviations, spread over the three hours before; the
//! carb ratio from the carb-ratio periods; the carb sensitivity factor from
//! the absorption stretches; the ISF from the median ratio of deviation to
//! insulin impact; each moved 20 % toward what the day implies and capped
//! between `autosens_min` and `autosens_max` times the pump profile's value.

use super::js;
use super::prep::{Datum, Prepped};
use super::profile::{BasalEntry, Profile};
use super::LocalClock;
use serde_json::{json, Value};

/// The tuned values, with what the pump profile had.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Tuned {
    /// The 24 tuned hourly basals (with `untuned` counts).
    pub basal: Vec<BasalEntry>,
    /// The pump profile's hourly basals.
    pub pump_basal: Vec<f64>,
    /// Tuned ISF (mg/dL/U).
    pub isf: f64,
    /// Pump ISF.
    pub pump_isf: f64,
    /// Tuned carb ratio (g/U).
    pub carb_ratio: f64,
    /// Pump carb ratio.
    pub pump_carb_ratio: f64,
    /// Tuned carb sensitivity factor (mg/dL per g).
    pub csf: f64,
    /// Duration of insulin action (h), unchanged.
    pub dia_h: f64,
    /// Insulin peak (min) as oref0 writes it back.
    pub peak_min: f64,
    /// What happened, one line each (oref0's log, shortened).
    pub notes: Vec<String>,
}

/// oref0's percentile (lib/percentile.js): linear between ranks at n·p.
fn percentile(sorted: &[f64], p: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let index = sorted.len() as f64 * p;
    let lower = index.floor() as usize;
    let weight = index % 1.0;
    if lower + 1 >= sorted.len() {
        return sorted[lower.min(sorted.len() - 1)];
    }
    sorted[lower] * (1.0 - weight) + sorted[lower + 1] * weight
}

/// `v.sort((a, b) => a - b)` in node's order: a ratio of a reading without
/// insulin activity is NaN (0 / 0), which that comparator cannot order.
fn sorted(mut v: Vec<f64>) -> Vec<f64> {
    super::js_sort::sort_by(&mut v, |a, b| a - b);
    v
}

/// The ISF data's ratios `1 + deviation / BGI`, in the order oref0's sort
/// leaves them. oref0's core reads BGI back with parseFloat (from the
/// prepped JSON), which has no -0: a reading without insulin activity
/// divides by +0 (`+ 0.0` turns our -0.0 into +0.0), so its ratio is +∞
/// for a rise, −∞ for a fall and NaN for none.
fn isf_ratios(isf: &[Datum]) -> Vec<f64> {
    sorted(
        isf.iter()
            .map(|d| 1.0 + d.deviation / (d.bgi + 0.0))
            .collect(),
    )
}

/// One autotune step from `previous` (the profile tuned so far, with the
/// pump's `dia`, `curve` and peak already applied) and the day's `prepped`
/// data, capped relative to `pump`.
pub fn tune(
    prepped: &Prepped,
    previous: &Profile,
    pump: &Profile,
    clock: &dyn LocalClock,
) -> Tuned {
    let mut notes = Vec::new();
    let pump_isf = pump.first_isf();
    let pump_cr = pump.carb_ratio.unwrap_or(f64::NAN);
    let pump_csf = pump_isf / pump_cr;
    let isf = previous.first_isf();
    let carb_ratio = previous.carb_ratio.unwrap_or(pump_cr);
    let mut csf = isf / carb_ratio;
    if !csf.is_finite() || csf == 0.0 {
        csf = pump_csf;
    }
    // oref0 writes the raw custom peak back, or its curve's default.
    let peak = match (previous.use_custom_peak, previous.curve) {
        (true, _) => previous.insulin_peak_min.unwrap_or(75.0),
        (false, super::curve::Curve::UltraRapid) => 55.0,
        (false, _) => 75.0,
    };
    let (max_f, min_f) = (pump.autosens_max, pump.autosens_min);

    // Carb ratio from the carb-ratio periods.
    let (mut cr_carbs, mut cr_insulin) = (0.0, 0.0);
    for d in &prepped.cr {
        let total = d.initial_iob + d.insulin + (d.end_bg - d.initial_bg) / isf;
        if total > 0.0 {
            cr_carbs += d.carbs;
            cr_insulin += total;
        }
    }
    let cr_insulin = js::round_to(cr_insulin, 3);
    let total_cr = js::round_to(cr_carbs / cr_insulin, 3);

    // Hourly basals.
    let old = previous.hourly();
    let pump_hourly = pump.hourly();
    let mut new = old.clone();
    for hour in 0..24u32 {
        let sum: f64 = prepped
            .basal
            .iter()
            .filter(|d| clock.minute_of_day(d.at_ms) / 60 == hour)
            .map(|d| d.deviation)
            .sum();
        let deviations = js::round_to(sum, 3);
        let needed = js::round_to(0.2 * deviations / isf, 2);
        let before = |offset: u32| ((hour + 24 - offset) % 24) as usize;
        if needed > 0.0 {
            for off in [3, 2, 1] {
                let h = before(off);
                new[h].rate = js::round_to(new[h].rate + needed / 3.0, 3);
            }
        } else if needed < 0.0 {
            let three: f64 = [3, 2, 1].iter().map(|&o| new[before(o)].rate).sum();
            let ratio = 1.0 + needed / three;
            for off in [3, 2, 1] {
                let h = before(off);
                new[h].rate = js::round_to(new[h].rate * ratio, 3);
            }
        }
    }
    for h in 0..24 {
        let (lo, hi) = (pump_hourly[h].rate * min_f, pump_hourly[h].rate * max_f);
        if new[h].rate > hi {
            notes.push(format!(
                "hour {h}: basal limited to {hi:.2} ({max_f} × pump {})",
                pump_hourly[h].rate
            ));
            new[h].rate = hi;
        } else if new[h].rate < lo {
            notes.push(format!(
                "hour {h}: basal limited to {lo:.2} ({min_f} × pump {})",
                pump_hourly[h].rate
            ));
            new[h].rate = lo;
        }
        new[h].rate = js::round_to(new[h].rate, 3);
    }
    // Hours without data move toward the tuned hours around them.
    let mut last_adjusted = 0;
    for h in 0..24 {
        if old[h].rate == new[h].rate {
            let next = (h..24).find(|&n| old[n].rate != new[n].rate).unwrap_or(23);
            new[h].rate = js::round_to(
                0.8 * old[h].rate + 0.1 * new[last_adjusted].rate + 0.1 * new[next].rate,
                3,
            );
            new[h].untuned = Some(new[h].untuned.map_or(1, |u| u + 1));
        } else {
            last_adjusted = h;
        }
    }

    // Carb sensitivity factor from the absorption stretches.
    let (mut dev, mut meal_carbs, mut total_carbs, mut total_dev) = (0.0, 0.0, 0.0, 0.0);
    for d in &prepped.csf {
        match d.meal_absorption {
            Some(super::prep::Absorption::Start) => {
                dev = 0.0;
                meal_carbs = js::int(d.meal_carbs);
            }
            Some(super::prep::Absorption::End) => {
                dev += d.deviation;
                total_carbs += meal_carbs;
                total_dev += dev;
            }
            None => {
                dev += d.deviation.max(0.0);
                meal_carbs = f64::max(meal_carbs, js::int(d.meal_carbs));
            }
        }
    }
    if total_carbs == 0.0 {
        total_carbs += meal_carbs;
    }
    if total_dev == 0.0 {
        total_dev += dev;
    }
    let full_csf = if total_carbs == 0.0 {
        csf
    } else {
        js::round_to(total_dev / total_carbs, 2)
    };
    let mut new_csf = 0.8 * csf + 0.2 * full_csf;
    if pump_csf.is_finite() {
        new_csf = new_csf.clamp_like(pump_csf * min_f, pump_csf * max_f);
    }
    let new_csf = js::round_to(new_csf, 3);
    if new_csf != 0.0 && new_csf.is_finite() {
        csf = new_csf;
    }

    // Carb ratio: 20 % toward the day's, within the caps (and 3-150 g/U).
    let full_cr = if total_cr == 0.0 {
        carb_ratio
    } else {
        total_cr
    };
    let max_cr = (pump_cr * max_f).min(150.0);
    let min_cr = (pump_cr * min_f).max(3.0);
    let full_cr = full_cr.clamp_like(min_cr, max_cr);
    let new_cr = js::round_to(
        (0.8 * carb_ratio + 0.2 * full_cr).clamp_like(min_cr, max_cr),
        3,
    );
    let carb_ratio = if new_cr != 0.0 && new_cr.is_finite() {
        new_cr
    } else {
        notes.push("no carb-ratio period: carb ratio unchanged".into());
        carb_ratio
    };

    // ISF from the median ratio of deviation to insulin impact.
    let ratios = isf_ratios(&prepped.isf);
    let p50 = js::round_to(percentile(&ratios, 0.5), 3);
    let full_isf = if prepped.isf.len() < 10 {
        notes.push(format!(
            "only {} ISF data points: ISF left at {isf}",
            prepped.isf.len()
        ));
        isf
    } else {
        isf * p50
    };
    let full_isf = js::round_to(full_isf, 3);
    let fraction = pump
        .raw
        .get("autotune_isf_adjustmentFraction")
        .and_then(Value::as_f64)
        .unwrap_or(1.0);
    let (max_isf, min_isf) = (pump_isf / min_f, pump_isf / max_f);
    let adjusted = if full_isf < 0.0 {
        isf
    } else {
        fraction * full_isf + (1.0 - fraction) * pump_isf
    }
    .clamp_like(min_isf, max_isf);
    let new_isf = js::round_to((0.8 * isf + 0.2 * adjusted).clamp_like(min_isf, max_isf), 3);
    let isf = if new_isf != 0.0 && new_isf.is_finite() {
        new_isf
    } else {
        isf
    };

    Tuned {
        basal: new.to_vec(),
        pump_basal: pump_hourly.iter().map(|e| e.rate).collect(),
        isf,
        pump_isf,
        carb_ratio: js::round_to(carb_ratio, 3),
        pump_carb_ratio: pump_cr,
        csf,
        dia_h: previous.dia_h,
        peak_min: peak,
        notes,
    }
}

/// A number as JavaScript writes it (whole numbers without a fraction).
fn js_num(x: f64) -> Value {
    if x.fract() == 0.0 && x.abs() < 9.0e15 {
        json!(x as i64)
    } else {
        json!(x)
    }
}

/// oref0's caps: above `hi` → `hi`, else below `lo` → `lo` (NaN passes).
trait ClampLike {
    fn clamp_like(self, lo: f64, hi: f64) -> f64;
}

impl ClampLike for f64 {
    fn clamp_like(self, lo: f64, hi: f64) -> f64 {
        if self > hi {
            hi
        } else if self < lo {
            lo
        } else {
            self
        }
    }
}

impl Tuned {
    /// The tuned profile in oref0's JSON shape: `previous`'s document with
    /// `basalprofile`, `isfProfile`, `sens`, `csf`, `carb_ratio`, `dia` and
    /// `insulinPeakTime` replaced (as oref0-autotune-core writes it).
    pub fn to_json(&self, previous: &Profile) -> Value {
        let mut doc = previous.raw.clone();
        let basal: Vec<Value> = self
            .basal
            .iter()
            .map(|e| {
                let mut v = json!({
                    "i": e.i,
                    "minutes": e.minutes,
                    "start": format!("{:02}:00:00", e.minutes / 60),
                    "rate": js_num(e.rate),
                });
                if let (Some(u), Value::Object(m)) = (e.untuned, &mut v) {
                    m.insert("untuned".into(), json!(u));
                }
                v
            })
            .collect();
        doc.insert("basalprofile".into(), Value::Array(basal));
        let mut isf = doc.get("isfProfile").cloned().unwrap_or_else(|| json!({}));
        if let Some(Value::Object(first)) = isf.get_mut("sensitivities").and_then(|s| s.get_mut(0))
        {
            first.insert("sensitivity".into(), js_num(self.isf));
        }
        doc.insert("isfProfile".into(), isf);
        doc.insert("sens".into(), js_num(self.isf));
        doc.insert("csf".into(), js_num(self.csf));
        doc.insert("carb_ratio".into(), js_num(self.carb_ratio));
        doc.insert("dia".into(), js_num(self.dia_h));
        doc.insert("insulinPeakTime".into(), js_num(self.peak_min));
        Value::Object(doc)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::baselines::autotune::Category;

    fn datum(deviation: f64, bgi: f64) -> Datum {
        Datum {
            at_ms: 0,
            glucose: 120.0,
            avg_delta: deviation + bgi,
            bgi,
            deviation,
            category: Category::Isf,
            meal_absorption: None,
            meal_carbs: 0.0,
        }
    }

    /// A BGI of -0 (no insulin activity) divides as +0, as it does in
    /// oref0's core: a rise is +∞, not −∞, and the median moves with it
    /// (benches/autotune_oref0/differential.py's case 19 before: ISF 49.467
    /// against oref0's 53).
    #[test]
    fn a_bgi_of_minus_zero_divides_as_plus_zero() {
        let mut data = vec![datum(2.0, -0.0), datum(3.0, -0.0), datum(-1.0, -0.0)];
        data.extend((0..4).map(|i| datum(-0.5 * f64::from(i), -2.0)));
        let r = isf_ratios(&data);
        assert_eq!(r.len(), 7);
        assert_eq!(r[0], f64::NEG_INFINITY, "{r:?}");
        assert_eq!(&r[5..], &[f64::INFINITY, f64::INFINITY], "{r:?}");
        assert_eq!(percentile(&r, 0.5), 1.625, "{r:?}");
        // 0 / 0 is NaN, kept where node's sort leaves it.
        assert!(isf_ratios(&[datum(0.0, -0.0)])[0].is_nan());
    }
}
