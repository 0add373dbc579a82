//! Byte-exact vectors of the format, and damage that must read as a torn tail.

use std::time::Duration;

use softplc_io::point::{Quality, Value, ValueType};

use super::frame::CASTAGNOLI;
use super::*;

fn header() -> Header {
    Header {
        project: "quickstart".into(),
        project_hash: digest(b"project"),
        program_hash: digest(b"program"),
        program_file: "conveyor.expr".into(),
        period: Duration::from_millis(100),
        virtual_clock: true,
        run_id: 1_764_000_000_000_000_000,
        wall_origin: 1_763_999_999_000_000_000,
        segment: 3,
        tags: vec![
            TagInfo {
                name: "start".into(),
                ty: ValueType::Bool,
                role: TagRole::Input,
            },
            TagInfo {
                name: "level".into(),
                ty: ValueType::I32,
                role: TagRole::Memory,
            },
        ],
        task: None,
    }
}

#[test]
fn the_checksum_is_crc_32c() {
    // The check value of CRC-32C (Castagnoli).
    assert_eq!(CASTAGNOLI.checksum(b"123456789"), 0xE306_9283);
}

#[test]
fn a_block_is_framed_byte_for_byte() {
    let block = frame(
        BlockKind::End,
        &Enc::end(&End {
            cycles: 300,
            dropped: 0,
        }),
    );
    // length 4 (kind + 3 bytes), CRC-32C of the body, kind 4, varint 300 = ac 02, 0.
    let body = [4u8, 0xac, 0x02, 0x00];
    let crc = CASTAGNOLI.checksum(&body).to_le_bytes();
    let mut expected = vec![4, 0, 0, 0];
    expected.extend_from_slice(&crc);
    expected.extend_from_slice(&body);
    assert_eq!(block, expected);
    assert_eq!(
        next_block(&block, 0),
        Framed::Block(BlockKind::End, &body[1..], block.len())
    );
}

#[test]
fn values_encode_compactly_and_round_trip() {
    let mut e = Enc::default();
    e.value(Value::Bool(true), Quality::Good);
    e.value(Value::U16(0x1234), Quality::Stale);
    e.value(Value::I32(-3), Quality::Bad);
    e.value(Value::F32(1.5), Quality::Good);
    assert_eq!(
        e.0,
        [0x10, 0x05, 0x34, 0x12, 0x0a, 0x05, 0x03, 0x00, 0x00, 0xc0, 0x3f]
    );
    let mut d = Dec::new(&e.0);
    assert_eq!(d.value(), Ok((Value::Bool(true), Quality::Good)));
    assert_eq!(d.value(), Ok((Value::U16(0x1234), Quality::Stale)));
    assert_eq!(d.value(), Ok((Value::I32(-3), Quality::Bad)));
    assert_eq!(d.value(), Ok((Value::F32(1.5), Quality::Good)));
    assert!(d.done());
}

#[test]
fn a_tasks_header_names_it_after_the_tag_table_and_a_header_of_one_task_is_unchanged() {
    let one = Enc::header(&header());
    let task = Header {
        task: Some("fast".into()),
        ..header()
    };
    let named = Enc::header(&task);
    // The name comes last, as a string: a reader without the field reads the rest alike.
    assert_eq!(named[..one.len()], one[..]);
    assert_eq!(named[one.len()..], [4, b'f', b'a', b's', b't']);
    assert_eq!(Dec::new(&named).header(), Ok(task));
    assert_eq!(Dec::new(&one).header().map(|h| h.task), Ok(None));
}

#[test]
fn header_keyframe_and_cycles_round_trip() {
    let h = header();
    assert_eq!(Dec::new(&Enc::header(&h)).header(), Ok(h.clone()));
    let k = Keyframe {
        next_cycle: 40,
        now: ScanInstant::after_origin(Duration::from_millis(4000)),
        slots: vec![
            (Value::Bool(false), Quality::Bad),
            (Value::I32(i32::MIN), Quality::Good),
        ],
        forces: vec![(0, Value::Bool(true))],
    };
    assert_eq!(Dec::new(&Enc::keyframe(&k)).keyframe(2), Ok(k));
    let records = vec![
        CycleRecord {
            cycle: 40,
            now: ScanInstant::after_origin(Duration::from_millis(4000)),
            dropped_before: 0,
            faulted: false,
            events: vec![
                Event::Force {
                    tag: 0,
                    value: Value::Bool(true),
                },
                Event::Unforce { tag: 1 },
                Event::UnforceAll,
                Event::Write {
                    values: vec![(1, Value::I32(7))],
                },
                Event::Reload {
                    program_hash: digest(b"new"),
                },
            ],
            seen: vec![Change {
                tag: 0,
                value: Value::Bool(true),
                quality: Quality::Good,
            }],
            wrote: vec![],
        },
        CycleRecord {
            cycle: 43,
            now: ScanInstant::after_origin(Duration::from_millis(4300)),
            dropped_before: 2,
            faulted: true,
            ..CycleRecord::default()
        },
    ];
    let mut block = Enc::cycles_block(40, ScanInstant::after_origin(Duration::from_millis(4000)));
    let mut prev = (40, ScanInstant::after_origin(Duration::from_millis(4000)));
    for r in &records {
        block.cycle(r, prev);
        prev = (r.cycle, r.now);
    }
    assert_eq!(Dec::new(&block.0).cycles(2), Ok(records));
}

#[test]
fn damage_is_a_torn_tail_never_a_panic() {
    let block = frame(
        BlockKind::End,
        &Enc::end(&End {
            cycles: 1,
            dropped: 0,
        }),
    );
    for cut in 1..block.len() {
        assert_eq!(next_block(&block[..cut], 0), Framed::Torn, "cut at {cut}");
    }
    let mut flipped = block.clone();
    *flipped.last_mut().unwrap() ^= 1;
    assert_eq!(next_block(&flipped, 0), Framed::Torn);
    assert_eq!(next_block(&block, block.len()), Framed::Eof);
    // A payload that lies about its counts is refused, not allocated for.
    assert_eq!(
        Dec::new(&[0xff, 0xff, 0xff, 0xff, 0x0f]).changes(2),
        Err(DecodeError::Truncated)
    );
    assert_eq!(
        Dec::new(&[1, 9, 0]).changes(2),
        Err(DecodeError::TagRange { tag: 9 })
    );
}
