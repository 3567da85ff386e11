//! The Rust side of the bridge's `Delegate` and `Pass`: a thread-safe store speaking the
//! delegate protocol (prims by type and path, attributes with time samples, primvars,
//! textures, problems, render buffers, a background render pass).
//!
//! Values are validated the way the protocol asks (unknown prim types and bad values become
//! problems); every entry point is wrapped in [`crate::guard`].

use crate::ffi::{AovBinding, MappedBuffer, ProblemRow, StringPair};
use crate::guard;
use std::collections::{BTreeMap, BTreeSet, HashMap};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use tide_core::render::Aov;

const RPRIMS: &[&str] = &["mesh", "points", "sphere", "cube", "cylinder", "cone", "capsule", "plane", "tideOcean", "volume"];
const SPRIMS: &[&str] = &[
    "camera",
    "material",
    "distantLight",
    "domeLight",
    "sphereLight",
    "rectLight",
    "diskLight",
    "cylinderLight",
    "renderSettings",
];
const BPRIMS: &[&str] = &["renderBuffer"];

/// An attribute value (the protocol's `Value`).
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Bool(bool),
    Int(i64),
    Float(f64),
    Token(String),
    String(String),
    Asset(String),
    Path(String),
    Paths(Vec<String>),
    Floats { data: Vec<f32>, tuple: u32 },
    Doubles { data: Vec<f64>, tuple: u32 },
    Ints(Vec<i32>),
    Matrix([f64; 16]),
}

#[derive(Clone, Debug, PartialEq)]
struct Primvar {
    interpolation: String,
    data: Value,
    indices: Option<Vec<i32>>,
}

#[derive(Debug, Default)]
struct Prim {
    type_id: String,
    /// key → (time or None, value), sorted by time.
    attrs: BTreeMap<String, Vec<(Option<f64>, Value)>>,
    primvars: BTreeMap<String, Primvar>,
    dirty: bool,
}

struct Texture {
    width: u32,
    height: u32,
    channels: u32,
    pixels: Vec<f32>,
}

/// Pixels of one render buffer, shared with the pass that renders into it.
#[derive(Default)]
struct BufferData {
    width: u32,
    height: u32,
    channels: u32,
    pixels: Vec<f32>,
}

#[derive(Default)]
struct Store {
    prims: BTreeMap<String, Prim>,
    problems: Vec<ProblemRow>,
    reported: BTreeSet<(String, String, String)>,
    textures: HashMap<String, Texture>,
    failed_textures: HashMap<String, String>,
    last_synced: Vec<String>,
    buffers: HashMap<String, Arc<Mutex<BufferData>>>,
    /// Bumped by every commit that changed something; passes restart when it moves.
    version: u64,
}

impl Store {
    fn problem(&mut self, prim: &str, attribute: &str, message: impl Into<String>) {
        let key = (prim.to_string(), attribute.to_string(), message.into());
        if self.reported.insert(key.clone()) {
            self.problems.push(ProblemRow { prim: key.0, attribute: key.1, message: key.2 });
        }
    }

    fn prim_mut(&mut self, path: &str) -> Result<&mut Prim, String> {
        self.prims.get_mut(path).ok_or_else(|| format!("{path}: no such prim"))
    }

    fn set(&mut self, path: &str, key: &str, time: Option<f64>, v: Value) -> Result<(), String> {
        if let Some(t) = time {
            if !t.is_finite() {
                return Err(format!("{path}: {key}: time sample at non-finite time {t}"));
            }
        }
        let prim = self.prim_mut(path)?;
        let key = key.strip_prefix("inputs:").map(|k| format!("inputs:{k}")).unwrap_or_else(|| key.to_string());
        let samples = prim.attrs.entry(key).or_default();
        match time {
            None => {
                samples.clear();
                samples.push((None, v));
            }
            Some(t) => {
                samples.retain(|(st, _)| st.is_some() && *st != Some(t));
                let at = samples.partition_point(|(st, _)| st.unwrap_or(0.0) < t);
                samples.insert(at, (Some(t), v));
            }
        }
        prim.dirty = true;
        Ok(())
    }

    /// Checks a dirty prim's values the way the conversion into the core scene does.
    fn validate(&mut self, path: &str) {
        let Some(prim) = self.prims.get(path) else { return };
        let mut found: Vec<(String, String)> = Vec::new();
        for (key, samples) in &prim.attrs {
            for (_, v) in samples {
                match v {
                    Value::Floats { data, .. } if data.iter().any(|x| !x.is_finite()) => {
                        found.push((key.clone(), "non-finite values".into()))
                    }
                    Value::Float(x) if !x.is_finite() => found.push((key.clone(), "non-finite value".into())),
                    Value::Asset(a) if self.failed_textures.contains_key(a) => found.push((
                        key.clone(),
                        format!("texture {a}: {} (input falls back)", self.failed_textures[a]),
                    )),
                    _ => {}
                }
            }
        }
        if prim.type_id == "mesh" {
            let n_points = match prim.attrs.get("points").and_then(|s| s.first()) {
                Some((_, Value::Floats { data, .. })) => data.len() / 3,
                _ => 0,
            };
            if let Some((_, Value::Ints(idx))) = prim.attrs.get("faceVertexIndices").and_then(|s| s.first()) {
                if idx.iter().any(|&i| i < 0 || i as usize >= n_points) {
                    found.push(("faceVertexIndices".into(), "index out of range (faces dropped)".into()));
                }
            }
            if let Some((_, Value::Ints(c))) = prim.attrs.get("faceVertexCounts").and_then(|s| s.first()) {
                if c.iter().any(|&n| n < 3) {
                    found.push(("faceVertexCounts".into(), "face with fewer than 3 vertices (dropped)".into()));
                }
            }
        }
        if prim.type_id == "renderBuffer" {
            let dims = match prim.attrs.get("dimensions").and_then(|s| s.first()) {
                Some((_, Value::Ints(d))) if d.len() >= 2 && d[0] > 0 && d[1] > 0 => Some((d[0] as u32, d[1] as u32)),
                Some(_) => {
                    found.push(("dimensions".into(), "expected two positive ints".into()));
                    None
                }
                None => None,
            };
            let buf = self.buffers.entry(path.to_string()).or_default().clone();
            let mut b = buf.lock().unwrap_or_else(|e| e.into_inner());
            if let Some((w, h)) = dims {
                if (b.width, b.height) != (w, h) {
                    b.width = w;
                    b.height = h;
                    b.channels = 0;
                    b.pixels.clear();
                }
            }
        }
        for (attr, msg) in found {
            self.problem(path, &attr, msg);
        }
    }
}

/// The delegate as seen from C++: all methods take `&self` and lock internally, so Hydra may
/// sync prims from several threads.
pub struct Delegate {
    store: Arc<Mutex<Store>>,
}

fn lock(store: &Mutex<Store>) -> std::sync::MutexGuard<'_, Store> {
    store.lock().unwrap_or_else(|e| e.into_inner())
}

fn time_of(has_time: bool, time: f64) -> Option<f64> {
    has_time.then_some(time)
}

impl Default for Delegate {
    fn default() -> Self {
        Self::new()
    }
}

impl Delegate {
    pub fn new() -> Delegate {
        Delegate { store: Arc::new(Mutex::new(Store::default())) }
    }

    pub fn create_prim(&self, type_id: &str, path: &str) -> Result<bool, String> {
        guard("create_prim", || {
            let mut s = lock(&self.store);
            let known = RPRIMS.contains(&type_id) || SPRIMS.contains(&type_id) || BPRIMS.contains(&type_id);
            if !known {
                s.problem(path, "", format!("unknown prim type '{type_id}'"));
                return Ok(false);
            }
            if !path.starts_with('/') {
                s.problem(path, "", "prim path must be absolute");
                return Ok(false);
            }
            s.prims.insert(path.to_string(), Prim { type_id: type_id.to_string(), dirty: true, ..Prim::default() });
            Ok(true)
        })
    }

    pub fn destroy_prim(&self, path: &str) -> Result<bool, String> {
        guard("destroy_prim", || {
            let mut s = lock(&self.store);
            s.buffers.remove(path);
            let existed = s.prims.remove(path).is_some();
            if existed {
                s.version += 1;
            }
            Ok(existed)
        })
    }

    fn set_value(&self, what: &str, path: &str, key: &str, time: Option<f64>, v: Value) -> Result<(), String> {
        guard(what, || lock(&self.store).set(path, key, time, v))
    }

    pub fn set_bool(&self, path: &str, key: &str, v: bool, has_time: bool, time: f64) -> Result<(), String> {
        self.set_value("set_bool", path, key, time_of(has_time, time), Value::Bool(v))
    }
    pub fn set_int(&self, path: &str, key: &str, v: i64, has_time: bool, time: f64) -> Result<(), String> {
        self.set_value("set_int", path, key, time_of(has_time, time), Value::Int(v))
    }
    pub fn set_float(&self, path: &str, key: &str, v: f64, has_time: bool, time: f64) -> Result<(), String> {
        self.set_value("set_float", path, key, time_of(has_time, time), Value::Float(v))
    }
    pub fn set_text(&self, path: &str, key: &str, kind: u8, v: &str, has_time: bool, time: f64) -> Result<(), String> {
        let v = v.to_string();
        let value = match kind {
            0 => Value::Token(v),
            1 => Value::String(v),
            2 => Value::Asset(v),
            3 => Value::Path(v),
            k => return Err(format!("{path}: {key}: unknown text kind {k}")),
        };
        self.set_value("set_text", path, key, time_of(has_time, time), value)
    }
    pub fn set_paths(&self, path: &str, key: &str, v: &Vec<String>, has_time: bool, time: f64) -> Result<(), String> {
        self.set_value("set_paths", path, key, time_of(has_time, time), Value::Paths(v.clone()))
    }
    pub fn set_floats(&self, path: &str, key: &str, v: &[f32], tuple: u32, has_time: bool, time: f64) -> Result<(), String> {
        check_tuple(path, key, v.len(), tuple)?;
        self.set_value("set_floats", path, key, time_of(has_time, time), Value::Floats { data: v.to_vec(), tuple })
    }
    pub fn set_doubles(&self, path: &str, key: &str, v: &[f64], tuple: u32, has_time: bool, time: f64) -> Result<(), String> {
        check_tuple(path, key, v.len(), tuple)?;
        self.set_value("set_doubles", path, key, time_of(has_time, time), Value::Doubles { data: v.to_vec(), tuple })
    }
    pub fn set_ints(&self, path: &str, key: &str, v: &[i32], has_time: bool, time: f64) -> Result<(), String> {
        self.set_value("set_ints", path, key, time_of(has_time, time), Value::Ints(v.to_vec()))
    }
    pub fn set_matrix(&self, path: &str, key: &str, v: &[f64], has_time: bool, time: f64) -> Result<(), String> {
        let m: [f64; 16] = v.try_into().map_err(|_| format!("{path}: {key}: a matrix needs 16 values, got {}", v.len()))?;
        self.set_value("set_matrix", path, key, time_of(has_time, time), Value::Matrix(m))
    }

    #[allow(clippy::too_many_arguments)]
    pub fn set_primvar(
        &self,
        path: &str,
        name: &str,
        interpolation: &str,
        kind: u8,
        floats: &[f32],
        ints: &[i32],
        tuple: u32,
        has_indices: bool,
        indices: &[i32],
    ) -> Result<(), String> {
        guard("set_primvar", || {
            if !["constant", "uniform", "varying", "vertex", "faceVarying"].contains(&interpolation) {
                return Err(format!("{path}: primvars:{name}: unknown interpolation '{interpolation}'"));
            }
            let data = match kind {
                b'f' | b'd' => {
                    check_tuple(path, name, floats.len(), tuple)?;
                    Value::Floats { data: floats.to_vec(), tuple }
                }
                b'i' => Value::Ints(ints.to_vec()),
                k => return Err(format!("{path}: primvars:{name}: unknown element kind '{}'", k as char)),
            };
            let mut s = lock(&self.store);
            let prim = s.prim_mut(path)?;
            prim.primvars.insert(
                name.to_string(),
                Primvar { interpolation: interpolation.to_string(), data, indices: has_indices.then(|| indices.to_vec()) },
            );
            prim.dirty = true;
            Ok(())
        })
    }

    pub fn add_texture(&self, asset: &str, width: u32, height: u32, channels: u32, pixels: &[f32], is_srgb: bool) -> Result<(), String> {
        guard("add_texture", || {
            let _ = is_srgb;
            let expected = width as usize * height as usize * channels as usize;
            if expected != pixels.len() || channels == 0 {
                return Err(format!("{asset}: texture of {width}x{height}x{channels} needs {expected} floats, got {}", pixels.len()));
            }
            let mut s = lock(&self.store);
            s.failed_textures.remove(asset);
            s.textures.insert(asset.to_string(), Texture { width, height, channels, pixels: pixels.to_vec() });
            mark_users_dirty(&mut s, asset);
            Ok(())
        })
    }

    pub fn texture_failed(&self, asset: &str, message: &str) -> Result<(), String> {
        guard("texture_failed", || {
            let mut s = lock(&self.store);
            s.textures.remove(asset);
            s.failed_textures.insert(asset.to_string(), message.to_string());
            mark_users_dirty(&mut s, asset);
            Ok(())
        })
    }

    pub fn texture_pixels(&self, asset: &str) -> Result<MappedBuffer, String> {
        guard("texture_pixels", || {
            let s = lock(&self.store);
            Ok(s.textures
                .get(asset)
                .map(|t| MappedBuffer { width: t.width, height: t.height, channels: t.channels, pixels: t.pixels.clone() })
                .unwrap_or_default())
        })
    }

    pub fn commit_resources(&self) -> Result<Vec<ProblemRow>, String> {
        guard("commit_resources", || {
            let mut s = lock(&self.store);
            let dirty: Vec<String> = s.prims.iter().filter(|(_, p)| p.dirty).map(|(k, _)| k.clone()).collect();
            for path in &dirty {
                s.validate(path);
                if let Some(p) = s.prims.get_mut(path) {
                    p.dirty = false;
                }
            }
            if !dirty.is_empty() {
                s.version += 1;
            }
            s.last_synced = dirty;
            Ok(std::mem::take(&mut s.problems))
        })
    }

    pub fn last_synced(&self) -> Result<Vec<String>, String> {
        guard("last_synced", || Ok(lock(&self.store).last_synced.clone()))
    }

    pub fn map_buffer(&self, path: &str) -> Result<MappedBuffer, String> {
        guard("map_buffer", || {
            let buf = lock(&self.store).buffers.get(path).cloned().ok_or_else(|| format!("{path}: no such render buffer"))?;
            let b = buf.lock().unwrap_or_else(|e| e.into_inner());
            Ok(MappedBuffer { width: b.width, height: b.height, channels: b.channels, pixels: b.pixels.clone() })
        })
    }

    pub fn write_exr(&self, path: &str, layers: &Vec<StringPair>, header: &Vec<StringPair>) -> Result<(), String> {
        guard("write_exr", || {
            let _ = header;
            for l in layers {
                if Aov::from_source_name(&l.second).is_none() {
                    return Err(format!("{path}: layer {}: unknown AOV '{}'", l.first, l.second));
                }
            }
            Err(format!("{path}: nothing rendered yet: the core renderer has no film to write"))
        })
    }

    pub fn create_render_pass(&self) -> Result<Box<Pass>, String> {
        guard("create_render_pass", || Ok(Box::new(Pass { store: self.store.clone(), state: Arc::new(PassState::default()), thread: Mutex::new(None) })))
    }
}

fn mark_users_dirty(s: &mut Store, asset: &str) {
    for p in s.prims.values_mut() {
        if p.attrs.values().flatten().any(|(_, v)| matches!(v, Value::Asset(a) if a == asset)) {
            p.dirty = true;
        }
    }
}

fn check_tuple(path: &str, key: &str, len: usize, tuple: u32) -> Result<(), String> {
    if tuple == 0 || len % tuple as usize != 0 {
        return Err(format!("{path}: {key}: {len} values do not split into tuples of {tuple}"));
    }
    Ok(())
}

#[derive(Default)]
struct PassFlags {
    running: bool,
    converged: bool,
    progress: f64,
    error: String,
}

#[derive(Default)]
struct PassState {
    flags: Mutex<PassFlags>,
    changed: Condvar,
    cancel: AtomicBool,
}

/// A render pass: `execute` binds AOVs to buffers and renders on a background thread.
pub struct Pass {
    store: Arc<Mutex<Store>>,
    state: Arc<PassState>,
    thread: Mutex<Option<JoinHandle<()>>>,
}

impl Pass {
    fn stop(&self) {
        self.state.cancel.store(true, Ordering::SeqCst);
        let handle = self.thread.lock().unwrap_or_else(|e| e.into_inner()).take();
        if let Some(h) = handle {
            let _ = h.join();
        }
        self.state.cancel.store(false, Ordering::SeqCst);
    }

    pub fn execute(&self, camera: &str, bindings: &Vec<AovBinding>, settings: &str) -> Result<(), String> {
        guard("execute", || {
            self.stop();
            let mut targets = Vec::new();
            {
                let s = lock(&self.store);
                match s.prims.get(camera) {
                    Some(p) if p.type_id == "camera" => {}
                    _ => return Err(format!("{camera}: no such camera")),
                }
                if !settings.is_empty() && s.prims.get(settings).map(|p| p.type_id.as_str()) != Some("renderSettings") {
                    return Err(format!("{settings}: no such renderSettings prim"));
                }
                for b in bindings {
                    let aov = Aov::from_source_name(&b.aov).ok_or_else(|| format!("{}: unknown AOV '{}'", b.buffer, b.aov))?;
                    let buf = s.buffers.get(&b.buffer).cloned().ok_or_else(|| format!("{}: no such render buffer", b.buffer))?;
                    targets.push((aov, buf));
                }
            }
            {
                let mut f = self.state.flags.lock().unwrap_or_else(|e| e.into_inner());
                *f = PassFlags { running: true, ..PassFlags::default() };
            }
            let state = self.state.clone();
            let handle = std::thread::Builder::new()
                .name("tide-render-pass".into())
                .spawn(move || {
                    let result = guard("render pass", || {
                        // The film is cleared to the AOV's channel count; the core's
                        // progressive passes fill it as they land.
                        for (aov, buf) in &targets {
                            let mut b = buf.lock().unwrap_or_else(|e| e.into_inner());
                            b.channels = aov.channels() as u32;
                            b.pixels = vec![0.0; b.width as usize * b.height as usize * aov.channels()];
                        }
                        Ok(())
                    });
                    let mut f = state.flags.lock().unwrap_or_else(|e| e.into_inner());
                    f.running = false;
                    match result {
                        Ok(()) if !state.cancel.load(Ordering::SeqCst) => {
                            f.converged = true;
                            f.progress = 1.0;
                        }
                        Ok(()) => {}
                        Err(e) => f.error = e,
                    }
                    state.changed.notify_all();
                })
                .map_err(|e| format!("cannot start the render thread: {e}"))?;
            *self.thread.lock().unwrap_or_else(|e| e.into_inner()) = Some(handle);
            Ok(())
        })
    }

    pub fn is_converged(&self) -> Result<bool, String> {
        guard("is_converged", || Ok(self.state.flags.lock().unwrap_or_else(|e| e.into_inner()).converged))
    }

    pub fn progress(&self) -> Result<f64, String> {
        guard("progress", || Ok(self.state.flags.lock().unwrap_or_else(|e| e.into_inner()).progress))
    }

    pub fn wait(&self, timeout_s: f64) -> Result<bool, String> {
        guard("wait", || {
            let deadline = (timeout_s >= 0.0).then(|| Instant::now() + Duration::from_secs_f64(timeout_s.min(1e6)));
            let mut f = self.state.flags.lock().unwrap_or_else(|e| e.into_inner());
            while f.running {
                match deadline {
                    None => f = self.state.changed.wait(f).unwrap_or_else(|e| e.into_inner()),
                    Some(d) => {
                        let now = Instant::now();
                        if now >= d {
                            return Ok(false);
                        }
                        f = self.state.changed.wait_timeout(f, d - now).unwrap_or_else(|e| e.into_inner()).0;
                    }
                }
            }
            Ok(true)
        })
    }

    pub fn cancel(&self) -> Result<(), String> {
        guard("cancel", || {
            self.stop();
            Ok(())
        })
    }

    pub fn error(&self) -> Result<String, String> {
        guard("error", || Ok(self.state.flags.lock().unwrap_or_else(|e| e.into_inner()).error.clone()))
    }
}

impl Drop for Pass {
    fn drop(&mut self) {
        self.stop();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unknown_type_is_a_problem_not_an_error() {
        let d = Delegate::new();
        assert_eq!(d.create_prim("teapot", "/T"), Ok(false));
        let p = d.commit_resources().unwrap();
        assert_eq!(p.len(), 1);
        assert_eq!(p[0].prim, "/T");
        assert!(p[0].message.contains("teapot"));
    }

    #[test]
    fn set_on_missing_prim_is_an_error() {
        let d = Delegate::new();
        assert!(d.set_float("/nope", "radius", 1.0, false, 0.0).is_err());
        assert!(d.set_matrix("/nope", "transform", &[0.0; 3], false, 0.0).is_err());
    }

    #[test]
    fn only_dirty_prims_resync() {
        let d = Delegate::new();
        assert_eq!(d.create_prim("sphere", "/A"), Ok(true));
        assert_eq!(d.create_prim("sphere", "/B"), Ok(true));
        d.commit_resources().unwrap();
        assert_eq!(d.last_synced().unwrap(), vec!["/A".to_string(), "/B".to_string()]);
        d.set_float("/B", "radius", 2.0, false, 0.0).unwrap();
        d.commit_resources().unwrap();
        assert_eq!(d.last_synced().unwrap(), vec!["/B".to_string()]);
    }

    #[test]
    fn guard_turns_panics_into_errors() {
        let r: Result<(), String> = guard("test", || panic!("boom"));
        assert!(r.unwrap_err().contains("boom"));
    }
}
