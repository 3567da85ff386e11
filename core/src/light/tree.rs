//! Many-light sampling: a tree over the lights that have a place (points, spheres, rects, disks,
//! cylinders and emissive triangles), each node bounding its lights' extent, power and the cone
//! of directions they emit into, so that next-event estimation picks a light in proportion to
//! an estimate of what it gives the shading point (Conty Estevez & Kulla 2018, "Importance
//! sampling of many lights"; the bounds and importance follow pbrt-v4's `BVHLightSampler`,
//! except that the angle between a node's emission axis and the point is taken to the node's
//! box itself, not to its bounding sphere: branches beside a spot's light pool no longer look
//! as if they reached into it).
//! Power alone picks the far bulbs of a street as often as the one overhead.
//!
//! The tree takes the share of the lights' selection weights (their power, floored as
//! [`LightSampler`] floors it) that its lights hold (moving ones bounded over the shutter); the
//! rest (infinite lights) keep being picked by weight. Descending, each node's two children are chosen in proportion
//! to their importance at the point; the probability of a light is the product along its path,
//! which [`LightTree::pmf`] retraces from the light's recorded branch bits, so multiple
//! importance sampling weighs a light reached by a BSDF ray with exactly the probability
//! [`LightTree::sample`] would have given it. Below [`MIN_TREE_LIGHTS`] such lights no tree is
//! built and selection is by weight alone, as before.
//!
//! A node's importance is zero only where none of its lights can light the point (behind every
//! one-sided emitter it holds), so no light that contributes is ever left out.

use super::{Light, LightSampleContext, LightSampler};
use crate::math::ONE_MINUS_EPSILON;
use glam::Vec3;
use std::f32::consts::PI;

/// Fewest lights with a place for which a tree is built.
pub const MIN_TREE_LIGHTS: usize = 16;

/// Directions around `w` within angle acos(`cos_theta`).
#[derive(Clone, Copy, Debug, PartialEq)]
struct Cone {
    w: Vec3,
    cos_theta: f32,
}

impl Cone {
    const ALL: Cone = Cone { w: Vec3::Z, cos_theta: -1.0 };

    /// The smallest cone holding both (pbrt-v4's `Union`).
    fn union(a: Cone, b: Cone) -> Cone {
        let (ta, tb) = (a.cos_theta.clamp(-1.0, 1.0).acos(), b.cos_theta.clamp(-1.0, 1.0).acos());
        let td = a.w.dot(b.w).clamp(-1.0, 1.0).acos();
        if (td + tb).min(PI) <= ta {
            return a;
        }
        if (td + ta).min(PI) <= tb {
            return b;
        }
        let to = (ta + td + tb) / 2.0;
        if to >= PI {
            return Cone::ALL;
        }
        let axis = a.w.cross(b.w);
        if axis.length_squared() < 1e-12 {
            return Cone::ALL;
        }
        let w = glam::Quat::from_axis_angle(axis.normalize(), to - ta) * a.w;
        Cone { w: w.normalize(), cos_theta: to.cos() }
    }
}

/// What a node knows of its lights.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Bounds {
    lo: Vec3,
    hi: Vec3,
    /// Selection weight (power).
    phi: f32,
    /// The normals of the emitters' fronts lie in this cone ...
    normals: Cone,
    /// ... and each emits within this angle of its normal (cos; 0: a hemisphere).
    cos_theta_e: f32,
    two_sided: bool,
}

impl Bounds {
    fn union(a: &Bounds, b: &Bounds) -> Bounds {
        Bounds {
            lo: a.lo.min(b.lo),
            hi: a.hi.max(b.hi),
            phi: a.phi + b.phi,
            normals: Cone::union(a.normals, b.normals),
            cos_theta_e: a.cos_theta_e.min(b.cos_theta_e),
            two_sided: a.two_sided || b.two_sided,
        }
    }

    fn centroid(&self) -> Vec3 {
        (self.lo + self.hi) * 0.5
    }

    /// The cosine of the smallest angle between a direction the lights emit along (their
    /// normals' cone) and a direction from their box to `p` (`wi` from the centroid, the box's
    /// bounding sphere seen from `p` within acos `cos_b`); at or below `cos_theta_e`, nothing
    /// of theirs reaches `p`.
    #[inline(always)]
    fn cos_p(&self, p: Vec3, wi: Vec3, cos_b: f32, sin_b: f32) -> f32 {
        let cos_o = self.normals.cos_theta;
        let sin_o = safe_sqrt(1.0 - cos_o * cos_o);
        if cos_o <= -1.0 {
            1.0
        } else {
            // first through the box's bounding sphere (pbrt-v4's bound, cheap): nothing there,
            // nothing in the box
            let mut cos_w = self.normals.w.dot(wi);
            if self.two_sided {
                cos_w = cos_w.abs();
            }
            let sin_w = safe_sqrt(1.0 - cos_w * cos_w);
            let cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, cos_o);
            let sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, cos_o);
            if cos_sub_clamped(sin_x, cos_x, sin_b, cos_b) <= self.cos_theta_e {
                return f32::NEG_INFINITY;
            }
            // then the smallest angle between the normals' axis and a direction from the box
            // itself to p (a row of spots' box seen from beside it), less the normals' spread
            let mut cos_a = max_cos_to_box(self.normals.w, p, self.lo, self.hi);
            if self.two_sided {
                cos_a = cos_a.max(max_cos_to_box(-self.normals.w, p, self.lo, self.hi));
            }
            let sin_a = safe_sqrt(1.0 - cos_a * cos_a);
            cos_sub_clamped(sin_a, cos_a, sin_o, cos_o)
        }
    }

    /// An estimate of what the lights give point `p` with normal `n` (zero: in a medium),
    /// zero only where none of them can.
    fn importance(&self, p: Vec3, n: Vec3) -> f32 {
        let pc = self.centroid();
        let d2 = p.distance_squared(pc).max((self.hi - self.lo).length() * 0.5);
        let wi = (p - pc).normalize_or_zero();
        // the cone from p holding the box (its bounding sphere)
        let r2 = (self.hi - self.lo).length_squared() * 0.25;
        let dist2 = p.distance_squared(pc);
        let cos_b = if dist2 <= r2 || (p.cmpge(self.lo).all() && p.cmple(self.hi).all()) { -1.0 } else { safe_sqrt(1.0 - r2 / dist2) };
        let sin_b = safe_sqrt(1.0 - cos_b * cos_b);
        let cos_p = self.cos_p(p, wi, cos_b, sin_b);
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        // how far inside the emission the closest direction lies: cos θp for a hemisphere
        // (θe = 90°, as pbrt-v4), and positive wherever anything is emitted, beyond 90° too
        let e = self.cos_theta_e;
        let mut importance = self.phi * (cos_p - e) / (1.0 - e) / d2;
        if n != Vec3::ZERO {
            let cos_i = wi.dot(n).abs();
            let sin_i = safe_sqrt(1.0 - cos_i * cos_i);
            importance *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
        }
        if importance.is_finite() {
            importance.max(0.0)
        } else {
            0.0
        }
    }
}

fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// cos(max(0, a − b)) from the sines and cosines of a and b.
#[inline]
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// sin(max(0, a − b)) from the sines and cosines of a and b.
#[inline]
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

/// The largest cos∠(w, p − x) over the points x of the box [lo, hi]: 1 where the ray from p
/// along −w meets the box (p inside it too), else the best over the box's twelve edges (the
/// directions within an angle of w form a convex cone, which first touches a box off the ray
/// on an edge). Along an edge v(s) = a + s·d the cosine (α + βs)/√(γ + 2δs + εs²) is
/// stationary at s = (αδ − βγ)/(βδ − αε).
fn max_cos_to_box(w: Vec3, p: Vec3, lo: Vec3, hi: Vec3) -> f32 {
    let (mut t0, mut t1) = (0.0f32, f32::INFINITY);
    for k in 0..3 {
        let d = -w[k];
        if d.abs() < 1e-12 {
            if p[k] < lo[k] || p[k] > hi[k] {
                t1 = -1.0;
            }
            continue;
        }
        let (a, b) = ((lo[k] - p[k]) / d, (hi[k] - p[k]) / d);
        t0 = t0.max(a.min(b));
        t1 = t1.min(a.max(b));
    }
    if t0 <= t1 {
        return 1.0;
    }
    // the corners, and the directions from each to p, once (each is shared by three edges)
    let corner: [Vec3; 8] = std::array::from_fn(|i| Vec3::new(if i & 1 == 0 { lo.x } else { hi.x }, if i & 2 == 0 { lo.y } else { hi.y }, if i & 4 == 0 { lo.z } else { hi.z }));
    let to_p = corner.map(|c| p - c);
    let cos_at = |v: Vec3| {
        let l = v.length();
        if l > 0.0 {
            w.dot(v) / l
        } else {
            1.0
        }
    };
    let mut best = -1.0f32;
    for i in 0..8 {
        best = best.max(cos_at(to_p[i]));
        for bit in [1usize, 2, 4] {
            if i & bit != 0 {
                continue;
            }
            let a = to_p[i];
            let d = corner[i] - corner[i | bit];
            let (al, be, ga, de, ep) = (w.dot(a), w.dot(d), a.dot(a), a.dot(d), d.dot(d));
            let den = be * de - al * ep;
            if den != 0.0 {
                let s = (al * de - be * ga) / den;
                if s > 0.0 && s < 1.0 {
                    best = best.max(cos_at(a + s * d));
                }
            }
        }
    }
    best.min(1.0)
}


/// A light's bounds over `shutter`, for a light with a place (None: it stays out of the tree).
/// Normals are the emitting fronts'; a light emitting all round, or one that moves (its front
/// may turn), has the whole sphere, except an emissive triangle that deforms on a still
/// instance or turns with its instance (its normals' cone over the shutter:
/// [`deforming_normals`], [`turning_normals`]).
/// Where a light sends its light: its extent over the shutter and the cone it emits into, as
/// the tree bounds it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmissionBounds(Bounds);

impl EmissionBounds {
    /// The bounds of `light` over `shutter` (None for lights without a place).
    pub fn of(light: &Light, shutter: (f32, f32)) -> Option<EmissionBounds> {
        light_bounds(light, 1.0, shutter).map(EmissionBounds)
    }

    /// The light's intensity towards a sphere (`center`, `radius`) relative to a light of the
    /// same power emitting alike all round: 1 for a light that does; 0 where no direction it
    /// emits along reaches the sphere from any of its points (a spot aimed away, a rect facing
    /// away); else the tree's angular estimate (cos θp − cos θe) / (1 − cos θe) over the part
    /// of the sphere it emits into, π (1 − cos θe) (twice that two-sided), so a hemisphere's
    /// cosine lobe reads 4 cos θ along θ, and a narrow spot far more along its axis.
    pub fn toward(&self, center: Vec3, radius: f32) -> f32 {
        let b = &self.0;
        if b.normals.cos_theta <= -1.0 {
            return 1.0;
        }
        // every point of the sphere seen from every point of the box: the box grown by the
        // radius seen from the centre
        let grown = Bounds { lo: b.lo - Vec3::splat(radius.max(0.0)), hi: b.hi + Vec3::splat(radius.max(0.0)), ..*b };
        let pc = grown.centroid();
        let wi = (center - pc).normalize_or_zero();
        let r2 = (grown.hi - grown.lo).length_squared() * 0.25;
        let dist2 = center.distance_squared(pc);
        let inside = dist2 <= r2 || (center.cmpge(grown.lo).all() && center.cmple(grown.hi).all());
        let cos_b = if inside { -1.0 } else { safe_sqrt(1.0 - r2 / dist2) };
        let cos_p = grown.cos_p(center, wi, cos_b, safe_sqrt(1.0 - cos_b * cos_b));
        let e = b.cos_theta_e;
        if !(cos_p > e) {
            return 0.0;
        }
        let spread = if b.two_sided { 2.0 } else { 4.0 };
        spread * (cos_p - e) / ((1.0 - e) * (1.0 - e))
    }
}

fn light_bounds(light: &Light, phi: f32, shutter: (f32, f32)) -> Option<Bounds> {
    let (lo, hi) = super::bvh::extent_over(light, shutter)?;
    // a one-sided emitter faces its front normal; the others emit all round
    let (mut normals, two_sided) = match light {
        Light::Rect(r) => (Cone { w: r.shape.n, cos_theta: 1.0 }, false),
        Light::Disk(d) => (Cone { w: d.shape.n, cos_theta: 1.0 }, false),
        Light::Triangle(t) => match &t.motion {
            None => (Cone { w: t.n, cos_theta: 1.0 }, t.two_sided),
            Some(m) => (deforming_normals(m, t.mirrored, shutter).unwrap_or(Cone::ALL), t.two_sided),
        },
        _ => (Cone::ALL, false),
    };
    let mut cos_theta_e = 0.0;
    // a shaping cone (a spot) narrows what it emits to θc about its axis: within the front's
    // hemisphere for a rect or disk facing along it, all round the axis for the others
    if let Some((axis, theta_c)) = light.shaping().and_then(|s| s.emission_cone()) {
        if normals == Cone::ALL {
            normals = Cone { w: axis, cos_theta: 1.0 };
            cos_theta_e = theta_c.cos();
        } else if normals.w.dot(axis) > 1.0 - 1e-5 {
            cos_theta_e = theta_c.min(std::f32::consts::FRAC_PI_2).cos();
        }
    }
    let ok = normals.w.is_finite() && normals.w.length_squared() > 0.5;
    ok.then_some(Bounds { lo, hi, phi, normals, cos_theta_e, two_sided })
}

/// The cone holding a deforming emissive triangle's front normal over `shutter`, or None
/// (the whole sphere) where its instance moves or the normals spread over a hemisphere.
/// Between two motion samples the world edges move linearly, so the normal e1(s) × e2(s) is a
/// quadratic Bézier curve in s whose control points are e1a × e2a, (e1a × e2b + e1b × e2a)/2
/// and e1b × e2b; with weights that are never negative it stays in the convex cone of those
/// three, which a cone narrower than a hemisphere holding them holds.
fn deforming_normals(m: &super::TriangleMotion, mirrored: bool, shutter: (f32, f32)) -> Option<Cone> {
    if m.p.is_empty() {
        return None;
    }
    if !m.xf.is_static() {
        return turning_normals(m, mirrored, shutter);
    }
    let xf = m.xf.at(shutter.0);
    let side = if mirrored { -1.0 } else { 1.0 };
    let edges = |k: usize| {
        let p = m.p[k].map(|v| xf.transform_point3(v));
        (p[1] - p[0], p[2] - p[0])
    };
    let (t0, t1) = (shutter.0.min(shutter.1), shutter.0.max(shutter.1));
    let mut controls = Vec::new();
    if m.p.len() == 1 {
        let (a, b) = edges(0);
        controls.push(a.cross(b));
    }
    for k in 0..m.p.len().saturating_sub(1) {
        // the intervals the shutter reaches (before the first sample and after the last the
        // triangle stands as at that sample, an end point of its interval)
        let reached = (m.times[k] <= t1 && m.times[k + 1] >= t0) || (k == 0 && t0 < m.times[0]) || (k + 2 == m.p.len() && t1 > m.times[k + 1]);
        if !reached {
            continue;
        }
        let ((a1, a2), (b1, b2)) = (edges(k), edges(k + 1));
        controls.extend([a1.cross(a2), 0.5 * (a1.cross(b2) + b1.cross(a2)), b1.cross(b2)]);
    }
    narrow_union(controls.into_iter().filter(|c| c.is_finite() && c.length_squared() > 0.0).map(|c| Cone { w: (side * c).normalize(), cos_theta: 1.0 }))
}

/// The cone holding `cones`, widened by a milliradian against rounding; None where it reaches
/// a hemisphere (a cap that wide does not hold the arcs between its points) or there are none.
fn narrow_union(cones: impl Iterator<Item = Cone>) -> Option<Cone> {
    let k = cones.reduce(Cone::union)?;
    let theta = k.cos_theta.clamp(-1.0, 1.0).acos() + 1e-3;
    (theta < std::f32::consts::FRAC_PI_2 - 1e-3).then(|| Cone { w: k.w, cos_theta: theta.cos() })
}

/// The cone holding the front normal over `shutter` of an emissive triangle that keeps its
/// shape on an instance that turns (None where it also deforms, or where the instance's
/// motion bends normals: [`crate::accel::motion::MotionTransform::turning_segments`]). The
/// world normal is R(t)·c, c the object normal through the scale's cofactor; between two keys
/// slerp turns c about one axis, a small-circle arc no longer than a half turn, held by the
/// cap about its middle through its ends.
fn turning_normals(m: &super::TriangleMotion, mirrored: bool, shutter: (f32, f32)) -> Option<Cone> {
    if m.p.len() != 1 {
        return None;
    }
    let (s, segments) = m.xf.turning_segments(shutter)?;
    let p = m.p[0];
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    let side = if mirrored { -1.0 } else { 1.0 };
    let c = side * Vec3::new(s.y * s.z, s.x * s.z, s.x * s.y) * n;
    if !(c.is_finite() && c.length_squared() > 0.0) {
        return None;
    }
    let c = c.normalize();
    narrow_union(segments.into_iter().map(|(a, b)| {
        let mid = (a.slerp(b, 0.5) * c).normalize();
        Cone { w: mid, cos_theta: mid.dot((a * c).normalize()).min(mid.dot((b * c).normalize())).clamp(-1.0, 1.0) }
    }))
}

#[derive(Clone, Debug, PartialEq)]
struct Node {
    bounds: Bounds,
    /// Leaf: the light; inner: the right child (the left follows the node).
    index: u32,
    leaf: bool,
}

/// Light selection for next-event estimation: the tree over the lights with a place, and
/// selection by weight for the rest.
#[derive(Clone, Debug, Default)]
pub struct LightTree {
    nodes: Vec<Node>,
    /// Per light: its branch bits from the root (bit k: right at depth k) and depth, or None
    /// where it is not in the tree.
    trail: Vec<Option<(u64, u8)>>,
    /// Probability of choosing from the tree.
    p_tree: f32,
    /// The lights outside the tree, by weight.
    rest: LightSampler,
    /// Selection by weight over every light (used when there is no tree).
    all: LightSampler,
}

impl LightTree {
    /// The tree over `lights` over `shutter` (a moving light bounded along its motion), whose
    /// selection weights `all` holds (kept: [`LightTree::by_weight`]).
    pub fn build(lights: &[Light], all: LightSampler, shutter: (f32, f32)) -> LightTree {
        let n = lights.len();
        let mut tree = LightTree { trail: vec![None; n], ..Default::default() };
        let mut items: Vec<(u32, Bounds)> = (0..n).filter_map(|i| (all.pmf(i) > 0.0).then(|| light_bounds(&lights[i], all.pmf(i), shutter).map(|b| (i as u32, b))).flatten()).collect();
        if items.len() >= MIN_TREE_LIGHTS {
            tree.p_tree = items.iter().map(|(i, _)| all.pmf(*i as usize) as f64).sum::<f64>().min(1.0) as f32;
            let mut in_tree = vec![false; n];
            for (i, _) in &items {
                in_tree[*i as usize] = true;
            }
            let rest: Vec<f32> = (0..n).map(|i| if in_tree[i] { 0.0 } else { all.pmf(i) }).collect();
            tree.rest = LightSampler::from_powers(&rest);
            tree.nodes.reserve(2 * items.len());
            tree.build_node(&mut items, 0, 0);
        }
        tree.all = all;
        tree
    }

    /// Selection by weight alone over every light (what the tree falls back to below
    /// MIN_TREE_LIGHTS lights with a place).
    pub fn by_weight(&self) -> &LightSampler {
        &self.all
    }

    fn build_node(&mut self, items: &mut [(u32, Bounds)], bits: u64, depth: u8) -> usize {
        let at = self.nodes.len();
        if items.len() == 1 {
            // one light a leaf
            let (li, b) = items[0];
            self.nodes.push(Node { bounds: b, index: li, leaf: true });
            self.trail[li as usize] = Some((bits, depth));
            return at;
        }
        let bounds = items[1..].iter().fold(items[0].1, |acc, (_, b)| Bounds::union(&acc, b));
        self.nodes.push(Node { bounds, index: 0, leaf: false });
        let mid = split(items, depth >= 32);
        let (left, right) = items.split_at_mut(mid);
        self.build_node(left, bits, depth + 1);
        let r = self.build_node(right, bits | 1 << depth, depth + 1);
        self.nodes[at].index = r as u32;
        at
    }

    /// Whether selection uses the tree (else it is by weight alone).
    pub fn has_tree(&self) -> bool {
        !self.nodes.is_empty()
    }

    /// Picks a light for the point of `ctx` with `u` in [0, 1): (light, its probability).
    pub fn sample(&self, ctx: &LightSampleContext, u: f32) -> Option<(usize, f32)> {
        if self.nodes.is_empty() {
            return self.all.sample(u);
        }
        if u >= self.p_tree {
            let p_rest = 1.0 - self.p_tree;
            let (li, p) = self.rest.sample(((u - self.p_tree) / p_rest).min(ONE_MINUS_EPSILON))?;
            return Some((li, p * p_rest));
        }
        let mut u = (u / self.p_tree).min(ONE_MINUS_EPSILON);
        let mut pmf = self.p_tree;
        let mut node = 0usize;
        if !(self.nodes[0].bounds.importance(ctx.p, ctx.n) > 0.0) {
            return None;
        }
        loop {
            let nd = &self.nodes[node];
            if nd.leaf {
                return (pmf > 0.0).then_some((nd.index as usize, pmf));
            }
            let (l, r) = (node + 1, nd.index as usize);
            let pl = self.p_left(l, r, ctx)?;
            if u < pl {
                u = (u / pl).min(ONE_MINUS_EPSILON);
                pmf *= pl;
                node = l;
            } else {
                u = ((u - pl) / (1.0 - pl)).min(ONE_MINUS_EPSILON);
                pmf *= 1.0 - pl;
                node = r;
            }
        }
    }

    /// Probability of the left child of an inner node (None: neither child lights the point).
    #[inline]
    fn p_left(&self, l: usize, r: usize, ctx: &LightSampleContext) -> Option<f32> {
        let il = self.nodes[l].bounds.importance(ctx.p, ctx.n);
        let ir = self.nodes[r].bounds.importance(ctx.p, ctx.n);
        (il + ir > 0.0).then(|| il / (il + ir))
    }

    /// Probability that [`LightTree::sample`] picks light `li` for the point of `ctx`.
    pub fn pmf(&self, ctx: &LightSampleContext, li: usize) -> f32 {
        if self.nodes.is_empty() {
            return self.all.pmf(li);
        }
        let Some((bits, depth)) = self.trail.get(li).copied().flatten() else {
            return self.rest.pmf(li) * (1.0 - self.p_tree);
        };
        if !(self.nodes[0].bounds.importance(ctx.p, ctx.n) > 0.0) {
            return 0.0;
        }
        let mut pmf = self.p_tree;
        let mut node = 0usize;
        for k in 0..depth {
            let (l, r) = (node + 1, self.nodes[node].index as usize);
            let Some(pl) = self.p_left(l, r, ctx) else { return 0.0 };
            if bits >> k & 1 == 0 {
                pmf *= pl;
                node = l;
            } else {
                pmf *= 1.0 - pl;
                node = r;
            }
        }
        pmf
    }
}

/// pbrt-v4's orientation measure of a bounds' emission (the solid angle its cone and spread
/// reach, weighted by cosine).
fn orientation_measure(b: &Bounds) -> f32 {
    let theta_o = b.normals.cos_theta.clamp(-1.0, 1.0).acos();
    let theta_e = b.cos_theta_e.clamp(-1.0, 1.0).acos();
    let theta_w = (theta_o + theta_e).min(PI);
    let (sin_o, cos_o) = theta_o.sin_cos();
    2.0 * PI * (1.0 - cos_o) + PI / 2.0 * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o + cos_o)
}

fn surface_area(b: &Bounds) -> f32 {
    let d = (b.hi - b.lo).max(Vec3::ZERO);
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

/// Reorders `items` and returns where to split them (1 ..= len − 1): the bucket boundary along
/// the centroids' widest axis of least power × area × orientation cost, or the median where the
/// centroids coincide or a `balanced` split is asked for (deep in the tree: its depth stays
/// under 64 whatever the lights' spacing).
fn split(items: &mut [(u32, Bounds)], balanced: bool) -> usize {
    const BUCKETS: usize = 12;
    let (clo, chi) = items.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), (_, b)| (lo.min(b.centroid()), hi.max(b.centroid())));
    let ext = chi - clo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z { 0 } else if ext.y >= ext.z { 1 } else { 2 };
    let key = |b: &Bounds| b.centroid()[axis];
    // ties by light index: the same tree on every run
    let order = |a: &(u32, Bounds), b: &(u32, Bounds)| key(&a.1).total_cmp(&key(&b.1)).then(a.0.cmp(&b.0));
    if balanced || !(ext[axis] > 0.0) {
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, order);
        return mid;
    }
    let bucket = |b: &Bounds| (((key(b) - clo[axis]) / ext[axis] * BUCKETS as f32) as usize).min(BUCKETS - 1);
    let mut buckets: [Option<Bounds>; BUCKETS] = [None; BUCKETS];
    for (_, b) in items.iter() {
        let k = bucket(b);
        buckets[k] = Some(buckets[k].map_or(*b, |x| Bounds::union(&x, b)));
    }
    let cost = |b: &Option<Bounds>| b.map_or(0.0, |b| b.phi as f64 * surface_area(&b) as f64 * orientation_measure(&b) as f64);
    let mut best = (f64::INFINITY, 0usize);
    for s in 1..BUCKETS {
        let merge = |r: &[Option<Bounds>]| r.iter().flatten().fold(None, |acc: Option<Bounds>, b| Some(acc.map_or(*b, |a| Bounds::union(&a, b))));
        let (l, r) = (merge(&buckets[..s]), merge(&buckets[s..]));
        if l.is_none() || r.is_none() {
            continue;
        }
        let c = cost(&l) + cost(&r);
        if c < best.0 {
            best = (c, s);
        }
    }
    if !best.0.is_finite() {
        let mid = items.len() / 2;
        items.select_nth_unstable_by(mid, order);
        return mid;
    }
    // the lights of the buckets below the split first (in place, in linear time)
    let mut mid = 0;
    for k in 0..items.len() {
        if bucket(&items[k].1) < best.1 {
            items.swap(k, mid);
            mid += 1;
        }
    }
    mid
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::tests::{build, desc, lambda};
    use crate::scene::LightShape;
    use crate::testing::chi2::{gamma_q, TestRng};
    use glam::{Mat4, Quat, Vec2, Vec4};

    /// Points, spheres, rects, disks and cylinders scattered and turned every way, a third of
    /// them spots (a shaping cone of 10° to 170°, soft or hard), moving lights (a sphere, a
    /// point, a turning rect, a deforming emissive triangle and one on a turning instance: in
    /// the tree, bounded over the shutter) and a dome (picked by weight, outside the tree).
    fn crowd() -> Vec<Light> {
        let mut rng = TestRng::new(3);
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let mut lights = Vec::new();
        for k in 0..60 {
            let shape = match k % 5 {
                0 => LightShape::Sphere { radius: r(0.05, 0.5), treat_as_point: false },
                1 => LightShape::Rect { width: r(0.2, 2.0), height: r(0.2, 2.0), texture: None },
                2 => LightShape::Disk { radius: r(0.1, 1.0) },
                3 => LightShape::Cylinder { radius: r(0.05, 0.2), length: r(0.3, 2.0), treat_as_line: false },
                _ => LightShape::Sphere { radius: 0.0, treat_as_point: true },
            };
            let axis = Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0)).normalize_or(Vec3::Y);
            let m = Mat4::from_rotation_translation(Quat::from_axis_angle(axis, r(0.0, 6.0)), Vec3::new(r(-8.0, 8.0), r(-8.0, 8.0), r(-8.0, 8.0)));
            let mut d = desc(shape, m);
            d.intensity = r(0.5, 20.0);
            if k % 3 == 0 {
                d.shaping = Some(crate::scene::ShapingDesc { cone_angle_deg: r(10.0, 170.0), cone_softness: if k % 2 == 0 { 0.0 } else { r(0.0, 1.0) }, ..Default::default() });
            }
            lights.push(build(&d));
        }
        lights.push(build(&desc(LightShape::Dome { texture: None }, Mat4::IDENTITY)));
        let mut d = desc(LightShape::Sphere { radius: 0.3, treat_as_point: false }, Mat4::from_translation(Vec3::new(1.0, 2.0, 3.0)));
        d.motion = vec![(0.0, d.transform), (1.0, Mat4::from_translation(Vec3::new(2.0, 2.0, 3.0)))];
        lights.push(build(&d));
        let mut d = desc(LightShape::Sphere { radius: 0.0, treat_as_point: true }, Mat4::from_translation(Vec3::new(-4.0, 0.0, 2.0)));
        d.motion = vec![(0.0, d.transform), (1.0, Mat4::from_translation(Vec3::new(-1.0, 3.0, 2.0)))];
        lights.push(build(&d));
        let mut d = desc(LightShape::Rect { width: 1.0, height: 0.5, texture: None }, Mat4::from_translation(Vec3::new(5.0, -3.0, 0.0)));
        d.motion = vec![(0.0, d.transform), (1.0, Mat4::from_rotation_translation(Quat::from_rotation_x(2.5), Vec3::new(5.0, -2.0, 1.0)))];
        lights.push(build(&d));
        // emissive triangles moving over the shutter: one deforming (three samples, the middle
        // one off the line between the others and turned), one carried by a turning instance
        let em = crate::spectrum::Spectrum::Constant(2.0);
        let xf = |m: &[Mat4], t: &[f32]| std::sync::Arc::new(crate::accel::motion::MotionTransform::new(m, t));
        let tri = |c: Vec3| [c, c + Vec3::X, c + Vec3::new(0.0, 0.5, 0.8)];
        let tilted = |c: Vec3| [c, c + Vec3::new(1.0, 0.3, 0.0), c + Vec3::new(-0.2, 0.9, 0.4)];
        let deform = crate::light::TriangleMotion { times: vec![0.0, 0.4, 1.0], p: vec![tri(Vec3::new(-6.0, 1.0, 0.0)), tilted(Vec3::new(-5.0, 4.0, 1.0)), tri(Vec3::new(-6.0, 1.5, 0.5))], xf: xf(&[Mat4::IDENTITY], &[0.0]) };
        lights.push(Light::moving_triangle(deform, 0.0, em.clone(), false).unwrap());
        let turn = crate::light::TriangleMotion { times: vec![0.0], p: vec![tri(Vec3::new(2.0, 0.0, 0.0))], xf: xf(&[Mat4::IDENTITY, Mat4::from_rotation_y(3.0)], &[0.0, 1.0]) };
        lights.push(Light::moving_triangle(turn, 0.0, em, true).unwrap());
        lights
    }

    fn moves(light: &Light) -> bool {
        matches!(light, Light::Moving(_)) || matches!(light, Light::Triangle(t) if t.motion.is_some())
    }

    fn contexts() -> Vec<LightSampleContext> {
        vec![
            LightSampleContext::new(Vec3::ZERO, Vec3::Y),
            LightSampleContext::new(Vec3::new(3.0, -2.0, 1.0), Vec3::new(1.0, 1.0, 0.0).normalize()),
            LightSampleContext::new(Vec3::new(-7.0, 7.0, -7.0), -Vec3::Z),
            LightSampleContext::new(Vec3::new(20.0, 0.0, 0.0), Vec3::X),
            // in a medium: no normal
            LightSampleContext::new(Vec3::new(0.5, 0.5, 0.5), Vec3::ZERO),
            LightSampleContext::new(Vec3::new(0.0, 30.0, 0.0), Vec3::ZERO),
        ]
    }

    /// At every point the frequencies of the picks follow `pmf` (χ²), each pick reports the
    /// probability `pmf` gives it, and the probabilities and the share of no pick sum to 1.
    #[test]
    fn picks_follow_the_pmf_that_multiple_importance_sampling_reads() {
        let lights = crowd();
        let all = LightSampler::new(&lights);
        let tree = LightTree::build(&lights, all.clone(), (0.0, 1.0));
        assert!(tree.has_tree());
        let n = lights.len();
        let moving: Vec<usize> = (0..n).filter(|&i| moves(&lights[i])).collect();
        assert!(moving.len() == 5 && moving.iter().all(|&i| tree.trail[i].is_some()), "moving lights in the tree");
        let contexts = contexts();
        for (c, ctx) in contexts.iter().enumerate() {
            let pmf: Vec<f64> = (0..n).map(|li| tree.pmf(ctx, li) as f64).collect();
            let total: f64 = pmf.iter().sum();
            assert!(total > 0.5 && total < 1.0 + 1e-5, "context {c}: Σ pmf = {total}");
            let draws = 200_000;
            let mut counts = vec![0f64; n];
            let mut none = 0f64;
            let mut rng = TestRng::new(100 + c as u64);
            for _ in 0..draws {
                match tree.sample(ctx, rng.next_f32()) {
                    Some((li, p)) => {
                        assert_eq!(p, tree.pmf(ctx, li), "context {c}, light {li}");
                        counts[li] += 1.0;
                    }
                    None => none += 1.0,
                }
            }
            let (mut stat, mut dof) = (0.0, 0);
            for li in 0..n {
                let e = draws as f64 * pmf[li];
                if e == 0.0 {
                    assert_eq!(counts[li], 0.0, "context {c}: light {li} of pmf 0 picked");
                    continue;
                }
                stat += (counts[li] - e).powi(2) / e;
                dof += 1;
            }
            let e_none = draws as f64 * (1.0 - total).max(0.0);
            if e_none > 0.5 {
                stat += (none - e_none).powi(2) / e_none;
                dof += 1;
            } else {
                assert!(none <= 3.0, "context {c}: {none} draws picked nothing");
            }
            // six seeded runs at 1e-4 each (Šidák)
            let p = gamma_q((dof - 1) as f64 / 2.0, stat / 2.0);
            assert!(p > 1e-4, "context {c}: χ² = {stat} over {dof} cells (p = {p})");
        }
    }

    /// A light that gives a point anything has a nonzero probability there: samples on each
    /// light whose radiance reaches the point from the side of its normal (or any side, in a
    /// medium) find it pickable.
    #[test]
    fn no_light_that_lights_a_point_is_left_out() {
        let lights = crowd();
        let all = LightSampler::new(&lights);
        let tree = LightTree::build(&lights, all.clone(), (0.0, 1.0));
        let lam = lambda();
        let mut rng = TestRng::new(9);
        let mut checked = 0;
        for k in 0..400 {
            let p = Vec3::new(rng.next_f32() * 24.0 - 12.0, rng.next_f32() * 24.0 - 12.0, rng.next_f32() * 24.0 - 12.0);
            let n = if k % 4 == 0 { Vec3::ZERO } else { Vec3::new(rng.next_f32() - 0.5, rng.next_f32() - 0.5, rng.next_f32() - 0.5).normalize_or(Vec3::Y) };
            // at any time of the shutter: a moving light is bounded over all of it
            let ctx = LightSampleContext { time: rng.next_f32(), ..LightSampleContext::new(p, n) };
            for (li, light) in lights.iter().enumerate() {
                for _ in 0..4 {
                    let u = Vec2::new(rng.next_f32(), rng.next_f32());
                    let Some(ls) = light.sample_li(&ctx, u, &lam) else { continue };
                    if ls.l.is_black() || !(ls.pdf > 0.0) || (n != Vec3::ZERO && ls.wi.dot(n).abs() < 1e-4) {
                        continue;
                    }
                    checked += 1;
                    assert!(tree.pmf(&ctx, li) > 0.0, "light {li} lights {p} (normal {n}) but cannot be picked");
                }
            }
        }
        assert!(checked > 20_000, "{checked}");
    }

    /// 64 spots on a grid 4 apart, 5 above a floor, each lighting a disc of radius 1.34 below
    /// it (15° cones; points, spheres, disks, rects and cylinders alike): a point under one
    /// spot picks that spot always, and never another, which cannot light it (no branch whose
    /// box lies beyond the cones' reach is taken: seen through the box's bounding sphere, the
    /// neighbours' branches took 0.36 to 0.5 of the picks, and none of them lights the point).
    #[test]
    fn a_spot_pointing_elsewhere_is_not_picked() {
        let shapes = [
            LightShape::Sphere { radius: 0.0, treat_as_point: true },
            LightShape::Sphere { radius: 0.1, treat_as_point: false },
            LightShape::Disk { radius: 0.2 },
            LightShape::Rect { width: 0.3, height: 0.3, texture: None },
            LightShape::Cylinder { radius: 0.05, length: 0.3, treat_as_line: false },
        ];
        let mut lights = Vec::new();
        for k in 0..64 {
            let at = Vec3::new(4.0 * (k % 8) as f32, 5.0, 4.0 * (k / 8) as f32);
            // the light's −Z (its axis) turned to point down
            let mut d = desc(shapes[k % shapes.len()].clone(), Mat4::from_rotation_translation(Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2), at));
            d.shaping = Some(crate::scene::ShapingDesc { cone_angle_deg: 15.0, ..Default::default() });
            lights.push(build(&d));
        }
        let tree = LightTree::build(&lights, LightSampler::new(&lights), (0.0, 1.0));
        for k in [0usize, 9, 27, 63] {
            let below = Vec3::new(4.0 * (k % 8) as f32 + 0.3, 0.0, 4.0 * (k / 8) as f32 - 0.2);
            let ctx = LightSampleContext::new(below, Vec3::Y);
            assert_eq!(tree.pmf(&ctx, k), 1.0, "spot {k}");
            let others: f32 = (0..64).filter(|&j| j != k).map(|j| tree.pmf(&ctx, j)).sum();
            assert_eq!(others, 0.0, "spot {k}");
        }
    }

    /// The box's nearest direction to an axis, against a search over the box's faces (3 000
    /// random boxes, points and axes; each face on a grid refined about its best point, in
    /// f64): never below it (a light left out), above it by no more than 1e-4; 1 only where
    /// the ray from p along −w meets the box.
    #[test]
    fn the_nearest_direction_to_a_box_is_found_on_its_edges() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let (mut hits, mut tight) = (0, 0);
        for _ in 0..3000 {
            let c = Vec3::new(next(), next(), next()) * 4.0 - 2.0;
            let e = Vec3::new(next(), next() * 0.2, next()) * if next() < 0.3 { 0.05 } else { 1.0 };
            let (lo, hi) = (c - e, c + e);
            let p = Vec3::new(next(), next(), next()) * 10.0 - 5.0;
            let mut w = Vec3::new(next() - 0.5, next() - 0.5, next() - 0.5).normalize();
            if next() < 0.25 {
                // an axis from a point of the box to p: the ray along −w meets the box
                let x = lo + Vec3::new(next(), next(), next()) * (hi - lo);
                w = (p - x).normalize();
            }
            let got = max_cos_to_box(w, p, lo, hi);
            // each face searched on a 32² grid, then three times again on a 32² grid about its
            // best point, one former cell each way
            let n = 32;
            let mut best = -1.0f64;
            for face in 0..6 {
                let (k, side) = (face / 2, face % 2);
                let (a, b) = ((k + 1) % 3, (k + 2) % 3);
                let cos_at = |u: f64, v: f64| {
                    let mut x = [0.0f64; 3];
                    x[k] = if side == 0 { lo[k] } else { hi[k] } as f64;
                    x[a] = lo[a] as f64 + u * (hi[a] - lo[a]) as f64;
                    x[b] = lo[b] as f64 + v * (hi[b] - lo[b]) as f64;
                    let d = [p.x as f64 - x[0], p.y as f64 - x[1], p.z as f64 - x[2]];
                    let l = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
                    if l > 0.0 {
                        (w.x as f64 * d[0] + w.y as f64 * d[1] + w.z as f64 * d[2]) / l
                    } else {
                        1.0
                    }
                };
                let (mut cu, mut cv, mut span) = (0.5f64, 0.5f64, 1.0f64);
                for _ in 0..4 {
                    let (mut bu, mut bv, mut bc) = (cu, cv, -2.0f64);
                    for i in 0..=n {
                        for j in 0..=n {
                            let u = (cu - span / 2.0 + span * i as f64 / n as f64).clamp(0.0, 1.0);
                            let v = (cv - span / 2.0 + span * j as f64 / n as f64).clamp(0.0, 1.0);
                            let c = cos_at(u, v);
                            if c > bc {
                                (bu, bv, bc) = (u, v, c);
                            }
                        }
                    }
                    best = best.max(bc);
                    (cu, cv, span) = (bu, bv, span * 2.0 / n as f64);
                }
            }
            assert!(got as f64 >= best - 1e-5, "box {lo}..{hi}, p {p}, w {w}: {got} below {best}");
            if got == 1.0 {
                // the ray meets the box: check it does
                let t = (0..3).filter(|&k| w[k] != 0.0).flat_map(|k| [(lo[k] - p[k]) / -w[k], (hi[k] - p[k]) / -w[k]]);
                assert!(t.filter(|&t| t >= 0.0).any(|t| {
                    let x = p - t * w;
                    x.cmpge(lo - 1e-4).all() && x.cmple(hi + 1e-4).all()
                }), "box {lo}..{hi}, p {p}, w {w}: 1 without the ray meeting the box");
                hits += 1;
                continue;
            }
            // off the ray the refined search comes within rounding of the edges' best
            assert!((got as f64) <= best + 1e-4, "box {lo}..{hi}, p {p}, w {w}: {got} above {best}");
            tight += 1;
        }
        assert!(hits > 500 && tight > 1800, "{hits} {tight}");
    }

    /// A deforming emissive triangle's normal cone over the shutter holds its normal at 20 001
    /// times (the normal turning 75° and back, through samples at 0, 0.3, 0.7 and 1; the
    /// shutter taking all of them, or only the first two) and is narrower than a hemisphere; so
    /// for random deformations, and for random turns of instances scaled alike at each key,
    /// whose cones are narrower than a hemisphere; a triangle that both turns and deforms, or
    /// one on a sheared instance, takes the whole sphere.
    #[test]
    fn a_deforming_triangles_normals_are_bounded_over_the_shutter() {
        let xf = |m: &[Mat4], t: &[f32]| std::sync::Arc::new(crate::accel::motion::MotionTransform::new(m, t));
        let turned = |a: f32, c: Vec3| {
            let r = Quat::from_rotation_x(a) * Quat::from_rotation_z(0.3 * a);
            [c, c + r * Vec3::X, c + r * Vec3::new(0.3, 1.0, 0.0)]
        };
        let p = vec![turned(0.0, Vec3::ZERO), turned(0.9, Vec3::new(1.0, 0.0, 0.5)), turned(1.3, Vec3::new(0.5, 1.0, 0.0)), turned(0.2, Vec3::Y)];
        let em = crate::spectrum::Spectrum::Constant(1.0);
        for mirrored in [false, true] {
            for shutter in [(0.0f32, 1.0f32), (-0.5, 0.45), (0.1, 0.2)] {
                let m = crate::light::TriangleMotion { times: vec![0.0, 0.3, 0.7, 1.0], p: p.clone(), xf: xf(&[Mat4::IDENTITY], &[0.0]) };
                let mut light = Light::moving_triangle(m, shutter.0, em.clone(), false).unwrap();
                if let Light::Triangle(t) = &mut light {
                    t.mirrored = mirrored;
                }
                let b = light_bounds(&light, 1.0, shutter).unwrap();
                assert!(b.normals.cos_theta > 0.0, "{shutter:?}: {:?}", b.normals);
                let Light::Triangle(t) = &light else { unreachable!() };
                for k in 0..=20_000 {
                    let time = shutter.0 + (shutter.1 - shutter.0) * k as f32 / 20_000.0;
                    let (_, n, _) = t.at_time(time).unwrap();
                    assert!(n.dot(b.normals.w) >= b.normals.cos_theta - 1e-6, "{shutter:?} at {time}: {n} outside {:?}", b.normals);
                }
            }
        }
        // random deformations: each sample's vertices moved up to 0.6 from a unit triangle's
        let mut state = 0x853c_49e6_748f_ea9bu64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5
        };
        // a light's cone over the whole shutter holds its normal at 2001 times; whether it is
        // narrower than the whole sphere
        let held = |m: crate::light::TriangleMotion, case: usize| {
            let Some(light) = Light::moving_triangle(m, 0.0, em.clone(), false) else { return false };
            let b = light_bounds(&light, 1.0, (0.0, 1.0)).unwrap();
            let Light::Triangle(t) = &light else { unreachable!() };
            for k in 0..=2000 {
                if let Some((_, n, _)) = t.at_time(k as f32 / 2000.0) {
                    assert!(n.dot(b.normals.w) >= b.normals.cos_theta - 1e-6, "case {case}: {n} outside {:?}", b.normals);
                }
            }
            b.normals != Cone::ALL
        };
        let mut narrow = 0;
        for case in 0..300 {
            let base = [Vec3::ZERO, Vec3::X, Vec3::Y];
            let keys: Vec<[Vec3; 3]> = (0..3).map(|_| base.map(|v| v + 1.2 * Vec3::new(next(), next(), next()))).collect();
            let m = crate::light::TriangleMotion { times: vec![0.0, 0.5, 1.0], p: keys, xf: xf(&[Mat4::IDENTITY], &[0.0]) };
            narrow += held(m, case) as usize;
        }
        assert!(narrow > 100, "{narrow}");
        // on turning instances: two or three keys turned about random axes by up to 0.8 rad,
        // scaled alike at each key (uniformly, or by one proportion, mirrored or not), or not
        let mut narrow = 0;
        for case in 0..300 {
            let turn = |next: &mut dyn FnMut() -> f32, by: f32| Quat::from_axis_angle(Vec3::new(next(), next(), next()).normalize(), by * next());
            let proportion = if case % 3 == 0 { Vec3::ONE } else { Vec3::new(1.0, 0.5 + next(), 1.2) * if case % 3 == 2 { Vec3::new(-1.0, 1.0, 1.0) } else { Vec3::ONE } };
            let keys = 2 + case % 2;
            // every fifth case each key has its own proportions (normals bent, not only turned),
            // turned little (so that a cone that took the bend for a turn would be narrow)
            let own = case % 5 == 4;
            let mats: Vec<Mat4> = (0..keys)
                .map(|_| {
                    let scale = if own { Vec3::new(1.0, 0.3 + 2.0 * (next() + 0.5), 1.0) } else { proportion * (1.0 + next()) };
                    Mat4::from_scale_rotation_translation(scale, turn(&mut next, if own { 0.1 } else { 1.6 }), Vec3::new(next(), next(), next()))
                })
                .collect();
            let times: Vec<f32> = (0..keys).map(|k| k as f32 / (keys - 1) as f32).collect();
            // a triangle whose normal (0, 0.6, 0.8) a scale along y bends
            let leaning = [Vec3::ZERO, Vec3::X, Vec3::new(0.0, 0.8, -0.6)];
            let m = crate::light::TriangleMotion { times: vec![0.0], p: vec![leaning], xf: xf(&mats, &times) };
            narrow += held(m, case) as usize;
        }
        assert!(narrow > 100, "{narrow}");
        // a turn that also deforms, or a sheared instance, takes the whole sphere
        let turn = crate::light::TriangleMotion { times: vec![0.0, 1.0], p: vec![p[0], p[1]], xf: xf(&[Mat4::IDENTITY, Mat4::from_rotation_y(1.0)], &[0.0, 1.0]) };
        let light = Light::moving_triangle(turn, 0.0, em.clone(), false).unwrap();
        assert_eq!(light_bounds(&light, 1.0, (0.0, 1.0)).unwrap().normals, Cone::ALL);
        let shear = Mat4::from_cols(Vec4::X, Vec4::new(0.7, 1.0, 0.0, 0.0), Vec4::Z, Vec4::W);
        let sheared = crate::light::TriangleMotion { times: vec![0.0], p: vec![p[0]], xf: xf(&[Mat4::IDENTITY, shear], &[0.0, 1.0]) };
        let light = Light::moving_triangle(sheared, 0.0, em, false).unwrap();
        assert_eq!(light_bounds(&light, 1.0, (0.0, 1.0)).unwrap().normals, Cone::ALL);
    }

    /// Fewer than MIN_TREE_LIGHTS lights with a place: selection by weight, as without a tree.
    #[test]
    fn few_lights_are_picked_by_weight() {
        let lights: Vec<Light> = crowd().into_iter().take(MIN_TREE_LIGHTS - 1).collect();
        let all = LightSampler::new(&lights);
        let tree = LightTree::build(&lights, all.clone(), (0.0, 1.0));
        assert!(!tree.has_tree());
        let ctx = LightSampleContext::new(Vec3::ZERO, Vec3::Y);
        for k in 0..100 {
            let u = k as f32 / 100.0;
            assert_eq!(tree.sample(&ctx, u), all.sample(u));
        }
        assert!((0..lights.len()).all(|li| tree.pmf(&ctx, li) == all.pmf(li)));
    }
}
