//! Property tests: every reader, given arbitrary bytes or a mutated real
//! export, returns records or an error, never panics; every error names the
//! file, and a value error also names the line or JSON path and the field.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use abba_io::{read_all, Format, IoError, ReadOptions};
use common::{fixture, opts};
use proptest::prelude::*;

const FORMATS: [Option<Format>; 8] = [
    None,
    Some(Format::Nightscout),
    Some(Format::Clarity),
    Some(Format::LibreView),
    Some(Format::Tidepool),
    Some(Format::TidepoolXlsx),
    Some(Format::Csv),
    Some(Format::CareLink),
];

fn check(name: &str, bytes: Vec<u8>, format: Option<Format>) -> Result<(), TestCaseError> {
    let mut o = opts("Europe/Zurich");
    o.format = format;
    o.units = Some(abba_io::GlucoseUnit::MgDl);
    match read_all(&[(name.to_string(), bytes)], &o) {
        Ok(batch) => {
            prop_assert!(batch.records.windows(2).all(|w| w[0].at <= w[1].at));
        }
        Err(e) => {
            let msg = e.to_string();
            match &e {
                IoError::Invalid { .. } => {
                    prop_assert!(msg.starts_with(name), "{}", msg);
                    prop_assert!(
                        msg.contains(": line ")
                            || msg.contains(": $[")
                            || msg.contains(": sheet \""),
                        "{}",
                        msg
                    );
                    prop_assert!(msg.contains(", field \""), "{}", msg);
                }
                IoError::Format { .. } | IoError::Units { .. } => {
                    prop_assert!(msg.starts_with(name), "{}", msg)
                }
                other => prop_assert!(false, "unexpected error kind: {other}"),
            }
        }
    }
    Ok(())
}

/// A mutation of a file: flip, insert or delete bytes, or truncate.
#[derive(Debug, Clone)]
enum Mutation {
    Set(usize, u8),
    Insert(usize, Vec<u8>),
    Delete(usize, usize),
    Truncate(usize),
}

fn mutation() -> impl Strategy<Value = Mutation> {
    let tokens = prop::sample::select(vec![
        b",".to_vec(),
        b";".to_vec(),
        b"\"".to_vec(),
        b"\r\n".to_vec(),
        b"\n".to_vec(),
        b"-".to_vec(),
        b"1e308".to_vec(),
        b"NaN".to_vec(),
        b"null".to_vec(),
        b"{".to_vec(),
        b"]".to_vec(),
        b"Low".to_vec(),
        b"\xEF\xBB\xBF".to_vec(),
        b"\xff\xfe".to_vec(),
        b"25:61".to_vec(),
        b"31-02-2024".to_vec(),
    ]);
    prop_oneof![
        (any::<prop::sample::Index>(), any::<u8>())
            .prop_map(|(i, b)| Mutation::Set(i.index(usize::MAX), b)),
        (any::<prop::sample::Index>(), tokens)
            .prop_map(|(i, t)| Mutation::Insert(i.index(usize::MAX), t)),
        (any::<prop::sample::Index>(), 1usize..64)
            .prop_map(|(i, n)| Mutation::Delete(i.index(usize::MAX), n)),
        any::<prop::sample::Index>().prop_map(|i| Mutation::Truncate(i.index(usize::MAX))),
    ]
}

fn apply(mut bytes: Vec<u8>, mutations: &[Mutation]) -> Vec<u8> {
    for m in mutations {
        let len = bytes.len().max(1);
        match m {
            Mutation::Set(i, b) => {
                if !bytes.is_empty() {
                    let i = i % len;
                    bytes[i] = *b;
                }
            }
            Mutation::Insert(i, t) => {
                let i = i % (bytes.len() + 1);
                bytes.splice(i..i, t.iter().copied());
            }
            Mutation::Delete(i, n) => {
                let i = i % len;
                let end = (i + n).min(bytes.len());
                if i < end {
                    bytes.drain(i..end);
                }
            }
            Mutation::Truncate(i) => bytes.truncate(i % len),
        }
    }
    bytes
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 512, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes_never_panic(bytes in prop::collection::vec(any::<u8>(), 0..2048), f in 0usize..8) {
        check("arbitrary.bin", bytes, FORMATS[f])?;
    }

    #[test]
    fn arbitrary_text_rows_never_panic(
        header in prop::sample::select(vec![
            "time,glucose_mg_dl,carbs,bolus,basal",
            "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams)",
            "Glucose Data,Generated on\nDevice,Serial Number,Device Timestamp,Record Type,Historic Glucose mg/dL,Scan Glucose mg/dL,Rapid-Acting Insulin (units),Carbohydrates (grams)",
            "-------;MiniMed 780G MMT-1886;Pump;NG0000000X;-------\nIndex;Date;Time;BG Reading (mg/dL);Basal Rate (U/h);Temp Basal Amount;Temp Basal Type;Temp Basal Duration (h:mm:ss);Bolus Type;Bolus Volume Delivered (U);Bolus Duration (h:mm:ss);BWZ Carb Input (grams);Sensor Glucose (mg/dL);Event Marker;Suspend",
            "id,date,time,glucose,type",
        ]),
        rows in prop::collection::vec("[0-9a-zA-Z:,;. \\-\"+TZé€]{0,60}", 0..40),
    ) {
        let text = format!("{header}\n{}", rows.join("\n"));
        check("rows.csv", text.into_bytes(), None)?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 96, ..ProptestConfig::default() })]

    #[test]
    fn mutated_real_exports_never_panic(
        which in 0usize..6,
        mutations in prop::collection::vec(mutation(), 1..6),
    ) {
        let names = [
            "clarity_export_synthetic.csv",
            "libreview_libre3_synthetic.csv",
            "nightscout_entries_synthetic.json",
            "nightscout_treatments_synthetic.json",
            "nightscout_profile_synthetic.json",
            "carelink_780g_synthetic.csv",
        ];
        let bytes = apply(fixture(names[which]), &mutations);
        check(names[which], bytes, None)?;
    }
}

#[test]
fn an_unchanged_fixture_reads_without_error() {
    // The property tests above would pass vacuously if every fixture failed.
    for name in [
        "clarity_export_synthetic.csv",
        "libreview_libre3_synthetic.csv",
        "nightscout_entries_synthetic.json",
        "carelink_780g_synthetic.csv",
    ] {
        let o = ReadOptions {
            tz: opts("Europe/Zurich").tz,
            ..ReadOptions::default()
        };
        assert!(
            read_all(&[(name.to_string(), fixture(name))], &o).is_ok(),
            "{name}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    /// The CareLink reader on its own fixture, mutated (sections, decimal
    /// commas, CRLF, newest-first rows), detected and forced.
    #[test]
    fn mutated_carelink_exports_never_panic(
        mutations in prop::collection::vec(mutation(), 1..8),
        forced in any::<bool>(),
    ) {
        let bytes = apply(fixture("carelink_780g_synthetic.csv"), &mutations);
        check("carelink.csv", bytes, forced.then_some(Format::CareLink))?;
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 128, ..ProptestConfig::default() })]

    /// Tidepool's workbook (a zip of XML), mutated: detected and forced.
    #[test]
    fn mutated_tidepool_workbooks_never_panic(
        mutations in prop::collection::vec(mutation(), 1..4),
        forced in any::<bool>(),
    ) {
        let book = crate::tidepool_workbook::workbook(
            &crate::tidepool_workbook::person_data()[..60],
            &crate::tidepool_workbook::Options::default(),
        );
        let bytes = apply(book, &mutations);
        check("TidepoolExport.xlsx", bytes, forced.then_some(Format::TidepoolXlsx))?;
    }
}
