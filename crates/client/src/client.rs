//! Typed calls to every `/v1` endpoint, on abba-api's types.

use crate::error::ClientError;
use abba_api::{
    AdviceResponse, AnswerBody, AnswersAck, BoundsBody, ErrorBody, EventsAck, EventsBody, Health,
    HistoryResponse, NewPersonBody, PersonCreated, SuggestionList, SyncResponse, TokenIssued,
    TokenRevoked,
};
use serde::de::DeserializeOwned;
use serde::Serialize;
use std::time::Duration;

/// Largest response body read (the OpenAPI document and a long history are
/// the big ones).
const MAX_RESPONSE_BYTES: u64 = 64 * 1024 * 1024;

/// A blocking client of one service, with one bearer token.
///
/// Connections are kept alive and reused. Every call returns the typed
/// body of a 2xx answer, or a [`ClientError`]: [`ClientError::Status`]
/// with the service's [`ErrorBody`] for a 4xx/5xx,
/// [`ClientError::Unreachable`] when no answer came.
#[derive(Debug, Clone)]
pub struct Client {
    base: String,
    token: Option<String>,
    agent: ureq::Agent,
}

impl Client {
    /// A client of the service at `base_url` (`http://127.0.0.1:8080`)
    /// presenting `token` (none: only `/healthz` answers). Requests time
    /// out after 60 s.
    pub fn new(base_url: &str, token: Option<&str>) -> Result<Self, ClientError> {
        Self::with_timeout(base_url, token, Duration::from_secs(60))
    }

    /// Like [`Client::new`] with another timeout for a whole request.
    pub fn with_timeout(
        base_url: &str,
        token: Option<&str>,
        timeout: Duration,
    ) -> Result<Self, ClientError> {
        let bad = |problem: &str| ClientError::Url {
            url: base_url.to_string(),
            problem: problem.to_string(),
        };
        let rest = base_url
            .strip_prefix("http://")
            .ok_or_else(|| bad("expected http://HOST:PORT (this client speaks plain HTTP only)"))?;
        if rest.is_empty() || rest.starts_with('/') {
            return Err(bad("no host after http://"));
        }
        let agent: ureq::Agent = ureq::Agent::config_builder()
            .http_status_as_error(false)
            .timeout_global(Some(timeout))
            .build()
            .into();
        Ok(Self {
            base: base_url.trim_end_matches('/').to_string(),
            token: token.map(str::to_string),
            agent,
        })
    }

    /// The same service with another token (a person's token issued by the
    /// admin, for instance); the connection pool is shared.
    pub fn with_token(&self, token: &str) -> Self {
        Self {
            base: self.base.clone(),
            token: Some(token.to_string()),
            agent: self.agent.clone(),
        }
    }

    /// The base URL.
    pub fn base_url(&self) -> &str {
        &self.base
    }

    /// `GET /healthz` (no token needed).
    pub fn health(&self) -> Result<Health, ClientError> {
        self.get("/healthz")
    }

    /// `GET /v1/openapi.json`: the generated OpenAPI document.
    pub fn openapi(&self) -> Result<serde_json::Value, ClientError> {
        self.get("/v1/openapi.json")
    }

    /// `POST /v1/persons` (admin).
    pub fn create_person(&self, body: &NewPersonBody) -> Result<PersonCreated, ClientError> {
        self.send("POST", "/v1/persons", body)
    }

    /// `PUT /v1/persons/{id}/bounds` (admin).
    pub fn set_bounds(&self, person: u64, body: &BoundsBody) -> Result<BoundsBody, ClientError> {
        self.send("PUT", &format!("/v1/persons/{person}/bounds"), body)
    }

    /// `POST /v1/persons/{id}/tokens` (admin): the person's own token.
    pub fn issue_token(&self, person: u64) -> Result<TokenIssued, ClientError> {
        let url = self.url(&format!("/v1/persons/{person}/tokens"));
        let r = self.auth(self.agent.post(&url)).send_empty();
        self.finish("POST", url, r)
    }

    /// `DELETE /v1/tokens/{token_id}` (admin).
    pub fn revoke_token(&self, token_id: u64) -> Result<TokenRevoked, ClientError> {
        let path = format!("/v1/tokens/{token_id}");
        let url = self.url(&path);
        let r = self.auth(self.agent.delete(&url)).call();
        self.finish("DELETE", url, r)
    }

    /// `POST /v1/persons/{id}/events`: a batch, acknowledged after COMMIT.
    pub fn post_events(&self, person: u64, body: &EventsBody) -> Result<EventsAck, ClientError> {
        self.send("POST", &format!("/v1/persons/{person}/events"), body)
    }

    /// `POST /v1/persons/{id}/answers`.
    pub fn post_answers(&self, person: u64, body: &AnswerBody) -> Result<AnswersAck, ClientError> {
        self.send("POST", &format!("/v1/persons/{person}/answers"), body)
    }

    /// `GET /v1/persons/{id}/sync?from=N`: the held sequence numbers ≥ N.
    pub fn sync(&self, person: u64, from: u64) -> Result<SyncResponse, ClientError> {
        self.get(&format!("/v1/persons/{person}/sync?from={from}"))
    }

    /// `GET /v1/persons/{id}/suggestions[?after=ID]`, every page.
    pub fn suggestions(
        &self,
        person: u64,
        after: Option<u64>,
    ) -> Result<SuggestionList, ClientError> {
        let mut all = self.suggestions_page(person, after, None)?;
        while let Some(next) = all.next_after {
            let more = self.suggestions_page(person, Some(next), None)?;
            all.suggestions.extend(more.suggestions);
            all.next_after = more.next_after;
        }
        Ok(all)
    }

    /// One page: `GET /v1/persons/{id}/suggestions?after=ID&limit=N`.
    pub fn suggestions_page(
        &self,
        person: u64,
        after: Option<u64>,
        limit: Option<u64>,
    ) -> Result<SuggestionList, ClientError> {
        self.get(&format!(
            "/v1/persons/{person}/suggestions{}",
            page_query(after, limit)
        ))
    }

    /// `GET /v1/persons/{id}/advice`.
    pub fn advice(&self, person: u64) -> Result<AdviceResponse, ClientError> {
        self.get(&format!("/v1/persons/{person}/advice"))
    }

    /// `GET /v1/persons/{id}/history`, every page.
    pub fn history(&self, person: u64) -> Result<HistoryResponse, ClientError> {
        let mut all = self.history_page(person, None, None)?;
        while let Some(next) = all.next_after {
            let more = self.history_page(person, Some(next), None)?;
            all.suggestions.extend(more.suggestions);
            all.next_after = more.next_after;
        }
        Ok(all)
    }

    /// One page: `GET /v1/persons/{id}/history?after=ID&limit=N`.
    pub fn history_page(
        &self,
        person: u64,
        after: Option<u64>,
        limit: Option<u64>,
    ) -> Result<HistoryResponse, ClientError> {
        self.get(&format!(
            "/v1/persons/{person}/history{}",
            page_query(after, limit)
        ))
    }

    fn url(&self, path: &str) -> String {
        format!("{}{path}", self.base)
    }

    fn auth<B>(&self, rb: ureq::RequestBuilder<B>) -> ureq::RequestBuilder<B> {
        match &self.token {
            Some(t) => rb.header("Authorization", format!("Bearer {t}")),
            None => rb,
        }
    }

    fn get<T: DeserializeOwned>(&self, path: &str) -> Result<T, ClientError> {
        let url = self.url(path);
        let r = self.auth(self.agent.get(&url)).call();
        self.finish("GET", url, r)
    }

    fn send<B: Serialize, T: DeserializeOwned>(
        &self,
        method: &'static str,
        path: &str,
        body: &B,
    ) -> Result<T, ClientError> {
        let url = self.url(path);
        let bytes = serde_json::to_vec(body).map_err(|e| ClientError::Decode {
            method,
            url: url.clone(),
            message: format!("cannot encode the request: {e}"),
        })?;
        let rb = match method {
            "PUT" => self.agent.put(&url),
            _ => self.agent.post(&url),
        };
        let r = self
            .auth(rb)
            .content_type("application/json")
            .send(&bytes[..]);
        self.finish(method, url, r)
    }

    fn finish<T: DeserializeOwned>(
        &self,
        method: &'static str,
        url: String,
        r: Result<ureq::http::Response<ureq::Body>, ureq::Error>,
    ) -> Result<T, ClientError> {
        let mut resp = r.map_err(|e| ClientError::Unreachable {
            method,
            url: url.clone(),
            message: e.to_string(),
        })?;
        let status = resp.status().as_u16();
        let retry_after = resp
            .headers()
            .get("retry-after")
            .and_then(|v| v.to_str().ok())
            .and_then(|v| v.trim().parse::<u32>().ok());
        let body = resp
            .body_mut()
            .with_config()
            .limit(MAX_RESPONSE_BYTES)
            .read_to_vec()
            .map_err(|e| ClientError::Unreachable {
                method,
                url: url.clone(),
                message: format!("reading the response: {e}"),
            })?;
        if !(200..300).contains(&status) {
            let text: String = String::from_utf8_lossy(&body).chars().take(500).collect();
            return Err(ClientError::Status {
                method,
                url,
                status,
                body: serde_json::from_slice::<ErrorBody>(&body).ok(),
                text,
                retry_after,
            });
        }
        let de = &mut serde_json::Deserializer::from_slice(&body);
        serde_path_to_error::deserialize(de).map_err(|e| ClientError::Decode {
            method,
            url,
            message: format!("at {}: {}", e.path(), e.inner()),
        })
    }
}

/// `?after=..&limit=..` (empty when neither).
fn page_query(after: Option<u64>, limit: Option<u64>) -> String {
    let mut parts = Vec::new();
    if let Some(a) = after {
        parts.push(format!("after={a}"));
    }
    if let Some(l) = limit {
        parts.push(format!("limit={l}"));
    }
    if parts.is_empty() {
        String::new()
    } else {
        format!("?{}", parts.join("&"))
    }
}
