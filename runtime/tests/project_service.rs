//! The project file's `service:` section and each tag's `scada:`: the address map as documented
//! (file order, pinned addresses first, two registers for i32/f32), the defaults, and every
//! error at its `line:column`.

use std::path::{Path, PathBuf};
use std::time::Duration;

use softplc::project::{
    parse_str, ErrorKind, ModbusTcpConfig, Project, ProjectError, ReadGaps, ServiceError, Space,
};
use softplc_io::point::Access;

/// The file name inline projects pretend to come from (its folder has `conveyor.expr`).
fn file() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/projects/inline.yaml")
}

/// Lines 1..=10: a program, one simulated bus, one MiniMod; `tags:` is line 11.
const HEAD: &str = "\
project: t
scan:
  period: 20ms
program:
  file: conveyor.expr
  kind: expr
buses:
  - { name: line1, port: sim }
modules:
  - { name: mm1, bus: line1, model: minimod, address: 1 }
tags:
";

fn parse(text: &str) -> Project {
    parse_str(text, &file()).unwrap_or_else(|e| panic!("{e}"))
}

fn errors(text: &str) -> Vec<ProjectError> {
    match parse_str(text, &file()) {
        Ok(p) => panic!("expected errors, got {:#?}", p.service),
        Err(e) => e.errors,
    }
}

/// The single error of `text`: its position and its service error.
fn one(text: &str) -> ((usize, usize), ServiceError, String) {
    let mut e = errors(text);
    assert_eq!(e.len(), 1, "expected one error, got {e:#?}");
    let e = e.remove(0);
    match e.kind.clone() {
        ErrorKind::Service(s) => ((e.line, e.column), s, e.to_string()),
        other => panic!("not a service error: {other:?} ({e})"),
    }
}

/// (tag name, space, first address, width, writable, pinned) of every mapped tag.
fn map(p: &Project) -> Vec<(&str, Space, u16, u16, bool, bool)> {
    p.service
        .scada
        .entries
        .iter()
        .map(|e| {
            let name = p.tags[e.tag].name.as_str();
            (name, e.space, e.address, e.width, e.writable, e.pinned)
        })
        .collect()
}

#[test]
fn the_map_follows_file_order_around_pinned_addresses() {
    use Space::{Bits, Registers};
    let text = format!(
        "{HEAD}  - {{ name: a, type: bool }}
  - {{ name: b, type: bool, scada: {{ address: 1 }} }}
  - {{ name: c, type: bool }}
  - {{ name: n, type: u16, scada: write }}
  - {{ name: f, type: f32, scada: {{ access: write, address: 1 }} }}
  - {{ name: i, type: i32 }}
  - {{ name: h, type: u16, scada: none }}
  - {{ name: u, type: u16, scada: read }}
  - {{ name: x1, point: mm1.X1 }}
  - {{ name: y1, point: mm1.Y1, scada: write }}
"
    );
    let p = parse(&text);
    assert_eq!(
        map(&p),
        [
            ("a", Bits, 0, 1, false, false),
            ("b", Bits, 1, 1, false, true),
            ("c", Bits, 2, 1, false, false),
            ("n", Registers, 0, 1, true, false),
            ("f", Registers, 1, 2, true, true),
            ("i", Registers, 3, 2, false, false),
            ("u", Registers, 5, 1, false, false),
            ("x1", Bits, 3, 1, false, false),
            ("y1", Bits, 4, 1, true, false),
        ]
    );
    // Appending a tag moves no other one.
    let more = parse(&format!("{text}  - {{ name: z, type: u16 }}\n"));
    assert_eq!(map(&more)[..9], map(&p)[..]);
    assert_eq!(map(&more)[9], ("z", Registers, 6, 1, false, false));
    // No service section: nothing listens, every tag is still mapped (read-only by default).
    assert_eq!(p.service.metrics, None);
    assert_eq!(p.service.modbus_tcp, None);
}

#[test]
fn modbus_defaults_are_loopback_unit_1_and_no_writes() {
    let p = parse(&format!("{HEAD}service:\n  modbus_tcp: {{}}\n"));
    assert_eq!(
        p.service.modbus_tcp,
        Some(ModbusTcpConfig {
            bind: "127.0.0.1:5020".parse().unwrap(),
            unit: 1,
            writes: false,
            idle_timeout: Duration::from_secs(60),
            send_timeout: Duration::from_secs(10),
            read_gaps: ReadGaps::Exception,
        })
    );
    let p = parse(&format!(
        "{HEAD}service:\n  metrics: 127.0.0.1:9464\n  modbus_tcp: {{ bind: \"[::1]:1502\", unit: 247, writes: true }}\n"
    ));
    assert_eq!(p.service.metrics, Some("127.0.0.1:9464".parse().unwrap()));
    let m = p.service.modbus_tcp.unwrap();
    assert_eq!((m.bind.port(), m.unit, m.writes), (1502, 247, true));
    // Remote writes, said explicitly.
    let p = parse(&format!(
        "{HEAD}service:\n  modbus_tcp: {{ bind: 0.0.0.0:5020, writes: true, allow_remote_writes: true }}\n"
    ));
    assert!(p.service.modbus_tcp.unwrap().writes);
}

#[test]
fn addresses_must_be_ip_and_port() {
    let (at, e, shown) = one(&format!("{HEAD}service:\n  metrics: localhost:9464\n"));
    assert_eq!(at, (13, 12));
    assert!(
        matches!(
            e,
            ServiceError::BadAddress {
                key: "service.metrics",
                ..
            }
        ),
        "{e:?}"
    );
    assert!(shown.ends_with("inline.yaml:13:12: error: service.metrics \"localhost:9464\" is not an address: write IP:PORT, like 127.0.0.1:9464 (IPv6 in quotes: \"[::1]:9464\")"), "{shown}");
    let (at, e, _) = one(&format!(
        "{HEAD}service:\n  modbus_tcp:\n    bind: 127.0.0.1\n"
    ));
    assert_eq!(at, (14, 11));
    assert!(matches!(
        e,
        ServiceError::BadAddress {
            key: "service.modbus_tcp.bind",
            ..
        }
    ));
    let (at, e, _) = one(&format!(
        "{HEAD}service:\n  metrics: 127.0.0.1:9000\n  modbus_tcp: {{ bind: 127.0.0.1:9000 }}\n"
    ));
    assert_eq!(at, (14, 23));
    assert!(matches!(e, ServiceError::SameAddress { .. }), "{e:?}");
}

#[test]
fn modbus_timeouts_are_durations_above_zero() {
    let p = parse(&format!(
        "{HEAD}service:\n  modbus_tcp: {{ idle_timeout: 1.5s, send_timeout: 250ms }}\n"
    ));
    let m = p.service.modbus_tcp.unwrap();
    assert_eq!(
        (m.idle_timeout, m.send_timeout),
        (Duration::from_millis(1500), Duration::from_millis(250))
    );
    let (at, e, shown) = one(&format!(
        "{HEAD}service:\n  modbus_tcp:\n    send_timeout: 0s\n"
    ));
    assert_eq!(at, (14, 19));
    assert_eq!(
        e,
        ServiceError::ZeroTimeout {
            key: "send_timeout"
        }
    );
    assert!(
        shown.ends_with("service.modbus_tcp.send_timeout must be longer than zero"),
        "{shown}"
    );
    let (at, e, _) = one(&format!(
        "{HEAD}service:\n  modbus_tcp: {{ idle_timeout: 0ms }}\n"
    ));
    assert_eq!(at, (13, 31));
    assert_eq!(
        e,
        ServiceError::ZeroTimeout {
            key: "idle_timeout"
        }
    );
    // A bare number is ambiguous, as everywhere in the file.
    let e = errors(&format!(
        "{HEAD}service:\n  modbus_tcp: {{ idle_timeout: 60 }}\n"
    ));
    assert_eq!((e.len(), e[0].line), (1, 13), "{e:?}");
}

#[test]
fn unit_range() {
    for bad in [0, 248, 255, -1] {
        let (at, e, _) = one(&format!(
            "{HEAD}service:\n  modbus_tcp: {{ unit: {bad} }}\n"
        ));
        assert_eq!(at, (13, 23), "{bad}");
        assert_eq!(e, ServiceError::BadUnit { value: bad });
    }
}

#[test]
fn remote_writes_need_to_be_allowed_explicitly() {
    let (at, e, shown) = one(&format!(
        "{HEAD}service:\n  modbus_tcp:\n    bind: 0.0.0.0:5020\n    writes: true\n"
    ));
    assert_eq!(at, (15, 13));
    assert_eq!(
        e,
        ServiceError::RemoteWrites {
            bind: "0.0.0.0:5020".parse().unwrap()
        }
    );
    assert!(
        shown.contains("need `allow_remote_writes: true`"),
        "{shown}"
    );
    // Reading from beyond loopback is a choice, not a hazard.
    parse(&format!(
        "{HEAD}service:\n  modbus_tcp: {{ bind: 0.0.0.0:5020 }}\n"
    ));
}

#[test]
fn writes_only_on_memory_tags_and_outputs() {
    let (at, e, shown) = one(&format!(
        "{HEAD}  - {{ name: x1, point: mm1.X1, scada: write }}\n"
    ));
    assert_eq!(at, (12, 39));
    assert_eq!(
        e,
        ServiceError::WriteOnInput {
            tag: "x1".into(),
            point: "mm1.X1".into(),
            access: Access::Input
        }
    );
    assert!(shown.ends_with("error: tag x1: `scada: write` is only allowed on memory tags and outputs; mm1.X1 is an input the module overwrites every scan"), "{shown}");
    let (at, _, _) = one(&format!(
        "{HEAD}  - name: x1\n    point: mm1.X1\n    scada: {{ access: write, address: 4 }}\n"
    ));
    assert_eq!(at, (14, 22));
}

#[test]
fn pinned_addresses_must_not_overlap() {
    let (at, e, shown) = one(&format!(
        "{HEAD}  - {{ name: t, type: i32, scada: {{ address: 10 }} }}
  - {{ name: u, type: u16, scada: {{ address: 11 }} }}
  - {{ name: b, type: bool, scada: {{ address: 11 }} }}
"
    ));
    assert_eq!(at, (13, 45));
    assert_eq!(
        e,
        ServiceError::AddressTaken {
            tag: "u".into(),
            space: Space::Registers,
            address: 11,
            other: "t".into(),
            other_first: 10,
            other_last: 11,
            other_line: 12,
        }
    );
    assert!(
        shown.ends_with(
            "error: tag u: register address 11 overlaps tag t (register 10..=11, line 12)"
        ),
        "{shown}"
    );
}

#[test]
fn address_range_and_hidden_tags() {
    let (at, e, _) = one(&format!(
        "{HEAD}  - {{ name: t, type: f32, scada: {{ address: 65535 }} }}\n"
    ));
    assert_eq!(at, (12, 45));
    assert_eq!(
        e,
        ServiceError::AddressOutOfRange {
            tag: "t".into(),
            space: Space::Registers,
            address: 65535,
            max: 65534
        }
    );
    let (_, e, _) = one(&format!(
        "{HEAD}  - {{ name: t, type: bool, scada: {{ address: -1 }} }}\n"
    ));
    assert!(
        matches!(e, ServiceError::AddressOutOfRange { max: 65535, .. }),
        "{e:?}"
    );
    parse(&format!(
        "{HEAD}  - {{ name: t, type: bool, scada: {{ address: 65535 }} }}\n"
    ));
    let (at, e, _) = one(&format!(
        "{HEAD}  - {{ name: t, type: u16, scada: {{ access: none, address: 3 }} }}\n"
    ));
    assert_eq!(at, (12, 59));
    assert_eq!(e, ServiceError::AddressOnHidden { tag: "t".into() });
}

#[test]
fn reader_errors_in_scada_and_service() {
    let e = errors(&format!("{HEAD}  - {{ name: t, type: u16, scada: rw }}\n"));
    assert_eq!(e.len(), 1);
    assert_eq!((e[0].line, e[0].column), (12, 34));
    assert!(
        e[0].to_string()
            .contains("unknown variant `rw`, expected one of `read`, `write`, `none`"),
        "{}",
        e[0]
    );
    let e = errors(&format!(
        "{HEAD}  - {{ name: t, type: u16, scada: {{ adress: 3 }} }}\n"
    ));
    assert_eq!(e.len(), 1);
    assert!(
        matches!(&e[0].kind, ErrorKind::UnknownKey { key, .. } if key == "adress"),
        "{:?}",
        e[0]
    );
    assert_eq!(e[0].line, 12);
    let e = errors(&format!("{HEAD}service:\n  modbus_tcp: {{ port: 502 }}\n"));
    assert!(
        matches!(&e[0].kind, ErrorKind::UnknownKey { key, expected, .. } if key == "port" && expected.contains("`bind`")),
        "{:?}",
        e[0]
    );
}

#[test]
fn every_error_at_once() {
    let e = errors(&format!(
        "{HEAD}  - {{ name: x1, point: mm1.X1, scada: write }}\nservice:\n  metrics: nowhere\n  modbus_tcp: {{ unit: 0 }}\n"
    ));
    let found: Vec<(usize, usize)> = e.iter().map(|e| (e.line, e.column)).collect();
    assert_eq!(found, [(12, 39), (14, 12), (15, 23)], "{e:#?}");
}
