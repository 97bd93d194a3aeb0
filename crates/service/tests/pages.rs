//! The web pages by plain HTTP (no browser): sign-in links, sessions,
//! CSRF and Origin checks, the headers of every page, the access matrix,
//! inert names, and a person's whole flow through Today and the Log into
//! the store.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use abba_service::auth;
use abba_store::token::Role;
use axum::body::Body;
use axum::http::{header, Method, Request, StatusCode};
use common::{ev, Svc};
use http_body_util::BodyExt;
use serde_json::{json, Value};
use std::collections::BTreeMap;
use tower::ServiceExt;

const HOST: &str = "abba.test";
const ORIGIN: &str = "http://abba.test";
const HOSTILE: &str = "<script>alert(1)</script>\"' {{ 7*7 }}";
/// [`HOSTILE`] as the pages show it (minijinja escapes `/` too).
const INERT: &str = "&lt;script&gt;alert(1)&lt;&#x2f;script&gt;&quot;&#x27; {{ 7*7 }}";
const CSP: &str = "default-src 'none'; style-src 'self'; img-src 'self' data:; form-action 'self'; frame-ancestors 'none'; base-uri 'none'";

/// A page's answer.
#[derive(Debug)]
pub(crate) struct Page {
    pub(crate) status: StatusCode,
    pub(crate) headers: axum::http::HeaderMap,
    pub(crate) html: String,
}

impl Page {
    fn location(&self) -> &str {
        self.headers
            .get(header::LOCATION)
            .map(|v| v.to_str().unwrap())
            .unwrap_or("")
    }

    /// The value of the first `name="NAME" value="..."` hidden input.
    fn hidden(&self, name: &str) -> String {
        let pat = format!("name=\"{name}\" value=\"");
        let i = self
            .html
            .find(&pat)
            .unwrap_or_else(|| panic!("no {name} in {}", self.html))
            + pat.len();
        let j = self.html[i..].find('"').unwrap();
        self.html[i..i + j].to_string()
    }

    /// The HTML of the element starting at `start` up to its `</tag>`.
    pub(crate) fn section(&self, start: &str, tag: &str) -> &str {
        let i = self
            .html
            .find(start)
            .unwrap_or_else(|| panic!("no {start} in {}", self.html));
        let end = format!("</{tag}>");
        let j = self.html[i..].find(&end).unwrap();
        &self.html[i..i + j]
    }
}

/// A browser without JavaScript: a cookie jar, same-origin forms.
pub(crate) struct Browser<'a> {
    svc: &'a Svc,
    cookies: BTreeMap<String, String>,
    origin: Option<&'static str>,
}

impl<'a> Browser<'a> {
    fn new(svc: &'a Svc) -> Self {
        Self {
            svc,
            cookies: BTreeMap::new(),
            origin: Some(ORIGIN),
        }
    }

    /// The jar as a `Cookie` header.
    fn cookie_header(&self) -> String {
        let c: Vec<String> = self
            .cookies
            .iter()
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        c.join("; ")
    }

    async fn send(&mut self, method: Method, path: &str, form: Option<&[(&str, &str)]>) -> Page {
        let mut req = Request::builder()
            .method(method.clone())
            .uri(path)
            .header(header::HOST, HOST);
        if !self.cookies.is_empty() {
            req = req.header(header::COOKIE, self.cookie_header());
        }
        if method == Method::POST {
            if let Some(o) = self.origin {
                req = req.header(header::ORIGIN, o);
            }
        }
        let req = match form {
            Some(fields) => {
                let mut s = form_urlencoded::Serializer::new(String::new());
                for (k, v) in fields {
                    s.append_pair(k, v);
                }
                req.header(header::CONTENT_TYPE, "application/x-www-form-urlencoded")
                    .body(Body::from(s.finish()))
                    .unwrap()
            }
            None => req.body(Body::empty()).unwrap(),
        };
        let res = self.svc.router.clone().oneshot(req).await.unwrap();
        let status = res.status();
        let headers = res.headers().clone();
        for v in headers.get_all(header::SET_COOKIE) {
            let v = v.to_str().unwrap();
            let (pair, attrs) = v.split_once(';').unwrap_or((v, ""));
            let (k, val) = pair.split_once('=').unwrap();
            if attrs.contains("Max-Age=0") {
                self.cookies.remove(k);
            } else {
                self.cookies.insert(k.to_string(), val.to_string());
            }
        }
        let bytes = res.into_body().collect().await.unwrap().to_bytes();
        Page {
            status,
            headers,
            html: String::from_utf8_lossy(&bytes).to_string(),
        }
    }

    pub(crate) async fn get(&mut self, path: &str) -> Page {
        self.send(Method::GET, path, None).await
    }

    async fn post(&mut self, path: &str, form: &[(&str, &str)]) -> Page {
        self.send(Method::POST, path, Some(form)).await
    }

    /// A `multipart/form-data` POST as a browser sends a form with file
    /// inputs: text fields, then files (field, file name, bytes).
    async fn post_multipart(
        &mut self,
        path: &str,
        fields: &[(&str, &str)],
        files: &[(&str, &str, &[u8])],
    ) -> Page {
        const BOUNDARY: &str = "----abba-test-boundary-7MA4YWxkTrZu0gW";
        let mut body = Vec::new();
        for (k, v) in fields {
            body.extend_from_slice(
                format!(
                    "--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"{k}\"\r\n\r\n{v}\r\n"
                )
                .as_bytes(),
            );
        }
        for (k, name, bytes) in files {
            body.extend_from_slice(
                format!("--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"{k}\"; filename=\"{name}\"\r\nContent-Type: text/csv\r\n\r\n")
                    .as_bytes(),
            );
            body.extend_from_slice(bytes);
            body.extend_from_slice(b"\r\n");
        }
        body.extend_from_slice(format!("--{BOUNDARY}--\r\n").as_bytes());
        let mut req = Request::builder()
            .method(Method::POST)
            .uri(path)
            .header(header::HOST, HOST)
            .header(header::ORIGIN, ORIGIN)
            .header(
                header::CONTENT_TYPE,
                format!("multipart/form-data; boundary={BOUNDARY}"),
            );
        req = req.header(header::COOKIE, self.cookie_header());
        let res = self
            .svc
            .router
            .clone()
            .oneshot(req.body(Body::from(body)).unwrap())
            .await
            .unwrap();
        let status = res.status();
        let headers = res.headers().clone();
        let bytes = res.into_body().collect().await.unwrap().to_bytes();
        Page {
            status,
            headers,
            html: String::from_utf8_lossy(&bytes).to_string(),
        }
    }

    /// Opens a sign-in link and presses the button.
    async fn sign_in(&mut self, secret: &str) -> Page {
        let p = self.get(&format!("/signin/{secret}")).await;
        assert_eq!(p.status, StatusCode::OK, "{}", p.html);
        let csrf = p.hidden("csrf");
        self.post("/signin", &[("csrf", &csrf), ("link", secret)])
            .await
    }
}

fn link(svc: &Svc, role: Role) -> String {
    let mut store = abba_service::open_store(&svc.db).unwrap();
    auth::issue_signin(&mut store, role).unwrap()
}

/// A person's signed-in browser and their session's CSRF token.
pub(crate) async fn signed_in<'a>(svc: &'a Svc, role: Role) -> (Browser<'a>, String) {
    let mut b = Browser::new(svc);
    let p = b.sign_in(&link(svc, role)).await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let home = b.get(p.location()).await;
    let csrf = if home.status == StatusCode::OK {
        home.hidden("csrf")
    } else {
        String::new()
    };
    (b, csrf)
}

fn app_events(svc: &Svc, person: u64) -> i64 {
    let store = abba_service::open_store(&svc.db).unwrap();
    store.app_event_count(person as i64).unwrap()
}

/// The sign-in link the clinic's page shows for person `id`.
async fn link_shown(svc: &Svc, id: u64) -> String {
    let (mut admin, _) = signed_in(svc, Role::Admin).await;
    let path = format!("/clinic/persons/{id}");
    let csrf = admin.get(&path).await.hidden("csrf");
    let p = admin
        .post(&format!("{path}/signin"), &[("csrf", &csrf)])
        .await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    p.section("<code id=\"signin-url\"", "code").to_string()
}

/// The clinic's sign-in link names `abba serve --public-url` when given,
/// not the request's Host (which a proxy may pass on from anyone).
#[tokio::test]
async fn a_sign_in_link_names_the_public_url_not_the_requests_host() {
    let mut svc = Svc::new();
    let id = svc.person("ana").await;
    let shown = link_shown(&svc, id).await;
    assert!(
        shown.contains("http:&#x2f;&#x2f;abba.test&#x2f;signin&#x2f;"),
        "{shown}"
    );
    let state = abba_service::AppState::open(
        &svc.db,
        abba_service::StoreSettings {
            public_url: Some("https://abba.clinic.example".into()),
            ..abba_service::StoreSettings::default()
        },
    )
    .unwrap();
    svc.router = abba_service::router(state);
    let shown = link_shown(&svc, id).await;
    assert!(
        shown.contains("https:&#x2f;&#x2f;abba.clinic.example&#x2f;signin&#x2f;"),
        "{shown}"
    );
}

/// Signing in on a browser that holds another session (a shared phone)
/// ends that session on the server, not only in this browser.
#[tokio::test]
async fn signing_in_over_a_session_revokes_it() {
    let svc = Svc::new();
    let ana = svc.person("ana").await;
    let bob = svc.person("bob").await;
    let (mut b, _) = signed_in(&svc, Role::Person(bob as i64)).await;
    let bobs = b.cookies.clone();
    assert_eq!(b.get("/").await.status, StatusCode::OK);
    let p = b.sign_in(&link(&svc, Role::Person(ana as i64))).await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    assert_ne!(b.cookies, bobs, "a new session cookie");
    assert_eq!(b.get("/").await.status, StatusCode::OK, "ana is in");
    // Bob's cookie, kept by someone else: the session is over.
    let mut old = Browser::new(&svc);
    old.cookies = bobs;
    let p = old.get("/").await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    assert_eq!(p.location(), "/signin");
}

#[tokio::test]
async fn a_sign_in_link_works_once_and_gives_a_strict_http_only_cookie() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let secret = link(&svc, Role::Person(id as i64));
    let mut b = Browser::new(&svc);
    // Link previews fetch the page: a GET never uses the link.
    for _ in 0..2 {
        let p = b.get(&format!("/signin/{secret}")).await;
        assert_eq!(p.status, StatusCode::OK);
        assert!(p.html.contains("id=\"signin-form\""));
        assert!(p.html.contains("id=\"signin\""));
    }
    let csrf = b.get(&format!("/signin/{secret}")).await.hidden("csrf");
    // Without the double-submit cookie's value: refused, the link unused.
    let p = b.post("/signin", &[("csrf", "0"), ("link", &secret)]).await;
    assert_eq!(p.status, StatusCode::FORBIDDEN);
    let p = b
        .post("/signin", &[("csrf", &csrf), ("link", &secret)])
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    assert_eq!(p.location(), "/");
    let cookie = p
        .headers
        .get_all(header::SET_COOKIE)
        .iter()
        .map(|v| v.to_str().unwrap().to_string())
        .find(|v| v.starts_with("abba_session="))
        .unwrap();
    for attr in ["HttpOnly", "SameSite=Strict", "Path=/;"] {
        assert!(cookie.contains(attr), "{cookie}");
    }
    assert!(
        !cookie.contains("Secure"),
        "plain HTTP from a client: {cookie}"
    );
    let today = b.get("/").await;
    assert_eq!(today.status, StatusCode::OK, "{}", today.html);
    assert!(today.html.contains("id=\"setting-basal\""));
    // Used: refused on its page and on a POST from another browser.
    let mut other = Browser::new(&svc);
    let p = other.get(&format!("/signin/{secret}")).await;
    assert_eq!(p.status, StatusCode::FORBIDDEN);
    assert!(p.html.contains("used already"), "{}", p.html);
    other.cookies.insert("abba_signin".into(), "1".repeat(64));
    let p = other
        .post("/signin", &[("csrf", &"1".repeat(64)), ("link", &secret)])
        .await;
    assert_eq!(p.status, StatusCode::FORBIDDEN);
    assert!(!other.cookies.contains_key("abba_session"));
    // An unknown link.
    let p = other.get(&format!("/signin/{}", "a".repeat(64))).await;
    assert_eq!(p.status, StatusCode::FORBIDDEN);
    // Secure behind a proxy on the same machine only: the in-process
    // router has no peer address, so X-Forwarded-Proto is not trusted.
    let secret = link(&svc, Role::Admin);
    let req = Request::builder()
        .uri(format!("/signin/{secret}"))
        .header(header::HOST, HOST)
        .header("x-forwarded-proto", "https")
        .body(Body::empty())
        .unwrap();
    let res = svc.router.clone().oneshot(req).await.unwrap();
    let c = res
        .headers()
        .get(header::SET_COOKIE)
        .unwrap()
        .to_str()
        .unwrap();
    assert!(!c.contains("Secure"), "{c}");
}

#[tokio::test]
async fn an_expired_link_is_refused() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let secret = "b".repeat(64);
    {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        let then =
            jiff::Timestamp::now().as_millisecond() - abba_store::session::LINK_LIFE_MS - 1000;
        store
            .insert_signin_link(&auth::hash(&secret), Role::Person(id as i64), then)
            .unwrap();
    }
    let mut b = Browser::new(&svc);
    let p = b.get(&format!("/signin/{secret}")).await;
    assert_eq!(p.status, StatusCode::FORBIDDEN);
    assert!(p.html.contains("older than 15 minutes"), "{}", p.html);
    b.cookies.insert("abba_signin".into(), "c".repeat(64));
    let p = b
        .post("/signin", &[("csrf", &"c".repeat(64)), ("link", &secret)])
        .await;
    assert_eq!(p.status, StatusCode::FORBIDDEN);
    assert!(!b.cookies.contains_key("abba_session"));
}

#[tokio::test]
async fn every_page_has_the_csp_and_the_other_headers() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    let secret = link(&svc, Role::Admin);
    for path in [
        "/".to_string(),
        "/log".into(),
        "/glucose".into(),
        "/glucose?range=14d".into(),
        "/history".into(),
        "/signin".into(),
        format!("/signin/{secret}"),
        format!("/signin/{}", "0".repeat(64)),
        "/static/abba.css".into(),
    ] {
        let p = b.get(&path).await;
        let h = |n: &str| {
            p.headers
                .get(n)
                .map(|v| v.to_str().unwrap().to_string())
                .unwrap_or_default()
        };
        assert_eq!(h("content-security-policy"), CSP, "{path}");
        assert_eq!(h("cache-control"), "no-store", "{path}");
        assert_eq!(h("x-content-type-options"), "nosniff", "{path}");
        assert_eq!(h("x-frame-options"), "DENY", "{path}");
        assert_eq!(h("referrer-policy"), "same-origin", "{path}");
        if path != "/static/abba.css" {
            assert!(h("content-type").starts_with("text/html"), "{path}");
            for part in [
                "<main id=\"main\"",
                "class=\"skip\" href=\"#main\"",
                "<nav",
                "id=\"notice\"",
                "abba is research software, not a medical device",
                "lang=\"en\"",
            ] {
                assert!(p.html.contains(part), "{path} lacks {part}");
            }
        }
    }
    // No script anywhere.
    assert!(!b.get("/").await.html.contains("<script"));
}

#[tokio::test]
async fn the_access_matrix_of_the_pages() {
    let svc = Svc::new();
    let a = svc.person("ana").await;
    let _b = svc.person("ben").await;
    let mut nobody = Browser::new(&svc);
    let (mut ana, ana_csrf) = signed_in(&svc, Role::Person(a as i64)).await;
    let (mut admin, admin_csrf) = signed_in(&svc, Role::Admin).await;
    for path in ["/", "/log", "/glucose", "/history", "/report"] {
        let p = nobody.get(path).await;
        assert_eq!(
            (p.status, p.location()),
            (StatusCode::SEE_OTHER, "/signin"),
            "{path}"
        );
        assert_eq!(ana.get(path).await.status, StatusCode::OK, "{path}");
        let p = admin.get(path).await;
        assert_eq!(
            (p.status, p.location()),
            (StatusCode::SEE_OTHER, "/clinic"),
            "{path}"
        );
    }
    let posts: [(&str, Vec<(&str, &str)>); 4] = [
        (
            "/answer",
            vec![("suggestion_id", "4"), ("action", "accept")],
        ),
        ("/log/reading", vec![("glucose", "120")]),
        ("/log/meal", vec![("carbs", "40"), ("slot", "lunch")]),
        ("/signout", vec![]),
    ];
    for (path, fields) in &posts {
        let p = nobody.post(path, fields).await;
        assert_eq!(p.status, StatusCode::FORBIDDEN, "{path} without a session");
        let mut f = fields.clone();
        f.push(("csrf", &admin_csrf));
        if *path != "/signout" {
            let p = admin.post(path, &f).await;
            assert_eq!(p.status, StatusCode::FORBIDDEN, "{path} by the admin");
        }
    }
    assert_eq!(app_events(&svc, a), 0);
    // The clinic's pages: the admin only; a person's session is refused
    // (their own record included), nobody is sent to sign in.
    let b = _b;
    let clinic_gets = [
        "/clinic".to_string(),
        format!("/clinic/persons/{a}"),
        format!("/clinic/persons/{b}"),
        format!("/clinic/persons/{a}/report"),
    ];
    for path in &clinic_gets {
        assert_eq!(ana.get(path).await.status, StatusCode::FORBIDDEN, "{path}");
        let p = nobody.get(path).await;
        assert_eq!(
            (p.status, p.location()),
            (StatusCode::SEE_OTHER, "/signin"),
            "{path}"
        );
    }
    assert_eq!(admin.get("/clinic").await.status, StatusCode::OK);
    assert_eq!(
        admin.get(&format!("/clinic/persons/{b}")).await.status,
        StatusCode::OK
    );
    let clinic_posts: [(String, Vec<(&str, &str)>); 5] = [
        (
            format!("/clinic/persons/{a}/bounds"),
            vec![("basal_min", "0.1"), ("basal_max", "3")],
        ),
        (
            format!("/clinic/persons/{a}/steps"),
            vec![("basal_step", "0.01")],
        ),
        (
            format!("/clinic/persons/{a}/therapy"),
            vec![("basal", "1.1")],
        ),
        (format!("/clinic/persons/{a}/signin"), vec![]),
        (format!("/clinic/persons/{a}/tokens"), vec![]),
    ];
    for (path, fields) in &clinic_posts {
        let mut f = fields.clone();
        f.push(("csrf", &ana_csrf));
        assert_eq!(
            ana.post(path, &f).await.status,
            StatusCode::FORBIDDEN,
            "{path} by a person"
        );
        assert_eq!(
            nobody.post(path, fields).await.status,
            StatusCode::FORBIDDEN,
            "{path} by nobody"
        );
    }
    {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        let before = store.person("ben").unwrap();
        let live = store.live(a as i64).unwrap();
        use abba_advisor::Advisor as _;
        assert_eq!(live.advisor.settings().basal.0, 1.0, "no change of therapy");
        assert_eq!(
            format!("{:?}", live.person.settings.bounds),
            format!("{:?}", before.settings.bounds),
            "no bounds"
        );
        assert_eq!(
            store.tokens_of(Role::Person(a as i64)).unwrap().len(),
            0,
            "no token"
        );
    }
    // The cookie is never accepted on /v1.
    let cookie = ana
        .cookies
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join("; ");
    let req = Request::builder()
        .uri(format!("/v1/persons/{a}/advice"))
        .header(header::COOKIE, cookie)
        .body(Body::empty())
        .unwrap();
    let res = svc.router.clone().oneshot(req).await.unwrap();
    assert_eq!(res.status(), StatusCode::UNAUTHORIZED);
    // Signing out ends the session in the store.
    let p = ana.post("/signout", &[("csrf", &ana_csrf)]).await;
    assert_eq!(
        (p.status, p.location()),
        (StatusCode::SEE_OTHER, "/signin?out=1")
    );
    let p = ana.get("/").await;
    assert_eq!(p.status, StatusCode::SEE_OTHER);
}

#[tokio::test]
async fn a_post_without_the_csrf_token_or_from_another_origin_changes_nothing() {
    let svc = Svc::new();
    let a = svc.person("ana").await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(a as i64)).await;
    let forms: [(&str, Vec<(&str, &str)>); 3] = [
        ("/log/reading", vec![("glucose", "120")]),
        ("/log/meal", vec![("carbs", "40"), ("slot", "lunch")]),
        ("/signout", vec![]),
    ];
    for (path, fields) in &forms {
        // No token, a wrong token.
        let p = b.post(path, fields).await;
        assert_eq!(p.status, StatusCode::FORBIDDEN, "{path} without csrf");
        let mut f = fields.clone();
        f.push(("csrf", "0123"));
        assert_eq!(
            b.post(path, &f).await.status,
            StatusCode::FORBIDDEN,
            "{path}"
        );
        // The right token from another origin, or with no origin at all.
        let mut f = fields.clone();
        f.push(("csrf", &csrf));
        b.origin = Some("http://evil.test");
        assert_eq!(
            b.post(path, &f).await.status,
            StatusCode::FORBIDDEN,
            "{path}"
        );
        b.origin = None;
        assert_eq!(
            b.post(path, &f).await.status,
            StatusCode::FORBIDDEN,
            "{path}"
        );
        b.origin = Some(ORIGIN);
    }
    assert_eq!(app_events(&svc, a), 0);
    assert_eq!(b.get("/").await.status, StatusCode::OK, "still signed in");
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/reading",
            &[("glucose", "120"), ("csrf", &csrf), ("submission", &key)],
        )
        .await;
    assert_eq!(
        (p.status, p.location()),
        (StatusCode::SEE_OTHER, "/log?saved=reading")
    );
    assert_eq!(app_events(&svc, a), 1);
}

/// The CSRF token is the session's: the person's token from their other
/// browser, another person's or the clinic's, sent with this session's
/// cookie, is refused (403) and nothing is stored; each session's own
/// goes through.
#[tokio::test]
async fn a_csrf_token_of_another_session_is_refused() {
    let svc = Svc::new();
    let a = svc.person("ana").await;
    let o = svc.person("otto").await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(a as i64)).await;
    let (_, same_person) = signed_in(&svc, Role::Person(a as i64)).await;
    let (_, other_person) = signed_in(&svc, Role::Person(o as i64)).await;
    let (_, clinic) = signed_in(&svc, Role::Admin).await;
    for token in [&same_person, &other_person, &clinic] {
        assert_ne!(token, &csrf);
        let key = b.get("/log").await.hidden("submission");
        let p = b
            .post(
                "/log/reading",
                &[("glucose", "120"), ("csrf", token), ("submission", &key)],
            )
            .await;
        assert_eq!(p.status, StatusCode::FORBIDDEN, "{}", p.html);
    }
    assert_eq!(app_events(&svc, a), 0);
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/reading",
            &[("glucose", "120"), ("csrf", &csrf), ("submission", &key)],
        )
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    assert_eq!(app_events(&svc, a), 1);
}

#[tokio::test]
async fn a_hostile_name_is_inert_on_every_page_that_shows_it() {
    let svc = Svc::new();
    let id = svc
        .person_with(json!({
            "name": HOSTILE, "tz": "UTC", "mode": "smbg", "first_day": "2026-01-01",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    // (No check for "49": the pages' random CSRF tokens may hold it; the
    // escaped name with its literal `{{ 7*7 }}` is the check.)
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    for path in ["/", "/log", "/glucose", "/history"] {
        let p = b.get(path).await;
        assert_eq!(p.status, StatusCode::OK, "{path}");
        assert!(!p.html.contains("<script"), "{path}: {}", p.html);
        assert!(p.html.contains(INERT), "{path}: {}", p.html);
    }
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    for path in ["/clinic".to_string(), format!("/clinic/persons/{id}")] {
        let p = admin.get(&path).await;
        assert_eq!(p.status, StatusCode::OK, "{path}");
        assert!(!p.html.contains("<script"), "{path}: {}", p.html);
        assert!(p.html.contains(INERT), "{path}: {}", p.html);
    }
}

/// Names a person's devices write into their exports (a Nightscout
/// profile's name, the profile a Profile Switch names, the uploader's
/// `enteredBy`) and their clinic's import reads: inert on the import's
/// result, the clinic's person page, every page of the person and both
/// reports.
#[tokio::test]
async fn hostile_names_in_an_imported_export_are_inert_on_every_page_and_report() {
    const PROFILE: &str = "<img src=x onerror=alert(2)>";
    const SWITCHED: &str = "<script>alert(3)</script>";
    let svc = Svc::new();
    let id = svc
        .person_with(json!({
            "name": "ana", "tz": "UTC", "mode": "cgm",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    let entries = std::fs::read(cgm_entries(&svc, "2026-11-02T00:00:00Z", 3)).unwrap();
    let at = |day: i64, hhmm: &str| format!("2026-11-0{}T{hhmm}:00.000Z", 2 + day);
    let mut treatments = vec![json!({"_id": "sw", "eventType": "Profile Switch",
        "profile": SWITCHED, "duration": 0, "created_at": at(1, "10:00"), "enteredBy": HOSTILE})];
    for day in 0..3 {
        for (k, (hhmm, carbs)) in [("07:30", 40), ("12:30", 60), ("19:00", 70)]
            .iter()
            .enumerate()
        {
            treatments.push(
                json!({"_id": format!("m{day}{k}"), "eventType": "Meal Bolus",
                "carbs": carbs, "insulin": f64::from(*carbs) / 10.0,
                "created_at": at(day, hhmm), "enteredBy": HOSTILE}),
            );
        }
    }
    let profile = profile_store_named(PROFILE);
    let treatments = serde_json::to_vec(&treatments).unwrap();
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let p = import_adopting(&mut admin, id, &csrf, &entries, &treatments, &profile).await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    // The import names the profiles (so the test can fail), escaped.
    let switched = "&lt;script&gt;alert(3)&lt;&#x2f;script&gt;";
    assert!(p.html.contains(switched), "{}", p.html);
    let raw = |html: &str| {
        ["<script", "<img"]
            .into_iter()
            .filter(|r| html.contains(r))
            .collect::<Vec<_>>()
    };
    assert_eq!(raw(&p.html), Vec::<&str>::new(), "{}", p.html);
    for path in [
        format!("/clinic/persons/{id}"),
        format!("/clinic/persons/{id}/report"),
    ] {
        let p = admin.get(&path).await;
        assert_eq!(p.status, StatusCode::OK, "{path}");
        assert_eq!(raw(&p.html), Vec::<&str>::new(), "{path}: {}", p.html);
    }
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    for path in ["/", "/log", "/glucose", "/history", "/report"] {
        let p = b.get(path).await;
        assert_eq!(p.status, StatusCode::OK, "{path}");
        assert_eq!(raw(&p.html), Vec::<&str>::new(), "{path}: {}", p.html);
    }
    // A person created from that profile: the page the form lands on.
    let f = [
        ("csrf", csrf.as_str()),
        ("name", "bo"),
        ("tz", "UTC"),
        ("unit", "mg/dL"),
        ("mode", "cgm"),
    ];
    let p = admin
        .post_multipart(
            "/clinic/persons",
            &f,
            &[("profile", "profile.json", &profile)],
        )
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let p = admin.get(p.location()).await;
    assert_eq!(p.status, StatusCode::OK);
    assert_eq!(raw(&p.html), Vec::<&str>::new(), "{}", p.html);
}

/// A CGM person in UTC whose day 1 was `days` days before today, with the
/// first week of data posted by their app through /v1 (no data rule).
async fn person_past_first_week(svc: &Svc, name: &str, days: i64) -> (u64, String) {
    let today = jiff::Timestamp::now()
        .to_zoned(jiff::tz::TimeZone::UTC)
        .date();
    let first = today.checked_sub(jiff::Span::new().days(days)).unwrap();
    let id = svc
        .person_with(json!({
            "name": name, "tz": "UTC", "mode": "cgm", "first_day": first.to_string(),
            "continuous_values": true,
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]},
            "min_data": {"cgm_coverage": 0.0, "cgm_period_min": 5, "smbg_per_day": 0, "smbg_per_meal": 0}
        }))
        .await;
    let (_, token) = svc.token(id).await;
    let day0 = first.to_zoned(jiff::tz::TimeZone::UTC).unwrap().timestamp();
    let at = |m: i64| (day0 + jiff::SignedDuration::from_mins(m)).to_string();
    let mut events: Vec<Value> = Vec::new();
    let mut seq = 0u64;
    let mut push = |t: i64, e: Value, events: &mut Vec<Value>| {
        seq += 1;
        events.push(json!({"seq": seq, "at": at(t), "event": e}));
    };
    let meals = [
        (7 * 60 + 30, "breakfast", 50.0),
        (12 * 60 + 30, "lunch", 70.0),
        (19 * 60, "dinner", 80.0),
    ];
    for day in 0..days {
        for m in (0..1440).step_by(5) {
            let t = day * 1440 + m;
            let mut g = 130.0 + 25.0 * ((t as f64) / 300.0).sin();
            for &(mt, _, carbs) in &meals {
                let since = (m - mt) as f64;
                if since >= 0.0 {
                    g += carbs * (since / 60.0) * (-since / 60.0).exp() * 6.0;
                }
            }
            push(t, json!({"type": "cgm", "mg_dl": g}), &mut events);
            if m == 0 && day > 0 {
                push(t, json!({"type": "day_closed"}), &mut events);
            }
            for &(mt, slot, carbs) in &meals {
                if m == mt {
                    push(
                        t,
                        json!({"type": "meal", "carbs_g": carbs, "slot": slot}),
                        &mut events,
                    );
                    push(
                        t,
                        json!({"type": "bolus", "units": carbs / 10.0}),
                        &mut events,
                    );
                }
            }
        }
    }
    // The day of today's first minute closed, as the app does at midnight.
    push(days * 1440, json!({"type": "day_closed"}), &mut events);
    let _ = ev;
    for chunk in events.chunks(4000) {
        let r = svc
            .call(
                Method::POST,
                &format!("/v1/persons/{id}/events"),
                Some(&token),
                Some(&json!({"events": chunk})),
            )
            .await;
        assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    }
    (id, token)
}

/// The `suggestion_id` of the open answer form in a section.
fn open_sid(section: &str) -> Option<String> {
    let pat = "name=\"suggestion_id\" value=\"";
    let i = section.find(pat)? + pat.len();
    let j = section[i..].find('"')?;
    Some(section[i..i + j].to_string())
}

#[tokio::test]
async fn a_person_logs_a_reading_and_a_meal_and_answers_on_the_pages() {
    let svc = Svc::new();
    let (id, token) = person_past_first_week(&svc, "ana", 9).await;
    let r = svc
        .call(
            Method::PUT,
            &format!("/v1/persons/{id}/bounds"),
            Some(&svc.admin),
            Some(&json!({"bounds": {"basal": {"min": 0.5, "max": 2.0}}})),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let before = app_events(&svc, id);
    let today = b.get("/").await;
    assert!(!today.html.contains("id=\"first-week\""), "{}", today.html);
    let basal_sid = open_sid(today.section("<section id=\"setting-basal\"", "section"))
        .expect("an open basal suggestion after the day closed");
    // A meter reading, then a main meal: its carb ratio and bolus.
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/reading",
            &[("csrf", &csrf), ("glucose", "142"), ("submission", &key)],
        )
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/meal",
            &[
                ("csrf", &csrf),
                ("carbs", "60"),
                ("slot", "lunch"),
                ("submission", &key),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    assert!(p.location().starts_with("/log?meal="), "{}", p.location());
    let log = b.get(p.location()).await;
    let advice = log
        .section("<section id=\"meal-advice\"", "section")
        .to_string();
    assert!(advice.contains("60 g at"), "{advice}");
    let meal_sid = open_sid(&advice).expect("the lunch suggestion to answer");
    let key = log.hidden("submission");
    // The events went through the one event path with the next seqs.
    assert_eq!(app_events(&svc, id), before + 2);
    let sync = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/sync"),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(sync.json["last_seq"].as_u64().unwrap() as i64, before + 2);
    // Accept the carb ratio.
    let p = b
        .post(
            "/answer",
            &[
                ("csrf", &csrf),
                ("suggestion_id", &meal_sid),
                ("action", "accept"),
                ("submission", &key),
            ],
        )
        .await;
    assert_eq!(
        (p.status, p.location()),
        (
            StatusCode::SEE_OTHER,
            format!("/?answered={meal_sid}").as_str()
        ),
        "{}",
        p.html
    );
    let today = b.get(p.location()).await;
    // The acknowledgement says what the store recorded, under the notice.
    let status = unescaped(today.section("<div id=\"status\"", "div"));
    assert!(
        status.contains("Saved: you accepted the suggested lunch carb ratio; ")
            && status.contains(" g/U is in force."),
        "{status}"
    );
    assert!(today
        .html
        .contains("research software, not a medical device"));
    let key = today.hidden("submission");
    // A status link made up (or kept from before, or of an older
    // version's form) says nothing: the basal suggestion is still open.
    for q in [
        format!("/?answered={basal_sid}"),
        "/?answered=accept".into(),
    ] {
        let p = b.get(&q).await;
        assert_eq!(
            p.section("<div id=\"status\"", "div"),
            "<div id=\"status\" role=\"status\">",
            "{q}"
        );
    }
    // An own basal value outside the bounds: refused beside the field.
    let p = b
        .post(
            "/answer",
            &[
                ("csrf", &csrf),
                ("suggestion_id", &basal_sid),
                ("action", "override"),
                ("value", "3.5"),
                ("submission", &key),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    let err_id = format!("value-error-{basal_sid}");
    assert!(
        p.html
            .contains(&format!("<p class=\"field-error\" id=\"{err_id}\">")),
        "{}",
        p.html
    );
    assert!(p.html.contains(&format!("aria-describedby=\"{err_id}\"")));
    assert!(p.html.contains("value=\"3.5\""), "the typed value is kept");
    // Inside: accepted.
    let p = b
        .post(
            "/answer",
            &[
                ("csrf", &csrf),
                ("suggestion_id", &basal_sid),
                ("action", "override"),
                ("value", "1.1"),
                ("submission", &key),
            ],
        )
        .await;
    assert_eq!(
        (p.status, p.location()),
        (
            StatusCode::SEE_OTHER,
            format!("/?answered={basal_sid}").as_str()
        ),
        "{}",
        p.html
    );
    let today = b.get(p.location()).await;
    assert!(
        unescaped(today.section("<div id=\"status\"", "div"))
            .contains("Saved: you chose your own basal rate; 1.10 U/h is in force."),
        "{}",
        today.html
    );
    // The store's history holds exactly those two answers.
    let h = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/history?limit=1000"),
            Some(&token),
            None,
        )
        .await;
    let answered: Vec<(u64, String)> = h.json["suggestions"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| ["accepted", "rejected", "overridden"].contains(&s["status"].as_str().unwrap()))
        .map(|s| {
            (
                s["id"].as_u64().unwrap(),
                s["status"].as_str().unwrap().to_string(),
            )
        })
        .collect();
    assert_eq!(
        answered,
        vec![
            (basal_sid.parse().unwrap(), "overridden".to_string()),
            (meal_sid.parse().unwrap(), "accepted".to_string()),
        ],
        "{}",
        h.text
    );
}

/// An own value off the pump's step, past what pumps can program or
/// outside the clinician's bounds: Today again (422) with the reason
/// beside the field, the typed value kept and nothing stored.
#[tokio::test]
async fn an_own_value_off_the_step_past_the_limits_or_the_bounds_is_refused_beside_it() {
    let svc = Svc::new();
    let (id, token) = person_past_first_week(&svc, "ana", 9).await;
    let (mut admin, acsrf) = signed_in(&svc, Role::Admin).await;
    let path = format!("/clinic/persons/{id}");
    for (form, fields) in [
        ("steps", [("basal_step", "0.05"), ("cr_step", "0.1")]),
        ("bounds", [("basal_min", "0.5"), ("basal_max", "2")]),
    ] {
        let mut f = vec![("csrf", acsrf.as_str())];
        f.extend(fields);
        let p = admin.post(&format!("{path}/{form}"), &f).await;
        assert_eq!(p.status, StatusCode::SEE_OTHER, "{form}: {}", p.html);
    }
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let today = b.get("/").await;
    let sid = open_sid(today.section("<section id=\"setting-basal\"", "section"))
        .expect("an open basal suggestion");
    for (typed, why) in [
        ("1.07", "1.07 U/h is not on the pump's basal step (0.05 U/h): the nearest values the pump can be set to are 1.05 and 1.1 U/h"),
        ("40", "basal rate (U/h) must be between 0.025 and 35 U/h (the range pumps can program), got 40"),
        ("2.5", "2.5 U/h is outside the clinician's bounds 0.5-2"),
    ] {
        let key = b.get("/").await.hidden("submission");
        let p = b
            .post(
                "/answer",
                &[
                    ("csrf", &csrf),
                    ("suggestion_id", &sid),
                    ("action", "override"),
                    ("value", typed),
                    ("submission", &key),
                ],
            )
            .await;
        assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{typed}: {}", p.html);
        let card = p.section("<section id=\"setting-basal\"", "section");
        let start = format!("<p class=\"field-error\" id=\"value-error-{sid}\">");
        let i = card
            .find(&start)
            .unwrap_or_else(|| panic!("{typed}: no error beside the field: {card}"));
        let error = &card[i..i + card[i..].find("</p>").unwrap()];
        assert!(unescaped(error).contains(why), "{typed}: {error}");
        assert!(card.contains(&format!("value=\"{typed}\"")), "{typed} kept: {card}");
        assert!(p.html.contains("research software, not a medical device"));
    }
    let h = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/history?limit=1000"),
            Some(&token),
            None,
        )
        .await;
    let answered = h.json["suggestions"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| ["accepted", "rejected", "overridden"].contains(&s["status"].as_str().unwrap()))
        .count();
    assert_eq!(answered, 0, "{}", h.text);
}

/// The Glucose page shows the range asked for or refuses the query (400
/// naming `range`): a range it does not have, a second `range` or another
/// parameter were answered with the last 24 hours, as if asked.
#[tokio::test]
async fn the_glucose_page_refuses_a_range_it_does_not_have() {
    let svc = Svc::new();
    let id = svc.person("gil").await;
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    for path in ["/glucose", "/glucose?range=24h", "/glucose?range=14d"] {
        assert_eq!(b.get(path).await.status, StatusCode::OK, "{path}");
    }
    for path in [
        "/glucose?range=1000000d",
        "/glucose?range=14d&range=24h",
        "/glucose?days=1000000",
        "/glucose?range=24h&x=1",
    ] {
        let p = b.get(path).await;
        assert_eq!(p.status, StatusCode::BAD_REQUEST, "{path}: {}", p.html);
        assert!(
            p.html.contains("expected range=24h or range=14d"),
            "{path}: {}",
            p.html
        );
    }
}

#[tokio::test]
async fn glucose_history_and_the_report_show_the_persons_own_data() {
    let svc = Svc::new();
    let (id, _) = person_past_first_week(&svc, "bea", 8).await;
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    // Readings every 5 minutes up to today's midnight: the last 24 hours
    // hold a day of them, drawn as one line (no gap) in mg/dL.
    for path in ["/glucose", "/glucose?range=24h", "/glucose?range=14d"] {
        let p = b.get(path).await;
        assert_eq!(p.status, StatusCode::OK, "{path}");
        assert!(
            p.html.contains("<svg id=\"glucose-chart\" role=\"img\""),
            "{path}: {}",
            p.html
        );
        assert_eq!(p.html.matches("<path class=\"cgm\"").count(), 1, "{path}");
        assert!(
            p.html.contains("mg&#x2f;dL") || p.html.contains("mg/dL"),
            "{path}"
        );
        assert!(p.html.contains("id=\"glucose-summary\""), "{path}");
        assert!(p.html.contains("<rect class=\"band\""), "{path}");
    }
    let day = b.get("/glucose").await.html;
    let two_weeks = b.get("/glucose?range=14d").await.html;
    assert!(day.contains("aria-current=\"page\">Last 24 hours"));
    assert!(two_weeks.contains("aria-current=\"page\">Last 14 days"));
    // A day of readings against eight days.
    let points = |h: &str| h.matches(" L").count();
    assert!(
        points(&two_weeks) > 6 * points(&day),
        "{} {}",
        points(&two_weeks),
        points(&day)
    );

    let h = b.get("/history").await;
    assert_eq!(h.status, StatusCode::OK);
    assert!(h.html.contains("<table id=\"history\">"), "{}", h.html);
    assert!(h.html.contains("<a id=\"report\" href=\"/report\">"));
    let views = {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        store.history("bea").unwrap()
    };
    assert!(!views.is_empty());
    assert_eq!(
        h.html.matches("<tr><th scope=\"row\">").count(),
        views.len()
    );

    let r = b.get("/report").await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.html);
    let csp = r.headers["content-security-policy"]
        .to_str()
        .unwrap()
        .to_string();
    assert!(
        csp.starts_with("default-src 'none'; style-src 'sha256-"),
        "{csp}"
    );
    assert!(!csp.contains("unsafe"), "{csp}");
    assert!(r.html.contains("research software"), "{}", r.html);
    assert!(r.html.contains("bea"));
    // The clinic opens the same report; a person cannot reach the clinic's.
    assert_eq!(
        b.get(&format!("/clinic/persons/{id}/report")).await.status,
        StatusCode::FORBIDDEN
    );
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    let c = admin.get(&format!("/clinic/persons/{id}/report")).await;
    assert_eq!(c.status, StatusCode::OK);
    // Each with the way back to where its reader came from (a served
    // report had none), the rest the same page.
    let back = |html: &str| -> String {
        let nav = html
            .split("<nav class=\"back\" aria-label=\"App\">")
            .nth(1)
            .unwrap_or_else(|| panic!("no way back: {html}"));
        nav[..nav.find("</nav>").unwrap()].to_string()
    };
    assert_eq!(back(&r.html), "<a href=\"/\">Back to Today</a>");
    assert!(
        back(&c.html).starts_with(&format!(
            "<a href=\"/clinic/persons/{id}\">Back to the person"
        )),
        "{}",
        back(&c.html)
    );
    let without = |html: &str| html.replace(&back(html), "");
    assert_eq!(without(&c.html), without(&r.html));
}

#[tokio::test]
async fn a_person_without_data_sees_an_empty_chart_and_no_report_yet() {
    let svc = Svc::new();
    let id = svc.person("cid").await;
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    let g = b.get("/glucose").await;
    assert_eq!(g.status, StatusCode::OK);
    assert!(g.html.contains("id=\"glucose-empty\""), "{}", g.html);
    assert!(!g.html.contains("<svg"));
    let h = b.get("/history").await;
    assert!(h.html.contains("id=\"history-empty\""), "{}", h.html);
    let r = b.get("/report").await;
    assert_eq!(r.status, StatusCode::OK);
    assert!(r.html.contains("nothing to report yet"), "{}", r.html);
    // Today counts the first week's days done, never a "day 0".
    let t = b.get("/").await;
    assert!(
        t.html.contains("0 of 7 days done, 7 to go") && !t.html.contains("day 0"),
        "{}",
        t.html
    );
}

/// What a link's last successful sync could not look for (its
/// warnings: a site's own `_id` may be in them) is shown where the clinic
/// sees the link, escaped, and in the API's link, until a sync without.
#[tokio::test]
async fn the_link_shows_what_its_last_sync_could_not_look_for_escaped() {
    let svc = Svc::new();
    let a = svc.person("ana").await;
    let warning = "late uploads (dated before the window read again) cannot be looked for: \
                   the server served _id <b>x</b> outside the asked bound (it ignores find[_id])";
    let at: jiff::Timestamp = "2026-12-01T08:00:00Z".parse().unwrap();
    {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        store
            .set_link(
                "ana",
                "https://ana.example.org",
                &abba_store::link::Credential::Token("ana-0123456789abcdef".into()),
                false,
            )
            .unwrap();
        store
            .record_success("ana", at, &[warning.to_string()])
            .unwrap();
    }
    let (_, token) = svc.token(a).await;
    let advice = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{a}/advice"),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(advice.status, StatusCode::OK, "{}", advice.text);
    assert_eq!(advice.json["nightscout"]["warnings"], json!([warning]));
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    let escaped = "_id &lt;b&gt;x&lt;&#x2f;b&gt; outside";
    let list = admin.get("/clinic").await;
    let page = admin.get(&format!("/clinic/persons/{a}")).await;
    for html in [&list.html, &page.html] {
        assert!(html.contains("not looked for by the last sync"), "{html}");
        assert!(html.contains(escaped), "{html}");
        assert!(!html.contains("<b>x"), "{html}");
    }
    // A failed sync leaves them (what was imported is as it was); a sync
    // without any takes them away.
    {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        store.record_sync("ana", at, Some("HTTP 500")).unwrap();
        assert_eq!(store.link("ana").unwrap().unwrap().warnings, [warning]);
        store.record_sync("ana", at, None).unwrap();
    }
    let advice = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{a}/advice"),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(advice.json["nightscout"]["warnings"], json!([]));
    let list = admin.get("/clinic").await;
    assert!(!list.html.contains("not looked for"), "{}", list.html);
}

#[tokio::test]
async fn the_clinic_shows_each_persons_nightscout_link_and_its_last_sync_never_its_credential() {
    let svc = Svc::new();
    let a = svc
        .person_with(json!({
            "name": "ana", "tz": "Europe/Zurich", "mode": "cgm", "first_day": "2026-01-01",
            "continuous_values": true,
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    let _ = svc.person("ben").await;
    let secret = "ana-0123456789abcdef";
    {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        store
            .set_link(
                "ana",
                "https://ana.example.org",
                &abba_store::link::Credential::Token(secret.into()),
                false,
            )
            .unwrap();
        let at: jiff::Timestamp = "2026-12-01T08:00:00Z".parse().unwrap();
        store
            .record_sync("ana", at, Some("401 Unauthorized: the token was refused"))
            .unwrap();
    }
    let (mut admin, admin_csrf) = signed_in(&svc, Role::Admin).await;
    let list = admin.get("/clinic").await;
    assert_eq!(list.status, StatusCode::OK);
    let row = |name: &str| {
        let start = list
            .html
            .find(&format!("<tr data-person=\"{name}\""))
            .unwrap();
        let rest = &list.html[start..];
        rest[..rest.find("</tr>").unwrap()].to_string()
    };
    let ana = row("ana");
    assert!(ana.contains("last sync failed: 401 Unauthorized"), "{ana}");
    assert!(!row("ben").contains("linked"), "ben has no link");
    let page = admin.get(&format!("/clinic/persons/{a}")).await;
    let ns = page.html.split("<p id=\"nightscout\">").nth(1).unwrap();
    let ns = &ns[..ns.find("</p>").unwrap()];
    assert!(
        ns.contains("https:&#x2f;&#x2f;ana.example.org") || ns.contains("https://ana.example.org"),
        "{ns}"
    );
    // On the person's clock, the zone named (never a UTC instant).
    assert!(
        ns.replace("&#x2f;", "/")
            .contains("last sync 2026-12-01 09:00 (Europe/Zurich)")
            && ns.contains("failed: 401"),
        "{ns}"
    );
    // A session and a token are listed on the person's clock too.
    let _person = signed_in(&svc, Role::Person(a as i64)).await;
    let f = [("csrf", admin_csrf.as_str())];
    let issued = admin.post(&format!("/clinic/persons/{a}/tokens"), &f).await;
    assert_eq!(issued.status, StatusCode::OK, "{}", issued.html);
    let page = admin.get(&format!("/clinic/persons/{a}")).await;
    assert!(
        page.html.contains("signed in ") && page.html.contains("token "),
        "{}",
        page.html
    );
    assert_eq!(utc_instant_in(&page.html), None, "{}", page.html);
    for html in [&list.html, &page.html] {
        assert!(!html.contains(secret), "the credential is never shown");
    }
    // After a successful sync the error is gone.
    {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        let at: jiff::Timestamp = "2026-12-01T08:05:00Z".parse().unwrap();
        store.record_sync("ana", at, None).unwrap();
    }
    let list = admin.get("/clinic").await;
    assert!(
        list.html
            .replace("&#x2f;", "/")
            .contains("linked; last sync 2026-12-01 09:05 (Europe/Zurich)"),
        "{}",
        list.html
    );
    assert_eq!(utc_instant_in(&list.html), None, "{}", list.html);
    assert!(!list.html.contains("failed"));
}

#[tokio::test]
async fn the_clinics_change_of_therapy_goes_in_force_and_a_refused_value_stays_beside_its_field() {
    let svc = Svc::new();
    let a = svc.person("ana").await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let path = format!("/clinic/persons/{a}/therapy");
    let basal_in_force = |svc: &Svc| {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        use abba_advisor::Advisor as _;
        store.live(a as i64).unwrap().advisor.settings().basal.0
    };
    // Refused: out of the plausibility limits, beside the basal field.
    let p = admin.post(&path, &[("csrf", &csrf), ("basal", "99")]).await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(p.html.contains("id=\"basal-error\""), "{}", p.html);
    assert!(p.html.contains("value=\"99\""), "the typed value is kept");
    // Refused: two ratios where three are needed, beside the ratios.
    let p = admin
        .post(&path, &[("csrf", &csrf), ("carb_ratios", "10,12")])
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(p.html.contains("id=\"carb_ratios-error\""), "{}", p.html);
    assert_eq!(basal_in_force(&svc), 1.0, "nothing refused is in force");
    // Accepted: in force at once, for the live advisor too.
    let p = admin
        .post(&path, &[("csrf", &csrf), ("basal", "1.2")])
        .await;
    assert_eq!(
        (p.status, p.location()),
        (
            StatusCode::SEE_OTHER,
            format!("/clinic/persons/{a}?done=therapy").as_str()
        )
    );
    assert_eq!(basal_in_force(&svc), 1.2);
    let page = admin.get(p.location()).await;
    assert!(
        page.html.contains("Saved: the change of therapy."),
        "{}",
        page.html
    );
}

/// A real CareLink export (Paradigm Veo 754, HUPA-UCM, CC BY 4.0; see
/// crates/io/tests/data/PROVENANCE.md) whose bolus wizard counts in
/// exchanges: 28 exchanges of carbohydrate in 10 wizard rows.
const EXCHANGES_EXPORT: &str = concat!(
    env!("CARGO_MANIFEST_DIR"),
    "/../io/tests/data/carelink_veo754_hupa0001p.csv"
);

/// The carbohydrate records in a person's log, in grams.
fn logged_carbs(svc: &Svc, name: &str) -> Vec<f64> {
    let store = abba_service::open_store(&svc.db).unwrap();
    store
        .records(name)
        .unwrap()
        .into_iter()
        .filter_map(|r| match r.kind {
            abba_io::RecordKind::Carbs { grams } => Some(grams.0),
            _ => None,
        })
        .collect()
}

/// Posts [`EXCHANGES_EXPORT`]'s bytes to a person's import form (`path`),
/// with `grams` per exchange when given.
async fn import_export(
    b: &mut Browser<'_>,
    path: &str,
    csrf: &str,
    grams: Option<&str>,
    export: &[u8],
) -> Page {
    let mut fields = vec![("csrf", csrf)];
    if let Some(g) = grams {
        fields.push(("grams_per_exchange", g));
    }
    b.post_multipart(
        path,
        &fields,
        &[("files", "carelink_veo754_hupa0001p.csv", export)],
    )
    .await
}

#[tokio::test]
async fn the_clinics_import_reads_exchanges_with_the_grams_given_and_shows_every_note() {
    let svc = Svc::new();
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let export = std::fs::read(EXCHANGES_EXPORT).unwrap();
    let file = "carelink_veo754_hupa0001p.csv";
    // The person from the export's pump profile; the wizard's ratios are
    // in units per exchange, so the form takes grams per exchange too.
    let person = [
        ("csrf", csrf.as_str()),
        ("name", "lucia"),
        ("tz", "Europe/Madrid"),
        ("unit", "mg/dL"),
        ("mode", "cgm"),
        ("carb_ratios", "8,7.5,11"),
    ];
    for bad in ["0.5", "ten"] {
        let mut f = person.to_vec();
        f.push(("grams_per_exchange", bad));
        let p = admin
            .post_multipart("/clinic/persons", &f, &[("profile", file, &export)])
            .await;
        assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
        assert!(
            p.html.contains("id=\"grams_per_exchange-error\""),
            "{}",
            p.html
        );
        assert!(
            p.html.contains(&format!("value=\"{bad}\"")),
            "the typed value is kept"
        );
    }
    let mut f = person.to_vec();
    f.push(("grams_per_exchange", "10"));
    let p = admin
        .post_multipart("/clinic/persons", &f, &[("profile", file, &export)])
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let page_path = p.location().to_string();
    let import = format!("{page_path}/import");

    // A grams-per-exchange out of range is refused beside its field, and
    // nothing is imported.
    let p = import_export(&mut admin, &import, &csrf, Some("40"), &export).await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(
        p.html.contains("id=\"grams_per_exchange-error\""),
        "{}",
        p.html
    );
    assert!(p.html.contains("5 to 25"), "{}", p.html);
    assert!(p.html.contains("value=\"40\""), "the typed value is kept");
    assert!(logged_carbs(&svc, "lucia").is_empty());

    // Without it: the rest imports, and the page says the carbohydrate was
    // not read, and why (the reader's note, as `abba import` prints it).
    let p = import_export(&mut admin, &import, &csrf, None, &export).await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    let result = p.section("<ul id=\"import-result\"", "ul").to_string();
    assert!(result.contains("Imported "), "{result}");
    assert!(
        result.contains("Note: ") && result.contains("BWZ Carb Input (exchanges)"),
        "{result}"
    );
    assert!(p.html.contains("Imported."), "the status says it");
    assert!(logged_carbs(&svc, "lucia").is_empty());

    // With 10 g per exchange: the 28 exchanges come as 280 g, and the
    // records already imported are known, not added twice.
    let p = import_export(&mut admin, &import, &csrf, Some("10"), &export).await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    let result = p.section("<ul id=\"import-result\"", "ul").to_string();
    assert!(result.contains("already known"), "{result}");
    assert!(!result.contains("BWZ Carb Input (exchanges)"), "{result}");
    let carbs = logged_carbs(&svc, "lucia");
    let total: f64 = carbs.iter().sum();
    assert!((total - 280.0).abs() < 1e-9, "{carbs:?}");

    // The same files again: nothing new, said so.
    let p = import_export(&mut admin, &import, &csrf, Some("10"), &export).await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    assert!(p.html.contains("Nothing new"), "{}", p.html);
    assert_eq!(logged_carbs(&svc, "lucia").len(), carbs.len());

    // Without the form's CSRF token: refused, nothing read.
    let p = admin
        .post_multipart(&import, &[("csrf", "0")], &[("files", file, &export)])
        .await;
    assert_eq!(p.status, StatusCode::FORBIDDEN);
}

/// A file that does not tell its date order (a FreeStyle Libre 2 reader's
/// LibreView export of the first days of a month) or the unit of a value:
/// refused beside the files, then imported with the page's date order and
/// unit (`abba import`'s flags); the choice stays selected on a refusal.
#[tokio::test]
async fn the_clinics_import_takes_a_date_order_and_a_unit() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    let path = format!("/clinic/persons/{id}");
    let page = admin.get(&path).await;
    assert_eq!(page.status, StatusCode::OK);
    assert!(
        page.html
            .contains("<select id=\"date_order\" name=\"date_order\">"),
        "{}",
        page.html
    );
    let csrf = page.hidden("csrf");
    let mut csv =
        String::from("Glucose Data,Generated on,07-11-2026 10:00 UTC,Generated by,Someone\n");
    csv.push_str("Device,Serial Number,Device Timestamp,Record Type,Historic Glucose mmol/L,Scan Glucose mmol/L,Non-numeric Rapid-Acting Insulin,Rapid-Acting Insulin (units),Non-numeric Food,Carbohydrates (grams),Carbohydrates (servings),Non-numeric Long-Acting Insulin,Long-Acting Insulin Value (units),Notes,Strip Glucose mmol/L,Ketone mmol/L,Meal Insulin (units),Correction Insulin (units),User Change Insulin (units)\n");
    for day in 2..=5 {
        for q in 0..96 {
            csv.push_str(&format!(
                "FreeStyle Libre 2,A1B2C3D4-0000-0000-0000-000000000001,{day:02}-11-2026 {:02}:{:02},0,6.{},,,,,,,,,,,,,,\n",
                q / 4,
                (q % 4) * 15,
                q % 10
            ));
        }
    }
    let import = format!("{path}/import");
    let files = [("files", "libre2.csv", csv.as_bytes())];
    let p = admin
        .post_multipart(&import, &[("csrf", &csrf), ("units", "mmol/L")], &files)
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    let error = p
        .section("<p class=\"field-error\" id=\"files-error\"", "p")
        .to_string();
    assert!(error.contains("day-first or month-first"), "{error}");
    let units = p.section("<select id=\"units\"", "select").to_string();
    assert!(
        units.contains("L\" selected>mmol"),
        "the unit stays chosen: {units}"
    );
    let p = admin
        .post_multipart(
            &import,
            &[("csrf", &csrf), ("date_order", "sideways")],
            &files,
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(p.html.contains("id=\"date_order-error\""), "{}", p.html);
    let p = admin
        .post_multipart(
            &import,
            &[("csrf", &csrf), ("date_order", "day-first")],
            &files,
        )
        .await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    assert!(p.html.contains("Imported 384 new records"), "{}", p.html);
}

/// An import while another writer holds the store: the service's 503 (retry
/// later), not an error beside the files, and nothing imported.
#[tokio::test]
async fn the_clinics_import_on_a_busy_store_is_a_503_not_a_field_error() {
    let mut svc = Svc::new();
    if abba_store::testing::is_postgres(&svc.db) {
        eprintln!(
            "the_clinics_import_on_a_busy_store_is_a_503_not_a_field_error: SQLite's write lock"
        );
        return;
    }
    let id = svc.person("ana").await;
    let state = abba_service::AppState::open(
        &svc.db,
        abba_service::StoreSettings {
            busy_timeout: std::time::Duration::from_millis(300),
            ..abba_service::StoreSettings::default()
        },
    )
    .unwrap();
    svc.router = abba_service::router(state);
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    let page = admin.get(&format!("/clinic/persons/{id}")).await;
    assert_eq!(page.status, StatusCode::OK);
    let csrf = page.hidden("csrf");
    // A day of Nightscout CGM (no profile: nothing for the settings check).
    let day0: jiff::Timestamp = "2026-11-02T00:00:00Z".parse().unwrap();
    let entries: Vec<Value> = (0..288)
        .map(|k| {
            let t = day0 + jiff::SignedDuration::from_mins(5 * k);
            json!({"_id": format!("e{k}"), "type": "sgv", "sgv": 120,
                   "date": t.as_millisecond(), "dateString": t.to_string()})
        })
        .collect();
    let bytes = serde_json::to_vec(&entries).unwrap();
    let path = format!("/clinic/persons/{id}/import");
    // The same request both times: refused while the writer holds the
    // store, then accepted.
    let (fields, files) = (
        [("csrf", csrf.as_str())],
        [("files", "entries.json", bytes.as_slice())],
    );
    let other = rusqlite::Connection::open(&svc.db).unwrap();
    other.execute_batch("BEGIN IMMEDIATE").unwrap();
    let p = admin.post_multipart(&path, &fields, &files).await;
    assert_eq!(p.status, StatusCode::SERVICE_UNAVAILABLE, "{}", p.html);
    assert!(!p.html.contains("id=\"files-error\""), "{}", p.html);
    other.execute_batch("ROLLBACK").unwrap();
    let store = abba_service::open_store(&svc.db).unwrap();
    assert!(store.records("ana").unwrap().is_empty(), "nothing imported");
    drop(store);
    // The writer gone, the same import goes through.
    let p = admin.post_multipart(&path, &fields, &files).await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    assert!(p.html.contains("Imported 288 new records"), "{}", p.html);
}

/// A Nightscout export (profile, entries, treatments) from
/// crates/io/tests/data: its profile's basal schedule (0.8 / 0.95 / 0.8
/// U/h) differs from the 1.0 U/h the test person is created with.
fn nightscout_export() -> Vec<(&'static str, Vec<u8>)> {
    ["profile", "entries", "treatments"]
        .into_iter()
        .map(|kind| {
            let file = format!(
                "{}/../io/tests/data/nightscout_{kind}_synthetic.json",
                env!("CARGO_MANIFEST_DIR")
            );
            (kind, std::fs::read(file).unwrap())
        })
        .collect()
}

/// Posts `parts` to person `id`'s import form with `choice` as its
/// `profile_choice`.
async fn import_choosing(
    b: &mut Browser<'_>,
    id: u64,
    csrf: &str,
    choice: &str,
    parts: &[(&str, &str, &[u8])],
) -> Page {
    b.post_multipart(
        &format!("/clinic/persons/{id}/import"),
        &[("csrf", csrf), ("profile_choice", choice)],
        parts,
    )
    .await
}

/// A Nightscout profile store whose one profile, named `name` (0.9 U/h,
/// 10 g/U, ISF 50 mg/dL/U), is the default.
fn profile_store_named(name: &str) -> Vec<u8> {
    let seg = |v: f64| json!([{"time": "00:00", "timeAsSeconds": 0, "value": v}]);
    let mut store = serde_json::Map::new();
    store.insert(
        name.to_string(),
        json!({"basal": seg(0.9), "carbratio": seg(10.0), "sens": seg(50.0),
            "target_low": seg(100.0), "target_high": seg(120.0), "timezone": "UTC",
            "units": "mg/dl", "dia": 5}),
    );
    let profile = json!([{"_id": "p1", "defaultProfile": name,
        "startDate": "2026-11-01T00:00:00.000Z", "mills": 1_761_955_200_000_i64, "units": "mg/dl",
        "store": store}]);
    serde_json::to_vec(&profile).unwrap()
}

/// Imports Nightscout's three files to person `id`, adopting the profile.
async fn import_adopting(
    b: &mut Browser<'_>,
    id: u64,
    csrf: &str,
    entries: &[u8],
    treatments: &[u8],
    profile: &[u8],
) -> Page {
    import_choosing(
        b,
        id,
        csrf,
        "adopt",
        &[
            ("files", "entries.json", entries),
            ("files", "treatments.json", treatments),
            ("files", "profile.json", profile),
        ],
    )
    .await
}

/// The import form's choice when the export's pump profile differs from
/// the therapy abba holds: stop (the default) shows both values and the
/// page's own choice (not the CLI's flags), nothing imported; adopt puts
/// the profile in force; keep keeps abba's therapy; anything else is
/// refused beside the choice.
#[tokio::test]
async fn the_clinics_import_asks_what_to_do_when_the_pumps_profile_differs() {
    let svc = Svc::new();
    let body = |name: &str| {
        json!({
            "name": name, "tz": "Europe/Zurich", "mode": "cgm",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        })
    };
    let adopt = svc.person_with(body("ada")).await;
    let keep = svc.person_with(body("kim")).await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let files = nightscout_export();
    let named: Vec<(String, Vec<u8>)> = files
        .iter()
        .map(|(k, b)| (format!("{k}.json"), b.clone()))
        .collect();
    let parts: Vec<(&str, &str, &[u8])> = named
        .iter()
        .map(|(n, b)| ("files", n.as_str(), b.as_slice()))
        .collect();
    let import = |id: u64| format!("/clinic/persons/{id}/import");
    let records = |name: &str| {
        abba_service::open_store(&svc.db)
            .unwrap()
            .records(name)
            .unwrap()
            .len()
    };
    let person = |name: &str| {
        abba_service::open_store(&svc.db)
            .unwrap()
            .person(name)
            .unwrap()
    };

    // The page offers the three choices, stop checked.
    let page = admin.get(&format!("/clinic/persons/{adopt}")).await;
    assert_eq!(page.status, StatusCode::OK);
    assert!(
        page.html.contains("given when the person was created"),
        "{}",
        page.html
    );
    let choice = page.section("<fieldset id=\"profile_choice\"", "fieldset");
    for v in ["stop", "adopt", "keep"] {
        assert!(choice.contains(&format!("value=\"{v}\"")), "{choice}");
    }
    assert!(choice.contains("value=\"stop\" checked"), "{choice}");

    // No choice (stop): refused beside the choice with both values.
    let p = admin
        .post_multipart(&import(adopt), &[("csrf", &csrf)], &parts)
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    let err = p.section("<p class=\"field-error\" id=\"profile_choice-error\"", "p");
    assert!(err.contains("differs") && err.contains("0.95"), "{err}");
    assert!(err.contains("(basal 1 U"), "{err}");
    assert!(err.contains("Choose what abba should do"), "{err}");
    assert!(!err.contains("--adopt-profile"), "the page's words: {err}");
    assert!(
        p.html.contains("aria-describedby=\"profile_choice-error\""),
        "the group names its error"
    );
    assert_eq!(records("ada"), 0, "nothing imported");

    // A choice the form does not offer: refused, nothing imported.
    let p = import_choosing(&mut admin, adopt, &csrf, "both", &parts).await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(p.html.contains("id=\"profile_choice-error\""), "{}", p.html);
    assert!(
        p.html.contains("expected stop, adopt or keep"),
        "{}",
        p.html
    );
    assert_eq!(records("ada"), 0, "nothing imported");

    // Adopt: imported, the pump's schedule in force.
    let p = import_choosing(&mut admin, adopt, &csrf, "adopt", &parts).await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    assert!(p.html.contains("id=\"import-result\""), "{}", p.html);
    let s = person("ada").settings;
    let rates: Vec<f64> = s
        .basal_schedule
        .clone()
        .unwrap()
        .iter()
        .map(|r| r.1)
        .collect();
    assert_eq!(rates, [0.8, 0.95, 0.8]);
    assert_eq!(s.therapy_source, abba_store::person::TherapySource::Profile);
    let source = |p: &Page| p.section("<p id=\"therapy-source\"", "p").to_string();
    assert!(
        source(&p).contains("the pump&#x27;s profile"),
        "{}",
        source(&p)
    );

    // Keep: imported, abba's therapy kept.
    let p = import_choosing(&mut admin, keep, &csrf, "keep", &parts).await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    let s = person("kim").settings;
    assert_eq!(s.start.basal.0, 1.0);
    assert!(s.basal_schedule.is_none());
    assert_eq!(s.therapy_source, abba_store::person::TherapySource::Kept);
    assert!(source(&p).contains("kept over the pump"), "{}", source(&p));
    assert!(records("kim") > 0, "imported");
}

/// `days` whole days of CGM every 5 minutes from `start` (UTC), as
/// Nightscout exports them, in the service's folder; the file's path.
fn cgm_entries(svc: &Svc, start: &str, days: i64) -> std::path::PathBuf {
    let day0: jiff::Timestamp = start.parse().unwrap();
    let entries: Vec<Value> = (0..days * 288)
        .map(|k| {
            let t = day0 + jiff::SignedDuration::from_mins(5 * k);
            json!({"_id": format!("e{k}"), "type": "sgv", "sgv": 120 + (k % 30),
                   "date": t.as_millisecond(), "dateString": t.to_string(), "direction": "Flat"})
        })
        .collect();
    let file = svc.dir.path().join("entries.json");
    std::fs::write(&file, serde_json::to_string(&entries).unwrap()).unwrap();
    file
}

#[tokio::test]
async fn today_for_a_person_fed_by_imports_says_what_abba_advise_says() {
    let svc = Svc::new();
    // Day 1 is the first imported reading's day (no first_day given).
    let id = svc
        .person_with(json!({
            "name": "imp", "tz": "UTC", "mode": "cgm",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    // Two whole days of CGM every 5 minutes, as Nightscout exports them.
    let file = cgm_entries(&svc, "2026-11-02T00:00:00Z", 2);
    let advice = {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        store.import_files("imp", &[file], None).unwrap();
        store.advise("imp").unwrap()
    };
    let abba_store::advise::Phase::FirstWeek {
        days_done,
        days_left,
        ..
    } = advice.phase
    else {
        panic!("{:?}", advice.phase)
    };
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    let p = b.get("/").await;
    assert_eq!(p.status, StatusCode::OK);
    let fw = p
        .html
        .split("<p id=\"first-week\" class=\"callout\">")
        .nth(1)
        .unwrap_or_else(|| panic!("{}", p.html));
    let fw = &fw[..fw.find("</p>").unwrap()];
    let want = abba_web::texts::fill(
        abba_web::texts::EN.first_week,
        &[
            ("done", &days_done.to_string()),
            ("left", &days_left.to_string()),
            ("total", &(days_done + days_left).to_string()),
        ],
    );
    assert_eq!(
        fw, want,
        "Today against abba advise ({days_done} done, {days_left} left)"
    );
    // The Log knows this person is fed by imports: nothing to enter there.
    assert!(b.get("/log").await.html.contains("id=\"import-fed\""));
}

/// The clinic's new-person form takes the age group (a labelled select,
/// adult by default): its defaults in the stored advisor configuration,
/// the group on the person's page; an unknown one stays beside its field.
#[tokio::test]
async fn the_clinics_new_person_form_takes_an_age_group() {
    let svc = Svc::new();
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let page = admin.get("/clinic").await;
    assert_eq!(page.status, StatusCode::OK);
    assert!(
        page.html.contains("<label for=\"age_group\">")
            && page
                .html
                .contains("<select id=\"age_group\" name=\"age_group\"")
            && page.html.contains("<option value=\"adult\" selected>"),
        "{}",
        page.html
    );
    let person = |group: &'static str| {
        vec![
            ("csrf", csrf.clone()),
            ("name", "kim".to_string()),
            ("tz", "Europe/Zurich".to_string()),
            ("unit", "mg/dL".to_string()),
            ("mode", "cgm".to_string()),
            ("age_group", group.to_string()),
            ("basal", "0.6".to_string()),
            ("carb_ratios", "20,22,21".to_string()),
        ]
    };
    let fields = person("<b>toddler</b>");
    let f: Vec<(&str, &str)> = fields.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let p = admin.post_multipart("/clinic/persons", &f, &[]).await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    let error = p.section("id=\"age_group-error\"", "p").to_string();
    assert!(
        error.contains("expected adult, adolescent or child") && !error.contains("<b>"),
        "{error}"
    );
    assert!(abba_service::open_store(&svc.db)
        .unwrap()
        .person("kim")
        .is_err());
    let fields = person("child");
    let f: Vec<(&str, &str)> = fields.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let p = admin.post_multipart("/clinic/persons", &f, &[]).await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let page = admin.get(p.location()).await;
    assert!(page.html.contains("age group child"), "{}", page.html);
    let kim = abba_service::open_store(&svc.db)
        .unwrap()
        .person("kim")
        .unwrap();
    assert_eq!(kim.settings.age_group, abba_advisor::AgeGroup::Child);
    assert_eq!(
        kim.settings.advisor.features.cgm_basal_window_min,
        Some([120, 420])
    );

    // Changed on the person's page: an unknown group stays beside its
    // field, nothing changed; adult: the whole day again.
    let path = p.location().to_string();
    assert!(
        page.html.contains("<form id=\"age-group\"")
            && page.html.contains("<option value=\"child\" selected>"),
        "{}",
        page.html
    );
    let change = format!("{path}/age-group");
    let r = admin
        .post(&change, &[("csrf", csrf.as_str()), ("age_group", "teen")])
        .await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.html);
    let error = r.section("id=\"age_group-error\"", "p").to_string();
    assert!(
        error.contains("expected adult, adolescent or child"),
        "{error}"
    );
    let stored = |svc: &Svc| {
        abba_service::open_store(&svc.db)
            .unwrap()
            .person("kim")
            .unwrap()
            .settings
    };
    assert_eq!(stored(&svc).age_group, abba_advisor::AgeGroup::Child);
    let r = admin.post(&change, &[("age_group", "adult")]).await;
    assert_eq!(r.status, StatusCode::FORBIDDEN, "without the CSRF token");
    assert_eq!(stored(&svc).age_group, abba_advisor::AgeGroup::Child);
    let r = admin
        .post(&change, &[("csrf", csrf.as_str()), ("age_group", "adult")])
        .await;
    assert_eq!(r.status, StatusCode::SEE_OTHER, "{}", r.html);
    let s = stored(&svc);
    assert_eq!(s.age_group, abba_advisor::AgeGroup::Adult);
    assert_eq!(
        (
            s.advisor.features.cgm_basal_window_min,
            s.advisor.features.smbg_basal_window_min
        ),
        abba_advisor::AgeGroup::Adult.basal_windows_min()
    );
    let page = admin.get(r.location()).await;
    assert!(
        page.html.contains("Saved: the age group") && page.html.contains("age group adult"),
        "{}",
        page.html
    );
}

/// A person from an uploaded profile: what the reader noted about it (a
/// temporary profile still running at the end, not taken) is on the
/// person's page the form lands on, escaped, and stays there.
#[tokio::test]
async fn the_notes_of_the_uploaded_profile_are_on_the_persons_page() {
    let svc = Svc::new();
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let file = "nightscout_treatments_aaps_profile_switch_synthetic.json";
    let export = std::fs::read(format!(
        "{}/../io/tests/data/{file}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let f = [
        ("csrf", csrf.as_str()),
        ("name", "ida"),
        ("tz", "Europe/Zurich"),
        ("unit", "mg/dL"),
        ("mode", "cgm"),
    ];
    let p = admin
        .post_multipart("/clinic/persons", &f, &[("profile", file, &export)])
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let path = p.location().to_string();
    for _ in 0..2 {
        let page = admin.get(&path).await;
        assert_eq!(page.status, StatusCode::OK);
        let notes = page.section("<ul id=\"therapy-notes\"", "ul").to_string();
        assert!(
            notes.contains("<li>A temporary profile")
                && notes.contains("was still running at the end of the data")
                && notes.contains("not taken as the person&#x27;s settings"),
            "{notes}"
        );
        assert!(
            page.html.contains("<h3 id=\"therapy-notes-title\">"),
            "{}",
            page.html
        );
    }
    // A person given by hand has no such notes.
    let f = [
        ("csrf", csrf.as_str()),
        ("name", "ben"),
        ("tz", "Europe/Zurich"),
        ("unit", "mg/dL"),
        ("mode", "cgm"),
        ("basal", "0.8"),
        ("carb_ratios", "10,12,11"),
    ];
    let p = admin.post_multipart("/clinic/persons", &f, &[]).await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let page = admin.get(p.location()).await;
    assert!(!page.html.contains("therapy-notes"), "{}", page.html);
}

/// A person made on the clinic's page (mode `cgm` or `smbg`, unit
/// `mg/dL` or `mmol/L`); their id.
async fn clinic_person(svc: &Svc, name: &str, mode: &str, unit: &str) -> u64 {
    let (mut admin, csrf) = signed_in(svc, Role::Admin).await;
    let f = [
        ("csrf", csrf.as_str()),
        ("name", name),
        ("tz", "UTC"),
        ("unit", unit),
        ("mode", mode),
        ("age_group", "adult"),
        ("basal", "1.0"),
        ("carb_ratios", "10,12,11"),
    ];
    let p = admin.post_multipart("/clinic/persons", &f, &[]).await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let store = abba_service::open_store(&svc.db).unwrap();
    store.person(name).unwrap().id as u64
}

/// The `app_event` rows of a kind (`meal_announced`, `smbg`, ...).
fn rows_of(svc: &Svc, person: u64, tag: &str) -> usize {
    let store = abba_service::open_store(&svc.db).unwrap();
    let n = store.app_event_count(person as i64).unwrap();
    (0..=n as u64 + 16)
        .filter_map(|seq| store.app_event(person as i64, seq).unwrap())
        .filter(|e| abba_io::events::kind_name(&e.event.kind) == tag)
        .count()
}

/// The same form sent twice (a double click, a retry after a timeout):
/// one event, one answer; the second gets the first's result. Another
/// value typed into the same page is another entry; a form without its
/// one-time key stores nothing.
#[tokio::test]
async fn a_form_sent_twice_stores_its_event_or_answer_once() {
    let svc = Svc::new();
    let (id, token) = person_past_first_week(&svc, "ana", 9).await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let before = app_events(&svc, id);
    let meals = rows_of(&svc, id, "meal_announced");
    let log = b.get("/log").await;
    let key = log.hidden("submission");
    let meal = [
        ("csrf", csrf.as_str()),
        ("carbs", "60"),
        ("slot", "lunch"),
        ("submission", key.as_str()),
    ];
    let first = b.post("/log/meal", &meal).await;
    assert_eq!(first.status, StatusCode::SEE_OTHER, "{}", first.html);
    assert!(first.location().starts_with("/log?meal="));
    let second = b.post("/log/meal", &meal).await;
    assert_eq!(
        (second.status, second.location()),
        (StatusCode::SEE_OTHER, first.location()),
        "the first result again"
    );
    assert_eq!(app_events(&svc, id), before + 1);
    assert_eq!(rows_of(&svc, id, "meal_announced"), meals + 1);
    // A reading sent twice: one; with another value from the same page: a second.
    let reading = |g: &'static str| {
        [
            ("csrf", csrf.clone()),
            ("glucose", g.to_string()),
            ("submission", key.clone()),
        ]
    };
    let send = |f: [(&'static str, String); 3]| f;
    for _ in 0..2 {
        let f = send(reading("142"));
        let f: Vec<(&str, &str)> = f.iter().map(|(k, v)| (*k, v.as_str())).collect();
        let p = b.post("/log/reading", &f).await;
        assert_eq!(
            (p.status, p.location()),
            (StatusCode::SEE_OTHER, "/log?saved=reading")
        );
    }
    assert_eq!(app_events(&svc, id), before + 2);
    let f = send(reading("150"));
    let f: Vec<(&str, &str)> = f.iter().map(|(k, v)| (*k, v.as_str())).collect();
    assert_eq!(
        b.post("/log/reading", &f).await.status,
        StatusCode::SEE_OTHER
    );
    assert_eq!(app_events(&svc, id), before + 3);
    // Without the key (a page of an older version): refused, nothing stored.
    let p = b
        .post(
            "/log/reading",
            &[("csrf", csrf.as_str()), ("glucose", "130")],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(p.html.contains("reload the page"), "{}", p.html);
    assert_eq!(app_events(&svc, id), before + 3);
    // An answer sent twice: accepted once, the second gets the same page.
    let log = b.get(first.location()).await;
    let advice = log
        .section("<section id=\"meal-advice\"", "section")
        .to_string();
    let sid = open_sid(&advice).expect("the lunch suggestion to answer");
    let key = log.hidden("submission");
    let answer = [
        ("csrf", csrf.as_str()),
        ("suggestion_id", sid.as_str()),
        ("action", "accept"),
        ("submission", key.as_str()),
    ];
    for _ in 0..2 {
        let p = b.post("/answer", &answer).await;
        assert_eq!(
            (p.status, p.location()),
            (StatusCode::SEE_OTHER, format!("/?answered={sid}").as_str()),
            "{}",
            p.html
        );
    }
    let h = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/history?limit=1000"),
            Some(&token),
            None,
        )
        .await;
    let accepted = h.json["suggestions"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["status"] == "accepted")
        .count();
    assert_eq!(accepted, 1, "{}", h.text);
}

/// After an app numbered an event 2^53 − 1 (the API's largest seq), the
/// Log numbers nothing past it: the entry is refused on the page, nothing
/// stored, and sync never says a seq the API would refuse.
#[tokio::test]
async fn the_logs_numbers_never_pass_the_apis_seq_limit() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (_, token) = svc.token(id).await;
    assert_eq!(abba_store::app::MAX_SEQ, abba_api::MAX_SEQ);
    let minute_ago = (jiff::Timestamp::now() - jiff::SignedDuration::from_mins(1)).to_string();
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/events"),
            Some(&token),
            Some(
                &json!({"events": [{"seq": abba_api::MAX_SEQ, "at": minute_ago,
                "event": {"type": "cgm", "mg_dl": 120.0}}]}),
            ),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/reading",
            &[("csrf", &csrf), ("glucose", "120"), ("submission", &key)],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(
        p.section("id=\"glucose-error\"", "p")
            .contains("no event number is left"),
        "{}",
        p.html
    );
    assert_eq!(app_events(&svc, id), 1, "nothing stored");
    let sync = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/sync"),
            Some(&token),
            None,
        )
        .await;
    assert_eq!(sync.json["last_seq"].as_u64(), Some(abba_api::MAX_SEQ));
}

/// A form declared compressed (`Content-Encoding: gzip`) is refused (415
/// naming the encoding) and nothing is stored: its bytes were read as a
/// plain form, so a reading sent plain under that header was stored, and
/// a form really compressed was refused as one from another origin.
#[tokio::test]
async fn a_form_under_a_content_coding_is_refused_and_stores_nothing() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let key = b.get("/log").await.hidden("submission");
    let body = form_urlencoded::Serializer::new(String::new())
        .append_pair("csrf", &csrf)
        .append_pair("glucose", "120")
        .append_pair("submission", &key)
        .finish();
    let req = Request::builder()
        .method(Method::POST)
        .uri("/log/reading")
        .header(header::HOST, HOST)
        .header(header::ORIGIN, ORIGIN)
        .header(header::CONTENT_TYPE, "application/x-www-form-urlencoded")
        .header(header::CONTENT_ENCODING, "gzip")
        .header(header::COOKIE, b.cookie_header())
        .body(Body::from(body))
        .unwrap();
    let res = svc.router.clone().oneshot(req).await.unwrap();
    let status = res.status();
    let html =
        String::from_utf8_lossy(&res.into_body().collect().await.unwrap().to_bytes()).to_string();
    assert_eq!(status, StatusCode::UNSUPPORTED_MEDIA_TYPE, "{html}");
    assert!(html.contains("Content-Encoding"), "{html}");
    assert_eq!(app_events(&svc, id), 0, "nothing stored");
}

/// The bedtime box closes an SMBG day; a CGM day closes by itself at the
/// first event after midnight: no box, and `bedtime=on` from a CGM person
/// is refused on the page with nothing stored.
#[tokio::test]
async fn the_bedtime_box_is_for_finger_sticks_only() {
    let svc = Svc::new();
    let cgm = clinic_person(&svc, "cem", "cgm", "mg/dL").await;
    let smbg = clinic_person(&svc, "sam", "smbg", "mg/dL").await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(smbg as i64)).await;
    let log = b.get("/log").await;
    assert!(log.html.contains("name=\"bedtime\""), "{}", log.html);
    let (mut b, csrf_c) = signed_in(&svc, Role::Person(cgm as i64)).await;
    let log = b.get("/log").await;
    assert_eq!(log.status, StatusCode::OK);
    assert!(!log.html.contains("name=\"bedtime\""), "{}", log.html);
    let key = log.hidden("submission");
    let p = b
        .post(
            "/log/reading",
            &[
                ("csrf", &csrf_c),
                ("glucose", "100"),
                ("bedtime", "on"),
                ("submission", &key),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(
        p.section("id=\"glucose-error\"", "p")
            .contains("does not close the day"),
        "{}",
        p.html
    );
    assert_eq!(app_events(&svc, cgm), 0, "nothing stored");
    let _ = csrf;
}

/// A mmol/L person who types a value in mg/dL is told so in mmol/L.
#[tokio::test]
async fn a_reading_out_of_range_is_refused_in_the_persons_unit() {
    let svc = Svc::new();
    let id = clinic_person(&svc, "mia", "smbg", "mmol/L").await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/reading",
            &[("csrf", &csrf), ("glucose", "120"), ("submission", &key)],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    let error = p.section("id=\"glucose-error\"", "p").to_string();
    assert!(
        error.contains("from 0.6 to 55.5 mmol&#x2f;L; you entered 120")
            && error.contains("120 mg&#x2f;dL would be 6.7 mmol&#x2f;L")
            && !error.contains("2161"),
        "{error}"
    );
    assert_eq!(app_events(&svc, id), 0);
    let p = b
        .post(
            "/log/reading",
            &[("csrf", &csrf), ("glucose", "6,7"), ("submission", &key)],
        )
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    assert_eq!(app_events(&svc, id), 1);
}

/// A person's read-only pages answer while another writer (an `abba
/// import`) holds the store: the session's "seen" is noted only when the
/// store is free, never waited for.
#[tokio::test]
async fn read_only_pages_answer_while_another_writer_holds_the_store() {
    let mut svc = Svc::new();
    if abba_store::testing::is_postgres(&svc.db) {
        eprintln!(
            "read_only_pages_answer_while_another_writer_holds_the_store: SQLite's write lock"
        );
        return;
    }
    let (id, _) = person_past_first_week(&svc, "ana", 2).await;
    let state = abba_service::AppState::open(
        &svc.db,
        abba_service::StoreSettings {
            busy_timeout: std::time::Duration::from_millis(300),
            ..abba_service::StoreSettings::default()
        },
    )
    .unwrap();
    svc.router = abba_service::router(state);
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    let other = rusqlite::Connection::open(&svc.db).unwrap();
    for path in ["/", "/history", "/glucose?range=14d", "/report", "/log"] {
        // Last used long enough ago that this use would be noted.
        other
            .execute("UPDATE web_session SET seen_ms = seen_ms - 3600000", [])
            .unwrap();
        other.execute_batch("BEGIN IMMEDIATE").unwrap();
        let p = b.get(path).await;
        other.execute_batch("ROLLBACK").unwrap();
        assert_eq!(p.status, StatusCode::OK, "{path}: {}", p.html);
    }
}

/// A sign-in with a link that is unknown, used or expired is refused from
/// a read: it never waits for the store's write lock. Each such POST (an
/// anonymous client's, with a made-up link and its own double-submit
/// cookie) began a write transaction: while another writer held the store
/// it held a pooled connection for the whole busy timeout and got 503, and
/// a dozen of them kept a person's reads waiting for a connection.
#[tokio::test]
async fn a_made_up_sign_in_link_is_refused_without_the_write_lock() {
    let mut svc = Svc::new();
    if abba_store::testing::is_postgres(&svc.db) {
        eprintln!("a_made_up_sign_in_link_is_refused_without_the_write_lock: SQLite's write lock");
        return;
    }
    let id = svc.person("ana").await;
    let used = link(&svc, Role::Person(id as i64));
    let mut first = Browser::new(&svc);
    assert_eq!(first.sign_in(&used).await.status, StatusCode::SEE_OTHER);
    let state = abba_service::AppState::open(
        &svc.db,
        abba_service::StoreSettings {
            busy_timeout: std::time::Duration::from_millis(300),
            ..abba_service::StoreSettings::default()
        },
    )
    .unwrap();
    svc.router = abba_service::router(state);
    let live = link(&svc, Role::Person(id as i64));
    let other = rusqlite::Connection::open(&svc.db).unwrap();
    other.execute_batch("BEGIN IMMEDIATE").unwrap();
    let made_up = "ab".repeat(32);
    for (secret, why) in [(made_up.as_str(), "unknown"), (used.as_str(), "used")] {
        let mut b = Browser::new(&svc);
        let csrf = "cd".repeat(32);
        b.cookies.insert("abba_signin".into(), csrf.clone());
        let p = b
            .post("/signin", &[("csrf", &csrf), ("link", secret)])
            .await;
        assert_eq!(p.status, StatusCode::FORBIDDEN, "{why}: {}", p.html);
        assert!(p.headers.get(header::SET_COOKIE).is_none(), "{why}");
    }
    // A live link still needs the write lock: busy, then used once free.
    let mut b = Browser::new(&svc);
    let p = b.sign_in(&live).await;
    assert_eq!(p.status, StatusCode::SERVICE_UNAVAILABLE, "{}", p.html);
    other.execute_batch("ROLLBACK").unwrap();
    let p = b.sign_in(&live).await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
}

/// A text field of the clinic's upload forms with bytes that are no UTF-8
/// (no browser sends them; a client can) is refused, never decoded with
/// U+FFFD in their place: the new person's name was stored as "eva\u{FFFD}\u{FFFD}".
#[tokio::test]
async fn a_form_field_that_is_not_utf8_is_refused_not_replaced() {
    let svc = Svc::new();
    let (admin, csrf) = signed_in(&svc, Role::Admin).await;
    const BOUNDARY: &str = "----abba-test-boundary-utf8";
    let mut body = Vec::new();
    for (k, v) in [
        ("csrf", csrf.as_bytes()),
        ("name", &b"eva\xff\xfe"[..]),
        ("tz", b"UTC"),
        ("unit", b"mg/dL"),
        ("mode", b"cgm"),
        ("age_group", b"adult"),
        ("basal", b"0.9"),
        ("carb_ratios", b"10,12,11"),
    ] {
        body.extend_from_slice(
            format!("--{BOUNDARY}\r\nContent-Disposition: form-data; name=\"{k}\"\r\n\r\n")
                .as_bytes(),
        );
        body.extend_from_slice(v);
        body.extend_from_slice(b"\r\n");
    }
    body.extend_from_slice(format!("--{BOUNDARY}--\r\n").as_bytes());
    let req = Request::builder()
        .method(Method::POST)
        .uri("/clinic/persons")
        .header(header::HOST, HOST)
        .header(header::ORIGIN, ORIGIN)
        .header(
            header::CONTENT_TYPE,
            format!("multipart/form-data; boundary={BOUNDARY}"),
        )
        .header(header::COOKIE, admin.cookie_header())
        .body(Body::from(body))
        .unwrap();
    let res = svc.router.clone().oneshot(req).await.unwrap();
    let status = res.status();
    let html =
        String::from_utf8_lossy(&res.into_body().collect().await.unwrap().to_bytes()).to_string();
    assert_eq!(status, StatusCode::UNPROCESSABLE_ENTITY, "{html}");
    assert!(
        html.contains("name") && html.contains("not UTF-8") && html.contains("byte 4"),
        "{html}"
    );
    let names = abba_service::open_store(&svc.db)
        .unwrap()
        .persons()
        .unwrap();
    assert!(names.is_empty(), "nothing stored: {names:?}");
}

/// The clinic's page shows the pump steps the store holds: a person made
/// by `POST /v1/persons` has `abba person new`'s (0.05 U/h, 0.1 g/U); a
/// person without steps (research, continuous values) shows none, never
/// defaults they do not have.
#[tokio::test]
async fn the_clinic_page_shows_the_steps_the_store_holds() {
    let svc = Svc::new();
    let with = svc
        .person_with(serde_json::json!({
            "name": "ana", "tz": "UTC", "mode": "cgm",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    let without = svc
        .person_with(serde_json::json!({
            "name": "bo", "tz": "UTC", "mode": "cgm", "continuous_values": true,
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    let page = admin.get(&format!("/clinic/persons/{with}")).await;
    assert_eq!(page.status, StatusCode::OK, "{}", page.html);
    let steps = page.section("<form id=\"steps\"", "form");
    assert!(
        steps.contains("name=\"basal_step\" type=\"text\" inputmode=\"decimal\" value=\"0.05\"")
            && steps.contains("name=\"cr_step\" type=\"text\" inputmode=\"decimal\" value=\"0.1\""),
        "{steps}"
    );
    let page = admin.get(&format!("/clinic/persons/{without}")).await;
    let steps = page.section("<form id=\"steps\"", "form");
    assert!(
        steps.contains("name=\"basal_step\" type=\"text\" inputmode=\"decimal\" value=\"\"")
            && steps.contains("name=\"cr_step\" type=\"text\" inputmode=\"decimal\" value=\"\""),
        "{steps}"
    );
}

/// The clinic's sign-in-link and token forms on a store held by another
/// writer: 503 with `Retry-After` as every other form (they gave 500).
#[tokio::test]
async fn the_clinics_link_and_token_forms_on_a_busy_store_give_503() {
    let mut svc = Svc::new();
    if abba_store::testing::is_postgres(&svc.db) {
        eprintln!("the_clinics_link_and_token_forms_on_a_busy_store_give_503: SQLite's write lock");
        return;
    }
    let a = svc.person("ada").await;
    let state = abba_service::AppState::open(
        &svc.db,
        abba_service::StoreSettings {
            busy_timeout: std::time::Duration::from_millis(300),
            ..Default::default()
        },
    )
    .unwrap();
    svc.router = abba_service::router(state);
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let forms = [
        format!("/clinic/persons/{a}/signin"),
        format!("/clinic/persons/{a}/tokens"),
    ];
    let other = rusqlite::Connection::open(&svc.db).unwrap();
    other.execute_batch("BEGIN IMMEDIATE").unwrap();
    for path in &forms {
        let p = admin.post(path, &[("csrf", &csrf)]).await;
        assert_eq!(
            p.status,
            StatusCode::SERVICE_UNAVAILABLE,
            "{path}: {}",
            p.html
        );
        assert_eq!(p.headers[header::RETRY_AFTER], "1", "{path}");
        assert!(p.html.contains("not a medical device"), "{}", p.html);
    }
    other.execute_batch("ROLLBACK").unwrap();
    for path in &forms {
        let p = admin.post(path, &[("csrf", &csrf)]).await;
        assert_eq!(p.status, StatusCode::OK, "{path}: {}", p.html);
    }
}

/// A suggestion the clinician's change of settings replaced is not shown
/// as "Suggested" on Today: it says it was replaced and what is in force.
#[tokio::test]
async fn today_shows_a_replaced_suggestion_as_replaced_not_suggested() {
    let svc = Svc::new();
    let (id, _) = person_past_first_week(&svc, "rae", 9).await;
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    let today = b.get("/").await;
    let card = today.section("<section id=\"setting-basal\"", "section");
    assert!(open_sid(card).is_some(), "{card}");
    assert!(card.contains("Suggested:"), "{card}");
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/therapy"),
            Some(&svc.admin),
            Some(&json!({"basal_units_per_hour": 1.3})),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let today = b.get("/").await;
    assert_eq!(today.status, StatusCode::OK);
    let card = today.section("<section id=\"setting-basal\"", "section");
    assert!(open_sid(card).is_none(), "{card}");
    assert!(!card.contains("Suggested:"), "{card}");
    assert!(card.contains("Last suggestion:"), "{card}");
    assert!(
        card.contains(
            "Replaced by your clinician&#x27;s change of settings: 1.30 U&#x2f;h is in force."
        ),
        "{card}"
    );
    assert!(today.html.contains("not a medical device"));
}

/// What is no page as asked gets the service's HTML page with the notice,
/// never axum's plain-text rejection or the API's JSON 404: a form that is
/// not multipart (415), a path segment that is not UTF-8, an unknown URL.
#[tokio::test]
async fn malformed_page_requests_get_the_services_pages() {
    let svc = Svc::new();
    let a = svc.person("ada").await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let is_page = |p: &Page, status: StatusCode, what: &str| {
        assert_eq!(p.status, status, "{what}: {}", p.html);
        let ct = p.headers[header::CONTENT_TYPE].to_str().unwrap();
        assert!(ct.starts_with("text/html"), "{what}: {ct}");
        assert!(
            p.html.contains("not a medical device"),
            "{what}: {}",
            p.html
        );
    };
    // Not multipart: 415.
    for path in [
        "/clinic/persons".to_string(),
        format!("/clinic/persons/{a}/import"),
    ] {
        let p = admin.post(&path, &[("csrf", &csrf), ("name", "x")]).await;
        is_page(&p, StatusCode::UNSUPPORTED_MEDIA_TYPE, &path);
        assert!(p.html.contains("multipart"), "{}", p.html);
    }
    // Not UTF-8 in the path: as an unknown link or id.
    let p = admin.get("/signin/%ff").await;
    assert_ne!(p.status, StatusCode::BAD_REQUEST, "{}", p.html);
    assert!(p.html.contains("not a medical device"), "{}", p.html);
    let p = admin.get("/clinic/persons/%ff").await;
    is_page(&p, StatusCode::NOT_FOUND, "/clinic/persons/%ff");
    let p = admin
        .post(
            &format!("/clinic/persons/{a}/tokens/%ff/revoke"),
            &[("csrf", &csrf)],
        )
        .await;
    is_page(&p, StatusCode::NOT_FOUND, "revoke %ff");
    // Unknown URLs: the 404 page with the pages' CSP; /v1 stays JSON.
    for path in [
        "/nonexistent",
        "/robots.txt",
        &format!("/clinic/persons/{a}/unknown"),
    ] {
        let p = admin.get(path).await;
        is_page(&p, StatusCode::NOT_FOUND, path);
        assert_eq!(p.headers[header::CONTENT_SECURITY_POLICY], CSP, "{path}");
    }
    let r = svc
        .call(Method::GET, "/v1/nonexistent", Some(&svc.admin), None)
        .await;
    assert_eq!(r.status, StatusCode::NOT_FOUND);
    assert_eq!(r.json["code"], "not_found", "{}", r.text);
    // A page asked with a method it does not take: a page with the
    // pages' headers and `Allow` (it was the API's JSON);
    // /v1 stays JSON.
    for (method, path) in [
        (Method::PUT, "/answer"),
        (Method::DELETE, "/clinic"),
        (Method::POST, "/"),
    ] {
        let p = admin.send(method.clone(), path, None).await;
        is_page(&p, StatusCode::METHOD_NOT_ALLOWED, path);
        assert_eq!(p.headers[header::CONTENT_SECURITY_POLICY], CSP, "{path}");
        assert_eq!(p.headers[header::X_FRAME_OPTIONS], "DENY", "{path}");
        assert!(
            p.headers.contains_key(header::ALLOW),
            "{method} {path}: {:?}",
            p.headers
        );
    }
    let r = svc
        .call(Method::PUT, "/v1/persons", Some(&svc.admin), None)
        .await;
    assert_eq!(r.status, StatusCode::METHOD_NOT_ALLOWED);
    assert_eq!(r.json["code"], "method_not_allowed", "{}", r.text);
}

/// Refusals name their field: bounds that leave out the value in force
/// name `bounds.basal` / `bounds.lunch` (and the clinic's form shows a
/// basal one beside the basal box), a change of settings for a person
/// without data says so in the API's words, a form field sent twice is
/// named on the page.
#[tokio::test]
async fn refusals_name_the_field_they_are_about() {
    let svc = Svc::new();
    let a = svc.person("ada").await;
    let bounds = format!("/v1/persons/{a}/bounds");
    for (body, path) in [
        (
            json!({"bounds": {"basal": {"min": 1.5, "max": 2.0}}}),
            "bounds.basal",
        ),
        (
            json!({"bounds": {"lunch": {"min": 20.0, "max": 30.0}}}),
            "bounds.lunch",
        ),
    ] {
        let r = svc
            .call(Method::PUT, &bounds, Some(&svc.admin), Some(&body))
            .await;
        assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
        assert_eq!(r.json["path"], path, "{}", r.text);
    }
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let p = admin
        .post(
            &format!("/clinic/persons/{a}/bounds"),
            &[
                ("csrf", &csrf),
                ("basal_min", "1.5"),
                ("basal_max", "2.0"),
                ("cr_min", ""),
                ("cr_max", ""),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(p.html.contains("id=\"basal_min-error\""), "{}", p.html);
    assert!(!p.html.contains("id=\"cr_min-error\""), "{}", p.html);
    // No data yet: day 1 is not known.
    let none = svc
        .person_with(json!({
            "name": "nod", "tz": "UTC", "mode": "cgm",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{none}/therapy"),
            Some(&svc.admin),
            Some(&json!({"basal_units_per_hour": 1.1})),
        )
        .await;
    assert_eq!(r.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", r.text);
    assert!(r.json["path"].is_null(), "{}", r.text);
    let m = r.json["message"].as_str().unwrap();
    assert!(m.contains("no data yet") && m.contains("/events"), "{m}");
    assert!(!m.contains("import first"), "{m}");
    // A field sent twice.
    let (mut b, csrf) = signed_in(&svc, Role::Person(a as i64)).await;
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/reading",
            &[
                ("glucose", "123"),
                ("glucose", "5"),
                ("csrf", &csrf),
                ("submission", &key),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(p.html.contains("`glucose` was given twice"), "{}", p.html);
    assert_eq!(app_events(&svc, a), 0);
}

/// The import page's refusals name its own fields (or the command for
/// what it cannot choose), never the CLI's flags.
#[tokio::test]
async fn the_clinics_import_words_its_errors_for_its_own_fields() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let import = format!("/clinic/persons/{id}/import");
    let no_unit = "time,glucose\n2026-01-02 08:00,120\n2026-01-02 08:05,122\n";
    let no_order = "time,glucose_mg_dl\n02/01/2026 08:00,120\n03/01/2026 08:05,122\n";
    let unknown = "\u{1}\u{2} nothing a reader knows\n";
    for (file, want) in [
        (
            no_unit,
            "choose mg&#x2f;dL or mmol&#x2f;L in the &quot;Glucose unit&quot; field",
        ),
        (no_order, "in the &quot;Date order&quot; field"),
        (unknown, "this page cannot choose a format"),
    ] {
        let files = [("files", "export.csv", file.as_bytes())];
        let p = admin
            .post_multipart(&import, &[("csrf", &csrf)], &files)
            .await;
        assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
        let error = p
            .section("<p class=\"field-error\" id=\"files-error\"", "p")
            .to_string();
        assert!(error.contains(want), "{want}: {error}");
        // A flag only in the command named for what the page cannot do.
        assert!(
            !error.replace("`abba import --", "").contains(" --"),
            "a CLI flag: {error}"
        );
    }
}

/// Two tabs of Today: the basal suggestion accepted in one, "keep the
/// previous value" pressed on the other's older page. The store refuses
/// the second answer (the suggestion is no longer open) and keeps the
/// first; the page says so above the cards, since the card it came from
/// has no answer form left to show the error beside.
#[tokio::test]
async fn an_answer_from_an_older_tab_is_refused_with_a_message() {
    let svc = Svc::new();
    let (id, token) = person_past_first_week(&svc, "ana", 9).await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let tab_a = b.get("/").await;
    let tab_b = b.get("/").await;
    let sid = open_sid(tab_a.section("<section id=\"setting-basal\"", "section"))
        .expect("an open basal suggestion after the day closed");
    let answer = |action: &'static str, key: String| {
        vec![
            ("csrf", csrf.clone()),
            ("suggestion_id", sid.clone()),
            ("action", action.to_string()),
            ("submission", key),
        ]
    };
    let fields = answer("accept", tab_b.hidden("submission"));
    let f: Vec<(&str, &str)> = fields.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let p = b.post("/answer", &f).await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let fields = answer("reject", tab_a.hidden("submission"));
    let f: Vec<(&str, &str)> = fields.iter().map(|(k, v)| (*k, v.as_str())).collect();
    let p = b.post("/answer", &f).await;
    assert_eq!(p.status, StatusCode::CONFLICT, "{}", p.html);
    let refused = p.section("<p id=\"answer-refused\"", "p");
    assert!(
        refused.contains("Your answer was not saved"),
        "the refusal is on the page: {}",
        p.html
    );
    // ... with the focus on it (read first), the title saying so.
    assert_eq!(autofocused(&p.html), ["answer-refused"], "{}", p.html);
    assert!(p.html.contains("<title>Not saved · Today"), "{}", p.html);
    assert!(
        !p.section("<section id=\"setting-basal\"", "section")
            .contains("name=\"suggestion_id\""),
        "no answer form left for it"
    );
    // The first answer stands.
    let h = svc
        .call(
            Method::GET,
            &format!("/v1/persons/{id}/history?limit=1000"),
            Some(&token),
            None,
        )
        .await;
    let status: Vec<&str> = h.json["suggestions"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|s| s["id"].as_u64().map(|x| x.to_string()) == Some(sid.clone()))
        .map(|s| s["status"].as_str().unwrap())
        .collect();
    assert_eq!(status, vec!["accepted"], "{}", h.text);
    // An own value refused beside its open field stays there, no banner.
    let today = b.get("/").await;
    assert!(!today.html.contains("id=\"answer-refused\""));
}

/// A form sent from a page left open after signing out (another tab, the
/// Back button) is refused, nothing stored, and the page says why: the
/// person is signed out, not that the form came from elsewhere.
#[tokio::test]
async fn a_form_sent_after_signing_out_says_the_person_is_signed_out() {
    let svc = Svc::new();
    let a = svc.person("ana").await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(a as i64)).await;
    let key = b.get("/log").await.hidden("submission");
    let session = b.cookies.get("abba_session").cloned().unwrap();
    let p = b.post("/signout", &[("csrf", &csrf)]).await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    // The other tab still sends the old cookie.
    b.cookies.insert("abba_session".into(), session);
    let p = b
        .post(
            "/log/reading",
            &[("glucose", "120"), ("csrf", &csrf), ("submission", &key)],
        )
        .await;
    assert_eq!(p.status, StatusCode::FORBIDDEN, "{}", p.html);
    assert!(
        p.html
            .contains("You are not signed in on this device any more"),
        "{}",
        p.html
    );
    assert!(p.html.contains("nothing was saved"), "{}", p.html);
    assert!(!p.html.contains("not sent from abba"), "{}", p.html);
    assert_eq!(app_events(&svc, a), 0);
    // From another origin it is still the other refusal.
    b.origin = Some("http://evil.test");
    let p = b
        .post(
            "/log/reading",
            &[("glucose", "120"), ("csrf", &csrf), ("submission", &key)],
        )
        .await;
    assert_eq!(p.status, StatusCode::FORBIDDEN);
    assert!(p.html.contains("not sent from abba"), "{}", p.html);
}

/// abba-io's test file `f`.
fn io_data(f: &str) -> Vec<u8> {
    std::fs::read(format!(
        "{}/../io/tests/data/{f}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

/// A person whose uploaded export shows a closed loop (AndroidAPS): the
/// clinic's page of the person says that no basal rate is suggested and
/// why, with the records that show it (what `abba advise` says under
/// "Delivery"); a person with no such data says nothing of it.
#[tokio::test]
async fn the_clinic_page_of_a_person_on_a_closed_loop_says_why_no_basal_is_suggested() {
    let svc = Svc::new();
    let body = |name: &str| {
        json!({
            "name": name, "tz": "Europe/Zurich", "mode": "cgm",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        })
    };
    let looped = svc.person_with(body("lou")).await;
    let open = svc.person_with(body("ola")).await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let data = io_data;
    let entries = data("nightscout_entries_synthetic.json");
    let aaps = data("nightscout_treatments_aaps_synthetic.json");
    let p = import_choosing(
        &mut admin,
        looped,
        &csrf,
        "keep",
        &[
            ("files", "entries.json", &entries),
            ("files", "treatments.json", &aaps),
        ],
    )
    .await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    let page = admin.get(&format!("/clinic/persons/{looped}")).await;
    let note = page.section("<p id=\"delivery-note\"", "p");
    assert!(note.contains("closed loop"), "{note}");
    assert!(note.contains("suggests no basal rate"), "{note}");
    let evidence = page.section("<ul id=\"delivery-evidence\"", "ul");
    assert!(evidence.to_lowercase().contains("androidaps"), "{evidence}");
    // A person with no import yet: nothing to say.
    let page = admin.get(&format!("/clinic/persons/{open}")).await;
    assert!(!page.html.contains("id=\"delivery-note\""), "{}", page.html);
}

/// Loop with closed loop off (its settings in Nightscout's profile
/// collection say so; its device status carries `enacted` all the same):
/// the clinic's page says nothing of a loop and basal rates are suggested;
/// the same uploads without Loop's settings are taken as a closed loop and
/// the page says why.
#[tokio::test]
async fn the_clinic_page_of_loop_in_open_loop_holds_no_basal() {
    let svc = Svc::new();
    let body = |name: &str| {
        json!({
            "name": name, "tz": "Europe/Zurich", "mode": "cgm",
            "start": {"basal_units_per_hour": 0.85, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        })
    };
    let open = svc.person_with(body("olu")).await;
    let unknown = svc.person_with(body("ulu")).await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let data = io_data;
    let entries = data("nightscout_entries_synthetic.json");
    let treatments = data("nightscout_treatments_loop_open_loop_synthetic.json");
    let status = data("nightscout_devicestatus_loop_open_loop_synthetic.json");
    let settings = data("nightscout_profile_loop_open_loop_synthetic.json");
    for (id, with_settings) in [(open, true), (unknown, false)] {
        let mut files: Vec<(&str, &str, &[u8])> = vec![
            ("files", "entries.json", &entries),
            ("files", "treatments.json", &treatments),
            ("files", "devicestatus.json", &status),
        ];
        if with_settings {
            files.push(("files", "profile.json", &settings));
        }
        let p = import_choosing(&mut admin, id, &csrf, "keep", &files).await;
        assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    }
    let page = admin.get(&format!("/clinic/persons/{open}")).await;
    assert_eq!(page.status, StatusCode::OK, "{}", page.html);
    assert!(page.html.contains("olu"), "{}", page.html);
    assert!(!page.html.contains("id=\"delivery-note\""), "{}", page.html);
    let page = admin.get(&format!("/clinic/persons/{unknown}")).await;
    let note = page.section("<p id=\"delivery-note\"", "p");
    assert!(
        note.contains("closed loop") && note.contains("suggests no basal rate"),
        "{note}"
    );
    let evidence = page.section("<ul id=\"delivery-evidence\"", "ul");
    assert!(
        evidence.contains("no record of its running mode")
            && evidence.contains("loopSettings.dosingEnabled"),
        "{evidence}"
    );
}

/// The bounds form with two unreadable fields, one in each range: both
/// errors beside their fields at once (not one per submission), what was
/// typed kept, nothing stored.
#[tokio::test]
async fn the_bounds_form_shows_every_fields_error_at_once() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let path = format!("/clinic/persons/{id}/bounds");
    let p = admin
        .post(
            &path,
            &[
                ("csrf", &csrf),
                ("basal_min", "abc"),
                ("basal_max", "1,2"),
                ("cr_min", "6"),
                ("cr_max", "NaN"),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    for field in ["basal_min", "cr_max"] {
        assert!(
            p.html
                .contains(&format!("<p class=\"field-error\" id=\"{field}-error\">")),
            "{field}'s error beside it: {}",
            p.html
        );
        assert!(
            p.html
                .contains(&format!("aria-describedby=\"{field}-error\"")),
            "{field}"
        );
    }
    for field in ["basal_max", "cr_min"] {
        assert!(
            !p.html.contains(&format!("id=\"{field}-error\"")),
            "{field}"
        );
    }
    assert!(p.html.contains("value=\"abc\"") && p.html.contains("value=\"NaN\""));
    let store = abba_service::open_store(&svc.db).unwrap();
    let bounds = store.person("ana").unwrap().settings.bounds;
    assert!(
        bounds.basal.is_none() && bounds.carb_ratio[0].is_none(),
        "{bounds:?}"
    );
}

/// `--public-url https://...`: persons reach the service over TLS, so the
/// sign-in and session cookies are `Secure` even when the proxy in front
/// sends no `X-Forwarded-Proto` (or is on another machine); an `http://`
/// public URL changes nothing.
#[tokio::test]
async fn an_https_public_url_makes_every_cookie_secure() {
    let mut svc = Svc::new();
    let id = svc.person("ana").await;
    for (url, secure) in [
        ("https://abba.clinic.example", true),
        ("http://abba.lan", false),
    ] {
        let state = abba_service::AppState::open(
            &svc.db,
            abba_service::StoreSettings {
                public_url: Some(url.into()),
                ..abba_service::StoreSettings::default()
            },
        )
        .unwrap();
        svc.router = abba_service::router(state);
        let mut b = Browser::new(&svc);
        let secret = link(&svc, Role::Person(id as i64));
        let page = b
            .send(Method::GET, &format!("/signin/{secret}"), None)
            .await;
        let signin = page
            .headers
            .get(header::SET_COOKIE)
            .unwrap()
            .to_str()
            .unwrap();
        assert_eq!(signin.contains("; Secure"), secure, "{url}: {signin}");
        let csrf = page.hidden("csrf");
        let p = b
            .post("/signin", &[("csrf", &csrf), ("link", &secret)])
            .await;
        assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
        // Over TLS the session cookie is `__Host-` (only this host sets it).
        let name = if secure {
            "__Host-abba_session="
        } else {
            "abba_session="
        };
        let session = p
            .headers
            .get_all(header::SET_COOKIE)
            .iter()
            .map(|v| v.to_str().unwrap().to_string())
            .find(|v| v.starts_with(name))
            .unwrap_or_else(|| panic!("{url}: no {name} in {:?}", p.headers));
        assert_eq!(session.contains("; Secure"), secure, "{url}: {session}");
        assert!(session.contains("HttpOnly") && session.contains("SameSite=Strict"));
        assert!(session.contains("; Path=/;") && !session.contains("Domain"));
        assert_eq!(b.get("/").await.status, StatusCode::OK, "{url}: signed in");
        // The same live session under the plain name, as a site on a
        // sibling subdomain can plant it for the whole domain (cookie
        // tossing): over TLS it is not read, so it signs nobody in.
        let value = session[name.len()..].split(';').next().unwrap().to_string();
        let mut tossed = Browser::new(&svc);
        tossed.cookies.insert("abba_session".into(), value);
        let p = tossed.get("/").await;
        if secure {
            assert_eq!(
                (p.status, p.location()),
                (StatusCode::SEE_OTHER, "/signin"),
                "{url}: a tossed abba_session signs in"
            );
        } else {
            assert_eq!(p.status, StatusCode::OK, "{url}: {}", p.html);
        }
    }
}

/// Behind a proxy that rewrites `Host` to the service's own address, the
/// browser's `Origin` names `--public-url`: its forms are same-origin
/// (they were all refused 403); any other origin still is not.
#[tokio::test]
async fn forms_from_the_public_url_pass_the_origin_check_behind_a_host_rewriting_proxy() {
    let mut svc = Svc::new();
    let id = svc.person("ana").await;
    let state = abba_service::AppState::open(
        &svc.db,
        abba_service::StoreSettings {
            public_url: Some("https://abba.clinic.example/".into()),
            ..abba_service::StoreSettings::default()
        },
    )
    .unwrap();
    svc.router = abba_service::router(state);
    for (origin, passes) in [
        ("https://abba.clinic.example", true),
        ("https://ABBA.clinic.example", true),
        ("https://evil.example", false),
        ("https://abba.clinic.example.evil.example", false),
    ] {
        let mut b = Browser::new(&svc);
        b.origin = Some(origin);
        let secret = link(&svc, Role::Person(id as i64));
        let page = b.get(&format!("/signin/{secret}")).await;
        let csrf = page.hidden("csrf");
        let p = b
            .post("/signin", &[("csrf", &csrf), ("link", &secret)])
            .await;
        let want = if passes {
            StatusCode::SEE_OTHER
        } else {
            StatusCode::FORBIDDEN
        };
        assert_eq!(p.status, want, "{origin}: {}", p.html);
    }
}

/// The new-person form's refusals from the store are worded for the page:
/// beside the field, without the CLI flag the store's message starts with.
#[tokio::test]
async fn the_new_person_forms_refusals_name_no_cli_flag() {
    let svc = Svc::new();
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    for (field, value, said) in [
        ("basal", "-1", "must be between 0.025 and 35"),
        ("first_day", "2099-01-01", "expected a date from 1990-01-01"),
    ] {
        let mut f = vec![
            ("csrf", csrf.as_str()),
            ("name", "ana"),
            ("tz", "UTC"),
            ("unit", "mg/dL"),
            ("mode", "cgm"),
            ("age_group", "adult"),
            ("basal", "1.0"),
            ("carb_ratios", "10,12,11"),
        ];
        f.retain(|(k, _)| *k != field);
        f.push((field, value));
        let p = admin.post_multipart("/clinic/persons", &f, &[]).await;
        assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
        let error = p.section(
            &format!("<p class=\"field-error\" id=\"{field}-error\""),
            "p",
        );
        assert!(error.contains(said), "{error}");
        assert!(!error.contains("--"), "no CLI flag: {error}");
    }
    // A CareLink export whose bolus wizard never ran at dinner: the
    // profile's refusal asks for the form's carb-ratio field, not a flag.
    let carelink = std::fs::read(format!(
        "{}/../io/tests/data/carelink_780g_mmol_synthetic.csv",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap();
    let f = [
        ("csrf", csrf.as_str()),
        ("name", "cal"),
        ("tz", "Europe/Madrid"),
        ("unit", "mmol/L"),
        ("mode", "cgm"),
        ("age_group", "adult"),
    ];
    let p = admin
        .post_multipart(
            "/clinic/persons",
            &f,
            &[("profile", "carelink.csv", &carelink)],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    let error = p.section("<p class=\"field-error\" id=\"profile-error\"", "p");
    assert!(
        error.contains("no bolus wizard event with a carb ratio in the dinner window"),
        "{error}"
    );
    assert!(error.contains("&quot;Carb ratios&quot; field"), "{error}");
    assert!(!error.contains("--"), "no CLI flag: {error}");
    // With the three ratios given, the same export makes the person.
    let mut f = f.to_vec();
    f.push(("carb_ratios", "10,12,11"));
    let p = admin
        .post_multipart(
            "/clinic/persons",
            &f,
            &[("profile", "carelink.csv", &carelink)],
        )
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
}

/// A wrong file uploaded to the import (a PDF report, a photo): refused
/// beside the files field naming what it is, never its bytes shown as a
/// CSV's column names; nothing stored.
#[tokio::test]
async fn the_clinics_import_names_a_pdf_or_a_binary_file() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let import = format!("/clinic/persons/{id}/import");
    let pdf: &[u8] = b"%PDF-1.7\n%\xe2\xe3\xcf\xd3\n1 0 obj <</Type /Catalog>>, endobj\n";
    let png: &[u8] = b"\x89PNG\r\n\x1a\n\0\0\0\rIHDR,\x01\x02,\x03\n";
    for (name, bytes, want) in [
        ("clarity.pdf", pdf, "a PDF document"),
        ("photo.png", png, "binary data"),
    ] {
        let p = admin
            .post_multipart(&import, &[("csrf", &csrf)], &[("files", name, bytes)])
            .await;
        assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
        let error = p.section("<p class=\"field-error\" id=\"files-error\"", "p");
        assert!(error.contains(name) && error.contains(want), "{error}");
        assert!(!error.contains("column"), "{error}");
    }
    let store = abba_service::open_store(&svc.db).unwrap();
    assert!(store.records("ana").unwrap().is_empty());
}

/// An own value that is no number: the error beside the field gives an
/// example in that setting's unit (a basal rate in U/h, a carb ratio in
/// g/U), not a basal rate's for a carb ratio.
#[tokio::test]
async fn an_own_value_that_is_no_number_gets_an_example_in_its_unit() {
    let svc = Svc::new();
    let (id, _) = person_past_first_week(&svc, "ana", 9).await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let today = b.get("/").await;
    let basal_sid = open_sid(today.section("<section id=\"setting-basal\"", "section"))
        .expect("an open basal suggestion");
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/meal",
            &[
                ("csrf", &csrf),
                ("carbs", "60"),
                ("slot", "lunch"),
                ("submission", &key),
            ],
        )
        .await;
    let log = b.get(p.location()).await;
    let meal_sid = open_sid(log.section("<section id=\"meal-advice\"", "section"))
        .expect("the lunch suggestion to answer");
    for (sid, example) in [
        (&basal_sid, "for example 0.85 "),
        (&meal_sid, "for example 10.5 "),
    ] {
        let key = b.get("/").await.hidden("submission");
        let p = b
            .post(
                "/answer",
                &[
                    ("csrf", &csrf),
                    ("suggestion_id", sid),
                    ("action", "override"),
                    ("value", "abc"),
                    ("submission", &key),
                ],
            )
            .await;
        assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
        let error = p.section(
            &format!("<p class=\"field-error\" id=\"value-error-{sid}\""),
            "p",
        );
        assert!(error.contains(example), "{example}: {error}");
    }
}

/// The steps and the change-of-therapy forms with both fields unreadable:
/// both errors beside their fields at once; nothing changes.
#[tokio::test]
async fn the_steps_and_therapy_forms_show_every_unreadable_field_at_once() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let before = abba_service::open_store(&svc.db)
        .unwrap()
        .person("ana")
        .unwrap()
        .settings;
    for (form, fields) in [
        ("steps", [("basal_step", "fine"), ("cr_step", "1/10")]),
        ("therapy", [("basal", "0.9 U"), ("carb_ratios", "10;12;11")]),
    ] {
        let mut f = vec![("csrf", csrf.as_str())];
        f.extend(fields);
        let p = admin
            .post(&format!("/clinic/persons/{id}/{form}"), &f)
            .await;
        assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
        for (field, _) in fields {
            assert!(
                p.html
                    .contains(&format!("<p class=\"field-error\" id=\"{field}-error\">")),
                "{form}: {field}'s error beside it: {}",
                p.html
            );
            assert!(p
                .html
                .contains(&format!("aria-describedby=\"{field}-error\"")));
        }
    }
    let after = abba_service::open_store(&svc.db)
        .unwrap()
        .person("ana")
        .unwrap()
        .settings;
    assert_eq!(after.pump_steps, before.pump_steps);
    assert_eq!(after.start, before.start);
}

/// "1,000" g is a thousands separator in English and a decimal comma
/// elsewhere: refused beside the field, nothing stored (it was read as
/// 1 g). "45,5" g is 45.5 g, and the meal's advice says 45.5, not 46.
#[tokio::test]
async fn an_ambiguous_thousands_comma_is_refused_and_a_decimal_comma_kept() {
    let svc = Svc::new();
    let (id, _) = person_past_first_week(&svc, "ana", 9).await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let before = app_events(&svc, id);
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/meal",
            &[
                ("csrf", &csrf),
                ("carbs", "1,000"),
                ("slot", "snack"),
                ("submission", &key),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    let error = p.section("<p class=\"field-error\" id=\"carbs-error\"", "p");
    assert!(error.contains("no thousands separator"), "{error}");
    assert!(
        p.html.contains("value=\"1,000\""),
        "the typed value is kept"
    );
    assert_eq!(app_events(&svc, id), before);
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/meal",
            &[
                ("csrf", &csrf),
                ("carbs", "45,5"),
                ("slot", "lunch"),
                ("submission", &key),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let log = b.get(p.location()).await;
    let advice = log.section("<section id=\"meal-advice\"", "section");
    assert!(advice.contains("45.5 g at"), "{advice}");
    assert_eq!(app_events(&svc, id), before + 1);
}

/// An upload over the limit (a browser declares its size): 413 at once,
/// a page that says how large it was, the limit and what to do, with a
/// link back to the form, never the service's "something went wrong".
#[tokio::test]
async fn an_upload_over_the_limit_says_what_to_do() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (admin, _) = signed_in(&svc, Role::Admin).await;
    for (path, back) in [
        (
            format!("/clinic/persons/{id}/import"),
            format!("/clinic/persons/{id}"),
        ),
        ("/clinic/persons".to_string(), "/clinic".to_string()),
    ] {
        let req = Request::builder()
            .method(Method::POST)
            .uri(&path)
            .header(header::HOST, HOST)
            .header(header::ORIGIN, ORIGIN)
            .header(header::COOKIE, admin.cookie_header())
            .header(
                header::CONTENT_TYPE,
                "multipart/form-data; boundary=----abba-test-boundary",
            )
            .header(header::CONTENT_LENGTH, 70 * 1024 * 1024)
            .body(Body::empty())
            .unwrap();
        let res = svc.router.clone().oneshot(req).await.unwrap();
        assert_eq!(res.status(), StatusCode::PAYLOAD_TOO_LARGE, "{path}");
        let bytes = res.into_body().collect().await.unwrap().to_bytes();
        let html = String::from_utf8_lossy(&bytes);
        assert!(html.contains("70.0 MB, at most 32.0 MB"), "{html}");
        assert!(html.contains("Nothing was imported"), "{html}");
        assert!(!html.contains("Something went wrong"), "{html}");
        let link = format!("href=\"{}\"", back.replace('/', "&#x2f;"));
        assert!(html.contains(&link), "{link}: {html}");
    }
}

#[tokio::test]
async fn the_clinics_list_says_each_persons_zone_and_both_units_of_its_low_mark() {
    let svc = Svc::new();
    let id = svc
        .person_with(json!({
            "name": "kiri", "tz": "Pacific/Auckland", "mode": "cgm",
            "first_day": "2026-01-01",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    let (_, token) = svc.token(id).await;
    // Two readings on day 1 at 08:00 and 08:05 Auckland time (UTC+13).
    let events: Vec<Value> = [(0, 140.0), (5, 60.0)]
        .iter()
        .enumerate()
        .map(|(i, &(m, g))| {
            json!({"seq": i + 1, "at": format!("2026-01-01T08:{m:02}:00+13:00"),
                   "event": {"type": "cgm", "mg_dl": g}})
        })
        .collect();
    let r = svc
        .call(
            Method::POST,
            &format!("/v1/persons/{id}/events"),
            Some(&token),
            Some(&json!({ "events": events })),
        )
        .await;
    assert_eq!(r.status, StatusCode::OK, "{}", r.text);
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    let list = admin.get("/clinic").await;
    let start = list.html.find("<tr data-person=\"kiri\"").unwrap();
    let row = &list.html[start..];
    let row = &row[..row.find("</tr>").unwrap()];
    // The last reading in her own clock, and which clock that is.
    assert!(
        row.contains("08:05") && row.contains("Pacific&#x2f;Auckland")
            || row.contains("Pacific/Auckland"),
        "{row}"
    );
    assert!(
        list.html
            .replace("&#x2f;", "/")
            .contains("Below 70 mg/dL (3.9 mmol/L)"),
        "the column names its mark in both units: {}",
        list.html
    );
}

#[tokio::test]
async fn the_new_person_form_sent_twice_makes_one_person_and_shows_it_both_times() {
    let svc = Svc::new();
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let form = [
        ("csrf", csrf.as_str()),
        ("name", "noa"),
        ("tz", "Europe/Zurich"),
        ("unit", "mg/dL"),
        ("mode", "cgm"),
        ("basal", "0.9"),
        ("carb_ratios", "10,12,11"),
    ];
    // A double click: the second send is answered as the first was.
    let first = admin.post_multipart("/clinic/persons", &form, &[]).await;
    assert_eq!(first.status, StatusCode::SEE_OTHER, "{}", first.html);
    let again = admin.post_multipart("/clinic/persons", &form, &[]).await;
    assert_eq!(again.status, StatusCode::SEE_OTHER, "{}", again.html);
    assert_eq!(again.location(), first.location());
    let store = abba_service::open_store(&svc.db).unwrap();
    assert_eq!(store.persons().unwrap(), ["noa"]);
    // Other settings under the taken name: refused beside the name.
    let mut other = form.to_vec();
    other[5] = ("basal", "1.1");
    let p = admin.post_multipart("/clinic/persons", &other, &[]).await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(p.html.contains("already exists"), "{}", p.html);
}

/// A person on pens (xDrip+'s injections, crates/io/tests/data): Today
/// says the data show injections and no basal rate is suggested, in words
/// a person can act on, never a flag of `abba person new` (nor does their
/// report); the clinic's page and report name the command, as its form
/// has no such field.
#[tokio::test]
async fn a_person_on_injections_reads_no_command_line_flag_on_their_pages() {
    let svc = Svc::new();
    let id = svc
        .person_with(json!({
            "name": "pens", "tz": "Europe/London", "mode": "cgm",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    // Three days of CGM beside the pen injections of 2026-03-10.
    let entries_file = cgm_entries(&svc, "2026-03-08T00:00:00Z", 3);
    let treatments = std::path::PathBuf::from(format!(
        "{}/../io/tests/data/nightscout_treatments_xdrip_injections_synthetic.json",
        env!("CARGO_MANIFEST_DIR")
    ));
    {
        let mut store = abba_service::open_store(&svc.db).unwrap();
        store
            .import_files("pens", &[entries_file, treatments], None)
            .unwrap();
    }
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    let today = b.get("/").await;
    assert_eq!(today.status, StatusCode::OK);
    let note = today
        .html
        .split("<p id=\"not-designed-for\" class=\"callout\">")
        .nth(1)
        .unwrap_or_else(|| panic!("no delivery note on Today: {}", today.html));
    let note = &note[..note.find("</p>").unwrap()];
    assert!(note.contains("multiple daily injections"), "{note}");
    assert!(note.contains("your clinic"), "{note}");
    // The report too (its notes repeat the advice's; the person opens it
    // from History).
    for page in ["/", "/history", "/report"] {
        let p = b.get(page).await;
        assert_eq!(p.status, StatusCode::OK, "{page}");
        assert!(
            !p.html.contains("--allow-closed-loop") && !p.html.contains("--meal-windows"),
            "{page} names a flag: {}",
            p.html
        );
    }
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    let clinic = admin.get(&format!("/clinic/persons/{id}")).await;
    assert!(
        clinic
            .html
            .contains("created with `abba person new --allow-closed-loop`"),
        "{}",
        clinic.html
    );
    let report = admin.get(&format!("/clinic/persons/{id}/report")).await;
    assert!(
        report
            .html
            .contains("created with `abba person new --allow-closed-loop`"),
        "{}",
        report.html
    );
}

/// The first `YYYY-MM-DDTHH:MM` (an instant as RFC 3339 writes it) in
/// `html`, if any: a page says times on a clock, never as UTC instants.
fn utc_instant_in(html: &str) -> Option<String> {
    let b = html.as_bytes();
    let digits = |r: std::ops::Range<usize>| r.clone().all(|i| b[i].is_ascii_digit());
    (0..b.len().saturating_sub(16)).find_map(|i| {
        (digits(i..i + 4)
            && b[i + 4] == b'-'
            && digits(i + 5..i + 7)
            && b[i + 7] == b'-'
            && digits(i + 8..i + 10)
            && b[i + 10] == b'T'
            && digits(i + 11..i + 13)
            && b[i + 13] == b':')
            .then(|| html[i..i + 16].to_string())
    })
}

/// What the clinic's import says (its notes, its refusals) names times on
/// the person's clock with the zone, never as UTC instants: Careportal's
/// Profile Switches naming a profile the import cannot look up, and a file
/// refused for its dates.
#[tokio::test]
async fn the_clinics_import_says_times_on_the_persons_clock() {
    let svc = Svc::new();
    let id = svc
        .person_with(json!({
            "name": "zoe", "tz": "Europe/Zurich", "mode": "cgm",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let data = io_data;
    let path = format!("/clinic/persons/{id}/import");
    // One file through the clinic's import: the status it must get, the
    // page's text (with no UTC instant left in it).
    let mut import = async |name: &str, bytes: &[u8], status: StatusCode| -> String {
        let p = admin
            .post_multipart(&path, &[("csrf", csrf.as_str())], &[("files", name, bytes)])
            .await;
        assert_eq!(p.status, status, "{}", p.html);
        assert_eq!(utc_instant_in(&p.html), None, "{}", p.html);
        p.html.replace("&#x2f;", "/")
    };
    let treatments = data("nightscout_treatments_careportal_switches_synthetic.json");
    let html = import("treatments.json", &treatments, StatusCode::OK).await;
    // The first named switch: 2026-11-14T08:00:00Z in the file.
    assert!(
        html.contains("the first at 2026-11-14 09:00 (Europe/Zurich)"),
        "{html}"
    );
    // Sensor readings dated in 1961 are refused; the bound is said on
    // the person's clock too.
    let clarity = data("clarity_export_synthetic.csv");
    let html = import("clarity.csv", &clarity, StatusCode::UNPROCESSABLE_ENTITY).await;
    assert!(
        html.contains("1961-04-12 00:56:47 (Europe/Zurich)"),
        "{html}"
    );
    // One reading a year ahead (a device clock set wrong): one record,
    // on the person's clock.
    let next_year = jiff::Zoned::now().year() + 1;
    let ahead = format!(
        "Glukose-Werte,Erstellt am,24.11.2026 12:12 UTC,Erstellt von,Test\r\n{LIBRE_DE}\r\nFreeStyle Libre 2,ABC,22.11.{next_year} 07:00,0,\"5,6\",,,,,,,,,,,,,,\r\n"
    );
    let html = import(
        "ahead.csv",
        ahead.as_bytes(),
        StatusCode::UNPROCESSABLE_ENTITY,
    )
    .await;
    assert!(
        html.contains(&format!(
            "1 record, the first ahead.csv: line 3 ({next_year}-11-22 07:00 (Europe/Zurich))"
        )),
        "{html}"
    );
}

/// LibreView's header for a German account in mmol/L (its 19 columns).
const LIBRE_DE: &str = "Gerät,Seriennummer,Gerätezeitstempel,Aufzeichnungstyp,Glukosewert-Verlauf mmol/L,Glukose-Scan mmol/L,Nicht numerisches schnellwirkendes Insulin,Schnellwirkendes Insulin (Einheiten),Nicht numerische Nahrungsdaten,Kohlenhydrate (Gramm),Kohlenhydrate (Portionen),Nicht numerisches Depotinsulin,Depotinsulin (Einheiten),Notizen,Glukose-Teststreifen mmol/L,Keton mmol/L,Mahlzeiteninsulin (Einheiten),Korrekturinsulin (Einheiten),Insulin-Änderung durch Anwender (Einheiten)";

/// The characters the pages escape, back.
fn unescaped(html: &str) -> String {
    html.replace("&#x27;", "'")
        .replace("&#x2f;", "/")
        .replace("&quot;", "\"")
        .replace("&lt;", "<")
        .replace("&gt;", ">")
        .replace("&amp;", "&")
}

#[tokio::test]
async fn today_shows_the_schedule_in_force_the_suggested_schedule_and_the_advices_notes() {
    let svc = Svc::new();
    let (id, advice) = crate::advice_parity::imported_person(&svc, 12);
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    let today = b.get("/").await;
    assert_eq!(today.status, StatusCode::OK, "{}", today.html);
    assert!(!advice.notes.is_empty(), "a trip: {:#?}", advice.notes);
    let notes = unescaped(today.section("<section id=\"advice-notes\"", "section"));
    for n in &advice.notes {
        assert!(notes.contains(n.as_str()), "{n}\nnot in\n{notes}");
    }
    let basal = unescaped(today.section("<section id=\"setting-basal\"", "section"));
    let in_force = advice.therapy.basal_schedule.as_ref().unwrap();
    assert!(
        basal.contains(&abba_advisor::words::schedule(in_force)),
        "the schedule in force: {basal}"
    );
    let latest = advice.settings[0].latest.as_ref().unwrap();
    assert_eq!(latest.status, "open", "{latest:#?}");
    let suggested = latest.schedule.as_ref().unwrap();
    assert_ne!(suggested, in_force);
    assert!(
        basal.contains(&abba_advisor::words::schedule(suggested)),
        "the suggested schedule: {basal}"
    );
}

#[tokio::test]
async fn history_says_an_answer_a_later_import_changed_and_that_it_stands() {
    use abba_advisor::{Mode, PumpSteps};
    let svc = Svc::new();
    let full = crate::advice_parity::export(svc.dir.path(), 12);
    // Imported in three: days 0-9 without day 9's evening, day 10 the
    // next day (showing its suggestions), then day 9's evening: a low the
    // sensor uploads late.
    let day9 = 1_777_845_600_000_i64 + 9 * 86_400_000;
    let late = (day9 + 19 * 3_600_000)..(day9 + 23 * 3_600_000);
    let day10 = day9 + 86_400_000;
    let read = |f: &std::path::PathBuf| -> Vec<Value> {
        serde_json::from_slice(&std::fs::read(f).unwrap()).unwrap()
    };
    let ms = |v: &Value| {
        v["date"].as_i64().unwrap_or_else(|| {
            v["created_at"]
                .as_str()
                .unwrap()
                .parse::<jiff::Timestamp>()
                .unwrap()
                .as_millisecond()
        })
    };
    let mut parts: [Vec<Value>; 3] = Default::default();
    for mut v in read(&full[0]).into_iter().chain(read(&full[1])) {
        let t = ms(&v);
        let k = if late.contains(&t) && v.get("sgv").is_some() {
            v["sgv"] = json!(62);
            2
        } else if t < day10 {
            0
        } else if t < day10 + 86_400_000 {
            1
        } else {
            continue;
        };
        parts[k].push(v);
    }
    let file = |k: usize| {
        let (e, t): (Vec<&Value>, Vec<&Value>) =
            parts[k].iter().partition(|x| x.get("sgv").is_some());
        let ep = svc.dir.path().join(format!("part{k}-entries.json"));
        std::fs::write(&ep, serde_json::to_vec(&e).unwrap()).unwrap();
        let tp = svc.dir.path().join(format!("part{k}-treatments.json"));
        std::fs::write(&tp, serde_json::to_vec(&t).unwrap()).unwrap();
        vec![ep, tp]
    };
    let mut store = abba_store::Store::open(&svc.db).unwrap();
    let start = abba_core::TherapySettings::new(
        abba_core::UnitsPerHour(1.0),
        abba_core::GramsPerUnit(10.0),
    )
    .unwrap();
    let mut p = abba_store::NewPerson::new("ana", "Europe/Zurich", Mode::Cgm, start);
    p.settings.pump_steps = Some(PumpSteps::default());
    let id = store.create_person(&p).unwrap().id;
    store.import_files("ana", &file(0), None).unwrap();
    store.import_files("ana", &file(1), None).unwrap();
    let answered = store
        .answer("ana", &abba_store::AnswerRequest::Accept)
        .unwrap();
    assert!(!answered.is_empty());
    store.import_files("ana", &file(2), None).unwrap();
    let notes: Vec<String> = store
        .history("ana")
        .unwrap()
        .into_iter()
        .filter_map(|v| v.answer_note)
        .collect();
    assert!(
        !notes.is_empty(),
        "the late low changed an answered suggestion"
    );
    let (mut b, _) = signed_in(&svc, Role::Person(id)).await;
    let h = b.get("/history").await;
    assert_eq!(h.status, StatusCode::OK, "{}", h.html);
    let table = unescaped(h.section("<table id=\"history\"", "table"));
    for n in &notes {
        assert!(table.contains(n.as_str()), "{n}\nnot in\n{table}");
    }
}

/// An uploaded file whose name holds a right-to-left override (or
/// another control or format character) is refused beside the file field
/// with the name escaped, never shown as it is (`entries\u{202E}nosj.exe`
/// showed as `entriesexe.json`) and nothing is read; so is a file sent
/// under a field the form does not have (it was dropped unread). The same
/// bytes under a plain name are imported.
#[tokio::test]
async fn an_upload_whose_file_name_hides_or_reorders_text_is_refused_beside_the_field() {
    let svc = Svc::new();
    let id = svc.person("ana").await;
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let import = format!("/clinic/persons/{id}/import");
    let entries = std::fs::read(cgm_entries(&svc, "2026-01-01T00:00:00Z", 1)).unwrap();
    let records = || {
        abba_service::open_store(&svc.db)
            .unwrap()
            .records("ana")
            .unwrap()
            .len()
    };
    for (field, name, want) in [
        ("files", "entries\u{202E}nosj.exe", "\\u{202e}"),
        ("files", "entries\t.json", "\\u{9}"),
        ("files", "entries\u{200B}.json", "\\u{200b}"),
        ("file", "entries.json", "no file field &quot;file&quot;"),
    ] {
        let p = admin
            .post_multipart(&import, &[("csrf", &csrf)], &[(field, name, &entries)])
            .await;
        assert_eq!(
            p.status,
            StatusCode::UNPROCESSABLE_ENTITY,
            "{name:?}: {}",
            p.html
        );
        let error = p.section("<p class=\"field-error\" id=\"files-error\"", "p");
        assert!(error.contains(want), "{name:?}: {error}");
        for c in ['\u{202E}', '\u{200B}'] {
            assert!(!p.html.contains(c), "{name:?} shown as it is: {}", p.html);
        }
        assert_eq!(records(), 0, "{name:?}: nothing is read");
    }
    let p = admin
        .post_multipart(
            &import,
            &[("csrf", &csrf)],
            &[("files", "entries.json", &entries)],
        )
        .await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    assert!(records() > 0, "the same bytes under a plain name are read");
    // The new person's form: its profile file likewise, and no person made.
    let profile = nightscout_export().remove(0).1;
    let f = [
        ("csrf", csrf.as_str()),
        ("name", "bo"),
        ("tz", "UTC"),
        ("unit", "mg/dL"),
        ("mode", "cgm"),
    ];
    let p = admin
        .post_multipart(
            "/clinic/persons",
            &f,
            &[("profile", "profile\u{202E}nosj.exe", &profile)],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    let error = p.section("id=\"profile-error\"", "p");
    assert!(error.contains("\\u{202e}"), "{error}");
    assert!(!p.html.contains('\u{202E}'), "{}", p.html);
    let store = abba_service::open_store(&svc.db).unwrap();
    assert!(store.person("bo").is_err(), "no person was made");
    let p = admin
        .post_multipart(
            "/clinic/persons",
            &f,
            &[("profile", "profile.json", &profile)],
        )
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
}

/// Names read from inside an export (a Nightscout profile's, a profile
/// switch's) that hold a right-to-left override or a zero-width space
/// are shown with those characters as code points on the import's page,
/// the person's page and the report, never as they are (the page showed
/// `Default\u{202E}lmth.exe` as `Defaultexe.html`).
#[tokio::test]
async fn names_read_from_an_export_never_reorder_or_hide_text_on_a_page() {
    const PROFILE: &str = "Default\u{202E}lmth.exe";
    const SWITCHED: &str = "Sport\u{200B}\u{2066}day";
    let svc = Svc::new();
    let id = svc
        .person_with(json!({
            "name": "ana", "tz": "UTC", "mode": "cgm",
            "start": {"basal_units_per_hour": 1.0, "carb_ratio_g_per_unit": [10.0, 12.0, 11.0]}
        }))
        .await;
    let entries = std::fs::read(cgm_entries(&svc, "2026-11-02T00:00:00Z", 3)).unwrap();
    let treatments = json!([{"_id": "sw", "eventType": "Profile Switch",
        "profile": SWITCHED, "duration": 0, "created_at": "2026-11-03T10:00:00.000Z"}]);
    let profile = profile_store_named(PROFILE);
    let treatments = serde_json::to_vec(&treatments).unwrap();
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    let p = import_adopting(&mut admin, id, &csrf, &entries, &treatments, &profile).await;
    assert_eq!(p.status, StatusCode::OK, "{}", p.html);
    let unseen = |html: &str| {
        ['\u{202E}', '\u{200B}', '\u{2066}']
            .into_iter()
            .filter(|c| html.contains(*c))
            .collect::<Vec<_>>()
    };
    // The import names the profiles (so the test can fail), as code points.
    assert!(p.html.contains("Default\\u{202e}lmth.exe"), "{}", p.html);
    assert!(p.html.contains("Sport\\u{200b}\\u{2066}day"), "{}", p.html);
    assert_eq!(unseen(&p.html), Vec::<char>::new(), "{}", p.html);
    for path in [
        format!("/clinic/persons/{id}"),
        format!("/clinic/persons/{id}/report"),
    ] {
        let p = admin.get(&path).await;
        assert_eq!(p.status, StatusCode::OK, "{path}");
        assert_eq!(unseen(&p.html), Vec::<char>::new(), "{path}: {}", p.html);
    }
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    for path in ["/", "/log", "/glucose", "/history", "/report"] {
        let p = b.get(path).await;
        assert_eq!(p.status, StatusCode::OK, "{path}");
        assert_eq!(unseen(&p.html), Vec::<char>::new(), "{path}: {}", p.html);
    }
}

/// The clinic's pages read a person's id only as they write it: `+1`,
/// `01` and `%31` are the 404 page, not person 1's page or report.
#[tokio::test]
async fn the_clinics_pages_read_an_id_only_as_they_write_it() {
    let svc = Svc::new();
    let id = svc.person("zelda-q").await;
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    for path in [
        format!("/clinic/persons/{id}"),
        format!("/clinic/persons/{id}/report"),
    ] {
        let p = admin.get(&path).await;
        assert_eq!(p.status, StatusCode::OK, "{path}");
        for alias in [
            path.replace(&format!("/{id}"), &format!("/+{id}")),
            path.replace(&format!("/{id}"), &format!("/0{id}")),
            path.replace(
                &format!("/{id}"),
                &format!(
                    "/{}",
                    id.to_string()
                        .bytes()
                        .map(|b| format!("%{b:02X}"))
                        .collect::<String>()
                ),
            ),
        ] {
            let p = admin.get(&alias).await;
            assert_eq!(p.status, StatusCode::NOT_FOUND, "{alias}: {}", p.html);
            assert!(!p.html.contains("zelda-q"), "{alias}: {}", p.html);
        }
    }
}

/// The elements of `html` with an `autofocus` attribute, as their `id`s.
fn autofocused(html: &str) -> Vec<String> {
    html.split('<')
        .filter(|tag| {
            let head = tag.split('>').next().unwrap_or("");
            head.split_whitespace()
                .any(|a| a == "autofocus" || a == "autofocus=\"\"")
        })
        .map(|tag| {
            tag.split("id=\"")
                .nth(1)
                .and_then(|rest| rest.split('"').next())
                .unwrap_or("(no id)")
                .to_string()
        })
        .collect()
}

/// A refused form comes back with the keyboard's focus on its first field
/// in error (`autofocus`, no script): a screen reader then reads that
/// field's label and its error (`aria-describedby`) instead of starting
/// again at the top of a page that looks unchanged. Exactly one field,
/// the first in the page's order, on the clinic's new-person and bounds
/// forms, the Log and an own value on Today, whose title then starts by
/// saying it was not saved; a page without an error or a message moves no
/// focus, and the page after a saved form puts it on its message.
#[tokio::test]
async fn a_refused_form_puts_the_focus_on_its_first_field_in_error() {
    let svc = Svc::new();
    let (mut admin, csrf) = signed_in(&svc, Role::Admin).await;
    assert!(autofocused(&admin.get("/clinic").await.html).is_empty());
    let f = [
        ("csrf", csrf.as_str()),
        ("name", "ana"),
        ("tz", "Mars/Olympus"),
        ("unit", "mg/dL"),
        ("mode", "cgm"),
        ("age_group", "adult"),
        ("basal", "0,8x"),
        ("carb_ratios", "10,12,11"),
    ];
    let p = admin.post_multipart("/clinic/persons", &f, &[]).await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert!(p.html.contains("id=\"basal-error\""), "{}", p.html);
    assert_eq!(autofocused(&p.html), ["tz"], "{}", p.html);

    let id = svc.person("bea").await;
    let p = admin
        .post(
            &format!("/clinic/persons/{id}/bounds"),
            &[
                ("csrf", &csrf),
                ("basal_min", "0.5"),
                ("basal_max", "1,2"),
                ("cr_min", "6"),
                ("cr_max", "NaN"),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert_eq!(autofocused(&p.html), ["cr_max"], "{}", p.html);

    let (id, _) = person_past_first_week(&svc, "cy", 9).await;
    let (mut b, csrf) = signed_in(&svc, Role::Person(id as i64)).await;
    let today = b.get("/").await;
    assert!(autofocused(&today.html).is_empty());
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/reading",
            &[("csrf", &csrf), ("glucose", "abc"), ("submission", &key)],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert_eq!(autofocused(&p.html), ["glucose"], "{}", p.html);

    let sid = open_sid(today.section("<section id=\"setting-basal\"", "section"))
        .expect("an open basal suggestion");
    let key = today.hidden("submission");
    let p = b
        .post(
            "/answer",
            &[
                ("csrf", &csrf),
                ("suggestion_id", &sid),
                ("action", "override"),
                ("value", "abc"),
                ("submission", &key),
            ],
        )
        .await;
    assert_eq!(p.status, StatusCode::UNPROCESSABLE_ENTITY, "{}", p.html);
    assert_eq!(autofocused(&p.html), [format!("value-{sid}")], "{}", p.html);
    assert!(
        p.html.contains("<title>Not saved · Today · abba</title>"),
        "the title, said first, says so: {}",
        p.html
    );

    // A form saved: the page it leads to puts the focus on what was saved
    // (the status message), its title unchanged.
    let key = b.get("/log").await.hidden("submission");
    let p = b
        .post(
            "/log/reading",
            &[("csrf", &csrf), ("glucose", "120"), ("submission", &key)],
        )
        .await;
    assert_eq!(p.status, StatusCode::SEE_OTHER, "{}", p.html);
    let saved = b.get(p.location()).await;
    assert!(
        saved.html.contains("id=\"status-message\""),
        "{}",
        saved.html
    );
    assert_eq!(
        autofocused(&saved.html),
        ["status-message"],
        "{}",
        saved.html
    );
    assert!(
        saved.html.contains("<title>Log · abba</title>"),
        "{}",
        saved.html
    );
}

/// The Glucose chart says its unit where a sighted reader looks (over the
/// glucose axis, not only in its accessible name), and its days as a day
/// and a month's name: "12-02" is the 2nd of December to some and the
/// 12th of February to others.
#[tokio::test]
async fn the_glucose_chart_shows_its_unit_and_unambiguous_days() {
    let svc = Svc::new();
    let (id, _) = person_past_first_week(&svc, "bea", 8).await;
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    for path in ["/glucose?range=24h", "/glucose?range=14d"] {
        let p = b.get(path).await;
        let svg = p.section("<svg id=\"glucose-chart\"", "svg");
        let texts: Vec<&str> = svg
            .split("<text ")
            .skip(1)
            .filter_map(|t| t.split('>').nth(1))
            .map(|t| t.trim_end_matches("</text"))
            .collect();
        assert!(
            texts.contains(&"mg&#x2f;dL") || texts.contains(&"mg/dL"),
            "{path}: no visible unit among {texts:?}"
        );
        if path.ends_with("14d") {
            let days: Vec<&str> = svg
                .split("text-anchor=\"middle\">")
                .skip(1)
                .filter_map(|t| t.split("</text>").next())
                .collect();
            assert!(days.len() >= 3, "{days:?}");
            for d in days {
                let (day, month) = d.split_once(' ').unwrap_or_else(|| panic!("{d:?}"));
                assert!(
                    day.parse::<u8>().is_ok_and(|n| (1..=31).contains(&n))
                        && [
                            "Jan", "Feb", "Mar", "Apr", "May", "Jun", "Jul", "Aug", "Sep", "Oct",
                            "Nov", "Dec"
                        ]
                        .contains(&month),
                    "{d:?}"
                );
            }
        }
    }
}

/// Every table of the person's and the clinic's pages has a name (a
/// caption, or the heading of its card through `aria-labelledby`): a
/// screen reader's list of tables says what each one is.
#[tokio::test]
async fn every_table_on_the_pages_has_a_name() {
    let svc = Svc::new();
    let (id, _) = person_past_first_week(&svc, "bea", 8).await;
    let (mut b, _) = signed_in(&svc, Role::Person(id as i64)).await;
    let (mut admin, _) = signed_in(&svc, Role::Admin).await;
    let mut pages = Vec::new();
    for path in ["/", "/history", "/glucose?range=14d", "/glucose?range=24h"] {
        pages.push((path.to_string(), b.get(path).await.html));
    }
    for path in ["/clinic".to_string(), format!("/clinic/persons/{id}")] {
        let html = admin.get(&path).await.html;
        pages.push((path, html));
    }
    let mut tables = 0;
    for (path, html) in &pages {
        for rest in html.split("<table").skip(1) {
            tables += 1;
            let (tag, after) = rest.split_once('>').unwrap();
            let named = tag.contains("aria-labelledby=\"") || tag.contains("aria-label=\"");
            assert!(
                named || after.trim_start().starts_with("<caption>"),
                "{path}: a table without a name: <table{tag}>"
            );
            if let Some(by) = tag.split("aria-labelledby=\"").nth(1) {
                let by = &by[..by.find('"').unwrap()];
                assert!(html.contains(&format!("id=\"{by}\"")), "{path}: {by}");
            }
        }
    }
    assert!(tables >= 5, "{tables}");
}
