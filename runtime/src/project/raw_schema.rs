//! JSON Schemas of the project file's hand-written readers: what each visitor in `raw.rs`,
//! `service.rs` and `offload.rs` accepts, said in JSON Schema so an editor checks and completes
//! it (`softplc schema project`). The derived structs reach these through `JsonSchema`.
//!
//! A schema here may be looser than the validation (ranges, names of other entries, whether a
//! duration is a whole number of ms), never stricter: a file the runtime accepts must not be
//! marked wrong in the editor. Word lists are the validation's own where it has one.

use std::borrow::Cow;

use schemars::{json_schema, JsonSchema, Schema, SchemaGenerator};
use serde_json::{json, Value};

use super::offload::RawOffload;
use super::raw::{DurationText, Int, RawAdapterLatency, ScalarText, Settings};
use super::service::{RawScada, ScadaAccess};

/// The duration syntax of `raw::parse_duration`: a decimal number, an optional space, a unit.
/// (Whole nanoseconds and the upper bound are the validation's.)
pub(crate) const DURATION_PATTERN: &str =
    r"^\s*([0-9]+(\.[0-9]*)?|\.[0-9]+) ?(ns|us|µs|ms|s|m|h)\s*$";

/// A serial character format as `SerialFormat::from_str` reads it: data bits, parity, stop bits.
pub(crate) const SERIAL_FORMAT_PATTERN: &str = "^[78][NEOneo][12]$";

/// The formats an editor offers for `format:`, the usual first (the pattern also takes them in
/// lower case).
pub(crate) const SERIAL_FORMATS: &[&str] = &[
    "8E1", "8N1", "8O1", "8N2", "8E2", "8O2", "7E1", "7O1", "7N2", "7E2", "7O2", "7N1",
];

/// The words of `offload:` and a tag's `offload:` (`OffloadMode`).
pub(crate) const OFFLOAD_MODES: &[&str] = &["never", "auto", "require"];

/// The words of `offload.on_stop:` (`OnStop`).
pub(crate) const ON_STOP: &[&str] = &["clear", "keep"];

/// A schema that is one of `words`.
pub(crate) fn words(words: &[&str]) -> Schema {
    json_schema!({ "type": "string", "enum": words })
}

/// `schema` or null: an optional key given as `~` reads as absent.
pub(crate) fn nullable(schema: Schema) -> Schema {
    json_schema!({ "anyOf": [schema, { "type": "null" }] })
}

/// A scalar as `ScalarText` reads it.
fn scalar() -> Value {
    json!({ "type": ["string", "number", "boolean"] })
}

impl JsonSchema for DurationText {
    fn schema_name() -> Cow<'static, str> {
        "Duration".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "type": "string",
            "pattern": DURATION_PATTERN,
            "description": "A duration with a unit: 20ms, 1.5s, 250us, 2m, 1h (ns, us or µs, ms, \
                            s, m, h). A bare number is refused: milliseconds or seconds would be \
                            a guess.",
            "examples": ["20ms", "1.5s", "10m"]
        })
    }
}

impl JsonSchema for Int {
    fn schema_name() -> Cow<'static, str> {
        "Integer".into()
    }

    fn inline_schema() -> bool {
        true
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({ "type": "integer" })
    }
}

impl JsonSchema for ScalarText {
    fn schema_name() -> Cow<'static, str> {
        "Scalar".into()
    }

    fn inline_schema() -> bool {
        true
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        scalar().try_into().expect("an object is a schema")
    }
}

impl JsonSchema for Settings {
    fn schema_name() -> Cow<'static, str> {
        "Settings".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "type": ["object", "null"],
            "description": "A mapping of key: value, each value a number, true/false or text; \
                            a key given twice is an error.",
            "additionalProperties": scalar()
        })
    }
}

impl JsonSchema for RawAdapterLatency {
    fn schema_name() -> Cow<'static, str> {
        "AdapterLatency".into()
    }

    fn json_schema(generator: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "anyOf": [words(&["auto"]), generator.subschema_for::<DurationText>()],
            "description": "auto: the USB adapter's latency timer is read from sysfs and lowered \
                            to 1 ms at open; a duration (whole ms, 0ms..=255ms): what check \
                            counts, and the most the port may keep."
        })
    }
}

impl JsonSchema for RawScada {
    fn schema_name() -> Cow<'static, str> {
        "Scada".into()
    }

    fn json_schema(generator: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "description": "SCADA access to the tag: read (default), write (memory tags and \
                            outputs) or none; or a mapping that also pins its 0-based address.",
            "anyOf": [
                words(ScadaAccess::NAMES),
                {
                    "type": "object",
                    "additionalProperties": false,
                    "properties": {
                        "access": nullable(words(ScadaAccess::NAMES)),
                        "address": nullable(generator.subschema_for::<Int>())
                    }
                }
            ]
        })
    }
}

impl JsonSchema for RawOffload {
    fn schema_name() -> Cow<'static, str> {
        "Offload".into()
    }

    fn json_schema(_: &mut SchemaGenerator) -> Schema {
        json_schema!({
            "description": "Push-down of rungs into the modules: never (default), auto, \
                            require; or a mapping with mode and on_stop (clear or keep).",
            "anyOf": [
                words(OFFLOAD_MODES),
                {
                    "type": "object",
                    "additionalProperties": false,
                    "properties": {
                        "mode": nullable(words(OFFLOAD_MODES)),
                        "on_stop": nullable(words(ON_STOP))
                    }
                }
            ]
        })
    }
}

/// `schemars(schema_with)` functions for string fields whose values are a fixed list.
pub(crate) mod field {
    use schemars::{json_schema, Schema, SchemaGenerator};

    use super::{nullable, words, OFFLOAD_MODES, SERIAL_FORMATS, SERIAL_FORMAT_PATTERN};

    /// `buses[].format`. An editor completes from `enum`s, so the formats are one (and the
    /// pattern takes the lower-case spellings). Unquoted, `8E1` and `7E2` are numbers to a YAML
    /// reader that resolves types, as an editor's does (8×10¹ = 80); the runtime reads the text
    /// as written, so the numbers the even-parity formats spell are accepted too, by ranges
    /// rather than an `enum`, so that completion never offers `80` for a format.
    pub(crate) fn serial_format(_: &mut SchemaGenerator) -> Schema {
        nullable(json_schema!({
            "anyOf": [
                { "type": "string", "enum": SERIAL_FORMATS },
                { "type": "string", "pattern": SERIAL_FORMAT_PATTERN },
                {
                    "type": "integer",
                    "anyOf": [
                        { "minimum": 70, "maximum": 80, "multipleOf": 10 },
                        { "minimum": 700, "maximum": 800, "multipleOf": 100 }
                    ]
                }
            ]
        }))
    }

    /// `buses[].echo`.
    pub(crate) fn echo(_: &mut SchemaGenerator) -> Schema {
        nullable(words(&["none", "discard"]))
    }

    /// `buses[].direction`.
    pub(crate) fn direction(_: &mut SchemaGenerator) -> Schema {
        nullable(words(&["host", "auto"]))
    }

    /// `buses[].tune`.
    pub(crate) fn tune(_: &mut SchemaGenerator) -> Schema {
        nullable(words(&["reply_delay"]))
    }

    /// `modules[].protocol`.
    pub(crate) fn protocol(_: &mut SchemaGenerator) -> Schema {
        nullable(words(&["modbus", "text"]))
    }

    /// `modules[].watchdog`: the words `watchdog::parse_policy` reads (in any case, around
    /// spaces), and YAML's booleans; `auto` and `off` first, for completion.
    pub(crate) fn module_watchdog(_: &mut SchemaGenerator) -> Schema {
        const WORDS: [&str; 7] = ["auto", "on", "true", "yes", "off", "false", "no"];
        let any_case: Vec<String> = WORDS
            .iter()
            .map(|w| {
                w.chars()
                    .map(|c| format!("[{c}{}]", c.to_ascii_uppercase()))
                    .collect()
            })
            .collect();
        json_schema!({
            "anyOf": [
                words(&["auto", "off"]),
                { "type": "string", "pattern": format!(r"^\s*({})\s*$", any_case.join("|")) },
                { "type": ["boolean", "null"] }
            ]
        })
    }

    /// `modules[].model`: a model of the catalog (`softplc models`), each with its summary.
    pub(crate) fn module_model(_: &mut SchemaGenerator) -> Schema {
        let models = softplc_io::devices::catalog()
            .iter()
            .map(|m| (m.name, m.summary));
        let mut schema = named(models);
        // Or a device profile file, relative to the project's folder.
        if let Some(serde_json::Value::Array(choices)) = schema.get_mut("anyOf") {
            choices.push(serde_json::json!({
                "pattern": "^profile:.+",
                "description": "a device profile file, relative to the project file's folder: \
                                profile:profiles/sdm120.yaml"
            }));
        }
        schema
    }

    /// `plant.model`: a built-in plant model, each with its summary.
    pub(crate) fn plant_model(_: &mut SchemaGenerator) -> Schema {
        let plants = crate::plant::CATALOG.iter().map(|p| (p.name, p.summary));
        named(plants)
    }

    /// One of the `(name, description)` pairs; the editor shows the description beside each
    /// name it offers.
    fn named(pairs: impl Iterator<Item = (&'static str, &'static str)>) -> Schema {
        let choices: Vec<_> = pairs
            .map(|(name, summary)| json_schema!({ "const": name, "description": summary }))
            .collect();
        json_schema!({ "type": "string", "anyOf": choices })
    }

    /// `modules[].settings`' keys per model, offered for completion (`if model is X then its
    /// settings have X's keys`). Hints only: the model checks the keys and values, with "did
    /// you mean", and the schema does not refuse what the model might accept.
    pub(crate) fn settings_hints() -> serde_json::Value {
        let per_model: Vec<_> = softplc_io::devices::catalog()
            .iter()
            .map(|m| {
                let keys: serde_json::Map<String, serde_json::Value> = (m.setting_keys)()
                    .into_iter()
                    .map(|k| (k.to_owned(), serde_json::json!({})))
                    .collect();
                serde_json::json!({
                    "if": { "properties": { "model": { "const": m.name } }, "required": ["model"] },
                    "then": { "properties": { "settings": { "properties": keys } } }
                })
            })
            .collect();
        per_model.into()
    }

    /// `tags[].type`.
    pub(crate) fn tag_type(_: &mut SchemaGenerator) -> Schema {
        nullable(words(&["bool", "u16", "i32", "f32"]))
    }

    /// `tags[].offload`.
    pub(crate) fn tag_offload(_: &mut SchemaGenerator) -> Schema {
        nullable(words(OFFLOAD_MODES))
    }

    /// `tags[].blink_phase`.
    pub(crate) fn blink_phase(_: &mut SchemaGenerator) -> Schema {
        nullable(words(&["enable", "free"]))
    }

    /// `program.kind`.
    pub(crate) fn program_kind(_: &mut SchemaGenerator) -> Schema {
        words(&["expr", "ladder", "rhai"])
    }

    /// `traces[].mode`.
    pub(crate) fn trace_mode(_: &mut SchemaGenerator) -> Schema {
        nullable(words(&["single", "repeat"]))
    }

    pub(crate) fn trace_arm(_: &mut SchemaGenerator) -> Schema {
        nullable(words(&["start", "manual"]))
    }
}

#[cfg(test)]
mod tests {
    use std::str::FromStr;

    use serde_json::json;
    use softplc_io::line::SerialFormat;

    use super::*;
    use crate::project::raw;

    fn accepts(schema: &Schema, value: Value) -> bool {
        jsonschema::draft7::new(schema.as_value())
            .expect("a valid schema")
            .is_valid(&value)
    }

    // The pattern must agree with `parse_duration` on syntax: a text it refuses only for being
    // finer than a nanosecond or too long is still well-formed.
    #[test]
    fn the_duration_pattern_is_the_parsers_syntax() {
        let schema = DurationText::json_schema(&mut SchemaGenerator::default());
        for text in [
            "20ms",
            "1.5s",
            ".5s",
            "5.s",
            "250us",
            "250µs",
            "2m",
            "1h",
            "7ns",
            "10 ms",
            " 3s ",
            "0ms",
            "20",
            "ms",
            "-5ms",
            "1.2.3s",
            "5 parsecs",
            "1 sec",
            "10  ms",
            "1e3ms",
            "",
        ] {
            let parsed = !matches!(
                raw::parse_duration(text),
                Err(raw::DurationError::NoNumber
                    | raw::DurationError::NoUnit
                    | raw::DurationError::UnknownUnit(_))
            );
            assert_eq!(accepts(&schema, json!(text)), parsed, "{text:?}");
        }
        assert!(!accepts(&schema, json!(20)), "a bare number");
    }

    #[test]
    fn the_format_pattern_is_the_parsers() {
        let schema = field::serial_format(&mut SchemaGenerator::default());
        for text in [
            "8E1", "8N1", "8O2", "7E1", "8e1", "8n2", "9E1", "8X1", "8E3", "8E", "8E11", "",
        ] {
            let parsed = SerialFormat::from_str(text).is_ok();
            assert_eq!(accepts(&schema, json!(text)), parsed, "{text:?}");
        }
        // `format: 8E1` unquoted, as a YAML reader that resolves types sees it.
        for unquoted in ["8E1", "7E1", "8E2", "7E2"] {
            let read: Value = yaml_serde::from_str(unquoted).unwrap();
            assert!(accepts(&schema, read), "{unquoted}");
        }
        for number in [19200, 75, 90, 750] {
            assert!(!accepts(&schema, json!(number)), "{number}");
        }
    }

    /// Every value an `enum` anywhere in `schema` lists: what an editor's completion offers.
    fn offered(schema: &Value, into: &mut Vec<Value>) {
        match schema {
            Value::Object(map) => {
                if let Some(Value::Array(values)) = map.get("enum") {
                    into.extend(values.iter().cloned());
                }
                map.values().for_each(|v| offered(v, into));
            }
            Value::Array(items) => items.iter().for_each(|v| offered(v, into)),
            _ => {}
        }
    }

    #[test]
    fn completion_offers_real_formats_for_format() {
        let schema = field::serial_format(&mut SchemaGenerator::default());
        let mut values = Vec::new();
        offered(&schema.to_value(), &mut values);
        assert_eq!(values.first(), Some(&json!("8E1")), "the default first");
        assert_eq!(values.len(), SERIAL_FORMATS.len());
        for v in values {
            let text = v
                .as_str()
                .unwrap_or_else(|| panic!("{v} is offered, not a format"));
            assert!(SerialFormat::from_str(text).is_ok(), "{text}");
        }
    }

    #[test]
    fn the_module_watchdog_words_are_the_parsers() {
        let schema = field::module_watchdog(&mut SchemaGenerator::default());
        for text in [
            "auto", "off", "OFF", " On ", "yes", "no", "true", "maybe", "offf", "",
        ] {
            let parsed = crate::project::watchdog::parse_policy(text).is_ok();
            assert_eq!(accepts(&schema, json!(text)), parsed, "{text:?}");
        }
        assert!(accepts(&schema, json!(false)));
    }
}
