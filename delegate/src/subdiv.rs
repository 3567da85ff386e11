//! Uniform subdivision of UsdGeomMesh, opt-in per prim: `tide:subdivision:level` = L ≥ 1 refines
//! a `catmullClark` mesh L times and moves every vertex to its limit position, or splits a
//! `bilinear` one L times without changing its shape. Level 0 (the default) keeps the control
//! cage exactly as [`crate::mesh`] draws it without subdivision; `loop` is not supported (a
//! problem, and the cage); `none` ignores the level. Where the level is not authored, the
//! viewer's refinement ([`REFINE_ATTR`]: Hydra's display style, usdview's complexity, `tide
//! render --complexity`) is the level.
//!
//! The refinement is a linear operator built once from the topology: a [`Stencil`] gives every
//! refined vertex as Σ wᵢ·Pᵢ over the control points. The same stencil moves `points` (and each
//! of its time samples), `velocities`, `accelerations` and `vertex` primvars, so refining
//! P + V·t gives the refined P plus the refined V times t.
//!
//! Catmull-Clark follows OpenSubdiv's and USD's rules: face, edge and vertex points for any
//! polygon sizes (an n-gon gives n quads, after which every face is a quad); boundary edges
//! and non-manifold edges (more than two faces) are infinitely sharp creases, and their
//! vertices use the crease (cubic B-spline curve) rule. `interpolateBoundary` `edgeAndCorner`
//! (USD's fallback) also pins boundary vertices with only two incident edges; `edgeOnly` keeps
//! them on the smooth boundary curve; `none` leaves the faces that touch the boundary out (as
//! holes: they still shape their neighbours).
//! `creaseIndices` / `creaseLengths` / `creaseSharpnesses` (one sharpness per crease or per
//! crease edge) and `cornerIndices` / `cornerSharpnesses` sharpen edges and vertices: a
//! sharpness of [`INFINITELY_SHARP`] (10) or more is sharp at every level, a semi-sharp one
//! loses 1 per level (child edges inherit their parent's sharpness − 1, the uniform rule of
//! DeRose et al. 1998) and, where it decays to zero, the sharp and smooth rules are blended by
//! the decaying sharpness (OpenSubdiv's fractional weight). A vertex pinned where two face
//! fans meet (non-manifold) is a corner. After the last level every vertex moves to its limit:
//! interior (n²·v + 4·Σeᵢ + Σdᵢ) / (n·(n+5)) over its n edge neighbours eᵢ and the opposite
//! corners dᵢ of its quads, crease vertices (e₀ + 4·v + e₁) / 6 along the crease, corners stay;
//! a semi-sharp feature with sharpness left after the last level counts as sharp there.
//!
//! Primvars: `vertex` through the stencil (smooth), `varying` bilinearly over the refined
//! faces, `faceVarying` as a mesh of its own values (its seams are that mesh's boundaries)
//! refined by Catmull-Clark to its limit, with the mesh's creases and corners, under
//! `faceVaryingLinearInterpolation` ([`FaceVarying`], OpenSubdiv's rules: `cornersPlus1` by
//! default; `all`, and any bilinear mesh, split each control face bilinearly), `uniform` from
//! the control face, `constant` unchanged. Holes (`holeIndices`) are refined as faces, so their
//! neighbours keep the shape they have with the hole filled, and their children are then
//! dropped by the mesh conversion. Faces the cage conversion drops (fewer than 3 vertices,
//! indices out of range, NaN points) are left out of the refinement.
//!
//! A level whose refined mesh would pass about 4 million faces (n-gons counting more, as their
//! limit points weigh every corner) is lowered until it fits, with a problem.
//!
//! Refined faces are numbered hierarchically: the children of control face f are
//! [`Refinement::child_faces`]`(f)`, its n-gon's quad k first, each quad's four children in
//! corner order, so a GeomSubset of control faces maps to ranges of refined faces.

use crate::value::{AttrStore, Problems};
use glam::Vec3;
use std::collections::HashMap;
use std::ops::Range;

/// The per-prim attribute that turns refinement on: the number of uniform levels (0 = the cage).
pub const LEVEL_ATTR: &str = "tide:subdivision:level";
/// The viewer's refinement level for a mesh that authors no [`LEVEL_ATTR`]: Hydra's
/// `HdDisplayStyle::refineLevel` (usdview's complexity), or the command line's. Levels above
/// [`MAX_LEVEL`] are lowered to it without a problem (usdview's highest complexity asks for 8).
pub const REFINE_ATTR: &str = "displayStyle:refineLevel";
/// Levels above this are clamped to it (with a problem).
pub const MAX_LEVEL: u32 = 6;
/// A crease or corner sharpness from which on the feature is sharp at every level.
pub const INFINITELY_SHARP: f32 = 10.0;
/// A triangle's face-point weight in a smooth edge point under the smooth triangle rule
/// (OpenSubdiv's `TRI_SUB_SMOOTH`, in place of ¼).
const SMOOTH_TRIANGLE_EDGE_WEIGHT: f64 = 0.47;

/// At most this many refined faces per mesh (about 4 million quads, 8 million triangles; the
/// refinement peaks near 0.6 kB per refined face): a higher level is lowered (with a problem).
const MAX_REFINED_FACES: u64 = 1 << 22;
/// At most about this many stencil weights per mesh (an n-gon's face point weighs all n points).
const MAX_STENCIL_WEIGHTS: u64 = 1 << 26;

/// The subdivision rules applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scheme {
    CatmullClark,
    /// Faces split at their edge midpoints and centroids; the shape does not change.
    Bilinear,
}

/// `interpolateBoundary`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Boundary {
    /// Boundary vertices with only two incident edges are corners.
    EdgeAndCorner,
    /// Every boundary vertex follows the smooth boundary curve.
    EdgeOnly,
    /// The faces that touch the boundary only shape their neighbours: they are holes
    /// ([`boundary_faces`]), as OpenSubdiv's `VTX_BOUNDARY_NONE` makes them.
    None,
}

/// `faceVaryingLinearInterpolation`: where the faceVarying primvars of a Catmull-Clark mesh
/// keep to straight lines (OpenSubdiv's `FVarLinearInterpolation`). A faceVarying primvar is
/// refined as a mesh of its own values: its seams (edges across which the two faces' values
/// differ) are that mesh's boundaries.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaceVarying {
    /// Smooth everywhere, the seams as smooth boundary curves.
    None,
    /// Smooth, with the corners of the seams (a value used by one face only) pinned.
    CornersOnly,
    /// And junctions, where three or more values meet at a point, pinned (USD's fallback).
    CornersPlus1,
    /// And darts, where a seam ends inside the surface, pinned.
    CornersPlus2,
    /// Smooth inside, linear along every seam and boundary.
    Boundaries,
    /// Linear everywhere: bilinear within each control face.
    All,
}

/// `faceVaryingLinearInterpolation`'s tokens, in [`FaceVarying`]'s order.
const FACE_VARYING_TOKENS: [&str; 6] = ["none", "cornersOnly", "cornersPlus1", "cornersPlus2", "boundaries", "all"];

/// What to refine and how, read from a mesh prim by [`read_options`].
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    pub scheme: Scheme,
    /// 1..=[`MAX_LEVEL`] (a level of 0 refines once).
    pub level: u32,
    pub boundary: Boundary,
    /// Crease edges: (point, point, sharpness); a pair no face edge joins is a problem.
    pub creases: Vec<(u32, u32, f32)>,
    /// Corner points and their sharpness.
    pub corners: Vec<(u32, f32)>,
    pub face_varying: FaceVarying,
    /// `triangleSubdivisionRule = smooth`: edge points next to triangles take OpenSubdiv's
    /// smooth-triangle weights (Catmull-Clark only).
    pub smooth_triangles: bool,
}

impl Options {
    /// Smooth Catmull-Clark at `level` with USD's fallbacks (no creases, `edgeAndCorner`,
    /// `cornersPlus1`).
    pub fn catmull_clark(level: u32) -> Options {
        Options { scheme: Scheme::CatmullClark, level, boundary: Boundary::EdgeAndCorner, creases: Vec::new(), corners: Vec::new(), face_varying: FaceVarying::CornersPlus1, smooth_triangles: false }
    }
}

/// Reads a mesh prim's subdivision settings: `None` renders the cage (level 0, scheme `none`,
/// or `loop`, which is reported). A negative level is a problem and means 0, a level above
/// [`MAX_LEVEL`] is a problem and clamped; a level whose refined mesh would exceed the size
/// limits is lowered with a problem. Malformed crease or corner data is a problem naming its
/// attribute, and that data (all creases, or all corners) is ignored.
pub fn read_options(store: &AttrStore, scheme: &str, counts: &[i32], n_points: usize, p: &mut Problems) -> Option<Options> {
    let authored = store.get(LEVEL_ATTR).is_some();
    let attr = if authored { LEVEL_ATTR } else { REFINE_ATTR };
    store.get(attr)?;
    let raw = store.i64_or(attr, 0, p);
    let asked = if raw < 0 {
        p.add(attr, format!("level {raw} is negative; using 0 (the control cage)"));
        0
    } else if raw > MAX_LEVEL as i64 {
        if authored {
            p.add(attr, format!("level {raw} is above the maximum {MAX_LEVEL}; using {MAX_LEVEL}"));
        }
        MAX_LEVEL
    } else {
        raw as u32
    };
    if asked == 0 {
        return None;
    }
    let scheme = match scheme {
        "catmullClark" => Scheme::CatmullClark,
        "bilinear" => Scheme::Bilinear,
        "loop" => {
            p.add("subdivisionScheme", "loop subdivision is not supported; rendered as its cage");
            return None;
        }
        _ => return None,
    };
    let mut level = asked;
    while level > 0 && {
        let (faces, weights) = refined_size(counts, level);
        faces > MAX_REFINED_FACES || weights > MAX_STENCIL_WEIGHTS
    } {
        level -= 1;
    }
    if level < asked {
        let (faces, _) = refined_size(counts, asked);
        let what = if level == 0 { "rendered as its cage".to_string() } else { format!("refined to level {level}") };
        p.add(attr, format!("level {asked} would make about {faces} faces (at most {MAX_REFINED_FACES}, with n-gons counting more); {what}"));
        if level == 0 {
            return None;
        }
    }
    let boundary = match store.token_or("interpolateBoundary", &["none", "edgeOnly", "edgeAndCorner"], "edgeAndCorner", p) {
        "edgeOnly" => Boundary::EdgeOnly,
        "none" => Boundary::None,
        _ => Boundary::EdgeAndCorner,
    };
    let (creases, corners) = match scheme {
        Scheme::CatmullClark => (read_creases(store, n_points, p), read_corners(store, n_points, p)),
        Scheme::Bilinear => (Vec::new(), Vec::new()),
    };
    let fv = store.token_or("faceVaryingLinearInterpolation", &FACE_VARYING_TOKENS, "cornersPlus1", p);
    let face_varying = [FaceVarying::None, FaceVarying::CornersOnly, FaceVarying::CornersPlus1, FaceVarying::CornersPlus2, FaceVarying::Boundaries, FaceVarying::All]
        [FACE_VARYING_TOKENS.iter().position(|t| *t == fv).unwrap_or(2)];
    let smooth_triangles = scheme == Scheme::CatmullClark && store.token_or("triangleSubdivisionRule", &["catmullClark", "smooth"], "catmullClark", p) == "smooth";
    Some(Options { scheme, level, boundary, creases, corners, face_varying, smooth_triangles })
}

/// The faces (of `counts` corners, indexing `indices` into `n_points` points) that touch the
/// boundary: a vertex of theirs lies on an edge only one face has. Faces that cannot be drawn
/// (fewer than 3 corners, indices out of range) neither count nor are flagged.
pub fn boundary_faces(counts: &[i32], indices: &[i32], n_points: usize) -> Vec<bool> {
    let mut ranges = Vec::with_capacity(counts.len());
    let mut off = 0usize;
    for &c in counts {
        let c = c.max(0) as usize;
        let r = off..(off + c).min(indices.len());
        off += c;
        let usable = c >= 3 && r.len() == c && indices[r.clone()].iter().all(|&i| i >= 0 && (i as usize) < n_points);
        ranges.push(usable.then_some(r));
    }
    let mut uses: HashMap<(i32, i32), u32> = HashMap::new();
    for r in ranges.iter().flatten() {
        let f = &indices[r.clone()];
        for k in 0..f.len() {
            let (a, b) = (f[k], f[(k + 1) % f.len()]);
            *uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
    }
    let mut on_boundary = vec![false; n_points];
    for (&(a, b), &n) in &uses {
        if n == 1 {
            on_boundary[a as usize] = true;
            on_boundary[b as usize] = true;
        }
    }
    ranges.iter().map(|r| r.as_ref().is_some_and(|r| indices[r.clone()].iter().any(|&i| on_boundary[i as usize]))).collect()
}

/// Refined faces and (roughly) stencil weights of refining faces of `counts` corners `level` times.
fn refined_size(counts: &[i32], level: u32) -> (u64, u64) {
    let d = 1u64 << (2 * (level.max(1) - 1));
    counts.iter().filter(|&&c| c >= 3).fold((0u64, 0u64), |(f, w), &c| {
        let faces = (c as u64).saturating_mul(d);
        (f.saturating_add(faces), w.saturating_add(faces.saturating_mul(16 + c as u64)))
    })
}

/// Ints of an attribute (empty when unauthored); a wrong type is a problem and `None`.
fn ints(store: &AttrStore, name: &str, what: &str, p: &mut Problems) -> Option<Vec<i32>> {
    match store.get(name) {
        None => Some(Vec::new()),
        Some(v) => v.to_ints().or_else(|| {
            p.add(name, format!("expected Ints, got {}; {what} ignored", v.kind()));
            None
        }),
    }
}

/// Floats of an attribute (empty when unauthored); a wrong type or a NaN is a problem and `None`.
fn floats(store: &AttrStore, name: &str, what: &str, p: &mut Problems) -> Option<Vec<f32>> {
    match store.get(name) {
        None => Some(Vec::new()),
        Some(v) => match v.to_f32s() {
            Some(d) if d.iter().any(|x| x.is_nan()) => {
                p.add(name, format!("contains NaN; {what} ignored"));
                None
            }
            Some(d) => Some(d),
            None => {
                p.add(name, format!("expected Floats, got {}; {what} ignored", v.kind()));
                None
            }
        },
    }
}

/// `creaseIndices`, `creaseLengths`, `creaseSharpnesses` as crease edges (empty if malformed).
fn read_creases(store: &AttrStore, n_points: usize, p: &mut Problems) -> Vec<(u32, u32, f32)> {
    const WHAT: &str = "the creases are";
    let idx = ints(store, "creaseIndices", WHAT, p);
    let lens = ints(store, "creaseLengths", WHAT, p);
    let sharp = floats(store, "creaseSharpnesses", WHAT, p);
    let (Some(idx), Some(lens), Some(sharp)) = (idx, lens, sharp) else { return Vec::new() };
    if idx.is_empty() && lens.is_empty() && sharp.is_empty() {
        return Vec::new();
    }
    if let Some(&l) = lens.iter().find(|&&l| l < 2) {
        p.add("creaseLengths", format!("a crease of length {l} (each joins at least 2 points); {WHAT} ignored"));
        return Vec::new();
    }
    let total: i64 = lens.iter().map(|&l| l as i64).sum();
    if total != idx.len() as i64 {
        p.add("creaseLengths", format!("lengths sum to {total} but creaseIndices has {} entries; {WHAT} ignored", idx.len()));
        return Vec::new();
    }
    if let Some(&i) = idx.iter().find(|&&i| i < 0 || i as usize >= n_points) {
        p.add("creaseIndices", format!("point index {i} is out of range (0..{n_points}); {WHAT} ignored"));
        return Vec::new();
    }
    let n_edges = idx.len() - lens.len();
    let per_edge = if sharp.len() == lens.len() {
        false
    } else if sharp.len() == n_edges {
        true
    } else {
        p.add(
            "creaseSharpnesses",
            format!("{} values for {} creases of {} edges (one per crease or one per crease edge); {WHAT} ignored", sharp.len(), lens.len(), n_edges),
        );
        return Vec::new();
    };
    let mut out = Vec::with_capacity(n_edges);
    let mut start = 0;
    for (c, &l) in lens.iter().enumerate() {
        for k in start..start + l as usize - 1 {
            out.push((idx[k] as u32, idx[k + 1] as u32, if per_edge { sharp[out.len()] } else { sharp[c] }));
        }
        start += l as usize;
    }
    out
}

/// `cornerIndices`, `cornerSharpnesses` (empty if malformed).
fn read_corners(store: &AttrStore, n_points: usize, p: &mut Problems) -> Vec<(u32, f32)> {
    const WHAT: &str = "the corners are";
    let idx = ints(store, "cornerIndices", WHAT, p);
    let sharp = floats(store, "cornerSharpnesses", WHAT, p);
    let (Some(idx), Some(sharp)) = (idx, sharp) else { return Vec::new() };
    if sharp.len() != idx.len() {
        p.add("cornerSharpnesses", format!("{} values for {} cornerIndices (one per corner); {WHAT} ignored", sharp.len(), idx.len()));
        return Vec::new();
    }
    if let Some(&i) = idx.iter().find(|&&i| i < 0 || i as usize >= n_points) {
        p.add("cornerIndices", format!("point index {i} is out of range (0..{n_points}); {WHAT} ignored"));
        return Vec::new();
    }
    idx.iter().zip(sharp).map(|(&i, s)| (i as u32, s)).collect()
}

/// A sparse linear map from source values (control points) to refined values: row r is
/// Σ weight·source over its entries.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Stencil {
    offsets: Vec<usize>,
    sources: Vec<u32>,
    weights: Vec<f32>,
    n_sources: usize,
}

impl Stencil {
    fn empty(n_sources: usize, rows: usize, weights: usize) -> Stencil {
        let mut offsets = Vec::with_capacity(rows + 1);
        offsets.push(0);
        Stencil { offsets, sources: Vec::with_capacity(weights), weights: Vec::with_capacity(weights), n_sources }
    }

    /// Number of rows (refined values).
    pub fn len(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Number of source values (control points) it reads.
    pub fn source_count(&self) -> usize {
        self.n_sources
    }

    /// Total number of weights.
    pub fn weight_count(&self) -> usize {
        self.weights.len()
    }

    /// Row `r` as (source, weight) pairs.
    pub fn row(&self, r: usize) -> impl Iterator<Item = (usize, f32)> + '_ {
        let k = self.offsets[r]..self.offsets[r + 1];
        self.sources[k.clone()].iter().zip(&self.weights[k]).map(|(&s, &w)| (s as usize, w))
    }

    /// Applies the map to flat data of `tuple` components per source (missing sources read 0).
    pub fn apply(&self, data: &[f32], tuple: usize) -> Vec<f32> {
        if tuple == 0 {
            return Vec::new();
        }
        let need = self.n_sources * tuple;
        let padded;
        let data = if data.len() >= need {
            data
        } else {
            padded = data.iter().copied().chain(std::iter::repeat(0.0)).take(need).collect::<Vec<f32>>();
            &padded[..]
        };
        let mut out = vec![0.0f32; self.len() * tuple];
        for (r, o) in out.chunks_exact_mut(tuple).enumerate() {
            for k in self.offsets[r]..self.offsets[r + 1] {
                let (s, w) = (self.sources[k] as usize * tuple, self.weights[k]);
                for (x, &d) in o.iter_mut().zip(&data[s..s + tuple]) {
                    *x += w * d;
                }
            }
        }
        out
    }

    /// Applies the map to points (or vectors); missing sources read 0.
    pub fn apply_vec3(&self, data: &[Vec3]) -> Vec<Vec3> {
        (0..self.len())
            .map(|r| (self.offsets[r]..self.offsets[r + 1]).fold(Vec3::ZERO, |a, k| a + self.weights[k] * data.get(self.sources[k] as usize).copied().unwrap_or(Vec3::ZERO)))
            .collect()
    }
}

/// Sums weighted rows of the previous level's stencil into one row of the next.
struct Acc {
    w: Vec<f64>,
    used: Vec<bool>,
    touched: Vec<u32>,
}

impl Acc {
    fn new(n: usize) -> Acc {
        Acc { w: vec![0.0; n], used: vec![false; n], touched: Vec::new() }
    }

    /// Adds `w` times vertex `v` of the previous level: its row of `prev`, or the control point
    /// itself when `prev` is `None` (the cage level).
    fn add(&mut self, prev: Option<&Stencil>, v: u32, w: f64) {
        if w == 0.0 {
            return;
        }
        match prev {
            None => self.put(v, w),
            Some(s) => {
                for k in s.offsets[v as usize]..s.offsets[v as usize + 1] {
                    self.put(s.sources[k], w * s.weights[k] as f64);
                }
            }
        }
    }

    fn put(&mut self, c: u32, w: f64) {
        let i = c as usize;
        if !self.used[i] {
            self.used[i] = true;
            self.touched.push(c);
        }
        self.w[i] += w;
    }

    fn end_row(&mut self, out: &mut Stencil) {
        for &c in &self.touched {
            let i = c as usize;
            if self.w[i] != 0.0 {
                out.sources.push(c);
                out.weights.push(self.w[i] as f32);
            }
            self.w[i] = 0.0;
            self.used[i] = false;
        }
        self.touched.clear();
        out.offsets.push(out.sources.len());
    }
}

/// Compressed adjacency lists: the values of key k are `val[off[k]..off[k + 1]]`.
struct Csr {
    off: Vec<u32>,
    val: Vec<u32>,
}

impl Csr {
    /// Built from the (key, value) pairs `each` emits (called twice: counting, then filling),
    /// each key's values in emission order.
    fn build(n: usize, each: impl Fn(&mut dyn FnMut(usize, u32))) -> Csr {
        let mut off = vec![0u32; n + 1];
        each(&mut |k, _| off[k + 1] += 1);
        for i in 0..n {
            off[i + 1] += off[i];
        }
        let mut cursor = off.clone();
        let mut val = vec![0u32; off[n] as usize];
        each(&mut |k, v| {
            val[cursor[k] as usize] = v;
            cursor[k] += 1;
        });
        Csr { off, val }
    }

    fn get(&self, k: usize) -> &[u32] {
        &self.val[self.off[k] as usize..self.off[k + 1] as usize]
    }
}

/// Sharpness after one level of uniform refinement.
fn decay(s: f32) -> f32 {
    if s >= INFINITELY_SHARP {
        s
    } else {
        (s - 1.0).max(0.0)
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Rule {
    /// No sharp edge, or one (a dart).
    Smooth,
    /// Two sharp edges.
    Crease,
    /// A sharp vertex, or three or more sharp edges.
    Corner,
}

fn rule(vertex_sharpness: f32, sharp_edges: usize) -> Rule {
    if vertex_sharpness > 0.0 {
        return Rule::Corner;
    }
    match sharp_edges {
        0 | 1 => Rule::Smooth,
        2 => Rule::Crease,
        _ => Rule::Corner,
    }
}

/// The topology of one level, with its edges, adjacency and sharpness.
struct Topo {
    n_verts: usize,
    face_off: Vec<u32>,
    face_verts: Vec<u32>,
    /// Per face corner: the edge from that corner to the next.
    face_edges: Vec<u32>,
    edges: Vec<[u32; 2]>,
    /// Infinitely sharp for boundary and non-manifold edges.
    edge_sharp: Vec<f32>,
    vert_sharp: Vec<f32>,
    edge_faces: Csr,
    vert_edges: Csr,
    vert_faces: Csr,
}

impl Topo {
    #[allow(clippy::too_many_arguments)]
    fn assemble(n_verts: usize, face_off: Vec<u32>, face_verts: Vec<u32>, face_edges: Vec<u32>, edges: Vec<[u32; 2]>, edge_sharp: Vec<f32>, vert_sharp: Vec<f32>) -> Topo {
        let n_faces = face_off.len() - 1;
        let each_corner = |emit: &mut dyn FnMut(usize, u32), by_edge: bool| {
            for f in 0..n_faces {
                for c in face_off[f] as usize..face_off[f + 1] as usize {
                    emit(if by_edge { face_edges[c] } else { face_verts[c] } as usize, f as u32);
                }
            }
        };
        let edge_faces = Csr::build(edges.len(), |emit| each_corner(emit, true));
        let vert_faces = Csr::build(n_verts, |emit| each_corner(emit, false));
        let vert_edges = Csr::build(n_verts, |emit| {
            for (e, &[a, b]) in edges.iter().enumerate() {
                emit(a as usize, e as u32);
                if b != a {
                    emit(b as usize, e as u32);
                }
            }
        });
        Topo { n_verts, face_off, face_verts, face_edges, edges, edge_sharp, vert_sharp, edge_faces, vert_edges, vert_faces }
    }

    /// The control level: the usable faces (corner ranges of `indices`), edges found through a
    /// map of point pairs, sharpness from the boundary, the creases and the corners.
    fn from_cage(n_points: usize, faces: &[Range<usize>], indices: &[i32], opts: &Options, p: &mut Problems) -> Topo {
        let mut face_off = Vec::with_capacity(faces.len() + 1);
        face_off.push(0u32);
        let mut face_verts = Vec::new();
        for r in faces {
            face_verts.extend(indices[r.clone()].iter().map(|&i| i as u32));
            face_off.push(face_verts.len() as u32);
        }
        let mut map: HashMap<(u32, u32), u32> = HashMap::with_capacity(face_verts.len());
        let mut edges: Vec<[u32; 2]> = Vec::new();
        let mut face_edges = Vec::with_capacity(face_verts.len());
        for f in 0..faces.len() {
            let fv = &face_verts[face_off[f] as usize..face_off[f + 1] as usize];
            for k in 0..fv.len() {
                let (a, b) = (fv[k], fv[(k + 1) % fv.len()]);
                let e = *map.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    edges.push([a, b]);
                    edges.len() as u32 - 1
                });
                face_edges.push(e);
            }
        }
        let n_edges = edges.len();
        let mut t = Topo::assemble(n_points, face_off, face_verts, face_edges, edges, vec![0.0; n_edges], vec![0.0; n_points]);
        for e in 0..n_edges {
            if t.edge_faces.get(e).len() != 2 {
                t.edge_sharp[e] = INFINITELY_SHARP;
            }
        }
        let mut missing = 0usize;
        for &(a, b, s) in &opts.creases {
            match map.get(&(a.min(b), a.max(b))) {
                Some(&e) => t.edge_sharp[e as usize] = t.edge_sharp[e as usize].max(s),
                None => missing += 1,
            }
        }
        if missing > 0 {
            p.add("creaseIndices", format!("{missing} crease edge(s) join points that no face edge joins; ignored"));
        }
        for &(v, s) in &opts.corners {
            if let Some(x) = t.vert_sharp.get_mut(v as usize) {
                *x = x.max(s);
            }
        }
        for v in 0..n_points {
            let edges = t.vert_edges.get(v);
            let pinned = opts.boundary != Boundary::EdgeOnly && edges.len() == 2 && edges.iter().any(|&e| t.edge_faces.get(e as usize).len() == 1);
            if pinned || t.fans(v) > 1 {
                t.vert_sharp[v] = INFINITELY_SHARP;
            }
        }
        t
    }

    /// How many fans of faces (connected through the vertex's edges) meet at vertex `v`.
    fn fans(&self, v: usize) -> usize {
        let mut faces: Vec<u32> = self.vert_faces.get(v).to_vec();
        faces.dedup(); // ascending: faces were listed in face order
        if faces.len() < 2 {
            return faces.len();
        }
        let mut parent: Vec<usize> = (0..faces.len()).collect();
        fn root(parent: &mut [usize], mut i: usize) -> usize {
            while parent[i] != i {
                parent[i] = parent[parent[i]];
                i = parent[i];
            }
            i
        }
        for &e in self.vert_edges.get(v) {
            let fs = self.edge_faces.get(e as usize);
            let Ok(first) = faces.binary_search(&fs[0]) else { continue };
            for f in &fs[1..] {
                if let Ok(i) = faces.binary_search(f) {
                    let (a, b) = (root(&mut parent, first), root(&mut parent, i));
                    parent[a] = b;
                }
            }
        }
        (0..faces.len()).filter(|&i| root(&mut parent, i) == i).count()
    }

    fn n_faces(&self) -> usize {
        self.face_off.len() - 1
    }

    fn face(&self, f: usize) -> &[u32] {
        &self.face_verts[self.face_off[f] as usize..self.face_off[f + 1] as usize]
    }

    fn other(&self, e: u32, v: usize) -> u32 {
        let [a, b] = self.edges[e as usize];
        if a as usize == v {
            b
        } else {
            a
        }
    }

    /// The face point: the centroid.
    fn face_point(&self, f: usize, w: f64, out: &mut impl FnMut(u32, f64)) {
        let fv = self.face(f);
        for &v in fv {
            out(v, w / fv.len() as f64);
        }
    }

    /// The Catmull-Clark edge point: the midpoint on a sharp edge, the average of the end
    /// points and the two face points on a smooth one, blended by a sharpness in (0, 1).
    /// With `smooth_triangles` (USD's `triangleSubdivisionRule = smooth`, OpenSubdiv's smooth
    /// triangle option) a triangle's face point weighs 0.47 instead of ¼ in the smooth rule:
    /// both face points take the mean of their faces' weights, the end points what is left.
    fn edge_point(&self, e: usize, smooth_triangles: bool, out: &mut impl FnMut(u32, f64)) {
        let [a, b] = self.edges[e];
        let faces = self.edge_faces.get(e);
        let sharp = if faces.len() == 2 { (self.edge_sharp[e] as f64).clamp(0.0, 1.0) } else { 1.0 };
        out(a, 0.5 * sharp);
        out(b, 0.5 * sharp);
        if sharp < 1.0 {
            let w = 1.0 - sharp;
            let face_weight = |f: u32| if smooth_triangles && self.face(f as usize).len() == 3 { SMOOTH_TRIANGLE_EDGE_WEIGHT } else { 0.25 };
            let fw = faces.iter().map(|&f| face_weight(f)).sum::<f64>() / faces.len() as f64;
            let vw = 0.5 * (1.0 - 2.0 * fw);
            out(a, vw * w);
            out(b, vw * w);
            for &f in faces {
                self.face_point(f as usize, fw * w, out);
            }
        }
    }

    /// The Catmull-Clark vertex point, blending the parent's and the child's rule where a
    /// sharpness decays to zero on this level.
    fn vertex_point(&self, v: usize, out: &mut impl FnMut(u32, f64)) {
        let edges = self.vert_edges.get(v);
        let vs = self.vert_sharp[v];
        let count = |sharp: &dyn Fn(f32) -> bool| edges.iter().filter(|&&e| sharp(self.edge_sharp[e as usize])).count();
        let parent = rule(vs, count(&|s| s > 0.0));
        let child = rule(decay(vs), count(&|s| decay(s) > 0.0));
        if parent == child {
            self.vertex_mask(v, parent, 1.0, &|s| s > 0.0, out);
            return;
        }
        let (mut n, mut sum) = (0usize, 0.0f64);
        for s in std::iter::once(vs).chain(edges.iter().map(|&e| self.edge_sharp[e as usize])) {
            if s > 0.0 && decay(s) <= 0.0 {
                n += 1;
                sum += s as f64;
            }
        }
        let fw = if n == 0 { 0.0 } else { (sum / n as f64).min(1.0) };
        self.vertex_mask(v, parent, fw, &|s| s > 0.0, out);
        self.vertex_mask(v, child, 1.0 - fw, &|s| decay(s) > 0.0, out);
    }

    /// One rule's vertex mask times `w`; `sharp` says which edges are sharp for that rule.
    fn vertex_mask(&self, v: usize, rule: Rule, w: f64, sharp: &dyn Fn(f32) -> bool, out: &mut impl FnMut(u32, f64)) {
        if w == 0.0 {
            return;
        }
        let edges = self.vert_edges.get(v);
        let faces = self.vert_faces.get(v);
        match rule {
            Rule::Corner => out(v as u32, w),
            Rule::Crease => {
                out(v as u32, 0.75 * w);
                for &e in edges.iter().filter(|&&e| sharp(self.edge_sharp[e as usize])) {
                    out(self.other(e, v), 0.125 * w);
                }
            }
            Rule::Smooth => {
                let (n, m) = (edges.len() as f64, faces.len() as f64);
                if edges.len() < 2 || faces.is_empty() {
                    out(v as u32, w);
                    return;
                }
                out(v as u32, w * (n - 2.0) / n);
                for &e in edges {
                    out(self.other(e, v), w / (n * n));
                }
                for &f in faces {
                    self.face_point(f as usize, w / (n * m), out);
                }
            }
        }
    }

    /// The Catmull-Clark limit position of vertex `v` (every face a quad, as after one level).
    fn limit_point(&self, v: usize, out: &mut impl FnMut(u32, f64)) {
        let edges = self.vert_edges.get(v);
        let faces = self.vert_faces.get(v);
        let sharp_edges = || edges.iter().filter(|&&e| self.edge_sharp[e as usize] > 0.0);
        match rule(self.vert_sharp[v], sharp_edges().count()) {
            Rule::Corner => out(v as u32, 1.0),
            Rule::Crease => {
                out(v as u32, 4.0 / 6.0);
                for &e in sharp_edges() {
                    out(self.other(e, v), 1.0 / 6.0);
                }
            }
            Rule::Smooth => {
                if edges.len() < 2 || faces.is_empty() {
                    out(v as u32, 1.0);
                    return;
                }
                let n = edges.len() as f64;
                let denom = n * n + 4.0 * n + faces.len() as f64;
                out(v as u32, n * n / denom);
                for &e in edges {
                    out(self.other(e, v), 4.0 / denom);
                }
                for &f in faces {
                    let fv = self.face(f as usize);
                    match fv.iter().position(|&u| u as usize == v) {
                        Some(k) if fv.len() == 4 => out(fv[(k + 2) % 4], 1.0 / denom),
                        _ => self.face_point(f as usize, 1.0 / denom, out),
                    }
                }
            }
        }
    }

    /// This control level refined `level` times by `scheme`, and the stencil giving its
    /// vertices over the control vertices (at their limit for Catmull-Clark).
    fn refined(self, level: u32, scheme: Scheme, smooth_triangles: bool) -> (Topo, Stencil) {
        let n = self.n_verts;
        let mut topo = self;
        let mut rows: Option<Stencil> = None;
        for _ in 0..level {
            let next = topo.refine_rows(rows.as_ref(), scheme, n, smooth_triangles);
            topo = topo.refine();
            rows = Some(next);
        }
        let mut stencil = rows.unwrap_or_default();
        if scheme == Scheme::CatmullClark {
            stencil = topo.limit_rows(&stencil, n);
        }
        (topo, stencil)
    }

    /// The next level's vertices as rows over the control points: vertex points (child of
    /// vertex v is v), then face points, then edge points.
    fn refine_rows(&self, prev: Option<&Stencil>, scheme: Scheme, n_control: usize, smooth_triangles: bool) -> Stencil {
        let (nv, nf, ne) = (self.n_verts, self.n_faces(), self.edges.len());
        let per_row = prev.map_or(1, |s| s.weights.len().div_ceil(s.len().max(1)));
        let mut out = Stencil::empty(n_control, nv + nf + ne, (nv + nf + ne) * (per_row + 4));
        let mut acc = Acc::new(n_control);
        // a mask over this level's vertices, merged (face points repeat vertices) before its
        // rows are summed
        let mut mask: Vec<(u32, f64)> = Vec::new();
        let push = |mask: &mut Vec<(u32, f64)>, u: u32, w: f64| match mask.iter_mut().take(64).find(|m| m.0 == u) {
            Some(m) => m.1 += w,
            None => mask.push((u, w)),
        };
        let emit = |mask: &mut Vec<(u32, f64)>, acc: &mut Acc, out: &mut Stencil| {
            for &(u, w) in mask.iter() {
                acc.add(prev, u, w);
            }
            mask.clear();
            acc.end_row(out);
        };
        for v in 0..nv {
            match scheme {
                Scheme::CatmullClark => self.vertex_point(v, &mut |u, w| push(&mut mask, u, w)),
                Scheme::Bilinear => push(&mut mask, v as u32, 1.0),
            }
            emit(&mut mask, &mut acc, &mut out);
        }
        for f in 0..nf {
            self.face_point(f, 1.0, &mut |u, w| push(&mut mask, u, w));
            emit(&mut mask, &mut acc, &mut out);
        }
        for e in 0..ne {
            match scheme {
                Scheme::CatmullClark => self.edge_point(e, smooth_triangles, &mut |u, w| push(&mut mask, u, w)),
                Scheme::Bilinear => {
                    let [a, b] = self.edges[e];
                    push(&mut mask, a, 0.5);
                    push(&mut mask, b, 0.5);
                }
            }
            emit(&mut mask, &mut acc, &mut out);
        }
        out
    }

    /// The limit positions of this level's vertices as rows over the control points.
    fn limit_rows(&self, rows: &Stencil, n_control: usize) -> Stencil {
        let mut out = Stencil::empty(n_control, self.n_verts, rows.weights.len() + rows.weights.len() / 2);
        let mut acc = Acc::new(n_control);
        for v in 0..self.n_verts {
            self.limit_point(v, &mut |u, w| acc.add(Some(rows), u, w));
            acc.end_row(&mut out);
        }
        out
    }

    /// The next level's topology: face f's corner k becomes the quad (vertex k, point of the
    /// edge leaving k, face point, point of the edge entering k); edge e splits into 2e (at its
    /// first end) and 2e + 1; each face corner adds an edge from its edge point to the face point.
    fn refine(&self) -> Topo {
        let (nv, nf, ne) = (self.n_verts, self.n_faces(), self.edges.len());
        let n_corners = self.face_verts.len();
        let fp = |f: usize| (nv + f) as u32;
        let ep = |e: u32| (nv + nf) as u32 + e;
        let half = |e: u32, v: u32| if self.edges[e as usize][0] == v { 2 * e } else { 2 * e + 1 };
        let mut face_verts = Vec::with_capacity(4 * n_corners);
        let mut face_edges = Vec::with_capacity(4 * n_corners);
        for f in 0..nf {
            let start = self.face_off[f] as usize;
            let m = self.face_off[f + 1] as usize - start;
            for k in 0..m {
                let prev = start + (k + m - 1) % m;
                let (v, e_out, e_in) = (self.face_verts[start + k], self.face_edges[start + k], self.face_edges[prev]);
                face_verts.extend_from_slice(&[v, ep(e_out), fp(f), ep(e_in)]);
                let inner = |c: usize| (2 * ne + c) as u32;
                face_edges.extend_from_slice(&[half(e_out, v), inner(start + k), inner(prev), half(e_in, v)]);
            }
        }
        let mut edges = Vec::with_capacity(2 * ne + n_corners);
        let mut edge_sharp = Vec::with_capacity(2 * ne + n_corners);
        for (e, &[a, b]) in self.edges.iter().enumerate() {
            edges.push([a, ep(e as u32)]);
            edges.push([ep(e as u32), b]);
            let s = decay(self.edge_sharp[e]);
            edge_sharp.extend_from_slice(&[s, s]);
        }
        for f in 0..nf {
            for c in self.face_off[f] as usize..self.face_off[f + 1] as usize {
                edges.push([ep(self.face_edges[c]), fp(f)]);
                edge_sharp.push(0.0);
            }
        }
        let mut vert_sharp: Vec<f32> = self.vert_sharp.iter().map(|&s| decay(s)).collect();
        vert_sharp.resize(nv + nf + ne, 0.0);
        let face_off = (0..=n_corners as u32).map(|i| 4 * i).collect();
        Topo::assemble(nv + nf + ne, face_off, face_verts, face_edges, edges, edge_sharp, vert_sharp)
    }
}

/// A refined mesh: its points, quads, the stencil that made the points, and what carries
/// primvars from the control cage onto it.
#[derive(Clone, Debug)]
pub struct Refinement {
    pub scheme: Scheme,
    pub level: u32,
    /// The refined points: limit positions (Catmull-Clark) or split positions (bilinear).
    pub points: Vec<Vec3>,
    /// Four per refined face, in the control face's winding.
    pub face_vertex_indices: Vec<i32>,
    /// Control points → refined points.
    pub stencil: Stencil,
    /// Per control face, its first refined face (and one past the last at the end).
    child_offsets: Vec<u32>,
    /// Per control face, its first corner in `cage_indices` and its corner count (0: not refined).
    cage_faces: Vec<(u32, u32)>,
    cage_indices: Vec<i32>,
    /// The (u, v) of every corner of the descendants of one level-1 quad, in refined order.
    pattern: Vec<[f32; 2]>,
    /// The options refined with (creases, corners and the faceVarying rule shape faceVarying
    /// primvars too).
    opts: Options,
}

/// Refines a control cage (`faceVertexCounts`, `faceVertexIndices`, `points`) as `opts` says
/// (level clamped to 1..=[`MAX_LEVEL`]). Faces with fewer than 3 vertices, indices out of range
/// or NaN points are left out, as is everything after `counts` runs past the indices (the
/// cage conversion reports these); crease edges no face edge joins are a problem.
pub fn refine(counts: &[i32], indices: &[i32], points: &[Vec3], opts: &Options, p: &mut Problems) -> Refinement {
    let level = opts.level.clamp(1, MAX_LEVEL);
    let n = points.len();
    let mut ranges = Vec::new();
    let mut cage_faces = vec![(0u32, 0u32); counts.len()];
    let mut offset = 0usize;
    for (f, &c) in counts.iter().enumerate() {
        if c < 0 || offset + c as usize > indices.len() {
            break;
        }
        let r = offset..offset + c as usize;
        offset = r.end;
        if r.len() < 3 || indices[r.clone()].iter().any(|&i| i < 0 || i as usize >= n || !points[i as usize].is_finite()) {
            continue;
        }
        cage_faces[f] = (r.start as u32, r.len() as u32);
        ranges.push(r);
    }
    let descendants = 1u32 << (2 * (level - 1));
    let mut child_offsets = Vec::with_capacity(counts.len() + 1);
    child_offsets.push(0u32);
    for &(_, m) in &cage_faces {
        child_offsets.push(child_offsets.last().copied().unwrap_or(0) + m * descendants);
    }

    let (topo, stencil) = Topo::from_cage(n, &ranges, indices, opts, p).refined(level, opts.scheme, opts.smooth_triangles);
    let points = stencil.apply_vec3(points);
    let face_vertex_indices = topo.face_verts.iter().map(|&v| v as i32).collect();

    let mut quads = vec![[[0.0f32, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]];
    for _ in 1..level {
        quads = quads
            .iter()
            .flat_map(|q| {
                let mid = |a: [f32; 2], b: [f32; 2]| [0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])];
                let center = mid(mid(q[0], q[1]), mid(q[2], q[3]));
                (0..4).map(move |s| [q[s], mid(q[s], q[(s + 1) % 4]), center, mid(q[(s + 3) % 4], q[s])])
            })
            .collect();
    }
    let pattern = quads.into_iter().flatten().collect();
    Refinement { scheme: opts.scheme, level, points, face_vertex_indices, stencil, child_offsets, cage_faces, cage_indices: indices.to_vec(), pattern, opts: opts.clone() }
}

impl Refinement {
    /// The refined faces (quads) of control face `face`; empty for a face left out.
    pub fn child_faces(&self, face: usize) -> Range<usize> {
        match (self.child_offsets.get(face), self.child_offsets.get(face + 1)) {
            (Some(&a), Some(&b)) => a as usize..b as usize,
            _ => 0..0,
        }
    }

    /// Number of refined faces.
    pub fn face_count(&self) -> usize {
        self.face_vertex_indices.len() / 4
    }

    /// A `vertex` primvar (or velocities, ...) on the refined points: through the stencil.
    pub fn vertex(&self, data: &[f32], tuple: usize) -> Vec<f32> {
        self.stencil.apply(data, tuple)
    }

    /// Bilinear interpolation within each control face: `x(first corner, k, component)` is the
    /// value at corner k of the face whose corners start at `first` (in `cage_indices`);
    /// `put(refined corner, component, value)` receives the refined corners' values.
    fn bilinear_faces(&self, x: impl Fn(usize, usize, usize) -> f32, tuple: usize, mut put: impl FnMut(usize, usize, f32)) {
        let d = self.pattern.len() / 4;
        for (f, &(start, m)) in self.cage_faces.iter().enumerate() {
            let (start, m) = (start as usize, m as usize);
            if m == 0 {
                continue;
            }
            let first = self.child_offsets[f] as usize;
            for c in 0..tuple {
                let avg = (0..m).map(|k| x(start, k, c)).sum::<f32>() / m as f32;
                for k in 0..m {
                    let (a, b, z) = (x(start, k, c), x(start, (k + 1) % m, c), x(start, (k + m - 1) % m, c));
                    // the level-1 quad k: corner k, its outgoing edge's midpoint, the centroid,
                    // its incoming edge's midpoint
                    let q = [a, 0.5 * (a + b), avg, 0.5 * (z + a)];
                    for (j, &[u, v]) in self.pattern.iter().enumerate() {
                        let val = (1.0 - u) * (1.0 - v) * q[0] + u * (1.0 - v) * q[1] + u * v * q[2] + (1.0 - u) * v * q[3];
                        put(4 * (first + k * d) + j, c, val);
                    }
                }
            }
        }
    }

    /// A `varying` primvar on the refined points: bilinear over the refined faces (points
    /// used by no refined face keep their control value, or 0).
    pub fn varying(&self, data: &[f32], tuple: usize) -> Vec<f32> {
        let n = self.points.len();
        let mut out: Vec<f32> = data.iter().copied().chain(std::iter::repeat(0.0)).take(n * tuple).collect();
        let value = |i: i32, c: usize| data.get(i as usize * tuple + c).copied().unwrap_or(0.0);
        self.bilinear_faces(|start, k, c| value(self.cage_indices[start + k], c), tuple, |corner, c, v| {
            out[self.face_vertex_indices[corner] as usize * tuple + c] = v;
        });
        out
    }

    /// A `faceVarying` primvar (one value per control face corner) on the refined corners:
    /// bilinear within each control face for a bilinear mesh or the rule `all`; otherwise
    /// refined by Catmull-Clark as a mesh of its own values, to their limit as the points are
    /// ([`FaceVarying`]). Corners of one point with equal values share a value (however the
    /// primvar is indexed).
    pub fn face_varying(&self, data: &[f32], tuple: usize) -> Vec<f32> {
        let mut out = vec![0.0f32; self.face_vertex_indices.len() * tuple];
        let value = |corner: usize, c: usize| data.get(corner * tuple + c).copied().unwrap_or(0.0);
        if self.scheme == Scheme::Bilinear || self.opts.face_varying == FaceVarying::All {
            self.bilinear_faces(|start, k, c| value(start + k, c), tuple, |corner, c, v| out[corner * tuple + c] = v);
            return out;
        }
        // the values' mesh: one vertex per (point, value) of the refined control faces
        let mut ids: HashMap<(i32, Vec<u32>), u32> = HashMap::new();
        let mut values: Vec<f32> = Vec::new();
        let mut owner: Vec<i32> = Vec::new();
        let mut fv_indices = vec![0i32; self.cage_indices.len()];
        let mut ranges = Vec::new();
        for &(start, m) in self.cage_faces.iter().filter(|f| f.1 > 0) {
            let r = start as usize..(start + m) as usize;
            for corner in r.clone() {
                let v = self.cage_indices[corner];
                let x: Vec<f32> = (0..tuple).map(|c| value(corner, c)).collect();
                let id = *ids.entry((v, x.iter().map(|f| f.to_bits()).collect())).or_insert_with(|| {
                    values.extend_from_slice(&x);
                    owner.push(v);
                    owner.len() as u32 - 1
                });
                fv_indices[corner] = id as i32;
            }
            ranges.push(r);
        }
        let (t, stencil) = self.value_mesh(owner.len(), &ranges, &fv_indices, &owner).refined(self.level, Scheme::CatmullClark, self.opts.smooth_triangles);
        let refined = stencil.apply(&values, tuple);
        for (corner, &v) in t.face_verts.iter().enumerate() {
            out[corner * tuple..(corner + 1) * tuple].copy_from_slice(&refined[v as usize * tuple..(v as usize + 1) * tuple]);
        }
        out
    }

    /// The control level of a faceVarying primvar's own mesh (`n` values; `owner[i]`: the
    /// point of value i): the mesh's creases and corners on the edges and points they lie on,
    /// and the faceVarying rule's pins.
    fn value_mesh(&self, n: usize, ranges: &[Range<usize>], fv: &[i32], owner: &[i32]) -> Topo {
        let rule = self.opts.face_varying;
        let sharp: HashMap<(u32, u32), f32> = self.opts.creases.iter().map(|&(a, b, s)| ((a.min(b), a.max(b)), s)).collect();
        // each face edge as its two corners
        let face_edges = || ranges.iter().flat_map(|r| r.clone().map(move |k| (k, r.start + (k - r.start + 1) % r.len())));
        let mut creases = Vec::new();
        for (k, next) in face_edges() {
            let (a, b) = (self.cage_indices[k] as u32, self.cage_indices[next] as u32);
            if let Some(&s) = sharp.get(&(a.min(b), a.max(b))) {
                creases.push((fv[k] as u32, fv[next] as u32, s));
            }
        }
        let pinned: HashMap<i32, f32> = self.opts.corners.iter().map(|&(v, s)| (v as i32, s)).collect();
        let corners = (0..n).filter_map(|i| pinned.get(&owner[i]).map(|&s| (i as u32, s))).collect();
        let boundary = if rule == FaceVarying::None { Boundary::EdgeOnly } else { Boundary::EdgeAndCorner };
        let opts = Options { scheme: Scheme::CatmullClark, level: self.level, boundary, creases, corners, face_varying: rule, smooth_triangles: self.opts.smooth_triangles };
        let mut t = Topo::from_cage(n, ranges, fv, &opts, &mut Problems::new(""));
        // values per point (junctions: 3 or more), and the points on the mesh's own boundary
        let mut per_point: HashMap<i32, u32> = HashMap::new();
        for &v in owner {
            *per_point.entry(v).or_default() += 1;
        }
        let mut edge_uses: HashMap<(i32, i32), u32> = HashMap::new();
        for (k, next) in face_edges() {
            let (a, b) = (self.cage_indices[k], self.cage_indices[next]);
            *edge_uses.entry((a.min(b), a.max(b))).or_default() += 1;
        }
        let on_mesh_boundary: std::collections::HashSet<i32> = edge_uses.iter().filter(|e| *e.1 == 1).flat_map(|((a, b), _)| [*a, *b]).collect();
        for i in 0..n {
            let on_seam = t.vert_edges.get(i).iter().any(|&e| t.edge_faces.get(e as usize).len() == 1);
            let regions = per_point[&owner[i]];
            let dart = regions == 1 && !on_mesh_boundary.contains(&owner[i]);
            let pin = on_seam
                && match rule {
                    FaceVarying::CornersPlus1 => regions >= 3,
                    FaceVarying::CornersPlus2 => regions >= 3 || dart,
                    FaceVarying::Boundaries => true,
                    _ => false,
                };
            if pin {
                t.vert_sharp[i] = INFINITELY_SHARP;
            }
        }
        t
    }

    /// Smooth shading normals of the refined points (unit length, or zero where the surface
    /// around a point has no area): the area-weighted normals of the refined quads, skipping
    /// the children of faces flagged in `skip` (holes). They face the side the control faces'
    /// winding makes right-handed.
    pub fn smooth_normals(&self, skip: &[bool]) -> Vec<Vec3> {
        let mut n = vec![Vec3::ZERO; self.points.len()];
        for f in 0..self.cage_faces.len() {
            if skip.get(f).copied().unwrap_or(false) {
                continue;
            }
            for g in self.child_faces(f) {
                let q = &self.face_vertex_indices[4 * g..4 * g + 4];
                let [a, b, c, d] = [0, 1, 2, 3].map(|k| self.points[q[k] as usize]);
                let area = 0.5 * (c - a).cross(d - b);
                for &i in q {
                    n[i as usize] += area;
                }
            }
        }
        n.iter().map(|v| v.normalize_or_zero()).collect()
    }
}

#[cfg(test)]
mod tests;
