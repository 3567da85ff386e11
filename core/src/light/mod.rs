//! Tide's lights: every UsdLux light of the USD contract (distant, dome, sphere, rect, disk,
//! cylinder), point lights, and emissive mesh triangles, with their sampling for next-event
//! estimation and power-proportional light selection ([`LightSampler`]).
//!
//! Units follow UsdLux: emitted radiance = `color` × `intensity` × 2^`exposure` (× the
//! normalised blackbody RGB of `colorTemperature` when enabled), uplifted as an illuminant.
//! `normalize` divides area lights by their world-space area (so their power does not change
//! with size) and makes a distant light's `intensity` the irradiance it delivers to a surface
//! facing it.
//!
//! Conventions:
//! - Every pdf returned by [`Light::sample_li`] and [`Light::pdf_li`] is a solid-angle density at
//!   the receiving point; delta lights (point, distant with angle 0) report pdf 1 for their
//!   single direction and `pdf_li` 0.
//! - Area lights emit one-sided: rect and disk towards their local −Z, sphere and cylinder
//!   outwards (the cylinder from its side only), triangles towards their counter-clockwise
//!   front unless two-sided. `intersect` returns the emitting-side normal; `l` tests the side.
//! - A light sample whose radiance is zero because the receiver sees the back of the light is
//!   not returned (`None`), and `pdf_li` is 0 for such directions, so the two always agree.
//!   Shaping (UsdLuxShapingAPI, [`shaping`]) only weights the radiance: a sample outside a
//!   spot light's cone is not returned either, while `pdf_li` keeps the unshaped density
//!   (both strategies then see zero radiance there, so MIS stays consistent).
//!
//! Sampling: sphere lights by the cone they subtend; rect lights uniformly in solid angle
//! (spherical rectangles; by area when sheared or when they subtend under 1e-3 sr); disks,
//! cylinders and triangles by area; distant lights uniformly in their cone; domes by a 2D
//! piecewise-constant distribution of texel luminance × sin θ (uniformly without a texture);
//! the Hošek–Wilkie sky (`LightShape::Sky`) by its tabulated luminance over the upper
//! hemisphere ([`crate::sky::SkySampler`]); a dome or sky with portals partly through the
//! portals that face the receiver ([`portal`]).
//!
//! The sky and its physical sun: `LightShape::Sky` is [`Light::Sky`], an infinite light like
//! a dome (not delta, `le`/`pdf_li` over the upper hemisphere, zero below the horizon, power
//! 4π · mean luminance · πR²). `LightShape::SkySun` is a [`Light::Distant`] of the solar
//! disc's angular diameter (0.51°) whose radiance is the disc's mean spectral radiance
//! ([`crate::sky::HosekWilkieSky::sun_spectrum`]: limb darkening averaged over the disc, the
//! irradiance exact) for its elevation; the light's `color` and `normalize` do not apply.
//!
//! Approximations: a sphere light under a non-uniform scale stays a sphere whose radius is
//! scaled by the mean of the axis scales; a cylinder's cross-section likewise stays circular
//! (mean of the Y and Z scales); a dome's transform is used for its rotation only. A
//! cylinder's `treatAsLine` is ignored (rendered as a true cylinder). A rect light's image
//! (`texture:file`, [`RectMap`]) colours its radiance texel by texel; it is sampled as the
//! untextured rect is, each sample weighted by its texel (none on black texels). Dome textures are looked up nearest-texel so that radiance and sampling
//! density are both piecewise constant over the same cells.

// `!(x > 0.0)` is used on purpose throughout: it rejects NaN along with the out-of-range values.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod bvh;
pub mod distrib;
pub mod dome_format;
pub mod emit;
pub mod ies;
pub mod map_cache;
pub mod portal;
pub mod sampler;
pub mod shaping;
pub mod tree;

#[cfg(test)]
pub(crate) mod tests;

pub use sampler::LightSampler;
pub use shaping::Shaping;

use std::sync::Arc;
use glam::{Mat3, Mat4, Vec2, Vec3};

use crate::math::{sample_concentric_disk, sample_uniform_sphere, Frame, INV_4PI, PI};
use crate::scene::{ColorSpace, LightDesc, LightShape, TextureDesc};
use crate::spectrum::{color, uplift, SampledSpectrum, SampledWavelengths, Spectrum};
use distrib::Distribution2D;

/// Where a light is sampled from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSampleContext {
    pub p: Vec3,
    /// Surface normal at `p`, or `Vec3::ZERO` inside a medium (currently informative only).
    pub n: Vec3,
    /// Shutter time of the path (moving emissive triangles are sampled where they are then).
    pub time: f32,
}

impl LightSampleContext {
    /// A context at time 0.
    pub fn new(p: Vec3, n: Vec3) -> Self {
        LightSampleContext { p, n, time: 0.0 }
    }

    /// The same context at shutter time `time`.
    pub fn at(self, time: f32) -> Self {
        LightSampleContext { time, ..self }
    }
}

/// A sampled direction towards a light.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightLiSample {
    /// Radiance arriving at the receiver along `-wi` (for delta lights: irradiance-like
    /// contribution, to be divided by nothing but the light's selection probability).
    pub l: SampledSpectrum,
    /// Unit direction from the receiver towards the light.
    pub wi: Vec3,
    /// Distance to `p_light`; `f32::INFINITY` for infinite lights.
    pub dist: f32,
    /// Solid-angle density of `wi`; 1 for delta lights.
    pub pdf: f32,
    pub is_delta: bool,
    /// Point on the light (for infinite lights: a point beyond the scene bounds along `wi`).
    pub p_light: Vec3,
    /// Emitting-side normal at `p_light` (for point and infinite lights: `-wi`).
    pub n_light: Vec3,
}

/// What a light emits: a spectrum shape and a scalar scale (intensity, exposure and
/// normalisation folded in).
#[derive(Clone, Debug, PartialEq)]
pub struct Emission {
    pub spectrum: Spectrum,
    pub scale: f32,
    /// Luminance of `spectrum` (CIE Y relative to an equal-energy spectrum of value 1).
    pub luminance: f32,
}

impl Emission {
    pub fn new(spectrum: Spectrum, scale: f32) -> Self {
        let luminance = spectrum_luminance(&spectrum);
        Emission { spectrum, scale, luminance }
    }
    #[inline]
    pub fn sample(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        self.spectrum.sample(lambda) * self.scale
    }
}

/// A distant (directional) light, optionally with an angular extent (a sun disk).
#[derive(Clone, Debug, PartialEq)]
pub struct DistantLight {
    /// Unit direction from the scene towards the light (the light shines along `-to_light`).
    pub to_light: Vec3,
    frame: Frame,
    /// 1 − cos of the cone's half-angle (0 for a delta light), kept separately for precision.
    one_minus_cos: f32,
    /// Radiance of the disk, or for a delta light the irradiance on a facing surface.
    pub emission: Emission,
    pub visible_to_camera: bool,
    scene_radius: f32,
}

/// Lat-long environment map of a dome light.
#[derive(Clone, Debug, PartialEq)]
pub struct DomeMap {
    width: usize,
    height: usize,
    /// Texel RGB × the light's colour, row-major from the top row (+Y).
    rgb: Vec<[f32; 3]>,
    distrib: Distribution2D,
    cs: ColorSpace,
    /// Solid-angle mean of the texels' luminance.
    mean_luminance: f32,
}

/// An infinitely distant environment.
#[derive(Clone, Debug, PartialEq)]
pub struct DomeLight {
    /// Light-to-world rotation.
    rot: Mat3,
    /// Constant colour (no map), or the map's scale (with a map: spectrum unused, scale used).
    pub emission: Emission,
    pub map: Option<Arc<DomeMap>>,
    pub visible_to_camera: bool,
    /// Portals guiding the sampling ([`portal`]); None: the dome's own sampling only.
    pub portals: Option<Box<portal::Portals>>,
    scene_center: Vec3,
    scene_radius: f32,
}

/// The Hošek–Wilkie sky as an infinite light (`LightShape::Sky`): radiance, sampling and
/// density from [`crate::sky::SkyLight`] (the upper hemisphere only; nothing below the horizon).
#[derive(Clone, Debug, PartialEq)]
pub struct SkyDomeLight {
    pub sky: crate::sky::SkyLight,
    /// The sky's solid-angle mean radiance over the whole sphere (∫_H L dω / 4π per
    /// wavelength, scale included) as a spectrum, so that power and `phi` follow the dome's
    /// formulas (4π · mean · πR²); `luminance` is that spectrum's exact Y (scale 1).
    pub emission: Emission,
    pub visible_to_camera: bool,
    /// Portals guiding the sampling ([`portal`]).
    pub portals: Option<Box<portal::Portals>>,
    scene_center: Vec3,
    scene_radius: f32,
}

impl SkyDomeLight {
    fn new(sky: crate::sky::HosekWilkieSky, scale: f32, visible_to_camera: bool) -> Result<SkyDomeLight, String> {
        use crate::sky::data::N_BANDS;
        use crate::sky::model::{band_position, band_xyz_weights};
        let integrals = sky.band_hemisphere_integrals();
        let w = band_xyz_weights();
        let inv4pi = 1.0 / (4.0 * std::f64::consts::PI);
        let mean: [f64; N_BANDS] = std::array::from_fn(|b| integrals[b] * inv4pi * scale as f64);
        let luminance = (0..N_BANDS).map(|b| w[b][1] * mean[b]).sum::<f64>() as f32;
        // the band values interpolated as the sky interpolates its radiance (linear between
        // bands, held from 720 nm), tabulated every nanometre so the interpolation is kept
        let lambda: Vec<f32> = (crate::spectrum::LAMBDA_MIN as u32..=crate::spectrum::LAMBDA_MAX as u32).map(|l| l as f32).collect();
        let value: Vec<f32> = lambda
            .iter()
            .map(|&l| match band_position(l as f64) {
                Some((i, f)) => ((1.0 - f) * mean[i] + f * mean[i + 1]) as f32,
                None => 0.0,
            })
            .collect();
        let spectrum = Spectrum::tabulated(&lambda, &value).map_err(|e| err("tide:sky:model", format!("mean sky spectrum: {e}")))?;
        let light = crate::sky::SkyLight::new(sky, scale).map_err(|e| e.to_string())?;
        Ok(SkyDomeLight { sky: light, emission: Emission { spectrum, scale: 1.0, luminance }, visible_to_camera, portals: None, scene_center: Vec3::ZERO, scene_radius: 1.0 })
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct SphereLight {
    pub center: Vec3,
    pub radius: f32,
    pub emission: Emission,
    pub visible_to_camera: bool,
    pub shaping: Option<Box<Shaping>>,
}

#[derive(Clone, Debug, PartialEq)]
pub struct PointLight {
    pub p: Vec3,
    /// Radiant intensity (per steradian).
    pub emission: Emission,
    pub shaping: Option<Box<Shaping>>,
}

/// A parallelogram (rect) or ellipse (disk) spanned by `a`, `b` about `origin`.
#[derive(Clone, Debug, PartialEq)]
pub struct Planar {
    /// Rect: a corner; disk: the centre.
    pub origin: Vec3,
    pub a: Vec3,
    pub b: Vec3,
    /// Unit normal of the emitting side.
    pub n: Vec3,
    /// Dual basis: `da·a = 1, da·b = 0`, `db·b = 1, db·a = 0`.
    da: Vec3,
    db: Vec3,
    pub area: f32,
}

impl Planar {
    fn new(origin: Vec3, a: Vec3, b: Vec3, front: Vec3, ellipse: bool) -> Option<Planar> {
        let c = a.cross(b);
        let c2 = c.length_squared();
        let area = c2.sqrt() * if ellipse { PI } else { 1.0 };
        if !(area > 0.0) || !area.is_finite() || !c2.is_normal() {
            return None;
        }
        let n = c / c2.sqrt();
        let d = front.dot(n);
        let n = if d < 0.0 { -n } else { n };
        Some(Planar { origin, a, b, n, da: b.cross(c) / c2, db: c.cross(a) / c2, area })
    }

    #[inline]
    fn hit(&self, o: Vec3, d: Vec3, t_max: f32, ellipse: bool) -> Option<(f32, Vec3, Vec3)> {
        let denom = d.dot(self.n);
        if denom == 0.0 {
            return None;
        }
        let t = (self.origin - o).dot(self.n) / denom;
        if !(t > 0.0 && t < t_max) {
            return None;
        }
        let p = o + d * t;
        let q = p - self.origin;
        let (s, u) = (self.da.dot(q), self.db.dot(q));
        // EDGE_EPS: rays towards points sampled on the rim must not miss by rounding
        let inside = if ellipse {
            s * s + u * u <= 1.0 + 2.0 * EDGE_EPS
        } else {
            (-EDGE_EPS..=1.0 + EDGE_EPS).contains(&s) && (-EDGE_EPS..=1.0 + EDGE_EPS).contains(&u)
        };
        inside.then_some((t, p, self.n))
    }
}

/// A rect light. Sampled uniformly in the solid angle it subtends (spherical rectangles,
/// Ureña, Fajardo and King 2013) when it is a true rectangle that subtends at least
/// [`MIN_SPHERICAL_RECT`] sr, otherwise by area.
#[derive(Clone, Debug, PartialEq)]
pub struct RectLight {
    pub shape: Planar,
    pub emission: Emission,
    pub visible_to_camera: bool,
    /// The edges are orthogonal (no shear in the transform).
    rectangular: bool,
    pub shaping: Option<Box<Shaping>>,
    /// `texture:file`: the image over the rectangle (texels × the light's colour).
    pub map: Option<Arc<RectMap>>,
}

/// A rect light's image: its first column at the light's +X edge and its top row at the +Y
/// edge (UsdLux: "a texture file's min coordinates should be at (+X, +Y) and max coordinates
/// at (−X, −Y)"), so that it reads upright from the side it lights; looked up nearest-texel.
#[derive(Clone, Debug, PartialEq)]
pub struct RectMap {
    width: usize,
    height: usize,
    rgb: Vec<[f32; 3]>,
    cs: ColorSpace,
}

impl RectMap {
    fn new(tex: &TextureDesc, tint: [f32; 3], cs: ColorSpace) -> Result<RectMap, String> {
        let (width, height, rgb) = light_texels(tex, tint)?;
        Ok(RectMap { width, height, rgb, cs })
    }

    #[inline]
    fn at(&self, s: f32, t: f32) -> [f32; 3] {
        nearest_texel(&self.rgb, self.width, self.height, s, t)
    }

    /// Mean luminance of the texels.
    fn mean_luminance(&self) -> f32 {
        (self.rgb.iter().map(|&c| color::luminance(c, self.cs).max(0.0) as f64).sum::<f64>() / self.rgb.len() as f64) as f32
    }

    /// Mean spectral value of the uplifted texels at `lambda` (cost ∝ texels).
    fn mean(&self, lambda: &SampledWavelengths) -> SampledSpectrum {
        let mut acc = [0.0f64; crate::spectrum::N_SPECTRUM];
        for &c in &self.rgb {
            if c != [0.0; 3] {
                let v = uplift::illuminant(c, self.cs).sample(lambda);
                for (a, x) in acc.iter_mut().zip(v.0) {
                    *a += x as f64;
                }
            }
        }
        SampledSpectrum(acc.map(|a| (a / self.rgb.len() as f64) as f32))
    }
}

impl RectLight {
    /// Radiance leaving point `p` of the rectangle (its image's texel there, if it has one).
    #[inline]
    fn radiance(&self, p: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        match &self.map {
            None => self.emission.sample(lambda),
            Some(m) => {
                let q = p - self.shape.origin;
                let c = m.at(1.0 - self.shape.da.dot(q), 1.0 - self.shape.db.dot(q));
                if c == [0.0; 3] {
                    return SampledSpectrum::ZERO;
                }
                uplift::illuminant(c, m.cs).sample(lambda) * self.emission.scale
            }
        }
    }
}

/// Below this solid angle (sr) a rect is area-sampled: its spherical rectangle would lose
/// precision to cancellation, and area sampling is then nearly uniform in solid angle anyway.
pub const MIN_SPHERICAL_RECT: f32 = 1e-3;

/// A rectangle as seen from a point, in the rectangle's frame centred on that point.
struct SphericalRect {
    p: glam::DVec3,
    x: glam::DVec3,
    y: glam::DVec3,
    z: glam::DVec3,
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
    z0: f64,
    b0: f64,
    b1: f64,
    k: f64,
    /// Solid angle.
    s: f64,
}

impl SphericalRect {
    fn new(p: Vec3, corner: Vec3, a: Vec3, b: Vec3) -> Option<SphericalRect> {
        let (a, b, p) = (a.as_dvec3(), b.as_dvec3(), p.as_dvec3());
        let (la, lb) = (a.length(), b.length());
        let (x, y) = (a / la, b / lb);
        let mut z = x.cross(y);
        let d = corner.as_dvec3() - p;
        let (x0, y0, mut z0) = (d.dot(x), d.dot(y), d.dot(z));
        if z0 > 0.0 {
            z = -z;
            z0 = -z0;
        }
        if !(z0 < 0.0) {
            return None;
        }
        let (x1, y1) = (x0 + la, y0 + lb);
        let v00 = glam::DVec3::new(x0, y0, z0);
        let v01 = glam::DVec3::new(x0, y1, z0);
        let v10 = glam::DVec3::new(x1, y0, z0);
        let v11 = glam::DVec3::new(x1, y1, z0);
        // normals of the planes through p and each edge
        let n0 = v00.cross(v10).normalize();
        let n1 = v10.cross(v11).normalize();
        let n2 = v11.cross(v01).normalize();
        let n3 = v01.cross(v00).normalize();
        let angle = |m: glam::DVec3, n: glam::DVec3| (-m.dot(n)).clamp(-1.0, 1.0).acos();
        let (g0, g1, g2, g3) = (angle(n0, n1), angle(n1, n2), angle(n2, n3), angle(n3, n0));
        let k = 2.0 * std::f64::consts::PI - g2 - g3;
        let s = g0 + g1 - k;
        if !(s >= MIN_SPHERICAL_RECT as f64) || !s.is_finite() {
            return None;
        }
        Some(SphericalRect { p, x, y, z, x0, x1, y0, y1, z0, b0: n0.z, b1: n2.z, k, s })
    }

    /// Uniform point of the rectangle in solid angle.
    fn sample(&self, u: Vec2) -> Option<Vec3> {
        let au = u.x as f64 * self.s + self.k;
        let (sa, ca) = au.sin_cos();
        let fu = (ca * self.b0 - self.b1) / sa;
        let cu = (1.0 / (fu * fu + self.b0 * self.b0).sqrt()).copysign(fu).clamp(-1.0, 1.0);
        let xu = (-(cu * self.z0) / (1.0 - cu * cu).max(1e-300).sqrt()).clamp(self.x0, self.x1);
        let d = (xu * xu + self.z0 * self.z0).sqrt();
        let h0 = self.y0 / (d * d + self.y0 * self.y0).sqrt();
        let h1 = self.y1 / (d * d + self.y1 * self.y1).sqrt();
        let hv = h0 + u.y as f64 * (h1 - h0);
        let hv2 = hv * hv;
        let yv = if hv2 < 1.0 - 1e-12 { (hv * d / (1.0 - hv2).sqrt()).clamp(self.y0, self.y1) } else { self.y1 };
        let q = self.p + self.x * xu + self.y * yv + self.z * self.z0;
        q.is_finite().then(|| q.as_vec3())
    }
}

impl RectLight {
    #[inline]
    fn spherical(&self, p: Vec3) -> Option<SphericalRect> {
        if !self.rectangular {
            return None;
        }
        SphericalRect::new(p, self.shape.origin, self.shape.a, self.shape.b)
    }

    /// Whether `p` is on the emitting side.
    #[inline]
    fn faces(&self, p: Vec3) -> bool {
        (p - self.shape.origin).dot(self.shape.n) > 0.0
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct DiskLight {
    pub shape: Planar,
    pub emission: Emission,
    pub visible_to_camera: bool,
    pub shaping: Option<Box<Shaping>>,
}

/// An open cylinder (no caps) emitting outwards from its side.
#[derive(Clone, Debug, PartialEq)]
pub struct CylinderLight {
    pub center: Vec3,
    /// Frame whose `n` is the cylinder's axis.
    frame: Frame,
    pub half_length: f32,
    pub radius: f32,
    pub area: f32,
    pub emission: Emission,
    pub visible_to_camera: bool,
    pub shaping: Option<Box<Shaping>>,
}

/// An emissive mesh triangle (world space). `p`, `n` and `area` are its place at the shutter's
/// open; a triangle of a moving instance or a deforming mesh also carries its `motion`, and is
/// sampled where it is at the time of the sample ([`LightSampleContext::time`]).
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleLight {
    pub p: [Vec3; 3],
    /// Unit normal of the front: the counter-clockwise side, or the clockwise one where
    /// `mirrored`.
    pub n: Vec3,
    /// A mirroring transform placed the triangle: its front (its mesh's counter-clockwise side
    /// in the mesh's own space) is the clockwise side of its placed vertices.
    pub mirrored: bool,
    pub area: f32,
    pub two_sided: bool,
    /// The radiance; an estimate of its mean where it varies (for the light's power).
    pub emission: Emission,
    pub motion: Option<std::sync::Arc<TriangleMotion>>,
    /// Radiance that varies over the triangle as the surface's emission does. None:
    /// `emission` everywhere.
    pub varying: Option<Box<VaryingEmission>>,
}

/// An emissive triangle's radiance where it varies over the triangle (RGB in `cs`).
#[derive(Clone, Debug, PartialEq)]
pub enum VaryingEmission {
    /// RGB at each corner, interpolated (emission read from a primvar).
    Corners { rgb: [[f32; 3]; 3], cs: ColorSpace },
    /// A texture looked up at the corners' texture coordinates, interpolated (`lookup` names
    /// texture 0, `texture`).
    Texture { texture: std::sync::Arc<TextureDesc>, lookup: crate::scene::TexLookup, uv: [Vec2; 3], cs: ColorSpace },
    /// A node graph evaluated where the sample lies: its primvars interpolated from the
    /// corners (`corners[i]`: primvar `graph.names[i]` at each corner, None where the geometry
    /// lacks it), its textures looked up at interpolated coordinates (`uv`: the mesh's).
    /// `object` and `world`: the corners in the mesh's own space and in the world; `normals`:
    /// the mesh's own normals at the corners in those two spaces, where it has them.
    Graph {
        graph: std::sync::Arc<EmissionGraph>,
        corners: Box<[Option<[[f32; 4]; 3]>]>,
        uv: [Vec2; 3],
        object: [Vec3; 3],
        world: [Vec3; 3],
        normals: Option<[[Vec3; 3]; 2]>,
        cs: ColorSpace,
    },
}

/// A node graph's emission as its triangles share it: the graph with its texture indices into
/// `textures`, and the primvars it reads.
#[derive(Clone, Debug, PartialEq)]
pub struct EmissionGraph {
    pub expr: crate::shader_graph::Expr,
    pub textures: Vec<std::sync::Arc<TextureDesc>>,
    /// [`crate::shader_graph::Expr::primvar_names`].
    pub names: Vec<String>,
}

/// What a node graph's lookups read at barycentric coordinates `b` of an emissive triangle.
struct OnTriangle<'a> {
    graph: &'a EmissionGraph,
    corners: &'a [Option<[[f32; 4]; 3]>],
    uv: [Vec2; 3],
    object: [Vec3; 3],
    world: [Vec3; 3],
    normals: Option<[[Vec3; 3]; 2]>,
    b: [f32; 3],
}

impl crate::shader_graph::Lookups for OnTriangle<'_> {
    fn texture(&self, l: &crate::scene::TexLookup, st: Vec2) -> [f32; 4] {
        crate::texture::lookup_rgba_in(self.graph.textures.get(l.texture).map(|t| &**t), l, st)
    }

    fn uv(&self) -> Vec2 {
        self.uv[0] * self.b[0] + self.uv[1] * self.b[1] + self.uv[2] * self.b[2]
    }

    fn position(&self, world: bool) -> Vec3 {
        let p = if world { self.world } else { self.object };
        p[0] * self.b[0] + p[1] * self.b[1] + p[2] * self.b[2]
    }

    /// The triangle's own normal (its winding's side), in either space.
    /// The mesh's normals interpolated, as a camera ray's hit reads them; the face's where the
    /// mesh has none.
    fn normal(&self, world: bool) -> Vec3 {
        if let Some(n) = &self.normals {
            let n = n[usize::from(world)];
            return (n[0] * self.b[0] + n[1] * self.b[1] + n[2] * self.b[2]).normalize_or_zero();
        }
        let p = if world { self.world } else { self.object };
        (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero()
    }

    fn tangent(&self, world: bool) -> Vec3 {
        crate::math::triangle_dpdu(if world { self.world } else { self.object }, self.uv).normalize_or_zero()
    }

    fn primvar(&self, l: &crate::scene::PrimvarLookup) -> [f32; 4] {
        let corners = self.graph.names.iter().position(|n| *n == l.name).and_then(|i| self.corners.get(i).copied().flatten());
        let v = corners.map_or(l.fallback, |c| std::array::from_fn(|k| self.b[0] * c[0][k] + self.b[1] * c[1][k] + self.b[2] * c[2][k]));
        std::array::from_fn(|k| v[k] * l.scale[k])
    }
}

impl VaryingEmission {
    /// RGB at barycentric coordinates (b0, b1, b2), before clamping, and its colour space.
    pub fn rgb(&self, b: [f32; 3]) -> ([f32; 3], ColorSpace) {
        match self {
            VaryingEmission::Corners { rgb, cs } => (std::array::from_fn(|k| b[0] * rgb[0][k] + b[1] * rgb[1][k] + b[2] * rgb[2][k]), *cs),
            VaryingEmission::Texture { texture, lookup, uv, cs } => {
                let st = uv[0] * b[0] + uv[1] * b[1] + uv[2] * b[2];
                (crate::texture::lookup_rgb(std::slice::from_ref(&**texture), lookup, st), *cs)
            }
            VaryingEmission::Graph { graph, corners, uv, object, world, normals, cs } => {
                let v = graph.expr.eval(&OnTriangle { graph, corners, uv: *uv, object: *object, world: *world, normals: *normals, b });
                ([v[0], v[1], v[2]], *cs)
            }
        }
    }
}

/// Where a moving emissive triangle is over the shutter, evaluated exactly as the scene's
/// acceleration structure places the geometry: object-space vertices interpolated linearly
/// between the mesh's motion samples, then the instance's object-to-world at that time.
#[derive(Clone, Debug, PartialEq)]
pub struct TriangleMotion {
    /// Times of `p` (one entry for a mesh that does not deform).
    pub times: Vec<f32>,
    /// Object-space vertices at each time.
    pub p: Vec<[Vec3; 3]>,
    /// The instance's object-to-world over the shutter (shared by its triangles).
    pub xf: std::sync::Arc<crate::accel::motion::MotionTransform>,
}

impl TriangleMotion {
    /// World-space vertices at `time`.
    pub fn at(&self, time: f32) -> [Vec3; 3] {
        let obj = if self.p.len() >= 2 {
            let (i, w) = crate::scene::locate_key(&self.times, time);
            [0, 1, 2].map(|k| self.p[i][k].lerp(self.p[i + 1][k], w))
        } else {
            self.p[0]
        };
        let m = self.xf.at(time);
        obj.map(|v| m.transform_point3(v))
    }
}

impl TriangleLight {
    /// Radiance at barycentric coordinates (b1, b2).
    #[inline]
    pub fn radiance(&self, b1: f32, b2: f32, lambda: &SampledWavelengths) -> SampledSpectrum {
        let b0 = 1.0 - b1 - b2;
        let (rgb, cs) = match self.varying.as_deref() {
            None => return self.emission.sample(lambda),
            Some(v) => v.rgb([b0, b1, b2]),
        };
        let rgb: [f32; 3] = rgb.map(|v| v.max(0.0));
        if rgb == [0.0; 3] {
            return SampledSpectrum::ZERO;
        }
        uplift::illuminant(rgb, cs).sample(lambda) * self.emission.scale
    }

    /// Barycentric coordinates (b1, b2) of a point of the triangle (as it stands unmoved).
    fn barycentric(&self, p: Vec3) -> (f32, f32) {
        let (e1, e2, v) = (self.p[1] - self.p[0], self.p[2] - self.p[0], p - self.p[0]);
        let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
        let (v1, v2) = (v.dot(e1), v.dot(e2));
        let det = d11 * d22 - d12 * d12;
        if !(det > 0.0) {
            return (1.0 / 3.0, 1.0 / 3.0);
        }
        ((d22 * v1 - d12 * v2) / det, (d11 * v2 - d12 * v1) / det)
    }

    /// Vertices, unit normal and area at `time`; None where the moving triangle degenerates.
    #[inline]
    pub fn at_time(&self, time: f32) -> Option<([Vec3; 3], Vec3, f32)> {
        let Some(m) = &self.motion else { return Some((self.p, self.n, self.area)) };
        let p = m.at(time);
        let c = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = c.length();
        let side = if self.mirrored { -1.0 } else { 1.0 };
        (len > 0.0 && len.is_finite() && c.length_squared().is_normal()).then(|| (p, c * (side / len), 0.5 * len))
    }
}

/// Any light. Enum dispatch: no virtual calls in the sampling loop.
#[derive(Clone, Debug, PartialEq)]
pub enum Light {
    Distant(DistantLight),
    Dome(DomeLight),
    Sky(Box<SkyDomeLight>),
    Sphere(SphereLight),
    Rect(RectLight),
    Disk(DiskLight),
    Cylinder(CylinderLight),
    Triangle(TriangleLight),
    Point(PointLight),
    /// A finite light that moves over the shutter (see [`MovingLight`]).
    Moving(Box<MovingLight>),
}

/// A finite light moving over the shutter: `inner` is the light where its `transform` puts
/// it, and each query at time t is answered by `inner` in its own frame, carried by the rigid
/// move from there to where the light is at t (the light's keyed light-to-world interpolated as
/// the scene's instances are, its scale change dropped: a light keeps its size).
#[derive(Clone, Debug, PartialEq)]
pub struct MovingLight {
    pub inner: Light,
    motion: crate::accel::motion::MotionTransform,
    /// Inverse of the transform `inner` was built with.
    base_inv: Mat4,
}

impl MovingLight {
    /// The rigid move (world to world) from where `inner` is to where the light is at `time`,
    /// and its inverse.
    #[inline]
    fn moves(&self, time: f32) -> (Mat4, Mat4) {
        let (_, r, t) = (self.motion.at(time) * self.base_inv).to_scale_rotation_translation();
        let m = Mat4::from_rotation_translation(r.normalize(), t);
        (m, m.inverse())
    }
}

fn err(attr: &str, what: impl std::fmt::Display) -> String {
    format!("{attr}: {what}")
}

fn check_finite(attr: &str, v: f32) -> Result<f32, String> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(err(attr, format!("not finite ({v})")))
    }
}

fn check_length(attr: &str, v: f32) -> Result<f32, String> {
    let v = check_finite(attr, v)?;
    if v < 0.0 {
        return Err(err(attr, format!("negative ({v})")));
    }
    Ok(v)
}

/// Direction of the lat-long coordinates (u, t) in the dome's frame, where u is
/// the image column fraction (longitude +π at u = 0, −π at u = 1) and t the row fraction from
/// the top (+Y at t = 0). Longitude 0 is +Z, longitude π/2 is +X (OpenEXR lat-long).
#[inline]
fn latlong_direction(u: f32, t: f32) -> Vec3 {
    let theta = t * PI;
    let lon = PI - 2.0 * PI * u;
    let (st, ct) = theta.sin_cos();
    let (sl, cl) = lon.sin_cos();
    Vec3::new(st * sl, ct, st * cl)
}

/// Inverse of [`latlong_direction`]: (u, t, sin θ).
#[inline]
fn latlong_coords(d: Vec3) -> (f32, f32, f32) {
    let lon = d.x.atan2(d.z);
    let u = (PI - lon) * (0.5 / PI);
    let t = d.y.clamp(-1.0, 1.0).acos() / PI;
    let sin_theta = (d.x * d.x + d.z * d.z).sqrt();
    (u.clamp(0.0, 1.0), t.clamp(0.0, 1.0), sin_theta)
}

/// Direction in the cone about +Z with 1 − cosθ uniform in [0, one_minus_cos]
/// (`math::sample_uniform_cone` parameterised by 1 − cos, which keeps a 0.5° sun disk exact in f32).
#[inline]
fn sample_cone(u: Vec2, one_minus_cos: f32) -> Vec3 {
    let x = u.x * one_minus_cos;
    let cos_t = 1.0 - x;
    let sin_t = (x * (2.0 - x)).max(0.0).sqrt();
    let (sp, cp) = (2.0 * PI * u.y).sin_cos();
    Vec3::new(sin_t * cp, sin_t * sp, cos_t)
}

/// Whether unit `w` lies in the cone of unit axis `axis` with the given 1 − cos half-angle.
/// Uses the chord length (|w − axis|² = 2(1 − cos)), which is exact for tiny cones; the relative
/// slack of 1e-4 covers the rounding of sampled directions on the rim.
#[inline]
fn in_cone(w: Vec3, axis: Vec3, one_minus_cos: f32) -> bool {
    (w - axis).length_squared() <= 2.0 * one_minus_cos * (1.0 + 1e-4)
}

/// CIE 1931 ȳ by the multi-lobe Gaussian fit of Wyman, Sloan and Shirley (2013).
fn cie_y_fit(lambda: f32) -> f32 {
    let g = |mu: f32, s1: f32, s2: f32| {
        let t = (lambda - mu) / if lambda < mu { s1 } else { s2 };
        (-0.5 * t * t).exp()
    };
    0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1)
}

/// Luminance of a spectrum relative to an equal-energy spectrum of value 1 (∫Sȳ / ∫ȳ), used to
/// weigh light powers against each other.
pub fn spectrum_luminance(s: &Spectrum) -> f32 {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    let mut l = 360.0f32;
    while l <= 830.0 {
        let y = cie_y_fit(l) as f64;
        num += s.eval(l).max(0.0) as f64 * y;
        den += y;
        l += 5.0;
    }
    (num / den) as f32
}


/// The texel of a `w` × `h` image (rows from the top) that covers (u, t) ∈ [0, 1]²; outside,
/// the nearest edge texel (float-to-index casts saturate: NaN and negatives give 0).
#[inline]
fn nearest_texel(rgb: &[[f32; 3]], w: usize, h: usize, u: f32, t: f32) -> [f32; 3] {
    let x = ((u * w as f32) as usize).min(w - 1);
    let y = ((t * h as f32) as usize).min(h - 1);
    rgb[y * w + x]
}

/// A light's image as RGB texels × the light's colour `tint`, row-major from the top row, with
/// its width and height. Errors name the texture (no pixels, wrong channels or size,
/// non-finite values); negative texels (ringing of resampled HDRs) emit nothing.
fn light_texels(tex: &TextureDesc, tint: [f32; 3]) -> Result<(usize, usize, Vec<[f32; 3]>), String> {
    let (w, h, ch) = (tex.width as usize, tex.height as usize, tex.channels as usize);
    if w == 0 || h == 0 {
        return Err(err("texture", format!("'{}' has no pixels ({w}×{h})", tex.name)));
    }
    if !matches!(ch, 1 | 3 | 4) {
        return Err(err("texture", format!("'{}' has {ch} channels (1, 3 or 4 expected)", tex.name)));
    }
    if tex.pixels.len() != w * h * ch {
        return Err(err("texture", format!("'{}' holds {} values, {w}×{h}×{ch} expected", tex.name, tex.pixels.len())));
    }
    let mut rgb = Vec::with_capacity(w * h);
    for i in 0..w * h {
        let texel = tex.pixels.texel(i * ch, ch);
        let px = &texel[..ch];
        if let Some(bad) = px.iter().find(|v| !v.is_finite()) {
            return Err(err("texture", format!("'{}' has a non-finite value ({bad}) at pixel ({}, {})", tex.name, i % w, i / w)));
        }
        let c = if ch == 1 { [px[0]; 3] } else { [px[0], px[1], px[2]] };
        rgb.push([c[0].max(0.0) * tint[0], c[1].max(0.0) * tint[1], c[2].max(0.0) * tint[2]]);
    }
    Ok((w, h, rgb))
}

impl DomeMap {
    fn new(tex: &TextureDesc, tint: [f32; 3], cs: ColorSpace) -> Result<DomeMap, String> {
        let (w, h, rgb) = light_texels(tex, tint)?;
        let mut func = Vec::with_capacity(w * h);
        let mut mean = 0.0f64;
        for y in 0..h {
            let sin_row = (PI * (y as f32 + 0.5) / h as f32).sin();
            for x in 0..w {
                let lum = color::luminance(rgb[y * w + x], cs).max(0.0);
                func.push(lum * sin_row);
                mean += (lum * sin_row) as f64;
            }
        }
        // ∫ lum dω / 4π with dω = 2π² sinθ du dt
        let mean_luminance = (mean / (w * h) as f64 * 2.0 * (PI as f64).powi(2) / (4.0 * PI as f64)) as f32;
        Ok(DomeMap { width: w, height: h, rgb, distrib: Distribution2D::new(&func, w, h), cs, mean_luminance })
    }

    #[inline]
    fn texel(&self, u: f32, t: f32) -> [f32; 3] {
        nearest_texel(&self.rgb, self.width, self.height, u, t)
    }
}

impl DomeLight {
    #[inline]
    fn to_local(&self, w: Vec3) -> Vec3 {
        self.rot.transpose() * w
    }

    fn le(&self, w: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        match &self.map {
            None => self.emission.sample(lambda),
            Some(m) => {
                let (u, t, _) = latlong_coords(self.to_local(w));
                let c = m.texel(u, t);
                if c == [0.0; 3] {
                    return SampledSpectrum::ZERO;
                }
                uplift::illuminant(c, m.cs).sample(lambda) * self.emission.scale
            }
        }
    }

    fn pdf(&self, w: Vec3) -> f32 {
        match &self.map {
            None => INV_4PI,
            Some(m) => {
                if !(m.distrib.integral() > 0.0) {
                    return 0.0;
                }
                let (u, t, sin_theta) = latlong_coords(self.to_local(w));
                if sin_theta <= 0.0 {
                    return 0.0;
                }
                m.distrib.pdf([u, t]) / (2.0 * PI * PI * sin_theta)
            }
        }
    }
}

/// The portals of a dome's description, world space, sampled with `share`; None without any.
fn portals_of(desc: &LightDesc, share: f32) -> Result<Option<Box<portal::Portals>>, String> {
    if desc.portals.is_empty() {
        return Ok(None);
    }
    let rects: Vec<_> = desc.portals.iter().map(|p| (p.transform, p.width, p.height)).collect();
    match portal::Portals::new(&rects, share) {
        Ok(ps) => Ok(Some(Box::new(ps))),
        Err((i, e)) => Err(err("portals", format!("'{}': {e}", desc.portals[i].name))),
    }
}

impl Light {
    /// A dome's or the sky's portals.
    #[inline]
    fn portals(&self) -> Option<&portal::Portals> {
        match self {
            Light::Dome(d) => d.portals.as_deref(),
            Light::Sky(d) => d.portals.as_deref(),
            _ => None,
        }
    }

    /// An infinite light's own density of unit direction `wi`, portals aside.
    #[inline]
    pub(crate) fn environment_pdf(&self, wi: Vec3) -> f32 {
        match self {
            Light::Dome(d) => d.pdf(wi),
            Light::Sky(d) => d.sky.pdf_li(wi),
            _ => 0.0,
        }
    }

    /// A direction by an infinite light's own sampling, portals aside.
    #[inline]
    fn environment_direction(&self, u: Vec2) -> Option<Vec3> {
        match self {
            Light::Dome(d) => match &d.map {
                None => Some(sample_uniform_sphere(u)),
                Some(m) => {
                    if !(m.distrib.integral() > 0.0) {
                        return None;
                    }
                    let (uv, _) = m.distrib.sample([u.x, u.y]);
                    Some((d.rot * latlong_direction(uv[0], uv[1])).normalize())
                }
            },
            Light::Sky(d) => d.sky.sampler.sample(u).map(|(wi, _)| wi),
            _ => None,
        }
    }

    /// `sample_li` of a dome or the sky; `guided`: through its portals where they face
    /// `ctx.p` (else by its own sampling alone, as light emission samples it).
    pub(crate) fn sample_environment(&self, ctx: &LightSampleContext, u: Vec2, lambda: &SampledWavelengths, guided: bool) -> Option<LightLiSample> {
        let (centre, radius) = match self {
            Light::Dome(d) => (d.scene_center, d.scene_radius),
            Light::Sky(d) => (d.scene_center, d.scene_radius),
            _ => return None,
        };
        // the directions drawn are unit vectors already
        let (wi, pdf) = match self.portals().filter(|_| guided) {
            None => {
                let wi = self.environment_direction(u)?;
                (wi, self.environment_pdf(wi))
            }
            Some(ps) => {
                let (strategy, total) = ps.sample(ctx.p, u);
                let (wi, through) = match strategy {
                    portal::Strategy::Portal(wi, i) => (wi?, Some(i)),
                    portal::Strategy::Own(u) => (self.environment_direction(u)?, None),
                };
                // the density of the direction itself, as `pdf_li` gives it
                (wi, ps.mix(ctx.p, wi, self.environment_pdf(wi), total, through))
            }
        };
        if !(pdf > 0.0) {
            return None;
        }
        let l = match self {
            Light::Dome(d) => d.le(wi, lambda),
            // the sky's radiance as `le` gives it, bit for bit
            _ => self.le(wi, lambda),
        };
        let far = (ctx.p - centre).length() + 2.0 * radius;
        Some(LightLiSample { l, wi, dist: f32::INFINITY, pdf, is_delta: false, p_light: ctx.p + wi * far, n_light: -wi })
    }
}

impl Light {
    /// Builds a light from its UsdLux description. `textures` is the scene's texture table
    /// (the dome's lat-long map indexes into it). Errors name the attribute: "radius: ...".
    pub fn from_desc(desc: &LightDesc, textures: &[TextureDesc], cs: ColorSpace) -> Result<Light, String> {
        Light::from_desc_with(desc, textures, cs, None)
    }

    /// [`Light::from_desc`], taking a dome's map from `maps` where an earlier build made it.
    pub(crate) fn from_desc_with(desc: &LightDesc, textures: &[TextureDesc], cs: ColorSpace, maps: Option<&mut map_cache::MapSession>) -> Result<Light, String> {
        let m = desc.transform;
        if !m.is_finite() {
            return Err(err("transform", "not finite"));
        }
        let intensity = check_finite("intensity", desc.intensity)?;
        let exposure = check_finite("exposure", desc.exposure)?;
        for (i, &c) in desc.color.iter().enumerate() {
            check_finite("color", c)?;
            if c < 0.0 {
                return Err(err("color", format!("component {i} is negative ({c})")));
            }
        }
        let mut rgb = desc.color;
        if let Some(k) = desc.color_temperature {
            if !(k.is_finite() && k > 0.0) {
                return Err(err("colorTemperature", format!("must be a positive number of kelvin ({k})")));
            }
            let bb = color::blackbody_rgb(k, cs);
            rgb = [rgb[0] * bb[0], rgb[1] * bb[1], rgb[2] * bb[2]];
        }
        let scale = intensity * exposure.exp2();
        if !scale.is_finite() {
            return Err(err("exposure", format!("intensity × 2^exposure overflows ({intensity} × 2^{exposure})")));
        }
        let m3 = Mat3::from_mat4(m);
        let origin = m.transform_point3(Vec3::ZERO);
        let vis = desc.visible_to_camera;
        let emission = |s: f32| Emission::new(uplift::illuminant(rgb, cs), s);
        // front of a planar light: where its local −Z goes (falls back to the plane normal)
        let front = -(m3 * Vec3::Z);
        // the light's image in the scene's texture table
        let texture_of = |t: &Option<usize>| -> Result<Option<&TextureDesc>, String> {
            match t {
                None => Ok(None),
                Some(i) => textures.get(*i).map(Some).ok_or_else(|| err("texture:file", format!("texture index {i} out of range ({} textures)", textures.len()))),
            }
        };
        // UsdLuxShapingAPI about the light's axis (its −Z, or a planar light's normal)
        let shaping = |axis: Vec3, spread: shaping::Spread| -> Result<Option<Box<Shaping>>, String> {
            match &desc.shaping {
                None => Ok(None),
                Some(sd) => Ok(Shaping::with_frame(sd, axis, m3 * Vec3::X, spread, cs)?.map(Box::new)),
            }
        };

        let light = match &desc.shape {
            LightShape::Distant { angle_deg } => {
                let angle = check_finite("angle", *angle_deg)?;
                if !(0.0..=360.0).contains(&angle) {
                    return Err(err("angle", format!("must lie in [0, 360] degrees ({angle})")));
                }
                let to_light = m3 * Vec3::Z;
                if !(to_light.length_squared() > 0.0) {
                    return Err(err("transform", "collapses the light's direction"));
                }
                let to_light = to_light.normalize();
                let half = 0.5 * angle.to_radians();
                let omc = 2.0 * (0.5 * half).sin().powi(2);
                let s = if omc == 0.0 {
                    // delta light: intensity is the irradiance on a facing surface either way
                    scale
                } else if desc.normalize {
                    // UsdLux's sizeFactor: ∫_cone |cos| dω, π sin²(half) up to a hemisphere and
                    // π (2 − sin²(half)) beyond, so that a facing surface receives the
                    // intensity up to 90° and less past it
                    let sin2 = half.sin().powi(2);
                    scale / (PI * if half > 0.5 * PI { 2.0 - sin2 } else { sin2 })
                } else {
                    scale
                };
                Light::Distant(DistantLight {
                    to_light,
                    frame: Frame::from_normal(to_light),
                    one_minus_cos: omc,
                    emission: emission(s),
                    visible_to_camera: vis,
                    scene_radius: 1.0,
                })
            }
            LightShape::Dome { texture } => {
                let x = (m3 * Vec3::X).normalize_or_zero();
                let y = m3 * Vec3::Y;
                let y = (y - x * x.dot(y)).normalize_or_zero();
                if x == Vec3::ZERO || y == Vec3::ZERO {
                    return Err(err("transform", "collapses the dome's orientation"));
                }
                let rot = Mat3::from_cols(x, y, x.cross(y));
                let map = match texture_of(texture)? {
                    None => None,
                    Some(tex) => Some(match maps {
                        Some(maps) => maps.dome(tex, rgb, cs)?,
                        None => Arc::new(DomeMap::new(tex, rgb, cs)?),
                    }),
                };
                let mut em = emission(scale);
                if let Some(mp) = &map {
                    em.luminance = mp.mean_luminance;
                }
                let portals = portals_of(desc, if map.is_some() { portal::PORTAL_SHARE_MAPPED } else { portal::PORTAL_SHARE })?;
                Light::Dome(DomeLight { rot, emission: em, map, visible_to_camera: vis, portals, scene_center: Vec3::ZERO, scene_radius: 1.0 })
            }
            LightShape::Sky { turbidity, ground_albedo, sun_direction, scale: units } => {
                let units = check_length("tide:sky:scale", *units)?;
                let y = m3 * Vec3::Y;
                let sky = crate::sky::HosekWilkieSky::with_frame(y, *sun_direction, *turbidity, crate::sky::GroundAlbedo::Rgb { rgb: *ground_albedo, color_space: cs }).map_err(|e| e.to_string())?;
                let s = scale * units;
                if !s.is_finite() {
                    return Err(err("exposure", format!("intensity × 2^exposure × sky scale overflows ({intensity} × 2^{exposure} × {units})")));
                }
                let portals = portals_of(desc, portal::PORTAL_SHARE_MAPPED)?;
                Light::Sky(Box::new(SkyDomeLight { portals, ..SkyDomeLight::new(sky, s, vis)? }))
            }
            LightShape::SkySun { zenith, turbidity, scale: units } => {
                let units = check_length("tide:sky:scale", *units)?;
                let to_light = m3 * Vec3::Z;
                if !(to_light.length_squared() > 0.0) {
                    return Err(err("transform", "collapses the light's direction"));
                }
                let to_light = to_light.normalize();
                // the ground albedo does not enter the solar radiance
                let sky = crate::sky::HosekWilkieSky::with_frame(*zenith, to_light, *turbidity, 0.0).map_err(|e| e.to_string())?;
                let spectrum = sky.sun_spectrum().map_err(|e| e.to_string())?;
                let s = scale * units;
                if !s.is_finite() {
                    return Err(err("exposure", format!("intensity × 2^exposure × sky scale overflows ({intensity} × 2^{exposure} × {units})")));
                }
                let r = crate::sky::SUN_ANGULAR_RADIUS;
                let omc = (2.0 * (0.5 * r).sin().powi(2)) as f32;
                Light::Distant(DistantLight { to_light, frame: Frame::from_normal(to_light), one_minus_cos: omc, emission: Emission::new(spectrum, s), visible_to_camera: vis, scene_radius: 1.0 })
            }
            LightShape::Sphere { radius, treat_as_point } => {
                let r = check_length("radius", *radius)?;
                let s = (m3.x_axis.length() + m3.y_axis.length() + m3.z_axis.length()) / 3.0;
                let rw = r * s;
                if !rw.is_finite() {
                    return Err(err("radius", "not finite in world space"));
                }
                let area = 4.0 * PI * rw * rw;
                if *treat_as_point || !(area > 0.0) {
                    // same power as the sphere: I = L π r²; for r → 0 only the normalised
                    // limit (I = intensity / 4) is finite, and it is used for any zero radius
                    let i = if desc.normalize || !(area > 0.0) { 0.25 * scale } else { scale * PI * rw * rw };
                    Light::Point(PointLight { p: origin, emission: emission(i), shaping: shaping(front, shaping::Spread::Uniform)? })
                } else {
                    let s = if desc.normalize { scale / area } else { scale };
                    Light::Sphere(SphereLight { center: origin, radius: rw, emission: emission(s), visible_to_camera: vis, shaping: shaping(front, shaping::Spread::Uniform)? })
                }
            }
            LightShape::Rect { width, height, texture } => {
                let w = check_length("width", *width)?;
                let h = check_length("height", *height)?;
                if w == 0.0 {
                    return Err(err("width", "zero-area light"));
                }
                if h == 0.0 {
                    return Err(err("height", "zero-area light"));
                }
                let a = m3 * Vec3::X * w;
                let b = m3 * Vec3::Y * h;
                let corner = origin - 0.5 * (a + b);
                let shape = Planar::new(corner, a, b, front, false).ok_or_else(|| err("transform", "zero-area light (the transform collapses the rect)"))?;
                let s = if desc.normalize { scale / shape.area } else { scale };
                let rectangular = a.dot(b).abs() <= 1e-5 * a.length() * b.length();
                let shaping = shaping(shape.n, shaping::Spread::Cosine(shape.n))?;
                let map = match texture_of(texture)? {
                    None => None,
                    Some(tex) => Some(match maps {
                        Some(maps) => maps.rect(tex, rgb, cs)?,
                        None => Arc::new(RectMap::new(tex, rgb, cs)?),
                    }),
                };
                let mut em = emission(s);
                if let Some(m) = &map {
                    // the image carries the colour; the emission keeps the scale
                    em.luminance = m.mean_luminance();
                }
                Light::Rect(RectLight { shape, emission: em, visible_to_camera: vis, rectangular, shaping, map })
            }
            LightShape::Disk { radius } => {
                let r = check_length("radius", *radius)?;
                if r == 0.0 {
                    return Err(err("radius", "zero-area light"));
                }
                let shape = Planar::new(origin, m3 * Vec3::X * r, m3 * Vec3::Y * r, front, true)
                    .ok_or_else(|| err("transform", "zero-area light (the transform collapses the disk)"))?;
                let s = if desc.normalize { scale / shape.area } else { scale };
                let shaping = shaping(shape.n, shaping::Spread::Cosine(shape.n))?;
                Light::Disk(DiskLight { shape, emission: emission(s), visible_to_camera: vis, shaping })
            }
            LightShape::Cylinder { radius, length, treat_as_line: _ } => {
                let r = check_length("radius", *radius)?;
                let l = check_length("length", *length)?;
                if r == 0.0 {
                    return Err(err("radius", "zero-area light"));
                }
                if l == 0.0 {
                    return Err(err("length", "zero-area light"));
                }
                let axis = m3 * Vec3::X;
                let half_length = 0.5 * l * axis.length();
                let radius = r * 0.5 * (m3.y_axis.length() + m3.z_axis.length());
                let area = 2.0 * PI * radius * 2.0 * half_length;
                if !(area > 0.0 && area.is_finite()) {
                    return Err(err("transform", "zero-area light (the transform collapses the cylinder)"));
                }
                let s = if desc.normalize { scale / area } else { scale };
                let frame = Frame::from_normal(axis.normalize());
                Light::Cylinder(CylinderLight {
                    center: origin,
                    frame,
                    half_length,
                    radius,
                    area,
                    emission: emission(s),
                    visible_to_camera: vis,
                    shaping: shaping(front, shaping::Spread::Cylinder(frame.n))?,
                })
            }
        };
        if desc.motion.len() >= 2 && !light.is_infinite() && desc.motion.iter().any(|(_, m)| *m != desc.motion[0].1) {
            if desc.motion.iter().any(|(t, m)| !t.is_finite() || !m.is_finite()) {
                return Err(err("transform", "a motion sample is not finite"));
            }
            let (times, mats): (Vec<f32>, Vec<Mat4>) = desc.motion.iter().copied().unzip();
            let motion = crate::accel::motion::MotionTransform::new(&mats, &times);
            return Ok(Light::Moving(Box::new(MovingLight { inner: light, motion, base_inv: m.inverse() })));
        }
        Ok(light)
    }

    /// An emissive mesh triangle in world space; `emission` is its radiance. None when the
    /// triangle is degenerate or not finite.
    pub fn triangle(p: [Vec3; 3], emission: Spectrum, two_sided: bool) -> Option<Light> {
        if !p.iter().all(|v| v.is_finite()) {
            return None;
        }
        let c = (p[1] - p[0]).cross(p[2] - p[0]);
        let len = c.length();
        if !(len > 0.0) || !len.is_finite() || !c.length_squared().is_normal() {
            return None;
        }
        Some(Light::Triangle(TriangleLight { p, n: c / len, mirrored: false, area: 0.5 * len, two_sided, emission: Emission::new(emission, 1.0), motion: None, varying: None }))
    }

    /// The same light with its front on the other side: a triangle a mirroring transform
    /// placed (its mesh's front stays its front, as Hydra keeps it).
    pub fn mirrored(self) -> Light {
        match self {
            Light::Triangle(mut t) => {
                t.mirrored = !t.mirrored;
                t.n = -t.n;
                Light::Triangle(t)
            }
            other => other,
        }
    }

    /// An emissive triangle that moves over the shutter: placed by `motion` at each sample's
    /// time, and at `open` (the shutter's open) for everything that does not depend on time
    /// (its power for light selection). None when it is degenerate or not finite at `open`.
    pub fn moving_triangle(motion: TriangleMotion, open: f32, emission: Spectrum, two_sided: bool) -> Option<Light> {
        let p = motion.at(open);
        match Light::triangle(p, emission, two_sided)? {
            Light::Triangle(mut t) => {
                t.motion = Some(std::sync::Arc::new(motion));
                Some(Light::Triangle(t))
            }
            _ => None,
        }
    }

    /// A point light of radiant intensity `intensity` × `spectrum` (per steradian).
    pub fn point(p: Vec3, spectrum: Spectrum, intensity: f32) -> Light {
        Light::Point(PointLight { p, emission: Emission::new(spectrum, intensity), shaping: None })
    }

    /// Gives infinite lights the scene's bounding sphere (for power and for placing their
    /// sample points beyond the scene).
    pub fn preprocess(&mut self, scene_center: Vec3, scene_radius: f32) {
        let r = if scene_radius.is_finite() && scene_radius > 0.0 { scene_radius } else { 1.0 };
        match self {
            Light::Distant(d) => d.scene_radius = r,
            Light::Dome(d) => {
                d.scene_center = if scene_center.is_finite() { scene_center } else { Vec3::ZERO };
                d.scene_radius = r;
            }
            Light::Sky(d) => {
                d.scene_center = if scene_center.is_finite() { scene_center } else { Vec3::ZERO };
                d.scene_radius = r;
            }
            _ => {}
        }
    }

    pub fn is_infinite(&self) -> bool {
        matches!(self, Light::Distant(_) | Light::Dome(_) | Light::Sky(_))
    }

    /// The light itself, or for a moving light the light where its `transform` puts it.
    pub fn inner(&self) -> &Light {
        match self {
            Light::Moving(m) => &m.inner,
            l => l,
        }
    }

    pub fn is_delta(&self) -> bool {
        match self {
            Light::Moving(m) => m.inner.is_delta(),
            Light::Point(_) => true,
            Light::Distant(d) => d.one_minus_cos == 0.0,
            _ => false,
        }
    }

    /// Whether camera rays see the light itself (emissive triangles: always).
    pub fn visible_to_camera(&self) -> bool {
        match self {
            Light::Moving(m) => m.inner.visible_to_camera(),
            Light::Distant(l) => l.visible_to_camera,
            Light::Dome(l) => l.visible_to_camera,
            Light::Sky(l) => l.visible_to_camera,
            Light::Sphere(l) => l.visible_to_camera,
            Light::Rect(l) => l.visible_to_camera,
            Light::Disk(l) => l.visible_to_camera,
            Light::Cylinder(l) => l.visible_to_camera,
            Light::Triangle(_) => true,
            Light::Point(_) => false,
        }
    }

    pub fn emission(&self) -> &Emission {
        match self {
            Light::Moving(m) => m.inner.emission(),
            Light::Distant(l) => &l.emission,
            Light::Dome(l) => &l.emission,
            Light::Sky(l) => &l.emission,
            Light::Sphere(l) => &l.emission,
            Light::Rect(l) => &l.emission,
            Light::Disk(l) => &l.emission,
            Light::Cylinder(l) => &l.emission,
            Light::Triangle(l) => &l.emission,
            Light::Point(l) => &l.emission,
        }
    }

    /// The light's UsdLuxShapingAPI, if it has one that shapes anything.
    pub fn shaping(&self) -> Option<&Shaping> {
        match self {
            // in the light's frame where its transform puts it: queries go through `inner`
            Light::Moving(_) => None,
            Light::Sphere(l) => l.shaping.as_deref(),
            Light::Rect(l) => l.shaping.as_deref(),
            Light::Disk(l) => l.shaping.as_deref(),
            Light::Cylinder(l) => l.shaping.as_deref(),
            Light::Point(l) => l.shaping.as_deref(),
            _ => None,
        }
    }

    /// What the light emits along unit `w` (leaving it) at `lambda`, per unit of its unshaped
    /// emission: its shaping's factor, 1 for unshaped lights.
    #[inline]
    pub fn shaping_factor(&self, w: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self.shaping() {
            Some(s) => s.factor(w, lambda),
            None => SampledSpectrum::ONE,
        }
    }

    /// Emitting area in world space (0 for non-area lights).
    pub fn area(&self) -> f32 {
        match self {
            Light::Moving(m) => m.inner.area(),
            Light::Sphere(l) => 4.0 * PI * l.radius * l.radius,
            Light::Rect(l) => l.shape.area,
            Light::Disk(l) => l.shape.area,
            Light::Cylinder(l) => l.area,
            Light::Triangle(l) => l.area,
            _ => 0.0,
        }
    }

    /// Estimate of the emitted power, luminance-weighted (infinite lights: through a disk of
    /// the scene's radius), for light selection.
    pub fn power(&self) -> f32 {
        if let Light::Moving(m) = self {
            return m.inner.power();
        }
        let e = self.emission();
        let base = e.luminance * e.scale;
        let p = match self {
            Light::Point(_) => 4.0 * PI * base,
            Light::Distant(d) => {
                let irradiance = if d.one_minus_cos == 0.0 {
                    base
                } else {
                    // π sin²(half) = π (1 − cos²) = π omc (2 − omc) for half ≤ 90° (without
                    // the cancellation of 1 − cos² for a cone of a few arcseconds), π beyond
                    let omc = d.one_minus_cos;
                    base * PI * if omc < 1.0 { omc * (2.0 - omc) } else { 1.0 }
                };
                irradiance * PI * d.scene_radius * d.scene_radius
            }
            Light::Dome(d) => base * 4.0 * PI * PI * d.scene_radius * d.scene_radius,
            Light::Sky(d) => base * 4.0 * PI * PI * d.scene_radius * d.scene_radius,
            Light::Triangle(t) => base * PI * t.area * if t.two_sided { 2.0 } else { 1.0 },
            _ => base * PI * self.area(),
        };
        let p = match self.shaping() {
            Some(s) => p * s.power_ratio_y(),
            None => p,
        };
        if p.is_finite() {
            p.max(0.0)
        } else {
            0.0
        }
    }

    /// Radiance leaving an area light at `p` (normal `n`, the emitting side as `intersect`
    /// returns it) towards `w`.
    #[inline]
    pub fn l(&self, p: Vec3, n: Vec3, w: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        let _ = p;
        let c = n.dot(w);
        match self {
            Light::Moving(m) => m.inner.l(p, n, w, lambda),
            Light::Rect(r) if c > 0.0 => r.radiance(p, lambda) * self.shaping_factor(w, lambda),
            Light::Sphere(_) | Light::Disk(_) | Light::Cylinder(_) if c > 0.0 => self.emission().sample(lambda) * self.shaping_factor(w, lambda),
            Light::Triangle(t) if c > 0.0 || (t.two_sided && c != 0.0) => match t.varying {
                None => t.emission.sample(lambda),
                Some(_) => {
                    let (b1, b2) = t.barycentric(p);
                    t.radiance(b1, b2, lambda)
                }
            },
            _ => SampledSpectrum::ZERO,
        }
    }

    /// [`Light::l`] at `time`: where a moving light is then.
    #[inline]
    pub fn l_at(&self, p: Vec3, n: Vec3, w: Vec3, time: f32, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Light::Moving(m) => {
                let (_, inv) = m.moves(time);
                m.inner.l(inv.transform_point3(p), inv.transform_vector3(n), inv.transform_vector3(w), lambda)
            }
            _ => self.l(p, n, w, lambda),
        }
    }

    /// [`Light::intersect`] at `time`: where a moving light is then.
    #[inline]
    pub fn intersect_at(&self, o: Vec3, d: Vec3, t_max: f32, time: f32) -> Option<(f32, Vec3, Vec3)> {
        match self {
            Light::Moving(m) => {
                let (fwd, inv) = m.moves(time);
                let (t, p, n) = m.inner.intersect(inv.transform_point3(o), inv.transform_vector3(d), t_max)?;
                Some((t, fwd.transform_point3(p), fwd.transform_vector3(n).normalize()))
            }
            _ => self.intersect(o, d, t_max),
        }
    }

    /// Radiance of infinite lights along a ray of direction `dir` that left the scene.
    #[inline]
    pub fn le(&self, dir: Vec3, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self {
            Light::Dome(d) => d.le(dir.normalize(), lambda),
            Light::Sky(d) => d.sky.le(dir.normalize(), lambda),
            Light::Distant(d) if d.one_minus_cos > 0.0 && in_cone(dir.normalize(), d.to_light, d.one_minus_cos) => d.emission.sample(lambda),
            _ => SampledSpectrum::ZERO,
        }
    }

    /// Nearest intersection of the ray `o + t d` (0 < t < t_max) with the light's surface:
    /// (t, point, emitting-side normal). Back faces are reported too (`l` gives them zero).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, Vec3, Vec3)> {
        match self {
            Light::Moving(m) => m.inner.intersect(o, d, t_max),
            Light::Sphere(s) => {
                let oc = (o - s.center).as_dvec3();
                let dd = d.as_dvec3();
                let r = s.radius as f64;
                let (t0, t1) = crate::math::solve_quadratic(dd.length_squared(), 2.0 * oc.dot(dd), oc.length_squared() - r * r)?;
                let t = if t0 > 0.0 { t0 } else { t1 };
                let tf = t as f32;
                if !(t > 0.0 && tf < t_max) {
                    return None;
                }
                let p = o + d * tf;
                Some((tf, p, ((oc + dd * t) / r).as_vec3().normalize()))
            }
            Light::Rect(r) => r.shape.hit(o, d, t_max, false),
            Light::Disk(r) => r.shape.hit(o, d, t_max, true),
            Light::Cylinder(c) => {
                let f = &c.frame;
                let ol = f.to_local(o - c.center).as_dvec3();
                let dl = f.to_local(d).as_dvec3();
                let r = c.radius as f64;
                let (t0, t1) = crate::math::solve_quadratic(dl.x * dl.x + dl.y * dl.y, 2.0 * (ol.x * dl.x + ol.y * dl.y), ol.x * ol.x + ol.y * ol.y - r * r)?;
                for t in [t0, t1] {
                    let tf = t as f32;
                    if !(t > 0.0 && tf < t_max) {
                        continue;
                    }
                    let q = ol + dl * t;
                    if q.z.abs() > c.half_length as f64 * (1.0 + EDGE_EPS as f64) {
                        continue;
                    }
                    let n = f.to_world(Vec3::new((q.x / r) as f32, (q.y / r) as f32, 0.0)).normalize();
                    return Some((tf, o + d * tf, n));
                }
                None
            }
            Light::Triangle(tr) => intersect_triangle(tr.p, tr.n, o, d, t_max),
            _ => None,
        }
    }

    /// Samples a direction towards the light from `ctx.p`. None when the light sends nothing
    /// there (receiver behind a one-sided light, inside a sphere light, black texel, ...).
    pub fn sample_li(&self, ctx: &LightSampleContext, u: Vec2, lambda: &SampledWavelengths) -> Option<LightLiSample> {
        let mut s = self.sample_li_unshaped(ctx, u, lambda)?;
        if let Some(sh) = self.shaping() {
            s.l *= sh.factor(-s.wi, lambda);
            if s.l.is_black() {
                return None;
            }
        }
        Some(s)
    }

    /// `sample_li` before the light's shaping.
    #[inline]
    fn sample_li_unshaped(&self, ctx: &LightSampleContext, u: Vec2, lambda: &SampledWavelengths) -> Option<LightLiSample> {
        match self {
            // the inner light's sample (its shaping included) where the light is at ctx.time
            Light::Moving(m) => {
                let (fwd, inv) = m.moves(ctx.time);
                let local = LightSampleContext { p: inv.transform_point3(ctx.p), n: inv.transform_vector3(ctx.n), ..*ctx };
                let s = m.inner.sample_li(&local, u, lambda)?;
                Some(LightLiSample { wi: fwd.transform_vector3(s.wi).normalize(), p_light: fwd.transform_point3(s.p_light), n_light: fwd.transform_vector3(s.n_light).normalize(), ..s })
            }
            Light::Point(pl) => {
                let v = pl.p - ctx.p;
                let d2 = v.length_squared();
                if !(d2 > 0.0) {
                    return None;
                }
                let dist = d2.sqrt();
                let wi = v / dist;
                Some(LightLiSample { l: pl.emission.sample(lambda) / d2, wi, dist, pdf: 1.0, is_delta: true, p_light: pl.p, n_light: -wi })
            }
            Light::Distant(d) => {
                let (wi, l, pdf, is_delta) = if d.one_minus_cos == 0.0 {
                    (d.to_light, d.emission.sample(lambda), 1.0, true)
                } else {
                    let wi = d.frame.to_world(sample_cone(u, d.one_minus_cos)).normalize();
                    (wi, d.emission.sample(lambda), 1.0 / (2.0 * PI * d.one_minus_cos), false)
                };
                Some(LightLiSample { l, wi, dist: f32::INFINITY, pdf, is_delta, p_light: ctx.p + wi * (2.0 * d.scene_radius), n_light: -wi })
            }
            Light::Dome(_) | Light::Sky(_) => self.sample_environment(ctx, u, lambda, true),
            Light::Sphere(s) => {
                let v = s.center - ctx.p;
                let d2 = v.length_squared();
                let r2 = s.radius * s.radius;
                if !(d2 > r2) {
                    return None;
                }
                let sin2 = r2 / d2;
                let cos_max = (1.0 - sin2).max(0.0).sqrt();
                let omc = sin2 / (1.0 + cos_max);
                let axis = v / d2.sqrt();
                let wi = Frame::from_normal(axis).to_world(sample_cone(u, omc)).normalize();
                // nearest point of the sphere along wi (tangent point on the rim)
                let dist_c = d2.sqrt() as f64;
                let cos_t = wi.dot(axis) as f64;
                let disc = (s.radius as f64).powi(2) - dist_c * dist_c * (1.0 - cos_t * cos_t).max(0.0);
                let dist = (dist_c * cos_t - disc.max(0.0).sqrt()) as f32;
                let p_light = ctx.p + wi * dist;
                let n_light = (p_light - s.center).normalize();
                Some(LightLiSample { l: s.emission.sample(lambda), wi, dist, pdf: 1.0 / (2.0 * PI * omc), is_delta: false, p_light, n_light })
            }
            Light::Rect(r) => {
                if !r.faces(ctx.p) {
                    return None;
                }
                if let Some(sr) = r.spherical(ctx.p) {
                    let p = sr.sample(u)?;
                    let v = p - ctx.p;
                    let dist = v.length();
                    if !(dist > 0.0) {
                        return None;
                    }
                    let pdf = (1.0 / sr.s) as f32;
                    let l = r.radiance(p, lambda);
                    if l.is_black() {
                        return None;
                    }
                    return Some(LightLiSample { l, wi: v / dist, dist, pdf, is_delta: false, p_light: p, n_light: r.shape.n });
                }
                let p = r.shape.origin + r.shape.a * u.x + r.shape.b * u.y;
                let mut s = area_sample(ctx.p, p, r.shape.n, r.shape.area, false, r.emission.sample(lambda))?;
                if r.map.is_some() {
                    s.l = r.radiance(p, lambda);
                    if s.l.is_black() {
                        return None;
                    }
                }
                Some(s)
            }
            Light::Disk(dl) => {
                let q = sample_concentric_disk(u);
                let p = dl.shape.origin + dl.shape.a * q.x + dl.shape.b * q.y;
                area_sample(ctx.p, p, dl.shape.n, dl.shape.area, false, dl.emission.sample(lambda))
            }
            Light::Cylinder(c) => {
                let z = (2.0 * u.x - 1.0) * c.half_length;
                let (sp, cp) = (2.0 * PI * u.y).sin_cos();
                let n = c.frame.to_world(Vec3::new(cp, sp, 0.0));
                let p = c.center + c.frame.n * z + n * c.radius;
                area_sample(ctx.p, p, n, c.area, false, c.emission.sample(lambda))
            }
            Light::Triangle(t) => {
                let (tp, n, area) = t.at_time(ctx.time)?;
                let su = u.x.sqrt();
                let (b1, b2) = (su * (1.0 - u.y), su * u.y);
                let p = tp[0] * (1.0 - b1 - b2) + tp[1] * b1 + tp[2] * b2;
                area_sample(ctx.p, p, n, area, t.two_sided, t.radiance(b1, b2, lambda))
            }
        }
    }

    /// Solid-angle density with which `sample_li` from `ctx.p` produces `wi`. `hit` is the
    /// point and normal where the ray along `wi` meets the light, when the caller knows it
    /// (emissive triangles found by the scene BVH); otherwise it is found by `intersect`.
    pub fn pdf_li(&self, ctx: &LightSampleContext, wi: Vec3, hit: Option<(Vec3, Vec3)>) -> f32 {
        match self {
            Light::Moving(m) => {
                let (_, inv) = m.moves(ctx.time);
                let local = LightSampleContext { p: inv.transform_point3(ctx.p), n: inv.transform_vector3(ctx.n), ..*ctx };
                m.inner.pdf_li(&local, inv.transform_vector3(wi), hit.map(|(p, n)| (inv.transform_point3(p), inv.transform_vector3(n))))
            }
            Light::Point(_) => 0.0,
            Light::Distant(d) => {
                if d.one_minus_cos > 0.0 && in_cone(wi.normalize(), d.to_light, d.one_minus_cos) {
                    1.0 / (2.0 * PI * d.one_minus_cos)
                } else {
                    0.0
                }
            }
            Light::Dome(_) | Light::Sky(_) => {
                let wi = wi.normalize();
                let own = self.environment_pdf(wi);
                self.portals().map_or(own, |ps| ps.pdf(ctx.p, wi, own))
            }
            Light::Sphere(s) => {
                let v = s.center - ctx.p;
                let d2 = v.length_squared();
                let r2 = s.radius * s.radius;
                if !(d2 > r2) {
                    return 0.0;
                }
                let sin2 = r2 / d2;
                let omc = sin2 / (1.0 + (1.0 - sin2).max(0.0).sqrt());
                if in_cone(wi.normalize(), v / d2.sqrt(), omc) {
                    1.0 / (2.0 * PI * omc)
                } else {
                    0.0
                }
            }
            Light::Rect(r) if !r.faces(ctx.p) => 0.0,
            Light::Rect(r) if r.rectangular => {
                let hit = match hit {
                    Some(h) => h,
                    None => match self.intersect(ctx.p, wi, f32::INFINITY) {
                        Some((_, p, n)) => (p, n),
                        None => return 0.0,
                    },
                };
                match r.spherical(ctx.p) {
                    Some(sr) => (1.0 / sr.s) as f32,
                    None => self.pdf_li_area(ctx, wi, Some(hit)),
                }
            }
            _ => self.pdf_li_area(ctx, wi, hit),
        }
    }

    /// `pdf_li` of the lights sampled by area.
    fn pdf_li_area(&self, ctx: &LightSampleContext, wi: Vec3, hit: Option<(Vec3, Vec3)>) -> f32 {
        let mut area = self.area();
        let mut found = None;
        if let Light::Triangle(t) = self {
            if t.motion.is_some() {
                // where the triangle is at the sample's time
                let Some((p3, n3, a)) = t.at_time(ctx.time) else { return 0.0 };
                area = a;
                if hit.is_none() {
                    found = intersect_triangle(p3, n3, ctx.p, wi, f32::INFINITY);
                    if found.is_none() {
                        return 0.0;
                    }
                }
            }
        }
        let (p, n) = match hit {
            Some(h) => h,
            None => match found.or_else(|| self.intersect(ctx.p, wi, f32::INFINITY)) {
                Some((_, p, n)) => (p, n),
                None => return 0.0,
            },
        };
        let two_sided = matches!(self, Light::Triangle(t) if t.two_sided);
        let v = p - ctx.p;
        let d2 = v.length_squared();
        let cos_l = -n.dot(v) / d2.sqrt();
        let cos_l = if two_sided { cos_l.abs() } else { cos_l };
        if !(cos_l >= MIN_LIGHT_COS && d2 > 0.0) {
            return 0.0;
        }
        let pdf = d2 / (cos_l * area);
        if pdf.is_finite() {
            pdf
        } else {
            0.0
        }
    }
}

/// Relative tolerance of the edge tests in `intersect`: a sample drawn on the very edge of a
/// light must be found again by the ray towards it despite f32 rounding (≈ 1e-7); 1e-5 of the
/// light's size is invisible in an image.
const EDGE_EPS: f32 = 1e-5;

/// Area-light points seen more grazing than this (cos < 0.005, beyond 89.7°) are neither
/// sampled nor given a density: there the f32 ray towards the point can miss a curved light
/// by rounding, and their share of the irradiance (∝ cos²) is ~1e-5. `pdf_li` returns 0 for
/// them too, so MIS leaves them to BSDF sampling and stays unbiased.
const MIN_LIGHT_COS: f32 = 5e-3;

/// Möller–Trumbore: the hit (t, point, `n`) of `o + t·d`, t ∈ (0, t_max), on the triangle `p`,
/// with the edges widened by `EDGE_EPS`.
fn intersect_triangle(p: [Vec3; 3], n: Vec3, o: Vec3, d: Vec3, t_max: f32) -> Option<(f32, Vec3, Vec3)> {
    let e1 = p[1] - p[0];
    let e2 = p[2] - p[0];
    let pv = d.cross(e2);
    let det = e1.dot(pv);
    if det == 0.0 {
        return None;
    }
    let inv = 1.0 / det;
    let tv = o - p[0];
    let b1 = tv.dot(pv) * inv;
    if !(-EDGE_EPS..=1.0 + EDGE_EPS).contains(&b1) {
        return None;
    }
    let qv = tv.cross(e1);
    let b2 = d.dot(qv) * inv;
    if b2 < -EDGE_EPS || b1 + b2 > 1.0 + EDGE_EPS {
        return None;
    }
    let t = e2.dot(qv) * inv;
    (t > 0.0 && t < t_max).then(|| (t, o + d * t, n))
}

/// Converts a uniform area sample `p` (normal `n`) into a solid-angle sample seen from `from`.
#[inline]
fn area_sample(from: Vec3, p: Vec3, n: Vec3, area: f32, two_sided: bool, l: SampledSpectrum) -> Option<LightLiSample> {
    let v = p - from;
    let d2 = v.length_squared();
    if !(d2 > 0.0) {
        return None;
    }
    let dist = d2.sqrt();
    let wi = v / dist;
    let cos_l = -n.dot(wi);
    let cos_abs = if two_sided { cos_l.abs() } else { cos_l };
    if !(cos_abs >= MIN_LIGHT_COS) {
        return None;
    }
    let pdf = d2 / (cos_abs * area);
    if !pdf.is_finite() {
        return None;
    }
    let n_light = if cos_l < 0.0 { -n } else { n };
    Some(LightLiSample { l, wi, dist, pdf, is_delta: false, p_light: p, n_light })
}
