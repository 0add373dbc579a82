//! Logging natively to the systemd journal, when systemd connected stderr to it.
//!
//! Under systemd the log goes to journald through `tracing-journald`, one entry per event,
//! with the level as `PRIORITY` and, where an event concerns them, `PROJECT`, `BUS` and
//! `MODULE` fields, so `journalctl -u softplc@NAME BUS=line1` or `MODULE=mm1` picks one line's
//! or one module's story out of a busy log. The fields come from the event's own fields first
//! (`module = ...` in a driver's event), then from the context the event happened in:
//!
//! - `PROJECT`: the running project (set by `softplc run` once the project is loaded);
//! - `BUS`: the bus thread the event comes from (`bus-NAME`), or a message that starts with
//!   `line NAME:`, as every line's and module's event does;
//! - `MODULE`: a message `line L: module NAME ...`, or the module at the event's `address` on
//!   its bus (a driver's event names the address it was built with, not the module).
//!
//! `tracing-journald` sends to `/run/systemd/journal/socket` and adds fixed fields per layer
//! (`with_custom_fields`), so [`JournalLayer`] keeps one journald layer per set of context
//! fields (a handful: one per bus and module of the project) and hands each event to the one
//! that matches it; [`context_fields`] is the mapping.

use std::collections::HashMap;
use std::fmt;
use std::sync::{Mutex, OnceLock};

use tracing::field::{Field, Visit};
use tracing::span::{Attributes, Id, Record};
use tracing::{Event, Subscriber};
use tracing_subscriber::layer::Context;
use tracing_subscriber::registry::LookupSpan;

/// Whether systemd connected stderr to the journal: `$JOURNAL_STREAM` (`DEVICE:INODE`, in
/// decimal) names stderr's device and inode. systemd.exec(5): checking that the variable is
/// set is not enough (a child whose stderr was redirected inherits it).
pub(super) fn stderr_is_journal() -> bool {
    let Some(var) = std::env::var_os("JOURNAL_STREAM") else {
        return false;
    };
    let Some(var) = var.to_str() else {
        return false;
    };
    match stderr_dev_ino() {
        Some((dev, ino)) => journal_stream_names(var, dev, ino),
        None => false,
    }
}

fn stderr_dev_ino() -> Option<(u64, u64)> {
    use std::os::fd::AsFd;
    use std::os::unix::fs::MetadataExt;
    let fd = std::io::stderr().as_fd().try_clone_to_owned().ok()?;
    let meta = std::fs::File::from(fd).metadata().ok()?;
    Some((meta.dev(), meta.ino()))
}

/// Whether a `$JOURNAL_STREAM` value names the file `dev`:`ino`.
pub(crate) fn journal_stream_names(var: &str, dev: u64, ino: u64) -> bool {
    let Some((d, i)) = var.trim().split_once(':') else {
        return false;
    };
    matches!((d.parse::<u64>(), i.parse::<u64>()), (Ok(d), Ok(i)) if d == dev && i == ino)
}

/// What the journal fields are taken from: the running project and its modules.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct LogContext {
    /// The project's name.
    pub project: String,
    /// Every module: (bus name, address, module name).
    pub modules: Vec<(String, u8, String)>,
}

static CONTEXT: OnceLock<LogContext> = OnceLock::new();

/// Names the running project (and its modules) in every journal entry from now on.
pub(crate) fn set_context(project: &crate::project::Project) {
    let modules = project
        .modules
        .iter()
        .map(|m| {
            let bus = project
                .buses
                .get(m.bus)
                .map(|b| b.name.clone())
                .unwrap_or_default();
            (bus, m.device.address.get(), m.name.clone())
        })
        .collect();
    // Set once per process: a second run in the same process keeps the first context.
    drop(CONTEXT.set(LogContext {
        project: project.name.clone(),
        modules,
    }));
}

/// What an event says about itself: which context fields it has and its message.
#[derive(Debug, Default, Clone, PartialEq)]
pub(crate) struct EventFacts {
    /// The event has a `project` field of its own.
    pub has_project: bool,
    /// The event has a `bus` (or `line`) field of its own.
    pub has_bus: bool,
    /// The event has a `module` field of its own.
    pub has_module: bool,
    /// Its `address` field.
    pub address: Option<u64>,
    /// Its message.
    pub message: String,
}

impl Visit for EventFacts {
    fn record_u64(&mut self, field: &Field, value: u64) {
        if field.name() == "address" {
            self.address = Some(value);
        }
        self.note(field);
    }

    fn record_i64(&mut self, field: &Field, value: i64) {
        if field.name() == "address" {
            self.address = u64::try_from(value).ok();
        }
        self.note(field);
    }

    fn record_str(&mut self, field: &Field, value: &str) {
        if field.name() == "message" {
            self.message = value.to_string();
        }
        self.note(field);
    }

    fn record_debug(&mut self, field: &Field, value: &dyn fmt::Debug) {
        if field.name() == "message" {
            self.message = format!("{value:?}");
        }
        self.note(field);
    }
}

impl EventFacts {
    fn note(&mut self, field: &Field) {
        match field.name() {
            "project" => self.has_project = true,
            "bus" | "line" => self.has_bus = true,
            "module" => self.has_module = true,
            _ => {}
        }
    }
}

/// The journal fields an event gets from its context (see the module's docs), in the order
/// PROJECT, BUS, MODULE; none that the event has itself.
pub(crate) fn context_fields(
    context: Option<&LogContext>,
    thread: Option<&str>,
    event: &EventFacts,
) -> Vec<(&'static str, String)> {
    let mut fields = Vec::new();
    if let Some(c) = context {
        if !event.has_project && !c.project.is_empty() {
            fields.push(("PROJECT", c.project.clone()));
        }
    }
    // "line NAME: module NAME ..." is how every line's and module's event begins.
    let (line_in_text, rest) = match event.message.strip_prefix("line ") {
        Some(r) => match r.split_once(": ") {
            Some((name, rest)) if !name.is_empty() && !name.contains(' ') => (Some(name), rest),
            _ => (None, ""),
        },
        None => (None, ""),
    };
    let bus = thread
        .and_then(|t| t.strip_prefix("bus-"))
        .filter(|b| !b.is_empty())
        .or(line_in_text);
    if let (false, Some(b)) = (event.has_bus, bus) {
        fields.push(("BUS", b.to_string()));
    }
    if event.has_module {
        return fields;
    }
    let named = rest
        .strip_prefix("module ")
        .and_then(|r| r.split([' ', ':']).next())
        .filter(|m| !m.is_empty());
    let by_address = || {
        let (c, bus, address) = (context?, bus?, event.address?);
        c.modules
            .iter()
            .find(|(b, a, _)| b == bus && u64::from(*a) == address)
            .map(|(_, _, m)| m.as_str())
    };
    if let Some(m) = named.or_else(by_address) {
        fields.push(("MODULE", m.to_string()));
    }
    fields
}

/// At most this many sets of context fields get a journald layer of their own (more would be
/// a project with hundreds of modules; the rest are logged without them).
const MAX_LAYERS: usize = 256;

type Fields = Vec<(&'static str, String)>;

/// The journal layer: `tracing-journald`, with the context fields of [`context_fields`].
pub(super) struct JournalLayer {
    /// For events without context fields, and for every span.
    plain: tracing_journald::Layer,
    /// One layer per set of context fields, made when first needed (`None`: it could not be).
    with_fields: Mutex<HashMap<Fields, Option<tracing_journald::Layer>>>,
}

impl fmt::Debug for JournalLayer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("JournalLayer").finish_non_exhaustive()
    }
}

fn journald() -> std::io::Result<tracing_journald::Layer> {
    // No prefix: the fields keep their names (MODULE, ADDRESS), as journalctl matches them.
    Ok(tracing_journald::layer()?
        .with_field_prefix(None)
        .with_syslog_identifier("softplc".to_string()))
}

impl JournalLayer {
    /// Connects to journald; fails when its socket cannot be reached.
    pub(super) fn new() -> std::io::Result<Self> {
        Ok(Self {
            plain: journald()?,
            with_fields: Mutex::new(HashMap::new()),
        })
    }
}

impl<S> tracing_subscriber::Layer<S> for JournalLayer
where
    S: Subscriber + for<'span> LookupSpan<'span>,
{
    fn on_new_span(&self, attrs: &Attributes<'_>, id: &Id, ctx: Context<'_, S>) {
        self.plain.on_new_span(attrs, id, ctx);
    }

    fn on_record(&self, id: &Id, values: &Record<'_>, ctx: Context<'_, S>) {
        self.plain.on_record(id, values, ctx);
    }

    fn on_event(&self, event: &Event<'_>, ctx: Context<'_, S>) {
        let mut facts = EventFacts::default();
        event.record(&mut facts);
        let fields = context_fields(CONTEXT.get(), std::thread::current().name(), &facts);
        if fields.is_empty() {
            return self.plain.on_event(event, ctx);
        }
        let mut layers = self.with_fields.lock().unwrap_or_else(|e| e.into_inner());
        if !layers.contains_key(&fields) && layers.len() < MAX_LAYERS {
            let layer = journald()
                .ok()
                .map(|l| l.with_custom_fields(fields.iter().map(|(k, v)| (*k, v.as_str()))));
            layers.insert(fields.clone(), layer);
        }
        match layers.get(&fields) {
            Some(Some(layer)) => layer.on_event(event, ctx),
            _ => self.plain.on_event(event, ctx),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn context() -> LogContext {
        LogContext {
            project: "press".into(),
            modules: vec![
                ("line1".into(), 1, "mm1".into()),
                ("line1".into(), 2, "resi".into()),
                ("line2".into(), 1, "ex1".into()),
            ],
        }
    }

    fn said(message: &str) -> EventFacts {
        EventFacts {
            message: message.into(),
            ..EventFacts::default()
        }
    }

    #[test]
    fn journal_stream_must_name_stderr_itself() {
        assert!(journal_stream_names("8:3456", 8, 3456));
        assert!(journal_stream_names("8:3456\n", 8, 3456));
        // Set, but for another file (stderr redirected by the parent): not the journal.
        assert!(!journal_stream_names("8:3456", 8, 3457));
        assert!(!journal_stream_names("9:3456", 8, 3456));
        assert!(!journal_stream_names("", 8, 3456));
        assert!(!journal_stream_names("8", 8, 3456));
        assert!(!journal_stream_names("8:x", 8, 3456));
        assert!(!journal_stream_names("0x8:3456", 8, 3456));
    }

    #[test]
    fn a_test_process_stderr_is_not_the_journal_unless_named() {
        // Whatever the environment, the answer follows the variable and stderr's inode.
        let (dev, ino) = stderr_dev_ino().expect("stderr has an inode");
        let var = std::env::var("JOURNAL_STREAM").ok();
        let expected = var
            .as_deref()
            .is_some_and(|v| journal_stream_names(v, dev, ino));
        assert_eq!(stderr_is_journal(), expected);
        assert!(journal_stream_names(&format!("{dev}:{ino}"), dev, ino));
    }

    #[test]
    fn a_module_lost_on_its_bus_thread_names_project_bus_and_module() {
        let c = context();
        let f = context_fields(
            Some(&c),
            Some("bus-line1"),
            &said("line line1: module mm1 lost (timeout); retrying every 100ms at first"),
        );
        assert_eq!(
            f,
            vec![
                ("PROJECT", "press".to_string()),
                ("BUS", "line1".to_string()),
                ("MODULE", "mm1".to_string())
            ]
        );
        let f = context_fields(
            Some(&c),
            Some("bus-line1"),
            &said("line line1: module resi: outputs not written (exception 2)"),
        );
        assert_eq!(f[2], ("MODULE", "resi".to_string()));
    }

    #[test]
    fn a_port_event_names_the_bus_and_no_module() {
        let c = context();
        let f = context_fields(
            Some(&c),
            Some("bus-line2"),
            &said("line line2: port reopened after 2.0s"),
        );
        assert_eq!(
            f,
            vec![("PROJECT", "press".into()), ("BUS", "line2".into())]
        );
        // From the scan thread, the bus comes from the text.
        let f = context_fields(
            Some(&c),
            Some("scan"),
            &said("line line2: no input within 90ms of the cycle's start"),
        );
        assert_eq!(
            f,
            vec![("PROJECT", "press".into()), ("BUS", "line2".into())]
        );
    }

    #[test]
    fn a_drivers_watchdog_event_finds_its_module_by_address_on_its_bus() {
        let c = context();
        let facts = EventFacts {
            address: Some(1),
            ..said("MiniMod at address 1: its watch-dog had fired")
        };
        let f = context_fields(Some(&c), Some("bus-line1"), &facts);
        assert_eq!(f[1..], [("BUS", "line1".into()), ("MODULE", "mm1".into())]);
        let f = context_fields(Some(&c), Some("bus-line2"), &facts);
        assert_eq!(f[2], ("MODULE", "ex1".to_string()));
        // An address nobody has: no module.
        let facts = EventFacts {
            address: Some(9),
            ..facts
        };
        assert_eq!(context_fields(Some(&c), Some("bus-line1"), &facts).len(), 2);
    }

    #[test]
    fn fields_the_event_has_are_not_repeated() {
        let c = context();
        let facts = EventFacts {
            has_module: true,
            has_bus: true,
            ..said("line line1: module mm1 lost")
        };
        assert_eq!(
            context_fields(Some(&c), Some("bus-line1"), &facts),
            vec![("PROJECT", "press".to_string())]
        );
    }

    #[test]
    fn scan_events_carry_the_project_only() {
        let c = context();
        let f = context_fields(Some(&c), Some("scan"), &said("overrun: cycle took 120ms"));
        assert_eq!(f, vec![("PROJECT", "press".to_string())]);
        let f = context_fields(Some(&c), Some("main"), &said("program p.rhai reloaded"));
        assert_eq!(f, vec![("PROJECT", "press".to_string())]);
        // Before the project is loaded: nothing to add.
        assert!(context_fields(None, Some("main"), &said("starting")).is_empty());
        // "line" in prose is not a bus.
        assert_eq!(
            context_fields(Some(&c), Some("scan"), &said("line one of two: x")).len(),
            1
        );
    }

    #[test]
    fn the_visitor_reads_message_address_and_own_fields() {
        use tracing_subscriber::layer::SubscriberExt;
        #[derive(Default, Clone)]
        struct Grab(std::sync::Arc<Mutex<Vec<EventFacts>>>);
        impl<S: Subscriber> tracing_subscriber::Layer<S> for Grab {
            fn on_event(&self, event: &Event<'_>, _: Context<'_, S>) {
                let mut f = EventFacts::default();
                event.record(&mut f);
                self.0.lock().unwrap().push(f);
            }
        }
        let grab = Grab::default();
        let subscriber = tracing_subscriber::registry().with(grab.clone());
        tracing::subscriber::with_default(subscriber, || {
            let address = 7u8;
            tracing::warn!(address, "MiniMod at address {address}: fired");
            tracing::error!(module = %"mm1", "ignored setting");
        });
        let got = grab.0.lock().unwrap().clone();
        assert_eq!(got[0].address, Some(7));
        assert_eq!(got[0].message, "MiniMod at address 7: fired");
        assert!(!got[0].has_module);
        assert!(got[1].has_module);
    }
}
