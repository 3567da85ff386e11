//! Render buffers and the progressive render pass.
//!
//! A [`RenderPass`] owns one background thread. Each job (a scene, settings and AOV → buffer
//! bindings) is rendered in passes of 1, 2, 4, … samples per pixel until the target (or the
//! time budget, counted from when the engine is built, so scene preparation is not in it) is
//! reached; with a budget, a pass is shortened to what the measured rate fits in half the time
//! left; after every pass the resolved pixels are published into the bound
//! [`RenderBuffer`]s, which any thread may [`RenderBuffer::map`] at any time. Starting a new job
//! cancels the running one (through the engine's cancel flag) and restarts. A panic inside the
//! engine is caught and becomes [`PassStatus::Failed`]; dropping the pass joins the thread.
//!
//! The engine is abstracted by [`Engine`] so the state machine can be tested without the core
//! renderer; [`core_factory`] builds the real one. Engines are created and used on the render
//! thread only, so they need not be `Send`.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, RwLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};
use tide_core::accel::BuildStats;
use tide_core::film::{try_filled, try_zeroed_floats};
use tide_core::world::BuildCache;
use tide_core::{Aov, PauseGate, Problem, RenderError, RenderSettings, Renderer, SampleFormat, SceneDesc};

/// What a render pass drives.
pub trait Engine {
    /// Renders `spp` more samples per pixel; false if cancelled part way, or if `deadline`
    /// passed before the pass finished (the engine then holds the passes before it).
    fn render_pass(&mut self, spp: u32, cancel: &AtomicBool, deadline: Option<Instant>, gate: &PauseGate) -> bool;
    fn samples_per_pixel(&self) -> u32;
    /// Resolved pixels, row-major from the top, `aov.channels()` per pixel.
    fn aov_pixels(&self, aov: Aov) -> Vec<f32>;
    /// An id AOV's pixels exactly, laid as [`Engine::aov_pixels`]'s (None: read the floats).
    fn aov_ids(&self, _aov: Aov) -> Option<Vec<i32>> {
        None
    }
    /// Writes the AOVs, each in its sample format, named by their source names.
    fn write_exr(&self, path: &std::path::Path, aovs: &[(Aov, SampleFormat)], header: &[(String, String)]) -> std::io::Result<()>;
    /// How the engine's acceleration structure was built (None for engines without one).
    fn build_stats(&self) -> Option<BuildStats> {
        None
    }
    /// Figures for the render summary as (key, value) pairs: photons, memory, ….
    fn summary(&self) -> Vec<(String, String)> {
        Vec::new()
    }
    /// Whether adaptive sampling has stopped every pixel (the job then ends early).
    fn converged(&self) -> bool {
        false
    }
    /// How far the pass under way has got, readable while it renders (None: not told).
    fn pass_progress(&self) -> Option<Arc<tide_core::PassProgress>> {
        None
    }
    /// What the engine found wrong in its scene and replaced or dropped while preparing it
    /// (the core renderer's validation and world build), camera included.
    fn problems(&self) -> Vec<Problem> {
        Vec::new()
    }
    /// Takes `scene`'s camera, for a scene that differs from the engine's only there, keeping
    /// the rest of what it built; false (nothing changed) when it cannot, and a new engine is
    /// needed.
    fn set_camera(&mut self, scene: &SceneDesc, settings: &RenderSettings) -> bool {
        let _ = (scene, settings);
        false
    }
}

impl Engine for Renderer {
    fn render_pass(&mut self, spp: u32, cancel: &AtomicBool, deadline: Option<Instant>, gate: &PauseGate) -> bool {
        Renderer::render_pass_paused(self, spp, Some(cancel), deadline, Some(gate))
    }
    fn samples_per_pixel(&self) -> u32 {
        Renderer::samples_per_pixel(self)
    }
    fn set_camera(&mut self, scene: &SceneDesc, settings: &RenderSettings) -> bool {
        Renderer::set_camera(self, &scene.camera, settings)
    }
    fn aov_pixels(&self, aov: Aov) -> Vec<f32> {
        Renderer::aov_pixels(self, aov)
    }
    fn aov_ids(&self, aov: Aov) -> Option<Vec<i32>> {
        Renderer::aov_ids(self, aov)
    }
    fn write_exr(&self, path: &std::path::Path, aovs: &[(Aov, SampleFormat)], header: &[(String, String)]) -> std::io::Result<()> {
        let named: Vec<(String, Aov, SampleFormat)> = aovs.iter().map(|&(a, f)| (a.source_name().to_string(), a, f)).collect();
        Renderer::write_exr_named(self, path, &named, header)
    }
    fn build_stats(&self) -> Option<BuildStats> {
        Some(Renderer::build_stats(self).clone())
    }
    fn pass_progress(&self) -> Option<Arc<tide_core::PassProgress>> {
        Some(Renderer::pass_progress(self))
    }
    fn converged(&self) -> bool {
        Renderer::converged(self)
    }
    fn problems(&self) -> Vec<Problem> {
        Renderer::problems(self).to_vec()
    }
    fn summary(&self) -> Vec<(String, String)> {
        let st = self.stats();
        let mut out = vec![("renderSeconds".to_string(), format!("{:.6}", st.render_seconds)), ("spp".to_string(), st.samples_per_pixel.to_string())];
        if st.mean_samples_per_pixel < st.samples_per_pixel as f64 {
            out.push(("meanSpp".into(), format!("{:.2}", st.mean_samples_per_pixel)));
        }
        if st.unsampled_pixels > 0 {
            out.push(("unsampledPixels".into(), st.unsampled_pixels.to_string()));
        }
        if let Some(c) = &st.caustics {
            out.push(("photonPasses".into(), c.passes.to_string()));
            out.push(("photonsEmitted".into(), c.photons_emitted.to_string()));
            out.push(("photonsStored".into(), c.photons_stored.to_string()));
            out.push(("photonMapPeakBytes".into(), c.peak_map_bytes.to_string()));
            out.push(("photonPassesCapped".into(), c.capped_passes.to_string()));
            out.push(("photonSeconds".into(), format!("{:.3}", st.photon_seconds)));
            out.push(("lightConnections".into(), c.light_connections.to_string()));
            if let Some(m) = c.beams_per_query {
                out.push(("beamsPerQuery".into(), format!("{m:.3}")));
                out.push(("beamShare".into(), format!("{:.6}", c.beam_share)));
            }
        }
        out
    }
}

/// Builds an engine for a job (called on the render thread).
pub type EngineFactory = Arc<dyn Fn(&SceneDesc, &RenderSettings) -> Result<Box<dyn Engine>, RenderError> + Send + Sync>;

/// The core renderer as the engine. The factory keeps what its last build checked and made
/// (validated meshes, per-geometry BVHs, dome and rect-light maps), so a job that follows an
/// edit checks and rebuilds only the geometry whose points or triangles changed, and a
/// light's map only when its image changed.
pub fn core_factory() -> EngineFactory {
    let cache = BuildCache::default();
    Arc::new(move |scene, settings| Ok(Box::new(Renderer::with_cache(scene, settings.clone(), Some(&cache))?) as Box<dyn Engine>))
}

/// A copy of a render buffer's pixels.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MappedBuffer {
    pub width: u32,
    pub height: u32,
    pub channels: u32,
    pub pixels: Vec<f32>,
    /// Samples per pixel the pixels hold.
    pub samples: u32,
}

/// A render buffer (bprim): shared, readable from any thread.
#[derive(Clone, Debug, Default)]
pub struct RenderBuffer {
    inner: Arc<RwLock<MappedBuffer>>,
    /// Left unfilled while rendering (its `tide:publish` false): an AOV that only goes to a
    /// file, written from the film, needs no copy of its pixels after every pass.
    unpublished: Arc<AtomicBool>,
    /// Holds 32-bit integers (its `format` an int32 one, as Hydra's id AOVs): each value is
    /// rounded and its bits stored in place of the float's.
    int: Arc<AtomicBool>,
    /// What each pixel holds until a pass publishes into the buffer (a Hydra binding's
    /// `clearValue`: depth 1, ids -1), a value per channel; empty: zeros.
    clear: Arc<Mutex<Vec<f64>>>,
}

/// How an AOV's pixels are laid into the buffer it is bound to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Binding {
    pub aov: Aov,
    /// Hydra's `depth`: the depth of the camera's projection (clip space) mapped to [0, 1],
    /// 1 where nothing is hit, in place of the distance along the view axis.
    pub clip_depth: bool,
    /// Rows from the bottom of the image up (a Hydra render buffer's order), else from the top.
    pub bottom_up: bool,
}

impl Binding {
    /// `aov` as the film resolves it, rows from the top.
    pub fn plain(aov: Aov) -> Binding {
        Binding { aov, clip_depth: false, bottom_up: false }
    }

    /// A Hydra render pass's AOV `name` (HdAovTokens, else a Tide `sourceName`): `depth` is the
    /// projection's depth in [0, 1] and `cameraDepth` the distance along the view axis; rows
    /// run from the bottom. None for an AOV Tide does not render.
    pub fn hydra(name: &str) -> Option<Binding> {
        let (aov, clip_depth) = match name {
            "depth" => (Aov::Depth, true),
            "cameraDepth" => (Aov::Depth, false),
            _ => (Aov::from_source_name(name)?, false),
        };
        Some(Binding { aov, clip_depth, bottom_up: true })
    }
}

/// A camera's projection along its view axis, for depth in clip space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipDepth {
    pub near: f32,
    pub far: f32,
    pub orthographic: bool,
}

impl ClipDepth {
    /// The depth in [0, 1] of a point `z` along the view axis: OpenGL's projection (that of
    /// `GfFrustum::ComputeProjectionMatrix`) to clip space, then [−1, 1] mapped to [0, 1];
    /// points nearer than `near` read 0, beyond `far` (or none: ∞) 1.
    pub fn of(&self, z: f32) -> f32 {
        let (n, f, z) = (self.near as f64, self.far as f64, z as f64);
        let d = match self.orthographic {
            true => (z - n) / (f - n),
            false => f * (z - n) / ((f - n) * z),
        };
        match z.is_finite() {
            true => d.clamp(0.0, 1.0) as f32,
            false => 1.0,
        }
    }
}

/// The film window ([`tide_core::RenderSettings::film_window`]) a host's projection matrix
/// frames `cam` with: `m` is the matrix as OpenUSD's GfMatrix4d holds it (row-major, points as
/// row vectors; Hydra's render pass state's `GetProjectionMatrix`, its framing and window policy
/// in it). A point (x, y, -1) of the view maps to x_ndc = M00·x − M20 in perspective, so the
/// image spans x = (±1 + M20) / M00 at unit distance: times the focal length in film units;
/// orthographic, x_ndc = M00·x + M30 in scene units. None where the matrix is not of the
/// camera's projection or frames nothing.
pub fn film_window(m: &[f64; 16], cam: &tide_core::scene::CameraDesc) -> Option<[f32; 4]> {
    let (m00, m11) = (m[0], m[5]);
    let perspective = m[11] == -1.0 && m[15] == 0.0;
    let orthographic = m[11] == 0.0 && m[15] == 1.0;
    let w = match cam.projection {
        tide_core::scene::Projection::Perspective if perspective => {
            let f = cam.focal_length as f64;
            [f * m[8] / m00, f * m[9] / m11, 2.0 * f / m00, 2.0 * f / m11]
        }
        tide_core::scene::Projection::Orthographic if orthographic => {
            let u = tide_core::camera::LENS_UNIT as f64;
            [-m[12] / m00 / u, -m[13] / m11 / u, 2.0 / m00 / u, 2.0 / m11 / u]
        }
        _ => return None,
    };
    let w = w.map(|v| v as f32);
    (w.iter().all(|v| v.is_finite()) && w[2] > 0.0 && w[3] > 0.0).then_some(w)
}

/// A binding with what laying its pixels needs from the job: the camera's clip depth.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Output {
    pub binding: Binding,
    pub clip: ClipDepth,
}

impl Output {
    /// `pixels` (`channels` per pixel, `width` wide, rows from the top, as the film resolves
    /// them) laid as the binding and a buffer holding integers (`int`) want them.
    pub fn lay(&self, mut pixels: Vec<f32>, width: u32, channels: usize, int: bool) -> Vec<f32> {
        if self.binding.clip_depth && self.binding.aov == Aov::Depth {
            pixels.iter_mut().for_each(|v| *v = self.clip.of(*v));
        }
        if int {
            // ids are whole numbers (−1 for none); anything else reads −1
            let bits = |v: f32| if v.is_finite() && v.abs() < 2.0e9 { v.round() as i32 } else { -1 };
            pixels.iter_mut().for_each(|v| *v = f32::from_bits(bits(*v) as u32));
        }
        self.flip(&mut pixels, width as usize * channels);
        pixels
    }

    /// Ids (one a pixel, `width` wide, rows from the top) laid as a buffer holding integers
    /// wants them: each one's int32 bits.
    pub fn lay_ids(&self, ids: Vec<i32>, width: u32) -> Vec<f32> {
        let mut pixels: Vec<f32> = ids.into_iter().map(|i| f32::from_bits(i as u32)).collect();
        self.flip(&mut pixels, width as usize);
        pixels
    }

    /// Reverses the order of the rows (`row` values each) where the binding's rows run from the
    /// bottom.
    fn flip(&self, pixels: &mut [f32], row: usize) {
        if self.binding.bottom_up && row > 0 {
            let rows = pixels.len() / row;
            for y in 0..rows / 2 {
                let (top, rest) = pixels.split_at_mut((rows - 1 - y) * row);
                top[y * row..(y + 1) * row].swap_with_slice(&mut rest[..row]);
            }
        }
    }
}

impl RenderBuffer {
    /// Whether the buffer holds 32-bit integers (see [`RenderBuffer`]).
    pub fn holds_ints(&self) -> bool {
        self.int.load(Ordering::Relaxed)
    }

    pub fn set_holds_ints(&self, on: bool) {
        if self.int.swap(on, Ordering::Relaxed) != on {
            self.refill_unpublished();
        }
    }

    /// Sets the value (one per channel) each pixel holds until a pass publishes into the
    /// buffer, and gives it to the pixels now where none has since the buffer was sized.
    pub fn set_clear(&self, values: &[f64]) {
        let mut c = self.clear.lock().unwrap_or_else(|e| e.into_inner());
        if *c != values {
            *c = values.to_vec();
            drop(c);
            self.refill_unpublished();
        }
    }

    /// `width` × `height` pixels of the clear value, with its channel count (`channels` of
    /// zeros without one).
    /// The cleared pixels of a buffer of these dimensions (and their channel count), or what
    /// kept them from being allocated.
    fn cleared(&self, width: u32, height: u32, channels: u32) -> Result<(u32, Vec<f32>), String> {
        let clear = self.clear.lock().unwrap_or_else(|e| e.into_inner()).clone();
        let int = self.holds_ints();
        let one: Vec<f32> = clear.iter().map(|&v| if int { f32::from_bits((v.round().clamp(i32::MIN as f64, i32::MAX as f64) as i32) as u32) } else { v as f32 }).collect();
        let per = if one.is_empty() { channels as usize } else { one.len() };
        let n = width as usize * height as usize;
        let too_big = || format!("not enough memory for a {width}×{height} buffer of {per} channels ({} MiB)", (n as u128 * per as u128 * 4) >> 20);
        let len = n.checked_mul(per).ok_or_else(too_big)?;
        if one.is_empty() {
            // zeroed by the allocator: pages never written (a buffer never read) cost nothing
            return try_zeroed_floats(len).map(|pixels| (per as u32, pixels)).ok_or_else(too_big);
        }
        let mut pixels = try_filled(len, 0.0f32).ok_or_else(too_big)?;
        for px in pixels.chunks_exact_mut(per) {
            px.copy_from_slice(&one);
        }
        Ok((per as u32, pixels))
    }

    /// Gives the clear value to the pixels where no pass has published since the buffer was
    /// sized.
    fn refill_unpublished(&self) {
        let mut g = self.inner.write().unwrap_or_else(|e| e.into_inner());
        if g.samples == 0 {
            // (its size was allocated once already: on failure the pixels stay as they are)
            if let Ok((channels, pixels)) = self.cleared(g.width, g.height, g.channels) {
                g.channels = channels;
                g.pixels = pixels;
            }
        }
    }

    /// Whether passes fill this buffer (they do unless told otherwise).
    pub fn publishes(&self) -> bool {
        !self.unpublished.load(Ordering::Relaxed)
    }

    pub fn set_publishes(&self, on: bool) {
        self.unpublished.store(!on, Ordering::Relaxed);
    }

    /// A buffer of these dimensions (0×0 when they cannot be allocated).
    pub fn new(width: u32, height: u32, channels: u32) -> Self {
        let b = RenderBuffer::default();
        let _ = b.resize(width, height, channels);
        b
    }

    /// Sets the dimensions, clearing the pixels (to the clear value where there is one, with
    /// its channel count; else `channels` of zeros).
    /// An allocation that fails leaves the buffer empty (0×0) and says why.
    pub fn resize(&self, width: u32, height: u32, channels: u32) -> Result<(), String> {
        let made = self.cleared(width, height, channels);
        let mut g = self.inner.write().unwrap_or_else(|e| e.into_inner());
        match made {
            Ok((channels, pixels)) => {
                *g = MappedBuffer { width, height, channels, pixels, samples: 0 };
                Ok(())
            }
            Err(e) => {
                *g = MappedBuffer { width: 0, height: 0, channels, pixels: Vec::new(), samples: 0 };
                Err(e)
            }
        }
    }

    /// A copy of the current pixels with their dimensions.
    pub fn map(&self) -> MappedBuffer {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).clone()
    }

    fn publish(&self, width: u32, height: u32, channels: u32, pixels: Vec<f32>, samples: u32) {
        let mut g = self.inner.write().unwrap_or_else(|e| e.into_inner());
        *g = MappedBuffer { width, height, channels, pixels, samples };
    }

    pub fn dimensions(&self) -> (u32, u32) {
        let g = self.inner.read().unwrap_or_else(|e| e.into_inner());
        (g.width, g.height)
    }

    /// Whether a pass has published into the buffer since it was sized.
    pub fn published(&self) -> bool {
        self.inner.read().unwrap_or_else(|e| e.into_inner()).samples > 0
    }

    /// The current (width, height, channels).
    pub fn shape(&self) -> (u32, u32, u32) {
        let g = self.inner.read().unwrap_or_else(|e| e.into_inner());
        (g.width, g.height, g.channels)
    }

    /// Copies the current pixels into `out` where it holds exactly as many floats, without a
    /// copy in between (a reader's own storage, filled in place); returns their (width,
    /// height, channels), or None (`out` untouched) when the size differs: the buffer was
    /// resized or published at another size since [`RenderBuffer::shape`].
    pub fn read_into(&self, out: &mut [f32]) -> Option<(u32, u32, u32)> {
        let g = self.inner.read().unwrap_or_else(|e| e.into_inner());
        (g.pixels.len() == out.len()).then(|| {
            out.copy_from_slice(&g.pixels);
            (g.width, g.height, g.channels)
        })
    }
}

/// Where a pass stands.
#[derive(Clone, Debug, PartialEq)]
pub enum PassStatus {
    /// No job yet.
    Idle,
    /// A job is queued or being rendered.
    Rendering,
    /// The sample target (or time budget) was reached.
    Converged,
    /// The engine could not be built, or panicked; the message says why.
    Failed(String),
}

/// One render job.
#[derive(Clone)]
pub struct Job {
    pub scene: Arc<SceneDesc>,
    pub settings: RenderSettings,
    pub bindings: Vec<(Output, RenderBuffer)>,
    /// Jobs with the same `world` have scenes that differ at most in their camera: the engine
    /// of the one before is kept and given the new camera ([`Engine::set_camera`]).
    pub world: u64,
}

type ExrReply = std::sync::mpsc::Sender<std::io::Result<()>>;
/// A queued EXR write: path, AOVs, header, where to send the result.
type ExrRequest = (std::path::PathBuf, Vec<(Aov, SampleFormat)>, Vec<(String, String)>, ExrReply);

struct State {
    job: Option<Job>,
    /// Incremented by every start; the thread renders the latest.
    generation: u64,
    taken: u64,
    status: PassStatus,
    spp_done: u32,
    spp_target: u32,
    shutdown: bool,
    exr: Vec<ExrRequest>,
    /// The engine's summary after the last finished pass.
    summary: Vec<(String, String)>,
    /// The problems of the engine the running job was prepared with (None before the first
    /// is built; a job being prepared shows its predecessor's).
    problems: Option<Vec<Problem>>,
    /// The pass under way: its samples per pixel and how far it has got (engines that tell).
    pass: Option<(u32, Arc<tide_core::PassProgress>)>,
    /// True while the thread works on a job (preparing its scene or rendering), false while it
    /// waits for the next.
    busy: bool,
}

struct Shared {
    state: Mutex<State>,
    cond: Condvar,
    cancel: AtomicBool,
    /// Holds the render where it is while paused (passes wait at their next pixel).
    gate: PauseGate,
}

impl Shared {
    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Observes a [`RenderPass`] (status, progress, waiting) without borrowing it, so a caller
/// can wait for a render while the pass's owner stays available to other threads. It does not
/// keep the render thread alive: once the pass is dropped its last status stays readable.
#[derive(Clone)]
pub struct PassWatcher {
    shared: Arc<Shared>,
}

impl PassWatcher {
    pub fn status(&self) -> PassStatus {
        self.shared.lock().status.clone()
    }

    pub fn is_converged(&self) -> bool {
        self.status() == PassStatus::Converged
    }

    /// Fraction of the sample target reached (1 when converged), the pass under way counted by
    /// the part of it done (so a long pass moves it).
    pub fn progress(&self) -> f32 {
        let st = self.shared.lock();
        match st.status {
            PassStatus::Converged => 1.0,
            _ if st.spp_target == 0 => 0.0,
            _ => {
                let part = st.pass.as_ref().map_or(0.0, |(n, p)| *n as f64 * p.fraction());
                ((st.spp_done as f64 + part) / st.spp_target as f64).min(1.0) as f32
            }
        }
    }

    /// The engine's figures after the last finished pass (photons, memory, …).
    pub fn summary(&self) -> Vec<(String, String)> {
        self.shared.lock().summary.clone()
    }

    /// What the engine of the running (or last) job found wrong while preparing its scene;
    /// empty until that engine is built.
    pub fn problems(&self) -> Vec<Problem> {
        self.engine_problems().unwrap_or_default()
    }

    /// [`PassWatcher::problems`], None before any engine was built.
    pub fn engine_problems(&self) -> Option<Vec<Problem>> {
        self.shared.lock().problems.clone()
    }

    /// Waits until the render thread is between jobs (true), or `timeout` passes (false): no
    /// worker renders when it returns true. A scene being prepared is finished first (its
    /// preparation is not interrupted); a cancelled pass is left at the workers' next pixel.
    pub fn wait_idle(&self, timeout: Duration) -> bool {
        let deadline = Instant::now().checked_add(timeout);
        let mut st = self.shared.lock();
        while st.busy {
            st = match deadline {
                None => self.shared.cond.wait(st).unwrap_or_else(|e| e.into_inner()),
                Some(d) => {
                    let left = d.saturating_duration_since(Instant::now());
                    if left.is_zero() {
                        return false;
                    }
                    self.shared.cond.wait_timeout(st, left).unwrap_or_else(|e| e.into_inner()).0
                }
            };
        }
        true
    }

    /// Waits until the job converges or fails (or `timeout` passes); true if converged.
    pub fn wait(&self, timeout: Duration) -> bool {
        let deadline = Instant::now().checked_add(timeout);
        let mut st = self.shared.lock();
        loop {
            match st.status {
                PassStatus::Converged => return true,
                PassStatus::Failed(_) | PassStatus::Idle => return false,
                PassStatus::Rendering => {}
            }
            if st.shutdown {
                return false;
            }
            st = match deadline {
                None => self.shared.cond.wait(st).unwrap_or_else(|e| e.into_inner()),
                Some(d) => {
                    let now = Instant::now();
                    if now >= d {
                        return false;
                    }
                    self.shared.cond.wait_timeout(st, d - now).unwrap_or_else(|e| e.into_inner()).0
                }
            };
        }
    }
}

/// A progressive render on a background thread.
pub struct RenderPass {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

fn panic_message(e: Box<dyn std::any::Any + Send>) -> String {
    if let Some(s) = e.downcast_ref::<&str>() {
        s.to_string()
    } else if let Some(s) = e.downcast_ref::<String>() {
        s.clone()
    } else {
        "unknown panic".into()
    }
}

impl RenderPass {
    /// Starts the thread (idle until [`RenderPass::start`]).
    pub fn new(factory: EngineFactory) -> RenderPass {
        let shared = Arc::new(Shared {
            state: Mutex::new(State {
                job: None,
                generation: 0,
                taken: 0,
                status: PassStatus::Idle,
                spp_done: 0,
                pass: None,
                spp_target: 0,
                shutdown: false,
                exr: Vec::new(),
                summary: Vec::new(),
                problems: None,
                busy: false,
            }),
            cond: Condvar::new(),
            cancel: AtomicBool::new(false),
            gate: PauseGate::new(),
        });
        let s = shared.clone();
        let thread = std::thread::Builder::new()
            .name("tide-render-pass".into())
            .spawn(move || {
                // The loop itself catches engine panics per job; this outer guard keeps a bug
                // in the bookkeeping from escaping the thread.
                if let Err(e) = catch_unwind(AssertUnwindSafe(|| thread_main(&s, &factory))) {
                    let mut st = s.lock();
                    st.status = PassStatus::Failed(format!("render thread panicked: {}", panic_message(e)));
                    s.cond.notify_all();
                }
            })
            .ok();
        let pass = RenderPass { shared, thread };
        if pass.thread.is_none() {
            pass.shared.lock().status = PassStatus::Failed("could not start the render thread".into());
        }
        pass
    }

    /// Renders `job`, cancelling whatever is running.
    pub fn start(&self, job: Job) {
        let mut st = self.shared.lock();
        st.generation += 1;
        st.spp_target = job.settings.spp;
        st.spp_done = 0;
        st.pass = None;
        st.job = Some(job);
        if self.thread.is_some() {
            st.status = PassStatus::Rendering;
        }
        self.shared.cancel.store(true, Ordering::SeqCst);
        self.shared.cond.notify_all();
    }

    /// Pauses rendering where it is: the pass under way waits at its next pixel, and a job
    /// started meanwhile waits before its first pass (its scene is prepared). Paused time does
    /// not count against a time budget.
    pub fn pause(&self) {
        self.shared.gate.pause();
    }

    /// Resumes a paused render where it stopped (the same samples as if never paused).
    pub fn resume(&self) {
        self.shared.gate.resume();
    }

    pub fn is_paused(&self) -> bool {
        self.shared.gate.is_paused()
    }

    /// Stops the current job (the buffers keep what was published).
    pub fn cancel(&self) {
        let mut st = self.shared.lock();
        st.job = None;
        st.generation += 1;
        if st.status == PassStatus::Rendering {
            st.status = PassStatus::Idle;
        }
        self.shared.cancel.store(true, Ordering::SeqCst);
        self.shared.cond.notify_all();
    }

    /// Cancels the current job like [`RenderPass::cancel`] and waits until the render thread
    /// has left it ([`PassWatcher::wait_idle`]).
    pub fn cancel_and_wait(&self, timeout: Duration) -> bool {
        self.cancel();
        self.watcher().wait_idle(timeout)
    }

    pub fn status(&self) -> PassStatus {
        self.watcher().status()
    }

    pub fn is_converged(&self) -> bool {
        self.status() == PassStatus::Converged
    }

    /// Fraction of the sample target reached (1 when converged).
    pub fn progress(&self) -> f32 {
        self.watcher().progress()
    }

    /// Waits until the job converges or fails (or `timeout` passes); true if converged.
    pub fn wait(&self, timeout: Duration) -> bool {
        self.watcher().wait(timeout)
    }

    /// A handle that observes this pass without borrowing it.
    pub fn watcher(&self) -> PassWatcher {
        PassWatcher { shared: self.shared.clone() }
    }

    /// Writes the current film of the running (or finished) job to EXR through the engine.
    pub fn write_exr(&self, path: &std::path::Path, aovs: &[(Aov, SampleFormat)], header: &[(String, String)]) -> std::io::Result<()> {
        let (tx, rx) = std::sync::mpsc::channel();
        {
            let mut st = self.shared.lock();
            if st.job.is_none() {
                return Err(std::io::Error::other("no render to write: execute a render pass first"));
            }
            st.exr.push((path.to_path_buf(), aovs.to_vec(), header.to_vec(), tx));
            self.shared.cond.notify_all();
        }
        rx.recv().unwrap_or_else(|_| Err(std::io::Error::other("the render thread stopped before writing")))
    }
}

impl Drop for RenderPass {
    fn drop(&mut self) {
        {
            let mut st = self.shared.lock();
            st.shutdown = true;
            if st.status == PassStatus::Rendering {
                st.status = PassStatus::Idle;
            }
            self.shared.cancel.store(true, Ordering::SeqCst);
            self.shared.cond.notify_all();
        }
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

fn serve_exr(shared: &Shared, engine: Option<&dyn Engine>) {
    let reqs = std::mem::take(&mut shared.lock().exr);
    for (path, aovs, header, reply) in reqs {
        let r = match engine {
            Some(e) => catch_unwind(AssertUnwindSafe(|| e.write_exr(&path, &aovs, &header)))
                .unwrap_or_else(|p| Err(std::io::Error::other(format!("writing panicked: {}", panic_message(p))))),
            None => Err(std::io::Error::other("no finished render to write")),
        };
        let _ = reply.send(r);
    }
}

fn thread_main(shared: &Shared, factory: &EngineFactory) {
    let mut engine: Option<Box<dyn Engine>> = None;
    // the `world` of the job `engine` was built or last re-aimed for
    let mut engine_world: Option<u64> = None;
    loop {
        // Wait for a new job, serving EXR requests against the last engine meanwhile.
        let (job, generation) = {
            let mut st = shared.lock();
            loop {
                if st.shutdown {
                    for (_, _, _, reply) in st.exr.drain(..) {
                        let _ = reply.send(Err(std::io::Error::other("the render pass was dropped")));
                    }
                    return;
                }
                if !st.exr.is_empty() {
                    drop(st);
                    serve_exr(shared, engine.as_deref());
                    st = shared.lock();
                    continue;
                }
                if st.generation != st.taken {
                    st.taken = st.generation;
                    if let Some(j) = st.job.clone() {
                        shared.cancel.store(false, Ordering::SeqCst);
                        st.busy = true;
                        break (j, st.generation);
                    }
                    continue;
                }
                st = shared.cond.wait(st).unwrap_or_else(|e| e.into_inner());
            }
        };
        if engine_world != Some(job.world) {
            // freed before the next engine is built
            engine = None;
        }
        let outcome = catch_unwind(AssertUnwindSafe(|| run_job(shared, factory, &job, generation, &mut engine)));
        engine_world = engine.as_ref().map(|_| job.world);
        let mut st = shared.lock();
        st.busy = false;
        if st.generation == generation {
            match outcome {
                Ok(Ok(true)) => st.status = PassStatus::Converged,
                Ok(Ok(false)) => {}
                Ok(Err(msg)) => st.status = PassStatus::Failed(msg),
                Err(p) => {
                    engine = None;
                    st.status = PassStatus::Failed(format!("the renderer panicked: {}", panic_message(p)));
                }
            }
        }
        shared.cond.notify_all();
    }
}

/// Renders one job; Ok(true) when it reached its target or budget, Ok(false) if superseded.
fn run_job(shared: &Shared, factory: &EngineFactory, job: &Job, generation: u64, slot: &mut Option<Box<dyn Engine>>) -> Result<bool, String> {
    let target = job.settings.spp;
    let budget = job.settings.time_budget_s;
    let reaimed = slot.as_mut().is_some_and(|e| e.set_camera(&job.scene, &job.settings));
    if !reaimed {
        // the old engine is freed before the new one is built
        *slot = None;
        *slot = Some(factory(&job.scene, &job.settings).map_err(|e| format!("the scene could not be prepared: {}", e))?);
    }
    let Some(e) = slot.as_mut() else { unreachable!() };
    {
        let problems = e.problems();
        let mut st = shared.lock();
        if st.generation != generation {
            return Ok(false);
        }
        st.problems = Some(problems);
        shared.cond.notify_all();
    }
    // the budget counts rendering: from here, less the time paused
    let gate = &shared.gate;
    gate.restart_clock();
    let start = Instant::now();
    let rendering = || start.elapsed().saturating_sub(gate.paused_time());
    let mut next = 1u32;
    let mut done = 0u32;
    while done < target {
        gate.wait(Some(&shared.cancel));
        if shared.cancel.load(Ordering::SeqCst) {
            return Ok(false);
        }
        let mut n = next.min(target - done);
        if budget > 0.0 && done > 0 {
            // Size the pass to half the budget left at the rate measured so far (which includes
            // publishing), so the render ends at the budget instead of up to one doubling past
            // it, and a slowdown of the machine during the last passes overruns by at most a
            // small pass; a pass that would not fit even one sample is not started.
            let elapsed = rendering().as_secs_f64();
            let fit = (budget as f64 - elapsed) / (elapsed / done as f64);
            if fit < 1.0 {
                break;
            }
            n = n.min((fit * 0.5).clamp(1.0, u32::MAX as f64) as u32);
        }
        // a pass still running at the budget's end is given up there, the first included: the
        // render keeps the passes before it and the pixels the last one finished (after a
        // first pass given up, some pixels have no samples, and the summary says how many)
        let deadline = (budget > 0.0).then(|| start + Duration::from_secs_f64(budget as f64));
        {
            let mut st = shared.lock();
            if st.generation != generation {
                return Ok(false);
            }
            // from nothing done (the engine's count still holds its last pass until it starts)
            st.pass = e.pass_progress().map(|p| {
                p.start(0);
                (n, p)
            });
        }
        let whole = e.render_pass(n, &shared.cancel, deadline, gate);
        if !whole && (shared.cancel.load(Ordering::SeqCst) || !deadline.is_some_and(|d| gate.past(d))) {
            return Ok(false);
        }
        done = if whole { done + n } else { e.samples_per_pixel().min(target) };
        let (w, h) = (job.settings.width, job.settings.height);
        let mut laid_out = Vec::new();
        for (out, buf) in job.bindings.iter().filter(|(_, b)| b.publishes()) {
            let aov = out.binding.aov;
            let whole = (w * h) as usize * aov.channels();
            // A film that does not match the job's size is not published (the buffer keeps
            // its last consistent pixels). Ids go into a buffer of integers exactly (a float
            // holds them only up to 2^24).
            let laid = match buf.holds_ints().then(|| e.aov_ids(aov)).flatten() {
                Some(ids) => (ids.len() == whole).then(|| out.lay_ids(ids, w)),
                None => {
                    let px = e.aov_pixels(aov);
                    (px.len() == whole).then(|| out.lay(px, w, aov.channels(), buf.holds_ints()))
                }
            };
            if let Some(px) = laid {
                laid_out.push((buf, aov.channels() as u32, px));
            }
        }
        {
            // published under the state's lock, once the job is known to be current: a job
            // cancelled or stopped (which takes the lock) publishes nothing after it returns
            let mut st = shared.lock();
            if st.generation != generation {
                return Ok(false);
            }
            for (buf, channels, px) in laid_out {
                buf.publish(w, h, channels, px, e.samples_per_pixel());
            }
            st.spp_done = done;
            st.pass = None;
            st.summary = e.summary();
            shared.cond.notify_all();
        }
        if !shared.lock().exr.is_empty() {
            serve_exr(shared, Some(&**e));
        }
        next = next.saturating_mul(2);
        if !whole || (budget > 0.0 && rendering().as_secs_f32() >= budget) {
            break;
        }
        if e.converged() {
            break;
        }
    }
    Ok(true)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use std::sync::atomic::AtomicU32;

    /// `aov` as the film resolves it.
    pub(crate) fn plain(aov: Aov) -> Output {
        Output { binding: Binding::plain(aov), clip: ClipDepth { near: 0.1, far: 1.0e4, orthographic: false } }
    }

    /// A fake engine: fills every AOV with its sample count; optionally slow or panicking.
    pub(crate) struct Fake {
        pub w: u32,
        pub h: u32,
        pub spp: u32,
        pub delay: Duration,
        /// Extra time per sample per pixel of a pass.
        pub per_spp: Duration,
        pub panic_at: Option<u32>,
        pub passes: Arc<Mutex<Vec<u32>>>,
        /// (after, each): samples past the first `after` take `each` more.
        pub slow: Option<(u32, Duration)>,
    }

    impl Engine for Fake {
        fn render_pass(&mut self, spp: u32, cancel: &AtomicBool, deadline: Option<Instant>, _: &PauseGate) -> bool {
            // samples past `slow_after` take `slow` each (paths that turn slow late in a render)
            let slow = self.slow.map_or(Duration::ZERO, |(after, each)| each * (self.spp + spp).saturating_sub(after.max(self.spp)));
            let until = Instant::now() + self.delay + self.per_spp * spp + slow;
            while Instant::now() < until {
                if cancel.load(Ordering::SeqCst) || deadline.is_some_and(|d| Instant::now() >= d) {
                    return false;
                }
                std::thread::sleep(Duration::from_millis(1));
            }
            if self.panic_at == Some(self.spp + spp) {
                panic!("fake engine failure");
            }
            self.spp += spp;
            self.passes.lock().unwrap().push(spp);
            true
        }
        fn samples_per_pixel(&self) -> u32 {
            self.spp
        }
        fn aov_pixels(&self, aov: Aov) -> Vec<f32> {
            vec![self.spp as f32; (self.w * self.h) as usize * aov.channels()]
        }
        fn write_exr(&self, _: &std::path::Path, _: &[(Aov, SampleFormat)], _: &[(String, String)]) -> std::io::Result<()> {
            Ok(())
        }
    }

    pub(crate) fn fake_factory(delay: Duration, panic_at: Option<u32>, builds: Arc<AtomicU32>, passes: Arc<Mutex<Vec<u32>>>) -> EngineFactory {
        Arc::new(move |_, s| {
            builds.fetch_add(1, Ordering::SeqCst);
            Ok(Box::new(Fake { w: s.width, h: s.height, spp: 0, delay, per_spp: Duration::ZERO, panic_at, passes: passes.clone(), slow: None }) as Box<dyn Engine>)
        })
    }

    fn job(spp: u32, buf: &RenderBuffer) -> Job {
        let settings = RenderSettings { width: 4, height: 2, spp, ..Default::default() };
        Job { scene: Arc::new(SceneDesc::default()), settings, bindings: vec![(plain(Aov::Color), buf.clone())], world: 0 }
    }

    #[test]
    fn progressive_passes_double_and_publish() {
        let passes = Arc::new(Mutex::new(Vec::new()));
        let pass = RenderPass::new(fake_factory(Duration::ZERO, None, Default::default(), passes.clone()));
        assert_eq!(pass.status(), PassStatus::Idle);
        let buf = RenderBuffer::new(4, 2, 4);
        pass.start(job(10, &buf));
        assert!(pass.wait(Duration::from_secs(5)));
        assert_eq!(*passes.lock().unwrap(), vec![1, 2, 4, 3]);
        let m = buf.map();
        assert_eq!((m.width, m.height, m.channels, m.samples), (4, 2, 4, 10));
        assert!(m.pixels.iter().all(|&x| x == 10.0) && m.pixels.len() == 32);
        assert_eq!(pass.progress(), 1.0);
    }

    #[test]
    fn watcher_waits_apart_from_the_pass_and_outlives_it() {
        let pass = RenderPass::new(fake_factory(Duration::from_millis(20), None, Default::default(), Default::default()));
        let buf = RenderBuffer::new(4, 2, 4);
        let w = pass.watcher();
        pass.start(job(4, &buf));
        let waiter = std::thread::spawn(move || w.wait(Duration::from_secs(5)));
        assert!(waiter.join().unwrap());
        assert_eq!(buf.map().samples, 4);
        let w = pass.watcher();
        pass.start(job(1000, &buf));
        drop(pass);
        // Waiting "forever" on a dropped pass returns at once: nothing will ever finish it.
        let t = Instant::now();
        assert!(!w.wait(Duration::MAX));
        assert!(t.elapsed() < Duration::from_secs(1), "{:?}", t.elapsed());
        assert_eq!(w.status(), PassStatus::Idle);
    }

    /// An engine whose pass takes `linger` to wind down after it sees the cancel flag (as
    /// workers finish the pixel they are on), counting the passes under way.
    struct Lingering {
        inside: Arc<AtomicU32>,
        linger: Duration,
    }

    impl Engine for Lingering {
        fn render_pass(&mut self, _: u32, cancel: &AtomicBool, _: Option<Instant>, _: &PauseGate) -> bool {
            self.inside.fetch_add(1, Ordering::SeqCst);
            while !cancel.load(Ordering::SeqCst) {
                std::thread::sleep(Duration::from_millis(1));
            }
            std::thread::sleep(self.linger);
            self.inside.fetch_sub(1, Ordering::SeqCst);
            false
        }
        fn samples_per_pixel(&self) -> u32 {
            0
        }
        fn aov_pixels(&self, _: Aov) -> Vec<f32> {
            Vec::new()
        }
        fn write_exr(&self, _: &std::path::Path, _: &[(Aov, SampleFormat)], _: &[(String, String)]) -> std::io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn cancel_and_wait_returns_once_no_pass_renders() {
        let inside = Arc::new(AtomicU32::new(0));
        let i = inside.clone();
        let pass = RenderPass::new(Arc::new(move |_, _| Ok(Box::new(Lingering { inside: i.clone(), linger: Duration::from_millis(80) }) as Box<dyn Engine>)));
        let buf = RenderBuffer::new(4, 2, 4);
        for _ in 0..2 {
            pass.start(job(10, &buf));
            let t = Instant::now();
            while inside.load(Ordering::SeqCst) == 0 {
                assert!(t.elapsed() < Duration::from_secs(5));
                std::thread::sleep(Duration::from_millis(1));
            }
            assert!(pass.cancel_and_wait(Duration::from_secs(5)));
            assert_eq!(inside.load(Ordering::SeqCst), 0);
            assert_eq!(pass.status(), PassStatus::Idle);
        }
        // nothing under way: returns at once
        assert!(pass.cancel_and_wait(Duration::ZERO));
        // a pass that outlasts the timeout: false, and it still winds down
        let inside = Arc::new(AtomicU32::new(0));
        let i = inside.clone();
        let pass = RenderPass::new(Arc::new(move |_, _| Ok(Box::new(Lingering { inside: i.clone(), linger: Duration::from_millis(300) }) as Box<dyn Engine>)));
        pass.start(job(10, &buf));
        while inside.load(Ordering::SeqCst) == 0 {
            std::thread::sleep(Duration::from_millis(1));
        }
        assert!(!pass.cancel_and_wait(Duration::from_millis(20)));
        assert!(pass.cancel_and_wait(Duration::from_secs(5)));
        assert_eq!(inside.load(Ordering::SeqCst), 0);
    }

    #[test]
    fn zero_spp_converges_immediately() {
        let pass = RenderPass::new(fake_factory(Duration::ZERO, None, Default::default(), Default::default()));
        pass.start(job(0, &RenderBuffer::default()));
        assert!(pass.wait(Duration::from_secs(5)));
    }

    #[test]
    fn restart_cancels_the_running_job_and_drop_joins() {
        let builds = Arc::new(AtomicU32::new(0));
        let passes = Arc::new(Mutex::new(Vec::new()));
        // Each pass takes 20 ms: the first job (1000 spp) cannot finish before the restart.
        let pass = RenderPass::new(fake_factory(Duration::from_millis(20), None, builds.clone(), passes.clone()));
        let buf = RenderBuffer::new(4, 2, 4);
        pass.start(job(1000, &buf));
        std::thread::sleep(Duration::from_millis(30));
        assert_eq!(pass.status(), PassStatus::Rendering);
        assert!(!pass.wait(Duration::from_millis(1)));
        pass.start(job(3, &buf));
        assert!(pass.wait(Duration::from_secs(5)));
        assert_eq!(builds.load(Ordering::SeqCst), 2);
        assert_eq!(buf.map().samples, 3);
        pass.start(job(1000, &buf));
        std::thread::sleep(Duration::from_millis(10));
        pass.cancel();
        assert_eq!(pass.status(), PassStatus::Idle);
        let t = Instant::now();
        pass.start(job(1000, &buf));
        drop(pass);
        // Drop cancels through the flag: well under one 1000-spp job (≥ 10 passes · 20 ms).
        assert!(t.elapsed() < Duration::from_millis(150), "{:?}", t.elapsed());
    }

    #[test]
    fn engine_panic_becomes_an_error_state() {
        let pass = RenderPass::new(fake_factory(Duration::ZERO, Some(3), Default::default(), Default::default()));
        let buf = RenderBuffer::new(4, 2, 4);
        pass.start(job(8, &buf));
        assert!(!pass.wait(Duration::from_secs(5)));
        match pass.status() {
            PassStatus::Failed(m) => assert!(m.contains("fake engine failure"), "{}", m),
            s => panic!("{:?}", s),
        }
        // The first pass (1 spp) was published before the failure.
        assert_eq!(buf.map().samples, 1);
        // The thread survives and takes the next job.
        let ok = RenderPass::new(fake_factory(Duration::ZERO, None, Default::default(), Default::default()));
        ok.start(job(2, &buf));
        assert!(ok.wait(Duration::from_secs(5)));
        pass.start(job(2, &buf));
        assert!(pass.wait(Duration::from_secs(5)));
    }

    #[test]
    fn factory_error_is_reported() {
        let f: EngineFactory = Arc::new(|_, _| Err(RenderError("empty scene".into())));
        let pass = RenderPass::new(f);
        pass.start(job(4, &RenderBuffer::default()));
        assert!(!pass.wait(Duration::from_secs(5)));
        assert!(matches!(pass.status(), PassStatus::Failed(m) if m.contains("empty scene")));
    }

    #[test]
    fn time_budget_stops_early() {
        let pass = RenderPass::new(fake_factory(Duration::from_millis(5), None, Default::default(), Default::default()));
        let buf = RenderBuffer::new(4, 2, 4);
        let mut j = job(1 << 20, &buf);
        j.settings.time_budget_s = 0.02;
        pass.start(j);
        assert!(pass.wait(Duration::from_secs(5)));
        assert!(buf.map().samples < 1 << 20);
    }

    #[test]
    fn time_budget_is_not_overshot_by_a_doubling() {
        // 2 ms per sample, 0.2 s budget: the budget holds at most 100 samples. Doubling passes
        // alone would end at 127 (the pass of 64 starting at 63 samples, 0.126 s). Every pass is
        // sized by a measured rate that is never faster than the true one, so the bound of 100
        // is exact whatever the machine's load.
        let per_spp = Duration::from_millis(2);
        let f: EngineFactory = Arc::new(move |_, s| {
            Ok(Box::new(Fake { w: s.width, h: s.height, spp: 0, delay: Duration::ZERO, per_spp, panic_at: None, passes: Default::default(), slow: None })
                as Box<dyn Engine>)
        });
        let pass = RenderPass::new(f);
        let buf = RenderBuffer::new(4, 2, 4);
        let mut j = job(1 << 20, &buf);
        j.settings.time_budget_s = 0.2;
        pass.start(j);
        assert!(pass.wait(Duration::from_secs(10)));
        let n = buf.map().samples;
        // Lower bound: a pass is only skipped when not one more sample fits, so the render cannot
        // stop far below the budget; 10 samples (20% of it) leaves room for a loaded machine
        // where sleeps overrun several-fold.
        assert!((10..=100).contains(&n), "{n} samples in a 0.2 s budget at 2 ms per sample");
    }

    /// An engine whose every pass takes 20 steps of 10 ms and says so.
    struct Steps {
        spp: u32,
        progress: Arc<tide_core::PassProgress>,
    }

    impl Engine for Steps {
        fn render_pass(&mut self, spp: u32, _: &AtomicBool, _: Option<Instant>, _: &PauseGate) -> bool {
            self.progress.start(20);
            for _ in 0..20 {
                std::thread::sleep(Duration::from_millis(10));
                self.progress.add(1);
            }
            self.spp += spp;
            true
        }
        fn samples_per_pixel(&self) -> u32 {
            self.spp
        }
        fn aov_pixels(&self, aov: Aov) -> Vec<f32> {
            vec![self.spp as f32; 8 * aov.channels()]
        }
        fn write_exr(&self, _: &std::path::Path, _: &[(Aov, SampleFormat)], _: &[(String, String)]) -> std::io::Result<()> {
            Ok(())
        }
        fn pass_progress(&self) -> Option<Arc<tide_core::PassProgress>> {
            Some(self.progress.clone())
        }
    }

    #[test]
    fn a_hydra_binding_lays_rows_from_the_bottom_ids_as_ints_and_depth_in_clip_space() {
        let rows = |v: &[f32]| v.chunks(2).map(|r| r.to_vec()).collect::<Vec<_>>();
        // three rows of two: the middle one stays
        let px = vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let hd = Output { binding: Binding::hydra("primId").unwrap(), ..plain(Aov::PrimId) };
        let laid = hd.lay(px.clone(), 2, 1, false);
        assert_eq!(rows(&laid), [[5.0, 6.0], [3.0, 4.0], [1.0, 2.0]]);
        assert_eq!(plain(Aov::PrimId).lay(px.clone(), 2, 1, false), px);
        // an int32 buffer holds the ids' bits; none (or anything not a number) reads -1
        let ids = plain(Aov::PrimId).lay(vec![7.0, -1.0, f32::NAN, 3.0], 2, 1, true);
        assert_eq!(ids.iter().map(|v| v.to_bits() as i32).collect::<Vec<_>>(), [7, -1, -1, 3]);
        // clip depth: 0 at the near plane, 1 at the far one and for nothing hit; in between
        // OpenGL's perspective (z_ndc = (f+n)/(f-n) - 2fn/((f-n)z)) or orthographic depth
        let (n, f) = (0.5f32, 50.0f32);
        let persp = ClipDepth { near: n, far: f, orthographic: false };
        let ortho = ClipDepth { orthographic: true, ..persp };
        for c in [persp, ortho] {
            assert_eq!((c.of(n), c.of(f), c.of(f32::INFINITY), c.of(0.1), c.of(1e6)), (0.0, 1.0, 1.0, 0.0, 1.0));
        }
        let z = 10.0f64;
        let (n, f) = (n as f64, f as f64);
        let ndc = (f + n) / (f - n) - 2.0 * f * n / ((f - n) * z);
        assert!((persp.of(z as f32) as f64 - (ndc + 1.0) / 2.0).abs() < 1e-7);
        assert!((ortho.of(z as f32) as f64 - (z - n) / (f - n)).abs() < 1e-7);
        let depth = Output { binding: Binding::hydra("depth").unwrap(), clip: persp };
        assert_eq!(depth.lay(vec![z as f32, f32::INFINITY], 1, 1, false), [1.0, persp.of(z as f32)]);
        let camera = Output { binding: Binding::hydra("cameraDepth").unwrap(), clip: persp };
        assert_eq!(camera.lay(vec![z as f32, 3.0], 1, 1, false), [3.0, z as f32]);
        assert_eq!(Binding::hydra("elementId").map(|b| b.aov), Some(Aov::ElementId));
        assert_eq!(Binding::hydra("pointId"), None);
        assert_eq!(Binding::hydra("tide:caustics").map(|b| b.aov), Some(Aov::Caustics));
        // exact ids: their bits, rows from the bottom, past where a float counts in ones
        let big = (1 << 24) + 1;
        let laid = hd.lay_ids(vec![big, -1, 0, 2, 3, big + 2], 2);
        assert_eq!(laid.iter().map(|v| v.to_bits() as i32).collect::<Vec<_>>(), [3, big + 2, 0, 2, big, -1]);
    }

    /// A buffer holds its clear value (a value per channel; ids as int32 bits) from when it is
    /// sized until a pass publishes into it, and keeps what a pass published when the clear
    /// value is set again (as each execution of a Hydra pass does).
    #[test]
    fn a_buffer_holds_its_clear_value_until_a_pass_publishes() {
        let ints = |b: &RenderBuffer| b.map().pixels.iter().map(|v| v.to_bits() as i32).collect::<Vec<_>>();
        let b = RenderBuffer::new(2, 1, 4);
        assert_eq!(b.map().pixels, [0.0; 8], "no clear value: zeros");
        b.set_clear(&[0.25, 0.5, 1.0, 0.0]);
        assert_eq!(b.map().pixels, [0.25, 0.5, 1.0, 0.0, 0.25, 0.5, 1.0, 0.0]);
        b.set_holds_ints(true);
        b.set_clear(&[-1.0]);
        assert_eq!((b.shape(), ints(&b)), ((2, 1, 1), vec![-1, -1]));
        b.resize(3, 1, 4).unwrap();
        assert_eq!((b.shape(), ints(&b)), ((3, 1, 1), vec![-1, -1, -1]));
        assert!(!b.published());
        b.publish(3, 1, 1, vec![f32::from_bits(7); 3], 1);
        b.set_clear(&[-1.0]);
        b.set_clear(&[-2.0]);
        assert!(b.published());
        assert_eq!(ints(&b), [7, 7, 7], "what a pass published stays");
        b.set_holds_ints(false);
        assert_eq!(ints(&b), [7, 7, 7]);
        b.resize(1, 1, 4).unwrap();
        assert_eq!(b.map().pixels, [-2.0]);
    }

    #[test]
    fn progress_moves_within_a_pass() {
        // target 4: the first pass (1 sample) is the first quarter, and the watcher sees it fill
        let f: EngineFactory = Arc::new(|_, _| Ok(Box::new(Steps { spp: 0, progress: Default::default() }) as Box<dyn Engine>));
        let pass = RenderPass::new(f);
        let buf = RenderBuffer::new(4, 2, 4);
        pass.start(job(4, &buf));
        let mut seen = Vec::new();
        let until = Instant::now() + Duration::from_secs(20);
        while pass.status() != PassStatus::Converged && Instant::now() < until {
            seen.push(pass.progress());
            std::thread::sleep(Duration::from_millis(2));
        }
        assert_eq!(pass.progress(), 1.0);
        assert!(seen.windows(2).all(|w| w[1] >= w[0]), "progress went back: {seen:?}");
        let within_first = seen.iter().filter(|&&f| f > 0.0 && f < 0.25).count();
        assert!(within_first >= 3, "{within_first} readings inside the first pass: {seen:?}");
    }

    #[test]
    fn a_first_pass_longer_than_the_budget_ends_at_the_budget() {
        // one sample a pixel takes a minute: the render stops at the budget of 0.3 s all the
        // same (the contract: whichever comes first), with what the pass finished published
        let f: EngineFactory = Arc::new(move |_, s| {
            Ok(Box::new(Fake { w: s.width, h: s.height, spp: 0, delay: Duration::from_secs(60), per_spp: Duration::ZERO, panic_at: None, passes: Default::default(), slow: None })
                as Box<dyn Engine>)
        });
        let pass = RenderPass::new(f);
        let buf = RenderBuffer::new(4, 2, 4);
        let mut j = job(64, &buf);
        j.settings.time_budget_s = 0.3;
        let t = Instant::now();
        pass.start(j);
        assert!(pass.wait(Duration::from_secs(30)));
        let took = t.elapsed();
        assert!(took < Duration::from_secs(10), "{took:?}");
        assert_eq!(pass.status(), PassStatus::Converged);
        assert_eq!(buf.map().samples, 0);
    }

    #[test]
    fn a_pass_running_at_the_end_of_the_budget_is_given_up() {
        // 1 ms a sample for the first 8, then 1 s each: the pass sized by the fast rate (half the
        // budget left) would run for minutes; it is given up at the budget of 0.3 s, and the
        // image keeps the samples of the passes before it
        let passes = Arc::new(Mutex::new(Vec::new()));
        let p = passes.clone();
        let f: EngineFactory = Arc::new(move |_, s| {
            Ok(Box::new(Fake { w: s.width, h: s.height, spp: 0, delay: Duration::ZERO, per_spp: Duration::from_millis(1), panic_at: None, passes: p.clone(), slow: Some((8, Duration::from_secs(1))) })
                as Box<dyn Engine>)
        });
        let pass = RenderPass::new(f);
        let buf = RenderBuffer::new(4, 2, 4);
        let mut j = job(1 << 20, &buf);
        j.settings.time_budget_s = 0.3;
        let t = Instant::now();
        pass.start(j);
        assert!(pass.wait(Duration::from_secs(20)));
        let took = t.elapsed();
        // the slow pass holds at least one 1 s sample: ending under it means it was given up
        assert!(took < Duration::from_millis(900), "{took:?}");
        let kept: u32 = passes.lock().unwrap().iter().sum();
        assert_eq!(buf.map().samples, kept);
        assert!((1..=8).contains(&kept), "{kept} samples kept");
    }
}
