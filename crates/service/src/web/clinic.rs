//! The clinic's pages (an admin session): the persons with their data,
//! creating a person (from an uploaded export's pump profile, as `person
//! new --therapy-from`, or from values), and a person's page: bounds, the
//! pump's steps, an import, a change of therapy, sign-in links (with a QR
//! code), tokens and sessions. Every write goes through the store's one
//! function for it (the same as `/v1` and the CLI).

use super::form::{self, Form};
use super::page::{forbidden_csrf, not_found, render, see_other, PageError, PageResult, PathText};
use super::session::{self, Ctx};
use super::today::with_unit;
use crate::auth;
use crate::body::RawBody;
use crate::error::ApiError;
use crate::state::AppState;
use abba_advisor::bounds::Range;
use abba_advisor::{AgeGroup, Mode, Parameter, PumpSteps};
use abba_core::units::GlucoseUnit;
use abba_core::{GramsPerUnit, TherapySettings, UnitsPerHour};
use abba_store::advise::{self, PARAMETERS};
use abba_store::person::TherapySource;
use abba_store::token::Role;
use abba_store::{Live, NewPerson, ProfileResolution, Store};
use abba_web::pages::{Choice, Layout};
use abba_web::texts::{fill, CLINIC_EN as C, EN};
use axum::extract::multipart::MultipartRejection;
use axum::extract::{Multipart, RawQuery, State};
use axum::http::StatusCode;
use serde::Serialize;
use std::collections::BTreeMap;

/// The largest upload (an export to import or a profile), in bytes.
pub const MAX_UPLOAD_BYTES: usize = 32 * 1024 * 1024;

/// One person on the clinic's list.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    id: i64,
    name: String,
    last_data: String,
    tir: String,
    below_70: String,
    waiting: usize,
    flags: Vec<&'static str>,
    nightscout: Option<String>,
}

/// The new-person form: what was typed and the errors beside each field.
#[derive(Debug, Clone, Default, Serialize)]
pub struct NewPersonForm {
    values: BTreeMap<String, String>,
    errors: BTreeMap<String, String>,
    units: Vec<Choice>,
    modes: Vec<Choice>,
    age_groups: Vec<Choice>,
}

#[derive(Debug, Clone, Serialize)]
struct ClinicModel {
    rows: Vec<Row>,
    form: NewPersonForm,
}

fn choices(values: &[(&'static str, &'static str)], selected: &str) -> Vec<Choice> {
    values
        .iter()
        .map(|&(value, label)| Choice {
            value,
            label,
            selected: value == selected,
        })
        .collect()
}

/// The age groups of the forms, `selected` chosen.
fn age_group_choices(selected: &str) -> Vec<Choice> {
    choices(
        &[
            ("adult", "Adult"),
            ("adolescent", "Adolescent"),
            ("child", "Child"),
        ],
        selected,
    )
}

/// An age group from a form's field: absent, the default (adult, as the
/// API's); otherwise one of the three names.
fn age_group_field(text: &str) -> Result<AgeGroup, String> {
    match text {
        "" => Ok(AgeGroup::Adult),
        g => AgeGroup::parse(g)
            .ok_or_else(|| format!("expected adult, adolescent or child, got {g:?}")),
    }
}

impl NewPersonForm {
    fn new(values: BTreeMap<String, String>, errors: BTreeMap<String, String>) -> Self {
        // An error quotes the value it refuses: cut, as every message is.
        let errors: BTreeMap<String, String> = errors
            .into_iter()
            .map(|(k, v)| {
                (
                    k,
                    abba_web::pages::shortened(&v, abba_web::pages::MAX_MESSAGE_CHARS),
                )
            })
            .collect();
        let unit = values
            .get("unit")
            .cloned()
            .unwrap_or_else(|| "mg/dL".into());
        let mode = values.get("mode").cloned().unwrap_or_else(|| "smbg".into());
        let age_group = values
            .get("age_group")
            .cloned()
            .unwrap_or_else(|| "adult".into());
        Self {
            units: choices(&[("mg/dL", "mg/dL"), ("mmol/L", "mmol/L")], &unit),
            modes: choices(&[("smbg", "SMBG (meter)"), ("cgm", "CGM")], &mode),
            age_groups: age_group_choices(&age_group),
            values,
            errors,
        }
    }
}

/// A local time from an advisor minute of a person (their zone).
fn row(store: &mut Store, id: i64, now_ms: i64) -> Result<Row, ApiError> {
    let live = store.live_read(id)?;
    let p = &live.person;
    let clock = advise::clock(p);
    let last = live.stream.events.last();
    let last_data = last
        .map(|e| {
            let at = advise::local(clock.as_ref(), e.at);
            match p.tz.iana_name() {
                Some(zone) => format!("{at} ({zone})"),
                None => at,
            }
        })
        .unwrap_or_else(|| C.no_data.into());
    let end = last.map_or(0, |e| e.at.0);
    let glucose: Vec<f64> = live
        .stream
        .events
        .iter()
        .filter(|e| e.at.0 > end - 14 * 1440)
        .filter_map(|e| match e.kind {
            abba_core::EventKind::Cgm(g) | abba_core::EventKind::Smbg(g) => Some(g.0),
            _ => None,
        })
        .collect();
    let (tir, below) = match abba_core::metrics::range_percentages(&glucose) {
        Ok(r) => (format!("{:.0} %", r[2]), format!("{:.1} %", r[1])),
        Err(_) => ("—".into(), "—".into()),
    };
    let views = live.views();
    let waiting = views.iter().filter(|v| v.status == "open").count();
    let a = live.advice();
    let mut flags = Vec::new();
    if !a.delivery.basal_suggestions {
        flags.push(C.flag_loop);
    }
    if !matches!(a.phase, advise::Phase::Adapting) {
        flags.push(C.flag_first_week);
    }
    let nightscout = store.link(&p.name)?.map(|l| {
        let state = match (&l.last_error, &l.last_sync_at) {
            (Some(e), _) => fill(C.link_failed, &[("error", e)]),
            (None, Some(t)) => fill(C.link_synced, &[("at", &instant_text(t, &p.tz))]),
            (None, None) => C.link_new.into(),
        };
        match link_warnings(&l) {
            Some(w) => format!("{state}; {w}"),
            None => state,
        }
    });
    let _ = now_ms;
    Ok(Row {
        id,
        name: p.name.clone(),
        last_data,
        tir,
        below_70: below,
        waiting,
        flags,
        nightscout,
    })
}

fn rows(store: &mut Store) -> Result<Vec<Row>, ApiError> {
    let now = session::now_ms();
    let mut out = Vec::new();
    for name in store.persons()? {
        let id = store.person(&name)?.id;
        out.push(row(store, id, now)?);
    }
    Ok(out)
}

async fn clinic_page(
    s: &AppState,
    csrf: &str,
    status: StatusCode,
    form: NewPersonForm,
    message: Option<String>,
) -> PageResult {
    let rows = s.every_person(rows).await?;
    let layout = Layout::clinic(EN.clinic_title, csrf, "/clinic").with_status(message);
    render(status, "clinic.html", &layout, &ClinicModel { rows, form })
}

/// `GET /clinic`.
pub async fn list(State(s): State<AppState>, ctx: Ctx) -> PageResult {
    let w = session::admin_page(&s, &ctx).await?;
    clinic_page(
        &s,
        &w.csrf,
        StatusCode::OK,
        NewPersonForm::new(BTreeMap::new(), BTreeMap::new()),
        None,
    )
    .await
}

/// A multipart form read whole: text fields and files (name, bytes).
#[derive(Debug, Default)]
struct Upload {
    text: Form,
    files: Vec<(String, String, Vec<u8>)>,
}

async fn read_multipart(
    ctx: &Ctx,
    m: Result<Multipart, MultipartRejection>,
) -> Result<Upload, ApiError> {
    crate::body::uncompressed(&ctx.headers, "form")?;
    // Not a multipart form (another content type, no boundary): the
    // service's 415 page, not axum's plain-text rejection.
    let mut m = m.map_err(|e| {
        ApiError::new(
            StatusCode::UNSUPPORTED_MEDIA_TYPE,
            abba_api::ErrorCode::UnsupportedMediaType,
            format!("expected the page's upload form (multipart/form-data with a boundary): {e}"),
        )
    })?;
    let mut pairs = Vec::new();
    let mut files = Vec::new();
    let bad = |e: axum::extract::multipart::MultipartError| {
        ApiError::new(
            e.status(),
            abba_api::ErrorCode::BadJson,
            format!("the form could not be read: {e}"),
        )
    };
    while let Some(field) = m.next_field().await.map_err(bad)? {
        let name = field.name().unwrap_or("").to_string();
        match field.file_name().map(str::to_string) {
            Some(file) => {
                let bytes = field.bytes().await.map_err(bad)?;
                // A file input left empty sends a part without a name or bytes.
                if !(file.is_empty() && bytes.is_empty()) {
                    files.push((name, file, bytes.to_vec()));
                }
            }
            None => {
                // Read as bytes, never decoded lossily: a name with bytes
                // that are no UTF-8 was stored with U+FFFD in their place.
                let bytes = field.bytes().await.map_err(bad)?;
                let v = String::from_utf8(bytes.to_vec()).map_err(|e| {
                    ApiError::invalid(
                        name.clone(),
                        format!(
                            "the field `{name}` is not UTF-8 text (byte {} is no character): nothing was saved",
                            e.utf8_error().valid_up_to() + 1
                        ),
                    )
                })?;
                pairs.push((name, v));
            }
        }
    }
    Ok(Upload {
        text: Form::from_pairs(pairs),
        files,
    })
}

/// The first uploaded file the form refuses, with why (shown beside the
/// form's file field `field`): one under another field (never dropped
/// unread), or one whose name holds a character a name may not
/// (`abba_store::person::refused_char`: control, format such as a
/// right-to-left override, hidden ...), said with the name escaped. Such
/// a name is never shown or stored as it is: `evil\u{202E}gpj.csv`
/// showed as `evilvsc.jpg` on the page that says what was read, and a
/// file's name is kept with its evidence.
fn refused_file(up: &Upload, field: &str) -> Option<String> {
    up.files.iter().find_map(|(f, file, _)| {
        if f != field {
            return Some(format!(
                "this form has no file field {f:?} (the file \"{}\"); expected {field}: nothing was read",
                file.escape_debug()
            ));
        }
        let (i, c, why) = abba_store::person::refused_char(file)?;
        Some(format!(
            "the file name \"{}\" holds {} at character {}: {why}; rename the file and upload it again (nothing was read)",
            file.escape_debug(),
            c.escape_unicode(),
            i + 1
        ))
    })
}

/// Checks an upload's CSRF token (the session was checked before the body
/// was read).
fn upload_csrf(w: &abba_store::session::WebSession, up: &Upload) -> Result<(), PageError> {
    use subtle::ConstantTimeEq;
    let sent = up.text.get("csrf").unwrap_or("");
    if bool::from(sent.as_bytes().ct_eq(w.csrf.as_bytes())) {
        Ok(())
    } else {
        Err(forbidden_csrf())
    }
}

/// A POST of the clinic before its body is read: same origin, an admin
/// session (a form's token is checked once the body is read).
async fn admin_post_head(
    s: &AppState,
    ctx: &Ctx,
) -> Result<abba_store::session::WebSession, PageError> {
    if !ctx.same_origin() {
        return Err(forbidden_csrf());
    }
    let w = session::current(s, ctx)
        .await?
        .ok_or_else(super::page::forbidden_no_session)?;
    match w.role {
        Role::Admin => Ok(w),
        Role::Person(_) => Err(super::page::forbidden_role()),
    }
}

fn carb_ratios(text: &str) -> Result<[f64; 3], String> {
    let parts: Vec<Option<f64>> = text.split(',').map(form::number).collect();
    match parts[..] {
        [Some(b), Some(l), Some(d)] => Ok([b, l, d]),
        _ => Err(format!(
            "expected three carb ratios (g/U) for breakfast, lunch and dinner, separated by commas: 10,12,11; got {text:?}"
        )),
    }
}

/// The optional grams-per-exchange field of the forms that read exports
/// (a CareLink pump whose wizard counts in exchanges): empty is none.
fn grams_per_exchange(text: &str) -> Result<Option<f64>, String> {
    match text {
        "" => Ok(None),
        t => match form::number(t) {
            Some(g) => abba_io::read::check_grams_per_exchange(g).map(Some),
            None => Err(fill(EN.expected_number, &[("example", "10")])),
        },
    }
}

/// The new person from the form, or the errors beside each field.
fn new_person(up: &Upload) -> Result<NewPerson, BTreeMap<String, String>> {
    let f = &up.text;
    let mut errors = BTreeMap::new();
    let name = f.text("name").to_string();
    if name.is_empty() {
        errors.insert("name".into(), EN.missing_field.to_string());
    }
    let tz = f.text("tz").to_string();
    let zone = match jiff::tz::TimeZone::get(&tz) {
        Ok(z) => Some(z),
        Err(_) => {
            errors.insert(
                "tz".into(),
                format!("expected an IANA time zone such as Europe/Zurich, got {tz:?}"),
            );
            None
        }
    };
    let units = match f.text("unit") {
        "mg/dL" => GlucoseUnit::MgDl,
        "mmol/L" => GlucoseUnit::MmolL,
        other => {
            errors.insert(
                "unit".into(),
                format!("expected mg/dL or mmol/L, got {other:?}"),
            );
            GlucoseUnit::MgDl
        }
    };
    let mode = match f.text("mode") {
        "cgm" => Mode::Cgm,
        "smbg" => Mode::Smbg,
        other => {
            errors.insert(
                "mode".into(),
                format!("expected cgm or smbg, got {other:?}"),
            );
            Mode::Smbg
        }
    };
    let age_group = match age_group_field(f.text("age_group")) {
        Ok(g) => g,
        Err(e) => {
            errors.insert("age_group".into(), e);
            AgeGroup::Adult
        }
    };
    let first_day = match f.text("first_day") {
        "" => None,
        d => match d.parse::<jiff::civil::Date>() {
            Ok(d) => Some(d),
            Err(_) => {
                errors.insert(
                    "first_day".into(),
                    format!("expected a date YYYY-MM-DD, got {d:?}"),
                );
                None
            }
        },
    };
    let profiles: Vec<(String, Vec<u8>)> = up
        .files
        .iter()
        .filter(|(field, _, _)| field == "profile")
        .map(|(_, file, bytes)| (file.clone(), bytes.clone()))
        .collect();
    let (basal, cr) = (f.text("basal"), f.text("carb_ratios"));
    let grams = match grams_per_exchange(f.text("grams_per_exchange")) {
        Ok(g) => g,
        Err(e) => {
            errors.insert("grams_per_exchange".into(), e);
            None
        }
    };
    let meal_windows = abba_io::meals::MealWindows::default();
    let mut start = None;
    let mut schedule = None;
    let mut from_profile = false;
    let mut notes = Vec::new();
    match (profiles.is_empty(), basal.is_empty()) {
        (false, false) => {
            errors.insert(
                "basal".into(),
                "give a profile file or a basal rate, not both (carb ratios may replace the profile's)".into(),
            );
        }
        (false, true) => {
            let replace = if cr.is_empty() {
                Ok(None)
            } else {
                carb_ratios(cr).map(Some)
            };
            let replace = match replace {
                Ok(r) => r,
                Err(e) => {
                    errors.insert("carb_ratios".into(), e);
                    None
                }
            };
            if let (Some(tz), false) = (zone.clone(), errors.contains_key("carb_ratios")) {
                let opts = abba_io::ReadOptions {
                    tz: Some(tz),
                    grams_per_exchange: grams,
                    ..abba_io::ReadOptions::default()
                };
                match abba_io::therapy::therapy_from_contents(
                    &profiles,
                    &opts,
                    &meal_windows,
                    replace,
                ) {
                    Ok(t) => {
                        schedule = (t.basal.len() > 1).then(|| t.basal.clone());
                        start = Some(t.settings());
                        from_profile = true;
                        notes = t.notes;
                    }
                    Err(e) => {
                        errors.insert("profile".into(), profile_words(&e.to_string()));
                    }
                }
            }
        }
        (true, _) => {
            let b = form::number(basal);
            if b.is_none() {
                errors.insert(
                    "basal".into(),
                    fill(EN.expected_number, &[("example", "0.85")])
                        + " (U/h), or upload a profile",
                );
            }
            let c = carb_ratios(cr);
            if let Err(e) = &c {
                errors.insert("carb_ratios".into(), e.clone());
            }
            if let (Some(b), Ok([x, y, z])) = (b, c) {
                start = Some(TherapySettings {
                    basal: UnitsPerHour(b),
                    carb_ratio: [GramsPerUnit(x), GramsPerUnit(y), GramsPerUnit(z)],
                });
            }
        }
    }
    if !errors.is_empty() {
        return Err(errors);
    }
    let Some(start) = start else {
        return Err(errors);
    };
    let mut p = NewPerson::new(&name, &tz, mode, start);
    p.settings.set_age_group(age_group);
    p.first_day = first_day;
    p.settings.meal_windows = meal_windows;
    p.settings.basal_schedule = schedule;
    if from_profile {
        p.settings.therapy_source = TherapySource::Profile;
        p.settings.therapy_notes = notes;
    }
    p.settings.pump_steps = Some(PumpSteps::default());
    p.settings.units = units;
    Ok(p)
}

/// What reading an uploaded profile refused, in the new-person form's
/// words: its fields instead of `abba person new`'s flags.
fn profile_words(msg: &str) -> String {
    const RATIOS: &str = "the \"Carb ratios\" field";
    msg.replace(
        "give the carb ratios with --carb-ratio B,L,D",
        "give the carb ratios of breakfast, lunch and dinner in the \"Carb ratios\" field (with a profile they replace its ratios)",
    )
    .replace(
        "give --basal and --carb-ratio",
        "create the person without a profile, from the \"Basal rate\" and \"Carb ratios\" fields",
    )
    .replace(
        "give the person's zone with --tz",
        "give the person's zone in the \"Time zone\" field",
    )
    .replace("--carb-ratio", RATIOS)
    .replace("--basal", "the \"Basal rate\" field")
}

/// The form field a store error names (`--basal` → `basal`, ...).
fn field_of(e: &abba_store::StoreError) -> &'static str {
    let text = e.to_string();
    if matches!(
        e,
        abba_store::StoreError::PersonExists(_) | abba_store::StoreError::PersonLookAlike { .. }
    ) || text.contains("name")
    {
        "name"
    } else if text.starts_with("--first-day") {
        "first_day"
    } else if text.contains("carb") {
        "carb_ratios"
    } else if text.contains("basal") {
        "basal"
    } else if text.contains("zone") || text.contains("tz") {
        "tz"
    } else {
        "name"
    }
}

/// A store message without the CLI flag it starts with (`--basal: ...`):
/// beside its field on the page, the field names it.
fn without_flag(msg: &str) -> &str {
    match msg.split_once(": ") {
        Some((flag, rest))
            if flag.starts_with("--")
                && flag[2..]
                    .bytes()
                    .all(|b| b.is_ascii_lowercase() || b == b'-') =>
        {
            rest
        }
        _ => msg,
    }
}

/// True when the person named as `np` exists with exactly its zone, day 1
/// and settings and holds no data yet (no import, no app event): the same
/// creation sent again, not another person under a taken name.
fn same_new_person(
    store: &mut abba_store::Store,
    np: &NewPerson,
) -> Result<bool, abba_store::StoreError> {
    let Ok(p) = store.person(&np.name) else {
        return Ok(false);
    };
    Ok(p.name == np.name
        && p.tz.iana_name() == Some(np.tz.as_str())
        && p.first_day == np.first_day
        && p.settings == np.settings
        && store.imports_of(p.id)?.is_empty()
        && store.app_event_count(p.id)? == 0)
}

/// `POST /clinic/persons` (multipart): creates a person; 303 to their page,
/// or the form again (422) with each error beside its field.
pub async fn create(
    State(s): State<AppState>,
    ctx: Ctx,
    m: Result<Multipart, MultipartRejection>,
) -> PageResult {
    let w = admin_post_head(&s, &ctx).await?;
    let up = read_multipart(&ctx, m).await?;
    upload_csrf(&w, &up)?;
    up.text.only(&[
        "csrf",
        "name",
        "tz",
        "unit",
        "mode",
        "age_group",
        "basal",
        "carb_ratios",
        "first_day",
        "grams_per_exchange",
        "profile",
    ])?;
    let values: BTreeMap<String, String> = [
        "name",
        "tz",
        "unit",
        "mode",
        "age_group",
        "basal",
        "carb_ratios",
        "first_day",
        "grams_per_exchange",
    ]
    .iter()
    .map(|k| (k.to_string(), up.text.text(k).to_string()))
    .collect();
    let refused =
        refused_file(&up, "profile").map(|e| BTreeMap::from([("profile".to_string(), e)]));
    let np = match refused.map_or_else(|| new_person(&up), Err) {
        Ok(p) => p,
        Err(errors) => {
            return clinic_page(
                &s,
                &w.csrf,
                StatusCode::UNPROCESSABLE_ENTITY,
                NewPersonForm::new(values, errors),
                None,
            )
            .await
        }
    };
    let out = s
        .store(move |store| {
            Ok(match store.create_person(&np) {
                Ok(p) => Ok(p),
                // The same form sent twice (a double click, a reload): the
                // person it made, as the first answer would have shown.
                Err(abba_store::StoreError::PersonExists(_)) if same_new_person(store, &np)? => {
                    store
                        .person(&np.name)
                        .map_err(|e| ("name", without_flag(&e.to_string()).to_string()))
                }
                Err(e) => {
                    let f = field_of(&e);
                    Err((f, without_flag(&e.to_string()).to_string()))
                }
            })
        })
        .await?;
    match out {
        Ok(p) => Ok(see_other(&format!("/clinic/persons/{}", p.id))),
        Err((field, msg)) => {
            let errors = BTreeMap::from([(field.to_string(), msg)]);
            clinic_page(
                &s,
                &w.csrf,
                StatusCode::UNPROCESSABLE_ENTITY,
                NewPersonForm::new(values, errors),
                None,
            )
            .await
        }
    }
}

/// A token or a session of the person's page.
#[derive(Debug, Clone, Serialize)]
struct Item {
    id: i64,
    text: String,
}

/// A person's page for the clinic.
#[derive(Debug, Clone, Serialize, Default)]
struct PersonModel {
    id: i64,
    name: String,
    mode: String,
    tz: String,
    unit: String,
    summary: String,
    settings: Vec<(String, String)>,
    schedule: Vec<(String, String)>,
    bounds: BTreeMap<&'static str, String>,
    steps: BTreeMap<&'static str, String>,
    waiting: Vec<(String, String)>,
    /// Where the therapy in force comes from (given, the pump's profile,
    /// kept over it).
    therapy_source: String,
    tokens: Vec<Item>,
    sessions: Vec<Item>,
    nightscout: Option<String>,
    /// After `form#issue-signin`: the link and its QR code (SVG).
    signin_url: Option<String>,
    signin_qr: Option<String>,
    /// After `form#issue-token`: the token, shown once.
    new_token: Option<String>,
    /// After `form#import`: what the import did (every count and note).
    import_result: Vec<String>,
    /// What the reader noted about the profile the starting therapy was
    /// read from (kept with the person's settings).
    therapy_notes: Vec<String>,
    /// The age groups, the person's selected.
    age_groups: Vec<Choice>,
    /// Why no basal rate is suggested (a closed loop, injections, no
    /// insulin records), with the records that show it; none when basal
    /// rates are suggested.
    delivery: Option<DeliveryModel>,
    /// The person's Today as they read it (the same model and words,
    /// shown without its answer forms).
    today: Option<super::today::Today>,
    /// Errors beside the fields of every form.
    errors: BTreeMap<String, String>,
    /// What was typed into a refused form.
    values: BTreeMap<String, String>,
}

/// How insulin is delivered, when it keeps basal suggestions back (what
/// `abba advise` says under "Delivery").
#[derive(Debug, Clone, Default, Serialize)]
struct DeliveryModel {
    /// The note (what the data show and what abba does about it).
    note: String,
    /// The evidence (counts of the records that show it).
    evidence: Vec<String>,
}

/// An instant (milliseconds) on the person's clock, the zone named.
fn ms_text(ms: i64, tz: &jiff::tz::TimeZone) -> String {
    jiff::Timestamp::from_millisecond(ms).map_or_else(|_| String::new(), |t| zoned_text(t, tz))
}

/// An instant the store keeps as UTC text (a token's issue, a sync) on
/// the person's clock, the zone named; text that is no instant as it is.
fn instant_text(text: &str, tz: &jiff::tz::TimeZone) -> String {
    text.parse::<jiff::Timestamp>()
        .map_or_else(|_| text.to_string(), |t| zoned_text(t, tz))
}

/// `text` with every UTC instant in it (`2026-11-14T08:00:00Z`, as the
/// readers and the store write them in their notes and errors) said on
/// the person's clock, the zone named, to the second when it has seconds;
/// a quoted one (`got "2099-01-01T00:00:00Z"`, the file's own words) is
/// left as it is.
pub fn local_instants(text: &str, tz: &jiff::tz::TimeZone) -> String {
    let b = text.as_bytes();
    let digit = |i: usize| b.get(i).is_some_and(u8::is_ascii_digit);
    let mut out = String::with_capacity(text.len());
    let mut done = 0;
    let mut i = 0;
    while i + 17 <= b.len() {
        let head = (0..4).all(|k| digit(i + k))
            && b[i + 4] == b'-'
            && digit(i + 5)
            && digit(i + 6)
            && b[i + 7] == b'-'
            && digit(i + 8)
            && digit(i + 9)
            && b[i + 10] == b'T'
            // Not inside a word, nor a value quoted from a file (an
            // error says what the file holds, as it holds it).
            && (i == 0 || !(b[i - 1].is_ascii_alphanumeric() || b[i - 1] == b'"'));
        let end = head
            .then(|| b[i..].iter().position(|&c| c == b'Z').map(|z| i + z + 1))
            .flatten()
            .filter(|&e| {
                e - i <= 30
                    && b[i + 11..e - 1]
                        .iter()
                        .all(|c| c.is_ascii_digit() || matches!(c, b':' | b'.'))
            });
        let parsed = end.and_then(|e| Some((e, text[i..e].parse::<jiff::Timestamp>().ok()?)));
        if let Some((e, t)) = parsed {
            let z = t.to_zoned(tz.clone());
            let clock = if z.second() == 0 && z.subsec_nanosecond() == 0 {
                z.strftime("%Y-%m-%d %H:%M").to_string()
            } else {
                z.strftime("%Y-%m-%d %H:%M:%S").to_string()
            };
            out.push_str(&text[done..i]);
            out.push_str(&match tz.iana_name() {
                Some(zone) => format!("{clock} ({zone})"),
                None => format!("{clock} ({})", z.strftime("UTC%:z")),
            });
            done = e;
            i = e;
        } else {
            i += 1;
        }
    }
    out.push_str(&text[done..]);
    out
}

/// `2026-12-01 09:05 (Europe/Zurich)`: as the list's last data, to the
/// minute, in the zone `tz` (its UTC offset when it has no name).
fn zoned_text(t: jiff::Timestamp, tz: &jiff::tz::TimeZone) -> String {
    let z = t
        .round(jiff::Unit::Minute)
        .unwrap_or(t)
        .to_zoned(tz.clone());
    match tz.iana_name() {
        Some(zone) => format!("{} ({zone})", z.strftime("%Y-%m-%d %H:%M")),
        None => z.strftime("%Y-%m-%d %H:%M (UTC%:z)").to_string(),
    }
}

fn range_text(r: Option<Range>) -> (String, String) {
    r.map_or((String::new(), String::new()), |r| {
        (format!("{}", r.min), format!("{}", r.max))
    })
}

fn person_model(
    store: &mut Store,
    id: i64,
    fx: Option<&crate::state::EffectSource>,
) -> Result<PersonModel, ApiError> {
    let live = store.live_read(id)?;
    let p = &live.person;
    let a = live.advice();
    let settings = PARAMETERS
        .iter()
        .zip(&a.settings)
        .map(|(&q, sa)| {
            (
                super::today::title(q).to_string(),
                with_unit(q, sa.in_force),
            )
        })
        .collect();
    let schedule = a
        .therapy
        .basal_schedule
        .clone()
        .unwrap_or_default()
        .into_iter()
        .map(|(t, r)| (t, with_unit(Parameter::Basal, r)))
        .collect();
    let views = live.views();
    let waiting = live
        .decisions
        .iter()
        .zip(&views)
        .filter(|(_, v)| v.status == "open")
        .map(|(d, v)| {
            (
                super::today::title(d.parameter).to_string(),
                format!(
                    "{} → {} ({})",
                    with_unit(d.parameter, v.previous),
                    with_unit(d.parameter, v.suggested),
                    v.decided_at
                ),
            )
        })
        .collect();
    let b = p.settings.bounds;
    let (basal_min, basal_max) = range_text(b.basal);
    let (cr_min, cr_max) = range_text(b.carb_ratio[0]);
    // What the store holds: a person without steps (continuous values,
    // research) shows empty fields, never defaults they do not have.
    let steps = p.settings.pump_steps;
    let now = session::now_ms();
    let tokens = store
        .tokens_of(Role::Person(id))?
        .into_iter()
        .filter(|t| t.revoked_at.is_none())
        .map(|t| Item {
            id: t.id,
            text: format!(
                "token {} issued {}",
                t.id,
                instant_text(&t.created_at, &p.tz)
            ),
        })
        .collect();
    let sessions = store
        .web_sessions(Role::Person(id), now)?
        .into_iter()
        .map(|x| Item {
            id: x.id,
            text: format!(
                "signed in {}, last used {}, ends {}",
                ms_text(x.created_ms, &p.tz),
                ms_text(x.seen_ms, &p.tz),
                ms_text(x.ends_ms, &p.tz)
            ),
        })
        .collect();
    let nightscout = store.link(&p.name)?.map(|l| {
        format!(
            "{}: last sync {}{}",
            l.url,
            l.last_sync_at
                .as_deref()
                .map_or_else(|| "never".to_string(), |t| instant_text(t, &p.tz)),
            l.last_error
                .as_ref()
                .map(|e| format!(", failed: {e}"))
                .unwrap_or_default()
        ) + &link_warnings(&l)
            .map(|w| format!("; {w}"))
            .unwrap_or_default()
    });
    let unit = p.settings.units.label();
    let summary = fill(
        abba_web::texts::CLINIC_EN.person_summary,
        &[
            ("mode", &a.mode.to_string().to_uppercase()),
            ("tz", &a.tz),
            ("unit", unit),
            ("age_group", p.settings.age_group.name()),
        ],
    );
    Ok(PersonModel {
        id,
        name: p.name.clone(),
        mode: a.mode.to_string(),
        tz: a.tz.clone(),
        unit: unit.into(),
        summary,
        settings,
        schedule,
        bounds: BTreeMap::from([
            ("basal_min", basal_min),
            ("basal_max", basal_max),
            ("cr_min", cr_min),
            ("cr_max", cr_max),
        ]),
        steps: steps
            .map(|st| {
                BTreeMap::from([
                    ("basal_step", format!("{}", st.basal_u_per_h)),
                    ("cr_step", format!("{}", st.carb_ratio_g_per_u)),
                ])
            })
            .unwrap_or_default(),
        waiting,
        therapy_source: a.therapy.source.to_string(),
        therapy_notes: p.settings.therapy_notes.clone(),
        age_groups: age_group_choices(p.settings.age_group.name()),
        delivery: (!a.delivery.basal_suggestions || a.delivery.note.is_some()).then(|| {
            DeliveryModel {
                note: a.delivery.note.as_deref().map_or_else(
                    || a.delivery.words.to_string(),
                    super::advice_words::for_clinic,
                ),
                evidence: a
                    .delivery
                    .evidence
                    .iter()
                    .map(|e| local_instants(e, &p.tz))
                    .collect(),
            }
        }),
        today: Some(super::today::model(&live, None, fx)),
        tokens,
        sessions,
        nightscout,
        ..PersonModel::default()
    })
}

fn person_id(text: &str) -> Result<i64, PageError> {
    let id = crate::extract::parse_id(text);
    if id < 0 {
        Err(not_found())
    } else {
        Ok(id)
    }
}

async fn show_person(
    s: &AppState,
    csrf: &str,
    id: i64,
    status: StatusCode,
    message: Option<String>,
    edit: impl FnOnce(&mut PersonModel) + Send + 'static,
) -> PageResult {
    let fx = s.effects();
    let model = s
        .store(move |store| {
            let mut m = person_model(store, id, fx.as_ref())?;
            edit(&mut m);
            Ok(m)
        })
        .await
        .map_err(|e| {
            if e.status == StatusCode::NOT_FOUND {
                not_found()
            } else {
                PageError::from(e)
            }
        })?;
    let title = format!("{} · {}", model.name, EN.clinic_title);
    let layout = Layout::clinic(&title, csrf, "").with_status(message);
    render(status, "clinic_person.html", &layout, &model)
}

fn done_text(q: Option<&str>) -> Option<String> {
    let what = q?.strip_prefix("done=")?;
    Some(
        match what {
            "bounds" => C.saved_bounds,
            "steps" => C.saved_steps,
            "age-group" => C.saved_age_group,
            "therapy" => C.saved_therapy,
            "token-revoked" => C.token_revoked,
            "session-revoked" => C.session_revoked,
            _ => return None,
        }
        .to_string(),
    )
}

/// `GET /clinic/persons/{id}`.
pub async fn person(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(id): PathText<String>,
    RawQuery(q): RawQuery,
) -> PageResult {
    let w = session::admin_page(&s, &ctx).await?;
    let id = person_id(&id)?;
    show_person(
        &s,
        &w.csrf,
        id,
        StatusCode::OK,
        done_text(q.as_deref()),
        |_| {},
    )
    .await
}

/// A form of the person's page: origin, admin session, CSRF token, fields.
async fn person_form(
    s: &AppState,
    ctx: &Ctx,
    body: RawBody,
    known: &[&str],
) -> Result<(abba_store::session::WebSession, Form), PageError> {
    if !ctx.same_origin() {
        return Err(forbidden_csrf());
    }
    let form = Form::parse(&ctx.headers, body)?;
    let w = session::post_session(s, ctx, &form).await?;
    if w.role != Role::Admin {
        return Err(super::page::forbidden_role());
    }
    form.only(known)?;
    Ok((w, form))
}

/// A refused form: the person's page again (422) with the error beside
/// `field` and what was typed.
async fn refused(
    s: &AppState,
    csrf: &str,
    id: i64,
    form: &Form,
    fields: &[&'static str],
    field: &str,
    message: String,
) -> PageResult {
    refused_all(
        s,
        csrf,
        id,
        form,
        fields,
        vec![(field.to_string(), message)],
    )
    .await
}

/// A refused form with an error beside each of `errors`' fields (every
/// field found wrong at once, not one per submission) and what was typed.
async fn refused_all(
    s: &AppState,
    csrf: &str,
    id: i64,
    form: &Form,
    fields: &[&'static str],
    errors: Vec<(String, String)>,
) -> PageResult {
    let values: BTreeMap<String, String> = fields
        .iter()
        .map(|k| (k.to_string(), form.text(k).to_string()))
        .collect();
    show_person(
        s,
        csrf,
        id,
        StatusCode::UNPROCESSABLE_ENTITY,
        None,
        move |m| {
            m.values = values;
            m.errors.extend(errors);
        },
    )
    .await
}

fn optional_number(
    form: &Form,
    field: &'static str,
) -> Result<Option<f64>, (&'static str, String)> {
    match form.text(field) {
        "" => Ok(None),
        t => form::number(t)
            .map(Some)
            .ok_or_else(|| (field, fill(EN.expected_number, &[("example", "0.5")]))),
    }
}

/// A range of two optional fields; every field's error (both ends
/// unreadable: both).
fn range_of(
    form: &Form,
    lo: &'static str,
    hi: &'static str,
) -> Result<Option<Range>, Vec<(String, String)>> {
    match (optional_number(form, lo), optional_number(form, hi)) {
        (Ok(None), Ok(None)) => Ok(None),
        (Ok(Some(min)), Ok(Some(max))) => Ok(Some(Range { min, max })),
        (Ok(None), Ok(Some(_))) => Err(vec![(
            lo.to_string(),
            "give both ends of the range, or neither".into(),
        )]),
        (Ok(Some(_)), Ok(None)) => Err(vec![(
            hi.to_string(),
            "give both ends of the range, or neither".into(),
        )]),
        (a, b) => Err([a.err(), b.err()]
            .into_iter()
            .flatten()
            .map(|(f, m)| (f.to_string(), m))
            .collect()),
    }
}

const BOUNDS: [&str; 4] = ["basal_min", "basal_max", "cr_min", "cr_max"];

/// `POST /clinic/persons/{id}/bounds`: the clinician bounds (the carb
/// ratio range holds for the three meals), through the store's one path.
pub async fn bounds(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(id): PathText<String>,
    body: RawBody,
) -> PageResult {
    let id = person_id(&id)?;
    let (w, form) = person_form(
        &s,
        &ctx,
        body,
        &["csrf", "basal_min", "basal_max", "cr_min", "cr_max"],
    )
    .await?;
    let (basal, cr) = match (
        range_of(&form, "basal_min", "basal_max"),
        range_of(&form, "cr_min", "cr_max"),
    ) {
        (Ok(b), Ok(c)) => (b, c),
        (b, c) => {
            let errors = [b.err(), c.err()].into_iter().flatten().flatten().collect();
            return refused_all(&s, &w.csrf, id, &form, &BOUNDS, errors).await;
        }
    };
    let range = |r: Option<Range>| {
        r.map(|r| abba_api::Range {
            min: r.min,
            max: r.max,
        })
    };
    let wire = abba_api::BoundsBody {
        bounds: abba_api::Bounds {
            basal: range(basal),
            breakfast: range(cr),
            lunch: range(cr),
            dinner: range(cr),
        },
    };
    let out = s
        .person(id, true, move |store, live| {
            Ok(crate::routes::admin::put_bounds(store, live, id, &wire))
        })
        .await?;
    match out {
        Ok(()) => Ok(see_other(&format!("/clinic/persons/{id}?done=bounds"))),
        Err(e) => {
            let field = if e.path.as_deref().is_some_and(|p| p.contains("basal")) {
                "basal_min"
            } else {
                "cr_min"
            };
            refused(&s, &w.csrf, id, &form, &BOUNDS, field, e.message).await
        }
    }
}

/// `POST /clinic/persons/{id}/steps`: the pump's basal and carb-ratio steps.
pub async fn steps(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(id): PathText<String>,
    body: RawBody,
) -> PageResult {
    let id = person_id(&id)?;
    let fields = ["basal_step", "cr_step"];
    let (w, form) = person_form(&s, &ctx, body, &["csrf", "basal_step", "cr_step"]).await?;
    let (b, c) = (
        form::number(form.text("basal_step")),
        form::number(form.text("cr_step")),
    );
    let (Some(b), Some(c)) = (b, c) else {
        // Each unreadable field's error beside it, at once.
        let errors = [("basal_step", b, "0.05"), ("cr_step", c, "0.1")]
            .into_iter()
            .filter(|(_, v, _)| v.is_none())
            .map(|(f, _, example)| {
                (
                    f.to_string(),
                    fill(EN.expected_number, &[("example", example)]),
                )
            })
            .collect();
        return refused_all(&s, &w.csrf, id, &form, &fields, errors).await;
    };
    let steps = PumpSteps {
        basal_u_per_h: b,
        carb_ratio_g_per_u: c,
    };
    let out = s
        .person(id, true, move |store, live| {
            settings_changed(store.set_pump_steps_by_id(id, steps), live)
        })
        .await?;
    match out {
        Ok(()) => Ok(see_other(&format!("/clinic/persons/{id}?done=steps"))),
        Err(msg) => {
            let field = if msg.contains("carb") {
                "cr_step"
            } else {
                "basal_step"
            };
            refused(&s, &w.csrf, id, &form, &fields, field, msg).await
        }
    }
}

/// A settings change's outcome for the page: the rebuilt person in
/// `live`, or what the advisor refused (shown beside the form), or an
/// error of the service.
fn settings_changed(
    out: Result<Live, abba_store::StoreError>,
    live: &mut Live,
) -> Result<Result<(), String>, ApiError> {
    match out {
        Ok(l) => {
            *live = l;
            Ok(Ok(()))
        }
        Err(e @ abba_store::StoreError::Advisor(_)) => Ok(Err(e.to_string())),
        Err(e) => Err(e.into()),
    }
}

/// `POST /clinic/persons/{id}/age-group`: the person's age group (its
/// defaults applied, every decision replayed: `Store::set_age_group_by_id`).
pub async fn age_group(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(id): PathText<String>,
    body: RawBody,
) -> PageResult {
    let id = person_id(&id)?;
    let (w, form) = person_form(&s, &ctx, body, &["csrf", "age_group"]).await?;
    let group = match form.text("age_group") {
        "" => Err(EN.missing_field.to_string()),
        g => age_group_field(g),
    };
    let group = match group {
        Ok(g) => g,
        Err(msg) => return refused(&s, &w.csrf, id, &form, &["age_group"], "age_group", msg).await,
    };
    let out = s
        .person(id, true, move |store, live| {
            settings_changed(store.set_age_group_by_id(id, group), live)
        })
        .await?;
    match out {
        Ok(()) => Ok(see_other(&format!("/clinic/persons/{id}?done=age-group"))),
        Err(msg) => refused(&s, &w.csrf, id, &form, &["age_group"], "age_group", msg).await,
    }
}

/// `POST /clinic/persons/{id}/therapy`: the clinician's change of settings
/// (`Store::set_therapy`, as `abba therapy set`; what it refuses is shown).
pub async fn therapy(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(id): PathText<String>,
    body: RawBody,
) -> PageResult {
    let id = person_id(&id)?;
    let fields = ["basal", "carb_ratios"];
    let (w, form) = person_form(&s, &ctx, body, &["csrf", "basal", "carb_ratios"]).await?;
    let basal = match form.text("basal") {
        "" => Ok(None),
        t => form::number(t)
            .map(|v| Some(vec![(0, v)]))
            .ok_or_else(|| fill(EN.expected_number, &[("example", "0.85")])),
    };
    let cr = match form.text("carb_ratios") {
        "" => Ok(None),
        t => carb_ratios(t).map(Some),
    };
    let (basal, cr) = match (basal, cr) {
        (Ok(b), Ok(c)) => (b, c),
        (b, c) => {
            // Each unreadable field's error beside it, at once.
            let errors = [("basal", b.err()), ("carb_ratios", c.err())]
                .into_iter()
                .filter_map(|(f, e)| Some((f.to_string(), e?)))
                .collect();
            return refused_all(&s, &w.csrf, id, &form, &fields, errors).await;
        }
    };
    if basal.is_none() && cr.is_none() {
        return refused(
            &s,
            &w.csrf,
            id,
            &form,
            &fields,
            "basal",
            "give the basal rate, the carb ratios or both".into(),
        )
        .await;
    }
    // The store's one path (as `POST /v1/persons/{id}/therapy`): a value
    // it refuses is shown beside its field; a busy or broken store is the
    // service's error (503 / 500), never a field's.
    let out = s
        .person(id, true, move |store, live| {
            match store.set_therapy_by_id(id, basal, cr, None, "the clinic's page") {
                Ok((_, rebuilt)) => {
                    *live = rebuilt;
                    Ok(Ok(()))
                }
                Err(abba_store::StoreError::Invalid { field, problem }) => {
                    let f = if field.starts_with("--carb-ratio") {
                        "carb_ratios"
                    } else {
                        "basal"
                    };
                    Ok(Err((f, problem)))
                }
                Err(e @ abba_store::StoreError::Advisor(_)) => Ok(Err(("basal", e.to_string()))),
                Err(e) => Err(e.into()),
            }
        })
        .await?;
    match out {
        Ok(()) => Ok(see_other(&format!("/clinic/persons/{id}?done=therapy"))),
        Err((field, msg)) => refused(&s, &w.csrf, id, &form, &fields, field, msg).await,
    }
}

/// `POST /clinic/persons/{id}/import` (multipart, `files`;
/// `grams_per_exchange` for a CareLink export counting in exchanges,
/// `date_order` and `units` for files that do not tell, as `abba import`'s
/// flags): the
/// same import as `abba import` (idempotent, whole or nothing). The page
/// answers with what it did, every count and reader's note as `abba
/// import` prints them (200: importing the same files again adds nothing).
pub async fn import(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(id): PathText<String>,
    m: Result<Multipart, MultipartRejection>,
) -> PageResult {
    let id = person_id(&id)?;
    let w = admin_post_head(&s, &ctx).await?;
    let up = read_multipart(&ctx, m).await?;
    upload_csrf(&w, &up)?;
    up.text.only(&[
        "csrf",
        "files",
        "grams_per_exchange",
        "date_order",
        "units",
        "profile_choice",
    ])?;
    // What the person typed or chose, shown again on a refusal.
    let kept: Vec<(&'static str, String)> = [
        "grams_per_exchange",
        "date_order",
        "units",
        "profile_choice",
    ]
    .into_iter()
    .map(|k| (k, up.text.text(k).to_string()))
    .collect();
    let grams_text = up.text.text("grams_per_exchange").to_string();
    let choice_text = up.text.text("profile_choice").to_string();
    let refuse = |field: &'static str, msg: String| {
        let kept = kept.clone();
        show_person(
            &s,
            &w.csrf,
            id,
            StatusCode::UNPROCESSABLE_ENTITY,
            None,
            move |m| {
                m.errors.insert(field.into(), msg);
                for (k, v) in kept {
                    m.values.insert(k.into(), v);
                }
            },
        )
    };
    if let Some(msg) = refused_file(&up, "files") {
        return refuse("files", msg).await;
    }
    let grams = match grams_per_exchange(&grams_text) {
        Ok(g) => g,
        Err(e) => return refuse("grams_per_exchange", e).await,
    };
    let date_order = match up.text.text("date_order") {
        "" => None,
        "day-first" => Some(abba_io::time::DateOrder::DayFirst),
        "month-first" => Some(abba_io::time::DateOrder::MonthFirst),
        other => {
            return refuse(
                "date_order",
                format!("expected day-first or month-first, got {other:?}"),
            )
            .await
        }
    };
    let units = match up.text.text("units") {
        "" => None,
        u => match abba_io::GlucoseUnit::parse(u) {
            Some(u) => Some(u),
            None => return refuse("units", format!("expected mg/dL or mmol/L, got {u:?}")).await,
        },
    };
    let resolve = match profile_choice(&choice_text) {
        Ok(r) => r,
        Err(e) => return refuse("profile_choice", e).await,
    };
    let contents: Vec<(String, Vec<u8>)> = up
        .files
        .into_iter()
        .filter(|(f, _, _)| f == "files")
        .map(|(_, name, bytes)| (name, bytes))
        .collect();
    if contents.is_empty() {
        return refuse("files", "choose one or more export files".into()).await;
    }
    let read = abba_io::ReadOptions {
        grams_per_exchange: grams,
        date_order,
        units,
        ..abba_io::ReadOptions::default()
    };
    // What the files or the person's settings refuse is shown beside the
    // files, a differing pump profile beside the choice; a busy, read-only or broken store is the service's error
    // (503 / 500), never a field's (as the change of therapy).
    let out = s
        .store(move |store| {
            let person = store.person_by_id(id)?;
            let (name, tz) = (person.name, person.tz);
            let local = |text: &str| local_instants(text, &tz);
            match store.import_contents_read(
                &name,
                &contents,
                &read,
                resolve,
                jiff::Timestamp::now(),
                true,
                &mut |_| Ok(()),
            ) {
                Ok(summary) => {
                    let lines: Vec<String> = summary
                        .lines(&name)
                        .iter()
                        .map(|l| local(&super::advice_words::for_clinic(l)))
                        .collect();
                    Ok(Ok((name, summary, lines)))
                }
                Err(
                    e @ (abba_store::StoreError::Db(_)
                    | abba_store::StoreError::Corrupt { .. }
                    | abba_store::StoreError::NewerSchema { .. }),
                ) => Err(e.into()),
                // The page's own choice instead of the CLI's flags.
                Err(abba_store::StoreError::ProfileDiffers { origin, difference }) => Ok(Err((
                    "profile_choice",
                    local(&format!("{origin}: {difference} {}", C.profile_choose)),
                ))),
                Err(e) => Ok(Err(("files", local(&page_words(&e.to_string()))))),
            }
        })
        .await?;
    s.forget(id);
    match out {
        Ok((name, summary, lines)) => {
            if summary.added > 0 || summary.updated > 0 {
                s.log_changed(&name);
            }
            show_person(
                &s,
                &w.csrf,
                id,
                StatusCode::OK,
                Some(C.imported.to_string()),
                move |m| m.import_result = lines,
            )
            .await
        }
        Err((field, msg)) => refuse(field, msg).await,
    }
}

/// A reader's or the store's refusal in the import page's words: the
/// CLI's flags it names become this page's fields (the glucose unit, the
/// date order, the grams per exchange) or, for what the page cannot
/// choose (a format, a column, a subject), the command that can.
fn page_words(msg: &str) -> String {
    const FIELD_UNIT: &str = "the \"Glucose unit\" field";
    const FIELD_ORDER: &str = "the \"Date order\" field";
    let mut out = msg.to_string();
    for (cli, page) in [
        (
            "give --units mg/dL or --units mmol/L",
            "choose mg/dL or mmol/L in the \"Glucose unit\" field",
        ),
        ("give --units mg/dL", "choose mg/dL in the \"Glucose unit\" field"),
        ("(or --units)", "(or the \"Glucose unit\" field)"),
        ("check --units", "check the \"Glucose unit\" field"),
        ("--units says", "the \"Glucose unit\" field says"),
        (
            "give --date-order day-first or month-first",
            "choose day first or month first in the \"Date order\" field",
        ),
        (
            "--date-order day-first or month-first",
            "the \"Date order\" field (day first or month first)",
        ),
        ("give --date-order", "choose one in the \"Date order\" field"),
        ("--date-order says", "the \"Date order\" field says"),
        ("as --date-order says", "as the \"Date order\" field says"),
        (
            "(--grams-per-exchange G, or the clinic page's grams-per-exchange field;",
            "(the \"Grams of carbohydrate per exchange\" field;",
        ),
        (
            "no --grams-per-exchange",
            "no \"Grams of carbohydrate per exchange\" given",
        ),
        (
            "give --format",
            "this page cannot choose a format: upload an export abba detects, or import the file with `abba import --format`",
        ),
        (
            "choose one with --time-column",
            "this page cannot choose a column: import the file with `abba import --time-column`",
        ),
        (
            "choose one with --glucose-column",
            "this page cannot choose a column: import the file with `abba import --glucose-column`",
        ),
        (
            "choose one with --subject",
            "this page cannot choose a subject: import the file with `abba import --subject`",
        ),
    ] {
        out = out.replace(cli, page);
    }
    // Anything left names a flag this page has as a field.
    out.replace("--units", FIELD_UNIT)
        .replace("--date-order", FIELD_ORDER)
        .replace(
            "--grams-per-exchange",
            "the \"Grams of carbohydrate per exchange\" field",
        )
}

/// The import form's `profile_choice`: what to do when an export's pump
/// profile differs from the therapy the store holds (`abba import`'s
/// `--adopt-profile` / `--keep-therapy`; empty or `stop`: stop and say so).
fn profile_choice(text: &str) -> Result<ProfileResolution, String> {
    match text {
        "" | "stop" => Ok(ProfileResolution::Stop),
        "adopt" => Ok(ProfileResolution::Adopt),
        "keep" => Ok(ProfileResolution::Keep),
        other => Err(format!("expected stop, adopt or keep, got {other:?}")),
    }
}

/// The URL persons reach abba at (for a sign-in link): `abba serve
/// --public-url`, else the one this request came to.
fn base_url(s: &AppState, ctx: &Ctx) -> String {
    if let Some(url) = s.public_url() {
        return url.to_string();
    }
    let host = ctx
        .headers
        .get(axum::http::header::HOST)
        .and_then(|v| v.to_str().ok())
        .unwrap_or("localhost");
    format!("{}://{host}", if ctx.https { "https" } else { "http" })
}

/// `POST /clinic/persons/{id}/signin`: a one-time sign-in link, shown on
/// the page itself (200, not a redirect: the secret is never put in a URL
/// or kept) with its QR code.
pub async fn issue_signin(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(id): PathText<String>,
    body: RawBody,
) -> PageResult {
    let id = person_id(&id)?;
    let (w, _) = person_form(&s, &ctx, body, &["csrf"]).await?;
    let secret = s
        .store(move |store| {
            store.person_by_id(id)?;
            Ok(auth::issue_signin(store, Role::Person(id))?)
        })
        .await?;
    let url = format!("{}/signin/{secret}", base_url(&s, &ctx));
    let qr = abba_web::qr::svg(&url, "QR code of the sign-in link").map_err(ApiError::internal)?;
    show_person(&s, &w.csrf, id, StatusCode::OK, None, move |m| {
        m.signin_url = Some(url);
        m.signin_qr = Some(qr);
    })
    .await
}

/// `POST /clinic/persons/{id}/tokens`: a person's API token, shown once.
pub async fn issue_token(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(id): PathText<String>,
    body: RawBody,
) -> PageResult {
    let id = person_id(&id)?;
    let (w, _) = person_form(&s, &ctx, body, &["csrf"]).await?;
    let (_, token) = s
        .store(move |store| {
            store.person_by_id(id)?;
            Ok(auth::issue(store, Role::Person(id))?)
        })
        .await?;
    show_person(&s, &w.csrf, id, StatusCode::OK, None, move |m| {
        m.new_token = Some(token)
    })
    .await
}

/// `POST /clinic/persons/{id}/tokens/{token}/revoke`.
pub async fn revoke_token(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(ids): PathText<(String, String)>,
    body: RawBody,
) -> PageResult {
    revoke_of_person(&s, &ctx, ids, body, "token-revoked", |store, id, tid| {
        if !store
            .tokens_of(Role::Person(id))?
            .iter()
            .any(|t| t.id == tid)
        {
            return Err(ApiError::not_found("no such token of this person"));
        }
        Ok(store.revoke_token(tid)?)
    })
    .await
}

/// `POST /clinic/persons/{id}/sessions/{session}/revoke`.
pub async fn revoke_session(
    State(s): State<AppState>,
    ctx: Ctx,
    PathText(ids): PathText<(String, String)>,
    body: RawBody,
) -> PageResult {
    revoke_of_person(&s, &ctx, ids, body, "session-revoked", |store, id, sid| {
        let now = session::now_ms();
        if !store
            .web_sessions(Role::Person(id), now)?
            .iter()
            .any(|x| x.id == sid)
        {
            return Err(ApiError::not_found("no such session of this person"));
        }
        Ok(store.revoke_web_session(sid, now)?)
    })
    .await
}

/// A revocation from a person's page: the form checked, then `revoke`
/// (person id, the credential's id) in the store, which refuses a
/// credential that is not this person's, then back to the page.
async fn revoke_of_person(
    s: &AppState,
    ctx: &Ctx,
    (id, what): (String, String),
    body: RawBody,
    done: &str,
    revoke: impl FnOnce(&mut Store, i64, i64) -> Result<(), ApiError> + Send + 'static,
) -> PageResult {
    let id = person_id(&id)?;
    let what = person_id(&what)?;
    person_form(s, ctx, body, &["csrf"]).await?;
    s.store(move |store| revoke(store, id, what)).await?;
    Ok(see_other(&format!("/clinic/persons/{id}?done={done}")))
}

/// True for a path whose POST takes an upload of up to
/// [`MAX_UPLOAD_BYTES`] (the routes below with that body limit; every
/// other body is at most `abba_api::MAX_BODY_BYTES`): the service refuses
/// a request declaring more before reading it
/// ([`crate::body::refuse_declared_oversize`]).
pub fn is_upload(path: &str) -> bool {
    path == "/clinic/persons"
        || path
            .strip_prefix("/clinic/persons/")
            .and_then(|rest| rest.strip_suffix("/import"))
            .is_some_and(|id| !id.is_empty() && !id.contains('/'))
}

/// The page of an upload (`path`, [`is_upload`]) that declares `size`
/// bytes, over [`MAX_UPLOAD_BYTES`]: 413, what to do, a link back to the
/// form (the person's page, or the clinic's for a new person).
pub fn upload_too_large(path: &str, size: u64) -> axum::response::Response {
    use axum::response::IntoResponse;
    let mb = |b: f64| format!("{:.1}", b / (1024.0 * 1024.0));
    let back = path.strip_suffix("/import").unwrap_or("/clinic");
    let model = abba_web::pages::Message {
        text: fill(
            C.upload_too_large,
            &[
                ("size", &mb(size as f64)),
                ("max", &mb(MAX_UPLOAD_BYTES as f64)),
            ],
        ),
        link: Some((back.to_string(), C.back_to_form.to_string())),
    };
    let layout = Layout::new(C.upload_too_large_title, None);
    match abba_web::render("message.html", &layout, &model) {
        Ok(body) => super::page::html(StatusCode::PAYLOAD_TOO_LARGE, body),
        Err(e) => ApiError::internal(e).into_response(),
    }
}

/// This module's routes (merged by [`super::routes`]).
pub fn routes() -> axum::Router<crate::state::AppState> {
    use axum::extract::DefaultBodyLimit;
    use axum::routing::{get, post};
    axum::Router::new()
        .route("/clinic", get(list))
        .route(
            "/clinic/persons",
            post(create).layer(DefaultBodyLimit::max(MAX_UPLOAD_BYTES)),
        )
        .route("/clinic/persons/{id}", get(person))
        .route("/clinic/persons/{id}/bounds", post(bounds))
        .route("/clinic/persons/{id}/steps", post(steps))
        .route("/clinic/persons/{id}/age-group", post(age_group))
        .route("/clinic/persons/{id}/therapy", post(therapy))
        .route(
            "/clinic/persons/{id}/import",
            post(import).layer(DefaultBodyLimit::max(MAX_UPLOAD_BYTES)),
        )
        .route("/clinic/persons/{id}/signin", post(issue_signin))
        .route("/clinic/persons/{id}/tokens", post(issue_token))
        .route(
            "/clinic/persons/{id}/tokens/{token}/revoke",
            post(revoke_token),
        )
        .route(
            "/clinic/persons/{id}/sessions/{session}/revoke",
            post(revoke_session),
        )
}

/// What the link's last successful sync could not look for, in words
/// (`None`: nothing).
fn link_warnings(l: &abba_store::link::Link) -> Option<String> {
    (!l.warnings.is_empty()).then(|| fill(C.link_warnings, &[("warnings", &l.warnings.join("; "))]))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instants_are_said_on_the_persons_clock() {
        let zurich = jiff::tz::TimeZone::get("Europe/Zurich").unwrap();
        assert_eq!(
            local_instants(
                "the first at 2026-11-14T08:00:00Z ($[10]); line 12 (2021-06-18T06:05:07.250Z), from 1990-01-01T00:00:00Z on",
                &zurich
            ),
            "the first at 2026-11-14 09:00 (Europe/Zurich) ($[10]); line 12 (2021-06-18 08:05:07 (Europe/Zurich)), from 1990-01-01 01:00 (Europe/Zurich) on"
        );
        // Not an instant: a local date-time, a date, a word ending in Z.
        for text in [
            "2026-11-14T08:00",
            "2026-11-14 and FOOZ",
            "x2026-11-14T08:00:00Z",
            "got \"2099-01-01T00:00:00Z\"",
            "é 2026-13-40T99:00:00Z",
        ] {
            assert_eq!(local_instants(text, &zurich), text);
        }
        let fixed = jiff::tz::TimeZone::fixed(jiff::tz::offset(-5));
        assert_eq!(
            local_instants("at 2026-11-14T08:00:00Z.", &fixed),
            "at 2026-11-14 03:00 (UTC-05:00)."
        );
    }
}
