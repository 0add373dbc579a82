//! Who may do what on the page.
//!
//! - **Reading** needs nothing but the right `Host`: on a loopback bind only `127.0.0.1:PORT`,
//!   `localhost:PORT` and `[::1]:PORT` are answered, so a web site that rebinds its own name to
//!   127.0.0.1 (DNS rebinding) cannot read the plant through a visitor's browser.
//! - **Writing** (force, write, unforce) needs `writes: true` in the project, a `POST` with
//!   `Content-Type: application/json`, and `Authorization: Bearer TOKEN`. There are no cookies:
//!   a browser sends that header only when the page's own script adds it, and another site's
//!   script cannot add it to a request here without a CORS preflight this server never
//!   approves, so a write cannot be forged from another site (CSRF). An `Origin` or
//!   `Sec-Fetch-Site` saying the request comes from elsewhere is refused too.
//! - **Roles**: the token that matches decides the [`WebRole`]. The operator's token writes
//!   values once and acknowledges alarms; forcing, unforcing and arming a trace need the engineer's (a 403 naming the
//!   role otherwise). Both tokens are compared every time, so the answer's timing does not tell
//!   which one a guess came closer to.

use std::net::SocketAddr;

use super::http::Request;
use crate::project::{WebRole, WebToken};

/// What a request asks to do, for the role it needs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Act {
    /// Check a token (the page's sign-in): any role.
    SignIn,
    /// Write values once: the operator may.
    Write,
    /// Force a tag: the engineer's.
    Force,
    /// Unforce: the engineer's.
    Unforce,
    /// Arm or disarm a trace: the engineer's.
    Trace,
    /// Acknowledge an alarm: the operator may.
    Acknowledge,
}

impl Act {
    /// The least role that may do it.
    fn needs(self) -> WebRole {
        match self {
            Act::SignIn | Act::Write | Act::Acknowledge => WebRole::Operator,
            Act::Force | Act::Unforce | Act::Trace => WebRole::Engineer,
        }
    }
}

impl std::fmt::Display for Act {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Act::SignIn => "signing in",
            Act::Write => "writing",
            Act::Force => "forcing",
            Act::Unforce => "unforcing",
            Act::Trace => "arming or disarming a trace",
            Act::Acknowledge => "acknowledging an alarm",
        })
    }
}

/// Why a write is refused (each is a 403 with this text).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum Refusal {
    /// The project does not allow writes.
    #[error("writes are off in this project (service.web.writes: false)")]
    WritesOff,
    /// No `Authorization: Bearer` header.
    #[error("a token is needed: send Authorization: Bearer TOKEN (sign in on the page)")]
    NoToken,
    /// A token that is not the project's.
    #[error("the token is not valid")]
    BadToken,
    /// An `Origin` or `Sec-Fetch-Site` from another site.
    #[error("the request comes from another site")]
    CrossSite,
    /// Not `application/json`.
    #[error("a write must be sent as application/json")]
    NotJson,
    /// The operator's token asking for what only the engineer may do.
    #[error(
        "the operator token may write values and acknowledge alarms; {0} needs the engineer's"
    )]
    EngineerOnly(Act),
}

/// The write policy of a running page.
#[derive(Debug, Clone)]
pub(crate) struct WriteAuth {
    writes: bool,
    engineer: Option<WebToken>,
    operator: Option<WebToken>,
}

impl WriteAuth {
    /// The policy: `writes` from the project, and the tokens it configured for each role.
    pub(crate) fn new(
        writes: bool,
        engineer: Option<WebToken>,
        operator: Option<WebToken>,
    ) -> Self {
        Self {
            writes,
            engineer,
            operator,
        }
    }

    /// Whether writes are possible at all (the page shows its sign-in).
    pub(crate) fn enabled(&self) -> bool {
        self.writes && (self.engineer.is_some() || self.operator.is_some())
    }

    /// The role `req` may do `act` as, or why it may not.
    pub(crate) fn authorize(&self, req: &Request, act: Act) -> Result<WebRole, Refusal> {
        if !self.enabled() {
            return Err(Refusal::WritesOff);
        }
        if req
            .header("sec-fetch-site")
            .is_some_and(|s| s.eq_ignore_ascii_case("cross-site"))
        {
            return Err(Refusal::CrossSite);
        }
        if let (Some(origin), Some(host)) = (req.header("origin"), req.header("host")) {
            let same = origin
                .strip_prefix("http://")
                .or_else(|| origin.strip_prefix("https://"))
                .is_some_and(|o| o.eq_ignore_ascii_case(host));
            if !same {
                return Err(Refusal::CrossSite);
            }
        }
        let given = req
            .header("authorization")
            .and_then(|a| {
                let (scheme, rest) = a.split_once(' ')?;
                scheme.eq_ignore_ascii_case("bearer").then(|| rest.trim())
            })
            .ok_or(Refusal::NoToken)?;
        // Both compared, whatever the first says (see the module docs).
        let engineer = self
            .engineer
            .as_ref()
            .is_some_and(|t| t.matches(given.as_bytes()));
        let operator = self
            .operator
            .as_ref()
            .is_some_and(|t| t.matches(given.as_bytes()));
        let role = match (engineer, operator) {
            (true, _) => WebRole::Engineer,
            (false, true) => WebRole::Operator,
            (false, false) => return Err(Refusal::BadToken),
        };
        let json = req.header("content-type").is_some_and(|c| {
            c.split(';')
                .next()
                .is_some_and(|m| m.trim().eq_ignore_ascii_case("application/json"))
        });
        if !json {
            return Err(Refusal::NotJson);
        }
        if role < act.needs() {
            return Err(Refusal::EngineerOnly(act));
        }
        Ok(role)
    }
}

/// Whether a request with this `Host` header is answered by a server bound to `bind` (see the
/// module docs): any host beyond loopback, only the loopback names on a loopback bind.
pub(crate) fn host_allowed(bind: SocketAddr, port: u16, host: Option<&str>) -> bool {
    if !bind.ip().is_loopback() {
        return true;
    }
    let Some(host) = host else {
        // HTTP/1.0 clients may omit it; they are not browsers a site can drive.
        return true;
    };
    let host = host.to_ascii_lowercase();
    ["127.0.0.1", "localhost", "[::1]"]
        .iter()
        .any(|name| host == *name || host == format!("{name}:{port}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn request(headers: &[(&str, &str)]) -> Request {
        Request {
            method: super::super::http::Method::Post,
            path: "/api/force".into(),
            query: String::new(),
            headers: headers
                .iter()
                .map(|(n, v)| (n.to_string(), v.to_string()))
                .collect(),
            body: Vec::new(),
            peer: None,
        }
    }

    const JSON: (&str, &str) = ("content-type", "application/json");

    #[test]
    fn writes_need_the_switch_the_token_and_json() {
        let on = WriteAuth::new(true, Some(WebToken::new("s3cret-token")), None);
        let bearer = ("authorization", "Bearer s3cret-token");
        assert!(on.enabled());
        assert_eq!(
            on.authorize(&request(&[JSON, bearer]), Act::Force),
            Ok(WebRole::Engineer)
        );
        assert_eq!(
            on.authorize(
                &request(&[
                    ("content-type", "application/json; charset=utf-8"),
                    ("authorization", "bearer  s3cret-token")
                ]),
                Act::Force
            ),
            Ok(WebRole::Engineer)
        );
        assert_eq!(
            on.authorize(&request(&[JSON]), Act::Force),
            Err(Refusal::NoToken)
        );
        assert_eq!(
            on.authorize(
                &request(&[JSON, ("authorization", "Basic s3cret-token")]),
                Act::Force
            ),
            Err(Refusal::NoToken)
        );
        assert_eq!(
            on.authorize(
                &request(&[JSON, ("authorization", "Bearer wrong")]),
                Act::Force
            ),
            Err(Refusal::BadToken)
        );
        assert_eq!(
            on.authorize(
                &request(&[("content-type", "text/plain"), bearer]),
                Act::Force
            ),
            Err(Refusal::NotJson)
        );
        let off = WriteAuth::new(false, Some(WebToken::new("s3cret-token")), None);
        assert!(!off.enabled());
        assert_eq!(
            off.authorize(&request(&[JSON, bearer]), Act::Force),
            Err(Refusal::WritesOff)
        );
        let no_token = WriteAuth::new(true, None, None);
        assert_eq!(
            no_token.authorize(&request(&[JSON, bearer]), Act::Force),
            Err(Refusal::WritesOff)
        );
    }

    #[test]
    fn the_matching_token_decides_the_role() {
        let both = WriteAuth::new(
            true,
            Some(WebToken::new("engineer-token")),
            Some(WebToken::new("operator-token")),
        );
        let operator = request(&[JSON, ("authorization", "Bearer operator-token")]);
        let engineer = request(&[JSON, ("authorization", "Bearer engineer-token")]);
        assert_eq!(both.authorize(&operator, Act::Write), Ok(WebRole::Operator));
        assert_eq!(
            both.authorize(&operator, Act::SignIn),
            Ok(WebRole::Operator)
        );
        for act in [Act::Force, Act::Unforce, Act::Trace] {
            assert_eq!(
                both.authorize(&operator, act),
                Err(Refusal::EngineerOnly(act))
            );
            assert_eq!(both.authorize(&engineer, act), Ok(WebRole::Engineer));
        }
        assert_eq!(
            Refusal::EngineerOnly(Act::Force).to_string(),
            "the operator token may write values and acknowledge alarms; forcing needs the engineer's"
        );
        let operator_only = WriteAuth::new(true, None, Some(WebToken::new("operator-token")));
        assert!(operator_only.enabled());
        assert_eq!(
            operator_only.authorize(&operator, Act::Write),
            Ok(WebRole::Operator)
        );
        assert_eq!(
            operator_only.authorize(&engineer, Act::Write),
            Err(Refusal::BadToken)
        );
    }

    #[test]
    fn writes_from_another_site_are_refused() {
        let on = WriteAuth::new(true, Some(WebToken::new("s3cret-token")), None);
        let bearer = ("authorization", "Bearer s3cret-token");
        let host = ("host", "127.0.0.1:8080");
        assert_eq!(
            on.authorize(
                &request(&[JSON, bearer, host, ("origin", "http://127.0.0.1:8080")]),
                Act::Force
            ),
            Ok(WebRole::Engineer)
        );
        assert_eq!(
            on.authorize(
                &request(&[JSON, bearer, host, ("origin", "http://evil.example")]),
                Act::Force
            ),
            Err(Refusal::CrossSite)
        );
        assert_eq!(
            on.authorize(
                &request(&[JSON, bearer, ("sec-fetch-site", "cross-site")]),
                Act::Force
            ),
            Err(Refusal::CrossSite)
        );
    }

    #[test]
    fn loopback_binds_answer_loopback_names_only() {
        let lo: SocketAddr = "127.0.0.1:8080".parse().unwrap();
        for ok in [
            "127.0.0.1:8080",
            "localhost:8080",
            "LOCALHOST:8080",
            "[::1]:8080",
            "localhost",
        ] {
            assert!(host_allowed(lo, 8080, Some(ok)), "{ok}");
        }
        for bad in [
            "evil.example:8080",
            "127.0.0.1.evil.example:8080",
            "localhost:9090",
        ] {
            assert!(!host_allowed(lo, 8080, Some(bad)), "{bad}");
        }
        assert!(host_allowed(lo, 8080, None));
        let any: SocketAddr = "0.0.0.0:8080".parse().unwrap();
        assert!(host_allowed(any, 8080, Some("plc.plant.example:8080")));
    }
}
