//! Water FX primitives on points (contract §5; SIGGRAPH 2023 course "the path of water" §7.4):
//!
//! * **Bubbles** (`TideBubbleAPI`): an air bubble sitting on water, flattened underneath. In the
//!   bubble's frame (its orientation; +Y up) with horizontal radius r, height h₁ above the
//!   equator and depth h₂ below it, the surface is
//!   (x² + z²)/r² + y²/h₁² = 1 for y ≥ 0 (a half ellipsoid) and
//!   (x² + z²)/r² + y⁴/h₂⁴ = 1 for y < 0 (a quartic, flat-bottomed half). Both halves and their
//!   first derivatives meet at y = 0. The upper half is intersected in closed form, the lower
//!   one by isolating the quartic's roots ([`first_root`]).
//! * **Blobbies** (`TideBlobbyAPI`): the isosurface φ = Σᵢ ψᵢ − T = 0 of kernels
//!   ψᵢ(x) = (1 − |Aᵢ(x − xᵢ)|²)³ inside |Aᵢ(x − xᵢ)| < 1, with Aᵢ = diag(1/R)·Bᵢᵀ (Bᵢ the
//!   point's orientation, R its bounding radii). The bounding radius follows from the inner
//!   radius r (the surface of an isolated blobby) and T: (1 − r²/R²)³ = T. Along a ray each
//!   kernel is a polynomial of degree 6 in t between its entry and exit, so φ is piecewise
//!   polynomial: [`Sweep`] keeps the sum as kernels enter and leave, bounds each piece by its
//!   Bernstein coefficients and isolates roots only where the bound straddles zero. Through the
//!   BVH the ray is swept in segments of a bounded number of kernels, so the work follows the
//!   kernels in front of the hit, not all those the ray would pass.
//!
//! Hits on these primitives carry their object-space normal in the hit's (u, v), octahedrally
//! encoded ([`oct_encode`]), so shading needs no second query.

use crate::math::solve_quadratic;
use glam::{Mat3, Quat, Vec3};

/// Octahedral encoding of a unit vector into [−1, 1]² ([`crate::math::oct_encode`]).
#[inline]
pub fn oct_encode(n: Vec3) -> (f32, f32) {
    let e = crate::math::oct_encode(n);
    (e.x, e.y)
}

/// The inverse of [`oct_encode`] (a unit vector).
#[inline]
pub fn oct_decode(u: f32, v: f32) -> Vec3 {
    crate::math::oct_decode(glam::Vec2::new(u, v))
}

// ------------------------------------------------------------------ polynomial roots

/// Most coefficients a polynomial here has (degree 6).
const MAX_COEFFS: usize = 7;

#[inline]
fn eval(c: &[f64], x: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &k| acc * x + k)
}

/// Derivative of the polynomial with coefficients `c` (lowest degree first).
fn derivative(c: &[f64]) -> ([f64; MAX_COEFFS], usize) {
    let mut d = [0.0; MAX_COEFFS];
    let n = c.len().saturating_sub(1);
    for k in 1..c.len() {
        d[k - 1] = c[k] * k as f64;
    }
    (d, n)
}

/// The root of `c` in [lo, hi], where c(lo) and c(hi) differ in sign: Newton steps kept
/// inside the shrinking bracket, bisection where they leave it.
fn refine(c: &[f64], mut lo: f64, mut hi: f64, mut f_lo: f64) -> f64 {
    let (d, nd) = derivative(c);
    let mut x = 0.5 * (lo + hi);
    for _ in 0..100 {
        let fx = eval(c, x);
        if fx == 0.0 {
            return x;
        }
        if (fx < 0.0) == (f_lo < 0.0) {
            lo = x;
            f_lo = fx;
        } else {
            hi = x;
        }
        if hi - lo <= 1e-13 * hi.abs().max(lo.abs()).max(1e-3) {
            break;
        }
        let dx = eval(&d[..nd], x);
        let xn = x - fx / dx;
        x = if dx != 0.0 && xn > lo && xn < hi {
            xn
        } else {
            0.5 * (lo + hi)
        };
    }
    x
}

/// Roots of `c` in [a, b] in ascending order, written to `out` (returns how many): the
/// derivative's roots split [a, b] into intervals where `c` is monotone, each holding at most one
/// root (Yuksel 2022, "High-Performance Polynomial Root Finding for Graphics"). Roots of even
/// multiplicity (touching without crossing) are found only where they fall on a split point.
fn roots(c: &[f64], a: f64, b: f64, out: &mut [f64; MAX_COEFFS]) -> usize {
    let mut n = c.len();
    while n > 0 && c[n - 1] == 0.0 {
        n -= 1;
    }
    let c = &c[..n];
    if n <= 1 {
        return 0;
    }
    if n == 2 {
        let x = -c[0] / c[1];
        if x >= a && x <= b {
            out[0] = x;
            return 1;
        }
        return 0;
    }
    let (d, nd) = derivative(c);
    let mut crit = [0.0; MAX_COEFFS];
    let nc = roots(&d[..nd], a, b, &mut crit);
    let mut count = 0;
    let mut x0 = a;
    let mut f0 = eval(c, a);
    if f0 == 0.0 {
        out[count] = a;
        count += 1;
    }
    for k in 0..=nc {
        let x1 = if k < nc { crit[k] } else { b };
        if x1 <= x0 {
            continue;
        }
        let f1 = eval(c, x1);
        if f1 == 0.0 {
            out[count] = x1;
            count += 1;
        } else if f0 != 0.0 && (f0 < 0.0) != (f1 < 0.0) {
            out[count] = refine(c, x0, x1, f0);
            count += 1;
        }
        x0 = x1;
        f0 = f1;
    }
    count
}

/// The roots of the polynomial `c` (coefficients lowest degree first, at most degree 6) in
/// [a, b], ascending, and how many there are.
pub fn roots_in(c: &[f64], a: f64, b: f64) -> ([f64; MAX_COEFFS], usize) {
    debug_assert!(c.len() <= MAX_COEFFS);
    let mut out = [0.0; MAX_COEFFS];
    let n = roots(c, a, b, &mut out);
    (out, n)
}

/// The smallest root of `c` in (a, b], if any.
pub fn first_root(c: &[f64], a: f64, b: f64) -> Option<f64> {
    let (r, n) = roots_in(c, a, b);
    r[..n].iter().copied().find(|&x| x > a)
}

/// Product of two polynomials (the result's degree must stay ≤ 6).
fn mul(a: &[f64], b: &[f64]) -> ([f64; MAX_COEFFS], usize) {
    let mut r = [0.0; MAX_COEFFS];
    let n = a.len() + b.len() - 1;
    for (i, &x) in a.iter().enumerate() {
        for (j, &y) in b.iter().enumerate() {
            r[i + j] += x * y;
        }
    }
    (r, n)
}

// ------------------------------------------------------------------ bubbles

/// One bubble in object space.
#[derive(Clone, Copy, Debug)]
pub struct Bubble {
    pub center: Vec3,
    /// Horizontal radius.
    pub r: f32,
    /// Height above the equator (h₁) and depth below it (h₂).
    pub top: f32,
    pub bottom: f32,
    /// The bubble's frame (+Y up).
    pub rot: Quat,
}

impl Bubble {
    /// The radius of a sphere about the centre that holds the bubble.
    pub fn bounding_radius(&self) -> f32 {
        self.r.max(self.top).max(self.bottom)
    }

    /// The implicit function in the bubble's frame (negative inside).
    pub fn value_local(&self, p: Vec3) -> f32 {
        let h = (p.x * p.x + p.z * p.z) / (self.r * self.r);
        if p.y >= 0.0 {
            h + (p.y / self.top).powi(2) - 1.0
        } else {
            h + (p.y / self.bottom).powi(4) - 1.0
        }
    }

    /// Outward normal (object space) at a point on or near the surface.
    pub fn normal(&self, p: Vec3) -> Vec3 {
        let l = self.rot.inverse() * (p - self.center);
        let gy = if l.y >= 0.0 {
            l.y / (self.top * self.top)
        } else {
            2.0 * l.y.powi(3) / self.bottom.powi(4)
        };
        let g = Vec3::new(l.x / (self.r * self.r), gy, l.z / (self.r * self.r));
        (self.rot * g).normalize_or_zero()
    }

    /// The nearest hit in (t_min, t_max) of the ray o + t·d (object space; d need not be unit).
    pub fn intersect(&self, o: Vec3, d: Vec3, t_min: f32, t_max: f32) -> Option<f32> {
        let inv = self.rot.inverse();
        let lo = (inv * (o - self.center)).as_dvec3();
        let ld = (inv * d).as_dvec3();
        let (r, h1, h2) = (self.r as f64, self.top as f64, self.bottom as f64);
        let (t_min, t_max) = (t_min as f64, t_max as f64);
        let mut best = f64::INFINITY;
        // upper half: a unit sphere in (x/r, y/h1, z/r), roots with y ≥ 0
        {
            let s = glam::DVec3::new(1.0 / r, 1.0 / h1, 1.0 / r);
            let (so, sd) = (lo * s, ld * s);
            if let Some((t0, t1)) = solve_quadratic(sd.length_squared(), 2.0 * so.dot(sd), so.length_squared() - 1.0) {
                for t in [t0, t1] {
                    if t > t_min && t < t_max && t < best && lo.y + t * ld.y >= 0.0 {
                        best = t;
                        break;
                    }
                }
            }
        }
        // lower half: X² + Z² + Y⁴ = 1 in (x/r, y/h2, z/r), roots with y < 0, searched only
        // where the ray is inside the half's bounding box (−1 ≤ Y < 0)
        {
            let s = glam::DVec3::new(1.0 / r, 1.0 / h2, 1.0 / r);
            let (so, sd) = (lo * s, ld * s);
            // (with a margin below, so that the bottom's apex is inside the interval)
            let (mut a, mut b) = (t_min, t_max.min(best));
            const LOW: f64 = -1.0 - 1e-3;
            if sd.y != 0.0 {
                let (ya, yb) = ((LOW - so.y) / sd.y, (0.0 - so.y) / sd.y);
                a = a.max(ya.min(yb));
                b = b.min(ya.max(yb));
            } else if !(so.y >= LOW && so.y < 0.0) {
                b = a; // parallel to the slab and outside it
            }
            // and inside the cylinder X² + Z² ≤ 1 (with a margin)
            let ca = sd.x * sd.x + sd.z * sd.z;
            let cb = so.x * sd.x + so.z * sd.z;
            let cc = so.x * so.x + so.z * so.z - (1.0 + 1e-3);
            if ca > 0.0 {
                let disc = cb * cb - ca * cc;
                if disc < 0.0 {
                    b = a;
                } else {
                    let sq = disc.sqrt();
                    a = a.max((-cb - sq) / ca);
                    b = b.min((-cb + sq) / ca);
                }
            } else if cc > 0.0 {
                b = a;
            }
            if a < b {
                // shift to the interval's start for conditioning: t = a + u
                let (ox, oy, oz) = (so.x + a * sd.x, so.y + a * sd.y, so.z + a * sd.z);
                let (dx, dy, dz) = (sd.x, sd.y, sd.z);
                let mut c = [0.0f64; 5];
                c[0] = ox * ox + oz * oz - 1.0 + oy.powi(4);
                c[1] = 2.0 * (ox * dx + oz * dz) + 4.0 * oy.powi(3) * dy;
                c[2] = dx * dx + dz * dz + 6.0 * oy * oy * dy * dy;
                c[3] = 4.0 * oy * dy.powi(3);
                c[4] = dy.powi(4);
                let (r, n) = roots_in(&c, 0.0, b - a);
                if let Some(t) = r[..n]
                    .iter()
                    .map(|u| a + u)
                    .find(|&t| t > t_min && lo.y + t * ld.y < 0.0)
                {
                    best = best.min(t);
                }
            }
        }
        (best < t_max).then_some(best as f32)
    }
}

// ------------------------------------------------------------------ blobbies

/// The bounding radius factor R/r of a kernel for threshold T: (1 − r²/R²)³ = T.
#[inline]
pub fn blobby_bound_factor(threshold: f32) -> f32 {
    1.0 / (1.0 - threshold.clamp(1e-6, 1.0 - 1e-6).cbrt()).sqrt()
}

/// One blobby kernel at a time: centre and the map A = diag(1/R)·Bᵀ to its unit ball.
#[derive(Clone, Copy, Debug)]
pub struct Kernel {
    pub center: Vec3,
    pub a: Mat3,
}

impl Kernel {
    /// A kernel of inner radii `r · scale` along the axes of `rot`, for threshold T.
    pub fn new(center: Vec3, r: f32, scale: Vec3, rot: Quat, threshold: f32) -> Kernel {
        let big = r * scale * blobby_bound_factor(threshold);
        let b = Mat3::from_quat(rot);
        Kernel {
            center,
            a: Mat3::from_diagonal(big.recip()) * b.transpose(),
        }
    }

    #[inline]
    fn q(&self, p: Vec3) -> f32 {
        (self.a * (p - self.center)).length_squared()
    }

    /// ψ at p.
    #[inline]
    pub fn psi(&self, p: Vec3) -> f32 {
        let q = self.q(p);
        if q < 1.0 {
            (1.0 - q).powi(3)
        } else {
            0.0
        }
    }

    /// ∇ψ at p.
    #[inline]
    fn grad(&self, p: Vec3) -> Vec3 {
        let w = p - self.center;
        let q = (self.a * w).length_squared();
        if q >= 1.0 {
            return Vec3::ZERO;
        }
        // ψ = (1 − q)³, ∇q = 2 AᵀA w
        (self.a.transpose() * (self.a * w)) * (-6.0 * (1.0 - q) * (1.0 - q))
    }

    /// The kernel's stretch of the ray o + t·d (None where the ray misses its support);
    /// `key` is the caller's name for the kernel.
    #[inline]
    pub fn span(&self, o: Vec3, d: Vec3, key: usize) -> Option<Span> {
        let v = self.center - o;
        let ts = v.dot(d) * (1.0 / d.length_squared());
        self.span_near(ts, d * ts - v, d, key)
    }

    /// [`Self::span`] from the ray's closest approach to the centre: its distance `ts` along
    /// the ray and the offset `p` of that point from the centre. Only that small offset goes
    /// through A, so q's vertex form (γ·(t − t_m)² + q_m) keeps the kernel's precision however far
    /// the origin is (the closest approach itself carries the ray's).
    #[inline]
    pub fn span_near(&self, ts: f32, p: Vec3, d: Vec3, key: usize) -> Option<Span> {
        let w = self.a * p;
        let e = self.a * d;
        let ga = e.length_squared();
        if !(ga > 0.0) || !ga.is_finite() {
            return None;
        }
        let s = w.dot(e) / ga;
        let qm = (w - e * s).length_squared() as f64;
        if !(qm < 1.0) {
            return None;
        }
        let (tm, ga) = (ts as f64 - s as f64, ga as f64);
        let half = ((1.0 - qm) / ga).sqrt();
        Some(Span { t0: tm - half, t1: tm + half, key, tm, qm, ga })
    }
}

/// A kernel's stretch of a ray, where its ψ is not zero: q(t) = γ·(t − t_m)² + q_m < 1 for
/// t0 < t < t1.
#[derive(Clone, Copy, Debug)]
pub struct Span {
    pub t0: f64,
    pub t1: f64,
    /// The caller's name for the kernel.
    pub key: usize,
    tm: f64,
    qm: f64,
    ga: f64,
}

impl Span {
    /// Where the ray enters the kernel's level set q ≤ `level` (None if it misses it).
    #[inline]
    pub fn entry(&self, level: f32) -> Option<f64> {
        (self.qm <= level as f64).then(|| self.tm - ((level as f64 - self.qm) / self.ga).sqrt())
    }

    /// ψ(r + u) as a polynomial in u (lowest degree first).
    #[inline]
    fn psi_about(&self, r: f64) -> [f64; MAX_COEFFS] {
        let x = r - self.tm;
        let w = [1.0 - (self.ga * x * x + self.qm), -2.0 * self.ga * x, -self.ga];
        let (w2, n2) = mul(&w, &w);
        mul(&w2[..n2], &w).0
    }
}

/// A span ordered for a max-heap: by entry (then key) with `BY_EXIT = false`, the latest entry
/// on top (a blobby ray's gathering); reversed by exit (then key) with `BY_EXIT = true`, the first
/// to leave on top (the sweep's active set).
pub struct Ordered<const BY_EXIT: bool>(pub Span);

/// The sweep's active set's order.
type Leaving = Ordered<true>;

/// The order of the kernels given to [`Sweep::advance`] (sorted ascending: by entry, then key).
pub type Entering = Ordered<false>;

impl<const BY_EXIT: bool> PartialEq for Ordered<BY_EXIT> {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == std::cmp::Ordering::Equal
    }
}
impl<const BY_EXIT: bool> Eq for Ordered<BY_EXIT> {}
impl<const BY_EXIT: bool> PartialOrd for Ordered<BY_EXIT> {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}
impl<const BY_EXIT: bool> Ord for Ordered<BY_EXIT> {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        if BY_EXIT {
            other.0.t1.total_cmp(&self.0.t1).then(other.0.key.cmp(&self.0.key))
        } else {
            self.0.t0.total_cmp(&other.0.t0).then(self.0.key.cmp(&other.0.key))
        }
    }
}

/// Bernstein weights C(i, k) / C(6, k): the Bernstein coefficients of a degree-6 polynomial on
/// [0, 1] from its power coefficients (row i, column k ≤ i).
const BERNSTEIN6: [[f64; MAX_COEFFS]; MAX_COEFFS] = {
    const C6: [f64; MAX_COEFFS] = [1.0, 6.0, 15.0, 20.0, 15.0, 6.0, 1.0];
    let mut m = [[0.0; MAX_COEFFS]; MAX_COEFFS];
    let mut i = 0;
    while i < MAX_COEFFS {
        let mut k = 0;
        let mut c = 1.0; // C(i, k)
        while k <= i {
            m[i][k] = c / C6[k];
            c = c * (i - k) as f64 / (k + 1) as f64;
            k += 1;
        }
        i += 1;
    }
    m
};

/// φ = Σψ − T swept front to back along one ray.
///
/// Kernels join as the sweep passes their entry and leave at their exit; between two such
/// events φ is one polynomial of degree 6, kept as a sum about a reference point and updated
/// per event (rebuilt from the active kernels once the updates outnumber them, so rounding does
/// not pile up and the reference stays near). Each piece is first bounded by its Bernstein
/// coefficients; only a piece whose bound straddles zero has its roots isolated. The sweep can
/// be fed in segments ([`Sweep::advance`]): a caller that gathers kernels front to back with a
/// bounded buffer stops as soon as the first crossing is found.
pub struct Sweep {
    threshold: f64,
    at: f64,
    active: std::collections::BinaryHeap<Leaving>,
    reference: f64,
    poly: [f64; MAX_COEFFS],
    updates: usize,
    /// φ < 0 at the end of the last piece looked at.
    below: Option<bool>,
}

impl Sweep {
    /// A sweep standing at `start` with no kernel yet.
    pub fn new(threshold: f32, start: f64) -> Sweep {
        let mut poly = [0.0; MAX_COEFFS];
        poly[0] = -(threshold as f64);
        Sweep { threshold: threshold as f64, at: start, active: Default::default(), reference: start, poly, updates: 0, below: None }
    }

    /// Where the sweep stands.
    pub fn at(&self) -> f64 {
        self.at
    }

    /// The kernels active where the sweep stands (at a crossing it returned: those reaching it).
    pub fn active(&self) -> impl Iterator<Item = &Span> {
        self.active.iter().map(|l| &l.0)
    }

    fn add(&mut self, s: &Span, sign: f64) {
        for (c, v) in self.poly.iter_mut().zip(s.psi_about(self.reference)) {
            *c += sign * v;
        }
        self.updates += 1;
    }

    /// Adds a kernel met before where the sweep stands (its entry may lie behind it).
    pub fn enter(&mut self, s: Span) {
        if self.active.is_empty() {
            self.rebase();
        }
        self.add(&s, 1.0);
        self.active.push(Ordered(s));
    }

    /// The sum rebuilt about where the sweep stands.
    fn rebase(&mut self) {
        self.reference = self.at;
        self.poly = [0.0; MAX_COEFFS];
        self.poly[0] = -self.threshold;
        self.updates = 0;
        for l in self.active.iter() {
            for (c, v) in self.poly.iter_mut().zip(l.0.psi_about(self.reference)) {
                *c += v;
            }
        }
    }

    /// Sweeps on to `end` with `entering`: every kernel whose entry lies in [where the sweep
    /// stands, `end`), sorted ([`Entering`]: by entry) (all kernels entering earlier must have been given
    /// before). Returns the first crossing of φ = 0 beyond `t_lo`, the sweep then standing at its
    /// piece; otherwise the sweep stands at `end` with the kernels still active kept.
    pub fn advance(&mut self, entering: &[Entering], end: f64, t_lo: f64) -> Option<f64> {
        let mut next_in = 0;
        loop {
            while next_in < entering.len() && entering[next_in].0.t0 <= self.at {
                self.enter(entering[next_in].0);
                next_in += 1;
            }
            while self.active.peek().is_some_and(|l| l.0.t1 <= self.at) {
                let Ordered(s) = self.active.pop().unwrap();
                if self.active.is_empty() {
                    self.rebase();
                } else {
                    self.add(&s, -1.0);
                }
            }
            if self.at >= end {
                return None;
            }
            let mut next = end;
            if let Some(s) = entering.get(next_in) {
                next = next.min(s.0.t0);
            }
            if let Some(l) = self.active.peek() {
                next = next.min(l.0.t1);
            } else if next_in == entering.len() {
                // nothing reaches the rest of the segment: φ = −T there
                self.below = Some(self.threshold > 0.0);
                self.at = end;
                return None;
            }
            if self.active.is_empty() {
                self.below = Some(self.threshold > 0.0);
            } else if next > self.at {
                if let Some(t) = self.crossing(self.at, next, t_lo) {
                    return Some(t);
                }
            }
            self.at = next;
        }
    }

    /// The first root of the current piece's polynomial in [a, b] beyond `t_lo`.
    fn crossing(&mut self, a: f64, b: f64, t_lo: f64) -> Option<f64> {
        if self.updates > 2 * self.active.len() + 16 {
            self.rebase();
        }
        // φ(a + h·v) for v in [0, 1]: Taylor shift to a, then scale
        let mut c = self.poly;
        let shift = a - self.reference;
        for i in 0..MAX_COEFFS - 1 {
            for j in (i..MAX_COEFFS - 1).rev() {
                c[j] += shift * c[j + 1];
            }
        }
        let h = b - a;
        let mut hk = 1.0;
        for ck in c.iter_mut() {
            *ck *= hk;
            hk *= h;
        }
        let below_a = c[0] < 0.0;
        let was_below = self.below.replace(below_a);
        // a sign change between the last piece's end and this one's start (rounding at an event)
        if was_below.is_some_and(|w| w != below_a) && a > t_lo {
            return Some(a);
        }
        // the Bernstein coefficients bound φ on the piece
        let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
        for row in &BERNSTEIN6 {
            let bi: f64 = row.iter().zip(&c).map(|(w, x)| w * x).sum();
            lo = lo.min(bi);
            hi = hi.max(bi);
        }
        let end_value: f64 = c.iter().sum();
        if lo > 0.0 || hi < 0.0 {
            self.below = Some(end_value < 0.0);
            return None;
        }
        let (r, n) = roots_in(&c, 0.0, 1.0);
        if let Some(t) = r[..n].iter().map(|v| a + h * v).find(|&t| t > t_lo && t <= b) {
            return Some(t);
        }
        self.below = Some(end_value < 0.0);
        None
    }

    /// Outward unit normal (−∇φ) at p from the active kernels, and the key of the one
    /// contributing most there (the smallest key among equals).
    pub fn normal(&self, p: Vec3, kernel: impl Fn(usize) -> Kernel) -> (Vec3, usize) {
        let mut g = Vec3::ZERO;
        let (mut best, mut best_psi) = (usize::MAX, -1.0);
        for s in self.active() {
            let k = kernel(s.key);
            g += k.grad(p);
            let psi = k.psi(p);
            if psi > best_psi || (psi == best_psi && s.key < best) {
                best_psi = psi;
                best = s.key;
            }
        }
        ((-g).normalize_or_zero(), best)
    }
}

/// φ = Σψ − T at p over `kernels`.
pub fn blobby_value(kernels: &[Kernel], threshold: f32, p: Vec3) -> f32 {
    kernels.iter().map(|k| k.psi(p)).sum::<f32>() - threshold
}

/// The first crossing of φ = 0 in (t_min, t_max) along o + t·d, with the kernels the caller
/// found near the ray (any superset of those the ray passes through): (t, index into
/// `kernels` of the kernel contributing most at the hit, outward normal).
pub fn blobby_intersect(
    kernels: &[Kernel],
    threshold: f32,
    o: Vec3,
    d: Vec3,
    t_min: f32,
    t_max: f32,
) -> Option<(f32, usize, Vec3)> {
    let (t_lo, t_hi) = (t_min as f64, t_max as f64);
    let mut spans: Vec<Entering> = kernels.iter().enumerate().filter_map(|(i, k)| k.span(o, d, i)).filter(|s| s.t1 > t_lo && s.t0 < t_hi).map(Ordered).collect();
    spans.sort_unstable();
    let mut sweep = Sweep::new(threshold, t_lo);
    let t = sweep.advance(&spans, t_hi, t_lo)?;
    let (n, i) = sweep.normal(o + d * t as f32, |i| kernels[i]);
    Some((t as f32, i, n))
}
