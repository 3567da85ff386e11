//! `tideOcean` rprims (contract §5): the prim's attributes become [`OceanParams`] (bad values
//! are problems and fall back to the documented defaults), and at scene assembly the FFT ocean
//! mesh is built around the render camera, with a flat skirt out to the horizon for an open sea.
//!
//! * Level of detail follows the camera (core's `OceanView`): its position in the ocean's
//!   local space and what one of its pixels covers. The mesh is rebuilt when the camera enters
//!   another patch, when its height or its pixel's angle or width changes by a half octave, or
//!   when its height changes the horizon skirt's reach; otherwise the cached mesh is reused.
//! * `time` (s): the reader authors the stage time (frame / timeCodesPerSecond) when the prim
//!   has none; a prim without it here is synthesised at t = 0.
//! * Materials: bound to a `TideWater` with `surfaceModel = sea`, the ocean takes the material's
//!   optics and its own `windSpeed` / `windDirection` (the sea state is the prim's), and the
//!   facets carry only the sub-grid share of the Cox–Munk slope variance
//!   ([`sea_variance_scale`]): the mesh's resolved slopes plus the BSDF's equal Cox–Munk. The
//!   horizon skirt has no waves, so its facets carry all of it.

use glam::{Mat4, Vec3};
use tide_core::bsdf::sea::CoxMunk;
use tide_core::ocean::{ocean_mesh_with_horizon_seen, OceanParams, OceanView, SpectrumKind};
use std::sync::Arc;
use tide_core::scene::MeshDesc;

use crate::value::{AttrStore, Problems};

/// What a `tideOcean` prim asks for: its parameters and time.
#[derive(Clone, Debug, PartialEq)]
pub struct OceanSpec {
    pub params: OceanParams,
    pub time: f64,
}

/// The surface mesh (and, for an open sea, the horizon skirt) of an ocean for one camera key.
#[derive(Clone, Debug, PartialEq)]
pub struct OceanMeshes {
    pub surface: Arc<MeshDesc>,
    pub skirt: Option<Arc<MeshDesc>>,
}

/// What the built mesh depends on besides the spec: the camera's patch and the skirt's reach.
#[derive(Clone, Debug, PartialEq)]
pub struct OceanKey {
    pub spec: OceanSpec,
    pub tile: (i64, i64),
    /// The camera's height, its pixel's angle and its (orthographic) width, in half octaves.
    pub height: i32,
    pub pixel_angle: i32,
    pub pixel_width: Option<i32>,
    pub reach: f32,
    /// The stage's metres per unit: the ocean is made in metres and scaled into units.
    pub meters_per_unit: f32,
}

/// How far below the horizontal the skirt leaves sky: the skirt reaches 10⁵ camera heights past
/// the camera, atan(10⁻⁵) = 0.0006°, under a pixel of any practical camera (a 10° field on an
/// 8K image has 0.0012° pixels).
pub const HORIZON_HEIGHTS: f32 = 1e5;

/// Largest skirt reach (m, local): the skirt's vertices stay within f32's exact integers.
pub const MAX_REACH: f32 = 16_777_216.0;

/// Reads the prim's attributes. Each bad value is a problem naming the attribute and the
/// default used instead.
pub fn ocean_spec(store: &AttrStore, p: &mut Problems) -> OceanSpec {
    let d = OceanParams::default();
    let spectrum = store.token_or("spectrum", &["piersonMoskowitz", "jonswap"], "piersonMoskowitz", p);
    let int = |name: &str, default: i64, p: &mut Problems| -> i64 {
        match store.get(name).map(|v| v.as_f64()) {
            None => default,
            Some(Some(x)) if x.is_finite() && x.fract() == 0.0 => x as i64,
            Some(_) => {
                p.add(name, format!("expected an integer; using {default}"));
                default
            }
        }
    };
    let resolution = int("resolution", d.resolution as i64, p);
    let mut params = OceanParams {
        wind_speed: store.f32_or("windSpeed", d.wind_speed, p),
        wind_direction: store.f32_or("windDirection", d.wind_direction, p),
        spectrum: SpectrumKind::from_token(spectrum).unwrap_or_default(),
        patch_size: store.f32_or("patchSize", d.patch_size, p),
        resolution: u32::try_from(resolution).unwrap_or(0),
        choppiness: store.f32_or("choppiness", d.choppiness, p),
        seed: int("seed", d.seed, p),
        extent: store.f32_or("extent", d.extent, p),
        depth: store.f32_or("depth", d.depth, p),
    };
    if u32::try_from(resolution).is_err() {
        p.add("resolution", format!("must be a power of two from 8 to 4096, got {resolution}; using {}", d.resolution));
        params.resolution = d.resolution;
    }
    // validation names the first attribute at fault: reset it and look again (`extent` can
    // also fail with a valid value, by needing too many patches: then it is capped)
    for _ in 0..10 {
        let Err(e) = params.validate() else { break };
        let used = match e.parameter {
            "windSpeed" => {
                params.wind_speed = d.wind_speed;
                params.wind_speed.to_string()
            }
            "windDirection" => {
                params.wind_direction = d.wind_direction;
                params.wind_direction.to_string()
            }
            "patchSize" => {
                params.patch_size = d.patch_size;
                params.patch_size.to_string()
            }
            "resolution" => {
                params.resolution = d.resolution;
                params.resolution.to_string()
            }
            "choppiness" => {
                params.choppiness = d.choppiness;
                params.choppiness.to_string()
            }
            "depth" => {
                params.depth = d.depth;
                params.depth.to_string()
            }
            "extent" => {
                let limit = (tide_core::ocean::MAX_TILES_PER_SIDE / 2) as f32 * params.patch_size;
                params.extent = if params.extent.is_finite() && params.extent > 0.0 { d.extent.min(limit) } else { d.extent };
                params.extent.to_string()
            }
            _ => break,
        };
        p.add(e.parameter, format!("{}; using {used}", e.message));
    }
    let time = store.get("time").and_then(|v| v.as_f64());
    let time = match time {
        Some(t) if t.is_finite() => t,
        None if !store.has("time") => 0.0,
        _ => {
            p.add("time", "expected a finite time in seconds; using 0");
            0.0
        }
    };
    OceanSpec { params, time }
}

/// What one pixel of the render camera covers: the angle it spans (radians; 0 for an
/// orthographic camera) and its width (scene units; 0 for a perspective camera).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraPixel {
    pub angle: f32,
    pub width: f32,
}

impl CameraPixel {
    /// The pixel of camera `c` rendering `width` pixels across its horizontal aperture.
    pub fn of(c: &tide_core::scene::CameraDesc, width: u32) -> CameraPixel {
        let across = width.max(1) as f32;
        match c.projection {
            tide_core::scene::Projection::Perspective => {
                CameraPixel { angle: 2.0 * (0.5 * c.horizontal_aperture / c.focal_length).atan() / across, width: 0.0 }
            }
            tide_core::scene::Projection::Orthographic => CameraPixel { angle: 0.0, width: c.horizontal_aperture * tide_core::camera::LENS_UNIT / across },
        }
    }
}

/// Half octaves of a positive length or angle (at least `floor`).
fn half_octaves(v: f32, floor: f32) -> i32 {
    (2.0 * v.max(floor).log2()).round() as i32
}

/// The key of the mesh for a camera at `camera_local` (the ocean's local space, in units of
/// `meters_per_unit` metres; None: at the origin, 2 m up) whose pixel is `pixel` (None: the
/// pixels core takes for an unknown camera).
pub fn ocean_key(spec: &OceanSpec, camera_local: Option<Vec3>, pixel: Option<CameraPixel>, meters_per_unit: f32) -> OceanKey {
    let cam = camera_local.filter(|c| c.is_finite()).map_or(Vec3::new(0.0, 2.0, 0.0), |c| c * meters_per_unit);
    let l = spec.params.patch_size as f64;
    let tile = ((cam.x as f64 / l).floor() as i64, (cam.z as f64 / l).floor() as i64);
    let pixel = pixel.filter(|p| p.angle.is_finite() && p.width.is_finite() && (p.angle > 0.0 || p.width > 0.0));
    let default_angle = 2.0 / spec.params.resolution.max(1) as f32;
    let pixel_angle = half_octaves(pixel.map_or(default_angle, |p| p.angle), 1e-6);
    let pixel_width = pixel.filter(|p| p.width > 0.0).map(|p| half_octaves(p.width * meters_per_unit, 1e-6));
    let height = half_octaves(cam.y.abs(), 0.25);
    let away = cam.x.abs().max(cam.z.abs());
    let want = away + HORIZON_HEIGHTS * cam.y.abs().max(1.0);
    // a power of two: the mesh is rebuilt when the camera's height changes it by a factor 2
    let reach = if want.is_finite() { want.min(MAX_REACH).log2().ceil().exp2().min(MAX_REACH) } else { MAX_REACH };
    OceanKey { spec: spec.clone(), tile, height, pixel_angle, pixel_width, reach, meters_per_unit }
}

/// Builds the meshes for a key (in metres, then scaled into the stage's units). A `depth`
/// that does not reach below the deepest trough is a problem and the sea is built open
/// (`depth` 0).
pub fn build(key: &OceanKey, p: &mut Problems) -> OceanMeshes {
    let l = key.spec.params.patch_size;
    // the LOD depends on the key only: the camera at its patch's centre, its height and its
    // pixel at their half octaves
    let octaves = |h: i32| (h as f32 * 0.5).exp2();
    let view = OceanView {
        position: Vec3::new((key.tile.0 as f32 + 0.5) * l, octaves(key.height), (key.tile.1 as f32 + 0.5) * l),
        pixel_angle: if key.pixel_width.is_some() { 0.0 } else { octaves(key.pixel_angle) },
        pixel_width: key.pixel_width.map_or(0.0, octaves),
    };
    let (surface, skirt) = ocean_mesh_with_horizon_seen(&key.spec.params, key.spec.time, &view, key.reach).unwrap_or_else(|e| {
        p.add(e.parameter, format!("{}; using 0 (an open sea)", e.message));
        let open = OceanParams { depth: 0.0, ..key.spec.params.clone() };
        ocean_mesh_with_horizon_seen(&open, key.spec.time, &view, key.reach).expect("validated open sea")
    });
    // in scene units, about the mesh's own centre when it is far from the ocean's origin
    let units = |mut m: MeshDesc| {
        if key.meters_per_unit != 1.0 {
            m.positions.iter_mut().for_each(|v| *v /= key.meters_per_unit);
        }
        m.recentre();
        m
    };
    OceanMeshes { surface: units(surface).into(), skirt: skirt.map(|s| Arc::new(units(s))) }
}

/// The share of the sea BSDF's Cox–Munk slope variance left when the mesh of `params` resolves
/// its part: the sub-grid variance over the variance the BSDF has at the prim's wind.
pub fn sea_variance_scale(params: &OceanParams) -> f32 {
    let (vu, vc) = CoxMunk::variances(params.wind_speed);
    let total = vu as f64 + vc as f64;
    if total > 0.0 {
        (params.subgrid_slope_variance() / total) as f32
    } else {
        1.0
    }
}

/// The prim's wind direction in world degrees about +Y from +X, through its transform.
pub fn world_wind_direction(params: &OceanParams, object_to_world: Mat4) -> f32 {
    let [x, z] = params.wind_vector();
    let w = object_to_world.transform_vector3(Vec3::new(x as f32, 0.0, z as f32));
    if w.x == 0.0 && w.z == 0.0 {
        return params.wind_direction;
    }
    (-w.z).atan2(w.x).to_degrees()
}
