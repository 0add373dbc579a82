//! Buses over TCP: `port: tcp://HOST:PORT` (Modbus TCP devices and TCP-to-RTU gateways) and
//! `port: rtu+tcp://HOST:PORT` (serial device servers that pass RTU frames through).
//!
//! - [`endpoint`]: the URL, parsed once into a [`TcpEndpoint`].
//! - [`modbus_tcp`]: the Modbus TCP transport, tokio-modbus's client behind the bus owner's
//!   [`crate::line::transport::PduChannel`].
//! - [`rtu_over_tcp`]: the byte pipe for RTU over TCP, framed by our own RTU codec.

pub(crate) mod convert;
pub(crate) mod endpoint;
pub(crate) mod modbus_tcp;
pub(crate) mod rtu_over_tcp;

pub use endpoint::{EndpointError, NetFraming, TcpEndpoint};
pub use modbus_tcp::ModbusTcpTransport;
pub use rtu_over_tcp::RtuOverTcpTransport;

/// How long a connection attempt may take before it counts as failed: long enough for a
/// gateway across a plant network, short enough that a dead one holds its bus thread (never
/// the scan) only briefly per backoff step.
pub const CONNECT_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(1);
