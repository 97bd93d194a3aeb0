//! The person report's input (`abba_report::html::person`), assembled from
//! the store (for `abba report --person` and the app's `/report`):
//! the last `days` days with data, read from the store's device events
//! (on the advisor's clock: day 1 = the person's first day, local time) and
//! its suggestion history.

use crate::{Store, StoreError};
use abba_core::units::GlucoseUnit;
use abba_core::{EventKind, MINUTES_PER_DAY};
use abba_report::html::person::{
    MealTime, PersonDay, PersonReportInput, Reading, SettingsInForce, SuggestionLine,
};

/// Reads person `name` from `store`: the `days` days ending at the last day
/// with data.
pub fn person_input(
    store: &mut Store,
    name: &str,
    days: u32,
    unit: GlucoseUnit,
) -> Result<PersonReportInput, StoreError> {
    if days == 0 {
        return Err(StoreError::Invalid {
            field: "--days".into(),
            problem: "must be at least 1".into(),
        });
    }
    let person = store.person(name)?;
    let mode = person.mode();
    let events = store.events(name)?;
    // A report only reads (nothing stored, no write lock taken).
    let history = store.history_read(name, unit)?;
    let (Some(first_day), Some(last)) = (person.first_day, events.last()) else {
        return Err(StoreError::NoData(name.to_string()));
    };
    let last_index = last.at.day_index();
    let first_index = (last_index - i64::from(days) + 1).max(events[0].at.day_index());
    let n = (last_index - first_index + 1) as usize;
    let date = |i: i64| -> Result<String, StoreError> {
        first_day
            .checked_add(jiff::Span::new().days(i))
            .map(|d| d.to_string())
            .map_err(|e| StoreError::Corrupt {
                what: format!("day {} of person '{name}'", i + 1),
                detail: e.to_string(),
            })
    };
    let mut out = Vec::with_capacity(n);
    for k in 0..n as i64 {
        out.push(PersonDay {
            date: date(first_index + k)?,
            readings: Vec::new(),
            settings: None,
            basal_u: None,
            bolus_u: None,
            carbs_g: Some(0.0),
            meals: Vec::new(),
            rescue_g: None,
        });
    }
    // Insulin delivered, from the pump's records: the scheduled rate (as
    // the profile's segments give it) unless a temporary basal or a
    // suspension says otherwise, boluses and extended boluses. A day with
    // no pump record (bolus, temporary basal, suspension) gets no total:
    // a schedule is not a delivery.
    let mut pump_day = vec![false; n];
    let mut sched = person.settings.start.basal.0;
    let mut temp: Option<(abba_core::TempBasalRate, i64)> = None;
    let mut suspended = false;
    let mut since = first_index * MINUTES_PER_DAY;
    let rate_at =
        |sched: f64, temp: &Option<(abba_core::TempBasalRate, i64)>, suspended: bool, t: i64| {
            if suspended {
                return 0.0;
            }
            match temp {
                Some((abba_core::TempBasalRate::UnitsPerHour(r), end)) if t < *end => r.0,
                Some((abba_core::TempBasalRate::Percent(p), end)) if t < *end => sched * p / 100.0,
                _ => sched,
            }
        };
    let add_basal = |out: &mut Vec<PersonDay>,
                     from: i64,
                     to: i64,
                     sched: f64,
                     temp: &Option<(abba_core::TempBasalRate, i64)>,
                     suspended: bool| {
        let mut t = from.max(first_index * MINUTES_PER_DAY);
        while t < to {
            let day = t.div_euclid(MINUTES_PER_DAY);
            // Pieces end at midnight and where a temporary basal ends.
            let mut end = to.min((day + 1) * MINUTES_PER_DAY);
            if let Some((_, e)) = temp {
                if *e > t && *e < end {
                    end = *e;
                }
            }
            if let Some(d) = out.get_mut((day - first_index) as usize) {
                *d.basal_u.get_or_insert(0.0) +=
                    rate_at(sched, temp, suspended, t) * (end - t) as f64 / 60.0;
            }
            t = end;
        }
    };
    let mut same_minute = SameMinute::default();
    for e in &events {
        let t = e.at.minutes();
        let k = usize::try_from(e.at.day_index() - first_index).ok();
        match e.kind {
            EventKind::BasalRate(_)
            | EventKind::TempBasal { .. }
            | EventKind::Suspend
            | EventKind::Resume => {
                if k.is_some() {
                    add_basal(&mut out, since, t, sched, &temp, suspended);
                }
                since = t;
                match e.kind {
                    EventKind::BasalRate(r) => sched = r.0,
                    EventKind::TempBasal { rate, duration_min } => {
                        temp = (duration_min > 0).then_some((rate, t + i64::from(duration_min)))
                    }
                    EventKind::Suspend => suspended = true,
                    EventKind::Resume => suspended = false,
                    _ => {}
                }
                if let (Some(k), false) = (k, matches!(e.kind, EventKind::BasalRate(_))) {
                    pump_day[k] = true;
                }
                continue;
            }
            _ => {}
        }
        let Some(k) = k else {
            continue;
        };
        let day = &mut out[k];
        let minute_of_day = e.at.minute_of_day() as u32;
        match e.kind {
            EventKind::Cgm(g) if mode == abba_advisor::Mode::Cgm => {
                same_minute.push(day, t * 60, minute_of_day, g.0)
            }
            EventKind::Smbg(g) if mode == abba_advisor::Mode::Smbg => {
                same_minute.push(day, t * 60, minute_of_day, g.0)
            }
            EventKind::MealAnnounced { carbs, slot } => {
                *day.carbs_g.get_or_insert(0.0) += carbs.0;
                day.meals.push(MealTime {
                    at_s: t * 60,
                    minute_of_day,
                    slot,
                    carbs_g: Some(carbs.0),
                });
            }
            EventKind::Bolus(u) => {
                *day.bolus_u.get_or_insert(0.0) += u.0;
                pump_day[k] = true;
            }
            EventKind::ExtendedBolus { total, .. } => {
                *day.bolus_u.get_or_insert(0.0) += total.0;
                pump_day[k] = true;
            }
            _ => {}
        }
    }
    add_basal(
        &mut out,
        since,
        (last_index + 1) * MINUTES_PER_DAY,
        sched,
        &temp,
        suspended,
    );
    for (d, pump) in out.iter_mut().zip(&pump_day) {
        if !pump {
            d.basal_u = None;
            d.bolus_u = None;
        }
    }
    // Hypoglycaemia treatments, from the records (they are not meals); the
    // records are dropped before the advice is built (a long log's are
    // large).
    {
        let records = store.used_records(name)?.records;
        let rescue = abba_io::rescue::Rescue::new(&records);
        let clock = abba_io::clock::AdvisorClock::new(person.tz.clone(), first_day);
        for r in &records {
            if let abba_io::RecordKind::Carbs { grams } = r.kind {
                if rescue.is_rescue(r.at) {
                    let k = clock.timestamp(r.at).day_index() - first_index;
                    if let Some(d) = usize::try_from(k).ok().and_then(|k| out.get_mut(k)) {
                        *d.rescue_g.get_or_insert(0.0) += grams.0;
                    }
                }
            }
        }
    }
    let advice = store.advise_read(name, unit)?;
    let mut notes = Vec::new();
    if same_minute.merged > 0 {
        notes.push(format!(
            "{} readings were taken in the same minute as another (a finger-stick checked \
             again, two sources of one sensor): the log keeps time to the minute, so the \
             report shows each minute's mean.",
            same_minute.merged
        ));
    }
    if let Some(note) = &advice.delivery.note {
        notes.push(note.clone());
        if !advice.delivery.evidence.is_empty() {
            notes.push(format!(
                "Evidence: {}.",
                advice.delivery.evidence.join("; ")
            ));
        }
    }

    // What the advice says about the data (readings at the device's
    // limit, hypoglycaemia treatments, meals outside their windows, zones)
    // and the rows it left out.
    notes.extend(advice.notes.iter().cloned());
    if advice.data.records_not_used > 0 {
        notes.push(abba_advisor::words::records_left_out(
            advice.data.records_not_used,
            &advice.data.not_used_examples,
        ));
    }
    if let Some(schedule) = &advice.therapy.basal_schedule {
        notes.push(abba_advisor::words::basal_schedule_in_force(schedule));
    }

    // Settings in force by day: the start, then each answered suggestion's
    // value from the day it is for.
    let mut settings = person.settings.start;
    let mut views = history.iter().filter(|v| !v.no_update).peekable();
    let mut suggestions = Vec::new();
    for k in 0..n as i64 {
        let day_number = first_index + k + 1;
        while let Some(v) = views.next_if(|v| v.day <= day_number) {
            // A suggestion still waiting for an answer (or held back by
            // the twin check) is not in force.
            let value = match v.status.as_str() {
                "open" | "held_back" => v.previous,
                _ => v.in_force,
            };
            match v.setting {
                "basal" => settings.basal.0 = value,
                "breakfast" => settings.carb_ratio[0].0 = value,
                "lunch" => settings.carb_ratio[1].0 = value,
                "dinner" => settings.carb_ratio[2].0 = value,
                _ => {}
            }
            if v.day > first_index {
                suggestions.push(line(v));
            }
        }
        out[k as usize].settings = Some(SettingsInForce {
            basal_u_per_h: settings.basal.0,
            carb_ratio_g_per_u: settings.carb_ratio.map(|c| c.0),
        });
    }
    Ok(PersonReportInput {
        person: name.to_string(),
        mode,
        unit,
        days: out,
        suggestions,
        notes,
        back: None,
    })
}

/// A suggestion in words.
fn line(v: &crate::advise::SuggestionView) -> SuggestionLine {
    let setting = abba_advisor::words::setting_name(v.setting);
    let mut answer = abba_advisor::words::answer_words(&v.status, v.in_force, v.unit);
    // An answer a later import changed the suggestion of: said, both values.
    if let Some(n) = &v.answer_note {
        answer = format!("{answer} {n}");
    }
    let mut reason = v.reasons.join(" ");
    if reason.is_empty() {
        reason.clone_from(&v.data);
    }
    SuggestionLine {
        when: v.decided_at.clone(),
        setting,
        from: format!("{:.3} {}", v.previous, v.unit),
        to: match &v.schedule {
            Some(sch) => format!(
                "{:.3} {} ({:+.1} %): {}",
                v.suggested,
                v.unit,
                v.change_percent,
                abba_advisor::words::schedule(sch)
            ),
            None => format!("{:.3} {} ({:+.1} %)", v.suggested, v.unit, v.change_percent),
        },
        reason,
        answer,
    }
}

/// Readings of one minute, as the report shows them: the log keeps time
/// to the minute, so two readings in one minute (a finger-stick checked
/// again seconds later, a sensor's reading from two sources) cannot be
/// ordered; the report shows their mean and counts them.
#[derive(Default)]
struct SameMinute {
    /// Readings in the last reading's minute so far.
    count: usize,
    /// Readings merged into an earlier one of their minute.
    merged: usize,
}

impl SameMinute {
    fn push(&mut self, day: &mut PersonDay, at_s: i64, minute_of_day: u32, mg_dl: f64) {
        match day.readings.last_mut() {
            Some(last) if last.at_s == at_s => {
                self.count += 1;
                last.mg_dl += (mg_dl - last.mg_dl) / self.count as f64;
                self.merged += 1;
            }
            _ => {
                self.count = 1;
                day.readings.push(Reading {
                    at_s,
                    minute_of_day,
                    mg_dl,
                });
            }
        }
    }
}
