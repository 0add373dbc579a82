//! Every DCON example of the manual (chapter 2), string-exact, against the simulator, with
//! and without checksum; INIT* mode; what the module does with damaged or foreign lines.

use std::time::Duration;

use crate::devices::ex9053::dcon::{check_line, encode_line};
use crate::devices::ex9053::{Ex9053Sim, Variant};
use crate::sim::SimDevice;
use crate::time::LineInstant;

/// A terminal on one simulated module.
struct Term {
    sim: Ex9053Sim,
    t: Duration,
    checksum: bool,
}

impl Term {
    /// A module just powered on at `address`, checksum as asked. A checksum module is made as
    /// the manual says (§1.4, §2.1): INIT* on, `%00AA4006 40`, INIT* off, power-cycle.
    fn new(variant: Variant, address: u8, checksum: bool) -> Self {
        let mut term = Self {
            sim: Ex9053Sim::new(variant, address),
            t: Duration::ZERO,
            checksum: false,
        };
        if variant == Variant::M {
            term.cmd(&["protocol", "dcon"]);
        }
        if checksum {
            term.cmd(&["init", "on"]);
            term.cmd(&["power-cycle"]);
            let set = format!("%00{address:02X}400640");
            term.expect(&set, &format!("!{address:02X}"));
            term.cmd(&["init", "off"]);
        }
        term.cmd(&["power-cycle"]);
        term.checksum = checksum;
        term
    }

    fn cmd(&mut self, words: &[&str]) -> String {
        self.sim.command(words).unwrap()
    }

    fn at_ms(&mut self, ms: u64) {
        self.t = Duration::from_millis(ms);
    }

    /// Sends `body` (with the checksum when enabled) and returns the raw answer.
    fn raw(&mut self, body: &str) -> Option<Vec<u8>> {
        self.sim
            .on_frame(
                &encode_line(body, self.checksum),
                LineInstant::after_origin(self.t),
            )
            .map(|r| r.bytes)
    }

    /// Sends `body`, checks the answer's framing and returns its body.
    fn ask(&mut self, body: &str) -> Option<String> {
        let raw = self.raw(body)?;
        let line = raw.strip_suffix(b"\r").expect("answers end with CR");
        let body = check_line(line, self.checksum).expect("answer checksum");
        Some(String::from_utf8(body.to_vec()).unwrap())
    }

    /// `command` gets exactly `answer` (byte-exact, checksum included when enabled).
    fn expect(&mut self, command: &str, answer: &str) {
        let raw = self.raw(command);
        assert_eq!(
            raw.as_deref().map(String::from_utf8_lossy),
            Some(String::from_utf8_lossy(&encode_line(answer, self.checksum))),
            "{command}"
        );
    }

    fn silent(&mut self, command: &str) {
        assert_eq!(self.ask(command), None, "{command} gets no answer");
    }

    fn set_inputs(&mut self, hex: &str) {
        self.cmd(&["inputs", hex]);
    }

    fn pulses(&mut self, di: &str, n: u32) {
        for _ in 0..n {
            self.cmd(&["pulse", di]);
        }
    }
}

/// §2.x examples in order. FF reads 40 instead of 00 when the checksum is on: that is the
/// module's checksum bit.
fn every_example(checksum: bool) {
    let ff = if checksum { "40" } else { "00" };
    let d = Variant::D;

    // §2.1 %AANNTTCCFF: "%0102240600" → "!02", then the module is at 02.
    let mut m = Term::new(d, 0x01, checksum);
    m.expect(&format!("%01022406{ff}"), "!02");
    m.expect("$022", &format!("!024006{ff}"));
    m.silent("$012");

    // §2.2 #** and §2.5 $AA4: first read S=1, then S=0, data 0F00.
    let mut m = Term::new(d, 0x01, checksum);
    m.set_inputs("0F00");
    m.silent("#**");
    m.set_inputs("0000");
    m.expect("$014", "!10F0000");
    m.expect("$014", "!00F0000");

    // §2.3 #AAN: channel 2 of module 03 counted 103.
    let mut m = Term::new(d, 0x03, checksum);
    m.pulses("DI2", 103);
    m.expect("#032", "!0300103");
    // The manual's "#025 → ?02" is from a module with fewer channels: the EX-9053D has 16
    // counters, so an invalid channel is one that is not a hexadecimal digit.
    let mut m = Term::new(d, 0x02, checksum);
    m.expect("#02G", "?02");
    m.expect("#025", "!0200000");

    // §2.4 $AA2.
    let mut m = Term::new(d, 0x01, checksum);
    m.expect("$012", &format!("!014006{ff}"));

    // §2.6 $AA5: set at power-on, cleared by the read.
    m.expect("$015", "!011");
    m.expect("$015", "!010");

    // §2.7 $AA6 and §2.13 @AA: DI0..DI3 on.
    m.set_inputs("000F");
    m.expect("$016", "!000F00");
    m.expect("@01", ">000F");

    // §2.8 $AAF, §2.9 $AAM.
    m.expect("$01F", "!01D04.03");
    m.expect("$01M", "!019053");

    // §2.10 $AAC with latch low: all inputs were low (power-on), now all high.
    let mut m = Term::new(d, 0x01, checksum);
    m.set_inputs("FFFF");
    m.expect("$01L0", "!FFFF00");
    m.expect("$01C", "!01");
    m.expect("$01L0", "!000000");

    // §2.11 $AACN: channel 0 counted 123, cleared.
    let mut m = Term::new(d, 0x01, checksum);
    m.pulses("DI0", 123);
    m.expect("#010", "!0100123");
    m.expect("$01C0", "!01");
    m.expect("#010", "!0100000");

    // §2.12 $AALS with latch high: DI0, DI1, DI5, DI8 pulsed high.
    let mut m = Term::new(d, 0x01, checksum);
    m.set_inputs("0123");
    m.set_inputs("0000");
    m.expect("$01L1", "!012300");
    m.expect("$01C", "!01");
    m.expect("$01L1", "!000000");

    // §2.14 ~AAO(Data).
    let mut m = Term::new(d, 0x01, checksum);
    m.expect("~01OMIXER", "!01");
    m.expect("$01M", "!01MIXER");
    m.expect("~01O9053", "!01");
    m.expect("$01M", "!019053");

    // §2.17 ~**, §2.18..§2.21: the host watchdog example, 10.0 s.
    let mut m = Term::new(d, 0x01, checksum);
    m.expect("~010", "!0100");
    m.expect("~013164", "!01");
    m.expect("~012", "!01164");
    m.expect("~010", "!0180");
    m.at_ms(1_000);
    m.silent("~**");
    m.at_ms(10_999);
    m.expect("~010", "!0180");
    m.at_ms(11_000);
    m.expect("~010", "!0104");
    m.expect("~012", "!01064");
    m.expect("~011", "!01");
    m.expect("~010", "!0100");

    // §2.15, §2.16 $AAP / $AAPN on the -M running DCON.
    let mut m = Term::new(Variant::M, 0x01, checksum);
    m.expect("$01P", "!0110");
    m.expect("$01P1", "?01");
    m.cmd(&["init", "on"]);
    m.cmd(&["power-cycle"]);
    m.checksum = false;
    m.expect("$01P1", "!01");
    m.expect("$01P", "!0111");
    // and on the EX-9053D, which has no Modbus:
    let mut m = Term::new(d, 0x01, checksum);
    m.expect("$01P", "?01");
    m.expect("$01P1", "?01");
}

#[test]
fn every_example_of_the_manual_without_checksum() {
    every_example(false);
}

#[test]
fn every_example_of_the_manual_with_checksum() {
    every_example(true);
}

#[test]
fn checksum_byte_exact() {
    let mut m = Term::new(Variant::D, 0x01, true);
    // "$012" sums to B7; "!01400640" to B0.
    assert_eq!(
        m.sim
            .on_frame(b"$012B7\r", LineInstant::ZERO)
            .map(|r| r.bytes),
        Some(b"!01400640B0\r".to_vec())
    );
    // Lower-case checksum digits are read.
    assert!(m.sim.on_frame(b"$012b7\r", LineInstant::ZERO).is_some());
    // A wrong or missing checksum: silence.
    assert_eq!(m.sim.on_frame(b"$012B8\r", LineInstant::ZERO), None);
    assert_eq!(m.sim.on_frame(b"$012\r", LineInstant::ZERO), None);
    // Broadcasts need it too: "#**" sums to 0x77.
    m.set_inputs("1234");
    assert_eq!(m.sim.on_frame(b"#**\r", LineInstant::ZERO), None);
    assert_eq!(
        m.ask("$014").as_deref(),
        Some("!0000000"),
        "no sample taken"
    );
    assert_eq!(m.sim.on_frame(b"#**77\r", LineInstant::ZERO), None);
    assert_eq!(m.ask("$014").as_deref(), Some("!1123400"));
    // Without the checksum enabled, appended characters make an invalid command.
    let mut plain = Term::new(Variant::D, 0x01, false);
    assert_eq!(
        plain
            .sim
            .on_frame(b"$012B7\r", LineInstant::ZERO)
            .map(|r| r.bytes),
        Some(b"?01\r".to_vec())
    );
}

#[test]
fn init_mode_answers_at_00_and_changes_baud_and_checksum_for_the_next_power_on() {
    let mut m = Term::new(Variant::D, 0x05, false);
    // Outside INIT*: baud or checksum changes are refused, the address change is not.
    m.expect("%0505400700", "?05");
    m.expect("%0505400640", "?05");
    m.expect("%0505400A00", "?05");
    m.cmd(&["init", "on"]);
    m.expect("$052", "!05400600");
    m.cmd(&["power-cycle"]);
    // INIT*: address 00, 9600 Bd, no checksum; $002 shows the stored configuration.
    assert_eq!(m.sim.address(), 0);
    m.expect("$002", "!05400600");
    m.expect("%0005400A40", "!05");
    m.expect("$002", "!05400A40");
    m.expect("$006", "!000000");
    let running = m.sim.state().running();
    assert_eq!((running.baud_code, running.checksum), (0x06, false));
    m.cmd(&["init", "off"]);
    m.cmd(&["power-cycle"]);
    let running = m.sim.state().running();
    assert_eq!(
        (running.address, running.baud_code, running.checksum),
        (0x05, 0x0A, true)
    );
    m.checksum = true;
    m.expect("$052", "!05400A40");
    m.silent("$002");
    // A bad baud code is refused even in INIT*.
    m.cmd(&["init", "on"]);
    m.cmd(&["power-cycle"]);
    m.checksum = false;
    m.expect("%0005400B00", "?00");
}

#[test]
fn settings_survive_a_power_cycle_and_ram_does_not() {
    let mut m = Term::new(Variant::D, 0x01, false);
    m.expect("~01OPUMP", "!01");
    m.expect("~0131FF", "!01");
    m.expect("%0101400680", "!01");
    m.pulses("DI1", 2);
    m.set_inputs("0002");
    m.silent("#**");
    m.cmd(&["power-cycle"]);
    m.expect("$01M", "!01PUMP");
    m.expect("~012", "!011FF");
    m.expect("$012", "!01400680");
    m.expect("#011", "!0100000");
    m.expect("$014", "!0000000");
    m.expect("$01L1", "!000200");
    m.expect("$015", "!011");
}

#[test]
fn counters_follow_the_edge_of_ff_bit_7() {
    let mut m = Term::new(Variant::D, 0x01, false);
    m.set_inputs("0010");
    m.expect("#014", "!0100000");
    m.cmd(&["pulse", "DI4", "low"]);
    m.expect("#014", "!0100001");
    m.expect("%0101400680", "!01");
    m.cmd(&["pulse", "DI4", "low"]);
    m.expect("#014", "!0100002");
    m.set_inputs("0000");
    m.cmd(&["pulse", "DI4"]);
    m.expect("#014", "!0100003");
    m.expect("#01F", "!0100000");
}

#[test]
fn foreign_and_damaged_lines_are_ignored() {
    let mut m = Term::new(Variant::D, 0x01, false);
    m.silent("$022");
    m.silent("hello");
    m.expect("$01X", "?01");
    m.expect("~01O1234567", "?01");
    m.expect("~013000", "!01");
    m.expect("~013100", "?01");
    let t = Duration::ZERO;
    assert_eq!(
        m.sim.on_frame(b"$012", LineInstant::after_origin(t)),
        None,
        "no terminator yet"
    );
    assert_eq!(
        m.sim
            .on_frame(b"\n$012\r\n", LineInstant::after_origin(t))
            .map(|r| r.bytes),
        Some(b"!01400600\r".to_vec()),
        "a terminal's LF around the line"
    );
    assert_eq!(
        m.sim
            .on_frame(b"$012\n", LineInstant::after_origin(t))
            .map(|r| r.bytes),
        Some(b"!01400600\r".to_vec()),
        "LF alone ends a line"
    );
    // A Modbus frame to unit 1 is not a DCON line.
    assert_eq!(
        m.sim.on_frame(
            &[0x01, 0x02, 0x00, 0x00, 0x00, 0x10, 0x79, 0xC6],
            LineInstant::after_origin(t)
        ),
        None
    );
    // No byte sequence panics.
    let mut x: u32 = 0x1234_5678;
    for len in 0..200usize {
        let frame: Vec<u8> = (0..len % 24)
            .map(|_| {
                x ^= x << 13;
                x ^= x >> 17;
                x ^= x << 5;
                let alphabet = b"$#%@~0123456789ABCFLMOP*\x00\xff";
                if x % 5 == 0 {
                    b'\r'
                } else {
                    alphabet[x as usize % alphabet.len()]
                }
            })
            .collect();
        // Only that it never panics: what junk gets back is not the point.
        drop(m.sim.on_frame(&frame, LineInstant::after_origin(t)));
    }
}

#[test]
fn sim_points_and_commands() {
    let mut m = Term::new(Variant::D, 0x01, false);
    let sim = &mut m.sim;
    use crate::point::Value;
    sim.set("DI9", Value::Bool(true)).unwrap();
    assert_eq!(sim.get("DI9"), Ok(Value::Bool(true)));
    assert_eq!(sim.get("DI9_LATCH_HIGH"), Ok(Value::Bool(true)));
    sim.set("DI9", Value::U16(0)).unwrap();
    assert_eq!(sim.get("DI9_COUNTER"), Ok(Value::I32(1)));
    assert!(sim.set("DI9_COUNTER", Value::I32(0)).is_err());
    assert!(sim.set("DI9", Value::U16(2)).is_err());
    assert!(sim.get("X1").is_err());
    assert!(sim.command(&["pulse", "DI16"]).is_err());
    assert!(sim.command(&["inputs", "XYZ"]).is_err());
    assert!(sim.command(&["init", "maybe"]).is_err());
    assert!(sim.command(&["protocol", "modbus"]).is_err(), "EX-9053D");
    assert!(sim.command(&["dance"]).is_err());
    assert!(sim
        .command(&["status"])
        .unwrap()
        .contains("running: address=01h"));
    assert!(sim.command_help().contains("init on|off"));
    assert_eq!(sim.model(), "ex9053d");
    for p in sim.points() {
        assert!(sim.get(p.name).is_ok(), "{}", p.name);
    }
}

#[test]
fn a_long_idle_advance_is_fast() {
    let mut m = Term::new(Variant::D, 0x01, false);
    m.expect("~0131FF", "!01");
    let start = std::time::Instant::now();
    m.sim
        .advance_to(LineInstant::after_origin(Duration::from_secs(
            365 * 24 * 3600,
        )));
    assert!(start.elapsed() < Duration::from_millis(50));
    assert!(m.sim.state().watchdog_timeout());
}
