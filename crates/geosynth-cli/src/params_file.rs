//! `--params FILE`: parameters read from JSON, with the flags given on the command line
//! taking precedence.
//!
//! A document is either the parameters themselves (any subset of the fields, nested objects
//! included) or a report written by the same command's `--report`, whose parameters are
//! under one key; so a report reproduces its run. Fields the document leaves out keep the
//! command's defaults, also inside nested objects (serde alone would fill a nested object
//! from its own type's defaults, which are not always the command's).
//!
//! Reports name the command that wrote them under [`COMMAND_KEY`], and a report of another
//! command is refused as such. They also record how the input was read under
//! [`INPUT_OPTIONS_KEY`] (`--up`, `--relief`, `--orient-normals`, `--trim`,
//! `--orient-faces`…), which `--params` reads back like the parameters: a flag given on
//! the command line wins, and a switch (`--orient-normals`) can be turned on by either.

use std::fmt::Display;
use std::path::Path;

use clap::ArgMatches;
use clap::parser::ValueSource;
use serde::Serialize;
use serde::de::DeserializeOwned;
use serde_json::{Map, Value};

use crate::CliResult;

/// The key under which a report names the command that wrote it.
pub const COMMAND_KEY: &str = "command";

/// The key under which a report records how its input was read.
pub const INPUT_OPTIONS_KEY: &str = "input_options";

/// The reports one command's `--params` reads: its own, and those of the commands that
/// share its parameters.
#[derive(Debug, Clone, Copy)]
pub struct ReportKind {
    /// The command reading.
    pub command: &'static str,
    /// The key of the parameters in a report.
    pub params_key: &'static str,
    /// Other commands whose reports hold the same parameters (their input options, which
    /// describe another command's input, are not read).
    pub siblings: &'static [&'static str],
}

/// `quilt` reads its own reports (`QuiltParams` under `params`).
pub const QUILT_REPORTS: ReportKind = ReportKind {
    command: "quilt",
    params_key: "params",
    siblings: &[],
};

/// `voxel` reads its own reports (the `VoxelSynth` stage under `stage`).
pub const VOXEL_REPORTS: ReportKind = ReportKind {
    command: "voxel",
    params_key: "stage",
    siblings: &[],
};

/// `sdf` reads its own reports and `reconstruct`'s (`FieldParams` under `params`).
pub const SDF_REPORTS: ReportKind = ReportKind {
    command: "sdf",
    params_key: "params",
    siblings: &["reconstruct"],
};

/// `reconstruct` reads its own reports and `sdf`'s (`FieldParams` under `params`).
pub const RECONSTRUCT_REPORTS: ReportKind = ReportKind {
    command: "reconstruct",
    params_key: "params",
    siblings: &["sdf"],
};

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

/// The document of `--params`, if one was given: the parameters to read over a command's
/// defaults, and the input options of the run that wrote it.
#[derive(Debug, Default)]
pub struct ParamsFile(Option<Document>);

/// A parameter document as read.
#[derive(Debug)]
struct Document {
    /// The file's name, for errors.
    name: String,
    /// The parameters as written (a report's parameters key, or the whole document).
    params: Map<String, Value>,
    /// The report's input options, if it has them.
    input_options: Option<Value>,
}

impl ParamsFile {
    /// Reads the document at `path` (nothing to read for `None`): the parameters
    /// themselves (with input options if it has them), or a report of `kind`'s command (its
    /// parameters and input options) or of a sibling (its parameters). Errors name the
    /// file: unreadable, not JSON, not an object, or a report of another command.
    pub fn read(path: Option<&Path>, kind: ReportKind) -> CliResult<Self> {
        let Some(path) = path else {
            return Ok(Self(None));
        };
        let name = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| format!("cannot read {name}: {e}"))?;
        let document: Value = serde_json::from_str(&text)
            .map_err(|e| format!("{name} is not a JSON parameter file: {e}"))?;
        let Value::Object(mut fields) = document else {
            return Err(format!("{name} must hold a JSON object of parameters").into());
        };
        let own = match fields.remove(COMMAND_KEY) {
            Some(command) => report_is_own(&name, &command, kind)?,
            None => true,
        };
        let input_options = fields.remove(INPUT_OPTIONS_KEY).filter(|_| own);
        let params = match fields.remove(kind.params_key) {
            Some(Value::Object(params)) => params,
            Some(other) => {
                fields.insert(kind.params_key.to_string(), other);
                fields
            }
            None => fields,
        };
        Ok(Self(Some(Document {
            name,
            params,
            input_options,
        })))
    }

    /// The document's parameters over `defaults` (just `defaults` without a document),
    /// checked by `validate`. Errors name the file: a field the parameters do not have, a
    /// value of the wrong kind, or one `validate` refuses.
    pub fn params<T, E>(
        &self,
        defaults: T,
        validate: impl FnOnce(&T) -> Result<(), E>,
    ) -> CliResult<T>
    where
        T: Serialize + DeserializeOwned,
        E: Display,
    {
        let Some(Document { name, params, .. }) = &self.0 else {
            return Ok(defaults);
        };
        let mut merged = serde_json::to_value(defaults)?;
        merge(&mut merged, Value::Object(params.clone()));
        let params: T = serde_json::from_value(merged).map_err(|e| format!("{name}: {e}"))?;
        validate(&params).map_err(|e| format!("{name}: {e}"))?;
        Ok(params)
    }

    /// The input options the document records (`T::default()`, every option unset, when
    /// it records none), checked. Errors name the file and the option.
    pub fn input_options<T: RecordedInput>(&self) -> CliResult<T> {
        match &self.0 {
            Some(Document {
                name,
                input_options: Some(options),
                ..
            }) => {
                let options: T = serde_json::from_value(options.clone())
                    .map_err(|e| format!("{name}: {INPUT_OPTIONS_KEY}: {e}"))?;
                options
                    .check()
                    .map_err(|e| format!("{name}: {INPUT_OPTIONS_KEY}: {e}"))?;
                Ok(options)
            }
            _ => Ok(T::default()),
        }
    }
}

/// Refuses `value` (the option `name`) unless it is unset or a positive, finite number of
/// `unit`s: `relief must be a positive fraction, not 0`.
pub fn check_positive(name: &str, value: Option<f32>, unit: &str) -> Result<(), String> {
    match value {
        Some(v) if !(v.is_finite() && v > 0.0) => {
            Err(format!("{name} must be a positive {unit}, not {v}"))
        }
        _ => Ok(()),
    }
}

/// A command's input options as its reports record them under [`INPUT_OPTIONS_KEY`].
pub trait RecordedInput: DeserializeOwned + Default {
    /// Why recorded values cannot be used, if they cannot (checked as they are read, so
    /// the error names the file; by default every value can).
    fn check(&self) -> Result<(), String> {
        Ok(())
    }
}

/// Whether a report of `command` is `kind`'s command's own (`false`: a sibling's). Refuses
/// the report of any other command, whose parameters are another type.
fn report_is_own(name: &str, command: &Value, kind: ReportKind) -> CliResult<bool> {
    let Some(command) = command.as_str() else {
        return Err(
            format!("{name}: `{COMMAND_KEY}` must name the command that wrote the report").into(),
        );
    };
    if command == kind.command {
        return Ok(true);
    }
    if kind.siblings.contains(&command) {
        return Ok(false);
    }
    let readable = std::iter::once(&kind.command)
        .chain(kind.siblings)
        .map(|c| format!("`geosynth {c}`"))
        .collect::<Vec<_>>()
        .join(" or ");
    Err(format!(
        "{name} is a report of `geosynth {command}`, whose parameters `geosynth {}` does \
         not take; give a report of {readable}, or a parameter file",
        kind.command
    )
    .into())
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
