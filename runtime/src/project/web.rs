//! The `service.web:` section: the web page of a running instance (live I/O, forcing, the
//! program with live values, timing plots), as written and as validated. The server is in
//! `crate::service::web`.
//!
//! ```yaml
//! service:
//!   web:                           # optional; no page without it
//!     bind: 127.0.0.1:8080         # default 127.0.0.1:8080 (loopback)
//!     writes: false                # forcing from the page; default false; needs a token
//!     token_file: web.token        # the engineer's token (write, force, unforce, traces),
//!                                  # relative to the project file; or token_env:
//!                                  # SOFTPLC_WEB_TOKEN, or token: "..." (in clear)
//!     operator_token_file: op.token  # optional: the operator's token (writes values once,
//!                                  # nothing else); or operator_token_env, operator_token
//!     trend: [motor, box_at_exit]  # tags of the scrolling trend (at most 8); default: the
//!                                  # first 8 module tags
//! ```
//!
//! Reading the page needs nothing; every write needs `writes: true` **and** a token (sent by
//! the page as `Authorization: Bearer TOKEN`); which token matches decides the [`WebRole`].
//! The two roles' tokens must differ, or the roles would mean nothing. The token is read when the project is loaded,
//! so `softplc check` refuses a missing file or variable before the first scan. A token is
//! printable ASCII without spaces, at least [`MIN_TOKEN`] characters, and at least
//! [`MIN_REMOTE_TOKEN`] on an address beyond loopback.

use std::fmt;
use std::net::SocketAddr;
use std::path::{Path, PathBuf};

use schemars::JsonSchema;
use serde::Deserialize;

use super::scada::ServiceError;
use super::span::YPath;
use crate::suggest::edit_distance;

/// Where the page listens unless told.
pub const DEFAULT_WEB_BIND: &str = "127.0.0.1:8080";
/// The most tags a trend shows (more lines are no longer readable).
pub(crate) const MAX_TREND: usize = 8;
/// The shortest token on a loopback address.
pub(crate) const MIN_TOKEN: usize = 8;
/// The shortest token on an address beyond loopback, where anyone on the network may guess.
pub(crate) const MIN_REMOTE_TOKEN: usize = 16;
/// The longest token (it travels in a request head of bounded size).
pub(crate) const MAX_TOKEN: usize = 256;

/// `service.web:` as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "web page settings: a mapping with bind, writes, token, token_file, token_env, \
                 operator_token, operator_token_file, operator_token_env and trend"
)]
pub(crate) struct RawWeb {
    /// Listening address (default `127.0.0.1:8080`).
    #[serde(default)]
    pub bind: Option<String>,
    /// Whether the page may force tags (default false).
    #[serde(default)]
    pub writes: Option<bool>,
    /// The engineer's token (write, force, unforce, traces), in clear.
    #[serde(default)]
    pub token: Option<String>,
    /// A file holding the engineer's token, relative to the project file's folder.
    #[serde(default)]
    pub token_file: Option<String>,
    /// An environment variable holding the engineer's token.
    #[serde(default)]
    pub token_env: Option<String>,
    /// The operator's token (writes values once, nothing else), in clear.
    #[serde(default)]
    pub operator_token: Option<String>,
    /// A file holding the operator's token, relative to the project file's folder.
    #[serde(default)]
    pub operator_token_file: Option<String>,
    /// An environment variable holding the operator's token.
    #[serde(default)]
    pub operator_token_env: Option<String>,
    /// Tags of the trend.
    #[serde(default)]
    pub trend: Option<Vec<String>>,
}

/// The secret a write must present. Its `Debug` does not show it, so a project printed in a
/// log or a panic message does not leak it.
#[derive(Clone, PartialEq, Eq)]
pub struct WebToken(String);

impl WebToken {
    /// A token from its text (the validation checks its characters and length).
    pub fn new(text: impl Into<String>) -> Self {
        Self(text.into())
    }

    /// Whether `given` is the token, in a time that does not depend on where they differ
    /// (only on the length of `given`, which the attacker knows anyway).
    pub fn matches(&self, given: &[u8]) -> bool {
        let want = self.0.as_bytes();
        let mut diff = u8::from(want.len() != given.len());
        for (i, &g) in given.iter().enumerate() {
            diff |= g ^ want.get(i % want.len().max(1)).copied().unwrap_or(0);
        }
        diff == 0 && !want.is_empty()
    }

    /// Its length in characters.
    pub fn len(&self) -> usize {
        self.0.len()
    }

    /// Whether it is empty (never, once validated).
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

impl fmt::Debug for WebToken {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "WebToken(<{} characters>)", self.0.len())
    }
}

/// The validated web page settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WebConfig {
    /// Listening address.
    pub bind: SocketAddr,
    /// Whether writing from the page is allowed (a token is then always present).
    pub writes: bool,
    /// The engineer's token: writes, forces, unforces, traces.
    pub token: Option<WebToken>,
    /// The operator's token: writes values once, nothing else.
    pub operator_token: Option<WebToken>,
    /// Tags of the trend: indexes into [`super::Project::tags`].
    pub trend: Vec<usize>,
}

/// Who a page token belongs to: what its bearer may do.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum WebRole {
    /// Writes values once (`/api/write`), nothing else.
    Operator,
    /// Everything the operator may, plus force, unforce and the traces.
    Engineer,
}

impl fmt::Display for WebRole {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            WebRole::Operator => "operator",
            WebRole::Engineer => "engineer",
        })
    }
}

/// Where a token comes from, for messages.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TokenSource {
    /// `token:` (the engineer's).
    Inline,
    /// `token_file:` (the engineer's).
    File,
    /// `token_env:` (the engineer's).
    Env,
    /// `operator_token:`.
    OperatorInline,
    /// `operator_token_file:`.
    OperatorFile,
    /// `operator_token_env:`.
    OperatorEnv,
}

impl fmt::Display for TokenSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            TokenSource::Inline => "token",
            TokenSource::File => "token_file",
            TokenSource::Env => "token_env",
            TokenSource::OperatorInline => "operator_token",
            TokenSource::OperatorFile => "operator_token_file",
            TokenSource::OperatorEnv => "operator_token_env",
        })
    }
}

/// What is wrong with `service.web:`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum WebError {
    /// The page on the address of another service.
    #[error("service.web.bind is {addr}, the address of {other} too")]
    SameAddress {
        /// The address.
        addr: SocketAddr,
        /// The other service's key.
        other: &'static str,
    },
    /// `writes: true` with no token.
    #[error(
        "service.web: writes need a token (token_file, token_env or token): without one, \
         anyone who opens the page could move the machine"
    )]
    WritesNeedToken,
    /// More than one source for one role's token (`token`, `token_file`, `token_env`).
    #[error("service.web: give one of {first} and {second}, not both")]
    TwoTokenSources {
        /// The first one given.
        first: TokenSource,
        /// Another one.
        second: TokenSource,
    },
    /// The token file cannot be read.
    #[error("service.web.{from} {}: cannot read it: {message}", path.display())]
    TokenFile {
        /// Which key named it.
        from: TokenSource,
        /// The file, resolved.
        path: PathBuf,
        /// The OS error.
        message: String,
    },
    /// The token variable is not set.
    #[error("service.web.{from}: the environment variable {var} is not set (or is empty)")]
    TokenEnv {
        /// Which key named it.
        from: TokenSource,
        /// The variable.
        var: String,
    },
    /// A token with spaces, control characters or non-ASCII.
    #[error(
        "service.web.{from}: the token must be printable ASCII without spaces (it is sent \
         in an Authorization header)"
    )]
    TokenCharacters {
        /// Where it came from.
        from: TokenSource,
    },
    /// A token too short (or too long).
    #[error(
        "service.web.{from}: the token has {len} characters; it needs {min}..={MAX_TOKEN}{}",
        if *remote { " on an address beyond loopback" } else { "" }
    )]
    TokenLength {
        /// Where it came from.
        from: TokenSource,
        /// Its length.
        len: usize,
        /// The minimum that applies.
        min: usize,
        /// Whether the bind is beyond loopback.
        remote: bool,
    },
    /// The operator's token is the engineer's: the roles would mean nothing.
    #[error(
        "service.web.{from}: the operator's token is the engineer's token; give the operator \
         a token of their own, or the operator could force"
    )]
    SameTokenForBothRoles {
        /// The key of the operator's token.
        from: TokenSource,
    },
    /// A trend tag that is not a tag.
    #[error("service.web.trend: no tag {tag}{}", hint.as_ref().map(|h| format!("; did you mean {h}?")).unwrap_or_default())]
    UnknownTrendTag {
        /// The name given.
        tag: String,
        /// A close tag name.
        hint: Option<String>,
    },
    /// A trend tag given twice.
    #[error("service.web.trend: {tag} is listed twice")]
    TrendTwice {
        /// The tag.
        tag: String,
    },
    /// Too many trend tags.
    #[error("service.web.trend: {count} tags; a trend shows at most {MAX_TREND}")]
    TooManyTrendTags {
        /// How many were given.
        count: usize,
    },
}

/// Validates `raw` (the page of a project read from `file`, whose tags are `tags`: name and
/// whether bound to a module point); `taken` are the other services' addresses. Errors go to
/// `errors` with their paths.
pub(crate) fn validate(
    raw: &RawWeb,
    file: &Path,
    tags: &[(&str, bool)],
    taken: &[(SocketAddr, &'static str)],
    errors: &mut Vec<(YPath, ServiceError)>,
) -> Option<WebConfig> {
    let path = YPath::root().key("service").key("web");
    let bind_text = raw.bind.as_deref().unwrap_or(DEFAULT_WEB_BIND);
    let bind = match bind_text.trim().parse::<SocketAddr>() {
        Ok(a) => Some(a),
        Err(_) => {
            errors.push((
                path.key("bind"),
                ServiceError::BadAddress {
                    key: "service.web.bind",
                    text: bind_text.to_owned(),
                },
            ));
            None
        }
    };
    if let Some(bind) = bind {
        if let Some(&(_, other)) = taken.iter().find(|(a, _)| *a == bind && a.port() != 0) {
            errors.push((
                path.key("bind"),
                WebError::SameAddress { addr: bind, other }.into(),
            ));
        }
    }
    let remote = bind.is_some_and(|b| !b.ip().is_loopback());
    let mut err = |key: &str, e: WebError| errors.push((path.key(key), e.into()));

    let writes = raw.writes.unwrap_or(false);
    let mut token_ok = true;
    let mut read_role = |sources: [(TokenSource, Option<&String>); 3]| {
        let (token, given, ok) = role_token(sources, file, remote, &mut err);
        token_ok &= ok;
        (token, given)
    };
    let (token, engineer_given) = read_role([
        (TokenSource::Inline, raw.token.as_ref()),
        (TokenSource::File, raw.token_file.as_ref()),
        (TokenSource::Env, raw.token_env.as_ref()),
    ]);
    let (operator_token, operator_given) = read_role([
        (TokenSource::OperatorInline, raw.operator_token.as_ref()),
        (TokenSource::OperatorFile, raw.operator_token_file.as_ref()),
        (TokenSource::OperatorEnv, raw.operator_token_env.as_ref()),
    ]);
    if let (Some(e), Some(o), Some(from)) = (&token, &operator_token, operator_given) {
        if e.matches(o.0.as_bytes()) {
            err(&from.to_string(), WebError::SameTokenForBothRoles { from });
            token_ok = false;
        }
    }
    let any_token = engineer_given.is_some() || operator_given.is_some();
    if writes && !any_token {
        err("writes", WebError::WritesNeedToken);
    }

    let mut trend_ok = true;
    let trend = match &raw.trend {
        None => {
            let points = tags.iter().enumerate().filter(|(_, (_, p))| *p);
            let mut chosen: Vec<usize> = points.map(|(i, _)| i).take(MAX_TREND).collect();
            if chosen.is_empty() {
                chosen = (0..tags.len().min(MAX_TREND)).collect();
            }
            chosen
        }
        Some(names) => {
            if names.len() > MAX_TREND {
                err("trend", WebError::TooManyTrendTags { count: names.len() });
                trend_ok = false;
            }
            let mut chosen = Vec::with_capacity(names.len());
            for (k, name) in names.iter().enumerate() {
                let at = path.key("trend").index(k);
                match tags.iter().position(|(t, _)| t == name) {
                    Some(i) if chosen.contains(&i) => {
                        errors.push((at, WebError::TrendTwice { tag: name.clone() }.into()));
                        trend_ok = false;
                    }
                    Some(i) => chosen.push(i),
                    None => {
                        let hint = closest(name, tags.iter().map(|(t, _)| *t));
                        errors.push((
                            at,
                            WebError::UnknownTrendTag {
                                tag: name.clone(),
                                hint,
                            }
                            .into(),
                        ));
                        trend_ok = false;
                    }
                }
            }
            chosen
        }
    };
    if !(token_ok && trend_ok) || (writes && token.is_none() && operator_token.is_none()) {
        return None;
    }
    Some(WebConfig {
        bind: bind?,
        writes,
        token,
        operator_token,
        trend,
    })
}

/// One role's token from its possible `sources` (the key and the text given): the token, the
/// key it came from, and whether it is valid; errors go to `err` under the key at fault.
fn role_token(
    sources: [(TokenSource, Option<&String>); 3],
    file: &Path,
    remote: bool,
    err: &mut impl FnMut(&str, WebError),
) -> (Option<WebToken>, Option<TokenSource>, bool) {
    let given: Vec<(TokenSource, &String)> = sources
        .into_iter()
        .filter_map(|(s, v)| Some((s, v?)))
        .collect();
    match given.as_slice() {
        [] => (None, None, true),
        [(source, text)] => {
            match read_token(*source, text, file).and_then(|t| check_token(t, *source, remote)) {
                Ok(t) => (Some(WebToken(t)), Some(*source), true),
                Err(e) => {
                    err(&source.to_string(), e);
                    (None, Some(*source), false)
                }
            }
        }
        [(first, _), (second, _), ..] => {
            err(
                &second.to_string(),
                WebError::TwoTokenSources {
                    first: *first,
                    second: *second,
                },
            );
            (None, Some(*first), false)
        }
    }
}

/// The token's text from its source.
fn read_token(source: TokenSource, text: &str, file: &Path) -> Result<String, WebError> {
    match source {
        TokenSource::Inline | TokenSource::OperatorInline => Ok(text.to_owned()),
        TokenSource::File | TokenSource::OperatorFile => {
            let path = file.parent().unwrap_or(Path::new("")).join(text);
            // A token file is small; reading at most a few KiB keeps a wrong path (a device,
            // a log) from being read whole.
            let mut buf = Vec::new();
            let read = std::fs::File::open(&path).and_then(|f| {
                use std::io::Read;
                f.take(4096).read_to_end(&mut buf)
            });
            match read {
                Ok(_) => Ok(String::from_utf8_lossy(&buf)
                    .trim_end_matches(['\n', '\r'])
                    .to_owned()),
                Err(e) => Err(WebError::TokenFile {
                    from: source,
                    path,
                    message: e.to_string(),
                }),
            }
        }
        TokenSource::Env | TokenSource::OperatorEnv => match std::env::var(text) {
            Ok(v) if !v.is_empty() => Ok(v),
            _ => Err(WebError::TokenEnv {
                from: source,
                var: text.to_owned(),
            }),
        },
    }
}

/// `token` if it is printable ASCII of an allowed length.
fn check_token(token: String, source: TokenSource, remote: bool) -> Result<String, WebError> {
    if !token.bytes().all(|b| b.is_ascii_graphic()) {
        return Err(WebError::TokenCharacters { from: source });
    }
    let min = if remote { MIN_REMOTE_TOKEN } else { MIN_TOKEN };
    if token.len() < min || token.len() > MAX_TOKEN {
        return Err(WebError::TokenLength {
            from: source,
            len: token.len(),
            min,
            remote,
        });
    }
    Ok(token)
}

/// The tag name closest to `name` (same letters ignoring case, or at most 2 edits away).
pub(crate) fn closest<'a>(name: &str, tags: impl Iterator<Item = &'a str>) -> Option<String> {
    let mut best: Option<(usize, &str)> = None;
    for t in tags {
        let d = if t.eq_ignore_ascii_case(name) {
            0
        } else {
            edit_distance(name, t)
        };
        if d <= 2 && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, t));
        }
    }
    best.map(|(_, t)| t.to_owned())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_token_matches_only_itself() {
        let t = WebToken::new("correct-horse");
        assert!(t.matches(b"correct-horse"));
        for wrong in [
            &b""[..],
            b"correct-hors",
            b"correct-horse!",
            b"Correct-horse",
        ] {
            assert!(!t.matches(wrong), "{wrong:?}");
        }
        assert!(!WebToken::new("").matches(b""));
        assert_eq!(format!("{t:?}"), "WebToken(<13 characters>)");
    }

    #[test]
    fn closest_names() {
        let tags = ["motor", "lamp", "start"];
        assert_eq!(closest("motr", tags.into_iter()), Some("motor".into()));
        assert_eq!(closest("LAMP", tags.into_iter()), Some("lamp".into()));
        assert_eq!(closest("zzzzzz", tags.into_iter()), None);
    }
}
