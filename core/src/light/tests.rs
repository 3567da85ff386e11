//! Statistical and physical tests of the lights: χ² of every sampler against its own pdf,
//! agreement of samples with `pdf_li`/`l`/`le`/`intersect`, analytic irradiances, and the
//! UsdLux conventions (normalisation, orientation, errors).

use super::*;
use crate::math::sample_uniform_sphere;
use crate::scene::{ColorSpace, LightDesc, LightShape, TextureDesc, Wrap};
use crate::spectrum::{uplift, SampledWavelengths};
use crate::testing::chi2::{chi2_sphere, Chi2Config, TestRng};
use glam::{Mat4, Quat, Vec2, Vec3};

/// Number of χ² runs through `check_sampling` (here and in `portal/tests.rs`), for the Šidák
/// correction of the significance level.
const N_CHI2: usize = 35;
const ALPHA: f64 = 0.01;

pub(crate) fn desc(shape: LightShape, transform: Mat4) -> LightDesc {
    LightDesc {
        shaping: None, response: Default::default(), motion: Vec::new(), portals: Vec::new(), shadow: Default::default(),
        name: "/light".into(),
        shape,
        transform,
        color: [1.0; 3],
        intensity: 1.0,
        exposure: 0.0,
        normalize: false,
        color_temperature: None,
        visible_to_camera: true,
        light_link: None,
        shadow_link: None,
    }
}

pub(crate) fn build(d: &LightDesc) -> Light {
    Light::from_desc(d, &[], ColorSpace::LinearRec709).unwrap()
}

pub(crate) fn lambda() -> SampledWavelengths {
    SampledWavelengths::sample_uniform(0.37)
}

/// The spectral value, at the first test wavelength, of an illuminant of RGB (1,1,1): what a
/// white light of unit scale emits there, whatever the uplifting.
fn white() -> f32 {
    uplift::illuminant([1.0; 3], ColorSpace::LinearRec709).sample(&lambda())[0]
}

fn cfg(seed: u64) -> Chi2Config {
    // 512 cells; 128² quadrature points per cell resolve the rims of the lights used below
    // (none subtends less than ~0.2 rad), and the 1/√ peak of area-sampled densities at a
    // curved light's silhouette, to well under the χ² noise of 100k samples (at 64² the
    // cylinder's silhouette cells are already off by a few %)
    Chi2Config { theta_res: 16, phi_res: 32, samples: 100_000, quad_res: 128, min_expected: 5.0, seed }
}

/// χ² of `sample_li` against `pdf_li` seen from `p`, plus per-sample consistency of the
/// returned pdf, radiance and geometry with `pdf_li`, `l`/`le` and `intersect`.
/// Returns (pdf integral, success rate).
pub(crate) fn check_sampling(name: &str, light: &Light, p: Vec3, seed: u64) -> (f64, f64) {
    let ctx = LightSampleContext::new(p, Vec3::ZERO);
    let lam = lambda();
    // consistency on a few thousand samples
    let mut rng = TestRng::new(seed ^ 0x5eed);
    for _ in 0..2000 {
        let u = Vec2::new(rng.next_f32(), rng.next_f32());
        let Some(s) = light.sample_li(&ctx, u, &lam) else { continue };
        assert!((s.wi.length() - 1.0).abs() < 1e-4, "{name}: wi not unit");
        let pdf = light.pdf_li(&ctx, s.wi, None);
        // a grazing ray moves its hit point by (rounding of wi) / cos: compare away from grazing
        if s.n_light.dot(-s.wi).abs() < 0.02 && !light.is_infinite() {
            continue;
        }
        // f32 geometry (distance², cosines) recomputed along the same ray: 1e-3 relative
        assert!((pdf - s.pdf).abs() <= 1e-3 * s.pdf, "{name} from {p}: sample pdf {} vs pdf_li {pdf} (wi {})", s.pdf, s.wi);
        assert!(s.l.max_component() > 0.0, "{name}: black sample returned");
        if light.is_infinite() {
            let le = light.le(s.wi, &lam);
            assert!((le[0] - s.l[0]).abs() <= 1e-5 * s.l[0], "{name}: le {le:?} vs sample {:?}", s.l);
        } else {
            let l = light.l(s.p_light, s.n_light, -s.wi, &lam);
            assert!((l[0] - s.l[0]).abs() <= 1e-5 * s.l[0], "{name}: l {l:?} vs sample {:?}", s.l);
            let (t, _, n) = light.intersect(p, s.wi, f32::INFINITY).unwrap_or_else(|| panic!("{name}: sampled direction misses the light"));
            assert!((t - s.dist).abs() <= 1e-3 * s.dist.max(1.0), "{name}: hit at {t}, sample at {}", s.dist);
            assert!(n.dot(-s.wi) > 0.0 || matches!(light, Light::Triangle(t) if t.two_sided), "{name}: back face sampled");
            // the hit handed in by a caller (the scene BVH for triangles) gives the same density
            let with_hit = light.pdf_li(&ctx, s.wi, Some((s.p_light, s.n_light)));
            assert!((with_hit - s.pdf).abs() <= 1e-3 * s.pdf, "{name}: pdf_li with hit {with_hit} vs {}", s.pdf);
        }
    }
    // The harness bins directions on a (z, φ) grid and integrates the pdf with a fixed
    // quadrature, which cannot see a sliver of light thinner than 1/128 of a cell; a generic
    // rotation of the direction space keeps the axis-aligned edges of the test lights off
    // the grid's cell boundaries.
    let rot = Quat::from_euler(glam::EulerRot::ZXY, 0.61, 0.37, 1.13);
    let r = chi2_sphere(
        cfg(seed),
        |rng| light.sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lam).map(|s| rot * s.wi),
        |w| light.pdf_li(&ctx, rot.inverse() * w, None),
    );
    assert!(r.passed(ALPHA, N_CHI2), "{name} from {p}: {r:?}");
    // every successful sample has a density, and nothing else does: the pdf integrates to the
    // success rate; 1 % covers the midpoint quadrature of a discontinuous pdf on 512×256 points
    assert!((r.pdf_integral - r.success_rate).abs() < 0.01, "{name} from {p}: ∫pdf = {} but success rate {}", r.pdf_integral, r.success_rate);
    (r.pdf_integral, r.success_rate)
}

pub(crate) fn tilt() -> Mat4 {
    Mat4::from_rotation_translation(Quat::from_euler(glam::EulerRot::XYZ, 0.4, -0.7, 0.2), Vec3::new(0.3, -0.2, 0.5))
}

#[test]
fn sphere_light_sampling_matches_its_pdf() {
    let l = build(&desc(LightShape::Sphere { radius: 1.0, treat_as_point: false }, Mat4::from_translation(Vec3::new(0.2, 0.1, -0.3))));
    let c = Vec3::new(0.2, 0.1, -0.3);
    for (i, p) in [Vec3::new(0.0, 0.0, 1.6), Vec3::new(3.0, -4.0, 0.0), Vec3::new(0.0, 1.02, 0.0)].iter().enumerate() {
        let (integral, rate) = check_sampling("sphere", &l, c + *p, 10 + i as u64);
        assert_eq!(rate, 1.0);
        assert!((integral - 1.0).abs() < 0.01);
    }
    // inside: a sphere light emits outwards only
    let ctx = LightSampleContext::new(c, Vec3::ZERO);
    assert!(l.sample_li(&ctx, Vec2::splat(0.3), &lambda()).is_none());
    assert_eq!(l.pdf_li(&ctx, Vec3::Z, None), 0.0);
}

#[test]
fn rect_light_sampling_matches_its_pdf() {
    let l = build(&desc(LightShape::Rect { width: 2.0, height: 1.0, texture: None }, Mat4::IDENTITY));
    // front is −Z: near, far, grazing (10° above the plane: thinner slivers than that are
    // below what the χ² quadrature resolves)
    for (i, p) in [Vec3::new(0.3, 0.2, -0.4), Vec3::new(1.0, -1.0, -2.5), Vec3::new(2.5, 0.3, -0.45)].iter().enumerate() {
        let (integral, rate) = check_sampling("rect", &l, *p, 20 + i as u64);
        assert_eq!(rate, 1.0);
        assert!((integral - 1.0).abs() < 0.01);
    }
    // behind: nothing, consistently
    let ctx = LightSampleContext::new(Vec3::new(0.0, 0.0, 1.0), Vec3::ZERO);
    assert!(l.sample_li(&ctx, Vec2::splat(0.5), &lambda()).is_none());
    assert_eq!(l.pdf_li(&ctx, -Vec3::Z, None), 0.0);
    // a tilted, non-uniformly scaled rect
    let m = tilt() * Mat4::from_scale(Vec3::new(1.5, 0.5, 3.0));
    let l = build(&desc(LightShape::Rect { width: 1.0, height: 2.0, texture: None }, m));
    let front = m.transform_point3(Vec3::new(0.2, 0.1, -1.0));
    check_sampling("tilted rect", &l, front, 23);
}

#[test]
fn sheared_rect_light_sampling_matches_its_pdf() {
    // a sheared rect (a parallelogram) is sampled by area
    let shear = Mat4::from_cols(Vec3::new(1.0, 0.6, 0.0).extend(0.0), Vec3::Y.extend(0.0), Vec3::Z.extend(0.0), glam::Vec4::W);
    let l = build(&desc(LightShape::Rect { width: 2.0, height: 1.0, texture: None }, tilt() * shear));
    assert!(matches!(&l, Light::Rect(r) if !r.rectangular));
    for (i, q) in [Vec3::new(0.3, 0.2, -0.4), Vec3::new(1.0, -1.0, -2.5)].iter().enumerate() {
        check_sampling("sheared rect", &l, (tilt() * shear).transform_point3(*q), 24 + i as u64);
    }
}

#[test]
fn spherical_rect_sampling_is_uniform_in_solid_angle() {
    let l = build(&desc(LightShape::Rect { width: 2.0, height: 1.0, texture: None }, Mat4::IDENTITY));
    let ctx = LightSampleContext::new(Vec3::new(0.4, -0.3, -0.5), Vec3::ZERO);
    let mut rng = TestRng::new(5);
    let mut pdf0 = None;
    for _ in 0..1000 {
        let s = l.sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lambda()).unwrap();
        let p0 = *pdf0.get_or_insert(s.pdf);
        assert_eq!(s.pdf, p0);
        // on the rect, inside its bounds (1e-5: f32 rounding of the reconstructed point)
        assert!(s.p_light.z.abs() < 1e-5 && s.p_light.x.abs() <= 1.0 + 1e-5 && s.p_light.y.abs() <= 0.5 + 1e-5, "{:?}", s.p_light);
    }
    // 1/pdf is the solid angle: compare with the closed form for a rectangle seen from a point
    // on the normal through one corner, Ω = asin(ab / √((a²+h²)(b²+h²))), summed over 4 parts
    let omega = |a: f64, b: f64, h: f64| (a * b / ((a * a + h * h) * (b * b + h * h)).sqrt()).asin();
    let (px, py, h) = (0.4f64, -0.3f64, 0.5f64);
    let total = omega(1.0 - px, 0.5 - py, h) + omega(1.0 + px, 0.5 - py, h) + omega(1.0 - px, 0.5 + py, h) + omega(1.0 + px, 0.5 + py, h);
    // f64 geometry on both sides: agreement to f32 rounding of the returned pdf
    assert!((1.0 / pdf0.unwrap() as f64 - total).abs() < 1e-5 * total, "{} vs {total}", 1.0 / pdf0.unwrap());
}

#[test]
fn disk_light_sampling_matches_its_pdf() {
    let m = tilt() * Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0));
    let l = build(&desc(LightShape::Disk { radius: 0.7 }, m));
    for (i, q) in [Vec3::new(0.1, 0.2, -0.5), Vec3::new(-1.0, 0.5, -2.0), Vec3::new(2.0, 0.0, -0.35)].iter().enumerate() {
        let (integral, rate) = check_sampling("disk", &l, m.transform_point3(*q), 30 + i as u64);
        assert_eq!(rate, 1.0);
        assert!((integral - 1.0).abs() < 0.01);
    }
}

#[test]
fn cylinder_light_sampling_matches_its_pdf() {
    let m = tilt();
    let l = build(&desc(LightShape::Cylinder { radius: 0.5, length: 3.0, treat_as_line: false }, m));
    // beside it, past one open end (sees part of the outside), and far
    for (i, q) in [Vec3::new(0.3, 0.0, 0.8), Vec3::new(2.5, 1.0, 0.4), Vec3::new(3.0, -4.0, 2.0)].iter().enumerate() {
        let (_, rate) = check_sampling("cylinder", &l, m.transform_point3(*q), 40 + i as u64);
        // about half of the side faces any outside point
        assert!(rate > 0.1 && rate < 0.6, "success rate {rate}");
    }
    // inside the tube no outer surface is visible
    let ctx = LightSampleContext::new(m.transform_point3(Vec3::new(0.5, 0.1, 0.0)), Vec3::ZERO);
    let mut rng = TestRng::new(3);
    for _ in 0..200 {
        assert!(l.sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lambda()).is_none());
    }
}

#[test]
fn triangle_light_sampling_matches_its_pdf() {
    let p = [Vec3::new(-1.0, -0.5, 0.0), Vec3::new(1.5, -0.2, 0.3), Vec3::new(0.0, 1.2, -0.2)];
    let one = Light::triangle(p, Spectrum::Constant(2.0), false).unwrap();
    let front = Vec3::new(0.1, 0.0, 0.8);
    check_sampling("triangle", &one, front, 50);
    check_sampling("triangle far", &one, Vec3::new(-1.0, 2.0, 3.0), 51);
    let two = Light::triangle(p, Spectrum::Constant(2.0), true).unwrap();
    let (integral, rate) = check_sampling("two-sided triangle from behind", &two, Vec3::new(0.3, -0.1, -0.9), 52);
    assert_eq!(rate, 1.0);
    assert!((integral - 1.0).abs() < 0.01);
    assert!(one.sample_li(&LightSampleContext::new(Vec3::new(0.0, 0.0, -1.0), Vec3::ZERO), Vec2::splat(0.4), &lambda()).is_none());
    assert!(Light::triangle([Vec3::ZERO, Vec3::X, Vec3::X * 2.0], Spectrum::Constant(1.0), false).is_none());
    assert!(Light::triangle([Vec3::ZERO, Vec3::X, Vec3::NAN], Spectrum::Constant(1.0), false).is_none());
}

#[test]
fn distant_light_cone_sampling_matches_its_pdf() {
    for (i, angle) in [25.0f32, 200.0].iter().enumerate() {
        let mut l = build(&desc(LightShape::Distant { angle_deg: *angle }, tilt()));
        l.preprocess(Vec3::ZERO, 10.0);
        let (integral, rate) = check_sampling("distant", &l, Vec3::new(1.0, 2.0, 3.0), 60 + i as u64);
        assert_eq!(rate, 1.0);
        assert!((integral - 1.0).abs() < 0.01);
    }
}

#[test]
fn constant_dome_sampling_matches_its_pdf() {
    let mut l = build(&desc(LightShape::Dome { texture: None }, tilt()));
    l.preprocess(Vec3::ZERO, 5.0);
    let (integral, _) = check_sampling("dome", &l, Vec3::ZERO, 70);
    assert!((integral - 1.0).abs() < 0.01);
}

/// A Hošek–Wilkie sky whose zenith is the tilted frame's +Y, the sun `elev` above its horizon.
pub(crate) fn sky_desc(elev_deg: f32, intensity: f32) -> LightDesc {
    let m = tilt();
    let up = m.transform_vector3(Vec3::Y).normalize();
    let f = crate::math::Frame::from_normal(up);
    let e = elev_deg.to_radians();
    let sun = f.to_world(Vec3::new(e.cos() * 0.6, e.cos() * 0.8, e.sin()));
    let mut d = desc(LightShape::Sky { turbidity: 4.0, ground_albedo: [0.2, 0.3, 0.4], sun_direction: sun, scale: 1.0 }, m);
    d.intensity = intensity;
    d
}

#[test]
fn sky_sampling_matches_its_pdf_and_le() {
    let mut l = build(&sky_desc(30.0, 3.0));
    l.preprocess(Vec3::ZERO, 5.0);
    // check_sampling compares every sample's radiance with `le` and its pdf with `pdf_li`;
    // the sky covers the upper hemisphere only, so every sample succeeds and ∫pdf = 1
    let (integral, rate) = check_sampling("sky", &l, Vec3::new(0.5, -1.0, 2.0), 75);
    assert_eq!(rate, 1.0);
    assert!((integral - 1.0).abs() < 0.01);
    // radiance is the model's × intensity; nothing below the horizon
    let Light::Sky(s) = &l else { unreachable!() };
    let lam = lambda();
    let up = tilt().transform_vector3(Vec3::Y).normalize();
    let w = (up + Vec3::new(0.3, 0.0, 0.2)).normalize();
    assert_eq!(l.le(w, &lam), s.sky.sky.radiance(w, &lam) * 3.0);
    assert!(l.le(-up, &lam).is_black());
    assert_eq!(l.pdf_li(&LightSampleContext::new(Vec3::ZERO, Vec3::ZERO), -up, None), 0.0);
    assert!(l.is_infinite() && !l.is_delta());
}

#[test]
fn physical_sun_irradiance_is_the_solar_models() {
    let up = Vec3::new(0.1, 1.0, -0.2).normalize();
    // the sun 40° above the horizon of `up`: a DistantLight whose +Z points at it
    let f = crate::math::Frame::from_normal(up);
    let e = 40f32.to_radians();
    let to_sun = f.to_world(Vec3::new(e.cos(), 0.0, e.sin()));
    let xf = Mat4::from_quat(Quat::from_rotation_arc(Vec3::Z, to_sun));
    let mut d = desc(LightShape::SkySun { zenith: up, turbidity: 2.5, scale: 1.0 }, xf);
    d.intensity = 0.5;
    d.color = [0.2, 0.4, 1.0]; // not used by the physical sun
    let mut l = build(&d);
    l.preprocess(Vec3::ZERO, 10.0);
    let model = crate::sky::HosekWilkieSky::with_frame(up, to_sun, 2.5, 0.0).unwrap();
    let lam = lambda();
    // irradiance on a surface facing the sun = 0.5 × the disc's mean radiance × its solid
    // angle (the model's disc irradiance, tabulated every 5 nm); the estimator is L/pdf · cos
    // over the 0.255° cone (cos ≥ 0.99999), exact up to that cosine
    let p = Vec3::ZERO;
    let (m, se) = irradiance(&l, p, to_sun, 2000, 9);
    let truth = 0.5 * (model.sun_spectrum().unwrap().eval(lam.lambda[0]) as f64) * crate::sky::sun_solid_angle();
    // at a 5 nm node the table is the disc integral itself
    assert!((model.sun_spectrum().unwrap().eval(550.0) as f64 * crate::sky::sun_solid_angle() / model.sun_irradiance(550.0) as f64 - 1.0).abs() < 1e-5);
    assert!((m - truth).abs() <= 3.0 * se + 2e-5 * truth, "{m} ± {se} vs {truth}");
    // a sun below its horizon is an error naming the attribute
    let below = desc(LightShape::SkySun { zenith: -up, turbidity: 2.5, scale: 1.0 }, xf);
    let e = Light::from_desc(&below, &[], ColorSpace::LinearRec709).unwrap_err();
    assert!(e.starts_with("tide:sky:sun"), "{e}");
    let bad = LightDesc { shape: LightShape::Sky { turbidity: 12.0, ground_albedo: [0.3; 3], sun_direction: to_sun, scale: 1.0 }, ..desc(LightShape::Dome { texture: None }, Mat4::IDENTITY) };
    let e = Light::from_desc(&bad, &[], ColorSpace::LinearRec709).unwrap_err();
    assert!(e.starts_with("tide:sky:turbidity"), "{e}");
}

/// A 64×32 lat-long map: dim background, a bright 3×2-texel hot spot, and a black band.
pub(crate) fn hot_spot_texture() -> TextureDesc {
    let (w, h) = (64usize, 32usize);
    let mut pixels = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for x in 0..w {
            let v = if (40..43).contains(&x) && (9..11).contains(&y) {
                [400.0, 300.0, 200.0]
            } else if (20..28).contains(&y) && (10..20).contains(&x) {
                [0.0; 3]
            } else {
                [0.5 + 0.3 * ((x as f32) * 0.3).sin(), 0.4, 0.3 + 0.01 * y as f32]
            };
            pixels.extend_from_slice(&v);
        }
    }
    TextureDesc { name: "hot".into(), width: w as u32, height: h as u32, channels: 3, pixels: pixels.into(), wrap_s: Wrap::Repeat, wrap_t: Wrap::Clamp, filter: crate::scene::Filter::Linear }
}

#[test]
fn textured_dome_sampling_matches_its_pdf() {
    let tex = vec![hot_spot_texture()];
    let d = desc(LightShape::Dome { texture: Some(0) }, tilt());
    let mut l = Light::from_desc(&d, &tex, ColorSpace::LinearRec709).unwrap();
    l.preprocess(Vec3::ONE, 5.0);
    let (integral, rate) = check_sampling("textured dome", &l, Vec3::new(0.5, 0.5, 0.5), 80);
    assert_eq!(rate, 1.0);
    assert!((integral - 1.0).abs() < 0.01);
    // importance: the hot spot (6 of 2048 texels) draws most samples
    let ctx = LightSampleContext::new(Vec3::ZERO, Vec3::ZERO);
    let mut rng = TestRng::new(81);
    let mut hot = 0;
    for _ in 0..2000 {
        let s = l.sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lambda()).unwrap();
        if s.l[0] > 100.0 * white() {
            hot += 1;
        }
    }
    assert!(hot > 1000, "{hot} of 2000 samples on the hot spot");
}

#[test]
fn dome_follows_the_openexr_lat_long_layout() {
    // 8×4 map, one lit texel at column 3 (longitude just above 0), row 1 (latitude just above 0)
    let mut pixels = vec![0.0f32; 8 * 4];
    pixels[8 + 3] = 1.0;
    let tex = vec![TextureDesc { name: "t".into(), width: 8, height: 4, channels: 1, pixels: pixels.into(), wrap_s: Wrap::Repeat, wrap_t: Wrap::Clamp, filter: crate::scene::Filter::Linear }];
    let dir = |lat: f32, lon: f32| {
        let (lat, lon) = (lat.to_radians(), lon.to_radians());
        // OpenEXR: latitude +90° is +Y, (0, 0) is +Z, longitude +90° is +X
        Vec3::new(lat.cos() * lon.sin(), lat.sin(), lat.cos() * lon.cos())
    };
    let lam = lambda();
    let l = Light::from_desc(&desc(LightShape::Dome { texture: Some(0) }, Mat4::IDENTITY), &tex, ColorSpace::LinearRec709).unwrap();
    assert!(l.le(dir(10.0, 10.0), &lam)[0] > 0.0);
    assert_eq!(l.le(dir(10.0, -10.0), &lam)[0], 0.0);
    assert_eq!(l.le(dir(-10.0, 10.0), &lam)[0], 0.0);
    assert_eq!(l.le(dir(10.0, 60.0), &lam)[0], 0.0);
    // the light's rotation turns the dome: 90° about +Y takes +Z to +X
    let r = Mat4::from_rotation_y(0.5 * PI);
    let l = Light::from_desc(&desc(LightShape::Dome { texture: Some(0) }, r), &tex, ColorSpace::LinearRec709).unwrap();
    assert!(l.le(r.transform_vector3(dir(10.0, 10.0)), &lam)[0] > 0.0);
    assert_eq!(l.le(dir(10.0, 10.0), &lam)[0], 0.0);
}

#[test]
fn lights_face_the_usd_directions() {
    let lam = lambda();
    // a distant light shines along its −Z: light arrives from +Z
    let l = build(&desc(LightShape::Distant { angle_deg: 0.0 }, Mat4::IDENTITY));
    let s = l.sample_li(&LightSampleContext::new(Vec3::ZERO, Vec3::Z), Vec2::splat(0.5), &lam).unwrap();
    assert!(s.is_delta && (s.wi - Vec3::Z).length() < 1e-6 && s.dist == f32::INFINITY);
    let l = build(&desc(LightShape::Distant { angle_deg: 0.0 }, Mat4::from_rotation_x(0.5 * PI)));
    let s = l.sample_li(&LightSampleContext::new(Vec3::ZERO, Vec3::Z), Vec2::splat(0.5), &lam).unwrap();
    assert!((s.wi - Vec3::NEG_Y).length() < 1e-6);
    // rect and disk emit towards their −Z
    for shape in [LightShape::Rect { width: 1.0, height: 1.0, texture: None }, LightShape::Disk { radius: 0.5 }] {
        let l = build(&desc(shape, Mat4::IDENTITY));
        assert!(l.sample_li(&LightSampleContext::new(Vec3::new(0.0, 0.0, -1.0), Vec3::Z), Vec2::splat(0.3), &lam).is_some());
        assert!(l.sample_li(&LightSampleContext::new(Vec3::new(0.0, 0.0, 1.0), -Vec3::Z), Vec2::splat(0.3), &lam).is_none());
        let (_, p, n) = l.intersect(Vec3::new(0.1, 0.1, -2.0), Vec3::Z, f32::INFINITY).unwrap();
        assert!(l.l(p, n, -Vec3::Z, &lam)[0] > 0.0 && l.l(p, n, Vec3::Z, &lam)[0] == 0.0);
    }
    // the cylinder lies along its local X
    let l = build(&desc(LightShape::Cylinder { radius: 0.1, length: 4.0, treat_as_line: false }, Mat4::IDENTITY));
    assert!(l.intersect(Vec3::new(1.8, 0.0, -1.0), Vec3::Z, f32::INFINITY).is_some());
    assert!(l.intersect(Vec3::new(0.0, 1.8, -1.0), Vec3::Z, f32::INFINITY).is_none());
}

/// Monte Carlo irradiance on a surface with normal `n` at `p`: (mean, standard error).
fn irradiance(l: &Light, p: Vec3, n: Vec3, samples: usize, seed: u64) -> (f64, f64) {
    let ctx = LightSampleContext::new(p, n);
    let lam = lambda();
    let mut rng = TestRng::new(seed);
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..samples {
        let x = match l.sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lam) {
            Some(s) => (s.l[0] * s.wi.dot(n).max(0.0) / s.pdf) as f64,
            None => 0.0,
        };
        s1 += x;
        s2 += x * x;
    }
    let m = s1 / samples as f64;
    let var = (s2 / samples as f64 - m * m).max(0.0);
    (m, (var / samples as f64).sqrt())
}

/// |estimate − truth| within 3 standard errors (plus f32 accumulation slack of 1e-5 relative,
/// for estimators whose variance is 0).
fn assert_3_sigma(what: &str, (m, se): (f64, f64), truth: f64) {
    assert!((m - truth).abs() <= 3.0 * se + 1e-5 * truth.abs(), "{what}: {m} ± {se}, expected {truth}");
}

#[test]
fn distant_light_irradiance_follows_usd_normalisation() {
    let e = 3.0f32;
    let w = white() as f64;
    let rot = Mat4::from_rotation_x(0.3);
    let n = rot.transform_vector3(Vec3::Z);
    for angle in [0.53f32, 10.0, 60.0] {
        let mut d = desc(LightShape::Distant { angle_deg: angle }, rot);
        d.intensity = e;
        d.normalize = true;
        let l = build(&d);
        assert_3_sigma(&format!("normalized {angle}°"), irradiance(&l, Vec3::ZERO, n, 20_000, 1), e as f64 * w);
        d.normalize = false;
        let l = build(&d);
        let half = 0.5 * (angle as f64).to_radians();
        assert_3_sigma(&format!("radiance {angle}°"), irradiance(&l, Vec3::ZERO, n, 20_000, 2), e as f64 * w * std::f64::consts::PI * half.sin().powi(2));
    }
    // angle 0: a delta light whose irradiance is the intensity, with or without normalize
    for normalize in [false, true] {
        let mut d = desc(LightShape::Distant { angle_deg: 0.0 }, rot);
        d.intensity = e;
        d.normalize = normalize;
        let l = build(&d);
        assert!(l.is_delta());
        let (m, _) = irradiance(&l, Vec3::ZERO, n, 10, 3);
        assert!((m - e as f64 * w).abs() < 1e-5 * m);
    }
}

#[test]
fn sphere_light_irradiance_is_analytic() {
    let (r, dist) = (0.5f32, 2.0f32);
    let mut d = desc(LightShape::Sphere { radius: r, treat_as_point: false }, Mat4::from_translation(Vec3::new(0.0, 0.0, dist)));
    d.intensity = 7.0;
    let l = build(&d);
    let truth = 7.0 * white() as f64 * std::f64::consts::PI * (r as f64 / dist as f64).powi(2);
    assert_3_sigma("sphere", irradiance(&l, Vec3::ZERO, Vec3::Z, 20_000, 4), truth);
    // normalized: radiance ÷ 4πr²; as a point light of the same power the irradiance is I/d²
    d.normalize = true;
    let l = build(&d);
    assert_3_sigma("normalized sphere", irradiance(&l, Vec3::ZERO, Vec3::Z, 20_000, 5), truth / (4.0 * std::f64::consts::PI * (r as f64).powi(2)));
    d.shape = LightShape::Sphere { radius: r, treat_as_point: true };
    let p = build(&d);
    assert!(p.is_delta());
    assert!((p.power() - l.power()).abs() <= 1e-5 * l.power());
    assert_3_sigma("point", irradiance(&p, Vec3::ZERO, Vec3::Z, 10, 6), truth / (4.0 * std::f64::consts::PI * (r as f64).powi(2)));
    d.normalize = false;
    let p = build(&d);
    let s = build(&desc(LightShape::Sphere { radius: r, treat_as_point: false }, Mat4::IDENTITY));
    assert!((p.power() - 7.0 * s.power()).abs() <= 1e-4 * p.power());
}

/// Total power of a light by Monte Carlo: irradiance through a sphere of radius `big` about
/// the origin, integrated over that sphere, one light sample per point.
fn flux(l: &Light, big: f32, samples: usize, seed: u64) -> (f64, f64) {
    flux_about(l, Vec3::ZERO, big, samples, seed)
}

/// [`flux`] through a sphere centred at `c`: (mean, standard error).
pub(crate) fn flux_about(l: &Light, c: Vec3, big: f32, samples: usize, seed: u64) -> (f64, f64) {
    let lam = lambda();
    let mut rng = TestRng::new(seed);
    let area = 4.0 * std::f64::consts::PI * (big as f64).powi(2);
    let (mut s1, mut s2) = (0.0f64, 0.0f64);
    for _ in 0..samples {
        let n = -sample_uniform_sphere(Vec2::new(rng.next_f32(), rng.next_f32()));
        let ctx = LightSampleContext::new(c - n * big, n);
        let v = match l.sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lam) {
            Some(s) => area * (s.l[0] * s.wi.dot(n).max(0.0) / s.pdf) as f64,
            None => 0.0,
        };
        s1 += v;
        s2 += v * v;
    }
    let m = s1 / samples as f64;
    (m, ((s2 / samples as f64 - m * m).max(0.0) / samples as f64).sqrt())
}

#[test]
fn normalized_area_lights_keep_their_power_whatever_their_size() {
    let truth = 2.0 * std::f64::consts::PI * white() as f64; // π × intensity 2
    let mut powers = Vec::new();
    for (i, (w, h, m)) in [
        (1.0f32, 1.0f32, Mat4::IDENTITY),
        (3.0, 0.5, Mat4::IDENTITY),
        (1.0, 1.0, tilt() * Mat4::from_scale(Vec3::new(2.0, 0.7, 1.0))),
    ]
    .into_iter()
    .enumerate()
    {
        let mut d = desc(LightShape::Rect { width: w, height: h, texture: None }, m);
        d.intensity = 2.0;
        d.normalize = true;
        let l = build(&d);
        assert_3_sigma(&format!("rect {w}×{h}"), flux(&l, 6.0, 40_000, 90 + i as u64), truth);
        powers.push(l.power());
    }
    // power() scales the same way (the estimate for light selection)
    for p in &powers {
        assert!((p - powers[0]).abs() <= 1e-4 * powers[0], "{powers:?}");
    }
    // and unnormalized power grows with the area
    let mut d = desc(LightShape::Rect { width: 2.0, height: 1.0, texture: None }, Mat4::from_scale(Vec3::splat(2.0)));
    d.intensity = 2.0;
    let l = build(&d);
    assert_3_sigma("unnormalized rect", flux(&l, 6.0, 40_000, 95), truth * 8.0);
    // the disk and the cylinder normalise by their world area too
    for (i, shape) in [LightShape::Disk { radius: 1.3 }, LightShape::Cylinder { radius: 0.3, length: 2.0, treat_as_line: false }].into_iter().enumerate() {
        let mut d = desc(shape, Mat4::from_scale(Vec3::splat(1.5)));
        d.intensity = 2.0;
        d.normalize = true;
        assert_3_sigma(&format!("normalized shape {i}"), flux(&build(&d), 6.0, 40_000, 96 + i as u64), truth);
    }
}

#[test]
fn light_sampler_follows_light_powers() {
    let lights = vec![
        build(&desc(LightShape::Sphere { radius: 1.0, treat_as_point: false }, Mat4::IDENTITY)),
        build(&desc(LightShape::Rect { width: 1.0, height: 1.0, texture: None }, Mat4::IDENTITY)),
        Light::triangle([Vec3::ZERO, Vec3::X, Vec3::Y], Spectrum::Constant(0.0), false).unwrap(),
    ];
    let s = LightSampler::new(&lights);
    // sphere: π L 4π r²; rect: π L A
    assert!((s.pmf(0) / s.pmf(1) - 4.0 * PI).abs() < 1e-3);
    assert_eq!(s.pmf(2), 0.0);
    let mut rng = TestRng::new(17);
    for _ in 0..1000 {
        assert_ne!(s.sample(rng.next_f32()).unwrap().0, 2);
    }
}

#[test]
fn bad_lights_are_rejected_naming_the_attribute() {
    let cs = ColorSpace::LinearRec709;
    let expect = |d: LightDesc, attr: &str| {
        let e = Light::from_desc(&d, &[], cs).unwrap_err();
        assert!(e.starts_with(attr), "expected an error on {attr}, got {e}");
    };
    expect(desc(LightShape::Rect { width: 0.0, height: 1.0, texture: None }, Mat4::IDENTITY), "width");
    expect(desc(LightShape::Rect { width: 1.0, height: f32::NAN, texture: None }, Mat4::IDENTITY), "height");
    expect(desc(LightShape::Rect { width: 1.0, height: 1.0, texture: None }, Mat4::from_scale(Vec3::new(1.0, 0.0, 1.0))), "transform");
    expect(desc(LightShape::Disk { radius: -1.0 }, Mat4::IDENTITY), "radius");
    expect(desc(LightShape::Disk { radius: 0.0 }, Mat4::IDENTITY), "radius");
    expect(desc(LightShape::Cylinder { radius: 0.5, length: 0.0, treat_as_line: false }, Mat4::IDENTITY), "length");
    expect(desc(LightShape::Distant { angle_deg: 400.0 }, Mat4::IDENTITY), "angle");
    expect(desc(LightShape::Dome { texture: Some(3) }, Mat4::IDENTITY), "texture");
    expect(desc(LightShape::Sphere { radius: 1.0, treat_as_point: false }, Mat4::from_translation(Vec3::new(f32::NAN, 0.0, 0.0))), "transform");
    let mut d = desc(LightShape::Sphere { radius: 1.0, treat_as_point: false }, Mat4::IDENTITY);
    d.intensity = f32::INFINITY;
    expect(d.clone(), "intensity");
    d.intensity = 1.0;
    d.color = [1.0, -1.0, 0.0];
    expect(d.clone(), "color");
    d.color = [1.0; 3];
    d.color_temperature = Some(-5.0);
    expect(d.clone(), "colorTemperature");
    d.color_temperature = None;
    d.exposure = 1000.0;
    expect(d, "exposure");
    let mut tex = hot_spot_texture();
    let mut px = tex.pixels.to_f32(tex.channels as usize);
    px[7] = f32::NAN;
    tex.pixels = px.into();
    let e = Light::from_desc(&desc(LightShape::Dome { texture: Some(0) }, Mat4::IDENTITY), &[tex], cs).unwrap_err();
    assert!(e.starts_with("texture"), "{e}");
    let mut tex = hot_spot_texture();
    let mut px = tex.pixels.to_f32(tex.channels as usize);
    px.pop();
    tex.pixels = px.into();
    assert!(Light::from_desc(&desc(LightShape::Dome { texture: Some(0) }, Mat4::IDENTITY), &[tex], cs).is_err());
}

#[test]
fn exposure_scales_the_radiance() {
    let mut d = desc(LightShape::Dome { texture: None }, Mat4::IDENTITY);
    d.intensity = 3.0;
    d.exposure = 2.0;
    let l = build(&d);
    let v = l.le(Vec3::Y, &lambda())[0];
    assert!((v - 12.0 * white()).abs() <= 1e-5 * v);
    // a dome of radiance L lights a plane with irradiance π L
    assert_3_sigma("dome irradiance", irradiance(&l, Vec3::ZERO, Vec3::Y, 20_000, 7), (12.0 * white()) as f64 * std::f64::consts::PI);
}



/// A rect light 2 × 1 with an image of 4 × 2 texels: the first column at its +X edge, the top
/// row at its +Y edge (UsdLux's min coordinates at (+X, +Y)); one texel is black.
pub(crate) fn textured_rect(m: Mat4) -> Light {
    let px: Vec<f32> = [[1.0, 2.0, 3.0, 4.0], [5.0, 0.0, 7.0, 8.0]].iter().flatten().flat_map(|&v| [v, 0.5 * v, 0.25 * v]).collect();
    let tex = TextureDesc { name: "rect".into(), width: 4, height: 2, channels: 3, pixels: px.into(), wrap_s: Wrap::Clamp, wrap_t: Wrap::Clamp, filter: crate::scene::Filter::Linear };
    let mut d = desc(LightShape::Rect { width: 2.0, height: 1.0, texture: Some(0) }, m);
    d.intensity = 2.0;
    Light::from_desc(&d, &[tex], ColorSpace::LinearRec709).unwrap()
}

#[test]
fn a_rect_lights_image_lies_on_it_as_usd_maps_it() {
    let lam = lambda();
    let l = textured_rect(Mat4::IDENTITY);
    let grey = |v: f32| uplift::illuminant([v, 0.5 * v, 0.25 * v], ColorSpace::LinearRec709).sample(&lam) * 2.0;
    // the light emits along −Z; texel (column c, row r) covers x ∈ [1 − (c+1)/2, 1 − c/2] (seen
    // from the lit side, looking along +Z, +X is on the left: the image reads upright there),
    // y from +½ (row 0) down
    for (x, y, v) in [(0.75, 0.25, 1.0), (-0.75, 0.25, 4.0), (0.75, -0.25, 5.0), (-0.25, -0.25, 7.0), (0.25, -0.25, 0.0)] {
        let p = Vec3::new(x, y, 0.0);
        let got = l.l(p, -Vec3::Z, -Vec3::Z, &lam);
        let want = if v == 0.0 { SampledSpectrum::ZERO } else { grey(v) };
        assert_eq!(got, want, "at ({x}, {y})");
    }
    // light samples carry the radiance of the texel they land on (and none land on black)
    let ctx = LightSampleContext::new(Vec3::new(0.1, 0.05, -0.7), Vec3::Z);
    let mut rng = TestRng::new(5);
    for _ in 0..500 {
        let Some(s) = l.sample_li(&ctx, Vec2::new(rng.next_f32(), rng.next_f32()), &lam) else { continue };
        assert_eq!(s.l, l.l(s.p_light, -Vec3::Z, -s.wi, &lam));
        assert!(!s.l.is_black());
    }
    // power: the texels' mean luminance (one black of eight) × scale × πA
    let mean_y: f32 = [1.0, 2.0, 3.0, 4.0, 5.0, 0.0, 7.0, 8.0].iter().map(|&v| crate::spectrum::color::luminance([v, 0.5 * v, 0.25 * v], ColorSpace::LinearRec709)).sum::<f32>() / 8.0;
    assert!((l.power() - mean_y * 2.0 * PI * 2.0).abs() <= 1e-4 * l.power());
    // the flux through an enclosing sphere is the spectral power, texel by texel
    let disk = crate::light::emit::EmissionDisk::new(Vec3::ZERO, 1.0).unwrap();
    let truth = l.phi(&lam, &disk).0[0] as f64;
    let (m, se) = flux(&textured_rect(tilt()), 8.0, 100_000, 77);
    assert!((m - truth).abs() <= 4.0 * se + 1e-4 * truth, "flux {m} ± {se} vs phi {truth}");
}

#[test]
fn a_moving_light_answers_as_the_static_light_where_it_is_then() {
    // each answer of the moving light at time t is an answer of the light built where it is at
    // t: its samples land on that light with that light's radiance and density (the samples
    // themselves differ: the frames they are drawn in turn with the light)
    let lam = lambda();
    let at = |t: f32| Mat4::from_rotation_translation(Quat::from_rotation_y(0.8 * t) * Quat::from_rotation_x(-1.2), Vec3::new(2.0 * t - 1.0, 1.5, 0.5 * t));
    // radiances within 1e-3 of themselves, or of 1e-3 near a cone's edge, where f32 rounding of
    // the direction moves a factor of 1e-6 by a percent
    let rel = |a: f32, b: f32| (a - b).abs() <= 1e-3 * b.abs().max(1e-3);
    for shape in [LightShape::Sphere { radius: 0.3, treat_as_point: false }, LightShape::Rect { width: 0.8, height: 0.5, texture: None }, LightShape::Disk { radius: 0.4 }, LightShape::Sphere { radius: 0.3, treat_as_point: true }] {
        let mut d = desc(shape.clone(), at(0.0));
        d.shaping = Some(crate::scene::ShapingDesc { cone_angle_deg: 60.0, cone_softness: 0.5, ..Default::default() });
        d.motion = vec![(0.0, at(0.0)), (1.0, at(1.0))];
        let moving = build(&d);
        assert!(matches!(moving, Light::Moving(_)), "{shape:?}");
        let disk = crate::light::emit::EmissionDisk::new(Vec3::ZERO, 5.0).unwrap();
        let mut answered = 0;
        for t in [0.0f32, 0.3, 1.0] {
            let mut sd = d.clone();
            sd.transform = at(t);
            sd.motion.clear();
            let fixed = build(&sd);
            let ctx = LightSampleContext::new(Vec3::new(0.2, -0.4, 0.1), Vec3::Y).at(t);
            let mut rng = TestRng::new(9);
            for _ in 0..50 {
                let u = Vec2::new(rng.next_f32(), rng.next_f32());
                if let Some(a) = moving.sample_li(&ctx, u, &lam) {
                    answered += 1;
                    if a.is_delta {
                        let b = fixed.sample_li(&ctx, u, &lam).unwrap();
                        assert!((a.wi - b.wi).length() < 1e-4 && rel(a.l.0[0], b.l.0[0]));
                        continue;
                    }
                    let (_, ph, nh) = fixed.intersect(ctx.p, a.wi, f32::INFINITY).unwrap_or_else(|| panic!("{shape:?} t {t}: the sample misses the light where it is"));
                    assert!((ph - a.p_light).length() < 1e-3, "{shape:?} t {t}: lands at {} not {ph}", a.p_light);
                    assert!(rel(a.l.0[0], fixed.l(ph, nh, -a.wi, &lam).0[0]), "{shape:?} t {t}: radiance");
                    assert!(rel(a.pdf, fixed.pdf_li(&ctx, a.wi, None)), "{shape:?} t {t}: pdf {} vs {}", a.pdf, fixed.pdf_li(&ctx, a.wi, None));
                    assert!(rel(moving.pdf_li(&ctx, a.wi, None), a.pdf));
                    let (_, pm, nm) = moving.intersect_at(ctx.p, a.wi, f32::INFINITY, t).unwrap();
                    assert!((pm - ph).length() < 1e-3 && rel(moving.l_at(pm, nm, -a.wi, t, &lam).0[0], a.l.0[0]));
                }
                let (u1, u2) = (Vec2::new(rng.next_f32(), rng.next_f32()), Vec2::new(rng.next_f32(), rng.next_f32()));
                // a shaped sphere's far side gives no ray (its directions lie in the cone)
                let Some(e) = moving.sample_le(u1, u2, &lam, t, &disk) else { continue };
                if !e.delta_pos {
                    // the emitted ray leaves the light where it is, with its radiance there
                    let back = e.ray_o + e.ray_d * 0.5;
                    let (_, ph, nh) = fixed.intersect(back, -e.ray_d, f32::INFINITY).expect("the ray leaves the light where it is");
                    assert!((ph - e.ray_o).length() < 1e-3 && rel(e.l.0[0], fixed.l(ph, nh, e.ray_d, &lam).0[0]), "{shape:?} t {t}: {e:?} vs {ph} {}", fixed.l(ph, nh, e.ray_d, &lam).0[0]);
                } else {
                    assert!((e.ray_o - at(t).transform_point3(Vec3::ZERO)).length() < 1e-4);
                }
            }
        }
        assert!(answered > 50, "{shape:?}: {answered}");
    }
}

/// The intensity towards a sphere that the caustics' atlas weighs a light by
/// ([`tree::EmissionBounds::toward`]): zero only where no direction the light emits along,
/// from any point of it, meets the sphere (checked by brute force over points of both), 1 for
/// a light emitting alike all round, and a rect's cosine lobe (4 cos θ) along θ.
#[test]
fn emission_bounds_reach_a_sphere_wherever_the_light_does() {
    use super::tree::EmissionBounds;
    use std::f32::consts::TAU;
    let lam = lambda();
    let mut rng = TestRng::new(21);
    let mut u = move || rng.next_f32();
    let (mut unreached, mut reached) = (0, 0);
    for k in 0..400 {
        let rot = Quat::from_euler(glam::EulerRot::XYZ, u() * TAU, u() * TAU, u() * TAU);
        let at = Vec3::new(u(), u(), u()) * 4.0 - 2.0;
        let xf = Mat4::from_rotation_translation(rot, at);
        let shape = match k % 4 {
            0 => LightShape::Sphere { radius: 0.0, treat_as_point: true },
            1 => LightShape::Sphere { radius: 0.3, treat_as_point: false },
            2 => LightShape::Rect { width: 1.0, height: 0.6, texture: None },
            _ => LightShape::Disk { radius: 0.5 },
        };
        let mut d = desc(shape.clone(), xf);
        if k % 4 < 2 || k % 8 >= 6 {
            d.shaping = Some(crate::scene::ShapingDesc { cone_angle_deg: 10.0 + 80.0 * u(), cone_softness: 0.3, ..Default::default() });
        }
        let light = build(&d);
        let bounds = EmissionBounds::of(&light, (0.0, 0.0)).expect("a light with a place");
        let (c, r) = (Vec3::new(u(), u(), u()) * 12.0 - 6.0, 0.05 + u());
        let f = bounds.toward(c, r);
        assert!(f.is_finite() && f >= 0.0, "{f}");
        // points of the light, each with the front it emits through (None: all round)
        let front = xf.transform_vector3(Vec3::NEG_Z).normalize();
        let lights: Vec<(Vec3, Option<Vec3>)> = (0..64)
            .map(|_| match shape {
                LightShape::Sphere { treat_as_point: true, .. } => (at, None),
                LightShape::Sphere { radius, .. } => {
                    let n = sample_uniform_sphere(Vec2::new(u(), u()));
                    (at + n * radius, Some(n))
                }
                LightShape::Rect { width, height, .. } => (xf.transform_point3(Vec3::new((u() - 0.5) * width, (u() - 0.5) * height, 0.0)), Some(front)),
                _ => {
                    let (rr, phi) = (0.5 * u().sqrt(), u() * TAU);
                    (xf.transform_point3(Vec3::new(rr * phi.cos(), rr * phi.sin(), 0.0)), Some(front))
                }
            })
            .collect();
        let sphere: Vec<Vec3> = (0..64).map(|_| c + sample_uniform_sphere(Vec2::new(u(), u())) * r).chain([c]).collect();
        let reaches = lights.iter().any(|&(x, n)| {
            sphere.iter().any(|&q| {
                let w = (q - x).normalize();
                n.is_none_or(|n| n.dot(w) > 0.0) && light.shaping_factor(w, &lam).0[0] > 0.0
            })
        });
        if reaches {
            assert!(f > 0.0, "light {k} ({shape:?}) reaches the sphere at {c} (r {r}) but weighs it 0");
            reached += 1;
        } else if f == 0.0 {
            unreached += 1;
        }
    }
    // both kinds of answer were put to the test
    assert!(reached > 50 && unreached > 50, "{reached} reached, {unreached} weighed 0");
    // all round: as a light of its power would
    let point = build(&desc(LightShape::Sphere { radius: 0.0, treat_as_point: true }, Mat4::IDENTITY));
    assert_eq!(EmissionBounds::of(&point, (0.0, 0.0)).unwrap().toward(Vec3::X * 5.0, 0.5), 1.0);
    // a small rect facing −Z seen 60° off its normal from far away: 4 cos 60° = 2
    let rect = build(&desc(LightShape::Rect { width: 0.01, height: 0.01, texture: None }, Mat4::IDENTITY));
    let w = Vec3::new(60f32.to_radians().sin(), 0.0, -60f32.to_radians().cos());
    let f = EmissionBounds::of(&rect, (0.0, 0.0)).unwrap().toward(w * 1000.0, 0.01);
    assert!((f - 2.0).abs() < 0.01, "{f}");
}
