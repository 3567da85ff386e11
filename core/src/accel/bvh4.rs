//! The triangle BVH that rays spend their time in: four-wide nodes with full-precision child
//! boxes in SoA layout (one 4-lane box test per node), and leaves of four triangles stored
//! SoA (one 4-lane Möller–Trumbore per leaf block). The tree is a binary BVH built by obvhs
//! (PLOC, reinsertion, SAH leaf collapse) folded into four-wide nodes: each node takes the two
//! children of a binary node and keeps opening its largest inner child until it has four.

use glam::{Vec3, Vec3A};
use obvhs::{bvh2::builder::build_bvh2_from_tris, bvh2::Bvh2, triangle::Triangle, BvhBuildParams};
use std::time::Duration;

/// Four f32 lanes: SSE on x86-64, plain arrays elsewhere (same results lane for lane: min/max
/// return the second operand when either is NaN, like `minps`/`maxps`).
#[cfg(target_arch = "x86_64")]
mod lanes {
    use std::arch::x86_64::*;
    #[derive(Clone, Copy)]
    pub struct F4(__m128);
    impl F4 {
        #[inline(always)]
        pub fn splat(x: f32) -> F4 {
            unsafe { F4(_mm_set1_ps(x)) }
        }
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            unsafe { F4(_mm_loadu_ps(a.as_ptr())) }
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            let mut a = [0.0; 4];
            unsafe { _mm_storeu_ps(a.as_mut_ptr(), self.0) };
            a
        }
        #[inline(always)]
        pub fn add(self, b: F4) -> F4 {
            unsafe { F4(_mm_add_ps(self.0, b.0)) }
        }
        #[inline(always)]
        pub fn sub(self, b: F4) -> F4 {
            unsafe { F4(_mm_sub_ps(self.0, b.0)) }
        }
        #[inline(always)]
        pub fn mul(self, b: F4) -> F4 {
            unsafe { F4(_mm_mul_ps(self.0, b.0)) }
        }
        #[inline(always)]
        pub fn div(self, b: F4) -> F4 {
            unsafe { F4(_mm_div_ps(self.0, b.0)) }
        }
        #[inline(always)]
        pub fn min(self, b: F4) -> F4 {
            unsafe { F4(_mm_min_ps(self.0, b.0)) }
        }
        #[inline(always)]
        pub fn max(self, b: F4) -> F4 {
            unsafe { F4(_mm_max_ps(self.0, b.0)) }
        }
        /// Bit i set where lane i of self <= b.
        #[inline(always)]
        pub fn le(self, b: F4) -> u32 {
            unsafe { _mm_movemask_ps(_mm_cmple_ps(self.0, b.0)) as u32 }
        }
        /// Bit i set where lane i of self < b.
        #[inline(always)]
        pub fn lt(self, b: F4) -> u32 {
            unsafe { _mm_movemask_ps(_mm_cmplt_ps(self.0, b.0)) as u32 }
        }
    }
}

#[cfg(not(target_arch = "x86_64"))]
mod lanes {
    #[derive(Clone, Copy)]
    pub struct F4([f32; 4]);
    macro_rules! lanewise {
        ($a:expr, $b:expr, |$x:ident, $y:ident| $e:expr) => {{
            let (a, b) = ($a.0, $b.0);
            F4([0, 1, 2, 3].map(|i| {
                let ($x, $y) = (a[i], b[i]);
                $e
            }))
        }};
    }
    impl F4 {
        #[inline(always)]
        pub fn splat(x: f32) -> F4 {
            F4([x; 4])
        }
        #[inline(always)]
        pub fn load(a: &[f32; 4]) -> F4 {
            F4(*a)
        }
        #[inline(always)]
        pub fn to_array(self) -> [f32; 4] {
            self.0
        }
        #[inline(always)]
        pub fn add(self, b: F4) -> F4 {
            lanewise!(self, b, |x, y| x + y)
        }
        #[inline(always)]
        pub fn sub(self, b: F4) -> F4 {
            lanewise!(self, b, |x, y| x - y)
        }
        #[inline(always)]
        pub fn mul(self, b: F4) -> F4 {
            lanewise!(self, b, |x, y| x * y)
        }
        #[inline(always)]
        pub fn div(self, b: F4) -> F4 {
            lanewise!(self, b, |x, y| x / y)
        }
        #[inline(always)]
        pub fn min(self, b: F4) -> F4 {
            lanewise!(self, b, |x, y| if x < y { x } else { y })
        }
        #[inline(always)]
        pub fn max(self, b: F4) -> F4 {
            lanewise!(self, b, |x, y| if x > y { x } else { y })
        }
        #[inline(always)]
        pub fn le(self, b: F4) -> u32 {
            (0..4).map(|i| ((self.0[i] <= b.0[i]) as u32) << i).sum()
        }
        #[inline(always)]
        pub fn lt(self, b: F4) -> u32 {
            (0..4).map(|i| ((self.0[i] < b.0[i]) as u32) << i).sum()
        }
    }
}

use lanes::F4;

/// Child slot tags: leaves carry this bit, their first block in the low 28 bits and the block
/// count minus one in bits 28..31.
const LEAF: u32 = 1 << 31;
const EMPTY: u32 = u32::MAX;
/// Bvh2 subtrees with at most this many triangles become one leaf block.
const BLOCK: usize = 4;

/// Children per node.
const W: usize = 8;

/// W child boxes, SoA: rows are min x, max x, min y, max y, min z, max z.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    b: [[f32; W]; 6],
    child: [u32; W],
}

/// Four triangles, SoA: a vertex and two edges per lane, and the input index of each.
#[derive(Clone, Copy)]
#[repr(C, align(32))]
struct Tri4 {
    v0: [[f32; 4]; 3],
    e1: [[f32; 4]; 3],
    e2: [[f32; 4]; 3],
    ids: [u32; 4],
}

pub struct TriBvh4 {
    nodes: Vec<Node>,
    blocks: Vec<Tri4>,
    /// Root child slot: an inner node index, a leaf, or EMPTY.
    root: u32,
    /// Longest root-to-leaf path in nodes, which bounds the traversal stack.
    depth: usize,
    pub bounds: (Vec3, Vec3),
}

struct Builder<'a> {
    bvh2: &'a Bvh2,
    tris: &'a [Triangle],
    counts: Vec<u32>,
    nodes: Vec<Node>,
    blocks: Vec<Tri4>,
}

impl Builder<'_> {
    /// Triangle count under each Bvh2 node (children always follow parents in obvhs' layout? not
    /// assumed: computed by explicit post-order).
    fn count(&mut self, root: usize) {
        let mut order = vec![root];
        let mut i = 0;
        while i < order.len() {
            let n = &self.bvh2.nodes[order[i]];
            if n.prim_count == 0 {
                order.push(n.first_index as usize);
                order.push(n.first_index as usize + 1);
            }
            i += 1;
        }
        for &k in order.iter().rev() {
            let n = &self.bvh2.nodes[k];
            self.counts[k] = if n.prim_count == 0 {
                self.counts[n.first_index as usize] + self.counts[n.first_index as usize + 1]
            } else {
                n.prim_count
            };
        }
    }

    fn gather(&self, k: usize, out: &mut Vec<u32>) {
        let n = &self.bvh2.nodes[k];
        if n.prim_count == 0 {
            self.gather(n.first_index as usize, out);
            self.gather(n.first_index as usize + 1, out);
        } else {
            let f = n.first_index as usize;
            out.extend_from_slice(&self.bvh2.primitive_indices[f..f + n.prim_count as usize]);
        }
    }

    fn leaf(&mut self, k: usize) -> u32 {
        let mut prims = Vec::with_capacity(BLOCK);
        self.gather(k, &mut prims);
        let first = self.blocks.len() as u32;
        let nblocks = prims.len().div_ceil(BLOCK);
        for c in prims.chunks(BLOCK) {
            let mut blk = Tri4 { v0: [[0.0; 4]; 3], e1: [[0.0; 4]; 3], e2: [[0.0; 4]; 3], ids: [0; 4] };
            for lane in 0..4 {
                // short blocks repeat their last triangle: a duplicate never wins a strict `<`
                let id = c[lane.min(c.len() - 1)];
                let t = &self.tris[id as usize];
                let (e1, e2) = (t.v1 - t.v0, t.v2 - t.v0);
                for a in 0..3 {
                    blk.v0[a][lane] = t.v0[a];
                    blk.e1[a][lane] = e1[a];
                    blk.e2[a][lane] = e2[a];
                }
                blk.ids[lane] = id;
            }
            self.blocks.push(blk);
        }
        LEAF | ((nblocks as u32 - 1) << 28) | first
    }

    fn area(&self, k: usize) -> f32 {
        self.bvh2.nodes[k].aabb.half_area()
    }

    fn is_leaf(&self, k: usize) -> bool {
        self.bvh2.nodes[k].prim_count != 0 || self.counts[k] as usize <= BLOCK
    }

    /// Makes the child slot for Bvh2 node `k`; returns the slot and the depth below it.
    fn slot(&mut self, k: usize) -> (u32, usize) {
        if self.is_leaf(k) {
            return (self.leaf(k), 0);
        }
        let n = &self.bvh2.nodes[k];
        let mut kids = vec![n.first_index as usize, n.first_index as usize + 1];
        while kids.len() < W {
            let open = (0..kids.len())
                .filter(|&i| !self.is_leaf(kids[i]))
                .max_by(|&a, &b| self.area(kids[a]).total_cmp(&self.area(kids[b])));
            let Some(i) = open else { break };
            let c = self.bvh2.nodes[kids[i]].first_index as usize;
            kids[i] = c;
            kids.insert(i + 1, c + 1);
        }
        let me = self.nodes.len();
        let (inf, ninf) = ([f32::INFINITY; W], [f32::NEG_INFINITY; W]);
        self.nodes.push(Node { b: [inf, ninf, inf, ninf, inf, ninf], child: [EMPTY; W] });
        let mut depth = 0;
        for (lane, &c) in kids.iter().enumerate() {
            let bb = self.bvh2.nodes[c].aabb;
            let (s, d) = self.slot(c);
            depth = depth.max(d);
            let node = &mut self.nodes[me];
            for a in 0..3 {
                node.b[2 * a][lane] = bb.min[a];
                node.b[2 * a + 1][lane] = bb.max[a];
            }
            node.child[lane] = s;
        }
        (me as u32, depth + 1)
    }
}

/// A ray prepared for traversal.
struct PreRay {
    o: [F4; 3],
    d: [F4; 3],
    inv: [F4; 3],
    /// Row offsets of the near and far planes per axis (0 or 1, by the direction's sign).
    near: [usize; 3],
}

impl TriBvh4 {
    pub fn build(tris: &[Triangle], params: BvhBuildParams) -> TriBvh4 {
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        for t in tris {
            for v in [t.v0, t.v1, t.v2] {
                lo = lo.min(v.into());
                hi = hi.max(v.into());
            }
        }
        if tris.is_empty() {
            return TriBvh4 { nodes: vec![], blocks: vec![], root: EMPTY, depth: 0, bounds: (Vec3::ZERO, Vec3::ZERO) };
        }
        let params = BvhBuildParams { max_prims_per_leaf: BLOCK as u32, ..params };
        let bvh2 = build_bvh2_from_tris(tris, params, &mut Duration::default());
        let mut b = Builder { bvh2: &bvh2, tris, counts: vec![0; bvh2.nodes.len()], nodes: vec![], blocks: vec![] };
        b.count(0);
        let (root, depth) = b.slot(0);
        if std::env::var("TIDE_BVH_STATS").is_ok() { eprintln!("nodes {} blocks {} depth {} bvh2 nodes {}", b.nodes.len(), b.blocks.len(), depth, bvh2.nodes.len()); }
        TriBvh4 { nodes: b.nodes, blocks: b.blocks, root, depth, bounds: (lo, hi) }
    }

    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>() + self.blocks.len() * std::mem::size_of::<Tri4>()
    }

    /// Closest hit with t in (0, t_max): (t, triangle, u, v), u and v the weights of vertices 1 and 2.
    #[inline]
    pub fn intersect(&self, o: Vec3A, d: Vec3A, t_max: f32) -> Option<(f32, u32, f32, f32)> {
        if self.root == EMPTY {
            return None;
        }
        // -0 becomes +0 so the sign test and the reciprocal agree.
        let d = d + Vec3A::ZERO;
        let inv = Vec3A::ONE / d;
        let ray = PreRay {
            o: [F4::splat(o.x), F4::splat(o.y), F4::splat(o.z)],
            d: [F4::splat(d.x), F4::splat(d.y), F4::splat(d.z)],
            inv: [F4::splat(inv.x), F4::splat(inv.y), F4::splat(inv.z)],
            near: [(d.x < 0.0) as usize, (d.y < 0.0) as usize, (d.z < 0.0) as usize],
        };
        // Each node visited pushes at most W - 1 siblings.
        const FIXED: usize = (W - 1) * 24 + 1;
        if self.depth <= 24 {
            let mut stack = [(0u32, 0f32); FIXED];
            self.traverse(&ray, t_max, &mut stack)
        } else {
            let mut stack = vec![(0u32, 0f32); (W - 1) * self.depth + 1];
            self.traverse(&ray, t_max, &mut stack)
        }
    }

    #[inline(always)]
    fn traverse(&self, ray: &PreRay, t_max: f32, stack: &mut [(u32, f32)]) -> Option<(f32, u32, f32, f32)> {
        let mut best_t = t_max;
        let mut best: Option<(f32, u32, f32, f32)> = None;
        let mut sp = 0usize;
        let mut cur = self.root;
        let [nx, ny, nz] = ray.near;
        loop {
            if cur & LEAF == 0 {
                let n = &self.nodes[cur as usize];
                let mut mask = 0u32;
                let mut tn = [0f32; W];
                for h in 0..W / 4 {
                    let row = |r: usize| F4::load(n.b[r][4 * h..4 * h + 4].try_into().unwrap());
                    let tx0 = row(nx).sub(ray.o[0]).mul(ray.inv[0]);
                    let tx1 = row(1 - nx).sub(ray.o[0]).mul(ray.inv[0]);
                    let ty0 = row(2 + ny).sub(ray.o[1]).mul(ray.inv[1]);
                    let ty1 = row(3 - ny).sub(ray.o[1]).mul(ray.inv[1]);
                    let tz0 = row(4 + nz).sub(ray.o[2]).mul(ray.inv[2]);
                    let tz1 = row(5 - nz).sub(ray.o[2]).mul(ray.inv[2]);
                    // NaN (origin on a slab plane with a zero direction component) leaves the bound open
                    let tnear = tz0.max(ty0.max(tx0.max(F4::splat(0.0))));
                    let tfar = tz1.min(ty1.min(tx1.min(F4::splat(best_t))));
                    mask |= tnear.le(tfar) << (4 * h);
                    tn[4 * h..4 * h + 4].copy_from_slice(&tnear.to_array());
                }
                if mask != 0 {
                    // nearest hit child next, the others onto the stack farthest first
                    let mut kids = [(0u32, 0f32); W];
                    let mut k = 0;
                    while mask != 0 {
                        let i = mask.trailing_zeros() as usize;
                        mask &= mask - 1;
                        let e = (n.child[i], tn[i]);
                        let mut j = k;
                        while j > 0 && kids[j - 1].1 < e.1 {
                            kids[j] = kids[j - 1];
                            j -= 1;
                        }
                        kids[j] = e;
                        k += 1;
                    }
                    stack[sp..sp + k - 1].copy_from_slice(&kids[..k - 1]);
                    sp += k - 1;
                    cur = kids[k - 1].0;
                    continue;
                }
            } else {
                let first = (cur & 0x0fff_ffff) as usize;
                let count = ((cur >> 28) & 7) as usize + 1;
                for b in first..first + count {
                    if let Some((t, lane, u, v)) = self.intersect_block(b, ray, best_t) {
                        best_t = t;
                        best = Some((t, self.blocks[b].ids[lane], u, v));
                    }
                }
            }
            // pop the next entry still nearer than the best hit
            loop {
                if sp == 0 {
                    return best;
                }
                sp -= 1;
                let (c, t) = stack[sp];
                if t <= best_t {
                    cur = c;
                    break;
                }
            }
        }
    }

    /// Nearest of a block's four triangles with t in (0, t_max), lanes tested in order.
    #[inline(always)]
    fn intersect_block(&self, b: usize, ray: &PreRay, t_max: f32) -> Option<(f32, usize, f32, f32)> {
        let blk = &self.blocks[b];
        let l = |r: &[[f32; 4]; 3]| [F4::load(&r[0]), F4::load(&r[1]), F4::load(&r[2])];
        let (v0, e1, e2) = (l(&blk.v0), l(&blk.e1), l(&blk.e2));
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
        let one = F4::splat(1.0);
        // det = 0 or non-finite gives NaN or infinite u, v, t, which every test below rejects
        let mut mask = zero.le(u) & zero.le(v) & u.add(v).le(one) & zero.lt(t) & t.lt(F4::splat(t_max));
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
}
