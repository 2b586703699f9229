//! `--params FILE`: parameters read from JSON, with the flags given on the command line
//! taking precedence.
//!
//! A document is either the parameters themselves (any subset of the fields, nested objects
//! included) or a report written by the same command's `--report`, whose parameters are
//! under one key; so a report reproduces its run. Fields the document leaves out keep the
//! command's defaults, also inside nested objects (serde alone would fill a nested object
//! from its own type's defaults, which are not always the command's).

use std::path::Path;

use clap::ArgMatches;
use clap::parser::ValueSource;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::Value;

use crate::CliResult;

/// Which arguments of one subcommand were given on the command line (rather than left at
/// their defaults).
#[derive(Debug, Clone, Copy)]
pub struct GivenFlags<'a>(Option<&'a ArgMatches>);

impl<'a> GivenFlags<'a> {
    /// The flags of the subcommand `name` in `matches`.
    pub fn of(matches: &'a ArgMatches, name: &str) -> Self {
        Self(matches.subcommand_matches(name))
    }

    /// Whether the argument `id` (its field name) was given on the command line.
    pub fn has(&self, id: &str) -> bool {
        self.0
            .and_then(|m| m.value_source(id))
            .is_some_and(|source| source == ValueSource::CommandLine)
    }

    /// Puts `value` in `slot` when the argument `id` was given on the command line.
    pub fn apply<T>(&self, id: &str, slot: &mut T, value: T) {
        if self.has(id) {
            *slot = value;
        }
    }
}

/// Reads the parameter document at `path` over `defaults`: the parameters themselves, or a
/// report whose `report_key` holds them. Errors name the file: unreadable, not JSON, not an
/// object, or a field the parameters do not have or with a value of the wrong kind.
pub fn read_params<T: Serialize + DeserializeOwned>(
    path: &Path,
    report_key: &str,
    defaults: &T,
) -> CliResult<T> {
    let name = path.display();
    let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {name}: {e}"))?;
    let document: Value = serde_json::from_str(&text)
        .map_err(|e| format!("{name} is not a JSON parameter file: {e}"))?;
    let Value::Object(mut fields) = document else {
        return Err(format!("{name} must hold a JSON object of parameters").into());
    };
    let given = match fields.remove(report_key) {
        Some(Value::Object(params)) => params,
        _ => fields,
    };
    let mut merged = serde_json::to_value(defaults)?;
    merge(&mut merged, Value::Object(given));
    Ok(serde_json::from_value(merged).map_err(|e| format!("{name}: {e}"))?)
}

/// Writes `given` over `base`. An object merges field by field into an object that has
/// every one of its fields (a struct's fields); any other value replaces what was there,
/// including an object naming a field `base` lacks: another enum variant (`{"absolute":
/// …}` over `{"scale": …}`), or a misspelt field, which deserializing then refuses by name.
fn merge(base: &mut Value, given: Value) {
    match (base, given) {
        (Value::Object(base), Value::Object(given))
            if given.keys().all(|k| base.contains_key(k)) =>
        {
            for (key, value) in given {
                if let Some(slot) = base.get_mut(&key) {
                    merge(slot, value);
                }
            }
        }
        (slot, given) => *slot = given,
    }
}

#[cfg(test)]
mod tests {
    use super::merge;
    use serde_json::json;

    #[test]
    fn merging_keeps_what_the_document_leaves_out_and_replaces_variants() {
        let mut base = json!({
            "seed": 0,
            "clusters": { "max_points": 12, "max_variation": 0.1 },
            "output": { "scale": 2.0 },
            "pairing": null,
        });
        merge(
            &mut base,
            json!({
                "clusters": { "max_points": 4 },
                "output": { "absolute": [3.0, 2.0] },
                "pairing": { "w_n": 1.0 },
            }),
        );
        assert_eq!(
            base,
            json!({
                "seed": 0,
                "clusters": { "max_points": 4, "max_variation": 0.1 },
                "output": { "absolute": [3.0, 2.0] },
                "pairing": { "w_n": 1.0 },
            })
        );
        // A misspelt nested field replaces the object, so deserializing names it.
        merge(&mut base, json!({ "clusters": { "max_pts": 4 } }));
        assert_eq!(base["clusters"], json!({ "max_pts": 4 }));
    }
}
