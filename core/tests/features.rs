//! Render-level checks of features with exact expectations: nested dielectrics resolved by
//! priority (an index-matched object vanishes; a higher-priority glass wins where it overlaps
//! water), thin transparency, emissive surfaces seen directly, and shading without acne on an
//! ocean-sized plane far from the origin.

mod common;
use common::*;
use glam::{Mat4, Vec3};
use tide_core::scene::*;
use tide_core::render::IntegratorKind;
use tide_core::{Aov, RenderSettings};

fn water(ior: f32, priority: i32) -> SurfaceDesc {
    SurfaceDesc::Water(WaterDesc { ior, priority, ..Default::default() })
}

fn mean_rgb(r: &tide_core::Renderer) -> [f64; 3] {
    let px = r.aov_pixels(Aov::Color);
    let n = (px.len() / 4) as f64;
    let mut m = [0.0f64; 3];
    for p in px.chunks_exact(4) {
        for k in 0..3 {
            m[k] += p[k] as f64 / n;
        }
    }
    m
}

/// A camera inside a box of absorbing water looking at a lit floor through it; `extra`
/// adds objects inside the water.
fn underwater(extra: impl Fn(&mut SceneDesc)) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(box_mesh("/sea", Vec3::new(-10.0, -2.0, -10.0), Vec3::new(10.0, 3.0, 10.0))));
    s.meshes.push(std::sync::Arc::new(quad_y("/floor", 9.0)));
    s.media.push(MediumDesc { name: "/w".into(), sigma_a: SpectrumDesc::Rgb([0.3, 0.08, 0.04]), sigma_s: SpectrumDesc::Rgb([0.0; 3]), scale: 1.0, phase: PhaseDesc::Isotropic, water: None, method: Default::default() });
    s.materials.push(MaterialDesc { name: "/water".into(), surface: water(1.333, 0), interior_medium: Some(0) });
    s.materials.push(MaterialDesc { name: "/floor".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.7, 0.6, 0.4]) }, interior_medium: None });
    s.instances_mut().push(instance("/sea", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    s.instances_mut().push(instance("/floor", GeometryRef::Mesh(1), Mat4::from_translation(Vec3::new(0.0, -1.0, 0.0)), 1));
    // light from a sphere light inside the water, so no refraction is needed for NEE
    s.lights.push(light("/bulb", LightShape::Sphere { radius: 0.2, treat_as_point: false }, Mat4::from_translation(Vec3::new(0.5, 1.5, 0.0)), 40.0, false));
    s.camera = camera(Vec3::new(0.0, 1.0, 3.0), Vec3::new(0.0, -1.0, 0.0), 40.0);
    extra(&mut s);
    s
}

#[test]
fn an_index_matched_object_inside_water_is_invisible() {
    let base = underwater(|_| {});
    // a clear sphere of the water's own IOR, no medium inside: the path must see water/water
    // (eta = 1) at its boundary and keep the water medium inside (equal priority: the
    // sphere wins, but it has no medium; so give it the water medium too)
    let with = underwater(|s| {
        s.meshes.push(std::sync::Arc::new(uv_sphere("/ghost", 0.6, 24)));
        s.materials.push(MaterialDesc { name: "/ghost".into(), surface: water(1.333, 0), interior_medium: Some(0) });
        s.instances_mut().push(instance("/ghost", GeometryRef::Mesh(2), Mat4::from_translation(Vec3::new(0.0, -0.2, 0.0)), 2));
    });
    let (w, h) = (16, 16);
    let a = render(&base, settings(w, h, 64));
    let b = render(&with, settings(w, h, 64));
    let (ma, mb) = (mean_rgb(&a), mean_rgb(&b));
    // per-pixel difference statistics: same expectation
    let (pa, pb) = (a.aov_pixels(Aov::Color), b.aov_pixels(Aov::Color));
    for k in 0..3 {
        let d: Vec<f64> = (0..(w * h) as usize).map(|i| (pa[i * 4 + k] - pb[i * 4 + k]) as f64).collect();
        let n = d.len() as f64;
        let md = d.iter().sum::<f64>() / n;
        let se = (d.iter().map(|x| (x - md).powi(2)).sum::<f64>() / (n - 1.0) / n).sqrt();
        assert!(md.abs() < 3.0 * se + 1e-4, "channel {k}: {ma:?} vs {mb:?}, diff {md} ± {se}");
    }
    // and a glass sphere (ior 1.5) in the same place is visible: the test can fail
    let glass = underwater(|s| {
        s.meshes.push(std::sync::Arc::new(uv_sphere("/glass", 0.6, 24)));
        s.materials.push(MaterialDesc { name: "/glass".into(), surface: water(1.5, 0), interior_medium: None });
        s.instances_mut().push(instance("/glass", GeometryRef::Mesh(2), Mat4::from_translation(Vec3::new(0.0, -0.2, 0.0)), 2));
    });
    let c = render(&glass, settings(w, h, 64));
    let pc = c.aov_pixels(Aov::Color);
    let diff: f64 = (0..(w * h) as usize).map(|i| (pa[i * 4 + 1] - pc[i * 4 + 1]).abs() as f64).sum::<f64>() / (w * h) as f64;
    assert!(diff > 0.01, "glass sphere had no effect: {diff}");
}

#[test]
fn higher_priority_glass_wins_where_it_overlaps_water() {
    // a glass block (priority 5, clear) straddling the water surface: inside the overlap the
    // water boundary is false, so looking straight down through the glass's top we see the
    // floor without the water's absorption along the overlapped part
    let scene = |prio: i32| {
        let mut s = underwater(|_| {});
        s.camera = camera(Vec3::new(0.0, 5.0, 0.001), Vec3::new(0.0, 0.0, 0.0), 8.0);
        s.meshes.push(std::sync::Arc::new(box_mesh("/block", Vec3::new(-1.0, -0.9, -1.0), Vec3::new(1.0, 4.0, 1.0))));
        s.materials.push(MaterialDesc { name: "/glass".into(), surface: water(1.5, prio), interior_medium: None });
        s.instances_mut().push(instance("/block", GeometryRef::Mesh(2), Mat4::IDENTITY, 2));
        s.lights.clear();
        s.lights.push(dome(1.0));
        s
    };
    let (w, h) = (8, 8);
    let hi = mean_rgb(&render(&scene(5), settings(w, h, 64)));
    let lo = mean_rgb(&render(&scene(-5), settings(w, h, 64)));
    // with the glass winning there is no water inside the block: far less red absorption
    assert!(hi[0] > 1.5 * lo[0], "priority had no effect: {hi:?} vs {lo:?}");
}

#[test]
fn thin_transparency_lets_through_one_minus_opacity() {
    // a black, non-reflective card of opacity 0.3 in front of a white environment of radiance 1
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/card", 50.0)));
    let mut p = PreviewSurfaceDesc::default();
    p.diffuse_color = ColorInput::Const([0.0; 3]);
    p.use_specular_workflow = true;
    p.specular_color = ColorInput::Const([0.0; 3]);
    p.opacity = FloatInput::Const(0.3);
    s.materials.push(MaterialDesc { name: "/card".into(), surface: SurfaceDesc::Preview(p), interior_medium: None });
    s.instances_mut().push(instance("/card", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    s.lights.push(dome(1.0));
    s.camera = camera(Vec3::new(0.0, 3.0, 0.001), Vec3::ZERO, 10.0);
    let (w, h) = (8, 8);
    let r = render(&s, settings(w, h, 64));
    for ch in 0..3 {
        let (m, se, _) = channel_stats(&r, ch, |_, _| true, w);
        // Bernoulli(0.7) per sample: 3σ + the white round trip
        assert!((m - 0.7).abs() < 3.0 * se + 0.005, "channel {ch}: {m} ± {se}");
    }
}

#[test]
fn emissive_surface_seen_directly_has_its_radiance() {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/panel", 10.0)));
    s.materials.push(MaterialDesc { name: "/panel".into(), surface: SurfaceDesc::Emissive { radiance: [2.0, 1.0, 0.5], two_sided: false }, interior_medium: None });
    s.instances_mut().push(instance("/panel", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    s.camera = camera(Vec3::new(0.0, 2.0, 0.001), Vec3::ZERO, 10.0);
    let (w, h) = (4, 4);
    let r = render(&s, settings(w, h, 16));
    let expect = [2.0, 1.0, 0.5];
    for ch in 0..3 {
        let (m, se, _) = channel_stats(&r, ch, |_, _| true, w);
        // the illuminant uplift reproduces in-gamut RGB within 1% of the max channel
        assert!((m - expect[ch]).abs() < 3.0 * se + 0.02, "channel {ch}: {m} ± {se}");
    }
}

// A camera declared to sit in water (`tide:medium`) with no water object around it: the path
// starts in that water, unbounded, so an emissive panel d away is seen through e^{−σa·d} of it
// (grey σa: exact per wavelength), by the path tracer and by the caustics integrator, whose
// photon and light tracers start from the same stack.
#[test]
fn a_camera_declared_in_water_with_no_water_around_it_sees_through_it() {
    let (sigma_a, d) = (0.3f32, 2.0f32);
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/panel", 10.0)));
    s.media.push(MediumDesc { name: "/w".into(), sigma_a: SpectrumDesc::Rgb([sigma_a; 3]), sigma_s: SpectrumDesc::Rgb([0.0; 3]), scale: 1.0, phase: PhaseDesc::Isotropic, water: None, method: Default::default() });
    s.materials.push(MaterialDesc { name: "/panel".into(), surface: SurfaceDesc::Emissive { radiance: [2.0, 1.0, 0.5], two_sided: false }, interior_medium: None });
    // dispersive water elsewhere in the scene: every path's stack is set to its wavelengths
    s.meshes.push(std::sync::Arc::new(box_mesh("/drop", Vec3::splat(20.0), Vec3::splat(21.0))));
    s.materials.push(MaterialDesc { name: "/drop".into(), surface: SurfaceDesc::Water(WaterDesc { dispersion: true, ..Default::default() }), interior_medium: None });
    s.instances_mut().push(instance("/panel", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    s.instances_mut().push(instance("/drop", GeometryRef::Mesh(1), Mat4::IDENTITY, 1));
    s.lights.push(light("/sun", LightShape::Distant { angle_deg: 0.5 }, look_at(Vec3::ZERO, -Vec3::Y), 1.0, true));
    s.camera = camera(Vec3::new(0.0, d, 0.001), Vec3::ZERO, 10.0);
    s.camera.medium = Some(0);
    let (w, h) = (4, 4);
    for kind in [IntegratorKind::Path, IntegratorKind::Caustics] {
        let mut settings = settings(w, h, 16);
        settings.integrator = kind;
        let r = render(&s, settings);
        let t = (-sigma_a * d).exp() as f64;
        for (ch, e) in [2.0, 1.0, 0.5].into_iter().enumerate() {
            let (m, se, _) = channel_stats(&r, ch, |_, _| true, w);
            // the illuminant uplift reproduces in-gamut RGB within 1% of the max channel
            assert!((m - e * t).abs() < 3.0 * se + 0.02 * t, "{kind:?} channel {ch}: {m} ± {se}, expected {}", e * t);
        }
    }
}

#[test]
fn no_acne_on_an_ocean_sized_plane_far_from_the_origin() {
    // a 20 km plane 8 km from the origin under a sun: every pixel must equal albedo·E·cosθ/π
    // (self-intersection would darken pixels at random)
    let far = Vec3::new(8000.0, 0.0, -6000.0);
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/ocean", 10_000.0)));
    s.materials.push(MaterialDesc { name: "/m".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
    // slightly tilted and raised so hit points are not exactly representable on the plane
    let tilt = Mat4::from_rotation_x(0.013) * Mat4::from_rotation_z(-0.007);
    s.instances_mut().push(instance("/ocean", GeometryRef::Mesh(0), Mat4::from_translation(far + Vec3::Y * 0.37) * tilt, 0));
    let normal = tilt.transform_vector3(Vec3::Y);
    let el = 40f32.to_radians();
    let to_sun = Vec3::new(0.0, el.sin(), el.cos());
    s.lights.push(light("/sun", LightShape::Distant { angle_deg: 0.0 }, look_at(Vec3::ZERO, -to_sun), 2.0, true));
    s.camera = camera(far + Vec3::new(0.0, 1.9, 0.0), far + Vec3::new(0.0, 0.3, -4.0), 30.0);
    let (w, h) = (32, 32);
    let r = render(&s, settings(w, h, 16));
    let expect = 0.5 * 2.0 * normal.dot(to_sun) / std::f32::consts::PI;
    let px = r.aov_pixels(Aov::Color);
    let vals: Vec<f32> = px.chunks_exact(4).enumerate().filter(|(i, _)| i / w as usize >= h as usize / 2).map(|(_, p)| p[1]).collect();
    let n = vals.len() as f32;
    let mean = vals.iter().sum::<f32>() / n;
    let se = (vals.iter().map(|v| (v - mean).powi(2)).sum::<f32>() / (n - 1.0) / n).sqrt();
    let (lo, hi) = vals.iter().fold((f32::MAX, f32::MIN), |(a, b), &v| (a.min(v), b.max(v)));
    eprintln!("ocean: mean {mean} ± {se}, min {lo}, max {hi}, expect {expect}");
    // The only noise is the spectral estimate of a grey surface (4 wavelengths per sample).
    // Self-shadowed samples contribute 0, so acne in even 1% of the 8192 samples would pull
    // the mean below expect by 1%: about 5σ here.
    assert!((mean - expect).abs() < 3.0 * se, "mean {mean} ± {se} vs {expect}");
    assert!(lo > 0.5 * expect, "a pixel at {lo}: samples shadowed by their own surface");
}

#[test]
fn a_closed_mesh_invisible_to_the_camera_is_not_seen_from_either_side() {
    // a black box hidden from camera rays in front of a white environment: both its faces
    // along a camera ray must be skipped, so every pixel sees the environment (radiance 1)
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(box_mesh("/box", Vec3::splat(-1.0), Vec3::splat(1.0))));
    s.materials.push(MaterialDesc { name: "/black".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.0; 3]) }, interior_medium: None });
    let mut inst = instance("/box", GeometryRef::Mesh(0), Mat4::IDENTITY, 0);
    inst.visible_to_camera = false;
    s.instances_mut().push(inst);
    s.lights.push(dome(1.0));
    s.camera = camera(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 10.0);
    let (w, h) = (8, 8);
    let r = render(&s, settings(w, h, 16));
    for ch in 0..3 {
        let (m, se, _) = channel_stats(&r, ch, |_, _| true, w);
        // white round trip of the uplift plus 3σ of the spectral estimate
        assert!((m - 1.0).abs() < 3.0 * se + 0.005, "channel {ch}: {m} ± {se}");
    }
}

/// UsdGeomCamera: a shutter that closes before it opens exposes nothing: the image is black
/// (and the problem is named); the same camera with its shutter the right way round sees the
/// dome. With `adjustPixelAspectRatio` the EXR records the pixel aspect that fits the aperture,
/// not the settings' own.
#[test]
fn a_shutter_closing_before_it_opens_renders_black() {
    let mut s = SceneDesc::default();
    s.lights.push(dome(1.0));
    s.camera = camera(Vec3::ZERO, -Vec3::Z, 40.0);
    s.camera.shutter_open = 0.25;
    s.camera.shutter_close = -0.25;
    let r = render(&s, settings(4, 4, 2));
    assert!(r.aov_pixels(Aov::Color).iter().all(|&v| v == 0.0));
    assert!(r.problems().iter().any(|p| p.attribute == "shutter:close" && p.message.contains("black")), "{:?}", r.problems());
    s.camera.shutter_close = 0.5;
    let r = render(&s, settings(4, 4, 16));
    for ch in 0..3 {
        let (m, se, _) = channel_stats(&r, ch, |_, _| true, 4);
        assert!((m - 1.0).abs() < 3.0 * se + 0.01, "channel {ch}: {m} ± {se}");
    }

    // a 36 × 24 aperture on a square image: pixels 1.5 wide for 1 high
    s.camera.horizontal_aperture = 36.0;
    s.camera.vertical_aperture = 24.0;
    let mut st = settings(4, 4, 1);
    st.aspect_conform = tide_core::camera::AspectConform::AdjustPixelAspectRatio;
    st.pixel_aspect_ratio = 2.0;
    let r = render(&s, st);
    let path = std::env::temp_dir().join(format!("tide-par-{}.exr", std::process::id()));
    r.write_exr(&path, &[Aov::Color], &[]).unwrap();
    let img = exr::prelude::read_all_flat_layers_from_file(&path).unwrap();
    std::fs::remove_file(&path).unwrap();
    assert!((img.attributes.pixel_aspect - 1.5).abs() < 1e-6, "{}", img.attributes.pixel_aspect);
}

/// A one-sided emissive quad keeps its mesh's front under a mirroring transform (Hydra keeps
/// it; the winding turns in the world): mirrored across x it still lights the floor below it
/// as the plain one does; mirrored across y its front turns up and the floor stays dark.
#[test]
fn a_mirrored_emitter_keeps_its_front() {
    let floor_mean = |placement: Mat4| {
        let mut s = SceneDesc::default();
        s.meshes.push(std::sync::Arc::new(quad_y("/floor", 2.0)));
        s.meshes.push(std::sync::Arc::new(quad_y("/panel", 0.1)));
        s.materials.push(MaterialDesc { name: "/grey".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
        let glow = PreviewSurfaceDesc { diffuse_color: ColorInput::Const([0.0; 3]), emissive_color: ColorInput::Const([20.0; 3]), ..Default::default() };
        s.materials.push(MaterialDesc { name: "/glow".into(), surface: SurfaceDesc::Preview(glow), interior_medium: None });
        s.instances_mut().push(instance("/floor", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
        // the panel faces down (−Y) at height 0.5, then the placement under test
        let down = Mat4::from_translation(Vec3::Y * 0.5) * placement * Mat4::from_rotation_x(std::f32::consts::PI);
        s.instances_mut().push(instance("/panel", GeometryRef::Mesh(1), down, 1));
        s.camera = camera(Vec3::new(0.0, 3.0, 0.01), Vec3::ZERO, 40.0);
        let (w, h) = (16, 16);
        let r = render(&s, settings(w, h, 16));
        // the floor around the panel (the panel itself, at the centre, left out)
        channel_stats(&r, 1, |x, y| !(5..11).contains(&x) || !(5..11).contains(&y), w)
    };
    let (plain, se, _) = floor_mean(Mat4::IDENTITY);
    assert!(plain > 0.01, "{plain}");
    let (mirror_x, se_x, _) = floor_mean(Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)));
    assert!((mirror_x - plain).abs() < 4.0 * (se + se_x) + 0.01 * plain, "{mirror_x} vs {plain}");
    let (mirror_y, _, _) = floor_mean(Mat4::from_scale(Vec3::new(1.0, -1.0, 1.0)));
    assert!(mirror_y < 1e-3 * plain, "{mirror_y} vs {plain}");
}

/// A render keeping colour alone (the film the CLI makes for a beauty-only product) draws the
/// same colour, sample for sample, as one keeping every AOV, in a fifth of the film's memory;
/// the AOVs it did not keep read as zeros and cannot be written to a file. The scene is a
/// floor seen through scattering water, where the first-hit AOVs trace the camera ray again
/// (the work colour alone skips).
#[test]
fn a_colour_only_film_draws_the_same_colour_in_less_memory() {
    use tide_core::{film::Film, AovSet};
    let mut scene = underwater(|_| {});
    scene.media[0].sigma_s = SpectrumDesc::Rgb([0.4; 3]);
    let all = render(&scene, settings(24, 24, 4));
    let colour = render(&scene, RenderSettings { aovs: AovSet::of([Aov::Color]), ..settings(24, 24, 4) });
    let (c_all, c_one) = (all.aov_pixels(Aov::Color), colour.aov_pixels(Aov::Color));
    assert!(c_all.iter().any(|&v| v > 0.0));
    assert!(c_all.iter().zip(&c_one).all(|(a, b)| a.to_bits() == b.to_bits()), "the colour differs");
    // the full render did take the floor's normal through the water; the other kept none
    assert!(all.aov_pixels(Aov::Normal).iter().any(|&v| v != 0.0));
    assert!(colour.aov_pixels(Aov::Normal).iter().all(|&v| v == 0.0));
    let dir = std::env::temp_dir().join(format!("tide-colour-only-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    colour.write_exr(&dir.join("ok.exr"), &[Aov::Color], &[]).unwrap();
    let err = colour.write_exr(&dir.join("no.exr"), &[Aov::Color, Aov::Normal], &[]).unwrap_err();
    assert!(err.to_string().contains("'normal'"), "{err}");
    assert!(!dir.join("no.exr").exists());
    std::fs::remove_dir_all(&dir).unwrap();
    // colour, alpha and the luminance pair in f32 and a sample count: 28 bytes a pixel, where
    // every AOV takes 140 (24 more floats of averages, and the first hit's depth, primId,
    // instanceId and elementId)
    assert_eq!(Film::bytes_per_pixel(AovSet::of([Aov::Color])), 28);
    assert_eq!(Film::bytes_per_pixel(AovSet::ALL), 140);
}

/// A pass given up part way (its deadline passed) keeps the pixels it finished, each with the
/// very samples a whole pass gives it, and leaves the others as they were; a first pass given
/// up leaves pixels without samples, transparent black, which take their first hit's depth
/// from the pass that reaches them.
#[test]
fn a_pass_given_up_part_way_keeps_the_pixels_it_finished() {
    use std::time::{Duration, Instant};
    let mut scene = underwater(|_| {});
    scene.media[0].sigma_s = SpectrumDesc::Rgb([0.4; 3]);
    let s = RenderSettings { threads: 1, ..settings(40, 40, 9) };
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    let mut whole = tide_core::Renderer::new(&scene, s.clone()).unwrap();
    assert!(whole.render_pass(1, None));
    let (c1, d1) = (whole.aov_pixels(Aov::Color), whole.aov_pixels(Aov::Depth));
    assert!(whole.render_pass(8, None));
    let c9 = whole.aov_pixels(Aov::Color);
    let mut first8 = tide_core::Renderer::new(&scene, s.clone()).unwrap();
    assert!(first8.render_pass(8, None));
    let (f8, fd8) = (first8.aov_pixels(Aov::Color), first8.aov_pixels(Aov::Depth));
    let total = 40 * 40;
    // deadlines from 1 ms up, until one falls inside the pass (whatever the machine's speed)
    let (mut later, mut first) = (false, false);
    for ms in (0..14).map(|k| 1u64 << k) {
        let mut r = tide_core::Renderer::new(&scene, s.clone()).unwrap();
        assert!(r.render_pass(1, None));
        if !later && !r.render_pass_until(8, None, Some(Instant::now() + Duration::from_millis(ms))) {
            let n = r.pixel_samples();
            let reached = n.iter().filter(|&&k| k == 9).count();
            if reached > 0 && reached < total {
                later = true;
                assert!(n.iter().all(|&k| k == 1 || k == 9), "a pixel took part of its samples");
                assert_eq!(r.samples_per_pixel(), 9);
                assert_eq!(r.unsampled_pixels(), 0);
                let c = r.aov_pixels(Aov::Color);
                for (i, &k) in n.iter().enumerate() {
                    let want = if k == 9 { &c9[i * 4..i * 4 + 4] } else { &c1[i * 4..i * 4 + 4] };
                    assert_eq!(bits(&c[i * 4..i * 4 + 4]), bits(want), "pixel {i} with {k} samples");
                }
                assert_eq!(bits(&r.aov_pixels(Aov::Depth)), bits(&d1));
                // the next pass follows on in every pixel
                assert!(r.render_pass(2, None));
                assert!(r.pixel_samples().iter().zip(&n).all(|(&a, &b)| a == b + 2));
            }
        }
        let mut r = tide_core::Renderer::new(&scene, s.clone()).unwrap();
        if !first && !r.render_pass_until(8, None, Some(Instant::now() + Duration::from_millis(ms))) {
            let n = r.pixel_samples();
            let reached = n.iter().filter(|&&k| k == 8).count();
            if reached > 0 && reached < total {
                first = true;
                assert!(n.iter().all(|&k| k == 0 || k == 8), "a pixel took part of its samples");
                assert_eq!(r.unsampled_pixels(), (total - reached) as u64);
                assert_eq!(r.stats().unsampled_pixels, (total - reached) as u64);
                let (c, d) = (r.aov_pixels(Aov::Color), r.aov_pixels(Aov::Depth));
                for (i, &k) in n.iter().enumerate() {
                    let want = if k == 8 { &f8[i * 4..i * 4 + 4] } else { &[0.0f32; 4][..] };
                    assert_eq!(bits(&c[i * 4..i * 4 + 4]), bits(want), "pixel {i} with {k} samples");
                    // a pixel not reached has no first hit yet
                    assert_eq!(d[i].is_finite(), k == 8, "pixel {i} ({k}): depth {}", d[i]);
                }
                // every ray meets the water's box: a pixel's depth is its first sample's
                assert!(r.render_pass(1, None));
                assert_eq!(r.unsampled_pixels(), 0);
                let d2 = r.aov_pixels(Aov::Depth);
                for (i, &k) in n.iter().enumerate() {
                    assert!(d2[i].is_finite() && d2[i] > 0.0, "pixel {i} ({k}): depth {} ref {} {}", d2[i], fd8[i], d1[i]);
                    if k == 8 {
                        assert_eq!(d2[i].to_bits(), fd8[i].to_bits());
                    }
                }
            }
        }
        if later && first {
            break;
        }
    }
    assert!(later && first, "no deadline fell inside a pass ({later}, {first})");
}

/// A pass tells how far it has got while it renders: another thread reading its progress sees
/// it rise through the pass (never past 1, never back) to 1 when it is done.
#[test]
fn a_pass_tells_how_far_it_has_got_while_it_renders() {
    let mut scene = underwater(|_| {});
    scene.media[0].sigma_s = SpectrumDesc::Rgb([0.4; 3]);
    let mut r = tide_core::Renderer::new(&scene, RenderSettings { threads: 1, ..settings(96, 96, 16) }).unwrap();
    let progress = r.pass_progress();
    let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let watcher = {
        let (progress, stop) = (progress.clone(), stop.clone());
        std::thread::spawn(move || {
            let mut seen = Vec::new();
            while !stop.load(std::sync::atomic::Ordering::Relaxed) {
                seen.push(progress.fraction());
                std::thread::sleep(std::time::Duration::from_micros(200));
            }
            seen
        })
    };
    assert!(r.render_pass(16, None));
    stop.store(true, std::sync::atomic::Ordering::Relaxed);
    let seen = watcher.join().unwrap();
    assert!(seen.windows(2).all(|w| w[1] >= w[0]), "progress went back");
    assert!(seen.iter().all(|&f| (0.0..=1.0).contains(&f)));
    let inside = seen.iter().filter(|&&f| f > 0.0 && f < 1.0).count();
    assert!(inside >= 3, "{inside} readings inside the pass of {}", seen.len());
    assert_eq!(progress.fraction(), 1.0);
}
