//! The triangle BVH: a [`super::wide`] tree whose leaves are blocks of four triangles stored
//! SoA with their ids (one 4-lane Möller–Trumbore per block). The build's SAH costs a side in
//! blocks (a leaf of 1 to 4 triangles costs one block test).

use super::wide::{leaf_items, leaf_slot, prefetch_lines, Binary, PreRay, PrimRef, WideTree, F4, MAX_LEAF};
use glam::{Vec3, Vec3A};

/// Triangles per block.
pub(super) const BLOCK: usize = 4;

/// The triangle of each lane of a block made of `ids` (one to four): a short block repeats its
/// last triangle.
#[inline]
pub(super) fn block_ids(ids: &[u32]) -> [u32; BLOCK] {
    [0, 1, 2, 3].map(|l| ids[l.min(ids.len() - 1)])
}
const _: () = assert!(MAX_LEAF <= BLOCK * 4, "a leaf's blocks must fit its slot's count");

/// Four triangles' geometry, SoA: a vertex and two edges per lane.
#[derive(Clone, Copy)]
#[repr(C, align(16))]
pub(super) struct Tri4Geom {
    v0: [[f32; 4]; 3],
    e1: [[f32; 4]; 3],
    e2: [[f32; 4]; 3],
}

impl Tri4Geom {
    /// Lane i holds triangle `tris[i]` (vertices 0, 1, 2).
    pub(super) fn new(tris: [[Vec3A; 3]; 4]) -> Tri4Geom {
        let mut g = Tri4Geom { v0: [[0.0; 4]; 3], e1: [[0.0; 4]; 3], e2: [[0.0; 4]; 3] };
        for (lane, [v0, v1, v2]) in tris.into_iter().enumerate() {
            let (e1, e2) = (v1 - v0, v2 - v0);
            for a in 0..3 {
                g.v0[a][lane] = v0[a];
                g.e1[a][lane] = e1[a];
                g.e2[a][lane] = e2[a];
            }
        }
        g
    }

    /// Rows v0, e1, e2, each as x, y, z lanes.
    #[inline(always)]
    pub(super) fn load(&self) -> [[F4; 3]; 3] {
        let l = |r: &[[f32; 4]; 3]| [F4::load(&r[0]), F4::load(&r[1]), F4::load(&r[2])];
        [l(&self.v0), l(&self.e1), l(&self.e2)]
    }

    #[cfg(test)]
    fn bits(&self) -> impl Iterator<Item = u32> + '_ {
        self.v0.iter().chain(&self.e1).chain(&self.e2).flatten().map(|x| x.to_bits())
    }
}

/// Four triangles and the input index of each.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Tri4 {
    g: Tri4Geom,
    ids: [u32; 4],
}

pub struct TriBvh {
    tree: WideTree,
    blocks: Vec<Tri4>,
    pub bounds: (Vec3, Vec3),
}

/// A mesh's triangles as the build reads them: three indices per triangle into `positions`.
#[derive(Clone, Copy)]
pub struct TriMesh<'a> {
    pub positions: &'a [Vec3],
    pub indices: &'a [u32],
}

impl TriMesh<'_> {
    #[inline]
    fn len(&self) -> usize {
        self.indices.len() / 3
    }
    #[inline]
    pub(super) fn tri(&self, i: usize) -> [Vec3A; 3] {
        [0, 1, 2].map(|k| Vec3A::from(self.positions[self.indices[3 * i + k] as usize]))
    }
}

impl TriBvh {
    /// Builds over every triangle of `mesh`. The largest arrays live one at a time: the
    /// triangles' boxes while the binary tree is built, the output (allocated at its exact
    /// size) while the tree is folded into it.
    pub fn build(mesh: TriMesh) -> TriBvh {
        if mesh.len() == 0 {
            return TriBvh { tree: WideTree::empty(), blocks: vec![], bounds: (Vec3::ZERO, Vec3::ZERO) };
        }
        use rayon::prelude::*;
        let prims = (0..mesh.len())
            .into_par_iter()
            .map(|i| {
                let [v0, v1, v2] = mesh.tri(i);
                PrimRef::new(v0.min(v1).min(v2), v0.max(v1).max(v2), i as u32)
            })
            .collect();
        let bin = Binary::build(prims, |c| c.div_ceil(BLOCK as u32) as f32);
        let (tree, blocks) = bin.fold(
            |n| n.div_ceil(BLOCK),
            |ids, _, first, out| {
                for c in ids.chunks(BLOCK) {
                    let ids = block_ids(c);
                    out.push(Tri4 { g: Tri4Geom::new(ids.map(|i| mesh.tri(i as usize))), ids });
                }
                leaf_slot(first, ids.len().div_ceil(BLOCK))
            },
        );
        let bounds = tree.bounds;
        TriBvh { tree, blocks, bounds }
    }

    pub fn bytes(&self) -> usize {
        self.tree.bytes() + self.blocks.len() * std::mem::size_of::<Tri4>()
    }

    /// Closest hit with t in (0, t_max): (t, triangle, u, v), u and v the weights of vertices 1 and 2.
    #[inline]
    pub fn intersect(&self, o: Vec3A, d: Vec3A, t_max: f32) -> Option<(f32, u32, f32, f32)> {
        let ray = PreRay::new(o, d);
        nearest_in_blocks(
            &self.tree,
            &ray,
            t_max,
            |b, t_max| self.intersect_block(b, &ray, t_max).map(|(t, lane, u, v)| (t, self.blocks[b].ids[lane], u, v)),
            |first| prefetch_lines(self.blocks.as_ptr().wrapping_add(first) as *const u8, std::mem::size_of::<Tri4>()),
        )
        .map(into_triangle)
    }

    /// Nearest of a block's four triangles with t in (0, t_max), lanes tested in order.
    #[inline(always)]
    fn intersect_block(&self, b: usize, ray: &PreRay, t_max: f32) -> Option<(f32, usize, f32, f32)> {
        hit4(self.blocks[b].g.load(), ray, t_max)
    }
}

/// A hit's barycentric weights (u, v) of vertices 1 and 2, up to [`EDGE_SLACK`] past an edge,
/// moved onto the triangle.
#[inline]
pub(super) fn into_triangle((t, id, u, v): (f32, u32, f32, f32)) -> (f32, u32, f32, f32) {
    let (u, v) = (u.max(0.0), v.max(0.0));
    let over = (u + v - 1.0).max(0.0) * 0.5;
    (t, id, (u - over).max(0.0), (v - over).max(0.0))
}

/// The nearest hit (t, triangle, u, v) in (0, t_max) over the blocks of the leaves of `tree`
/// that the ray reaches: `block(b, t)` tests block b up to t; `prefetch(b)` starts the loads of a
/// leaf whose first block is b.
#[inline(always)]
pub(super) fn nearest_in_blocks(
    tree: &WideTree,
    ray: &PreRay,
    t_max: f32,
    block: impl Fn(usize, f32) -> Option<(f32, u32, f32, f32)>,
    prefetch: impl Fn(usize),
) -> Option<(f32, u32, f32, f32)> {
    let mut best = None;
    tree.traverse(
        ray,
        t_max,
        |slot, mut t_max| {
            let (first, count) = leaf_items(slot);
            for b in first..first + count {
                if let Some(h) = block(b, t_max) {
                    t_max = h.0;
                    best = Some(h);
                }
            }
            t_max
        },
        |slot| prefetch(leaf_items(slot).0),
    );
    best
}

/// How far past its edges, in barycentric terms, a triangle is hit (about 8 units in the last
/// place of 1): a ray through a shared edge meets at least one of its triangles.
const EDGE_SLACK: f32 = 1.0 / (1 << 20) as f32;

/// Möller–Trumbore on four triangles at once (rows v0, e1, e2 as from [`Tri4Geom::load`]): the
/// nearest hit in (0, t_max) as (t, lane, u, v), u and v the weights of vertices 1 and 2 (up
/// to [`EDGE_SLACK`] outside the triangle: [`into_triangle`] moves them onto it).
#[inline(always)]
pub(super) fn hit4([v0, e1, e2]: [[F4; 3]; 3], ray: &PreRay, t_max: f32) -> Option<(f32, usize, f32, f32)> {
    let cross = |a: [F4; 3], b: [F4; 3]| {
        [
            a[1].mul(b[2]).sub(a[2].mul(b[1])),
            a[2].mul(b[0]).sub(a[0].mul(b[2])),
            a[0].mul(b[1]).sub(a[1].mul(b[0])),
        ]
    };
    let dot = |a: [F4; 3], b: [F4; 3]| a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]));
    let p = cross(ray.d, e2);
    let det = dot(e1, p);
    let inv = F4::splat(1.0).div(det);
    let s = [ray.o[0].sub(v0[0]), ray.o[1].sub(v0[1]), ray.o[2].sub(v0[2])];
    let u = dot(s, p).mul(inv);
    let q = cross(s, e1);
    let v = dot(ray.d, q).mul(inv);
    let t = dot(e2, q).mul(inv);
    let zero = F4::splat(0.0);
    // the edge tests reach EDGE_SLACK past each edge: rounding puts a ray through a shared edge
    // a little outside one triangle or the other, often both (Möller–Trumbore is not
    // watertight), and light leaked through the cracks of closed surfaces
    let below = F4::splat(-EDGE_SLACK);
    let above = F4::splat(1.0 + EDGE_SLACK);
    // det = 0 or non-finite gives NaN or infinite u, v, t, which every test below rejects
    let mut mask = below.le(u) & below.le(v) & u.add(v).le(above) & zero.lt(t) & t.lt(F4::splat(t_max));
    if mask == 0 {
        return None;
    }
    let (ta, ua, va) = (t.to_array(), u.to_array(), v.to_array());
    let mut best: Option<(f32, usize, f32, f32)> = None;
    while mask != 0 {
        let i = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        if best.is_none_or(|b| ta[i] < b.0) {
            best = Some((ta[i], i, ua[i], va[i]));
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A bumpy grid of `n`×`n` quads sharing their vertices.
    fn grid(n: u32) -> (Vec<Vec3>, Vec<u32>) {
        let pos = (0..=n).flat_map(|j| (0..=n).map(move |i| Vec3::new(i as f32, ((i * 7 + j * 3) % 5) as f32 * 0.1, j as f32))).collect();
        let mut idx = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let a = j * (n + 1) + i;
                idx.extend([a, a + n + 1, a + 1, a + 1, a + n + 1, a + n + 2]);
            }
        }
        (pos, idx)
    }

    #[test]
    fn the_output_is_allocated_once_and_holds_every_triangle() {
        for n in [1, 2, 9, 40] {
            let (positions, indices) = grid(n);
            let bvh = TriBvh::build(TriMesh { positions: &positions, indices: &indices });
            assert!(bvh.tree.allocated_exactly(), "n = {n}");
            assert_eq!(bvh.blocks.len(), bvh.blocks.capacity(), "n = {n}");
            let mut ids: Vec<u32> = bvh.blocks.iter().flat_map(|b| b.ids).collect();
            ids.sort_unstable();
            ids.dedup();
            assert_eq!(ids, (0..2 * n * n).collect::<Vec<_>>(), "n = {n}");
            // straight down through the middle of each quad's second triangle
            for (k, (i, j)) in [(0, 0), (n - 1, n - 1), (n / 2, n / 3)].into_iter().enumerate() {
                let o = Vec3A::new(i as f32 + 0.75, 5.0, j as f32 + 0.75);
                let (t, tri, _, _) = bvh.intersect(o, Vec3A::NEG_Y, f32::INFINITY).unwrap_or_else(|| panic!("ray {k} missed"));
                assert_eq!(tri, 2 * (j * n + i) + 1, "ray {k}");
                let [v0, v1, v2] = TriMesh { positions: &positions, indices: &indices }.tri(tri as usize);
                let y = (v0.y + v1.y + v2.y) / 3.0;
                assert!((5.0 - t - y).abs() < 0.5, "ray {k}: t {t}");
            }
        }
    }

    /// Every bit of a build: tree and blocks.
    fn bits(bvh: &TriBvh) -> Vec<u32> {
        let mut v = bvh.tree.bits();
        for b in &bvh.blocks {
            v.extend(b.g.bits());
            v.extend(b.ids);
        }
        v
    }

    #[test]
    fn the_build_is_the_same_whatever_the_thread_count() {
        // 80 000 triangles: binned and folded in parallel at the top
        let (positions, indices) = grid(200);
        let mesh = TriMesh { positions: &positions, indices: &indices };
        let build = |threads| rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| TriBvh::build(mesh));
        let one = build(1);
        assert!(one.tree.allocated_exactly() && one.blocks.len() == one.blocks.capacity());
        let b1 = bits(&one);
        for threads in [2, 5] {
            assert!(b1 == bits(&build(threads)), "{threads} threads");
        }
        // and it is a BVH of the mesh: rays down through quads hit their triangles
        let n = 200;
        for (i, j) in [(0, 0), (199, 199), (17, 123), (150, 3), (99, 100)] {
            let o = Vec3A::new(i as f32 + 0.25, 5.0, j as f32 + 0.25);
            let (_, tri, _, _) = one.intersect(o, Vec3A::NEG_Y, f32::INFINITY).expect("hit");
            assert_eq!(tri, 2 * (j * n + i), "quad ({i}, {j})");
        }
    }
}

#[cfg(test)]
mod edge_tests {
    use super::*;

    /// Rays aimed exactly at the shared edges of closed fans of triangles (seven around a centre
    /// vertex, not planar) all hit one of them: with the plain Möller–Trumbore test about 5 % of
    /// them fell between the two (both barycentric tests rounded negative), so light leaked
    /// through the seams of closed zero-thickness surfaces. Hits are reported inside the
    /// triangle.
    #[test]
    fn a_ray_through_a_shared_edge_meets_one_of_its_triangles() {
        let (mut misses, mut total) = (0, 0);
        let mut rng = crate::testing::chi2::TestRng::new(3);
        for _ in 0..200 {
            let c = Vec3::new(rng.next_f32() * 3.0 - 1.5, rng.next_f32() * 3.0 - 1.5, -2.0 - rng.next_f32());
            let n = 7u32;
            let mut positions = vec![c];
            for k in 0..n {
                let a = k as f32 / n as f32 * std::f32::consts::TAU + rng.next_f32() * 0.3;
                positions.push(c + Vec3::new(a.cos() * (1.0 + rng.next_f32()), a.sin() * (1.0 + rng.next_f32()), rng.next_f32() * 0.5));
            }
            let indices: Vec<u32> = (0..n).flat_map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
            let bvh = TriBvh::build(TriMesh { positions: &positions, indices: &indices });
            for k in 0..n as usize {
                let (a, b) = (positions[0], positions[1 + k]);
                for j in 1..50 {
                    let target = a + (b - a) * (j as f32 / 50.0);
                    let o = Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 3.0);
                    total += 1;
                    match bvh.intersect(o.into(), (target - o).normalize().into(), f32::INFINITY) {
                        None => misses += 1,
                        Some((_, _, u, v)) => assert!(u >= 0.0 && v >= 0.0 && u + v <= 1.0 + 1e-6, "{u} {v}"),
                    }
                }
            }
        }
        assert_eq!(misses, 0, "{misses} of {total} rays through shared edges met no triangle");
    }
}
