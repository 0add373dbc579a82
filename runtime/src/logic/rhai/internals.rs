//! Rhai's unstable internals, in one room.
//!
//! The checker, the lowering to the logic VM, the push-down description and the quality
//! resolution read a compiled script's syntax tree, which Rhai exports only under its
//! `internals` feature and changes between releases without notice; the input slots use
//! `Engine::on_var`, which Rhai marks volatile. This module is the only one that names Rhai's
//! `Stmt`, `Expr`, `ASTNode`, `FnCallExpr` variants and `on_var`: it hands the others views of
//! its own ([`ExprView`], [`StmtView`], [`Call`]) and keeps Rhai's nodes opaque. A Rhai upgrade
//! that moves a node's shape fails this module's compilation or its test
//! (`the_shapes_softplc_reads_are_rhai_s`), nowhere else (DESIGN.md, "Upgrading Rhai").

use rhai::{ASTNode, Dynamic, Engine, EvalAltResult, Position};

pub(crate) use rhai::{Expr, Stmt, AST};

/// A function or operator call: `ton("t", a, 10)`, `a > 2` (operator `>`).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Call<'a> {
    /// The function's name, or the operator's symbol.
    pub name: &'a str,
    /// Its arguments (a method call's: those after the object).
    pub args: &'a [Expr],
    /// Where Rhai places the call (a binary operator's: at the operator).
    pub pos: Position,
    /// Whether it is an operator (`!`, `>`, `-`, ...) rather than a function.
    pub operator: bool,
}

/// An expression, as softplc reads it.
#[derive(Debug, Clone, Copy)]
pub(crate) enum ExprView<'a> {
    /// `true`, `false`.
    Bool(bool),
    /// An integer literal.
    Int(i64, Position),
    /// A float literal.
    Float(f64),
    /// A string literal.
    Str(&'a str, Position),
    /// A string with `${..}` in it.
    Interpolated,
    /// A character literal.
    Char,
    /// `()`.
    Unit,
    /// `[..]`.
    Array,
    /// `#{..}`.
    Map,
    /// A block used as a value: `{ .. }`, `if` or `switch` as an expression.
    Block,
    /// `x[i]`.
    Index,
    /// `x.len()`.
    Method(Call<'a>),
    /// `x.y`, `x.y.z()`.
    Property,
    /// A variable (a tag, a `let`, a parameter).
    Var(&'a str, Position),
    /// `a && b && ...`.
    And(&'a [Expr]),
    /// `a || b || ...`.
    Or(&'a [Expr]),
    /// A function call, or an operator (`!a`, `a > b`, `-1`: [`Call::operator`]).
    Call(Call<'a>),
    /// Anything else (a closure, a custom syntax).
    Other,
}

/// The view of `e`.
pub(crate) fn expr(e: &Expr) -> ExprView<'_> {
    match e {
        Expr::BoolConstant(b, _) => ExprView::Bool(*b),
        Expr::IntegerConstant(i, pos) => ExprView::Int(*i, *pos),
        Expr::FloatConstant(f, _) => ExprView::Float(**f),
        Expr::StringConstant(s, pos) => ExprView::Str(s.as_str(), *pos),
        Expr::InterpolatedString(..) => ExprView::Interpolated,
        Expr::CharConstant(..) => ExprView::Char,
        Expr::Unit(..) => ExprView::Unit,
        Expr::Array(..) => ExprView::Array,
        Expr::Map(..) => ExprView::Map,
        Expr::Stmt(..) => ExprView::Block,
        Expr::Index(..) => ExprView::Index,
        Expr::MethodCall(call, pos) => ExprView::Method(view_call(call, *pos)),
        Expr::Dot(..) | Expr::Property(..) => ExprView::Property,
        Expr::Variable(v, _, pos) => ExprView::Var(v.1.as_str(), *pos),
        Expr::And(items, _) => ExprView::And(items.as_slice()),
        Expr::Or(items, _) => ExprView::Or(items.as_slice()),
        Expr::FnCall(call, pos) => ExprView::Call(view_call(call, *pos)),
        _ => ExprView::Other,
    }
}

fn view_call(call: &rhai::FnCallExpr, pos: Position) -> Call<'_> {
    Call {
        name: call.name.as_str(),
        args: call.args.as_slice(),
        pos,
        operator: call.is_operator_call(),
    }
}

/// A float literal as Rhai writes it (`2.0`, `1e-9`), for messages.
pub(crate) fn float_text(f: f64) -> String {
    rhai::FloatWrapper::from(f).to_string()
}

/// Where Rhai places `e` (a binary operator: at the operator).
pub(crate) fn position(e: &Expr) -> Position {
    e.position()
}

/// Where `e` begins, as Rhai says it (a binary operator's call: still at the operator, see
/// `typing::start`).
pub(crate) fn start_position(e: &Expr) -> Position {
    e.start_position()
}

/// `x = e`, `x += e`.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Assignment<'a> {
    /// What is assigned: a variable, an element, a property.
    pub lhs: &'a Expr,
    /// The value.
    pub rhs: &'a Expr,
    /// An op-assignment's operator (`+` for `+=`), `None` for `=`.
    pub operator: Option<&'static str>,
    /// Where the `=` or `+=` is.
    pub pos: Position,
}

/// A statement, as softplc reads it.
#[derive(Debug, Clone)]
pub(crate) enum StmtView<'a> {
    /// An assignment.
    Assign(Assignment<'a>),
    /// A function call as a statement.
    Call(Call<'a>),
    /// Another expression as a statement.
    Expr(&'a Expr),
    /// An empty statement.
    Noop,
    /// `let x = ..`, `const x = ..`: the name.
    Let(&'a str),
    /// `for x in ..`, `for (x, i) in ..`: the loop variable and the counter.
    For(&'a str, Option<&'a str>),
    /// `if c { .. }`: the condition.
    If(&'a Expr),
    /// `while c { .. }`, `loop { .. }` (its condition is `()`).
    While(&'a Expr),
    /// `do { .. } while c`: the condition.
    Do(&'a Expr),
    /// `switch`.
    Switch,
    /// `{ .. }`.
    Block,
    /// `try { .. } catch { .. }`.
    Try,
    /// `break`, `continue`.
    Break,
    /// `return`, `throw`.
    Return,
    /// The variables a closure captures, each where it is named.
    Share(Vec<(&'a str, Position)>),
    /// Anything else.
    Other,
}

/// The view of `s`.
pub(crate) fn stmt(s: &Stmt) -> StmtView<'_> {
    match s {
        Stmt::Assignment(a) => StmtView::Assign(Assignment {
            lhs: &a.1.lhs,
            rhs: &a.1.rhs,
            operator: a.0.get_op_assignment_info().map(|info| info.5),
            pos: a.0.position(),
        }),
        Stmt::FnCall(call, pos) => StmtView::Call(view_call(call, *pos)),
        Stmt::Expr(e) => StmtView::Expr(e),
        Stmt::Noop(_) => StmtView::Noop,
        Stmt::Var(v, _, _) => StmtView::Let(v.0.name.as_str()),
        Stmt::For(f, _) => StmtView::For(f.0.name.as_str(), f.1.as_ref().map(|c| c.name.as_str())),
        Stmt::If(flow, _) => StmtView::If(&flow.expr),
        Stmt::While(flow, _) => StmtView::While(&flow.expr),
        Stmt::Do(flow, _, _) => StmtView::Do(&flow.expr),
        Stmt::Switch(..) => StmtView::Switch,
        Stmt::Block(..) => StmtView::Block,
        Stmt::TryCatch(..) => StmtView::Try,
        Stmt::BreakLoop(..) => StmtView::Break,
        Stmt::Return(..) => StmtView::Return,
        Stmt::Share(vars) => StmtView::Share(
            vars.iter()
                .map(|(var, _)| (var.name.as_str(), var.pos))
                .collect(),
        ),
        _ => StmtView::Other,
    }
}

/// Where `s` is.
pub(crate) fn stmt_position(s: &Stmt) -> Position {
    s.position()
}

/// A node of the tree.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Node<'a> {
    /// A statement.
    Stmt(&'a Stmt),
    /// An expression.
    Expr(&'a Expr),
}

/// Calls `visit` on every node of `ast`, its functions' included, parents before children;
/// `visit` returns `false` to stop.
pub(crate) fn walk(ast: &AST, mut visit: impl FnMut(Node<'_>) -> bool) {
    ast.walk(&mut |path: &[ASTNode]| match path.last() {
        Some(ASTNode::Stmt(s)) => visit(Node::Stmt(s)),
        Some(ASTNode::Expr(e)) => visit(Node::Expr(e)),
        _ => true,
    });
}

/// The top-level statements of `ast`.
pub(crate) fn statements(ast: &AST) -> &[Stmt] {
    ast.statements()
}

/// `statements` with `ast`'s functions: a script of other statements.
pub(crate) fn with_statements(ast: &AST, statements: Vec<Stmt>) -> AST {
    AST::new(statements, ast.shared_lib().clone())
}

/// Every function `engine` has (its packages' and those registered on it), each overload as
/// its name and number of parameters.
pub(crate) fn function_forms(engine: &Engine) -> Vec<(String, usize)> {
    engine.collect_fn_metadata(
        None,
        |f| Some((f.metadata.name.to_string(), f.metadata.num_params)),
        true,
    )
}

/// Resolves variables through `resolve` before the scope (`Engine::on_var`): `resolve` gets the
/// name, its index in the scope counted from the end as Rhai resolved it at compile time (0
/// if not), and the scope's length.
pub(crate) fn on_var(
    engine: &mut Engine,
    resolve: impl Fn(&str, usize, usize) -> Result<Option<Dynamic>, Box<EvalAltResult>>
        + Send
        + Sync
        + 'static,
) {
    // `on_var` is marked volatile by Rhai, not deprecated.
    #[allow(deprecated)]
    engine.on_var(move |name, offset, ctx| resolve(name, offset, ctx.scope().len()));
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every node kind the views name, in walk order, one word each.
    fn shapes(script: &str) -> Vec<String> {
        let mut engine = Engine::new_raw();
        engine.set_optimization_level(rhai::OptimizationLevel::None);
        let ast = engine.compile(script).expect("compiles");
        let mut out = Vec::new();
        walk(&ast, |node| {
            out.push(match node {
                Node::Stmt(s) => match stmt(s) {
                    StmtView::Assign(a) => format!("assign{}", a.operator.unwrap_or("")),
                    StmtView::Call(c) => format!(
                        "call-stmt:{}/{}{}",
                        c.name,
                        c.args.len(),
                        if c.operator { " op" } else { "" }
                    ),
                    StmtView::Expr(_) => "expr-stmt".into(),
                    StmtView::Noop => "noop".into(),
                    StmtView::Let(n) => format!("let:{n}"),
                    StmtView::For(n, c) => {
                        format!("for:{n}{}", c.map_or(String::new(), |c| format!(",{c}")))
                    }
                    StmtView::If(_) => "if".into(),
                    StmtView::While(_) => "while".into(),
                    StmtView::Do(_) => "do".into(),
                    StmtView::Switch => "switch".into(),
                    StmtView::Block => "block".into(),
                    StmtView::Try => "try".into(),
                    StmtView::Break => "break".into(),
                    StmtView::Return => "return".into(),
                    StmtView::Share(v) => format!("share:{}", v.len()),
                    StmtView::Other => "stmt?".into(),
                },
                Node::Expr(e) => match expr(e) {
                    ExprView::Bool(b) => format!("{b}"),
                    ExprView::Int(i, _) => format!("{i}"),
                    ExprView::Float(f) => format!("{f:?}"),
                    ExprView::Str(s, _) => format!("{s:?}"),
                    ExprView::Interpolated => "interpolated".into(),
                    ExprView::Char => "char".into(),
                    ExprView::Unit => "()".into(),
                    ExprView::Array => "array".into(),
                    ExprView::Map => "map".into(),
                    ExprView::Block => "block-expr".into(),
                    ExprView::Index => "index".into(),
                    ExprView::Method(c) => format!("method:{}/{}", c.name, c.args.len()),
                    ExprView::Property => "property".into(),
                    ExprView::Var(n, _) => format!("var:{n}"),
                    ExprView::And(items) => format!("and/{}", items.len()),
                    ExprView::Or(items) => format!("or/{}", items.len()),
                    ExprView::Call(c) if c.operator => format!("op:{}/{}", c.name, c.args.len()),
                    ExprView::Call(c) => format!("call:{}/{}", c.name, c.args.len()),
                    ExprView::Other => "expr?".into(),
                },
            });
            true
        });
        out
    }

    /// The shapes every reader of a script relies on (see the module docs). Should this fail
    /// after a Rhai upgrade, adapt [`expr`] and [`stmt`] until it passes; nothing else reads
    /// Rhai's tree.
    #[test]
    fn the_shapes_softplc_reads_are_rhai_s() {
        let script = r#"
            let a = true; let x = 1; let s = [1];
            y = a && !a || a ^ (x > 2);
            x += 1;
            ton("t", a, "1s");
            if x >= -1 { x = 2.5; } else { s[0] = 'c'; }
            while a { break; }
            loop { return; }
            do { x = s.len(); } while !a;
            for i in s { }
            for (i, n) in s { }
            x == 1;
            let m = #{ k: () };
            m.k = `v${x}`;
        "#;
        assert_eq!(
            shapes(script),
            [
                "let:a",
                "true",
                "let:x",
                "1",
                "let:s",
                "array",
                "1",
                // `||` and `&&` are lists; `^` and `>` are operator calls.
                "assign",
                "var:y",
                "op:^/2",
                "or/2",
                "and/2",
                "var:a",
                "op:!/1",
                "var:a",
                "var:a",
                "op:>/2",
                "var:x",
                "2",
                "assign+",
                "var:x",
                "1",
                // A call as a statement is an expression statement.
                "expr-stmt",
                "call:ton/3",
                "\"t\"",
                "var:a",
                "\"1s\"",
                // `-1` is a literal.
                "if",
                "op:>=/2",
                "var:x",
                "-1",
                "assign",
                "var:x",
                "2.5",
                "assign",
                "index",
                "var:s",
                "0",
                "char",
                "while",
                "var:a",
                "break",
                "while",
                "()",
                "return",
                "do",
                "op:!/1",
                "var:a",
                "assign",
                "var:x",
                "property",
                "var:s",
                "method:len/0",
                "for:i",
                "var:s",
                "for:i,n",
                "var:s",
                "expr-stmt",
                "op:==/2",
                "var:x",
                "1",
                "let:m",
                "map",
                "()",
                "assign",
                "property",
                "var:m",
                "property",
                "interpolated",
                "\"v\"",
                "block-expr",
                "expr-stmt",
                "var:x",
            ]
        );
        // Positions: a variable's where it is named; a binary operator's call at the operator.
        let mut engine = Engine::new_raw();
        engine.set_optimization_level(rhai::OptimizationLevel::None);
        let ast = engine.compile("y = a > b;").expect("compiles");
        let [s] = statements(&ast) else {
            panic!("one statement");
        };
        let StmtView::Assign(a) = stmt(s) else {
            panic!("an assignment");
        };
        assert_eq!((a.pos.line(), a.pos.position()), (Some(1), Some(3)));
        let ExprView::Call(gt) = expr(a.rhs) else {
            panic!("an operator");
        };
        assert!(gt.operator);
        assert_eq!(gt.pos.position(), Some(7));
        let ExprView::Var("a", at) = expr(&gt.args[0]) else {
            panic!("a variable");
        };
        assert_eq!(at.position(), Some(5));
        assert_eq!(start_position(a.rhs).position(), Some(7));
    }
}
