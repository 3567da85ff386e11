//! The BVH: Tide's two-level acceleration structure. One BVH per geometry: a static mesh's
//! triangles in an eight-wide tree of four-triangle blocks (`tribvh.rs`), a points set's
//! spheres, bubbles or blobby kernels in the same eight-wide tree with primitive ids in its
//! leaves, intersected by callback (`wide.rs`), a deforming mesh in the same tree with
//! four-triangle blocks stored per position key (`motion_mesh.rs`); and one eight-wide tree over
//! the instances that place them. Instances may move
//! (transform motion blur with any number of samples, rotations interpolated on the sphere),
//! spheres may move by velocity and meshes may deform (vertex position keys).

mod tribvh;
mod wide;
pub mod implicit;
mod motion_mesh;
pub mod motion;

use crate::scene::{GeometryRef, InstanceDesc, MeshDesc, PointShape, SpheresDesc};
use implicit::{Bubble, Entering, Kernel, Ordered, Sweep};
use tribvh::{TriBvh, TriMesh};
pub(crate) use wide::{prefetch_lines, PointBvh};
pub use wide::MAX_LEAF_ITEMS;
use motion_mesh::MotionTriBlas;
use glam::{Mat3, Mat4, Quat, Vec3, Vec3A};
use motion::MotionTransform;
use obvhs::aabb::Aabb;
use std::collections::HashMap;
use std::hash::{Hash, Hasher};
use std::sync::{Arc, Mutex};

/// A ray with a time (seconds of shutter time) and a maximum distance.
#[derive(Clone, Copy, Debug)]
pub struct Ray {
    pub o: Vec3,
    pub d: Vec3,
    pub t_max: f32,
    pub time: f32,
}

/// The closest intersection found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Index into the instances the accelerator was built from.
    pub instance: u32,
    /// Triangle index in the mesh, or point index in the points set.
    pub prim: u32,
    /// Barycentrics (triangles: weights of vertices 1 and 2).
    pub u: f32,
    pub v: f32,
}

/// A triangle prepared for intersection: a vertex and two edges (the tests' reference).
#[cfg(test)]
#[derive(Clone, Copy, Debug)]
struct TriPre {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
}

#[cfg(test)]
impl TriPre {
    /// Möller–Trumbore; returns (t, u, v) with u, v the weights of vertices 1 and 2.
    #[inline(always)]
    fn intersect(&self, o: Vec3A, d: Vec3A, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        let p = d.cross(self.e2);
        let det = self.e1.dot(p);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - self.v0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(self.e1);
        let v = d.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = self.e2.dot(q) * inv;
        if t > t_min && t < t_max {
            Some((t, u, v))
        } else {
            None
        }
    }
}


/// A points set's BVH with the points' data in the BVH's leaf order (slot k holds point
/// `bvh.ids()[k]`): a leaf's points sit side by side instead of scattered over the input order.
struct SphereBlas {
    bvh: PointBvh,
    centers: Vec<Vec3>,
    radii: Vec<f32>,
    velocities: Option<Vec<Vec3>>,
    shape: PointsBlasShape,
    /// Point i's slot (u32::MAX for a point left out of the BVH).
    slot_of: Vec<u32>,
}

/// What a points BVH's primitives are.
enum PointsBlasShape {
    Spheres,
    /// Bubbles as at time 0 (centres move with the velocities).
    Bubbles(Vec<Bubble>),
    /// Blobby kernels' maps to their unit balls, their bounding radii, and the threshold.
    Blobby { a: Vec<Mat3>, reach: Vec<f32>, threshold: f32 },
}

enum Blas {
    Tri(TriBvh),
    MotionTri(MotionTriBlas),
    Sphere(SphereBlas),
    Empty,
}

struct InstanceRec {
    blas: usize,
    xf: MotionTransform,
    /// Static with the identity transform: rays need no change of frame.
    identity: bool,
}

/// Bytes and timings of a build, for reports.
#[derive(Clone, Debug, Default)]
pub struct BuildStats {
    pub triangles: usize,
    pub spheres: usize,
    pub instances: usize,
    pub bytes: usize,
    pub seconds: f64,
    /// Per-geometry BVHs built by this build.
    pub blas_built: usize,
    /// Per-geometry BVHs taken from a [`BlasCache`] instead of being rebuilt.
    pub blas_reused: usize,
}

/// What a per-geometry BVH depends on: the geometry's content (hashed, with its sizes) and,
/// for spheres, the shutter their motion is bounded over.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
enum BlasKey {
    Tri { points: usize, indices: usize, hash: u64 },
    MotionTri { points: usize, indices: usize, keys: usize, hash: u64 },
    Sphere { spheres: usize, moving: bool, shutter: (u32, u32), hash: u64 },
}

impl BlasKey {
    fn mesh(m: &MeshDesc) -> BlasKey {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        h.write(bytemuck::cast_slice(&m.positions));
        h.write(bytemuck::cast_slice(&m.indices));
        if let Some(mo) = &m.motion {
            h.write(bytemuck::cast_slice(&mo.times));
            for k in &mo.positions {
                h.write(bytemuck::cast_slice(k));
            }
            return BlasKey::MotionTri { points: m.positions.len(), indices: m.indices.len(), keys: mo.times.len(), hash: h.finish() };
        }
        BlasKey::Tri { points: m.positions.len(), indices: m.indices.len(), hash: h.finish() }
    }

    fn spheres(s: &SpheresDesc, shutter: (f32, f32)) -> BlasKey {
        let mut h = std::collections::hash_map::DefaultHasher::new();
        h.write(bytemuck::cast_slice(&s.centers));
        h.write(bytemuck::cast_slice(&s.radii));
        if let Some(v) = &s.velocities {
            v.len().hash(&mut h);
            h.write(bytemuck::cast_slice(v));
        }
        let quats = |h: &mut std::collections::hash_map::DefaultHasher, q: &Option<Vec<Quat>>| {
            if let Some(q) = q {
                q.len().hash(h);
                q.iter().for_each(|q| h.write(bytemuck::cast_slice(&q.to_array())));
            }
        };
        match &s.shape {
            PointShape::Spheres => 0u8.hash(&mut h),
            PointShape::Bubbles { top, bottom, orientations } => {
                1u8.hash(&mut h);
                h.write(bytemuck::cast_slice(top));
                h.write(bytemuck::cast_slice(bottom));
                quats(&mut h, orientations);
            }
            PointShape::Blobby { threshold, orientations, scales } => {
                2u8.hash(&mut h);
                threshold.to_bits().hash(&mut h);
                quats(&mut h, orientations);
                if let Some(sc) = scales {
                    h.write(bytemuck::cast_slice(sc));
                }
            }
        }
        BlasKey::Sphere { spheres: s.centers.len(), moving: s.velocities.is_some(), shutter: (shutter.0.to_bits(), shutter.1.to_bits()), hash: h.finish() }
    }
}

/// Per-geometry BVHs kept from one build to the next, so that a scene edit that leaves a
/// geometry's points and triangles as they were (a moved instance, a new material, another
/// prim edited) does not rebuild its BVH. Geometry is recognised by content, whatever its
/// name or position in the scene. After each build the cache holds exactly the BVHs that
/// build used. Cloning shares the cache.
#[derive(Clone, Default)]
pub struct BlasCache {
    entries: Arc<Mutex<HashMap<BlasKey, Arc<Blas>>>>,
    /// The keys of meshes seen by the last build, by the mesh's address (the mesh is held so
    /// that the address is not reused): an unchanged shared mesh is not hashed again.
    mesh_keys: Arc<Mutex<HashMap<usize, (Arc<MeshDesc>, BlasKey)>>>,
    /// The same for sphere sets (whose keys also hold the shutter).
    sphere_keys: Arc<Mutex<HashMap<usize, (Arc<SpheresDesc>, BlasKey)>>>,
}

impl BlasCache {
    /// Number of per-geometry BVHs held.
    pub fn len(&self) -> usize {
        self.entries.lock().unwrap_or_else(|e| e.into_inner()).len()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// The content keys of one build's shared geometry, taken from the last build's where the
/// geometry is the same (by identity) and the key still applies.
struct KeyMemo<T> {
    old: HashMap<usize, (Arc<T>, BlasKey)>,
    now: HashMap<usize, (Arc<T>, BlasKey)>,
}

impl<T> KeyMemo<T> {
    fn begin(last: Option<&Mutex<HashMap<usize, (Arc<T>, BlasKey)>>>) -> KeyMemo<T> {
        KeyMemo { old: last.map(|m| std::mem::take(&mut *m.lock().unwrap_or_else(|e| e.into_inner()))).unwrap_or_default(), now: HashMap::new() }
    }

    fn key(&mut self, item: &Arc<T>, applies: impl Fn(&BlasKey) -> bool, hash: impl FnOnce() -> BlasKey) -> BlasKey {
        let addr = Arc::as_ptr(item) as usize;
        let known = self.now.get(&addr).or_else(|| self.old.get(&addr)).filter(|e| Arc::ptr_eq(&e.0, item) && applies(&e.1)).map(|e| e.1);
        let key = known.unwrap_or_else(hash);
        self.now.insert(addr, (item.clone(), key));
        key
    }
}

/// The scene's acceleration structure.
pub struct Accel {
    tlas: Option<PointBvh>,
    blas: Vec<Arc<Blas>>,
    instances: Vec<InstanceRec>,
    bounds: (Vec3, Vec3),
    pub stats: BuildStats,
}

/// Intersects a sphere; returns the nearest t in (t_min, t_max).
#[inline(always)]
fn intersect_sphere(c: Vec3A, r: f32, o: Vec3A, d: Vec3A, t_min: f32, t_max: f32) -> Option<f32> {
    // Numerically robust form (Haines et al., Ray Tracing Gems ch. 7)
    let f = o - c;
    let a = d.dot(d);
    let b = -f.dot(d);
    let l = f + (b / a) * d;
    let disc = r * r - l.dot(l);
    if disc < 0.0 {
        return None;
    }
    let c2 = f.dot(f) - r * r;
    let q = b + b.signum() * (a * disc).sqrt();
    if q == 0.0 {
        return None;
    }
    let t0 = c2 / q;
    let t1 = q / a;
    let (t0, t1) = if t0 < t1 { (t0, t1) } else { (t1, t0) };
    if t0 > t_min && t0 < t_max {
        Some(t0)
    } else if t1 > t_min && t1 < t_max {
        Some(t1)
    } else {
        None
    }
}

fn build_tri_blas(mesh: &MeshDesc) -> Blas {
    let ntri = mesh.indices.len() / 3;
    if ntri == 0 {
        return Blas::Empty;
    }
    if mesh.motion.is_some() {
        return MotionTriBlas::build(mesh).map_or(Blas::Empty, Blas::MotionTri);
    }
    Blas::Tri(TriBvh::build(TriMesh { positions: &mesh.positions, indices: &mesh.indices }))
}

fn build_sphere_blas(s: &SpheresDesc, shutter: (f32, f32)) -> Blas {
    if s.centers.is_empty() {
        return Blas::Empty;
    }
    let shape = match &s.shape {
        PointShape::Spheres => PointsBlasShape::Spheres,
        PointShape::Bubbles { top, bottom, orientations } => PointsBlasShape::Bubbles(
            (0..s.centers.len())
                .map(|i| Bubble {
                    center: s.centers[i],
                    r: s.radii[i],
                    top: top[i],
                    bottom: bottom[i],
                    rot: orientations.as_ref().map_or(Quat::IDENTITY, |o| o[i]),
                })
                .collect(),
        ),
        PointShape::Blobby { threshold, orientations, scales } => PointsBlasShape::Blobby {
            a: (0..s.centers.len())
                .map(|i| {
                    let rot = orientations.as_ref().map_or(Quat::IDENTITY, |o| o[i]);
                    let scale = scales.as_ref().map_or(Vec3::ONE, |sc| sc[i]);
                    Kernel::new(Vec3::ZERO, s.radii[i], scale, rot, *threshold).a
                })
                .collect(),
            reach: Vec::new(),
            threshold: *threshold,
        },
    };
    // the radius of a sphere about each centre that holds its primitive
    let bound_radius = |i: usize| match (&s.shape, &shape) {
        (_, PointsBlasShape::Bubbles(b)) => b[i].bounding_radius(),
        (PointShape::Blobby { threshold, scales, .. }, _) => {
            s.radii[i] * scales.as_ref().map_or(1.0, |sc| sc[i].max_element()) * implicit::blobby_bound_factor(*threshold)
        }
        _ => s.radii[i],
    };
    let bounds = s.centers.iter().enumerate().map(|(i, &c)| {
        let r = Vec3A::splat(bound_radius(i));
        let (mut lo, mut hi) = (Vec3A::from(c) - r, Vec3A::from(c) + r);
        if let Some(v) = &s.velocities {
            for t in [shutter.0, shutter.1] {
                let cc = Vec3A::from(c + v[i] * t);
                (lo, hi) = (lo.min(cc - r), hi.max(cc + r));
            }
        }
        (lo, hi)
    });
    let bvh = PointBvh::build(bounds);
    // the points' data in leaf order
    let ids = bvh.ids();
    fn in_slots<T: Copy>(ids: &[u32], v: &[T]) -> Vec<T> {
        ids.iter().map(|&i| v[i as usize]).collect()
    }
    let reach_in_slots: Vec<f32> = match shape {
        PointsBlasShape::Blobby { .. } => ids.iter().map(|&i| bound_radius(i as usize)).collect(),
        _ => Vec::new(),
    };
    let mut slot_of = vec![u32::MAX; s.centers.len()];
    for (k, &i) in ids.iter().enumerate() {
        slot_of[i as usize] = k as u32;
    }
    let shape = match shape {
        PointsBlasShape::Spheres => PointsBlasShape::Spheres,
        PointsBlasShape::Bubbles(b) => PointsBlasShape::Bubbles(in_slots(ids, &b)),
        PointsBlasShape::Blobby { a, threshold, .. } => PointsBlasShape::Blobby { a: in_slots(ids, &a), reach: reach_in_slots, threshold },
    };
    Blas::Sphere(SphereBlas {
        centers: in_slots(ids, &s.centers),
        radii: in_slots(ids, &s.radii),
        velocities: s.velocities.as_deref().map(|v| in_slots(ids, v)),
        shape,
        slot_of,
        bvh,
    })
}

fn transform_aabb(m: &Mat4, bb: &Aabb) -> Aabb {
    let mut out = Aabb::empty();
    for k in 0..8 {
        let p = Vec3::new(
            if k & 1 == 0 { bb.min.x } else { bb.max.x },
            if k & 2 == 0 { bb.min.y } else { bb.max.y },
            if k & 4 == 0 { bb.min.z } else { bb.max.z },
        );
        out.extend(Vec3A::from(m.transform_point3(p)));
    }
    out
}

impl Accel {
    /// Builds the structure. `shutter` is the time interval rays will sample.
    /// Inputs must be validated (finite, well-indexed): see `SceneDesc::validate`.
    pub fn build(meshes: &[Arc<MeshDesc>], spheres: &[Arc<SpheresDesc>], instances: &[InstanceDesc], shutter: (f32, f32)) -> Accel {
        Accel::build_cached(meshes, spheres, instances, shutter, None)
    }

    /// [`Accel::build`], taking the per-geometry BVHs of unchanged geometry from `cache` and
    /// leaving in it those of this build.
    pub fn build_cached(meshes: &[Arc<MeshDesc>], spheres: &[Arc<SpheresDesc>], instances: &[InstanceDesc], shutter: (f32, f32), cache: Option<&BlasCache>) -> Accel {
        let start = std::time::Instant::now();
        let mut blas: Vec<Arc<Blas>> = Vec::with_capacity(meshes.len() + spheres.len());
        let mut stats = BuildStats::default();
        let mut old = cache.map(|c| std::mem::take(&mut *c.entries.lock().unwrap_or_else(|e| e.into_inner()))).unwrap_or_default();
        let mut kept: HashMap<BlasKey, Arc<Blas>> = HashMap::new();
        let mut get = |key: Option<BlasKey>, build: &dyn Fn() -> Blas, stats: &mut BuildStats| -> Arc<Blas> {
            let Some(key) = key else {
                stats.blas_built += 1;
                return Arc::new(build());
            };
            if let Some(b) = kept.get(&key).or_else(|| old.get(&key)).cloned() {
                stats.blas_reused += 1;
                old.remove(&key);
                kept.insert(key, b.clone());
                return b;
            }
            stats.blas_built += 1;
            let b = Arc::new(build());
            kept.insert(key, b.clone());
            b
        };
        let mut mesh_keys = KeyMemo::begin(cache.map(|c| &*c.mesh_keys));
        for m in meshes {
            stats.triangles += m.indices.len() / 3;
            let key = cache.map(|_| mesh_keys.key(m, |k| matches!(k, BlasKey::Tri { .. } | BlasKey::MotionTri { .. }), || BlasKey::mesh(m)));
            blas.push(get(key, &|| build_tri_blas(m), &mut stats));
        }
        let bits = (shutter.0.to_bits(), shutter.1.to_bits());
        let mut sphere_keys = KeyMemo::begin(cache.map(|c| &*c.sphere_keys));
        for s in spheres {
            stats.spheres += s.centers.len();
            let key = cache.map(|_| sphere_keys.key(s, |k| matches!(k, BlasKey::Sphere { shutter, .. } if *shutter == bits), || BlasKey::spheres(s, shutter)));
            blas.push(get(key, &|| build_sphere_blas(s, shutter), &mut stats));
        }
        drop(old);
        if let Some(c) = cache {
            *c.entries.lock().unwrap_or_else(|e| e.into_inner()) = kept;
            *c.mesh_keys.lock().unwrap_or_else(|e| e.into_inner()) = mesh_keys.now;
            *c.sphere_keys.lock().unwrap_or_else(|e| e.into_inner()) = sphere_keys.now;
        }
        let mut recs = Vec::with_capacity(instances.len());
        let mut ibounds = Vec::with_capacity(instances.len());
        for inst in instances {
            let b = match inst.geometry {
                GeometryRef::Mesh(i) => i,
                GeometryRef::Spheres(i) => meshes.len() + i,
            };
            let xf = MotionTransform::new(&inst.transforms, &inst.times);
            let local = match blas[b].as_ref() {
                Blas::Tri(t) => Aabb::new(t.bounds.0.into(), t.bounds.1.into()),
                Blas::MotionTri(t) => {
                    let (lo, hi) = t.bounds();
                    Aabb::new(lo.into(), hi.into())
                }
                Blas::Sphere(s) => {
                    let (lo, hi) = s.bvh.bounds();
                    Aabb::new(lo.into(), hi.into())
                }
                Blas::Empty => Aabb::empty(),
            };
            let mut wb = Aabb::empty();
            if local.valid() {
                for m in xf.bounding_matrices(shutter) {
                    wb = wb.union(&transform_aabb(&m, &local));
                }
            }
            let identity = inst.transforms.len() == 1 && inst.transforms[0] == Mat4::IDENTITY;
            recs.push(InstanceRec { blas: b, xf, identity });
            ibounds.push(wb);
        }
        let tlas = if ibounds.iter().any(|b| b.valid()) {
            // instances with nothing to hit are left out
            Some(PointBvh::build(ibounds.iter().map(|b| (b.min, b.max))))
        } else {
            None
        };
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for b in &ibounds {
            if b.valid() {
                lo = lo.min(b.min.into());
                hi = hi.max(b.max.into());
            }
        }
        if !(lo.x <= hi.x) {
            lo = Vec3::ZERO;
            hi = Vec3::ZERO;
        }
        stats.instances = recs.len();
        stats.bytes = blas
            .iter()
            .map(|b| match b.as_ref() {
                Blas::Tri(t) => t.bytes(),
                Blas::MotionTri(t) => t.bytes(),
                Blas::Sphere(s) => s.bvh.bytes() + s.centers.len() * 16 + s.slot_of.len() * 4,
                Blas::Empty => 0,
            })
            .sum::<usize>()
            + tlas.as_ref().map_or(0, |t| t.bytes());
        stats.seconds = start.elapsed().as_secs_f64();
        Accel { tlas, blas, instances: recs, bounds: (lo, hi), stats }
    }

    /// World bounds of everything (over the shutter).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// Object-to-world matrix of an instance at a time.
    pub fn instance_transform(&self, instance: u32, time: f32) -> Mat4 {
        self.instances[instance as usize].xf.at(time)
    }

    /// Object-to-world of an instance over the shutter.
    pub fn instance_motion(&self, instance: u32) -> &MotionTransform {
        &self.instances[instance as usize].xf
    }

    /// Closest hit in (0, ray.t_max).
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        self.intersect_where(ray, |_| true)
    }

    /// Closest hit in (0, ray.t_max) on the instances `keep` accepts.
    #[inline]
    pub fn intersect_where(&self, ray: &Ray, keep: impl Fn(u32) -> bool) -> Option<Hit> {
        let tlas = self.tlas.as_ref()?;
        if self.instances.len() == 1 {
            if !keep(0) {
                return None;
            }
            // A lone instance needs no TLAS (whose padded build would visit it twice).
            let inst = &self.instances[0];
            let (o, d) = if inst.identity { (ray.o, ray.d) } else { inst.xf.ray_to_local(ray.o, ray.d, ray.time) };
            let (t, prim, u, v) = self.intersect_blas(inst.blas, o.into(), d.into(), ray.t_max, ray.time)?;
            return Some(Hit { t, instance: 0, prim, u, v });
        }
        let mut best = None;
        tlas.traverse(ray.o.into(), ray.d.into(), ray.t_max, |i, t_max| {
            if !keep(i) {
                return None;
            }
            let inst = &self.instances[i as usize];
            let (o, d) = inst.xf.ray_to_local(ray.o, ray.d, ray.time);
            let (t, prim, u, v) = self.intersect_blas(inst.blas, o.into(), d.into(), t_max, ray.time)?;
            best = Some(Hit { t, instance: i, prim, u, v });
            Some(t)
        });
        best
    }

    #[inline]
    fn intersect_blas(&self, b: usize, o: Vec3A, d: Vec3A, t_max: f32, time: f32) -> Option<(f32, u32, f32, f32)> {
        match self.blas[b].as_ref() {
            Blas::Tri(tb) => tb.intersect(o, d, t_max),
            Blas::MotionTri(mb) => mb.intersect(o, d, t_max, time),
            Blas::Sphere(sb) => {
                let mut best: Option<(f32, u32, f32, f32)> = None;
                // by slot k (the data's leaf order); hits report the point's own index
                let ids = sb.bvh.ids();
                let center = |k: usize| match &sb.velocities {
                    Some(v) => sb.centers[k] + v[k] * time,
                    None => sb.centers[k],
                };
                let prefetch = |k: usize| wide::prefetch_lines(sb.centers.as_ptr().wrapping_add(k) as *const u8, 4 * 12);
                match &sb.shape {
                    PointsBlasShape::Spheres => {
                        sb.bvh.traverse_slots(
                            o,
                            d,
                            t_max,
                            |k, t_max| {
                                let t = intersect_sphere(center(k).into(), sb.radii[k], o, d, 0.0, t_max)?;
                                best = Some((t, ids[k], 0.0, 0.0));
                                Some(t)
                            },
                            prefetch,
                        );
                    }
                    PointsBlasShape::Bubbles(bubbles) => {
                        let bound = BoundingTest::new(o.into(), d.into());
                        sb.bvh.traverse_slots(
                            o,
                            d,
                            t_max,
                            |k, t_max| {
                                let b = Bubble { center: center(k), ..bubbles[k] };
                                bound.near(b.center, b.bounding_radius(), 0.0, t_max as f64)?;
                                let t = b.intersect(o.into(), d.into(), 0.0, t_max)?;
                                let (u, v) = implicit::oct_encode(b.normal(Vec3::from(o + d * t)));
                                best = Some((t, ids[k], u, v));
                                Some(t)
                            },
                            prefetch,
                        );
                    }
                    PointsBlasShape::Blobby { a, reach, threshold } => {
                        best = blobby_hit(sb, a, reach, *threshold, o, d, t_max, &center, &prefetch);
                    }
                }
                best
            }
            Blas::Empty => None,
        }
    }

    /// True when hits on `instance` carry their object-space normal in (u, v) (octahedral, see
    /// [`implicit::oct_decode`]): bubbles and blobbies.
    pub fn hit_carries_normal(&self, instance: u32) -> bool {
        let inst = &self.instances[instance as usize];
        matches!(self.blas[inst.blas].as_ref(), Blas::Sphere(SphereBlas { shape: PointsBlasShape::Bubbles(_) | PointsBlasShape::Blobby { .. }, .. }))
    }

    /// Centre of a sphere at a time (object space).
    pub fn sphere_center(&self, instance: u32, prim: u32, time: f32) -> Option<(Vec3, f32)> {
        let inst = &self.instances[instance as usize];
        match self.blas[inst.blas].as_ref() {
            Blas::Sphere(sb) => {
                let k = *sb.slot_of.get(prim as usize).filter(|&&k| k != u32::MAX)? as usize;
                let mut c = sb.centers[k];
                if let Some(v) = &sb.velocities {
                    c += v[k] * time;
                }
                Some((c, sb.radii[k]))
            }
            _ => None,
        }
    }
}

/// A ray against points' bounding spheres, by its closest approach to their centres, in single
/// precision with a margin for rounding: the cheap test before a primitive's own.
struct BoundingTest {
    o: Vec3,
    d: Vec3,
    inv_dd: f32,
    inv_len: f64,
    o_size: f32,
}

impl BoundingTest {
    fn new(o: Vec3, d: Vec3) -> BoundingTest {
        let dd = d.length_squared();
        BoundingTest { o, d, inv_dd: 1.0 / dd, inv_len: 1.0 / (dd as f64).sqrt(), o_size: o.abs().max_element() }
    }

    /// Where the ray passes nearest the centre `c` (its distance along the ray, and that point's
    /// offset from `c`), if the ray may cross the sphere of radius `r` about `c` within
    /// (t_lo, t_hi); None where it surely does not.
    #[inline]
    fn near(&self, c: Vec3, r: f32, t_lo: f64, t_hi: f64) -> Option<(f32, Vec3)> {
        let v = c - self.o;
        let tc = v.dot(self.d) * self.inv_dd;
        let p = self.d * tc - v;
        let r = r * 1.001 + 1e-6 * (v.abs().max_element() + self.o_size);
        let half = r as f64 * self.inv_len;
        (p.length_squared() <= r * r && (tc as f64 - half) < t_hi && (tc as f64 + half) > t_lo).then_some((tc, p))
    }
}

/// Kernels a blobby ray's segment gathers beyond those it already met. Each segment's traversal
/// visits the kernels already met again, so fewer segments of more kernels pay where kernels
/// overlap many times (`cargo bench -p tide-core --bench fx`: 24 is best at 20000 points, 128
/// at a million; 64 is within 10% of either).
const BLOBBY_SEGMENT: usize = 64;

/// The first crossing of a points set's blobby surface along o + t·d within (0, t_max):
/// (t, point index, octahedral normal).
///
/// The ray is swept in segments. Each segment's gathering traverses the BVH from where the sweep
/// stands and keeps the [`BLOBBY_SEGMENT`] kernels entering first; the segment ends where the next
/// one would enter, or earlier at the entry of a kernel's inner core (where that kernel alone
/// reaches T, so φ ≥ 0 there and a ray from outside has crossed the surface before). Every
/// kernel entering within a segment is then known and the sweep over it is exact; the kernels
/// still active carry over to the next segment. A ray meeting the surface early gathers little of
/// what lies behind, however many kernels overlap there; a ray from inside the water sweeps on
/// to its exit.
#[allow(clippy::too_many_arguments)]
fn blobby_hit(sb: &SphereBlas, a: &[Mat3], reach: &[f32], threshold: f32, o: Vec3A, d: Vec3A, t_max: f32, center: &impl Fn(usize) -> Vec3, prefetch: &impl Fn(usize)) -> Option<(f32, u32, f32, f32)> {
    let kernel = |k: usize| Kernel { center: center(k), a: a[k] };
    let (o3, d3): (Vec3, Vec3) = (o.into(), d.into());
    let core = 1.0 - threshold.cbrt();
    let t_end = t_max as f64;
    let bound = BoundingTest::new(o3, d3);
    let mut sweep = Sweep::new(threshold, 0.0);
    // the kernels entering in the segment, latest on top while gathering (one buffer for all
    // segments: sorted for the sweep, then cleared and made a heap again)
    let mut entering: std::collections::BinaryHeap<Entering> = std::collections::BinaryHeap::with_capacity(BLOBBY_SEGMENT + 1);
    let mut first = true;
    loop {
        let s = sweep.at();
        let mut e = t_end;
        let mut t_first = f64::INFINITY;
        // the traversal starts a little before s (boxes behind it are skipped)
        let shift = if first { 0.0 } else { s as f32 * (1.0 - 4.0 * f32::EPSILON) };
        sb.bvh.traverse_slots(
            o + d * shift,
            d,
            t_max - shift,
            |k, _| {
                // first the bounding sphere
                let c = center(k);
                let (tc, p) = bound.near(c, reach[k], s, e)?;
                let sp = Kernel { center: c, a: a[k] }.span_near(tc, p, d3, k)?;
                if sp.t1 <= s || sp.t0 >= e {
                    return None;
                }
                if sp.t0 < s {
                    // met by an earlier segment, or (first segment) reaching the ray's origin
                    if first {
                        sweep.enter(sp);
                    }
                    return None;
                }
                let mut cut = sp.entry(core).filter(|&tc| tc > s).map_or(e, |tc| tc.min(e));
                t_first = t_first.min(sp.t0);
                entering.push(Ordered(sp));
                if entering.len() > BLOBBY_SEGMENT {
                    // the first entry past the kept ones, never cutting kernels that enter together
                    // with the first (a segment always moves the sweep on)
                    let last = entering.peek().unwrap().0.t0;
                    if last > t_first {
                        cut = cut.min(last);
                    }
                }
                if cut < e {
                    e = cut;
                    while entering.peek().is_some_and(|x| x.0.t0 >= e) {
                        entering.pop();
                    }
                    if entering.is_empty() {
                        t_first = f64::INFINITY;
                    }
                    return Some((e - shift as f64) as f32 * (1.0 + 1e-6));
                }
                None
            },
            prefetch,
        );
        let mut sorted = std::mem::take(&mut entering).into_sorted_vec();
        first = false;
        if let Some(t) = sweep.advance(&sorted, e, 0.0) {
            let (n, k) = sweep.normal(o3 + d3 * t as f32, kernel);
            let (u, v) = implicit::oct_encode(n);
            return Some((t as f32, sb.bvh.ids()[k], u, v));
        }
        if e >= t_end {
            return None;
        }
        sorted.clear();
        entering = sorted.into();
    }
}

#[cfg(test)]
mod tests;
