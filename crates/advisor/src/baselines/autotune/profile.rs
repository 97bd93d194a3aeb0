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
