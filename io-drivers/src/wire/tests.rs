//! Byte-exact frames from the manuals through the decoder and the framer.

use std::time::Duration;

use super::framer::{FrameEnd, Framer, Framing};
use super::*;
use crate::line::settings::{LineSettings, SerialFormat};
use crate::modbus::crc::append_crc;

fn with_crc(body: &[u8]) -> Vec<u8> {
    let mut v = body.to_vec();
    append_crc(&mut v);
    v
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// Modbus Application Protocol v1.1b3 §6.3: read holding registers 108..110 of unit 17.
const READ_REQ: [u8; 8] = [0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x76, 0x87];
const READ_REPLY: [u8; 11] = [
    0x11, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64, 0xC8, 0xBA,
];

#[test]
fn a_read_and_its_reply_name_unit_function_addresses_and_values() {
    assert_eq!(
        decode_request(&READ_REQ).to_string(),
        "rtu request unit 17: read holding registers (FC 3) 107..=109 (3 registers), CRC ok"
    );
    assert_eq!(
        decode_reply(&READ_REPLY, &READ_REQ).to_string(),
        "rtu reply unit 17: read holding registers (FC 3) 107..=109 (3 registers) = \
         [555, 0, 100], CRC ok"
    );
    // Without its request, the byte count still says how many registers.
    assert_eq!(
        Conversation::new().frame(&READ_REPLY).to_string(),
        "rtu reply unit 17: read holding registers (FC 3) 3 registers, request not seen = \
         [555, 0, 100], CRC ok"
    );
}

#[test]
fn exceptions_are_named_and_a_bad_crc_says_both_crcs() {
    let req = with_crc(&[0x01, 0x03, 0x00, 0x00, 0x00, 0x0A]);
    let exception = [0x01, 0x83, 0x02, 0xC0, 0xF1];
    assert_eq!(
        decode_reply(&exception, &req).to_string(),
        "rtu reply unit 1: read holding registers (FC 3) exception illegal data address (02), \
         CRC ok"
    );
    let mut bad = READ_REPLY;
    bad[4] ^= 0x01;
    assert_eq!(
        decode_reply(&bad, &READ_REQ).to_string(),
        "rtu unit 17 FC 3: CRC bad (computed 0x7AF5, frame carries 0xBAC8)"
    );
    // An exception to a function softplc does not speak (FC 43).
    let foreign = with_crc(&[0x05, 0xAB, 0x01]);
    assert_eq!(
        decode_request(&foreign).to_string(),
        "unrecognised: no Modbus RTU frame"
    );
    assert_eq!(
        Conversation::new().frame(&foreign).to_string(),
        "rtu reply unit 5: FC 43 exception illegal function (01), CRC ok"
    );
}

#[test]
fn collect_frames_follow_the_minimod_manual() {
    // "The Modbus function Collect": DST FCN FIRST LAST SLVACK SLVSEQ, broadcast.
    let collect = [0x00, 0x46, 0x01, 0x10, 0x00, 0x00, 0x89, 0xED];
    // SLAVE FCN SLVSEQ TYPE DATH DATL 0: slave 4, inputs 0x0005.
    let event = [0x04, 0x46, 0x05, 0x02, 0x00, 0x05, 0x00, 0x9E, 0x8E];
    let mut talk = Conversation::new();
    assert_eq!(
        talk.frame(&collect).to_string(),
        "rtu request broadcast: Collect (FC 70) window 1..=16, SLVACK 0 SLVSEQ 0, CRC ok"
    );
    assert_eq!(
        talk.frame(&event).to_string(),
        "rtu reply unit 4: Collect (FC 70) event of slave 4: SLVSEQ 5, inputs 0x0005, CRC ok"
    );
}

#[test]
fn a_conversation_pairs_writes_with_their_echo() {
    let write = with_crc(&[0x01, 0x05, 0x00, 0xAC, 0xFF, 0x00]);
    let mut talk = Conversation::new();
    assert!(talk
        .frame(&write)
        .to_string()
        .starts_with("rtu request unit 1: write single coil (FC 5) 172 = ON"));
    assert_eq!(
        talk.frame(&write).to_string(),
        "rtu reply unit 1: write single coil (FC 5) 172 = ON done, CRC ok"
    );
    // The echo has been paired: the next identical frame is a request again.
    assert!(talk.frame(&write).to_string().starts_with("rtu request"));
}

#[test]
fn minimod_text_names_the_module_the_identifier_and_the_value() {
    // Manual "Text commands protocol", "Slave addressing"; "Configuration of Minimod" (SERLINE).
    assert_session(&[
        (b"@3?X1\r", "minimod command to module 3: read X1"),
        (b"X1=1\r", "minimod reply: X1 = 1"),
        (b">Y1=1\r", "minimod command to every module: write Y1 = 1"),
        (b"OK\r", "minimod reply: OK (written)"),
        (
            b"@3>SERLINE=9600E\r",
            "minimod command to module 3: write SERLINE = 9600 Bd, mode E",
        ),
        (b"Error\r", "minimod reply: Error (refused)"),
        (
            b"@3?NOSUCH\r",
            "minimod command to module 3: answered Error (unknown identifier)",
        ),
    ]);
    // The bus owner's trace decodes a reply against the request it answers.
    assert_eq!(
        decode_reply(b"X1=1\r", b"@3?X1\r").to_string(),
        "minimod reply: X1 = 1"
    );
}

/// Feeds a conversation `frames` in order; each must decode as given.
fn assert_session(frames: &[(&[u8], &str)]) {
    let mut talk = Conversation::new();
    for (frame, want) in frames {
        assert_eq!(talk.frame(frame).to_string(), *want, "{}", Shown(frame));
    }
}

#[test]
fn resi_frames_keep_the_address_as_spelled() {
    // resi-spec §2.2: the address is echoed in the notation it arrived in.
    assert_session(&[
        (b"#0x2B,VER\r", "resi command address 0x2B: VER"),
        (
            b"#0x2B,VERSION:3.0.0\r",
            "resi answer address 0x2B: VERSION [3.0.0]",
        ),
        (b"#1,SSWITCH1:3\r", "resi command address 1: SSWITCH1 [3]"),
        (b"#1,OK\r", "resi answer address 1: OK"),
    ]);
}

#[test]
fn dcon_commands_and_answers_from_the_manual_examples() {
    // EX-9053D manual §2.9 "$AAM" and §2.3 "#AAN" examples.
    assert_session(&[
        (b"$01M\r", "dcon command to 01: §2.9 read module name"),
        (b"!019053\r", "dcon answer from 01: \"9053\""),
        (
            b"#032\r",
            "dcon command to 03: §2.3 read digital input counter of DI2",
        ),
        (b"!0300103\r", "dcon answer from 03: count 103"),
        (
            b"#025\r",
            "dcon command to 02: §2.3 read digital input counter of DI5",
        ),
        (b"?02\r", "dcon answer from 02: invalid command"),
    ]);
    // With the checksum of §1.10: "$01M" sums to 0xD2.
    assert_eq!(
        decode_request(b"$01MD2\r").to_string(),
        "dcon command to 01: §2.9 read module name, checksum ok"
    );
}

#[test]
fn what_no_protocol_knows_is_unrecognised() {
    assert_eq!(decode_request(b"").to_string(), "unrecognised: no bytes");
    assert_eq!(decode_request(b"hello\r").to_string(), "unrecognised text");
    assert_eq!(
        decode_request(b"@3?X").to_string(),
        "unrecognised: text without its CR"
    );
    assert_eq!(
        decode_request(&[0x01, 0x03, 0x00]).to_string(),
        "unrecognised: no Modbus RTU frame"
    );
}

#[test]
fn a_frame_is_shown_as_hex_and_a_text_line_as_its_text_too() {
    assert_eq!(Shown(&[0x01, 0xAB]).to_string(), "01 AB");
    assert_eq!(Shown(b"OK\r").to_string(), "4F 4B 0D  \"OK\\r\"");
}

#[test]
fn rtu_frames_end_at_t3_5_and_text_lines_at_cr() {
    let settings = LineSettings {
        baud: 9600,
        format: SerialFormat::EVEN_8E1,
    };
    // 3.5 characters of 11 bits at 9600 Bd.
    assert_eq!(framer::frame_gap(settings), Duration::from_nanos(4_010_416));
    let mut f = Framer::new(Framing::Auto, framer::frame_gap(settings));
    let mut out = Vec::new();
    // A request in two fragments 2 ms apart is one frame.
    f.push(&READ_REQ[..3], ms(10), &mut out);
    f.push(&READ_REQ[3..], ms(12), &mut out);
    assert!(out.is_empty());
    assert_eq!(f.deadline(), Some(ms(12) + framer::frame_gap(settings)));
    assert_eq!(f.poll(ms(15)), None, "3 ms of silence is less than t3.5");
    let req = f.poll(ms(17)).expect("ended by silence");
    assert_eq!(
        (req.bytes.as_slice(), req.start, req.end),
        (&READ_REQ[..], ms(10), ms(12))
    );
    assert_eq!((req.gap, req.ended_by), (None, FrameEnd::Silence));
    // The reply 40 ms later: its gap is measured from the request's last byte.
    f.push(&READ_REPLY, ms(52), &mut out);
    f.push(b"@3?X1\r\n", ms(80), &mut out);
    assert_eq!(out.len(), 2, "{out:?}");
    assert_eq!(out[0].bytes, READ_REPLY);
    assert_eq!(out[0].gap, Some(ms(40)));
    assert_eq!(
        (out[1].bytes.as_slice(), out[1].ended_by),
        (&b"@3?X1\r"[..], FrameEnd::Terminator)
    );
    assert_eq!(out[1].gap, Some(ms(28)));
    // The LF after the CR is not a frame; a CR inside a binary frame is data.
    let binary = with_crc(&[0x0D, 0x03, 0x0D, 0x0D, 0x00, 0x01]);
    out.clear();
    f.push(&binary, ms(90), &mut out);
    assert!(out.is_empty());
    assert_eq!(f.poll(ms(100)).map(|fr| fr.bytes), Some(binary));
}

#[test]
fn lines_read_together_show_no_silence_between_them() {
    // A reader late on a loaded machine gets a question and its answer in one read: the
    // second line's gap is unknown, not zero; the next read's line has its own.
    let mut f = Framer::new(Framing::Text, ms(4));
    let mut out = Vec::new();
    f.push(b"@3?X1\r@3X1=0\r", ms(10), &mut out);
    f.push(b"@3?X2\r", ms(70), &mut out);
    let gaps: Vec<Option<Duration>> = out.iter().map(|fr| fr.gap).collect();
    assert_eq!(gaps, [None, None, Some(ms(60))]);
}

#[test]
fn text_framing_cuts_an_unterminated_line_at_silence_and_memory_is_bounded() {
    let mut f = Framer::new(Framing::Text, ms(5));
    let mut out = Vec::new();
    f.push(b"@1?X", ms(0), &mut out);
    assert_eq!(f.poll(ms(5)).map(|fr| fr.ended_by), Some(FrameEnd::Silence));
    // A babbling transmitter: cut every MAX_FRAME bytes.
    let noise = vec![0x55u8; framer::MAX_FRAME * 2 + 10];
    let mut rtu = Framer::new(Framing::Rtu, ms(5));
    rtu.push(&noise, ms(10), &mut out);
    assert_eq!(out.len(), 2);
    assert!(out
        .iter()
        .all(|fr| fr.ended_by == FrameEnd::Overflow && fr.bytes.len() == framer::MAX_FRAME));
    assert_eq!(rtu.finish().map(|fr| fr.bytes.len()), Some(10));
}

#[test]
fn rtu_frames_glued_together_are_split_where_their_crcs_say() {
    let glued: Vec<u8> = [&READ_REQ[..], &READ_REPLY[..]].concat();
    let whole = HeardFrame {
        bytes: glued,
        start: ms(10),
        end: ms(14),
        gap: Some(ms(50)),
        ended_by: FrameEnd::Silence,
    };
    let pieces = framer::unglue(whole);
    let parts: Vec<(&[u8], Option<Duration>, FrameEnd)> = pieces
        .iter()
        .map(|p| (p.bytes.as_slice(), p.gap, p.ended_by))
        .collect();
    assert_eq!(
        parts,
        [
            (&READ_REQ[..], Some(ms(50)), FrameEnd::Glued),
            (&READ_REPLY[..], None, FrameEnd::Silence)
        ]
    );
    // A frame with a bad CRC that does not divide into good ones stays whole; so does text.
    let mut bad = READ_REPLY.to_vec();
    bad[4] ^= 1;
    for bytes in [bad, b"@1?X1\r".to_vec()] {
        let frame = HeardFrame {
            bytes: bytes.clone(),
            start: ms(0),
            end: ms(0),
            gap: None,
            ended_by: FrameEnd::Silence,
        };
        assert_eq!(framer::unglue(frame).len(), 1);
    }
}
