//! `softplc schema project|ladder|scenario|profile|blocks`: prints the JSON Schema of a file kind, generated
//! from the serde types that read it, so an editor (VS Code with the YAML extension) checks
//! and completes the files. The repository's `schema/*.schema.json` are this command's output;
//! a test fails when they drift from the code.

use std::process::ExitCode;

use clap::{Args, ValueEnum};
use schemars::generate::SchemaSettings;
use schemars::transform::RecursiveTransform;
use schemars::{Schema, SchemaGenerator};

/// Arguments of `softplc schema`.
#[derive(Debug, Args)]
pub(crate) struct SchemaArgs {
    /// The file kind.
    #[arg(value_enum)]
    pub file: FileKind,
    /// Print the reference in Markdown instead (`docs/project-file.md` is the project's).
    #[arg(long)]
    pub markdown: bool,
}

/// A file kind softplc reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub(crate) enum FileKind {
    /// The project file (`project.yaml`).
    Project,
    /// A ladder program (`*.ladder.yaml`).
    Ladder,
    /// A scenario file for `softplc test` (`*.scenario.yaml`).
    Scenario,
    /// A device profile (`model: profile:FILE`, `softplc sim --profile FILE`).
    Profile,
    /// A file of blocks of one's own (`blocks: [FILE]` in a project; `*.blocks.yaml`).
    Blocks,
}

impl FileKind {
    /// What its reference is titled.
    fn reference_title(self) -> &'static str {
        match self {
            FileKind::Project => "The project file",
            FileKind::Ladder => "Ladder programs",
            FileKind::Scenario => "Scenario files",
            FileKind::Profile => "Device profiles",
            FileKind::Blocks => "Block files",
        }
    }

    /// The schema's title, shown by editors.
    fn title(self) -> &'static str {
        match self {
            FileKind::Project => "softplc project file",
            FileKind::Ladder => "softplc ladder program",
            FileKind::Scenario => "softplc scenario file",
            FileKind::Profile => "softplc device profile",
            FileKind::Blocks => "softplc block file",
        }
    }
}

/// Prints the schema of `args.file`.
pub(crate) fn schema(args: SchemaArgs) -> anyhow::Result<ExitCode> {
    let text = if args.markdown {
        reference(args.file)?
    } else {
        schema_text(args.file)?
    };
    super::out::out(&text)?;
    Ok(ExitCode::SUCCESS)
}

/// The Markdown reference of `kind`, written from its schema.
pub(crate) fn reference(kind: FileKind) -> serde_json::Result<String> {
    let schema = serde_json::to_value(generate(kind))?;
    let name = kind
        .to_possible_value()
        .map(|v| v.get_name().to_string())
        .unwrap_or_default();
    Ok(super::schema_doc::markdown(
        &schema,
        kind.reference_title(),
        &format!("softplc schema {name} --markdown"),
    ))
}

/// The schema of `kind`, as pretty JSON ending in a newline (the committed files' form).
pub(crate) fn schema_text(kind: FileKind) -> serde_json::Result<String> {
    let mut schema = generate(kind);
    schema.insert("title".into(), kind.title().into());
    let mut text = serde_json::to_string_pretty(&schema)?;
    text.push('\n');
    Ok(text)
}

fn generate(kind: FileKind) -> Schema {
    // Draft 7: the newest draft the YAML language server implements in full.
    let mut generator: SchemaGenerator = SchemaSettings::draft07()
        .with_transform(RecursiveTransform(for_editors))
        .into_generator();
    match kind {
        FileKind::Project => generator.root_schema_for::<crate::project::raw::RawProject>(),
        FileKind::Ladder => crate::logic::ladder::file_schema(&mut generator),
        FileKind::Scenario => super::test::scenario::file_schema(&mut generator),
        FileKind::Profile => {
            generator.root_schema_for::<crate::project::profile::raw::RawProfile>()
        }
        FileKind::Blocks => {
            generator.root_schema_for::<crate::project::user_blocks::raw::RawBlockFile>()
        }
    }
}

/// What an editor shows: Rust doc links (`` [`super::offload`] ``) mean nothing in a hover, so
/// only the name is kept; `default: null` (an optional key) would be inserted by completion as
/// `key: null`, so it goes.
fn for_editors(schema: &mut Schema) {
    if let Some(serde_json::Value::String(text)) = schema.get_mut("description") {
        *text = plain_text(text);
    }
    if schema
        .get("default")
        .is_some_and(serde_json::Value::is_null)
    {
        schema.remove("default");
    }
}

/// `` [`super::web`] `` → `` `web` ``, `` [`DEFAULT_UNIT`] `` → `` `DEFAULT_UNIT` ``.
fn plain_text(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find("[`") {
        let Some(len) = rest[start..].find("`]") else {
            break;
        };
        let inner = &rest[start + 2..start + len];
        let name = inner.rsplit("::").next().unwrap_or(inner);
        out.push_str(&rest[..start]);
        out.push('`');
        out.push_str(name);
        out.push('`');
        rest = &rest[start + len + 2..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn doc_links_become_names() {
        assert_eq!(
            plain_text("see [`super::offload`] and [`DEFAULT_UNIT`]."),
            "see `offload` and `DEFAULT_UNIT`."
        );
        assert_eq!(plain_text("no links [here"), "no links [here");
    }

    // Reading a file against its schema is `runtime/tests/schema.rs`; here, that each kind
    // generates and names itself.
    #[test]
    fn every_kind_has_its_title() {
        for kind in [
            FileKind::Project,
            FileKind::Ladder,
            FileKind::Scenario,
            FileKind::Profile,
        ] {
            let text = schema_text(kind).unwrap();
            assert!(text.contains(kind.title()), "{kind:?}");
            assert!(text.contains("\"additionalProperties\": false"), "{kind:?}");
        }
    }
}
