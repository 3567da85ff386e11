//! The triangle BVH: a [`super::wide`] tree whose leaves are blocks of four triangles stored
//! SoA with their ids (one 4-lane watertight test per block). The build's SAH costs a side in
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

/// Four triangles' geometry, SoA: the three vertices of each lane, as the mesh gives them (so
/// that triangles sharing an edge see the same numbers for it).
#[derive(Clone, Copy)]
#[repr(C, align(16))]
pub(super) struct Tri4Geom {
    v: [[[f32; 4]; 3]; 3],
}

impl Tri4Geom {
    /// Lane i holds triangle `tris[i]` (vertices 0, 1, 2).
    pub(super) fn new(tris: [[Vec3A; 3]; 4]) -> Tri4Geom {
        let mut g = Tri4Geom { v: [[[0.0; 4]; 3]; 3] };
        for (lane, tri) in tris.into_iter().enumerate() {
            for (k, vk) in tri.into_iter().enumerate() {
                for a in 0..3 {
                    g.v[k][a][lane] = vk[a];
                }
            }
        }
        g
    }

    /// Rows v0, v1, v2, each as x, y, z lanes.
    #[inline(always)]
    pub(super) fn load(&self) -> [[F4; 3]; 3] {
        self.v.map(|r| [F4::load(&r[0]), F4::load(&r[1]), F4::load(&r[2])])
    }

    #[cfg(test)]
    fn bits(&self) -> impl Iterator<Item = u32> + '_ {
        self.v.iter().flatten().flatten().map(|x| x.to_bits())
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

/// A hit's barycentric weights (u, v) of vertices 1 and 2, rounded a little past an edge,
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

/// The watertight ray–triangle inside test (Woop, Benthin and Wald 2013, "Watertight
/// ray/triangle intersection"), t from the triangle's plane, on four triangles at once (rows
/// v0, v1, v2 as from [`Tri4Geom::load`]): the nearest hit in (0, t_max) as (t, lane, u, v), u
/// and v the weights of vertices 1 and 2.
///
/// The vertices are taken relative to the ray's origin into the ray's sheared frame (its
/// direction along +z, [`PreRay`]), where the three edge functions are 2-D cross products of
/// the vertices. Two triangles sharing an edge compute that edge's function from the same
/// numbers with the operands swapped, so one gets exactly the negation of the other: a ray
/// through the edge is inside at least one of them, however far it comes from and however
/// small the triangles are (Möller–Trumbore's rounding let rays slip between them).
#[inline(always)]
pub(super) fn hit4([v0, v1, v2]: [[F4; 3]; 3], ray: &PreRay, t_max: f32) -> Option<(f32, usize, f32, f32)> {
    let [kx, ky, kz] = ray.axes;
    let [sx, sy] = ray.shear;
    // a vertex relative to the origin, sheared: (x, y) in the plane across the ray
    let rel = |v: [F4; 3]| [v[0].sub(ray.o[0]), v[1].sub(ray.o[1]), v[2].sub(ray.o[2])];
    let (pa, pb, pc) = (rel(v0), rel(v1), rel(v2));
    let frame = |p: [F4; 3]| (p[kx].sub(sx.mul(p[kz])), p[ky].sub(sy.mul(p[kz])));
    let (ax, ay) = frame(pa);
    let (bx, by) = frame(pb);
    let (cx, cy) = frame(pc);
    // the edge functions opposite each vertex (weights of v0, v1, v2 times det)
    let e0 = cx.mul(by).sub(cy.mul(bx));
    let e1 = ax.mul(cy).sub(ay.mul(cx));
    let e2 = bx.mul(ay).sub(by.mul(ax));
    let zero = F4::splat(0.0);
    // inside: no edge function of either sign against another (zero counts as both)
    let (n0, n1, n2) = (e0.lt(zero), e1.lt(zero), e2.lt(zero));
    let (p0, p1, p2) = (zero.lt(e0), zero.lt(e1), zero.lt(e2));
    let mut mask = !((n0 | n1 | n2) & (p0 | p1 | p2)) & 0xf;
    if mask == 0 {
        return None;
    }
    // An edge function that rounds to zero is taken again in double precision, where the
    // products of the frame's floats are exact and the difference rounds once, so its sign is
    // the true one (still the exact negation of the neighbour's): a ray just outside an edge
    // is not let in by rounding, and one through it stays in one triangle of the two.
    let on_edge = mask & !((n0 & n1 & n2) | (p0 & p1 & p2));
    let mut exact = [None; 4];
    if on_edge != 0 {
        let [ax, ay, bx, by, cx, cy] = [ax, ay, bx, by, cx, cy].map(F4::to_array);
        let mut lanes = on_edge;
        while lanes != 0 {
            let i = lanes.trailing_zeros() as usize;
            lanes &= lanes - 1;
            let [ax, ay, bx, by, cx, cy] = [ax[i], ay[i], bx[i], by[i], cx[i], cy[i]].map(f64::from);
            let f = [cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax];
            if f.iter().any(|&e| e < 0.0) && f.iter().any(|&e| e > 0.0) {
                mask &= !(1 << i);
            } else {
                let det = f[0] + f[1] + f[2];
                exact[i] = Some(((f[1] / det) as f32, (f[2] / det) as f32));
            }
        }
        if mask == 0 {
            return None;
        }
    }
    // t from the plane of the triangle in the scene's own axes, (v0 − o)·n / (d·n): exact
    // where the plane is (an axis-aligned wall or floor), so a ray leaving it from the origin
    // offset past its hit point's error does not meet it again; in the sheared frame the far
    // vertices' coordinates would mix into it. A ray along the plane (d·n = 0) has t infinite
    // or NaN, which the t tests reject.
    let cross = |a: [F4; 3], b: [F4; 3]| {
        [
            a[1].mul(b[2]).sub(a[2].mul(b[1])),
            a[2].mul(b[0]).sub(a[0].mul(b[2])),
            a[0].mul(b[1]).sub(a[1].mul(b[0])),
        ]
    };
    let dot = |a: [F4; 3], b: [F4; 3]| a[0].mul(b[0]).add(a[1].mul(b[1])).add(a[2].mul(b[2]));
    let edge = |a: [F4; 3], b: [F4; 3]| [b[0].sub(a[0]), b[1].sub(a[1]), b[2].sub(a[2])];
    let n = cross(edge(v0, v1), edge(v0, v2));
    let t = dot(pa, n).div(dot(ray.d, n));
    mask &= zero.lt(t) & t.lt(F4::splat(t_max));
    if mask == 0 {
        return None;
    }
    let inv = F4::splat(1.0).div(e0.add(e1).add(e2));
    let (ta, ua, va) = (t.to_array(), e1.mul(inv).to_array(), e2.mul(inv).to_array());
    let mut best: Option<(f32, usize, f32, f32)> = None;
    while mask != 0 {
        let i = mask.trailing_zeros() as usize;
        mask &= mask - 1;
        if best.is_none_or(|b| ta[i] < b.0) {
            let (u, v) = exact[i].unwrap_or((ua[i], va[i]));
            best = Some((ta[i], i, u, v));
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

    /// Rays aimed at the shared edges of fans of triangles
    /// (seven around a centre vertex, not planar), each of `size`, at `offset` from the origin,
    /// the rays starting about `distance` away: (rays that met no triangle, rays).
    fn edge_misses(size: f32, offset: Vec3, distance: f32, seed: u64) -> (u32, u32) {
        let (mut misses, mut total) = (0, 0);
        let mut rng = crate::testing::chi2::TestRng::new(seed);
        for _ in 0..200 {
            let c = offset + Vec3::new(rng.next_f32() * 3.0 - 1.5, rng.next_f32() * 3.0 - 1.5, -2.0 - rng.next_f32()) * size;
            let n = 7u32;
            let mut positions = vec![c];
            for k in 0..n {
                let a = k as f32 / n as f32 * std::f32::consts::TAU + rng.next_f32() * 0.3;
                positions.push(c + Vec3::new(a.cos() * (1.0 + rng.next_f32()), a.sin() * (1.0 + rng.next_f32()), rng.next_f32() * 0.5) * size);
            }
            let indices: Vec<u32> = (0..n).flat_map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
            let bvh = TriBvh::build(TriMesh { positions: &positions, indices: &indices });
            for k in 0..n as usize {
                let (a, b) = (positions[0], positions[1 + k]);
                for j in 1..50 {
                    let target = a + (b - a) * (j as f32 / 50.0);
                    let o = c + Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, 1.0).normalize() * distance;
                    total += 1;
                    match bvh.intersect(o.into(), (target - o).normalize().into(), f32::INFINITY) {
                        None => misses += 1,
                        Some((_, _, u, v)) => assert!(u >= 0.0 && v >= 0.0 && u + v <= 1.0 + 1e-6, "{u} {v}"),
                    }
                }
            }
        }
        (misses, total)
    }

    /// Rays through the shared edges of closed fans all hit one of their
    /// triangles, from near (with the plain Möller–Trumbore test about 5 % of them fell between
    /// two, both barycentric tests rounding negative), and from 10⁵ times the triangles' size
    /// away or off a mesh 5 km from the origin (where Möller–Trumbore, even let 2⁻²⁰ past each
    /// edge, still let rays through): light does not leak through the seams of closed
    /// zero-thickness surfaces, however far the camera. Hits are reported inside the triangle.
    #[test]
    fn a_ray_through_a_shared_edge_meets_one_of_its_triangles() {
        for (size, offset, distance) in [(1.0, Vec3::ZERO, 5.0), (1e-3, Vec3::ZERO, 100.0), (0.05, Vec3::new(5000.0, 20.0, -3000.0), 10.0)] {
            let (misses, total) = edge_misses(size, offset, distance, 3);
            assert_eq!(misses, 0, "size {size} at {offset} from {distance}: {misses} of {total} rays through shared edges met no triangle");
        }
    }

    /// A ray whose edge function rounds to zero in single precision, just outside one triangle
    /// of a shared edge: it meets the other alone, with weights from the exact edge functions.
    #[test]
    fn an_edge_function_rounding_to_zero_is_taken_again_exactly() {
        // straight up +z from the origin, so the frame's (x, y) are the vertices' own; edge b–c:
        // (p s − r q) is 2⁻⁴⁶ while p s and r q round to the same float
        let e = |k: i32| 2f32.powi(k);
        let b = Vec3::new(-(1.0 + e(-23)), -(1.0 + e(-22)), 1.0);
        let c = Vec3::new(1.0, 1.0 + e(-23), 1.0);
        let f32_edge = c.x * b.y - c.y * b.x;
        let exact = c.x as f64 * b.y as f64 - c.y as f64 * b.x as f64;
        assert_eq!(f32_edge, 0.0);
        assert_eq!(exact.abs(), e(-46) as f64);
        // a and d on either side of b–c; the triangles share the edge, one each way round
        let (a, d) = (Vec3::new(-1.0, 1.0, 1.0), Vec3::new(1.0, -1.0, 1.0));
        let positions = vec![a, b, c, d];
        let indices = vec![0, 1, 2, 2, 1, 3];
        let bvh = TriBvh::build(TriMesh { positions: &positions, indices: &indices });
        let (t, tri, u, v) = bvh.intersect(Vec3A::ZERO, Vec3A::Z, f32::INFINITY).expect("a hit");
        // the origin lies on d's side of b–c: (b − c) × (o − c) has the sign of (d − c) × ...
        let side = |p: Vec3| ((b.x - c.x) as f64) * ((p.y - c.y) as f64) - ((b.y - c.y) as f64) * ((p.x - c.x) as f64);
        let origin_side = -(c.x as f64) * (b.y - c.y) as f64 + (c.y as f64) * (b.x - c.x) as f64;
        let want = if origin_side.signum() == side(d).signum() { 1 } else { 0 };
        assert!(origin_side != 0.0 && side(a).signum() != side(d).signum());
        assert_eq!(tri, want, "the ray met the triangle it passes outside of");
        assert_eq!(t, 1.0);
        // on the edge to within 2⁻⁴⁶: the weight of the vertex off it is (almost) zero, the
        // others about a half each
        let w = [1.0 - u - v, u, v];
        let off = if want == 0 { w[0] } else { w[2] };
        assert!(off.abs() < 1e-6 && off >= 0.0, "{w:?}");
    }
}
