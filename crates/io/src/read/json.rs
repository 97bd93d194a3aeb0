//! Helpers for JSON exports: typed field access with JSON-path errors.

use serde_json::{Map, Value};

use crate::error::{IoError, Location};

/// One item of a top-level JSON array, with its path for errors; or one
/// row of a workbook turned into the same object (Tidepool's Excel export),
/// with its sheet, row and column headers for errors.
pub struct Item<'a> {
    /// The file.
    pub file: &'a str,
    /// Index in the array (a workbook's: in the order read).
    pub index: usize,
    /// The object.
    pub obj: &'a Map<String, Value>,
    /// The sheet row the object was read from, if it was.
    pub sheet: Option<SheetPlace<'a>>,
}

/// Where a workbook row's object was read: the sheet, Excel's row number,
/// and the column header of each field (errors name the column).
#[derive(Clone, Copy)]
pub struct SheetPlace<'a> {
    /// The sheet's name.
    pub sheet: &'a str,
    /// Excel's 1-based row number.
    pub row: u32,
    /// (field, column header) of the sheet's layout; a nested field
    /// (`nutrition.carbohydrate.net`) is named by the column of its first
    /// part.
    pub columns: &'a [(&'static str, &'static str)],
}

impl SheetPlace<'_> {
    /// The column that holds `field`, as the sheet's header names it.
    pub fn column(&self, field: &str) -> String {
        if let Some((_, h)) = self.columns.iter().find(|(f, _)| *f == field) {
            return (*h).to_string();
        }
        let mut best: Option<(&str, &str)> = None;
        for (f, h) in self.columns {
            if field.starts_with(f)
                && field.as_bytes().get(f.len()) == Some(&b'.')
                && best.is_none_or(|b| f.len() > b.0.len())
            {
                best = Some((f, h));
            }
        }
        match best {
            Some((f, h)) => format!("{h} ({})", &field[f.len() + 1..]),
            None => field.to_string(),
        }
    }
}

impl<'a> Item<'a> {
    /// An item of a JSON array.
    pub fn json(file: &'a str, index: usize, obj: &'a Map<String, Value>) -> Self {
        Self {
            file,
            index,
            obj,
            sheet: None,
        }
    }
    /// How errors name `field`: the field, or in a workbook its column.
    pub fn name(&self, field: &str) -> String {
        match &self.sheet {
            Some(s) => s.column(field),
            None => field.to_string(),
        }
    }
    /// The location of `field` in this item.
    pub fn at(&self, field: &str) -> Location {
        match &self.sheet {
            Some(s) => Location::sheet(self.file, s.sheet, s.row),
            None => Location::json(self.file, format!("$[{}].{field}", self.index)),
        }
    }
    /// An error about `field`.
    pub fn err(&self, field: &str, message: impl Into<String>) -> IoError {
        IoError::Invalid {
            at: match &self.sheet {
                Some(s) => Location::sheet(self.file, s.sheet, s.row),
                None => Location::json(self.file, format!("$[{}]", self.index)),
            },
            field: self.name(field),
            message: message.into(),
        }
    }
    /// `field`'s value `v` checked against `min..=max` (`what` names the
    /// quantity), the error naming the field or column.
    pub fn range(
        &self,
        field: &str,
        v: f64,
        min: f64,
        max: f64,
        what: &str,
    ) -> Result<f64, IoError> {
        crate::units::check_range(&self.at(field), &self.name(field), v, min, max, what)
    }
    /// A field that is present and not null.
    pub fn get(&self, field: &str) -> Option<&'a Value> {
        self.obj.get(field).filter(|v| !v.is_null())
    }
    /// A string field, if present.
    pub fn str(&self, field: &str) -> Result<Option<&'a str>, IoError> {
        match self.get(field) {
            None => Ok(None),
            Some(Value::String(s)) => Ok(Some(s)),
            Some(v) => Err(self.err(field, format!("expected a string, got {v}"))),
        }
    }
    /// A number field (a numeric string is accepted, as some uploaders
    /// write them), if present.
    pub fn num(&self, field: &str) -> Result<Option<f64>, IoError> {
        match self.get(field) {
            None => Ok(None),
            Some(Value::Number(n)) => n
                .as_f64()
                .filter(|v| v.is_finite())
                .map(Some)
                .ok_or_else(|| self.err(field, format!("expected a finite number, got {n}"))),
            Some(Value::String(s)) if s.trim().parse::<f64>().is_ok_and(f64::is_finite) => {
                Ok(s.trim().parse().ok())
            }
            // MongoDB extended JSON (canonical mode): {"$numberInt": "120"}.
            Some(Value::Object(o))
                if o.len() == 1
                    && ["$numberInt", "$numberLong", "$numberDouble"]
                        .iter()
                        .any(|k| o.contains_key(*k)) =>
            {
                o.values()
                    .next()
                    .and_then(Value::as_str)
                    .and_then(|s| s.trim().parse::<f64>().ok())
                    .filter(|v| v.is_finite())
                    .map(Some)
                    .ok_or_else(|| self.err(field, "expected a finite number in extended JSON"))
            }
            Some(v) => Err(self.err(field, format!("expected a number, got {v}"))),
        }
    }
    /// A required number field.
    pub fn need_num(&self, field: &str, what: &str) -> Result<f64, IoError> {
        self.num(field)?
            .ok_or_else(|| self.err(field, format!("missing: expected {what}")))
    }
}

/// Parses `bytes` as a JSON array of objects (a single object counts as an
/// array of one).
pub fn parse_array(file: &str, bytes: &[u8]) -> Result<Vec<Value>, IoError> {
    // mongoexport writes one document a line (no array): read them in order.
    let mut stream = serde_json::Deserializer::from_slice(bytes).into_iter::<Value>();
    if let (Some(Ok(Value::Object(first))), Some(second)) = (stream.next(), stream.next()) {
        let mut items = vec![Value::Object(first)];
        let mut next = Some(second);
        while let Some(v) = next {
            let v = v.map_err(|e| IoError::Invalid {
                at: Location::line(file, e.line() as u64),
                field: "json".into(),
                message: format!("not valid JSON (one document a line): {e}"),
            })?;
            items.push(v);
            next = stream.next();
        }
        return Ok(items);
    }
    let v: Value = serde_json::from_slice(bytes).map_err(|e| IoError::Invalid {
        at: Location::line(file, e.line() as u64),
        field: "json".into(),
        message: format!("not valid JSON: {e}"),
    })?;
    match v {
        Value::Array(items) => Ok(items),
        // Nightscout API v3 answers `{"status": 200, "result": [...]}` (a
        // search or history) or `{"status": 200, "result": {...}}` (one
        // document): its records are the result's.
        Value::Object(mut o)
            if o.contains_key("status")
                && matches!(o.get("result"), Some(Value::Array(_) | Value::Object(_))) =>
        {
            match o.remove("result") {
                Some(Value::Array(items)) => Ok(items),
                Some(one) => Ok(vec![one]),
                None => Ok(Vec::new()),
            }
        }
        Value::Object(_) => Ok(vec![v]),
        other => Err(IoError::format(
            file,
            format!("expected a JSON array of records, got {}", kind(&other)),
        )),
    }
}

/// The JSON type name of a value.
pub fn kind(v: &Value) -> &'static str {
    match v {
        Value::Null => "null",
        Value::Bool(_) => "a boolean",
        Value::Number(_) => "a number",
        Value::String(_) => "a string",
        Value::Array(_) => "an array",
        Value::Object(_) => "an object",
    }
}

/// Item `index` of a file's array as an object, or an error naming its
/// path.
pub fn object<'a>(file: &'a str, index: usize, v: &'a Value) -> Result<Item<'a>, IoError> {
    match v {
        Value::Object(obj) => Ok(Item::json(file, index, obj)),
        other => Err(IoError::Invalid {
            at: Location::json(file, format!("$[{index}]")),
            field: "record".into(),
            message: format!("expected an object, got {}", kind(other)),
        }),
    }
}

/// The items that are objects; any other is left out and reported
/// ([`super::Ctx::skip`]).
pub fn objects<'a>(ctx: &super::Ctx<'a>, items: &'a [Value]) -> Result<Vec<Item<'a>>, IoError> {
    let mut out = Vec::with_capacity(items.len());
    for (index, v) in items.iter().enumerate() {
        out.push(super::or_skip!(ctx, object(ctx.file, index, v)));
    }
    Ok(out)
}
