//! A plan at run time: the pushed-down outputs belong to their modules.
//!
//! - **Ownership.** The scan never writes a pushed-down output (its slot in the output frame
//!   stays `None`, so the driver leaves it to the module's logic); the engine was told to stop
//!   writing the coil ([`crate::logic::LogicEngine::release`]), and whatever it may still
//!   write is overwritten with the module's value after the logic.
//! - **Read-back.** Each cycle the output's value as the module reports it (the MiniMod's coils
//!   read back with FC 1, the RESI relays in the poll list) goes into the image, with the
//!   read's quality, so programs, `status` and SCADA see the true state.
//! - **Pulses.** A TP rung on a MiniMod keeps its trigger central: after the logic the trigger
//!   is evaluated on the image; on its edge, when no pulse runs, the scan writes the pulser
//!   register (`YPULSEn`) for one cycle. The image shows the pulse as the module runs it (on
//!   from the cycle that wrote it for its exact width): the pulser does not show in the coils
//!   the driver can read back.
//! - **Blinkers.** A LAMP rung (or a BLINK with `blink_phase: free`) on a MiniMod keeps its
//!   enable central: after the logic the enable is evaluated on the image, and the output
//!   phase asks for the blinker register (`YLAMPn`) to hold the mask while it holds and 0
//!   otherwise; the driver writes it when it changes (one write per change of the enable,
//!   none per toggle) and again after the module's restart. The image shows the enable: the
//!   module's status does not show a blinking output. A force is the scan's to carry out: the
//!   mask is 0 while the output is forced and the forced value is written to the output; at
//!   the unforce the output is written off and the mask again if enabled.
//! - **Start.** The drivers clear every logic register at start-up and write a stateful
//!   output's start value before its tables ([`super::planner::ModulePlacement::initial`]),
//!   so the image's start value (`Pushed::value`, the tag's initial value) is the module's.
//! - **Stop.** With `on_stop: clear` the safe state writes zero to every table register the
//!   plan wrote and the output's safe value; with `keep` the module keeps running its tables
//!   and the output is left to it.

use std::time::Duration;

use softplc_io::devices::minimod::PulseWidth;
use softplc_io::line::{InputFrame, OutputFrame};
use softplc_io::point::{Quality, Value};

use super::planner::{Command, Placement, Plan, RequireFailure};
use crate::image::{ProcessImage, TagId};
use crate::project::{Binding, OnStop, Project};
use softplc_io::rung::BoolExpr;
use softplc_io::time::ScanInstant;

/// How the image learns a pushed-down output's value.
#[derive(Debug, Clone)]
enum Source {
    /// From the module's read-back of the output.
    ReadBack,
    /// A pulser the scan triggers.
    Pulse {
        /// The pulser register's point.
        command: usize,
        /// The trigger conditions.
        trigger: Vec<BoolExpr>,
        /// Last scan's value of each (`None` before the first scan).
        prev: Vec<Option<bool>>,
        /// The pulse's length.
        width: Duration,
        /// Its register value.
        width_ms: PulseWidth,
        /// When the running pulse was commanded (scan time).
        started: Option<ScanInstant>,
        /// Write the pulser in this cycle's output phase.
        fire: bool,
    },
    /// A blinker the scan enables: its mask while the enable holds, 0 otherwise.
    Lamp {
        /// The blinker register's point (`YLAMPn`).
        command: usize,
        /// The enable condition.
        enable: BoolExpr,
        /// The register value while enabled.
        mask: u16,
    },
}

/// One pushed-down output.
#[derive(Debug, Clone)]
struct Pushed {
    tag: TagId,
    bus: usize,
    /// Index on its bus.
    module: usize,
    point: usize,
    safe: Value,
    /// Table registers (point index, zero of its type) zeroed at stop.
    tables: Vec<(usize, Value)>,
    /// The module's value as last known (restored after the logic).
    value: Value,
    /// The quality of the last read-back of the output (read-back outputs only; a pulser is
    /// never read).
    read: Quality,
    source: Source,
}

impl Pushed {
    /// The register the scan writes instead of the output (a pulser, a blinker), if any.
    fn command(&self) -> Option<usize> {
        match self.source {
            Source::ReadBack => None,
            Source::Pulse { command, .. } | Source::Lamp { command, .. } => Some(command),
        }
    }
}

/// The pushed-down outputs of a running PLC.
#[derive(Debug, Clone, Default)]
pub(crate) struct Offloaded {
    outputs: Vec<Pushed>,
    on_stop: OnStop,
}

impl Offloaded {
    /// The run-time side of `plan`. `bus_modules[b]` lists the project module indexes of bus
    /// `b` in the bus owner's order.
    pub(crate) fn new(plan: &Plan, project: &Project, bus_modules: &[Vec<usize>]) -> Self {
        let mut outputs = Vec::new();
        for (r, p) in plan.pushed() {
            let Some(tag) = project.tags.get(r.rung.coil.index()) else {
                continue;
            };
            let Binding::Point { module, .. } = tag.binding else {
                continue;
            };
            let bus = project.modules[module].bus;
            let Some(in_bus) = bus_modules
                .get(bus)
                .and_then(|mods| mods.iter().position(|&m| m == module))
            else {
                continue;
            };
            let model = project.modules[module].model;
            let tables = p
                .tables
                .iter()
                .filter_map(|t| model.point_index(t.register))
                .map(|i| (i, model.points[i].ty.zero()))
                .collect();
            let source = match &p.command {
                None => Source::ReadBack,
                Some(Command::Pulse {
                    point,
                    trigger,
                    width,
                    width_ms,
                }) => Source::Pulse {
                    command: *point,
                    prev: vec![None; trigger.len()],
                    trigger: trigger.clone(),
                    width: *width,
                    width_ms: *width_ms,
                    started: None,
                    fire: false,
                },
                Some(Command::Lamp {
                    point,
                    enable,
                    mask,
                }) => Source::Lamp {
                    command: *point,
                    enable: enable.clone(),
                    mask: *mask,
                },
            };
            outputs.push(Pushed {
                tag: r.rung.coil,
                bus,
                module: in_bus,
                point: p.point,
                safe: tag.safe.unwrap_or(tag.ty.zero()),
                tables,
                value: tag.initial,
                read: Quality::Bad,
                source,
            });
        }
        Self {
            outputs,
            on_stop: project.offload.on_stop,
        }
    }

    /// Whether `tag` is a pushed-down output a force cannot reach: every one but a blinker,
    /// whose force the scan carries out (the mask cleared while forced, the output written).
    pub(crate) fn refuses_force(&self, tag: TagId) -> bool {
        self.outputs
            .iter()
            .any(|p| p.tag == tag && !matches!(p.source, Source::Lamp { .. }))
    }

    /// Input phase: the modules' values of their outputs into the image (`frames[b]` is bus
    /// `b`'s read, `None` when the line did not answer).
    pub(crate) fn read_back(
        &mut self,
        image: &mut ProcessImage,
        frames: &[Option<InputFrame>],
        now: ScanInstant,
    ) {
        for p in &mut self.outputs {
            match &p.source {
                Source::ReadBack => {
                    let snap = frames
                        .get(p.bus)
                        .and_then(Option::as_ref)
                        .and_then(|f| f.modules.get(p.module));
                    match snap {
                        Some(snap) => {
                            let value = snap.values.get(p.point).copied().flatten();
                            let quality = if value.is_none() {
                                Quality::Bad
                            } else {
                                snap.quality
                            };
                            if let Some(v) = value {
                                p.value = v;
                            }
                            p.read = quality;
                            image.update(p.tag, value, quality, now);
                        }
                        None => {
                            if p.read == Quality::Good {
                                p.read = Quality::Stale;
                            }
                            image.set_quality(p.tag, p.read);
                        }
                    }
                }
                Source::Pulse { .. } | Source::Lamp { .. } => {}
            }
        }
    }

    /// Logic phase, after the program: pulse triggers, and the image keeps the modules' values
    /// of their outputs whatever the program wrote. `now` is the scan's time.
    pub(crate) fn after_logic(&mut self, image: &mut ProcessImage, now: ScanInstant) {
        for p in &mut self.outputs {
            if let Source::Pulse {
                trigger,
                prev,
                width,
                started,
                fire,
                ..
            } = &mut p.source
            {
                let mut edge = false;
                for (cond, last) in trigger.iter().zip(prev.iter_mut()) {
                    let v = cond.eval(&mut |t| image.get(t).as_bool());
                    edge |= v && *last == Some(false);
                    *last = Some(v);
                }
                // IEC TP: edges while the pulse runs are ignored.
                let running = started.is_some_and(|s| now.saturating_duration_since(s) < *width);
                if edge && !running {
                    *started = Some(now);
                    *fire = true;
                }
                let on = started.is_some_and(|s| now.saturating_duration_since(s) < *width);
                p.value = Value::Bool(on);
            }
            // The module's status does not show a blinking output: the tag shows what the
            // scan knows, the enable.
            if let Source::Lamp { enable, .. } = &p.source {
                p.value = Value::Bool(enable.eval(&mut |t| image.get(t).as_bool()));
            }
            if image.get(p.tag) != p.value {
                image.set(p.tag, p.value, now);
            }
        }
    }

    /// Output phase, after the write: each pushed-down output's quality as for any output
    /// (`outputs(bus, module)`: what its module holds of its outputs, see
    /// [`softplc_io::line::ModuleSnapshot::outputs`]); a read-back output is good only while
    /// its read-back is too, since that read is what shows the module's logic drives it.
    pub(crate) fn set_qualities(
        &self,
        image: &mut ProcessImage,
        outputs: impl Fn(usize, usize) -> Quality,
    ) {
        for p in &self.outputs {
            let held = outputs(p.bus, p.module);
            let quality = match (&p.source, held) {
                (Source::ReadBack, Quality::Good) => p.read,
                (_, held) => held,
            };
            image.set_quality(p.tag, quality);
        }
    }

    /// Output phase: this cycle's commands into the output frames (call
    /// [`Self::clear_commands`] after the write). A blinker's mask and output are asked for
    /// every cycle; its module's driver writes them when they change (and again after the
    /// module's restart, which clears its blinkers): the mask while enabled and not forced,
    /// else 0, and the output off, or the forced value while forced.
    pub(crate) fn commands(&mut self, frames: &mut [OutputFrame], image: &ProcessImage) {
        for p in &mut self.outputs {
            if let Source::Lamp { command, mask, .. } = &p.source {
                let forced = image.forced(p.tag);
                let shown = match forced {
                    None if p.value.as_bool() => *mask,
                    _ => 0,
                };
                let _ = set(frames, p.bus, p.module, *command, Value::U16(shown));
                let output = forced.unwrap_or(Value::Bool(false));
                let _ = set(frames, p.bus, p.module, p.point, output);
            }
            if let Source::Pulse {
                command,
                width_ms,
                fire,
                ..
            } = &mut p.source
            {
                if std::mem::take(fire) {
                    let _ = set(frames, p.bus, p.module, *command, Value::U16(width_ms.ms()));
                }
            }
        }
    }

    /// Removes the commands (and the safe state's writes) from the frames: they are written
    /// once, and the outputs stay the modules'.
    pub(crate) fn clear_commands(&self, frames: &mut [OutputFrame]) {
        for p in &self.outputs {
            if let Some(slot) = slot(frames, p.bus, p.module, p.point) {
                *slot = None;
            }
            if let Some(command) = p.command() {
                if let Some(slot) = slot(frames, p.bus, p.module, command) {
                    *slot = None;
                }
            }
            for &(t, _) in &p.tables {
                if let Some(slot) = slot(frames, p.bus, p.module, t) {
                    *slot = None;
                }
            }
        }
    }

    /// The safe state, first step: with `on_stop: clear`, zero every table and pulser of the
    /// pushed-down outputs. Returns whether there is anything to write.
    pub(crate) fn clear_tables(&self, frames: &mut [OutputFrame]) -> bool {
        if self.on_stop == OnStop::Keep {
            return false;
        }
        let mut any = false;
        for p in &self.outputs {
            for &(t, zero) in &p.tables {
                any |= set(frames, p.bus, p.module, t, zero);
            }
            if let Some(command) = p.command() {
                any |= set(frames, p.bus, p.module, command, Value::U16(0));
            }
        }
        any
    }

    /// The safe state, second step: with `on_stop: clear`, the safe values of the pushed-down
    /// outputs (the image shows them); with `keep`, the outputs stay the modules'.
    pub(crate) fn safe_outputs(
        &self,
        frames: &mut [OutputFrame],
        image: &mut ProcessImage,
        now: ScanInstant,
    ) {
        if self.on_stop == OnStop::Keep {
            return;
        }
        for p in &self.outputs {
            let _ = set(frames, p.bus, p.module, p.point, p.safe);
            image.set(p.tag, p.safe, now);
        }
    }
}

fn slot(
    frames: &mut [OutputFrame],
    bus: usize,
    module: usize,
    point: usize,
) -> Option<&mut Option<Value>> {
    frames
        .get_mut(bus)
        .and_then(|f| f.modules.get_mut(module))
        .and_then(|m| m.get_mut(point))
}

/// Puts `v` in a frame slot; whether the slot exists.
fn set(frames: &mut [OutputFrame], bus: usize, module: usize, point: usize, v: Value) -> bool {
    match slot(frames, bus, module, point) {
        Some(s) => {
            *s = Some(v);
            true
        }
        None => false,
    }
}

/// Whether two plans put the same rungs in the same modules with the same tables and
/// settings (a program reload must not change what the modules were given at start-up).
pub(crate) fn same_placement(a: &Plan, b: &Plan) -> bool {
    let pushed = |p: &Plan| -> Vec<(TagId, Placement)> {
        p.rungs
            .iter()
            .filter(|r| matches!(r.placement, Placement::Module(_)))
            .map(|r| (r.rung.coil, r.placement.clone()))
            .collect()
    };
    a.push_down == b.push_down && pushed(a) == pushed(b)
}

/// One failure per line.
pub(crate) fn lines(failures: &[RequireFailure]) -> String {
    failures
        .iter()
        .map(ToString::to_string)
        .collect::<Vec<_>>()
        .join("\n")
}
