//! A CSV file as the exports write them: an optional byte-order mark,
//! preamble lines before the header, `,` `;` or tab as delimiter, LF or
//! CRLF line ends, decimal commas (see [`number`]).

use crate::error::{IoError, Location};
use crate::units::GlucoseUnit;

/// A CSV table: its header cells and rows, each with its 1-based line.
pub struct Table<'a> {
    /// The file name (for errors).
    pub file: &'a str,
    /// Header cells, trimmed, quotes removed.
    pub header: Vec<String>,
    /// The header's line.
    pub header_line: u64,
    /// The delimiter.
    pub delimiter: u8,
    reader: csv::Reader<&'a [u8]>,
    /// Lines before the CSV reader's input.
    offset: u64,
    /// The CSV reader's input (line numbers are counted here, not by the
    /// CSV reader, so that CRLF and LF files count alike).
    input: &'a [u8],
    /// Bytes of `input` whose newlines are counted in `newlines`.
    counted: usize,
    newlines: u64,
    record: csv::ByteRecord,
}

/// Strips a UTF-8 byte-order mark.
pub fn strip_bom(bytes: &[u8]) -> &[u8] {
    bytes.strip_prefix(b"\xEF\xBB\xBF").unwrap_or(bytes)
}

/// A UTF-16 file (byte-order mark `FF FE` or `FE FF`, as some Windows
/// programs save CSV) as UTF-8 bytes; `None` for any other file. Text that
/// is not valid UTF-16 is an error.
pub fn utf16_to_utf8(file: &str, bytes: &[u8]) -> Result<Option<Vec<u8>>, IoError> {
    let little = match bytes {
        [0xFF, 0xFE, ..] => true,
        [0xFE, 0xFF, ..] => false,
        _ => return Ok(None),
    };
    if !bytes.len().is_multiple_of(2) {
        return Err(IoError::format(
            file,
            "the file starts with a UTF-16 byte-order mark but has an odd number of bytes",
        ));
    }
    let units: Vec<u16> = bytes[2..]
        .chunks(2)
        .map(|c| match (c, little) {
            ([a, b], true) => u16::from_le_bytes([*a, *b]),
            ([a, b], false) => u16::from_be_bytes([*a, *b]),
            _ => 0xFFFF, // not reached: the length is even
        })
        .collect();
    String::from_utf16(&units)
        .map(|s| Some(s.into_bytes()))
        .map_err(|e| IoError::format(file, format!("the file says UTF-16 but is not: {e}")))
}

/// The characters Windows-1252 puts at bytes 0x80-0x9F (where Latin-1 has
/// control codes; the five bytes it leaves undefined stay those codes).
const WINDOWS_1252_80_9F: [char; 32] = [
    '\u{20AC}', '\u{81}', '\u{201A}', '\u{192}', '\u{201E}', '\u{2026}', '\u{2020}', '\u{2021}',
    '\u{2C6}', '\u{2030}', '\u{160}', '\u{2039}', '\u{152}', '\u{8D}', '\u{17D}', '\u{8F}',
    '\u{90}', '\u{2018}', '\u{2019}', '\u{201C}', '\u{201D}', '\u{2022}', '\u{2013}', '\u{2014}',
    '\u{2DC}', '\u{2122}', '\u{161}', '\u{203A}', '\u{153}', '\u{9D}', '\u{17E}', '\u{178}',
];

/// A text file that is not UTF-8 as UTF-8 bytes, read as Windows-1252
/// (Western European: the encoding in which Windows programs, Excel among
/// them, save CSV; `é` is one byte, 0xE9); `None` for UTF-8, and for a
/// file whose only fault is a character cut at its very end (UTF-8 cut
/// short: the cut line is the readers' to report, see [`cut_last_line`]).
/// Only letters change with the encoding: digits, separators and the
/// English, German, French, Spanish, Italian and Dutch column names abba
/// reads are the same bytes or the same letters in either.
pub fn windows_1252_to_utf8(bytes: &[u8]) -> Option<Vec<u8>> {
    match std::str::from_utf8(bytes) {
        Ok(_) => None,
        Err(e) if e.error_len().is_none() => None,
        Err(_) => Some(
            bytes
                .iter()
                .map(|&b| match b {
                    0x80..=0x9F => WINDOWS_1252_80_9F[usize::from(b - 0x80)],
                    _ => char::from(b),
                })
                .collect::<String>()
                .into_bytes(),
        ),
    }
}

/// A CSV file's last line when the file ends within it (a download or a
/// copy cut short): no line end after it and fewer cells than the line
/// before it, or a quote left open. Such a line's last cell is a part of
/// what was written (`145` cut to `14`), so it is never read.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CutLine {
    /// Where the line starts (the bytes before it are whole lines).
    pub start: usize,
    /// Its 1-based line number.
    pub line: u64,
    /// The cells it has.
    pub cells: usize,
    /// The cells the line before it has.
    pub expected: usize,
}

impl CutLine {
    /// The error that reports the line (left out, the rest read).
    pub fn error(&self, file: &str) -> IoError {
        IoError::invalid(
            Location::line(file, self.line),
            "row",
            format!(
                "the file ends within this line (no line end after it, {} of the {} cells the \
                 line before it has{}): the export was cut short and its last value may be cut \
                 too, so the line is not read; export the file again to read it",
                self.cells,
                self.expected,
                if self.cells >= self.expected {
                    ", a quote left open"
                } else {
                    ""
                }
            ),
        )
    }
}

/// The cut last line of a CSV file (BOM stripped), if it is cut (see
/// [`CutLine`]). A section divider before it (CareLink's `-------;...`)
/// or a file of one line tells nothing.
pub fn cut_last_line(bytes: &[u8]) -> Option<CutLine> {
    if bytes.last().is_some_and(|&b| b == b'\n') {
        return None;
    }
    let start = bytes.iter().rposition(|&b| b == b'\n')? + 1;
    let last = &bytes[start..];
    if last.iter().all(u8::is_ascii_whitespace) {
        return None;
    }
    let before = bytes[..start]
        .split(|&b| b == b'\n')
        .rev()
        .find(|l| !l.iter().all(u8::is_ascii_whitespace))?;
    if before.trim_ascii_start().starts_with(b"-------")
        || before.trim_ascii_start().starts_with(b"\"-------")
    {
        return None;
    }
    let delimiter = sniff(before);
    let cells = |line: &[u8]| {
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .delimiter(delimiter)
            .from_reader(line);
        let mut record = csv::ByteRecord::new();
        match reader.read_byte_record(&mut record) {
            Ok(true) => record.len(),
            _ => 0,
        }
    };
    let (have, expected) = (cells(last), cells(before));
    let open_quote = last.iter().filter(|&&b| b == b'"').count() % 2 == 1;
    if have >= expected && !open_quote {
        return None;
    }
    let line = bytes[..start].iter().filter(|&&b| b == b'\n').count() as u64 + 1;
    Some(CutLine {
        start,
        line,
        cells: have,
        expected,
    })
}

/// The byte offset where line `n` (0-based) starts, if the input has it.
fn line_start(bytes: &[u8], n: usize) -> Option<usize> {
    let mut at = 0;
    for _ in 0..n {
        at += bytes[at..].iter().position(|&b| b == b'\n')? + 1;
    }
    Some(at)
}

/// The delimiter of a header line: the most frequent of `,` `;` tab.
fn sniff(line: &[u8]) -> u8 {
    let count = |d: u8| line.iter().filter(|&&b| b == d).count();
    [b',', b';', b'\t']
        .into_iter()
        .max_by_key(|&d| count(d))
        .unwrap_or(b',')
}

impl<'a> Table<'a> {
    /// Opens `bytes` (BOM already stripped) with the header on 0-based line
    /// `header_at`.
    pub fn open(file: &'a str, bytes: &'a [u8], header_at: usize) -> Result<Self, IoError> {
        let start = line_start(bytes, header_at).ok_or_else(|| {
            IoError::format(file, format!("expected a header on line {}", header_at + 1))
        })?;
        let rest = &bytes[start..];
        let first_line = rest.split(|&b| b == b'\n').next().unwrap_or(rest);
        let delimiter = sniff(first_line);
        let mut reader = csv::ReaderBuilder::new()
            .has_headers(false)
            .flexible(true)
            .delimiter(delimiter)
            .from_reader(rest);
        let mut record = csv::ByteRecord::new();
        let offset = header_at as u64;
        let header_line = offset + 1;
        let ok = reader.read_byte_record(&mut record).map_err(|e| {
            IoError::format(file, format!("line {header_line}: unreadable header: {e}"))
        })?;
        if !ok {
            return Err(IoError::format(file, "the file is empty (no header row)"));
        }
        let header = record
            .iter()
            .map(|c| {
                String::from_utf8_lossy(c)
                    .trim()
                    .trim_matches('"')
                    .trim()
                    .to_string()
            })
            .collect();
        Ok(Self {
            file,
            header,
            header_line,
            delimiter,
            reader,
            offset,
            input: rest,
            counted: 0,
            newlines: 0,
            record,
        })
    }

    /// Lines after the header (an upper bound of the rows, to reserve
    /// memory once).
    pub fn lines_left(&self) -> usize {
        self.input.iter().filter(|&&b| b == b'\n').count()
    }

    /// Index of the first header cell for which `pred` holds.
    pub fn column(&self, pred: impl Fn(&str) -> bool) -> Option<usize> {
        self.header.iter().position(|h| pred(h))
    }

    /// Index of the first header cell that starts with `prefix`.
    pub fn column_starting(&self, prefix: &str) -> Option<usize> {
        self.column(|h| h.starts_with(prefix))
    }

    /// Index of the first header cell that starts with `prefix`, or an
    /// error saying that an `export` file needs it and which columns it has.
    pub fn need_column_starting(&self, export: &str, prefix: &str) -> Result<usize, IoError> {
        self.column_starting(prefix).ok_or_else(|| {
            IoError::format(
                self.file,
                format!(
                    "a {export} export needs a \"{prefix}...\" column; the columns found are {}",
                    self.columns_found()
                ),
            )
        })
    }

    /// The glucose unit named in the header of column `at` (`mg/dL` or
    /// `mmol/L`); an error if it names none or if `given` (the caller's
    /// `--units`) says otherwise.
    pub fn unit_of_column(
        &self,
        at: usize,
        given: Option<GlucoseUnit>,
    ) -> Result<GlucoseUnit, IoError> {
        let name = &self.header[at];
        let unit = unit_in_name(name).ok_or_else(|| IoError::Units {
            file: self.file.to_string(),
            message: format!("column \"{name}\" names no unit (expected mg/dL or mmol/L)"),
        })?;
        if let Some(given) = given.filter(|&g| g != unit) {
            return Err(IoError::Units {
                file: self.file.to_string(),
                message: format!(
                    "the file says {} (column \"{name}\") but --units says {}",
                    unit.label(),
                    given.label()
                ),
            });
        }
        Ok(unit)
    }

    /// The header cells, quoted and joined (for errors).
    pub fn columns_found(&self) -> String {
        self.header
            .iter()
            .map(|h| format!("\"{h}\""))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Reads the next row into the table's buffer; returns its 1-based
    /// line, or `None` at the end. Blank lines are skipped.
    pub fn next_row(&mut self) -> Result<Option<u64>, IoError> {
        loop {
            let ok = self
                .reader
                .read_byte_record(&mut self.record)
                .map_err(|e| {
                    let byte = e.position().map_or(self.counted, |p| p.byte() as usize);
                    let line = self.line_at(byte);
                    IoError::invalid(
                        Location::line(self.file, line),
                        "row",
                        format!("unreadable CSV: {e}"),
                    )
                })?;
            if !ok {
                return Ok(None);
            }
            // The CSV reader's position can sit on the line end before the
            // record (CRLF) or on skipped blank lines: start at the first
            // byte that is not a line end.
            let mut byte = self.record.position().map_or(0, |p| p.byte()) as usize;
            while matches!(self.input.get(byte), Some(b'\r' | b'\n')) {
                byte += 1;
            }
            let line = self.line_at(byte);
            if self
                .record
                .iter()
                .all(|c| c.iter().all(u8::is_ascii_whitespace))
            {
                continue;
            }
            return Ok(Some(line));
        }
    }

    /// The 1-based file line of byte `byte` of the input (bytes only
    /// move forward).
    fn line_at(&mut self, byte: usize) -> u64 {
        let end = byte.min(self.input.len()).max(self.counted);
        self.newlines += self.input[self.counted..end]
            .iter()
            .filter(|&&b| b == b'\n')
            .count() as u64;
        self.counted = end;
        self.offset + self.newlines + 1
    }

    /// Cell `i` of the current row, trimmed (empty if the row is short or
    /// the cell is not UTF-8).
    pub fn cell(&self, i: usize) -> &str {
        self.record
            .get(i)
            .and_then(|c| std::str::from_utf8(c).ok())
            .unwrap_or("")
            .trim()
    }

    /// The raw cells of the current row (for content hashes).
    pub fn raw(&self) -> impl Iterator<Item = &[u8]> {
        self.record.iter()
    }
}

/// Parses a number as the file writes it: `.` decimals, or one `,` as the
/// decimal mark (locales such as German, French, Dutch; in a `,`-delimited
/// file such a cell arrives quoted, `"5,6"`). In a `,`-delimited file a
/// comma followed by exactly three digits (`1,500`) could be a thousands
/// separator and is refused, not guessed.
pub fn number(text: &str, delimiter: u8) -> Option<f64> {
    let t = text.trim();
    if t.is_empty() {
        return None;
    }
    let v: f64 = match t.split_once(',') {
        Some((whole, frac)) if !t.contains('.') && !frac.contains(',') => {
            if delimiter == b',' && frac.len() == 3 {
                return None;
            }
            if whole.is_empty() || frac.is_empty() {
                return None;
            }
            format!("{whole}.{frac}").parse().ok()?
        }
        _ => t.parse().ok()?,
    };
    v.is_finite().then_some(v)
}

/// A required number in column `name` at `line`, or an error saying what
/// was found.
pub fn required_number(
    file: &str,
    line: u64,
    name: &str,
    text: &str,
    delimiter: u8,
    what: &str,
) -> Result<f64, IoError> {
    number(text, delimiter).ok_or_else(|| {
        IoError::invalid(
            Location::line(file, line),
            name,
            format!("expected {what}, got \"{text}\""),
        )
    })
}

/// The unit a column name declares, if any.
pub fn unit_in_name(name: &str) -> Option<GlucoseUnit> {
    let n = name
        .to_ascii_lowercase()
        .replace([' ', '(', ')', '[', ']'], "");
    if n.contains("mg/dl") || n.ends_with("mg_dl") || n.ends_with("mgdl") {
        Some(GlucoseUnit::MgDl)
    } else if n.contains("mmol/l") || n.ends_with("mmol_l") || n.ends_with("mmol") {
        Some(GlucoseUnit::MmolL)
    } else {
        None
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn utf16_files_are_read_as_utf8() {
        let text = "Gerät,Zeit\r\n1,2\r\n";
        let mut le = vec![0xFF, 0xFE];
        le.extend(text.encode_utf16().flat_map(u16::to_le_bytes));
        let mut be = vec![0xFE, 0xFF];
        be.extend(text.encode_utf16().flat_map(u16::to_be_bytes));
        for bytes in [le, be] {
            assert_eq!(
                utf16_to_utf8("f", &bytes).unwrap(),
                Some(text.as_bytes().to_vec())
            );
        }
        assert_eq!(utf16_to_utf8("f", text.as_bytes()).unwrap(), None);
        assert!(utf16_to_utf8("f", &[0xFF, 0xFE, 0x41]).is_err());
    }

    #[test]
    fn decimal_commas_are_read_and_thousands_are_refused() {
        assert_eq!(number("5,6", b','), Some(5.6));
        assert_eq!(number("5,6", b';'), Some(5.6));
        assert_eq!(number("12,25", b'\t'), Some(12.25));
        assert_eq!(number("7.4", b','), Some(7.4));
        // Thousands separator or decimal comma: not told, refused.
        assert_eq!(number("1,500", b','), None);
        for bad in ["1,2,3", "1.2,3", ",5", "5,", "x"] {
            assert_eq!(number(bad, b','), None, "{bad}");
        }
    }

    #[test]
    fn lines_count_alike_with_lf_and_crlf() {
        for text in [
            "a,b\n1,2\n\n3,4\n",
            "a,b\r\n1,2\r\n\r\n3,4\r\n",
            "pre\na,b\n1,2\n\n3,4",
        ] {
            let header_at = usize::from(text.starts_with("pre"));
            let mut t = Table::open("f", text.as_bytes(), header_at).unwrap();
            let mut lines = Vec::new();
            while let Some(l) = t.next_row().unwrap() {
                lines.push((l, t.cell(0).to_string()));
            }
            let h = header_at as u64;
            assert_eq!(
                lines,
                vec![(h + 2, "1".to_string()), (h + 4, "3".to_string())],
                "{text:?}"
            );
        }
    }
}
