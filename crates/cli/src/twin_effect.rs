//! The person's stored twin as the store's [`EffectPredictor`]: what
//! `abba advise`, `abba report` and `abba serve` put beside each open
//! suggestion. Never fits: it reads the twin `abba twin fit` stored beside
//! the store file, uses it only when its grade is usable and it was fitted
//! on exactly the log the advice was built from, and replays the last
//! [`EFFECT_DAYS`] days of its window with the suggestion against the
//! recorded days. Replays are kept per (person, log hash, twin revision,
//! setting, values), so a service answers a repeated request from memory;
//! and each person's last twin read is kept with the runs under the
//! recorded settings its replays share, so a day's other suggestions
//! replay in half the runs.
//!
//! [`TwinRefits`] is the store's [`TwinRefitter`]: what `abba serve`'s refit
//! worker calls after a person's log changed. It refits a person who has a
//! twin (never one who has none) by abba-twin's refit rule
//! ([`abba_twin::file::refit`]), with the stored twin's window, held-out
//! days and population.

use abba_advisor::Parameter;
use abba_store::effect::{
    Band, Effect, EffectPredictor, EffectQuery, Figures, NoPrediction, Predicted, RefitOutcome,
    TwinCheck, TwinRefitter,
};
use abba_twin::{Banded, Grade, Ranges, WhatIf};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// Recent days a suggestion is replayed on.
pub const EFFECT_DAYS: usize = 7;

/// Replays kept at most (then the memory starts again).
const CACHE_MAX: usize = 4096;

/// Persons whose last twin read is kept at most (then they start again).
const TWINS_MAX: usize = 256;

type Key = (String, String, u32, &'static str, u64, u64);

/// The store file twins are kept beside, or why there is none: twins live
/// in a folder beside a store *file* (`abba_twin::file`), so a PostgreSQL
/// store (a URL) has none yet, and a folder named after a URL would hold
/// its password in a path.
pub fn twins_beside(db: &Path) -> Result<&Path, String> {
    if abba_store::backend::postgres::is_url(&db.to_string_lossy()) {
        return Err(format!(
            "twins are kept in a folder beside a store file, and {} is a PostgreSQL store: \
             not yet supported there (copy the store into a file with `abba store copy` to fit and replay twins)",
            abba_store::backend::shown(db)
        ));
    }
    Ok(db)
}

/// Twins beside a store file.
#[derive(Debug)]
pub struct TwinPredictor {
    /// The store file, or why twins are not kept for this store.
    db: Result<PathBuf, String>,
    cache: Mutex<HashMap<Key, Effect>>,
    /// Each person's twin as last read, with the runs its replays keep.
    twins: Mutex<HashMap<String, std::sync::Arc<abba_twin::Twin>>>,
}

impl TwinPredictor {
    /// The twins beside `db` (none for a PostgreSQL store: [`twins_beside`]).
    pub fn new(db: &Path) -> Self {
        Self {
            db: twins_beside(db).map(Path::to_path_buf),
            cache: Mutex::new(HashMap::new()),
            twins: Mutex::new(HashMap::new()),
        }
    }
}

/// `--twin-check on|off`.
pub fn twin_check(on_off: &str) -> anyhow::Result<TwinCheck> {
    match on_off {
        "on" => Ok(TwinCheck::default()),
        "off" => Ok(TwinCheck {
            on: false,
            ..TwinCheck::default()
        }),
        other => anyhow::bail!("--twin-check {other}: expected on or off"),
    }
}

fn band(b: &Banded, f: fn(&Ranges) -> f64) -> Band {
    Band {
        value: f(&b.value),
        low: f(&b.low),
        high: f(&b.high),
    }
}

fn figures(b: &Banded) -> Figures {
    Figures {
        tir_pct: band(b, |r| r.tir_pct),
        below_70_pct: band(b, |r| r.below_70_pct),
    }
}

/// The what-if of one suggestion: its setting times suggested / in force.
fn what_if(q: &EffectQuery<'_>) -> WhatIf {
    let meal = match q.parameter {
        Parameter::Basal => None,
        Parameter::CarbRatio(slot) => Some(slot),
    };
    WhatIf::one_setting(meal, q.suggested / q.in_force)
}

impl EffectPredictor for TwinPredictor {
    fn predict(&self, q: &EffectQuery<'_>) -> Effect {
        let db = match &self.db {
            Ok(db) => db,
            Err(_) => return Effect::None(NoPrediction::NotAvailable),
        };
        let twin = match abba_twin::file::load(db, q.person) {
            Ok(Some(t)) => t,
            Ok(None) => return Effect::None(NoPrediction::NoTwin),
            Err(e) => {
                return Effect::None(NoPrediction::Failed {
                    reason: e.to_string(),
                })
            }
        };
        if twin.grade == Grade::NotUsable {
            return Effect::None(NoPrediction::NotUsable {
                reason: twin.grade_reason,
            });
        }
        let hash = abba_twin::twin::events_hash(q.events);
        if hash != twin.data.events_hash {
            return Effect::None(NoPrediction::Outdated {
                revision: twin.revision,
            });
        }
        let key: Key = (
            q.person.to_string(),
            hash,
            twin.revision,
            abba_store::answer::param_key(q.parameter),
            q.in_force.to_bits(),
            q.suggested.to_bits(),
        );
        if let Some(e) = self
            .cache
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
            .get(&key)
        {
            return e.clone();
        }
        // The twin read before for this person when it is the same fit
        // (its kept runs are then this one's), else this one, kept.
        let twin = {
            let mut twins = self
                .twins
                .lock()
                .unwrap_or_else(std::sync::PoisonError::into_inner);
            match twins.get(q.person) {
                Some(kept) if **kept == twin => kept.clone(),
                _ => {
                    if twins.len() >= TWINS_MAX {
                        twins.clear();
                    }
                    let twin = std::sync::Arc::new(twin);
                    twins.insert(q.person.to_string(), twin.clone());
                    twin
                }
            }
        };
        let days = EFFECT_DAYS.min(twin.data.days);
        let effect = match twin.replay(q.events, &what_if(q), days) {
            Ok(r) => Effect::Predicted(Predicted {
                days: r.days,
                twin_revision: twin.revision,
                grade: twin.grade.name().to_string(),
                in_force: figures(&r.twin_recorded),
                suggested: figures(&r.twin_what_if),
                change: figures(&r.change),
            }),
            Err(e) => Effect::None(NoPrediction::Failed {
                reason: e.to_string(),
            }),
        };
        let mut cache = self
            .cache
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner);
        if cache.len() >= CACHE_MAX {
            cache.clear();
        }
        cache.insert(key, effect.clone());
        effect
    }
}

/// Refits the twins beside a store file (`abba serve`'s refit worker).
#[derive(Debug)]
pub struct TwinRefits {
    /// The store file; `None` for a PostgreSQL store, which has no twins.
    db: Option<PathBuf>,
}

impl TwinRefits {
    /// The twins beside `db` (none for a PostgreSQL store: [`twins_beside`]).
    pub fn new(db: &Path) -> Self {
        Self {
            db: twins_beside(db).ok().map(Path::to_path_buf),
        }
    }
}

impl TwinRefitter for TwinRefits {
    fn has_twin(&self, person: &str) -> bool {
        self.db
            .as_ref()
            .is_some_and(|db| abba_twin::file::path(db, person).is_file())
    }

    fn refit(&self, store: &abba_store::Store, person: &str) -> Result<RefitOutcome, String> {
        let Some(db) = &self.db else {
            return Ok(RefitOutcome::NoTwin);
        };
        let Some(old) = abba_twin::file::load(db, person).map_err(|e| e.to_string())? else {
            return Ok(RefitOutcome::NoTwin);
        };
        let p = store.person(person).map_err(|e| e.to_string())?;
        let events = store.events(person).map_err(|e| e.to_string())?;
        let options = abba_twin::TwinOptions {
            days: old.data.days,
            held_out_days: old.data.held_out_days,
            population: old.prior.population,
            basal_in_force_u_per_h: p.settings.start.basal.0,
            units: p.settings.units,
            ..abba_twin::TwinOptions::default()
        };
        match abba_twin::file::refit(db, person, &events, &options, false)
            .map_err(|e| e.to_string())?
        {
            abba_twin::file::Refit::Unchanged(t) => Ok(RefitOutcome::Unchanged {
                revision: t.revision,
            }),
            abba_twin::file::Refit::Stored { twin, .. } => Ok(RefitOutcome::Refitted {
                revision: twin.revision,
                grade: twin.grade.name().to_string(),
            }),
        }
    }
}
