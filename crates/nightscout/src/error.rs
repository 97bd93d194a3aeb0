//! The one error type of abba-nightscout. No message carries a credential.

use thiserror::Error;

/// Everything that can go wrong talking to a Nightscout site.
#[derive(Debug, Error)]
pub enum NsError {
    /// The URL given is not one abba links to.
    #[error("--url \"{url}\": {problem}")]
    Url {
        /// The URL as given.
        url: String,
        /// What is wrong and what was expected.
        problem: String,
    },
    /// A credential that cannot be right.
    #[error("{flag}: {problem}")]
    Credential {
        /// The flag.
        flag: &'static str,
        /// What is wrong.
        problem: String,
    },
    /// The site refused the credential (HTTP 401).
    #[error("{site}: the site refused the credential (401 Unauthorized) for {call}: check the {what} (`abba link nightscout` again with the right one); a token's roles must allow the call (readable to read; careportal and admin to write back)")]
    Unauthorized {
        /// The site.
        site: String,
        /// The call (method and path).
        call: String,
        /// `API secret` or `access token`.
        what: &'static str,
    },
    /// The credential's roles do not allow the call (HTTP 403).
    #[error("{site}: the credential is not allowed {call} (403 Forbidden): {need}")]
    Forbidden {
        /// The site.
        site: String,
        /// The call.
        call: String,
        /// Which role it needs.
        need: String,
    },
    /// The site's TLS certificate was refused (not retried).
    #[error("{site}: its TLS certificate is refused ({problem}): abba trusts the public certificate authorities only (webpki roots), so a self-signed certificate, an expired one or one for another name does not pass. Give the site a certificate from a public authority (Let's Encrypt), or link the address the certificate names")]
    Certificate {
        /// The site.
        site: String,
        /// What rustls said.
        problem: String,
    },
    /// The site answered with a redirect, which abba does not follow with
    /// the credential.
    #[error("{site}: {call} is redirected to {to} (HTTP {status}); abba does not follow redirects with the credential: link that URL instead if it is the same site")]
    Redirect {
        /// The site.
        site: String,
        /// The call.
        call: String,
        /// The status.
        status: u16,
        /// Where to.
        to: String,
    },
    /// An HTTP status abba does not retry.
    #[error("{site}: {call} answered HTTP {status}: {body}")]
    Status {
        /// The site.
        site: String,
        /// The call.
        call: String,
        /// The status.
        status: u16,
        /// The start of the body.
        body: String,
    },
    /// The site stayed unreachable, overloaded or failing after the retries.
    #[error("{site}: {call} failed {attempts} times, the last: {last}")]
    GaveUp {
        /// The site.
        site: String,
        /// The call.
        call: String,
        /// Attempts made.
        attempts: u32,
        /// The last failure.
        last: String,
    },
    /// The body is not what Nightscout's API promises.
    #[error("{site}: {call}: {problem}")]
    Protocol {
        /// The site.
        site: String,
        /// The call.
        call: String,
        /// What was expected.
        problem: String,
    },
    /// The site served what abba cannot prove to be all of it (a server
    /// that does not page as Nightscout does): nothing of this sync is
    /// imported, so no advice rests on a day that may be incomplete.
    #[error("{site}: the sync cannot prove it read everything, so it imported nothing (the store and the advice stay as the last complete sync left them): {}. The site does not answer as Nightscout does; abba will try again at the next sync", what.join("; "))]
    Incomplete {
        /// The site.
        site: String,
        /// What may be missing, each in words.
        what: Vec<String>,
    },
    /// A first sync (or its rest) failed part-way: the whole days read
    /// are kept (not imported), the next sync reads the rest.
    #[error("{site}: the first sync failed part-way; the days from {from} on were read whole and are kept, not imported (no advice rests on a history read in part): the next sync reads only the rest, then imports all. {error}")]
    Resumable {
        /// The site.
        site: String,
        /// From when (UTC) the data are kept.
        from: String,
        /// Why the read stopped.
        error: Box<NsError>,
    },
    /// The person has no link.
    #[error("{0} has no Nightscout link (make one with `abba link nightscout --person {0} --url ... --token ...`)")]
    NoLink(String),
    /// `--write-back` with a credential that may not write what abba
    /// writes.
    #[error("{site}: the access token may not {what} ({missing}), which --write-back needs; give a token whose roles allow it (Nightscout's admin role does), or link without --write-back")]
    CannotWrite {
        /// The site.
        site: String,
        /// In words.
        what: String,
        /// The permissions missing.
        missing: String,
    },
    /// The sync's records came in, writing back failed.
    #[error("the sync's records are in the store; writing back failed: {0}")]
    WriteBack(Box<NsError>),
    /// The store said no.
    #[error(transparent)]
    Store(#[from] abba_store::StoreError),
}
