//! The Prometheus text endpoint: `GET /metrics` on the small std HTTP server the web page
//! uses too ([`super::web::http`]: a thread per connection, at most [`LIMITS`]`.clients` at
//! once, 5 s to send a request, so slow or silent clients never delay a scrape), rendering the
//! snapshot the scan publishes ([`super::snapshot`]). It never touches the scan.
//!
//! Metrics (text exposition format 0.0.4):
//!
//! | name | type | what |
//! |---|---|---|
//! | `softplc_info{project}` | gauge | always 1 |
//! | `softplc_scan_period_seconds` | gauge | the configured period |
//! | `softplc_scans_total`, `softplc_overruns_total` | counter | completed cycles, skipped deadlines |
//! | `softplc_{cycle,read,logic,write,boundary,lateness}_seconds` | summary | quantiles 0.5, 0.99, 0.999, `_sum`, `_count` |
//! | `softplc_phase_max_seconds{phase}` | gauge | the longest sample of each phase |
//! | `softplc_module_{requests,timeouts,crc_errors,bad_replies,exceptions,echo_errors}_total{module,bus}` | counter | bus counters |
//! | `softplc_module_quality{module,bus}` | gauge | 0 good, 1 stale, 2 bad |
//! | `softplc_module_round_trip_seconds{module,bus}` | gauge | last good transaction |
//! | `softplc_tag_value{tag}` | gauge | value (bools 0/1) |
//! | `softplc_tag_quality{tag}` | gauge | 0 good, 1 stale, 2 bad |
//! | `softplc_tag_forced{tag}` | gauge | 1 when forced |
//! | `softplc_service_lost_changes_total{service}` | counter | changes a service (opcua, mqtt, alarms) could not take in time (`super::changes`) |
//! | `softplc_alarms_active{priority}` | gauge | active alarms per priority band: low, medium, high, urgent |
//! | `softplc_alarms_unacknowledged` | gauge | alarms waiting for an acknowledgement (active or gone) |
//! | `softplc_task_period_seconds{task}` | gauge | with `tasks:`, each task's period |
//! | `softplc_task_scans_total{task}`, `softplc_task_overruns_total{task}` | counter | each task's completed cycles, skipped deadlines |
//! | `softplc_task_cycle_{p50,p99,max}_seconds{task}` | gauge | each task's cycle time |
//! | `softplc_task_lateness_{p99,max}_seconds{task}` | gauge | each task's wake-up lateness |
//!
//! Statistics are refreshed every 250 ms of scan time, tag values every cycle.

use crate::service::accepting::Accepting;
use crate::service::health::{Health, Service};
use std::fmt::Write as _;
use std::io::Write;
use std::net::{SocketAddr, TcpListener};
use std::time::Duration;

use softplc_io::line::Counters;
use softplc_io::point::{Quality, Value};

use super::snapshot::{Phase, ServiceSnapshot, SnapshotCell};
use super::web::http::{self, Limits, Method, Request, Response, ServerConfig};

/// The endpoint's bounds: as the web page's.
pub(crate) const LIMITS: Limits = Limits {
    clients: 16,
    request: Duration::from_secs(5),
    write: Duration::from_secs(5),
    streams: 0,
};

/// The names the metrics carry; fixed for the life of the process.
#[derive(Debug, Clone, Default)]
pub(crate) struct MetricsInfo {
    /// Project name.
    pub project: String,
    /// Scan period.
    pub period: Duration,
    /// Tag names, in tag order.
    pub tags: Vec<String>,
    /// Modules: (name, bus), in project order.
    pub modules: Vec<(String, String)>,
    /// The services' states.
    pub health: Health,
    /// The alarms, when they run.
    pub alarms: Option<super::alarms::Alarms>,
}

/// How this endpoint reads a request: the shared parser, [`http::parse`]. Kept under this name
/// for the fuzz test that already calls it.
pub fn parse_head(bytes: &[u8]) -> Result<Option<Request>, http::HttpError> {
    http::parse(bytes)
}

/// The answer to `req`: the exposition at `/metrics`, a pointer to it at `/`.
pub(crate) fn respond(info: &MetricsInfo, snapshot: &SnapshotCell, req: &Request) -> Response {
    let readable = matches!(req.method, Method::Get | Method::Head);
    match req.path.as_str() {
        "/metrics" if readable => Response::new(
            200,
            "text/plain; version=0.0.4; charset=utf-8",
            render(info, &snapshot.get()),
        ),
        "/" if readable => Response::new(
            200,
            "text/plain; charset=utf-8",
            format!("softplc {}: metrics at /metrics\n", info.project),
        ),
        "/metrics" | "/" => Response::error(405, "GET or HEAD").with("Allow", "GET, HEAD"),
        _ => Response::error(404, "no such page; the metrics are at /metrics"),
    }
}

/// A float as the exposition format writes it.
fn num(x: f64) -> String {
    if x.is_nan() {
        "NaN".into()
    } else if x.is_infinite() {
        if x > 0.0 { "+Inf" } else { "-Inf" }.into()
    } else {
        format!("{x}")
    }
}

/// A label value, escaped (`\`, `"`, newline).
fn label(v: &str) -> String {
    v.replace('\\', r"\\")
        .replace('"', r#"\""#)
        .replace('\n', r"\n")
}

fn quality_code(q: Quality) -> u8 {
    match q {
        Quality::Good => 0,
        Quality::Stale => 1,
        Quality::Bad => 2,
    }
}

fn value_number(v: Value) -> f64 {
    match v {
        Value::Bool(b) => f64::from(u8::from(b)),
        Value::U16(x) => f64::from(x),
        Value::I32(x) => f64::from(x),
        Value::F32(x) => f64::from(x),
    }
}

fn family(out: &mut String, name: &str, kind: &str, help: &str) {
    let _ = writeln!(out, "# HELP {name} {help}");
    let _ = writeln!(out, "# TYPE {name} {kind}");
}

/// Each task's figures (a PLC of several tasks; none for one task, whose figures are the
/// unlabelled families).
fn tasks(out: &mut String, tasks: &[super::status::TaskReport]) {
    if tasks.is_empty() {
        return;
    }
    let us = |v: u64| v as f64 / 1e6;
    type Figure = fn(&super::status::TaskReport) -> u64;
    let families: [(&str, &str, &str, Figure, bool); 8] = [
        (
            "softplc_task_period_seconds",
            "gauge",
            "The task's period.",
            |t| t.period_us,
            true,
        ),
        (
            "softplc_task_scans_total",
            "counter",
            "The task's completed cycles.",
            |t| t.scans,
            false,
        ),
        (
            "softplc_task_overruns_total",
            "counter",
            "The task's skipped deadlines.",
            |t| t.overruns,
            false,
        ),
        (
            "softplc_task_cycle_p50_seconds",
            "gauge",
            "The task's median cycle time.",
            |t| t.cycle.p50_us,
            true,
        ),
        (
            "softplc_task_cycle_p99_seconds",
            "gauge",
            "The task's 99th percentile cycle time.",
            |t| t.cycle.p99_us,
            true,
        ),
        (
            "softplc_task_cycle_max_seconds",
            "gauge",
            "The task's longest cycle.",
            |t| t.cycle.max_us,
            true,
        ),
        (
            "softplc_task_lateness_p99_seconds",
            "gauge",
            "The task's 99th percentile wake-up lateness.",
            |t| t.lateness.p99_us,
            true,
        ),
        (
            "softplc_task_lateness_max_seconds",
            "gauge",
            "The task's largest wake-up lateness.",
            |t| t.lateness.max_us,
            true,
        ),
    ];
    for (name, kind, help, figure, micros) in families {
        family(out, name, kind, help);
        for t in tasks {
            let v = figure(t);
            let task = label(&t.name);
            let _ = match micros {
                true => writeln!(out, "{name}{{task=\"{task}\"}} {}", us(v)),
                false => writeln!(out, "{name}{{task=\"{task}\"}} {v}"),
            };
        }
    }
}

/// Every service's state, one series per state word with 1 on the service's own (the
/// reason is in `softplc status` and the log).
fn services(out: &mut String, health: &Health) {
    family(
        out,
        "softplc_service_state",
        "gauge",
        "1 on the service's state: off (not configured), running, degraded or stopped.",
    );
    for r in health.report() {
        for word in ["off", "running", "degraded", "stopped"] {
            let _ = writeln!(
                out,
                "softplc_service_state{{service=\"{}\",state=\"{word}\"}} {}",
                r.service.name(),
                u8::from(r.state.word() == word)
            );
        }
    }
}

/// The alarms' figures.
fn alarms(out: &mut String, c: &super::alarms::AlarmCounts) {
    family(
        out,
        "softplc_alarms_active",
        "gauge",
        "Active alarms per priority band (low 1-250, medium 251-500, high 501-750, urgent 751-1000).",
    );
    for ((level, _), n) in crate::project::Priority::LEVELS.iter().zip(c.active) {
        let _ = writeln!(out, "softplc_alarms_active{{priority=\"{level}\"}} {n}");
    }
    family(
        out,
        "softplc_alarms_unacknowledged",
        "gauge",
        "Alarms waiting for an acknowledgement, active or gone.",
    );
    let _ = writeln!(out, "softplc_alarms_unacknowledged {}", c.unacknowledged);
}

/// The exposition text for `snapshot`.
pub(crate) fn render(info: &MetricsInfo, s: &ServiceSnapshot) -> String {
    let mut out = String::with_capacity(4096 + 160 * info.tags.len());
    services(&mut out, &info.health);
    family(&mut out, "softplc_info", "gauge", "The running project.");
    let _ = writeln!(
        out,
        "softplc_info{{project=\"{}\"}} 1",
        label(&info.project)
    );
    family(
        &mut out,
        "softplc_scan_period_seconds",
        "gauge",
        "The configured scan period.",
    );
    let _ = writeln!(
        out,
        "softplc_scan_period_seconds {}",
        num(info.period.as_secs_f64())
    );
    family(
        &mut out,
        "softplc_scans_total",
        "counter",
        "Completed scan cycles.",
    );
    let _ = writeln!(out, "softplc_scans_total {}", s.cycles);
    family(
        &mut out,
        "softplc_overruns_total",
        "counter",
        "Deadlines skipped because a cycle ran past them.",
    );
    let _ = writeln!(out, "softplc_overruns_total {}", s.overruns);

    for (phase, p) in Phase::ALL.iter().zip(&s.phases) {
        let name = format!("softplc_{}_seconds", phase.name());
        family(
            &mut out,
            &name,
            "summary",
            &format!("Duration of the scan's {} phase.", phase.name()),
        );
        for (q, d) in [("0.5", p.p50), ("0.99", p.p99), ("0.999", p.p999)] {
            let _ = writeln!(out, "{name}{{quantile=\"{q}\"}} {}", num(d.as_secs_f64()));
        }
        let _ = writeln!(out, "{name}_sum {}", num(p.sum.as_secs_f64()));
        let _ = writeln!(out, "{name}_count {}", p.count);
    }
    family(
        &mut out,
        "softplc_phase_max_seconds",
        "gauge",
        "The longest sample of each scan phase.",
    );
    for (phase, p) in Phase::ALL.iter().zip(&s.phases) {
        let _ = writeln!(
            out,
            "softplc_phase_max_seconds{{phase=\"{}\"}} {}",
            phase.name(),
            num(p.max.as_secs_f64())
        );
    }

    type Counter = fn(&Counters) -> u64;
    let counters: [(&str, &str, Counter); 6] = [
        ("requests", "Requests sent, retries included.", |c| {
            c.requests
        }),
        ("timeouts", "Requests with no reply in time.", |c| {
            c.timeouts
        }),
        ("crc_errors", "Replies with a bad CRC.", |c| c.crc_errors),
        ("bad_replies", "Replies that were not the answer.", |c| {
            c.bad_replies
        }),
        (
            "exceptions",
            "Exception replies (the device said no).",
            |c| c.exceptions,
        ),
        (
            "echo_errors",
            "Requests whose echo was wrong or missing, or came back as the reply.",
            |c| c.echo_errors,
        ),
    ];
    let module = |i: usize| s.modules.get(i).copied().unwrap_or_default();
    let labels = |(name, bus): &(String, String)| {
        format!("module=\"{}\",bus=\"{}\"", label(name), label(bus))
    };
    for (key, help, get) in counters {
        let name = format!("softplc_module_{key}_total");
        family(&mut out, &name, "counter", help);
        for (i, m) in info.modules.iter().enumerate() {
            let _ = writeln!(out, "{name}{{{}}} {}", labels(m), get(&module(i).counters));
        }
    }
    family(
        &mut out,
        "softplc_module_quality",
        "gauge",
        "Quality of the module's last read: 0 good, 1 stale, 2 bad.",
    );
    for (i, m) in info.modules.iter().enumerate() {
        let q = quality_code(module(i).quality);
        let _ = writeln!(out, "softplc_module_quality{{{}}} {q}", labels(m));
    }
    family(
        &mut out,
        "softplc_module_round_trip_seconds",
        "gauge",
        "Round trip of the module's last good transaction.",
    );
    for (i, m) in info.modules.iter().enumerate() {
        let rt = module(i).counters.last_round_trip.as_secs_f64();
        let _ = writeln!(
            out,
            "softplc_module_round_trip_seconds{{{}}} {}",
            labels(m),
            num(rt)
        );
    }

    type TagGauge = fn(&ServiceSnapshot, usize) -> Option<f64>;
    let tag_gauges: [(&str, &str, TagGauge); 3] = [
        ("value", "The tag's value (bools 0/1).", |s, i| {
            s.values.get(i).map(|v| value_number(*v))
        }),
        (
            "quality",
            "The tag's quality: 0 good, 1 stale, 2 bad.",
            |s, i| s.qualities.get(i).map(|q| f64::from(quality_code(*q))),
        ),
        ("forced", "1 when the tag is forced.", |s, i| {
            s.forced.get(i).map(|f| f64::from(u8::from(*f)))
        }),
    ];
    for (key, help, get) in tag_gauges {
        let name = format!("softplc_tag_{key}");
        family(&mut out, &name, "gauge", help);
        for (i, tag) in info.tags.iter().enumerate() {
            if let Some(x) = get(s, i) {
                let _ = writeln!(out, "{name}{{tag=\"{}\"}} {}", label(tag), num(x));
            }
        }
    }
    if let Some(a) = &info.alarms {
        alarms(&mut out, &a.counts());
    }
    if !s.lost_changes.is_empty() {
        family(
            &mut out,
            "softplc_service_lost_changes_total",
            "counter",
            "Tag changes a service could not take in time (it fell behind the scan).",
        );
        for (service, lost) in &s.lost_changes {
            let _ = writeln!(
                out,
                "softplc_service_lost_changes_total{{service=\"{service}\"}} {lost}"
            );
        }
    }
    tasks(&mut out, &s.tasks);
    out
}

/// A running endpoint; it lives as long as the process.
#[derive(Debug)]
pub(crate) struct MetricsServer {
    addr: SocketAddr,
}

impl MetricsServer {
    /// Binds `addr` and serves on threads.
    pub(crate) fn start(
        addr: SocketAddr,
        info: MetricsInfo,
        snapshot: SnapshotCell,
    ) -> std::io::Result<Self> {
        let listener = TcpListener::bind(addr)?;
        let addr = listener.local_addr()?;
        let config = ServerConfig {
            name: "metrics",
            limits: LIMITS,
            allow: "GET, HEAD",
        };
        let accepting = Accepting::new(&info.health, Service::Metrics);
        http::spawn(listener, config, accepting, move |req, stream, _| {
            let response = respond(&info, &snapshot, req);
            stream.write_all(&response.to_bytes(req.method != Method::Head))
        })?;
        Ok(Self { addr })
    }

    /// The address it listens on (the bound port when the configured one was 0).
    pub(crate) fn local_addr(&self) -> SocketAddr {
        self.addr
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::service::snapshot::{ModuleSnapshot, PhaseSummary};

    fn sample() -> (MetricsInfo, ServiceSnapshot) {
        let info = MetricsInfo {
            project: "demo".into(),
            period: Duration::from_millis(100),
            tags: vec!["motor".into(), "level".into(), "we\"ird".into()],
            modules: vec![("mm1".into(), "line1".into())],
            health: Health::new(),
            alarms: None,
        };
        let mut s = ServiceSnapshot {
            published: true,
            cycles: 42,
            overruns: 1,
            values: vec![Value::Bool(true), Value::F32(f32::NAN), Value::I32(-5)],
            qualities: vec![Quality::Good, Quality::Stale, Quality::Bad],
            forced: vec![true, false, false],
            modules: vec![ModuleSnapshot {
                quality: Quality::Good,
                ..ModuleSnapshot::default()
            }],
            lost_changes: vec![("opcua", 0), ("mqtt", 17)],
            ..ServiceSnapshot::default()
        };
        s.modules[0].counters.requests = 114;
        s.phases[0] = PhaseSummary {
            count: 42,
            sum: Duration::from_millis(420),
            p50: Duration::from_millis(10),
            p99: Duration::from_millis(20),
            p999: Duration::from_millis(30),
            max: Duration::from_millis(31),
        };
        (info, s)
    }

    #[test]
    fn renders_the_exposition_format() {
        let (info, s) = sample();
        info.health.set(
            crate::service::health::Service::Recorder,
            crate::service::health::ServiceState::Degraded("disk full".into()),
        );
        let text = render(&info, &s);
        for line in [
            "softplc_info{project=\"demo\"} 1",
            "softplc_scan_period_seconds 0.1",
            "# TYPE softplc_scans_total counter",
            "softplc_scans_total 42",
            "softplc_overruns_total 1",
            "# TYPE softplc_cycle_seconds summary",
            "softplc_cycle_seconds{quantile=\"0.5\"} 0.01",
            "softplc_cycle_seconds{quantile=\"0.999\"} 0.03",
            "softplc_cycle_seconds_sum 0.42",
            "softplc_cycle_seconds_count 42",
            "softplc_lateness_seconds_count 0",
            "softplc_phase_max_seconds{phase=\"cycle\"} 0.031",
            "softplc_module_requests_total{module=\"mm1\",bus=\"line1\"} 114",
            "softplc_module_crc_errors_total{module=\"mm1\",bus=\"line1\"} 0",
            "softplc_module_quality{module=\"mm1\",bus=\"line1\"} 0",
            "softplc_tag_value{tag=\"motor\"} 1",
            "softplc_tag_value{tag=\"level\"} NaN",
            "softplc_tag_value{tag=\"we\\\"ird\"} -5",
            "softplc_tag_quality{tag=\"level\"} 1",
            "softplc_tag_forced{tag=\"motor\"} 1",
            "softplc_service_state{service=\"recorder\",state=\"degraded\"} 1",
            "softplc_service_state{service=\"recorder\",state=\"running\"} 0",
            "softplc_service_state{service=\"web\",state=\"off\"} 1",
            "# TYPE softplc_service_lost_changes_total counter",
            "softplc_service_lost_changes_total{service=\"opcua\"} 0",
            "softplc_service_lost_changes_total{service=\"mqtt\"} 17",
        ] {
            assert!(
                text.lines().any(|l| l == line),
                "missing {line:?} in\n{text}"
            );
        }
        // Every sample line is `name{labels} value` or `name value`; every family is typed
        // once, before its samples.
        let mut typed = std::collections::HashSet::new();
        for l in text.lines() {
            if let Some(rest) = l.strip_prefix("# TYPE ") {
                let name = rest.split(' ').next().unwrap();
                assert!(typed.insert(name.to_string()), "typed twice: {name}");
            } else if !l.starts_with("# HELP ") {
                let name = l.split(['{', ' ']).next().unwrap();
                let base = name
                    .strip_suffix("_sum")
                    .or_else(|| name.strip_suffix("_count"))
                    .filter(|b| typed.contains(*b))
                    .unwrap_or(name);
                assert!(typed.contains(base), "untyped sample {l}");
                let value = l.rsplit(' ').next().unwrap();
                assert!(
                    value.parse::<f64>().is_ok() || ["NaN", "+Inf", "-Inf"].contains(&value),
                    "{l}"
                );
            }
        }
    }

    #[test]
    fn numbers_and_labels() {
        assert_eq!(num(f64::INFINITY), "+Inf");
        assert_eq!(num(f64::NEG_INFINITY), "-Inf");
        assert_eq!(num(0.000_001), "0.000001");
        assert_eq!(label("a\\b\"c\nd"), "a\\\\b\\\"c\\nd");
    }

    #[test]
    fn serves_over_http_and_refuses_the_rest() {
        use std::io::Read;
        use std::net::TcpStream;
        let (info, _) = sample();
        let cell = SnapshotCell::new();
        let server = MetricsServer::start("127.0.0.1:0".parse().unwrap(), info, cell).unwrap();
        let connect = || {
            let c = TcpStream::connect(server.local_addr()).unwrap();
            c.set_read_timeout(Some(Duration::from_secs(10))).unwrap();
            c
        };
        let get = |req: &[u8]| {
            let mut c = connect();
            c.write_all(req).unwrap();
            let mut out = String::new();
            // A reset after the response still leaves the response read; the assertion judges it.
            drop(c.read_to_string(&mut out));
            out
        };
        let ok = get(b"GET /metrics HTTP/1.1\r\nHost: localhost\r\n\r\n");
        assert!(ok.starts_with("HTTP/1.1 200 OK\r\n"), "{ok}");
        assert!(
            ok.contains("Content-Type: text/plain; version=0.0.4; charset=utf-8\r\n"),
            "{ok}"
        );
        assert!(ok.contains("softplc_scans_total 0"), "{ok}");
        let head = get(b"HEAD /metrics?x=1 HTTP/1.0\r\n\r\n");
        assert!(head.starts_with("HTTP/1.1 200 OK\r\n"), "{head}");
        assert!(head.ends_with("\r\n\r\n"), "{head}");
        assert!(get(b"GET / HTTP/1.1\r\n\r\n").contains("metrics at /metrics"));
        let post = get(b"POST /metrics HTTP/1.1\r\n\r\n");
        assert!(post.starts_with("HTTP/1.1 405"), "{post}");
        assert!(post.contains("\r\nAllow: GET, HEAD\r\n"), "{post}");
        let delete = get(b"DELETE / HTTP/1.1\r\n\r\n");
        assert!(delete.starts_with("HTTP/1.1 405"), "{delete}");
        assert!(delete.contains("\r\nAllow: GET, HEAD\r\n"), "{delete}");
        assert!(get(b"GET /x HTTP/1.1\r\n\r\n").starts_with("HTTP/1.1 404"));
        assert!(get(b"GET metrics HTTP/1.1\r\n\r\n").starts_with("HTTP/1.1 400"));
        assert!(get(&vec![b'a'; http::MAX_HEAD + 1]).starts_with("HTTP/1.1 431"));
        // Clients that say nothing, or dribble, do not hold up a scrape: each has its own
        // connection and thread, and is answered 408 at its own deadline.
        let mut idle: Vec<TcpStream> = (0..8).map(|_| connect()).collect();
        for c in &mut idle {
            c.write_all(b"GET /met").unwrap();
        }
        let t = std::time::Instant::now();
        let ok = get(b"GET /metrics HTTP/1.0\r\n\r\n");
        assert!(ok.starts_with("HTTP/1.1 200"), "{ok}");
        assert!(t.elapsed() < LIMITS.request / 2, "{:?}", t.elapsed());
        for mut c in idle {
            let mut out = String::new();
            // A reset after the response still leaves the response read; the assertion judges it.
            drop(c.read_to_string(&mut out));
            assert!(out.starts_with("HTTP/1.1 408"), "{out}");
        }
    }

    #[test]
    fn the_alarms_figures_per_priority_band() {
        let mut out = String::new();
        alarms(
            &mut out,
            &crate::service::alarms::AlarmCounts {
                active: [0, 1, 2, 0],
                unacknowledged: 3,
            },
        );
        for line in [
            "# TYPE softplc_alarms_active gauge",
            "softplc_alarms_active{priority=\"low\"} 0",
            "softplc_alarms_active{priority=\"medium\"} 1",
            "softplc_alarms_active{priority=\"high\"} 2",
            "softplc_alarms_active{priority=\"urgent\"} 0",
            "softplc_alarms_unacknowledged 3",
        ] {
            assert!(out.lines().any(|l| l == line), "{line}\n{out}");
        }
    }
}
