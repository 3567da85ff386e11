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
//!   polynomial: the pieces are swept front to back and the first root of each is isolated.
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

    /// Where the ray o + t·d first enters the set q ≤ `level` (None if it misses it).
    pub fn entry(&self, o: Vec3, d: Vec3, level: f32) -> Option<f32> {
        let (al, be, ga) = self.along(o, d);
        if !(ga > 0.0) {
            return None;
        }
        solve_quadratic(ga, be, al - level as f64).map(|(t0, _)| t0 as f32)
    }

    /// q along the ray as γt² + βt + α: (α, β, γ).
    #[inline]
    fn along(&self, o: Vec3, d: Vec3) -> (f64, f64, f64) {
        let w = (self.a * (o - self.center)).as_dvec3();
        let e = (self.a * d).as_dvec3();
        (w.length_squared(), 2.0 * w.dot(e), e.length_squared())
    }
}

/// φ = Σψ − T at p over `kernels`.
pub fn blobby_value(kernels: &[Kernel], threshold: f32, p: Vec3) -> f32 {
    kernels.iter().map(|k| k.psi(p)).sum::<f32>() - threshold
}

/// Outward unit normal (−∇φ) at p and the kernel contributing most there.
pub fn blobby_normal(kernels: &[Kernel], p: Vec3) -> (Vec3, usize) {
    normal_over(kernels.iter().enumerate(), p)
}

/// [`blobby_normal`] over (index, kernel) pairs; the index returned is the pair's.
fn normal_over<'a>(kernels: impl Iterator<Item = (usize, &'a Kernel)>, p: Vec3) -> (Vec3, usize) {
    let mut g = Vec3::ZERO;
    let (mut best, mut best_psi) = (0, -1.0);
    for (i, k) in kernels {
        g += k.grad(p);
        let psi = k.psi(p);
        if psi > best_psi {
            best_psi = psi;
            best = i;
        }
    }
    ((-g).normalize_or_zero(), best)
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
    // each kernel's stretch of the ray: q(t) < 1
    let mut spans: Vec<(f64, f64, usize, (f64, f64, f64))> = Vec::with_capacity(kernels.len());
    let (t_lo, t_hi) = (t_min as f64, t_max as f64);
    for (i, k) in kernels.iter().enumerate() {
        let (al, be, ga) = k.along(o, d);
        if !(ga > 0.0) {
            continue;
        }
        let Some((t0, t1)) = solve_quadratic(ga, be, al - 1.0) else { continue };
        if t1 <= t0 || t1 <= t_lo || t0 >= t_hi {
            continue;
        }
        spans.push((t0, t1, i, (al, be, ga)));
    }
    if spans.is_empty() {
        return None;
    }
    // segment boundaries: every entry and exit inside (t_lo, t_hi)
    let mut cuts: Vec<f64> = Vec::with_capacity(2 * spans.len() + 2);
    cuts.push(t_lo);
    cuts.push(t_hi);
    for s in &spans {
        for t in [s.0, s.1] {
            if t > t_lo && t < t_hi {
                cuts.push(t);
            }
        }
    }
    cuts.sort_by(|a, b| a.total_cmp(b));
    cuts.dedup();
    spans.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut active: Vec<usize> = Vec::new();
    let mut next = 0;
    for w in cuts.windows(2) {
        let (a, b) = (w[0], w[1]);
        let mid = 0.5 * (a + b);
        active.retain(|&j| spans[j].1 > mid);
        while next < spans.len() && spans[next].0 <= mid {
            if spans[next].1 > mid {
                active.push(next);
            }
            next += 1;
        }
        if active.is_empty() {
            continue;
        }
        // bounds of φ over the piece from each kernel's q range on it (q is a convex quadratic:
        // its least value at the vertex or an end, its largest at an end): where φ cannot
        // change sign, there is no root to look for
        let (mut upper, mut lower) = (-(threshold as f64), -(threshold as f64));
        for &j in &active {
            let (al, be, ga) = spans[j].3;
            let q = |t: f64| al + be * t + ga * t * t;
            let vertex = (-be / (2.0 * ga)).clamp(a, b);
            let (qa, qb) = (q(a), q(b));
            let (q_lo, q_hi) = (q(vertex).min(qa).min(qb).max(0.0), qa.max(qb).min(1.0));
            upper += (1.0 - q_lo).powi(3);
            lower += (1.0 - q_hi).max(0.0).powi(3);
        }
        if upper < 0.0 || lower > 0.0 {
            continue;
        }
        // φ(a + u) = Σ (1 − q(a + u))³ − T
        let mut poly = [0.0f64; MAX_COEFFS];
        poly[0] = -(threshold as f64);
        for &j in &active {
            let (al, be, ga) = spans[j].3;
            let u = [1.0 - (al + be * a + ga * a * a), -(be + 2.0 * ga * a), -ga];
            let (u2, n2) = mul(&u, &u);
            let (u3, n3) = mul(&u2[..n2], &u);
            for k in 0..n3 {
                poly[k] += u3[k];
            }
        }
        let (r, n) = roots_in(&poly, 0.0, b - a);
        if let Some(t) = r[..n].iter().map(|u| a + u).find(|&t| t > t_lo) {
            if t < t_hi {
                let p = o + d * t as f32;
                let (n, k) = normal_over(active.iter().map(|&j| (spans[j].2, &kernels[spans[j].2])), p);
                return Some((t as f32, k, n));
            }
        }
    }
    None
}
