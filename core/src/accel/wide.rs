//! The wide BVH that rays spend their time in, over any primitives with boxes: eight-wide
//! nodes with full-precision child boxes in SoA layout (one 8-lane AVX box test per node, or
//! two 4-lane ones without AVX; fewer dependent loads per ray than a binary or four-wide tree),
//! on 2 MiB pages where the system gives them. Built top-down with binned SAH,
//! then folded into eight-wide nodes: each node takes the two children of a binary node and
//! keeps opening its largest inner child until it has eight. What a leaf holds is the user's:
//! [`super::tribvh`] packs triangles four to a block, [`PointBvh`] keeps primitive ids.
//!
//! The build reads each range twice per split (binned, then partitioned while gathering its
//! sides' bounds), sweeps only occupied bins, bins large ranges and folds the top levels in
//! parallel; the tree is the same whatever the thread count.

use glam::{Vec3, Vec3A, Vec4};
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

/// Most items (blocks of four triangles, or points) one BVH's leaves address: a leaf slot is
/// the leaf bit, two bits of count and 29 of first item. Validation keeps meshes and points sets
/// within it (`crate::validate`).
pub const MAX_LEAF_ITEMS: usize = 1 << 29;
const _: () = assert!(MAX_LEAF <= 4, "a points leaf's count must fit its slot");

/// A leaf slot for `count` (1 to 4) items from `first` on.
#[inline]
pub(super) fn leaf_slot(first: usize, count: usize) -> u32 {
    debug_assert!((1..=4).contains(&count));
    assert!(first < MAX_LEAF_ITEMS, "a BVH holds at most 2^29 leaf items (blocks of four triangles, or points)");
    LEAF | ((count as u32 - 1) << 29) | first as u32
}

/// The (first, count) items of leaf slot `slot`.
#[inline(always)]
pub(super) fn leaf_items(slot: u32) -> (usize, usize) {
    ((slot as usize & (MAX_LEAF_ITEMS - 1)), ((slot >> 29) & 3) as usize + 1)
}

/// W child boxes, SoA: rows are min x, max x, min y, max y, min z, max z.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Node {
    b: [[f32; W]; 6],
    child: [u32; W],
}

/// A primitive's box during the build: 32 bytes, its id in the w lane of `lo` (the builder's
/// passes over these are what a build spends its time on).
#[derive(Clone, Copy)]
pub(super) struct PrimRef {
    lo: Vec4,
    hi: Vec4,
}

impl PrimRef {
    #[inline]
    pub fn new(lo: Vec3A, hi: Vec3A, id: u32) -> PrimRef {
        PrimRef { lo: lo.extend(f32::from_bits(id)), hi: hi.extend(0.0) }
    }

    #[inline]
    pub fn id(&self) -> u32 {
        self.lo.w.to_bits()
    }

    /// Twice the centroid (x, y, z; w is meaningless).
    #[inline(always)]
    fn centroid2(&self) -> Vec4 {
        self.lo + self.hi
    }
}

/// Boxes of a range of primitives and of their (doubled) centroids; w lanes are meaningless.
#[derive(Clone, Copy)]
struct Bounds {
    lo: Vec4,
    hi: Vec4,
    clo: Vec4,
    chi: Vec4,
}

impl Bounds {
    const EMPTY: Bounds = Bounds { lo: Vec4::INFINITY, hi: Vec4::NEG_INFINITY, clo: Vec4::INFINITY, chi: Vec4::NEG_INFINITY };

    #[inline(always)]
    fn add(&mut self, p: &PrimRef) {
        self.lo = self.lo.min(p.lo);
        self.hi = self.hi.max(p.hi);
        let c = p.centroid2();
        self.clo = self.clo.min(c);
        self.chi = self.chi.max(c);
    }

    fn of(prims: &[PrimRef]) -> Bounds {
        let mut b = Bounds::EMPTY;
        for p in prims {
            b.add(p);
        }
        b
    }

    fn merge(self, o: Bounds) -> Bounds {
        Bounds { lo: self.lo.min(o.lo), hi: self.hi.max(o.hi), clo: self.clo.min(o.clo), chi: self.chi.max(o.chi) }
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
/// Ranges above this size are binned in parallel chunks of this size.
const PARALLEL_BINNING: usize = 64 * 1024;

/// The bins of the x, y, z lanes of `v`, scaled centroid coordinates: truncated and clamped
/// to the last bin (in [0, BINS) for finite input; NaN goes to the last bin).
#[inline(always)]
fn bins4(v: Vec4) -> [usize; 3] {
    #[cfg(target_arch = "x86_64")]
    {
        use std::arch::x86_64::*;
        // SAFETY: SSE2 is part of x86-64; the store target is 16 bytes
        let mut k = [0u32; 4];
        unsafe { _mm_storeu_si128(k.as_mut_ptr() as *mut __m128i, _mm_cvttps_epi32(v.into())) };
        let top = BINS as u32 - 1;
        [k[0].min(top) as usize, k[1].min(top) as usize, k[2].min(top) as usize]
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        // as cvttps2dq: NaN becomes i32::MIN, which the clamp sends to the last bin
        let b = |x: f32| if x.is_nan() { BINS - 1 } else { (x as i32 as u32).min(BINS as u32 - 1) as usize };
        [b(v.x), b(v.y), b(v.z)]
    }
}

/// Per-axis bins: boxes (w meaningless) and counts.
#[derive(Clone, Copy)]
struct Bins {
    lo: [[Vec4; BINS]; 3],
    hi: [[Vec4; BINS]; 3],
    cnt: [[u32; BINS]; 3],
}

impl Bins {
    fn of(prims: &[PrimRef], clo: Vec4, scale: Vec4) -> Bins {
        let mut b = Bins { lo: [[Vec4::INFINITY; BINS]; 3], hi: [[Vec4::NEG_INFINITY; BINS]; 3], cnt: [[0; BINS]; 3] };
        for p in prims {
            let k = bins4((p.centroid2() - clo) * scale);
            for a in 0..3 {
                let i = k[a];
                b.lo[a][i] = b.lo[a][i].min(p.lo);
                b.hi[a][i] = b.hi[a][i].max(p.hi);
                b.cnt[a][i] += 1;
            }
        }
        b
    }

    fn merge(mut self, o: &Bins) -> Bins {
        for a in 0..3 {
            for i in 0..BINS {
                self.lo[a][i] = self.lo[a][i].min(o.lo[a][i]);
                self.hi[a][i] = self.hi[a][i].max(o.hi[a][i]);
                self.cnt[a][i] += o.cnt[a][i];
            }
        }
        self
    }
}

/// Top-down binned SAH over primitive boxes, a side of c primitives costing `cost(c)` tests;
/// ranges of at most [`MAX_LEAF`] become leaves. `b` is the bounds of `prims`; each split's
/// partition gathers its sides' bounds, so a range is read twice (binned, partitioned).
/// Deterministic: the tree does not depend on thread timing (bins merge exactly: minima,
/// maxima and counts).
fn build_node<C: Fn(u32) -> f32 + Copy + Sync>(prims: &mut [PrimRef], offset: u32, cost: C, b: Bounds) -> BNode {
    let (lo, hi) = (Vec3A::from_vec4(b.lo), Vec3A::from_vec4(b.hi));
    let n = prims.len();
    if n <= MAX_LEAF {
        return BNode { lo, hi, kind: BKind::Leaf { start: offset, count: n as u32 } };
    }
    let (clo, chi) = (Vec3A::from_vec4(b.clo), Vec3A::from_vec4(b.chi));
    let extent = chi - clo;
    let scale = Vec3A::select(extent.cmpgt(Vec3A::ZERO), Vec3A::splat(BINS as f32 * (1.0 - 1e-6)) / extent, Vec3A::ZERO);
    let (clo4, scale4) = (clo.extend(0.0), scale.extend(0.0));
    let bins = if n > PARALLEL_BINNING {
        use rayon::prelude::*;
        let parts: Vec<Bins> = prims.par_chunks(PARALLEL_BINNING).map(|c| Bins::of(c, clo4, scale4)).collect();
        let (first, rest) = parts.split_first().expect("a range above the chunk size has chunks");
        rest.iter().fold(*first, |acc, p| acc.merge(p))
    } else {
        Bins::of(prims, clo4, scale4)
    };
    let v3 = Vec3A::from_vec4;
    let mut best = (f32::INFINITY, 0usize, 0usize);
    let mut occupied = [0usize; BINS];
    let mut right = [0f32; BINS];
    for a in 0..3 {
        if extent[a] <= 0.0 {
            continue;
        }
        // Only the occupied bins are swept: a split anywhere in a run of empty bins parts the
        // primitives alike at the same cost, and the first split of the run is the one taken.
        let mut k = 0;
        for i in 0..BINS {
            occupied[k] = i;
            k += (bins.cnt[a][i] != 0) as usize;
        }
        // right sweep: right[j] = cost of occupied bins j.. on the right
        let (mut rl, mut rh, mut rc) = (Vec4::INFINITY, Vec4::NEG_INFINITY, 0u32);
        for j in (1..k).rev() {
            let i = occupied[j];
            rl = rl.min(bins.lo[a][i]);
            rh = rh.max(bins.hi[a][i]);
            rc += bins.cnt[a][i];
            right[j] = half_area(v3(rl), v3(rh)) * cost(rc);
        }
        let (mut ll, mut lh, mut lc) = (Vec4::INFINITY, Vec4::NEG_INFINITY, 0u32);
        for j in 1..k {
            let i = occupied[j - 1];
            ll = ll.min(bins.lo[a][i]);
            lh = lh.max(bins.hi[a][i]);
            lc += bins.cnt[a][i];
            let c = half_area(v3(ll), v3(lh)) * cost(lc) + right[j];
            if c < best.0 {
                best = (c, a, i + 1);
            }
        }
    }
    let (mut lb, mut rb) = (Bounds::EMPTY, Bounds::EMPTY);
    let mid = if best.0.is_finite() {
        let (_, a, split) = best;
        // in-place partition: bins below `split` first, each side's bounds gathered on the way
        let (mut i, mut j) = (0, n);
        while i < j {
            let p = prims[i];
            if bins4((p.centroid2() - clo4) * scale4)[a] < split {
                lb.add(&p);
                i += 1;
            } else {
                rb.add(&p);
                j -= 1;
                prims.swap(i, j);
            }
        }
        i
    } else {
        0
    };
    // all centroids in one bin (coincident triangles): halve by position
    let mid = if mid == 0 || mid == n {
        lb = Bounds::of(&prims[..n / 2]);
        rb = Bounds::of(&prims[n / 2..]);
        n / 2
    } else {
        mid
    };
    let (l, r) = prims.split_at_mut(mid);
    let (a, b) = if n > PARALLEL {
        rayon::join(|| build_node(l, offset, cost, lb), || build_node(r, offset + mid as u32, cost, rb))
    } else {
        (build_node(l, offset, cost, lb), build_node(r, offset + mid as u32, cost, rb))
    };
    BNode { lo, hi, kind: BKind::Inner(Box::new((a, b))) }
}

/// The children a W-wide node takes for binary build node `k` (None for a leaf): its two
/// children, then the largest inner child opened until there are W.
fn fold(k: &BNode) -> Option<([&BNode; W], usize)> {
    let BKind::Inner(ab) = &k.kind else { return None };
    let mut kids = [&ab.0; W];
    kids[1] = &ab.1;
    let mut n = 2;
    while n < W {
        // the largest inner child; the last of equals
        let mut open: Option<(usize, f32)> = None;
        for (i, c) in kids[..n].iter().enumerate() {
            if matches!(c.kind, BKind::Inner(_)) {
                let area = half_area(c.lo, c.hi);
                if open.is_none_or(|(_, best)| area.total_cmp(&best).is_ge()) {
                    open = Some((i, area));
                }
            }
        }
        let Some((i, _)) = open else { break };
        let BKind::Inner(ab) = &kids[i].kind else { unreachable!() };
        kids.copy_within(i + 1..n, i + 2);
        kids[i] = &ab.0;
        kids[i + 1] = &ab.1;
        n += 1;
    }
    Some((kids, n))
}

/// (W-wide nodes, Σ `per_leaf`(leaf size)) that build node `k` becomes.
fn count(k: &BNode, per_leaf: &impl Fn(usize) -> usize) -> (usize, usize) {
    match fold(k) {
        None => match k.kind {
            BKind::Leaf { count, .. } => (0, per_leaf(count as usize)),
            BKind::Inner(_) => unreachable!(),
        },
        Some((kids, n)) => kids[..n].iter().map(|c| count(c, per_leaf)).fold((1, 0), |(n, b), (cn, cb)| (n + cn, b + cb)),
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
        use rayon::prelude::*;
        let b = if prims.len() > PARALLEL_BINNING {
            let parts: Vec<Bounds> = prims.par_chunks(PARALLEL_BINNING).map(Bounds::of).collect();
            parts.into_iter().fold(Bounds::EMPTY, Bounds::merge)
        } else {
            Bounds::of(&prims)
        };
        let tree = build_node(&mut prims, 0, cost, b);
        let ids = prims.par_iter().map(|p| p.id()).collect();
        Binary { tree, ids }
    }

    /// Folds the tree into wide nodes and packs the leaves' items, each output allocated once
    /// at its exact size. A leaf of `ids` (beginning at `start` of [`Self::ids`]) takes
    /// `per_leaf(ids.len())` items; `leaf(ids, start, first, out)` pushes that many to `out`
    /// (items `first..` of the output) and returns the leaf's child slot. The top
    /// levels fold in parallel; node and item order do not depend on it (depth first).
    pub fn fold<T: Send>(
        &self,
        per_leaf: impl Fn(usize) -> usize + Sync,
        leaf: impl Fn(&[u32], usize, usize, &mut Sink<T>) -> u32 + Sync,
    ) -> (WideTree, Vec<T>) {
        // the root's children's counts size the outputs and split them for the first level
        let kids = fold(&self.tree).map(|(kids, k)| kid_counts(&kids[..k], &per_leaf));
        let (n, m) = match &kids {
            Some(c) => c.iter().fold((1, 0), |(n, m), (cn, cm)| (n + cn, m + cm)),
            None => count(&self.tree, &per_leaf),
        };
        let mut nodes: Vec<Node> = Vec::with_capacity(n);
        let mut items: Vec<T> = Vec::with_capacity(m);
        // (where the system refuses, the tree is the same on small pages)
        let _ = advise_huge_pages(&mut nodes);
        let _ = advise_huge_pages(&mut items);
        let f = Folder { ids: &self.ids, per_leaf: &per_leaf, leaf: &leaf, item: std::marker::PhantomData };
        let (root, depth, nu, mu) = f.slot(&self.tree, &mut nodes.spare_capacity_mut()[..n], 0, &mut items.spare_capacity_mut()[..m], 0, 0, kids);
        assert!(nu == n && mu == m, "the fold writes every node and item it counted");
        // SAFETY: `slot` wrote a gapless prefix of n nodes and m items (each subtree writes a
        // prefix of what it is handed, and each leaf's sink is full: asserted)
        unsafe {
            nodes.set_len(n);
            items.set_len(m);
        }
        if std::env::var("TIDE_BVH_STATS").is_ok() {
            eprintln!("nodes {} leaves' items {} depth {}", nodes.len(), self.ids.len(), depth);
        }
        (WideTree { nodes, root, depth, bounds: (self.tree.lo.into(), self.tree.hi.into()) }, items)
    }
}

/// Where a leaf's items go: exactly as many as its share.
pub(super) struct Sink<'a, T> {
    out: &'a mut [MaybeUninit<T>],
    len: usize,
}

impl<T> Sink<'_, T> {
    #[inline]
    pub fn push(&mut self, item: T) {
        self.out[self.len].write(item);
        self.len += 1;
    }
}

/// (wide nodes, items) of each of `kids`, counted in parallel.
fn kid_counts(kids: &[&BNode], per_leaf: &(impl Fn(usize) -> usize + Sync)) -> Vec<(usize, usize)> {
    use rayon::prelude::*;
    kids.par_iter().map(|c| count(c, per_leaf)).collect()
}

/// Wide levels folded in parallel (8 subtrees at the first, 64 at the second).
const PARALLEL_FOLD_LEVELS: usize = 2;

struct Folder<'a, T, P, L> {
    ids: &'a [u32],
    per_leaf: &'a P,
    leaf: &'a L,
    item: std::marker::PhantomData<fn() -> T>,
}

impl<T: Send, P: Fn(usize) -> usize + Sync, L: Fn(&[u32], usize, usize, &mut Sink<T>) -> u32 + Sync> Folder<'_, T, P, L> {
    /// Writes build node `k`'s subtree at the front of `nodes` (node `at` of the output) and
    /// of `items` (item `first` of the output); returns the child slot for `k`, the depth
    /// below it, and how many nodes and items it wrote (a prefix of each slice, with no gaps).
    /// `counts`: its children's counts, where the caller has them.
    #[allow(clippy::too_many_arguments)]
    fn slot(&self, k: &BNode, nodes: &mut [MaybeUninit<Node>], at: usize, items: &mut [MaybeUninit<T>], first: usize, level: usize, counts: Option<Vec<(usize, usize)>>) -> (u32, usize, usize, usize) {
        let Some((kids, n)) = fold(k) else {
            let BKind::Leaf { start, count } = k.kind else { unreachable!() };
            let (s, c) = (start as usize, count as usize);
            let m = (self.per_leaf)(c);
            let mut sink = Sink { out: &mut items[..m], len: 0 };
            let slot = (self.leaf)(&self.ids[s..s + c], s, first, &mut sink);
            assert_eq!(sink.len, m, "a leaf writes the items it counted");
            return (slot, 0, 0, m);
        };
        let (me, rest) = nodes.split_first_mut().expect("a wide node has its slot");
        let mut out = [(EMPTY, 0usize, 0usize, 0usize); W];
        if level < PARALLEL_FOLD_LEVELS {
            use rayon::prelude::*;
            // each kid's share of the output, from its counts, filled in parallel
            let counts = counts.unwrap_or_else(|| kid_counts(&kids[..n], self.per_leaf));
            let mut parts = Vec::with_capacity(n);
            let (mut rest, mut items) = (rest, items);
            let (mut node_at, mut item_at) = (at + 1, first);
            for (&c, &(cn, cm)) in kids[..n].iter().zip(&counts) {
                let (kn, r) = std::mem::take(&mut rest).split_at_mut(cn);
                let (km, ri) = std::mem::take(&mut items).split_at_mut(cm);
                parts.push((c, kn, node_at, km, item_at));
                (rest, items) = (r, ri);
                (node_at, item_at) = (node_at + cn, item_at + cm);
            }
            let done: Vec<_> = parts.into_par_iter().map(|(c, kn, na, km, ia)| self.slot(c, kn, na, km, ia, level + 1, None)).collect();
            for (lane, (d, &(cn, cm))) in done.into_iter().zip(&counts).enumerate() {
                assert!(d.2 == cn && d.3 == cm, "a subtree fills the share its counts gave it");
                out[lane] = d;
            }
        } else {
            let (mut nu, mut mu) = (0, 0);
            for (lane, &c) in kids[..n].iter().enumerate() {
                let d = self.slot(c, &mut rest[nu..], at + 1 + nu, &mut items[mu..], first + mu, level + 1, None);
                (nu, mu) = (nu + d.2, mu + d.3);
                out[lane] = d;
            }
        }
        let (inf, ninf) = ([f32::INFINITY; W], [f32::NEG_INFINITY; W]);
        let mut node = Node { b: [inf, ninf, inf, ninf, inf, ninf], child: [EMPTY; W] };
        let (mut depth, mut nu, mut mu) = (0, 1, 0);
        for (lane, (&c, &(s, d, cn, cm))) in kids[..n].iter().zip(&out).enumerate() {
            (depth, nu, mu) = (depth.max(d), nu + cn, mu + cm);
            for a in 0..3 {
                node.b[2 * a][lane] = c.lo[a];
                node.b[2 * a + 1][lane] = c.hi[a];
            }
            node.child[lane] = s;
        }
        me.write(node);
        (at as u32, depth + 1, nu, mu)
    }
}

/// A ray prepared for traversal.
pub(super) struct PreRay {
    pub o: [F4; 3],
    pub d: [F4; 3],
    inv: [F4; 3],
    /// Row offsets of the near and far planes per axis (0 or 1, by the direction's sign).
    near: [usize; 3],
    /// Origin and direction are finite (a ray that is not meets nothing).
    finite: bool,
    /// The watertight triangle test's frame ([`super::tribvh::hit4`]): the axis the direction
    /// is largest along (z) and the two others (x, y) ...
    pub axes: [usize; 3],
    /// ... and the shear taking the direction onto the z axis: d_x / d_z, d_y / d_z (any
    /// rounding of it is the same for every triangle the ray meets, which is all the test needs).
    pub shear: [F4; 2],
}

impl PreRay {
    #[inline(always)]
    pub fn new(o: Vec3A, d: Vec3A) -> PreRay {
        // -0 becomes +0 so the sign test and the reciprocal agree.
        let d = d + Vec3A::ZERO;
        let inv = Vec3A::ONE / d;
        let kz = d.abs().max_position();
        PreRay {
            o: [F4::splat(o.x), F4::splat(o.y), F4::splat(o.z)],
            d: [F4::splat(d.x), F4::splat(d.y), F4::splat(d.z)],
            inv: [F4::splat(inv.x), F4::splat(inv.y), F4::splat(inv.z)],
            near: [(d.x < 0.0) as usize, (d.y < 0.0) as usize, (d.z < 0.0) as usize],
            finite: o.is_finite() && d.is_finite(),
            axes: [(kz + 1) % 3, (kz + 2) % 3, kz],
            shear: [F4::splat(d[(kz + 1) % 3] * inv[kz]), F4::splat(d[(kz + 2) % 3] * inv[kz])],
        }
    }
}

/// How a node's W child boxes are tested against a ray: which children it crosses within
/// [0, t_far] (bit i for child i) and where it enters each. Both ways do the same operations
/// lane for lane, so they give the same bits.
trait BoxTest {
    /// SAFETY: the implementation's CPU features must be present.
    unsafe fn hits(n: &Node, ray: &PreRay, t_far: f32) -> (u32, [f32; W]);
}

/// Two four-lane halves (any CPU).
struct Halves;

impl BoxTest for Halves {
    #[inline(always)]
    unsafe fn hits(n: &Node, ray: &PreRay, t_far: f32) -> (u32, [f32; W]) {
        let [nx, ny, nz] = ray.near;
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
            let tfar = tz1.min(ty1.min(tx1.min(F4::splat(t_far))));
            mask |= tnear.le(tfar) << (4 * h);
            tn[4 * h..4 * h + 4].copy_from_slice(&tnear.to_array());
        }
        (mask, tn)
    }
}

/// All eight lanes at once (x86-64 with AVX).
#[cfg(target_arch = "x86_64")]
struct Avx;

#[cfg(target_arch = "x86_64")]
impl BoxTest for Avx {
    // Not a `target_feature` function itself (those cannot be forced inline): it inlines into
    // `traverse_avx`, where the AVX intrinsics inline in turn.
    #[inline(always)]
    unsafe fn hits(n: &Node, ray: &PreRay, t_far: f32) -> (u32, [f32; W]) {
        use std::arch::x86_64::*;
        const _: () = assert!(W == 8, "one AVX register per row");
        let [nx, ny, nz] = ray.near;
        let (o, inv) = (ray.o.map(|v| v.to_array()[0]), ray.inv.map(|v| v.to_array()[0]));
        // the operations of `Halves`, in the same order and with the same operand order
        macro_rules! slab {
            ($row:expr, $a:expr) => {
                _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(n.b[$row].as_ptr()), _mm256_set1_ps(o[$a])), _mm256_set1_ps(inv[$a]))
            };
        }
        let (tx0, tx1) = (slab!(nx, 0), slab!(1 - nx, 0));
        let (ty0, ty1) = (slab!(2 + ny, 1), slab!(3 - ny, 1));
        let (tz0, tz1) = (slab!(4 + nz, 2), slab!(5 - nz, 2));
        let tnear = _mm256_max_ps(tz0, _mm256_max_ps(ty0, _mm256_max_ps(tx0, _mm256_setzero_ps())));
        let tfar = _mm256_min_ps(tz1, _mm256_min_ps(ty1, _mm256_min_ps(tx1, _mm256_set1_ps(t_far))));
        let mask = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tnear, tfar)) as u32;
        let mut tn = [0f32; W];
        _mm256_storeu_ps(tn.as_mut_ptr(), tnear);
        (mask, tn)
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

    /// Every bit of the tree, for tests that two builds made the same one.
    #[cfg(test)]
    pub fn bits(&self) -> Vec<u32> {
        let mut v = vec![self.root, self.depth as u32];
        for n in &self.nodes {
            v.extend(n.b.iter().flatten().map(|x| x.to_bits()));
            v.extend(n.child);
        }
        v
    }

    /// Visits, nearest first, the leaves whose boxes the ray crosses before the nearest hit:
    /// `leaf(slot, t)` tests the leaf's items against the ray up to `t` and returns the nearest
    /// hit's t (`t` itself if none is nearer); `prefetch(slot)` starts the loads of a leaf that
    /// will be visited later.
    #[inline(always)]
    pub fn traverse(&self, ray: &PreRay, t_max: f32, mut leaf: impl FnMut(u32, f32) -> f32, prefetch: impl Fn(u32)) {
        // a NaN in the slab tests leaves a box open, an empty child slot's included: a ray
        // with a non-finite origin or direction would visit leaves that are not there
        if self.root == EMPTY || !ray.finite {
            return;
        }
        #[cfg(target_arch = "x86_64")]
        if std::arch::is_x86_feature_detected!("avx") {
            // SAFETY: the CPU has AVX
            return unsafe { self.traverse_avx(ray, t_max, &mut leaf, &prefetch) };
        }
        self.stacked::<Halves>(ray, t_max, &mut leaf, &prefetch)
    }

    /// [`Self::traverse`] compiled for AVX: the whole walk, leaf tests included, so that the
    /// eight-lane box test inlines.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn traverse_avx(&self, ray: &PreRay, t_max: f32, leaf: &mut impl FnMut(u32, f32) -> f32, prefetch: &impl Fn(u32)) {
        self.stacked::<Avx>(ray, t_max, leaf, prefetch)
    }

    #[inline(always)]
    fn stacked<B: BoxTest>(&self, ray: &PreRay, t_max: f32, leaf: &mut impl FnMut(u32, f32) -> f32, prefetch: &impl Fn(u32)) {
        // Each node visited pushes at most W - 1 siblings.
        const FIXED: usize = (W - 1) * 24 + 1;
        if self.depth <= 24 {
            // left uninitialised: zeroing it would cost more than a short ray's traversal
            let mut stack = [MaybeUninit::<(u32, f32)>::uninit(); FIXED];
            self.walk::<B>(ray, t_max, &mut stack, leaf, prefetch)
        } else {
            let mut stack = vec![MaybeUninit::<(u32, f32)>::uninit(); (W - 1) * self.depth + 1];
            self.walk::<B>(ray, t_max, &mut stack, leaf, prefetch)
        }
    }

    #[inline(always)]
    fn walk<B: BoxTest>(&self, ray: &PreRay, t_max: f32, stack: &mut [MaybeUninit<(u32, f32)>], leaf: &mut impl FnMut(u32, f32) -> f32, prefetch: &impl Fn(u32)) {
        let mut best_t = t_max;
        let mut sp = 0usize;
        let mut cur = self.root;
        loop {
            if cur & LEAF == 0 {
                let n = &self.nodes[cur as usize];
                // the child slots share no cache line with the boxes and are read only after
                // the box tests: start their load with the boxes' loads
                prefetch_lines(n.child.as_ptr() as *const u8, 1);
                // SAFETY: `B` is `Avx` only in `traverse_avx`, on CPUs with AVX
                let (mut mask, tn) = unsafe { B::hits(n, ray, best_t) };
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
pub(crate) fn prefetch_lines(p: *const u8, bytes: usize) {
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

/// Asks for the not yet written capacity of `v` to be backed by 2 MiB pages (Linux, where
/// transparent huge pages are given on request); returns whether the advice was taken. Rays
/// read a large BVH's nodes and leaves in no order the TLB can follow: over tens of megabytes
/// of 4 KiB pages most node visits would also wait for a page walk. Arrays under 4 MiB and
/// other systems: nothing.
pub(super) fn advise_huge_pages<T>(v: &mut Vec<T>) -> bool {
    #[cfg(target_os = "linux")]
    {
        const HUGE: usize = 2 << 20;
        let begin = v.as_mut_ptr() as usize;
        let bytes = v.capacity() * std::mem::size_of::<T>();
        // only whole 2 MiB pages inside the allocation can be huge
        let (start, end) = (begin.next_multiple_of(HUGE), (begin + bytes) / HUGE * HUGE);
        if bytes < 2 * HUGE || end <= start {
            return false;
        }
        // SAFETY: advice on address ranges the vector owns; it changes no memory (and fails
        // harmlessly where huge pages are off)
        unsafe { libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE) == 0 }
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = v;
        false
    }
}

/// A wide BVH over primitives the caller intersects (points, for spheres, bubbles and
/// blobby kernels; instances, for the top level; pieces of photon beams): leaves hold up to [`MAX_LEAF`] primitive ids,
/// each tested on its own.
pub(crate) struct PointBvh {
    tree: WideTree,
    ids: Vec<u32>,
}

impl PointBvh {
    /// Builds over the primitives' boxes (`bounds[i]` = (lo, hi) of primitive i); an empty box
    /// (lo > hi on an axis) leaves its primitive out.
    pub fn build(bounds: impl Iterator<Item = (Vec3A, Vec3A)>) -> PointBvh {
        let prims: Vec<PrimRef> =
            bounds.enumerate().filter(|(_, (lo, hi))| lo.cmple(*hi).all()).map(|(i, (lo, hi))| PrimRef::new(lo, hi, i as u32)).collect();
        if prims.is_empty() {
            return PointBvh { tree: WideTree::empty(), ids: vec![] };
        }
        // one test per primitive
        let bin = Binary::build(prims, |c| c as f32);
        let (tree, _) = bin.fold::<()>(|_| 0, |ids, start, _, _| leaf_slot(start, ids.len()));
        PointBvh { tree, ids: bin.ids }
    }

    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.tree.bounds
    }

    pub fn bytes(&self) -> usize {
        self.tree.bytes() + self.ids.len() * 4
    }

    /// The primitive ids in leaf order: slot k of [`Self::traverse_slots`] holds primitive
    /// `ids()[k]` (primitives left out by an empty box have no slot).
    pub fn ids(&self) -> &[u32] {
        &self.ids
    }

    /// Calls `hit(i, t)` for every primitive i whose leaf the ray reaches before the nearest
    /// hit so far (t); `hit` returns the primitive's hit distance below t, if any.
    #[inline]
    pub fn traverse(&self, o: Vec3A, d: Vec3A, t_max: f32, mut hit: impl FnMut(u32, f32) -> Option<f32>) {
        self.traverse_slots(o, d, t_max, |k, t| hit(self.ids[k], t), |k| {
            prefetch_lines(self.ids.as_ptr().wrapping_add(k) as *const u8, 16)
        });
    }

    /// [`Self::traverse`] by slot: `hit(k, t)` for the primitive in slot k (for callers that
    /// keep their primitives' data in leaf order, where a leaf's primitives sit side by side);
    /// `prefetch(k)` starts the loads of a leaf whose first slot is k.
    #[inline]
    pub fn traverse_slots(&self, o: Vec3A, d: Vec3A, t_max: f32, mut hit: impl FnMut(usize, f32) -> Option<f32>, prefetch: impl Fn(usize)) {
        let ray = PreRay::new(o, d);
        self.tree.traverse(
            &ray,
            t_max,
            |slot, mut t_max| {
                let (first, count) = leaf_items(slot);
                for k in first..first + count {
                    if let Some(t) = hit(k, t_max) {
                        t_max = t;
                    }
                }
                t_max
            },
            |slot| prefetch(leaf_items(slot).0),
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
    fn a_ray_that_is_not_finite_meets_nothing() {
        // 20 unit boxes along x: a root with empty child slots (five leaves of four)
        let bvh = PointBvh::build((0..20).map(|i| (Vec3A::new(3.0 * i as f32, 0.0, 0.0), Vec3A::new(3.0 * i as f32 + 1.0, 1.0, 1.0))));
        let visits = |o: Vec3A, d: Vec3A| {
            let mut seen = Vec::new();
            bvh.traverse(o, d, f32::INFINITY, |i, _| {
                seen.push(i);
                None
            });
            seen
        };
        assert!(visits(Vec3A::new(0.5, 0.5, -5.0), Vec3A::Z).contains(&0));
        for (o, d) in [(Vec3A::new(f32::NAN, 0.5, -5.0), Vec3A::Z), (Vec3A::new(0.5, 0.5, -5.0), Vec3A::new(0.0, f32::NAN, 1.0)), (Vec3A::new(f32::INFINITY, 0.5, 0.5), Vec3A::Z)] {
            assert_eq!(visits(o, d), [], "{o} {d}");
        }
    }

    #[test]
    fn leaf_slots_round_trip_up_to_the_last_addressable_item() {
        for first in [0, 1, 12345, MAX_LEAF_ITEMS - 4, MAX_LEAF_ITEMS - 1] {
            for count in 1..=4 {
                let slot = leaf_slot(first, count);
                assert!(slot & LEAF != 0);
                assert_eq!(leaf_items(slot), (first, count));
            }
        }
    }

    #[test]
    #[should_panic(expected = "at most 2^29 leaf items")]
    fn a_leaf_past_the_last_addressable_item_is_refused() {
        leaf_slot(MAX_LEAF_ITEMS, 1);
    }

    #[test]
    #[cfg(target_arch = "x86_64")]
    fn both_box_tests_give_the_same_bits_and_visit_the_same_leaves() {
        if !std::arch::is_x86_feature_detected!("avx") {
            eprintln!("no AVX here: only the four-lane box test runs");
            return;
        }
        let mut rng = TestRng::new(5);
        let mut v = || Vec3A::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
        let boxes: Vec<(Vec3A, Vec3A)> = (0..3000)
            .map(|i| {
                let (c, e) = (v() * 10.0, v() * 0.4);
                // some flat boxes, some on whole-number planes a ray can start on
                if i % 5 == 0 { (c.floor(), c.floor() + e * Vec3A::new(1.0, 0.0, 1.0)) } else { (c - e, c + e) }
            })
            .collect();
        let bvh = PointBvh::build(boxes.iter().copied());
        let mut rays = Vec::new();
        for i in 0..400 {
            let (mut o, mut d) = (v() * 12.0 - 1.0, (v() - 0.5).normalize());
            // axis-parallel rays, zero components of both signs, origins on slab planes
            match i % 4 {
                1 => d = Vec3A::new(0.0, -0.0, 1.0) * d.z.signum(),
                2 => {
                    d.x = -0.0;
                    o = o.floor();
                }
                _ => {}
            }
            rays.push((o, d));
        }
        let mut visits = 0;
        for (o, d) in rays {
            let ray = PreRay::new(o, d);
            for n in &bvh.tree.nodes {
                for t_far in [f32::INFINITY, 3.0] {
                    // SAFETY: the CPU has AVX (checked above)
                    let (a, b) = unsafe { (Halves::hits(n, &ray, t_far), Avx::hits(n, &ray, t_far)) };
                    assert_eq!(a.0, b.0, "masks, ray {o} {d}");
                    assert_eq!(a.1.map(f32::to_bits), b.1.map(f32::to_bits), "entry distances, ray {o} {d}");
                }
            }
            let (mut a, mut b) = (Vec::new(), Vec::new());
            bvh.tree.stacked::<Halves>(&ray, 15.0, &mut |slot, t| { a.push(slot); t * 0.999 }, &|_| {});
            // SAFETY: as above
            unsafe { bvh.tree.traverse_avx(&ray, 15.0, &mut |slot, t| { b.push(slot); t * 0.999 }, &|_| {}) };
            assert_eq!(a, b, "leaves visited, ray {o} {d}");
            visits += a.len();
        }
        assert!(visits > 1000, "the rays cross the boxes ({visits} leaf visits)");
    }

    #[test]
    #[cfg(target_os = "linux")]
    fn large_arrays_are_advised_onto_huge_pages_where_the_system_allows_it() {
        let mode = std::fs::read_to_string("/sys/kernel/mm/transparent_hugepage/enabled").unwrap_or_default();
        // an allocation not on a 2 MiB boundary, as the allocator hands them out
        let mut big: Vec<[f32; 8]> = Vec::with_capacity((9 << 20) / 32 + 3);
        let taken = advise_huge_pages(&mut big);
        if mode.contains("[always]") || mode.contains("[madvise]") {
            assert!(taken, "madvise refused the aligned interior of a 9 MiB array (THP: {})", mode.trim());
        } else {
            eprintln!("transparent huge pages unavailable ({}): advice not checked", mode.trim());
        }
        // small arrays are left alone
        assert!(!advise_huge_pages(&mut Vec::<u8>::with_capacity(1 << 20)));
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
