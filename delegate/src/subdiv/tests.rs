use super::*;
use crate::mesh::{convert_mesh, convert_usd_mesh, Deformation};
use crate::value::{Attr, Interpolation, Primvar, Value};
use glam::{DVec3, Vec2};
use std::collections::HashMap;

/// Deterministic numbers in [0, 1) (xorshift64*).
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        (self.0.wrapping_mul(0x2545_F491_4F6C_DD1D) >> 40) as f32 / (1u64 << 24) as f32
    }
}

fn put(s: &mut AttrStore, name: &str, v: Value) {
    s.attrs.insert(name.to_string(), Attr { value: Some(v), samples: vec![] });
}

fn mesh_store(points: &[Vec3], counts: &[i32], idx: &[i32]) -> AttrStore {
    let mut s = AttrStore::default();
    put(&mut s, "points", Value::Floats { data: points.iter().flat_map(|p| p.to_array()).collect(), tuple: 3 });
    put(&mut s, "faceVertexCounts", Value::Ints(counts.to_vec()));
    put(&mut s, "faceVertexIndices", Value::Ints(idx.to_vec()));
    s
}

/// The cube [-1, 1]³, outward-facing quads.
fn cube() -> (Vec<Vec3>, Vec<i32>, Vec<i32>) {
    let pts = (0..8).map(|i| Vec3::new(if i & 1 == 0 { -1.0 } else { 1.0 }, if i & 2 == 0 { -1.0 } else { 1.0 }, if i & 4 == 0 { -1.0 } else { 1.0 })).collect();
    let idx = vec![0, 2, 3, 1, 4, 5, 7, 6, 0, 1, 5, 4, 2, 6, 7, 3, 0, 4, 6, 2, 1, 3, 7, 5];
    (pts, vec![4; 6], idx)
}

const CUBE_EDGES: [(u32, u32); 12] = [(0, 1), (2, 3), (4, 5), (6, 7), (0, 2), (1, 3), (4, 6), (5, 7), (0, 4), (1, 5), (2, 6), (3, 7)];

/// A (w × h)-face grid of points (i, j, 0), row-major, counter-clockwise quads.
fn grid(w: usize, h: usize) -> (Vec<Vec3>, Vec<i32>, Vec<i32>) {
    let pts = (0..=h).flat_map(|j| (0..=w).map(move |i| Vec3::new(i as f32, j as f32, 0.0))).collect();
    let mut idx = Vec::new();
    for j in 0..h {
        for i in 0..w {
            let v = (j * (w + 1) + i) as i32;
            idx.extend_from_slice(&[v, v + 1, v + w as i32 + 2, v + w as i32 + 1]);
        }
    }
    (pts, vec![4; w * h], idx)
}

fn run(points: &[Vec3], counts: &[i32], idx: &[i32], opts: &Options) -> Refinement {
    let mut p = Problems::new("/m");
    let r = refine(counts, idx, points, opts, &mut p);
    assert!(p.list.is_empty(), "{:?}", p.list);
    r
}

fn quads(r: &Refinement) -> impl Iterator<Item = [DVec3; 4]> + '_ {
    r.face_vertex_indices.chunks_exact(4).map(|q| [0, 1, 2, 3].map(|k| r.points[q[k] as usize].as_dvec3()))
}

/// Signed volume enclosed by closed quads (divergence theorem over their two triangles).
fn volume(quads: impl Iterator<Item = [DVec3; 4]>) -> f64 {
    quads.map(|[a, b, c, d]| (a.dot(b.cross(c)) + a.dot(c.cross(d))) / 6.0).sum()
}

/// Independent Catmull-Clark of a closed, smooth quad mesh in f64: face points, edge points
/// (v₀ + v₁ + f₀ + f₁) / 4 and vertex points (Q + 2R + (n − 3)·v) / n, by hashing edges.
fn naive_cc(points: &[DVec3], faces: &[Vec<usize>]) -> (Vec<DVec3>, Vec<Vec<usize>>) {
    let key = |a: usize, b: usize| (a.min(b), a.max(b));
    let mut edge_faces: HashMap<(usize, usize), Vec<usize>> = HashMap::new();
    for (f, fv) in faces.iter().enumerate() {
        for k in 0..fv.len() {
            edge_faces.entry(key(fv[k], fv[(k + 1) % fv.len()])).or_default().push(f);
        }
    }
    let face_pt: Vec<DVec3> = faces.iter().map(|fv| fv.iter().map(|&v| points[v]).sum::<DVec3>() / fv.len() as f64).collect();
    let mut out = Vec::new();
    let mut edge_index = HashMap::new();
    for (&(a, b), fs) in &edge_faces {
        assert_eq!(fs.len(), 2, "closed meshes only");
        edge_index.insert((a, b), out.len());
        out.push((points[a] + points[b] + face_pt[fs[0]] + face_pt[fs[1]]) / 4.0);
    }
    let face_base = out.len();
    out.extend_from_slice(&face_pt);
    let vert_base = out.len();
    let mut vert_faces = vec![Vec::new(); points.len()];
    for (f, fv) in faces.iter().enumerate() {
        for &v in fv {
            vert_faces[v].push(f);
        }
    }
    let mut vert_edges = vec![Vec::new(); points.len()];
    for &(a, b) in edge_faces.keys() {
        vert_edges[a].push((a, b));
        vert_edges[b].push((a, b));
    }
    for v in 0..points.len() {
        let (fs, es) = (&vert_faces[v], &vert_edges[v]);
        let n = es.len() as f64;
        let q = fs.iter().map(|&f| face_pt[f]).sum::<DVec3>() / fs.len() as f64;
        let r = es.iter().map(|&(a, b)| (points[a] + points[b]) / 2.0).sum::<DVec3>() / n;
        out.push((q + 2.0 * r + (n - 3.0) * points[v]) / n);
    }
    let mut new_faces = Vec::new();
    for (f, fv) in faces.iter().enumerate() {
        let m = fv.len();
        for k in 0..m {
            let e_out = edge_index[&key(fv[k], fv[(k + 1) % m])];
            let e_in = edge_index[&key(fv[(k + m - 1) % m], fv[k])];
            new_faces.push(vec![vert_base + fv[k], e_out, face_base + f, e_in]);
        }
    }
    (out, new_faces)
}

/// Limit positions of a closed quad mesh: (n²·v + 4·Σ edge neighbours + Σ opposite corners) / (n·(n + 5)).
fn naive_limit(points: &[DVec3], faces: &[Vec<usize>]) -> Vec<DVec3> {
    let mut vert_faces = vec![Vec::new(); points.len()];
    for fv in faces {
        for &v in fv {
            vert_faces[v].push(fv);
        }
    }
    (0..points.len())
        .map(|v| {
            let mut nbrs = Vec::new();
            let mut diag = DVec3::ZERO;
            for fv in &vert_faces[v] {
                let k = fv.iter().position(|&u| u == v).unwrap();
                for u in [fv[(k + 1) % 4], fv[(k + 3) % 4]] {
                    if !nbrs.contains(&u) {
                        nbrs.push(u);
                    }
                }
                diag += points[fv[(k + 2) % 4]];
            }
            let n = nbrs.len() as f64;
            (n * n * points[v] + 4.0 * nbrs.iter().map(|&u| points[u]).sum::<DVec3>() + diag) / (n * (n + 5.0))
        })
        .collect()
}

fn naive_volume(points: &[DVec3], faces: &[Vec<usize>]) -> f64 {
    volume(faces.iter().map(|f| [points[f[0]], points[f[1]], points[f[2]], points[f[3]]]))
}

#[test]
fn planar_quad_stays_the_same_square_at_every_level() {
    let (pts, counts, idx) = grid(1, 1);
    for level in 1..=MAX_LEVEL {
        let r = run(&pts, &counts, &idx, &Options::catmull_clark(level));
        assert_eq!(r.face_count(), 1 << (2 * level));
        // the corners are pinned (edgeAndCorner) and the child of control point i is point i
        assert_eq!(&r.points[..4], &pts[..]);
        for p in &r.points {
            assert!(p.z == 0.0 && (-1e-6..=1.0 + 1e-6).contains(&p.x) && (-1e-6..=1.0 + 1e-6).contains(&p.y), "{p}");
        }
        // every refined quad faces +z, and together they cover exactly the unit square
        let mut area = 0.0;
        for [a, b, c, d] in quads(&r) {
            for n in [(b - a).cross(c - a), (c - a).cross(d - a)] {
                assert!(n.z > 0.0);
                area += 0.5 * n.z;
            }
        }
        assert!((area - 1.0).abs() < 1e-6, "level {level}: area {area}");
    }
}

#[test]
fn planar_grid_stays_planar() {
    let mut rng = Rng(7);
    let (flat, counts, idx) = grid(5, 4);
    let (u, v) = (Vec3::new(0.8, 0.6, 0.0), Vec3::new(-0.36, 0.48, 0.8));
    let normal = u.cross(v).normalize();
    let origin = Vec3::new(1.0, -2.0, 0.5);
    let pts: Vec<Vec3> = flat.iter().map(|p| origin + (p.x + 0.3 * rng.next()) * u + (p.y + 0.3 * rng.next()) * v).collect();
    let r = run(&pts, &counts, &idx, &Options::catmull_clark(3));
    for p in &r.points {
        assert!((*p - origin).dot(normal).abs() < 1e-5, "{p} off the plane by {}", (*p - origin).dot(normal));
    }
}

#[test]
fn cube_limit_surface_is_round_symmetric_and_matches_an_independent_refinement() {
    let (pts, counts, idx) = cube();
    let r = run(&pts, &counts, &idx, &Options::catmull_clark(3));
    assert_eq!(r.face_count(), 6 * 64);
    assert_eq!(r.points.len(), 6 * 64 + 2);

    // Exact limit positions: a cube corner (valence 3) goes to (9v + 4·Σe + Σd) / 24 = v / 2,
    // radius √3/2; a face centre (a valence-4 face point after one level) to 68/81 of the way
    // out. Every other limit point lies in between.
    let corner = 3f32.sqrt() / 2.0;
    let face_centre = 68.0 / 81.0;
    assert!((r.points[7] - Vec3::splat(0.5)).length() < 1e-6, "{}", r.points[7]);
    let radii: Vec<f32> = r.points.iter().map(|p| p.length()).collect();
    let (lo, hi) = radii.iter().fold((f32::MAX, 0.0f32), |(a, b), &x| (a.min(x), b.max(x)));
    assert!((lo - face_centre).abs() < 1e-6 && (hi - corner).abs() < 1e-6, "radii {lo}..{hi}");

    // symmetric: centroid at the origin, the point set invariant under the axis permutations
    let centroid = r.points.iter().copied().sum::<Vec3>() / r.points.len() as f32;
    assert!(centroid.length() < 1e-6, "{centroid}");
    for perm in [[1, 0, 2], [0, 2, 1], [2, 1, 0], [1, 2, 0], [2, 0, 1]] {
        for p in &r.points {
            let q = Vec3::new(p[perm[0]], p[perm[1]], p[perm[2]]);
            assert!(r.points.iter().any(|x| (*x - q).length() < 1e-5), "{q} missing ({perm:?})");
        }
    }

    // the same points as an independent f64 Catmull-Clark (no stencils, other vertex formula)
    let mut np: Vec<DVec3> = pts.iter().map(|p| p.as_dvec3()).collect();
    let mut nf: Vec<Vec<usize>> = idx.chunks(4).map(|c| c.iter().map(|&i| i as usize).collect()).collect();
    for _ in 0..3 {
        (np, nf) = naive_cc(&np, &nf);
    }
    let limit = naive_limit(&np, &nf);
    for p in &r.points {
        assert!(limit.iter().any(|x| (*x - p.as_dvec3()).length() < 1e-5), "{p} not in the independent refinement");
    }

    // Enclosed volume: the same as the independent refinement's, inside the limit surface's
    // volume V∞ (see `cube_limit_volume_reference`: 2.620376 < V∞ < 2.620462, Richardson
    // estimate 2.620419), and the gap shrinks four-fold per level (the chordal error, O(h²)).
    let v3 = volume(quads(&r));
    let v3_independent = naive_volume(&limit, &nf);
    assert!((v3 - v3_independent).abs() < 1e-5, "{v3} vs {v3_independent}");
    assert!((v3 - 2.576957).abs() < 1e-5, "level-3 volume {v3}");
    let v_inf = 2.620419;
    let volumes: Vec<f64> = (3..=6).map(|l| volume(quads(&run(&pts, &counts, &idx, &Options::catmull_clark(l))))).collect();
    assert!(volumes.iter().all(|&v| v < 2.620376), "{volumes:?}");
    let gaps: Vec<f64> = volumes.iter().map(|v| v_inf - v).collect();
    for w in gaps.windows(2) {
        assert!((3.9..4.1).contains(&(w[0] / w[1])), "{gaps:?}");
    }
}

/// The reference for the cube's limit volume: the independent refinement brackets it between
/// its limit points' polyhedron (inscribed in the convex surface) and its control polyhedron
/// (which contains the surface). Measured: level 7 [2.6202476, 2.6205904], level 8
/// [2.6203762, 2.6204619]; Richardson from either side: 2.620419.
#[test]
fn cube_limit_volume_reference() {
    let (pts, _, idx) = cube();
    let mut np: Vec<DVec3> = pts.iter().map(|p| p.as_dvec3()).collect();
    let mut nf: Vec<Vec<usize>> = idx.chunks(4).map(|c| c.iter().map(|&i| i as usize).collect()).collect();
    let mut brackets = Vec::new();
    for _ in 0..8 {
        (np, nf) = naive_cc(&np, &nf);
        brackets.push((naive_volume(&naive_limit(&np, &nf), &nf), naive_volume(&np, &nf)));
    }
    // nested: the lower bounds rise, the upper bounds fall
    for w in brackets.windows(2) {
        assert!(w[1].0 > w[0].0 && w[1].1 < w[0].1 && w[1].0 < w[1].1, "{brackets:?}");
    }
    let (lower, upper) = brackets[7];
    assert!((lower - 2.6203762).abs() < 1e-6 && (upper - 2.6204619).abs() < 1e-6, "{lower} {upper}");
    let ((l7, u7), (l8, u8)) = (brackets[6], brackets[7]);
    let (from_below, from_above) = (l8 + (l8 - l7) / 3.0, u8 - (u7 - u8) / 3.0);
    assert!((from_below - 2.620419).abs() < 2e-6 && (from_above - 2.620419).abs() < 2e-6, "{from_below} {from_above}");
}


/// The uniform cubic B-spline basis function centred at 0.
fn bspline(t: f64) -> f64 {
    let t = t.abs();
    if t < 1.0 {
        (4.0 - 6.0 * t * t + 3.0 * t * t * t) / 6.0
    } else if t < 2.0 {
        (2.0 - t).powi(3) / 6.0
    } else {
        0.0
    }
}

#[test]
fn regular_grid_reproduces_the_bicubic_bspline_surface() {
    // Control net (i, j, z_ij) on an 8 × 8-face grid: x and y are linear in (i, j), which
    // B-splines reproduce, so a refined point's (x, y) is its parameter. Points at least two
    // cells from the boundary are unaffected by the boundary rules.
    let mut rng = Rng(42);
    let (mut pts, counts, idx) = grid(8, 8);
    for p in pts.iter_mut() {
        p.z = 2.0 * rng.next() - 1.0;
    }
    let z = |i: i64, j: i64| pts[(j * 9 + i) as usize].z as f64;
    let surface = |x: f64, y: f64| -> f64 {
        let mut s = 0.0;
        for j in (y.floor() as i64 - 2)..=(y.floor() as i64 + 2) {
            for i in (x.floor() as i64 - 2)..=(x.floor() as i64 + 2) {
                if (0..=8).contains(&i) && (0..=8).contains(&j) {
                    s += bspline(x - i as f64) * bspline(y - j as f64) * z(i, j);
                }
            }
        }
        s
    };
    for level in [1, 2, 3] {
        let r = run(&pts, &counts, &idx, &Options::catmull_clark(level));
        let mut checked = 0;
        for p in &r.points {
            let (x, y) = (p.x as f64, p.y as f64);
            if (2.0 - 1e-4..=6.0 + 1e-4).contains(&x) && (2.0 - 1e-4..=6.0 + 1e-4).contains(&y) {
                let step = 1.0 / (1 << level) as f64;
                // on the refined lattice
                assert!(((x / step).round() * step - x).abs() < 1e-5 && ((y / step).round() * step - y).abs() < 1e-5, "{p}");
                assert!((p.z as f64 - surface(x, y)).abs() < 1e-5, "level {level} at ({x}, {y}): {} vs {}", p.z, surface(x, y));
                checked += 1;
            }
        }
        let side = 4 * (1 << level) + 1;
        assert_eq!(checked, side * side);
    }
}

fn creased_cube(sharpness: f32) -> Options {
    Options { creases: CUBE_EDGES.iter().map(|&(a, b)| (a, b, sharpness)).collect(), ..Options::catmull_clark(3) }
}

#[test]
fn infinitely_sharp_creases_keep_the_cube() {
    let (pts, counts, idx) = cube();
    let r = run(&pts, &counts, &idx, &creased_cube(10.0));
    for p in &r.points {
        assert!((p.abs().max_element() - 1.0).abs() < 1e-6, "{p} is off the cube");
    }
    assert_eq!(&r.points[..8], &pts[..]);
    assert!((volume(quads(&r)) - 8.0).abs() < 1e-5);
}

#[test]
fn sharp_corner_stays_put() {
    let (pts, counts, idx) = cube();
    let opts = Options { corners: vec![(7, 10.0)], ..Options::catmull_clark(3) };
    let r = run(&pts, &counts, &idx, &opts);
    assert_eq!(r.points[7], pts[7]);
    assert!((r.points[0] - Vec3::splat(-0.5)).length() < 1e-6, "the other corners are smooth: {}", r.points[0]);
    // a semi-sharp corner moves, but less than a smooth one
    let opts = Options { corners: vec![(7, 2.0)], ..Options::catmull_clark(3) };
    let semi = run(&pts, &counts, &idx, &opts).points[7].length();
    assert!(semi > 0.5 * 3f32.sqrt() + 1e-3 && semi < 3f32.sqrt() - 1e-3, "{semi}");
}

#[test]
fn semi_sharp_creases_lie_between_smooth_and_sharp() {
    let (pts, counts, idx) = cube();
    let vol = |o: &Options| volume(quads(&run(&pts, &counts, &idx, o)));
    let smooth = vol(&Options::catmull_clark(3));
    let sharp = vol(&creased_cube(10.0));
    let mut last = smooth;
    for s in [0.5, 1.0, 2.0, 3.0] {
        let v = vol(&creased_cube(s));
        assert!(v > last + 1e-3 && v < sharp - 1e-3, "sharpness {s}: {v} after {last} (smooth {smooth}, sharp {sharp})");
        last = v;
    }
    // sharpness ≥ 10 is infinitely sharp; 3 at level 3 has decayed to nothing by the limit
    // step, yet stays short of the cube
    assert!((vol(&creased_cube(25.0)) - sharp).abs() < 1e-9);
}

#[test]
fn edge_only_boundary_rounds_the_corners() {
    let (pts, counts, idx) = grid(1, 1);
    let opts = Options { boundary: Boundary::EdgeOnly, ..Options::catmull_clark(1) };
    let r = run(&pts, &counts, &idx, &opts);
    // corner 0 is a crease vertex of the boundary curve: level 1 gives (e₀ + 6v + e₁) / 8 =
    // (1/8, 1/8) with neighbours (1/2, 0) and (0, 1/2), whose limit is (e₀ + 4v + e₁) / 6
    let v1 = Vec3::new(0.125, 0.125, 0.0);
    let want = (Vec3::new(0.5, 0.0, 0.0) + 4.0 * v1 + Vec3::new(0.0, 0.5, 0.0)) / 6.0;
    assert!((r.points[0] - want).length() < 1e-6, "{} vs {want}", r.points[0]);
}

#[test]
fn hole_children_are_dropped_and_the_rest_refined() {
    let (pts, counts, idx) = grid(3, 3);
    let mut s = mesh_store(&pts, &counts, &idx);
    put(&mut s, "holeIndices", Value::Ints(vec![4]));
    put(&mut s, LEVEL_ATTR, Value::Int(2));
    let mut p = Problems::new("/m");
    let m = convert_mesh("/m", &s, &mut p);
    assert!(p.list.is_empty(), "{:?}", p.list);
    assert_eq!(m.indices.len(), 3 * 2 * 8 * 16);
    // a uniform planar grid refines into the uniform grid of spacing 1/4 (linear precision)
    for t in m.indices.chunks_exact(3) {
        let c = t.iter().map(|&i| m.positions[i as usize]).sum::<Vec3>() / 3.0;
        assert!(!(c.x > 1.0 && c.x < 2.0 && c.y > 1.0 && c.y < 2.0), "triangle {c} inside the hole");
    }
    // the hole's children exist in the refinement (they shape their neighbours)
    let r = run(&pts, &counts, &idx, &Options::catmull_clark(2));
    assert_eq!(r.child_faces(4), 64..80);
}

#[test]
fn the_stencil_is_linear_and_affine() {
    let mut rng = Rng(3);
    let (pts, counts, idx) = cube();
    let pts: Vec<Vec3> = pts.iter().map(|p| *p + Vec3::new(rng.next(), rng.next(), rng.next()) * 0.3).collect();
    let vel: Vec<Vec3> = (0..8).map(|_| Vec3::new(rng.next(), rng.next(), rng.next()) - 0.5).collect();
    let opts = Options { corners: vec![(2, 1.5)], creases: vec![(0, 1, 0.7), (1, 3, 10.0)], ..Options::catmull_clark(3) };
    let r = run(&pts, &counts, &idx, &opts);
    let t = 0.37;
    let moved: Vec<Vec3> = pts.iter().zip(&vel).map(|(p, v)| *p + *v * t).collect();
    let direct = r.stencil.apply_vec3(&moved);
    let refined_v = r.stencil.apply_vec3(&vel);
    for i in 0..r.points.len() {
        assert!((direct[i] - (r.points[i] + refined_v[i] * t)).length() < 1e-5);
    }
    // flat data through `apply` equals the Vec3 path, and every row is an affine combination
    let flat = r.stencil.apply(&pts.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>(), 3);
    for (i, q) in r.points.iter().enumerate() {
        assert!((Vec3::from_slice(&flat[3 * i..3 * i + 3]) - *q).length() < 1e-6);
        let sum: f32 = r.stencil.row(i).map(|(_, w)| w).sum();
        assert!((sum - 1.0).abs() < 1e-5, "row {i} sums to {sum}");
        assert!(r.stencil.row(i).all(|(_, w)| w > 0.0));
    }
}

#[test]
fn bilinear_splits_without_changing_the_shape() {
    let (pts, counts, idx) = cube();
    let opts = Options { scheme: Scheme::Bilinear, ..Options::catmull_clark(2) };
    let r = run(&pts, &counts, &idx, &opts);
    assert_eq!(r.face_count(), 6 * 16);
    assert_eq!(&r.points[..8], &pts[..]);
    for p in &r.points {
        assert!((p.abs().max_element() - 1.0).abs() < 1e-6, "{p}");
        // on the 1/2-spaced lattice of the cube's faces
        assert!((*p * 2.0).round().abs_diff_eq(*p * 2.0, 1e-6), "{p}");
    }
    assert!((volume(quads(&r)) - 8.0).abs() < 1e-6);
}

#[test]
fn n_gons_give_n_quads_and_face_varying_all_is_bilinear_per_face() {
    // a pentagon and a triangle sharing an edge
    let pts = vec![Vec3::new(0.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(2.5, 1.5, 0.0), Vec3::new(1.0, 2.5, 0.0), Vec3::new(-0.5, 1.5, 0.0), Vec3::new(2.0, -1.5, 0.0)];
    let counts = [5, 3];
    let idx = [0, 1, 2, 3, 4, 0, 5, 1];
    let r = run(&pts, &counts, &idx, &Options { face_varying: FaceVarying::All, ..Options::catmull_clark(2) });
    assert_eq!(r.child_faces(0), 0..20);
    assert_eq!(r.child_faces(1), 20..32);
    // faceVarying values equal to the corners' positions: under `all` the refined values are
    // the bilinear split of each control face (no smoothing), so the corners of each level-1
    // quad's children interpolate that quad's corner, edge midpoints and centroid
    let data: Vec<f32> = idx.iter().flat_map(|&i| [pts[i as usize].x, pts[i as usize].y]).collect();
    let fv = r.face_varying(&data, 2);
    assert_eq!(fv.len(), 2 * 4 * 32);
    let centroid = pts[..5].iter().copied().sum::<Vec3>() / 5.0;
    let at = |corner: usize| Vec2::new(fv[2 * corner], fv[2 * corner + 1]);
    // face 0's quad 0 = (P0, mid P0P1, centroid, mid P4P0); its first child's corners
    let (p0, m01, m40) = (pts[0].truncate(), (pts[0] + pts[1]).truncate() / 2.0, (pts[4] + pts[0]).truncate() / 2.0);
    let q = [p0, m01, centroid.truncate(), m40];
    let mid = |a: Vec2, b: Vec2| (a + b) / 2.0;
    let want = [q[0], mid(q[0], q[1]), (q[0] + q[1] + q[2] + q[3]) / 4.0, mid(q[3], q[0])];
    for (k, w) in want.iter().enumerate() {
        assert!((at(k) - *w).length() < 1e-6, "corner {k}: {} vs {w}", at(k));
    }
    // varying: the same values per refined point, consistent across the shared edge
    let vdata: Vec<f32> = pts.iter().flat_map(|p| [p.x, p.y]).collect();
    let var = r.varying(&vdata, 2);
    for (corner, &v) in r.face_vertex_indices.iter().enumerate() {
        if corner < 4 * 20 {
            let x = Vec2::new(var[2 * v as usize], var[2 * v as usize + 1]);
            assert!((x - at(corner)).length() < 1e-5, "corner {corner}");
        }
    }
}

#[test]
fn non_manifold_edges_and_bad_faces_do_not_break_it() {
    // three quads on the edge 0-1 (a non-manifold fin), a bowtie vertex, a face with a NaN
    // point, one with an index out of range and one with two vertices
    let mut pts = vec![
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 1.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::new(1.0, -1.0, 0.0),
        Vec3::new(0.0, -1.0, 0.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.0, 0.0, 1.0),
        Vec3::new(2.0, 2.0, 0.0),
        Vec3::new(1.0, 2.0, 0.0),
    ];
    pts.push(Vec3::NAN);
    let counts = [4, 4, 4, 3, 3, 3, 2];
    let idx = [0, 1, 2, 3, 1, 0, 5, 4, 0, 1, 6, 7, 2, 8, 9, 2, 8, 10, 2, 8, 99, 0, 1];
    let mut p = Problems::new("/m");
    let r = refine(&counts, &idx, &pts, &Options::catmull_clark(3), &mut p);
    assert!(p.list.is_empty());
    // every point a refined face uses is finite (the NaN point itself is used by none)
    assert!(r.face_vertex_indices.iter().all(|&v| r.points[v as usize].is_finite()));
    assert!(r.points[10].is_nan() && r.points.iter().filter(|q| !q.is_finite()).count() == 1);
    assert_eq!(r.face_count(), (4 + 4 + 4 + 3) * 16);
    assert!(r.child_faces(4).is_empty() && r.child_faces(5).is_empty() && r.child_faces(6).is_empty());
    // the fin edge is a crease: its end points stay on the x axis
    for v in [0, 1] {
        assert!(r.points[v].y.abs() < 1e-6 && r.points[v].z.abs() < 1e-6, "{}", r.points[v]);
    }
    // the bowtie vertex 2 (two fans) is pinned
    assert_eq!(r.points[2], pts[2]);

    // through the mesh conversion: the cage's problems, and the good faces refined
    let mut s = mesh_store(&pts, &counts, &idx);
    put(&mut s, LEVEL_ATTR, Value::Int(1));
    let mut p = Problems::new("/m");
    let m = convert_mesh("/m", &s, &mut p);
    let attrs: Vec<&str> = p.list.iter().map(|q| q.attribute.as_str()).collect();
    assert!(attrs.contains(&"points") && attrs.contains(&"faceVertexIndices") && attrs.contains(&"faceVertexCounts"), "{attrs:?}");
    assert_eq!(m.indices.len(), 3 * 2 * (4 + 4 + 4 + 3));
    assert!(m.positions.iter().all(|q| q.is_finite()) && m.normals.as_ref().unwrap().iter().all(|n| n.is_finite()));
}

fn problems(s: &AttrStore) -> (tide_core::scene::MeshDesc, Vec<(String, String, String)>) {
    let mut p = Problems::new("/World/M");
    let m = convert_mesh("/World/M", s, &mut p);
    (m, p.list.into_iter().map(|q| (q.item, q.attribute, q.message)).collect())
}

#[test]
fn level_zero_and_scheme_none_are_exactly_the_cage() {
    let (pts, counts, idx) = cube();
    let mut base = mesh_store(&pts, &counts, &idx);
    base.primvars.insert("st".into(), Primvar { interpolation: Interpolation::FaceVarying, data: (0..48).map(|i| i as f32 / 48.0).collect(), tuple: 2, indices: None });
    base.primvars.insert("normals".into(), Primvar { interpolation: Interpolation::Vertex, data: pts.iter().flat_map(|p| p.normalize().to_array()).collect(), tuple: 3, indices: None });
    let cage = problems(&base);
    assert!(cage.1.is_empty());
    for (scheme, level) in [(None, 0), (Some("catmullClark"), 0), (Some("none"), 3), (Some("bilinear"), 0)] {
        let mut s = base.clone();
        if let Some(sc) = scheme {
            put(&mut s, "subdivisionScheme", Value::Token(sc.into()));
        }
        put(&mut s, LEVEL_ATTR, Value::Int(level));
        assert_eq!(problems(&s), cage, "{scheme:?} {level}");
    }
}

#[test]
fn bad_levels_schemes_and_creases_are_problems_naming_prim_and_attribute() {
    let (pts, counts, idx) = cube();
    let base = mesh_store(&pts, &counts, &idx);
    let cage = problems(&base).0;
    let with = |attrs: &[(&str, Value)]| {
        let mut s = base.clone();
        for (n, v) in attrs {
            put(&mut s, n, v.clone());
        }
        problems(&s)
    };
    let smooth2 = with(&[(LEVEL_ATTR, Value::Int(2))]);
    assert!(smooth2.1.is_empty());
    assert_eq!(smooth2.0.indices.len(), 6 * 16 * 2 * 3);
    let only = |list: &[(String, String, String)], attr: &str, text: &str| {
        assert_eq!(list.len(), 1, "{list:?}");
        assert_eq!((list[0].0.as_str(), list[0].1.as_str()), ("/World/M", attr));
        assert!(list[0].2.contains(text), "{list:?}");
    };
    // negative: the cage
    let (m, list) = with(&[(LEVEL_ATTR, Value::Int(-2))]);
    only(&list, LEVEL_ATTR, "negative");
    assert_eq!(m, cage);
    // above 6: level 6
    let (m, list) = with(&[(LEVEL_ATTR, Value::Int(9))]);
    only(&list, LEVEL_ATTR, "maximum 6");
    assert_eq!(m.indices.len(), 6 * 4096 * 2 * 3);
    // the viewer's refinement where no level is authored; an authored level wins, an authored
    // 0 included; a fallback above 6 is 6 without a problem
    let (m, list) = with(&[(REFINE_ATTR, Value::Int(2))]);
    assert!(list.is_empty(), "{list:?}");
    assert_eq!(m, smooth2.0);
    assert_eq!(with(&[(REFINE_ATTR, Value::Int(2)), (LEVEL_ATTR, Value::Int(0))]).0, cage);
    assert_eq!(with(&[(REFINE_ATTR, Value::Int(1)), (LEVEL_ATTR, Value::Int(2))]).0, smooth2.0);
    let (m, list) = with(&[(REFINE_ATTR, Value::Int(8))]);
    assert!(list.is_empty(), "{list:?}");
    assert_eq!(m.indices.len(), 6 * 4096 * 2 * 3);
    // an unknown faceVarying rule: USD's fallback, cornersPlus1
    let fvar = |t: &str| vec![(LEVEL_ATTR, Value::Int(2)), ("faceVaryingLinearInterpolation", Value::Token(t.into()))];
    let (m, list) = with(&fvar("smoothest"));
    only(&list, "faceVaryingLinearInterpolation", "unknown token 'smoothest'");
    assert_eq!(m, with(&fvar("cornersPlus1")).0);
    // loop: the cage
    let (m, list) = with(&[(LEVEL_ATTR, Value::Int(2)), ("subdivisionScheme", Value::Token("loop".into()))]);
    only(&list, "subdivisionScheme", "loop subdivision is not supported; rendered as its cage");
    assert_eq!(m, cage);
    // interpolateBoundary none on a closed mesh: no boundary, nothing left out
    let (m, list) = with(&[(LEVEL_ATTR, Value::Int(2)), ("interpolateBoundary", Value::Token("none".into()))]);
    assert!(list.is_empty(), "{list:?}");
    assert_eq!(m, smooth2.0);
    // malformed creases and corners: reported, ignored, the smooth surface rendered
    let crease = |i: Vec<i32>, l: Vec<i32>, sh: Vec<f32>| {
        vec![(LEVEL_ATTR, Value::Int(2)), ("creaseIndices", Value::Ints(i)), ("creaseLengths", Value::Ints(l)), ("creaseSharpnesses", Value::Floats { data: sh, tuple: 1 })]
    };
    for (attrs, attr, text) in [
        (crease(vec![0, 1, 42], vec![3], vec![2.0]), "creaseIndices", "out of range"),
        (crease(vec![0, 1, 3], vec![2], vec![2.0]), "creaseLengths", "sum to 2"),
        (crease(vec![0, 1, 3], vec![3], vec![2.0, 2.0, 2.0]), "creaseSharpnesses", "one per crease or one per crease edge"),
        (crease(vec![0, 7], vec![2], vec![2.0]), "creaseIndices", "no face edge joins"),
        (vec![(LEVEL_ATTR, Value::Int(2)), ("cornerIndices", Value::Ints(vec![8])), ("cornerSharpnesses", Value::Floats { data: vec![10.0], tuple: 1 })], "cornerIndices", "out of range"),
        (vec![(LEVEL_ATTR, Value::Int(2)), ("cornerIndices", Value::Ints(vec![1, 2])), ("cornerSharpnesses", Value::Floats { data: vec![10.0], tuple: 1 })], "cornerSharpnesses", "one per corner"),
    ] {
        let (m, list) = with(&attrs);
        only(&list, attr, text);
        assert_eq!(m, smooth2.0, "{attr}");
    }
    // well-formed creases, per crease and per edge, through the attributes
    let (m, list) = with(&crease(vec![0, 1, 3, 2, 0], vec![5], vec![10.0]));
    assert!(list.is_empty(), "{list:?}");
    let (m2, list) = with(&crease(vec![0, 1, 3, 2, 0], vec![5], vec![10.0; 4]));
    assert!(list.is_empty(), "{list:?}");
    assert_eq!(m, m2);
    assert_ne!(m, smooth2.0);
    // the creased square's points stay on the plane z = -1
    let on_face = m.positions.iter().filter(|p| (p.z + 1.0).abs() < 1e-6).count();
    assert!(on_face >= 25, "{on_face}");
}

#[test]
fn usd_mesh_with_time_samples_subsets_and_st() {
    let (pts, counts, idx) = grid(2, 1);
    let mut s = mesh_store(&pts, &counts, &idx);
    put(&mut s, LEVEL_ATTR, Value::Int(2));
    let later: Vec<Vec3> = pts.iter().map(|p| *p + Vec3::new(0.1, 0.0, p.x * 0.5)).collect();
    let flat = |v: &[Vec3]| Value::Floats { data: v.iter().flat_map(|p| p.to_array()).collect(), tuple: 3 };
    s.attrs.insert("points".into(), Attr { value: None, samples: vec![(0.0, flat(&pts)), (1.0, flat(&later))] });
    put(&mut s, "geomSubsets", Value::Paths(vec!["/M/left".into()]));
    put(&mut s, "/M/left.indices", Value::Ints(vec![0]));
    put(&mut s, "/M/left.material", Value::Path("/Looks/Red".into()));
    s.primvars.insert("st".into(), Primvar { interpolation: Interpolation::FaceVarying, data: idx.iter().flat_map(|&i| [pts[i as usize].x, pts[i as usize].y]).collect(), tuple: 2, indices: None });
    let mut p = Problems::new("/M");
    let g = convert_usd_mesh("/M", &s, &mut p);
    assert!(p.list.is_empty(), "{:?}", p.list);
    let m = &g.mesh;
    assert_eq!(m.indices.len(), 2 * 16 * 2 * 3);
    assert_eq!(g.subsets[0].triangles.len(), 16 * 2);
    assert_eq!(g.rest.len(), 16 * 2);
    // the subset holds the left face's children (x ≤ 1 at frame 0), the rest the right one's;
    // each refined triangle's element is its control face
    let corners = |t: u32| m.indices[3 * t as usize..3 * t as usize + 3].iter().map(|&i| m.positions[i as usize].x).collect::<Vec<_>>();
    assert!(g.subsets[0].triangles.iter().all(|&t| corners(t).iter().all(|&x| x <= 1.0 + 1e-6) && m.element_of(t) == 0));
    assert!(g.rest.iter().all(|&t| corners(t).iter().all(|&x| x >= 1.0 - 1e-6) && m.element_of(t) == 1));
    // faceVarying st: the control face's bilinear split, here the refined (x, y) themselves,
    // and the normals from the limit surface (+z for the planar grid)
    let (uvs, normals) = (m.uvs.as_ref().unwrap(), m.normals.as_ref().unwrap());
    for (i, q) in m.positions.iter().enumerate() {
        assert!((uvs[i] - q.truncate()).length() < 1e-5, "{} vs {q}", uvs[i]);
        assert!((normals[i] - Vec3::Z).length() < 1e-5);
    }
    // the keys: each sample refined with the same topology, as converting that pose would
    let Some(Deformation::Samples(keys)) = &g.deformation else { panic!("no keys: {:?}", g.deformation) };
    assert_eq!(keys.len(), 2);
    for (t, pose) in [(0.0, &pts), (1.0, &later)] {
        let key = &keys.iter().find(|k| k.0 == t).unwrap().1;
        assert_eq!(key.len(), m.positions.len());
        let mut still = s.clone();
        put(&mut still, "points", flat(pose));
        let posed = convert_mesh("/M", &still, &mut Problems::new("/M"));
        assert_eq!(posed.indices, m.indices);
        for (a, b) in key.iter().zip(&posed.positions) {
            assert!((*a - *b).length() < 1e-6);
        }
    }
    // velocities go through the same stencil
    let mut moving = mesh_store(&pts, &counts, &idx);
    put(&mut moving, LEVEL_ATTR, Value::Int(2));
    put(&mut moving, "velocities", flat(&pts.iter().map(|p| Vec3::new(0.0, 0.0, p.x)).collect::<Vec<_>>()));
    let g = convert_usd_mesh("/M", &moving, &mut Problems::new("/M"));
    let Some(Deformation::Velocity { velocities, .. }) = &g.deformation else { panic!("no velocities") };
    for (v, q) in velocities.iter().zip(&g.mesh.positions) {
        assert!((v.z - q.x).abs() < 1e-5 && v.x == 0.0 && v.y == 0.0, "{v} at {q}");
    }
}

#[test]
fn left_handed_subdivided_normals_face_the_flipped_winding() {
    let (pts, counts, idx) = cube();
    for orientation in ["rightHanded", "leftHanded"] {
        let mut s = mesh_store(&pts, &counts, &idx);
        put(&mut s, LEVEL_ATTR, Value::Int(2));
        put(&mut s, "orientation", Value::Token(orientation.into()));
        let m = problems(&s).0;
        let n = m.normals.as_ref().unwrap();
        for t in m.indices.chunks_exact(3) {
            let [a, b, c] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
            let g = (b - a).cross(c - a);
            assert!(t.iter().all(|&i| n[i as usize].dot(g) > 0.0), "{orientation}");
            // the cube's faces are wound outward, so right-handed normals point out
            let out = n[t[0] as usize].dot(a) > 0.0;
            assert_eq!(out, orientation == "rightHanded");
        }
    }
}

/// About 100k control faces at level 2 (run with `--ignored` to time it).
#[test]
#[ignore]
fn large_mesh_refines_quickly() {
    let (mut pts, counts, idx) = grid(320, 320);
    let mut rng = Rng(11);
    for p in pts.iter_mut() {
        p.z = rng.next();
    }
    let t = std::time::Instant::now();
    let r = run(&pts, &counts, &idx, &Options::catmull_clark(2));
    let refine_s = t.elapsed().as_secs_f64();
    let mut s = mesh_store(&pts, &counts, &idx);
    put(&mut s, LEVEL_ATTR, Value::Int(2));
    let t = std::time::Instant::now();
    let m = convert_usd_mesh("/M", &s, &mut Problems::new("/M"));
    println!(
        "{} faces → {} refined, {} weights: refine {:.2} s, convert {:.2} s",
        counts.len(),
        r.face_count(),
        r.stencil.weight_count(),
        refine_s,
        t.elapsed().as_secs_f64()
    );
    assert_eq!(m.mesh.indices.len(), counts.len() * 16 * 6);
}

#[test]
fn levels_past_the_size_limit_are_lowered_with_a_problem() {
    let mut s = AttrStore::default();
    put(&mut s, LEVEL_ATTR, Value::Int(6));
    // 1100 quads at level 6 would be 4.5 million faces: level 5 (1.1 million)
    let mut p = Problems::new("/m");
    let o = read_options(&s, "catmullClark", &vec![4; 1100], 1200, &mut p).unwrap();
    assert_eq!(o.level, 5);
    assert_eq!((p.list.len(), p.list[0].attribute.as_str()), (1, LEVEL_ATTR));
    assert!(p.list[0].message.contains("refined to level 5"), "{:?}", p.list);
    // one 100000-gon: every refined point weighs all its corners, so not even level 1
    put(&mut s, LEVEL_ATTR, Value::Int(1));
    let mut p = Problems::new("/m");
    assert!(read_options(&s, "catmullClark", &[100_000], 100_000, &mut p).is_none());
    assert!(p.list[0].message.contains("rendered as its cage"), "{:?}", p.list);
    // within the limits nothing is said
    let mut p = Problems::new("/m");
    assert_eq!(read_options(&s, "catmullClark", &vec![4; 100_000], 100_000, &mut p).map(|o| o.level), Some(1));
    assert!(p.list.is_empty());
}

#[test]
fn boundary_none_leaves_the_faces_that_touch_the_boundary_out() {
    // a 3 x 3 grid bent into a bowl: only the middle face touches no boundary vertex
    let (mut pts, counts, idx) = grid(3, 3);
    for q in &mut pts {
        q.z = 0.3 * ((q.x - 1.5).powi(2) + (q.y - 1.5).powi(2));
    }
    let flags = boundary_faces(&counts, &idx, pts.len());
    assert_eq!(flags.iter().filter(|&&b| !b).count(), 1);
    assert!(!flags[4], "the middle face");
    let mut s = mesh_store(&pts, &counts, &idx);
    put(&mut s, LEVEL_ATTR, Value::Int(2));
    let (corners, list) = problems(&s);
    assert!(list.is_empty(), "{list:?}");
    put(&mut s, "interpolateBoundary", Value::Token("none".into()));
    let (none, list) = problems(&s);
    assert!(list.is_empty(), "{list:?}");
    // the middle face's 16 children, each where edgeAndCorner puts it (the boundary rules do
    // not reach a face whose vertices are all interior)
    assert_eq!(none.indices.len(), 16 * 2 * 3);
    for t in none.indices.chunks_exact(3) {
        let tri = t.iter().map(|&i| none.positions[i as usize]).collect::<Vec<_>>();
        let found = corners.indices.chunks_exact(3).any(|u| u.iter().zip(&tri).all(|(&i, q)| (corners.positions[i as usize] - *q).length() < 1e-6));
        assert!(found, "{tri:?}");
    }
}

/// The refined faceVarying value at the point that corner `k` of control face `f` was.
fn at_control_corner(r: &Refinement, fv: &[f32], f: usize, k: usize) -> Vec2 {
    let d = 1usize << (2 * (r.level - 1));
    let c = 4 * (r.child_faces(f).start + k * d);
    Vec2::new(fv[2 * c], fv[2 * c + 1])
}

/// A faceVarying primvar without seams whose values are the points' positions refines exactly
/// as the points do (the values' mesh is the mesh), and a seam keeps each side's constant
/// value: no value crosses it.
#[test]
fn face_varying_without_seams_follows_the_points_and_seams_are_not_crossed() {
    let (pts, counts, idx) = cube();
    for rule in [FaceVarying::None, FaceVarying::CornersOnly, FaceVarying::CornersPlus1, FaceVarying::CornersPlus2, FaceVarying::Boundaries] {
        let r = run(&pts, &counts, &idx, &Options { face_varying: rule, ..Options::catmull_clark(3) });
        let data: Vec<f32> = idx.iter().flat_map(|&i| pts[i as usize].to_array()).collect();
        let fv = r.face_varying(&data, 3);
        for (corner, &v) in r.face_vertex_indices.iter().enumerate() {
            let x = Vec3::from_slice(&fv[3 * corner..3 * corner + 3]);
            assert!((x - r.points[v as usize]).length() < 1e-5, "{rule:?} corner {corner}: {x} vs {}", r.points[v as usize]);
        }
        // one value per face: six islands, each refined to its own constant
        let data: Vec<f32> = (0..24).flat_map(|c| [(c / 4) as f32, 10.0]).collect();
        let fv = r.face_varying(&data, 2);
        for f in 0..6 {
            for g in r.child_faces(f) {
                for c in 4 * g..4 * g + 4 {
                    assert!((fv[2 * c] - f as f32).abs() < 1e-6 && (fv[2 * c + 1] - 10.0).abs() < 1e-6, "{rule:?} face {f}");
                }
            }
        }
    }
}

/// Each faceVarying rule pins what it names and smooths the rest, with limits computed by hand.
#[test]
fn face_varying_rules_pin_corners_junctions_darts_and_boundaries() {
    // 2 × 2 unit quads: point 3y + x at (x, y), the centre point 4
    let (pts, counts, idx) = grid(2, 2);
    let pts = &pts;
    let refine = |rule: FaceVarying, data: &[f32]| {
        let r = run(pts, &counts, &idx, &Options { face_varying: rule, ..Options::catmull_clark(3) });
        let fv = r.face_varying(data, 2);
        (r, fv)
    };
    use FaceVarying::*;
    // corners: one island with the points' positions; its corner (0, 0) has one face. Pinned by
    // every rule but none, where it moves to its boundary curve's limit (e₀ + 4v + e₁) / 6
    // = ((1, 0) + (0, 1)) / 6
    let plain: Vec<f32> = idx.iter().flat_map(|&i| [pts[i as usize].x, pts[i as usize].y]).collect();
    for rule in [CornersOnly, CornersPlus1, CornersPlus2, Boundaries, All] {
        let (r, fv) = refine(rule, &plain);
        assert!(at_control_corner(&r, &fv, 0, 0).length() < 1e-6, "{rule:?}");
    }
    let (r, fv) = refine(None, &plain);
    assert!((at_control_corner(&r, &fv, 0, 0) - Vec2::splat(1.0 / 6.0)).length() < 1e-6);
    // boundaries: the boundary point (1, 0) given the value (1, 0.5): linear along the
    // boundary under `boundaries` (kept), on the smooth boundary curve otherwise:
    // (0 + 4·0.5 + 0) / 6 = 1/3
    let bent: Vec<f32> = idx.iter().flat_map(|&i| if i == 1 { [1.0, 0.5] } else { [pts[i as usize].x, pts[i as usize].y] }).collect();
    for (rule, y) in [(Boundaries, 0.5), (CornersPlus1, 1.0 / 3.0), (None, 1.0 / 3.0)] {
        let (r, fv) = refine(rule, &bent);
        assert!((at_control_corner(&r, &fv, 0, 1) - Vec2::new(1.0, y)).length() < 1e-6, "{rule:?}: {}", at_control_corner(&r, &fv, 0, 1));
    }
    // junctions: faces 0 and 1 one island, faces 2 and 3 one each: three values meet at the
    // centre (1, 1). Island 0's value there is (1, 1.5) against (0, 1) and (2, 1) along its
    // seam: pinned by cornersPlus1, on the seam curve's limit under cornersOnly: y =
    // (1 + 4·1.5 + 1) / 6
    let island = |f: usize, i: i32| -> [f32; 2] {
        let p = pts[i as usize];
        match f {
            0 | 1 if i == 4 => [1.0, 1.5],
            0 | 1 => [p.x, p.y],
            _ => [p.x + 10.0 * f as f32, p.y],
        }
    };
    let three: Vec<f32> = idx.chunks(4).enumerate().flat_map(|(f, q)| q.iter().flat_map(move |&i| island(f, i)).collect::<Vec<_>>()).collect();
    let (r, fv) = refine(CornersPlus1, &three);
    assert!((at_control_corner(&r, &fv, 0, 2) - Vec2::new(1.0, 1.5)).length() < 1e-6);
    let (r, fv) = refine(CornersOnly, &three);
    assert!((at_control_corner(&r, &fv, 0, 2) - Vec2::new(1.0, 8.0 / 6.0)).length() < 1e-6, "{}", at_control_corner(&r, &fv, 0, 2));
    // darts: a seam from the boundary point (1, 0) to the centre only (faces 0 and 1 differ at
    // (1, 0) alone); the centre, valued (1, 1.5), is pinned by cornersPlus2 and not by
    // cornersPlus1
    let dart: Vec<f32> = idx
        .chunks(4)
        .enumerate()
        .flat_map(|(f, q)| q.iter().flat_map(move |&i| if i == 4 { [1.0, 1.5] } else if i == 1 && f == 1 { [1.0, -1.0] } else { [pts[i as usize].x, pts[i as usize].y] }).collect::<Vec<_>>())
        .collect();
    let (r, fv) = refine(CornersPlus2, &dart);
    assert!((at_control_corner(&r, &fv, 0, 2) - Vec2::new(1.0, 1.5)).length() < 1e-6);
    let (r, fv) = refine(CornersPlus1, &dart);
    assert!((at_control_corner(&r, &fv, 0, 2) - Vec2::new(1.0, 1.5)).length() > 0.05, "{}", at_control_corner(&r, &fv, 0, 2));
}

/// `triangleSubdivisionRule = smooth` (OpenSubdiv's smooth triangle option): in a smooth edge
/// point each adjacent triangle's face point weighs 0.47 instead of ¼, both face points take
/// the mean of their faces' weights and the end points share what is left; edges between quads
/// keep Catmull-Clark's own rule, and nothing changes without the option.
#[test]
fn the_smooth_triangle_rule_reweights_edge_points_next_to_triangles() {
    // a square pyramid: four triangles about the apex 4 and a quad base
    let counts = [3, 3, 3, 3, 4];
    let idx = [0, 1, 4, 1, 2, 4, 2, 3, 4, 3, 0, 4, 0, 3, 2, 1];
    let ranges: Vec<Range<usize>> = vec![0..3, 3..6, 6..9, 9..12, 12..16];
    let opts = Options::catmull_clark(1);
    let topo = Topo::from_cage(5, &ranges, &idx, &opts, &mut Problems::new(""));
    let weights = |smooth: bool| -> Vec<Vec<f64>> {
        let rows = topo.refine_rows(None, Scheme::CatmullClark, 5, smooth);
        (0..5).map(|k| rows.apply(&(0..5).map(|i| (i == k) as u32 as f32).collect::<Vec<_>>(), 1).iter().map(|&w| w as f64).collect()).collect()
    };
    let (plain, smooth) = (weights(false), weights(true));
    let (nv, nf) = (5, counts.len());
    for (e, &[a, b]) in topo.edges.iter().enumerate() {
        let row = nv + nf + e;
        let faces: Vec<usize> = topo.edge_faces.get(e).iter().map(|&f| f as usize).collect();
        let tri = |f: usize| counts[f] == 3;
        // expected weights over the control points, from the rule's definition: face points
        // of weight fw each, the end points (1 − 2 fw)/2 each
        let want = |fw: f64| {
            let mut w = [0.0f64; 5];
            w[a as usize] += 0.5 * (1.0 - 2.0 * fw);
            w[b as usize] += 0.5 * (1.0 - 2.0 * fw);
            for &f in &faces {
                for &v in &idx[ranges[f].clone()] {
                    w[v as usize] += fw / counts[f] as f64;
                }
            }
            w
        };
        // 0.47 between two triangles, (0.47 + 0.25)/2 between a triangle and the quad
        let fw = if faces.iter().all(|&f| tri(f)) { 0.47 } else { 0.36 };
        for k in 0..5 {
            assert!((smooth[k][row] - want(fw)[k]).abs() < 1e-6, "edge {a}-{b}, point {k}: {} vs {}", smooth[k][row], want(fw)[k]);
            assert!((plain[k][row] - want(0.25)[k]).abs() < 1e-6, "edge {a}-{b}, point {k}: {} vs {}", plain[k][row], want(0.25)[k]);
        }
    }
    // vertex and face points are the same either way
    for k in 0..5 {
        assert_eq!(plain[k][..nv + nf], smooth[k][..nv + nf]);
    }
    // the mesh's token turns the option on (Catmull-Clark only); an unknown one is named
    let mut s = AttrStore::default();
    put(&mut s, LEVEL_ATTR, Value::Int(1));
    let rule = |s: &mut AttrStore, t: &str, scheme: &str| {
        put(s, "triangleSubdivisionRule", Value::Token(t.into()));
        let mut p = Problems::new("/m");
        (read_options(s, scheme, &counts, 5, &mut p).map(|o| o.smooth_triangles), p.list.len())
    };
    assert_eq!(rule(&mut s, "smooth", "catmullClark"), (Some(true), 0));
    assert_eq!(rule(&mut s, "catmullClark", "catmullClark"), (Some(false), 0));
    assert_eq!(rule(&mut s, "smooth", "bilinear"), (Some(false), 0));
    assert_eq!(rule(&mut s, "loopy", "catmullClark"), (Some(false), 1));
}
