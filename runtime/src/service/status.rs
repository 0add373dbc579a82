//! The status of a running instance, as `softplc status` prints it and the control socket
//! sends it (JSON).

use serde::{Deserialize, Serialize};

use crate::image::TagId;
use crate::plc::Plc;
use crate::scan::ScanStats;

/// Percentiles in microseconds, for JSON.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
pub struct MicrosPercentiles {
    /// Samples.
    pub count: u64,
    /// Median.
    pub p50_us: u64,
    /// 99th percentile.
    pub p99_us: u64,
    /// 99.9th percentile.
    pub p999_us: u64,
    /// Largest.
    pub max_us: u64,
}

impl From<crate::scan::Percentiles> for MicrosPercentiles {
    fn from(p: crate::scan::Percentiles) -> Self {
        Self {
            count: p.count,
            p50_us: p.p50.as_micros() as u64,
            p99_us: p.p99.as_micros() as u64,
            p999_us: p.p999.as_micros() as u64,
            max_us: p.max.as_micros() as u64,
        }
    }
}

/// One module's state.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ModuleReport {
    /// Name.
    pub name: String,
    /// Bus.
    pub bus: String,
    /// `good`, `stale` or `bad`.
    pub quality: String,
    /// Whether it holds what the program last asked of its outputs: `good`, or `bad` while a
    /// write is refused or fails, while it restarts and while it is lost.
    #[serde(default)]
    pub outputs: String,
    /// Requests sent.
    pub requests: u64,
    /// Timeouts.
    pub timeouts: u64,
    /// CRC errors.
    pub crc_errors: u64,
    /// Replies that were not the answer.
    pub bad_replies: u64,
    /// Exception replies.
    pub exceptions: u64,
    /// Requests whose echo was wrong or missing, or came back as the reply (line errors).
    #[serde(default)]
    pub echo_errors: u64,
    /// Last round trip, µs.
    pub last_round_trip_us: u64,
    /// The last failure, if the last read failed.
    pub last_error: Option<String>,
}

/// One tag's state.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TagReport {
    /// Name.
    pub name: String,
    /// Value as text.
    pub value: String,
    /// `good`, `stale` or `bad`.
    pub quality: String,
    /// The forced value, if forced.
    pub forced: Option<String>,
}

/// Everything `softplc status` shows.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct StatusReport {
    /// Project name.
    pub project: String,
    /// Completed scans.
    pub scans: u64,
    /// Overruns.
    pub overruns: u64,
    /// Scan period, µs.
    pub period_us: u64,
    /// Cycle time.
    pub cycle: MicrosPercentiles,
    /// Wake-up lateness.
    pub lateness: MicrosPercentiles,
    /// Modules.
    pub modules: Vec<ModuleReport>,
    /// Tags.
    pub tags: Vec<TagReport>,
    /// Every service's state.
    #[serde(default)]
    pub services: Vec<super::health::ServiceReport>,
    /// The services fed every change (OPC UA, MQTT) and the changes each lost so far.
    #[serde(default)]
    pub lost_changes: Vec<LostChanges>,
    /// The simulated plant, when the project has one on a `port: sim` line.
    #[serde(default)]
    pub plant: Option<PlantReport>,
    /// Active alarms per priority band and those waiting for an acknowledgement (absent
    /// when the instance runs no alarm service).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alarms: Option<crate::service::alarms::AlarmCounts>,
    /// With several tasks, each task's figures (the fields above are the first task's);
    /// absent for a project with `scan:`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub tasks: Vec<TaskReport>,
    /// The program files of the (first) task, in the order they run each cycle.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub programs: Vec<String>,
}

/// The plant model's state: running or stopped (and why), and its states.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PlantReport {
    /// The model's name.
    pub model: String,
    /// `running`, or `stopped` after an error of the model.
    pub state: String,
    /// Why it stopped (the model file's line:col and the error).
    pub error: Option<String>,
    /// Its states by name, as text.
    pub states: Vec<(String, String)>,
}

impl PlantReport {
    /// The report of `plc`'s plant, if it has one running in a simulated world.
    pub fn of(plc: &Plc) -> Option<Self> {
        use softplc_io::sim::plant::PlantHealth;
        let model = plc.project().plant.as_ref()?.model.name.clone();
        let world = plc.world()?.lock().unwrap_or_else(|p| p.into_inner());
        let plant = world.plant()?;
        let (state, error) = match plant.health() {
            PlantHealth::Running => ("running".to_owned(), None),
            PlantHealth::Stopped(why) => ("stopped".to_owned(), Some(why)),
        };
        let states = plant
            .states()
            .into_iter()
            .map(|(name, v)| (name, state_text(v)))
            .collect();
        Some(Self {
            model,
            state,
            error,
            states,
        })
    }
}

/// A state as a person reads it: a float to 3 decimals, trailing zeros dropped.
fn state_text(v: softplc_io::sim::plant::StateValue) -> String {
    match v {
        softplc_io::sim::plant::StateValue::Float(x) => {
            let text = format!("{x:.3}");
            let text = text.trim_end_matches('0').trim_end_matches('.');
            if text == "-0" {
                "0".to_owned()
            } else {
                text.to_owned()
            }
        }
        other => other.to_string(),
    }
}

impl std::fmt::Display for PlantReport {
    /// `plant door: running; position 45.2, ...` or `plant door: stopped: file:line:col: ...`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "plant {}: {}", self.model, self.state)?;
        if let Some(e) = &self.error {
            write!(f, ": {e} (its terminals hold their last values)")?;
        }
        let states: Vec<String> = self
            .states
            .iter()
            .map(|(n, v)| format!("{n} {v}"))
            .collect();
        if !states.is_empty() {
            write!(f, "; {}", states.join(", "))?;
        }
        Ok(())
    }
}

/// One task's figures.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TaskReport {
    /// The task.
    pub name: String,
    /// Its completed cycles.
    pub scans: u64,
    /// Its overruns.
    pub overruns: u64,
    /// Its period, µs.
    pub period_us: u64,
    /// Its cycle time.
    pub cycle: MicrosPercentiles,
    /// Its wake-up lateness.
    pub lateness: MicrosPercentiles,
    /// Its program files, in the order they run each cycle.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub programs: Vec<String>,
}

impl TaskReport {
    /// Task `t`'s figures as its scan last published them (`None`: its scan panicked holding
    /// them).
    pub fn of(t: &TaskStatus) -> Option<Self> {
        let live = t.live.lock().ok()?;
        Some(Self {
            name: t.name.clone(),
            scans: live.cycles,
            overruns: live.overruns,
            period_us: t.period.as_micros() as u64,
            cycle: live.cycle.into(),
            lateness: live.lateness.into(),
            programs: t.programs.clone(),
        })
    }
}

/// A task's live figures, as the status reads them.
#[derive(Debug, Clone)]
pub struct TaskStatus {
    /// The task.
    pub name: String,
    /// Its period.
    pub period: std::time::Duration,
    /// Its program files, in running order (as the status lists them).
    pub programs: Vec<String>,
    /// What its scan publishes (every 200 ms).
    pub live: std::sync::Arc<std::sync::Mutex<crate::scan::StatusSnapshot>>,
    /// Its modules' indices in the project, in its own order (the status lists every task's
    /// modules in project order).
    pub modules: Vec<usize>,
}

impl StatusReport {
    /// Adds every task's figures (from their live snapshots), the other tasks' modules (every
    /// task's in project order) and their forces (a tag is forced in the image of the task
    /// owning it).
    pub fn with_tasks(mut self, tasks: &[TaskStatus]) -> Self {
        // (project index, report); a module whose index is unknown keeps its place at the end.
        let place = |t: &TaskStatus, k: usize| t.modules.get(k).copied().unwrap_or(usize::MAX);
        let mut modules: Vec<(usize, ModuleReport)> = match tasks.first() {
            // The first task's modules are in the report already, as its scan sees them.
            Some(first) => std::mem::take(&mut self.modules)
                .into_iter()
                .enumerate()
                .map(|(k, m)| (place(first, k), m))
                .collect(),
            None => return self,
        };
        for (i, t) in tasks.iter().enumerate() {
            let Some(mut report) = TaskReport::of(t) else {
                continue;
            };
            if i == 0 {
                // The first task answers at its own boundary: its counts are the report's,
                // after this cycle, not as its scan last published them (a cycle or more
                // before, so `scans` said N and the task's own entry N - 1).
                report.scans = self.scans;
                report.overruns = self.overruns;
            }
            self.tasks.push(report);
            let Ok(live) = t.live.lock() else { continue };
            if i > 0 {
                modules.extend(
                    live.modules
                        .iter()
                        .enumerate()
                        .map(|(k, m)| (place(t, k), ModuleReport::of(m))),
                );
                for (tag, value) in &live.forces {
                    if let Some(t) = self.tags.get_mut(tag.index()) {
                        t.forced = Some(value.to_string());
                    }
                }
            }
        }
        modules.sort_by_key(|(at, _)| *at);
        self.modules = modules.into_iter().map(|(_, m)| m).collect();
        self
    }
}

/// The changes a service fed every change could not take in time.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct LostChanges {
    /// The service: `opcua` or `mqtt`.
    pub service: String,
    /// Changes lost so far.
    pub lost: u64,
}

impl StatusReport {
    /// The report of `plc` after the cycles `stats` counted (with several tasks: the tags
    /// other tasks own as they last published them).
    pub fn of(plc: &Plc, stats: &ScanStats) -> Self {
        let project = plc.project();
        let image = plc.image();
        let mut report = Self {
            project: project.name.clone(),
            scans: stats.cycles,
            overruns: stats.overruns,
            period_us: project.scan.period.as_micros() as u64,
            cycle: stats.cycle.percentiles().into(),
            lateness: stats.lateness.percentiles().into(),
            modules: plc.module_status().iter().map(ModuleReport::of).collect(),
            tags: (0..image.len())
                .map(|i| {
                    let id = TagId(i as u32);
                    let slot = image.slot(id);
                    TagReport {
                        name: image.name(id).to_string(),
                        value: slot.value.to_string(),
                        quality: slot.quality.to_string(),
                        forced: image.forced(id).map(|v| v.to_string()),
                    }
                })
                .collect(),
            services: Vec::new(),
            lost_changes: Vec::new(),
            plant: PlantReport::of(plc),
            alarms: None,
            tasks: Vec::new(),
            programs: program_names(&project.programs),
        };
        for (tag, slot) in plc.published_by_others() {
            if let Some(t) = report.tags.get_mut(tag.index()) {
                t.value = slot.value.to_string();
                t.quality = slot.quality.to_string();
            }
        }
        report
    }
}

/// The file names of `programs`, in running order.
pub(crate) fn program_names(programs: &[crate::project::ProgramConfig]) -> Vec<String> {
    programs
        .iter()
        .map(|p| {
            p.path.file_name().map_or_else(
                || p.path.display().to_string(),
                |n| n.to_string_lossy().into_owned(),
            )
        })
        .collect()
}

impl ModuleReport {
    fn of(m: &crate::plc::ModuleStatus) -> Self {
        ModuleReport {
            name: m.name.clone(),
            bus: m.bus.clone(),
            quality: m.quality.to_string(),
            outputs: m.outputs.to_string(),
            requests: m.counters.requests,
            timeouts: m.counters.timeouts,
            crc_errors: m.counters.crc_errors,
            bad_replies: m.counters.bad_replies,
            exceptions: m.counters.exceptions,
            echo_errors: m.counters.echo_errors,
            last_round_trip_us: m.counters.last_round_trip.as_micros() as u64,
            last_error: m.last_error.as_ref().map(ToString::to_string),
        }
    }
}

/// A JSON field in µs, printed as `softplc run` prints its times (µs, ms or s by size), so
/// the same figure reads the same in both places.
fn micros(us: u64) -> String {
    crate::scan::fmt_duration(std::time::Duration::from_micros(us))
}

/// `cycle p50 … p99 … max …`, as the status line says a cycle's time.
fn cycle_text(c: &MicrosPercentiles) -> String {
    format!(
        "cycle p50 {} p99 {} max {}",
        micros(c.p50_us),
        micros(c.p99_us),
        micros(c.max_us)
    )
}

impl std::fmt::Display for StatusReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if self.tasks.is_empty() {
            writeln!(
                f,
                "{}: {} scans, {} overruns, period {}; {}",
                self.project,
                self.scans,
                self.overruns,
                micros(self.period_us),
                cycle_text(&self.cycle)
            )?;
            // One program says nothing the project file does not; several, their order.
            if self.programs.len() > 1 {
                writeln!(
                    f,
                    "  programs, in running order: {}",
                    self.programs.join(", ")
                )?;
            }
        } else {
            writeln!(f, "{}: {} tasks", self.project, self.tasks.len())?;
        }
        for t in &self.tasks {
            writeln!(
                f,
                "  task {}: {} cycles, {} overruns, period {}; {}; lateness p99 {}",
                t.name,
                t.scans,
                t.overruns,
                micros(t.period_us),
                cycle_text(&t.cycle),
                micros(t.lateness.p99_us)
            )?;
            if !t.programs.is_empty() {
                writeln!(f, "    programs: {}", t.programs.join(", "))?;
            }
        }
        let services: Vec<String> = self
            .services
            .iter()
            .filter(|s| s.state != super::health::ServiceState::Off)
            .map(ToString::to_string)
            .collect();
        if !services.is_empty() {
            writeln!(f, "  services: {}", services.join(", "))?;
        }
        if let Some(p) = &self.plant {
            writeln!(f, "  {p}")?;
        }
        if let Some(a) = &self.alarms {
            writeln!(
                f,
                "  alarms: {} active (urgent {}, high {}, medium {}, low {}), {} waiting for \
                 acknowledgement (softplc alarms)",
                a.active.iter().sum::<u64>(),
                a.active[3],
                a.active[2],
                a.active[1],
                a.active[0],
                a.unacknowledged
            )?;
        }
        for m in &self.modules {
            writeln!(
                f,
                "  module {} ({}): {}{}  requests {} timeouts {} crc {} bad {} exceptions {}{}{}",
                m.name,
                m.bus,
                m.quality,
                if m.outputs.is_empty() || m.outputs == "good" {
                    String::new()
                } else {
                    format!(", outputs {}", m.outputs)
                },
                m.requests,
                m.timeouts,
                m.crc_errors,
                m.bad_replies,
                m.exceptions,
                // Only on a bus whose adapter echoes, or should.
                if m.echo_errors > 0 {
                    format!(" echo {}", m.echo_errors)
                } else {
                    String::new()
                },
                m.last_error
                    .as_ref()
                    .map(|e| format!("  last error: {e}"))
                    .unwrap_or_default()
            )?;
        }
        for t in &self.tags {
            let forced = t
                .forced
                .as_ref()
                .map(|v| format!("  FORCED {v}"))
                .unwrap_or_default();
            writeln!(f, "  {:<16} {:>8} {}{forced}", t.name, t.value, t.quality)?;
        }
        if !self.lost_changes.is_empty() {
            let each: Vec<String> = self
                .lost_changes
                .iter()
                .map(|l| format!("{} {}", l.service, l.lost))
                .collect();
            writeln!(f, "  changes lost by services: {}", each.join(", "))?;
        }
        Ok(())
    }
}
