//! The CSV form of an [`InputDay`]: header
//! `minute,cho_g_per_min,insulin_u_per_min` (other columns are ignored), one
//! row per minute from 0. A last row with both input cells empty (the
//! final-glucose row of the simglucose reference files) carries no input.

use super::{InputDay, MinuteRates};
use crate::SimError;

/// The three columns read (and written, in this order).
pub const INPUT_COLUMNS: [&str; 3] = ["minute", "cho_g_per_min", "insulin_u_per_min"];

impl InputDay {
    /// Reads an input day from CSV text; `file` names it in errors. Every
    /// row is checked (consecutive minutes from 0, rates finite, `>= 0` and
    /// within [`MinuteRates::check`]'s limits) before anything is returned;
    /// an error names the file, the line and the column.
    pub fn from_csv(file: &str, text: &str) -> Result<InputDay, SimError> {
        let err = |line: u64, reason: String| SimError::InputFile {
            file: file.to_string(),
            line,
            reason,
        };
        let mut rdr = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .from_reader(text.as_bytes());
        let header = rdr
            .headers()
            .map_err(|e| err(1, format!("cannot read the header: {e}")))?
            .clone();
        let col = |name: &str| {
            header.iter().position(|h| h == name).ok_or_else(|| {
                err(
                    1,
                    format!(
                        "missing column '{name}' (expected {}; found {})",
                        INPUT_COLUMNS.join(","),
                        header.iter().collect::<Vec<_>>().join(",")
                    ),
                )
            })
        };
        let cols = [
            col(INPUT_COLUMNS[0])?,
            col(INPUT_COLUMNS[1])?,
            col(INPUT_COLUMNS[2])?,
        ];
        let mut minutes = Vec::new();
        // A last row whose two input cells are both empty only carries the
        // final glucose; anywhere else an empty cell is an error.
        let mut final_row: Option<u64> = None;
        // Line numbers from byte offsets. After a CRLF line end the csv
        // crate puts a record's start on the LF of the line before (and
        // counts its lines one too low), so line ends at the offset are
        // skipped before counting.
        let bytes = text.as_bytes();
        let line_at = |byte: u64| {
            let mut at = usize::try_from(byte).map_or(bytes.len(), |b| b.min(bytes.len()));
            while at < bytes.len() && matches!(bytes[at], b'\r' | b'\n') {
                at += 1;
            }
            1 + bytes[..at].iter().filter(|&&b| b == b'\n').count() as u64
        };
        let mut record = csv::StringRecord::new();
        loop {
            let line = line_at(rdr.position().byte());
            match rdr.read_record(&mut record) {
                Ok(true) => {}
                Ok(false) => break,
                Err(e) => return Err(err(line, format!("malformed CSV row: {e}"))),
            }
            let line = record.position().map_or(line, |p| line_at(p.byte()));
            if let Some(at) = final_row {
                return Err(err(
                    at,
                    format!("empty cho_g_per_min and insulin_u_per_min are only allowed on the last row (the final-glucose row), but line {line} follows"),
                ));
            }
            let cell = |k: usize| record.get(cols[k]).unwrap_or("");
            let minute: usize = cell(0).parse().map_err(|_| {
                err(
                    line,
                    format!(
                        "column 'minute': expected a whole number, got '{}'",
                        cell(0)
                    ),
                )
            })?;
            if minute != minutes.len() {
                return Err(err(
                    line,
                    format!(
                        "column 'minute': expected minute {} (rows must be consecutive from 0), got {minute}",
                        minutes.len()
                    ),
                ));
            }
            if cell(1).is_empty() && cell(2).is_empty() {
                final_row = Some(line);
                continue;
            }
            let number = |k: usize, unit: &str| -> Result<f64, SimError> {
                cell(k).parse().map_err(|_| {
                    err(
                        line,
                        format!(
                            "column '{}': expected a number ({unit}), got '{}'",
                            INPUT_COLUMNS[k],
                            cell(k)
                        ),
                    )
                })
            };
            let rates = MinuteRates {
                cho_g_per_min: number(1, "g/min")?,
                insulin_u_per_min: number(2, "U/min")?,
            };
            rates.check().map_err(|reason| err(line, reason))?;
            minutes.push(rates);
        }
        if minutes.is_empty() {
            return Err(err(1, "no input rows after the header".into()));
        }
        Ok(InputDay { minutes })
    }

    /// The CSV text [`InputDay::from_csv`] reads back to the same day
    /// (rates written with Rust's shortest round-trip formatting).
    pub fn to_csv(&self) -> String {
        let mut text = INPUT_COLUMNS.join(",");
        text.push('\n');
        for (m, r) in self.minutes.iter().enumerate() {
            text.push_str(&format!(
                "{m},{},{}\n",
                r.cho_g_per_min, r.insulin_u_per_min
            ));
        }
        text
    }
}

#[cfg(test)]
mod tests {
    use super::super::{MAX_CHO_G_PER_MIN, MAX_INSULIN_U_PER_MIN};
    use super::*;
    use crate::devices::PumpConfig;

    fn read(text: &str) -> Result<InputDay, String> {
        InputDay::from_csv("in.csv", text).map_err(|e| e.to_string())
    }

    #[test]
    fn the_insulin_limit_is_the_default_pumps_largest_bolus_and_basal_minute() {
        let p = PumpConfig::default();
        assert_eq!(
            MAX_INSULIN_U_PER_MIN,
            p.max_bolus_u + p.max_basal_u_per_h / 60.0
        );
    }

    #[test]
    fn a_hundred_units_in_one_minute_is_refused_with_the_limit_named() {
        let e = read("minute,cho_g_per_min,insulin_u_per_min\n0,0,0.02\n1,0,100\n").unwrap_err();
        assert!(
            e.contains("in.csv, line 3")
                && e.contains("insulin_u_per_min")
                && e.contains("100 U/min")
                && e.contains(&format!("limit of {MAX_INSULIN_U_PER_MIN} U/min")),
            "{e}"
        );
    }

    #[test]
    fn the_limits_themselves_are_accepted() {
        let text = format!(
            "minute,cho_g_per_min,insulin_u_per_min\n0,{MAX_CHO_G_PER_MIN},{MAX_INSULIN_U_PER_MIN}\n"
        );
        let day = read(&text).unwrap();
        assert_eq!(day.minutes[0].insulin_u_per_min, MAX_INSULIN_U_PER_MIN);
    }

    #[test]
    fn a_million_grams_in_one_minute_is_refused_with_the_limit_named() {
        let e = read("minute,cho_g_per_min,insulin_u_per_min\n0,1000000,0\n").unwrap_err();
        assert!(
            e.contains("line 2") && e.contains("cho_g_per_min") && e.contains("limit of 5 g/min"),
            "{e}"
        );
    }

    #[test]
    fn crlf_files_report_the_right_line() {
        let e = read("minute,cho_g_per_min,insulin_u_per_min\r\n0,0,0\r\n1,x,0\r\n").unwrap_err();
        assert!(e.contains("line 3") && e.contains("'x'"), "{e}");
    }

    #[test]
    fn written_text_reads_back_to_the_same_day() {
        let day = InputDay {
            minutes: vec![
                MinuteRates {
                    cho_g_per_min: 5.0,
                    insulin_u_per_min: 0.1 + 0.2,
                },
                MinuteRates::default(),
            ],
        };
        assert_eq!(read(&day.to_csv()).unwrap(), day);
    }

    #[test]
    fn validate_names_the_minute() {
        let mut day = InputDay {
            minutes: vec![MinuteRates::default(); 3],
        };
        assert!(day.validate().is_ok());
        day.minutes[2].cho_g_per_min = 6.0;
        let e = day.validate().unwrap_err().to_string();
        assert!(
            e.contains("input minute 2") && e.contains("cho_g_per_min"),
            "{e}"
        );
    }
}
