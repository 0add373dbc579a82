//! A Modbus TCP bus: tokio-modbus's client on one connection per endpoint, shared by every
//! unit id behind it (a gateway allows only a few connections).
//!
//! The bus owner still runs the bus on its own OS thread (or inline on a virtual clock); this
//! transport keeps a current-thread tokio runtime and blocks on each call. tokio's timer
//! lateness (~1 ms) is small beside a network round trip, and the scan never waits on it
//! (DESIGN.md principle 1: the scan keeps its own deadline).
//!
//! Discipline: a request waits at most the bus's response timeout. After a timeout, a reply
//! that is not Modbus, or one with another transaction id, the connection is dropped and the
//! next request opens a new one at once: a late answer can then never meet a later request
//! (the TCP counterpart of the RTU guard and flush). A connection that cannot be made is a
//! line failure: the bus owner retries it with its bounded, doubling backoff
//! (`reconnect_min`..`reconnect_max`), logs it, and its modules go stale, then bad, as on a
//! dead serial line. A gateway's "target device failed to respond" and "path unavailable"
//! exceptions (0x0B, 0x0A) are the unit's silence, not a refusal: the module is missing, as a
//! timeout on RS-485 would say.

use std::sync::Arc;
use std::time::Duration;

use tokio_modbus::client::{Client as _, Context};
use tokio_modbus::slave::{Slave, SlaveContext as _};

use crate::line::settings::LineSettings;
use crate::line::tcp::convert;
use crate::line::tcp::endpoint::TcpEndpoint;
use crate::line::transport::{CallMiss, LineError, PduChannel, Transport};
use crate::modbus::master::ReplyError;
use crate::modbus::{Request, Response};
use crate::time::{Clock, LineInstant};

/// The exceptions by which a gateway says the unit behind it did not answer.
const GATEWAY_SILENCE: [u8; 2] = [0x0A, 0x0B];

/// A Modbus TCP connection to one endpoint.
pub struct ModbusTcpTransport {
    endpoint: TcpEndpoint,
    runtime: tokio::runtime::Runtime,
    context: Option<Context>,
    connect_timeout: Duration,
    clock: Arc<dyn Clock>,
    /// Connections made so far (the first one included).
    connects: u64,
}

impl std::fmt::Debug for ModbusTcpTransport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ModbusTcpTransport")
            .field("endpoint", &self.endpoint)
            .field("connected", &self.context.is_some())
            .field("connects", &self.connects)
            .finish()
    }
}

impl ModbusTcpTransport {
    /// A transport for `endpoint`; nothing is connected yet (the first request connects, so a
    /// server that is not up at start-up only leaves its modules lost until it is).
    pub fn new(
        endpoint: TcpEndpoint,
        connect_timeout: Duration,
        clock: Arc<dyn Clock>,
    ) -> std::io::Result<Self> {
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_io()
            .enable_time()
            .build()?;
        Ok(Self {
            endpoint,
            runtime,
            context: None,
            connect_timeout,
            clock,
            connects: 0,
        })
    }

    /// Connections made so far.
    pub fn connects(&self) -> u64 {
        self.connects
    }

    fn connect(&mut self) -> Result<(), LineError> {
        let authority = self.endpoint.authority();
        let timeout = self.connect_timeout;
        let stream = self.runtime.block_on(async {
            let connect = async {
                let stream = tokio::net::TcpStream::connect(authority.as_str()).await?;
                // Requests are small and each waits for its answer: never hold one back.
                stream.set_nodelay(true)?;
                Ok::<_, std::io::Error>(stream)
            };
            match tokio::time::timeout(timeout, connect).await {
                Ok(r) => r,
                Err(_) => Err(std::io::Error::new(
                    std::io::ErrorKind::TimedOut,
                    format!("no answer within {timeout:?}"),
                )),
            }
        });
        match stream {
            Ok(stream) => {
                self.connects += 1;
                tracing::debug!(endpoint = %self.endpoint, "connected");
                self.context = Some(tokio_modbus::client::tcp::attach_slave(
                    stream,
                    Slave::tcp_device(),
                ));
                Ok(())
            }
            Err(source) => Err(LineError::Connect {
                endpoint: self.endpoint.to_string(),
                source,
            }),
        }
    }

    /// Drops the connection (inside the runtime, whose reactor the socket is registered with).
    fn disconnect(&mut self) {
        let _guard = self.runtime.enter();
        self.context = None;
    }
}

impl Transport for ModbusTcpTransport {
    fn settings(&self) -> LineSettings {
        // No serial line: the settings only name a format for the reports that print one.
        LineSettings::DEFAULT
    }

    fn now(&self) -> LineInstant {
        self.clock.line_now()
    }

    fn write_frame(&mut self, _frame: &[u8]) -> Result<(), LineError> {
        // Validation keeps text-protocol modules off a Modbus TCP bus; a frame that gets here
        // all the same is refused, never sent as a malformed message.
        Err(LineError::Io(std::io::Error::new(
            std::io::ErrorKind::Unsupported,
            "a Modbus TCP bus carries Modbus requests only",
        )))
    }

    fn read_until(
        &mut self,
        _buf: &mut Vec<u8>,
        _deadline: LineInstant,
    ) -> Result<usize, LineError> {
        Ok(0)
    }

    fn wait_until(&mut self, t: LineInstant) {
        self.clock.sleep_until_on_line(t);
    }

    fn flush_input(&mut self) -> Result<usize, LineError> {
        Ok(0)
    }

    fn reopen(&mut self) -> Result<(), LineError> {
        self.disconnect();
        self.connect()
    }

    fn pdu_channel(&mut self) -> Option<&mut dyn PduChannel> {
        Some(self)
    }
}

impl PduChannel for ModbusTcpTransport {
    fn call(
        &mut self,
        unit: u8,
        request: &Request,
        timeout: Duration,
    ) -> Result<Response, CallMiss> {
        let Some(req) = convert::request(request) else {
            return Err(CallMiss::Bad(ReplyError::WrongFunction {
                expected: request.function() as u8,
                found: 0,
            }));
        };
        if self.context.is_none() {
            self.connect().map_err(CallMiss::Line)?;
        }
        let Some(context) = self.context.as_mut() else {
            return Err(CallMiss::Line(LineError::Io(std::io::Error::new(
                std::io::ErrorKind::NotConnected,
                "not connected",
            ))));
        };
        context.set_slave(Slave(unit));
        let answer = self
            .runtime
            .block_on(async { tokio::time::timeout(timeout, context.call(req)).await });
        let result = match answer {
            Err(_elapsed) => Err(CallMiss::Silence),
            Ok(Ok(Ok(res))) => convert::response(request, res).map_err(CallMiss::Bad),
            // A well-formed answer from the gateway itself: the connection stays.
            Ok(Ok(Err(code))) if GATEWAY_SILENCE.contains(&u8::from(code)) => {
                return Err(CallMiss::Silence);
            }
            Ok(Ok(Err(code))) => Ok(convert::exception(request, code)),
            Ok(Err(tokio_modbus::Error::Protocol(e))) => Err(CallMiss::Bad(match e {
                tokio_modbus::ProtocolError::HeaderMismatch { .. } => ReplyError::HeaderMismatch,
                tokio_modbus::ProtocolError::FunctionCodeMismatch { result, .. } => {
                    ReplyError::WrongFunction {
                        expected: request.function() as u8,
                        found: match result {
                            Ok(r) => r.function_code().value(),
                            Err(e) => e.function.value(),
                        },
                    }
                }
            })),
            // The codec refuses what is not a Modbus TCP frame (a wrong protocol id, a length
            // outside the ADU's, a PDU it cannot decode).
            Ok(Err(tokio_modbus::Error::Transport(e)))
                if e.kind() == std::io::ErrorKind::InvalidData =>
            {
                Err(CallMiss::Bad(ReplyError::Malformed { offset: 0 }))
            }
            Ok(Err(tokio_modbus::Error::Transport(e))) => Err(CallMiss::Line(LineError::Io(e))),
        };
        if result.is_err() {
            // Whatever comes on this connection now may be the late answer: start afresh.
            self.disconnect();
        }
        result
    }
}
