//! The local control interface of a running instance: a Unix socket (mode 0660, in a 0700
//! folder unless systemd's RuntimeDirectory= provides one), one JSON request per line, one JSON
//! response per line. Local only by construction: nothing listens on a network.
//!
//! ```text
//! {"cmd":"status"}
//! {"cmd":"force","tag":"motor","value":"1"}
//! {"cmd":"unforce","tag":"motor"}        {"cmd":"unforce"}   (every tag)
//! {"cmd":"reload"}   {"cmd":"reload","task":"slow"}   (one task of several)
//! {"cmd":"write","values":[{"tag":"speed","value":"42"}]}   (all at one cycle boundary; with
//!                                 several tasks, each task's tags at its own: see task_router)
//! {"cmd":"alarms","action":"list","history":20}   {"cmd":"alarms","action":"ack","alarm":"jam"}
//!                                                 ("all": every alarm waiting)
//! {"cmd":"trace","action":"arm","name":"jam"}   (and status, save, read, disarm: see
//!                                                 crate::service::trace)
//! ```
//!
//! The socket thread only parses and forwards: the scan thread applies each request at a
//! cycle boundary and answers, so a request never races a scan.

use crate::log_limit::{limited, Site};
use crate::service::slots::{Caps, Evict, Held, Slots};
use std::io::{BufRead, BufReader, Read, Write};
use std::os::unix::fs::PermissionsExt;
use std::os::unix::net::{UnixListener, UnixStream};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use crossbeam_channel::{Receiver, Sender};
use serde::{Deserialize, Serialize};

use crate::service::status::StatusReport;

/// A request.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "cmd", rename_all = "lowercase", deny_unknown_fields)]
pub enum Request {
    /// The instance's status.
    Status,
    /// Force a tag to a value until unforced (or the instance restarts).
    Force {
        /// The tag.
        tag: String,
        /// The value, as text (`1`, `true`, `42`, `0x10`, `1.5`).
        value: String,
    },
    /// Remove a tag's force, or every force when `tag` is absent.
    Unforce {
        /// The tag; absent: all.
        #[serde(default)]
        tag: Option<String>,
    },
    /// Re-read the program and swap it in at the next cycle boundary if it passes `check`;
    /// with several tasks, every task's whose files changed, each at its own boundary.
    Reload {
        /// Only this task's program.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        task: Option<String>,
    },
    /// Set tags at the next cycle boundary, all at once (the SCADA server's writes): like an
    /// assignment, so the program may overwrite them in its next scan; a forced tag refuses.
    Write {
        /// The tags and their values.
        values: Vec<TagValue>,
    },
    /// Arm a trace, ask for its state or its samples (see `crate::service::trace`).
    Trace(crate::service::trace::TraceRequest),
    /// The alarms: their list, or an acknowledgement (see `crate::service::alarms`).
    Alarms(crate::service::alarms::AlarmRequest),
}

/// A tag and a value, as text (parsed as the tag's type).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TagValue {
    /// The tag.
    pub tag: String,
    /// The value (`1`, `true`, `42`, `0x10`, `1.5`).
    pub value: String,
}

/// A response.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct Response {
    /// Whether the request was carried out.
    pub ok: bool,
    /// What was done, for people.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub message: Option<String>,
    /// Why not.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
    /// The status, for `status`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub status: Option<StatusReport>,
    /// The traces' states, for `trace status` and `trace arm`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub traces: Option<Vec<crate::trace::TraceStatus>>,
    /// A trace's samples, for `trace save` and `trace read`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trace: Option<crate::trace::TraceData>,
    /// For `write`: the cycle boundary it was applied at (the scan's count of completed
    /// cycles then), the first whose published values hold it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub applied_at: Option<u64>,
    /// For `write`: refused because a tag is forced (the force wins until it is removed), so a
    /// protocol that has a word for it says so (OPC UA's `BadLocked`) whenever the force came,
    /// even after the snapshot the service last saw.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub locked: bool,
    /// For `alarms list`: the current list, the counts and the latest events.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub alarms: Option<crate::service::alarms::AlarmList>,
    /// For a request a PLC of several tasks split between them (a write naming tags of
    /// several tasks, `unforce` of every tag, `reload`): each task's answer, in task order.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub parts: Option<Vec<TaskPart>>,
}

/// One task's answer to its part of a request split between tasks.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
pub struct TaskPart {
    /// The task.
    pub task: String,
    /// Its answer (for a write, `applied_at` counts the task's own cycles).
    #[serde(flatten)]
    pub answer: Response,
}

impl Response {
    /// A success with a message.
    pub fn done(message: impl Into<String>) -> Self {
        Self {
            ok: true,
            message: Some(message.into()),
            ..Self::default()
        }
    }

    /// A refusal.
    pub fn refused(error: impl Into<String>) -> Self {
        Self {
            ok: false,
            error: Some(error.into()),
            ..Self::default()
        }
    }
}

/// A request on its way to the scan thread, with the way back.
#[derive(Debug)]
pub struct Envelope {
    /// The request.
    pub request: Request,
    /// Where the scan sends the response.
    pub reply: Sender<Response>,
    /// After this the client has been told the request failed: the scan must not carry it out.
    pub expires: std::time::Instant,
    /// Who asked, for the audit file.
    pub origin: crate::service::audit::Origin,
}

impl Envelope {
    /// A request from `origin` whose client waits at most `answer_within` for it.
    pub fn new(
        request: Request,
        reply: Sender<Response>,
        answer_within: Duration,
        origin: crate::service::audit::Origin,
    ) -> Self {
        Self {
            request,
            reply,
            expires: std::time::Instant::now() + answer_within,
            origin,
        }
    }

    /// Whether the client has given up on it.
    pub fn expired(&self) -> bool {
        std::time::Instant::now() >= self.expires
    }
}

/// Longest request line accepted; a longer one is refused, not buffered.
const MAX_LINE: u64 = 64 * 1024;
/// How long a client waits for the scan to answer.
const SCAN_ANSWER: Duration = Duration::from_secs(5);

/// Parses one request line.
pub fn parse_request(line: &str) -> Result<Request, String> {
    serde_json::from_str(line.trim()).map_err(|e| format!("bad request: {e}"))
}

/// Where an instance of `project` puts its socket: `$SOFTPLC_RUNTIME_DIR`, systemd's
/// `$RUNTIME_DIRECTORY`, `$XDG_RUNTIME_DIR/softplc`, or `/tmp/softplc-UID`.
pub fn default_socket_path(project: &str) -> PathBuf {
    let dir = std::env::var_os("SOFTPLC_RUNTIME_DIR")
        .or_else(|| std::env::var_os("RUNTIME_DIRECTORY"))
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("XDG_RUNTIME_DIR").map(|d| PathBuf::from(d).join("softplc")))
        .unwrap_or_else(|| PathBuf::from(format!("/tmp/softplc-{}", current_uid())));
    dir.join(format!("{project}.sock"))
}

/// The real user id of this process: it names the fallback socket folder and is the owner
/// that folder must have.
#[allow(unsafe_code)]
fn current_uid() -> u32 {
    // SAFETY: getuid has no preconditions and cannot fail.
    unsafe { libc::getuid() }
}

/// Refuses a socket folder another user owns or may write to: whoever can write there can put
/// their own socket in its place (a folder under /tmp may have been made by anyone first).
fn check_folder(dir: &Path) -> std::io::Result<()> {
    use std::os::unix::fs::MetadataExt;
    let meta = std::fs::symlink_metadata(dir)?;
    let me = current_uid();
    let others_write = meta.mode() & 0o022 != 0;
    if !meta.is_dir()
        || (meta.uid() != me && meta.uid() != 0)
        || (others_write && meta.mode() & 0o1000 == 0)
    {
        return Err(std::io::Error::new(
            std::io::ErrorKind::PermissionDenied,
            format!(
                "{} is not a private folder of this user (owner {}, mode {:o}); remove it or pass --socket",
                dir.display(),
                meta.uid(),
                meta.mode() & 0o7777
            ),
        ));
    }
    Ok(())
}

/// Control-socket clients at once (a thread each); past it the one waiting longest for its
/// next request gives way, so 2,000 idle connections hold 32 threads and `softplc status`
/// still gets through.
const CONTROL_CAPS: Caps = Caps {
    clients: 32,
    streams: 0,
};
/// How long a control client may stay silent before its connection is closed.
const CONTROL_IDLE: Duration = Duration::from_secs(60);

/// A log site a flood of connections repeats (see [`crate::log_limit`]).
const CANNOT_SERVE: Site = Site::new("control.cannot_serve", "control socket: clients not served");
const CANNOT_ACCEPT: Site = Site::new("control.cannot_accept", "control socket: failed accepts");

/// The listening side; dropping it removes the socket file.
#[derive(Debug)]
pub struct ControlServer {
    path: PathBuf,
}

impl ControlServer {
    /// Binds `path` and serves it on a thread, forwarding requests to `scan`.
    pub fn start(path: &Path, scan: Sender<Envelope>) -> std::io::Result<Self> {
        // A bare file name (`--socket ctl.sock`) has the empty path as its parent, which no
        // folder call accepts: it is the working folder.
        let dir = match path.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir,
            _ => Path::new("."),
        };
        if !dir.exists() {
            std::fs::create_dir_all(dir)?;
            std::fs::set_permissions(dir, std::fs::Permissions::from_mode(0o700))?;
        }
        check_folder(dir)?;
        if path.exists() {
            if UnixStream::connect(path).is_ok() {
                return Err(std::io::Error::new(
                    std::io::ErrorKind::AddrInUse,
                    // The caller names the socket; the cause is said once.
                    "in use: another instance is running",
                ));
            }
            // A socket left by an instance that died: nobody answers it.
            std::fs::remove_file(path)?;
        }
        let listener = UnixListener::bind(path)?;
        std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o660))?;
        std::thread::Builder::new()
            .name("control".into())
            .spawn(move || {
                let slots = Slots::new(CONTROL_CAPS);
                for stream in listener.incoming() {
                    let stream = match stream {
                        Ok(stream) => stream,
                        Err(e) => {
                            // Out of file descriptors and the like: said, and retried
                            // without spinning on a core.
                            limited!(
                                ERROR,
                                CANNOT_ACCEPT,
                                e.to_string(),
                                "control socket: cannot accept a client: {e}; retrying"
                            );
                            std::thread::sleep(Duration::from_millis(10));
                            continue;
                        }
                    };
                    let evict = || -> Evict {
                        let handle = stream.try_clone();
                        Box::new(move || {
                            if let Ok(s) = &handle {
                                // Best effort: the client may be gone already.
                                drop(s.shutdown(std::net::Shutdown::Both));
                            }
                        })
                    };
                    let Some(held) = slots.admit_patiently(evict) else {
                        refuse_busy(stream);
                        continue;
                    };
                    let scan = scan.clone();
                    // Out of threads: this client's connection closes unanswered, and
                    // whoever runs the PLC should learn why `softplc control` saw nothing.
                    if let Err(e) = std::thread::Builder::new()
                        .name("control-client".into())
                        .spawn(move || serve_client(stream, &scan, &held))
                    {
                        limited!(
                            WARN,
                            CANNOT_SERVE,
                            e.to_string(),
                            "control socket: cannot serve a client: {e}"
                        );
                    }
                }
            })?;
        Ok(Self {
            path: path.to_path_buf(),
        })
    }

    /// The socket's path.
    pub fn path(&self) -> &Path {
        &self.path
    }
}

impl Drop for ControlServer {
    fn drop(&mut self) {
        // Best effort: a socket file already gone (removed by hand, or the folder) is the goal.
        drop(std::fs::remove_file(&self.path));
    }
}

/// Tells a client that every slot is being served, without waiting on it.
fn refuse_busy(mut stream: UnixStream) {
    // Best effort: the answer is for a client that may not read it.
    drop(stream.set_nonblocking(true));
    drop(write_response(
        &mut stream,
        &Response::refused(format!(
            "{} control clients are being served; try again",
            CONTROL_CAPS.clients
        )),
    ));
}

fn serve_client(stream: UnixStream, scan: &Sender<Envelope>, held: &Held) {
    // A client that says nothing for this long gives its thread back.
    drop(stream.set_read_timeout(Some(CONTROL_IDLE)));
    drop(stream.set_write_timeout(Some(CONTROL_IDLE)));
    let Ok(mut out) = stream.try_clone() else {
        return;
    };
    let mut reader = BufReader::new(stream.take(u64::MAX));
    loop {
        let mut line = String::new();
        let n = match (&mut reader).take(MAX_LINE).read_line(&mut line) {
            Ok(n) => n,
            Err(_) => return,
        };
        if n == 0 {
            return;
        }
        let response = if !line.ends_with('\n') && n as u64 >= MAX_LINE {
            // The client is dropped either way; a failed write only means it left first.
            drop(write_response(
                &mut out,
                &Response::refused("request longer than 64 KiB"),
            ));
            return;
        } else if line.trim().is_empty() {
            continue;
        } else {
            held.busy();
            match parse_request(&line) {
                Ok(request) => forward(scan, request),
                Err(e) => Response::refused(e),
            }
        };
        if write_response(&mut out, &response).is_err() {
            return;
        }
        held.waiting(Instant::now());
    }
}

fn forward(scan: &Sender<Envelope>, request: Request) -> Response {
    let (reply, answer): (Sender<Response>, Receiver<Response>) = crossbeam_channel::bounded(1);
    if scan
        .send_timeout(
            Envelope::new(
                request,
                reply,
                SCAN_ANSWER,
                crate::service::audit::Origin::Cli,
            ),
            SCAN_ANSWER,
        )
        .is_err()
    {
        return Response::refused("the scan has stopped, or is not taking requests");
    }
    answer
        .recv_timeout(SCAN_ANSWER)
        .unwrap_or_else(|_| Response::refused("the scan did not answer within 5 s"))
}

fn write_response(out: &mut UnixStream, response: &Response) -> std::io::Result<()> {
    let mut text = serde_json::to_string(response).map_err(std::io::Error::other)?;
    text.push('\n');
    out.write_all(text.as_bytes())
}

/// Sends one request to the instance listening at `path` and waits for its response.
pub fn request(path: &Path, request: &Request) -> std::io::Result<Response> {
    let mut stream = UnixStream::connect(path).map_err(|e| {
        std::io::Error::new(
            e.kind(),
            format!("cannot reach a running instance at {}: {e}", path.display()),
        )
    })?;
    stream.set_read_timeout(Some(SCAN_ANSWER + Duration::from_secs(1)))?;
    let mut text = serde_json::to_string(request).map_err(std::io::Error::other)?;
    text.push('\n');
    stream.write_all(text.as_bytes())?;
    let mut line = String::new();
    BufReader::new(stream).read_line(&mut line)?;
    serde_json::from_str(&line).map_err(|e| std::io::Error::other(format!("bad response: {e}")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_request_form() {
        assert_eq!(parse_request(r#"{"cmd":"status"}"#), Ok(Request::Status));
        assert_eq!(
            parse_request(r#"{"cmd":"force","tag":"motor","value":"1"}"#),
            Ok(Request::Force {
                tag: "motor".into(),
                value: "1".into()
            })
        );
        assert_eq!(
            parse_request(r#"{"cmd":"unforce"}"#),
            Ok(Request::Unforce { tag: None })
        );
        assert_eq!(
            parse_request(r#"{"cmd":"reload"}"#),
            Ok(Request::Reload { task: None })
        );
        assert_eq!(
            parse_request(r#"{"cmd":"reload","task":"slow"}"#),
            Ok(Request::Reload {
                task: Some("slow".into())
            })
        );
        assert_eq!(
            parse_request(r#"{"cmd":"write","values":[{"tag":"speed","value":"42"}]}"#),
            Ok(Request::Write {
                values: vec![TagValue {
                    tag: "speed".into(),
                    value: "42".into()
                }]
            })
        );
        assert!(parse_request(r#"{"cmd":"format-disk"}"#).is_err());
        // A misspelt field must not turn "unforce motor" into "unforce everything".
        assert!(parse_request(r#"{"cmd":"unforce","tagg":"motor"}"#).is_err());
        assert!(parse_request("not json").is_err());
    }

    #[test]
    fn a_client_talks_to_the_server_through_the_socket() {
        let dir = std::env::temp_dir().join(format!("softplc-ctl-{}", std::process::id()));
        let path = dir.join("t.sock");
        let (tx, rx) = crossbeam_channel::unbounded::<Envelope>();
        let server = ControlServer::start(&path, tx).unwrap();
        std::thread::spawn(move || {
            for env in rx {
                // The test's client may have given up; nothing to tell then.
                drop(env.reply.send(Response::done(format!("{:?}", env.request))));
            }
        });
        let r = request(server.path(), &Request::Reload { task: None }).unwrap();
        assert_eq!(r, Response::done("Reload { task: None }"));
        let mode = std::fs::metadata(server.path())
            .unwrap()
            .permissions()
            .mode()
            & 0o777;
        assert_eq!(mode, 0o660);
        assert!(
            ControlServer::start(&path, crossbeam_channel::unbounded().0).is_err(),
            "in use"
        );
        drop(server);
        assert!(!path.exists());
        // Best effort: the test's scratch folder.
        drop(std::fs::remove_dir_all(dir));
    }
}
