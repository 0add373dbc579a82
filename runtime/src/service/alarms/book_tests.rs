//! The book driven by cycles on the virtual clock: raise, clear and acknowledge with their
//! stamps, a one-cycle transient, the history's bound and restore, a lost module's folding.

use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, SystemTime};

use softplc_io::point::{Quality, Value};
use softplc_io::time::ScanInstant;

use super::*;
use crate::service::changes::{CycleChanges, Delivery, TagChange};

/// Tags 0 `jam` (bool alarm, high), 1 `air_ok` (alarm when false) on mm1; 2 `level` (f32
/// memory, alarm above 95, urgent); 3 `setpoint`, on the operator's page.
fn project(history: usize) -> Project {
    let text = format!(
        "project: t\nscan: {{ period: 10ms }}\nalarms: {{ history: {history} }}\n\
         buses: [ {{ name: line1, port: sim }} ]\n\
         modules: [ {{ name: mm1, bus: line1, model: minimod, address: 1 }} ]\n\
         tags:\n\
         \x20 - {{ name: jam, point: mm1.X1, alarm: {{ text: Door jammed, priority: high }} }}\n\
         \x20 - {{ name: air_ok, point: mm1.X2, alarm: {{ text: No air, when: false }} }}\n\
         \x20 - {{ name: level, type: f32, alarm: {{ text: Overflow, when: \"> 95\", priority: 900 }} }}\n\
         \x20 - {{ name: setpoint, type: u16, operator: true }}\n\
         program: {{ file: conveyor.expr, kind: expr }}\n"
    );
    let file =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/projects/inline.yaml");
    crate::project::parse_str(&text, &file).unwrap_or_else(|e| panic!("{e}"))
}

/// 2026-01-01T00:00:00Z.
fn origin() -> SystemTime {
    SystemTime::UNIX_EPOCH + Duration::from_secs(1_767_225_600)
}

fn book(history: usize) -> AlarmBook {
    AlarmBook::new(&project(history), origin())
}

/// Cycle `n` at `10 n` ms, changing `tags` (good) and `modules`.
fn cycle(n: u64, tags: &[(usize, Value)], modules: &[(usize, Quality)]) -> Delivery {
    cycle_q(
        n,
        &tags
            .iter()
            .map(|&(t, v)| (t, v, Quality::Good))
            .collect::<Vec<_>>(),
        modules,
    )
}

fn cycle_q(n: u64, tags: &[(usize, Value, Quality)], modules: &[(usize, Quality)]) -> Delivery {
    Delivery {
        cycle: Arc::new(CycleChanges {
            task: 0,
            cycle: n,
            at: ScanInstant::after_origin(Duration::from_millis(10 * n)),
            changes: tags
                .iter()
                .map(|&(tag, value, quality)| TagChange {
                    tag,
                    value,
                    quality,
                })
                .collect(),
            modules: modules.to_vec(),
        }),
        catch_up: Vec::new(),
        overflowed: Vec::new(),
        modules_catch_up: Vec::new(),
    }
}

/// The first cycle: every tag, the module good; nothing active.
fn first() -> Delivery {
    cycle(
        1,
        &[
            (0, Value::Bool(false)),
            (1, Value::Bool(true)),
            (2, Value::F32(10.0)),
            (3, Value::U16(0)),
        ],
        &[(0, Quality::Good)],
    )
}

fn events(b: &AlarmBook) -> Vec<(u64, String, EventKind)> {
    b.events()
        .map(|e| (e.cycle, e.alarm.clone(), e.event))
        .collect()
}

#[test]
fn an_alarm_is_raised_cleared_and_acknowledged_with_utc_and_the_cycle() {
    let mut b = book(1000);
    assert!(!b.apply(&first()), "nothing active at the start");
    assert!(b.current().is_empty());
    assert!(b.apply(&cycle(5, &[(0, Value::Bool(true))], &[])));
    let now = b.current();
    assert_eq!(now.len(), 1);
    let jam = &now[0];
    assert_eq!(
        (jam.name.as_str(), jam.text.as_str()),
        ("jam", "Door jammed")
    );
    assert_eq!((jam.priority, jam.level.as_str()), (750, "high"));
    assert!(jam.active && !jam.acknowledged);
    assert_eq!(
        jam.raised,
        Some(Stamp {
            utc: "2026-01-01T00:00:00.050Z".into(),
            cycle: 5
        })
    );
    assert_eq!(b.counts().active, [0, 0, 1, 0]);
    assert_eq!(b.counts().unacknowledged, 1);
    // Cleared but not acknowledged: still in the list, waiting.
    b.apply(&cycle(9, &[(0, Value::Bool(false))], &[]));
    let now = b.current();
    assert!(!now[0].active && !now[0].acknowledged);
    assert_eq!(now[0].cleared.as_ref().map(|s| s.cycle), Some(9));
    let at = ScanInstant::after_origin(Duration::from_millis(120));
    assert_eq!(
        b.acknowledge("jam", "web 127.0.0.1:5000 operator", 12, at),
        Ok(vec!["jam".to_string()])
    );
    assert!(b.current().is_empty(), "cleared and acknowledged: gone");
    let all = b.all();
    assert_eq!(
        all[0].acked,
        Some(Stamp {
            utc: "2026-01-01T00:00:00.120Z".into(),
            cycle: 12
        })
    );
    assert_eq!(
        all[0].acked_by.as_deref(),
        Some("web 127.0.0.1:5000 operator")
    );
    assert_eq!(
        events(&b),
        [
            (5, "jam".into(), EventKind::Raised),
            (9, "jam".into(), EventKind::Cleared),
            (12, "jam".into(), EventKind::Acknowledged)
        ]
    );
    assert_eq!(
        b.history(1)[0].by.as_deref(),
        Some("web 127.0.0.1:5000 operator")
    );
    // Twice is refused with the reason; an unknown name with the closest one.
    let e = b.acknowledge("jam", "cli", 13, at).unwrap_err();
    assert_eq!(
        e.to_string(),
        "alarm jam is not waiting for an acknowledgement"
    );
    let e = b.acknowledge("jamm", "cli", 13, at).unwrap_err();
    assert_eq!(e.to_string(), "no alarm jamm (did you mean jam?)");
}

#[test]
fn the_list_puts_those_waiting_first_then_the_highest_priority() {
    let mut b = book(1000);
    b.apply(&first());
    b.apply(&cycle(
        2,
        &[(0, Value::Bool(true)), (1, Value::Bool(false))],
        &[],
    ));
    b.apply(&cycle(3, &[(2, Value::F32(96.0))], &[]));
    let at = ScanInstant::after_origin(Duration::from_millis(40));
    b.acknowledge("level", "cli", 4, at).unwrap();
    let names: Vec<String> = b.current().into_iter().map(|a| a.name).collect();
    // jam (high, 750) before air_ok (medium), both waiting; level (urgent) acknowledged last.
    assert_eq!(names, ["jam", "air_ok", "level"]);
    assert_eq!(b.counts().active, [0, 1, 1, 1]);
    assert_eq!(b.counts().unacknowledged, 2);
    assert_eq!(b.acknowledge("all", "cli", 5, at).map(|n| n.len()), Ok(2));
    assert_eq!(b.counts().unacknowledged, 0);
    assert_eq!(b.acknowledge("all", "cli", 6, at), Ok(vec![]));
}

#[test]
fn a_one_cycle_transient_is_raised_and_cleared_in_the_history() {
    let mut b = book(1000);
    b.apply(&first());
    b.apply(&cycle(7, &[(2, Value::F32(99.5))], &[]));
    b.apply(&cycle(8, &[(2, Value::F32(50.0))], &[]));
    assert_eq!(
        events(&b),
        [
            (7, "level".into(), EventKind::Raised),
            (8, "level".into(), EventKind::Cleared)
        ]
    );
    // It came and went, and waits for the operator.
    let level = &b.current()[0];
    assert!(!level.active && !level.acknowledged);
}

#[test]
fn the_history_keeps_the_latest_events_and_comes_back_with_their_states() {
    let mut b = book(10);
    b.apply(&first());
    for n in 0..8u64 {
        b.apply(&cycle(2 + 2 * n, &[(0, Value::Bool(true))], &[]));
        b.apply(&cycle(3 + 2 * n, &[(0, Value::Bool(false))], &[]));
    }
    b.apply(&cycle(30, &[(2, Value::F32(100.0))], &[]));
    let kept: Vec<AlarmEvent> = b.events().cloned().collect();
    assert_eq!(kept.len(), 10, "the bound");
    assert_eq!(kept[9].alarm, "level");
    assert_eq!(kept[0].cycle, 9, "the oldest went first");
    // A restart: the same events, level still raised and waiting, jam waiting too.
    let mut again = book(10);
    again.restore(kept.clone());
    assert_eq!(again.events().cloned().collect::<Vec<_>>(), kept);
    let names: Vec<(String, bool)> = again
        .current()
        .into_iter()
        .map(|a| (a.name, a.active))
        .collect();
    assert_eq!(names, [("level".into(), true), ("jam".into(), false)]);
    // The first cycle after it finds level still high: no second raise.
    let mut f = first();
    Arc::make_mut(&mut f.cycle).changes[2].value = Value::F32(100.0);
    again.apply(&f);
    assert_eq!(again.events().count(), 10);
    assert_eq!(again.events().last().map(|e| e.cycle), Some(30));
}

#[test]
fn a_lost_module_is_one_alarm_and_its_tags_alarms_are_held() {
    let mut b = book(1000);
    b.apply(&first());
    // The line dies: the module's quality goes bad, its inputs too (air_ok's value would
    // raise "No air" if it were believed).
    b.apply(&cycle_q(
        4,
        &[
            (0, Value::Bool(false), Quality::Bad),
            (1, Value::Bool(false), Quality::Bad),
        ],
        &[(0, Quality::Bad)],
    ));
    let now = b.current();
    assert_eq!(now.len(), 1, "{now:?}");
    assert_eq!(
        (now[0].name.as_str(), now[0].text.as_str(), now[0].priority),
        ("lost.mm1", "module lost: mm1", 750)
    );
    // A stale read (the module not lost yet) is believed: nothing raised without the loss.
    // Back: lost.mm1 clears, and air_ok, now really false, is raised.
    b.apply(&cycle(
        9,
        &[(0, Value::Bool(false)), (1, Value::Bool(false))],
        &[(0, Quality::Good)],
    ));
    assert_eq!(
        events(&b),
        [
            (4, "lost.mm1".into(), EventKind::Raised),
            (9, "lost.mm1".into(), EventKind::Cleared),
            (9, "air_ok".into(), EventKind::Raised)
        ]
    );
}

#[test]
fn a_reader_takes_the_events_since_its_count_even_past_the_history_s_bound() {
    let mut b = book(10);
    b.apply(&first());
    assert_eq!(b.events_since(0), (Vec::new(), 0));
    b.apply(&cycle(2, &[(0, Value::Bool(true))], &[]));
    let (new, seen) = b.events_since(0);
    assert_eq!(seen, 1);
    assert_eq!((new[0].cycle, new[0].event), (2, EventKind::Raised));
    assert_eq!(b.events_since(seen), (Vec::new(), 1));
    // Twelve events in one go: the history keeps 10, the reader gets those 10, the newest last.
    for n in 0..6 {
        b.apply(&cycle(3 + 2 * n, &[(0, Value::Bool(false))], &[]));
        b.apply(&cycle(4 + 2 * n, &[(0, Value::Bool(true))], &[]));
    }
    let (new, seen) = b.events_since(seen);
    assert_eq!(seen, 13);
    assert_eq!(new.len(), 10);
    assert_eq!(
        new.last().map(|e| (e.cycle, e.event)),
        Some((14, EventKind::Raised))
    );
}
