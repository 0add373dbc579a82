//! The Modbus TCP server for SCADA/HMI (tokio-modbus), on its own thread with a
//! current-thread tokio runtime.
//!
//! Reads are answered from the snapshot the scan publishes ([`super::snapshot`]); writes go to
//! the scan thread through the control channel and are answered once the scan has applied
//! them at a cycle boundary and published the result, so a read after a write's answer sees
//! the written value (unless the program has overwritten it since). The map of addresses is
//! [`super::modbus_map`]; the exceptions it answers are listed on
//! [`super::modbus_map::Exception`].
//!
//! The server answers its configured unit identifier and 255 (Modbus TCP's "this server");
//! any other unit gets exception 0B. At most [`MAX_CLIENTS`] clients at once. A client that
//! completes no request within the project's `idle_timeout` of its last reply (60 s unless
//! told; a frame dribbled byte by byte does not count as activity) is disconnected, and so is
//! one that does not take a reply within `send_timeout` (10 s unless told): a client that
//! sends requests without reading the answers fills the socket's buffers and would otherwise
//! hold its slot for good. See [`super::modbus_guard`].

use crate::log_limit::{limited, Site};
use std::future::Future;
use std::net::SocketAddr;
use std::pin::Pin;
use std::sync::atomic::AtomicUsize;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crossbeam_channel::Sender;
use softplc_io::point::Value;
use tokio_modbus::server::tcp::Server;
use tokio_modbus::{ExceptionCode, Request as MbRequest, Response as MbResponse, SlaveRequest};

use super::accepting::Accepting;
use super::control::{Envelope, Request, TagValue};
use super::modbus_guard::{ClientSlot, FrameGuard, Patience};
use super::modbus_map::{Exception, ModbusMap};
use super::snapshot::{ServiceSnapshot, SnapshotCell};
use crate::project::ModbusTcpConfig;

/// Most clients connected at once; more are refused (closed at once).
pub(crate) const MAX_CLIENTS: usize = 16;
/// The unit identifier Modbus TCP uses for "the server itself".
pub(crate) const UNIT_THIS_SERVER: u8 = 255;
/// How long a write waits for the scan to apply and publish it.
const WRITE_WAIT: Duration = Duration::from_secs(3);

/// What to do with a request.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Answer {
    /// Answer this.
    Now(MbResponse),
    /// Set these tags (index, value) through the scan, then answer this.
    Write(Vec<(usize, Value)>, MbResponse),
}

/// Decides the answer to `request` for `unit` from `snapshot`. Pure: the server's whole
/// protocol logic, unit-tested and fuzzable without a socket.
pub(crate) fn answer(
    cfg: &ModbusTcpConfig,
    map: &ModbusMap,
    snapshot: &ServiceSnapshot,
    unit: u8,
    request: &MbRequest<'_>,
) -> Result<Answer, Exception> {
    use MbRequest as Q;
    use MbResponse as R;
    if unit != cfg.unit && unit != UNIT_THIS_SERVER {
        return Err(Exception::GatewayTargetFailed);
    }
    let values = &snapshot.values;
    let is_write = matches!(
        request,
        Q::WriteSingleCoil(..)
            | Q::WriteMultipleCoils(..)
            | Q::WriteSingleRegister(..)
            | Q::WriteMultipleRegisters(..)
    );
    if is_write && !cfg.writes {
        return Err(Exception::IllegalFunction);
    }
    let is_read = matches!(
        request,
        Q::ReadCoils(..)
            | Q::ReadDiscreteInputs(..)
            | Q::ReadHoldingRegisters(..)
            | Q::ReadInputRegisters(..)
    );
    if is_read && !snapshot.published {
        return Err(Exception::ServerDeviceBusy);
    }
    Ok(match request {
        Q::ReadCoils(a, n) => Answer::Now(R::ReadCoils(map.read_bits(*a, *n, values)?)),
        Q::ReadDiscreteInputs(a, n) => {
            Answer::Now(R::ReadDiscreteInputs(map.read_bits(*a, *n, values)?))
        }
        Q::ReadHoldingRegisters(a, n) => {
            Answer::Now(R::ReadHoldingRegisters(map.read_registers(*a, *n, values)?))
        }
        Q::ReadInputRegisters(a, n) => {
            Answer::Now(R::ReadInputRegisters(map.read_registers(*a, *n, values)?))
        }
        Q::WriteSingleCoil(a, b) => {
            Answer::Write(map.write_bits(*a, &[*b])?, R::WriteSingleCoil(*a, *b))
        }
        Q::WriteMultipleCoils(a, bits) => {
            let n = u16::try_from(bits.len()).map_err(|_| Exception::IllegalDataValue)?;
            Answer::Write(map.write_bits(*a, bits)?, R::WriteMultipleCoils(*a, n))
        }
        Q::WriteSingleRegister(a, w) => Answer::Write(
            map.write_registers(*a, &[*w])?,
            R::WriteSingleRegister(*a, *w),
        ),
        Q::WriteMultipleRegisters(a, words) => {
            let n = u16::try_from(words.len()).map_err(|_| Exception::IllegalDataValue)?;
            Answer::Write(
                map.write_registers(*a, words)?,
                R::WriteMultipleRegisters(*a, n),
            )
        }
        _ => return Err(Exception::IllegalFunction),
    })
}

/// Everything a connection needs, shared by all of them.
#[derive(Debug)]
struct Shared {
    cfg: ModbusTcpConfig,
    map: ModbusMap,
    /// Tag names, in tag order (writes name their tags to the scan).
    names: Vec<String>,
    snapshot: SnapshotCell,
    scan: Sender<Envelope>,
}

impl Shared {
    /// Sends `writes` to the scan and waits until it has applied and published them.
    /// Blocking: runs on tokio's blocking pool.
    fn apply(&self, writes: &[(usize, Value)], peer: Option<SocketAddr>) -> Result<(), Exception> {
        let values = writes
            .iter()
            .map(|&(tag, v)| {
                let tag = self
                    .names
                    .get(tag)
                    .cloned()
                    .ok_or(Exception::ServerDeviceFailure)?;
                Ok(TagValue {
                    tag,
                    value: v.to_string(),
                })
            })
            .collect::<Result<Vec<_>, Exception>>()?;
        let before = self.snapshot.with(|s| s.cycles);
        let deadline = Instant::now() + WRITE_WAIT;
        let (reply, answer) = crossbeam_channel::bounded(1);
        let envelope = Envelope::new(
            Request::Write { values },
            reply,
            WRITE_WAIT,
            crate::service::audit::Origin::Modbus(peer),
        );
        self.scan
            .send_deadline(envelope, deadline)
            .map_err(|_| Exception::ServerDeviceFailure)?;
        let response = answer
            .recv_deadline(deadline)
            .map_err(|_| Exception::ServerDeviceFailure)?;
        if !response.ok {
            let why = response.error.unwrap_or_default();
            limited!(INFO, WRITE_REFUSED, why, "Modbus TCP write refused: {why}");
            return Err(Exception::ServerDeviceFailure);
        }
        // The scan applied the write before publishing at that boundary; a publication of a
        // later cycle than the one seen before sending therefore shows it.
        while self.snapshot.with(|s| s.cycles) <= before {
            if Instant::now() >= deadline {
                return Err(Exception::ServerDeviceFailure);
            }
            std::thread::sleep(Duration::from_millis(1));
        }
        Ok(())
    }
}

/// The tokio-modbus service of one connection, with its client's address (for the audit file).
#[derive(Debug, Clone)]
struct Scada(Arc<Shared>, Option<SocketAddr>);

type Reply = Pin<Box<dyn Future<Output = Result<MbResponse, ExceptionCode>> + Send>>;

fn exception(e: Exception) -> ExceptionCode {
    ExceptionCode::new(e.code())
}

impl tokio_modbus::server::Service for Scada {
    type Request = SlaveRequest<'static>;
    type Response = MbResponse;
    type Exception = ExceptionCode;
    type Future = Reply;

    fn call(&self, req: Self::Request) -> Self::Future {
        let shared = &self.0;
        let decided = shared
            .snapshot
            .with(|s| answer(&shared.cfg, &shared.map, s, req.slave, &req.request));
        match decided {
            Ok(Answer::Now(r)) => Box::pin(std::future::ready(Ok(r))),
            Err(e) => Box::pin(std::future::ready(Err(exception(e)))),
            Ok(Answer::Write(writes, r)) => {
                let shared = shared.clone();
                let peer = self.1;
                Box::pin(async move {
                    match tokio::task::spawn_blocking(move || shared.apply(&writes, peer)).await {
                        Ok(Ok(())) => Ok(r),
                        Ok(Err(e)) => Err(exception(e)),
                        Err(_) => Err(exception(Exception::ServerDeviceFailure)),
                    }
                })
            }
        }
    }
}

/// Why the server could not start.
#[derive(Debug, thiserror::Error)]
pub(crate) enum StartError {
    /// The address could not be bound.
    #[error("cannot listen on {addr}: {source}")]
    Bind {
        /// The address.
        addr: SocketAddr,
        /// The OS error.
        source: std::io::Error,
    },
    /// The thread or its runtime could not be made.
    #[error("cannot start the Modbus TCP thread: {0}")]
    Thread(std::io::Error),
}

/// A running server; it lives as long as the process.
#[derive(Debug)]
pub(crate) struct ModbusTcpServer {
    addr: SocketAddr,
}

impl ModbusTcpServer {
    /// Binds `cfg.bind` and serves `map` on a thread. `names` are the tag names in tag order;
    /// `snapshot` is what the scan publishes; writes go to `scan`.
    pub(crate) fn start(
        cfg: ModbusTcpConfig,
        map: ModbusMap,
        names: Vec<String>,
        snapshot: SnapshotCell,
        scan: Sender<Envelope>,
        accepting: Accepting,
    ) -> Result<Self, StartError> {
        let bind = |source| StartError::Bind {
            addr: cfg.bind,
            source,
        };
        let listener = std::net::TcpListener::bind(cfg.bind).map_err(bind)?;
        listener.set_nonblocking(true).map_err(bind)?;
        let addr = listener.local_addr().map_err(bind)?;
        let runtime = tokio::runtime::Builder::new_current_thread()
            .enable_all()
            .max_blocking_threads(4)
            .build()
            .map_err(StartError::Thread)?;
        let shared = Arc::new(Shared {
            cfg,
            map,
            names,
            snapshot,
            scan,
        });
        std::thread::Builder::new()
            .name("modbus-tcp".into())
            .spawn(move || runtime.block_on(serve(listener, shared, accepting)))
            .map_err(StartError::Thread)?;
        Ok(Self { addr })
    }

    /// The address it listens on (the bound port when the configured one was 0).
    pub(crate) fn local_addr(&self) -> SocketAddr {
        self.addr
    }
}

/// Kernel buffer of each direction of a client connection, in bytes: room for dozens of the
/// largest frames (260 bytes), where the kernel's autotuning would otherwise grow to megabytes
/// for a client that floods requests or does not read its replies (so such a client is
/// noticed, by the send timeout, after a few hundred replies rather than a few hundred
/// thousand).
const SOCKET_BUFFER: usize = 16 * 1024;

/// Log sites a peer or the system can repeat (see [`crate::log_limit`]).
const REFUSED: Site = Site::new("modbus_tcp.refused", "Modbus TCP: refused connections");
const WRITE_REFUSED: Site = Site::new("modbus_tcp.write_refused", "Modbus TCP: refused writes");

async fn serve(listener: std::net::TcpListener, shared: Arc<Shared>, accepting: Accepting) {
    let listener = match tokio::net::TcpListener::from_std(listener) {
        Ok(l) => l,
        Err(e) => {
            accepting.stopped(format!("cannot listen: {e}"));
            return;
        }
    };
    let server = Server::new(listener);
    let clients = Arc::new(AtomicUsize::new(0));
    let patience = Patience {
        idle: shared.cfg.idle_timeout,
        send: shared.cfg.send_timeout,
    };
    let service = Scada(shared, None);
    let on_connected = |stream: tokio::net::TcpStream, peer: SocketAddr| {
        accepting.taken();
        let service = Scada(service.0.clone(), Some(peer));
        let clients = clients.clone();
        async move {
            let Some(slot) = ClientSlot::take(&clients, MAX_CLIENTS) else {
                limited!(
                    WARN,
                    REFUSED,
                    format!("from {}", peer.ip()),
                    "Modbus TCP: {peer} refused: {MAX_CLIENTS} clients connected"
                );
                return Ok(None);
            };
            // Small request/response frames: do not wait to coalesce them.
            drop(stream.set_nodelay(true));
            crate::service::socket::bound_buffers(&stream, SOCKET_BUFFER);
            tracing::debug!("Modbus TCP: {peer} connected");
            Ok(Some((service, FrameGuard::new(stream, slot, patience))))
        }
    };
    let on_process_error = |e: std::io::Error| tracing::debug!("Modbus TCP client: {e}");
    loop {
        // serve() returns only when accept() fails (e.g. out of file descriptors): wait a
        // little and listen again rather than leave SCADA without a server.
        if let Err(e) = server.serve(&on_connected, on_process_error).await {
            accepting.failed(&e);
            tokio::time::sleep(Duration::from_millis(100)).await;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::project::{ReadGaps, ScadaMap};
    use crate::service::modbus_map::tests::entry;
    use softplc_io::point::ValueType;

    fn setup(writes: bool) -> (ModbusTcpConfig, ModbusMap, ServiceSnapshot) {
        let cfg = ModbusTcpConfig {
            bind: "127.0.0.1:0".parse().unwrap(),
            unit: 1,
            writes,
            idle_timeout: Duration::from_secs(60),
            send_timeout: Duration::from_secs(10),
            read_gaps: ReadGaps::Exception,
        };
        let map = ModbusMap::new(&ScadaMap {
            entries: vec![
                entry(0, ValueType::Bool, 0, false),
                entry(1, ValueType::U16, 0, true),
            ],
        });
        let snapshot = ServiceSnapshot {
            published: true,
            values: vec![Value::Bool(true), Value::U16(9)],
            ..ServiceSnapshot::default()
        };
        (cfg, map, snapshot)
    }

    #[test]
    fn reads_come_from_the_snapshot() {
        let (cfg, map, s) = setup(false);
        let r = answer(&cfg, &map, &s, 1, &MbRequest::ReadDiscreteInputs(0, 1));
        assert_eq!(
            r,
            Ok(Answer::Now(MbResponse::ReadDiscreteInputs(vec![true])))
        );
        let r = answer(&cfg, &map, &s, 255, &MbRequest::ReadInputRegisters(0, 1));
        assert_eq!(r, Ok(Answer::Now(MbResponse::ReadInputRegisters(vec![9]))));
        let r = answer(
            &cfg,
            &map,
            &ServiceSnapshot::default(),
            1,
            &MbRequest::ReadCoils(0, 1),
        );
        assert_eq!(r, Err(Exception::ServerDeviceBusy));
    }

    #[test]
    fn units_writes_and_functions_are_checked() {
        let (cfg, map, s) = setup(false);
        let w = MbRequest::WriteSingleRegister(0, 5);
        assert_eq!(
            answer(&cfg, &map, &s, 2, &MbRequest::ReadCoils(0, 1)),
            Err(Exception::GatewayTargetFailed)
        );
        assert_eq!(
            answer(&cfg, &map, &s, 1, &w),
            Err(Exception::IllegalFunction)
        );
        let (cfg, map, s) = setup(true);
        assert_eq!(
            answer(&cfg, &map, &s, 1, &w),
            Ok(Answer::Write(
                vec![(1, Value::U16(5))],
                MbResponse::WriteSingleRegister(0, 5)
            ))
        );
        assert_eq!(
            answer(&cfg, &map, &s, 1, &MbRequest::WriteSingleCoil(0, true)),
            Err(Exception::IllegalDataAddress)
        );
        assert_eq!(
            answer(&cfg, &map, &s, 1, &MbRequest::ReportServerId),
            Err(Exception::IllegalFunction)
        );
    }

    /// One request/response exchange on `stream`.
    fn exchange(stream: &mut std::net::TcpStream, frame: &[u8]) -> Vec<u8> {
        use std::io::{Read, Write};
        stream.write_all(frame).unwrap();
        let mut head = [0u8; 7];
        stream.read_exact(&mut head).unwrap();
        let len = usize::from(u16::from_be_bytes([head[4], head[5]])) - 1;
        let mut pdu = vec![0u8; len];
        stream.read_exact(&mut pdu).unwrap();
        pdu
    }

    #[test]
    fn serves_reads_and_writes_and_survives_malformed_frames() {
        use std::io::Read;
        let (cfg, map, s) = setup(true);
        let cell = SnapshotCell::new();
        cell.set(s);
        let (tx, rx) = crossbeam_channel::bounded::<Envelope>(4);
        // A stand-in scan: applies a write by publishing a later cycle with the value.
        let scan_cell = cell.clone();
        std::thread::spawn(move || {
            for env in rx {
                let mut snap = scan_cell.get();
                if let Request::Write { values } = &env.request {
                    assert_eq!(values[0].tag, "speed");
                    snap.values[1] = Value::U16(values[0].value.parse().unwrap());
                }
                snap.cycles += 1;
                scan_cell.set(snap);
                // The test's client may have given up; nothing to tell then.
                drop(env.reply.send(super::super::control::Response::done("ok")));
            }
        });
        let names = vec!["run".to_string(), "speed".to_string()];
        let health = crate::service::Health::new();
        let accepting = Accepting::new(&health, crate::service::Service::ModbusTcp);
        let server = ModbusTcpServer::start(cfg, map, names, cell, tx, accepting).unwrap();
        let connect = || {
            let c = std::net::TcpStream::connect(server.local_addr()).unwrap();
            c.set_read_timeout(Some(Duration::from_secs(5))).unwrap();
            c
        };
        let mut c = connect();
        let read = [0, 1, 0, 0, 0, 6, 1, 0x04, 0, 0, 0, 1];
        assert_eq!(exchange(&mut c, &read), [0x04, 2, 0, 9]);
        let write = [0, 2, 0, 0, 0, 6, 1, 0x06, 0, 0, 0x01, 0x2C];
        assert_eq!(exchange(&mut c, &write), [0x06, 0, 0, 0x01, 0x2C]);
        assert_eq!(exchange(&mut c, &read), [0x04, 2, 0x01, 0x2C]);
        // Read-only bit: exception 02.
        let coil = [0, 3, 0, 0, 0, 6, 1, 0x05, 0, 0, 0xFF, 0x00];
        assert_eq!(exchange(&mut c, &coil), [0x85, 0x02]);
        // FC 15 announcing 100 coils in one byte: the connection is closed, nothing panics.
        let bad = [0, 4, 0, 0, 0, 8, 1, 0x0F, 0, 0, 0, 100, 1, 0xFF];
        std::io::Write::write_all(&mut c, &bad).unwrap();
        let mut rest = Vec::new();
        // A reset counts as closed, as an end of file does; `rest` must be empty either way.
        drop(c.read_to_end(&mut rest));
        assert!(rest.is_empty(), "{rest:?}");
        // And the server still serves.
        assert_eq!(exchange(&mut connect(), &read), [0x04, 2, 0x01, 0x2C]);
    }
}
