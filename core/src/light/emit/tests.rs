//! Tests of emission sampling: χ² of directions (on the sphere) and of origins (on each
//! light's surface, by a planar χ² over its parameter square) against `pdf_le`, the densities'
//! integrals, photon power against analytic emitted power, a distant light's irradiance from
//! splatted photons, and agreement with `l`, `le`, `intersect` and `sample_li`.

use super::super::{latlong_direction, Light, LightSampleContext};
use super::*;
use crate::scene::{ColorSpace, LightShape, TextureDesc, Wrap};
use crate::testing::chi2::{chi2_sphere, gamma_q, Chi2Config, TestRng};
use glam::{Mat4, Quat, Vec2, Vec3};

/// χ² runs in this file (directions and positions), for the Šidák correction.
const N_CHI2: usize = 27;
const ALPHA: f64 = 0.01;

use crate::light::tests::{build, desc, lambda, tilt};

fn u2(rng: &mut TestRng) -> Vec2 {
    Vec2::new(rng.next_f32(), rng.next_f32())
}

fn scene_disk() -> EmissionDisk {
    EmissionDisk::new(Vec3::new(0.5, -1.0, 2.0), 4.0).unwrap()
}

fn sphere() -> Light {
    build(&desc(LightShape::Sphere { radius: 0.7, treat_as_point: false }, tilt()))
}
fn rect() -> Light {
    build(&desc(LightShape::Rect { width: 2.0, height: 0.5, texture: None }, tilt() * Mat4::from_scale(Vec3::new(1.5, 1.0, 1.0))))
}
fn sheared_rect() -> Light {
    let shear = Mat4::from_cols_array(&[1.0, 0.0, 0.0, 0.0, 0.6, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0]);
    build(&desc(LightShape::Rect { width: 1.0, height: 1.2, texture: None }, tilt() * shear))
}
fn ellipse() -> Light {
    build(&desc(LightShape::Disk { radius: 0.8 }, tilt() * Mat4::from_scale(Vec3::new(2.0, 0.7, 1.0))))
}
fn cylinder() -> Light {
    build(&desc(LightShape::Cylinder { radius: 0.3, length: 2.5, treat_as_line: false }, tilt()))
}
fn triangle(two_sided: bool) -> Light {
    let white = uplift::illuminant([1.0; 3], ColorSpace::LinearRec709);
    Light::triangle([Vec3::new(0.1, 0.2, 0.3), Vec3::new(2.0, -0.5, 0.7), Vec3::new(0.4, 1.5, -0.6)], white, two_sided).unwrap()
}
fn point() -> Light {
    Light::point(Vec3::new(1.0, 2.0, -1.0), uplift::illuminant([0.2, 0.5, 1.0], ColorSpace::LinearRec709), 3.0)
}
fn distant(angle_deg: f32, intensity: f32) -> Light {
    let mut d = desc(LightShape::Distant { angle_deg }, tilt());
    d.intensity = intensity;
    d.normalize = true;
    let mut l = build(&d);
    l.preprocess(scene_disk().center(), scene_disk().radius());
    l
}
fn dome(textured: bool) -> Light {
    let (tex, shape) = if textured { (vec![hot_spot_texture()], LightShape::Dome { texture: Some(0) }) } else { (vec![], LightShape::Dome { texture: None }) };
    let mut d = desc(shape, tilt());
    d.intensity = 0.8;
    let mut l = Light::from_desc(&d, &tex, ColorSpace::LinearRec709).unwrap();
    l.preprocess(scene_disk().center(), scene_disk().radius());
    l
}

/// A Hošek–Wilkie sky under a tilted frame, the sun 35° above its horizon.
fn sky() -> Light {
    let rot = Quat::from_euler(glam::EulerRot::XYZ, 0.4, -0.7, 0.2);
    let sun = rot * Vec3::new(0.3, 35f32.to_radians().sin(), 0.77).normalize();
    let sun = (sun - rot * Vec3::Y * (rot * Vec3::Y).dot(sun)).normalize() * 35f32.to_radians().cos() + rot * Vec3::Y * 35f32.to_radians().sin();
    let mut d = desc(LightShape::Sky { turbidity: 3.0, ground_albedo: [0.3; 3], sun_direction: sun, scale: 1.0 }, tilt());
    d.intensity = 2.0;
    build(&d)
}

fn hot_spot_texture() -> TextureDesc {
    let (w, h) = (32usize, 16usize);
    let mut pixels = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let v = if (20..22).contains(&x) && (4..6).contains(&y) {
                [60.0, 40.0, 20.0]
            } else if (10..14).contains(&y) && (5..10).contains(&x) {
                [0.0; 3]
            } else {
                [0.5 + 0.3 * ((x as f32) * 0.3).sin(), 0.4, 0.3 + 0.02 * y as f32]
            };
            pixels.extend_from_slice(&v);
        }
    }
    TextureDesc { name: "hot".into(), width: w as u32, height: h as u32, channels: 3, pixels: pixels.into(), wrap_s: Wrap::Repeat, wrap_t: Wrap::Clamp, filter: crate::scene::Filter::Linear }
}

// ---------------------------------------------------------------------------------------------
// directions

fn dir_cfg(seed: u64, quad_res: usize) -> Chi2Config {
    Chi2Config { theta_res: 16, phi_res: 32, samples: 100_000, quad_res, min_expected: 5.0, seed }
}

/// χ² of `sample_le`'s directions against `pdf_le`'s `pdf_dir` (512 cells, 100k samples,
/// `quad`² quadrature points per cell). `u_pos`: the origin is held fixed (area lights: the
/// direction density depends on it), or drawn anew (infinite lights). Returns the pdf's integral.
fn check_directions(name: &str, light: &Light, u_pos: Option<Vec2>, quad: usize, seed: u64) -> f64 {
    let disk = scene_disk();
    let lam = lambda();
    let mut rng0 = TestRng::new(seed);
    let reference = std::iter::repeat_with(|| light.sample_le(u_pos.unwrap_or(Vec2::splat(0.5)), u2(&mut rng0), &lam, 0.0, &disk)).flatten().next().unwrap();
    let (o, n) = if light.is_infinite() { (disk.center(), Vec3::ZERO) } else { (reference.ray_o, reference.n_light) };
    let r = chi2_sphere(
        dir_cfg(seed, quad),
        |rng| {
            let up = u_pos.unwrap_or_else(|| u2(rng));
            let s = light.sample_le(up, u2(rng), &lam, 0.0, &disk)?;
            if u_pos.is_some() {
                assert!((s.ray_o - o).length() < 1e-6, "{name}: origin moved with u_dir");
            }
            Some(s.ray_d)
        },
        |d| light.pdf_le(o, d, n, &disk).1,
    );
    assert!(r.passed(ALPHA, N_CHI2), "{name}: {r:?}");
    r.pdf_integral
}

/// Cosine lobes about each area light's normal.
fn check_area_directions(name: &str, l: &Light, seed: u64) {
    // cos/π vanishes continuously at the horizon: 24² midpoint points per cell integrate it
    // to ~1e-4, far below the χ² noise of cells holding a few hundred samples
    let integral = check_directions(name, l, Some(Vec2::new(0.3, 0.8)), 24, seed);
    assert!((integral - 1.0).abs() < 1e-3, "{name}: ∫pdf_dir = {integral}");
}

/// Uniform sphere, cones and dome distributions, whose densities jump at rims and texel
/// edges: 128² points per cell keep the cut cells' expected counts well inside the χ² noise.
fn check_infinite_directions(name: &str, l: &Light, seed: u64) {
    let integral = check_directions(name, l, None, 128, seed);
    assert!((integral - 1.0).abs() < 2e-3, "{name}: ∫pdf_dir = {integral}");
}

#[test]
fn sphere_directions_match_pdf_le() {
    check_area_directions("sphere", &sphere(), 11);
}
#[test]
fn rect_and_disk_directions_match_pdf_le() {
    check_area_directions("rect", &rect(), 12);
    check_area_directions("ellipse", &ellipse(), 13);
}
#[test]
fn cylinder_directions_match_pdf_le() {
    check_area_directions("cylinder", &cylinder(), 14);
}
#[test]
fn triangle_directions_match_pdf_le() {
    check_area_directions("triangle", &triangle(false), 15);
    check_area_directions("two-sided triangle", &triangle(true), 16);
}
#[test]
fn point_directions_match_pdf_le() {
    check_infinite_directions("point", &point(), 21);
}
#[test]
fn distant_cone_directions_match_pdf_le() {
    check_infinite_directions("distant 20°", &distant(40.0, 1.0), 22);
}
#[test]
fn wide_distant_cone_directions_match_pdf_le() {
    check_infinite_directions("distant 70°", &distant(140.0, 1.0), 23);
}
#[test]
fn dome_directions_match_pdf_le() {
    check_infinite_directions("dome", &dome(false), 24);
}
#[test]
fn sky_directions_match_pdf_le() {
    check_infinite_directions("sky", &sky(), 26);
}
#[test]
fn textured_dome_directions_match_pdf_le() {
    check_infinite_directions("textured dome", &dome(true), 25);
}

// ---------------------------------------------------------------------------------------------
// positions: a planar χ² over each light's parameter square

struct PlaneChi2 {
    p_value: f64,
    integral: f64,
    outside: usize,
}

/// χ² of points mapped into [0,1)² (by `sample`) against a density on the unit square, on a
/// `res` × `res` grid with `quad`² midpoint quadrature points per cell; cells expecting fewer
/// than 5 samples are pooled. Samples outside the square or where the density is 0 are counted
/// in `outside`, and samples in a cell of zero expectation make the p-value 0.
fn chi2_plane(res: usize, samples: usize, seed: u64, quad: usize, mut sample: impl FnMut(&mut TestRng) -> Option<Vec2>, density: impl Fn(Vec2) -> f64) -> PlaneChi2 {
    let mut observed = vec![0f64; res * res];
    let mut rng = TestRng::new(seed);
    let mut outside = 0;
    for _ in 0..samples {
        let Some(q) = sample(&mut rng) else { continue };
        if !(q.x >= 0.0 && q.x <= 1.0 && q.y >= 0.0 && q.y <= 1.0 && density(q) > 0.0) {
            outside += 1;
            continue;
        }
        let i = ((q.x * res as f32) as usize).min(res - 1);
        let j = ((q.y * res as f32) as usize).min(res - 1);
        observed[j * res + i] += 1.0;
    }
    let mut expected = vec![0f64; res * res];
    let mut integral = 0.0;
    let h = 1.0 / res as f64;
    for j in 0..res {
        for i in 0..res {
            let mut acc = 0.0;
            for b in 0..quad {
                for a in 0..quad {
                    let x = (i as f64 + (a as f64 + 0.5) / quad as f64) * h;
                    let y = (j as f64 + (b as f64 + 0.5) / quad as f64) * h;
                    acc += density(Vec2::new(x as f32, y as f32));
                }
            }
            let e = acc * h * h / (quad * quad) as f64;
            integral += e;
            expected[j * res + i] = e * samples as f64;
        }
    }
    let mut order: Vec<usize> = (0..res * res).collect();
    order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));
    let (mut stat, mut dof, mut pe, mut po) = (0.0, 0usize, 0.0, 0.0);
    for &c in &order {
        if expected[c] == 0.0 {
            if observed[c] > 0.0 {
                stat = f64::INFINITY;
            }
            continue;
        }
        pe += expected[c];
        po += observed[c];
        if pe >= 5.0 {
            stat += (po - pe) * (po - pe) / pe;
            dof += 1;
            pe = 0.0;
            po = 0.0;
        }
    }
    if pe > 0.0 {
        stat += (po - pe) * (po - pe) / pe;
        dof += 1;
    }
    let dof = dof.saturating_sub(1).max(1);
    let p_value = if stat.is_finite() { gamma_q(dof as f64 / 2.0, stat / 2.0) } else { 0.0 };
    PlaneChi2 { p_value, integral, outside }
}

/// Polar coordinates of a point of the unit disk, (φ/2π, ρ²): uniform density there is uniform
/// on the square, and the square maps onto the whole disk.
fn polar(q: Vec2) -> Vec2 {
    let phi = q.y.atan2(q.x);
    Vec2::new((phi / (2.0 * PI)).rem_euclid(1.0), q.length_squared())
}

fn unpolar(s: Vec2) -> Vec2 {
    let (sp, cp) = (2.0 * PI * s.x).sin_cos();
    Vec2::new(cp, sp) * s.y.sqrt()
}

/// A light's surface as a map from the unit square: (point, normal, area Jacobian) at `s`,
/// and the inverse map of a point.
type SurfaceMap<'a> = Box<dyn Fn(Vec2) -> Option<(Vec3, Vec3, f64)> + 'a>;

struct Param<'a> {
    to_surface: SurfaceMap<'a>,
    to_square: Box<dyn Fn(Vec3) -> Vec2 + 'a>,
}

fn param(light: &Light) -> Param<'_> {
    match light {
        Light::Rect(r) => {
            let s = &r.shape;
            Param { to_surface: Box::new(move |u| Some((s.origin + s.a * u.x + s.b * u.y, s.n, s.area as f64))), to_square: Box::new(move |p| Vec2::new(s.da.dot(p - s.origin), s.db.dot(p - s.origin))) }
        }
        Light::Disk(d) => {
            let s = &d.shape;
            Param {
                to_surface: Box::new(move |u| {
                    let q = unpolar(u);
                    Some((s.origin + s.a * q.x + s.b * q.y, s.n, s.area as f64))
                }),
                to_square: Box::new(move |p| polar(Vec2::new(s.da.dot(p - s.origin), s.db.dot(p - s.origin)))),
            }
        }
        Light::Sphere(sp) => Param {
            to_surface: Box::new(move |u| {
                let z = 1.0 - 2.0 * u.y;
                let r = (1.0 - z * z).max(0.0).sqrt();
                let (s, c) = (2.0 * PI * u.x).sin_cos();
                let n = Vec3::new(r * c, r * s, z);
                Some((sp.center + n * sp.radius, n, (4.0 * PI * sp.radius * sp.radius) as f64))
            }),
            to_square: Box::new(move |p| {
                let n = (p - sp.center) / sp.radius;
                Vec2::new((n.y.atan2(n.x) / (2.0 * PI)).rem_euclid(1.0), (1.0 - n.z) * 0.5)
            }),
        },
        Light::Cylinder(c) => Param {
            to_surface: Box::new(move |u| {
                let (s, co) = (2.0 * PI * u.y).sin_cos();
                let n = c.frame.to_world(Vec3::new(co, s, 0.0));
                Some((c.center + c.frame.n * ((2.0 * u.x - 1.0) * c.half_length) + n * c.radius, n, c.area as f64))
            }),
            to_square: Box::new(move |p| {
                let q = c.frame.to_local(p - c.center);
                Vec2::new((q.z / c.half_length + 1.0) * 0.5, (q.y.atan2(q.x) / (2.0 * PI)).rem_euclid(1.0))
            }),
        },
        Light::Triangle(t) => {
            let (e1, e2) = (t.p[1] - t.p[0], t.p[2] - t.p[0]);
            let c = e1.cross(e2);
            let (d1, d2) = (e2.cross(c) / c.length_squared(), c.cross(e1) / c.length_squared());
            Param {
                // the barycentric half of the square; quadrature points on its diagonal count
                // half, which makes the midpoint rule exact on the cut cells
                to_surface: Box::new(move |u| {
                    let s = u.x + u.y;
                    let w = if s > 1.0 + 1e-5 { return None } else if s > 1.0 - 1e-5 { 0.5 } else { 1.0 };
                    Some((t.p[0] + e1 * u.x + e2 * u.y, t.n, 2.0 * w * t.area as f64))
                }),
                to_square: Box::new(move |p| Vec2::new(d1.dot(p - t.p[0]), d2.dot(p - t.p[0]))),
            }
        }
        _ => unreachable!("not an area light"),
    }
}

fn plane_cfg_check(name: &str, r: &PlaneChi2, integral_tol: f64) {
    assert!(r.outside == 0, "{name}: {} samples outside the support", r.outside);
    let a = 1.0 - (1.0 - ALPHA).powf(1.0 / N_CHI2 as f64);
    assert!(r.p_value > a, "{name}: p = {}", r.p_value);
    assert!((r.integral - 1.0).abs() < integral_tol, "{name}: ∫pdf_pos dA = {}", r.integral);
}

#[test]
fn area_light_origins_match_pdf_le() {
    let disk = scene_disk();
    let lam = lambda();
    for (name, l) in [("sphere", sphere()), ("rect", sheared_rect()), ("ellipse", ellipse()), ("cylinder", cylinder()), ("triangle", triangle(true))] {
        let pm = param(&l);
        let r = chi2_plane(
            16,
            50_000,
            31,
            8,
            |rng| {
                let s = l.sample_le(u2(rng), u2(rng), &lam, 0.0, &disk)?;
                Some((pm.to_square)(s.ray_o))
            },
            |u| match (pm.to_surface)(u) {
                Some((p, n, jac)) => l.pdf_le(p, n, n, &disk).0 as f64 * jac,
                None => 0.0,
            },
        );
        // the densities are constant on the square (the triangle's on its lower half, whose
        // diagonal cells the quadrature above halves exactly): the integral is exact to rounding
        plane_cfg_check(name, &r, 1e-4);
    }
}

#[test]
fn infinite_light_origins_match_pdf_le() {
    let disk = scene_disk();
    let lam = lambda();
    for (name, l) in [("sun 0.53°", distant(0.53, 1.0)), ("distant 20°", distant(40.0, 1.0)), ("delta distant", distant(0.0, 1.0)), ("distant 70°", distant(140.0, 1.0)), ("dome", dome(true)), ("sky", sky())] {
        // the disk each sample starts on, in its own frame: (centre, frame, radius)
        let disk_of = |s: &LeSample| -> (Vec3, Frame, f32) {
            match &l {
                Light::Distant(dl) => match dl.disk_kind(&disk) {
                    DistantDisk::Fixed(r) => (disk.center() + dl.to_light * disk.radius(), dl.frame, r),
                    DistantDisk::PerRay => (disk.center() - s.ray_d * disk.radius(), Frame::from_normal(-s.ray_d), disk.radius()),
                },
                _ => (disk.center() - s.ray_d * disk.radius(), Frame::from_normal(-s.ray_d), disk.radius()),
            }
        };
        // the density test needs one frame: the fixed disk, or the disk of one direction with
        // the positions of every sample expressed in its own disk's frame
        let mut rng0 = TestRng::new(5);
        let reference = std::iter::repeat_with(|| l.sample_le(u2(&mut rng0), u2(&mut rng0), &lam, 0.0, &disk)).flatten().next().unwrap();
        let (c0, f0, r0) = disk_of(&reference);
        let r = chi2_plane(
            16,
            50_000,
            37,
            8,
            |rng| {
                let s = l.sample_le(u2(rng), u2(rng), &lam, 0.0, &disk)?;
                let (c, f, r) = disk_of(&s);
                let q = f.to_local(s.ray_o - c);
                assert!(q.z.abs() < 1e-4 * r, "{name}: origin off its disk's plane by {}", q.z);
                Some(polar(Vec2::new(q.x, q.y) / r))
            },
            |u| {
                let q = unpolar(u) * r0;
                let p = c0 + f0.s * q.x + f0.t * q.y;
                l.pdf_le(p, reference.ray_d, Vec3::ZERO, &disk).0 as f64 * (PI * r0 * r0) as f64
            },
        );
        plane_cfg_check(name, &r, 1e-4);
        // a line that misses the disk has no density
        let far = c0 + f0.s * (1.01 * r0 * (1.0 + 2.0 * DISK_EPS));
        assert_eq!(l.pdf_le(far, reference.ray_d, Vec3::ZERO, &disk).0, 0.0, "{name}: density outside the disk");
    }
}

// ---------------------------------------------------------------------------------------------
// power

/// Mean and standard error, per wavelength, of the photon power over `n` samples.
fn photon_power(l: &Light, disk: &EmissionDisk, n: usize, seed: u64) -> ([f64; 4], [f64; 4]) {
    let lam = lambda();
    let mut rng = TestRng::new(seed);
    let (mut s1, mut s2) = ([0f64; 4], [0f64; 4]);
    for _ in 0..n {
        if let Some(s) = l.sample_le(u2(&mut rng), u2(&mut rng), &lam, 0.0, disk) {
            let p = s.power();
            for k in 0..4 {
                s1[k] += p.0[k] as f64;
                s2[k] += (p.0[k] as f64).powi(2);
            }
        }
    }
    let mean = s1.map(|v| v / n as f64);
    let se = std::array::from_fn(|k| ((s2[k] / n as f64 - mean[k] * mean[k]).max(0.0) / n as f64).sqrt());
    (mean, se)
}

/// |estimate − truth| ≤ 3σ + 1e-4·truth per wavelength: 3σ is the statistical bound; area
/// lights' estimators are constant (cosine sampling cancels the cosine), σ ≈ 0, and 1e-4
/// covers the f32 rounding of cos/pdf in each sample.
fn assert_power(name: &str, (mean, se): ([f64; 4], [f64; 4]), truth: SampledSpectrum) {
    for k in 0..4 {
        let t = truth.0[k] as f64;
        assert!((mean[k] - t).abs() <= 3.0 * se[k] + 1e-4 * t.abs(), "{name} λ{k}: {} ± {} vs {t}", mean[k], se[k]);
    }
}

#[test]
fn photon_power_matches_the_analytic_emitted_power() {
    let disk = scene_disk();
    let lam = lambda();
    let rad = |l: &Light| l.emission().sample(&lam);
    let (r_sun, big_r) = (0.5 * 0.53f32.to_radians(), disk.radius());
    let cases: Vec<(&str, Light, f32)> = vec![
        // sphere: each point emits π L per unit area (one-sided Lambertian) over 4πr²
        ("sphere", sphere(), 4.0 * PI * PI * 0.7 * 0.7),
        // rect 2 × 0.5 stretched 1.5× in X: π L w h
        ("rect", rect(), PI * 3.0 * 0.5),
        // ellipse of semi-axes 1.6 and 0.56: π L · π a b
        ("ellipse", ellipse(), PI * PI * 1.6 * 0.56),
        // open cylinder side: π L · 2π r l
        ("cylinder", cylinder(), PI * 2.0 * PI * 0.3 * 2.5),
        ("triangle", triangle(false), PI * 0.5 * (Vec3::new(1.9, -0.7, 0.4).cross(Vec3::new(0.3, 1.3, -0.9))).length()),
        // two-sided: both faces, 2π L A
        ("two-sided triangle", triangle(true), 2.0 * PI * 0.5 * (Vec3::new(1.9, -0.7, 0.4).cross(Vec3::new(0.3, 1.3, -0.9))).length()),
        // isotropic intensity I over 4π sr
        ("point", point(), 4.0 * PI),
        // delta sun: irradiance E through the disk πR²
        ("delta distant", distant(0.0, 2.0), PI * big_r * big_r),
        // sun disk: ∫cone L cos dω = π L sin²θ through the enlarged disk R(1 + sin θ)/cos θ
        ("sun", distant(0.53, 2.0), PI * r_sun.sin().powi(2) * PI * (big_r * (1.0 + r_sun.sin()) / r_sun.cos()).powi(2)),
        // 70° cone, per-ray disks: L Ω πR² with Ω = 2π(1 − cos 70°)
        ("distant 70°", distant(140.0, 2.0), 2.0 * PI * (1.0 - 70f32.to_radians().cos()) * PI * big_r * big_r),
        // constant dome: L · 4π · πR²
        ("dome", dome(false), 4.0 * PI * PI * big_r * big_r),
    ];
    for (i, (name, l, factor)) in cases.into_iter().enumerate() {
        let truth = rad(&l) * factor;
        assert_power(name, photon_power(&l, &disk, 100_000, 50 + i as u64), truth);
        // phi is the same number, exactly up to f32 rounding of its formula
        let phi = l.phi(&lam, &disk);
        for k in 0..4 {
            assert!((phi.0[k] - truth.0[k]).abs() <= 1e-5 * truth.0[k].abs(), "{name}: phi {phi:?} vs {truth:?}");
        }
    }
}

#[test]
fn sky_photon_power_matches_quadrature_of_le() {
    let disk = scene_disk();
    let lam = lambda();
    let l = sky();
    let Light::Sky(d) = &l else { unreachable!() };
    // πR² ∫ le dω by an independent midpoint quadrature in (θ, φ) about the sky's zenith
    let zenith = (tilt().transform_vector3(Vec3::Y)).normalize();
    let f = Frame::from_normal(zenith);
    let (nt, np) = (600usize, 1200usize);
    let mut q = [0.0f64; 4];
    for it in 0..nt {
        let th = (it as f64 + 0.5) / nt as f64 * std::f64::consts::FRAC_PI_2;
        let w = th.sin() * std::f64::consts::FRAC_PI_2 / nt as f64 * 2.0 * std::f64::consts::PI / np as f64;
        for ip in 0..np {
            let ph = (ip as f64 + 0.5) / np as f64 * 2.0 * std::f64::consts::PI;
            let dir = f.to_world(Vec3::new((th.sin() * ph.cos()) as f32, (th.sin() * ph.sin()) as f32, th.cos() as f32));
            for (acc, v) in q.iter_mut().zip(l.le(dir, &lam).0) {
                *acc += v as f64 * w;
            }
        }
    }
    let r2 = (PI * disk.radius() * disk.radius()) as f64;
    let truth = SampledSpectrum(q.map(|v| (v * r2) as f32));
    // photons: 3σ of 100k samples (importance-sampled by luminance, so σ is small)
    let (mean, se) = photon_power(&l, &disk, 100_000, 61);
    let phi = l.phi(&lam, &disk);
    for k in 0..4 {
        let t = truth.0[k] as f64;
        // the two quadratures (this 600×1200 one in θ and the light's 512×1024 one in cos θ)
        // differ by their discretisation of the circumsolar peak and the horizon: 2e-3
        assert!((phi.0[k] as f64 - t).abs() <= 2e-3 * t, "sky λ{k}: phi {} vs quadrature {t}", phi.0[k]);
        assert!((mean[k] - t).abs() <= 3.0 * se[k] + 2e-3 * t, "sky λ{k}: photons {} ± {} vs {t}", mean[k], se[k]);
    }
    // phi_y and the selection power agree (same mean luminance, same disk)
    let mut m = l.clone();
    m.preprocess(disk.center(), disk.radius());
    assert!((m.power() - l.phi_y(&disk)).abs() <= 1e-5 * m.power(), "power {} vs phi_y {}", m.power(), l.phi_y(&disk));
    assert!(d.emission.luminance > 0.0);
}

#[test]
fn textured_dome_photon_power_matches_quadrature_of_le() {
    let disk = scene_disk();
    let lam = lambda();
    let l = dome(true);
    let Light::Dome(d) = &l else { unreachable!() };
    // ∫ le dω by texels: radiance is constant on each (nearest lookup), so le at the centre
    // times the texel's exact solid angle is exact
    let (w, h) = (32usize, 16usize);
    let mut acc = [0f64; 4];
    for y in 0..h {
        let omega = 2.0 * std::f64::consts::PI / w as f64 * ((PI as f64 * y as f64 / h as f64).cos() - (PI as f64 * (y + 1) as f64 / h as f64).cos());
        for x in 0..w {
            let dir = d.rot * latlong_direction((x as f32 + 0.5) / w as f32, (y as f32 + 0.5) / h as f32);
            let v = l.le(dir, &lam);
            for (a, s) in acc.iter_mut().zip(v.0) {
                *a += s as f64 * omega;
            }
        }
    }
    let r = disk.radius() as f64;
    let truth = SampledSpectrum(acc.map(|a| (a * std::f64::consts::PI * r * r) as f32));
    // 400k: the hot spot makes the photon powers vary by ~10× across the dome
    assert_power("textured dome", photon_power(&l, &disk, 400_000, 61), truth);
    let phi = l.phi(&lam, &disk);
    for k in 0..4 {
        // f32 sums over 512 texels
        assert!((phi.0[k] - truth.0[k]).abs() <= 1e-4 * truth.0[k], "phi {phi:?} vs {truth:?}");
    }
}

/// Lights with UsdLuxShapingAPI: a soft 50° cone with a tinted focus (the cylinder's cone is
/// wider, about an axis across its length).
fn shaped() -> Vec<(&'static str, Light)> {
    let sd = crate::scene::ShapingDesc { cone_angle_deg: 50.0, cone_softness: 0.4, focus: 3.0, focus_tint: [0.8, 0.3, 0.1], ..Default::default() };
    let mk = |shape: LightShape, sd: &crate::scene::ShapingDesc| {
        let mut d = desc(shape, tilt());
        d.shaping = Some(sd.clone());
        build(&d)
    };
    vec![
        ("shaped sphere", mk(LightShape::Sphere { radius: 0.7, treat_as_point: false }, &sd)),
        ("shaped point", mk(LightShape::Sphere { radius: 0.7, treat_as_point: true }, &sd)),
        ("shaped rect", mk(LightShape::Rect { width: 2.0, height: 0.5, texture: None }, &sd)),
        ("shaped disk", mk(LightShape::Disk { radius: 0.8 }, &sd)),
        ("shaped cylinder", mk(LightShape::Cylinder { radius: 0.3, length: 2.5, treat_as_line: false }, &crate::scene::ShapingDesc { cone_angle_deg: 100.0, ..sd.clone() })),
    ]
}

#[test]
fn narrow_cones_draw_directions_within_the_cone() {
    // the 50° cones of the sphere, point, rect and disk: uniform in the cone, against pdf_le
    // (a sphere origin's far side gives no ray: the pdf integrates to the rays given)
    for (i, (name, l)) in shaped().into_iter().enumerate().filter(|(_, (n, _))| *n != "shaped cylinder") {
        let integral = check_directions(name, &l, Some(Vec2::new(0.3, 0.8)), 128, 700 + i as u64);
        assert!(integral > 0.0 && integral <= 1.0 + 2e-3, "{name}: ∫pdf_dir = {integral}");
    }
    // a 10° spot: almost every photon carries light (drawn unshaped, sin²10° = 3% of a rect's
    // and (1 − cos 10°)/2 = 0.8% of a point's would)
    let sd = crate::scene::ShapingDesc { cone_angle_deg: 10.0, ..Default::default() };
    let disk = scene_disk();
    let lam = lambda();
    for shape in [LightShape::Rect { width: 2.0, height: 0.5, texture: None }, LightShape::Sphere { radius: 0.7, treat_as_point: true }] {
        let mut d = desc(shape, tilt());
        d.shaping = Some(sd.clone());
        let l = build(&d);
        let mut rng = TestRng::new(77);
        let lit = (0..10_000).filter(|_| l.sample_le(u2(&mut rng), u2(&mut rng), &lam, 0.0, &disk).is_some_and(|s| !s.l.is_black())).count();
        assert!(lit > 9_900, "{lit} of 10000 photons carry light");
    }
}

#[test]
fn shaped_and_textured_photon_power_matches_phi() {
    // photons drawn unshaped and weighted by the factor along their direction (Monte Carlo)
    // against phi's quadrature of the shaping, per wavelength (the tint is spectral)
    let disk = scene_disk();
    let lam = lambda();
    for (i, (name, l)) in shaped().into_iter().chain([("textured rect", crate::light::tests::textured_rect(tilt()))]).enumerate() {
        let truth = l.phi(&lam, &disk);
        let (mean, se) = photon_power(&l, &disk, 200_000, 400 + i as u64);
        for k in 0..4 {
            let t = truth.0[k] as f64;
            assert!((mean[k] - t).abs() <= 4.0 * se[k] + 1e-4 * t, "{name} λ{k}: {} ± {} vs phi {t}", mean[k], se[k]);
        }
        // well below the unshaped light's power: the comparison is not vacuous
        if l.shaping().is_some() {
            let unshaped = l.emission().sample(&lam).0[0] * l.phi_factor(&disk);
            assert!(truth.0[0] < 0.5 * unshaped, "{name}: {} vs unshaped {unshaped}", truth.0[0]);
        }
    }
}

#[test]
fn phi_y_is_the_selection_power_of_finite_lights() {
    let disk = scene_disk();
    for (name, l) in [("sphere", sphere()), ("rect", rect()), ("ellipse", ellipse()), ("cylinder", cylinder()), ("triangle", triangle(false)), ("two-sided", triangle(true)), ("point", point()), ("delta distant", distant(0.0, 2.0)), ("dome", dome(false))] {
        // infinite ones here: scene radius = disk radius, and no cone to enlarge the disk
        let (a, b) = (l.phi_y(&disk), l.power());
        assert!((a - b).abs() <= 1e-5 * b, "{name}: phi_y {a} vs power {b}");
    }
    // a textured dome's power takes texel solid angles at row centres: within 1% at 16 rows
    let l = dome(true);
    let (a, b) = (l.phi_y(&disk), l.power());
    assert!((a - b).abs() <= 1e-2 * b, "textured dome: phi_y {a} vs power {b}");
}

// ---------------------------------------------------------------------------------------------
// distant light irradiance by splatting photons

/// Irradiance on a square of half-size `half` centred at `c` in the plane of unit normal `n`
/// (facing the light), from `n_ph` photons: mean and standard error.
fn splat_irradiance(l: &Light, disk: &EmissionDisk, c: Vec3, n: Vec3, half: f32, n_ph: usize, seed: u64) -> (f64, f64) {
    let lam = lambda();
    let f = Frame::from_normal(n);
    let mut rng = TestRng::new(seed);
    let (mut s1, mut s2) = (0f64, 0f64);
    let area = (2.0 * half as f64).powi(2);
    for _ in 0..n_ph {
        let Some(s) = l.sample_le(u2(&mut rng), u2(&mut rng), &lam, 0.0, disk) else { continue };
        let dn = s.ray_d.dot(n);
        if !(dn < 0.0) {
            continue;
        }
        let t = (c - s.ray_o).dot(n) / dn;
        let q = f.to_local(s.ray_o + s.ray_d * t - c);
        if t > 0.0 && q.x.abs() < half && q.y.abs() < half {
            let v = s.power().0[0] as f64 / area;
            s1 += v;
            s2 += v * v;
        }
    }
    let m = s1 / n_ph as f64;
    (m, ((s2 / n_ph as f64 - m * m).max(0.0) / n_ph as f64).sqrt())
}

#[test]
fn splatted_sun_photons_give_the_lights_irradiance() {
    let disk = scene_disk();
    let white = uplift::illuminant([1.0; 3], ColorSpace::LinearRec709).sample(&lambda()).0[0] as f64;
    let big_r = disk.radius();
    for (name, angle, seed) in [("delta", 0.0, 71), ("sun 0.53°", 0.53, 72), ("distant 20°", 40.0, 73)] {
        // normalised: intensity 2.5 is the irradiance on a surface facing the light
        let l = distant(angle, 2.5);
        let Light::Distant(dl) = &l else { unreachable!() };
        let a = dl.to_light;
        let fa = dl.frame;
        let e = 2.5 * white;
        // facing square at the centre
        let got = splat_irradiance(&l, &disk, disk.center(), a, 0.3 * big_r, 200_000, seed);
        // 3σ: photon counts in the square are binomial (a few % of the photons land there)
        assert!((got.0 - e).abs() <= 3.0 * got.1, "{name} centre: {got:?} vs {e}");
        // a square near the rim of the sphere, deep on the far side: every point in it must
        // still receive the whole cone, which is what the enlarged fixed disk guarantees
        let c = disk.center() - a * (0.6 * big_r) + fa.s * (0.6 * big_r);
        let got = splat_irradiance(&l, &disk, c, a, 0.1 * big_r, 400_000, seed + 10);
        assert!((got.0 - e).abs() <= 3.0 * got.1, "{name} rim: {got:?} vs {e}");
        // tilted by 35°: ∫cone L (ω·n) dω = cos 35° · E while the cone stays above the plane
        let n = (a * 35f32.to_radians().cos() + fa.t * 35f32.to_radians().sin()).normalize();
        let got = splat_irradiance(&l, &disk, disk.center(), n, 0.3 * big_r, 200_000, seed + 20);
        let e_t = e * 35f64.to_radians().cos();
        assert!((got.0 - e_t).abs() <= 3.0 * got.1, "{name} tilted: {got:?} vs {e_t}");
    }
}

// ---------------------------------------------------------------------------------------------
// agreement with the rest of the light interface

#[test]
fn emitted_rays_agree_with_l_le_intersect_and_sample_li() {
    let disk = scene_disk();
    let lam = lambda();
    let mut rng = TestRng::new(91);
    let area: Vec<(&str, Light)> = vec![("sphere", sphere()), ("rect", rect()), ("ellipse", ellipse()), ("cylinder", cylinder()), ("triangle", triangle(false)), ("two-sided triangle", triangle(true))];
    let shaped_area = shaped().into_iter().filter(|(n, _)| *n != "shaped point");
    let textured = [("textured rect", crate::light::tests::textured_rect(tilt()))];
    for (name, l) in area.into_iter().chain(shaped_area).chain(textured) {
        let mut checked = 0;
        for _ in 0..2000 {
            let Some(s) = l.sample_le(u2(&mut rng), u2(&mut rng), &lam, 0.0, &disk) else { continue };
            assert!((s.ray_d.length() - 1.0).abs() < 1e-5, "{name}: ray_d not unit");
            assert_eq!(l.l(s.ray_o, s.n_light, s.ray_d, &lam), s.l, "{name}: l at the origin");
            let (pp, pd) = l.pdf_le(s.ray_o, s.ray_d, s.n_light, &disk);
            // same formula in both: equal to f32 rounding
            assert!((pp - s.pdf_pos).abs() <= 1e-6 * pp && (pd - s.pdf_dir).abs() <= 1e-5 * pd.max(1e-3), "{name}: pdfs {pp} {pd} vs {s:?}");
            // seen from a point down the ray, the light is found at the origin, with the
            // same radiance, and sample_li gives that direction a density (unless so grazing
            // that it declines area-light points, cos < 0.005)
            let p = s.ray_o + s.ray_d * 1.5;
            let (_, hit, n) = l.intersect(p, -s.ray_d, f32::INFINITY).unwrap_or_else(|| panic!("{name}: ray back to the light misses"));
            assert!((hit - s.ray_o).length() < 1e-4, "{name}: hit {hit} vs origin {}", s.ray_o);
            let n = if n.dot(s.ray_d) < 0.0 { -n } else { n };
            assert!(n.dot(s.n_light) > 0.999, "{name}: normal");
            assert_eq!(l.l(hit, n, s.ray_d, &lam), s.l);
            if s.n_light.dot(s.ray_d).abs() > 0.01 {
                assert!(l.pdf_li(&LightSampleContext::new(p, Vec3::ZERO), -s.ray_d, None) > 0.0, "{name}: pdf_li 0");
            }
            checked += 1;
        }
        // a shaped sphere draws its directions in the cone, so about half its origins face away
        let min = if name == "shaped sphere" { 900 } else { 1900 };
        assert!(checked > min, "{name}: only {checked} samples");
    }
    for (name, l) in [("sun", distant(0.53, 1.0)), ("distant 70°", distant(140.0, 1.0)), ("dome", dome(true)), ("sky", sky())] {
        for _ in 0..2000 {
            let Some(s) = l.sample_le(u2(&mut rng), u2(&mut rng), &lam, 0.0, &disk) else { continue };
            assert_eq!(l.le(-s.ray_d, &lam), s.l, "{name}: le");
            let ctx = LightSampleContext::new(s.ray_o + s.ray_d * disk.radius(), Vec3::ZERO);
            let pdf_li = l.pdf_li(&ctx, -s.ray_d, None);
            let (pp, pd) = l.pdf_le(s.ray_o, s.ray_d, Vec3::ZERO, &disk);
            assert!(pp > 0.0 && (pd - pdf_li).abs() <= 1e-6 * pd && (pd - s.pdf_dir).abs() <= 1e-4 * pd, "{name}: pdf_dir {pd}, pdf_li {pdf_li}, sampled {}", s.pdf_dir);
            // every ray starts outside the sphere it must light
            assert!((s.ray_o - disk.center()).length() >= disk.radius() * (1.0 - 1e-5), "{name}: origin inside the sphere");
        }
    }
    // delta lights: the same quantity sample_li delivers
    let l = distant(0.0, 3.0);
    let s = l.sample_le(Vec2::new(0.2, 0.9), Vec2::new(0.5, 0.5), &lam, 0.0, &disk).unwrap();
    let li = l.sample_li(&LightSampleContext::new(Vec3::ZERO, Vec3::ZERO), Vec2::ZERO, &lam).unwrap();
    assert!(s.delta_dir && !s.delta_pos && s.l == li.l && (s.ray_d + li.wi).length() < 1e-6);
    assert_eq!(l.pdf_le(s.ray_o, s.ray_d, Vec3::ZERO, &disk).1, 0.0);
    let l = point();
    let s = l.sample_le(Vec2::ZERO, Vec2::new(0.3, 0.6), &lam, 0.0, &disk).unwrap();
    let li = l.sample_li(&LightSampleContext::new(s.ray_o + s.ray_d * 2.0, Vec3::ZERO), Vec2::ZERO, &lam).unwrap();
    assert!(s.delta_pos && (s.ray_d + li.wi).length() < 1e-5);
    for k in 0..4 {
        assert!((li.l[k] * 4.0 - s.l[k]).abs() <= 1e-5 * s.l[k], "point: {li:?} vs {s:?}");
    }
    assert_eq!(l.pdf_le(s.ray_o, s.ray_d, s.n_light, &disk).0, 0.0);
}

#[test]
fn time_does_not_change_a_still_lights_sample() {
    let disk = scene_disk();
    let (u, v) = (Vec2::new(0.31, 0.72), Vec2::new(0.45, 0.13));
    for l in [sphere(), distant(0.53, 1.0), dome(true)] {
        assert_eq!(l.sample_le(u, v, &lambda(), 0.0, &disk), l.sample_le(u, v, &lambda(), 0.75, &disk));
    }
}

#[test]
fn bad_emission_disks_are_rejected_naming_the_argument() {
    let e = EmissionDisk::new(Vec3::new(f32::NAN, 0.0, 0.0), 1.0).unwrap_err();
    assert!(e.starts_with("center"), "{e}");
    for r in [0.0, -1.0, f32::NAN, f32::INFINITY] {
        let e = EmissionDisk::new(Vec3::ZERO, r).unwrap_err();
        assert!(e.starts_with("radius"), "{e}");
    }
    for (lo, hi) in [(Vec3::ONE, Vec3::ZERO), (Vec3::ONE, Vec3::ONE), (Vec3::splat(f32::NEG_INFINITY), Vec3::ZERO)] {
        let e = EmissionDisk::from_bounds(lo, hi).unwrap_err();
        assert!(e.starts_with("bounds"), "{e}");
    }
    let d = EmissionDisk::from_bounds(Vec3::new(-1.0, -2.0, -2.0), Vec3::new(1.0, 2.0, 2.0)).unwrap();
    assert_eq!((d.center(), d.radius()), (Vec3::ZERO, 3.0));
}
