//! Validation of the `service:` section and the SCADA address map.
//!
//! # The map (stable by construction)
//!
//! Every tag is exposed read-only unless its `scada:` says `write` or `none`. Bool tags live
//! in the bit space (coil and discrete input N are the same tag), numeric tags in the register
//! space (holding and input register N are the same tag): u16 takes one register, i32 and f32
//! two, high word first. Pinned addresses (`scada: { address: N }`) are placed first; then each
//! other exposed tag, in file order, takes the lowest free address at or after the end of the
//! previous unpinned tag of its space. So appending a tag never moves another one, and a tag
//! whose address must never move is pinned.

use std::collections::BTreeMap;
use std::net::SocketAddr;

use softplc_io::point::{Access, ValueType};

use super::model::{Binding, TagConfig};
use super::raw::{DurationText, Int, RawProject};
use super::service::{
    ModbusTcpConfig, RawModbusTcp, ScadaAccess, ScadaEntry, ScadaMap, ServiceConfig, Space,
    DEFAULT_MODBUS_BIND, DEFAULT_MODBUS_IDLE, DEFAULT_MODBUS_SEND, DEFAULT_UNIT,
};
use super::span::{Locator, YPath};

/// Unit identifiers a Modbus server may have (0 is broadcast, 248..=255 reserved).
const UNITS: std::ops::RangeInclusive<i64> = 1..=247;

/// What the map needs to know of a validated tag.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct TagFacts {
    /// Its type.
    pub(crate) ty: ValueType,
    /// `None`: a memory tag; else its point's text and access.
    pub(crate) point: Option<(String, Access)>,
}

/// The facts of every tag (`None` where the tag was refused); `access(module, point)` gives a
/// bound point's access.
pub(crate) fn facts(
    raw: &RawProject,
    tags: &[Option<TagConfig>],
    access: impl Fn(usize, usize) -> Option<Access>,
) -> Vec<Option<TagFacts>> {
    tags.iter()
        .zip(&raw.tags)
        .map(|(t, r)| {
            let t = t.as_ref()?;
            let point = match t.binding {
                Binding::Memory => None,
                Binding::Point { module, point } => {
                    Some((r.point.clone().unwrap_or_default(), access(module, point)?))
                }
            };
            Some(TagFacts { ty: t.ty, point })
        })
        .collect()
}

/// What is wrong with the `service:` section or a tag's `scada:`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ServiceError {
    /// Not `IP:PORT`.
    #[error(
        "{key} \"{text}\" is not an address: write IP:PORT, like 127.0.0.1:9464 (IPv6 in \
         quotes: \"[::1]:9464\")"
    )]
    BadAddress {
        /// `service.metrics`, `service.modbus_tcp.bind` or `service.web.bind`.
        key: &'static str,
        /// The text given.
        text: String,
    },
    /// The metrics endpoint and the Modbus server on one address.
    #[error("service.metrics and service.modbus_tcp.bind are both {addr}")]
    SameAddress {
        /// The address.
        addr: SocketAddr,
    },
    /// A Modbus TCP timeout of zero.
    #[error("service.modbus_tcp.{key} must be longer than zero")]
    ZeroTimeout {
        /// `idle_timeout` or `send_timeout`.
        key: &'static str,
    },
    /// A unit identifier outside 1..=247.
    #[error("Modbus unit {value} is outside 1..=247")]
    BadUnit {
        /// The value given.
        value: i64,
    },
    /// Writes enabled on an address beyond loopback without saying so.
    #[error(
        "Modbus TCP writes on {bind}, which is not a loopback address, need \
         `allow_remote_writes: true`: anyone who reaches that address could move the machine"
    )]
    RemoteWrites {
        /// The bind address.
        bind: SocketAddr,
    },
    /// `scada: write` on a tag that a module overwrites every scan.
    #[error(
        "tag {tag}: `scada: write` is only allowed on memory tags and outputs; {point} is an \
         {} the module overwrites every scan",
        if *access == Access::Input { "input" } else { "input setting" }
    )]
    WriteOnInput {
        /// The tag.
        tag: String,
        /// Its point.
        point: String,
        /// The point's access.
        access: Access,
    },
    /// An address outside the protocol's range.
    #[error("tag {tag}: {space} address {address} is outside 0..={max}")]
    AddressOutOfRange {
        /// The tag.
        tag: String,
        /// Its space.
        space: Space,
        /// The address given.
        address: i64,
        /// Its highest valid first address (65534 for two-register tags).
        max: u16,
    },
    /// Two pinned tags overlapping.
    #[error(
        "tag {tag}: {space} address {address} overlaps tag {other} ({space} {other_first}..={other_last}, line {other_line})"
    )]
    AddressTaken {
        /// The tag.
        tag: String,
        /// Its space.
        space: Space,
        /// Its address.
        address: u16,
        /// The tag there first.
        other: String,
        /// Its first address.
        other_first: u16,
        /// Its last address.
        other_last: u16,
        /// Its line.
        other_line: usize,
    },
    /// `address` with `access: none`.
    #[error("tag {tag}: `address` is given but access is `none` (not exposed)")]
    AddressOnHidden {
        /// The tag.
        tag: String,
    },
    /// No address left in a space.
    #[error("tag {tag}: no free {space} address is left")]
    MapFull {
        /// The tag.
        tag: String,
        /// Its space.
        space: Space,
    },
    /// The web page's settings.
    #[error(transparent)]
    Web(#[from] super::web::WebError),
    /// The MQTT edge node's settings.
    #[error(transparent)]
    Mqtt(#[from] super::mqtt::MqttError),
    /// The OPC UA server's settings.
    #[error(transparent)]
    OpcUa(#[from] super::opcua::OpcUaError),
}

/// Validates `raw.service` (of the project file `file`) and every tag's `scada:` against the
/// validated tags (`None`: a tag refused elsewhere, skipped here). Returns the config (when nothing here is wrong) and the
/// errors with their paths.
pub(crate) fn validate(
    raw: &RawProject,
    tags: &[Option<TagFacts>],
    loc: &Locator<'_>,
    file: &std::path::Path,
) -> (Option<ServiceConfig>, Vec<(YPath, ServiceError)>) {
    let mut errors = Vec::new();
    let root = YPath::root().key("service");
    let service = raw.service.clone().unwrap_or_default();
    let metrics = service
        .metrics
        .as_deref()
        .map(|text| address(text, "service.metrics", root.key("metrics"), &mut errors));
    let modbus = service
        .modbus_tcp
        .as_ref()
        .map(|m| modbus_tcp(m, &root.key("modbus_tcp"), &mut errors));
    if let (Some(Some(a)), Some(Some(m))) = (metrics, modbus) {
        if a == m.bind && a.port() != 0 {
            errors.push((
                root.key("modbus_tcp").key("bind"),
                ServiceError::SameAddress { addr: a },
            ));
        }
    }
    let web = service.web.as_ref().map(|w| {
        let names: Vec<(&str, bool)> = raw
            .tags
            .iter()
            .map(|t| (t.name.as_str(), t.point.is_some()))
            .collect();
        let mut taken = Vec::new();
        if let Some(Some(a)) = metrics {
            taken.push((a, "service.metrics"));
        }
        if let Some(Some(m)) = modbus {
            taken.push((m.bind, "service.modbus_tcp"));
        }
        super::web::validate(w, file, &names, &taken, &mut errors)
    });
    let mqtt = service.mqtt.as_ref().map(|m| {
        let names: Vec<(&str, Option<ValueType>)> = raw
            .tags
            .iter()
            .zip(tags)
            .map(|(t, f)| (t.name.as_str(), f.as_ref().map(|f| f.ty)))
            .collect();
        super::mqtt::validate(m, file, &names, &root.key("mqtt"), &mut errors)
    });
    let opcua = service
        .opcua
        .as_ref()
        .map(|o| super::opcua::validate(o, &root.key("opcua"), &mut errors));
    let map = scada_map(raw, tags, loc, &mut errors);
    let config = (|| {
        Some(ServiceConfig {
            metrics: metrics.map_or(Some(None), |a| a.map(Some))?,
            modbus_tcp: modbus.map_or(Some(None), |m| m.map(Some))?,
            web: web.map_or(Some(None), |w| w.map(Some))?,
            mqtt: mqtt.map_or(Some(None), |m| m.map(Some))?,
            opcua: opcua.map_or(Some(None), |o| o.map(Some))?,
            scada: map,
        })
    })();
    (config.filter(|_| errors.is_empty()), errors)
}

fn address(
    text: &str,
    key: &'static str,
    path: YPath,
    errors: &mut Vec<(YPath, ServiceError)>,
) -> Option<SocketAddr> {
    match text.trim().parse::<SocketAddr>() {
        Ok(a) => Some(a),
        Err(_) => {
            let text = text.to_owned();
            errors.push((path, ServiceError::BadAddress { key, text }));
            None
        }
    }
}

fn modbus_tcp(
    m: &RawModbusTcp,
    path: &YPath,
    errors: &mut Vec<(YPath, ServiceError)>,
) -> Option<ModbusTcpConfig> {
    let bind = address(
        m.bind.as_deref().unwrap_or(DEFAULT_MODBUS_BIND),
        "service.modbus_tcp.bind",
        path.key("bind"),
        errors,
    );
    let unit = match m.unit {
        None => Some(DEFAULT_UNIT),
        Some(Int(u)) if UNITS.contains(&u) => u8::try_from(u).ok(),
        Some(Int(value)) => {
            errors.push((path.key("unit"), ServiceError::BadUnit { value }));
            None
        }
    };
    let writes = m.writes.unwrap_or(false);
    if let Some(bind) = bind {
        if writes && !bind.ip().is_loopback() && !m.allow_remote_writes.unwrap_or(false) {
            errors.push((path.key("writes"), ServiceError::RemoteWrites { bind }));
        }
    }
    let mut timeout = |raw: Option<DurationText>, key: &'static str, default| match raw {
        None => Some(default),
        Some(DurationText(d)) if !d.is_zero() => Some(d),
        Some(_) => {
            errors.push((path.key(key), ServiceError::ZeroTimeout { key }));
            None
        }
    };
    let idle_timeout = timeout(m.idle_timeout, "idle_timeout", DEFAULT_MODBUS_IDLE);
    let send_timeout = timeout(m.send_timeout, "send_timeout", DEFAULT_MODBUS_SEND);
    Some(ModbusTcpConfig {
        bind: bind?,
        unit: unit?,
        writes,
        idle_timeout: idle_timeout?,
        send_timeout: send_timeout?,
        read_gaps: m.read_gaps.unwrap_or_default(),
    })
}

/// Occupied ranges of one space: first address → (last address, entry index).
type Occupied = BTreeMap<u32, (u32, usize)>;

/// The entry overlapping `first..=last`, if any (ranges in `occ` never overlap each other, so
/// only the last range starting at or before `last` can).
fn overlap(occ: &Occupied, first: u32, last: u32) -> Option<(u32, u32, usize)> {
    occ.range(..=last)
        .next_back()
        .filter(|(_, &(end, _))| end >= first)
        .map(|(&start, &(end, i))| (start, end, i))
}

fn scada_map(
    raw: &RawProject,
    tags: &[Option<TagFacts>],
    loc: &Locator<'_>,
    errors: &mut Vec<(YPath, ServiceError)>,
) -> ScadaMap {
    let mut entries: Vec<ScadaEntry> = Vec::new();
    let mut occupied: [Occupied; 2] = [Occupied::new(), Occupied::new()];
    let slot = |s: Space| usize::from(s == Space::Registers);
    // Unpinned tags, placed after every pinned one: (entry index).
    let mut unpinned = Vec::new();
    for (i, (raw_tag, facts)) in raw.tags.iter().zip(tags).enumerate() {
        let Some(facts) = facts else { continue };
        let scada = raw_tag.scada.clone().unwrap_or_default();
        let path = YPath::root().key("tags").index(i).key("scada");
        let access = scada.access.unwrap_or_default();
        if access == ScadaAccess::None {
            if scada.address.is_some() {
                let tag = raw_tag.name.clone();
                errors.push((path.key("address"), ServiceError::AddressOnHidden { tag }));
            }
            continue;
        }
        let writable = access == ScadaAccess::Write;
        if writable {
            if let Some((point, a)) = &facts.point {
                if *a != Access::Output {
                    errors.push((
                        path.key("access"),
                        ServiceError::WriteOnInput {
                            tag: raw_tag.name.clone(),
                            point: point.clone(),
                            access: *a,
                        },
                    ));
                }
            }
        }
        let (space, width) = Space::of(facts.ty);
        let mut entry = ScadaEntry {
            tag: i,
            ty: facts.ty,
            space,
            address: 0,
            width,
            writable,
            pinned: scada.address.is_some(),
        };
        let Some(Int(wanted)) = scada.address else {
            unpinned.push(entries.len());
            entries.push(entry);
            continue;
        };
        let max = u16::MAX - (width - 1);
        let Some(first) = u16::try_from(wanted).ok().filter(|a| *a <= max) else {
            errors.push((
                path.key("address"),
                ServiceError::AddressOutOfRange {
                    tag: raw_tag.name.clone(),
                    space,
                    address: wanted,
                    max,
                },
            ));
            continue;
        };
        let (lo, hi) = (u32::from(first), u32::from(first) + u32::from(width) - 1);
        let occ = &mut occupied[slot(space)];
        if let Some((start, end, other)) = overlap(occ, lo, hi) {
            let other_tag = entries.get(other).map_or(0, |e| e.tag);
            let other_line = loc.line(
                &YPath::root()
                    .key("tags")
                    .index(other_tag)
                    .key("scada")
                    .key("address"),
            );
            errors.push((
                path.key("address"),
                ServiceError::AddressTaken {
                    tag: raw_tag.name.clone(),
                    space,
                    address: first,
                    other: raw
                        .tags
                        .get(other_tag)
                        .map(|t| t.name.clone())
                        .unwrap_or_default(),
                    other_first: u16::try_from(start).unwrap_or(u16::MAX),
                    other_last: u16::try_from(end).unwrap_or(u16::MAX),
                    other_line,
                },
            ));
            continue;
        }
        occ.insert(lo, (hi, entries.len()));
        entry.address = first;
        entries.push(entry);
    }

    let mut cursor = [0u32; 2];
    for k in unpinned {
        let Some(entry) = entries.get_mut(k) else {
            continue;
        };
        let s = slot(entry.space);
        let occ = &mut occupied[s];
        let width = u32::from(entry.width);
        let mut first = cursor[s];
        let placed = loop {
            let last = first + width - 1;
            if last > u32::from(u16::MAX) {
                break None;
            }
            match overlap(occ, first, last) {
                Some((_, end, _)) => first = end + 1,
                None => break Some((first, last)),
            }
        };
        match placed.and_then(|(f, l)| Some((u16::try_from(f).ok()?, l))) {
            Some((f, last)) => {
                occ.insert(u32::from(f), (last, k));
                entry.address = f;
                cursor[s] = last + 1;
            }
            None => {
                let tag = raw
                    .tags
                    .get(entry.tag)
                    .map(|t| t.name.clone())
                    .unwrap_or_default();
                let path = YPath::root().key("tags").index(entry.tag);
                errors.push((
                    path,
                    ServiceError::MapFull {
                        tag,
                        space: entry.space,
                    },
                ));
            }
        }
    }
    entries.sort_by_key(|e| e.tag);
    ScadaMap { entries }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn occ(ranges: &[(u32, u32)]) -> Occupied {
        ranges
            .iter()
            .enumerate()
            .map(|(i, &(a, b))| (a, (b, i)))
            .collect()
    }

    #[test]
    fn overlap_finds_the_range_touching_an_interval() {
        let o = occ(&[(0, 0), (10, 11), (20, 21)]);
        assert_eq!(overlap(&o, 1, 9), None);
        assert_eq!(overlap(&o, 11, 12), Some((10, 11, 1)));
        assert_eq!(overlap(&o, 9, 10), Some((10, 11, 1)));
        assert_eq!(overlap(&o, 12, 19), None);
        assert_eq!(overlap(&o, 0, 0), Some((0, 0, 0)));
        assert_eq!(overlap(&o, 22, 65535), None);
    }
}
