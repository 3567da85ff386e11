//! UsdGeomMesh → [`MeshDesc`]: validation of the topology (bad faces are dropped with a
//! problem), polygon triangulation by ear clipping on each polygon's best-fit plane, holes,
//! `orientation`, and primvar expansion (every interpolation, indexed or not) to per-vertex
//! arrays of the triangulated mesh, unwelding vertices where uniform/faceVarying data needs it.
//!
//! Subdivision surfaces (`catmullClark`, `loop`, `bilinear`) are rendered as their control
//! cage, flat, unless `tide:subdivision:level` asks for refinement: then [`crate::subdiv`]
//! refines the polygons (Catmull-Clark to the limit surface, or bilinear splitting) before the
//! triangulation and primvar expansion here, and its stencil carries every time sample of
//! `points` and the velocities. Each triangle keeps its control face (for uniform primvars and
//! GeomSubsets). A refined Catmull-Clark mesh gets smooth normals from its limit surface and
//! its authored normals are ignored, as USD says they are for subdivision surfaces; a refined
//! bilinear mesh keeps its authored normals, interpolated like any primvar.
//!
//! Authored normals are taken as USD states them: they point to the front side of the surface.
//! `leftHanded` reverses the triangle winding so the core's right-handed geometric normal
//! agrees with USD's front side; the authored normals already describe that side and are
//! therefore kept as they are (they are the "flipped" normals of a left-handed mesh).

use crate::subdiv::{self, Refinement, Scheme, Stencil};
use crate::value::{AttrStore, Interpolation, Primvar, Problems};
use glam::{Quat, Vec2, Vec3};
use std::sync::Arc;
use tide_core::scene::{MeshDesc, MeshMotion, PrimvarData};

/// Triangulates one simple polygon (possibly concave) given its corner positions. Returns
/// corner triples (indices into `poly`) in the polygon's own winding. Ear clipping is done in
/// the polygon's best-fit plane (Newell normal); a degenerate polygon (no area) is fanned.
pub fn triangulate_polygon(poly: &[Vec3], out: &mut Vec<[u32; 3]>) {
    let n = poly.len();
    if n < 3 {
        return;
    }
    if n == 3 {
        out.push([0, 1, 2]);
        return;
    }
    // Newell's normal: robust best-fit plane normal, oriented by the winding.
    let mut normal = Vec3::ZERO;
    for i in 0..n {
        let a = poly[i];
        let b = poly[(i + 1) % n];
        normal += Vec3::new((a.y - b.y) * (a.z + b.z), (a.z - b.z) * (a.x + b.x), (a.x - b.x) * (a.y + b.y));
    }
    let len = normal.length();
    if len <= 0.0 || !len.is_finite() {
        fan(n, out);
        return;
    }
    let nz = normal / len;
    let (u, v) = nz.any_orthonormal_pair();
    // (u, v, nz) is right-handed, so the polygon is counter-clockwise in (u, v).
    let center = poly.iter().copied().sum::<Vec3>() / n as f32;
    let p2: Vec<Vec2> = poly.iter().map(|&p| Vec2::new((p - center).dot(u), (p - center).dot(v))).collect();
    let scale = p2.iter().fold(0.0f32, |m, p| m.max(p.abs().max_element())).max(f32::MIN_POSITIVE);
    // Relative tolerance on doubled triangle areas (f32 round-off of coordinates ~ 1e-7 · scale).
    let eps = 1e-6 * scale * scale;

    let cross = |a: Vec2, b: Vec2, c: Vec2| (b - a).perp_dot(c - a);
    // Only reflex (or flat) corners can lie inside an ear, and clipping ears never turns a
    // convex corner reflex, so the initial reflex set is a sufficient list of blockers.
    let blockers: Vec<usize> = (0..n).filter(|&i| cross(p2[(i + n - 1) % n], p2[i], p2[(i + 1) % n]) <= eps).collect();
    if blockers.is_empty() {
        fan(n, out); // convex
        return;
    }
    let mut alive = vec![true; n];
    let mut remaining: Vec<usize> = (0..n).collect();
    let mut k = 0usize;
    while remaining.len() > 3 {
        let m = remaining.len();
        let mut clipped = false;
        for step in 0..m {
            let kk = (k + step) % m;
            let ia = remaining[(kk + m - 1) % m];
            let ib = remaining[kk];
            let ic = remaining[(kk + 1) % m];
            let (a, b, c) = (p2[ia], p2[ib], p2[ic]);
            if cross(a, b, c) <= eps {
                continue; // reflex or degenerate corner
            }
            let blocked = blockers.iter().any(|&j| {
                if !alive[j] || j == ia || j == ib || j == ic {
                    return false;
                }
                let p = p2[j];
                if p == a || p == b || p == c {
                    return false;
                }
                cross(a, b, p) >= -eps && cross(b, c, p) >= -eps && cross(c, a, p) >= -eps
            });
            if blocked {
                continue;
            }
            out.push([ia as u32, ib as u32, ic as u32]);
            remaining.remove(kk);
            alive[ib] = false;
            k = if kk == 0 { 0 } else { kk - 1 };
            clipped = true;
            break;
        }
        if !clipped {
            // Self-intersecting or numerically degenerate remainder: cut off the flattest
            // corner (smallest |area|) as a sliver triangle so the loop always progresses.
            let area = |x: usize| cross(p2[remaining[(x + m - 1) % m]], p2[remaining[x]], p2[remaining[(x + 1) % m]]).abs();
            let kk = (0..m).min_by(|&x, &y| area(x).partial_cmp(&area(y)).unwrap_or(std::cmp::Ordering::Equal)).unwrap_or(0);
            out.push([remaining[(kk + m - 1) % m] as u32, remaining[kk] as u32, remaining[(kk + 1) % m] as u32]);
            alive[remaining[kk]] = false;
            remaining.remove(kk);
            k = kk.saturating_sub(1);
        }
    }
    out.push([remaining[0] as u32, remaining[1] as u32, remaining[2] as u32]);
}

fn fan(n: usize, out: &mut Vec<[u32; 3]>) {
    for i in 1..n - 1 {
        out.push([0, i as u32, i as u32 + 1]);
    }
}

/// A primvar resolved against the topology: flat per-element data and its interpolation.
struct Expanded {
    interp: Interpolation,
    tuple: usize,
    data: Vec<f32>,
}

impl Expanded {
    fn element(&self, face: usize, point: usize, corner: usize) -> &[f32] {
        let i = match self.interp {
            Interpolation::Constant => 0,
            Interpolation::Uniform => face,
            Interpolation::Varying | Interpolation::Vertex => point,
            Interpolation::FaceVarying => corner,
        };
        &self.data[i * self.tuple..i * self.tuple + self.tuple]
    }
}

fn resolve_primvar(
    pv: Primvar,
    name: &str,
    tuple: usize,
    n_faces: usize,
    n_points: usize,
    n_corners: usize,
    p: &mut Problems,
) -> Option<Expanded> {
    if pv.tuple as usize != tuple {
        p.add(name, format!("expected {} components per element, got {}; ignored", tuple, pv.tuple));
        return None;
    }
    let data = match pv.flatten() {
        Ok(d) => d,
        Err(e) => {
            p.add(name, format!("{}; ignored", e));
            return None;
        }
    };
    if data.iter().any(|x| !x.is_finite()) {
        p.add(name, "contains NaN or infinite values; ignored");
        return None;
    }
    let need = match pv.interpolation {
        Interpolation::Constant => 1,
        Interpolation::Uniform => n_faces,
        Interpolation::Varying | Interpolation::Vertex => n_points,
        Interpolation::FaceVarying => n_corners,
    };
    let have = data.len() / tuple;
    if have < need {
        p.add(name, format!("{:?} interpolation needs {} elements, got {}; ignored", pv.interpolation, need, have));
        return None;
    }
    Some(Expanded { interp: pv.interpolation, tuple, data })
}

/// A resolved primvar carried onto a subdivided mesh's refined points / corners (uniform data
/// stays per control face: triangles keep their control face).
fn refine_primvar(e: Expanded, r: Option<&Refinement>) -> Expanded {
    let Some(r) = r else { return e };
    let data = match e.interp {
        Interpolation::Constant | Interpolation::Uniform => return e,
        Interpolation::Vertex => r.vertex(&e.data, e.tuple),
        Interpolation::Varying => r.varying(&e.data, e.tuple),
        Interpolation::FaceVarying => r.face_varying(&e.data, e.tuple),
    };
    Expanded { data, ..e }
}

/// The primvars a mesh takes its texture coordinates (`uvs`) from, the first found.
pub(crate) const UV_NAMES: [&str; 3] = tide_core::scene::UV_PRIMVAR_NAMES;

/// The primvars a material may read (every primvar of 1 to 4 components but the geometry's
/// own: `normals`, `widths`, the texture coordinates `uvs_from`, `tide:` and `skel:` ones),
/// sorted by name.
pub(crate) fn shading_primvar_names(store: &AttrStore, uvs_from: Option<&str>) -> Vec<String> {
    let mut names: Vec<String> = store
        .primvars
        .iter()
        .filter(|(n, pv)| {
            (1..=4).contains(&pv.tuple)
                && !["normals", "widths"].contains(&n.as_str())
                && Some(n.as_str()) != uvs_from
                && !n.starts_with("tide:")
                && !n.starts_with("skel:")
        })
        .map(|(n, _)| n.clone())
        .collect();
    names.sort();
    names
}

/// The constant primvars a material may read (what an implicit gprim carries).
pub(crate) fn constant_primvars(store: &AttrStore, p: &mut Problems) -> Vec<PrimvarData> {
    shading_primvar_names(store, None)
        .into_iter()
        .filter_map(|n| {
            let pv = store.primvar(&n, Interpolation::Constant)?;
            if pv.interpolation != Interpolation::Constant {
                return None;
            }
            let e = resolve_primvar(pv.clone(), &n, pv.tuple as usize, 1, 1, 1, p)?;
            Some(PrimvarData { data: e.element(0, 0, 0).to_vec(), name: n, tuple: e.tuple as u32, constant: true })
        })
        .collect()
}

/// The primvars a material may read of `n` points, of which `kept` are kept: per point
/// (vertex, varying or faceVarying) or constant (constant or uniform).
pub(crate) fn point_primvars(store: &AttrStore, n: usize, kept: &[usize], p: &mut Problems) -> Vec<PrimvarData> {
    shading_primvar_names(store, None)
        .into_iter()
        .filter_map(|name| {
            let pv = store.primvar(&name, Interpolation::Constant)?;
            let e = resolve_primvar(pv.clone(), &name, pv.tuple as usize, 1, n, n, p)?;
            let constant = matches!(e.interp, Interpolation::Constant | Interpolation::Uniform);
            let data = if constant { e.element(0, 0, 0).to_vec() } else { kept.iter().flat_map(|&i| e.element(0, i, i).to_vec()).collect() };
            Some(PrimvarData { name, tuple: e.tuple as u32, constant, data })
        })
        .collect()
}

/// Reads `points` (Floats 3) and reports non-finite ones; returns the points and a per-point
/// "bad" flag.
pub(crate) fn read_points(store: &AttrStore, p: &mut Problems) -> (Vec<Vec3>, Vec<bool>) {
    let Some(v) = store.get("points") else { return (Vec::new(), Vec::new()) };
    let Some(data) = v.to_f32s() else {
        p.add("points", format!("expected Floats with 3 components, got {}", v.kind()));
        return (Vec::new(), Vec::new());
    };
    if data.len() % 3 != 0 {
        p.add("points", format!("length {} is not a multiple of 3; the incomplete point is dropped", data.len()));
    }
    let pts: Vec<Vec3> = data.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect();
    let bad: Vec<bool> = pts.iter().map(|q| !q.is_finite()).collect();
    let n_bad = bad.iter().filter(|&&b| b).count();
    if n_bad > 0 {
        let first = bad.iter().position(|&b| b).unwrap_or(0);
        p.add("points", format!("{} point(s) are NaN or infinite (first: index {}); what uses them is dropped", n_bad, first));
    }
    (pts, bad)
}

/// Converts a mesh prim's attributes into a triangle mesh.
pub fn convert_mesh(name: &str, store: &AttrStore, p: &mut Problems) -> MeshDesc {
    convert_mesh_sources(name, store, p).0
}

/// How a mesh's points move, per output vertex of the converted mesh.
#[derive(Clone, Debug, PartialEq)]
pub enum Deformation {
    /// Time samples of `points`: (frame offset, positions), two or more, sorted by time.
    Samples(Vec<(f64, Vec<Vec3>)>),
    /// `velocities` and `accelerations`, units per second (and per second²), and the keys
    /// that follow a path the accelerations curve (`motion:nonlinearSampleCount`).
    Velocity { velocities: Vec<Vec3>, accelerations: Option<Vec<Vec3>>, nonlinear_samples: usize },
}

/// A `materialBind` GeomSubset's share of a mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct SubsetPart {
    /// The subset prim's path.
    pub path: String,
    /// Its bound material (after binding resolution), if any: else the mesh's.
    pub material: Option<String>,
    /// The triangles (indices of the mesh's triangles) of the subset's faces.
    pub triangles: Vec<u32>,
}

/// The part of `m` made of its triangles `triangles`: those triangles (each keeping its
/// authored face) over only the vertices they reference, renumbered in first-use order, with
/// every per-vertex array (normals, uvs, primvars, motion keys) cut to match. A subset's mesh
/// is this, so a mesh split among many materials holds each vertex about once, not once per
/// material.
pub fn sub_mesh(m: &MeshDesc, triangles: &[u32]) -> MeshDesc {
    let mut new_of = vec![u32::MAX; m.positions.len()];
    let mut old: Vec<u32> = Vec::new();
    let indices = triangles
        .iter()
        .flat_map(|&t| &m.indices[3 * t as usize..3 * t as usize + 3])
        .map(|&i| {
            let slot = &mut new_of[i as usize];
            if *slot == u32::MAX {
                *slot = old.len() as u32;
                old.push(i);
            }
            *slot
        })
        .collect();
    let pick = |v: &[Vec3]| old.iter().map(|&i| v[i as usize]).collect::<Vec<_>>();
    MeshDesc {
        name: m.name.clone(),
        positions: pick(&m.positions),
        indices,
        faces: triangles.iter().map(|&t| m.element_of(t)).collect(),
        normals: m.normals.as_deref().map(pick),
        uvs: m.uvs.as_ref().map(|uv| old.iter().map(|&i| uv[i as usize]).collect()),
        uv_name: m.uv_name.clone(),
        primvars: m
            .primvars
            .iter()
            .map(|pv| {
                if pv.constant {
                    return pv.clone();
                }
                let t = pv.tuple as usize;
                let data = old.iter().flat_map(|&i| pv.data[i as usize * t..(i as usize + 1) * t].iter().copied()).collect();
                PrimvarData { data, ..pv.clone() }
            })
            .collect(),
        double_sided: m.double_sided,
        motion: m.motion.as_ref().map(|mo| MeshMotion {
            times: mo.times.clone(),
            positions: mo.positions.iter().map(|k| pick(k)).collect(),
            normals: mo.normals.as_ref().map(|n| n.iter().map(|k| pick(k)).collect()),
        }),
        origin: m.origin,
    }
}

/// A mesh prim converted: the triangles at the current frame, how the points move, and the
/// triangles of each `materialBind` subset (`geomSubsets`); `rest` holds the triangles of
/// faces in no subset (none without subsets: the whole mesh is one part then).
#[derive(Clone, Debug, PartialEq)]
pub struct MeshGeom {
    /// Shared with the scenes assembled from it.
    pub mesh: Arc<MeshDesc>,
    pub deformation: Option<Deformation>,
    pub subsets: Vec<SubsetPart>,
    pub rest: Vec<u32>,
    /// The core meshes last made, and the shutter they were made for.
    made: crate::memo::Memo<Option<[u64; 3]>, Vec<CorePart>>,
}

/// A shutter as the assembly places a deforming mesh over it: open and close in frames, and
/// frames per second.
pub type Shutter = (f64, f64, f64);

/// One core mesh of a [`MeshGeom`]: its triangles of one material, and the subset (index
/// into `subsets`) they belong to (None: the faces in no subset, or the whole mesh).
pub type CorePart = (Arc<MeshDesc>, Option<usize>);

impl MeshGeom {
    pub fn new(mesh: MeshDesc, deformation: Option<Deformation>, subsets: Vec<SubsetPart>, rest: Vec<u32>) -> MeshGeom {
        MeshGeom { mesh: Arc::new(mesh), deformation, subsets, rest, made: Default::default() }
    }

    /// The core meshes of the geometry, with motion keys over `shutter` when it deforms
    /// (None: static): the whole mesh, or one part per material when GeomSubsets bind
    /// materials (the faces in no subset first, then each subset's; empty ones are left out).
    /// Made once per shutter and shared after. Geometry authored far from its own origin is
    /// moved back about it ([`MeshDesc::recentre`]; the parts share one origin, so vertices
    /// they share stay equal): its instances are placed by [`MeshDesc::origin`].
    pub fn core_meshes(&self, shutter: Option<Shutter>) -> Vec<CorePart> {
        let shutter = shutter.filter(|_| self.deformation.is_some());
        let key = shutter.map(|(a, b, c)| [a.to_bits(), b.to_bits(), c.to_bits()]);
        self.made.get_or_make(key, || {
            let whole = match (shutter, &self.deformation) {
                (Some((open, close, tcps)), Some(d)) => {
                    let mut m = (*self.mesh).clone();
                    m.motion = motion_keys(&m, d, open, close, tcps);
                    m.recentre();
                    Arc::new(m)
                }
                _ => {
                    let shift = self.mesh.recentring();
                    if shift == Vec3::ZERO {
                        self.mesh.clone()
                    } else {
                        let mut m = (*self.mesh).clone();
                        m.shift_origin(shift);
                        Arc::new(m)
                    }
                }
            };
            if self.subsets.is_empty() {
                return vec![(whole, None)];
            }
            std::iter::once((&self.rest, None))
                .chain(self.subsets.iter().enumerate().map(|(k, s)| (&s.triangles, Some(k))))
                .filter(|(triangles, _)| !triangles.is_empty())
                .map(|(triangles, k)| (Arc::new(sub_mesh(&whole, triangles)), k))
                .collect()
        })
    }
}

/// Converts a mesh prim: its triangles, their motion ([`Deformation`]) and its GeomSubsets. `geomSubsets`
/// (Paths) names the subsets; each subset S has `S.indices` (face indices) and `S.material`
/// (Path). Face indices out of range are a problem naming the subset and `indices`, and are
/// ignored; a face named by an earlier subset stays there (also a problem).
pub fn convert_usd_mesh(name: &str, store: &AttrStore, p: &mut Problems) -> MeshGeom {
    let (mesh, src, stencil) = convert_mesh_sources(name, store, p);
    let deformation = deformation(&mesh, &src, stencil.as_ref(), store, p);
    let n_faces = store.get("faceVertexCounts").and_then(|v| v.to_ints()).map_or(0, |c| c.len());
    let subset_paths = store.get("geomSubsets").and_then(|v| v.to_strings()).unwrap_or_default();
    // the subset (index into `subsets`) of each face
    let mut owner: Vec<Option<u32>> = vec![None; n_faces];
    let mut subsets = Vec::new();
    for path in subset_paths {
        let k = subsets.len() as u32;
        let indices = store.get(&format!("{path}.indices")).and_then(|v| v.to_ints()).unwrap_or_default();
        let (mut bad, mut taken) = (Vec::new(), 0usize);
        for i in indices {
            match owner.get_mut(i as usize).filter(|_| i >= 0) {
                None => bad.push(i),
                Some(Some(o)) if *o != k => taken += 1,
                Some(o) => *o = Some(k),
            }
        }
        if !bad.is_empty() {
            p.list.push(tide_core::Problem {
                item: path.clone(),
                attribute: "indices".into(),
                message: format!("{} face index(es) out of range (0..{}; first: {}); ignored", bad.len(), n_faces, bad[0]),
            });
        }
        if taken > 0 {
            p.list.push(tide_core::Problem {
                item: path.clone(),
                attribute: "indices".into(),
                message: format!("{taken} face(s) already belong to an earlier materialBind subset; they keep its material"),
            });
        }
        let material = store.get(&format!("{path}.material")).and_then(|v| v.as_str()).filter(|m| !m.is_empty()).map(String::from);
        subsets.push(SubsetPart { path, material, triangles: Vec::new() });
    }
    let mut rest = Vec::new();
    if !subsets.is_empty() {
        for t in 0..(mesh.indices.len() / 3) as u32 {
            match owner.get(mesh.element_of(t) as usize).copied().flatten() {
                Some(k) => subsets[k as usize].triangles.push(t),
                None => rest.push(t),
            }
        }
    }
    MeshGeom::new(mesh, deformation, subsets, rest)
}

/// How the points of a converted mesh move: time samples of `points` (all with the same
/// point count), else `velocities` (and `accelerations`). A sample with another point count
/// or non-finite points, or velocities of another count, is a problem and the mesh is static.
/// A subdivided mesh's `stencil` refines each sample (and the velocities) first.
fn deformation(mesh: &MeshDesc, src: &[u32], stencil: Option<&Stencil>, store: &AttrStore, p: &mut Problems) -> Option<Deformation> {
    if mesh.indices.is_empty() {
        return None;
    }
    let n_points = store.get("points").and_then(|v| v.to_f32s()).map_or(0, |d| d.len() / 3);
    let expand = |d: &[f32]| -> Vec<Vec3> {
        let refined = stencil.map(|s| s.apply(d, 3));
        let d = refined.as_deref().unwrap_or(d);
        src.iter().map(|&i| Vec3::new(d[3 * i as usize], d[3 * i as usize + 1], d[3 * i as usize + 2])).collect()
    };
    point_motion(store, n_points, mesh.positions.len(), "the mesh", expand, expand, p)
}

/// How converted point-based geometry moves: time samples of `points` (two or more, each with
/// the prim's `n_points` finite points), each turned into the converted vertices' positions by
/// `key`; else `velocities` and `accelerations` (one finite vector per point) carried onto the
/// `n_vertices` vertices by `carry`. A sample or vector array that does not fit is a problem
/// (`what` names the prim's kind in it) and the geometry is static.
pub(crate) fn point_motion(store: &AttrStore, n_points: usize, n_vertices: usize, what: &str, key: impl Fn(&[f32]) -> Vec<Vec3>, carry: impl Fn(&[f32]) -> Vec<Vec3>, p: &mut Problems) -> Option<Deformation> {
    let samples = store.attr("points").map_or(&[][..], |a| &a.samples[..]);
    if samples.len() >= 2 {
        let mut keys = Vec::with_capacity(samples.len());
        for (t, v) in samples {
            let d = v.to_f32s().unwrap_or_default();
            if d.len() != 3 * n_points {
                p.add("points", format!("the time sample at frame offset {} has {} points, {} {}; the topology must not change, so {} renders static at frame 0", t, d.len() / 3, what, n_points, what));
                return None;
            }
            if d.iter().any(|x| !x.is_finite()) {
                p.add("points", format!("the time sample at frame offset {} has NaN or infinite points; {} renders static at frame 0", t, what));
                return None;
            }
            keys.push((*t, key(&d)));
        }
        if keys.windows(2).any(|w| w[0].1 != w[1].1) {
            return Some(Deformation::Samples(keys));
        }
        return None;
    }
    let per_point = |attr: &str, p: &mut Problems| -> Option<Vec<Vec3>> {
        let v = store.get(attr)?;
        match v.to_f32s() {
            Some(d) if d.len() == 3 * n_points && d.iter().all(|x| x.is_finite()) => Some(carry(&d)),
            _ => {
                p.add(attr, format!("expected {} finite vectors, one per point; ignored", n_points));
                None
            }
        }
    };
    let velocities = per_point("velocities", p);
    let accelerations = per_point("accelerations", p);
    let moving = |v: &Option<Vec<Vec3>>| v.as_ref().is_some_and(|v| v.iter().any(|x| *x != Vec3::ZERO));
    if !moving(&velocities) && !moving(&accelerations) {
        return None;
    }
    let velocities = velocities.unwrap_or_else(|| vec![Vec3::ZERO; n_vertices]);
    let nonlinear_samples = nonlinear_sample_count(store, p);
    Some(Deformation::Velocity { velocities, accelerations, nonlinear_samples })
}

/// Most keys a curved motion gets.
const MAX_NONLINEAR_SAMPLES: i64 = 64;

/// UsdGeomMotionAPI's `motion:nonlinearSampleCount` (inherited; the reader sends it where a
/// prim has accelerations): 3 unless given, at least 2 (fewer named, 3 used) and at most 64
/// (more named and cut).
pub(crate) fn nonlinear_sample_count(store: &AttrStore, p: &mut Problems) -> usize {
    const NAME: &str = "motion:nonlinearSampleCount";
    let n = store.get(NAME).and_then(|v| v.to_ints()).and_then(|v| v.first().copied()).map_or(NONLINEAR_SAMPLES as i64, i64::from);
    if n < 2 {
        p.add(NAME, format!("{n} is fewer than 2 samples; using {NONLINEAR_SAMPLES}"));
        NONLINEAR_SAMPLES
    } else if n > MAX_NONLINEAR_SAMPLES {
        p.add(NAME, format!("{n} samples are more than Tide keys a motion with; using {MAX_NONLINEAR_SAMPLES}"));
        MAX_NONLINEAR_SAMPLES as usize
    } else {
        n as usize
    }
}

/// Area-weighted vertex normals of a triangle mesh at given positions.
fn vertex_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in indices.chunks_exact(3) {
        let [a, b, c] = [t[0], t[1], t[2]].map(|i| positions[i as usize]);
        let f = (b - a).cross(c - a);
        for &i in t {
            n[i as usize] += f;
        }
    }
    n
}

/// Keys of a motion with accelerations over the shutter (UsdGeomMotionAPI's default
/// `motion:nonlinearSampleCount`).
const NONLINEAR_SAMPLES: usize = 3;

/// The deformation keys over the shutter [open, close] (frame offsets; seconds =
/// frames / `tcps`): the samples inside the shutter plus one on either side, or for
/// velocities the positions at open and close (p + v·t + a·t²/2), and with accelerations
/// `nonlinear_samples` keys evenly over the shutter along each point's parabola. Authored
/// normals turn with the surface: each key's normal is the authored one rotated by the
/// shortest arc from the vertex's geometric normal at the current frame to its geometric
/// normal at the key (exact for rigid motion).
pub fn motion_keys(mesh: &MeshDesc, d: &Deformation, open: f64, close: f64, tcps: f64) -> Option<MeshMotion> {
    let (times, positions): (Vec<f32>, Vec<Vec<Vec3>>) = match d {
        Deformation::Samples(samples) => {
            let lo = samples.iter().rposition(|s| s.0 <= open).unwrap_or(0);
            let hi = samples.iter().position(|s| s.0 >= close).unwrap_or(samples.len() - 1);
            let kept = &samples[lo..=hi.max(lo)];
            if kept.len() < 2 {
                return None;
            }
            kept.iter().map(|s| ((s.0 / tcps) as f32, s.1.clone())).unzip()
        }
        Deformation::Velocity { velocities, accelerations, nonlinear_samples } => {
            let key = |t: f32| -> Vec<Vec3> {
                (0..mesh.positions.len())
                    .map(|i| mesh.positions[i] + velocities[i] * t + accelerations.as_ref().map_or(Vec3::ZERO, |a| a[i] * (0.5 * t * t)))
                    .collect()
            };
            let (t0, t1) = ((open / tcps) as f32, (close / tcps) as f32);
            // accelerations curve the path: motion:nonlinearSampleCount keys (USD's default 3
            // puts the middle one where a symmetric shutter's turning point lies)
            let n = if accelerations.is_some() && t1 > t0 { (*nonlinear_samples).max(2) } else { 2 };
            let times: Vec<f32> = (0..n).map(|k| t0 + (t1 - t0) * k as f32 / (n - 1) as f32).collect();
            let keys = times.iter().map(|&t| key(t)).collect();
            (times, keys)
        }
    };
    if !(times.windows(2).all(|w| w[0] < w[1])) {
        return None;
    }
    let normals = mesh.normals.as_ref().map(|authored| {
        let g0 = vertex_normals(&mesh.positions, &mesh.indices);
        positions
            .iter()
            .map(|key| {
                let gk = vertex_normals(key, &mesh.indices);
                authored
                    .iter()
                    .zip(g0.iter().zip(&gk))
                    .map(|(n, (a, b))| match (a.try_normalize(), b.try_normalize()) {
                        (Some(a), Some(b)) => Quat::from_rotation_arc(a, b) * *n,
                        _ => *n,
                    })
                    .collect()
            })
            .collect()
    });
    Some(MeshMotion { times, positions, normals })
}

/// [`convert_mesh`], plus the source point of each output vertex (a refined point when
/// subdivided) and the subdivision stencil, if any. The mesh's `faces` name each triangle's
/// (control) face.
fn convert_mesh_sources(name: &str, store: &AttrStore, p: &mut Problems) -> (MeshDesc, Vec<u32>, Option<Stencil>) {
    let (points, bad_point) = read_points(store, p);
    let ints = |attr: &str, p: &mut Problems| -> Vec<i32> {
        match store.get(attr) {
            None => Vec::new(),
            Some(v) => v.to_ints().unwrap_or_else(|| {
                p.add(attr, format!("expected Ints, got {}", v.kind()));
                Vec::new()
            }),
        }
    };
    let counts = ints("faceVertexCounts", p);
    let fv = ints("faceVertexIndices", p);
    let holes = ints("holeIndices", p);
    let left = store.token_or("orientation", &["rightHanded", "leftHanded"], "rightHanded", p) == "leftHanded";
    let scheme = store.token_or("subdivisionScheme", &["none", "catmullClark", "loop", "bilinear"], "catmullClark", p);
    let double_sided = store.bool_or("doubleSided", false, p);

    let n_faces = counts.len();
    let n_points = points.len();
    let n_corners = fv.len();
    let mut is_hole = vec![false; n_faces];
    for &h in &holes {
        if h >= 0 && (h as usize) < n_faces {
            is_hole[h as usize] = true;
        } else {
            p.add("holeIndices", format!("hole face index {} is out of range (0..{}); ignored", h, n_faces));
        }
    }
    let options = subdiv::read_options(store, scheme, &counts, n_points, p);
    if options.as_ref().is_some_and(|o| o.boundary == subdiv::Boundary::None) {
        for (f, b) in subdiv::boundary_faces(&counts, &fv, n_points).into_iter().enumerate() {
            is_hole[f] |= b;
        }
    }
    let refined = options.map(|o| subdiv::refine(&counts, &fv, &points, &o, p));

    // Triangles as (face, corner a, corner b, corner c), corners indexing faceVertexIndices.
    let mut tris: Vec<(u32, [u32; 3])> = Vec::new();
    let mut local = Vec::new();
    let mut poly = Vec::new();
    let (mut n_small, mut n_bad_index, mut first_bad_index) = (0usize, 0usize, None);
    let mut offset = 0usize;
    for (f, &c) in counts.iter().enumerate() {
        if c < 0 || offset + c as usize > n_corners {
            p.add(
                "faceVertexCounts",
                format!("counts need more than the {} faceVertexIndices given (from face {}); the remaining faces are dropped", n_corners, f),
            );
            break;
        }
        let c = c as usize;
        let corners = offset..offset + c;
        offset += c;
        if c < 3 {
            n_small += 1;
            continue;
        }
        if is_hole[f] {
            continue;
        }
        if let Some(&bad) = fv[corners.clone()].iter().find(|&&i| i < 0 || i as usize >= n_points) {
            n_bad_index += 1;
            first_bad_index.get_or_insert((f, bad));
            continue;
        }
        if fv[corners.clone()].iter().any(|&i| bad_point[i as usize]) {
            continue;
        }
        // the face, or when subdivided its refined quads (corners of the refined indices)
        let (pfv, ppts, first, pieces, size) = match &refined {
            None => (&fv[..], &points[..], corners.start, 1, c),
            Some(r) => {
                let g = r.child_faces(f);
                (&r.face_vertex_indices[..], &r.points[..], 4 * g.start, g.len(), 4)
            }
        };
        for start in (0..pieces).map(|k| first + k * size) {
            poly.clear();
            poly.extend(pfv[start..start + size].iter().map(|&i| ppts[i as usize]));
            local.clear();
            triangulate_polygon(&poly, &mut local);
            for t in &local {
                let [a, b, cc] = t.map(|k| (start + k as usize) as u32);
                tris.push((f as u32, if left { [a, cc, b] } else { [a, b, cc] }));
            }
        }
    }
    if n_small > 0 {
        p.add("faceVertexCounts", format!("{} face(s) have fewer than 3 vertices; dropped", n_small));
    }
    if let Some((f, i)) = first_bad_index {
        p.add(
            "faceVertexIndices",
            format!("{} face(s) use point indices out of range (first: face {} index {}, {} points); dropped", n_bad_index, f, i, n_points),
        );
    }
    if offset < n_corners && !counts.is_empty() {
        p.add("faceVertexIndices", format!("{} indices beyond the faces' counts; ignored", n_corners - offset));
    }

    let normals = match &refined {
        // the limit surface's normals (authored normals do not apply to a subdivision surface)
        Some(r) if r.scheme == Scheme::CatmullClark => {
            let data = r.smooth_normals(&is_hole).iter().flat_map(|&n| (if left { -n } else { n }).to_array()).collect();
            Some(Expanded { interp: Interpolation::Vertex, tuple: 3, data })
        }
        _ => store
            .primvar("normals", Interpolation::Vertex)
            .and_then(|pv| resolve_primvar(pv, "normals", 3, n_faces, n_points, n_corners, p))
            .map(|e| refine_primvar(e, refined.as_ref())),
    };
    let st_name = UV_NAMES.into_iter().find(|n| store.primvars.contains_key(*n) || store.has(n));
    let st = st_name.and_then(|n| {
        store
            .primvar(n, Interpolation::FaceVarying)
            .and_then(|pv| resolve_primvar(pv, n, 2, n_faces, n_points, n_corners, p))
            .map(|e| refine_primvar(e, refined.as_ref()))
    });
    let extra: Vec<(String, Expanded)> = shading_primvar_names(store, st_name)
        .into_iter()
        .filter_map(|n| {
            let pv = store.primvar(&n, Interpolation::Constant)?;
            let e = resolve_primvar(pv.clone(), &n, pv.tuple as usize, n_faces, n_points, n_corners, p)?;
            Some((n, refine_primvar(e, refined.as_ref())))
        })
        .collect();
    // from here on a subdivided mesh is its refined points and quads
    let (points, fv, stencil) = match refined {
        Some(r) => (r.points, r.face_vertex_indices, Some(r.stencil)),
        None => (points, fv, None),
    };
    let (n_points, n_corners) = (points.len(), fv.len());

    let unweld = [&normals, &st]
        .into_iter()
        .flatten()
        .chain(extra.iter().map(|(_, e)| e))
        .any(|e| matches!(e.interp, Interpolation::Uniform | Interpolation::FaceVarying));
    let mut primvars: Vec<PrimvarData> = extra
        .iter()
        .map(|(n, e)| {
            let constant = e.interp == Interpolation::Constant;
            let data = if constant { e.element(0, 0, 0).to_vec() } else { Vec::new() };
            PrimvarData { name: n.clone(), tuple: e.tuple as u32, constant, data }
        })
        .collect();

    // Output vertex per key: the point (welded) or the face corner (unwelded).
    let key_count = if unweld { n_corners } else { n_points };
    let mut remap = vec![u32::MAX; key_count];
    let mut positions = Vec::new();
    let mut sources = Vec::new();
    let mut out_n: Vec<Vec3> = Vec::new();
    let mut out_uv: Vec<Vec2> = Vec::new();
    let mut indices = Vec::with_capacity(tris.len() * 3);
    for &(f, t) in &tris {
        for corner in t {
            let corner = corner as usize;
            let point = fv[corner] as usize;
            let key = if unweld { corner } else { point };
            if remap[key] == u32::MAX {
                remap[key] = positions.len() as u32;
                positions.push(points[point]);
                sources.push(point as u32);
                if let Some(e) = &normals {
                    let s = e.element(f as usize, point, corner);
                    out_n.push(Vec3::new(s[0], s[1], s[2]).normalize_or_zero());
                }
                if let Some(e) = &st {
                    let s = e.element(f as usize, point, corner);
                    out_uv.push(Vec2::new(s[0], s[1]));
                }
                for (pv, (_, e)) in primvars.iter_mut().zip(&extra) {
                    if !pv.constant {
                        pv.data.extend_from_slice(e.element(f as usize, point, corner));
                    }
                }
            }
            indices.push(remap[key]);
        }
    }
    // each triangle's authored face (none kept where every face is a triangle and none is
    // dropped: each triangle is then its face)
    let identity = tris.iter().enumerate().all(|(t, &(f, _))| f as usize == t);
    let faces = if identity { Vec::new() } else { tris.iter().map(|t| t.0).collect() };
    let mesh = MeshDesc {
        name: name.to_string(),
        positions,
        indices,
        faces,
        normals: normals.map(|_| out_n),
        uv_name: st.as_ref().and(st_name).map(String::from),
        uvs: st.map(|_| out_uv),
        double_sided,
        motion: None,
        primvars,
        origin: Default::default(),
    };
    (mesh, sources, stencil)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::value::{Attr, Value};

    /// Velocities alone move a mesh along straight lines (two keys); accelerations curve the
    /// path, so it is keyed at three times (USD's default nonlinear sample count), each key
    /// on the parabola p + v t + a t²/2: a symmetric shutter with no velocity turns back at
    /// the middle instead of standing still; an authored motion:nonlinearSampleCount keys it
    /// that many times.
    #[test]
    fn a_nonlinear_sample_count_below_2_or_past_64_is_named() {
        let count = |n: Option<i64>| {
            let mut store = AttrStore::default();
            if let Some(n) = n {
                store.attrs.insert("motion:nonlinearSampleCount".into(), Attr { value: Some(Value::Int(n)), samples: vec![] });
            }
            let mut p = Problems::new("/m");
            (nonlinear_sample_count(&store, &mut p), p.list.len())
        };
        assert_eq!(count(None), (3, 0));
        assert_eq!(count(Some(7)), (7, 0));
        assert_eq!(count(Some(1)), (3, 1));
        assert_eq!(count(Some(1000)), (64, 1));
    }

    #[test]
    fn accelerations_key_the_curved_path() {
        let mesh = MeshDesc { positions: vec![Vec3::ZERO, Vec3::X, Vec3::Y], indices: vec![0, 1, 2], ..Default::default() };
        let still = vec![Vec3::ZERO; 3];
        let a = vec![Vec3::new(9216.0, 0.0, 0.0); 3];
        let d = Deformation::Velocity { velocities: still.clone(), accelerations: Some(a.clone()), nonlinear_samples: 3 };
        let m = motion_keys(&mesh, &d, -0.5, 0.5, 24.0).unwrap();
        assert_eq!(m.times, vec![-0.5 / 24.0, 0.0, 0.5 / 24.0]);
        // x = ½ · 9216 · (1/48)² = 2 at the shutter's ends, 0 in the middle
        let xs: Vec<f32> = m.positions.iter().map(|k| k[0].x).collect();
        assert!((xs[0] - 2.0).abs() < 1e-4 && xs[1].abs() < 1e-6 && (xs[2] - 2.0).abs() < 1e-4, "{xs:?}");
        let lin = Deformation::Velocity { velocities: vec![Vec3::X; 3], accelerations: None, nonlinear_samples: 3 };
        assert_eq!(motion_keys(&mesh, &lin, -0.5, 0.5, 24.0).unwrap().times.len(), 2);
        // motion:nonlinearSampleCount 5: five keys along the parabola
        let five = Deformation::Velocity { velocities: still.clone(), accelerations: Some(a), nonlinear_samples: 5 };
        let m = motion_keys(&mesh, &five, -0.5, 0.5, 24.0).unwrap();
        let want = [-2.0f32, -1.0, 0.0, 1.0, 2.0].map(|k| k * 0.25 / 24.0);
        assert!(m.times.iter().zip(&want).all(|(t, w)| (t - w).abs() < 1e-9), "{:?}", m.times);
        let xs: Vec<f32> = m.positions.iter().map(|k| k[0].x).collect();
        assert!(xs.iter().zip([2.0, 0.5, 0.0, 0.5, 2.0]).all(|(x, w)| (x - w).abs() < 1e-5), "{xs:?}");
    }

    fn store(points: &[f32], counts: &[i32], idx: &[i32]) -> AttrStore {
        let mut s = AttrStore::default();
        let mut put = |n: &str, v: Value| {
            s.attrs.insert(n.to_string(), Attr { value: Some(v), samples: vec![] });
        };
        put("points", Value::Floats { data: points.to_vec(), tuple: 3 });
        put("faceVertexCounts", Value::Ints(counts.to_vec()));
        put("faceVertexIndices", Value::Ints(idx.to_vec()));
        s
    }

    #[test]
    fn core_meshes_are_made_once_per_shutter_and_shared() {
        // two quads: face 1 in a subset; the points move by a velocity
        let mut st = store(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0., 2., 0., 0., 2., 1., 0.], &[4, 4], &[0, 1, 2, 3, 1, 4, 5, 2]);
        st.attrs.insert("velocities".into(), Attr { value: Some(Value::Floats { data: [1.0f32, 0.0, 0.0].repeat(6), tuple: 3 }), samples: vec![] });
        st.attrs.insert("geomSubsets".into(), Attr { value: Some(Value::Paths(vec!["/M/s".into()])), samples: vec![] });
        st.attrs.insert("/M/s.indices".into(), Attr { value: Some(Value::Ints(vec![1])), samples: vec![] });
        let mut p = Problems::new("/M");
        let g = convert_usd_mesh("/M", &st, &mut p);
        assert!(p.list.is_empty(), "{:?}", p.list);
        let ptrs = |parts: &[CorePart]| parts.iter().map(|(m, k)| (Arc::as_ptr(m), *k)).collect::<Vec<_>>();
        let a = g.core_meshes(Some((0.0, 1.0, 25.0)));
        // the faces in no subset, then the subset's
        assert_eq!(a.iter().map(|(m, k)| (m.indices.len(), *k)).collect::<Vec<_>>(), [(6, None), (6, Some(0))]);
        assert!(a.iter().all(|(m, _)| m.motion.is_some()));
        // the same shutter again: the same meshes, not copies
        assert_eq!(ptrs(&g.core_meshes(Some((0.0, 1.0, 25.0)))), ptrs(&a));
        // another shutter makes other keys; no shutter gives static parts
        let b = g.core_meshes(Some((0.0, 2.0, 25.0)));
        assert!(b.iter().zip(&a).all(|((x, _), (y, _))| !Arc::ptr_eq(x, y) && x.motion != y.motion));
        let s = g.core_meshes(None);
        assert!(s.iter().all(|(m, _)| m.motion.is_none()));
        assert_eq!(ptrs(&g.core_meshes(None)), ptrs(&s));
        // a clone of the geometry starts without them, and is still equal
        let c = g.clone();
        assert_eq!(c, g);
        assert_ne!(ptrs(&c.core_meshes(None)), ptrs(&s));
        // without subsets, a static mesh is the geometry's own
        let plain = convert_usd_mesh("/P", &store(&[0., 0., 0., 1., 0., 0., 1., 1., 0.], &[3], &[0, 1, 2]), &mut p);
        assert!(Arc::ptr_eq(&plain.core_meshes(Some((0.0, 1.0, 25.0)))[0].0, &plain.mesh));
    }

    #[test]
    fn a_subset_mesh_keeps_only_its_vertices_with_their_data() {
        // a strip of four triangles over six vertices, with every per-vertex array
        let positions: Vec<Vec3> = (0..6).map(|i| Vec3::new(i as f32, (i % 2) as f32, 0.0)).collect();
        let m = MeshDesc {
            name: "/Strip".into(),
            positions: positions.clone(),
            indices: vec![0, 1, 2, 2, 1, 3, 2, 3, 4, 4, 3, 5],
            faces: vec![0, 0, 1, 1],
            normals: Some(positions.iter().map(|p| Vec3::new(0.0, 0.0, 1.0 + p.x)).collect()),
            uvs: Some(positions.iter().map(|p| Vec2::new(p.x, p.y)).collect()),
            uv_name: Some("st".into()),
            primvars: vec![
                PrimvarData { name: "rgb".into(), tuple: 3, constant: false, data: (0..18).map(|k| k as f32).collect() },
                PrimvarData { name: "k".into(), tuple: 1, constant: true, data: vec![7.0] },
            ],
            double_sided: true,
            motion: Some(MeshMotion {
                times: vec![0.0, 1.0],
                positions: vec![positions.clone(), positions.iter().map(|p| *p + Vec3::Z).collect()],
                normals: None,
            }),
            origin: Default::default(),
        };
        // the last two triangles: vertices 2, 3, 4, 5 in first-use order
        let s = sub_mesh(&m, &[2, 3]);
        assert_eq!(s.indices, vec![0, 1, 2, 2, 1, 3]);
        assert_eq!(s.faces, vec![1, 1], "each triangle keeps its authored face");
        assert_eq!(s.positions, m.positions[2..].to_vec());
        assert_eq!(s.normals.as_deref(), Some(&m.normals.as_ref().unwrap()[2..]));
        assert_eq!(s.uvs.as_deref(), Some(&m.uvs.as_ref().unwrap()[2..]));
        assert_eq!(s.primvars[0].data, (6..18).map(|k| k as f32).collect::<Vec<_>>());
        assert_eq!(s.primvars[1], m.primvars[1]);
        let mo = s.motion.as_ref().unwrap();
        assert_eq!((mo.times.clone(), mo.positions[1].clone()), (vec![0.0, 1.0], m.motion.as_ref().unwrap().positions[1][2..].to_vec()));
        assert!(s.double_sided && s.name == m.name);
        // every triangle is where it was
        for t in 0..2 {
            for k in 0..3 {
                assert_eq!(s.positions[s.indices[3 * t + k] as usize], m.positions[m.indices[6 + 3 * t + k] as usize]);
            }
        }
        // first use decides the order: triangle 3, (4, 3, 5), listed first comes first
        let s = sub_mesh(&m, &[3, 0]);
        assert_eq!(s.positions, [4, 3, 5, 0, 1, 2].map(|i| m.positions[i]).to_vec());
        assert_eq!(s.faces, vec![1, 0]);
        let triangles = MeshDesc { faces: Vec::new(), ..m.clone() };
        assert_eq!(sub_mesh(&triangles, &[3, 0]).faces, vec![3, 0], "a mesh of triangles: each its own face");
    }

    fn tri_normal(m: &MeshDesc, t: usize) -> Vec3 {
        let [a, b, c] = [0, 1, 2].map(|k| m.positions[m.indices[3 * t + k] as usize]);
        (b - a).cross(c - a) * 0.5
    }

    const QUAD: [f32; 12] = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.];

    #[test]
    fn concave_ngon_ear_clipping_preserves_area_and_winding() {
        // An "L"-shaped hexagon tilted out of every coordinate plane: area 3 (unit squares).
        let l2 = [(0., 0.), (2., 0.), (2., 1.), (1., 1.), (1., 2.), (0., 2.)];
        let rot = glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, -0.7, 1.1);
        let poly: Vec<Vec3> = l2.iter().map(|&(x, y)| rot * Vec3::new(x, y, 0.0) + Vec3::new(5.0, -2.0, 1.0)).collect();
        let mut tris = Vec::new();
        triangulate_polygon(&poly, &mut tris);
        assert_eq!(tris.len(), 4);
        let expected_n = rot * Vec3::Z;
        let mut area = 0.0;
        for t in &tris {
            let [a, b, c] = t.map(|k| poly[k as usize]);
            let n = (b - a).cross(c - a) * 0.5;
            // Each triangle faces the polygon's side (no flipped or zero-area ears).
            assert!(n.dot(expected_n) > 1e-3, "{:?}", t);
            area += n.length();
        }
        // f32 coordinates of magnitude ~5: area error ~1e-6 relative; 1e-4 leaves margin.
        assert!((area - 3.0).abs() < 1e-4, "area {}", area);
        // The reflex corner (index 3) must not be the tip of an ear spanning outside.
        for t in &tris {
            let c = t.map(|k| l2[k as usize]);
            let centroid = ((c[0].0 + c[1].0 + c[2].0) / 3.0, (c[0].1 + c[1].1 + c[2].1) / 3.0);
            assert!(!(centroid.0 > 1.0 && centroid.1 > 1.0), "triangle outside the L: {:?}", t);
        }
    }

    #[test]
    fn assorted_polygons_triangulate_to_their_area() {
        // Shoelace area of each outline vs the sum of its triangles (all counter-clockwise).
        let star: Vec<(f32, f32)> = (0..10)
            .map(|i| {
                let a = std::f32::consts::TAU * i as f32 / 10.0;
                let r = if i % 2 == 0 { 1.0 } else { 0.4 };
                (r * a.cos(), r * a.sin())
            })
            .collect();
        let comb = vec![(0., 0.), (5., 0.), (5., 3.), (4., 3.), (4., 1.), (3., 1.), (3., 3.), (2., 3.), (2., 1.), (1., 1.), (1., 3.), (0., 3.)];
        let collinear = vec![(0., 0.), (1., 0.), (2., 0.), (2., 2.), (1., 1.), (0., 2.)];
        let big: Vec<(f32, f32)> = (0..2000)
            .map(|i| {
                let a = std::f32::consts::TAU * i as f32 / 2000.0;
                let r = if i % 2 == 0 { 1.0 } else { 0.9 };
                (r * a.cos(), r * a.sin())
            })
            .collect();
        for outline in [star, comb, collinear, big] {
            let n = outline.len();
            let shoelace: f32 = (0..n).map(|i| {
                let (a, b) = (outline[i], outline[(i + 1) % n]);
                0.5 * (a.0 * b.1 - b.0 * a.1)
            }).sum();
            let poly: Vec<Vec3> = outline.iter().map(|&(x, y)| Vec3::new(x, 0.0, -y)).collect();
            let mut tris = Vec::new();
            triangulate_polygon(&poly, &mut tris);
            assert_eq!(tris.len(), n - 2);
            let mut area = 0.0;
            for t in &tris {
                let [a, b, c] = t.map(|k| poly[k as usize]);
                let cr = (b - a).cross(c - a);
                // Polygon in the XZ plane wound counter-clockwise about +Y; flat triangles
                // (collinear corners) may have zero area but never negative.
                assert!(cr.y >= -1e-6, "{:?}", t);
                area += 0.5 * cr.y;
            }
            // f32 sums over up to 2000 triangles of unit-size coordinates: 1e-4 relative.
            assert!((area - shoelace).abs() < 1e-4 * shoelace.abs().max(1.0), "{} vs {}", area, shoelace);
        }
    }

    #[test]
    fn left_handed_quad_faces_minus_z() {
        let mut s = store(&QUAD, &[4], &[0, 1, 2, 3]);
        let m = convert_mesh("/q", &s, &mut Problems::new("/q"));
        assert!(tri_normal(&m, 0).z > 0.0 && tri_normal(&m, 1).z > 0.0);
        s.attrs.insert("orientation".into(), Attr { value: Some(Value::Token("leftHanded".into())), samples: vec![] });
        let m = convert_mesh("/q", &s, &mut Problems::new("/q"));
        assert_eq!(m.indices.len(), 6);
        assert!(tri_normal(&m, 0).z < 0.0 && tri_normal(&m, 1).z < 0.0);
    }

    #[test]
    fn holes_are_skipped() {
        let pts = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0., 2., 0., 0., 2., 1., 0.];
        let mut s = store(&pts, &[4, 4], &[0, 1, 2, 3, 1, 4, 5, 2]);
        s.attrs.insert("holeIndices".into(), Attr { value: Some(Value::Ints(vec![0])), samples: vec![] });
        let mut p = Problems::new("/m");
        let m = convert_mesh("/m", &s, &mut p);
        assert!(p.list.is_empty());
        assert_eq!(m.indices.len(), 6);
        assert!(m.indices.iter().all(|&i| m.positions[i as usize].x >= 1.0));
    }

    #[test]
    fn bad_faces_are_dropped_with_problems_and_the_rest_kept() {
        // Face 0 good, face 1 has 2 vertices, face 2 indexes point 9, face 3 uses a NaN point.
        let mut pts = QUAD.to_vec();
        pts.extend_from_slice(&[f32::NAN, 0., 0.]);
        let s = store(&pts, &[3, 2, 3, 3], &[0, 1, 2, 0, 1, 0, 2, 9, 0, 2, 4]);
        let mut p = Problems::new("/bad");
        let m = convert_mesh("/bad", &s, &mut p);
        assert_eq!(m.indices.len(), 3);
        let attrs: Vec<&str> = p.list.iter().map(|q| q.attribute.as_str()).collect();
        assert!(attrs.contains(&"faceVertexCounts"));
        assert!(attrs.contains(&"faceVertexIndices"));
        assert!(attrs.contains(&"points"));
        assert!(p.list.iter().all(|q| q.item == "/bad"));
    }

    fn with_pv(mut s: AttrStore, name: &str, interp: Interpolation, data: Vec<f32>, tuple: u32, idx: Option<Vec<i32>>) -> AttrStore {
        s.primvars.insert(name.into(), Primvar { interpolation: interp, data, tuple, indices: idx });
        s
    }

    /// Two quads sharing an edge; checks each interpolation lands on the right corners.
    #[test]
    fn every_primvar_interpolation_with_and_without_indices() {
        let pts = [0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0., 2., 0., 0., 2., 1., 0.];
        let counts = [4, 4];
        let fvi = [0, 1, 2, 3, 1, 4, 5, 2];
        let base = || store(&pts, &counts, &fvi);
        // Expected st value per (face, point, corner) for each case, checked on every output vertex.
        type Expect = fn(usize, usize, usize) -> f32;
        let cases: Vec<(Interpolation, Vec<f32>, Option<Vec<i32>>, Expect)> = vec![
            (Interpolation::Constant, vec![7.0, 7.0], None, |_, _, _| 7.0),
            (Interpolation::Constant, vec![1.0, 1.0, 7.0, 7.0], Some(vec![1]), |_, _, _| 7.0),
            (Interpolation::Uniform, vec![10.0, 10.0, 11.0, 11.0], None, |f, _, _| 10.0 + f as f32),
            (Interpolation::Uniform, vec![11.0, 11.0, 10.0, 10.0], Some(vec![1, 0]), |f, _, _| 10.0 + f as f32),
            (Interpolation::Vertex, (0..6).flat_map(|i| [i as f32, i as f32]).collect(), None, |_, p, _| p as f32),
            (Interpolation::Varying, (0..6).flat_map(|i| [i as f32, i as f32]).collect(), None, |_, p, _| p as f32),
            (
                Interpolation::Vertex,
                (0..6).rev().flat_map(|i| [i as f32, i as f32]).collect(),
                Some((0..6).rev().collect()),
                |_, p, _| p as f32,
            ),
            (Interpolation::FaceVarying, (0..8).flat_map(|i| [i as f32, i as f32]).collect(), None, |_, _, c| c as f32),
            (
                Interpolation::FaceVarying,
                (0..8).rev().flat_map(|i| [i as f32, i as f32]).collect(),
                Some((0..8).rev().collect()),
                |_, _, c| c as f32,
            ),
        ];
        for (interp, data, idx, expect) in cases {
            // the same values as texture coordinates and as a primvar a material may read
            let s = with_pv(base(), "st", interp, data.clone(), 2, idx.clone());
            let s = with_pv(s, "heat", interp, data, 2, idx.clone());
            let mut p = Problems::new("/m");
            let m = convert_mesh("/m", &s, &mut p);
            assert!(p.list.is_empty(), "{:?}", p.list);
            let uvs = m.uvs.as_ref().unwrap();
            let [heat] = &m.primvars[..] else { panic!("{:?}", m.primvars) };
            assert_eq!((heat.name.as_str(), heat.tuple, heat.constant), ("heat", 2, interp == Interpolation::Constant));
            if heat.constant {
                assert_eq!(heat.data, [7.0, 7.0]);
            }
            assert_eq!(uvs.len(), m.positions.len());
            assert_eq!(m.indices.len(), 12);
            let unwelded = matches!(interp, Interpolation::Uniform | Interpolation::FaceVarying);
            assert_eq!(m.positions.len(), if unwelded { 8 } else { 6 }, "{:?}", interp);
            // Every triangle corner: find its face (first 2 triangles = face 0) and corner.
            for t in 0..4 {
                let f = t / 2;
                for k in 0..3 {
                    let v = m.indices[3 * t + k] as usize;
                    let pos = m.positions[v];
                    let corner = (4 * f..4 * f + 4).find(|&c| {
                        let q = fvi[c] as usize;
                        Vec3::new(pts[3 * q], pts[3 * q + 1], pts[3 * q + 2]) == pos
                    });
                    let corner = corner.unwrap();
                    let want = expect(f, fvi[corner] as usize, corner);
                    assert_eq!(uvs[v], Vec2::splat(want), "{:?} {:?} tri {} corner {}", interp, idx, t, k);
                    assert_eq!(heat.element(v)[..2], [want; 2], "{:?} {:?} tri {} corner {}", interp, idx, t, k);
                }
            }
        }
    }

    #[test]
    fn wrong_sized_or_badly_indexed_primvar_is_dropped_with_a_problem() {
        let s = with_pv(store(&QUAD, &[4], &[0, 1, 2, 3]), "normals", Interpolation::Vertex, vec![0., 0., 1.], 3, None);
        let mut p = Problems::new("/m");
        let m = convert_mesh("/m", &s, &mut p);
        assert!(m.normals.is_none() && m.indices.len() == 6);
        assert_eq!(p.list[0].attribute, "normals");
        let s = with_pv(store(&QUAD, &[4], &[0, 1, 2, 3]), "st", Interpolation::FaceVarying, vec![0., 0.], 2, Some(vec![0, 0, 3, 0]));
        let mut p = Problems::new("/m");
        let m = convert_mesh("/m", &s, &mut p);
        assert!(m.uvs.is_none());
        assert_eq!(p.list[0].attribute, "st");
    }

    #[test]
    fn authored_normals_of_left_handed_mesh_agree_with_winding() {
        let mut s = with_pv(store(&QUAD, &[4], &[0, 1, 2, 3]), "normals", Interpolation::Constant, vec![0., 0., -1.], 3, None);
        s.attrs.insert("orientation".into(), Attr { value: Some(Value::Token("leftHanded".into())), samples: vec![] });
        let m = convert_mesh("/m", &s, &mut Problems::new("/m"));
        let n = m.normals.as_ref().unwrap();
        for t in 0..2 {
            let g = tri_normal(&m, t);
            for k in 0..3 {
                assert!(n[m.indices[3 * t + k] as usize].dot(g) > 0.0);
            }
        }
    }

    #[test]
    fn catmull_clark_renders_the_cage() {
        let mut s = store(&QUAD, &[4], &[0, 1, 2, 3]);
        s.attrs.insert("subdivisionScheme".into(), Attr { value: Some(Value::Token("catmullClark".into())), samples: vec![] });
        let mut p = Problems::new("/m");
        let m = convert_mesh("/m", &s, &mut p);
        assert!(p.list.is_empty());
        assert_eq!(m.indices.len(), 6);
    }
}
