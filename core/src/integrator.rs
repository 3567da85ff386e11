//! The unidirectional volumetric path tracer: next-event estimation with multiple importance
//! sampling (power heuristic) at surfaces and in media, spectral free-flight sampling in
//! homogeneous media, nested dielectrics resolved by priority, stochastic opacity, Russian
//! roulette, and the AOVs of the first vertex (depth, normal, albedo, primId) and the
//! light-path split (`tide:diffuse`, `tide:specular`, `tide:transmission`, `tide:volume`,
//! `tide:emission`), which sums to `color`.

use crate::accel::Ray;
use crate::bsdf::{flags, Bsdf, TransportMode};
use crate::film::SampleValue;
use crate::light::LightSampleContext;
use crate::math::{power_heuristic, Frame};
use crate::sampler::{PixelSampler, StreamRng};
use crate::spectrum::{color, SampledSpectrum, SampledWavelengths};
use crate::medium::DistanceSample;
use crate::world::{SurfaceHit, World};
use glam::{Vec2, Vec3};

/// Index of each light-path category in `SampleValue::split`.
const DIFFUSE: usize = 0;
const SPECULAR: usize = 1;
const TRANSMISSION: usize = 2;
const VOLUME: usize = 3;
const EMISSION: usize = 4;
const CAUSTICS: usize = 5;
use crate::caustics::engine::{Caustics, Chain};
use crate::caustics::footprint::Footprint;
use crate::film::N_SPLIT;
use crate::scene::CausticsTransparency;

/// Path-state bits for switch-to-transparency (`tide:caustics:transparency`).
const AFTER_DIFFUSE: u8 = 1;
const AFTER_VOLUME: u8 = 2;

/// Whether a surface with transparency mode `t` is transparent to a path in state `flags`.
#[inline]
fn transparent(t: CausticsTransparency, flags: u8) -> bool {
    match t {
        CausticsTransparency::Off => false,
        CausticsTransparency::AfterDiffuse => flags & AFTER_DIFFUSE != 0,
        CausticsTransparency::Volume => flags & AFTER_VOLUME != 0,
        CausticsTransparency::All => flags != 0,
    }
}

const MAX_NESTING: usize = 8;
/// Surfaces a path may pass through without scattering (opacity cut-outs, overlapped
/// dielectric boundaries) before it is stopped.
const MAX_NULL_EVENTS: u32 = 128;

/// One closed dielectric object a path is inside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Interior {
    pub instance: u32,
    pub priority: i32,
    pub ior: f32,
    pub medium: Option<usize>,
    /// The box of a volume: takes no part in the priority and IOR, and its medium replaces
    /// every other while the path is inside (the latest entered box wins).
    pub volume: bool,
}

/// The objects a path is inside, for nested dielectrics with priorities (Schmidt & Budge
/// 2002): the highest priority wins (ties: the most recently entered); a boundary of an
/// object that does not win is a false interface the path passes straight through.
#[derive(Clone, Copy, Debug)]
pub struct InteriorStack {
    items: [Interior; MAX_NESTING],
    len: usize,
}

impl Default for InteriorStack {
    fn default() -> Self {
        InteriorStack { items: [Interior { instance: u32::MAX, priority: i32::MIN, ior: 1.0, medium: None, volume: false }; MAX_NESTING], len: 0 }
    }
}

impl InteriorStack {
    /// The winning object (highest priority, latest among equals).
    pub fn top(&self) -> Option<&Interior> {
        let mut best: Option<&Interior> = None;
        for it in self.items[..self.len].iter().filter(|i| !i.volume) {
            if best.is_none_or(|b| it.priority >= b.priority) {
                best = Some(it);
            }
        }
        best
    }
    pub fn ior(&self) -> f32 {
        self.top().map_or(1.0, |t| t.ior)
    }
    pub fn medium(&self) -> Option<usize> {
        self.volume_medium().or_else(|| self.top().and_then(|t| t.medium))
    }
    /// The gprim whose interior medium the path travels in (the volume box entered last, else
    /// the winning object): light links apply to its scattering vertices. None outside any
    /// (e.g. a camera medium named by relationship alone).
    pub fn medium_owner(&self) -> Option<u32> {
        let it = self.items[..self.len].iter().rev().find(|i| i.volume && i.medium.is_some()).or_else(|| self.top().filter(|t| t.medium.is_some()))?;
        (it.instance != u32::MAX).then_some(it.instance)
    }
    /// The medium of the volume box entered last, if the path is inside one.
    pub fn volume_medium(&self) -> Option<usize> {
        self.items[..self.len].iter().rev().find(|i| i.volume).and_then(|i| i.medium)
    }
    pub fn contains(&self, instance: u32) -> bool {
        self.items[..self.len].iter().any(|i| i.instance == instance)
    }
    pub fn push(&mut self, it: Interior) {
        if self.len < MAX_NESTING {
            self.items[self.len] = it;
            self.len += 1;
        }
    }
    pub fn remove(&mut self, instance: u32) {
        if let Some(k) = self.items[..self.len].iter().rposition(|i| i.instance == instance) {
            self.items.copy_within(k + 1..self.len, k);
            self.len -= 1;
        }
    }
    /// Crosses the surface at `s` without scattering (a false boundary, a surface switched to
    /// transparency): entering pushes the object (a dielectric, or a volume's box), leaving
    /// removes it; other surfaces leave the stack as it is.
    pub(crate) fn cross(&mut self, world: &World, s: &SurfaceHit, front: bool, lambda: &SampledWavelengths) {
        if !front {
            self.remove(s.instance);
            return;
        }
        let mat = &world.materials[world.instances[s.instance as usize].material];
        if let Some(d) = mat.dielectric() {
            self.push(Interior { instance: s.instance, priority: d.priority, ior: d.ior_at(lambda), medium: mat.interior_medium, volume: false });
        } else if mat.is_medium_boundary() {
            self.push(Interior { instance: s.instance, priority: i32::MIN, ior: 1.0, medium: mat.interior_medium, volume: true });
        }
    }

    /// Sets the index of every dispersive object on the stack to its index at the hero
    /// wavelength of `lambda`: a stack found once for all paths (the camera's, a light's) holds
    /// the objects' constant indices.
    pub(crate) fn at_wavelengths(&mut self, world: &World, lambda: &SampledWavelengths) {
        for it in &mut self.items[..self.len] {
            // the water a camera is declared to sit in has no object (its constant index)
            let Some(info) = world.instances.get(it.instance as usize) else { continue };
            let mat = &world.materials[info.material];
            if let Some(d) = mat.dielectric().filter(|d| d.dispersion.is_some() && !it.volume) {
                it.ior = d.ior_at(lambda);
            }
        }
    }

    /// The stack as it would be after removing `instance`.
    pub fn without(&self, instance: u32) -> InteriorStack {
        let mut s = *self;
        s.remove(instance);
        s
    }
    pub fn len(&self) -> usize {
        self.len
    }
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }
}

/// How a dielectric boundary hit acts on a path.
pub(crate) enum Boundary {
    /// Not a dielectric: an ordinary surface in the current medium.
    Opaque,
    /// A boundary the path passes through unchanged (the stack is updated).
    False,
    /// A real interface: relative IOR (inside over outside) and the media on each side.
    Real { eta: f32, medium_front: Option<usize>, medium_back: Option<usize>, enter: Interior },
}

/// A volume's box is crossed unchanged (its medium is pushed or removed by the caller); inside
/// a box, both sides of any other interface are in the box's medium.
pub(crate) fn classify_boundary(world: &World, s: &SurfaceHit, front: bool, stack: &InteriorStack, lambda: &SampledWavelengths) -> Boundary {
    if world.materials[world.instances[s.instance as usize].material].is_medium_boundary() {
        return Boundary::False;
    }
    match (classify_dielectric(world, s, front, stack, lambda), stack.volume_medium()) {
        (Boundary::Real { eta, enter, .. }, Some(v)) => Boundary::Real { eta, medium_front: Some(v), medium_back: Some(v), enter },
        (b, _) => b,
    }
}

fn classify_dielectric(world: &World, s: &SurfaceHit, front: bool, stack: &InteriorStack, lambda: &SampledWavelengths) -> Boundary {
    let info = &world.instances[s.instance as usize];
    let mat = &world.materials[info.material];
    let Some(d) = mat.dielectric() else { return Boundary::Opaque };
    let me = Interior { instance: s.instance, priority: d.priority, ior: d.ior_at(lambda), medium: mat.interior_medium, volume: false };
    if front {
        // entering
        if let Some(top) = stack.top() {
            if top.priority > d.priority {
                return Boundary::False;
            }
        }
        Boundary::Real { eta: me.ior / stack.ior(), medium_front: stack.medium(), medium_back: me.medium, enter: me }
    } else {
        // leaving
        if stack.contains(s.instance) {
            if stack.top().is_some_and(|t| t.instance != s.instance) {
                return Boundary::False;
            }
            let after = stack.without(s.instance);
            Boundary::Real { eta: me.ior / after.ior(), medium_front: after.medium(), medium_back: me.medium, enter: me }
        } else {
            // leaving an object the path was not known to be inside (an open surface seen
            // from behind, or a camera placed inside without a medium): treat the back as
            // this object and the front as the current surroundings
            Boundary::Real { eta: me.ior / stack.ior(), medium_front: stack.medium(), medium_back: me.medium, enter: me }
        }
    }
}

/// Transmittance along a shadow ray from `o` (already offset) in direction `d` over `dist`,
/// starting in `medium`. Opaque and dielectric surfaces block; translucent preview surfaces
/// attenuate by their opacity, thin walls by what they let straight through; surfaces that
/// cast no shadows, or not those of `light` (its shadow-link collection), are skipped. `seed`
/// (a sample value) seeds the numbers a depth-varying medium's ratio tracking draws.
/// Crossing a volume's box switches the medium: to the box's on entering; on leaving, to the
/// medium of the boxes still entered (from `stack`, the path's, and those entered along the
/// ray), else to `medium` or, if the ray started inside a box, to the medium of `stack`'s
/// dielectrics.
/// A light's shadow controls (`UsdLuxShadowAPI`: colour, distance, falloff) apply here: the ray
/// looks for occluders only as far as they reach, and the shadowed part keeps its colour.
#[allow(clippy::too_many_arguments)]
fn shadow_transmittance(world: &World, light: usize, o: Vec3, d: Vec3, dist: f32, time: f32, medium: Option<usize>, stack: &InteriorStack, lambda: &SampledWavelengths, seed: f32, path_flags: u8) -> SampledSpectrum {
    match world.shadow_controls(light) {
        None => unshadowed_share(world, light, o, d, dist, time, medium, stack, lambda, seed, path_flags),
        Some(c) => {
            let reach = c.reach(dist, StreamRng::new(seed, 0x5d15).next_f32());
            c.shade(unshadowed_share(world, light, o, d, reach, time, medium, stack, lambda, seed, path_flags), lambda)
        }
    }
}

/// The direction and length of the shadow ray from `o` (a point stepped off a surface) to
/// the point `ls` sampled on a light: aimed at it from `o` itself (the sample's direction,
/// taken from the surface point, would pass beside it by the step), stopping short of it by
/// 10⁻⁴ of the way; an infinite light's direction, without end.
pub(crate) fn shadow_ray(o: Vec3, ls: &crate::light::LightLiSample) -> (Vec3, f32) {
    if !ls.dist.is_finite() {
        return (ls.wi, f32::INFINITY);
    }
    let to = ls.p_light - o;
    let len = to.length();
    if len > 0.0 && len.is_finite() {
        (to / len, len * (1.0 - 1e-4))
    } else {
        (ls.wi, 0.0)
    }
}

/// [`shadow_transmittance`] before the light's shadow controls.
#[allow(clippy::too_many_arguments)]
fn unshadowed_share(world: &World, light: usize, o: Vec3, d: Vec3, dist: f32, time: f32, medium: Option<usize>, stack: &InteriorStack, lambda: &SampledWavelengths, seed: f32, path_flags: u8) -> SampledSpectrum {
    let mut tr = SampledSpectrum::ONE;
    let mut origin = o;
    let mut remaining = dist;
    let mut stream = StreamRng::new(seed, 0x5ad0);
    let mut vols = *stack;
    let mut base = if stack.volume_medium().is_some() { stack.top().and_then(|t| t.medium) } else { medium };
    let (mut cur, mut seg_o, mut seg_len, mut switched) = (medium, o, 0.0f32, false);
    for _ in 0..MAX_NULL_EVENTS {
        let ray = Ray { o: origin, d, t_max: remaining, time };
        let Some(hit) = world.accel.intersect(&ray) else {
            break;
        };
        if world.is_light_geometry(light, &hit) {
            // the light itself, met a rounding short of the point sampled on it
            break;
        }
        let info = &world.instances[hit.instance as usize];
        let s = world.surface(&ray, &hit);
        seg_len += hit.t;
        let boundary = world.materials[info.material].is_medium_boundary() && info.casts_shadows && world.casts_shadow_of(light, hit.instance);
        let see_through = transparent(world.caustic_instances[hit.instance as usize].transparency, path_flags);
        // a volume's box, or a water body switched to transparency: the medium changes here
        let water_switch = see_through && world.materials[info.material].dielectric().is_some();
        if boundary || water_switch {
            // the segment so far was in `cur`; the surface's side decides what follows
            if let Some(m) = cur {
                let mut rng = || stream.next_f32();
                let (ro, rd) = world.media[m].rest_ray(time, seg_o, d);
                tr *= world.media[m].transmittance(ro, rd, seg_len.min(1e30), &mut rng, lambda);
            }
            let entering = d.dot(s.ng) < 0.0;
            if boundary {
                if entering {
                    vols.push(Interior { instance: hit.instance, priority: i32::MIN, ior: 1.0, medium: world.materials[info.material].interior_medium, volume: true });
                } else {
                    vols.remove(hit.instance);
                }
            } else {
                base = if entering { world.materials[info.material].interior_medium } else { None };
                tr *= world.transmission_tint(info.material, &s, lambda);
            }
            cur = vols.volume_medium().or(base);
            seg_o = s.origin_towards(d);
            seg_len = 0.0;
            switched = true;
        }
        if !(boundary || see_through || !info.casts_shadows || !world.casts_shadow_of(light, hit.instance)) {
            // a dielectric blocks but where an opaque part it is blended with is cut out; a
            // thin wall lets through what passes it unbent
            let opacity = world.opacity(info.material, &s);
            let pass = SampledSpectrum::splat(1.0 - opacity) + world.straight_through(info.material, &s, d, stack.ior(), lambda) * opacity;
            if pass.is_black() {
                return SampledSpectrum::ZERO;
            }
            tr *= pass;
        }
        origin = s.origin_towards(d);
        remaining -= hit.t;
        if remaining <= 0.0 {
            break;
        }
    }
    if let Some(m) = cur {
        let mut rng = || stream.next_f32();
        let len = if switched { seg_len + remaining.max(0.0) } else { dist };
        let (ro, rd) = world.media[m].rest_ray(time, seg_o, d);
        tr *= world.media[m].transmittance(ro, rd, len.min(1e30), &mut rng, lambda);
    }
    tr
}

/// The nearest analytic area light (index, t, point, normal) `ray` meets before `t_hit`; for
/// a camera ray (`camera`), only the lights the camera sees (the others are not there for it:
/// it goes on past them).
#[inline]
fn nearest_light_hit(world: &World, ray: &Ray, t_hit: f32, camera: bool) -> Option<(usize, f32, Vec3, Vec3)> {
    world.light_bvh.nearest(&world.lights, ray.o, ray.d, t_hit, ray.time, |li| !camera || world.lights[li].visible_to_camera())
}

/// The first-hit AOVs of camera ray `cr` by geometry alone: the first surface it meets that
/// the camera sees, past volume boxes, surfaces hidden from the camera and cut-outs (opacity
/// under ½), or an area light the camera sees before it. For a sample whose path scattered or
/// was absorbed in a medium before it met a surface (an underwater view of the sea floor, a
/// wall seen through fog): its normal and albedo are the surface's, as a sample's that the
/// medium let through; the pixel's depth and primId too where it is the pixel's first sample
/// (`first`, which gives those).
fn first_surface_aov(world: &World, cr: &crate::camera::CameraRay, lambda: &SampledWavelengths, first: bool, aov: &mut SampleValue) {
    use crate::render::Aov;
    let wanted = |a: Aov| world.aovs.contains(a);
    if !(wanted(Aov::Normal) || wanted(Aov::Albedo) || (first && world.aovs.keeps_first_hit())) {
        // nothing of it is kept: the camera ray is not traced again
        return;
    }
    let mut ray = Ray { o: cr.o, d: cr.d, t_max: cr.t_max, time: cr.time };
    let mut passed = 0.0f32;
    for _ in 0..MAX_NULL_EVENTS {
        let hit = world.intersect_path(&ray);
        let t_hit = hit.map_or(ray.t_max, |h| h.t);
        if let Some((_, t, _, _)) = nearest_light_hit(world, &ray, t_hit, true) {
            if first {
                aov.depth = (passed + t) * cr.depth_per_t + cr.depth_at_origin;
            }
            return;
        }
        let Some(hit) = hit else { return };
        let info = &world.instances[hit.instance as usize];
        let s = world.surface(&ray, &hit);
        let skip = world.materials[info.material].is_medium_boundary() || !info.visible_to_camera || world.opacity(info.material, &s) < 0.5;
        if !skip {
            if first {
                aov.depth = (passed + hit.t) * cr.depth_per_t + cr.depth_at_origin;
                aov.prim_id = info.id as i32;
                aov.instance_id = info.index;
                if wanted(Aov::ElementId) {
                    aov.element_id = world.element_of(&hit);
                }
            }
            aov.normal = s.ns.to_array();
            if wanted(Aov::Albedo) {
                aov.albedo = albedo_aov(world, &world.bsdf(info.material, &s, lambda, 1.0, 1.0).0, lambda);
            }
            return;
        }
        let front = -ray.d.dot(s.ng) > 0.0;
        ray.o = s.origin_on(if front { -s.ng } else { s.ng });
        ray.t_max -= hit.t;
        passed += hit.t;
    }
}

/// The `albedo` AOV of a BSDF: its reflectance seen under the authored colours' white, so
/// that a white surface reads (1, 1, 1) in any rendering colour space. A reflectance the
/// same at every wavelength sampled (a grey, from a grey colour's flat spectrum) is read as
/// that grey exactly, without the noise of estimating the white's colour from four
/// wavelengths; any other as the white it reflects, estimated from them.
fn albedo_aov(world: &World, bsdf: &Bsdf, lambda: &SampledWavelengths) -> [f32; 3] {
    let a = bsdf.albedo_hint();
    let (lo, hi) = (0..crate::spectrum::N_SPECTRUM).fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), i| (lo.min(a[i]), hi.max(a[i])));
    if hi - lo <= 1e-6 * hi.abs() {
        return [hi; 3];
    }
    let white = color::white_illuminant(crate::scene::AUTHORED_COLOR_SPACE);
    let lit = a * SampledSpectrum::from_fn(|i| white.eval(lambda.lambda[i]));
    color::xyz_to_output(color::to_xyz(lit, lambda), world.cs)
}

/// Splits an NEE contribution at the first vertex into light-path categories by the BSDF's
/// lobes: transmission by the side of `wi`; reflection by the diffuse and glossy parts.
fn split_reflection(bsdf: &Bsdf, wo: Vec3, wi: Vec3, contrib: SampledSpectrum) -> [(usize, SampledSpectrum); 2] {
    if wo.z * wi.z < 0.0 {
        return [(TRANSMISSION, contrib), (SPECULAR, SampledSpectrum::ZERO)];
    }
    let share = diffuse_share(bsdf, wo, wi);
    [(DIFFUSE, contrib * share), (SPECULAR, contrib * (SampledSpectrum::ONE - share))]
}

/// The diffuse lobes' share of `bsdf`'s f from `wo` to `wi` (per wavelength, in [0, 1]):
/// what a light's `diffuse` multiplier applies to, the rest taking its `specular` one.
pub fn diffuse_share(bsdf: &Bsdf, wo: Vec3, wi: Vec3) -> SampledSpectrum {
    if wo.z * wi.z < 0.0 || bsdf.flags() & flags::DIFFUSE == 0 {
        return SampledSpectrum::ZERO;
    }
    if bsdf.flags() & (flags::GLOSSY | flags::SPECULAR) == 0 {
        return SampledSpectrum::ONE;
    }
    let fd = bsdf.f_diffuse(wo, wi);
    let ft = bsdf.f(wo, wi, TransportMode::Radiance);
    fd.safe_div(ft).map(|v| v.clamp(0.0, 1.0))
}

/// Finds the dielectric objects that contain point `p` (by the side of each object's first
/// hit along a fixed direction), outermost first, with their constant indices (see
/// [`InteriorStack::at_wavelengths`]).
pub fn initial_stack(world: &World, p: Vec3, time: f32) -> InteriorStack {
    let d = Vec3::new(0.301_511_35, 0.904_534, 0.301_511_35);
    let mut stack = InteriorStack::default();
    let mut seen: Vec<u32> = Vec::new();
    let mut found: Vec<(f32, Interior)> = Vec::new();
    let mut origin = p;
    let mut travelled = 0.0;
    for _ in 0..256 {
        let ray = Ray { o: origin, d, t_max: f32::INFINITY, time };
        let Some(hit) = world.accel.intersect(&ray) else { break };
        let s = world.surface(&ray, &hit);
        travelled += hit.t;
        if !seen.contains(&hit.instance) {
            seen.push(hit.instance);
            let info = &world.instances[hit.instance as usize];
            let mat = &world.materials[info.material];
            if let Some(di) = mat.dielectric() {
                if d.dot(s.ng) > 0.0 {
                    found.push((travelled, Interior { instance: hit.instance, priority: di.priority, ior: di.ior, medium: mat.interior_medium, volume: false }));
                }
            } else if mat.is_medium_boundary() && d.dot(s.ng) > 0.0 {
                found.push((travelled, Interior { instance: hit.instance, priority: i32::MIN, ior: 1.0, medium: mat.interior_medium, volume: true }));
            }
        }
        origin = s.origin_towards(d);
    }
    found.sort_by(|a, b| b.0.partial_cmp(&a.0).unwrap_or(std::cmp::Ordering::Equal));
    for (_, it) in found {
        stack.push(it);
    }
    if stack.top().is_none() {
        if let Some(m) = world.camera.medium {
            // a camera declared to sit in a medium with no enclosing object: water around it
            stack.push(Interior { instance: u32::MAX - 1, priority: i32::MIN, ior: 1.333, medium: Some(m), volume: false });
        }
    }
    stack
}

/// Radiance (and AOVs) of one camera sample through `raster` with wavelengths `lambda`.
/// Returns the radiance split by light-path category (its sum is the sample's radiance) and
/// the first-vertex AOVs. With `caustics`, photon lookups are made at non-specular receiver
/// vertices and the caustic transport they carry is weighted out of the path tracer's share
/// (see [`crate::caustics::engine`]). `first` where the sample may be its pixel's first, whose
/// depth and primId the pixel keeps (behind a medium that scatters before the first surface
/// they take a ray of their own, so other samples leave them out).
pub fn trace_camera_sample(world: &World, sampler: &mut PixelSampler, raster: Vec2, lambda: &mut SampledWavelengths, camera_stack: &InteriorStack, caustics: Option<&Caustics>, first: bool) -> ([SampledSpectrum; N_SPLIT], SampleValue) {
    let u_lens = sampler.get2d();
    let u_time = sampler.get1d();
    let cr = world.camera.generate_ray(raster, u_lens, u_time);
    let mut ray = Ray { o: cr.o, d: cr.d, t_max: cr.t_max, time: cr.time };
    let mut aov = SampleValue { depth: f32::INFINITY, prim_id: -1, instance_id: -1, element_id: -1, ..Default::default() };
    let mut split = [SampledSpectrum::ZERO; N_SPLIT];
    // the ray footprint (for photon lookup radii), carried through specular events
    let mut fp = caustics.map_or(Footprint::default(), |c| c.pixel_footprint());
    let mut path_flags = 0u8;
    let mut chain: Option<Chain> = None;
    let chain_weight = |li: usize, chain: &Option<Chain>| match (caustics, chain) {
        (Some(c), Some(ch)) => c.path_weight(li, ch),
        _ => 1.0,
    };
    let mut beta = SampledSpectrum::ONE;
    let mut stack = *camera_stack;
    stack.at_wavelengths(world, lambda);
    let mut depth = 0u32;
    let mut null_events = 0u32;
    // how far the camera ray went through the surfaces it passed unchanged (null events): the
    // depth AOV measures from the camera, not from the last of them
    let mut passed = 0.0f32;
    let mut specular_bounce = false;
    let mut eta_scale = 1.0f32;
    let mut prev_pdf = 0.0f32;
    // UsdLux's diffuse / specular multipliers of the lights this path reaches by BSDF sampling:
    // the diffuse share of the last surface's f along the sampled direction (None: the camera
    // or a medium scattered it last), kept only when some light needs it
    let responses = world.any_light_response;
    let mut prev_share: Option<SampledSpectrum> = None;
    let gathered = |li: usize, share: &Option<SampledSpectrum>| -> SampledSpectrum {
        match share {
            Some(sh) if responses => {
                let r = &world.light_response[li];
                *sh * r.diffuse + (SampledSpectrum::ONE - *sh) * r.specular
            }
            _ => SampledSpectrum::ONE,
        }
    };
    let mut prev_ctx = LightSampleContext::new(ray.o, Vec3::ZERO).at(ray.time);
    // where the last vertex picked its light for next-event estimation (the point itself, where
    // `prev_ctx` holds the ray's offset origin): a light the ray reaches is weighed with the
    // probability that pick gave it
    let mut prev_pick = prev_ctx;
    // the surface the last BSDF-sampled ray left (None: the camera or a medium), whose light
    // links decide which lights that ray may reach
    let mut prev_instance: Option<u32> = None;
    let lit = |li: usize, from: Option<u32>| from.is_none_or(|i| world.illuminates(li, i));
    // light-path category of everything after the first scattering event
    let mut category = EMISSION;
    let mut first_surface = true;
    let n_light = world.lights.len();

    macro_rules! add {
        ($c:expr) => {{
            let c: SampledSpectrum = $c;
            split[category] += c;
        }};
    }

    let mut vertex = 0u32;
    loop {
        sampler.start_vertex(vertex);
        vertex += 1;
        let hit = world.intersect_path(&ray);
        let t_hit = hit.map_or(ray.t_max, |h| h.t);
        // analytic area lights along the ray
        let light_hit = nearest_light_hit(world, &ray, t_hit, depth == 0);
        let t_surface = light_hit.map_or(t_hit, |h| h.1);

        // the medium the ray travels in
        if let Some(mi) = stack.medium() {
            // photon beams scattered towards the camera along this stretch (on every stretch:
            // god rays lighting the sand that the camera sees matter as much as those seen
            // directly)
            // (on the camera's first stretch, light tracing has connected the photon stretches
            // of media it covers to the camera instead)
            let first_stretch = vertex == 1 && depth == 0 && null_events == 0;
            // photons (beams, or light-traced connections) carry the caustic transport of this
            // stretch's scattering vertices
            let beams_here = caustics.is_some_and(|c| c.beams_in(mi));
            let gather_here = beams_here && !(first_stretch && caustics.is_some_and(|c| c.light_traced(mi)));
            if let Some(c) = caustics.filter(|c| gather_here && c.has_beams(mi)) {
                let u = sampler.get1d();
                let l = c.gather_beams(world, ray.o, ray.d, t_surface.min(1e30), mi, lambda, beta.average(), &fp, u);
                if !l.is_black() {
                    split[CAUSTICS] += beta * l;
                }
            }
            // the first number is the sampler's (all a homogeneous medium uses); tracking
            // in a depth-varying one continues with a stream seeded by the next
            let u = sampler.get1d();
            let mut stream = StreamRng::new(sampler.get1d(), vertex);
            let mut uu = Some(u);
            let mut rng = || uu.take().unwrap_or_else(|| stream.next_f32());
            let (ro, rd) = world.media[mi].rest_ray(ray.time, ray.o, ray.d);
            match world.media[mi].sample_distance(ro, rd, t_surface.min(1e30), &mut rng, lambda) {
                DistanceSample::Scatter { t, weight } => {
                    if depth == 0 && first_surface {
                        // the first-hit AOVs of the surface behind the medium, by geometry
                        first_surface_aov(world, &cr, lambda, first, &mut aov);
                    }
                    beta *= weight;
                    fp.advance(t);
                    fp.after_diffuse();
                    path_flags |= AFTER_VOLUME;
                    if beta.is_black() {
                        break;
                    }
                    if depth == 0 {
                        category = VOLUME;
                        aov.alpha = 1.0;
                    }
                    depth += 1;
                    if depth > world.max_depth {
                        break;
                    }
                    let p = ray.o + ray.d * t;
                    let wo = -ray.d;
                    let phase = world.media[mi].phase(p);
                    // the gprim this medium fills: its light links apply here
                    let owner = stack.medium_owner();
                    // NEE from the medium
                    if n_light > 0 {
                        let ul = sampler.get1d();
                        let u2 = sampler.get2d();
                        let u_tr = sampler.get1d();
                        let ctx = LightSampleContext::new(p, Vec3::ZERO).at(ray.time);
                        if let Some((li, pmf)) = world.light_tree.sample(&ctx, ul).filter(|&(li, _)| lit(li, owner)) {
                            if let Some(ls) = world.lights[li].sample_li(&ctx, u2, lambda) {
                                if ls.pdf > 0.0 && !ls.l.is_black() {
                                    let fp = phase.eval(wo, ls.wi);
                                    let dist = if ls.dist.is_finite() { ls.dist * (1.0 - 1e-4) } else { f32::INFINITY };
                                    let tr = shadow_transmittance(world, li, p, ls.wi, dist, ray.time, Some(mi), &stack, lambda, u_tr, path_flags);
                                    if !tr.is_black() {
                                        let w = if ls.is_delta { 1.0 } else { power_heuristic(1.0, ls.pdf * pmf, 1.0, fp) }; // the phase function's pdf is its value
                                        add!(beta * tr * ls.l * (fp * w / (ls.pdf * pmf)));
                                    }
                                }
                            }
                        }
                    }
                    let (wi, val, pdf) = phase.sample(wo, sampler.get2d());
                    if !(pdf > 0.0) {
                        break;
                    }
                    // a chain from this volume vertex through casters to a light is what
                    // photon beams carry
                    chain = beams_here.then_some(Chain { p_b: pdf, last: u32::MAX });
                    beta *= val / pdf;
                    prev_pdf = pdf;
                    prev_share = None;
                    specular_bounce = false;
                    prev_ctx = LightSampleContext::new(p, Vec3::ZERO).at(ray.time);
                    prev_pick = prev_ctx;
                    prev_instance = owner;
                    ray = Ray { o: p, d: wi, t_max: f32::INFINITY, time: ray.time };
                    continue;
                }
                DistanceSample::Pass { weight } => {
                    beta *= weight;
                    if beta.is_black() {
                        if depth == 0 && first_surface {
                            first_surface_aov(world, &cr, lambda, first, &mut aov);
                        }
                        break;
                    }
                }
            }
        }

        // an area light in front of every surface
        if let Some((li, t, p, n)) = light_hit {
            let light = &world.lights[li];
            if (depth > 0 || light.visible_to_camera()) && lit(li, prev_instance) {
                let le = light.l_at(p, n, -ray.d, ray.time, lambda);
                if !le.is_black() {
                    let w = if depth == 0 || specular_bounce {
                        1.0
                    } else {
                        let lp = light.pdf_li(&prev_ctx, ray.d, Some((p, n))) * world.light_tree.pmf(&prev_pick, li);
                        power_heuristic(1.0, prev_pdf, 1.0, lp)
                    };
                    add!(beta * le * gathered(li, &prev_share) * (w * chain_weight(li, &chain)));
                }
            }
            if depth == 0 {
                aov.depth = (passed + t) * cr.depth_per_t + cr.depth_at_origin;
            }
            break;
        }

        let Some(hit) = hit else {
            // escaped: infinite lights
            for &li in &world.infinite_lights {
                let light = &world.lights[li];
                if (depth == 0 && !light.visible_to_camera()) || !lit(li, prev_instance) {
                    continue;
                }
                let le = light.le(ray.d, lambda);
                if le.is_black() {
                    continue;
                }
                let w = if depth == 0 || specular_bounce {
                    1.0
                } else {
                    let lp = light.pdf_li(&prev_ctx, ray.d, None) * world.light_tree.pmf(&prev_pick, li);
                    power_heuristic(1.0, prev_pdf, 1.0, lp)
                };
                add!(beta * le * gathered(li, &prev_share) * (w * chain_weight(li, &chain)));
            }
            break;
        };

        let s = world.surface(&ray, &hit);
        let info = &world.instances[hit.instance as usize];
        let mat_i = info.material;
        let wo_w = -ray.d;
        let front = wo_w.dot(s.ng) > 0.0;
        fp.advance(hit.t);
        let roles = world.caustic_instances[hit.instance as usize];
        // the path goes on through the surface unchanged (a null event)
        macro_rules! pass_through {
            () => {{
                ray.o = s.origin_on(if front { -s.ng } else { s.ng });
                ray.t_max -= hit.t;
                passed += hit.t;
                null_events += 1;
                if null_events > MAX_NULL_EVENTS {
                    break;
                }
                continue;
            }};
        }
        if transparent(roles.transparency, path_flags) {
            // switch-to-transparency: the path goes on as if the surface were not there (a
            // water body's medium still begins and ends at it)
            if world.materials[mat_i].dielectric().is_some() {
                stack.cross(world, &s, front, lambda);
                beta *= world.transmission_tint(mat_i, &s, lambda);
            }
            pass_through!();
        }
        if depth == 0 && !info.visible_to_camera {
            // invisible to the camera: continue as if it were not there
            pass_through!();
        }

        // stochastic opacity
        let opacity = world.opacity(mat_i, &s);
        if opacity < 1.0 && sampler.get1d() >= opacity {
            pass_through!();
        }

        let boundary = classify_boundary(world, &s, front, &stack, lambda);
        if let Boundary::False = boundary {
            stack.cross(world, &s, front, lambda);
            ray.o = s.origin_on(if front { -s.ng } else { s.ng });
            // the camera's far clipping distance still counts from the camera
            ray.t_max -= hit.t;
            passed += hit.t;
            null_events += 1;
            if null_events > MAX_NULL_EVENTS {
                break;
            }
            continue;
        }

        // the caustic chain goes on through casters and ends at anything else
        if roles.caster {
            if let Some(c) = chain.as_mut() {
                c.last = s.instance;
            }
        } else {
            chain = None;
        }

        // first-hit AOVs
        if first_surface {
            first_surface = false;
            if depth == 0 {
                aov.alpha = 1.0;
                aov.depth = (passed + hit.t) * cr.depth_per_t + cr.depth_at_origin;
                aov.prim_id = info.id as i32;
                aov.instance_id = info.index;
                if world.aovs.contains(crate::render::Aov::ElementId) {
                    aov.element_id = world.element_of(&hit);
                }
                aov.normal = s.ns.to_array();
            }
        }

        // emission of emissive surfaces
        let le = world.emitted(mat_i, &s, wo_w, lambda, world.meshes.get(match info.geometry {
            crate::scene::GeometryRef::Mesh(m) => m,
            _ => usize::MAX,
        }).is_some_and(|m| m.double_sided));
        if !le.is_black() {
            let light = world.triangle_lights.get(&(hit.instance, hit.prim)).copied();
            let w = if light.is_some_and(|li| !lit(li, prev_instance)) {
                // a mesh light whose links leave out the surface the ray left
                0.0
            } else if depth == 0 || specular_bounce {
                1.0
            } else if let Some(li) = light {
                let lp = world.lights[li].pdf_li(&prev_ctx, ray.d, Some((s.p, s.ng))) * world.light_tree.pmf(&prev_pick, li);
                power_heuristic(1.0, prev_pdf, 1.0, lp)
            } else {
                1.0
            };
            add!(beta * le * w);
        }

        // a dispersive interface sends each wavelength its own way: only the hero goes on
        if let Boundary::Real { .. } = boundary {
            if world.materials[mat_i].dielectric().is_some_and(|d| d.dispersion.is_some()) && !lambda.secondary_terminated() {
                lambda.terminate_secondary();
            }
        }
        let (eta, medium_front, medium_back) = match &boundary {
            Boundary::Real { eta, medium_front, medium_back, .. } => (*eta, *medium_front, *medium_back),
            _ => (1.0, stack.medium(), stack.medium()),
        };
        let (bsdf, frame) = world.bsdf(mat_i, &s, lambda, stack.ior(), eta);
        let flip = if s.ns.dot(s.ng) < 0.0 { -1.0 } else { 1.0 };
        let frame = if flip < 0.0 { Frame::from_normal(-s.ns) } else { frame };
        let wo = frame.to_local(wo_w);
        if depth == 0 && world.aovs.contains(crate::render::Aov::Albedo) {
            aov.albedo = albedo_aov(world, &bsdf, lambda);
        }

        let non_specular = !bsdf.is_specular();
        if non_specular {
            path_flags |= AFTER_DIFFUSE;
        }
        // caustic photons arriving here
        if let Some(c) = caustics.filter(|_| non_specular && roles.receiver) {
            let u = sampler.get1d();
            let l = c.gather(s.p, s.ng, c.radius(fp.width()), &bsdf, &frame, wo, lambda, beta.average(), u);
            if !l.is_black() {
                split[CAUSTICS] += beta * l;
            }
        }

        // next-event estimation
        if non_specular && n_light > 0 {
            let ul = sampler.get1d();
            let u2 = sampler.get2d();
            let u_tr = sampler.get1d();
            let ctx = LightSampleContext::new(s.p, s.ns).at(ray.time);
            if let Some((li, pmf)) = world.light_tree.sample(&ctx, ul).filter(|&(li, _)| world.illuminates(li, s.instance)) {
                if let Some(ls) = world.lights[li].sample_li(&ctx, u2, lambda) {
                    let wi = frame.to_local(ls.wi);
                    if ls.pdf > 0.0 && !ls.l.is_black() {
                        let f = bsdf.f(wo, wi, TransportMode::Radiance) * wi.z.abs();
                        // geometric side check: no light leaks through the true surface
                        let same_side = (ls.wi.dot(s.ng) > 0.0) == (wi.z > 0.0);
                        if !f.is_black() && same_side {
                            let out_front = ls.wi.dot(s.ng) > 0.0;
                            let med = if out_front { medium_front } else { medium_back };
                            let o = s.origin_on(if out_front { s.ng } else { -s.ng });
                            let (d, dist) = shadow_ray(o, &ls);
                            let tr = shadow_transmittance(world, li, o, d, dist, ray.time, med, &stack, lambda, u_tr, path_flags);
                            if !tr.is_black() {
                                let w = if ls.is_delta { 1.0 } else { power_heuristic(1.0, ls.pdf * pmf, 1.0, bsdf.pdf(wo, wi, TransportMode::Radiance)) };
                                let c = beta * tr * f * ls.l * (w * chain_weight(li, &chain) / (ls.pdf * pmf));
                                let r = world.light_response[li];
                                if depth == 0 || !r.is_physical() {
                                    for (cat, v) in split_reflection(&bsdf, wo, wi, c) {
                                        let v = v * if cat == DIFFUSE { r.diffuse } else { r.specular };
                                        if depth == 0 {
                                            split[cat] += v;
                                        } else {
                                            add!(v);
                                        }
                                    }
                                } else {
                                    add!(c);
                                }
                            }
                        }
                    }
                }
            }
        }

        // continue the path
        let uc = sampler.get1d();
        let u2 = sampler.get2d();
        let Some(bs) = bsdf.sample_f(wo, uc, u2, TransportMode::Radiance) else { break };
        if !(bs.pdf > 0.0) || bs.f.is_black() {
            break;
        }
        let wi_w = frame.to_world(bs.wi);
        let out_front = wi_w.dot(s.ng) > 0.0;
        // reject samples that cross the true surface on the wrong side of the shading normal
        if (bs.wi.z > 0.0) != out_front {
            break;
        }
        beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
        if responses {
            prev_share = Some(if bs.is_specular() { SampledSpectrum::ZERO } else { diffuse_share(&bsdf, wo, bs.wi) });
        }
        if depth == 0 {
            category = if bs.is_transmission() {
                TRANSMISSION
            } else if bs.flags & flags::DIFFUSE != 0 {
                DIFFUSE
            } else {
                SPECULAR
            };
        }
        if bs.is_transmission() && front && world.diffusion.body(s.instance).is_some() {
            // a body whose medium renders in diffusion mode: its subsurface light ends the path
            add!(beta * crate::diffusion::radiance_exit(world, &s, wi_w, lambda, sampler));
            break;
        }
        specular_bounce = bs.is_specular();
        if !roles.caster {
            chain = (caustics.is_some() && roles.receiver && !bs.is_specular()).then_some(Chain { p_b: bs.pdf, last: u32::MAX });
        }
        if non_specular {
            fp.after_diffuse();
        } else if caustics.is_some() && bs.is_specular() {
            // curvature seen from the incoming side: the outside's, or its negative from within
            let k = world.mean_curvature(&ray, &hit) * if front { 1.0 } else { -1.0 };
            if bs.is_transmission() {
                fp.refract(k, bs.eta, wo.z, bs.wi.z);
            } else {
                fp.reflect(k);
            }
        }
        prev_pdf = bs.pdf;
        // the next ray starts stepped off the surface: a light it meets is weighed by the
        // density of light sampling from there (from the surface point itself, a sphere light
        // the ray grazes could have no density and its hit count at full weight)
        let o_next = s.origin_on(if out_front { s.ng } else { -s.ng });
        prev_ctx = LightSampleContext::new(o_next, s.ns).at(ray.time);
        prev_pick = LightSampleContext::new(s.p, s.ns).at(ray.time);
        prev_instance = Some(s.instance);
        if bs.is_transmission() {
            eta_scale *= bs.eta * bs.eta;
            if let Boundary::Real { enter, .. } = boundary {
                if front {
                    stack.push(enter);
                } else {
                    stack.remove(s.instance);
                }
            }
        }
        ray = Ray { o: o_next, d: wi_w, t_max: f32::INFINITY, time: ray.time };
        depth += 1;
        if depth > world.max_depth {
            break;
        }
        // Russian roulette
        if depth > 3 {
            let rr = (beta * eta_scale).max_component();
            if rr < 1.0 {
                let q = (1.0 - rr).max(0.0);
                if sampler.get1d() < q {
                    break;
                }
                beta /= 1.0 - q;
            }
        }
    }
    (split, aov)
}

#[cfg(test)]
#[path = "integrator_tests.rs"]
mod tests;
