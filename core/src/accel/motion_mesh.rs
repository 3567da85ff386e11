//! Deforming meshes: triangles whose vertices move linearly between position keys. One
//! obvhs `CwBvh` over each triangle's bounds across all keys (a vertex between two keys lies
//! on the segment joining them, so the union of the key bounds encloses the triangle at every
//! time); a ray interpolates each candidate triangle to its own time and tests it with
//! Möller–Trumbore. Static meshes never come here (see `tribvh.rs`).

use super::{bvh_ray, pad_single};
use crate::scene::MeshDesc;
use glam::{Vec3, Vec3A};
use obvhs::{
    aabb::Aabb,
    cwbvh::{builder::build_cwbvh, CwBvh},
    ray::RayHit,
    Boundable, BvhBuildParams,
};
use std::time::Duration;

#[derive(Clone, Copy)]
struct TriBound(Aabb);

impl Boundable for TriBound {
    fn aabb(&self) -> Aabb {
        self.0
    }
}

/// The BVH of one deforming mesh.
pub(super) struct MotionTriBlas {
    pub(super) bvh: CwBvh,
    tris: Vec<[u32; 3]>,
    times: Vec<f32>,
    /// Positions per key.
    keys: Vec<Vec<Vec3A>>,
}

/// Möller–Trumbore; returns (t, u, v) with u, v the weights of vertices 1 and 2.
#[inline(always)]
pub(super) fn intersect_triangle(v0: Vec3A, v1: Vec3A, v2: Vec3A, o: Vec3A, d: Vec3A, t_max: f32) -> Option<(f32, f32, f32)> {
    let e1 = v1 - v0;
    let e2 = v2 - v0;
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let inv = 1.0 / det;
    let s = o - v0;
    let u = s.dot(p) * inv;
    if !(0.0..=1.0).contains(&u) {
        return None;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return None;
    }
    let t = e2.dot(q) * inv;
    if t > 0.0 && t < t_max {
        Some((t, u, v))
    } else {
        None
    }
}

impl MotionTriBlas {
    /// None when the mesh has no triangles. `mesh.motion` must hold validated keys.
    pub(super) fn build(mesh: &MeshDesc) -> Option<MotionTriBlas> {
        let mo = mesh.motion.as_ref()?;
        let tris: Vec<[u32; 3]> = mesh.indices.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
        if tris.is_empty() {
            return None;
        }
        let keys: Vec<Vec<Vec3A>> = mo.positions.iter().map(|k| k.iter().map(|&p| Vec3A::from(p)).collect()).collect();
        let mut bounds: Vec<TriBound> = tris
            .iter()
            .map(|t| {
                let mut bb = Aabb::empty();
                for k in &keys {
                    for &i in t {
                        bb.extend(k[i as usize]);
                    }
                }
                TriBound(bb)
            })
            .collect();
        pad_single(&mut bounds);
        let bvh = build_cwbvh(&bounds, BvhBuildParams::medium_build(), &mut Duration::default());
        Some(MotionTriBlas { bvh, tris, times: mo.times.clone(), keys })
    }

    pub(super) fn bytes(&self) -> usize {
        self.bvh.nodes.len() * 80 + self.bvh.primitive_indices.len() * 4 + self.tris.len() * 12 + self.keys.iter().map(|k| k.len() * 16).sum::<usize>()
    }

    /// Key segment and weight of the later key at `time` (held outside the keys).
    #[inline]
    fn locate(&self, time: f32) -> (usize, f32) {
        crate::scene::locate_key(&self.times, time)
    }

    /// Closest hit (t, triangle, u, v) in (0, t_max) of the mesh as it stands at `time`.
    pub(super) fn intersect(&self, o: Vec3A, d: Vec3A, t_max: f32, time: f32) -> Option<(f32, u32, f32, f32)> {
        let (k, w) = self.locate(time);
        let (a, b) = (&self.keys[k], &self.keys[k + 1]);
        let at = |i: u32| a[i as usize].lerp(b[i as usize], w);
        let mut best = None;
        let r = bvh_ray(o, d, t_max);
        let mut rh = RayHit::none();
        self.bvh.ray_traverse(r, &mut rh, |r, id| {
            let ti = self.bvh.primitive_indices[id] as usize % self.tris.len();
            let [i0, i1, i2] = self.tris[ti];
            match intersect_triangle(at(i0), at(i1), at(i2), o, d, r.tmax) {
                Some((t, u, v)) => {
                    best = Some((t, ti as u32, u, v));
                    t
                }
                None => f32::INFINITY,
            }
        });
        best
    }

    /// Bounds over all keys.
    pub(super) fn bounds(&self) -> (Vec3, Vec3) {
        (self.bvh.total_aabb.min.into(), self.bvh.total_aabb.max.into())
    }
}
