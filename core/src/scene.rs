//! The scene as plain data: what the delegate hands the core. Nothing here knows USD; every
//! array is already flattened (triangulated, primvars expanded per vertex), every transform is
//! a world matrix. [`SceneDesc::validate`] rejects bad input with a message naming the item.

use glam::{Mat4, Vec2, Vec3};
use std::sync::Arc;

/// An RGB triple in the scene's working colour space (linear).
pub type Rgb = [f32; 3];

/// A spectrum as the scene states it.
#[derive(Clone, Debug, PartialEq)]
pub enum SpectrumDesc {
    /// Reflectance-like (bounded) or coefficient RGB, uplifted to a smooth spectrum.
    Rgb(Rgb),
    /// Tabulated samples (nm, value), linearly interpolated, clamped at the ends.
    Tabulated { lambda: Vec<f32>, value: Vec<f32> },
}

/// A texture's pixels, already decoded (the bridge reads files with OpenImageIO).
#[derive(Clone, Debug, PartialEq)]
pub struct TextureDesc {
    pub name: String,
    pub width: u32,
    pub height: u32,
    /// 1, 3 or 4 channels, row-major, first row at the top of the image (v = 1).
    pub channels: u32,
    /// Linear values (colour textures are linearised by the bridge), as floats or as 8-bit
    /// codes with a value per code. Shared: a scene and the copies made of it (validation,
    /// each render job) hold one set of pixels.
    pub pixels: crate::texture::Texels,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    pub filter: Filter,
}

/// How a lookup between texel centres reads the texels (MaterialX `filtertype`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
pub enum Filter {
    /// Bilinear between the four nearest texels.
    #[default]
    Linear,
    /// The texel the coordinates fall in (`closest`: pixel art, masks, ids).
    Closest,
    /// The uniform cubic B-spline over the 4×4 nearest texels (`cubic`, as OpenImageIO's and
    /// OSL's bicubic lookups): smooth (continuous slopes, which bilinear lookups of a height
    /// map lack), reproducing constant and linear ramps, and blurring a texel into its
    /// neighbours (weights 1/6, 4/6, 1/6 at a texel's centre).
    Cubic,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Wrap {
    #[default]
    Repeat,
    Mirror,
    Clamp,
    /// Outside [0,1] the texture reads black (UsdUVTexture's `black`; bilinear filtering
    /// blends it into the outer half texel).
    Black,
    /// Outside [0,1] a lookup gives its fallback (MaterialX's `constant` address mode: the
    /// node's `default`); inside, the edge texels are held as by `Clamp`.
    Default,
}

/// Which part of a texture feeds an input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Channel {
    Rgb,
    R,
    G,
    B,
    A,
}

/// A texture lookup as UsdUVTexture + UsdTransform2d + UsdPrimvarReader describe it.
#[derive(Clone, Debug, PartialEq)]
pub struct TexLookup {
    pub texture: usize,
    pub channel: Channel,
    /// The texture coordinates' transform, uv' = transform(uv): UsdTransform2d (scale, then
    /// rotation, then translation), or any affine map a MaterialX graph makes of them.
    pub transform: glam::Affine2,
    /// value = texel · tex_scale + bias (UsdUVTexture `scale`, `bias`; the first 3 of rgba).
    pub tex_scale: [f32; 4],
    pub bias: [f32; 4],
    /// Value outside the texture for `Wrap::Black` and when the file could not be read.
    pub fallback: [f32; 4],
    /// The texture coordinates: the geometry's `uvs` (None), or another primvar of two
    /// components that a UsdPrimvarReader names (its fallback where the geometry lacks it).
    pub uv_set: Option<PrimvarLookup>,
}

/// A value read from the shaded geometry's primvar (UsdPrimvarReader_*): its components
/// (a one-component primvar fills three), or `fallback` where the geometry has no such primvar,
/// times `scale`.
#[derive(Clone, Debug, PartialEq)]
pub struct PrimvarLookup {
    pub name: String,
    pub fallback: [f32; 4],
    /// Multiplies the value (the primvar's or the fallback), per component: a weight or a tint
    /// applied to the reader's output.
    pub scale: [f32; 4],
}

impl PrimvarLookup {
    /// A lookup of primvar `name`, unscaled.
    pub fn new(name: impl Into<String>, fallback: [f32; 4]) -> Self {
        PrimvarLookup { name: name.into(), fallback, scale: [1.0; 4] }
    }
}

/// A primvar carried to shading: `tuple` floats per element, one element for the whole
/// geometry (`constant`) or one per vertex of a mesh / per point of a sphere set.
#[derive(Clone, Debug, PartialEq)]
pub struct PrimvarData {
    pub name: String,
    pub tuple: u32,
    pub constant: bool,
    pub data: Vec<f32>,
}

impl PrimvarData {
    /// Element `i` (element 0 when constant), components beyond `tuple` zero and a
    /// one-component value repeated into the first three.
    #[inline]
    pub fn element(&self, i: usize) -> [f32; 4] {
        let t = self.tuple as usize;
        let i = if self.constant { 0 } else { i };
        let mut out = [0.0; 4];
        match self.data.get(i * t..i * t + t) {
            Some([v]) => out = [*v, *v, *v, 0.0],
            Some(d) => out[..t.min(4)].copy_from_slice(&d[..t.min(4)]),
            None => {}
        }
        out
    }
}

/// A colour input: constant or textured.
#[derive(Clone, Debug, PartialEq)]
pub enum ColorInput {
    Const(Rgb),
    Texture(TexLookup),
    Primvar(PrimvarLookup),
    /// Arithmetic over lookups (its first three components).
    Graph(crate::shader_graph::Expr),
}

impl ColorInput {
    /// The input times `s`, per channel: a constant's value, a texture's scale and bias, a
    /// primvar's scale, or a graph's result.
    pub fn scaled(self, s: Rgb) -> ColorInput {
        match self {
            ColorInput::Const(c) => ColorInput::Const(std::array::from_fn(|k| c[k] * s[k])),
            ColorInput::Texture(mut t) => {
                for k in 0..3 {
                    t.tex_scale[k] *= s[k];
                    t.bias[k] *= s[k];
                }
                ColorInput::Texture(t)
            }
            ColorInput::Primvar(mut l) => {
                for k in 0..3 {
                    l.scale[k] *= s[k];
                }
                ColorInput::Primvar(l)
            }
            ColorInput::Graph(e) => {
                use crate::shader_graph::{Binary, Expr};
                ColorInput::Graph(Expr::binary(Binary::Mul, e, Expr::Const([s[0], s[1], s[2], 1.0])))
            }
        }
    }
}

/// A scalar input: constant or textured.
#[derive(Clone, Debug, PartialEq)]
pub enum FloatInput {
    Const(f32),
    Texture(TexLookup),
    /// The primvar's first component.
    Primvar(PrimvarLookup),
    /// Arithmetic over lookups (its first component).
    Graph(crate::shader_graph::Expr),
}

/// UsdPreviewSurface, every input.
#[derive(Clone, Debug, PartialEq)]
pub struct PreviewSurfaceDesc {
    pub diffuse_color: ColorInput,
    pub emissive_color: ColorInput,
    pub use_specular_workflow: bool,
    pub specular_color: ColorInput,
    pub metallic: FloatInput,
    pub roughness: FloatInput,
    pub clearcoat: FloatInput,
    pub clearcoat_roughness: FloatInput,
    pub opacity: FloatInput,
    /// > 0: cut-out (opacity below it is fully transparent, above fully opaque).
    pub opacity_threshold: f32,
    pub ior: f32,
    /// Tangent-space normal (UsdPreviewSurface `normal`, in [−1, 1]: a texture's values
    /// remapped by its scale and bias upstream), from a texture, a primvar, a node graph or a
    /// constant; None: the surface's own normal.
    pub normal: Option<ColorInput>,
    /// A thin water film over the surface (the material's `TideWetAPI`).
    pub wet: Option<WetDesc>,
    /// The inputs of a MaterialX PBR surface beyond UsdPreviewSurface's (None: all neutral).
    pub extras: Option<Box<PbrExtras>>,
}

/// The inputs of a MaterialX PBR surface (Standard Surface, OpenPBR) that UsdPreviewSurface
/// lacks; [`Default`] is neutral (see [`crate::bsdf::preview`] for how they render).
#[derive(Clone, Debug, PartialEq)]
pub struct PbrExtras {
    /// Weight of the dielectric specular reflection, 0–1.
    pub specular_weight: FloatInput,
    /// Tint of the dielectric specular reflection.
    pub specular_tint: ColorInput,
    /// Colour the coat gives whatever lies under it.
    pub coat_color: ColorInput,
    /// IOR of the coat.
    pub coat_ior: f32,
    /// The coat's anisotropy, 0–1, along the specular's tangent.
    pub coat_anisotropy: FloatInput,
    /// OpenPBR's coat darkening, 0–1, and the base albedo it is estimated from.
    pub coat_darkening: FloatInput,
    pub darkening_albedo: ColorInput,
    /// Specular anisotropy, 0–1, and how it maps to the two roughnesses.
    pub anisotropy: FloatInput,
    pub flavour: crate::bsdf::PbrFlavour,
    /// Turn of the anisotropy's tangent about the normal, in revolutions (Standard Surface's
    /// `specular_rotation`); 0 is the direction of increasing u.
    pub anisotropy_rotation: FloatInput,
    /// Roughness of the diffuse base, 0–1 (Oren–Nayar; 0 is Lambertian).
    pub diffuse_roughness: FloatInput,
    /// The sheen (Standard Surface `sheen`, OpenPBR `fuzz`): weight 0–1, colour, roughness.
    pub sheen_weight: FloatInput,
    pub sheen_color: ColorInput,
    pub sheen_roughness: FloatInput,
    /// A thin film over the specular layer: its weight 0–1, its thickness in units of
    /// `thin_film_unit_nm` nanometres (1 for Standard Surface's nanometres, 1000 for OpenPBR's
    /// micrometres), its IOR.
    pub thin_film_weight: FloatInput,
    pub thin_film_thickness: FloatInput,
    pub thin_film_unit_nm: f32,
    pub thin_film_ior: f32,
    /// A thin wall's transmitting base (None: the base only reflects).
    pub thin_walled: Option<ThinWalledDesc>,
}

/// The base of a thin wall (see [`crate::bsdf::preview::ThinWalled`]): the share that passes
/// straight through and its tint, and of the rest the translucent share, which reflects and
/// transmits diffusely.
#[derive(Clone, Debug, PartialEq)]
pub struct ThinWalledDesc {
    pub transmission: FloatInput,
    pub tint: ColorInput,
    pub subsurface: FloatInput,
    pub reflect: ColorInput,
    pub transmit: ColorInput,
}

impl Default for PbrExtras {
    fn default() -> Self {
        PbrExtras {
            specular_weight: FloatInput::Const(1.0),
            specular_tint: ColorInput::Const([1.0; 3]),
            coat_color: ColorInput::Const([1.0; 3]),
            coat_ior: crate::bsdf::preview::CLEARCOAT_IOR,
            coat_anisotropy: FloatInput::Const(0.0),
            coat_darkening: FloatInput::Const(0.0),
            darkening_albedo: ColorInput::Const([0.0; 3]),
            anisotropy: FloatInput::Const(0.0),
            flavour: crate::bsdf::PbrFlavour::StandardSurface,
            anisotropy_rotation: FloatInput::Const(0.0),
            diffuse_roughness: FloatInput::Const(0.0),
            sheen_weight: FloatInput::Const(0.0),
            sheen_color: ColorInput::Const([1.0; 3]),
            sheen_roughness: FloatInput::Const(0.3),
            thin_film_weight: FloatInput::Const(0.0),
            thin_film_thickness: FloatInput::Const(0.0),
            thin_film_unit_nm: 1.0,
            thin_film_ior: 1.5,
            thin_walled: None,
        }
    }
}

/// Wetness (contract §3, `TideWetAPI`): a thin smooth water film over the surface response.
#[derive(Clone, Debug, PartialEq)]
pub struct WetDesc {
    /// Wet fraction of the surface, 0–1: constant, or a mask (a texture or a primvar).
    pub amount: FloatInput,
    /// Index of the film.
    pub ior: f32,
    /// Brighten instead of darken when the surface sits inside geometric water.
    pub water_compliant: bool,
}

impl Default for WetDesc {
    fn default() -> Self {
        WetDesc { amount: FloatInput::Const(0.0), ior: 1.333, water_compliant: true }
    }
}

impl Default for PreviewSurfaceDesc {
    fn default() -> Self {
        PreviewSurfaceDesc {
            diffuse_color: ColorInput::Const([0.18; 3]),
            emissive_color: ColorInput::Const([0.0; 3]),
            use_specular_workflow: false,
            specular_color: ColorInput::Const([0.0; 3]),
            metallic: FloatInput::Const(0.0),
            roughness: FloatInput::Const(0.5),
            clearcoat: FloatInput::Const(0.0),
            clearcoat_roughness: FloatInput::Const(0.01),
            opacity: FloatInput::Const(1.0),
            opacity_threshold: 0.0,
            ior: 1.5,
            normal: None,
            wet: None,
            extras: None,
        }
    }
}

/// Surface model of a TideWater interface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum SurfaceModel {
    #[default]
    Dielectric,
    Sea,
}

/// TideWater (contract §3): a dielectric interface, optionally dispersive.
#[derive(Clone, Debug, PartialEq)]
pub struct WaterDesc {
    pub ior: f32,
    pub dispersion: bool,
    /// A glass's dispersion: its Abbe number, n(λ) then Cauchy's through `ior` at 587.56 nm
    /// ([`crate::water::abbe_spectrum`]; MaterialX's transmission dispersion). Unused with
    /// `dispersion` (Quan–Fry); None: `ior` at every wavelength.
    pub abbe: Option<f32>,
    pub temperature: f32,
    pub salinity: f32,
    pub roughness: f32,
    pub surface_model: SurfaceModel,
    pub wind_speed: f32,
    pub wind_direction: f32,
    /// Share of the Cox–Munk slope variance the `sea` facets carry (1 for a flat interface;
    /// less on a wave mesh that resolves the rest, e.g. a `TideOcean`).
    pub slope_variance_scale: f32,
    pub priority: i32,
    /// Colour each transmission through the interface multiplies the light by, in and out (a
    /// surface tint, as MaterialX's `transmission_color` with no depth); None: clear.
    pub tint: Option<ColorInput>,
    /// An opaque surface sharing the interface (None: the interface alone); see [`WaterBlend`].
    pub blend: Option<Box<WaterBlend>>,
}

/// A dielectric interface over part of a surface: the interface takes the share `transmission`
/// (0–1) and `surface` the rest, under one specular reflection (a MaterialX surface's partial
/// transmission or partial subsurface). The object is still a body the interface bounds.
#[derive(Clone, Debug, PartialEq)]
pub struct WaterBlend {
    pub transmission: FloatInput,
    pub surface: PreviewSurfaceDesc,
}

impl Default for WaterDesc {
    fn default() -> Self {
        WaterDesc {
            ior: 1.333,
            dispersion: false,
            abbe: None,
            temperature: 20.0,
            salinity: 0.0,
            roughness: 0.0,
            surface_model: SurfaceModel::Dielectric,
            wind_speed: 5.0,
            wind_direction: 0.0,
            slope_variance_scale: 1.0,
            priority: 0,
            tint: None,
            blend: None,
        }
    }
}

/// What a surface does to light.
#[derive(Clone, Debug, PartialEq)]
pub enum SurfaceDesc {
    /// Lambertian reflector.
    Diffuse { color: ColorInput },
    /// UsdPreviewSurface.
    Preview(PreviewSurfaceDesc),
    /// TideWater, or any clear dielectric.
    Water(WaterDesc),
    /// GGX conductor with complex IOR (per RGB, uplifted).
    Conductor { eta: Rgb, k: Rgb, roughness: f32 },
    /// Emits `radiance` (RGB, uplifted as an illuminant) on the front side, black otherwise.
    Emissive { radiance: Rgb, two_sided: bool },
}

/// A material: a surface plus the medium inside the closed object it is bound to.
#[derive(Clone, Debug, PartialEq)]
pub struct MaterialDesc {
    pub name: String,
    pub surface: SurfaceDesc,
    /// Index into `SceneDesc::media`: what fills the object's interior.
    pub interior_medium: Option<usize>,
}

/// Phase function of a medium.
#[derive(Clone, Debug, PartialEq)]
pub enum PhaseDesc {
    Isotropic,
    HenyeyGreenstein { g: f32 },
    /// w·HG(g1) + (1−w)·HG(g2).
    DualHg { g1: f32, g2: f32, w: f32 },
    /// A measured or modelled p(θ) (Fournier–Forand, Petzold, mixtures with the molecular
    /// function): nodes (θ in radians ∈ [0, π], value ≥ 0) in any order, values proportional
    /// to the density (normalised on use), linear in cosθ between nodes and held beyond the
    /// first and last node.
    Tabulated { theta: Vec<f32>, value: Vec<f32> },
}

/// A Jerlov water type and the published table its IOPs come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JerlovDesc {
    pub water_type: crate::water::JerlovType,
    pub source: crate::water::JerlovSource,
}

/// A Gaussian depth profile added to a concentration: peak·exp(−(z − depth)²/(2·width²)),
/// z in metres below the water's top.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DepthProfileDesc {
    pub depth: f32,
    /// σ of the Gaussian, m (0 = no profile).
    pub width: f32,
    /// Added concentration at `depth`, in the unit of the constituent it shapes (mg m⁻³ for
    /// chlorophyll, g m⁻³ for CDOM and SPM).
    pub peak: f32,
}

/// Spectral, depth-dependent coefficients of natural water: the `TideMedium` inputs
/// `jerlovType`, `jerlovSource`, `chlorophyll`, `cdom`, `spm` and `profileDepth/Width/Peak`.
///
/// The water's σa(λ, z), σs(λ, z) (m⁻¹) are a Jerlov type's IOPs when `jerlov` is set, pure
/// seawater (Buiteveld absorption, Morel scattering at `salinity`) otherwise, plus the
/// bio-optical constituents (see `water::bio`); the profile applies to chlorophyll where the
/// water holds chlorophyll or nothing, else to the CDOM and SPM it holds (see
/// [`crate::water::profiled`]). Both are
/// added to the medium's `sigma_a` / `sigma_s` and the sum is multiplied by `scale`.
///
/// Depth z is measured down the scene's up direction `up` (+Y, or +Z on a Z-up stage) from
/// the height `top`: z = top − p·up. With `top` unset the world builder uses the highest
/// point (largest p·up), at shutter open, of every object whose material is filled with this
/// medium (0 when no object is).
#[derive(Clone, Debug, PartialEq)]
pub struct WaterIopDesc {
    pub jerlov: Option<JerlovDesc>,
    /// Chlorophyll-a, mg m⁻³.
    pub chlorophyll: f32,
    /// Coloured dissolved organic matter, g m⁻³.
    pub cdom: f32,
    /// Suspended particulate matter, g m⁻³.
    pub spm: f32,
    /// The Gaussian depth profile of the constituents (`profileDepth/Width/Peak`).
    pub profile: Option<DepthProfileDesc>,
    /// PSU, for pure-seawater scattering (the enclosing `TideWater.salinity`).
    pub salinity: f32,
    /// Height (along `up`) of depth 0; None: from the bounds of the water bodies (see above).
    pub top: Option<f32>,
    /// The scene's up direction, a unit vector: depth is measured down it (+Y; +Z on a Z-up
    /// stage).
    pub up: Vec3,
}

impl Default for WaterIopDesc {
    fn default() -> Self {
        WaterIopDesc { jerlov: None, chlorophyll: 0.0, cdom: 0.0, spm: 0.0, profile: None, salinity: 0.0, top: None, up: Vec3::Y }
    }
}

/// A participating medium (coefficients in 1/m, i.e. per scene unit): homogeneous from
/// `sigma_a`/`sigma_s`, or depth-varying when `water` adds natural-water IOPs.
#[derive(Clone, Debug, PartialEq)]
pub struct MediumDesc {
    pub name: String,
    pub sigma_a: SpectrumDesc,
    pub sigma_s: SpectrumDesc,
    pub scale: f32,
    pub phase: PhaseDesc,
    pub water: Option<WaterIopDesc>,
    /// How light inside bodies filled with this medium is rendered.
    pub method: MediumMethod,
}

/// How a medium is rendered (`TideMedium.method`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum MediumMethod {
    /// Volumetric path tracing (exact; the reference).
    #[default]
    Volumetric,
    /// A dipole BSSRDF (the classical one; the directional dipole selectable in code) over
    /// cached surface irradiance (`crate::diffusion`): fast for optically thick, highly
    /// scattering bodies.
    Diffusion,
}

/// A triangle mesh, already triangulated and with primvars expanded per vertex.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshDesc {
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Three indices per triangle, counter-clockwise seen from the front (right-handed).
    pub indices: Vec<u32>,
    /// The authored element each triangle comes from (the face of a polygon mesh, the curve of
    /// a curves prim), one per triangle: what the `elementId` AOV reads. Empty where each
    /// triangle is its own element (a mesh authored as triangles, a shape Tide tessellates).
    pub faces: Vec<u32>,
    /// Per-vertex shading normals (same length as `positions`), or none for flat shading.
    pub normals: Option<Vec<Vec3>>,
    /// Per-vertex texture coordinates.
    pub uvs: Option<Vec<Vec2>>,
    /// The primvar `uvs` was read from (`st`, `st0` or `uv`): a primvar reader of that name
    /// reads `uvs`. None for coordinates made by Tide (implicit shapes, curves), which answer
    /// every one of [`UV_PRIMVAR_NAMES`].
    pub uv_name: Option<String>,
    /// Other primvars, per vertex or constant, for materials that read them.
    pub primvars: Vec<PrimvarData>,
    /// Rendered from both sides (affects only the facing test of one-sided emitters/culling).
    pub double_sided: bool,
    /// Deformation motion blur: vertex positions (and normals) at several times. `positions`
    /// and `normals` above stay the pose at time 0 (used where a single pose is needed:
    /// emissive triangles, the water's top).
    pub motion: Option<MeshMotion>,
    /// The point of the geometry's own space that `positions` (and the motion keys) are
    /// measured from; zero for geometry as authored. A front end moves geometry authored far
    /// from its own origin back about it ([`recentring_shift`]), and its instances' transforms
    /// by as much the other way, so that rays meet it in small numbers; object-space shading
    /// (a graph's object `position`, displacement) adds this back.
    pub origin: Vec3,
}

/// A per-vertex primvar of a mesh carrying a `sea` water material: the share of the Cox–Munk
/// slope variance the sea BSDF's facets take there, in place of the material's
/// `slope_variance_scale` (a `TideOcean` mesh carries, at each vertex, what its tile's level
/// leaves unresolved).
pub const SEA_SHARE_PRIMVAR: &str = "tide:ocean:slopeVarianceShare";

/// The primvar names texture coordinates are looked for under, in order.
pub const UV_PRIMVAR_NAMES: [&str; 3] = ["st", "st0", "uv"];

/// The shift that moves geometry bounded by `lo`–`hi` back about its own origin: the bounds'
/// centre where it lies further out along some axis than [`RECENTRE_FACTOR`] times the bounds'
/// half-size along any (geometry authored far from its origin, whose coordinates would spend
/// four or more bits of precision on the distance), else zero (geometry about its origin keeps
/// its numbers).
pub fn recentring_shift(lo: Vec3, hi: Vec3) -> Vec3 {
    let (c, half) = ((lo + hi) * 0.5, (hi - lo) * 0.5);
    match c.is_finite() && half.is_finite() && c.abs().max_element() > RECENTRE_FACTOR * half.max_element() {
        true => c,
        false => Vec3::ZERO,
    }
}

/// How many times its own half-size geometry must lie from its origin to be moved back about
/// it ([`recentring_shift`]).
pub const RECENTRE_FACTOR: f32 = 16.0;

/// The bounds of points, or None for none.
fn bounds_of<'a>(points: impl Iterator<Item = &'a Vec3>) -> Option<(Vec3, Vec3)> {
    points.fold(None, |b, &p| Some(b.map_or((p, p), |(lo, hi): (Vec3, Vec3)| (lo.min(p), hi.max(p)))))
}

impl MeshDesc {
    /// Moves the mesh back about its own origin when it lies far from it
    /// ([`recentring_shift`] of its positions over every motion key), adding the shift to
    /// [`MeshDesc::origin`]; returns the shift (zero: nothing changed). Each difference is one
    /// rounding, so vertices equal before stay equal.
    pub fn recentre(&mut self) -> Vec3 {
        let shift = self.recentring();
        self.shift_origin(shift);
        shift
    }

    /// Measures the positions (and motion keys) from `shift` further along, adding it to
    /// [`MeshDesc::origin`]: what [`MeshDesc::recentre`] does with [`MeshDesc::recentring`]'s.
    pub fn shift_origin(&mut self, shift: Vec3) {
        if shift != Vec3::ZERO {
            self.positions.iter_mut().for_each(|p| *p -= shift);
            for key in self.motion.iter_mut().flat_map(|m| m.positions.iter_mut()) {
                key.iter_mut().for_each(|p| *p -= shift);
            }
            self.origin += shift;
        }
    }

    /// The shift [`MeshDesc::recentre`] would make.
    pub fn recentring(&self) -> Vec3 {
        let keys = self.motion.iter().flat_map(|m| m.positions.iter().flatten());
        bounds_of(self.positions.iter().chain(keys)).map_or(Vec3::ZERO, |(lo, hi)| recentring_shift(lo, hi))
    }

    /// Whether a primvar reader of `name` reads this mesh's own texture coordinates.
    pub fn uvs_answer(&self, name: &str) -> bool {
        self.uvs.is_some()
            && match &self.uv_name {
                Some(n) => n == name,
                None => UV_PRIMVAR_NAMES.contains(&name),
            }
    }
}

/// The keys of a deforming mesh: the same vertices (and triangles) at increasing times. A
/// vertex moves linearly between keys and holds the first / last key outside them.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshMotion {
    /// Seconds of shutter time (as `InstanceDesc::times`), increasing, two or more.
    pub times: Vec<f32>,
    /// One array per time, each as long as `MeshDesc::positions`.
    pub positions: Vec<Vec<Vec3>>,
    /// Per-vertex shading normals per time (same shape as `positions`), when the mesh has them.
    pub normals: Option<Vec<Vec<Vec3>>>,
}

impl MeshMotion {
    /// Key segment and weight of the later key at `time`: values are
    /// `key[i]·(1−w) + key[i+1]·w`.
    #[inline]
    pub fn locate(&self, time: f32) -> (usize, f32) {
        locate_key(&self.times, time)
    }
}

/// Key segment of increasing key `times` at `time` and the weight of the later key (values are
/// `key[i]·(1−w) + key[i+1]·w`; held at the first and last keys outside them).
#[inline]
pub fn locate_key(times: &[f32], time: f32) -> (usize, f32) {
    let n = times.len();
    if n < 2 || time <= times[0] {
        return (0, 0.0);
    }
    if time >= times[n - 1] {
        return (n - 2, 1.0);
    }
    // the last key at or before `time` (bisection: thousands of keys are read per ray)
    let i = (times.partition_point(|&t| t <= time) - 1).min(n - 2);
    let (a, b) = (times[i], times[i + 1]);
    (i, if b > a { (time - a) / (b - a) } else { 0.0 })
}

impl MeshDesc {
    /// The authored element of triangle `t` ([`MeshDesc::faces`]).
    #[inline]
    pub fn element_of(&self, t: u32) -> u32 {
        self.faces.get(t as usize).copied().unwrap_or(t)
    }

    /// Position of vertex `k` at `time` (seconds).
    #[inline]
    pub fn position_at(&self, k: usize, time: f32) -> Vec3 {
        match &self.motion {
            Some(m) if m.positions.len() >= 2 => {
                let (i, w) = m.locate(time);
                m.positions[i][k].lerp(m.positions[i + 1][k], w)
            }
            _ => self.positions[k],
        }
    }

    /// Shading normal of vertex `k` at `time` (not normalised), when the mesh has normals.
    #[inline]
    pub fn normal_at(&self, k: usize, time: f32) -> Option<Vec3> {
        match &self.motion {
            Some(m @ MeshMotion { normals: Some(n), .. }) if n.len() >= 2 => {
                let (i, w) = m.locate(time);
                Some(n[i][k].lerp(n[i + 1][k], w))
            }
            _ => self.normals.as_ref().map(|n| n[k]),
        }
    }
}

/// A set of spheres (UsdGeomPoints), optionally moving linearly over the shutter.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SpheresDesc {
    pub name: String,
    pub centers: Vec<Vec3>,
    pub radii: Vec<f32>,
    /// Object-space velocity per point (units per second of shutter time), or none.
    pub velocities: Option<Vec<Vec3>>,
    /// What each point is: a sphere of its radius, a bubble, or a blobby kernel.
    pub shape: PointShape,
    /// Primvars, per point or constant, for materials that read them.
    pub primvars: Vec<PrimvarData>,
    /// The authored index of each point (what the `elementId` AOV reads), where points were
    /// dropped; empty where point i is the authored point i.
    pub ids: Vec<u32>,
    /// As [`MeshDesc::origin`]: where `centers` are measured from in the points' own space.
    pub origin: Vec3,
}

impl SpheresDesc {
    /// As [`MeshDesc::recentre`], for the points' centres (velocities and shapes are relative
    /// to them).
    pub fn recentre(&mut self) -> Vec3 {
        let shift = self.recentring();
        self.shift_origin(shift);
        shift
    }

    /// As [`MeshDesc::shift_origin`], for the centres.
    pub fn shift_origin(&mut self, shift: Vec3) {
        if shift != Vec3::ZERO {
            self.centers.iter_mut().for_each(|p| *p -= shift);
            self.origin += shift;
        }
    }

    /// The authored index of point `i` ([`SpheresDesc::ids`]).
    #[inline]
    pub fn element_of(&self, i: u32) -> u32 {
        self.ids.get(i as usize).copied().unwrap_or(i)
    }

    /// The shift [`SpheresDesc::recentre`] would make.
    pub fn recentring(&self) -> Vec3 {
        bounds_of(self.centers.iter()).map_or(Vec3::ZERO, |(lo, hi)| recentring_shift(lo, hi))
    }
}

/// The shape points take (contract §5). Radii are the points' inner radii (half their widths).
#[derive(Clone, Debug, Default, PartialEq)]
pub enum PointShape {
    #[default]
    Spheres,
    /// `TideBubbleAPI`: per point the height above the equator (h₁) and the depth below it
    /// (h₂), and optionally the bubble's frame (+Y up).
    Bubbles { top: Vec<f32>, bottom: Vec<f32>, orientations: Option<Vec<glam::Quat>> },
    /// `TideBlobbyAPI`: the threshold T of φ = Σψᵢ − T, and optionally per point the frame and
    /// the inner radius' multipliers along its axes.
    Blobby { threshold: f32, orientations: Option<Vec<glam::Quat>>, scales: Option<Vec<Vec3>> },
}

/// What an instance places.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GeometryRef {
    Mesh(usize),
    Spheres(usize),
}

/// One placement of a geometry in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct InstanceDesc {
    /// Name (prim path) used in messages.
    pub name: String,
    pub geometry: GeometryRef,
    /// Object-to-world transforms at `times`, one or more (transform motion blur).
    pub transforms: Vec<Mat4>,
    /// Times (seconds, in shutter time) of `transforms`; same length, increasing.
    pub times: Vec<f32>,
    pub material: usize,
    /// Identifier written to the `primId` AOV.
    pub id: u32,
    pub visible_to_camera: bool,
    pub casts_shadows: bool,
    /// Its own primvar values: (table in [`SceneDesc::instance_primvars`], row).
    pub primvar_row: Option<(u32, u32)>,
    /// Its index among its prim's authored instances (a PointInstancer's or a Hydra
    /// instancer's, in their order), written to the `instanceId` AOV; None for a prim drawn
    /// once.
    pub index: Option<u32>,
}

/// Primvars that vary per instance (a PointInstancer's, or those native instances inherit):
/// each non-constant [`PrimvarData`] holds one element per row. An instance's value comes
/// after its geometry's varying primvar of the same name and before its constant one.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct InstancePrimvars {
    /// Name (the instancing prim's path) used in messages.
    pub name: String,
    pub rows: u32,
    pub primvars: Vec<PrimvarData>,
}

/// A scalar grid (an OpenVDB field): the value `[i, j, k]` sits at the point (i, j, k) of the
/// grid's local space; between points the grid is trilinear and outside the array 0, so it is
/// non-zero only inside the box (−1, dims). The values are held in bricks, those all zero left
/// out, and shared: a grid read once serves every volume and every scene made with it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GridDesc {
    /// Name (file and field) used in messages.
    pub name: String,
    pub values: std::sync::Arc<crate::medium::grid::Bricks>,
    /// How many of the values as read were negative or not finite (held as 0), to report.
    pub bad_values: usize,
    /// Grid-local to world (the field's index-to-object transform, then the prim's).
    pub local_to_world: Mat4,
}

impl GridDesc {
    /// A grid of `dims` values, x fastest.
    pub fn dense(name: String, dims: [u32; 3], values: &[f32], local_to_world: Mat4) -> Result<GridDesc, crate::medium::grid::GridError> {
        let bad_values = values.iter().filter(|x| !x.is_finite() || **x < 0.0).count();
        let values = std::sync::Arc::new(crate::medium::grid::Bricks::from_dense(dims, values)?);
        Ok(GridDesc { name, values, bad_values, local_to_world })
    }
}

/// A volume (`UsdVolVolume`): its `density` grid times the coefficients of a medium fill the
/// grid's box. The world builder gives the box a boundary surface that neither reflects nor
/// refracts: paths cross it and take its medium while inside (see [`crate::volume`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VolumeDesc {
    /// Name (prim path) used in messages.
    pub name: String,
    pub density: GridDesc,
    /// Transform motion blur: the grid's local-to-world (as `density.local_to_world`) at each
    /// time (seconds of shutter time, increasing). Empty, or one key: the volume is still at
    /// `density.local_to_world`; otherwise it moves and `density.local_to_world` is ignored.
    pub motion: Vec<(f32, Mat4)>,
    /// Index into `SceneDesc::media`: the coefficients at density 1 and the phase function.
    pub medium: usize,
    /// Identifier written to the `primId` AOV (unused: a volume has no surface).
    pub id: u32,
    pub visible_to_camera: bool,
    pub casts_shadows: bool,
}

/// Kind of light and its shape (in the light's local frame; USD conventions).
#[derive(Clone, Debug, PartialEq)]
pub enum LightShape {
    /// Shines along local −Z; `angle_deg` is the angular diameter.
    Distant { angle_deg: f32 },
    /// Infinite environment; lat-long texture oriented as UsdLuxDomeLight (+Y up).
    Dome { texture: Option<usize> },
    Sphere { radius: f32, treat_as_point: bool },
    /// In the local XY plane, emitting towards −Z.
    Rect { width: f32, height: f32, texture: Option<usize> },
    /// In the local XY plane, emitting towards −Z.
    Disk { radius: f32 },
    /// Along the local X axis.
    Cylinder { radius: f32, length: f32, treat_as_line: bool },
    /// The Hošek–Wilkie sky dome (`TideSkyAPI`, [`crate::sky`]): zenith along the light's
    /// local +Y (as for a dome's lat-long map), the sun towards `sun_direction` (world space,
    /// at or above the horizon). Emitted radiance = model radiance (W m⁻² sr⁻¹ nm⁻¹) ×
    /// `scale` × `intensity` × 2^`exposure`; `scale` = [`crate::sky::nits_per_model_unit`]
    /// puts the sky's luminance in cd m⁻². `color`, `colorTemperature` and `normalize` are not
    /// used. The sun's disc is not part of the dome (see [`LightShape::SkySun`]).
    Sky { turbidity: f32, ground_albedo: Rgb, sun_direction: Vec3, scale: f32 },
    /// The physical sun of a sky: a distant light along the light's local +Z (as a
    /// `DistantLight`) with the solar disc's angular diameter (0.51°), emitting the disc's mean
    /// spectral radiance for its elevation above the horizon of `zenith` (world) and
    /// `turbidity`, × `scale` × `intensity` × 2^`exposure` (see [`LightShape::Sky`]).
    SkySun { zenith: Vec3, turbidity: f32, scale: f32 },
}

/// `UsdLuxShadowAPI`'s non-physical controls of a light's shadows ([`Default`]: black shadows
/// reaching as far as the light).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowDesc {
    /// `shadow:color`: what the shadowed part of the light keeps (RGB, 0–1).
    pub color: Rgb,
    /// `shadow:distance`: how far from the lit point occluders cast shadows (≤ 0: no limit).
    pub distance: f32,
    /// `shadow:falloff`: the share of that distance, at its far end, over which shadows fade
    /// (≤ 0: none, a hard cut), and `shadow:falloffGamma`, the fade's exponent.
    pub falloff: f32,
    pub falloff_gamma: f32,
}

impl Default for ShadowDesc {
    fn default() -> Self {
        ShadowDesc { color: [0.0; 3], distance: -1.0, falloff: -1.0, falloff_gamma: 1.0 }
    }
}

/// A light as UsdLux states it.
#[derive(Clone, Debug, PartialEq)]
pub struct LightDesc {
    pub name: String,
    pub shape: LightShape,
    /// Light-to-world transform.
    pub transform: Mat4,
    pub color: Rgb,
    pub intensity: f32,
    pub exposure: f32,
    pub normalize: bool,
    /// Kelvin, when `enableColorTemperature` is on.
    pub color_temperature: Option<f32>,
    /// Whether camera rays see the light itself.
    pub visible_to_camera: bool,
    /// Names of the instances the light illuminates (`collection:lightLink`); None: all.
    pub light_link: Option<Vec<String>>,
    /// Names of the instances that cast the light's shadows (`collection:shadowLink`); None:
    /// all (that cast shadows at all).
    pub shadow_link: Option<Vec<String>>,
    /// `UsdLuxShadowAPI`'s non-physical controls: shadow colour, distance and falloff.
    pub shadow: ShadowDesc,
    /// `UsdLuxShapingAPI` (sphere, rect, disk and cylinder lights); None: unshaped.
    pub shaping: Option<ShapingDesc>,
    /// UsdLux's non-physical `diffuse` and `specular` multipliers.
    pub response: LightResponse,
    /// Light-to-world over the shutter as (time in seconds, matrix) keys when the light moves
    /// (empty: it stays at `transform`). Taken as a rigid move of the light from `transform`.
    pub motion: Vec<(f32, Mat4)>,
    /// A dome's (or the sky's) `UsdLuxPortalLight`s, which guide its sampling
    /// ([`crate::light::portal`]); ignored on other lights.
    pub portals: Vec<PortalDesc>,
}

/// A `UsdLuxPortalLight`: the rectangle of `width` × `height` centred in its local XY plane,
/// through which light passes towards its local −Z.
#[derive(Clone, Debug, PartialEq)]
pub struct PortalDesc {
    /// The portal's prim path, for messages.
    pub name: String,
    /// Portal-to-world (where the dome moves, the portal is where it is at `transform`).
    pub transform: Mat4,
    pub width: f32,
    pub height: f32,
}

/// How strongly a light shows in materials' diffuse and specular responses (UsdLux `diffuse`,
/// `specular`; 1 and 1 for physical light). A multiplier applies where the light's emission is
/// gathered: at the surface vertex that receives it (next-event estimation, or a ray sampled
/// from its BSDF that reaches the light), by the lobe that vertex scatters it with (diffuse,
/// or glossy / specular reflection and transmission), so a caustic photon carries the specular
/// one from its first bounce. Light gathered in a medium is not changed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightResponse {
    pub diffuse: f32,
    pub specular: f32,
}

impl Default for LightResponse {
    fn default() -> Self {
        LightResponse { diffuse: 1.0, specular: 1.0 }
    }
}

impl LightResponse {
    /// Whether both multipliers are 1.
    pub fn is_physical(&self) -> bool {
        self.diffuse == 1.0 && self.specular == 1.0
    }
}

/// A light's `UsdLuxShapingAPI` values (see [`crate::light::shaping`]).
#[derive(Clone, Debug, PartialEq)]
pub struct ShapingDesc {
    /// `shaping:cone:angle`, degrees off the light's axis (90 when unauthored; ≥ 180: no cone).
    pub cone_angle_deg: f32,
    /// `shaping:cone:softness`, clamped to [0, 1].
    pub cone_softness: f32,
    /// `shaping:focus` (≤ 0: none).
    pub focus: f32,
    /// `shaping:focusTint`.
    pub focus_tint: Rgb,
    /// `shaping:ies:file`, parsed.
    pub ies: Option<std::sync::Arc<crate::light::ies::IesProfile>>,
    /// `shaping:ies:angleScale` (clipped at −1).
    pub ies_angle_scale: f32,
    /// `shaping:ies:normalize`: divide the profile by its mean intensity.
    pub ies_normalize: bool,
}

impl Default for ShapingDesc {
    /// The schema's fallbacks: a 90° cone with a hard edge, no focus, no profile.
    fn default() -> Self {
        ShapingDesc { cone_angle_deg: 90.0, cone_softness: 0.0, focus: 0.0, focus_tint: [0.0; 3], ies: None, ies_angle_scale: 0.0, ies_normalize: false }
    }
}

/// A spectral filter in front of the camera (`tide:camera:filter`), applied to the radiance
/// before it is converted to colour; see [`crate::camera::filter_transmission`].
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CameraFilter {
    #[default]
    None,
    UnderwaterRed,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Projection {
    #[default]
    Perspective,
    Orthographic,
}

/// A camera as UsdGeomCamera states it (lengths in scene units; apertures and focal length
/// in the same "tenths of a scene unit" USD uses: mm for metre scenes).
#[derive(Clone, Debug, PartialEq)]
pub struct CameraDesc {
    pub name: String,
    /// Camera-to-world at `times` (looks down local −Z, +Y up).
    pub transforms: Vec<Mat4>,
    pub times: Vec<f32>,
    pub projection: Projection,
    pub focal_length: f32,
    pub horizontal_aperture: f32,
    pub vertical_aperture: f32,
    pub horizontal_aperture_offset: f32,
    pub vertical_aperture_offset: f32,
    pub clipping_range: [f32; 2],
    /// UsdGeomCamera `clippingPlanes`: (a, b, c, d) cuts away, from the camera's view, the
    /// camera-space points where a·x + b·y + c·z + d < 0.
    pub clipping_planes: Vec<[f32; 4]>,
    /// 0 = pinhole.
    pub f_stop: f32,
    pub focus_distance: f32,
    pub shutter_open: f32,
    pub shutter_close: f32,
    /// Exposure in stops (multiplies by 2^exposure).
    pub exposure: f32,
    pub exposure_f_stop: f32,
    pub exposure_time: f32,
    pub exposure_iso: f32,
    pub exposure_responsivity: f32,
    /// Index into `SceneDesc::media`: the medium the camera sits in (underwater camera).
    pub medium: Option<usize>,
    pub filter: CameraFilter,
}

impl Default for CameraDesc {
    fn default() -> Self {
        CameraDesc {
            name: "/camera".into(),
            transforms: vec![Mat4::IDENTITY],
            times: vec![0.0],
            projection: Projection::Perspective,
            focal_length: 50.0,
            horizontal_aperture: 20.955,
            vertical_aperture: 15.2908,
            horizontal_aperture_offset: 0.0,
            vertical_aperture_offset: 0.0,
            clipping_range: [1.0, 1_000_000.0],
            clipping_planes: Vec::new(),
            f_stop: 0.0,
            focus_distance: 0.0,
            shutter_open: 0.0,
            shutter_close: 0.0,
            exposure: 0.0,
            exposure_f_stop: 1.0,
            exposure_time: 1.0,
            exposure_iso: 100.0,
            exposure_responsivity: 1.0,
            medium: None,
            filter: CameraFilter::None,
        }
    }
}

/// A linear RGB colour space: of the authored colours ([`AUTHORED_COLOR_SPACE`]) or of the
/// rendering (`SceneDesc::color_space`: the AOVs are written in it).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum ColorSpace {
    #[default]
    LinearRec709,
    AcesCg,
    /// Linear ITU-R BT.2020 (D65); a rendering colour space only.
    LinearRec2020,
}

/// The colour space of every authored colour (UsdPreviewSurface, UsdLux, TideMedium inputs,
/// linear textures): linear Rec.709, USD's default colour space (`lin_rec709_scene`). The
/// rendering colour space changes how the result is written, not what the scene looks like.
pub const AUTHORED_COLOR_SPACE: ColorSpace = ColorSpace::LinearRec709;

/// The links of an instance whose surface is a light (UsdLuxMeshLightAPI), as a light's
/// ([`LightDesc::light_link`], [`LightDesc::shadow_link`]): the instances its emissive
/// triangles light and those that shadow them, by name (None: all).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EmitterLinks {
    /// The instance's name.
    pub instance: String,
    pub light_link: Option<Vec<String>>,
    pub shadow_link: Option<Vec<String>>,
}

/// Everything the renderer needs.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneDesc {
    /// Shared, so that a scene assembled anew around unchanged meshes copies none of them
    /// (and caches recognise them by identity).
    pub meshes: Vec<Arc<MeshDesc>>,
    /// Shared as the meshes are.
    pub spheres: Vec<Arc<SpheresDesc>>,
    /// Shared too: a copy of the scene (the validated scene a render builds from) shares them
    /// until it changes one ([`SceneDesc::instances_mut`]); a million instances are not
    /// copied for nothing.
    pub instances: Arc<Vec<InstanceDesc>>,
    /// Per-instance primvar tables ([`InstanceDesc::primvar_row`]).
    pub instance_primvars: Vec<InstancePrimvars>,
    /// Links of mesh lights (instances absent here light everything).
    pub emitter_links: Vec<EmitterLinks>,
    pub materials: Vec<MaterialDesc>,
    pub media: Vec<MediumDesc>,
    pub textures: Vec<TextureDesc>,
    pub lights: Vec<LightDesc>,
    pub camera: CameraDesc,
    /// The rendering colour space (UsdRenderSettings `renderingColorSpace`) the AOVs are in.
    pub color_space: ColorSpace,
    pub volumes: Vec<VolumeDesc>,
    /// `TideCausticsAPI` tags (contract §4), by light and instance name.
    pub caustics: CausticsTags,
    /// Where this scene's (0, 0, 0) lies in the world: a front end may place everything about
    /// a point near the camera, so that positions stay small in single precision far from the
    /// world's origin. Only what shading reads as a world position (a node graph's world-space
    /// position) adds it back.
    pub origin: glam::DVec3,
}

impl SceneDesc {
    /// The instances to change: the scene's own, copied first if they are shared.
    pub fn instances_mut(&mut self) -> &mut Vec<InstanceDesc> {
        Arc::make_mut(&mut self.instances)
    }
}

/// `tide:caustics:transparency`: which paths pass straight through a surface.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum CausticsTransparency {
    #[default]
    Off,
    /// Transparent to paths after their first non-specular bounce (their shadow rays included).
    AfterDiffuse,
    /// Transparent to paths that scattered in a volume.
    Volume,
    /// Both of the above.
    All,
}

/// `TideCausticsAPI` attributes of one gprim, as authored.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ObjectCaustics {
    /// `tide:caustics:caster` (None: unauthored).
    pub caster: Option<bool>,
    /// `tide:caustics:receiver` (default true).
    pub receiver: bool,
    pub transparency: CausticsTransparency,
}

impl Default for ObjectCaustics {
    fn default() -> Self {
        ObjectCaustics { caster: None, receiver: true, transparency: CausticsTransparency::Off }
    }
}

/// The caustics tags of a scene. Instances are matched by name: a key names the instances
/// called exactly so, and those whose name continues with `[` (instancer copies) or ` `
/// (generated parts such as an ocean's horizon skirt).
///
/// Which lights emit photons and which objects cast caustics (contract §4): when some light is
/// tagged `emitter = true`, exactly the tagged lights emit; otherwise every distant and sphere
/// light does (one-click default) unless tagged `false`. Likewise casters: the objects tagged
/// `caster = true` if any, else every object with a `TideWater` surface not tagged `false`.
/// Objects with a transparency mode other than `off` never cast caustics.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CausticsTags {
    /// (light name, `tide:caustics:emitter`) where authored.
    pub emitters: Vec<(String, bool)>,
    /// (instance name, tags) where any `TideCausticsAPI` attribute is authored.
    pub objects: Vec<(String, ObjectCaustics)>,
}

impl CausticsTags {
    /// Whether instance `name` is named by `key`.
    pub fn name_matches(key: &str, name: &str) -> bool {
        name == key || (name.len() > key.len() && name.starts_with(key) && matches!(name.as_bytes()[key.len()], b'[' | b' '))
    }

    /// The tags of instance `name` (defaults when none are authored).
    pub fn object(&self, name: &str) -> ObjectCaustics {
        self.objects.iter().rev().find(|(k, _)| Self::name_matches(k, name)).map(|(_, o)| *o).unwrap_or_default()
    }

    /// The authored emitter tag of light `name`.
    pub fn emitter(&self, name: &str) -> Option<bool> {
        self.emitters.iter().rev().find(|(k, _)| k == name).map(|(_, e)| *e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn geometry_far_from_its_origin_is_moved_back_about_it() {
        // about its origin, or near it for its size: kept as it is
        assert_eq!(recentring_shift(Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0)), Vec3::ZERO);
        assert_eq!(recentring_shift(Vec3::new(15.0, 0.0, 0.0), Vec3::new(17.0, 2.0, 0.0)), Vec3::ZERO);
        // further than 16 half-sizes along some axis: its centre
        assert_eq!(recentring_shift(Vec3::new(17.0, 0.0, 0.0), Vec3::new(19.0, 2.0, 0.0)), Vec3::new(18.0, 1.0, 0.0));
        assert_eq!(recentring_shift(Vec3::new(0.0, -1e4, 0.0), Vec3::ZERO), Vec3::ZERO);
        assert_eq!(recentring_shift(Vec3::new(f32::NAN, 1e4, 0.0), Vec3::new(0.0, 1e4, 0.0)), Vec3::ZERO);

        // a room's wall 10^4 out, moving over the shutter
        let far = Vec3::new(1.0e4 + 0.37, 2.0, -3.0e4);
        let positions: Vec<Vec3> = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]].map(|p| far + Vec3::from(p)).to_vec();
        let later: Vec<Vec3> = positions.iter().map(|p| *p + Vec3::X * 0.5).collect();
        let mut m = MeshDesc { positions: positions.clone(), indices: vec![0, 1, 2, 0, 2, 3], ..Default::default() };
        m.motion = Some(MeshMotion { times: vec![0.0, 1.0], positions: vec![positions.clone(), later.clone()], normals: None });
        let shift = m.recentre();
        assert_eq!(shift, m.origin);
        assert!((shift - (far + Vec3::new(0.75, 0.5, 0.0))).abs().max_element() < 1e-2, "{shift:?}");
        // each point moved by exactly the shift, rounded once; the keys with it
        for (moved, authored) in m.positions.iter().zip(&positions) {
            assert_eq!(*moved, *authored - shift);
            assert!(((moved.as_dvec3() + shift.as_dvec3()) - authored.as_dvec3()).abs().max_element() < 1e-6);
        }
        let keys = &m.motion.as_ref().unwrap().positions;
        assert_eq!(keys[0], m.positions);
        assert!(keys[1].iter().zip(&later).all(|(k, a)| *k == *a - shift));
        // again: nothing more to do
        assert_eq!(m.recentre(), Vec3::ZERO);
        assert_eq!(m.origin, shift);

        let mut s = SpheresDesc { centers: vec![far, far + Vec3::Y], radii: vec![0.5; 2], ..Default::default() };
        let shift = s.recentre();
        assert_eq!((s.origin, s.centers[0], s.centers[1]), (shift, far - shift, far + Vec3::Y - shift));
        assert!(s.centers.iter().all(|c| c.length() <= 0.5 + 1e-3));
    }
}
