//! UsdGeomBasisCurves → triangle meshes.
//!
//! A curve without `normals` becomes a round tube of diameter `widths`, capped at both ends
//! when it is open; with `normals` it becomes a ribbon of width `widths` whose face looks along
//! the normal (UsdGeomBasisCurves: oriented curves are ribbons, unoriented ones cylinders).
//!
//! The curve is evaluated as USD defines it: `type` `linear` or `cubic`, `basis` `bezier`
//! (3 vertices per segment), `bspline` or `catmullRom` (1 per segment), `wrap` `nonperiodic`,
//! `periodic` (the last segment closes the curve) or `pinned` (phantom points 2·P₀ − P₁ and
//! 2·Pₙ₋₁ − Pₙ₋₂ at the ends, so B-splines reach their end points). Primvars follow the curves'
//! interpolation rules: `constant`, `uniform` (one per curve), `varying` and `faceVarying` (one
//! per segment end, linear between), `vertex` (one per control vertex, through the basis).
//!
//! Each cubic segment is cut where its tangent has turned by [`MAX_TURN`] (at least 2 and at most
//! [`MAX_STEPS`] steps), as measured on the pose at the current frame; every time sample of
//! `points` is cut the same way, so the keys share one topology. Tube frames are parallel
//! transported along the curve (a closed curve's twist is spread evenly), so a tube does not
//! twist about itself.

use crate::mesh::{point_motion, read_points, Deformation, MeshGeom};
use crate::value::{AttrStore, Interpolation, Primvar, Problems};
use glam::{Quat, Vec2, Vec3};
use std::f32::consts::{PI, TAU};
use tide_core::scene::{MeshDesc, PrimvarData};

/// Sides of a tube's cross-section.
pub const TUBE_SIDES: usize = 8;
/// Largest turn of the tangent (radians) within one step of a cubic segment.
pub const MAX_TURN: f32 = PI / 16.0;
/// Most steps per cubic segment.
pub const MAX_STEPS: usize = 32;
/// Fewest steps per cubic segment where per-vertex widths vary (they blend through the basis).
pub const WIDTH_STEPS: usize = 8;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Basis {
    Linear,
    Bezier,
    BSpline,
    CatmullRom,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Wrap {
    Nonperiodic,
    Periodic,
    Pinned,
}

/// A linear combination of control vertices (at most two per window point, four window points).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Combo {
    terms: [(u32, f32); 8],
    n: u8,
}

impl Combo {
    fn one(i: u32) -> Combo {
        let mut c = Combo::default();
        c.push(i, 1.0);
        c
    }

    fn push(&mut self, i: u32, w: f32) {
        if w == 0.0 {
            return;
        }
        if let Some(t) = self.terms[..self.n as usize].iter_mut().find(|t| t.0 == i) {
            t.1 += w;
            return;
        }
        self.terms[self.n as usize] = (i, w);
        self.n += 1;
    }

    fn add_scaled(&mut self, other: &Combo, s: f32) {
        for &(i, w) in &other.terms[..other.n as usize] {
            self.push(i, w * s);
        }
    }

    fn eval<T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>>(&self, v: &[T], zero: T) -> T {
        self.terms[..self.n as usize].iter().fold(zero, |acc, &(i, w)| acc + v[i as usize] * w)
    }
}

/// Cubic basis weights at t ∈ [0, 1] for a 4-vertex window.
fn cubic_weights(basis: Basis, t: f32) -> [f32; 4] {
    let (t2, t3, s) = (t * t, t * t * t, 1.0 - t);
    match basis {
        Basis::Bezier => [s * s * s, 3.0 * t * s * s, 3.0 * t2 * s, t3],
        Basis::BSpline => [s * s * s / 6.0, (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0, (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0, t3 / 6.0],
        Basis::CatmullRom => [(-t3 + 2.0 * t2 - t) / 2.0, (3.0 * t3 - 5.0 * t2 + 2.0) / 2.0, (-3.0 * t3 + 4.0 * t2 + t) / 2.0, (t3 - t2) / 2.0],
        Basis::Linear => [s, t, 0.0, 0.0],
    }
}

/// One curve's segments: the window of (possibly phantom) points each segment blends.
struct CurvePlan {
    /// Per segment, the window points (each a combination of control vertices).
    windows: Vec<[Combo; 4]>,
    /// Steps per segment.
    steps: Vec<usize>,
    closed: bool,
    /// Index of this curve's first `varying` value, and how many it has.
    varying_base: usize,
    varying_count: usize,
    /// The curve's index (for `uniform` primvars).
    curve: usize,
}

/// A point along a curve: its position as a combination of control vertices, and where it
/// lies for `varying` primvars (segment, t) and for the texture coordinate u.
#[derive(Clone, Copy, Debug)]
struct CurvePoint {
    combo: Combo,
    segment: usize,
    t: f32,
    u: f32,
}

impl CurvePlan {
    fn point(&self, basis: Basis, s: usize, t: f32, u: f32) -> CurvePoint {
        let w = cubic_weights(basis, t);
        let mut combo = Combo::default();
        for (k, win) in self.windows[s].iter().enumerate() {
            combo.add_scaled(win, w[k]);
        }
        CurvePoint { combo, segment: s, t, u }
    }

    fn points(&self, basis: Basis) -> Vec<CurvePoint> {
        let total: usize = self.steps.iter().sum::<usize>().max(1);
        let mut out = Vec::new();
        let mut done = 0;
        for (s, &n) in self.steps.iter().enumerate() {
            for j in 0..n {
                out.push(self.point(basis, s, j as f32 / n as f32, done as f32 / total as f32));
                done += 1;
            }
        }
        if !self.closed {
            let last = self.steps.len() - 1;
            out.push(self.point(basis, last, 1.0, 1.0));
        }
        out
    }

    /// The value of a `varying` primvar at a curve point (linear between segment ends).
    fn varying_at<T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>>(&self, v: &[T], cp: &CurvePoint) -> T {
        let a = self.varying_base + cp.segment % self.varying_count;
        let b = self.varying_base + (cp.segment + 1) % self.varying_count;
        v[a] * (1.0 - cp.t) + v[b] * cp.t
    }
}

/// How many vertices a curve needs, and its segment count, or why it cannot be drawn.
fn segments(basis: Basis, wrap: Wrap, n: usize) -> Result<usize, String> {
    let fail = |need: &str| Err(format!("a curve of {n} vertices cannot be drawn as {need}"));
    match (basis, wrap) {
        (Basis::Linear, Wrap::Periodic) if n >= 2 => Ok(n),
        (Basis::Linear, _) if n >= 2 => Ok(n - 1),
        (Basis::Linear, _) => fail("a line (it needs 2 or more)"),
        (Basis::Bezier, Wrap::Periodic) if n >= 3 && n.is_multiple_of(3) => Ok(n / 3),
        (Basis::Bezier, Wrap::Periodic) => fail("a periodic bezier curve (it needs a multiple of 3)"),
        (Basis::Bezier, _) if n >= 4 && (n - 4).is_multiple_of(3) => Ok((n - 1) / 3),
        (Basis::Bezier, _) => fail("a bezier curve (it needs 4, 7, 10, ...)"),
        (_, Wrap::Periodic) if n >= 3 => Ok(n),
        (_, Wrap::Pinned) if n >= 2 => Ok(n - 1),
        (_, Wrap::Nonperiodic) if n >= 4 => Ok(n - 3),
        _ => fail("this cubic curve (it needs 4 or more, 3 when periodic, 2 when pinned)"),
    }
}

/// The windows of one curve whose control vertices start at `o`.
fn windows(basis: Basis, wrap: Wrap, o: u32, n: usize, segs: usize) -> Vec<[Combo; 4]> {
    let at = |i: usize| Combo::one(o + (i % n) as u32);
    match basis {
        Basis::Linear => (0..segs).map(|s| [at(s), at(s + 1), Combo::default(), Combo::default()]).collect(),
        Basis::Bezier => (0..segs).map(|s| [at(3 * s), at(3 * s + 1), at(3 * s + 2), at(3 * s + 3)]).collect(),
        _ if wrap == Wrap::Pinned => {
            // phantom points that make the curve start and end at its end vertices
            let phantom = |a: usize, b: usize| {
                let mut c = Combo::default();
                c.push(o + a as u32, 2.0);
                c.push(o + b as u32, -1.0);
                c
            };
            let mut ext = vec![phantom(0, 1.min(n - 1))];
            ext.extend((0..n).map(at));
            ext.push(phantom(n - 1, n.saturating_sub(2)));
            (0..segs).map(|s| [ext[s], ext[s + 1], ext[s + 2], ext[s + 3]]).collect()
        }
        _ => (0..segs).map(|s| [at(s), at(s + 1), at(s + 2), at(s + 3)]).collect(),
    }
}

/// Angle between two vectors (0 when either is zero).
fn turn(a: Vec3, b: Vec3) -> f32 {
    match (a.try_normalize(), b.try_normalize()) {
        (Some(a), Some(b)) => a.dot(b).clamp(-1.0, 1.0).acos(),
        _ => 0.0,
    }
}

/// Steps for a cubic segment: enough that the tangent turns by at most MAX_TURN per step.
fn cubic_steps(basis: Basis, window: &[Combo; 4], pts: &[Vec3]) -> usize {
    const PROBES: usize = 16;
    let mut prev_chord = None;
    let mut prev = None;
    let mut total = 0.0;
    for j in 0..=PROBES {
        let w = cubic_weights(basis, j as f32 / PROBES as f32);
        let p = window.iter().zip(w).fold(Vec3::ZERO, |acc, (c, wk)| acc + c.eval(pts, Vec3::ZERO) * wk);
        if let Some(q) = prev {
            let chord: Vec3 = p - q;
            if let Some(c) = prev_chord {
                total += turn(c, chord);
            }
            prev_chord = Some(chord);
        }
        prev = Some(p);
    }
    ((total / MAX_TURN).ceil() as usize).clamp(2, MAX_STEPS)
}

/// Expected element count of a primvar with `interp` on these curves.
fn expected(interp: Interpolation, n_curves: usize, n_varying: usize, n_points: usize) -> usize {
    match interp {
        Interpolation::Constant => 1,
        Interpolation::Uniform => n_curves,
        Interpolation::Varying | Interpolation::FaceVarying => n_varying,
        Interpolation::Vertex => n_points,
    }
}

/// A primvar's values resolved against the curves' counts, or a problem under `attr`.
struct CurvePrimvar<T> {
    interp: Interpolation,
    values: Vec<T>,
}

impl<T: Copy + std::ops::Mul<f32, Output = T> + std::ops::Add<Output = T>> CurvePrimvar<T> {
    fn at(&self, plan: &CurvePlan, cp: &CurvePoint, zero: T) -> T {
        match self.interp {
            Interpolation::Constant => self.values[0],
            Interpolation::Uniform => self.values[plan.curve],
            Interpolation::Varying | Interpolation::FaceVarying => plan.varying_at(&self.values, cp),
            Interpolation::Vertex => cp.combo.eval(&self.values, zero),
        }
    }
}

fn read_primvar<T>(pv: Option<Primvar>, attr: &str, tuple: u32, counts: (usize, usize, usize), make: impl Fn(&[f32]) -> T, p: &mut Problems) -> Option<CurvePrimvar<T>> {
    let pv = pv?;
    let data = match pv.flatten() {
        Ok(d) => d,
        Err(e) => {
            p.add(attr, format!("{e}; ignored"));
            return None;
        }
    };
    let n = data.len() / tuple as usize;
    // a single value is constant whatever its declared interpolation
    let interp = if n == 1 { Interpolation::Constant } else { pv.interpolation };
    let want = expected(interp, counts.0, counts.1, counts.2);
    if pv.tuple != tuple || n != want || data.iter().any(|x| !x.is_finite()) {
        p.add(attr, format!("expected {want} finite value(s) of {tuple} ({:?} interpolation), got {n} of {}; ignored", interp, pv.tuple));
        return None;
    }
    Some(CurvePrimvar { interp, values: data.chunks_exact(tuple as usize).map(make).collect() })
}

/// The converted curves: their triangle mesh, and for each output vertex the curve point it
/// lies on (to move it with the control vertices).
struct Built {
    mesh: MeshDesc,
    /// Per output vertex: its curve (an index into the plan's) and the curve point it lies on.
    vertex_point: Vec<(usize, CurvePoint)>,
}

/// Everything about the curves that does not depend on the pose.
struct Plan {
    basis: Basis,
    curves: Vec<CurvePlan>,
    widths: Option<CurvePrimvar<f32>>,
    normals: Option<CurvePrimvar<Vec3>>,
}

fn tangents(pos: &[Vec3], closed: bool) -> Vec<Vec3> {
    let n = pos.len();
    (0..n)
        .map(|i| {
            let (a, b) = match (i, closed) {
                (_, true) => ((i + n - 1) % n, (i + 1) % n),
                (0, false) => (0, 1.min(n - 1)),
                (_, false) if i == n - 1 => (i - 1, i),
                _ => (i - 1, i + 1),
            };
            (pos[b] - pos[a]).try_normalize().unwrap_or(Vec3::Z)
        })
        .collect()
}

/// At point `i` of a linear curve, the directions of the segments before and after it (None at an
/// open curve's ends, or where a segment has no length).
fn joint(pos: &[Vec3], i: usize, closed: bool) -> Option<(Vec3, Vec3)> {
    let n = pos.len();
    if !closed && (i == 0 || i + 1 >= n) || n < 3 {
        return None;
    }
    let (a, b) = ((i + n - 1) % n, (i + 1) % n);
    Some(((pos[i] - pos[a]).try_normalize()?, (pos[b] - pos[i]).try_normalize()?))
}

/// How far out along `dir` (perpendicular to the joint's mean tangent) a point must lie to be on
/// the surface of the segment of direction `d` and radius 1: the miter that keeps both segments
/// at their full width through a corner (at most 4, the miter limit).
fn miter(dir: Vec3, d: Vec3) -> f32 {
    let c = dir.dot(d);
    1.0 / (1.0 - c * c).max(1.0 / 16.0).sqrt()
}

fn any_perpendicular(t: Vec3) -> Vec3 {
    let a = t.abs();
    let axis = if a.x <= a.y && a.x <= a.z {
        Vec3::X
    } else if a.y <= a.z {
        Vec3::Y
    } else {
        Vec3::Z
    };
    t.cross(axis).normalize()
}

/// Frames transported along the tangents (each the previous turned by the tangent's turn).
fn transported_normals(tan: &[Vec3], closed: bool) -> Vec<Vec3> {
    let mut out = Vec::with_capacity(tan.len());
    let mut n = any_perpendicular(tan[0]);
    out.push(n);
    for w in tan.windows(2) {
        n = (Quat::from_rotation_arc(w[0], w[1]) * n).reject_from(w[1]).try_normalize().unwrap_or_else(|| any_perpendicular(w[1]));
        out.push(n);
    }
    if closed && tan.len() > 2 {
        // carried once more around, the frame comes back turned about the first tangent: spread
        // that twist over the curve so the last ring meets the first
        let back = (Quat::from_rotation_arc(tan[tan.len() - 1], tan[0]) * n).reject_from(tan[0]).normalize_or_zero();
        let first = out[0];
        let twist = first.cross(back).dot(tan[0]).atan2(first.dot(back));
        let count = tan.len() as f32;
        for (i, (v, t)) in out.iter_mut().zip(tan).enumerate() {
            *v = Quat::from_axis_angle(*t, -twist * i as f32 / count) * *v;
        }
    }
    out
}

fn build(name: &str, plan: &Plan, pts: &[Vec3], double_sided: bool) -> Built {
    let mut mesh = MeshDesc { name: name.into(), double_sided: double_sided || plan.normals.is_some(), ..Default::default() };
    let (mut normals, mut uvs, mut vertex_point) = (Vec::new(), Vec::new(), Vec::new());
    for (ci, c) in plan.curves.iter().enumerate() {
        let cps = c.points(plan.basis);
        let pos: Vec<Vec3> = cps.iter().map(|cp| cp.combo.eval(pts, Vec3::ZERO)).collect();
        let radius: Vec<f32> = cps.iter().map(|cp| 0.5 * plan.widths.as_ref().map_or(1.0, |w| w.at(c, cp, 0.0)).max(0.0)).collect();
        let tan = tangents(&pos, c.closed);
        let rings = cps.len() + c.closed as usize;
        // a linear curve's corners: its segments keep their width up to the joint
        let joints: Vec<Option<(Vec3, Vec3)>> = (0..cps.len()).map(|i| if plan.basis == Basis::Linear { joint(&pos, i, c.closed) } else { None }).collect();
        let stretch = |i: usize, dir: Vec3| joints[i].map_or(1.0, |(d0, _)| miter(dir, d0));
        let base = mesh.positions.len() as u32;
        let across = match &plan.normals {
            Some(nv) => {
                // a ribbon: two vertices across each curve point, facing its normal
                for (i, cp) in cps.iter().enumerate() {
                    let n = nv.at(c, cp, Vec3::ZERO).try_normalize().unwrap_or_else(|| any_perpendicular(tan[i]));
                    let side = tan[i].cross(n).try_normalize().unwrap_or_else(|| any_perpendicular(tan[i]));
                    let reach = radius[i] * stretch(i, side);
                    for (k, s) in [-1.0f32, 1.0].into_iter().enumerate() {
                        mesh.positions.push(pos[i] + side * (s * reach));
                        normals.push(n);
                        uvs.push(Vec2::new(cp.u, k as f32));
                        vertex_point.push((ci, *cp));
                    }
                }
                if c.closed {
                    for k in 0..2 {
                        mesh.positions.push(mesh.positions[base as usize + k]);
                        normals.push(normals[base as usize + k]);
                        uvs.push(Vec2::new(1.0, k as f32));
                        vertex_point.push(vertex_point[base as usize + k]);
                    }
                }
                2
            }
            None => {
                let frame = transported_normals(&tan, c.closed);
                for ring in 0..rings {
                    let i = ring % cps.len();
                    let (t, n) = (tan[i], frame[i]);
                    let b = t.cross(n);
                    let u = if ring == cps.len() { 1.0 } else { cps[i].u };
                    for k in 0..=TUBE_SIDES {
                        let phi = TAU * k as f32 / TUBE_SIDES as f32;
                        let dir = n * phi.cos() + b * phi.sin();
                        mesh.positions.push(pos[i] + dir * (radius[i] * stretch(i, dir)));
                        normals.push(dir);
                        uvs.push(Vec2::new(u, k as f32 / TUBE_SIDES as f32));
                        vertex_point.push((ci, cps[i]));
                    }
                }
                TUBE_SIDES + 1
            }
        };
        let across = across as u32;
        for ring in 0..rings as u32 - 1 {
            for k in 0..across - 1 {
                let a = base + ring * across + k;
                let (b, c2, d) = (a + 1, a + across + 1, a + across);
                mesh.indices.extend_from_slice(&[a, b, d, b, c2, d]);
            }
        }
        if plan.normals.is_none() && !c.closed {
            // flat caps on an open tube's ends, facing out along the curve
            for (i, outward) in [(0usize, -1.0f32), (cps.len() - 1, 1.0)] {
                if radius[i] <= 0.0 {
                    continue;
                }
                let n = tan[i] * outward;
                let ring_base = base + (i * (TUBE_SIDES + 1)) as u32;
                let centre = mesh.positions.len() as u32;
                mesh.positions.push(pos[i]);
                normals.push(n);
                uvs.push(Vec2::new(cps[i].u, 0.5));
                vertex_point.push((ci, cps[i]));
                for k in 0..TUBE_SIDES as u32 {
                    let v = mesh.positions.len() as u32;
                    mesh.positions.push(mesh.positions[(ring_base + k) as usize]);
                    normals.push(n);
                    uvs.push(uvs[(ring_base + k) as usize]);
                    vertex_point.push((ci, cps[i]));
                    let next = centre + 1 + (k + 1) % TUBE_SIDES as u32;
                    if outward < 0.0 {
                        mesh.indices.extend_from_slice(&[centre, next, v]);
                    } else {
                        mesh.indices.extend_from_slice(&[centre, v, next]);
                    }
                }
            }
        }
        // the curve's triangles are its element
        mesh.faces.resize(mesh.indices.len() / 3, c.curve as u32);
    }
    mesh.normals = Some(normals);
    mesh.uvs = Some(uvs);
    Built { mesh, vertex_point }
}

/// Converts a BasisCurves prim: its triangles at the current frame and how they move (time
/// samples of `points`, or `velocities`/`accelerations` carried to each vertex through the
/// basis). A curve whose vertex count its type cannot draw, or that has a point that is not
/// finite, is dropped with a problem; the others render.
pub fn convert_curves(name: &str, store: &AttrStore, p: &mut Problems) -> MeshGeom {
    let empty = |mesh: MeshDesc| MeshGeom::new(mesh, None, Vec::new(), Vec::new());
    let (pts, bad) = read_points(store, p);
    let blank = MeshDesc { name: name.into(), ..Default::default() };
    let counts: Vec<i32> = match store.get("curveVertexCounts") {
        None => {
            p.add("curveVertexCounts", "missing; the curves are not drawn");
            return empty(blank);
        }
        Some(v) => match v.to_ints() {
            Some(c) => c,
            None => {
                p.add("curveVertexCounts", format!("expected Ints, got {}; the curves are not drawn", v.kind()));
                return empty(blank);
            }
        },
    };
    let total: i64 = counts.iter().map(|&c| c.max(0) as i64).sum();
    if counts.iter().any(|&c| c < 0) || total != pts.len() as i64 {
        p.add("curveVertexCounts", format!("the counts add up to {total} vertices, the curves have {} points; the curves are not drawn", pts.len()));
        return empty(blank);
    }
    let cubic = store.token_or("type", &["linear", "cubic"], "cubic", p) == "cubic";
    let basis = match store.token_or("basis", &["bezier", "bspline", "catmullRom", "hermite"], "bezier", p) {
        _ if !cubic => Basis::Linear,
        "bspline" => Basis::BSpline,
        "catmullRom" => Basis::CatmullRom,
        "hermite" => {
            p.add("basis", "hermite basis curves are not supported; drawn as lines through their vertices");
            Basis::Linear
        }
        _ => Basis::Bezier,
    };
    let wrap = match store.token_or("wrap", &["nonperiodic", "periodic", "pinned"], "nonperiodic", p) {
        "periodic" => Wrap::Periodic,
        "pinned" => Wrap::Pinned,
        _ => Wrap::Nonperiodic,
    };
    let mut curves = Vec::new();
    let (mut start, mut varying) = (0usize, 0usize);
    let mut skipped: Vec<String> = Vec::new();
    for (ci, &c) in counts.iter().enumerate() {
        let n = c as usize;
        let segs = segments(basis, wrap, n);
        let vcount = match segs {
            Ok(s) if wrap == Wrap::Periodic => s,
            Ok(s) => s + 1,
            Err(_) => 0,
        };
        match segs {
            Err(e) => skipped.push(format!("curve {ci}: {e}")),
            Ok(_) if bad[start..start + n].iter().any(|&b| b) => skipped.push(format!("curve {ci}: a point is NaN or infinite")),
            Ok(s) => {
                let win = windows(basis, wrap, start as u32, n, s);
                let steps = win.iter().map(|w| if basis == Basis::Linear { 1 } else { cubic_steps(basis, w, &pts) }).collect();
                curves.push(CurvePlan { windows: win, steps, closed: wrap == Wrap::Periodic, varying_base: varying, varying_count: vcount, curve: ci });
            }
        }
        start += n;
        varying += vcount;
    }
    if !skipped.is_empty() {
        p.add("curveVertexCounts", format!("{} curve(s) dropped ({})", skipped.len(), skipped[..skipped.len().min(3)].join("; ")));
    }
    let shape = (counts.len(), varying, pts.len());
    let widths = read_primvar(store.primvar("widths", Interpolation::Vertex), "widths", 1, shape, |c| c[0], p);
    let widths = widths.filter(|w| {
        let ok = w.values.iter().all(|&x| x >= 0.0);
        if !ok {
            p.add("widths", "a width is negative; using width 1");
        }
        ok
    });
    let normals = read_primvar(store.primvar("normals", Interpolation::Vertex), "normals", 3, shape, |c| Vec3::new(c[0], c[1], c[2]), p);
    // widths blended through a cubic basis vary between the turns' samples: sample each segment
    // often enough to follow them
    let mut curves = curves;
    if basis != Basis::Linear && widths.as_ref().is_some_and(|w| w.interp == Interpolation::Vertex && w.values.windows(2).any(|v| v[0] != v[1])) {
        for c in &mut curves {
            c.steps.iter_mut().for_each(|s| *s = (*s).max(WIDTH_STEPS));
        }
    }
    let plan = Plan { basis, curves, widths, normals };
    let double_sided = store.get("doubleSided").and_then(|v| v.as_bool()).unwrap_or(false);
    let mut built = build(name, &plan, &pts, double_sided);
    built.mesh.primvars = shading_primvars(store, &plan, &built, shape, p);
    let deformation = curve_deformation(name, &plan, &built, store, pts.len(), double_sided, p);
    MeshGeom::new(built.mesh, deformation, Vec::new(), Vec::new())
}

/// The primvars a material may read, carried to every output vertex through the curves'
/// interpolation rules (constant ones stay constant).
fn shading_primvars(store: &AttrStore, plan: &Plan, built: &Built, shape: (usize, usize, usize), p: &mut Problems) -> Vec<PrimvarData> {
    let mut out = Vec::new();
    for name in crate::mesh::shading_primvar_names(store, None) {
        let pv = store.primvar(&name, Interpolation::Constant);
        let tuple = pv.as_ref().map_or(1, |pv| pv.tuple);
        let widen = |c: &[f32]| {
            let mut v = glam::Vec4::ZERO;
            c.iter().enumerate().for_each(|(i, x)| v[i] = *x);
            v
        };
        let Some(cv) = read_primvar(pv, &name, tuple, shape, widen, p) else { continue };
        let data = match cv.interp {
            Interpolation::Constant => cv.values[0].to_array()[..tuple as usize].to_vec(),
            _ => built.vertex_point.iter().flat_map(|(c, cp)| cv.at(&plan.curves[*c], cp, glam::Vec4::ZERO).to_array()[..tuple as usize].to_vec()).collect(),
        };
        out.push(PrimvarData { name, tuple, constant: cv.interp == Interpolation::Constant, data });
    }
    out
}

/// How the converted curves move: every time sample of `points` built with the same plan, or
/// the control vertices' velocities (and accelerations) carried to each output vertex.
fn curve_deformation(name: &str, plan: &Plan, built: &Built, store: &AttrStore, n_points: usize, double_sided: bool, p: &mut Problems) -> Option<Deformation> {
    if built.mesh.indices.is_empty() {
        return None;
    }
    let vec3s = |d: &[f32]| -> Vec<Vec3> { d.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect() };
    let key = |d: &[f32]| build(name, plan, &vec3s(d), double_sided).mesh.positions;
    let carry = |d: &[f32]| -> Vec<Vec3> {
        let v = vec3s(d);
        built.vertex_point.iter().map(|(_, cp)| cp.combo.eval(&v, Vec3::ZERO)).collect()
    };
    point_motion(store, n_points, built.mesh.positions.len(), "the curves", key, carry, p)
}

#[cfg(test)]
mod tests;
