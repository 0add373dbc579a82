use super::*;
use crate::modbus::crc::check_crc;

fn enc(unit: u8, req: &Request) -> Vec<u8> {
    let mut out = Vec::new();
    let r = encode_request(unit, req, &mut out);
    assert_eq!(r, Ok(()), "{req:?}");
    assert!(check_crc(&out));
    out
}

#[test]
fn spec_vectors() {
    assert_eq!(
        enc(
            0x11,
            &Request::ReadHoldingRegisters {
                addr: 0x006B,
                count: 3
            }
        ),
        [0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x76, 0x87]
    );
    assert_eq!(
        enc(1, &Request::ReadHoldingRegisters { addr: 0, count: 10 }),
        [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD]
    );
    assert_eq!(
        enc(
            1,
            &Request::WriteSingleCoil {
                addr: 0x00AC,
                value: true
            }
        ),
        [0x01, 0x05, 0x00, 0xAC, 0xFF, 0x00, 0x4C, 0x1B]
    );
    assert_eq!(
        enc(1, &Request::ReadCoils { addr: 0, count: 1 }),
        [0x01, 0x01, 0x00, 0x00, 0x00, 0x01, 0xFD, 0xCA]
    );
}

/// The PDU part (without address and CRC) of every function, as the spec lays it out.
#[test]
fn every_function_layout() {
    let cases: Vec<(Request, Vec<u8>)> = vec![
        (
            Request::ReadCoils {
                addr: 0x0013,
                count: 0x13,
            },
            vec![0x01, 0x00, 0x13, 0x00, 0x13],
        ),
        (
            Request::ReadDiscreteInputs {
                addr: 0x00C4,
                count: 0x16,
            },
            vec![0x02, 0x00, 0xC4, 0x00, 0x16],
        ),
        (
            Request::ReadHoldingRegisters {
                addr: 0x006B,
                count: 3,
            },
            vec![0x03, 0x00, 0x6B, 0x00, 0x03],
        ),
        (
            Request::ReadInputRegisters {
                addr: 0x0008,
                count: 1,
            },
            vec![0x04, 0x00, 0x08, 0x00, 0x01],
        ),
        (
            Request::WriteSingleCoil {
                addr: 0x00AC,
                value: false,
            },
            vec![0x05, 0x00, 0xAC, 0x00, 0x00],
        ),
        (
            Request::WriteSingleRegister {
                addr: 0x0001,
                value: 0x0003,
            },
            vec![0x06, 0x00, 0x01, 0x00, 0x03],
        ),
        (
            // Spec example: coils 20..29 = CD 01.
            Request::WriteMultipleCoils {
                addr: 0x0013,
                values: vec![
                    true, false, true, true, false, false, true, true, true, false,
                ],
            },
            vec![0x0F, 0x00, 0x13, 0x00, 0x0A, 0x02, 0xCD, 0x01],
        ),
        (
            Request::WriteMultipleRegisters {
                addr: 0x0001,
                values: vec![0x000A, 0x0102],
            },
            vec![0x10, 0x00, 0x01, 0x00, 0x02, 0x04, 0x00, 0x0A, 0x01, 0x02],
        ),
        (
            Request::MaskWriteRegister {
                addr: 0x0004,
                and_mask: 0x00F2,
                or_mask: 0x0025,
            },
            vec![0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25],
        ),
        (
            Request::Collect {
                first: 5,
                last: 16,
                slave_ack: 4,
                slave_seq: 9,
            },
            vec![0x46, 5, 16, 4, 9],
        ),
    ];
    for (req, pdu) in cases {
        let frame = enc(0x07, &req);
        assert_eq!(frame.first(), Some(&0x07));
        assert_eq!(frame.get(1..frame.len() - 2), Some(&pdu[..]), "{req:?}");
    }
}

#[test]
fn minimod_collect_request() {
    let frame = enc(
        0,
        &Request::Collect {
            first: 1,
            last: 16,
            slave_ack: 0,
            slave_seq: 0,
        },
    );
    assert_eq!(frame, [0x00, 0x46, 0x01, 0x10, 0x00, 0x00, 0x89, 0xED]);
}

#[test]
fn quantity_limits() {
    let bad = |unit: u8, req: Request| {
        let mut out = vec![0xAA];
        let e = encode_request(unit, &req, &mut out);
        assert_eq!(out, [0xAA], "nothing appended on error");
        e
    };
    let q = |function: u8, count: usize, max: u16| {
        Err(EncodeError::Quantity {
            function,
            count,
            max,
        })
    };
    assert_eq!(
        bad(1, Request::ReadCoils { addr: 0, count: 0 }),
        q(1, 0, 2000)
    );
    assert_eq!(
        bad(
            1,
            Request::ReadDiscreteInputs {
                addr: 0,
                count: 2001
            }
        ),
        q(2, 2001, 2000)
    );
    assert_eq!(
        bad(
            1,
            Request::ReadHoldingRegisters {
                addr: 0,
                count: 126
            }
        ),
        q(3, 126, 125)
    );
    assert_eq!(
        bad(1, Request::ReadInputRegisters { addr: 0, count: 0 }),
        q(4, 0, 125)
    );
    assert_eq!(
        bad(
            1,
            Request::WriteMultipleCoils {
                addr: 0,
                values: vec![false; 1969]
            }
        ),
        q(15, 1969, 1968)
    );
    assert_eq!(
        bad(
            1,
            Request::WriteMultipleRegisters {
                addr: 0,
                values: vec![]
            }
        ),
        q(16, 0, 123)
    );
    assert_eq!(
        bad(
            1,
            Request::WriteMultipleRegisters {
                addr: 0,
                values: vec![0; 124]
            }
        ),
        q(16, 124, 123)
    );
    // Upper limits themselves are fine.
    enc(
        1,
        &Request::ReadCoils {
            addr: 0,
            count: 2000,
        },
    );
    enc(
        1,
        &Request::ReadHoldingRegisters {
            addr: 0,
            count: 125,
        },
    );
    let f = enc(
        1,
        &Request::WriteMultipleCoils {
            addr: 0,
            values: vec![true; 1968],
        },
    );
    assert_eq!(f.len(), 9 + 246);
    let f = enc(
        1,
        &Request::WriteMultipleRegisters {
            addr: 0,
            values: vec![1; 123],
        },
    );
    assert_eq!(f.len(), 9 + 246);
}

#[test]
fn address_range() {
    enc(
        1,
        &Request::ReadHoldingRegisters {
            addr: 0xFFFF - 124,
            count: 125,
        },
    );
    assert_eq!(
        encode_request(
            1,
            &Request::ReadHoldingRegisters {
                addr: 0xFFFF - 123,
                count: 125
            },
            &mut Vec::new()
        ),
        Err(EncodeError::AddressOverflow {
            function: 3,
            addr: 0xFFFF - 123,
            count: 125
        })
    );
    enc(
        1,
        &Request::WriteSingleRegister {
            addr: 0xFFFF,
            value: 0,
        },
    );
    assert_eq!(
        encode_request(
            1,
            &Request::WriteMultipleCoils {
                addr: 0xFFFF,
                values: vec![true, true]
            },
            &mut Vec::new()
        ),
        Err(EncodeError::AddressOverflow {
            function: 15,
            addr: 0xFFFF,
            count: 2
        })
    );
}

#[test]
fn unit_rules() {
    let read = Request::ReadCoils { addr: 0, count: 1 };
    let write = Request::WriteSingleCoil {
        addr: 0,
        value: true,
    };
    assert_eq!(
        encode_request(248, &write, &mut Vec::new()),
        Err(EncodeError::ReservedUnit { unit: 248 })
    );
    assert_eq!(
        encode_request(0, &read, &mut Vec::new()),
        Err(EncodeError::BroadcastRead { function: 1 })
    );
    enc(0, &write);
    enc(247, &read);
    assert!(!expects_reply(0, &write));
    assert!(expects_reply(3, &write));
    assert!(expects_reply(
        0,
        &Request::Collect {
            first: 1,
            last: 16,
            slave_ack: 0,
            slave_seq: 0
        }
    ));
    assert_eq!(
        encode_request(
            0,
            &Request::Collect {
                first: 9,
                last: 8,
                slave_ack: 0,
                slave_seq: 0
            },
            &mut Vec::new()
        ),
        Err(EncodeError::CollectWindow { first: 9, last: 8 })
    );
}

#[test]
fn appends_to_existing_buffer() {
    let mut out = vec![0xEE];
    encode_request(1, &Request::ReadCoils { addr: 0, count: 1 }, &mut out).ok();
    assert_eq!(out, [0xEE, 0x01, 0x01, 0x00, 0x00, 0x00, 0x01, 0xFD, 0xCA]);
}

#[test]
fn bits_round_trip() {
    let bits: Vec<bool> = (0..19).map(|i| i % 3 == 0).collect();
    let mut packed = Vec::new();
    pack_bits(&bits, &mut packed);
    assert_eq!(packed.len(), 3);
    assert_eq!(unpack_bits(&packed, 19), bits);
    assert_eq!(unpack_bits(&[0xFF], 3), vec![true; 3]);
    assert_eq!(unpack_bits(&[0x01], 12).len(), 8);
    assert_eq!(word_at(&[1, 2, 3], 1), Some(0x0203));
    assert_eq!(word_at(&[1, 2, 3], 2), None);
    assert_eq!(word_at(&[1, 2, 3], usize::MAX), None);
}
