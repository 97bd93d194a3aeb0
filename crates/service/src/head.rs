//! A request's head checked before it is served (by the connection loop,
//! `crate::server`): what the rest of the service reads from the head must
//! mean one thing. Each refusal is a 400 naming the header or the request
//! target, and the connection is closed after it (its body is not read).

use crate::error::ApiError;
use abba_api::ErrorCode;
use axum::http::{header, Request, StatusCode, Version};

/// Why a request's head is refused, if it is: [`bad_target`],
/// [`bad_host`], [`bad_transfer_coding`].
pub fn refused<B>(req: &Request<B>) -> Option<ApiError> {
    let bad = |at: &str, why: &str| {
        Some(ApiError::new(StatusCode::BAD_REQUEST, ErrorCode::Invalid, why).at(at))
    };
    if let Some(why) = bad_target(req) {
        return bad("request target", why);
    }
    if let Some(why) = bad_host(req) {
        return bad("Host", why);
    }
    if let Some(why) = bad_transfer_coding(req) {
        return bad("Transfer-Encoding", &why);
    }
    None
}

/// Why a request target in absolute form (`GET http://host/path`) is
/// refused: a scheme other than `http` (abba speaks plain HTTP: TLS ends
/// at a proxy in front, which says so only as `crate::web::session`
/// trusts; `GET https://...` made every cookie of the answer `Secure`
/// and named the session `__Host-`, a plain client's say-so taken for
/// TLS), or a host other than the `Host` header's (RFC 9112 section
/// 3.2.2 makes the target's host the one that counts, but the origin check
/// and the clinic's sign-in links read `Host`: one request, two hosts).
/// The target's host equal to `Host` is served (a server must accept the
/// absolute form).
fn bad_target<B>(req: &Request<B>) -> Option<&'static str> {
    let uri = req.uri();
    let scheme = uri.scheme_str()?;
    if !scheme.eq_ignore_ascii_case("http") {
        return Some("the request target names a scheme other than http (abba speaks plain HTTP; send the path alone)");
    }
    let host = req
        .headers()
        .get(header::HOST)
        .and_then(|h| h.to_str().ok());
    let same = match (uri.authority(), host) {
        (Some(a), Some(h)) => a.as_str().eq_ignore_ascii_case(h),
        _ => false,
    };
    (!same).then_some("the request target's host is not the Host header's (send the path alone)")
}

/// Why a request's `Host` is refused (RFC 9112 section 3.2): an HTTP/1.1
/// request without one, one with more than one (which would the origin
/// check and the sign-in links read?), or one that is not a host and port
/// (an empty one is allowed, for a URI without authority).
fn bad_host<B>(req: &Request<B>) -> Option<&'static str> {
    let mut hosts = req.headers().get_all(header::HOST).iter();
    let Some(host) = hosts.next() else {
        return (req.version() == Version::HTTP_11)
            .then_some("an HTTP/1.1 request needs a Host header");
    };
    if hosts.next().is_some() {
        return Some("more than one Host header");
    }
    let ok = host.is_empty()
        || host
            .to_str()
            .ok()
            .is_some_and(|h| !h.contains('@') && h.parse::<axum::http::uri::Authority>().is_ok());
    (!ok).then_some("the Host header is not a host (and port)")
}

/// Why a request's `Transfer-Encoding` is refused: anything but `chunked`
/// once. hyper reads the chunks of `gzip, chunked` and hands the body on
/// still gzip-coded, and nothing after it looks at transfer codings: a
/// body its sender coded was read as if plain (a JSON body declared
/// `Content-Encoding: gzip` is refused, the same bytes under a transfer
/// coding were parsed). RFC 9112 section 6.1 suggests 501 for a coding a
/// server does not know; a 400 here, as for every other malformed head
/// (the service answers a client's mistakes below 500).
fn bad_transfer_coding<B>(req: &Request<B>) -> Option<String> {
    let lines = req.headers().get_all(header::TRANSFER_ENCODING);
    lines.iter().next()?;
    let codings: Vec<String> = lines
        .iter()
        .flat_map(|v| {
            String::from_utf8_lossy(v.as_bytes())
                .split(',')
                .map(|c| c.trim().to_ascii_lowercase())
                .collect::<Vec<_>>()
        })
        .collect();
    (codings != ["chunked"]).then(|| {
        let shown: String = codings.join(", ").chars().take(100).collect();
        format!("Transfer-Encoding \"{shown}\" is not accepted: send the body with Content-Length, or chunked alone")
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn head(target: &str, lines: &[(&str, &str)]) -> Option<String> {
        let mut r = Request::builder().uri(target);
        for (k, v) in lines {
            r = r.header(*k, *v);
        }
        refused(&r.body(()).unwrap()).map(|e| e.body().path.unwrap_or_default())
    }

    #[test]
    fn a_head_means_one_thing_or_is_refused() {
        let host = [("host", "abba.example:8080")];
        assert_eq!(head("/healthz", &host), None);
        assert_eq!(head("http://abba.example:8080/healthz", &host), None);
        assert_eq!(head("http://ABBA.example:8080/healthz", &host), None);
        for target in [
            "https://abba.example:8080/healthz",
            "ftp://abba.example:8080/healthz",
            "http://evil.example/healthz",
            "http://abba.example/healthz",
        ] {
            assert_eq!(
                head(target, &host).as_deref(),
                Some("request target"),
                "{target}"
            );
        }
        assert_eq!(
            head("http://abba.example:8080/healthz", &[]).as_deref(),
            Some("request target")
        );
        let te = |v: &'static str| [host[0], ("transfer-encoding", v)];
        assert_eq!(head("/signin", &te("chunked")), None);
        assert_eq!(head("/signin", &te(" Chunked ")), None);
        for v in [
            "gzip, chunked",
            "chunked, chunked",
            "identity",
            "chunked, gzip",
        ] {
            assert_eq!(
                head("/signin", &te(v)).as_deref(),
                Some("Transfer-Encoding"),
                "{v}"
            );
        }
    }
}
