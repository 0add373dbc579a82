//! Start-up of the MiniMod's own logic: the automatic outputs (Y1AON1..Y4AOFF3), the blinkers
//! (YLAMP1..4) and the pulsers (YPULSE1..4).
//!
//! These registers keep whatever the last master wrote: a run that ended without its clean
//! stop (a crash, `kill -9`, a power loss of the host) leaves its pushed-down tables armed, and
//! they would go on driving the outputs under the next program ("Automatic output management":
//! "the outputs can be turned on and off directly by Minimod when a given pattern presents
//! itself at the inputs"). So every start-up (and every restart after the module was lost)
//! runs, after the other settings and the watchdog reset (a fired watchdog refuses output and
//! pulser writes, "Watchdog"):
//!
//! 1. **disarm**: every logic register is written 0 (those the settings set get their value in
//!    step 3) and read back: holding registers 51..=78 (40052..40079, AON/AOFF conditions and
//!    blinkers) in one FC 16 + FC 3, 83..=86 (40084..40087, pulsers) in another. A condition
//!    with an empty low byte checks nothing and never holds; a blinker mask of 0 gives the
//!    output back to its normal usage ("The blinkers are contained in the Holding Registers 75,
//!    76, 77 and 78; a bitmask different from 0 imposes a flashing"); a pulser at 0 runs no
//!    pulse ("The generator starts with the indicated value when written, and counts down").
//! 2. **initial values** of the pushed-down outputs that keep a state (latches, pulses:
//!    [`super::super::push_down::PushDown::initial`], from the push-down planner): FC 15 on the coil, read
//!    back with FC 1, so the output starts where the central rung would (its tag's initial
//!    value, a latch reset, no pulse).
//! 3. **arm**: the settings' own conditions and blinkers, FC 16 + FC 3 per run.
//!
//! The order is the point of it. An automatic output only acts "when a given pattern presents
//! itself at the inputs": armed on an output that is already on, a latch's tables leave it on
//! (no condition holds while neither start nor stop is pressed), so a motor left running by
//! the crashed run would keep running. The initial value must therefore be written before the
//! tables are armed, and with the old tables disarmed, or a stale condition could switch the
//! output again between the write and the arming. A combinational rung gets no initial write:
//! its conditions cover every input combination, so the module sets the output from its
//! inputs at the first tick after arming, as the central scan does at its first cycle, and an
//! extra write would only switch a load off and on again.
//!
//! Everything here goes through Modbus, also on the text protocol (the manual allows both on
//! one line, "Text commands protocol"): the text protocol writes conditions but cannot read them
//! back.

use std::ops::RangeInclusive;

use super::super::map::{self, Space};
use super::{runs, SetupStep};

/// AON/AOFF conditions and blinkers: Y1AON1 (40052) ..= YLAMP4 (40079), protocol addresses.
const TABLES: RangeInclusive<u16> = 51..=78;
/// Pulsers YPULSE1..4 (40084..40087), protocol addresses.
const PULSERS: RangeInclusive<u16> = 83..=86;
/// Coils Y1..Y4 (00001..00004).
const OUTPUTS: RangeInclusive<u16> = map::COIL_Y1..=map::COIL_Y1 + 3;

/// The logic registers start-up clears (register-table names), for reports.
pub const CLEARED: &str = "Y1AON1..Y4AOFF3, YLAMP1..4, YPULSE1..4";

fn register_name(addr: u16) -> &'static str {
    map::MAP
        .iter()
        .find(|e| e.space == Space::HoldingRegister && e.addr == addr)
        .map_or("register", |e| e.name)
}

/// Takes the logic registers and the output coils out of the start-up writes and returns
/// their own sequence (disarm, initial values, arm; see the module docs), to run after the
/// other settings.
pub(super) fn split(
    registers: &mut Vec<(u16, u16, &'static str)>,
    coils: &mut Vec<(u16, bool, &'static str)>,
) -> Vec<SetupStep> {
    let tables: Vec<_> = registers
        .iter()
        .copied()
        .filter(|r| TABLES.contains(&r.0))
        .collect();
    registers.retain(|r| !TABLES.contains(&r.0) && !PULSERS.contains(&r.0));
    let outputs: Vec<_> = coils
        .iter()
        .copied()
        .filter(|c| OUTPUTS.contains(&c.0))
        .collect();
    coils.retain(|c| !OUTPUTS.contains(&c.0));
    let mut steps = Vec::new();
    for range in [TABLES, PULSERS] {
        steps.push(SetupStep::Registers {
            addr: *range.start(),
            values: range.clone().map(|_| 0).collect(),
            names: range.map(register_name).collect(),
        });
    }
    for (addr, values, names) in runs(outputs) {
        steps.push(SetupStep::Coils {
            addr,
            values,
            names,
        });
    }
    for (addr, values, names) in runs(tables) {
        steps.push(SetupStep::Registers {
            addr,
            values,
            names,
        });
    }
    steps
}

#[cfg(test)]
pub(super) mod tests {
    use std::time::Duration;

    use super::super::super::push_down::{Output, PushDown};
    use super::super::super::settings::Settings;
    use super::super::super::sim::MiniModSim;
    use super::super::{MiniModDriver, Setting};
    use crate::driver::{Driver, Outgoing, Reply, Transaction};
    use crate::modbus::crc::append_crc;
    use crate::modbus::master::{encode_request, Progress, ReplyAssembler};
    use crate::modbus::UnitId;
    use crate::point::Value;
    use crate::sim::SimDevice;
    use crate::time::LineInstant;

    const UNIT: u8 = 5;

    fn frame(bytes: &[u8]) -> Vec<u8> {
        let mut f = bytes.to_vec();
        append_crc(&mut f);
        f
    }

    /// The disarm step's four frames on the wire: FC 16 of 28 zeros at 51 (Y1AON1..YLAMP4),
    /// its FC 3 read-back, FC 16 of 4 zeros at 83 (YPULSE1..4), its FC 3.
    pub(in super::super) fn clear_frames(unit: u8) -> Vec<Vec<u8>> {
        let mut tables = vec![unit, 0x10, 0x00, 51, 0x00, 28, 56];
        tables.extend([0u8; 56]);
        let mut pulsers = vec![unit, 0x10, 0x00, 83, 0x00, 4, 8];
        pulsers.extend([0u8; 8]);
        vec![
            frame(&tables),
            frame(&[unit, 0x03, 0x00, 51, 0x00, 28]),
            frame(&pulsers),
            frame(&[unit, 0x03, 0x00, 83, 0x00, 4]),
        ]
    }

    /// A driver with `settings` and the planner's start values `initial`.
    fn driver(settings: &[(&str, &str)], initial: &[(&str, bool)]) -> MiniModDriver {
        let mut settings: Vec<Setting> = settings
            .iter()
            .map(|(k, v)| Setting::parse(k, v).unwrap())
            .collect();
        let push = PushDown {
            initial: initial
                .iter()
                .map(|(y, on)| (Output::named(y).unwrap(), *on))
                .collect(),
            ..PushDown::default()
        };
        settings.extend(push.settings(&Settings::default()));
        MiniModDriver::new(UnitId::new(UNIT), &settings)
    }

    fn wire(tx: &Transaction) -> Vec<u8> {
        let Outgoing::Modbus { unit, request } = &tx.frame else {
            panic!("logic start-up is Modbus")
        };
        let mut out = Vec::new();
        encode_request(unit.get(), request, &mut out).unwrap();
        out
    }

    /// Runs the start-up against the simulator at `t`, as a bus owner would.
    fn start(d: &mut MiniModDriver, sim: &mut MiniModSim, t: Duration) -> Vec<Vec<u8>> {
        let mut plan = Vec::new();
        d.plan_startup(&mut plan);
        let mut wires = Vec::new();
        for tx in &plan {
            let Outgoing::Modbus { unit, request } = &tx.frame else {
                continue;
            };
            let bytes = wire(tx);
            let reply = sim
                .on_frame(&bytes, LineInstant::after_origin(t))
                .expect("a reply");
            let mut asm = ReplyAssembler::new(unit.get(), request);
            let Progress::Complete { response, .. } = asm.push(&reply.bytes) else {
                panic!("reply not verified: {:?}", reply.bytes)
            };
            d.on_reply(tx.tag, &Reply::Modbus(response)).unwrap();
            wires.push(bytes);
        }
        wires
    }

    /// What a run that pushed `y2 = (x1 | y2) & !x2` down and was killed leaves in the module:
    /// its conditions, a blinker and a pulse of another run, Y2 on.
    fn crashed_module() -> MiniModSim {
        let mut sim = MiniModSim::new(UNIT);
        for (point, value) in [
            ("XLATUP1", 0),
            ("XLATDN1", 0),
            ("XLATUP2", 0),
            ("XLATDN2", 0),
            ("Y2AON1", 0x0001),  // X1
            ("Y2AOFF1", 0x0002), // X2
            ("YLAMP3", 0x00FF),
            ("YPULSE4", 60000),
        ] {
            sim.set(point, Value::U16(value)).unwrap();
        }
        sim.set("Y2", Value::Bool(true)).unwrap();
        sim.advance_to(LineInstant::after_origin(Duration::from_millis(5)));
        sim
    }

    #[test]
    fn stale_tables_are_cleared_and_read_back_when_nothing_is_pushed() {
        let mut sim = crashed_module();
        let mut d = driver(&[], &[]);
        let wires = start(&mut d, &mut sim, Duration::from_millis(10));
        assert_eq!(wires, clear_frames(UNIT), "the clear, nothing else");
        for point in ["Y2AON1", "Y2AOFF1", "YLAMP3", "YPULSE4"] {
            assert_eq!(sim.get(point), Ok(Value::U16(0)), "{point} cleared");
        }
        // X1 no longer switches Y2: holding it leaves Y2 as the program will write it.
        sim.set("Y2", Value::Bool(false)).unwrap();
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.advance_to(LineInstant::after_origin(Duration::from_millis(50)));
        assert_eq!(sim.get("Y2"), Ok(Value::Bool(false)));
        assert_eq!(
            sim.state().outputs() & 0b1100,
            0,
            "no blinker, no pulse left"
        );
    }

    #[test]
    fn a_pushed_latch_starts_reset_then_its_tables_are_armed() {
        let mut sim = crashed_module();
        let mut d = driver(
            &[("Y2AON1", "0x0001"), ("Y2AOFF1", "0x0002")],
            &[("Y2", false)],
        );
        let wires = start(&mut d, &mut sim, Duration::from_millis(10));
        let mut want = clear_frames(UNIT);
        // Y2 = 0 (FC 15 at coil 1) and its read-back, then the conditions.
        want.push(frame(&[UNIT, 0x0F, 0x00, 0x01, 0x00, 0x01, 0x01, 0x00]));
        want.push(frame(&[UNIT, 0x01, 0x00, 0x01, 0x00, 0x01]));
        assert_eq!(wires[..6], want[..], "disarm, then the initial value");
        assert_eq!(wires.len(), 10, "then Y2AON1 and Y2AOFF1, each read back");
        sim.advance_to(LineInstant::after_origin(Duration::from_millis(20)));
        assert_eq!(
            sim.get("Y2"),
            Ok(Value::Bool(false)),
            "the latch left on by the crashed run starts reset, as the central rung does"
        );
        assert_eq!(sim.get("Y2AON1"), Ok(Value::U16(1)));
        // Armed: a start press sets it within a tick.
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.advance_to(LineInstant::after_origin(Duration::from_millis(22)));
        assert_eq!(sim.get("Y2"), Ok(Value::Bool(true)));
    }
}
