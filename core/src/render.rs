//! The public rendering API: build a [`Renderer`] from a [`SceneDesc`] and settings, run
//! progressive passes, read AOVs, write EXR.

use crate::film::SampleFormat;
use crate::scene::{CameraDesc, SceneDesc};
use std::sync::atomic::AtomicBool;

/// A problem found in the input: which item (prim path), which attribute, what is wrong.
/// The offending item (or input) was dropped or replaced by its documented default.
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub struct Problem {
    pub item: String,
    pub attribute: String,
    pub message: String,
}

impl std::fmt::Display for Problem {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}: {}: {}", self.item, self.attribute, self.message)
    }
}

/// Widest and tallest image Tide renders, in pixels.
pub const MAX_IMAGE_SIDE: u32 = 65_536;

/// Which estimator renders the image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum IntegratorKind {
    #[default]
    Path,
    /// Path tracing plus guided caustic photon mapping ([`crate::caustics::engine`]).
    Caustics,
}

impl IntegratorKind {
    /// The `tide:integrator` token.
    pub fn token(self) -> &'static str {
        match self {
            IntegratorKind::Path => "path",
            IntegratorKind::Caustics => "caustics",
        }
    }
}

/// An output of the renderer.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Aov {
    /// RGBA, scene-linear in the working colour space.
    Color,
    /// Camera-space distance along the view axis (Z).
    Depth,
    /// World-space shading normal of the first hit (X, Y, Z).
    Normal,
    /// Albedo of the first surface the camera ray hits (RGB, its reflectance seen under the colour
    /// space's white; a mirror or glass gives its own, not what it shows).
    Albedo,
    /// `InstanceDesc::id` of the first hit, or -1 (one channel; the film keeps it as an
    /// integer, [`crate::film::Film::resolve_ids`], and resolves it to f32).
    PrimId,
    /// The first hit's index among the instances of its prim (`InstanceDesc::index`: a
    /// PointInstancer's or a Hydra instancer's), or -1 (one channel, kept as `PrimId`).
    InstanceId,
    /// The authored element of the first hit (`World::element_of`: a mesh's face, a curve, a
    /// point), or -1 (one channel, kept as `PrimId`).
    ElementId,
    Diffuse,
    Specular,
    Transmission,
    Volume,
    Emission,
    /// Light carried by caustic photons (the `caustics` integrator's photon lookups).
    Caustics,
    /// Debug view of the caustics guiding table stretched over the image: R the sampling
    /// probability, G the learned visibility signal (each scaled to a maximum of 1), B 1 on
    /// cells that belong to a (light, caster) pair. Zero without photons. Not part of the split.
    Guiding,
}

impl Aov {
    pub const ALL: [Aov; 14] = [
        Aov::Color,
        Aov::Depth,
        Aov::Normal,
        Aov::Albedo,
        Aov::PrimId,
        Aov::InstanceId,
        Aov::ElementId,
        Aov::Diffuse,
        Aov::Specular,
        Aov::Transmission,
        Aov::Volume,
        Aov::Emission,
        Aov::Caustics,
        Aov::Guiding,
    ];

    /// The `sourceName` of a UsdRenderVar (contract §6).
    pub fn source_name(self) -> &'static str {
        match self {
            Aov::Color => "color",
            Aov::Depth => "depth",
            Aov::Normal => "normal",
            Aov::Albedo => "albedo",
            Aov::PrimId => "primId",
            Aov::InstanceId => "instanceId",
            Aov::ElementId => "elementId",
            Aov::Diffuse => "tide:diffuse",
            Aov::Specular => "tide:specular",
            Aov::Transmission => "tide:transmission",
            Aov::Volume => "tide:volume",
            Aov::Emission => "tide:emission",
            Aov::Caustics => "tide:caustics",
            Aov::Guiding => "tide:guiding",
        }
    }

    pub fn from_source_name(name: &str) -> Option<Aov> {
        Aov::ALL.iter().copied().find(|a| a.source_name() == name)
    }

    /// Whether this AOV holds ids (whole numbers, -1 for none), kept exact by the film.
    pub fn is_id(self) -> bool {
        matches!(self, Aov::PrimId | Aov::InstanceId | Aov::ElementId)
    }

    /// Whether the film keeps this AOV among its first-hit values (the first sample's, not
    /// averaged).
    pub fn is_first_hit(self) -> bool {
        self == Aov::Depth || self.is_id()
    }

    /// Number of channels stored for this AOV.
    pub fn channels(self) -> usize {
        match self {
            Aov::Color => 4,
            Aov::Depth | Aov::PrimId | Aov::InstanceId | Aov::ElementId => 1,
            _ => 3,
        }
    }
}

/// A set of AOVs: those a render keeps accumulators for. A film holds only what its set
/// needs (colour always): an image with its colour alone takes a fifth of the memory of one
/// with every AOV, and the first-hit work for normal, albedo, depth and primId is skipped
/// where none of them is asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct AovSet(u16);

impl AovSet {
    /// Every AOV.
    pub const ALL: AovSet = AovSet((1 << Aov::ALL.len()) - 1);

    /// `aovs`, with colour (always kept: the preview and the noise estimate are made of it).
    pub fn of(aovs: impl IntoIterator<Item = Aov>) -> AovSet {
        aovs.into_iter().fold(AovSet(1 << Aov::Color as u16), |s, a| AovSet(s.0 | 1 << a as u16))
    }

    pub fn contains(self, aov: Aov) -> bool {
        self.0 & (1 << aov as u16) != 0
    }

    /// Whether the set keeps any first-hit AOV ([`Aov::is_first_hit`]: depth and the ids).
    pub fn keeps_first_hit(self) -> bool {
        const FIRST_HIT: u16 = 1 << Aov::Depth as u16 | 1 << Aov::PrimId as u16 | 1 << Aov::InstanceId as u16 | 1 << Aov::ElementId as u16;
        self.0 & FIRST_HIT != 0
    }
}

impl Default for AovSet {
    fn default() -> Self {
        AovSet::ALL
    }
}

/// Settings of a render.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Target samples per pixel.
    pub spp: u32,
    pub max_depth: u32,
    pub seed: u64,
    /// Worker threads; 0 = all cores.
    pub threads: usize,
    pub pixel_aspect_ratio: f32,
    /// How the camera's aperture is made to fit the image (UsdRenderSettings
    /// `aspectRatioConformPolicy`).
    pub aspect_conform: crate::camera::AspectConform,
    /// (xmin, ymin, xmax, ymax) in NDC, as UsdRenderSettings `dataWindowNDC`.
    pub data_window_ndc: [f32; 4],
    /// The part of the film the image covers, where a host frames the camera itself (Hydra's
    /// render pass, whose projection holds its framing and window policy): (horizontal offset,
    /// vertical offset, horizontal aperture, vertical aperture) in the camera's film units, in
    /// place of the camera's own aperture conformed by `aspect_conform`.
    pub film_window: Option<[f32; 4]>,
    pub disable_motion_blur: bool,
    pub disable_depth_of_field: bool,
    /// Seconds of rendering after which progressive passes stop; 0 = none.
    pub time_budget_s: f32,
    pub integrator: IntegratorKind,
    /// Settings of the caustics integrator.
    pub caustics: crate::caustics::engine::CausticsConfig,
    /// The pixel reconstruction filter (`tide:pixelFilter`).
    pub pixel_filter: crate::filter::PixelFilter,
    /// Adaptive sampling's noise threshold (`tide:adaptive:threshold`, 0 = off): see
    /// [`crate::adaptive`].
    pub adaptive_threshold: f32,
    /// Samples every pixel takes before adaptive sampling may stop it (0 = automatic).
    pub adaptive_min_spp: u32,
    /// The AOVs the film keeps (all by default); another reads as zeros and cannot be
    /// written to a file.
    pub aovs: AovSet,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 360,
            spp: 64,
            max_depth: 64,
            seed: 0,
            threads: 0,
            pixel_aspect_ratio: 1.0,
            aspect_conform: Default::default(),
            data_window_ndc: [0.0, 0.0, 1.0, 1.0],
            film_window: None,
            disable_motion_blur: false,
            disable_depth_of_field: false,
            time_budget_s: 0.0,
            integrator: IntegratorKind::Path,
            caustics: Default::default(),
            pixel_filter: Default::default(),
            adaptive_threshold: 0.0,
            adaptive_min_spp: 0,
            aovs: AovSet::ALL,
        }
    }
}

/// Why a render could not be set up at all (an unusable scene or settings).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RenderError(pub String);

impl std::fmt::Display for RenderError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}
impl std::error::Error for RenderError {}

/// Counters of a render so far.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderStats {
    /// Samples per pixel of the passes so far (the most any pixel has).
    pub samples_per_pixel: u32,
    /// Mean samples per pixel over the image (below `samples_per_pixel` where adaptive
    /// sampling stopped pixels).
    pub mean_samples_per_pixel: f64,
    pub render_seconds: f64,
    pub build_seconds: f64,
    pub samples_per_second: f64,
    /// Photon passes of the caustics integrator (None: no photons are traced).
    pub caustics: Option<crate::caustics::engine::CausticsStats>,
    /// Seconds spent tracing photons and building photon maps (part of `render_seconds`).
    pub photon_seconds: f64,
    /// Pixels of the data window without a sample (a first pass given up part way).
    pub unsampled_pixels: u64,
}

const TILE: u32 = 16;
/// Most samples per pixel one caustic photon pass serves (longer passes are split).
pub const PHOTON_PASS_MAX_SPP: u32 = 16;
/// Seed key of the probe's camera samples (see [`crate::caustics::engine::CausticsConfig::beams_per_query`]).
const PROBE_KEY: u64 = 0x9b0b_e5a3_71c4_d2e9;

/// The probe of a pass's photon beams (see
/// [`crate::caustics::engine::CausticsConfig::beams_per_query`]): camera samples at random
/// points of the data `window`, their results discarded, count the beams gathering meets.
/// False when `cancelled` cut it short.
fn probe_beams(world: &crate::world::World, caustics: &crate::caustics::engine::Caustics, stack: &crate::integrator::InteriorStack, seed: u64, window: [u32; 4], cancelled: &(dyn Fn() -> bool + Sync)) -> bool {
    use rayon::prelude::*;
    let [x0, y0, x1, y1] = window;
    let (wx, wy) = ((x1 - x0) as f32, (y1 - y0) as f32);
    (0..crate::caustics::engine::PROBE_SAMPLES).into_par_iter().with_min_len(64).all(|k| {
        if cancelled() {
            return false;
        }
        let mut sampler = crate::sampler::PixelSampler::new(seed ^ PROBE_KEY, k, u32::MAX, 0);
        let u = sampler.get2d();
        let raster = glam::Vec2::new(x0 as f32 + u.x * wx, y0 as f32 + u.y * wy);
        let mut lambda = crate::spectrum::color::sample_wavelengths(sampler.get1d());
        let _ = crate::integrator::trace_camera_sample(world, &mut sampler, raster, &mut lambda, stack, Some(caustics), false);
        true
    })
}

/// The guiding table (probability, visibility, pair cells) stretched over a `w × h` image.
fn guiding_image(c: &crate::caustics::engine::Caustics, w: u32, h: u32) -> Vec<f32> {
    let atlas = c.atlas();
    let (tw, th, prob) = atlas.to_image();
    let (_, _, vis) = atlas.visibility_image();
    let mut out = vec![0.0f32; (w * h * 3) as usize];
    for y in 0..h {
        for x in 0..w {
            let cx = ((x as u64 * tw as u64) / w as u64).min(tw as u64 - 1) as u32;
            let cy = ((y as u64 * th as u64) / h as u64).min(th as u64 - 1) as u32;
            let cell = (cy * tw + cx) as usize;
            let o = ((y * w + x) * 3) as usize;
            out[o] = prob[cell];
            out[o + 1] = vis[cell];
            out[o + 2] = if atlas.pair_of_cell(cell as u32).is_some() { 1.0 } else { 0.0 };
        }
    }
    out
}

/// A prepared scene plus its film.
pub struct Renderer {
    world: crate::world::World,
    film: crate::film::Film,
    settings: RenderSettings,
    problems: Vec<Problem>,
    pool: rayon::ThreadPool,
    camera_stack: crate::integrator::InteriorStack,
    stats: RenderStats,
    caustics: Option<crate::caustics::engine::Caustics>,
    /// Which pixels still sample (None: adaptive sampling is off).
    adaptive: Option<crate::adaptive::Adaptive>,
    /// The camera prim's name, which its problems carry.
    camera_name: String,
    /// How far the pass under way has got, for other threads to read.
    progress: std::sync::Arc<PassProgress>,
}

/// How far a pass has got, readable from any thread while it renders: pixel-samples finished
/// of those it takes (a tile counts when it finishes).
#[derive(Debug, Default)]
pub struct PassProgress {
    done: std::sync::atomic::AtomicU64,
    total: std::sync::atomic::AtomicU64,
}

impl PassProgress {
    /// The share of the pass under way (or of the last one run) that is done, in [0, 1].
    pub fn fraction(&self) -> f64 {
        use std::sync::atomic::Ordering;
        let total = self.total.load(Ordering::Relaxed);
        if total == 0 {
            return 0.0;
        }
        (self.done.load(Ordering::Relaxed) as f64 / total as f64).min(1.0)
    }

    /// A pass of `total` units begins (0: none is under way).
    pub fn start(&self, total: u64) {
        use std::sync::atomic::Ordering;
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
    }

    /// `n` more units of the pass are done.
    pub fn add(&self, n: u64) {
        self.done.fetch_add(n, std::sync::atomic::Ordering::Relaxed);
    }
}

/// The image's pixels (x0, y0, x1, y1; rows from the top, ends exclusive; negative or past
/// the image for overscan) inside a `dataWindowNDC` (xmin, ymin, xmax, ymax; y up): those
/// whose centres lie in the window, as UsdRenderSettings defines. None when no pixel centre
/// is inside.
fn data_window(dw: [f32; 4], w: u32, h: u32) -> Option<[i64; 4]> {
    if !(dw.iter().all(|v| v.is_finite()) && dw[2] > dw[0] && dw[3] > dw[1]) {
        return None;
    }
    // centre (i + ½)/n ∈ [lo, hi]  ⇔  i ∈ [lo·n − ½, hi·n − ½]
    let span = |lo: f32, hi: f32, n: u32| -> Option<(i64, i64)> {
        let a = (lo as f64 * n as f64 - 0.5).ceil();
        let b = (hi as f64 * n as f64 - 0.5).floor() + 1.0;
        (b > a).then_some((a as i64, b as i64))
    };
    let (x0, x1) = span(dw[0], dw[2], w)?;
    // y up: NDC y = 1 − (row + ½)/h
    let (y0, y1) = span(1.0 - dw[3], 1.0 - dw[1], h)?;
    Some([x0, y0, x1, y1])
}

/// Overscan past each side of the image, in pixels, at most the image's own size.
const MAX_OVERSCAN: f64 = 1.0;

/// How a render's film lies against its image: the pixels `pad`ded on each side (left, top,
/// right, bottom) for the overscan `dataWindowNDC` asks for, and the rendered `window` in the
/// padded film's pixels; with the problem to report, if any (an empty window renders the
/// whole image; overscan past the image's own size on a side is cut there).
pub(crate) struct Framing {
    pub pad: [u32; 4],
    pub window: [u32; 4],
    pub problem: Option<String>,
}

pub(crate) fn framing(settings: &RenderSettings) -> Framing {
    let (w, h) = (settings.width, settings.height);
    let Some([x0, y0, x1, y1]) = data_window(settings.data_window_ndc, w, h) else {
        return Framing { pad: [0; 4], window: [0, 0, w, h], problem: Some("empty or invalid window (no pixel centre inside); the whole image is rendered".into()) };
    };
    let (mw, mh) = ((w as f64 * MAX_OVERSCAN) as i64, (h as f64 * MAX_OVERSCAN) as i64);
    let cut = [(-x0).max(0) > mw, (-y0).max(0) > mh, (x1 - w as i64).max(0) > mw, (y1 - h as i64).max(0) > mh];
    let (x0, y0, x1, y1) = (x0.max(-mw), y0.max(-mh), x1.min(w as i64 + mw), y1.min(h as i64 + mh));
    let pad = [(-x0).max(0) as u32, (-y0).max(0) as u32, (x1 - w as i64).max(0) as u32, (y1 - h as i64).max(0) as u32];
    let window = [(x0 + pad[0] as i64) as u32, (y0 + pad[1] as i64) as u32, (x1 + pad[0] as i64) as u32, (y1 + pad[1] as i64) as u32];
    let problem = cut.iter().any(|&c| c).then(|| "overscan past the image's own size on a side is cut there".to_string());
    Framing { pad, window, problem }
}

impl Renderer {
    /// Validates the scene (problems are kept, see [`Renderer::problems`]) and builds the
    /// acceleration structures.
    pub fn new(scene: &SceneDesc, settings: RenderSettings) -> Result<Renderer, RenderError> {
        Renderer::with_cache(scene, settings, None)
    }

    /// [`Renderer::new`], taking the BVHs of geometry that is unchanged since the last build
    /// with the same `cache` from it (an interactive session passes the same cache to every
    /// rebuild, so an edit rebuilds only the geometry it touched).
    pub fn with_cache(scene: &SceneDesc, settings: RenderSettings, cache: Option<&crate::world::BuildCache>) -> Result<Renderer, RenderError> {
        let start = std::time::Instant::now();
        if settings.width == 0 || settings.height == 0 || settings.width > MAX_IMAGE_SIDE || settings.height > MAX_IMAGE_SIDE {
            return Err(RenderError(format!("resolution {}×{} is not renderable", settings.width, settings.height)));
        }
        if !(settings.pixel_aspect_ratio > 0.0 && settings.pixel_aspect_ratio.is_finite()) {
            return Err(RenderError(format!("pixelAspectRatio {} must be > 0", settings.pixel_aspect_ratio)));
        }
        // the film first: one too large for memory stops the render before the world is built
        let framing = framing(&settings);
        let mut film = Self::new_film(&settings, &framing).ok_or_else(|| {
            let [l, t, r, b] = framing.pad;
            let (fw, fh) = (settings.width + l + r, settings.height + t + b);
            let gb = fw as f64 * fh as f64 * crate::film::Film::bytes_per_pixel(settings.aovs) as f64 / 1e9;
            RenderError(format!("an image of {fw}×{fh} pixels (overscan included) needs {gb:.1} GB of film; not that much memory can be had"))
        })?;
        let (clean, mut problems) = crate::validate::validate_cached(scene, cache.map(|c| &c.checks));
        let world = crate::world::World::build_cached(&clean, &settings, &mut problems, cache);
        if let Some(message) = framing.problem.clone() {
            problems.push(Problem { item: "renderSettings".into(), attribute: "dataWindowNDC".into(), message });
        }
        film.scale = world.camera.exposure_scale;
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(settings.threads)
            .thread_name(|i| format!("tide-render-{i}"))
            .build()
            .map_err(|e| RenderError(format!("cannot start render threads: {e}")))?;
        let camera_stack = crate::integrator::initial_stack(&world, world.camera.position(world.camera.shutter.0), world.camera.shutter.0);
        let caustics = Self::caustics_for(&world, &settings, film.window);
        let mut stats = RenderStats { build_seconds: start.elapsed().as_secs_f64(), ..Default::default() };
        stats.caustics = caustics.as_ref().map(|c| c.stats().clone());
        let adaptive = crate::adaptive::Adaptive::new(settings.adaptive_threshold, settings.adaptive_min_spp, &film);
        let camera_name = clean.camera.name.clone();
        Ok(Renderer { world, film, settings, problems, pool, camera_stack, stats, caustics, adaptive, camera_name, progress: Default::default() })
    }

    /// The film of a render: the image and the overscan `framing` pads it with.
    fn new_film(settings: &RenderSettings, framing: &Framing) -> Option<crate::film::Film> {
        let [l, t, r, b] = framing.pad;
        let mut film = crate::film::Film::try_new(settings.width + l + r, settings.height + t + b, framing.window, settings.aovs)?;
        film.display = [l, t, settings.width, settings.height];
        Some(film)
    }

    /// The caustics integrator's state for `world`'s camera (None for the path integrator).
    fn caustics_for(world: &crate::world::World, settings: &RenderSettings, window: [u32; 4]) -> Option<crate::caustics::engine::Caustics> {
        // the camera's image: the film, overscan included
        let (w, h) = (world.camera.width, world.camera.height);
        let mut caustics = match settings.integrator {
            IntegratorKind::Caustics => crate::caustics::engine::Caustics::new(world, w, h, settings.caustics),
            IntegratorKind::Path => None,
        };
        if let Some(c) = caustics.as_mut() {
            c.set_image(settings.pixel_filter, window);
        }
        caustics
    }

    /// Points the renderer at `camera` (another camera, or the same one moved or changed),
    /// keeping everything else it built: BVHs, lights, media. The image starts over and is the
    /// one a new renderer of the scene with that camera makes, sample for sample. Returns
    /// false, changing nothing, when the settings differ from the renderer's or the camera's
    /// shutter differs from the one the scene was built over (instances and lights are placed
    /// over it): the caller then builds a new renderer. The camera's problems replace those of
    /// the camera before.
    pub fn set_camera(&mut self, camera: &CameraDesc, settings: &RenderSettings) -> bool {
        let start = std::time::Instant::now();
        if *settings != self.settings {
            return false;
        }
        let mut desc = camera.clone();
        let mut problems = Vec::new();
        crate::validate::validate_camera(&mut desc, self.world.media.len(), &mut problems);
        let s = settings;
        let cam = crate::camera::Camera::for_settings(&desc, s);
        if cam.shutter != self.world.camera.shutter {
            return false;
        }
        self.world.camera = cam;
        let old = std::mem::replace(&mut self.camera_name, desc.name);
        self.problems.retain(|p| p.item != old);
        self.problems.extend(problems);
        let world = &self.world;
        self.camera_stack = crate::integrator::initial_stack(world, world.camera.position(world.camera.shutter.0), world.camera.shutter.0);
        self.film = Self::new_film(s, &framing(s)).expect("memory for a film of the size the renderer holds");
        self.film.scale = world.camera.exposure_scale;
        self.caustics = Self::caustics_for(world, s, self.film.window);
        self.adaptive = crate::adaptive::Adaptive::new(s.adaptive_threshold, s.adaptive_min_spp, &self.film);
        self.stats = RenderStats { build_seconds: start.elapsed().as_secs_f64(), caustics: self.caustics.as_ref().map(|c| c.stats().clone()), ..Default::default() };
        true
    }

    /// Problems found in the input.
    pub fn problems(&self) -> &[Problem] {
        &self.problems
    }

    /// Acceleration-structure statistics.
    pub fn build_stats(&self) -> &crate::accel::BuildStats {
        &self.world.accel.stats
    }

    /// Renders `spp` more samples per pixel; returns false if cancelled part way. The flag is
    /// looked at before every pixel, so a pass of slow paths stops within one pixel's samples;
    /// the pixels the pass finished keep its samples (each tile goes into the film as it
    /// finishes), the others keep what they had.
    pub fn render_pass(&mut self, spp: u32, cancel: Option<&AtomicBool>) -> bool {
        self.render_pass_until(spp, cancel, None)
    }

    /// [`Renderer::render_pass`] that also gives the pass up (false) once `deadline` has
    /// passed: a time budget's last pass, where the paths turn out slower than the passes
    /// before measured, ends at the budget and not at the end of the pass, with the pixels it
    /// finished. A first pass given up leaves pixels without samples (see
    /// [`Renderer::unsampled_pixels`]).
    pub fn render_pass_until(&mut self, spp: u32, cancel: Option<&AtomicBool>, deadline: Option<std::time::Instant>) -> bool {
        self.render_pass_paused(spp, cancel, deadline, None)
    }

    /// [`Renderer::render_pass_until`] whose workers wait at their next pixel while `gate` is
    /// paused (see [`crate::pause`]): the pass goes on where it stopped, sample for sample as
    /// if never paused, and the deadline and the render's time leave the pause out.
    pub fn render_pass_paused(&mut self, spp: u32, cancel: Option<&AtomicBool>, deadline: Option<std::time::Instant>, gate: Option<&crate::pause::PauseGate>) -> bool {
        let [x0, y0, x1, y1] = self.film.window;
        self.progress.start((x1 - x0) as u64 * (y1 - y0) as u64 * spp as u64);
        self.pass(spp, cancel, deadline, gate)
    }

    /// How far the pass under way has got, for another thread to read while it renders.
    pub fn pass_progress(&self) -> std::sync::Arc<PassProgress> {
        self.progress.clone()
    }

    /// [`Renderer::render_pass_until`]'s pass (or one of the photon passes it is cut into).
    fn pass(&mut self, spp: u32, cancel: Option<&AtomicBool>, deadline: Option<std::time::Instant>, gate: Option<&crate::pause::PauseGate>) -> bool {
        use crate::film::SampleValue;
        use crate::spectrum::color;
        use rayon::prelude::*;
        use std::sync::atomic::Ordering;
        if spp == 0 || self.converged() {
            return true;
        }
        if self.caustics.is_some() && spp > PHOTON_PASS_MAX_SPP {
            // a photon map serves at most PHOTON_PASS_MAX_SPP samples per pixel: its photon
            // count, and so the photons each lookup visits, grow with the samples it serves
            let mut left = spp;
            while left > 0 {
                let k = left.min(PHOTON_PASS_MAX_SPP);
                if !self.pass(k, cancel, deadline, gate) {
                    return false;
                }
                left -= k;
            }
            return true;
        }
        let start = std::time::Instant::now();
        let paused_before = gate.map_or(std::time::Duration::ZERO, |g| g.paused_time());
        let [x0, y0, x1, y1] = self.film.window;
        let mut tiles = Vec::new();
        let mut ty = y0;
        while ty < y1 {
            let mut tx = x0;
            while tx < x1 {
                tiles.push((tx, ty, TILE.min(x1 - tx), TILE.min(y1 - ty)));
                tx += TILE;
            }
            ty += TILE;
        }
        let base = self.film.spp;
        let seed = self.settings.seed;
        let pixels = ((x1 - x0) as u64) * ((y1 - y0) as u64);
        // camera samples this pass (fewer than spp × pixels once adaptive sampling stops some)
        let camera_samples = spp as u64 * self.active_pixels() as u64;
        let past = |d: std::time::Instant| match gate {
            Some(g) => g.past(d),
            None => std::time::Instant::now() >= d,
        };
        let cancelled = || cancel.is_some_and(|c| c.load(Ordering::Relaxed)) || deadline.is_some_and(past);
        let mut photons_traced = true;
        if let Some(c) = self.caustics.as_mut() {
            let t = std::time::Instant::now();
            let world = &self.world;
            // photons for the whole image, whatever part of it `dataWindowNDC` renders: a
            // crop's pixels are then no noisier than the whole image's (photons per pass
            // following the crop's pixels left a quarter of the image with a quarter of them
            // and 3–4× the variance in its caustics)
            let image_pixels = self.film.width as u64 * self.film.height as u64;
            photons_traced = self.pool.install(|| c.begin_pass_until(world, seed, spp, image_pixels, pixels, &cancelled));
            if photons_traced && c.wants_probe() {
                c.begin_probe();
                let complete = self.pool.install(|| probe_beams(world, c, &self.camera_stack, seed, self.film.window, &cancelled));
                c.end_probe(complete);
            }
            self.stats.photon_seconds += t.elapsed().as_secs_f64();
        }
        if !photons_traced {
            // given up while its photons were traced (a Stop, a new camera or the budget's
            // end): no pixel was rendered, and the next pass traces the same photons
            self.end_pass_stats(start, paused_before, gate);
            return false;
        }
        let caustics = self.caustics.as_ref();
        let world = &self.world;
        let cs = world.cs;
        let stack = self.camera_stack;
        let pixel_filter = self.settings.pixel_filter;
        let adaptive = self.adaptive.as_ref();
        let film_layout = self.film.layout();
        // pixels without samples are left only by a first pass given up (counted at its end)
        let first_pass = base == 0 || self.stats.unsampled_pixels > 0;
        // Each tile goes into the film as it finishes (one addition a pixel a pass, so the
        // order the tiles finish in changes nothing): a pass holds only the tiles in flight.
        let progress = &*self.progress;
        let film = std::sync::Mutex::new(&mut self.film);
        let took = std::sync::atomic::AtomicBool::new(false);
        let given_up = self.pool.install(|| {
            tiles
                .par_iter()
                .filter(|&&(tx, ty, tw, th)| {
                    let mut tile = film_layout.tile(tx, ty, tw, th, first_pass);
                    let mut finished = true;
                    'pixels: for y in ty..ty + th {
                        for x in tx..tx + tw {
                            if adaptive.is_some_and(|a| !a.is_active(x, y)) {
                                continue;
                            }
                            if let Some(g) = gate {
                                g.wait(cancel);
                            }
                            if cancelled() {
                                finished = false;
                                break 'pixels;
                            }
                            for s in base..base + spp {
                                let mut sampler = crate::sampler::PixelSampler::new(seed, x, y, s);
                                let f = sampler.get2d();
                                let raster = glam::Vec2::new(x as f32 + 0.5 + pixel_filter.sample(f.x), y as f32 + 0.5 + pixel_filter.sample(f.y));
                                let mut lambda = color::sample_wavelengths(sampler.get1d());
                                let (split, mut v) = crate::integrator::trace_camera_sample(world, &mut sampler, raster, &mut lambda, &stack, caustics, first_pass && s == base);
                                let filter = world.camera.filter.map(|f| f.sample(&lambda));
                                let to_rgb = |x: crate::spectrum::SampledSpectrum| {
                                    let x = match &filter {
                                        Some(t) => x * *t,
                                        None => x,
                                    };
                                    let rgb = color::xyz_to_output(color::to_xyz(x, &lambda), cs);
                                    if rgb.iter().all(|c| c.is_finite()) {
                                        rgb
                                    } else {
                                        [0.0; 3]
                                    }
                                };
                                let mut total = [0.0f32; 3];
                                for (k, sp) in split.iter().enumerate() {
                                    v.split[k] = to_rgb(*sp);
                                    for c in 0..3 {
                                        total[c] += v.split[k][c];
                                    }
                                }
                                // colour is the sum of the split, so the split AOVs add up exactly
                                v.color = total;
                                let sv: SampleValue = v;
                                tile.add(x, y, &sv, first_pass && s == base);
                            }
                        }
                    }
                    if film.lock().unwrap_or_else(|e| e.into_inner()).merge(&tile) {
                        took.store(true, Ordering::Relaxed);
                    }
                    if finished {
                        progress.add(tw as u64 * th as u64 * spp as u64);
                    }
                    !finished
                })
                .count()
        });
        let complete = given_up == 0;
        if let Some(c) = self.caustics.as_mut() {
            if complete {
                c.end_pass(camera_samples);
                self.stats.caustics = Some(c.stats().clone());
                if self.settings.aovs.contains(Aov::Guiding) {
                    self.film.guiding = Some(guiding_image(c, self.film.width, self.film.height));
                }
            } else {
                // the guiding table learns from whole passes only
                c.end_pass_cancelled();
            }
        }
        if let Some(c) = self.caustics.as_ref() {
            // the pass's photons were all traced before its pixels: its light image is whole
            let (image, weight) = c.light_image();
            self.film.add_light(image, spp, weight);
        }
        // the next pass's samples follow this one's in every pixel, whether it reached the
        // pixel or not (a pass given up before any pixel leaves the count as it was)
        if took.into_inner() {
            self.film.spp += spp;
        }
        if let Some(a) = self.adaptive.as_mut() {
            a.update(&self.film);
        }
        self.end_pass_stats(start, paused_before, gate);
        complete
    }

    /// Counts a pass that began at `start` (the pause gate's paused time then
    /// `paused_before`) into the render's statistics: the time rendered, not paused, and the
    /// film's samples as they now stand.
    fn end_pass_stats(&mut self, start: std::time::Instant, paused_before: std::time::Duration, gate: Option<&crate::pause::PauseGate>) {
        let paused = gate.map_or(std::time::Duration::ZERO, |g| g.paused_time().saturating_sub(paused_before));
        self.stats.render_seconds += start.elapsed().saturating_sub(paused).as_secs_f64();
        self.stats.samples_per_pixel = self.film.spp;
        let [x0, y0, x1, y1] = self.film.window;
        let px = ((x1 - x0) as f64) * ((y1 - y0) as f64);
        self.stats.mean_samples_per_pixel = self.film.mean_samples();
        self.stats.samples_per_second = px * self.stats.mean_samples_per_pixel / self.stats.render_seconds.max(1e-9);
        self.stats.unsampled_pixels = self.film.unsampled_pixels();
    }

    /// Pixels of the data window without a sample: those a first pass given up part way (at a
    /// time budget's end, or cancelled) did not reach. They resolve to no camera samples:
    /// alpha 0, colour black but for what light tracing splatted there.
    pub fn unsampled_pixels(&self) -> u64 {
        self.film.unsampled_pixels()
    }

    /// Samples each pixel of the image has taken, row-major from the top (0 outside the data
    /// window; overscan left out).
    pub fn pixel_samples(&self) -> Vec<u32> {
        self.film.displayed((0..(self.film.width * self.film.height) as usize).map(|i| self.film.pixel_samples(i)).collect(), 1)
    }

    /// Whether adaptive sampling has stopped every pixel (always false when it is off).
    pub fn converged(&self) -> bool {
        self.adaptive.as_ref().is_some_and(|a| a.converged())
    }

    /// Pixels still taking samples (all of the window when adaptive sampling is off).
    pub fn active_pixels(&self) -> usize {
        match &self.adaptive {
            Some(a) => a.active_count(),
            None => {
                let [x0, y0, x1, y1] = self.film.window;
                ((x1 - x0) * (y1 - y0)) as usize
            }
        }
    }

    /// Samples per pixel accumulated so far.
    pub fn samples_per_pixel(&self) -> u32 {
        self.film.spp
    }

    /// Discards everything rendered so far.
    pub fn reset(&mut self) {
        self.film.clear();
        self.stats.render_seconds = 0.0;
        self.stats.photon_seconds = 0.0;
        self.stats.samples_per_pixel = 0;
        self.stats.unsampled_pixels = 0;
        if let Some(c) = self.caustics.as_mut() {
            c.reset();
            self.stats.caustics = Some(c.stats().clone());
        }
        self.film.guiding = None;
        self.adaptive = crate::adaptive::Adaptive::new(self.settings.adaptive_threshold, self.settings.adaptive_min_spp, &self.film);
        self.stats.mean_samples_per_pixel = 0.0;
    }

    /// Resolved pixels of an AOV over the image (overscan, written to EXR files only, left
    /// out), row-major from the top row, `aov.channels()` per pixel.
    pub fn aov_pixels(&self, aov: Aov) -> Vec<f32> {
        self.film.displayed(self.film.resolve(aov), aov.channels())
    }

    /// An id AOV's pixels exactly (as [`Renderer::aov_pixels`] lays them, one a pixel); None
    /// for an AOV that holds no ids or that the render does not keep.
    pub fn aov_ids(&self, aov: Aov) -> Option<Vec<i32>> {
        self.film.resolve_ids(aov).map(|ids| self.film.displayed(ids, 1))
    }

    /// Writes the chosen AOVs to an OpenEXR file atomically (temporary name, then rename).
    /// Each AOV is named by its source name; `header` entries are stored as string attributes.
    pub fn write_exr(&self, path: &std::path::Path, aovs: &[Aov], header: &[(String, String)]) -> std::io::Result<()> {
        let named: Vec<(String, Aov, SampleFormat)> = aovs.iter().map(|a| (a.source_name().to_string(), *a, SampleFormat::F32)).collect();
        self.write_exr_named(path, &named, header)
    }

    /// Like [`Renderer::write_exr`] with an output name and a sample format per AOV. An AOV
    /// outside the settings' set is an error (the film has nothing of it).
    pub fn write_exr_named(&self, path: &std::path::Path, aovs: &[(String, Aov, SampleFormat)], header: &[(String, String)]) -> std::io::Result<()> {
        if let Some((name, aov, _)) = aovs.iter().find(|(_, a, _)| !self.settings.aovs.contains(*a)) {
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, format!("AOV '{}' ({name}) was not rendered: the render was set up without it", aov.source_name())));
        }
        // the renderer's own figures replace any the caller passed under the same keys
        // what the render used, whatever a caller's header says (a rejected value replaced by
        // its default is recorded as the default)
        let own = ["tide:spp", "tide:seed", "tide:renderSeconds", "tide:buildSeconds", "tide:integrator", "tide:pixelFilter", "tide:pixelFilter:width", "tide:maxDepth", "tide:time:budget", "tide:unsampledPixels", "renderingColorSpace"];
        let mut h: Vec<(String, String)> = header.iter().filter(|(k, _)| !own.contains(&k.as_str()) && !k.starts_with("tide:caustics:") && !k.starts_with("tide:adaptive:")).cloned().collect();
        h.push(("tide:spp".into(), self.film.spp.to_string()));
        h.push(("tide:seed".into(), self.settings.seed.to_string()));
        h.push(("tide:renderSeconds".into(), format!("{:.6}", self.stats.render_seconds)));
        h.push(("tide:buildSeconds".into(), format!("{:.3}", self.stats.build_seconds)));
        h.push(("tide:integrator".into(), self.settings.integrator.token().into()));
        h.push(("tide:pixelFilter".into(), self.settings.pixel_filter.kind.token().into()));
        h.push(("tide:pixelFilter:width".into(), format!("{}", self.settings.pixel_filter.width)));
        h.push(("tide:maxDepth".into(), self.settings.max_depth.to_string()));
        h.push(("tide:time:budget".into(), format!("{}", self.settings.time_budget_s)));
        let unsampled = self.film.unsampled_pixels();
        if unsampled > 0 {
            h.push(("tide:unsampledPixels".into(), unsampled.to_string()));
        }
        let space = match self.world.cs {
            crate::scene::ColorSpace::LinearRec709 => "lin_rec709",
            crate::scene::ColorSpace::AcesCg => "ACEScg",
            crate::scene::ColorSpace::LinearRec2020 => "lin_rec2020",
        };
        h.push(("renderingColorSpace".into(), space.into()));
        if self.adaptive.is_some() {
            h.push(("tide:adaptive:threshold".into(), format!("{}", self.settings.adaptive_threshold)));
            h.push(("tide:adaptive:meanSpp".into(), format!("{:.2}", self.film.mean_samples())));
        }
        if let Some(c) = &self.stats.caustics {
            h.push(("tide:caustics:passes".into(), c.passes.to_string()));
            h.push(("tide:caustics:photonsEmitted".into(), c.photons_emitted.to_string()));
            h.push(("tide:caustics:photonsStored".into(), c.photons_stored.to_string()));
            h.push(("tide:caustics:peakPhotonBytes".into(), c.peak_map_bytes.to_string()));
            h.push(("tide:caustics:pairs".into(), c.pairs.to_string()));
            h.push(("tide:caustics:lightConnections".into(), c.light_connections.to_string()));
            if let Some(r) = c.disk_area_ratio {
                h.push(("tide:caustics:diskRefit".into(), format!("{r:.6}")));
            }
            if let Some(m) = c.beams_per_query {
                h.push(("tide:caustics:beamsPerQuery".into(), format!("{m:.3}")));
                h.push(("tide:caustics:beamShare".into(), format!("{:.6}", c.beam_share)));
            }
        }
        // adjustPixelAspectRatio keeps the aperture: the pixels' aspect is the one that fits it
        let pixel_aspect = match self.settings.aspect_conform {
            crate::camera::AspectConform::AdjustPixelAspectRatio => {
                let ap = self.world.camera.aperture();
                (ap.x / ap.y) * self.settings.height as f32 / self.settings.width as f32
            }
            _ => self.settings.pixel_aspect_ratio,
        };
        self.film.write_exr(path, aovs, &h, pixel_aspect)
    }

    /// The caustics state (None for the path integrator, or when no light casts caustics).
    pub fn caustics(&self) -> Option<&crate::caustics::engine::Caustics> {
        self.caustics.as_ref()
    }

    pub fn stats(&self) -> RenderStats {
        self.stats.clone()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A film the process cannot have is an error naming its size in memory, not an abort
    /// (an 8192² frame asked 16 GB and died of it), and 65536² pixels no longer wrap a u32
    /// count to an empty film.
    #[test]
    fn a_film_too_large_for_memory_is_an_error_that_says_how_large() {
        assert!(crate::film::Film::try_new(64, 64, [0, 0, 64, 64], AovSet::ALL).is_some());
        assert!(crate::film::Film::try_new(65_536, 65_536, [0, 0, 65_536, 65_536], AovSet::ALL).is_none());
        let settings = RenderSettings { width: 65_536, height: 65_536, spp: 1, ..Default::default() };
        let err = Renderer::new(&SceneDesc::default(), settings).err().expect("an error");
        assert!(err.0.contains("65536×65536") && err.0.contains("GB"), "{}", err.0);
    }

    /// A pass whose deadline has passed is given up whole: the film keeps the passes before
    /// it, pixel for pixel (a time budget's last pass that would overrun it).
    #[test]
    fn a_pass_past_its_deadline_leaves_the_film_as_it_was() {
        let settings = RenderSettings { width: 16, height: 8, spp: 4, threads: 1, ..Default::default() };
        let mut r = Renderer::new(&SceneDesc::default(), settings).expect("renderer");
        assert!(r.render_pass_until(1, None, Some(std::time::Instant::now() + std::time::Duration::from_secs(3600))));
        let before = r.aov_pixels(Aov::Color);
        assert!(!r.render_pass_until(2, None, Some(std::time::Instant::now())));
        assert_eq!(r.samples_per_pixel(), 1);
        assert_eq!(r.aov_pixels(Aov::Color), before);
        assert!(r.render_pass_until(2, None, None));
        assert_eq!(r.samples_per_pixel(), 3);
    }

    /// The first-hit mask is `Aov::is_first_hit`: every AOV alone, and colour only.
    #[test]
    fn the_first_hit_mask_is_the_first_hit_aovs() {
        for a in Aov::ALL {
            assert_eq!(AovSet::of([a]).keeps_first_hit(), a.is_first_hit(), "{a:?}");
        }
        assert!(!AovSet::of([]).keeps_first_hit());
    }

    /// A pass started paused waits at its first pixel until resumed, then renders the very
    /// samples a pass never paused does; its deadline moves on by the pause, and the render's
    /// time leaves the pause out.
    #[test]
    fn a_paused_pass_waits_then_renders_as_if_never_paused() {
        use std::time::{Duration, Instant};
        let settings = RenderSettings { width: 16, height: 8, spp: 4, threads: 2, ..Default::default() };
        let mut plain = Renderer::new(&SceneDesc::default(), settings.clone()).expect("renderer");
        assert!(plain.render_pass(2, None));
        let mut r = Renderer::new(&SceneDesc::default(), settings).expect("renderer");
        let gate = crate::pause::PauseGate::new();
        gate.pause();
        let progress = r.pass_progress();
        let pause = Duration::from_millis(300);
        let whole = std::thread::scope(|s| {
            let worker = s.spawn(|| r.render_pass_paused(2, None, Some(Instant::now() + Duration::from_millis(100)), Some(&gate)));
            std::thread::sleep(pause);
            assert_eq!(progress.fraction(), 0.0, "nothing rendered while paused");
            gate.resume();
            worker.join().unwrap()
        });
        assert!(whole, "the deadline moved on by the pause");
        assert_eq!(r.aov_pixels(Aov::Color), plain.aov_pixels(Aov::Color));
        assert!(r.stats().render_seconds < 0.1, "{}", r.stats().render_seconds);
    }

    /// dataWindowNDC takes the pixels whose centres lie in the window (UsdRenderSettings), y up.
    #[test]
    fn the_data_window_holds_the_pixels_whose_centres_it_contains() {
        assert_eq!(data_window([0.0, 0.0, 1.0, 1.0], 20, 10), Some([0, 0, 20, 10]));
        // centres at (i + ½)/20: 0.28 → 5.1 → the first is 6, 0.72 → 13.9 → the last is 13
        assert_eq!(data_window([0.28, 0.28, 0.72, 0.72], 20, 20), Some([6, 6, 14, 14]));
        // y up: the window's bottom quarter is the film's last rows; a centre on the edge is in
        assert_eq!(data_window([0.0, 0.0, 1.0, 0.25], 8, 8), Some([0, 6, 8, 8]));
        assert_eq!(data_window([0.0, 0.0, 0.0625, 1.0], 8, 8), Some([0, 0, 1, 8]));
        // between two centres: no pixel; past the image: overscan, pixels past its edges
        assert_eq!(data_window([0.0, 0.0, 0.05, 1.0], 8, 8), None);
        assert_eq!(data_window([-0.25, -0.25, 1.25, 1.25], 20, 20), Some([-5, -5, 25, 25]));
        assert_eq!(data_window([-0.1, 0.0, 1.0, 1.0], 20, 10), Some([-2, 0, 20, 10]));
        assert_eq!(data_window([0.5, 0.0, 0.5, 1.0], 8, 8), None);
        assert_eq!(data_window([f32::NAN, 0.0, 1.0, 1.0], 8, 8), None);
    }
}
