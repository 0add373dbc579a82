//! Alarms in a scenario: an alarm's state expected at a time (`alarm.door_fault: raised`) and
//! acknowledgements by time (`ack: door_fault`), evaluated by the service's own alarm book
//! (`service::alarms::book`), fed each cycle's changes by the same change feed the running
//! service reads, on the scenario's virtual clock: the same scenario gives the same events.
//! With several tasks the book is fed as `softplc run` feeds it: each task's share (the tags
//! it owns, its modules) at that task's own cycles, so a fast task's alarm is raised and
//! cleared at its times and every module's `lost.` alarm is there.

use std::time::{Duration, SystemTime};

use super::runner::{secs, RunResult};
use super::trace::{Change, Shown};
use crate::logic::ScanContext;
use crate::plc::Plc;
use crate::project::Project;
use crate::scan::ScanInstant;
use crate::service::alarms::book::AlarmBook;
use crate::service::alarms::{AlarmView, EventKind};
use crate::service::boundary::offer_cycle;
use crate::service::changes::{ChangeFeed, ChangeStream};
use crate::service::task_share::TaskShare;

/// How a scenario names an alarm: `alarm.door_fault`, `alarm.lost.door`.
pub(crate) const ALARM_PREFIX: &str = "alarm.";

/// Who the book says acknowledged an alarm of a scenario's `ack:`.
const ACK_BY: &str = "scenario";

/// A state an alarm is expected in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlarmState {
    /// Active and waiting for an acknowledgement.
    Raised,
    /// Its condition holds (acknowledged or not).
    Active,
    /// Its condition does not hold (`inactive` says the same).
    Cleared,
    /// Its last raise was acknowledged.
    Acknowledged,
    /// Waiting for an acknowledgement, active or not.
    Unacknowledged,
}

impl AlarmState {
    /// Each state by its words.
    const WORDS: [(&'static str, AlarmState); 6] = [
        ("raised", AlarmState::Raised),
        ("active", AlarmState::Active),
        ("cleared", AlarmState::Cleared),
        ("inactive", AlarmState::Cleared),
        ("acknowledged", AlarmState::Acknowledged),
        ("unacknowledged", AlarmState::Unacknowledged),
    ];

    /// Reads `raised`, or several states that must all hold: `cleared, acknowledged`.
    pub(crate) fn parse_all(text: &str) -> Option<Vec<Self>> {
        text.split(',')
            .map(|w| {
                let w = w.trim();
                Self::WORDS
                    .iter()
                    .find(|(n, _)| n.eq_ignore_ascii_case(w))
                    .map(|(_, s)| *s)
            })
            .collect()
    }

    /// The words a scenario may write, for a message.
    pub(crate) fn words() -> String {
        let names: Vec<&str> = Self::WORDS.iter().map(|(n, _)| *n).collect();
        names.join(", ")
    }

    fn word(self) -> &'static str {
        Self::WORDS
            .iter()
            .find(|(_, s)| *s == self)
            .map_or("?", |(n, _)| n)
    }

    /// Whether `a` is in this state.
    fn holds(self, a: &AlarmView) -> bool {
        let acked = a.acknowledged && a.raised.is_some();
        match self {
            AlarmState::Raised => a.active && !a.acknowledged,
            AlarmState::Active => a.active,
            AlarmState::Cleared => !a.active,
            AlarmState::Acknowledged => acked,
            AlarmState::Unacknowledged => !a.acknowledged,
        }
    }
}

/// When an alarm's last events happened, in scenario time.
#[derive(Debug, Clone, Copy, Default)]
struct Times {
    raised: Option<Duration>,
    cleared: Option<Duration>,
    acknowledged: Option<Duration>,
}

impl Times {
    fn note(&mut self, event: EventKind, now: Duration) {
        match event {
            EventKind::Raised => {
                *self = Times {
                    raised: Some(now),
                    ..Times::default()
                }
            }
            EventKind::Cleared => self.cleared = Some(now),
            EventKind::Acknowledged => self.acknowledged = Some(now),
        }
    }
}

/// How an alarm's state reads in a failure: `active, unacknowledged (raised at 16.1s)`.
fn describe(a: &AlarmView, times: Times) -> String {
    if a.raised.is_none() {
        return "never raised".into();
    }
    let state = format!(
        "{}, {}",
        if a.active { "active" } else { "cleared" },
        if a.acknowledged {
            "acknowledged"
        } else {
            "unacknowledged"
        }
    );
    let when: Vec<String> = [
        (times.raised, "raised"),
        (times.cleared, "cleared"),
        (times.acknowledged, "acknowledged"),
    ]
    .into_iter()
    .filter_map(|(t, what)| Some(format!("{what} at {}", secs(t?))))
    .collect();
    if when.is_empty() {
        state
    } else {
        format!("{state} ({})", when.join(", "))
    }
}

/// What a scenario does about alarms at a time.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum AlarmStepKind {
    /// The alarm is expected in every one of these states.
    Expect(Vec<AlarmState>),
    /// The alarm (or `all` those waiting) is acknowledged.
    Ack,
}

/// An alarm expected or acknowledged by a step.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct AlarmStep {
    /// Scenario time.
    pub at: Duration,
    /// The alarm's name (the tag's, `lost.MODULE`, or `all` for an acknowledgement).
    pub alarm: String,
    /// What happens.
    pub kind: AlarmStepKind,
    /// The line in the scenario file.
    pub line: usize,
}

/// The alarms `project` has: its tags' and every module's `lost.MODULE`.
pub(crate) fn alarm_names(project: &Project) -> Vec<String> {
    let tags = project
        .alarms
        .alarms
        .iter()
        .filter_map(|a| project.tags.get(a.tag).map(|t| t.name.clone()));
    let modules = project.modules.iter().map(|m| format!("lost.{}", m.name));
    tags.chain(modules).collect()
}

/// Checks that `project` has the alarm `name` (`all` too, for an acknowledgement).
pub(crate) fn check_name(names: &[String], name: &str, all: bool) -> Result<(), String> {
    if names.iter().any(|n| n == name) || (all && name == "all") {
        return Ok(());
    }
    Err(format!(
        "the project has no alarm `{name}` (its alarms: {}){}",
        if names.is_empty() {
            "none".to_owned()
        } else {
            names.join(", ")
        },
        crate::suggest::did_you_mean(name, names.iter().map(String::as_str))
    ))
}

/// The alarm book of one run, fed at every cycle (see the module docs).
pub(crate) struct ScenarioAlarms {
    /// The book's feeds: one of every tag and module for a PLC of one task; with several
    /// tasks one per task, offering its share (the tags it owns, its modules) at its own
    /// cycles, as each task's boundary feeds the alarm service of `softplc run`.
    feeds: Vec<ChangeFeed>,
    stream: ChangeStream,
    book: AlarmBook,
    /// By time; at one time the expectations before the acknowledgements.
    steps: Vec<AlarmStep>,
    next: usize,
    /// Events of the book already in the trace.
    traced: u64,
    /// Per alarm (the book's order): when its last events happened.
    times: Vec<(String, Times)>,
    /// The last cycle fed into the book: an acknowledgement is taken at its boundary.
    last: Option<LastCycle>,
}

/// A cycle fed into the book: its number and scan time (the book's stamp), its scenario time
/// (the trace's).
#[derive(Debug, Clone, Copy)]
struct LastCycle {
    cycle: u64,
    at: ScanInstant,
    now: Duration,
}

impl ScenarioAlarms {
    /// The book of `project` (of one task) and the scenario's alarm `steps`.
    pub(crate) fn new(project: &Project, steps: Vec<AlarmStep>) -> Self {
        Self::fed(project, steps, |feed| vec![feed])
    }

    /// The book of `project` of several tasks, fed each task's share (`shares`, in task
    /// order) at that task's cycles, and the scenario's alarm `steps`.
    pub(crate) fn of_tasks(
        project: &Project,
        shares: Vec<TaskShare>,
        steps: Vec<AlarmStep>,
    ) -> Self {
        Self::fed(project, steps, |feed| {
            shares.into_iter().map(|s| feed.share(s)).collect()
        })
    }

    /// The book of `project`, fed by the feeds `feeds` makes of one feed of the book's own.
    fn fed(
        project: &Project,
        mut steps: Vec<AlarmStep>,
        feeds: impl FnOnce(ChangeFeed) -> Vec<ChangeFeed>,
    ) -> Self {
        steps.sort_by_key(|s| (s.at, matches!(s.kind, AlarmStepKind::Ack)));
        let mut feed = ChangeFeed::new();
        // Taken at once after each offer: one cycle is all the queue ever holds.
        let stream = feed.subscribe("scenario alarms", 2);
        // A fixed origin: the events' UTC does not depend on when the scenario ran.
        let book = AlarmBook::new(project, SystemTime::UNIX_EPOCH);
        let times = book
            .all()
            .into_iter()
            .map(|a| (a.name, Times::default()))
            .collect();
        Self {
            feeds: feeds(feed),
            stream,
            book,
            steps,
            next: 0,
            traced: 0,
            times,
            last: None,
        }
    }

    /// After the cycle `ctx` of task `task` (0 with one task; scenario time `now`): its
    /// changes into the book, then the steps due before `next` (when the next cycle of any
    /// task starts, at the earliest); the book's events into the trace, the failures and the
    /// count of expectations checked into `result`.
    pub(crate) fn cycle(
        &mut self,
        task: usize,
        plc: &Plc,
        ctx: &ScanContext,
        now: Duration,
        next: Duration,
        result: &mut RunResult,
    ) {
        if let Some(feed) = self.feeds.get_mut(task) {
            offer_cycle(feed, plc, ctx.cycle, ctx.now);
        }
        self.last = Some(LastCycle {
            cycle: ctx.cycle,
            at: ctx.now,
            now,
        });
        for d in self.stream.receiver().try_iter() {
            self.book.apply(&d);
        }
        self.take_events(now, &mut result.trace);
        self.steps_before(next, result);
    }

    /// The steps due before `next`, each at the boundary of the last cycle fed (with several
    /// tasks also before a cycle that starts at `next` is fed: the steps due before it, on
    /// the state the cycles before it left).
    pub(crate) fn steps_before(&mut self, next: Duration, result: &mut RunResult) {
        let Some(last) = self.last else {
            return;
        };
        while let Some(step) = self.steps.get(self.next) {
            if step.at >= next {
                break;
            }
            match &step.kind {
                AlarmStepKind::Expect(states) => {
                    result.checked += 1;
                    self.check(step, states, &mut result.failures);
                }
                AlarmStepKind::Ack => {
                    match self
                        .book
                        .acknowledge(&step.alarm, ACK_BY, last.cycle, last.at)
                    {
                        Ok(_) => self.take_events(last.now, &mut result.trace),
                        Err(e) => result.failures.push(format!(
                            "at {} (line {}): cannot acknowledge {}: {e}",
                            secs(step.at),
                            step.line,
                            step.alarm
                        )),
                    }
                }
            }
            self.next += 1;
        }
    }

    /// The book's events since the last call into the trace at `now` (every one comes from
    /// this cycle's changes or acknowledgements), and the alarms' times.
    fn take_events(&mut self, now: Duration, trace: &mut Vec<Change>) {
        let (events, seen) = self.book.events_since(self.traced);
        self.traced = seen;
        for e in events {
            if let Some((_, t)) = self.times.iter_mut().find(|(n, _)| *n == e.alarm) {
                t.note(e.event, now);
            }
            trace.push(Change {
                at: now,
                tag: format!("{ALARM_PREFIX}{}", e.alarm),
                value: Shown::Alarm(e.event),
            });
        }
    }

    fn check(&self, step: &AlarmStep, states: &[AlarmState], failures: &mut Vec<String>) {
        let all = self.book.all();
        let Some(a) = all.iter().find(|a| a.name == step.alarm) else {
            failures.push(format!(
                "at {} (line {}): no alarm {}",
                secs(step.at),
                step.line,
                step.alarm
            ));
            return;
        };
        if states.iter().all(|s| s.holds(a)) {
            return;
        }
        let want: Vec<&str> = states.iter().map(|s| s.word()).collect();
        failures.push(format!(
            "at {} (line {}): alarm.{} expected {}, got {}",
            secs(step.at),
            step.line,
            step.alarm,
            want.join(", "),
            describe(a, self.times_of(&a.name))
        ));
    }

    fn times_of(&self, alarm: &str) -> Times {
        self.times
            .iter()
            .find(|(n, _)| n == alarm)
            .map(|(_, t)| *t)
            .unwrap_or_default()
    }

    /// The steps the run ended before: their times and lines.
    pub(crate) fn left(&self) -> impl Iterator<Item = (Duration, usize)> + '_ {
        self.steps[self.next..].iter().map(|s| (s.at, s.line))
    }
}
