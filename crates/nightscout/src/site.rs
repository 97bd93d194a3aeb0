//! The site's URL and the credential as abba keeps them: the URL's scheme
//! and host checked, an API secret only as its SHA-1 hex.

use crate::error::NsError;
use abba_store::link::Credential;
use sha1::{Digest, Sha1};

/// Nightscout refuses an API_SECRET shorter than this at start-up.
pub const API_SECRET_MIN_CHARS: usize = 12;

/// A checked site URL: `https://host[:port][/path]` (plain `http` only to
/// this machine), without user, query or fragment, no trailing slash.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SiteUrl {
    base: String,
    host: String,
}

impl SiteUrl {
    /// Checks `url`.
    pub fn parse(url: &str) -> Result<Self, NsError> {
        // The URL as the messages show it: a user, password or query
        // (xDrip's `https://SECRET@host/api/v1`, `?token=...`) may hold a
        // credential, which no message shows.
        let shown = redacted(url);
        let bad = |problem: &str| NsError::Url {
            url: shown.clone(),
            problem: problem.to_string(),
        };
        let trimmed = url.trim();
        if trimmed.contains('#') {
            return Err(bad("a fragment (#...) is not part of a site's address"));
        }
        let uri: ureq::http::Uri = trimmed.parse().map_err(|e| {
            bad(&format!(
                "not a URL ({e}); expected https://your-site.example"
            ))
        })?;
        let scheme = uri
            .scheme_str()
            .ok_or_else(|| bad("expected https://your-site.example (the scheme is missing)"))?
            .to_ascii_lowercase();
        let authority = uri
            .authority()
            .ok_or_else(|| bad("expected https://your-site.example (the host is missing)"))?;
        if authority.as_str().contains('@') {
            return Err(bad(
                "a user or password in the URL is not how Nightscout authenticates: give --token or --api-secret",
            ));
        }
        if uri.query().is_some() {
            return Err(bad(
                "a query (?...) is not part of a site's address; give a token with --token",
            ));
        }
        let host = authority.host().to_ascii_lowercase();
        if host.is_empty() {
            return Err(bad("the host is empty"));
        }
        let loopback = host == "localhost"
            || host == "[::1]"
            || host
                .parse::<std::net::Ipv4Addr>()
                .is_ok_and(|a| a.is_loopback());
        match scheme.as_str() {
            "https" => {}
            "http" if loopback => {}
            "http" => {
                return Err(bad(
                    "plain http would send the credential and the person's data unencrypted: use https (plain http only to this machine)",
                ))
            }
            other => return Err(bad(&format!("scheme {other}: expected https"))),
        }
        // The API's own path pasted with the site (uploaders are
        // configured with `https://host/api/v1`): the site is what is
        // before it.
        let mut path = uri.path().trim_end_matches('/');
        for api in ["/api/v1", "/api/v2", "/api/v3"] {
            if path.to_ascii_lowercase().ends_with(api) {
                path = path[..path.len() - api.len()].trim_end_matches('/');
                break;
            }
        }
        let base = format!(
            "{scheme}://{}{path}",
            authority.as_str().to_ascii_lowercase()
        );
        Ok(Self { base, host })
    }

    /// The base URL (no trailing slash).
    pub fn as_str(&self) -> &str {
        &self.base
    }

    /// The host.
    pub fn host(&self) -> &str {
        &self.host
    }

    /// The full URL of `path` (which starts with `/`).
    pub fn join(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }
}

impl std::fmt::Display for SiteUrl {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.base)
    }
}

/// `url` with what may be a credential replaced by `***`: the user and
/// password before `@` and the query's values.
pub(crate) fn redacted(url: &str) -> String {
    let url = url.trim();
    let (head, query) = match url.split_once('?') {
        Some((h, q)) => (h, Some(q)),
        None => (url, None),
    };
    let mut out = match head.split_once("://") {
        Some((scheme, rest)) => {
            let (authority, path) = match rest.find('/') {
                Some(i) => rest.split_at(i),
                None => (rest, ""),
            };
            match authority.rsplit_once('@') {
                Some((_, host)) => format!("{scheme}://***@{host}{path}"),
                None => head.to_string(),
            }
        }
        None => match head.rsplit_once('@') {
            Some((_, host)) => format!("***@{host}"),
            None => head.to_string(),
        },
    };
    if let Some(q) = query {
        let q = q.split('#').next().unwrap_or("");
        let parts: Vec<String> = q
            .split('&')
            .map(|kv| match kv.split_once('=') {
                Some((k, _)) => format!("{k}=***"),
                None => kv.to_string(),
            })
            .collect();
        out.push('?');
        out.push_str(&parts.join("&"));
    }
    out
}

/// The SHA-1 hex of an API secret (what the `api-secret` header carries).
pub fn hash_api_secret(secret: &str) -> String {
    let d = Sha1::digest(secret.as_bytes());
    d.iter().map(|b| format!("{b:02x}")).collect()
}

/// The credential to store from what the user gave: an API secret (at
/// least [`API_SECRET_MIN_CHARS`], kept only as its hash) or an access
/// token (`subject-0123456789abcdef`, kept as given).
pub fn credential(token: Option<&str>, api_secret: Option<&str>) -> Result<Credential, NsError> {
    match (token, api_secret) {
        (Some(t), None) => {
            let t = t.trim();
            if t.is_empty() || t.chars().any(|c| c.is_whitespace() || c.is_control()) {
                return Err(NsError::Credential {
                    flag: "--token",
                    problem: "expected an access token such as abba-0123456789abcdef (from Nightscout's Admin tools)".into(),
                });
            }
            Ok(Credential::Token(t.to_string()))
        }
        (None, Some(s)) => {
            if s.chars().count() < API_SECRET_MIN_CHARS {
                return Err(NsError::Credential {
                    flag: "--api-secret",
                    problem: format!(
                        "{} characters; Nightscout's API_SECRET has at least {API_SECRET_MIN_CHARS}",
                        s.chars().count()
                    ),
                });
            }
            Ok(Credential::ApiSecretSha1(hash_api_secret(s)))
        }
        _ => Err(NsError::Credential {
            flag: "--token / --api-secret",
            problem: "give exactly one of them".into(),
        }),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn urls_are_checked() {
        let u = SiteUrl::parse("https://My.Site.example/ns/").unwrap();
        assert_eq!(u.as_str(), "https://my.site.example/ns");
        assert_eq!(u.host(), "my.site.example");
        assert!(SiteUrl::parse("http://127.0.0.1:8080").is_ok());
        for bad in [
            "http://my.site.example",
            "ftp://my.site.example",
            "https://user:pw@my.site.example",
            "https://my.site.example/?token=x",
            "https://my.site.example/#x",
            "my.site.example",
        ] {
            assert!(SiteUrl::parse(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn the_apis_path_pasted_with_the_site_is_the_site() {
        for (given, base) in [
            ("https://my.site.example/api/v1", "https://my.site.example"),
            ("https://my.site.example/api/v1/", "https://my.site.example"),
            (
                "https://my.site.example/ns/API/V1/",
                "https://my.site.example/ns",
            ),
            ("https://my.site.example/api/v3", "https://my.site.example"),
            ("https://my.site.example/api", "https://my.site.example/api"),
        ] {
            assert_eq!(SiteUrl::parse(given).unwrap().as_str(), base, "{given}");
        }
    }

    #[test]
    fn a_credential_in_a_refused_url_is_not_shown() {
        for (given, secret) in [
            ("https://s3cr3t-api-secret@my.site.example/api/v1", "s3cr3t"),
            ("https://user:pa55word@my.site.example", "pa55word"),
            (
                "https://my.site.example/?token=reader-0123456789abcdef",
                "0123456789abcdef",
            ),
            ("http://s3cr3t-api-secret@my.site.example/api/v1", "s3cr3t"),
            ("s3cr3t-api-secret@my.site.example", "s3cr3t"),
        ] {
            let e = SiteUrl::parse(given).unwrap_err().to_string();
            assert!(!e.contains(secret), "{e}");
            assert!(e.contains("my.site.example"), "{e}");
        }
    }

    #[test]
    fn secrets_are_hashed_as_nightscout_does() {
        // SHA-1 of "abc" (FIPS 180-1 test vector).
        assert_eq!(
            hash_api_secret("abc"),
            "a9993e364706816aba3e25717850c26c9cd0d89d"
        );
        assert!(credential(None, Some("short")).is_err());
        let c = credential(None, Some("a-long-enough-secret")).unwrap();
        assert_eq!(c.secret().len(), 40);
        assert!(!format!("{c:?}").contains(c.secret()));
    }
}
