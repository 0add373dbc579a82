//! The phases the scan calls, and the safe state.

use softplc_io::line::bus::{BusCommand, BusEvent, InputFrame};
use softplc_io::point::Quality;

use crate::image::convert;
use crate::logic::{LogicFault, ScanContext};

use super::*;

impl Plc {
    /// Input phase: every line reads its modules (in parallel), then the image is updated.
    pub fn read_inputs(&mut self) {
        let start = self.clock.now();
        let mut frames: Vec<Option<InputFrame>> = Vec::with_capacity(self.lines.len());
        let mut sent = vec![false; self.lines.len()];
        for (b, line) in self.lines.iter_mut().enumerate() {
            if let Line::Thread(t) = line {
                sent[b] = t.send(BusCommand::Read);
            }
        }
        let mut latest = start;
        let mut dead = vec![false; self.lines.len()];
        for (b, line) in self.lines.iter_mut().enumerate() {
            let frame = match line {
                Line::Inline(owner) => {
                    owner.sync(start);
                    let f = owner.read_inputs();
                    latest = latest.max(f.finished);
                    Some(f)
                }
                Line::Thread(t) if sent[b] => match t.recv(self.line_wait) {
                    Some(BusEvent::Inputs(f)) => Some(f),
                    _ => None,
                },
                Line::Thread(_) => None,
                Line::Stopped => None,
            };
            if let Line::Thread(t) = line {
                // A bus thread that ended on its own (a driver bug) must not leave its line's
                // inputs looking merely stale: they are lost.
                dead[b] = t.is_finished();
                if dead[b] && !self.dead_lines.contains(&b) {
                    self.dead_lines.push(b);
                    tracing::error!(
                        "line {}: its bus thread has ended; its points are bad",
                        self.project.buses[b].name
                    );
                }
            }
            frames.push(frame);
        }
        if self.clock.is_virtual() {
            self.clock.sleep_until(latest);
        }
        let now = self.clock.now();
        for (b, frame) in frames.iter().enumerate() {
            for (k, &m) in self.bus_modules[b].iter().enumerate() {
                let st = &mut self.status[m];
                match frame.as_ref().and_then(|f| f.modules.get(k)) {
                    Some(snap) => {
                        st.quality = snap.quality;
                        st.counters = snap.counters;
                        st.last_error = snap.last_error.clone();
                    }
                    None if dead[b] => st.quality = Quality::Bad,
                    None => {
                        // The line did not answer in time: its points keep their values.
                        st.quality = if st.quality == Quality::Good {
                            Quality::Stale
                        } else {
                            st.quality
                        };
                    }
                }
            }
        }
        for bind in &self.inputs {
            let Some(frame) = frames.get(bind.bus).and_then(Option::as_ref) else {
                let q = self.image.slot(bind.tag).quality;
                if dead[bind.bus] {
                    self.image.set_quality(bind.tag, Quality::Bad);
                } else if q == Quality::Good {
                    self.image.set_quality(bind.tag, Quality::Stale);
                }
                continue;
            };
            if let Some(snap) = frame.modules.get(bind.module) {
                let value = snap.values.get(bind.point).copied().flatten();
                let quality = if value.is_none() {
                    Quality::Bad
                } else {
                    snap.quality
                };
                self.image.update(bind.tag, value, quality, now);
            }
        }
        self.offload.read_back(&mut self.image, &frames, now);
        self.image.apply_forces(now);
    }

    /// Logic phase.
    pub fn run_logic(&mut self, ctx: &ScanContext) -> Result<(), LogicFault> {
        let result = self.logic.scan(&mut self.image, ctx);
        self.offload.after_logic(&mut self.image, ctx.now);
        result
    }

    /// Output phase: every line writes what changed (in parallel).
    pub fn write_outputs(&mut self) {
        self.image.apply_forces(self.clock.now());
        for bind in &self.outputs {
            let v = convert(
                self.image.get(bind.tag),
                self.project.tags[bind.tag.index()].ty,
            );
            self.frames[bind.bus].modules[bind.module][bind.point] = Some(v);
        }
        self.offload.commands(&mut self.frames);
        self.dispatch_writes();
        self.offload.clear_commands(&mut self.frames);
        // Between cycles: hand changed retained values to their writer (never waits).
        if let Some(r) = self.retain.as_mut() {
            r.tick(&self.image, self.clock.now());
        }
    }

    /// Drives every output to its safe value (stop, fault, watchdog).
    pub fn write_safe_state(&mut self) {
        // Pushed-down outputs: their tables are cleared first, in a write of their own, so no
        // module logic drives them once they are set to their safe values.
        if self.offload.clear_tables(&mut self.frames) {
            self.dispatch_writes();
            self.offload.clear_commands(&mut self.frames);
        }
        for bind in &self.outputs {
            self.frames[bind.bus].modules[bind.module][bind.point] = Some(bind.safe);
            self.image.set(bind.tag, bind.safe, self.clock.now());
        }
        self.offload
            .safe_outputs(&mut self.frames, &mut self.image, self.clock.now());
        self.dispatch(true);
        self.offload.clear_commands(&mut self.frames);
    }

    fn dispatch_writes(&mut self) {
        self.dispatch(false);
    }

    /// Sends the output frames to every line and waits for them; `safe`: the safe state,
    /// written in full and to lost modules too.
    fn dispatch(&mut self, safe: bool) {
        let start = self.clock.now();
        let mut sent = vec![false; self.lines.len()];
        for (b, line) in self.lines.iter_mut().enumerate() {
            if let Line::Thread(t) = line {
                let frame = self.frames[b].clone();
                sent[b] = t.send(if safe {
                    BusCommand::WriteSafe(frame)
                } else {
                    BusCommand::Write(frame)
                });
            }
        }
        let mut latest = start;
        for (b, line) in self.lines.iter_mut().enumerate() {
            match line {
                Line::Inline(owner) => {
                    owner.sync(start);
                    let report = if safe {
                        owner.write_safe(&self.frames[b])
                    } else {
                        owner.write_outputs(&self.frames[b])
                    };
                    latest = latest.max(report.finished);
                }
                Line::Thread(t) if sent[b] => {
                    let _ = t.recv(self.line_wait);
                }
                Line::Thread(_) => {}
                Line::Stopped => {}
            }
        }
        if self.clock.is_virtual() {
            self.clock.sleep_until(latest);
        }
    }

    /// Writes the safe state and stops every line thread.
    pub fn shutdown(&mut self) {
        self.write_safe_state();
        if let Some(r) = self.retain.as_mut() {
            r.finish(&self.image);
        }
        for line in &mut self.lines {
            if let Line::Thread(t) = std::mem::replace(line, Line::Stopped) {
                let _ = t.stop(None, self.line_wait);
            }
        }
    }
}
