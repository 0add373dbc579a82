//! The bus owner's line discipline, on a scripted line with the real MiniMod driver.
//!
//! Every case runs on a virtual time cursor: the script says which bytes arrive when after
//! each request, and the tests assert what the owner wrote (byte-exact, and when), what it
//! counted, and what reached the image. DESIGN.md principle 4: a fragmented reply is
//! reassembled, a corrupted or foreign reply is refused and retried, a late reply is flushed
//! and never taken as the answer to the next request, an exception is not retried.

use std::time::Duration;

use softplc_io::driver::DecodeError;
use softplc_io::line::{
    BusOwner, Discipline, InputFrame, LineSettings, Module, OutputFrame, TxError,
};
use softplc_io::modbus::{ExceptionCode, ReplyError};
use softplc_io::point::{Quality, Value};
use softplc_io::time::LineInstant;
use softplc_tests::frames::{exception, hex, minimod_inputs_reply, rtu};
use softplc_tests::minimod::{desired, driver, point};
use softplc_tests::scripted::{scripted, Answer, ScriptHandle};

const UNIT: u8 = 5;
const LINE: LineSettings = LineSettings::DEFAULT;
/// The MiniMod's power-on reply delay (RDELAYT = 1: 10 ms).
const DELAY: Duration = Duration::from_millis(10);
const TIMEOUT: Duration = Duration::from_millis(100);
/// The guard after a timeout or a bad reply: half the response timeout (it is longer than
/// two t3.5 at 19200 Bd).
const GUARD: Duration = Duration::from_millis(50);

/// The per-cycle read of unit 5: FC 2, discrete inputs 0..=9 (10001..10010).
const READ_INPUTS: [u8; 8] = [0x05, 0x02, 0x00, 0x00, 0x00, 0x0A, 0xF9, 0x89];

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn t35() -> Duration {
    LINE.t3_5()
}

fn discipline() -> Discipline {
    Discipline {
        response_timeout: TIMEOUT,
        retries: 1,
        output_refresh: Duration::from_secs(1),
        fail_limit: 3,
        ..Discipline::default()
    }
}

/// A bus owner with one MiniMod at unit 5 on a scripted 19200 8E1 line.
fn owner() -> (BusOwner, ScriptHandle) {
    let (transport, script) = scripted(LINE);
    let module = Module::new("mm5", driver("mm5", UNIT));
    let owner = BusOwner::new("line1", Box::new(transport), discipline(), vec![module]);
    (owner, script)
}

/// The inputs reply with X1 at `x1`, X2, X3, X9, X10 off.
fn inputs(x1: bool) -> Vec<u8> {
    minimod_inputs_reply(UNIT, [x1, false, false], [false, false])
}

/// The inputs reply as a MiniMod puts it on the wire: after its reply delay, byte by byte.
fn reply(x1: bool) -> Answer {
    Answer::on_wire(LINE, DELAY, &inputs(x1))
}

fn value(frame: &InputFrame, name: &str) -> Option<Value> {
    frame.modules[0].values[point(name)]
}

fn x1(frame: &InputFrame) -> Option<Value> {
    value(frame, "X1")
}

const ON: Option<Value> = Some(Value::Bool(true));
const OFF: Option<Value> = Some(Value::Bool(false));

#[test]
fn the_cycle_read_is_the_manuals_fc2_and_a_reply_on_the_wire_is_taken() {
    let (mut owner, script) = owner();
    script.push(reply(true));
    let frame = owner.read_inputs();

    let w = script.written();
    assert_eq!(w.len(), 1);
    assert_eq!(hex(&w[0].bytes), hex(&READ_INPUTS));
    assert_eq!(w[0].start, Duration::ZERO, "an idle line is free at once");
    assert_eq!(w[0].end, LINE.chars(8));

    let m = &frame.modules[0];
    assert_eq!(m.quality, Quality::Good);
    assert_eq!(m.last_error, None);
    assert_eq!(x1(&frame), ON);
    for name in ["X2", "X3", "X9", "X10", "FB1", "FB2"] {
        assert_eq!(value(&frame, name), OFF, "{name}");
    }
    assert_eq!(value(&frame, "Y1"), None, "outputs are not read by default");
    assert_eq!(m.counters.requests, 1);
    assert_eq!(m.counters.errors(), 0);
    assert_eq!(m.counters.dropped_bytes, 0);
    // Request, the module's 10 ms, a 7-byte reply: DESIGN.md's transaction without its t3.5.
    assert_eq!(m.counters.last_round_trip, DELAY + LINE.chars(7));
    assert_eq!(frame.started, LineInstant::ZERO);
    assert_eq!(
        frame.finished.since_origin(),
        LINE.chars(8) + DELAY + LINE.chars(7)
    );
    assert_eq!(script.unread(), 0);
}

#[test]
fn a_reply_in_one_byte_fragments_is_reassembled() {
    let (mut owner, script) = owner();
    // Slower than the wire (a USB adapter's chunking): 1 byte every 4 ms, longer than t1.5
    // but within the owner's inter-character allowance.
    let bytes = inputs(true);
    script.push(Answer::fragments(DELAY, ms(4), &bytes));
    let frame = owner.read_inputs();
    assert_eq!(frame.modules[0].quality, Quality::Good);
    assert_eq!(x1(&frame), ON);
    assert_eq!(frame.modules[0].counters.requests, 1);
    assert_eq!(frame.modules[0].counters.errors(), 0);
    assert_eq!(
        frame.modules[0].counters.last_round_trip,
        DELAY + ms(4) * 6,
        "the reply ends with its last fragment"
    );

    // The next cycle, on the wire's own pace (one byte per character time).
    script.push(reply(false));
    let frame = owner.read_inputs();
    assert_eq!(x1(&frame), OFF);
    assert_eq!(frame.modules[0].counters.errors(), 0);
    assert_eq!(script.unread(), 0);
}

#[test]
fn a_reply_cut_by_a_long_silence_is_dropped_and_the_retry_answers() {
    let (mut owner, script) = owner();
    // Three bytes, 30 ms of silence (longer than the inter-character allowance), the rest:
    // the head must not be glued to the tail.
    let bytes = inputs(true);
    let mut cut = Answer::fragments(DELAY, LINE.char_time(), &bytes[..3]);
    for (i, b) in bytes[3..].iter().enumerate() {
        cut = cut.then(DELAY + ms(30) + LINE.char_time() * i as u32, &[*b]);
    }
    script.push(cut);
    script.push(reply(false));
    let frame = owner.read_inputs();
    let m = &frame.modules[0];
    assert_eq!(m.quality, Quality::Good);
    assert_eq!(x1(&frame), OFF, "the value comes from the retry");
    assert_eq!(m.counters.requests, 2);
    assert_eq!(m.counters.errors(), 1);
    assert_eq!(m.counters.dropped_bytes, 4, "the tail was flushed");
    assert_eq!(script.unread(), 0);
}

#[test]
fn a_flipped_bit_is_a_crc_error_retried_after_the_guard() {
    let (mut owner, script) = owner();
    let mut corrupt = inputs(false);
    corrupt[3] ^= 0x01; // X1 appears on, but the CRC no longer matches.
    script.push(Answer::on_wire(LINE, DELAY, &corrupt));
    script.push(reply(false));
    let frame = owner.read_inputs();

    let m = &frame.modules[0];
    assert_eq!(m.counters.crc_errors, 1);
    assert_eq!(m.counters.requests, 2, "retried once");
    assert_eq!(m.counters.errors(), 1);
    assert_eq!(m.quality, Quality::Good, "the retry succeeded");
    assert_eq!(m.last_error, None);
    assert_eq!(x1(&frame), OFF, "the corrupted X1 never reached the image");

    let w = script.written();
    assert_eq!(w.len(), 2);
    assert_eq!(hex(&w[1].bytes), hex(&READ_INPUTS));
    let corrupt_end = w[0].end + DELAY + LINE.chars(7);
    assert_eq!(
        w[1].start,
        corrupt_end + GUARD + t35(),
        "guard after the bad reply, then t3.5 of silence"
    );
}

#[test]
fn no_reply_is_a_timeout_stale_then_bad_then_good_again() {
    let (mut owner, script) = owner();
    script.push(reply(true));
    assert_eq!(owner.read_inputs().modules[0].quality, Quality::Good);

    // Three cycles of silence: two attempts in the first (retries: 1), then one per cycle
    // while the module is failing (retries are for noise, not for a module that is gone).
    let mut qualities = Vec::new();
    for cycle in 0..3 {
        script.push(Answer::silence());
        if cycle == 0 {
            script.push(Answer::silence());
        }
        let frame = owner.read_inputs();
        let m = &frame.modules[0];
        assert_eq!(m.last_error, Some(TxError::Timeout(TIMEOUT)));
        assert_eq!(x1(&frame), ON, "the last good value is kept");
        qualities.push(m.quality);
    }
    assert_eq!(
        qualities,
        [Quality::Stale, Quality::Stale, Quality::Bad],
        "bad at the fail limit (3 cycles)"
    );

    // Each attempt: response timeout, guard, t3.5, then the next request.
    let w = script.written();
    assert_eq!(w.len(), 5);
    for pair in w[1..].windows(2) {
        assert_eq!(pair[1].start, pair[0].end + TIMEOUT + GUARD + t35());
    }

    // Lost: not polled again before the reconnect backoff (1 s), so it costs no bus time.
    let frame = owner.read_inputs();
    assert_eq!(frame.modules[0].quality, Quality::Bad);
    assert_eq!(script.written().len(), 5, "no request while backing off");
    let m = &frame.modules[0];
    assert_eq!(m.counters.timeouts, 4);
    assert_eq!(m.counters.requests, 5);
    assert_eq!(
        m.outputs,
        Quality::Bad,
        "a lost module's outputs are not held"
    );

    // At the backoff its probe is the first exchange of its start-up sequence, one attempt:
    // a module that may have been power-cycled gets its settings again before it is read
    // (the whole comeback, against simulators: runtime/tests/transients.rs).
    owner.sync(LineInstant::after_origin(
        script.now() + Duration::from_secs(1),
    ));
    script.push(Answer::silence());
    let frame = owner.read_inputs();
    assert_eq!(frame.modules[0].quality, Quality::Bad);
    assert_eq!(script.written().len(), 6, "one request per probe");
}

/// A reply to the first attempt that comes `after` the request (past the response timeout),
/// with X1 on; the retry's reply says X1 off. The image must get the retry's value.
fn late_reply_case(late: Answer, what: &str) {
    let (mut owner, script) = owner();
    script.push(late);
    script.push(reply(false));
    let frame = owner.read_inputs();
    let m = &frame.modules[0];
    assert_eq!(
        x1(&frame),
        OFF,
        "{what}: the late reply was taken as the answer"
    );
    assert_eq!(m.quality, Quality::Good, "{what}");
    assert_eq!(m.counters.timeouts, 1, "{what}");
    assert_eq!(m.counters.requests, 2, "{what}");
    assert_eq!(
        m.counters.dropped_bytes, 7,
        "{what}: the late reply was flushed"
    );
    assert_eq!(script.flushed(), 7, "{what}");
    assert_eq!(script.unread(), 0, "{what}");
    let w = script.written();
    assert_eq!(w[1].start, w[0].end + TIMEOUT + GUARD + t35(), "{what}");
}

#[test]
fn a_late_reply_during_the_guard_is_flushed() {
    // Whole, 120 ms after the request: after the 100 ms timeout, inside the 50 ms guard.
    late_reply_case(Answer::at(ms(120), &inputs(true)), "during the guard");
}

#[test]
fn a_late_reply_across_the_end_of_the_guard_is_flushed() {
    // On the wire from 148 ms: four bytes inside the guard, three after it, before the retry.
    late_reply_case(
        Answer::fragments(ms(148), LINE.char_time(), &inputs(true)),
        "across the end of the guard",
    );
}

#[test]
fn a_late_reply_right_before_the_next_request_is_flushed() {
    // 151 ms: after the guard (150 ms), within the t3.5 before the retry (152 ms).
    late_reply_case(Answer::at(ms(151), &inputs(true)), "right before the retry");
}

#[test]
fn a_late_reply_between_cycles_is_not_the_answer_to_the_next_cycle() {
    let (mut owner, script) = owner();
    // Both attempts of the first cycle time out; the second's reply comes 400 ms late, while
    // the line is idle between cycles.
    script.push(Answer::silence());
    script.push(Answer::at(ms(400), &inputs(true)));
    let frame = owner.read_inputs();
    assert_eq!(frame.modules[0].quality, Quality::Stale);
    assert_eq!(x1(&frame), None, "never read");

    owner.sync(LineInstant::after_origin(Duration::from_secs(1)));
    script.push(reply(false));
    let frame = owner.read_inputs();
    let m = &frame.modules[0];
    assert_eq!(x1(&frame), OFF, "the late reply was taken as the answer");
    assert_eq!(m.quality, Quality::Good);
    assert_eq!(m.counters.dropped_bytes, 7);
    assert_eq!(script.written()[2].start, Duration::from_secs(1));
}

#[test]
fn a_reply_from_another_unit_is_a_bad_reply_and_retried() {
    let (mut owner, script) = owner();
    let foreign = minimod_inputs_reply(6, [true, false, false], [false, false]);
    script.push(Answer::on_wire(LINE, DELAY, &foreign));
    script.push(reply(false));
    let frame = owner.read_inputs();
    let m = &frame.modules[0];
    assert_eq!(m.counters.bad_replies, 1);
    assert_eq!(m.counters.crc_errors, 0);
    assert_eq!(m.counters.requests, 2);
    assert_eq!(m.quality, Quality::Good);
    assert_eq!(x1(&frame), OFF, "unit 6's X1 never reached unit 5's image");
    assert_eq!(
        m.counters.dropped_bytes, 6,
        "refused at its first byte; the rest flushed after the guard"
    );
    assert_eq!(script.unread(), 0);

    // Unit 6 answers both attempts of the next cycle: the module's read failed, and says why.
    script.push(Answer::on_wire(LINE, DELAY, &foreign));
    script.push(Answer::on_wire(LINE, DELAY, &foreign));
    let frame = owner.read_inputs();
    let m = &frame.modules[0];
    assert_eq!(m.quality, Quality::Stale);
    assert_eq!(
        m.last_error,
        Some(TxError::BadReply(ReplyError::WrongUnit {
            expected: 5,
            found: 6
        }))
    );
    assert_eq!(x1(&frame), OFF, "the last good value is kept");
    assert_eq!(m.counters.bad_replies, 3);
}

#[test]
fn an_exception_is_counted_and_not_retried() {
    let (mut owner, script) = owner();
    // 05 82 02: illegal data address.
    let refused = exception(UNIT, 0x02, 0x02);
    assert_eq!(hex(&refused), "05 82 02 80 A0");
    script.push(Answer::on_wire(LINE, DELAY, &refused));
    let frame = owner.read_inputs();
    let m = &frame.modules[0];
    assert_eq!(m.counters.exceptions, 1);
    assert_eq!(
        m.counters.requests, 1,
        "the device said no: asking again changes nothing"
    );
    assert_eq!(m.counters.errors(), 1);
    assert_eq!(m.counters.crc_errors + m.counters.bad_replies, 0);
    assert_eq!(m.quality, Quality::Stale);
    assert_eq!(
        m.last_error,
        Some(TxError::Decode(DecodeError::Exception(
            ExceptionCode::IllegalDataAddress
        )))
    );
    assert_eq!(x1(&frame), None);

    // The exception was a complete reply: the next request only waits t3.5.
    script.push(reply(true));
    let frame = owner.read_inputs();
    assert_eq!(x1(&frame), ON);
    let w = script.written();
    assert_eq!(w[1].start, w[0].end + DELAY + LINE.chars(5) + t35());
}

#[test]
fn extra_trailing_bytes_are_dropped_and_the_reply_kept() {
    let (mut owner, script) = owner();
    // Glued to the reply in the same read.
    let mut glued = inputs(true);
    glued.extend_from_slice(&[0xFF, 0x00]);
    script.push(Answer::at(DELAY, &glued));
    let frame = owner.read_inputs();
    let m = &frame.modules[0];
    assert_eq!(x1(&frame), ON);
    assert_eq!(m.quality, Quality::Good);
    assert_eq!(m.counters.errors(), 0);
    assert_eq!(m.counters.dropped_bytes, 2);

    // Arriving after the complete reply: flushed before the next request.
    let babble = reply(false).then(ms(40), &[0x05, 0x02, 0x02]);
    script.push(babble);
    let frame = owner.read_inputs();
    assert_eq!(x1(&frame), OFF);
    owner.sync(LineInstant::after_origin(ms(1000)));
    script.push(reply(true));
    let frame = owner.read_inputs();
    let m = &frame.modules[0];
    assert_eq!(x1(&frame), ON, "the babble did not disturb the next reply");
    assert_eq!(m.counters.errors(), 0);
    assert_eq!(m.counters.dropped_bytes, 5);
    assert_eq!(m.counters.requests, 3);
}

#[test]
fn outputs_are_written_on_change_byte_exact_and_refreshed() {
    let (mut owner, script) = owner();
    let y1_on = OutputFrame {
        modules: vec![desired(&[("Y1", true)])],
    };
    // FC 5 on coil 0 (00001), ON = FF 00; the MiniMod echoes the request.
    let write_y1 = rtu(&[0x05, 0x05, 0x00, 0x00, 0xFF, 0x00]);
    assert_eq!(hex(&write_y1), "05 05 00 00 FF 00 8D BE");
    script.push(Answer::on_wire(LINE, DELAY, &write_y1));
    let report = owner.write_outputs(&y1_on);
    assert_eq!((report.transactions, report.failures), (1, 0));
    assert_eq!(hex(&script.written()[0].bytes), hex(&write_y1));
    assert_eq!(
        owner.modules()[0].driver.values()[point("Y1")],
        ON,
        "the echo is the module's output state"
    );

    // No change: nothing on the line.
    owner.sync(LineInstant::after_origin(ms(100)));
    let report = owner.write_outputs(&y1_on);
    assert_eq!(report.transactions, 0);
    assert_eq!(script.written().len(), 1);

    // The refresh period (1 s) has passed: written again.
    owner.sync(LineInstant::after_origin(ms(1000)));
    script.push(Answer::on_wire(LINE, DELAY, &write_y1));
    let report = owner.write_outputs(&y1_on);
    assert_eq!(report.transactions, 1);
    assert_eq!(script.written()[1].start, ms(1000));

    // Y1 off: FC 5 with 00 00. Its echo is lost twice: the write failed, and the next cycle
    // writes it again.
    let y1_off = OutputFrame {
        modules: vec![desired(&[("Y1", false)])],
    };
    let write_y1_off = rtu(&[0x05, 0x05, 0x00, 0x00, 0x00, 0x00]);
    assert_eq!(hex(&write_y1_off), "05 05 00 00 00 00 CC 4E");
    owner.sync(LineInstant::after_origin(ms(1100)));
    script.push(Answer::silence());
    script.push(Answer::silence());
    let report = owner.write_outputs(&y1_off);
    assert_eq!((report.transactions, report.failures), (1, 1));
    let w = script.written();
    assert_eq!(hex(&w[2].bytes), hex(&write_y1_off));
    assert_eq!(hex(&w[3].bytes), hex(&write_y1_off), "retried once");

    owner.sync(LineInstant::after_origin(ms(1500)));
    script.push(Answer::on_wire(LINE, DELAY, &write_y1_off));
    let report = owner.write_outputs(&y1_off);
    assert_eq!((report.transactions, report.failures), (1, 0));
    assert_eq!(hex(&script.written()[4].bytes), hex(&write_y1_off));
    assert_eq!(owner.modules()[0].driver.values()[point("Y1")], OFF);
    assert_eq!(script.answers_left(), 0);
}

#[test]
fn a_refused_write_is_not_retried() {
    let (mut owner, script) = owner();
    let frame = OutputFrame {
        modules: vec![desired(&[("Y1", true)])],
    };
    script.push(Answer::on_wire(LINE, DELAY, &exception(UNIT, 0x05, 0x02)));
    let report = owner.write_outputs(&frame);
    assert_eq!((report.transactions, report.failures), (1, 1));
    assert_eq!(script.written().len(), 1, "an exception is not retried");
    // Planned again next cycle, as any failed write.
    owner.sync(LineInstant::after_origin(ms(100)));
    script.push(Answer::on_wire(
        LINE,
        DELAY,
        &rtu(&[0x05, 0x05, 0x00, 0x00, 0xFF, 0x00]),
    ));
    let report = owner.write_outputs(&frame);
    assert_eq!((report.transactions, report.failures), (1, 0));
}

#[test]
fn a_write_refused_by_the_module_watchdog_waits_for_its_restart() {
    let (mut owner, script) = owner();
    let frame = OutputFrame {
        modules: vec![desired(&[("Y1", true)])],
    };
    // 04: the module holds its own safe state (a fired watchdog refuses writes).
    script.push(Answer::on_wire(LINE, DELAY, &exception(UNIT, 0x05, 0x04)));
    let report = owner.write_outputs(&frame);
    assert_eq!((report.transactions, report.failures), (1, 1));
    // No more writes until its start-up has run again (at the next read): they would be
    // refused the same way.
    owner.sync(LineInstant::after_origin(ms(100)));
    let report = owner.write_outputs(&frame);
    assert_eq!((report.transactions, report.failures), (0, 0));
    assert_eq!(script.written().len(), 1);
}

#[test]
fn a_wrong_echo_is_a_bad_reply() {
    let (mut owner, script) = owner();
    let frame = OutputFrame {
        modules: vec![desired(&[("Y1", true)])],
    };
    // The echo names coil 1 instead of coil 0.
    let wrong = rtu(&[0x05, 0x05, 0x00, 0x01, 0xFF, 0x00]);
    let right = rtu(&[0x05, 0x05, 0x00, 0x00, 0xFF, 0x00]);
    script.push(Answer::on_wire(LINE, DELAY, &wrong));
    script.push(Answer::on_wire(LINE, DELAY, &right));
    let report = owner.write_outputs(&frame);
    assert_eq!((report.transactions, report.failures), (1, 0));
    let c = owner.modules()[0].driver.values()[point("Y1")];
    assert_eq!(c, ON);
    // The counters of a write show in the next read's snapshot.
    script.push(reply(false));
    let snap = owner.read_inputs();
    let m = &snap.modules[0];
    assert_eq!(m.counters.bad_replies, 1);
    assert_eq!(m.counters.requests, 3);
}
