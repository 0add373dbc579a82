//! Compiling a model file: its declarations first (`fn plant()`), then its step against them,
//! so a name the model never declared is an error at its line:col before the first scan.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use rhai::{CallFnOptions, Dynamic, Map, ParseError, ParseErrorType, Scope, AST};
use softplc_io::point::ValueType;
use softplc_io::sim::plant::StateValue;

use super::api::{self, StepContext};
use super::decl::{self, Declarations, RESERVED};
use super::error::ModelError;
use super::run::RhaiPlant;

/// A plant model compiled from its Rhai file, ready to run any number of times.
#[derive(Debug, Clone)]
pub struct PlantModel {
    /// The model's name: its file's name before `.plant.rhai` (`door`).
    pub name: String,
    /// The file, for messages (a built-in's name in the catalog).
    pub file: PathBuf,
    source: String,
    ast: Arc<AST>,
    /// What its `fn plant()` declares.
    pub decl: Declarations,
}

impl PartialEq for PlantModel {
    /// The same file with the same text is the same model (a reload keeps a running plant).
    fn eq(&self, other: &Self) -> bool {
        self.file == other.file && self.source == other.source
    }
}

impl Eq for PlantModel {}

/// An error of a model file at its line and column (1-based).
#[derive(Debug, Clone, PartialEq)]
pub struct ModelErrorAt {
    /// The line.
    pub line: usize,
    /// The column.
    pub column: usize,
    /// What is wrong.
    pub error: ModelError,
}

impl PlantModel {
    /// Every terminal: the read ones, then the driven ones, with `true` for driven; a project
    /// wires them in this order.
    pub fn terminals(&self) -> impl Iterator<Item = (&str, bool)> {
        let reads = self.decl.reads.iter().map(|n| (n.as_str(), false));
        reads.chain(self.decl.drives.iter().map(|n| (n.as_str(), true)))
    }

    /// A running instance whose driven terminals have the types `drive_types` (in the order
    /// of `decl.drives`), its random source seeded with `seed`.
    pub fn instantiate(&self, drive_types: Vec<ValueType>, seed: u64) -> RhaiPlant {
        RhaiPlant::new(self, self.ast.clone(), drive_types, seed)
    }
}

/// The model's name from its file's: `door.plant.rhai` → `door`.
fn name_of(file: &Path) -> String {
    let name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    name.strip_suffix(".plant.rhai")
        .or_else(|| name.strip_suffix(".rhai"))
        .unwrap_or(&name)
        .to_owned()
}

/// Compiles `source`, the text of `file`; every error found, at its line:col.
pub fn compile(file: &Path, source: &str) -> Result<PlantModel, Vec<ModelErrorAt>> {
    let ctx = Arc::new(Mutex::new(StepContext::new(10, 0, Vec::new())));
    let mut engine = api::engine(&ctx);
    // The declarations are read before the step's names are known.
    engine.set_strict_variables(false);
    let ast = engine
        .compile(source)
        .map_err(|e| vec![parse_error(&e, &[])])?;
    if !ast
        .iter_functions()
        .any(|f| f.name == "plant" && f.params.is_empty())
    {
        return Err(vec![at(1, 1, ModelError::NoDeclaration)]);
    }
    let options = CallFnOptions::new().eval_ast(false);
    let declared = engine
        .call_fn_with_options::<Dynamic>(options, &mut Scope::new(), &ast, "plant", ())
        .map_err(|e| {
            let (line, column) = position(e.position()).unwrap_or_else(|| locate(source, "plant"));
            let mut e = *e;
            e.clear_position();
            vec![at(
                line,
                column,
                ModelError::BadDeclaration { why: e.to_string() },
            )]
        })?;
    let Some(map) = declared.read_lock::<Map>().map(|m| m.clone()) else {
        let (line, column) = locate(source, "plant");
        let why = format!("it returned a {}", declared.type_name());
        return Err(vec![at(line, column, ModelError::BadDeclaration { why })]);
    };
    let decl = decl::read(&map).map_err(|errors| {
        let mut placed: Vec<ModelErrorAt> = errors
            .into_iter()
            .map(|(error, needle)| {
                let (line, column) = needle.map_or((1, 1), |n| locate(source, &n));
                at(line, column, error)
            })
            .collect();
        placed.sort_by_key(|e| (e.line, e.column));
        placed
    })?;

    // The step, compiled against exactly the declared names: any other is an error here.
    engine.set_strict_variables(true);
    let mut scope = Scope::new();
    for name in &decl.reads {
        scope.push_constant(name.as_str(), false);
    }
    for name in RESERVED {
        scope.push_constant(name, 0.0 as rhai::FLOAT);
    }
    for name in &decl.drives {
        scope.push(name.as_str(), false);
    }
    for s in &decl.states {
        scope.push(s.name.as_str(), initial(s.initial));
    }
    let known: Vec<&str> = scope.iter_raw().map(|(n, _, _)| n).collect();
    let ast = engine
        .compile_with_scope(&scope, source)
        .map_err(|e| vec![parse_error(&e, &known)])?;
    let mut errors = Vec::new();
    writes_to_reads(&ast, &decl, &mut errors);
    if !errors.is_empty() {
        return Err(errors);
    }
    Ok(PlantModel {
        name: name_of(file),
        file: file.to_path_buf(),
        source: source.to_owned(),
        ast: Arc::new(ast),
        decl,
    })
}

/// A state's value as the step sees it.
pub(crate) fn initial(v: StateValue) -> Dynamic {
    match v {
        StateValue::Bool(b) => Dynamic::from_bool(b),
        StateValue::Int(i) => Dynamic::from_int(i),
        StateValue::Float(x) => Dynamic::from_float(x),
    }
}

fn at(line: usize, column: usize, error: ModelError) -> ModelErrorAt {
    ModelErrorAt {
        line,
        column,
        error,
    }
}

fn position(p: rhai::Position) -> Option<(usize, usize)> {
    Some((p.line()?, p.position().unwrap_or(1)))
}

/// Rhai's parse error, in the model's words where it has them.
fn parse_error(e: &ParseError, known: &[&str]) -> ModelErrorAt {
    let (line, column) = position(e.position()).unwrap_or((1, 1));
    let error = match e.err_type() {
        ParseErrorType::VariableUndefined(name) => ModelError::UnknownName {
            name: name.clone(),
            hint: crate::suggest::did_you_mean(name, known.iter().copied()),
        },
        other => ModelError::Syntax {
            message: other.to_string(),
        },
    };
    at(line, column, error)
}

/// Assignments to a read terminal (a constant of the step's scope, which Rhai itself would
/// refuse only when the step runs).
fn writes_to_reads(ast: &AST, decl: &Declarations, errors: &mut Vec<ModelErrorAt>) {
    use rhai::{ASTNode, Expr, Stmt};
    let mut found = Vec::new();
    ast.walk(&mut |path: &[ASTNode]| {
        if let Some(ASTNode::Stmt(Stmt::Assignment(assign))) = path.last() {
            let target = &assign.1.lhs;
            let root = match target {
                Expr::Variable(v, _, pos) => Some((v.1.as_str(), *pos)),
                Expr::Index(b, _, _) | Expr::Dot(b, _, _) => match &b.lhs {
                    Expr::Variable(v, _, pos) => Some((v.1.as_str(), *pos)),
                    _ => None,
                },
                _ => None,
            };
            if let Some((name, pos)) = root {
                if decl.reads.iter().any(|r| r == name) || RESERVED.contains(&name) {
                    found.push((name.to_owned(), pos));
                }
            }
        }
        true
    });
    for (name, pos) in found {
        let (line, column) = position(pos).unwrap_or((1, 1));
        let error = if RESERVED.contains(&name.as_str()) {
            ModelError::WritesApi { name }
        } else {
            ModelError::WritesRead { name }
        };
        errors.push(at(line, column, error));
    }
}

/// Where `needle` first stands as a whole word in `source` (outside comments, roughly): the
/// place to show a declaration's error at.
fn locate(source: &str, needle: &str) -> (usize, usize) {
    let is_word = |c: char| c.is_ascii_alphanumeric() || c == '_';
    for (i, line) in source.lines().enumerate() {
        let code = line.split("//").next().unwrap_or("");
        let mut from = 0;
        while let Some(k) = code.get(from..).and_then(|rest| rest.find(needle)) {
            let start = from + k;
            let end = start + needle.len();
            let before = code[..start].chars().next_back();
            let after = code[end..].chars().next();
            if !before.is_some_and(is_word) && !after.is_some_and(is_word) {
                return (i + 1, code[..start].chars().count() + 1);
            }
            from = end;
        }
    }
    (1, 1)
}
