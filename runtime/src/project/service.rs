//! The `service:` section and each tag's `scada:` key: how a running instance is seen from
//! outside (a Prometheus text endpoint, a Modbus TCP server for SCADA/HMI), as written and as
//! validated. The validation and the address map are in `scada.rs`.
//!
//! ```yaml
//! service:                          # optional; nothing listens on a network without it
//!   metrics: 127.0.0.1:9464         # Prometheus text endpoint, GET /metrics; off when absent
//!   modbus_tcp:                     # Modbus TCP server; off when absent
//!     bind: 127.0.0.1:5020          # default 127.0.0.1:5020 (502 needs root)
//!     unit: 1                       # unit identifier it answers (and 255), 1..=247; default 1
//!     writes: false                 # project-wide switch for writes; default false
//!     allow_remote_writes: false    # needed for writes on a non-loopback bind
//!     idle_timeout: 60s             # a client that completes no request for this long is
//!                                   # disconnected (counted from its last reply); default 60s
//!     send_timeout: 10s             # a client that does not take a reply within this is
//!                                   # disconnected (it does not read); default 10s
//!     read_gaps: exception          # exception | zero: what a read spanning addresses no tag
//!                                   # holds gets; default exception (02)
//!   web: { bind: 127.0.0.1:8080 }   # the web page; off when absent (see `web.rs`)
//!   mqtt: ...                       # MQTT Sparkplug B edge node (see `mqtt.rs`)
//!   opcua: { port: 4840 }           # OPC UA server; off when absent (see `opcua.rs`)
//! tags:
//!   - { name: speed, type: u16, scada: write }                        # writable, next free address
//!   - { name: motor, point: mm1.Y1, scada: { access: read, address: 8 } }   # pinned address
//!   - { name: debug, type: u16, scada: none }                        # not exposed
//! ```
//!
//! Addresses are socket addresses with an IP literal (`127.0.0.1:9464`; IPv6 quoted:
//! `"[::1]:9464"`). A tag without `scada:` is exposed read-only at the next free address.

use std::fmt;
use std::net::SocketAddr;
use std::time::Duration;

use schemars::JsonSchema;
use serde::de::{self, value::MapAccessDeserializer, Deserializer, MapAccess, Visitor};
use serde::Deserialize;
use softplc_io::point::ValueType;

use super::raw::{DurationText, Int};

/// `service:` as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "service settings: a mapping with metrics, modbus_tcp, web, mqtt and opcua"
)]
pub(crate) struct RawService {
    /// Address of the Prometheus text endpoint.
    #[serde(default)]
    pub metrics: Option<String>,
    /// The Modbus TCP server.
    #[serde(default)]
    pub modbus_tcp: Option<RawModbusTcp>,
    /// The web page (see [`super::web`]).
    #[serde(default)]
    pub web: Option<super::web::RawWeb>,
    /// The MQTT Sparkplug B edge node (see [`super::mqtt`]).
    #[serde(default)]
    pub mqtt: Option<super::mqtt::RawMqtt>,
    /// The OPC UA server (see [`super::opcua`]).
    #[serde(default)]
    pub opcua: Option<super::opcua::RawOpcUa>,
}

/// `service.modbus_tcp:` as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "Modbus TCP settings: a mapping with bind, unit, writes, allow_remote_writes, \
                 idle_timeout, send_timeout and read_gaps"
)]
pub(crate) struct RawModbusTcp {
    /// Listening address (default `127.0.0.1:5020`).
    #[serde(default)]
    pub bind: Option<String>,
    /// Unit identifier (default 1).
    #[serde(default)]
    pub unit: Option<Int>,
    /// Whether any write is accepted (default false).
    #[serde(default)]
    pub writes: Option<bool>,
    /// Whether writes may come from beyond the loopback interface (default false).
    #[serde(default)]
    pub allow_remote_writes: Option<bool>,
    /// How long a client may go without completing a request, from its last reply (default
    /// 60 s).
    #[serde(default)]
    pub idle_timeout: Option<DurationText>,
    /// How long a reply may wait for the client to take it (default 10 s).
    #[serde(default)]
    pub send_timeout: Option<DurationText>,
    /// What a read spanning addresses no tag holds gets (default `exception`).
    #[serde(default)]
    pub read_gaps: Option<ReadGaps>,
}

/// What a Modbus TCP read spanning addresses no tag holds gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, JsonSchema)]
#[serde(rename_all = "lowercase")]
pub enum ReadGaps {
    /// Exception 02 (illegal data address), as the Modbus specification says.
    #[default]
    Exception,
    /// 0 for each such address (false for a bit), for SCADA drivers that merge the addresses
    /// they poll into blocks; a read that holds no tag at all still gets exception 02.
    Zero,
}

/// What SCADA may do with a tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ScadaAccess {
    /// Readable (the default).
    #[default]
    Read,
    /// Readable and writable (memory tags and outputs only).
    Write,
    /// Not exposed.
    None,
}

impl ScadaAccess {
    /// The project-file spellings.
    pub const NAMES: &'static [&'static str] = &["read", "write", "none"];

    fn parse(text: &str) -> Option<Self> {
        match text {
            "read" => Some(Self::Read),
            "write" => Some(Self::Write),
            "none" => Some(Self::None),
            _ => None,
        }
    }
}

/// A tag's `scada:` as written: `read` | `write` | `none`, or `{ access, address }`.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct RawScada {
    /// Access (default read).
    pub access: Option<ScadaAccess>,
    /// Pinned protocol address (0-based), checked by the validation.
    pub address: Option<Int>,
}

/// The mapping form of `scada:`.
#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "SCADA settings: read, write, none, or a mapping with access and address"
)]
struct RawScadaMap {
    #[serde(default)]
    access: Option<String>,
    #[serde(default)]
    address: Option<Int>,
}

fn access<E: de::Error>(text: &str) -> Result<ScadaAccess, E> {
    ScadaAccess::parse(text).ok_or_else(|| E::unknown_variant(text, ScadaAccess::NAMES))
}

impl<'de> Deserialize<'de> for RawScada {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawScada;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("read, write, none, or a mapping with access and address")
            }

            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawScada, E> {
                Ok(RawScada {
                    access: Some(access(v)?),
                    address: None,
                })
            }

            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RawScada, A::Error> {
                let m = RawScadaMap::deserialize(MapAccessDeserializer::new(map))?;
                Ok(RawScada {
                    access: m.access.as_deref().map(access).transpose()?,
                    address: m.address,
                })
            }
        }
        d.deserialize_any(V)
    }
}

/// Where the Modbus TCP server listens unless told: loopback, and a port above 1023 so an
/// unprivileged service can bind it (502, the registered port, needs root or
/// CAP_NET_BIND_SERVICE).
pub const DEFAULT_MODBUS_BIND: &str = "127.0.0.1:5020";
/// The unit identifier answered unless told.
pub(crate) const DEFAULT_UNIT: u8 = 1;
/// How long a Modbus TCP client may go without completing a request unless told.
pub(crate) const DEFAULT_MODBUS_IDLE: Duration = Duration::from_secs(60);
/// How long a Modbus TCP reply may wait for its client to take it unless told.
pub(crate) const DEFAULT_MODBUS_SEND: Duration = Duration::from_secs(10);

/// The validated `service:` section and SCADA map.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ServiceConfig {
    /// Prometheus text endpoint (`None`: off).
    pub metrics: Option<SocketAddr>,
    /// Modbus TCP server (`None`: off).
    pub modbus_tcp: Option<ModbusTcpConfig>,
    /// The web page (`None`: off).
    pub web: Option<super::web::WebConfig>,
    /// The MQTT Sparkplug B edge node (`None`: off).
    pub mqtt: Option<super::mqtt::MqttConfig>,
    /// The OPC UA server (`None`: off).
    pub opcua: Option<super::opcua::OpcUaConfig>,
    /// Every exposed tag's Modbus addresses.
    pub scada: ScadaMap,
}

/// The Modbus TCP server's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ModbusTcpConfig {
    /// Listening address.
    pub bind: SocketAddr,
    /// Unit identifier answered (255, "this server" in Modbus TCP, is answered too).
    pub unit: u8,
    /// Whether writes are accepted at all (each tag must also be `scada: write`).
    pub writes: bool,
    /// A client that completes no request for this long after its last reply (or after
    /// connecting) is disconnected; a frame sent byte by byte does not restart the clock.
    pub idle_timeout: Duration,
    /// A client that does not take a reply within this (it sends requests and does not read
    /// the answers) is disconnected.
    pub send_timeout: Duration,
    /// What a read spanning addresses no tag holds gets.
    pub read_gaps: ReadGaps,
}

/// The two Modbus address spaces of the map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Space {
    /// Bool tags: coils (FC 1, 5, 15) and discrete inputs (FC 2) at the same address.
    Bits,
    /// Numeric tags: holding registers (FC 3, 6, 16) and input registers (FC 4) at the same
    /// address.
    Registers,
}

impl Space {
    /// The space of a tag of type `ty`, and how many addresses it takes there.
    pub fn of(ty: ValueType) -> (Self, u16) {
        match ty {
            ValueType::Bool => (Space::Bits, 1),
            ValueType::U16 => (Space::Registers, 1),
            ValueType::I32 | ValueType::F32 => (Space::Registers, 2),
        }
    }
}

impl fmt::Display for Space {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Space::Bits => "coil/discrete input",
            Space::Registers => "register",
        })
    }
}

/// One exposed tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ScadaEntry {
    /// Index into [`super::Project::tags`].
    pub tag: usize,
    /// Its type.
    pub ty: ValueType,
    /// Its address space.
    pub space: Space,
    /// Its first protocol address (0-based).
    pub address: u16,
    /// Addresses it takes (1, or 2 for i32/f32).
    pub width: u16,
    /// Whether SCADA may write it (when `writes: true`).
    pub writable: bool,
    /// Whether the address was given in the file (else: the next free one).
    pub pinned: bool,
}

/// Every exposed tag, in tag order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct ScadaMap {
    /// The entries.
    pub entries: Vec<ScadaEntry>,
}
