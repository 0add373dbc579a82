use super::*;
use crate::modbus::crc::append_crc;

fn framed(body: &[u8]) -> Vec<u8> {
    let mut v = body.to_vec();
    append_crc(&mut v);
    v
}

/// Tiny xorshift, so split tests are reproducible without a dependency.
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        usize::try_from(self.next()).unwrap_or(0) % n.max(1)
    }
}

fn all_at_once(unit: u8, req: &Request, bytes: &[u8]) -> Progress {
    ReplyAssembler::new(unit, req).push(bytes)
}

fn byte_by_byte(unit: u8, req: &Request, bytes: &[u8]) -> Progress {
    let mut asm = ReplyAssembler::new(unit, req);
    let mut last = Progress::NeedMore;
    for b in bytes {
        last = asm.push(std::slice::from_ref(b));
    }
    last
}

fn random_splits(unit: u8, req: &Request, bytes: &[u8], rng: &mut Rng) -> Progress {
    let mut asm = ReplyAssembler::new(unit, req);
    let mut last = asm.push(&[]);
    let mut rest = bytes;
    while !rest.is_empty() {
        let n = 1 + rng.below(rest.len());
        let (now, later) = rest.split_at(n);
        last = asm.push(now);
        rest = later;
    }
    last
}

/// Feeds `bytes` whole, one byte at a time and in 50 random splittings; all must agree.
fn decode(unit: u8, req: &Request, bytes: &[u8]) -> Progress {
    let whole = all_at_once(unit, req, bytes);
    assert_eq!(byte_by_byte(unit, req, bytes), whole, "byte by byte");
    let mut rng = Rng(0x9E37_79B9 ^ u32::try_from(bytes.len()).unwrap_or(0));
    for _ in 0..50 {
        assert_eq!(
            random_splits(unit, req, bytes, &mut rng),
            whole,
            "random split"
        );
    }
    whole
}

fn complete(response: Response) -> Progress {
    Progress::Complete { response, extra: 0 }
}

#[test]
fn fc1_read_coils_spec_example() {
    // 19 coils from 20 (0x13): CD 6B 05, the top 5 bits of 05 are padding.
    let req = Request::ReadCoils {
        addr: 0x13,
        count: 19,
    };
    let bytes = framed(&[0x11, 0x01, 0x03, 0xCD, 0x6B, 0x05]);
    let mut expected = Vec::new();
    for byte in [0xCDu8, 0x6B, 0x05] {
        for i in 0..8 {
            expected.push(byte & (1 << i) != 0);
        }
    }
    expected.truncate(19);
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::ReadCoils(expected))
    );
}

#[test]
fn fc1_padding_bits_dropped() {
    let req = Request::ReadCoils { addr: 0, count: 1 };
    let bytes = framed(&[0x01, 0x01, 0x01, 0xFF]);
    assert_eq!(
        decode(1, &req, &bytes),
        complete(Response::ReadCoils(vec![true]))
    );
}

#[test]
fn fc2_read_discrete_inputs_spec_example() {
    // 22 inputs from 197 (0xC4): AC DB 35.
    let req = Request::ReadDiscreteInputs {
        addr: 0xC4,
        count: 22,
    };
    let bytes = framed(&[0x11, 0x02, 0x03, 0xAC, 0xDB, 0x35]);
    let Progress::Complete {
        response: Response::ReadDiscreteInputs(bits),
        extra: 0,
    } = decode(0x11, &req, &bytes)
    else {
        panic!("not decoded");
    };
    assert_eq!(bits.len(), 22);
    assert_eq!(
        bits.get(..8),
        Some(&[false, false, true, true, false, true, false, true][..])
    );
    assert_eq!(
        bits.get(16..),
        Some(&[true, false, true, false, true, true][..])
    );
}

#[test]
fn fc3_read_holding_registers_known_frame() {
    let req = Request::ReadHoldingRegisters {
        addr: 0x6B,
        count: 3,
    };
    let bytes = [
        0x11, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64, 0xC8, 0xBA,
    ];
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::ReadHoldingRegisters(vec![0x022B, 0, 0x64]))
    );
    let bytes = [
        0x11, 0x03, 0x06, 0xAE, 0x41, 0x56, 0x52, 0x43, 0x40, 0x49, 0xAD,
    ];
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::ReadHoldingRegisters(vec![0xAE41, 0x5652, 0x4340]))
    );
}

#[test]
fn fc4_read_input_registers() {
    let req = Request::ReadInputRegisters { addr: 8, count: 1 };
    let bytes = framed(&[0x11, 0x04, 0x02, 0x00, 0x0A]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::ReadInputRegisters(vec![10]))
    );
}

#[test]
fn fc5_fc6_echo() {
    let req = Request::WriteSingleCoil {
        addr: 0xAC,
        value: true,
    };
    let bytes = [0x01, 0x05, 0x00, 0xAC, 0xFF, 0x00, 0x4C, 0x1B];
    assert_eq!(
        decode(1, &req, &bytes),
        complete(Response::WriteSingleCoil {
            addr: 0xAC,
            value: true
        })
    );
    let req = Request::WriteSingleCoil {
        addr: 0xAC,
        value: false,
    };
    let bytes = framed(&[0x01, 0x05, 0x00, 0xAC, 0x00, 0x00]);
    assert_eq!(
        decode(1, &req, &bytes),
        complete(Response::WriteSingleCoil {
            addr: 0xAC,
            value: false
        })
    );
    let req = Request::WriteSingleRegister { addr: 1, value: 3 };
    let bytes = framed(&[0x11, 0x06, 0x00, 0x01, 0x00, 0x03]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::WriteSingleRegister { addr: 1, value: 3 })
    );
}

#[test]
fn fc15_fc16_echo() {
    let req = Request::WriteMultipleCoils {
        addr: 0x13,
        values: vec![true; 10],
    };
    let bytes = framed(&[0x11, 0x0F, 0x00, 0x13, 0x00, 0x0A]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::WriteMultipleCoils {
            addr: 0x13,
            count: 10
        })
    );
    let req = Request::WriteMultipleRegisters {
        addr: 1,
        values: vec![0x0A, 0x0102],
    };
    let bytes = framed(&[0x11, 0x10, 0x00, 0x01, 0x00, 0x02]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::WriteMultipleRegisters { addr: 1, count: 2 })
    );
}

#[test]
fn fc22_echo() {
    let req = Request::MaskWriteRegister {
        addr: 4,
        and_mask: 0xF2,
        or_mask: 0x25,
    };
    let bytes = framed(&[0x11, 0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x25]);
    assert_eq!(bytes.len(), 10);
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::MaskWriteRegister {
            addr: 4,
            and_mask: 0xF2,
            or_mask: 0x25
        })
    );
}

fn collect_req(first: u8, last: u8) -> Request {
    Request::Collect {
        first,
        last,
        slave_ack: 0,
        slave_seq: 0,
    }
}

#[test]
fn fc70_minimod_collect_exchange() {
    // Request `00 46 01 10 00 00` + CRC (broadcast, window 1..=16)...
    let mut request = Vec::new();
    super::super::encode_request(0, &collect_req(1, 16), &mut request).ok();
    assert_eq!(request, [0x00, 0x46, 0x01, 0x10, 0x00, 0x00, 0x89, 0xED]);
    // ... answered by slave 4: `04 46 SEQ 02 DATH DATL 00` + CRC.
    let reply = [0x04, 0x46, 0x05, 0x02, 0x00, 0x05, 0x00, 0x9E, 0x8E];
    let mut asm = ReplyAssembler::new(0, &collect_req(1, 16));
    assert_eq!(asm.push(&reply[..2]), Progress::NeedMore);
    assert_eq!(asm.expected_len(), Some(9));
    assert_eq!(
        decode(0, &collect_req(1, 16), &reply),
        complete(Response::Collect {
            slave: 4,
            seq: 5,
            kind: 2,
            data: 0x0005
        })
    );
}

#[test]
fn fc70_outside_window_and_trailer() {
    let reply = framed(&[0x04, 0x46, 0x05, 0x02, 0x00, 0x05, 0x00]);
    // After slave 4 was acknowledged the window is 5..=16.
    assert_eq!(
        decode(0, &collect_req(5, 16), &reply),
        Progress::Failed(ReplyError::OutsideWindow {
            first: 5,
            last: 16,
            found: 4
        })
    );
    let reply = framed(&[0x04, 0x46, 0x05, 0x02, 0x00, 0x05, 0x01]);
    assert_eq!(
        decode(0, &collect_req(1, 16), &reply),
        Progress::Failed(ReplyError::Malformed { offset: 6 })
    );
}

#[test]
fn exception_reply_is_a_successful_decode() {
    let req = Request::ReadHoldingRegisters { addr: 0, count: 1 };
    let bytes = framed(&[0x11, 0x83, 0x02]);
    let mut asm = ReplyAssembler::new(0x11, &req);
    assert_eq!(asm.push(&bytes[..2]), Progress::NeedMore);
    assert_eq!(asm.expected_len(), Some(5));
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::Exception {
            function: 3,
            code: ExceptionCode::IllegalDataAddress
        })
    );
    // A Collect may be refused too, by a device in the window.
    let bytes = framed(&[0x07, 0xC6, 0x01]);
    assert_eq!(
        decode(0, &collect_req(1, 16), &bytes),
        complete(Response::Exception {
            function: 70,
            code: ExceptionCode::IllegalFunction
        })
    );
    // Unknown codes are kept.
    let bytes = framed(&[0x11, 0x83, 0x0B]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        complete(Response::Exception {
            function: 3,
            code: ExceptionCode::Other(0x0B)
        })
    );
}

#[test]
fn exception_for_another_function_is_wrong_function() {
    let req = Request::ReadHoldingRegisters { addr: 0, count: 1 };
    let bytes = framed(&[0x11, 0x84, 0x02]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        Progress::Failed(ReplyError::WrongFunction {
            expected: 3,
            found: 0x84
        })
    );
}

#[test]
fn corrupted_crc() {
    let req = Request::ReadHoldingRegisters {
        addr: 0x6B,
        count: 3,
    };
    let mut bytes = vec![
        0x11, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64, 0xC8, 0xBA,
    ];
    if let Some(b) = bytes.last_mut() {
        *b = 0xBB;
    }
    assert_eq!(
        decode(0x11, &req, &bytes),
        Progress::Failed(ReplyError::Crc {
            expected: 0xBAC8,
            found: 0xBBC8
        })
    );
}

#[test]
fn noise_in_content_is_a_crc_error() {
    // Any single bit flip past the address byte that keeps the frame length is a CRC error,
    // never a content error: the CRC is checked first.
    let req = Request::WriteSingleRegister { addr: 1, value: 3 };
    let good = framed(&[0x11, 0x06, 0x00, 0x01, 0x00, 0x03]);
    for i in 2..good.len() {
        for bit in 0..8 {
            let mut bad = good.clone();
            if let Some(b) = bad.get_mut(i) {
                *b ^= 1 << bit;
            }
            assert!(
                matches!(
                    decode(0x11, &req, &bad),
                    Progress::Failed(ReplyError::Crc { .. })
                ),
                "byte {i} bit {bit}"
            );
        }
    }
}

#[test]
fn wrong_unit_fails_on_first_byte() {
    let req = Request::ReadCoils { addr: 0, count: 1 };
    let mut asm = ReplyAssembler::new(1, &req);
    let failed = Progress::Failed(ReplyError::WrongUnit {
        expected: 1,
        found: 2,
    });
    assert_eq!(asm.push(&[0x02]), failed);
    assert_eq!(asm.expected_len(), None);
    // It stays failed.
    assert_eq!(asm.push(&[0x01, 0x01, 0x01, 0x00]), failed);
    // A broadcast expects no reply: anything is from a wrong unit.
    let write = Request::WriteSingleCoil {
        addr: 0,
        value: true,
    };
    assert_eq!(
        all_at_once(0, &write, &[0x05]),
        Progress::Failed(ReplyError::WrongUnit {
            expected: 0,
            found: 5
        })
    );
}

#[test]
fn wrong_function() {
    let req = Request::ReadHoldingRegisters { addr: 0, count: 1 };
    // A known function: read to its end, CRC checked, then refused.
    let bytes = framed(&[0x11, 0x04, 0x02, 0x00, 0x0A]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        Progress::Failed(ReplyError::WrongFunction {
            expected: 3,
            found: 4
        })
    );
    let bytes = framed(&[0x11, 0x06, 0x00, 0x01, 0x00, 0x03]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        Progress::Failed(ReplyError::WrongFunction {
            expected: 3,
            found: 6
        })
    );
    // An unknown function: the length is unknown, fail on the second byte.
    let mut asm = ReplyAssembler::new(0x11, &req);
    assert_eq!(
        asm.push(&[0x11, 0x2B]),
        Progress::Failed(ReplyError::WrongFunction {
            expected: 3,
            found: 0x2B
        })
    );
    // An impossible byte count under another known function.
    assert_eq!(
        all_at_once(0x11, &req, &[0x11, 0x04, 0xFB]),
        Progress::Failed(ReplyError::WrongFunction {
            expected: 3,
            found: 4
        })
    );
}

#[test]
fn late_reply_to_a_smaller_read_is_wrong_byte_count() {
    // FC 3 count 3 was asked; the (late) reply to an earlier FC 3 count 2 arrives.
    let req = Request::ReadHoldingRegisters { addr: 0, count: 3 };
    let bytes = framed(&[0x11, 0x03, 0x04, 0x00, 0x01, 0x00, 0x02]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        Progress::Failed(ReplyError::WrongByteCount {
            expected: 6,
            found: 4
        })
    );
    // Same for bits: 9 coils need 2 bytes.
    let req = Request::ReadCoils { addr: 0, count: 9 };
    let bytes = framed(&[0x11, 0x01, 0x01, 0xFF]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        Progress::Failed(ReplyError::WrongByteCount {
            expected: 2,
            found: 1
        })
    );
    // A byte count no frame can carry fails at once.
    assert_eq!(
        all_at_once(0x11, &req, &[0x11, 0x01, 0xFB]),
        Progress::Failed(ReplyError::WrongByteCount {
            expected: 2,
            found: 0xFB
        })
    );
}

#[test]
fn late_reply_to_another_write_is_echo_mismatch() {
    let req = Request::WriteSingleRegister { addr: 1, value: 3 };
    let other_addr = framed(&[0x11, 0x06, 0x00, 0x02, 0x00, 0x03]);
    assert_eq!(
        decode(0x11, &req, &other_addr),
        Progress::Failed(ReplyError::EchoMismatch {
            field: EchoField::Address,
            expected: 1,
            found: 2
        })
    );
    let other_value = framed(&[0x11, 0x06, 0x00, 0x01, 0x00, 0x04]);
    assert_eq!(
        decode(0x11, &req, &other_value),
        Progress::Failed(ReplyError::EchoMismatch {
            field: EchoField::Value,
            expected: 3,
            found: 4
        })
    );
    let req = Request::WriteSingleCoil {
        addr: 0xAC,
        value: true,
    };
    let off = framed(&[0x01, 0x05, 0x00, 0xAC, 0x00, 0x00]);
    assert_eq!(
        decode(1, &req, &off),
        Progress::Failed(ReplyError::EchoMismatch {
            field: EchoField::Value,
            expected: 0xFF00,
            found: 0
        })
    );
    let req = Request::WriteMultipleRegisters {
        addr: 1,
        values: vec![1, 2, 3],
    };
    let bytes = framed(&[0x11, 0x10, 0x00, 0x01, 0x00, 0x02]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        Progress::Failed(ReplyError::EchoMismatch {
            field: EchoField::Quantity,
            expected: 3,
            found: 2
        })
    );
    let req = Request::MaskWriteRegister {
        addr: 4,
        and_mask: 0xF2,
        or_mask: 0x25,
    };
    let bytes = framed(&[0x11, 0x16, 0x00, 0x04, 0x00, 0xF2, 0x00, 0x26]);
    assert_eq!(
        decode(0x11, &req, &bytes),
        Progress::Failed(ReplyError::EchoMismatch {
            field: EchoField::OrMask,
            expected: 0x25,
            found: 0x26
        })
    );
}

#[test]
fn extra_trailing_bytes() {
    let req = Request::WriteSingleRegister { addr: 1, value: 3 };
    let mut bytes = framed(&[0x11, 0x06, 0x00, 0x01, 0x00, 0x03]);
    bytes.extend_from_slice(&[0xAA, 0xBB, 0xCC]);
    let expected = Progress::Complete {
        response: Response::WriteSingleRegister { addr: 1, value: 3 },
        extra: 3,
    };
    assert_eq!(decode(0x11, &req, &bytes), expected);
    // More bytes after completion keep counting.
    let mut asm = ReplyAssembler::new(0x11, &req);
    asm.push(&bytes);
    assert_eq!(
        asm.push(&[0; 4]),
        Progress::Complete {
            response: Response::WriteSingleRegister { addr: 1, value: 3 },
            extra: 7,
        }
    );
    assert_eq!(asm.received(), 8);
}

#[test]
fn expected_len_from_header() {
    let req = Request::ReadHoldingRegisters { addr: 0, count: 3 };
    let mut asm = ReplyAssembler::new(0x11, &req);
    assert_eq!(asm.push(&[]), Progress::NeedMore);
    assert_eq!(asm.push(&[0x11]), Progress::NeedMore);
    assert_eq!(asm.expected_len(), None);
    assert_eq!(asm.push(&[0x03]), Progress::NeedMore);
    assert_eq!(asm.expected_len(), None);
    assert_eq!(asm.push(&[0x06]), Progress::NeedMore);
    assert_eq!(asm.expected_len(), Some(11));
    assert_eq!(asm.received(), 3);
    for (unit, req, len) in [
        (
            1,
            Request::WriteSingleCoil {
                addr: 0,
                value: true,
            },
            8,
        ),
        (1, Request::WriteSingleRegister { addr: 0, value: 1 }, 8),
        (
            1,
            Request::WriteMultipleCoils {
                addr: 0,
                values: vec![true],
            },
            8,
        ),
        (
            1,
            Request::WriteMultipleRegisters {
                addr: 0,
                values: vec![1],
            },
            8,
        ),
        (
            1,
            Request::MaskWriteRegister {
                addr: 0,
                and_mask: 0,
                or_mask: 0,
            },
            10,
        ),
    ] {
        let mut asm = ReplyAssembler::new(unit, &req);
        asm.push(&[unit, req.function().code()]);
        assert_eq!(asm.expected_len(), Some(len), "{req:?}");
    }
}

#[test]
fn garbage_never_panics() {
    let reqs = [
        Request::ReadCoils { addr: 0, count: 9 },
        Request::ReadHoldingRegisters { addr: 0, count: 2 },
        Request::WriteSingleCoil {
            addr: 0,
            value: true,
        },
        Request::MaskWriteRegister {
            addr: 0,
            and_mask: 1,
            or_mask: 2,
        },
        collect_req(1, 247),
        // Invalid requests must not make the assembler panic either.
        Request::ReadHoldingRegisters {
            addr: 0xFFFF,
            count: u16::MAX,
        },
        Request::WriteMultipleCoils {
            addr: 0,
            values: vec![],
        },
    ];
    let mut rng = Rng(12345);
    for round in 0..3000 {
        let len = rng.below(40);
        let mut bytes: Vec<u8> = (0..len).map(|_| rng.next().to_le_bytes()[0]).collect();
        // Make many of them start plausibly: right address, known function.
        if round % 2 == 0 {
            if let Some(b) = bytes.get_mut(0) {
                *b = 1;
            }
            if let Some(b) = bytes.get_mut(1) {
                *b = [1u8, 2, 3, 4, 5, 6, 15, 16, 22, 70, 0x83][rng.below(11)];
            }
        }
        for req in &reqs {
            let whole = all_at_once(1, req, &bytes);
            assert_eq!(random_splits(1, req, &bytes, &mut rng), whole);
        }
    }
}
