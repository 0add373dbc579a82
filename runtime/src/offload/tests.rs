//! The planner's decisions, rung by rung: every reason a rung stays central, and the tables of
//! the rungs it pushes down (the equivalence of those is tested end to end in
//! `tests/tests/offload_equivalence.rs`).

use std::path::PathBuf;
use std::time::Duration;

use super::planner::{plan, Command, Feature, ModulePlacement, Placement, Plan, Reason};
use crate::image::TagId;
use crate::logic::Rung;
use crate::logic::SourcePos;
use crate::project::{parse_str, Project};
use softplc_io::rung::{BoolExpr, RungShape};

/// A project on one simulated line: `modules` and `tags` are YAML flow entries; tag `i` is
/// `TagId(i)`.
fn project(offload: &str, modules: &[&str], tags: &[&str]) -> Project {
    parse_project(offload, modules, tags).unwrap_or_else(|e| panic!("{e}"))
}

/// [`project`], or the errors.
fn parse_project(
    offload: &str,
    modules: &[&str],
    tags: &[&str],
) -> Result<Project, crate::project::ProjectErrors> {
    let mut text = format!(
        "project: t\nscan: {{ period: 50ms }}\noffload: {offload}\n\
         buses: [ {{ name: line1, port: sim }} ]\nmodules:\n"
    );
    for m in modules {
        text.push_str(&format!("  - {{ bus: line1, {m} }}\n"));
    }
    text.push_str("tags:\n");
    for t in tags {
        text.push_str(&format!("  - {{ {t} }}\n"));
    }
    text.push_str("program: { file: conveyor.expr, kind: expr }\n");
    let file =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/projects/inline.yaml");
    parse_str(&text, &file)
}

fn t(i: u32) -> BoolExpr {
    BoolExpr::Tag(TagId(i))
}

fn rung(coil: u32, shape: RungShape) -> Rung {
    Rung {
        coil: TagId(coil),
        shape,
        pos: SourcePos {
            file: "p.expr".into(),
            line: coil + 1,
            column: 1,
        },
        title: None,
    }
}

/// The placement of each rung.
fn placements(p: &Project, rungs: Vec<Rung>) -> Vec<Placement> {
    plan(p, Some(rungs), "expr")
        .rungs
        .into_iter()
        .map(|r| r.placement)
        .collect()
}

fn module(p: &Placement) -> &ModulePlacement {
    match p {
        Placement::Module(m) => m,
        Placement::Central(r) => panic!("central: {r}"),
    }
}

fn reason(p: &Placement) -> &Reason {
    match p {
        Placement::Central(r) => r,
        Placement::Module(m) => panic!("in a module: {m:?}"),
    }
}

const MM: &str = "name: mm1, model: minimod, address: 1";
const MM_TAGS: [&str; 5] = [
    "name: a, point: mm1.X1",
    "name: b, point: mm1.X2",
    "name: c, point: mm1.X3",
    "name: y, point: mm1.Y1",
    "name: z, point: mm1.Y2",
];

/// What the plan makes module 0's driver write at start-up, as `NAME: value`.
fn given(p: &Project, pl: &Plan) -> Vec<String> {
    pl.push_down
        .first()
        .map(|push| super::report::push_down_settings(p, 0, push))
        .unwrap_or_default()
}

#[test]
fn minimod_conditions_and_their_limits() {
    let p = project("auto", &[MM], &MM_TAGS);
    let parity = BoolExpr::Xor(vec![t(0), t(1), t(2)]);
    let out = placements(
        &p,
        vec![
            rung(
                3,
                RungShape::Latch {
                    set: t(0),
                    reset: t(1),
                    reset_dominant: false,
                },
            ),
            rung(4, RungShape::Combinational { expr: parity }),
        ],
    );
    // Set dominant: OFF = b & !a, ON = a.
    let m = module(&out[0]);
    assert_eq!(m.feature, Feature::AutoOnOff);
    let regs: Vec<(&str, u32)> = m.tables.iter().map(|e| (e.register, e.value)).collect();
    assert_eq!(
        regs,
        vec![
            ("Y1AON1", 0x0001),
            ("Y1AON2", 0),
            ("Y1AON3", 0),
            ("Y1AOFF1", 0x0103),
            ("Y1AOFF2", 0),
            ("Y1AOFF3", 0)
        ]
    );
    assert_eq!(m.tables[3].meaning, "-X1X2");
    // Parity: OFF needs all four of its terms; ON, free where OFF holds, two.
    assert_eq!(reason(&out[1]), &Reason::TooManyTerms { on: 2, off: 4 });
    // The module gets its read-back.
    let pl = plan(
        &p,
        Some(vec![rung(3, RungShape::Combinational { expr: t(0) })]),
        "expr",
    );
    assert!(given(&p, &pl).contains(&"readback: every".into()));
}

#[test]
fn minimod_pulses() {
    let p = project("auto", &[MM], &MM_TAGS);
    let pulse = |coil, trigger: BoolExpr, ms| {
        rung(
            coil,
            RungShape::Pulse {
                trigger: vec![trigger],
                width: Duration::from_micros(ms),
            },
        )
    };
    let out = placements(&p, vec![pulse(3, t(0), 50_000), pulse(4, t(0), 50_500)]);
    let m = module(&out[0]);
    assert_eq!(m.feature, Feature::Pulser);
    assert!(matches!(
        m.command,
        Some(Command::Pulse { width_ms, .. }) if width_ms.ms() == 50
    ));
    assert!(matches!(reason(&out[1]), Reason::Time { .. }));
    let out = placements(&p, vec![pulse(3, t(4), 50_000), pulse(4, t(0), 70_000_000)]);
    assert!(matches!(reason(&out[0]), Reason::TriggerReadsLater { tag } if tag == "z"));
    assert!(matches!(reason(&out[1]), Reason::Time { .. }));
}

#[test]
fn why_rungs_stay_central() {
    let p = project(
        "auto",
        &[
            MM,
            "name: mm2, model: minimod, address: 2",
            "name: mm3, model: minimod, address: 3, protocol: text",
            "name: mm4, model: minimod, address: 4, settings: { Y1AOFF2: 0 }",
            "name: co, model: resi-8co, address: 5",
        ],
        &[
            "name: a, point: mm1.X1",
            "name: fb, point: mm1.X9",
            "name: other, point: mm2.X1",
            "name: m, type: bool",
            "name: y1, point: mm1.Y1",
            "name: y2, point: mm1.Y2",
            "name: y3, point: mm1.Y3",
            "name: t3, point: mm3.Y1",
            "name: t4, point: mm4.Y1",
            "name: relay, point: co.RO1",
            "name: s, point: mm1.Y4, scada: write",
            "name: x3, point: mm3.X1",
        ],
    );
    let comb = |coil, e| rung(coil, RungShape::Combinational { expr: e });
    let out = placements(
        &p,
        vec![
            comb(4, t(2)),
            comb(5, t(1)),
            comb(6, t(3)),
            comb(3, t(0)),
            comb(7, t(11)),
            comb(8, BoolExpr::Const(true)),
            comb(9, t(0)),
            comb(10, t(0)),
            rung(
                6,
                RungShape::Opaque {
                    reason: "a timer".into(),
                },
            ),
        ],
    );
    assert!(matches!(reason(&out[0]), Reason::OtherModule { module, .. } if module == "mm2"));
    assert!(matches!(
        reason(&out[1]),
        Reason::NotCheckable { point: "X9", .. }
    ));
    assert!(
        matches!(reason(&out[2]), Reason::WrittenElsewhere { .. }),
        "y3 twice"
    );
    assert!(matches!(reason(&out[3]), Reason::NotAnOutput { .. }));
    assert!(matches!(reason(&out[4]), Reason::NotVerifiable { .. }));
    assert!(matches!(reason(&out[5]), Reason::SettingTaken { register } if register == "Y1AOFF2"));
    assert!(matches!(
        reason(&out[6]),
        Reason::NoTables {
            model: "resi-8co",
            ..
        }
    ));
    assert!(matches!(reason(&out[7]), Reason::WrittenElsewhere { by } if by.contains("SCADA")));
    assert_eq!(
        reason(&out[8]),
        &Reason::WrittenElsewhere {
            by: "another rung of the program at p.expr:7:1".into()
        }
    );
    // The report says every reason, one rung per line.
    let pl = plan(&p, Some(vec![comb(4, t(2))]), "expr");
    let text = super::report::report(&p, &pl);
    assert!(
        text.contains("central: an input from another module: other is on mm2"),
        "{text}"
    );
}

#[test]
fn modes_and_silent_engines() {
    let p = project("never", &[MM], &MM_TAGS);
    let out = placements(&p, vec![rung(3, RungShape::Combinational { expr: t(0) })]);
    assert!(matches!(
        reason(&out[0]),
        Reason::Never {
            by_tag: false,
            would: Some(_)
        }
    ));
    let pl = plan(&p, None, "rhai");
    assert_eq!(pl.silent_engine, Some("rhai"));
    let text = super::report::report(&p, &pl);
    assert!(
        text.contains("engine rhai does not describe its rungs"),
        "{text}"
    );

    let mut tags = MM_TAGS.to_vec();
    tags[3] = "name: y, point: mm1.Y1, offload: require";
    let p = project("never", &[MM], &tags);
    let pl = plan(
        &p,
        Some(vec![rung(
            3,
            RungShape::Opaque {
                reason: "a timer".into(),
            },
        )]),
        "expr",
    );
    let f = pl.require_failures();
    assert_eq!(f.len(), 1);
    assert_eq!(
        f[0].to_string(),
        "p.expr:4:1: error: offload: require: the rung writing y stays central: a timer"
    );
}

const RESI: &str = "name: r1, model: resi-16di8ro, address: 1";
const RESI_TAGS: [&str; 6] = [
    "name: a, point: r1.DI1",
    "name: b, point: r1.DI16",
    "name: q1, point: r1.RO1",
    "name: q2, point: r1.RO2",
    "name: q3, point: r1.RO3",
    "name: q4, point: r1.RO4",
];

#[test]
fn resi_functions() {
    let p = project("auto", &[RESI], &RESI_TAGS);
    let out = placements(
        &p,
        vec![
            rung(
                2,
                RungShape::StairPulse {
                    trigger: vec![t(0), t(1)],
                    time: Duration::from_secs(30),
                },
            ),
            rung(
                3,
                RungShape::EdgeSetReset {
                    set: vec![t(0)],
                    reset: vec![t(1)],
                },
            ),
            rung(
                4,
                RungShape::Combinational {
                    expr: BoolExpr::And(vec![t(0), t(1)]),
                },
            ),
            rung(
                5,
                RungShape::StairPulse {
                    trigger: vec![t(0)],
                    time: Duration::from_millis(150),
                },
            ),
        ],
    );
    let m = module(&out[0]);
    assert_eq!(m.feature, Feature::Pulse);
    let regs: Vec<(&str, u32)> = m
        .tables
        .iter()
        .filter(|e| e.value != 0)
        .map(|e| (e.register, e.value))
        .collect();
    assert_eq!(regs, vec![("PULSE_RO1", 0x8001), ("PULSE_TIME_RO1", 300)]);
    let m = module(&out[1]);
    assert_eq!(m.feature, Feature::SwitchOnOff);
    assert!(matches!(reason(&out[2]), Reason::Unsupported { .. }));
    assert!(matches!(reason(&out[3]), Reason::Time { .. }));
    let pl = plan(
        &p,
        Some(vec![rung(
            2,
            RungShape::Toggle {
                trigger: vec![t(0)],
            },
        )]),
        "expr",
    );
    assert!(given(&p, &pl).contains(&"TOGGLE_RO1: 1".into()));
    assert!(given(&p, &pl).contains(&"ENABLE_LOGIC_FUNCTIONS: 1".into()));
}

#[test]
fn outputs_that_keep_a_state_get_their_start_value_before_their_tables() {
    // An output tag starts off (`initial` is for memory tags), as the central rung does.
    let p = project("auto", &[MM], &MM_TAGS);
    let latch = RungShape::Latch {
        set: t(0),
        reset: t(1),
        reset_dominant: true,
    };
    let pl = plan(
        &p,
        Some(vec![
            rung(3, latch),
            rung(4, RungShape::Combinational { expr: t(2) }),
        ]),
        "expr",
    );
    let initial: Vec<Option<bool>> = pl.pushed().map(|(_, m)| m.initial).collect();
    assert_eq!(
        initial,
        [Some(false), None],
        "a latch, then a combinational rung"
    );
    assert!(given(&p, &pl).contains(&"initial Y1: 0".into()));
    assert!(!given(&p, &pl).iter().any(|s| s.starts_with("initial Y2")));
    // A pulse starts with no pulse running.
    let pulse = RungShape::Pulse {
        trigger: vec![t(0)],
        width: Duration::from_millis(50),
    };
    let pl = plan(&p, Some(vec![rung(3, pulse)]), "expr");
    assert_eq!(module(&pl.rungs[0].placement).initial, Some(false));
    assert!(given(&p, &pl).contains(&"initial Y1: 0".into()));
    // RESI-16DI8RO: a TOGGLE and a SWITCH ON / OFF keep a state, a SWITCH does not.
    let p = project("auto", &[RESI], &RESI_TAGS);
    let pl = plan(
        &p,
        Some(vec![
            rung(
                2,
                RungShape::Toggle {
                    trigger: vec![t(0)],
                },
            ),
            rung(
                3,
                RungShape::EdgeSetReset {
                    set: vec![t(0)],
                    reset: vec![t(1)],
                },
            ),
            rung(4, RungShape::Combinational { expr: t(1) }),
        ]),
        "expr",
    );
    let initial: Vec<Option<bool>> = pl.pushed().map(|(_, m)| m.initial).collect();
    assert_eq!(initial, [Some(false), Some(false), None]);
    for key in ["initial RO1: 0", "initial RO2: 0"] {
        assert!(given(&p, &pl).contains(&key.into()), "{key}");
    }
    assert!(!given(&p, &pl).iter().any(|s| s.starts_with("initial RO3")));
}

#[test]
fn minimod_blinkers() {
    let ms = Duration::from_millis;
    let mut tags = MM_TAGS.to_vec();
    tags.push("name: w, point: mm1.Y3, blink_phase: free");
    let p = project("auto", &[MM], &tags);
    let blink = |coil, on, off| {
        rung(
            coil,
            RungShape::Blink {
                enable: t(0),
                on: ms(on),
                off: ms(off),
            },
        )
    };
    let out = placements(
        &p,
        vec![
            rung(
                3,
                RungShape::Lamp {
                    enable: t(0),
                    mask: 0x0F0F,
                },
            ),
            blink(4, 400, 400),
            blink(5, 800, 800),
        ],
    );
    // LAMP: its phase is free by definition.
    let lamp = module(&out[0]);
    assert_eq!(lamp.feature, Feature::Lamp);
    assert_eq!(lamp.initial, Some(false), "off until the mask is written");
    assert!(lamp.tables.is_empty());
    let Some(Command::Lamp { point, mask, .. }) = &lamp.command else {
        panic!("a blinker command: {lamp:?}");
    };
    assert_eq!(p.modules[0].model.points[*point].name, "YLAMP1");
    assert_eq!(*mask, 0x0F0F);
    // BLINK 400/400 on Y2: it could go down, but starts on at its enable.
    assert_eq!(reason(&out[1]), &Reason::BlinkPhase { mask: 0x0F0F });
    assert!(reason(&out[1]).to_string().contains("blink_phase: free"));
    // BLINK 800/800 on Y3 with blink_phase: free: YLAMP3 = 255, the manual's slow flashing.
    let Some(Command::Lamp { point, mask, .. }) = &module(&out[2]).command else {
        panic!("a blinker command");
    };
    assert_eq!(p.modules[0].model.points[*point].name, "YLAMP3");
    assert_eq!(*mask, 0x00FF);
    // A period the 16 steps do not repeat stays central, with the ones that would go down.
    let out = placements(&p, vec![blink(5, 500, 500)]);
    assert!(
        reason(&out[0])
            .to_string()
            .ends_with("400ms/400ms or 800ms/800ms would go down"),
        "{}",
        reason(&out[0])
    );
    // An enable that reads a coil written later is evaluated too late.
    let out = placements(
        &p,
        vec![
            rung(
                3,
                RungShape::Lamp {
                    enable: t(4),
                    mask: 1,
                },
            ),
            rung(4, RungShape::Combinational { expr: t(0) }),
        ],
    );
    assert_eq!(
        reason(&out[0]),
        &Reason::TriggerReadsLater { tag: "z".into() }
    );
}

#[test]
fn blink_phase_is_refused_where_no_blinker_can_go() {
    let mut tags = MM_TAGS.to_vec();
    tags.push("name: m, type: bool, blink_phase: free");
    tags.push("name: x, point: mm1.X1, blink_phase: enable");
    tags.push("name: v, point: mm1.Y4, blink_phase: loose");
    let errors = parse_project("auto", &[MM], &tags)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    for expected in [
        "inline.yaml:13:41: error: tag m: blink_phase applies to tags bound to a module output (the \
         BLINK writing the output); this is a memory tag",
        "tag x: blink_phase applies to tags bound to a module output (the BLINK writing the \
         output); this is not an output",
        "tag v: blink_phase \"loose\" is not one of enable, free",
    ] {
        assert!(errors.contains(expected), "{expected}\nin\n{errors}");
    }
}
