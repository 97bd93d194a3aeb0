//! Form bodies (`application/x-www-form-urlencoded`, parsed by the
//! `form_urlencoded` crate): a field given twice or one the form does not
//! have is refused, never picked or dropped.

use crate::body::RawBody;
use crate::error::ApiError;
use axum::http::{header, HeaderMap, StatusCode};

/// A parsed form.
#[derive(Debug, Clone, Default)]
pub struct Form {
    fields: Vec<(String, String)>,
}

impl Form {
    /// Parses a form body (its fields are checked by [`Form::only`] once
    /// the CSRF token was).
    pub fn parse(headers: &HeaderMap, body: RawBody) -> Result<Self, ApiError> {
        let bytes = body.map_err(|e| {
            if crate::body::is_timeout(&e) {
                return ApiError::timeout("the form");
            }
            if crate::body::is_too_large(&e) {
                return ApiError::new(
                    StatusCode::PAYLOAD_TOO_LARGE,
                    abba_api::ErrorCode::TooLarge,
                    format!(
                        "the form is larger than {} bytes",
                        crate::body::FORM_BODY_BYTES
                    ),
                );
            }
            ApiError::new(
                e.status(),
                abba_api::ErrorCode::BadJson,
                "the form could not be read whole",
            )
        })?;
        let urlencoded = headers
            .get(header::CONTENT_TYPE)
            .and_then(|v| v.to_str().ok())
            .map(|v| v.split(';').next().unwrap_or("").trim())
            .is_some_and(|m| m.eq_ignore_ascii_case("application/x-www-form-urlencoded"));
        if !urlencoded {
            return Err(ApiError::new(
                StatusCode::UNSUPPORTED_MEDIA_TYPE,
                abba_api::ErrorCode::UnsupportedMediaType,
                "expected a form (application/x-www-form-urlencoded)",
            ));
        }
        crate::body::uncompressed(headers, "form")?;
        Ok(Self {
            fields: form_urlencoded::parse(&bytes)
                .map(|(k, v)| (k.into_owned(), v.into_owned()))
                .collect(),
        })
    }

    /// Refuses a field the form does not have or one given twice (422
    /// naming it).
    pub fn only(&self, known: &[&str]) -> Result<(), ApiError> {
        for (i, (k, _)) in self.fields.iter().enumerate() {
            if !known.contains(&k.as_str()) {
                return Err(ApiError::invalid(
                    k.clone(),
                    format!(
                        "this form has no field {k:?}; expected {}",
                        known.join(", ")
                    ),
                ));
            }
            if self.fields[..i].iter().any(|(f, _)| f == k) {
                return Err(ApiError::invalid(
                    k.clone(),
                    format!("the field `{k}` was given twice; expected it once"),
                ));
            }
        }
        Ok(())
    }

    /// A form of fields already read (a multipart form's text fields).
    pub fn from_pairs(fields: Vec<(String, String)>) -> Self {
        Self { fields }
    }

    /// A field's value.
    pub fn get(&self, name: &str) -> Option<&str> {
        self.fields
            .iter()
            .find(|(k, _)| k == name)
            .map(|(_, v)| v.as_str())
    }

    /// A field's value with surrounding blanks removed ("" when absent).
    pub fn text(&self, name: &str) -> &str {
        self.get(name).unwrap_or("").trim()
    }
}

/// The one-time key field of the forms that write ([`Form::submission`]).
pub const SUBMISSION: &str = "submission";

impl Form {
    /// The submission's key for the store ([`abba_store::submission`]):
    /// SHA-256 of the form's one-time key (the hidden `submission` field,
    /// 64 hex digits rendered with the page), its action and every other
    /// field but the CSRF token. The same form sent twice (a double
    /// click, a retry) has the same key; the same page's form sent with
    /// other values (a second reading typed into a page restored by the
    /// Back button) is another submission. `None` without a well-formed
    /// key (a form from a page of an older version).
    pub fn submission(&self, action: &str) -> Option<abba_store::submission::SubmissionKey> {
        let key = self
            .get(SUBMISSION)
            .filter(|k| super::session::is_secret(k))?;
        let mut fields: Vec<&(String, String)> = self
            .fields
            .iter()
            .filter(|(k, _)| k != "csrf" && k != SUBMISSION)
            .collect();
        fields.sort();
        // Each part with its length: no two forms give the same text.
        let mut text = format!("{}:{action}{}:{key}", action.len(), key.len());
        for (k, v) in fields {
            text.push_str(&format!("{}:{k}{}:{v}", k.len(), v.len()));
        }
        Some(crate::auth::hash(&text))
    }
}

/// A decimal number as people type it: `5.4` or `5,4` (one decimal comma
/// is read as the point); anything else is `None`. A comma followed by
/// exactly three digits after a whole part other than 0 (`1,000`,
/// `12,500`) is `None` too: a thousands separator in English, a decimal
/// comma elsewhere, so never guessed (`0,850` is 0.85).
pub fn number(text: &str) -> Option<f64> {
    let t = text.trim();
    let t = if t.matches(',').count() == 1 && !t.contains('.') {
        let (whole, decimals) = t.split_once(',').unwrap_or((t, ""));
        let digits = whole.trim_start_matches(['+', '-']);
        let thousands = decimals.len() == 3
            && decimals.bytes().all(|b| b.is_ascii_digit())
            && !digits.is_empty()
            && digits.bytes().any(|b| b != b'0');
        if thousands {
            return None;
        }
        t.replace(',', ".")
    } else {
        t.to_string()
    };
    t.parse::<f64>().ok().filter(|x| x.is_finite())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_submission_key_is_the_form_not_its_csrf_token() {
        let key = "ab".repeat(32);
        let form = |pairs: &[(&str, &str)]| {
            Form::from_pairs(
                pairs
                    .iter()
                    .map(|(k, v)| (k.to_string(), v.to_string()))
                    .collect(),
            )
        };
        let a = form(&[("csrf", "1"), ("submission", &key), ("glucose", "120")]);
        let b = form(&[("glucose", "120"), ("submission", &key), ("csrf", "2")]);
        let c = form(&[("csrf", "1"), ("submission", &key), ("glucose", "121")]);
        let k = a.submission("/log/reading").unwrap();
        assert_eq!(b.submission("/log/reading"), Some(k));
        assert_ne!(c.submission("/log/reading"), Some(k));
        assert_ne!(a.submission("/log/meal"), Some(k));
        assert_eq!(form(&[("glucose", "120")]).submission("/log/reading"), None);
        assert_eq!(
            form(&[("submission", "x"), ("glucose", "120")]).submission("/log/reading"),
            None
        );
    }

    #[test]
    fn numbers_with_a_decimal_comma_or_point() {
        assert_eq!(number(" 5,4 "), Some(5.4));
        assert_eq!(number("5.4"), Some(5.4));
        assert_eq!(number("1,000.5"), None);
        // A thousands separator or a decimal comma: not guessed.
        assert_eq!(number("1,000"), None);
        assert_eq!(number("12,500"), None);
        assert_eq!(number("0,850"), Some(0.85));
        assert_eq!(number("0,85"), Some(0.85));
        assert_eq!(number("1,25"), Some(1.25));
        assert_eq!(number("1,0"), Some(1.0));
        assert_eq!(number("NaN"), None);
        assert_eq!(number("inf"), None);
        assert_eq!(number(""), None);
    }
}
