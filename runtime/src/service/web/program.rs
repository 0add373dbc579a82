//! The program as the page shows it: the source, line by line, cut into code, comments,
//! strings and the names of tags (which the page decorates with their live values), with the
//! push-down plan's placement of each rung on the rung's first line.
//!
//! This reads the text only; no engine internals: a name is a tag when it is spelt like one
//! outside comments and strings and is not a member (`jam.Q`); in a ladder file, only in the
//! rungs (a `description:` is prose, and so are a rung's `title:` and `comment:`, shown as
//! comments).
//!
//! A ladder program also gets its diagram ([`crate::logic::ladder::diagram`]: the compiler's own
//! parse of each rung), which the page draws as a ladder with power flow lit live.

use serde::Serialize;

use crate::image::TagId;
use crate::logic::expr::TagTable;
use crate::logic::ladder::{self, RungDiagram};
use crate::logic::load;
use crate::offload::{Placement, Plan};
use crate::project::{ProgramConfig, ProgramKind, Project};

/// One piece of a line.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Part {
    /// `code`, `tag`, `comment` or `string`.
    pub k: &'static str,
    /// The text.
    pub s: String,
    /// For a tag: its index in the project's tags.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tag: Option<usize>,
}

/// Where the rung starting on a line runs.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct RungMark {
    /// The coil's tag.
    pub coil: usize,
    /// The module that runs it, when pushed down.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub module: Option<String>,
    /// The module feature that runs it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub feature: Option<String>,
    /// Why it stays in the scan, when it does.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub central: Option<String>,
    /// The rung's title (a ladder rung's `title:`, the first sentence of an expr
    /// statement's comment).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub title: Option<String>,
}

/// One source line.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Default)]
pub struct Line {
    /// Its pieces, in order.
    pub parts: Vec<Part>,
    /// The rungs that start on it.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub rungs: Vec<RungMark>,
}

/// One program as the program page shows it (a task of several programs has one each, in
/// running order).
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct ProgramView {
    /// The program file, as the project names it.
    pub file: String,
    /// With several tasks, the task that runs it (its index in the page's `tasks`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub task: Option<usize>,
    /// The index of the program's first block instance in the state's block outputs (`b`):
    /// a later program's instances are numbered after an earlier one's.
    pub inst_base: u32,
    /// `expr`, `ladder` or `rhai`.
    pub kind: &'static str,
    /// Its lines.
    pub lines: Vec<Line>,
    /// A ladder program's rungs as diagrams, in file order.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub diagram: Option<Vec<RungDiagram>>,
    /// Why a ladder program has no diagram (the page shows its text).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub no_diagram: Option<String>,
    /// Why there is no source, when it could not be read.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub error: Option<String>,
}

/// Every program of `project`'s (first) task, read now, with `plan`'s placements;
/// `instance_counts`: per program, its block instances as the running engine numbers them
/// ([`crate::logic::LogicEngine::instance_counts`]).
pub(crate) fn views(project: &Project, plan: &Plan, instance_counts: &[u32]) -> Vec<ProgramView> {
    let mut base = 0u32;
    project
        .programs
        .iter()
        .enumerate()
        .map(|(i, program)| {
            let v = view(project, program, plan, base);
            base += instance_counts.get(i).copied().unwrap_or(0);
            v
        })
        .collect()
}

/// The program `program` of `project`, read now, with the placements of `plan`'s rungs that
/// are in its file; its instances numbered from `inst_base`.
fn view(project: &Project, program: &ProgramConfig, plan: &Plan, inst_base: u32) -> ProgramView {
    let path = &program.path;
    let kind = crate::offload::engine_name(program.kind);
    let file = path.file_name().map_or_else(
        || path.display().to_string(),
        |n| n.to_string_lossy().into_owned(),
    );
    let tags: Vec<&str> = project.tags.iter().map(|t| t.name.as_str()).collect();
    let (text, error) = match std::fs::read_to_string(path) {
        Ok(t) => (t, None),
        Err(e) => (
            String::new(),
            Some(format!("cannot read {}: {e}", path.display())),
        ),
    };
    let mut lines = annotate(&text, program.kind, &tags);
    for r in plan.rungs.iter().filter(|r| r.rung.pos.file == *path) {
        let at = (r.rung.pos.line as usize).saturating_sub(1);
        let Some(line) = lines.get_mut(at) else {
            continue;
        };
        let mark = match &r.placement {
            Placement::Module(p) => RungMark {
                coil: r.rung.coil.index(),
                module: project.modules.get(p.module).map(|m| m.name.clone()),
                feature: Some(p.feature.name().to_owned()),
                central: None,
                title: r.rung.title.clone(),
            },
            Placement::Central(reason) => RungMark {
                coil: r.rung.coil.index(),
                module: None,
                feature: None,
                central: Some(reason.to_string()),
                title: r.rung.title.clone(),
            },
        };
        line.rungs.push(mark);
    }
    let (diagram, no_diagram) = match program.kind {
        ProgramKind::Ladder if error.is_none() => match ladder_diagram(project, path, &text) {
            Ok(d) => (Some(d), None),
            Err(why) => (None, Some(why)),
        },
        _ => (None, None),
    };
    ProgramView {
        file,
        task: None,
        inst_base,
        kind,
        lines,
        diagram,
        no_diagram,
        error,
    }
}

/// The diagram of the ladder program `text` (the file `path`), or why there is none (the
/// file changed since the scan compiled it and no longer compiles: the page then shows the
/// text).
fn ladder_diagram(
    project: &Project,
    path: &std::path::Path,
    text: &str,
) -> Result<Vec<RungDiagram>, String> {
    let tags = TagTable::new(project.tags.iter().enumerate().map(|(i, t)| {
        (
            t.name.clone(),
            TagId(i as u32),
            t.ty,
            load::writable(project, i),
        )
    }));
    let own = crate::logic::OwnBlocks::declared(project);
    ladder::diagram(text, path, &tags, &own).map_err(|errors| {
        let first = errors.first().map(ToString::to_string).unwrap_or_default();
        format!("no diagram: the file no longer compiles ({first})")
    })
}

/// Cuts `text` (a program of `kind`) into lines of parts, recognising the names in `tags`.
pub(crate) fn annotate(text: &str, kind: ProgramKind, tags: &[&str]) -> Vec<Line> {
    let line_comment: &[char] = match kind {
        ProgramKind::Expr | ProgramKind::Ladder => &['#'],
        ProgramKind::Rhai => &['/', '/'],
    };
    let block_comments = kind == ProgramKind::Rhai;
    let mut in_block = false;
    // Ladder: the top-level key the line is under (`rungs`, `description`, ...).
    let mut in_rungs = kind != ProgramKind::Ladder;
    // Ladder: the column of a rung's `title:` or `comment:` whose value is a block (`|`,
    // `>`): the lines indented past it are its prose.
    let mut doc_block: Option<usize> = None;
    text.lines()
        .map(|line| {
            let chars: Vec<char> = line.chars().collect();
            if let Some(key) = doc_block {
                let indent = chars.iter().take_while(|c| **c == ' ').count();
                if line.trim().is_empty() || indent > key {
                    let mut cut = Cutter::default();
                    if !chars.is_empty() {
                        cut.piece("comment", &chars, 0, chars.len());
                    }
                    return cut.finish();
                }
                doc_block = None;
            }
            let mut tags_here = in_rungs;
            if kind == ProgramKind::Ladder && chars.first().is_some_and(|c| c.is_ascii_alphabetic())
            {
                if let Some((key, _)) = line.split_once(':') {
                    in_rungs = key.trim() == "rungs";
                    tags_here = false;
                }
            }
            let mut cut = Cutter::default();
            let mut i = 0;
            while i < chars.len() {
                let at = |pat: &[char]| chars.get(i..i + pat.len()) == Some(pat);
                let c = chars.get(i).copied().unwrap_or(' ');
                if in_block {
                    let mut j = i;
                    while j < chars.len() && chars.get(j..j + 2) != Some(&['*', '/'][..]) {
                        j += 1;
                    }
                    in_block = j >= chars.len();
                    let end = (j + 2).min(chars.len());
                    cut.piece("comment", &chars, i, end);
                    i = end;
                } else if at(line_comment) {
                    cut.piece("comment", &chars, i, chars.len());
                    i = chars.len();
                } else if block_comments && at(&['/', '*']) {
                    in_block = true;
                    cut.piece("comment", &chars, i, i + 2);
                    i += 2;
                } else if c == '"' || (c == '\'' && kind != ProgramKind::Ladder) || c == '`' {
                    let mut j = i + 1;
                    while j < chars.len() && chars.get(j) != Some(&c) {
                        j += if chars.get(j) == Some(&'\\') { 2 } else { 1 };
                    }
                    let end = (j + 1).min(chars.len());
                    cut.piece("string", &chars, i, end);
                    i = end;
                } else if c.is_ascii_alphabetic() || c == '_' {
                    let mut j = i;
                    while chars
                        .get(j)
                        .is_some_and(|c| c.is_ascii_alphanumeric() || *c == '_')
                    {
                        j += 1;
                    }
                    let word: String = chars.get(i..j).unwrap_or_default().iter().collect();
                    // A rung's title and comment are prose, shown as comments are: the
                    // value to the end of the line, or of the entry in a flow mapping.
                    let doc_key = matches!(word.as_str(), "title" | "comment");
                    if kind == ProgramKind::Ladder
                        && tags_here
                        && doc_key
                        && chars.get(j) == Some(&':')
                    {
                        let flow = chars.get(..i).is_some_and(|b| b.contains(&'{'));
                        let end = if flow {
                            (j..chars.len())
                                .find(|&k| matches!(chars.get(k), Some(',' | '}')))
                                .unwrap_or(chars.len())
                        } else {
                            chars.len()
                        };
                        let value: String =
                            chars.get(j + 1..end).unwrap_or_default().iter().collect();
                        if value.trim_start().starts_with(['|', '>']) {
                            doc_block = Some(i);
                        }
                        cut.piece("comment", &chars, i, end);
                        i = end;
                        continue;
                    }
                    // `jam.Q`, `x.motor` and `jam(5s)` name blocks and members, not tags.
                    let member = i > 0 && chars.get(i - 1) == Some(&'.');
                    let instance = matches!(chars.get(j), Some('(' | '.'));
                    match tags.iter().position(|t| *t == word) {
                        Some(t) if tags_here && !member && !instance => cut.tag(word, t),
                        _ => cut.code.push_str(&word),
                    }
                    i = j;
                } else {
                    cut.code.push(c);
                    i += 1;
                }
            }
            cut.finish()
        })
        .collect()
}

/// Builds one line's parts, gathering plain code between the other pieces.
#[derive(Debug, Default)]
struct Cutter {
    line: Line,
    code: String,
}

impl Cutter {
    fn flush(&mut self) {
        if !self.code.is_empty() {
            self.line.parts.push(Part {
                k: "code",
                s: std::mem::take(&mut self.code),
                tag: None,
            });
        }
    }

    fn piece(&mut self, k: &'static str, chars: &[char], from: usize, to: usize) {
        self.flush();
        self.line.parts.push(Part {
            k,
            s: chars.get(from..to).unwrap_or_default().iter().collect(),
            tag: None,
        });
    }

    fn tag(&mut self, name: String, tag: usize) {
        self.flush();
        self.line.parts.push(Part {
            k: "tag",
            s: name,
            tag: Some(tag),
        });
    }

    fn finish(mut self) -> Line {
        self.flush();
        self.line
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn show(lines: &[Line]) -> Vec<String> {
        lines
            .iter()
            .map(|l| {
                l.parts
                    .iter()
                    .map(|p| match p.k {
                        "tag" => format!("[{}]", p.s),
                        "comment" => format!("{{{}}}", p.s),
                        "string" => format!("<{}>", p.s),
                        _ => p.s.clone(),
                    })
                    .collect()
            })
            .collect()
    }

    const TAGS: &[&str] = &["start", "stop", "motor", "box_at_exit", "jam"];

    #[test]
    fn expr_lines() {
        let lines = annotate(
            "# start the motor\nmotor = (rising(start) | motor) & !stop & !box_at_exit\n",
            ProgramKind::Expr,
            TAGS,
        );
        assert_eq!(
            show(&lines),
            [
                "{# start the motor}",
                "[motor] = (rising([start]) | [motor]) & ![stop] & ![box_at_exit]",
            ]
        );
    }

    #[test]
    fn ladder_members_and_calls_are_not_tags() {
        let lines = annotate(
            "description: >\n  the motor stops\nrungs:\n  - motor jam.Q -> TON jam(5s) -> stop  # a jam\n",
            ProgramKind::Ladder,
            TAGS,
        );
        assert_eq!(
            show(&lines),
            [
                "description: >",
                "  the motor stops",
                "rungs:",
                "  - [motor] jam.Q -> TON jam(5s) -> [stop]  {# a jam}"
            ]
        );
    }

    #[test]
    fn a_rungs_title_and_comment_are_prose_not_tags() {
        let lines = annotate(
            "rungs:\n  - rung: motor -> stop\n    title: Stop motor\n    comment: |\n      start\n\n      jam\n  - { rung: jam -> stop, title: The jam, comment: motor }\n  - start -> motor\n",
            ProgramKind::Ladder,
            TAGS,
        );
        assert_eq!(
            show(&lines),
            [
                "rungs:",
                "  - rung: [motor] -> [stop]",
                "    {title: Stop motor}",
                "    {comment: |}",
                "{      start}",
                "",
                "{      jam}",
                "  - { rung: [jam] -> [stop], {title: The jam}, {comment: motor }}",
                "  - [start] -> [motor]",
            ]
        );
    }

    #[test]
    fn rhai_strings_and_comments() {
        let lines = annotate(
            "motor = ton(\"motor\", start, \"5s\"); // motor\n/* stop\nstop */ stop = false;\n",
            ProgramKind::Rhai,
            TAGS,
        );
        assert_eq!(
            show(&lines),
            [
                "[motor] = ton(<\"motor\">, [start], <\"5s\">); {// motor}",
                "{/*}{ stop}",
                "{stop */} [stop] = false;",
            ]
        );
        // Unterminated strings and odd characters do not panic.
        annotate("\"abc\\\nµ'x\n/*", ProgramKind::Rhai, TAGS);
    }
}
