//! Where a request ends, on the virtual line and deterministically: the simulated MiniMod
//! frames a request by "a silence on the line, lasting 28 bits or more", enlarged by RDELAYM
//! tenths of a millisecond (manual, "Setting the Modbus communication timeout"). A master that
//! pauses inside a request for less than that still sends one request and gets its reply; a
//! longer pause makes two halves, neither of which passes the CRC, and the module answers
//! nothing.

use std::sync::Arc;
use std::time::Duration;

use crate::devices;
use crate::line::transport::Transport;
use crate::line::LineSettings;
use crate::modbus::crc::append_crc;
use crate::sim::line::{SimWorld, VirtualPort};
use crate::time::{LineInstant, VirtualClock};

/// FC 2 of discrete inputs 0..=9 from unit 5 (the driver's input read).
fn fc2() -> Vec<u8> {
    let mut f = vec![5, 0x02, 0x00, 0x00, 0x00, 0x0A];
    append_crc(&mut f);
    f
}

/// A MiniMod at 5 on a line at `settings`, with `rdelaym` set by its text command; the
/// master's port on a virtual clock.
fn line(settings: LineSettings, rdelaym: u8) -> (VirtualPort, Arc<VirtualClock>) {
    let mut world = SimWorld::new(vec![settings]);
    world.add_device(0, "mm5", (devices::model("minimod").unwrap().simulator)(5));
    let clock = Arc::new(VirtualClock::new());
    let mut port = VirtualPort::new(world.shared(), 0, settings, clock.clone());
    port.sync(LineInstant::after_origin(Duration::from_millis(100)));
    port.write_frame(format!("@5>RDELAYM={rdelaym}\r").as_bytes())
        .unwrap();
    assert_eq!(read_all(&mut port, Duration::from_secs(1)), b"OK\r");
    port.wait_until(port.now() + Duration::from_millis(50));
    (port, clock)
}

/// The FC 2 request sent in two halves (4 + 4 bytes) with `gap` of silence between them;
/// the reply heard within 200 ms, and when it began after the request's last byte.
fn split(settings: LineSettings, rdelaym: u8, gap: Duration) -> (Vec<u8>, Option<Duration>) {
    let (mut port, _clock) = line(settings, rdelaym);
    let request = fc2();
    port.write_frame(&request[..4]).unwrap();
    port.wait_until(port.now() + gap);
    port.write_frame(&request[4..]).unwrap();
    let sent = port.now();
    let mut reply = Vec::new();
    port.read_until(&mut reply, sent + Duration::from_millis(200))
        .unwrap();
    // The first byte arrived one character after the reply began.
    let began = (!reply.is_empty()).then(|| (port.now() - settings.char_time()) - sent);
    reply.extend(read_all(&mut port, Duration::from_millis(200)));
    (reply, began)
}

/// Everything that arrives within `wait` from now.
fn read_all(port: &mut VirtualPort, wait: Duration) -> Vec<u8> {
    let deadline = port.now() + wait;
    let mut bytes = Vec::new();
    while port.read_until(&mut bytes, deadline).unwrap() > 0 {}
    bytes
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn us(n: u64) -> Duration {
    Duration::from_micros(n)
}

const AT_19200: LineSettings = LineSettings::DEFAULT;

#[test]
fn rdelaym_200_joins_halves_10_ms_apart_into_one_request() {
    let (reply, _) = split(AT_19200, 200, ms(10));
    assert_eq!(
        &reply[..3],
        &[5, 0x02, 0x02],
        "one request, answered: {reply:02X?}"
    );
    // 28 bits at 19200 (1.458 ms) + 20 ms: a pause of 25 ms ends the request.
    let (reply, _) = split(AT_19200, 200, ms(25));
    assert!(reply.is_empty(), "two halves, no reply: {reply:02X?}");
}

#[test]
fn rdelaym_100_joins_halves_6_ms_apart() {
    let (reply, _) = split(AT_19200, 100, ms(6));
    assert_eq!(&reply[..3], &[5, 0x02, 0x02], "{reply:02X?}");
}

#[test]
fn at_rdelaym_0_a_pause_of_28_bits_or_more_ends_the_request() {
    // 28 bits at 19200: 1458.3 µs. The manual: "lasting 28 bits or more".
    let (reply, _) = split(AT_19200, 0, ms(3));
    assert!(
        reply.is_empty(),
        "3 ms at 19200 is two requests: {reply:02X?}"
    );
    let (reply, _) = split(AT_19200, 0, us(1459));
    assert!(
        reply.is_empty(),
        "just over the silence ends it: {reply:02X?}"
    );
    let (reply, _) = split(AT_19200, 0, us(1458));
    assert_eq!(&reply[..3], &[5, 0x02, 0x02], "just under it: {reply:02X?}");
    // At 9600 the same 28 bits last 2917 µs: a 2 ms pause is inside a request.
    let at_9600 = LineSettings {
        baud: 9600,
        ..AT_19200
    };
    let (reply, _) = split(at_9600, 0, ms(2));
    assert_eq!(&reply[..3], &[5, 0x02, 0x02], "{reply:02X?}");
}

#[test]
fn a_split_request_is_answered_after_its_reply_delay_from_its_last_byte() {
    // RDELAYT power-on 10 ms + RDELAYM 5 ms ("Setting the reply delay"): the turn-around is
    // counted from the request's last byte, as for a request sent whole.
    let (_, whole) = split(AT_19200, 50, Duration::ZERO);
    let (_, halves) = split(AT_19200, 50, ms(4));
    assert_eq!(whole, Some(ms(15)));
    assert_eq!(halves, whole);
}

#[test]
fn after_two_halves_that_were_two_requests_the_next_request_is_answered() {
    let (mut port, _clock) = line(AT_19200, 0);
    let request = fc2();
    port.write_frame(&request[..4]).unwrap();
    port.wait_until(port.now() + ms(5));
    port.write_frame(&request[4..]).unwrap();
    assert!(read_all(&mut port, ms(100)).is_empty());
    port.write_frame(&request).unwrap();
    let reply = read_all(&mut port, ms(100));
    assert_eq!(reply.len(), 7, "{reply:02X?}");
}
