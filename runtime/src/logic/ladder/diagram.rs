//! The ladder diagram of each rung, for a page that draws it: series and parallel elements
//! (contacts, edges, comparisons, quality tests), then the coils, math boxes or the function
//! block the power flow drives, each with the tag or instance it names so live values can
//! light it.
//!
//! Built from the parser's tree of a program that passed the checker (the same front end the
//! compiler lowers), so what is drawn is what runs; names are resolved to tag indexes and
//! instance indexes (the order of `LadderProgram`'s instances).

use std::path::Path;

use serde::Serialize;

use super::check::{param_list, Instances};
use super::error::CompileError;
use super::parser::{self, Action, Arg, Cond, Lit, Ref};
use super::{front, CoilKind, Front};
use crate::logic::expr::TagTable;
use crate::logic::user_blocks::{Found, OwnBlocks};
use crate::project::DocText;
use crate::project::{ProgramKind, UserBlock, VarRole};

/// A value as a diagram shows it: a tag, an instance's output or a literal.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "k", rename_all = "snake_case")]
pub enum Operand {
    /// A tag: its name and index in the project's tags.
    Tag {
        /// Its name.
        name: String,
        /// Its index.
        tag: usize,
    },
    /// `instance.MEMBER`.
    Member {
        /// The instance's name.
        instance: String,
        /// Its index among the program's instances.
        inst: u32,
        /// `Q`, `ET`, `CV`, `QU` or `QD`.
        member: &'static str,
    },
    /// A literal as written: `80`, `1.5s`, `true`.
    Literal {
        /// Its text.
        text: String,
    },
}

/// One element of a rung's condition.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "k", rename_all = "snake_case")]
pub enum Element {
    /// A contact on a bool: `| |` (normally open) or `|/|` (normally closed, `negated`).
    Contact {
        /// What it reads.
        of: Operand,
        /// Normally closed.
        negated: bool,
    },
    /// `rising(..)` (P) or `falling(..)` (N) of a condition; a single contact's edge is a P/N
    /// contact on it.
    Edge {
        /// P when true, N when false.
        rising: bool,
        /// The condition whose edge passes power.
        of: Box<Element>,
        /// Normally closed: `/rising(x)`.
        negated: bool,
    },
    /// A comparison box: passes power while `lhs op rhs` holds (or does not, `negated`).
    Compare {
        /// Left operand.
        lhs: Operand,
        /// `<`, `<=`, `>`, `>=`, `==`, `!=`.
        op: &'static str,
        /// Right operand.
        rhs: Operand,
        /// Normally closed.
        negated: bool,
    },
    /// `good(tag)` / `bad(tag)`: a contact on the tag's quality.
    Quality {
        /// `good` (true) or `bad`.
        good: bool,
        /// The tag.
        of: Operand,
        /// Normally closed.
        negated: bool,
    },
    /// Elements one after the other.
    Series {
        /// Left to right.
        items: Vec<Element>,
    },
    /// Branches side by side.
    Parallel {
        /// Top to bottom.
        branches: Vec<Element>,
    },
    /// A negated group: `/(a | b)` passes power when the group does not.
    Not {
        /// The group.
        of: Box<Element>,
    },
}

/// A coil.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Coil {
    /// `normal` `( )`, `negated` `(/)`, `set` `(S)` or `reset` `(R)`.
    pub kind: &'static str,
    /// Its tag.
    pub of: Operand,
}

/// A math box: `OP(args) => dest`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct MathBox {
    /// `MOVE`, `ADD`, `SUB`, `MUL`, `DIV`, `LIMIT`.
    pub op: String,
    /// Its arguments, in order.
    pub args: Vec<Operand>,
    /// Where the result goes.
    pub dest: Operand,
}

/// What the power flow drives.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "k", rename_all = "snake_case")]
pub enum Output {
    /// A coil.
    Coil(Coil),
    /// A math box, computed while powered.
    Math(MathBox),
}

/// One input of a block besides the power flow.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "k", rename_all = "snake_case")]
pub enum BlockInput {
    /// A bool input (`R`, `LD`, `CD`): a condition wired into the block.
    Power {
        /// The parameter, upper case as the block's pin: `R`.
        pin: String,
        /// What drives it.
        of: Element,
    },
    /// A value (`PT`, `PV`, `ON`, ...).
    Value {
        /// The pin: `PT`.
        pin: String,
        /// The value.
        of: Operand,
    },
}

/// A function block fed by the rung's condition, its main output feeding the coils.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct BlockBox {
    /// `TON`, `CTU`, ..., or a block of one's own (`STATION`).
    pub kind: String,
    /// The instance's name.
    pub instance: String,
    /// Its index among the program's instances.
    pub inst: u32,
    /// The input the power flow feeds: `IN`, `CU`, `EN`, ... ([`crate::logic::blocks::Kind::main_input`]).
    pub input: String,
    /// Inputs besides the power flow, as given.
    pub inputs: Vec<BlockInput>,
    /// Its outputs: `Q`, `ET`, `CV`, `QU`, `QD`; a block of one's own's as declared.
    pub outputs: Vec<String>,
    /// The output passed along the rung: `Q` (`QU` for CTUD).
    pub main: String,
    /// The coils after it.
    pub coils: Vec<Coil>,
    /// A block of one's own: its instance's tags and its body.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub own: Option<OwnBox>,
}

/// What the page shows of an instance of a block of one's own: every variable's tag (its live
/// value) and the body, drawn with that instance's tags.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct OwnBox {
    /// Each variable (inputs, outputs, state) and the index of its tag `INSTANCE.VARIABLE`.
    pub tags: Vec<(String, usize)>,
    /// The body's file.
    pub body_file: String,
    /// `ladder` or `rhai`.
    pub body_kind: &'static str,
    /// A ladder body's rungs, over this instance's tags (a built-in block inside the body
    /// shows its outputs through the coils it drives).
    pub body: Vec<RungDiagram>,
    /// A Rhai body's text.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub body_text: Option<String>,
}

/// Instance indexes of a body's own built-in blocks start here, apart from the program's
/// (whose live outputs the page looks up by index).
const BODY_INSTANCES: u32 = 1 << 30;

/// One rung as a diagram.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct RungDiagram {
    /// Its first line in the file (1-based).
    pub line: u32,
    /// Its text.
    pub text: String,
    /// Its `title:`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub title: Option<String>,
    /// Its `comment:`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub comment: Option<String>,
    /// Its condition; `None` when always powered (`-> ...`).
    pub cond: Option<Element>,
    /// The block it calls, if any.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub block: Option<BlockBox>,
    /// Its coils and boxes (none when it calls a block: the block's coils are in `block`).
    pub outputs: Vec<Output>,
}

/// The diagram of each rung of a ladder program, in file order; the compiler's errors when it
/// does not compile.
pub fn diagram(
    source: &str,
    file: &Path,
    tags: &TagTable,
    own: &OwnBlocks,
) -> Result<Vec<RungDiagram>, Vec<CompileError>> {
    diagram_from(source, file, tags, own, 0, "")
}

/// [`diagram`] of a program or a body; `prefix` is the instance path of the body's instance
/// (`p1.`), which a nested instance's box is named under (`p1.la`).
fn diagram_from(
    source: &str,
    file: &Path,
    tags: &TagTable,
    own: &OwnBlocks,
    inst_base: u32,
    prefix: &str,
) -> Result<Vec<RungDiagram>, Vec<CompileError>> {
    let Front {
        src,
        parsed,
        instances,
        ..
    } = front(source, file, tags, own)?;
    let names = Names {
        tags,
        instances: &instances,
        own,
        inst_base,
        prefix,
    };
    Ok(parsed
        .iter()
        .map(|(i, rung)| {
            let (block, outputs) = match &rung.action {
                Action::Outputs(outs) => (None, outs.iter().map(|o| names.output(o)).collect()),
                Action::Block { call, coils } => (names.block(call, coils), Vec::new()),
            };
            let rung_text = src.rungs.get(*i);
            let doc = |d: Option<&DocText>| d.map(ToString::to_string);
            RungDiagram {
                line: src.position(*i, 0).0,
                text: rung_text.map(|r| r.text.clone()).unwrap_or_default(),
                title: doc(rung_text.and_then(|r| r.title.as_ref())),
                comment: doc(rung_text.and_then(|r| r.comment.as_ref())),
                cond: rung.cond.as_ref().map(|c| names.element(c)),
                block,
                outputs,
            }
        })
        .collect())
}

/// Resolves the names of a checked program.
struct Names<'a> {
    tags: &'a TagTable,
    instances: &'a Instances,
    own: &'a OwnBlocks,
    /// Added to every instance index (a body's, see [`BODY_INSTANCES`]).
    inst_base: u32,
    /// The instance path a body's nested instances are named under (`p1.`); empty for the
    /// program.
    prefix: &'a str,
}

impl Names<'_> {
    fn operand(&self, c: &Cond) -> Operand {
        match c {
            Cond::Ref(r) => self.reference(r),
            Cond::Lit(lit, _) => Operand::Literal {
                text: match lit {
                    Lit::Number { text, .. } | Lit::Duration { text } => text.clone(),
                    Lit::Bool(b) => b.to_string(),
                },
            },
            // The checker accepts only names and literals as values; nothing else gets here.
            _ => Operand::Literal { text: "?".into() },
        }
    }

    fn reference(&self, r: &Ref) -> Operand {
        match &r.member {
            // An instance of a block of one's own: its variables are tags.
            Some(member)
                if self
                    .tags
                    .get(&format!("{}.{}", r.name.text, member.text))
                    .is_some() =>
            {
                self.tag(&format!("{}.{}", r.name.text, member.text))
            }
            Some(member) => Operand::Member {
                instance: r.name.text.clone(),
                inst: self.inst_base + self.instances.get(&r.name.text).map_or(0, |(i, _)| i),
                member: crate::logic::blocks::Member::parse(&member.text).map_or("Q", |m| m.name()),
            },
            None => self.tag(&r.name.text),
        }
    }

    fn tag(&self, name: &str) -> Operand {
        Operand::Tag {
            name: name.to_owned(),
            tag: self.tags.get(name).map_or(0, |t| t.id.0 as usize),
        }
    }

    /// `c`, normally closed when `negated`.
    fn contact(&self, c: &Cond, negated: bool) -> Element {
        match c {
            Cond::Ref(_) | Cond::Lit(..) => Element::Contact {
                of: self.operand(c),
                negated,
            },
            Cond::Not(inner) => self.contact(inner, !negated),
            Cond::Edge { rising, arg } => Element::Edge {
                rising: *rising,
                of: Box::new(self.element(arg)),
                negated,
            },
            Cond::Cmp { lhs, op, rhs, .. } => Element::Compare {
                lhs: self.operand(lhs),
                op: op.symbol(),
                rhs: self.operand(rhs),
                negated,
            },
            Cond::Quality { good, tag, .. } => Element::Quality {
                good: *good,
                of: self.tag(&tag.text),
                negated,
            },
            Cond::Series(_) | Cond::Parallel(_) if negated => Element::Not {
                of: Box::new(self.element(c)),
            },
            Cond::Series(items) => Element::Series {
                items: items.iter().map(|i| self.element(i)).collect(),
            },
            Cond::Parallel(items) => Element::Parallel {
                branches: items.iter().map(|i| self.element(i)).collect(),
            },
        }
    }

    fn element(&self, c: &Cond) -> Element {
        self.contact(c, false)
    }

    fn coil(&self, c: &parser::Coil) -> Coil {
        Coil {
            kind: match c.kind {
                CoilKind::Normal => "normal",
                CoilKind::Negated => "negated",
                CoilKind::Set => "set",
                CoilKind::Reset => "reset",
            },
            of: self.tag(&c.name.text),
        }
    }

    fn output(&self, o: &parser::Output) -> Output {
        match o {
            parser::Output::Coil(c) => Output::Coil(self.coil(c)),
            parser::Output::Box(b) => Output::Math(MathBox {
                op: b.op.text.clone(),
                args: b.args.iter().map(|a| self.operand(&a.value)).collect(),
                dest: self.tag(&b.dest.text),
            }),
        }
    }

    fn block(&self, call: &parser::BlockCall, coils: &[parser::Coil]) -> Option<BlockBox> {
        if let Some(Found::Own(block)) = self.own.find(&call.kind.text) {
            return self.own_block(block, call, coils);
        }
        let (inst, kind) = self.instances.get(&call.instance.text)?;
        let params: Vec<(&str, bool, bool)> = param_list(kind).collect();
        let mut positional = params.iter().filter(|p| p.2);
        let inputs = call
            .args
            .iter()
            .filter_map(|Arg { name, value }| {
                let (pin, is_bool, _) = match name {
                    Some(n) => *params.iter().find(|p| p.0.eq_ignore_ascii_case(&n.text))?,
                    None => *positional.next()?,
                };
                Some(self.input(pin.to_string(), is_bool, value))
            })
            .collect();
        Some(BlockBox {
            kind: kind.name().to_owned(),
            instance: call.instance.text.clone(),
            inst: self.inst_base + inst,
            input: kind.main_input().to_owned(),
            inputs,
            outputs: kind.outputs().iter().map(|m| m.name().to_owned()).collect(),
            main: kind.main_output().name().to_owned(),
            coils: coils.iter().map(|c| self.coil(c)).collect(),
            own: None,
        })
    }

    /// A block's input as a call gives it: a bool wired in, or a value written at its pin.
    fn input(&self, pin: String, is_bool: bool, value: &Cond) -> BlockInput {
        if is_bool {
            BlockInput::Power {
                pin,
                of: self.element(value),
            }
        } else {
            BlockInput::Value {
                pin,
                of: self.operand(value),
            }
        }
    }

    /// A call of a block of one's own: its inputs as the call gives them, its outputs, and its
    /// instance's tags and body.
    fn own_block(
        &self,
        block: &UserBlock,
        call: &parser::BlockCall,
        coils: &[parser::Coil],
    ) -> Option<BlockBox> {
        let instance = &call.instance.text;
        let mut positional = block.inputs.iter().skip(1);
        let inputs = call
            .args
            .iter()
            .filter_map(|Arg { name, value }| {
                let var = match name {
                    Some(n) => block.inputs.iter().skip(1).find(|v| v.name == n.text)?,
                    None => positional.next()?,
                };
                let is_bool = var.ty == softplc_io::point::ValueType::Bool;
                Some(self.input(var.name.clone(), is_bool, value))
            })
            .collect();
        let tag_of = |var: &str| self.tags.get(&format!("{instance}.{var}")).map(|t| t.id);
        let tree = block.tree(&self.own.blocks);
        let table = TagTable::new(tree.iter().filter_map(|v| {
            let id = tag_of(&v.name)?;
            Some((
                v.name.clone(),
                id,
                v.var.ty,
                v.own && v.role != VarRole::Input,
            ))
        }));
        let text = std::fs::read_to_string(&block.body).unwrap_or_default();
        let (body_kind, body, body_text) = match block.body_kind {
            ProgramKind::Ladder => {
                let own = OwnBlocks::for_body(&self.own.blocks, block);
                let path = format!("{}{instance}.", self.prefix);
                let body = diagram_from(&text, &block.body, &table, &own, BODY_INSTANCES, &path)
                    .unwrap_or_default();
                ("ladder", body, None)
            }
            _ => ("rhai", Vec::new(), Some(text)),
        };
        Some(BlockBox {
            kind: block.name.clone(),
            instance: format!("{}{instance}", self.prefix),
            inst: u32::MAX,
            input: block
                .inputs
                .first()
                .map(|v| v.name.clone())
                .unwrap_or_default(),
            inputs,
            outputs: block.outputs.iter().map(|v| v.name.clone()).collect(),
            main: block
                .outputs
                .first()
                .map(|v| v.name.clone())
                .unwrap_or_default(),
            coils: coils.iter().map(|c| self.coil(c)).collect(),
            own: Some(OwnBox {
                tags: tree
                    .iter()
                    .filter_map(|v| Some((v.name.clone(), tag_of(&v.name)?.index())))
                    .collect(),
                body_file: block.body.display().to_string(),
                body_kind,
                body,
                body_text,
            }),
        })
    }
}

#[cfg(test)]
mod tests {
    use softplc_io::point::ValueType;

    use super::*;
    use crate::image::TagId;

    fn tags() -> TagTable {
        let names = ["start", "stop", "motor", "level", "reset", "count", "lamp"];
        TagTable::new(names.iter().enumerate().map(|(i, n)| {
            let ty = if matches!(*n, "level" | "count") {
                ValueType::F32
            } else {
                ValueType::Bool
            };
            (n.to_string(), TagId(i as u32), ty, true)
        }))
    }

    fn draw(rungs: &str) -> Vec<RungDiagram> {
        let text = format!("description: x\nrungs:\n{rungs}");
        diagram(
            &text,
            Path::new("p.ladder.yaml"),
            &tags(),
            &OwnBlocks::none(),
        )
        .unwrap_or_else(|e| panic!("{e:?}"))
    }

    fn tag(name: &str, tag: usize) -> Operand {
        Operand::Tag {
            name: name.into(),
            tag,
        }
    }

    fn no(name: &str, t: usize) -> Element {
        Element::Contact {
            of: tag(name, t),
            negated: false,
        }
    }

    #[test]
    fn contacts_branches_and_coils() {
        let d = draw("  - (rising(start) | motor) /stop -> motor, set lamp\n");
        assert_eq!(d.len(), 1);
        assert_eq!(d[0].line, 3);
        assert_eq!(
            d[0].text,
            "(rising(start) | motor) /stop -> motor, set lamp"
        );
        assert_eq!(
            d[0].cond,
            Some(Element::Series {
                items: vec![
                    Element::Parallel {
                        branches: vec![
                            Element::Edge {
                                rising: true,
                                of: Box::new(no("start", 0)),
                                negated: false
                            },
                            no("motor", 2),
                        ]
                    },
                    Element::Contact {
                        of: tag("stop", 1),
                        negated: true
                    },
                ]
            })
        );
        assert_eq!(
            d[0].outputs,
            vec![
                Output::Coil(Coil {
                    kind: "normal",
                    of: tag("motor", 2)
                }),
                Output::Coil(Coil {
                    kind: "set",
                    of: tag("lamp", 6)
                }),
            ]
        );
        assert_eq!(d[0].block, None);
    }

    #[test]
    fn blocks_comparisons_and_boxes() {
        let d = draw(
            "  - motor -> TON t(5s)\n  - start -> CTU n(10, r=reset) -> /lamp\n  - t.Q level >= 80 /(start | stop) -> ADD(count, 1) => count\n  - -> reset motor\n",
        );
        let ton = d[0].block.as_ref().unwrap();
        assert_eq!(
            (ton.kind.as_str(), ton.instance.as_str(), ton.inst),
            ("TON", "t", 0)
        );
        assert_eq!(
            ton.inputs,
            vec![BlockInput::Value {
                pin: "PT".into(),
                of: Operand::Literal { text: "5s".into() }
            }]
        );
        assert_eq!(ton.outputs, ["Q", "ET"]);
        let ctu = d[1].block.as_ref().unwrap();
        assert_eq!(
            (ctu.kind.as_str(), ctu.inst, ctu.main.as_str()),
            ("CTU", 1, "Q")
        );
        assert_eq!(
            ctu.inputs[1],
            BlockInput::Power {
                pin: "R".into(),
                of: no("reset", 4)
            }
        );
        assert_eq!(ctu.coils[0].kind, "negated");
        let Some(Element::Series { items }) = &d[2].cond else {
            panic!("a series: {:?}", d[2].cond)
        };
        assert_eq!(
            items[0],
            Element::Contact {
                of: Operand::Member {
                    instance: "t".into(),
                    inst: 0,
                    member: "Q"
                },
                negated: false
            }
        );
        assert_eq!(
            items[1],
            Element::Compare {
                lhs: tag("level", 3),
                op: ">=",
                rhs: Operand::Literal { text: "80".into() },
                negated: false
            }
        );
        assert!(
            matches!(&items[2], Element::Not { of } if matches!(**of, Element::Parallel { .. }))
        );
        assert_eq!(
            d[2].outputs,
            vec![Output::Math(MathBox {
                op: "ADD".into(),
                args: vec![tag("count", 5), Operand::Literal { text: "1".into() }],
                dest: tag("count", 5)
            })]
        );
        assert_eq!(d[3].cond, None);
    }

    /// The JSON the page's ladder.js reads: every element and operand tagged by `k`.
    #[test]
    fn the_json_the_page_reads() {
        let d = draw("  - /rising(start) t.ET > 2s -> TON t(5s) -> lamp\n");
        let json = serde_json::to_value(&d[0]).unwrap();
        assert_eq!(
            json,
            serde_json::json!({
                "line": 3,
                "text": "/rising(start) t.ET > 2s -> TON t(5s) -> lamp",
                "cond": {"k": "series", "items": [
                    {"k": "edge", "rising": true, "negated": true,
                     "of": {"k": "contact", "negated": false,
                            "of": {"k": "tag", "name": "start", "tag": 0}}},
                    {"k": "compare", "op": ">", "negated": false,
                     "lhs": {"k": "member", "instance": "t", "inst": 0, "member": "ET"},
                     "rhs": {"k": "literal", "text": "2s"}},
                ]},
                "block": {"kind": "TON", "instance": "t", "inst": 0, "input": "IN",
                          "inputs": [{"k": "value", "pin": "PT", "of": {"k": "literal", "text": "5s"}}],
                          "outputs": ["Q", "ET"], "main": "Q",
                          "coils": [{"kind": "normal", "of": {"k": "tag", "name": "lamp", "tag": 6}}]},
                "outputs": [],
            })
        );
    }

    #[test]
    fn each_block_names_the_input_its_rung_feeds_as_the_docs_do() {
        // docs/programming.md, the block table's second column.
        for (rung, input) in [
            ("start -> BLINK b(500ms, 250ms)", "EN"),
            ("start -> CTU c(10)", "CU"),
            ("start -> CTD c(10)", "CD"),
            ("start -> R_TRIG e", "CLK"),
            ("start -> SR l(r=stop)", "S1"),
            ("start -> RS l(r=stop)", "S"),
            ("start -> TOF t(1s)", "IN"),
        ] {
            let text = format!("rungs:\n  - {rung}\n");
            let d = diagram(&text, Path::new("p.yaml"), &tags(), &OwnBlocks::none()).unwrap();
            let block = d[0].block.as_ref().unwrap();
            assert_eq!(block.input, input, "{rung}");
        }
    }

    #[test]
    fn a_program_that_does_not_compile_has_no_diagram() {
        let text = "rungs:\n  - strat -> motor\n";
        let err = diagram(text, Path::new("p.yaml"), &tags(), &OwnBlocks::none()).unwrap_err();
        assert_eq!(
            err[0].to_string(),
            "p.yaml:2:5: error: unknown tag `strat`; did you mean `start`?"
        );
    }
}
