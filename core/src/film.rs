//! The film: per-pixel accumulation of every AOV, resolving to images, and atomic OpenEXR
//! output (channel names per the USD contract §6: `R G B A` for colour, `<aov>.R/G/B`,
//! `depth.Z`, `normal.X/Y/Z`, `primId.R`).

use crate::render::{Aov, AovSet};
use std::path::Path;

/// The light-path categories of the split AOVs, in `SampleValue::split` order.
pub const SPLIT_AOVS: [Aov; 6] = [Aov::Diffuse, Aov::Specular, Aov::Transmission, Aov::Volume, Aov::Emission, Aov::Caustics];
/// Number of light-path categories.
pub const N_SPLIT: usize = SPLIT_AOVS.len();

/// What one camera sample contributes to its pixel.
#[derive(Clone, Copy, Debug, Default)]
pub struct SampleValue {
    pub color: [f32; 3],
    pub alpha: f32,
    /// View-axis depth of the first hit (∞ for none).
    pub depth: f32,
    pub normal: [f32; 3],
    pub albedo: [f32; 3],
    /// Instance id of the first hit, −1 for none.
    pub prim_id: i32,
    /// The first hit's index among its prim's instances (`InstanceDesc::index`), −1 for none
    /// or a prim drawn once.
    pub instance_id: i32,
    /// The first hit's authored element (`World::element_of`), −1 for none.
    pub element_id: i32,
    /// `color` split by light path, in `SPLIT_AOVS` order; sums to `color`.
    pub split: [[f32; 3]; N_SPLIT],
}

/// What a pixel keeps of its first sample (not averageable): the depth and the ids, exact.
#[derive(Clone, Copy, Debug, PartialEq)]
struct FirstHit {
    depth: f32,
    prim: i32,
    instance: i32,
    element: i32,
}

impl FirstHit {
    fn of(s: &SampleValue) -> FirstHit {
        FirstHit { depth: s.depth, prim: s.prim_id, instance: s.instance_id, element: s.element_id }
    }

    /// The id `aov` reads (one of [`Aov::is_id`]).
    fn id(&self, aov: Aov) -> i32 {
        match aov {
            Aov::InstanceId => self.instance,
            Aov::ElementId => self.element,
            _ => self.prim,
        }
    }
}

/// The first-hit values of a pixel without a hit.
const NO_FIRST_HIT: FirstHit = FirstHit { depth: f32::INFINITY, prim: -1, instance: -1, element: -1 };

/// Floats every pixel accumulates: colour and alpha, then the colour's luminance and its
/// square (the noise estimate of adaptive sampling).
const ACC_BASE: usize = 6;
const ACC_Y: usize = 4;

/// Luminance weights of a sample's colour for the noise estimate (Rec. 709 Y; in other
/// rendering spaces it is still a fixed positive mix of the channels).
const Y_WEIGHTS: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// Where a film's accumulators lie in each pixel's run of floats: colour, alpha and the
/// luminance pair always; normal, albedo and each light-path category only where its AOV is
/// kept; depth and the ids (the first sample's, not averaged) beside them where any is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilmLayout {
    /// Floats per pixel.
    acc: usize,
    normal: Option<usize>,
    albedo: Option<usize>,
    split: [Option<usize>; N_SPLIT],
    first: bool,
    aovs: AovSet,
}

impl FilmLayout {
    pub fn new(aovs: AovSet) -> FilmLayout {
        let mut acc = ACC_BASE;
        let mut take = |aov: Aov| {
            aovs.contains(aov).then(|| {
                acc += 3;
                acc - 3
            })
        };
        let normal = take(Aov::Normal);
        let albedo = take(Aov::Albedo);
        let split = SPLIT_AOVS.map(&mut take);
        let first = aovs.keeps_first_hit();
        FilmLayout { acc, normal, albedo, split, first, aovs }
    }

    /// Bytes a film of this layout holds per pixel (accumulators, sample count, first-hit
    /// values).
    pub fn bytes_per_pixel(&self) -> usize {
        self.acc * 4 + 4 + if self.first { std::mem::size_of::<FirstHit>() } else { 0 }
    }

    /// An empty tile of this layout; `first_pass` where the film has pixels without samples
    /// (the tile then keeps the first-hit values of each pixel's first sample in it, which the
    /// film takes for those pixels).
    pub fn tile(&self, x0: u32, y0: u32, w: u32, h: u32, first_pass: bool) -> FilmTile {
        let n = w as usize * h as usize;
        let has_first = first_pass && self.first;
        FilmTile { x0, y0, w, h, sums: vec![0.0; n * self.acc], n: vec![0; n], first: if has_first { vec![NO_FIRST_HIT; n] } else { Vec::new() }, has_first, layout: *self }
    }
}

/// Accumulated samples of a rectangle of pixels.
#[derive(Clone, Debug)]
pub struct FilmTile {
    pub x0: u32,
    pub y0: u32,
    pub w: u32,
    pub h: u32,
    sums: Vec<f32>,
    /// Samples added per pixel.
    n: Vec<u32>,
    /// What each pixel keeps of its first sample.
    first: Vec<FirstHit>,
    has_first: bool,
    layout: FilmLayout,
}

impl FilmTile {
    /// A tile keeping every AOV.
    pub fn new(x0: u32, y0: u32, w: u32, h: u32, has_first: bool) -> Self {
        FilmLayout::new(AovSet::ALL).tile(x0, y0, w, h, has_first)
    }

    /// Adds one sample to pixel (x, y) (image coordinates inside the tile); `first_sample`
    /// where it is the first the tile takes for that pixel.
    #[inline]
    pub fn add(&mut self, x: u32, y: u32, s: &SampleValue, first_sample: bool) {
        let l = &self.layout;
        let i = ((y - self.y0) * self.w + (x - self.x0)) as usize;
        let a = &mut self.sums[i * l.acc..(i + 1) * l.acc];
        a[0] += s.color[0];
        a[1] += s.color[1];
        a[2] += s.color[2];
        a[3] += s.alpha;
        let y = Y_WEIGHTS[0] * s.color[0] + Y_WEIGHTS[1] * s.color[1] + Y_WEIGHTS[2] * s.color[2];
        a[ACC_Y] += y;
        a[ACC_Y + 1] += y * y;
        let mut put = |at: Option<usize>, v: &[f32; 3]| {
            if let Some(o) = at {
                for k in 0..3 {
                    a[o + k] += v[k];
                }
            }
        };
        put(l.normal, &s.normal);
        put(l.albedo, &s.albedo);
        for (c, v) in s.split.iter().enumerate() {
            put(l.split[c], v);
        }
        self.n[i] += 1;
        if first_sample && self.has_first {
            self.first[i] = FirstHit::of(s);
        }
    }
}

/// How an AOV's samples are stored in the EXR: 32-bit float, or 16-bit half (a `UsdRenderVar`
/// whose `dataType` is a half type: `half3`, `color3h`, ...).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SampleFormat {
    #[default]
    F32,
    F16,
}

/// The whole image's accumulators. They are f32, as a pass's tiles are: a pixel's film sum
/// takes one addition per pass (a tile's sum of that pass's samples), and passes double, so
/// the rounding the film adds grows with the number of passes (log₂ of the samples), not of
/// samples; what rounding there is comes from the tiles' sums within a pass either way.
#[derive(Clone, Debug)]
pub struct Film {
    pub width: u32,
    pub height: u32,
    sums: Vec<f32>,
    /// Samples each pixel has taken (fewer than `spp` where adaptive sampling stopped it).
    n: Vec<u32>,
    first: Vec<FirstHit>,
    /// Samples per pixel of the passes so far (the most any pixel has).
    pub spp: u32,
    /// Multiplier applied when resolving colour AOVs (camera exposure).
    pub scale: f32,
    /// Pixels outside this window [x0, y0, x1, y1) are not rendered (data window).
    pub window: [u32; 4],
    /// The image's own pixels within the film (x0, y0, width, height): the display window,
    /// all of the film unless `dataWindowNDC` asks for overscan, which extends the film past
    /// it on every side it names.
    pub display: [u32; 4],
    layout: FilmLayout,
    /// The `tide:guiding` debug image (3 channels per pixel), set by the caustics integrator.
    pub guiding: Option<Vec<f32>>,
    /// Light-traced radiance (RGB per pixel) summed over passes, each pass's image weighted by
    /// its samples per pixel; resolved over `light_spp` into colour and `tide:caustics`.
    light: Vec<f32>,
    /// Samples per pixel of the passes whose light-traced image is in `light` (every pass's
    /// photons are traced whole before its pixels, so a pass given up part way still adds its
    /// image, and this can exceed what a pixel's own camera samples count).
    light_spp: u32,
}

impl Film {
    /// Bytes a film keeping `aovs` holds per pixel (its accumulators, sample count and
    /// first-hit values).
    pub fn bytes_per_pixel(aovs: AovSet) -> usize {
        FilmLayout::new(aovs).bytes_per_pixel()
    }

    /// A film keeping every AOV.
    pub fn new(width: u32, height: u32, window: [u32; 4]) -> Film {
        Film::try_new(width, height, window, AovSet::ALL).expect("memory for the film")
    }

    /// A film keeping `aovs`, or None where this process cannot have the memory its
    /// accumulators ask (an allocation it would die of otherwise).
    pub fn try_new(width: u32, height: u32, window: [u32; 4], aovs: AovSet) -> Option<Film> {
        let layout = FilmLayout::new(aovs);
        let n = width as usize * height as usize;
        let sums = try_filled(n.checked_mul(layout.acc)?, 0.0f32)?;
        let count = try_filled(n, 0u32)?;
        let first = try_filled(if layout.first { n } else { 0 }, NO_FIRST_HIT)?;
        Some(Film { width, height, sums, n: count, first, spp: 0, scale: 1.0, window, display: [0, 0, width, height], layout, guiding: None, light: Vec::new(), light_spp: 0 })
    }

    /// Where the film's accumulators lie (the layout of the tiles merged into it).
    pub fn layout(&self) -> FilmLayout {
        self.layout
    }

    /// Whether the film keeps `aov` (else it resolves to zeros).
    pub fn keeps(&self, aov: Aov) -> bool {
        self.layout.aovs.contains(aov)
    }

    /// `per_pixel` (`ch` values a pixel, over the whole film) cut to the display window.
    pub fn displayed<T: Copy>(&self, per_pixel: Vec<T>, ch: usize) -> Vec<T> {
        let [dx, dy, dw, dh] = self.display.map(|v| v as usize);
        if [dx, dy, dw, dh] == [0, 0, self.width as usize, self.height as usize] {
            return per_pixel;
        }
        let w = self.width as usize;
        (dy..dy + dh).flat_map(|y| (dx..dx + dw).flat_map(move |x| (0..ch).map(move |k| (y * w + x) * ch + k))).map(|i| per_pixel[i]).collect()
    }

    /// Merges a tile of a pass: each pixel takes the samples the tile holds for it (none for
    /// a pixel the pass did not reach), and a pixel taking its first samples takes the tile's
    /// first-hit values. Returns whether the tile held any samples.
    pub fn merge(&mut self, t: &FilmTile) -> bool {
        assert_eq!(t.layout, self.layout, "a tile merged into a film of another layout");
        let acc = self.layout.acc;
        let mut took = false;
        for y in 0..t.h {
            for x in 0..t.w {
                let src = (y * t.w + x) as usize;
                let dst = ((t.y0 + y) * self.width + t.x0 + x) as usize;
                if t.n[src] == 0 {
                    continue;
                }
                for k in 0..acc {
                    self.sums[dst * acc + k] += t.sums[src * acc + k];
                }
                if t.has_first && self.n[dst] == 0 {
                    self.first[dst] = t.first[src];
                }
                self.n[dst] += t.n[src];
                took = true;
            }
        }
        took
    }

    /// Pixels of the data window without a sample (a first pass given up part way leaves some).
    pub fn unsampled_pixels(&self) -> u64 {
        let [x0, y0, x1, y1] = self.window;
        (y0..y1).map(|y| (x0..x1).filter(|&x| self.n[(y * self.width + x) as usize] == 0).count() as u64).sum()
    }

    pub fn clear(&mut self) {
        self.sums.iter_mut().for_each(|v| *v = 0.0);
        self.first.iter_mut().for_each(|v| *v = NO_FIRST_HIT);
        self.n.iter_mut().for_each(|v| *v = 0);
        self.light.clear();
        self.light_spp = 0;
        self.spp = 0;
    }

    /// Adds the light-traced image (RGB per pixel, the whole image) of a pass of `spp` samples
    /// per pixel whose photons weigh `weight` each.
    pub fn add_light(&mut self, image: &[f32], spp: u32, weight: f32) {
        self.light_spp += spp;
        let w = spp as f64 * weight as f64;
        let n = (self.width * self.height) as usize * 3;
        if image.len() != n || w == 0.0 {
            return;
        }
        if self.light.is_empty() {
            self.light.resize(n, 0.0);
        }
        for (a, &v) in self.light.iter_mut().zip(image) {
            *a += (v as f64 * w) as f32;
        }
    }

    /// Pixel `i`'s (Σ Y, Σ Y², samples) of its colour samples' luminance (unexposed).
    pub fn luminance_sums(&self, i: usize) -> (f64, f64, u32) {
        let acc = self.layout.acc;
        (self.sums[i * acc + ACC_Y] as f64, self.sums[i * acc + ACC_Y + 1] as f64, self.n[i])
    }

    /// Samples pixel `i` has taken.
    pub fn pixel_samples(&self, i: usize) -> u32 {
        self.n[i]
    }

    /// Mean samples per pixel over the window.
    pub fn mean_samples(&self) -> f64 {
        let [x0, y0, x1, y1] = self.window;
        let count = ((x1 - x0) as u64 * (y1 - y0) as u64).max(1);
        let mut total = 0u64;
        for y in y0..y1 {
            for x in x0..x1 {
                total += self.n[(y * self.width + x) as usize] as u64;
            }
        }
        total as f64 / count as f64
    }

    /// Light-traced radiance of pixel `i`, channel `k` (mean over the passes).
    #[inline]
    fn light_at(&self, i: usize, k: usize) -> f64 {
        if self.light.is_empty() || self.light_spp == 0 {
            0.0
        } else {
            self.light[i * 3 + k] as f64 / self.light_spp as f64
        }
    }

    /// Resolved pixels of an AOV, row-major from the top, `aov.channels()` per pixel.
    pub fn resolve(&self, aov: Aov) -> Vec<f32> {
        let n = (self.width * self.height) as usize;
        let ch = aov.channels();
        let mut out = vec![0.0f32; n * ch];
        if self.resolvable(aov) {
            for (i, o) in out.chunks_exact_mut(ch).enumerate() {
                self.resolve_pixel(aov, i, o);
            }
        }
        out
    }

    /// An id AOV ([`Aov::is_id`]) exactly, a pixel each (-1 where nothing was hit); None for
    /// another AOV or one the film does not keep. ([`Film::resolve`] gives them as f32, exact
    /// up to 2^24.)
    pub fn resolve_ids(&self, aov: Aov) -> Option<Vec<i32>> {
        (aov.is_id() && self.keeps(aov)).then(|| self.first.iter().map(|f| f.id(aov)).collect())
    }

    /// Whether `aov` has anything to resolve (else it reads as zeros).
    fn resolvable(&self, aov: Aov) -> bool {
        match aov {
            Aov::Guiding => self.guiding.as_ref().is_some_and(|g| g.len() == (self.width * self.height) as usize * 3),
            _ => self.keeps(aov),
        }
    }

    /// Pixel `i`'s resolved value of `aov` into `o` (`aov.channels()` long); `aov` resolvable.
    fn resolve_pixel(&self, aov: Aov, i: usize, o: &mut [f32]) {
        let s = self.scale as f64;
        let l = &self.layout;
        let inv = if self.n[i] > 0 { 1.0 / self.n[i] as f64 } else { 0.0 };
        let row = &self.sums[i * l.acc..(i + 1) * l.acc];
        let a = |k: usize| row[k] as f64;
        match aov {
            Aov::Color => {
                for k in 0..3 {
                    o[k] = ((a(k) * inv + self.light_at(i, k)) * s) as f32;
                }
                o[3] = (a(3) * inv) as f32;
            }
            Aov::Depth => o[0] = self.first[i].depth,
            Aov::PrimId | Aov::InstanceId | Aov::ElementId => o[0] = self.first[i].id(aov) as f32,
            Aov::Guiding => o.copy_from_slice(&self.guiding.as_ref().expect("resolvable")[i * 3..i * 3 + 3]),
            Aov::Normal => {
                let at = l.normal.unwrap_or(0);
                let v = glam::DVec3::new(a(at), a(at + 1), a(at + 2));
                let v = if v.length() > 0.0 { v.normalize() } else { v };
                o.copy_from_slice(&[v.x as f32, v.y as f32, v.z as f32]);
            }
            Aov::Albedo => {
                let at = l.albedo.unwrap_or(0);
                for k in 0..3 {
                    o[k] = (a(at + k) * inv) as f32;
                }
            }
            _ => {
                let c = SPLIT_AOVS.iter().position(|&x| x == aov).unwrap_or(0);
                let at = l.split[c].unwrap_or(0);
                let light = aov == Aov::Caustics;
                for k in 0..3 {
                    let lt = if light { self.light_at(i, k) } else { 0.0 };
                    o[k] = ((a(at + k) * inv + lt) * s) as f32;
                }
            }
        }
    }

    /// EXR channel names of an AOV.
    pub fn channel_names(aov: Aov) -> Vec<String> {
        let suffix: &[&str] = match aov {
            Aov::Color => return vec!["R".into(), "G".into(), "B".into(), "A".into()],
            Aov::Depth => &["Z"],
            Aov::Normal => &["X", "Y", "Z"],
            Aov::PrimId | Aov::InstanceId | Aov::ElementId => &["R"],
            _ => &["R", "G", "B"],
        };
        suffix.iter().map(|s| format!("{}.{}", aov.source_name(), s)).collect()
    }

    /// Writes AOVs to `path` atomically: a temporary file beside it, then a rename.
    /// `aovs` pairs an output name (the channel prefix) with the AOV it holds.
    /// `pixel_aspect` goes to OpenEXR's own attribute (what viewers display by). The file's data
    /// window is the film's window (the rendered part, as `dataWindowNDC` asks), placed against
    /// a display window of the image (overscan lies outside it, at negative coordinates on the
    /// left and top).
    pub fn write_exr(&self, path: &Path, aovs: &[(String, Aov, SampleFormat)], header: &[(String, String)], pixel_aspect: f32) -> std::io::Result<()> {
        use exr::prelude::*;
        let (w, h) = (self.width as usize, self.height as usize);
        let [x0, y0, x1, y1] = self.window.map(|v| v as usize);
        let (x1, y1) = (x1.min(w), y1.min(h));
        let (x0, y0) = (x0.min(x1.saturating_sub(1)), y0.min(y1.saturating_sub(1)));
        let (dw, dh) = (x1 - x0, y1 - y0);
        let mut channels: Vec<AnyChannel<FilmChannel>> = Vec::new();
        for (name, aov, format) in aovs {
            let names: Vec<String> = if *aov == Aov::Color && name == "color" {
                Self::channel_names(*aov)
            } else {
                Self::channel_names(*aov)
                    .into_iter()
                    .map(|n| match n.split_once('.') {
                        Some((_, s)) => format!("{name}.{s}"),
                        None => format!("{name}.{n}"),
                    })
                    .collect()
            };
            for (k, cname) in names.iter().enumerate() {
                // resolved line by line as the file's blocks are compressed: no channel is
                // held whole
                channels.push(AnyChannel::new(cname.as_str(), FilmChannel { film: self, aov: *aov, k, origin: [x0, y0], format: *format }));
            }
        }
        if channels.is_empty() {
            return Err(std::io::Error::new(std::io::ErrorKind::InvalidInput, "no AOV to write"));
        }
        let mut attrs = LayerAttributes::default();
        for (k, v) in header {
            attrs.other.insert(Text::from(k.as_str()), AttributeValue::Text(Text::from(v.as_str())));
        }
        let [dx, dy, dw_w, dw_h] = self.display;
        attrs.layer_position = Vec2(x0 as i32 - dx as i32, y0 as i32 - dy as i32);
        let layer = Layer::new((dw, dh), attrs, Encoding::SMALL_LOSSLESS, AnyChannels::sort(channels.into()));
        let mut image = Image::from_layer(layer);
        image.attributes.pixel_aspect = pixel_aspect;
        image.attributes.display_window = IntegerBounds::new((0, 0), (dw_w as usize, dw_h as usize));
        let dir = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let fname = path.file_name().map(|f| f.to_string_lossy().into_owned()).unwrap_or_else(|| "out.exr".into());
        let tmp = dir.join(format!(".{fname}.tmp{}.exr", std::process::id()));
        let res = image.write().to_file(&tmp).map_err(|e| std::io::Error::other(e.to_string()));
        if let Err(e) = res {
            let _ = std::fs::remove_file(&tmp);
            return Err(e);
        }
        std::fs::rename(&tmp, path).inspect_err(|_| {
            let _ = std::fs::remove_file(&tmp);
        })
    }
}

/// Channel `k` of an AOV as a file's samples, resolved from the film's accumulators line by
/// line as the writer asks for them (`origin`: the film pixel of the file's data window's
/// corner).
#[derive(Clone, Copy)]
struct FilmChannel<'a> {
    film: &'a Film,
    aov: Aov,
    k: usize,
    origin: [usize; 2],
    format: SampleFormat,
}

impl<'s, 'a: 's> exr::image::write::samples::WritableSamples<'s> for FilmChannel<'a> {
    type Writer = FilmChannel<'a>;

    fn sample_type(&self) -> exr::meta::attribute::SampleType {
        match self.format {
            SampleFormat::F32 => exr::meta::attribute::SampleType::F32,
            SampleFormat::F16 => exr::meta::attribute::SampleType::F16,
        }
    }

    fn infer_level_modes(&self) -> (exr::meta::attribute::LevelMode, exr::math::RoundingMode) {
        (exr::meta::attribute::LevelMode::Singular, exr::math::RoundingMode::Down)
    }

    fn create_samples_writer(&'s self, _header: &exr::meta::header::Header) -> FilmChannel<'a> {
        *self
    }
}

impl exr::image::write::samples::SamplesWriter for FilmChannel<'_> {
    fn extract_line(&self, line: exr::block::lines::LineRefMut<'_>) {
        let at = line.location.position;
        let w = self.film.width as usize;
        let first = (self.origin[1] + at.y()) * w + self.origin[0] + at.x();
        let ok = self.film.resolvable(self.aov);
        let value = |i: usize| {
            let mut o = [0.0f32; 4];
            if ok {
                self.film.resolve_pixel(self.aov, first + i, &mut o[..self.aov.channels()]);
            }
            o[self.k]
        };
        let written = match self.format {
            SampleFormat::F32 => line.write_samples(value),
            SampleFormat::F16 => line.write_samples(|i| exr::prelude::f16::from_f32(value(i))),
        };
        written.expect("a line's bytes are sized for its samples");
    }
}


/// `len` copies of `v`, or None where the allocation is refused (where `vec!` aborts): for
/// image-sized buffers, whose size comes from the scene.
pub fn try_filled<T: Clone>(len: usize, v: T) -> Option<Vec<T>> {
    let mut out = Vec::new();
    out.try_reserve_exact(len).ok()?;
    out.resize(len, v);
    Some(out)
}

/// `len` zeros from the allocator's zeroed memory (as `vec![0.0; len]`, whose pages the system
/// supplies only when written: a buffer never read costs nothing), or None where the
/// allocation is refused.
pub fn try_zeroed_floats(len: usize) -> Option<Vec<f32>> {
    if len == 0 {
        return Some(Vec::new());
    }
    let layout = std::alloc::Layout::array::<f32>(len).ok()?;
    // SAFETY: the layout is non-empty; a non-null pointer from `alloc_zeroed` with it is a
    // valid, zero-initialised (0.0f32 is all-zero bits) allocation of `len` f32s that the Vec
    // owns and frees with the same layout.
    unsafe {
        let ptr = std::alloc::alloc_zeroed(layout) as *mut f32;
        if ptr.is_null() {
            return None;
        }
        Some(Vec::from_raw_parts(ptr, len, len))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The light-traced image is the mean over the passes that traced it, each weighted by its
    /// samples per pixel, whatever the camera's samples in a pixel: a pass given up before a
    /// pixel still traced all its photons.
    #[test]
    fn the_light_traced_image_is_the_mean_of_its_own_passes() {
        let mut f = Film::new(2, 1, [0, 0, 2, 1]);
        let mut t = FilmTile::new(0, 0, 2, 1, true);
        t.add(0, 0, &SampleValue { color: [1.0, 2.0, 3.0], alpha: 1.0, ..Default::default() }, true);
        f.merge(&t);
        f.spp = 1;
        // passes of 2 and 6 samples, their photons weighing 0.5 and 1
        f.add_light(&[4.0, 8.0, 12.0, 16.0, 0.0, 0.0], 2, 0.5);
        f.add_light(&[8.0, 0.0, 4.0, 0.0, 0.0, 8.0], 6, 1.0);
        let want = |img1: [f32; 3], img2: [f32; 3], cam: [f32; 3]| -> Vec<f32> { (0..3).map(|k| cam[k] + (img1[k] * 0.5 * 2.0 + img2[k] * 6.0) / 8.0).collect() };
        let c = f.resolve(Aov::Color);
        assert_eq!(&c[0..3], &want([4.0, 8.0, 12.0], [8.0, 0.0, 4.0], [1.0, 2.0, 3.0])[..]);
        assert_eq!(c[3], 1.0);
        // the second pixel has no camera sample: light alone, and no alpha
        assert_eq!(&c[4..7], &want([16.0, 0.0, 0.0], [0.0, 0.0, 8.0], [0.0; 3])[..]);
        assert_eq!(c[7], 0.0);
        assert_eq!(f.unsampled_pixels(), 1);
    }

    /// A film rendering only a window writes that window as the file's data window, inside a
    /// display window of the whole image, with the window's pixels in place.
    #[test]
    fn a_windowed_film_writes_its_window_as_the_data_window() {
        let mut f = Film::new(4, 3, [1, 1, 3, 3]);
        let mut t = FilmTile::new(0, 0, 4, 3, true);
        for (x, y) in [(1, 1), (2, 1), (1, 2), (2, 2)] {
            let v = (10 * x + y) as f32;
            t.add(x, y, &SampleValue { color: [v, v, v], alpha: 1.0, depth: v, ..Default::default() }, true);
        }
        f.merge(&t);
        f.spp = 1;
        let dir = std::env::temp_dir().join(format!("tide-film-window-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("w.exr");
        f.write_exr(&p, &[("color".to_string(), Aov::Color, SampleFormat::F32), ("depth".to_string(), Aov::Depth, SampleFormat::F32)], &[], 1.0).unwrap();
        let img = exr::prelude::read_all_flat_layers_from_file(&p).unwrap();
        let layer = &img.layer_data[0];
        assert_eq!((layer.attributes.layer_position.0, layer.attributes.layer_position.1), (1, 1));
        assert_eq!((layer.size.0, layer.size.1), (2, 2));
        assert_eq!((img.attributes.display_window.size.0, img.attributes.display_window.size.1), (4, 3));
        let red = layer.channel_data.list.iter().find(|c| c.name.to_string() == "R").unwrap();
        let exr::prelude::FlatSamples::F32(r) = &red.sample_data else { panic!("not f32") };
        // rows from the window's top: (1, 1), (2, 1), then (1, 2), (2, 2)
        assert_eq!(r, &vec![11.0, 21.0, 12.0, 22.0]);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// A pixel's film sum rounds once per pass: over the doubling passes of a render (1, 2,
    /// 4, ... 2048 samples, 12 passes) of values spread over eight orders of magnitude, the
    /// film's mean is the exact (f64) mean of its passes' tile sums within 12 half-ulps of
    /// the total; a film that rounded per sample would not be held to this.
    #[test]
    fn the_film_rounds_once_a_pass() {
        let mut f = Film::new(1, 1, [0, 0, 1, 1]);
        let mut exact = 0.0f64;
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut n = 0u64;
        let mut passes = 0;
        let mut spp = 1u32;
        while n + spp as u64 <= 4095 {
            let mut t = FilmTile::new(0, 0, 1, 1, n == 0);
            for _ in 0..spp {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                let u = (state >> 11) as f64 / (1u64 << 53) as f64;
                let v = 10f64.powf(8.0 * u - 4.0) as f32;
                t.add(0, 0, &SampleValue { color: [v, v, v], alpha: 1.0, ..Default::default() }, n == 0);
            }
            // what the tile holds is the pass's sum, rounded as a tile rounds it
            exact += t.sums[0] as f64;
            f.merge(&t);
            n += spp as u64;
            passes += 1;
            spp *= 2;
        }
        f.spp = n as u32;
        assert_eq!(passes, 12);
        let got = f.resolve(Aov::Color)[0] as f64 * n as f64;
        let bound = passes as f64 * exact * f32::EPSILON as f64 / 2.0;
        assert!((got - exact).abs() <= bound + exact * f32::EPSILON as f64, "{got} vs {exact} (bound {bound})");
    }

    /// Ids are kept exactly whatever their size (a float would round 2^24 + 1), the first
    /// sample's and not averaged; a film without them resolves none.
    #[test]
    fn ids_are_kept_exactly_from_each_pixels_first_sample() {
        let mut f = Film::try_new(2, 1, [0, 0, 2, 1], AovSet::of([Aov::PrimId, Aov::InstanceId, Aov::ElementId])).unwrap();
        let mut t = f.layout().tile(0, 0, 2, 1, true);
        let big = (1 << 24) + 1;
        let s = SampleValue { depth: 2.0, prim_id: big, instance_id: big + 2, element_id: 3, ..Default::default() };
        t.add(0, 0, &s, true);
        t.add(0, 0, &SampleValue { prim_id: 1, instance_id: 1, element_id: 1, ..s }, false);
        f.merge(&t);
        assert_eq!(f.resolve_ids(Aov::PrimId), Some(vec![big, -1]));
        assert_eq!(f.resolve_ids(Aov::InstanceId), Some(vec![big + 2, -1]));
        assert_eq!(f.resolve_ids(Aov::ElementId), Some(vec![3, -1]));
        assert_eq!(f.resolve(Aov::ElementId), vec![3.0, -1.0]);
        assert_eq!(f.resolve_ids(Aov::Depth), None);
        let colour_only = Film::try_new(2, 1, [0, 0, 2, 1], AovSet::of([])).unwrap();
        assert_eq!(colour_only.resolve_ids(Aov::PrimId), None);
        assert_eq!(Film::bytes_per_pixel(AovSet::of([Aov::ElementId])), Film::bytes_per_pixel(AovSet::of([Aov::Depth])));
    }

    #[test]
    fn accumulates_resolves_and_writes_named_channels() {
        let mut f = Film::new(4, 3, [0, 0, 4, 3]);
        let mut t = FilmTile::new(0, 0, 4, 3, true);
        let s = SampleValue { color: [1.0, 2.0, 3.0], alpha: 1.0, depth: 5.0, prim_id: 7, split: [[1.0, 2.0, 3.0], [0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3], [0.0; 3]], ..Default::default() };
        t.add(1, 2, &s, true);
        t.add(1, 2, &SampleValue { depth: 9.0, ..s }, false);
        f.merge(&t);
        f.spp = 2;
        let c = f.resolve(Aov::Color);
        let i = (2 * 4 + 1) * 4;
        assert_eq!(&c[i..i + 4], &[1.0, 2.0, 3.0, 1.0]);
        assert_eq!(f.resolve(Aov::Depth)[9], 5.0);
        assert_eq!(f.resolve(Aov::PrimId)[9], 7.0);
        assert_eq!(f.resolve(Aov::Diffuse)[27..30], [1.0, 2.0, 3.0]);
        let dir = std::env::temp_dir().join(format!("tide-film-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let p = dir.join("t.exr");
        let aovs: Vec<(String, Aov, SampleFormat)> = [Aov::Color, Aov::Depth, Aov::Normal, Aov::Diffuse].iter().map(|a| (a.source_name().to_string(), *a, if *a == Aov::Depth { SampleFormat::F16 } else { SampleFormat::F32 })).collect();
        f.write_exr(&p, &aovs, &[("tide:spp".into(), "2".into())], 2.0).unwrap();
        let img = exr::prelude::read_all_flat_layers_from_file(&p).unwrap();
        let names: Vec<String> = img.layer_data[0].channel_data.list.iter().map(|c| c.name.to_string()).collect();
        for n in ["R", "G", "B", "A", "depth.Z", "normal.X", "normal.Y", "normal.Z", "tide:diffuse.R", "tide:diffuse.B"] {
            assert!(names.contains(&n.to_string()), "{n} missing from {names:?}");
        }
        assert!(img.layer_data[0].attributes.other.contains_key(&exr::prelude::Text::from("tide:spp")));
        assert_eq!(img.attributes.pixel_aspect, 2.0);
        // the half AOV is stored as halves, with its value; the others as floats
        for c in &img.layer_data[0].channel_data.list {
            let half = matches!(c.sample_data, exr::prelude::FlatSamples::F16(_));
            assert_eq!(half, c.name.to_string() == "depth.Z", "{}", c.name);
            if let exr::prelude::FlatSamples::F16(v) = &c.sample_data {
                assert_eq!(v[9].to_f32(), 5.0);
            }
        }
        // nothing but the final file is left in the directory
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 1);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
