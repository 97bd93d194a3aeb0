//! One patient in one arm of one scenario (`spec/architecture.md`, "The
//! closed loop"): a [`VirtualPerson`] and an advisor exchanging events and
//! settings, minute by minute.
//!
//! Per minute: plasma glucose is sampled every 5 min **for evaluation
//! only** (never shown to the advisor) and the run stops below the failure
//! threshold; then every event the person's devices produce goes to the
//! advisor, and every answer goes back to the person as suggested settings
//! (the person's module says in which order and what they do with them);
//! then the person's minute is simulated. What the person does is
//! abba-sim's business; this module only connects the two and keeps score.

use crate::error::TrialError;
use crate::protocol::{ArmKind, PlannedScenario, TrialConfig};
use crate::results::{evaluation_windows, PatientResult, RunFailure, Week, WeekResult};
use crate::twin_arm::{TwinArmStats, TwinChecked};
use abba_advisor::any::AnyAdvisor;
use abba_advisor::{Advisor, AdvisorError, Mode};
use abba_core::metrics::metrics_regular;
use abba_core::{derive_seed, Event, Stream, MINUTES_PER_DAY};
use abba_sim::cohort::VirtualPatient;
use abba_sim::patient::{GutTape, Pair};
use abba_sim::person::VirtualPerson;

pub use abba_sim::person::MinuteRecord;

/// Minutes between evaluation samples of plasma glucose.
pub const EVAL_PERIOD_MIN: usize = 5;
const SAMPLES_PER_DAY: usize = MINUTES_PER_DAY as usize / EVAL_PERIOD_MIN;

/// What a run can record beside its result.
#[derive(Debug, Default)]
pub struct Trace {
    /// Every event fed to the advisor (used to calibrate the TE reference
    /// from the standard-therapy week).
    pub events: Option<Vec<Event>>,
    /// Every decision of the advisor with its explanation.
    pub decisions: Option<Vec<abba_advisor::decision::Decision>>,
    /// One record per simulated minute (a 1-minute trace; about 140,000
    /// records for a 98-day run, so only on request).
    pub minutes: Option<Vec<MinuteRecord>>,
    /// Filled at the end of every run of an ABBA arm that got past its
    /// initialisation week: what the transfer-entropy initialisation did.
    pub init: Option<abba_advisor::abba::InitReport>,
}

/// What the loop measured.
#[derive(Debug, Clone, PartialEq)]
pub struct LoopRun {
    /// Plasma glucose every [`EVAL_PERIOD_MIN`] minutes (mg/dL; 0 after a failure).
    pub glucose_mg_dl: Vec<f64>,
    /// Insulin delivered per day (U).
    pub daily_insulin_u: Vec<f64>,
    /// Lowest plasma glucose seen at the start of a minute (mg/dL).
    pub min_glucose_mg_dl: f64,
    /// Where the run stopped, if it did.
    pub failure: Option<RunFailure>,
}

impl LoopRun {
    /// Scores the start of minute `m` of day `day` (0-based) at plasma
    /// glucose `plasma`: the 5-min sample, the minimum, and the failure
    /// when it is below `failure_below` (then returns true: the run stops).
    #[inline]
    fn sample(&mut self, day: usize, m: usize, plasma: f64, failure_below: f64) -> bool {
        if m.is_multiple_of(EVAL_PERIOD_MIN) {
            self.glucose_mg_dl[day * SAMPLES_PER_DAY + m / EVAL_PERIOD_MIN] = plasma;
        }
        self.min_glucose_mg_dl = self.min_glucose_mg_dl.min(plasma);
        if plasma < failure_below {
            self.failure = Some(RunFailure {
                day: day as u32 + 1,
                minute_of_day: m as u32,
                glucose_mg_dl: plasma,
            });
            return true;
        }
        false
    }
}

/// Runs one patient (number `patient_no` in its cohort, 1-based) through
/// one scenario in one arm.
pub fn run_patient(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &PlannedScenario,
    arm: ArmKind,
) -> Result<PatientResult, TrialError> {
    run_patient_with(config, vp, patient_no, scenario, arm, &mut Trace::default())
}

/// Like [`run_patient`], recording what `trace` asks for.
pub fn run_patient_with(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &PlannedScenario,
    arm: ArmKind,
    trace: &mut Trace,
) -> Result<PatientResult, TrialError> {
    let (mut person, mut advisor, context) = start(config, vp, patient_no, scenario, arm)?;
    let run = simulate(
        &mut person,
        &mut advisor,
        scenario.config.days,
        config.failure_glucose_mg_dl,
        trace,
        &context,
    )?;
    trace.init = advisor.init_report().cloned();
    result(vp, &person, &advisor, &run, &context)
}

/// Runs one patient through one scenario in several arms (the results in
/// the order of `arms`), the arms in lock-step minute by minute so that
/// they share the patient model's gut work while they eat the same
/// ([`GutTape`]): the results are those of [`run_patient`] for each arm,
/// bit for bit (test `arms_in_lockstep_match_one_by_one`).
pub fn run_patient_arms(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &PlannedScenario,
    arms: &[ArmKind],
) -> Result<Vec<PatientResult>, TrialError> {
    let runs: Vec<_> = arms.iter().map(|&arm| (scenario, arm)).collect();
    run_patient_group(config, vp, patient_no, &runs)
}

/// [`run_patient_arms`] for any (scenario, arm) runs of one patient, all in
/// lock-step: the trial's scenarios share their days (one scenario key),
/// so their runs eat the same too and share the gut's work as well. Runs of
/// scenarios with fewer days stop at their last day.
pub fn run_patient_group(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    runs: &[(&PlannedScenario, ArmKind)],
) -> Result<Vec<PatientResult>, TrialError> {
    Ok(run_patient_group_with_init(config, vp, patient_no, runs)?
        .into_iter()
        .map(|(r, _)| r)
        .collect())
}

/// [`run_patient_group`], with each run's ABBA initialisation report (as
/// [`Trace::init`] has it; `None` for other arms, for a run that did not
/// get past its initialisation, and for a twin).
pub fn run_patient_group_with_init(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    runs: &[(&PlannedScenario, ArmKind)],
) -> Result<Vec<(PatientResult, Option<abba_advisor::abba::InitReport>)>, TrialError> {
    // A run whose result cannot differ from an earlier run's (its twin,
    // see `same_outcome`) is not simulated: it takes that run's result.
    let twin: Vec<Option<usize>> = (0..runs.len())
        .map(|i| (0..i).find(|&j| same_outcome(runs[j], runs[i])))
        .collect();
    let simulated: Vec<usize> = (0..runs.len()).filter(|&i| twin[i].is_none()).collect();
    let days: Vec<u32> = simulated.iter().map(|&i| runs[i].0.config.days).collect();
    let mut started = simulated
        .iter()
        .map(|&i| start(config, vp, patient_no, runs[i].0, runs[i].1))
        .collect::<Result<Vec<_>, _>>()?;
    let loops = simulate_lockstep(&mut started, &days, config.failure_glucose_mg_dl)?;
    let mut results: Vec<Option<(PatientResult, Option<_>)>> = vec![None; runs.len()];
    for ((&i, (person, advisor, context)), run) in simulated.iter().zip(&started).zip(&loops) {
        let r = result(vp, person, advisor, run, context)?;
        results[i] = Some((r, advisor.init_report().cloned()));
    }
    for i in 0..runs.len() {
        if let Some(j) = twin[i] {
            results[i] = results[j].as_ref().map(|(r, _)| (r.clone(), None));
        }
    }
    results
        .into_iter()
        .map(|r| r.ok_or_else(|| TrialError::Config("a run of the group has no result".into())))
        .collect()
}

/// Whether runs `a` and `b` of one patient must give the same result, so
/// that one of them need not be simulated: both in the standard-therapy
/// arm (fixed settings: its advisor answers nothing, whatever it is shown)
/// in scenarios that differ at most in the person's devices (the SMBG
/// schedule and the CGM's wearing days), with no hypoglycaemia treatment
/// (which would make the person eat on a reading). Then the person eats,
/// boluses and lives the same days minute by minute: the meal and
/// sensitivity plans come from their own random streams, which the device
/// settings do not touch (`ScenarioGenerator`), and the devices only
/// produce readings, which nothing in the run acts on (the fixed arm's
/// event guard would refuse only an implausible reading, which the
/// simulated devices do not produce). The paper's S1, S2 and S3 are such
/// scenarios. Test: `standard_arm_twins_equal_their_own_runs`.
pub fn same_outcome(a: (&PlannedScenario, ArmKind), b: (&PlannedScenario, ArmKind)) -> bool {
    let physiology = |s: &PlannedScenario| {
        let mut c = s.config.clone();
        c.name.clear();
        c.smbg = None;
        c.cgm = abba_sim::scenario::CgmWear { until_day: None };
        c
    };
    a.1 == ArmKind::Standard
        && b.1 == ArmKind::Standard
        && a.0.config.hypo_treatment.is_none()
        && b.0.config.hypo_treatment.is_none()
        && physiology(a.0) == physiology(b.0)
}

/// The advisor of one run: an arm's own advisor, or ABBA with the twin
/// check (the `abba-twin` arm, [`crate::twin_arm`]).
#[derive(Debug)]
// One per run; boxing the common case would only add noise.
#[allow(clippy::large_enum_variant)]
pub enum ArmAdvisor {
    /// Every arm but `abba-twin`.
    Plain(AnyAdvisor),
    /// The `abba-twin` arm.
    TwinChecked(Box<TwinChecked<AnyAdvisor>>),
}

impl ArmAdvisor {
    fn any(&self) -> &AnyAdvisor {
        match self {
            ArmAdvisor::Plain(a) => a,
            ArmAdvisor::TwinChecked(t) => t.inner(),
        }
    }

    /// The TE initialisation report, if the advisor is ABBA and has
    /// initialised.
    pub fn init_report(&self) -> Option<&abba_advisor::abba::InitReport> {
        self.any().init_report()
    }

    /// What the twin check did (the `abba-twin` arm only).
    pub fn twin_stats(&self) -> Option<TwinArmStats> {
        match self {
            ArmAdvisor::Plain(_) => None,
            ArmAdvisor::TwinChecked(t) => Some(t.stats),
        }
    }

    fn advisor(&self) -> &dyn Advisor {
        match self {
            ArmAdvisor::Plain(a) => a,
            ArmAdvisor::TwinChecked(t) => t.as_ref(),
        }
    }

    fn advisor_mut(&mut self) -> &mut dyn Advisor {
        match self {
            ArmAdvisor::Plain(a) => a,
            ArmAdvisor::TwinChecked(t) => t.as_mut(),
        }
    }
}

impl Advisor for ArmAdvisor {
    fn observe(
        &mut self,
        event: &Event,
    ) -> Result<Option<abba_core::TherapySettings>, AdvisorError> {
        self.advisor_mut().observe(event)
    }

    fn settings(&self) -> &abba_core::TherapySettings {
        self.advisor().settings()
    }

    fn decisions(&self) -> &[abba_advisor::decision::Decision] {
        self.advisor().decisions()
    }

    fn take_decisions(&mut self) -> Vec<abba_advisor::decision::Decision> {
        self.advisor_mut().take_decisions()
    }

    fn arm(&self) -> ArmKind {
        self.advisor().arm()
    }

    fn mode(&self) -> Option<Mode> {
        self.advisor().mode()
    }
}

/// The person and advisor of one run, and the run's name for messages.
pub(crate) fn start(
    config: &TrialConfig,
    vp: &VirtualPatient,
    patient_no: u64,
    scenario: &PlannedScenario,
    arm: ArmKind,
) -> Result<(VirtualPerson, ArmAdvisor, String), TrialError> {
    let context = format!("{} {}/{}", vp.params.name, scenario.config.name, arm);
    let person = VirtualPerson::new(
        vp,
        patient_no,
        &scenario.config,
        config.seed,
        &config.devices,
        {
            let mut b = TrialConfig::behaviour(scenario.mode);
            b.suggestions = config.suggestions;
            b
        },
    )
    .map_err(|source| TrialError::Sim {
        context: context.clone(),
        source,
    })?;
    let exploration = derive_seed(
        config.seed,
        patient_no,
        scenario.config.random_key,
        Stream::Exploration,
    );
    let advisor = config
        .advisor_spec(arm, scenario.mode)
        .build(vp.therapy, exploration)
        .map_err(|source| TrialError::Advisor {
            context: context.clone(),
            source,
        })?;
    let advisor = match arm {
        ArmKind::AbbaTwin => ArmAdvisor::TwinChecked(Box::new(TwinChecked::new(
            advisor,
            &vp.params.name,
            config.population,
            vp.therapy,
            config.twin_check.unwrap_or_default(),
        ))),
        _ => ArmAdvisor::Plain(advisor),
    };
    Ok((person, advisor, context))
}

/// The result of a finished run.
pub(crate) fn result(
    vp: &VirtualPatient,
    person: &VirtualPerson,
    advisor: &ArmAdvisor,
    run: &LoopRun,
    context: &str,
) -> Result<PatientResult, TrialError> {
    let fin = advisor.settings();
    let start = vp.therapy;
    Ok(PatientResult {
        patient: vp.params.name.clone(),
        weeks: weeks(run, context)?,
        final_basal_u_per_h: fin.basal.0,
        final_carb_ratio_g_per_u: [
            fin.carb_ratio[0].0,
            fin.carb_ratio[1].0,
            fin.carb_ratio[2].0,
        ],
        start_basal_u_per_h: start.basal.0,
        start_carb_ratio_g_per_u: start.carb_ratio[0].0,
        pump_capped: person.pump_capped(),
        min_glucose_mg_dl: run.min_glucose_mg_dl,
        failure: run.failure,
        rescue_carbs_g: person.rescue().0,
        rescue_treatments: person.rescue().1,
        twin_check: advisor.twin_stats(),
    })
}

/// The loop: `days` days of `person` with `advisor`, events out and
/// settings in, stopping when plasma glucose falls below `failure_below`.
pub fn simulate<A: Advisor>(
    person: &mut VirtualPerson,
    advisor: &mut A,
    days: u32,
    failure_below: f64,
    trace: &mut Trace,
    context: &str,
) -> Result<LoopRun, TrialError> {
    let sim = |source| TrialError::Sim {
        context: context.into(),
        source,
    };
    let days = days as usize;
    let mut run = LoopRun {
        glucose_mg_dl: vec![0.0; days * SAMPLES_PER_DAY],
        daily_insulin_u: vec![0.0; days],
        min_glucose_mg_dl: f64::INFINITY,
        failure: None,
    };
    'days: for day in 0..days {
        let insulin_at_midnight = person.insulin_delivered().0;
        for m in 0..MINUTES_PER_DAY as usize {
            if run.sample(day, m, person.plasma_glucose_mg_dl(), failure_below) {
                break 'days;
            }
            person.begin_minute().map_err(sim)?;
            while let Some(event) = person.next_event().map_err(sim)? {
                if let Some(r) = trace.events.as_mut() {
                    r.push(event);
                }
                let answer = advisor
                    .observe(&event)
                    .map_err(|source| TrialError::Advisor {
                        context: context.into(),
                        source,
                    })?;
                if let Some(settings) = answer {
                    person.suggest(settings).map_err(sim)?;
                }
            }
            person.end_minute().map_err(sim)?;
            if let Some(t) = trace.minutes.as_mut() {
                t.push(*person.last_record());
            }
        }
        run.daily_insulin_u[day] = person.insulin_delivered().0 - insulin_at_midnight;
        // Keep the advisor's decision log bounded; keep the decisions only
        // when asked to.
        let decisions = advisor.take_decisions();
        if let Some(d) = trace.decisions.as_mut() {
            d.extend(decisions);
        }
    }
    Ok(run)
}

/// [`simulate`] for several runs at once (no trace), advanced minute by
/// minute in lock-step: each run exactly as `simulate` would run it alone,
/// with the patient models sharing one [`GutTape`]. A run that fails stops;
/// the others go on.
fn simulate_lockstep<A: Advisor>(
    runs: &mut [(VirtualPerson, A, String)],
    days: &[u32],
    failure_below: f64,
) -> Result<Vec<LoopRun>, TrialError> {
    let mut out: Vec<LoopRun> = days
        .iter()
        .map(|&d| LoopRun {
            glucose_mg_dl: vec![0.0; d as usize * SAMPLES_PER_DAY],
            daily_insulin_u: vec![0.0; d as usize],
            min_glucose_mg_dl: f64::INFINITY,
            failure: None,
        })
        .collect();
    let mut tape = GutTape::new();
    let mut midnight = vec![0.0; runs.len()];
    let most = days.iter().copied().max().unwrap_or(0) as usize;
    for day in 0..most {
        for ((person, _, _), at) in runs.iter().zip(midnight.iter_mut()) {
            *at = person.insulin_delivered().0;
        }
        for m in 0..MINUTES_PER_DAY as usize {
            // Each run's minute up to the integration; the runs then
            // integrate two by two, their bodies side by side
            // (`end_minutes_shared_side`: about the time of one run), the
            // last alone when their number is odd.
            let mut waiting: Option<(&mut VirtualPerson, &String)> = None;
            for ((person, advisor, context), run) in runs.iter_mut().zip(out.iter_mut()) {
                if run.failure.is_some() || day >= run.daily_insulin_u.len() {
                    continue;
                }
                let sim = |source| TrialError::Sim {
                    context: context.clone(),
                    source,
                };
                if run.sample(day, m, person.plasma_glucose_mg_dl(), failure_below) {
                    continue;
                }
                person.begin_minute().map_err(sim)?;
                while let Some(event) = person.next_event().map_err(sim)? {
                    let answer = advisor
                        .observe(&event)
                        .map_err(|source| TrialError::Advisor {
                            context: context.clone(),
                            source,
                        })?;
                    if let Some(settings) = answer {
                        person.suggest(settings).map_err(sim)?;
                    }
                }
                match waiting.take() {
                    None => waiting = Some((person, context)),
                    Some((first, first_context)) => {
                        VirtualPerson::end_minutes_shared_side::<Pair, 2>(
                            [first, person],
                            &mut tape,
                        )
                        .map_err(|source| TrialError::Sim {
                            context: format!("{first_context} / {context}"),
                            source,
                        })?
                    }
                }
            }
            if let Some((person, context)) = waiting {
                person
                    .end_minute_shared(&mut tape)
                    .map_err(|source| TrialError::Sim {
                        context: context.clone(),
                        source,
                    })?;
            }
        }
        for (((person, advisor, _), run), at) in runs.iter_mut().zip(out.iter_mut()).zip(&midnight)
        {
            if run.failure.is_none() && day < run.daily_insulin_u.len() {
                run.daily_insulin_u[day] = person.insulin_delivered().0 - at;
                advisor.take_decisions();
            }
        }
    }
    Ok(out)
}

/// The evaluation weeks that fit in the whole days simulated (a failed run
/// ends before its failure day).
fn weeks(run: &LoopRun, context: &str) -> Result<Vec<WeekResult>, TrialError> {
    let days = run.daily_insulin_u.len();
    let complete_days = run.failure.map_or(days, |f| f.day as usize - 1);
    let mut weeks = Vec::new();
    for (name, first, last) in evaluation_windows() {
        if last as usize > complete_days {
            continue;
        }
        let (a, b) = (
            (first as usize - 1) * SAMPLES_PER_DAY,
            last as usize * SAMPLES_PER_DAY,
        );
        let metrics =
            metrics_regular(&run.glucose_mg_dl[a..b]).map_err(|source| TrialError::Metric {
                context: format!("{context} {name}"),
                source,
            })?;
        let n_days = (last - first + 1) as f64;
        let tdi = run.daily_insulin_u[first as usize - 1..last as usize]
            .iter()
            .sum::<f64>()
            / n_days;
        weeks.push(WeekResult {
            week: name,
            first_day: first,
            last_day: last,
            metrics,
            tdi_u_per_day: tdi,
            plasma_5min_mg_dl: if Week::TABLE.contains(&name) {
                run.glucose_mg_dl[a..b].iter().map(|g| *g as f32).collect()
            } else {
                Vec::new()
            },
        });
    }
    Ok(weeks)
}
