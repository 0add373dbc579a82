//! The `service.mqtt:` section: the PLC as an MQTT Sparkplug B edge node, as written and as
//! validated. The edge node is in `crate::service::mqtt`.
//!
//! ```yaml
//! service:
//!   mqtt:                          # optional; no MQTT without it
//!     host: 127.0.0.1              # the broker (a name or an IP); required
//!     port: 1883                   # default 1883, 8883 with tls
//!     group: plant1                # Sparkplug group id; required
//!     node: line1                  # Sparkplug edge node id; required
//!     client_id: softplc-line1     # default softplc-GROUP-NODE
//!     username: plc                # optional; password or password_env with it
//!     password_env: SOFTPLC_MQTT_PASSWORD
//!     tls: { ca_file: ca.pem }     # TLS, the broker's CA (PEM), relative to the project file
//!     writes: false                # DCMD/NCMD writes to `scada: write` tags; default false
//!     buffer: 10000                # changes kept while the broker is away; default 10000
//!     deadband: { speed: 0.5 }     # per numeric tag: a change smaller than this is not sent
//!     primary_host: scada1         # Sparkplug 3.0 primary host id: births only while its
//!                                  # spBv1.0/STATE/scada1 says online; optional
//! ```
//!
//! Group, node and client ids follow Sparkplug B 3.0 ("Topic Namespace Elements"): UTF-8,
//! without `+`, `/` or `#`.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use schemars::JsonSchema;
use serde::Deserialize;
use softplc_io::point::ValueType;

use super::raw::Int;
use super::scada::ServiceError;
use super::span::YPath;

/// The broker's port unless told, plain.
pub(crate) const DEFAULT_MQTT_PORT: u16 = 1883;
/// The broker's port unless told, with TLS.
pub(crate) const DEFAULT_MQTTS_PORT: u16 = 8883;
/// How many changes are kept while the broker is away unless told.
pub(crate) const DEFAULT_BUFFER: usize = 10_000;
/// The most changes a buffer may keep (each takes a few dozen bytes).
pub(crate) const MAX_BUFFER: usize = 1_000_000;

/// `service.mqtt:` as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "MQTT settings: a mapping with host, port, group, node, client_id, username, \
                 password, password_env, tls, writes, buffer, deadband and primary_host"
)]
pub(crate) struct RawMqtt {
    /// The broker's host.
    #[serde(default)]
    pub host: Option<String>,
    /// The broker's port.
    #[serde(default)]
    pub port: Option<Int>,
    /// Sparkplug group id.
    #[serde(default)]
    pub group: Option<String>,
    /// Sparkplug edge node id.
    #[serde(default)]
    pub node: Option<String>,
    /// MQTT client id.
    #[serde(default)]
    pub client_id: Option<String>,
    /// User name.
    #[serde(default)]
    pub username: Option<String>,
    /// Password, in clear.
    #[serde(default)]
    pub password: Option<String>,
    /// An environment variable holding the password.
    #[serde(default)]
    pub password_env: Option<String>,
    /// TLS.
    #[serde(default)]
    pub tls: Option<RawMqttTls>,
    /// Whether DCMD/NCMD may write tags.
    #[serde(default)]
    pub writes: Option<bool>,
    /// Changes kept while the broker is away.
    #[serde(default)]
    pub buffer: Option<Int>,
    /// Deadband per numeric tag.
    #[serde(default)]
    pub deadband: Option<BTreeMap<String, f64>>,
    /// The Sparkplug 3.0 primary host application's id.
    #[serde(default)]
    pub primary_host: Option<String>,
}

/// `service.mqtt.tls:` as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "TLS settings: a mapping with ca_file"
)]
pub(crate) struct RawMqttTls {
    /// The CA certificate(s) the broker's certificate must chain to, PEM.
    pub ca_file: String,
}

/// The broker's password (the project's type of every password).
pub(crate) use super::secret::Password as MqttPassword;

/// The validated MQTT settings.
#[derive(Debug, Clone, PartialEq)]
pub struct MqttConfig {
    /// The broker's host.
    pub host: String,
    /// The broker's port.
    pub port: u16,
    /// Sparkplug group id.
    pub group: String,
    /// Sparkplug edge node id.
    pub node: String,
    /// MQTT client id.
    pub client_id: String,
    /// User name and password.
    pub credentials: Option<(String, MqttPassword)>,
    /// The CA (PEM, read when the project is loaded) and its file, with TLS.
    pub tls_ca: Option<(PathBuf, Vec<u8>)>,
    /// Whether DCMD/NCMD may write `scada: write` tags.
    pub writes: bool,
    /// Changes kept while the broker is away.
    pub buffer: usize,
    /// Deadband per tag (index into the project's tags), numeric tags only.
    pub deadband: Vec<(usize, f64)>,
    /// The primary host application's id: the node births only while its STATE says online.
    pub primary_host: Option<String>,
}

/// What is wrong with `service.mqtt:`.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum MqttError {
    /// A required key is missing.
    #[error("service.mqtt.{key} is required")]
    Missing {
        /// The key.
        key: &'static str,
    },
    /// An id with a character Sparkplug forbids, or empty.
    #[error(
        "service.mqtt.{key} \"{text}\" cannot be a Sparkplug id: it must be non-empty, without \
         '+', '/' or '#'"
    )]
    BadId {
        /// The key.
        key: &'static str,
        /// The text given.
        text: String,
    },
    /// A port outside 1..=65535.
    #[error("service.mqtt.port {value} is outside 1..=65535")]
    BadPort {
        /// The value given.
        value: i64,
    },
    /// A buffer size outside its range.
    #[error("service.mqtt.buffer {value} is outside 1..={MAX_BUFFER}")]
    BadBuffer {
        /// The value given.
        value: i64,
    },
    /// A password without a user name, or both password keys.
    #[error("service.mqtt: {0}")]
    Credentials(&'static str),
    /// The password's variable is not set.
    #[error("service.mqtt.password_env: the variable {name} is not set")]
    PasswordEnv {
        /// The variable.
        name: String,
    },
    /// The CA file cannot be read.
    #[error("service.mqtt.tls.ca_file {}: cannot read it: {message}", path.display())]
    CaFile {
        /// The file, resolved.
        path: PathBuf,
        /// The OS error.
        message: String,
    },
    /// A deadband on a tag that does not exist.
    #[error("service.mqtt.deadband: no tag named {tag}")]
    DeadbandTag {
        /// The name given.
        tag: String,
    },
    /// A deadband on a bool tag.
    #[error("service.mqtt.deadband: tag {tag} is a bool; a deadband needs a number")]
    DeadbandBool {
        /// The tag.
        tag: String,
    },
    /// A negative or non-finite deadband.
    #[error("service.mqtt.deadband: {tag}: {value} is not a deadband (a number ≥ 0)")]
    DeadbandValue {
        /// The tag.
        tag: String,
        /// The value given.
        value: f64,
    },
}

// Never compared for ordering or hashing; `f64` only rules out `Eq` derivation.
impl Eq for MqttError {}

fn check_id(key: &'static str, text: &str, errors: &mut Vec<(&'static str, MqttError)>) {
    if text.is_empty() || text.contains(['+', '/', '#']) {
        errors.push((
            key,
            MqttError::BadId {
                key,
                text: text.into(),
            },
        ));
    }
}

/// Validates `raw` (of the project file `file`) against the project's tags (name and type,
/// `None` for a tag refused elsewhere).
pub(crate) fn validate(
    raw: &RawMqtt,
    file: &Path,
    tags: &[(&str, Option<ValueType>)],
    path: &YPath,
    out: &mut Vec<(YPath, ServiceError)>,
) -> Option<MqttConfig> {
    let mut errors: Vec<(&'static str, MqttError)> = Vec::new();
    let mut required = |key: &'static str, v: &Option<String>| {
        if v.is_none() {
            errors.push((key, MqttError::Missing { key }));
        }
        v.clone().unwrap_or_default()
    };
    let host = required("host", &raw.host);
    let group = required("group", &raw.group);
    let node = required("node", &raw.node);
    if raw.group.is_some() {
        check_id("group", &group, &mut errors);
    }
    if raw.node.is_some() {
        check_id("node", &node, &mut errors);
    }
    let client_id = raw
        .client_id
        .clone()
        .unwrap_or_else(|| format!("softplc-{group}-{node}"));
    if raw.client_id.is_some() {
        check_id("client_id", &client_id, &mut errors);
    }
    if let Some(host) = &raw.primary_host {
        check_id("primary_host", host, &mut errors);
    }
    let tls_ca = raw.tls.as_ref().and_then(|t| {
        let at = file.parent().unwrap_or(Path::new(".")).join(&t.ca_file);
        match std::fs::read(&at) {
            Ok(pem) => Some((at, pem)),
            Err(e) => {
                errors.push((
                    "tls.ca_file",
                    MqttError::CaFile {
                        path: at,
                        message: e.to_string(),
                    },
                ));
                None
            }
        }
    });
    let port = match raw.port {
        None if raw.tls.is_some() => DEFAULT_MQTTS_PORT,
        None => DEFAULT_MQTT_PORT,
        Some(Int(p)) => match u16::try_from(p) {
            Ok(p) if p > 0 => p,
            _ => {
                errors.push(("port", MqttError::BadPort { value: p }));
                0
            }
        },
    };
    let buffer = match raw.buffer {
        None => DEFAULT_BUFFER,
        Some(Int(b)) if (1..=MAX_BUFFER as i64).contains(&b) => b as usize,
        Some(Int(value)) => {
            errors.push(("buffer", MqttError::BadBuffer { value }));
            0
        }
    };
    let password = super::secret::password_at(
        &raw.password,
        &raw.password_env,
        MqttError::Credentials("give password or password_env, not both"),
        |name| MqttError::PasswordEnv { name },
    )
    .unwrap_or_else(|e| {
        errors.push(e);
        None
    });
    let credentials = match (&raw.username, password) {
        (Some(u), Some(p)) => Some((u.clone(), p)),
        (Some(u), None) => Some((u.clone(), MqttPassword(String::new()))),
        (None, Some(_)) => {
            errors.push((
                "password",
                MqttError::Credentials("a password needs a username"),
            ));
            None
        }
        (None, None) => None,
    };
    let mut deadband = Vec::new();
    // Deadband errors point at their tag's key.
    let mut at_tag: Vec<(YPath, MqttError)> = Vec::new();
    for (tag, &value) in raw.deadband.iter().flatten() {
        let here = path.key("deadband").key_itself(tag);
        let Some(index) = tags.iter().position(|(n, _)| n == tag) else {
            at_tag.push((here, MqttError::DeadbandTag { tag: tag.clone() }));
            continue;
        };
        match tags[index].1 {
            Some(ValueType::Bool) => {
                at_tag.push((here, MqttError::DeadbandBool { tag: tag.clone() }))
            }
            _ if !value.is_finite() || value < 0.0 => at_tag.push((
                path.key("deadband").key(tag),
                MqttError::DeadbandValue {
                    tag: tag.clone(),
                    value,
                },
            )),
            _ => deadband.push((index, value)),
        }
    }
    let ok = errors.is_empty() && at_tag.is_empty();
    out.extend(at_tag.into_iter().map(|(p, e)| (p, ServiceError::Mqtt(e))));
    out.extend(errors.into_iter().map(|(key, e)| {
        let at = key.split('.').fold(path.clone(), |p, k| p.key(k));
        (at, ServiceError::Mqtt(e))
    }));
    ok.then_some(MqttConfig {
        host,
        port,
        group,
        node,
        client_id,
        credentials,
        tls_ca,
        writes: raw.writes.unwrap_or(false),
        buffer,
        deadband,
        primary_host: raw.primary_host.clone(),
    })
}
