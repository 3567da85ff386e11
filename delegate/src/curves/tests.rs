use super::*;
use crate::value::{Attr, Primvar, Value};
use std::collections::HashMap;

fn floats(d: &[f32], tuple: u32) -> Value {
    Value::Floats { data: d.to_vec(), tuple }
}

fn tok(s: &str) -> Value {
    Value::Token(s.into())
}

fn store(points: &[Vec3], counts: &[i32], attrs: &[(&str, Value)]) -> AttrStore {
    let mut s = AttrStore::default();
    let mut set = |n: &str, v: Value| {
        s.attrs.insert(n.to_string(), Attr { value: Some(v), samples: vec![] });
    };
    set("points", floats(&points.iter().flat_map(|p| p.to_array()).collect::<Vec<_>>(), 3));
    set("curveVertexCounts", Value::Ints(counts.to_vec()));
    for (n, v) in attrs {
        set(n, v.clone());
    }
    s
}

fn primvar(s: &mut AttrStore, name: &str, interp: Interpolation, data: &[f32], tuple: u32) {
    s.primvars.insert(name.into(), Primvar { interpolation: interp, data: data.to_vec(), tuple, indices: None });
}

fn convert(s: &AttrStore) -> (MeshGeom, Vec<tide_core::Problem>) {
    let mut p = Problems::new("/Curves");
    let g = convert_curves("/Curves", s, &mut p);
    (g, p.list)
}

/// Signed volume enclosed by a triangle mesh (divergence theorem): positive when it is
/// closed and its triangles face out.
fn volume(m: &MeshDesc) -> f32 {
    m.indices
        .chunks_exact(3)
        .map(|t| {
            let [a, b, c] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
            a.dot(b.cross(c)) / 6.0
        })
        .sum()
}

/// Every edge (between welded positions) is shared by exactly two triangles, once each way.
fn assert_watertight(m: &MeshDesc) {
    let key = |p: Vec3| (p * 1e4).round().as_ivec3().to_array();
    let mut edges: HashMap<([i32; 3], [i32; 3]), i32> = HashMap::new();
    for t in m.indices.chunks_exact(3) {
        for k in 0..3 {
            let (a, b) = (key(m.positions[t[k] as usize]), key(m.positions[t[(k + 1) % 3] as usize]));
            if a == b {
                continue; // a sliver's collapsed edge
            }
            *edges.entry((a, b)).or_default() += 1;
            *edges.entry((b, a)).or_default() -= 1;
        }
    }
    assert!(edges.values().all(|&c| c == 0), "open or doubly used edges");
}

/// The centre of each tube ring (its TUBE_SIDES distinct vertices), in order, without caps.
fn ring_centres(m: &MeshDesc, rings: usize) -> Vec<Vec3> {
    (0..rings).map(|r| (0..TUBE_SIDES).map(|k| m.positions[r * (TUBE_SIDES + 1) + k]).sum::<Vec3>() / TUBE_SIDES as f32).collect()
}

fn bezier(p: &[Vec3; 4], t: f32) -> Vec3 {
    let s = 1.0 - t;
    p[0] * (s * s * s) + p[1] * (3.0 * s * s * t) + p[2] * (3.0 * s * t * t) + p[3] * (t * t * t)
}

fn distance_to_curve(q: Vec3, f: impl Fn(f32) -> Vec3) -> f32 {
    (0..=4000).map(|i| (f(i as f32 / 4000.0) - q).length()).fold(f32::INFINITY, f32::min)
}

#[test]
fn a_linear_tube_is_a_closed_octagonal_prism_of_the_width() {
    let pts = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0)];
    let mut s = store(&pts, &[2], &[("type", tok("linear"))]);
    primvar(&mut s, "widths", Interpolation::Constant, &[0.5], 1);
    let (g, p) = convert(&s);
    assert!(p.is_empty(), "{p:?}");
    let m = &g.mesh;
    for (i, q) in m.positions.iter().enumerate().take(2 * (TUBE_SIDES + 1)) {
        assert!((q.y.hypot(q.z) - 0.25).abs() < 1e-6, "vertex {i} off the surface");
    }
    assert_watertight(m);
    // an octagon inscribed in r has area 2·√2·r²
    let expected = 2.0 * 2f32.sqrt() * 0.25 * 0.25 * 2.0;
    assert!((volume(m) - expected).abs() < 1e-5, "{} vs {}", volume(m), expected);
    // the shading normals point out of the axis
    let ns = m.normals.as_ref().unwrap();
    for (q, n) in m.positions.iter().zip(ns).take(2 * (TUBE_SIDES + 1)) {
        assert!((*n - Vec3::new(0.0, q.y, q.z) / 0.25).length() < 1e-5);
    }
    assert!(g.rest.is_empty() && g.subsets.is_empty());
    assert!(m.faces.len() == m.indices.len() / 3 && m.faces.iter().all(|&c| c == 0), "one curve: every triangle is curve 0's");
}

#[test]
fn a_bezier_tube_follows_its_curve_from_end_to_end() {
    let c = [Vec3::ZERO, Vec3::new(1.0, 2.0, 0.0), Vec3::new(3.0, 2.0, 1.0), Vec3::new(4.0, 0.0, 0.0)];
    let mut s = store(&c, &[4], &[]);
    primvar(&mut s, "widths", Interpolation::Constant, &[0.1], 1);
    let (g, p) = convert(&s);
    assert!(p.is_empty(), "{p:?}");
    let side_vertices = g.mesh.positions.len() - 2 * (TUBE_SIDES + 1);
    let rings = side_vertices / (TUBE_SIDES + 1);
    assert!((2..=MAX_STEPS + 1).contains(&rings));
    let centres = ring_centres(&g.mesh, rings);
    assert!((centres[0] - c[0]).length() < 1e-5 && (centres[rings - 1] - c[3]).length() < 1e-5);
    for q in &centres {
        // an octagon's vertex mean is its centre: on the curve
        assert!(distance_to_curve(*q, |t| bezier(&c, t)) < 2e-3, "{q}");
    }
    // no step turns the tangent by much more than MAX_TURN
    for w in centres.windows(3) {
        assert!(turn(w[1] - w[0], w[2] - w[1]) < 1.5 * MAX_TURN);
    }
    assert_watertight(&g.mesh);
    assert!(volume(&g.mesh) > 0.0);
}

#[test]
fn bspline_ends_depend_on_wrap_and_catmull_rom_passes_through_its_vertices() {
    let c: Vec<Vec3> = [(0.0, 0.0), (1.0, 1.0), (2.0, 0.0), (3.0, 1.0), (4.0, 0.0)].iter().map(|&(x, y)| Vec3::new(x, y, 0.0)).collect();
    let ends = |basis: &str, wrap: &str| {
        let s = store(&c, &[5], &[("basis", tok(basis)), ("wrap", tok(wrap))]);
        let (g, p) = convert(&s);
        assert!(p.is_empty(), "{p:?}");
        let rings = (g.mesh.positions.len() - 2 * (TUBE_SIDES + 1)) / (TUBE_SIDES + 1);
        ring_centres(&g.mesh, rings)
    };
    let open = ends("bspline", "nonperiodic");
    assert!((open[0] - (c[0] + 4.0 * c[1] + c[2]) / 6.0).length() < 1e-5);
    assert!((open.last().unwrap().clone() - (c[2] + 4.0 * c[3] + c[4]) / 6.0).length() < 1e-5);
    let pinned = ends("bspline", "pinned");
    assert!((pinned[0] - c[0]).length() < 1e-5 && (*pinned.last().unwrap() - c[4]).length() < 1e-5);
    let cr = ends("catmullRom", "nonperiodic");
    // a Catmull-Rom segment runs from its window's second vertex to its third
    for v in &c[1..4] {
        assert!(cr.iter().any(|q| (*q - *v).length() < 1e-5), "{v} not on the curve");
    }
}

#[test]
fn a_periodic_curve_is_a_closed_untwisted_ring() {
    // a trefoil knot as a periodic B-spline: parallel transport around it comes back turned by
    // about 2 radians, which the frames must spread over the loop
    let n = 48;
    let c: Vec<Vec3> = (0..n)
        .map(|i| {
            let a = TAU * i as f32 / n as f32;
            Vec3::new(a.sin() + 2.0 * (2.0 * a).sin(), a.cos() - 2.0 * (2.0 * a).cos(), -(3.0 * a).sin())
        })
        .collect();
    let mut s = store(&c, &[n as i32], &[("basis", tok("bspline")), ("wrap", tok("periodic"))]);
    primvar(&mut s, "widths", Interpolation::Constant, &[0.2], 1);
    let (g, p) = convert(&s);
    assert!(p.is_empty(), "{p:?}");
    let m = &g.mesh;
    assert_watertight(m);
    assert!(volume(m) > 0.0);
    // from ring to ring (the last back to the first) a vertex's offset from its ring's centre
    // turns only as much as the tangent does, plus a small share of the spread twist
    let rings = m.positions.len() / (TUBE_SIDES + 1);
    let centres = ring_centres(m, rings);
    for r in 0..rings - 1 {
        for k in 0..TUBE_SIDES {
            let a = m.positions[r * (TUBE_SIDES + 1) + k] - centres[r];
            let b = m.positions[(r + 1) * (TUBE_SIDES + 1) + k] - centres[r + 1];
            assert!((a - b).length() < 0.1 * (3.0 * MAX_TURN + 0.1), "ring {r} side {k}: {}", (a - b).length());
        }
    }
}

#[test]
fn widths_follow_the_curves_interpolation_rules() {
    let line = |n: usize, x0: f32| -> Vec<Vec3> { (0..n).map(|i| Vec3::new(x0 + i as f32, 0.0, 0.0)).collect() };
    let radius_at = |m: &MeshDesc, ring: usize| {
        let c = ring_centres(m, ring + 1)[ring];
        (m.positions[ring * (TUBE_SIDES + 1)] - c).length()
    };
    // varying on linear curves: one per vertex; two curves, so the second's widths start at 3
    let mut pts = line(3, 0.0);
    pts.extend(line(2, 10.0));
    let mut s = store(&pts, &[3, 2], &[("type", tok("linear"))]);
    primvar(&mut s, "widths", Interpolation::Varying, &[0.2, 0.4, 0.6, 1.0, 2.0], 1);
    let (g, p) = convert(&s);
    assert!(p.is_empty(), "{p:?}");
    let per_curve = 3 * (TUBE_SIDES + 1) + 2 * (TUBE_SIDES + 1); // rings and caps of the first
    for (ring, w) in [(0, 0.2), (1, 0.4), (2, 0.6)] {
        assert!((radius_at(&g.mesh, ring) - w / 2.0).abs() < 1e-5);
    }
    let second = &MeshDesc { positions: g.mesh.positions[per_curve..].to_vec(), ..Default::default() };
    assert!((radius_at(second, 0) - 0.5).abs() < 1e-5 && (radius_at(second, 1) - 1.0).abs() < 1e-5);
    // uniform: one per curve
    let mut s = store(&pts, &[3, 2], &[("type", tok("linear"))]);
    primvar(&mut s, "widths", Interpolation::Uniform, &[0.2, 0.8], 1);
    let g = convert(&s).0;
    assert!((radius_at(&g.mesh, 2) - 0.1).abs() < 1e-5);
    assert!((radius_at(&MeshDesc { positions: g.mesh.positions[per_curve..].to_vec(), ..Default::default() }, 0) - 0.4).abs() < 1e-5);
    // vertex on a pinned B-spline: through the basis, so the end widths are the end values
    let mut s = store(&line(4, 0.0), &[4], &[("basis", tok("bspline")), ("wrap", tok("pinned"))]);
    primvar(&mut s, "widths", Interpolation::Vertex, &[0.2, 0.2, 0.2, 0.8], 1);
    let g = convert(&s).0;
    let rings = (g.mesh.positions.len() - 2 * (TUBE_SIDES + 1)) / (TUBE_SIDES + 1);
    assert!((radius_at(&g.mesh, 0) - 0.1).abs() < 1e-5 && (radius_at(&g.mesh, rings - 1) - 0.4).abs() < 1e-5);
    // a wrong count is a problem and the width falls back to 1
    let mut s = store(&pts, &[3, 2], &[("type", tok("linear"))]);
    primvar(&mut s, "widths", Interpolation::Vertex, &[0.2, 0.4], 1);
    let (g, p) = convert(&s);
    assert_eq!(p.len(), 1);
    assert_eq!((p[0].item.as_str(), p[0].attribute.as_str()), ("/Curves", "widths"));
    assert!((radius_at(&g.mesh, 0) - 0.5).abs() < 1e-5);
}

#[test]
fn oriented_curves_are_ribbons_facing_their_normals() {
    let c = [Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(3.0, 0.0, 0.0)];
    let mut s = store(&c, &[4], &[("basis", tok("catmullRom")), ("wrap", tok("pinned"))]);
    primvar(&mut s, "widths", Interpolation::Constant, &[0.4], 1);
    primvar(&mut s, "normals", Interpolation::Constant, &[0.0, 1.0, 0.0], 3);
    let (g, p) = convert(&s);
    assert!(p.is_empty(), "{p:?}");
    let m = &g.mesh;
    assert!(m.double_sided);
    assert!(m.positions.iter().all(|q| q.y.abs() < 1e-6 && (q.z.abs() - 0.2).abs() < 1e-5));
    for t in m.indices.chunks_exact(3) {
        let [a, b, d] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
        let n = (b - a).cross(d - a);
        if n.length() > 1e-9 {
            assert!(n.normalize().dot(Vec3::Y) > 0.999, "a triangle faces {n}");
        }
    }
    assert!(m.normals.as_ref().unwrap().iter().all(|n| (*n - Vec3::Y).length() < 1e-6));
    // the ribbon spans the curve: area = width · length
    let area: f32 = m.indices.chunks_exact(3).map(|t| {
        let [a, b, d] = [0, 1, 2].map(|k| m.positions[t[k] as usize]);
        0.5 * (b - a).cross(d - a).length()
    }).sum();
    assert!((area - 0.4 * 3.0).abs() < 1e-4, "{area}");
}

#[test]
fn bad_counts_drop_the_curve_or_the_prim_with_a_problem() {
    let line: Vec<Vec3> = (0..7).map(|i| Vec3::new(i as f32, 0.0, 0.0)).collect();
    // counts that do not add up: nothing is drawn
    let (g, p) = convert(&store(&line, &[4, 4], &[]));
    assert!(g.mesh.indices.is_empty());
    assert_eq!(p[0].attribute, "curveVertexCounts");
    // a 3-vertex bezier cannot be drawn; the 4-vertex one is
    let (g, p) = convert(&store(&line, &[3, 4], &[]));
    assert_eq!(p.len(), 1);
    assert!(p[0].attribute == "curveVertexCounts" && p[0].message.contains("curve 0"), "{p:?}");
    assert!(g.mesh.positions.iter().all(|q| q.x >= 3.0 - 0.51));
    assert!(!g.mesh.indices.is_empty());
    // a NaN point drops its curve only
    let mut bad = line.clone();
    bad[1] = Vec3::NAN;
    let (g, p) = convert(&store(&bad, &[3, 4], &[("type", tok("linear"))]));
    assert!(p.iter().any(|q| q.attribute == "curveVertexCounts" && q.message.contains("NaN")));
    assert!(g.mesh.positions.iter().all(|q| q.is_finite() && q.x >= 3.0 - 0.51));
    // an unknown basis is a problem and the fallback (bezier) draws
    let (g, p) = convert(&store(&line[..4], &[4], &[("basis", tok("nurbs"))]));
    assert_eq!(p[0].attribute, "basis");
    assert!(!g.mesh.indices.is_empty());
}

#[test]
fn moving_points_move_every_tube_vertex() {
    let c = [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::new(2.0, 1.0, 0.0), Vec3::new(3.0, 0.0, 0.0)];
    let flat = |shift: f32| floats(&c.iter().flat_map(|p| (*p + Vec3::new(0.0, shift, 0.0)).to_array()).collect::<Vec<_>>(), 3);
    let mut s = store(&c, &[4], &[]);
    s.attrs.get_mut("points").unwrap().value = None;
    s.attrs.get_mut("points").unwrap().samples = vec![(0.0, flat(0.0)), (1.0, flat(0.5))];
    let (g, p) = convert(&s);
    assert!(p.is_empty(), "{p:?}");
    let Some(Deformation::Samples(keys)) = &g.deformation else { panic!("no keys") };
    assert_eq!(keys.len(), 2);
    for (a, b) in keys[0].1.iter().zip(&keys[1].1) {
        assert!((*b - *a - Vec3::new(0.0, 0.5, 0.0)).length() < 1e-5);
    }
    // velocities: a vertex moves with the blend of its control vertices' velocities
    let mut s = store(&c, &[4], &[("velocities", floats(&[0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 6.0], 3))]);
    primvar(&mut s, "widths", Interpolation::Constant, &[0.1], 1);
    let (g, _) = convert(&s);
    let Some(Deformation::Velocity { velocities, .. }) = &g.deformation else { panic!("no velocities") };
    // the tube's last ring sits on the last control vertex (bezier): it moves at its speed
    let last_ring = g.mesh.positions.len() - 2 * (TUBE_SIDES + 1) - (TUBE_SIDES + 1);
    assert!((velocities[last_ring] - Vec3::new(0.0, 0.0, 6.0)).length() < 1e-5);
    assert!(velocities[0].length() < 1e-6);
}


#[test]
fn primvars_reach_every_vertex_through_the_curves_rules() {
    // three linear curves, the middle one (a single vertex) dropped: uniform values keep their
    // curve's, vertex values are interpolated along it, constant ones stay constant
    let pts = [Vec3::ZERO, Vec3::X, Vec3::new(5.0, 0.0, 0.0), Vec3::new(0.0, 5.0, 0.0), Vec3::new(2.0, 5.0, 0.0)];
    let mut s = store(&pts, &[2, 1, 2], &[("type", tok("linear"))]);
    primvar(&mut s, "widths", Interpolation::Constant, &[0.2], 1);
    primvar(&mut s, "tag", Interpolation::Uniform, &[10.0, 20.0, 30.0], 1);
    primvar(&mut s, "heat", Interpolation::Vertex, &[0.0, 1.0, 7.0, 2.0, 4.0], 1);
    primvar(&mut s, "tint", Interpolation::Constant, &[0.1, 0.2, 0.3], 3);
    let (g, _) = convert(&s);
    let m = &g.mesh;
    let find = |n: &str| m.primvars.iter().find(|p| p.name == n).unwrap_or_else(|| panic!("{n} in {:?}", m.primvars));
    let (tag, heat, tint) = (find("tag"), find("heat"), find("tint"));
    assert!(!tag.constant && !heat.constant && tint.constant);
    assert_eq!(tint.data, [0.1, 0.2, 0.3]);
    assert_eq!((tag.data.len(), heat.data.len()), (m.positions.len(), m.positions.len()));
    for (v, p) in m.positions.iter().enumerate() {
        let (want_tag, want_heat) = if p.y < 1.0 { (10.0, p.x) } else { (30.0, 2.0 + p.x) };
        assert_eq!(tag.data[v], want_tag, "vertex {v} at {p}");
        assert!((heat.data[v] - want_heat).abs() < 1e-5, "vertex {v} at {p}: {}", heat.data[v]);
    }
}

/// A linear curve keeps its full width through a corner: the ring at the joint lies on both
/// segments' tubes (a miter), so each segment is as wide as its width all along (each ring had
/// been perpendicular to the mean tangent at the radius, narrowing both segments by
/// cos(turn / 2)); a ribbon's edge is mitred the same way.
#[test]
fn linear_corners_keep_the_segments_width() {
    let pts = [Vec3::ZERO, Vec3::new(2.0, 0.0, 0.0), Vec3::new(2.0, 2.0, 0.0)];
    let (r, dist_to_line) = (0.15f32, |q: Vec3, o: Vec3, d: Vec3| (q - o).reject_from(d).length());
    let s = store(&pts, &[3], &[("type", tok("linear")), ("widths", floats(&[0.3], 1))]);
    let (g, problems) = convert(&s);
    assert!(problems.is_empty(), "{problems:?}");
    let m = &g.mesh;
    for k in 0..TUBE_SIDES {
        let q = m.positions[TUBE_SIDES + 1 + k]; // the corner's ring
        assert!((dist_to_line(q, pts[0], Vec3::X) - r).abs() < 1e-5, "vertex {k}: {q}");
        assert!((dist_to_line(q, pts[2], Vec3::Y) - r).abs() < 1e-5, "vertex {k}: {q}");
    }
    // a ribbon facing +Z: its corner edge points are r from both segments' centre lines
    let mut s = store(&pts, &[3], &[("type", tok("linear")), ("widths", floats(&[0.3], 1))]);
    primvar(&mut s, "normals", Interpolation::Constant, &[0.0, 0.0, 1.0], 3);
    let (g, _) = convert(&s);
    for q in &g.mesh.positions[2..4] {
        assert!((dist_to_line(*q, pts[0], Vec3::X) - r).abs() < 1e-5 && (dist_to_line(*q, pts[2], Vec3::Y) - r).abs() < 1e-5, "{q}");
    }
}

/// Per-vertex widths blend through a cubic basis: a straight bezier's width follows the basis
/// between its ends (0.494 at a quarter for widths 0.1, 0.8, 0.8, 0.1), not a line between a
/// few samples.
#[test]
fn cubic_vertex_widths_follow_the_basis() {
    let pts = [Vec3::ZERO, Vec3::new(1.0, 0.0, 0.0), Vec3::new(2.0, 0.0, 0.0), Vec3::new(3.0, 0.0, 0.0)];
    let mut s = store(&pts, &[4], &[("type", tok("cubic")), ("basis", tok("bezier"))]);
    primvar(&mut s, "widths", Interpolation::Vertex, &[0.1, 0.8, 0.8, 0.1], 1);
    let (g, _) = convert(&s);
    let m = &g.mesh;
    // the tube's radius at each x, from its vertices (all rings; caps at the ends excluded)
    let w = |t: f32| {
        let s = 1.0 - t;
        0.1 * s * s * s + 0.8 * 3.0 * s * s * t + 0.8 * 3.0 * s * t * t + 0.1 * t * t * t
    };
    let rings = (m.positions.len() - 2 * (TUBE_SIDES + 1)) / (TUBE_SIDES + 1);
    assert!(rings >= WIDTH_STEPS + 1, "{rings} rings");
    for ring in 0..rings {
        let q = m.positions[ring * (TUBE_SIDES + 1)];
        let t = q.x / 3.0; // a straight bezier with evenly spaced points: x runs with t
        let radius = Vec2::new(q.y, q.z).length();
        assert!((radius - 0.5 * w(t)).abs() < 1e-4, "ring {ring} at t {t}: radius {radius}, want {}", 0.5 * w(t));
    }
}
