//! The alarms' state: every alarm of the project (a tag's, a module's), raised, cleared and
//! acknowledged from the change feed's deliveries and the acknowledgements, with the bounded
//! history of those events. No thread, no file, no clock: the same deliveries give the same
//! book, which is what the tests drive, and what `softplc test` scenarios run on the virtual
//! clock (`cli/test/alarms.rs`), so a scenario's alarms are the running service's.

use std::collections::VecDeque;
use std::time::{Duration, SystemTime};

use serde::{Deserialize, Serialize};
use softplc_io::point::{Quality, Value};
use softplc_io::time::ScanInstant;

use crate::project::{AlarmWhen, Binding, Priority, Project};
use crate::service::changes::Delivery;

/// When something happened: UTC and the cycle.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Stamp {
    /// Wall-clock time, UTC, RFC 3339 with milliseconds.
    pub utc: String,
    /// The cycle (the scan's count of completed cycles at that boundary).
    pub cycle: u64,
}

/// One alarm as a client sees it.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AlarmView {
    /// Its name: the tag's, or `lost.MODULE`.
    pub name: String,
    /// What the operator reads.
    pub text: String,
    /// Its severity, 1..=1000.
    pub priority: u16,
    /// The severity's band: low, medium, high, urgent.
    pub level: String,
    /// Whether its condition holds now.
    pub active: bool,
    /// Whether its last raise was acknowledged (true for an alarm never raised).
    pub acknowledged: bool,
    /// Its last raise.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub raised: Option<Stamp>,
    /// Its last clear (after its last raise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cleared: Option<Stamp>,
    /// Its last acknowledgement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acked: Option<Stamp>,
    /// Who acknowledged it (`cli`, `web ADDRESS operator`, ...).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub acked_by: Option<String>,
}

/// What happened to an alarm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum EventKind {
    /// Its condition came.
    Raised,
    /// Its condition went.
    Cleared,
    /// Someone acknowledged it.
    Acknowledged,
}

impl std::fmt::Display for EventKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            EventKind::Raised => "raised",
            EventKind::Cleared => "cleared",
            EventKind::Acknowledged => "acknowledged",
        })
    }
}

/// One line of the history.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct AlarmEvent {
    /// Wall-clock time, UTC, RFC 3339 with milliseconds.
    pub utc: String,
    /// The cycle it happened at.
    pub cycle: u64,
    /// The alarm.
    pub alarm: String,
    /// What happened.
    pub event: EventKind,
    /// The alarm's severity.
    pub priority: u16,
    /// The alarm's text.
    pub text: String,
    /// Who acknowledged it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub by: Option<String>,
}

impl std::fmt::Display for AlarmEvent {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let level = Priority::new(self.priority).map_or("?", Priority::level);
        write!(
            f,
            "{}  cycle {:<8} {:<12} {:<6} {:<16} {}",
            self.utc, self.cycle, self.event, level, self.alarm, self.text
        )?;
        if let Some(by) = &self.by {
            write!(f, "  (by {by})")?;
        }
        Ok(())
    }
}

/// The figures `status` and the metrics show.
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct AlarmCounts {
    /// Active alarms per band: low, medium, high, urgent.
    pub active: [u64; 4],
    /// Alarms waiting for an acknowledgement (active or not).
    pub unacknowledged: u64,
}

/// Why an acknowledgement was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum AckError {
    /// No alarm of that name.
    #[error("no alarm {name}{}", hint.as_ref().map(|h| format!(" (did you mean {h}?)")).unwrap_or_default())]
    Unknown {
        /// As asked.
        name: String,
        /// The closest name.
        hint: Option<String>,
    },
    /// Nothing to acknowledge.
    #[error("alarm {name} is not waiting for an acknowledgement")]
    NotWaiting {
        /// The alarm.
        name: String,
    },
}

/// What makes an alarm active.
#[derive(Debug, Clone, Copy)]
enum Source {
    /// A tag's value, held while its module is lost or its value bad.
    Tag {
        tag: usize,
        when: AlarmWhen,
        module: Option<usize>,
    },
    /// A module's loss.
    Lost,
}

#[derive(Debug, Clone)]
struct Alarm {
    name: String,
    text: String,
    priority: Priority,
    source: Source,
    active: bool,
    acknowledged: bool,
    raised: Option<Stamp>,
    cleared: Option<Stamp>,
    acked: Option<Stamp>,
    acked_by: Option<String>,
}

/// Every alarm's state and the history (see the module docs).
#[derive(Debug)]
pub(crate) struct AlarmBook {
    alarms: Vec<Alarm>,
    /// Per tag: its alarm.
    of_tag: Vec<Option<usize>>,
    /// Per module: its `lost.` alarm.
    of_module: Vec<usize>,
    /// Per tag: the last value and quality seen (alarm tags only).
    seen: Vec<Option<(Value, Quality)>>,
    history: VecDeque<AlarmEvent>,
    keep: usize,
    /// UTC at the scan's origin.
    wall_origin: SystemTime,
    /// Bumped at every change of an alarm (the publishers compare it).
    generation: u64,
    /// Events ever added to the history (a reader that keeps its own count takes the new
    /// ones, however many the bounded history dropped since).
    recorded: u64,
}

impl AlarmBook {
    /// `project`'s alarms, none raised; UTC of the scan's origin is `wall_origin`.
    pub(crate) fn new(project: &Project, wall_origin: SystemTime) -> Self {
        let mut alarms = Vec::new();
        let mut of_tag = vec![None; project.tags.len()];
        for a in &project.alarms.alarms {
            let Some(tag) = project.tags.get(a.tag) else {
                continue;
            };
            let module = match tag.binding {
                Binding::Point { module, .. } => Some(module),
                Binding::Memory => None,
            };
            of_tag[a.tag] = Some(alarms.len());
            alarms.push(Alarm::new(
                tag.name.clone(),
                a.text.as_str().to_owned(),
                a.priority,
                Source::Tag {
                    tag: a.tag,
                    when: a.when,
                    module,
                },
            ));
        }
        let mut of_module = Vec::new();
        for m in &project.modules {
            of_module.push(alarms.len());
            alarms.push(Alarm::new(
                format!("lost.{}", m.name),
                format!("module lost: {}", m.name),
                Priority::HIGH,
                Source::Lost,
            ));
        }
        Self {
            alarms,
            of_tag,
            of_module,
            seen: vec![None; project.tags.len()],
            history: VecDeque::new(),
            keep: project.alarms.history,
            wall_origin,
            generation: 0,
            recorded: 0,
        }
    }

    /// Takes back a history kept before a restart: its events, and each alarm's state as
    /// they left it (raised and not acknowledged stays so until the first cycle says
    /// otherwise).
    pub(crate) fn restore(&mut self, events: Vec<AlarmEvent>) {
        for e in &events {
            let Some(a) = self.alarms.iter_mut().find(|a| a.name == e.alarm) else {
                continue;
            };
            let stamp = Some(Stamp {
                utc: e.utc.clone(),
                cycle: e.cycle,
            });
            match e.event {
                EventKind::Raised => {
                    a.active = true;
                    a.acknowledged = false;
                    a.raised = stamp;
                    a.cleared = None;
                }
                EventKind::Cleared => {
                    a.active = false;
                    a.cleared = stamp;
                }
                EventKind::Acknowledged => {
                    a.acknowledged = true;
                    a.acked = stamp;
                    a.acked_by.clone_from(&e.by);
                }
            }
        }
        self.history = events.into();
        while self.history.len() > self.keep {
            self.history.pop_front();
        }
        self.generation += 1;
    }

    /// Takes one cycle's changes; whether an alarm changed.
    pub(crate) fn apply(&mut self, d: &Delivery) -> bool {
        let before = self.generation;
        let (cycle, at) = (d.cycle.cycle, d.cycle.at);
        for &(m, q) in d.modules_catch_up.iter().chain(&d.cycle.modules) {
            let Some(&i) = self.of_module.get(m) else {
                continue;
            };
            let lost = q == Quality::Bad;
            if self.alarms[i].active != lost {
                self.set_active(i, lost, cycle, at);
                if !lost {
                    self.reevaluate_module(m, cycle, at);
                }
            }
        }
        for (c, _) in d.all() {
            let Some(Some(i)) = self.of_tag.get(c.tag).copied() else {
                continue;
            };
            self.seen[c.tag] = Some((c.value, c.quality));
            self.evaluate(i, cycle, at);
        }
        self.generation != before
    }

    /// Acknowledges `name` (or every alarm waiting, for `all`) as `by` at `cycle`/`at`; the
    /// names acknowledged.
    pub(crate) fn acknowledge(
        &mut self,
        name: &str,
        by: &str,
        cycle: u64,
        at: ScanInstant,
    ) -> Result<Vec<String>, AckError> {
        let which: Vec<usize> = if name == "all" {
            (0..self.alarms.len())
                .filter(|&i| !self.alarms[i].acknowledged)
                .collect()
        } else {
            let Some(i) = self.alarms.iter().position(|a| a.name == name) else {
                let names = self.alarms.iter().map(|a| a.name.as_str());
                return Err(AckError::Unknown {
                    name: name.to_owned(),
                    hint: crate::project::web::closest(name, names),
                });
            };
            if self.alarms[i].acknowledged {
                return Err(AckError::NotWaiting {
                    name: name.to_owned(),
                });
            }
            vec![i]
        };
        let stamp = self.stamp(cycle, at);
        for &i in &which {
            let a = &mut self.alarms[i];
            a.acknowledged = true;
            a.acked = Some(stamp.clone());
            a.acked_by = Some(by.to_owned());
            self.event(i, EventKind::Acknowledged, &stamp, Some(by.to_owned()));
        }
        Ok(which
            .into_iter()
            .map(|i| self.alarms[i].name.clone())
            .collect())
    }

    /// The current list: every alarm active or waiting for an acknowledgement, those waiting
    /// first, then by priority (highest first), then the latest raised first.
    pub(crate) fn current(&self) -> Vec<AlarmView> {
        let mut list: Vec<&Alarm> = self
            .alarms
            .iter()
            .filter(|a| a.active || !a.acknowledged)
            .collect();
        list.sort_by(|a, b| {
            a.acknowledged
                .cmp(&b.acknowledged)
                .then(b.priority.cmp(&a.priority))
                .then(
                    b.raised
                        .as_ref()
                        .map(|s| s.cycle)
                        .cmp(&a.raised.as_ref().map(|s| s.cycle)),
                )
        });
        list.into_iter().map(Alarm::view).collect()
    }

    /// Every alarm, in the project's order (tags' first, then the modules').
    pub(crate) fn all(&self) -> Vec<AlarmView> {
        self.alarms.iter().map(Alarm::view).collect()
    }

    /// The latest `n` events, the newest first.
    pub(crate) fn history(&self, n: usize) -> Vec<AlarmEvent> {
        self.history.iter().rev().take(n).cloned().collect()
    }

    /// Every event kept, the oldest first (what the file holds).
    pub(crate) fn events(&self) -> impl Iterator<Item = &AlarmEvent> {
        self.history.iter()
    }

    /// The figures for `status` and the metrics.
    pub(crate) fn counts(&self) -> AlarmCounts {
        let mut c = AlarmCounts::default();
        for a in &self.alarms {
            if a.active {
                let band = Priority::LEVELS
                    .iter()
                    .position(|(n, _)| *n == a.priority.level())
                    .unwrap_or(3);
                c.active[band] += 1;
            }
            if !a.acknowledged {
                c.unacknowledged += 1;
            }
        }
        c
    }

    /// Bumped at every change.
    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    /// The events added since a reader had seen `seen` of them (the oldest first; those the
    /// bounded history dropped meanwhile are gone), and the count to remember.
    pub(crate) fn events_since(&self, seen: u64) -> (Vec<AlarmEvent>, u64) {
        let new = usize::try_from(self.recorded.saturating_sub(seen)).unwrap_or(usize::MAX);
        let skip = self.history.len().saturating_sub(new);
        (
            self.history.iter().skip(skip).cloned().collect(),
            self.recorded,
        )
    }

    /// Evaluates alarm `i` (a tag's) from the value last seen, unless it is held: its
    /// module is lost, or its value bad.
    fn evaluate(&mut self, i: usize, cycle: u64, at: ScanInstant) {
        let Source::Tag { tag, when, module } = self.alarms[i].source else {
            return;
        };
        if let Some(m) = module {
            if self
                .of_module
                .get(m)
                .is_some_and(|&l| self.alarms[l].active)
            {
                return;
            }
        }
        let Some((value, quality)) = self.seen[tag] else {
            return;
        };
        if quality == Quality::Bad {
            return;
        }
        let active = when.holds(value);
        if active != self.alarms[i].active {
            self.set_active(i, active, cycle, at);
        }
    }

    /// A module is back: its tags' alarms are evaluated from their latest values.
    fn reevaluate_module(&mut self, m: usize, cycle: u64, at: ScanInstant) {
        for i in 0..self.alarms.len() {
            if matches!(self.alarms[i].source, Source::Tag { module: Some(x), .. } if x == m) {
                self.evaluate(i, cycle, at);
            }
        }
    }

    fn set_active(&mut self, i: usize, active: bool, cycle: u64, at: ScanInstant) {
        let stamp = self.stamp(cycle, at);
        let a = &mut self.alarms[i];
        a.active = active;
        if active {
            a.acknowledged = false;
            a.raised = Some(stamp.clone());
            a.cleared = None;
            self.event(i, EventKind::Raised, &stamp, None);
        } else {
            a.cleared = Some(stamp.clone());
            self.event(i, EventKind::Cleared, &stamp, None);
        }
    }

    fn event(&mut self, i: usize, event: EventKind, stamp: &Stamp, by: Option<String>) {
        let a = &self.alarms[i];
        self.history.push_back(AlarmEvent {
            utc: stamp.utc.clone(),
            cycle: stamp.cycle,
            alarm: a.name.clone(),
            event,
            priority: a.priority.severity(),
            text: a.text.clone(),
            by,
        });
        while self.history.len() > self.keep {
            self.history.pop_front();
        }
        self.generation += 1;
        self.recorded += 1;
    }

    fn stamp(&self, cycle: u64, at: ScanInstant) -> Stamp {
        Stamp {
            utc: utc(self.wall_origin + at.since_origin()),
            cycle,
        }
    }
}

impl Alarm {
    fn new(name: String, text: String, priority: Priority, source: Source) -> Self {
        Self {
            name,
            text,
            priority,
            source,
            active: false,
            acknowledged: true,
            raised: None,
            cleared: None,
            acked: None,
            acked_by: None,
        }
    }

    fn view(&self) -> AlarmView {
        AlarmView {
            name: self.name.clone(),
            text: self.text.clone(),
            priority: self.priority.severity(),
            level: self.priority.level().to_owned(),
            active: self.active,
            acknowledged: self.acknowledged,
            raised: self.raised.clone(),
            cleared: self.cleared.clone(),
            acked: self.acked.clone(),
            acked_by: self.acked_by.clone(),
        }
    }
}

/// RFC 3339 with milliseconds, UTC.
pub(crate) fn utc(t: SystemTime) -> String {
    chrono::DateTime::<chrono::Utc>::from(t).to_rfc3339_opts(chrono::SecondsFormat::Millis, true)
}

/// UTC at the scan's origin, from the wall clock and the scan's time now.
pub(crate) fn wall_origin(scan_now: ScanInstant) -> SystemTime {
    SystemTime::now()
        .checked_sub(scan_now.since_origin())
        .unwrap_or(SystemTime::UNIX_EPOCH + Duration::ZERO)
}

#[cfg(test)]
#[path = "book_tests.rs"]
mod tests;
