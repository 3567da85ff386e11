//! Tests of the water FX primitives: root isolation against polynomials with known roots,
//! bubbles and blobbies against a brute-force march of their implicit functions, analytic
//! cases (an isolated blobby is a sphere of its inner radius, an anisotropic one an ellipsoid),
//! normals against finite differences, and the BVH path against the direct functions.

use super::implicit::*;
use super::*;
use crate::testing::chi2::TestRng;

fn unit(rng: &mut TestRng) -> Vec3 {
    crate::math::sample_uniform_sphere(glam::Vec2::new(rng.next_f32(), rng.next_f32()))
}

#[test]
fn octahedral_normals_round_trip() {
    let mut rng = TestRng::new(1);
    for _ in 0..10_000 {
        let n = unit(&mut rng);
        let (u, v) = oct_encode(n);
        assert!((oct_decode(u, v) - n).length() < 2e-6, "{n:?}");
    }
    for n in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
        let (u, v) = oct_encode(n);
        assert!((oct_decode(u, v) - n).length() < 1e-6, "{n:?}");
    }
}

/// Polynomials built from known roots (degree 1–6): every root inside the interval is found,
/// in order, to 1e-9.
#[test]
fn roots_of_polynomials_with_known_roots() {
    let mut rng = TestRng::new(2);
    for trial in 0..2000 {
        let deg = 1 + trial % 6;
        let mut known: Vec<f64> = (0..deg).map(|_| rng.next_f32() as f64 * 4.0 - 2.0).collect();
        known.sort_by(|a, b| a.total_cmp(b));
        // keep them apart: double roots are not crossings
        if known.windows(2).any(|w| w[1] - w[0] < 1e-3) {
            continue;
        }
        let scale = 0.1 + rng.next_f32() as f64 * 10.0;
        let mut c = vec![scale];
        for &r in &known {
            // multiply by (x − r)
            let mut n = vec![0.0; c.len() + 1];
            for (k, &ck) in c.iter().enumerate() {
                n[k + 1] += ck;
                n[k] -= r * ck;
            }
            c = n;
        }
        let (a, b) = (-1.5, 1.7);
        let (found, n) = roots_in(&c, a, b);
        let expect: Vec<f64> = known.iter().copied().filter(|&r| r >= a && r <= b).collect();
        assert_eq!(n, expect.len(), "roots {known:?}: found {:?}", &found[..n]);
        for (f, e) in found[..n].iter().zip(&expect) {
            assert!((f - e).abs() < 1e-9, "roots {known:?}: found {:?}", &found[..n]);
        }
        match (first_root(&c, a, b), expect.first().copied().filter(|&r| r > a)) {
            (Some(f), Some(e)) => assert!((f - e).abs() < 1e-9),
            (f, e) => assert_eq!(f, e),
        }
    }
}

/// The first sign change of `f` along the ray in (t0, t1], by marching `steps` steps and
/// bisecting the first step that changes sign.
fn march(f: impl Fn(Vec3) -> f32, o: Vec3, d: Vec3, t0: f32, t1: f32, steps: usize) -> Option<f32> {
    let at = |t: f32| f(o + d * t);
    let mut prev = at(t0);
    for k in 1..=steps {
        let t = t0 + (t1 - t0) * k as f32 / steps as f32;
        let v = at(t);
        if (v < 0.0) != (prev < 0.0) {
            let (mut lo, mut hi) = (t - (t1 - t0) / steps as f32, t);
            let f_lo = prev;
            for _ in 0..60 {
                let m = 0.5 * (lo + hi);
                if (at(m) < 0.0) == (f_lo < 0.0) {
                    lo = m
                } else {
                    hi = m
                }
            }
            return Some(0.5 * (lo + hi));
        }
        prev = v;
    }
    None
}

fn bubbles() -> Vec<Bubble> {
    vec![
        Bubble { center: Vec3::ZERO, r: 1.0, top: 0.8, bottom: 0.4, rot: Quat::IDENTITY },
        Bubble { center: Vec3::new(0.3, -0.2, 0.1), r: 0.5, top: 0.5, bottom: 0.25, rot: Quat::from_axis_angle(Vec3::new(1.0, 0.5, 0.2).normalize(), 0.7) },
        Bubble { center: Vec3::ZERO, r: 2.0, top: 0.3, bottom: 1.5, rot: Quat::from_rotation_z(1.2) },
    ]
}

fn bubble_value(b: &Bubble, p: Vec3) -> f32 {
    b.value_local(b.rot.inverse() * (p - b.center))
}

#[test]
fn bubbles_agree_with_a_march_of_their_implicit_function() {
    let mut rng = TestRng::new(3);
    for b in bubbles() {
        let mut hits = 0;
        for _ in 0..3000 {
            // rays from a sphere around the bubble towards points near it
            let o = b.center + unit(&mut rng) * 4.0;
            let target = b.center + unit(&mut rng) * b.bounding_radius() * rng.next_f32();
            let d = (target - o).normalize() * (0.5 + rng.next_f32()); // not unit: t scales
            let t_max = 10.0;
            let got = b.intersect(o, d, 0.0, t_max);
            let want = march(|p| bubble_value(&b, p), o, d, 0.0, t_max, 4000);
            match (got, want) {
                (Some(g), Some(w)) => {
                    hits += 1;
                    assert!((g - w).abs() < 2e-4 * (1.0 + w), "{b:?}: {g} vs march {w}");
                    let p = o + d * g;
                    assert!(bubble_value(&b, p).abs() < 1e-3, "{b:?}: off the surface {}", bubble_value(&b, p));
                    // the normal is the gradient's direction (finite differences)
                    let h = 1e-3;
                    let g_fd = Vec3::new(
                        bubble_value(&b, p + Vec3::X * h) - bubble_value(&b, p - Vec3::X * h),
                        bubble_value(&b, p + Vec3::Y * h) - bubble_value(&b, p - Vec3::Y * h),
                        bubble_value(&b, p + Vec3::Z * h) - bubble_value(&b, p - Vec3::Z * h),
                    )
                    .normalize();
                    assert!((b.normal(p) - g_fd).length() < 2e-2, "{b:?}: normal {:?} vs {g_fd:?}", b.normal(p));
                }
                (None, None) => {}
                // grazing rays may miss by a hair either way
                (g, w) => {
                    let t = g.or(w).unwrap();
                    assert!(bubble_value(&b, o + d * t).abs() < 1e-2, "{b:?}: {g:?} vs march {w:?}");
                }
            }
        }
        assert!(hits > 500, "{hits}");
    }
}

#[test]
fn a_bubble_has_its_heights_and_radius() {
    let b = Bubble { center: Vec3::new(1.0, 2.0, 3.0), r: 0.7, top: 0.5, bottom: 0.2, rot: Quat::IDENTITY };
    let down = b.intersect(b.center + Vec3::Y * 5.0, -Vec3::Y, 0.0, 100.0).unwrap();
    assert!((down - 4.5).abs() < 1e-5, "{down}");
    let up = b.intersect(b.center - Vec3::Y * 5.0, Vec3::Y, 0.0, 100.0).unwrap();
    assert!((up - 4.8).abs() < 1e-5, "{up}");
    let side = b.intersect(b.center + Vec3::X * 5.0, -Vec3::X, 0.0, 100.0).unwrap();
    assert!((side - 4.3).abs() < 1e-5, "{side}");
    // from inside: the exit
    let out = b.intersect(b.center, -Vec3::Y, 0.0, 100.0).unwrap();
    assert!((out - 0.2).abs() < 1e-5, "{out}");
    // the flat bottom: y⁴ makes the lower half wider than an ellipse at the same depth
    let y = -0.1f32;
    let x_quartic = 0.7 * (1.0 - (y / 0.2).powi(4)).sqrt();
    let t = b.intersect(b.center + Vec3::new(5.0, y, 0.0), -Vec3::X, 0.0, 100.0).unwrap();
    assert!((5.0 - t - x_quartic).abs() < 1e-5, "{t}");
    assert!(x_quartic > 0.7 * (1.0 - (y / 0.2).powi(2)).sqrt());
}

fn kernels() -> (Vec<Kernel>, f32) {
    let t = 0.5;
    let k = vec![
        Kernel::new(Vec3::ZERO, 0.5, Vec3::ONE, Quat::IDENTITY, t),
        Kernel::new(Vec3::new(0.9, 0.1, 0.0), 0.4, Vec3::ONE, Quat::IDENTITY, t),
        Kernel::new(Vec3::new(0.4, 0.7, 0.2), 0.3, Vec3::new(2.0, 0.5, 1.0), Quat::from_rotation_z(0.6), t),
        Kernel::new(Vec3::new(-0.8, 0.0, 0.3), 0.35, Vec3::ONE, Quat::IDENTITY, t),
    ];
    (k, t)
}

#[test]
fn an_isolated_blobby_is_a_sphere_of_its_inner_radius() {
    for t in [0.2f32, 0.5, 0.8] {
        let k = [Kernel::new(Vec3::new(1.0, 0.0, 0.0), 0.3, Vec3::ONE, Quat::IDENTITY, t)];
        let (hit, i, n) = blobby_intersect(&k, t, Vec3::new(1.0, 0.0, 5.0), -Vec3::Z, 0.0, 100.0).unwrap();
        assert!((hit - 4.7).abs() < 1e-5, "T {t}: {hit}");
        assert_eq!(i, 0);
        assert!((n - Vec3::Z).length() < 1e-5, "{n:?}");
        // an off-centre ray meets the sphere where a sphere would be met
        let o = Vec3::new(1.0 + 0.2, 0.1, 5.0);
        let (hit, _, _) = blobby_intersect(&k, t, o, -Vec3::Z, 0.0, 100.0).unwrap();
        let sphere = 5.0 - (0.09f32 - 0.04 - 0.01).sqrt();
        assert!((hit - sphere).abs() < 1e-4, "T {t}: {hit} vs {sphere}");
    }
    // anisotropic: semi-axes r·scale along the rotated axes
    let rot = Quat::from_rotation_z(std::f32::consts::FRAC_PI_2); // local X → world Y
    let k = [Kernel::new(Vec3::ZERO, 0.3, Vec3::new(2.0, 1.0, 0.5), rot, 0.5)];
    let along_y = blobby_intersect(&k, 0.5, Vec3::Y * 5.0, -Vec3::Y, 0.0, 100.0).unwrap().0;
    let along_x = blobby_intersect(&k, 0.5, Vec3::X * 5.0, -Vec3::X, 0.0, 100.0).unwrap().0;
    let along_z = blobby_intersect(&k, 0.5, Vec3::Z * 5.0, -Vec3::Z, 0.0, 100.0).unwrap().0;
    assert!((5.0 - along_y - 0.6).abs() < 1e-4 && (5.0 - along_x - 0.3).abs() < 1e-4 && (5.0 - along_z - 0.15).abs() < 1e-4, "{along_x} {along_y} {along_z}");
}

#[test]
fn blobbies_agree_with_a_march_of_their_implicit_function() {
    let (k, t) = kernels();
    let phi = |p: Vec3| blobby_value(&k, t, p);
    let mut rng = TestRng::new(4);
    let mut hits = 0;
    let mut merged = 0;
    for _ in 0..3000 {
        let o = unit(&mut rng) * 4.0;
        let target = unit(&mut rng) * rng.next_f32() * 1.2;
        let d = (target - o).normalize() * (0.5 + rng.next_f32());
        let got = blobby_intersect(&k, t, o, d, 0.0, 20.0);
        let want = march(phi, o, d, 0.0, 20.0, 20_000);
        match (got, want) {
            (Some((g, i, n)), Some(w)) => {
                hits += 1;
                assert!((g - w).abs() < 2e-4 * (1.0 + w), "{g} vs march {w}");
                let p = o + d * g;
                assert!(phi(p).abs() < 1e-4, "off the surface: {}", phi(p));
                let h = 1e-3;
                let g_fd = -Vec3::new(phi(p + Vec3::X * h) - phi(p - Vec3::X * h), phi(p + Vec3::Y * h) - phi(p - Vec3::Y * h), phi(p + Vec3::Z * h) - phi(p - Vec3::Z * h)).normalize();
                assert!((n - g_fd).length() < 1e-2, "normal {n:?} vs {g_fd:?}");
                // the named kernel contributes most at the hit
                assert!(k.iter().all(|q| q.psi(p) <= k[i].psi(p)));
                // where more than one kernel reaches the hit, the surface is a blend
                merged += (k.iter().filter(|q| q.psi(p) > 0.0).count() > 1) as usize;
                // continuing from just inside finds the exit, as from inside water
                let inside = p + d * 1e-3;
                if phi(inside) > 0.0 {
                    let exit = blobby_intersect(&k, t, inside, d, 0.0, 20.0);
                    let want_exit = march(phi, inside, d, 0.0, 20.0, 20_000);
                    match (exit, want_exit) {
                        (Some((e, _, _)), Some(we)) => assert!((e - we).abs() < 2e-4 * (1.0 + we), "exit {e} vs {we}"),
                        (e, we) => panic!("exit {e:?} vs march {we:?}"),
                    }
                }
            }
            (None, None) => {}
            (g, w) => {
                let tt = g.map(|g| g.0).or(w).unwrap();
                assert!(phi(o + d * tt).abs() < 1e-3, "{g:?} vs march {w:?}");
            }
        }
    }
    assert!(hits > 500 && merged > 50, "{hits} hits, {merged} on blends");
}

/// Through the BVH: points sets of bubbles and of blobbies, placed by an instance and moving
/// by velocity, hit where the direct functions say.
#[test]
fn the_bvh_finds_what_the_primitives_say() {
    let (k, threshold) = kernels();
    let centers: Vec<Vec3> = k.iter().map(|k| k.center).collect();
    let blob = SpheresDesc {
        name: "b".into(),
        centers: centers.clone(),
        radii: vec![0.5, 0.4, 0.3, 0.35],
        velocities: Some(vec![Vec3::new(0.5, 0.0, 0.0); 4]),
        shape: PointShape::Blobby {
            threshold,
            orientations: Some(vec![Quat::IDENTITY, Quat::IDENTITY, Quat::from_rotation_z(0.6), Quat::IDENTITY]),
            scales: Some(vec![Vec3::ONE, Vec3::ONE, Vec3::new(2.0, 0.5, 1.0), Vec3::ONE]),
        },
        primvars: Vec::new(),
        ids: Vec::new(),
        origin: Default::default(),
    };
    let bs = bubbles();
    let bub = SpheresDesc {
        name: "u".into(),
        centers: bs.iter().map(|b| b.center + Vec3::X * 30.0).collect(),
        radii: bs.iter().map(|b| b.r).collect(),
        velocities: None,
        shape: PointShape::Bubbles { top: bs.iter().map(|b| b.top).collect(), bottom: bs.iter().map(|b| b.bottom).collect(), orientations: Some(bs.iter().map(|b| b.rot).collect()) },
        primvars: Vec::new(),
        ids: Vec::new(),
        origin: Default::default(),
    };
    let m = Mat4::from_translation(Vec3::new(0.0, 0.0, -3.0));
    let instances = vec![
        InstanceDesc { name: "i".into(), geometry: GeometryRef::Spheres(0), transforms: vec![m], times: vec![0.0], material: 0, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None },
        InstanceDesc { name: "j".into(), geometry: GeometryRef::Spheres(1), transforms: vec![Mat4::IDENTITY], times: vec![0.0], material: 0, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None },
    ];
    let a = Accel::build(&[], &[std::sync::Arc::new(blob), std::sync::Arc::new(bub)], &instances, (0.0, 1.0));
    assert!(a.hit_carries_normal(0) && a.hit_carries_normal(1));
    let mut rng = TestRng::new(5);
    let mut hits = 0;
    for _ in 0..2000 {
        let time = rng.next_f32();
        let o = Vec3::new(0.0, 0.0, -3.0) + unit(&mut rng) * 4.0;
        let target = Vec3::new(0.0, 0.0, -3.0) + unit(&mut rng) * rng.next_f32();
        let d = (target - o).normalize();
        let ray = Ray { o, d, t_max: 9.0, time };
        let moved: Vec<Kernel> = k.iter().map(|q| Kernel { center: q.center + Vec3::new(0.5, 0.0, 0.0) * time, a: q.a }).collect();
        let want = blobby_intersect(&moved, threshold, o - Vec3::new(0.0, 0.0, -3.0), d, 0.0, 9.0);
        match (a.intersect(&ray), want) {
            (Some(h), Some((t, i, n))) => {
                hits += 1;
                assert_eq!(h.instance, 0);
                assert!((h.t - t).abs() < 1e-5 * (1.0 + t), "{} vs {t}", h.t);
                assert_eq!(h.prim as usize, i);
                assert!((oct_decode(h.u, h.v) - n).length() < 1e-5);
            }
            (None, None) => {}
            (h, w) => panic!("{h:?} vs {w:?}"),
        }
        // from inside the water (a kernel's centre): the exit, found by the second gathering
        let inside = centers[(rng.next_f32() * 4.0) as usize % 4] + Vec3::new(0.5, 0.0, 0.0) * time;
        let dir = unit(&mut rng);
        let ray = Ray { o: inside + Vec3::new(0.0, 0.0, -3.0), d: dir, t_max: 9.0, time };
        let want = blobby_intersect(&moved, threshold, inside, dir, 0.0, 9.0).expect("an exit");
        let h = a.intersect(&ray).expect("an exit through the BVH");
        assert!((h.t - want.0).abs() < 1e-5 * (1.0 + want.0), "exit {} vs {}", h.t, want.0);
        // the bubbles
        let o = Vec3::X * 30.0 + unit(&mut rng) * 5.0;
        let d = (Vec3::X * 30.0 + unit(&mut rng) * rng.next_f32() - o).normalize();
        let ray = Ray { o, d, t_max: 50.0, time };
        let want = bs.iter().enumerate().filter_map(|(i, b)| Bubble { center: b.center + Vec3::X * 30.0, ..*b }.intersect(o, d, 0.0, 50.0).map(|t| (t, i))).min_by(|x, y| x.0.total_cmp(&y.0));
        match (a.intersect(&ray), want) {
            (Some(h), Some((t, i))) => {
                assert_eq!((h.instance, h.prim as usize), (1, i));
                assert!((h.t - t).abs() < 1e-6 * (1.0 + t));
            }
            (None, None) => {}
            (h, w) => panic!("bubbles: ray {ray:?}: {h:?} vs {w:?}"),
        }
    }
    assert!(hits > 300, "{hits}");
}

/// Through the BVH over a dense slab of overlapping kernels, where rays from inside pass many
/// more kernels than one segment of the gathering holds on their way to the exit (rays from
/// outside skim the top, through many kernels' outer parts, but meet the surface within a
/// segment: a kernel's inner core is entered about once per five supports): the hits are the
/// sweep's over all kernels at once, and that sweep agrees with a march of φ.
#[test]
fn dense_blobbies_through_the_bvh_agree_with_all_kernels_at_once() {
    let threshold = 0.5;
    let mut rng = TestRng::new(11);
    let n = 6000;
    let mut desc = SpheresDesc { name: "dense".into(), ..Default::default() };
    desc.shape = PointShape::Blobby { threshold, orientations: None, scales: None };
    for _ in 0..n {
        desc.centers.push(Vec3::new(rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 0.3, rng.next_f32() * 2.0 - 1.0));
        desc.radii.push(0.03 + 0.03 * rng.next_f32());
    }
    let kernels: Vec<Kernel> = desc.centers.iter().zip(&desc.radii).map(|(&c, &r)| Kernel::new(c, r, Vec3::ONE, Quat::IDENTITY, threshold)).collect();
    let phi = |p: Vec3| blobby_value(&kernels, threshold, p);
    let inst = vec![InstanceDesc { name: "i".into(), geometry: GeometryRef::Spheres(0), transforms: vec![Mat4::IDENTITY], times: vec![0.0], material: 0, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None }];
    let a = Accel::build(&[], &[std::sync::Arc::new(desc)], &inst, (0.0, 0.0));
    let segment = crate::accel::BLOBBY_SEGMENT;
    let (mut hits_from_outside, mut long_from_inside) = (0, 0);
    for i in 0..600 {
        let from_inside = i % 2 == 1;
        let (o, d) = if from_inside {
            // from inside the slab, at a shallow angle: a long way to the exit
            let o = Vec3::new(rng.next_f32() - 0.5, 0.1 + 0.1 * rng.next_f32(), rng.next_f32() - 0.5);
            let a = rng.next_f32() * std::f32::consts::TAU;
            (o, Vec3::new(a.cos(), 0.2 * (rng.next_f32() - 0.5), a.sin()).normalize())
        } else {
            // from outside, skimming the slab's top through the kernels' outer parts
            let o = Vec3::new(rng.next_f32() - 0.5, 0.32 + 0.08 * rng.next_f32(), -1.2);
            (o, Vec3::new(0.3 * (rng.next_f32() - 0.5), -0.08 * rng.next_f32(), 1.0).normalize())
        };
        if from_inside != (phi(o) > 0.0) {
            continue;
        }
        let want = blobby_intersect(&kernels, threshold, o, d, 0.0, 10.0);
        let got = a.intersect(&Ray { o, d, t_max: 10.0, time: 0.0 });
        match (got, want) {
            (Some(h), Some((t, k, nrm))) => {
                hits_from_outside += !from_inside as usize;
                assert!((h.t - t).abs() < 1e-5 * (1.0 + t), "{} vs {t}", h.t);
                assert_eq!(h.prim as usize, k);
                assert!((oct_decode(h.u, h.v) - nrm).length() < 1e-4);
                // the kernels entered before the hit, against one segment's worth
                let before = kernels.iter().filter_map(|q| q.span(o, d, 0)).filter(|s| s.t0 < t as f64 && s.t1 > 0.0).count();
                long_from_inside += (from_inside && before > 2 * segment) as usize;
                // the sweep over all kernels against a march of φ (over the kernels the ray meets)
                let met: Vec<Kernel> = kernels.iter().filter(|q| q.span(o, d, 0).is_some()).copied().collect();
                let w = march(|p| blobby_value(&met, threshold, p), o, d, 0.0, t + 0.01, 5_000).expect("the march crosses too");
                assert!((w - t).abs() < 1e-4, "march {w} vs {t}");
            }
            (None, None) => {}
            (h, w) => panic!("{o:?} {d:?}: {h:?} vs {w:?}"),
        }
    }
    assert!(hits_from_outside > 200 && long_from_inside > 100, "{hits_from_outside} hits from outside, {long_from_inside} exits past two segments");
}

/// Points simulations repeat positions: a hundred and fifty kernels on one spot (more than a
/// gathering segment holds, all entering together) and a few elsewhere. Through the BVH the
/// sweep moves on past the tie and finds what the sweep over all kernels finds, from outside
/// and from inside.
#[test]
fn coincident_blobbies_more_than_a_segment_are_swept_past() {
    let threshold = 0.5;
    let mut desc = SpheresDesc { name: "dup".into(), ..Default::default() };
    desc.shape = PointShape::Blobby { threshold, orientations: None, scales: None };
    for i in 0..160 {
        desc.centers.push(if i < 150 { Vec3::ZERO } else { Vec3::new(0.3 * (i - 150) as f32, 0.1, 0.0) });
        desc.radii.push(if i < 150 { 0.02 } else { 0.1 });
    }
    let kernels: Vec<Kernel> = desc.centers.iter().zip(&desc.radii).map(|(&c, &r)| Kernel::new(c, r, Vec3::ONE, Quat::IDENTITY, threshold)).collect();
    let inst = vec![InstanceDesc { name: "i".into(), geometry: GeometryRef::Spheres(0), transforms: vec![Mat4::IDENTITY], times: vec![0.0], material: 0, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None }];
    let a = Accel::build(&[], &[std::sync::Arc::new(desc)], &inst, (0.0, 0.0));
    assert!(150 > crate::accel::BLOBBY_SEGMENT);
    let mut rng = TestRng::new(21);
    let mut hits = 0;
    for i in 0..400 {
        let (o, d) = if i % 2 == 0 {
            let o = unit(&mut rng) * 3.0;
            (o, (Vec3::new(rng.next_f32() * 3.0 - 0.3, 0.0, 0.0) + unit(&mut rng) * 0.15 * rng.next_f32() - o).normalize())
        } else {
            (unit(&mut rng) * 0.01, unit(&mut rng))
        };
        let want = blobby_intersect(&kernels, threshold, o, d, 0.0, 10.0);
        match (a.intersect(&Ray { o, d, t_max: 10.0, time: 0.0 }), want) {
            (Some(h), Some((t, k, _))) => {
                hits += 1;
                assert!((h.t - t).abs() < 1e-6 * (1.0 + t), "{} vs {t}", h.t);
                assert_eq!(h.prim as usize, k);
            }
            (None, None) => {}
            (h, w) => panic!("{o:?} {d:?}: {h:?} vs {w:?}"),
        }
    }
    assert!(hits > 250, "{hits}");
}
