//! The `caustics` integrator's state across progressive passes: which lights emit photons and
//! which objects cast caustics, the guided photon pass, the lookups camera paths make, and the
//! approximate MIS weights that split caustic transport between photons and path tracing
//! (Conty & Kulla 2019 §3–7).
//!
//! # A pass
//! [`Caustics::begin_pass`] shoots `ρ² · spp · pixels` photons (capped by the memory budget),
//! each from a cell of the guiding atlas: the cell picks a (light, caster) pair and the photon's
//! start within the pair's cone (local lights) or disk (distant lights, whose direction is then
//! jittered within the sun's cone; the disk is refit to the useful area as the atlas learns,
//! with a defensive share of photons still starting on the original disk). A photon is kept only if its first hit is the pair's caster.
//! It then scatters through caster surfaces (any BSDF, sampled in importance mode) and media
//! (attenuated by their transmittance: only unscattered light is carried), and is stored at the
//! first non-caster surface if that surface is a receiver with a non-specular response; the walk
//! ends there. The photons are built into a [`PhotonMap`].
//!
//! Camera paths then call [`Caustics::gather`] at every non-specular vertex on a receiver, with
//! a radius of about one pixel footprint carried along the path, and select one photon in
//! proportion to kernel × energy (stochastic lookup, §6.1). Every photon in reach adds its
//! throughput to the atlas's visibility signal; [`Caustics::end_pass`] learns the next table.
//!
//! # What is counted once
//! A path `x → c₁ … cₖ → light` with `x` a non-specular receiver vertex, `c₁…cₖ` (k ≥ 1) caster
//! surfaces and no volume scattering in between can be made by photons (if the light emits them
//! and the pair (light, group of `cₖ`) has a square in the atlas) and by the path tracer (a
//! BSDF-sampled chain that reaches the light, or NEE from a glossy `cₖ`). Both estimators are
//! weighted by the approximate MIS of §7: with `P_b` the BSDF pdf at `x` of the chain's first
//! direction and `P_l` the pair's light-sampling pdf (1 / solid angle of the light seen from the
//! caster's centre; ∞ for delta lights), the path tracer gets
//! `W_l = 1 / (1 + N_p P_l / P_b)` and the photon `W_p = 1 − W_l` (`N_p` = 16). The weights
//! depend only on `P_b` and the pair, so they sum to one on every such path.
//!
//! The first pass only trains the atlas (photon weight 0); the second makes up for it with the
//! weight `(N₁ + N₂)/N₂` ([`Atlas::photon_weight`]).

// `!(x < y)` is used on purpose: it rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::{Vec2, Vec3};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU64, Ordering};

use super::atlas::{Atlas, AtlasConfig, AtlasLight, CameraHint, Caster, VisibilityBuffer, VisibilityKind};
use super::beams::{Beam, BeamMap};
use super::footprint::Footprint;
use super::photon_map::{NormalCheck, Photon, PhotonMap, Query, SpectralKernel};
use crate::accel::Ray;
use crate::bsdf::{Bsdf, TransportMode};
use crate::integrator::{classify_boundary, Boundary, InteriorStack};
use crate::light::emit::EmissionDisk;
use crate::math::{offset_ray_origin, point_error, Frame, ONE_MINUS_EPSILON};
use crate::sampler::{PixelSampler, StreamRng};
use super::light_tracing::{LightTracer, Splat};
use crate::scene::CausticsTransparency;
use crate::spectrum::{color, SampledSpectrum, SampledWavelengths};
use crate::world::World;

/// Settings of the caustics integrator.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CausticsConfig {
    /// Photons shot per camera sample (ρ² of the paper).
    pub photons_per_sample: f32,
    /// Memory allowed for one pass's photon map (photons and grid); fewer photons are shot
    /// when a pass would need more.
    pub memory_limit_bytes: usize,
    /// `N_p` of the approximate MIS: larger values favour photons.
    pub mis_photon_count: f32,
    /// Lookup radius in pixel footprints.
    pub radius_pixels: f32,
    /// Radius (nm) of the kernel that merges a photon's wavelengths into a camera path's.
    pub spectral_radius_nm: f32,
    /// Photon beams per pixel and pass that set the beams' widths (beams of more photons are
    /// kept at random, with their flux scaled up accordingly; each is as wide as the share of
    /// the light it carries), before [`Self::beam_thinning_pixels`] thins them.
    pub beams_per_pixel: f32,
    /// Images of more pixels than this keep a share √(this / pixels) of those beams, drawn at
    /// random, their flux scaled up by its inverse and their widths unchanged (the expected
    /// image is the same), on top of [`Self::beams_per_query`]'s share. Off (∞) by default: a
    /// rule by pixel count alone cut the equal-time error of clear water 1.3–3× at 2048 and
    /// raised that of murky water, where the beams carry most of the noise, 4–400× (shares
    /// 0.25–0.0625; `docs/caustics.md`, "Thinned beams").
    pub beam_thinning_pixels: f32,
    /// Beams a gathering query that meets any should meet on average: the first pass after a
    /// (re)start measures, on a probe of [`PROBE_SAMPLES`] camera samples, how many beams the
    /// queries that meet one meet (m), and from then on a random share min(1, this / m) of the
    /// beams is kept, their flux scaled up by its inverse and their widths unchanged, so that
    /// the expected image is the same. The beams' widths follow the pixels' footprints, so a
    /// camera ray through clear water meets about √pixels of them and gathering costs
    /// pixels^1.5 per pass; thinned, it meets about this many at any resolution. Murky water,
    /// where a query meets far fewer than this, keeps every beam: there thinning would only
    /// make rare bright beams rarer and brighter. ∞ turns the rule off.
    pub beams_per_query: f32,
    /// Connect photon stretches in the camera's medium to a pinhole camera (light tracing of
    /// the god rays seen directly; see [`super::light_tracing`]).
    pub light_tracing: bool,
    /// Refit distant lights' emission disks to where photons proved useful (see
    /// [`super::atlas`], "Refitting a distant light's disk").
    pub disk_refit: bool,
}

impl Default for CausticsConfig {
    fn default() -> Self {
        CausticsConfig { photons_per_sample: 1.0, memory_limit_bytes: 1 << 30, mis_photon_count: 16.0, radius_pixels: 1.0, spectral_radius_nm: 20.0, beams_per_pixel: 0.25, beam_thinning_pixels: f32::INFINITY, beams_per_query: DEFAULT_BEAMS_PER_QUERY, light_tracing: true, disk_refit: true }
    }
}

/// Default of [`CausticsConfig::beams_per_query`].
pub const DEFAULT_BEAMS_PER_QUERY: f32 = 8.0;
/// Camera samples of the probe that measures the beams a query meets
/// ([`CausticsConfig::beams_per_query`]).
pub const PROBE_SAMPLES: u32 = 4096;

/// Counters of the caustics passes so far.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CausticsStats {
    pub passes: u32,
    pub photons_emitted: u64,
    pub photons_stored: u64,
    /// Photons stored in the last pass.
    pub photons_last_pass: u64,
    /// Photon beams stored (all passes, and the last).
    pub beams_stored: u64,
    pub beams_last_pass: u64,
    /// Share of the beams the last pass kept, of those its width share and the pixel rule
    /// ([`CausticsConfig::beam_thinning_pixels`]) keep (1: none thinned by the measured rule).
    pub beam_share: f32,
    /// Beams met per gathering query that met any, measured on the probe of the first pass
    /// after a (re)start, before thinning (None: not measured).
    pub beams_per_query: Option<f32>,
    /// Largest photon map of a pass, bytes.
    pub peak_map_bytes: usize,
    /// (light, caster) pairs in the atlas.
    pub pairs: usize,
    pub atlas_utilization: f32,
    /// Passes whose photon count was cut to the memory budget.
    pub capped_passes: u32,
    /// Photon stretches connected to the camera (light tracing), all passes.
    pub light_connections: u64,
    /// Area of the distant lights' emission disks now over their original area (refits shrink
    /// it); None without distant-light emitters.
    pub disk_area_ratio: Option<f32>,
    /// Emission-disk refits so far.
    pub disk_refits: u32,
}

/// A caustic chain a camera path is on: it left a non-specular receiver vertex with BSDF pdf
/// `p_b` and has since met only caster surfaces, the last being `last` (u32::MAX: none yet).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Chain {
    pub p_b: f32,
    pub last: u32,
}

/// Largest lookup radius, in photon-grid cells (a cell is two pixel footprints at the casters'
/// distance from the camera).
const MAX_RADIUS_CELLS: f32 = 2.0;
/// Photons a lookup aims to have in reach where photons are dense.
const LOOKUP_PHOTONS: f32 = 48.0;
/// Photons traced per parallel work item.
const CHUNK: usize = 4096;
/// Caster surfaces a photon may cross.
const MAX_PHOTON_BOUNCES: u32 = 32;
const NO_GROUP: u32 = u32::MAX;
/// Instances above which casters are grouped into one bounding sphere.
const MAX_CASTER_GROUPS: usize = 32;

/// One step of weighted reservoir sampling over a stream: adds `w` to the running `total` and
/// says whether the new item replaces the one kept (probability `w / total`), so that after the
/// stream each item is kept with probability `w / Σw`. `u` is uniform in [0, 1).
#[inline]
fn reservoir_take(total: &mut f32, w: f32, u: f32) -> bool {
    *total += w;
    u * *total < w
}

fn w_light(p_b: f32, p_l: f32, np: f32) -> f32 {
    if !(p_l.is_finite()) || !(p_b > 0.0) {
        return 0.0;
    }
    1.0 / (1.0 + np * p_l / p_b)
}

/// The caustics state of one render.
pub struct Caustics {
    atlas: Atlas,
    fresh_atlas: Atlas,
    vis: VisibilityBuffer,
    map: PhotonMap,
    beams: BeamMap,
    /// Media that scatter (beams are kept in them).
    beam_media: Vec<bool>,
    /// World light of each atlas light, and atlas light of each world light.
    atlas_lights: Vec<usize>,
    light_atlas: Vec<u32>,
    /// Caster group of each instance (NO_GROUP: not a caster).
    instance_group: Vec<u32>,
    n_groups: usize,
    /// `P_l` of each (atlas light, group) pair; NaN where the pair has no photons.
    pair_pl: Vec<f32>,
    /// Stack of dielectrics around each atlas light's photons' start (local lights).
    light_stack: Vec<InteriorStack>,
    config: CausticsConfig,
    /// Footprint of a camera ray: width at the camera and growth per unit length.
    pixel_w0: f32,
    pixel_spread: f32,
    cell_size: f32,
    scene_radius: f32,
    /// Narrowest beam width (10⁻⁵ of the largest caster's radius); a tenth of it is the
    /// smallest photon lookup radius.
    beam_width_floor: f32,
    disk: EmissionDisk,
    kernel: SpectralKernel,
    /// Connections of photon stretches to the camera (None: off, or no camera medium to do it in).
    light_tracer: Option<LightTracer>,
    /// This pass's light-traced image (RGB per pixel, before the pass's photon weight).
    light_image: Vec<f32>,
    /// Photon contribution scale of the current pass.
    weight: f32,
    mean_energy: f32,
    stats: CausticsStats,
    /// Share of the beams kept by the measured rule ([`CausticsConfig::beams_per_query`]);
    /// None until the probe of the first pass after a (re)start has measured it.
    beam_share: Option<f32>,
    /// Whether gathering counts the beams queries meet (and records no visibility): the probe.
    probing: bool,
    /// The probe's gathering queries, those that met a beam, and the beams they met.
    probe: [AtomicU64; 3],
}

impl Caustics {
    /// Sets up caustics for `world`; None when no light emits photons towards any caster (the
    /// integrator is then a plain path tracer).
    pub fn new(world: &World, width: u32, height: u32, config: CausticsConfig) -> Option<Caustics> {
        let n_inst = world.instances.len();
        // casters and their world bounds
        let caster_inst: Vec<u32> = (0..n_inst as u32).filter(|&i| world.caustic_instances[i as usize].caster).collect();
        if caster_inst.is_empty() {
            return None;
        }
        let (lo, hi) = world.accel.bounds();
        let scene_center = (lo + hi) * 0.5;
        let scene_radius = ((hi - lo).length() * 0.5).max(1e-3);
        // beams in scattering water, depth-varying water included (its beams and camera rays
        // then track their transmittance); not in volume grids, whose boxes photons do not enter
        let beam_media: Vec<bool> = world.media.iter().map(|m| m.scatters() && !matches!(m, crate::medium::Medium::Grid(_))).collect();
        let cam_pos = world.camera.position(world.camera.shutter.0);
        // the dielectrics and media around the camera (the probes below and light tracing)
        let camera_stack = crate::integrator::initial_stack(world, cam_pos, world.camera.shutter.0);
        // where photons matter: around the receivers (their bounds, expanded by half their size,
        // since a photon may meet a caster beside a receiver and turn onto it), and in the beam
        // media the camera sees, within a photon's reach of the camera rays' stretches through
        // them (an underwater camera in open water has no receiver at all)
        let mut rlo = Vec3::splat(f32::INFINITY);
        let mut rhi = Vec3::splat(f32::NEG_INFINITY);
        let mut bounds = Vec::with_capacity(n_inst);
        for i in 0..n_inst {
            let b = instance_bounds(world, i as u32);
            if let Some((a, b2)) = b {
                let c = &world.caustic_instances[i];
                if c.receiver && !c.caster {
                    rlo = rlo.min(a);
                    rhi = rhi.max(b2);
                }
            }
            bounds.push(b);
        }
        let probes = camera_probes(world, width, height, &camera_stack, &beam_media, 2.0 * scene_radius);
        let (mut clo, mut chi) = (probes.media_lo, probes.media_hi);
        if rlo.x <= rhi.x {
            let pad = (rhi - rlo) * 0.5 + Vec3::splat(1e-3 * scene_radius);
            (clo, chi) = (clo.min(rlo - pad), chi.max(rhi + pad));
        }
        if !(clo.x <= chi.x) {
            return None;
        }
        let mut groups: Vec<(Vec3, Vec3, Vec<u32>)> = Vec::new();
        for &i in &caster_inst {
            let Some((a, b)) = bounds[i as usize] else { continue };
            let (a, b) = (a.max(clo), b.min(chi));
            if !(a.x <= b.x && a.y <= b.y && a.z <= b.z) {
                continue;
            }
            groups.push((a, b, vec![i]));
        }
        if groups.is_empty() {
            return None;
        }
        if groups.len() > MAX_CASTER_GROUPS {
            let (mut a, mut b, mut all) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY), Vec::new());
            for g in groups.drain(..) {
                a = a.min(g.0);
                b = b.max(g.1);
                all.extend(g.2);
            }
            groups.push((a, b, all));
        }
        let mut instance_group = vec![NO_GROUP; n_inst];
        let casters: Vec<Caster> = groups
            .iter()
            .enumerate()
            .map(|(gi, (a, b, members))| {
                for &m in members {
                    instance_group[m as usize] = gi as u32;
                }
                Caster { center: (*a + *b) * 0.5, radius: ((*b - *a).length() * 0.5).max(1e-4 * scene_radius) }
            })
            .collect();
        // emitters
        let mut atlas_lights = Vec::new();
        let mut alights = Vec::new();
        let mut light_atlas = vec![NO_GROUP; world.lights.len()];
        for (li, light) in world.lights.iter().enumerate() {
            if !world.caustic_emitters.get(li).copied().unwrap_or(false) {
                continue;
            }
            if let Some(a) = AtlasLight::from_light(light) {
                light_atlas[li] = alights.len() as u32;
                alights.push(a);
                atlas_lights.push(li);
            }
        }
        if alights.is_empty() {
            return None;
        }
        // a distant light's photons start on a disk perpendicular to its axis and leave in
        // directions jittered within its cone: a disk of radius R (1 + sin θ) / cos θ lets every
        // point of a caster's sphere of radius R receive the whole cone
        let max_half_angle = alights
            .iter()
            .map(|a| match a {
                AtlasLight::Distant { cos_half_angle, .. } => cos_half_angle.clamp(-1.0, 1.0).acos(),
                AtlasLight::Local { .. } => 0.0,
            })
            .fold(0.0f32, f32::max)
            .min(1.2);
        let grow = (1.0 + max_half_angle.sin()) / max_half_angle.cos();
        let casters: Vec<Caster> = casters.into_iter().map(|c| Caster { center: c.center, radius: c.radius * grow }).collect();
        // the size of the caustics' region (the largest caster), which sets the guards against
        // degenerate footprints below: not the scene's, which a far ground plane can make
        // kilometres
        let region = casters.iter().map(|c| c.radius).fold(0.0f32, f32::max);
        let beam_width_floor = 1e-5 * region;
        let (pixel_w0, pixel_spread) = pixel_footprint(world, width, height);
        let fov = (pixel_spread * width as f32) * (pixel_spread * height as f32);
        let mut acfg = AtlasConfig::for_image(width, height, config.photons_per_sample.sqrt());
        acfg.disk_refit = config.disk_refit;
        acfg.camera = Some(CameraHint { position: cam_pos, solid_angle: if fov > 0.0 { fov.min(4.0 * std::f32::consts::PI) } else { 4.0 * std::f32::consts::PI } });
        let atlas = Atlas::new(&alights, &casters, None, &acfg).ok()?;
        if atlas.pairs().is_empty() {
            return None;
        }
        let mut pair_pl = vec![f32::NAN; alights.len() * casters.len()];
        for p in atlas.pairs() {
            let pl = match alights[p.light as usize] {
                AtlasLight::Local { center, radius, .. } => {
                    let c = &casters[p.caster as usize];
                    let d = center.distance(c.center);
                    if radius <= 0.0 {
                        f32::INFINITY
                    } else if d <= radius {
                        1.0 / (4.0 * std::f32::consts::PI)
                    } else {
                        let s2 = (radius / d).powi(2);
                        let omc = s2 / (1.0 + (1.0 - s2).max(0.0).sqrt());
                        1.0 / (2.0 * std::f32::consts::PI * omc)
                    }
                }
                AtlasLight::Distant { cos_half_angle, .. } => {
                    if cos_half_angle >= 1.0 {
                        f32::INFINITY
                    } else {
                        1.0 / (2.0 * std::f32::consts::PI * (1.0 - cos_half_angle))
                    }
                }
            };
            pair_pl[p.light as usize * casters.len() + p.caster as usize] = pl;
        }
        let light_stack = alights
            .iter()
            .map(|a| match a {
                AtlasLight::Local { center, .. } => crate::integrator::initial_stack(world, *center, world.camera.shutter.0),
                AtlasLight::Distant { .. } => InteriorStack::default(),
            })
            .collect();
        // grid cells of about two lookup radii at the median distance of the receivers the
        // camera sees (the casters' distance when none)
        let mut seen = probes.receivers;
        seen.sort_by(|a, b| a.total_cmp(b));
        let dist = match seen.get(seen.len() / 2) {
            Some(&d) => d,
            None => casters.iter().map(|c| c.center.distance(cam_pos)).fold(f32::INFINITY, f32::min),
        }
        .max(1e-3 * region);
        let cell_size = ((pixel_w0 + pixel_spread * dist) * config.radius_pixels * 2.0).max(1e-5 * region);
        let disk = EmissionDisk::new(scene_center, scene_radius).ok()?;
        let vis = VisibilityBuffer::new(&atlas, 1.0).ok()?;
        let stats = CausticsStats { pairs: atlas.pairs().len(), atlas_utilization: atlas.utilization(), disk_area_ratio: atlas.disk_area_ratio(), ..Default::default() };
        let light_tracer = if config.light_tracing {
            LightTracer::new(world, &beam_media, camera_stack.medium())
        } else {
            None
        };
        Some(Caustics {
            light_tracer,
            light_image: Vec::new(),
            fresh_atlas: atlas.clone(),
            atlas,
            vis,
            map: PhotonMap::build(Vec::new(), cell_size).ok()?,
            beams: BeamMap::default(),
            beam_media,
            atlas_lights,
            light_atlas,
            instance_group,
            n_groups: casters.len(),
            pair_pl,
            light_stack,
            config,
            pixel_w0,
            pixel_spread,
            cell_size,
            scene_radius,
            beam_width_floor,
            disk,
            kernel: SpectralKernel::new(config.spectral_radius_nm).unwrap_or_default(),
            weight: 0.0,
            mean_energy: 1.0,
            stats,
            beam_share: None,
            probing: false,
            probe: Default::default(),
        })
    }

    pub fn stats(&self) -> &CausticsStats {
        &self.stats
    }

    pub fn atlas(&self) -> &Atlas {
        &self.atlas
    }

    /// The photon map of the current pass.
    pub fn photon_map(&self) -> &PhotonMap {
        &self.map
    }

    /// Forgets everything learned (a restarted render is then identical to a fresh one).
    pub fn reset(&mut self) {
        self.atlas = self.fresh_atlas.clone();
        self.vis.clear();
        self.map = PhotonMap::build(Vec::new(), self.cell_size).expect("empty map");
        self.beams = BeamMap::default();
        self.weight = 0.0;
        self.beam_share = None;
        self.probing = false;
        self.stats = CausticsStats { pairs: self.stats.pairs, atlas_utilization: self.stats.atlas_utilization, disk_area_ratio: self.atlas.disk_area_ratio(), ..Default::default() };
    }

    /// The footprint of a camera ray at the camera (see [`super::footprint`]).
    pub fn pixel_footprint(&self) -> Footprint {
        Footprint::camera(self.pixel_w0, self.pixel_spread)
    }

    /// Traces this pass's photons (`spp` samples per pixel over `pixels` pixels are about to be
    /// rendered) and builds the photon map. Runs on the current rayon pool.
    pub fn begin_pass(&mut self, world: &World, seed: u64, spp: u32, pixels: u64) {
        self.begin_pass_over(world, seed, spp, pixels, pixels)
    }

    /// [`Self::begin_pass`] for a pass that renders `rendered` of the image's `pixels` (a
    /// `dataWindowNDC` crop): the photons follow the whole image, so that the crop meets the
    /// whole image's photon density, while the second pass's make-up weight for the training
    /// pass ([`Atlas::photon_weight`]) counts the camera samples taken, as the training pass's
    /// count does.
    pub fn begin_pass_over(&mut self, world: &World, seed: u64, spp: u32, pixels: u64, rendered: u64) {
        let traced = self.begin_pass_until(world, seed, spp, pixels, rendered, &|| false);
        debug_assert!(traced);
    }

    /// [`Self::begin_pass_over`] that gives the pass up (false) once `cancelled` says so: it is
    /// asked before each chunk of [`CHUNK`] photons and before the maps are built, so a Stop, a
    /// new camera or a time budget's end during the photon tracing is met within a chunk's
    /// photons instead of after the whole pass's. A pass given up changes nothing the next one
    /// sees: that pass traces the same photons, as if this one had never begun.
    pub fn begin_pass_until(&mut self, world: &World, seed: u64, spp: u32, pixels: u64, rendered: u64, cancelled: &(dyn Fn() -> bool + Sync)) -> bool {
        let wanted = (self.config.photons_per_sample as f64 * spp as f64 * pixels as f64).round().max(1.0) as u64;
        let cap = PhotonMap::max_photons_for_memory(self.config.memory_limit_bytes) as u64;
        let n = wanted.min(cap).max(1);
        let pass = self.stats.passes;
        let chunks = (n as usize).div_ceil(CHUNK);
        let this = &*self;
        // the share of stretches kept as beams, and the scale of their widths (set by the
        // density of the share before thinning)
        let width_share = if self.beam_media.iter().any(|b| *b) { (self.config.beams_per_pixel as f64 * pixels as f64 / n as f64).min(1.0) as f32 } else { 0.0 };
        let share = beam_thinning(self.config.beam_thinning_pixels, pixels) * self.beam_share.unwrap_or(1.0);
        let keep_beam = (width_share * share, if width_share > 0.0 { 1.0 / width_share.sqrt() } else { 0.0 });
        let parts: Option<Vec<(Vec<Photon>, Vec<Beam>, Vec<Splat>)>> = (0..chunks)
            .into_par_iter()
            .map(|c| {
                if cancelled() {
                    return None;
                }
                let mut out = (Vec::new(), Vec::new(), Vec::new());
                let start = c * CHUNK;
                let end = (start + CHUNK).min(n as usize);
                for i in start..end {
                    this.trace_photon(world, seed, pass, i as u32, n, keep_beam, &mut out);
                }
                Some(out)
            })
            .collect();
        let Some(parts) = parts.filter(|_| !cancelled()) else {
            return false;
        };
        if n < wanted {
            self.stats.capped_passes += 1;
        }
        self.stats.beam_share = self.beam_share.unwrap_or(1.0);
        let mut photons = Vec::new();
        let mut beams = Vec::new();
        // splats are summed in chunk order: the image is the same for any thread count
        let (w, h) = (world.camera.width as usize, world.camera.height as usize);
        self.light_image.clear();
        let mut splats = Vec::new();
        for (p, b, sp) in parts {
            photons.extend(p);
            beams.extend(b);
            if !sp.is_empty() {
                if self.light_image.is_empty() {
                    self.light_image.resize(w * h * 3, 0.0);
                }
                for s in &sp {
                    let o = s.pixel as usize * 3;
                    for k in 0..3 {
                        self.light_image[o + k] += s.rgb[k];
                    }
                }
                splats.extend(sp.into_iter().filter(|s| s.energy > 0.0).map(|s| (s.cell, s.energy)));
            }
        }
        let beam_cap = (self.config.memory_limit_bytes / 2 / (super::beams::BYTES_PER_BEAM + 64)).max(1);
        beams.truncate(beam_cap);
        self.stats.beams_last_pass = beams.len() as u64;
        self.stats.beams_stored += beams.len() as u64;
        self.beams = BeamMap::build(beams);
        let cap_stored = cap as usize;
        photons.truncate(cap_stored);
        let stored = photons.len() as u64;
        let energy: f64 = photons.iter().map(|p| p.energy() as f64).sum();
        self.mean_energy = if stored > 0 && energy > 0.0 { (energy / stored as f64) as f32 } else { 1.0 };
        self.map = PhotonMap::build(photons, self.cell_size).unwrap_or_else(|_| PhotonMap::build(Vec::new(), self.cell_size).expect("empty map"));
        self.weight = self.atlas.photon_weight(spp as u64 * rendered);
        self.stats.photons_emitted += n;
        self.stats.photons_stored += stored;
        self.stats.photons_last_pass = stored;
        self.stats.peak_map_bytes = self.stats.peak_map_bytes.max(self.map.memory_bytes() + self.beams.memory_bytes());
        self.vis.clear();
        // the connections that reached the camera are this pass's first guiding signal
        let inv_mean = 1.0 / self.mean_energy.max(1e-30);
        self.stats.light_connections += splats.len() as u64;
        for (cell, energy) in splats {
            self.vis.record(cell, VisibilityKind::Volume, energy * inv_mean);
        }
        true
    }

    /// The light-traced image of the pass just traced (RGB per pixel over the whole image,
    /// empty when nothing connected) and the weight it takes in this pass (the photons').
    pub fn light_image(&self) -> (&[f32], f32) {
        (&self.light_image, self.weight)
    }

    /// Sets the pixel filter and data window the light-traced splats land on.
    pub fn set_image(&mut self, filter: crate::filter::PixelFilter, window: [u32; 4]) {
        if let Some(lt) = self.light_tracer.as_mut() {
            lt.set_image(filter, window);
        }
    }

    /// Whether photon stretches in medium `m` are connected to the camera, so that the camera's
    /// first stretch in it gathers no beams.
    #[inline]
    pub fn light_traced(&self, m: usize) -> bool {
        self.light_tracer.as_ref().is_some_and(|lt| lt.covers(m))
    }

    /// Whether this pass's beams are to be measured by a probe before its pixels render: the
    /// first pass after a (re)start, when the measured rule is on and the pass has beams
    /// (see [`CausticsConfig::beams_per_query`]). The render loop then calls
    /// [`Self::begin_probe`], traces [`PROBE_SAMPLES`] camera samples whose results it
    /// discards, and calls [`Self::end_probe`].
    pub fn wants_probe(&self) -> bool {
        self.beam_share.is_none() && self.config.beams_per_query.is_finite() && !self.beams.is_empty()
    }

    /// Starts counting the beams gathering queries meet; they record no guiding signal meanwhile.
    pub fn begin_probe(&mut self) {
        self.probing = true;
        for c in &self.probe {
            c.store(0, Ordering::Relaxed);
        }
    }

    /// Ends the probe: sets the share of the beams kept from what it counted, and thins this
    /// pass's beams to it. `complete`: whether every probe sample was traced (a probe cut short
    /// measures nothing and the next pass probes again).
    pub fn end_probe(&mut self, complete: bool) {
        self.probing = false;
        if !complete {
            return;
        }
        let [_, meeting, met] = self.probe_counts();
        let m = if meeting > 0 { met as f64 / meeting as f64 } else { 0.0 };
        let q = beam_share_for(self.config.beams_per_query, m);
        self.beam_share = Some(q);
        self.stats.beam_share = q;
        self.stats.beams_per_query = Some(m as f32);
        if q < 1.0 {
            let before = self.beams.len() as u64;
            self.beams = std::mem::take(&mut self.beams).thin(q);
            let after = self.beams.len() as u64;
            self.stats.beams_stored -= before - after;
            self.stats.beams_last_pass = after;
        }
    }

    /// The distance beyond which a beam query in medium `m` drawn with `u` skips beams
    /// (unbiased culling; see [`Self::gather_beams`]).
    pub fn beam_cull_distance(&self, world: &World, m: usize, lambda: &SampledWavelengths, u: f32) -> f32 {
        cull_distance(&world.media[m], lambda, &mut StreamRng::new(u, BEAM_STREAM)).1
    }

    /// The probe's counts so far: gathering queries, those that met a beam, beams met.
    pub fn probe_counts(&self) -> [u64; 3] {
        self.probe.each_ref().map(|c| c.load(Ordering::Relaxed))
    }

    /// Drops a cancelled pass's visibility (the atlas is unchanged; its photons are replaced
    /// by the next pass's).
    pub fn end_pass_cancelled(&mut self) {
        self.vis.clear();
    }

    /// Learns the guiding table from the pass's visibility signal.
    pub fn end_pass(&mut self, camera_samples: u64) {
        let _ = self.atlas.end_pass(&self.vis, camera_samples.max(1));
        self.stats.passes += 1;
        self.stats.disk_area_ratio = self.atlas.disk_area_ratio();
        self.stats.disk_refits = self.atlas.refits();
    }

    /// One photon path; stored photons are appended to `out`. `keep_beam`: the share of
    /// stretches kept as beams and the scale of their widths.
    #[allow(clippy::too_many_arguments)]
    fn trace_photon(&self, world: &World, seed: u64, pass: u32, index: u32, n_emitted: u64, keep_beam: (f32, f32), out: &mut (Vec<Photon>, Vec<Beam>, Vec<Splat>)) {
        let mut smp = PixelSampler::new(seed ^ 0x0ca5_71c5_9e37_79b9, 0xffff_fff0, pass, index);
        let ua = smp.get2d();
        let mut s = self.atlas.sample([ua.x, ua.y]);
        let li = self.atlas_lights[s.light as usize];
        let light = &world.lights[li];
        let mut lambda = color::sample_wavelengths(smp.get1d());
        let (t0, t1) = world.camera.shutter;
        let time = t0 + (t1 - t0) * smp.get1d();
        let u_pos = smp.get2d();
        let u_dir = smp.get2d();
        let u_stream = smp.get1d();
        let (u_mix, u_disk) = (smp.get1d(), smp.get2d());
        let Some(ls) = light.sample_le(u_pos, u_dir, &lambda, time, &self.disk) else { return };
        // the photon's footprint: a width at the start and a growth per unit length
        let (mut width0, mut spread) = (0.0f32, 0.0f32);
        let (origin, dir, power, mut stack) = match self.atlas.lights()[s.light as usize] {
            AtlasLight::Local { .. } => {
                let Some(e) = self.atlas.emit(&s, ls.ray_o) else { return };
                // the atlas aims the photon: the light's emission is taken along that aim
                let l = light.le_towards(&ls, e.dir, time, &lambda);
                let power = if ls.delta_pos {
                    l / e.pdf
                } else {
                    let cos = e.dir.dot(ls.n_light);
                    if !(cos > 0.0) {
                        return;
                    }
                    l * (cos / (ls.pdf_pos * e.pdf))
                };
                let n = if ls.delta_pos { Vec3::ZERO } else { ls.n_light * ls.n_light.dot(e.dir).signum() };
                spread = (1.0 / (std::f32::consts::PI * n_emitted as f32 * e.pdf)).sqrt();
                (offset_ray_origin(e.origin, point_error(e.origin), n), e.dir, power, self.light_stack[s.light as usize])
            }
            AtlasLight::Distant { to_light, .. } => {
                let Some(e) = self.atlas.emit_mixture(&mut s, Vec3::ZERO, u_mix, [u_disk.x, u_disk.y]) else { return };
                let d = ls.ray_d;
                let cos = d.dot(-to_light);
                if !(cos > 0.0) {
                    return;
                }
                let power = if ls.delta_dir { ls.l / e.pdf } else { ls.l * (cos / (ls.pdf_dir * e.pdf)) };
                width0 = (1.0 / (std::f32::consts::PI * n_emitted as f32 * e.pdf)).sqrt();
                (e.origin - d * (2.0 * self.scene_radius), d, power, InteriorStack::default())
            }
        };
        let mut beta = power / n_emitted as f32;
        if !beta.is_finite() || beta.is_black() {
            return;
        }
        stack.at_wavelengths(world, &lambda);
        let mut ray = Ray { o: origin, d: dir, t_max: f32::INFINITY, time };
        let mut first = true;
        let mut bounces = 0u32;
        let mut stream = StreamRng::new(u_stream, index);
        let mut null_events = 0u32;
        let mut travelled = 0.0f32;
        // the normal of the surface the current stretch left (zero before the first)
        let mut from_ng = Vec3::ZERO;
        let (keep_beam, beam_scale) = keep_beam;
        loop {
            let Some(hit) = world.intersect_path(&ray) else { return };
            let s_hit = world.surface(&ray, &hit);
            if let Some(m) = stack.medium() {
                // the light's links decide whether it lights the gprim this medium fills
                let linked = stack.medium_owner().is_none_or(|o| world.illuminates(li, o));
                if let Some(lt) = self.light_tracer.as_ref().filter(|lt| linked && bounces > 0 && lt.covers(m)) {
                    let u = stream.next_f32();
                    let mut rng = || stream.next_f32();
                    lt.connect(world, ray.o, ray.d, hit.t, m, beta, &lambda, time, s.cell, u, &mut rng, |p_b| self.photon_weight_mis(s.cell, p_b), &mut out.2);
                }
                if linked && bounces > 0 && keep_beam > 0.0 && self.beam_media[m] {
                    let draw = stream.next_f32();
                    if draw < keep_beam {
                        let width = ((width0 + spread * (travelled + 0.5 * hit.t)) * beam_scale).max(self.beam_width_floor);
                        if let Ok(photon) = Photon::new(ray.o, -ray.d, ray.d, beta / keep_beam, &lambda, s.cell) {
                            out.1.push(Beam { photon, dir: ray.d, len: hit.t, width, caps: [super::beams::cap(ray.d, from_ng), super::beams::cap(ray.d, s_hit.ng)], medium: m as u32, rank: (draw / keep_beam).min(ONE_MINUS_EPSILON) });
                        }
                    }
                }
                let mut rng = || stream.next_f32();
                let (ro, rd) = world.media[m].rest_ray(ray.time, ray.o, ray.d);
                beta *= world.media[m].transmittance(ro, rd, hit.t, &mut rng, &lambda);
                if beta.is_black() {
                    return;
                }
            }
            // the next stretch starts on this surface
            from_ng = s_hit.ng;
            travelled += hit.t;
            let inst = hit.instance as usize;
            let roles = world.caustic_instances[inst];
            let front = ray.d.dot(s_hit.ng) < 0.0;
            let pass_through = |ray: &mut Ray| {
                ray.o = s_hit.origin_on(if front { -s_hit.ng } else { s_hit.ng });
                ray.t_max = f32::INFINITY;
            };
            // a crossing without scattering: counted (at most 128 per photon), the ray goes on
            macro_rules! cross_on {
                () => {{
                    null_events += 1;
                    if null_events > 128 {
                        return;
                    }
                    pass_through(&mut ray);
                    continue;
                }};
            }
            // surfaces transparent to paths after a non-specular bounce are not seen by light
            // paths that end on receivers behind them (camera paths gathering there have
            // bounced): the photon goes on. A receiver so tagged still takes the photon that
            // arrives on its outside: the camera sees it directly, before any bounce
            if matches!(roles.transparency, CausticsTransparency::AfterDiffuse | CausticsTransparency::All) {
                if front && !roles.caster && roles.receiver && bounces > 0 && world.illuminates(li, hit.instance) {
                    let (bsdf, _) = world.bsdf(world.instances[inst].material, &s_hit, &lambda, stack.ior(), 1.0);
                    if !bsdf.is_specular() {
                        if let Ok(p) = Photon::new(s_hit.p, -ray.d, s_hit.ng, beta, &lambda, s.cell) {
                            out.0.push(p);
                        }
                    }
                }
                cross_on!();
            }
            // a volume's box is no surface: the photon goes on in (or out of) its medium, the
            // transmittance above accounting for the volume (it is not the caster the photon
            // was aimed at, which still lies ahead)
            if world.materials[world.instances[inst].material].is_medium_boundary() {
                stack.cross(world, &s_hit, front, &lambda);
                cross_on!();
            }
            if first {
                if self.instance_group[inst] != s.caster {
                    return;
                }
                first = false;
            }
            let mat_i = world.instances[inst].material;
            let opacity = world.opacity(mat_i, &s_hit);
            if opacity < 1.0 && stream.next_f32() >= opacity {
                cross_on!();
            }
            let boundary = classify_boundary(world, &s_hit, front, &stack, &lambda);
            if let Boundary::False = boundary {
                stack.cross(world, &s_hit, front, &lambda);
                cross_on!();
            }
            if let Boundary::Real { .. } = boundary {
                if world.materials[mat_i].dielectric().is_some_and(|d| d.dispersion.is_some()) && !lambda.secondary_terminated() {
                    lambda.terminate_secondary();
                }
            }
            let eta = match &boundary {
                Boundary::Real { eta, .. } => *eta,
                _ => 1.0,
            };
            let (bsdf, frame) = world.bsdf(mat_i, &s_hit, &lambda, stack.ior(), eta);
            let frame = if s_hit.ns.dot(s_hit.ng) < 0.0 { Frame::from_normal(-s_hit.ns) } else { frame };
            let wo_w = -ray.d;
            if !roles.caster {
                if bounces > 0 && roles.receiver && !bsdf.is_specular() && world.illuminates(li, hit.instance) {
                    if let Ok(p) = Photon::new(s_hit.p, wo_w, s_hit.ng, beta, &lambda, s.cell) {
                        out.0.push(p);
                    }
                }
                return;
            }
            bounces += 1;
            if bounces > MAX_PHOTON_BOUNCES {
                return;
            }
            let wo = frame.to_local(wo_w);
            let uc = stream.next_f32();
            let u2 = Vec2::new(stream.next_f32(), stream.next_f32());
            let Some(bs) = bsdf.sample_f(wo, uc, u2, TransportMode::Importance) else { return };
            if !(bs.pdf > 0.0) || bs.f.is_black() {
                return;
            }
            let wi_w = frame.to_world(bs.wi);
            let out_front = wi_w.dot(s_hit.ng) > 0.0;
            if (bs.wi.z > 0.0) != out_front {
                return;
            }
            // importance transport: the shading-normal correction |wo·ng| / |wi·ng| … kept at 1
            beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
            // the light's diffuse / specular multipliers apply where its emission is first
            // gathered, as in the path tracer: at this first bounce
            let r = world.light_response[li];
            if bounces == 1 && !r.is_physical() {
                let share = if bs.is_specular() { SampledSpectrum::ZERO } else { crate::integrator::diffuse_share(&bsdf, wo, bs.wi) };
                beta *= share * r.diffuse + (SampledSpectrum::ONE - share) * r.specular;
            }
            if !beta.is_finite() || beta.is_black() {
                return;
            }
            if bs.is_transmission() {
                if let Boundary::Real { enter, .. } = boundary {
                    if front {
                        stack.push(enter);
                    } else {
                        stack.remove(s_hit.instance);
                    }
                }
            }
            ray = Ray { o: s_hit.origin_on(if out_front { s_hit.ng } else { -s_hit.ng }), d: wi_w, t_max: f32::INFINITY, time };
        }
    }

    /// The caster group of an instance, if it casts caustics.
    #[inline]
    pub fn group_of(&self, instance: u32) -> Option<u32> {
        self.instance_group.get(instance as usize).copied().filter(|&g| g != NO_GROUP)
    }

    /// The path tracer's weight `W_l` for light `light` reached through a caustic chain whose
    /// last caster surface is `last` (1 where photons do not carry that transport).
    #[inline]
    pub fn path_weight(&self, light: usize, chain: &Chain) -> f32 {
        if chain.last == u32::MAX {
            return 1.0;
        }
        let a = self.light_atlas.get(light).copied().unwrap_or(NO_GROUP);
        let Some(g) = self.group_of(chain.last) else { return 1.0 };
        if a == NO_GROUP {
            return 1.0;
        }
        self.pair_light_pdf(a, g).map_or(1.0, |pl| w_light(chain.p_b, pl, self.config.mis_photon_count))
    }

    /// `P_l` of the (atlas light, caster group) pair; None where the pair shoots no photons.
    #[inline]
    fn pair_light_pdf(&self, light: u32, group: u32) -> Option<f32> {
        Some(self.pair_pl[light as usize * self.n_groups + group as usize]).filter(|pl| !pl.is_nan())
    }

    fn photon_weight_mis(&self, cell: u32, p_b: f32) -> f32 {
        let Some(pair) = self.atlas.pair_of_cell(cell) else { return 0.0 };
        self.pair_light_pdf(pair.light, pair.caster).map_or(0.0, |pl| 1.0 - w_light(p_b, pl, self.config.mis_photon_count))
    }

    /// Lookup radius for a path whose footprint has width `width` at this vertex.
    #[inline]
    pub fn radius(&self, width: f32) -> f32 {
        (width * self.config.radius_pixels).max(0.1 * self.beam_width_floor)
    }

    /// Radiance towards `wo` (local) at a non-specular receiver vertex from the photons within
    /// `radius`: one photon chosen in proportion to kernel × energy (`u` seeds the choice),
    /// weighted by the approximate MIS and the pass's photon weight. `throughput` (the camera
    /// path's average weight) scales the visibility signal the photons in reach record.
    #[allow(clippy::too_many_arguments)]
    pub fn gather(&self, p: Vec3, ng: Vec3, radius: f32, bsdf: &Bsdf, frame: &Frame, wo: Vec3, lambda: &SampledWavelengths, throughput: f32, u: f32) -> SampledSpectrum {
        if self.map.is_empty() {
            return SampledSpectrum::ZERO;
        }
        let wo_w = frame.to_world(wo);
        let n = if ng.dot(wo_w) >= 0.0 { ng } else { -ng };
        // where photons are dense the radius shrinks so that about LOOKUP_PHOTONS are in reach
        // (wide lookups after diffuse bounces would otherwise visit thousands)
        // and it never spans more than a few grid cells, which bounds the cells a lookup visits
        let radius = radius.min(MAX_RADIUS_CELLS * self.cell_size);
        let count = self.map.bucket_count(p);
        let radius = if count as f32 > LOOKUP_PHOTONS {
            radius.min(self.cell_size * (LOOKUP_PHOTONS / (std::f32::consts::PI * count as f32)).sqrt())
        } else {
            radius
        };
        let q = Query { position: p, normal: n, radius, normal_check: NormalCheck::SameSide { cos_min: 0.5 } };
        let mut total = 0.0f32;
        let mut chosen: Option<(Photon, f32)> = None;
        let mut rng = StreamRng::new(u, 0x9a7e);
        // visibility: the photon's energy relative to the pass's mean, times the camera path's
        // throughput, times the kernel relative to one grid cell's
        let vis_scale = throughput * (self.cell_size * self.cell_size) / (radius * radius * self.mean_energy.max(1e-30));
        let record = throughput > 0.0 && vis_scale.is_finite() && !self.probing;
        self.map.for_each_in_radius(&q, |ph, k| {
            let e = ph.energy();
            let w = e * k;
            if !(w > 0.0) {
                return;
            }
            if record {
                self.vis.record(ph.cell, VisibilityKind::Surface, e * vis_scale);
            }
            if reservoir_take(&mut total, w, rng.next_f32()) {
                chosen = Some((*ph, w));
            }
        });
        let Some((ph, w)) = chosen else { return SampledSpectrum::ZERO };
        if self.weight <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let wi = frame.to_local(ph.wi());
        let f = bsdf.f(wo, wi, TransportMode::Radiance);
        if f.is_black() {
            return SampledSpectrum::ZERO;
        }
        let p_b = bsdf.pdf(wo, wi, TransportMode::Radiance);
        let mis = self.photon_weight_mis(ph.cell, p_b);
        if mis <= 0.0 {
            return SampledSpectrum::ZERO;
        }
        let lookup = self.kernel.at(lambda);
        let k = 1.0 / (std::f32::consts::PI * radius * radius);
        f * ph.spectral_flux(&lookup) * (k * total / w * mis * self.weight)
    }

    /// This pass's photon beams.
    pub fn beam_map(&self) -> &BeamMap {
        &self.beams
    }

    /// Whether camera rays in medium `m` gather photon beams.
    #[inline]
    pub fn has_beams(&self, m: usize) -> bool {
        !self.beams.is_empty() && self.beam_media.get(m).copied().unwrap_or(false)
    }

    /// Whether a volume vertex in medium `m` starts a caustic chain (beams carry that light).
    #[inline]
    pub fn beams_in(&self, m: usize) -> bool {
        self.beam_media.get(m).copied().unwrap_or(false)
    }

    /// Radiance scattered towards the camera ray `a + t·c`, t ∈ [0, t_max], in medium `m`
    /// from the photon beams (see [`super::beams`]), before the camera path's throughput.
    /// `fp` is the ray's pixel footprint at `a`; `u` draws the kernel width
    /// and seeds tracking in media that need it.
    #[allow(clippy::too_many_arguments)]
    pub fn gather_beams(&self, world: &World, a: Vec3, c: Vec3, t_max: f32, m: usize, lambda: &SampledWavelengths, throughput: f32, fp: &Footprint, u: f32) -> SampledSpectrum {
        let med = &world.media[m];
        let at = crate::medium::MediumAt::new(med, lambda);
        let lookup = self.kernel.at(lambda);
        let mut rng_state = StreamRng::new(u, BEAM_STREAM);
        let sq = u.sqrt();
        let mut sum = SampledSpectrum::ZERO;
        let record = throughput > 0.0 && !self.probing;
        let mut met = 0u64;
        let inv_mean = 1.0 / self.mean_energy.max(1e-30);
        // unbiased culling (seed 002 §6.2.2): beams beyond a distance drawn with half the
        // medium's mean extinction are skipped, and those kept are weighted by the inverse of
        // the probability e^{−σc t} of reaching them (the camera transmittance e^{−σt t} keeps the
        // weight below one, so culling adds no fireflies)
        let (sigma_c, t_cull) = cull_distance(med, lambda, &mut rng_state);
        let width = |wb: f32, t: f32| {
            let wp = fp.width_at(t).min(wb);
            wp + (wb - wp) * sq
        };
        // Each beam's point on its chord, drawn from the beam's index in proportion to what
        // changes along it in homogeneous water: the two transmittances and the culling weight,
        // e^{−σt (1 + c·k₀) t} · e^{σc t}, the light's depth into the beam growing by c·k₀ per
        // unit along the ray (a long chord, nearly parallel to the beam or through a wide short
        // one, then adds no noise of its own).
        let u_chord = rng_state.next_f32();
        let rate = 2.0 * sigma_c;
        let point = |beam: u32, t0: f32, t1: f32, ck: f32| super::beams::sample_exponential(t0, t1, rate * (1.0 + ck) - sigma_c, StreamRng::new(u_chord, beam).next_f32());
        self.beams.for_each_near(a, c, t_max.min(t_cull), width, point, |near, is_met, chord| {
            // the tests the piece answers come before the beam's record is read
            if near.medium as usize != m {
                return;
            }
            if is_met {
                met += 1;
            }
            let Some(ch) = chord else { return };
            let b = near.beam();
            if record {
                self.vis.record(b.photon.cell, VisibilityKind::Volume, throughput * b.photon.energy() * inv_mean);
            }
            if self.weight <= 0.0 {
                return;
            }
            let x = a + c * ch.t;
            let (wo, wi) = (-c, -b.dir);
            let phase = med.phase(x);
            let fp = phase.eval(wo, wi);
            if !(fp > 0.0) {
                return;
            }
            // a phase function samples its own density: its pdf is `fp`
            let mis = self.photon_weight_mis(b.photon.cell, fp);
            if mis <= 0.0 {
                return;
            }
            let mut rng = || rng_state.next_f32();
            // along the beam from where the point's light entered it, and from the point back
            // along the camera ray
            let tr = at.transmittance_of_two((x - b.dir * ch.s, b.dir, ch.s), (a, c, ch.t), &mut rng);
            let w = near.width;
            let k = (sigma_c * ch.t).exp() * ch.inv_pdf / (std::f32::consts::PI * w * w);
            sum += b.photon.spectral_flux(&lookup) * at.sigma_s_at(x) * tr * (fp * k * mis);
        });
        if self.probing {
            self.probe[0].fetch_add(1, Ordering::Relaxed);
            if met > 0 {
                self.probe[1].fetch_add(1, Ordering::Relaxed);
                self.probe[2].fetch_add(met, Ordering::Relaxed);
            }
        }
        sum * self.weight
    }

}

/// Salt of a beam query's random stream.
const BEAM_STREAM: u32 = 0xbea5;

/// The culling of a beam query (seed 002 §6.2.2): the rate σc (half the medium's mean
/// majorant) and the distance drawn with it, the stream's first number.
fn cull_distance(med: &crate::medium::Medium, lambda: &SampledWavelengths, rng: &mut StreamRng) -> (f32, f32) {
    let sigma_c = 0.5 * med.majorant(lambda).average();
    let xi = rng.next_f32();
    (sigma_c, if sigma_c > 0.0 { -(1.0 - xi).ln() / sigma_c } else { f32::INFINITY })
}

/// Share of the beams kept when gathering queries that meet any meet `m` on average and
/// should meet `target` (see [`CausticsConfig::beams_per_query`]).
pub fn beam_share_for(target: f32, m: f64) -> f32 {
    if m > target as f64 { (target as f64 / m) as f32 } else { 1.0 }
}

/// Share of the beams an image of `pixels` pixels keeps (see
/// [`CausticsConfig::beam_thinning_pixels`]).
pub fn beam_thinning(thinning_pixels: f32, pixels: u64) -> f32 {
    if pixels as f64 > thinning_pixels as f64 { (thinning_pixels as f64 / pixels as f64).sqrt() as f32 } else { 1.0 }
}

/// Width of a camera ray's footprint at the camera (orthographic) and its angular growth
/// (perspective), measured between the rays through the image centre and one pixel over.
fn pixel_footprint(world: &World, width: u32, height: u32) -> (f32, f32) {
    let c = Vec2::new(width as f32 * 0.5, height as f32 * 0.5);
    let a = world.camera.generate_ray(c, Vec2::splat(0.5), 0.0);
    let b = world.camera.generate_ray(c + Vec2::X, Vec2::splat(0.5), 0.0);
    let spread = crate::math::angle_between(a.d, b.d);
    let w0 = (a.o - b.o).length();
    (if w0.is_finite() { w0 } else { 0.0 }, if spread.is_finite() { spread } else { 0.0 })
}

/// What 16 × 16 camera rays through the image meet: the distances to the receivers they see
/// (through casters and other non-receivers, as camera paths see receivers) and the box of the
/// points within a photon's reach of their stretches through beam media.
struct CameraProbes {
    receivers: Vec<f32>,
    media_lo: Vec3,
    media_hi: Vec3,
}

/// The distance over which light in `medium` falls to 10⁻³ (its extinction averaged over the
/// visible wavelengths; a depth-varying medium's largest), at most `cap`: beams farther than this
/// from a camera ray's stretch through the medium, or photons that travel farther in it, bring
/// the camera little.
fn medium_reach(medium: &crate::medium::Medium, cap: f32) -> f32 {
    let n = 8;
    let mean = (0..n).map(|k| medium.majorant(&SampledWavelengths::sample_uniform((k as f32 + 0.5) / n as f32)).average()).sum::<f32>() / n as f32;
    let r = 1000f32.ln() / mean;
    if r.is_finite() && r > 0.0 { r.min(cap) } else { cap }
}

/// `start`: the interior stack at the camera.
fn camera_probes(world: &World, width: u32, height: u32, start: &InteriorStack, beam_media: &[bool], cap: f32) -> CameraProbes {
    let time = world.camera.shutter.0;
    let lambda = SampledWavelengths::sample_uniform(0.5);
    let reach: Vec<f32> = world.media.iter().zip(beam_media).map(|(m, &b)| if b { medium_reach(m, cap) } else { 0.0 }).collect();
    let mut out = CameraProbes { receivers: Vec::new(), media_lo: Vec3::splat(f32::INFINITY), media_hi: Vec3::splat(f32::NEG_INFINITY) };
    for j in 0..16 {
        for i in 0..16 {
            let raster = Vec2::new((i as f32 + 0.5) / 16.0 * width as f32, (j as f32 + 0.5) / 16.0 * height as f32);
            let cr = world.camera.generate_ray(raster, Vec2::splat(0.5), 0.0);
            let mut ray = Ray { o: cr.o, d: cr.d, t_max: cr.t_max, time };
            let mut stack = *start;
            let mut travelled = 0.0;
            for _ in 0..8 {
                let hit = world.accel.intersect(&ray);
                if let Some(m) = stack.medium().filter(|&m| beam_media.get(m).copied().unwrap_or(false)) {
                    let r = reach[m];
                    let t = hit.as_ref().map_or(r, |h| h.t.min(r));
                    for p in [ray.o, ray.o + ray.d * t] {
                        out.media_lo = out.media_lo.min(p - Vec3::splat(r));
                        out.media_hi = out.media_hi.max(p + Vec3::splat(r));
                    }
                }
                let Some(hit) = hit else { break };
                travelled += hit.t;
                let roles = world.caustic_instances[hit.instance as usize];
                if roles.receiver && !roles.caster {
                    out.receivers.push(travelled);
                    break;
                }
                let s = world.surface(&ray, &hit);
                stack.cross(world, &s, ray.d.dot(s.ng) < 0.0, &lambda);
                ray = Ray { o: s.origin_towards(ray.d), d: ray.d, t_max: f32::INFINITY, time: ray.time };
            }
        }
    }
    out
}

/// World bounds of an instance at the shutter's open.
fn instance_bounds(world: &World, instance: u32) -> Option<(Vec3, Vec3)> {
    let info = &world.instances[instance as usize];
    let xf = world.accel.instance_transform(instance, world.camera.shutter.0);
    let mut lo = Vec3::splat(f32::INFINITY);
    let mut hi = Vec3::splat(f32::NEG_INFINITY);
    match info.geometry {
        crate::scene::GeometryRef::Mesh(m) => {
            for p in &world.meshes.get(m)?.positions {
                let q = xf.transform_point3(*p);
                lo = lo.min(q);
                hi = hi.max(q);
            }
        }
        crate::scene::GeometryRef::Spheres(_) => {
            let (a, b) = world.accel.bounds();
            lo = a;
            hi = b;
        }
    }
    (lo.x <= hi.x && lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::reservoir_take;
    use crate::testing::chi2::{gamma_q, TestRng};

    // The stochastic lookup's one-pass selection keeps each photon with probability w / Σw:
    // χ² of the kept counts against those probabilities (8 weights spanning 50×, 200 000 draws;
    // 7 degrees of freedom, rejected below p = 0.001).
    #[test]
    fn reservoir_selection_follows_the_weights() {
        let w = [0.1f32, 5.0, 0.7, 2.0, 0.3, 1.0, 4.0, 0.9];
        let sum: f32 = w.iter().sum();
        let n = 200_000;
        let mut counts = [0u32; 8];
        let mut rng = TestRng::new(11);
        for _ in 0..n {
            let mut total = 0.0;
            let mut kept = usize::MAX;
            for (i, &wi) in w.iter().enumerate() {
                if reservoir_take(&mut total, wi, rng.next_f32()) {
                    kept = i;
                }
            }
            counts[kept] += 1;
        }
        let chi2: f64 = counts.iter().zip(&w).map(|(&c, &wi)| {
            let e = n as f64 * (wi / sum) as f64;
            (c as f64 - e).powi(2) / e
        }).sum();
        let p = gamma_q(3.5, chi2 / 2.0);
        assert!(p > 1e-3, "χ² {chi2:.1}, p {p:.2e}, counts {counts:?}");
    }
}
