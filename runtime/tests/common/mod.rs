//! What the subjects share: the workspace and loopback ports (`host`), a test's own project
//! folder (`scratch`), a simulated serial line served on a pty (`sim`), a mosquitto broker and the Sparkplug host's Python code (`broker`), the plant services' alarm project
//! (`alarm_project`).

#[cfg(any(feature = "opcua", feature = "mqtt"))]
pub(crate) mod alarm_project;
pub(crate) mod broker;
pub(crate) mod host;
pub(crate) mod scratch;
pub(crate) mod sim;
