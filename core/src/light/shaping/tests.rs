//! Tests of UsdLuxShapingAPI: the factor against the schema's formulas at chosen angles, the
//! power shares against closed forms, and shaped lights' radiant flux and irradiance (by
//! Monte Carlo through `sample_li`) against their `power()` and against the inverse-square law.

use super::*;
use crate::light::tests::{build, desc, flux_about, lambda, tilt};
use crate::light::{Light, LightSampleContext};
use crate::scene::{LightShape, ShapingDesc};
use glam::{Mat4, Vec2};

fn shaping(cone: f32, softness: f32, focus: f32, tint: [f32; 3], spread: Spread) -> Shaping {
    let d = ShapingDesc { cone_angle_deg: cone, cone_softness: softness, focus, focus_tint: tint, ..Default::default() };
    Shaping::new(&d, Vec3::Z, spread, ColorSpace::LinearRec709).unwrap().unwrap()
}

/// Unit direction at `deg` degrees off +Z.
fn off_axis(deg: f32) -> Vec3 {
    let t = deg.to_radians();
    Vec3::new(t.sin(), 0.0, t.cos())
}

#[test]
fn the_factor_follows_the_schema_at_chosen_angles() {
    let lam = lambda();
    let f = |s: &Shaping, deg: f32| s.factor(off_axis(deg), &lam).0[0];
    // a hard 30° cone: everything inside, nothing outside
    let hard = shaping(30.0, 0.0, 0.0, [0.0; 3], Spread::Uniform);
    assert_eq!(f(&hard, 0.0), 1.0);
    assert_eq!(f(&hard, 29.9), 1.0);
    assert_eq!(f(&hard, 30.1), 0.0);
    assert_eq!(f(&hard, 150.0), 0.0);
    // softness 0.5 of a 40° cone: the fade starts at 20°, is ½ halfway (30°), and ends at 40°;
    // at a quarter (25°) smoothstep is 5/32
    let soft = shaping(40.0, 0.5, 0.0, [0.0; 3], Spread::Uniform);
    assert_eq!(f(&soft, 19.0), 1.0);
    assert!((f(&soft, 30.0) - 0.5).abs() < 1e-5);
    assert!((f(&soft, 25.0) - (1.0 - 5.0 / 32.0)).abs() < 1e-5);
    assert!(f(&soft, 39.99) < 1e-6);
    assert_eq!(f(&soft, 41.0), 0.0);
    // softness is clamped to [0, 1]: 3 behaves as 1 (the fade spans the whole cone)
    let s3 = shaping(40.0, 3.0, 0.0, [0.0; 3], Spread::Uniform);
    let s1 = shaping(40.0, 1.0, 0.0, [0.0; 3], Spread::Uniform);
    assert_eq!(f(&s3, 10.0), f(&s1, 10.0));
    assert!((f(&s1, 20.0) - 0.5).abs() < 1e-5);
    // focus 2: |cos θ|², also behind the light (no cone)
    let focus = shaping(180.0, 0.0, 2.0, [0.0; 3], Spread::Uniform);
    assert!((f(&focus, 60.0) - 0.25).abs() < 1e-6);
    assert!((f(&focus, 120.0) - 0.25).abs() < 1e-6);
    assert_eq!(f(&focus, 90.0), cos_sq(90.0));
    // the tint lerps from itself off-axis to white on the axis: t + f (1 − t) per wavelength
    let t = [0.9, 0.2, 0.05];
    let tinted = shaping(180.0, 0.0, 2.0, t, Spread::Uniform);
    let ts = uplift::albedo(t, ColorSpace::LinearRec709).sample(&lam);
    let got = tinted.factor(off_axis(60.0), &lam);
    for k in 0..4 {
        let want = ts.0[k] * 0.75 + 0.25;
        assert!((got.0[k] - want).abs() < 1e-5, "λ{k}: {} vs {want}", got.0[k]);
    }
    assert!((tinted.factor(Vec3::Z, &lam).0[0] - 1.0).abs() < 1e-6);
    // nothing to shape: no cone and no focus, or a white tint (which disables the focus)
    let none = |d: ShapingDesc| Shaping::new(&d, Vec3::Z, Spread::Uniform, ColorSpace::LinearRec709).unwrap();
    assert!(none(ShapingDesc { cone_angle_deg: 180.0, ..Default::default() }).is_none());
    assert!(none(ShapingDesc { cone_angle_deg: 200.0, focus: -3.0, ..Default::default() }).is_none());
    assert!(none(ShapingDesc { cone_angle_deg: 180.0, focus: 5.0, focus_tint: [1.0; 3], ..Default::default() }).is_none());
    // the schema's fallbacks: a hard 90° cone, a hemisphere
    let d = none(ShapingDesc::default()).unwrap();
    assert_eq!(f(&d, 89.0), 1.0);
    assert_eq!(f(&d, 91.0), 0.0);
    // non-finite values are errors naming the attribute
    let e = Shaping::new(&ShapingDesc { focus: f32::NAN, ..Default::default() }, Vec3::Z, Spread::Uniform, ColorSpace::LinearRec709).unwrap_err();
    assert!(e.starts_with("shaping:focus"), "{e}");
}

fn cos_sq(deg: f32) -> f32 {
    deg.to_radians().cos().abs().powf(2.0)
}

#[test]
fn power_shares_match_closed_forms() {
    let close = |what: &str, got: f32, want: f64| assert!((got as f64 - want).abs() <= 2e-5 * want.max(1e-3), "{what}: {got} vs {want}");
    for deg in [5.0f64, 30.0, 90.0, 135.0] {
        let c = deg.to_radians().cos();
        // uniform spread, hard cone: the cap's share of the sphere, (1 − cos θc)/2
        let s = shaping(deg as f32, 0.0, 0.0, [0.0; 3], Spread::Uniform);
        close(&format!("cap {deg}"), s.power_ratio_y(), (1.0 - c) / 2.0);
        // cosine spread (one-sided planar light), hard cone ≤ 90°: sin² θc
        let s = shaping(deg as f32, 0.0, 0.0, [0.0; 3], Spread::Cosine(Vec3::Z));
        close(&format!("planar cap {deg}"), s.power_ratio_y(), if deg <= 90.0 { deg.to_radians().sin().powi(2) } else { 1.0 });
    }
    for f in [0.5f64, 3.0, 40.0, 2000.0] {
        // focus alone, uniform spread: ∫|cos|^f dω / 4π = 1/(f + 1)
        let s = shaping(180.0, 0.0, f as f32, [0.0; 3], Spread::Uniform);
        close(&format!("focus {f}"), s.power_ratio_y(), 1.0 / (f + 1.0));
        // with the fallback 90° cone: half of it
        let s = shaping(90.0, 0.0, f as f32, [0.0; 3], Spread::Uniform);
        close(&format!("focus {f} in the hemisphere"), s.power_ratio_y(), 0.5 / (f + 1.0));
        // cosine spread: ∫cos^(f+1) dω / π = 2/(f + 2)
        let s = shaping(180.0, 0.0, f as f32, [0.0; 3], Spread::Cosine(Vec3::Z));
        close(&format!("planar focus {f}"), s.power_ratio_y(), 2.0 / (f + 2.0));
    }
    // a soft edge, uniform spread: ½∫(1 − smoothstep) sin θ dθ by a fine midpoint rule here
    let (cone, soft) = (50.0f64, 0.6f64);
    let (tc, ts) = (cone.to_radians(), (1.0 - soft) * cone.to_radians());
    let n = 200_000;
    let mut acc = 0.0;
    for i in 0..n {
        let th = (i as f64 + 0.5) * tc / n as f64;
        let t = ((th - ts) / (tc - ts)).clamp(0.0, 1.0);
        acc += (1.0 - t * t * (3.0 - 2.0 * t)) * th.sin() * tc / n as f64;
    }
    let s = shaping(cone as f32, soft as f32, 0.0, [0.0; 3], Spread::Uniform);
    close("soft cone", s.power_ratio_y(), 0.5 * acc);
    // a tint keeps t (Kc − Kf) more, per wavelength
    let lam = lambda();
    let t = [0.3, 0.6, 0.9];
    let s = shaping(180.0, 0.0, 3.0, t, Spread::Uniform);
    let ts = uplift::albedo(t, ColorSpace::LinearRec709).sample(&lam);
    let r = s.power_ratio(&lam);
    for k in 0..4 {
        close(&format!("tinted λ{k}"), r.0[k], 0.25 + ts.0[k] as f64 * 0.75);
    }
}

fn spot(shape: LightShape, transform: Mat4, sd: ShapingDesc) -> Light {
    let mut d = desc(shape, transform);
    d.intensity = 3.0;
    d.shaping = Some(sd);
    build(&d)
}

#[test]
fn shaped_lights_emit_the_power_they_declare() {
    // the power light selection and photon emission use (the quadrature) against the flux
    // through a large sphere, sampled through sample_li and its per-direction factor
    let m = tilt();
    let c = m.transform_point3(Vec3::ZERO);
    let sd = ShapingDesc { cone_angle_deg: 50.0, cone_softness: 0.4, focus: 3.0, focus_tint: [0.2; 3], ..Default::default() };
    let cases = [
        ("sphere", spot(LightShape::Sphere { radius: 0.3, treat_as_point: false }, m, sd.clone())),
        ("point", spot(LightShape::Sphere { radius: 0.3, treat_as_point: true }, m, sd.clone())),
        ("rect", spot(LightShape::Rect { width: 0.6, height: 0.4, texture: None }, m, sd.clone())),
        ("disk", spot(LightShape::Disk { radius: 0.3 }, m, sd.clone())),
        ("cylinder", spot(LightShape::Cylinder { radius: 0.1, length: 0.8, treat_as_line: false }, m, ShapingDesc { cone_angle_deg: 70.0, ..sd.clone() })),
        ("hemisphere sphere", spot(LightShape::Sphere { radius: 0.3, treat_as_point: false }, m, ShapingDesc::default())),
    ];
    for (i, (name, l)) in cases.iter().enumerate() {
        let (mean, se) = flux_about(l, c, 8.0, 200_000, 300 + i as u64);
        // power() is luminance-weighted: compare the grey light's value at one wavelength,
        // scaled the same way (a grey tint's luminance is its value)
        let lam = lambda();
        let truth = l.phi(&lam, &crate::light::emit::EmissionDisk::new(Vec3::ZERO, 1.0).unwrap()).0[0] as f64;
        // every ray the light emits crosses the enclosing sphere once: the flux is the power,
        // exactly (4σ, plus 1e-4 for the quadrature)
        assert!((mean - truth).abs() <= 4.0 * se + 1e-4 * truth, "{name}: flux {mean} ± {se} vs phi {truth}");
        let (py, pw) = (l.power(), l.phi_y(&crate::light::emit::EmissionDisk::new(Vec3::ZERO, 1.0).unwrap()));
        assert!((py - pw).abs() <= 1e-5 * pw, "{name}: power {py} vs phi_y {pw}");
    }
    // the unshaped sphere emits more than its cone keeps (the test above is not vacuous)
    let mut d = desc(LightShape::Sphere { radius: 0.3, treat_as_point: false }, m);
    d.intensity = 3.0;
    let unshaped = build(&d).power();
    assert!(cases[0].1.power() < 0.2 * unshaped && cases[5].1.power() > 0.49 * unshaped && cases[5].1.power() < 0.51 * unshaped);
}

#[test]
fn a_spot_lights_irradiance_follows_its_profile() {
    // a point light along −Y (rotated so that its −Z points down), 2 m above a floor: the
    // irradiance at a floor point x off the foot is I k(θ) f(θ) cos θ / d², θ = atan(x / 2)
    let m = Mat4::from_translation(Vec3::new(0.0, 2.0, 0.0)) * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
    let sd = ShapingDesc { cone_angle_deg: 35.0, cone_softness: 0.5, focus: 4.0, focus_tint: [0.0; 3], ..Default::default() };
    let l = spot(LightShape::Sphere { radius: 0.0, treat_as_point: true }, m, sd);
    let lam = lambda();
    let white = uplift::illuminant([1.0; 3], ColorSpace::LinearRec709).sample(&lam).0[0] as f64;
    // treatAsPoint: intensity = scale π r², r = 0 → the normalised limit scale / 4
    let i0 = 3.0 * 0.25 * white;
    for x in [0.0f32, 0.5, 0.9, 1.2, 1.5, 2.5] {
        let p = Vec3::new(x, 0.0, 0.0);
        let s = l.sample_li(&LightSampleContext::new(p, Vec3::Y), Vec2::splat(0.5), &lam);
        let e = s.map_or(0.0, |s| (s.l.0[0] * s.wi.dot(Vec3::Y)) as f64);
        let th = (x as f64 / 2.0).atan();
        let (tc, ts) = (35f64.to_radians(), 0.5 * 35f64.to_radians());
        let t = ((th - ts) / (tc - ts)).clamp(0.0, 1.0);
        let k = 1.0 - t * t * (3.0 - 2.0 * t);
        let d2 = 4.0 + (x as f64).powi(2);
        let want = i0 * k * th.cos().powi(4) * th.cos() / d2;
        assert!((e - want).abs() <= 1e-5 * i0, "x = {x}: {e} vs {want}");
    }
}

fn profile(text: &str) -> std::sync::Arc<crate::light::ies::IesProfile> {
    std::sync::Arc::new(crate::light::ies::IesProfile::parse(text).unwrap())
}

/// A quadrant-symmetric downlight profile: 200 cd straight down, falling to 0 at 90°, twice as
/// wide along the light's X as along its Y.
fn quadrant_downlight() -> std::sync::Arc<crate::light::ies::IesProfile> {
    let v = [0.0, 15.0, 30.0, 45.0, 60.0, 75.0, 90.0];
    let along_x = vec![200.0, 190.0, 160.0, 120.0, 70.0, 30.0, 0.0];
    let along_y = vec![200.0, 150.0, 80.0, 30.0, 5.0, 0.0, 0.0];
    let mid: Vec<f64> = along_x.iter().zip(&along_y).map(|(a, b)| 0.5 * (a + b)).collect();
    profile(&crate::light::ies::tests::file(&v, &[0.0, 45.0, 90.0], &[along_x, mid, along_y]))
}

#[test]
fn an_ies_profile_shapes_along_the_lights_own_axes() {
    let lam = lambda();
    let p = quadrant_downlight();
    // a light turned about its axis by 30°: its X is (cos 30°, sin 30°, 0); the axis is −Z
    let x = Vec3::new(30f32.to_radians().cos(), 30f32.to_radians().sin(), 0.0);
    let sd = ShapingDesc { cone_angle_deg: 180.0, ies: Some(p.clone()), ..Default::default() };
    let s = Shaping::with_frame(&sd, -Vec3::Z, x, Spread::Uniform, ColorSpace::LinearRec709).unwrap().unwrap();
    let y = Vec3::Z.cross(x);
    let dir = |v: f32, along: Vec3| (-Vec3::Z * v.to_radians().cos() + along * v.to_radians().sin()).normalize();
    for v in [0.0f32, 20.0, 45.0, 70.0] {
        let fx = s.factor(dir(v, x), &lam).0[0];
        let fy = s.factor(dir(v, y), &lam).0[0];
        assert!((fx - p.eval(v.to_radians(), 0.0)).abs() < 1e-3, "v {v} along X: {fx}");
        assert!((fy - p.eval(v.to_radians(), std::f32::consts::FRAC_PI_2)).abs() < 1e-3, "v {v} along Y: {fy}");
        // the profile's quadrant symmetry: −X as X
        assert!((s.factor(dir(v, -x), &lam).0[0] - fx).abs() < 1e-3);
    }
    assert!(s.factor(dir(60.0, x), &lam).0[0] > 2.0 * s.factor(dir(60.0, y), &lam).0[0]);
    // above the horizon of a downlight: dark
    assert_eq!(s.factor(Vec3::Z, &lam).0[0], 0.0);
    // angleScale 1 samples the profile at half the angle: a wider beam
    let wide = Shaping::with_frame(&ShapingDesc { ies_angle_scale: 1.0, ..sd.clone() }, -Vec3::Z, x, Spread::Uniform, ColorSpace::LinearRec709).unwrap().unwrap();
    assert!((wide.factor(dir(60.0, x), &lam).0[0] - p.eval(30f32.to_radians(), 0.0)).abs() < 1e-3);
    // normalised: divided by the mean over the lower hemisphere (a downlight file), so a point
    // light keeps half its power (its upper half is dark) ...
    let n = Shaping::with_frame(&ShapingDesc { ies_normalize: true, ..sd.clone() }, -Vec3::Z, x, Spread::Uniform, ColorSpace::LinearRec709).unwrap().unwrap();
    assert!((n.power_ratio_y() - 0.5).abs() < 2e-4, "{}", n.power_ratio_y());
    // ... and unnormalised the power share is the mean candela over the sphere
    assert!((s.power_ratio_y() - 0.5 * p.mean_intensity()).abs() < 2e-4 * p.mean_intensity(), "{} vs {}", s.power_ratio_y(), 0.5 * p.mean_intensity());
}

#[test]
fn ies_lights_emit_the_power_they_declare() {
    let m = tilt();
    let c = m.transform_point3(Vec3::ZERO);
    let sd = ShapingDesc { cone_angle_deg: 70.0, cone_softness: 0.3, ies: Some(quadrant_downlight()), ies_normalize: true, ies_angle_scale: 0.3, ..Default::default() };
    let cases = [
        ("point", spot(LightShape::Sphere { radius: 0.3, treat_as_point: true }, m, sd.clone())),
        ("disk", spot(LightShape::Disk { radius: 0.3 }, m, sd.clone())),
        ("sphere", spot(LightShape::Sphere { radius: 0.3, treat_as_point: false }, m, sd.clone())),
    ];
    let disk = crate::light::emit::EmissionDisk::new(Vec3::ZERO, 1.0).unwrap();
    for (i, (name, l)) in cases.iter().enumerate() {
        let (mean, se) = flux_about(l, c, 8.0, 200_000, 330 + i as u64);
        let truth = l.phi(&lambda(), &disk).0[0] as f64;
        assert!((mean - truth).abs() <= 4.0 * se + 1e-4 * truth, "{name}: flux {mean} ± {se} vs phi {truth}");
    }
}
