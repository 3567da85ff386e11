//! The caustics integrator against the path tracer on scenes where both converge (the sun
//! widened to 5°): surface caustics under a wavy water surface seen from above (caustics seen
//! through waves: S–D–S paths), and a focused caustic of a glass sphere under a sphere light;
//! determinism across thread counts, learning included; the `tide:caustics` AOV and the
//! split summing to colour; switch-to-transparency.

mod common;
use common::*;
use glam::{Mat4, Vec3};
use tide_core::render::IntegratorKind;
use tide_core::scene::*;
use tide_core::{Aov, RenderSettings, Renderer};

/// A pool: a diffuse floor and walls under 0.8 m of clear water with a wavy top, seen from
/// above, under a sun of the given angle and a dim sky.
pub fn pool(sun_angle: f32) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/floor", 2.0)));
    s.meshes.push(std::sync::Arc::new(wavy_water(2.0, 48, 0.04, -0.801)));
    s.media.push(MediumDesc { name: "/clear".into(), sigma_a: SpectrumDesc::Rgb([0.45, 0.06, 0.02]), sigma_s: SpectrumDesc::Rgb([0.0; 3]), scale: 1.0, phase: PhaseDesc::Isotropic, water: None, method: Default::default() });
    s.materials.push(MaterialDesc { name: "/floor".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.6, 0.6, 0.6]) }, interior_medium: None });
    s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { ior: 1.333, ..Default::default() }), interior_medium: Some(0) });
    s.instances_mut().push(instance("/floor", GeometryRef::Mesh(0), Mat4::from_translation(Vec3::new(0.0, -0.8, 0.0)), 0));
    s.instances_mut().push(instance("/water", GeometryRef::Mesh(1), Mat4::IDENTITY, 1));
    s.lights.push(sun(sun_angle, 60.0, 200.0));
    s.lights.push(dome(0.05));
    s.camera = camera(Vec3::new(0.0, 1.6, 1.2), Vec3::new(0.0, -0.8, -0.1), 50.0);
    s
}

/// A glass sphere on a diffuse floor under a small sphere light.
pub fn glass_sphere(light_radius: f32) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/floor", 3.0)));
    s.meshes.push(std::sync::Arc::new(uv_sphere("/ball", 0.3, 48)));
    s.materials.push(MaterialDesc { name: "/floor".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.7, 0.7, 0.7]) }, interior_medium: None });
    s.materials.push(MaterialDesc { name: "/glass".into(), surface: SurfaceDesc::Water(WaterDesc { ior: 1.5, ..Default::default() }), interior_medium: None });
    s.instances_mut().push(instance("/floor", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    s.instances_mut().push(instance("/ball", GeometryRef::Mesh(1), Mat4::from_translation(Vec3::new(0.0, 0.3, 0.0)), 1));
    s.lights.push(light("/bulb", LightShape::Sphere { radius: light_radius, treat_as_point: false }, Mat4::from_translation(Vec3::new(0.6, 1.5, 0.3)), 2400.0 * (0.02f32 / light_radius).powi(2), false));
    s.camera = camera(Vec3::new(-1.64, 1.15, -0.83), Vec3::new(-0.1, 0.12, -0.05), 45.0);
    s
}

fn settings_for(kind: IntegratorKind, w: u32, h: u32, spp: u32, threads: usize) -> tide_core::RenderSettings {
    let mut s = settings(w, h, spp);
    s.integrator = kind;
    s.threads = threads;
    s
}

/// Per-block means (luminance-ish: channel sum) of the colour AOV and their standard errors
/// from the pixel spread within the block.
fn block_means(r: &Renderer, w: u32, h: u32, bw: u32, bh: u32) -> Vec<(f64, f64)> {
    let px = r.aov_pixels(Aov::Color);
    let mut out = Vec::new();
    for by in 0..h / bh {
        for bx in 0..w / bw {
            let mut v = Vec::new();
            for y in by * bh..(by + 1) * bh {
                for x in bx * bw..(bx + 1) * bw {
                    let i = ((y * w + x) * 4) as usize;
                    v.push((px[i] + px[i + 1] + px[i + 2]) as f64);
                }
            }
            let n = v.len() as f64;
            let m = v.iter().sum::<f64>() / n;
            let var = v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
            out.push((m, (var / n).sqrt()));
        }
    }
    out
}

#[test]
#[ignore]
fn explore_pool() {
    let w: u32 = std::env::var("W").ok().and_then(|v| v.parse().ok()).unwrap_or(64);
    let h = w * 3 / 4;
    let spp: u32 = std::env::var("SPP").ok().and_then(|v| v.parse().ok()).unwrap_or(16);
    let angle: f32 = std::env::var("ANGLE").ok().and_then(|v| v.parse().ok()).unwrap_or(5.0);
    let mut scene = pool(angle);
    if std::env::var("CLEAR").is_ok() {
        scene.media[0].sigma_a = SpectrumDesc::Rgb([0.0; 3]);
    }
    let kinds: Vec<IntegratorKind> = if std::env::var("ONLY_CAUSTICS").is_ok() { vec![IntegratorKind::Caustics] } else { vec![IntegratorKind::Path, IntegratorKind::Caustics] };
    for kind in kinds {
        let t = std::time::Instant::now();
        let mut st = settings_for(kind, w, h, spp, 2);
        if let Some(nm) = std::env::var("NM").ok().and_then(|v| v.parse().ok()) {
            st.caustics.spectral_radius_nm = nm;
        }
        let r = render_progressive(&scene, st);
        let px = r.aov_pixels(Aov::Color);
        let c = r.aov_pixels(Aov::Caustics);
        let mean: f64 = px.chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / (w * h) as f64;
        let cm: f64 = c.chunks_exact(3).map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / (w * h) as f64;
        println!("{kind:?}: mean {mean:.5} caustics {cm:.5} time {:.2}s stats {:?}", t.elapsed().as_secs_f64(), r.stats().caustics);
        let b = block_means(&r, w, h, w / 4, h / 3);
        println!("  blocks {:?}", b.iter().map(|(m, s)| format!("{m:.4}±{s:.4}")).collect::<Vec<_>>());
        if let Ok(dir) = std::env::var("OUT") {
            let p = std::path::Path::new(&dir).join(format!("pool_{kind:?}.exr"));
            r.write_exr(&p, &[Aov::Color, Aov::Caustics], &[]).unwrap();
        }
    }
}

/// Compares two renders region by region: for each block, the difference of the means must lie
/// within `k` combined standard errors. Returns the largest |difference| / σ seen.
fn assert_blocks_agree(a: &[(f64, f64)], b: &[(f64, f64)], k: f64, what: &str) -> f64 {
    let mut worst = 0.0f64;
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        let sigma = (x.1 * x.1 + y.1 * y.1).sqrt().max(1e-6);
        let z = (x.0 - y.0).abs() / sigma;
        worst = worst.max(z);
        assert!(z < k, "{what}: block {i}: {:.4}±{:.4} vs {:.4}±{:.4} ({z:.1}σ)", x.0, x.1, y.0, y.1);
    }
    worst
}

fn image_mean(r: &Renderer, aov: Aov) -> f64 {
    let px = r.aov_pixels(aov);
    let ch = aov.channels();
    px.chunks_exact(ch).map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>() / (px.len() / ch) as f64
}

/// Compares a caustics render with a path-traced one: 8×8-pixel regions (4σ, see
/// [`assert_blocks_agree`]) and the image means (4σ of their combined standard errors).
/// Returns (worst region in σ, path mean, caustics mean, means' distance in σ).
fn assert_agree_with_path(path: &Renderer, caus: &Renderer, w: u32, h: u32, what: &str) -> (f64, f64, f64, f64) {
    let bp = block_means(path, w, h, 8, 8);
    let bc = block_means(caus, w, h, 8, 8);
    let worst = assert_blocks_agree(&bp, &bc, 4.0, what);
    let (mp, mc) = (image_mean(path, Aov::Color), image_mean(caus, Aov::Color));
    let se = |b: &[(f64, f64)]| (b.iter().map(|x| x.1 * x.1).sum::<f64>()).sqrt() / b.len() as f64;
    let z = (mp - mc).abs() / (se(&bp).powi(2) + se(&bc).powi(2)).sqrt();
    assert!(z < 4.0, "{what}: image means {mp:.4} vs {mc:.4} ({z:.1}σ)");
    (worst, mp, mc, z)
}

// The sun is widened to 8° so that the path tracer, which reaches it only through BSDF-sampled
// refraction, converges in a test's time. 8 regions of 8×8 pixels (plus the image mean) must
// agree within 4σ of the combined standard errors (9 comparisons: a 4σ bound fails by chance
// with probability < 0.1%). The caustic share of the image is checked to be large, so that a
// caustics integrator that dropped or doubled photon light would fail.
#[test]
fn surface_caustics_seen_through_waves_agree_with_path_tracing() {
    let (w, h) = (32, 16);
    let scene = pool(8.0);
    let path = render_progressive(&scene, settings_for(IntegratorKind::Path, w, h, 768, 2));
    let caus = render_progressive(&scene, settings_for(IntegratorKind::Caustics, w, h, 64, 2));
    let (worst, mp, mc, _) = assert_agree_with_path(&path, &caus, w, h, "pool regions");
    let bp = block_means(&path, w, h, 8, 8);
    let bc = block_means(&caus, w, h, 8, 8);
    let share = image_mean(&caus, Aov::Caustics) / mc;
    assert!(share > 0.3, "photons carry only {share:.2} of the image");
    // the photon estimate is far less noisy than the path tracer's at 12× fewer samples
    let noise = |b: &[(f64, f64)]| b.iter().map(|x| x.1).sum::<f64>();
    assert!(noise(&bc) < noise(&bp), "caustics noisier than path: {} vs {}", noise(&bc), noise(&bp));
    println!("worst block {worst:.2}σ, means {mp:.4} / {mc:.4}, caustic share {share:.2}");
}

// A glass sphere focusing a 10 cm sphere light onto the floor (light–specular–specular–diffuse
// paths): the caustic under the sphere and the rest of the floor agree with path tracing by
// region, with the bound of the test above.
#[test]
fn a_glass_sphere_caustic_agrees_with_path_tracing() {
    let (w, h) = (32, 24);
    let scene = glass_sphere(0.1);
    let path = render_progressive(&scene, settings_for(IntegratorKind::Path, w, h, 512, 2));
    let caus = render_progressive(&scene, settings_for(IntegratorKind::Caustics, w, h, 64, 2));
    let bp = block_means(&path, w, h, 8, 8);
    let bc = block_means(&caus, w, h, 8, 8);
    assert_blocks_agree(&bp, &bc, 4.0, "sphere regions");
    let share = image_mean(&caus, Aov::Caustics) / image_mean(&caus, Aov::Color);
    assert!(share > 0.02, "no caustic light: {share}");
}

// The same caustic from a spot light (UsdLuxShapingAPI) aimed at the sphere, with a cone
// narrower than the sphere and a soft edge and a focus: the photons the atlas aims at the
// sphere carry the shaping of their own direction (not of the direction the light's emission
// sampler drew), which only then agrees with path tracing. The light's diffuse and specular
// multipliers (1.5, 0.5) must meet the same lobes in both.
#[test]
fn a_spot_lights_caustic_agrees_with_path_tracing() {
    let (w, h) = (32, 24);
    let mut scene = glass_sphere(0.2);
    let pos = Vec3::new(0.6, 1.5, 0.3);
    let aim = (Vec3::new(0.0, 0.3, 0.0) - pos).normalize();
    let l = &mut scene.lights[0];
    l.transform = Mat4::from_rotation_translation(glam::Quat::from_rotation_arc(Vec3::NEG_Z, aim), pos);
    l.shaping = Some(tide_core::scene::ShapingDesc { cone_angle_deg: 25.0, cone_softness: 0.6, focus: 8.0, focus_tint: [0.0; 3], ..Default::default() });
    // and UsdLux's multipliers: the caustic is light first gathered by the glass (specular), the
    // floor's direct light diffuse; photons and paths must agree on which is which
    l.response = LightResponse { diffuse: 1.5, specular: 0.5 };
    let path = render_progressive(&scene, settings_for(IntegratorKind::Path, w, h, 4096, 2));
    let caus = render_progressive(&scene, settings_for(IntegratorKind::Caustics, w, h, 256, 2));
    let (worst, mp, mc, z) = assert_agree_with_path(&path, &caus, w, h, "spot regions");
    // the photons carry the specular multiplier: at 1 instead of 0.5 the caustic AOV grows by
    // 2 exactly (the paths and the photons are the same samples; the atlas learns from
    // visibility, not power; without the multiplier the ratio is 1). A power of two keeps every
    // ratio of photon powers (the stochastic lookups', the atlas's) bit for bit; another factor
    // rounds them differently and the two renders' samples part ways.
    scene.lights[0].response.specular = 1.0;
    let caus1 = render_progressive(&scene, settings_for(IntegratorKind::Caustics, w, h, 256, 2));
    let ratio = image_mean(&caus, Aov::Caustics) / image_mean(&caus1, Aov::Caustics);
    assert!((ratio - 0.5).abs() < 1e-4, "caustic light at specular 0.5 over 1: {ratio}");
    let share = image_mean(&caus, Aov::Caustics) / mc;
    // photons carry about 0.22 of this image; taking their power along the direction the
    // light's sampler drew instead of their aim leaves 0.03
    assert!(share > 0.1, "too little caustic light: {share}");
    println!("worst block {worst:.2}σ, means {mp:.4} / {mc:.4} ({z:.1}σ), caustic share {share:.2}");
}

// Same seed → identical bits for 1 and 2 threads, over progressive passes in which the atlas
// learns from the visibility signal; the split AOVs (caustics included) sum to colour.
#[test]
fn caustics_are_deterministic_across_thread_counts() {
    let scene = pool(0.53);
    let a = render_progressive(&scene, settings_for(IntegratorKind::Caustics, 24, 16, 15, 1));
    let b = render_progressive(&scene, settings_for(IntegratorKind::Caustics, 24, 16, 15, 2));
    assert_eq!(a.stats().caustics.as_ref().unwrap().passes, 4);
    for aov in [Aov::Color, Aov::Caustics, Aov::Diffuse, Aov::Guiding] {
        let (x, y) = (a.aov_pixels(aov), b.aov_pixels(aov));
        assert!(x.iter().zip(&y).all(|(p, q)| p.to_bits() == q.to_bits()), "{aov:?} differs across thread counts");
    }
    let (ia, ib) = (a.caustics().unwrap().atlas().to_image(), b.caustics().unwrap().atlas().to_image());
    assert!(ia.2.iter().zip(&ib.2).all(|(p, q)| p.to_bits() == q.to_bits()), "learned tables differ");
    // the split sums to colour
    let c = a.aov_pixels(Aov::Color);
    let parts: Vec<Vec<f32>> = tide_core::film::SPLIT_AOVS.iter().map(|&x| a.aov_pixels(x)).collect();
    for i in 0..(24 * 16) as usize {
        for k in 0..3 {
            let sum: f32 = parts.iter().map(|p| p[i * 3 + k]).sum();
            assert!((sum - c[i * 4 + k]).abs() <= 1e-4 * (1.0 + c[i * 4 + k].abs()), "pixel {i}: split {sum} vs colour {}", c[i * 4 + k]);
        }
    }
    assert!(image_mean(&a, Aov::Caustics) > 0.0);
    // the guiding debug AOV shows the table: probabilities and visibility scaled to 1, and
    // the pairs' cells; the path integrator leaves it black
    let g = a.aov_pixels(Aov::Guiding);
    let max = |k: usize| g.chunks_exact(3).map(|p| p[k]).fold(0.0f32, f32::max);
    assert!((max(0) - 1.0).abs() < 1e-6 && (max(1) - 1.0).abs() < 1e-6 && max(2) == 1.0, "{} {} {}", max(0), max(1), max(2));
    let p = render(&scene, settings_for(IntegratorKind::Path, 8, 8, 1, 1));
    assert!(p.aov_pixels(Aov::Guiding).iter().all(|v| *v == 0.0));
    // under water, light tracing splats onto the image while photons are traced in parallel:
    // still the same bits
    let scene = underwater(8.0);
    let a = render_progressive(&scene, settings_for(IntegratorKind::Caustics, 16, 8, 7, 1));
    let b = render_progressive(&scene, settings_for(IntegratorKind::Caustics, 16, 8, 7, 2));
    assert!(a.stats().caustics.unwrap().light_connections > 0);
    for aov in [Aov::Color, Aov::Caustics] {
        let (x, y) = (a.aov_pixels(aov), b.aov_pixels(aov));
        assert!(x.iter().zip(&y).all(|(p, q)| p.to_bits() == q.to_bits()), "{aov:?} differs across thread counts under water");
    }
}

// Switch-to-transparency: a flat, clear water surface set `all` under a delta sun lets the
// floor's shadow rays through, so the floor seen straight down through the surface reads
// T(0)/n² of the floor without water (the camera's ray still refracts: radiance compresses by
// n² and loses the Fresnel reflectance). Without transparency the delta sun could not reach
// the floor at all and the ratio would be ~0.
#[test]
fn transparency_lets_shadow_rays_through_water() {
    let mk = |water: bool| {
        let mut s = SceneDesc::default();
        s.meshes.push(std::sync::Arc::new(quad_y("/floor", 4.0)));
        s.materials.push(MaterialDesc { name: "/floor".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.6, 0.6, 0.6]) }, interior_medium: None });
        s.instances_mut().push(instance("/floor", GeometryRef::Mesh(0), Mat4::from_translation(Vec3::new(0.0, -0.8, 0.0)), 0));
        if water {
            s.meshes.push(std::sync::Arc::new(box_mesh("/water", Vec3::new(-4.0, -0.801, -4.0), Vec3::new(4.0, 0.0, 4.0))));
            s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { ior: 1.333, ..Default::default() }), interior_medium: None });
            s.instances_mut().push(instance("/water", GeometryRef::Mesh(1), Mat4::IDENTITY, 1));
            s.caustics.objects.push(("/water".into(), ObjectCaustics { caster: None, receiver: true, transparency: CausticsTransparency::All }));
        }
        s.lights.push(sun(0.0, 60.0, 200.0));
        s.camera = camera(Vec3::new(0.0, 2.0, 0.0), Vec3::new(0.0, -0.8, 0.0), 10.0);
        s
    };
    let (w, h) = (16, 16);
    let with = render(&mk(true), settings_for(IntegratorKind::Caustics, w, h, 16, 2));
    let without = render(&mk(false), settings_for(IntegratorKind::Path, w, h, 16, 2));
    let ratio = image_mean(&with, Aov::Color) / image_mean(&without, Aov::Color);
    let r0 = ((1.333f64 - 1.0) / (1.333 + 1.0)).powi(2);
    let expected = (1.0 - r0) / (1.333f64 * 1.333);
    // 2%: Fresnel transmittance varies by < 0.1% over the 10° field; the rest is noise of 16
    // samples on a uniformly lit floor (< 0.5%)
    assert!((ratio / expected - 1.0).abs() < 0.02, "ratio {ratio:.4}, expected {expected:.4}");
    assert!(with.caustics().is_none(), "a transparent water body must not cast caustics");
}

#[test]
#[ignore]
fn explore_underwater() {
    let w: u32 = std::env::var("W").ok().and_then(|v| v.parse().ok()).unwrap_or(48);
    let h = w / 2;
    let spp: u32 = std::env::var("SPP").ok().and_then(|v| v.parse().ok()).unwrap_or(64);
    let pspp: u32 = std::env::var("PSPP").ok().and_then(|v| v.parse().ok()).unwrap_or(spp);
    let angle: f32 = std::env::var("ANGLE").ok().and_then(|v| v.parse().ok()).unwrap_or(8.0);
    let scene = underwater(angle);
    for (kind, n) in [(IntegratorKind::Path, pspp), (IntegratorKind::Caustics, spp)] {
        let t = std::time::Instant::now();
        let r = render_progressive(&scene, settings_for(kind, w, h, n, 2));
        println!("{kind:?} {n} spp: mean {:.5} caustics {:.5} time {:.2}s stats {:?}", image_mean(&r, Aov::Color), image_mean(&r, Aov::Caustics), t.elapsed().as_secs_f64(), r.stats().caustics);
        let b = block_means(&r, w, h, w / 4, h / 2);
        println!("  blocks {:?}", b.iter().map(|(m, s)| format!("{m:.4}±{s:.4}")).collect::<Vec<_>>());
        if let Ok(dir) = std::env::var("OUT") {
            let p = std::path::Path::new(&dir).join(format!("uw_{kind:?}.exr"));
            r.write_exr(&p, &[Aov::Color, Aov::Caustics], &[]).unwrap();
        }
    }
}

// God rays and caustics seen from under a wavy surface in scattering water, with the sun
// widened to 16° so that the path tracer (which reaches the sun from a volume vertex only
// through BSDF-sampled refraction) converges within a test: regions agree within 4σ. The
// photon beams carry a large share of the light, so a beam estimator off by more than the
// bound would fail.
#[test]
fn god_rays_agree_with_path_tracing() {
    let (w, h) = (24, 12);
    let scene = underwater(16.0);
    let path = render_progressive(&scene, settings_for(IntegratorKind::Path, w, h, 1024, 2));
    let caus = render_progressive(&scene, settings_for(IntegratorKind::Caustics, w, h, 64, 2));
    let bp = block_means(&path, w, h, 6, 6);
    let bc = block_means(&caus, w, h, 6, 6);
    assert_blocks_agree(&bp, &bc, 4.0, "underwater regions");
    let st = caus.stats().caustics.clone().unwrap();
    assert!(st.beams_stored > 0, "no beams");
    // the camera is in the water: the god rays it sees directly come from light tracing
    assert!(st.light_connections > 0, "no photon stretch connected to the camera");
    let share = image_mean(&caus, Aov::Caustics) / image_mean(&caus, Aov::Color);
    assert!(share > 0.3, "photons and beams carry only {share:.2}");
    // with light tracing off, beams take the camera's first stretch too, and agree as well
    let mut s = settings_for(IntegratorKind::Caustics, w, h, 64, 2);
    s.caustics.light_tracing = false;
    let beams_only = render_progressive(&scene, s);
    assert_eq!(beams_only.stats().caustics.unwrap().light_connections, 0);
    assert_blocks_agree(&bp, &block_means(&beams_only, w, h, 6, 6), 4.0, "underwater regions, beams only");
}

// God rays in water whose chlorophyll peaks at 1.5 m depth (the bio-optical model with a Gaussian
// profile, so σ varies along every beam and camera ray and both track their transmittance):
// caustics with beams and light tracing against path tracing under a 16° sun, region by region.
#[test]
fn god_rays_in_depth_varying_water_agree_with_path_tracing() {
    use tide_core::scene::{DepthProfileDesc, JerlovDesc, WaterIopDesc};
    use tide_core::water::{JerlovSource, JerlovType};
    let (w, h) = (24, 12);
    let mut scene = underwater(16.0);
    scene.media[0] = MediumDesc {
        name: "/bloom".into(),
        sigma_a: SpectrumDesc::Rgb([0.0; 3]),
        sigma_s: SpectrumDesc::Rgb([0.0; 3]),
        scale: 1.0,
        phase: PhaseDesc::HenyeyGreenstein { g: 0.6 },
        water: Some(WaterIopDesc {
            jerlov: Some(JerlovDesc { water_type: JerlovType::II, source: JerlovSource::Williamson2022 }),
            chlorophyll: 0.2,
            profile: Some(DepthProfileDesc { depth: 1.5, width: 0.5, peak: 6.0 }),
            top: Some(0.0),
            ..WaterIopDesc::default()
        }),
        method: Default::default(),
    };
    let path = render_progressive(&scene, settings_for(IntegratorKind::Path, w, h, 2048, 2));
    // every beam kept: thinned beams in tracked water scatter single renders' means by ±8%
    let mut s = settings_for(IntegratorKind::Caustics, w, h, 64, 2);
    s.caustics.beams_per_pixel = 100.0;
    let caus = render_progressive(&scene, s);
    let st = caus.stats().caustics.clone().unwrap();
    assert!(st.beams_stored > 0 && st.light_connections > 0, "{st:?}");
    assert_blocks_agree(&block_means(&path, w, h, 6, 6), &block_means(&caus, w, h, 6, 6), 4.0, "depth-varying water");
    let (mp, mc) = (image_mean(&path, Aov::Color), image_mean(&caus, Aov::Color));
    // measured with two seeds each: path 0.881 / 0.884 (4096 spp), caustics 0.866 / 0.870, 1.6%
    // low (in uniform water 1% low, the 20 nm spectral kernel smoothing the water's absorption);
    // 5% bounds that and the noise of one 2048-spp path render (about 1%)
    assert!((mc / mp - 1.0).abs() < 0.05, "image means {mc} (caustics) vs {mp} (path)");
}

// Thinning keeps a random share of the beams, with their widths and their flux scaled by the
// share's inverse (so the expected image is the same): with the same seed, the thinned pass's
// beams are among the full pass's (the same photon paths, the same draw against a smaller
// share), each with the same width and 1/share its flux, and their number is the share of the
// full count within 4σ of the binomial; one thread keeps the same beams, bit for bit.
#[test]
fn thinned_beams_are_a_reweighted_share_of_the_full_set() {
    use tide_core::caustics::engine::{beam_thinning, Caustics};
    assert_eq!(beam_thinning(12288.0, 12288), 1.0);
    assert_eq!(beam_thinning(12288.0, 4 * 12288), 0.5);
    assert_eq!(beam_thinning(12288.0, 64 * 12288), 0.125);
    let (w, h) = (128, 64);
    let scene = underwater(8.0);
    let settings = settings_for(IntegratorKind::Caustics, w, h, 1, 2);
    let world = tide_core::world::World::build(&scene, &settings, &mut Vec::new());
    let pixels = (w * h) as u64;
    let beams_on = |threads: usize, thinning_pixels: f32| {
        let mut config = settings.caustics;
        config.beam_thinning_pixels = thinning_pixels;
        let mut c = Caustics::new(&world, w, h, config).expect("caustics");
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().expect("pool");
        pool.install(|| c.begin_pass(&world, 7, 1, pixels));
        c.beam_map().beams().to_vec()
    };
    let beams = |thinning_pixels: f32| beams_on(2, thinning_pixels);
    let full = beams(f32::INFINITY);
    let share = beam_thinning(pixels as f32 / 16.0, pixels);
    assert_eq!(share, 0.25);
    let thinned = beams(pixels as f32 / 16.0);
    // the same beams in the same order, bit for bit, on one thread
    let one = beams_on(1, pixels as f32 / 16.0);
    assert!(one.len() == thinned.len() && one.iter().zip(&thinned).all(|(a, b)| beam_key(a) == beam_key(b) && a.width.to_bits() == b.width.to_bits() && a.photon.energy().to_bits() == b.photon.energy().to_bits()), "thinned beams differ across thread counts");
    assert_reweighted_share(&full, &thinned, share);
}

type BeamKey = ([u32; 3], [u32; 3]);

fn beam_key(b: &tide_core::caustics::beams::Beam) -> BeamKey {
    (b.photon.position.to_array().map(f32::to_bits), b.dir.to_array().map(f32::to_bits))
}

/// `thinned` is a random share `share` of `full`: each of its beams is one of `full`'s (same
/// start and direction, bit for bit) with the same width, length and medium and 1/share its
/// flux, and their number is within 4σ of the binomial's mean.
fn assert_reweighted_share(full: &[tide_core::caustics::beams::Beam], thinned: &[tide_core::caustics::beams::Beam], share: f32) {
    let by_key: std::collections::HashMap<_, _> = full.iter().map(|b| (beam_key(b), b)).collect();
    assert_eq!(by_key.len(), full.len());
    for b in thinned {
        let f = by_key.get(&beam_key(b)).unwrap_or_else(|| panic!("a thinned beam not in the full set: {b:?}"));
        assert_eq!((b.width, b.len, b.medium), (f.width, f.len, f.medium));
        let ratio = b.photon.energy() / f.photon.energy();
        assert!((ratio * share - 1.0).abs() < 1e-5, "flux ratio {ratio} for a share of {share}");
    }
    let (n, k) = (full.len() as f64, thinned.len() as f64);
    let sigma = (n * share as f64 * (1.0 - share as f64)).sqrt();
    assert!(n > 1000.0 && (k - n * share as f64).abs() < 4.0 * sigma, "{k} of {n} beams kept for a share of {share}");
}

// The probe of a pass counts, for each beam query, the beams the query walks: those in its
// medium whose closest approach lies on the beam and on the query's ray before its end or its
// culling distance, within the beam's width (a scan of every beam, for queries through random
// points of random beams in random directions). Ending it keeps the share min(1, target / m)
// of the pass's beams, m the beams met per query that met any: a reweighted random share of
// them; the next pass traces that share (among the beams a pass that probes nothing traces).
#[test]
fn a_probe_counts_the_beams_queries_meet_and_thins_them_to_the_target() {
    use tide_core::caustics::beams::closest_approach;
    use tide_core::caustics::engine::{beam_share_for, Caustics};
    use tide_core::spectrum::SampledWavelengths;
    let (w, h) = (128, 64);
    let scene = underwater(8.0);
    let settings = settings_for(IntegratorKind::Caustics, w, h, 1, 2);
    let world = tide_core::world::World::build(&scene, &settings, &mut Vec::new());
    let pixels = (w * h) as u64;
    let target = 1.5;
    let new = |target: f32| {
        let mut config = settings.caustics;
        config.beams_per_query = target;
        Caustics::new(&world, w, h, config).expect("caustics")
    };
    let mut c = new(target);
    c.begin_pass(&world, 7, 1, pixels);
    assert!(c.wants_probe());
    let full = c.beam_map().beams().to_vec();
    let m = full[0].medium as usize;
    let fp = c.pixel_footprint();
    c.begin_probe();
    let mut rng = tide_core::testing::chi2::TestRng::new(5);
    let (mut meeting, mut met) = (0u64, 0u64);
    let queries = 400;
    for _ in 0..queries {
        let b = &full[(rng.next_f32() * full.len() as f32) as usize % full.len()];
        let p = b.photon.position + b.dir * (b.len * rng.next_f32());
        let dir = loop {
            let v = Vec3::new(rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0, rng.next_f32() * 2.0 - 1.0);
            if v.length_squared() > 0.01 && v.length_squared() < 1.0 {
                break v.normalize();
            }
        };
        let a = p - dir * (2.0 * rng.next_f32());
        let t_max = 1.0 + 3.0 * rng.next_f32();
        let lambda = SampledWavelengths::sample_uniform(rng.next_f32());
        let u = rng.next_f32();
        let before = c.probe_counts();
        let _ = c.gather_beams(&world, a, dir, t_max, m, &lambda, 0.5, &fp, u);
        let after = c.probe_counts();
        let t_end = t_max.min(c.beam_cull_distance(&world, m, &lambda, u));
        let expect = full
            .iter()
            .filter(|b| b.medium as usize == m && closest_approach(a, dir, b.photon.position, b.dir).is_some_and(|ap| ap.s >= 0.0 && ap.s <= b.len && ap.t >= 0.0 && ap.t <= t_end && ap.h < b.width))
            .count() as u64;
        assert_eq!((after[0] - before[0], after[2] - before[2]), (1, expect), "the probe's count of one query");
        assert_eq!(after[1] - before[1], (expect > 0) as u64);
        meeting += (expect > 0) as u64;
        met += expect;
    }
    assert_eq!(c.probe_counts(), [queries, meeting, met]);
    let mean = met as f64 / meeting as f64;
    // thinning to the target is meaningful here: queries meet several times as many beams
    assert!(mean > 2.5 * target as f64, "{mean} beams per query");
    let share = beam_share_for(target, mean);
    assert_eq!(share, (target as f64 / mean) as f32);
    c.end_probe(true);
    assert!(!c.wants_probe());
    assert_eq!((c.stats().beam_share, c.stats().beams_per_query), (share, Some(mean as f32)));
    assert_eq!(c.stats().beams_last_pass, c.beam_map().len() as u64);
    assert_reweighted_share(&full, c.beam_map().beams(), share);
    // the next pass: the share of what a pass without the rule traces
    c.end_pass(pixels);
    c.begin_pass(&world, 7, 1, pixels);
    let mut plain = new(f32::INFINITY);
    plain.begin_pass(&world, 7, 1, pixels);
    plain.end_pass(pixels);
    plain.begin_pass(&world, 7, 1, pixels);
    assert!(!plain.wants_probe());
    assert_reweighted_share(plain.beam_map().beams(), c.beam_map().beams(), share);
    // a probe cut short measures nothing: the next pass probes again
    let mut cut = new(target);
    cut.begin_pass(&world, 7, 1, pixels);
    cut.begin_probe();
    cut.end_probe(false);
    assert!(cut.wants_probe() && cut.beam_map().len() == full.len());
    // a target above the beams met keeps them all
    assert_eq!(beam_share_for(target, 0.9 * target as f64), 1.0);
    assert_eq!(beam_share_for(target, 0.0), 1.0);
}

// A beam's width follows the density of the beams, whatever else the scene holds: a ground
// plane 100 km wide far below the sand (out of the camera's sight, the scene's radius 70 km)
// leaves the god-ray scene's beams as wide as without it (a floor set by the scene's size
// made them 0.7 m wide, 3.5 times their 0.2 m).
#[test]
fn beam_widths_do_not_depend_on_a_far_ground_plane() {
    use tide_core::caustics::engine::Caustics;
    let (w, h) = (128, 64);
    let settings = settings_for(IntegratorKind::Caustics, w, h, 1, 2);
    let mean_width = |scene: &SceneDesc| {
        let world = tide_core::world::World::build(scene, &settings, &mut Vec::new());
        let mut c = Caustics::new(&world, w, h, settings.caustics).expect("caustics");
        c.begin_pass(&world, 7, 1, (w * h) as u64);
        let b = c.beam_map().beams();
        assert!(b.len() > 500, "{} beams", b.len());
        b.iter().map(|b| b.width as f64).sum::<f64>() / b.len() as f64
    };
    let scene = underwater(8.0);
    let mut far = scene.clone();
    far.meshes.push(std::sync::Arc::new(quad_y("/far", 5.0e4)));
    let g = GeometryRef::Mesh(far.meshes.len() - 1);
    far.instances_mut().push(instance("/far", g, Mat4::from_translation(Vec3::new(0.0, -500.0, 0.0)), 0));
    let (near_w, far_w) = (mean_width(&scene), mean_width(&far));
    assert!(near_w > 0.05 && (far_w / near_w - 1.0).abs() < 0.05, "mean beam width {near_w} without the far plane, {far_w} with it");
}

// Through the renderer: beams thinned by the probe leave the expected image as it was (the
// caustics AOV's mean over seeds against every beam kept, within 4σ of the seeds' scatter),
// the render is the same bit for bit on one thread and two, and the stats say what was kept.
#[test]
fn beams_thinned_by_the_probe_keep_the_image() {
    let (w, h) = (64, 32);
    let scene = underwater(8.0);
    let run = |target: f32, seed: u64, threads: usize| {
        let mut s = settings_for(IntegratorKind::Caustics, w, h, 4, threads);
        s.seed = seed;
        s.caustics.beams_per_query = target;
        render_progressive(&scene, s)
    };
    let seeds = 7..=12u64;
    let stats = |target: f32| {
        let means: Vec<f64> = seeds.clone().map(|seed| image_mean(&run(target, seed, 2), Aov::Caustics)).collect();
        let n = means.len() as f64;
        let mean = means.iter().sum::<f64>() / n;
        let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (n - 1.0);
        (mean, var / n)
    };
    let target = 1.0;
    let r = run(target, 1, 2);
    let cs = r.stats().caustics.clone().expect("caustics stats");
    let m = cs.beams_per_query.expect("measured");
    assert!(m > 2.5 * target && (cs.beam_share - target / m).abs() < 1e-6, "{m} beams per query, share {}", cs.beam_share);
    let one = run(target, 1, 1);
    assert!(r.aov_pixels(Aov::Color).iter().zip(one.aov_pixels(Aov::Color)).all(|(a, b)| a.to_bits() == b.to_bits()), "thinned renders differ across thread counts");
    let (thin, v_thin) = stats(target);
    let (all, v_all) = stats(f32::INFINITY);
    let z = (thin - all) / (v_thin + v_all).sqrt();
    assert!(thin > 0.1 && z.abs() < 4.0, "caustics AOV means {thin} (thinned) vs {all} (every beam): {z}σ");
}

// A crop (`dataWindowNDC`) takes the whole image's photons: over sixteen seeds its pixels
// show the caustics the same pixels of the whole image show (the seeds' means over the crop
// within 4σ: 0.728 against 0.728; a make-up weight for the training pass counted in the
// image's camera samples rather than the crop's read 0.592) and are no noisier (mean
// per-pixel variance 0.84× the whole image's; a quarter of the photons for a quarter of the
// image gave 3.5×).
#[test]
fn a_crop_meets_the_whole_images_photon_density() {
    let (w, h) = (64, 32);
    let scene = underwater(8.0);
    let run = |crop: bool, seed: u64| {
        let mut s = settings_for(IntegratorKind::Caustics, w, h, 4, 2);
        s.seed = seed;
        if crop {
            // the lower left quarter (NDC y up): x < w/2, y ≥ h/2
            s.data_window_ndc = [0.0, 0.0, 0.5, 0.5];
        }
        render_progressive(&scene, s)
    };
    let ch = Aov::Caustics.channels();
    let in_crop = |i: usize| {
        let (x, y) = ((i / ch) as u32 % w, (i / ch) as u32 / w);
        x < w / 2 && y >= h / 2
    };
    // (mean per-pixel variance over the seeds, [each seed's mean over the crop's pixels])
    let variance = |crop: bool| {
        let images: Vec<Vec<f32>> = (1..=16u64).map(|seed| run(crop, seed).aov_pixels(Aov::Caustics)).collect();
        let n = images.len() as f64;
        let (mut sum, mut count) = (0.0, 0);
        let mut means = vec![0.0f64; images.len()];
        for i in (0..images[0].len()).step_by(ch).filter(|i| in_crop(*i)) {
            let v: Vec<f64> = images.iter().map(|im| (0..3).map(|k| im[i + k] as f64).sum()).collect();
            let m = v.iter().sum::<f64>() / n;
            sum += v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (n - 1.0);
            count += 1;
            means.iter_mut().zip(&v).for_each(|(a, x)| *a += x);
        }
        (sum / count as f64, means.into_iter().map(|m| m / count as f64).collect::<Vec<f64>>())
    };
    let (full, cropped) = (run(false, 1), run(true, 1));
    let (a, b) = (full.stats().caustics.clone().unwrap(), cropped.stats().caustics.clone().unwrap());
    assert_eq!(a.photons_emitted, b.photons_emitted, "photons emitted for the whole image and for a quarter of it");
    let outside = cropped.aov_pixels(Aov::Caustics).iter().enumerate().filter(|(i, v)| !in_crop(*i - *i % ch) && **v != 0.0).count();
    assert_eq!(outside, 0, "the crop rendered pixels outside it");
    let ((vf, mf), (vc, mc)) = (variance(false), variance(true));
    assert!(vf > 0.0 && vc / vf < 1.6, "caustics variance over the crop's pixels: {vc} cropped, {vf} in the whole image");
    // and the same caustics in expectation: the seeds' means over the crop agree within 4σ
    let stats = |m: &[f64]| {
        let n = m.len() as f64;
        let mean = m.iter().sum::<f64>() / n;
        (mean, m.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0) / n)
    };
    let ((m_full, v_full), (m_crop, v_crop)) = (stats(&mf), stats(&mc));
    assert!(m_full > 0.1 && (m_full - m_crop).abs() < 4.0 * (v_full + v_crop).sqrt(), "caustics over the crop: {m_crop} cropped, {m_full} in the whole image");
}

// A Stop, a new camera or a time budget's end while a pass traces its photons is met there
// (1.2 s of photon tracing for the first pass of the default stage at 1280 × 720 on two
// threads, `./tide render -o OUT.exr --width 1280 --spp 1`, during which a viewport's camera
// move waited): the tracing asks before each chunk
// of photons and gives the pass up, and a pass given up there changes nothing the next pass
// sees.
#[test]
fn a_pass_stopped_while_its_photons_are_traced_stops_there() {
    use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
    use tide_core::caustics::engine::Caustics;
    let (w, h) = (48, 24);
    let scene = underwater(8.0);
    let settings = settings_for(IntegratorKind::Caustics, w, h, 4, 2);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    // through the renderer: a pass stopped before it begins traces no photon and leaves every
    // pixel unsampled; the render then goes on as one never stopped, bit for bit
    let mut plain = Renderer::new(&scene, settings.clone()).unwrap();
    assert!(plain.render_pass(1, None) && plain.render_pass(2, None));
    let mut r = Renderer::new(&scene, settings.clone()).unwrap();
    let stop = AtomicBool::new(true);
    assert!(!r.render_pass(1, Some(&stop)));
    let c = r.stats().caustics.clone().unwrap();
    assert_eq!((c.photons_emitted, c.passes), (0, 0), "photons traced for a pass stopped before it began");
    assert_eq!(r.unsampled_pixels(), (w * h) as u64);
    assert_eq!(r.samples_per_pixel(), 0);
    assert!(r.render_pass(1, None) && r.render_pass(2, None));
    assert_eq!(bits(&r.aov_pixels(Aov::Color)), bits(&plain.aov_pixels(Aov::Color)));
    assert_eq!(r.stats().caustics.clone().unwrap().photons_emitted, plain.stats().caustics.clone().unwrap().photons_emitted);
    // in the tracing itself: stopped after two chunks' questions, on one thread, it traces no
    // more chunks, and the pass after it has the photons of a pass never stopped
    let world = tide_core::world::World::build(&scene, &settings, &mut Vec::new());
    let pixels = 64 * (w * h) as u64;
    let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
    let mut fresh = Caustics::new(&world, w, h, settings.caustics).expect("caustics");
    pool.install(|| fresh.begin_pass(&world, 7, 1, pixels));
    let emitted = fresh.stats().photons_emitted;
    assert!(emitted > 8 * 4096, "{emitted} photons: too few chunks to stop among");
    let mut c = Caustics::new(&world, w, h, settings.caustics).expect("caustics");
    let asked = AtomicU32::new(0);
    let traced = pool.install(|| c.begin_pass_until(&world, 7, 1, pixels, pixels, &|| asked.fetch_add(1, Ordering::Relaxed) >= 2));
    assert!(!traced);
    assert_eq!(asked.load(Ordering::Relaxed), 3, "the chunks asked: two traced, the third stopped");
    assert_eq!((c.stats().photons_emitted, c.photon_map().len()), (0, 0));
    pool.install(|| c.begin_pass(&world, 7, 1, pixels));
    assert_eq!((c.stats().photons_emitted, c.stats().photons_stored), (emitted, fresh.stats().photons_stored));
    let key = |m: &tide_core::caustics::photon_map::PhotonMap| m.photons().iter().map(|p| p.position.to_array().map(f32::to_bits)).collect::<Vec<_>>();
    assert_eq!(key(c.photon_map()), key(fresh.photon_map()));
}

// The sun's aureole seen from under a flat surface, against single scattering computed here:
// a camera 1.5 m down in strongly forward-scattering water (Henyey–Greenstein g = 0.9) looks up
// along the sun's refracted direction and up to 20° from it, where the camera rays run parallel
// or nearly so with the beams. With the path cut after its first stretch (maximum depth 0) and
// light tracing off, the caustics AOV is the beams' single scattering along the camera ray
// alone: `∫ σs p(−c·d) E_w e^{−σt z/cos θt} e^{−σt t} dt` up to the surface, with `E_w` the
// sun's irradiance across the refracted beam (Fresnel-transmitted, its cross-section narrowed
// by cos θi / cos θt). The image's mean ratio to it (each pixel's over a 4 × 4 grid within the
// pixel) is one within 4σ of six seeds' scatter (a beam crosses many pixels: the pixels of one
// render are not independent) and 1% (the kernel's blur where the beams begin at the surface).
// With `floor`, a black floor lies just below the camera: the beams end where the camera rays
// start, and the beams and rays nearly parallel to them share only the water above it.
// Measured 1.008 ± 0.011 in open water and 1.003 ± 0.013 with the floor (these tests with a
// print of the mean added, `cargo test --release -p tide-core --test caustics the_suns_aureole
// -- --nocapture`); a kernel of 0.9/(πw²) instead of 1/(πw²) reads 0.90 and fails.
fn aureole_ratio(floor: bool) {
    let (w, h) = (32u32, 32u32);
    let (sigma_a, sigma_s, g, ior) = (0.2f64, 0.3f64, 0.9f64, 1.333f64);
    let mut scene = SceneDesc::default();
    scene.meshes.push(std::sync::Arc::new(wavy_water(6.0, 4, 0.0, -3.01)));
    scene.media.push(MediumDesc { name: "/sea".into(), sigma_a: SpectrumDesc::Rgb([sigma_a as f32; 3]), sigma_s: SpectrumDesc::Rgb([sigma_s as f32; 3]), scale: 1.0, phase: PhaseDesc::HenyeyGreenstein { g: g as f32 }, water: None, method: Default::default() });
    scene.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { ior: ior as f32, ..Default::default() }), interior_medium: Some(0) });
    scene.instances_mut().push(instance("/water", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    if floor {
        scene.meshes.push(std::sync::Arc::new(quad_y("/floor", 6.0)));
        scene.materials.push(MaterialDesc { name: "/floor".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.0; 3]) }, interior_medium: None });
        scene.instances_mut().push(instance("/floor", GeometryRef::Mesh(1), Mat4::from_translation(Vec3::new(0.0, -1.5002, 0.0)), 1));
    }
    // the sun 60° up (irradiance 3 across its rays): in the water its light runs along d
    scene.lights.push(sun(0.53, 60.0, -90.0));
    let (cos_i, sin_i) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let sin_t = sin_i / ior;
    let cos_t = (1.0 - sin_t * sin_t).sqrt();
    let d = glam::DVec3::new(0.0, -cos_t, sin_t);
    let (rs, rp) = ((cos_i - ior * cos_t) / (cos_i + ior * cos_t), (ior * cos_i - cos_t) / (ior * cos_i + cos_t));
    let e_w = 3.0 * (1.0 - 0.5 * (rs * rs + rp * rp)) * cos_i / cos_t;
    // looking up 8° off the sun's refracted direction, a 24° field: the sun's direction is in it
    let eye = Vec3::new(0.0, -1.5, 0.0);
    let off = 8f64.to_radians();
    let view = glam::DVec3::new(0.0, cos_t * off.cos() + sin_t * off.sin(), -sin_t * off.cos() + cos_t * off.sin());
    let fov = 24f32;
    scene.camera = camera(eye, eye + view.as_vec3(), fov);
    // the camera's frame (look_at: −Z forward, +Y up)
    let z = -view.normalize();
    let x = glam::DVec3::Y.cross(z).normalize();
    let y = z.cross(x);
    let tan = (0.5 * fov as f64).to_radians().tan();
    let sigma_t = sigma_a + sigma_s;
    let single = |c: glam::DVec3| {
        let cos_s = -c.dot(d);
        let p = (1.0 - g * g) / (4.0 * std::f64::consts::PI * (1.0 + g * g - 2.0 * g * cos_s).powf(1.5));
        let t_s = 1.5 / c.y;
        let n = 2000;
        (0..n)
            .map(|k| {
                let t = t_s * (k as f64 + 0.5) / n as f64;
                let depth = 1.5 - t * c.y;
                sigma_s * p * e_w * (-sigma_t * depth / cos_t).exp() * (-sigma_t * t).exp() * t_s / n as f64
            })
            .sum::<f64>()
    };
    let mut want = Vec::new();
    for py in 0..h {
        for px in 0..w {
            let mut sum = 0.0;
            for (i, j) in (0..16).map(|k| (k % 4, k / 4)) {
                let sx = (2.0 * (px as f64 + (i as f64 + 0.5) / 4.0) / w as f64 - 1.0) * tan;
                let sy = (1.0 - 2.0 * (py as f64 + (j as f64 + 0.5) / 4.0) / h as f64) * tan;
                sum += single((x * sx + y * sy - z).normalize()) / 16.0;
            }
            want.push(sum);
        }
    }
    let ratios: Vec<f64> = (1..=6u64)
        .map(|seed| {
            let mut s = settings_for(IntegratorKind::Caustics, w, h, 64, 2);
            (s.seed, s.max_depth) = (seed, 0);
            s.caustics.light_tracing = false;
            // beams dense enough that one render's image holds many
            s.caustics.beams_per_pixel = 100.0;
            let r = render_progressive(&scene, s);
            let img = r.aov_pixels(Aov::Caustics);
            (0..want.len()).map(|k| (img[3 * k] + img[3 * k + 1] + img[3 * k + 2]) as f64 / 3.0 / want[k]).sum::<f64>() / want.len() as f64
        })
        .collect();
    let n = ratios.len() as f64;
    let mean = ratios.iter().sum::<f64>() / n;
    let se = (ratios.iter().map(|q| (q - mean).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
    assert!(se > 0.0 && (mean - 1.0).abs() < 4.0 * se + 0.01, "ratio to single scattering {mean} ± {se} ({ratios:?})");
}

// Open water: nothing for photons to land on, the beams alone carry the sun's light (the
// caustics engine must aim photons at the water the camera sees, not only at receivers).
#[test]
fn the_suns_aureole_under_a_flat_surface_is_its_single_scattering() {
    aureole_ratio(false);
}

#[test]
fn the_suns_aureole_seen_from_a_floor_where_the_beams_end() {
    aureole_ratio(true);
}

// Light tracing alone against the beams alone on the god rays seen directly: a camera in
// scattering water looking at nothing but water (no floor in view, a black sky), where all
// the light comes through the wavy surface and scatters once or more. The two estimators of
// the camera's first stretch must agree.
#[test]
fn light_traced_god_rays_agree_with_beams() {
    let (w, h) = (24, 12);
    let mut scene = underwater(8.0);
    scene.lights.truncate(1);
    scene.camera = camera(Vec3::new(0.0, -1.5, 3.0), Vec3::new(0.0, -0.6, 0.0), 60.0);
    let mean_of = |light_tracing: bool| {
        let mut sum = 0.0;
        let mut connections = 0;
        for seed in 1..=4u64 {
            let mut s = settings_for(IntegratorKind::Caustics, w, h, 64, 2);
            s.seed = seed;
            s.caustics.light_tracing = light_tracing;
            // every beam kept (no random thinning): fewer rare, bright beams
            s.caustics.beams_per_pixel = 100.0;
            let r = render_progressive(&scene, s);
            let m = image_mean(&r, Aov::Caustics);
            // nearly all the light is caustic: the path tracer keeps only what photons do not
            // carry (light tracing must not leave its stretch to the path tracer as well)
            assert!(image_mean(&r, Aov::Volume) < 0.01 * m);
            connections += r.stats().caustics.unwrap().light_connections;
            sum += m;
        }
        (sum / 4.0, connections)
    };
    let (ml, cl) = mean_of(true);
    let (mb, cb) = mean_of(false);
    assert!(cl > 4000 && cb == 0, "{cl} {cb} connections");
    // single renders' image means scattered by 2.4% (light tracing) and 2.9% (beams) over
    // three seeds, about the path tracer's 0.918 (4096 spp, two seeds within 0.3%): the
    // difference of 4-seed means has σ ≈ 1.9%, so 7% is over 3.5σ, and a double-counted first
    // stretch (+33%) or a lost factor fails
    assert!(ml > 0.5 && (ml / mb - 1.0).abs() < 0.07, "caustics AOV means {ml} (light tracing) vs {mb} (beams)");
}

/// Two sphere lights above three glass balls of different sizes.
fn two_lights_three_casters() -> SceneDesc {
    let mut s = glass_sphere(0.02);
    s.lights.push(light("/bulb2", LightShape::Sphere { radius: 0.02, treat_as_point: false }, Mat4::from_translation(Vec3::new(-0.8, 1.8, -0.4)), 2400.0, false));
    s.meshes.push(std::sync::Arc::new(uv_sphere("/small", 0.12, 24)));
    s.meshes.push(std::sync::Arc::new(uv_sphere("/large", 0.45, 32)));
    s.instances_mut().push(instance("/small", GeometryRef::Mesh(2), Mat4::from_translation(Vec3::new(-0.6, 0.12, 0.5)), 1));
    s.instances_mut().push(instance("/large", GeometryRef::Mesh(3), Mat4::from_translation(Vec3::new(0.9, 0.45, -0.7)), 1));
    s
}

// The guiding table learned while rendering two lights and three casters: each of the six
// (light, caster) squares is brighter over the cells whose directions hit its caster than over
// those that miss it (seed 002 Fig. 8: the casters' outlines show in the table).
#[test]
fn the_learned_guiding_table_shows_the_casters() {
    let scene = two_lights_three_casters();
    // the docs' picture (TIDE_GUIDING_IMAGE_DIR) comes from a larger image: a finer table
    let big = std::env::var("TIDE_GUIDING_IMAGE_DIR").is_ok();
    let (w, h, spp) = if big { (200, 150, 63) } else { (48, 36, 31) };
    let r = render_progressive(&scene, settings_for(IntegratorKind::Caustics, w, h, spp, 2));
    let c = r.caustics().expect("caustics");
    let atlas = c.atlas();
    assert_eq!(atlas.pairs().len(), 6);
    let (tw, _th, img) = atlas.visibility_image();
    for pair in atlas.pairs() {
        let light = atlas.lights()[pair.light as usize];
        let caster = atlas.casters()[pair.caster as usize];
        let tide_core::caustics::atlas::AtlasLight::Local { center, .. } = light else { panic!("local lights") };
        let (mut hit_sum, mut hit_n, mut miss_sum, mut miss_n) = (0.0f64, 0, 0.0f64, 0);
        for y in pair.y..pair.y + pair.size {
            for x in pair.x..pair.x + pair.size {
                // the cell's centre direction in the pair's cone, as the atlas maps it
                let local = [((x - pair.x) as f32 + 0.5) / pair.size as f32, ((y - pair.y) as f32 + 0.5) / pair.size as f32];
                let s = tide_core::caustics::atlas::AtlasSample { pair: 0, light: pair.light, caster: pair.caster, cell: y * tw + x, local, pdf_local: 1.0 };
                let pair_index = atlas.pairs().iter().position(|p| p == pair).unwrap() as u32;
                let e = atlas.emit(&tide_core::caustics::atlas::AtlasSample { pair: pair_index, ..s }, center).unwrap();
                // does the direction meet the caster's sphere (the ball itself: bounding
                // spheres here are the balls' own, grown by the mesh's tessellation)?
                let oc = caster.center - e.origin;
                let tca = oc.dot(e.dir);
                let d2 = oc.length_squared() - tca * tca;
                let v = img[(y * tw + x) as usize] as f64;
                if tca > 0.0 && d2 < (0.8 * caster.radius).powi(2) {
                    hit_sum += v;
                    hit_n += 1;
                } else if d2 > (1.2 * caster.radius).powi(2) || tca <= 0.0 {
                    miss_sum += v;
                    miss_n += 1;
                }
            }
        }
        let (hm, mm) = (hit_sum / hit_n.max(1) as f64, miss_sum / miss_n.max(1) as f64);
        assert!(hit_n > 0 && hm > 0.0, "pair {pair:?}: no signal over the caster");
        assert!(hm > 4.0 * mm, "pair {pair:?}: over the caster {hm:.3e}, beside it {mm:.3e}");
    }
    if let Ok(dir) = std::env::var("TIDE_GUIDING_IMAGE_DIR") {
        let (w, h, img) = atlas.visibility_image();
        // scaled to the 98th percentile of the lit cells, so single bright cells do not
        // darken the picture
        let mut lit: Vec<f32> = img.iter().copied().filter(|v| *v > 0.0).collect();
        lit.sort_by(|a, b| a.total_cmp(b));
        let top = lit.get(lit.len() * 98 / 100).copied().unwrap_or(1.0).max(1e-30);
        let mut pgm = format!("P2\n{w} {h}\n255\n");
        for v in img {
            pgm += &format!("{} ", ((v / top).clamp(0.0, 1.0).sqrt() * 255.0).round() as u32);
        }
        std::fs::write(std::path::Path::new(&dir).join("guiding_table.pgm"), pgm).unwrap();
    }
}




#[test]
fn a_new_camera_renders_what_a_new_renderer_of_it_would() {
    let scene = pool(5.0);
    // from above the water, then from inside it (the camera's medium changes), then a camera
    // with a shutter of its own, which the renderer refuses (its scene was placed over another)
    let under = CameraDesc { name: "/under".into(), ..camera(Vec3::new(0.3, -0.4, 0.9), Vec3::new(-0.2, -0.7, -0.5), 60.0) };
    for kind in [IntegratorKind::Path, IntegratorKind::Caustics] {
        let s = settings_for(kind, 24, 16, 4, 2);
        let mut r = Renderer::new(&scene, s.clone()).expect("renderer");
        assert!(r.render_pass(2, None));
        assert!(r.set_camera(&under, &s));
        assert_eq!(r.samples_per_pixel(), 0, "{kind:?}: the image starts over");
        assert!(r.render_pass(4, None));
        let moved = SceneDesc { camera: under.clone(), ..scene.clone() };
        let fresh = render(&moved, s.clone());
        assert_eq!(r.aov_pixels(Aov::Color), fresh.aov_pixels(Aov::Color), "{kind:?}");
        assert!(r.aov_pixels(Aov::Color) != render(&scene, s.clone()).aov_pixels(Aov::Color));
        let blurred = CameraDesc { shutter_close: 0.5, ..under.clone() };
        assert!(!r.set_camera(&blurred, &s), "{kind:?}: another shutter needs a new renderer");
        assert!(!r.set_camera(&under, &RenderSettings { seed: 2, ..s.clone() }), "{kind:?}: other settings too");
        assert_eq!(r.aov_pixels(Aov::Color), fresh.aov_pixels(Aov::Color), "{kind:?}: a refusal changes nothing");
    }
    // the camera's problems are its own: a bad aperture is reported, then gone with the camera
    let s = settings_for(IntegratorKind::Path, 8, 8, 1, 1);
    let mut r = Renderer::new(&scene, s.clone()).expect("renderer");
    assert!(r.set_camera(&CameraDesc { horizontal_aperture: -1.0, ..under.clone() }, &s));
    assert!(r.problems().iter().any(|p| p.item == "/under" && p.attribute == "horizontalAperture"));
    assert!(r.set_camera(&CameraDesc { name: "/other".into(), ..under.clone() }, &s));
    assert!(!r.problems().iter().any(|p| p.item == "/under"));
}
