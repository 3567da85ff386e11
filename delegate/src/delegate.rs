//! The delegate: prims keyed by SdfPath with Hydra-like create / set / dirty / sync / destroy.
//!
//! Every prim keeps its attributes ([`AttrStore`]); edits mark it dirty. [`Delegate::commit_resources`]
//! re-converts only the dirty prims into cached pieces (a mesh, a material, a light, ...) and
//! then assembles the [`SceneDesc`] from all caches. Cross-prim references (material bindings,
//! the camera's medium, textures) are resolved at assembly by path, so destroying or
//! re-creating one prim never forces another to re-convert: a mesh whose material is gone falls
//! back to its `displayColor` or the default material, and re-binds when the material returns.
//!
//! Times: transform samples and the camera shutter are authored in frames (offsets from the
//! current frame); the assembly turns them into seconds with the settings' `timeCodesPerSecond`.
//! Without motion blur (`disableMotionBlur`, or an instantaneous shutter) every transform is
//! evaluated at the current frame.

use crate::implicit::{self, PointsData};
use crate::lux::{self, CameraPiece, LightKind, LightPiece, SettingsPiece};
use crate::material::{self, default_material, MaterialPiece, TexKey, TexState};
use crate::mesh;
use crate::ocean::{self, OceanKey, OceanMeshes, OceanSpec};
use crate::render_pass::{core_factory, film_window, Binding, ClipDepth, EngineFactory, Job, MappedBuffer, Output, PassStatus, PassWatcher, RenderBuffer, RenderPass};
use crate::value::{about, normalize_name, AttrStore, Interpolation, Primvar, Problems, Value};
use crate::volume::{self, GridKey, GridState, VolumeSpec};
use glam::{DMat4, DVec3, Mat4, Vec3};
use std::collections::{BTreeMap, BTreeSet, HashMap, HashSet};
use std::sync::Arc;
use std::time::Duration;
use tide_core::light::dome_format::DomeFormat;
use tide_core::texture::CODES16;
use tide_core::texture::Texels;
use tide_core::scene::{GeometryRef, InstanceDesc, InstancePrimvars, LightShape, MeshDesc, PrimvarData, SpheresDesc, SurfaceDesc, SurfaceModel, TextureDesc};
use tide_core::{Aov, Problem, RenderSettings, SampleFormat, SceneDesc};

/// Which Hydra prim family a type belongs to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrimClass {
    Rprim,
    Sprim,
    Bprim,
}

/// The prim types of the protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrimType {
    Mesh,
    BasisCurves,
    Points,
    Sphere,
    Cube,
    Cylinder,
    Cone,
    Capsule,
    Plane,
    TideOcean,
    Volume,
    Camera,
    Material,
    Light(LightKind),
    /// A `UsdLuxPortalLight`: it guides domes' sampling and emits nothing.
    Portal,
    RenderSettings,
    RenderBuffer,
}

impl PrimType {
    pub fn parse(s: &str) -> Option<PrimType> {
        Some(match s {
            "mesh" => PrimType::Mesh,
            "basisCurves" => PrimType::BasisCurves,
            "points" => PrimType::Points,
            "sphere" => PrimType::Sphere,
            "cube" => PrimType::Cube,
            "cylinder" => PrimType::Cylinder,
            "cone" => PrimType::Cone,
            "capsule" => PrimType::Capsule,
            "plane" => PrimType::Plane,
            "tideOcean" => PrimType::TideOcean,
            "volume" => PrimType::Volume,
            "camera" => PrimType::Camera,
            "material" => PrimType::Material,
            "distantLight" => PrimType::Light(LightKind::Distant),
            "domeLight" => PrimType::Light(LightKind::Dome),
            "sphereLight" => PrimType::Light(LightKind::Sphere),
            "rectLight" => PrimType::Light(LightKind::Rect),
            "diskLight" => PrimType::Light(LightKind::Disk),
            "cylinderLight" => PrimType::Light(LightKind::Cylinder),
            "portalLight" => PrimType::Portal,
            "renderSettings" => PrimType::RenderSettings,
            "renderBuffer" => PrimType::RenderBuffer,
            _ => return None,
        })
    }

    pub fn class(self) -> PrimClass {
        match self {
            PrimType::Camera | PrimType::Material | PrimType::Light(_) | PrimType::Portal | PrimType::RenderSettings => PrimClass::Sprim,
            PrimType::RenderBuffer => PrimClass::Bprim,
            _ => PrimClass::Rprim,
        }
    }
}

struct Prim {
    ty: PrimType,
    store: AttrStore,
    /// Stable id for the `primId` AOV when `primId` is not authored.
    id: u32,
}

/// Rprim attributes that place or bind a prim without changing its geometry: editing only
/// these re-syncs the prim but keeps its converted points and triangles.
const PLACEMENT_ATTRIBUTES: &[&str] = &["transform", "visibility", "purpose", "renderTag", "material", "primId", "instanceTransforms", "instancePaths", "instanceIndices"];

/// A material's displacement in one assembly.
struct Displacement<'a> {
    /// Over the scene's textures.
    d: tide_core::scene::FloatInput,
    /// Over the material's own texture list, and that list.
    local: tide_core::scene::FloatInput,
    textures: Vec<TextureDesc>,
    material: &'a str,
}

/// A mesh displaced by a material, kept for the next assembly.
struct Displaced {
    src: Arc<MeshDesc>,
    local: tide_core::scene::FloatInput,
    textures: Vec<TextureDesc>,
    out: Arc<MeshDesc>,
}

impl Displaced {
    /// Whether displacing `src` by `d` makes this mesh: the same mesh (shared), the same
    /// displacement over the same textures (the same shared pixels).
    fn made_of(&self, src: &Arc<MeshDesc>, d: &Displacement) -> bool {
        let same = |a: &TextureDesc, b: &TextureDesc| {
            a.pixels.same(&b.pixels) && (&a.name, a.width, a.height, a.channels, a.wrap_s, a.wrap_t) == (&b.name, b.width, b.height, b.channels, b.wrap_s, b.wrap_t)
        };
        Arc::ptr_eq(&self.src, src) && self.local == d.local && self.textures.len() == d.textures.len() && self.textures.iter().zip(&d.textures).all(|(a, b)| same(a, b))
    }
}

/// Geometry of a converted rprim.
#[derive(Clone, Debug, PartialEq)]
enum Geometry {
    None,
    Mesh(Arc<MeshDesc>),
    /// A mesh prim: its points may move (time samples or velocities; keys are made at
    /// assembly, for the shutter) and GeomSubsets may bind other materials to some faces.
    UsdMesh(Box<mesh::MeshGeom>),
    Spheres(Arc<SpheresDesc>),
    Points(PointsData),
    /// A `tideOcean`: its mesh is built at assembly, around the render camera.
    Ocean(OceanSpec),
    /// A `volume`: its grid is looked up at assembly (grids arrive with `add_grid`).
    Volume(VolumeSpec),
}

impl Geometry {
    /// Whether the geometry carries primvar `name` per element (not constant).
    fn carries_varying(&self, name: &str) -> bool {
        let pvs = match self {
            Geometry::Mesh(m) => &m.primvars,
            Geometry::UsdMesh(g) => &g.mesh.primvars,
            Geometry::Spheres(s) => &s.primvars,
            Geometry::Points(p) => &p.spheres.primvars,
            _ => return false,
        };
        pvs.iter().any(|p| p.name == name && !p.constant)
    }
}

/// The kept instances' matrices of `instanceTransforms`, read from the attribute's own
/// (shared) numbers rather than copied: a million instances' matrices are held once by the
/// delegate.
#[derive(Clone, Debug, PartialEq)]
enum InstanceMats {
    /// One matrix (a prim drawn once: the identity).
    One(DMat4),
    /// Column-major matrices, 16 numbers each, and the kept ones (all when None).
    Shared { data: Arc<[f64]>, kept: Option<Arc<[u32]>> },
}

impl InstanceMats {
    fn len(&self) -> usize {
        match self {
            InstanceMats::One(_) => 1,
            InstanceMats::Shared { data, kept } => kept.as_ref().map_or(data.len() / 16, |k| k.len()),
        }
    }

    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Kept instance `k`'s matrix.
    fn get(&self, k: usize) -> Option<DMat4> {
        match self {
            InstanceMats::One(m) => (k == 0).then_some(*m),
            InstanceMats::Shared { data, kept } => {
                let i = match kept {
                    Some(kept) => *kept.get(k)? as usize,
                    None => k,
                };
                data.get(16 * i..16 * i + 16).map(DMat4::from_cols_slice)
            }
        }
    }

    fn first(&self) -> Option<DMat4> {
        self.get(0)
    }

    fn iter(&self) -> impl Iterator<Item = DMat4> + '_ {
        (0..self.len()).map(|k| self.get(k).expect("a kept instance"))
    }
}

#[derive(Clone, Debug, PartialEq)]
struct RprimPiece {
    /// Shared with the next conversion when only placement attributes change.
    geometry: Arc<Geometry>,
    /// The problems found converting the geometry (kept with it when it is reused).
    geometry_problems: Vec<Problem>,
    /// (frame offset, object-to-world), in double precision as every world matrix here: the
    /// assembly places them about the scene's origin.
    transforms: Vec<(f64, DMat4)>,
    instance_transforms: InstanceMats,
    /// Time samples of `instanceTransforms` (frame offset, one matrix per instance), when
    /// they move; empty otherwise.
    instance_samples: Vec<(f64, Vec<DMat4>)>,
    material: Option<String>,
    /// `displayColor`, the colour of an unbound gprim: constant, or its average where it
    /// varies (the geometry then carries it, when it can, for the fallback material to read).
    display_color: Option<[f32; 3]>,
    /// `displayOpacity`, likewise: constant, or its average where it varies.
    display_opacity: Option<f32>,
    visible: bool,
    purpose: String,
    /// Hydra's render tag (UsdImaging's from the purpose), where the host gives one: the prim
    /// is rendered by passes whose tags include it ([`Delegate::set_render_tags`]).
    render_tag: Option<String>,
    id: u32,
    /// `TideCausticsAPI` attributes where any is authored.
    caustics: Option<tide_core::scene::ObjectCaustics>,
    /// UsdLuxMeshLightAPI: the mesh emits.
    mesh_light: Option<lux::MeshLight>,
    /// Per-instance primvars, one row per kept instance.
    instance_primvars: Vec<PrimvarData>,
    /// Each kept instance's index among the authored `instanceTransforms` (the `instanceId`
    /// AOV); empty where none are authored.
    instance_index: Vec<u32>,
    /// The prim path each kept instance stands for in collections (`instancePaths`: a native
    /// instance's proxy path, so a light can link some instances of a prototype and not
    /// others); empty: the prim's own path for all.
    instance_link_paths: Vec<String>,
}

#[derive(Clone, Debug, PartialEq)]
enum Piece {
    Rprim(RprimPiece),
    Material(MaterialPiece),
    Light(Option<LightPiece>),
    Portal(Option<lux::PortalPiece>),
    Camera(CameraPiece),
    Settings(SettingsPiece),
    Buffer,
}

/// (scene generation, AOV bindings, settings) of a started job.
type JobKey = (u64, Vec<(Binding, String)>, RenderSettings);

struct Cached {
    piece: Piece,
    problems: Vec<Problem>,
}

/// The Rust side of the render delegate. See the crate's README for the protocol.
pub struct Delegate {
    prims: BTreeMap<String, Prim>,
    cache: BTreeMap<String, Cached>,
    dirty: BTreeSet<String>,
    /// Dirty prims whose geometry must be converted again (not only their placement).
    geometry_dirty: BTreeSet<String>,
    structure_changed: bool,
    textures: HashMap<String, TexState>,
    pending: Vec<Problem>,
    assembly_problems: Vec<Problem>,
    last_synced: Vec<String>,
    /// The `primId` of every path ever created: a prim re-created at a path keeps its id.
    ids: HashMap<String, u32>,
    scene: Arc<SceneDesc>,
    scene_generation: u64,
    /// Bumped by every assembly whose scene differs from the one before in more than its
    /// camera: a render job's [`crate::render_pass::Job::world`].
    world_generation: u64,
    /// The camera-side inputs of the last assembly that place the rest of the scene: shutter
    /// open and close (frames), time codes per second, motion blur on, the scene's origin.
    view_inputs: Option<(u64, u64, u64, bool, [u64; 3])>,
    settings: SettingsPiece,
    active_camera: Option<String>,
    active_settings: Option<String>,
    /// The render tags of the pass (Hydra's `Execute`): None renders every prim's.
    render_tags: Option<Vec<String>>,
    /// `render_tags` changed since the last assembly.
    render_tags_changed: bool,
    buffers: BTreeMap<String, RenderBuffer>,
    factory: EngineFactory,
    pass: Option<RenderPass>,
    /// Rendering is paused ([`Delegate::pause_render`]): a pass made later starts paused.
    paused: bool,
    /// Rendering is stopped ([`Delegate::stop_render`]): executions only note the job that
    /// [`Delegate::restart_render`] starts.
    stopped: bool,
    /// The engines' problems already returned by [`Delegate::commit_resources`] or
    /// [`Delegate::check_render`] (each is returned once).
    engine_reported: HashSet<Problem>,
    /// What the running job was started from: (scene generation, bindings, settings).
    job_key: Option<JobKey>,
    /// The projection matrix of the last `execute_as` (a Hydra pass's), framing the image.
    pass_projection: Option<[f64; 16]>,
    /// Built ocean meshes by prim path, with the key they were built for and their problems.
    oceans: HashMap<String, (OceanKey, Arc<OceanMeshes>, Vec<Problem>)>,
    /// Textures as the last assembly used them (linearised, domes made lat-long), each with the
    /// pixels it was made from: an assembly shares them instead of converting again.
    converted_textures: HashMap<TexKey, (Texels, TextureDesc)>,
    /// Meshes as the last assembly displaced them, by (source mesh, material path).
    displaced_meshes: HashMap<(usize, String), Displaced>,
    /// Grids of volumes by (file, field name, field index), each read once.
    grids: HashMap<GridKey, GridState>,
}

impl Default for Delegate {
    fn default() -> Self {
        Delegate::new()
    }
}

fn problem(item: &str, attribute: &str, message: impl Into<String>) -> Problem {
    Problem { item: item.into(), attribute: attribute.into(), message: message.into() }
}


/// Matrix at frame `t` from sorted samples (element-wise linear between neighbours).
fn matrix_at(samples: &[(f64, DMat4)], t: f64) -> DMat4 {
    let Some(i) = samples.iter().position(|s| s.0 >= t) else { return samples.last().map_or(DMat4::IDENTITY, |s| s.1) };
    if i == 0 || samples[i].0 == t {
        return samples[i].1;
    }
    let (a, b) = (samples[i - 1], samples[i]);
    let w = (t - a.0) / (b.0 - a.0);
    a.1 * (1.0 - w) + b.1 * w
}

/// Matrix at frame `t` from sorted samples interpolated as the core interpolates motion
/// (`tide_core::accel::motion`: scale and translation linearly, rotation by slerp; element-wise
/// where a sample does not decompose), in double precision.
fn motion_at(samples: &[(f64, DMat4)], t: f64) -> DMat4 {
    let Some(i) = samples.iter().position(|s| s.0 >= t) else { return samples.last().map_or(DMat4::IDENTITY, |s| s.1) };
    if i == 0 || samples[i].0 == t {
        return samples[i].1;
    }
    let decompose = |m: &DMat4| {
        let (s, r, tr) = m.to_scale_rotation_translation();
        let tol = 1e-4 * (1.0 + m.to_cols_array().iter().fold(0.0f64, |a, v| a.max(v.abs())));
        DMat4::from_scale_rotation_translation(s, r, tr).abs_diff_eq(*m, tol).then_some((s, r, tr))
    };
    let shears = samples.iter().any(|s| decompose(&s.1).is_none());
    let (a, b) = (samples[i - 1], samples[i]);
    let w = (t - a.0) / (b.0 - a.0);
    match (shears, decompose(&a.1), decompose(&b.1)) {
        (false, Some((sa, ra, ta)), Some((sb, rb, tb))) => DMat4::from_scale_rotation_translation(sa.lerp(sb, w), ra.slerp(rb, w), ta.lerp(tb, w)),
        _ => a.1 * (1.0 - w) + b.1 * w,
    }
}

/// World samples of instance `k` of a prim whose `instanceTransforms` move: at every sample
/// time of either the prim's transform or the instance matrices, the instance matrix applied
/// after the transform, each interpolated between its own samples as the core interpolates
/// motion (rotation on the sphere).
fn moving_instance(transforms: &[(f64, DMat4)], instance_samples: &[(f64, Vec<DMat4>)], k: usize) -> Vec<(f64, DMat4)> {
    let inst: Vec<(f64, DMat4)> = instance_samples.iter().map(|s| (s.0, s.1[k])).collect();
    let mut times: Vec<f64> = instance_samples.iter().map(|s| s.0).collect();
    if transforms.len() > 1 {
        times.extend(transforms.iter().map(|s| s.0));
    }
    times.sort_by(|a, b| a.total_cmp(b));
    times.dedup();
    times.into_iter().map(|t| (t, motion_at(&inst, t) * motion_at(transforms, t))).collect()
}

/// The cells the scene's origin snaps to are this many times the camera's near clipping
/// distance wide (see [`scene_origin`]), within [`ORIGIN_CELL_METRES`].
pub const ORIGIN_CELL_PER_NEAR: f64 = 1024.0;

/// The smallest and largest cells, in metres.
pub const ORIGIN_CELL_METRES: (f64, f64) = (1e-3, 256.0);

/// Where the scene is placed about: the camera's position at the frame to the nearest corner
/// of a grid of cells, or the world's origin without a camera. Far from the world's origin
/// single precision cannot hold positions finely (10⁵ units from it, its steps are 8·10⁻³
/// units); about this point what lies near the camera stays within a cell's width of it.
///
/// A cell is [`ORIGIN_CELL_PER_NEAR`] times the camera's near clipping distance `near` (scene
/// units) wide, to a power of two, and 1 mm to 256 m (from `meters_per_unit`): positions at
/// the camera are held to about 5·10⁻⁵ of the nearest distance it renders (0.87 × 1024 near ×
/// 2⁻²⁴), and error grows with the distance from the camera, as what a pixel covers does. A
/// macro camera (near 1 cm) snaps to 8 m cells, a camera with USD's default near of 1 m to
/// 256 m ones. Snapped, the origin stays put while the camera moves within its cell, so a
/// camera move rarely rebuilds the world; a scene whose camera is within half a cell of the
/// world's origin is placed as authored.
pub fn scene_origin(camera: Option<DVec3>, near: f64, meters_per_unit: f64) -> DVec3 {
    let pow2 = |units: f64| units.log2().round().exp2();
    let (lo, hi) = (pow2(ORIGIN_CELL_METRES.0 / meters_per_unit), pow2(ORIGIN_CELL_METRES.1 / meters_per_unit));
    let wanted = pow2(near * ORIGIN_CELL_PER_NEAR);
    let cell = if wanted.is_finite() && wanted > 0.0 { wanted.clamp(lo, hi) } else { hi };
    match camera.filter(|c| c.is_finite()) {
        Some(c) if cell.is_finite() && cell > 0.0 => (c / cell).round() * cell,
        _ => DVec3::ZERO,
    }
}

impl Delegate {
    /// A delegate rendering with the core renderer.
    pub fn new() -> Delegate {
        Delegate::with_engine(core_factory())
    }

    /// A delegate rendering with another engine (tests, previews).
    pub fn with_engine(factory: EngineFactory) -> Delegate {
        Delegate {
            prims: BTreeMap::new(),
            cache: BTreeMap::new(),
            dirty: BTreeSet::new(),
            geometry_dirty: BTreeSet::new(),
            structure_changed: false,
            textures: HashMap::new(),
            pending: Vec::new(),
            assembly_problems: Vec::new(),
            last_synced: Vec::new(),
            ids: HashMap::new(),
            scene: Arc::new(SceneDesc::default()),
            scene_generation: 0,
            world_generation: 0,
            view_inputs: None,
            settings: SettingsPiece::default(),
            active_camera: None,
            active_settings: None,
            render_tags: None,
            render_tags_changed: false,
            buffers: BTreeMap::new(),
            factory,
            pass: None,
            paused: false,
            stopped: false,
            engine_reported: HashSet::new(),
            job_key: None,
            pass_projection: None,
            oceans: HashMap::new(),
            converted_textures: HashMap::new(),
            displaced_meshes: HashMap::new(),
            grids: HashMap::new(),
        }
    }

    /// Creates (or re-creates, clearing its attributes) a prim. Unknown type → false + problem.
    pub fn create_prim(&mut self, type_name: &str, path: &str) -> bool {
        let Some(ty) = PrimType::parse(type_name) else {
            self.pending.push(problem(path, "type", format!("unknown prim type '{}'; the prim is ignored", type_name)));
            return false;
        };
        let next = self.ids.len() as u32;
        let id = *self.ids.entry(path.to_string()).or_insert(next);
        self.prims.insert(path.to_string(), Prim { ty, store: AttrStore::default(), id });
        if ty == PrimType::RenderBuffer {
            self.buffers.entry(path.to_string()).or_default();
        }
        self.dirty.insert(path.to_string());
        self.geometry_dirty.insert(path.to_string());
        true
    }

    /// Removes a prim (any order). False if it did not exist.
    pub fn destroy_prim(&mut self, path: &str) -> bool {
        let existed = self.prims.remove(path).is_some();
        self.cache.remove(path);
        self.dirty.remove(path);
        self.geometry_dirty.remove(path);
        self.buffers.remove(path);
        self.oceans.remove(path);
        if existed {
            self.structure_changed = true;
        }
        existed
    }

    pub fn has_prim(&self, path: &str) -> bool {
        self.prims.contains_key(path)
    }

    pub fn prim_type(&self, path: &str) -> Option<PrimType> {
        self.prims.get(path).map(|p| p.ty)
    }

    fn prim_mut(&mut self, path: &str, attr: &str) -> Option<&mut Prim> {
        if !self.prims.contains_key(path) {
            self.pending.push(problem(path, attr, "no such prim; the value is ignored"));
            return None;
        }
        self.dirty.insert(path.to_string());
        if !PLACEMENT_ATTRIBUTES.contains(&normalize_name(attr)) {
            self.geometry_dirty.insert(path.to_string());
        }
        self.prims.get_mut(path)
    }

    /// Sets an attribute (`time` = frame offset of a time sample, `None` = the value).
    pub fn set_attribute(&mut self, path: &str, name: &str, value: Value, time: Option<f64>) -> bool {
        let Some(prim) = self.prim_mut(path, name) else { return false };
        prim.store.attrs.entry(normalize_name(name).to_string()).or_default().set(time, value);
        true
    }

    /// Removes an attribute (back to its default).
    pub fn clear_attribute(&mut self, path: &str, name: &str) -> bool {
        let Some(prim) = self.prim_mut(path, name) else { return false };
        prim.store.attrs.remove(normalize_name(name)).is_some()
    }

    /// Sets a primvar (`primvars:` prefix optional). Interpolation `instance`: one element per
    /// instance of `instanceTransforms`.
    pub fn set_primvar(&mut self, path: &str, name: &str, interpolation: &str, data: Vec<f32>, tuple: u32, indices: Option<Vec<i32>>) -> bool {
        let name = name.strip_prefix("primvars:").unwrap_or(name);
        let per_instance = interpolation == "instance";
        let Some(interp) = Interpolation::parse(interpolation).or(per_instance.then_some(Interpolation::Constant)) else {
            self.pending.push(problem(path, name, format!("unknown interpolation '{}'; the primvar is ignored", interpolation)));
            return false;
        };
        if tuple == 0 {
            self.pending.push(problem(path, name, "tuple size 0; the primvar is ignored"));
            return false;
        }
        self.geometry_dirty.insert(path.to_string());
        let Some(prim) = self.prim_mut(path, name) else { return false };
        let map = if per_instance { &mut prim.store.instance_primvars } else { &mut prim.store.primvars };
        map.insert(name.to_string(), Primvar { interpolation: interp, data, tuple, indices });
        true
    }

    /// Marks a prim for re-sync without changing it.
    pub fn mark_dirty(&mut self, path: &str) {
        if self.prims.contains_key(path) {
            self.dirty.insert(path.to_string());
            self.geometry_dirty.insert(path.to_string());
        }
    }

    /// Dirties every material and light that mentions `asset`.
    fn dirty_users_of(&mut self, asset: &str) {
        for (path, prim) in &self.prims {
            if matches!(prim.ty, PrimType::Material | PrimType::Light(_))
                && prim.store.attrs.values().any(|a| a.current().and_then(|v| v.as_str()) == Some(asset))
            {
                self.dirty.insert(path.clone());
            }
        }
    }

    /// Provides a texture's decoded pixels (row-major from the top row). `is_srgb`: the file's
    /// colour space is sRGB (used when a UsdUVTexture's `sourceColorSpace` is `auto`);
    /// `wrapmodes`: the file's wrap metadata as OpenImageIO names it ("periodic,clamp"; empty
    /// if none), which a UsdUVTexture's `useMetadata` wrap follows. 2-channel (grey, alpha)
    /// images are expanded to RGBA. Bad sizes → false + problem.
    pub fn add_texture(&mut self, asset: &str, width: u32, height: u32, channels: u32, pixels: Vec<f32>, is_srgb: bool, wrapmodes: &str) -> bool {
        let pixels = grey_alpha_as_rgba(channels, pixels);
        self.add_texels(asset, width, height, channels, pixels.into(), is_srgb, wrapmodes)
    }

    /// [`Delegate::add_texture`] for an 8-bit file: its codes, which read as code / 255. They
    /// are held as they are (a quarter of the floats' memory) and shared by the materials
    /// decoding them by a transfer curve alone.
    pub fn add_texture_u8(&mut self, asset: &str, width: u32, height: u32, channels: u32, codes: Vec<u8>, is_srgb: bool, wrapmodes: &str) -> bool {
        let codes = grey_alpha_as_rgba(channels, codes);
        self.add_texels(asset, width, height, channels, Texels::unit_codes(Arc::new(codes)), is_srgb, wrapmodes)
    }

    /// [`Delegate::add_texture`] for a file of 16 bits in every channel: its codes, integers
    /// read as code / 65535 or, with `half`, half floats' bits. They are held as they are (half
    /// the floats' memory) and shared by the materials reading them undecoded (and, for large
    /// images, by those decoding them by a transfer curve alone).
    #[allow(clippy::too_many_arguments)]
    pub fn add_texture_u16(&mut self, asset: &str, width: u32, height: u32, channels: u32, codes: Vec<u16>, half: bool, is_srgb: bool, wrapmodes: &str) -> bool {
        let codes = Arc::new(grey_alpha_as_rgba(channels, codes));
        let texels = if half { Texels::halves(codes) } else { Texels::unit_codes16(codes) };
        self.add_texels(asset, width, height, channels, texels, is_srgb, wrapmodes)
    }

    /// A texture's values (2-channel ones of an even count already expanded to RGBA,
    /// `channels` still 2).
    fn add_texels(&mut self, asset: &str, width: u32, height: u32, channels: u32, pixels: Texels, is_srgb: bool, wrapmodes: &str) -> bool {
        let n = width as usize * height as usize;
        let held = if channels == 2 { 4 } else { channels };
        let state = if !(1..=4).contains(&channels) || n == 0 || pixels.len() != n * held as usize {
            let given = if channels == 2 { pixels.len() / 2 } else { pixels.len() };
            let msg = format!("{}x{} with {} channels does not match {} values", width, height, channels, given);
            self.pending.push(problem(asset, "pixels", msg.clone()));
            TexState::Failed(msg)
        } else {
            TexState::Loaded { width, height, channels: held, pixels, is_srgb, file_wrap: material::file_wrap_modes(wrapmodes) }
        };
        let ok = matches!(state, TexState::Loaded { .. });
        self.textures.insert(asset.to_string(), state);
        self.dirty_users_of(asset);
        ok
    }

    /// The pixels held for a texture as given to `add_texture` (2-channel images expanded to
    /// RGBA), with `samples` 0; None if the texture is unknown or failed.
    pub fn texture(&self, asset: &str) -> Option<MappedBuffer> {
        match self.textures.get(asset) {
            Some(TexState::Loaded { width, height, channels, pixels, .. }) => {
                Some(MappedBuffer { width: *width, height: *height, channels: *channels, pixels: pixels.to_f32(*channels as usize), samples: 0 })
            }
            _ => None,
        }
    }

    /// Provides a volume's grid read from `asset` (field `field`, the `index`-th of that name):
    /// `dims` values, x fastest, placed in the volume's space by `index_to_object` (USD-style
    /// matrix). Bad sizes or transform → false, and volumes reading it report the problem.
    pub fn add_grid(&mut self, asset: &str, field: &str, index: i64, dims: [u32; 3], values: Vec<f32>, index_to_object: [f64; 16]) -> bool {
        self.add_grid_data(asset, field, index, volume::grid_data(dims, values, index_to_object))
    }

    /// [`Delegate::add_grid`] from bricks as a reader hands them over
    /// ([`volume::grid_data_bricks`]).
    pub fn add_grid_bricks(&mut self, asset: &str, field: &str, index: i64, dims: [u32; 3], coords: &[u32], pool: Vec<f32>, index_to_object: [f64; 16]) -> bool {
        self.add_grid_data(asset, field, index, volume::grid_data_bricks(dims, coords, pool, index_to_object))
    }

    fn add_grid_data(&mut self, asset: &str, field: &str, index: i64, data: Result<volume::GridData, String>) -> bool {
        let state = match data {
            Ok(g) => GridState::Loaded(Arc::new(g)),
            Err(e) => GridState::Failed(e),
        };
        let ok = matches!(state, GridState::Loaded(_));
        self.grids.insert((asset.to_string(), field.to_string(), index), state);
        self.structure_changed = true;
        ok
    }

    /// The grid held for (file, field, index) as given to `add_grid`; None if unknown or failed.
    pub fn grid(&self, asset: &str, field: &str, index: i64) -> Option<Arc<volume::GridData>> {
        match self.grids.get(&(asset.to_string(), field.to_string(), index)) {
            Some(GridState::Loaded(g)) => Some(g.clone()),
            _ => None,
        }
    }

    /// Records that a volume's grid could not be read (missing file, missing field, wrong
    /// grid type); volumes reading it report `message` and are dropped.
    pub fn grid_failed(&mut self, asset: &str, field: &str, index: i64, message: &str) {
        self.grids.insert((asset.to_string(), field.to_string(), index), GridState::Failed(message.to_string()));
        self.structure_changed = true;
    }

    /// Whether a grid is held for (file, field, index), loaded or failed.
    pub fn has_grid(&self, asset: &str, field: &str, index: i64) -> bool {
        self.grids.contains_key(&(asset.to_string(), field.to_string(), index))
    }

    /// Records that a texture file could not be read.
    pub fn texture_failed(&mut self, asset: &str, message: &str) {
        self.textures.insert(asset.to_string(), TexState::Failed(message.to_string()));
        self.dirty_users_of(asset);
    }

    /// Converts a prim; `geometry` is an rprim's converted geometry (and its problems) to keep.
    fn convert(&self, path: &str, prim: &Prim, geometry: Option<(Arc<Geometry>, Vec<Problem>)>) -> Cached {
        let mut p = Problems::new(path);
        let s = &prim.store;
        let piece = match prim.ty {
            PrimType::Material => {
                let textures = |a: &str| self.textures.get(a).cloned();
                Piece::Material(material::convert_material(path, s, &textures, &mut p))
            }
            PrimType::Light(k) => Piece::Light(lux::convert_light(path, k, s, &mut p)),
            PrimType::Portal => Piece::Portal(lux::convert_portal(s, &mut p)),
            PrimType::Camera => Piece::Camera(lux::convert_camera(path, s, &mut p)),
            PrimType::RenderSettings => Piece::Settings(lux::convert_settings(s, &mut p)),
            PrimType::RenderBuffer => {
                let dims = s.get("dimensions").and_then(|v| v.to_ints());
                let buf = self.buffers.get(path);
                // the format's channels (a bound AOV's own count replaces them at its first pass)
                let channels = match s.str_opt("format").unwrap_or("float4") {
                    "float" | "int32" => 1,
                    "float2" => 2,
                    "float3" => 3,
                    _ => 4,
                };
                match dims {
                    Some(d) if d.len() == 2 && d[0] > 0 && d[1] > 0 => {
                        if let Some(b) = buf {
                            let (w, h, c) = b.shape();
                            if (w, h) != (d[0] as u32, d[1] as u32) || (c != channels && !b.published()) {
                                if let Err(e) = b.resize(d[0] as u32, d[1] as u32, channels) {
                                    p.add("dimensions", format!("{e}; the buffer stays empty"));
                                }
                            }
                        }
                    }
                    None => {}
                    Some(d) => p.add("dimensions", format!("expected two positive ints, got {:?}", d)),
                }
                let publish = s.bool_or("tide:publish", true, &mut p);
                let ints = s.str_opt("format").is_some_and(|f| f.starts_with("int"));
                if let Some(b) = buf {
                    b.set_publishes(publish);
                    b.set_holds_ints(ints);
                }
                Piece::Buffer
            }
            _ => Piece::Rprim(self.convert_rprim(path, prim, geometry, &mut p)),
        };
        Cached { piece, problems: p.list }
    }

    /// An rprim's geometry (points, triangles, spheres) from its attributes and primvars.
    fn convert_geometry(&self, path: &str, prim: &Prim, p: &mut Problems) -> Geometry {
        let s = &prim.store;
        let mut g = match prim.ty {
            PrimType::Mesh => Geometry::UsdMesh(Box::new(mesh::convert_usd_mesh(path, s, p))),
            PrimType::BasisCurves => Geometry::UsdMesh(Box::new(crate::curves::convert_curves(path, s, p))),
            PrimType::Points => Geometry::Points(implicit::points(path, s, p)),
            PrimType::Sphere => Geometry::Spheres(implicit::sphere(path, s, p).into()),
            PrimType::Cube => Geometry::Mesh(implicit::cube(path, s, p).into()),
            PrimType::Cylinder => Geometry::Mesh(implicit::cylinder(path, s, p).into()),
            PrimType::Cone => Geometry::Mesh(implicit::cone(path, s, p).into()),
            PrimType::Capsule => Geometry::Mesh(implicit::capsule(path, s, p).into()),
            PrimType::Plane => Geometry::Mesh(implicit::plane(path, s, p).into()),
            PrimType::TideOcean => Geometry::Ocean(ocean::ocean_spec(s, p)),
            PrimType::Volume => volume::volume_spec(s, p).map_or(Geometry::None, Geometry::Volume),
            _ => Geometry::None,
        };
        // implicit gprims carry their constant primvars (meshes, curves and points carry every
        // interpolation)
        match &mut g {
            Geometry::Mesh(m) => Arc::make_mut(m).primvars = mesh::constant_primvars(s, p),
            Geometry::Spheres(sp) => Arc::make_mut(sp).primvars = mesh::constant_primvars(s, p),
            _ => {}
        }
        g
    }

    fn convert_rprim(&self, path: &str, prim: &Prim, geometry: Option<(Arc<Geometry>, Vec<Problem>)>, p: &mut Problems) -> RprimPiece {
        let (geometry, geometry_problems) = geometry.unwrap_or_else(|| {
            let mut gp = Problems::new(path);
            let g = self.convert_geometry(path, prim, &mut gp);
            (Arc::new(g), gp.list)
        });
        p.list.extend(geometry_problems.iter().cloned());
        let s = &prim.store;
        let mut instance_transforms = InstanceMats::Shared { data: Arc::from(&[][..]), kept: None };
        let mut instance_samples = Vec::new();
        // the authored instances' count, and those kept
        let (mut n_instances, mut kept) = (1, vec![0]);
        if let Some(v) = s.get("instanceTransforms") {
            kept.clear();
            match v.f64s() {
                Some(d) if d.len() % 16 == 0 => {
                    // an instance whose matrix is not finite (in single precision too) at any
                    // time is dropped
                    let samples = &s.attr("instanceTransforms").map_or(&[][..], |a| &a.samples[..]);
                    let finite = |c: &[f64]| c.iter().all(|&x| (x as f32).is_finite());
                    // each sample's numbers once (not once an instance: a million moving
                    // instances took hours)
                    let sampled: Vec<Option<std::borrow::Cow<'_, [f64]>>> = samples.iter().map(|(_, v)| v.f64s()).collect();
                    let finite_at = |i: usize| sampled.iter().all(|d| d.as_ref().is_none_or(|d| d.get(16 * i..16 * i + 16).is_none_or(finite)));
                    n_instances = d.len() / 16;
                    for (i, c) in d.chunks_exact(16).enumerate() {
                        if finite(c) && finite_at(i) {
                            kept.push(i);
                        } else {
                            p.add("instanceTransforms", "a matrix is not finite; that instance is dropped");
                        }
                    }
                    // the attribute's own numbers where they are doubles already
                    let data: Arc<[f64]> = match v {
                        Value::Doubles { data, .. } => data.clone(),
                        _ => Arc::from(&d[..]),
                    };
                    let all = kept.len() == n_instances;
                    instance_transforms = InstanceMats::Shared { data, kept: (!all).then(|| kept.iter().map(|&i| i as u32).collect()) };
                    if samples.len() >= 2 {
                        let n = d.len() / 16;
                        let parsed: Option<Vec<(f64, Vec<DMat4>)>> = samples
                            .iter()
                            .zip(&sampled)
                            .map(|((t, _), d)| match d {
                                Some(d) if d.len() == 16 * n => Some((*t, kept.iter().map(|&i| DMat4::from_cols_slice(&d[16 * i..16 * i + 16])).collect())),
                                _ => None,
                            })
                            .collect();
                        match parsed {
                            Some(ps) if ps.windows(2).any(|w| w[0].1 != w[1].1) => instance_samples = ps,
                            Some(_) => {}
                            None => p.add("instanceTransforms", format!("time samples hold different numbers of matrices ({} at the current frame); the instances do not move", n)),
                        }
                    }
                }
                _ => p.add("instanceTransforms", "expected Doubles with 16 per matrix; ignored"),
            }
            if instance_transforms.is_empty() {
                // An authored empty list draws nothing; keep one invisible marker by visibility.
                p.add("instanceTransforms", "no usable instance matrices; the prim is not drawn");
            }
        }
        let display_color = display_average::<3>(s, "displayColor", p);
        let display_opacity = display_average::<1>(s, "displayOpacity", p).map(|[o]| o.clamp(0.0, 1.0));
        let id = match s.get("primId") {
            None => prim.id,
            Some(v) => match v.as_f64() {
                Some(x) if x >= 0.0 && x <= u32::MAX as f64 => x as u32,
                _ => {
                    p.add("primId", format!("expected a non-negative int; using {}", prim.id));
                    prim.id
                }
            },
        };
        RprimPiece {
            geometry,
            geometry_problems,
            transforms: s.matrix_samples("transform", p),
            instance_transforms: if s.has("instanceTransforms") { instance_transforms } else { InstanceMats::One(DMat4::IDENTITY) },
            instance_samples,
            material: s.str_opt("material").filter(|m| !m.is_empty()).map(String::from),
            display_color,
            display_opacity,
            visible: s.token_or("visibility", &["inherited", "invisible", "visible"], "inherited", p) != "invisible",
            purpose: s.token_or("purpose", &["default", "render", "proxy", "guide"], "default", p).to_string(),
            render_tag: s.str_opt("renderTag").filter(|t| !t.is_empty()).map(String::from),
            id,
            caustics: read_caustics(s, p),
            mesh_light: lux::read_mesh_light(s, p),
            instance_primvars: read_instance_primvars(s, n_instances, &kept, p),
            instance_link_paths: read_instance_paths(s, n_instances, &kept, p),
            instance_index: if s.has("instanceTransforms") { read_instance_indices(s, n_instances, &kept, p) } else { Vec::new() },
        }
    }

    /// Syncs the dirty prims (only those) and re-assembles the scene; returns the problems
    /// found by this commit (each once). Restarts a running render if anything changed.
    pub fn commit_resources(&mut self) -> Vec<Problem> {
        let dirty: Vec<String> = std::mem::take(&mut self.dirty).into_iter().filter(|p| self.prims.contains_key(p)).collect();
        let mut problems = std::mem::take(&mut self.pending);
        let geometry_dirty = std::mem::take(&mut self.geometry_dirty);
        for path in &dirty {
            let keep = match self.cache.get(path) {
                Some(Cached { piece: Piece::Rprim(r), .. }) if !geometry_dirty.contains(path) => Some((r.geometry.clone(), r.geometry_problems.clone())),
                _ => None,
            };
            let cached = self.convert(path, &self.prims[path], keep);
            problems.extend(cached.problems.iter().cloned());
            self.cache.insert(path.clone(), cached);
        }
        let changed = !dirty.is_empty() || self.structure_changed;
        let camera_only = !self.structure_changed && dirty.iter().all(|p| self.prims[p].ty == PrimType::Camera);
        self.structure_changed = false;
        self.last_synced = dirty;
        if changed {
            self.assemble(camera_only);
            problems.extend(self.assembly_problems.iter().cloned());
            self.restart_if_running();
        }
        // what the running render's engine found while preparing the scene (its validation
        // and world build), once it is built: returned by the next commit
        if let Some(found) = self.watcher().and_then(|w| w.engine_problems()) {
            problems.extend(self.engine_new(found));
        }
        let mut seen = Vec::with_capacity(problems.len());
        for p in problems {
            if !seen.contains(&p) {
                seen.push(p);
            }
        }
        seen
    }

    /// The engine problems in `found` (an engine's whole list) not returned before; those of
    /// earlier engines that `found` lacks are forgotten, so a problem mended and brought back
    /// is returned again.
    fn engine_new(&mut self, found: Vec<Problem>) -> Vec<Problem> {
        let now: HashSet<&Problem> = found.iter().collect();
        self.engine_reported.retain(|p| now.contains(p));
        drop(now);
        found.into_iter().filter(|p| self.engine_reported.insert(p.clone())).collect()
    }

    /// Prepares the scene for rendering as a render of the active camera and settings would
    /// (the engine's validation and world build, on this thread), without rendering, and returns
    /// what that found wrong and had not been returned before: `tide info`'s full check. What it
    /// builds is kept for the next render (the engine factory's cache).
    pub fn check_render(&mut self) -> Vec<Problem> {
        let mut problems = Vec::new();
        if self.scene_generation == 0 {
            self.assemble(false);
            problems.extend(self.assembly_problems.iter().cloned());
        }
        let settings = self.job_settings(&[]);
        match (self.factory)(&self.scene, &settings) {
            Ok(engine) => {
                let found = engine.problems();
                problems.extend(self.engine_new(found));
            }
            Err(e) => problems.push(problem("", "", format!("the scene could not be prepared: {e}"))),
        }
        problems
    }

    /// Prims synced by the last commit, sorted by path.
    pub fn last_synced(&self) -> &[String] {
        &self.last_synced
    }

    /// The scene as last assembled.
    pub fn scene(&self) -> &SceneDesc {
        &self.scene
    }

    /// The render settings in effect (of the active settings prim), with resolved size.
    pub fn settings(&self) -> &SettingsPiece {
        &self.settings
    }

    /// Every problem of the current state (all synced prims), each once.
    pub fn problems(&self) -> Vec<Problem> {
        let mut out: Vec<Problem> = self.cache.values().flat_map(|c| c.problems.iter().cloned()).collect();
        out.extend(self.assembly_problems.iter().cloned());
        for p in self.watcher().map(|w| w.problems()).unwrap_or_default() {
            if !out.contains(&p) {
                out.push(p);
            }
        }
        out
    }

    fn settings_path(&self) -> Option<String> {
        if let Some(s) = &self.active_settings {
            if matches!(self.cache.get(s), Some(Cached { piece: Piece::Settings(_), .. })) {
                return Some(s.clone());
            }
        }
        self.cache.iter().find(|(_, c)| matches!(c.piece, Piece::Settings(_))).map(|(p, _)| p.clone())
    }

    /// Builds the scene the renderer gets from the synced prims. `camera_only`: what changed
    /// since the last assembly is a camera or which camera is active (the rest of the scene
    /// then stays the same unless the camera moves it: a new shutter, an ocean's detail).
    fn assemble(&mut self, camera_only: bool) {
        let mut ap: Vec<Problem> = Vec::new();
        let sp = match self.settings_path().and_then(|p| self.cache.get(&p)) {
            Some(Cached { piece: Piece::Settings(s), .. }) => s.clone(),
            _ => SettingsPiece::default(),
        };
        let cam_path = [self.active_camera.clone(), sp.camera.clone()]
            .into_iter()
            .flatten()
            .find(|c| {
                let ok = matches!(self.cache.get(c), Some(Cached { piece: Piece::Camera(_), .. }));
                if !ok {
                    ap.push(problem(c, "camera", "no such camera; using another"));
                }
                ok
            })
            .or_else(|| self.cache.iter().find(|(_, c)| matches!(c.piece, Piece::Camera(_))).map(|(p, _)| p.clone()));
        let cam = cam_path.as_ref().and_then(|p| match self.cache.get(p) {
            Some(Cached { piece: Piece::Camera(c), .. }) => Some(c.clone()),
            _ => None,
        });
        // frames to seconds: the settings' rate (the reader's), else the one a Hydra plugin
        // sent with the camera, else 24
        let tcps = match (sp.time_codes_authored, cam.as_ref().and_then(|c| c.time_codes_per_second)) {
            (false, Some(t)) => t,
            _ => sp.time_codes_per_second,
        };
        let (open, close) = cam.as_ref().map_or((0.0, 0.0), |c| (c.desc.shutter_open as f64, c.desc.shutter_close as f64));
        let motion = !sp.settings.disable_motion_blur && close > open;
        let (t0, t1) = if motion { ((open / tcps) as f32, (close / tcps) as f32) } else { (0.0, 0.0) };
        // metres per scene unit: the settings' (the reader's), else the camera's (a Hydra plugin's)
        let mpu = sp.meters_per_unit.or(cam.as_ref().and_then(|c| c.meters_per_unit)).unwrap_or(1.0) as f32;
        // and the up axis the same way (Y where neither gives it)
        let z_up = sp.z_up.or(cam.as_ref().and_then(|c| c.z_up)).unwrap_or(false);
        // The scene is placed about a point near the camera (see [`scene_origin`]): every world
        // matrix is taken relative to it in double precision before it becomes single precision.
        let cam_world = cam.as_ref().map(|c| matrix_at(&c.transforms, 0.0).transform_point3(DVec3::ZERO));
        let near = cam.as_ref().map_or(1.0, |c| c.desc.clipping_range[0] as f64);
        let origin = scene_origin(cam_world, near, mpu as f64);
        let view = (open.to_bits(), close.to_bits(), tcps.to_bits(), motion, origin.to_array().map(f64::to_bits));
        let mut world_changed = !camera_only || self.view_inputs != Some(view);
        self.view_inputs = Some(view);
        // Transform samples: inside the shutter plus one on either side, or the value now;
        // each after `pre` (an instance's matrix), from geometry moved by `shift` about its own
        // origin (`MeshDesc::origin`), and placed about the scene's origin.
        let place = |samples: &[(f64, DMat4)], pre: &DMat4, shift: Vec3| -> (Vec<Mat4>, Vec<f32>) {
            let post = DMat4::from_translation(shift.as_dvec3());
            if !motion || samples.len() < 2 {
                return (vec![about(origin, &(*pre * matrix_at(samples, 0.0) * post))], vec![0.0]);
            }
            let lo = samples.iter().rposition(|s| s.0 <= open).unwrap_or(0);
            let hi = samples.iter().position(|s| s.0 >= close).unwrap_or(samples.len() - 1);
            let kept = &samples[lo..=hi.max(lo)];
            (kept.iter().map(|s| about(origin, &(*pre * s.1 * post))).collect(), kept.iter().map(|s| (s.0 / tcps) as f32).collect())
        };

        let mut scene = SceneDesc { color_space: sp.color_space, origin, ..Default::default() };

        // the prim path of each instance, and the path it stands for in light-link collections
        let mut instance_paths: Vec<&str> = Vec::new();
        let mut link_paths: Vec<&str> = Vec::new();
        scene.materials.push(default_material("default"));
        let mut tex_index: BTreeMap<TexKey, usize> = BTreeMap::new();
        let textures = &self.textures;
        let mut before = std::mem::take(&mut self.converted_textures);
        let mut converted = HashMap::new();
        let mut texture = |key: &TexKey, scene: &mut SceneDesc| -> Option<usize> {
            if let Some(&i) = tex_index.get(key) {
                return Some(i);
            }
            let Some(TexState::Loaded { width, height, channels, pixels, is_srgb, .. }) = textures.get(&key.asset) else { return None };
            let tex = match before.remove(key) {
                Some((source, tex)) if source.same(pixels) => tex,
                _ => convert_texture(key, *width, *height, *channels, pixels, *is_srgb)?,
            };
            converted.insert(key.clone(), (pixels.clone(), tex.clone()));
            scene.textures.push(tex);
            tex_index.insert(key.clone(), scene.textures.len() - 1);
            Some(scene.textures.len() - 1)
        };

        let mut mat_index: HashMap<&str, usize> = HashMap::new();
        let mut medium_of: HashMap<&str, usize> = HashMap::new();
        // scene material → its displacement (textures in the scene's list)
        let mut displacement_of: HashMap<usize, Displacement> = HashMap::new();
        for (path, c) in &self.cache {
            let Piece::Material(m) = &c.piece else { continue };
            let map: Option<Vec<usize>> = m.textures.iter().map(|k| texture(k, &mut scene)).collect();
            let mut desc = match &map {
                Some(map) => {
                    let mut d = m.desc.clone();
                    material::remap_textures(&mut d, map);
                    d
                }
                None => default_material(path),
            };
            if let Some(med) = &m.medium {
                scene.media.push(material::medium_in_stage(med, mpu, z_up));
                desc.interior_medium = Some(scene.media.len() - 1);
                medium_of.insert(path, scene.media.len() - 1);
            }
            scene.materials.push(desc);
            mat_index.insert(path, scene.materials.len() - 1);
            if let (Some(local), Some(map)) = (&m.displacement, &map) {
                let mut d = local.clone();
                material::remap_float(&mut d, map);
                let textures = map.iter().map(|&i| scene.textures[i].clone()).collect();
                displacement_of.insert(scene.materials.len() - 1, Displacement { d, local: local.clone(), textures, material: path });
            }
        }
        // (mesh, material) → the mesh displaced by the material, made once per assembly and
        // taken from the last assembly when its mesh, displacement and textures are the same
        let mut displaced: HashMap<(usize, usize), usize> = HashMap::new();
        let displaced_before = std::mem::take(&mut self.displaced_meshes);
        let mut displaced_now: HashMap<(usize, String), Displaced> = HashMap::new();

        let included = &sp.included_purposes;
        let mut color_mats: HashMap<([u32; 3], bool, u32, bool), usize> = HashMap::new();
        let mut oceans_seen = BTreeSet::new();
        for (path, c) in &self.cache {
            let Piece::Rprim(r) = &c.piece else { continue };
            if !r.visible || (r.purpose != "default" && !included.contains(&r.purpose)) {
                continue;
            }
            if let Some(tag) = &r.render_tag {
                // Hydra's `hidden` is rendered only by a pass that names it
                let shown = self.render_tags.as_ref().map_or(tag != "hidden", |tags| tags.contains(tag));
                if !shown {
                    continue;
                }
            }
            // the geometry, and for an ocean's parts the (wind direction, slope-variance share)
            // their sea material takes
            let mut parts: Vec<(GeometryRef, Option<(f32, f32)>)> = Vec::new();
            if let Geometry::Volume(spec) = r.geometry.as_ref() {
                let medium = r.material.as_deref().and_then(|m| medium_of.get(m).copied());
                let grid = self.grids.get(&(spec.asset.clone(), spec.field.clone(), spec.index));
                let mut p = Problems::new(path);
                for inst in r.instance_transforms.iter() {
                    let (mats, times) = place(&r.transforms, &inst, Vec3::ZERO);
                    let keys: Vec<(f32, Mat4)> = times.into_iter().zip(mats).collect();
                    if let Some(v) = volume::volume_desc(path, spec, grid, medium, &keys, r.id, &mut p) {
                        scene.volumes.push(v);
                    }
                }
                ap.extend(p.list);
                continue;
            }
            // per part: the suffix of its instances' names and the GeomSubset whose material it takes
            let mut part_names: Vec<(String, Option<&mesh::SubsetPart>)> = Vec::new();
            match r.geometry.as_ref() {
                Geometry::Mesh(m) if !m.indices.is_empty() => {
                    scene.meshes.push(m.clone());
                    parts.push((GeometryRef::Mesh(scene.meshes.len() - 1), None));
                }
                Geometry::UsdMesh(g) if !g.mesh.indices.is_empty() => {
                    // one core mesh per material (GeomSubsets): its own triangles over the
                    // vertices they use; made once per shutter and shared by later assemblies
                    for (m, subset) in g.core_meshes(motion.then_some((open, close, tcps))) {
                        let subset = subset.map(|k| &g.subsets[k]);
                        scene.meshes.push(m);
                        parts.push((GeometryRef::Mesh(scene.meshes.len() - 1), None));
                        part_names.push((subset.map_or(String::new(), |s| format!(" {}", s.path)), subset));
                    }
                }
                Geometry::Spheres(s) if !s.centers.is_empty() => {
                    scene.spheres.push(s.clone());
                    parts.push((GeometryRef::Spheres(scene.spheres.len() - 1), None));
                }
                Geometry::Points(pd) if !pd.spheres.centers.is_empty() => {
                    // made once per shutter and shared by later assemblies; the droplets' grid
                    // lies in the points' space, its voxels sized in the world's metres at the
                    // prim's scale (its first instance's, at the frame), and its coefficients
                    // per unit of that space are per 1/scale world units
                    let xf0 = r.instance_transforms.first().unwrap_or(DMat4::IDENTITY) * matrix_at(&r.transforms, 0.0);
                    // (positive and finite, unless single precision cannot hold it with mpu)
                    let scale = Some(implicit::object_scale(&xf0) as f32).filter(|s| (mpu * s).is_finite() && mpu * s > 0.0).unwrap_or(1.0);
                    let made = pd.made(t0, t1, motion, tcps, mpu * scale);
                    match &made.droplets {
                        // droplets inside the cloud become a scattering medium; the shell stays spheres
                        Some(Ok(Some(grid))) => {
                            scene.media.push(tide_core::scene::MediumDesc {
                                name: format!("{path} (droplets)"),
                                sigma_a: tide_core::scene::SpectrumDesc::Rgb([0.0; 3]),
                                sigma_s: tide_core::scene::SpectrumDesc::Rgb([1.0; 3]),
                                scale: 1.0 / scale,
                                phase: tide_core::droplets::droplet_phase(),
                                water: None,
                                method: tide_core::scene::MediumMethod::Volumetric,
                            });
                            let medium = scene.media.len() - 1;
                            for inst in r.instance_transforms.iter() {
                                let (mats, times) = place(&r.transforms, &inst, Vec3::ZERO);
                                let keys: Vec<(f32, Mat4)> = times.into_iter().zip(mats).collect();
                                scene.volumes.push(volume::placed_volume(path, grid.clone(), &keys, |m| m * grid.local_to_world, medium, r.id));
                            }
                        }
                        Some(Err(e)) => ap.push(problem(path, "tide:droplets:voxelSize", format!("{e}; the droplets render as spheres"))),
                        _ => {}
                    }
                    if made.spheres.centers.is_empty() {
                        continue;
                    }
                    scene.spheres.push(made.spheres);
                    parts.push((GeometryRef::Spheres(scene.spheres.len() - 1), None));
                }
                Geometry::Ocean(spec) => {
                    // level of detail about the camera in the ocean's space (its first instance)
                    let xf0 = r.instance_transforms.first().unwrap_or(DMat4::IDENTITY) * matrix_at(&r.transforms, 0.0);
                    let inv = xf0.inverse();
                    let cam_local = cam_world.filter(|_| inv.is_finite()).map(|c| inv.transform_point3(c).as_vec3());
                    let pixel = cam.as_ref().map(|c| ocean::CameraPixel::of(&c.desc, sp.settings.width));
                    let key = ocean::ocean_key(spec, cam_local, pixel, mpu);
                    let meshes = match self.oceans.get(path.as_str()) {
                        Some((k, m, probs)) if *k == key => {
                            ap.extend(probs.iter().cloned());
                            m.clone()
                        }
                        _ => {
                            world_changed = true;
                            let mut p = Problems::new(path);
                            let m = Arc::new(ocean::build(&key, &mut p));
                            ap.extend(p.list.iter().cloned());
                            self.oceans.insert(path.clone(), (key, m.clone(), p.list));
                            m
                        }
                    };
                    oceans_seen.insert(path.clone());
                    let wind = ocean::world_wind_direction(&spec.params, xf0.as_mat4());
                    scene.meshes.push(meshes.surface.clone());
                    parts.push((GeometryRef::Mesh(scene.meshes.len() - 1), Some((wind, ocean::sea_variance_scale(&spec.params)))));
                    if let Some(skirt) = &meshes.skirt {
                        scene.meshes.push(skirt.clone());
                        parts.push((GeometryRef::Mesh(scene.meshes.len() - 1), Some((wind, 1.0))));
                    }
                }
                _ => continue,
            }
            let bound = r.material.as_deref().and_then(|m| {
                let i = mat_index.get(m).copied();
                if i.is_none() {
                    ap.push(problem(path, "material", format!("bound material '{}' does not exist; using the fallback", m)));
                }
                i
            });
            let varies = |name: &str| r.geometry.carries_varying(name) || r.instance_primvars.iter().any(|p| p.name == name);
            let (color_varies, opacity_varies) = (varies("displayColor"), varies("displayOpacity"));
            // varying per instance only: the defaults where an instance has none
            let color = r.display_color.or(color_varies.then_some([0.18; 3]));
            let opacity = r.display_opacity.or(opacity_varies.then_some(1.0));
            let material = bound.unwrap_or_else(|| {
                if color.is_none() && opacity.is_none() {
                    return 0;
                }
                let (col, o) = (color.unwrap_or([0.18; 3]), opacity.unwrap_or(1.0));
                let key = (col.map(f32::to_bits), color_varies, o.to_bits(), opacity_varies);
                *color_mats.entry(key).or_insert_with(|| {
                    scene.materials.push(display_material(col, color_varies, o, opacity_varies));
                    scene.materials.len() - 1
                })
            });
            let many = r.instance_transforms.len() > 1;
            let table = (!r.instance_primvars.is_empty()).then(|| {
                scene.instance_primvars.push(InstancePrimvars { name: path.clone(), rows: r.instance_transforms.len() as u32, primvars: r.instance_primvars.clone() });
                scene.instance_primvars.len() as u32 - 1
            });
            for (part, (geometry, sea)) in parts.into_iter().enumerate() {
                let (suffix, subset) = part_names.get(part).cloned().unwrap_or_else(|| (if part == 0 { String::new() } else { " horizon".into() }, None));
                let material = match subset.and_then(|s| s.material.as_deref().map(|m| (s, m))) {
                    Some((s, m)) => mat_index.get(m).copied().unwrap_or_else(|| {
                        ap.push(problem(&s.path, "material", format!("bound material '{}' does not exist; the faces take the mesh's material", m)));
                        material
                    }),
                    None => material,
                };
                let material = match (sea, &scene.materials[material].surface) {
                    (Some((wind, share)), SurfaceDesc::Water(w)) if w.surface_model == SurfaceModel::Sea => {
                        let mut m = scene.materials[material].clone();
                        if let SurfaceDesc::Water(w) = &mut m.surface {
                            w.wind_speed = match r.geometry.as_ref() {
                                Geometry::Ocean(spec) => spec.params.wind_speed,
                                _ => w.wind_speed,
                            };
                            w.wind_direction = wind;
                            w.slope_variance_scale = share;
                        }
                        m.name = format!("{} on {}", m.name, path);
                        scene.materials.push(m);
                        scene.materials.len() - 1
                    }
                    _ => material,
                };
                // a displacing material moves the mesh's points (a copy per mesh and material)
                let geometry = match (geometry, displacement_of.get(&material)) {
                    (GeometryRef::Mesh(mi), Some(d)) => GeometryRef::Mesh(*displaced.entry((mi, material)).or_insert_with(|| {
                        let src = scene.meshes[mi].clone();
                        let key = (Arc::as_ptr(&src) as usize, d.material.to_string());
                        let kept = displaced_now.get(&key).or(displaced_before.get(&key)).filter(|e| e.made_of(&src, d)).map(|e| e.out.clone());
                        let out = kept.unwrap_or_else(|| Arc::new(tide_core::displace::displace(&src, &d.d, &scene.textures)));
                        displaced_now.insert(key, Displaced { src, local: d.local.clone(), textures: d.textures.clone(), out: out.clone() });
                        scene.meshes.push(out);
                        scene.meshes.len() - 1
                    })),
                    (g, _) => g,
                };
                // a mesh light: its material emits (UsdLuxMeshLightAPI); with `normalize`, each
                // instance divides by its own world area (one material per area)
                let mut emitting: Vec<(u32, usize)> = Vec::new();
                let mut material_of = |k: usize, scene: &mut SceneDesc, ap: &mut Vec<Problem>| match (&r.mesh_light, geometry) {
                    (Some(ml), GeometryRef::Mesh(mi)) => {
                        let world = place(&r.transforms, &r.instance_transforms.get(k).unwrap_or(DMat4::IDENTITY), scene.meshes[mi].origin).0[0];
                        let key = if ml.normalize { lux::world_area(&scene.meshes[mi], world).to_bits() } else { 0 };
                        if let Some(&(_, m)) = emitting.iter().find(|e| e.0 == key) {
                            return m;
                        }
                        let (m, problem) = lux::mesh_light_material(ml, &scene.materials[material], &scene.meshes[mi], world, tide_core::scene::AUTHORED_COLOR_SPACE, path);
                        // reported once per mesh
                        if emitting.is_empty() {
                            ap.extend(problem);
                        }
                        scene.materials.push(m);
                        emitting.push((key, scene.materials.len() - 1));
                        scene.materials.len() - 1
                    }
                    _ => material,
                };
                let shift = match geometry {
                    GeometryRef::Mesh(mi) => scene.meshes[mi].origin,
                    GeometryRef::Spheres(si) => scene.spheres[si].origin,
                };
                for (k, inst) in r.instance_transforms.iter().enumerate() {
                    let material = material_of(k, &mut scene, &mut ap);
                    let name = if many { format!("{}[{}]", path, k) } else { path.clone() };
                    instance_paths.push(path);
                    link_paths.push(r.instance_link_paths.get(k).unwrap_or(path));
                    let (transforms, times) = if motion && !r.instance_samples.is_empty() {
                        place(&moving_instance(&r.transforms, &r.instance_samples, k), &DMat4::IDENTITY, shift)
                    } else {
                        place(&r.transforms, &inst, shift)
                    };
                    scene.instances_mut().push(InstanceDesc {
                        name: format!("{name}{suffix}"),
                        geometry,
                        transforms,
                        times,
                        material,
                        id: r.id,
                        visible_to_camera: true,
                        casts_shadows: true,
                        primvar_row: table.map(|t| (t, k as u32)),
                        index: r.instance_index.get(k).copied(),
                    });
                }
            }
        }
        self.oceans.retain(|p, _| oceans_seen.contains(p));
        for (path, c) in &self.cache {
            match &c.piece {
                Piece::Rprim(r) => {
                    if let Some(o) = r.caustics {
                        scene.caustics.objects.push((path.clone(), o));
                    }
                }
                Piece::Light(Some(l)) => {
                    if let Some(e) = l.caustics_emitter {
                        scene.caustics.emitters.push((path.clone(), e));
                    }
                }
                _ => {}
            }
        }

        // TideSkyAPI domes: the sun's direction from the DistantLight they name, and the
        // physical suns (path → the sun's shape and the dome's intensity and exposure, or None
        // for a physical sun below the horizon, which is dropped)
        let mut physical_suns: HashMap<String, Option<(LightShape, f32, f32)>> = HashMap::new();
        let mut sky_suns: HashMap<String, Vec3> = HashMap::new();
        for (path, c) in &self.cache {
            let Piece::Light(Some(l)) = &c.piece else { continue };
            let (Some(sky), LightShape::Sky { turbidity, .. }) = (&l.sky, &l.desc.shape) else { continue };
            let m3 = glam::Mat3::from_mat4(l.desc.transform);
            let zenith = (m3 * Vec3::Y).normalize_or_zero();
            let zenith = if zenith == Vec3::ZERO { Vec3::Y } else { zenith };
            // where the relationship cannot arrive (a Hydra scene delegate), the only DistantLight
            let sun_path: Option<String> = match (&sky.sun, sky.sun_unreadable) {
                (Some(s), _) => Some(s.clone()),
                (None, false) => None,
                (None, true) => {
                    let distant: Vec<&String> = self
                        .cache
                        .iter()
                        .filter(|(_, c)| matches!(&c.piece, Piece::Light(Some(sl)) if matches!(sl.desc.shape, LightShape::Distant { .. })))
                        .map(|(p, _)| p)
                        .collect();
                    if let [only] = distant.as_slice() {
                        ap.push(problem(path, "tide:sky:sun", format!("the relationship cannot be read through this Hydra scene delegate; the scene's only DistantLight '{only}' is the sun")));
                        Some((*only).clone())
                    } else {
                        ap.push(problem(
                            path,
                            "tide:sky:sun",
                            format!("the relationship cannot be read through this Hydra scene delegate and the scene has {} DistantLights; the sun stands {}° above the horizon", distant.len(), lux::DEFAULT_SUN_ELEVATION_DEG),
                        ));
                        None
                    }
                }
            };
            let sky = lux::SkyPiece { sun: sun_path, ..sky.clone() };
            let sky = &sky;
            let sun_light = sky.sun.as_deref().and_then(|s| match self.cache.get(s).map(|c| &c.piece) {
                Some(Piece::Light(Some(sl))) if matches!(sl.desc.shape, LightShape::Distant { .. }) => Some(sl),
                _ => {
                    ap.push(problem(path, "tide:sky:sun", format!("'{}' is not a visible DistantLight; the sun stands {}° above the horizon", s, lux::DEFAULT_SUN_ELEVATION_DEG)));
                    None
                }
            });
            let to_sun = match sun_light {
                Some(sl) => (glam::Mat3::from_mat4(sl.desc.transform) * Vec3::Z).normalize_or_zero(),
                None => {
                    let e = lux::DEFAULT_SUN_ELEVATION_DEG.to_radians();
                    (m3 * Vec3::new(0.0, e.sin(), e.cos())).normalize_or_zero()
                }
            };
            let sin_elev = zenith.dot(to_sun);
            let mut physical = sky.physical_sun && sun_light.is_some();
            let to_sun = if to_sun == Vec3::ZERO || sin_elev < 0.0 {
                // below the horizon the model has no data: the sky of a sun on the horizon
                // (azimuth kept), and no physical sun (it would light the scene from below)
                let h = to_sun - zenith * sin_elev;
                let h = if h.length_squared() > 1e-12 { h.normalize() } else { zenith.any_orthonormal_vector() };
                ap.push(problem(
                    path,
                    "tide:sky:sun",
                    format!(
                        "the sun{} is {:.2}° below the horizon, where the Hošek–Wilkie model has no data; the sky is rendered for a sun on the horizon{}",
                        sky.sun.as_deref().map(|s| format!(" ({s})")).unwrap_or_default(),
                        sin_elev.clamp(-1.0, 1.0).asin().to_degrees().abs(),
                        if physical { " and the physical sun is off" } else { "" }
                    ),
                ));
                physical = false;
                h
            } else {
                to_sun
            };
            sky_suns.insert(path.clone(), to_sun);
            if let (true, Some(sun)) = (physical, &sky.sun) {
                let shape = LightShape::SkySun { zenith, turbidity: *turbidity, scale: tide_core::sky::nits_per_model_unit() };
                physical_suns.entry(sun.clone()).or_insert(Some((shape, l.desc.intensity, l.desc.exposure)));
            } else if let (true, Some(sun)) = (sky.physical_sun && sun_light.is_some(), &sky.sun) {
                physical_suns.entry(sun.clone()).or_insert(None);
            }
        }

        // collections of prim paths → the names of the instances of member prims
        let members = |instances: &[InstanceDesc], c: &Option<lux::Collection>| {
            c.as_ref().map(|c| instances.iter().zip(&link_paths).filter(|(_, p)| c.contains(p)).map(|(i, _)| i.name.clone()).collect::<Vec<_>>())
        };
        // mesh lights' links, per instance of the mesh
        let mut emitter_links = Vec::new();
        for (inst, path) in scene.instances.iter().zip(&instance_paths) {
            let Some(Cached { piece: Piece::Rprim(r), .. }) = self.cache.get(*path) else { continue };
            let Some(ml) = r.mesh_light.as_ref().filter(|ml| ml.light_link.is_some() || ml.shadow_link.is_some()) else { continue };
            emitter_links.push(tide_core::scene::EmitterLinks { instance: inst.name.clone(), light_link: members(&scene.instances, &ml.light_link), shadow_link: members(&scene.instances, &ml.shadow_link) });
        }
        scene.emitter_links = emitter_links;
        let unnamed = self.unnamed_portals(origin);
        for (path, c) in &self.cache {
            let Piece::Light(Some(l)) = &c.piece else { continue };
            let mut desc = l.desc.clone();
            desc.transform = about(origin, &l.world);
            if matches!(desc.shape, LightShape::Dome { .. } | LightShape::Sky { .. }) {
                desc.portals = match &l.portals {
                    None => unnamed.clone(),
                    Some(names) => self.named_portals(path, names, origin, &mut ap),
                };
            }
            desc.light_link = members(&scene.instances, &l.light_link);
            desc.shadow_link = members(&scene.instances, &l.shadow_link);
            // a light that moves over the shutter (keys in seconds, as the instances')
            let (xf, times) = place(&l.transforms, &DMat4::IDENTITY, Vec3::ZERO);
            if xf.len() >= 2 {
                desc.motion = times.into_iter().zip(xf).collect();
            }
            if let LightShape::Sky { sun_direction, .. } = &mut desc.shape {
                if let Some(d) = sky_suns.get(path) {
                    *sun_direction = *d;
                }
            }
            if let Some(sun) = physical_suns.get(path) {
                let Some((shape, intensity, exposure)) = sun else { continue };
                // the solar model's radiance in place of the light's own (contract §6), on the
                // sky's scale so that sun and sky keep their physical ratio
                desc.shape = shape.clone();
                desc.intensity = *intensity;
                desc.exposure = *exposure;
                desc.color = [1.0; 3];
                desc.color_temperature = None;
                desc.normalize = false;
            }
            let t = l.texture.as_ref().and_then(|k| {
                let i = texture(k, &mut scene);
                if i.is_none() {
                    let state = match textures.get(&k.asset) {
                        Some(TexState::Failed(m)) => format!("could not be read ({})", m),
                        _ => "was not provided".into(),
                    };
                    ap.push(problem(&desc.name, "texture:file", format!("texture '{}' {}; the light is untextured", k.asset, state)));
                }
                i
            });
            match &mut desc.shape {
                LightShape::Dome { texture } | LightShape::Rect { texture, .. } => *texture = t,
                _ => {}
            }
            scene.lights.push(desc);
        }

        if let (Some(path), Some(c)) = (&cam_path, cam) {
            let mut d = c.desc.clone();
            let (xf, times) = place(&c.transforms, &DMat4::IDENTITY, Vec3::ZERO);
            d.transforms = xf;
            d.times = times;
            d.shutter_open = t0;
            d.shutter_close = t1;
            if let Some(m) = &c.medium {
                d.medium = medium_of.get(m.as_str()).copied();
                if d.medium.is_none() {
                    ap.push(problem(path, "tide:medium", format!("'{}' is not a material with a volume; the camera starts in vacuum", m)));
                }
            }
            scene.camera = d;
        }
        self.converted_textures = converted;
        drop(displaced_before);
        self.displaced_meshes = displaced_now;
        self.assembly_problems = ap;
        self.settings = sp;
        self.scene = Arc::new(scene);
        self.scene_generation += 1;
        if world_changed {
            self.world_generation += 1;
        }
    }

    /// The portals that no dome's `portals` relationship names (a dome naming none takes them).
    fn unnamed_portals(&self, origin: DVec3) -> Vec<tide_core::scene::PortalDesc> {
        let named: BTreeSet<&str> = self
            .cache
            .values()
            .filter_map(|c| match &c.piece {
                Piece::Light(Some(l)) => l.portals.as_ref(),
                _ => None,
            })
            .flatten()
            .map(String::as_str)
            .collect();
        self.cache
            .iter()
            .filter_map(|(path, c)| match &c.piece {
                Piece::Portal(Some(pp)) if !named.contains(path.as_str()) => Some(pp.desc(path, origin)),
                _ => None,
            })
            .collect()
    }

    /// The portals dome `path` names; a name that is not a portal is a problem.
    fn named_portals(&self, path: &str, names: &[String], origin: DVec3, ap: &mut Vec<Problem>) -> Vec<tide_core::scene::PortalDesc> {
        names
            .iter()
            .filter_map(|n| match self.cache.get(n).map(|c| &c.piece) {
                Some(Piece::Portal(Some(pp))) => Some(pp.desc(n, origin)),
                // an invisible or empty portal guides nothing, as it renders nothing
                Some(Piece::Portal(None)) => None,
                _ => {
                    ap.push(problem(path, "portals", format!("'{n}' is not a PortalLight; ignored")));
                    None
                }
            })
            .collect()
    }

    /// The settings of a job: resolution from the settings prim, else the first bound buffer;
    /// the film keeps the AOVs bound (and colour).
    fn job_settings(&self, bindings: &[(Binding, String)]) -> RenderSettings {
        let mut s = self.settings.settings.clone();
        s.aovs = tide_core::AovSet::of(bindings.iter().map(|(b, _)| b.aov));
        s.film_window = self.pass_projection.and_then(|m| film_window(&m, &self.scene.camera));
        if !self.settings.resolution_authored {
            if let Some((w, h)) = bindings.iter().filter_map(|(_, b)| self.buffers.get(b)).map(|b| b.dimensions()).find(|d| d.0 > 0 && d.1 > 0) {
                s.width = w;
                s.height = h;
            }
        }
        s
    }

    fn start_job(&mut self, bindings: Vec<(Binding, String)>) {
        let settings = self.job_settings(&bindings);
        let key = (self.scene_generation, bindings.clone(), settings.clone());
        if self.job_key.as_ref() == Some(&key) {
            return;
        }
        let cam = &self.scene.camera;
        let clip = ClipDepth { near: cam.clipping_range[0], far: cam.clipping_range[1], orthographic: cam.projection == tide_core::scene::Projection::Orthographic };
        let job = Job {
            scene: self.scene.clone(),
            settings,
            bindings: bindings.iter().filter_map(|(a, b)| self.buffers.get(b).map(|buf| (Output { binding: *a, clip }, buf.clone()))).collect(),
            world: self.world_generation,
        };
        self.job_key = Some(key);
        if self.stopped {
            return;
        }
        let factory = self.factory.clone();
        let pass = self.pass.get_or_insert_with(|| RenderPass::new(factory));
        if self.paused {
            pass.pause();
        }
        pass.start(job);
    }

    fn restart_if_running(&mut self) {
        if let Some((_, bindings, _)) = self.job_key.clone() {
            self.start_job(bindings);
        }
    }

    /// Renders progressively into the bound buffers (`aovs`: (AOV sourceName, buffer path)).
    /// `camera` / `settings` pick the camera and settings prims (else the settings' camera /
    /// the first of each). Calling it again with nothing changed keeps the running render.
    /// Returns problems with the bindings (unknown AOVs or buffers are skipped).
    pub fn execute(&mut self, camera: Option<&str>, aovs: &[(String, String)], settings: Option<&str>) -> Vec<Problem> {
        self.execute_as(camera, aovs, settings, false, None)
    }

    /// [`Delegate::execute`], with the AOVs named and laid as Hydra's render buffers want them
    /// where `hydra` ([`Binding::hydra`]), else as `UsdRenderVar` sourceNames, rows from the top;
    /// `projection`: the host's projection matrix (GfMatrix4d's order), whose framing the image
    /// takes in place of the camera's aperture conformed by the settings ([`film_window`]).
    pub fn execute_as(&mut self, camera: Option<&str>, aovs: &[(String, String)], settings: Option<&str>, hydra: bool, projection: Option<[f64; 16]>) -> Vec<Problem> {
        let mut problems = Vec::new();
        let cam = camera.filter(|c| !c.is_empty()).map(String::from);
        let set = settings.filter(|c| !c.is_empty()).map(String::from);
        if cam != self.active_camera || set != self.active_settings || self.scene_generation == 0 || self.render_tags_changed {
            let camera_only = set == self.active_settings && self.scene_generation != 0 && !self.render_tags_changed;
            self.render_tags_changed = false;
            self.active_camera = cam;
            self.active_settings = set;
            self.assemble(camera_only);
            problems.extend(self.assembly_problems.iter().cloned());
        }
        self.pass_projection = projection;
        if let Some(m) = projection {
            if film_window(&m, &self.scene.camera).is_none() {
                let cam = self.scene.camera.name.clone();
                problems.push(problem(&cam, "projection", "the render pass's projection matrix is not of the camera's projection, or frames nothing; the camera's own aperture is used"));
            }
        }
        let mut bindings = Vec::new();
        for (name, buf) in aovs {
            let binding = if hydra { Binding::hydra(name) } else { Aov::from_source_name(name).map(Binding::plain) };
            match (binding, self.buffers.contains_key(buf)) {
                (Some(a), true) => bindings.push((a, buf.clone())),
                (None, _) => problems.push(problem(buf, "aov", format!("unknown AOV '{}'; not rendered", name))),
                (_, false) => problems.push(problem(buf, "aov", format!("'{}' is not a render buffer; AOV '{}' not rendered", buf, name))),
            }
        }
        self.start_job(bindings);
        problems
    }

    /// The render tags of the passes that follow (HdRenderPass::Execute's): a prim with a
    /// render tag (`renderTag`) is rendered only by a pass whose tags include it; empty renders
    /// every prim, as Hydra's "no tags" does, but those tagged `hidden`. Prims without a tag are
    /// always rendered. Takes effect at the next execution (re-assembling the scene when the
    /// tags changed).
    pub fn set_render_tags(&mut self, tags: &[String]) {
        let tags = (!tags.is_empty()).then(|| {
            let mut t = tags.to_vec();
            t.sort();
            t.dedup();
            t
        });
        if tags != self.render_tags {
            self.render_tags = tags;
            self.render_tags_changed = true;
        }
    }

    pub fn render_status(&self) -> PassStatus {
        self.pass.as_ref().map_or(PassStatus::Idle, |p| p.status())
    }

    /// True once the running render reached its sample target or time budget, or rendering
    /// is stopped (the image will not change until it restarts).
    pub fn is_converged(&self) -> bool {
        self.stopped || self.pass.as_ref().is_some_and(|p| p.is_converged())
    }

    /// Pauses rendering where it is (HdRenderDelegate::Pause): the buffers keep their pixels,
    /// edits and executions still prepare their render, and [`Delegate::resume_render`] goes
    /// on from the very sample it stopped at. Paused time does not count against a budget.
    pub fn pause_render(&mut self) {
        self.paused = true;
        if let Some(p) = &self.pass {
            p.pause();
        }
    }

    pub fn resume_render(&mut self) {
        self.paused = false;
        if let Some(p) = &self.pass {
            p.resume();
        }
    }

    pub fn is_render_paused(&self) -> bool {
        self.paused
    }

    /// Stops rendering (HdRenderDelegate::Stop): the render under way ends, its buffers keep
    /// what it published, and executions and edits start nothing until
    /// [`Delegate::restart_render`], which renders the last job asked for from its start.
    /// Nothing is published after it returns; to wait until no worker renders either (a
    /// blocking stop), wait on the watcher's [`PassWatcher::wait_idle`] after it.
    pub fn stop_render(&mut self) {
        self.stopped = true;
        if let Some(p) = &self.pass {
            p.cancel();
        }
    }

    pub fn restart_render(&mut self) {
        if !std::mem::take(&mut self.stopped) {
            return;
        }
        if let Some((_, bindings, _)) = self.job_key.take() {
            self.start_job(bindings);
        }
    }

    pub fn is_render_stopped(&self) -> bool {
        self.stopped
    }

    /// The running render's figures after its last finished pass (see
    /// `render_pass::Engine::summary`); empty before the first.
    pub fn render_summary(&self) -> Vec<(String, String)> {
        self.watcher().map(|w| w.summary()).unwrap_or_default()
    }

    pub fn progress(&self) -> f32 {
        self.pass.as_ref().map_or(0.0, |p| p.progress())
    }

    /// Waits for convergence (true) or failure / timeout (false).
    pub fn wait(&self, timeout: Duration) -> bool {
        self.pass.as_ref().is_some_and(|p| p.wait(timeout))
    }

    /// A handle on the render pass for waiting or polling without borrowing the delegate
    /// (None before the first `execute`).
    pub fn watcher(&self) -> Option<PassWatcher> {
        self.pass.as_ref().map(|p| p.watcher())
    }

    /// Stops rendering (buffers keep their pixels).
    pub fn cancel(&mut self) {
        if let Some(p) = &self.pass {
            p.cancel();
        }
        self.job_key = None;
    }

    pub fn render_buffer(&self, path: &str) -> Option<RenderBuffer> {
        self.buffers.get(path).cloned()
    }

    /// A copy of a buffer's current pixels with width, height and channel count.
    pub fn map_buffer(&self, path: &str) -> Option<MappedBuffer> {
        self.buffers.get(path).map(|b| b.map())
    }

    /// Writes AOVs (`(name, sourceName, dataType)`) of the current render to EXR through the
    /// core, atomically: a half `dataType` ([`sample_format`]) stores that AOV's channels as
    /// halves, any other as 32-bit floats. The names are recorded in the header as
    /// `tide:aov:<name>`.
    pub fn write_exr(&self, path: &std::path::Path, aovs: &[(String, String, String)], header: &[(String, String)]) -> std::io::Result<()> {
        let mut list = Vec::new();
        let mut hdr = header.to_vec();
        for (name, src, data_type) in aovs {
            let a = Aov::from_source_name(src).ok_or_else(|| std::io::Error::other(format!("unknown AOV '{}' for '{}'", src, name)))?;
            list.push((a, sample_format(data_type)));
            hdr.push((format!("tide:aov:{}", name), src.clone()));
        }
        match &self.pass {
            Some(p) => p.write_exr(path, &list, &hdr),
            None => Err(std::io::Error::other("no render to write: execute a render pass first")),
        }
    }
}

/// The EXR sample format for a `UsdRenderVar`'s `dataType` (an Sdf value type name): halves
/// for the half types (`half`, `half3`, `color3h`, `color4h`, `normal3h`, ...), 32-bit floats
/// for everything else, the unauthored fallback `color3f` included. Integer types (`int` for
/// `primId`) are written as floats too, exact to 2^24.
pub fn sample_format(data_type: &str) -> SampleFormat {
    let t = data_type.trim().trim_end_matches("[]");
    let half = t.starts_with("half") || (t.ends_with('h') && ["color", "normal", "point", "vector", "texCoord"].iter().any(|p| t.starts_with(p)));
    if half {
        SampleFormat::F16
    } else {
        SampleFormat::F32
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render_pass::tests::fake_factory;
    use std::sync::atomic::{AtomicU32, Ordering};
    use std::sync::Mutex;
    use tide_core::scene::{ColorInput, LightShape, SurfaceDesc};

    fn floats(d: &[f32], tuple: u32) -> Value {
        Value::Floats { data: d.to_vec(), tuple }
    }
    fn tok(s: &str) -> Value {
        Value::Token(s.into())
    }
    fn translate(x: f64, y: f64, z: f64) -> Value {
        let mut m = [0.0; 16];
        for i in 0..4 {
            m[5 * i] = 1.0;
        }
        m[12] = x;
        m[13] = y;
        m[14] = z;
        Value::Matrix(m)
    }

    fn quad(d: &mut Delegate, path: &str) {
        d.create_prim("mesh", path);
        d.set_attribute(path, "points", floats(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.], 3), None);
        d.set_attribute(path, "faceVertexCounts", Value::Ints(vec![4]), None);
        d.set_attribute(path, "faceVertexIndices", Value::Ints(vec![0, 1, 2, 3]), None);
    }

    fn red_material(d: &mut Delegate, path: &str) {
        d.create_prim("material", path);
        d.set_attribute(path, "surface", Value::Path(format!("{}/S", path)), None);
        d.set_attribute(path, &format!("{}/S.info:id", path), tok("UsdPreviewSurface"), None);
        d.set_attribute(path, &format!("{}/S.inputs:diffuseColor", path), floats(&[1., 0., 0.], 3), None);
    }

    /// A UsdPreviewSurface material at `path` whose diffuse colour reads the texture `file`.
    fn textured_material(d: &mut Delegate, path: &str, file: &str) {
        red_material(d, path);
        d.set_attribute(path, &format!("{path}/S.inputs:diffuseColor.connect"), tok(&format!("{path}/T.outputs:rgb")), None);
        d.set_attribute(path, &format!("{path}/T.info:id"), tok("UsdUVTexture"), None);
        d.set_attribute(path, &format!("{path}/T.inputs:file"), Value::Asset(file.into()), None);
        // repeating, so a texel covers the whole quad (useMetadata would blend in a black border)
        for wrap in ["wrapS", "wrapT"] {
            d.set_attribute(path, &format!("{path}/T.inputs:{wrap}"), tok("repeat"), None);
        }
    }

    fn material_of<'a>(d: &'a Delegate, inst: &str) -> &'a tide_core::scene::MaterialDesc {
        let i = d.scene().instances.iter().find(|i| i.name == inst).unwrap();
        &d.scene().materials[i.material]
    }

    #[test]
    fn unknown_type_is_refused_with_a_problem() {
        let mut d = Delegate::new();
        assert!(!d.create_prim("nurbsPatch", "/N"));
        assert!(!d.set_attribute("/N", "points", floats(&[], 3), None));
        let p = d.commit_resources();
        assert_eq!(p.len(), 2);
        assert!(p.iter().all(|q| q.item == "/N"));
        assert_eq!(PrimType::parse("rectLight").unwrap().class(), PrimClass::Sprim);
        assert_eq!(PrimType::parse("renderBuffer").unwrap().class(), PrimClass::Bprim);
        assert_eq!(PrimType::parse("tideOcean").unwrap().class(), PrimClass::Rprim);
    }

    #[test]
    fn dirty_tracking_resyncs_only_edited_prims() {
        let mut d = Delegate::new();
        quad(&mut d, "/A");
        quad(&mut d, "/B");
        red_material(&mut d, "/M");
        d.create_prim("sphereLight", "/L");
        d.commit_resources();
        assert_eq!(d.last_synced(), ["/A", "/B", "/L", "/M"]);
        let before = d.scene().meshes.clone();
        d.set_attribute("/B", "transform", translate(0., 0., 5.), None);
        d.commit_resources();
        assert_eq!(d.last_synced(), ["/B"]);
        assert_eq!(d.scene().meshes, before);
        let b = d.scene().instances.iter().find(|i| i.name == "/B").unwrap();
        assert_eq!(b.transforms[0].w_axis.z, 5.0);
        d.commit_resources();
        assert!(d.last_synced().is_empty());
    }

    #[test]
    fn destroy_in_any_order_and_material_rebinding() {
        let mut d = Delegate::new();
        quad(&mut d, "/A");
        d.set_attribute("/A", "material", Value::Path("/M".into()), None);
        red_material(&mut d, "/M");
        d.commit_resources();
        assert!(matches!(&material_of(&d, "/A").surface, SurfaceDesc::Preview(p) if p.diffuse_color == ColorInput::Const([1., 0., 0.])));
        // Material first: the mesh falls back to the default material (not re-synced).
        assert!(d.destroy_prim("/M"));
        let p = d.commit_resources();
        assert!(d.last_synced().is_empty());
        assert_eq!(material_of(&d, "/A"), &default_material("default"));
        assert!(p.iter().any(|q| q.item == "/A" && q.attribute == "material"));
        // Re-created later: re-binds.
        red_material(&mut d, "/M");
        d.commit_resources();
        assert_eq!(d.last_synced(), ["/M"]);
        assert!(matches!(&material_of(&d, "/A").surface, SurfaceDesc::Preview(_)));
        // displayColor is the fallback of an unbound gprim.
        d.set_primvar("/A", "primvars:displayColor", "constant", vec![0.2, 0.4, 0.6], 3, None);
        d.set_attribute("/A", "material", Value::Path(String::new()), None);
        d.commit_resources();
        assert_eq!(material_of(&d, "/A").surface, SurfaceDesc::Diffuse { color: ColorInput::Const([0.2, 0.4, 0.6]) });
        // Mesh first, then its material, then a prim that never existed.
        assert!(d.destroy_prim("/A"));
        assert!(d.destroy_prim("/M"));
        assert!(!d.destroy_prim("/nope"));
        d.commit_resources();
        assert!(d.scene().instances.is_empty() && d.scene().materials.len() == 1);
    }

    #[test]
    fn assemblies_share_converted_textures_until_the_file_changes() {
        let mut d = Delegate::new();
        textured_material(&mut d, "/M", "/t.png");
        assert!(d.add_texture("/t.png", 2, 1, 3, vec![0.5, 0.5, 0.5, 1.0, 1.0, 1.0], true, ""));
        quad(&mut d, "/A");
        d.set_attribute("/A", "material", Value::Path("/M".into()), None);
        d.commit_resources();
        let first = d.scene().textures[0].pixels.clone();
        assert!((first.value(0, 3) - 0.214_041).abs() < 1e-5, "linearised once: {}", first.value(0, 3));
        // another prim's edit re-assembles the scene: the same pixels, not a copy
        d.set_attribute("/A", "transform", translate(1.0, 0.0, 0.0), None);
        d.commit_resources();
        assert!(d.scene().textures[0].pixels.same(&first));
        // new pixels for the file are converted anew
        assert!(d.add_texture("/t.png", 2, 1, 3, vec![1.0; 6], true, ""));
        d.commit_resources();
        assert!(!d.scene().textures[0].pixels.same(&first));
        assert_eq!(d.scene().textures[0].pixels.to_f32(3), vec![1.0; 6]);
        // a texture no material uses any more is let go
        d.set_attribute("/M", "/M/T.inputs:file", Value::Asset("/u.png".into()), None);
        d.commit_resources();
        assert!(d.converted_textures.is_empty());
    }

    #[test]
    fn assemblies_share_unchanged_meshes_their_parts_and_displaced_copies() {
        let mut d = Delegate::new();
        quad(&mut d, "/A");
        quad(&mut d, "/B");
        // a mesh whose second face takes another material through a GeomSubset
        red_material(&mut d, "/Red");
        quad(&mut d, "/S");
        d.set_attribute("/S", "faceVertexCounts", Value::Ints(vec![3, 3]), None);
        d.set_attribute("/S", "faceVertexIndices", Value::Ints(vec![0, 1, 2, 0, 2, 3]), None);
        d.set_attribute("/S", "geomSubsets", Value::Paths(vec!["/S/a".into()]), None);
        d.set_attribute("/S", "/S/a.indices", Value::Ints(vec![1]), None);
        d.set_attribute("/S", "/S/a.material", Value::Path("/Red".into()), None);
        // a mesh displaced by a texture
        textured_material(&mut d, "/M", "/h.png");
        d.set_attribute("/M", "/M/S.inputs:displacement.connect", tok("/M/T.outputs:r"), None);
        assert!(d.add_texture("/h.png", 1, 1, 1, vec![0.5], false, ""));
        quad(&mut d, "/D");
        d.set_attribute("/D", "material", Value::Path("/M".into()), None);
        d.commit_resources();
        let names = ["/A", "/S", "/S /S/a", "/D"];
        let meshes = |d: &Delegate| names.map(|n| {
            let i = d.scene().instances.iter().find(|i| i.name == n).unwrap();
            let GeometryRef::Mesh(m) = i.geometry else { unreachable!() };
            d.scene().meshes[m].clone()
        });
        let first = meshes(&d);
        assert!((first[3].positions[0].z - 0.5).abs() < 1e-6, "displaced by the texel: {:?}", first[3].positions[0]);
        // another prim moved: every mesh is the one the last assembly made, not a copy
        d.set_attribute("/B", "transform", translate(1.0, 0.0, 0.0), None);
        d.commit_resources();
        let second = meshes(&d);
        assert!(first.iter().zip(&second).all(|(a, b)| Arc::ptr_eq(a, b)));
        // new pixels for the displacement's texture: that mesh is displaced again, alone
        assert!(d.add_texture("/h.png", 1, 1, 1, vec![0.25], false, ""));
        d.commit_resources();
        let third = meshes(&d);
        assert!(!Arc::ptr_eq(&third[3], &second[3]) && (third[3].positions[0].z - 0.25).abs() < 1e-6);
        assert!(third[..3].iter().zip(&second[..3]).all(|(a, b)| Arc::ptr_eq(a, b)));
        // another displacement amount over the same texture: displaced again
        d.set_attribute("/M", "/M/T.inputs:scale", floats(&[2.0, 2.0, 2.0, 2.0], 4), None);
        d.commit_resources();
        let fourth = meshes(&d);
        assert!(!Arc::ptr_eq(&fourth[3], &third[3]) && (fourth[3].positions[0].z - 0.5).abs() < 1e-6, "{:?}", fourth[3].positions[0]);
        // the subset mesh's points edited: its parts are made anew
        d.set_attribute("/S", "points", floats(&[0., 0., 0., 2., 0., 0., 2., 2., 0., 0., 2., 0.], 3), None);
        d.commit_resources();
        let fifth = meshes(&d);
        assert!(!Arc::ptr_eq(&fifth[1], &fourth[1]) && !Arc::ptr_eq(&fifth[2], &fourth[2]) && Arc::ptr_eq(&fifth[0], &fourth[0]));
        // displaced copies no longer used are let go
        d.set_attribute("/D", "material", Value::Path("/Red".into()), None);
        d.commit_resources();
        assert!(d.displaced_meshes.is_empty());
    }

    /// One file, read once, is decoded by each user's own `sourceColorSpace`: `raw` keeps the
    /// values, `sRGB` decodes them, `auto` decodes a file read as sRGB-encoded (8 bits, 3 or 4
    /// channels) and keeps another's; a dome light's image is read as `auto`.
    #[test]
    fn one_file_is_decoded_by_each_users_colour_space() {
        let decoded = 0.214_041f32; // sRGB 0.5 (IEC 61966-2-1)
        for (file_srgb, auto) in [(true, decoded), (false, 0.5)] {
            let mut d = Delegate::new();
            assert!(d.add_texture("/t.png", 1, 1, 3, vec![0.5, 0.5, 0.5], file_srgb, ""));
            for (k, cs) in ["raw", "auto", "sRGB"].iter().enumerate() {
                let (m, prim) = (format!("/M{k}"), format!("/A{k}"));
                textured_material(&mut d, &m, "/t.png");
                d.set_attribute(&m, &format!("{m}/T.inputs:sourceColorSpace"), tok(cs), None);
                quad(&mut d, &prim);
                d.set_attribute(&prim, "material", Value::Path(m), None);
            }
            d.create_prim("domeLight", "/Dome");
            d.set_attribute("/Dome", "inputs:texture:file", Value::Asset("/t.png".into()), None);
            assert!(d.commit_resources().is_empty());
            let mut values: Vec<f32> = d.scene().textures.iter().map(|t| t.pixels.value(0, t.channels as usize)).collect();
            values.sort_by(f32::total_cmp);
            let mut want = vec![0.5, auto, decoded, auto];
            want.sort_by(f32::total_cmp);
            assert_eq!(values.len(), 4, "a texture per colour space and the dome's");
            for (v, w) in values.iter().zip(&want) {
                assert!((v - w).abs() < 1e-5, "file sRGB {file_srgb}: {values:?} against {want:?}");
            }
        }
    }

    /// A quad whose material reads texture `asset` with `sourceColorSpace` `source` and the
    /// file colour space `space`, committed.
    fn read_by_a_material(d: &mut Delegate, asset: &str, source: &str, space: Option<&str>) {
        textured_material(d, "/M", asset);
        d.set_attribute("/M", "/M/T.inputs:sourceColorSpace", tok(source), None);
        if let Some(space) = space {
            d.set_attribute("/M", "/M/T.inputs:colorSpace:file", tok(space), None);
        }
        quad(d, "/A");
        d.set_attribute("/A", "material", Value::Path("/M".into()), None);
        assert!(d.commit_resources().is_empty());
    }

    /// An 8-bit file held as its codes converts, for every colour space, to the values the
    /// same file gives as floats (code / 255); decoded by a curve alone it shares the codes
    /// (no float copy), and alpha is never decoded.
    #[test]
    fn eight_bit_textures_convert_as_their_float_values_and_share_their_codes() {
        let codes: Vec<u8> = vec![0, 1, 64, 128, 200, 255, 17, 90]; // 2×1 RGBA
        let floats: Vec<f32> = codes.iter().map(|&b| b as f32 / 255.0).collect();
        // (sourceColorSpace, the file's colour space metadata, decoded by a curve alone)
        let spaces = [("raw", None, true), ("auto", None, true), ("sRGB", None, true), ("auto", Some("g22_rec709"), true), ("auto", Some("acescg"), false), ("auto", Some("srgb_ap1"), false)];
        for (source, space, by_curve) in spaces {
            let convert = |eight: bool| {
                let mut d = Delegate::new();
                let ok = if eight { d.add_texture_u8("/t.png", 2, 1, 4, codes.clone(), true, "") } else { d.add_texture("/t.png", 2, 1, 4, floats.clone(), true, "") };
                assert!(ok);
                read_by_a_material(&mut d, "/t.png", source, space);
                d.scene().textures[0].pixels.clone()
            };
            let (eight, float) = (convert(true), convert(false));
            assert_eq!(matches!(eight, Texels::U8 { .. }), by_curve, "{source} {space:?}: kept as codes");
            let (a, b) = (eight.to_f32(4), float.to_f32(4));
            for (x, y) in a.iter().zip(&b) {
                assert!((x - y).abs() <= 1e-6 * y.abs().max(1.0), "{source} {space:?}: {a:?} against {b:?}");
            }
            assert_eq!((a[3], a[7]), (floats[3], floats[7]), "{source} {space:?}: alpha kept");
        }
        // within one delegate the scene's texels are the held codes themselves
        let mut d = Delegate::new();
        assert!(d.add_texture_u8("/t.png", 2, 1, 4, codes.clone(), true, ""));
        textured_material(&mut d, "/M", "/t.png");
        quad(&mut d, "/A");
        d.set_attribute("/A", "material", Value::Path("/M".into()), None);
        d.commit_resources();
        let (Some(TexState::Loaded { pixels: Texels::U8 { codes: held, .. }, .. }), Texels::U8 { codes: used, .. }) = (d.textures.get("/t.png"), &d.scene().textures[0].pixels) else { panic!("8-bit texels expected") };
        assert!(Arc::ptr_eq(held, used));
        // a two-channel (grey, alpha) file is expanded to RGBA as floats are
        assert!(d.add_texture_u8("/g.png", 1, 1, 2, vec![51, 255], false, ""));
        assert_eq!(d.texture("/g.png").unwrap().pixels, vec![0.2, 0.2, 0.2, 1.0]);
        assert!(!d.add_texture_u8("/bad.png", 2, 2, 3, vec![0; 5], false, ""));
    }

    /// A 16-bit file (integers, or half floats) held as its codes converts, for every colour
    /// space, to the values of the same file as floats; undecoded it shares the codes, decoded
    /// by a curve alone too where the image is larger than a 16-bit decoding table.
    #[test]
    fn sixteen_bit_textures_convert_as_their_float_values_and_share_their_codes() {
        use tide_core::texture::half_to_f32;
        // (sourceColorSpace, the file's colour space metadata, undecoded, decoded by a curve alone)
        let spaces = [("raw", None, true, true), ("auto", None, true, true), ("sRGB", None, false, true), ("auto", Some("g22_rec709"), false, true), ("auto", Some("acescg"), false, false)];
        for half in [false, true] {
            for (w, h) in [(2u32, 1u32), (256, 256)] {
                let n = (w * h * 4) as usize;
                // spread over the codes: integers all of [0, 65535]; halves of [0, 2) and -0..
                let codes: Vec<u16> = (0..n).map(|i| if half { (i * 7919 % 0x4000) as u16 | if i % 5 == 0 { 0x8000 } else { 0 } } else { (i * 40503 % 65536) as u16 }).collect();
                let floats: Vec<f32> = codes.iter().map(|&b| if half { half_to_f32(b) } else { b as f32 / 65535.0 }).collect();
                for (source, space, undecoded, by_curve) in spaces {
                    let convert = |sixteen: bool| {
                        let mut d = Delegate::new();
                        let ok = if sixteen { d.add_texture_u16("/t.exr", w, h, 4, codes.clone(), half, false, "") } else { d.add_texture("/t.exr", w, h, 4, floats.clone(), false, "") };
                        assert!(ok);
                        read_by_a_material(&mut d, "/t.exr", source, space);
                        let kept = matches!((d.textures.get("/t.exr"), &d.scene().textures[0].pixels), (Some(TexState::Loaded { pixels: Texels::U16 { codes: a, .. }, .. }), Texels::U16 { codes: b, .. }) if Arc::ptr_eq(a, b));
                        (d.scene().textures[0].pixels.clone(), kept)
                    };
                    let ((sixteen, shared), (float, _)) = (convert(true), convert(false));
                    let what = format!("half {half} {w}x{h} {source} {space:?}");
                    assert_eq!(shared, undecoded || (by_curve && n >= 4 * CODES16), "{what}: codes shared");
                    let (a, b) = (sixteen.to_f32(4), float.to_f32(4));
                    for (x, y) in a.iter().zip(&b) {
                        assert!((x - y).abs() <= 1e-6 * y.abs().max(1.0) && x.is_sign_negative() == y.is_sign_negative(), "{what}: {x} against {y}");
                    }
                    assert!((3..n).step_by(4).all(|i| a[i] == floats[i]), "{what}: alpha kept");
                }
            }
        }
        // a two-channel (grey, alpha) file is expanded to RGBA as floats are; a wrong count fails
        let mut d = Delegate::new();
        assert!(d.add_texture_u16("/g.exr", 1, 1, 2, vec![0x3800, 0x3c00], true, false, ""));
        assert_eq!(d.texture("/g.exr").unwrap().pixels, vec![0.5, 0.5, 0.5, 1.0]);
        assert!(!d.add_texture_u16("/bad.exr", 2, 2, 3, vec![0; 5], false, false, ""));
    }

    #[test]
    fn textures_added_after_the_material_resync_it() {
        let mut d = Delegate::new();
        textured_material(&mut d, "/M", "/t.png");
        let p = d.commit_resources();
        assert_eq!(p[0].attribute, "/M/T.inputs:file");
        assert!(d.add_texture("/t.png", 1, 1, 3, vec![0.5, 0.5, 0.5], true, ""));
        let p = d.commit_resources();
        assert!(p.is_empty(), "{:?}", p);
        assert_eq!(d.last_synced(), ["/M"]);
        let t = &d.scene().textures[0];
        // sRGB 0.5 decodes to 0.21404 (IEC 61966-2-1); 1e-5 is f32 round-off of powf.
        assert!((t.pixels.value(0, 3) - 0.214_041).abs() < 1e-5, "{}", t.pixels.value(0, 3));
        assert!(!d.add_texture("/bad.png", 2, 2, 3, vec![0.0; 5], false, ""));
    }

    /// A camera with the shutter [open, close] (frames) at 25 frames per second.
    fn shutter(d: &mut Delegate, open: f64, close: f64) {
        d.create_prim("camera", "/cam");
        d.set_attribute("/cam", "shutter:open", Value::Float(open), None);
        d.set_attribute("/cam", "shutter:close", Value::Float(close), None);
        d.create_prim("renderSettings", "/S");
        d.set_attribute("/S", "timeCodesPerSecond", Value::Float(25.0), None);
    }

    fn motion_of<'a>(d: &'a Delegate, inst: &str) -> Option<&'a tide_core::scene::MeshMotion> {
        mesh_of(d, inst).motion.as_ref()
    }

    /// Through Hydra the settings carry no frame rate: the one the plugin sends with the camera
    /// turns frames into seconds; the settings' (the reader's) wins where given.
    #[test]
    fn the_frame_rate_comes_from_the_camera_when_the_settings_have_none() {
        let mut d = Delegate::new();
        d.create_prim("camera", "/cam");
        d.set_attribute("/cam", "shutter:open", Value::Float(-0.5), None);
        d.set_attribute("/cam", "shutter:close", Value::Float(0.5), None);
        d.set_attribute("/cam", "timeCodesPerSecond", Value::Float(10.0), None);
        quad(&mut d, "/Moving");
        d.set_attribute("/Moving", "velocities", floats(&[2., 0., 0.].repeat(4), 3), None);
        assert_eq!(d.commit_resources(), []);
        // ±0.5 frame at 10 frames per second = ±0.05 s
        assert_eq!(motion_of(&d, "/Moving").unwrap().times, vec![-0.05, 0.05]);
        d.create_prim("renderSettings", "/S");
        d.set_attribute("/S", "timeCodesPerSecond", Value::Float(25.0), None);
        d.commit_resources();
        assert_eq!(motion_of(&d, "/Moving").unwrap().times, vec![-0.02, 0.02]);
    }

    #[test]
    fn mesh_velocities_and_accelerations_become_keys_over_the_shutter() {
        let mut d = Delegate::new();
        shutter(&mut d, -0.5, 0.5);
        quad(&mut d, "/Still");
        d.set_attribute("/Still", "velocities", Value::Doubles { data: vec![0.0; 12].into(), tuple: 3 }, None);
        quad(&mut d, "/Moving");
        d.set_attribute("/Moving", "velocities", floats(&[2., 0., 0.].repeat(4), 3), None);
        d.set_attribute("/Moving", "accelerations", floats(&[0., 50., 0.].repeat(4), 3), None);
        assert_eq!(d.commit_resources(), []);
        assert!(motion_of(&d, "/Still").is_none());
        let m = motion_of(&d, "/Moving").unwrap();
        // shutter ±0.5 frame = ±0.02 s; p + v·t + a·t²/2 with v = 2 (x), a = 50 (y), keyed at
        // the ends and the middle (accelerations curve the path)
        assert_eq!(m.times, vec![-0.02, 0.0, 0.02]);
        let p0 = mesh_of(&d, "/Moving").positions[0];
        for (k, t) in [-0.02f32, 0.0, 0.02].into_iter().enumerate() {
            let want = p0 + Vec3::new(2.0 * t, 25.0 * t * t, 0.0);
            assert!((m.positions[k][0] - want).length() < 1e-6, "{:?} vs {want:?}", m.positions[k][0]);
        }
        // no motion blur: the mesh stands at frame 0
        d.set_attribute("/S", "disableMotionBlur", Value::Bool(true), None);
        d.commit_resources();
        assert!(motion_of(&d, "/Moving").is_none());
    }

    #[test]
    fn point_samples_become_keys_and_another_point_count_is_a_problem() {
        let mut d = Delegate::new();
        shutter(&mut d, 0.0, 0.5);
        let lifted = |y: f32| floats(&[0., y, 0., 1., y, 0., 1., 1. + y, 0., 0., 1. + y, 0.], 3);
        quad(&mut d, "/Blob");
        for (t, y) in [(-1.0, -1.0), (0.0, 0.0), (1.0, 4.0), (2.0, 9.0)] {
            d.set_attribute("/Blob", "points", lifted(y), Some(t));
        }
        assert_eq!(d.commit_resources(), []);
        let m = motion_of(&d, "/Blob").unwrap();
        // the samples at frames 0 and 1 bracket the shutter [0, 0.5]
        assert_eq!(m.times, vec![0.0, 0.04]);
        assert_eq!(m.positions[1][0], Vec3::new(0.0, 4.0, 0.0));
        d.set_attribute("/Blob", "points", floats(&[0.; 9], 3), Some(1.0));
        let p = d.commit_resources();
        assert_eq!(p.iter().map(|q| (q.item.as_str(), q.attribute.as_str())).collect::<Vec<_>>(), [("/Blob", "points")]);
        assert!(motion_of(&d, "/Blob").is_none());
        assert_eq!(mesh_of(&d, "/Blob").positions[0], Vec3::ZERO, "static at frame 0");
    }

    #[test]
    fn authored_normals_turn_with_a_rigidly_rotating_mesh() {
        let mut d = Delegate::new();
        shutter(&mut d, 0.0, 1.0);
        quad(&mut d, "/Card");
        d.set_primvar("/Card", "normals", "vertex", [0., 0., 1.].repeat(4), 3, None);
        // the card (in z = 0) turned 90° about x at frame 1: now in y = 0, facing −y
        d.set_attribute("/Card", "points", floats(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.], 3), Some(0.0));
        d.set_attribute("/Card", "points", floats(&[0., 0., 0., 1., 0., 0., 1., 0., 1., 0., 0., 1.], 3), Some(1.0));
        assert_eq!(d.commit_resources(), []);
        let n = motion_of(&d, "/Card").unwrap().normals.as_ref().unwrap();
        assert!((n[0][0] - Vec3::Z).length() < 1e-6 && (n[1][0] - Vec3::NEG_Y).length() < 1e-6, "{:?}", n[1][0]);
    }

    #[test]
    fn per_instance_primvars_follow_the_instances_kept() {
        let mut d = Delegate::new();
        quad(&mut d, "/P");
        let mut v = Vec::new();
        for k in 0..3 {
            let Value::Matrix(m) = translate(k as f64, 0., 0.) else { unreachable!() };
            v.extend_from_slice(&m);
        }
        v[16 + 12] = f64::NAN; // the second instance is dropped
        d.set_attribute("/P", "instanceTransforms", Value::Doubles { data: v.into(), tuple: 16 }, None);
        assert!(d.set_primvar("/P", "primvars:displayColor", "instance", vec![1., 0., 0., 0., 1., 0., 0., 0., 1.], 3, None));
        assert!(d.set_primvar("/P", "heat", "instance", vec![5., 6., 7.], 1, Some(vec![2, 1, 0])));
        assert!(d.set_primvar("/P", "short", "instance", vec![5., 6.], 1, None));
        let p = d.commit_resources();
        let attrs: Vec<&str> = p.iter().map(|q| q.attribute.as_str()).collect();
        assert_eq!(attrs, ["instanceTransforms", "primvars:short"], "{p:?}");
        let s = d.scene();
        assert_eq!(s.instances.iter().map(|i| i.primvar_row).collect::<Vec<_>>(), [Some((0, 0)), Some((0, 1))]);
        let t = &s.instance_primvars[0];
        assert_eq!(t.rows, 2);
        let pvs: Vec<(&str, &[f32])> = t.primvars.iter().map(|p| (p.name.as_str(), &p.data[..])).collect();
        assert_eq!(pvs, [("displayColor", &[1., 0., 0., 0., 0., 1.][..]), ("heat", &[7., 5.][..])]);
    }

    #[test]
    fn the_scene_origin_is_the_cameras_cell_corner_nearest_it() {
        // USD's default near (1 unit): 256 m cells in metres (1024 m capped), 1024 units in
        // centimetres, a quarter unit in kilometres (256 m to the nearest power of two)
        assert_eq!(scene_origin(Some(DVec3::new(100.0, -200.0, 1e5 + 0.3)), 1.0, 1.0), DVec3::new(0.0, -256.0, 100_096.0));
        assert_eq!(scene_origin(Some(DVec3::new(20_000.0, 0.0, -50_000.0)), 1.0, 0.01), DVec3::new(20_480.0, 0.0, -50_176.0));
        // a centimetre stage's camera with a 10 m near: capped at 256 m = 2^15 units
        assert_eq!(scene_origin(Some(DVec3::new(20_000.0, 0.0, -50_000.0)), 1000.0, 0.01), DVec3::new(32_768.0, 0.0, -65_536.0));
        assert_eq!(scene_origin(Some(DVec3::new(0.1, 0.2, 0.4)), 1.0, 1000.0), DVec3::new(0.0, 0.25, 0.5));
        // a macro camera (near 1 cm: 10.24 m, to 8 m cells); a near of 1 µm keeps 1 mm cells
        // (2^-10 m); a near of 0 or NaN the largest
        assert_eq!(scene_origin(Some(DVec3::new(13.0, -3.0, 1e5 + 0.3)), 0.01, 1.0), DVec3::new(16.0, 0.0, 100_000.0));
        assert_eq!(scene_origin(Some(DVec3::new(0.0031, 0.0, 0.0)), 1e-6, 1.0), DVec3::new(0.0029296875, 0.0, 0.0));
        assert_eq!(scene_origin(Some(DVec3::new(100.0, 0.0, 0.0)), 0.0, 1.0), DVec3::new(0.0, 0.0, 0.0));
        assert_eq!(scene_origin(Some(DVec3::new(200.0, 0.0, 0.0)), f64::NAN, 1.0), DVec3::new(256.0, 0.0, 0.0));
        // no camera, or one not placed: the world's origin
        assert_eq!(scene_origin(None, 1.0, 1.0), DVec3::ZERO);
        assert_eq!(scene_origin(Some(DVec3::new(f64::NAN, 0.0, 0.0)), 1.0, 1.0), DVec3::ZERO);
    }

    #[test]
    fn a_scene_far_from_the_origin_is_placed_about_its_camera() {
        // everything 3·10⁶ units out: positions reach the core relative to the camera's cell
        // corner, exact where single precision would have steps of 0.25
        let far = 3.0e6 + 0.125;
        let mut d = Delegate::new();
        quad(&mut d, "/P");
        d.set_attribute("/P", "transform", translate(far + 0.5, 2.0, -far), None);
        d.create_prim("camera", "/cam");
        d.set_attribute("/cam", "transform", translate(far, 0.0, -far + 3.0), None);
        d.create_prim("sphereLight", "/L");
        d.set_attribute("/L", "transform", translate(far + 0.0625, 1.0, -far), None);
        d.create_prim("portalLight", "/Door");
        d.set_attribute("/Door", "transform", translate(far - 0.0625, 1.0, -far), None);
        d.create_prim("domeLight", "/Dome");
        assert_eq!(d.commit_resources(), []);
        let s = d.scene();
        let o = scene_origin(Some(DVec3::new(far, 0.0, -far + 3.0)), 1.0, 1.0);
        assert_eq!(s.origin, o);
        assert!(o.x != 0.0 && (o.x - far).abs() <= 128.0, "{o}");
        let rel = |x: f64| (x - o.x) as f32;
        assert_eq!(s.instances[0].transforms[0].w_axis.truncate(), Vec3::new(rel(far + 0.5), 2.0, (-far - o.z) as f32));
        assert_eq!(s.camera.transforms[0].w_axis.truncate(), Vec3::new(rel(far), 0.0, (-far + 3.0 - o.z) as f32));
        let sphere = s.lights.iter().find(|l| l.name == "/L").unwrap();
        assert_eq!(sphere.transform.w_axis.x, rel(far + 0.0625));
        let dome = s.lights.iter().find(|l| l.name == "/Dome").unwrap();
        assert_eq!(dome.portals[0].transform.w_axis.x, rel(far - 0.0625));
        // the fractions survive: 0.5, 0.0625 apart as authored
        assert_eq!(s.instances[0].transforms[0].w_axis.x - s.camera.transforms[0].w_axis.x, 0.5);
        assert_eq!(sphere.transform.w_axis.x - dome.portals[0].transform.w_axis.x, 0.125);
        // a camera move within its cell keeps the world; one into the next cell moves it
        let before = d.world_generation;
        d.set_attribute("/cam", "transform", translate(far + 1.0, 0.0, -far + 3.0), None);
        assert_eq!(d.commit_resources(), []);
        assert_eq!((d.scene().origin, d.world_generation), (o, before));
        d.set_attribute("/cam", "transform", translate(o.x + 200.0, 0.0, -far + 3.0), None);
        assert_eq!(d.commit_resources(), []);
        assert_eq!(d.scene().origin.x, o.x + 256.0);
        assert!(d.world_generation > before);
        assert_eq!(d.scene().instances[0].transforms[0].w_axis.x, (far + 0.5 - o.x - 256.0) as f32);
    }

    /// `instanceIndices` gives each kept instance its `instanceId` (a dropped instance's index
    /// skipped); without it, or where it does not fit the instances (named), an instance's
    /// position among the authored matrices stands in; a prim drawn once has none.
    #[test]
    fn instance_indices_give_the_instance_ids_and_bad_ones_are_named() {
        let mut d = Delegate::new();
        quad(&mut d, "/P");
        quad(&mut d, "/Once");
        let mut mats = Vec::new();
        for k in 0..3 {
            let Value::Matrix(m) = translate(k as f64, 0., 0.) else { unreachable!() };
            mats.extend_from_slice(&m);
        }
        mats[16 + 12] = f64::NAN;
        d.set_attribute("/P", "instanceTransforms", Value::Doubles { data: mats.into(), tuple: 16 }, None);
        // (name, instanceId) of every instance, by name
        let ids = |d: &Delegate| {
            let mut v = d.scene().instances.iter().map(|i| (i.name.clone(), i.index)).collect::<Vec<_>>();
            v.sort();
            v
        };
        let attrs = |p: &[Problem]| p.iter().map(|q| (q.item.clone(), q.attribute.clone())).collect::<Vec<_>>();
        assert_eq!(attrs(&d.commit_resources()), [("/P".to_string(), "instanceTransforms".to_string())]);
        let want = |a: u32, b: u32| vec![("/Once".to_string(), None), ("/P[0]".to_string(), Some(a)), ("/P[1]".to_string(), Some(b))];
        assert_eq!(ids(&d), want(0, 2));
        // the kept instances take their own matrices: the first and the third
        let x = |name: &str| d.scene().instances.iter().find(|i| i.name == name).unwrap().transforms[0].w_axis.x;
        assert_eq!(x("/P[1]") - x("/P[0]"), 2.0);
        d.set_attribute("/P", "instanceIndices", Value::Ints(vec![7, 8, 9]), None);
        assert_eq!(attrs(&d.commit_resources()), [("/P".to_string(), "instanceTransforms".to_string())]);
        assert_eq!(ids(&d), want(7, 9));
        d.set_attribute("/P", "instanceIndices", Value::Ints(vec![7, -8, 9]), None);
        let p = d.commit_resources();
        assert!(p.iter().any(|q| q.item == "/P" && q.attribute == "instanceIndices" && q.message.contains("3 non-negative ints")), "{p:?}");
        assert_eq!(ids(&d), want(0, 2));
    }

    #[test]
    fn moving_instance_transforms_give_each_instance_motion_samples() {
        let mut d = Delegate::new();
        shutter(&mut d, 0.0, 1.0);
        quad(&mut d, "/P");
        d.set_attribute("/P", "transform", translate(0., 0., 5.), None);
        let mats = |dx: f64| {
            let mut v = Vec::new();
            for k in 0..2 {
                let Value::Matrix(m) = translate(k as f64 * 10.0 + dx * k as f64, 0., 0.) else { unreachable!() };
                v.extend_from_slice(&m);
            }
            Value::Doubles { data: v.into(), tuple: 16 }
        };
        d.set_attribute("/P", "instanceTransforms", mats(0.0), Some(0.0));
        d.set_attribute("/P", "instanceTransforms", mats(3.0), Some(1.0));
        assert_eq!(d.commit_resources(), []);
        let s = d.scene();
        let (i0, i1) = (&s.instances[0], &s.instances[1]);
        assert_eq!(i0.transforms.len(), 2, "samples of every instance, still or not");
        assert_eq!(i1.times, vec![0.0, 0.04]);
        assert_eq!(i1.transforms[0].w_axis.truncate(), Vec3::new(10.0, 0.0, 5.0));
        assert_eq!(i1.transforms[1].w_axis.truncate(), Vec3::new(13.0, 0.0, 5.0));
        // samples with another instance count: a problem, and the instances stand still
        d.set_attribute("/P", "instanceTransforms", Value::Doubles { data: vec![0.0; 16].into(), tuple: 16 }, Some(1.0));
        let p = d.commit_resources();
        assert_eq!(p.iter().map(|q| (q.item.as_str(), q.attribute.as_str())).collect::<Vec<_>>(), [("/P", "instanceTransforms")]);
        assert_eq!(d.scene().instances[1].transforms.len(), 1);
    }

    #[test]
    fn material_bind_subsets_give_their_faces_their_material() {
        let mut d = Delegate::new();
        red_material(&mut d, "/Red");
        d.create_prim("mesh", "/Strip");
        // three quads side by side: faces 0, 1, 2
        let pts: Vec<f32> = (0..4).flat_map(|i| [i as f32, 0., 0., i as f32, 1., 0.]).collect();
        d.set_attribute("/Strip", "points", floats(&pts, 3), None);
        d.set_attribute("/Strip", "faceVertexCounts", Value::Ints(vec![4, 4, 4]), None);
        d.set_attribute("/Strip", "faceVertexIndices", Value::Ints(vec![0, 2, 3, 1, 2, 4, 5, 3, 4, 6, 7, 5]), None);
        d.set_attribute("/Strip", "geomSubsets", Value::Paths(vec!["/Strip/a".into(), "/Strip/b".into()]), None);
        d.set_attribute("/Strip", "/Strip/a.indices", Value::Ints(vec![2, 7, -1]), None);
        d.set_attribute("/Strip", "/Strip/a.material", Value::Path("/Red".into()), None);
        d.set_attribute("/Strip", "/Strip/b.indices", Value::Ints(vec![0, 2]), None);
        d.set_attribute("/Strip", "/Strip/b.material", Value::Path("/Gone".into()), None);
        let p = d.commit_resources();
        let mut got: Vec<_> = p.iter().map(|q| (q.item.as_str(), q.attribute.as_str())).collect();
        got.sort();
        // out-of-range indices and a face claimed twice name subset a / b and `indices`; a
        // missing material names the subset and `material`
        assert_eq!(got, [("/Strip/a", "indices"), ("/Strip/b", "indices"), ("/Strip/b", "material")]);
        let s = d.scene();
        let parts: Vec<(&str, usize, String)> = s.instances.iter().map(|i| {
            let GeometryRef::Mesh(m) = i.geometry else { unreachable!() };
            (i.name.as_str(), s.meshes[m].indices.len() / 3, s.materials[i.material].name.clone())
        }).collect();
        // face 1 keeps the mesh's (default) material, face 2 takes /Red, face 0 is in b whose
        // material is gone (the mesh's material)
        assert_eq!(parts, [("/Strip", 2, "default".to_string()), ("/Strip /Strip/a", 2, "/Red".to_string()), ("/Strip /Strip/b", 2, "default".to_string())]);
        // each part holds only its own quad's four vertices
        assert!(s.meshes.iter().all(|m| m.positions.len() == 4));
    }

    #[test]
    fn prim_ids_are_stable_per_path() {
        let mut d = Delegate::new();
        quad(&mut d, "/A");
        quad(&mut d, "/B");
        d.commit_resources();
        let id_of = |d: &Delegate, name: &str| d.scene().instances.iter().find(|i| i.name == name).map(|i| i.id);
        let (a, b) = (id_of(&d, "/A").unwrap(), id_of(&d, "/B").unwrap());
        assert_ne!(a, b);
        d.destroy_prim("/A");
        quad(&mut d, "/C");
        quad(&mut d, "/A");
        d.commit_resources();
        assert_eq!((id_of(&d, "/A"), id_of(&d, "/B")), (Some(a), Some(b)));
        assert!(![a, b].contains(&id_of(&d, "/C").unwrap()));
        d.set_attribute("/C", "primId", Value::Int(77), None);
        d.commit_resources();
        assert_eq!(id_of(&d, "/C"), Some(77));
    }

    #[test]
    fn textures_read_back_as_held() {
        let mut d = Delegate::new();
        assert!(d.add_texture("/g.png", 2, 1, 2, vec![0.1, 0.9, 0.3, 0.7], false, ""));
        let t = d.texture("/g.png").unwrap();
        assert_eq!((t.width, t.height, t.channels), (2, 1, 4));
        assert_eq!(t.pixels, vec![0.1, 0.1, 0.1, 0.9, 0.3, 0.3, 0.3, 0.7]);
        d.texture_failed("/g.png", "gone");
        assert!(d.texture("/g.png").is_none());
        assert!(d.texture("/never.png").is_none());
    }

    #[test]
    fn motion_samples_instances_and_shutter() {
        let mut d = Delegate::new();
        quad(&mut d, "/A");
        d.set_attribute("/A", "transform", translate(0., 0., 0.), Some(-1.0));
        d.set_attribute("/A", "transform", translate(1., 0., 0.), Some(0.0));
        d.set_attribute("/A", "transform", translate(2., 0., 0.), Some(1.0));
        d.set_attribute("/A", "transform", translate(3., 0., 0.), Some(2.0));
        let mut inst = Vec::new();
        for k in 0..2 {
            let Value::Matrix(m) = translate(0., 10. * k as f64, 0.) else { unreachable!() };
            inst.extend_from_slice(&m);
        }
        d.set_attribute("/A", "instanceTransforms", Value::Doubles { data: inst.into(), tuple: 16 }, None);
        d.create_prim("camera", "/cam");
        d.set_attribute("/cam", "shutter:open", Value::Float(0.0), None);
        d.set_attribute("/cam", "shutter:close", Value::Float(0.5), None);
        d.create_prim("renderSettings", "/S");
        d.set_attribute("/S", "timeCodesPerSecond", Value::Float(25.0), None);
        d.commit_resources();
        let s = d.scene();
        assert_eq!(s.instances.len(), 2);
        let i1 = &s.instances[1];
        assert_eq!(i1.name, "/A[1]");
        // Samples at frames 0 and 1 bracket the shutter [0, 0.5]; seconds = frames / 25.
        assert_eq!(i1.times, vec![0.0, 0.04]);
        assert_eq!(i1.transforms[1].w_axis.truncate(), Vec3::new(2.0, 10.0, 0.0));
        assert_eq!((s.camera.shutter_open, s.camera.shutter_close), (0.0, 0.02));
        assert_eq!(s.camera.name, "/cam");
        d.set_attribute("/S", "disableMotionBlur", Value::Bool(true), None);
        d.commit_resources();
        let i0 = &d.scene().instances[0];
        assert_eq!((i0.transforms.len(), i0.times.clone()), (1, vec![0.0]));
        assert_eq!(i0.transforms[0].w_axis.x, 1.0);
    }

    #[test]
    fn instances_stand_for_their_own_paths_in_light_links() {
        let mut d = Delegate::new();
        quad(&mut d, "/Proto/m");
        let mut inst = Vec::new();
        for k in 0..3 {
            let Value::Matrix(m) = translate(2. * k as f64, 0., 0.) else { unreachable!() };
            inst.extend_from_slice(&m);
        }
        // the middle instance's matrix is not finite: dropped, and its path with it
        inst[16 + 12] = f64::NAN;
        d.set_attribute("/Proto/m", "instanceTransforms", Value::Doubles { data: inst.into(), tuple: 16 }, None);
        let paths = |v: &[&str]| Value::Paths(v.iter().map(|s| s.to_string()).collect());
        d.set_attribute("/Proto/m", "instancePaths", paths(&["/W/A/m", "/W/B/m", "/W/C/m"]), None);
        d.create_prim("distantLight", "/Sun");
        d.set_attribute("/Sun", "collection:lightLink:includes", paths(&["/W/C"]), None);
        d.set_attribute("/Sun", "collection:lightLink:includeRoot", Value::Bool(false), None);
        d.set_attribute("/Sun", "collection:shadowLink:excludes", paths(&["/W/A"]), None);
        let problems = d.commit_resources();
        assert_eq!(problems.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), ["instanceTransforms"], "{problems:?}");
        let s = d.scene();
        let names: Vec<&str> = s.instances.iter().map(|i| i.name.as_str()).collect();
        assert_eq!(names, ["/Proto/m[0]", "/Proto/m[1]"]);
        assert_eq!(s.instances[1].transforms[0].w_axis.x, 4.0, "the kept second instance is the third authored");
        let sun = s.lights.iter().find(|l| l.name == "/Sun").unwrap();
        assert_eq!(sun.light_link.as_deref(), Some(&["/Proto/m[1]".to_string()][..]), "only C's instance is linked");
        assert_eq!(sun.shadow_link.as_deref(), Some(&["/Proto/m[1]".to_string()][..]), "A's instance casts no shadow");
        // a path list that does not match the instances: reported, the prim's path for all
        d.set_attribute("/Proto/m", "instancePaths", paths(&["/W/A/m"]), None);
        let problems = d.commit_resources();
        assert!(problems.iter().any(|q| q.item == "/Proto/m" && q.attribute == "instancePaths" && q.message.contains("1 paths for 3 instances")), "{problems:?}");
        let sun = d.scene().lights.iter().find(|l| l.name == "/Sun").unwrap().clone();
        assert_eq!(sun.light_link.as_deref(), Some(&[][..]));
        d.set_attribute("/Proto/m", "instancePaths", paths(&[]), None);
        d.set_attribute("/Sun", "collection:lightLink:includes", paths(&["/Proto"]), None);
        assert!(d.commit_resources().iter().all(|q| q.attribute != "instancePaths"));
        let sun = d.scene().lights.iter().find(|l| l.name == "/Sun").unwrap().clone();
        assert_eq!(sun.light_link.map(|v| v.len()), Some(2));
    }

    #[test]
    fn domes_take_the_portals_they_name_else_those_no_dome_names() {
        let mut d = Delegate::new();
        let m = |x: f64| Value::Matrix([1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, x, 0.0, 0.0, 1.0]);
        for (path, x) in [("/Window", 1.0), ("/Door", 2.0), ("/Skylight", 3.0)] {
            d.create_prim("portalLight", path);
            d.set_attribute(path, "transform", m(x), None);
        }
        d.set_attribute("/Door", "inputs:width", Value::Float(0.8), None);
        d.set_attribute("/Door", "inputs:height", Value::Float(2.0), None);
        d.create_prim("domeLight", "/Named");
        d.set_attribute("/Named", "portals", Value::Paths(vec!["/Door".into(), "/Nothing".into()]), None);
        d.create_prim("domeLight", "/Unnamed");
        d.create_prim("sphereLight", "/Lamp");
        let p = d.commit_resources();
        assert!(p.iter().any(|q| q.item == "/Named" && q.attribute == "portals" && q.message.contains("'/Nothing' is not a PortalLight")), "{p:?}");
        let portals = |d: &Delegate, name: &str| d.scene().lights.iter().find(|l| l.name == name).unwrap().portals.clone();
        let named = portals(&d, "/Named");
        assert_eq!(named.len(), 1);
        assert_eq!((named[0].name.as_str(), named[0].width, named[0].height, named[0].transform.w_axis.x), ("/Door", 0.8, 2.0, 2.0));
        assert_eq!(portals(&d, "/Unnamed").iter().map(|p| p.name.as_str()).collect::<Vec<_>>(), ["/Skylight", "/Window"]);
        assert!(portals(&d, "/Lamp").is_empty());
        // a portal of zero area is reported and guides nothing; an invisible one is quietly out
        d.set_attribute("/Window", "inputs:width", Value::Float(0.0), None);
        d.set_attribute("/Skylight", "visibility", tok("invisible"), None);
        let p = d.commit_resources();
        assert!(p.iter().any(|q| q.item == "/Window" && q.attribute == "width"), "{p:?}");
        assert!(portals(&d, "/Unnamed").is_empty());
        assert!(d.scene().lights.len() == 3, "portals are not lights");
    }

    #[test]
    fn lights_camera_medium_and_purpose() {
        let mut d = Delegate::new();
        d.create_prim("domeLight", "/Dome");
        d.set_attribute("/Dome", "inputs:texture:file", Value::Asset("/sky.exr".into()), None);
        d.add_texture("/sky.exr", 2, 1, 3, vec![1.0; 6], false, "");
        d.create_prim("material", "/Sea");
        d.set_attribute("/Sea", "volume", Value::Path("/Sea/V".into()), None);
        d.set_attribute("/Sea", "/Sea/V.info:id", tok("TideMedium"), None);
        d.create_prim("camera", "/cam");
        d.set_attribute("/cam", "tide:medium", Value::Path("/Sea".into()), None);
        quad(&mut d, "/Proxy");
        d.set_attribute("/Proxy", "purpose", tok("proxy"), None);
        quad(&mut d, "/Hidden");
        d.set_attribute("/Hidden", "visibility", tok("invisible"), None);
        let p = d.commit_resources();
        assert!(p.is_empty(), "{:?}", p);
        let s = d.scene();
        assert_eq!(s.lights[0].shape, LightShape::Dome { texture: Some(0) });
        assert_eq!((s.textures[0].wrap_s, s.textures[0].wrap_t), (tide_core::scene::Wrap::Repeat, tide_core::scene::Wrap::Clamp));
        assert_eq!(s.camera.medium, Some(0));
        assert!(s.instances.is_empty());
    }

    fn ocean(d: &mut Delegate, path: &str) {
        d.create_prim("tideOcean", path);
        for (k, v) in [("windSpeed", 7.0), ("windDirection", 30.0), ("patchSize", 8.0), ("extent", 20.0), ("time", 1.5)] {
            d.set_attribute(path, k, Value::Float(v), None);
        }
        d.set_attribute(path, "resolution", Value::Int(16), None);
    }

    fn sea_material(d: &mut Delegate, path: &str) {
        d.create_prim("material", path);
        d.set_attribute(path, "surface", Value::Path(format!("{}/W", path)), None);
        d.set_attribute(path, &format!("{}/W.info:id", path), tok("TideWater"), None);
        d.set_attribute(path, &format!("{}/W.inputs:surfaceModel", path), tok("sea"), None);
    }

    fn water_of<'a>(d: &'a Delegate, inst: &str) -> &'a tide_core::scene::WaterDesc {
        match &material_of(d, inst).surface {
            SurfaceDesc::Water(w) => w,
            other => panic!("{inst}: not water: {other:?}"),
        }
    }

    fn mesh_of<'a>(d: &'a Delegate, inst: &str) -> &'a MeshDesc {
        let i = d.scene().instances.iter().find(|i| i.name == inst).unwrap();
        let GeometryRef::Mesh(m) = i.geometry else { panic!("{inst} is not a mesh") };
        &d.scene().meshes[m]
    }

    /// A mesh and points authored 10^4 units out in their own space, under transforms that
    /// bring them back near the camera: the core gets them about their own centres (so rays
    /// meet them in small numbers), their instances placed by as much, so that every point
    /// lands where it was authored to, to single-precision rounding of the result. A mesh's
    /// GeomSubset parts share one origin (vertices they share stay equal).
    #[test]
    fn geometry_far_out_in_its_own_space_is_placed_about_its_centre() {
        let far = DVec3::new(1.0e4 + 0.37, 0.0, -2.0e4 + 0.11);
        let mut d = Delegate::new();
        d.create_prim("mesh", "/M");
        let pts: Vec<DVec3> = [[0., 0., 0.], [1., 0., 0.], [1., 1., 0.], [0., 1., 0.], [2., 0., 0.], [2., 1., 0.]].iter().map(|p| far + DVec3::from(*p)).collect();
        d.set_attribute("/M", "points", floats(&pts.iter().flat_map(|p| p.to_array().map(|v| v as f32)).collect::<Vec<_>>(), 3), None);
        d.set_attribute("/M", "faceVertexCounts", Value::Ints(vec![4, 4]), None);
        d.set_attribute("/M", "faceVertexIndices", Value::Ints(vec![0, 1, 2, 3, 1, 4, 5, 2]), None);
        d.set_attribute("/M", "geomSubsets", Value::Paths(vec!["/M/s".into()]), None);
        d.set_attribute("/M", "/M/s.indices", Value::Ints(vec![1]), None);
        d.set_attribute("/M", "transform", translate(-far.x, -far.y, -far.z), None);
        d.create_prim("points", "/P");
        d.set_attribute("/P", "points", floats(&[far.x as f32, 1.0, far.z as f32, far.x as f32 + 1.0, 1.0, far.z as f32], 3), None);
        d.set_attribute("/P", "transform", translate(-far.x, -far.y, -far.z), None);
        let p = d.commit_resources();
        assert!(p.is_empty(), "{p:?}");
        let s = d.scene();
        let parts: Vec<&InstanceDesc> = s.instances.iter().filter(|i| i.name.starts_with("/M")).collect();
        assert_eq!(parts.len(), 2);
        let mut origins = Vec::new();
        for inst in parts {
            let GeometryRef::Mesh(mi) = inst.geometry else { panic!() };
            let m = &s.meshes[mi];
            origins.push(m.origin);
            assert!(m.origin.length() > 1e4 && m.positions.iter().all(|p| p.length() < 2.0), "{:?} {:?}", m.origin, m.positions);
            for q in &m.positions {
                // the authored point this one is, placed by the prim's transform (about the
                // scene's origin): its authored position minus `far`
                let authored = (q.as_dvec3() + m.origin.as_dvec3()) - far;
                let placed = inst.transforms[0].transform_point3(*q).as_dvec3() + s.origin;
                assert!((placed - authored).abs().max_element() < 1e-6, "{placed:?} vs {authored:?}");
            }
        }
        assert_eq!(origins[0], origins[1], "the parts share one origin");
        let inst = s.instances.iter().find(|i| i.name == "/P").unwrap();
        let GeometryRef::Spheres(si) = inst.geometry else { panic!() };
        let sp = &s.spheres[si];
        assert!(sp.origin.length() > 1e4);
        let placed: Vec<DVec3> = sp.centers.iter().map(|c| inst.transforms[0].transform_point3(*c).as_dvec3() + s.origin).collect();
        // the points as authored (single precision), brought back by `far`
        let authored = [0.0, 1.0].map(|dx: f64| DVec3::new((far.x as f32) as f64 + dx, 1.0, (far.z as f32) as f64) - far);
        assert!(placed.iter().zip(authored).all(|(p, a)| (*p - a).abs().max_element() < 1e-6), "{placed:?} vs {authored:?}");
    }

    #[test]
    fn ocean_is_the_fft_mesh_with_a_horizon_and_a_sub_grid_sea() {
        use tide_core::ocean::OceanParams;
        let mut d = Delegate::new();
        ocean(&mut d, "/Sea");
        d.set_attribute("/Sea", "transform", translate(0., -1., 0.), None);
        d.set_attribute("/Sea", "material", Value::Path("/M".into()), None);
        sea_material(&mut d, "/M");
        d.create_prim("camera", "/cam");
        d.set_attribute("/cam", "transform", translate(3., 1., 2.), None);
        let p = d.commit_resources();
        assert!(p.is_empty(), "{p:?}");
        let params = OceanParams { wind_speed: 7.0, wind_direction: 30.0, patch_size: 8.0, extent: 20.0, resolution: 16, ..Default::default() };
        // the camera 2 m above the ocean's origin, in its patch (0, 0): built about that patch's
        // centre, for its height and the default camera's pixel (USD's 20.955 mm aperture, a 50
        // mm lens, 640 pixels across) taken to the nearest half octave
        let half_octave = |v: f32| ((2.0 * v.log2()).round() * 0.5).exp2();
        let pixel = half_octave(2.0 * (20.955f32 / 100.0).atan() / 640.0);
        let view = tide_core::ocean::OceanView { position: Vec3::new(4.0, half_octave(2.0), 4.0), pixel_angle: pixel, pixel_width: 0.0 };
        let (surface, skirt) = tide_core::ocean::ocean_mesh_with_horizon_seen(&params, 1.5, &view, 262_144.0).unwrap();
        assert_eq!(mesh_of(&d, "/Sea").positions, surface.positions);
        assert_eq!(mesh_of(&d, "/Sea").indices, surface.indices);
        let surface = surface.clone();
        // the skirt reaches 1e5 camera heights out (2e5 m, rounded up to a power of two)
        assert_eq!(mesh_of(&d, "/Sea horizon").positions, skirt.unwrap().positions);
        let inst = d.scene().instances.iter().find(|i| i.name == "/Sea").unwrap();
        assert_eq!(inst.transforms[0].w_axis.y, -1.0);
        // the sea material takes the prim's wind and carries the sub-grid share; the skirt all
        let w = water_of(&d, "/Sea");
        let scale = ocean::sea_variance_scale(&params);
        assert!(scale > 0.2 && scale < 0.8, "{scale}");
        assert_eq!((w.wind_speed, w.slope_variance_scale), (7.0, scale));
        assert!((w.wind_direction - 30.0).abs() < 1e-4, "{}", w.wind_direction);
        assert_eq!(water_of(&d, "/Sea horizon").slope_variance_scale, 1.0);
        // seen by a coarse camera (4 pixels across: far patches coarser than the grid), a move
        // inside the patch keeps the mesh; into another patch re-tessellates
        d.create_prim("renderSettings", "/S");
        d.set_attribute("/S", "resolution", Value::Ints(vec![4, 4]), None);
        d.commit_resources();
        let before = mesh_of(&d, "/Sea").clone();
        assert_ne!(before.indices, surface.indices, "coarser far out than for 640 pixels");
        d.set_attribute("/cam", "transform", translate(5., 1., 7.), None);
        d.commit_resources();
        assert_eq!(mesh_of(&d, "/Sea"), &before);
        d.set_attribute("/cam", "transform", translate(-13., 1., 7.), None);
        d.commit_resources();
        assert_ne!(mesh_of(&d, "/Sea").indices, before.indices);
        // a depth makes a closed body and no skirt
        d.set_attribute("/Sea", "depth", Value::Float(30.0), None);
        assert!(d.commit_resources().is_empty());
        assert!(d.scene().instances.iter().all(|i| i.name != "/Sea horizon"));
        assert_eq!(mesh_of(&d, "/Sea").positions.iter().fold(0.0f32, |m, q| m.min(q.y)), -30.0);
    }

    /// In a centimetre stage (`metersPerUnit` 0.01, from the settings, or from the camera as a
    /// Hydra plugin sends it) the ocean is the metre one scaled into units, a medium's
    /// coefficients per metre are per unit a hundredth, its profile's lengths a hundredfold.
    #[test]
    fn metres_become_units_by_the_stages_meters_per_unit() {
        use tide_core::ocean::{ocean_mesh_with_horizon_seen, OceanParams, OceanView};
        for on_camera in [false, true] {
            let mut d = Delegate::new();
            ocean(&mut d, "/Sea");
            d.create_prim("camera", "/cam");
            d.set_attribute("/cam", "transform", translate(300., 100., 200.), None);
            let holder = if on_camera { "/cam" } else { "/S" };
            if !on_camera {
                d.create_prim("renderSettings", "/S");
            }
            d.set_attribute(holder, "metersPerUnit", Value::Float(0.01), None);
            d.create_prim("material", "/Sea/M");
            d.set_attribute("/Sea/M", "volume", Value::Path("/Sea/M/V.outputs:volume".into()), None);
            d.set_attribute("/Sea/M", "/Sea/M/V.info:id", tok("TideMedium"), None);
            for (k, v) in [("absorption", [0.5, 0.5, 0.5]), ("scattering", [0.1, 0.1, 0.1])] {
                d.set_attribute("/Sea/M", &format!("/Sea/M/V.inputs:{k}"), floats(&v, 3), None);
            }
            for (k, v) in [("chlorophyll", 1.0), ("profileDepth", 10.0), ("profileWidth", 2.0), ("profilePeak", 3.0)] {
                d.set_attribute("/Sea/M", &format!("/Sea/M/V.inputs:{k}"), Value::Float(v), None);
            }
            let p = d.commit_resources();
            assert!(p.is_empty(), "{p:?}");
            let params = OceanParams { wind_speed: 7.0, wind_direction: 30.0, patch_size: 8.0, extent: 20.0, resolution: 16, ..Default::default() };
            // the camera (3, 1, 2) m away: the metre mesh about patch (0, 0), 1 m up, seen with
            // the default camera's pixel, a hundred units a metre
            let pixel = ((2.0 * (2.0 * (20.955f32 / 100.0).atan() / 640.0).log2()).round() * 0.5).exp2();
            let view = OceanView { position: Vec3::new(4.0, 1.0, 4.0), pixel_angle: pixel, pixel_width: 0.0 };
            let (surface, _) = ocean_mesh_with_horizon_seen(&params, 1.5, &view, 262_144.0).unwrap();
            let want: Vec<Vec3> = surface.positions.iter().map(|v| *v / 0.01).collect();
            assert_eq!(mesh_of(&d, "/Sea").positions, want, "on the camera: {on_camera}");
            let m = &d.scene().media[0];
            assert_eq!(m.scale, 0.01);
            let profile = m.water.as_ref().and_then(|w| w.profile).unwrap();
            assert_eq!((profile.depth, profile.width, profile.peak), (1000.0, 200.0, 3.0));
        }
    }

    /// The stage's `upAxis` sets the direction water depth is measured down: Z on a Z-up stage,
    /// Y otherwise; an unknown axis is named. The reader sends it on the settings, a Hydra
    /// plugin with the camera (as `metersPerUnit`); the settings' wins where both give one.
    #[test]
    fn water_depth_follows_the_stages_up_axis() {
        let cases = [(None, None, Vec3::Y), (Some("Y"), None, Vec3::Y), (Some("Z"), None, Vec3::Z), (Some("X"), None, Vec3::Y), (None, Some("Z"), Vec3::Z), (None, Some("Y"), Vec3::Y), (Some("Y"), Some("Z"), Vec3::Y), (Some("Z"), Some("Y"), Vec3::Z)];
        for (axis, on_camera, up) in cases {
            let mut d = Delegate::new();
            d.create_prim("renderSettings", "/S");
            if let Some(a) = axis {
                d.set_attribute("/S", "upAxis", tok(a), None);
            }
            if let Some(a) = on_camera {
                d.create_prim("camera", "/cam");
                d.set_attribute("/cam", "transform", translate(0., 1., 5.), None);
                d.set_attribute("/S", "camera", Value::Path("/cam".into()), None);
                d.set_attribute("/cam", "upAxis", tok(a), None);
            }
            d.create_prim("material", "/M");
            d.set_attribute("/M", "volume", Value::Path("/M/V.outputs:volume".into()), None);
            d.set_attribute("/M", "/M/V.info:id", tok("TideMedium"), None);
            for (k, v) in [("chlorophyll", 1.0), ("profileDepth", 10.0), ("profileWidth", 2.0), ("profilePeak", 3.0)] {
                d.set_attribute("/M", &format!("/M/V.inputs:{k}"), Value::Float(v), None);
            }
            quad(&mut d, "/Q");
            d.set_attribute("/Q", "material", Value::Path("/M".into()), None);
            let p = d.commit_resources();
            assert_eq!(p.iter().map(|q| (q.item.as_str(), q.attribute.as_str())).collect::<Vec<_>>(), if axis == Some("X") { vec![("/S", "upAxis")] } else { vec![] }, "{p:?}");
            assert_eq!(d.scene().media[0].water.as_ref().unwrap().up, up, "{axis:?} on the settings, {on_camera:?} on the camera");
        }
    }

    #[test]
    fn bad_ocean_values_are_problems_with_defaults() {
        let mut d = Delegate::new();
        ocean(&mut d, "/Sea");
        d.set_attribute("/Sea", "windSpeed", Value::Float(-3.0), None);
        d.set_attribute("/Sea", "resolution", Value::Int(100), None);
        d.set_attribute("/Sea", "spectrum", tok("phillips"), None);
        d.set_attribute("/Sea", "choppiness", Value::Float(f64::NAN), None);
        d.set_attribute("/Sea", "depth", Value::Float(0.01), None);
        let p = d.commit_resources();
        let find = |a: &str| p.iter().find(|q| q.item == "/Sea" && q.attribute == a).unwrap_or_else(|| panic!("no {a} problem in {p:?}")).message.clone();
        assert!(find("windSpeed").ends_with("using 5"), "{}", find("windSpeed"));
        assert!(find("resolution").ends_with("using 256"), "{}", find("resolution"));
        assert!(find("spectrum").contains("using 'piersonMoskowitz'"));
        assert!(find("choppiness").contains("using 0"));
        // 1 cm does not reach below the troughs of a 5 m/s sea: built open instead
        assert!(find("depth").contains("an open sea"), "{}", find("depth"));
        assert!(d.scene().instances.iter().any(|i| i.name == "/Sea horizon"));
        // too many patches for the extent: capped
        d.set_attribute("/Sea", "patchSize", Value::Float(0.5), None);
        d.set_attribute("/Sea", "extent", Value::Float(5000.0), None);
        let p = d.commit_resources();
        let e = p.iter().find(|q| q.attribute == "extent").expect("extent problem");
        assert!(e.message.ends_with("using 128"), "{}", e.message);
    }

    fn sun_at(d: &mut Delegate, path: &str, elevation_deg: f32) {
        d.create_prim("distantLight", path);
        // +Z towards the sun: rotate +Z up about +X by the elevation
        let m = Mat4::from_rotation_x(-elevation_deg.to_radians());
        d.set_attribute(path, "transform", Value::Matrix(m.to_cols_array().map(|v| v as f64)), None);
        d.set_attribute(path, "inputs:intensity", Value::Float(5.0), None);
    }

    #[test]
    fn tide_sky_api_maps_to_the_sky_and_the_physical_sun() {
        let mut d = Delegate::new();
        d.create_prim("domeLight", "/Sky");
        d.set_attribute("/Sky", "tide:sky:model", tok("hosekWilkie"), None);
        d.set_attribute("/Sky", "tide:sky:turbidity", Value::Float(4.0), None);
        d.set_attribute("/Sky", "tide:sky:groundAlbedo", Value::Floats { data: vec![0.1, 0.2, 0.3], tuple: 3 }, None);
        d.set_attribute("/Sky", "tide:sky:sun", Value::Path("/Sun".into()), None);
        d.set_attribute("/Sky", "tide:sky:physicalSun", Value::Bool(true), None);
        d.set_attribute("/Sky", "inputs:intensity", Value::Float(0.5), None);
        sun_at(&mut d, "/Sun", 30.0);
        let p = d.commit_resources();
        assert!(p.is_empty(), "{:?}", p);
        let s = d.scene();
        let sky = s.lights.iter().find(|l| l.name == "/Sky").unwrap();
        let sun = s.lights.iter().find(|l| l.name == "/Sun").unwrap();
        let nits = tide_core::sky::nits_per_model_unit();
        let LightShape::Sky { turbidity, ground_albedo, sun_direction, scale } = sky.shape.clone() else { panic!("{:?}", sky.shape) };
        assert_eq!((turbidity, ground_albedo, scale), (4.0, [0.1, 0.2, 0.3], nits));
        assert!((sun_direction.dot(Vec3::Y) - 30f32.to_radians().sin()).abs() < 1e-5, "{sun_direction}");
        assert_eq!(sun.shape, LightShape::SkySun { zenith: Vec3::Y, turbidity: 4.0, scale: nits });
        // the sky's scale, not the DistantLight's intensity
        assert_eq!((sun.intensity, sun.exposure), (0.5, 0.0));
        // the renderer builds both
        let mut probs = Vec::new();
        let w = tide_core::world::World::build(s, &RenderSettings { width: 4, height: 4, ..Default::default() }, &mut probs);
        assert!(probs.is_empty(), "{probs:?}");
        assert_eq!(w.lights.len(), 2);
    }

    /// Through a Hydra scene delegate the sun relationship cannot arrive: the plugin says so, and
    /// the scene's only DistantLight is the sun (said as a problem); with two, none is guessed.
    #[test]
    fn an_unreadable_sun_relationship_takes_the_only_distant_light() {
        let mut d = Delegate::new();
        d.create_prim("domeLight", "/Sky");
        d.set_attribute("/Sky", "tide:sky:model", tok("hosekWilkie"), None);
        d.set_attribute("/Sky", "tide:sky:physicalSun", Value::Bool(true), None);
        d.set_attribute("/Sky", "tide:sky:sunUnreadable", Value::Bool(true), None);
        sun_at(&mut d, "/Sun", 30.0);
        let p = d.commit_resources();
        assert_eq!(p.iter().map(|q| (q.item.as_str(), q.attribute.as_str())).collect::<Vec<_>>(), [("/Sky", "tide:sky:sun")], "{p:?}");
        assert!(p[0].message.contains("'/Sun' is the sun"), "{}", p[0].message);
        let sky = d.scene().lights.iter().find(|l| l.name == "/Sky").unwrap().shape.clone();
        let LightShape::Sky { sun_direction, .. } = sky else { panic!() };
        assert!((sun_direction.dot(Vec3::Y) - 30f32.to_radians().sin()).abs() < 1e-5, "{sun_direction}");
        assert!(matches!(d.scene().lights.iter().find(|l| l.name == "/Sun").unwrap().shape, LightShape::SkySun { .. }));
        // a second DistantLight: no guess, the default elevation
        sun_at(&mut d, "/Moon", 60.0);
        let p = d.commit_resources();
        assert!(p.iter().any(|q| q.attribute == "tide:sky:sun" && q.message.contains("2 DistantLights")), "{p:?}");
        let LightShape::Sky { sun_direction, .. } = d.scene().lights.iter().find(|l| l.name == "/Sky").unwrap().shape.clone() else { panic!() };
        assert!((sun_direction.dot(Vec3::Y) - lux::DEFAULT_SUN_ELEVATION_DEG.to_radians().sin()).abs() < 1e-5);
        // without the plugin's word (the reader: an unauthored relationship), nothing is guessed
        d.set_attribute("/Sky", "tide:sky:sunUnreadable", Value::Bool(false), None);
        d.destroy_prim("/Moon");
        let p = d.commit_resources();
        assert!(!p.iter().any(|q| q.attribute == "tide:sky:sun"), "{p:?}");
    }

    #[test]
    fn bad_sky_values_are_problems_naming_prim_and_attribute() {
        let mut d = Delegate::new();
        d.create_prim("domeLight", "/Sky");
        d.set_attribute("/Sky", "tide:sky:turbidity", Value::Float(12.0), None);
        d.set_attribute("/Sky", "tide:sky:groundAlbedo", Value::Floats { data: vec![1.5, 0.2, -0.1], tuple: 3 }, None);
        d.set_attribute("/Sky", "tide:sky:model", tok("preetham"), None);
        d.set_attribute("/Sky", "tide:sky:sun", Value::Path("/Sun".into()), None);
        d.set_attribute("/Sky", "tide:sky:physicalSun", Value::Bool(true), None);
        sun_at(&mut d, "/Sun", -10.0);
        let p = d.commit_resources();
        let attrs: Vec<(&str, &str)> = p.iter().map(|x| (x.item.as_str(), x.attribute.as_str())).collect();
        for a in ["tide:sky:turbidity", "tide:sky:groundAlbedo", "tide:sky:model", "tide:sky:sun"] {
            assert!(attrs.contains(&("/Sky", a)), "{a} missing from {p:?}");
        }
        let below = p.iter().find(|x| x.attribute == "tide:sky:sun").unwrap();
        assert!(below.message.contains("below the horizon") && below.message.contains("physical sun is off"), "{}", below.message);
        let s = d.scene();
        // the sky renders clamped (turbidity 10, albedo in [0, 1], sun on the horizon); the
        // physical sun below the horizon is dropped
        assert_eq!(s.lights.len(), 1);
        let LightShape::Sky { turbidity, ground_albedo, sun_direction, .. } = s.lights[0].shape.clone() else { panic!() };
        assert_eq!((turbidity, ground_albedo), (10.0, [1.0, 0.2, 0.0]));
        assert!(sun_direction.dot(Vec3::Y).abs() < 1e-6 && sun_direction.z > 0.9);
        let mut probs = Vec::new();
        tide_core::world::World::build(s, &RenderSettings { width: 4, height: 4, ..Default::default() }, &mut probs);
        assert!(probs.is_empty(), "{probs:?}");
        // a sun that is not a DistantLight: the default sun, named in the problem
        d.set_attribute("/Sky", "tide:sky:sun", Value::Path("/Nothing".into()), None);
        let p = d.commit_resources();
        assert!(p.iter().any(|x| x.attribute == "tide:sky:sun" && x.message.contains("/Nothing")), "{p:?}");
    }

    #[test]
    fn camera_filter_maps_to_the_core() {
        let mut d = Delegate::new();
        d.create_prim("camera", "/cam");
        d.set_attribute("/cam", "tide:camera:filter", tok("underwaterRed"), None);
        let p = d.commit_resources();
        assert!(p.is_empty(), "{p:?}");
        assert_eq!(d.scene().camera.filter, tide_core::scene::CameraFilter::UnderwaterRed);
        d.set_attribute("/cam", "tide:camera:filter", tok("sepia"), None);
        let p = d.commit_resources();
        assert!(p.iter().any(|x| x.item == "/cam" && x.attribute == "tide:camera:filter"), "{p:?}");
        assert_eq!(d.scene().camera.filter, tide_core::scene::CameraFilter::None);
    }

    #[test]
    fn a_one_prim_edit_rebuilds_only_that_prims_geometry() {
        let mut d = Delegate::new();
        for k in 0..5 {
            quad(&mut d, &format!("/Q{k}"));
            let mut pts = vec![0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.];
            pts.iter_mut().skip(2).step_by(3).for_each(|z| *z = k as f32);
            d.set_attribute(&format!("/Q{k}"), "points", floats(&pts, 3), None);
        }
        d.commit_resources();
        let build = crate::render_pass::core_factory();
        let settings = RenderSettings { width: 4, height: 4, spp: 1, ..Default::default() };
        let stats = |d: &Delegate| {
            let s = build(d.scene(), &settings).ok().and_then(|e| e.build_stats()).unwrap();
            (s.blas_built, s.blas_reused)
        };
        assert_eq!(stats(&d), (5, 0));
        // Moved: the prim re-syncs, its geometry is the same, so no BVH is rebuilt.
        d.set_attribute("/Q3", "transform", translate(0., 2., 0.), None);
        d.commit_resources();
        assert_eq!(d.last_synced(), ["/Q3"]);
        assert_eq!(stats(&d), (0, 5));
        // Points edited: that one BVH is rebuilt.
        d.set_attribute("/Q1", "points", floats(&[0., 0., 9., 2., 0., 9., 2., 2., 9., 0., 2., 9.], 3), None);
        d.commit_resources();
        assert_eq!(stats(&d), (1, 4));
    }

    #[test]
    fn placement_edits_keep_the_converted_geometry() {
        let mut d = Delegate::new();
        quad(&mut d, "/A");
        // A face with two vertices: a geometry problem that must stay reported.
        d.set_attribute("/A", "faceVertexCounts", Value::Ints(vec![4, 2]), None);
        d.set_attribute("/A", "faceVertexIndices", Value::Ints(vec![0, 1, 2, 3, 0, 1]), None);
        let first = d.commit_resources();
        assert!(first.iter().any(|q| q.attribute == "faceVertexCounts"), "{:?}", first);
        let geometry = |d: &Delegate| match &d.cache["/A"].piece {
            Piece::Rprim(r) => r.geometry.clone(),
            _ => unreachable!(),
        };
        let g0 = geometry(&d);
        for (name, value) in [("transform", translate(0., 0., 5.)), ("material", Value::Path("/M".into())), ("visibility", tok("visible")), ("primId", Value::Int(7))] {
            d.set_attribute("/A", name, value, None);
            d.commit_resources();
            assert_eq!(d.last_synced(), ["/A"]);
            assert!(Arc::ptr_eq(&g0, &geometry(&d)), "{} re-converted the geometry", name);
        }
        assert!(d.problems().iter().any(|q| q.attribute == "faceVertexCounts"));
        assert_eq!(d.scene().instances[0].transforms[0].w_axis.z, 5.0);
        assert_eq!(d.scene().meshes[0].indices.len(), 6);
        // Anything else (an attribute, a primvar, doubleSided) converts the geometry again.
        d.set_attribute("/A", "doubleSided", Value::Bool(true), None);
        d.commit_resources();
        let g1 = geometry(&d);
        assert!(!Arc::ptr_eq(&g0, &g1) && d.scene().meshes[0].double_sided);
        d.set_primvar("/A", "st", "vertex", vec![0.0; 8], 2, None);
        d.commit_resources();
        assert!(!Arc::ptr_eq(&g1, &geometry(&d)) && d.scene().meshes[0].uvs.is_some());
        d.set_attribute("/A", "faceVertexCounts", Value::Ints(vec![3, 3]), None);
        d.commit_resources();
        assert!(!d.problems().iter().any(|q| q.attribute == "faceVertexCounts"));
        assert_eq!(d.scene().meshes[0].indices.len(), 6);
    }

    /// A delegate on the core renderer that counts its builds: a quad under a dome, a camera
    /// at (x, 0.5, z), an 8×6 colour buffer, 2 spp.
    fn counted_core_delegate(x: f64, z: f64) -> (Delegate, Arc<AtomicU32>) {
        let builds = Arc::new(AtomicU32::new(0));
        let (inner, n) = (crate::render_pass::core_factory(), builds.clone());
        let factory: EngineFactory = Arc::new(move |scene, settings| {
            n.fetch_add(1, Ordering::SeqCst);
            inner(scene, settings)
        });
        let mut d = Delegate::with_engine(factory);
        quad(&mut d, "/A");
        d.create_prim("domeLight", "/Dome");
        d.create_prim("camera", "/cam");
        d.set_attribute("/cam", "transform", translate(x, 0.5, z), None);
        d.create_prim("renderBuffer", "/buf");
        d.set_attribute("/buf", "dimensions", Value::Ints(vec![8, 6]), None);
        d.create_prim("renderSettings", "/S");
        d.set_attribute("/S", "tide:samples", Value::Int(2), None);
        d.commit_resources();
        d.execute(Some("/cam"), &[("color".into(), "/buf".into())], Some("/S"));
        assert!(d.wait(Duration::from_secs(20)) && d.is_converged());
        (d, builds)
    }

    #[test]
    fn a_moved_camera_keeps_the_engine_and_renders_as_a_new_one() {
        let (mut d, builds) = counted_core_delegate(0.5, 3.0);
        let first = d.map_buffer("/buf").unwrap().pixels;
        d.set_attribute("/cam", "transform", translate(0.4, 0.5, 2.0), None);
        d.commit_resources();
        assert!(d.wait(Duration::from_secs(20)) && d.is_converged());
        let moved = d.map_buffer("/buf").unwrap();
        assert_eq!(builds.load(Ordering::SeqCst), 1, "the camera move re-aimed the engine");
        assert_eq!(moved.samples, 2);
        assert_ne!(moved.pixels, first);
        // a delegate that starts with the camera there renders the same pixels
        let (fresh, _) = counted_core_delegate(0.4, 2.0);
        assert_eq!(fresh.map_buffer("/buf").unwrap().pixels, moved.pixels);
        // anything else builds anew: the quad moved, or a shutter that places the scene anew
        d.set_attribute("/A", "transform", translate(0.0, 0.1, 0.0), None);
        d.commit_resources();
        assert!(d.wait(Duration::from_secs(20)));
        assert_eq!(builds.load(Ordering::SeqCst), 2);
        d.set_attribute("/cam", "shutter:close", Value::Float(0.5), None);
        d.commit_resources();
        assert!(d.wait(Duration::from_secs(20)));
        assert_eq!(builds.load(Ordering::SeqCst), 3);
    }

    /// What the engine finds while preparing its scene (here the core's validation dropping a
    /// zero-area triangle) reaches the first commit after the engine is built, once; a check
    /// without rendering finds it too.
    #[test]
    fn problems_the_engine_finds_are_returned_once() {
        let flat = |d: &mut Delegate| {
            d.create_prim("mesh", "/Flat");
            d.set_attribute("/Flat", "points", floats(&[0., 0., 0., 1., 0., 0., 2., 0., 0.], 3), None);
            d.set_attribute("/Flat", "faceVertexCounts", Value::Ints(vec![3]), None);
            d.set_attribute("/Flat", "faceVertexIndices", Value::Ints(vec![0, 1, 2]), None);
        };
        let (mut d, _) = counted_core_delegate(0.5, 3.0);
        assert!(d.commit_resources().is_empty() && d.problems().is_empty());
        flat(&mut d);
        let mut found = d.commit_resources();
        assert!(d.wait(Duration::from_secs(20)));
        found.extend(d.commit_resources());
        let flat_problems: Vec<&Problem> = found.iter().filter(|p| p.item == "/Flat").collect();
        assert_eq!(flat_problems.len(), 1, "{found:?}");
        assert_eq!(flat_problems[0].attribute, "points");
        assert!(flat_problems[0].message.contains("1 degenerate"), "{}", flat_problems[0].message);
        assert!(d.commit_resources().is_empty(), "returned once");
        assert!(d.problems().iter().any(|p| p.item == "/Flat"));
        // commits and waits for the engine the commit started, then commits again (the engine's
        // problems arrive with that second commit): the /Flat problems of both
        let settle = |d: &mut Delegate| {
            let mut got = d.commit_resources();
            assert!(d.wait(Duration::from_secs(20)));
            got.extend(d.commit_resources());
            got.into_iter().filter(|p| p.item == "/Flat").count()
        };
        // still flat after an edit: not returned again; mended, then flat again: returned again
        d.set_attribute("/Flat", "transform", translate(0.0, 0.5, 0.0), None);
        assert_eq!(settle(&mut d), 0);
        d.set_attribute("/Flat", "points", floats(&[0., 0., 0., 1., 0., 0., 2., 1., 0.], 3), None);
        assert_eq!(settle(&mut d), 0);
        assert!(!d.problems().iter().any(|p| p.item == "/Flat"));
        flat(&mut d);
        assert_eq!(settle(&mut d), 1, "a problem brought back is returned again");

        let mut fresh = Delegate::new();
        quad(&mut fresh, "/A");
        flat(&mut fresh);
        fresh.create_prim("camera", "/cam");
        fresh.commit_resources();
        let checked = fresh.check_render();
        assert_eq!(checked.iter().filter(|p| p.item == "/Flat").count(), 1, "{checked:?}");
        assert!(fresh.check_render().is_empty());
    }

    /// Hydra's render tags: a pass renders the prims whose tag it names (and those without a
    /// tag); no tags renders all but the hidden; a prim's tag edited moves it in or out without
    /// converting its geometry again.
    #[test]
    fn render_tags_choose_the_prims_a_pass_renders() {
        let mut d = Delegate::with_engine(fake_factory(Duration::ZERO, None, Default::default(), Default::default()));
        for p in ["/Geo", "/Proxy", "/Guide", "/Untagged", "/Hidden"] {
            quad(&mut d, p);
        }
        d.set_attribute("/Hidden", "renderTag", tok("hidden"), None);
        d.set_attribute("/Geo", "renderTag", tok("geometry"), None);
        d.set_attribute("/Proxy", "renderTag", tok("proxy"), None);
        d.set_attribute("/Guide", "renderTag", tok("guide"), None);
        d.create_prim("camera", "/cam");
        d.commit_resources();
        let rendered = |d: &mut Delegate, tags: &[&str]| {
            d.set_render_tags(&tags.iter().map(|t| t.to_string()).collect::<Vec<_>>());
            d.execute(Some("/cam"), &[], None);
            let mut names: Vec<String> = d.scene().instances.iter().map(|i| i.name.clone()).collect();
            names.sort();
            names
        };
        assert_eq!(rendered(&mut d, &[]), ["/Geo", "/Guide", "/Proxy", "/Untagged"]);
        assert_eq!(rendered(&mut d, &["geometry"]), ["/Geo", "/Untagged"]);
        assert_eq!(rendered(&mut d, &["proxy", "geometry", "proxy"]), ["/Geo", "/Proxy", "/Untagged"]);
        assert_eq!(rendered(&mut d, &["render"]), ["/Untagged"]);
        assert_eq!(rendered(&mut d, &["hidden"]), ["/Hidden", "/Untagged"]);
        assert_eq!(rendered(&mut d, &[]), ["/Geo", "/Guide", "/Proxy", "/Untagged"]);
        let geometry = |d: &Delegate| match &d.cache["/Guide"].piece {
            Piece::Rprim(r) => r.geometry.clone(),
            _ => unreachable!(),
        };
        let before = geometry(&d);
        assert_eq!(rendered(&mut d, &["geometry"]), ["/Geo", "/Untagged"]);
        d.set_attribute("/Guide", "renderTag", tok("geometry"), None);
        d.commit_resources();
        assert_eq!(rendered(&mut d, &["geometry"]), ["/Geo", "/Guide", "/Untagged"]);
        assert!(Arc::ptr_eq(&before, &geometry(&d)), "a tag edit converted the geometry again");
    }

    /// A buffer whose `tide:publish` is false is bound (its AOV is rendered) but left
    /// unfilled by the passes; the others are filled; a bad value is a problem and publishes.
    #[test]
    fn a_buffer_told_not_to_publish_is_left_unfilled() {
        let builds = Arc::new(AtomicU32::new(0));
        let passes = Arc::new(Mutex::new(Vec::new()));
        let mut d = Delegate::with_engine(fake_factory(Duration::ZERO, None, builds, passes));
        quad(&mut d, "/A");
        for b in ["/col", "/dep", "/nrm"] {
            d.create_prim("renderBuffer", b);
            d.set_attribute(b, "dimensions", Value::Ints(vec![8, 4]), None);
        }
        d.set_attribute("/dep", "tide:publish", Value::Bool(false), None);
        d.set_attribute("/nrm", "tide:publish", Value::Token("no".into()), None);
        d.create_prim("renderSettings", "/S");
        d.set_attribute("/S", "tide:samples", Value::Int(4), None);
        let problems = d.commit_resources();
        assert!(problems.iter().any(|p| p.item == "/nrm" && p.attribute == "tide:publish"), "{problems:?}");
        d.execute(None, &[("color".into(), "/col".into()), ("depth".into(), "/dep".into()), ("normal".into(), "/nrm".into())], Some("/S"));
        assert!(d.wait(Duration::from_secs(5)) && d.is_converged());
        assert_eq!(d.map_buffer("/col").unwrap().samples, 4);
        assert_eq!(d.map_buffer("/nrm").unwrap().samples, 4);
        let dep = d.map_buffer("/dep").unwrap();
        assert_eq!(dep.samples, 0);
        assert!(dep.pixels.iter().all(|&v| v == 0.0));
    }

    #[test]
    fn render_pass_lifecycle_through_the_delegate() {
        let builds = Arc::new(AtomicU32::new(0));
        let passes = Arc::new(Mutex::new(Vec::new()));
        let mut d = Delegate::with_engine(fake_factory(Duration::ZERO, None, builds.clone(), passes));
        quad(&mut d, "/A");
        d.create_prim("renderBuffer", "/buf");
        d.set_attribute("/buf", "dimensions", Value::Ints(vec![8, 4]), None);
        d.create_prim("renderSettings", "/S");
        d.set_attribute("/S", "tide:samples", Value::Int(4), None);
        d.commit_resources();
        assert!(d.map_buffer("/buf").unwrap().pixels.len() == 8 * 4 * 4);
        let p = d.execute(None, &[("color".into(), "/buf".into()), ("bogus".into(), "/buf".into())], Some("/S"));
        assert_eq!(p.len(), 1);
        assert!(d.wait(Duration::from_secs(5)) && d.is_converged());
        let m = d.map_buffer("/buf").unwrap();
        assert_eq!((m.width, m.height, m.channels, m.samples), (8, 4, 4, 4));
        // Same execute again: no restart.
        d.execute(None, &[("color".into(), "/buf".into())], Some("/S"));
        assert_eq!(builds.load(Ordering::SeqCst), 1);
        // A commit that changes something restarts; one that changes nothing does not.
        d.commit_resources();
        assert_eq!(builds.load(Ordering::SeqCst), 1);
        d.set_attribute("/S", "tide:samples", Value::Int(2), None);
        d.commit_resources();
        assert!(d.wait(Duration::from_secs(5)));
        assert_eq!(builds.load(Ordering::SeqCst), 2);
        assert_eq!(d.map_buffer("/buf").unwrap().samples, 2);
        assert!(d.write_exr(std::path::Path::new("/nonexistent/x.exr"), &[("beauty".into(), "color".into(), "color3f".into())], &[]).is_ok());
        drop(d);
    }

    /// A droplet cloud as a medium, its points scaled by `unit` and placed by a transform that
    /// scales by 1/`unit`: the same cloud in the world, authored in other units.
    fn droplet_volume(unit: f32) -> tide_core::scene::VolumeDesc {
        let mut d = Delegate::new();
        d.create_prim("points", "/Spray");
        // 27 touching droplets of 6 mm radius 1 cm apart: the middle one becomes medium
        let pts: Vec<f32> = (0..27).flat_map(|i| [(i % 3) as f32, (i / 3 % 3) as f32, (i / 9) as f32]).map(|x| x * 0.01 * unit).collect();
        d.set_attribute("/Spray", "points", floats(&pts, 3), None);
        d.set_primvar("/Spray", "widths", "constant", vec![0.012 * unit], 1, None);
        d.set_attribute("/Spray", "tide:droplets:asVolume", Value::Bool(true), None);
        d.set_attribute("/Spray", "tide:droplets:voxelSize", Value::Float(0.005), None);
        let s = 1.0 / unit as f64;
        d.set_attribute("/Spray", "transform", Value::Matrix([s, 0., 0., 0., 0., s, 0., 0., 0., 0., s, 0., 0.3, 0., 0., 1.]), None);
        let problems = d.commit_resources();
        assert!(problems.is_empty(), "{problems:?}");
        assert_eq!(d.scene().volumes.len(), 1, "the droplets became a medium");
        let mut v = d.scene().volumes[0].clone();
        // σs per world unit: the grid's values times the medium's scale
        let k = d.scene().media[v.medium].scale;
        let dense: Vec<f32> = v.density.values.to_dense().iter().map(|x| x * k).collect();
        v.density = tide_core::scene::GridDesc::dense(v.density.name.clone(), v.density.values.dims().map(|n| n as u32), &dense, v.density.local_to_world).unwrap();
        v
    }

    #[test]
    fn a_droplet_grids_voxels_are_metres_of_the_world_whatever_the_prims_scale() {
        // the voxel size (and shell) are world lengths: authored in centimetres under a scale
        // of 0.01, or in kilometres under 1000, the cloud makes the grid it makes in metres
        let metres = droplet_volume(1.0);
        for unit in [100.0, 0.001] {
            let other = droplet_volume(unit);
            assert_eq!(other.density.values.dims(), metres.density.values.dims(), "unit {unit}");
            let (a, b) = (other.density.values.to_dense(), metres.density.values.to_dense());
            assert!(b.iter().any(|&x| x > 0.0) && a.iter().zip(&b).all(|(x, y)| (x - y).abs() <= 1e-5 * y), "unit {unit}: {a:?} against {b:?}");
            let (a, b) = (other.density.local_to_world, metres.density.local_to_world);
            assert!(a.abs_diff_eq(b, 1e-6), "unit {unit}: {a} against {b}");
        }
    }
}

/// A decoded texture as materials read it: linearised where its key's encoding asks (`auto`
/// by `file_srgb`), a dome's image resampled to lat-long (None where it cannot be).
fn convert_texture(key: &TexKey, width: u32, height: u32, channels: u32, pixels: &Texels, file_srgb: bool) -> Option<TextureDesc> {
    // the file's curve undone, then its primaries' RGB taken to linear Rec.709 (grey stays
    // grey: a one- or two-channel file keeps its values)
    let (curve, primaries) = key.encoding.decoding(file_srgb);
    let ch = channels as usize;
    let same_primaries = primaries == tide_core::spectrum::color::FilePrimaries::Rec709 || ch < 3;
    let texels = match pixels {
        // 8-bit codes decoded channel by channel: the decoded value of each code, the codes shared
        Texels::U8 { codes, values } if same_primaries => {
            let mut decoded = **values;
            for row in decoded.iter_mut().take(ch.min(3)) {
                row.iter_mut().for_each(|v| *v = curve.decode(*v));
            }
            Some(Texels::U8 { codes: codes.clone(), values: Arc::new(decoded) })
        }
        Texels::F32(_) | Texels::U16 { .. } if curve == material::Curve::Linear && same_primaries => Some(pixels.clone()),
        // 16-bit codes decoded by a table of their own (1 MB): for an image larger than it
        Texels::U16 { codes, values } if same_primaries && codes.len() >= 4 * CODES16 => {
            let mut decoded = values.as_ref().clone();
            for row in decoded.chunks_exact_mut(CODES16).take(ch.min(3)) {
                row.iter_mut().for_each(|v| *v = curve.decode(*v));
            }
            Some(Texels::U16 { codes: codes.clone(), values: Arc::new(decoded) })
        }
        _ => None,
    };
    let texels = match texels {
        Some(t) => t,
        None => decode_texels(pixels.to_f32(ch), ch, curve, primaries).into(),
    };
    let tex = TextureDesc {
        name: key.asset.clone(),
        width,
        height,
        channels,
        pixels: texels,
        wrap_s: key.wrap_s.wrap(),
        wrap_t: key.wrap_t.wrap(),
        filter: key.filter,
    };
    // a dome's mirrored-ball, angular or cross image, as the lat-long it renders from
    let tex = if key.dome == DomeFormat::LatLong { tex } else { tide_core::light::dome_format::to_latlong(&tex, key.dome).ok()? };
    Some(tex)
}

/// A 2-channel (grey, alpha) image's values as RGBA (grey in each colour channel); others,
/// and a 2-channel one of an odd count (refused by its size), as they are.
fn grey_alpha_as_rgba<T: Copy>(channels: u32, values: Vec<T>) -> Vec<T> {
    if channels == 2 && values.len() % 2 == 0 {
        values.chunks_exact(2).flat_map(|c| [c[0], c[0], c[0], c[1]]).collect()
    } else {
        values
    }
}

/// Float texels of `ch` channels decoded by `curve`, then taken from `primaries` to Rec.709.
fn decode_texels(mut px: Vec<f32>, ch: usize, curve: material::Curve, primaries: tide_core::spectrum::color::FilePrimaries) -> Vec<f32> {
    if curve != material::Curve::Linear {
        for texel in px.chunks_exact_mut(ch) {
            for c in texel.iter_mut().take(ch.min(3)) {
                *c = curve.decode(*c);
            }
        }
    }
    if primaries != tide_core::spectrum::color::FilePrimaries::Rec709 && ch >= 3 {
        let m = tide_core::spectrum::color::file_to_authored(primaries);
        for texel in px.chunks_exact_mut(ch) {
            let v = [texel[0], texel[1], texel[2]];
            for (r, c) in texel.iter_mut().take(3).enumerate() {
                *c = m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2];
            }
        }
    }
    px
}

/// A display primvar (`displayColor`, `displayOpacity`) of N components: its value, or its
/// average where it varies (the whole prim's value where the geometry cannot carry it).
fn display_average<const N: usize>(s: &AttrStore, name: &str, p: &mut Problems) -> Option<[f32; N]> {
    let pv = s.primvar(name, Interpolation::Constant)?;
    match pv.flatten() {
        Ok(d) if pv.tuple as usize == N && d.len() >= N && d.iter().all(|x| x.is_finite()) => {
            let n = (d.len() / N) as f32;
            let mut sum = [0.0f32; N];
            for c in d.chunks_exact(N) {
                for k in 0..N {
                    sum[k] += c[k];
                }
            }
            Some(sum.map(|x| x / n))
        }
        _ => {
            p.add(name, format!("expected finite data of {N} component(s); ignored"));
            None
        }
    }
}

/// The fallback material of an unbound gprim: Lambertian of its displayColor, seen through its
/// displayOpacity (each read per element where it varies, as UsdImaging's fallback does).
fn display_material(color: [f32; 3], color_varies: bool, opacity: f32, opacity_varies: bool) -> tide_core::scene::MaterialDesc {
    use tide_core::scene::{ColorInput, FloatInput, PreviewSurfaceDesc, PrimvarLookup};
    let mut name = format!("displayColor{:?}{}", color, if color_varies { " varying" } else { "" });
    if opacity < 1.0 || opacity_varies {
        name += &format!(" displayOpacity {}{}", opacity, if opacity_varies { " varying" } else { "" });
    }
    let mut m = default_material(&name);
    let color = match color_varies {
        true => ColorInput::Primvar(PrimvarLookup::new("displayColor", [color[0], color[1], color[2], 0.0])),
        false => ColorInput::Const(color),
    };
    m.surface = match (opacity, opacity_varies) {
        (o, false) if o >= 1.0 => SurfaceDesc::Diffuse { color },
        (o, varies) => SurfaceDesc::Preview(PreviewSurfaceDesc {
            diffuse_color: color,
            use_specular_workflow: true,
            specular_color: ColorInput::Const([0.0; 3]),
            opacity: match varies {
                true => FloatInput::Primvar(PrimvarLookup::new("displayOpacity", [o, o, o, 0.0])),
                false => FloatInput::Const(o),
            },
            ..Default::default()
        }),
    };
    m
}

/// `instanceIndices`: each authored instance's index for the `instanceId` AOV (a reader's
/// PointInstancer's own, where it sends each prototype's instances apart), kept in `kept`;
/// unauthored, or anything but one non-negative int per instance (reported): its position among
/// the authored `instanceTransforms` (Hydra's instance index).
fn read_instance_indices(s: &AttrStore, n_instances: usize, kept: &[usize], p: &mut Problems) -> Vec<u32> {
    let positions = || kept.iter().map(|&i| i as u32).collect();
    match s.get("instanceIndices") {
        None => positions(),
        Some(v) => match v.to_ints() {
            Some(ix) if ix.len() == n_instances && ix.iter().all(|&i| i >= 0) => kept.iter().map(|&i| ix[i] as u32).collect(),
            _ => {
                p.add("instanceIndices", format!("expected {n_instances} non-negative ints, one per instance; each instance's position is its index"));
                positions()
            }
        },
    }
}

/// `instancePaths`: the path each instance stands for in collections, one per authored
/// instance (kept in `kept`); none (or an empty list): the prim's own path; anything else is
/// reported and the prim's own path is used.
fn read_instance_paths(s: &AttrStore, n_instances: usize, kept: &[usize], p: &mut Problems) -> Vec<String> {
    match s.get("instancePaths") {
        None => vec![],
        // an empty list takes the paths back (the bridge's way to clear them)
        Some(Value::Paths(v)) if v.is_empty() => vec![],
        Some(Value::Paths(v)) if v.len() == n_instances => kept.iter().map(|&i| v[i].clone()).collect(),
        Some(Value::Paths(v)) => {
            p.add("instancePaths", format!("{} paths for {} instances; the prim's own path stands for every instance", v.len(), n_instances));
            vec![]
        }
        Some(v) => {
            p.add("instancePaths", format!("expected paths, got {}; the prim's own path stands for every instance", v.kind()));
            vec![]
        }
    }
}

/// The per-instance primvars of an rprim with `n` authored instances, rows picked for those
/// `kept`: every one of 1 to 4 components with one finite element per instance.
fn read_instance_primvars(s: &AttrStore, n: usize, kept: &[usize], p: &mut Problems) -> Vec<PrimvarData> {
    let mut names: Vec<&String> = s.instance_primvars.keys().collect();
    names.sort();
    names
        .into_iter()
        .filter_map(|name| {
            let pv = &s.instance_primvars[name];
            let attr = format!("primvars:{name}");
            let t = pv.tuple as usize;
            let data = match pv.flatten() {
                Ok(d) if (1..=4).contains(&t) && d.len() == n * t && d.iter().all(|x| x.is_finite()) => d,
                Ok(d) => {
                    p.add(&attr, format!("expected {n} finite per-instance value(s) of 1 to 4 components, got {} of {t}; ignored", d.len() / t.max(1)));
                    return None;
                }
                Err(e) => {
                    p.add(&attr, format!("{e}; ignored"));
                    return None;
                }
            };
            Some(PrimvarData { name: name.clone(), tuple: pv.tuple, constant: false, data: kept.iter().flat_map(|&i| data[i * t..i * t + t].to_vec()).collect() })
        })
        .collect()
}

/// Reads a gprim's `TideCausticsAPI` attributes (contract §4); None when none is authored.
fn read_caustics(s: &crate::value::AttrStore, p: &mut Problems) -> Option<tide_core::scene::ObjectCaustics> {
    use tide_core::scene::{CausticsTransparency, ObjectCaustics};
    let names = ["tide:caustics:caster", "tide:caustics:receiver", "tide:caustics:transparency"];
    if !names.iter().any(|n| s.has(n)) {
        return None;
    }
    let transparency = match s.token_or("tide:caustics:transparency", &["off", "afterDiffuse", "volume", "all"], "off", p) {
        "afterDiffuse" => CausticsTransparency::AfterDiffuse,
        "volume" => CausticsTransparency::Volume,
        "all" => CausticsTransparency::All,
        _ => CausticsTransparency::Off,
    };
    Some(ObjectCaustics {
        caster: s.has("tide:caustics:caster").then(|| s.bool_or("tide:caustics:caster", false, p)),
        receiver: s.bool_or("tide:caustics:receiver", true, p),
        transparency,
    })
}
