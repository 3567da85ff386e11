//! Implicit gprims (USD dimensions and `axis`) and UsdGeomPoints.
//!
//! `Sphere` becomes an exact [`SpheresDesc`]; `Cube`, `Cylinder`, `Cone`, `Capsule` and `Plane`
//! are tessellated into meshes with analytic normals and uvs (cylinders and cones capped).
//! Shapes are built around +Z and then turned to their `axis` by a cyclic permutation of the
//! coordinates (a rotation), so the winding stays counter-clockwise seen from outside.
//!
//! Points become spheres of radius `widths / 2` (constant or per vertex, default width 1).
//! Velocities are units per second. The core moves spheres linearly only, so accelerations
//! are folded in over the shutter interval [t0, t1] (seconds): each point moves on the chord of
//! its parabola, v' = v + a·(t0 + t1)/2 and c' = c − a·t0·t1/2, which is exact at the shutter's
//! open and close and off by at most |a|·(t1 − t0)²/8 in between (see [`fold_acceleration`]).

use crate::mesh::read_points;
use crate::value::{AttrStore, Interpolation, Problems};
use glam::{Quat, Vec2, Vec3};
use std::f32::consts::{PI, TAU};
use std::sync::Arc;
use tide_core::scene::{MeshDesc, PointShape, SpheresDesc};

/// Angular segments of tessellated round shapes.
pub const SEGMENTS: u32 = 64;
/// Latitude rings of each capsule hemisphere.
pub const CAP_RINGS: u32 = 16;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Axis {
    X,
    Y,
    Z,
}

impl Axis {
    pub(crate) fn read(store: &AttrStore, p: &mut Problems) -> Axis {
        match store.token_or("axis", &["X", "Y", "Z"], "Z", p) {
            "X" => Axis::X,
            "Y" => Axis::Y,
            _ => Axis::Z,
        }
    }

    /// Maps a +Z-built point (a, b, h) so that h lies along this axis (a rotation).
    pub fn map(self, v: Vec3) -> Vec3 {
        match self {
            Axis::Z => v,
            Axis::X => Vec3::new(v.z, v.x, v.y),
            Axis::Y => Vec3::new(v.y, v.z, v.x),
        }
    }
}

/// Mesh under construction.
#[derive(Default)]
struct Builder {
    p: Vec<Vec3>,
    n: Vec<Vec3>,
    uv: Vec<Vec2>,
    idx: Vec<u32>,
}

impl Builder {
    fn vert(&mut self, p: Vec3, n: Vec3, uv: Vec2) -> u32 {
        self.p.push(p);
        self.n.push(n);
        self.uv.push(uv);
        self.p.len() as u32 - 1
    }

    /// A grid of (rows+1)×(cols+1) vertices from `f(u, v)` with u, v in [0,1]; quads wound
    /// counter-clockwise in (u, v) order (u then v).
    fn grid(&mut self, rows: u32, cols: u32, f: impl Fn(f32, f32) -> (Vec3, Vec3)) {
        let base = self.p.len() as u32;
        for r in 0..=rows {
            for c in 0..=cols {
                let (u, v) = (c as f32 / cols as f32, r as f32 / rows as f32);
                let (p, n) = f(u, v);
                self.vert(p, n, Vec2::new(u, v));
            }
        }
        let w = cols + 1;
        for r in 0..rows {
            for c in 0..cols {
                let a = base + r * w + c;
                self.idx.extend_from_slice(&[a, a + 1, a + w + 1, a, a + w + 1, a + w]);
            }
        }
    }

    /// A disk at height `h` facing `+Z` (up = true) or `−Z`, radius `r`.
    fn disk(&mut self, r: f32, h: f32, up: bool) {
        let n = if up { Vec3::Z } else { Vec3::NEG_Z };
        let c = self.vert(Vec3::new(0.0, 0.0, h), n, Vec2::splat(0.5));
        let first = self.p.len() as u32;
        for s in 0..=SEGMENTS {
            let phi = TAU * s as f32 / SEGMENTS as f32;
            let (sn, cs) = phi.sin_cos();
            self.vert(Vec3::new(r * cs, r * sn, h), n, Vec2::new(0.5 + 0.5 * cs, 0.5 + 0.5 * sn));
        }
        for s in 0..SEGMENTS {
            let (a, b) = (first + s, first + s + 1);
            self.idx.extend_from_slice(&if up { [c, a, b] } else { [c, b, a] });
        }
    }

    /// The mesh turned to `axis`, without the triangles of no area a grid makes where a row
    /// closes into a point (a cone's apex, a capsule's poles).
    fn finish(self, name: &str, axis: Axis, double_sided: bool) -> MeshDesc {
        let positions: Vec<Vec3> = self.p.into_iter().map(|p| axis.map(p)).collect();
        let indices: Vec<u32> = self
            .idx
            .chunks_exact(3)
            .filter(|t| {
                let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
                (b - a).cross(c - a).length() > 0.0
            })
            .flatten()
            .copied()
            .collect();
        MeshDesc {
            name: name.to_string(),
            positions,
            indices,
            faces: Vec::new(),
            normals: Some(self.n.into_iter().map(|n| axis.map(n)).collect()),
            uvs: Some(self.uv),
            uv_name: None,
            double_sided,
            motion: None,
            primvars: Vec::new(),
            origin: Default::default(),
        }
    }
}

fn positive(store: &AttrStore, name: &str, default: f32, p: &mut Problems) -> f32 {
    let v = store.f32_or(name, default, p);
    if v > 0.0 {
        v
    } else {
        p.add(name, format!("must be positive, got {}; using {}", v, default));
        default
    }
}

/// UsdGeomSphere: one exact sphere.
pub fn sphere(name: &str, store: &AttrStore, p: &mut Problems) -> SpheresDesc {
    let r = positive(store, "radius", 1.0, p);
    SpheresDesc { name: name.into(), centers: vec![Vec3::ZERO], radii: vec![r], velocities: None, ..Default::default() }
}

/// UsdGeomCube: edge `size` (default 2), centred at the origin; 4 vertices per face.
pub fn cube(name: &str, store: &AttrStore, p: &mut Problems) -> MeshDesc {
    let h = positive(store, "size", 2.0, p) * 0.5;
    let ds = store.bool_or("doubleSided", false, p);
    let mut b = Builder::default();
    for axis in [Vec3::X, Vec3::Y, Vec3::Z] {
        for n in [axis, -axis] {
            // (t, s, n) right-handed so corners go counter-clockwise seen from outside.
            let t = if axis == Vec3::X { Vec3::Y } else if axis == Vec3::Y { Vec3::Z } else { Vec3::X };
            let s = n.cross(t);
            b.grid(1, 1, |u, v| (n * h + t * h * (2.0 * u - 1.0) + s * h * (2.0 * v - 1.0), n));
        }
    }
    b.finish(name, Axis::Z, ds)
}

/// The (bottom, top) radii of a shape: `radiusBottom` and `radiusTop` where either is
/// authored (UsdGeomCylinder_1, UsdGeomCapsule_1; each ≥ 0, not both 0), else `radius` at both
/// ends.
fn end_radii(store: &AttrStore, default: f32, p: &mut Problems) -> (f32, f32) {
    if store.get("radiusBottom").is_none() && store.get("radiusTop").is_none() {
        let r = positive(store, "radius", default, p);
        return (r, r);
    }
    let mut end = |name: &str| {
        let v = store.f32_or(name, default, p);
        if v >= 0.0 && v.is_finite() {
            v
        } else {
            p.add(name, format!("must not be negative, got {}; using {}", v, default));
            default
        }
    };
    let (rb, rt) = (end("radiusBottom"), end("radiusTop"));
    if rb > 0.0 || rt > 0.0 {
        (rb, rt)
    } else {
        p.add("radiusBottom", format!("both end radii are 0; using {default}"));
        (default, default)
    }
}

/// UsdGeomCylinder: `radius` 1, `height` 2 along `axis`, centred, both ends capped;
/// UsdGeomCylinder_1: `radiusBottom` at −height/2 and `radiusTop` at +height/2 (a frustum).
pub fn cylinder(name: &str, store: &AttrStore, p: &mut Problems) -> MeshDesc {
    let (rb, rt) = end_radii(store, 1.0, p);
    let h = positive(store, "height", 2.0, p);
    let hh = h * 0.5;
    let axis = Axis::read(store, p);
    let ds = store.bool_or("doubleSided", false, p);
    let mut b = Builder::default();
    // the side's normal ∝ (h·cosφ, h·sinφ, rb − rt)
    b.grid(1, SEGMENTS, |u, v| {
        let (s, c) = (TAU * u).sin_cos();
        let r = rb + (rt - rb) * v;
        (Vec3::new(r * c, r * s, hh * (2.0 * v - 1.0)), Vec3::new(h * c, h * s, rb - rt).normalize())
    });
    if rt > 0.0 {
        b.disk(rt, hh, true);
    }
    if rb > 0.0 {
        b.disk(rb, -hh, false);
    }
    b.finish(name, axis, ds)
}

/// UsdGeomCone: `radius` 1 at −height/2, apex at +height/2 (`height` 2) along `axis`; capped.
pub fn cone(name: &str, store: &AttrStore, p: &mut Problems) -> MeshDesc {
    let r = positive(store, "radius", 1.0, p);
    let h = positive(store, "height", 2.0, p);
    let axis = Axis::read(store, p);
    let ds = store.bool_or("doubleSided", false, p);
    let mut b = Builder::default();
    // Side normal ∝ (h·cosφ, h·sinφ, r); the apex row gets the normal of its column so the
    // shading stays smooth around and correct along each generator line.
    b.grid(1, SEGMENTS, |u, v| {
        let (s, c) = (TAU * u).sin_cos();
        let rad = r * (1.0 - v);
        (Vec3::new(rad * c, rad * s, h * (v - 0.5)), Vec3::new(h * c, h * s, r).normalize())
    });
    b.disk(r, -0.5 * h, false);
    b.finish(name, axis, ds)
}

/// UsdGeomCapsule: a cylinder of `height` (default 1) with hemispherical ends of `radius`
/// (default 0.5) along `axis`; total extent height + 2·radius. UsdGeomCapsule_1: spheres of
/// `radiusBottom` and `radiusTop` on the ends of the spine, joined by the cone tangent to both
/// (the hull of the two spheres).
pub fn capsule(name: &str, store: &AttrStore, p: &mut Problems) -> MeshDesc {
    let (mut rb, mut rt) = end_radii(store, 0.5, p);
    let mut hh = store.f32_or("height", 1.0, p).max(0.0) * 0.5;
    let axis = Axis::read(store, p);
    let ds = store.bool_or("doubleSided", false, p);
    // where one sphere holds the other, the hull is the larger sphere: a capsule of no height
    // about that end
    let mut shift = 0.0;
    if (rb - rt).abs() >= 2.0 * hh && rb != rt {
        (shift, rb, rt, hh) = if rb > rt { (-hh, rb, rb, 0.0) } else { (hh, rt, rt, 0.0) };
    }
    // latitude where the tangent cone meets both spheres: sin φ = (rb − rt) / height
    let phi = if hh > 0.0 { ((rb - rt) / (2.0 * hh)).asin() } else { 0.0 };
    let rings = 2 * CAP_RINGS + 1;
    let mut b = Builder::default();
    // Latitude θ from −π/2 to φ on the bottom sphere, then φ to π/2 on the top one; the middle
    // ring band is the cone between them (a cylinder where the radii agree).
    b.grid(rings, SEGMENTS, |u, v| {
        let (s, c) = (TAU * u).sin_cos();
        let k = (v * rings as f32).round() as u32;
        let (theta, z0, r) = if k <= CAP_RINGS {
            (-0.5 * PI + (phi + 0.5 * PI) * (k as f32 / CAP_RINGS as f32), -hh, rb)
        } else {
            (phi + (0.5 * PI - phi) * ((k - CAP_RINGS - 1) as f32 / CAP_RINGS as f32), hh, rt)
        };
        let (st, ct) = theta.sin_cos();
        let n = Vec3::new(ct * c, ct * s, st);
        (Vec3::new(0.0, 0.0, z0 + shift) + r * n, n)
    });
    b.finish(name, axis, ds)
}

/// UsdGeomPlane: `width` (default 2) × `length` (default 2), normal along `axis`. Width runs
/// along X for axis Z or Y and along Z for axis X; length along Y for axis Z or X and along Z
/// for axis Y (USD's definition). `doubleSided` defaults to false as for any gprim.
pub fn plane(name: &str, store: &AttrStore, p: &mut Problems) -> MeshDesc {
    let w = positive(store, "width", 2.0, p) * 0.5;
    let l = positive(store, "length", 2.0, p) * 0.5;
    let axis = Axis::read(store, p);
    let ds = store.bool_or("doubleSided", false, p);
    let (wd, ld, n) = match axis {
        Axis::Z => (Vec3::X, Vec3::Y, Vec3::Z),
        Axis::Y => (Vec3::X, Vec3::Z, Vec3::Y),
        Axis::X => (Vec3::Z, Vec3::Y, Vec3::X),
    };
    let mut b = Builder::default();
    b.grid(1, 1, |u, v| (wd * w * (2.0 * u - 1.0) + ld * l * (2.0 * v - 1.0), n));
    // The grid winds counter-clockwise around wd × ld; flip where that is −n.
    if wd.cross(ld).dot(n) < 0.0 {
        for t in b.idx.chunks_exact_mut(3) {
            t.swap(1, 2);
        }
    }
    b.finish(name, Axis::Z, ds)
}

/// Per-point data of UsdGeomPoints before the shutter is known.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PointsData {
    pub spheres: Arc<SpheresDesc>,
    pub accelerations: Option<Vec<Vec3>>,
    /// `TideDropletsAPI` with `asVolume`: (voxel size, shell) in metres.
    pub droplets: Option<(f32, f32)>,
    /// Without velocities: the points at the first and last time samples of their positions
    /// (frame offsets in time codes), which move them over the shutter along the chord.
    pub ends: Option<[(f64, Vec<Vec3>); 2]>,
    /// What the last assembly made of the points, and for which shutter (and whether it
    /// blurs).
    made: crate::memo::Memo<(u32, u32, bool, u64, u32), PointsMade>,
}

/// The points as an assembly places them over a shutter.
#[derive(Clone, Debug)]
pub struct PointsMade {
    /// The spheres to render (the droplets that stay spheres, with `TideDropletsAPI`).
    pub spheres: Arc<SpheresDesc>,
    /// With `TideDropletsAPI`: the scattering grid of the droplets that became a medium (None
    /// when none did), or why the points could not be split.
    pub droplets: Option<Result<Option<tide_core::scene::GridDesc>, String>>,
}

impl PointsData {
    /// The points over the shutter [t0, t1] (seconds), moving if `motion`: accelerations
    /// folded into the velocities, then the droplets split off (their voxel size and shell
    /// in metres of the world, of which a unit of the points' own space is `meters_per_unit`:
    /// the stage's metersPerUnit times the scale of the prim's transform, see
    /// [`object_scale`]). Made once per shutter and shared after; points that neither
    /// accelerate nor lose their motion nor split are the converted ones, shared.
    pub fn made(&self, t0: f32, t1: f32, motion: bool, time_codes_per_second: f64, meters_per_unit: f32) -> PointsMade {
        let tcps = time_codes_per_second;
        self.made.get_or_make((t0.to_bits(), t1.to_bits(), motion, tcps.to_bits(), meters_per_unit.to_bits()), || {
            // points authored far from their own origin are moved back about it (the
            // droplets' grid stays in the points' own space)
            let mut made = self.made_where_authored(t0, t1, motion, tcps, meters_per_unit);
            let shift = made.spheres.recentring();
            if shift != Vec3::ZERO {
                Arc::make_mut(&mut made.spheres).shift_origin(shift);
            }
            made
        })
    }

    /// [`PointsData::made`] before the points are moved about their origin.
    fn made_where_authored(&self, t0: f32, t1: f32, motion: bool, tcps: f64, meters_per_unit: f32) -> PointsMade {
        let still = !motion && self.spheres.velocities.is_some();
        let sampled = motion && self.ends.is_some();
        if self.accelerations.is_none() && !still && !sampled && self.droplets.is_none() {
            return PointsMade { spheres: self.spheres.clone(), droplets: None };
        }
        let mut s = fold_acceleration(self, t0, t1);
        if !motion {
            s.velocities = None;
        }
        if let Some([(ta, a), (tb, b)]) = self.ends.as_ref().filter(|_| motion) {
            // the chord from the first sample to the last, in seconds of shutter time:
            // centre + v·t passes a at ta and b at tb
            let (sa, sb) = ((ta / tcps) as f32, (tb / tcps) as f32);
            if sb > sa {
                let v: Vec<Vec3> = a.iter().zip(b).map(|(a, b)| (*b - *a) / (sb - sa)).collect();
                s.centers = a.iter().zip(&v).map(|(a, v)| *a - *v * sa).collect();
                s.velocities = Some(v);
            }
        }
        let Some((voxel, shell)) = self.droplets else {
            return PointsMade { spheres: Arc::new(s), droplets: None };
        };
        match tide_core::droplets::split(&s, voxel / meters_per_unit, shell / meters_per_unit) {
            Ok(split) => PointsMade { spheres: Arc::new(split.spheres), droplets: Some(Ok(split.grid)) },
            Err(e) => PointsMade { spheres: Arc::new(s), droplets: Some(Err(format!("{voxel} m voxels: {e}"))) },
        }
    }
}

/// How much a transform enlarges lengths: the cube root of its linear part's determinant (a
/// uniform scale's factor; for an uneven one, the factor that keeps volumes); 1 where that is
/// not a positive finite number. What turns a world length (a droplet grid's voxel size) into
/// one of the points' own space.
pub fn object_scale(m: &glam::DMat4) -> f64 {
    let s = glam::DMat3::from_mat4(*m).determinant().abs().cbrt();
    if s.is_finite() && s > 0.0 {
        s
    } else {
        1.0
    }
}

/// A per-point primvar's flattened values and tuple size, or None (absent, or unreadable:
/// reported under `attr`).
fn flat_primvar(store: &AttrStore, name: &str, attr: &str, p: &mut Problems) -> Option<(Vec<f32>, usize)> {
    let pv = store.primvar(name, Interpolation::Vertex)?;
    match pv.flatten() {
        Ok(d) => Some((d, pv.tuple as usize)),
        Err(e) => {
            p.add(attr, format!("{}; ignored", e));
            None
        }
    }
}

fn per_point_vec3(store: &AttrStore, name: &str, n: usize, p: &mut Problems) -> Option<Vec<Vec3>> {
    let (data, tuple) = flat_primvar(store, name, name, p)?;
    if tuple != 3 || data.len() / 3 < n || data.iter().any(|x| !x.is_finite()) {
        p.add(name, format!("expected {} finite 3-vectors (one per point); ignored", n));
        return None;
    }
    Some(data.chunks_exact(3).take(n).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
}

/// UsdGeomPoints → spheres. Points that are not finite, or whose width is not positive and
/// finite, are dropped with a problem.
pub fn points(name: &str, store: &AttrStore, p: &mut Problems) -> PointsData {
    let (pts, bad) = read_points(store, p);
    let n = pts.len();
    let widths: Vec<f32> = match store.primvar("widths", Interpolation::Vertex) {
        None => vec![1.0; n],
        Some(pv) => match pv.flatten() {
            Ok(d) if d.len() == 1 || pv.interpolation == Interpolation::Constant && !d.is_empty() => vec![d[0]; n],
            Ok(d) if d.len() >= n => d[..n].to_vec(),
            Ok(d) => {
                p.add("widths", format!("{} widths for {} points; using width 1", d.len(), n));
                vec![1.0; n]
            }
            Err(e) => {
                p.add("widths", format!("{}; using width 1", e));
                vec![1.0; n]
            }
        },
    };
    let vel = per_point_vec3(store, "velocities", n, p);
    let acc = per_point_vec3(store, "accelerations", n, p);

    let mut spheres = SpheresDesc { name: name.into(), ..Default::default() };
    let mut out = PointsData::default();
    let mut n_bad_w = 0;
    let (mut vs, mut as_) = (Vec::new(), Vec::new());
    for i in 0..n {
        if bad[i] {
            continue;
        }
        if !(widths[i] > 0.0 && widths[i].is_finite()) {
            n_bad_w += 1;
            continue;
        }
        spheres.centers.push(pts[i]);
        spheres.radii.push(0.5 * widths[i]);
        if let Some(v) = &vel {
            vs.push(v[i]);
        }
        if let Some(a) = &acc {
            as_.push(a[i]);
        }
    }
    if n_bad_w > 0 {
        p.add("widths", format!("{} point(s) have a width that is not positive and finite; dropped", n_bad_w));
    }
    spheres.velocities = vel.map(|_| vs);
    out.accelerations = acc.map(|_| as_);
    // the points kept, for the per-point shape data
    let kept: Vec<usize> = (0..n).filter(|&i| !bad[i] && widths[i] > 0.0 && widths[i].is_finite()).collect();
    if kept.len() < n {
        // the authored index of each point kept (the `elementId` AOV)
        spheres.ids = kept.iter().map(|&i| i as u32).collect();
    }
    spheres.shape = point_shape(store, n, &kept, &spheres.radii, p);
    spheres.primvars = crate::mesh::point_primvars(store, n, &kept, p);
    if spheres.velocities.is_none() {
        out.ends = sample_ends(store, n, &kept, p);
    }
    if store.get("tide:droplets:asVolume").and_then(|v| v.as_bool()) == Some(true) {
        if spheres.shape != PointShape::Spheres {
            p.add("tide:droplets:asVolume", "droplets become a medium only as plain spheres, not as bubbles or blobbies; ignored");
        } else {
            let mut voxel = store.f32_or("tide:droplets:voxelSize", 0.01, p);
            if !(voxel > 0.0) {
                p.add("tide:droplets:voxelSize", format!("{} is not positive; using 0.01", voxel));
                voxel = 0.01;
            }
            let mut shell = store.f32_or("tide:droplets:shell", 0.0, p);
            if !(shell >= 0.0) {
                p.add("tide:droplets:shell", format!("{} is negative; using 0", shell));
                shell = 0.0;
            }
            out.droplets = Some((voxel, shell));
        }
    }
    out.spheres = Arc::new(spheres);
    out
}

/// The kept points at the first and last time samples of `points` (frame offsets, in time
/// codes), where they move: what moves points without velocities (USD interpolates their
/// positions). The samples are checked as a mesh's are ([`crate::mesh::point_motion`]: another
/// point count or non-finite points are a problem, and the points render as at the frame).
fn sample_ends(store: &AttrStore, n: usize, kept: &[usize], p: &mut Problems) -> Option<[(f64, Vec<Vec3>); 2]> {
    if store.attr("points").map_or(0, |a| a.samples.len()) < 2 {
        return None;
    }
    let key = |d: &[f32]| kept.iter().map(|&i| Vec3::new(d[3 * i], d[3 * i + 1], d[3 * i + 2])).collect();
    match crate::mesh::point_motion(store, n, kept.len(), "the points prim", key, key, p)? {
        crate::mesh::Deformation::Samples(mut keys) => {
            let last = keys.pop()?;
            Some([keys.into_iter().next()?, last])
        }
        crate::mesh::Deformation::Velocity { .. } => None,
    }
}

/// Per-point floats of a primvar (one per point, or one for all), or None (absent or bad:
/// reported under `attr`).
fn per_point(store: &AttrStore, name: &str, attr: &str, tuple: usize, n: usize, p: &mut Problems) -> Option<Vec<f32>> {
    let (data, got) = flat_primvar(store, name, attr, p)?;
    if got != tuple || data.iter().any(|x| !x.is_finite()) {
        p.add(attr, format!("expected finite values of {} component(s); ignored", tuple));
        return None;
    }
    match data.len() / tuple {
        1 => Some((0..n).flat_map(|_| data.iter().copied()).collect()),
        m if m >= n => Some(data[..n * tuple].to_vec()),
        m => {
            p.add(attr, format!("{} values for {} points; ignored", m, n));
            None
        }
    }
}

/// What the points are (contract §5): blobby kernels (`TideBlobbyAPI`), bubbles
/// (`TideBubbleAPI`) or spheres. `kept`: the indices of the points kept, `radii` theirs.
fn point_shape(store: &AttrStore, n: usize, kept: &[usize], radii: &[f32], p: &mut Problems) -> PointShape {
    let apis = store.get("apiSchemas").and_then(|v| v.to_strings()).unwrap_or_default();
    let has_api = |a: &str| apis.iter().any(|s| s == a);
    let blobby = has_api("TideBlobbyAPI") || store.has("tide:blobby:threshold");
    let bubble = has_api("TideBubbleAPI") || store.primvars.contains_key("tide:bubble:top") || store.primvars.contains_key("tide:bubble:bottom");
    let pick = |v: Vec<f32>, tuple: usize| -> Vec<f32> { kept.iter().flat_map(|&i| v[i * tuple..(i + 1) * tuple].to_vec()).collect() };
    let quats = |v: Vec<f32>| -> Vec<Quat> { pick(v, 4).chunks_exact(4).map(|c| Quat::from_xyzw(c[0], c[1], c[2], c[3])).collect() };
    if blobby {
        if bubble {
            p.add("apiSchemas", "both TideBlobbyAPI and TideBubbleAPI; the points render as blobbies");
        }
        let threshold = store.f32_or("tide:blobby:threshold", 0.5, p);
        let orientations = per_point(store, "tide:blobby:orientation", "primvars:tide:blobby:orientation", 4, n, p).map(quats);
        let scales = per_point(store, "tide:blobby:scale", "primvars:tide:blobby:scale", 3, n, p)
            .map(|v| pick(v, 3).chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect());
        return PointShape::Blobby { threshold, orientations, scales };
    }
    if bubble {
        // a missing height is the point's radius (half a sphere above, the quartic below)
        let height = |name: &str, attr: &str, p: &mut Problems| match per_point(store, name, attr, 1, n, p) {
            Some(v) => pick(v, 1),
            None => radii.to_vec(),
        };
        let top = height("tide:bubble:top", "primvars:tide:bubble:top", p);
        let bottom = height("tide:bubble:bottom", "primvars:tide:bubble:bottom", p);
        let orientations = per_point(store, "tide:bubble:orientation", "primvars:tide:bubble:orientation", 4, n, p).map(quats);
        return PointShape::Bubbles { top, bottom, orientations };
    }
    PointShape::Spheres
}

/// Folds accelerations into linear motion over the shutter [t0, t1] (seconds): the chord of
/// each point's parabola p(t) = c + v·t + a·t²/2.
pub fn fold_acceleration(data: &PointsData, t0: f32, t1: f32) -> SpheresDesc {
    let mut s = (*data.spheres).clone();
    if let Some(acc) = &data.accelerations {
        let vel = s.velocities.get_or_insert_with(|| vec![Vec3::ZERO; s.centers.len()]);
        for ((c, v), a) in s.centers.iter_mut().zip(vel.iter_mut()).zip(acc) {
            *v += *a * (0.5 * (t0 + t1));
            *c -= *a * (0.5 * t0 * t1);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::{Attr, Primvar, Value};

    fn st(pairs: &[(&str, Value)]) -> AttrStore {
        let mut s = AttrStore::default();
        for (n, v) in pairs {
            s.attrs.insert(n.to_string(), Attr { value: Some(v.clone()), samples: vec![] });
        }
        s
    }

    fn bounds(m: &MeshDesc) -> (Vec3, Vec3) {
        m.positions.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &p| (lo.min(p), hi.max(p)))
    }

    /// Every triangle's geometric normal points away from the centroid of the (convex) shape
    /// and agrees with the shading normals at its corners.
    fn check_outward(m: &MeshDesc) {
        let c = m.positions.iter().copied().sum::<Vec3>() / m.positions.len() as f32;
        let ns = m.normals.as_ref().unwrap();
        for t in m.indices.chunks_exact(3) {
            let [a, b, d] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
            let g = (b - a).cross(d - a);
            if g.length() < 1e-9 {
                continue; // apex slivers of the capsule poles
            }
            let mid = (a + b + d) / 3.0;
            assert!(g.dot(mid - c) > 0.0, "{} inward triangle {:?}", m.name, t);
            for k in 0..3 {
                assert!(ns[t[k] as usize].dot(g) > 0.0, "{} normal disagrees", m.name);
            }
        }
        assert_eq!(m.uvs.as_ref().unwrap().len(), m.positions.len());
    }

    fn close(a: Vec3, b: Vec3) -> bool {
        // Tessellation vertices are evaluated with f32 sin/cos: 1e-5 covers their round-off.
        (a - b).abs().max_element() < 1e-5
    }

    #[test]
    fn implicit_gprims_have_usd_dimensions_axis_and_outward_normals() {
        let mut p = Problems::new("/g");
        let c = cube("/c", &st(&[("size", Value::Float(3.0))]), &mut p);
        assert!(close(bounds(&c).1, Vec3::splat(1.5)) && close(bounds(&c).0, Vec3::splat(-1.5)));
        check_outward(&c);

        let cyl = cylinder("/cyl", &st(&[("radius", Value::Float(0.5)), ("height", Value::Float(4.0)), ("axis", Value::Token("X".into()))]), &mut p);
        assert!(close(bounds(&cyl).1, Vec3::new(2.0, 0.5, 0.5)), "{:?}", bounds(&cyl));
        check_outward(&cyl);

        let cn = cone("/cone", &st(&[("height", Value::Float(2.0)), ("axis", Value::Token("Y".into()))]), &mut p);
        assert!(close(bounds(&cn).0, Vec3::new(-1.0, -1.0, -1.0)) && close(bounds(&cn).1, Vec3::new(1.0, 1.0, 1.0)));
        // The apex is on +axis.
        assert!(cn.positions.iter().any(|q| close(*q, Vec3::new(0.0, 1.0, 0.0))));
        check_outward(&cn);

        let cap = capsule("/cap", &st(&[("radius", Value::Float(0.25)), ("height", Value::Float(1.0))]), &mut p);
        assert!(close(bounds(&cap).1, Vec3::new(0.25, 0.25, 0.75)), "{:?}", bounds(&cap));
        check_outward(&cap);
        for (q, n) in cap.positions.iter().zip(cap.normals.as_ref().unwrap()) {
            assert!((n.length() - 1.0).abs() < 1e-5);
            let axis_pt = Vec3::new(0.0, 0.0, q.z.clamp(-0.5, 0.5));
            assert!(close(axis_pt + 0.25 * *n, *q));
        }

        for (axis, n, ext) in [("Z", Vec3::Z, Vec3::new(1.0, 2.0, 0.0)), ("Y", Vec3::Y, Vec3::new(1.0, 0.0, 2.0)), ("X", Vec3::X, Vec3::new(0.0, 2.0, 1.0))] {
            let pl = plane("/pl", &st(&[("width", Value::Float(2.0)), ("length", Value::Float(4.0)), ("axis", Value::Token(axis.into()))]), &mut p);
            assert!(close(bounds(&pl).1, ext), "{} {:?}", axis, bounds(&pl));
            for t in pl.indices.chunks_exact(3) {
                let [a, b, d] = [0, 1, 2].map(|k| pl.positions[t[k] as usize]);
                assert!((b - a).cross(d - a).normalize().dot(n) > 0.999);
            }
        }
        let sp = sphere("/s", &st(&[("radius", Value::Float(2.5))]), &mut p);
        assert_eq!(sp.radii, vec![2.5]);
        assert!(p.list.is_empty(), "{:?}", p.list);
    }

    /// Cylinder_1 and Capsule_1: different end radii. The frustum's rim lies on both radii,
    /// its side normals are perpendicular to the side; the capsule's surface lies on the hull of
    /// its two end spheres (every vertex on one sphere and outside the other, or on the tangent
    /// cone between them), with normals continuous across the cone. No triangle has zero area
    /// (a cone's apex, the poles).
    #[test]
    fn tapered_cylinders_and_capsules_follow_their_end_radii() {
        let mut p = Problems::new("/g");
        let f = cylinder("/f", &st(&[("radiusBottom", Value::Float(1.5)), ("radiusTop", Value::Float(0.3)), ("height", Value::Float(3.0)), ("axis", Value::Token("Y".into()))]), &mut p);
        assert!(close(bounds(&f).0, Vec3::new(-1.5, -1.5, -1.5)) && close(bounds(&f).1, Vec3::new(1.5, 1.5, 1.5)), "{:?}", bounds(&f));
        let ns = f.normals.as_ref().unwrap();
        for (q, n) in f.positions.iter().zip(ns) {
            let radial = Vec2::new(q.z, q.x).length();
            let want = 1.5 + (0.3 - 1.5) * (q.y + 1.5) / 3.0;
            if n.y.abs() < 0.99 {
                // side vertex: on the frustum, normal perpendicular to its generator line
                assert!((radial - want).abs() < 1e-5, "{q:?} at radius {radial}, want {want}");
                let generator = Vec3::new(q.x / radial * (0.3 - 1.5), 3.0, q.z / radial * (0.3 - 1.5));
                assert!(n.dot(generator).abs() < 1e-5);
            }
        }
        check_outward(&f);
        // a cone as a Cylinder_1 with radiusTop 0: no slivers at the apex
        let cn = cylinder("/c", &st(&[("radiusBottom", Value::Float(1.0)), ("radiusTop", Value::Float(0.0))]), &mut p);
        let cb = cone("/cb", &st(&[]), &mut p);
        for m in [&cn, &cb, &f] {
            assert!(m.indices.chunks_exact(3).all(|t| {
                let [a, b, d] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
                (b - a).cross(d - a).length() > 0.0
            }), "{} has a triangle of no area", m.name);
        }

        let (rb, rt, h) = (1.0f32, 0.4f32, 2.0f32);
        let cap = capsule("/cap", &st(&[("radiusBottom", Value::Float(rb as f64)), ("radiusTop", Value::Float(rt as f64)), ("height", Value::Float(h as f64))]), &mut p);
        // the poles are vertices; the widest ring, the bottom sphere's equator, lies between two
        // of its rings (1.1e-3 short of rb with 16 rings to the tangent latitude)
        let (lo, hi) = bounds(&cap);
        assert!(close(Vec3::new(lo.z, hi.z, 0.0), Vec3::new(-1.0 - rb, 1.0 + rt, 0.0)) && hi.x <= rb && hi.x > rb * (1.0 - 2e-3), "{:?}", (lo, hi));
        let (cb0, ct0) = (Vec3::new(0.0, 0.0, -1.0), Vec3::new(0.0, 0.0, 1.0));
        let sin_phi = (rb - rt) / h;
        for (q, n) in cap.positions.iter().zip(cap.normals.as_ref().unwrap()) {
            let on_bottom = ((*q - cb0).length() - rb).abs() < 1e-5;
            let on_top = ((*q - ct0).length() - rt).abs() < 1e-5;
            assert!(on_bottom || on_top, "{q:?} on neither sphere");
            // the surface is the hull: no vertex inside either sphere
            assert!((*q - cb0).length() > rb - 1e-5 && (*q - ct0).length() > rt - 1e-5);
            // a sphere's vertex has that sphere's normal; the tangent ring has the cone's
            let (centre, r) = if on_bottom { (cb0, rb) } else { (ct0, rt) };
            assert!(close(centre + r * *n, *q), "{q:?} normal {n:?}");
        }
        // the cone meets each sphere on its tangent circle: both rings carry the cone's normal,
        // whose latitude is asin((rb − rt) / height)
        let ring = |centre: Vec3, r: f32| cap.positions.iter().zip(cap.normals.as_ref().unwrap()).filter(|(q, n)| (n.z - sin_phi).abs() < 1e-5 && close(centre + r * **n, **q)).count();
        assert!(ring(cb0, rb) > 0 && ring(ct0, rt) > 0);
        check_outward(&cap);
        // one sphere holding the other: the hull is the larger sphere
        let ball = capsule("/b", &st(&[("radiusBottom", Value::Float(2.0)), ("radiusTop", Value::Float(0.5)), ("height", Value::Float(1.0))]), &mut p);
        assert!(!ball.indices.is_empty());
        assert!(ball.indices.iter().all(|&i| ((ball.positions[i as usize] - Vec3::new(0.0, 0.0, -0.5)).length() - 2.0).abs() < 1e-5));
        assert!(p.list.is_empty(), "{:?}", p.list);
        // bad end radii are named
        let mut p = Problems::new("/s");
        cylinder("/s", &st(&[("radiusTop", Value::Float(-1.0))]), &mut p);
        capsule("/s", &st(&[("radiusTop", Value::Float(0.0)), ("radiusBottom", Value::Float(0.0))]), &mut p);
        assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), ["radiusTop", "radiusBottom"]);
    }

    #[test]
    fn bad_dimensions_fall_back_with_a_problem() {
        let mut p = Problems::new("/s");
        assert_eq!(sphere("/s", &st(&[("radius", Value::Float(-1.0))]), &mut p).radii, vec![1.0]);
        cylinder("/s", &st(&[("axis", Value::Token("W".into()))]), &mut p);
        let attrs: Vec<_> = p.list.iter().map(|q| q.attribute.as_str()).collect();
        assert_eq!(attrs, vec!["radius", "axis"]);
    }

    /// Points without velocities move between the time samples of their positions (USD
    /// interpolates them): along the chord from the first sample to the last, in seconds of
    /// shutter time; without motion blur they stand at the frame. A sample of another point
    /// count is named and the points stand still.
    #[test]
    fn points_move_between_their_position_samples() {
        let at = |x: f32| Value::Floats { data: vec![x, 0., 0., x, 1., 0.], tuple: 3 };
        let sampled = |a: Value, b: Value| {
            let mut s = st(&[("points", at(0.5))]);
            s.attrs.get_mut("points").unwrap().samples = vec![(-0.5, a), (0.5, b)];
            s
        };
        let mut p = Problems::new("/p");
        let d = points("/p", &sampled(at(0.0), at(2.0)), &mut p);
        assert!(p.list.is_empty(), "{:?}", p.list);
        // 24 time codes a second: the shutter [-0.5, 0.5] is 1/24 s, the points move 2 units
        let m = d.made(-0.5 / 24.0, 0.5 / 24.0, true, 24.0, 1.0);
        let v = m.spheres.velocities.clone().unwrap();
        assert!(v.iter().all(|v| (*v - Vec3::new(48.0, 0.0, 0.0)).length() < 1e-3), "{v:?}");
        let c = &m.spheres.centers;
        assert!((c[0] - Vec3::new(1.0, 0.0, 0.0)).length() < 1e-5 && (c[1] - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-5, "{c:?}");
        // no motion blur: at the frame, still
        let still = d.made(0.0, 0.0, false, 24.0, 1.0);
        assert!(still.spheres.velocities.is_none() && still.spheres.centers[0] == Vec3::new(0.5, 0.0, 0.0));
        // another count: named, still
        let mut p = Problems::new("/p");
        let d = points("/p", &sampled(at(0.0), Value::Floats { data: vec![0.0; 3], tuple: 3 }), &mut p);
        assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), ["points"]);
        assert!(d.made(-0.02, 0.02, true, 24.0, 1.0).spheres.velocities.is_none());
    }

    #[test]
    fn points_become_spheres_of_half_width() {
        let pts = Value::Floats { data: vec![0., 0., 0., 1., 0., 0., f32::NAN, 0., 0.], tuple: 3 };
        let mut p = Problems::new("/p");
        let d = points("/p", &st(&[("points", pts.clone())]), &mut p);
        assert_eq!(d.spheres.radii, vec![0.5, 0.5]);
        assert_eq!(p.list.len(), 1);
        let mut s = st(&[("points", pts)]);
        s.primvars.insert("widths".into(), Primvar { interpolation: Interpolation::Vertex, data: vec![2.0, 4.0, 1.0], tuple: 1, indices: None });
        s.primvars.insert("velocities".into(), Primvar { interpolation: Interpolation::Vertex, data: vec![1.0; 9], tuple: 3, indices: None });
        s.primvars.insert(
            "accelerations".into(),
            Primvar { interpolation: Interpolation::Vertex, data: vec![0., -10., 0., 0., 0., 0., 0., 0., 0.], tuple: 3, indices: None },
        );
        let d = points("/p", &s, &mut Problems::new("/p"));
        assert_eq!(d.spheres.radii, vec![1.0, 2.0]);
        // Folding: the chord matches the parabola at both shutter ends.
        let (t0, t1) = (-0.02f32, 0.03f32);
        let f = fold_acceleration(&d, t0, t1);
        for t in [t0, t1] {
            let exact = d.spheres.centers[0] + d.spheres.velocities.as_ref().unwrap()[0] * t + Vec3::new(0., -10., 0.) * (0.5 * t * t);
            let lin = f.centers[0] + f.velocities.as_ref().unwrap()[0] * t;
            assert!(close(exact, lin), "{:?} {:?}", exact, lin);
        }
    }

    /// TideBlobbyAPI / TideBubbleAPI pick the points' shape; per-point data follows the points
    /// kept; bad data is named and replaced.
    #[test]
    fn points_shapes_from_the_api_schemas() {
        let pts = Value::Floats { data: vec![0., 0., 0., f32::NAN, 0., 0., 1., 0., 0.], tuple: 3 };
        let pv = |data: Vec<f32>, tuple: u32| Primvar { interpolation: Interpolation::Vertex, data, tuple, indices: None };
        let apis = |a: &[&str]| Value::Paths(a.iter().map(|s| s.to_string()).collect());
        // bubbles: heights per point (the NaN point's dropped), a constant orientation
        let mut s = st(&[("points", pts.clone()), ("apiSchemas", apis(&["TideBubbleAPI"]))]);
        s.primvars.insert("tide:bubble:top".into(), pv(vec![0.3, 0.4, 0.5], 1));
        s.primvars.insert("tide:bubble:orientation".into(), pv(vec![0.0, 0.0, 0.0, 1.0], 4));
        let mut p = Problems::new("/b");
        let d = points("/b", &s, &mut p);
        assert_eq!(
            d.spheres.shape,
            PointShape::Bubbles { top: vec![0.3, 0.5], bottom: vec![0.5, 0.5], orientations: Some(vec![Quat::IDENTITY; 2]) }
        );
        // blobbies: the threshold shows the API even without the schema list
        let mut s = st(&[("points", pts.clone()), ("tide:blobby:threshold", Value::Float(0.4))]);
        s.primvars.insert("tide:blobby:scale".into(), pv(vec![1.0, 2.0, 3.0, 1.0, 1.0, 1.0], 3));
        let mut p = Problems::new("/k");
        let d = points("/k", &s, &mut p);
        let want = PointShape::Blobby { threshold: 0.4, orientations: None, scales: None };
        assert_eq!(d.spheres.shape, want, "2 scales for 3 points");
        assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), ["points", "primvars:tide:blobby:scale"]);
        // droplets as a medium: the voxel size and shell (a bad voxel size named and replaced);
        // on blobbies asVolume is refused and named
        let s = st(&[("points", pts.clone()), ("tide:droplets:asVolume", Value::Bool(true)), ("tide:droplets:shell", Value::Float(0.2))]);
        let d = points("/d", &s, &mut Problems::new("/d"));
        assert_eq!((d.spheres.shape.clone(), d.droplets), (PointShape::Spheres, Some((0.01, 0.2))));
        let s = st(&[("points", pts.clone()), ("tide:droplets:asVolume", Value::Bool(true)), ("tide:droplets:voxelSize", Value::Float(-1.0))]);
        let mut p = Problems::new("/d");
        assert_eq!(points("/d", &s, &mut p).droplets, Some((0.01, 0.0)));
        assert_eq!(p.list.iter().map(|q| q.attribute.as_str()).collect::<Vec<_>>(), ["points", "tide:droplets:voxelSize"]);
        let s = st(&[("points", pts), ("tide:droplets:asVolume", Value::Bool(true)), ("tide:blobby:threshold", Value::Float(0.5))]);
        let mut p = Problems::new("/d");
        assert_eq!(points("/d", &s, &mut p).droplets, None);
        assert!(p.list.iter().any(|q| q.attribute == "tide:droplets:asVolume"));
    }

    #[test]
    fn points_are_placed_once_per_shutter_and_shared() {
        // a cloud of 27 touching droplets: the inner ones become a medium
        let data: Vec<f32> = (0..27).flat_map(|i| [(i % 3) as f32 * 0.01, (i / 3 % 3) as f32 * 0.01, (i / 9) as f32 * 0.01]).collect();
        let pts = Value::Floats { data, tuple: 3 };
        let mut s = st(&[("points", pts.clone()), ("tide:droplets:asVolume", Value::Bool(true)), ("tide:droplets:voxelSize", Value::Float(0.005))]);
        s.primvars.insert("widths".into(), Primvar { interpolation: Interpolation::Constant, data: vec![0.012], tuple: 1, indices: None });
        let d = points("/d", &s, &mut Problems::new("/d"));
        let a = d.made(0.0, 0.0, false, 24.0, 1.0);
        let Some(Ok(Some(grid))) = &a.droplets else { panic!("no droplet medium: {:?}", a.droplets) };
        assert!(a.spheres.centers.len() < 27 && grid.values.to_dense().iter().any(|&v| v > 0.0));
        let b = d.made(0.0, 0.0, false, 24.0, 1.0);
        assert!(Arc::ptr_eq(&a.spheres, &b.spheres), "split once, then shared");
        // the voxel size is in metres: 0.005 m in a stage of 0.5 m units is 0.01 units
        let mut s2 = s.clone();
        s2.attrs.insert("tide:droplets:voxelSize".into(), Attr { value: Some(Value::Float(0.01)), samples: vec![] });
        let d2 = points("/d2", &s2, &mut Problems::new("/d2"));
        let grid_of = |m: &PointsMade| match &m.droplets {
            Some(Ok(Some(g))) => (g.values.dims(), g.values.to_dense(), g.local_to_world),
            other => panic!("no droplet medium: {other:?}"),
        };
        let unit = grid_of(&d2.made(0.0, 0.0, false, 24.0, 1.0));
        assert_eq!(grid_of(&d.made(0.0, 0.0, false, 24.0, 0.5)), unit);
        assert_ne!(grid_of(&a), unit);
        // plain points that need nothing done are the converted ones
        let plain = points("/p", &st(&[("points", pts.clone())]), &mut Problems::new("/p"));
        assert!(Arc::ptr_eq(&plain.made(0.0, 0.1, true, 24.0, 1.0).spheres, &plain.spheres));
        // accelerating points: folded per shutter, the same shutter shared, another made anew
        let mut s = st(&[("points", pts)]);
        s.primvars.insert("accelerations".into(), Primvar { interpolation: Interpolation::Vertex, data: [0.0f32, -10.0, 0.0].repeat(27), tuple: 3, indices: None });
        let d = points("/a", &s, &mut Problems::new("/a"));
        let m = d.made(-0.02, 0.03, true, 24.0, 1.0);
        assert_eq!(*m.spheres, fold_acceleration(&d, -0.02, 0.03));
        assert!(Arc::ptr_eq(&m.spheres, &d.made(-0.02, 0.03, true, 24.0, 1.0).spheres));
        let other = d.made(0.0, 0.04, true, 24.0, 1.0);
        assert!(!Arc::ptr_eq(&m.spheres, &other.spheres) && *other.spheres == fold_acceleration(&d, 0.0, 0.04));
        // without motion blur the velocities go
        assert!(d.made(-0.02, 0.03, false, 24.0, 1.0).spheres.velocities.is_none());
    }
}
