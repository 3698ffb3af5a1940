//! Python values read into the flight messages as strictly as the wire reads bytes
//! (`Fsw.step`, `Fsw.request`, `frame_to_bytes`). `pythonize` reads a `bool` field by the
//! object's truthiness (`"false"` is true), an `int` field from a `bool`, and ignores dict
//! keys that are no field; on the wire, postcard refuses a bool byte other than 0 or 1, an
//! unknown variant, and a frame with bytes left over (`FrameError::Decode`). Here:
//!
//! - a bool field takes `True`/`False` (or a `numpy.bool_`) only;
//! - an integer field takes an `int` (or an object with `__index__`, such as a numpy
//!   integer), not a bool, and within the field's range;
//! - a float field takes a real number (`float`, `int`, numpy floats), not a bool; an f32
//!   field refuses a finite value beyond the f32 range (it would arrive as ±∞). NaN and ±∞
//!   given as such are carried, as the wire carries them: the flight code judges them;
//! - a struct is a dict with exactly its fields (an unknown key is refused, naming it);
//! - a fixed array is a list, tuple or 1-D numpy array of exactly its length;
//! - an enum is its variant's name (a variant without data) or a one-key dict
//!   `{variant: value}`.
//!
//! Every refusal names the field by its path (`FreezeAdaptation.frozen`, `rate_rad_s[2]`).

use pyo3::prelude::*;
use pyo3::types::{PyBool, PyBytes, PyDict, PyFloat, PyInt, PyList, PyString, PyTuple};
use serde::de::{self, DeserializeSeed, IntoDeserializer, Visitor};
use std::fmt::Display;

/// A refusal, with the path of the field it concerns (the innermost one).
#[derive(Debug)]
pub struct StrictError {
    path: Option<String>,
    msg: String,
}

impl de::Error for StrictError {
    fn custom<T: Display>(msg: T) -> Self {
        Self { path: None, msg: msg.to_string() }
    }
}

impl Display for StrictError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.path.as_deref() {
            Some(p) if !p.is_empty() => write!(f, "`{p}`: {}", self.msg),
            _ => write!(f, "{}", self.msg),
        }
    }
}

impl std::error::Error for StrictError {}

impl From<PyErr> for StrictError {
    fn from(e: PyErr) -> Self {
        Self { path: None, msg: e.to_string() }
    }
}

type Result<T> = std::result::Result<T, StrictError>;

/// Reads `obj` as a `T` by the rules above.
pub fn from_py<T: de::DeserializeOwned>(obj: &Bound<'_, PyAny>) -> Result<T> {
    T::deserialize(Strict { obj: obj.clone(), path: String::new() })
}

/// One Python value at `path` (empty at the top).
struct Strict<'py> {
    obj: Bound<'py, PyAny>,
    path: String,
}

/// `obj`'s type and a short repr, for refusals (`str 'false'`).
fn describe(obj: &Bound<'_, PyAny>) -> String {
    let ty = obj.get_type().name().map(|n| n.to_string()).unwrap_or_else(|_| "?".into());
    let mut r = obj.repr().map(|r| r.to_string()).unwrap_or_default();
    if r.chars().count() > 40 {
        r = r.chars().take(37).collect::<String>() + "...";
    }
    format!("{ty} {r}")
}

/// `numpy.bool_` (a bool, though not a Python `bool`).
fn is_numpy_bool(obj: &Bound<'_, PyAny>) -> bool {
    let ty = obj.get_type();
    ty.module().is_ok_and(|m| m == "numpy") && ty.name().is_ok_and(|n| n == "bool_" || n == "bool")
}

fn join(path: &str, key: &str) -> String {
    if path.is_empty() { key.to_owned() } else { format!("{path}.{key}") }
}

impl<'py> Strict<'py> {
    fn child(&self, obj: Bound<'py, PyAny>, key: &str) -> Self {
        Self { obj, path: join(&self.path, key) }
    }

    fn fail(&self, msg: impl Display) -> StrictError {
        StrictError { path: Some(self.path.clone()), msg: msg.to_string() }
    }

    fn wrong(&self, expected: &str) -> StrictError {
        self.fail(format!("expected {expected}, got {}", describe(&self.obj)))
    }

    /// An error from below keeps its (deeper) path; one without gets this value's.
    fn at<T>(&self, r: Result<T>) -> Result<T> {
        r.map_err(|mut e| {
            e.path.get_or_insert_with(|| self.path.clone());
            e
        })
    }

    /// An integer that is not a bool: an `int`, or an object with `__index__`.
    fn integer(&self) -> Result<i128> {
        if self.obj.is_instance_of::<PyBool>() || is_numpy_bool(&self.obj) {
            return Err(self.wrong("an integer (not a bool)"));
        }
        let int = if self.obj.is_instance_of::<PyInt>() {
            self.obj.clone()
        } else if self.obj.hasattr("__index__").unwrap_or(false) {
            self.obj.call_method0("__index__").map_err(|_| self.wrong("an integer"))?
        } else {
            return Err(self.wrong("an integer"));
        };
        int.extract::<i128>().map_err(|_| self.fail(format!("{} is out of range", describe(&self.obj))))
    }

    fn int_in<T: TryFrom<i128> + Display>(&self, ty: &str, min: T, max: T) -> Result<T> {
        let v = self.integer()?;
        T::try_from(v).map_err(|_| self.fail(format!("{v} is out of range for {ty} ({min}..={max})")))
    }

    /// A real number that is not a bool: `float` (numpy float64 included), `int`, or any
    /// `numbers.Real` (numpy float32).
    fn real(&self) -> Result<f64> {
        let obj = &self.obj;
        if obj.is_instance_of::<PyBool>() || is_numpy_bool(obj) {
            return Err(self.wrong("a number (not a bool)"));
        }
        if let Ok(f) = obj.cast::<PyFloat>() {
            return Ok(f.value());
        }
        let py = obj.py();
        let real = py.import("numbers").and_then(|m| m.getattr("Real"))?;
        if obj.is_instance_of::<PyInt>() || obj.is_instance(&real).unwrap_or(false) {
            return obj.extract::<f64>().map_err(|e| self.fail(format!("{}: {e}", describe(obj))));
        }
        Err(self.wrong("a number"))
    }

    /// The items of a list, tuple or 1-D numpy array.
    fn items(&self) -> Result<Vec<Bound<'py, PyAny>>> {
        let obj = &self.obj;
        if let Ok(l) = obj.cast::<PyList>() {
            return Ok(l.iter().collect());
        }
        if let Ok(t) = obj.cast::<PyTuple>() {
            return Ok(t.iter().collect());
        }
        let is_array = obj.get_type().name().is_ok_and(|n| n == "ndarray")
            && obj.getattr("ndim").and_then(|d| d.extract::<usize>()).is_ok_and(|d| d == 1);
        if is_array {
            let list = obj.call_method0("tolist")?;
            return Ok(list.cast::<PyList>().map_err(|_| self.wrong("a list"))?.iter().collect());
        }
        Err(self.wrong("a list"))
    }

    fn dict(&self) -> Result<&Bound<'py, PyDict>> {
        self.obj.cast::<PyDict>().map_err(|_| self.wrong("a dict"))
    }

    /// `(key, value)` of a dict whose keys are strings.
    fn entries(&self) -> Result<Vec<(String, Bound<'py, PyAny>)>> {
        self.dict()?
            .iter()
            .map(|(k, v)| match k.cast::<PyString>() {
                Ok(s) => Ok((s.to_string(), v)),
                Err(_) => Err(self.fail(format!("a key is {}, not a string", describe(&k)))),
            })
            .collect()
    }

    /// A struct: a dict with only its fields (serde says which are missing).
    fn strukt<'de, V: Visitor<'de>>(self, name: &str, fields: &'static [&'static str], visitor: V) -> Result<V::Value> {
        let entries = self.entries()?;
        if let Some((k, _)) = entries.iter().find(|(k, _)| !fields.contains(&k.as_str())) {
            return Err(self.fail(format!("unknown field `{k}` of {name} (its fields: {})", fields.join(", "))));
        }
        let mut access = Map { parent: &self, entries: entries.into_iter(), value: None };
        self.at(visitor.visit_map(&mut access))
    }

    fn seq<'de, V: Visitor<'de>>(self, len: Option<usize>, visitor: V) -> Result<V::Value> {
        let items = self.items()?;
        if let Some(n) = len.filter(|n| *n != items.len()) {
            return Err(self.fail(format!("expected {n} values, got {}", items.len())));
        }
        let mut access = Seq { parent: &self, items: items.into_iter(), index: 0 };
        let v = self.at(visitor.visit_seq(&mut access))?;
        match access.items.len() {
            0 => Ok(v),
            left => Err(self.fail(format!("expected {} values, got {}", access.index, access.index + left))),
        }
    }
}

macro_rules! ints {
    ($($method:ident $visit:ident $t:ty),*) => {$(
        fn $method<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
            let v = self.int_in(stringify!($t), <$t>::MIN, <$t>::MAX)?;
            self.at(visitor.$visit(v))
        }
    )*};
}

impl<'de, 'py> de::Deserializer<'de> for Strict<'py> {
    type Error = StrictError;

    /// Only for types that do not say what they expect (none of the flight messages).
    fn deserialize_any<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let o = &self.obj;
        if o.is_none() {
            self.deserialize_unit(visitor)
        } else if o.is_instance_of::<PyBool>() {
            self.deserialize_bool(visitor)
        } else if o.is_instance_of::<PyInt>() {
            self.deserialize_i64(visitor)
        } else if o.is_instance_of::<PyFloat>() {
            self.deserialize_f64(visitor)
        } else if o.is_instance_of::<PyString>() {
            self.deserialize_str(visitor)
        } else if o.is_instance_of::<PyDict>() {
            self.deserialize_map(visitor)
        } else {
            self.deserialize_seq(visitor)
        }
    }

    fn deserialize_bool<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let b = match self.obj.cast::<PyBool>() {
            Ok(b) => b.is_true(),
            Err(_) if is_numpy_bool(&self.obj) => self.obj.is_truthy()?,
            Err(_) => return Err(self.wrong("a bool (True or False)")),
        };
        self.at(visitor.visit_bool(b))
    }

    ints!(deserialize_i8 visit_i8 i8, deserialize_i16 visit_i16 i16, deserialize_i32 visit_i32 i32,
          deserialize_i64 visit_i64 i64, deserialize_u8 visit_u8 u8, deserialize_u16 visit_u16 u16,
          deserialize_u32 visit_u32 u32, deserialize_u64 visit_u64 u64);

    fn deserialize_f32<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let v = self.real()?;
        let f = v as f32;
        if v.is_finite() && !f.is_finite() {
            return Err(self.fail(format!("{v:e} is beyond the f32 range (±{:e}): the wire carries an f32", f32::MAX)));
        }
        self.at(visitor.visit_f32(f))
    }

    fn deserialize_f64<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let v = self.real()?;
        self.at(visitor.visit_f64(v))
    }

    fn deserialize_char<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.deserialize_str(visitor)
    }

    fn deserialize_str<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let s = self.obj.cast::<PyString>().map_err(|_| self.wrong("a string"))?.to_string();
        self.at(visitor.visit_str(&s))
    }

    fn deserialize_string<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.deserialize_str(visitor)
    }

    fn deserialize_bytes<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let b = self.obj.cast::<PyBytes>().map_err(|_| self.wrong("bytes"))?.as_bytes().to_vec();
        self.at(visitor.visit_bytes(&b))
    }

    fn deserialize_byte_buf<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.deserialize_bytes(visitor)
    }

    fn deserialize_option<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        if self.obj.is_none() {
            return self.at(visitor.visit_none());
        }
        let path = self.path.clone();
        visitor.visit_some(self).map_err(|mut e| {
            e.path.get_or_insert(path);
            e
        })
    }

    fn deserialize_unit<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        if !self.obj.is_none() {
            return Err(self.wrong("None"));
        }
        self.at(visitor.visit_unit())
    }

    fn deserialize_unit_struct<V: Visitor<'de>>(self, _name: &'static str, visitor: V) -> Result<V::Value> {
        self.deserialize_unit(visitor)
    }

    fn deserialize_newtype_struct<V: Visitor<'de>>(self, _name: &'static str, visitor: V) -> Result<V::Value> {
        visitor.visit_newtype_struct(self)
    }

    fn deserialize_seq<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.seq(None, visitor)
    }

    fn deserialize_tuple<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value> {
        self.seq(Some(len), visitor)
    }

    fn deserialize_tuple_struct<V: Visitor<'de>>(
        self,
        _name: &'static str,
        len: usize,
        visitor: V,
    ) -> Result<V::Value> {
        self.seq(Some(len), visitor)
    }

    fn deserialize_map<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        let entries = self.entries()?;
        let mut access = Map { parent: &self, entries: entries.into_iter(), value: None };
        self.at(visitor.visit_map(&mut access))
    }

    fn deserialize_struct<V: Visitor<'de>>(
        self,
        name: &'static str,
        fields: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        self.strukt(name, fields, visitor)
    }

    fn deserialize_enum<V: Visitor<'de>>(
        self,
        name: &'static str,
        variants: &'static [&'static str],
        visitor: V,
    ) -> Result<V::Value> {
        let known = |v: &str| -> Result<()> {
            if variants.contains(&v) {
                Ok(())
            } else {
                Err(self.fail(format!("unknown variant `{v}` of {name} (its variants: {})", variants.join(", "))))
            }
        };
        let (variant, value) = if let Ok(s) = self.obj.cast::<PyString>() {
            (s.to_string(), None)
        } else if let Ok(d) = self.obj.cast::<PyDict>() {
            let mut entries = self.entries()?;
            match (entries.pop(), entries.is_empty()) {
                (Some((k, v)), true) if d.len() == 1 => (k, Some(v)),
                _ => return Err(self.fail(format!("a {name} dict has one key, its variant (got {})", d.len()))),
            }
        } else {
            return Err(self.wrong(&format!("a {name}: a variant name, or a dict {{variant: value}}")));
        };
        known(&variant)?;
        let value = value.map(|v| self.child(v, &variant));
        let path = join(&self.path, &variant);
        self.at(visitor.visit_enum(Enum { variant, value, path }))
    }

    fn deserialize_identifier<V: Visitor<'de>>(self, visitor: V) -> Result<V::Value> {
        self.deserialize_str(visitor)
    }

    fn deserialize_ignored_any<V: Visitor<'de>>(self, _visitor: V) -> Result<V::Value> {
        Err(self.fail("a value that nothing reads"))
    }
}

/// The items of a list, each at `path[i]`.
struct Seq<'a, 'py> {
    parent: &'a Strict<'py>,
    items: std::vec::IntoIter<Bound<'py, PyAny>>,
    index: usize,
}

impl<'de> de::SeqAccess<'de> for Seq<'_, '_> {
    type Error = StrictError;

    fn next_element_seed<T: DeserializeSeed<'de>>(&mut self, seed: T) -> Result<Option<T::Value>> {
        let Some(obj) = self.items.next() else { return Ok(None) };
        let path = format!("{}[{}]", self.parent.path, self.index);
        self.index += 1;
        seed.deserialize(Strict { obj, path }).map(Some)
    }

    fn size_hint(&self) -> Option<usize> {
        Some(self.items.len())
    }
}

/// The entries of a dict, each value at `path.key`.
struct Map<'a, 'py> {
    parent: &'a Strict<'py>,
    entries: std::vec::IntoIter<(String, Bound<'py, PyAny>)>,
    value: Option<(String, Bound<'py, PyAny>)>,
}

impl<'de> de::MapAccess<'de> for Map<'_, '_> {
    type Error = StrictError;

    fn next_key_seed<K: DeserializeSeed<'de>>(&mut self, seed: K) -> Result<Option<K::Value>> {
        let Some((k, v)) = self.entries.next() else { return Ok(None) };
        let key = seed.deserialize(IntoDeserializer::<StrictError>::into_deserializer(k.clone()))?;
        self.value = Some((k, v));
        Ok(Some(key))
    }

    fn next_value_seed<T: DeserializeSeed<'de>>(&mut self, seed: T) -> Result<T::Value> {
        let (k, v) = self.value.take().ok_or_else(|| self.parent.fail("a value without its key"))?;
        seed.deserialize(self.parent.child(v, &k))
    }
}

/// An enum's variant and its value (`None`: given as the bare name).
struct Enum<'py> {
    variant: String,
    value: Option<Strict<'py>>,
    path: String,
}

impl<'de, 'py> de::EnumAccess<'de> for Enum<'py> {
    type Error = StrictError;
    type Variant = Self;

    fn variant_seed<V: DeserializeSeed<'de>>(self, seed: V) -> Result<(V::Value, Self)> {
        let v = seed.deserialize(IntoDeserializer::<StrictError>::into_deserializer(self.variant.clone()))?;
        Ok((v, self))
    }
}

impl<'de> de::VariantAccess<'de> for Enum<'_> {
    type Error = StrictError;

    /// A variant without data: its bare name, or `{name: None}`.
    fn unit_variant(self) -> Result<()> {
        match self.value {
            None => Ok(()),
            Some(v) if v.obj.is_none() => Ok(()),
            Some(v) => Err(v.fail(format!("`{}` takes no value (give the string {:?})", self.variant, self.variant))),
        }
    }

    fn newtype_variant_seed<T: DeserializeSeed<'de>>(self, seed: T) -> Result<T::Value> {
        seed.deserialize(self.value()?)
    }

    fn tuple_variant<V: Visitor<'de>>(self, len: usize, visitor: V) -> Result<V::Value> {
        self.value()?.seq(Some(len), visitor)
    }

    fn struct_variant<V: Visitor<'de>>(self, fields: &'static [&'static str], visitor: V) -> Result<V::Value> {
        let name = self.variant.clone();
        self.value()?.strukt(&name, fields, visitor)
    }
}

impl<'py> Enum<'py> {
    /// The value of a variant with data (given as the bare name: refused).
    fn value(self) -> Result<Strict<'py>> {
        match self.value {
            Some(v) => Ok(v),
            None => Err(StrictError {
                path: Some(self.path),
                msg: format!("`{}` needs a value: give a dict {{{:?}: ...}}", self.variant, self.variant),
            }),
        }
    }
}
