//! Wiring the flight recorder into a PLC (see [`crate::recorder`]): the record's header from
//! the project, its first keyframe from the image as built (retained values, initial values,
//! kept forces), and the tap the phases and the control requests report to.

use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use crate::image::TagId;
use crate::recorder::format::{self, Event, Header, Keyframe};
use crate::recorder::replay::tag_table;
use crate::recorder::tap::{Tap, TapCounters};
use crate::recorder::{writer, Disk, FileDisk, RecorderHandle, Settings};

use super::Plc;

/// Why the recorder could not start.
#[derive(Debug, thiserror::Error)]
#[error("flight recorder: {}: {source}", folder.display())]
pub struct RecordError {
    /// The record's folder.
    pub folder: std::path::PathBuf,
    /// The OS error.
    pub source: std::io::Error,
}

impl Plc {
    /// Records every cycle from the next one on into `settings.folder`; the returned handle
    /// waits for the writer once the PLC is gone. Call it before the scan starts, after kept
    /// forces are applied: the first keyframe is the state the first cycle starts from.
    pub fn record(&mut self, settings: Settings) -> Result<RecorderHandle, RecordError> {
        self.record_on(settings, Box::new(FileDisk))
    }

    /// [`Plc::record`] through `disk` (a test's full disk).
    pub fn record_on(
        &mut self,
        settings: Settings,
        disk: Box<dyn Disk>,
    ) -> Result<RecorderHandle, RecordError> {
        let folder = settings.folder.clone();
        let fail = |source| RecordError {
            folder: folder.clone(),
            source,
        };
        let program = self.project.program_source().map_err(fail)?;
        let project_file = std::fs::read(&self.project.source).map_err(fail)?;
        let now = self.clock.now();
        let wall = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .unwrap_or(Duration::ZERO);
        let run_id = u64::try_from(wall.as_nanos()).unwrap_or(u64::MAX);
        let header = Header {
            project: self.project.name.clone(),
            project_hash: format::digest(&project_file),
            program_hash: format::digest(&program),
            program_file: self.project.program_files(),
            period: self.project.scan.period,
            virtual_clock: self.clock.is_virtual(),
            run_id,
            wall_origin: u64::try_from(wall.saturating_sub(now.since_origin()).as_nanos())
                .unwrap_or(0),
            segment: 0,
            tags: tag_table(&self.project, |id| self.plan.is_pushed(id)),
        };
        let keyframe = Keyframe {
            next_cycle: 1,
            now,
            slots: self
                .image
                .slots()
                .iter()
                .map(|s| (s.value, s.quality))
                .collect(),
            forces: (0..self.image.len() as u32)
                .filter_map(|i| self.image.forced(TagId(i)).map(|v| (i, v)))
                .collect(),
        };
        let counters = Arc::new(TapCounters::default());
        let (tx, rx) = crossbeam_channel::bounded(settings.channel);
        self.recorder = Some(Tap::new(tx, &self.image, counters.clone()));
        writer::start(settings, header, keyframe, rx, counters, disk).map_err(|e| {
            self.recorder = None;
            fail(e)
        })
    }

    /// Tells the recorder, if there is one, of a control request applied now.
    pub(super) fn note(&mut self, event: impl FnOnce() -> Event) {
        if let Some(tap) = self.recorder.as_mut() {
            tap.event(event());
        }
    }
}
