//! Block files read and checked into [`UserBlock`]s, and a project's `instances:` into
//! [`BlockInstance`]s with their tags; every error at its file:line:col.

use std::collections::HashMap;
use std::path::Path;

use softplc_io::point::{Value, ValueType};

use super::raw::{RawBlock, RawBlockFile, RawInstance, RawVar};
use super::{BlockInstance, BlockVar, NestedInstance, UserBlock, VarRole};
use crate::project::error::{read_text, ErrorKind, ProjectError, ProjectErrors};
use crate::project::span::{Locator, YPath};
use crate::project::{Binding, DocKind, DocText, ProgramKind, TagConfig};

/// What can be wrong with a block file, a block, or an instance of one.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum UserBlockError {
    /// A `description:` that cannot document the block or variable.
    #[error("description: {0}")]
    Description(crate::project::DocTextError),
    /// A block file that cannot be read.
    #[error("cannot read the block file {path}: {message}")]
    Unreadable {
        /// The path as the project gives it.
        path: String,
        /// The OS's reason.
        message: String,
    },
    /// A block file with errors (listed at their own places).
    #[error("the block file {path} has {count} error(s)")]
    Refused {
        /// The path as the project gives it.
        path: String,
        /// How many.
        count: usize,
    },
    /// A block name that is not upper case letters, digits and `_`.
    #[error("block name {0:?} must be upper case letters, digits and _, not first a digit (STATION, PUMP_2)")]
    BadBlockName(String),
    /// A variable name that programs could not use.
    #[error(
        "{role} name {name:?} is not an identifier (letters, digits and _, not first a digit)"
    )]
    BadVarName {
        /// Input, output or state.
        role: &'static str,
        /// The name.
        name: String,
    },
    /// A type that is not a tag type.
    #[error("unknown type {0:?} (known: bool, u16, i32, f32)")]
    UnknownType(String),
    /// A value that is not of its variable's type.
    #[error("{key} {value:?} of `{var}` is not {}", super::a_type(*.ty))]
    BadValue {
        /// `initial` or `default`.
        key: &'static str,
        /// The variable.
        var: String,
        /// The text given.
        value: String,
        /// Its type.
        ty: ValueType,
    },
    /// A key a role does not take (`initial` on an input, `default` on an output).
    #[error("`{key}` is for {takes}, not for {role} `{var}`")]
    MisplacedKey {
        /// The key.
        key: &'static str,
        /// Which variables take it.
        takes: &'static str,
        /// The variable's role.
        role: &'static str,
        /// The variable.
        var: String,
    },
    /// Two variables of one name in a block.
    #[error("`{name}` is already declared in this block at line {line}")]
    DuplicateVar {
        /// The name.
        name: String,
        /// The first one's line.
        line: usize,
    },
    /// A block with no input or no output.
    #[error("block {block} has no {role}: the first input is the power flow a rung feeds, the first output the value a call gives back")]
    Empty {
        /// The block.
        block: String,
        /// `input` or `output`.
        role: &'static str,
    },
    /// A first input or output that is not a bool.
    #[error("the first {role} of block {block}, `{var}`, is {}: it is the block's {what}, a bool", super::a_type(*.ty))]
    MainNotBool {
        /// `input` or `output`.
        role: &'static str,
        /// The block.
        block: String,
        /// The variable.
        var: String,
        /// Its type.
        ty: ValueType,
        /// What the first one is.
        what: &'static str,
    },
    /// A power flow declared optional.
    #[error("the first input of a block is the power flow a rung feeds: it takes no default")]
    DefaultOnPowerFlow,
    /// A body that is neither a ladder file nor a Rhai script.
    #[error("the body {0:?} must be a ladder file (.yaml) or a Rhai script (.rhai)")]
    BodyKind(String),
    /// A body file that is not there.
    #[error("the body {path:?} cannot be read: {message}")]
    BodyNotFound {
        /// The path as written.
        path: String,
        /// The OS's reason.
        message: String,
    },
    /// One name for two blocks in one file.
    #[error("block {name} is already defined in this file at line {line}")]
    DuplicateBlock {
        /// The name.
        name: String,
        /// The first one's line.
        line: usize,
    },
    /// One name for blocks of two included files.
    #[error(
        "block {name} is also defined in {other}:{line}; a project includes one block of a name"
    )]
    ClashAcrossFiles {
        /// The name.
        name: String,
        /// The other file, as the project names it.
        other: String,
        /// The line there.
        line: usize,
    },
    /// An instance of a block no included file defines.
    #[error("unknown block {name:?} ({})", known_blocks(.known))]
    UnknownBlock {
        /// The name given.
        name: String,
        /// The blocks the project's files define.
        known: Vec<String>,
    },
    /// A block that reaches itself through the instances its body calls.
    #[error("block {block} calls itself through its instances: {chain}; a block's instances are of other blocks, none of which may call it back")]
    Recursion {
        /// The block.
        block: String,
        /// The chain, `STATION (v: VALVE) -> VALVE (s: STATION) -> STATION`.
        chain: String,
    },
    /// An instance whose name is not an identifier.
    #[error("instance name {0:?} is not an identifier (letters, digits and _, not first a digit)")]
    BadInstanceName(String),
    /// An instance named like a tag or another instance.
    #[error("instance name `{name}` is already used by {what} at line {line}")]
    InstanceNameTaken {
        /// The name.
        name: String,
        /// `a tag`, `an instance`.
        what: &'static str,
        /// The line of the first.
        line: usize,
    },
}

fn known_blocks(known: &[String]) -> String {
    if known.is_empty() {
        "the project's `blocks:` files define none".to_owned()
    } else {
        format!("known: {}", known.join(", "))
    }
}

/// Reads every block file the project includes (`blocks:`, relative to `project`'s folder),
/// in order; a block file's own errors are at its own lines, and the project's `blocks[i]`
/// entry says it was refused. Two files defining one name: refused at the second.
pub(crate) fn load_all(
    files: &[String],
    project: &Path,
    loc: &Locator<'_>,
    errors: &mut Vec<ProjectError>,
) -> Option<Vec<UserBlock>> {
    let mut whole = true;
    let dir = project.parent().unwrap_or(Path::new(""));
    let at_entry = |i: usize, e: UserBlockError| {
        let (line, column) = loc.position(&YPath::root().key("blocks").index(i));
        ProjectError {
            file: project.to_path_buf(),
            line,
            column,
            kind: ErrorKind::UserBlock(e),
        }
    };
    let mut blocks: Vec<UserBlock> = Vec::new();
    let mut from: HashMap<String, String> = HashMap::new();
    for (i, rel) in files.iter().enumerate() {
        let file = dir.join(rel.trim());
        let loaded = read_text(&file).and_then(|text| {
            crate::project::unknown_keys::read_checked::<RawBlockFile, _>(&text, &file, check_file)
        });
        match loaded {
            Ok(found) => {
                for b in found {
                    if let Some(other) = blocks.iter().find(|o| o.name == b.name) {
                        let other_rel = from.get(&b.name).cloned().unwrap_or_default();
                        errors.push(ProjectError {
                            file: b.file.clone(),
                            line: b.name_at.0,
                            column: b.name_at.1,
                            kind: ErrorKind::UserBlock(UserBlockError::ClashAcrossFiles {
                                name: b.name.clone(),
                                other: other_rel,
                                line: other.name_at.0,
                            }),
                        });
                        continue;
                    }
                    from.insert(b.name.clone(), rel.clone());
                    blocks.push(b);
                }
            }
            Err(ProjectErrors { errors: mut found }) => {
                let e = match found.as_slice() {
                    [one] if one.line == 0 => UserBlockError::Unreadable {
                        path: rel.clone(),
                        message: one.kind.to_string(),
                    },
                    _ => UserBlockError::Refused {
                        path: rel.clone(),
                        count: found.len(),
                    },
                };
                if !matches!(e, UserBlockError::Unreadable { .. }) {
                    errors.append(&mut found);
                }
                errors.push(at_entry(i, e));
                whole = false;
            }
        }
    }
    // A file refused leaves its blocks unknown: instances of them would only repeat that.
    if !whole {
        return None;
    }
    let before = errors.len();
    check_nesting(&blocks, errors);
    (errors.len() == before).then_some(blocks)
}

/// Every block's nested instances: of a known block, and never leading back to the block
/// (a body would run itself without end). Each error at the `block:` of the instance that
/// starts the chain.
fn check_nesting(blocks: &[UserBlock], errors: &mut Vec<ProjectError>) {
    let known: Vec<String> = blocks.iter().map(|b| b.name.clone()).collect();
    for b in blocks {
        for nested in &b.instances {
            let kind = if !known.contains(&nested.block) {
                UserBlockError::UnknownBlock {
                    name: nested.block.clone(),
                    known: known.clone(),
                }
            } else if let Some(chain) = back_to(blocks, &b.name, nested, &mut Vec::new()) {
                UserBlockError::Recursion {
                    block: b.name.clone(),
                    chain: format!("{} ({}: {}) -> {chain}", b.name, nested.name, nested.block),
                }
            } else {
                continue;
            };
            errors.push(ProjectError {
                file: b.file.clone(),
                line: nested.block_at.0,
                column: nested.block_at.1,
                kind: ErrorKind::UserBlock(kind),
            });
        }
    }
}

/// The chain from `via`'s block back to `target`, if there is one (`VALVE (s: STATION) ->
/// STATION`); `seen` holds the blocks already followed, so a cycle not through `target` ends.
fn back_to(
    blocks: &[UserBlock],
    target: &str,
    via: &NestedInstance,
    seen: &mut Vec<String>,
) -> Option<String> {
    if via.block == target {
        return Some(target.to_owned());
    }
    if seen.contains(&via.block) {
        return None;
    }
    seen.push(via.block.clone());
    let block = blocks.iter().find(|b| b.name == via.block)?;
    block.instances.iter().find_map(|next| {
        back_to(blocks, target, next, seen)
            .map(|rest| format!("{} ({}: {}) -> {rest}", block.name, next.name, next.block))
    })
}

struct FileChecker<'a> {
    loc: Locator<'a>,
    file: &'a Path,
    errors: Vec<ProjectError>,
}

fn check_file(
    raw: &RawBlockFile,
    text: &str,
    file: &Path,
) -> Result<Vec<UserBlock>, Vec<ProjectError>> {
    let mut c = FileChecker {
        loc: Locator::new(text),
        file,
        errors: Vec::new(),
    };
    let mut out: Vec<UserBlock> = Vec::with_capacity(raw.blocks.len());
    for (i, b) in raw.blocks.iter().enumerate() {
        let path = YPath::root().key("blocks").index(i);
        if let Some(block) = c.block(b, &path) {
            if let Some(first) = out.iter().find(|o| o.name == block.name) {
                let e = UserBlockError::DuplicateBlock {
                    name: block.name.clone(),
                    line: first.name_at.0,
                };
                c.error(&path.key("name"), e);
            } else {
                out.push(block);
            }
        }
    }
    if c.errors.is_empty() {
        Ok(out)
    } else {
        Err(c.errors)
    }
}

impl FileChecker<'_> {
    fn error(&mut self, path: &YPath, e: UserBlockError) {
        let (line, column) = self.loc.position(path);
        self.errors.push(ProjectError {
            file: self.file.to_path_buf(),
            line,
            column,
            kind: ErrorKind::UserBlock(e),
        });
    }

    fn doc(&mut self, text: Option<&str>, path: &YPath) -> Option<Option<DocText>> {
        let Some(text) = text else {
            return Some(None);
        };
        match DocText::new(DocKind::Description, text) {
            Ok(d) => Some(d),
            Err(error) => {
                let (line, column) = self.loc.position(path);
                self.errors.push(ProjectError {
                    file: self.file.to_path_buf(),
                    line,
                    column,
                    kind: ErrorKind::UserBlock(UserBlockError::Description(error)),
                });
                None
            }
        }
    }

    fn block(&mut self, b: &RawBlock, path: &YPath) -> Option<UserBlock> {
        let before = self.errors.len();
        let name_ok = is_block_name(&b.name);
        if !name_ok {
            self.error(
                &path.key("name"),
                UserBlockError::BadBlockName(b.name.clone()),
            );
        }
        let description = self.doc(b.description.as_deref(), &path.key("description"));
        let mut seen: HashMap<String, usize> = HashMap::new();
        let mut vars = |c: &mut Self, list: &[RawVar], key: &'static str, role: VarRole| {
            let mut out = Vec::with_capacity(list.len());
            for (i, v) in list.iter().enumerate() {
                let at = path.key(key).index(i);
                if let Some(&line) = seen.get(v.name.as_str()) {
                    let e = UserBlockError::DuplicateVar {
                        name: v.name.clone(),
                        line,
                    };
                    c.error(&at.key("name"), e);
                    continue;
                }
                seen.insert(v.name.clone(), c.loc.line(&at.key("name")));
                if let Some(var) = c.var(v, role, &at) {
                    out.push(var);
                }
            }
            out
        };
        let inputs = vars(self, &b.inputs, "inputs", VarRole::Input);
        let outputs = vars(self, &b.outputs, "outputs", VarRole::Output);
        let state = vars(self, &b.state, "state", VarRole::State);
        for (list, raw, key, role, what) in [
            (&inputs, &b.inputs, "inputs", "input", "power flow"),
            (&outputs, &b.outputs, "outputs", "output", "main output"),
        ] {
            let first_ok = raw.first().map(|r| &r.name) == list.first().map(|v| &v.name);
            match list.first() {
                _ if !raw.is_empty() && !first_ok => {}
                None => {
                    let e = UserBlockError::Empty {
                        block: b.name.clone(),
                        role,
                    };
                    self.error(&path.key(key), e);
                }
                Some(first) if first.ty != ValueType::Bool => {
                    let e = UserBlockError::MainNotBool {
                        role,
                        block: b.name.clone(),
                        var: first.name.clone(),
                        ty: first.ty,
                        what,
                    };
                    self.error(&path.key(key).index(0).key("type"), e);
                }
                Some(first) if role == "input" && first.optional => {
                    self.error(
                        &path.key(key).index(0).key("default"),
                        UserBlockError::DefaultOnPowerFlow,
                    );
                }
                Some(_) => {}
            }
        }
        let instances = self.nested(&b.instances, &seen, path);
        let body = self.body(&b.body, &path.key("body"));
        if self.errors.len() != before {
            return None;
        }
        let (body, body_kind) = body?;
        Some(UserBlock {
            name: b.name.clone(),
            description: description?,
            file: self.file.to_path_buf(),
            name_at: self.loc.position(&path.key("name")),
            inputs,
            outputs,
            state,
            instances,
            body,
            body_kind,
        })
    }

    /// A block's `instances:`: each an identifier, named apart from the block's variables
    /// and from each other. Their blocks are looked up once every file is read.
    fn nested(
        &mut self,
        raw: &[RawInstance],
        vars: &HashMap<String, usize>,
        path: &YPath,
    ) -> Vec<NestedInstance> {
        let mut out: Vec<NestedInstance> = Vec::with_capacity(raw.len());
        let mut lines: HashMap<&str, usize> = HashMap::new();
        for (i, inst) in raw.iter().enumerate() {
            let at = path.key("instances").index(i);
            if !crate::project::validate::is_identifier(&inst.name) {
                self.error(
                    &at.key("name"),
                    UserBlockError::BadInstanceName(inst.name.clone()),
                );
                continue;
            }
            let taken = vars
                .get(inst.name.as_str())
                .map(|&line| ("a variable", line))
                .or_else(|| {
                    lines
                        .get(inst.name.as_str())
                        .map(|&line| ("an instance", line))
                });
            if let Some((what, line)) = taken {
                let e = UserBlockError::InstanceNameTaken {
                    name: inst.name.clone(),
                    what,
                    line,
                };
                self.error(&at.key("name"), e);
                continue;
            }
            lines.insert(&inst.name, self.loc.line(&at.key("name")));
            out.push(NestedInstance {
                name: inst.name.clone(),
                block: inst.block.clone(),
                block_at: self.loc.position(&at.key("block")),
            });
        }
        out
    }

    fn var(&mut self, v: &RawVar, role: VarRole, at: &YPath) -> Option<BlockVar> {
        if !crate::project::validate::is_identifier(&v.name) {
            let e = UserBlockError::BadVarName {
                role: role.word(),
                name: v.name.clone(),
            };
            self.error(&at.key("name"), e);
            return None;
        }
        let Some(ty) = ValueType::parse(&v.ty) else {
            self.error(&at.key("type"), UserBlockError::UnknownType(v.ty.clone()));
            return None;
        };
        let (given, key) = match role {
            VarRole::State => (&v.initial, "initial"),
            VarRole::Input => (&v.default, "default"),
            VarRole::Output => (&None, ""),
        };
        for (other, other_key, other_takes) in [
            (&v.initial, "initial", "state variables"),
            (&v.default, "default", "inputs"),
        ] {
            if other.is_some() && other_key != key {
                let e = UserBlockError::MisplacedKey {
                    key: other_key,
                    takes: other_takes,
                    role: role.word(),
                    var: v.name.clone(),
                };
                self.error(&at.key(other_key), e);
                return None;
            }
        }
        let initial = match given {
            None => ty.zero(),
            Some(text) => match Value::parse(ty, &text.0) {
                Some(value) => value,
                None => {
                    let e = UserBlockError::BadValue {
                        key,
                        var: v.name.clone(),
                        value: text.0.clone(),
                        ty,
                    };
                    self.error(&at.key(key), e);
                    return None;
                }
            },
        };
        if v.retain.is_some() && role != VarRole::State {
            let e = UserBlockError::MisplacedKey {
                key: "retain",
                takes: "state variables",
                role: role.word(),
                var: v.name.clone(),
            };
            self.error(&at.key("retain"), e);
            return None;
        }
        let description = self.doc(v.description.as_deref(), &at.key("description"))?;
        Some(BlockVar {
            retain: v.retain == Some(true),
            name: v.name.clone(),
            ty,
            initial,
            optional: role == VarRole::Input && v.default.is_some(),
            description,
        })
    }

    fn body(&mut self, rel: &str, at: &YPath) -> Option<(std::path::PathBuf, ProgramKind)> {
        let kind = if rel.ends_with(".rhai") {
            ProgramKind::Rhai
        } else if rel.ends_with(".yaml") || rel.ends_with(".yml") {
            ProgramKind::Ladder
        } else {
            self.error(at, UserBlockError::BodyKind(rel.to_owned()));
            return None;
        };
        let path = self.file.parent().unwrap_or(Path::new("")).join(rel);
        match std::fs::metadata(&path) {
            Ok(meta) if meta.is_file() => Some((path, kind)),
            Ok(_) => {
                let e = UserBlockError::BodyNotFound {
                    path: rel.to_owned(),
                    message: "not a file".to_owned(),
                };
                self.error(at, e);
                None
            }
            Err(err) => {
                let e = UserBlockError::BodyNotFound {
                    path: rel.to_owned(),
                    message: err.to_string(),
                };
                self.error(at, e);
                None
            }
        }
    }
}

/// `STATION`, `PUMP_2`: what ladder writes before an instance's name.
fn is_block_name(name: &str) -> bool {
    crate::project::validate::is_identifier(name) && !name.chars().any(|c| c.is_ascii_lowercase())
}

/// The project's `instances:`: each named once, apart from the tags, of a block the included
/// files define; its variables become memory tags `NAME.VARIABLE`, appended to `tags` (whose
/// entries so far are the project's own `tags:`).
pub(crate) fn instances(
    raw: &[RawInstance],
    blocks: &[UserBlock],
    tags: &mut Vec<Option<TagConfig>>,
    tag_names: &[&str],
    module_names: &[&str],
    loc: &Locator<'_>,
    mut error: impl FnMut(YPath, ErrorKind),
) -> Vec<BlockInstance> {
    let mut out = Vec::with_capacity(raw.len());
    let mut names: HashMap<&str, usize> = HashMap::new();
    for (i, inst) in raw.iter().enumerate() {
        let path = YPath::root().key("instances").index(i);
        let name_path = path.key("name");
        if !crate::project::validate::is_identifier(&inst.name) {
            error(
                name_path,
                UserBlockError::BadInstanceName(inst.name.clone()).into(),
            );
            continue;
        }
        let taken = if let Some(t) = tag_names.iter().position(|t| *t == inst.name) {
            Some((
                "a tag",
                loc.line(&YPath::root().key("tags").index(t).key("name")),
            ))
        } else if let Some(m) = module_names.iter().position(|m| *m == inst.name) {
            // `io.X` in a trace is a module's counter: an instance `io` would be ambiguous.
            let at = YPath::root().key("modules").index(m).key("name");
            Some(("a module", loc.line(&at)))
        } else {
            names.get(inst.name.as_str()).map(|&first| {
                let first = YPath::root().key("instances").index(first).key("name");
                ("an instance", loc.line(&first))
            })
        };
        if let Some((what, line)) = taken {
            let e = UserBlockError::InstanceNameTaken {
                name: inst.name.clone(),
                what,
                line,
            };
            error(name_path, e.into());
            continue;
        }
        names.insert(&inst.name, i);
        let Some(block) = blocks.iter().position(|b| b.name == inst.block) else {
            let e = UserBlockError::UnknownBlock {
                name: inst.block.clone(),
                known: blocks.iter().map(|b| b.name.clone()).collect(),
            };
            error(path.key("block"), e.into());
            continue;
        };
        let first_tag = tags.len();
        for v in blocks[block].tree(blocks) {
            let var = v.var;
            tags.push(Some(TagConfig {
                name: format!("{}.{}", inst.name, v.name),
                description: var.description.clone(),
                ty: var.ty,
                binding: Binding::Memory,
                safe: None,
                initial: var.initial,
                retain: var.retain,
            }));
        }
        out.push(BlockInstance {
            name: inst.name.clone(),
            block,
            first_tag,
        });
    }
    out
}
