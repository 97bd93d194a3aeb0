//! Tidepool's data model as its API gives it, of a Medtronic pump whose
//! bolus wizard counts exchanges (`carbUnits: "exchanges"`, as Tidepool's
//! viewer marks such wizards): the carbohydrate is never read as grams
//! without the grams of one exchange; boluses cut short are read as
//! delivered (`normal`, `extended`, `duration`), not as programmed
//! (`expectedNormal`, ...).

use crate::common::{fixture, opts, read, read_in_part};
use abba_io::record::RecordKind;
use abba_io::ReadOptions;

const F: &str = "tidepool_medtronic_exchanges_synthetic.json";
const TZ: &str = "Europe/Madrid";

/// The carbohydrate records: instant and grams.
fn carbs(b: &abba_io::Batch) -> Vec<(String, f64)> {
    b.records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Carbs { grams } => Some((r.at.to_string(), grams.0)),
            _ => None,
        })
        .collect()
}

#[test]
fn wizard_carbohydrate_in_exchanges_is_read_only_with_the_grams_of_one() {
    let b = read(&[(F, fixture(F))], &opts(TZ)).unwrap();
    assert_eq!(carbs(&b), vec![], "exchanges read as grams");
    assert!(
        b.notes.iter().any(|n| n.starts_with(F)
            && n.contains("2 bolus wizard records")
            && n.contains("carbUnits")
            && n.contains("--grams-per-exchange")),
        "{:?}",
        b.notes
    );
    let o = ReadOptions {
        grams_per_exchange: Some(12.0),
        ..opts(TZ)
    };
    let b = read(&[(F, fixture(F))], &o).unwrap();
    assert_eq!(
        carbs(&b),
        vec![
            ("2026-11-04T07:00:00Z".to_string(), 48.0),
            ("2026-11-04T13:00:00Z".to_string(), 66.0)
        ]
    );
    assert!(
        !b.notes.iter().any(|n| n.contains("--grams-per-exchange")),
        "{:?}",
        b.notes
    );
}

#[test]
fn boluses_cut_short_are_read_as_delivered() {
    let b = read(&[(F, fixture(F))], &opts(TZ)).unwrap();
    let doses: Vec<(String, String)> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Bolus { units } => Some((r.at.to_string(), format!("{}", units.0))),
            RecordKind::ExtendedBolus {
                now,
                extended,
                duration_min,
            } => Some((
                r.at.to_string(),
                format!("{} + {} over {duration_min} min", now.0, extended.0),
            )),
            _ => None,
        })
        .collect();
    assert_eq!(
        doses,
        vec![
            ("2026-11-04T07:00:02Z".to_string(), "4.8".to_string()),
            ("2026-11-04T13:00:02Z".to_string(), "2.5".to_string()),
            (
                "2026-11-04T17:00:02Z".to_string(),
                "0.5 + 0.2 over 20 min".to_string()
            ),
        ]
    );
}

#[test]
fn a_carb_unit_other_than_grams_or_exchanges_is_refused_by_its_field() {
    let text = String::from_utf8(fixture(F)).unwrap().replacen(
        "\"carbUnits\":\"exchanges\"",
        "\"carbUnits\":\"servings\"",
        1,
    );
    let (b, first) = read_in_part(&[(F, text.into_bytes())], &opts(TZ));
    assert!(
        first.contains(F)
            && first.contains("$[3]")
            && first.contains("carbUnits")
            && first.contains("\"servings\""),
        "{first}"
    );
    // The rest is read: the other exchange wizard is counted, not read.
    assert_eq!(b.count("bolus"), 2);
    assert!(b
        .notes
        .iter()
        .any(|n| n.contains("1 bolus wizard record (`wizard`)")));
}
