//! Ten years of 5-minute CGM as export files (for the benchmark and the
//! memory measurement). Not an example of use; a data generator.
#![allow(dead_code, missing_docs)]

use std::fmt::Write;

/// Rows: 10 × 365 days × 288 readings a day.
pub const ROWS: usize = 10 * 365 * 288;

fn glucose(i: usize) -> u32 {
    // A deterministic daily wave with a weekly drift, 60..250 mg/dL.
    let day = (i % 288) as f64 / 288.0 * std::f64::consts::TAU;
    (150.0 + 70.0 * day.sin() + 20.0 * ((i / 2016) as f64).cos()).round() as u32
}

/// `time,glucose_mg_dl` with UTC instants from 2015-01-01.
pub fn plain_csv() -> Vec<u8> {
    let start = jiff::Timestamp::from_second(1_420_070_400).unwrap_or_default();
    let mut s = String::with_capacity(ROWS * 32);
    s.push_str("time,glucose_mg_dl\n");
    for i in 0..ROWS {
        let t = start + jiff::SignedDuration::from_mins(5 * i as i64);
        let _ = writeln!(s, "{},{}", t.strftime("%Y-%m-%dT%H:%M:%SZ"), glucose(i));
    }
    s.into_bytes()
}

/// A Clarity export (local wall times in Europe/Zurich, as the device writes).
pub fn clarity() -> Vec<u8> {
    let zone = jiff::tz::TimeZone::get("Europe/Zurich").unwrap_or(jiff::tz::TimeZone::UTC);
    let start = jiff::Timestamp::from_second(1_420_070_400).unwrap_or_default();
    let mut s = String::with_capacity(ROWS * 80);
    s.push_str("Index,Timestamp (YYYY-MM-DDThh:mm:ss),Event Type,Event Subtype,Patient Info,Device Info,Source Device ID,Glucose Value (mg/dL),Insulin Value (u),Carb Value (grams),Duration (hh:mm:ss),Glucose Rate of Change (mg/dL/min),Transmitter Time (Long Integer),Transmitter ID\r\n");
    for i in 0..ROWS {
        let t = start + jiff::SignedDuration::from_mins(5 * i as i64);
        let wall = zone.to_datetime(t);
        let _ = write!(
            s,
            "{},{},EGV,,,,android G6,{},,,,,{},X\r\n",
            i + 1,
            wall.strftime("%Y-%m-%dT%H:%M:%S"),
            glucose(i),
            300 * i
        );
    }
    s.into_bytes()
}

fn main() {
    // `cargo run --release -p abba-io --example ten_years -- DIR` writes both files.
    let dir = std::env::args().nth(1).unwrap_or_else(|| ".".into());
    let _ = std::fs::write(format!("{dir}/ten_years.csv"), plain_csv());
    let _ = std::fs::write(format!("{dir}/ten_years_clarity.csv"), clarity());
}
