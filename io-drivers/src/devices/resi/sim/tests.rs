//! The manual's worked examples of the 16DI8RO logic (10.1.1, L16514–L16750), over ASCII and
//! over Modbus, byte-exact, and their behaviour on the simulator's clock.

use super::*;
use crate::devices::resi::models::{m16di8ro, m1ro, m2rtd, m8co};
use crate::line::settings::LineSettings;
use crate::modbus::crc::append_crc;
use std::time::Duration;

use crate::time::LineInstant;

const UNIT: u8 = 1;

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// `n` ms after the line's origin.
fn at(n: u64) -> LineInstant {
    LineInstant::after_origin(ms(n))
}

fn sim() -> ResiSim {
    ResiSim::new(&m16di8ro::MODEL, UNIT)
}

/// An ASCII exchange at `t` ms.
fn ascii(s: &mut ResiSim, t: u64, request: &str) -> Option<String> {
    s.on_frame(request.as_bytes(), at(t))
        .map(|r| String::from_utf8(r.bytes).unwrap())
}

/// Sends an ASCII request the manual shows answered `#OK`.
fn ok(s: &mut ResiSim, t: u64, request: &str) {
    assert_eq!(
        ascii(s, t, request).as_deref(),
        Some("#OK\r"),
        "{request:?}"
    );
}

fn with_crc(bytes: &[u8]) -> Vec<u8> {
    let mut f = bytes.to_vec();
    append_crc(&mut f);
    f
}

/// A Modbus exchange at `t` ms; the reply frame.
fn rtu(s: &mut ResiSim, t: u64, request: &[u8]) -> Option<Vec<u8>> {
    s.on_frame(&with_crc(request), at(t)).map(|r| r.bytes)
}

/// A Modbus write whose reply is its echo (FC 5, FC 6).
fn echo(s: &mut ResiSim, t: u64, request: &[u8]) {
    assert_eq!(
        rtu(s, t, request),
        Some(with_crc(request)),
        "{request:02X?}"
    );
}

fn point(s: &ResiSim, name: &str) -> Value {
    s.get(name).unwrap()
}

fn on(s: &ResiSim, name: &str) -> bool {
    point(s, name).as_bool()
}

fn press(s: &mut ResiSim, t: u64, di: &str, level: bool) {
    s.advance_to(at(t));
    s.set(di, Value::Bool(level)).unwrap();
}

fn relays(s: &ResiSim) -> u16 {
    match point(s, "ROS") {
        Value::U16(v) => v,
        other => panic!("{other:?}"),
    }
}

#[test]
fn frames_of_resi_spec_3_6_are_byte_exact() {
    // The digest's derived frames, unit 1, CRC low byte first.
    let mut s = sim();
    let frames: [&[u8]; 9] = [
        &[0x01, 0x02, 0x00, 0x00, 0x00, 0x10, 0x79, 0xC6],
        &[0x01, 0x01, 0x00, 0x10, 0x00, 0x08, 0x3C, 0x09],
        &[0x01, 0x05, 0x00, 0x10, 0xFF, 0x00, 0x8D, 0xFF],
        &[0x01, 0x06, 0x00, 0x65, 0x00, 0xFF, 0xD9, 0x95],
        &[0x01, 0x06, 0x52, 0x08, 0x00, 0x01, 0xD9, 0x70],
        &[
            0x01, 0x10, 0x4E, 0x60, 0x00, 0x02, 0x04, 0x00, 0x00, 0x01, 0x2C, 0x88, 0x69,
        ],
        &[0x01, 0x03, 0x00, 0x00, 0x00, 0x20, 0x44, 0x12],
        &[0x01, 0x03, 0x00, 0xC8, 0x00, 0x10, 0xC5, 0xF8],
        &[0x01, 0x03, 0x4E, 0x80, 0x00, 0x10, 0x52, 0xC6],
    ];
    for f in frames {
        let (body, _) = f.split_at(f.len() - 2);
        assert_eq!(with_crc(body), f, "CRC of {f:02X?}");
        assert!(s.on_frame(f, at(0)).is_some(), "{f:02X?} answered");
    }
    // RO1 on, then all relays on through ROS: relay counter of RO1 is 1, RO2..8 too.
    assert_eq!(relays(&s), 0xFF);
    assert_eq!(point(&s, "ENABLE_LOGIC_FUNCTIONS"), Value::U16(1));
    assert_eq!(point(&s, "PULSE_TIME_RO1"), Value::I32(300));
    let counters = rtu(&mut s, 1, &[0x01, 0x03, 0x00, 0xC8, 0x00, 0x04]).unwrap();
    assert_eq!(
        counters,
        with_crc(&[0x01, 0x03, 0x08, 0, 0, 0, 1, 0, 0, 0, 1])
    );
    let low_first = rtu(&mut s, 1, &[0x01, 0x03, 0x00, 0xDC, 0x00, 0x02]).unwrap();
    assert_eq!(low_first, with_crc(&[0x01, 0x03, 0x04, 0, 1, 0, 0]));
    let di = rtu(&mut s, 1, &[0x01, 0x02, 0x00, 0x00, 0x00, 0x10]).unwrap();
    assert_eq!(di, with_crc(&[0x01, 0x02, 0x02, 0x00, 0x00]));
}

#[test]
fn switch_ro1_with_di1_over_ascii() {
    // L16514–L16526.
    let mut s = sim();
    ok(&mut s, 0, "#SET SWITCH1:0x0001\r");
    ok(&mut s, 5, "#SET SPECIAL MODE:1\r");
    assert_eq!(
        ascii(&mut s, 6, "#GSMODE\r").as_deref(),
        Some("#GSMODE:1,0x1\r"),
        "L16498"
    );
    press(&mut s, 100, "DI1", true);
    s.advance_to(at(109));
    assert!(!on(&s, "RO1"), "not before the next 10 ms sample");
    s.advance_to(at(110));
    assert!(on(&s, "RO1"));
    press(&mut s, 200, "DI1", false);
    s.advance_to(at(210));
    assert!(!on(&s, "RO1"));
    assert_eq!(relays(&s), 0, "the other relays are not affected");
    assert_eq!(
        ascii(&mut s, 300, "#1,GSWITCH1\r").as_deref(),
        Some("#1,GSWITCH1:1,0x1\r")
    );
}

#[test]
fn switch_ro1_with_di1_over_modbus() {
    let mut s = sim();
    echo(&mut s, 0, &[0x01, 0x06, 0x4E, 0x20, 0x00, 0x01]); // SWITCH RO1 (4x20001) = 1
    echo(&mut s, 1, &[0x01, 0x06, 0x52, 0x08, 0x00, 0x01]); // ENABLE (4x21001) = 1
    press(&mut s, 100, "DI1", true);
    let reply = rtu(&mut s, 110, &[0x01, 0x01, 0x00, 0x00, 0x00, 0x18]).unwrap();
    assert_eq!(
        reply,
        with_crc(&[0x01, 0x01, 0x03, 0x01, 0x00, 0x01]),
        "DI1 and RO1"
    );
}

#[test]
fn switch_eight_relays_with_eight_inputs() {
    // L16528–L16562.
    let mut s = sim();
    for x in 1..=8 {
        ok(
            &mut s,
            0,
            &format!("#SET SWITCH{x}:0x{:04X}\r", 1 << (x - 1)),
        );
    }
    ok(&mut s, 0, "#SET SPECIAL MODE:1\r");
    for (t, di) in [(10, "DI3"), (20, "DI8")] {
        press(&mut s, t, di, true);
    }
    s.advance_to(at(30));
    assert_eq!(relays(&s), 0b1000_0100);
}

#[test]
fn switch_on_ro1_with_any_of_di1_to_di4() {
    // L16570–L16582: SWITCH ON acts on rising edges; the relay stays on.
    let mut s = sim();
    ok(&mut s, 0, "#SET SWITCH ON1:0x000F\r");
    ok(&mut s, 0, "#SET SPECIAL MODE:1\r");
    press(&mut s, 10, "DI4", true);
    press(&mut s, 30, "DI4", false);
    s.advance_to(at(40));
    assert!(on(&s, "RO1"));
    // Modbus: SWITCH ON RO1 is 4x20017.
    let mut m = sim();
    echo(&mut m, 0, &[0x01, 0x06, 0x4E, 0x30, 0x00, 0x0F]);
    echo(&mut m, 0, &[0x01, 0x06, 0x52, 0x08, 0x00, 0x01]);
    press(&mut m, 10, "DI2", true);
    m.advance_to(at(20));
    assert!(on(&m, "RO1"));
}

#[test]
fn central_light_on_with_di16_and_off_with_di15() {
    // L16584–L16619 and L16645–L16680.
    let mut s = sim();
    for x in 1..=8 {
        ok(&mut s, 0, &format!("#SET SWITCH ON{x}:0x8000\r"));
        ok(&mut s, 0, &format!("#SET SWITCH OFF{x}:0x4000\r"));
    }
    ok(&mut s, 0, "#SET SPECIAL MODE:1\r");
    press(&mut s, 100, "DI16", true);
    s.advance_to(at(110));
    assert_eq!(relays(&s), 0xFF, "all eight relays on at once");
    // "If you don't press the button, you can switch each of the eight relay on or off via
    // MODBUS or ASCII protocol": the button is still held, the host switches RO3 off.
    assert_eq!(
        ascii(&mut s, 200, "#1,SRO3:0\r").as_deref(),
        Some("#1,OK\r")
    );
    echo(&mut s, 210, &[0x01, 0x05, 0x00, 0x14, 0x00, 0x00]); // RO5 off (coil 0x00021)
    s.advance_to(at(500));
    assert_eq!(
        relays(&s),
        0xFF & !0b0001_0100,
        "held buttons do not switch again"
    );
    press(&mut s, 600, "DI16", false);
    press(&mut s, 700, "DI15", true);
    s.advance_to(at(710));
    assert_eq!(relays(&s), 0, "central off");
    press(&mut s, 800, "DI15", false);
    ok(&mut s, 900, "#SRO8:1\r");
    s.advance_to(at(1000));
    assert_eq!(relays(&s), 0x80, "after release the host switches freely");
    assert_eq!(
        ascii(&mut s, 1000, "#GET SWITCH OFF8\r").as_deref(),
        Some("#GSOFF8:16384,0x4000\r")
    );
}

#[test]
fn central_light_on_over_modbus_and_erratum_3() {
    // The Modbus lines of L16608–L16615: SWITCH ON RO1..8 (4x20017..24) = 0x8000, then
    // "Write value 0x8000 to ... ENABLE LOGIC FUNCTIONS": the logic runs only on 1 (L22516).
    let mut s = sim();
    let mut f = vec![0x01, 0x10, 0x4E, 0x30, 0x00, 0x08, 0x10];
    for _ in 0..8 {
        f.extend([0x80, 0x00]);
    }
    assert_eq!(
        rtu(&mut s, 0, &f),
        Some(with_crc(&[0x01, 0x10, 0x4E, 0x30, 0x00, 0x08]))
    );
    echo(&mut s, 1, &[0x01, 0x06, 0x52, 0x08, 0x80, 0x00]);
    press(&mut s, 10, "DI16", true);
    s.advance_to(at(20));
    assert_eq!(relays(&s), 0, "ENABLE = 0x8000 runs no logic");
    press(&mut s, 30, "DI16", false);
    echo(&mut s, 40, &[0x01, 0x06, 0x52, 0x08, 0x00, 0x01]);
    press(&mut s, 50, "DI16", true);
    s.advance_to(at(60));
    assert_eq!(relays(&s), 0xFF);
    // The option for a module that would take any non-zero value.
    let mut lax = sim();
    lax.module_mut().opts.enable_exactly_one = false;
    echo(&mut lax, 0, &[0x01, 0x06, 0x4E, 0x30, 0x80, 0x00]);
    echo(&mut lax, 0, &[0x01, 0x06, 0x52, 0x08, 0x80, 0x00]);
    press(&mut lax, 10, "DI16", true);
    lax.advance_to(at(20));
    assert!(on(&lax, "RO1"));
}

#[test]
fn switch_off_ro2_with_di1_di3_di6() {
    // L16627–L16643: 37 = DI1 + DI3 + DI6.
    let mut s = sim();
    ok(&mut s, 0, "#SET SWITCH OFF2:37\r");
    ok(&mut s, 0, "#SET SPECIAL MODE:1\r");
    for (t, di) in [(10, "DI1"), (30, "DI3"), (50, "DI6")] {
        ok(&mut s, t - 5, "#SRO2:1\r");
        press(&mut s, t, di, true);
        s.advance_to(at(t + 10));
        assert!(!on(&s, "RO2"), "{di}");
    }
    // Modbus: SWITCH OFF RO2 is 4x20026.
    let mut m = sim();
    echo(&mut m, 0, &[0x01, 0x06, 0x4E, 0x39, 0x00, 0x25]);
    assert_eq!(point(&m, "SWITCH_OFF_RO2"), Value::U16(37));
}

#[test]
fn toggle_ro4_with_di1_or_di2() {
    // L16688–L16705.
    for modbus in [false, true] {
        let mut s = sim();
        if modbus {
            echo(&mut s, 0, &[0x01, 0x06, 0x4E, 0x2B, 0x00, 0x03]); // TOGGLE RO4 (4x20012)
            echo(&mut s, 0, &[0x01, 0x06, 0x52, 0x08, 0x00, 0x01]);
        } else {
            ok(&mut s, 0, "#SET TOGGLE4:3\r");
            ok(&mut s, 0, "#SET SPECIAL MODE:1\r");
        }
        let mut expected = false;
        for (t, di) in [(100, "DI1"), (300, "DI2"), (500, "DI1"), (700, "DI1")] {
            press(&mut s, t, di, true);
            s.advance_to(at(t + 10));
            expected = !expected;
            assert_eq!(on(&s, "RO4"), expected, "{di} at {t}");
            press(&mut s, t + 100, di, false);
            s.advance_to(at(t + 110));
            assert_eq!(on(&s, "RO4"), expected, "release does nothing");
        }
        assert_eq!(relays(&s), 0, "only RO4");
    }
}

#[test]
fn stairway_pulse_of_30_s_over_ascii() {
    // L16713–L16750: the ASCII lines configure relay 4 (erratum 1).
    let mut s = sim();
    ok(&mut s, 0, "#SET PULSE4:3\r");
    ok(&mut s, 0, "#SET PULSE TIME4:300\r");
    ok(&mut s, 0, "#SET SPECIAL MODE:1\r");
    assert_eq!(
        ascii(&mut s, 0, "#GPTIME4\r").as_deref(),
        Some("#GPTIME4:300,0x12C\r")
    );
    press(&mut s, 1000, "DI2", true);
    press(&mut s, 1500, "DI2", false);
    s.advance_to(at(1010));
    assert!(on(&s, "RO4"));
    assert_eq!(
        ascii(&mut s, 11_010, "#GET PULSE TIMER4\r").as_deref(),
        Some("#GPTIMER4:200,0xC8\r")
    );
    s.advance_to(at(31_000));
    assert!(on(&s, "RO4"));
    s.advance_to(at(31_010));
    assert!(!on(&s, "RO4"), "off after 30 s");
    assert_eq!(
        ascii(&mut s, 31_010, "#GPTIMER4\r").as_deref(),
        Some("#GPTIMER4:0,0x0\r")
    );
    // Retrigger: pressed again while on, the 30 s start again (L16749).
    press(&mut s, 40_000, "DI1", true);
    press(&mut s, 40_100, "DI1", false);
    press(&mut s, 60_000, "DI2", true);
    s.advance_to(at(89_999));
    assert!(on(&s, "RO4"));
    s.advance_to(at(90_010));
    assert!(!on(&s, "RO4"));
    assert_eq!(relays(&s), 0);
}

#[test]
fn stairway_pulse_of_30_s_over_modbus() {
    // The Modbus lines configure relay 1 (erratum 1), take addresses from the register table
    // (erratum 2): PULSE RO1 4x20033 = 3, PULSE TIME RO1 4x20065 = 0x0000, 4x20066 = 0x012C.
    let mut s = sim();
    echo(&mut s, 0, &[0x01, 0x06, 0x4E, 0x40, 0x00, 0x03]);
    echo(&mut s, 0, &[0x01, 0x06, 0x4E, 0x60, 0x00, 0x00]);
    echo(&mut s, 0, &[0x01, 0x06, 0x4E, 0x61, 0x01, 0x2C]);
    // The same value through the low-word-first view 4x20081/4x20082 (L16740–L16744).
    let low = rtu(&mut s, 0, &[0x01, 0x03, 0x4E, 0x70, 0x00, 0x02]).unwrap();
    assert_eq!(low, with_crc(&[0x01, 0x03, 0x04, 0x01, 0x2C, 0x00, 0x00]));
    echo(&mut s, 0, &[0x01, 0x06, 0x52, 0x08, 0x00, 0x01]);
    press(&mut s, 1000, "DI1", true);
    press(&mut s, 1200, "DI1", false);
    let timer = rtu(&mut s, 11_010, &[0x01, 0x03, 0x4E, 0x80, 0x00, 0x02]).unwrap();
    assert_eq!(
        timer,
        with_crc(&[0x01, 0x03, 0x04, 0x00, 0x00, 0x00, 0xC8]),
        "20.0 s left"
    );
    let timer = rtu(&mut s, 11_010, &[0x01, 0x03, 0x4E, 0x90, 0x00, 0x02]).unwrap();
    assert_eq!(
        timer,
        with_crc(&[0x01, 0x03, 0x04, 0x00, 0xC8, 0x00, 0x00]),
        "low word first"
    );
    s.advance_to(at(31_000));
    assert!(on(&s, "RO1"));
    s.advance_to(at(31_010));
    assert!(!on(&s, "RO1"));
    // Written low word first with FC 16 on 4x20081 (the alternative of L16740).
    let mut t = sim();
    let f = [
        0x01, 0x10, 0x4E, 0x70, 0x00, 0x02, 0x04, 0x01, 0x2C, 0x00, 0x00,
    ];
    assert_eq!(
        rtu(&mut t, 0, &f),
        Some(with_crc(&[0x01, 0x10, 0x4E, 0x70, 0x00, 0x02]))
    );
    assert_eq!(point(&t, "PULSE_TIME_RO1"), Value::I32(300));
}

#[test]
fn retention_across_power_cycles_over_the_wire() {
    let mut s = sim();
    ok(&mut s, 0, "#SET TOGGLE4:3\r");
    ok(&mut s, 0, "#SET PULSE TIME4:300\r");
    ok(&mut s, 0, "#SET SPECIAL MODE:1\r");
    ok(&mut s, 0, "#SROS:0x81\r");
    press(&mut s, 10, "DI1", true);
    s.advance_to(at(20));
    s.command(&["power-cycle"]).unwrap();
    assert_eq!(relays(&s), 0x89, "relays kept");
    assert_eq!(
        ascii(&mut s, 30, "#GTOGGLE4\r").as_deref(),
        Some("#GTOGGLE4:3,0x3\r")
    );
    assert_eq!(
        ascii(&mut s, 30, "#GSMODE\r").as_deref(),
        Some("#GSMODE:1,0x1\r")
    );
    assert_eq!(
        ascii(&mut s, 30, "#GCRO4\r").as_deref(),
        Some("#GCRO4:1,0x1\r")
    );
    assert_eq!(
        ascii(&mut s, 30, "#RDI1\r").as_deref(),
        Some("#RDI1:0,0x0\r")
    );
    // The logic works again after the power cycle.
    press(&mut s, 40, "DI1", false);
    press(&mut s, 50, "DI2", true);
    s.advance_to(at(60));
    assert!(!on(&s, "RO4"));
    // RESET SPECIAL MODE clears the tables permanently.
    ok(&mut s, 70, "#RESET SPECIAL MODE\r");
    s.command(&["power-cycle"]).unwrap();
    assert_eq!(
        ascii(&mut s, 80, "#GSMODE\r").as_deref(),
        Some("#GSMODE:0,0x0\r")
    );
    assert_eq!(
        ascii(&mut s, 80, "#GPTIME4\r").as_deref(),
        Some("#GPTIME4:0,0x0\r")
    );
}

/// An input held on across a power cycle reads on at once (the levels are taken as they are
/// at power-on, so it is no rising edge) and on every sample after, over Modbus too.
#[test]
fn a_terminal_held_on_reads_on_after_a_power_cycle() {
    let mut s = sim();
    press(&mut s, 5, "DI1", true);
    s.advance_to(at(5_000));
    assert!(on(&s, "DI1"));
    s.command(&["power-cycle"]).unwrap();
    assert!(on(&s, "DI1"), "right after power-up");
    for t in [5_010, 5_030, 10_000] {
        let di = rtu(&mut s, t, &[0x01, 0x02, 0x00, 0x00, 0x00, 0x10]).unwrap();
        assert_eq!(di, with_crc(&[0x01, 0x02, 0x02, 0x01, 0x00]), "at {t} ms");
    }
    assert_eq!(
        ascii(&mut s, 10_000, "#RDI1\r").as_deref(),
        Some("#RDI1:0,0x0\r"),
        "no rising edge counted at power-up"
    );
}

#[test]
fn every_16di8ro_command_answers() {
    let mut s = sim();
    let cases = [
        ("#1,VER\r", "#1,VERSION:3.0.0\r"),
        ("#1,TYP\r", "#1,TYPE:RESI-16DI8RO-ASCII\r"),
        ("#1,OWN\r", "#1,OWNER:RESI\r"),
        (
            "#1,COPY\r",
            "#1,COPYRIGHT:2015-16 BY RESI AND DI HC SIGL,MSC WWW.RESI.CC\r",
        ),
        ("#1,GET DIP\r", "#1,GDIP:160,0xA0\r"),
        ("#1,GDIS\r", "#1,GDIS:0,0x0\r"),
        ("#1,GDI16\r", "#1,GDI16:0,0x0\r"),
        ("#1,SET ROS:3\r", "#1,OK\r"),
        ("#1,GET ROS\r", "#1,GROS:3,0x3\r"),
        ("#1,SET RO8:1\r", "#1,OK\r"),
        ("#1,GET RO8\r", "#1,GRO8:1,0x1\r"),
        ("#1,GET CYCLES RO1\r", "#1,GCRO1:1,0x1\r"),
        ("#1,RISE DI3\r", "#1,RDI3:0,0x0\r"),
        ("#1,FALL DI3\r", "#1,FDI3:0,0x0\r"),
        ("#1,RESET COUNTERS\r", "#1,OK\r"),
        ("#1,SSMODE:1\r", "#1,OK\r"),
        ("#1,GET SPECIAL MODE\r", "#1,GSMODE:1,0x1\r"),
        ("#1,SSWITCH2:0x0002\r", "#1,OK\r"),
        ("#1,GSWITCH2\r", "#1,GSWITCH2:2,0x2\r"),
        ("#1,SSON3:4\r", "#1,OK\r"),
        ("#1,GSON3\r", "#1,GSON3:4,0x4\r"),
        ("#1,SSOFF3:8\r", "#1,OK\r"),
        ("#1,GSOFF3\r", "#1,GSOFF3:8,0x8\r"),
        ("#1,STOGGLE5:16\r", "#1,OK\r"),
        ("#1,GTOGGLE5\r", "#1,GTOGGLE5:16,0x10\r"),
        ("#1,SPULSE6:0xFFFF\r", "#1,OK\r"),
        ("#1,GPULSE6\r", "#1,GPULSE6:65535,0xFFFF\r"),
        ("#1,SPTIME6:100000\r", "#1,OK\r"),
        ("#1,GPTIME6\r", "#1,GPTIME6:100000,0x186A0\r"),
        ("#1,GPTIMER6\r", "#1,GPTIMER6:0,0x0\r"),
        ("#1,RSTSPCMODE\r", "#1,OK\r"),
        ("#1,GSWITCH2\r", "#1,GSWITCH2:0,0x0\r"),
        ("#1,GET MODBUS ADDRESS\r", "#1,GMBADR:1,1,0x1,0x1\r"),
        ("#1,SET MODBUS ADDRESS:9\r", "#1,OK\r"),
        ("#9,GMBADR\r", "#9,GMBADR:9,9,0x9,0x9\r"),
    ];
    for (req, answer) in cases {
        assert_eq!(ascii(&mut s, 0, req).as_deref(), Some(answer), "{req:?}");
    }
    assert_eq!(ascii(&mut s, 0, "#9,RESET\r"), None, "RST answers nothing");
}

#[test]
fn exceptions_and_broadcast() {
    let mut s = sim();
    let exception = |fc: u8, code: u8| with_crc(&[0x01, fc | 0x80, code]);
    // FC 22 is not a RESI function.
    assert_eq!(
        rtu(&mut s, 0, &[0x01, 0x16, 0x00, 0x65, 0xFF, 0x00, 0x00, 0x01]),
        Some(exception(0x16, 1))
    );
    // Undocumented address, read-only writes.
    assert_eq!(
        rtu(&mut s, 0, &[0x01, 0x03, 0x00, 0x20, 0x00, 0x01]),
        Some(exception(3, 2))
    );
    assert_eq!(
        rtu(&mut s, 0, &[0x01, 0x03, 0x00, 0x1F, 0x00, 0x02]),
        Some(exception(3, 2))
    );
    assert_eq!(
        rtu(&mut s, 0, &[0x01, 0x06, 0x00, 0x64, 0x00, 0x01]),
        Some(exception(6, 2))
    );
    assert_eq!(
        rtu(&mut s, 0, &[0x01, 0x05, 0x00, 0x00, 0xFF, 0x00]),
        Some(exception(5, 2))
    );
    assert_eq!(
        rtu(&mut s, 0, &[0x01, 0x05, 0x00, 0x10, 0x12, 0x34]),
        Some(exception(5, 3))
    );
    s.module_mut().opts.strict_addresses = false;
    assert_eq!(
        rtu(&mut s, 0, &[0x01, 0x03, 0x00, 0x20, 0x00, 0x01]),
        Some(with_crc(&[0x01, 0x03, 0x02, 0x00, 0x00]))
    );
    // Another unit, a bad CRC: silence. Broadcast: executed, not answered.
    assert_eq!(rtu(&mut s, 0, &[0x02, 0x01, 0x00, 0x10, 0x00, 0x08]), None);
    assert_eq!(
        s.on_frame(&[0x01, 0x01, 0x00, 0x10, 0x00, 0x08, 0, 0], at(0)),
        None
    );
    assert_eq!(rtu(&mut s, 0, &[0x00, 0x05, 0x00, 0x11, 0xFF, 0x00]), None);
    assert!(on(&s, "RO2"));
    // RESET SYSTEM exists on the 16DI8RO only with the option.
    s.module_mut().opts.strict_addresses = true;
    assert_eq!(
        rtu(&mut s, 0, &[0x01, 0x06, 0x17, 0x70, 0x00, 0x01]),
        Some(exception(6, 2))
    );
    s.command(&["option", "system-registers", "on"]).unwrap();
    echo(&mut s, 0, &[0x01, 0x06, 0x17, 0x70, 0x00, 0x01]);
    assert!(on(&s, "RO2"), "a reboot keeps the bistable relays");
}

#[test]
fn modbus_variant_and_reply_delay() {
    let mut s = sim();
    assert_eq!(s.on_frame(b"#VER\r", at(0)).map(|r| r.delay), Some(ms(2)));
    s.command(&["option", "ascii", "off"]).unwrap();
    s.command(&["option", "reply-delay", "7"]).unwrap();
    assert_eq!(ascii(&mut s, 0, "#VER\r"), None);
    let r = s
        .on_frame(&with_crc(&[0x01, 0x01, 0x00, 0x10, 0x00, 0x08]), at(0))
        .unwrap();
    assert_eq!(r.delay, ms(7));
}

#[test]
fn dip_switches_from_standard_input() {
    let mut s = sim();
    s.command(&["address", "5"]).unwrap();
    assert_eq!(s.address(), 5);
    assert_eq!(ascii(&mut s, 0, "#1,VER\r"), None);
    assert_eq!(
        ascii(&mut s, 0, "#5,GDIP\r").as_deref(),
        Some("#5,GDIP:165,0xA5\r")
    );
    s.set("DIP8", Value::Bool(false)).unwrap();
    assert_eq!(point(&s, "DIP"), Value::U16(0x25));
    s.set("DIP", Value::U16(0)).unwrap();
    assert_eq!(s.address(), 1, "ADR = 0: the FLASH address");
    let coils = rtu(&mut s, 0, &[0x01, 0x02, 0x00, 0x18, 0x00, 0x08]).unwrap();
    assert_eq!(coils, with_crc(&[0x01, 0x02, 0x01, 0x00]));
    assert!(s.command_help().contains("power-cycle"));
}

#[test]
fn other_models_over_both_protocols() {
    let mut co = ResiSim::new(&m8co::MODEL, 3);
    assert_eq!(
        ascii(&mut co, 0, "#3,PRO2:20\r").as_deref(),
        Some("#3,OK\r")
    );
    assert_eq!(
        ascii(&mut co, 500, "#3,GPT2\r").as_deref(),
        Some("#3,GPT2:1500,0x5DC\r")
    );
    assert_eq!(
        ascii(&mut co, 500, "#3,GET PPULSE TIMER2\r").as_deref(),
        Some("#3,GPT2:1500,0x5DC\r"),
        "erratum 11 spelling"
    );
    // ROS at 4x00001 and at 4x00101 (erratum 6).
    let ros = rtu(&mut co, 600, &[0x03, 0x03, 0x00, 0x64, 0x00, 0x01]).unwrap();
    assert_eq!(ros, with_crc(&[0x03, 0x03, 0x02, 0x00, 0x02]));
    co.advance_to(at(2000));
    assert!(!on(&co, "RO2"));

    let mut ro = ResiSim::new(&m1ro::MODEL, 4);
    assert_eq!(
        ascii(&mut ro, 0, "#4,SOFFDLY:5000\r").as_deref(),
        Some("#4,OK\r")
    );
    assert_eq!(
        ascii(&mut ro, 0, "#4,GDOS\r").as_deref(),
        Some("#4,GDOS:2,0x2\r")
    );
    let regs = rtu(&mut ro, 1000, &[0x04, 0x03, 0x00, 0x00, 0x00, 0x05]).unwrap();
    assert_eq!(
        regs,
        with_crc(&[0x04, 0x03, 0x0A, 0, 0, 0, 1, 0, 1, 0, 0, 0x0F, 0xA0])
    );
    ro.advance_to(at(5000));
    assert!(!on(&ro, "TDO1"));

    let mut rtd = ResiSim::new(&m2rtd::MODEL, 5);
    rtd.set("CH1_REAL_TEMP", Value::F32(21.5)).unwrap();
    assert_eq!(
        ascii(&mut rtd, 0, "#5,GT1\r").as_deref(),
        Some("#5,GT1:21.5\r")
    );
    assert_eq!(
        ascii(&mut rtd, 0, "#5,GTS\r").as_deref(),
        Some("#5,GTS:21.5,20.0\r")
    );
    let s16 = rtu(&mut rtd, 0, &[0x05, 0x03, 0x00, 0x00, 0x00, 0x01]).unwrap();
    assert_eq!(
        s16,
        with_crc(&[0x05, 0x03, 0x02, 0x00, 0xD7]),
        "215 = 21.5 × 10"
    );
    assert_eq!(
        ascii(&mut rtd, 0, "#5,SOT1:-0.5\r").as_deref(),
        Some("#5,OK\r")
    );
    assert_eq!(
        ascii(&mut rtd, 0, "#5,GOT1\r").as_deref(),
        Some("#5,GOT1:-0.5\r")
    );
    assert_eq!(
        point(&rtd, "CH1_REAL_TEMP"),
        Value::F32(21.5),
        "valid after a reboot"
    );
    assert_eq!(ascii(&mut rtd, 0, "#5,RST\r"), None);
    assert_eq!(point(&rtd, "CH1_REAL_TEMP"), Value::F32(21.0));
}

/// A small deterministic generator, so the robustness tests need no dependency.
struct Lcg(u64);

impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1_442_695_040_888_963_407);
        self.0 >> 33
    }

    fn pick<'a>(&mut self, from: &[&'a str]) -> &'a str {
        from[(self.next() as usize) % from.len()]
    }
}

#[test]
fn no_bytes_or_text_make_it_panic() {
    let models = [
        &m16di8ro::MODEL,
        &m8co::MODEL,
        &m1ro::MODEL,
        &m2rtd::MODEL,
        &crate::devices::resi::models::m4led::MODEL,
    ];
    let words = [
        "#",
        "1",
        ",",
        ":",
        "0x",
        "FFFF",
        "-",
        ".",
        "9",
        "65536",
        "4294967296",
        "SRO",
        "SROS",
        "GDIS",
        "SET ",
        "SWITCH",
        " ON",
        "SPTIME",
        "SALL",
        "SOTS",
        "PRO",
        "SLO",
        "SMODE",
        "SMBADR",
        "RST",
        "RC",
        "RSTSPCMODE",
        "GALL",
        "\r",
        "\n",
        "GT",
        "SSMODE",
        "x",
        "0",
    ];
    let mut rng = Lcg(7);
    for m in models {
        let mut s = ResiSim::new(m, 1);
        for i in 0..3000u64 {
            let t = ms(i * 7);
            let n = (rng.next() % 12) as usize;
            let mut line = String::from("#");
            for _ in 0..n {
                line += rng.pick(&words);
            }
            line.push('\r');
            // Only that none of these panics: what junk gets back is not the point.
            drop(s.on_frame(line.as_bytes(), LineInstant::after_origin(t)));
            let len = (rng.next() % 20) as usize;
            let mut bytes: Vec<u8> = (0..len).map(|_| rng.next() as u8).collect();
            if rng.next() % 2 == 0 && !bytes.is_empty() {
                bytes[0] = 1;
                append_crc(&mut bytes);
            }
            drop(s.on_frame(&bytes, LineInstant::after_origin(t)));
            drop(s.command(&[
                rng.pick(&["dip", "baud", "address", "temp", "option"]),
                rng.pick(&words),
                rng.pick(&words),
            ]));
        }
    }
}

/// The UART runs at the DIP switches' baud and parity: a module installed for a line takes
/// its settings as its switches; a master at another baud, or a known other parity, is not
/// heard; a switch change moves it (resi-spec §1.3).
#[test]
fn the_uart_follows_the_dip_switches() {
    let mut s = sim();
    let line = |baud, parity: &str| LineSettings {
        baud,
        format: format!("8{parity}1").parse().unwrap(),
    };
    assert!(s.set_uart(line(9600, "N")));
    assert_eq!(s.uart(), line(9600, "N"));
    s.master_line(9600, None);
    assert!(ascii(&mut s, 10, "#1,TYP\r").is_some());
    s.master_line(19200, None);
    assert_eq!(ascii(&mut s, 20, "#1,TYP\r"), None, "another baud");
    s.master_line(9600, Some(line(9600, "E").format));
    assert_eq!(ascii(&mut s, 30, "#1,TYP\r"), None, "another parity");
    s.command(&["baud", "38400"]).unwrap();
    s.master_line(38400, None);
    assert!(ascii(&mut s, 40, "#1,TYP\r").is_some());
    // Odd parity and two stop bits are not on the switches: left to the world.
    assert!(!s.set_uart(line(9600, "O")));
    assert!(!s.set_uart(LineSettings {
        baud: 9600,
        format: "8N2".parse().unwrap(),
    }));
}

/// SMBADR + RST: the FLASH address is in use after the reboot and survives a power cycle;
/// the edge counters (RAM) do not.
#[test]
fn smbadr_survives_a_power_cycle() {
    let mut s = sim();
    assert_eq!(
        ascii(&mut s, 10, "#1,SMBADR:9\r").as_deref(),
        Some("#1,OK\r")
    );
    assert_eq!(ascii(&mut s, 20, "#9,RST\r"), None, "RST answers nothing");
    assert_eq!(
        ascii(&mut s, 30, "#9,GMBADR\r").as_deref(),
        Some("#9,GMBADR:9,9,0x9,0x9\r")
    );
    press(&mut s, 40, "DI1", true);
    press(&mut s, 60, "DI1", false);
    assert_eq!(
        ascii(&mut s, 80, "#9,RDI1\r").as_deref(),
        Some("#9,RDI1:1,0x1\r")
    );
    s.command(&["power-cycle"]).unwrap();
    assert_eq!(ascii(&mut s, 90, "#1,TYP\r"), None);
    assert_eq!(
        ascii(&mut s, 100, "#9,RDI1\r").as_deref(),
        Some("#9,RDI1:0,0x0\r")
    );
}
