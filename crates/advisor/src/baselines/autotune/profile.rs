//! oref0's profile JSON (what `oref0-get-profile` writes and autotune reads
//! and writes): `basalprofile`, `isfProfile`, `carb_ratio`, `dia`, `curve`,
//! `insulinPeakTime`, `useCustomPeakTime`, `min_5m_carbimpact`,
//! `autosens_max`, `autosens_min`. The whole document is kept, so fields
//! autotune does not touch come back unchanged (as oref0 passes them on).

use super::curve::{Curve, InsulinModel};
use super::js;
use super::AutotuneError;
use abba_core::limits::{Limit, BASAL_U_PER_H, CARB_RATIO_G_PER_U, ISF_MG_DL_PER_U};
use serde_json::{json, Map, Value};

/// One entry of `basalprofile`.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct BasalEntry {
    /// `i`: the entry's index (oref0 sorts by it for lookups).
    pub i: i64,
    /// `minutes`: start, minutes after local midnight.
    pub minutes: u32,
    /// `rate` (U/h).
    pub rate: f64,
    /// `untuned`: how many runs left this hour without data (autotune's output).
    pub untuned: Option<u32>,
}

/// One entry of `isfProfile.sensitivities`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sensitivity {
    /// `offset`: start, minutes after local midnight.
    pub offset: u32,
    /// `sensitivity` (mg/dL/U).
    pub sensitivity: f64,
}

/// A parsed oref0 profile.
#[derive(Debug, Clone, PartialEq)]
pub struct Profile {
    /// `basalprofile`, in file order.
    pub basal: Vec<BasalEntry>,
    /// `isfProfile.sensitivities`, in file order.
    pub isf: Vec<Sensitivity>,
    /// `carb_ratio` (g/U).
    pub carb_ratio: Option<f64>,
    /// `dia` (h).
    pub dia_h: f64,
    /// `curve` (oref0's default when absent: bilinear).
    pub curve: Curve,
    /// `insulinPeakTime` (min).
    pub insulin_peak_min: Option<f64>,
    /// `useCustomPeakTime`.
    pub use_custom_peak: bool,
    /// `min_5m_carbimpact` (mg/dL per 5 min; oref0's default 8).
    pub min_5m_carbimpact: f64,
    /// `autosens_max` (oref0's default 1.2).
    pub autosens_max: f64,
    /// `autosens_min` (oref0's default 0.7).
    pub autosens_min: f64,
    /// The whole document.
    pub raw: Map<String, Value>,
}

fn err(path: impl Into<String>, problem: impl Into<String>) -> AutotuneError {
    AutotuneError::Profile {
        path: path.into(),
        problem: problem.into(),
    }
}

fn num(obj: &Map<String, Value>, path: &str, key: &str) -> Result<Option<f64>, AutotuneError> {
    match obj.get(key) {
        None | Some(Value::Null) => Ok(None),
        Some(Value::Number(n)) => Ok(n.as_f64()),
        Some(other) => Err(err(
            format!("{path}{key}"),
            format!("expected a number, got {other}"),
        )),
    }
}

fn limited(limit: &Limit, path: String, v: f64) -> Result<f64, AutotuneError> {
    limit.check(v).map_err(|e| err(path, e.to_string()))
}

fn minutes(path: String, v: Option<f64>) -> Result<u32, AutotuneError> {
    match v {
        Some(m) if (0.0..1440.0).contains(&m) && m.fract() == 0.0 => Ok(m as u32),
        Some(m) => Err(err(path, format!("expected whole minutes 0-1439, got {m}"))),
        None => Err(err(path, "missing")),
    }
}

/// mg/dL per mmol/L of an ISF, as `oref0-get-profile` converts a profile in
/// mmol/L (`sensitivity * 18`).
pub const OREF0_MG_DL_PER_MMOL_L: f64 = 18.0;

/// A Nightscout profile's schedule `key` (`[{time, value, timeAsSeconds}]`)
/// as (minute of the local day, value), sorted; the first must start at
/// 00:00.
fn schedule(
    p: &Map<String, Value>,
    path: &str,
    key: &str,
) -> Result<Vec<(u32, f64)>, AutotuneError> {
    let Some(Value::Array(items)) = p.get(key) else {
        return Err(err(
            format!("{path}.{key}"),
            "missing: expected [{time, value}]",
        ));
    };
    let mut out = Vec::with_capacity(items.len());
    for (n, e) in items.iter().enumerate() {
        let at = format!("{path}.{key}[{n}]");
        let Value::Object(e) = e else {
            return Err(err(at, "expected {time, value}"));
        };
        let m = match num(e, &format!("{at}."), "timeAsSeconds")? {
            Some(s) if s.fract() == 0.0 && (s as i64) % 60 == 0 => {
                minutes(format!("{at}.timeAsSeconds"), Some(s / 60.0))?
            }
            Some(s) => {
                return Err(err(
                    format!("{at}.timeAsSeconds"),
                    format!("expected whole minutes in seconds, got {s}"),
                ))
            }
            None => {
                let t = e.get("time").and_then(Value::as_str).unwrap_or("");
                let mut parts = t.split(':').map(|x| x.parse::<u32>().ok());
                match (parts.next().flatten(), parts.next().flatten()) {
                    (Some(h), Some(mi)) if h < 24 && mi < 60 => h * 60 + mi,
                    _ => {
                        return Err(err(
                            format!("{at}.time"),
                            format!("expected HH:MM, got \"{t}\""),
                        ))
                    }
                }
            }
        };
        let v = num(e, &format!("{at}."), "value")?
            .ok_or_else(|| err(format!("{at}.value"), "missing"))?;
        out.push((m, v));
    }
    out.sort_by_key(|e| e.0);
    if out.first().map(|e| e.0) != Some(0) {
        return Err(err(
            format!("{path}.{key}"),
            "expected a first entry at 00:00",
        ));
    }
    Ok(out)
}

/// The mean of a schedule over the day, each value weighted by the minutes
/// it is in force.
fn mean_over_day(s: &[(u32, f64)]) -> f64 {
    let total: f64 = s
        .iter()
        .enumerate()
        .map(|(i, &(m, v))| v * f64::from(s.get(i + 1).map_or(1440, |n| n.0) - m))
        .sum();
    total / 1440.0
}

impl Profile {
    /// Parses an oref0 profile document; every error names its JSON path.
    pub fn from_json(text: &str) -> Result<Self, AutotuneError> {
        let v: Value = serde_json::from_str(text).map_err(|e| err("$", e.to_string()))?;
        let Value::Object(raw) = v else {
            return Err(err("$", "expected an object (an oref0 profile)"));
        };
        Self::from_map(raw)
    }

    /// Parses an already-read document.
    pub fn from_map(raw: Map<String, Value>) -> Result<Self, AutotuneError> {
        let Some(Value::Array(basal)) = raw.get("basalprofile") else {
            return Err(err(
                "basalprofile",
                "missing: expected an array of {minutes, rate}",
            ));
        };
        let mut entries = Vec::with_capacity(basal.len());
        for (n, b) in basal.iter().enumerate() {
            let p = format!("basalprofile[{n}].");
            let Value::Object(b) = b else {
                return Err(err(format!("basalprofile[{n}]"), "expected an object"));
            };
            let m = minutes(format!("{p}minutes"), num(b, &p, "minutes")?)?;
            let rate = num(b, &p, "rate")?.ok_or_else(|| err(format!("{p}rate"), "missing"))?;
            let rate = limited(&BASAL_U_PER_H, format!("{p}rate"), rate)?;
            let i = num(b, &p, "i")?.map_or(n as i64, |i| i as i64);
            let untuned = num(b, &p, "untuned")?.map(|u| u as u32);
            entries.push(BasalEntry {
                i,
                minutes: m,
                rate,
                untuned,
            });
        }
        if !entries.iter().any(|e| e.minutes == 0) {
            return Err(err("basalprofile", "no entry starts at minutes 0"));
        }
        let Some(Value::Object(isf)) = raw.get("isfProfile") else {
            return Err(err(
                "isfProfile",
                "missing: expected {sensitivities: [...]}",
            ));
        };
        let Some(Value::Array(sens)) = isf.get("sensitivities") else {
            return Err(err(
                "isfProfile.sensitivities",
                "missing: expected an array",
            ));
        };
        let mut isf_entries = Vec::with_capacity(sens.len());
        for (n, s) in sens.iter().enumerate() {
            let p = format!("isfProfile.sensitivities[{n}].");
            let Value::Object(s) = s else {
                return Err(err(
                    format!("isfProfile.sensitivities[{n}]"),
                    "expected an object",
                ));
            };
            let offset = minutes(format!("{p}offset"), num(s, &p, "offset")?)?;
            let v = num(s, &p, "sensitivity")?
                .ok_or_else(|| err(format!("{p}sensitivity"), "missing"))?;
            let units = isf.get("units").and_then(Value::as_str).unwrap_or("mg/dL");
            if !units.eq_ignore_ascii_case("mg/dL") {
                return Err(err(
                    "isfProfile.units",
                    format!("autotune works in mg/dL; got \"{units}\" (convert the profile first)"),
                ));
            }
            isf_entries.push(Sensitivity {
                offset,
                sensitivity: limited(&ISF_MG_DL_PER_U, format!("{p}sensitivity"), v)?,
            });
        }
        if isf_entries.is_empty() {
            return Err(err("isfProfile.sensitivities", "empty"));
        }
        let carb_ratio = match num(&raw, "", "carb_ratio")? {
            Some(cr) => Some(limited(&CARB_RATIO_G_PER_U, "carb_ratio".into(), cr)?),
            None => None,
        };
        let dia_h = num(&raw, "", "dia")?.ok_or_else(|| err("dia", "missing (hours)"))?;
        if !(1.0..=24.0).contains(&dia_h) {
            return Err(err("dia", format!("expected 1-24 hours, got {dia_h}")));
        }
        let curve = match raw.get("curve") {
            None | Some(Value::Null) => Curve::Bilinear,
            Some(Value::String(s)) => Curve::parse(s).ok_or_else(|| {
                err(
                    "curve",
                    format!("expected bilinear, rapid-acting or ultra-rapid, got \"{s}\""),
                )
            })?,
            Some(other) => return Err(err("curve", format!("expected a string, got {other}"))),
        };
        let use_custom_peak = raw.get("useCustomPeakTime") == Some(&Value::Bool(true));
        let fraction = |key: &str, default: f64, lo: f64, hi: f64| -> Result<f64, AutotuneError> {
            let v = num(&raw, "", key)?.unwrap_or(default);
            if (lo..=hi).contains(&v) {
                Ok(v)
            } else {
                Err(err(key, format!("expected {lo}-{hi}, got {v}")))
            }
        };
        let autosens_max = fraction("autosens_max", 1.2, 1.0, 3.0)?;
        let autosens_min = fraction("autosens_min", 0.7, 0.1, 1.0)?;
        let min_5m_carbimpact = fraction("min_5m_carbimpact", 8.0, 0.0, 100.0)?;
        Ok(Self {
            basal: entries,
            isf: isf_entries,
            carb_ratio,
            dia_h,
            curve,
            insulin_peak_min: num(&raw, "", "insulinPeakTime")?,
            use_custom_peak,
            min_5m_carbimpact,
            autosens_max,
            autosens_min,
            raw,
        })
    }

    /// A profile of one flat basal rate, one ISF and one carb ratio (the
    /// trial's therapy), exponential rapid-acting curve.
    pub fn flat(basal: f64, isf: f64, carb_ratio: f64, dia_h: f64) -> Result<Self, AutotuneError> {
        Self::from_schedule(&[(0, basal)], isf, carb_ratio, dia_h)
    }

    /// A profile of a basal schedule (`(minute of the local day, U/h)`, the
    /// first at minute 0), one ISF (mg/dL/U) and one carb ratio (g/U), the
    /// exponential rapid-acting curve with oref0's defaults for the rest
    /// (peak 75 min unused, `min_5m_carbimpact` 8, autosens 0.7-1.2).
    pub fn from_schedule(
        basal: &[(u32, f64)],
        isf: f64,
        carb_ratio: f64,
        dia_h: f64,
    ) -> Result<Self, AutotuneError> {
        let entries: Vec<Value> = basal
            .iter()
            .enumerate()
            .map(|(i, &(m, rate))| {
                json!({"i": i, "start": format!("{:02}:{:02}:00", m / 60, m % 60),
                       "minutes": m, "rate": rate})
            })
            .collect();
        let doc = json!({
            "basalprofile": entries,
            "isfProfile": {"units": "mg/dL", "sensitivities": [
                {"i": 0, "start": "00:00:00", "offset": 0, "x": 0, "endOffset": 1440, "sensitivity": isf}]},
            "carb_ratio": carb_ratio,
            "dia": dia_h,
            "curve": "rapid-acting",
            "useCustomPeakTime": false,
            "insulinPeakTime": 75,
            "min_5m_carbimpact": 8,
            "autosens_max": 1.2,
            "autosens_min": 0.7,
        });
        match doc {
            Value::Object(m) => Self::from_map(m),
            _ => Err(err("$", "not an object")),
        }
    }

    /// An oref0 profile from a Nightscout profile store (`api/v1/profile`:
    /// an array of documents, or one document): the newest document's
    /// `defaultProfile`, its basal schedule, ISF schedule, carb ratio and
    /// DIA, with oref0's defaults for what a Nightscout profile does not
    /// hold (the rapid-acting curve, peak 75 min unused,
    /// `min_5m_carbimpact` 8, autosens 0.7-1.2), as `from_schedule` makes
    /// them. An ISF in mmol/L is converted as `oref0-get-profile` converts
    /// one ([`OREF0_MG_DL_PER_MMOL_L`]); the units must be given. Several
    /// carb ratios become their mean over the day, weighted by the hours
    /// each is in force (oref0 tunes one). Returns what was taken, one line
    /// each; every error names its JSON path.
    pub fn from_nightscout(v: &Value) -> Result<(Self, Vec<String>), AutotuneError> {
        let docs: Vec<(String, &Map<String, Value>)> = match v {
            Value::Array(items) => items
                .iter()
                .enumerate()
                .map(|(k, d)| match d {
                    Value::Object(o) => Ok((format!("$[{k}]"), o)),
                    _ => Err(err(
                        format!("$[{k}]"),
                        "expected a profile document (an object)",
                    )),
                })
                .collect::<Result<_, _>>()?,
            Value::Object(o) => vec![("$".to_string(), o)],
            _ => {
                return Err(err(
                    "$",
                    "expected an oref0 profile (an object) or a Nightscout profile store (an array of documents)",
                ))
            }
        };
        // The newest by `mills` (Nightscout's own order is newest first).
        let (path, doc) = docs
            .iter()
            .enumerate()
            .max_by(|(i, a), (j, b)| {
                let mills = |d: &Map<String, Value>| d.get("mills").and_then(Value::as_f64);
                mills(a.1)
                    .partial_cmp(&mills(b.1))
                    .unwrap_or(std::cmp::Ordering::Equal)
                    .then(j.cmp(i))
            })
            .map(|(_, d)| d.clone())
            .ok_or_else(|| err("$", "no profile document"))?;
        let name = doc
            .get("defaultProfile")
            .and_then(Value::as_str)
            .ok_or_else(|| err(format!("{path}.defaultProfile"), "missing: expected a name"))?;
        let store_path = format!("{path}.store.{name}");
        let Some(Value::Object(p)) = doc.get("store").and_then(|s| s.get(name)) else {
            return Err(err(
                &store_path,
                "missing: the default profile is not in the store",
            ));
        };
        let units = p
            .get("units")
            .or_else(|| doc.get("units"))
            .and_then(Value::as_str)
            .ok_or_else(|| {
                err(
                    format!("{store_path}.units"),
                    "missing: expected mg/dl or mmol (the ISF's unit is never guessed)",
                )
            })?;
        let per_unit = match units.to_ascii_lowercase().as_str() {
            "mg/dl" | "mgdl" | "mg" => 1.0,
            "mmol" | "mmol/l" => OREF0_MG_DL_PER_MMOL_L,
            other => {
                return Err(err(
                    format!("{store_path}.units"),
                    format!("expected mg/dl or mmol, got \"{other}\""),
                ))
            }
        };
        let basal = schedule(p, &store_path, "basal")?;
        let sens = schedule(p, &store_path, "sens")?;
        let ratios = schedule(p, &store_path, "carbratio")?;
        let dia_h = num(p, &format!("{store_path}."), "dia")?
            .ok_or_else(|| err(format!("{store_path}.dia"), "missing (hours)"))?;
        let carb_ratio = js::round_to(mean_over_day(&ratios), 3);
        let mut profile = Self::from_schedule(&basal, sens[0].1 * per_unit, carb_ratio, dia_h)?;
        let isf: Vec<Value> = sens
            .iter()
            .enumerate()
            .map(|(i, &(m, v))| {
                let end = sens.get(i + 1).map_or(1440, |n| n.0);
                json!({"i": i, "start": format!("{:02}:{:02}:00", m / 60, m % 60), "offset": m,
                       "x": i, "endOffset": end, "sensitivity": v * per_unit})
            })
            .collect();
        profile.raw.insert(
            "isfProfile".into(),
            json!({"units": "mg/dL", "sensitivities": isf}),
        );
        let profile = Self::from_map(profile.raw)?;
        let mut said = vec![format!(
            "profile: Nightscout profile \"{name}\" of {path}{}: {} basal segment(s), {} ISF segment(s){}, carb ratio {}, DIA {dia_h} h; oref0's defaults for the rest (rapid-acting curve, min_5m_carbimpact 8, autosens 0.7-1.2)",
            p.get("timezone")
                .and_then(Value::as_str)
                .map_or(String::new(), |z| format!(" (its schedules in {z}'s hours)")),
            basal.len(),
            sens.len(),
            if per_unit == 1.0 { String::new() } else { format!(" converted from mmol/L x {OREF0_MG_DL_PER_MMOL_L}") },
            carb_ratio,
        )];
        if ratios.len() > 1 {
            said.push(format!(
                "profile: {} carb ratios ({}) taken as their mean over the day, weighted by the hours each is in force: {} g/U (oref0 tunes one)",
                ratios.len(),
                ratios
                    .iter()
                    .map(|&(m, r)| format!("{:02}:{:02} {r}", m / 60, m % 60))
                    .collect::<Vec<_>>()
                    .join(", "),
                carb_ratio,
            ));
        }
        Ok((profile, said))
    }

    /// The insulin model the profile asks for.
    pub fn insulin(&self) -> InsulinModel {
        let custom = if self.use_custom_peak {
            self.insulin_peak_min
        } else {
            None
        };
        InsulinModel::new(self.curve, self.dia_h, custom)
    }

    /// oref0's basalLookup: the rate at a local minute of the day, rounded to 0.001.
    pub fn basal_at(&self, minute_of_day: u32) -> f64 {
        let mut sorted: Vec<&BasalEntry> = self.basal.iter().collect();
        sorted.sort_by_key(|e| e.i);
        let mut rate = sorted.last().map_or(0.0, |e| e.rate);
        for w in sorted.windows(2) {
            if minute_of_day >= w[0].minutes && minute_of_day < w[1].minutes {
                rate = w[0].rate;
                break;
            }
        }
        js::round_to(rate, 3)
    }

    /// oref0's isfLookup: the sensitivity at a local minute of the day
    /// (sorted by offset; the first must start at 0).
    pub fn isf_at(&self, minute_of_day: u32) -> f64 {
        let mut sorted = self.isf.clone();
        sorted.sort_by_key(|s| s.offset);
        if sorted[0].offset != 0 {
            return -1.0;
        }
        let mut sens = sorted[sorted.len() - 1].sensitivity;
        for w in sorted.windows(2) {
            if minute_of_day >= w[0].offset && minute_of_day < w[1].offset {
                sens = w[0].sensitivity;
                break;
            }
        }
        sens
    }

    /// The first ISF (the one oref0's autotune tunes).
    pub fn first_isf(&self) -> f64 {
        self.isf[0].sensitivity
    }

    /// oref0's hourly view of the basal schedule: for each hour the last
    /// entry (in file order) starting at or before it, rate rounded to 0.001.
    pub fn hourly(&self) -> [BasalEntry; 24] {
        std::array::from_fn(|h| {
            let mut e = self.basal[0].clone();
            for b in &self.basal {
                if b.minutes <= h as u32 * 60 {
                    e = b.clone();
                }
            }
            BasalEntry {
                i: h as i64,
                minutes: h as u32 * 60,
                rate: js::round_to(e.rate, 3),
                untuned: e.untuned,
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn store(units: &str, extra: Value) -> Value {
        let mut p = json!({
            "dia": 5, "units": units,
            "carbratio": [{"time": "00:00", "value": 10, "timeAsSeconds": 0}],
            "sens": [{"time": "00:00", "value": 45, "timeAsSeconds": 0}],
            "basal": [{"time": "00:00", "value": 0.9, "timeAsSeconds": 0},
                      {"time": "07:30", "value": 1.2}],
        });
        for (k, v) in extra.as_object().unwrap() {
            p[k] = v.clone();
        }
        json!([{"defaultProfile": "Old", "mills": 1, "store": {"Old": {}}},
               {"defaultProfile": "Default", "mills": 2, "store": {"Default": p}}])
    }

    #[test]
    fn a_nightscout_profile_store_becomes_an_oref0_profile() {
        let (p, said) = Profile::from_nightscout(&store("mg/dl", json!({}))).unwrap();
        let want = Profile::from_schedule(&[(0, 0.9), (450, 1.2)], 45.0, 10.0, 5.0).unwrap();
        assert_eq!(p.basal, want.basal);
        assert_eq!(p.isf, want.isf);
        assert_eq!(
            (p.carb_ratio, p.dia_h, p.curve),
            (Some(10.0), 5.0, Curve::RapidActing)
        );
        assert_eq!(
            (p.autosens_min, p.autosens_max, p.min_5m_carbimpact),
            (0.7, 1.2, 8.0)
        );
        // The newest document (by `mills`), whatever its place.
        assert!(said[0].contains("\"Default\" of $[1]"), "{said:?}");
        // mmol/L: every ISF entry times 18, as oref0-get-profile converts;
        // carb ratios: their mean over the day, by the hours in force.
        let (p, said) = Profile::from_nightscout(&store(
            "mmol",
            json!({"sens": [{"time": "00:00", "value": 2.5}, {"time": "12:00", "value": 3.0}],
                   "carbratio": [{"time": "00:00", "value": 10}, {"time": "06:00", "value": 14}]}),
        ))
        .unwrap();
        assert_eq!(
            p.isf,
            [
                Sensitivity {
                    offset: 0,
                    sensitivity: 45.0
                },
                Sensitivity {
                    offset: 720,
                    sensitivity: 54.0
                }
            ]
        );
        assert_eq!(p.carb_ratio, Some(13.0));
        assert_eq!(p.raw["isfProfile"]["sensitivities"][0]["endOffset"], 720);
        assert!(
            said.iter().any(|l| l.contains("mean over the day")),
            "{said:?}"
        );
    }

    #[test]
    fn a_nightscout_profile_that_cannot_be_read_names_its_field() {
        let e = |v: Value| match Profile::from_nightscout(&v) {
            Err(AutotuneError::Profile { path, .. }) => path,
            other => panic!("expected an error, got {other:?}"),
        };
        let mut no_units = store("mg/dl", json!({}));
        no_units[1]["store"]["Default"]
            .as_object_mut()
            .unwrap()
            .remove("units");
        assert_eq!(e(no_units), "$[1].store.Default.units");
        assert_eq!(e(store("mmol/kg", json!({}))), "$[1].store.Default.units");
        assert_eq!(
            e(store(
                "mg/dl",
                json!({"basal": [{"time": "7:3x", "value": 1}]})
            )),
            "$[1].store.Default.basal[0].time"
        );
        assert_eq!(
            e(store(
                "mg/dl",
                json!({"sens": [{"time": "01:00", "value": 40}]})
            )),
            "$[1].store.Default.sens"
        );
        assert_eq!(
            e(store(
                "mg/dl",
                json!({"sens": [{"time": "00:00", "value": 4000}]})
            )),
            "isfProfile.sensitivities[0].sensitivity"
        );
        assert_eq!(e(json!([{"store": {}}])), "$[0].defaultProfile");
        assert_eq!(e(json!("profile.json")), "$");
        assert_eq!(e(json!([1])), "$[0]");
    }
}
