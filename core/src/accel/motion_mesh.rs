//! Deforming meshes: triangles whose vertices move linearly between position keys. The same
//! eight-wide tree as static meshes ([`super::wide`]) over each triangle's bounds across all keys
//! (a vertex between two keys lies on the segment joining them, so the union of the key bounds
//! encloses the triangle at every time). Leaves are blocks of four triangles stored once per key
//! (vertices, SoA, a block's keys side by side); a ray blends its block's two keys
//! around its time and tests the four triangles at once with the watertight test ([`super::tribvh`]).
//! Static meshes never come here.

use super::tribvh::{block_ids, hit4, nearest_in_blocks, Tri4Geom, TriMesh, BLOCK};
use super::wide::{advise_huge_pages, leaf_slot, prefetch_lines, Binary, PreRay, PrimRef, WideTree, F4};
use crate::scene::MeshDesc;
use glam::{Vec3, Vec3A};
use rayon::prelude::*;

/// The BVH of one deforming mesh.
pub(super) struct MotionTriBlas {
    tree: WideTree,
    /// Per block, its four triangles' indices (a short block repeats its last one).
    ids: Vec<[u32; 4]>,
    /// Block b's geometry at key k is `geom[b * keys + k]`.
    geom: Vec<Tri4Geom>,
    times: Vec<f32>,
}

impl MotionTriBlas {
    /// None when the mesh has no triangles. `mesh.motion` must hold validated keys.
    pub(super) fn build(mesh: &MeshDesc) -> Option<MotionTriBlas> {
        let mo = mesh.motion.as_ref()?;
        let ntri = mesh.indices.len() / 3;
        if ntri == 0 {
            return None;
        }
        let keys = &mo.positions;
        let tri = |key: &[Vec3], i: usize| TriMesh { positions: key, indices: &mesh.indices }.tri(i);
        let prims: Vec<PrimRef> = (0..ntri)
            .into_par_iter()
            .map(|i| {
                let (mut lo, mut hi) = (Vec3A::INFINITY, Vec3A::NEG_INFINITY);
                for key in keys {
                    for v in tri(key, i) {
                        (lo, hi) = (lo.min(v), hi.max(v));
                    }
                }
                PrimRef::new(lo, hi, i as u32)
            })
            .collect();
        let bin = Binary::build(prims, |c| c.div_ceil(BLOCK as u32) as f32);
        let (tree, ids) = bin.fold(
            |n| n.div_ceil(BLOCK),
            |ids, _, first, out| {
                for c in ids.chunks(BLOCK) {
                    out.push(block_ids(c));
                }
                leaf_slot(first, ids.len().div_ceil(BLOCK))
            },
        );
        let nk = keys.len();
        let mut geom = Vec::with_capacity(ids.len() * nk);
        let _ = advise_huge_pages(&mut geom);
        (0..ids.len() * nk)
            .into_par_iter()
            .map(|j| Tri4Geom::new(ids[j / nk].map(|i| tri(&keys[j % nk], i as usize))))
            .collect_into_vec(&mut geom);
        Some(MotionTriBlas { tree, ids, geom, times: mo.times.clone() })
    }

    pub(super) fn bytes(&self) -> usize {
        self.tree.bytes() + self.ids.len() * 16 + self.geom.len() * std::mem::size_of::<Tri4Geom>()
    }

    /// Closest hit (t, triangle, u, v) in (0, t_max) of the mesh as it stands at `time` (held
    /// at the first / last key outside them).
    pub(super) fn intersect(&self, o: Vec3A, d: Vec3A, t_max: f32, time: f32) -> Option<(f32, u32, f32, f32)> {
        let (k, w) = crate::scene::locate_key(&self.times, time);
        let nk = self.times.len();
        let wl = F4::splat(w);
        let ray = PreRay::new(o, d);
        nearest_in_blocks(
            &self.tree,
            &ray,
            t_max,
            |b, t_max| {
                let (a, z) = (self.geom[b * nk + k].load(), self.geom[b * nk + k + 1].load());
                // a + (z - a) w, row by row: the vertices of each triangle at `time` (a vertex two
                // triangles share is the same numbers in both)
                let rows = [0, 1, 2].map(|r| [0, 1, 2].map(|c| a[r][c].add(z[r][c].sub(a[r][c]).mul(wl))));
                hit4(rows, &ray, t_max).map(|(t, lane, u, v)| (t, self.ids[b][lane], u, v))
            },
            |first| prefetch_lines(self.geom.as_ptr().wrapping_add(first * nk + k) as *const u8, 2 * std::mem::size_of::<Tri4Geom>()),
        )
        .map(super::tribvh::into_triangle)
    }

    /// Bounds over all keys.
    pub(super) fn bounds(&self) -> (Vec3, Vec3) {
        self.tree.bounds
    }
}
