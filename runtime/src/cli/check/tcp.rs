//! What `check` prints for a network bus: its endpoint and connection, and for Modbus TCP a
//! budget in transactions and timeouts (no wire-time floor: there is no baud to make one).

use std::fmt::Write as _;
use std::time::Duration;

use softplc_io::line::{LineBudget, NetFraming, TcpEndpoint, CONNECT_TIMEOUT};

use crate::project::{BusConfig, ModuleConfig};
use crate::scan::fmt_duration;

/// How the connection is kept, the same for both framings.
pub(super) fn connection() -> String {
    format!(
        "connection: opened at the first request (connect timeout {}); a timeout or a reply \
         that is not the request's closes it and the next request opens another; a refused or \
         lost connection is retried every 1s, doubling to 30s, the modules stale, then bad, \
         meanwhile",
        fmt_duration(CONNECT_TIMEOUT)
    )
}

/// `tcp://HOST:PORT (Modbus TCP: ...)` with how many unit ids share the connection.
pub(super) fn describe<'a>(
    endpoint: &TcpEndpoint,
    modules: impl Iterator<Item = &'a ModuleConfig>,
) -> String {
    let units = modules.count();
    match endpoint.framing {
        NetFraming::ModbusTcp => {
            format!("{endpoint} (Modbus TCP: one connection, shared by {units} unit id(s))")
        }
        NetFraming::RtuOverTcp => {
            format!("{endpoint} (RTU over TCP: one connection to a serial server, its line)")
        }
    }
}

/// The budget of a Modbus TCP bus: its transactions per cycle and what a cycle costs when the
/// server or a unit stops answering; what a good transaction takes is the network's round
/// trip and the device's (or the gateway's RTU line's) own time, which only a run measures
/// (`last round trip` in the status).
pub(super) fn budget(bus: &BusConfig, budget: &LineBudget, period: Duration) -> String {
    let mut out = String::new();
    let reads: usize = budget.modules.iter().map(|m| m.read_transactions).sum();
    let writes: usize = budget.modules.iter().map(|m| m.write_transactions).sum();
    let _ = writeln!(
        out,
        "  budget: inputs {reads} transaction(s), full output write {writes}; no wire-time \
         floor: each transaction is one network round trip plus the device's own reply time \
         (behind a gateway, its RTU exchange), measured in the run as each module's last round \
         trip"
    );
    for m in &budget.modules {
        let _ = writeln!(
            out,
            "    {}: read in {} tx, write in {} tx",
            m.name, m.read_transactions, m.write_transactions
        );
    }
    let attempt = bus.response_timeout;
    let first = attempt * (u32::from(bus.retries) + 1);
    let _ = writeln!(
        out,
        "  on failure: a silent unit costs the connection {} in its first failed cycle, then {} \
         per cycle until lost (3 cycles), then one probe of {} per backoff (1 s to 30 s); a \
         server that refuses the connection costs nothing but the attempt; the scan waits {} \
         for inputs, then goes on with the bus's last values (stale)",
        fmt_duration(first),
        fmt_duration(attempt),
        fmt_duration(attempt),
        fmt_duration(period * 9 / 10)
    );
    out
}
