//! LibreView's columns in the account's language. LibreView writes its
//! header in the language of the account (English `Device Timestamp`,
//! German `Gerätezeitstempel`, Spanish `Sello de tiempo del dispositivo`,
//! Dutch `Tijdstempel apparaat`, French `Horodatage de l'appareil`,
//! Traditional Chinese `裝置時間戳記`, ...);
//! the record types stay numbers and the glucose columns always name their
//! unit (`mg/dL`, `mmol/L`). A column is recognised by word stems of those
//! languages; a glucose column whose role cannot be told, or a header
//! without time, record type and historic glucose, is an error listing the
//! columns found (never a guess by position).

use crate::units::GlucoseUnit;

/// What a column holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Role {
    /// The device's wall time.
    Time,
    /// The record type (0..6).
    RecordType,
    /// Historic (automatic) sensor glucose.
    Historic,
    /// Scan (on-demand) sensor glucose.
    Scan,
    /// Meter strip glucose.
    Strip,
    /// Blood ketone (mmol/L, not glucose).
    Ketone,
    /// Rapid-acting insulin (U).
    Rapid,
    /// Long-acting insulin (U).
    Long,
    /// The device's serial number (which device uploaded the row).
    Serial,
    /// Meal insulin (U).
    Meal,
    /// Correction insulin (U).
    Correction,
    /// Carbohydrates in grams.
    CarbsGrams,
    /// Carbohydrates in servings.
    CarbsServings,
    /// The person's change of the dose the reader's calculator suggested
    /// (U): read only to refuse a dose it changed without the dose itself.
    UserChange,
    /// Known and not needed: device, notes, the
    /// "non-numeric" flag columns.
    Other,
    /// Not recognised.
    Unknown,
}

fn has(name: &str, stems: &[&str]) -> bool {
    stems.iter().any(|s| name.contains(s))
}

const TIME: [&str; 17] = [
    "timestamp",
    "zeitstempel",
    "horodatage",
    "sello de tiempo",
    "marca de tiempo",
    "hora del dispositivo",
    "fecha y hora",
    "tijdstempel",
    "data e ora",
    "data/ora",
    "ora dispositivo",
    "carimbo de data",
    "data/hora",
    "tidsstämpel",
    "tidsstempel",
    "aikaleima",
    // Traditional Chinese (Taiwan): `裝置時間戳記`.
    "時間戳記",
];
// Traditional Chinese `記錄類型`, `歷史葡萄糖`, `掃描葡萄糖`, `葡萄糖試紙`,
// `血酮`, `非數值…`, `使用者變更胰島素`, `速效`, `長效`, `餐時`, `校正`,
// `碳水化合物（克）` and `（份）`, `裝置`, `序號`, `備註`: the names of a
// real export of a LibreView account in Taiwan (see PROVENANCE.md).
const RECORD_TYPE: [&str; 4] = ["typ", "tipo", "type", "類型"];
const HISTORIC: [&str; 5] = ["histor", "histór", "verlauf", "storico", "歷史"];
const SCAN: [&str; 8] = [
    "scan",
    // The older FreeStyle Libre software's Spanish "Glucosa leída".
    "leída",
    "leida",
    "escane",
    "numérisation",
    "numerisation",
    "digitaliz",
    "掃描",
];
const STRIP: [&str; 11] = [
    "strip",
    "streifen",
    "tira",
    "bandelette",
    "striscia",
    "teststrook",
    "sangu",
    // Spanish (Latin America) "Banda de glucosa"; the older French
    // software's "Glycémie avec électrode de dosage".
    "banda",
    "électrode",
    "electrode",
    "試紙",
];
// Spanish "Cuerpos cetónicos" as LibreView writes it.
const KETONE: [&str; 6] = ["keton", "céton", "ceton", "cetón", "cheton", "酮"];
const NON_NUMERIC: [&str; 3] = ["numeri", "numéri", "非數值"];
const USER_CHANGE: [&str; 7] = [
    "user change",
    "änderung",
    "wijzig",
    "cambio",
    "modifi",
    "alteração",
    "變更",
];
const RAPID: [&str; 7] = [
    "rapid", "rápid", "schnell", "snelwerk", "snel", "kurz", "速效",
];
// Spanish "acción larga", French (older software) "action lente".
const LONG: [&str; 10] = [
    "long", "depot", "langwerk", "lenta", "lento", "lente", "larga", "prolong", "basal", "長效",
];
const MEAL: [&str; 7] = [
    "meal", "mahlzeit", "maaltijd", "comida", "repas", "pasto", "餐時",
];
const CORRECTION: [&str; 4] = ["correc", "korrektur", "correz", "校正"];
const CARBS: [&str; 6] = [
    "carb",
    "kohlenhydrat",
    "koolhydrat",
    "glucide",
    "hidrato",
    "碳水化合物",
];
const GRAMS: [&str; 2] = ["gram", "（克）"];
// Spanish "porciones".
const SERVINGS: [&str; 8] = [
    "serving",
    "portion",
    "portie",
    "porcion",
    "racion",
    "ración",
    "porzion",
    "（份）",
];
const SERIAL: [&str; 4] = ["serial", "serie", "série", "序號"];
const OTHER: [&str; 12] = [
    "device",
    "gerät",
    "dispositivo",
    "appareil",
    "apparaat",
    "note",
    "notiz",
    "notit",
    "nota",
    // The older French software's "Commentaires".
    "comment",
    "裝置",
    "備註",
];

/// The role of a header cell, with the glucose unit it names (if any).
pub fn role(header: &str) -> (Role, Option<GlucoseUnit>) {
    let name = header.to_lowercase();
    let unit = crate::read::table::unit_in_name(header);
    if has(&name, &KETONE) {
        return (Role::Ketone, None);
    }
    if let Some(u) = unit {
        let role = if has(&name, &SCAN) {
            Role::Scan
        } else if has(&name, &STRIP) {
            Role::Strip
        } else if has(&name, &HISTORIC) {
            Role::Historic
        } else {
            Role::Unknown
        };
        return (role, Some(u));
    }
    // Older desktop exports name the time column with one word.
    let role = if has(&name, &TIME)
        || ["time", "zeit", "heure", "hora", "ora", "tijd"].contains(&name.trim())
    {
        Role::Time
    } else if has(&name, &NON_NUMERIC) {
        Role::Other
    } else if has(&name, &USER_CHANGE) {
        Role::UserChange
    } else if has(&name, &CARBS) {
        if has(&name, &GRAMS) {
            Role::CarbsGrams
        } else if has(&name, &SERVINGS) {
            Role::CarbsServings
        } else {
            Role::Unknown
        }
    } else if has(&name, &MEAL) {
        Role::Meal
    } else if has(&name, &CORRECTION) {
        Role::Correction
    } else if has(&name, &RAPID) {
        Role::Rapid
    } else if has(&name, &LONG) {
        Role::Long
    } else if has(&name, &RECORD_TYPE) {
        Role::RecordType
    } else if has(&name, &SERIAL) {
        Role::Serial
    } else if has(&name, &OTHER) || name.trim() == "id" {
        // `ID`: the older FreeStyle Libre software's row number.
        Role::Other
    } else {
        Role::Unknown
    };
    (role, None)
}

/// Whether a header row (its cells) is LibreView's: a time column, a
/// record-type column and a glucose column with a unit.
pub fn is_header(cells: &[String]) -> bool {
    let roles: Vec<Role> = cells.iter().map(|c| role(c).0).collect();
    roles.contains(&Role::Time)
        && roles.contains(&Role::RecordType)
        && roles
            .iter()
            .any(|r| matches!(r, Role::Historic | Role::Scan | Role::Strip))
}

/// Splits a raw line into header cells (quotes and spaces trimmed) with
/// the delimiter that occurs most.
pub fn cells(line: &str) -> Vec<String> {
    let count = |d: char| line.matches(d).count();
    let delimiter = [',', ';', '\t']
        .into_iter()
        .max_by_key(|&d| count(d))
        .unwrap_or(',');
    line.split(delimiter)
        .map(|c| c.trim().trim_matches('"').trim().to_string())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_language_names_the_same_roles() {
        let headers = [
            // English
            "Device,Serial Number,Device Timestamp,Record Type,Historic Glucose mg/dL,Scan Glucose mg/dL,Non-numeric Rapid-Acting Insulin,Rapid-Acting Insulin (units),Non-numeric Food,Carbohydrates (grams),Carbohydrates (servings),Non-numeric Long-Acting Insulin,Long-Acting Insulin Value (units),Notes,Strip Glucose mg/dL,Ketone mmol/L,Meal Insulin (units),Correction Insulin (units),User Change Insulin (units)",
            // German
            "Gerät,Seriennummer,Gerätezeitstempel,Aufzeichnungstyp,Glukosewert-Verlauf mg/dL,Glukose-Scan mg/dL,Nicht numerisches schnellwirkendes Insulin,Schnellwirkendes Insulin (Einheiten),Nicht numerische Nahrungsdaten,Kohlenhydrate (Gramm),Kohlenhydrate (Portionen),Nicht numerisches Depotinsulin,Depotinsulin (Einheiten),Notizen,Glukose-Teststreifen mg/dL,Keton mmol/L,Mahlzeiteninsulin (Einheiten),Korrekturinsulin (Einheiten),Insulin-Änderung durch Anwender (Einheiten)",
            // Traditional Chinese (a real export of an account in Taiwan)
            "裝置,序號,裝置時間戳記,記錄類型,歷史葡萄糖 mg/dL,掃描葡萄糖 mg/dL,非數值速效胰島素,速效胰島素（單位）,非數值食品,碳水化合物（克）,碳水化合物（份）,非數值長效胰島素,長效胰島素（單位）,備註,葡萄糖試紙 mg/dL,血酮 mmol/L,餐時胰島素（單位）,校正胰島素（單位）,使用者變更胰島素（單位）",
            // Dutch
            "Apparaat,Serienummer,Tijdstempel apparaat,Gegevenstype,Historische glucose mmol/l,Scan Glucose mmol/l,Niet-numerieke snelwerkende insuline,Snelwerkende insuline (eenheden),Niet-numeriek voedsel,Koolhydraten (gram),Koolhydraten (porties),Niet-numerieke langwerkende insuline,Langwerkende insuline (eenheden),Notities,Strip Glucose mmol/l,Keton mmol/l,Maaltijdinsuline (eenheden),Correctie insuline (eenheden),Wijzigen insuline gebruiker (eenheden)",
        ];
        let want = [
            Role::Other,
            Role::Serial,
            Role::Time,
            Role::RecordType,
            Role::Historic,
            Role::Scan,
            Role::Other,
            Role::Rapid,
            Role::Other,
            Role::CarbsGrams,
            Role::CarbsServings,
            Role::Other,
            Role::Long,
            Role::Other,
            Role::Strip,
            Role::Ketone,
            Role::Meal,
            Role::Correction,
            Role::UserChange,
        ];
        for h in headers {
            let got: Vec<Role> = cells(h).iter().map(|c| role(c).0).collect();
            assert_eq!(got, want, "{h}");
            assert!(is_header(&cells(h)));
        }
        // Spanish (the columns its exports are known to carry).
        let es = cells("Dispositivo,Número de serie,Sello de tiempo del dispositivo,Tipo de registro,Historial de glucosa mg/dL,Escaneo de glucosa mg/dL,Insulina de acción rápida no numérica,Notas");
        let got: Vec<Role> = es.iter().map(|c| role(c).0).collect();
        assert_eq!(
            got,
            [
                Role::Other,
                Role::Serial,
                Role::Time,
                Role::RecordType,
                Role::Historic,
                Role::Scan,
                Role::Other,
                Role::Other
            ]
        );
        assert!(!is_header(&cells(
            "Glucose Data,Generated on,12-04-1961 09:40 UTC,Generated by,Gagarin"
        )));
    }
}
