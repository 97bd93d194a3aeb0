//! ABBA for people who put it in their own loop: feed device events, get
//! settings back at decision points.

use crate::value_error;
use abba_advisor::{Abba, AbbaConfig, Advisor, Mode};
use abba_core::{
    Event, EventKind, Grams, GramsPerUnit, MealSlot, MgDl, TherapySettings, Timestamp, Units,
    UnitsPerHour,
};
use pyo3::prelude::*;

pub(crate) fn register(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_class::<AbbaCore>()?;
    Ok(())
}

/// Settings as (basal U/h, [breakfast, lunch, dinner] g/U).
type Settings = (f64, [f64; 3]);

fn settings(s: &TherapySettings) -> Settings {
    (
        s.basal.0,
        [s.carb_ratio[0].0, s.carb_ratio[1].0, s.carb_ratio[2].0],
    )
}

/// The ABBA advisor (see `abba.advisor.Abba`).
#[pyclass(module = "abba._abba")]
pub struct AbbaCore {
    inner: Abba,
}

impl AbbaCore {
    fn feed(&mut self, minute: i64, kind: EventKind) -> PyResult<Option<Settings>> {
        let out = self
            .inner
            .observe(&Event::new(Timestamp(minute), kind))
            .map_err(value_error)?;
        Ok(out.as_ref().map(settings))
    }
}

#[pymethods]
impl AbbaCore {
    /// A new advisor in `mode` (`cgm` or `smbg`) starting from the person's
    /// therapy; `config_json` sets every knob (`AbbaConfig` as JSON).
    #[new]
    #[pyo3(signature = (basal_u_per_h, carb_ratio_g_per_u, mode = "cgm", exploration_seed = 0, config_json = None))]
    fn new(
        basal_u_per_h: f64,
        carb_ratio_g_per_u: [f64; 3],
        mode: &str,
        exploration_seed: u64,
        config_json: Option<&str>,
    ) -> PyResult<Self> {
        let mode = match mode {
            "cgm" => Mode::Cgm,
            "smbg" => Mode::Smbg,
            _ => return Err(value_error(format!("mode '{mode}': expected cgm or smbg"))),
        };
        let mut config = match config_json {
            Some(j) => serde_json::from_str::<AbbaConfig>(j)
                .map_err(|e| value_error(format!("config: not an ABBA configuration: {e}")))?,
            None => AbbaConfig::new(mode, exploration_seed),
        };
        config.mode = mode;
        config.exploration_seed = exploration_seed;
        let start = TherapySettings {
            basal: UnitsPerHour(basal_u_per_h),
            carb_ratio: carb_ratio_g_per_u.map(GramsPerUnit),
        };
        start.validate().map_err(value_error)?;
        Ok(Self {
            inner: Abba::new(config, start).map_err(value_error)?,
        })
    }

    /// A CGM reading (mg/dL) at `minute` (minutes since 00:00 of day 1).
    fn cgm(&mut self, minute: i64, mg_dl: f64) -> PyResult<Option<Settings>> {
        self.feed(minute, EventKind::Cgm(MgDl(mg_dl)))
    }

    /// A finger-stick reading (mg/dL).
    fn smbg(&mut self, minute: i64, mg_dl: f64) -> PyResult<Option<Settings>> {
        self.feed(minute, EventKind::Smbg(MgDl(mg_dl)))
    }

    /// A meal announcement (g) for `slot` (breakfast, lunch, dinner, snack);
    /// answers with that meal's carb ratio after the update.
    fn meal(&mut self, minute: i64, carbs_g: f64, slot: &str) -> PyResult<Option<Settings>> {
        let slot = match slot {
            "breakfast" => MealSlot::Breakfast,
            "lunch" => MealSlot::Lunch,
            "dinner" => MealSlot::Dinner,
            "snack" => MealSlot::Snack,
            _ => {
                return Err(value_error(format!(
                    "slot '{slot}': expected breakfast, lunch, dinner or snack"
                )))
            }
        };
        self.feed(
            minute,
            EventKind::MealAnnounced {
                carbs: Grams(carbs_g),
                slot,
            },
        )
    }

    /// Bolus insulin delivered (U).
    fn bolus(&mut self, minute: i64, units: f64) -> PyResult<Option<Settings>> {
        self.feed(minute, EventKind::Bolus(Units(units)))
    }

    /// The basal rate in force from now on (U/h).
    fn basal(&mut self, minute: i64, u_per_h: f64) -> PyResult<Option<Settings>> {
        self.feed(minute, EventKind::BasalRate(UnitsPerHour(u_per_h)))
    }

    /// The day closed (SMBG mode: after the bedtime reading; CGM mode: at midnight).
    fn day_closed(&mut self, minute: i64) -> PyResult<Option<Settings>> {
        self.feed(minute, EventKind::DayClosed)
    }

    /// The settings in force: (basal U/h, [breakfast, lunch, dinner] g/U).
    #[getter]
    fn settings(&self) -> Settings {
        settings(self.inner.settings())
    }

    /// Whether the initialisation week is over.
    #[getter]
    fn initialised(&self) -> bool {
        self.inner.is_initialised()
    }

    /// The decisions since the last call, with their explanations, as JSON lines.
    fn take_decisions_json(&mut self) -> PyResult<Vec<String>> {
        self.inner
            .take_decisions()
            .iter()
            .map(|d| serde_json::to_string(d).map_err(value_error))
            .collect()
    }

    /// The whole advisor state as JSON (resume with `load_json`).
    fn save_json(&self) -> PyResult<String> {
        self.inner.save_json().map_err(value_error)
    }

    /// An advisor resumed from `save_json` output.
    #[staticmethod]
    fn load_json(json: &str) -> PyResult<Self> {
        Ok(Self {
            inner: Abba::load_json(json).map_err(value_error)?,
        })
    }
}
