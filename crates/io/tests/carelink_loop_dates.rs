//! CareLink's SmartGuard (auto mode) evidence, dated: each auto-mode row
//! at the instant the reader gives its record, a daily total of auto
//! insulin at the end of its day. A SmartGuard run that ended before the
//! last 28 days of the data is a past loop (advice given, its end said);
//! one within them is a closed loop; an auto-mode row whose date cannot
//! be read is taken as current and said. The files are written here from
//! the real-layout fixtures (see tests/data/PROVENANCE.md).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common::{fixture, opts, read};
use abba_io::automation::{recent_from_ms, Delivery, Evidence};
use abba_io::record::RecordKind;
use abba_io::ReadOptions;

const SMARTGUARD: &str = "carelink_780g_smartguard_synthetic.csv";
const BERLIN: &str = "Europe/Berlin";

/// `manual_days` days of manual mode (a basal rate row and a wizard
/// bolus from `BOLUS_WIZARD` each day) after the SmartGuard fixture's day
/// (2026-03-14), newest first at the top of its Pump section, as CareLink
/// writes rows.
fn smartguard_then_manual(manual_days: i64) -> String {
    let text = String::from_utf8(fixture(SMARTGUARD)).unwrap();
    let header = text.lines().find(|l| l.starts_with("Index;")).unwrap();
    let columns = header.split(';').count();
    let col = |name: &str| header.split(';').position(|h| h.starts_with(name)).unwrap();
    let row = |date: &str, time: &str, cells: &[(usize, &str)]| {
        let mut r = vec![String::new(); columns];
        r[0] = "0,00000".into();
        r[1] = date.into();
        r[2] = time.into();
        for &(i, v) in cells {
            r[i] = v.into();
        }
        r.join(";")
    };
    let first = jiff::civil::date(2026, 3, 14);
    let mut rows = Vec::new();
    for d in (1..=manual_days).rev() {
        let day = first.checked_add(jiff::Span::new().days(d)).unwrap();
        let date = day.strftime("%Y/%m/%d").to_string();
        rows.push(row(
            &date,
            "12:20:10",
            &[
                (col("Bolus Type"), "Normal"),
                (col("Bolus Volume Selected"), "4,0"),
                (col("Bolus Volume Delivered"), "4,0"),
                (col("Bolus Source"), "BOLUS_WIZARD"),
            ],
        ));
        rows.push(row(&date, "06:00:00", &[(col("Basal Rate"), "0,900")]));
    }
    let at = text.find(header).unwrap() + header.len() + 1;
    // The fixture's line ends.
    let eol = if text.contains("\r\n") { "\r\n" } else { "\n" };
    let at = if eol == "\r\n" { at + 1 } else { at };
    let mut out = text[..at].to_string();
    for r in rows {
        out.push_str(&r);
        out.push_str(eol);
    }
    out.push_str(&text[at..]);
    out
}

/// The delivery a person's import shows (as the store tells it): the
/// records' counts of the last 28 days, the file's dated evidence added.
fn shown(name: &str, bytes: &[u8], o: &ReadOptions) -> Evidence {
    let b = read(&[(name, bytes.to_vec())], o).unwrap();
    let recent = recent_from_ms(&b.records);
    let tz = o.tz.clone().unwrap();
    let mut e = Evidence::from_records_since(&b.records, &tz, recent.unwrap());
    e.add_file_since(&Evidence::from_file_with(bytes, o), recent);
    e
}

#[test]
fn smartguard_ended_more_than_28_days_before_the_end_is_a_past_loop_said_with_its_date() {
    let file = smartguard_then_manual(35);
    let e = shown("past.csv", file.as_bytes(), &opts(BERLIN));
    assert_eq!(e.delivery(), Delivery::OpenLoop, "{e:?}");
    assert_eq!((e.smb, e.systems.len()), (0, 0), "{e:?}");
    // The last mark is the daily total of 2026-03-14: the end of that day
    // in Berlin (UTC+1).
    let words = e.words().join("; ");
    assert!(
        words.contains("until 2026-03-14T22:59:59.999Z") && words.contains("a past loop"),
        "{words}"
    );
    // Undated (no zone), the same marks are current: a closed loop.
    let mut undated = Evidence::default();
    undated.add_file_since(&Evidence::from_file(file.as_bytes()), Some(0));
    assert_eq!(undated.delivery(), Delivery::ClosedLoop);
}

#[test]
fn smartguard_within_the_last_28_days_is_a_closed_loop() {
    let file = smartguard_then_manual(20);
    let e = shown("recent.csv", file.as_bytes(), &opts(BERLIN));
    assert_eq!(e.delivery(), Delivery::ClosedLoop, "{e:?}");
    assert_eq!(e.smb, 2);
    assert!(e.past_loop_until_ms.is_none(), "{e:?}");
    // Dated: the daily total at the end of its day (Berlin, UTC+1), the
    // automatic doses by the last of them (the 14:05 auto correction).
    let f = Evidence::from_file_with(file.as_bytes(), &opts(BERLIN));
    let ms = |t: &str| t.parse::<jiff::Timestamp>().unwrap().as_millisecond();
    assert_eq!(
        (f.loop_marks_until_ms, f.automated_until_ms),
        (
            Some(ms("2026-03-14T22:59:59.999Z")),
            Some(ms("2026-03-14T13:05:00Z"))
        )
    );
    assert!(!f.undated_loop_marks, "{f:?}");
}

#[test]
fn the_us_layout_is_dated_by_its_own_date_order() {
    // The same rows as CareLink's US English export writes them: `,`
    // between cells, decimal points, `MM/DD/YY` dates.
    let eu = smartguard_then_manual(35);
    let us: String = eu
        .lines()
        .map(|l| {
            let cells: Vec<String> = l
                .split(';')
                .map(|c| {
                    let c = c.replace(',', ".");
                    match c.split('/').collect::<Vec<_>>()[..] {
                        [y, m, d] if y.len() == 4 && d.len() == 2 => {
                            format!("{m}/{d}/{}", &y[2..])
                        }
                        _ => c,
                    }
                })
                .collect();
            cells.join(",") + "\r\n"
        })
        .collect();
    let e = shown("us.csv", us.as_bytes(), &opts("America/Chicago"));
    assert_eq!(e.delivery(), Delivery::OpenLoop, "{e:?}");
    // The end of 2026-03-14 in Chicago (CDT, UTC-5).
    let words = e.words().join("; ");
    assert!(words.contains("until 2026-03-15T04:59:59.999Z"), "{words}");
}

#[test]
fn an_auto_mode_row_with_an_unreadable_date_is_taken_as_current_and_said() {
    // SmartGuard's last auto basal micro-bolus (2026/03/14 03:00:00) with
    // a date that is no date, 35 days of manual mode after it.
    let file = smartguard_then_manual(35);
    let bad = file.replacen("2026/03/14;03:00:00", "2026/14/03;03:00:00", 1);
    assert_ne!(bad, file);
    let line = bad.lines().position(|l| l.contains("2026/14/03")).unwrap() + 1;
    let e = shown("bad.csv", bad.as_bytes(), &opts(BERLIN));
    assert_eq!(e.delivery(), Delivery::ClosedLoop, "{e:?}");
    let words = e.words().join("; ");
    assert!(
        words.contains(&format!("(line {line})")) && words.contains("taken as current"),
        "{words}"
    );
    // Every row of SmartGuard's day unreadable: all its marks counted,
    // the first five lines said.
    let all_bad = file.replace("2026/03/14;", "2026/14/03;");
    let e = Evidence::from_file_with(all_bad.as_bytes(), &opts(BERLIN));
    let marks = e.smb + e.systems.values().sum::<usize>();
    assert_eq!(
        (e.undated_marks, e.undated_mark_lines.len()),
        (marks, 5),
        "{e:?}"
    );
    assert_eq!(e.loop_marks_until_ms, None);
    let words = e.words().join("; ");
    assert!(
        words.contains(&format!("and {} more)", marks - 5)),
        "{words}"
    );
}

/// The instant the auto-mode evidence of `file` gives when its bolus row
/// at `row` (date;time) is made SmartGuard's (the others manual), and
/// the instant the reader gives that bolus's record (`expected`, UTC).
fn mark_and_record(file: &str, row: &str, expected: &str) -> (Option<i64>, i64) {
    let text = String::from_utf8(fixture(file)).unwrap();
    let auto: String = text
        .split_inclusive('\n')
        .map(|l| match l.contains(row) {
            true => l.replace("BOLUS_WIZARD", "CLOSED_LOOP_BG_CORRECTION_AND_FOOD_BOLUS"),
            false => l.to_string(),
        })
        .collect();
    assert_ne!(auto, text);
    let o = opts("Europe/Zurich");
    let e = Evidence::from_file_with(auto.as_bytes(), &o);
    assert!(!e.undated_loop_marks, "{e:?}");
    let b = read(&[(file, auto.into_bytes())], &o).unwrap();
    let bolus = b
        .records
        .iter()
        .filter(|r| matches!(r.kind, RecordKind::Bolus { .. }))
        .map(|r| r.at)
        .find(|t| t.to_string() == expected)
        .expect("the bolus placed by the pump's clock");
    (e.loop_marks_until_ms, bolus.as_millisecond())
}

#[test]
fn a_mark_gets_the_instant_its_record_gets_across_the_pumps_clock_setting() {
    // Autumn (Zurich): on 2026-10-25, the day of the change, the pump
    // kept summer time until it was set back at 09:00; its 08:30:10 bolus
    // is 07:30:10 CET.
    let (mark, record) = mark_and_record(
        "carelink_780g_autumn_clock_synthetic.csv",
        "2026/10/25;08:30:10",
        "2026-10-25T06:30:10Z",
    );
    assert_eq!(mark, Some(record));
    // Spring: on 2026-03-29 the pump kept winter time until set forward
    // at 09:00; its 06:30:10 bolus is 07:30:10 CEST.
    let (mark, record) = mark_and_record(
        "carelink_780g_spring_clock_synthetic.csv",
        "2026/03/29;06:30:10",
        "2026-03-29T05:30:10Z",
    );
    assert_eq!(mark, Some(record));
}
