//! Numbers in JSON reports that may be infinite or not a number: finite values as
//! numbers, the others as the texts `inf`, `-inf` and `nan` (JSON has no such numbers;
//! serde_json would write `null`, which a reader takes for "none"). Use with
//! `#[serde(with = "crate::io::json_number")]`; [`option`] for `Option<f64>`, whose
//! `null` then always means none.

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

#[derive(Deserialize)]
#[serde(untagged)]
enum NumOrText {
    Num(f64),
    Text(String),
}

fn read<E: serde::de::Error>(v: NumOrText) -> Result<f64, E> {
    match v {
        NumOrText::Num(v) => Ok(v),
        NumOrText::Text(t) => match t.as_str() {
            "inf" => Ok(f64::INFINITY),
            "-inf" => Ok(f64::NEG_INFINITY),
            "nan" => Ok(f64::NAN),
            other => Err(E::custom(format!(
                "`{other}` is not a number (nor inf, -inf, nan)"
            ))),
        },
    }
}

/// Reads a number or one of the texts `inf`, `-inf`, `nan`.
pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    read(NumOrText::deserialize(d)?)
}

pub mod option {
    //! `Option<f64>` as [`super`] writes `f64`: `null` for none.

    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes none as `null`, a value as [`super::serialize`] does.
    pub fn serialize<S: Serializer>(v: &Option<f64>, s: S) -> Result<S::Ok, S::Error> {
        match v {
            None => s.serialize_none(),
            Some(x) => super::serialize(x, s),
        }
    }

    /// Reads `null` as none, else as [`super::deserialize`] does.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<f64>, D::Error> {
        Option::<super::NumOrText>::deserialize(d)?
            .map(super::read)
            .transpose()
    }
}
