//! The prepared scene the integrator traces: the BVH, materials with their spectra uplifted,
//! media, lights (including emissive triangles) with their sampler, the camera, and the
//! surface-interaction and material evaluation at a hit.

use crate::accel::{Accel, Hit, Ray};
use crate::bsdf::{Bsdf, PreviewParams};
use crate::camera::Camera;
use crate::light::{Light, LightSampler};
use crate::math::Frame;
use crate::medium::Medium;
use crate::render::{Problem, RenderSettings};
use crate::scene::*;
use crate::shader_graph::{Expr, Lookups};
use crate::spectrum::{uplift, SampledSpectrum, SampledWavelengths, Spectrum};
use crate::texture;
use glam::{Mat3, Vec2, Vec3};
use std::collections::HashMap;
use std::sync::Arc;

/// Relative distance within which two faces along a ray coincide (see
/// [`World::intersect_path`]): 10⁻⁵ of the hit's distance plus the ray origin's size, well
/// above single precision's rounding of faces placed by different transforms (about 10⁻⁷),
/// well below what a modeller means as a gap (0.1 mm at 10 m).
pub const COINCIDENT: f32 = 1e-5;

/// A tangent-space normal at a hit: a constant, or a lookup (texture, primvar, node graph).
#[derive(Clone, Debug)]
pub enum NormalParam {
    Const([f32; 3]),
    Lookup(ColorParam),
}

/// A colour input with its constant spectrum uplifted once.
#[derive(Clone, Debug)]
pub enum ColorParam {
    Const(Spectrum),
    Tex(TexLookup),
    Primvar(PrimvarLookup),
    Graph(Expr),
}

/// A scalar input.
#[derive(Clone, Debug)]
pub enum FloatParam {
    Const(f32),
    Tex(TexLookup),
    Primvar(PrimvarLookup),
    Graph(Expr),
}

/// A surface's wetness ([`WetDesc`]) with its amount ready to evaluate.
#[derive(Clone, Debug)]
pub struct WetParam {
    pub amount: FloatParam,
    pub ior: f32,
    pub water_compliant: bool,
}

/// A MaterialX surface's inputs beyond UsdPreviewSurface ([`crate::scene::PbrExtras`]),
/// ready to evaluate.
#[derive(Clone, Debug)]
pub struct ExtrasParam {
    pub specular_weight: FloatParam,
    pub specular_tint: ColorParam,
    pub coat_color: ColorParam,
    pub coat_ior: f32,
    pub coat_anisotropy: FloatParam,
    pub coat_darkening: FloatParam,
    pub darkening_albedo: ColorParam,
    pub anisotropy: FloatParam,
    pub flavour: crate::bsdf::PbrFlavour,
    pub anisotropy_rotation: FloatParam,
    pub diffuse_roughness: FloatParam,
    pub sheen_weight: FloatParam,
    pub sheen_color: ColorParam,
    pub sheen_roughness: FloatParam,
    pub thin_film_weight: FloatParam,
    pub thin_film_thickness: FloatParam,
    pub thin_film_unit_nm: f32,
    pub thin_film_ior: f32,
    pub thin_walled: Option<ThinWalledParam>,
}

/// A light's [`ShadowDesc`] ready to apply (only where it is not the default).
#[derive(Clone, Debug)]
pub struct ShadowControls {
    /// What the shadowed part of the light keeps (None: black shadows).
    pub color: Option<Spectrum>,
    /// (shadow distance, where its falloff zone begins, the fade's exponent); None: no limit.
    pub reach: Option<(f32, f32, f32)>,
}

impl ShadowControls {
    fn from_desc(d: &ShadowDesc, cs: ColorSpace) -> Option<ShadowControls> {
        let color = (d.color != [0.0; 3]).then(|| uplift::albedo(d.color.map(|c| c.clamp(0.0, 1.0)), cs));
        let reach = (d.distance > 0.0).then(|| {
            let falloff = if d.falloff > 0.0 { d.falloff.min(1.0) } else { 0.0 };
            (d.distance, d.distance * (1.0 - falloff), if d.falloff_gamma > 0.0 { d.falloff_gamma } else { 1.0 })
        });
        (color.is_some() || reach.is_some()).then_some(ShadowControls { color, reach })
    }

    /// How far from the lit point a shadow ray towards a light `dist` away looks for
    /// occluders: up to the shadow distance, whose falloff zone it ends in at a point drawn
    /// with `u` such that an occluder a fraction x into the zone shadows with probability
    /// (1 − x)^γ (full shadow before the zone, none beyond it).
    pub fn reach(&self, dist: f32, u: f32) -> f32 {
        match self.reach {
            None => dist,
            Some((max, start, gamma)) => dist.min(start + (max - start) * (1.0 - u.powf(1.0 / gamma))),
        }
    }

    /// The light reaching the lit point through `tr`, its shadowed part coloured.
    pub fn shade(&self, tr: SampledSpectrum, lambda: &SampledWavelengths) -> SampledSpectrum {
        match &self.color {
            None => tr,
            Some(c) => tr + (SampledSpectrum::ONE - tr) * c.sample(lambda),
        }
    }
}

/// [`ThinWalledDesc`] ready to evaluate.
#[derive(Clone, Debug)]
pub struct ThinWalledParam {
    pub transmission: FloatParam,
    pub tint: ColorParam,
    pub subsurface: FloatParam,
    pub reflect: ColorParam,
    pub transmit: ColorParam,
}

/// A clear dielectric interface (TideWater or any glass).
#[derive(Clone, Debug)]
pub struct DielectricMat {
    pub ior: f32,
    pub roughness: f32,
    pub priority: i32,
    /// Wind-driven sea surface: (wind speed m/s, world wind direction in the XZ plane, share
    /// of the Cox–Munk slope variance the facets carry: the mesh's
    /// [`crate::scene::SEA_SHARE_PRIMVAR`] where it has one, else the material's).
    pub sea: Option<(f32, Vec3, FloatParam)>,
    /// Spectral IOR n(λ) (Quan–Fry, or a glass's from its Abbe number) when the interface is
    /// dispersive; `ior` is then n(589 nm).
    pub dispersion: Option<Spectrum>,
    /// What each transmission multiplies the light by (None: clear).
    pub tint: Option<ColorParam>,
    /// An opaque preview surface taking the share 1 − transmission (see [`WaterBlend`]).
    pub blend: Option<Box<(FloatParam, SurfaceKind)>>,
}

impl DielectricMat {
    /// IOR at the hero wavelength of a path.
    #[inline]
    pub fn ior_at(&self, lambda: &SampledWavelengths) -> f32 {
        match &self.dispersion {
            Some(n) => n.eval(lambda.lambda[0]),
            None => self.ior,
        }
    }
}

/// What a surface does, ready to evaluate.
#[derive(Clone, Debug)]
pub enum SurfaceKind {
    Diffuse(ColorParam),
    Preview {
        diffuse: ColorParam,
        emissive: Option<ColorParam>,
        specular: ColorParam,
        use_specular_workflow: bool,
        metallic: FloatParam,
        roughness: FloatParam,
        clearcoat: FloatParam,
        clearcoat_roughness: FloatParam,
        opacity: FloatParam,
        opacity_threshold: f32,
        ior: f32,
        wet: Option<WetParam>,
        extras: Option<Box<ExtrasParam>>,
        /// A tangent-space normal (UsdPreviewSurface `normal`, already scaled and biased to
        /// [−1, 1] by its texture node where it comes from one): x along the surface's dp/du,
        /// y along dp/dv, z the shading normal.
        normal: Option<NormalParam>,
    },
    Dielectric(DielectricMat),
    Conductor { eta: Spectrum, k: Spectrum, roughness: f32 },
    Emissive { radiance: Spectrum, two_sided: bool },
    /// The box of a volume: no reflection or refraction, only the interior medium changes
    /// (see [`crate::volume`]).
    MediumBoundary,
}

#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    pub kind: SurfaceKind,
    pub interior_medium: Option<usize>,
}

impl SurfaceKind {
    /// The surface whose emission and opacity this one has: its own, or the opaque part of a
    /// dielectric blended over one.
    pub fn face(&self) -> &SurfaceKind {
        match self {
            SurfaceKind::Dielectric(DielectricMat { blend: Some(b), .. }) => &b.1,
            k => k,
        }
    }
}

impl Material {
    pub fn dielectric(&self) -> Option<&DielectricMat> {
        match &self.kind {
            SurfaceKind::Dielectric(d) => Some(d),
            _ => None,
        }
    }

    /// True for the box of a volume, which paths cross unchanged.
    pub fn is_medium_boundary(&self) -> bool {
        matches!(self.kind, SurfaceKind::MediumBoundary)
    }
}

/// Per-instance data the integrator needs.
#[derive(Clone, Debug)]
pub struct InstanceInfo {
    pub geometry: GeometryRef,
    pub material: usize,
    pub id: u32,
    /// `InstanceDesc::index`, or -1 for none.
    pub index: i32,
    pub visible_to_camera: bool,
    pub casts_shadows: bool,
    /// Its own primvar values: (table in [`World::instance_primvars`], row).
    pub primvar_row: Option<(u32, u32)>,
}

/// Geometry at a hit point (world space).
#[derive(Clone, Copy, Debug)]
pub struct SurfaceHit {
    pub p: Vec3,
    /// Bound of the rounding error in `p`, per component (world space), for offsetting rays
    /// that leave it ([`crate::math::offset_ray_origin`]).
    pub err: Vec3,
    /// Geometric normal on the object's outside (the side its winding/authored normals face).
    pub ng: Vec3,
    /// Shading normal, on the same side as `ng`.
    pub ns: Vec3,
    pub uv: Vec2,
    pub dpdu: Vec3,
    pub instance: u32,
    pub prim: u32,
    /// Barycentric coordinates (b1, b2) of a triangle hit (zero for spheres), for primvars.
    pub bary: Vec2,
    pub t: f32,
}

impl SurfaceHit {
    /// The origin of a ray leaving the surface towards `w`'s side of it.
    #[inline]
    pub fn origin_towards(&self, w: Vec3) -> Vec3 {
        crate::math::offset_towards(self.p, self.err, self.ng, w)
    }

    /// The origin of a ray leaving the surface on the side `n` (± the geometric normal) faces.
    #[inline]
    pub fn origin_on(&self, n: Vec3) -> Vec3 {
        crate::math::offset_ray_origin(self.p, self.err, n)
    }
}

impl World {
    /// Whether `hit` is light `light`'s own geometry (its emissive triangle): a shadow ray
    /// towards a point on it that meets it has arrived, whatever its rounding.
    #[inline]
    pub fn is_light_geometry(&self, light: usize, hit: &crate::accel::Hit) -> bool {
        self.light_triangles.get(light).copied().flatten() == Some((hit.instance, hit.prim))
    }
}

/// The kind of scattering at the vertex that gathers a light's emission, which picks the
/// light's multiplier ([`World::light_response`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Lobe {
    /// The camera itself, or a medium: no multiplier.
    None,
    Diffuse,
    /// Glossy or specular reflection and transmission.
    Specular,
}

/// The prepared scene.
pub struct World {
    pub accel: Accel,
    pub instances: Vec<InstanceInfo>,
    pub meshes: Vec<Arc<MeshDesc>>,
    /// Per sphere set, its primvars (the meshes carry theirs).
    pub sphere_primvars: Vec<Vec<PrimvarData>>,
    /// Each sphere set's [`crate::scene::SpheresDesc::origin`] (for object-space shading).
    pub sphere_origins: Vec<Vec3>,
    /// The sphere sets, shared with the scene description (their authored point indices and
    /// shapes give the `elementId` AOV).
    pub spheres: Vec<Arc<crate::scene::SpheresDesc>>,
    /// Per-instance primvar tables ([`InstanceInfo::primvar_row`]).
    pub instance_primvars: Vec<InstancePrimvars>,
    pub materials: Vec<Material>,
    pub media: Vec<Medium>,
    pub textures: Vec<TextureDesc>,
    pub lights: Vec<Light>,
    /// Light selection: the many-light tree for next-event estimation, and selection by
    /// power ([`crate::light::tree::LightTree::by_weight`]).
    pub light_tree: crate::light::tree::LightTree,
    /// Lights with a shape of their own that rays can hit (not triangles: those are in the BVH).
    pub hittable_lights: Vec<usize>,
    /// The hierarchy over the hittable lights (the nearest light along a ray).
    pub light_bvh: crate::light::bvh::LightBvh,
    pub infinite_lights: Vec<usize>,
    /// (instance, triangle) → light index of emissive triangles: those whose material emits a
    /// constant colour, a colour from a primvar (its value at each corner, interpolated as the
    /// surface interpolates it) or from a texture (looked up where the sample lies).
    pub triangle_lights: HashMap<(u32, u32), usize>,
    /// Per light: the (instance, triangle) it is, for an emissive triangle (a shadow ray that
    /// meets it has reached its light).
    pub light_triangles: Vec<Option<(u32, u32)>>,
    /// Per light: which instances it illuminates, by instance index (None: all).
    pub light_links: Vec<Option<std::sync::Arc<[bool]>>>,
    /// Per light: which instances cast its shadows, by instance index (None: all).
    pub shadow_links: Vec<Option<std::sync::Arc<[bool]>>>,
    /// Per light: its diffuse and specular multipliers (see [`crate::scene::LightResponse`]).
    pub light_response: Vec<crate::scene::LightResponse>,
    /// Per UsdLux light (mesh lights come after them, with none): its shadow controls, where
    /// set.
    pub shadow_controls: Vec<Option<ShadowControls>>,
    /// Some light's multipliers are not 1 (paths then track what they need for them).
    pub any_light_response: bool,
    pub camera: Camera,
    /// [`SceneDesc::origin`], where the world's positions are measured from.
    pub origin: Vec3,
    /// The rendering colour space the AOVs are written in (authored colours are in
    /// [`crate::scene::AUTHORED_COLOR_SPACE`]).
    pub cs: ColorSpace,
    pub max_depth: u32,
    /// The AOVs the render keeps: first-hit work for those it does not is skipped.
    pub aovs: crate::render::AovSet,
    /// Cached surface irradiance of the bodies whose medium renders in diffusion mode.
    pub diffusion: crate::diffusion::DiffusionCache,
    /// Caustics roles of each instance (resolved `TideCausticsAPI` tags, contract §4).
    pub caustic_instances: Vec<InstanceCaustics>,
    /// Whether each light emits caustic photons.
    pub caustic_emitters: Vec<bool>,
}

/// An instance's roles in caustics, with the one-click defaults resolved
/// (see [`crate::scene::CausticsTags`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct InstanceCaustics {
    pub caster: bool,
    pub receiver: bool,
    pub transparency: crate::scene::CausticsTransparency,
}

fn color_param(c: &ColorInput, cs: ColorSpace) -> ColorParam {
    match c {
        ColorInput::Const(rgb) => ColorParam::Const(uplift::albedo(*rgb, cs)),
        ColorInput::Texture(l) => ColorParam::Tex(l.clone()),
        ColorInput::Primvar(l) => ColorParam::Primvar(l.clone()),
        ColorInput::Graph(e) => ColorParam::Graph(e.clone()),
    }
}

/// A UsdPreviewSurface (or MaterialX PBR surface) ready to evaluate.
fn preview_kind(p: &PreviewSurfaceDesc, cs: ColorSpace) -> SurfaceKind {
    let emissive = match &p.emissive_color {
        ColorInput::Const(c) if c.iter().all(|v| *v <= 0.0) => None,
        ColorInput::Const(c) => Some(ColorParam::Const(uplift::illuminant(*c, cs))),
        ColorInput::Texture(l) => Some(ColorParam::Tex(l.clone())),
        ColorInput::Primvar(l) => Some(ColorParam::Primvar(l.clone())),
        ColorInput::Graph(e) => Some(ColorParam::Graph(e.clone())),
    };
    SurfaceKind::Preview {
        diffuse: color_param(&p.diffuse_color, cs),
        emissive,
        specular: color_param(&p.specular_color, cs),
        use_specular_workflow: p.use_specular_workflow,
        metallic: float_param(&p.metallic),
        roughness: float_param(&p.roughness),
        clearcoat: float_param(&p.clearcoat),
        clearcoat_roughness: float_param(&p.clearcoat_roughness),
        opacity: float_param(&p.opacity),
        opacity_threshold: p.opacity_threshold,
        ior: p.ior,
        normal: p.normal.as_ref().map(|c| match c {
            ColorInput::Const(v) => NormalParam::Const(*v),
            other => NormalParam::Lookup(color_param(other, cs)),
        }),
        wet: p.wet.as_ref().map(|w| WetParam { amount: float_param(&w.amount), ior: w.ior, water_compliant: w.water_compliant }),
        extras: p.extras.as_ref().map(|x| {
            Box::new(ExtrasParam {
                specular_weight: float_param(&x.specular_weight),
                specular_tint: color_param(&x.specular_tint, cs),
                coat_color: color_param(&x.coat_color, cs),
                coat_ior: x.coat_ior,
                coat_anisotropy: float_param(&x.coat_anisotropy),
                coat_darkening: float_param(&x.coat_darkening),
                darkening_albedo: color_param(&x.darkening_albedo, cs),
                anisotropy: float_param(&x.anisotropy),
                flavour: x.flavour,
                anisotropy_rotation: float_param(&x.anisotropy_rotation),
                diffuse_roughness: float_param(&x.diffuse_roughness),
                sheen_weight: float_param(&x.sheen_weight),
                sheen_color: color_param(&x.sheen_color, cs),
                sheen_roughness: float_param(&x.sheen_roughness),
                thin_film_weight: float_param(&x.thin_film_weight),
                thin_film_thickness: float_param(&x.thin_film_thickness),
                thin_film_unit_nm: x.thin_film_unit_nm,
                thin_film_ior: x.thin_film_ior,
                thin_walled: x.thin_walled.as_ref().map(|t| ThinWalledParam {
                    transmission: float_param(&t.transmission),
                    tint: color_param(&t.tint, cs),
                    subsurface: float_param(&t.subsurface),
                    reflect: color_param(&t.reflect, cs),
                    transmit: color_param(&t.transmit, cs),
                }),
            })
        }),
    }
}

fn float_param(c: &FloatInput) -> FloatParam {
    match c {
        FloatInput::Const(v) => FloatParam::Const(*v),
        FloatInput::Texture(l) => FloatParam::Tex(l.clone()),
        FloatInput::Primvar(l) => FloatParam::Primvar(l.clone()),
        FloatInput::Graph(e) => FloatParam::Graph(e.clone()),
    }
}

/// The largest world y, at time 0, of every object whose material is filled with medium
/// `medium` (the depth origin of a depth-varying water medium); None when no object is.
fn water_top(scene: &SceneDesc, accel: &Accel, medium: usize, up: Vec3) -> Option<f32> {
    let mut top: Option<f32> = None;
    for (ii, inst) in scene.instances.iter().enumerate() {
        if scene.materials.get(inst.material).and_then(|m| m.interior_medium) != Some(medium) {
            continue;
        }
        let xf = accel.instance_transform(ii as u32, 0.0);
        let mut rise = |h: f32| {
            if h.is_finite() {
                top = Some(top.map_or(h, |t| t.max(h)));
            }
        };
        match inst.geometry {
            GeometryRef::Mesh(i) => scene.meshes[i].positions.iter().for_each(|p| rise(xf.transform_point3(*p).dot(up))),
            GeometryRef::Spheres(i) => {
                let s = &scene.spheres[i];
                // the top of a transformed sphere: its centre plus the radius times the length
                // of the transform's transpose applied to `up`
                let reach = Mat3::from_mat4(xf).transpose().mul_vec3(up).length();
                for (c, r) in s.centers.iter().zip(&s.radii) {
                    rise(xf.transform_point3(*c).dot(up) + r * reach);
                }
            }
        }
    }
    top
}

/// An emissive triangle whose radiance varies over it (emission from a primvar or a texture),
/// its power from `mean` (RGB); None where it emits nothing.
fn with_varying(light: Light, varying: crate::light::VaryingEmission, mean: [f32; 3], cs: ColorSpace) -> Option<Light> {
    let Light::Triangle(mut t) = light else { return Some(light) };
    let mean = mean.map(|v| v.max(0.0));
    if mean == [0.0; 3] {
        return None;
    }
    t.emission = crate::light::Emission::new(uplift::illuminant(mean, cs), 1.0);
    t.varying = Some(Box::new(varying));
    Some(Light::Triangle(t))
}

/// Per triangle (its vertex indices), how an emission that varies over a mesh varies there
/// and an estimate of its mean RGB.
type VaryingFn<'a> = Box<dyn Fn(&[u32]) -> (crate::light::VaryingEmission, [f32; 3]) + 'a>;

/// How the emission `e` (from a primvar or a texture) of instance `inst` of mesh `m` varies per
/// triangle; None for a constant or a missing texture. `shared` holds each texture once.
fn varying_emission<'a>(e: &ColorParam, m: &'a MeshDesc, inst: &InstanceDesc, scene: &'a SceneDesc, shared: &mut HashMap<usize, std::sync::Arc<TextureDesc>>, cs: ColorSpace) -> Option<VaryingFn<'a>> {
    match e {
        ColorParam::Const(_) => None,
        ColorParam::Primvar(l) => {
            // the primvar's value at each corner of each triangle
            let value = corner_values(m, inst.primvar_row, &scene.instance_primvars, l);
            Some(Box::new(move |t: &[u32]| {
                let rgb = [0, 1, 2].map(|k| value(t[k]));
                let mean = std::array::from_fn(|c| (rgb[0][c] + rgb[1][c] + rgb[2][c]) / 3.0);
                (crate::light::VaryingEmission::Corners { rgb: rgb.map(|v| [v[0], v[1], v[2]]), cs }, mean)
            }))
        }
        ColorParam::Tex(l) => {
            let tex = scene.textures.get(l.texture)?;
            let texture = shared.entry(l.texture).or_insert_with(|| std::sync::Arc::new(tex.clone())).clone();
            let lookup = TexLookup { texture: 0, ..l.clone() };
            // the texture coordinates at each corner: a uv set, the mesh's, or the triangle's
            // own barycentrics (as a hit without uvs reads them)
            let set = l.uv_set.as_ref().map(|set| corner_values(m, inst.primvar_row, &scene.instance_primvars, set));
            let own = m.uvs.as_deref();
            Some(Box::new(move |t: &[u32]| {
                let uv: [Vec2; 3] = match (&set, own) {
                    (Some(value), _) => [0, 1, 2].map(|k| {
                        let v = value(t[k]);
                        Vec2::new(v[0], v[1])
                    }),
                    (None, Some(uvs)) => [0, 1, 2].map(|k| uvs[t[k] as usize]),
                    (None, None) => [Vec2::ZERO, Vec2::X, Vec2::Y],
                };
                let probe = |st: Vec2| texture::lookup_rgb(std::slice::from_ref(&*texture), &lookup, st);
                let samples = [uv[0], uv[1], uv[2], (uv[0] + uv[1] + uv[2]) / 3.0].map(probe);
                let mean = std::array::from_fn(|c| samples.iter().map(|s| s[c]).sum::<f32>() / 4.0);
                (crate::light::VaryingEmission::Texture { texture: texture.clone(), lookup: lookup.clone(), uv, cs }, mean)
            }))
        }
        ColorParam::Graph(g) => Some(graph_emission(g, m, inst, scene, shared, cs)),
    }
}

/// What a node graph's lookups read at a hit.
struct AtHit<'a> {
    w: &'a World,
    s: &'a SurfaceHit,
}

impl Lookups for AtHit<'_> {
    fn texture(&self, l: &TexLookup, st: Vec2) -> [f32; 4] {
        texture::lookup_rgba(&self.w.textures, l, st)
    }

    fn primvar(&self, l: &PrimvarLookup) -> [f32; 4] {
        self.w.primvar_or(self.s, l)
    }

    fn uv(&self) -> Vec2 {
        self.s.uv
    }

    fn position(&self, world: bool) -> Vec3 {
        if world {
            return self.s.p + self.w.origin;
        }
        let Some(info) = self.w.instances.get(self.s.instance as usize) else { return self.s.p };
        match info.geometry {
            // the mesh's own vertices at the hit's barycentrics (its pose at time 0)
            GeometryRef::Mesh(mi) => {
                let m = &self.w.meshes[mi];
                let i = 3 * self.s.prim as usize;
                let b = [1.0 - self.s.bary.x - self.s.bary.y, self.s.bary.x, self.s.bary.y];
                m.origin + (0..3).map(|k| m.indices.get(i + k).and_then(|&v| m.positions.get(v as usize)).map_or(Vec3::ZERO, |p| *p * b[k])).sum::<Vec3>()
            }
            GeometryRef::Spheres(si) => {
                let origin = self.w.sphere_origins.get(si).copied().unwrap_or(Vec3::ZERO);
                origin + self.w.accel.instance_transform(self.s.instance, 0.0).inverse().transform_point3(self.s.p)
            }
        }
    }

    /// The shading normal; in the geometry's own space through the instance's transform (at
    /// time 0, as the position's).
    fn normal(&self, world: bool) -> Vec3 {
        match world {
            true => self.s.ns,
            false => (glam::Mat3::from_mat4(self.w.accel.instance_transform(self.s.instance, 0.0)).transpose() * self.s.ns).normalize_or_zero(),
        }
    }

    fn tangent(&self, world: bool) -> Vec3 {
        match world {
            true => self.s.dpdu.normalize_or_zero(),
            false => self.w.accel.instance_transform(self.s.instance, 0.0).inverse().transform_vector3(self.s.dpdu).normalize_or_zero(),
        }
    }
}

/// A lookup's value at each vertex of an instance's mesh (as [`World::primvar`] reads it at a
/// hit on that vertex).
fn corner_values<'a>(m: &'a MeshDesc, row: Option<(u32, u32)>, tables: &[InstancePrimvars], l: &PrimvarLookup) -> Box<dyn Fn(u32) -> [f32; 4] + 'a> {
    let (scale, fallback) = (l.scale, l.fallback);
    let source = corner_source(m, row, tables, &l.name);
    Box::new(move |v| {
        let x = source.as_ref().map_or(fallback, |f| f(v));
        std::array::from_fn(|k| x[k] * scale[k])
    })
}

/// Primvar `name` at each vertex of an instance's mesh, unscaled; None where neither the mesh
/// nor the instance has it.
fn corner_source<'a>(m: &'a MeshDesc, row: Option<(u32, u32)>, tables: &[InstancePrimvars], name: &str) -> Option<Box<dyn Fn(u32) -> [f32; 4] + 'a>> {
    match primvar_source(&m.primvars, row, tables, name)? {
        PrimvarSource::Varying(pv) => Some(Box::new(move |v| pv.element(v as usize))),
        PrimvarSource::Value(v) => Some(Box::new(move |_| v)),
    }
}

/// A node graph's emission over an instance's mesh: its textures each once (from `shared`),
/// its primvars at each triangle's corners.
fn graph_emission<'a>(e: &Expr, m: &'a MeshDesc, inst: &InstanceDesc, scene: &'a SceneDesc, shared: &mut HashMap<usize, std::sync::Arc<TextureDesc>>, cs: ColorSpace) -> VaryingFn<'a> {
    let mut expr = e.clone();
    let mut textures: Vec<std::sync::Arc<TextureDesc>> = Vec::new();
    let mut local: HashMap<usize, usize> = HashMap::new();
    expr.leaves_mut(&mut |leaf| {
        let Expr::Texture(l) = leaf else { return };
        l.texture = match scene.textures.get(l.texture) {
            Some(tex) => *local.entry(l.texture).or_insert_with(|| {
                textures.push(shared.entry(l.texture).or_insert_with(|| std::sync::Arc::new(tex.clone())).clone());
                textures.len() - 1
            }),
            // validation leaves none; a lookup of no texture reads its fallback
            None => usize::MAX,
        };
    });
    let names = expr.primvar_names();
    let sources: Vec<_> = names.iter().map(|n| corner_source(m, inst.primvar_row, &scene.instance_primvars, n)).collect();
    let graph = std::sync::Arc::new(crate::light::EmissionGraph { expr, textures, names });
    let own = m.uvs.as_deref();
    let to_world = inst.transforms.first().copied().unwrap_or(glam::Mat4::IDENTITY);
    let normal_to_world = glam::Mat3::from_mat4(to_world).inverse().transpose();
    let origin = scene.origin.as_vec3();
    Box::new(move |t: &[u32]| {
        let corners = sources.iter().map(|s| s.as_ref().map(|f| [0, 1, 2].map(|k| f(t[k])))).collect();
        let uv = match own {
            Some(uvs) => [0, 1, 2].map(|k| uvs[t[k] as usize]),
            None => [Vec2::ZERO, Vec2::X, Vec2::Y],
        };
        let own = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
        let world = own.map(|p| to_world.transform_point3(p) + origin);
        let object = own.map(|p| p + m.origin);
        let normals = m.normals.as_deref().map(|n| {
            let own = [0, 1, 2].map(|k| n.get(t[k] as usize).copied().unwrap_or(Vec3::ZERO));
            [own, own.map(|v| (normal_to_world * v).normalize_or_zero())]
        });
        let how = crate::light::VaryingEmission::Graph { graph: graph.clone(), corners, uv, object, world, normals, cs };
        let third = 1.0 / 3.0;
        let probes = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [third; 3]].map(|b| how.rgb(b).0);
        let mean = std::array::from_fn(|c| probes.iter().map(|p| p[c]).sum::<f32>() / 4.0);
        (how, mean)
    })
}

/// Where an instance's primvar `name` comes from (see [`World::primvar`]).
enum PrimvarSource<'a> {
    /// The geometry's, per vertex or point.
    Varying(&'a PrimvarData),
    /// One value for the whole instance: its own row, or the geometry's constant.
    Value([f32; 4]),
}

fn primvar_source<'a>(own: &'a [PrimvarData], row: Option<(u32, u32)>, tables: &[InstancePrimvars], name: &str) -> Option<PrimvarSource<'a>> {
    let own = own.iter().find(|p| p.name == name);
    if let Some(pv) = own.filter(|p| !p.constant) {
        return Some(PrimvarSource::Varying(pv));
    }
    let instance = row.and_then(|(t, r)| Some((tables.get(t as usize)?.primvars.iter().find(|p| p.name == name)?, r)));
    match instance {
        Some((pv, r)) => Some(PrimvarSource::Value(pv.element(r as usize))),
        None => own.map(|pv| PrimvarSource::Value(pv.element(0))),
    }
}

/// What a build keeps for the next: the meshes and textures validation checked, per-geometry
/// BVHs, and dome and rect-light maps. An interactive session passes the same cache to every
/// rebuild, so an edit rebuilds only what it touched. Cloning shares the cache.
#[derive(Clone, Default)]
pub struct BuildCache {
    pub checks: crate::validate::CheckCache,
    pub bvh: crate::accel::BlasCache,
    pub maps: crate::light::map_cache::MapCache,
}

impl World {
    /// Builds the world from a validated scene. Problems met here are appended to `problems`.
    pub fn build(scene: &SceneDesc, settings: &RenderSettings, problems: &mut Vec<Problem>) -> World {
        World::build_cached(scene, settings, problems, None)
    }

    /// [`World::build`] reusing from `cache` the per-geometry BVHs of unchanged geometry and
    /// the maps of unchanged domes.
    pub fn build_cached(scene: &SceneDesc, settings: &RenderSettings, problems: &mut Vec<Problem>, cache: Option<&BuildCache>) -> World {
        // authored colours are uplifted from their own space; AOVs are written in the scene's
        let cs = crate::scene::AUTHORED_COLOR_SPACE;
        // volumes become boxes with a medium-boundary material and a grid medium
        let expanded = (!scene.volumes.is_empty()).then(|| crate::volume::expand(scene, problems));
        let scene = expanded.as_ref().map_or(scene, |e| &e.scene);
        let camera = Camera::for_settings(&scene.camera, settings);
        // the BSDFs' albedo tables are built once per process; started here, beside the BVH,
        // the first pass does not wait for them
        let uses_sheen = scene.materials.iter().any(|m| matches!(&m.surface, SurfaceDesc::Preview(p) if p.extras.as_ref().is_some_and(|x| !matches!(x.sheen_weight, FloatInput::Const(w) if w <= 0.0))));
        let (accel, ()) = rayon::join(
            || Accel::build_cached(&scene.meshes, &scene.spheres, &scene.instances, camera.shutter, cache.map(|c| &c.bvh)),
            || {
                crate::bsdf::albedo::tables();
                if uses_sheen {
                    crate::bsdf::sheen::tables();
                }
            },
        );
        let mut materials: Vec<Material> = scene
            .materials
            .iter()
            .map(|m| {
                let kind = match &m.surface {
                    SurfaceDesc::Diffuse { color } => SurfaceKind::Diffuse(color_param(color, cs)),
                    SurfaceDesc::Preview(p) => preview_kind(p, cs),
                    SurfaceDesc::Water(w) => {
                        // Quan–Fry water, or a glass of an Abbe number; where the model
                        // cannot be built, the constant ior
                        let model = if w.dispersion {
                            Some(crate::water::quan_fry_spectrum(w.salinity, w.temperature).map_err(|e| {
                                let attribute = match e {
                                    crate::water::WaterError::OutOfRange { name: "salinity", .. } => "inputs:salinity",
                                    _ => "inputs:temperature",
                                };
                                (attribute, e.to_string())
                            }))
                        } else {
                            w.abbe.map(|v| crate::water::abbe_spectrum(w.ior, v).map_err(|e| ("abbe", e)))
                        };
                        let dispersion = match model {
                            Some(Err((attribute, e))) => {
                                problems.push(Problem { item: m.name.clone(), attribute: attribute.into(), message: format!("{e}; dispersion off, constant ior used") });
                                None
                            }
                            m => m.and_then(Result::ok),
                        };
                        let sea = (w.surface_model == SurfaceModel::Sea).then(|| {
                            // degrees about +Y from +X: the rotated +X axis
                            let a = w.wind_direction.to_radians();
                            let share = FloatParam::Primvar(PrimvarLookup::new(crate::scene::SEA_SHARE_PRIMVAR, [w.slope_variance_scale; 4]));
                            (w.wind_speed.clamp(0.0, crate::bsdf::sea::MAX_WIND_SPEED), Vec3::new(a.cos(), 0.0, -a.sin()), share)
                        });
                        let ior = dispersion.as_ref().map_or(w.ior, |n| n.eval(589.0));
                        SurfaceKind::Dielectric(DielectricMat {
                            ior,
                            roughness: w.roughness,
                            priority: w.priority,
                            sea,
                            dispersion,
                            tint: w.tint.as_ref().map(|c| color_param(c, cs)),
                            blend: w.blend.as_ref().map(|b| Box::new((float_param(&b.transmission), preview_kind(&b.surface, cs)))),
                        })
                    }
                    SurfaceDesc::Conductor { eta, k, roughness } => SurfaceKind::Conductor { eta: uplift::unbounded(*eta, cs), k: uplift::unbounded(*k, cs), roughness: *roughness },
                    SurfaceDesc::Emissive { radiance, two_sided } => SurfaceKind::Emissive { radiance: uplift::illuminant(*radiance, cs), two_sided: *two_sided },
                };
                Material { name: m.name.clone(), kind, interior_medium: m.interior_medium }
            })
            .collect();
        for &mi in expanded.iter().flat_map(|e| &e.boundary_materials) {
            materials[mi].kind = SurfaceKind::MediumBoundary;
        }
        let grid_of = |mi: usize| expanded.as_ref().and_then(|e| e.grids.iter().find(|g| g.0 == mi)).map(|g| g.1.clone());
        let media = scene
            .media
            .iter()
            .enumerate()
            .map(|(mi, m)| {
                let mut m = m.clone();
                if let Some(w) = m.water.as_mut().filter(|w| w.top.is_none()) {
                    w.top = Some(water_top(scene, &accel, mi, w.up).unwrap_or(0.0));
                }
                (mi, m)
            })
            .map(|(mi, m)| match grid_of(mi).map_or_else(|| Medium::from_desc(&m, cs), |g| Medium::grid(&m, g, cs)) {
                Ok(med) => med,
                Err(e) => {
                    problems.push(Problem { item: m.name.clone(), attribute: "inputs".into(), message: format!("{e}; medium made empty") });
                    Medium::from_desc(&MediumDesc { name: m.name.clone(), sigma_a: SpectrumDesc::Rgb([0.0; 3]), sigma_s: SpectrumDesc::Rgb([0.0; 3]), scale: 1.0, phase: PhaseDesc::Isotropic, water: None, method: Default::default() }, cs).expect("empty medium")
                }
            })
            .collect();

        let mut lights = Vec::new();
        let mut caustic_emitters = Vec::new();
        let any_emitter_tagged = scene.caustics.emitters.iter().any(|(_, e)| *e);
        let mut light_links = Vec::new();
        let mut shadow_links = Vec::new();
        let mut light_response = Vec::new();
        let mut shadow_controls = Vec::new();
        let link_mask = |names: &Option<Vec<String>>| {
            names.as_ref().map(|names| {
                let names: std::collections::HashSet<&str> = names.iter().map(String::as_str).collect();
                scene.instances.iter().map(|i| names.contains(i.name.as_str())).collect::<std::sync::Arc<[bool]>>()
            })
        };
        let mut maps = cache.map(|c| c.maps.begin());
        for l in &scene.lights {
            match Light::from_desc_with(l, &scene.textures, cs, maps.as_mut()) {
                Ok(light) => {
                    let tag = scene.caustics.emitter(&l.name);
                    let default = matches!(l.shape, crate::scene::LightShape::Distant { .. } | crate::scene::LightShape::SkySun { .. } | crate::scene::LightShape::Sphere { .. });
                    caustic_emitters.push(if any_emitter_tagged { tag == Some(true) } else { tag.unwrap_or(default) });
                    lights.push(light);
                    light_links.push(link_mask(&l.light_link));
                    shadow_links.push(link_mask(&l.shadow_link));
                    light_response.push(l.response);
                    shadow_controls.push(ShadowControls::from_desc(&l.shadow, cs));
                }
                Err(e) => {
                    let (attr, msg) = e.split_once(": ").map(|(a, m)| (a.to_string(), m.to_string())).unwrap_or(("inputs".into(), e.clone()));
                    problems.push(Problem { item: l.name.clone(), attribute: attr, message: format!("{msg}; light dropped") });
                }
            }
        }
        if let (Some(c), Some(m)) = (cache, maps) {
            c.maps.end(m);
        }
        // emissive triangles of meshes whose material emits a constant colour, or one from a
        // primvar or a texture
        let mut triangle_lights = HashMap::new();
        let mut light_triangles: Vec<Option<(u32, u32)>> = Vec::new();
        let mut shared_textures: HashMap<usize, std::sync::Arc<TextureDesc>> = HashMap::new();
        for (ii, inst) in scene.instances.iter().enumerate() {
            let GeometryRef::Mesh(mi) = inst.geometry else { continue };
            let m = &scene.meshes[mi];
            let (emission, two_sided, varying) = match materials[inst.material].kind.face() {
                SurfaceKind::Emissive { radiance, two_sided } => (radiance.clone(), *two_sided, None),
                SurfaceKind::Preview { emissive: Some(ColorParam::Const(s)), .. } => (s.clone(), false, None),
                SurfaceKind::Preview { emissive: Some(e), .. } => match varying_emission(e, m, inst, scene, &mut shared_textures, cs) {
                    Some(v) => (Spectrum::Constant(0.0), false, Some(v)),
                    None => continue,
                },
                _ => continue,
            };
            let deforms = m.motion.as_ref().is_some_and(|mm| mm.positions.len() >= 2);
            let moves = deforms || !accel.instance_motion(ii as u32).is_static();
            // the instance's motion, shared by its moving triangles
            let motion = moves.then(|| std::sync::Arc::new(accel.instance_motion(ii as u32).clone()));
            let xf = accel.instance_transform(ii as u32, camera.shutter.0);
            // a mesh light's links, shared by its triangles
            let links = scene.emitter_links.iter().find(|e| e.instance == inst.name);
            let (light_link, shadow_link) = (links.and_then(|e| link_mask(&e.light_link)), links.and_then(|e| link_mask(&e.shadow_link)));
            for (ti, t) in m.indices.chunks_exact(3).enumerate() {
                let two = two_sided || m.double_sided;
                let light = if let Some(motion) = &motion {
                    // sampled where the triangle is at each path's time, as the BVH places it
                    let (times, p) = match &m.motion {
                        Some(mm) if deforms => (mm.times.clone(), mm.positions.iter().map(|ps| [0, 1, 2].map(|k| ps[t[k] as usize])).collect()),
                        _ => (vec![0.0], vec![[0, 1, 2].map(|k| m.positions[t[k] as usize])]),
                    };
                    Light::moving_triangle(crate::light::TriangleMotion { times, p, xf: motion.clone() }, camera.shutter.0, emission.clone(), two)
                } else {
                    Light::triangle([0, 1, 2].map(|k| xf.transform_point3(m.positions[t[k] as usize])), emission.clone(), two)
                };
                // a mirroring placement keeps the mesh's front (its winding turns in the world)
                let light = if xf.determinant() < 0.0 { light.map(Light::mirrored) } else { light };
                let light = match (&varying, light) {
                    (Some(v), Some(l)) => {
                        let (how, mean) = v(t);
                        with_varying(l, how, mean, cs)
                    }
                    (_, l) => l,
                };
                if let Some(l) = light {
                    triangle_lights.insert((ii as u32, ti as u32), lights.len());
                    light_triangles.resize(lights.len(), None);
                    light_triangles.push(Some((ii as u32, ti as u32)));
                    lights.push(l);
                    caustic_emitters.push(false);
                    light_links.push(light_link.clone());
                    shadow_links.push(shadow_link.clone());
                    light_response.push(Default::default());
                }
            }
        }
        let (lo, hi) = accel.bounds();
        let center = (lo + hi) * 0.5;
        let radius = ((hi - lo).length() * 0.5).max(1e-3);
        for l in &mut lights {
            l.preprocess(center, radius);
        }
        let light_tree = crate::light::tree::LightTree::build(&lights, LightSampler::new(&lights), camera.shutter);
        let hittable_lights: Vec<usize> = (0..lights.len()).filter(|&i| !lights[i].is_infinite() && !lights[i].is_delta() && !matches!(lights[i].inner(), Light::Triangle(_))).collect();
        let light_bvh = crate::light::bvh::LightBvh::build(&lights, &hittable_lights, camera.shutter);
        let infinite_lights = (0..lights.len()).filter(|&i| lights[i].is_infinite()).collect();
        let instances = scene
            .instances
            .iter()
            .map(|i| InstanceInfo { geometry: i.geometry, material: i.material, id: i.id, index: i.index.map_or(-1, |k| k.min(i32::MAX as u32) as i32), visible_to_camera: i.visible_to_camera, casts_shadows: i.casts_shadows, primvar_row: i.primvar_row })
            .collect();
        let any_caster_tagged = scene.caustics.objects.iter().any(|(_, o)| o.caster == Some(true));
        let caustic_instances = scene
            .instances
            .iter()
            .map(|i| {
                let o = scene.caustics.object(&i.name);
                let water = matches!(materials[i.material].kind, SurfaceKind::Dielectric(_));
                let caster = if any_caster_tagged { o.caster == Some(true) } else { o.caster.unwrap_or(water) };
                let caster = caster && o.transparency == crate::scene::CausticsTransparency::Off;
                InstanceCaustics { caster, receiver: o.receiver && !caster, transparency: o.transparency }
            })
            .collect();
        let mut world = World {
            caustic_instances,
            caustic_emitters,
            accel,
            instances,
            meshes: scene.meshes.clone(),
            sphere_primvars: scene.spheres.iter().map(|s| s.primvars.clone()).collect(),
            sphere_origins: scene.spheres.iter().map(|s| s.origin).collect(),
            spheres: scene.spheres.clone(),
            instance_primvars: scene.instance_primvars.clone(),
            materials,
            media,
            textures: scene.textures.clone(),
            lights,
            light_tree,
            hittable_lights,
            light_bvh,
            infinite_lights,
            triangle_lights,
            light_triangles,
            light_links,
            shadow_links,
            any_light_response: light_response.iter().any(|r| !r.is_physical()),
            light_response,
            shadow_controls,
            camera,
            origin: scene.origin.as_vec3(),
            cs: scene.color_space,
            max_depth: settings.max_depth,
            aovs: settings.aovs,
            diffusion: Default::default(),
        };
        world.diffusion = crate::diffusion::DiffusionCache::build(&world, scene);
        world
    }

    /// Whether light `light` illuminates instance `instance` (its light-link collection).
    pub fn illuminates(&self, light: usize, instance: u32) -> bool {
        self.light_links[light].as_ref().is_none_or(|m| m.get(instance as usize).copied().unwrap_or(false))
    }

    /// Light `light`'s multiplier for emission gathered by a vertex that scatters with `lobe`.
    #[inline]
    pub fn light_response(&self, light: usize, lobe: Lobe) -> f32 {
        let r = &self.light_response[light];
        match lobe {
            Lobe::None => 1.0,
            Lobe::Diffuse => r.diffuse,
            Lobe::Specular => r.specular,
        }
    }

    /// Whether a mesh hit's texture coordinates run clockwise round its triangle (seen from the
    /// side its normal faces; a mirroring instance transform turns them once more): dp/dv then
    /// lies on the side of −(n × dp/du).
    fn uv_mirrored(&self, s: &SurfaceHit) -> bool {
        let Some(info) = self.instances.get(s.instance as usize) else { return false };
        let GeometryRef::Mesh(mi) = info.geometry else { return false };
        let mesh = &self.meshes[mi];
        let Some(uvs) = &mesh.uvs else { return false };
        let i = 3 * s.prim as usize;
        let Some(tri) = mesh.indices.get(i..i + 3) else { return false };
        let t = [0, 1, 2].map(|k| uvs[tri[k] as usize]);
        let (a, b) = (t[1] - t[0], t[2] - t[0]);
        let mirrors = self.accel.instance_transform(s.instance, 0.0).determinant() < 0.0;
        (a.x * b.y - a.y * b.x < 0.0) != mirrors
    }

    /// A light's shadow controls, where set.
    #[inline]
    pub fn shadow_controls(&self, light: usize) -> Option<&ShadowControls> {
        self.shadow_controls.get(light).and_then(Option::as_ref)
    }

    /// Whether instance `instance` casts the shadows of light `light` (its shadow-link
    /// collection; the instance's own `casts_shadows` is separate).
    pub fn casts_shadow_of(&self, light: usize, instance: u32) -> bool {
        self.shadow_links[light].as_ref().is_none_or(|m| m.get(instance as usize).copied().unwrap_or(false))
    }

    /// The authored element a hit lies on (the `elementId` AOV): a mesh's face, a curve, a
    /// point; -1 on a blobby surface (no one point's).
    pub fn element_of(&self, hit: &Hit) -> i32 {
        match self.instances[hit.instance as usize].geometry {
            GeometryRef::Mesh(mi) => self.meshes[mi].element_of(hit.prim) as i32,
            GeometryRef::Spheres(si) => match self.spheres.get(si) {
                Some(s) if matches!(s.shape, crate::scene::PointShape::Blobby { .. }) => -1,
                Some(s) => s.element_of(hit.prim) as i32,
                None => hit.prim as i32,
            },
        }
    }

    /// The closest hit along a path's ray, where a water body's boundary and another surface
    /// coincide (a pool's water meeting its floor and walls face to face, as pools are
    /// modelled) resolved to the other surface: which of two coincident faces single
    /// precision finds first is otherwise a matter of rounding, and the path would leave the
    /// water through its boundary and reach the floor from behind it, or from air, by turns
    /// as the scene's size or position changes. Faces within [`COINCIDENT`] of the hit's
    /// distance and position of each other coincide. A hit on anything else is the closest
    /// hit; one on a boundary costs a probe of that short stretch.
    pub fn intersect_path(&self, ray: &Ray) -> Option<Hit> {
        let hit = self.accel.intersect(ray)?;
        if !self.is_boundary(hit.instance) {
            return Some(hit);
        }
        let reach = COINCIDENT * (hit.t + ray.o.abs().max_element()).max(f32::MIN_POSITIVE);
        let start = (hit.t - reach).max(0.0);
        let probe = Ray { o: ray.o + ray.d * start, d: ray.d, t_max: hit.t + reach - start, time: ray.time };
        match self.accel.intersect_where(&probe, |i| !self.is_boundary(i)) {
            Some(h) => Some(Hit { t: (start + h.t).min(ray.t_max), ..h }),
            None => Some(hit),
        }
    }

    /// Whether an instance's surface is a boundary a path may cross (a dielectric, or a
    /// volume's box).
    #[inline]
    fn is_boundary(&self, instance: u32) -> bool {
        let m = &self.materials[self.instances[instance as usize].material];
        m.dielectric().is_some() || m.is_medium_boundary()
    }

    /// Geometry at a hit.
    pub fn surface(&self, ray: &Ray, hit: &Hit) -> SurfaceHit {
        let info = &self.instances[hit.instance as usize];
        let m = self.accel.instance_transform(hit.instance, ray.time);
        let nm = Mat3::from_mat4(m).inverse().transpose();
        match info.geometry {
            GeometryRef::Mesh(mi) => {
                let mesh = &self.meshes[mi];
                let i = 3 * hit.prim as usize;
                let idx = [mesh.indices[i] as usize, mesh.indices[i + 1] as usize, mesh.indices[i + 2] as usize];
                let (b1, b2) = (hit.u, hit.v);
                let b0 = 1.0 - b1 - b2;
                let v = idx.map(|k| mesh.position_at(k, ray.time));
                let p_obj = v[0] * b0 + v[1] * b1 + v[2] * b2;
                // the weighted sum's rounding (the barycentrics' own error moves the point
                // within the triangle's plane, not off it)
                let err_obj = ((v[0] * b0).abs() + (v[1] * b1).abs() + (v[2] * b2).abs()) * crate::math::gamma(7);
                let ng_obj = (v[1] - v[0]).cross(v[2] - v[0]);
                let ng = (nm * ng_obj).normalize();
                let mut ns = ng;
                if let [Some(n0), Some(n1), Some(n2)] = idx.map(|k| mesh.normal_at(k, ray.time)) {
                    let ni = n0 * b0 + n1 * b1 + n2 * b2;
                    if ni.length_squared() > 1e-12 {
                        let w = (nm * ni).normalize();
                        ns = if w.dot(ng) < 0.0 { -w } else { w };
                    }
                }
                let (uv, dpdu) = match &mesh.uvs {
                    Some(uvs) => {
                        let t = idx.map(|k| uvs[k]);
                        let uv = t[0] * b0 + t[1] * b1 + t[2] * b2;
                        (uv, m.transform_vector3(crate::math::triangle_dpdu(v, t)))
                    }
                    None => (Vec2::new(b1, b2), m.transform_vector3(v[1] - v[0])),
                };
                let err = crate::math::transformed_error(&m, p_obj, err_obj);
                SurfaceHit { p: m.transform_point3(p_obj), err, ng, ns, uv, dpdu, instance: hit.instance, prim: hit.prim, bary: Vec2::new(b1, b2), t: hit.t }
            }
            GeometryRef::Spheres(_) => {
                let (c, r) = self.accel.sphere_center(hit.instance, hit.prim, ray.time).unwrap_or((Vec3::ZERO, 1.0));
                let inv = m.inverse();
                let p_obj_ray = inv.transform_point3(ray.o + ray.d * hit.t);
                let (n_obj, p_obj, err_obj) = if self.accel.hit_carries_normal(hit.instance) {
                    // bubbles and blobbies: the normal the intersection found, the ray's point
                    // (its distance found in f64; o + t·d, brought into the object's space)
                    let w = ray.o.abs() + ray.d.abs() * hit.t;
                    (crate::accel::implicit::oct_decode(hit.u, hit.v), p_obj_ray, crate::math::transformed_error(&inv, w, Vec3::ZERO) + p_obj_ray.abs() * crate::math::gamma(4))
                } else {
                    let n = (p_obj_ray - c).normalize_or_zero();
                    // reprojected onto the surface
                    (n, c + n * r, (c.abs() + (n * r).abs()) * crate::math::gamma(6))
                };
                let ng = (nm * n_obj).normalize();
                let phi = n_obj.z.atan2(n_obj.x);
                let uv = Vec2::new(0.5 + phi / (2.0 * std::f32::consts::PI), 1.0 - n_obj.y.clamp(-1.0, 1.0).acos() / std::f32::consts::PI);
                let dpdu = m.transform_vector3(Vec3::new(-n_obj.z, 0.0, n_obj.x));
                let err = crate::math::transformed_error(&m, p_obj, err_obj);
                SurfaceHit { p: m.transform_point3(p_obj), err, ng, ns: ng, uv, dpdu, instance: hit.instance, prim: hit.prim, bary: Vec2::ZERO, t: hit.t }
            }
        }
    }

    /// Mean curvature (1/length, world units) of the shading surface at `hit`, positive where
    /// it is convex on its outside (the side of [`SurfaceHit::ng`]): the normal derivative of
    /// a mesh's interpolated vertex normals (0 without them), `1/r` on a sphere. Only what the
    /// caustics footprint needs at specular events; not part of [`World::surface`].
    pub fn mean_curvature(&self, ray: &Ray, hit: &Hit) -> f32 {
        let info = &self.instances[hit.instance as usize];
        let m = self.accel.instance_transform(hit.instance, ray.time);
        match info.geometry {
            GeometryRef::Mesh(mi) => {
                let mesh = &self.meshes[mi];
                let i = 3 * hit.prim as usize;
                let idx = [mesh.indices[i] as usize, mesh.indices[i + 1] as usize, mesh.indices[i + 2] as usize];
                let [Some(n0), Some(n1), Some(n2)] = idx.map(|k| mesh.normal_at(k, ray.time)) else { return 0.0 };
                let nm = Mat3::from_mat4(m).inverse().transpose();
                let p = idx.map(|k| m.transform_point3(mesh.position_at(k, ray.time)));
                let n = [n0, n1, n2].map(|v| (nm * v).normalize_or_zero());
                let k = crate::caustics::footprint::triangle_mean_curvature(p, n, Vec2::new(hit.u, hit.v));
                // the curvature is signed for the side the normals face; the outside is ng's
                let ng = (p[1] - p[0]).cross(p[2] - p[0]) * Mat3::from_mat4(m).determinant().signum();
                let ni = n[0] * (1.0 - hit.u - hit.v) + n[1] * hit.u + n[2] * hit.v;
                if ni.dot(ng) < 0.0 { -k } else { k }
            }
            GeometryRef::Spheres(_) => {
                let r = self.accel.sphere_center(hit.instance, hit.prim, ray.time).map_or(1.0, |(_, r)| r);
                // world radius under the instance's scale (the cube root of its volume change)
                let s = Mat3::from_mat4(m).determinant().abs().cbrt();
                let k = 1.0 / (r * s);
                if k.is_finite() { k } else { 0.0 }
            }
        }
    }

    /// The primvar `name` at a hit: the geometry's varying one (interpolated over a triangle,
    /// or a sphere's own value), else the instance's, else the geometry's constant one; None
    /// where there is no such primvar.
    pub fn primvar(&self, s: &SurfaceHit, name: &str) -> Option<[f32; 4]> {
        let info = self.instances.get(s.instance as usize)?;
        if let GeometryRef::Mesh(mi) = info.geometry {
            if self.meshes[mi].uvs_answer(name) {
                // the mesh's texture coordinates, as the hit interpolated them
                return Some([s.uv.x, s.uv.y, 0.0, 0.0]);
            }
        }
        let own = match info.geometry {
            GeometryRef::Mesh(mi) => &self.meshes[mi].primvars[..],
            GeometryRef::Spheres(si) => &self.sphere_primvars.get(si)?[..],
        };
        match primvar_source(own, info.primvar_row, &self.instance_primvars, name)? {
            PrimvarSource::Value(v) => Some(v),
            PrimvarSource::Varying(pv) => match info.geometry {
                GeometryRef::Mesh(mi) => {
                    let mesh = &self.meshes[mi];
                    let i = 3 * s.prim as usize;
                    let w = [1.0 - s.bary.x - s.bary.y, s.bary.x, s.bary.y];
                    let mut out = [0.0; 4];
                    for (k, wk) in w.into_iter().enumerate() {
                        let e = pv.element(*mesh.indices.get(i + k)? as usize);
                        for c in 0..4 {
                            out[c] += wk * e[c];
                        }
                    }
                    Some(out)
                }
                GeometryRef::Spheres(_) => Some(pv.element(s.prim as usize)),
            },
        }
    }

    fn rgb(&self, c: &ColorParam, s: &SurfaceHit) -> Option<[f32; 3]> {
        match c {
            ColorParam::Const(_) => None,
            ColorParam::Tex(l) => Some(texture::lookup_rgb(&self.textures, l, AtHit { w: self, s }.st(l))),
            ColorParam::Primvar(l) => {
                let v = self.primvar_or(s, l);
                Some([v[0], v[1], v[2]])
            }
            ColorParam::Graph(e) => {
                let v = e.eval(&AtHit { w: self, s });
                Some([v[0], v[1], v[2]])
            }
        }
    }

    /// A lookup's value at a hit: the primvar's or the fallback, times the lookup's scale.
    fn primvar_or(&self, s: &SurfaceHit, l: &PrimvarLookup) -> [f32; 4] {
        let v = self.primvar(s, &l.name).unwrap_or(l.fallback);
        std::array::from_fn(|k| v[k] * l.scale[k])
    }

    fn color(&self, c: &ColorParam, s: &SurfaceHit, lambda: &SampledWavelengths) -> SampledSpectrum {
        match (c, self.rgb(c, s)) {
            (ColorParam::Const(sp), _) => sp.sample(lambda),
            (_, rgb) => uplift::albedo(rgb.unwrap_or_default(), crate::scene::AUTHORED_COLOR_SPACE).sample(lambda),
        }
    }

    fn float(&self, c: &FloatParam, s: &SurfaceHit) -> f32 {
        match c {
            FloatParam::Const(v) => *v,
            FloatParam::Tex(l) => texture::lookup_float(&self.textures, l, AtHit { w: self, s }.st(l)),
            FloatParam::Primvar(l) => self.primvar_or(s, l)[0],
            FloatParam::Graph(e) => e.eval(&AtHit { w: self, s })[0],
        }
    }

    /// Opacity of a surface at a hit (1 for everything but a translucent preview surface, or a
    /// dielectric blended with one).
    pub fn opacity(&self, material: usize, s: &SurfaceHit) -> f32 {
        match self.materials[material].kind.face() {
            SurfaceKind::Preview { opacity, opacity_threshold, .. } => {
                let o = self.float(opacity, s).clamp(0.0, 1.0);
                if *opacity_threshold > 0.0 {
                    if o < *opacity_threshold {
                        0.0
                    } else {
                        1.0
                    }
                } else {
                    o
                }
            }
            _ => 1.0,
        }
    }

    /// What a thin wall at a hit lets straight through along `d` (world, either way), in a
    /// medium of index `outside_ior`; zero for a surface with no straight transmission.
    pub fn straight_through(&self, material: usize, s: &SurfaceHit, d: Vec3, outside_ior: f32, lambda: &SampledWavelengths) -> SampledSpectrum {
        let SurfaceKind::Preview { extras: Some(x), .. } = &self.materials[material].kind else {
            return SampledSpectrum::ZERO;
        };
        if x.thin_walled.as_ref().is_none_or(|t| matches!(t.transmission, FloatParam::Const(v) if v == 0.0)) {
            return SampledSpectrum::ZERO;
        }
        let (bsdf, frame) = self.bsdf(material, s, lambda, outside_ior, 1.0);
        bsdf.straight_through(frame.to_local(d))
    }

    /// What crossing a dielectric's surface without scattering (switched to transparency)
    /// multiplies the light by: its transmission tint (1 for a clear one or any other surface).
    pub fn transmission_tint(&self, material: usize, s: &SurfaceHit, lambda: &SampledWavelengths) -> SampledSpectrum {
        match self.materials[material].dielectric().and_then(|d| d.tint.as_ref()) {
            Some(tint) => self.color(tint, s, lambda).map(|v| v.clamp(0.0, 1.0)),
            None => SampledSpectrum::ONE,
        }
    }

    /// Emitted radiance of a surface towards `wo` (world), for emissive materials.
    pub fn emitted(&self, material: usize, s: &SurfaceHit, wo: Vec3, lambda: &SampledWavelengths, double_sided: bool) -> SampledSpectrum {
        let front = wo.dot(s.ng) > 0.0;
        match self.materials[material].kind.face() {
            SurfaceKind::Emissive { radiance, two_sided } if front || *two_sided || double_sided => radiance.sample(lambda),
            SurfaceKind::Preview { emissive: Some(e), .. } if front || double_sided => match e {
                ColorParam::Const(sp) => sp.sample(lambda),
                // as an emissive triangle light evaluates it: negative values emit nothing
                _ => uplift::illuminant(self.rgb(e, s).unwrap_or_default().map(|v| v.max(0.0)), crate::scene::AUTHORED_COLOR_SPACE).sample(lambda),
            },
            _ => SampledSpectrum::ZERO,
        }
    }

    /// The BSDF at a hit, in the shading frame. `outside_ior` is the IOR of the medium the
    /// surface sits in (for preview surfaces inside water), `eta` the relative IOR for
    /// dielectrics (inside over outside).
    pub fn bsdf(&self, material: usize, s: &SurfaceHit, lambda: &SampledWavelengths, outside_ior: f32, eta: f32) -> (Bsdf, Frame) {
        let mut frame = Frame::from_normal_tangent(s.ns, s.dpdu);
        let kind = &self.materials[material].kind;
        let bsdf = match kind {
            SurfaceKind::Diffuse(c) => Bsdf::lambert(self.color(c, s, lambda).map(|v| v.clamp(0.0, 1.0))),
            SurfaceKind::Preview { wet, normal, .. } => {
                if let Some(map) = normal {
                    frame = self.normal_mapped(map, s, &frame);
                }
                // the inputs are looked up once; a wet surface builds its layers twice, against
                // the outside and against the film
                let params = self.preview_params(kind, s, lambda, outside_ior, &mut frame);
                let dry = Bsdf::preview(params);
                let wet = wet.as_ref().map(|w| (w, self.float(&w.amount, s)));
                match wet {
                    // the covered surface's layers meet the film, not the outside
                    Some((w, amount)) if amount > 0.0 => dry.and_then(|dry| {
                        let covered = Bsdf::preview(PreviewParams { outside_ior: w.ior.max(outside_ior), ..params })?;
                        Bsdf::wet(dry, covered, amount, w.ior / outside_ior)
                    }),
                    _ => dry,
                }
            }
            SurfaceKind::Dielectric(dm) => match (&dm.sea, &dm.tint, &dm.blend) {
                (Some((speed, wind, share)), ..) => {
                    let l = frame.to_local(*wind);
                    // a share read from the mesh that is no share takes the material's
                    let scale = match (self.float(share, s), share) {
                        (v, _) if v.is_finite() && v >= 0.0 => v,
                        (_, FloatParam::Primvar(look)) => look.fallback[0],
                        _ => 1.0,
                    };
                    Bsdf::sea_scaled(eta, *speed, l.y.atan2(l.x), scale)
                }
                (None, None, None) => Bsdf::dielectric(eta, dm.roughness),
                _ => self.tinted_or_blended(dm, s, lambda, eta, &mut frame),
            },
            SurfaceKind::Conductor { eta: e, k, roughness } => Bsdf::conductor(e.sample(lambda) / outside_ior, k.sample(lambda) / outside_ior, *roughness),
            SurfaceKind::Emissive { .. } | SurfaceKind::MediumBoundary => Bsdf::lambert(SampledSpectrum::ZERO),
        };
        (bsdf.unwrap_or_else(|_| Bsdf::lambert(SampledSpectrum::splat(0.18)).expect("grey lambert")), frame)
    }

    /// The shading frame turned to a tangent-space normal map's normal at the hit: its x along
    /// the frame's tangent (dp/du), y along dp/dv's side of n × x (the other side where the
    /// texture coordinates are mirrored), z along n. A normal that is not finite, or that
    /// points below the tangent plane, leaves the frame as it is.
    fn normal_mapped(&self, map: &NormalParam, s: &SurfaceHit, frame: &Frame) -> Frame {
        let [x, y, z] = match map {
            NormalParam::Const(v) => *v,
            NormalParam::Lookup(c) => self.rgb(c, s).unwrap_or([0.0, 0.0, 1.0]),
        };
        let y = if self.uv_mirrored(s) { -y } else { y };
        let n = (frame.s * x + frame.t * y + frame.n * z).normalize_or_zero();
        if n.dot(frame.n) > 0.0 && n.is_finite() {
            Frame::from_normal_tangent(n, frame.s)
        } else {
            *frame
        }
    }

    /// A dielectric with a transmission tint or an opaque part blended with it (the plain one
    /// stays on [`Self::bsdf`]'s short path: the BSDF is large to move).
    #[inline(never)]
    fn tinted_or_blended(&self, dm: &DielectricMat, s: &SurfaceHit, lambda: &SampledWavelengths, eta: f32, frame: &mut Frame) -> Result<Bsdf, crate::bsdf::BsdfError> {
        let mut clear = Bsdf::dielectric(eta, dm.roughness)?;
        if let Some(tint) = &dm.tint {
            clear = clear.tint_transmission(self.color(tint, s, lambda))?;
        }
        let Some(b) = &dm.blend else { return Ok(clear) };
        // MaterialX's metal lies over the whole surface, the transmission under its specular
        // layer: the interface's share is (1 − metal) × transmission, and the opaque part's
        // metal is rescaled to keep its own share. The opaque part meets the index outside
        // the body from either side, as one BSDF whichever way it is seen.
        let mut p = self.preview_params(&b.1, s, lambda, dm.ior_at(lambda) / eta, frame);
        let share = self.float(&b.0, s).clamp(0.0, 1.0) * (1.0 - p.metallic);
        p.metallic = if share < 1.0 { (p.metallic / (1.0 - share)).min(1.0) } else { 0.0 };
        Bsdf::blend(clear, Bsdf::preview(p)?, share)
    }

    /// A preview surface's inputs at a hit (the default stack for any other kind); the frame's
    /// tangent turns by its anisotropy's rotation.
    #[inline]
    fn preview_params(&self, kind: &SurfaceKind, s: &SurfaceHit, lambda: &SampledWavelengths, outside_ior: f32, frame: &mut Frame) -> PreviewParams {
        let SurfaceKind::Preview { diffuse, specular, use_specular_workflow, metallic, roughness, clearcoat, clearcoat_roughness, ior, wet, extras, .. } = kind else {
            return PreviewParams::default();
        };
        let mut d = self.color(diffuse, s, lambda).map(|v| v.clamp(0.0, 1.0));
        if let Some(w) = wet.as_ref().filter(|w| w.water_compliant) {
            d = crate::bsdf::wet::compliance_boost(d, w.ior, outside_ior);
        }
        let params = PreviewParams {
            diffuse: d,
            specular_f0: self.color(specular, s, lambda).map(|v| v.clamp(0.0, 1.0)),
            metallic: self.float(metallic, s).clamp(0.0, 1.0),
            base_for_metal: d,
            roughness: self.float(roughness, s).clamp(0.0, 1.0),
            clearcoat: self.float(clearcoat, s).clamp(0.0, 1.0),
            clearcoat_roughness: self.float(clearcoat_roughness, s).clamp(0.0, 1.0),
            ior: *ior,
            outside_ior,
            use_specular_workflow: *use_specular_workflow,
            // UsdPreviewSurface's ior serves the clearcoat too (MaterialX extras set their own)
            coat_ior: *ior,
            ..PreviewParams::default()
        };
        match extras.as_deref() {
            Some(x) => {
                let turn = self.float(&x.anisotropy_rotation, s);
                if turn != 0.0 && turn.is_finite() {
                    let (sin, cos) = (turn * std::f32::consts::TAU).sin_cos();
                    *frame = Frame::from_normal_tangent(s.ns, frame.s * cos + frame.t * sin);
                }
                PreviewParams {
                    specular_weight: self.float(&x.specular_weight, s),
                    specular_tint: self.color(&x.specular_tint, s, lambda),
                    coat_color: self.color(&x.coat_color, s, lambda),
                    coat_ior: x.coat_ior,
                    coat_anisotropy: self.float(&x.coat_anisotropy, s),
                    coat_darkening: self.float(&x.coat_darkening, s),
                    darkening_albedo: self.color(&x.darkening_albedo, s, lambda),
                    anisotropy: self.float(&x.anisotropy, s),
                    flavour: x.flavour,
                    diffuse_roughness: self.float(&x.diffuse_roughness, s),
                    sheen_weight: self.float(&x.sheen_weight, s),
                    sheen_color: self.color(&x.sheen_color, s, lambda),
                    sheen_roughness: self.float(&x.sheen_roughness, s),
                    thin_film: match x.thin_film_weight {
                        FloatParam::Const(w) if w == 0.0 => None,
                        ref w => Some(crate::bsdf::ThinFilmParams {
                            weight: self.float(w, s),
                            thickness_nm: self.float(&x.thin_film_thickness, s) * x.thin_film_unit_nm,
                            ior: x.thin_film_ior,
                            lambda: *lambda,
                        }),
                    },
                    thin_walled: x.thin_walled.as_ref().map(|t| crate::bsdf::preview::ThinWalled {
                        transmission: self.float(&t.transmission, s),
                        tint: self.color(&t.tint, s, lambda),
                        subsurface: self.float(&t.subsurface, s),
                        reflect: self.color(&t.reflect, s, lambda),
                        transmit: self.color(&t.transmit, s, lambda),
                    }),
                    ..params
                }
            }
            None => params,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Mat4;

    /// A shadow's reach: the whole way without a distance; the distance with no falloff; in
    /// a falloff zone, beyond a point x into it with probability (1 − x)^γ (Kolmogorov–Smirnov
    /// against that law, 4000 draws); and its colour on the shadowed part only.
    #[test]
    fn shadow_controls_reach_and_colour_as_usdlux_says() {
        let cs = ColorSpace::LinearRec709;
        assert!(ShadowControls::from_desc(&ShadowDesc::default(), cs).is_none());
        let hard = ShadowControls::from_desc(&ShadowDesc { distance: 3.0, ..Default::default() }, cs).unwrap();
        assert_eq!((hard.reach(10.0, 0.3), hard.reach(2.0, 0.3), hard.reach(f32::INFINITY, 0.9)), (3.0, 2.0, 3.0));
        let gamma = 2.0f32;
        let soft = ShadowControls::from_desc(&ShadowDesc { distance: 4.0, falloff: 0.5, falloff_gamma: gamma, ..Default::default() }, cs).unwrap();
        let n = 4000;
        let mut reach: Vec<f32> = (0..n).map(|i| soft.reach(f32::INFINITY, (i as f32 + 0.5) / n as f32)).collect();
        reach.sort_by(f32::total_cmp);
        assert!(reach[0] >= 2.0 && reach[n - 1] <= 4.0);
        // P(reach > 2 + 2x) = (1 − x)^γ: the empirical CDF against 1 − (1 − x)^γ
        let ks = reach.iter().enumerate().map(|(i, r)| {
            let cdf = 1.0 - (1.0 - (r - 2.0) / 2.0).powf(gamma);
            (cdf - i as f32 / n as f32).abs().max((cdf - (i + 1) as f32 / n as f32).abs())
        });
        let d = ks.fold(0.0f32, f32::max);
        assert!(d < 1.63 / (n as f32).sqrt(), "KS distance {d}");
        // the colour fills the shadowed part: black, half and no shadow
        let lambda = SampledWavelengths::sample_uniform(0.3);
        let red = ShadowControls::from_desc(&ShadowDesc { color: [0.5, 0.5, 0.5], ..Default::default() }, cs).unwrap();
        for (tr, want) in [(0.0, 0.5), (0.5, 0.75), (1.0, 1.0)] {
            let got = red.shade(SampledSpectrum::splat(tr), &lambda);
            assert!((0..4).all(|k| (got[k] - want).abs() < 1e-5), "{tr}: {got:?}");
        }
    }

    fn tri(name: &str, y: [f32; 3]) -> MeshDesc {
        MeshDesc { name: name.into(), positions: vec![Vec3::new(0.0, y[0], 0.0), Vec3::new(1.0, y[1], 0.0), Vec3::new(0.0, y[2], 1.0)], indices: vec![0, 1, 2], ..Default::default() }
    }

    fn inst(g: GeometryRef, m: Mat4, material: usize) -> InstanceDesc {
        InstanceDesc { name: "/i".into(), geometry: g, transforms: vec![m], times: vec![0.0], material, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None }
    }

    #[test]
    fn a_water_face_lying_on_another_surface_gives_way_to_it() {
        // a water triangle and a diffuse one in the same plane y = h, placed by transforms
        // that round differently: a path's ray meets the diffuse one, at any scale and place;
        // water alone, or 2·10⁻⁵ of the distance before the other, is met as water
        let build = |scale: f32, at: Vec3, gap: f32| {
            let mut s = SceneDesc::default();
            let mut m = tri("/t", [0.0; 3]);
            m.indices = vec![0, 2, 1];
            s.meshes.push(m.into());
            s.materials.push(MaterialDesc { name: "/w".into(), surface: SurfaceDesc::Water(WaterDesc::default()), interior_medium: None });
            s.materials.push(MaterialDesc { name: "/d".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
            // the same plane reached as 3·(h/3) and as h: rounded apart
            let h = 0.7 * scale;
            let water = Mat4::from_translation(at + Vec3::Y * (h / 3.0 * 3.0 + gap)) * Mat4::from_scale(Vec3::splat(3.0 * scale)) * Mat4::from_translation(Vec3::new(-0.2, 0.0, -0.2));
            let floor = Mat4::from_translation(at + Vec3::Y * h) * Mat4::from_scale(Vec3::splat(2.0 * scale)) * Mat4::from_translation(Vec3::new(-0.1, 0.0, -0.1));
            s.instances_mut().push(inst(GeometryRef::Mesh(0), water, 0));
            s.instances_mut().push(inst(GeometryRef::Mesh(0), floor, 1));
            World::build(&s, &RenderSettings::default(), &mut Vec::new())
        };
        for scale in [1.0f32, 0.3, 1e-3, 7e2] {
            for at in [Vec3::ZERO, Vec3::new(3.1, -2.7, 0.9) * scale] {
                for k in 0..16 {
                    let x = (k as f32 * 0.37).fract() * 0.5 * scale;
                    let ray = Ray { o: at + Vec3::new(x + 0.05 * scale, 5.0 * scale, 0.05 * scale + x * 0.3), d: Vec3::new(0.01, -1.0, 0.02).normalize(), t_max: f32::INFINITY, time: 0.0 };
                    let w = build(scale, at, 0.0);
                    let hit = w.intersect_path(&ray).expect("a hit");
                    assert_eq!(hit.instance, 1, "scale {scale} at {at} ray {k}: the water's face was taken");
                    let plain = w.accel.intersect(&ray).unwrap();
                    assert!((hit.t - plain.t).abs() <= COINCIDENT * (plain.t + ray.o.abs().max_element()));
                    // the water a little above the floor is water
                    let w = build(scale, at, 2e-5 * 5.0 * scale);
                    assert_eq!(w.intersect_path(&ray).unwrap().instance, 0, "scale {scale} at {at} ray {k}");
                }
            }
        }
    }

    #[test]
    fn a_deforming_mesh_is_shaded_as_it_stands_at_the_ray_time() {
        // a triangle in y = 0 lifted to y = 2 over [0, 1] s while its normals turn from +Y
        // to +X: at t = 0.25 the hit is at y = 0.5 and the normal is the lerp, normalised
        let mut m = tri("/m", [0.0; 3]);
        m.indices = vec![0, 2, 1]; // front side +Y, as the normals say
        m.normals = Some(vec![Vec3::Y; 3]);
        let lifted: Vec<Vec3> = m.positions.iter().map(|p| *p + Vec3::Y * 2.0).collect();
        m.motion = Some(crate::scene::MeshMotion { times: vec![0.0, 1.0], positions: vec![m.positions.clone(), lifted], normals: Some(vec![vec![Vec3::Y; 3], vec![Vec3::X; 3]]) });
        let mut s = SceneDesc::default();
        s.meshes.push(m.into());
        s.materials.push(MaterialDesc { name: "/d".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
        s.instances_mut().push(inst(GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
        s.camera.shutter_close = 1.0;
        let w = World::build(&s, &RenderSettings::default(), &mut Vec::new());
        let ray = Ray { o: Vec3::new(0.25, 5.0, 0.25), d: -Vec3::Y, t_max: f32::INFINITY, time: 0.25 };
        let hit = w.accel.intersect(&ray).expect("the triangle at y = 0.5");
        let sh = w.surface(&ray, &hit);
        // positions are lerped in f32: a few ulp
        assert!((sh.p - Vec3::new(0.25, 0.5, 0.25)).length() < 1e-5, "{:?}", sh.p);
        assert!((sh.ns - Vec3::new(0.25, 0.75, 0.0).normalize()).length() < 1e-5, "{:?}", sh.ns);
    }

    #[test]
    fn water_top_is_the_highest_point_of_the_bodies_filled_with_the_medium() {
        let mut s = SceneDesc::default();
        s.meshes.push(tri("/a", [-5.0, 1.0, -2.0]).into());
        s.spheres.push(std::sync::Arc::new(SpheresDesc { name: "/s".into(), centers: vec![Vec3::ZERO], radii: vec![1.0], velocities: None, ..Default::default() }));
        let water = |m| MaterialDesc { name: "/w".into(), surface: SurfaceDesc::Water(WaterDesc::default()), interior_medium: m };
        s.materials = vec![water(Some(0)), water(Some(1)), water(None)];
        // medium 0: the mesh lifted by 2 (top 3) and a unit sphere scaled by 2.5 at y = 1 (top 3.5)
        s.instances_mut().push(inst(GeometryRef::Mesh(0), Mat4::from_translation(Vec3::Y * 2.0), 0));
        s.instances_mut().push(inst(GeometryRef::Spheres(0), Mat4::from_scale_rotation_translation(Vec3::splat(2.5), glam::Quat::IDENTITY, Vec3::Y), 0));
        // medium 1: the mesh as is; an unfilled body far above changes nothing
        s.instances_mut().push(inst(GeometryRef::Mesh(0), Mat4::IDENTITY, 1));
        s.instances_mut().push(inst(GeometryRef::Mesh(0), Mat4::from_translation(Vec3::Y * 50.0), 2));
        let accel = Accel::build(&s.meshes, &s.spheres, &s.instances, (0.0, 0.0));
        assert_eq!(water_top(&s, &accel, 0, Vec3::Y), Some(3.5));
        assert_eq!(water_top(&s, &accel, 1, Vec3::Y), Some(1.0));
        assert_eq!(water_top(&s, &accel, 2, Vec3::Y), None);
        // on a Z-up stage: the mesh reaches z = 1 (lifting it along y changes nothing), the
        // sphere scaled by 2.5 about (0, 1, 0) z = 2.5
        assert_eq!(water_top(&s, &accel, 0, Vec3::Z), Some(2.5));
        assert_eq!(water_top(&s, &accel, 1, Vec3::Z), Some(1.0));
    }

    /// A sea surface's facets take the share of the Cox–Munk slopes the mesh carries at the hit
    /// (a `TideOcean` tile's), in place of the material's; a mesh without it, or with a value
    /// that is no share, takes the material's.
    #[test]
    fn a_sea_surface_takes_the_meshs_slope_share_at_the_hit() {
        use crate::spectrum::SampledWavelengths;
        let sea = WaterDesc { surface_model: SurfaceModel::Sea, wind_speed: 9.0, slope_variance_scale: 0.9, ..Default::default() };
        let mut with = tri("/o", [0.0; 3]);
        with.primvars = vec![PrimvarData { name: SEA_SHARE_PRIMVAR.into(), tuple: 1, constant: false, data: vec![0.1, 0.3, 0.5] }];
        let mut odd = tri("/n", [0.0; 3]);
        odd.primvars = vec![PrimvarData { name: SEA_SHARE_PRIMVAR.into(), tuple: 1, constant: false, data: vec![f32::NAN; 3] }];
        let mut s = SceneDesc::default();
        s.meshes = vec![with.into(), tri("/p", [0.0; 3]).into(), odd.into()];
        s.materials.push(MaterialDesc { name: "/sea".into(), surface: SurfaceDesc::Water(sea), interior_medium: None });
        for (k, x) in [0.0f32, 10.0, 20.0].into_iter().enumerate() {
            s.instances_mut().push(inst(GeometryRef::Mesh(k), Mat4::from_translation(Vec3::X * x), 0));
        }
        let w = World::build(&s, &RenderSettings::default(), &mut Vec::new());
        let lambda = SampledWavelengths::sample_uniform(0.5);
        let (wo, wi) = (Vec3::new(0.3, 0.2, 0.93).normalize(), Vec3::new(-0.5, 0.1, 0.86).normalize());
        for (x, share) in [(0.0f32, 0.1 * 0.5 + 0.3 * 0.25 + 0.5 * 0.25), (10.0, 0.9), (20.0, 0.9)] {
            // at (0.25, 0.25) of the triangle: barycentrics (0.5, 0.25, 0.25)
            let ray = Ray { o: Vec3::new(x + 0.25, 3.0, 0.25), d: -Vec3::Y, t_max: f32::INFINITY, time: 0.0 };
            let hit = w.surface(&ray, &w.accel.intersect(&ray).expect("a hit"));
            let (bsdf, frame) = w.bsdf(0, &hit, &lambda, 1.0, 1.33);
            let l = frame.to_local(Vec3::X);
            let want = Bsdf::sea_scaled(1.33, 9.0, l.y.atan2(l.x), share).unwrap();
            let (got, want) = (bsdf.f(wo, wi, crate::bsdf::TransportMode::Radiance), want.f(wo, wi, crate::bsdf::TransportMode::Radiance));
            assert!((got[0] - want[0]).abs() <= 1e-5 * want[0], "at x = {x}: {} vs {} (share {share})", got[0], want[0]);
            // the shares give apart values: the test can tell them
            let other = Bsdf::sea_scaled(1.33, 9.0, l.y.atan2(l.x), if share == 0.9 { 0.2 } else { 0.9 }).unwrap();
            assert!((other.f(wo, wi, crate::bsdf::TransportMode::Radiance)[0] - want[0]).abs() > 0.05 * want[0]);
        }
    }

    #[test]
    fn primvars_are_interpolated_at_the_hit_or_give_the_fallback() {
        // the triangle (0,0,0) (1,0,0) (0,0,1): at (x, 0, z) the barycentrics are (1-x-z, x, z)
        let mut m = tri("/m", [0.0; 3]);
        m.primvars = vec![
            PrimvarData { name: "heat".into(), tuple: 1, constant: false, data: vec![0.0, 1.0, 2.0] },
            PrimvarData { name: "tint".into(), tuple: 3, constant: true, data: vec![0.1, 0.2, 0.3] },
        ];
        let mut s = SceneDesc::default();
        s.meshes.push(m.into());
        s.spheres.push(std::sync::Arc::new(SpheresDesc {
            name: "/s".into(),
            centers: vec![Vec3::new(10.0, 0.0, 0.0), Vec3::new(20.0, 0.0, 0.0)],
            radii: vec![1.0; 2],
            primvars: vec![PrimvarData { name: "heat".into(), tuple: 1, constant: false, data: vec![5.0, 7.0] }],
            ..Default::default()
        }));
        s.materials.push(MaterialDesc { name: "/d".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
        s.instances_mut().push(inst(GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
        s.instances_mut().push(inst(GeometryRef::Spheres(0), Mat4::IDENTITY, 0));
        let w = World::build(&s, &RenderSettings::default(), &mut Vec::new());
        let at = |o: Vec3, d: Vec3| {
            let ray = Ray { o, d, t_max: f32::INFINITY, time: 0.0 };
            w.surface(&ray, &w.accel.intersect(&ray).expect("a hit"))
        };
        let sh = at(Vec3::new(0.25, 3.0, 0.5), -Vec3::Y);
        let heat = w.primvar(&sh, "heat").unwrap();
        assert!((heat[0] - 1.25).abs() < 1e-5 && heat[..3].iter().all(|&v| v == heat[0]), "{heat:?}");
        assert_eq!(w.primvar(&sh, "tint"), Some([0.1, 0.2, 0.3, 0.0]));
        assert_eq!(w.primvar(&sh, "absent"), None);
        let look = |name: &str| PrimvarLookup::new(name, [0.9, 0.8, 0.7, 1.0]);
        assert!((w.float(&FloatParam::Primvar(look("heat")), &sh) - 1.25).abs() < 1e-5);
        assert_eq!(w.float(&FloatParam::Primvar(look("absent")), &sh), 0.9);
        // a lookup's scale multiplies the primvar and the fallback alike
        let scaled = |name: &str| PrimvarLookup { scale: [2.0, 1.0, 0.5, 1.0], ..look(name) };
        assert!((w.float(&FloatParam::Primvar(scaled("heat")), &sh) - 2.5).abs() < 1e-5);
        assert_eq!(w.rgb(&ColorParam::Primvar(scaled("absent")), &sh), Some([1.8, 0.8, 0.35]));
        assert_eq!(w.rgb(&ColorParam::Primvar(look("tint")), &sh), Some([0.1, 0.2, 0.3]));
        // a texture's coordinates from another primvar: its first two components
        let mut tex = TexLookup { texture: 0, channel: Channel::Rgb, transform: glam::Affine2::IDENTITY, tex_scale: [1.0; 4], bias: [0.0; 4], fallback: [0.0; 4], uv_set: None };
        assert_eq!(AtHit { w: &w, s: &sh }.st(&tex), sh.uv);
        tex.uv_set = Some(look("tint"));
        assert_eq!(AtHit { w: &w, s: &sh }.st(&tex), Vec2::new(0.1, 0.2));
        tex.uv_set = Some(look("absent"));
        assert_eq!(AtHit { w: &w, s: &sh }.st(&tex), Vec2::new(0.9, 0.8));
        // an instance's own values come between the geometry's varying and constant ones
        let mut s2 = s.clone();
        s2.instances_mut()[0].primvar_row = Some((0, 1));
        let row = |name: &str, data: Vec<f32>, tuple| PrimvarData { name: name.into(), tuple, constant: false, data };
        s2.instance_primvars.push(InstancePrimvars {
            name: "/instancer".into(),
            rows: 2,
            primvars: vec![row("tint", vec![0.0, 0.0, 0.0, 0.4, 0.5, 0.6], 3), row("heat", vec![8.0, 9.0], 1), row("mood", vec![3.0, 4.0], 1)],
        });
        let w2 = World::build(&s2, &RenderSettings::default(), &mut Vec::new());
        let ray = Ray { o: Vec3::new(0.25, 3.0, 0.5), d: -Vec3::Y, t_max: f32::INFINITY, time: 0.0 };
        let sh2 = w2.surface(&ray, &w2.accel.intersect(&ray).expect("a hit"));
        assert_eq!(w2.primvar(&sh2, "tint"), Some([0.4, 0.5, 0.6, 0.0]));
        assert!((w2.primvar(&sh2, "heat").unwrap()[0] - 1.25).abs() < 1e-5);
        assert_eq!(w2.primvar(&sh2, "mood").map(|v| v[0]), Some(4.0));
        // each sphere has its own value
        let sh = at(Vec3::new(20.0, 5.0, 0.0), -Vec3::Y);
        assert_eq!(w.primvar(&sh, "heat").map(|v| v[0]), Some(7.0));
        let sh = at(Vec3::new(10.0, 5.0, 0.0), -Vec3::Y);
        assert_eq!(w.primvar(&sh, "heat").map(|v| v[0]), Some(5.0));
    }

    /// A mesh light's links reach each of its triangle lights; other lights keep theirs.
    #[test]
    fn a_mesh_lights_links_reach_its_triangles() {
        let mut s = SceneDesc::default();
        s.meshes.push(MeshDesc { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Z, Vec3::new(1.0, 0.0, 1.0)], indices: vec![0, 1, 2, 1, 3, 2], ..Default::default() }.into());
        s.materials.push(MaterialDesc { name: "/glow".into(), surface: SurfaceDesc::Emissive { radiance: [1.0; 3], two_sided: true }, interior_medium: None });
        for (name, y) in [("/glow", 2.0), ("/a", 0.0), ("/b", -1.0), ("/plain", 5.0)] {
            s.instances_mut().push(InstanceDesc { name: name.into(), ..inst(GeometryRef::Mesh(0), Mat4::from_translation(Vec3::Y * y), 0) });
        }
        s.emitter_links.push(EmitterLinks { instance: "/glow".into(), light_link: Some(vec!["/a".into()]), shadow_link: Some(vec!["/b".into()]) });
        let w = World::build(&s, &RenderSettings::default(), &mut Vec::new());
        // every instance's two triangles are lights; those of /glow carry its links
        assert_eq!(w.triangle_lights.len(), 8);
        for (&(ii, _), &li) in &w.triangle_lights {
            let linked = ii == 0;
            assert_eq!((w.illuminates(li, 1), w.illuminates(li, 2)), (true, !linked), "instance {ii}");
            assert_eq!((w.casts_shadow_of(li, 1), w.casts_shadow_of(li, 2)), (!linked, true), "instance {ii}");
        }
    }

    #[test]
    fn emission_from_a_primvar_a_texture_or_a_graph_is_sampled_as_the_surface_glows() {
        // a quad facing down (-Y) whose glow rises from 0 at x = 0 to (1, 0.5, 0.25) at x = 2,
        // or shows a 2 x 2 texture (uv = (x, z) / 2), or a graph of both, of the texture read
        // through a second uv set, of u, of the position and of the interpolated normal
        let mut m = MeshDesc { name: "/glow".into(), ..Default::default() };
        m.positions = vec![Vec3::new(0.0, 1.0, 0.0), Vec3::new(2.0, 1.0, 0.0), Vec3::new(2.0, 1.0, 2.0), Vec3::new(0.0, 1.0, 2.0)];
        m.indices = vec![0, 1, 2, 0, 2, 3];
        m.uvs = Some(m.positions.iter().map(|p| Vec2::new(p.x, p.z) / 2.0).collect());
        // authored normals leaning apart, so that the interpolated normal is not the face's
        m.normals = Some(m.positions.iter().map(|p| Vec3::new(0.5 * (p.x - 1.0), -1.0, 0.3 * (p.z - 1.0)).normalize()).collect());
        let hot = [1.0, 0.5, 0.25];
        m.primvars = vec![
            PrimvarData { name: "glow".into(), tuple: 3, constant: false, data: [[0.0; 3], hot, hot, [0.0; 3]].concat() },
            PrimvarData { name: "st1".into(), tuple: 2, constant: false, data: m.positions.iter().flat_map(|p| [p.z / 2.0, 1.0 - p.x / 2.0]).collect() },
        ];
        let texture = TextureDesc { name: "t".into(), width: 2, height: 2, channels: 3, pixels: vec![0.9, 0.1, 0.1, 0.1, 0.9, 0.1, 0.1, 0.1, 0.9, 0.5, 0.5, 0.5].into(), wrap_s: Wrap::Clamp, wrap_t: Wrap::Clamp, filter: crate::scene::Filter::Linear };
        let lookup = TexLookup { texture: 0, channel: Channel::Rgb, transform: glam::Affine2::IDENTITY, tex_scale: [1.0; 4], bias: [0.0; 4], fallback: [0.0; 4], uv_set: None };
        let tinted = PrimvarLookup { scale: [0.5, 2.0, 1.0, 1.0], ..PrimvarLookup::new("glow", [0.0; 4]) };
        use crate::shader_graph::{Binary, Expr};
        let through_st1 = TexLookup { uv_set: Some(PrimvarLookup::new("st1", [0.0; 4])), ..lookup.clone() };
        let graph = Expr::binary(
            Binary::Add,
            Expr::binary(Binary::Mul, Expr::Texture(lookup.clone()), Expr::Primvar(tinted.clone())),
            Expr::binary(Binary::Mul, Expr::Texture(through_st1), Expr::Primvar(PrimvarLookup::new("absent", [0.5; 4]))),
        );
        // and the texture coordinates' u, the object-space x and the world's z
        let graph = Expr::binary(Binary::Add, graph, Expr::splat(Expr::TexCoord, 0));
        let graph = Expr::binary(Binary::Add, graph, Expr::splat(Expr::Position { world: false }, 0));
        let graph = Expr::binary(Binary::Add, graph, Expr::splat(Expr::Position { world: true }, 2));
        // and the normal's x in the world and z in the object's space, made positive
        let graph = Expr::binary(Binary::Add, graph, Expr::splat(Expr::Normal { world: true }, 0));
        let graph = Expr::binary(Binary::Add, graph, Expr::splat(Expr::Normal { world: false }, 2));
        let graph = Expr::binary(Binary::Add, graph, Expr::Const([2.0; 4]));
        for glow in [ColorInput::Primvar(tinted), ColorInput::Texture(lookup), ColorInput::Graph(graph)] {
            let mut s = SceneDesc::default();
            s.meshes.push(m.clone().into());
            s.textures.push(texture.clone());
            let preview = PreviewSurfaceDesc { diffuse_color: ColorInput::Const([0.0; 3]), emissive_color: glow.clone(), ..Default::default() };
            s.materials.push(MaterialDesc { name: "/m".into(), surface: SurfaceDesc::Preview(preview), interior_medium: None });
            s.instances_mut().push(inst(GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
            let w = World::build(&s, &RenderSettings::default(), &mut Vec::new());
            assert_eq!(w.triangle_lights.len(), 2, "both triangles are lights: {glow:?}");
            let lambda = SampledWavelengths::sample_uniform(0.37);
            let mut rng = crate::testing::chi2::TestRng::new(7);
            for &li in w.triangle_lights.values() {
                for _ in 0..50 {
                    let ctx = crate::light::LightSampleContext::new(Vec3::new(1.0, 0.0, 1.0), Vec3::Y);
                    let Some(ls) = w.lights[li].sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lambda) else { continue };
                    // the surface there, found by tracing to it, glows as the light says
                    let ray = Ray { o: ctx.p, d: ls.wi, t_max: f32::INFINITY, time: 0.0 };
                    let hit = w.accel.intersect(&ray).expect("the light's point");
                    let sh = w.surface(&ray, &hit);
                    assert!((sh.p - ls.p_light).length() < 1e-4);
                    let shown = w.emitted(0, &sh, -ls.wi, &lambda, false);
                    for k in 0..4 {
                        assert!((shown.0[k] - ls.l.0[k]).abs() <= 1e-4 * shown.0[k].max(1.0), "{glow:?}: {shown:?} vs {:?}", ls.l);
                    }
                }
            }
        }
    }
}
