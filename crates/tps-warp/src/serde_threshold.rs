//! The serde form of a pairing threshold: a number, or none (`null` in JSON) for unlimited.
//! JSON has no infinity; serde_json writes one as `null` and cannot read that back into a
//! number, so an unlimited threshold is written as a missing value on purpose.

use serde::{Deserialize, Deserializer, Serialize, Serializer};

/// Writes `+∞` as none, anything else as the number.
pub(crate) fn serialize<S: Serializer>(threshold: &f32, serializer: S) -> Result<S::Ok, S::Error> {
    (*threshold != f32::INFINITY)
        .then_some(*threshold)
        .serialize(serializer)
}

/// Reads none as `+∞`.
pub(crate) fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<f32, D::Error> {
    Ok(Option::<f32>::deserialize(deserializer)?.unwrap_or(f32::INFINITY))
}
