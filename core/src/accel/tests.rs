use super::*;
use crate::scene::{GeometryRef, InstanceDesc, MeshDesc, SpheresDesc};
use glam::{Mat4, Quat, Vec3};

fn quad() -> MeshDesc {
    MeshDesc {
        name: "quad".into(),
        positions: vec![Vec3::new(-1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, -1.0), Vec3::new(1.0, 0.0, 1.0), Vec3::new(-1.0, 0.0, 1.0)],
        indices: vec![0, 2, 1, 0, 3, 2],
        ..Default::default()
    }
}

fn inst(g: GeometryRef, m: Vec<Mat4>, times: Vec<f32>) -> InstanceDesc {
    InstanceDesc { name: "i".into(), geometry: g, transforms: m, times, material: 0, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None }
}

#[test]
fn hits_a_translated_quad_and_a_sphere_in_order() {
    let meshes = vec![Arc::new(quad())];
    let spheres = vec![Arc::new(SpheresDesc { name: "s".into(), centers: vec![Vec3::new(0.0, 3.0, 0.0)], radii: vec![0.5], velocities: None, ..Default::default() })];
    let instances = vec![
        inst(GeometryRef::Mesh(0), vec![Mat4::from_translation(Vec3::new(0.0, 1.0, 0.0))], vec![0.0]),
        inst(GeometryRef::Spheres(0), vec![Mat4::IDENTITY], vec![0.0]),
    ];
    let a = Accel::build(&meshes, &spheres, &instances, (0.0, 0.0));
    let down = Ray { o: Vec3::new(0.1, 10.0, 0.2), d: -Vec3::Y, t_max: f32::INFINITY, time: 0.0 };
    let h = a.intersect(&down).unwrap();
    assert_eq!(h.instance, 1);
    // sphere top at y = 3.5 (sphere centre offset by (0.1, 0.2) in xz)
    let expect = 10.0 - (3.0 + (0.25f32 - 0.05).sqrt());
    assert!((h.t - expect).abs() < 1e-4, "{} vs {}", h.t, expect);
    let beside = Ray { o: Vec3::new(0.9, 10.0, 0.9), d: -Vec3::Y, t_max: f32::INFINITY, time: 0.0 };
    let h = a.intersect(&beside).unwrap();
    assert_eq!(h.instance, 0);
    assert!((h.t - 9.0).abs() < 1e-5);
    // t_max limits the search
    assert!(a.intersect(&Ray { t_max: 8.0, ..beside }).is_none());
}

#[test]
fn ocean_scale_quads_are_hit_exactly() {
    // a 10 km quad hit far from the origin: t must be accurate to well below a millimetre
    let mut m = quad();
    for p in &mut m.positions {
        *p *= 5000.0;
    }
    let a = Accel::build(&[m.into()], &[], &[inst(GeometryRef::Mesh(0), vec![Mat4::IDENTITY], vec![0.0])], (0.0, 0.0));
    let r = Ray { o: Vec3::new(3000.0, 2.0, -2500.0), d: Vec3::new(0.0, -1.0, 0.0), t_max: f32::INFINITY, time: 0.0 };
    let h = a.intersect(&r).unwrap();
    assert!((h.t - 2.0).abs() < 1e-3);
}

#[test]
fn moving_instance_is_hit_where_it_is_at_the_ray_time() {
    let m0 = Mat4::from_translation(Vec3::new(-5.0, 0.0, 0.0));
    let m1 = Mat4::from_translation(Vec3::new(5.0, 0.0, 0.0));
    let a = Accel::build(&[quad().into()], &[], &[inst(GeometryRef::Mesh(0), vec![m0, m1], vec![0.0, 1.0])], (0.0, 1.0));
    let r = |time| Ray { o: Vec3::new(0.0, 1.0, 0.0), d: -Vec3::Y, t_max: f32::INFINITY, time };
    assert!(a.intersect(&r(0.0)).is_none());
    assert!(a.intersect(&r(0.5)).is_some());
    assert!(a.intersect(&r(1.0)).is_none());
}

#[test]
fn rotation_is_interpolated_on_an_arc() {
    // quad rotated 90° about Y over the shutter: halfway it is at 45°, not a sheared lerp
    let m0 = Mat4::IDENTITY;
    let m1 = Mat4::from_quat(Quat::from_rotation_y(std::f32::consts::FRAC_PI_2));
    let xf = motion::MotionTransform::new(&[m0, m1], &[0.0, 1.0]);
    let mid = xf.at(0.5);
    let x = mid.transform_vector3(Vec3::X);
    assert!((x.length() - 1.0).abs() < 1e-5);
    assert!((x - Vec3::new(0.5f32.sqrt(), 0.0, -(0.5f32.sqrt()))).length() < 1e-5);
}

/// A spin of ten turns over 4000 keys gives bounding matrices within 32 a key interval (π/64 of
/// turn each: 4 for its 9°), not 32 a key; a point a unit off the axis of a turn of 170° over
/// three keys lies, at any time, in the box of the point carried through the bounding matrices but
/// for the arcs' sag between steps (1 − cos(π/128) of the radius; the keys alone miss the
/// top of the arc by 0.004); a transform that only moves gives its keys alone.
#[test]
fn bounding_matrices_of_many_keys_are_few_and_hold_the_motion() {
    let turning = |n: usize, turn: f32| {
        let times: Vec<f32> = (0..n).map(|i| i as f32 / (n - 1) as f32).collect();
        let mats: Vec<Mat4> = times.iter().map(|&t| Mat4::from_rotation_y(turn * t)).collect();
        motion::MotionTransform::new(&mats, &times)
    };
    let n = 4000;
    let spin = turning(n, 20.0 * std::f32::consts::PI).bounding_matrices((0.0, 1.0));
    assert!(spin.len() <= 1 + 4 * (n - 1), "{}", spin.len());
    let xf = turning(3, 170f32.to_radians());
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for m in xf.bounding_matrices((0.0, 1.0)) {
        let p = m.transform_point3(Vec3::X);
        lo = lo.min(p);
        hi = hi.max(p);
    }
    let sag = 1.0 - (std::f32::consts::PI / 128.0).cos() + 1e-5;
    let mut rng = crate::testing::chi2::TestRng::new(5);
    for _ in 0..10000 {
        let p = xf.at(rng.next_f32()).transform_point3(Vec3::X);
        assert!(p.cmpge(lo - sag).all() && p.cmple(hi + sag).all(), "{p} outside {lo}..{hi}");
    }
    // moving without turning: the keys themselves
    let times: Vec<f32> = (0..n).map(|i| i as f32 / (n - 1) as f32).collect();
    let slide: Vec<Mat4> = times.iter().map(|&t| Mat4::from_translation(Vec3::new(t, 0.0, 0.0))).collect();
    assert_eq!(motion::MotionTransform::new(&slide, &times).bounding_matrices((0.0, 1.0)).len(), n);
}

/// The key interval a time falls in, found by bisection, is the one a scan finds, repeated
/// key times and times outside the keys included.
#[test]
fn key_location_by_bisection_agrees_with_a_scan() {
    let scan = |times: &[f32], time: f32| {
        let n = times.len();
        if n < 2 || time <= times[0] {
            return (0, 0.0);
        }
        if time >= times[n - 1] {
            return (n - 2, 1.0);
        }
        let mut i = 0;
        while i + 2 < n && times[i + 1] <= time {
            i += 1;
        }
        let (a, b) = (times[i], times[i + 1]);
        (i, if b > a { (time - a) / (b - a) } else { 0.0 })
    };
    let mut rng = crate::testing::chi2::TestRng::new(9);
    for n in [1usize, 2, 3, 7, 50] {
        let mut times: Vec<f32> = (0..n).map(|_| (rng.next_f32() * 8.0).floor() / 4.0).collect();
        times.sort_by(f32::total_cmp);
        for k in 0..200 {
            let t = if k % 3 == 0 { times[k % n] } else { rng.next_f32() * 2.5 - 0.25 };
            assert_eq!(crate::scene::locate_key(&times, t), scan(&times, t), "{times:?} at {t}");
        }
    }
}

#[test]
fn moving_spheres_follow_their_velocity() {
    let s = SpheresDesc { name: "s".into(), centers: vec![Vec3::ZERO], radii: vec![0.1], velocities: Some(vec![Vec3::new(2.0, 0.0, 0.0)]), ..Default::default() };
    let a = Accel::build(&[], &[std::sync::Arc::new(s)], &[inst(GeometryRef::Spheres(0), vec![Mat4::IDENTITY], vec![0.0])], (0.0, 0.5));
    let r = |x: f32, time| Ray { o: Vec3::new(x, 5.0, 0.0), d: -Vec3::Y, t_max: f32::INFINITY, time };
    assert!(a.intersect(&r(0.0, 0.0)).is_some());
    assert!(a.intersect(&r(1.0, 0.0)).is_none());
    assert!(a.intersect(&r(1.0, 0.5)).is_some());
}

#[test]
fn brute_force_agrees_on_random_rays() {
    // random triangle soup vs brute force over all triangles
    let mut rng = crate::testing::chi2::TestRng::new(5);
    let mut m = MeshDesc { name: "soup".into(), ..Default::default() };
    for i in 0..300u32 {
        let c = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 10.0;
        for _ in 0..3 {
            m.positions.push(c + Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5);
        }
        m.indices.extend([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    let a = Accel::build(&[m.clone().into()], &[], &[inst(GeometryRef::Mesh(0), vec![Mat4::IDENTITY], vec![0.0])], (0.0, 0.0));
    for _ in 0..500 {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 14.0 - 2.0;
        let d = crate::math::sample_uniform_sphere(glam::Vec2::new(rng.next_f32(), rng.next_f32()));
        let mut best = f32::INFINITY;
        let mut exact = f64::INFINITY;
        for i in 0..300usize {
            let p = |k: usize| m.positions[m.indices[3 * i + k] as usize];
            let t = TriPre { v0: p(0).into(), e1: (p(1) - p(0)).into(), e2: (p(2) - p(0)).into() };
            if let Some((t, _, _)) = t.intersect(o.into(), d.into(), 0.0, best) {
                best = t;
                let (a, b, c) = (p(0).as_dvec3(), p(1).as_dvec3(), p(2).as_dvec3());
                let n = (b - a).cross(c - a);
                exact = (a - o.as_dvec3()).dot(n) / d.as_dvec3().dot(n);
            }
        }
        let h = a.intersect(&Ray { o, d, t_max: f32::INFINITY, time: 0.0 });
        // the same hit, at the plane's distance computed in f64 to within 8 ulps of f32 (the
        // reference's own f32 distance strays up to 2e-6 from it)
        match h {
            Some(h) => assert!(((h.t as f64 - exact) / exact).abs() <= 1e-6, "{} against {exact} ({best})", h.t),
            None => assert!(best.is_infinite(), "missed a hit at {best}"),
        }
    }
}



#[test]
fn a_cache_reuses_the_bvh_of_unchanged_geometry_and_rebuilds_the_edited() {
    let moved = |x: f32| Mat4::from_translation(Vec3::new(x, 0.0, 0.0));
    let lifted = |k: f32| {
        let mut m = quad();
        for p in &mut m.positions {
            p.y += k;
        }
        m
    };
    let meshes: Vec<Arc<MeshDesc>> = vec![lifted(0.0).into(), lifted(1.0).into(), lifted(2.0).into()];
    let spheres = vec![Arc::new(SpheresDesc { name: "s".into(), centers: vec![Vec3::new(0.0, 5.0, 0.0)], radii: vec![0.5], velocities: None, ..Default::default() })];
    let instances = |x: f32| {
        vec![
            inst(GeometryRef::Mesh(0), vec![moved(x)], vec![0.0]),
            inst(GeometryRef::Mesh(1), vec![Mat4::IDENTITY], vec![0.0]),
            inst(GeometryRef::Mesh(2), vec![Mat4::IDENTITY], vec![0.0]),
            inst(GeometryRef::Spheres(0), vec![Mat4::IDENTITY], vec![0.0]),
        ]
    };
    let cache = BlasCache::default();
    let a = Accel::build_cached(&meshes, &spheres, &instances(0.0), (0.0, 0.0), Some(&cache));
    assert_eq!((a.stats.blas_built, a.stats.blas_reused, cache.len()), (4, 0, 4));

    // An instance moved: every geometry BVH is reused, and the moved instance is hit where it now is.
    let b = Accel::build_cached(&meshes, &spheres, &instances(10.0), (0.0, 0.0), Some(&cache));
    assert_eq!((b.stats.blas_built, b.stats.blas_reused), (0, 4));
    let down = |x: f32| Ray { o: Vec3::new(x, 0.5, 0.0), d: -Vec3::Y, t_max: f32::INFINITY, time: 0.0 };
    assert_eq!(b.intersect(&down(10.0)).map(|h| (h.instance, h.t)), Some((0, 0.5)));
    assert!(b.intersect(&down(0.0)).is_none());

    // One mesh's points edited (and the order of geometry changed): only that BVH is built,
    // and the stale one leaves the cache.
    let edited: Vec<Arc<MeshDesc>> = vec![lifted(2.0).into(), lifted(1.0).into(), lifted(-3.0).into()];
    let c = Accel::build_cached(&edited, &spheres, &instances(0.0), (0.0, 0.0), Some(&cache));
    assert_eq!((c.stats.blas_built, c.stats.blas_reused, cache.len()), (1, 3, 4));
    let h = c.intersect(&Ray { o: Vec3::new(0.9, 10.0, 0.9), d: -Vec3::Y, t_max: f32::INFINITY, time: 0.0 }).unwrap();
    assert_eq!((h.instance, h.t), (0, 8.0));
    let fresh = Accel::build(&edited, &spheres, &instances(0.0), (0.0, 0.0));
    for k in 0..50 {
        let r = Ray { o: Vec3::new(-1.2 + 0.05 * k as f32, 10.0, 0.3), d: Vec3::new(0.01, -1.0, 0.02).normalize(), t_max: f32::INFINITY, time: 0.0 };
        assert_eq!(c.intersect(&r), fresh.intersect(&r));
    }

    // Moving spheres depend on the shutter: a new shutter rebuilds them, not the meshes.
    let moving = vec![Arc::new(SpheresDesc { velocities: Some(vec![Vec3::X]), ..(*spheres[0]).clone() })];
    Accel::build_cached(&edited, &moving, &instances(0.0), (0.0, 0.5), Some(&cache));
    let d = Accel::build_cached(&edited, &moving, &instances(0.0), (0.0, 1.0), Some(&cache));
    assert_eq!((d.stats.blas_built, d.stats.blas_reused), (1, 3));

    // Without a cache everything is built.
    assert_eq!((fresh.stats.blas_built, fresh.stats.blas_reused), (4, 0));
}

/// A triangle soup whose vertices move between three keys (times 0, 0.3, 1 s).
fn deforming_soup(rng: &mut crate::testing::chi2::TestRng, n: u32) -> MeshDesc {
    let mut r3 = || Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
    let mut m = MeshDesc { name: "soup".into(), ..Default::default() };
    let mut keys = vec![Vec::new(), Vec::new(), Vec::new()];
    for i in 0..n {
        let c = r3() * 10.0;
        for _ in 0..3 {
            let p = c + r3() - 0.5;
            keys[0].push(p);
            keys[1].push(p + (r3() - 0.5) * 2.0);
            keys[2].push(p + (r3() - 0.5) * 2.0);
        }
        m.indices.extend([3 * i, 3 * i + 1, 3 * i + 2]);
    }
    m.positions = keys[0].clone();
    m.motion = Some(crate::scene::MeshMotion { times: vec![0.0, 0.3, 1.0], positions: keys, normals: None });
    m
}

/// Reference for the deforming mesh: every vertex interpolated on its own (clamped outside
/// the keys), then the plane hit tested against the three edge functions — another
/// algorithm than the accelerator's Möller–Trumbore.
fn brute_force_at(m: &MeshDesc, o: Vec3, d: Vec3, time: f32) -> Option<(f32, u32)> {
    let mo = m.motion.as_ref().unwrap();
    let tc = time.clamp(0.0, 1.0);
    let (k, w) = if tc < 0.3 { (0, tc / 0.3) } else { (1, (tc - 0.3) / 0.7) };
    let at = |i: u32| mo.positions[k][i as usize] * (1.0 - w) + mo.positions[k + 1][i as usize] * w;
    let mut best: Option<(f32, u32)> = None;
    for (ti, t) in m.indices.chunks_exact(3).enumerate() {
        let [a, b, c] = [at(t[0]), at(t[1]), at(t[2])];
        let n = (b - a).cross(c - a);
        let dn = d.dot(n);
        if dn == 0.0 {
            continue;
        }
        let s = (a - o).dot(n) / dn;
        if s.is_nan() || s <= 0.0 || best.is_some_and(|(bt, _)| s >= bt) {
            continue;
        }
        let p = o + d * s;
        let inside = [(a, b), (b, c), (c, a)].iter().all(|&(x, y)| (y - x).cross(p - x).dot(n) >= 0.0);
        if inside {
            best = Some((s, ti as u32));
        }
    }
    best
}

#[test]
fn deforming_mesh_agrees_with_brute_force_at_the_ray_time() {
    let mut rng = crate::testing::chi2::TestRng::new(11);
    let m = deforming_soup(&mut rng, 300);
    let a = Accel::build(&[m.clone().into()], &[], &[inst(GeometryRef::Mesh(0), vec![Mat4::IDENTITY], vec![0.0])], (0.0, 1.0));
    assert!(matches!(a.blas[0].as_ref(), Blas::MotionTri(_)));
    let (mut hits, mut moved) = (0, 0);
    for _ in 0..1500 {
        let o = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * 14.0 - 2.0;
        let d = crate::math::sample_uniform_sphere(glam::Vec2::new(rng.next_f32(), rng.next_f32()));
        // times beyond the keys too: the mesh holds its first / last key there
        let time = rng.next_f32() * 1.4 - 0.2;
        let want = brute_force_at(&m, o, d, time);
        let got = a.intersect(&Ray { o, d, t_max: f32::INFINITY, time });
        // the two algorithms round differently; 1e-4 relative is ~100 ulp at these distances
        // and far below the 0.1-unit spacing at which another triangle could be in front
        match (want, got) {
            (None, None) => {}
            (Some((t, ti)), Some(h)) => {
                assert_eq!(h.prim, ti, "ray at time {time}");
                assert!((h.t - t).abs() <= 1e-4 * t.max(1.0), "t {} vs {}", h.t, t);
                hits += 1;
                if brute_force_at(&m, o, d, 0.0).map(|x| x.1) != Some(ti) {
                    moved += 1;
                }
            }
            (w, g) => panic!("brute force {w:?} vs accelerator {g:?} at time {time}"),
        }
    }
    // the test means something only if many rays hit, and many hit what the time-0 pose lacks
    assert!(hits > 150 && moved > 50, "{hits} hits, {moved} differ from the time-0 pose");
}

#[test]
fn a_static_mesh_keeps_the_static_path_and_a_deforming_quad_moves() {
    let a = Accel::build(&[quad().into()], &[], &[inst(GeometryRef::Mesh(0), vec![Mat4::IDENTITY], vec![0.0])], (0.0, 1.0));
    assert!(matches!(a.blas[0].as_ref(), Blas::Tri(_)));
    // the quad slides from x = -5 to x = +5 by its points alone
    let mut m = quad();
    let key = |dx: f32| m.positions.iter().map(|p| *p + Vec3::X * dx).collect::<Vec<_>>();
    let keys = vec![key(-5.0), key(5.0)];
    m.motion = Some(crate::scene::MeshMotion { times: vec![0.0, 1.0], positions: keys, normals: None });
    let both = [inst(GeometryRef::Mesh(0), vec![Mat4::IDENTITY], vec![0.0]), inst(GeometryRef::Spheres(0), vec![Mat4::IDENTITY], vec![0.0])];
    let far = SpheresDesc { name: "s".into(), centers: vec![Vec3::new(0.0, -50.0, 30.0)], radii: vec![0.5], velocities: None, ..Default::default() };
    let a = Accel::build(&[m.into()], &[std::sync::Arc::new(far)], &both, (0.0, 1.0));
    let r = |x: f32, time| Ray { o: Vec3::new(x, 1.0, 0.0), d: -Vec3::Y, t_max: f32::INFINITY, time };
    assert_eq!(a.intersect(&r(0.0, 0.5)).map(|h| h.instance), Some(0));
    assert!(a.intersect(&r(0.0, 0.0)).is_none());
    assert!(a.intersect(&r(-5.0, 0.0)).is_some());
    assert!(a.intersect(&r(-5.0, 1.0)).is_none());
    assert!(a.intersect(&r(5.5, 1.0)).is_some());
    // world bounds hold the whole sweep
    assert!(a.bounds().0.x <= -6.0 && a.bounds().1.x >= 6.0);
}

#[test]
fn a_lone_deforming_triangle_is_found_at_every_time() {
    // one triangle (the tree's root is its leaf) rising from y = 0 to y = 2 over the shutter
    let tri = [Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 1.0)];
    let key = |y: f32| tri.iter().map(|p| *p + Vec3::Y * y).collect::<Vec<_>>();
    let m = MeshDesc {
        name: "lone".into(),
        positions: key(0.0),
        indices: vec![0, 1, 2],
        motion: Some(crate::scene::MeshMotion { times: vec![0.0, 1.0], positions: vec![key(0.0), key(2.0)], normals: None }),
        ..Default::default()
    };
    let a = Accel::build(&[m.into()], &[], &[inst(GeometryRef::Mesh(0), vec![Mat4::IDENTITY], vec![0.0])], (0.0, 1.0));
    assert!(matches!(a.blas[0].as_ref(), Blas::MotionTri(_)));
    for (time, y) in [(0.0, 0.0), (0.25, 0.5), (1.0, 2.0), (7.0, 2.0), (-1.0, 0.0)] {
        let h = a.intersect(&Ray { o: Vec3::new(0.2, 5.0, 0.3), d: -Vec3::Y, t_max: f32::INFINITY, time }).expect("hit");
        assert!((h.t - (5.0 - y)).abs() < 1e-5, "time {time}: t {}", h.t);
        // outside the triangle at that time: a miss
        assert!(a.intersect(&Ray { o: Vec3::new(0.8, 5.0, 0.8), d: -Vec3::Y, t_max: f32::INFINITY, time }).is_none());
    }
}

#[path = "implicit_tests.rs"]
mod implicit_tests;
