//! Attribute values as the protocol carries them, the per-prim attribute store (with time
//! samples) and primvars, plus typed accessors that turn a wrong type into a [`Problem`].

use glam::{DMat4, DVec3, Mat4, Vec2, Vec3};
use std::collections::HashMap;
use tide_core::Problem;

/// One attribute value (the protocol's `Value`).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Bool(bool),
    Int(i64),
    Float(f64),
    Token(String),
    String(String),
    /// A resolved asset path.
    Asset(String),
    Path(String),
    Paths(Vec<String>),
    Floats { data: Vec<f32>, tuple: u32 },
    /// Shared: a prim's converted state reads large arrays (instance matrices) from here
    /// rather than holding a copy.
    Doubles { data: std::sync::Arc<[f64]>, tuple: u32 },
    Ints(Vec<i32>),
    /// USD matrix: row-major, row vectors (p' = p·M), translation in elements 12..14.
    Matrix([f64; 16]),
}

/// World matrix `m` placed about `origin` (the scene is rendered about a point near the camera,
/// see `Delegate::assemble`): the translation is taken relative to it in double precision, so
/// what reaches single precision is small near the camera however far from the world origin.
pub fn about(origin: DVec3, m: &DMat4) -> Mat4 {
    (DMat4::from_translation(-origin) * *m).as_mat4()
}

impl Value {
    /// A short name of the variant, for messages.
    pub fn kind(&self) -> &'static str {
        match self {
            Value::Bool(_) => "bool",
            Value::Int(_) => "int",
            Value::Float(_) => "float",
            Value::Token(_) => "token",
            Value::String(_) => "string",
            Value::Asset(_) => "asset",
            Value::Path(_) => "path",
            Value::Paths(_) => "paths",
            Value::Floats { .. } => "floats",
            Value::Doubles { .. } => "doubles",
            Value::Ints(_) => "ints",
            Value::Matrix(_) => "matrix",
        }
    }

    pub fn as_f64(&self) -> Option<f64> {
        match self {
            Value::Float(f) => Some(*f),
            Value::Int(i) => Some(*i as f64),
            Value::Bool(b) => Some(*b as i32 as f64),
            Value::Floats { data, .. } if data.len() == 1 => Some(data[0] as f64),
            Value::Doubles { data, .. } if data.len() == 1 => Some(data[0]),
            Value::Ints(v) if v.len() == 1 => Some(v[0] as f64),
            _ => None,
        }
    }

    pub fn as_bool(&self) -> Option<bool> {
        match self {
            Value::Bool(b) => Some(*b),
            Value::Int(i) => Some(*i != 0),
            Value::Float(f) => Some(*f != 0.0),
            Value::Token(t) | Value::String(t) => match t.as_str() {
                "true" | "1" | "on" => Some(true),
                "false" | "0" | "off" => Some(false),
                _ => None,
            },
            _ => None,
        }
    }

    /// Token, string, asset or path text.
    pub fn as_str(&self) -> Option<&str> {
        match self {
            Value::Token(s) | Value::String(s) | Value::Asset(s) | Value::Path(s) => Some(s),
            Value::Paths(p) if p.len() == 1 => Some(&p[0]),
            _ => None,
        }
    }

    /// [`Value::to_f64s`], borrowing doubles rather than copying them.
    pub fn f64s(&self) -> Option<std::borrow::Cow<'_, [f64]>> {
        match self {
            Value::Doubles { data, .. } => Some(std::borrow::Cow::Borrowed(data)),
            _ => self.to_f64s().map(std::borrow::Cow::Owned),
        }
    }

    /// Flat numeric data as f64 (scalars give one element).
    pub fn to_f64s(&self) -> Option<Vec<f64>> {
        match self {
            Value::Floats { data, .. } => Some(data.iter().map(|&x| x as f64).collect()),
            Value::Doubles { data, .. } => Some(data.to_vec()),
            Value::Ints(v) => Some(v.iter().map(|&x| x as f64).collect()),
            Value::Matrix(m) => Some(m.to_vec()),
            Value::Float(_) | Value::Int(_) | Value::Bool(_) => self.as_f64().map(|x| vec![x]),
            _ => None,
        }
    }

    /// Flat numeric data as f32.
    pub fn to_f32s(&self) -> Option<Vec<f32>> {
        match self {
            Value::Floats { data, .. } => Some(data.clone()),
            _ => self.to_f64s().map(|v| v.into_iter().map(|x| x as f32).collect()),
        }
    }

    pub fn to_ints(&self) -> Option<Vec<i32>> {
        match self {
            Value::Ints(v) => Some(v.clone()),
            Value::Int(i) => Some(vec![*i as i32]),
            Value::Floats { data, .. } if data.iter().all(|x| x.fract() == 0.0) => {
                Some(data.iter().map(|&x| x as i32).collect())
            }
            Value::Doubles { data, .. } if data.iter().all(|x| x.fract() == 0.0) => {
                Some(data.iter().map(|&x| x as i32).collect())
            }
            _ => None,
        }
    }

    /// A USD matrix as a glam (column-vector) matrix: USD's row-major row-vector layout is
    /// exactly glam's column-major array.
    pub fn as_matrix(&self) -> Option<Mat4> {
        self.as_dmatrix().map(|m| m.as_mat4())
    }

    /// [`Value::as_matrix`] in double precision (world transforms keep their translations
    /// exact until the scene is placed about its origin).
    pub fn as_dmatrix(&self) -> Option<DMat4> {
        let d = match self {
            Value::Matrix(m) => m.to_vec(),
            Value::Doubles { data, .. } if data.len() == 16 => data.to_vec(),
            Value::Floats { data, .. } if data.len() == 16 => data.iter().map(|&x| x as f64).collect(),
            _ => return None,
        };
        Some(DMat4::from_cols_slice(&d))
    }

    pub fn as_vec3(&self) -> Option<Vec3> {
        let v = self.to_f32s()?;
        match v.len() {
            3 => Some(Vec3::new(v[0], v[1], v[2])),
            1 => Some(Vec3::splat(v[0])),
            _ => None,
        }
    }

    pub fn as_vec2(&self) -> Option<Vec2> {
        let v = self.to_f32s()?;
        (v.len() == 2).then(|| Vec2::new(v[0], v[1]))
    }

    /// Paths (a single path or token is a list of one).
    pub fn to_strings(&self) -> Option<Vec<String>> {
        match self {
            Value::Paths(p) => Some(p.clone()),
            Value::Token(s) | Value::String(s) | Value::Path(s) | Value::Asset(s) => {
                Some(s.split(|c: char| c == ',' || c.is_whitespace()).filter(|s| !s.is_empty()).map(String::from).collect())
            }
            _ => None,
        }
    }
}

/// Primvar interpolation (UsdGeom).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Constant,
    Uniform,
    Varying,
    Vertex,
    FaceVarying,
}

impl Interpolation {
    pub fn parse(s: &str) -> Option<Interpolation> {
        Some(match s {
            "constant" => Interpolation::Constant,
            "uniform" => Interpolation::Uniform,
            "varying" => Interpolation::Varying,
            "vertex" => Interpolation::Vertex,
            "faceVarying" | "facevarying" => Interpolation::FaceVarying,
            _ => return None,
        })
    }
}

/// A primvar: flat data with `tuple` components per element, optionally indexed.
#[derive(Clone, Debug, PartialEq)]
pub struct Primvar {
    pub interpolation: Interpolation,
    pub data: Vec<f32>,
    pub tuple: u32,
    pub indices: Option<Vec<i32>>,
}

impl Primvar {
    /// Number of elements as seen through the indices.
    pub fn len(&self) -> usize {
        match &self.indices {
            Some(i) => i.len(),
            None => self.data.len() / self.tuple.max(1) as usize,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Resolves indices: one element slice start per logical element, or a message naming
    /// the first bad index / bad data length.
    pub fn flatten(&self) -> Result<Vec<f32>, String> {
        let t = self.tuple.max(1) as usize;
        if !self.data.len().is_multiple_of(t) {
            return Err(format!("data length {} is not a multiple of tuple size {}", self.data.len(), t));
        }
        let n = self.data.len() / t;
        match &self.indices {
            None => Ok(self.data.clone()),
            Some(idx) => {
                let mut out = Vec::with_capacity(idx.len() * t);
                for (k, &i) in idx.iter().enumerate() {
                    if i < 0 || i as usize >= n {
                        return Err(format!("index {} at position {} is out of range (0..{})", i, k, n));
                    }
                    out.extend_from_slice(&self.data[i as usize * t..i as usize * t + t]);
                }
                Ok(out)
            }
        }
    }
}

/// One attribute: a default value and/or time samples (frame offsets from the current frame).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Attr {
    pub value: Option<Value>,
    /// Sorted by time.
    pub samples: Vec<(f64, Value)>,
}

impl Attr {
    /// The value at the current frame: the untimed value, else the sample at (or nearest to)
    /// time 0.
    pub fn current(&self) -> Option<&Value> {
        if let Some(v) = &self.value {
            return Some(v);
        }
        self.samples
            .iter()
            .min_by(|a, b| a.0.abs().partial_cmp(&b.0.abs()).unwrap_or(std::cmp::Ordering::Equal))
            .map(|s| &s.1)
    }

    pub fn set(&mut self, time: Option<f64>, v: Value) {
        match time {
            None => self.value = Some(v),
            // kept sorted by time: found by bisection (samples come in order, so a push)
            Some(t) => {
                let at = self.samples.partition_point(|s| s.0 < t);
                match self.samples.get_mut(at) {
                    Some(s) if s.0 == t => s.1 = v,
                    _ => self.samples.insert(at, (t, v)),
                }
            }
        }
    }
}

/// Removes the `inputs:` prefix the protocol makes optional.
pub fn normalize_name(name: &str) -> &str {
    name.strip_prefix("inputs:").unwrap_or(name)
}

/// A prim's attributes and primvars, with typed getters that record problems.
#[derive(Clone, Debug, Default)]
pub struct AttrStore {
    pub attrs: HashMap<String, Attr>,
    pub primvars: HashMap<String, Primvar>,
    /// Primvars with one element per instance (interpolation `instance`, Hydra's name for an
    /// instancer's per-instance data), in the order of `instanceTransforms`.
    pub instance_primvars: HashMap<String, Primvar>,
}

/// Collects problems of one conversion, each (attribute, message) once.
#[derive(Debug)]
pub struct Problems<'a> {
    pub item: &'a str,
    pub list: Vec<Problem>,
}

impl<'a> Problems<'a> {
    pub fn new(item: &'a str) -> Self {
        Problems { item, list: Vec::new() }
    }

    pub fn add(&mut self, attribute: &str, message: impl Into<String>) {
        let p = Problem { item: self.item.to_string(), attribute: attribute.to_string(), message: message.into() };
        if !self.list.contains(&p) {
            self.list.push(p);
        }
    }
}

impl AttrStore {
    pub fn get(&self, name: &str) -> Option<&Value> {
        self.attrs.get(normalize_name(name)).and_then(|a| a.current())
    }

    pub fn attr(&self, name: &str) -> Option<&Attr> {
        self.attrs.get(normalize_name(name))
    }

    pub fn has(&self, name: &str) -> bool {
        self.get(name).is_some()
    }

    pub fn f32_or(&self, name: &str, default: f32, p: &mut Problems) -> f32 {
        match self.get(name) {
            None => default,
            Some(v) => match v.as_f64() {
                Some(x) if x.is_finite() => x as f32,
                Some(x) => {
                    p.add(name, format!("value {} is not finite; using {}", x, default));
                    default
                }
                None => {
                    p.add(name, format!("expected a number, got {}; using {}", v.kind(), default));
                    default
                }
            },
        }
    }

    pub fn i64_or(&self, name: &str, default: i64, p: &mut Problems) -> i64 {
        match self.get(name) {
            None => default,
            Some(v) => match v.as_f64() {
                Some(x) if x.is_finite() => x as i64,
                _ => {
                    p.add(name, format!("expected an integer, got {}; using {}", v.kind(), default));
                    default
                }
            },
        }
    }

    pub fn bool_or(&self, name: &str, default: bool, p: &mut Problems) -> bool {
        match self.get(name) {
            None => default,
            Some(v) => v.as_bool().unwrap_or_else(|| {
                p.add(name, format!("expected a bool, got {}; using {}", v.kind(), default));
                default
            }),
        }
    }

    pub fn str_opt(&self, name: &str) -> Option<&str> {
        self.get(name).and_then(|v| v.as_str())
    }

    /// A token restricted to `allowed`; anything else is a problem and gives `default`.
    pub fn token_or<'s>(&'s self, name: &str, allowed: &[&'s str], default: &'s str, p: &mut Problems) -> &'s str {
        match self.get(name) {
            None => default,
            Some(v) => match v.as_str() {
                Some("") => default,
                Some(s) if allowed.contains(&s) => s,
                Some(s) => {
                    p.add(name, format!("unknown token '{}' (expected one of {}); using '{}'", s, allowed.join(", "), default));
                    default
                }
                None => {
                    p.add(name, format!("expected a token, got {}; using '{}'", v.kind(), default));
                    default
                }
            },
        }
    }

    pub fn vec3_or(&self, name: &str, default: Vec3, p: &mut Problems) -> Vec3 {
        match self.get(name) {
            None => default,
            Some(v) => match v.as_vec3() {
                Some(x) if x.is_finite() => x,
                _ => {
                    p.add(name, format!("expected 3 finite numbers, got {}; using {:?}", v.kind(), default.to_array()));
                    default
                }
            },
        }
    }

    pub fn vec2_or(&self, name: &str, default: Vec2, p: &mut Problems) -> Vec2 {
        match self.get(name) {
            None => default,
            Some(v) => match v.as_vec2() {
                Some(x) if x.is_finite() => x,
                _ => {
                    p.add(name, format!("expected 2 finite numbers, got {}; using {:?}", v.kind(), default.to_array()));
                    default
                }
            },
        }
    }

    /// Time-sampled matrix: (frame offset, matrix) pairs, the untimed value as time 0 when
    /// there are no samples; identity when unauthored.
    pub fn matrix_samples(&self, name: &str, p: &mut Problems) -> Vec<(f64, DMat4)> {
        let Some(a) = self.attr(name) else { return vec![(0.0, DMat4::IDENTITY)] };
        let mut out = Vec::new();
        let mut push = |t: f64, v: &Value, p: &mut Problems| match v.as_dmatrix() {
            Some(m) if m.is_finite() && m.as_mat4().is_finite() => out.push((t, m)),
            _ => p.add(name, format!("expected a finite 4x4 matrix, got {}; sample ignored", v.kind())),
        };
        if a.samples.is_empty() {
            if let Some(v) = &a.value {
                push(0.0, v, p);
            }
        } else {
            for (t, v) in &a.samples {
                push(*t, v, p);
            }
        }
        if out.is_empty() {
            out.push((0.0, DMat4::IDENTITY));
        }
        out
    }

    /// Primvar by name, or an attribute of that name treated as a primvar with `fallback`
    /// interpolation.
    pub fn primvar(&self, name: &str, fallback: Interpolation) -> Option<Primvar> {
        if let Some(pv) = self.primvars.get(name) {
            return Some(pv.clone());
        }
        let v = self.get(name)?;
        let (data, tuple) = match v {
            Value::Floats { data, tuple } => (data.clone(), *tuple),
            Value::Doubles { data, tuple } => (data.iter().map(|&x| x as f32).collect(), *tuple),
            other => (other.to_f32s()?, 1),
        };
        Some(Primvar { interpolation: fallback, data, tuple, indices: None })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn usd_matrix_translation_lands_in_w_axis() {
        let mut m = [0.0; 16];
        m[0] = 1.0;
        m[5] = 1.0;
        m[10] = 1.0;
        m[15] = 1.0;
        m[12] = 1.0;
        m[13] = 2.0;
        m[14] = 3.0;
        let g = Value::Matrix(m).as_matrix().unwrap();
        assert_eq!(g.transform_point3(Vec3::ZERO), Vec3::new(1.0, 2.0, 3.0));
    }

    #[test]
    fn samples_stay_sorted_by_time_with_one_value_per_time() {
        let mut a = Attr::default();
        for t in [2.0, 0.5, 3.0, 0.5, -1.0, 2.0, 4.0] {
            a.set(Some(t), Value::Float(t * 10.0 + a.samples.len() as f64));
        }
        let times: Vec<f64> = a.samples.iter().map(|s| s.0).collect();
        assert_eq!(times, vec![-1.0, 0.5, 2.0, 3.0, 4.0]);
        // a time set again holds its last value
        assert_eq!(a.samples[1].1, Value::Float(5.0 + 3.0));
        assert_eq!(a.samples[2].1, Value::Float(20.0 + 4.0));
    }

    #[test]
    fn indexed_primvar_flattens_and_rejects_bad_index() {
        let pv = Primvar { interpolation: Interpolation::Vertex, data: vec![1.0, 2.0], tuple: 1, indices: Some(vec![1, 0, 1]) };
        assert_eq!(pv.flatten().unwrap(), vec![2.0, 1.0, 2.0]);
        let bad = Primvar { indices: Some(vec![0, 5]), ..pv };
        assert!(bad.flatten().unwrap_err().contains("index 5"));
    }
}
