//! How a failed command reports its error: the message, then each cause
//! that adds something, each once.
//!
//! Why a plain `anyhow` report printed causes twice: the library error
//! types write their source into their own message (`"{context}:
//! {source}"`, so that a message read alone is complete) *and* expose it as
//! `source()`; anyhow's report prints every link of the chain, so the
//! source appeared in the message and again under "Caused by". Here a cause
//! whose text the link above it already contains is left out.

/// The text printed on standard error for `e`.
pub fn render(e: &anyhow::Error) -> String {
    let mut out = format!("Error: {e}");
    let mut causes = Vec::new();
    let mut above = e.to_string();
    for cause in e.chain().skip(1) {
        let text = cause.to_string();
        if !above.contains(&text) {
            causes.push(text.clone());
        }
        above = text;
    }
    match causes.as_slice() {
        [] => {}
        [one] => out.push_str(&format!("\n\nCaused by:\n    {one}")),
        many => {
            out.push_str("\n\nCaused by:");
            for (k, c) in many.iter().enumerate() {
                out.push_str(&format!("\n    {k}: {c}"));
            }
        }
    }
    out
}

/// When the failure was a store that stayed busy past the wait (another
/// process writing), the sentence that says so and who holds it.
pub fn busy(e: &anyhow::Error, db: Option<&std::path::Path>) -> Option<String> {
    let busy = e
        .chain()
        .filter_map(|c| c.downcast_ref::<abba_store::StoreError>())
        .any(abba_store::StoreError::is_busy);
    if !busy {
        return None;
    }
    let holders = db.map(abba_store::busy::lock_holders).unwrap_or_default();
    let who = if holders.is_empty() {
        "another process".to_string()
    } else {
        holders.join(", ")
    };
    Some(format!(
        "Error: the store is busy (held by {who}): waited {} s for its write lock; nothing was changed, try again",
        abba_store::schema::DEFAULT_BUSY.as_secs()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context;

    #[derive(Debug, thiserror::Error)]
    #[error("cannot write out.csv: {source}")]
    struct Wrapping {
        #[source]
        source: std::io::Error,
    }

    fn io() -> std::io::Error {
        std::io::Error::new(std::io::ErrorKind::AlreadyExists, "File exists")
    }

    #[test]
    fn a_source_already_in_the_message_is_printed_once() {
        let e = anyhow::Error::new(Wrapping { source: io() });
        let text = render(&e);
        assert_eq!(text, "Error: cannot write out.csv: File exists");
        assert_eq!(text.matches("File exists").count(), 1);
    }

    #[test]
    fn a_context_keeps_its_cause() {
        let e = Err::<(), _>(io())
            .context("writing the report")
            .unwrap_err();
        assert_eq!(
            render(&e),
            "Error: writing the report\n\nCaused by:\n    File exists"
        );
    }

    #[test]
    fn several_new_causes_are_numbered() {
        let e = Err::<(), _>(io())
            .context("inner step")
            .context("outer step")
            .unwrap_err();
        assert_eq!(
            render(&e),
            "Error: outer step\n\nCaused by:\n    0: inner step\n    1: File exists"
        );
    }
}
