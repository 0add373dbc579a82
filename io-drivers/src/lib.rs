//! softplc-io: everything that talks to I/O modules.
//!
//! The public surface is one namespace per layer, bottom up (see DESIGN.md); everything else
//! is internal to the crate:
//! - [`time`]: the [`Clock`](time::Clock) trait (monotonic or virtual) every timed part shares,
//!   and a point in time per clock: [`ScanInstant`](time::ScanInstant) on the scan's,
//!   [`LineInstant`](time::LineInstant) on a line's, so the two cannot be mixed up: a stable API.
//! - [`point`]: a module's points: [`Value`](point::Value), [`ValueType`](point::ValueType),
//!   [`Quality`](point::Quality), [`PointSpec`](point::PointSpec).
//! - [`driver`]: the sans-IO [`Driver`](driver::Driver) trait: a driver plans
//!   [`Transaction`](driver::Transaction)s and decodes their replies, never touching a port.
//! - [`line`](mod@line): serial settings and the wire-time budget, transports (a real serial
//!   port, the virtual multidrop line, TCP) and the [`BusOwner`](line::BusOwner) that runs
//!   transactions on one line, on its own thread or linked to the scan.
//! - [`modbus`]: the sans-IO Modbus RTU codec, master side (requests out, replies verified and
//!   reassembled) and server side (what the simulators answer).
//! - [`devices`]: the [`catalog`](devices::catalog) of module models
//!   ([`ModelSpec`](devices::ModelSpec)), and one namespace per family ([`devices::minimod`],
//!   [`devices::resi`], [`devices::ex9053`], [`devices::profile`]) with its settings, tables
//!   and simulator, and the [`Family`](devices::Family) trait through which each family states
//!   its capabilities to the runtime (its watchdog plan, its input modes): a stable API, as
//!   the trait's docs say.
//! - [`push_down`]: what a family's own logic runs in a rung's place
//!   ([`ModulePlacement`](push_down::ModulePlacement)) or why a rung stays in the scan
//!   ([`Reason`](push_down::Reason)), and the [`Site`](push_down::Site) a family asks about
//!   the project: a stable API.
//! - [`rung`]: the engine-neutral shape of a rung ([`RungShape`](rung::RungShape) over
//!   [`BoolExpr`](rung::BoolExpr)s of tags), what a logic engine tells the push-down planner
//!   about each coil it writes: a stable API.
//! - [`sim`]: the simulated world: devices on a virtual line ([`SimWorld`](sim::SimWorld)),
//!   injected faults, [`sim::plant`] models, serving on a pty or TCP.
//! - [`wire`]: seeing the wire: one frame decoder (every protocol), the bus owner's frame
//!   trace and the framing of a passively heard line.
//!
//! This crate never depends on the runtime: drivers never see logic.

pub mod devices;
pub mod driver;
pub mod line;
pub mod modbus;
pub mod point;
pub mod push_down;
pub mod rung;
pub mod sim;
pub mod time;
pub mod wire;
