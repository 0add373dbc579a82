//! The module's own UART on a served line: it listens at the baud of its last power-on
//! (§1.4: EEPROM, or 9600 Bd in INIT*), so a baud set by `%AANNTTCCFF` in INIT* is heard only
//! after the next power-on, and the old baud no longer is.

use std::time::Duration;

use crate::devices::ex9053::{Ex9053Sim, Variant};
use crate::line::settings::{LineSettings, SerialFormat};
use crate::sim::SimDevice;
use crate::time::LineInstant;

fn ask(sim: &mut Ex9053Sim, master_baud: u32, line: &str, ms: u64) -> Option<String> {
    sim.master_line(master_baud, None);
    let mut frame = line.as_bytes().to_vec();
    frame.push(b'\r');
    sim.on_frame(&frame, LineInstant::after_origin(Duration::from_millis(ms)))
        .map(|r| String::from_utf8_lossy(&r.bytes).trim_end().to_string())
}

#[test]
fn a_new_baud_is_heard_after_the_power_on_that_takes_it_and_the_old_one_is_not() {
    let mut sim = Ex9053Sim::new(Variant::D, 2);
    assert!(sim.set_uart(LineSettings {
        baud: 19200,
        format: "8N1".parse::<SerialFormat>().unwrap(),
    }));
    assert_eq!(ask(&mut sim, 19200, "$02M", 10).as_deref(), Some("!029053"));
    assert_eq!(
        ask(&mut sim, 9600, "$02M", 20),
        None,
        "deaf at another baud"
    );
    // Outside INIT* the module refuses the new baud, as it would (§2.1).
    assert_eq!(
        ask(&mut sim, 19200, "%0202400800", 30).as_deref(),
        Some("?02")
    );
    sim.command(&["init", "on"]).unwrap();
    sim.command(&["power-cycle"]).unwrap();
    assert_eq!(
        ask(&mut sim, 19200, "$002", 40),
        None,
        "INIT* listens at 9600"
    );
    assert_eq!(
        ask(&mut sim, 9600, "$002", 50).as_deref(),
        Some("!02400700")
    );
    assert_eq!(
        ask(&mut sim, 9600, "%0003400800", 60).as_deref(),
        Some("!03")
    );
    // Stored, not yet in force: still INIT*'s 9600.
    assert_eq!(ask(&mut sim, 38400, "$03M", 70), None);
    sim.command(&["init", "off"]).unwrap();
    sim.command(&["power-cycle"]).unwrap();
    assert_eq!(
        ask(&mut sim, 19200, "$03M", 80),
        None,
        "the old baud is gone"
    );
    assert_eq!(ask(&mut sim, 38400, "$03M", 90).as_deref(), Some("!039053"));
    // A known other format is not heard either: a DCON line is 8N1.
    sim.master_line(38400, Some(SerialFormat::EVEN_8E1));
    assert_eq!(
        sim.on_frame(
            b"$03M\r",
            LineInstant::after_origin(Duration::from_millis(100))
        ),
        None
    );
}
