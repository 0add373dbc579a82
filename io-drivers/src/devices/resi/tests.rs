//! Consistency of every model table: the points, the map, the ASCII commands and the state
//! agree with each other, so a new model's table is checked by adding it to [`MODELS`].

use super::ascii::command::{Action, COMMON};
use super::driver::plan;
use super::item::Item;
use super::map::{Acc, Table};
use super::model::Model;
use super::models::*;
use super::state::Module;
use super::value::Enc;
use crate::point::Access;

#[test]
fn every_point_has_an_entry_of_its_type_and_access() {
    for m in ALL {
        for p in m.points {
            let e = m
                .map
                .by_name(p.name)
                .unwrap_or_else(|| panic!("{}: {} not in the map", m.name, p.name));
            assert_eq!(e.enc.value_type(), p.ty, "{}: {}", m.name, p.name);
            match p.access {
                Access::Input => {}
                Access::Output | Access::ReadWrite => {
                    assert_eq!(e.access, Acc::ReadWrite, "{}: {}", m.name, p.name)
                }
            }
            let n = m.points.iter().filter(|q| q.name == p.name).count();
            assert_eq!(n, 1, "{}: {} twice", m.name, p.name);
        }
    }
}

#[test]
fn no_address_is_mapped_twice() {
    for m in ALL {
        let entries: Vec<_> = m.map.entries().collect();
        for (i, a) in entries.iter().enumerate() {
            assert!(
                a.reference >= 1 && a.reference <= 65536,
                "{}: {}",
                m.name,
                a.name
            );
            for b in &entries[i + 1..] {
                let overlap = a.table == b.table
                    && a.addr() < b.addr() + b.words()
                    && b.addr() < a.addr() + a.words();
                assert!(!overlap, "{}: {} and {} overlap", m.name, a.name, b.name);
            }
        }
    }
}

#[test]
fn every_mapped_item_and_command_field_exists_in_the_state() {
    for m in ALL {
        let module = Module::new(m, 1);
        for e in m.map.entries() {
            assert!(module.read(e.item).is_ok(), "{}: {} absent", m.name, e.name);
            if e.table == Table::Bits {
                assert_eq!(e.enc, Enc::Bit, "{}: {}", m.name, e.name);
            }
        }
        for c in m.commands.iter().chain(COMMON) {
            let (first, last) = c.x.unwrap_or((1, 1));
            for x in first..=last {
                let fields = match c.action {
                    Action::Get { fields, .. }
                    | Action::Set { fields }
                    | Action::SetSensorConfig { fields } => fields,
                    _ => &[],
                };
                for f in fields {
                    let item = Item::new(f.kind, f.index(x));
                    assert!(
                        module.read(item).is_ok(),
                        "{}: {}{x} reaches {item:?}",
                        m.name,
                        c.short
                    );
                }
            }
        }
    }
}

/// Points the manual gives no ASCII command for, per model: Modbus only.
fn modbus_only(m: &'static Model) -> (Vec<&'static str>, Vec<&'static str>) {
    let all: Vec<usize> = (0..m.points.len()).collect();
    let (_, unreadable) = plan::ascii(m, &all);
    let unreadable = unreadable.iter().map(|&i| m.points[i].name).collect();
    let unwritable = m
        .points
        .iter()
        .filter(|p| p.access != Access::Input)
        .filter(|p| {
            let e = m.map.by_name(p.name).unwrap();
            super::driver::ascii::ascii_set(m, e.item).is_none()
        })
        .map(|p| p.name)
        .collect();
    (unreadable, unwritable)
}

#[test]
fn ascii_covers_the_points_the_manual_gives_commands_for() {
    let expected: [(&str, &[&str], &[&str]); 9] = [
        ("resi-16di8ro", &[], &[]),
        ("resi-32di", &[], &[]),
        ("resi-14ri", &[], &[]),
        (
            "resi-8co",
            &[
                "PULSE_RO1",
                "PULSE_RO2",
                "PULSE_RO3",
                "PULSE_RO4",
                "PULSE_RO5",
                "PULSE_RO6",
                "PULSE_RO7",
                "PULSE_RO8",
            ],
            &[],
        ),
        ("resi-2ri", &[], &[]),
        ("resi-1ro", &["NTDO1"], &[]),
        (
            "resi-2rtd",
            &[
                "CH1_AVG_SUM",
                "CH2_AVG_SUM",
                "CH1_AVG_COUNT",
                "CH2_AVG_COUNT",
                "CH1_SENSOR_TYPE",
                "CH2_SENSOR_TYPE",
            ],
            &["CH1_SENSOR_TYPE", "CH2_SENSOR_TYPE"],
        ),
        ("resi-1led", &["ISFADING"], &[]),
        (
            "resi-4led",
            &["ISFADING1", "ISFADING2", "ISFADING3", "ISFADING4"],
            &[],
        ),
    ];
    for (m, (name, unreadable, unwritable)) in ALL.iter().zip(expected) {
        assert_eq!(m.name, name);
        let (r, w) = modbus_only(m);
        assert_eq!(
            (r.as_slice(), w.as_slice()),
            (unreadable, unwritable),
            "{name}"
        );
    }
}

#[test]
fn catalog_entries() {
    for (spec, m) in super::MODELS.iter().zip(ALL) {
        assert_eq!(spec.name, m.name);
        assert!(
            crate::devices::model(m.name).is_some(),
            "{} not in the catalog",
            m.name
        );
        assert_eq!(spec.points.len(), m.points.len());
        assert_eq!(spec.max_baud, m.series.max_baud());
        let sim = (spec.simulator)(7);
        assert_eq!((sim.model(), sim.address()), (m.name, 7));
        let config = spec
            .device_config("r", 7, crate::devices::Protocol::Modbus, &[])
            .unwrap();
        let mut d = (spec.driver)(&config);
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        assert!(!plan.is_empty(), "{} polls nothing", m.name);
        let poll = [("poll".to_owned(), "nope".to_owned())];
        assert!((spec.parse_settings)(&poll).is_err());
    }
}
