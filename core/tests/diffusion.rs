//! The diffusion mode at render level: the flat centre of a thick milky-water body under a
//! uniform sky, rendered with `method = diffusion`, against (1) the directional dipole
//! integrated numerically over the plane (the renderer's points, irradiance cache, octree and
//! Fresnel/η² bookkeeping must reproduce the model) and (2) volumetric path tracing (the
//! model's own bias, measured against a random walk in the unit tests, bounds the ratio).

mod common;
use common::*;
use glam::{Mat4, Vec3};
use tide_core::bsdf::fresnel::fresnel_dielectric;
use tide_core::diffusion::DipoleParams;
use tide_core::scene::*;

const SIGMA_S: f32 = 10.0;
const SIGMA_A: f32 = 0.5;
const ETA: f32 = 1.333;

fn scene(method: MediumMethod) -> SceneDesc {
    let mut s = SceneDesc::default();
    // 4 × 2 × 4 m: the edges and the bottom (lit by the lower half of the sky) are 2 m
    // (7.7 diffusion lengths 1/σtr) from the viewed patch
    s.meshes.push(box_mesh("/body", Vec3::new(-2.0, -2.0, -2.0), Vec3::new(2.0, 0.0, 2.0)));
    s.media.push(MediumDesc { name: "/milk".into(), sigma_a: SpectrumDesc::Rgb([SIGMA_A; 3]), sigma_s: SpectrumDesc::Rgb([SIGMA_S; 3]), scale: 1.0, phase: PhaseDesc::Isotropic, water: None, method });
    s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { ior: ETA, ..Default::default() }), interior_medium: Some(0) });
    s.instances.push(instance("/body", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    let mut sky = dome(1.0);
    sky.visible_to_camera = false;
    s.lights.push(sky);
    // straight down onto a 0.4 m patch at the centre
    let mut cam = camera(Vec3::new(0.0, 4.0, 0.0), Vec3::ZERO, 2.0 * (0.2f32 / 4.0).atan().to_degrees());
    cam.clipping_range = [1e-3, 1e6];
    s.camera = cam;
    s
}

/// The model's radiance leaving the centre along the normal under a uniform sky of radiance
/// 1: T(normal) · E_t · ∫ S_d dA, with E_t = 2π ∫ T(μ) μ dμ the transmitted irradiance and the
/// incident light refracted along the normal on average (a uniform sky's mean direction).
fn model_radiance() -> f64 {
    let p = DipoleParams::new(SIGMA_A, SIGMA_S, 0.0, ETA).unwrap();
    let n = Vec3::Y;
    let mut e_t = 0.0f64;
    for k in 0..2000 {
        let mu = (k as f64 + 0.5) / 2000.0;
        e_t += (1.0 - fresnel_dielectric(mu as f32, ETA) as f64) * mu * 2.0 * std::f64::consts::PI / 2000.0;
    }
    let (a, b, m) = ((1e-6f64).ln(), (20.0f64).ln(), 20_000);
    let mut plane = 0.0f64;
    for k in 0..m {
        let r = (a + (b - a) * (k as f64 + 0.5) / m as f64).exp();
        plane += p.sd(Vec3::ZERO, n, -n, Vec3::new(r as f32, 0.0, 0.0), n) as f64 * 2.0 * std::f64::consts::PI * r * r * (b - a) / m as f64;
    }
    (1.0 - fresnel_dielectric(1.0, ETA) as f64) * e_t * plane
}

#[test]
fn flat_centre_reproduces_the_model_and_bounds_its_bias_against_volumetric_path_tracing() {
    let (w, h) = (4, 4);
    let dif = render(&scene(MediumMethod::Diffusion), settings(w, h, 64));
    let (ld, sd, _) = channel_stats(&dif, 1, |_, _| true, w);
    let expect = model_radiance();
    // the renderer's approximations: tree ε = 0.25 (≤ ½ε² ≈ 3%); 64 sky samples per point,
    // whose noisy mean direction raises the result a little (the profile is convex in the
    // direction near the source: +3–4% measured with 256 samples, more with fewer); points
    // one mean free path apart, averaged over the patch (~1%); the finite box (< 1%): 6%
    assert!((ld / expect - 1.0).abs() < 0.06 + 3.0 * sd / ld, "diffusion {ld} ± {sd} vs model {expect}");

    let mut st = settings(w, h, 256);
    st.max_depth = 4096;
    let vol = render(&scene(MediumMethod::Volumetric), st);
    let (lv, sv, _) = channel_stats(&vol, 1, |_, _| true, w);
    // the directional dipole overestimates the total diffuse reflectance of a half-space by a
    // factor 1.2–1.5 at these albedos (pinned against a random walk in the unit tests); the
    // normal-exit radiance of exact transport is slightly above the Lambertian average the
    // model assumes, so the ratio lies in 1.1–1.6 (plus the reference's noise, 3σ)
    let ratio = ld / lv;
    let slack = 3.0 * sv / lv * ratio;
    assert!(ratio > 1.1 - slack && ratio < 1.6 + slack, "diffusion {ld} vs volumetric {lv} ± {sv}: ratio {ratio}");
}
