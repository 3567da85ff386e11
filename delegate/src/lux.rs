//! UsdLux lights → [`LightDesc`], UsdGeomCamera → [`CameraDesc`], UsdRenderSettings → the
//! core's [`RenderSettings`] plus the render products and vars as plain data.
//!
//! Camera lengths stay in USD's units (apertures and focal length in tenths of a scene unit),
//! which is the core's convention. Shutter times stay in frames here; the scene assembly turns
//! them (and transform sample times) into seconds with `timeCodesPerSecond`.

use crate::material::{Encoding, TexKey, WrapKey};
use crate::value::{about, AttrStore, Problems};
use glam::{DMat4, DVec3, Mat4, Vec3};
use tide_core::render::MAX_IMAGE_SIDE;
use tide_core::light::dome_format::DomeFormat;
use tide_core::light::ies::IesProfile;
use tide_core::scene::{CameraDesc, CameraFilter, ColorSpace, LightDesc, LightShape, Projection, ShadowDesc, ShapingDesc};
use tide_core::{IntegratorKind, RenderSettings};

/// Light prim types of the protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    Distant,
    Dome,
    Sphere,
    Rect,
    Disk,
    Cylinder,
}

/// A converted light: its texture (if any) is named by key; the assembly resolves it.
#[derive(Clone, Debug, PartialEq)]
pub struct LightPiece {
    pub desc: LightDesc,
    pub texture: Option<TexKey>,
    /// `TideSkyAPI` on a dome: the sun it names; the assembly sets the sky's sun direction.
    pub sky: Option<SkyPiece>,
    /// `collection:lightLink` (None: unauthored, the light illuminates everything).
    pub light_link: Option<Collection>,
    /// `collection:shadowLink` (None: unauthored, everything casts the light's shadows).
    pub shadow_link: Option<Collection>,
    /// `tide:caustics:emitter` where authored (`TideCausticsAPI`).
    pub caustics_emitter: Option<bool>,
    /// The light's light-to-world samples (frame offsets; one at 0 when it does not move): the
    /// assembly keys `desc.motion` from those over the shutter.
    pub transforms: Vec<(f64, DMat4)>,
    /// The light-to-world matrix at the frame (`desc.transform` in double precision: the
    /// assembly places it about the scene's origin).
    pub world: DMat4,
    /// A dome's `portals` relationship: the `portalLight` prims that guide its sampling (None:
    /// unauthored; the assembly then gives it the portals no dome names).
    pub portals: Option<Vec<String>>,
}

/// A `UsdLuxPortalLight`: where it is and its size (see [`tide_core::scene::PortalDesc`]).
#[derive(Clone, Debug, PartialEq)]
pub struct PortalPiece {
    pub transform: DMat4,
    pub width: f32,
    pub height: f32,
}

impl PortalPiece {
    /// The core's description of the portal at `path`, placed about `origin`.
    pub fn desc(&self, path: &str, origin: DVec3) -> tide_core::scene::PortalDesc {
        tide_core::scene::PortalDesc { name: path.into(), transform: about(origin, &self.transform), width: self.width, height: self.height }
    }
}

/// Converts a portal; None (with a problem) for one of zero size, None for an invisible one.
pub fn convert_portal(store: &AttrStore, p: &mut Problems) -> Option<PortalPiece> {
    if store.token_or("visibility", &["inherited", "invisible"], "inherited", p) == "invisible" {
        return None;
    }
    let transform = light_transform(store, p);
    let (width, height) = (nonneg(store, "width", 1.0, p), nonneg(store, "height", 1.0, p));
    if width * height == 0.0 {
        p.add(if width == 0.0 { "width" } else { "height" }, "the portal has zero area; dropped (its dome lights the scene without it)");
        return None;
    }
    Some(PortalPiece { transform, width, height })
}

/// A light's `transform` (identity, reported, when it is not a finite matrix).
fn light_transform(store: &AttrStore, p: &mut Problems) -> DMat4 {
    match store.get("transform") {
        None => DMat4::IDENTITY,
        Some(v) => match v.as_dmatrix() {
            Some(m) if m.is_finite() && m.as_mat4().is_finite() => m,
            _ => {
                p.add("transform", "expected a finite 4x4 matrix; using identity");
                DMat4::IDENTITY
            }
        },
    }
}

/// A UsdCollectionAPI collection of prim paths as the reader sends it
/// (`collection:<name>:includes`, `:excludes`, `:includeRoot`, `:expansionRule`).
#[derive(Clone, Debug, PartialEq)]
pub struct Collection {
    pub includes: Vec<String>,
    pub excludes: Vec<String>,
    pub include_root: bool,
    /// `expansionRule = explicitOnly`: only the paths named, not their descendants.
    pub explicit_only: bool,
}

impl Collection {
    /// Reads collection `name`; None when none of its attributes is present.
    fn read(store: &AttrStore, name: &str, p: &mut Problems) -> Option<Collection> {
        let attr = |a: &str| format!("collection:{name}:{a}");
        let (inc, exc, root) = (attr("includes"), attr("excludes"), attr("includeRoot"));
        if store.get(&inc).is_none() && store.get(&exc).is_none() && store.get(&root).is_none() {
            return None;
        }
        let mut paths = |a: &str| -> Vec<String> {
            let all = store.get(a).and_then(|v| v.to_strings()).unwrap_or_default();
            let (nested, plain): (Vec<String>, Vec<String>) = all.into_iter().partition(|s| s.contains(".collection:"));
            for n in nested {
                p.add(a, format!("'{n}' names a collection; collections within collections are not supported and it is ignored"));
            }
            plain
        };
        let includes = paths(&inc);
        let excludes = paths(&exc);
        let include_root = store.bool_or(&root, true, p);
        let rule = attr("expansionRule");
        let explicit_only = store.token_or(&rule, &["expandPrims", "expandPrimsAndProperties", "explicitOnly"], "expandPrims", p) == "explicitOnly";
        Some(Collection { includes, excludes, include_root, explicit_only })
    }

    /// Whether the prim at `path` is a member: under the expansion rules, the nearest of its
    /// ancestors (itself included) that the collection names decides (an exclude wins over an
    /// include of the same path; `includeRoot` includes `/`).
    pub fn contains(&self, path: &str) -> bool {
        if self.explicit_only {
            return self.includes.iter().any(|i| i == path) && !self.excludes.iter().any(|e| e == path);
        }
        let under = |a: &str| {
            let a = a.trim_end_matches('/');
            a.is_empty() || path == a || (path.starts_with(a) && path.as_bytes().get(a.len()) == Some(&b'/'))
        };
        let depth = |a: &str| a.trim_end_matches('/').len();
        let inc = self.includes.iter().filter(|a| under(a)).map(|a| depth(a)).max();
        let inc = if self.include_root { inc.max(Some(0)) } else { inc };
        let exc = self.excludes.iter().filter(|a| under(a)).map(|a| depth(a)).max();
        match (inc, exc) {
            (Some(i), Some(e)) => i > e,
            (Some(_), None) => true,
            _ => false,
        }
    }
}

/// The sun of a `TideSkyAPI` dome (contract §6), resolved at scene assembly.
#[derive(Clone, Debug, PartialEq)]
pub struct SkyPiece {
    /// `tide:sky:sun`: path of the DistantLight whose direction sets the sun (None: unauthored).
    pub sun: Option<String>,
    /// `tide:sky:physicalSun`: that light emits the solar model's radiance.
    pub physical_sun: bool,
    /// `tide:sky:sunUnreadable`: a Hydra plugin says the relationship cannot reach it (a scene
    /// delegate's `Get` reads attributes only); the scene's only DistantLight then stands in.
    pub sun_unreadable: bool,
}

/// Where the sky's sun stands when `tide:sky:sun` names no light: 45° above the horizon,
/// towards the dome's local +Z (a clear mid-morning sky).
pub const DEFAULT_SUN_ELEVATION_DEG: f32 = 45.0;

/// Reads `TideSkyAPI` off a dome (any `tide:sky:*` attribute marks it). Bad values become
/// problems naming the attribute: an unknown model → `hosekWilkie`; turbidity outside [1, 10]
/// → clamped into it; ground-albedo components outside [0, 1] → clamped.
fn convert_sky(store: &AttrStore, p: &mut Problems) -> Option<(LightShape, SkyPiece)> {
    const ATTRS: [&str; 5] = ["tide:sky:model", "tide:sky:turbidity", "tide:sky:groundAlbedo", "tide:sky:sun", "tide:sky:physicalSun"];
    if !ATTRS.iter().any(|a| store.has(a)) {
        return None;
    }
    store.token_or("tide:sky:model", &["hosekWilkie"], "hosekWilkie", p);
    let t = store.f32_or("tide:sky:turbidity", 3.0, p);
    let turbidity = if !t.is_finite() {
        p.add("tide:sky:turbidity", format!("{t} is not a number; using 3"));
        3.0
    } else if !(1.0..=10.0).contains(&t) {
        let c = t.clamp(1.0, 10.0);
        p.add("tide:sky:turbidity", format!("{t} is outside the model's range [1, 10]; using {c}"));
        c
    } else {
        t
    };
    let a = store.vec3_or("tide:sky:groundAlbedo", Vec3::splat(0.3), p);
    let ground = if !a.is_finite() {
        p.add("tide:sky:groundAlbedo", format!("{a} is not finite; using 0.3"));
        Vec3::splat(0.3)
    } else if a.min_element() < 0.0 || a.max_element() > 1.0 {
        let c = a.clamp(Vec3::ZERO, Vec3::ONE);
        p.add("tide:sky:groundAlbedo", format!("{a} has components outside [0, 1]; using {c}"));
        c
    } else {
        a
    };
    let sun = store.str_opt("tide:sky:sun").filter(|s| !s.is_empty()).map(String::from);
    let physical_sun = store.bool_or("tide:sky:physicalSun", false, p);
    let sun_unreadable = store.get("tide:sky:sunUnreadable").and_then(|v| v.as_bool()).unwrap_or(false);
    if physical_sun && sun.is_none() && !sun_unreadable {
        p.add("tide:sky:physicalSun", "no tide:sky:sun light to give the solar radiance to; the sky has no sun disc");
    }
    let shape = LightShape::Sky { turbidity, ground_albedo: ground.to_array(), sun_direction: Vec3::Y, scale: tide_core::sky::nits_per_model_unit() };
    Some((shape, SkyPiece { sun, physical_sun, sun_unreadable }))
}

/// `UsdLuxShapingAPI` attributes (any of them present marks a shaped light).
const SHAPING_ATTRS: [&str; 7] = [
    "shaping:cone:angle",
    "shaping:cone:softness",
    "shaping:focus",
    "shaping:focusTint",
    "shaping:ies:file",
    "shaping:ies:angleScale",
    "shaping:ies:normalize",
];

/// Reads `UsdLuxShapingAPI` (None when no shaping attribute is present). Values the schema
/// clamps (softness into [0, 1], a negative focus ignored, an angle scale below −1) are taken
/// silently; a negative cone angle, a negative tint component and an IES file that cannot be
/// read or parsed (the light is then shaped without it) are problems.
fn convert_shaping(kind: LightKind, store: &AttrStore, p: &mut Problems) -> Option<ShapingDesc> {
    let present: Vec<&str> = SHAPING_ATTRS.iter().copied().filter(|a| store.has(a)).collect();
    if present.is_empty() {
        return None;
    }
    if matches!(kind, LightKind::Distant | LightKind::Dome) {
        p.add(present[0], "shaping applies to sphere, rect, disk and cylinder lights; ignored on this light");
        return None;
    }
    let d = ShapingDesc::default();
    let mut angle = store.f32_or("shaping:cone:angle", d.cone_angle_deg, p);
    if angle < 0.0 {
        p.add("shaping:cone:angle", format!("{angle} is negative; using 0 (the light emits nothing)"));
        angle = 0.0;
    }
    let tint = store.vec3_or("shaping:focusTint", Vec3::ZERO, p);
    let tint = if tint.min_element() < 0.0 {
        p.add("shaping:focusTint", format!("{tint} has negative components; using {}", tint.max(Vec3::ZERO)));
        tint.max(Vec3::ZERO)
    } else {
        tint
    };
    let ies = store.str_opt("shaping:ies:file").filter(|f| !f.is_empty()).and_then(|f| {
        let read = std::fs::read(f).map_err(|e| format!("cannot read '{f}': {e}")).and_then(|bytes| {
            // LM-63 files are ASCII; older ones may carry Latin-1 in their keyword lines
            let text: String = bytes.iter().map(|&b| b as char).collect();
            IesProfile::parse(&text).map_err(|e| format!("'{f}': {e}"))
        });
        match read {
            Ok(profile) => Some(std::sync::Arc::new(profile)),
            Err(e) => {
                p.add("shaping:ies:file", format!("{e}; the light is shaped without it"));
                None
            }
        }
    });
    Some(ShapingDesc {
        cone_angle_deg: angle,
        cone_softness: store.f32_or("shaping:cone:softness", d.cone_softness, p),
        focus: store.f32_or("shaping:focus", d.focus, p),
        focus_tint: tint.to_array(),
        ies,
        ies_angle_scale: store.f32_or("shaping:ies:angleScale", d.ies_angle_scale, p),
        ies_normalize: store.bool_or("shaping:ies:normalize", d.ies_normalize, p),
    })
}

/// `UsdLuxShadowAPI`: whether the light casts shadows at all (`shadow:enable`).
fn shadows_enabled(store: &AttrStore, p: &mut Problems) -> bool {
    store.bool_or("shadow:enable", true, p)
}

/// `UsdLuxShadowAPI`'s non-physical controls: the shadow colour (0–1), how far occluders cast
/// shadows, and the falloff zone at that distance's far end and its exponent.
fn shadow_controls(store: &AttrStore, p: &mut Problems) -> ShadowDesc {
    let d = ShadowDesc::default();
    let mut color = store.vec3_or("shadow:color", Vec3::from(d.color), p).to_array();
    if color.iter().any(|c| !(0.0..=1.0).contains(c)) {
        p.add("shadow:color", format!("{color:?} is outside [0, 1]; clamped"));
        color = color.map(|c| if c.is_finite() { c.clamp(0.0, 1.0) } else { 0.0 });
    }
    let mut falloff_gamma = store.f32_or("shadow:falloffGamma", d.falloff_gamma, p);
    if !(falloff_gamma > 0.0) {
        p.add("shadow:falloffGamma", format!("must be above 0, got {falloff_gamma}; using 1"));
        falloff_gamma = 1.0;
    }
    ShadowDesc { color, distance: store.f32_or("shadow:distance", d.distance, p), falloff: store.f32_or("shadow:falloff", d.falloff, p), falloff_gamma }
}

fn nonneg(store: &AttrStore, name: &str, default: f32, p: &mut Problems) -> f32 {
    let v = store.f32_or(name, default, p);
    if v < 0.0 {
        p.add(name, format!("must not be negative, got {}; using {}", v, default));
        default
    } else {
        v
    }
}

/// Converts a light. `None` (with a problem) for a light that cannot emit (zero area) or is
/// invisible.
pub fn convert_light(path: &str, kind: LightKind, store: &AttrStore, p: &mut Problems) -> Option<LightPiece> {
    if store.token_or("visibility", &["inherited", "invisible"], "inherited", p) == "invisible" {
        return None;
    }
    // DomeLight_1's pole axis (Hydra's `domeOffset`): a turn of the dome alone, before its
    // transform
    let offset = match store.get("domeOffset").filter(|_| kind == LightKind::Dome).map(|v| v.as_dmatrix()) {
        None => DMat4::IDENTITY,
        Some(Some(m)) if m.is_finite() && m.as_mat4().determinant() != 0.0 => m,
        Some(_) => {
            p.add("domeOffset", "expected an invertible 4x4 matrix; the dome is not turned");
            DMat4::IDENTITY
        }
    };
    let world = light_transform(store, p) * offset;
    let transform = world.as_mat4();
    let mut texture = None;
    let mut sky = None;
    // the image's colour space metadata (`colorSpace:texture:file`, as the reader hands it on)
    // decodes it; unmarked, the file's own encoding decides
    let encoding = Encoding::from_metadata(store.str_opt("colorSpace:texture:file")).unwrap_or_else(|why| {
        p.add("texture:file", why);
        Encoding::Auto
    });
    let tex_key = |wrap_s, wrap_t, dome| {
        store.str_opt("texture:file").filter(|s| !s.is_empty()).map(|a| TexKey { asset: a.to_string(), wrap_s, wrap_t, encoding, dome, filter: Default::default() })
    };
    let zero_area = |p: &mut Problems, attr: &str| {
        p.add(attr, "the light has zero area; dropped");
        None
    };
    let shape = match kind {
        LightKind::Distant => LightShape::Distant { angle_deg: nonneg(store, "angle", 0.53, p) },
        LightKind::Dome => {
            let fmt = store.token_or("texture:format", &["automatic", "latlong", "mirroredBall", "angular", "cubeMapVerticalCross"], "automatic", p);
            // every UsdLux layout: the assembly resamples the others to lat-long
            texture = tex_key(WrapKey::Repeat, WrapKey::Clamp, DomeFormat::from_token(fmt).unwrap_or_default());
            match convert_sky(store, p) {
                Some((shape, piece)) => {
                    if texture.take().is_some() {
                        p.add("texture:file", "a TideSkyAPI dome is the Hošek–Wilkie sky; its texture is ignored");
                    }
                    sky = Some(piece);
                    shape
                }
                None => LightShape::Dome { texture: None },
            }
        }
        LightKind::Sphere => {
            let radius = nonneg(store, "radius", 0.5, p);
            let treat_as_point = store.bool_or("treatAsPoint", false, p);
            if radius == 0.0 && !treat_as_point {
                p.add("radius", "radius 0 without treatAsPoint; rendered as a point light");
            }
            LightShape::Sphere { radius, treat_as_point: treat_as_point || radius == 0.0 }
        }
        LightKind::Rect => {
            let (width, height) = (nonneg(store, "width", 1.0, p), nonneg(store, "height", 1.0, p));
            if width * height == 0.0 {
                return zero_area(p, if width == 0.0 { "width" } else { "height" });
            }
            texture = tex_key(WrapKey::Clamp, WrapKey::Clamp, DomeFormat::LatLong);
            LightShape::Rect { width, height, texture: None }
        }
        LightKind::Disk => {
            let radius = nonneg(store, "radius", 0.5, p);
            if radius == 0.0 {
                return zero_area(p, "radius");
            }
            LightShape::Disk { radius }
        }
        LightKind::Cylinder => {
            let radius = nonneg(store, "radius", 0.5, p);
            let length = nonneg(store, "length", 1.0, p);
            let treat_as_line = store.bool_or("treatAsLine", false, p);
            if length == 0.0 || (radius == 0.0 && !treat_as_line) {
                return zero_area(p, if length == 0.0 { "length" } else { "radius" });
            }
            LightShape::Cylinder { radius, length, treat_as_line }
        }
    };
    let shaping = convert_shaping(kind, store, p);
    let response = tide_core::scene::LightResponse { diffuse: nonneg(store, "diffuse", 1.0, p), specular: nonneg(store, "specular", 1.0, p) };
    let color = store.vec3_or("color", Vec3::ONE, p);
    let color_temperature = color_temperature(store, p);
    Some(LightPiece {
        desc: LightDesc {
            shaping,
            response,
            motion: Vec::new(), portals: Vec::new(),
            name: path.into(),
            shape,
            transform,
            color: color.to_array(),
            intensity: store.f32_or("intensity", 1.0, p),
            exposure: store.f32_or("exposure", 0.0, p),
            normalize: store.bool_or("normalize", false, p),
            color_temperature,
            visible_to_camera: true,
            light_link: None,
            shadow_link: None,
            shadow: shadow_controls(store, p),
        },
        texture,
        sky,
        light_link: Collection::read(store, "lightLink", p),
        // shadow:enable = false: nothing casts the light's shadows
        shadow_link: if shadows_enabled(store, p) {
            Collection::read(store, "shadowLink", p)
        } else {
            Some(Collection { includes: vec![], excludes: vec![], include_root: false, explicit_only: true })
        },
        caustics_emitter: store.has("tide:caustics:emitter").then(|| store.bool_or("tide:caustics:emitter", false, p)),
        transforms: if store.attr("transform").is_some_and(|a| a.samples.len() >= 2) { store.matrix_samples("transform", p).into_iter().map(|(t, m)| (t, m * offset)).collect() } else { vec![(0.0, world)] },
        world,
        portals: match kind {
            LightKind::Dome => store.get("portals").map(|v| {
                v.to_strings().unwrap_or_else(|| {
                    p.add("portals", format!("expected paths, got a {}; no portals", v.kind()));
                    Vec::new()
                })
            }),
            _ => None,
        },
    })
}

/// `colorTemperature` where `enableColorTemperature` is on (a non-positive value: 6500 K,
/// reported).
fn color_temperature(store: &AttrStore, p: &mut Problems) -> Option<f32> {
    store.bool_or("enableColorTemperature", false, p).then(|| {
        let k = store.f32_or("colorTemperature", 6500.0, p);
        if k > 0.0 {
            k
        } else {
            p.add("colorTemperature", format!("must be positive, got {}; using 6500", k));
            6500.0
        }
    })
}

/// UsdLuxMeshLightAPI on a mesh: what it emits and how its material takes part.
#[derive(Clone, Debug, PartialEq)]
pub struct MeshLight {
    /// color × intensity × 2^exposure (before the colour temperature and normalisation).
    pub rgb: [f32; 3],
    pub color_temperature: Option<f32>,
    /// Divide by the mesh's world-space area.
    pub normalize: bool,
    /// `light:materialSyncMode`.
    pub mode: MeshLightMode,
    /// `collection:lightLink` and `collection:shadowLink`, as a light's.
    pub light_link: Option<Collection>,
    pub shadow_link: Option<Collection>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MeshLightMode {
    /// The light's emission tinted by the material's emissive colour (where it has one); the
    /// material shades the surface as before.
    MaterialGlowTintsLight,
    /// The light's emission replaces the material's; the material shades the surface.
    Independent,
    /// The surface only emits.
    NoMaterialResponse,
}

/// The mesh light a mesh carries (`meshLight` true: the reader or Hydra saw MeshLightAPI), with
/// UsdLux's light attributes and fallbacks; None for other meshes.
pub fn read_mesh_light(store: &AttrStore, p: &mut Problems) -> Option<MeshLight> {
    if !store.bool_or("meshLight", false, p) {
        return None;
    }
    let color = store.vec3_or("color", Vec3::ONE, p).max(Vec3::ZERO);
    let scale = store.f32_or("intensity", 1.0, p) * store.f32_or("exposure", 0.0, p).exp2();
    let scale = if scale.is_finite() && scale >= 0.0 {
        scale
    } else {
        p.add("intensity", format!("intensity × 2^exposure is {scale}; the mesh emits nothing"));
        0.0
    };
    let color_temperature = color_temperature(store, p);
    let mode = match store.token_or("light:materialSyncMode", &["materialGlowTintsLight", "independent", "noMaterialResponse"], "materialGlowTintsLight", p) {
        "independent" => MeshLightMode::Independent,
        "noMaterialResponse" => MeshLightMode::NoMaterialResponse,
        _ => MeshLightMode::MaterialGlowTintsLight,
    };
    Some(MeshLight {
        rgb: (color * scale).to_array(),
        color_temperature,
        normalize: store.bool_or("normalize", false, p),
        mode,
        light_link: Collection::read(store, "lightLink", p),
        shadow_link: Collection::read(store, "shadowLink", p),
    })
}

/// The area of `mesh` placed by `world`.
pub fn world_area(mesh: &tide_core::scene::MeshDesc, world: Mat4) -> f32 {
    mesh.indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| world.transform_point3(mesh.positions[t[k] as usize]));
            0.5 * (b - a).cross(c - a).length()
        })
        .sum()
}

/// The material a mesh light's mesh renders with: `base` (its bound material) emitting the
/// light's radiance as UsdLux's `light:materialSyncMode` says. Emission from a constant colour
/// makes the mesh's triangles lights the renderer samples. `world` places the mesh (for
/// `normalize`, which divides by its world-space area). Surfaces other than UsdPreviewSurface
/// and Lambert cannot also emit: they become emitters only, with a problem.
pub fn mesh_light_material(ml: &MeshLight, base: &tide_core::scene::MaterialDesc, mesh: &tide_core::scene::MeshDesc, world: Mat4, cs: ColorSpace, path: &str) -> (tide_core::scene::MaterialDesc, Option<tide_core::Problem>) {
    use tide_core::scene::{ColorInput, PreviewSurfaceDesc, SurfaceDesc};
    let mut rgb = ml.rgb;
    if let Some(k) = ml.color_temperature {
        let bb = tide_core::spectrum::color::blackbody_rgb(k, cs);
        rgb = [rgb[0] * bb[0], rgb[1] * bb[1], rgb[2] * bb[2]];
    }
    if ml.normalize {
        let area = world_area(mesh, world);
        if area > 0.0 {
            rgb = rgb.map(|c| c / area);
        }
    }
    let mut m = base.clone();
    m.name = format!("{} (mesh light {})", base.name, path);
    let mut problem = None;
    let preview = match &base.surface {
        _ if ml.mode == MeshLightMode::NoMaterialResponse => None,
        SurfaceDesc::Preview(pr) => Some(pr.clone()),
        SurfaceDesc::Diffuse { color } => Some(PreviewSurfaceDesc { diffuse_color: color.clone(), use_specular_workflow: true, specular_color: ColorInput::Const([0.0; 3]), ..Default::default() }),
        _ => {
            problem = Some(tide_core::Problem { item: path.into(), attribute: "light:materialSyncMode".into(), message: format!("material '{}' cannot also emit; the mesh light renders as an emitter only (noMaterialResponse)", base.name) });
            None
        }
    };
    m.surface = match preview {
        None => SurfaceDesc::Emissive { radiance: rgb, two_sided: mesh.double_sided },
        Some(mut pr) => {
            pr.emissive_color = match (&pr.emissive_color, ml.mode) {
                (ColorInput::Const(g), MeshLightMode::MaterialGlowTintsLight) if g.iter().all(|&c| c <= 0.0) => ColorInput::Const(rgb),
                // the glow tints the light, texel by texel or point by point where it varies
                (g, MeshLightMode::MaterialGlowTintsLight) => g.clone().scaled(rgb),
                _ => ColorInput::Const(rgb),
            };
            SurfaceDesc::Preview(pr)
        }
    };
    (m, problem)
}

/// A converted camera; shutter in frames, transform samples in frames; `medium` is the path of
/// the material whose volume the camera starts in.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPiece {
    pub desc: CameraDesc,
    pub transforms: Vec<(f64, DMat4)>,
    pub medium: Option<String>,
    /// The stage's `timeCodesPerSecond` as a Hydra plugin hands it on with the camera (the
    /// usdImagingTide adapter); the settings' value wins where the reader authored one.
    pub time_codes_per_second: Option<f64>,
    /// The stage's authored `metersPerUnit`, handed on the same way.
    pub meters_per_unit: Option<f64>,
    /// Whether the stage's up axis is Z, where handed on the same way (`upAxis`).
    pub z_up: Option<bool>,
}

/// A stage-wide rate or scale (`timeCodesPerSecond`, `metersPerUnit`) where given: positive
/// and finite, else named (`then`: what is used instead) and ignored.
fn stage_positive(store: &AttrStore, name: &str, then: &str, p: &mut Problems) -> Option<f64> {
    store.has(name).then(|| store.f32_or(name, 1.0, p) as f64).filter(|v| {
        let ok = *v > 0.0 && v.is_finite();
        if !ok {
            p.add(name, format!("{v} must be positive; {then}"));
        }
        ok
    })
}

/// Whether a stage's `upAxis` (token `Y` or `Z`) is Z, where given; another value is named
/// and Y used.
fn up_axis_is_z(store: &AttrStore, p: &mut Problems) -> Option<bool> {
    match store.str_opt("upAxis")? {
        "Y" => Some(false),
        "Z" => Some(true),
        other => {
            p.add("upAxis", format!("unknown up axis '{other}'; using Y"));
            Some(false)
        }
    }
}

/// A stage's `metersPerUnit` where given.
fn meters_per_unit(store: &AttrStore, p: &mut Problems) -> Option<f64> {
    stage_positive(store, "metersPerUnit", "one unit is one metre", p)
}

/// Converts a camera. Zero or negative apertures / focal length become problems and defaults.
pub fn convert_camera(path: &str, store: &AttrStore, p: &mut Problems) -> CameraPiece {
    let d = CameraDesc::default();
    let positive = |name: &str, default: f32, p: &mut Problems| {
        let v = store.f32_or(name, default, p);
        if v > 0.0 {
            v
        } else {
            p.add(name, format!("must be positive, got {}; using {}", v, default));
            default
        }
    };
    // depth of field: 0 (the default) turns it off; a negative or non-finite value is named
    let lens = |name: &str, p: &mut Problems| {
        let v = store.f32_or(name, 0.0, p);
        if v >= 0.0 && v.is_finite() {
            v
        } else {
            p.add(name, format!("must be 0 (no depth of field) or positive, got {v}; using 0 (no depth of field)"));
            0.0
        }
    };
    let projection = match store.token_or("projection", &["perspective", "orthographic"], "perspective", p) {
        "orthographic" => Projection::Orthographic,
        _ => Projection::Perspective,
    };
    let clipping_range = match store.get("clippingRange").and_then(|v| v.to_f32s()) {
        Some(c) if c.len() == 2 && c[0] > 0.0 && c[1] > c[0] && c[1].is_finite() => [c[0], c[1]],
        None => d.clipping_range,
        Some(c) => {
            p.add("clippingRange", format!("expected 0 < near < far, got {:?}; using {:?}", c, d.clipping_range));
            d.clipping_range
        }
    };
    // clippingPlanes: float4 (a, b, c, d) each, camera space; non-finite ones are dropped
    let clipping_planes = match store.get("clippingPlanes").map(|v| (v.to_f32s(), v)) {
        None => Vec::new(),
        Some((Some(f), _)) if f.len() % 4 == 0 && f.iter().all(|x| x.is_finite()) => f.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect(),
        Some((_, v)) => {
            p.add("clippingPlanes", format!("expected finite float4 planes, got {}; none used", v.kind()));
            Vec::new()
        }
    };
    let filter = match store.token_or("tide:camera:filter", &["none", "underwaterRed"], "none", p) {
        "underwaterRed" => CameraFilter::UnderwaterRed,
        _ => CameraFilter::None,
    };
    // a shutter closing before it opens goes to the renderer as authored: it renders black
    let shutter_open = store.f32_or("shutter:open", 0.0, p);
    let shutter_close = store.f32_or("shutter:close", 0.0, p);
    let desc = CameraDesc {
        name: path.into(),
        transforms: vec![Mat4::IDENTITY],
        times: vec![0.0],
        projection,
        focal_length: positive("focalLength", d.focal_length, p),
        horizontal_aperture: positive("horizontalAperture", d.horizontal_aperture, p),
        vertical_aperture: positive("verticalAperture", d.vertical_aperture, p),
        horizontal_aperture_offset: store.f32_or("horizontalApertureOffset", 0.0, p),
        vertical_aperture_offset: store.f32_or("verticalApertureOffset", 0.0, p),
        clipping_range,
        clipping_planes,
        f_stop: lens("fStop", p),
        focus_distance: lens("focusDistance", p),
        shutter_open,
        shutter_close,
        exposure: store.f32_or("exposure", 0.0, p),
        exposure_f_stop: positive("exposure:fStop", d.exposure_f_stop, p),
        exposure_time: positive("exposure:time", d.exposure_time, p),
        exposure_iso: positive("exposure:iso", d.exposure_iso, p),
        exposure_responsivity: positive("exposure:responsivity", d.exposure_responsivity, p),
        medium: None,
        filter,
    };
    let time_codes_per_second = stage_positive(store, "timeCodesPerSecond", "ignored", p);
    CameraPiece {
        desc,
        transforms: store.matrix_samples("transform", p),
        medium: store.str_opt("tide:medium").filter(|s| !s.is_empty()).map(String::from),
        time_codes_per_second,
        meters_per_unit: meters_per_unit(store, p),
        z_up: up_axis_is_z(store, p),
    }
}

/// The most bounces `tide:maxDepth` may ask of a path (deep enough for the densest media a
/// volumetric path tracer is asked to walk; a path of 2^31 bounces through a scattering medium
/// of albedo 1 never ends in practice, and a pass waits for its paths).
pub const MAX_PATH_DEPTH: u32 = 1 << 16;

/// One UsdRenderVar of a product.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderVarDesc {
    pub path: String,
    pub source_name: String,
    /// The core AOV, when the source name is one.
    pub aov: Option<tide_core::Aov>,
}

/// One UsdRenderProduct: an EXR file and its vars.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderProductDesc {
    pub path: String,
    pub product_name: String,
    pub camera: Option<String>,
    pub resolution: Option<[u32; 2]>,
    pub vars: Vec<RenderVarDesc>,
}

/// A converted render settings prim.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingsPiece {
    pub settings: RenderSettings,
    /// Whether `resolution` was authored (otherwise the render buffers' size is used).
    pub resolution_authored: bool,
    pub camera: Option<String>,
    pub included_purposes: Vec<String>,
    pub color_space: ColorSpace,
    pub time_codes_per_second: f64,
    /// Whether `timeCodesPerSecond` was given (the reader always gives it; Hydra does not).
    pub time_codes_authored: bool,
    /// The stage's `metersPerUnit` where authored (the reader gives it so): lengths and
    /// coefficients the contract gives in metres are converted to scene units with it.
    pub meters_per_unit: Option<f64>,
    /// Whether the stage's up axis is Z (`upAxis`, as the reader gives it; None: not given):
    /// water depth is then measured down +Z instead of +Y.
    pub z_up: Option<bool>,
    pub adaptive_threshold: f32,
    pub products: Vec<RenderProductDesc>,
}

impl Default for SettingsPiece {
    fn default() -> Self {
        SettingsPiece {
            settings: RenderSettings::default(),
            resolution_authored: false,
            camera: None,
            included_purposes: vec!["default".into(), "render".into()],
            color_space: ColorSpace::LinearRec709,
            time_codes_per_second: 24.0,
            time_codes_authored: false,
            meters_per_unit: None,
            z_up: None,
            adaptive_threshold: 0.0,
            products: Vec::new(),
        }
    }
}

/// A rendering colour space by its name: OpenUSD's (`lin_rec709_scene`, `lin_ap1_scene`,
/// `lin_rec2020_scene`, also without `_scene`) or the usual OpenColorIO ones, any case; None
/// for any other (a non-linear space such as `srgb_rec709_scene` is no rendering space).
pub fn rendering_color_space(name: &str) -> Option<ColorSpace> {
    let n = name.trim().to_ascii_lowercase();
    let n = n.strip_suffix("_scene").unwrap_or(&n);
    match n {
        "lin_rec709" | "lin_srgb" | "srgb_linear" | "linear" | "linear rec.709 (srgb)" | "utility - linear - srgb" | "linear rec.709" => Some(ColorSpace::LinearRec709),
        "lin_ap1" | "acescg" | "aces - acescg" | "aces cg" => Some(ColorSpace::AcesCg),
        "lin_rec2020" | "linear rec.2020" | "utility - linear - rec.2020" => Some(ColorSpace::LinearRec2020),
        _ => None,
    }
}

/// Whether `n` pixels can be an image's width or height.
fn side_ok(n: i32) -> bool {
    n > 0 && n as u32 <= MAX_IMAGE_SIDE
}

/// Converts a render settings prim. Products and vars are read from attributes prefixed with
/// their paths: `products` (Paths), `<P>.productName`, `<P>.camera`, `<P>.resolution`,
/// `<P>.orderedVars` (Paths), `<V>.sourceName`.
pub fn convert_settings(store: &AttrStore, p: &mut Problems) -> SettingsPiece {
    let d = SettingsPiece::default();
    let mut s = d.settings.clone();
    let mut resolution_authored = false;
    if let Some(v) = store.get("resolution") {
        match v.to_ints() {
            Some(r) if r.len() == 2 && side_ok(r[0]) && side_ok(r[1]) => {
                s.width = r[0] as u32;
                s.height = r[1] as u32;
                resolution_authored = true;
            }
            _ => p.add("resolution", format!("expected two positive ints up to {MAX_IMAGE_SIDE}; using {}x{}", s.width, s.height)),
        }
    }
    let policy = store.token_or("aspectRatioConformPolicy", &["expandAperture", "cropAperture", "adjustApertureWidth", "adjustApertureHeight", "adjustPixelAspectRatio"], "expandAperture", p);
    s.aspect_conform = tide_core::camera::AspectConform::from_token(policy).unwrap_or_default();
    // OpenEXR's files hold a pixel aspect ratio from 1e-6 to 1e6
    let par = store.f32_or("pixelAspectRatio", 1.0, p);
    s.pixel_aspect_ratio = if (1e-6..=1e6).contains(&par) {
        par
    } else {
        p.add("pixelAspectRatio", format!("{par} is not within 1e-6 to 1e6 (positive, as an OpenEXR file holds it); using 1"));
        1.0
    };
    if let Some(v) = store.get("dataWindowNDC") {
        match v.to_f32s() {
            Some(w) if w.len() == 4 && w[2] > w[0] && w[3] > w[1] && w.iter().all(|x| x.is_finite()) => {
                s.data_window_ndc = [w[0], w[1], w[2], w[3]]
            }
            _ => p.add("dataWindowNDC", "expected (xmin, ymin, xmax, ymax) with min < max; using (0, 0, 1, 1)"),
        }
    }
    s.disable_motion_blur = store.bool_or("disableMotionBlur", false, p);
    s.disable_depth_of_field = store.bool_or("disableDepthOfField", false, p);
    let integrator = store.token_or("tide:integrator", &["caustics", "path"], "caustics", p);
    s.integrator = if integrator == "path" { IntegratorKind::Path } else { IntegratorKind::Caustics };
    let nonneg_int = |name: &str, default: i64, p: &mut Problems| {
        let v = store.i64_or(name, default, p);
        if v < 0 {
            p.add(name, format!("must not be negative; using {}", default));
            default
        } else {
            v
        }
    };
    s.spp = match store.i64_or("tide:samples", 64, p) {
        v if v >= 1 => v.min(u32::MAX as i64) as u32,
        v => {
            p.add("tide:samples", format!("{v} is not a positive sample count; using 64"));
            64
        }
    };
    s.max_depth = match nonneg_int("tide:maxDepth", 64, p) {
        d if d > MAX_PATH_DEPTH as i64 => {
            p.add("tide:maxDepth", format!("{d} is more than {MAX_PATH_DEPTH} bounces; using {MAX_PATH_DEPTH}"));
            MAX_PATH_DEPTH
        }
        d => d as u32,
    };
    s.seed = nonneg_int("tide:seed", 0, p) as u64;
    s.time_budget_s = match store.f32_or("tide:time:budget", 0.0, p) {
        b if b >= 0.0 && b.is_finite() => b,
        b => {
            p.add("tide:time:budget", format!("{b} is not a number of seconds >= 0; no budget (0)"));
            0.0
        }
    };
    let adaptive_threshold = store.f32_or("tide:adaptive:threshold", 0.0, p);
    s.adaptive_threshold = if adaptive_threshold >= 0.0 {
        adaptive_threshold
    } else {
        p.add("tide:adaptive:threshold", "must not be negative; adaptive sampling is off");
        0.0
    };
    s.adaptive_min_spp = nonneg_int("tide:adaptive:minSamples", 0, p).min(u32::MAX as i64) as u32;
    let filter_name = store.token_or("tide:pixelFilter", &["gaussian", "box", "triangle"], "box", p);
    let kind = tide_core::filter::FilterKind::from_token(filter_name).unwrap_or_default();
    let width = store.f32_or("tide:pixelFilter:width", 0.0, p);
    s.pixel_filter = match tide_core::filter::PixelFilter::new(kind, width) {
        Ok(f) => f,
        Err(e) => {
            let f = tide_core::filter::PixelFilter::new(kind, 0.0).unwrap_or_default();
            p.add("tide:pixelFilter:width", format!("{e}; using {}", f.width));
            f
        }
    };
    let included_purposes = store.get("includedPurposes").and_then(|v| v.to_strings()).unwrap_or(d.included_purposes);
    let color_space = match store.str_opt("renderingColorSpace") {
        None | Some("") => ColorSpace::LinearRec709,
        Some(c) => rendering_color_space(c).unwrap_or_else(|| {
            p.add("renderingColorSpace", format!("'{}' is not a linear colour space Tide renders in (lin_rec709_scene, lin_ap1_scene / ACEScg, lin_rec2020_scene); using linear Rec.709", c));
            ColorSpace::LinearRec709
        }),
    };
    let tcps = store.f32_or("timeCodesPerSecond", 24.0, p) as f64;
    let time_codes_per_second = if tcps > 0.0 {
        tcps
    } else {
        p.add("timeCodesPerSecond", "must be positive; using 24");
        24.0
    };
    let mut products = Vec::new();
    for prod in store.get("products").and_then(|v| v.to_strings()).unwrap_or_default() {
        let get = |n: &str| store.get(&format!("{}.{}", prod, n));
        let vars = get("orderedVars")
            .and_then(|v| v.to_strings())
            .unwrap_or_default()
            .into_iter()
            .map(|var| {
                let source_name = store.str_opt(&format!("{}.sourceName", var)).unwrap_or("").to_string();
                let aov = tide_core::Aov::from_source_name(&source_name);
                if aov.is_none() {
                    p.add(&format!("{}.sourceName", var), format!("unknown AOV '{}'; the var is skipped", source_name));
                }
                RenderVarDesc { path: var, source_name, aov }
            })
            .collect();
        products.push(RenderProductDesc {
            product_name: get("productName").and_then(|v| v.as_str()).unwrap_or("").to_string(),
            camera: get("camera").and_then(|v| v.as_str()).map(String::from),
            resolution: get("resolution").and_then(|v| v.to_ints()).filter(|r| r.len() == 2 && side_ok(r[0]) && side_ok(r[1])).map(|r| [r[0] as u32, r[1] as u32]),
            vars,
            path: prod,
        });
    }
    SettingsPiece {
        settings: s,
        resolution_authored,
        camera: store.str_opt("camera").filter(|c| !c.is_empty()).map(String::from),
        included_purposes,
        color_space,
        time_codes_per_second,
        time_codes_authored: store.has("timeCodesPerSecond"),
        meters_per_unit: meters_per_unit(store, p),
        z_up: up_axis_is_z(store, p),
        adaptive_threshold,
        products,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::{normalize_name, Attr, Value};

    fn st(pairs: &[(&str, Value)]) -> AttrStore {
        let mut s = AttrStore::default();
        for (n, v) in pairs {
            s.attrs.insert(normalize_name(n).to_string(), Attr { value: Some(v.clone()), samples: vec![] });
        }
        s
    }
    fn f(x: f64) -> Value {
        Value::Float(x)
    }

    #[test]
    fn lights_convert_with_usd_names_and_zero_area_is_dropped() {
        let mut p = Problems::new("/L");
        let rect = convert_light(
            "/L",
            LightKind::Rect,
            &st(&[("inputs:width", f(2.0)), ("inputs:height", f(0.5)), ("inputs:intensity", f(10.0)), ("inputs:exposure", f(1.0)), ("inputs:color", Value::Floats { data: vec![1.0, 0.5, 0.25], tuple: 3 }), ("inputs:normalize", Value::Bool(true))]),
            &mut p,
        )
        .unwrap();
        assert_eq!(rect.desc.shape, LightShape::Rect { width: 2.0, height: 0.5, texture: None });
        assert_eq!((rect.desc.intensity, rect.desc.exposure, rect.desc.color, rect.desc.normalize), (10.0, 1.0, [1.0, 0.5, 0.25], true));
        let sun = convert_light("/S", LightKind::Distant, &st(&[("inputs:angle", f(1.0)), ("inputs:enableColorTemperature", Value::Bool(true)), ("inputs:colorTemperature", f(5000.0))]), &mut p).unwrap();
        assert_eq!(sun.desc.shape, LightShape::Distant { angle_deg: 1.0 });
        assert_eq!(sun.desc.color_temperature, Some(5000.0));
        let sph = convert_light("/P", LightKind::Sphere, &st(&[("inputs:radius", f(0.1)), ("treatAsPoint", Value::Bool(true))]), &mut p).unwrap();
        assert_eq!(sph.desc.shape, LightShape::Sphere { radius: 0.1, treat_as_point: true });
        let dome = convert_light("/D", LightKind::Dome, &st(&[("inputs:texture:file", Value::Asset("/sky.exr".into()))]), &mut p).unwrap();
        assert_eq!(dome.texture.unwrap().asset, "/sky.exr");
        assert!(p.list.is_empty(), "{:?}", p.list);
        assert!(convert_light("/Z", LightKind::Disk, &st(&[("inputs:radius", f(0.0))]), &mut p).is_none());
        assert_eq!(p.list.len(), 1);
        assert_eq!(p.list[0].attribute, "radius");
    }

    /// DomeLight_1's pole axis arrives as `domeOffset` (USD's row-vector matrix), turning the
    /// dome before its transform: a Z pole takes the image's up (+Y) to +Z and its centre (+Z)
    /// to −Y, and the transform then applies.
    #[test]
    fn a_dome_offset_turns_the_dome_before_its_transform() {
        let m = |a: [f64; 16]| Value::Matrix(a);
        let z_pole = m([1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let spin = m([0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
        let mut p = Problems::new("/D");
        let d = convert_light("/D", LightKind::Dome, &st(&[("domeOffset", z_pole.clone())]), &mut p).unwrap().desc.transform;
        assert!((d.transform_vector3(Vec3::Y) - Vec3::Z).length() < 1e-6 && (d.transform_vector3(Vec3::Z) + Vec3::Y).length() < 1e-6, "{d}");
        // with a transform turning +X to +Y about Z: the offset first
        let d = convert_light("/D", LightKind::Dome, &st(&[("domeOffset", z_pole.clone()), ("transform", spin)]), &mut p).unwrap().desc.transform;
        assert!((d.transform_vector3(Vec3::Z) - Vec3::X).length() < 1e-6, "{d}");
        assert!(p.list.is_empty(), "{:?}", p.list);
        // not on other lights; a singular one is reported
        let r = convert_light("/R", LightKind::Rect, &st(&[("domeOffset", z_pole)]), &mut p).unwrap().desc.transform;
        assert_eq!(r, Mat4::IDENTITY);
        convert_light("/D", LightKind::Dome, &st(&[("domeOffset", m([0.0; 16]))]), &mut p).unwrap();
        assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), ["domeOffset"]);
    }

    #[test]
    fn shaping_is_read_where_it_applies() {
        let mut p = Problems::new("/L");
        // the API applied with its fallbacks: a hard 90° cone
        let l = convert_light("/L", LightKind::Sphere, &st(&[("inputs:shaping:cone:angle", f(90.0))]), &mut p).unwrap();
        assert_eq!(l.desc.shaping, Some(ShapingDesc::default()));
        let l = convert_light(
            "/L",
            LightKind::Rect,
            &st(&[("inputs:shaping:cone:angle", f(25.0)), ("inputs:shaping:cone:softness", f(0.3)), ("inputs:shaping:focus", f(4.0)), ("inputs:shaping:focusTint", Value::Floats { data: vec![0.1, 0.2, 0.3], tuple: 3 })]),
            &mut p,
        )
        .unwrap();
        assert_eq!(l.desc.shaping, Some(ShapingDesc { cone_angle_deg: 25.0, cone_softness: 0.3, focus: 4.0, focus_tint: [0.1, 0.2, 0.3], ..Default::default() }));
        assert!(p.list.is_empty(), "{:?}", p.list);
        // unshaped lights stay unshaped
        assert_eq!(convert_light("/L", LightKind::Disk, &st(&[]), &mut p).unwrap().desc.shaping, None);
        // problems name the attribute: a negative angle, a negative tint, an IES profile, and
        // shaping on a distant light
        let l = convert_light("/L", LightKind::Sphere, &st(&[("inputs:shaping:cone:angle", f(-5.0)), ("inputs:shaping:focusTint", Value::Floats { data: vec![-1.0, 0.5, 0.5], tuple: 3 }), ("inputs:shaping:ies:file", Value::Asset("/no/such/file.ies".into()))]), &mut p).unwrap();
        let sd = l.desc.shaping.unwrap();
        assert_eq!((sd.cone_angle_deg, sd.focus_tint, sd.ies.is_none()), (0.0, [0.0, 0.5, 0.5], true));
        assert!(p.list[2].message.contains("cannot read '/no/such/file.ies'"), "{:?}", p.list[2]);
        // a readable profile is parsed; a malformed one is a problem naming the file
        let dir = std::env::temp_dir().join(format!("tide-ies-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let good = dir.join("good.ies");
        std::fs::write(&good, "TILT=NONE\n1 -1 1 2 1 1 2 0 0 0\n1 1 0\n0 90\n0\n300 100\n").unwrap();
        let bad = dir.join("bad.ies");
        std::fs::write(&bad, "TILT=NONE\n1 -1 1 2 1 4 2 0 0 0\n1 1 0\n0 90\n0\n300 100\n").unwrap();
        let mut q = Problems::new("/L");
        let asset = |f: &std::path::Path| Value::Asset(f.to_string_lossy().into_owned());
        let l = convert_light("/L", LightKind::Disk, &st(&[("inputs:shaping:ies:file", asset(&good)), ("inputs:shaping:ies:normalize", Value::Bool(true)), ("inputs:shaping:ies:angleScale", f(0.5))]), &mut q).unwrap();
        let sd = l.desc.shaping.unwrap();
        assert_eq!((sd.ies.unwrap().eval(0.0, 0.0), sd.ies_normalize, sd.ies_angle_scale), (300.0, true, 0.5));
        assert!(q.list.is_empty(), "{:?}", q.list);
        let l = convert_light("/L", LightKind::Disk, &st(&[("inputs:shaping:ies:file", asset(&bad))]), &mut q).unwrap();
        assert!(l.desc.shaping.unwrap().ies.is_none());
        assert!(q.list[0].attribute == "shaping:ies:file" && q.list[0].message.contains("type 4 is none of 1 (C), 2 (B) and 3 (A)"), "{:?}", q.list);
        std::fs::remove_dir_all(&dir).unwrap();
        let sun = convert_light("/L", LightKind::Distant, &st(&[("inputs:shaping:focus", f(2.0))]), &mut p).unwrap();
        assert!(sun.desc.shaping.is_none());
        let attrs: Vec<&str> = p.list.iter().map(|q| q.attribute.as_str()).collect();
        assert_eq!(attrs, ["shaping:cone:angle", "shaping:focusTint", "shaping:ies:file", "shaping:focus"]);
    }

    #[test]
    fn mesh_lights_emit_through_their_material() {
        use tide_core::scene::{ColorInput, MaterialDesc, MeshDesc, PreviewSurfaceDesc, SurfaceDesc};
        let mut p = Problems::new("/M");
        assert!(read_mesh_light(&st(&[("inputs:intensity", f(2.0))]), &mut p).is_none(), "no meshLight: not a light");
        let store = st(&[("meshLight", Value::Bool(true)), ("inputs:intensity", f(3.0)), ("inputs:exposure", f(1.0)), ("inputs:color", Value::Floats { data: vec![1.0, 0.5, 0.25], tuple: 3 }), ("inputs:normalize", Value::Bool(true))]);
        let ml = read_mesh_light(&store, &mut p).unwrap();
        assert_eq!((ml.rgb, ml.normalize, ml.mode), ([6.0, 3.0, 1.5], true, MeshLightMode::MaterialGlowTintsLight));
        // a unit square scaled by 2 × 3 in the world: area 6
        let quad = MeshDesc { positions: vec![Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y], indices: vec![0, 1, 2, 0, 2, 3], ..Default::default() };
        let world = Mat4::from_scale(Vec3::new(2.0, 3.0, 1.0));
        let glow = MaterialDesc { name: "glow".into(), surface: SurfaceDesc::Preview(PreviewSurfaceDesc { emissive_color: ColorInput::Const([0.5, 1.0, 2.0]), ..Default::default() }), interior_medium: None };
        let (m, problem) = mesh_light_material(&ml, &glow, &quad, world, ColorSpace::LinearRec709, "/M");
        assert!(problem.is_none());
        let SurfaceDesc::Preview(pr) = &m.surface else { panic!("{:?}", m.surface) };
        assert_eq!(pr.emissive_color, ColorInput::Const([6.0 / 6.0 * 0.5, 3.0 / 6.0, 1.5 / 6.0 * 2.0]));
        // a glow map tints the light texel by texel: its scale and bias carry the light's colour
        let map = tide_core::scene::TexLookup {
            texture: 0,
            channel: tide_core::scene::Channel::Rgb,
            transform: glam::Affine2::IDENTITY,
            tex_scale: [1.0, 2.0, 1.0, 1.0],
            bias: [0.5, 0.0, 0.0, 0.0],
            fallback: [0.0; 4],
            uv_set: None,
        };
        let mapped = MaterialDesc { surface: SurfaceDesc::Preview(PreviewSurfaceDesc { emissive_color: ColorInput::Texture(map), ..Default::default() }), ..glow.clone() };
        let (m, problem) = mesh_light_material(&ml, &mapped, &quad, world, ColorSpace::LinearRec709, "/M");
        assert!(problem.is_none());
        let SurfaceDesc::Preview(pr) = &m.surface else { panic!() };
        let ColorInput::Texture(t) = &pr.emissive_color else { panic!("{:?}", pr.emissive_color) };
        assert_eq!((t.tex_scale, t.bias), ([1.0, 1.0, 0.25, 1.0], [0.5, 0.0, 0.0, 0.0]));
        // a glow read from a primvar is tinted through the lookup's scale
        let painted = MaterialDesc { surface: SurfaceDesc::Preview(PreviewSurfaceDesc { emissive_color: ColorInput::Primvar(tide_core::scene::PrimvarLookup::new("glow", [0.0; 4])), ..Default::default() }), ..glow.clone() };
        let (m, problem) = mesh_light_material(&ml, &painted, &quad, world, ColorSpace::LinearRec709, "/M");
        assert!(problem.is_none());
        let SurfaceDesc::Preview(pr) = &m.surface else { panic!() };
        let ColorInput::Primvar(l) = &pr.emissive_color else { panic!("{:?}", pr.emissive_color) };
        assert_eq!(l.scale, [1.0, 0.5, 0.25, 1.0]);
        // independent: the glow is replaced; a Lambert material keeps its colour and emits
        let ind = MeshLight { mode: MeshLightMode::Independent, normalize: false, ..ml.clone() };
        let (m, _) = mesh_light_material(&ind, &glow, &quad, world, ColorSpace::LinearRec709, "/M");
        let SurfaceDesc::Preview(pr) = &m.surface else { panic!() };
        assert_eq!(pr.emissive_color, ColorInput::Const([6.0, 3.0, 1.5]));
        let lambert = MaterialDesc { name: "l".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.2; 3]) }, interior_medium: None };
        let (m, _) = mesh_light_material(&ind, &lambert, &quad, world, ColorSpace::LinearRec709, "/M");
        let SurfaceDesc::Preview(pr) = &m.surface else { panic!() };
        assert_eq!((pr.diffuse_color.clone(), pr.emissive_color.clone()), (ColorInput::Const([0.2; 3]), ColorInput::Const([6.0, 3.0, 1.5])));
        // noMaterialResponse, or a surface that cannot emit (a conductor: reported): an emitter
        let only = MeshLight { mode: MeshLightMode::NoMaterialResponse, ..ind.clone() };
        let (m, problem) = mesh_light_material(&only, &glow, &quad, world, ColorSpace::LinearRec709, "/M");
        assert_eq!((m.surface, problem), (SurfaceDesc::Emissive { radiance: [6.0, 3.0, 1.5], two_sided: false }, None));
        let metal = MaterialDesc { name: "metal".into(), surface: SurfaceDesc::Conductor { eta: [0.2; 3], k: [3.0; 3], roughness: 0.1 }, interior_medium: None };
        let (m, problem) = mesh_light_material(&ind, &metal, &quad, world, ColorSpace::LinearRec709, "/M");
        assert!(matches!(m.surface, SurfaceDesc::Emissive { .. }));
        assert_eq!(problem.map(|q| (q.item, q.attribute)), Some(("/M".into(), "light:materialSyncMode".into())));
        // an unknown sync mode is a problem and takes the fallback
        let mut p = Problems::new("/M");
        let ml = read_mesh_light(&st(&[("meshLight", Value::Bool(true)), ("light:materialSyncMode", Value::Token("glowy".into()))]), &mut p).unwrap();
        assert_eq!(ml.mode, MeshLightMode::MaterialGlowTintsLight);
        assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), ["light:materialSyncMode"]);
    }

    #[test]
    fn diffuse_and_specular_multipliers_are_read() {
        let mut p = Problems::new("/L");
        let l = convert_light("/L", LightKind::Rect, &st(&[("inputs:diffuse", f(0.5)), ("inputs:specular", f(0.0))]), &mut p).unwrap();
        assert_eq!((l.desc.response.diffuse, l.desc.response.specular), (0.5, 0.0));
        assert!(convert_light("/L", LightKind::Rect, &st(&[]), &mut p).unwrap().desc.response.is_physical());
        assert!(p.list.is_empty());
        let l = convert_light("/L", LightKind::Rect, &st(&[("inputs:specular", f(-2.0))]), &mut p).unwrap();
        assert_eq!(l.desc.response.specular, 1.0);
        assert_eq!(p.list[0].attribute, "specular");
    }

    #[test]
    fn shadow_api_turns_the_lights_shadows_off_and_shapes_them() {
        let mut p = Problems::new("/L");
        let on = convert_light("/L", LightKind::Sphere, &st(&[("inputs:shadow:enable", Value::Bool(true)), ("inputs:shadow:color", Value::Floats { data: vec![0.0; 3], tuple: 3 }), ("inputs:shadow:distance", f(-1.0))]), &mut p).unwrap();
        assert!(on.shadow_link.is_none());
        assert!(p.list.is_empty(), "{:?}", p.list);
        // off: an empty shadow-link collection, which no prim belongs to (even where a
        // shadowLink collection is authored too)
        let off = convert_light("/L", LightKind::Rect, &st(&[("inputs:shadow:enable", Value::Bool(false)), ("collection:shadowLink:includeRoot", Value::Bool(true))]), &mut p).unwrap();
        let c = off.shadow_link.unwrap();
        assert!(!c.contains("/World") && !c.contains("/World/Ball"));
        // the colour, distance and falloff are carried; a colour outside [0, 1] and a gamma
        // not above 0 are named
        let l = convert_light("/L", LightKind::Disk, &st(&[("inputs:shadow:color", Value::Floats { data: vec![0.2, 0.0, 0.0], tuple: 3 }), ("inputs:shadow:distance", f(3.0)), ("inputs:shadow:falloff", f(0.5)), ("inputs:shadow:falloffGamma", f(2.0))]), &mut p).unwrap();
        assert!(p.list.is_empty(), "{:?}", p.list);
        assert_eq!(l.desc.shadow, ShadowDesc { color: [0.2, 0.0, 0.0], distance: 3.0, falloff: 0.5, falloff_gamma: 2.0 });
        assert_eq!(on.desc.shadow, ShadowDesc::default());
        let l = convert_light("/L", LightKind::Disk, &st(&[("inputs:shadow:color", Value::Floats { data: vec![2.0, -1.0, 0.5], tuple: 3 }), ("inputs:shadow:falloffGamma", f(0.0))]), &mut p).unwrap();
        assert_eq!((l.desc.shadow.color, l.desc.shadow.falloff_gamma), ([1.0, 0.0, 0.5], 1.0));
        let attrs: Vec<&str> = p.list.iter().map(|q| q.attribute.as_str()).collect();
        assert_eq!(attrs, ["shadow:color", "shadow:falloffGamma"]);
    }

    #[test]
    fn light_link_collections_resolve_by_nearest_ancestor() {
        let paths = |v: &[&str]| Value::Paths(v.iter().map(|s| s.to_string()).collect());
        let mut p = Problems::new("/L");
        let l = convert_light(
            "/L",
            LightKind::Sphere,
            &st(&[
                ("collection:lightLink:includes", paths(&["/World/a", "/World/b/keep"])),
                ("collection:lightLink:excludes", paths(&["/World/b"])),
                ("collection:lightLink:includeRoot", Value::Bool(false)),
            ]),
            &mut p,
        )
        .unwrap();
        assert!(l.shadow_link.is_none());
        let c = l.light_link.unwrap();
        assert!(c.contains("/World/a") && c.contains("/World/a/mesh"));
        assert!(!c.contains("/World/ab") && !c.contains("/World/c"));
        assert!(!c.contains("/World/b") && !c.contains("/World/b/x"));
        assert!(c.contains("/World/b/keep/mesh"));
        let all_but = Collection { includes: vec![], excludes: vec!["/World/b".into()], include_root: true, explicit_only: false };
        assert!(all_but.contains("/World/c") && !all_but.contains("/World/b/x"));
        let explicit = Collection { explicit_only: true, include_root: true, ..c };
        assert!(explicit.contains("/World/a") && !explicit.contains("/World/a/mesh"));
        assert!(p.list.is_empty(), "{:?}", p.list);
    }

    #[test]
    fn camera_keeps_usd_units_and_rejects_zero_aperture() {
        let mut p = Problems::new("/cam");
        let c = convert_camera(
            "/cam",
            &st(&[
                ("focalLength", f(35.0)),
                ("horizontalAperture", f(36.0)),
                ("verticalAperture", f(0.0)),
                ("fStop", f(2.8)),
                ("focusDistance", f(5.0)),
                ("clippingRange", Value::Floats { data: vec![0.1, 100.0], tuple: 2 }),
                ("shutter:open", f(-0.25)),
                ("shutter:close", f(0.25)),
                ("projection", Value::Token("orthographic".into())),
                ("tide:medium", Value::Path("/Looks/Sea".into())),
            ]),
            &mut p,
        );
        assert_eq!((c.desc.focal_length, c.desc.horizontal_aperture), (35.0, 36.0));
        assert_eq!(c.desc.vertical_aperture, CameraDesc::default().vertical_aperture);
        assert_eq!((c.desc.f_stop, c.desc.focus_distance, c.desc.clipping_range), (2.8, 5.0, [0.1, 100.0]));
        assert_eq!((c.desc.shutter_open, c.desc.shutter_close, c.desc.projection), (-0.25, 0.25, Projection::Orthographic));
        assert_eq!(c.medium.as_deref(), Some("/Looks/Sea"));
        assert_eq!(p.list.len(), 1);
        assert_eq!((p.list[0].item.as_str(), p.list[0].attribute.as_str()), ("/cam", "verticalAperture"));
    }

    /// A negative or non-finite `fStop` or `focusDistance` is named and turns depth of field
    /// off, as 0 does (it was turned off silently).
    #[test]
    fn camera_names_a_negative_lens() {
        for (stop, focus, bad) in [(-4.0, 20.0, "fStop"), (2.8, -20.0, "focusDistance"), (f64::NAN, 20.0, "fStop")] {
            let mut p = Problems::new("/cam");
            let c = convert_camera("/cam", &st(&[("fStop", f(stop)), ("focusDistance", f(focus))]), &mut p);
            assert_eq!(p.list.iter().map(|q| (q.item.as_str(), q.attribute.as_str())).collect::<Vec<_>>(), [("/cam", bad)]);
            assert!(stop.is_nan() || p.list[0].message.contains("no depth of field"), "{}", p.list[0].message);
            assert!(c.desc.f_stop == 0.0 || c.desc.focus_distance == 0.0);
        }
        let mut p = Problems::new("/cam");
        let c = convert_camera("/cam", &st(&[("fStop", f(0.0)), ("focusDistance", f(0.0))]), &mut p);
        assert!(p.list.is_empty() && c.desc.f_stop == 0.0, "{:?}", p.list);
    }

    /// No samples, a negative or non-finite budget are named and replaced (0 samples rendered
    /// a black image).
    #[test]
    fn degenerate_sample_counts_and_budgets_are_named_and_replaced() {
        for (samples, budget, spp, kept_budget, named) in [
            (0, 1.5, 64, 1.5, vec!["tide:samples"]),
            (-5, -1.0, 64, 0.0, vec!["tide:samples", "tide:time:budget"]),
            (3, f64::NAN, 3, 0.0, vec!["tide:time:budget"]),
            (1, 0.0, 1, 0.0, vec![]),
        ] {
            let mut p = Problems::new("/Render/S");
            let s = convert_settings(&st(&[("tide:samples", Value::Int(samples)), ("tide:time:budget", f(budget))]), &mut p);
            assert_eq!((s.settings.spp, s.settings.time_budget_s), (spp, kept_budget));
            assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), named, "{:?}", p.list);
        }
    }

    // A resolution no image can have (over 65536 pixels a side, or not positive) is reported
    // on the settings and replaced by the default; a product's is ignored (its settings' rule).
    #[test]
    fn a_resolution_over_the_largest_image_is_replaced() {
        for bad in [vec![65_537, 100], vec![100, 1 << 20], vec![0, 10], vec![-4, 10]] {
            let mut p = Problems::new("/Render/S");
            let s = convert_settings(
                &st(&[
                    ("resolution", Value::Ints(bad.clone())),
                    ("products", Value::Paths(vec!["/Render/P".into()])),
                    ("/Render/P.resolution", Value::Ints(bad.clone())),
                ]),
                &mut p,
            );
            let d = RenderSettings::default();
            assert_eq!((s.settings.width, s.settings.height, s.resolution_authored), (d.width, d.height, false), "{bad:?}");
            assert_eq!(s.products[0].resolution, None, "{bad:?}");
            assert_eq!(p.list.len(), 1, "{:?}", p.list);
            assert!(p.list[0].attribute == "resolution" && p.list[0].message.contains("65536"), "{:?}", p.list);
        }
        let mut p = Problems::new("/Render/S");
        let s = convert_settings(&st(&[("resolution", Value::Ints(vec![65_536, 1]))]), &mut p);
        assert!(p.list.is_empty() && (s.settings.width, s.settings.height) == (65_536, 1));
    }

    #[test]
    fn render_settings_and_products() {
        let mut p = Problems::new("/Render/S");
        let s = convert_settings(
            &st(&[
                ("resolution", Value::Ints(vec![320, 240])),
                ("tide:samples", Value::Int(16)),
                ("tide:maxDepth", Value::Int(8)),
                ("tide:seed", Value::Int(7)),
                ("tide:time:budget", f(2.0)),
                ("disableMotionBlur", Value::Bool(true)),
                ("camera", Value::Path("/cam".into())),
                ("renderingColorSpace", Value::Token("ACEScg".into())),
                ("products", Value::Paths(vec!["/Render/P".into()])),
                ("/Render/P.productName", Value::String("out.exr".into())),
                ("/Render/P.orderedVars", Value::Paths(vec!["/Render/P/color".into(), "/Render/P/depth".into()])),
                ("/Render/P/color.sourceName", Value::String("color".into())),
                ("/Render/P/depth.sourceName", Value::String("depth".into())),
            ]),
            &mut p,
        );
        assert!(p.list.is_empty(), "{:?}", p.list);
        assert_eq!((s.settings.width, s.settings.height, s.settings.spp, s.settings.max_depth, s.settings.seed), (320, 240, 16, 8, 7));
        assert!(s.settings.disable_motion_blur && s.resolution_authored);
        assert_eq!((s.settings.time_budget_s, s.color_space, s.camera.as_deref()), (2.0, ColorSpace::AcesCg, Some("/cam")));
        assert_eq!(s.products[0].product_name, "out.exr");
        let aovs: Vec<_> = s.products[0].vars.iter().map(|v| v.aov).collect();
        assert_eq!(aovs, vec![Some(tide_core::Aov::Color), Some(tide_core::Aov::Depth)]);
    }

    #[test]
    fn rendering_color_spaces_by_their_names() {
        for (name, want) in [
            ("lin_rec709_scene", Some(ColorSpace::LinearRec709)),
            ("Linear Rec.709 (sRGB)", Some(ColorSpace::LinearRec709)),
            ("ACEScg", Some(ColorSpace::AcesCg)),
            ("lin_ap1_scene", Some(ColorSpace::AcesCg)),
            ("lin_rec2020_scene", Some(ColorSpace::LinearRec2020)),
            ("lin_rec2020", Some(ColorSpace::LinearRec2020)),
            ("srgb_texture", None),
            ("srgb_rec709_scene", None),
            ("g22_rec709_scene", None),
            ("lin_ap0_scene", None),
        ] {
            assert_eq!(rendering_color_space(name), want, "{name}");
        }
        let mut p = Problems::new("/Render/S");
        let s = convert_settings(&st(&[("renderingColorSpace", Value::Token("srgb_rec709_scene".into()))]), &mut p);
        assert_eq!(s.color_space, ColorSpace::LinearRec709);
        assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), ["renderingColorSpace"]);
    }

    /// A path depth past MAX_PATH_DEPTH (2^31 bounces never end in a scattering medium of
    /// albedo 1, and a render cannot stop mid-pass), or a pixel aspect ratio an OpenEXR file
    /// cannot hold (the render finished, then failed to write), is named and replaced.
    #[test]
    fn settings_past_what_a_render_can_finish_or_write_are_named() {
        for (depth, want, named) in [(1 << 16, 1 << 16, false), ((1 << 16) + 1, 1 << 16, true), (i32::MAX as i64, 1 << 16, true)] {
            let mut p = Problems::new("/Render/S");
            let s = convert_settings(&st(&[("tide:maxDepth", Value::Int(depth))]), &mut p);
            assert_eq!(s.settings.max_depth, want);
            assert_eq!(p.list.iter().any(|q| q.attribute == "tide:maxDepth"), named, "{:?}", p.list);
        }
        for (par, want, named) in [(1e6, 1e6, false), (1e-6, 1e-6, false), (1e7, 1.0, true), (1e-7, 1.0, true), (f64::INFINITY, 1.0, true), (0.0, 1.0, true)] {
            let mut p = Problems::new("/Render/S");
            let s = convert_settings(&st(&[("pixelAspectRatio", f(par))]), &mut p);
            assert_eq!(s.settings.pixel_aspect_ratio, want as f32);
            assert_eq!(p.list.iter().any(|q| q.attribute == "pixelAspectRatio"), named, "{par}: {:?}", p.list);
        }
    }

    #[test]
    fn pixel_filter_and_adaptive_settings() {
        use tide_core::filter::FilterKind;
        let mut p = Problems::new("/Render/S");
        let s = convert_settings(
            &st(&[
                ("tide:pixelFilter", Value::Token("box".into())),
                ("tide:adaptive:threshold", f(0.02)),
                ("tide:adaptive:minSamples", Value::Int(32)),
            ]),
            &mut p,
        );
        assert!(p.list.is_empty(), "{:?}", p.list);
        assert_eq!((s.settings.pixel_filter.kind, s.settings.pixel_filter.width), (FilterKind::Box, 1.0));
        assert_eq!((s.settings.adaptive_threshold, s.settings.adaptive_min_spp), (0.02, 32));
        // defaults: the pixel's box, adaptive sampling off
        let d = convert_settings(&st(&[]), &mut Problems::new("/Render/S"));
        assert_eq!((d.settings.pixel_filter.kind, d.settings.pixel_filter.width, d.settings.adaptive_threshold), (FilterKind::Box, 1.0, 0.0));
        // bad values: each named, the rest kept
        let mut p = Problems::new("/Render/S");
        let s = convert_settings(
            &st(&[
                ("tide:pixelFilter", Value::Token("mitchell".into())),
                ("tide:pixelFilter:width", f(-2.0)),
                ("tide:adaptive:threshold", f(-1.0)),
            ]),
            &mut p,
        );
        let attrs: Vec<&str> = p.list.iter().map(|q| q.attribute.as_str()).collect();
        assert_eq!(attrs, vec!["tide:adaptive:threshold", "tide:pixelFilter", "tide:pixelFilter:width"]);
        assert_eq!((s.settings.pixel_filter.kind, s.settings.pixel_filter.width, s.settings.adaptive_threshold), (FilterKind::Box, 1.0, 0.0));
    }
}
