//! The state of every service of a running PLC: running, degraded (with the reason) or
//! stopped (with the reason), as `status --json`, the metrics and the web page's overview
//! show it.
//!
//! Why one registry: a service that fails around the scan (a recorder on a full disk, an OPC
//! UA server without a usable certificate, a broker that is gone) must never look up. Each
//! service sets its own entry where it learns something (a network service when it starts or
//! stops, the MQTT session when it connects or loses the broker), or is asked when a report is
//! made (the recorder's writer and the retain writer keep their own state; a probe reads it).
//! Readers take a copy under a short lock, never on the scan's timing path.

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex, PoisonError};

use serde::{Deserialize, Serialize};

use crate::project::Bytes;
use crate::recorder::WriterState;
use crate::retain::SaveFailure;

/// The services a PLC may run, in the order they are reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Service {
    /// The web page.
    Web,
    /// The Prometheus metrics endpoint.
    Metrics,
    /// The Modbus TCP server.
    ModbusTcp,
    /// The OPC UA server.
    Opcua,
    /// The MQTT Sparkplug B edge node.
    Mqtt,
    /// The flight recorder.
    Recorder,
    /// The retained values' writer.
    Retain,
    /// Traces.
    Trace,
    /// The audit file's writer.
    Audit,
    /// The alarms' thread and history file.
    Alarms,
}

impl Service {
    /// Every service, in report order.
    pub const ALL: [Service; 10] = [
        Service::Web,
        Service::Metrics,
        Service::ModbusTcp,
        Service::Opcua,
        Service::Mqtt,
        Service::Recorder,
        Service::Retain,
        Service::Trace,
        Service::Audit,
        Service::Alarms,
    ];

    /// Its name in reports and metrics labels.
    pub fn name(self) -> &'static str {
        match self {
            Service::Web => "web",
            Service::Metrics => "metrics",
            Service::ModbusTcp => "modbus_tcp",
            Service::Opcua => "opcua",
            Service::Mqtt => "mqtt",
            Service::Recorder => "recorder",
            Service::Retain => "retain",
            Service::Trace => "trace",
            Service::Audit => "audit",
            Service::Alarms => "alarms",
        }
    }
}

/// Where a service is.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "state", content = "reason", rename_all = "snake_case")]
pub enum ServiceState {
    /// Not configured in the project.
    Off,
    /// Doing its job.
    Running,
    /// Up, but not doing all of its job; why.
    Degraded(String),
    /// Not running; why.
    Stopped(String),
}

impl ServiceState {
    /// The state's word: `off`, `running`, `degraded`, `stopped`.
    pub fn word(&self) -> &'static str {
        match self {
            ServiceState::Off => "off",
            ServiceState::Running => "running",
            ServiceState::Degraded(_) => "degraded",
            ServiceState::Stopped(_) => "stopped",
        }
    }

    /// The reason, for degraded and stopped.
    pub fn reason(&self) -> Option<&str> {
        match self {
            ServiceState::Degraded(r) | ServiceState::Stopped(r) => Some(r),
            ServiceState::Off | ServiceState::Running => None,
        }
    }
}

/// One service's line of a report.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ServiceReport {
    /// The service.
    pub service: Service,
    /// Its state (and reason).
    #[serde(flatten)]
    pub state: ServiceState,
}

impl std::fmt::Display for ServiceReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}", self.service.name(), self.state.word())?;
        match self.state.reason() {
            Some(r) => write!(f, " ({r})"),
            None => Ok(()),
        }
    }
}

/// What a writer's state says of the recorder service.
fn writer_state(state: &WriterState) -> ServiceState {
    match state {
        WriterState::Writing => ServiceState::Running,
        WriterState::Held {
            reason,
            held_bytes,
            losing,
        } => ServiceState::Degraded(format!(
            "cannot write ({reason}); {} held in memory{}",
            Bytes(*held_bytes as u64),
            if *losing {
                ", more lost: the record will have a gap"
            } else {
                ", retrying"
            }
        )),
        WriterState::Stopped { reason } => {
            ServiceState::Stopped(format!("cannot write ({reason})"))
        }
    }
}

/// One service each task of a PLC of several tasks runs for itself (its recorder's writer, its
/// retained values' writer), reported as one, with each task's state read when a report is
/// made (see [`Health::watch_tasks`]); cloned handles share the list, so each task adds its
/// own as it starts.
#[derive(Clone, Default)]
pub struct PerTask(Arc<Mutex<Vec<(String, Probe)>>>);

impl std::fmt::Debug for PerTask {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let tasks = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        f.debug_list()
            .entries(tasks.iter().map(|(t, _)| t))
            .finish()
    }
}

impl PerTask {
    /// An empty list.
    pub fn new() -> Self {
        Self::default()
    }

    /// Task `task` records through the writer whose state is `writer`.
    pub fn add_recorder(&self, task: &str, writer: Arc<Mutex<WriterState>>) {
        self.add(task, move || {
            writer_state(&writer.lock().unwrap_or_else(PoisonError::into_inner))
        });
    }

    /// Task `task` saves its retained values through the writer whose failure is `failure`.
    pub fn add_retain(&self, task: &str, failure: SaveFailure) {
        self.add(task, move || retain_state(&failure));
    }

    fn add(&self, task: &str, probe: impl Fn() -> ServiceState + Send + Sync + 'static) {
        self.0
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push((task.to_string(), Box::new(probe)));
    }

    /// The service's state over every task's: running while every task's runs; stopped when
    /// none runs; degraded otherwise. The reason names each task whose part is not running,
    /// so an operator knows which task has a hole while the others' go on.
    fn state(&self) -> ServiceState {
        let tasks = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        let states: Vec<(&str, ServiceState)> = tasks
            .iter()
            .map(|(task, probe)| (task.as_str(), probe()))
            .collect();
        if states.is_empty() {
            // No task runs it (no task retains a tag, say).
            return ServiceState::Off;
        }
        let failing: Vec<String> = states
            .iter()
            .filter_map(|(task, s)| Some(format!("task {task}: {}", s.reason()?)))
            .collect();
        if failing.is_empty() {
            return ServiceState::Running;
        }
        let reason = failing.join("; ");
        let all_stopped = states
            .iter()
            .all(|(_, s)| matches!(s, ServiceState::Stopped(_)));
        if all_stopped {
            ServiceState::Stopped(reason)
        } else {
            ServiceState::Degraded(reason)
        }
    }
}

/// The retained values' state: degraded while saving fails.
fn retain_state(failure: &SaveFailure) -> ServiceState {
    match &*failure.lock().unwrap_or_else(PoisonError::into_inner) {
        None => ServiceState::Running,
        Some(e) => ServiceState::Degraded(format!("cannot save: {e}")),
    }
}

/// A service whose state is read when a report is made.
type Probe = Box<dyn Fn() -> ServiceState + Send + Sync>;

#[derive(Default)]
struct Entries {
    set: BTreeMap<Service, ServiceState>,
    probes: BTreeMap<Service, Probe>,
}

/// The registry of a running PLC's services; cloned handles share it.
#[derive(Clone, Default)]
pub struct Health(Arc<Mutex<Entries>>);

impl std::fmt::Debug for Health {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_list().entries(self.report()).finish()
    }
}

impl Health {
    /// Every service off.
    pub fn new() -> Self {
        Self::default()
    }

    /// `service` is now `state`.
    pub fn set(&self, service: Service, state: ServiceState) {
        let mut e = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        e.probes.remove(&service);
        e.set.insert(service, state);
    }

    /// `service`'s state is what `probe` says when asked.
    pub fn watch(
        &self,
        service: Service,
        probe: impl Fn() -> ServiceState + Send + Sync + 'static,
    ) {
        let mut e = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        e.set.remove(&service);
        e.probes.insert(service, Box::new(probe));
    }

    /// The recorder's state is its writer's: degraded while the disk refuses (holding records,
    /// or losing some), stopped when the record ended before the run.
    pub fn watch_recorder(&self, writer: Arc<Mutex<WriterState>>) {
        self.watch(Service::Recorder, move || {
            writer_state(&writer.lock().unwrap_or_else(PoisonError::into_inner))
        });
    }

    /// `service` run by each task of a PLC of several tasks (the recorder, the retained
    /// values' writer), as one service over every task's part.
    pub fn watch_tasks(&self, service: Service, tasks: PerTask) {
        self.watch(service, move || tasks.state());
    }

    /// The retained values' state: degraded while saving fails.
    pub fn watch_retain(&self, failure: SaveFailure) {
        self.watch(Service::Retain, move || retain_state(&failure));
    }

    /// The state of `service`.
    pub fn state(&self, service: Service) -> ServiceState {
        let e = self.0.lock().unwrap_or_else(PoisonError::into_inner);
        match (e.set.get(&service), e.probes.get(&service)) {
            (Some(s), _) => s.clone(),
            (None, Some(probe)) => probe(),
            (None, None) => ServiceState::Off,
        }
    }

    /// Every service's state, in [`Service::ALL`] order.
    pub fn report(&self) -> Vec<ServiceReport> {
        Service::ALL
            .iter()
            .map(|&service| ServiceReport {
                service,
                state: self.state(service),
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_and_probed_states_are_reported_in_order_with_their_reasons() {
        let health = Health::new();
        health.set(Service::Web, ServiceState::Running);
        health.set(
            Service::Opcua,
            ServiceState::Stopped("no certificate".into()),
        );
        let disk = Arc::new(Mutex::new(ServiceState::Running));
        let seen = disk.clone();
        health.watch(Service::Recorder, move || seen.lock().unwrap().clone());
        *disk.lock().unwrap() = ServiceState::Degraded("disk full".into());
        let text: Vec<String> = health.report().iter().map(ToString::to_string).collect();
        assert_eq!(
            text,
            [
                "web: running",
                "metrics: off",
                "modbus_tcp: off",
                "opcua: stopped (no certificate)",
                "mqtt: off",
                "recorder: degraded (disk full)",
                "retain: off",
                "trace: off",
                "audit: off",
                "alarms: off",
            ]
        );
        let retain: SaveFailure = Arc::new(Mutex::new(Some("No space left on device".into())));
        health.watch_retain(retain.clone());
        let writer = Arc::new(Mutex::new(WriterState::Held {
            reason: "No space left on device (os error 28)".into(),
            held_bytes: 2048,
            losing: true,
        }));
        health.watch_recorder(writer.clone());
        assert_eq!(
            health.state(Service::Recorder).reason(),
            Some(
                "cannot write (No space left on device (os error 28)); 2 KiB held in memory, \
                 more lost: the record will have a gap"
            )
        );
        assert_eq!(
            health.state(Service::Retain),
            ServiceState::Degraded("cannot save: No space left on device".into())
        );
        *writer.lock().unwrap() = WriterState::Writing;
        *retain.lock().unwrap() = None;
        assert_eq!(health.state(Service::Recorder), ServiceState::Running);
        assert_eq!(health.state(Service::Retain), ServiceState::Running);
        let json = serde_json::to_string(&health.report()[3]).unwrap();
        assert_eq!(
            json,
            r#"{"service":"opcua","state":"stopped","reason":"no certificate"}"#
        );
    }

    #[test]
    fn the_recorder_of_several_tasks_names_each_failing_task() {
        let health = Health::new();
        let recorders = PerTask::new();
        let fast = Arc::new(Mutex::new(WriterState::Writing));
        let slow = Arc::new(Mutex::new(WriterState::Writing));
        recorders.add_recorder("fast", fast.clone());
        recorders.add_recorder("slow", slow.clone());
        health.watch_tasks(Service::Recorder, recorders);
        assert_eq!(health.state(Service::Recorder), ServiceState::Running);
        *slow.lock().unwrap() = WriterState::Stopped {
            reason: "Read-only file system (os error 30)".into(),
        };
        assert_eq!(
            health.state(Service::Recorder),
            ServiceState::Degraded(
                "task slow: cannot write (Read-only file system (os error 30))".into()
            ),
            "the fast task still records"
        );
        *fast.lock().unwrap() = WriterState::Held {
            reason: "No space left on device (os error 28)".into(),
            held_bytes: 1024,
            losing: false,
        };
        assert_eq!(
            health.state(Service::Recorder).reason(),
            Some(
                "task fast: cannot write (No space left on device (os error 28)); 1 KiB held \
                 in memory, retrying; task slow: cannot write (Read-only file system (os \
                 error 30))"
            )
        );
        *fast.lock().unwrap() = WriterState::Stopped {
            reason: "gone".into(),
        };
        assert_eq!(health.state(Service::Recorder).word(), "stopped");
    }

    #[test]
    fn the_retained_values_of_several_tasks_name_the_task_whose_saves_fail() {
        let health = Health::new();
        let retains = PerTask::new();
        health.watch_tasks(Service::Retain, retains.clone());
        assert_eq!(
            health.state(Service::Retain),
            ServiceState::Off,
            "no task retains a tag yet"
        );
        let press: SaveFailure = Arc::new(Mutex::new(None));
        let panel: SaveFailure = Arc::new(Mutex::new(None));
        retains.add_retain("press", press.clone());
        retains.add_retain("panel", panel.clone());
        assert_eq!(health.state(Service::Retain), ServiceState::Running);
        *panel.lock().unwrap() = Some("No space left on device".into());
        assert_eq!(
            health.state(Service::Retain),
            ServiceState::Degraded("task panel: cannot save: No space left on device".into()),
            "the first task's failure is not the only one seen"
        );
        *panel.lock().unwrap() = None;
        assert_eq!(health.state(Service::Retain), ServiceState::Running);
    }
}
