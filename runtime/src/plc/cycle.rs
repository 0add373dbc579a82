//! The phases the scan calls, and the safe state.

use std::time::Duration;

use softplc_io::line::InputFrame;
use softplc_io::point::Quality;

use crate::image::convert;
use crate::logic::{LogicFault, ScanContext};

use super::*;

impl Plc {
    /// Input phase: every line reads its modules (in parallel), then the image is updated.
    ///
    /// The scan waits for the lines until one deadline, [`Plc::read_budget`] after the cycle's
    /// start: a line that has not delivered by then keeps its last values, stale, and finishes
    /// in its own time (see [`softplc_io::line::LineLink`]).
    pub fn read_inputs(&mut self) {
        let start = self.clock.now();
        let grid = self.cycle_grid.take().unwrap_or(start).min(start);
        self.cycle_start = grid;
        for line in &mut self.lines {
            line.start_read(start);
        }
        let deadline = (grid + self.read_budget).max(start);
        let mut frames: Vec<Option<InputFrame>> = Vec::with_capacity(self.lines.len());
        let mut dead = vec![false; self.lines.len()];
        let mut latest = start;
        for (b, line) in self.lines.iter_mut().enumerate() {
            let delivery = line.finish_read(deadline);
            latest = latest.max(delivery.at);
            // A bus thread that ended on its own (a driver bug) must not leave its line's
            // inputs looking merely stale: they are lost.
            dead[b] = line.is_dead();
            if dead[b] && !self.dead_lines.contains(&b) {
                self.dead_lines.push(b);
                tracing::error!(
                    "line {}: its bus thread has ended; its points are bad",
                    self.project.buses[b].name
                );
            }
            frames.push(delivery.answer);
        }
        for b in 0..frames.len() {
            if frames[b].is_none() && !dead[b] {
                self.note_late_line(b);
            }
        }
        self.clock.sleep_until(latest);
        let now = self.clock.now();
        self.io_wait = now - start;
        for (b, frame) in frames.iter().enumerate() {
            for (k, &m) in self.bus_modules[b].iter().enumerate() {
                let st = &mut self.status[m];
                match frame.as_ref().and_then(|f| f.modules.get(k)) {
                    Some(snap) => {
                        st.quality = snap.quality;
                        st.outputs = snap.outputs;
                        st.counters = snap.counters;
                        st.last_error = snap.last_error;
                        st.reported = true;
                    }
                    None if dead[b] => {
                        st.quality = Quality::Bad;
                        st.outputs = Quality::Bad;
                        st.reported = true;
                    }
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
        // With several tasks: what the others published by now, once per cycle (forces win).
        if let Some(task) = &self.task {
            task.exchange.copy_in(&task.foreign, &mut self.image, now);
        }
        self.image.apply_forces(now);
    }

    /// Logic phase.
    pub fn run_logic(&mut self, ctx: &ScanContext) -> Result<(), LogicFault> {
        if let Some(tap) = self.recorder.as_mut() {
            tap.seen(&self.image, ctx.cycle, ctx.now);
        }
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
        self.offload.commands(&mut self.frames, &self.image);
        self.dispatch_writes();
        // An output tag's quality is what its module holds of it, whoever wrote the value:
        // good once acknowledged, bad while a write is refused or fails (or not made yet),
        // stale while the module is lost (`ModuleSnapshot::outputs`).
        for bind in &self.outputs {
            let m = self.bus_modules[bind.bus][bind.module];
            self.image.set_quality(bind.tag, self.status[m].outputs);
        }
        let (status, bus_modules) = (&self.status, &self.bus_modules);
        self.offload.set_qualities(&mut self.image, |b, k| {
            bus_modules
                .get(b)
                .and_then(|mods| mods.get(k))
                .and_then(|&m| status.get(m))
                .map_or(Quality::Bad, |st| st.outputs)
        });
        self.offload.clear_commands(&mut self.frames);
        // Between cycles: hand changed retained values to their writer (never waits).
        if let Some(r) = self.retain.as_mut() {
            r.tick(&self.image, self.clock.now());
        }
        if let Some(f) = self.kept_forces.as_mut() {
            f.flush();
        }
        // What the cycle wrote, to the flight recorder (never waits either).
        if let Some(tap) = self.recorder.as_mut() {
            tap.wrote(&self.image);
        }
        // With several tasks: the tags this one owns, for the others' next cycles.
        if let Some(task) = &self.task {
            task.exchange
                .publish(&task.owned, &self.image, self.clock.now());
        }
    }

    /// Drives every output to its safe value (stop, fault, watchdog).
    pub fn write_safe_state(&mut self) {
        // A cycle whose program faulted ends here: the recorder keeps it, as it started.
        if let Some(tap) = self.recorder.as_mut() {
            tap.unfinished();
        }
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
        // The other tasks see this one's outputs at their safe values.
        if let Some(task) = &self.task {
            task.exchange
                .publish(&task.owned, &self.image, self.clock.now());
        }
    }

    fn dispatch_writes(&mut self) {
        self.dispatch(false);
    }

    /// Hands the output frames to every line and waits for them: this cycle's writes until
    /// the next cycle's deadline (a busy or dead line finishes them in its own time); `safe`:
    /// the safe state, written in full and to lost modules too, waited for longer.
    fn dispatch(&mut self, safe: bool) {
        let start = self.clock.now();
        for (b, line) in self.lines.iter_mut().enumerate() {
            if safe {
                line.start_safe_write(&self.frames[b], start);
            } else {
                line.start_write(&self.frames[b], start);
            }
        }
        let deadline = if safe {
            start + self.line_wait
        } else {
            (self.cycle_start + self.project.scan.period).max(start)
        };
        let mut latest = start;
        for line in &mut self.lines {
            latest = latest.max(line.finish_write(deadline).at);
        }
        if !safe {
            self.note_unfinished_writes();
        }
        self.clock.sleep_until(latest);
        self.io_wait += self.clock.now() - start;
    }

    /// Keeps which lines were still writing when the scan stopped waiting for them
    /// ([`Plc::cycle_work`]).
    fn note_unfinished_writes(&mut self) {
        use softplc_io::line::WriteEnd;
        let mut unfinished = super::Unfinished {
            since: self.clock.now(),
            ..Default::default()
        };
        for (b, line) in self.lines.iter().enumerate() {
            match line.unfinished_write() {
                Some(WriteEnd::At(t)) => {
                    unfinished.known = Some(unfinished.known.map_or(t, |k| k.max(t)));
                }
                Some(WriteEnd::Later(seq)) => unfinished.later.push((b, seq)),
                None => {}
            }
        }
        if unfinished.work() == super::CycleWork::Later {
            self.open_work.push_back(unfinished.clone());
        }
        self.unfinished = unfinished;
    }

    /// Logs, at most once a minute per line, that a line did not deliver in time.
    fn note_late_line(&mut self, b: usize) {
        let now = self.clock.now();
        let last = &mut self.late_logged[b];
        if last.is_some_and(|t| now - t < Duration::from_secs(60)) {
            return;
        }
        *last = Some(now);
        tracing::warn!(
            "line {}: no input within {:.1?} of the cycle's start; its values are kept stale \
             and the scan goes on (logged at most once a minute)",
            self.project.buses[b].name,
            self.read_budget
        );
    }

    /// Writes the safe state and stops every line thread.
    pub fn shutdown(&mut self) {
        self.write_safe_state();
        if let Some(r) = self.retain.as_mut() {
            r.finish(&self.image);
        }
        if let Some(f) = self.kept_forces.as_mut() {
            f.finish();
        }
        for line in &mut self.lines {
            line.stop(self.line_wait);
        }
    }
}
