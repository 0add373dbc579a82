//! Scenario 15: a 400 ms on / 400 ms off warning lamp (LAMP, mask 0x0F0F) from a program
//! scanning every 80 ms, central against pushed down into the MiniMod's blinker (YLAMP1),
//! measured on the virtual line in real time.
//!
//! - Central (`offload: never`): the scan plays the mask on 100 ms steps counted from the
//!   PLC's start and writes Y1 at each toggle; its edges come at its write phases.
//! - Pushed down (`offload: auto`): the scan writes YLAMP1 = 0x0F0F once (the enable is
//!   constant) and the module's own steps toggle Y1.
//!
//! Y1 is sampled at the module's terminal every millisecond; each edge is compared with its
//! ideal grid (every 400 ms: from the PLC's start for the central lamp, from the simulated
//! module's power-on, which is the same instant, for the module's). The module's write
//! requests (FC 5, 6, 15, 16) are counted at the simulator: the lamp's, and the periodic
//! rewrite of the outputs, which both builds have.

use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use softplc::project::{ProgramConfig, ProgramKind};
use softplc::scan::DurationHistogram;
use softplc_io::devices::minimod::MiniModSim;
use softplc_io::devices::{ModelSpec, Protocol};
use softplc_io::line::{LineSettings, SerialFormat};
use softplc_io::point::{PointSpec, Value};
use softplc_io::sim::{SimDevice, SimError, SimReply};
use softplc_io::time::LineInstant;

use super::{Ctx, Scenario};
use crate::project_file::{self, SimBus};
use crate::report::{Bound, Outcome, Row};
use crate::sim_scan::Scanning;
use crate::terminal::SAMPLE;

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 15,
    name: "blink",
    title: "A 400/400 ms warning lamp from a program scanning every 80 ms: bus writes and edges",
    summary: "LAMP mask 0x0F0F on Y1 of a simulated MiniMod, 57600 8E1, polled; Y1 sampled at \
              the terminal every 1 ms; edge error = edge − its ideal 400 ms grid; write \
              requests counted at the simulator.",
    run,
};

const PERIOD: Duration = Duration::from_millis(80);
/// The lamp's half period (0x0F0F: four 100 ms steps on, four off).
const HALF: Duration = Duration::from_millis(400);

/// Write requests the simulated module has been sent: to YLAMP1..4, and to its outputs.
static LAMP_WRITES: AtomicU64 = AtomicU64::new(0);
static OUTPUT_WRITES: AtomicU64 = AtomicU64::new(0);

/// What one build gave.
struct Measured {
    /// Edge − ideal grid.
    errors: DurationHistogram,
    /// Write requests a minute, to the blinker register and to the outputs.
    lamp_per_minute: f64,
    output_per_minute: f64,
}

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let mut out = Outcome::default();
    for (offload, case, note) in [
        (
            "never",
            "central: LAMP in the scan, 80 ms",
            "the scan writes Y1 at each toggle, at its write phase",
        ),
        (
            "auto",
            "pushed down: YLAMP1 = 0x0F0F",
            "the planner's push-down (offload: auto): the mask written once, the module's \
             steps toggle Y1",
        ),
    ] {
        let m = measure(ctx, offload)?;
        let total = m.lamp_per_minute + m.output_per_minute;
        let p = m.errors.percentiles();
        out.rows.push(
            Row::measured(case, "edge error vs the ideal grid", p)
                .bound(Bound::fixed("scan period", PERIOD))
                .value("writes_per_minute", total)
                .value("lamp_writes_per_minute", m.lamp_per_minute)
                .value("output_writes_per_minute", m.output_per_minute)
                .note(format!(
                    "{total:.0} bus writes a minute ({:.0} to YLAMP1, {:.0} to the outputs: \
                     the periodic rewrite once a second in both); {note}",
                    m.lamp_per_minute, m.output_per_minute
                )),
        );
    }
    Ok(out)
}

/// The lamp, central (`offload: never`) or pushed down (`auto`).
fn measure(ctx: &Ctx, offload: &str) -> anyhow::Result<Measured> {
    let run_for = ctx.pick(Duration::from_secs(40), Duration::from_secs(5));
    let bus = SimBus {
        settings: "{ events: false }".into(),
        ..SimBus::new("line1", 57600, [1])
    };
    let tags = [
        "{ name: en, type: bool, initial: true }".to_string(),
        "{ name: lamp, point: line1_m1.Y1, safe: false }".to_string(),
    ];
    let name = format!("blink_{offload}");
    let mut project =
        project_file::load_offload(&ctx.scratch, &name, "80ms", &[bus], &tags, "", offload)?;
    // LAMP is a ladder and Rhai block.
    let ladder = ctx.scratch.join(format!("{name}.ladder.yaml"));
    std::fs::write(&ladder, "rungs:\n  - en -> LAMP warn(3855) -> lamp\n")?;
    let program = ProgramConfig {
        path: ladder,
        kind: ProgramKind::Ladder,
    };
    project.set_programs(0, vec![program]);
    for m in &mut project.modules {
        let spec = m.model;
        m.model = Box::leak(Box::new(ModelSpec {
            simulator: counted_minimod,
            addresses: spec.addresses.clone(),
            ..*spec
        }));
    }
    let scan = Scanning::start(project, format!("scan-{name}"), run_for)?;
    let clock = scan.clock.clone();
    // From the second second on: the start-up's writes are not the lamp's.
    let from = scan.begin + Duration::from_secs(1);
    let until = scan.begin + run_for.saturating_sub(PERIOD * 3);
    let mut errors = DurationHistogram::new();
    let mut last = None;
    let mut next = clock.now();
    let mut counted_from = None;
    while next < until {
        clock.sleep_until(next);
        let now = clock.now();
        if now >= from && counted_from.is_none() {
            counted_from = Some((
                now,
                LAMP_WRITES.load(Ordering::Relaxed),
                OUTPUT_WRITES.load(Ordering::Relaxed),
            ));
        }
        let on = {
            let mut w = scan.world.lock().unwrap_or_else(|e| e.into_inner());
            w.advance_to(now.on_line_clock());
            matches!(w.get(scan.device, "Y1"), Ok(Value::Bool(true)))
        };
        if last.is_some_and(|l| l != on) && now >= from {
            // The grid: multiples of 400 ms on the PLC's clock, which the world shares.
            let since = now.since_origin();
            let ideal = Duration::from_nanos(
                u64::try_from(since.as_nanos() / HALF.as_nanos() * HALF.as_nanos())
                    .unwrap_or(u64::MAX),
            );
            errors.record(since - ideal);
        }
        last = Some(on);
        next += SAMPLE;
    }
    let end = clock.now();
    let (start, lamp0, out0) = counted_from.unwrap_or((end, 0, 0));
    let minutes = (end - start).as_secs_f64() / 60.0;
    let lamp = LAMP_WRITES.load(Ordering::Relaxed) - lamp0;
    let output = OUTPUT_WRITES.load(Ordering::Relaxed) - out0;
    scan.join()?;
    Ok(Measured {
        errors,
        lamp_per_minute: lamp as f64 / minutes.max(f64::MIN_POSITIVE),
        output_per_minute: output as f64 / minutes.max(f64::MIN_POSITIVE),
    })
}

/// A MiniMod simulator that counts the write requests it is sent.
fn counted_minimod(address: u8) -> Box<dyn SimDevice> {
    Box::new(Counted(Box::new(MiniModSim::new(address))))
}

/// Holding registers YLAMP1..4 (40076..40079), protocol addresses.
const YLAMP: std::ops::RangeInclusive<u16> = 75..=78;

#[derive(Debug)]
struct Counted(Box<dyn SimDevice>);

impl SimDevice for Counted {
    fn model(&self) -> &'static str {
        self.0.model()
    }
    fn address(&self) -> u8 {
        self.0.address()
    }
    fn advance_to(&mut self, t: LineInstant) {
        self.0.advance_to(t);
    }
    fn on_frame(&mut self, frame: &[u8], t: LineInstant) -> Option<SimReply> {
        if frame.first() == Some(&self.0.address()) {
            let register = frame
                .get(2..4)
                .map(|b| u16::from_be_bytes([b[0], b[1]]))
                .unwrap_or(0);
            match frame.get(1) {
                Some(6) if YLAMP.contains(&register) => {
                    LAMP_WRITES.fetch_add(1, Ordering::Relaxed);
                }
                Some(5 | 6 | 15 | 16) => {
                    OUTPUT_WRITES.fetch_add(1, Ordering::Relaxed);
                }
                _ => {}
            }
        }
        self.0.on_frame(frame, t)
    }
    fn points(&self) -> &'static [PointSpec] {
        self.0.points()
    }
    fn get(&self, point: &str) -> Result<Value, SimError> {
        self.0.get(point)
    }
    fn set(&mut self, point: &str, value: Value) -> Result<(), SimError> {
        self.0.set(point, value)
    }
    fn command(&mut self, words: &[&str]) -> Result<String, SimError> {
        self.0.command(words)
    }
    fn frame_silence(&self, settings: LineSettings) -> Option<Duration> {
        self.0.frame_silence(settings)
    }
    fn yields_to_earlier_reply(&self, frame: &[u8]) -> bool {
        self.0.yields_to_earlier_reply(frame)
    }
    fn set_protocol(&mut self, protocol: Protocol) -> Result<(), SimError> {
        self.0.set_protocol(protocol)
    }
    fn master_line(&mut self, baud: u32, format: Option<SerialFormat>) {
        self.0.master_line(baud, format);
    }
    fn set_uart(&mut self, settings: LineSettings) -> bool {
        self.0.set_uart(settings)
    }
    fn command_help(&self) -> &'static str {
        self.0.command_help()
    }
}
