//! A simulated trial patient as a real person's data: the trial's ABBA arm
//! with every event it fed to the advisor, written as Nightscout exports.
#![allow(dead_code)]

use abba_advisor::any::AdvisorSpec;
use abba_advisor::{Decision, Mode};
use abba_core::{derive_seed, Event, Stream};
use abba_io::clock::AdvisorClock;
use abba_io::read::{read_all, Batch, ReadOptions};
use abba_sim::scenario::ScenarioId;
use abba_store::{NewPerson, Store};
use abba_trial::closed_loop::{run_patient_with, Trace};
use abba_trial::protocol::ArmKind;
use abba_trial::protocol::RawTrialConfig;
use abba_trial::runner::build_cohort;
use abba_trial::TrialConfig;
use jiff::tz::TimeZone;

/// One simulated patient's run in the ABBA arm.
pub struct Sim {
    /// Every event the trial fed to the advisor.
    pub events: Vec<Event>,
    /// Every decision of the trial's advisor.
    pub decisions: Vec<Decision>,
    /// The person as the store should know it.
    pub person: NewPerson,
    /// The clock (D1 = 2026-03-02, UTC).
    pub clock: AdvisorClock,
}

/// The trial's ABBA arm for patient `patient_no` (1-based) of the default
/// cohort in `scenario` (S1: CGM mode, S2: SMBG mode), `days` days, TE
/// reference not calibrated (both sides use the same configuration).
pub fn simulate(scenario: ScenarioId, patient_no: u64, days: u32) -> Sim {
    let raw = RawTrialConfig {
        patients: patient_no as u32,
        days,
        calibrate_te_ref: false,
        scenarios: vec![scenario],
        ..RawTrialConfig::default()
    };
    let config = TrialConfig::try_from(raw).unwrap();
    let cohort = build_cohort(&config).unwrap();
    let vp = &cohort.patients[patient_no as usize - 1];
    let sc = config.planned_scenario(scenario).unwrap();
    let mode = sc.mode;
    let mut trace = Trace {
        events: Some(Vec::new()),
        decisions: Some(Vec::new()),
        minutes: None,
        init: None,
    };
    run_patient_with(&config, vp, patient_no, sc, ArmKind::Abba, &mut trace).unwrap();
    let AdvisorSpec::Abba(mut abba) = config.advisor_spec(ArmKind::Abba, mode) else {
        panic!("not ABBA")
    };
    abba.exploration_seed = derive_seed(
        config.seed,
        patient_no,
        sc.config.random_key,
        Stream::Exploration,
    );
    let sc = &sc.config;
    let name = format!("{}-{}", vp.params.name, sc.name);
    let mut person = NewPerson::new(&name, "UTC", mode, vp.therapy);
    person.settings.advisor = abba;
    let first_day: jiff::civil::Date = "2026-03-02".parse().unwrap();
    person.first_day = Some(first_day);
    Sim {
        events: trace.events.unwrap(),
        decisions: trace.decisions.unwrap(),
        person,
        clock: AdvisorClock::new(TimeZone::UTC, first_day),
    }
}

impl Sim {
    /// The mode.
    pub fn mode(&self) -> Mode {
        self.person.settings.advisor.mode
    }

    /// The events of day indices `from..=to` as a Nightscout export, read back.
    pub fn export(&self, from: i64, to: i64) -> Batch {
        let slice: Vec<Event> = self
            .events
            .iter()
            .filter(|e| (from..=to).contains(&e.at.day_index()))
            .copied()
            .collect();
        let files =
            abba_io::nightscout_out::write(&slice, &self.person.settings.start, &self.clock)
                .unwrap();
        let inputs = vec![
            ("entries.json".to_string(), files.entries.into_bytes()),
            ("treatments.json".to_string(), files.treatments.into_bytes()),
            ("profile.json".to_string(), files.profile.into_bytes()),
        ];
        let opts = ReadOptions {
            tz: Some(TimeZone::UTC),
            ..ReadOptions::default()
        };
        read_all(&inputs, &opts).unwrap()
    }

    /// Last day index with events.
    pub fn last_day(&self) -> i64 {
        self.events.last().unwrap().at.day_index()
    }

    /// A fresh store file in `dir` with this person.
    pub fn store(&self, dir: &std::path::Path) -> Store {
        let mut s = Store::open(&dir.join("abba.db")).unwrap();
        s.create_person(&self.person).unwrap();
        s
    }
}

/// A temporary directory removed on drop.
pub struct TempDir(pub std::path::PathBuf);

impl TempDir {
    /// A new empty directory under the system's temp dir.
    pub fn new(tag: &str) -> Self {
        let p = std::env::temp_dir().join(format!(
            "abba-{tag}-{}-{:?}",
            std::process::id(),
            std::thread::current().id()
        ));
        let _ = std::fs::remove_dir_all(&p);
        std::fs::create_dir_all(&p).unwrap();
        TempDir(p)
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The base URL for a test that must run on PostgreSQL: `None` (with a
/// printed notice) when the run gives none; under `CI=true` a missing
/// server is an error (the CI run starts one).
pub fn postgres_or_skip(test: &str) -> Option<String> {
    use abba_store::testing::{postgres_url, POSTGRES_VAR};
    match postgres_url() {
        Some(u) => Some(u),
        None if std::env::var("CI").is_ok_and(|v| v == "true") => {
            panic!("{test}: CI=true but {POSTGRES_VAR} is not set (.ci/run starts a PostgreSQL server and sets it)")
        }
        None => {
            eprintln!("{test}: skipped on PostgreSQL ({POSTGRES_VAR} is not set)");
            None
        }
    }
}
