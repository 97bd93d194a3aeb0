//! Page responses: HTML with its status, redirects, refusals as pages.

use crate::error::ApiError;
use abba_web::pages::{Layout, Message};
use abba_web::texts::EN;
use axum::http::{header, HeaderValue, StatusCode};
use axum::response::{IntoResponse, Response};
use serde::Serialize;

/// The pages' `Referrer-Policy`. Not `no-referrer`: under it a browser
/// sends `Origin: null` with every form POST (the Fetch standard,
/// "append a request `Origin` header"), and the Origin check could not
/// tell abba's own forms from anyone's. `same-origin` sends the referrer
/// to abba only, never to another site, so a sign-in link's secret never
/// leaves it either (the pages link nowhere else).
pub const REFERRER_POLICY: &str = "same-origin";

/// A page path's parameters as text, "" for one that could not be decoded
/// (invalid UTF-8 after percent-decoding) or was written with
/// percent-encoding at all (`crate::extract::percent_encoded`: `%31` was
/// person 1's page): the handler answers it as any unknown id or link,
/// with its page, never axum's plain-text 400.
#[derive(Debug, Clone)]
pub struct PathText<T>(pub T);

impl<S, T> axum::extract::FromRequestParts<S> for PathText<T>
where
    S: Send + Sync,
    T: serde::de::DeserializeOwned + Default + Send,
{
    type Rejection = std::convert::Infallible;

    async fn from_request_parts(
        parts: &mut axum::http::request::Parts,
        state: &S,
    ) -> Result<Self, Self::Rejection> {
        if crate::extract::percent_encoded(parts) {
            return Ok(PathText(T::default()));
        }
        Ok(PathText(
            axum::extract::Path::<T>::from_request_parts(parts, state)
                .await
                .map(|axum::extract::Path(t)| t)
                .unwrap_or_default(),
        ))
    }
}

/// A page that could not be shown as asked: already a response.
#[derive(Debug)]
pub struct PageError(pub Box<Response>);

impl PageError {
    /// A response as a page error.
    pub fn of(r: Response) -> Self {
        PageError(Box::new(r))
    }
}

impl IntoResponse for PageError {
    fn into_response(self) -> Response {
        *self.0
    }
}

impl From<ApiError> for PageError {
    fn from(e: ApiError) -> Self {
        PageError::of(error_page(&e))
    }
}

/// What a page handler answers.
pub type PageResult = Result<Response, PageError>;

/// HTML with a status.
pub fn html(status: StatusCode, body: String) -> Response {
    let mut r = (status, body).into_response();
    r.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/html; charset=utf-8"),
    );
    r
}

/// Renders a page.
pub fn render(
    status: StatusCode,
    page: &'static str,
    layout: &Layout,
    model: &impl Serialize,
) -> PageResult {
    abba_web::render(page, layout, model)
        .map(|body| html(status, body))
        .map_err(|e| PageError::from(ApiError::internal(e)))
}

/// A page that says `text` (a refusal, an explanation).
pub fn message(status: StatusCode, title: &str, text: &str, csrf: Option<String>) -> Response {
    let model = Message {
        text: text.to_string(),
        link: None,
    };
    match abba_web::render("message.html", &Layout::new(title, csrf), &model) {
        Ok(body) => html(status, body),
        Err(e) => ApiError::internal(e).into_response(),
    }
}

/// 303 to `to` (after a POST: post/redirect/get).
pub fn see_other(to: &str) -> Response {
    let mut r = StatusCode::SEE_OTHER.into_response();
    if let Ok(v) = HeaderValue::from_str(to) {
        r.headers_mut().insert(header::LOCATION, v);
    }
    r
}

/// 403 for a form without a valid CSRF token or from another origin.
pub fn forbidden_csrf() -> PageError {
    PageError::of(message(
        StatusCode::FORBIDDEN,
        EN.forbidden_title,
        EN.forbidden_csrf,
        None,
    ))
}

/// 403 for a form sent without a live session (signed out, expired or
/// revoked): says so, never that the form came from elsewhere.
pub fn forbidden_no_session() -> PageError {
    PageError::of(message(
        StatusCode::FORBIDDEN,
        EN.forbidden_title,
        EN.forbidden_no_session,
        None,
    ))
}

/// 403 for a page of the other role.
pub fn forbidden_role() -> PageError {
    PageError::of(message(
        StatusCode::FORBIDDEN,
        EN.forbidden_title,
        EN.forbidden_role,
        None,
    ))
}

/// 404 as a page.
pub fn not_found() -> PageError {
    PageError::of(message(
        StatusCode::NOT_FOUND,
        EN.not_found_title,
        EN.not_found,
        None,
    ))
}

/// The answer to a URL that is no page (the router's fallback outside
/// `/v1`): the 404 page, with the pages' headers.
pub fn unknown_page() -> Response {
    with_page_headers(not_found().into_response())
}

/// The answer to a page asked with a method it does not take (the
/// router's 405 fallback outside `/v1`): a page, with the pages' headers,
/// never the API's JSON.
pub fn not_allowed_page() -> Response {
    with_page_headers(message(
        StatusCode::METHOD_NOT_ALLOWED,
        EN.not_allowed_title,
        EN.not_allowed,
        None,
    ))
}

/// `r` with the headers every page has (the pages' router layers do not
/// run for the router's fallbacks).
fn with_page_headers(mut r: Response) -> Response {
    let h = r.headers_mut();
    for (name, value) in [
        (header::CONTENT_SECURITY_POLICY, abba_web::CSP),
        (header::X_FRAME_OPTIONS, "DENY"),
        (header::REFERRER_POLICY, REFERRER_POLICY),
        (header::CACHE_CONTROL, "no-store"),
        (header::X_CONTENT_TYPE_OPTIONS, "nosniff"),
    ] {
        h.insert(name, HeaderValue::from_static(value));
    }
    r
}

/// An error of the store or the service as a page (503 keeps its
/// `Retry-After`).
pub fn error_page(e: &ApiError) -> Response {
    let text = match e.status {
        StatusCode::SERVICE_UNAVAILABLE => EN.busy.to_string(),
        _ => e.body().message,
    };
    let title = match e.status {
        StatusCode::NOT_FOUND => EN.not_found_title,
        StatusCode::FORBIDDEN => EN.forbidden_title,
        _ => EN.error_title,
    };
    let mut r = message(e.status, title, &text, None);
    if let Some(s) = e.retry_after {
        r.headers_mut()
            .insert(header::RETRY_AFTER, HeaderValue::from(s));
    }
    r
}

/// The stylesheet.
pub async fn style() -> Response {
    let mut r = abba_web::STYLE.into_response();
    r.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("text/css; charset=utf-8"),
    );
    r
}

/// The icon (`/favicon.ico`, an SVG).
pub async fn icon() -> Response {
    let mut r = abba_web::ICON_SVG.into_response();
    r.headers_mut().insert(
        header::CONTENT_TYPE,
        HeaderValue::from_static("image/svg+xml"),
    );
    r
}

/// This module's routes (merged by [`super::routes`]).
pub fn routes() -> axum::Router<crate::state::AppState> {
    use axum::routing::get;
    axum::Router::new()
        .route(abba_web::STYLE_PATH, get(style))
        .route("/favicon.ico", get(icon))
}
