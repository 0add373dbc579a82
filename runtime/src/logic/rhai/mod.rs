//! `rhai`: control programs as Rhai scripts, run whole once per scan.
//!
//! ```rhai
//! // Conveyor: start/stop latch with a jam timer.
//! motor = (r_trig("start", start) || motor) && !stop && !q("jam");
//! ton("jam", motor && !box_at_exit, "10s");
//! lamp = q("jam");
//! if r_trig("box", box_at_exit) { boxes += 1; }
//! ```
//!
//! # Tags
//!
//! Every project tag is a variable of the script under its own name: module inputs are
//! constants (assigning one is a compile error), outputs and memory tags are variables.
//! `bool` tags are Rhai `bool`s, `u16`/`i32` tags integers, `f32` tags floats. A tag takes a
//! value of its own kind only: a bool tag a bool, an integer tag an integer (saturated into its
//! range at the end of the scan), an `f32` tag an integer or a float. `pump1 = 2` or
//! `count = level / 2.0` is a type error at compile time when the value's type shows (a
//! literal, a tag, an operator or a library call over them), and a script fault naming the tag
//! when it does not (a `let` variable, a script function's result): never a silent conversion.
//!
//! # What the compiler checks
//!
//! Rhai finds functions and checks types only when a call is reached, so the compiler checks
//! every call in every branch and every script function first (see `typing.rs`): the
//! function's name (with the closest known one), its number of arguments, the types of
//! arguments it can see and literal durations and patterns; and assignments, operators and
//! conditions against the tags' declared types.
//! Variables declared with `let` live for one scan; what must survive to the next scan is a
//! memory tag (retained if `retain: true`) or a block instance. Script functions (`fn`) do not
//! see tags: pass values as arguments.
//!
//! # Blocks
//!
//! The library of `crate::logic::blocks`, instance state keyed by name:
//! `ton/tof/tp(name, in, pt)`, `stair(name, in, pt [, reset])`, `ctu(name, cu, reset, pv)`,
//! `ctd(name, cd, load, pv)`, `ctud(name, cu, cd, reset, load, pv)`, `r_trig/f_trig(name, x)`,
//! `sr(name, s1, r)`, `rs(name, s, r1)`, `toggle(name, x [, reset])`,
//! `blink(name, en, on, off)`, `blink_pattern(name, en, "1101", step)`; each returns its main
//! output. `q(name)`, `et(name)` (ms), `cv(name)`, `qu(name)`, `qd(name)` read outputs; times
//! are milliseconds or strings like `"1.5s"`; `limit(min, x, max)` clamps.
//!
//! # Push-down
//!
//! An output assigned once, at the top level, from a plain condition of bool tags the script
//! does not write (`y1 = a && !b || c;`, `y2 = (s || y2) && !r;`) is described to the planner
//! as the `expr` statement of the same text, and may run in its module; every other output is
//! described as opaque, with the reason (see `rungs.rs`).
//!
//! # Quality
//!
//! `good(tag)` is true while the tag's quality is Good (read from its module in the last
//! cycle, or a memory or forced tag), false while it is Stale or Bad; `bad(tag)` is true only
//! while it is Bad (the module is lost). The argument is the tag's variable itself
//! (`alarm = !good(level_high);`), resolved when the script is compiled (see `quality.rs`):
//! anything else, or a call inside a script function, is a compile error. The quality is the
//! image's at the start of the scan.
//!
//! # How tag access stays fast
//!
//! Rhai resolves a variable it finds declared in the script to a slot counted from the end of
//! its scope at compile time, but searches the scope by name (linearly) for any variable it
//! does not. So the script is compiled behind one extra line that declares every tag
//! (`let motor; const start = (); ...`), those declarations are cut from the compiled AST, and
//! each scan runs on a persistent scope holding exactly those variables, in that order. A tag
//! access in the script is then an index, whatever the number of tags:
//!
//! - a read-only tag (a module input) is read through Rhai's variable resolver from an indexed
//!   slot the scan fills from the image (see `slots.rs`): no lock, no name compared;
//! - a writable tag is a plain value of the scope, read and written in place. The scan copies
//!   the image into it only when the image holds something else than the script left there
//!   (a force, a write from outside, a module's read-back after push-down), and reads every
//!   writable tag back once, in order, after the script.
//!
//! Block calls with a literal instance name are resolved to the instance's slot at compile
//! time too (see `blocks.rs`). The scope is rewound after each scan, so `let`s do not pile up.
//!
//! # Plain scripts run on the logic VM
//!
//! Most of an interpreted scan is Rhai's own tree walk (evaluating each call's arguments,
//! resolving and dispatching the function), not tag access. So a script whose every top-level
//! statement is plain is lowered to the VM that `expr` and ladder share (see `lower.rs`) and
//! runs there, at their cost per rung: `tag = CONDITION;` for a bool tag, or a block call as a
//! statement, where a condition is made of bool tags, `true`/`false`, `!`, `&&`, `||`, `&`,
//! `|`, `^`, `==`/`!=`, comparisons of numeric tags, literals and `cv(..)`, `good`/`bad`, block
//! calls with a literal instance name and literal or tag presets, and `q`/`qu`/`qd`. The
//! script means the same there: statements in order, each reading what the earlier ones
//! wrote, a tag written only when its value changed (see `on_vm.rs`).
//!
//! The whole script stays in the interpreter when any part would mean something else on the
//! VM, which evaluates every instruction every scan: a block call that `&&`/`||` may skip
//! (`a || ton(..)`: Rhai does not run the timer while `a` holds), `good`/`bad` of a tag the
//! script assigns (Rhai answers the start of the scan), `et(..)` (whole milliseconds in Rhai);
//! and whatever the VM has no instruction for: `if`, loops, `let`, `fn`, arithmetic, numeric
//! assignments, strings, other functions, an instance named by an expression. Faults are the
//! interpreter's concern only: a plain script cannot raise one (its types are checked at
//! compile time, and it is refused when its size could reach the operations limit). `check`
//! prints which way the program runs, with the first reason when it is interpreted.
//!
//! # Sandbox
//!
//! A raw engine with the core language, math, arrays and maps only (no modules, no time, no
//! `eval`), strict variables, and limits: operations per scan, call depth, expression depth,
//! string/array/map sizes, and a time budget per scan checked every 1024 operations (the one
//! place a clock is read: a runaway script is stopped at the same place for the same inputs by
//! the operations limit, but where the budget stops it depends on the machine's speed). An
//! error or a limit faults the PLC to its safe state with the script position.

mod blocks;
mod check;
#[cfg(test)]
mod check_tests;
pub(crate) mod engine;
mod error;
mod internals;
mod lower;
#[cfg(test)]
mod lower_tests;
mod on_vm;
mod own;
mod quality;
mod rungs;
pub(crate) mod signatures;
mod slots;
#[cfg(test)]
mod slots_tests;
#[cfg(test)]
mod tests;
mod types;
mod typing;

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use rhai::{Dynamic, Engine, ImmutableString, Position, Scope, AST, INT};
use softplc_io::point::{Value, ValueType};

pub use blocks::MAX_INSTANCES;
pub use engine::Limits;
pub use error::{CompileError, CompileErrorKind};
pub(crate) use own::OUTPUT as OWN_OUTPUT;
pub use rungs::NOT_PLAIN;

use crate::image::{convert, ProcessImage, TagId};
use crate::logic::expr::TagTable;
use crate::logic::user_blocks::OwnBlocks;
use crate::logic::{LogicEngine, LogicFault, ScanContext, SourcePos};
use softplc_io::time::ScanInstant;

/// Most undeclared names one compile reports (each costs a compile of the script).
const MAX_UNDECLARED: usize = 64;

/// A tag the script names.
#[derive(Debug, Clone)]
struct Handle {
    id: TagId,
    ty: ValueType,
    writable: bool,
    /// Its variable's place in the scope (the order of the declarations line).
    position: usize,
    /// A read-only tag's slot (see `slots.rs`).
    slot: Option<u32>,
    /// The value copied in at the start of the scan.
    before: Value,
    /// A writable tag: the value its scope variable holds after the last scan, when that
    /// variable holds exactly this tag value (`None`: it must be copied in again).
    held: Option<Value>,
    /// A writable tag after the script: its value as a tag value and whether the variable
    /// holds exactly that (see [`holds`]), or the variable if no tag value fits it.
    after: Result<(Value, bool), Dynamic>,
    /// Where the script first assigns it (for a type fault).
    assigned: Option<Position>,
    name: String,
}

/// A variable of the declarations line, in order: what rebuilding the scope pushes.
#[derive(Debug, Clone)]
struct Declared {
    name: ImmutableString,
    ty: ValueType,
    writable: bool,
}

/// Changed writable tags above which the scope is rebuilt rather than searched by name once
/// per tag (`Scope` has no public write by index).
const REBUILD_ABOVE: usize = 8;

/// A compiled Rhai program, ready to scan. Build it with [`compile`].
pub struct RhaiProgram {
    engine: Engine,
    ast: AST,
    scope: Scope<'static>,
    base: usize,
    handles: Vec<Handle>,
    /// Every variable of the declarations line, in scope order.
    declared: Vec<Declared>,
    /// The read-only tags' values, read by the engine's variable resolver.
    inputs: Arc<slots::InputSlots>,
    /// Copy every writable tag in at the next scan (after a fault, a release, at the first).
    resync: bool,
    blocks: blocks::SharedBlocks,
    /// The instances of blocks of one's own the script calls, when the project has any.
    own: Option<own::SharedOwn>,
    /// The `good(tag)` / `bad(tag)` call sites and their tags' qualities.
    qualities: Arc<quality::Sites>,
    deadline: engine::Deadline,
    budget: Duration,
    file: PathBuf,
    /// The script's outputs as rungs for the push-down planner.
    described: rungs::Described,
    /// The user's top-level statements as compiled; `ast` holds those not released.
    statements: Vec<internals::Stmt>,
    /// Indexes into `statements` of the rungs a module runs.
    released: std::collections::BTreeSet<usize>,
    /// The script on the logic VM when every statement is plain, or why it is interpreted
    /// (see `lower.rs`).
    on_vm: Result<on_vm::OnVm, lower::Interpreted>,
    /// The number of tags the image must hold: one past the highest tag the script names.
    needs_tags: usize,
}

impl std::fmt::Debug for RhaiProgram {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RhaiProgram")
            .field("file", &self.file)
            .field("tags", &self.handles.len())
            .field("budget", &self.budget)
            .finish_non_exhaustive()
    }
}

/// Compiles a Rhai script against `tags`. `budget` is the most time one scan of the script may
/// take before it is stopped (and the PLC faults).
///
/// ```
/// use std::path::Path;
/// use std::time::Duration;
/// use softplc::image::{ProcessImage, TagId};
/// use softplc::scan::ScanInstant;
/// use softplc::logic::{expr::TagTable, rhai, LogicEngine, ScanContext};
/// use softplc_io::point::{Value, ValueType};
///
/// let tags = TagTable::new([
///     ("start".to_string(), TagId(0), ValueType::Bool, false),
///     ("motor".to_string(), TagId(1), ValueType::Bool, true),
/// ]);
/// let script = "motor = start || motor;\n";
/// let mut program =
///     rhai::compile(script, Path::new("m.rhai"), &tags, Duration::from_millis(50)).unwrap();
/// let mut image = ProcessImage::new(["start", "motor"].map(|n| (n.to_string(), Value::Bool(false))));
/// image.set(TagId(0), Value::Bool(true), ScanInstant::ZERO);
/// let ctx = ScanContext { now: ScanInstant::ZERO, delta: Duration::from_millis(10), cycle: 0 };
/// program.scan(&mut image, &ctx).unwrap();
/// assert_eq!(image.get(TagId(1)), Value::Bool(true));
///
/// let err = rhai::compile("start = true;\n", Path::new("m.rhai"), &tags, Duration::from_millis(50))
///     .unwrap_err();
/// assert!(err[0].to_string().starts_with("m.rhai:1:1: error:"), "{}", err[0]);
/// ```
pub fn compile(
    source: &str,
    file: &Path,
    tags: &TagTable,
    budget: Duration,
) -> Result<RhaiProgram, Vec<CompileError>> {
    compile_with(source, file, tags, budget, Limits::default())
}

/// [`compile`] with explicit limits.
pub fn compile_with(
    source: &str,
    file: &Path,
    tags: &TagTable,
    budget: Duration,
    limits: Limits,
) -> Result<RhaiProgram, Vec<CompileError>> {
    build(source, file, tags, budget, limits, OwnBlocks::none())
}

/// [`compile`] for a script that may call the project's blocks of one's own: `own` holds them
/// and their instances, which the program takes.
pub fn compile_calling(
    source: &str,
    file: &Path,
    tags: &TagTable,
    budget: Duration,
    own: OwnBlocks,
) -> Result<RhaiProgram, Vec<CompileError>> {
    build(source, file, tags, budget, Limits::default(), own)
}

fn build(
    source: &str,
    file: &Path,
    tags: &TagTable,
    budget: Duration,
    limits: Limits,
    mut own_blocks: OwnBlocks,
) -> Result<RhaiProgram, Vec<CompileError>> {
    let source = source.strip_prefix('\u{feff}').unwrap_or(source);
    let deadline = engine::Deadline::new();
    let blocks: blocks::SharedBlocks = Arc::new(Mutex::new(blocks::Blocks::default()));
    let mut engine = engine::sandboxed(limits, tags.len() + 1024, &deadline);
    blocks::register(&mut engine, &blocks);
    let own_signatures = own::signatures(&own_blocks);
    let own = (!own_blocks.is_empty()).then(|| own::register(&mut engine, &mut own_blocks));

    // Tags whose names Rhai reserves cannot be declared; they stay out of the script.
    let probe = Engine::new_raw();
    let usable: Vec<&crate::logic::expr::TagEntry> = tags
        .iter()
        .filter(|t| probe.compile(format!("let {} = 0;", t.name)).is_ok())
        .collect();
    let inputs = Arc::new(slots::InputSlots::new(
        usable.iter().map(|t| (t.name.as_str(), t.ty, t.writable)),
    ));
    {
        let inputs = inputs.clone();
        internals::on_var(&mut engine, move |name, offset, scope_len| {
            Ok(inputs.resolve(name, offset, scope_len))
        });
    }
    let mut declarations = String::with_capacity(usable.len() * 16);
    for t in &usable {
        if t.writable {
            declarations.push_str(&format!("let {};", t.name));
        } else {
            declarations.push_str(&format!("const {} = ();", t.name));
        }
    }

    let err = |pos: Position, kind: CompileErrorKind| CompileError {
        pos: error::user_pos(file, pos),
        kind,
    };
    let mut errors = Vec::new();
    // Rhai's strict variables stop at the first undeclared name. Each one found is declared on
    // the declarations line (which shifts no user position) and the script compiled again, so
    // every undeclared name is reported at once, at its first use, and the checks below still
    // see the whole script.
    let mut undeclared: Vec<String> = Vec::new();
    let full = loop {
        match engine.compile(format!("{declarations}\n{source}")) {
            Ok(ast) => break ast,
            Err(e) => {
                let kind = match e.err_type() {
                    rhai::ParseErrorType::VariableUndefined(name) => {
                        CompileErrorKind::UnknownVariable {
                            suggestion: crate::logic::expr::closest_name(
                                name,
                                usable.iter().map(|t| t.name.as_str()),
                            ),
                            name: name.clone(),
                        }
                    }
                    _ => CompileErrorKind::Parse {
                        message: error::message(e.to_string()),
                    },
                };
                if let CompileErrorKind::UnknownVariable { name, .. } = &kind {
                    // Undeclared in a script function (which no declaration here reaches), or
                    // too many: report what was found.
                    if !undeclared.contains(name) && undeclared.len() < MAX_UNDECLARED {
                        declarations.push_str(&format!("let {name};"));
                        undeclared.push(name.clone());
                        errors.push((e.position(), kind));
                        continue;
                    }
                }
                let parse = matches!(kind, CompileErrorKind::Parse { .. });
                if !errors.iter().any(|(p, k)| (*p, k) == (e.position(), &kind)) {
                    errors.push((e.position(), kind));
                }
                let mut out: Vec<CompileError> =
                    errors.into_iter().map(|(p, k)| err(p, k)).collect();
                // A tag named like a keyword, used, is what Rhai's parser stumbles on.
                if let Some(bad) = tags.iter().filter(|_| parse).find(|t| {
                    !usable.iter().any(|u| u.name == t.name) && source.contains(t.name.as_str())
                }) {
                    out.push(err(
                        Position::new(2, 1),
                        CompileErrorKind::KeywordTag {
                            name: bad.name.clone(),
                        },
                    ));
                }
                return Err(out);
            }
        }
    };
    let statements = internals::statements(&full);
    let declared = usable.len() + undeclared.len();
    let user = statements.get(declared..).unwrap_or(&[]).to_vec();
    let ast = internals::with_statements(&full, user);

    let usage = check::walk(&ast, &mut errors);
    for (pos, name) in &usage.captured {
        if tags.get(name).is_some_and(|t| !t.writable) {
            errors.push((*pos, CompileErrorKind::CapturedInput { name: name.clone() }));
        }
    }
    let mut known = typing::Known::of(&engine, &ast);
    known.own = own_signatures;
    typing::check(&ast, tags, &known, &mut errors);
    let qualities = Arc::new(quality::resolve(&ast, tags, &mut errors));
    // `good(strat)`: the undeclared name is the error, not that it is no tag.
    errors.retain(|(_, k)| {
        !matches!(k, CompileErrorKind::QualityOfNonTag { name, .. } if undeclared.contains(name))
    });
    quality::register(&mut engine, &qualities);
    if !errors.is_empty() {
        errors.sort_by_key(|(pos, _)| (pos.line(), pos.position()));
        return Err(errors.into_iter().map(|(p, k)| err(p, k)).collect());
    }

    match blocks.lock() {
        Ok(mut b) => b.resolve(&usage.block_calls),
        Err(p) => p.into_inner().resolve(&usage.block_calls),
    }
    let declared: Vec<Declared> = usable
        .iter()
        .map(|t| Declared {
            name: t.name.as_str().into(),
            ty: t.ty,
            writable: t.writable,
        })
        .collect();
    let mut scope = Scope::with_capacity(usable.len() + 16);
    push_declared(&mut scope, &declared, |_| None);
    let handles: Vec<Handle> = usable
        .iter()
        .enumerate()
        .filter(|(_, t)| usage.names.contains(&t.name))
        .map(|(position, t)| Handle {
            id: t.id,
            ty: t.ty,
            writable: t.writable,
            position,
            slot: inputs.slot_at(position),
            before: t.ty.zero(),
            held: None,
            after: Ok((t.ty.zero(), false)),
            assigned: usage.assigned.get(&t.name).copied(),
            name: t.name.clone(),
        })
        .collect();
    let written: Vec<(TagId, Position)> = handles
        .iter()
        .filter(|h| h.writable)
        .filter_map(|h| h.assigned.map(|at| (h.id, at)))
        .collect();
    let described = rungs::describe(&ast, tags, &written, file);
    let on_vm = lower::lower(&ast, tags, limits.operations, file).map(on_vm::OnVm::new);
    let needs_tags = handles.iter().map(|h| h.id.index() + 1).max().unwrap_or(0);
    Ok(RhaiProgram {
        on_vm,
        needs_tags,
        engine,
        statements: internals::statements(&ast).to_vec(),
        ast,
        described,
        released: std::collections::BTreeSet::new(),
        base: scope.len(),
        scope,
        handles,
        declared,
        inputs,
        resync: true,
        blocks,
        own,
        qualities,
        deadline,
        budget,
        file: file.to_path_buf(),
    })
}

/// Pushes every declared variable on `scope` (which holds nothing else): a writable tag with
/// `value(position)` or its type's zero, a read-only one as the unit constant its slot stands
/// for.
fn push_declared(
    scope: &mut Scope<'static>,
    declared: &[Declared],
    value: impl Fn(usize) -> Option<Value>,
) {
    for (position, d) in declared.iter().enumerate() {
        if d.writable {
            let v = value(position).unwrap_or(d.ty.zero());
            scope.push_dynamic(d.name.clone(), to_dynamic(v));
        } else {
            scope.push_constant_dynamic(d.name.clone(), Dynamic::UNIT);
        }
    }
}

/// Whether `d` is exactly what [`to_dynamic`] makes of tag value `v` (so the variable need not
/// be copied in again while the image holds `v`).
fn holds(d: &Dynamic, v: Value) -> bool {
    match v {
        Value::Bool(b) => d.as_bool() == Ok(b),
        Value::U16(x) => d.as_int() == Ok(INT::from(x)),
        Value::I32(x) => d.as_int() == Ok(INT::from(x)),
        Value::F32(x) => d
            .as_float()
            .is_ok_and(|f| f.to_bits() == f64::from(x).to_bits()),
    }
}

/// A tag value as Rhai sees it.
fn to_dynamic(v: Value) -> Dynamic {
    match v {
        Value::Bool(b) => Dynamic::from_bool(b),
        Value::U16(x) => Dynamic::from_int(INT::from(x)),
        Value::I32(x) => Dynamic::from_int(INT::from(x)),
        Value::F32(x) => Dynamic::from_float(f64::from(x)),
    }
}

/// A script value as a tag value of type `ty`, under the rule the checker applies to the
/// values it can see (`types::Ty::fits`): a bool tag takes a bool, an integer tag an integer
/// (saturated into its range), an `f32` tag a number. `None` for any other value: the script
/// faults naming the tag, rather than storing a silent conversion (`2` as `true`, `0.5` as
/// `0`).
fn from_dynamic(d: &Dynamic, ty: ValueType) -> Option<Value> {
    let v = match ty {
        ValueType::Bool => Value::Bool(d.as_bool().ok()?),
        ValueType::U16 | ValueType::I32 => {
            let i = d.as_int().ok()?;
            Value::I32(i.clamp(INT::from(i32::MIN), INT::from(i32::MAX)) as i32)
        }
        ValueType::F32 => match (d.as_int(), d.as_float()) {
            (Ok(i), _) => Value::F32(i as f32),
            (_, Ok(f)) => Value::F32(f as f32),
            _ => return None,
        },
    };
    Some(convert(v, ty))
}

/// A script value's type in words, as the checker says it (`types::Ty::words`).
fn words(d: &Dynamic) -> &'static str {
    if d.is_bool() {
        types::Ty::Bool.words()
    } else if d.is_int() {
        types::Ty::Int.words()
    } else if d.is_float() {
        types::Ty::Float.words()
    } else if d.is_string() {
        types::Ty::Str.words()
    } else {
        "a value of another type"
    }
}

impl RhaiProgram {
    /// The time budget of one scan.
    pub fn budget(&self) -> Duration {
        self.budget
    }

    /// The tags the script names, in project order.
    pub fn tags(&self) -> impl Iterator<Item = TagId> + '_ {
        self.handles.iter().map(|h| h.id)
    }

    /// The same program kept in the interpreter (to compare the two ways in tests).
    #[cfg(test)]
    fn interpreted(mut self) -> Self {
        self.on_vm = Err(lower::Interpreted {
            line: None,
            what: "kept for a test".into(),
        });
        self
    }

    /// The state of block instance `name` (`None`: never called).
    #[cfg(test)]
    fn instance(&self, name: &str) -> Option<crate::logic::blocks::Instance> {
        match &self.on_vm {
            Ok(vm) => vm.instance(name).cloned(),
            Err(_) => match self.blocks.lock() {
                Ok(b) => b.named(name).cloned(),
                Err(p) => p.into_inner().named(name).cloned(),
            },
        }
    }

    fn copy_in(&mut self, image: &ProcessImage) {
        self.qualities.copy_in(image);
        let mut stale = 0;
        for h in &mut self.handles {
            let v = image.get(h.id);
            h.before = v;
            if let Some(slot) = h.slot {
                self.inputs.store(slot, v);
            } else if self.resync || h.held != Some(v) {
                h.held = None;
                stale += 1;
            }
        }
        self.resync = false;
        if stale == 0 {
            return;
        }
        if stale > REBUILD_ABOVE {
            let before: std::collections::HashMap<usize, Value> = self
                .handles
                .iter()
                .filter(|h| h.writable)
                .map(|h| (h.position, h.before))
                .collect();
            self.scope.clear();
            push_declared(&mut self.scope, &self.declared, |p| before.get(&p).copied());
        } else {
            for h in self
                .handles
                .iter()
                .filter(|h| h.writable && h.held.is_none())
            {
                self.scope.set_value(h.name.as_str(), to_dynamic(h.before));
            }
        }
        for h in self.handles.iter_mut().filter(|h| h.writable) {
            h.held = Some(h.before);
        }
    }

    fn copy_out(&mut self, image: &mut ProcessImage, now: ScanInstant) -> Result<(), LogicFault> {
        // The scope iterates from its end: read every writable variable first (from the last
        // declared), then store them in project order, so a type fault stops at the same tag
        // as before, with the earlier ones stored.
        let len = self.scope.len();
        let mut writable = self
            .handles
            .iter_mut()
            .rev()
            .filter(|h| h.writable)
            .peekable();
        for (k, (_, _, d)) in self.scope.iter_raw().enumerate() {
            let position = len - 1 - k;
            let Some(h) = writable.next_if(|h| h.position == position) else {
                if writable.peek().is_none() {
                    break;
                }
                continue;
            };
            let d = d.flatten_clone();
            h.after = match from_dynamic(&d, h.ty) {
                Some(v) => Ok((v, holds(&d, v))),
                None => Err(d),
            };
        }
        for h in self.handles.iter_mut().filter(|h| h.writable) {
            let (v, exact) = match &h.after {
                Ok(after) => *after,
                Err(d) => {
                    return Err(LogicFault {
                        message: format!(
                            "script error: tag `{}` is {}, the script assigned it {} ({})",
                            h.name,
                            h.ty,
                            words(d),
                            d
                        ),
                        pos: error::user_pos(&self.file, h.assigned.unwrap_or(Position::new(2, 1))),
                    })
                }
            };
            if v != h.before {
                image.set(h.id, v, now);
            }
            // What the image now holds, or (a saturated integer, an f32 rounded, a force) a
            // reason to copy it in again.
            h.held = (exact && image.get(h.id) == v).then_some(v);
        }
        Ok(())
    }
}

impl LogicEngine for RhaiProgram {
    fn execution(&self) -> Option<String> {
        Some(match &self.on_vm {
            Ok(_) => "rhai: plain rungs, runs on the logic VM".to_string(),
            Err(why) => format!("rhai: runs in the Rhai interpreter ({why})"),
        })
    }

    /// Every output the script assigns, at its first assignment: the plain forms with their
    /// shapes, the others opaque with the reason (see `rungs.rs`).
    fn rungs(&self) -> Option<Vec<crate::logic::Rung>> {
        Some(self.described.rungs.clone())
    }

    /// Every writable tag the script assigns, at its first assignment.
    fn writes(&self) -> Vec<(TagId, crate::logic::SourcePos)> {
        let mut out: Vec<(TagId, crate::logic::SourcePos)> = self
            .handles
            .iter()
            .filter(|h| h.writable)
            .filter_map(|h| h.assigned.map(|at| (h.id, error::user_pos(&self.file, at))))
            .collect();
        out.sort_by_key(|(_, p)| (p.line, p.column));
        out
    }

    /// The module runs `coil`'s rung: its statement leaves the script, so the tag's variable
    /// holds the value the module's output is read back as.
    fn release(&mut self, coil: TagId) {
        let Some(&i) = self.described.statements.get(&coil) else {
            return;
        };
        self.released.insert(i);
        if let Ok(vm) = &mut self.on_vm {
            vm.release(coil);
        }
        let kept: Vec<internals::Stmt> = self
            .statements
            .iter()
            .enumerate()
            .filter(|(i, _)| !self.released.contains(i))
            .map(|(_, s)| s.clone())
            .collect();
        self.ast = internals::with_statements(&self.ast, kept);
        self.resync = true;
    }

    fn scan(&mut self, image: &mut ProcessImage, ctx: &ScanContext) -> Result<(), LogicFault> {
        let short = image.len() < self.needs_tags;
        if let Some(h) = self
            .handles
            .iter()
            .filter(|_| short)
            .find(|h| h.id.index() >= image.len())
        {
            return Err(LogicFault {
                message: format!(
                    "program uses tag `{}` (#{}) but the process image holds {} tags",
                    h.name,
                    h.id.index(),
                    image.len()
                ),
                pos: SourcePos {
                    file: self.file.clone(),
                    line: 1,
                    column: 1,
                },
            });
        }
        if let Ok(vm) = &mut self.on_vm {
            return vm.scan(image, ctx);
        }
        self.copy_in(image);
        match self.blocks.lock() {
            // A block's timers count in durations on the scan's clock (`logic::blocks`).
            Ok(mut b) => b.now = ctx.now.since_origin(),
            Err(p) => p.into_inner().now = ctx.now.since_origin(),
        }
        if let Some(own) = &self.own {
            own::begin(own, image, ctx);
        }
        self.deadline.arm(self.budget);
        let run = self.engine.run_ast_with_scope(&mut self.scope, &self.ast);
        self.scope.rewind(self.base);
        if let Err(e) = run {
            self.resync = true;
            return Err(error::fault(&e, &self.file, self.budget));
        }
        let out = self.copy_out(image, ctx.now);
        if out.is_err() {
            self.resync = true;
        }
        if let Some(own) = &self.own {
            own::publish(own, image, ctx);
        }
        out
    }
}
