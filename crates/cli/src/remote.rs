//! One simulated patient through a live abba service, over HTTP: the
//! reference client playing the pump app (issue 11).
//!
//! The in-process loop (`abba_trial::closed_loop`) hands each event of the
//! [`VirtualPerson`] to the advisor and each answer back to the person.
//! Here the advisor is the service's: the app gives each event the next
//! number of its own counter and keeps it in an [`Outbox`]; at each event
//! that can produce an answer (a main-meal announcement, a day closing) it
//! flushes the outbox (one `POST .../events` for everything since the last
//! flush), puts the suggestions of the acknowledgement in force exactly as
//! the in-process loop puts the advisor's settings in force
//! ([`VirtualPerson::suggest`]), and tells the service what the person did
//! with each (`POST .../answers`: the paper's person accepts every change;
//! a person who rejects or overrides some says so). A post that gets no
//! answer is retried; once the service answers again the app syncs
//! (`GET .../sync`), re-sends only what the service does not hold and
//! fetches the suggestions whose acknowledgement was lost.
//!
//! With the person created by [`person_body`] (the trial's ABBA
//! configuration and exploration seed, day 1 = `first_day` in UTC, no
//! minimum-data rule), the service makes exactly the decisions the trial's
//! ABBA arm makes for the same patient and seed (the end-to-end test in
//! `crates/cli/tests/app_e2e.rs` checks it for 98 days in CGM and SMBG
//! mode).
//!
//! It lives in the CLI (`abba app`), not in abba-trial, so that the trial
//! and the Python wheel built on it know no HTTP. The integration tests
//! that drive a service compile this file as their own module (`#[path]`),
//! so it names nothing of the CLI.

use abba_advisor::any::AdvisorSpec;
use abba_advisor::Parameter;
use abba_api::{
    AnswerBody, AnswerItem, AnswerKind, EventBody, MinDataBody, NewPersonBody, Setting, Suggestion,
    TempRate, TherapyBody,
};
use abba_client::{post_answers, Client, ClientError, Outbox, OutboxStats, Retry};
use abba_core::{
    derive_seed, Event, EventKind, GramsPerUnit, MealSlot, SettingValue, Stream, TempBasalRate,
    TherapySettings, UnitsPerHour, MINUTES_PER_DAY,
};
use abba_sim::cohort::VirtualPatient;
use abba_sim::person::{SuggestionResponse, VirtualPerson};
use abba_trial::protocol::{ArmKind, PlannedScenario, TrialConfig};
use abba_trial::results::RunFailure;
use abba_trial::TrialError;

/// What can go wrong in a run through the service.
#[derive(Debug, thiserror::Error)]
pub enum RemoteError {
    /// The trial's configuration, simulator or advisor failed.
    #[error(transparent)]
    Trial(#[from] TrialError),
    /// The service refused or did not answer.
    #[error("{context}: {source}")]
    Service {
        /// Which patient and scenario, and the service.
        context: String,
        /// The client's error.
        #[source]
        source: Box<ClientError>,
    },
    /// The person answered a setting the service has no name for (a snack
    /// carb ratio: the service suggests only the basal and the three main
    /// meals' ratios).
    #[error("the service has no setting for {0}")]
    NoSetting(String),
}

/// Where and as whom the app talks to the service.
#[derive(Debug, Clone)]
pub struct RemoteApp {
    /// A client with the person's token (or the admin's).
    pub client: Client,
    /// The person's id in the service.
    pub person: u64,
    /// The date simulated day 1 is (UTC): event instants are its 00:00Z
    /// plus the simulation's minutes.
    pub first_day: jiff::civil::Date,
    /// How long to keep trying when the service does not answer.
    pub retry: Retry,
}

/// What a run through the service did.
#[derive(Debug, Clone)]
pub struct RemoteRun {
    /// Every suggestion the service answered with, in the order received.
    pub suggestions: Vec<Suggestion>,
    /// Flushes (decision points reached, plus the final one).
    pub flushes: u64,
    /// Answers the app posted (the person's acceptances, rejections and
    /// overrides).
    pub answers_posted: u64,
    /// Answer posts that needed another attempt (an acknowledgement lost)
    /// and were then acknowledged, stored once.
    pub answers_recovered: u64,
    /// The outbox's counters (posts, failures, syncs, events).
    pub outbox: OutboxStats,
    /// Where the run stopped, if plasma glucose fell below the trial's
    /// failure threshold.
    pub failure: Option<RunFailure>,
    /// The settings the person follows at the end.
    pub final_settings: TherapySettings,
    /// Time spent waiting for event acknowledgements (flushes).
    pub events_wait: std::time::Duration,
    /// Time spent waiting for answer acknowledgements.
    pub answers_wait: std::time::Duration,
}

fn remote_err(context: &str) -> impl Fn(ClientError) -> RemoteError + '_ {
    move |source| RemoteError::Service {
        context: context.to_string(),
        source: Box::new(source),
    }
}

/// The ABBA configuration (with the patient's exploration seed) the trial
/// uses for patient `patient_no` in `scenario`.
pub fn abba_config(
    config: &TrialConfig,
    patient_no: u64,
    scenario: &PlannedScenario,
) -> Result<abba_advisor::AbbaConfig, TrialError> {
    let AdvisorSpec::Abba(mut c) = config.advisor_spec(ArmKind::Abba, scenario.mode) else {
        return Err(TrialError::Config(
            "the ABBA arm's advisor is not ABBA".into(),
        ));
    };
    c.exploration_seed = derive_seed(
        config.seed,
        patient_no,
        scenario.config.random_key,
        Stream::Exploration,
    );
    Ok(c)
}

/// The `POST /v1/persons` body that makes the service advise `vp` as the
/// trial's ABBA arm does: the trial's ABBA configuration and exploration
/// seed, the cohort's starting therapy, zone UTC, day 1 = `first_day`, no
/// minimum-data rule (the trial has none), no clinician bounds.
pub fn person_body(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &PlannedScenario,
    first_day: jiff::civil::Date,
    name: &str,
) -> Result<NewPersonBody, TrialError> {
    let abba = abba_config(config, patient_no, scenario)?;
    let advisor = serde_json::to_value(&abba)
        .map_err(|e| TrialError::Config(format!("the ABBA configuration as JSON: {e}")))?;
    let t = vp.therapy;
    Ok(NewPersonBody {
        name: name.to_string(),
        tz: "UTC".into(),
        mode: match scenario.mode {
            abba_advisor::Mode::Cgm => abba_api::Mode::Cgm,
            abba_advisor::Mode::Smbg => abba_api::Mode::Smbg,
        },
        first_day: Some(first_day.to_string()),
        start: TherapyBody {
            basal_units_per_hour: t.basal.0,
            carb_ratio_g_per_unit: [t.carb_ratio[0].0, t.carb_ratio[1].0, t.carb_ratio[2].0],
        },
        bounds: None,
        pump_steps: None,
        continuous_values: true,
        min_data: Some(MinDataBody {
            cgm_coverage: 0.0,
            cgm_period_min: 5,
            smbg_per_day: 0,
            smbg_per_meal: 0,
        }),
        advisor: Some(advisor),
        age_group: None,
    })
}

/// The simulated person of the trial for patient `patient_no` (1-based) in
/// `scenario`, answering suggestions as `config.suggestions` says.
pub fn trial_person(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &PlannedScenario,
) -> Result<VirtualPerson, TrialError> {
    let mut behaviour = TrialConfig::behaviour(scenario.mode);
    behaviour.suggestions = config.suggestions;
    VirtualPerson::new(
        vp,
        patient_no,
        &scenario.config,
        config.seed,
        &config.devices,
        behaviour,
    )
    .map_err(|source| TrialError::Sim {
        context: format!("{} {}", vp.params.name, scenario.config.name),
        source,
    })
}

/// The instant of simulation minute `minutes` (RFC 3339, UTC).
fn instant(day1: jiff::Timestamp, minutes: i64) -> Result<String, TrialError> {
    day1.checked_add(jiff::SignedDuration::from_mins(minutes))
        .map(|t| t.to_string())
        .map_err(|e| TrialError::Config(format!("simulation minute {minutes}: {e}")))
}

/// The wire form of a device event (`None` for the person's answers to
/// suggestions, which go to `POST .../answers` instead).
pub fn wire_event(kind: &EventKind) -> Result<Option<EventBody>, TrialError> {
    let slot = |s: MealSlot| match s {
        MealSlot::Breakfast => abba_api::MealSlot::Breakfast,
        MealSlot::Lunch => abba_api::MealSlot::Lunch,
        MealSlot::Dinner => abba_api::MealSlot::Dinner,
        MealSlot::Snack => abba_api::MealSlot::Snack,
    };
    Ok(Some(match *kind {
        EventKind::Cgm(g) => EventBody::Cgm { mg_dl: g.0 },
        EventKind::Smbg(g) => EventBody::Smbg { mg_dl: g.0 },
        EventKind::MealAnnounced { carbs, slot: s } => EventBody::Meal {
            carbs_g: carbs.0,
            slot: slot(s),
        },
        EventKind::Bolus(u) => EventBody::Bolus { units: u.0 },
        EventKind::BasalRate(r) => EventBody::BasalRate {
            units_per_hour: r.0,
        },
        EventKind::DayClosed => EventBody::DayClosed,
        EventKind::TempBasal { rate, duration_min } => EventBody::TempBasal {
            rate: match rate {
                TempBasalRate::UnitsPerHour(r) => TempRate::UnitsPerHour(r.0),
                TempBasalRate::Percent(p) => TempRate::Percent(p),
            },
            duration_min,
        },
        EventKind::Suspend => EventBody::Suspend,
        EventKind::Resume => EventBody::Resume,
        EventKind::ExtendedBolus {
            total,
            immediate,
            duration_min,
        } => EventBody::ExtendedBolus {
            total_units: total.0,
            immediate_units: immediate.0,
            duration_min,
        },
        EventKind::SuggestionAccepted(_)
        | EventKind::SuggestionRejected(_)
        | EventKind::SuggestionOverridden(_) => return Ok(None),
        ref other => {
            return Err(TrialError::Config(format!(
                "the app cannot send a {} event (no /v1 form)",
                other.name()
            )))
        }
    }))
}

/// True for the events after which the app flushes and waits for answers.
pub fn produces_answer(kind: &EventKind) -> bool {
    match kind {
        EventKind::MealAnnounced { slot, .. } => slot.main_index().is_some(),
        EventKind::DayClosed => true,
        _ => false,
    }
}

/// `settings` with each suggestion's value put in force.
pub fn apply(settings: &mut TherapySettings, answers: &[Suggestion]) {
    for a in answers {
        match a.parameter {
            Setting::Basal => settings.basal = UnitsPerHour(a.value),
            Setting::Breakfast => settings.carb_ratio[0] = GramsPerUnit(a.value),
            Setting::Lunch => settings.carb_ratio[1] = GramsPerUnit(a.value),
            Setting::Dinner => settings.carb_ratio[2] = GramsPerUnit(a.value),
        }
    }
}

/// The setting an answer event is about, as the service names it.
fn setting_of(v: &SettingValue) -> Result<Setting, RemoteError> {
    let p = match *v {
        SettingValue::Basal { .. } => Parameter::Basal,
        SettingValue::CarbRatio { slot, .. } => Parameter::CarbRatio(slot),
    };
    setting(p).ok_or_else(|| RemoteError::NoSetting(format!("an answer to the {p}")))
}

/// The answer the person's answer event says, to the latest suggestion of
/// its setting among `latest` (`None` for another event, or when no
/// suggestion of that setting was received); an answer to a setting the
/// service has no name for is an error, never sent as another setting's.
fn answer_item(e: &Event, latest: &[Suggestion]) -> Result<Option<AnswerItem>, RemoteError> {
    let (v, answer, value) = match e.kind {
        EventKind::SuggestionAccepted(v) => (v, AnswerKind::Accept, None),
        EventKind::SuggestionRejected(v) => (v, AnswerKind::Reject, None),
        EventKind::SuggestionOverridden(v) => (v, AnswerKind::Override, Some(v.number())),
        _ => return Ok(None),
    };
    let setting = setting_of(&v)?;
    Ok(latest
        .iter()
        .rev()
        .find(|s| s.parameter == setting)
        .map(|s| AnswerItem {
            suggestion_id: s.id,
            answer,
            value,
        }))
}

/// Runs `days` days of patient `vp` (number `patient_no`) in `scenario`
/// with the service's advisor (see the module docs); the person must have
/// been created with [`person_body`] and have no events yet.
pub fn run_remote(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &PlannedScenario,
    app: &RemoteApp,
) -> Result<RemoteRun, RemoteError> {
    let context = format!(
        "{} {} via {}",
        vp.params.name,
        scenario.config.name,
        app.client.base_url()
    );
    let err = remote_err(&context);
    let sim = |source| TrialError::Sim {
        context: context.clone(),
        source,
    };
    let mut person = trial_person(config, vp, patient_no, scenario)?;
    let day1 = app
        .first_day
        .to_zoned(jiff::tz::TimeZone::UTC)
        .map_err(|e| TrialError::Config(format!("first day {}: {e}", app.first_day)))?
        .timestamp();
    let accept_all = config.suggestions == SuggestionResponse::AcceptAll;
    let mut outbox = Outbox::new(app.person);
    let mut run = RemoteRun {
        suggestions: Vec::new(),
        flushes: 0,
        answers_posted: 0,
        answers_recovered: 0,
        outbox: OutboxStats::default(),
        failure: None,
        final_settings: *person.settings(),
        events_wait: std::time::Duration::ZERO,
        answers_wait: std::time::Duration::ZERO,
    };
    let mut latest: Vec<Suggestion> = Vec::new();
    let mut answers: Vec<AnswerItem> = Vec::new();
    'days: for day in 0..scenario.config.days as usize {
        for m in 0..MINUTES_PER_DAY as usize {
            let plasma = person.plasma_glucose_mg_dl();
            if plasma < config.failure_glucose_mg_dl {
                run.failure = Some(RunFailure {
                    day: day as u32 + 1,
                    minute_of_day: m as u32,
                    glucose_mg_dl: plasma,
                });
                break 'days;
            }
            person.begin_minute().map_err(sim)?;
            while let Some(event) = person.next_event().map_err(sim)? {
                let Some(body) = wire_event(&event.kind)? else {
                    answers.extend(answer_item(&event, &latest)?);
                    continue;
                };
                outbox.push(instant(day1, event.at.0)?, body);
                if !produces_answer(&event.kind) {
                    continue;
                }
                run.flushes += 1;
                let t = std::time::Instant::now();
                let flushed = outbox.flush(&app.client, &app.retry).map_err(&err)?;
                run.events_wait += t.elapsed();
                if flushed.answers.is_empty() {
                    continue;
                }
                let mut settings = *person.settings();
                apply(&mut settings, &flushed.answers);
                person.suggest(settings).map_err(sim)?;
                if accept_all {
                    // The paper's person takes every change; the app says so
                    // (as a person who answers says nothing of a suggestion
                    // that changes nothing).
                    answers.extend(
                        flushed
                            .answers
                            .iter()
                            .filter(|s| s.value != s.previous)
                            .map(|s| AnswerItem {
                                suggestion_id: s.id,
                                answer: AnswerKind::Accept,
                                value: None,
                            }),
                    );
                }
                latest.clone_from(&flushed.answers);
                run.suggestions.extend(flushed.answers);
            }
            for chunk in std::mem::take(&mut answers).chunks(4) {
                let body = AnswerBody {
                    answers: chunk.to_vec(),
                };
                run.answers_posted += body.answers.len() as u64;
                let t = std::time::Instant::now();
                let posted =
                    post_answers(&app.client, app.person, &body, &app.retry).map_err(&err)?;
                run.answers_wait += t.elapsed();
                if matches!(
                    posted,
                    abba_client::AnswersPosted::AlreadyStored
                        | abba_client::AnswersPosted::AckedAfterRetry(_)
                ) {
                    run.answers_recovered += body.answers.len() as u64;
                }
            }
            person.finish_minute().map_err(sim)?;
        }
    }
    run.flushes += 1;
    let last = outbox.flush(&app.client, &app.retry).map_err(&err)?;
    run.suggestions.extend(last.answers);
    run.outbox = outbox.stats();
    run.final_settings = *person.settings();
    Ok(run)
}

/// A patient of the configuration's cohort by name, with its number
/// (1-based).
pub fn cohort_patient(
    config: &TrialConfig,
    name: &str,
) -> Result<(VirtualPatient, u64), TrialError> {
    let cohort = abba_trial::runner::build_cohort(config)?;
    let names = || {
        cohort
            .patients
            .iter()
            .map(|p| p.params.name.as_str())
            .collect::<Vec<_>>()
            .join(", ")
    };
    let i = cohort
        .patients
        .iter()
        .position(|p| p.params.name == name)
        .ok_or_else(|| {
            TrialError::Config(format!(
                "no patient '{name}' in the cohort (patients: {})",
                names()
            ))
        })?;
    Ok((cohort.patients[i].clone(), i as u64 + 1))
}

/// Every decision the in-process trial's ABBA arm makes for the same
/// patient in the same scenario (the reference for a run through the
/// service).
pub fn in_process_decisions(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &PlannedScenario,
) -> Result<Vec<abba_advisor::Decision>, TrialError> {
    let mut trace = abba_trial::closed_loop::Trace {
        decisions: Some(Vec::new()),
        ..Default::default()
    };
    abba_trial::closed_loop::run_patient_with(
        config,
        vp,
        patient_no,
        scenario,
        ArmKind::Abba,
        &mut trace,
    )?;
    Ok(trace.decisions.unwrap_or_default())
}

/// The service's setting for an advisor parameter; `None` for a snack's
/// carb ratio, which the service neither suggests nor takes answers for
/// (it is never answered as another meal's).
pub fn setting(p: Parameter) -> Option<Setting> {
    match p {
        Parameter::Basal => Some(Setting::Basal),
        Parameter::CarbRatio(MealSlot::Breakfast) => Some(Setting::Breakfast),
        Parameter::CarbRatio(MealSlot::Lunch) => Some(Setting::Lunch),
        Parameter::CarbRatio(MealSlot::Dinner) => Some(Setting::Dinner),
        Parameter::CarbRatio(MealSlot::Snack) => None,
    }
}

/// Compares the in-process decisions with the service's suggestions by
/// (minute, setting, value before, value after), exactly. Returns how many
/// agree, or the first difference in words.
pub fn compare(
    decisions: &[abba_advisor::Decision],
    suggestions: &[Suggestion],
) -> Result<usize, String> {
    for (k, (d, s)) in decisions.iter().zip(suggestions).enumerate() {
        let (minute, param) = Setting::from_suggestion_id(s.id);
        let Some(wanted) = setting(d.parameter) else {
            return Err(format!(
                "decision {k} in process is about the {}, which the service has no setting for",
                d.parameter
            ));
        };
        let want = (d.at.0, wanted, d.old, d.new);
        let got = (minute as i64, param, s.previous, s.value);
        if want != got {
            return Err(format!(
                "suggestion {k} differs: in process (minute, setting, old, new) = {want:?}, through the service {got:?}"
            ));
        }
    }
    if decisions.len() != suggestions.len() {
        return Err(format!(
            "{} decisions in process, {} suggestions through the service (the first {} agree)",
            decisions.len(),
            suggestions.len(),
            decisions.len().min(suggestions.len())
        ));
    }
    Ok(decisions.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use abba_advisor::{Decision, DecisionDetail, SkipReason};
    use abba_core::Timestamp;

    fn suggestion(minute: u64, parameter: Setting) -> Suggestion {
        Suggestion {
            id: parameter.suggestion_id(minute),
            seq: None,
            parameter,
            value: 10.0,
            previous: 10.0,
            unit: "g/U".into(),
            no_update: true,
            reason: String::new(),
            reasons: Vec::new(),
            data: String::new(),
            decided_at: String::new(),
            day: 1,
            status: "open".into(),
            in_force: 10.0,
            schedule: None,
            answer_note: None,
        }
    }

    fn accepted(slot: MealSlot) -> Event {
        Event::new(
            Timestamp(600),
            EventKind::SuggestionAccepted(SettingValue::CarbRatio {
                slot,
                ratio: GramsPerUnit(10.0),
            }),
        )
    }

    #[test]
    fn each_main_setting_has_its_own_name_and_a_snack_none() {
        assert_eq!(setting(Parameter::Basal), Some(Setting::Basal));
        for (slot, s) in
            MealSlot::MAIN
                .into_iter()
                .zip([Setting::Breakfast, Setting::Lunch, Setting::Dinner])
        {
            assert_eq!(setting(Parameter::CarbRatio(slot)), Some(s));
        }
        assert_eq!(setting(Parameter::CarbRatio(MealSlot::Snack)), None);
    }

    #[test]
    fn a_dinner_answer_answers_the_latest_dinner_suggestion() {
        let latest = [
            suggestion(500, Setting::Dinner),
            suggestion(540, Setting::Lunch),
            suggestion(560, Setting::Dinner),
        ];
        let item = answer_item(&accepted(MealSlot::Dinner), &latest)
            .unwrap()
            .unwrap();
        assert_eq!(item.suggestion_id, Setting::Dinner.suggestion_id(560));
        assert_eq!(item.answer, AnswerKind::Accept);
    }

    #[test]
    fn a_snack_answer_is_an_error_not_a_dinner_answer() {
        let latest = [suggestion(560, Setting::Dinner)];
        let err = answer_item(&accepted(MealSlot::Snack), &latest).unwrap_err();
        assert!(matches!(err, RemoteError::NoSetting(_)), "{err:?}");
        assert_eq!(
            err.to_string(),
            "the service has no setting for an answer to the snack carb ratio"
        );
    }

    #[test]
    fn a_snack_decision_is_never_compared_as_dinner() {
        let decision = Decision {
            at: Timestamp(560),
            parameter: Parameter::CarbRatio(MealSlot::Snack),
            old: 10.0,
            new: 10.0,
            detail: DecisionDetail::Skipped {
                reason: SkipReason::NoPreviousDayWindow,
            },
        };
        let err = compare(&[decision], &[suggestion(560, Setting::Dinner)]).unwrap_err();
        assert!(err.contains("snack carb ratio"), "{err}");
    }
}
