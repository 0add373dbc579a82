//! A profile file's [`RawProfile`] checked into a [`Profile`]: names, words, ranges, which
//! types and accesses each table takes, poll groups and behaviours that name what exists; every
//! error found, each at its node.

use std::collections::HashMap;
use std::path::Path;
use std::time::Duration;

use softplc_io::devices::profile::{
    Behaviour, BitField, DataType, DeviceTiming, PointAccess, PollGroup, Profile, ProfilePoint,
    RequestLimits, Scaling, Table, WordOrder, WriteMode,
};

use super::error::ProfileError;
use super::raw::{RawPoint, RawProfile};
use super::{ACCESS, TABLES, WRITES};
use crate::project::error::{ErrorKind, ProjectError};
use crate::project::raw::parse_duration;
use crate::project::span::{Locator, YPath};

/// The default poll group's name, when the profile has none.
const DEFAULT_GROUP: &str = "cycle";

struct Checker<'a> {
    loc: Locator<'a>,
    file: &'a Path,
    errors: Vec<ProjectError>,
}

impl Checker<'_> {
    fn error(&mut self, path: &YPath, e: ProfileError) {
        let (line, column) = self.loc.position(path);
        self.errors.push(ProjectError {
            file: self.file.to_path_buf(),
            line,
            column,
            kind: ErrorKind::Profile(e),
        });
    }

    /// A number in `min..=max`, or an error at `path`.
    fn ranged(
        &mut self,
        path: &YPath,
        key: &'static str,
        given: i64,
        min: i64,
        max: i64,
    ) -> Option<i64> {
        if (min..=max).contains(&given) {
            Some(given)
        } else {
            self.error(
                path,
                ProfileError::OutOfRange {
                    key,
                    given,
                    min,
                    max,
                },
            );
            None
        }
    }

    /// The word `given` among `words` (by name), or an error at `path`.
    fn word<T: Copy>(
        &mut self,
        path: &YPath,
        what: &'static str,
        given: &str,
        words: &[(&'static str, T)],
    ) -> Option<T> {
        if let Some((_, v)) = words.iter().find(|(w, _)| *w == given) {
            return Some(*v);
        }
        let known = words.iter().map(|(w, _)| *w).collect();
        self.error(
            path,
            ProfileError::UnknownWord {
                what,
                given: given.to_owned(),
                known,
            },
        );
        None
    }

    fn identifier(&mut self, path: &YPath, what: &'static str, name: &str) -> bool {
        if crate::project::validate::is_identifier(name) {
            true
        } else {
            self.error(
                path,
                ProfileError::BadName {
                    what,
                    name: name.to_owned(),
                },
            );
            false
        }
    }

    fn duration(&mut self, d: Option<&crate::project::raw::DurationText>) -> Option<Duration> {
        d.map(|d| d.0)
    }
}

/// Checks `raw` (read from `text`, the file `file`).
pub(super) fn validate(
    raw: &RawProfile,
    text: &str,
    file: &Path,
) -> Result<Profile, Vec<ProjectError>> {
    let mut c = Checker {
        loc: Locator::new(text),
        file,
        errors: Vec::new(),
    };
    let root = YPath::root();
    let model_ok = !raw.model.is_empty()
        && raw
            .model
            .chars()
            .all(|ch| ch.is_ascii_alphanumeric() || ch == '-' || ch == '_');
    if !model_ok {
        c.error(
            &root.key("model"),
            ProfileError::BadModel(raw.model.clone()),
        );
    }

    let mut addresses = 1..=247u8;
    if let Some(a) = &raw.addresses {
        let p = root.key("addresses");
        let min = c.ranged(&p.key("min"), "min", a.min.0, 1, 247);
        let max = c.ranged(&p.key("max"), "max", a.max.0, min.unwrap_or(1), 247);
        if let (Some(min), Some(max)) = (min, max) {
            addresses = min as u8..=max as u8;
        }
    }
    let max_baud = match &raw.max_baud {
        Some(b) => c
            .ranged(&root.key("max_baud"), "max_baud", b.0, 300, 4_000_000)
            .unwrap_or(115_200) as u32,
        None => 115_200,
    };
    let timing = match &raw.timing {
        Some(t) => DeviceTiming {
            reply_timeout: c.duration(t.reply_timeout.as_ref()),
            frame_gap: c.duration(t.frame_gap.as_ref()),
            reply_delay: c
                .duration(t.reply_delay.as_ref())
                .unwrap_or(Duration::from_millis(5)),
        },
        None => DeviceTiming {
            reply_timeout: None,
            frame_gap: None,
            reply_delay: Duration::from_millis(5),
        },
    };
    if timing.reply_timeout.is_some_and(|t| t.is_zero()) {
        let p = root.key("timing").key("reply_timeout");
        c.error(
            &p,
            ProfileError::OutOfRange {
                key: "reply_timeout",
                given: 0,
                min: 1,
                max: i64::MAX,
            },
        );
    }
    let mut limits = RequestLimits::default();
    if let Some(r) = &raw.requests {
        let p = root.key("requests");
        if let Some(n) = &r.max_registers {
            if let Some(n) = c.ranged(&p.key("max_registers"), "max_registers", n.0, 1, 125) {
                limits.max_registers = n as u16;
            }
        }
        if let Some(n) = &r.max_bits {
            if let Some(n) = c.ranged(&p.key("max_bits"), "max_bits", n.0, 1, 2000) {
                limits.max_bits = n as u16;
            }
        }
        limits.read_gaps = r.read_gaps.unwrap_or(false);
        limits.write_multiple = r.write_multiple.unwrap_or(false);
    }

    // Poll groups.
    let mut groups = Vec::new();
    let mut group_line: HashMap<String, usize> = HashMap::new();
    match &raw.poll {
        Some(list) if !list.is_empty() => {
            for (i, g) in list.iter().enumerate() {
                let p = root.key("poll").index(i);
                c.identifier(&p.key("name"), "poll group", &g.name);
                if let Some(&line) = group_line.get(&g.name) {
                    let e = ProfileError::Duplicate {
                        what: "poll group",
                        name: g.name.clone(),
                        line,
                    };
                    c.error(&p.key("name"), e);
                } else {
                    group_line.insert(g.name.clone(), c.loc.line(&p.key("name")));
                }
                let period = match g.period.trim() {
                    "cycle" => None,
                    text => match parse_duration(text) {
                        Ok(d) if !d.is_zero() => Some(d),
                        Ok(_) => {
                            let e = ProfileError::BadPeriod {
                                given: text.to_owned(),
                                why: "zero".into(),
                            };
                            c.error(&p.key("period"), e);
                            None
                        }
                        Err(why) => {
                            let e = ProfileError::BadPeriod {
                                given: text.to_owned(),
                                why: why.to_string(),
                            };
                            c.error(&p.key("period"), e);
                            None
                        }
                    },
                };
                groups.push(PollGroup {
                    name: g.name.clone(),
                    period,
                });
            }
        }
        _ => groups.push(PollGroup {
            name: DEFAULT_GROUP.into(),
            period: None,
        }),
    }

    // The names of points and bit fields (one name space: the project's), then each point.
    let mut names: HashMap<&str, usize> = HashMap::new();
    for (i, rp) in raw.points.iter().enumerate() {
        let p = root.key("points").index(i);
        let mut named = vec![(rp.name.as_str(), p.key("name"))];
        for (b, f) in rp.bits.iter().flatten().enumerate() {
            named.push((f.name.as_str(), p.key("bits").index(b).key("name")));
        }
        for (name, at) in named {
            if let Some(&line) = names.get(name) {
                let e = ProfileError::Duplicate {
                    what: "point",
                    name: name.to_owned(),
                    line,
                };
                c.error(&at, e);
            } else {
                names.insert(name, c.loc.line(&at));
            }
        }
    }
    let mut points = Vec::new();
    for (i, rp) in raw.points.iter().enumerate() {
        let p = root.key("points").index(i);
        if let Some(point) = point(&mut c, &p, rp, &groups) {
            points.push(point);
        }
    }

    // Behaviours, by the points' names (indexes are the file's: the profile is refused
    // unless every point is good).
    let mut behaviours = Vec::new();
    let mut known: Vec<String> = Vec::new();
    for rp in &raw.points {
        if !known.contains(&rp.name) {
            known.push(rp.name.clone());
        }
    }
    for (i, b) in raw.simulate.iter().flatten().enumerate() {
        let p = root.key("simulate").index(i);
        let find = |c: &mut Checker<'_>, key: &str, name: &str| {
            let found = raw.points.iter().position(|q| q.name == name);
            if found.is_none() {
                let e = ProfileError::NoSuch {
                    what: "point",
                    name: name.to_owned(),
                    known: known.clone(),
                };
                c.error(&p.key(key), e);
            }
            found
        };
        let point = find(&mut c, "point", &b.point);
        let source = find(&mut c, "follows", &b.follows);
        if let (Some(point), Some(source)) = (point, source) {
            let bits = |i: usize| {
                TABLES
                    .iter()
                    .any(|t| t.is_bits() && t.name() == raw.points[i].table)
            };
            if point == source {
                c.error(
                    &p.key("follows"),
                    ProfileError::BadBehaviour("a point cannot follow itself"),
                );
            } else if bits(point) || bits(source) {
                c.error(
                    &p.key("point"),
                    ProfileError::BadBehaviour("a lag moves registers, not bits"),
                );
            } else {
                behaviours.push(Behaviour::Follow {
                    point,
                    source,
                    time_constant: b.time_constant.0,
                });
            }
        }
    }

    if c.errors.is_empty() {
        Ok(Profile {
            model: raw.model.clone(),
            summary: raw.summary.clone().unwrap_or_else(|| raw.model.clone()),
            source: raw.source.clone(),
            addresses,
            max_baud,
            points,
            groups,
            limits,
            timing,
            behaviours,
        })
    } else {
        Err(c.errors)
    }
}

/// One point, or `None` after its errors.
fn point(
    c: &mut Checker<'_>,
    p: &YPath,
    rp: &RawPoint,
    groups: &[PollGroup],
) -> Option<ProfilePoint> {
    let errors = c.errors.len();
    c.identifier(&p.key("name"), "point", &rp.name);
    let tables: Vec<(&'static str, Table)> = TABLES.iter().map(|t| (t.name(), *t)).collect();
    let table = c.word(&p.key("table"), "table", &rp.table, &tables);
    let types: Vec<(&'static str, DataType)> =
        DataType::ALL.iter().map(|t| (t.name(), *t)).collect();
    let data = match (&rp.ty, table) {
        (Some(t), _) => c.word(&p.key("type"), "type", t, &types),
        (None, Some(t)) if t.is_bits() => Some(DataType::Bool),
        (None, _) => Some(DataType::U16),
    };
    let orders: Vec<(&'static str, WordOrder)> =
        WordOrder::ALL.iter().map(|o| (o.name(), *o)).collect();
    let order = match &rp.order {
        Some(o) => c.word(&p.key("order"), "order", o, &orders),
        None => Some(WordOrder::Abcd),
    };
    let accesses: Vec<(&'static str, PointAccess)> =
        ACCESS.iter().map(|a| (a.name(), *a)).collect();
    let access = match &rp.access {
        Some(a) => c.word(&p.key("access"), "access", a, &accesses),
        None => Some(PointAccess::Read),
    };
    let write = match &rp.write {
        Some(w) => c.word(&p.key("write"), "write", w, &WRITES),
        None => Some(WriteMode::OnChange),
    };
    let group = match &rp.poll {
        Some(name) => match groups.iter().position(|g| &g.name == name) {
            Some(g) => Some(g),
            None => {
                let mut known: Vec<String> = groups.iter().map(|g| g.name.clone()).collect();
                known.dedup();
                c.error(
                    &p.key("poll"),
                    ProfileError::NoSuch {
                        what: "poll group",
                        name: name.clone(),
                        known,
                    },
                );
                None
            }
        },
        None => Some(0),
    };
    let address = c
        .ranged(&p.key("address"), "address", rp.address.0, 0, 65535)
        .map(|a| a as u16);

    if let (Some(table), Some(data)) = (table, data) {
        if table.is_bits() != (data == DataType::Bool) {
            let (expected, given) = if table.is_bits() {
                ("bool", data.name())
            } else {
                ("u16, i16, u32, i32 or f32", data.name())
            };
            c.error(
                &p.key("type"),
                ProfileError::TypeNotInTable {
                    table: table.name(),
                    expected,
                    given,
                },
            );
        }
        if let Some(a) = address {
            if u32::from(a) + u32::from(data.words()) > 65536 {
                c.error(
                    &p.key("address"),
                    ProfileError::PastEnd {
                        data: data.name(),
                        address: a,
                    },
                );
            }
        }
        if rp.order.is_some() && data.words() != 2 {
            c.error(
                &p.key("order"),
                ProfileError::DoesNotApply {
                    key: "order",
                    why: "a 16-bit or bit point",
                },
            );
        }
        if table.is_bits() {
            for (key, given) in [
                ("scale", rp.scale.is_some()),
                ("offset", rp.offset.is_some()),
                ("bits", rp.bits.is_some()),
            ] {
                if given {
                    c.error(
                        &p.key(key),
                        ProfileError::DoesNotApply {
                            key,
                            why: "a coil or discrete input",
                        },
                    );
                }
            }
        }
        if data == DataType::F32 && rp.bits.is_some() {
            c.error(
                &p.key("bits"),
                ProfileError::DoesNotApply {
                    key: "bits",
                    why: "an f32",
                },
            );
        }
        if let Some(access) = access {
            if access.writes() && !table.is_writable() {
                c.error(
                    &p.key("access"),
                    ProfileError::ReadOnlyTable {
                        table: table.name(),
                    },
                );
            }
            if !access.writes() && rp.write.is_some() {
                c.error(
                    &p.key("write"),
                    ProfileError::DoesNotApply {
                        key: "write",
                        why: "a point the program does not write (access: read)",
                    },
                );
            }
            if !access.reads() && rp.poll.is_some() {
                c.error(
                    &p.key("poll"),
                    ProfileError::DoesNotApply {
                        key: "poll",
                        why: "a write-only point (access: write)",
                    },
                );
            }
        }
        {
            let width_bits = (data.words() * 16) as u8;
            for (b, f) in rp.bits.iter().flatten().enumerate() {
                let fp = p.key("bits").index(b);
                c.identifier(&fp.key("name"), "bit field", &f.name);
                let width = f.width.as_ref().map_or(1, |w| w.0);
                let first = f.bit.0;
                let last = first + width - 1;
                if width < 1 {
                    c.ranged(&fp.key("width"), "width", width, 1, 16);
                } else if first < 0 || last >= i64::from(width_bits) {
                    c.error(
                        &fp.key("bit"),
                        ProfileError::BitsOutside {
                            first,
                            last,
                            bits: width_bits,
                        },
                    );
                }
            }
        }
    }
    if rp.scale == Some(0.0) {
        c.error(&p.key("scale"), ProfileError::ZeroScale);
    }
    if let Some([low, high]) = rp.range {
        if !(low.is_finite() && high.is_finite() && low < high) {
            c.error(&p.key("range"), ProfileError::BadRange);
        }
    }
    for (key, v) in [
        ("scale", rp.scale),
        ("offset", rp.offset),
        ("initial", rp.initial),
    ] {
        if v.is_some_and(|v| !v.is_finite()) {
            c.error(
                &p.key(key),
                ProfileError::DoesNotApply {
                    key,
                    why: "a value that is not a finite number",
                },
            );
        }
    }
    if c.errors.len() != errors {
        return None;
    }
    let (table, data, order, access, write, group, address) =
        (table?, data?, order?, access?, write?, group?, address?);
    let scaling = (rp.scale.is_some() || rp.offset.is_some()).then(|| Scaling {
        scale: rp.scale.unwrap_or(1.0),
        offset: rp.offset.unwrap_or(0.0),
    });
    let bits = rp
        .bits
        .iter()
        .flatten()
        .map(|f| BitField {
            name: f.name.clone(),
            bit: f.bit.0 as u8,
            width: f.width.as_ref().map_or(1, |w| w.0 as u8),
            manual: f.manual.clone(),
        })
        .collect();
    Some(ProfilePoint {
        name: rp.name.clone(),
        table,
        address,
        data,
        order,
        scaling,
        unit: rp.unit.clone(),
        range: rp.range.map(|[low, high]| (low, high)),
        access,
        manual: rp.manual.clone(),
        group,
        write,
        bits,
        initial: rp.initial.unwrap_or(0.0),
    })
}
