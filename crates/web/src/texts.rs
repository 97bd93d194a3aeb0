//! Every English text of the pages, in one place: a translation is one
//! more [`Texts`] value. Texts with `{name}` placeholders are filled by
//! [`fill`] (values given by people are escaped by the templates, never
//! put into a template's source).

use serde::Serialize;

/// The texts of the pages.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Texts {
    /// The `lang` of every page.
    pub lang: &'static str,
    /// The product's name (every page's title ends with it).
    pub product: &'static str,
    /// The research-software notice, on every page.
    pub notice: &'static str,
    /// The skip link.
    pub skip: &'static str,
    /// Before the title of a page whose form was not saved (a field in
    /// error, an answer refused): a screen reader says the title first.
    pub title_error: &'static str,
    /// The navigation's name.
    pub nav_label: &'static str,
    /// Sign out.
    pub sign_out: &'static str,
    /// Who is signed in ({name}).
    pub signed_in_as: &'static str,
    /// Navigation: Today.
    pub nav_today: &'static str,
    /// Navigation: Log.
    pub nav_log: &'static str,
    /// Navigation: Glucose.
    pub nav_glucose: &'static str,
    /// Navigation: History.
    pub nav_history: &'static str,
    /// Navigation: the clinic.
    pub nav_clinic: &'static str,
    /// Title of the sign-in page.
    pub signin_title: &'static str,
    /// What the sign-in button does.
    pub signin_intro: &'static str,
    /// The sign-in button.
    pub signin_button: &'static str,
    /// Title of the page for a refused sign-in link.
    pub signin_refused_title: &'static str,
    /// An unknown link.
    pub signin_unknown: &'static str,
    /// A used link.
    pub signin_used: &'static str,
    /// An expired link.
    pub signin_expired: &'static str,
    /// What to do after a refused link.
    pub signin_again: &'static str,
    /// `/signin` without a link.
    pub signin_needed: &'static str,
    /// Signed out.
    pub signed_out: &'static str,
    /// Title of a refused request.
    pub forbidden_title: &'static str,
    /// A form without a valid CSRF token or from another origin.
    pub forbidden_csrf: &'static str,
    /// A form sent without a live session (signed out, the session ended
    /// or was revoked).
    pub forbidden_no_session: &'static str,
    /// A page for the other role.
    pub forbidden_role: &'static str,
    /// Title of a page that does not exist.
    pub not_found_title: &'static str,
    /// A page that does not exist.
    pub not_found: &'static str,
    /// A page asked with a method it does not take (title).
    pub not_allowed_title: &'static str,
    /// Its text.
    pub not_allowed: &'static str,
    /// Title of a fault of abba.
    pub error_title: &'static str,
    /// The store is busy.
    pub busy: &'static str,
    /// Title of Today.
    pub today_title: &'static str,
    /// Basal rate.
    pub setting_basal: &'static str,
    /// Breakfast carb ratio.
    pub setting_breakfast: &'static str,
    /// Lunch carb ratio.
    pub setting_lunch: &'static str,
    /// Dinner carb ratio.
    pub setting_dinner: &'static str,
    /// "In force:".
    pub in_force: &'static str,
    /// "Suggested today:".
    pub suggested: &'static str,
    /// "Why:".
    pub why: &'static str,
    /// The summary of the explanation's details.
    pub how_details: &'static str,
    /// No change today.
    pub no_change: &'static str,
    /// The label of a suggestion no longer open (answered, replaced).
    pub last_suggestion: &'static str,
    /// A basal suggestion not offered (a loop, injections, unknown delivery).
    pub not_offered: &'static str,
    /// Replaced by the clinician's change of settings ({value}).
    pub answered_replaced: &'static str,
    /// Not answered before the next one, taken as followed ({value}).
    pub answered_superseded: &'static str,
    /// Made on past data and followed by the next within one import: never
    /// shown, not followed ({value}).
    pub answered_unseen: &'static str,
    /// No decision yet.
    pub no_decision: &'static str,
    /// The basal schedule in force ({segments}, {mean}).
    pub schedule_in_force: &'static str,
    /// A suggested basal schedule ({segments}).
    pub schedule_suggested: &'static str,
    /// The heading of the advice's notes on Today.
    pub advice_notes: &'static str,
    /// A suggestion's predicted effect ({revision}, {grade}, {days},
    /// {tir_new}, {tir_now}, {tir_change}, {low_new}, {low_now}, {low_change}).
    pub effect_predicted: &'static str,
    /// The twin check held a suggestion back ({rise}, {margin}, {value}).
    pub twin_check_held_back: &'static str,
    /// The twin check passed ({margin}).
    pub twin_check_passed: &'static str,
    /// The twin check is off.
    pub twin_check_off: &'static str,
    /// No prediction: this service predicts no effects.
    pub no_prediction_not_available: &'static str,
    /// No prediction: no twin yet.
    pub no_prediction_no_twin: &'static str,
    /// No prediction: the twin is not usable ({reason}).
    pub no_prediction_not_usable: &'static str,
    /// No prediction: the twin is older than the data ({revision}).
    pub no_prediction_outdated: &'static str,
    /// No prediction: the replay failed ({reason}).
    pub no_prediction_failed: &'static str,
    /// The report's note on an open suggestion ({setting}, {from}, {to}).
    pub report_open_suggestion: &'static str,
    /// The first week ({done}, {left}, {total}).
    pub first_week: &'static str,
    /// Accept.
    pub accept: &'static str,
    /// Reject.
    pub reject: &'static str,
    /// The own value's label.
    pub own_value: &'static str,
    /// Use my own value.
    pub override_button: &'static str,
    /// The answer buttons' group.
    pub answer_legend: &'static str,
    /// Answered: accepted ({value}).
    pub answered_accepted: &'static str,
    /// Answered: rejected ({value}).
    pub answered_rejected: &'static str,
    /// Answered: own value ({value}).
    pub answered_overridden: &'static str,
    /// When a suggestion was made and on what data ({at}, {data}).
    pub suggestion_made: &'static str,
    /// Status after an answer, said from the store: accepted ({setting},
    /// lower case, and the {value} in force).
    pub status_accepted: &'static str,
    /// Status: rejected ({setting}, {value}).
    pub status_rejected: &'static str,
    /// Status: own value ({setting}, {value}).
    pub status_overridden: &'static str,
    /// An answer refused for a suggestion the page no longer offers to
    /// answer (answered in another tab, replaced): {reason}.
    pub answer_not_saved: &'static str,
    /// Title of the log.
    pub log_title: &'static str,
    /// The reading form's heading.
    pub log_reading: &'static str,
    /// Glucose ({unit}).
    pub glucose_label: &'static str,
    /// The bedtime checkbox.
    pub bedtime_label: &'static str,
    /// Save the reading.
    pub save_reading: &'static str,
    /// The meal form's heading.
    pub log_meal: &'static str,
    /// Carbohydrate (g).
    pub carbs_label: &'static str,
    /// Which meal.
    pub slot_label: &'static str,
    /// Breakfast.
    pub slot_breakfast: &'static str,
    /// Lunch.
    pub slot_lunch: &'static str,
    /// Dinner.
    pub slot_dinner: &'static str,
    /// Snack.
    pub slot_snack: &'static str,
    /// Announce the meal.
    pub save_meal: &'static str,
    /// An import-fed person's log.
    pub log_import_fed: &'static str,
    /// Heading of the meal advice.
    pub meal_advice_title: &'static str,
    /// The ratio to use ({ratio}).
    pub meal_ratio: &'static str,
    /// The bolus it implies ({carbs}, {ratio}, {bolus}, {step}).
    pub meal_bolus: &'static str,
    /// Tomorrow's basal ({value}).
    pub tomorrow_basal: &'static str,
    /// A reading was saved.
    pub status_reading: &'static str,
    /// A bedtime reading closed the day.
    pub status_day_closed: &'static str,
    /// A meal was saved.
    pub status_meal: &'static str,
    /// A snack was saved (no carb ratio is suggested for snacks).
    pub status_snack: &'static str,
    /// A number was expected.
    pub expected_number: &'static str,
    /// A field is missing.
    pub missing_field: &'static str,
    /// A reading outside the plausible range, in the person's unit.
    pub glucose_out_of_range: &'static str,
    /// A mmol/L reading that looks like mg/dL.
    pub glucose_looks_mg_dl: &'static str,
    /// A bedtime reading from a person using a CGM (their days close by
    /// themselves).
    pub bedtime_cgm: &'static str,
    /// A form without its one-time key (a page from an older version).
    pub submission_missing: &'static str,
    /// Title of the clinic's page.
    pub clinic_title: &'static str,
    /// Column: readings.
    pub table_readings: &'static str,
    /// Column: mean.
    pub table_mean: &'static str,
    /// Column: lowest.
    pub table_lowest: &'static str,
    /// Column: highest.
    pub table_highest: &'static str,
    /// Column: in range.
    pub table_in_range: &'static str,
    /// Column: the hour.
    pub table_hour: &'static str,
    /// Column: the day.
    pub table_day: &'static str,
    /// The table's caption ({unit}).
    pub table_caption: &'static str,
    /// Title of the Glucose page.
    pub glucose_title: &'static str,
    /// The last 24 hours.
    pub range_24h: &'static str,
    /// The last 14 days.
    pub range_14d: &'static str,
    /// The range choice's name.
    pub range_label: &'static str,
    /// The chart's accessible name ({range}, {unit}).
    pub chart_title: &'static str,
    /// No readings in the range.
    pub chart_empty: &'static str,
    /// Readings ({kind}).
    pub summary_readings: &'static str,
    /// CGM readings.
    pub kind_cgm: &'static str,
    /// Finger sticks.
    pub kind_smbg: &'static str,
    /// Both kinds.
    pub kind_both: &'static str,
    /// Time in range ({low}-{high} {unit}).
    pub summary_tir: &'static str,
    /// Time below 70 mg/dL ({low} {unit}).
    pub summary_below: &'static str,
    /// Time above 180 mg/dL ({high} {unit}).
    pub summary_above: &'static str,
    /// Mean glucose.
    pub summary_mean: &'static str,
    /// A share of readings, not of time, for finger sticks.
    pub summary_share: &'static str,
    /// Legend: CGM line.
    pub chart_legend_cgm: &'static str,
    /// Legend: finger sticks.
    pub chart_legend_smbg: &'static str,
    /// Legend: the target band.
    pub chart_legend_band: &'static str,
    /// Title of the History page.
    pub history_title: &'static str,
    /// The table's caption.
    pub history_caption: &'static str,
    /// Column: the day.
    pub history_day: &'static str,
    /// Column: the setting.
    pub history_setting: &'static str,
    /// Column: when.
    pub history_decided: &'static str,
    /// Column: the value before.
    pub history_from: &'static str,
    /// Column: suggested.
    pub history_suggested: &'static str,
    /// Column: the answer.
    pub history_answer: &'static str,
    /// Column: in force after.
    pub history_in_force: &'static str,
    /// No suggestion yet.
    pub history_empty: &'static str,
    /// The link to the report.
    pub history_report: &'static str,
    /// Not answered yet.
    pub status_open: &'static str,
    /// Accepted.
    pub status_accepted_word: &'static str,
    /// Kept the previous value.
    pub status_rejected_word: &'static str,
    /// Own value.
    pub status_overridden_word: &'static str,
    /// Not answered before the next suggestion.
    pub status_superseded_word: &'static str,
    /// Never shown (history of one import).
    pub status_unseen_word: &'static str,
    /// No change.
    pub status_no_update_word: &'static str,
    /// The report without data.
    pub report_no_data: &'static str,
}

/// English.
pub const EN: Texts = Texts {
    lang: "en",
    product: "abba",
    notice: "abba is research software, not a medical device. Nothing it shows is medical advice: discuss every suggestion with your clinician before you act on it.",
    skip: "Skip to the content",
    title_error: "Not saved",
    nav_label: "Main",
    sign_out: "Sign out",
    signed_in_as: "Signed in as {name}",
    nav_today: "Today",
    nav_log: "Log",
    nav_glucose: "Glucose",
    nav_history: "History",
    nav_clinic: "Persons",
    signin_title: "Sign in",
    signin_intro: "This link signs you in to abba on this device. It works once and for 15 minutes after your clinic made it.",
    signin_button: "Sign in",
    signin_refused_title: "This sign-in link does not work",
    signin_unknown: "abba does not know this link.",
    signin_used: "This link was used already: a sign-in link works once.",
    signin_expired: "This link is older than 15 minutes: a sign-in link works for 15 minutes.",
    signin_again: "Ask your clinic for a new sign-in link.",
    signin_needed: "Open the sign-in link (or scan the QR code) your clinic gave you to sign in on this device.",
    signed_out: "You are signed out on this device.",
    forbidden_title: "Not allowed",
    forbidden_csrf: "This form was not sent from abba's own page, or the page was too old. Go back, reload the page and send the form again.",
    forbidden_no_session: "You are not signed in on this device any more (you signed out, or your session ended): this form was not taken and nothing was saved. Open the sign-in link (or scan the QR code) your clinic gave you to sign in again.",
    forbidden_role: "You are signed in with an account that cannot open this page.",
    not_found_title: "Not found",
    not_allowed_title: "Not a request this page takes",
    not_allowed: "This page is opened with a link or sent with its own form, not with this kind of request. Open abba's pages from their links.",
    not_found: "There is no such page.",
    error_title: "Something went wrong",
    busy: "abba is busy. Nothing was saved; try again in a moment.",
    today_title: "Today",
    setting_basal: "Basal rate",
    setting_breakfast: "Breakfast carb ratio",
    setting_lunch: "Lunch carb ratio",
    setting_dinner: "Dinner carb ratio",
    in_force: "In force",
    suggested: "Suggested",
    why: "Why",
    how_details: "How abba got there",
    no_change: "No change today.",
    last_suggestion: "Last suggestion",
    not_offered: "No basal rate is suggested for how your insulin is delivered (see your clinician).",
    answered_replaced: "Replaced by your clinician's change of settings: {value} is in force.",
    answered_superseded: "Not answered before the next suggestion (taken as followed): {value} is in force.",
    answered_unseen: "Made on past data that came in one import with later data, so never shown and not followed: {value} stayed in force.",
    no_decision: "No suggestion yet.",
    schedule_in_force: "Your pump's basal schedule: {segments}, the rate above is its mean ({mean}).",
    schedule_suggested: "Suggested schedule, each segment on the pump's step: {segments}.",
    advice_notes: "About your data",
    effect_predicted: "Predicted on your twin (revision {revision}, {grade}) over the last {days} days: time in range ({range}) {tir_new} with the suggestion, {tir_now} as now ({tir_change}); time below {low} {low_new} with it, {low_now} as now ({low_change}). A twin's prediction is not medical advice.",
    twin_check_held_back: "Held back by the twin check: your twin predicts time below {low} rising by {rise} points, more than the {margin}-point margin. Keep {value} today and talk it over with your clinician.",
    twin_check_passed: "Twin check passed: time below {low} does not rise by more than {margin} points.",
    twin_check_off: "The twin check is off.",
    no_prediction_not_available: "No predicted effect: this service has no twins.",
    no_prediction_no_twin: "No predicted effect: you have no twin yet (your clinic can make one from your data).",
    no_prediction_not_usable: "No predicted effect: your twin is not usable ({reason}).",
    no_prediction_outdated: "No predicted effect: your twin (revision {revision}) is older than your data and needs a refit (abba refits it when your data change; ask your clinic if this stays).",
    no_prediction_failed: "No predicted effect: the twin's replay failed ({reason}).",
    report_open_suggestion: "Open suggestion for {setting}: {from} to {to}.",
    first_week: "abba is observing your first week: {done} of {total} days done, {left} to go. Your settings stay as they are until then.",
    accept: "Accept",
    reject: "Keep the previous value",
    own_value: "My own value",
    override_button: "Use my own value",
    answer_legend: "Your answer",
    answered_accepted: "You accepted it: {value} is in force.",
    answered_rejected: "You kept the previous value: {value} is in force.",
    answered_overridden: "You chose your own value: {value} is in force.",
    suggestion_made: "Made on {at} (local time). Data: {data}.",
    status_accepted: "Saved: you accepted the suggested {setting}; {value} is in force.",
    status_rejected: "Saved: you kept the previous {setting}; {value} is in force.",
    status_overridden: "Saved: you chose your own {setting}; {value} is in force.",
    answer_not_saved: "Your answer was not saved: {reason}. The page now shows each setting as it stands.",
    log_title: "Log",
    log_reading: "A meter reading",
    glucose_label: "Glucose ({unit})",
    bedtime_label: "This is my bedtime reading (it closes the day)",
    save_reading: "Save the reading",
    log_meal: "A meal",
    carbs_label: "Carbohydrate (g)",
    slot_label: "Which meal",
    slot_breakfast: "Breakfast",
    slot_lunch: "Lunch",
    slot_dinner: "Dinner",
    slot_snack: "Snack",
    save_meal: "Announce the meal",
    log_import_fed: "Your data come from your devices' exports (files or Nightscout), so there is nothing to enter here: abba reads what your devices recorded.",
    meal_advice_title: "For this meal",
    meal_ratio: "Carb ratio to use: {ratio}.",
    meal_bolus: "{carbs} g at {ratio} is {bolus} U (rounded to the pump's step of {step} U).",
    tomorrow_basal: "Tomorrow's basal rate: {value}.",
    status_reading: "Saved: your reading.",
    status_day_closed: "Saved: your bedtime reading closed the day.",
    status_meal: "Saved: your meal.",
    status_snack: "Saved: your snack (abba suggests carb ratios for the three main meals only).",
    expected_number: "Enter a number, for example {example} (a decimal point or comma, no thousands separator).",
    missing_field: "This field is needed.",
    glucose_out_of_range: "Enter a reading from {min} to {max} {unit}; you entered {value}.",
    glucose_looks_mg_dl: "Your readings are in mmol/L: {value} mg/dL would be {mmol} mmol/L.",
    bedtime_cgm: "Your CGM closes each day at the first reading after midnight, so a bedtime reading does not close the day here. Nothing was saved; save the reading without the bedtime box.",
    submission_missing: "This form is from an older page: reload the page and send it again. Nothing was saved.",
    clinic_title: "Persons",
    table_readings: "Readings",
    table_mean: "Mean",
    table_lowest: "Lowest",
    table_highest: "Highest",
    table_in_range: "In range",
    table_hour: "Hour",
    table_day: "Day",
    table_caption: "The readings of the chart, in {unit}",
    glucose_title: "Glucose",
    range_24h: "Last 24 hours",
    range_14d: "Last 14 days",
    range_label: "Range",
    chart_title: "Glucose over the {range}, in {unit}, with the target range {low}-{high} {unit} shaded",
    chart_empty: "No glucose readings in this range yet.",
    summary_readings: "Readings ({kind})",
    kind_cgm: "CGM",
    kind_smbg: "finger sticks",
    kind_both: "CGM and finger sticks",
    summary_tir: "In range {low}-{high} {unit}",
    summary_below: "Below {low} {unit}",
    summary_above: "Above {high} {unit}",
    summary_mean: "Mean glucose",
    summary_share: "Shares are of readings: with finger sticks they are not of time.",
    chart_legend_cgm: "CGM readings (line; broken where the sensor was off)",
    chart_legend_smbg: "Finger sticks (dots)",
    chart_legend_band: "Target range",
    history_title: "History",
    history_caption: "Every suggestion, your answer and the value in force, newest day first",
    history_day: "Day",
    history_setting: "Setting",
    history_decided: "Decided",
    history_from: "Before",
    history_suggested: "Suggested",
    history_answer: "Your answer",
    history_in_force: "In force after",
    history_empty: "No suggestion yet: abba makes its first after the first week of data.",
    history_report: "Open the report for your clinician (printable)",
    status_open: "not answered yet",
    status_accepted_word: "accepted",
    status_rejected_word: "kept the previous value",
    status_overridden_word: "own value",
    status_superseded_word: "not answered before the next one (taken as followed)",
    status_unseen_word: "never shown (past data of one import; not followed)",
    status_no_update_word: "no change",
    report_no_data: "There is nothing to report yet: the report needs at least one day of data.",
};

/// The texts of the clinic's pages (`c` in their templates).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ClinicTexts {
    /// No data.
    pub no_data: &'static str,
    /// Flag: closed loop.
    pub flag_loop: &'static str,
    /// Flag: first week.
    pub flag_first_week: &'static str,
    /// A link whose last sync failed ({error}).
    pub link_failed: &'static str,
    /// A link synced at {at}.
    pub link_synced: &'static str,
    /// A link not synced yet.
    pub link_new: &'static str,
    /// What the last successful sync could not look for ({warnings}).
    pub link_warnings: &'static str,
    /// Status: bounds saved.
    pub saved_bounds: &'static str,
    /// Status: steps saved.
    pub saved_steps: &'static str,
    /// Status: age group saved.
    pub saved_age_group: &'static str,
    /// Status: therapy saved.
    pub saved_therapy: &'static str,
    /// Status: imported.
    pub imported: &'static str,
    /// Status: token revoked.
    pub token_revoked: &'static str,
    /// Status: session revoked.
    pub session_revoked: &'static str,
    /// The person's mode, zone, unit and age group ({mode}, {tz}, {unit}, {age_group}).
    pub person_summary: &'static str,
    /// The link to the person's report.
    pub person_report: &'static str,
    /// Before the link's state.
    pub nightscout: &'static str,
    /// The sign-in link's heading.
    pub signin_link_title: &'static str,
    /// The new token's heading.
    pub new_token_title: &'static str,
    /// Heading: settings in force.
    pub in_force_title: &'static str,
    /// Column: setting.
    pub col_setting: &'static str,
    /// Column: value.
    pub col_value: &'static str,
    /// A schedule segment's row (then its start).
    pub basal_from: &'static str,
    /// Heading: suggestions waiting.
    pub waiting_title: &'static str,
    /// Heading: the person's Today, as they read it.
    pub persons_today_title: &'static str,
    /// What that section is.
    pub persons_today_intro: &'static str,
    /// Nothing waiting.
    pub none: &'static str,
    /// Heading: bounds.
    pub bounds_title: &'static str,
    /// Button: bounds.
    pub save_bounds: &'static str,
    /// Heading: steps.
    pub steps_title: &'static str,
    /// Button: steps.
    pub save_steps: &'static str,
    /// Heading: the person's age group.
    pub age_group_title: &'static str,
    /// Button: save the age group.
    pub save_age_group: &'static str,
    /// Heading: therapy change.
    pub therapy_title: &'static str,
    /// Label: new carb ratios.
    pub new_carb_ratios: &'static str,
    /// Button: therapy change.
    pub record_change: &'static str,
    /// Heading: import.
    pub import_title: &'static str,
    /// Label: export files.
    pub import_files: &'static str,
    /// Button: import.
    pub import_button: &'static str,
    /// Label: grams of carbohydrate per exchange (import and profile).
    pub grams_per_exchange_label: &'static str,
    /// Label: the date order of a file whose dates do not tell.
    pub date_order_label: &'static str,
    /// Option: the file's dates tell their order.
    pub date_order_file: &'static str,
    /// Option: day first.
    pub date_order_day_first: &'static str,
    /// Option: month first.
    pub date_order_month_first: &'static str,
    /// Label: the glucose unit of values that do not say theirs.
    pub units_label: &'static str,
    /// Option: every value says its unit.
    pub units_file: &'static str,
    /// Legend: what an import does when the export's pump profile differs
    /// from the therapy abba holds.
    pub profile_choice_legend: &'static str,
    /// Option: stop and show both.
    pub profile_stop: &'static str,
    /// Option: put the pump's profile in force.
    pub profile_adopt: &'static str,
    /// Option: keep abba's therapy.
    pub profile_keep: &'static str,
    /// After a stopped import: how to go on.
    pub profile_choose: &'static str,
    /// Before where the therapy in force comes from.
    pub therapy_from: &'static str,
    /// Heading: what the reader noted about the profile the starting
    /// therapy was read from.
    pub therapy_notes_title: &'static str,
    /// Heading: how insulin is delivered, when it keeps basal suggestions
    /// back (a closed loop, injections, no insulin records).
    pub delivery_title: &'static str,
    /// Before the evidence of the delivery.
    pub delivery_evidence: &'static str,
    /// Heading: what the import did.
    pub import_result_title: &'static str,
    /// Title of the page of an upload over the limit.
    pub upload_too_large_title: &'static str,
    /// An upload over the limit ({size}, {max} in MB): nothing imported.
    pub upload_too_large: &'static str,
    /// The link back to the form.
    pub back_to_form: &'static str,
    /// Heading: access.
    pub access_title: &'static str,
    /// Button: sign-in link.
    pub make_signin: &'static str,
    /// Button: API token.
    pub issue_token: &'static str,
    /// Heading: sessions.
    pub sessions_title: &'static str,
    /// Button: revoke a session (then its id).
    pub revoke_session: &'static str,
    /// No session.
    pub no_session: &'static str,
    /// Heading: tokens.
    pub tokens_title: &'static str,
    /// Button: revoke a token (then its id).
    pub revoke_token: &'static str,
    /// No token.
    pub no_token: &'static str,
    /// Label: lowest basal.
    pub basal_min: &'static str,
    /// Label: highest basal.
    pub basal_max: &'static str,
    /// Label: lowest carb ratio.
    pub cr_min: &'static str,
    /// Label: highest carb ratio.
    pub cr_max: &'static str,
    /// Label: basal step.
    pub basal_step: &'static str,
    /// Label: carb-ratio step.
    pub cr_step: &'static str,
    /// Label: new basal.
    pub new_basal: &'static str,
    /// The list's caption.
    pub persons_caption: &'static str,
    /// Column: name.
    pub col_name: &'static str,
    /// Column: last data.
    pub col_last: &'static str,
    /// Column: TIR.
    pub col_tir: &'static str,
    /// Column: below 70.
    pub col_below: &'static str,
    /// Column: flags.
    pub col_flags: &'static str,
    /// Column: Nightscout.
    pub col_nightscout: &'static str,
    /// An empty list.
    pub no_persons: &'static str,
    /// Heading: a new person.
    pub new_person_title: &'static str,
    /// Label: unit.
    pub unit_label: &'static str,
    /// Label: mode.
    pub mode_label: &'static str,
    /// Label: age group.
    pub age_group_label: &'static str,
    /// Label: profile file.
    pub profile_label: &'static str,
    /// Before the by-hand fields.
    pub or_by_hand: &'static str,
    /// Label: basal.
    pub basal_label: &'static str,
    /// Label: carb ratios.
    pub carb_ratios_label: &'static str,
    /// Label: day 1.
    pub first_day_label: &'static str,
    /// Button: create.
    pub create_person: &'static str,
    /// Label: zone.
    pub tz_label: &'static str,
}

/// The clinic's pages in English.
pub const CLINIC_EN: ClinicTexts = ClinicTexts {
    no_data: "no data yet",
    flag_loop: "closed loop or injections",
    flag_first_week: "insufficient data (first week)",
    link_failed: "linked; last sync failed: {error}",
    link_synced: "linked; last sync {at}",
    link_new: "linked; not synced yet",
    link_warnings: "not looked for by the last sync (what it read is in): {warnings}",
    saved_bounds: "Saved: the bounds.",
    saved_steps: "Saved: the pump's steps.",
    saved_age_group: "Saved: the age group (every decision replayed with its defaults).",
    saved_therapy: "Saved: the change of therapy.",
    imported: "Imported.",
    token_revoked: "Revoked: the token.",
    session_revoked: "Revoked: the session.",
    person_summary: "{mode} mode, zone {tz}, glucose in {unit}, age group {age_group}.",
    person_report: "The person's report",
    nightscout: "Nightscout:",
    signin_link_title: "Sign-in link (works once, for 15 minutes)",
    new_token_title: "The new API token (shown only now)",
    in_force_title: "Settings in force",
    col_setting: "Setting",
    col_value: "Value",
    basal_from: "Basal from",
    waiting_title: "Suggestions waiting",
    persons_today_title: "The person's Today",
    persons_today_intro: "What the person reads on their Today page now, word for word (they answer there).",
    none: "None.",
    bounds_title: "Clinician bounds",
    save_bounds: "Save the bounds",
    steps_title: "The pump's steps",
    save_steps: "Save the steps",
    age_group_title: "Age group",
    save_age_group: "Save the age group",
    therapy_title: "A change of therapy",
    new_carb_ratios: "New carb ratios of breakfast, lunch, dinner (g/U, e.g. 10,12,11)",
    record_change: "Record the change",
    import_title: "Import an export",
    import_files: "Export files (Nightscout, Clarity, LibreView, Tidepool, CareLink, CSV)",
    import_button: "Import",
    grams_per_exchange_label: "Grams of carbohydrate per exchange, for a CareLink export whose bolus wizard counts in exchanges (10 for the Spanish raci\u{f3}n; empty otherwise)",
    date_order_label: "Date order, for a LibreView, CareLink or CSV file whose dates do not tell (no day above 12; the import's error says so)",
    date_order_file: "As the file shows",
    date_order_day_first: "Day first (31/12)",
    date_order_month_first: "Month first (12/31)",
    units_label: "Glucose unit of values that do not say theirs (a plain CSV, a Nightscout BG Check without units)",
    units_file: "As the file says",
    profile_choice_legend: "If an export's pump profile differs from the therapy abba holds",
    profile_stop: "Stop and show both (nothing is imported)",
    profile_adopt: "Put the pump's profile in force (what the pump runs)",
    profile_keep: "Keep abba's therapy (profiles in the data are then not read as therapy)",
    profile_choose: "Choose what abba should do below, then choose the files again and import.",
    therapy_from: "The therapy in force comes from:",
    therapy_notes_title: "Notes on the profile the starting therapy was read from",
    delivery_title: "How insulin is delivered, from the data",
    delivery_evidence: "What the data show:",
    import_result_title: "What the import did",
    upload_too_large_title: "Too large to upload",
    upload_too_large: "These files are too large to upload at once: {size} MB, at most {max} MB in one upload. Nothing was imported or created. Upload fewer files at a time, or export a shorter period.",
    back_to_form: "Back to the form",
    access_title: "Sign-in and tokens",
    make_signin: "Make a sign-in link",
    issue_token: "Issue an API token",
    sessions_title: "Sessions",
    revoke_session: "Revoke session",
    no_session: "No session.",
    tokens_title: "API tokens",
    revoke_token: "Revoke token",
    no_token: "No token.",
    basal_min: "Lowest basal rate (U/h)",
    basal_max: "Highest basal rate (U/h)",
    cr_min: "Lowest carb ratio (g/U)",
    cr_max: "Highest carb ratio (g/U)",
    basal_step: "Basal step (U/h: 0.05, 0.025 or 0.01)",
    cr_step: "Carb-ratio step (g/U: 0.1 or 1)",
    new_basal: "New basal rate (U/h)",
    persons_caption: "Persons in this store",
    col_name: "Name",
    col_last: "Last data (the person's local time)",
    col_tir: "Time in range (14 days)",
    col_below: "Below 70 mg/dL (3.9 mmol/L), 14 days",
    col_flags: "Flags",
    col_nightscout: "Nightscout",
    no_persons: "No persons yet.",
    new_person_title: "A new person",
    unit_label: "Glucose unit",
    mode_label: "Mode",
    age_group_label: "Age group (the advisor's defaults for it: the hours the basal rate learns from)",
    profile_label: "The pump's profile: a Nightscout profile, Tidepool or CareLink export",
    or_by_hand: "Or, instead of a profile:",
    basal_label: "Basal rate (U/h)",
    carb_ratios_label: "Carb ratios of breakfast, lunch, dinner (g/U, e.g. 10,12,11; with a profile, they replace its ratios)",
    first_day_label: "Day 1 (optional, YYYY-MM-DD)",
    create_person: "Create the person",
    tz_label: "Time zone (IANA, e.g. Europe/Zurich)",
};

/// Fills the `{name}` placeholders of `text`.
pub fn fill(text: &str, values: &[(&str, &str)]) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(i) = rest.find('{') {
        out.push_str(&rest[..i]);
        let after = &rest[i + 1..];
        let hit = after.find('}').and_then(|j| {
            let key = &after[..j];
            values.iter().find(|(k, _)| *k == key).map(|(_, v)| (j, *v))
        });
        match hit {
            Some((j, v)) => {
                out.push_str(v);
                rest = &after[j + 1..];
            }
            None => {
                out.push('{');
                rest = after;
            }
        }
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn placeholders_are_filled_and_the_notice_says_research_software() {
        assert_eq!(fill("a {x} b {y}", &[("x", "1"), ("y", "2")]), "a 1 b 2");
        // A value is never filled itself.
        assert_eq!(fill("{x}", &[("x", "{y}"), ("y", "no")]), "{y}");
        assert_eq!(fill("{{ 7*7 }}", &[]), "{{ 7*7 }}");
        assert!(EN
            .notice
            .starts_with("abba is research software, not a medical device"));
    }

    /// The person's pages name no command or flag: a person has no
    /// command line (the clinic's texts may name one).
    #[test]
    fn the_persons_texts_name_no_command() {
        let Ok(serde_json::Value::Object(texts)) = serde_json::to_value(EN) else {
            panic!("EN is an object of texts")
        };
        for (key, text) in texts {
            let text = text.as_str().unwrap_or_default();
            assert!(
                !text.contains("abba twin")
                    && !text.contains(" --")
                    && !text.contains("abba person"),
                "{key}: {text}"
            );
        }
    }
}
