//! `abba app`: one simulated trial patient through a running `abba serve`,
//! over HTTP, the way a pump app talks to the service ([`crate::remote`]).

use crate::remote::{self, RemoteApp};
use abba_client::{Client, Retry};
use abba_sim::scenario::ScenarioId;
use abba_trial::protocol::RawTrialConfig;
use abba_trial::TrialConfig;
use anyhow::{bail, Context, Result};
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `abba app`.
#[derive(clap::Args, Debug)]
pub struct Args {
    /// The service's base URL.
    #[arg(long, value_name = "URL", default_value = "http://127.0.0.1:8080")]
    pub url: String,
    /// An admin token (`abba token --admin`): the app creates the person
    /// and issues the person's own token, which it then uses.
    #[arg(long)]
    pub token: String,
    /// The patient of the trial's cohort.
    #[arg(long, default_value = "adult#001")]
    pub patient: String,
    /// The scenario (S1: CGM mode; S2-S4: SMBG mode).
    #[arg(long, default_value = "S1")]
    pub scenario: ScenarioId,
    /// Days to simulate.
    #[arg(long, default_value_t = 98)]
    pub days: u32,
    /// A JSON trial configuration (as `abba trial --config`); the TE
    /// reference is its configured value (no calibration on the cohort).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Day 1 of the simulation (UTC date).
    #[arg(long, default_value = "2026-03-02")]
    pub first_day: jiff::civil::Date,
    /// The person's name in the store (default: PATIENT SCENARIO and the
    /// current time, so that every run makes a new person).
    #[arg(long)]
    pub name: Option<String>,
    /// Also run the in-process trial for the same patient and check that
    /// the service made exactly the same suggestions (exit 1 if not).
    #[arg(long)]
    pub compare: bool,
}

/// Runs `abba app`.
pub fn run(a: Args) -> Result<()> {
    let mut raw = match &a.config {
        Some(p) => {
            let text = std::fs::read_to_string(p)
                .with_context(|| format!("cannot read trial configuration {}", p.display()))?;
            RawTrialConfig::from_json(&text)
                .with_context(|| format!("{}: not a valid trial configuration", p.display()))?
        }
        None => RawTrialConfig::default(),
    };
    raw.days = a.days;
    raw.scenarios = vec![a.scenario];
    raw.calibrate_te_ref = false;
    let number: u32 = a
        .patient
        .rsplit('#')
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or(0);
    raw.patients = raw.patients.max(number);
    let config = TrialConfig::try_from(raw)?;
    let Some(scenario) = config.planned_scenario(a.scenario).cloned() else {
        bail!("--scenario {}: not planned", a.scenario);
    };
    let (vp, patient_no) = remote::cohort_patient(&config, &a.patient)?;

    let admin = Client::new(&a.url, Some(&a.token))?;
    let health = admin
        .health()
        .with_context(|| format!("is `abba serve` running at {}?", a.url))?;
    let name = a
        .name
        .clone()
        .unwrap_or_else(|| format!("{} {} {}", a.patient, a.scenario, jiff::Timestamp::now()));
    let body = remote::person_body(&config, &vp, patient_no, &scenario, a.first_day, &name)?;
    let created = admin.create_person(&body).context("creating the person")?;
    let token = admin
        .issue_token(created.id)
        .context("issuing the person's token")?;
    println!("{}", abba_api::NOTICE);
    println!(
        "abba app: {} ({} {}) as person {} '{}' of {} {} at {}",
        a.patient,
        a.scenario,
        scenario.mode.name(),
        created.id,
        name,
        health.service,
        health.version,
        a.url
    );
    let app = RemoteApp {
        client: admin.with_token(&token.token),
        person: created.id,
        first_day: a.first_day,
        retry: Retry::default(),
    };
    let started = Instant::now();
    let run = remote::run_remote(&config, &vp, patient_no, &scenario, &app)?;
    let secs = started.elapsed().as_secs_f64();
    let o = run.outbox;
    println!(
        "{} days in {secs:.1} s: {} events in {} posts ({} failed, {} syncs), {} suggestions ({} changing a setting), {} answers posted",
        a.days,
        o.acked + o.held_on_sync,
        o.posts,
        o.failures,
        o.syncs,
        run.suggestions.len(),
        run.suggestions
            .iter()
            .filter(|s| s.value != s.previous)
            .count(),
        run.answers_posted
    );
    println!(
        "waiting for the service: {:.1} s for event acknowledgements, {:.1} s for answer acknowledgements",
        run.events_wait.as_secs_f64(),
        run.answers_wait.as_secs_f64()
    );
    if let Some(f) = run.failure {
        println!(
            "stopped on day {} at minute {}: plasma glucose {:.1} mg/dL",
            f.day, f.minute_of_day, f.glucose_mg_dl
        );
    }
    let s = run.final_settings;
    println!(
        "settings at the end: basal {:.3} U/h, carb ratios {:.2} / {:.2} / {:.2} g/U",
        s.basal.0, s.carb_ratio[0].0, s.carb_ratio[1].0, s.carb_ratio[2].0
    );
    if a.compare {
        let reference = remote::in_process_decisions(&config, &vp, patient_no, &scenario)?;
        match remote::compare(&reference, &run.suggestions) {
            Ok(n) => println!("compare: the {n} suggestions equal the in-process trial's"),
            Err(e) => bail!("compare: {e}"),
        }
    }
    Ok(())
}
