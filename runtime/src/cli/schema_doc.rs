//! `softplc schema KIND --markdown`: a file kind's reference as Markdown, written from the same
//! JSON Schema an editor reads, so the reference cannot say other than the code. Every mapping
//! gets a section named by its path in the file (`scan.watchdog`, `buses[]`), with a table of
//! its keys: type, whether it is required, and the key's documentation (defaults included).
//! `docs/project-file.md` is this output for the project file; a test fails when they differ.

use std::collections::{BTreeMap, BTreeSet};
use std::fmt::Write;

use serde_json::{Map, Value};

/// A mapping to document: its path in the file and its schema.
struct Section<'a> {
    path: String,
    schema: &'a Map<String, Value>,
}

/// The Markdown reference of `schema` (a whole file's schema, its `definitions` inside),
/// titled `title`; `command` is the command line that prints it.
pub(crate) fn markdown(schema: &Value, title: &str, command: &str) -> String {
    let defs = schema
        .get("definitions")
        .and_then(Value::as_object)
        .cloned()
        .unwrap_or_default();
    let mut out = String::new();
    let _ = writeln!(out, "# {title}: reference\n");
    let _ = writeln!(
        out,
        "Written by `{command}` from the types that read the file (the JSON Schema of `schema/`, \
         which editors use too); a test fails when this file differs from it, so it says what \
         the code does. Each mapping has a section named by its path in the file (`a.b` for a \
         key of a mapping, `a[]` for each entry of a list). Durations take a unit (`20ms`, \
         `1.5s`, `250us`, `2m`)."
    );
    let Some(root) = schema.as_object() else {
        return out;
    };
    if let Some(d) = root.get("description").and_then(Value::as_str) {
        let _ = writeln!(out, "\n{}", paragraph(d));
    }
    let mut queue = vec![Section {
        path: String::new(),
        schema: root,
    }];
    let mut seen = BTreeSet::new();
    // Each mapping type's first path: where it is documented, which every link to it names.
    let mut first = BTreeMap::new();
    while !queue.is_empty() {
        let section = queue.remove(0);
        let mut children = Vec::new();
        write_section(&mut out, &section, &defs, &mut children, &mut first);
        for child in children {
            // A type used at several places (a recursive or shared one) is documented once,
            // at its first path.
            if seen.insert(child.schema as *const Map<String, Value>) {
                queue.push(child);
            }
        }
    }
    out
}

fn write_section<'a>(
    out: &mut String,
    section: &Section<'a>,
    defs: &'a Map<String, Value>,
    children: &mut Vec<Section<'a>>,
    first: &mut BTreeMap<*const Map<String, Value>, String>,
) {
    let Some(props) = section.schema.get("properties").and_then(Value::as_object) else {
        return;
    };
    if section.path.is_empty() {
        let _ = writeln!(out, "\n## The top level\n");
    } else {
        let _ = writeln!(out, "\n## `{}`\n", section.path);
        if let Some(d) = section.schema.get("description").and_then(Value::as_str) {
            let _ = writeln!(out, "{}\n", paragraph(d));
        }
    }
    let required: BTreeSet<&str> = section
        .schema
        .get("required")
        .and_then(Value::as_array)
        .map(|r| r.iter().filter_map(Value::as_str).collect())
        .unwrap_or_default();
    let _ = writeln!(out, "| key | type | required | what |");
    let _ = writeln!(out, "|---|---|---|---|");
    for (key, prop) in props {
        let path = if section.path.is_empty() {
            key.clone()
        } else {
            format!("{}.{key}", section.path)
        };
        let (mut ty, mapping) = type_of(prop, defs, &path);
        if let Some(m) = mapping {
            // A type used at several places is documented at its first: link there.
            let at = first
                .entry(m.schema as *const Map<String, Value>)
                .or_insert_with(|| m.path.clone());
            if *at != m.path {
                let here = format!("[`{}`](#{})", m.path, anchor(&m.path));
                ty = ty.replace(&here, &format!("[`{at}`](#{})", anchor(at)));
            }
            children.push(m);
        }
        let what = prop
            .get("description")
            .and_then(Value::as_str)
            .map(cell)
            .unwrap_or_default();
        let _ = writeln!(
            out,
            "| `{key}` | {ty} | {} | {what} |",
            if required.contains(key.as_str()) {
                "yes"
            } else {
                ""
            }
        );
    }
}

/// What a value of schema `s` at `path` is, in words; and the mapping to document beside it,
/// if it is one (or a list of them).
fn type_of<'a>(
    s: &'a Value,
    defs: &'a Map<String, Value>,
    path: &str,
) -> (String, Option<Section<'a>>) {
    let Some(obj) = s.as_object() else {
        return ("any".into(), None);
    };
    if let Some(target) = obj.get("$ref").and_then(Value::as_str) {
        let name = target.rsplit('/').next().unwrap_or(target);
        return match defs.get(name) {
            Some(def) => type_of(def, defs, path),
            None => (format!("`{name}`"), None),
        };
    }
    if obj.contains_key("properties") {
        let words = format!("mapping ([`{path}`](#{}))", anchor(path));
        return (
            words,
            Some(Section {
                path: path.to_string(),
                schema: obj,
            }),
        );
    }
    if let Some(values) = obj.get("enum").and_then(Value::as_array) {
        let words: Vec<String> = values.iter().map(|v| format!("`{}`", bare(v))).collect();
        return (format!("one of {}", words.join(", ")), None);
    }
    if let Some(v) = obj.get("const") {
        return (format!("`{}`", bare(v)), None);
    }
    let types: Vec<&str> = match obj.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts
            .iter()
            .filter_map(Value::as_str)
            .filter(|t| *t != "null")
            .collect(),
        _ => Vec::new(),
    };
    if types == ["array"] {
        let item_path = format!("{path}[]");
        let (item, mapping) = obj
            .get("items")
            .map(|i| type_of(i, defs, &item_path))
            .unwrap_or_else(|| ("any".into(), None));
        return (format!("list of {item}"), mapping);
    }
    if types == ["object"] {
        return ("mapping of key: value".into(), None);
    }
    if types == ["string"] && obj.contains_key("pattern") && obj.contains_key("examples") {
        // A string of a given form (a duration): its examples say it best.
        let examples: Vec<String> = obj
            .get("examples")
            .and_then(Value::as_array)
            .map(|e| e.iter().map(|v| format!("`{}`", bare(v))).collect())
            .unwrap_or_default();
        return (format!("text such as {}", examples.join(", ")), None);
    }
    if types.is_empty() {
        for key in ["allOf", "anyOf", "oneOf"] {
            if let Some(options) = obj.get(key).and_then(Value::as_array) {
                let mut words = Vec::new();
                let mut mapping = None;
                for option in options {
                    if option.get("type").and_then(Value::as_str) == Some("null") {
                        continue;
                    }
                    let (word, m) = type_of(option, defs, path);
                    if mapping.is_none() {
                        mapping = m;
                    }
                    if !words.contains(&word) {
                        words.push(word);
                    }
                }
                return (words.join(" or "), mapping);
            }
        }
    }
    if types.is_empty() {
        return ("any".into(), None);
    }
    (
        types
            .iter()
            .map(|t| match *t {
                "string" => "text",
                "integer" => "integer",
                "number" => "number",
                "boolean" => "true/false",
                "object" => "mapping",
                other => other,
            })
            .collect::<Vec<_>>()
            .join(" or "),
        None,
    )
}

/// A JSON value as written in YAML: strings without their quotes.
fn bare(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

/// The anchor GitHub gives a heading `` `path` ``: lower case, `.` and `[]` dropped.
fn anchor(path: &str) -> String {
    path.chars()
        .filter(|c| c.is_alphanumeric() || *c == '_' || *c == '-')
        .flat_map(char::to_lowercase)
        .collect()
}

/// A description as one paragraph (the schema keeps the doc comment's line breaks).
fn paragraph(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// A description fit for a table cell: one line, `|` escaped.
fn cell(text: &str) -> String {
    paragraph(text).replace('|', "\\|")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_schema_becomes_a_section_per_mapping() {
        let schema = serde_json::json!({
            "description": "A file.",
            "type": "object",
            "required": ["name"],
            "properties": {
                "name": { "description": "Its name.", "type": "string" },
                "every": { "description": "How often.", "allOf": [{ "$ref": "#/definitions/Duration" }] },
                "items": { "type": "array", "items": { "$ref": "#/definitions/Item" } },
                "mode": { "anyOf": [{ "type": "string", "enum": ["a", "b"] }, { "type": "null" }] }
            },
            "definitions": {
                "Duration": { "type": "string", "pattern": "x", "examples": ["20ms"] },
                "Item": {
                    "description": "One item; a | b.",
                    "type": "object",
                    "properties": { "on": { "description": "Whether.", "type": ["boolean", "null"] } }
                }
            }
        });
        let text = markdown(&schema, "A file", "softplc schema x --markdown");
        assert!(text.starts_with("# A file: reference\n"), "{text}");
        assert!(
            text.contains("| `name` | text | yes | Its name. |"),
            "{text}"
        );
        assert!(
            text.contains("| `every` | text such as `20ms` |  | How often. |"),
            "{text}"
        );
        assert!(
            text.contains("| `items` | list of mapping ([`items[]`](#items)) |  |  |"),
            "{text}"
        );
        assert!(
            text.contains("| `mode` | one of `a`, `b` |  |  |"),
            "{text}"
        );
        assert!(
            text.contains("\n## `items[]`\n\nOne item; a | b.\n"),
            "{text}"
        );
        assert!(
            text.contains("| `on` | true/false |  | Whether. |"),
            "{text}"
        );
    }

    #[test]
    fn a_type_used_at_two_places_is_linked_where_it_is_documented() {
        let schema = serde_json::json!({
            "type": "object",
            "properties": {
                "one": { "allOf": [{ "$ref": "#/definitions/Item" }] },
                "many": { "type": "array", "items": { "$ref": "#/definitions/Item" } }
            },
            "definitions": {
                "Item": { "type": "object", "properties": { "on": { "type": "boolean" } } }
            }
        });
        let text = markdown(&schema, "A file", "softplc schema x --markdown");
        // `many` comes first (keys in order): the section is `many[]`, and `one` links to it.
        assert!(text.contains("\n## `many[]`\n"), "{text}");
        assert!(!text.contains("## `one`"), "{text}");
        assert!(
            text.contains("| `one` | mapping ([`many[]`](#many)) |  |  |"),
            "{text}"
        );
    }
}
