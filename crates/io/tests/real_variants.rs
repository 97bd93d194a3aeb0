//! Variants of the real exports that the shared samples do not show:
//! LibreView in other languages, Nightscout sensor error codes, Tidepool
//! pen insulin. Each is read correctly or refused with a message naming
//! the file, line or JSON path and field.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;
use abba_io::record::{Censor, RecordKind};
use abba_io::Format;
use common::{opts, read};

const DE_HEADER: &str = "Gerät,Seriennummer,Gerätezeitstempel,Aufzeichnungstyp,Glukosewert-Verlauf mmol/L,Glukose-Scan mmol/L,Nicht numerisches schnellwirkendes Insulin,Schnellwirkendes Insulin (Einheiten),Nicht numerische Nahrungsdaten,Kohlenhydrate (Gramm),Kohlenhydrate (Portionen),Nicht numerisches Depotinsulin,Depotinsulin (Einheiten),Notizen,Glukose-Teststreifen mmol/L,Keton mmol/L,Mahlzeiteninsulin (Einheiten),Korrekturinsulin (Einheiten),Insulin-Änderung durch Anwender (Einheiten)";

/// A German account's export in mmol/L: the metadata line, the German
/// header, decimal commas in quoted cells, day-first dates with dots.
fn libreview_german_mmol() -> Vec<u8> {
    let mut s = String::from(
        "\u{feff}Glukose-Werte,Erstellt am,24.02.2021 12:12 UTC,Erstellt von,Test\r\n",
    );
    s.push_str(DE_HEADER);
    s.push_str("\r\n");
    let row = |time: &str, ty: u8, cells: &[(usize, &str)]| {
        let mut c = vec![String::new(); 19];
        c[0] = "FreeStyle Libre 2".into();
        c[1] = "ABC".into();
        c[2] = time.into();
        c[3] = ty.to_string();
        for &(i, v) in cells {
            c[i] = v.into();
        }
        c.join(",") + "\r\n"
    };
    s.push_str(&row("24.02.2021 07:00", 0, &[(4, "\"5,6\"")]));
    s.push_str(&row("24.02.2021 07:15", 0, &[(4, "\"6,1\"")]));
    s.push_str(&row("24.02.2021 07:20", 1, &[(5, "\"6,4\"")]));
    s.push_str(&row("24.02.2021 07:25", 2, &[(14, "\"6,3\"")]));
    s.push_str(&row("24.02.2021 07:30", 3, &[(15, "\"0,2\"")]));
    s.push_str(&row("24.02.2021 07:31", 5, &[(9, "48")]));
    s.push_str(&row("24.02.2021 07:32", 4, &[(7, "\"4,5\"")]));
    s.push_str(&row("24.02.2021 22:00", 4, &[(12, "14")]));
    s.push_str(&row("24.02.2021 12:00", 4, &[(16, "3"), (17, "\"1,5\"")]));
    s.push_str(&row("24.02.2021 13:00", 6, &[(13, "Sport")]));
    s.into_bytes()
}

#[test]
fn libreview_in_german_with_mmol_and_decimal_commas() {
    let b = read(
        &[("de.csv", libreview_german_mmol())],
        &opts("Europe/Berlin"),
    )
    .unwrap();
    assert_eq!(b.formats, vec![Format::LibreView]);
    assert_eq!(b.count("cgm"), 2);
    assert_eq!(b.count("smbg"), 1);
    assert_eq!(b.count("carbs"), 1);
    assert_eq!(b.count("bolus"), 2);
    assert_eq!(b.count("long_acting"), 1);
    let mmol = abba_core::units::MG_DL_PER_MMOL_L;
    let cgm: Vec<f64> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Cgm { glucose } => Some(glucose.mg_dl.0),
            _ => None,
        })
        .collect();
    assert!((cgm[0] - 5.6 * mmol).abs() < 1e-9, "{cgm:?}");
    assert!((cgm[1] - 6.1 * mmol).abs() < 1e-9, "{cgm:?}");
    let smbg = b.records.iter().find_map(|r| match r.kind {
        RecordKind::Smbg { glucose } => Some(glucose.mg_dl.0),
        _ => None,
    });
    assert!((smbg.unwrap() - 6.3 * mmol).abs() < 1e-9);
    let boluses: Vec<f64> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Bolus { units } => Some(units.0),
            _ => None,
        })
        .collect();
    // 4,5 U rapid-acting at 07:32; meal 3 + correction 1,5 U at 12:00.
    assert_eq!(boluses, vec![4.5, 4.5]);
    // Day-first with dots: 24.02.2021 07:00 in Berlin (UTC+1).
    assert_eq!(b.records[0].at.to_string(), "2021-02-24T06:00:00Z");
    // The same file saved as UTF-16 (as some Windows programs do) reads
    // the same.
    let text = String::from_utf8(libreview_german_mmol()).unwrap();
    let utf16: Vec<u8> = text.encode_utf16().flat_map(u16::to_le_bytes).collect();
    assert_eq!(&utf16[..2], &[0xFF, 0xFE]);
    let b16 = read(&[("de.csv", utf16)], &opts("Europe/Berlin")).unwrap();
    assert_eq!(b16.records, b.records);
}

#[test]
fn libreview_in_spanish_dutch_and_french_after_metadata_lines() {
    // (Read together as one person's files: the Dutch reading is 6.8
    // mmol/L, not within 0.1 mmol/L of the Spanish 104 mg/dL at the same
    // minute, which would be the same reading in another unit.)
    let es = "Informe del paciente X,Generado el,05-11-2020 00:45 UTC,Generado por,Y\nX,\n\
              Dispositivo,Número de serie,Sello de tiempo del dispositivo,Tipo de registro,Historial de glucosa mg/dL,Escaneo de glucosa mg/dL,Insulina de acción rápida no numérica,Notas\n\
              FreeStyle LibreLink,,13-05-2020 08:00,0,104,,,\n\
              FreeStyle LibreLink,,13-05-2020 08:15,0,110,,,\n";
    let nl = "Glucosegegevens,Gegenereerd op,13-05-2020 09:00 UTC,Gegenereerd door,Z\n\
              Apparaat,Serienummer,Tijdstempel apparaat,Gegevenstype,Historische glucose mmol/l,Scan Glucose mmol/l,Niet-numerieke snelwerkende insuline,Snelwerkende insuline (eenheden),Niet-numeriek voedsel,Koolhydraten (gram),Koolhydraten (porties),Niet-numerieke langwerkende insuline,Langwerkende insuline (eenheden),Notities,Strip Glucose mmol/l,Keton mmol/l,Maaltijdinsuline (eenheden),Correctie insuline (eenheden),Wijzigen insuline gebruiker (eenheden)\n\
              FreeStyle Libre,S,13-05-2020 08:00,0,\"6,8\",,,,,,,,,,,,,,\n\
              FreeStyle Libre,S,13-05-2020 08:05,5,,,,,,40,,,,,,,,,\n";
    let fr = "Données de glucose,Généré le,05-13-2020 09:00 UTC,Généré par,W\n\
              Appareil,Numéro de série,Horodatage de l'appareil,Type d'enregistrement,Historique de la glycémie mg/dL,Glycémie de la numérisation mg/dL,Insuline à action rapide non numérique,Insuline à action rapide (unités),Glucides (grammes)\n\
              FreeStyle Libre,S,05/13/2020 08:00,0,99,,,,\n\
              FreeStyle Libre,S,05/13/2020 08:05,4,,,,\"2,5\",\n";
    let b = read(
        &[
            ("es.csv", es.into()),
            ("nl.csv", nl.into()),
            ("fr.csv", fr.into()),
        ],
        &opts("Europe/Madrid"),
    )
    .unwrap();
    assert_eq!(b.formats, vec![Format::LibreView; 3]);
    assert_eq!(b.count("cgm"), 4);
    assert_eq!(b.count("carbs"), 1);
    assert_eq!(b.count("bolus"), 1);
    // Every file's first reading is 13 May 2020 08:00 in Madrid (UTC+2).
    for (file, line) in [(0u16, 4u32), (1, 3), (2, 3)] {
        let r = b
            .records
            .iter()
            .find(|r| r.origin.file == file && r.origin.at == abba_io::record::OriginAt::Line(line))
            .unwrap();
        assert_eq!(r.at.to_string(), "2020-05-13T06:00:00Z", "file {file}");
    }
}

/// Spanish column names as LibreView and the older FreeStyle software
/// write them (the HUPA-UCM dataset's exports, CC BY 4.0, and a Latin
/// American LibreView export's 19 columns: names only, the rows are ours).
const ES_LIBRELINK: &str = "Dispositivo,Número de serial,Sello de tiempo del dispositivo,Tipo de registro,Historial de glucosa mg/dL,Escaneo de glucosa mg/dL,Insulina de acción rápida no numérica,Insulina de acción rápida (unidades),Alimento no numérico,Carbohidratos (gramos),Carbohidratos (porciones),Insulina de acción larga no numérica,Insulina de acción larga (unidades),Notas,Tira reactiva para glucosa mg/dL,Cuerpos cetónicos mmol/L,Comida e insulina (unidades),Insulina de corrección (unidades),Insulina del cambio de usuario (unidades)";
const ES_LATAM: &str = "Dispositivo,Número de serie,Sello de tiempo del dispositivo,Tipo de registro,Historial de glucosa mg/dL,Escaneo de glucosa mg/dL,Insulina de acción rápida no numérica,Insulina de acción rápida (unidades),Alimento no numérico,Carbohidratos (gramos),Carbohidratos (porciones),Insulina de acción prolongada no numérica,Insulina de acción prolongada (unidades),Notas,Banda de glucosa mg/dL,Cetona mmol/L,Insulina para la hora de la comida (unidades),Insulina de corrección (unidades),Insulina de cambio de usuario (unidades)";
/// The older FreeStyle software in French (tab-separated).
const FR_DESKTOP: &str = "ID\tHeure\tType d'enregistrement\tHistorique du taux de glucose (mg/dL)\tTaux de glucose scanné (mg/dL)\tInsuline à action rapide (sans valeur numérique)\tInsuline à action rapide (unités)\tNourriture (sans valeur numérique)\tGlucides (grammes)\tInsuline à action lente (sans valeur numérique)\tInsuline à action lente (unités)\tCommentaires\tGlycémie avec électrode de dosage (mg/dL)\tCétonémie (mmol/L)\tInsuline repas (unités)\tInsuline de correction (unités)\tInsuline modifiée par l'utilisateur (unités)";

/// A row to write: its time, record type and the cells set (index, text).
type RowSpec<'a> = (&'a str, u8, &'a [(usize, &'a str)]);

/// Rows of `n` cells (`sep`-joined) with their cells set.
fn rows(sep: &str, n: usize, rows: &[RowSpec<'_>], time_at: usize, type_at: usize) -> String {
    rows.iter()
        .map(|(time, ty, cells)| {
            let mut c = vec![String::new(); n];
            c[time_at] = (*time).into();
            c[type_at] = ty.to_string();
            for &(i, v) in *cells {
                c[i] = v.into();
            }
            c.join(sep) + "\r\n"
        })
        .collect()
}

#[test]
fn libreview_in_spanish_and_older_french_with_ketones_strips_long_acting_and_portions() {
    let es_rows: &[RowSpec<'_>] = &[
        ("13-05-2020 08:00", 0, &[(4, "104")]),
        ("13-05-2020 08:05", 2, &[(14, "98")]),
        ("13-05-2020 08:06", 3, &[(15, "\"0,3\"")]),
        ("13-05-2020 08:10", 4, &[(7, "5")]),
        ("13-05-2020 22:00", 4, &[(12, "16")]),
        ("13-05-2020 08:11", 5, &[(9, "45")]),
        ("13-05-2020 13:00", 5, &[(10, "2")]),
    ];
    let es = format!(
        "Informe del paciente X,Generado el,14-05-2020 00:45 UTC,Generado por,Y\r\nX,\r\n{ES_LIBRELINK}\r\n{}",
        rows(",", 19, es_rows, 2, 3)
    );
    let latam = format!(
        "Informe del paciente X,Generado el,14-05-2020 00:45 UTC,Generado por,Y\r\n{ES_LATAM}\r\n{}",
        rows(",", 19, es_rows, 2, 3)
    );
    let fr_rows: &[RowSpec<'_>] = &[
        ("2020/05/13 08:00", 0, &[(3, "104")]),
        ("2020/05/13 08:05", 2, &[(12, "98")]),
        ("2020/05/13 08:06", 3, &[(13, "0,3")]),
        ("2020/05/13 08:10", 4, &[(6, "5")]),
        ("2020/05/13 22:00", 4, &[(10, "16")]),
        ("2020/05/13 08:11", 5, &[(8, "45")]),
        ("2020/05/13 13:00", 6, &[(11, "Café")]),
    ];
    let fr = format!(
        "Patient X\r\n{FR_DESKTOP}\r\n{}",
        rows("\t", 17, fr_rows, 1, 2)
    );
    for (name, text) in [("es.csv", es), ("latam.csv", latam), ("fr.txt", fr)] {
        let b = read(&[(name, text.into_bytes())], &opts("Europe/Madrid"))
            .unwrap_or_else(|e| panic!("{name}: {e}"));
        assert_eq!(b.formats, vec![Format::LibreView], "{name}");
        assert_eq!(b.unread.count, 0, "{name}: {:?}", b.unread);
        let kinds: Vec<(String, &RecordKind)> = b
            .records
            .iter()
            .map(|r| (r.at.to_string(), &r.kind))
            .collect();
        let one = |at: &str| {
            kinds
                .iter()
                .filter(|(t, _)| t == at)
                .map(|(_, k)| *k)
                .collect::<Vec<_>>()
        };
        assert!(
            matches!(one("2020-05-13T06:00:00Z")[..], [RecordKind::Cgm { glucose }] if glucose.mg_dl.0 == 104.0),
            "{name}"
        );
        assert!(
            matches!(one("2020-05-13T06:05:00Z")[..], [RecordKind::Smbg { glucose }] if glucose.mg_dl.0 == 98.0),
            "{name}"
        );
        assert!(
            matches!(one("2020-05-13T06:06:00Z")[..], [RecordKind::Ignored { kind }] if kind == "ketone"),
            "{name}"
        );
        assert!(
            matches!(one("2020-05-13T06:10:00Z")[..], [RecordKind::Bolus { units }] if units.0 == 5.0),
            "{name}"
        );
        assert!(
            matches!(one("2020-05-13T20:00:00Z")[..], [RecordKind::LongActing { units }] if units.0 == 16.0),
            "{name}"
        );
        assert!(
            matches!(one("2020-05-13T06:11:00Z")[..], [RecordKind::Carbs { grams }] if grams.0 == 45.0),
            "{name}"
        );
        assert!(
            matches!(
                one("2020-05-13T11:00:00Z")[..],
                [RecordKind::Ignored { .. }]
            ),
            "{name}"
        );
    }
}

#[test]
fn libreview_headers_abba_cannot_read_are_refused_with_the_columns_found() {
    // A language abba does not know: no column is recognised.
    let pl = "Urządzenie,Numer seryjny,Sygnatura czasowa urządzenia,Rodzaj rekordu,Historia glikemii mg/dL\n\
              FreeStyle Libre,S,13-05-2020 08:00,0,99\n";
    let err = read(
        &[("pl.csv", pl.into())],
        &abba_io::ReadOptions {
            format: Some(Format::LibreView),
            ..opts("Europe/Warsaw")
        },
    )
    .unwrap_err()
    .to_string();
    assert!(err.starts_with("pl.csv: no LibreView header"), "{err}");
    assert!(err.contains("Historia glikemii mg/dL"), "{err}");
    // A glucose column whose role cannot be told is not guessed.
    let odd = "Device,Serial Number,Device Timestamp,Record Type,Historic Glucose mg/dL,Sensor Glucose mg/dL\n\
               FreeStyle Libre,S,13-05-2020 08:00,0,99,\n";
    let err = read(&[("odd.csv", odd.into())], &opts("Europe/Madrid"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("\"Sensor Glucose mg/dL\""), "{err}");
    assert!(err.contains("historic, scan or strip"), "{err}");
}

#[test]
fn libreview_rows_that_would_lose_data_are_left_out_naming_line_and_field() {
    let head = "Glucose Data,Generated on,13-05-2020 09:00 UTC,Generated by,T\n\
                Device,Serial Number,Device Timestamp,Record Type,Historic Glucose mg/dL,Fiasp (units)\n\
                FreeStyle Libre,S,13-05-2020 08:00,0,99,\n";
    // Each row is left out and reported (line and field), the rest read.
    // Insulin in a column abba does not recognise.
    let unknown = format!("{head}FreeStyle Libre,S,13-05-2020 08:05,4,,6\n");
    let (b, err) = common::read_in_part(&[("u.csv", unknown.into())], &opts("Europe/Madrid"));
    assert_eq!(b.count("cgm"), 1, "the row before it is read");
    assert!(
        err.starts_with("u.csv: line 4, field \"Fiasp (units)\""),
        "{err}"
    );
    // A record type written as a word.
    let word = format!("{head}FreeStyle Libre,S,13-05-2020 08:05,Historic,98,\n");
    let (b, err) = common::read_in_part(&[("w.csv", word.into())], &opts("Europe/Madrid"));
    assert_eq!(b.count("cgm"), 1, "the row before it is read");
    assert!(
        err.starts_with("w.csv: line 4, field \"Record Type\""),
        "{err}"
    );
    // 1,500 in a comma file: thousands separator or decimal comma.
    let ambiguous = format!("{head}FreeStyle Libre,S,13-05-2020 08:05,0,\"1,500\",\n");
    let (b, err) = common::read_in_part(&[("a.csv", ambiguous.into())], &opts("Europe/Madrid"));
    assert_eq!(b.count("cgm"), 1, "the row before it is read");
    assert!(
        err.starts_with("a.csv: line 4, field \"Historic Glucose mg/dL\""),
        "{err}"
    );
}

#[test]
fn nightscout_sgv_error_codes_are_counted_not_read_as_glucose() {
    // Dexcom error states arrive as sgv 1..12; 10 and 12 would otherwise
    // pass as (absurdly low) glucose.
    let entries = r#"[
 {"_id":"a","type":"sgv","sgv":120,"date":1709557200000},
 {"_id":"b","type":"sgv","sgv":10,"date":1709557500000},
 {"_id":"c","type":"sgv","sgv":12,"date":1709557800000},
 {"_id":"d","type":"sgv","sgv":1,"date":1709558100000},
 {"_id":"e","type":"sgv","sgv":39,"date":1709558400000},
 {"_id":"f","type":"sgv","sgv":41,"date":1709558700000},
 {"_id":"g","type":"sgv","sgv":45,"date":1709559000000}
]"#;
    let b = read(&[("e.json", entries.into())], &opts("UTC")).unwrap();
    assert_eq!(b.count("cgm"), 4);
    let kinds: Vec<String> = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Ignored { kind } => Some(kind.clone()),
            _ => None,
        })
        .collect();
    assert_eq!(
        kinds,
        [
            "sgv sensor error code 10",
            "sgv sensor error code 12",
            "sgv sensor error code 1"
        ]
    );
    // Mostly "error codes": glucose in mmol/L, refused as a unit error.
    let mmol = r#"[
 {"_id":"a","type":"sgv","sgv":6,"date":1709557200000},
 {"_id":"b","type":"sgv","sgv":7,"date":1709557500000},
 {"_id":"c","type":"sgv","sgv":120,"date":1709557800000}
]"#;
    let err = read(&[("m.json", mmol.into())], &opts("UTC")).unwrap_err();
    assert!(matches!(err, abba_io::IoError::Units { .. }), "{err}");
    assert!(err.to_string().contains("2 of 3 sgv values"), "{err}");
    // A negative or fractional sgv is not an error code: refused.
    let bad = r#"[{"_id":"a","type":"sgv","sgv":-5,"date":1709557200000}]"#;
    let err = read(&[("n.json", bad.into())], &opts("UTC")).unwrap_err();
    assert!(err.to_string().contains("$[0], field \"sgv\""), "{err}");
}

/// The bottom of a real night-time low as iAPS uploads it to Nightscout
/// (the layout of GlucoseDAO/cgm_format's `data/input/nightscout_entries.json`,
/// MIT, real iAPS data: `glucose`, `unfiltered` and `uncalibrated` beside
/// `sgv`, `utcOffset` 0, a UUID `_id`): 98 -> 32 -> 55 mg/dL over 1 h 45.
/// Values between 13 and 38 are glucose, not Dexcom's error codes (0-12):
/// dropping them hid the lowest readings of a severe hypoglycaemia.
#[test]
fn nightscout_sgv_between_13_and_38_is_the_bottom_of_a_low_not_an_error_code() {
    // An hour of the evening's fall, then the low.
    let values = [
        98, 94, 90, 87, 83, 79, 75, 71, 67, 63, 60, 56, 53, 51, 47, 43, 38, 34, 32, 34, 43, 55,
    ];
    let start_ms: i64 = 1_775_338_223_000; // 2026-04-04T21:30:23Z
    let items: Vec<String> = values
        .iter()
        .enumerate()
        .map(|(k, v)| {
            let ms = start_ms + 300_000 * k as i64;
            let at = jiff::Timestamp::from_millisecond(ms).unwrap();
            format!(
                r#"{{"_id":"6E2C1B7A-0D4F-4C55-9A1E-3B2F6A7C8D{k:02}","date":{ms},"dateString":"{at}","glucose":{v},"direction":"Flat","type":"sgv","sessionStartDate":"2026-04-02T14:10:28.450Z","sgv":{v},"unfiltered":{v},"uncalibrated":{v},"utcOffset":0,"sysTime":"{at}"}}"#
            )
        })
        .collect();
    let entries = format!("[{}]", items.join(",\n"));
    let b = read(
        &[("entries.json", entries.clone().into())],
        &opts("Europe/Moscow"),
    )
    .unwrap();
    let got: Vec<f64> = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Cgm { glucose } => Some(glucose.mg_dl.0),
            _ => None,
        })
        .collect();
    assert_eq!(
        got,
        values.map(f64::from),
        "every reading of the low is kept"
    );
    assert!(
        b.notes
            .iter()
            .any(|n| n.contains("4 sgv values between 13 and 38 mg/dL are kept as glucose")),
        "{:?}",
        b.notes
    );
    // With an error code among them, the code is still not glucose, and
    // the note says it was dropped.
    let with_code = entries.replacen("\"sgv\":53", "\"sgv\":5", 1);
    let b = read(
        &[("entries.json", with_code.into())],
        &opts("Europe/Moscow"),
    )
    .unwrap();
    assert_eq!(b.count("cgm"), values.len() - 1);
    assert!(
        b.notes
            .iter()
            .any(|n| n.contains("1 sgv values are Dexcom's error codes")),
        "{:?}",
        b.notes
    );
    // Integer glucose in mmol/L (5-20) is still refused as a unit error,
    // whether it reads as codes or as lows.
    let mmol = r#"[
 {"_id":"a","type":"sgv","sgv":14,"date":1709557200000},
 {"_id":"b","type":"sgv","sgv":16,"date":1709557500000},
 {"_id":"c","type":"sgv","sgv":6,"date":1709557800000},
 {"_id":"d","type":"sgv","sgv":120,"date":1709558100000}
]"#;
    let err = read(&[("m.json", mmol.into())], &opts("UTC")).unwrap_err();
    assert!(matches!(err, abba_io::IoError::Units { .. }), "{err}");
    assert!(
        err.to_string().contains("3 of 4 sgv values are below 39"),
        "{err}"
    );
}

#[test]
fn nightscout_date_in_seconds_is_refused() {
    let entries = r#"[{"_id":"a","type":"sgv","sgv":120,"date":1709557200}]"#;
    let err = read(&[("s.json", entries.into())], &opts("UTC"))
        .unwrap_err()
        .to_string();
    assert!(err.starts_with("s.json: $[0], field \"date\""), "{err}");
    assert!(err.contains("looks like seconds"), "{err}");
}

/// A schedule record: its instant, basal and carb-ratio segments.
type Sched = (String, Vec<(u32, f64)>, Vec<(u32, f64)>);

#[test]
fn nightscout_profile_switch_percentage_temporary_and_timeshift() {
    let profile = r#"{\"basal\":[{\"time\":\"00:00\",\"value\":1.0},{\"time\":\"12:00\",\"value\":0.5}],\"carbratio\":[{\"time\":\"00:00\",\"value\":10}]}"#;
    let treatments = format!(
        r#"[
 {{"_id":"p1","eventType":"Profile Switch","created_at":"2024-03-04T00:00:00Z","profile":"A","percentage":80,"timeshift":0,"duration":0,"profileJson":"{profile}"}},
 {{"_id":"p2","eventType":"Profile Switch","created_at":"2024-03-05T00:00:00Z","profile":"A","percentage":150,"duration":120,"profileJson":"{profile}"}},
 {{"_id":"p3","eventType":"Profile Switch","created_at":"2024-03-06T00:00:00Z","profile":"A","timeshift":2,"profileJson":"{profile}"}}
]"#
    );
    let b = read(&[("t.json", treatments.into())], &opts("UTC")).unwrap();
    let schedules: Vec<Sched> = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Schedule { profile } => Some((
                r.at.to_string(),
                profile
                    .basal
                    .segments
                    .iter()
                    .map(|s| (s.0, s.1 .0))
                    .collect(),
                profile.carb_ratio.iter().map(|s| (s.0, s.1 .0)).collect(),
            )),
            _ => None,
        })
        .collect();
    let s = |at: &str, basal: &[(u32, f64)], cr: &[(u32, f64)]| {
        (at.to_string(), basal.to_vec(), cr.to_vec())
    };
    assert_eq!(
        schedules,
        vec![
            // 80 %: basal ×0.8, carb ratio ÷0.8.
            s(
                "2024-03-04T00:00:00Z",
                &[(0, 0.8), (720, 0.4)],
                &[(0, 12.5)]
            ),
            // 150 % for two hours, then the permanent 80 % again.
            s(
                "2024-03-05T00:00:00Z",
                &[(0, 1.5), (720, 0.75)],
                &[(0, 10.0 / 1.5)]
            ),
            s(
                "2024-03-05T02:00:00Z",
                &[(0, 0.8), (720, 0.4)],
                &[(0, 12.5)]
            ),
            // Shifted 2 h later: 00:00-02:00 has the profile's 22:00-24:00.
            s(
                "2024-03-06T00:00:00Z",
                &[(0, 0.5), (120, 1.0), (840, 0.5)],
                &[(0, 10.0)]
            ),
        ]
    );
    assert_eq!(b.count("ignored"), 0);
}

#[test]
fn nightscout_profile_switch_timeshift_in_hours_or_androidaps_milliseconds() {
    let profile =
        r#"{\"basal\":[{\"time\":\"00:00\",\"value\":1.0},{\"time\":\"06:00\",\"value\":2.0}]}"#;
    let one = |shift: &str| {
        let t = format!(
            r#"[{{"_id":"p","eventType":"Profile Switch","created_at":"2024-03-04T00:00:00Z","profile":"A","percentage":100,"timeshift":{shift},"duration":0,"profileJson":"{profile}"}}]"#
        );
        read(&[("t.json", t.into())], &opts("UTC")).map(|b| match &b.records[0].kind {
            RecordKind::Schedule { profile } => profile
                .basal
                .segments
                .iter()
                .map(|s| (s.0, s.1 .0))
                .collect::<Vec<_>>(),
            other => panic!("{other:?}"),
        })
    };
    // AndroidAPS 3.2+ writes -1 h as -3600000; older versions as -1.
    // The profile's 06:00-24:00 at 2.0 runs 05:00-23:00.
    let earlier = vec![(0, 1.0), (300, 2.0), (1380, 1.0)];
    assert_eq!(one("-3600000").unwrap(), earlier);
    assert_eq!(one("-1").unwrap(), earlier);
    let e = one("90").unwrap_err().to_string();
    assert!(e.contains("timeshift"), "{e}");
}

#[test]
fn a_temporary_switch_with_no_permanent_one_before_it_is_counted() {
    let profile = r#"{\"basal\":[{\"time\":\"00:00\",\"value\":1.0}]}"#;
    let t = format!(
        r#"[
 {{"_id":"b","eventType":"Correction Bolus","created_at":"2024-03-05T08:00:00Z","insulin":1}},
 {{"_id":"p","eventType":"Profile Switch","created_at":"2024-03-05T00:00:00Z","profile":"A","percentage":50,"duration":60,"profileJson":"{profile}"}}
]"#
    );
    let b = read(&[("t.json", t.into())], &opts("UTC")).unwrap();
    assert_eq!(b.count("basal_schedule"), 0);
    assert!(b.records.iter().any(|r| matches!(&r.kind,
        RecordKind::Ignored { kind } if kind.starts_with("Profile Switch, temporary, and the file holds no permanent switch"))));
}

#[test]
fn tidepool_pen_insulin_and_food_totals() {
    let data = r#"[
 {"id":"i1","type":"insulin","time":"2024-03-04T08:00:00Z","dose":{"units":"Units","total":4.5},"formulation":{"simple":{"actingType":"rapid"}}},
 {"id":"i2","type":"insulin","time":"2024-03-04T22:00:00Z","dose":{"units":"Units","total":18},"formulation":{"simple":{"actingType":"long"}}},
 {"id":"i3","type":"insulin","time":"2024-03-04T23:00:00Z","dose":{"units":"Units","total":2}},
 {"id":"f1","type":"food","time":"2024-03-04T08:00:00Z","nutrition":{"carbohydrate":{"total":52,"units":"grams"}}},
 {"id":"c1","type":"cbg","time":"2024-03-04T08:10:00.000Z","units":"mmol/L","value":7.3}
]"#;
    let b = read(&[("tp.json", data.into())], &Default::default()).unwrap();
    assert_eq!(b.formats, vec![Format::Tidepool]);
    assert_eq!(b.count("bolus"), 1);
    assert_eq!(b.count("long_acting"), 1);
    assert_eq!(b.count("carbs"), 1);
    assert!(b.records.iter().any(
        |r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == "insulin without an acting type")
    ));
    let bad =
        r#"[{"id":"i1","type":"insulin","time":"2024-03-04T08:00:00Z","dose":{"units":"Units"}}]"#;
    let err = read(&[("tp.json", bad.into())], &Default::default())
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("tp.json: $[0], field \"dose.total\""),
        "{err}"
    );
}

#[test]
fn clarity_mmol_calibrations_censored_values_and_rows_without_time() {
    let head = "Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mmol/L),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mmol/L/min),Transmitter Time (Long Integer),Transmitter ID\n\
                1,,FirstName,,Ana,,,,,,,,,\n\
                2,,Device,,,Dexcom G7,,,,,,,,\n";
    let rows = "3,2024-03-04T08:00:00,EGV,,,,G7,\"5,6\",,,,,1,X\n\
                4,2024-03-04T08:05:00,EGV,,,,G7,Low,,,,,2,X\n\
                5,2024-03-04T08:10:00,EGV,,,,G7,High,,,,,3,X\n\
                6,2024-03-04T08:11:00,Calibration,,,,G7,6.1,,,,,4,X\n\
                7,2024-03-04T09:00:00,Exercise,Medium,,,G7,,,,0:30:00,,5,X\n";
    let b = read(
        &[("c.csv", format!("{head}{rows}").into())],
        &opts("Europe/Zurich"),
    )
    .unwrap();
    assert_eq!(b.formats, vec![Format::Clarity]);
    let mmol = abba_core::units::MG_DL_PER_MMOL_L;
    let cgm: Vec<(f64, abba_io::record::Censor)> = b
        .records
        .iter()
        .filter_map(|r| match r.kind {
            RecordKind::Cgm { glucose } => Some((glucose.mg_dl.0, glucose.censor)),
            _ => None,
        })
        .collect();
    use abba_io::record::Censor;
    assert_eq!(cgm.len(), 3);
    assert!((cgm[0].0 - 5.6 * mmol).abs() < 1e-9 && cgm[0].1 == Censor::Exact);
    assert!((cgm[1].0 - 2.2 * mmol).abs() < 1e-9 && cgm[1].1 == Censor::Below);
    assert!((cgm[2].0 - 22.2 * mmol).abs() < 1e-9 && cgm[2].1 == Censor::Above);
    assert_eq!(b.count("smbg"), 1);
    assert!(b
        .records
        .iter()
        .any(|r| matches!(&r.kind, RecordKind::Ignored { kind } if kind == "Exercise Medium")));
    // Insulin without its subtype: rapid or long-acting is not guessed.
    let insulin = format!("{head}8,2024-03-04T08:00:00,Insulin,,,,G7,,4,,,,6,X\n");
    let err = read(&[("c.csv", insulin.into())], &opts("Europe/Zurich"))
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("c.csv: line 4, field \"Event Subtype\""),
        "{err}"
    );
    // An EGV row that lost its time is not skipped as preamble.
    let lost = format!("{head}8,,EGV,,,,G7,7.0,,,,,6,X\n");
    let err = read(&[("c.csv", lost.into())], &opts("Europe/Zurich"))
        .unwrap_err()
        .to_string();
    assert!(
        err.starts_with("c.csv: line 4, field \"Timestamp (YYYY-MM-DDThh:mm:ss)\""),
        "{err}"
    );
}

#[test]
fn tidepool_mmol_to_five_decimals_is_the_whole_mg_dl_the_sensor_read() {
    // Tidepool keeps a sensor's mg/dL in mmol/L to 5 decimals: 54, 70,
    // 180 and 250 mg/dL come back a hair off (53.99993, 180.00003), on
    // the wrong side of the thresholds the metrics count. A meter's
    // 5.6 mmol/L is kept as it is.
    let whole = [54.0, 70.0, 100.0, 180.0, 250.0, 39.0, 401.0];
    let mut items: Vec<String> = whole
        .iter()
        .enumerate()
        .map(|(i, mg)| {
            let mmol = (mg / 18.01559_f64 * 1e5).round() / 1e5;
            format!(
                r#"{{"type":"cbg","units":"mmol/L","value":{mmol},"time":"2024-03-14T06:{:02}:00.000Z","id":"c{i}"}}"#,
                i * 5
            )
        })
        .collect();
    items.push(r#"{"type":"smbg","units":"mmol/L","value":5.6,"time":"2024-03-14T07:00:00.000Z","id":"m"}"#.into());
    // The export in mg/dL writes the product itself.
    items.push(r#"{"type":"cbg","units":"mg/dL","value":100.0000362,"time":"2024-03-14T07:05:00.000Z","id":"x"}"#.into());
    let json = format!("[{}]", items.join(",\n"));
    assert!(
        json.contains("5.55075") && json.contains("2.9974"),
        "{json}"
    );
    let b = read(&[("tp.json", json.into_bytes())], &opts("UTC")).unwrap();
    let got: Vec<f64> = b
        .records
        .iter()
        .map(|r| match &r.kind {
            RecordKind::Cgm { glucose } | RecordKind::Smbg { glucose } => glucose.mg_dl.0,
            other => panic!("{other:?}"),
        })
        .collect();
    let mut want = whole.to_vec();
    want.push(5.6 * 18.01559);
    want.push(100.0);
    assert_eq!(got, want);
}

/// Windows-1252 bytes of `text` (its letters are all Latin-1).
fn windows_1252(text: &str) -> Vec<u8> {
    text.chars()
        .map(|c| u8::try_from(u32::from(c)).expect("a Latin-1 letter"))
        .collect()
}

#[test]
fn a_windows_1252_export_is_read_with_its_accented_column_names() {
    // The French export saved again by Excel on Windows: `é` is the byte
    // 0xE9, which is no UTF-8; the glucose columns' names carry it.
    let fr = "Données de glucose,Généré le,14-05-2020 09:00 UTC,Généré par,W\r\n\
              Appareil,Numéro de série,Horodatage de l'appareil,Type d'enregistrement,Historique de la glycémie mg/dL,Numérisation de la glycémie mg/dL,Glycémie par bandelette mg/dL,Notes\r\n\
              FreeStyle Libre,S,13-05-2020 08:00,0,99,,,\r\n\
              FreeStyle Libre,S,13-05-2020 08:05,1,,104,,\r\n\
              FreeStyle Libre,S,13-05-2020 08:06,2,,,101,\r\n\
              FreeStyle Libre,S,13-05-2020 08:10,6,,,,Café au lait\r\n";
    let bytes = windows_1252(fr);
    assert!(std::str::from_utf8(&bytes).is_err());
    let b = read(&[("fr.csv", bytes)], &opts("Europe/Paris")).unwrap();
    assert_eq!(b.formats, vec![Format::LibreView]);
    assert_eq!(
        (b.count("cgm"), b.count("smbg"), b.count("ignored")),
        (1, 1, 2)
    );
    assert!(
        b.notes
            .iter()
            .any(|n| n.starts_with("fr.csv: not UTF-8 text: read as Windows-1252")),
        "{:?}",
        b.notes
    );
    // The same file in UTF-8 has no such note; cut within its last `é`,
    // it is still UTF-8 (cut short), not Windows-1252.
    let b = read(&[("fr.csv", fr.into())], &opts("Europe/Paris")).unwrap();
    assert!(
        b.notes.iter().all(|n| !n.contains("Windows-1252")),
        "{:?}",
        b.notes
    );
    let cut = &fr.as_bytes()[..fr.find("é au lait").unwrap() + 1];
    let b = read(&[("fr.csv", cut.to_vec())], &opts("Europe/Paris")).unwrap();
    assert!(
        b.notes.iter().all(|n| !n.contains("Windows-1252")),
        "{:?}",
        b.notes
    );
    assert_eq!((b.count("cgm"), b.count("smbg")), (1, 1));
}

/// Dexcom Clarity set to Spanish, as the HUPA-UCM dataset's Dexcom files
/// are (CC BY 4.0; read by public scripts with `;`, a BOM, and the names
/// "Marca temporal (AAAA-MM-DDThh:mm:ss)", "Tipo de evento", "Nivel de
/// glucosa (mg/dl)", "Nivel de insulina (u)", "Nivel de carbohidratos
/// (gramos)", sensor rows of the type "Niveles estimados de glucosa");
/// the other column names and every row are ours.
fn clarity_spanish(extra: &str) -> Vec<u8> {
    let mut s = String::from(
        "\u{feff}Índice;Marca temporal (AAAA-MM-DDThh:mm:ss);Tipo de evento;Subtipo de evento;Información del paciente;Información del dispositivo;ID del dispositivo de origen;Nivel de glucosa (mg/dl);Nivel de insulina (u);Nivel de carbohidratos (gramos);Duración (hh:mm:ss);Tasa de cambio de glucosa (mg/dl/min);Hora del transmisor (entero largo);ID del transmisor\r\n\
         1;;Nombre;;Ana;;;;;;;;;\r\n\
         2;;Dispositivo;;;G6;G6;;;;;;;\r\n",
    );
    for k in 0..6 {
        let value = match k {
            2 => "Nivel bajo".to_string(),
            3 => "Nivel alto".to_string(),
            _ => (100 + 4 * k).to_string(),
        };
        s.push_str(&format!(
            "{};2021-06-18T08:{:02}:07;Niveles estimados de glucosa;;;;G6;{value};;;;;{};8XXXXX\r\n",
            k + 3,
            k * 5,
            400_000 + 300 * k
        ));
    }
    s.push_str("9;2021-06-18T08:31:00;Carbohidratos;;;;G6;;;45;;;;\r\n");
    s.push_str(extra);
    s.into_bytes()
}

#[test]
fn clarity_in_spanish_reads_its_sensor_rows_and_refuses_a_glucose_it_cannot_name() {
    let b = read(&[("es.csv", clarity_spanish(""))], &opts("Europe/Madrid")).unwrap();
    assert_eq!(b.formats, vec![Format::Clarity]);
    let cgm: Vec<(String, f64, Censor)> = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Cgm { glucose } => {
                Some((r.at.to_string(), glucose.mg_dl.0, glucose.censor))
            }
            _ => None,
        })
        .collect();
    assert_eq!(cgm.len(), 6, "{:?}", b.records);
    let at = |m: u32| format!("2021-06-18T06:{m:02}:07Z");
    assert_eq!(cgm[0], (at(0), 100.0, Censor::Exact));
    // "Nivel bajo" and "Nivel alto": the sensor's limits, censored.
    assert_eq!(cgm[2], (at(10), 40.0, Censor::Below));
    assert_eq!(cgm[3], (at(15), 400.0, Censor::Above));
    assert_eq!(cgm[5], (at(25), 120.0, Censor::Exact));
    assert_eq!(b.count("carbs"), 1);
    // An event type abba cannot name that carries a glucose value is left
    // out and reported, never counted away as ignored.
    let odd = "10;2021-06-18T08:35:07;Glucosa del sensor;;;;G6;131;;;;;402100;8XXXXX\r\n";
    let (b, first) =
        common::read_in_part(&[("es.csv", clarity_spanish(odd))], &opts("Europe/Madrid"));
    assert_eq!(b.count("cgm"), 6);
    assert!(
        first.starts_with("es.csv: line 11, field \"Tipo de evento\"")
            && first.contains("\"Glucosa del sensor\" carries a glucose value"),
        "{first}"
    );
}

#[test]
fn clarity_in_italian_reads_basso_and_alto_as_the_sensors_limits() {
    // A G7 export with Clarity set to Italian (`clarity_g7_italian_synthetic.csv`,
    // the layout of a real one): quoted `;` cells, a BOM, CRLF, Italian
    // column names, the event types `EGV` and `Calibrazione`, preamble rows
    // `Nome`, `Cognome`, `Dispositivo`, `Avviso` one cell short, and a
    // reading below the sensor's range written "Basso" in the glucose
    // column (above it, "Alto").
    let file = common::fixture("clarity_g7_italian_synthetic.csv");
    let b = read(&[("it.csv", file)], &opts("Europe/Rome")).unwrap();
    assert_eq!(b.formats, vec![Format::Clarity]);
    assert_eq!(b.unread.count, 0, "{:?}", b.notes);
    let cgm: Vec<(String, f64, Censor)> = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Cgm { glucose } => {
                Some((r.at.to_string(), glucose.mg_dl.0, glucose.censor))
            }
            _ => None,
        })
        .collect();
    assert_eq!(cgm.len(), 22, "{cgm:?}");
    // 06:00:41 in Rome in November is 05:00:41 UTC.
    assert_eq!(cgm[0], ("2026-11-03T05:00:41Z".into(), 92.0, Censor::Exact));
    let below: Vec<&str> = cgm
        .iter()
        .filter(|c| c.2 == Censor::Below)
        .map(|c| c.0.as_str())
        .collect();
    assert_eq!(below, ["2026-11-03T05:25:41Z", "2026-11-03T05:30:41Z"]);
    assert!(cgm
        .iter()
        .filter(|c| c.2 == Censor::Below)
        .all(|c| c.1 == 40.0));
    let above: Vec<(&str, f64)> = cgm
        .iter()
        .filter(|c| c.2 == Censor::Above)
        .map(|c| (c.0.as_str(), c.1))
        .collect();
    assert_eq!(
        above,
        [
            ("2026-11-03T06:25:41Z", 400.0),
            ("2026-11-03T06:30:41Z", 400.0)
        ]
    );
    let smbg: Vec<f64> = b
        .records
        .iter()
        .filter_map(|r| match &r.kind {
            RecordKind::Smbg { glucose } => Some(glucose.mg_dl.0),
            _ => None,
        })
        .collect();
    assert_eq!(smbg, [57.0]);
    assert!(
        b.notes.iter().any(|n| n.contains("10 rows without a time")
            && n.contains("Avviso 7")
            && n.contains("Nome 1")),
        "{:?}",
        b.notes
    );
    // A word abba does not know in the glucose column is reported, not
    // read as a limit: the German export's words are not known.
    let text = String::from_utf8(common::fixture("clarity_g7_italian_synthetic.csv")).unwrap();
    // The first "Basso" reading (line 17), its glucose cell only.
    let odd = text.replacen("\"iOS G7\";\"Basso\"", "\"iOS G7\";\"Niedrig\"", 1);
    assert_ne!(odd, text);
    let (b, first) = common::read_in_part(&[("it.csv", odd.into_bytes())], &opts("Europe/Rome"));
    assert_eq!(b.count("cgm"), 21);
    assert!(
        first.starts_with("it.csv: line 17, field \"Valore del glucosio (mg/dL)\"")
            && first.contains("Niedrig"),
        "{first}"
    );
}
