//! Emission sampling: rays leaving the lights, for light tracing, photon mapping and photon
//! beams (paths that start at a light rather than at the camera).
//!
//! # API
//!
//! - [`Light::sample_le`]`(u_pos, u_dir, lambda, time, disk)` → [`LeSample`]: a ray
//!   (`ray_o`, unit `ray_d`) leaving the light, the radiance `l` it carries, the density of its
//!   origin `pdf_pos` (area measure) and of its direction `pdf_dir` (solid angle), and the
//!   emitting-side normal `n_light`. The photon's power is
//!   `l · |n_light · ray_d| / (pdf_pos · pdf_dir)` (divide further by the light's selection
//!   probability); its expectation is [`Light::phi`].
//! - [`Light::pdf_le`]`(ray_o, ray_d, n, disk)` → `(pdf_pos, pdf_dir)`: the densities with
//!   which `sample_le` produces that ray, for MIS between light and camera strategies.
//! - [`Light::phi`] (spectral) and [`Light::phi_y`] (luminance-weighted): the exact power
//!   emitted, the expectation of the photon power above.
//! - [`EmissionDisk`]: where rays of infinite lights start, chosen by the caller.
//!
//! # Per light
//!
//! | light | origin (`pdf_pos`) | direction (`pdf_dir`) |
//! |---|---|---|
//! | sphere, rect, disk, cylinder side, triangle | uniform by area, 1/A | cosine about the emitting normal, cos/π (two-sided triangles: either side with probability ½, cos/2π) |
//! | point | the point (delta, `pdf_pos` 1) | uniform sphere, 1/4π |
//! | distant | uniform on a disk perpendicular to the sun, 1/(πR′²) | uniform in the sun's cone, 1/(2π(1 − cos θ)) (delta for angle 0: `pdf_dir` 1) |
//! | dome, sky | uniform on a disk perpendicular to the sampled direction, 1/(πR²) | the dome's own distribution (as for `sample_li`; portals aside) |
//!
//! Infinite lights start their rays on a disk derived from an [`EmissionDisk`] `{center,
//! radius}` (a sphere the caller wants lit: the scene's bounding sphere, or the bounds of the
//! objects that cast caustics). The disk lies on that sphere's surface on the light's side,
//! so every ray starts outside the sphere, and it covers the sphere:
//! - distant lights with a cone of half-angle θ ≤ [`FIXED_DISK_MAX_HALF_ANGLE_DEG`]: one disk,
//!   fixed, perpendicular to the sun's axis, of radius R′ = R (1 + sin θ) / cos θ, the smallest
//!   that lets every point of the sphere receive its whole cone (R′ = R for a delta sun; for
//!   the 0.53° sun R′ ≈ 1.0093 R). Fixed disks are what a guided emission map is defined on.
//! - wider distant cones and domes: a disk of radius R perpendicular to each sampled direction.
//!
//! `n_light` is the emitting side's normal: the surface normal for area lights, the disk's
//! normal for infinite lights (so `|n_light · ray_d|` is the cosine at the disk), `ray_d`
//! for point lights. For delta lights `l` is not a radiance: a point light's `l` is its
//! intensity (W/sr), a delta distant light's its irradiance on a facing surface; the photon
//! power formula holds as written with the delta density reported as 1. Then `pdf_le`
//! returns 0 for the delta part (`pdf_pos` for point lights, `pdf_dir` for delta distant
//! lights), as `pdf_li` does, since no other strategy can produce those rays.
//!
//! A shaped light (UsdLuxShapingAPI, [`super::shaping`]) whose cone is narrower than a
//! hemisphere draws its directions uniformly within the cone (1/(2π(1 − cos θc))), about the
//! light's axis, with the origin as above; an area light's origin that faces away from the
//! direction gives no ray (a sphere's or cylinder's far side). Wider cones are sampled as
//! above. Either way each ray's `l` carries the shaping's factor along `ray_d`, and `phi` its
//! share of the power. A caller that sends the photon along another direction than `ray_d` (the caustics
//! atlas aims local lights' photons at casters) takes the emission along its own direction
//! ([`Light::le_towards`]). A rect light's image (`texture:file`) colours `l` at the origin.
//!
//! `time` places a moving light ([`super::MovingLight`]) where it is then (its sample is the
//! static light's, carried by the light's move); for other lights it only travels with the
//! light path, so that it carries the same time as the camera paths it is merged with.
//!
//! `phi` relates to [`Light::power`] (used to pick lights in proportion to their power):
//! for finite lights `phi_y()` equals `power()`. For infinite lights the power depends on the
//! disk; `power()` assumes a disk of the scene's radius, so it equals `phi_y` for that disk
//! except that distant cones here use the enlarged R′ (and wide cones the per-direction disk,
//! whose power is L·Ω·πR² rather than ∫L cos dω·πR²), and a textured dome's `power()` takes
//! its texel solid angles at the row centres while `phi` integrates them exactly.

use glam::{Vec2, Vec3};

use super::{in_cone, DomeMap, Light, LightSampleContext, INV_4PI, PI};
use crate::math::{sample_concentric_disk, sample_cosine_hemisphere, sample_uniform_cone, sample_uniform_sphere, uniform_cone_pdf, Frame, INV_PI};
use crate::spectrum::{color, uplift, SampledSpectrum, SampledWavelengths, N_SPECTRUM};

/// Distant lights whose cone's half-angle is at most this start their rays on one fixed disk
/// perpendicular to their axis; wider ones on a disk perpendicular to each ray. At this limit
/// the fixed disk is (1 + sin θ)/cos θ = 1.73 times the sphere's radius (3× its area).
pub const FIXED_DISK_MAX_HALF_ANGLE_DEG: f32 = 30.0;

/// Relative slack on the disk-membership test of `pdf_le`, so that rays sampled on the very rim
/// of a disk are found inside it again despite f32 rounding.
const DISK_EPS: f32 = 1e-4;

/// A sphere (centre, radius) that an infinite light's rays must cover: they start on a disk
/// on its surface facing the light (see the module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionDisk {
    center: Vec3,
    radius: f32,
}

impl EmissionDisk {
    /// Errors name the bad argument: "center: not finite (...)", "radius: must be positive ...".
    pub fn new(center: Vec3, radius: f32) -> Result<EmissionDisk, String> {
        if !center.is_finite() {
            return Err(format!("center: not finite ({center})"));
        }
        if !(radius > 0.0) || !radius.is_finite() {
            return Err(format!("radius: must be positive and finite ({radius})"));
        }
        Ok(EmissionDisk { center, radius })
    }

    /// The sphere around an axis-aligned box (centre and half diagonal). Errors name
    /// "bounds": not finite, min above max, or a box of zero size.
    pub fn from_bounds(min: Vec3, max: Vec3) -> Result<EmissionDisk, String> {
        if !min.is_finite() || !max.is_finite() {
            return Err(format!("bounds: not finite ({min} .. {max})"));
        }
        if !min.cmple(max).all() {
            return Err(format!("bounds: min exceeds max ({min} .. {max})"));
        }
        let radius = 0.5 * (max - min).length();
        if !(radius > 0.0) || !radius.is_finite() {
            return Err(format!("bounds: a box of zero or overflowing size ({min} .. {max})"));
        }
        EmissionDisk::new(0.5 * (min + max), radius)
    }

    pub fn center(&self) -> Vec3 {
        self.center
    }

    pub fn radius(&self) -> f32 {
        self.radius
    }
}

/// A ray leaving a light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeSample {
    pub ray_o: Vec3,
    /// Unit direction of emission.
    pub ray_d: Vec3,
    /// Radiance along the ray (point lights: intensity; delta distant lights: irradiance).
    pub l: SampledSpectrum,
    /// Density of `ray_o`, per unit area of the light (infinite lights: of the emission disk);
    /// 1 for a point light's delta position.
    pub pdf_pos: f32,
    /// Solid-angle density of `ray_d` given `ray_o`; 1 for a delta distant light's direction.
    pub pdf_dir: f32,
    /// Emitting-side normal at `ray_o` (see the module documentation).
    pub n_light: Vec3,
    /// `ray_o` comes from a delta distribution (point lights).
    pub delta_pos: bool,
    /// `ray_d` comes from a delta distribution (distant lights of angle 0).
    pub delta_dir: bool,
}

impl LeSample {
    /// The photon's power: `l · |n_light · ray_d| / (pdf_pos · pdf_dir)`.
    #[inline]
    pub fn power(&self) -> SampledSpectrum {
        self.l * (self.n_light.dot(self.ray_d).abs() / (self.pdf_pos * self.pdf_dir))
    }
}

/// How a distant light places its emission disk.
#[derive(Clone, Copy, Debug, PartialEq)]
enum DistantDisk {
    /// One disk perpendicular to the axis, of this radius.
    Fixed(f32),
    /// A disk of the sphere's radius perpendicular to each ray.
    PerRay,
}

impl super::DistantLight {
    fn disk_kind(&self, disk: &EmissionDisk) -> DistantDisk {
        let cos_t = 1.0 - self.one_minus_cos;
        if cos_t >= FIXED_DISK_MAX_HALF_ANGLE_DEG.to_radians().cos() {
            let sin_t = (self.one_minus_cos * (2.0 - self.one_minus_cos)).max(0.0).sqrt();
            DistantDisk::Fixed(disk.radius * (1.0 + sin_t) / cos_t)
        } else {
            DistantDisk::PerRay
        }
    }

    /// Half-angle's cosine-weighted solid angle ∫ cos dω = π sin²θ of the cone (θ ≤ 90°).
    fn cone_cos_integral(&self) -> f32 {
        let c = 1.0 - self.one_minus_cos;
        PI * if c > 0.0 { self.one_minus_cos * (1.0 + c) } else { 1.0 }
    }
}

/// Uniform point on the disk of radius `r` centred at `c` in the plane spanned by `f.s`, `f.t`.
#[inline]
fn disk_point(f: &Frame, c: Vec3, r: f32, u: Vec2) -> Vec3 {
    let q = sample_concentric_disk(u) * r;
    c + f.s * q.x + f.t * q.y
}

/// Whether the line through `o` along unit `d` crosses the disk (centre `c`, unit normal `n`,
/// radius `r`).
#[inline]
fn line_hits_disk(o: Vec3, d: Vec3, c: Vec3, n: Vec3, r: f32) -> bool {
    let dn = d.dot(n);
    if dn == 0.0 {
        return false;
    }
    let p = o + d * ((c - o).dot(n) / dn);
    (p - c).length_squared() <= r * r * (1.0 + DISK_EPS)
}

/// Cosine-weighted direction about `n`: (direction, cos/π), None when it grazes.
#[inline]
fn cosine_about(n: Vec3, u: Vec2) -> Option<(Vec3, f32)> {
    let w = sample_cosine_hemisphere(u);
    if !(w.z > 0.0) {
        return None;
    }
    Some((Frame::from_normal(n).to_world(w).normalize(), w.z * INV_PI))
}

impl Light {
    /// Samples a ray leaving the light (see the module documentation): `u_pos` picks the
    /// origin, `u_dir` the direction (infinite lights: `u_dir` the direction, then `u_pos` the
    /// point on the disk). `disk` is used by infinite lights only. None when the sample carries
    /// nothing (grazing direction, black dome texel, a dome that emits nothing).
    pub fn sample_le(&self, u_pos: Vec2, u_dir: Vec2, lambda: &SampledWavelengths, time: f32, disk: &EmissionDisk) -> Option<LeSample> {
        if let Some((sh, cos_cut)) = self.steered() {
            // a cone narrower than a hemisphere: the direction is drawn uniformly in it (the
            // light sends nothing outside it) and the origin as unshaped (`u_dir` = ½, ½ is a
            // valid direction for every origin), so aimed callers keep its density
            let mut s = self.sample_le_unshaped(u_pos, Vec2::splat(0.5), lambda, time, disk)?;
            let d = Frame::from_normal(sh.axis).to_world(sample_uniform_cone(u_dir, cos_cut)).normalize();
            if matches!(self, Light::Point(_)) {
                s.n_light = d;
            } else if !(s.n_light.dot(d) > 0.0) {
                return None; // behind this origin (a sphere's or cylinder's far side)
            }
            s.ray_d = d;
            s.pdf_dir = uniform_cone_pdf(cos_cut);
            s.l *= sh.factor(d, lambda);
            return Some(s);
        }
        let mut s = self.sample_le_unshaped(u_pos, u_dir, lambda, time, disk)?;
        // a shaped light's sample keeps its place and direction (its `l` may be 0 outside the
        // cone): callers that aim the ray elsewhere take the emission there (`le_towards`)
        if let Some(sh) = self.shaping() {
            s.l *= sh.factor(s.ray_d, lambda);
        }
        Some(s)
    }

    /// The shaping whose cone emission sampling draws directions in, and its cos θc.
    #[inline]
    fn steered(&self) -> Option<(&super::shaping::Shaping, f32)> {
        let sh = self.shaping()?;
        Some((sh, sh.steering_cos()?))
    }

    /// `sample_le` before the light's shaping.
    #[inline]
    fn sample_le_unshaped(&self, u_pos: Vec2, u_dir: Vec2, lambda: &SampledWavelengths, time: f32, disk: &EmissionDisk) -> Option<LeSample> {
        let area = |p: Vec3, n: Vec3, a: f32, l: SampledSpectrum| {
            let (d, pdf_dir) = cosine_about(n, u_dir)?;
            Some(LeSample { ray_o: p, ray_d: d, l, pdf_pos: 1.0 / a, pdf_dir, n_light: n, delta_pos: false, delta_dir: false })
        };
        match self {
            // the inner light's sample (its shaping included) where the light is at `time`
            Light::Moving(m) => {
                let (fwd, _) = m.moves(time);
                let s = m.inner.sample_le(u_pos, u_dir, lambda, time, disk)?;
                Some(LeSample { ray_o: fwd.transform_point3(s.ray_o), ray_d: fwd.transform_vector3(s.ray_d).normalize(), n_light: fwd.transform_vector3(s.n_light).normalize(), ..s })
            }
            Light::Sphere(s) => {
                let n = sample_uniform_sphere(u_pos);
                area(s.center + n * s.radius, n, self.area(), s.emission.sample(lambda))
            }
            Light::Rect(r) => {
                let p = r.shape.origin + r.shape.a * u_pos.x + r.shape.b * u_pos.y;
                area(p, r.shape.n, r.shape.area, r.radiance(p, lambda))
            }
            Light::Disk(dl) => {
                let q = sample_concentric_disk(u_pos);
                let p = dl.shape.origin + dl.shape.a * q.x + dl.shape.b * q.y;
                area(p, dl.shape.n, dl.shape.area, dl.emission.sample(lambda))
            }
            Light::Cylinder(c) => {
                let z = (2.0 * u_pos.x - 1.0) * c.half_length;
                let (sp, cp) = (2.0 * PI * u_pos.y).sin_cos();
                let n = c.frame.to_world(Vec3::new(cp, sp, 0.0));
                area(c.center + c.frame.n * z + n * c.radius, n, c.area, c.emission.sample(lambda))
            }
            Light::Triangle(t) => {
                let su = u_pos.x.sqrt();
                let (b1, b2) = (su * (1.0 - u_pos.y), su * u_pos.y);
                let p = t.p[0] * (1.0 - b1 - b2) + t.p[1] * b1 + t.p[2] * b2;
                let l = t.radiance(b1, b2, lambda);
                if !t.two_sided {
                    return area(p, t.n, t.area, l);
                }
                // the first direction number also picks the side
                let (n, ux) = if u_dir.x < 0.5 { (t.n, 2.0 * u_dir.x) } else { (-t.n, (2.0 * u_dir.x - 1.0).min(1.0 - f32::EPSILON)) };
                let (d, pdf_dir) = cosine_about(n, Vec2::new(ux, u_dir.y))?;
                Some(LeSample { ray_o: p, ray_d: d, l, pdf_pos: 1.0 / t.area, pdf_dir: 0.5 * pdf_dir, n_light: n, delta_pos: false, delta_dir: false })
            }
            Light::Point(pl) => {
                let d = sample_uniform_sphere(u_dir);
                Some(LeSample { ray_o: pl.p, ray_d: d, l: pl.emission.sample(lambda), pdf_pos: 1.0, pdf_dir: INV_4PI, n_light: d, delta_pos: true, delta_dir: false })
            }
            Light::Distant(dl) => {
                let ctx = LightSampleContext::new(disk.center, Vec3::ZERO);
                let li = self.sample_li(&ctx, u_dir, lambda)?;
                let d = -li.wi;
                let (ray_o, r, n_light) = match dl.disk_kind(disk) {
                    DistantDisk::Fixed(r) => (disk_point(&dl.frame, disk.center + dl.to_light * disk.radius, r, u_pos), r, -dl.to_light),
                    DistantDisk::PerRay => (disk_point(&Frame::from_normal(li.wi), disk.center + li.wi * disk.radius, disk.radius, u_pos), disk.radius, d),
                };
                Some(LeSample { ray_o, ray_d: d, l: li.l, pdf_pos: 1.0 / (PI * r * r), pdf_dir: li.pdf, n_light, delta_pos: false, delta_dir: li.is_delta })
            }
            Light::Dome(_) | Light::Sky(_) => {
                // the dome's own directions: portals guide receivers, not emission
                let ctx = LightSampleContext::new(disk.center, Vec3::ZERO);
                let li = self.sample_environment(&ctx, u_dir, lambda, false)?;
                if li.l.is_black() {
                    return None;
                }
                let r = disk.radius;
                let ray_o = disk_point(&Frame::from_normal(li.wi), disk.center + li.wi * r, r, u_pos);
                Some(LeSample { ray_o, ray_d: -li.wi, l: li.l, pdf_pos: 1.0 / (PI * r * r), pdf_dir: li.pdf, n_light: -li.wi, delta_pos: false, delta_dir: false })
            }
        }
    }

    /// What the origin of emission sample `s` sends along unit `dir` instead of its own
    /// `ray_d`, for a caller that aims the ray elsewhere (the caustics atlas aims local lights'
    /// photons at casters): the light's radiance there (a point light's intensity), with its
    /// shaping along `dir`. Infinite lights do not aim: their `l`.
    pub fn le_towards(&self, s: &LeSample, dir: Vec3, time: f32, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Light::Moving(m) => {
                let (_, inv) = m.moves(time);
                let local = LeSample { ray_o: inv.transform_point3(s.ray_o), ray_d: inv.transform_vector3(s.ray_d), n_light: inv.transform_vector3(s.n_light), ..*s };
                m.inner.le_towards(&local, inv.transform_vector3(dir), time, lambda)
            }
            Light::Point(p) => p.emission.sample(lambda) * self.shaping_factor(dir, lambda),
            _ if self.is_infinite() => s.l,
            _ => self.l(s.ray_o, s.n_light, dir, lambda),
        }
    }

    /// Densities `(pdf_pos, pdf_dir)` with which [`Light::sample_le`] produces the ray leaving
    /// `ray_o` along unit `ray_d`. For area lights `ray_o` is a point on the light and `n` its
    /// emitting-side normal there (as `intersect` returns them); `ray_o` is not checked. For
    /// infinite lights `ray_o` is any point of the ray (e.g. where a camera path left the
    /// scene), `n` is unused, and `pdf_pos` is 0 when the ray's line misses the emission disk.
    /// Delta parts are 0 (point: `pdf_pos`; distant of angle 0: `pdf_dir`).
    pub fn pdf_le(&self, ray_o: Vec3, ray_d: Vec3, n: Vec3, disk: &EmissionDisk) -> (f32, f32) {
        let cos = n.dot(ray_d);
        if let Some((sh, cos_cut)) = self.steered() {
            let point = matches!(self, Light::Point(_));
            let inside = sh.axis.dot(ray_d) >= cos_cut && (point || cos > 0.0);
            return (if point { 0.0 } else { 1.0 / self.area() }, if inside { uniform_cone_pdf(cos_cut) } else { 0.0 });
        }
        match self {
            // a rigid move keeps the densities of the ray and normal moved with it
            Light::Moving(m) => m.inner.pdf_le(ray_o, ray_d, n, disk),
            Light::Sphere(_) | Light::Rect(_) | Light::Disk(_) | Light::Cylinder(_) | Light::Triangle(_) => {
                let two_sided = matches!(self, Light::Triangle(t) if t.two_sided);
                let pdf_dir = if two_sided { 0.5 * cos.abs() } else { cos.max(0.0) } * INV_PI;
                (1.0 / self.area(), pdf_dir)
            }
            Light::Point(_) => (0.0, INV_4PI),
            Light::Distant(dl) => {
                let pdf_dir = if dl.one_minus_cos == 0.0 {
                    0.0
                } else if in_cone(-ray_d, dl.to_light, dl.one_minus_cos) {
                    1.0 / (2.0 * PI * dl.one_minus_cos)
                } else {
                    return (0.0, 0.0);
                };
                // per-ray disks: the line crosses its disk exactly when it passes within R of the centre
                let (c, n, r) = match dl.disk_kind(disk) {
                    DistantDisk::Fixed(r) => (disk.center + dl.to_light * disk.radius, dl.to_light, r),
                    DistantDisk::PerRay => (disk.center, ray_d, disk.radius),
                };
                if !line_hits_disk(ray_o, ray_d, c, n, r) {
                    return (0.0, pdf_dir);
                }
                (1.0 / (PI * r * r), pdf_dir)
            }
            Light::Dome(_) | Light::Sky(_) => {
                let pdf_dir = self.environment_pdf((-ray_d).normalize());
                let r = disk.radius;
                let pdf_pos = if line_hits_disk(ray_o, ray_d, disk.center, ray_d, r) { 1.0 / (PI * r * r) } else { 0.0 };
                (pdf_pos, pdf_dir)
            }
        }
    }

    /// Exact spectral power emitted at the wavelengths `lambda` (the expectation of
    /// [`LeSample::power`]); infinite lights: through their emission disk (see the module
    /// documentation). A textured dome sums its texels (cost ∝ texels: not for inner loops).
    pub fn phi(&self, lambda: &SampledWavelengths, disk: &EmissionDisk) -> SampledSpectrum {
        match self {
            Light::Moving(m) => m.inner.phi(lambda, disk),
            Light::Dome(d) => {
                let r = disk.radius;
                match &d.map {
                    None => d.emission.sample(lambda) * (4.0 * PI * PI * r * r),
                    Some(m) => dome_integral(m, |c| uplift::illuminant(c, m.cs).sample(lambda)) * (d.emission.scale * PI * r * r),
                }
            }
            _ => {
                let radiance = match self {
                    Light::Rect(super::RectLight { map: Some(m), emission, .. }) => m.mean(lambda) * emission.scale,
                    _ => self.emission().sample(lambda),
                };
                let phi = radiance * self.phi_factor(disk);
                match self.shaping() {
                    Some(s) => phi * s.power_ratio(lambda),
                    None => phi,
                }
            }
        }
    }

    /// Luminance-weighted power, in the units of [`Light::power`] (equal to it for finite
    /// lights; see the module documentation for infinite ones).
    pub fn phi_y(&self, disk: &EmissionDisk) -> f32 {
        let e = self.emission();
        match self {
            Light::Moving(m) => m.inner.phi_y(disk),
            Light::Dome(super::DomeLight { map: Some(m), .. }) => {
                let r = disk.radius;
                dome_integral(m, |c| SampledSpectrum::splat(color::luminance(c, m.cs).max(0.0))).0[0] * e.scale * PI * r * r
            }
            _ => e.luminance * e.scale * self.phi_factor(disk) * self.shaping().map_or(1.0, |s| s.power_ratio_y()),
        }
    }

    /// Power over emitted radiance (intensity, irradiance) for untextured lights.
    fn phi_factor(&self, disk: &EmissionDisk) -> f32 {
        match self {
            Light::Point(_) => 4.0 * PI,
            Light::Triangle(t) => PI * t.area * if t.two_sided { 2.0 } else { 1.0 },
            Light::Distant(dl) => {
                let (r, per_area) = match dl.disk_kind(disk) {
                    DistantDisk::Fixed(r) if dl.one_minus_cos == 0.0 => (r, 1.0),
                    DistantDisk::Fixed(r) => (r, dl.cone_cos_integral()),
                    DistantDisk::PerRay => (disk.radius, 2.0 * PI * dl.one_minus_cos),
                };
                per_area * PI * r * r
            }
            Light::Dome(_) | Light::Sky(_) => 4.0 * PI * PI * disk.radius * disk.radius,
            _ => PI * self.area(),
        }
    }
}

/// ∫ f(texel colour) dω over a textured dome, each texel weighted by its exact solid angle
/// (2π/w)(cos θ₀ − cos θ₁); texels are looked up nearest, so the radiance is constant on them.
fn dome_integral(m: &DomeMap, f: impl Fn([f32; 3]) -> SampledSpectrum) -> SampledSpectrum {
    let mut acc = [0.0f64; N_SPECTRUM];
    for y in 0..m.height {
        let c0 = (PI as f64 * y as f64 / m.height as f64).cos();
        let c1 = (PI as f64 * (y + 1) as f64 / m.height as f64).cos();
        let omega = 2.0 * std::f64::consts::PI / m.width as f64 * (c0 - c1);
        for x in 0..m.width {
            let c = m.rgb[y * m.width + x];
            if c == [0.0; 3] {
                continue;
            }
            let v = f(c);
            for (a, s) in acc.iter_mut().zip(v.0) {
                *a += s as f64 * omega;
            }
        }
    }
    SampledSpectrum(acc.map(|a| a as f32))
}

#[cfg(test)]
mod tests;
