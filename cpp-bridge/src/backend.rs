//! The Rust side of the bridge's `Delegate` and `Pass`: a thin, thread-safe wrapper around
//! [`tide_delegate::Delegate`] that maps every `cxx` entry point onto the delegate's API.
//!
//! The delegate lives in an `Arc<Mutex<..>>` shared by the bridge delegate and its passes.
//! Calls take the lock only for as long as the delegate call itself; waiting for a render
//! uses a [`PassWatcher`] taken out of the lock, so buffers can be mapped and prims edited by
//! other threads while one waits. Errors are the caller's mistakes (a prim that does not
//! exist, malformed arrays, an unknown camera or AOV); bad scene values are problems that
//! `commit_resources` returns. Every entry point is wrapped in [`crate::guard`].

use crate::ffi::{AovBinding, ExrLayer, MappedBuffer, ProblemRow, StringPair};
use crate::guard;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;
use tide_core::Aov;
use tide_delegate::{PassStatus, PrimType, Problem, Value};

/// Hydra's interpolations, with `instance` (one element per instance of `instanceTransforms`).
const INTERPOLATIONS: &[&str] = &["constant", "uniform", "varying", "vertex", "faceVarying", "instance"];

struct Shared {
    delegate: tide_delegate::Delegate,
    /// Problems found outside a commit (render pass bindings), returned by the next commit.
    pending: Vec<ProblemRow>,
    /// The pass that started the running render (0: none); dropping that pass cancels it.
    executing_pass: u64,
}

/// The delegate as seen from C++: all methods take `&self` and lock internally, so Hydra may
/// sync prims from several threads.
pub struct Delegate {
    shared: Arc<Mutex<Shared>>,
    next_pass: AtomicU64,
}

fn lock(shared: &Mutex<Shared>) -> MutexGuard<'_, Shared> {
    shared.lock().unwrap_or_else(|e| e.into_inner())
}

fn time_of(has_time: bool, time: f64) -> Option<f64> {
    has_time.then_some(time)
}

fn row(p: Problem) -> ProblemRow {
    ProblemRow { prim: p.item, attribute: p.attribute, message: p.message }
}

fn check_tuple(path: &str, key: &str, len: usize, tuple: u32) -> Result<(), String> {
    if tuple == 0 || len % tuple as usize != 0 {
        return Err(format!("{path}: {key}: {len} values do not split into tuples of {tuple}"));
    }
    Ok(())
}

impl Default for Delegate {
    fn default() -> Self {
        Self::new()
    }
}

/// A texture's values as its file stores them (see `ffi::new_texel_buffer`): the reader writes
/// them straight into the memory the delegate then keeps.
pub struct TexelBuffer {
    values: TexelValues,
}

enum TexelValues {
    U8(Vec<u8>),
    U16(Vec<u16>),
    Half(Vec<u16>),
    F32(Vec<f32>),
}

fn reserve<T>(total: usize) -> Result<Vec<T>, String> {
    let mut v = Vec::new();
    v.try_reserve_exact(total).map_err(|_| format!("not enough memory for {} values ({} MB)", total, total.saturating_mul(std::mem::size_of::<T>()) >> 20))?;
    Ok(v)
}

/// `n` more values (zero) at the end of `v`, as the bytes the reader writes them into.
fn grow_bytes<T: bytemuck::Pod>(v: &mut Vec<T>, n: usize) -> Result<&mut [u8], String> {
    v.try_reserve(n).map_err(|_| format!("not enough memory for {} more values", n))?;
    let at = v.len();
    v.resize(at + n, T::zeroed());
    Ok(bytemuck::cast_slice_mut(&mut v[at..]))
}

impl TexelBuffer {
    pub fn new(kind: u8, total: usize) -> Result<TexelBuffer, String> {
        let values = match kind {
            0 => TexelValues::U8(reserve(total)?),
            1 => TexelValues::U16(reserve(total)?),
            2 => TexelValues::Half(reserve(total)?),
            3 => TexelValues::F32(reserve(total)?),
            k => return Err(format!("unknown texel kind {k}")),
        };
        Ok(TexelBuffer { values })
    }

    pub fn grow(&mut self, values: usize) -> Result<&mut [u8], String> {
        guard("grow", || match &mut self.values {
            TexelValues::U8(v) => grow_bytes(v, values),
            TexelValues::U16(v) | TexelValues::Half(v) => grow_bytes(v, values),
            TexelValues::F32(v) => grow_bytes(v, values),
        })
    }
}

impl Delegate {
    pub fn new() -> Delegate {
        Delegate {
            shared: Arc::new(Mutex::new(Shared { delegate: tide_delegate::Delegate::new(), pending: Vec::new(), executing_pass: 0 })),
            next_pass: AtomicU64::new(1),
        }
    }

    pub fn create_prim(&self, type_id: &str, path: &str) -> Result<bool, String> {
        guard("create_prim", || {
            let mut s = lock(&self.shared);
            if !path.starts_with('/') {
                s.pending.push(ProblemRow { prim: path.into(), attribute: String::new(), message: "prim path must be absolute; the prim is ignored".into() });
                return Ok(false);
            }
            Ok(s.delegate.create_prim(type_id, path))
        })
    }

    pub fn destroy_prim(&self, path: &str) -> Result<bool, String> {
        guard("destroy_prim", || Ok(lock(&self.shared).delegate.destroy_prim(path)))
    }

    fn set_value(&self, what: &str, path: &str, key: &str, time: Option<f64>, v: Value) -> Result<(), String> {
        guard(what, || {
            if let Some(t) = time {
                if !t.is_finite() {
                    return Err(format!("{path}: {key}: time sample at non-finite time {t}"));
                }
            }
            let mut s = lock(&self.shared);
            if !s.delegate.has_prim(path) {
                return Err(format!("{path}: no such prim (setting {key})"));
            }
            s.delegate.set_attribute(path, key, v, time);
            Ok(())
        })
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
        self.set_value("set_doubles", path, key, time_of(has_time, time), Value::Doubles { data: v.into(), tuple })
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
            if !INTERPOLATIONS.contains(&interpolation) {
                return Err(format!("{path}: primvars:{name}: unknown interpolation '{interpolation}'"));
            }
            let data = match kind {
                b'f' | b'd' => floats.to_vec(),
                b'i' => ints.iter().map(|&i| i as f32).collect(),
                k => return Err(format!("{path}: primvars:{name}: unknown element kind '{}'", k as char)),
            };
            check_tuple(path, &format!("primvars:{name}"), data.len(), tuple)?;
            let mut s = lock(&self.shared);
            if !s.delegate.has_prim(path) {
                return Err(format!("{path}: no such prim (setting primvars:{name})"));
            }
            s.delegate.set_primvar(path, name, interpolation, data, tuple, has_indices.then(|| indices.to_vec()));
            Ok(())
        })
    }

    pub fn add_texture(&self, asset: &str, width: u32, height: u32, channels: u32, pixels: &[f32], is_srgb: bool, wrapmodes: &str) -> Result<(), String> {
        guard("add_texture", || {
            // A refused size becomes a problem on the asset (returned by the next commit).
            lock(&self.shared).delegate.add_texture(asset, width, height, channels, pixels.to_vec(), is_srgb, wrapmodes);
            Ok(())
        })
    }

    #[allow(clippy::too_many_arguments)]
    pub fn add_texels(&self, asset: &str, width: u32, height: u32, channels: u32, texels: Box<TexelBuffer>, is_srgb: bool, wrapmodes: &str) -> Result<(), String> {
        guard("add_texels", || {
            let mut s = lock(&self.shared);
            let d = &mut s.delegate;
            match texels.values {
                TexelValues::U8(v) => d.add_texture_u8(asset, width, height, channels, v, is_srgb, wrapmodes),
                TexelValues::U16(v) => d.add_texture_u16(asset, width, height, channels, v, false, is_srgb, wrapmodes),
                TexelValues::Half(v) => d.add_texture_u16(asset, width, height, channels, v, true, is_srgb, wrapmodes),
                TexelValues::F32(v) => d.add_texture(asset, width, height, channels, v, is_srgb, wrapmodes),
            };
            Ok(())
        })
    }

    pub fn texture_failed(&self, asset: &str, message: &str) -> Result<(), String> {
        guard("texture_failed", || {
            lock(&self.shared).delegate.texture_failed(asset, message);
            Ok(())
        })
    }

    /// A grid's values in bricks: `coords` the brick coordinates (voxel / 8, three per brick)
    /// of the 8³ bricks whose values `values` holds in turn; the other bricks are zeros.
    pub fn add_grid(&self, asset: &str, field: &str, index: i64, dims: &[u32], coords: &[u32], values: Box<TexelBuffer>, index_to_object: &[f64]) -> Result<bool, String> {
        guard("add_grid", || {
            let (Ok(dims), Ok(m)) = (<[u32; 3]>::try_from(dims), <[f64; 16]>::try_from(index_to_object)) else {
                return Err(format!("{asset}: a grid needs 3 dims and a 16-number matrix, got {} and {}", dims.len(), index_to_object.len()));
            };
            // a refused grid becomes a problem of the volumes reading it
            let TexelValues::F32(values) = values.values else {
                return Err(format!("{asset}: a grid's values are floats"));
            };
            Ok(lock(&self.shared).delegate.add_grid_bricks(asset, field, index, dims, coords, values, m))
        })
    }

    pub fn grid_failed(&self, asset: &str, field: &str, index: i64, message: &str) -> Result<(), String> {
        guard("grid_failed", || {
            lock(&self.shared).delegate.grid_failed(asset, field, index, message);
            Ok(())
        })
    }

    pub fn has_grid(&self, asset: &str, field: &str, index: i64) -> Result<bool, String> {
        guard("has_grid", || Ok(lock(&self.shared).delegate.has_grid(asset, field, index)))
    }

    pub fn texture_pixels(&self, asset: &str) -> Result<MappedBuffer, String> {
        guard("texture_pixels", || {
            Ok(lock(&self.shared)
                .delegate
                .texture(asset)
                .map(|t| MappedBuffer { width: t.width, height: t.height, channels: t.channels, pixels: t.pixels })
                .unwrap_or_default())
        })
    }

    pub fn grid_values(&self, asset: &str, field: &str, index: i64) -> Result<MappedBuffer, String> {
        guard("grid_values", || {
            let g = lock(&self.shared).delegate.grid(asset, field, index);
            Ok(g.map(|g| {
                let d = g.values.dims().map(|v| v as u32);
                MappedBuffer { width: d[0], height: d[1], channels: d[2], pixels: g.values.to_dense() }
            })
            .unwrap_or_default())
        })
    }

    pub fn commit_resources(&self) -> Result<Vec<ProblemRow>, String> {
        guard("commit_resources", || {
            let mut s = lock(&self.shared);
            let mut out = std::mem::take(&mut s.pending);
            out.extend(s.delegate.commit_resources().into_iter().map(row));
            Ok(out)
        })
    }

    /// Prepares the scene as a render would, without rendering: what that found wrong.
    pub fn check_render(&self) -> Result<Vec<ProblemRow>, String> {
        guard("check_render", || {
            let mut s = lock(&self.shared);
            let mut out = std::mem::take(&mut s.pending);
            out.extend(s.delegate.commit_resources().into_iter().map(row));
            out.extend(s.delegate.check_render().into_iter().map(row));
            Ok(out)
        })
    }

    pub fn last_synced(&self) -> Result<Vec<String>, String> {
        guard("last_synced", || Ok(lock(&self.shared).delegate.last_synced().to_vec()))
    }

    pub fn pause_render(&self) -> Result<(), String> {
        guard("pause_render", || Ok(lock(&self.shared).delegate.pause_render()))
    }

    pub fn resume_render(&self) -> Result<(), String> {
        guard("resume_render", || Ok(lock(&self.shared).delegate.resume_render()))
    }

    /// Stops rendering; `blocking`: also waits, without holding the delegate, until no worker
    /// renders. True once stopped (always, when not blocking).
    pub fn stop_render(&self, blocking: bool) -> Result<bool, String> {
        guard("stop_render", || {
            let watcher = {
                let mut s = lock(&self.shared);
                s.delegate.stop_render();
                s.delegate.watcher()
            };
            Ok(!blocking || watcher.is_none_or(|w| w.wait_idle(Duration::MAX)))
        })
    }

    pub fn restart_render(&self) -> Result<(), String> {
        guard("restart_render", || Ok(lock(&self.shared).delegate.restart_render()))
    }

    pub fn render_paused(&self) -> Result<bool, String> {
        guard("render_paused", || Ok(lock(&self.shared).delegate.is_render_paused()))
    }

    pub fn render_stopped(&self) -> Result<bool, String> {
        guard("render_stopped", || Ok(lock(&self.shared).delegate.is_render_stopped()))
    }

    pub fn map_buffer(&self, path: &str) -> Result<MappedBuffer, String> {
        guard("map_buffer", || {
            let buf = lock(&self.shared).delegate.render_buffer(path).ok_or_else(|| format!("{path}: no such render buffer"))?;
            let m = buf.map();
            Ok(MappedBuffer { width: m.width, height: m.height, channels: m.channels, pixels: m.pixels })
        })
    }

    pub fn buffer_shape(&self, path: &str) -> Result<MappedBuffer, String> {
        guard("buffer_shape", || {
            let buf = lock(&self.shared).delegate.render_buffer(path).ok_or_else(|| format!("{path}: no such render buffer"))?;
            let (width, height, channels) = buf.shape();
            Ok(MappedBuffer { width, height, channels, pixels: Vec::new() })
        })
    }

    pub fn read_buffer(&self, path: &str, out: &mut [f32]) -> Result<bool, String> {
        guard("read_buffer", || {
            let buf = lock(&self.shared).delegate.render_buffer(path).ok_or_else(|| format!("{path}: no such render buffer"))?;
            Ok(buf.read_into(out).is_some())
        })
    }

    pub fn write_exr(&self, path: &str, layers: &Vec<ExrLayer>, header: &Vec<StringPair>) -> Result<(), String> {
        guard("write_exr", || {
            let mut aovs = Vec::with_capacity(layers.len());
            for l in layers {
                if Aov::from_source_name(&l.aov).is_none() {
                    return Err(format!("{path}: layer '{}': unknown AOV '{}'", l.name, l.aov));
                }
                aovs.push((l.name.clone(), l.aov.clone(), l.data_type.clone()));
            }
            let header: Vec<(String, String)> = header.iter().map(|p| (p.first.clone(), p.second.clone())).collect();
            lock(&self.shared).delegate.write_exr(std::path::Path::new(path), &aovs, &header).map_err(|e| format!("{path}: {e}"))
        })
    }

    pub fn create_render_pass(&self) -> Result<Box<Pass>, String> {
        guard("create_render_pass", || Ok(Box::new(Pass { shared: self.shared.clone(), id: self.next_pass.fetch_add(1, Ordering::Relaxed) })))
    }
}

/// A render pass: `execute` binds AOVs to buffers and renders progressively on the
/// delegate's render thread. Dropping the pass that started the running render cancels it.
pub struct Pass {
    shared: Arc<Mutex<Shared>>,
    id: u64,
}

impl Pass {
    /// `hydra`: AOVs named and laid out as Hydra's render buffers want them (rows from the
    /// bottom, `depth` in clip space, ids as int32 where the buffer is), an AOV Tide does not
    /// render reported and the rest rendered; else `UsdRenderVar` sourceNames, an unknown one
    /// an error. `projection`: 16 doubles (GfMatrix4d's order) of the host's projection, whose
    /// framing the image takes, or none.
    /// `render_tags`: the pass's (Hydra's), empty for every prim ([`Delegate::set_render_tags`]).
    pub fn execute(&self, camera: &str, bindings: &Vec<AovBinding>, settings: &str, hydra: bool, projection: &[f64], render_tags: &Vec<String>) -> Result<(), String> {
        guard("execute", || {
            let mut s = lock(&self.shared);
            let d = &s.delegate;
            if !camera.is_empty() && d.prim_type(camera) != Some(PrimType::Camera) {
                return Err(format!("{camera}: no such camera"));
            }
            if !settings.is_empty() && d.prim_type(settings) != Some(PrimType::RenderSettings) {
                return Err(format!("{settings}: no such renderSettings prim"));
            }
            let mut aovs = Vec::with_capacity(bindings.len());
            for b in bindings {
                if !hydra && Aov::from_source_name(&b.aov).is_none() {
                    return Err(format!("{}: unknown AOV '{}'", b.buffer, b.aov));
                }
                if d.prim_type(&b.buffer) != Some(PrimType::RenderBuffer) {
                    return Err(format!("{}: no such render buffer (for AOV '{}')", b.buffer, b.aov));
                }
                aovs.push((b.aov.clone(), b.buffer.clone()));
            }
            let projection = match projection.len() {
                0 => None,
                16 => Some(std::array::from_fn(|i| projection[i])),
                n => return Err(format!("a projection matrix has 16 values, not {n}")),
            };
            for b in bindings {
                if let Some(buf) = s.delegate.render_buffer(&b.buffer) {
                    buf.set_clear(&b.clear);
                }
            }
            s.delegate.set_render_tags(render_tags);
            let problems = s.delegate.execute_as(Some(camera), &aovs, Some(settings), hydra, projection);
            s.pending.extend(problems.into_iter().map(row));
            s.executing_pass = self.id;
            Ok(())
        })
    }

    pub fn is_converged(&self) -> Result<bool, String> {
        guard("is_converged", || Ok(lock(&self.shared).delegate.is_converged()))
    }

    /// The render's figures after its last finished pass, as `key=value` strings.
    pub fn summary(&self) -> Result<Vec<String>, String> {
        guard("summary", || Ok(lock(&self.shared).delegate.render_summary().into_iter().map(|(k, v)| format!("{}={}", k, v)).collect()))
    }

    pub fn progress(&self) -> Result<f64, String> {
        guard("progress", || Ok(lock(&self.shared).delegate.progress() as f64))
    }

    /// Waits without holding the delegate's lock; true once the render stopped (converged,
    /// failed or cancelled), false on timeout.
    pub fn wait(&self, timeout_s: f64) -> Result<bool, String> {
        guard("wait", || {
            let Some(watcher) = lock(&self.shared).delegate.watcher() else { return Ok(true) };
            let timeout = if timeout_s.is_nan() || timeout_s < 0.0 { Duration::MAX } else { Duration::from_secs_f64(timeout_s.min(1e9)) };
            watcher.wait(timeout);
            Ok(watcher.status() != PassStatus::Rendering)
        })
    }

    pub fn cancel(&self) -> Result<(), String> {
        guard("cancel", || {
            let mut s = lock(&self.shared);
            s.delegate.cancel();
            s.executing_pass = 0;
            Ok(())
        })
    }

    /// The error that stopped the render, or "".
    pub fn error(&self) -> Result<String, String> {
        guard("error", || {
            Ok(match lock(&self.shared).delegate.render_status() {
                PassStatus::Failed(m) => m,
                _ => String::new(),
            })
        })
    }
}

impl Drop for Pass {
    fn drop(&mut self) {
        let _ = guard("drop render pass", || {
            let mut s = lock(&self.shared);
            if s.executing_pass == self.id {
                s.delegate.cancel();
                s.executing_pass = 0;
            }
            Ok(())
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn quad_scene(d: &Delegate) {
        assert_eq!(d.create_prim("camera", "/Cam"), Ok(true));
        assert_eq!(d.create_prim("renderBuffer", "/Out/color"), Ok(true));
        d.set_ints("/Out/color", "dimensions", &[8, 4], false, 0.0).unwrap();
        assert_eq!(d.create_prim("domeLight", "/Dome"), Ok(true));
        d.set_floats("/Dome", "inputs:color", &[0.25, 0.5, 0.75], 3, false, 0.0).unwrap();
        assert_eq!(d.create_prim("renderSettings", "/S"), Ok(true));
        d.set_int("/S", "tide:samples", 4, false, 0.0).unwrap();
    }

    fn binding(aov: &str, buffer: &str) -> Vec<AovBinding> {
        vec![AovBinding { aov: aov.into(), buffer: buffer.into(), clear: Vec::new() }]
    }

    #[test]
    fn unknown_type_is_a_problem_not_an_error() {
        let d = Delegate::new();
        assert_eq!(d.create_prim("teapot", "/T"), Ok(false));
        assert_eq!(d.create_prim("sphere", "relative"), Ok(false));
        let p = d.commit_resources().unwrap();
        assert_eq!(p.len(), 2, "{p:?}");
        assert!(p.iter().any(|r| r.prim == "/T" && r.message.contains("teapot")));
        assert!(p.iter().any(|r| r.prim == "relative"));
    }

    #[test]
    fn set_on_missing_prim_is_an_error() {
        let d = Delegate::new();
        assert!(d.set_float("/nope", "radius", 1.0, false, 0.0).unwrap_err().contains("/nope"));
        assert!(d.set_matrix("/nope", "transform", &[0.0; 3], false, 0.0).is_err());
        assert!(d.set_primvar("/nope", "st", "vertex", b'f', &[0.0; 2], &[], 2, false, &[]).is_err());
        d.create_prim("mesh", "/M").unwrap();
        assert!(d.set_floats("/M", "points", &[1.0, 2.0], 3, false, 0.0).is_err());
        assert!(d.set_primvar("/M", "st", "perVertex", b'f', &[0.0; 2], &[], 2, false, &[]).is_err());
        assert!(d.set_float("/M", "radius", 1.0, true, f64::NAN).is_err());
        assert!(d.commit_resources().unwrap().is_empty());
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
    fn textures_read_back_and_bad_sizes_are_problems() {
        let d = Delegate::new();
        d.add_texture("/t.exr", 1, 1, 3, &[0.5, 0.25, 1.0], false, "").unwrap();
        let t = d.texture_pixels("/t.exr").unwrap();
        assert_eq!((t.width, t.height, t.channels, t.pixels), (1, 1, 3, vec![0.5, 0.25, 1.0]));
        assert!(d.texture_pixels("/none.exr").unwrap().pixels.is_empty());
        d.add_texture("/bad.exr", 2, 2, 3, &[0.0; 5], false, "").unwrap();
        assert!(d.commit_resources().unwrap().iter().any(|p| p.prim == "/bad.exr"));
    }

    #[test]
    fn bad_bindings_are_errors_and_a_dome_renders_its_colour() {
        let d = Delegate::new();
        quad_scene(&d);
        assert!(d.commit_resources().unwrap().is_empty());
        let p = d.create_render_pass().unwrap();
        assert!(p.execute("/NoCamera", &binding("color", "/Out/color"), "", false, &[], &Vec::new()).is_err());
        assert!(p.execute("/Cam", &binding("bogus", "/Out/color"), "", false, &[], &Vec::new()).is_err());
        assert!(p.execute("/Cam", &binding("color", "/Dome"), "", false, &[], &Vec::new()).is_err());
        assert!(p.execute("/Cam", &binding("color", "/Out/color"), "/Cam", false, &[], &Vec::new()).is_err());
        p.execute("/Cam", &binding("color", "/Out/color"), "/S", false, &[], &Vec::new()).unwrap();
        assert!(p.wait(60.0).unwrap());
        assert_eq!(p.error().unwrap(), "");
        assert!(p.is_converged().unwrap());
        assert_eq!(p.progress().unwrap(), 1.0);
        let m = d.map_buffer("/Out/color").unwrap();
        assert_eq!((m.width, m.height, m.channels), (8, 4, 4));
        // A dome seen directly: every pixel is its colour. The RGB → spectrum → RGB round trip
        // of a smooth colour holds to about 1 %; 3 % leaves room for wavelength-sampling noise
        // at 4 spp on 32 pixels.
        let n = (m.width * m.height) as usize;
        for (c, want) in [0.25f32, 0.5, 0.75].iter().enumerate() {
            let mean = m.pixels.chunks_exact(4).map(|px| px[c]).sum::<f32>() / n as f32;
            assert!((mean - want).abs() < 0.03 * want, "channel {c}: {mean} vs {want}");
        }
        assert!(d.map_buffer("/nope").is_err());
        // read in place: the same pixels into storage of the buffer's shape, nothing into
        // storage of another
        let shape = d.buffer_shape("/Out/color").unwrap();
        assert_eq!((shape.width, shape.height, shape.channels, shape.pixels.len()), (8, 4, 4, 0));
        let mut out = vec![-1.0f32; 8 * 4 * 4];
        assert!(d.read_buffer("/Out/color", &mut out).unwrap());
        assert_eq!(out, m.pixels);
        let mut other = vec![-1.0f32; 8 * 4 * 4 - 1];
        assert!(!d.read_buffer("/Out/color", &mut other).unwrap());
        assert!(other.iter().all(|&v| v == -1.0));
        assert!(d.read_buffer("/nope", &mut out).is_err() && d.buffer_shape("/nope").is_err());
    }

    #[test]
    fn waiting_does_not_block_other_callers_and_dropping_the_pass_cancels() {
        let d = Arc::new(Delegate::new());
        quad_scene(&d);
        d.set_ints("/Out/color", "dimensions", &[64, 64], false, 0.0).unwrap();
        d.set_int("/S", "tide:samples", 1 << 20, false, 0.0).unwrap();
        d.commit_resources().unwrap();
        let p = d.create_render_pass().unwrap();
        p.execute("/Cam", &binding("color", "/Out/color"), "/S", false, &[], &Vec::new()).unwrap();
        let d2 = d.clone();
        let mapper = std::thread::spawn(move || (0..20).all(|_| d2.map_buffer("/Out/color").is_ok()));
        assert!(!p.wait(0.2).unwrap());
        assert!(mapper.join().unwrap());
        drop(p);
        let p = d.create_render_pass().unwrap();
        assert!(p.wait(5.0).unwrap());
        assert!(!p.is_converged().unwrap());
    }

    #[test]
    fn guard_turns_panics_into_errors() {
        let r: Result<(), String> = guard("test", || panic!("boom"));
        assert!(r.unwrap_err().contains("boom"));
    }
}
