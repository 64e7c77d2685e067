//! Pretty JSON of any `serde::Serialize` value, written atomically.
//!
//! `serde_json` silently turns NaN and infinities into `null`; here the value is first walked by
//! a checking serializer that refuses them, naming the JSON path of the offending number
//! (e.g. `backbone[3].omega`).

use std::fmt::Display;
use std::path::Path;

use serde::ser::{self, Serialize};

use crate::atomic::write_atomic;
use crate::OutputError;

/// Serializes `value` as pretty JSON, refusing non-finite numbers; `what` names the output in
/// errors.
pub fn to_json_string<T: Serialize + ?Sized>(what: &str, value: &T) -> Result<String, OutputError> {
    serialize(what, value, true)
}

/// `value` as JSON, pretty or compact (one line: for large number arrays, where the pretty form's
/// one number per indented line doubles the size), non-finite numbers refused.
fn serialize<T: Serialize + ?Sized>(
    what: &str,
    value: &T,
    pretty: bool,
) -> Result<String, OutputError> {
    value
        .serialize(FiniteCheck {
            path: String::new(),
        })
        .map_err(|e| match e {
            CheckError::NonFinite { path, value } => OutputError::NonFinite {
                what: format!(
                    "{what}, JSON value `{}`",
                    if path.is_empty() { "(root)" } else { &path }
                ),
                index: 0,
                value,
            },
            CheckError::Custom(msg) => OutputError::invalid(what.to_string(), msg),
        })?;
    let text = if pretty {
        serde_json::to_string_pretty(value)
    } else {
        serde_json::to_string(value)
    };
    let mut text = text.map_err(|e| OutputError::invalid(what.to_string(), e.to_string()))?;
    text.push('\n');
    Ok(text)
}

/// Writes `value` as pretty JSON to `path` atomically (see [`to_json_string`]).
pub fn write_json<T: Serialize + ?Sized>(path: &Path, value: &T) -> Result<(), OutputError> {
    let text = to_json_string(&path.display().to_string(), value)?;
    write_atomic(path, text.as_bytes())
}

/// Writes `value` as compact (one-line) JSON to `path` atomically, non-finite numbers refused:
/// for files of large number arrays (backbone.json: every orbit's Fourier coefficients).
pub fn write_json_compact<T: Serialize + ?Sized>(
    path: &Path,
    value: &T,
) -> Result<(), OutputError> {
    let text = serialize(&path.display().to_string(), value, false)?;
    write_atomic(path, text.as_bytes())
}

#[derive(Debug)]
enum CheckError {
    NonFinite { path: String, value: f64 },
    Custom(String),
}

impl Display for CheckError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            CheckError::NonFinite { path, value } => write!(f, "non-finite {value} at {path}"),
            CheckError::Custom(m) => f.write_str(m),
        }
    }
}

impl std::error::Error for CheckError {}

impl ser::Error for CheckError {
    fn custom<T: Display>(msg: T) -> Self {
        CheckError::Custom(msg.to_string())
    }
}

/// A serializer that produces nothing and fails on the first non-finite float.
struct FiniteCheck {
    path: String,
}

impl FiniteCheck {
    fn child(&self, key: impl Display) -> FiniteCheck {
        FiniteCheck {
            path: if self.path.is_empty() {
                key.to_string()
            } else {
                format!("{}.{key}", self.path)
            },
        }
    }

    fn index(&self, i: usize) -> FiniteCheck {
        FiniteCheck {
            path: format!("{}[{i}]", self.path),
        }
    }

    fn float(&self, v: f64) -> Result<(), CheckError> {
        if v.is_finite() {
            Ok(())
        } else {
            Err(CheckError::NonFinite {
                path: self.path.clone(),
                value: v,
            })
        }
    }
}

/// Compound-value walker: sequences count their elements, maps and structs name their keys.
struct Compound {
    parent: FiniteCheck,
    next: usize,
    key: Option<String>,
}

impl Compound {
    fn new(parent: FiniteCheck) -> Self {
        Compound {
            parent,
            next: 0,
            key: None,
        }
    }

    fn element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        let c = self.parent.index(self.next);
        self.next += 1;
        value.serialize(c)
    }
}

macro_rules! ok_scalars {
    ($($name:ident: $t:ty),* $(,)?) => {
        $(fn $name(self, _v: $t) -> Result<(), CheckError> { Ok(()) })*
    };
}

impl ser::Serializer for FiniteCheck {
    type Ok = ();
    type Error = CheckError;
    type SerializeSeq = Compound;
    type SerializeTuple = Compound;
    type SerializeTupleStruct = Compound;
    type SerializeTupleVariant = Compound;
    type SerializeMap = Compound;
    type SerializeStruct = Compound;
    type SerializeStructVariant = Compound;

    ok_scalars!(
        serialize_bool: bool,
        serialize_i8: i8,
        serialize_i16: i16,
        serialize_i32: i32,
        serialize_i64: i64,
        serialize_i128: i128,
        serialize_u8: u8,
        serialize_u16: u16,
        serialize_u32: u32,
        serialize_u64: u64,
        serialize_u128: u128,
        serialize_char: char,
        serialize_str: &str,
        serialize_bytes: &[u8],
    );

    fn serialize_f32(self, v: f32) -> Result<(), CheckError> {
        self.float(f64::from(v))
    }
    fn serialize_f64(self, v: f64) -> Result<(), CheckError> {
        self.float(v)
    }
    fn serialize_none(self) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_some<T: Serialize + ?Sized>(self, value: &T) -> Result<(), CheckError> {
        value.serialize(self)
    }
    fn serialize_unit(self) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_unit_struct(self, _name: &'static str) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_unit_variant(
        self,
        _name: &'static str,
        _index: u32,
        _variant: &'static str,
    ) -> Result<(), CheckError> {
        Ok(())
    }
    fn serialize_newtype_struct<T: Serialize + ?Sized>(
        self,
        _name: &'static str,
        value: &T,
    ) -> Result<(), CheckError> {
        value.serialize(self)
    }
    fn serialize_newtype_variant<T: Serialize + ?Sized>(
        self,
        _name: &'static str,
        _index: u32,
        variant: &'static str,
        value: &T,
    ) -> Result<(), CheckError> {
        value.serialize(self.child(variant))
    }
    fn serialize_seq(self, _len: Option<usize>) -> Result<Compound, CheckError> {
        Ok(Compound::new(self))
    }
    fn serialize_tuple(self, _len: usize) -> Result<Compound, CheckError> {
        Ok(Compound::new(self))
    }
    fn serialize_tuple_struct(
        self,
        _name: &'static str,
        _len: usize,
    ) -> Result<Compound, CheckError> {
        Ok(Compound::new(self))
    }
    fn serialize_tuple_variant(
        self,
        _name: &'static str,
        _index: u32,
        variant: &'static str,
        _len: usize,
    ) -> Result<Compound, CheckError> {
        Ok(Compound::new(self.child(variant)))
    }
    fn serialize_map(self, _len: Option<usize>) -> Result<Compound, CheckError> {
        Ok(Compound::new(self))
    }
    fn serialize_struct(self, _name: &'static str, _len: usize) -> Result<Compound, CheckError> {
        Ok(Compound::new(self))
    }
    fn serialize_struct_variant(
        self,
        _name: &'static str,
        _index: u32,
        variant: &'static str,
        _len: usize,
    ) -> Result<Compound, CheckError> {
        Ok(Compound::new(self.child(variant)))
    }
}

impl ser::SerializeSeq for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        self.element(value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeTuple for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_element<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        self.element(value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeTupleStruct for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        self.element(value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeTupleVariant for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_field<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        self.element(value)
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeMap for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_key<T: Serialize + ?Sized>(&mut self, key: &T) -> Result<(), CheckError> {
        // Keys are checked too (a float key would be written as text by serde_json) and
        // remembered, as text, to name the value's path.
        key.serialize(self.parent.child("<key>"))?;
        self.key = Some(
            serde_json::to_value(key)
                .ok()
                .and_then(|v| v.as_str().map(str::to_string).or(Some(v.to_string())))
                .unwrap_or_else(|| "?".to_string()),
        );
        Ok(())
    }
    fn serialize_value<T: Serialize + ?Sized>(&mut self, value: &T) -> Result<(), CheckError> {
        let key = self.key.take().unwrap_or_else(|| "?".to_string());
        value.serialize(self.parent.child(key))
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeStruct for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), CheckError> {
        value.serialize(self.parent.child(key))
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

impl ser::SerializeStructVariant for Compound {
    type Ok = ();
    type Error = CheckError;
    fn serialize_field<T: Serialize + ?Sized>(
        &mut self,
        key: &'static str,
        value: &T,
    ) -> Result<(), CheckError> {
        value.serialize(self.parent.child(key))
    }
    fn end(self) -> Result<(), CheckError> {
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde::Serialize;
    use std::collections::BTreeMap;

    #[derive(Serialize)]
    struct Point {
        q: f64,
        omega: f64,
        note: Option<String>,
    }

    #[test]
    fn compact_json_is_one_line_that_reads_back_and_refuses_nan() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("b.json");
        let points = vec![1.5f64, -2.25, 3e-9];
        write_json_compact(&path, &points).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        assert_eq!(text.trim_end().lines().count(), 1, "{text}");
        let back: Vec<f64> = serde_json::from_str(&text).unwrap();
        assert_eq!(back, points);
        let bad = write_json_compact(&dir.path().join("c.json"), &[f64::NAN]);
        assert!(bad.is_err());
        assert!(!dir.path().join("c.json").exists());
    }

    #[derive(Serialize)]
    struct Results {
        name: &'static str,
        backbone: Vec<Point>,
        extra: BTreeMap<String, (f32, f64)>,
    }

    fn results(bad: Option<usize>) -> Results {
        let mut backbone: Vec<Point> = (0..5)
            .map(|i| Point {
                q: i as f64,
                omega: 1.0 + 0.01 * i as f64,
                note: None,
            })
            .collect();
        if let Some(i) = bad {
            backbone[i].omega = f64::NAN;
        }
        let mut extra = BTreeMap::new();
        extra.insert("mode 1".to_string(), (1.5f32, 2.0));
        Results {
            name: "blade",
            backbone,
            extra,
        }
    }

    #[test]
    fn finite_value_round_trips() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("r.json");
        write_json(&path, &results(None)).expect("write");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&path).expect("read")).expect("parse");
        assert_eq!(v["backbone"][3]["omega"].as_f64(), Some(1.03));
        assert_eq!(v["extra"]["mode 1"][0].as_f64(), Some(1.5));
        assert!(v["backbone"][0]["note"].is_null());
    }

    #[test]
    fn nan_is_refused_with_its_path() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("bad.json");
        let err = write_json(&path, &results(Some(3))).expect_err("NaN");
        let msg = err.to_string();
        assert!(
            msg.contains("backbone[3].omega") && msg.contains("bad.json"),
            "{msg}"
        );
        assert!(!path.exists());
        let mut m = BTreeMap::new();
        m.insert("k", vec![1.0, f64::NEG_INFINITY]);
        let msg = to_json_string("m", &m).expect_err("inf").to_string();
        assert!(msg.contains("k[1]"), "{msg}");
        assert!(to_json_string("x", &f32::INFINITY).is_err());
    }
}
