//! The triangle BVH that rays spend their time in: eight-wide nodes with full-precision child
//! boxes in SoA layout (two 4-lane box tests per node, fewer dependent loads per ray than a
//! binary or four-wide tree), and leaves of four triangles stored SoA with their ids (one 4-lane
//! Möller–Trumbore per block). Built top-down with binned SAH costed in blocks, then folded
//! into eight-wide nodes: each node takes the two children of a binary node and keeps opening
//! its largest inner child until it has eight.

use glam::{Vec3, Vec3A};
use std::mem::MaybeUninit;

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

pub struct TriBvh {
    nodes: Vec<Node>,
    blocks: Vec<Tri4>,
    /// Root child slot: an inner node index, a leaf, or EMPTY.
    root: u32,
    /// Longest root-to-leaf path in nodes, which bounds the traversal stack.
    depth: usize,
    pub bounds: (Vec3, Vec3),
}

/// A triangle's box during the build.
#[derive(Clone, Copy)]
struct PrimRef {
    lo: Vec3A,
    hi: Vec3A,
    id: u32,
}

impl PrimRef {
    #[inline]
    fn centroid2(&self) -> Vec3A {
        self.lo + self.hi
    }
}

/// Binary build tree: leaves are ranges of the reordered `PrimRef`s.
struct BNode {
    lo: Vec3A,
    hi: Vec3A,
    kind: BKind,
}

enum BKind {
    Leaf { start: u32, count: u32 },
    Inner(Box<(BNode, BNode)>),
}

fn half_area(lo: Vec3A, hi: Vec3A) -> f32 {
    let e = (hi - lo).max(Vec3A::ZERO);
    e.x * e.y + e.y * e.z + e.z * e.x
}

const BINS: usize = 32;
/// Subtrees above this size build their halves in parallel.
const PARALLEL: usize = 16 * 1024;

/// Top-down binned SAH over triangle boxes, costed in four-triangle blocks (a leaf of 1 to 4
/// triangles costs one block test). Deterministic: the tree does not depend on thread timing.
fn build_node(prims: &mut [PrimRef], offset: u32) -> BNode {
    let mut lo = Vec3A::splat(f32::INFINITY);
    let mut hi = Vec3A::splat(f32::NEG_INFINITY);
    let mut clo = lo;
    let mut chi = hi;
    for p in prims.iter() {
        lo = lo.min(p.lo);
        hi = hi.max(p.hi);
        clo = clo.min(p.centroid2());
        chi = chi.max(p.centroid2());
    }
    let n = prims.len();
    if n <= BLOCK {
        return BNode { lo, hi, kind: BKind::Leaf { start: offset, count: n as u32 } };
    }
    let extent = chi - clo;
    let scale = Vec3A::select(extent.cmpgt(Vec3A::ZERO), Vec3A::splat(BINS as f32 * (1.0 - 1e-6)) / extent, Vec3A::ZERO);
    let bin = |p: &PrimRef, a: usize| (((p.centroid2()[a] - clo[a]) * scale[a]) as usize).min(BINS - 1);
    // per axis: bin boxes and counts
    let mut blo = [[Vec3A::splat(f32::INFINITY); BINS]; 3];
    let mut bhi = [[Vec3A::splat(f32::NEG_INFINITY); BINS]; 3];
    let mut cnt = [[0u32; BINS]; 3];
    for p in prims.iter() {
        for a in 0..3 {
            let b = bin(p, a);
            blo[a][b] = blo[a][b].min(p.lo);
            bhi[a][b] = bhi[a][b].max(p.hi);
            cnt[a][b] += 1;
        }
    }
    let blocks = |c: u32| c.div_ceil(BLOCK as u32) as f32;
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for a in 0..3 {
        if extent[a] <= 0.0 {
            continue;
        }
        // right sweep: cost of bins i.. on the right
        let mut right = [0f32; BINS];
        let (mut rl, mut rh, mut rc) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY), 0u32);
        for i in (1..BINS).rev() {
            rl = rl.min(blo[a][i]);
            rh = rh.max(bhi[a][i]);
            rc += cnt[a][i];
            right[i] = if rc == 0 { f32::INFINITY } else { half_area(rl, rh) * blocks(rc) };
        }
        let (mut ll, mut lh, mut lc) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY), 0u32);
        for i in 1..BINS {
            ll = ll.min(blo[a][i - 1]);
            lh = lh.max(bhi[a][i - 1]);
            lc += cnt[a][i - 1];
            if lc == 0 {
                continue;
            }
            let c = half_area(ll, lh) * blocks(lc) + right[i];
            if c < best.0 {
                best = (c, a, i);
            }
        }
    }
    let mid = if best.0.is_finite() {
        let (_, a, split) = best;
        // in-place partition: bins below `split` first
        let (mut i, mut j) = (0, n);
        while i < j {
            if bin(&prims[i], a) < split {
                i += 1;
            } else {
                j -= 1;
                prims.swap(i, j);
            }
        }
        i
    } else {
        0
    };
    // all centroids in one bin (coincident triangles): halve by position
    let mid = if mid == 0 || mid == n { n / 2 } else { mid };
    let (l, r) = prims.split_at_mut(mid);
    let (a, b) = if n > PARALLEL {
        rayon::join(|| build_node(l, offset), || build_node(r, offset + mid as u32))
    } else {
        (build_node(l, offset), build_node(r, offset + mid as u32))
    };
    BNode { lo, hi, kind: BKind::Inner(Box::new((a, b))) }
}

/// The children a W-wide node takes for binary build node `k` (None for a leaf): its two
/// children, then the largest inner child opened until there are W.
fn fold(k: &BNode) -> Option<Vec<&BNode>> {
    let BKind::Inner(ab) = &k.kind else { return None };
    let mut kids: Vec<&BNode> = Vec::with_capacity(W);
    kids.extend([&ab.0, &ab.1]);
    while kids.len() < W {
        let open = (0..kids.len())
            .filter(|&i| matches!(kids[i].kind, BKind::Inner(_)))
            .max_by(|&x, &y| half_area(kids[x].lo, kids[x].hi).total_cmp(&half_area(kids[y].lo, kids[y].hi)));
        let Some(i) = open else { break };
        let BKind::Inner(ab) = &kids[i].kind else { unreachable!() };
        kids[i] = &ab.0;
        kids.insert(i + 1, &ab.1);
    }
    Some(kids)
}

/// (W-wide nodes, leaf blocks) that build node `k` becomes: the output's exact sizes, so the
/// build allocates them once.
fn count(k: &BNode) -> (usize, usize) {
    match fold(k) {
        None => match k.kind {
            BKind::Leaf { count, .. } => (0, (count as usize).div_ceil(BLOCK)),
            BKind::Inner(_) => unreachable!(),
        },
        Some(kids) => kids.into_iter().map(count).fold((1, 0), |(n, b), (cn, cb)| (n + cn, b + cb)),
    }
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
    fn tri(&self, i: usize) -> [Vec3A; 3] {
        [0, 1, 2].map(|k| Vec3A::from(self.positions[self.indices[3 * i + k] as usize]))
    }
}

struct Builder<'a> {
    /// Triangle ids in build order: a leaf is a range of them.
    ids: &'a [u32],
    mesh: TriMesh<'a>,
    nodes: Vec<Node>,
    blocks: Vec<Tri4>,
}

impl Builder<'_> {
    fn leaf(&mut self, start: u32, count: u32) -> u32 {
        let ids = &self.ids[start as usize..(start + count) as usize];
        let first = self.blocks.len() as u32;
        for c in ids.chunks(BLOCK) {
            let mut blk = Tri4 { v0: [[0.0; 4]; 3], e1: [[0.0; 4]; 3], e2: [[0.0; 4]; 3], ids: [0; 4] };
            for lane in 0..4 {
                // short blocks repeat their last triangle: a duplicate never wins a strict `<`
                let id = c[lane.min(c.len() - 1)];
                let [v0, v1, v2] = self.mesh.tri(id as usize);
                let (e1, e2) = (v1 - v0, v2 - v0);
                for a in 0..3 {
                    blk.v0[a][lane] = v0[a];
                    blk.e1[a][lane] = e1[a];
                    blk.e2[a][lane] = e2[a];
                }
                blk.ids[lane] = id;
            }
            self.blocks.push(blk);
        }
        LEAF | ((ids.len().div_ceil(BLOCK) as u32 - 1) << 28) | first
    }

    /// Makes the child slot for build node `k`; returns the slot and the depth below it.
    fn slot(&mut self, k: &BNode) -> (u32, usize) {
        let Some(kids) = fold(k) else {
            let BKind::Leaf { start, count } = k.kind else { unreachable!() };
            return (self.leaf(start, count), 0);
        };
        let me = self.nodes.len();
        let (inf, ninf) = ([f32::INFINITY; W], [f32::NEG_INFINITY; W]);
        self.nodes.push(Node { b: [inf, ninf, inf, ninf, inf, ninf], child: [EMPTY; W] });
        let mut depth = 0;
        for (lane, c) in kids.into_iter().enumerate() {
            let (s, d) = self.slot(c);
            depth = depth.max(d);
            let node = &mut self.nodes[me];
            for a in 0..3 {
                node.b[2 * a][lane] = c.lo[a];
                node.b[2 * a + 1][lane] = c.hi[a];
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

impl TriBvh {
    /// Builds over every triangle of `mesh`. The largest arrays live one at a time: the
    /// triangles' boxes while the binary tree is built, the output (allocated at its exact
    /// size) while the tree is folded into it.
    pub fn build(mesh: TriMesh) -> TriBvh {
        if mesh.len() == 0 {
            return TriBvh { nodes: vec![], blocks: vec![], root: EMPTY, depth: 0, bounds: (Vec3::ZERO, Vec3::ZERO) };
        }
        let mut prims: Vec<PrimRef> = (0..mesh.len())
            .map(|i| {
                let [v0, v1, v2] = mesh.tri(i);
                PrimRef { lo: v0.min(v1).min(v2), hi: v0.max(v1).max(v2), id: i as u32 }
            })
            .collect();
        let tree = build_node(&mut prims, 0);
        let ids: Vec<u32> = prims.iter().map(|p| p.id).collect();
        drop(prims);
        let (nodes, blocks) = count(&tree);
        let mut b = Builder { ids: &ids, mesh, nodes: Vec::with_capacity(nodes), blocks: Vec::with_capacity(blocks) };
        let (root, depth) = b.slot(&tree);
        debug_assert_eq!((b.nodes.len(), b.blocks.len()), (nodes, blocks));
        if std::env::var("TIDE_BVH_STATS").is_ok() {
            eprintln!("nodes {} blocks {} depth {}", b.nodes.len(), b.blocks.len(), depth);
        }
        TriBvh { nodes: b.nodes, blocks: b.blocks, root, depth, bounds: (tree.lo.into(), tree.hi.into()) }
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
            // left uninitialised: zeroing it would cost more than a short ray's traversal
            let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); FIXED];
            self.traverse(&ray, t_max, &mut stack)
        } else {
            let mut stack = vec![MaybeUninit::<(u32, f32)>::uninit(); (W - 1) * self.depth + 1];
            self.traverse(&ray, t_max, &mut stack)
        }
    }

    #[inline(always)]
    fn traverse(&self, ray: &PreRay, t_max: f32, stack: &mut [MaybeUninit<(u32, f32)>]) -> Option<(f32, u32, f32, f32)> {
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
                    for (slot, &e) in stack[sp..sp + k - 1].iter_mut().zip(&kids[..k - 1]) {
                        slot.write(e);
                    }
                    sp += k - 1;
                    cur = kids[k - 1].0;
                    // the siblings left for later: start their loads now, so their cache
                    // misses overlap the work on the nearest child
                    for &(c, _) in &kids[..k - 1] {
                        self.prefetch(c);
                    }
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
                // SAFETY: entries below the pushed height were written by the push above.
                let (c, t) = unsafe { stack[sp].assume_init() };
                if t <= best_t {
                    cur = c;
                    break;
                }
            }
        }
    }

    #[inline(always)]
    fn prefetch(&self, slot: u32) {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let (p, lines) = if slot & LEAF == 0 {
                (self.nodes.as_ptr().wrapping_add(slot as usize) as *const i8, std::mem::size_of::<Node>() / 64)
            } else {
                (self.blocks.as_ptr().wrapping_add((slot & 0x0fff_ffff) as usize) as *const i8, std::mem::size_of::<Tri4>().div_ceil(64))
            };
            for l in 0..lines {
                // a prefetch never faults, whatever the address
                unsafe { _mm_prefetch(p.wrapping_add(64 * l), _MM_HINT_T0) };
            }
        }
        #[cfg(not(target_arch = "x86_64"))]
        let _ = slot;
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
            assert_eq!(bvh.nodes.len(), bvh.nodes.capacity(), "n = {n}");
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
}
