//! The wide BVH that rays spend their time in, over any primitives with boxes: eight-wide
//! nodes with full-precision child boxes in SoA layout (two 4-lane box tests per node, fewer
//! dependent loads per ray than a binary or four-wide tree). Built top-down with binned SAH,
//! then folded into eight-wide nodes: each node takes the two children of a binary node and
//! keeps opening its largest inner child until it has eight. What a leaf holds is the user's:
//! [`super::tribvh`] packs triangles four to a block, [`PointBvh`] keeps primitive ids.

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

pub(super) use lanes::F4;

/// Child slot tags: leaves carry this bit, their first item (a block, an id) in the low 28 bits
/// and their item count minus one in bits 28..31.
pub(super) const LEAF: u32 = 1 << 31;
const EMPTY: u32 = u32::MAX;
/// Binary subtrees with at most this many primitives become one leaf.
pub(super) const MAX_LEAF: usize = 4;

/// Children per node.
const W: usize = 8;

/// A leaf slot for `count` (1 to 8) items from `first` on.
#[inline]
pub(super) fn leaf_slot(first: usize, count: usize) -> u32 {
    debug_assert!((1..=8).contains(&count));
    assert!(first < 1 << 28, "a BVH holds at most 2^28 leaf items (blocks of four triangles, or points)");
    LEAF | ((count as u32 - 1) << 28) | first as u32
}

/// The (first, count) items of leaf slot `slot`.
#[inline(always)]
pub(super) fn leaf_items(slot: u32) -> (usize, usize) {
    ((slot & 0x0fff_ffff) as usize, ((slot >> 28) & 7) as usize + 1)
}

/// W child boxes, SoA: rows are min x, max x, min y, max y, min z, max z.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    b: [[f32; W]; 6],
    child: [u32; W],
}

/// A primitive's box during the build.
#[derive(Clone, Copy)]
pub(super) struct PrimRef {
    pub lo: Vec3A,
    pub hi: Vec3A,
    pub id: u32,
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

/// Top-down binned SAH over primitive boxes, a side of c primitives costing `cost(c)` tests;
/// ranges of at most [`MAX_LEAF`] become leaves. Deterministic: the tree does not depend on
/// thread timing.
fn build_node<C: Fn(u32) -> f32 + Copy + Sync>(prims: &mut [PrimRef], offset: u32, cost: C) -> BNode {
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
    if n <= MAX_LEAF {
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
            right[i] = if rc == 0 { f32::INFINITY } else { half_area(rl, rh) * cost(rc) };
        }
        let (mut ll, mut lh, mut lc) = (Vec3A::splat(f32::INFINITY), Vec3A::splat(f32::NEG_INFINITY), 0u32);
        for i in 1..BINS {
            ll = ll.min(blo[a][i - 1]);
            lh = lh.max(bhi[a][i - 1]);
            lc += cnt[a][i - 1];
            if lc == 0 {
                continue;
            }
            let c = half_area(ll, lh) * cost(lc) + right[i];
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
        rayon::join(|| build_node(l, offset, cost), || build_node(r, offset + mid as u32, cost))
    } else {
        (build_node(l, offset, cost), build_node(r, offset + mid as u32, cost))
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

/// (W-wide nodes, Σ `per_leaf`(leaf size)) that build node `k` becomes.
fn count(k: &BNode, per_leaf: &impl Fn(usize) -> usize) -> (usize, usize) {
    match fold(k) {
        None => match k.kind {
            BKind::Leaf { count, .. } => (0, per_leaf(count as usize)),
            BKind::Inner(_) => unreachable!(),
        },
        Some(kids) => kids.into_iter().map(|c| count(c, per_leaf)).fold((1, 0), |(n, b), (cn, cb)| (n + cn, b + cb)),
    }
}

/// The binary tree over a set of primitives, before it is folded into wide nodes.
pub(super) struct Binary {
    tree: BNode,
    /// Primitive ids in tree order: a leaf is a range of them.
    pub ids: Vec<u32>,
}

impl Binary {
    /// Builds over `prims` (not empty), freeing them before it returns.
    pub fn build(mut prims: Vec<PrimRef>, cost: impl Fn(u32) -> f32 + Copy + Sync) -> Binary {
        let tree = build_node(&mut prims, 0, cost);
        let ids = prims.iter().map(|p| p.id).collect();
        Binary { tree, ids }
    }

    /// Σ `per_leaf`(leaf size) over the leaves (to size what the leaves will be packed into).
    pub fn leaf_total(&self, per_leaf: impl Fn(usize) -> usize) -> usize {
        count(&self.tree, &per_leaf).1
    }

    /// Folds the tree into wide nodes (allocated once, at their exact count); `leaf(ids,
    /// start)` makes the child slot of the leaf holding `ids`, which begin at `start` of
    /// [`Self::ids`].
    pub fn fold(&self, mut leaf: impl FnMut(&[u32], usize) -> u32) -> WideTree {
        let (n, _) = count(&self.tree, &|_| 0);
        let mut f = Folder { ids: &self.ids, nodes: Vec::with_capacity(n), leaf: &mut leaf };
        let (root, depth) = f.slot(&self.tree);
        debug_assert_eq!(f.nodes.len(), n);
        if std::env::var("TIDE_BVH_STATS").is_ok() {
            eprintln!("nodes {} leaves' items {} depth {}", f.nodes.len(), self.ids.len(), depth);
        }
        WideTree { nodes: f.nodes, root, depth, bounds: (self.tree.lo.into(), self.tree.hi.into()) }
    }
}

struct Folder<'a, F> {
    ids: &'a [u32],
    nodes: Vec<Node>,
    leaf: &'a mut F,
}

impl<F: FnMut(&[u32], usize) -> u32> Folder<'_, F> {
    /// Makes the child slot for build node `k`; returns the slot and the depth below it.
    fn slot(&mut self, k: &BNode) -> (u32, usize) {
        let Some(kids) = fold(k) else {
            let BKind::Leaf { start, count } = k.kind else { unreachable!() };
            let (s, c) = (start as usize, count as usize);
            return ((self.leaf)(&self.ids[s..s + c], s), 0);
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
pub(super) struct PreRay {
    pub o: [F4; 3],
    pub d: [F4; 3],
    inv: [F4; 3],
    /// Row offsets of the near and far planes per axis (0 or 1, by the direction's sign).
    near: [usize; 3],
}

impl PreRay {
    #[inline(always)]
    pub fn new(o: Vec3A, d: Vec3A) -> PreRay {
        // -0 becomes +0 so the sign test and the reciprocal agree.
        let d = d + Vec3A::ZERO;
        let inv = Vec3A::ONE / d;
        PreRay {
            o: [F4::splat(o.x), F4::splat(o.y), F4::splat(o.z)],
            d: [F4::splat(d.x), F4::splat(d.y), F4::splat(d.z)],
            inv: [F4::splat(inv.x), F4::splat(inv.y), F4::splat(inv.z)],
            near: [(d.x < 0.0) as usize, (d.y < 0.0) as usize, (d.z < 0.0) as usize],
        }
    }
}

/// Wide nodes over leaves whose contents live elsewhere.
pub(super) struct WideTree {
    nodes: Vec<Node>,
    /// Root child slot: an inner node index, a leaf, or EMPTY.
    root: u32,
    /// Longest root-to-leaf path in nodes, which bounds the traversal stack.
    depth: usize,
    pub bounds: (Vec3, Vec3),
}

impl WideTree {
    pub fn empty() -> WideTree {
        WideTree { nodes: vec![], root: EMPTY, depth: 0, bounds: (Vec3::ZERO, Vec3::ZERO) }
    }

    pub fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>()
    }

    /// Whether the nodes were allocated once, at their exact count.
    #[cfg(test)]
    pub fn allocated_exactly(&self) -> bool {
        self.nodes.len() == self.nodes.capacity()
    }

    /// Visits, nearest first, the leaves whose boxes the ray crosses before the nearest hit:
    /// `leaf(slot, t)` tests the leaf's items against the ray up to `t` and returns the nearest
    /// hit's t (`t` itself if none is nearer); `prefetch(slot)` starts the loads of a leaf that
    /// will be visited later.
    #[inline(always)]
    pub fn traverse(&self, ray: &PreRay, t_max: f32, mut leaf: impl FnMut(u32, f32) -> f32, prefetch: impl Fn(u32)) {
        if self.root == EMPTY {
            return;
        }
        // Each node visited pushes at most W - 1 siblings.
        const FIXED: usize = (W - 1) * 24 + 1;
        if self.depth <= 24 {
            // left uninitialised: zeroing it would cost more than a short ray's traversal
            let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); FIXED];
            self.walk(ray, t_max, &mut stack, &mut leaf, &prefetch)
        } else {
            let mut stack = vec![MaybeUninit::<(u32, f32)>::uninit(); (W - 1) * self.depth + 1];
            self.walk(ray, t_max, &mut stack, &mut leaf, &prefetch)
        }
    }

    #[inline(always)]
    fn walk(&self, ray: &PreRay, t_max: f32, stack: &mut [MaybeUninit<(u32, f32)>], leaf: &mut impl FnMut(u32, f32) -> f32, prefetch: &impl Fn(u32)) {
        let mut best_t = t_max;
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
                        if c & LEAF == 0 {
                            self.prefetch_node(c);
                        } else {
                            prefetch(c);
                        }
                    }
                    continue;
                }
            } else {
                best_t = leaf(cur, best_t);
            }
            // pop the next entry still nearer than the best hit
            loop {
                if sp == 0 {
                    return;
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
    fn prefetch_node(&self, node: u32) {
        prefetch_lines(self.nodes.as_ptr().wrapping_add(node as usize) as *const u8, std::mem::size_of::<Node>());
    }
}

/// Starts loading the `bytes` from `p` into the cache (nothing off x86-64).
#[inline(always)]
pub(super) fn prefetch_lines(p: *const u8, bytes: usize) {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
        for l in 0..bytes.div_ceil(64) {
            // a prefetch never faults, whatever the address
            unsafe { _mm_prefetch(p.wrapping_add(64 * l) as *const i8, _MM_HINT_T0) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (p, bytes);
}

/// A wide BVH over primitives the caller intersects (points, for spheres, bubbles and
/// blobby kernels; instances, for the top level): leaves hold up to [`MAX_LEAF`] primitive ids,
/// each tested on its own.
pub(super) struct PointBvh {
    tree: WideTree,
    ids: Vec<u32>,
}

impl PointBvh {
    /// Builds over the primitives' boxes (`bounds[i]` = (lo, hi) of primitive i); an empty box
    /// (lo > hi on an axis) leaves its primitive out.
    pub fn build(bounds: impl Iterator<Item = (Vec3A, Vec3A)>) -> PointBvh {
        let prims: Vec<PrimRef> =
            bounds.enumerate().filter(|(_, (lo, hi))| lo.cmple(*hi).all()).map(|(i, (lo, hi))| PrimRef { lo, hi, id: i as u32 }).collect();
        if prims.is_empty() {
            return PointBvh { tree: WideTree::empty(), ids: vec![] };
        }
        // one test per primitive
        let bin = Binary::build(prims, |c| c as f32);
        let tree = bin.fold(|ids, start| leaf_slot(start, ids.len()));
        PointBvh { tree, ids: bin.ids }
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.tree.bounds
    }

    pub fn bytes(&self) -> usize {
        self.tree.bytes() + self.ids.len() * 4
    }

    /// Calls `hit(i, t)` for every primitive i whose leaf the ray reaches before the nearest
    /// hit so far (t); `hit` returns the primitive's hit distance below t, if any.
    #[inline]
    pub fn traverse(&self, o: Vec3A, d: Vec3A, t_max: f32, mut hit: impl FnMut(u32, f32) -> Option<f32>) {
        let ray = PreRay::new(o, d);
        self.tree.traverse(
            &ray,
            t_max,
            |slot, mut t_max| {
                let (first, count) = leaf_items(slot);
                for &i in &self.ids[first..first + count] {
                    if let Some(t) = hit(i, t_max) {
                        t_max = t;
                    }
                }
                t_max
            },
            |slot| {
                let (first, _) = leaf_items(slot);
                prefetch_lines(self.ids.as_ptr().wrapping_add(first) as *const u8, 16);
            },
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::chi2::TestRng;

    /// Where the ray enters box (lo, hi) (0 from inside), if it crosses it within [0, t_max].
    fn slab(o: Vec3A, d: Vec3A, lo: Vec3A, hi: Vec3A, t_max: f32) -> Option<f32> {
        let (a, b) = ((lo - o) / d, (hi - o) / d);
        let near = a.min(b).max_element().max(0.0);
        let far = a.max(b).min_element().min(t_max);
        (near <= far).then_some(near)
    }

    #[test]
    fn points_are_found_as_a_search_over_all_of_them_finds_them() {
        let mut rng = TestRng::new(11);
        let mut v = || Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        for n in [1usize, 3, 50, 2000] {
            // overlapping boxes of very different sizes, some of them flat
            let boxes: Vec<(Vec3A, Vec3A)> = (0..n)
                .map(|i| {
                    let c = v() * 10.0;
                    let mut e = v() * if i % 7 == 0 { 3.0 } else { 0.3 };
                    if i % 11 == 0 {
                        e.y = 0.0;
                    }
                    (c - e, c + e)
                })
                .collect();
            let bvh = PointBvh::build(boxes.iter().copied());
            for _ in 0..300 {
                let o = v() * 14.0 - 2.0;
                let d = (v() - 0.5).normalize();
                // a "hit" where the ray enters a box from outside
                let hit = |i: u32, t_max: f32| {
                    let (lo, hi) = boxes[i as usize];
                    slab(o, d, lo, hi, t_max).filter(|&t| t > 0.0 && t < t_max)
                };
                let want = (0..n as u32).filter_map(|i| hit(i, f32::INFINITY)).fold(f32::INFINITY, f32::min);
                let mut got = f32::INFINITY;
                bvh.traverse(o, d, f32::INFINITY, |i, t_max| {
                    let t = hit(i, t_max)?;
                    got = t;
                    Some(t)
                });
                assert_eq!(got, want, "n = {n}");
                // with no hits reported, every box the ray crosses is visited, once
                let mut seen = Vec::new();
                bvh.traverse(o, d, 20.0, |i, _| {
                    seen.push(i);
                    None
                });
                let crossed: Vec<u32> = (0..n as u32).filter(|&i| slab(o, d, boxes[i as usize].0, boxes[i as usize].1, 20.0).is_some()).collect();
                let mut visited = seen.clone();
                visited.sort_unstable();
                visited.dedup();
                assert_eq!(visited.len(), seen.len(), "n = {n}: a point visited twice");
                assert!(crossed.iter().all(|i| visited.binary_search(i).is_ok()), "n = {n}: a crossed box was not visited");
            }
        }
    }
}
