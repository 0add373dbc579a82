//! Why the PLC refused a request of the control interface: a force, an unforce, a write, a
//! reload. The variants keep what was asked (tag, type, text) so a caller can tell one
//! refusal from another without reading the message; the messages are what an operator sees.

use softplc_io::point::ValueType;

use crate::logic::{load::ProgramError, SourcePos};
use crate::project::ProjectErrors;

/// Why a force, an unforce or a write of a tag was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TagError {
    /// The project has no such tag.
    #[error("no tag {tag:?} in project {project}")]
    Unknown {
        /// The name asked for.
        tag: String,
        /// The running project's name.
        project: String,
    },
    /// The text is not a value of the tag's type.
    #[error("{tag} is {ty}: {text:?} is not a {ty}")]
    BadValue {
        /// The tag.
        tag: String,
        /// Its type.
        ty: ValueType,
        /// The text that did not parse.
        text: String,
    },
    /// A write to a forced tag: the force wins until it is removed.
    #[error("{tag} is forced; unforce it to write it")]
    Forced {
        /// The tag.
        tag: String,
    },
    /// A write to an input: the module's next read overwrites it before the program sees it.
    #[error(
        "{tag} is an input its module overwrites every scan: a write would not last; force it \
         to hold a value"
    )]
    Input {
        /// The tag.
        tag: String,
    },
    /// The tag is an output a module drives with its own logic (push-down).
    #[error(
        "{tag} is driven by its module's own logic (push-down); set offload: never on the tag \
         to drive it from the scan"
    )]
    PushedOutput {
        /// The tag.
        tag: String,
    },
    /// The tag is an input a module reads itself for a pushed-down rung: a force in the image
    /// would not reach the module's logic.
    #[error(
        "{tag} is read by the module's own logic for {coil} ({pos}), which sees the real \
         terminal, not a force; set offload: never on {coil} to force it"
    )]
    PushedInput {
        /// The tag.
        tag: String,
        /// The coil of the pushed-down rung that reads it.
        coil: String,
        /// Where that rung is in the program.
        pos: SourcePos,
    },
}

/// Why a reload was refused; the running program stays.
#[derive(Debug, thiserror::Error)]
pub enum ReloadError {
    /// The project file no longer validates.
    #[error("reload refused:\n{0}")]
    Project(ProjectErrors),
    /// Something besides the program changed, which only a restart applies.
    #[error(
        "reload refused: something besides the program changed (scan, buses, modules, tags, \
         retain, offload or service); restart to apply it"
    )]
    NotOnlyProgram,
    /// The new program does not compile.
    #[error("reload refused:\n{0}")]
    Program(ProgramError),
    /// The task reloaded is no longer in the project file.
    #[error(
        "reload refused: task `{task}` is no longer in the project; restart to run the \
         project's tasks"
    )]
    TaskGone {
        /// The task.
        task: String,
    },
    /// A task's new program writes tags its task does not own.
    #[error(
        "reload refused:\n{}",
        .0.iter().map(|e| e.to_string()).collect::<Vec<_>>().join("\n")
    )]
    ForeignWrites(Vec<super::task_reload::ForeignWrite>),
    /// The new program places rungs elsewhere than the module tables written at start-up.
    #[error(
        "reload refused: the new program moves rungs into or out of modules; restart to write \
         the module tables"
    )]
    Placement,
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use softplc_io::point::{Value, ValueType};

    use super::*;
    use crate::clock::VirtualClock;
    use crate::plc::Plc;

    /// A bus-less PLC with a bool `run` and a u16 `speed`.
    fn plc(dir: &str) -> Plc {
        let dir = std::env::temp_dir().join(format!("softplc-{dir}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("p.expr"), "run = run\n").unwrap();
        let yaml = "project: p\nscan:\n  period: 10ms\nbuses: []\nmodules: []\ntags:\n  - { name: run, type: bool }\n  - { name: speed, type: u16 }\nprogram: { file: p.expr, kind: expr }\n";
        std::fs::write(dir.join("p.yaml"), yaml).unwrap();
        let project = crate::project::load(&dir.join("p.yaml")).unwrap();
        Plc::build(project, Arc::new(VirtualClock::new())).unwrap()
    }

    #[test]
    fn refusals_carry_what_was_asked() {
        let mut plc = plc("tag-errors");
        assert_eq!(
            plc.force("nope", "1"),
            Err(TagError::Unknown {
                tag: "nope".into(),
                project: "p".into()
            })
        );
        let bad = plc.force("speed", "fast").unwrap_err();
        assert_eq!(
            bad,
            TagError::BadValue {
                tag: "speed".into(),
                ty: ValueType::U16,
                text: "fast".into()
            }
        );
        assert_eq!(bad.to_string(), r#"speed is u16: "fast" is not a u16"#);
        assert_eq!(plc.force("run", "1"), Ok(Value::Bool(true)));
        // Nothing is written when one of the values is refused.
        assert_eq!(
            plc.write_tags([("speed", "7"), ("run", "0")]),
            Err(TagError::Forced { tag: "run".into() })
        );
        assert_eq!(
            plc.image().get(plc.image().id("speed").unwrap()),
            Value::U16(0)
        );
        assert_eq!(plc.unforce(None), Ok(1));
        assert_eq!(plc.write_tags([("speed", "7"), ("run", "0")]), Ok(2));
        assert_eq!(
            plc.image().get(plc.image().id("speed").unwrap()),
            Value::U16(7)
        );
    }
}
