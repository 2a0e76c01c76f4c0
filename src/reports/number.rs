//! Numbers that may be infinite or not a number, in JSON: finite values as numbers, the others
//! as the texts `inf`, `-inf` and `nan` (JSON has no such numbers). Use with
//! `#[serde(with = "crate::reports::number")]`.

use serde::{Deserialize, Deserializer, Serializer};

/// Writes `v`: a number when finite, else `inf`, `-inf` or `nan`.
pub fn serialize<S: Serializer>(v: &f64, s: S) -> Result<S::Ok, S::Error> {
    if v.is_finite() {
        s.serialize_f64(*v)
    } else if v.is_nan() {
        s.serialize_str("nan")
    } else if *v > 0.0 {
        s.serialize_str("inf")
    } else {
        s.serialize_str("-inf")
    }
}

/// Reads a number or one of the texts `inf`, `-inf`, `nan`.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    #[derive(Deserialize)]
    #[serde(untagged)]
    enum NumOrText {
        Num(f64),
        Text(String),
    }
    match NumOrText::deserialize(d)? {
        NumOrText::Num(v) => Ok(v),
        NumOrText::Text(t) => match t.as_str() {
            "inf" => Ok(f64::INFINITY),
            "-inf" => Ok(f64::NEG_INFINITY),
            "nan" => Ok(f64::NAN),
            other => Err(serde::de::Error::custom(format!(
                "`{other}` is not a number (nor inf, -inf, nan)"
            ))),
        },
    }
}
