//! The diffusion mode at render level: the flat centre of a thick milky-water body under a
//! uniform sky, rendered with `method = diffusion`, against (1) the classical dipole's closed
//! form (the renderer's points, irradiance cache, octree and Fresnel/η² bookkeeping must
//! reproduce the model) and (2) volumetric path tracing (they must agree within the model's
//! error, measured against a random walk in the unit tests, and the reference's noise).

mod common;
use common::*;
use glam::{Mat4, Vec3};
use tide_core::bsdf::fresnel::fresnel_dielectric;
use tide_core::diffusion::profile::classic_rd_total;
use tide_core::diffusion::DipoleParams;
use tide_core::scene::*;

const SIGMA_S: f32 = 10.0;
const SIGMA_A: f32 = 0.5;
const ETA: f32 = 1.333;

fn scene(method: MediumMethod) -> SceneDesc {
    scene_at(method, Vec3::ZERO, 0.4)
}

/// The body viewed straight down onto `target` (on the top face), `view` metres wide.
fn scene_at(method: MediumMethod, target: Vec3, view: f32) -> SceneDesc {
    let mut s = SceneDesc::default();
    // 4 × 2 × 4 m: the edges and the bottom (lit by the lower half of the sky) are 2 m
    // (7.7 diffusion lengths 1/σtr) from the viewed patch
    s.meshes.push(std::sync::Arc::new(box_mesh("/body", Vec3::new(-2.0, -2.0, -2.0), Vec3::new(2.0, 0.0, 2.0))));
    s.media.push(MediumDesc { name: "/milk".into(), sigma_a: SpectrumDesc::Rgb([SIGMA_A; 3]), sigma_s: SpectrumDesc::Rgb([SIGMA_S; 3]), scale: 1.0, phase: PhaseDesc::Isotropic, water: None, method });
    s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { ior: ETA, ..Default::default() }), interior_medium: Some(0) });
    s.instances_mut().push(instance("/body", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    let mut sky = dome(1.0);
    sky.visible_to_camera = false;
    s.lights.push(sky);
    // straight down onto a patch `view` wide
    let mut cam = camera(target + Vec3::Y * 4.0, target, 2.0 * (0.5 * view / 4.0).atan().to_degrees());
    cam.clipping_range = [1e-3, 1e6];
    s.camera = cam;
    s
}

/// The model's radiance seen straight down on the centre under a uniform sky of radiance 1:
/// the sky reflected by the surface, F(normal), plus the light leaving the body,
/// T(normal) · E_t · ∫ S_d dA, with E_t = 2π ∫ T(μ) μ dμ the transmitted irradiance and
/// ∫ S_d dA = R_d,total / (4C_Φ(1/η) π) for the classical dipole (independent of the
/// direction of the light). The renderer's profile, the directional dipole normalised to
/// that total for light along the normal, gives the same: a uniform sky's mean refracted
/// direction on a flat face is the normal, and each point is evaluated with it.
fn model_radiance() -> f64 {
    let p = DipoleParams::new(SIGMA_A, SIGMA_S, 0.0, ETA).unwrap();
    let mut e_t = 0.0f64;
    for k in 0..2000 {
        let mu = (k as f64 + 0.5) / 2000.0;
        e_t += (1.0 - fresnel_dielectric(mu as f32, ETA) as f64) * mu * 2.0 * std::f64::consts::PI / 2000.0;
    }
    let plane = p.norm as f64 / std::f64::consts::PI * classic_rd_total(p.albedo_r, p.a) as f64;
    let f0 = fresnel_dielectric(1.0, ETA) as f64;
    f0 + (1.0 - f0) * e_t * plane
}

#[test]
fn flat_centre_reproduces_the_model_and_agrees_with_volumetric_path_tracing() {
    let (w, h) = (4, 4);
    let dif = render(&scene(MediumMethod::Diffusion), settings(w, h, 64));
    let (ld, sd, _) = channel_stats(&dif, 1, |_, _| true, w);
    let expect = model_radiance();
    // the renderer's approximations: where the points fall (points half a mean free path
    // apart: −2.9% measured on this patch, which the two triangles' shared edge crosses,
    // +0.2% on a patch 1 m off it); the irradiance estimate of each point (stratified, 1.3%
    // per point, averaged over ~100 points per exit point); tree ε = 0.25 (≤ ½ε² ≈ 3% on the
    // far nodes it replaces, which carry a small share); the finite box (< 1%): 5%, plus the
    // camera noise (3σ)
    assert!((ld / expect - 1.0).abs() < 0.05 + 3.0 * sd / ld, "diffusion {ld} ± {sd} vs model {expect}");

    let mut st = settings(w, h, 1024);
    st.max_depth = 4096;
    let vol = render(&scene(MediumMethod::Volumetric), st);
    let (lv, sv, _) = channel_stats(&vol, 1, |_, _| true, w);
    // agreement: the classical dipole's total diffuse reflectance is +3.5% above a random
    // walk at this albedo for light along the normal (unit tests; under a sky the incidence
    // spread brings it to within 1%), plus the point placement above (≤ 3%): 6%, plus 3σ of
    // the two renders' noise (the reference's ~1.3% at 1024 spp dominates). The directional
    // dipole (+40%) or adding single scattering on top (+16%) fails it.
    let ratio = ld / lv;
    let slack = 3.0 * ((sv / lv).powi(2) + (sd / ld).powi(2)).sqrt() * ratio;
    assert!((ratio - 1.0).abs() < 0.06 + slack, "diffusion {ld} ± {sd} vs volumetric {lv} ± {sv}: ratio {ratio}");
}

#[test]
fn edge_band_agrees_with_volumetric_path_tracing() {
    // The band 0–0.25 m (one diffusion length 1/σtr) from an edge of the top face: light
    // entering the side face leaves through the top, so the reference is ~40% brighter there
    // than on the flat. The classical dipole, which sees distance only, reads −21.6% on the
    // error table's band (docs/diffusion.md) and −22% here: it fails. The renderer's profile
    // (the directional dipole normalised to the classical total) reads −7.4% there and
    // −10% here (where the points fall along this box's edge moves it by a few per cent):
    // 15%, plus 3σ of the mean per-pixel difference of the two renders (the band's own
    // brightness gradient, common to both, cancels in the difference).
    let (w, h) = (8, 8);
    let target = Vec3::new(1.875, 0.0, 0.0);
    let dif = render(&scene_at(MediumMethod::Diffusion, target, 0.25), settings(w, h, 32));
    let mut st = settings(w, h, 512);
    st.max_depth = 4096;
    let vol = render(&scene_at(MediumMethod::Volumetric, target, 0.25), st);
    let g = |r: &tide_core::Renderer| r.aov_pixels(tide_core::Aov::Color).chunks_exact(4).map(|p| p[1] as f64).collect::<Vec<f64>>();
    let (pd, pv) = (g(&dif), g(&vol));
    let n = pd.len() as f64;
    let (ld, lv) = (pd.iter().sum::<f64>() / n, pv.iter().sum::<f64>() / n);
    let diff: Vec<f64> = pd.iter().zip(&pv).map(|(a, b)| a - b).collect();
    let md = diff.iter().sum::<f64>() / n;
    let se = (diff.iter().map(|d| (d - md).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    let ratio = ld / lv;
    assert!(ld.is_finite() && (ratio - 1.0).abs() < 0.15 + 3.0 * se / lv, "diffusion {ld} vs volumetric {lv} (σ of the difference {se}): ratio {ratio}");
}
