//! Tests of the diffusion mode: the dipole profile against a numerical evaluation of the
//! diffusion theory it comes from, energy against the closed-form albedo relation and a
//! brute-force random walk, the hierarchical sum against the brute-force sum, the point set
//! and the irradiance cache.

use super::profile::*;
use super::tree::*;
use super::*;
use crate::spectrum::SampledWavelengths;
use crate::testing::chi2::TestRng;
use glam::{DVec3, Vec3};

#[test]
fn boundary_terms_are_exact_when_index_matched_and_reflect_internally_otherwise() {
    let (cphi, ce) = boundary_terms(1.0);
    // F = 0: 1/4π ∫cos = 1/4, 3/4π ∫cos² = 1/2; quadrature error ~1e-7
    assert!((cphi - 0.25).abs() < 1e-5 && (ce - 0.5).abs() < 1e-5, "{cphi} {ce}");
    let p = DipoleParams::new(0.1, 10.0, 0.0, 1.0).unwrap();
    assert!((p.a - 1.0).abs() < 1e-4 && (p.norm - 1.0).abs() < 1e-4);
    // water: the internal diffuse Fresnel reflectance 1 − 4C_Φ(η) (total internal
    // reflection beyond 48.6°) against the Egan–Hilgeman fit F_dr = −1.440/η² + 0.710/η +
    // 0.668 + 0.0636η, which is good to ~0.5% of F_dr for η in [1, 1.6]: 1% here
    for eta in [1.2f32, 1.333, 1.5] {
        let (cphi, _) = boundary_terms(eta);
        let fdr = -1.440 / (eta * eta) + 0.710 / eta + 0.668 + 0.0636 * eta;
        assert!(((1.0 - 4.0 * cphi) / fdr - 1.0).abs() < 0.01, "η {eta}: {} vs {fdr}", 1.0 - 4.0 * cphi);
    }
}

/// φ and its gradient for a ray source, in f64, straight from diffusion theory: the point
/// source Green's function G = e^{−σtr r}/(4πD r) minus 3D ω·∇G (the first-order source).
fn fluence_f64(p: &DipoleParams, x: DVec3, w: DVec3) -> f64 {
    let (s, d) = (p.sigma_tr as f64, p.d as f64);
    let g = |y: DVec3| (-s * y.length()).exp() / (4.0 * std::f64::consts::PI * d * y.length());
    // −3D ω·∇G by central differences
    let h = 1e-4 * x.length();
    let dg = (g(x + w * h) - g(x - w * h)) / (2.0 * h);
    g(x) - 3.0 * d * dg
}

#[test]
fn ray_source_profile_matches_a_numerical_evaluation_of_its_diffusion_formula() {
    // S'_d = 1/(4C_Φ(1/η)) · 1/π · [C_Φ(η) φ(x) − C_E(η) D n·∇φ(x)], with φ and ∇φ here by
    // finite differences of the Green's function (independent of the closed form)
    let mut rng = TestRng::new(7);
    for &(sa, ss, g, eta) in &[(0.1f32, 10.0f32, 0.0f32, 1.333f32), (1.0, 3.0, 0.5, 1.0), (0.02, 40.0, 0.9, 1.5)] {
        let p = DipoleParams::new(sa, ss, g, eta).unwrap();
        let pi = std::f64::consts::PI;
        for _ in 0..50 {
            let mut u = || rng.next_f32() as f64 * 2.0 - 1.0;
            let x = DVec3::new(u(), u(), u()) * (3.0 / p.sigma_t_r as f64);
            let w = DVec3::new(u(), u(), u()).normalize();
            let n = DVec3::new(u(), u(), u()).normalize();
            if x.length() < 0.05 / p.sigma_t_r as f64 {
                continue;
            }
            let h = 1e-4 * x.length();
            let dn = (fluence_f64(&p, x + n * h, w) - fluence_f64(&p, x - n * h, w)) / (2.0 * h);
            let expect = p.norm as f64 / pi * (p.c_phi as f64 * fluence_f64(&p, x, w) - p.c_e as f64 * p.d as f64 * dn);
            let got = p.s_prime(x.as_vec3(), w.as_vec3(), x.length() as f32, n.as_vec3()) as f64;
            // nested central differences: O(h²) ≈ 1e-8 truncation; f32 evaluation of the
            // closed form ~1e-6 relative, but terms cancel, so compare against the scale of
            // the two parts
            let scale = p.norm as f64 / pi * (p.c_phi as f64 * fluence_f64(&p, x, w).abs() + p.c_e as f64 * p.d as f64 * dn.abs());
            assert!((got - expect).abs() <= 1e-4 * scale, "σa {sa} σs {ss} g {g} η {eta} x {x:?}: {got} vs {expect}");
        }
        // the fluence helper of the module is the same φ
        let x = Vec3::new(0.3, -0.2, 0.1) / p.sigma_t_r;
        let w = Vec3::new(0.0, -1.0, 0.0);
        let f = ray_source_fluence(&p, x, w) as f64;
        let fe = fluence_f64(&p, x.as_dvec3(), w.as_dvec3());
        assert!((f / fe - 1.0).abs() < 1e-4, "{f} vs {fe}");
    }
}

/// ∫₀^∞ f(r) 2πr dr on a log grid (midpoint in ln r), in f64.
fn radial_integral(f: impl Fn(f32) -> f32, r_min: f64, r_max: f64) -> f64 {
    let n = 20_000;
    let (a, b) = (r_min.ln(), r_max.ln());
    let mut s = 0.0;
    for k in 0..n {
        let lr = a + (b - a) * (k as f64 + 0.5) / n as f64;
        let r = lr.exp();
        s += f(r as f32) as f64 * 2.0 * std::f64::consts::PI * r * r * (b - a) / n as f64;
    }
    s
}

#[test]
fn classical_dipole_integrates_to_the_closed_form_albedo_relation() {
    for &(alpha, a) in &[(0.99f32, 1.0f32), (0.9, 2.5), (0.5, 1.0), (0.999, 2.5)] {
        let st = 10.0;
        let (sa, ssr) = (st * (1.0 - alpha), st * alpha);
        let num = radial_integral(|r| classic_rd(sa, ssr, a, r), 1e-6 / st as f64, 1e3 / st as f64);
        let exact = classic_rd_total(alpha, a) as f64;
        // the log-grid quadrature of this smooth profile is good to ~1e-5; the tail beyond
        // 1000 mean free paths is below e^{−1000 σtr/σt} ≈ 0 for these albedos... except
        // 0.999, where σtr/σt' = 0.055: e^{−55}, still negligible
        assert!((num / exact - 1.0).abs() < 1e-3, "α' {alpha} A {a}: {num} vs {exact}");
    }
}

/// Diffuse reflectance of a half-space (σt = 1, isotropic scattering of albedo `alpha`,
/// relative IOR `eta` with Fresnel reflection back into the medium) lit along the normal, by
/// a brute-force random walk: the fraction of photons leaving after at least one scattering,
/// in total and by exit radius in the annuli between `edges` (in mean free paths).
fn random_walk(alpha: f64, eta: f32, n: usize, seed: u64, edges: &[f64]) -> (f64, Vec<f64>) {
    random_walk_oblique(alpha, eta, n, seed, edges, 1.0)
}

/// [`random_walk`] with the light entering at `cos_t` to the normal (the refracted direction,
/// inside), travelling in the x–z plane towards +x.
fn random_walk_oblique(alpha: f64, eta: f32, n: usize, seed: u64, edges: &[f64], cos_t: f64) -> (f64, Vec<f64>) {
    let mut rng = TestRng::new(seed);
    let mut u = || (rng.next_f32() as f64).max(1e-12);
    let mut out = 0usize;
    let mut hist = vec![0usize; edges.len() - 1];
    let w0 = DVec3::new((1.0 - cos_t * cos_t).max(0.0).sqrt(), 0.0, -cos_t);
    for _ in 0..n {
        let mut pos = w0 * -u().ln();
        loop {
            if u() > alpha {
                break;
            }
            let c = 2.0 * u() - 1.0;
            let ph = 2.0 * std::f64::consts::PI * u();
            let s = (1.0 - c * c).sqrt();
            let mut next = pos + DVec3::new(s * ph.cos(), s * ph.sin(), c) * -u().ln();
            if next.z > 0.0 {
                if u() >= crate::bsdf::fresnel::fresnel_dielectric(c as f32, 1.0 / eta) as f64 {
                    out += 1;
                    // the exit point on the surface
                    let t = -pos.z / c;
                    let r = (pos.x + s * ph.cos() * t).hypot(pos.y + s * ph.sin() * t);
                    if let Some(k) = (0..hist.len()).find(|&k| r >= edges[k] && r < edges[k + 1]) {
                        hist[k] += 1;
                    }
                    break;
                }
                next.z = -next.z;
            }
            pos = next;
        }
    }
    (out as f64 / n as f64, hist.iter().map(|&h| h as f64 / n as f64).collect())
}

/// π ∫ S_d dA · 4C_Φ(1/η)/norm over r in [r0, r1) for light along the normal: the model's
/// flux leaving through the boundary (Fresnel included) per unit incident flux.
fn model_flux(p: &DipoleParams, r0: f64, r1: f64) -> f64 {
    let n = Vec3::Y;
    let f = |r: f32| if (r as f64) >= r0 && (r as f64) < r1 { p.sd(Vec3::ZERO, n, -n, Vec3::new(r, 0.0, 0.0), n) } else { 0.0 };
    std::f64::consts::PI * radial_integral(f, 1e-6, 200.0) / p.norm as f64
}

#[test]
fn directional_dipole_against_a_random_walk_far_from_and_near_the_source() {
    // Diffusion holds many transport lengths from the source, where every dipole decays like
    // the exact solution: between 8 and 16 mean free paths the flux leaving agrees with the
    // random walk within 20% (measured: directional dipole +7…+15%, the classical one
    // +4…+7%; the walk's standard error there is ~2–4% with 40 000 photons). Near the source
    // it does not: the directional dipole as published (every term checked against Frisvad
    // et al. 2014) overestimates the flux within a few mean free paths and the total by
    // ~30–45% at normal incidence; its total exceeds 1 as α' → 1 (1.25 at α' = 0.999, η = 1).
    // The authors' sample code (as in Mitsuba's plugin), appleseed's and ray_engine's
    // implementations give the same values (docs/diffusion.md). That is why the renderer
    // normalises it (ProfileModel::DirectionalNormalized); the test pins the published
    // model's ratio between 1.2 and 1.5 so that a change of it or of the walk shows.
    let edges = [0.0, 8.0, 16.0];
    for &(alpha, eta) in &[(0.99f32, 1.0f32), (0.999, 1.0), (0.99, 1.333)] {
        let p = DipoleParams::new(1.0 - alpha, alpha, 0.0, eta).unwrap();
        let (total, hist) = random_walk(alpha as f64, eta, 40_000, 5, &edges);
        let far = model_flux(&p, 8.0, 16.0);
        assert!((far / hist[1] - 1.0).abs() < 0.20, "α {alpha} η {eta}: 8–16 mfp dipole {far} vs walk {}", hist[1]);
        let all = model_flux(&p, 0.0, 1e9);
        let ratio = all / total;
        assert!(ratio > 1.2 && ratio < 1.5, "α {alpha} η {eta}: total dipole {all} vs walk {total}");
    }
}

#[test]
fn classical_dipole_total_matches_a_random_walk_with_and_without_an_index_mismatch() {
    // The profile the renderer uses. Its total diffuse reflectance (the flux leaving through
    // the boundary, Fresnel included, per unit flux entering along the normal; single
    // scattering included) against the walk: measured −0.7% (α' 0.99, η 1), +0.1% (0.99,
    // 1.333), +3.5% (0.952, 1.333: the milky water of the render tests). Classical diffusion
    // is known to drift above transport as the albedo falls; the walk's standard error is
    // ≤ 0.6% with 40 000 photons: 5%.
    for &(alpha, eta) in &[(0.99f32, 1.0f32), (0.99, 1.333), (0.952, 1.333)] {
        let p = DipoleParams::new(1.0 - alpha, alpha, 0.0, eta).unwrap().with_model(ProfileModel::Classical);
        let (total, _) = random_walk(alpha as f64, eta, 40_000, 11, &[0.0, 1.0]);
        // the BSSRDF integrated as the renderer sums it: π ∫ S_d dA / norm is R_d's total
        let n = Vec3::Y;
        let model = std::f64::consts::PI * radial_integral(|r| p.eval(Vec3::ZERO, n, -n, Vec3::new(r, 0.0, 0.0), n), 1e-6, 200.0) / p.norm as f64;
        let closed = classic_rd_total(alpha, p.a) as f64;
        // quadrature of the log grid ~1e-5 (classical_dipole_integrates_to_the_closed_form…)
        assert!((model / closed - 1.0).abs() < 1e-3, "α {alpha} η {eta}: ∫S_d {model} vs closed form {closed}");
        assert!((closed / total - 1.0).abs() < 0.05, "α {alpha} η {eta}: classical {closed} vs walk {total}");
    }
}

fn grid_points(n: usize, h: f32, e: impl Fn(Vec3) -> f32) -> Vec<IrradiancePoint> {
    let mut pts = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let p = Vec3::new((i as f32 - n as f32 / 2.0) * h, 0.0, (j as f32 - n as f32 / 2.0) * h);
            let v = e(p);
            pts.push(IrradiancePoint { p, n: Vec3::Y, area: h * h, dir: Vec3::new(0.3, -1.0, 0.1).normalize(), e: [v; N_BINS] });
        }
    }
    pts
}

fn lambda4() -> SampledWavelengths {
    SampledWavelengths { lambda: [400.0, 500.0, 600.0, 700.0], pdf: [1.0; 4] }
}

#[test]
fn hierarchical_sum_agrees_with_the_brute_force_sum_within_its_error_criterion() {
    let params: [Option<DipoleParams>; 4] = [0.05f32, 0.1, 0.3, 0.6].map(|sa| DipoleParams::new(sa, 8.0, 0.2, 1.333));
    // uniform irradiance. Near the exit point a replaced node's relative error is ≈ ½ε²;
    // farther out it grows like ½ε²(3 + σtr d)² but multiplies a share that falls as
    // e^{−σtr d}, so the total stays within ½ε² (asserted per wavelength and query)
    let tree = IrradianceTree::build(grid_points(120, 0.05, |_| 1.0));
    let lambda = lambda4();
    let mut worst = [0.0f32; 3];
    for (qi, &xo) in [Vec3::ZERO, Vec3::new(1.3, 0.0, -0.7), Vec3::new(2.9, 0.0, 2.9), Vec3::new(-0.37, 0.0, 0.11)].iter().enumerate() {
        let brute = tree.exitance_brute(&params, &lambda, xo, Vec3::Y);
        assert!(brute.min_component() > 0.0);
        let exact = tree.exitance(&params, &lambda, xo, Vec3::Y, 0.0);
        for (k, &eps) in [0.1f32, 0.25, 0.5].iter().enumerate() {
            let h = tree.exitance(&params, &lambda, xo, Vec3::Y, eps);
            for c in 0..4 {
                let rel = (h[c] / brute[c] - 1.0).abs();
                worst[k] = worst[k].max(rel);
                assert!(rel <= 0.5 * eps * eps, "query {qi} ε {eps} λ{c}: {} vs {}", h[c], brute[c]);
            }
        }
        for c in 0..4 {
            // ε = 0 visits every point: only the summation order differs (f32)
            assert!((exact[c] / brute[c] - 1.0).abs() < 1e-4);
        }
    }
    // the approximation is real (the test could fail) and shrinks with ε
    assert!(worst[2] > 0.0 && worst[0] <= worst[1] && worst[1] <= worst[2], "{worst:?}");
}

#[test]
fn points_next_to_the_exit_point_are_integrated_over_their_patches() {
    // The direction-aware profile peaks within a fraction of a mean free path of its source,
    // finer than the points (half a mean free path apart here, as rendered). A grid 4× finer
    // in each direction is the reference for the area integral. An exit point 0.1 of a
    // spacing from a point, light at cosθ 0.55 inside: evaluating each point at its centre
    // read +37% (measured), with the 3 × 3 patch rule +1.0%; an exit point midway between
    // points −1.3% with it. 5%.
    let mut p = DipoleParams::new(0.5, 10.0, 0.0, 1.333).unwrap().with_model(ProfileModel::DirectionalNormalized);
    p.scale = 1.0;
    let params = [Some(p); 4];
    let lambda = lambda4();
    let h = 0.5 / p.sigma_t_r;
    let dir = Vec3::new(0.8, -0.55, 0.0).normalize();
    let grid = |n: usize, h: f32| {
        let mut pts = Vec::new();
        for i in 0..n {
            for j in 0..n {
                let q = Vec3::new((i as f32 - n as f32 / 2.0) * h, 0.0, (j as f32 - n as f32 / 2.0) * h);
                pts.push(IrradiancePoint { p: q, n: Vec3::Y, area: h * h, dir, e: [1.0; N_BINS] });
            }
        }
        IrradianceTree::build(pts)
    };
    let coarse = grid(64, h);
    let fine = grid(256, h / 4.0);
    for xo in [Vec3::new(0.1 * h, 0.0, 0.0), Vec3::new(0.5 * h, 0.0, 0.5 * h)] {
        let got = coarse.exitance(&params, &lambda, xo, Vec3::Y, 0.0)[0] as f64;
        let reference = fine.exitance(&params, &lambda, xo, Vec3::Y, 0.0)[0] as f64;
        assert!((got / reference - 1.0).abs() < 0.05, "exit {xo:?}: {got} vs finer points {reference}");
    }
}

#[test]
fn hierarchical_sum_is_deterministic() {
    // two trees built from the same points give bit-identical sums
    let params: [Option<DipoleParams>; 4] = [0.1f32; 4].map(|sa| DipoleParams::new(sa, 8.0, 0.0, 1.333));
    let a = IrradianceTree::build(grid_points(60, 0.05, |p| 1.0 + p.x));
    let b = IrradianceTree::build(grid_points(60, 0.05, |p| 1.0 + p.x));
    let l = lambda4();
    for xo in [Vec3::ZERO, Vec3::new(0.5, 0.0, 0.2)] {
        assert_eq!(a.exitance(&params, &l, xo, Vec3::Y, 0.25).0, b.exitance(&params, &l, xo, Vec3::Y, 0.25).0);
    }
}


#[test]
fn single_scattering_matches_the_closed_form_for_a_flat_body_under_a_distant_light() {
    // A deep flat body (σs = 1, σa = 0.5, isotropic, η = 1.333) under a distant light at 60°
    // elevation, seen straight down. Exact single scattering along the refracted ray:
    // L = σs p E⊥ cosθe T(θe) / cosθi · 1/(σt (1 + cosθo/cosθi)), θe outside, θi inside.
    use crate::scene::*;
    let mut s = diffusion_box(Vec3::new(-50.0, -20.0, -50.0), Vec3::new(50.0, 0.0, 50.0), 1.0);
    let el = 60f32.to_radians();
    let to_sun = Vec3::new(el.cos(), el.sin(), 0.0);
    let z = to_sun;
    let x = Vec3::Y.cross(z).normalize();
    let y = z.cross(x);
    let xf = glam::Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), glam::Vec4::W);
    s.lights.push(LightDesc { name: "/sun".into(), shape: LightShape::Distant { angle_deg: 0.53 }, transform: xf, color: [1.0; 3], intensity: 2.0, exposure: 0.0, normalize: true, color_temperature: None, visible_to_camera: true, light_link: None, shadow_link: None, shadow: Default::default(), shaping: None, response: Default::default(), motion: Vec::new(), portals: Vec::new() });
    let world = crate::testing::world_of(&s);
    let ray = Ray { o: Vec3::new(0.3, 5.0, -0.2), d: -Vec3::Y, t_max: f32::INFINITY, time: 0.0 };
    let hit = world.accel.intersect(&ray).unwrap();
    let sh = world.surface(&ray, &hit);
    let lambda = crate::spectrum::color::sample_wavelengths(0.37);
    let n = 20_000;
    let mut rng = TestRng::new(9);
    let (mut sum, mut sum2, mut e_perp) = (0.0f64, 0.0f64, 0.0f64);
    let parts = Parts { multiple: false, single: true };
    for _ in 0..n {
        let u: [f32; 6] = std::array::from_fn(|_| rng.next_f32());
        let v = radiance_exit_with(&world, &sh, -Vec3::Y, &lambda, u, parts)[0] as f64;
        sum += v;
        sum2 += v * v;
        // the light's E⊥ at the hero wavelength, from its own samples above the surface
        let ls = world.lights[0].sample_li(&LightSampleContext::new(Vec3::new(0.0, 1.0, 0.0), Vec3::ZERO), glam::Vec2::new(u[2], u[3]), &lambda).unwrap();
        e_perp += (ls.l[0] / ls.pdf) as f64;
    }
    let mean = sum / n as f64;
    let se = ((sum2 / n as f64 - mean * mean) / n as f64).sqrt();
    let e_perp = e_perp / n as f64;
    let cos_e = el.sin() as f64;
    let sin_i = (1.0 - cos_e * cos_e).sqrt() / 1.333;
    let cos_i = (1.0 - sin_i * sin_i).sqrt();
    let t = 1.0 - fresnel_dielectric(cos_e as f32, 1.333) as f64;
    let expect = 1.0 * (1.0 / (4.0 * std::f64::consts::PI)) * e_perp * cos_e * t / cos_i / (1.5 * (1.0 + 1.0 / cos_i));
    // 4σ of the estimate (distance and light sampling are its only randomness) plus 0.5% for
    // the light's 0.53° disc (the closed form takes its centre)
    assert!(expect > 0.0 && (mean - expect).abs() < 4.0 * se + 0.005 * expect, "{mean} ± {se} vs {expect}");
}

/// A closed box of milky water (σa = 0.5, σs as given, isotropic, η = 1.333) in the diffusion
/// mode, with no lights.
fn diffusion_box(lo: Vec3, hi: Vec3, sigma_s: f32) -> crate::scene::SceneDesc {
    use crate::scene::*;
    let mut s = SceneDesc::default();
    s.meshes.push(crate::volume::box_mesh("/b", lo, hi).into());
    s.media.push(MediumDesc { name: "/m".into(), sigma_a: SpectrumDesc::Rgb([0.5; 3]), sigma_s: SpectrumDesc::Rgb([sigma_s; 3]), scale: 1.0, phase: PhaseDesc::Isotropic, water: None, method: MediumMethod::Diffusion });
    s.materials.push(MaterialDesc { name: "/w".into(), surface: SurfaceDesc::Water(WaterDesc { ior: 1.333, ..Default::default() }), interior_medium: Some(0) });
    s.instances_mut().push(InstanceDesc { name: "/b".into(), geometry: GeometryRef::Mesh(0), transforms: vec![glam::Mat4::IDENTITY], times: vec![0.0], material: 0, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None });
    s
}

fn dome_box_world() -> World {
    use crate::scene::*;
    let mut s = diffusion_box(Vec3::new(-1.0, -0.5, -1.5), Vec3::new(1.0, 0.0, 1.5), 10.0);
    s.lights.push(LightDesc { name: "/sky".into(), shape: LightShape::Dome { texture: None }, transform: glam::Mat4::IDENTITY, color: [1.0; 3], intensity: 1.0, exposure: 0.0, normalize: false, color_temperature: None, visible_to_camera: true, light_link: None, shadow_link: None, shadow: Default::default(), shaping: None, response: Default::default(), motion: Vec::new(), portals: Vec::new() });
    crate::testing::world_of(&s)
}

#[test]
fn surface_points_cover_the_body_by_area_and_the_cache_is_deterministic() {
    let w = dome_box_world();
    let spacing = 0.1;
    let pts = surface_points(&w, 0, spacing);
    let total = 2.0 * (2.0 * 0.5 + 2.0 * 3.0 + 0.5 * 3.0);
    let area: f32 = pts.iter().map(|q| q.area).sum();
    assert!((area / total - 1.0).abs() < 1e-4, "{area} vs {total}");
    assert_eq!(pts.len(), (total / (spacing * spacing)).ceil() as usize);
    // each face holds its share of the points to within one per triangle (stratified by area)
    for (axis, val, face_area) in [(1usize, 0.0f32, 6.0f32), (1, -0.5, 6.0), (0, 1.0, 1.5), (2, 1.5, 1.0)] {
        let count = pts.iter().filter(|q| (q.p.to_array()[axis] - val).abs() < 1e-5).count() as f32;
        let expect = face_area / total * pts.len() as f32;
        assert!((count - expect).abs() <= 2.0, "face {axis}={val}: {count} vs {expect}");
    }
    // building twice gives bit-identical caches (thread scheduling plays no part)
    let a = &w.diffusion.bodies[0].tree;
    let b = &dome_box_world().diffusion.bodies[0].tree;
    assert_eq!(a.points(), b.points());
}

#[test]
fn cached_irradiance_is_the_fresnel_transmitted_sky_irradiance() {
    // top face under a uniform sky: E_t(λ) = L(λ) · 2π ∫ T(μ) μ dμ. Each point's 64 samples
    // are a shifted Sobol net: 1.3% relative spread per point measured (random samples gave
    // 17%); the mean over the ~2600 points of the top is then exact to ~0.1%, so 1% (the
    // mean of an unstratified estimate would also pass; the per-point bound below would not)
    let w = dome_box_world();
    let tree = &w.diffusion.bodies[0].tree;
    let top: Vec<&IrradiancePoint> = tree.points().iter().filter(|q| q.p.y.abs() < 1e-5).collect();
    assert!(top.len() > 500);
    let mut t_int = 0.0f64;
    for k in 0..4000 {
        let mu = (k as f64 + 0.5) / 4000.0;
        t_int += (1.0 - fresnel_dielectric(mu as f32, 1.333) as f64) * mu * 2.0 * std::f64::consts::PI / 4000.0;
    }
    for g in 0..N_BINS / 4 {
        let lambda = SampledWavelengths { lambda: std::array::from_fn(|k| bin_lambda(g * 4 + k)), pdf: [1.0; 4] };
        let l = w.lights[0].le(Vec3::Y, &lambda);
        for k in 0..4 {
            let b = g * 4 + k;
            let mean = top.iter().map(|q| q.e[b] as f64).sum::<f64>() / top.len() as f64;
            let expect = l[k] as f64 * t_int;
            assert!((mean / expect - 1.0).abs() < 0.01, "bin {b}: {mean} vs {expect}");
            // per point: rms spread 1.3% measured, 17% with unstratified samples: 5%
            let rms = (top.iter().map(|q| (q.e[b] as f64 / expect - 1.0).powi(2)).sum::<f64>() / top.len() as f64).sqrt();
            assert!(rms < 0.05, "bin {b}: per-point spread {rms}");
        }
    }
    // the mean refracted direction of a uniform sky is straight in
    let d = top.iter().fold(Vec3::ZERO, |a, q| a + q.dir).normalize();
    assert!(d.dot(-Vec3::Y) > 0.99, "{d:?}");
}

/// 24 point lights over the top face (the many-light tree picks among them by what each gives
/// a point; the cache's estimate weighs a pick by its probability): the irradiance summed over
/// the top's points is that of Σ I(λ) T(cos θ) cos θ / d² over the lights, within 1 %.
#[test]
fn cached_irradiance_from_many_point_lights_is_their_fresnel_transmitted_sum() {
    use crate::scene::*;
    let mut s = diffusion_box(Vec3::new(-1.0, -0.5, -1.5), Vec3::new(1.0, 0.0, 1.5), 10.0);
    let mut rng = TestRng::new(11);
    for k in 0..24 {
        let at = Vec3::new(rng.next_f32() * 6.0 - 3.0, 0.5 + rng.next_f32() * 2.5, rng.next_f32() * 6.0 - 3.0);
        let intensity = 1.0 + 20.0 * rng.next_f32();
        s.lights.push(LightDesc { name: format!("/bulb{k}"), shape: LightShape::Sphere { radius: 0.1, treat_as_point: true }, transform: glam::Mat4::from_translation(at), color: [1.0; 3], intensity, exposure: 0.0, normalize: false, color_temperature: None, visible_to_camera: true, light_link: None, shadow_link: None, shadow: Default::default(), shaping: None, response: Default::default(), motion: Vec::new(), portals: Vec::new() });
    }
    let w = crate::testing::world_of(&s);
    assert!(w.light_tree.has_tree());
    let top: Vec<&IrradiancePoint> = w.diffusion.bodies[0].tree.points().iter().filter(|q| q.p.y.abs() < 1e-5).collect();
    assert!(top.len() > 500);
    for g in 0..N_BINS / 4 {
        let lambda = SampledWavelengths { lambda: std::array::from_fn(|k| bin_lambda(g * 4 + k)), pdf: [1.0; 4] };
        let (mut got, mut expect, mut spread) = ([0.0f64; 4], [0.0f64; 4], 0.0f64);
        for q in &top {
            let mut here = [0.0f64; 4];
            for light in &w.lights {
                let crate::light::Light::Point(pl) = light else { panic!("point lights only") };
                let d = pl.p - q.p;
                let cos = (d.y / d.length()) as f64;
                let t = 1.0 - fresnel_dielectric(cos as f32, 1.333) as f64;
                let i = pl.emission.sample(&lambda);
                for k in 0..4 {
                    here[k] += i[k] as f64 * t * cos / d.length_squared() as f64;
                }
            }
            for k in 0..4 {
                got[k] += q.e[g * 4 + k] as f64;
                expect[k] += here[k];
                spread += (q.e[g * 4 + k] as f64 / here[k] - 1.0).powi(2);
            }
        }
        // each point's 64 picks follow what each light gives it: a per-point spread of 6.6 %
        // measured (10.9 % picking by power alone)
        let rms = (spread / (4 * top.len()) as f64).sqrt();
        assert!(rms < 0.08, "bins {}..{}: per-point spread {rms}", g * 4, g * 4 + 3);
        for k in 0..4 {
            assert!((got[k] / expect[k] - 1.0).abs() < 0.01, "bin {}: {} vs {}", g * 4 + k, got[k], expect[k]);
        }
    }
}

/// π/norm · ∫ eval dA over the plane for light entering at the origin along `w12` (y up):
/// the model's flux leaving per unit flux entering. Polar grid: log r × uniform φ.
fn model_flux_2d(p: &DipoleParams, w12: Vec3) -> f64 {
    let (nr, nphi) = (1500, 96);
    let (a, b) = ((1e-6f64).ln(), (60.0 / p.sigma_tr as f64).min(1e4 / p.sigma_t_r as f64).ln());
    let h = (b - a) / nr as f64;
    let mut s = 0.0;
    for i in 0..nr {
        let r = (a + h * (i as f64 + 0.5)).exp();
        for j in 0..nphi {
            let phi = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / nphi as f64;
            let xo = Vec3::new((r * phi.cos()) as f32, 0.0, (r * phi.sin()) as f32);
            s += p.eval(Vec3::ZERO, Vec3::Y, w12, xo, Vec3::Y) as f64 * r * r;
        }
    }
    std::f64::consts::PI * s * h * 2.0 * std::f64::consts::PI / nphi as f64 / p.norm as f64
}

/// The renderer's profile for `alpha`, `eta`: the directional dipole with its factor from the
/// boundary's [`NormTable`].
fn normalized(alpha: f32, eta: f32) -> DipoleParams {
    let (c, e) = boundary_terms(eta);
    let (co, _) = boundary_terms(1.0 / eta);
    let p = DipoleParams::new(1.0 - alpha, alpha, 0.0, eta).unwrap().with_model(ProfileModel::DirectionalNormalized);
    DipoleParams { scale: NormTable::new(c, e, co).scale(p.albedo_r), ..p }
}

#[test]
fn normalized_directional_dipole_has_the_classical_total_at_normal_incidence() {
    // the table's nodes and the points between them (α' 0.952 is the render tests' water):
    // the quadrature of the table and of this test differ (1D log grid vs the 2D polar grid
    // below, ~1e-4) and the linear interpolation in u between 64 nodes is good to ~1e-3 of
    // the ratio: 0.5%. Without the factor the total is 1.3–1.45× the classical one.
    for &(alpha, eta) in &[(0.952f32, 1.333f32), (0.99, 1.333), (0.9, 1.0), (0.995, 1.5), (0.6, 1.333)] {
        let p = normalized(alpha, eta);
        let total = model_flux_2d(&p, -Vec3::Y);
        let classical = classic_rd_total(p.albedo_r, p.a) as f64;
        assert!((total / classical - 1.0).abs() < 0.005, "α' {alpha} η {eta}: {total} vs classical {classical}");
        let raw = model_flux_2d(&p.with_model(ProfileModel::Directional), -Vec3::Y);
        assert!(raw / classical > 1.2, "α' {alpha} η {eta}: unnormalised {raw}");
    }
}

#[test]
fn normalized_directional_dipole_follows_a_random_walk_at_oblique_incidence() {
    // The reason for the renderer's profile: a half-space's total diffuse reflectance grows
    // as the light enters more obliquely (the first collisions are shallower). The classical
    // dipole cannot see the direction (its total is the same at every angle: measured −12.1%
    // against the walk at cosθ = 0.4, α' 0.952, η 1.333); the normalised directional dipole
    // follows it: measured +3.9, +3.7, +2.3, +1.6% (α' 0.952) and +0.3, −0.7, −1.7, −3.1%
    // (α' 0.99) at cosθ = 1, 0.8, 0.6, 0.4 inside a water boundary. The walk's standard
    // error is ≤ 0.5% with 40 000 photons: 5% (the classical dipole fails at cosθ ≤ 0.6).
    // Index-matched (η = 1) both fall 6–10% short at cosθ 0.4–0.6; diffusion from a
    // boundary without reflection is known to be worse (docs/diffusion.md).
    for &alpha in &[0.952f32, 0.99] {
        let p = normalized(alpha, 1.333);
        for &ct in &[1.0f64, 0.8, 0.6, 0.4] {
            let (walk, _) = random_walk_oblique(alpha as f64, 1.333, 40_000, 21, &[0.0, 1.0], ct);
            let w12 = Vec3::new((1.0 - ct * ct).sqrt() as f32, -(ct as f32), 0.0);
            let m = model_flux_2d(&p, w12);
            assert!((m / walk - 1.0).abs() < 0.05, "α' {alpha} cosθ {ct}: model {m} vs walk {walk}");
        }
    }
}
