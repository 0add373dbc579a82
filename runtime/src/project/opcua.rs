//! The `service.opcua:` section: the PLC's OPC UA server, as written and as validated. The
//! server is in `crate::service::opcua`.
//!
//! ```yaml
//! service:
//!   opcua:                         # optional; no OPC UA server without it
//!     bind: 127.0.0.1              # an IP literal; default 127.0.0.1 (loopback only)
//!     port: 4840                   # default 4840 (OPC UA's registered port); 0: any free one
//!     writes: false                # writes to `scada: write` tags; default false
//!     security: none               # none | basic256sha256 (Sign & Encrypt); default none
//!     username: operator           # a user name clients log in with; password or
//!     password_env: SOFTPLC_OPCUA_PASSWORD   # password_env with it
//!     max_sessions: 20             # sessions at once; default 20
//!     max_subscriptions: 10        # subscriptions per session; default 10
//!     max_monitored_items: 1000    # monitored items per subscription; default 1000
//!     max_queue_size: 1000         # a monitored item's queue, at most; default 1000
//! ```
//!
//! SecurityPolicy None and anonymous access are for a server bound to loopback only: beyond
//! it (any other address, `0.0.0.0` included) the project is refused unless it sets
//! `security: basic256sha256` and a user name with its password.

use std::net::IpAddr;

use schemars::JsonSchema;
use serde::Deserialize;

use super::raw::Int;
use super::scada::ServiceError;
use super::span::YPath;

/// The port unless told: OPC UA's registered port.
pub(crate) const DEFAULT_OPCUA_PORT: u16 = 4840;
/// The address unless told.
pub(crate) const DEFAULT_OPCUA_BIND: &str = "127.0.0.1";

/// The server's limits (`max_*` keys): what a client may open, each with its default and
/// its largest value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OpcUaLimits {
    /// Sessions at once (more are refused `BadTooManySessions`).
    pub sessions: usize,
    /// Subscriptions per session (more are refused `BadTooManySubscriptions`).
    pub subscriptions: usize,
    /// Monitored items per subscription (more are refused `BadTooManyMonitoredItems`).
    pub monitored_items: usize,
    /// The largest queue a monitored item may have (a larger `queueSize` is revised to it).
    pub queue_size: usize,
}

impl Default for OpcUaLimits {
    fn default() -> Self {
        Self {
            sessions: 20,
            subscriptions: 10,
            monitored_items: 1000,
            queue_size: 1000,
        }
    }
}

/// The largest value of each limit: `(key, largest)`.
pub(crate) const LIMIT_MAX: [(&str, usize); 4] = [
    ("max_sessions", 1000),
    ("max_subscriptions", 1000),
    ("max_monitored_items", 100_000),
    ("max_queue_size", 100_000),
];

/// `service.opcua:` as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "OPC UA settings: a mapping with bind, port, writes, security, username, \
                 password, password_env, max_sessions, max_subscriptions, max_monitored_items \
                 and max_queue_size"
)]
pub(crate) struct RawOpcUa {
    /// The address to listen on (an IP literal; default `127.0.0.1`).
    #[serde(default)]
    pub bind: Option<String>,
    /// The port (default 4840; 0 takes any free one).
    #[serde(default)]
    pub port: Option<Int>,
    /// Whether clients may write `scada: write` tags (default false).
    #[serde(default)]
    pub writes: Option<bool>,
    /// The endpoint's security: `none` or `basic256sha256` (default none).
    #[serde(default)]
    pub security: Option<OpcUaSecurity>,
    /// The user name clients log in with.
    #[serde(default)]
    pub username: Option<String>,
    /// Its password, in clear.
    #[serde(default)]
    pub password: Option<String>,
    /// An environment variable holding the password.
    #[serde(default)]
    pub password_env: Option<String>,
    /// Sessions at once (default 20).
    #[serde(default)]
    pub max_sessions: Option<Int>,
    /// Subscriptions per session (default 10).
    #[serde(default)]
    pub max_subscriptions: Option<Int>,
    /// Monitored items per subscription (default 1000).
    #[serde(default)]
    pub max_monitored_items: Option<Int>,
    /// The largest queue a monitored item may ask for (default 1000).
    #[serde(default)]
    pub max_queue_size: Option<Int>,
}

/// The security of the server's one endpoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum OpcUaSecurity {
    /// SecurityPolicy None, MessageSecurityMode None: loopback only.
    #[default]
    None,
    /// SecurityPolicy Basic256Sha256, MessageSecurityMode SignAndEncrypt.
    Basic256Sha256,
}

impl OpcUaSecurity {
    /// How `check` and the log name it (the specification's names).
    pub fn describe(self) -> &'static str {
        match self {
            Self::None => "SecurityPolicy None",
            Self::Basic256Sha256 => "SecurityPolicy Basic256Sha256, Sign & Encrypt",
        }
    }
}

/// The user's password.
pub(crate) use super::secret::Password as OpcUaPassword;

/// The validated OPC UA settings.
#[derive(Debug, Clone, PartialEq)]
pub struct OpcUaConfig {
    /// The address listened on.
    pub bind: IpAddr,
    /// The port (0: any free one).
    pub port: u16,
    /// Whether clients may write `scada: write` tags.
    pub writes: bool,
    /// The endpoint's security.
    pub security: OpcUaSecurity,
    /// The one user and its password (`None`: anonymous, loopback only).
    pub user: Option<(String, OpcUaPassword)>,
    /// What clients may open.
    pub limits: OpcUaLimits,
}

impl OpcUaConfig {
    /// The endpoint's URL at `port` (the bound one when the configured one is 0). An
    /// unspecified address (`0.0.0.0`) is reached by the machine's host name.
    pub fn endpoint_url(&self, port: u16) -> String {
        format!("opc.tcp://{}:{port}/", self.host())
    }

    /// The host name the endpoint's URL carries.
    pub fn host(&self) -> String {
        match self.bind {
            a if a.is_unspecified() => std::fs::read_to_string("/proc/sys/kernel/hostname")
                .map(|h| h.trim().to_string())
                .ok()
                .filter(|h| !h.is_empty())
                .unwrap_or_else(|| "localhost".into()),
            IpAddr::V6(a) => format!("[{a}]"),
            IpAddr::V4(a) => a.to_string(),
        }
    }

    /// Who may log in, as `check` and the log say it.
    pub fn login(&self) -> String {
        match &self.user {
            Some((name, _)) => format!("user {name} with password"),
            None => "anonymous".into(),
        }
    }
}

/// What is wrong with `service.opcua:`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OpcUaError {
    /// `bind` is not an IP address.
    #[error("service.opcua.bind \"{text}\" is not an IP address (such as 127.0.0.1 or ::1)")]
    BadBind {
        /// The text given.
        text: String,
    },
    /// A port outside 0..=65535.
    #[error("service.opcua.port {value} is outside 0..=65535")]
    BadPort {
        /// The value given.
        value: i64,
    },
    /// Beyond loopback without Basic256Sha256 and a user.
    #[error(
        "service.opcua: bind {bind} reaches beyond loopback, where SecurityPolicy None and \
         anonymous access are not allowed: set security: basic256sha256 (Sign & Encrypt) and \
         username with password or password_env{}",
        if *.has_user { "; the user is set" } else { "" }
    )]
    Unsecured {
        /// The address.
        bind: IpAddr,
        /// Whether a user is configured (then security is what is missing).
        has_user: bool,
    },
    /// A password without a user name, or both password keys.
    #[error("service.opcua: {0}")]
    Credentials(&'static str),
    /// The password's variable is not set.
    #[error("service.opcua.password_env: the variable {name} is not set")]
    PasswordEnv {
        /// The variable.
        name: String,
    },
    /// A user without a password.
    #[error("service.opcua.username {name} needs password or password_env")]
    NoPassword {
        /// The user name.
        name: String,
    },
    /// A limit outside its range.
    #[error("service.opcua.{key} {value} is outside 1..={max}")]
    BadLimit {
        /// The key.
        key: &'static str,
        /// The value given.
        value: i64,
        /// The largest allowed.
        max: usize,
    },
    /// A user on an endpoint without security: the password would travel in clear.
    #[error(
        "service.opcua.username needs security: basic256sha256: with SecurityPolicy None the \
         password would travel in clear"
    )]
    UserWithoutSecurity,
}

/// Validates `raw`, whose path is `path`.
pub(crate) fn validate(
    raw: &RawOpcUa,
    path: &YPath,
    out: &mut Vec<(YPath, ServiceError)>,
) -> Option<OpcUaConfig> {
    let mut errors: Vec<(&'static str, OpcUaError)> = Vec::new();
    let bind_text = raw.bind.as_deref().unwrap_or(DEFAULT_OPCUA_BIND);
    let bind = match bind_text.trim().parse::<IpAddr>() {
        Ok(a) => Some(a),
        Err(_) => {
            let text = bind_text.to_owned();
            errors.push(("bind", OpcUaError::BadBind { text }));
            None
        }
    };
    let port = match raw.port {
        None => DEFAULT_OPCUA_PORT,
        Some(Int(p)) => u16::try_from(p).unwrap_or_else(|_| {
            errors.push(("port", OpcUaError::BadPort { value: p }));
            0
        }),
    };
    let password = super::secret::password_at(
        &raw.password,
        &raw.password_env,
        OpcUaError::Credentials("give password or password_env, not both"),
        |name| OpcUaError::PasswordEnv { name },
    )
    .unwrap_or_else(|e| {
        errors.push(e);
        None
    });
    let given_password = raw.password.is_some() || raw.password_env.is_some();
    let user = match (&raw.username, password) {
        (Some(u), Some(p)) => Some((u.clone(), p)),
        (Some(u), None) => {
            if !given_password {
                let name = u.clone();
                errors.push(("username", OpcUaError::NoPassword { name }));
            }
            None
        }
        (None, Some(_)) => {
            errors.push((
                "password",
                OpcUaError::Credentials("a password needs a username"),
            ));
            None
        }
        (None, None) => None,
    };
    let defaults = OpcUaLimits::default();
    let given = [
        (raw.max_sessions, defaults.sessions),
        (raw.max_subscriptions, defaults.subscriptions),
        (raw.max_monitored_items, defaults.monitored_items),
        (raw.max_queue_size, defaults.queue_size),
    ];
    let mut limit = [0usize; 4];
    for (i, ((value, default), (key, max))) in given.into_iter().zip(LIMIT_MAX).enumerate() {
        limit[i] = match value {
            None => default,
            Some(Int(v)) => match usize::try_from(v) {
                Ok(n) if (1..=max).contains(&n) => n,
                _ => {
                    errors.push((key, OpcUaError::BadLimit { key, value: v, max }));
                    default
                }
            },
        };
    }
    let limits = OpcUaLimits {
        sessions: limit[0],
        subscriptions: limit[1],
        monitored_items: limit[2],
        queue_size: limit[3],
    };
    let security = raw.security.unwrap_or_default();
    if raw.username.is_some() && security == OpcUaSecurity::None {
        errors.push(("username", OpcUaError::UserWithoutSecurity));
    }
    if let Some(bind) = bind.filter(|a| !a.is_loopback()) {
        if security != OpcUaSecurity::Basic256Sha256 || raw.username.is_none() {
            let has_user = raw.username.is_some();
            // The place to fix: the security key when it is there, else the address.
            let key = if raw.security.is_some() {
                "security"
            } else {
                "bind"
            };
            errors.push((key, OpcUaError::Unsecured { bind, has_user }));
        }
    }
    let ok = errors.is_empty();
    out.extend(
        errors
            .into_iter()
            .map(|(key, e)| (path.key(key), ServiceError::OpcUa(e))),
    );
    Some(OpcUaConfig {
        bind: bind?,
        port,
        writes: raw.writes.unwrap_or(false),
        security,
        user,
        limits,
    })
    .filter(|_| ok)
}
