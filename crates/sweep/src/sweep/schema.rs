//! The sweep file's JSON Schema (`chainsweep schema`), derived from the serde types that read it
//! (this module's parent and the solver's scene types), so that it cannot drift from them.
//!
//! The schema checks structure: the fields of every object (unknown ones refused), their types,
//! the names of methods, probe kinds and presets. Ranges that depend on other fields (a probe
//! beyond the chain, a damping that makes the scene absurd) are for `chainsweep validate`.

use schemars::{json_schema, JsonSchema, Schema, SchemaGenerator};
use serde_json::Value;

use chainsweep_solver::{IntegratorSpec, Scene};

use super::{SweepFile, CHAIN_PRESETS};

/// The file name under which the schema is published (beside the docs, and in the wheel).
pub const SCHEMA_FILE_NAME: &str = "chainsweep-sweep.schema.json";

/// The JSON Schema (draft 2020-12) of a sweep file.
pub fn sweep_file_schema() -> Value {
    let schema = schemars::schema_for!(SweepFile);
    schema.to_value()
}

/// The sweep file's `base`: a scene whose chain may start from a preset and whose integrator may
/// be `auto`.
pub(super) struct BaseScene;

impl JsonSchema for BaseScene {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "BaseScene".into()
    }

    fn json_schema(generator: &mut SchemaGenerator) -> Schema {
        let mut scene = Scene::json_schema(generator);
        let chain = generator.subschema_for::<chainsweep_solver::ChainSpec>();
        let integrator = generator.subschema_for::<IntegratorSpec>();
        let properties = scene
            .get_mut("properties")
            .and_then(Value::as_object_mut)
            .expect("a scene's schema lists its properties");
        // A scene's top-level numbers may be derived fields, `{"expr": "…"}`.
        for (_, prop) in properties.iter_mut() {
            if prop.get("type").and_then(Value::as_str) == Some("number") {
                let number = prop.clone();
                *prop = serde_json::json!({
                    "anyOf": [number, {
                        "type": "object",
                        "description": "A derived field: an expression of the point's axis values (by axis name) and the base scene's numbers (by dotted path), e.g. \"settle_s + 200 / frequency_hz\".",
                        "properties": {"expr": {"type": "string"}},
                        "required": ["expr"],
                        "additionalProperties": false
                    }]
                });
            }
        }
        properties.insert(
            "chain".into(),
            json_schema!({
                "description": "Geometry and materials: a chain written out, or a preset with overrides.",
                "oneOf": [chain, preset_chain()]
            })
            .to_value(),
        );
        properties.insert(
            "integrator".into(),
            json_schema!({
                "description": "The integrator and its accuracy settings, or `auto`: the cheapest setting that meets a target error, chosen before the sweep runs.",
                "anyOf": [integrator, auto_integrator()]
            })
            .to_value(),
        );
        scene.insert(
            "description".into(),
            "The scene every grid point starts from (a chain may start from a preset; the integrator may be `auto`).".into(),
        );
        scene
    }
}

/// `{"preset": NAME, …overrides}`: a preset chain whose fields the others override.
fn preset_chain() -> Value {
    json_schema!({
        "type": "object",
        "description": "A preset of the paper's chain, with any of its fields overridden (objects are merged field by field).",
        "required": ["preset"],
        "properties": {
            "preset": {"enum": CHAIN_PRESETS},
            "cylinders": {"type": "integer", "minimum": 0, "description": "Number of cylinders (default 50)."},
            "sphere": {"type": "object"},
            "cylinder": {"type": "object"},
            "striker": {"type": "object"},
            "wall_material": {"type": "object"}
        },
        "additionalProperties": false
    })
    .to_value()
}

/// `{"method": "auto", "target_rel_error": …, "pilot_points": …}`.
fn auto_integrator() -> Value {
    json_schema!({
        "type": "object",
        "description": "The cheapest integrator setting whose relative error stays below `target_rel_error` at pilot points of the grid.",
        "required": ["method", "target_rel_error"],
        "properties": {
            "method": {"const": "auto"},
            "target_rel_error": {"type": "number", "exclusiveMinimum": 0},
            "pilot_points": {"type": "integer", "minimum": 1, "maximum": super::auto::MAX_PILOT_POINTS}
        },
        "additionalProperties": false
    })
    .to_value()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_schema_names_every_top_level_field_and_refuses_others() {
        let s = sweep_file_schema();
        let props = s["properties"].as_object().unwrap();
        for field in [
            "$schema",
            "description",
            "base",
            "record",
            "axes",
            "limits",
            "search",
        ] {
            assert!(props.contains_key(field), "{field} missing");
        }
        assert_eq!(s["additionalProperties"], Value::Bool(false));
        assert_eq!(s["required"], serde_json::json!(["base"]));
    }
}
