//! Fuzzing everything that reads bytes off a wire: the RTU master codec, the device-side
//! request decoder, every simulator in the catalog (RTU frames and each module's text
//! protocol), every driver's reply decoding, and the Modbus TCP guard. The property is the same
//! everywhere: no input panics, and whatever is accepted is well formed.
//!
//! Bounded runs are part of the test suite (proptest's 256 cases per property, a few seconds in
//! all); a long run is `PROPTEST_CASES=200000 cargo test --release -p softplc-tests --test
//! system fuzz_wire::`. A failing case is saved under `proptest-regressions/` and replayed first
//! from then on: commit it, it is the regression test.

use std::time::Duration;

use proptest::collection::vec;
use proptest::prelude::*;
use softplc::service::{check_pdu, whole_frames};
use softplc_io::devices::{catalog, ModelSpec};
use softplc_io::driver::{Outgoing, Reply};
use softplc_io::modbus::{
    append_crc, check_crc, decode_request, request_frame_len, ExceptionCode, FrameLen, Progress,
    ReplyAssembler, Request, Response,
};
use softplc_io::point::Value;
use softplc_io::sim::complete_frame;
use softplc_io::time::LineInstant;

/// Characters the modules' text protocols are made of, so that random lines reach deep into
/// the parsers instead of failing at the first byte.
const TEXT: &[u8] = b"?>@#$%~=:,.-+*_ 0123456789ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefxX()\r\n\t";

fn text_line() -> impl Strategy<Value = Vec<u8>> {
    (vec(proptest::sample::select(TEXT), 0..90), any::<bool>()).prop_map(|(mut v, cr)| {
        if cr {
            v.push(b'\r');
        }
        v
    })
}

/// An RTU frame with a valid CRC and a plausible function code, or noise.
fn rtu_frame() -> impl Strategy<Value = Vec<u8>> {
    let function =
        proptest::sample::select(vec![1u8, 2, 3, 4, 5, 6, 15, 16, 22, 70, 0x2B, 0x83, 0]);
    prop_oneof![
        (any::<u8>(), function, vec(any::<u8>(), 0..40)).prop_map(|(unit, f, data)| {
            let mut v = vec![unit, f];
            v.extend(data);
            append_crc(&mut v);
            v
        }),
        vec(any::<u8>(), 0..64),
    ]
}

fn frame() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![rtu_frame(), text_line()]
}

fn request() -> impl Strategy<Value = Request> {
    let addr = any::<u16>();
    let count = 0u16..300;
    prop_oneof![
        (addr, count.clone()).prop_map(|(addr, count)| Request::ReadCoils { addr, count }),
        (addr, count.clone()).prop_map(|(addr, count)| Request::ReadDiscreteInputs { addr, count }),
        (addr, count.clone())
            .prop_map(|(addr, count)| Request::ReadHoldingRegisters { addr, count }),
        (addr, count).prop_map(|(addr, count)| Request::ReadInputRegisters { addr, count }),
        (addr, any::<bool>()).prop_map(|(addr, value)| Request::WriteSingleCoil { addr, value }),
        (addr, any::<u16>()).prop_map(|(addr, value)| Request::WriteSingleRegister { addr, value }),
        (addr, vec(any::<bool>(), 0..40))
            .prop_map(|(addr, values)| Request::WriteMultipleCoils { addr, values }),
        (addr, vec(any::<u16>(), 0..20))
            .prop_map(|(addr, values)| Request::WriteMultipleRegisters { addr, values }),
        (addr, any::<u16>(), any::<u16>()).prop_map(|(addr, and_mask, or_mask)| {
            Request::MaskWriteRegister {
                addr,
                and_mask,
                or_mask,
            }
        }),
        (any::<u8>(), any::<u8>(), any::<u8>(), any::<u8>()).prop_map(
            |(first, last, slave_ack, slave_seq)| {
                Request::Collect {
                    first,
                    last,
                    slave_ack,
                    slave_seq,
                }
            }
        ),
    ]
}

fn response() -> impl Strategy<Value = Response> {
    prop_oneof![
        vec(any::<bool>(), 0..40).prop_map(Response::ReadCoils),
        vec(any::<bool>(), 0..40).prop_map(Response::ReadDiscreteInputs),
        vec(any::<u16>(), 0..40).prop_map(Response::ReadHoldingRegisters),
        vec(any::<u16>(), 0..40).prop_map(Response::ReadInputRegisters),
        (any::<u16>(), any::<bool>())
            .prop_map(|(addr, value)| Response::WriteSingleCoil { addr, value }),
        (any::<u16>(), any::<u16>())
            .prop_map(|(addr, value)| Response::WriteSingleRegister { addr, value }),
        (any::<u16>(), any::<u16>())
            .prop_map(|(addr, count)| Response::WriteMultipleCoils { addr, count }),
        (any::<u16>(), any::<u16>())
            .prop_map(|(addr, count)| Response::WriteMultipleRegisters { addr, count }),
        (any::<u8>(), any::<u8>(), any::<u8>(), any::<u16>()).prop_map(
            |(slave, seq, kind, data)| Response::Collect {
                slave,
                seq,
                kind,
                data
            }
        ),
        (any::<u8>(), any::<u8>()).prop_map(|(function, c)| Response::Exception {
            function,
            code: ExceptionCode::from_u8(c)
        }),
    ]
}

fn models() -> Vec<&'static ModelSpec> {
    catalog().to_vec()
}

proptest! {
    /// Reassembly never panics; an accepted reply came in a frame with a good CRC.
    #[test]
    fn reply_assembler_takes_any_bytes(
        unit in any::<u8>(),
        req in request(),
        chunks in vec(vec(any::<u8>(), 0..12), 0..8),
        valid in rtu_frame(),
    ) {
        for bytes in [chunks.concat(), valid] {
            let mut asm = ReplyAssembler::new(unit, &req);
            let mut fed = Vec::new();
            for chunk in bytes.chunks(5) {
                fed.extend_from_slice(chunk);
                match asm.push(chunk) {
                    Progress::NeedMore => {}
                    Progress::Complete { extra, .. } => {
                        let used = fed.len() - extra;
                        prop_assert!(check_crc(&fed[..used]), "accepted a bad CRC: {fed:02X?}");
                        break;
                    }
                    Progress::Failed(_) => break,
                }
            }
        }
    }

    /// The device side: frame splitting and request decoding never panic, and a decoded
    /// request came from a frame with a good CRC.
    #[test]
    fn request_decoding_takes_any_bytes(bytes in frame()) {
        if let FrameLen::Complete(n) = request_frame_len(&bytes) {
            prop_assert!(n <= 256 + 9, "{n}");
        }
        if decode_request(&bytes).is_ok() {
            prop_assert!(check_crc(&bytes));
        }
        let _ = complete_frame(&bytes);
    }

    /// Every simulator in the catalog takes any frame, at any time, without panicking, and
    /// never answers a broadcast.
    #[test]
    fn every_simulator_takes_any_frame(frames in vec(frame(), 1..12), model_ix in 0usize..64) {
        let models = models();
        let model = models[model_ix % models.len()];
        let mut sim = (model.simulator)(*model.addresses.start());
        let mut t = Duration::ZERO;
        for f in &frames {
            t += Duration::from_millis(7);
            let t = LineInstant::after_origin(t);
            sim.advance_to(t);
            let reply = sim.on_frame(f, t);
            if f.first() == Some(&0) && check_crc(f) && f.len() >= 4 {
                prop_assert!(reply.is_none(), "{} answered a broadcast {f:02X?}", model.name);
            }
        }
    }

    /// Every simulator's standard-input surface takes any words.
    #[test]
    fn every_simulator_takes_any_console_input(
        words in vec("[A-Za-z0-9_.@-]{0,12}", 0..5),
        point_ix in any::<usize>(),
        value in "[0-9a-fx.-]{0,8}",
        model_ix in 0usize..64,
    ) {
        let models = models();
        let model = models[model_ix % models.len()];
        let mut sim = (model.simulator)(*model.addresses.start());
        let refs: Vec<&str> = words.iter().map(String::as_str).collect();
        // Only that the simulator answers without panicking: a refusal is fine.
        drop(sim.command(&refs));
        let points = sim.points();
        if !points.is_empty() {
            let p = points[point_ix % points.len()];
            if let Some(v) = Value::parse(p.ty, &value) {
                drop(sim.set(p.name, v));
            }
            drop(sim.get(p.name));
        }
    }

    /// Every driver, in every protocol its model speaks, takes any reply to any of its
    /// transactions without panicking.
    #[test]
    fn every_driver_takes_any_reply(
        replies in vec(prop_oneof![response().prop_map(Reply::Modbus), text_line().prop_map(Reply::Text)], 1..16),
        model_ix in 0usize..64,
        protocol_ix in 0usize..4,
    ) {
        let models = models();
        let model = models[model_ix % models.len()];
        let protocol = model.protocols[protocol_ix % model.protocols.len()];
        let config = model
            .device_config("m", *model.addresses.start(), protocol, &[])
            .unwrap();
        let mut driver = (model.driver)(&config);
        let mut plan = Vec::new();
        driver.plan_startup(&mut plan);
        driver.plan_read(&mut plan);
        let desired: Vec<Option<Value>> = model.points.iter().map(|p| Some(p.ty.zero())).collect();
        driver.plan_write(&desired, true, &mut plan);
        for (i, reply) in replies.iter().enumerate() {
            let Some(tx) = plan.get(i % plan.len().max(1)) else { break };
            if matches!(tx.frame, Outgoing::NoReply { .. }) {
                continue;
            }
            let _ = driver.on_reply(tx.tag, reply);
            driver.on_failure(tx.tag);
        }
        let _ = driver.values();
    }

    /// The Modbus TCP guard in front of tokio-modbus's decoder takes any byte stream.
    #[test]
    fn modbus_tcp_guard_takes_any_stream(bytes in vec(any::<u8>(), 0..300)) {
        let _ = whole_frames(&bytes);
        if bytes.len() > 7 {
            let _ = check_pdu(&bytes[7..]);
        }
    }
}
