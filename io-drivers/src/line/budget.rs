//! A line's time budget: the wire-time floor of its poll plan (DESIGN.md "Timing model").
//!
//! Each planned transaction costs request characters + the device's reply delay + reply
//! characters + t3.5, and, on a USB adapter with a latency timer, up to that timer for every
//! transaction that waits for bytes back ([`AdapterTiming`], `line/latency.rs`). The floor of a
//! cycle is the sum over its transactions; no master on this line can be faster. An adapter's
//! echo (`echo: discard`, `line/echo.rs`) arrives while the request is sent and adds nothing.
//! A line with modules in event mode adds one idle Collect round ([`CollectFloor::idle`]),
//! counted once for the line and without reply delays (a Collect reply has its slot instead),
//! and counts each member's full refresh: the longest input phase is a refresh cycle.

use std::time::Duration;

use crate::driver::{Driver, Outgoing, Transaction};
use crate::line::collect::floor::CollectFloor;
use crate::line::echo::EchoMode;
use crate::line::settings::LineSettings;
use crate::modbus::master::encode_request;
use crate::modbus::Request;
use crate::point::Access;

/// One module's share of a line's budget.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ModuleBudget {
    /// The module's name.
    pub name: String,
    /// Transactions to read its inputs each cycle.
    pub read_transactions: usize,
    /// Wire time of those reads.
    pub read_time: Duration,
    /// Transactions for a full output write.
    pub write_transactions: usize,
    /// Wire time of a full output write.
    pub write_time: Duration,
}

/// A line's budget.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LineBudget {
    /// Per module.
    pub modules: Vec<ModuleBudget>,
    /// Sum of every module's reads, and the line's idle Collect round when it has members
    /// (their refreshes counted: a refresh cycle is the longest): the input phase can be no
    /// shorter.
    pub read_floor: Duration,
    /// The idle Collect round in `read_floor` (zero without event-mode modules).
    pub collect_round: Duration,
    /// Sum of every module's full writes (a refresh cycle).
    pub write_floor: Duration,
}

impl LineBudget {
    /// Floor of a cycle that reads everything and writes everything.
    pub fn cycle_floor(&self) -> Duration {
        self.read_floor + self.write_floor
    }
}

/// The guard time after a timeout or a bad reply: long enough for a late or babbling reply
/// to end before the input is flushed (half the response timeout, at least two t3.5).
pub(crate) fn guard_time(settings: LineSettings, response_timeout: Duration) -> Duration {
    (response_timeout / 2).max(settings.t3_5() * 2)
}

/// What one attempt that gets no answer costs the line: an 8-character request (the longest
/// a poll sends is about that), the response timeout, the guard time and the t3.5 after it.
pub fn failed_attempt(settings: LineSettings, response_timeout: Duration) -> Duration {
    settings.chars(8) + response_timeout + guard_time(settings, response_timeout) + settings.t3_5()
}

/// Length on the wire of a Modbus reply to `req` (ADU with address and CRC), when it succeeds.
pub fn modbus_reply_len(req: &Request) -> usize {
    let pdu = match req {
        Request::ReadCoils { count, .. } | Request::ReadDiscreteInputs { count, .. } => {
            2 + usize::from(*count).div_ceil(8)
        }
        Request::ReadHoldingRegisters { count, .. } | Request::ReadInputRegisters { count, .. } => {
            2 + 2 * usize::from(*count)
        }
        Request::WriteSingleCoil { .. }
        | Request::WriteSingleRegister { .. }
        | Request::WriteMultipleCoils { .. }
        | Request::WriteMultipleRegisters { .. } => 5,
        Request::MaskWriteRegister { .. } => 7,
        // FCN SLVSEQ TYPE DATH DATL 0 (MiniMod manual, "The Modbus function Collect").
        Request::Collect { .. } => 6,
    };
    1 + pdu + 2
}

/// What a line's adapter adds to its transactions.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct AdapterTiming {
    /// Its latency timer: received bytes reach the host up to this late.
    pub latency: Duration,
    /// Whether the master reads back its own frames (then even a frame nothing answers waits
    /// for bytes back: its echo).
    pub echo: EchoMode,
}

impl AdapterTiming {
    /// The time a transaction waits for bytes held back by the adapter: its latency, when
    /// anything comes back (a reply, or the echo of a frame nothing answers).
    fn hold(self, tx: &Transaction) -> Duration {
        match (&tx.frame, self.echo) {
            (Outgoing::NoReply { .. }, EchoMode::None) => Duration::ZERO,
            _ => self.latency,
        }
    }
}

/// Wire time of one planned transaction.
pub fn transaction_time(
    settings: LineSettings,
    tx: &Transaction,
    reply_delay: Duration,
) -> Duration {
    wire_time(settings, tx, reply_delay)
}

/// Time of one planned transaction on a line whose adapter is `adapter`: its wire time and
/// what the adapter holds back.
pub fn transaction_time_on(
    settings: LineSettings,
    adapter: AdapterTiming,
    tx: &Transaction,
    reply_delay: Duration,
) -> Duration {
    wire_time(settings, tx, reply_delay) + adapter.hold(tx)
}

fn wire_time(settings: LineSettings, tx: &Transaction, reply_delay: Duration) -> Duration {
    match &tx.frame {
        Outgoing::Modbus { unit, request } => {
            let mut frame = Vec::new();
            let request_len = match encode_request(unit.get(), request, &mut frame) {
                Ok(()) => frame.len(),
                Err(_) => 0,
            };
            settings.transaction(request_len, reply_delay, modbus_reply_len(request))
        }
        // A text reply's length depends on the value; count the echo-sized reply as a floor.
        Outgoing::Text { line, .. } => settings.transaction(line.len(), reply_delay, line.len()),
        // Nothing answers: the frame and the t3.5 after it.
        Outgoing::NoReply { bytes } => settings.transaction(bytes.len(), Duration::ZERO, 0),
    }
}

/// The budget of a line whose modules are `drivers` (name, driver, the model's point access).
pub fn line_budget(
    settings: LineSettings,
    drivers: &mut [(String, Box<dyn Driver>, Vec<Access>)],
) -> LineBudget {
    line_budget_on(settings, AdapterTiming::default(), drivers)
}

/// The budget of a line whose adapter is `adapter` (its latency counted in every
/// transaction that waits for bytes back).
pub fn line_budget_on(
    settings: LineSettings,
    adapter: AdapterTiming,
    drivers: &mut [(String, Box<dyn Driver>, Vec<Access>)],
) -> LineBudget {
    let mut modules = Vec::with_capacity(drivers.len());
    let mut plan = Vec::new();
    let mut members = Vec::new();
    for (name, driver, access) in drivers.iter_mut() {
        plan.clear();
        driver.plan_read(&mut plan);
        if let Some(membership) = driver.collect_membership() {
            // A member's full refresh (a cycle that refreshes is the longest); its share of
            // the line's Collect round is counted once for the line, below.
            driver.plan_refresh(&mut plan);
            members.push(membership);
        }
        let read_transactions = plan.len();
        let read_time = plan_time(settings, adapter, driver.as_ref(), &plan);
        let desired: Vec<_> = access
            .iter()
            .map(|a| (*a == Access::Output).then_some(crate::point::Value::Bool(false)))
            .collect();
        plan.clear();
        driver.plan_write(&desired, true, &mut plan);
        let write_transactions = plan.len();
        let write_time = plan_time(settings, adapter, driver.as_ref(), &plan);
        modules.push(ModuleBudget {
            name: name.clone(),
            read_transactions,
            read_time,
            write_transactions,
            write_time,
        });
    }
    // One idle Collect round for the members, whose reply delays do not apply to it.
    let collect_round =
        members_floor(settings, adapter, &members).map_or(Duration::ZERO, |f| f.idle());
    let read_floor = modules.iter().map(|m| m.read_time).sum::<Duration>() + collect_round;
    let write_floor = modules.iter().map(|m| m.write_time).sum();
    LineBudget {
        modules,
        read_floor,
        write_floor,
        collect_round,
    }
}

/// What a device that needs more silence than t3.5 before a request adds to each of its
/// transactions.
fn frame_gap_excess(settings: LineSettings, driver: &dyn Driver) -> Duration {
    driver
        .frame_gap(settings)
        .map_or(Duration::ZERO, |g| g.saturating_sub(settings.t3_5()))
}

/// The floor of a line's input phase as the bus owner runs it on a cycle without events and
/// without refreshes: every module's own reads of the cycle (a member of the Collect round
/// reads its inputs from the round, so only its status and counters, if any), then one idle
/// Collect round over the members ([`CollectFloor::idle`]). Each reply delay and, per
/// transaction and per Collect, the adapter's latency are in it.
pub fn input_floor(
    settings: LineSettings,
    adapter: AdapterTiming,
    drivers: &mut [Box<dyn Driver>],
) -> Duration {
    input_floor_of(settings, adapter, drivers.iter_mut().map(|d| d.as_mut()))
}

/// [`input_floor`] over drivers held elsewhere (a line's modules with their names).
pub(crate) fn input_floor_of<'a>(
    settings: LineSettings,
    adapter: AdapterTiming,
    drivers: impl Iterator<Item = &'a mut (dyn Driver + 'static)>,
) -> Duration {
    let mut plan = Vec::new();
    let mut members = Vec::new();
    let mut total = Duration::ZERO;
    for driver in drivers {
        plan.clear();
        driver.plan_read(&mut plan);
        total += plan_time(settings, adapter, driver, &plan);
        members.extend(driver.collect_membership());
    }
    total + members_floor(settings, adapter, &members).map_or(Duration::ZERO, |f| f.idle())
}

/// The Collect rounds of a line whose event-mode members are `members`: over their window,
/// each slot as late as the member that waits longest for the end of a request
/// ([`CollectFloor::with_frame_timeout`], a MiniMod's RDELAYM); `None` without members.
pub fn members_floor(
    settings: LineSettings,
    adapter: AdapterTiming,
    members: &[crate::driver::Membership],
) -> Option<CollectFloor> {
    let units: Vec<u8> = members.iter().map(|m| m.unit.get()).collect();
    let frame_timeout = members
        .iter()
        .map(|m| m.frame_timeout)
        .max()
        .unwrap_or_default();
    CollectFloor::over(settings, adapter, &units).map(|f| f.with_frame_timeout(frame_timeout))
}

/// Time of `plan`, one module's transactions, on the line: each with the module's reply delay
/// and the silence it needs beyond t3.5.
pub(crate) fn plan_time(
    settings: LineSettings,
    adapter: AdapterTiming,
    driver: &dyn Driver,
    plan: &[Transaction],
) -> Duration {
    let delay = driver.reply_delay();
    let gap = frame_gap_excess(settings, driver);
    plan.iter()
        .map(|tx| transaction_time_on(settings, adapter, tx, delay) + gap)
        .sum()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reply_lengths_follow_the_function_code() {
        assert_eq!(
            modbus_reply_len(&Request::ReadDiscreteInputs { addr: 0, count: 10 }),
            7
        );
        assert_eq!(
            modbus_reply_len(&Request::ReadHoldingRegisters { addr: 0, count: 3 }),
            11
        );
        assert_eq!(
            modbus_reply_len(&Request::WriteSingleRegister { addr: 0, value: 1 }),
            8
        );
        assert_eq!(
            modbus_reply_len(&Request::MaskWriteRegister {
                addr: 0,
                and_mask: 0,
                or_mask: 0
            }),
            10
        );
    }
}
