//! A bounding-volume hierarchy over the lights a ray can hit (sphere, rect, disk and cylinder
//! lights, moving or not), so that finding the nearest light along a ray costs a descent, not a
//! test of every light: a scene of thousands of bulbs (a harbour at night, string lights over a
//! pool) rendered every ray against each of them.
//!
//! Each light is bounded over the whole shutter (a moving light by its bounds carried along its
//! motion, sampled densely, widened by half the longest step so the arcs between samples stay
//! inside). The tree is binary, split at the median of the widest axis of the centres, with up to
//! [`LEAF`] lights a leaf; a ray visits the nearer child first and skips any box past the nearest
//! hit so far. The answer is the linear scan's: the nearest hit, the lowest light index among
//! hits at the same distance.

use super::Light;
use glam::Vec3;

/// Lights per leaf.
const LEAF: usize = 4;
/// Below this many hittable lights the scan is as fast as a descent: no tree is built.
const MIN_LIGHTS: usize = 8;

#[derive(Clone, Debug, Default, PartialEq)]
struct Node {
    lo: Vec3,
    hi: Vec3,
    /// Leaf: first index into `order`; inner: the right child (the left follows the node).
    start: u32,
    /// Lights in a leaf; 0 for an inner node.
    count: u32,
}

/// The hierarchy over a world's hittable lights (empty below [`MIN_LIGHTS`] of them: the
/// queries then scan the list).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LightBvh {
    nodes: Vec<Node>,
    /// Light indices in leaf order.
    order: Vec<u32>,
    /// The hittable lights, scanned when there is no tree.
    lights: Vec<usize>,
}

/// The box of a light that stays where it is (points, spheres, rects, disks, cylinders, still
/// emissive triangles), or None for any other.
pub(super) fn still_extent(light: &Light) -> Option<(Vec3, Vec3)> {
    let fold = |points: &[Vec3]| points.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &c| (lo.min(c), hi.max(c)));
    let (lo, hi) = match light {
        Light::Point(p) => (p.p, p.p),
        Light::Sphere(s) => (s.center - Vec3::splat(s.radius), s.center + Vec3::splat(s.radius)),
        Light::Rect(r) => {
            let p = &r.shape;
            fold(&[p.origin, p.origin + p.a, p.origin + p.b, p.origin + p.a + p.b])
        }
        Light::Disk(d) => {
            let p = &d.shape;
            let e = p.a.abs() + p.b.abs();
            (p.origin - e, p.origin + e)
        }
        Light::Cylinder(c) => {
            let f = &c.frame;
            let e = (f.s.abs() + f.t.abs()) * c.radius + f.n.abs() * c.half_length;
            (c.center - e, c.center + e)
        }
        Light::Triangle(t) if t.motion.is_none() => fold(&t.p),
        _ => return None,
    };
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

/// The box of a light over `shutter`: [`still_extent`], a moving light's carried along its
/// motion (a moving emissive triangle's vertices along theirs); None for a light without a
/// place.
pub(super) fn extent_over(light: &Light, shutter: (f32, f32)) -> Option<(Vec3, Vec3)> {
    let (lo, hi) = match light {
        Light::Moving(m) => {
            let (lo, hi) = still_extent(&m.inner)?;
            let corners: Vec<Vec3> = (0..8).map(|k| Vec3::new([lo.x, hi.x][k & 1], [lo.y, hi.y][(k >> 1) & 1], [lo.z, hi.z][k >> 2])).collect();
            swept(shutter, &[], |t| {
                let (fwd, _) = m.moves(t);
                corners.iter().map(|&c| fwd.transform_point3(c)).collect()
            })
        }
        // vertices interpolated linearly between the mesh's samples (their extremes at the
        // samples' times), then placed by the instance's motion
        Light::Triangle(t) if t.motion.is_some() => {
            let m = t.motion.as_deref()?;
            swept(shutter, &m.times, |time| m.at(time).to_vec())
        }
        _ => still_extent(light)?,
    };
    (lo.is_finite() && hi.is_finite()).then_some((lo, hi))
}

/// The box of the points `at(t)` over `shutter`: taken at 64 even steps and at the `keys`
/// within it, widened by half the largest step a point takes between two of those times (the
/// most a path between them strays from its ends).
fn swept(shutter: (f32, f32), keys: &[f32], at: impl Fn(f32) -> Vec<Vec3>) -> (Vec3, Vec3) {
    let (t0, t1) = (shutter.0.min(shutter.1), shutter.0.max(shutter.1));
    let steps = 64usize;
    let mut times: Vec<f32> = (0..=steps).map(|k| t0 + (t1 - t0) * k as f32 / steps as f32).collect();
    times.extend(keys.iter().copied().filter(|&k| k > t0 && k < t1));
    times.sort_by(f32::total_cmp);
    let mut out = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    let mut step = 0.0f32;
    let mut prev: Option<Vec<Vec3>> = None;
    for t in times {
        let now = at(t);
        for &p in &now {
            out = (out.0.min(p), out.1.max(p));
        }
        if let Some(prev) = &prev {
            step = prev.iter().zip(&now).fold(step, |s, (a, b)| s.max(a.distance(*b)));
        }
        prev = Some(now);
    }
    (out.0 - Vec3::splat(step * 0.5), out.1 + Vec3::splat(step * 0.5))
}

/// A light's bounds over `shutter`: (lo, hi), or None for a light a ray cannot hit.
fn light_bounds(light: &Light, shutter: (f32, f32)) -> Option<(Vec3, Vec3)> {
    let hittable = matches!(light.inner(), Light::Sphere(_) | Light::Rect(_) | Light::Disk(_) | Light::Cylinder(_));
    if hittable {
        extent_over(light, shutter)
    } else {
        None
    }
}

impl LightBvh {
    /// The hierarchy over `hittable` (indices into `lights`), bounded over `shutter`.
    pub fn build(lights: &[Light], hittable: &[usize], shutter: (f32, f32)) -> LightBvh {
        let mut bvh = LightBvh { lights: hittable.to_vec(), ..Default::default() };
        if hittable.len() < MIN_LIGHTS {
            return bvh;
        }
        let mut items: Vec<(u32, Vec3, Vec3)> = Vec::with_capacity(hittable.len());
        for &li in hittable {
            match light_bounds(&lights[li], shutter) {
                Some((lo, hi)) => items.push((li as u32, lo, hi)),
                // a light the tree cannot bound keeps the scan
                None => return bvh,
            }
        }
        bvh.nodes.reserve(2 * items.len() / LEAF + 1);
        bvh.build_range(&mut items, 0);
        bvh.order = items.iter().map(|i| i.0).collect();
        bvh
    }

    /// Builds the node over `items` (which it reorders), lying at `offset` in the whole list;
    /// returns the node's index.
    fn build_range(&mut self, items: &mut [(u32, Vec3, Vec3)], offset: usize) -> usize {
        let (lo, hi) = items.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), i| (lo.min(i.1), hi.max(i.2)));
        let at = self.nodes.len();
        self.nodes.push(Node { lo, hi, start: offset as u32, count: items.len() as u32 });
        if items.len() <= LEAF {
            return at;
        }
        let (clo, chi) = items.iter().fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), i| {
            let c = (i.1 + i.2) * 0.5;
            (lo.min(c), hi.max(c))
        });
        let ext = chi - clo;
        let axis = if ext.x >= ext.y && ext.x >= ext.z { 0 } else if ext.y >= ext.z { 1 } else { 2 };
        let mid = items.len() / 2;
        // ties broken by light index: the tree, and so the traversal, is the same on every run
        items.select_nth_unstable_by(mid, |a, b| ((a.1 + a.2)[axis]).total_cmp(&(b.1 + b.2)[axis]).then(a.0.cmp(&b.0)));
        let (left, right) = items.split_at_mut(mid);
        self.build_range(left, offset);
        let r = self.build_range(right, offset + mid);
        self.nodes[at].start = r as u32;
        self.nodes[at].count = 0;
        at
    }

    /// The nearest light hit by the ray `o + t d` (0 < t < t_max) at `time`, among those
    /// `visible` keeps: (light, t, point, emitting-side normal).
    pub fn nearest(&self, lights: &[Light], o: Vec3, d: Vec3, t_max: f32, time: f32, visible: impl Fn(usize) -> bool) -> Option<(usize, f32, Vec3, Vec3)> {
        let mut best: Option<(usize, f32, Vec3, Vec3)> = None;
        let consider = |li: usize, best: &mut Option<(usize, f32, Vec3, Vec3)>| {
            if !visible(li) {
                return;
            }
            // a hit at the same distance as the best goes to the lower index (the scan's answer)
            let limit = best.map_or(t_max, |b| if li < b.0 { f32::from_bits(b.1.to_bits() + 1) } else { b.1 });
            if let Some((t, p, n)) = lights[li].intersect_at(o, d, limit, time) {
                if best.is_none_or(|b| t < b.1 || li < b.0) {
                    *best = Some((li, t, p, n));
                }
            }
        };
        if self.nodes.is_empty() {
            for &li in &self.lights {
                consider(li, &mut best);
            }
            return best;
        }
        let inv = d.recip();
        // (node, the ray's entry distance into its box): each box is tested once, when its
        // parent is opened; a node popped past the nearest hit found since is skipped
        let mut stack = [(0u32, 0.0f32); 64];
        let mut sp = 0usize;
        if let Some(t) = slab(self.nodes[0].lo, self.nodes[0].hi, o, inv, t_max) {
            stack[0] = (0, t);
            sp = 1;
        }
        while sp > 0 {
            sp -= 1;
            let (at, entry) = stack[sp];
            let reach = best.map_or(t_max, |b| f32::from_bits(b.1.to_bits() + 1));
            if entry > reach {
                continue;
            }
            let node = &self.nodes[at as usize];
            if node.count > 0 {
                for &li in &self.order[node.start as usize..(node.start + node.count) as usize] {
                    consider(li as usize, &mut best);
                }
                continue;
            }
            let (l, r) = (at + 1, node.start);
            let tl = slab(self.nodes[l as usize].lo, self.nodes[l as usize].hi, o, inv, reach).map(|t| (l, t));
            let tr = slab(self.nodes[r as usize].lo, self.nodes[r as usize].hi, o, inv, reach).map(|t| (r, t));
            // the nearer child on top of the stack
            let (first, second) = match (tl, tr) {
                (Some(a), Some(b)) if b.1 < a.1 => (Some(b), Some(a)),
                (a, b) if a.is_some() => (a, b),
                (a, b) => (b, a),
            };
            for c in [second, first].into_iter().flatten() {
                if sp < stack.len() {
                    stack[sp] = c;
                    sp += 1;
                }
            }
        }
        best
    }

    /// Whether any light blocks the segment `o + t d`, 0 < t < t_max, at `time`.
    pub fn any(&self, lights: &[Light], o: Vec3, d: Vec3, t_max: f32, time: f32) -> bool {
        self.nearest(lights, o, d, t_max, time, |_| true).is_some()
    }
}

/// Entry distance of the ray into the box [lo, hi] within (0, t_max), or None. The box is
/// widened by a few ulps so that a light lying flat in it (a rect's zero thickness) is entered.
#[inline]
fn slab(lo: Vec3, hi: Vec3, o: Vec3, inv: Vec3, t_max: f32) -> Option<f32> {
    let pad = (lo.abs().max(hi.abs()) * 4.0 * f32::EPSILON).max(Vec3::splat(f32::MIN_POSITIVE));
    let (lo, hi) = (lo - pad, hi + pad);
    let a = (lo - o) * inv;
    let b = (hi - o) * inv;
    // NaN (0 · ∞ for a ray in a box's face plane) must not reject: min/max ignore it
    let t0 = a.min(b).max_element().max(0.0);
    let t1 = a.max(b).min_element().min(t_max);
    (t0 <= t1 * (1.0 + 4.0 * f32::EPSILON)).then_some(t0)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::light::tests::{build, desc};
    use crate::scene::LightShape;
    use crate::testing::chi2::TestRng;
    use glam::{Mat4, Quat};

    /// The linear scan the tree replaces: every light in index order, the bound shrinking.
    fn scan(lights: &[Light], hittable: &[usize], o: Vec3, d: Vec3, t_max: f32, time: f32, visible: impl Fn(usize) -> bool) -> Option<(usize, f32, Vec3, Vec3)> {
        let mut best: Option<(usize, f32, Vec3, Vec3)> = None;
        for &li in hittable {
            if !visible(li) {
                continue;
            }
            if let Some((t, p, n)) = lights[li].intersect_at(o, d, best.map_or(t_max, |b| b.1), time) {
                best = Some((li, t, p, n));
            }
        }
        best
    }

    /// Hundreds of spheres, rects, disks and cylinders in every orientation, a third of them
    /// moving (turning and travelling over the shutter), some hidden, and an infinite light the
    /// tree leaves out: rays from inside and outside the crowd at random times find the light the
    /// scan finds, at the same distance, point and normal, and the scan's lowest index where
    /// two lie at the same distance (copies of one light).
    #[test]
    fn the_tree_finds_the_light_the_scan_finds() {
        let mut rng = TestRng::new(7);
        let mut r = |lo: f32, hi: f32| lo + (hi - lo) * rng.next_f32();
        let mut lights = Vec::new();
        for k in 0..600 {
            let shape = match k % 4 {
                0 => LightShape::Sphere { radius: r(0.05, 0.6), treat_as_point: false },
                1 => LightShape::Rect { width: r(0.1, 1.5), height: r(0.1, 1.5), texture: None },
                2 => LightShape::Disk { radius: r(0.05, 0.8) },
                _ => LightShape::Cylinder { radius: r(0.05, 0.3), length: r(0.2, 2.0), treat_as_line: false },
            };
            let axis = Vec3::new(r(-1.0, 1.0), r(-1.0, 1.0), r(-1.0, 1.0)).normalize_or(Vec3::Y);
            let rot = Quat::from_axis_angle(axis, r(0.0, 6.0));
            let at = Vec3::new(r(-20.0, 20.0), r(-20.0, 20.0), r(-20.0, 20.0));
            let m = Mat4::from_rotation_translation(rot, at);
            let mut d = desc(shape, m);
            d.visible_to_camera = k % 7 != 0;
            if k % 3 == 0 {
                let turn = Quat::from_axis_angle(Vec3::new(r(-1.0, 1.0), 1.0, r(-1.0, 1.0)).normalize(), r(0.5, 3.0));
                let m1 = Mat4::from_rotation_translation(turn * rot, at + Vec3::new(r(-3.0, 3.0), r(-3.0, 3.0), r(-3.0, 3.0)));
                d.motion = vec![(0.0, m), (0.5, Mat4::from_rotation_translation(turn.slerp(Quat::IDENTITY, 0.5) * rot, at)), (1.0, m1)];
            }
            lights.push(build(&d));
            if k % 50 == 0 {
                // a copy at the same place: ties go to the lower index
                lights.push(build(&d));
            }
        }
        lights.push(build(&desc(LightShape::Dome { texture: None }, Mat4::IDENTITY)));
        let hittable: Vec<usize> = (0..lights.len()).filter(|&i| !lights[i].is_infinite()).collect();
        assert!(lights.iter().filter(|l| matches!(l, Light::Moving(_))).count() > 150);
        let bvh = LightBvh::build(&lights, &hittable, (0.0, 1.0));
        assert!(!bvh.nodes.is_empty());
        let (mut hits, mut ties) = (0, 0);
        for k in 0..40_000 {
            let o = if k % 2 == 0 { Vec3::new(r(-25.0, 25.0), r(-25.0, 25.0), r(-25.0, 25.0)) } else { Vec3::new(r(-60.0, 60.0), 60.0, r(-60.0, 60.0)) };
            let target = Vec3::new(r(-20.0, 20.0), r(-20.0, 20.0), r(-20.0, 20.0));
            let d = (target - o).normalize();
            let time = r(0.0, 1.0);
            let t_max = if k % 5 == 0 { r(1.0, 30.0) } else { f32::INFINITY };
            let hidden = k % 3 == 0;
            let vis = |li: usize| !hidden || lights[li].visible_to_camera();
            let want = scan(&lights, &hittable, o, d, t_max, time, vis);
            let got = bvh.nearest(&lights, o, d, t_max, time, vis);
            assert_eq!(got, want, "ray {k}: o {o}, d {d}, time {time}, t_max {t_max}");
            assert_eq!(bvh.any(&lights, o, d, t_max, time), scan(&lights, &hittable, o, d, t_max, time, |_| true).is_some());
            if let Some((li, t, ..)) = want {
                hits += 1;
                ties += (li + 1 < lights.len() && lights[li + 1] == lights[li] && lights[li + 1].intersect_at(o, d, f32::INFINITY, time).is_some_and(|h| h.0 == t)) as u32;
            }
        }
        // the rays met lights often, and met copies where the tie rule decides
        assert!(hits > 2_000 && ties > 20, "{hits} hits, {ties} ties");
    }

    /// Below a handful of lights no tree is built and the scan answers.
    #[test]
    fn few_lights_are_scanned() {
        let lights: Vec<Light> = (0..3).map(|k| build(&desc(LightShape::Sphere { radius: 0.5, treat_as_point: false }, Mat4::from_translation(Vec3::new(0.0, 0.0, -2.0 * k as f32 - 2.0))))).collect();
        let bvh = LightBvh::build(&lights, &[0, 1, 2], (0.0, 0.0));
        assert!(bvh.nodes.is_empty());
        let hit = bvh.nearest(&lights, Vec3::ZERO, Vec3::NEG_Z, f32::INFINITY, 0.0, |li| li != 0).unwrap();
        assert_eq!((hit.0, hit.1), (1, 3.5));
    }

    /// A moving emissive triangle's box over the shutter holds its vertices at every time (a
    /// deformation whose middle sample lies off the line of the others, an instance turning by
    /// 3 radians) and is not much larger than where they go (found at 20 001 times).
    #[test]
    fn a_moving_triangle_is_bounded_along_its_motion() {
        let xf = |m: &[Mat4], t: &[f32]| std::sync::Arc::new(crate::accel::motion::MotionTransform::new(m, t));
        let tri = |c: Vec3| [c, c + Vec3::X, c + Vec3::new(0.0, 0.5, 0.8)];
        let em = crate::spectrum::Spectrum::Constant(1.0);
        let motions = [
            crate::light::TriangleMotion { times: vec![0.0, 0.37, 1.0], p: vec![tri(Vec3::ZERO), tri(Vec3::new(1.0, 3.0, 1.0)), tri(Vec3::new(0.0, 0.5, 0.5))], xf: xf(&[Mat4::IDENTITY], &[0.0]) },
            crate::light::TriangleMotion { times: vec![0.0], p: vec![tri(Vec3::new(2.0, 0.0, 0.0))], xf: xf(&[Mat4::IDENTITY, Mat4::from_rotation_y(3.0)], &[0.0, 1.0]) },
            crate::light::TriangleMotion { times: vec![-0.5, 0.5], p: vec![tri(Vec3::ZERO), tri(Vec3::new(0.0, 2.0, 0.0))], xf: xf(&[Mat4::from_translation(Vec3::X), Mat4::from_rotation_x(1.0)], &[-0.5, 0.5]) },
        ];
        for (k, m) in motions.into_iter().enumerate() {
            let shutter = (m.times[0].min(0.0), 1.0);
            let light = Light::moving_triangle(m.clone(), shutter.0, em.clone(), false).unwrap();
            let (lo, hi) = extent_over(&light, shutter).unwrap_or_else(|| panic!("motion {k}: no bounds"));
            let (mut tlo, mut thi) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
            for i in 0..=20_000 {
                for v in m.at(shutter.0 + (shutter.1 - shutter.0) * i as f32 / 20_000.0) {
                    (tlo, thi) = (tlo.min(v), thi.max(v));
                }
            }
            assert!(lo.cmple(tlo).all() && thi.cmple(hi).all(), "motion {k}: {lo} {hi} does not hold {tlo} {thi}");
            let slack = 0.05 * (thi - tlo).length();
            assert!((tlo - lo).max_element() < slack && (hi - thi).max_element() < slack, "motion {k}: {lo} {hi} against {tlo} {thi}");
        }
    }
}
