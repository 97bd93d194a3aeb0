//! Reading the small device parameter tables (`sensor_params.csv`,
//! `pump_params.csv`) that are compiled into the binary.
//!
//! Every error names the table, the 1-based line (the header is line 1), the
//! column and what was expected.

use crate::error::SimError;

/// One parsed CSV table: its header and its rows with their line numbers.
#[derive(Debug)]
pub(crate) struct Table {
    /// File name, for error messages.
    name: &'static str,
    /// Column names as in the header.
    headers: Vec<String>,
    /// (1-based line, fields) for each data row.
    rows: Vec<(u64, Vec<String>)>,
}

/// A row of a [`Table`], with what is needed to report errors about it.
#[derive(Debug)]
pub(crate) struct Row<'a> {
    table: &'a Table,
    line: u64,
    fields: &'a [String],
}

impl Table {
    /// Parses `text` and checks that the header is exactly `expected`.
    pub(crate) fn parse(
        name: &'static str,
        text: &str,
        expected: &[&str],
    ) -> Result<Self, SimError> {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(true)
            .from_reader(text.as_bytes());
        let headers: Vec<String> = reader
            .headers()
            .map_err(|e| table_error(name, 1, format!("cannot read the header: {e}")))?
            .iter()
            .map(str::to_owned)
            .collect();
        if headers.len() != expected.len() || headers.iter().zip(expected).any(|(h, e)| h != e) {
            return Err(table_error(
                name,
                1,
                format!(
                    "header is [{}], expected [{}]",
                    headers.join(","),
                    expected.join(",")
                ),
            ));
        }
        let mut rows = Vec::new();
        for (index, record) in reader.records().enumerate() {
            // Line of the record; fall back to counting rows (header = line 1).
            let fallback = index as u64 + 2;
            let record = record.map_err(|e| {
                let line = e.position().map_or(fallback, |p| p.line());
                table_error(name, line, format!("cannot read the row: {e}"))
            })?;
            let line = record.position().map_or(fallback, |p| p.line());
            rows.push((line, record.iter().map(str::to_owned).collect()));
        }
        if rows.is_empty() {
            return Err(table_error(name, 1, "the table has no data rows".into()));
        }
        Ok(Self {
            name,
            headers,
            rows,
        })
    }

    /// The row whose first column equals `key`; `what` names the kind of
    /// thing looked up ("CGM sensor", "pump") for the error message.
    pub(crate) fn row(&self, key: &str, what: &str) -> Result<Row<'_>, SimError> {
        self.rows
            .iter()
            .find(|(_, fields)| fields.first().is_some_and(|f| f == key))
            .map(|(line, fields)| Row {
                table: self,
                line: *line,
                fields,
            })
            .ok_or_else(|| {
                SimError::Config(format!(
                    "unknown {what} '{key}' in {} (known: {})",
                    self.name,
                    self.names().join(", ")
                ))
            })
    }

    /// The values of the first column, in order.
    pub(crate) fn names(&self) -> Vec<&str> {
        self.rows
            .iter()
            .filter_map(|(_, f)| f.first().map(String::as_str))
            .collect()
    }
}

impl Row<'_> {
    /// The field in column `column`, parsed as a finite number.
    pub(crate) fn number(&self, column: &str) -> Result<f64, SimError> {
        let index = self
            .table
            .headers
            .iter()
            .position(|h| h == column)
            .ok_or_else(|| {
                table_error(
                    self.table.name,
                    1,
                    format!("no column '{column}' in the header"),
                )
            })?;
        let raw = self.fields.get(index).ok_or_else(|| {
            table_error(
                self.table.name,
                self.line,
                format!("column '{column}' is missing (the row is too short)"),
            )
        })?;
        let value: f64 = raw.trim().parse().map_err(|_| {
            table_error(
                self.table.name,
                self.line,
                format!("column '{column}': expected a number, got '{raw}'"),
            )
        })?;
        if !value.is_finite() {
            return Err(table_error(
                self.table.name,
                self.line,
                format!("column '{column}': expected a finite number, got '{raw}'"),
            ));
        }
        Ok(value)
    }

    /// An error about this row: `column` had `value`, but `expected`.
    pub(crate) fn invalid(&self, column: &str, value: f64, expected: &str) -> SimError {
        table_error(
            self.table.name,
            self.line,
            format!("column '{column}' = {value}: expected {expected}"),
        )
    }

    /// The table's file name.
    pub(crate) fn table_name(&self) -> &'static str {
        self.table.name
    }

    /// The row's 1-based line number.
    pub(crate) fn line(&self) -> u64 {
        self.line
    }
}

fn table_error(table: &str, line: u64, reason: String) -> SimError {
    SimError::Table {
        table: table.to_owned(),
        line,
        reason,
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    const HEADER: &[&str] = &["Name", "a", "b"];

    #[test]
    fn parses_rows_and_reports_line_and_column() {
        let t = Table::parse("t.csv", "Name,a,b\nx,1,2\ny,3,oops\n", HEADER).unwrap();
        assert_eq!(t.names(), vec!["x", "y"]);
        assert_eq!(t.row("x", "thing").unwrap().number("b").unwrap(), 2.0);
        let err = t.row("y", "thing").unwrap().number("b").unwrap_err();
        let msg = err.to_string();
        assert!(
            msg.contains("t.csv")
                && msg.contains("line 3")
                && msg.contains("'b'")
                && msg.contains("oops"),
            "{msg}"
        );
        let err = t.row("z", "thing").unwrap_err().to_string();
        assert!(
            err.contains("unknown thing 'z'") && err.contains("x, y"),
            "{err}"
        );
    }

    #[test]
    fn rejects_wrong_header_and_non_finite_numbers() {
        let err = Table::parse("t.csv", "Name,a,c\nx,1,2\n", HEADER)
            .unwrap_err()
            .to_string();
        assert!(
            err.contains("line 1") && err.contains("expected [Name,a,b]"),
            "{err}"
        );
        let t = Table::parse("t.csv", "Name,a,b\nx,NaN,inf\n", HEADER).unwrap();
        let err = t
            .row("x", "thing")
            .unwrap()
            .number("a")
            .unwrap_err()
            .to_string();
        assert!(err.contains("finite"), "{err}");
        let err = Table::parse("t.csv", "Name,a,b\n", HEADER)
            .unwrap_err()
            .to_string();
        assert!(err.contains("no data rows"), "{err}");
    }
}
