//! The light–object guiding atlas (Conty & Kulla 2019, §4–5): one 2D table that chooses both a
//! (light, caster) pair and where, within that pair's emission domain, a photon starts.
//!
//! # Layout
//! Every (light, caster) pair gets an importance `I = Ω_cam · S · E` ([`Atlas::new`]):
//! - `Ω_cam`: solid angle of the caster's bounding sphere from the camera, clamped to the camera's
//!   field ([`CameraHint`]); without a camera, the sphere's cross-section `πR²`;
//! - `S = 1 / (1 + 1/P²)` with `P = 1/Ω_light` the average pdf of sampling the light from the
//!   caster's centre (`Ω_light` the light's bounding-sphere or sun-cone solid angle): 1 for delta
//!   lights, small for lights that look large from the caster (photons help less there);
//! - `E`: irradiance the light delivers at the caster's centre (`Φ / 4πd²`, or the sun's), times
//!   the light's intensity towards the caster relative to a light emitting alike all round
//!   ([`crate::light::tree::EmissionBounds::toward`]: 0 for a spot aimed away from it, or a rect
//!   facing away, from every point of both; more along a narrow spot's axis).
//!
//! Each pair receives a square of side ∝ √I, packed greedily (largest first, into the free
//! rectangle nearest the origin) into the `width × height` table; the squares shrink together
//! until all fit. Cells outside every square have probability 0. Pairs of zero importance get no
//! square.
//!
//! # Mapping a cell to an emission
//! A sample gives the pair and local coordinates `β' ∈ [0,1)²` in its square (column, row).
//! - Lights with a position ([`AtlasLight::Local`]): from the light point `x` (sampled by the
//!   caller on the light, or the point light's position) a direction in the cone towards the
//!   caster's bounding sphere, `cosθ = 1 − β'₀(1 − cosθ_max)`, `φ = 2πβ'₁` (uniform in solid
//!   angle); pdf per steradian `p_cell · side² / Ω_cone`.
//! - Distant lights: a point on the disk of the caster's radius perpendicular to the light,
//!   `r = R√β'₀`, `φ = 2πβ'₁` (uniform in area; the pair's refit disk once it has one, see
//!   below), moved towards the light by `R`; the direction is
//!   the light's (the caller may jitter it within a sun cone with its own numbers); pdf per m²
//!   `p_cell · side² / (πR²)`. Move the origin further back along `-dir` freely (the pdf holds).
//!
//! Cones of pairs of one light may overlap: the caller keeps a photon only when its first hit is
//! the pair's caster (rejection), and [`Atlas::pdf_direction`] / [`Atlas::pdf_position`] give the
//! density before rejection, summed over the light's pairs.
//!
//! # Learning
//! During a pass, camera lookups add the throughput of the photons they use to a
//! [`VisibilityBuffer`], split into surface and volume signals, in 40.24 fixed point with atomic
//! integer adds: the sums, hence the learned table, are bit-identical for any thread count and
//! order. [`Atlas::end_pass`] turns them into running means `Vⁿ = (T_{n−1}Vⁿ⁻¹ + Sₙ)/Tₙ`
//! (`Tₙ` camera samples so far), normalises each signal by its maximum, takes the per-cell
//! maximum of the two, and sets the next table to `normalize(t·U + (1−t)·K·V)` with `U` uniform
//! over the pairs' cells and `t = max(1/n, defensive)` for pass `n` (the defensive floor keeps
//! every used cell reachable). The first pass samples `U` and only trains:
//! [`Atlas::photon_weight`] is 0 then, `(N₁+N₂)/N₂` on the second pass to restore the missing
//! energy, and 1 afterwards.
//!
//! Sampling picks a row from the marginal, then a column (piecewise-constant 2D), in O(log n).
//!
//! # Refitting a distant light's disk (seed 000 §5.3, §5.5.2)
//! A large caster (an ocean, a pool seen in part) gets a disk far larger than the area whose
//! photons the camera uses, and the pair's cells are then too coarse to learn where that is.
//! After passes 2, 4, 8, 16, … ([`refit_due`]) every distant-light pair that has learned over at
//! least two passes since its last refit gets a new disk (a [`PairDisk`]: centre offset within
//! the plane of the old disk, radius): the smallest disk that holds its strongest cells holding
//! [`REFIT_SIGNAL_SHARE`] (95%) of its learned signal plus the cells around each of them (a
//! margin of one cell of the current disk, along both polar axes), grown by the sagitta of the
//! sampled cell arcs. It is taken only when its area is at most [`REFIT_MAX_AREA_RATIO`] (½) of
//! the current disk's. The pair's square then maps onto the new disk (same polar map, finer
//! cells); its visibility restarts (running means over its own samples since the refit) and its
//! table mass is spread uniformly over its square (the pair's probability is unchanged; the
//! defensive floor applies from the next pass as before). Refits only shrink a disk, and depend
//! only on the fixed-point sums, so they are identical for any thread count.
//!
//! Every start of the original disk stays possible: a refit pair's photon starts, with
//! probability [`REFIT_DEFENSIVE`] (δ = 0.1), uniformly on the original disk, otherwise from the
//! table on the refit disk ([`Atlas::emit_mixture`]); its pdf, and [`Atlas::pdf_position`], are
//! the mixture's `δ·P_pair/(πR₀²)·[x ∈ D₀] + (1−δ)·p_table(x)/(πR₁²)·[x ∈ D₁]`. A start from the
//! uniform part takes the refit cell it falls in, or the id `cell_count() + pair` outside the
//! table when it misses the refit disk (it names the pair for the MIS weights and records no
//! visibility). A refit discards no photons and changes no pass's weight, so the first pass's
//! `(N₁+N₂)/N₂` compensation is unchanged; the approximate-MIS `P_l` is the light's direction pdf
//! and does not depend on the disk.

// `!(x < y)` is used on purpose: it rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::f32::consts::PI;
use std::fmt;
use std::sync::atomic::{AtomicU64, Ordering};

use glam::Vec3;

use crate::light::distrib::Distribution1D;
use crate::light::tree::EmissionBounds;
use crate::light::{Light, LightSampleContext};
use crate::math::{spherical_direction, Frame};
use crate::spectrum::SampledWavelengths;

/// Fractional bits of the visibility signal's fixed-point sums.
pub const VISIBILITY_FRAC_BITS: u32 = 24;
/// Largest value (in units of the buffer's `unit`) one record may add; larger ones are clamped,
/// so 2^24 records at the clamp still fit in 64 bits.
pub const VISIBILITY_MAX_RECORD: f32 = 65536.0;
/// Largest table (cells).
pub const MAX_TABLE_CELLS: u64 = 1 << 24;
const NO_PAIR: u32 = u32::MAX;
/// Probability that a photon of a refit pair starts uniformly on the pair's original disk (the
/// defensive half of the one-sample mixture that keeps every start of the original disk possible).
pub const REFIT_DEFENSIVE: f32 = 0.1;
/// A disk is refit only when the new disk's area is at most this share of the current one: the
/// pair's cells then cover at least twice as finely what they cover (and the table restarts).
pub const REFIT_MAX_AREA_RATIO: f32 = 0.5;
/// Share of a pair's learned signal that its refit disk must hold: the strongest cells holding
/// it are kept (camera paths that reach far receivers after a diffuse bounce or a total internal
/// reflection leave a faint signal over much of a large caster; photons for them still start
/// from the defensive part of the mixture).
pub const REFIT_SIGNAL_SHARE: f64 = 0.95;
/// Points per cell edge on the outer arc of the cells a refit disk must hold.
const REFIT_ARC_POINTS: u32 = 4;

/// Whether the passes completed so far call for a refit check: after passes 2, 4, 8, 16, …
/// (a pair is checked only when it has learned over at least two passes since its last refit).
pub fn refit_due(passes: u32) -> bool {
    passes >= 2 && passes.is_power_of_two()
}

/// A refit emission disk of a distant-light pair: in the plane through the caster's centre
/// perpendicular to the light, its centre's offset from the caster's centre (coordinates along
/// the `s` and `t` axes of `Frame::from_normal(-to_light)`) and its radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PairDisk {
    pub offset: [f32; 2],
    pub radius: f32,
}

/// What is wrong with the atlas's input.
#[derive(Clone, Debug, PartialEq)]
pub enum AtlasError {
    NoLights,
    NoCasters,
    /// A light's data is invalid; `what` names the field.
    Light { index: usize, what: &'static str },
    /// A caster's bounding sphere is invalid.
    Caster { index: usize, what: &'static str },
    /// A requested pair names a light or caster that does not exist.
    Pair { index: usize },
    /// Table width or height is 0, or the table exceeds [`MAX_TABLE_CELLS`].
    TableSize { width: u32, height: u32 },
    /// `defensive` is not in [0, 1].
    Defensive(f32),
    /// The camera hint is not finite or its solid angle not positive.
    Camera,
    /// Every pair has zero importance (no power, or nothing to aim at).
    NoImportance,
    /// More pairs than the table has cells.
    TooManyPairs { pairs: usize, cells: u64 },
    /// The visibility buffer was made for another table.
    BufferMismatch { expected: usize, got: usize },
    /// A pass reported zero camera samples.
    NoSamples,
    /// The visibility unit is not a positive finite number.
    Unit(f32),
}

impl fmt::Display for AtlasError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            AtlasError::NoLights => write!(f, "caustic atlas: no caustic lights"),
            AtlasError::NoCasters => write!(f, "caustic atlas: no caustic casters"),
            AtlasError::Light { index, what } => write!(f, "caustic atlas: light {index}: {what}"),
            AtlasError::Caster { index, what } => write!(f, "caustic atlas: caster {index}: {what}"),
            AtlasError::Pair { index } => write!(f, "caustic atlas: pair {index} names a missing light or caster"),
            AtlasError::TableSize { width, height } => {
                write!(f, "caustic atlas: table {width}×{height} is empty or above {MAX_TABLE_CELLS} cells")
            }
            AtlasError::Defensive(d) => write!(f, "caustic atlas: defensive fraction {d} is not in [0, 1]"),
            AtlasError::Camera => write!(f, "caustic atlas: camera position not finite or solid angle not positive"),
            AtlasError::NoImportance => write!(f, "caustic atlas: every light–caster pair has zero importance"),
            AtlasError::TooManyPairs { pairs, cells } => write!(f, "caustic atlas: {pairs} pairs do not fit in {cells} cells"),
            AtlasError::BufferMismatch { expected, got } => {
                write!(f, "caustic atlas: visibility buffer has {got} cells, the table {expected}")
            }
            AtlasError::NoSamples => write!(f, "caustic atlas: a pass must report at least one camera sample"),
            AtlasError::Unit(u) => write!(f, "caustic atlas: visibility unit {u} is not a positive finite number"),
        }
    }
}

impl std::error::Error for AtlasError {}

/// A caustic light as the atlas sees it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum AtlasLight {
    /// A light with a position (point, sphere, rect, disk, cylinder, triangle): its bounding
    /// sphere (radius 0 for a point), emitted power and where it emits (None: all round).
    Local { center: Vec3, radius: f32, power: f32, emit: Option<EmissionBounds> },
    /// A distant light: direction towards it, irradiance on a facing surface, cosine of its
    /// half-angle (1 for a delta light).
    Distant { to_light: Vec3, irradiance: f32, cos_half_angle: f32 },
}

impl AtlasLight {
    /// The atlas's view of a renderer light; None for dome and sky lights (their smooth light is the
    /// path tracer's job).
    pub fn from_light(light: &Light) -> Option<AtlasLight> {
        let power = light.power();
        // where it sends its light (a spot's cone, a rect's front), for the pairs' importance
        let emit = EmissionBounds::of(light, (0.0, 0.0));
        let bound = |c: Vec3, pts: &[Vec3]| pts.iter().map(|p| p.distance(c)).fold(0.0f32, f32::max);
        match light {
            // where its transform puts it (the aim of its photons follows it over the shutter)
            Light::Moving(m) => AtlasLight::from_light(&m.inner),
            Light::Dome(_) | Light::Sky(_) => None,
            Light::Point(l) => Some(AtlasLight::Local { center: l.p, radius: 0.0, power, emit }),
            Light::Sphere(l) => Some(AtlasLight::Local { center: l.center, radius: l.radius, power, emit }),
            Light::Rect(l) => {
                let s = &l.shape;
                let c = s.origin + 0.5 * (s.a + s.b);
                let r = bound(c, &[s.origin, s.origin + s.a, s.origin + s.b, s.origin + s.a + s.b]);
                Some(AtlasLight::Local { center: c, radius: r, power, emit })
            }
            Light::Disk(l) => Some(AtlasLight::Local { center: l.shape.origin, radius: l.shape.a.length().max(l.shape.b.length()), power, emit }),
            Light::Cylinder(l) => Some(AtlasLight::Local {
                center: l.center,
                radius: (l.radius * l.radius + l.half_length * l.half_length).sqrt(),
                power,
                emit,
            }),
            Light::Triangle(l) => {
                let c = (l.p[0] + l.p[1] + l.p[2]) / 3.0;
                Some(AtlasLight::Local { center: c, radius: bound(c, &l.p), power, emit })
            }
            Light::Distant(d) => {
                let base = d.emission.luminance * d.emission.scale;
                if light.is_delta() {
                    return Some(AtlasLight::Distant { to_light: d.to_light, irradiance: base, cos_half_angle: 1.0 });
                }
                // the cone's pdf is 1 / (2π(1 − cos))
                let lambda = SampledWavelengths::sample_uniform(0.5);
                let ctx = LightSampleContext::new(Vec3::ZERO, Vec3::ZERO);
                let pdf = light.sample_li(&ctx, glam::Vec2::splat(0.5), &lambda).map(|s| s.pdf).unwrap_or(0.0);
                let one_minus_cos = if pdf > 0.0 { (1.0 / (2.0 * PI * pdf)).min(2.0) } else { 0.0 };
                let c = 1.0 - one_minus_cos;
                let irradiance = base * PI * if c > 0.0 { 1.0 - c * c } else { 1.0 };
                Some(AtlasLight::Distant { to_light: d.to_light, irradiance, cos_half_angle: c })
            }
        }
    }

    fn validate(&self, index: usize) -> Result<AtlasLight, AtlasError> {
        let e = |what| Err(AtlasError::Light { index, what });
        match *self {
            AtlasLight::Local { center, radius, power, .. } => {
                if !center.is_finite() {
                    return e("center is not finite");
                }
                if !(radius.is_finite() && radius >= 0.0) {
                    return e("radius is negative or not finite");
                }
                if !(power.is_finite() && power >= 0.0) {
                    return e("power is negative or not finite");
                }
                Ok(*self)
            }
            AtlasLight::Distant { to_light, irradiance, cos_half_angle } => {
                let Some(dir) = to_light.try_normalize() else { return e("direction is zero or not finite") };
                if !(irradiance.is_finite() && irradiance >= 0.0) {
                    return e("irradiance is negative or not finite");
                }
                if !(-1.0..=1.0).contains(&cos_half_angle) {
                    return e("cosine of the half-angle is not in [-1, 1]");
                }
                Ok(AtlasLight::Distant { to_light: dir, irradiance, cos_half_angle })
            }
        }
    }
}

/// A caustic caster's bounding sphere.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Caster {
    pub center: Vec3,
    pub radius: f32,
}

/// Where the camera is, for the atlas's importance heuristic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraHint {
    pub position: Vec3,
    /// Solid angle of the camera's field of view (sr), the clamp of a caster's solid angle.
    pub solid_angle: f32,
}

/// Table size and learning settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtlasConfig {
    pub width: u32,
    pub height: u32,
    pub camera: Option<CameraHint>,
    /// Least weight of the uniform distribution in the table's mixture, in [0, 1].
    pub defensive: f32,
    /// Refit distant lights' emission disks to the cells that learned visibility.
    pub disk_refit: bool,
}

impl Default for AtlasConfig {
    fn default() -> Self {
        AtlasConfig { width: 256, height: 256, camera: None, defensive: 0.1, disk_refit: true }
    }
}

impl AtlasConfig {
    /// A square table of `0.25 ρ² · width · height` cells for an image (ρ: photons per pixel
    /// and sample are ρ², see [`AtlasConfig::photons_per_pass`]), between 8² and 4096².
    pub fn for_image(width: u32, height: u32, rho: f32) -> AtlasConfig {
        let cells = 0.25 * (rho as f64).powi(2) * width as f64 * height as f64;
        let side = if cells.is_finite() { cells.sqrt().ceil().clamp(8.0, 4096.0) as u32 } else { 8 };
        AtlasConfig { width: side, height: side, ..Default::default() }
    }

    /// Photons to shoot in a pass of `spp` samples per pixel: `ρ² · spp · width · height`.
    pub fn photons_per_pass(spp: u32, width: u32, height: u32, rho: f32) -> u64 {
        let n = (rho as f64).powi(2) * spp as f64 * width as f64 * height as f64;
        if n.is_finite() && n > 0.0 {
            n.round() as u64
        } else {
            0
        }
    }
}

/// One light–caster pair and its square in the table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Pair {
    pub light: u32,
    pub caster: u32,
    pub importance: f32,
    /// First column and row of the square, and its side in cells.
    pub x: u32,
    pub y: u32,
    pub size: u32,
}

/// A sample of the table.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AtlasSample {
    pub pair: u32,
    pub light: u32,
    pub caster: u32,
    /// The table cell (row-major): store it in the photon for the visibility signal.
    pub cell: u32,
    /// Coordinates in the pair's square, [0,1)².
    pub local: [f32; 2],
    /// Density of choosing this pair and `local` (per unit square of the pair).
    pub pdf_local: f32,
}

/// Measure of a [`PhotonEmission`]'s pdf.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmissionMeasure {
    /// Per steradian of direction from the light point.
    SolidAngle,
    /// Per m² of the disk perpendicular to a distant light.
    Area,
}

/// Where a photon starts and with what density.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhotonEmission {
    pub origin: Vec3,
    pub dir: Vec3,
    pub pdf: f32,
    pub measure: EmissionMeasure,
}

impl PhotonEmission {
    /// The photon's share of the emission domain (sr or m²) when `photons_in_pass` photons are
    /// shot: `1 / (N · pdf)`. Its spread, or footprint radius, follows from it.
    pub fn footprint(&self, photons_in_pass: u64) -> f32 {
        1.0 / (photons_in_pass.max(1) as f32 * self.pdf)
    }
}

/// Which signal a visibility record feeds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VisibilityKind {
    Surface = 0,
    Volume = 1,
}

/// Per-cell visibility sums of one pass, in fixed point, shareable across threads.
#[derive(Debug)]
pub struct VisibilityBuffer {
    cells: usize,
    unit: f32,
    sums: Vec<AtomicU64>,
}

impl VisibilityBuffer {
    /// A buffer for `atlas`; `unit` is the value one fixed-point unit (before the 24 fractional
    /// bits) stands for, typically a photon's mean throughput. Records below `unit / 2^25` round
    /// to zero and above `VISIBILITY_MAX_RECORD · unit` are clamped.
    pub fn new(atlas: &Atlas, unit: f32) -> Result<VisibilityBuffer, AtlasError> {
        if !(unit.is_finite() && unit > 0.0) {
            return Err(AtlasError::Unit(unit));
        }
        let cells = atlas.cell_count();
        Ok(VisibilityBuffer { cells, unit, sums: (0..2 * cells).map(|_| AtomicU64::new(0)).collect() })
    }

    /// Adds `value` (a used photon's throughput, ≥ 0) to `cell`'s signal. Invalid cells
    /// (including `u32::MAX`) and non-finite or negative values are ignored.
    #[inline]
    pub fn record(&self, cell: u32, kind: VisibilityKind, value: f32) {
        let c = cell as usize;
        if c >= self.cells || !(value > 0.0 && value.is_finite()) {
            return;
        }
        let q = ((value / self.unit).min(VISIBILITY_MAX_RECORD) as f64 * (1u64 << VISIBILITY_FRAC_BITS) as f64).round() as u64;
        if q > 0 {
            self.sums[kind as usize * self.cells + c].fetch_add(q, Ordering::Relaxed);
        }
    }

    /// The accumulated value of a cell.
    pub fn value(&self, cell: usize, kind: VisibilityKind) -> f64 {
        let q = self.sums[kind as usize * self.cells + cell].load(Ordering::Relaxed);
        q as f64 / (1u64 << VISIBILITY_FRAC_BITS) as f64 * self.unit as f64
    }

    /// Zeroes the sums for the next pass.
    pub fn clear(&mut self) {
        for s in self.sums.iter_mut() {
            *s.get_mut() = 0;
        }
    }
}

/// The light–object atlas and its learned sampling table.
#[derive(Clone, Debug)]
pub struct Atlas {
    lights: Vec<AtlasLight>,
    casters: Vec<Caster>,
    pairs: Vec<Pair>,
    width: u32,
    height: u32,
    /// Pair of each cell, or NO_PAIR.
    cell_pair: Vec<u32>,
    used_cells: usize,
    defensive: f32,
    rows: Vec<Distribution1D>,
    marginal: Distribution1D,
    /// Running means of the surface and volume signals.
    visibility: [Vec<f64>; 2],
    total_samples: u64,
    passes: u32,
    first_pass_samples: u64,
    disk_refit: bool,
    /// Each pair's refit emission disk (None: the caster's own disk).
    disks: Vec<Option<PairDisk>>,
    /// Camera samples and passes each pair's visibility means span (since its last refit).
    pair_samples: Vec<u64>,
    pair_passes: Vec<u32>,
    /// Probability of sampling each pair in the current table.
    pair_prob: Vec<f64>,
    refits: u32,
}

fn sphere_solid_angle(dist: f32, radius: f32) -> f32 {
    if radius <= 0.0 {
        0.0
    } else if dist <= radius {
        4.0 * PI
    } else {
        let s2 = (radius / dist).powi(2);
        // 1 − cos = sin² / (1 + cos), exact for small spheres
        2.0 * PI * s2 / (1.0 + (1.0 - s2).max(0.0).sqrt())
    }
}

fn importance(light: &AtlasLight, caster: &Caster, camera: Option<&CameraHint>) -> f64 {
    let omega_cam = match camera {
        Some(c) => sphere_solid_angle(c.position.distance(caster.center), caster.radius).min(c.solid_angle),
        None => PI * caster.radius * caster.radius,
    } as f64;
    let (irradiance, omega_light) = match *light {
        AtlasLight::Local { center, radius, power, emit } => {
            let d = center.distance(caster.center).max(caster.radius);
            // a light that emits into a cone (a spot, a rect's front) sends the caster what
            // its intensity towards it sends, none where it never points at it
            let toward = emit.map_or(1.0, |e| e.toward(caster.center, caster.radius)) as f64;
            (toward * power as f64 / (4.0 * std::f64::consts::PI * (d as f64).powi(2)), sphere_solid_angle(center.distance(caster.center), radius))
        }
        AtlasLight::Distant { irradiance, cos_half_angle, .. } => (irradiance as f64, 2.0 * PI * (1.0 - cos_half_angle)),
    };
    // S = 1/(1 + 1/P²) with P = 1/Ω
    let s = 1.0 / (1.0 + (omega_light as f64).powi(2));
    let i = omega_cam * s * irradiance;
    if i.is_finite() && i > 0.0 {
        i
    } else {
        0.0
    }
}

/// Greedy packing of squares of the given sides into a `w × h` table: largest first, each into
/// the free rectangle nearest the origin (then smallest) that holds it, split guillotine-wise.
fn try_pack(sizes: &[u32], w: u32, h: u32) -> Option<Vec<(u32, u32)>> {
    let mut order: Vec<usize> = (0..sizes.len()).collect();
    order.sort_by(|&a, &b| sizes[b].cmp(&sizes[a]).then(a.cmp(&b)));
    let mut holes: Vec<[u32; 4]> = vec![[0, 0, w, h]];
    let mut pos = vec![(0, 0); sizes.len()];
    for k in order {
        let s = sizes[k];
        let i = holes.iter().position(|h| h[2] >= s && h[3] >= s)?;
        let [hx, hy, hw, hh] = holes.remove(i);
        pos[k] = (hx, hy);
        let (right, below) = if hw - s > hh - s {
            ([hx + s, hy, hw - s, hh], [hx, hy + s, s, hh - s])
        } else {
            ([hx + s, hy, hw - s, s], [hx, hy + s, hw, hh - s])
        };
        for r in [right, below] {
            if r[2] > 0 && r[3] > 0 {
                holes.push(r);
            }
        }
        holes.sort_by_key(|h| (h[0] as u64 + h[1] as u64, h[2] as u64 * h[3] as u64, h[0], h[1]));
    }
    Some(pos)
}

impl Atlas {
    /// Lays out the atlas for `pairs` (light index, caster index), or every pair when None, with
    /// a uniform table over the pairs' cells.
    pub fn new(
        lights: &[AtlasLight],
        casters: &[Caster],
        pairs: Option<&[(usize, usize)]>,
        config: &AtlasConfig,
    ) -> Result<Atlas, AtlasError> {
        if lights.is_empty() {
            return Err(AtlasError::NoLights);
        }
        if casters.is_empty() {
            return Err(AtlasError::NoCasters);
        }
        let lights: Vec<AtlasLight> = lights.iter().enumerate().map(|(i, l)| l.validate(i)).collect::<Result<_, _>>()?;
        for (index, c) in casters.iter().enumerate() {
            if !c.center.is_finite() {
                return Err(AtlasError::Caster { index, what: "center is not finite" });
            }
            if !(c.radius.is_finite() && c.radius > 0.0) {
                return Err(AtlasError::Caster { index, what: "radius is not a positive finite number" });
            }
        }
        let (w, h) = (config.width, config.height);
        let cells = w as u64 * h as u64;
        if w == 0 || h == 0 || cells > MAX_TABLE_CELLS {
            return Err(AtlasError::TableSize { width: w, height: h });
        }
        if !(0.0..=1.0).contains(&config.defensive) {
            return Err(AtlasError::Defensive(config.defensive));
        }
        if let Some(c) = &config.camera {
            if !(c.position.is_finite() && c.solid_angle > 0.0 && c.solid_angle.is_finite()) {
                return Err(AtlasError::Camera);
            }
        }
        let all: Vec<(usize, usize)>;
        let pairs = match pairs {
            Some(p) => p,
            None => {
                all = (0..lights.len()).flat_map(|l| (0..casters.len()).map(move |o| (l, o))).collect();
                &all
            }
        };
        let mut chosen = Vec::new();
        for (index, &(l, o)) in pairs.iter().enumerate() {
            if l >= lights.len() || o >= casters.len() {
                return Err(AtlasError::Pair { index });
            }
            let i = importance(&lights[l], &casters[o], config.camera.as_ref());
            if i > 0.0 {
                chosen.push((l, o, i));
            }
        }
        if chosen.is_empty() {
            return Err(AtlasError::NoImportance);
        }
        if chosen.len() as u64 > cells {
            return Err(AtlasError::TooManyPairs { pairs: chosen.len(), cells });
        }
        let sum: f64 = chosen.iter().map(|c| c.2).sum();
        let mut fill = 1.0f64;
        let mut placed = None;
        for _ in 0..200 {
            let sizes: Vec<u32> = chosen
                .iter()
                .map(|c| ((fill * cells as f64 * c.2 / sum).sqrt().floor() as u32).clamp(1, w.min(h)))
                .collect();
            if let Some(pos) = try_pack(&sizes, w, h) {
                placed = Some((sizes, pos));
                break;
            }
            fill *= 0.95;
        }
        let (sizes, pos) = match placed {
            Some(p) => p,
            None => {
                let ones = vec![1; chosen.len()];
                let pos = try_pack(&ones, w, h).ok_or(AtlasError::TooManyPairs { pairs: chosen.len(), cells })?;
                (ones, pos)
            }
        };
        let pairs: Vec<Pair> = chosen
            .iter()
            .enumerate()
            .map(|(k, &(l, o, i))| Pair { light: l as u32, caster: o as u32, importance: i as f32, x: pos[k].0, y: pos[k].1, size: sizes[k] })
            .collect();
        let mut cell_pair = vec![NO_PAIR; cells as usize];
        for (k, p) in pairs.iter().enumerate() {
            for row in p.y..p.y + p.size {
                for col in p.x..p.x + p.size {
                    cell_pair[(row * w + col) as usize] = k as u32;
                }
            }
        }
        let used_cells = cell_pair.iter().filter(|&&c| c != NO_PAIR).count();
        let n_pairs = pairs.len();
        let mut atlas = Atlas {
            lights,
            casters: casters.to_vec(),
            pairs,
            width: w,
            height: h,
            cell_pair,
            used_cells,
            defensive: config.defensive,
            rows: Vec::new(),
            marginal: Distribution1D::new(&[1.0]),
            visibility: [vec![0.0; cells as usize], vec![0.0; cells as usize]],
            total_samples: 0,
            passes: 0,
            first_pass_samples: 0,
            disk_refit: config.disk_refit,
            disks: vec![None; n_pairs],
            pair_samples: vec![0; n_pairs],
            pair_passes: vec![0; n_pairs],
            pair_prob: vec![0.0; n_pairs],
            refits: 0,
        };
        let m = atlas.table_masses(&vec![0.0; cells as usize], 1.0);
        atlas.rebuild_table(&m);
        Ok(atlas)
    }

    /// Cell masses `t·U + (1−t)·v` (0 outside the pairs' squares).
    fn table_masses(&self, normalized_visibility: &[f64], t: f64) -> Vec<f32> {
        let u = 1.0 / self.used_cells as f64;
        self.cell_pair
            .iter()
            .zip(normalized_visibility)
            .map(|(&p, &v)| if p == NO_PAIR { 0.0 } else { (t * u + (1.0 - t) * v) as f32 })
            .collect()
    }

    fn rebuild_table(&mut self, m: &[f32]) {
        let w = self.width as usize;
        self.rows = m.chunks(w).map(Distribution1D::new).collect();
        let marg: Vec<f32> = self.rows.iter().map(|r| r.integral()).collect();
        self.marginal = Distribution1D::new(&marg);
        let mut sums = vec![0.0f64; self.pairs.len()];
        for (&p, &v) in self.cell_pair.iter().zip(m) {
            if p != NO_PAIR {
                sums[p as usize] += v as f64;
            }
        }
        let total: f64 = sums.iter().sum();
        self.pair_prob = sums.iter().map(|v| if total > 0.0 { v / total } else { 0.0 }).collect();
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    pub fn cell_count(&self) -> usize {
        self.cell_pair.len()
    }

    pub fn pairs(&self) -> &[Pair] {
        &self.pairs
    }

    pub fn lights(&self) -> &[AtlasLight] {
        &self.lights
    }

    pub fn casters(&self) -> &[Caster] {
        &self.casters
    }

    /// Fraction of the table's cells that belong to a pair.
    pub fn utilization(&self) -> f32 {
        self.used_cells as f32 / self.cell_count() as f32
    }

    /// Completed passes ([`Atlas::end_pass`] calls).
    pub fn passes(&self) -> u32 {
        self.passes
    }

    /// The pair a cell belongs to. Cell ids `cell_count() + k` (photons of a refit pair `k`
    /// that started outside its refit disk) name pair `k` but lie outside the table.
    pub fn pair_of_cell(&self, cell: u32) -> Option<&Pair> {
        let c = cell as usize;
        match self.cell_pair.get(c) {
            Some(&p) => self.pairs.get(p as usize),
            None => self.pairs.get(c - self.cell_pair.len()),
        }
    }

    /// Pair `k`'s emission disk now (distant lights): its refit disk, or None while it uses the
    /// caster's own.
    pub fn pair_disk(&self, k: usize) -> Option<PairDisk> {
        self.disks.get(k).copied().flatten()
    }

    /// Refits made so far (over all pairs).
    pub fn refits(&self) -> u32 {
        self.refits
    }

    /// Area of the distant-light pairs' current emission disks over that of their original
    /// disks (1 before any refit); None without distant-light pairs.
    pub fn disk_area_ratio(&self) -> Option<f32> {
        let (mut now, mut orig) = (0.0f64, 0.0f64);
        for (k, p) in self.pairs.iter().enumerate() {
            if !matches!(self.lights[p.light as usize], AtlasLight::Distant { .. }) {
                continue;
            }
            let r0 = self.casters[p.caster as usize].radius as f64;
            let r = self.disks[k].map_or(r0, |d| d.radius as f64);
            now += r * r;
            orig += r0 * r0;
        }
        (orig > 0.0).then(|| (now / orig) as f32)
    }

    /// Probability of sampling `cell` (0 outside the pairs' squares).
    #[inline]
    pub fn cell_probability(&self, cell: u32) -> f32 {
        let (w, h) = (self.width as usize, self.height as usize);
        let c = cell as usize;
        if c >= w * h || self.cell_pair[c] == NO_PAIR {
            return 0.0;
        }
        let (row, col) = (c / w, c % w);
        self.rows[row].pdf_cell(col) * self.marginal.pdf_cell(row) / (w * h) as f32
    }

    /// Scale of photon contributions in the current pass: 0 in the first (training) pass,
    /// `(N₁ + N₂)/N₂` in the second to make up for the first's energy, 1 afterwards.
    pub fn photon_weight(&self, camera_samples_this_pass: u64) -> f32 {
        match self.passes {
            0 => 0.0,
            1 => (self.first_pass_samples + camera_samples_this_pass.max(1)) as f32 / camera_samples_this_pass.max(1) as f32,
            _ => 1.0,
        }
    }

    /// Samples a pair and a point of its square from two uniform numbers.
    #[inline]
    pub fn sample(&self, u: [f32; 2]) -> AtlasSample {
        let (w, h) = (self.width as usize, self.height as usize);
        // NaN and out-of-range numbers would land in zero-probability cells
        let clamp = |v: f32| if v >= 0.0 { v.min(1.0 - f32::EPSILON) } else { 0.0 };
        let (yv, py, row) = self.marginal.sample(clamp(u[1]));
        let (xv, px, col) = self.rows[row].sample(clamp(u[0]));
        let cell = row * w + col;
        let p = &self.pairs[self.cell_pair[cell] as usize];
        let fx = (xv * w as f32 - col as f32).clamp(0.0, 1.0 - f32::EPSILON);
        let fy = (yv * h as f32 - row as f32).clamp(0.0, 1.0 - f32::EPSILON);
        let s = p.size as f32;
        let local = [
            ((col as f32 - p.x as f32 + fx) / s).min(1.0 - f32::EPSILON),
            ((row as f32 - p.y as f32 + fy) / s).min(1.0 - f32::EPSILON),
        ];
        AtlasSample {
            pair: self.cell_pair[cell],
            light: p.light,
            caster: p.caster,
            cell: cell as u32,
            local,
            pdf_local: px * py / (w * h) as f32 * s * s,
        }
    }

    /// The photon's start for a sample: `light_point` is the point sampled on a local light
    /// (ignored for distant lights). None when the geometry degenerates (non-finite point).
    #[inline]
    pub fn emit(&self, s: &AtlasSample, light_point: Vec3) -> Option<PhotonEmission> {
        let pair = self.pairs.get(s.pair as usize)?;
        let caster = &self.casters[pair.caster as usize];
        let phi = 2.0 * PI * s.local[1];
        match self.lights[pair.light as usize] {
            AtlasLight::Local { .. } => {
                let (frame, one_minus_cos) = cone_to(light_point, caster)?;
                let cos_t = 1.0 - s.local[0] * one_minus_cos;
                let sin_t = (1.0 - cos_t * cos_t).max(0.0).sqrt();
                let dir = frame.to_world(spherical_direction(sin_t, cos_t, phi)).normalize();
                let pdf = s.pdf_local / (2.0 * PI * one_minus_cos);
                Some(PhotonEmission { origin: light_point, dir, pdf, measure: EmissionMeasure::SolidAngle })
            }
            AtlasLight::Distant { to_light, .. } => {
                let dir = -to_light;
                let frame = Frame::from_normal(dir);
                let (o, radius) = match self.disks[s.pair as usize] {
                    Some(d) => (d.offset, d.radius),
                    None => ([0.0, 0.0], caster.radius),
                };
                let r = radius * s.local[0].sqrt();
                let (sp, cp) = phi.sin_cos();
                let v = [o[0] + r * cp, o[1] + r * sp];
                let origin = caster.center + frame.s * v[0] + frame.t * v[1] + to_light * caster.radius;
                let pdf = self.pair_density(s.pair as usize, v, Some(s.pdf_local));
                Some(PhotonEmission { origin, dir, pdf, measure: EmissionMeasure::Area })
            }
        }
    }

    /// [`Atlas::emit`] with the defensive mixture of refit distant-light pairs: with probability
    /// [`REFIT_DEFENSIVE`] (`u_mix` below it) the start is drawn again from `u_disk`, uniformly on
    /// the pair's original disk, and `s.cell` / `s.local` become the refit cell it falls in (or
    /// `cell_count() + pair`, outside the table, when it falls outside the refit disk). The pdf
    /// is the mixture's either way. Other samples are [`Atlas::emit`]'s.
    #[inline]
    pub fn emit_mixture(&self, s: &mut AtlasSample, light_point: Vec3, u_mix: f32, u_disk: [f32; 2]) -> Option<PhotonEmission> {
        let k = s.pair as usize;
        let (Some(disk), Some(pair)) = (self.disks.get(k).copied().flatten(), self.pairs.get(k)) else { return self.emit(s, light_point) };
        let AtlasLight::Distant { to_light, .. } = self.lights[pair.light as usize] else { return self.emit(s, light_point) };
        if !(u_mix < REFIT_DEFENSIVE) {
            return self.emit(s, light_point);
        }
        let caster = &self.casters[pair.caster as usize];
        let r = caster.radius * u_disk[0].max(0.0).sqrt();
        let (sp, cp) = (2.0 * PI * u_disk[1]).sin_cos();
        let v = [r * cp, r * sp];
        let w = Vec3::new(v[0] - disk.offset[0], v[1] - disk.offset[1], 0.0);
        let r2 = (w.x * w.x + w.y * w.y) / (disk.radius * disk.radius);
        if r2 < 1.0 {
            let local = [r2, (crate::math::spherical_phi(w) / (2.0 * PI)).min(1.0 - f32::EPSILON)];
            s.local = local;
            s.cell = self.cell_in_pair(pair, local);
        } else {
            s.cell = (self.cell_pair.len() + k) as u32;
        }
        let frame = Frame::from_normal(-to_light);
        let origin = caster.center + frame.s * v[0] + frame.t * v[1] + to_light * caster.radius;
        let pdf = self.pair_density(k, v, None);
        Some(PhotonEmission { origin, dir: -to_light, pdf, measure: EmissionMeasure::Area })
    }

    /// Density (per m²) with which distant-light pair `k` starts a photon at offset `v` from its
    /// caster's centre in the plane perpendicular to the light; `table` is the table's density
    /// (per unit square, pair choice included) at the point's cell when the caller knows it.
    fn pair_density(&self, k: usize, v: [f32; 2], table: Option<f32>) -> f32 {
        let pair = &self.pairs[k];
        let c = &self.casters[pair.caster as usize];
        let on_disk = |o: [f32; 2], radius: f32| {
            let w = Vec3::new(v[0] - o[0], v[1] - o[1], 0.0);
            let r2 = (w.x * w.x + w.y * w.y) / (radius * radius);
            (r2 < 1.0).then(|| table.unwrap_or_else(|| self.pdf_in_pair(pair, [r2, crate::math::spherical_phi(w) / (2.0 * PI)])))
        };
        match self.disks[k] {
            None => on_disk([0.0, 0.0], c.radius).map_or(0.0, |t| t / (PI * c.radius * c.radius)),
            Some(d) => {
                let r0 = c.radius * c.radius;
                let uniform = if v[0] * v[0] + v[1] * v[1] < r0 { REFIT_DEFENSIVE * self.pair_prob[k] as f32 / (PI * r0) } else { 0.0 };
                uniform + on_disk(d.offset, d.radius).map_or(0.0, |t| (1.0 - REFIT_DEFENSIVE) * t / (PI * d.radius * d.radius))
            }
        }
    }

    /// The table cell of local coordinates in a pair's square.
    fn cell_in_pair(&self, pair: &Pair, local: [f32; 2]) -> u32 {
        let s = pair.size;
        let col = pair.x + ((local[0] * s as f32) as u32).min(s - 1);
        let row = pair.y + ((local[1] * s as f32) as u32).min(s - 1);
        row * self.width + col
    }

    fn pdf_in_pair(&self, pair: &Pair, local: [f32; 2]) -> f32 {
        self.cell_probability(self.cell_in_pair(pair, local)) * (pair.size * pair.size) as f32
    }

    /// Density (per steradian, before rejection) of emitting along unit `dir` from `from` on
    /// local light `light`, summed over the light's pairs. 0 for distant lights.
    pub fn pdf_direction(&self, light: usize, from: Vec3, dir: Vec3) -> f32 {
        if !matches!(self.lights.get(light), Some(AtlasLight::Local { .. })) {
            return 0.0;
        }
        let mut pdf = 0.0;
        for pair in self.pairs.iter().filter(|p| p.light as usize == light) {
            let Some((frame, one_minus_cos)) = cone_to(from, &self.casters[pair.caster as usize]) else { continue };
            let l = frame.to_local(dir);
            let u0 = (1.0 - l.z) / one_minus_cos;
            if !(u0 < 1.0) {
                continue;
            }
            let u1 = crate::math::spherical_phi(l) / (2.0 * PI);
            pdf += self.pdf_in_pair(pair, [u0.max(0.0), u1]) / (2.0 * PI * one_minus_cos);
        }
        pdf
    }

    /// Density (per m² of the plane perpendicular to the light, before rejection) of starting a
    /// photon of distant light `light` on the line through `point`, summed over its pairs; for a
    /// refit pair, the defensive mixture's ([`Atlas::emit_mixture`]).
    pub fn pdf_position(&self, light: usize, point: Vec3) -> f32 {
        let Some(&AtlasLight::Distant { to_light, .. }) = self.lights.get(light) else { return 0.0 };
        let frame = Frame::from_normal(-to_light);
        let mut pdf = 0.0;
        for (k, pair) in self.pairs.iter().enumerate().filter(|(_, p)| p.light as usize == light) {
            let v = frame.to_local(point - self.casters[pair.caster as usize].center);
            pdf += self.pair_density(k, [v.x, v.y], None);
        }
        pdf
    }

    /// Learns the next pass's table from this pass's visibility and camera sample count.
    pub fn end_pass(&mut self, vis: &VisibilityBuffer, camera_samples: u64) -> Result<(), AtlasError> {
        if vis.cells != self.cell_count() {
            return Err(AtlasError::BufferMismatch { expected: self.cell_count(), got: vis.cells });
        }
        if camera_samples == 0 {
            return Err(AtlasError::NoSamples);
        }
        // running means over the samples since each pair's last refit (all, for most pairs)
        for (k, kind) in [VisibilityKind::Surface, VisibilityKind::Volume].into_iter().enumerate() {
            for (c, v) in self.visibility[k].iter_mut().enumerate() {
                let p = self.cell_pair[c];
                let t_prev = if p == NO_PAIR { self.total_samples } else { self.pair_samples[p as usize] } as f64;
                let t_now = t_prev + camera_samples as f64;
                *v = (t_prev * *v + vis.value(c, kind)) / t_now;
            }
        }
        if self.passes == 0 {
            self.first_pass_samples = camera_samples;
        }
        self.total_samples += camera_samples;
        self.passes += 1;
        for (n, p) in self.pair_samples.iter_mut().zip(self.pair_passes.iter_mut()) {
            *n += camera_samples;
            *p += 1;
        }
        let max = |v: &[f64]| v.iter().copied().fold(0.0f64, f64::max);
        let (ms, mv) = (max(&self.visibility[0]), max(&self.visibility[1]));
        let combined: Vec<f64> = (0..self.cell_count())
            .map(|c| {
                if self.cell_pair[c] == NO_PAIR {
                    return 0.0;
                }
                let s = if ms > 0.0 { self.visibility[0][c] / ms } else { 0.0 };
                let v = if mv > 0.0 { self.visibility[1][c] / mv } else { 0.0 };
                s.max(v)
            })
            .collect();
        let total: f64 = combined.iter().sum();
        let next_pass = self.passes as f64 + 1.0;
        let mut m = if total > 0.0 {
            let normalized: Vec<f64> = combined.iter().map(|v| v / total).collect();
            let t = (1.0 / next_pass).max(self.defensive as f64);
            self.table_masses(&normalized, t)
        } else {
            self.table_masses(&combined, 1.0)
        };
        if self.disk_refit && refit_due(self.passes) {
            for k in 0..self.pairs.len() {
                if self.pair_passes[k] < 2 {
                    continue;
                }
                let Some(disk) = self.refit_disk(k, &combined) else { continue };
                // the pair starts afresh on the new disk: no visibility, its table mass spread
                // uniformly over its square
                let p = self.pairs[k];
                let mut mass = 0.0f64;
                for row in p.y..p.y + p.size {
                    for col in p.x..p.x + p.size {
                        let c = (row * self.width + col) as usize;
                        mass += m[c] as f64;
                        self.visibility[0][c] = 0.0;
                        self.visibility[1][c] = 0.0;
                    }
                }
                let each = (mass / (p.size as f64 * p.size as f64)) as f32;
                for row in p.y..p.y + p.size {
                    for col in p.x..p.x + p.size {
                        m[(row * self.width + col) as usize] = each;
                    }
                }
                self.disks[k] = Some(disk);
                self.pair_samples[k] = 0;
                self.pair_passes[k] = 0;
                self.refits += 1;
            }
        }
        self.rebuild_table(&m);
        Ok(())
    }

    /// The refit disk of distant-light pair `k` from the learned signal (`combined`, per cell):
    /// the smallest disk holding the pair's strongest cells that together hold
    /// [`REFIT_SIGNAL_SHARE`] of its signal, and the cells around them (a margin of one current cell, in the polar cells' rows and columns), when
    /// its area is at most [`REFIT_MAX_AREA_RATIO`] of the current disk's. None otherwise, or
    /// when the pair has learned nothing.
    fn refit_disk(&self, k: usize, combined: &[f64]) -> Option<PairDisk> {
        let p = self.pairs[k];
        if !matches!(self.lights[p.light as usize], AtlasLight::Distant { .. }) || p.size < 2 {
            return None;
        }
        let n = p.size as usize;
        let (o, radius) = match self.disks[k] {
            Some(d) => (d.offset, d.radius),
            None => ([0.0, 0.0], self.casters[p.caster as usize].radius),
        };
        // column i: radius R√(i/n)…R√((i+1)/n); row j: angle 2πj/n…2π(j+1)/n
        let value = |i: usize, j: usize| combined[(p.y as usize + j) * self.width as usize + p.x as usize + i];
        let mut sorted: Vec<f64> = (0..n * n).map(|c| value(c % n, c / n)).filter(|v| *v > 0.0).collect();
        sorted.sort_by(|a, b| b.total_cmp(a));
        let total: f64 = sorted.iter().sum();
        let mut acc = 0.0;
        let mut floor = f64::INFINITY;
        for v in sorted {
            floor = v;
            acc += v;
            if acc >= REFIT_SIGNAL_SHARE * total {
                break;
            }
        }
        let useful = |i: usize, j: usize| value(i, j) >= floor;
        let mut any = false;
        let mut keep = vec![false; n * n];
        for j in 0..n {
            for i in 0..n {
                if !useful(i, j) {
                    continue;
                }
                any = true;
                for dj in [n - 1, 0, 1] {
                    for i2 in i.saturating_sub(1)..=(i + 1).min(n - 1) {
                        keep[((j + dj) % n) * n + i2] = true;
                    }
                }
            }
        }
        if !any {
            return None;
        }
        // each row's kept cells lie in one annular sector; the sector lies in the convex hull of
        // its inner corners and its outer arc, sampled at REFIT_ARC_POINTS + 1 angles (the arc
        // leaves the chords by at most the sagitta, added to the radius)
        let mut pts: Vec<[f64; 2]> = Vec::new();
        let rad = |i: usize| radius as f64 * (i as f64 / n as f64).sqrt();
        for j in 0..n {
            let row = &keep[j * n..(j + 1) * n];
            let (Some(lo), Some(hi)) = (row.iter().position(|&b| b), row.iter().rposition(|&b| b)) else { continue };
            let (r_in, r_out) = (rad(lo), rad(hi + 1));
            let a = |f: f64| 2.0 * std::f64::consts::PI * (j as f64 + f) / n as f64;
            let at = |r: f64, phi: f64| [o[0] as f64 + r * phi.cos(), o[1] as f64 + r * phi.sin()];
            pts.push(at(r_in, a(0.0)));
            pts.push(at(r_in, a(1.0)));
            for q in 0..=REFIT_ARC_POINTS {
                pts.push(at(r_out, a(q as f64 / REFIT_ARC_POINTS as f64)));
            }
        }
        let (c, r) = enclosing_circle(&mut pts);
        let sagitta = radius as f64 * (1.0 - (std::f64::consts::PI / (n as f64 * REFIT_ARC_POINTS as f64)).cos());
        // f32 rounding of the centre and radius: grow by a few ulps of the disk's scale
        let r = (r + sagitta) * (1.0 + 1e-6) + 1e-6 * radius as f64;
        if !(r * r <= REFIT_MAX_AREA_RATIO as f64 * (radius as f64).powi(2)) {
            return None;
        }
        Some(PairDisk { offset: [c[0] as f32, c[1] as f32], radius: r as f32 })
    }

    /// The current sampling table as an image (row-major, `width × height`, scaled so the most
    /// likely cell is 1; cells outside every pair are 0).
    pub fn to_image(&self) -> (u32, u32, Vec<f32>) {
        let p: Vec<f32> = (0..self.cell_count() as u32).map(|c| self.cell_probability(c)).collect();
        let m = p.iter().copied().fold(0.0f32, f32::max);
        (self.width, self.height, p.iter().map(|v| if m > 0.0 { v / m } else { 0.0 }).collect())
    }

    /// The learned visibility signal (max of the normalised surface and volume signals), scaled
    /// to a maximum of 1, as an image.
    pub fn visibility_image(&self) -> (u32, u32, Vec<f32>) {
        let max = |v: &[f64]| v.iter().copied().fold(0.0f64, f64::max);
        let (ms, mv) = (max(&self.visibility[0]), max(&self.visibility[1]));
        let img = (0..self.cell_count())
            .map(|c| {
                let s = if ms > 0.0 { self.visibility[0][c] / ms } else { 0.0 };
                let v = if mv > 0.0 { self.visibility[1][c] / mv } else { 0.0 };
                s.max(v) as f32
            })
            .collect();
        (self.width, self.height, img)
    }
}

/// The smallest circle holding `pts` (Welzl's algorithm, iterative, over a fixed shuffle so the
/// result is a function of the points alone); the points are reordered.
fn enclosing_circle(pts: &mut [[f64; 2]]) -> ([f64; 2], f64) {
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    for i in (1..pts.len()).rev() {
        state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
        pts.swap(i, ((state >> 33) % (i as u64 + 1)) as usize);
    }
    let d = |a: [f64; 2], b: [f64; 2]| ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2)).sqrt();
    let two = |a: [f64; 2], b: [f64; 2]| ([(a[0] + b[0]) * 0.5, (a[1] + b[1]) * 0.5], d(a, b) * 0.5);
    let three = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| {
        let (bx, by, cx, cy) = (b[0] - a[0], b[1] - a[1], c[0] - a[0], c[1] - a[1]);
        let den = 2.0 * (bx * cy - by * cx);
        if den.abs() < 1e-300 {
            // collinear: the circle on the farthest two
            let cands = [two(a, b), two(a, c), two(b, c)];
            return cands.into_iter().fold(cands[0], |m, x| if x.1 > m.1 { x } else { m });
        }
        let (b2, c2) = (bx * bx + by * by, cx * cx + cy * cy);
        let ux = (cy * b2 - by * c2) / den;
        let uy = (bx * c2 - cx * b2) / den;
        ([a[0] + ux, a[1] + uy], (ux * ux + uy * uy).sqrt())
    };
    let Some(&first) = pts.first() else { return ([0.0, 0.0], 0.0) };
    let inside = |c: &([f64; 2], f64), p: [f64; 2]| d(c.0, p) <= c.1 * (1.0 + 1e-12) + 1e-300;
    let mut circ = (first, 0.0);
    for i in 1..pts.len() {
        if inside(&circ, pts[i]) {
            continue;
        }
        circ = (pts[i], 0.0);
        for j in 0..i {
            if inside(&circ, pts[j]) {
                continue;
            }
            circ = two(pts[i], pts[j]);
            for k in 0..j {
                if !inside(&circ, pts[k]) {
                    circ = three(pts[i], pts[j], pts[k]);
                }
            }
        }
    }
    // rounding in the circumcircles: the radius reaches the farthest point
    let r = pts.iter().map(|&p| d(circ.0, p)).fold(circ.1, f64::max);
    (circ.0, r)
}

/// Frame around the axis from `x` to the caster's centre and `1 − cosθ_max` of the cone that
/// holds its bounding sphere (2: the whole sphere, when `x` is inside).
fn cone_to(x: Vec3, caster: &Caster) -> Option<(Frame, f32)> {
    if !x.is_finite() {
        return None;
    }
    let d = caster.center - x;
    let dist = d.length();
    if !(dist > caster.radius) {
        let axis = d.try_normalize().unwrap_or(Vec3::Z);
        return Some((Frame::from_normal(axis), 2.0));
    }
    let s2 = (caster.radius / dist).powi(2);
    let one_minus_cos = s2 / (1.0 + (1.0 - s2).max(0.0).sqrt());
    Some((Frame::from_normal(d / dist), one_minus_cos))
}
