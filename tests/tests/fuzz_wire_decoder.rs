//! Fuzzing the frame decoder behind `softplc run --trace-bus` and `softplc monitor`, and the
//! monitor's framing: whatever a line carries (frames from the manuals with bytes flipped, cut
//! or glued together, noise, text in every protocol's alphabet), nothing panics, every byte is
//! framed exactly once and no frame outgrows its bound. Same conventions as `fuzz_wire.rs`:
//! proptest's 256 cases per property here, `PROPTEST_CASES=200000` for a long run.

use std::time::Duration;

use proptest::collection::vec;
use proptest::prelude::*;
use softplc_io::wire::{
    decode_reply, decode_request, unglue, Conversation, Framer, Framing, Shown, MAX_FRAME,
};

/// Frames from the manuals: Modbus (read, its reply, an exception, Collect and its event),
/// MiniMod text, RESI ASCII, DCON with and without checksum.
const SEEDS: &[&[u8]] = &[
    &[0x11, 0x03, 0x00, 0x6B, 0x00, 0x03, 0x76, 0x87],
    &[
        0x11, 0x03, 0x06, 0x02, 0x2B, 0x00, 0x00, 0x00, 0x64, 0xC8, 0xBA,
    ],
    &[0x01, 0x83, 0x02, 0xC0, 0xF1],
    &[0x00, 0x46, 0x01, 0x10, 0x00, 0x00, 0x89, 0xED],
    &[0x04, 0x46, 0x05, 0x02, 0x00, 0x05, 0x00, 0x9E, 0x8E],
    b"@3?X1\r",
    b"X1=1\r",
    b"@3>SERLINE=9600E\r",
    b"#0x2B,VER\r",
    b"#0x2B,VERSION:3.0.0\r",
    b"$01M\r",
    b"!019053\r",
    b"#032\r",
    b"$01MD2\r",
    b"?02\r",
];

/// A seed frame with a few bytes changed, cut, or with bytes glued on.
fn mutated() -> impl Strategy<Value = Vec<u8>> {
    (
        proptest::sample::select(SEEDS),
        vec((any::<usize>(), any::<u8>()), 0..3),
        any::<usize>(),
        vec(any::<u8>(), 0..4),
    )
        .prop_map(|(seed, flips, cut, tail)| {
            let mut v = seed.to_vec();
            for (at, b) in flips {
                let n = v.len();
                v[at % n] = b;
            }
            v.truncate(1 + cut % v.len());
            v.extend(tail);
            v
        })
}

/// Text of the protocols' alphabets, or any bytes.
fn noise() -> impl Strategy<Value = Vec<u8>> {
    const TEXT: &[u8] = b"?>@#$%~!=:,.-* 0123456789ABCDEFMXYOKr\r\n";
    prop_oneof![
        vec(proptest::sample::select(TEXT), 0..40),
        vec(any::<u8>(), 0..80),
    ]
}

fn frame() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![mutated(), noise()]
}

proptest! {
    /// Any frame decodes as a request, as a reply to any other, and in a conversation, and
    /// prints; nothing panics.
    #[test]
    fn any_frame_decodes_and_prints(frames in vec(frame(), 1..6)) {
        let mut talk = Conversation::new();
        for (i, f) in frames.iter().enumerate() {
            let request = &frames[i.saturating_sub(1)];
            let shown = format!("{} {} {} {}", Shown(f), decode_request(f), decode_reply(f, request), talk.frame(f));
            prop_assert!(!shown.is_empty());
        }
    }

    /// The framer (and the splitting of glued RTU frames after it) takes any stream in any
    /// chunks at any times: every byte comes out in exactly one frame, in order (an LF right after a CR excepted), no frame is longer than
    /// MAX_FRAME, and none ends before it starts.
    #[test]
    fn framing_keeps_every_byte_once(
        frames in vec(frame(), 0..8),
        steps in vec(0u64..10_000, 1..16),
        mode in proptest::sample::select(vec![Framing::Auto, Framing::Rtu, Framing::Text]),
        big in any::<bool>(),
    ) {
        let mut stream: Vec<u8> = frames.concat();
        if big {
            stream.extend(std::iter::repeat_n(0x55, MAX_FRAME + 3));
        }
        let mut framer = Framer::new(mode, Duration::from_micros(1750));
        let mut out = Vec::new();
        let mut t = Duration::ZERO;
        let mut rest = stream.as_slice();
        for (i, step) in steps.iter().cycle().enumerate() {
            if rest.is_empty() {
                break;
            }
            t += Duration::from_micros(*step);
            let n = (1 + i * 7 % 13).min(rest.len());
            let (now, later) = rest.split_at(n);
            framer.push(now, t, &mut out);
            out.extend(framer.poll(t));
            rest = later;
        }
        out.extend(framer.finish());
        let mut joined = Vec::new();
        // Splitting glued RTU frames by their CRCs keeps every byte too.
        for f in &out.into_iter().flat_map(unglue).collect::<Vec<_>>() {
            prop_assert!(!f.bytes.is_empty() && f.bytes.len() <= MAX_FRAME);
            prop_assert!(f.end >= f.start);
            joined.extend_from_slice(&f.bytes);
        }
        if mode == Framing::Rtu {
            prop_assert_eq!(joined, stream);
        } else {
            // An LF right after a frame's CR is dropped; every other byte is kept.
            let lf = |b: &&u8| **b != b'\n';
            prop_assert!(joined.len() <= stream.len());
            prop_assert!(joined.iter().filter(lf).eq(stream.iter().filter(lf)));
        }
    }
}
