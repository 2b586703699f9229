//! Writing JSON reports a person can read.

use std::path::Path;
use std::time::Duration;

use geosynth::core::io::write_whole;
use serde::Serialize;
use serde_json::{Number, Value, json};

use crate::CliResult;
use crate::memory::peak_resident_bytes;
use crate::params_file::COMMAND_KEY;
use crate::phases::wall_seconds;

/// The key under which a report records the peak resident memory of the process that
/// wrote it, in bytes: everything the run held at once, reading and writing files included.
pub const PEAK_MEMORY_KEY: &str = "peak_memory_bytes";

/// The key under which a report records the seconds from the command's start to the
/// report's writing ([`crate::phases::wall_seconds`]): the time its `timings` share out.
pub const WALL_SECONDS_KEY: &str = "wall_seconds";

/// Writes the report of `geosynth COMMAND` to `path` as indented JSON, naming the command
/// under [`COMMAND_KEY`] (so `--params` can tell one command's report from another's) and
/// the process's peak resident memory so far under [`PEAK_MEMORY_KEY`] (`null` where the
/// platform does not tell) and the command's time so far under [`WALL_SECONDS_KEY`].
/// Numbers that are exactly a single-precision value are written as that value's shortest
/// decimal: `json!` and `serde_json::to_value` widen an `f32` to the `f64` it equals, which
/// prints `0.1f32` as `0.10000000149011612`. Read back as `f32` (as `--params` does), the
/// short form gives the same bits.
pub fn write_json_report(path: &Path, command: &str, report: &impl Serialize) -> CliResult {
    let mut value = serde_json::to_value(report)?;
    if let Value::Object(fields) = &mut value {
        fields.insert(COMMAND_KEY.to_string(), Value::from(command));
        fields.insert(
            PEAK_MEMORY_KEY.to_string(),
            Value::from(peak_resident_bytes()),
        );
        fields.insert(WALL_SECONDS_KEY.to_string(), Value::from(wall_seconds()));
    }
    shorten_single_precision(&mut value);
    let text = serde_json::to_string_pretty(&value)?;
    write_whole(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()).into())
}

/// Stage timings (a run's [`geosynth::core::RunContext::timings`]) as report entries, `{"stage": NAME,
/// "seconds": S}` in the order the stages first ran.
pub fn timings_json(timings: &[(String, Duration)]) -> Value {
    timings
        .iter()
        .map(|(stage, d)| json!({ "stage": stage, "seconds": d.as_secs_f64() }))
        .collect()
}

/// Rewrites, throughout `value`, every non-integer number that equals an `f32` as the
/// `f64` nearest to that `f32`'s shortest decimal.
fn shorten_single_precision(value: &mut Value) {
    match value {
        Value::Number(n) if n.is_f64() => {
            if let Some(short) = n.as_f64().and_then(shortest_single) {
                *n = short;
            }
        }
        Value::Array(items) => items.iter_mut().for_each(shorten_single_precision),
        Value::Object(fields) => fields.values_mut().for_each(shorten_single_precision),
        _ => {}
    }
}

/// `x`'s shortest decimal as an `f32`, when `x` is exactly a finite `f32`.
fn shortest_single(x: f64) -> Option<Number> {
    let single = x as f32;
    if !(single.is_finite() && f64::from(single) == x) {
        return None;
    }
    Number::from_f64(single.to_string().parse().ok()?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn single_precision_values_print_short_and_read_back_to_the_same_bits() {
        let mut value = json!({
            "epsilon": 0.1f32,
            "nested": [1.0f32 / 3.0, 2.5f32, 7],
            "seconds": 0.123456789f64,
            "big": 3.0e20f32,
        });
        shorten_single_precision(&mut value);
        let text = value.to_string();
        assert!(text.contains("\"epsilon\":0.1,"), "{text}");
        assert!(text.contains("0.33333334"), "{text}");
        // A double that is not a single-precision value keeps every digit.
        assert!(text.contains("0.123456789"), "{text}");
        assert_eq!(value["nested"][2], 7);
        for (read, original) in [
            (&value["epsilon"], 0.1f32),
            (&value["nested"][0], 1.0 / 3.0),
            (&value["nested"][1], 2.5),
            (&value["big"], 3.0e20),
        ] {
            let back: f32 = serde_json::from_value(read.clone()).unwrap();
            assert_eq!(back.to_bits(), original.to_bits());
        }
    }
}
