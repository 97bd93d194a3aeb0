//! Who a request's client is, for the per-client limits (requests in
//! flight, failed authentications): the peer's address, or, behind a
//! reverse proxy on this host (`abba serve --behind-proxy`), the address
//! that proxy put last in `X-Forwarded-For`.
//!
//! The trust assumption: with `--behind-proxy` the operator says that
//! every loopback peer is their own proxy, and that it appends the
//! address it received the request from to `X-Forwarded-For` (nginx's
//! `proxy_set_header X-Forwarded-For $proxy_add_x_forwarded_for`, which
//! appends `$remote_addr`; Caddy 2.5 and later set it by default and drop
//! a client's own unless told to trust it). Only the last entry is read:
//! a client may write anything before it. A loopback peer without the
//! header (a local script, the proxy's health check) is its own client.
//! Without `--behind-proxy` the header is never read, so a client cannot
//! pose as many clients or as another; neither is `X-Forwarded-Proto`
//! ([`ViaProxy`]).

use axum::extract::ConnectInfo;
use axum::http::request::Parts;
use axum::http::HeaderMap;
use std::net::{IpAddr, SocketAddr};

/// Put in a request's extensions when it came from a reverse proxy this
/// service trusts: a loopback peer under `--behind-proxy`. Only then are
/// the proxy's `X-Forwarded-For` (here) and `X-Forwarded-Proto` (the
/// pages' `Ctx`: a session cookie `Secure`) read; without the flag any
/// local process could say them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ViaProxy;

/// The client a request is counted for (see the module's doc): put in
/// each request's extensions by the router's outer layer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientAddr(pub IpAddr);

impl ClientAddr {
    /// The client of a request from `peer` with `headers`: the peer, or
    /// with `behind_proxy` and a loopback peer, the last address of
    /// `X-Forwarded-For` (the peer when there is none; an entry that is
    /// not an address is logged and the peer used).
    pub fn of(peer: IpAddr, headers: &HeaderMap, behind_proxy: bool) -> Self {
        if !(behind_proxy && peer.is_loopback()) {
            return Self(peer);
        }
        match last_forwarded(headers) {
            None => Self(peer),
            Some(Ok(ip)) => Self(ip),
            Some(Err(text)) => {
                tracing::warn!(entry = %text.escape_debug(), "X-Forwarded-For's last entry is not an address: the request is counted for the proxy");
                Self(peer)
            }
        }
    }

    /// The key of the client's limits: an IPv4 address, or an IPv6
    /// address's /64 (one host holds a whole /64).
    pub fn key(self) -> IpAddr {
        crate::state::client_key(self.0)
    }
}

/// The last entry of every `X-Forwarded-For` line together (`None` without
/// the header): an address, `Err` with the entry's text otherwise. An
/// entry may carry a port (`192.0.2.7:4711`, `[2001:db8::1]:443`).
fn last_forwarded(headers: &HeaderMap) -> Option<Result<IpAddr, String>> {
    let last_line = headers.get_all("x-forwarded-for").iter().next_back()?;
    let text = String::from_utf8_lossy(last_line.as_bytes());
    let entry = text.rsplit(',').next().unwrap_or("").trim();
    let parsed = entry
        .parse::<IpAddr>()
        .ok()
        .or_else(|| entry.parse::<SocketAddr>().ok().map(|s| s.ip()))
        .map(|ip| match ip {
            IpAddr::V6(v6) => v6.to_ipv4_mapped().map_or(ip, IpAddr::V4),
            v4 => v4,
        });
    Some(parsed.ok_or_else(|| entry.chars().take(64).collect()))
}

/// The client of a request that came over a connection (the router's
/// layer put it there; without it, the peer of `ConnectInfo`).
pub fn of_parts(parts: &Parts) -> Option<IpAddr> {
    parts
        .extensions
        .get::<ClientAddr>()
        .map(|c| c.0)
        .or_else(|| {
            parts
                .extensions
                .get::<ConnectInfo<SocketAddr>>()
                .map(|c| c.0.ip())
        })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn headers(lines: &[&str]) -> HeaderMap {
        let mut h = HeaderMap::new();
        for l in lines {
            h.append("x-forwarded-for", l.parse().unwrap());
        }
        h
    }

    fn of(peer: &str, lines: &[&str], behind: bool) -> IpAddr {
        ClientAddr::of(peer.parse().unwrap(), &headers(lines), behind).0
    }

    /// Without `--behind-proxy` the header is never read; with it, only a
    /// loopback peer's, and only its last entry (what the proxy appended).
    #[test]
    fn only_the_last_entry_a_local_proxy_appended_counts() {
        let forged = ["203.0.113.9"];
        assert_eq!(of("127.0.0.1", &forged, false), of("127.0.0.1", &[], false));
        assert_eq!(of("192.0.2.1", &forged, true).to_string(), "192.0.2.1");
        assert_eq!(
            of("127.0.0.1", &["203.0.113.9, 198.51.100.4"], true).to_string(),
            "198.51.100.4"
        );
        assert_eq!(
            of("::1", &["203.0.113.9", "198.51.100.4:4711"], true).to_string(),
            "198.51.100.4"
        );
        assert_eq!(
            of("127.0.0.1", &["[2001:db8::1]:443"], true).to_string(),
            "2001:db8::1"
        );
        assert_eq!(
            of("127.0.0.1", &["::ffff:192.0.2.8"], true).to_string(),
            "192.0.2.8"
        );
        assert_eq!(of("127.0.0.1", &["unknown"], true).to_string(), "127.0.0.1");
        assert_eq!(of("127.0.0.1", &[], true).to_string(), "127.0.0.1");
    }
}
