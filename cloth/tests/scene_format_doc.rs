//! Keeps `docs/scene-format.md` honest: every field of the scene format must appear in it.
//!
//! The field list is derived from the format types themselves, not written down a second time: each
//! struct rejects unknown fields (`deny_unknown_fields`), and serde's error for an unknown field names
//! every field the struct has ("unknown field `…`, expected one of `a`, `b`"); for an enum it names
//! every variant. [`derive_format`] probes the [`Scene`] deserializer with a document that holds a single
//! unknown key at one location, reads the names from the error, and recurses into each of them: into
//! struct fields, array elements, `Option`s (a present value), externally tagged enums (`{"variant": …}`)
//! and internally tagged ones (`{"type": "variant", …}`). A field another change adds to the format
//! types therefore shows up here without touching this test.
//!
//! The doc must contain each field path in backticks (`` `task.targets[i].particle` ``; array elements are
//! written `[i]`), and each enum variant's JSON spelling in double quotes (`"spheres"`).

use cloth::Scene;
use serde_json::{json, Value};
use std::collections::BTreeSet;

/// The unknown key the probes insert.
const PROBE: &str = "__probe__";

/// One step from a parent location to a child location of the JSON document.
#[derive(Clone, Debug)]
enum Step {
    /// Into the field of an object.
    Field(String),
    /// Into the first element of an array.
    Element,
    /// Into the content of an externally tagged enum variant: `{"variant": content}`.
    Variant(String),
    /// Into an internally tagged enum: an object with `tag: variant` beside the fields.
    Tagged { tag: String, variant: String },
}

/// What the format holds: field paths (`cloth.rows`, `obstacles[i].radii`) and enum variants.
#[derive(Debug, Default)]
struct Format {
    /// Every field path, dotted, arrays as `[i]`.
    fields: BTreeSet<String>,
    /// Every enum variant's JSON name, with the path of the value it belongs to.
    variants: BTreeSet<(String, String)>,
}

/// The document that places `leaf` at the location `steps` lead to. Internally tagged steps put the
/// tag beside the next step's content.
fn document(steps: &[Step], leaf: Value) -> Value {
    let Some((first, rest)) = steps.split_first() else {
        return leaf;
    };
    let inner = document(rest, leaf);
    match first {
        Step::Field(name) | Step::Variant(name) => json!({ name.as_str(): inner }),
        Step::Element => json!([inner]),
        Step::Tagged { tag, variant } => {
            let mut object = match inner {
                Value::Object(map) => map,
                // A tagged variant's content is always an object (serde requires it).
                other => panic!("internally tagged content must be an object, got {other}"),
            };
            object.insert(tag.clone(), Value::String(variant.clone()));
            Value::Object(object)
        }
    }
}

/// The dotted path of a location, e.g. `obstacles[i].centers`.
fn path_of(steps: &[Step]) -> String {
    let mut path = String::new();
    for step in steps {
        match step {
            Step::Field(name) => {
                if !path.is_empty() {
                    path.push('.');
                }
                path.push_str(name);
            }
            Step::Element => path.push_str("[i]"),
            Step::Variant(name) => {
                path.push('.');
                path.push_str(name);
            }
            Step::Tagged { .. } => {}
        }
    }
    path
}

/// The scene parser's error for `document`, or `None` if it parses.
fn parse_error(document: &Value) -> Option<String> {
    serde_json::from_value::<Scene>(document.clone())
        .err()
        .map(|e| e.to_string())
}

/// The backticked names after `expected` in a serde message such as
/// "unknown field `x`, expected one of `a`, `b`" or "unknown variant `x`, expected `a` or `b`".
fn expected_names(message: &str) -> Vec<String> {
    let Some(at) = message.find("expected") else {
        return Vec::new();
    };
    message[at..]
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// The name inside the first backticks after `prefix`, e.g. the tag of "missing field `type`".
fn quoted_after(message: &str, prefix: &str) -> Option<String> {
    let rest = &message[message.find(prefix)? + prefix.len()..];
    let rest = rest.strip_prefix('`')?;
    Some(rest[..rest.find('`')?].to_string())
}

/// Explores the value at `steps` (which is known to exist in the format) and records what it holds.
fn explore(steps: &mut Vec<Step>, format: &mut Format, depth: usize) {
    assert!(
        depth < 16,
        "the format nests deeper than expected at {steps:?}"
    );
    let Some(message) = parse_error(&document(steps, json!({ PROBE: 1 }))) else {
        // A free-form value (a JSON object of any keys): nothing below it is part of the format.
        return;
    };
    if message.starts_with(&format!("unknown field `{PROBE}`")) {
        // A struct: recurse into each field.
        for field in expected_names(&message) {
            steps.push(Step::Field(field));
            format.fields.insert(path_of(steps));
            explore(steps, format, depth + 1);
            steps.pop();
        }
    } else if message.starts_with(&format!("unknown variant `{PROBE}`")) {
        // An externally tagged enum: each variant is `"name"` or `{"name": content}`.
        for variant in expected_names(&message) {
            format.variants.insert((path_of(steps), variant.clone()));
            steps.push(Step::Variant(variant));
            explore(steps, format, depth + 1);
            steps.pop();
        }
    } else if let Some(tag) = quoted_after(&message, "missing field ") {
        // An internally tagged enum: find its variants from the tag, then each variant's fields.
        let tag_probe = document(steps, json!({ tag.as_str(): PROBE }));
        let tag_message = parse_error(&tag_probe).unwrap_or_default();
        if !tag_message.starts_with(&format!("unknown variant `{PROBE}`")) {
            // Not a tag: the value here is free-form JSON (it took the probe), and the error is
            // the enclosing struct's, missing its other fields.
            return;
        }
        let variants = expected_names(&tag_message);
        steps.push(Step::Field(tag.clone()));
        format.fields.insert(path_of(steps));
        for variant in &variants {
            format.variants.insert((path_of(steps), variant.clone()));
        }
        steps.pop();
        for variant in variants {
            steps.push(Step::Tagged {
                tag: tag.clone(),
                variant,
            });
            explore(steps, format, depth + 1);
            steps.pop();
        }
    } else if message.contains("expected a sequence") || message.contains("expected an array") {
        // An array (or fixed-size tuple): its elements may be structs.
        steps.push(Step::Element);
        explore(steps, format, depth + 1);
        steps.pop();
    }
    // Anything else is a leaf: a number, string, or a value with a custom deserializer.
}

/// The scene format, derived from the types.
fn derive_format() -> Format {
    let mut format = Format::default();
    explore(&mut Vec::new(), &mut format, 0);
    format
}

/// The doc's text.
fn doc_text() -> String {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/../docs/scene-format.md");
    std::fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {path}: {e}"))
}

/// What `doc` leaves out: field paths not in backticks, variants not in double quotes.
fn missing_from(doc: &str, format: &Format) -> Vec<String> {
    let mut missing: Vec<String> = format
        .fields
        .iter()
        .filter(|f| !doc.contains(&format!("`{f}`")))
        .map(|f| format!("field `{f}`"))
        .collect();
    missing.extend(
        format
            .variants
            .iter()
            .filter(|(_, v)| !doc.contains(&format!("\"{v}\"")))
            .map(|(path, v)| format!("variant \"{v}\" of `{path}`")),
    );
    missing
}

#[test]
fn derivation_finds_the_known_fields_and_variants() {
    let format = derive_format();
    for field in [
        "name",
        "description",
        "cloth.rows",
        "cloth.particle_mass",
        "material.stretch",
        "material.bending.model",
        "material.bending.stiffness",
        "physics.dt",
        "physics.gravity",
        "controls",
        "obstacles",
        "obstacles[i].type",
        "obstacles[i].centers",
        "obstacles[i].radii",
        "obstacles[i].point",
        "obstacles[i].normal",
        "obstacles[i].role",
        "task.horizon",
        "task.targets[i].particle",
        "task.targets[i].position",
        "task.delta",
        "task.initial_controls",
        "task.initial_controls.constant",
        "task.initial_controls.explicit",
        "custom_constraints[i].type",
        "custom_constraints[i].params",
    ] {
        assert!(
            format.fields.contains(field)
                || format
                    .variants
                    .iter()
                    .any(|(p, v)| format!("{p}.{v}") == field),
            "the derivation missed `{field}`; found {:?}",
            format.fields
        );
    }
    let variants: BTreeSet<&str> = format.variants.iter().map(|(_, v)| v.as_str()).collect();
    for v in [
        "zeros", "constant", "explicit", "spheres", "plane", "safety", "collider", "both",
        "distance", "dihedral",
    ] {
        assert!(variants.contains(v), "the derivation missed variant {v:?}");
    }
}

#[test]
fn every_field_of_the_format_is_documented() {
    let format = derive_format();
    let missing = missing_from(&doc_text(), &format);
    assert!(
        missing.is_empty(),
        "docs/scene-format.md does not document: {}",
        missing.join(", ")
    );
}

#[test]
fn the_check_fails_when_a_field_is_left_out() {
    let format = derive_format();
    let doc = doc_text();
    let without = doc.replace("`task.targets[i].position`", "task targets position");
    assert_eq!(
        missing_from(&without, &format),
        vec!["field `task.targets[i].position`".to_string()]
    );
    let without = doc.replace("\"dihedral\"", "dihedral");
    assert_eq!(missing_from(&without, &format).len(), 1);
}
