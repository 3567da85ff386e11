//! Light linking and shadow linking: a light illuminates only the instances its link names,
//! by next-event estimation and by BSDF-sampled rays alike, and only the instances its shadow
//! link names block it.

mod common;
use common::*;
use glam::{Mat4, Vec3};
use tide_core::scene::*;
use tide_core::{Aov, Renderer};

const W: u32 = 32;

/// Two diffuse patches side by side (ids 1 and 2), seen from above; a sphere light off to the
/// side, out of the camera's view.
fn patches(light_link: Option<Vec<String>>, with_dome: bool) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/patch", 1.0)));
    s.materials.push(MaterialDesc { name: "/m".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
    for (name, x, id) in [("/left", -1.5f32, 1), ("/right", 1.5, 2)] {
        let mut i = instance(name, GeometryRef::Mesh(0), Mat4::from_translation(Vec3::new(x, 0.0, 0.0)), 0);
        i.id = id;
        s.instances_mut().push(i);
    }
    let mut l = light("/lamp", LightShape::Sphere { radius: 0.3, treat_as_point: false }, Mat4::from_translation(Vec3::new(0.0, 2.0, 3.0)), 400.0, false);
    l.visible_to_camera = false;
    l.light_link = light_link;
    s.lights.push(l);
    if with_dome {
        s.lights.push(dome(0.5));
    }
    s.camera = camera(Vec3::new(0.0, 5.0, 0.0), Vec3::ZERO, 60.0);
    s
}

/// Mean green of the pixels whose first hit is the instance with `id`, and their largest value.
fn patch_stats(r: &Renderer, id: f32) -> (f64, f32) {
    let ids = r.aov_pixels(Aov::PrimId);
    let px = r.aov_pixels(Aov::Color);
    let vals: Vec<f32> = (0..(W * W) as usize).filter(|&i| ids[i] == id).map(|i| px[4 * i + 1]).collect();
    assert!(vals.len() > 20, "too few pixels of id {id}");
    (vals.iter().map(|&v| v as f64).sum::<f64>() / vals.len() as f64, vals.iter().cloned().fold(0.0, f32::max))
}

#[test]
fn a_linked_light_illuminates_only_the_instances_it_names() {
    let r = render(&patches(Some(vec!["/left".into()]), false), settings(W, W, 64));
    let (left, _) = patch_stats(&r, 1.0);
    let (_, right_max) = patch_stats(&r, 2.0);
    assert!(left > 0.05, "the linked patch is lit: {left}");
    // neither technique (light sampling nor BSDF-sampled rays reaching the sphere) brings
    // any of the lamp's light to the unlinked patch; light bounced off the lit patch would
    // be the only way, and the patches are coplanar
    assert_eq!(right_max, 0.0, "the unlinked patch receives none of the lamp's light");

    // the same lamp unlinked lights both patches alike
    let all = render(&patches(None, false), settings(W, W, 64));
    let (l_all, _) = patch_stats(&all, 1.0);
    let (r_all, _) = patch_stats(&all, 2.0);
    assert!((l_all - r_all).abs() < 0.1 * l_all, "{l_all} vs {r_all}");
    assert!((left - l_all).abs() < 0.05 * l_all, "linking does not change the linked patch: {left} vs {l_all}");
}

#[test]
fn under_a_dome_both_patches_stay_lit_and_only_one_gets_the_lamp() {
    let linked = render(&patches(Some(vec!["/left".into()]), true), settings(W, W, 64));
    let mut dome_only = patches(None, true);
    dome_only.lights.remove(0);
    let dome_only = render(&dome_only, settings(W, W, 64));
    let (left, _) = patch_stats(&linked, 1.0);
    let (right, _) = patch_stats(&linked, 2.0);
    let (dome_right, _) = patch_stats(&dome_only, 2.0);
    assert!(dome_right > 0.01, "the dome lights the patches: {dome_right}");
    assert!((right - dome_right).abs() < 0.05 * dome_right, "the unlinked patch has the dome's light only: {right} vs {dome_right}");
    assert!(left > 1.5 * dome_right, "the linked patch has the lamp's light too: {left} vs {dome_right}");
}

#[test]
fn a_shadow_link_names_the_instances_that_block_a_light() {
    // a black blocker, invisible to the camera, between the lamp and the left patch
    let scene = |shadow_link: Option<Vec<String>>| {
        let mut s = patches(None, false);
        s.meshes.push(std::sync::Arc::new(quad_y("/blocker", 1.5)));
        s.materials.push(MaterialDesc { name: "/black".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.0; 3]) }, interior_medium: None });
        let mut b = instance("/blocker", GeometryRef::Mesh(1), Mat4::from_translation(Vec3::new(-1.5, 1.0, 1.5)), 1);
        b.visible_to_camera = false;
        s.instances_mut().push(b);
        s.lights[0].shadow_link = shadow_link;
        s
    };
    let shadowed = render(&scene(None), settings(W, W, 32));
    let unshadowed = render(&scene(Some(vec!["/left".into(), "/right".into()])), settings(W, W, 32));
    let (l_sh, _) = patch_stats(&shadowed, 1.0);
    let (l_un, _) = patch_stats(&unshadowed, 1.0);
    let (r_sh, _) = patch_stats(&shadowed, 2.0);
    assert!(r_sh > 0.05, "the right patch is not behind the blocker: {r_sh}");
    assert!(l_sh < 0.05 * r_sh, "the blocker shadows the left patch: {l_sh} vs {r_sh}");
    assert!(l_un > 0.8 * r_sh, "a blocker outside the shadow link casts no shadow: {l_un} vs {r_sh}");
}

/// A tank of scattering water (index-matched, so its surface neither reflects nor refracts)
/// beside a lamp, and a small patch far behind the camera: the lamp linked to the patch only
/// must not light the water's scattering vertices, by light sampling or phase-sampled rays.
fn tank(light_link: Option<Vec<String>>) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(box_mesh("/tank", Vec3::new(-1.0, -1.0, -1.0), Vec3::new(1.0, 1.0, 1.0))));
    s.meshes.push(std::sync::Arc::new(quad_y("/patch", 0.2)));
    s.media.push(MediumDesc { name: "/w".into(), sigma_a: SpectrumDesc::Rgb([0.1; 3]), sigma_s: SpectrumDesc::Rgb([1.0; 3]), scale: 1.0, phase: PhaseDesc::Isotropic, water: None, method: Default::default() });
    s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { ior: 1.0, ..Default::default() }), interior_medium: Some(0) });
    s.materials.push(MaterialDesc { name: "/m".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
    s.instances_mut().push(instance("/tank", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    s.instances_mut().push(instance("/patch", GeometryRef::Mesh(1), Mat4::from_translation(Vec3::new(0.0, -20.0, 40.0)), 1));
    let mut l = light("/lamp", LightShape::Sphere { radius: 0.2, treat_as_point: false }, Mat4::from_translation(Vec3::new(2.0, 1.5, 0.0)), 200.0, false);
    l.visible_to_camera = false;
    l.light_link = light_link;
    s.lights.push(l);
    s.camera = camera(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, 40.0);
    s
}

#[test]
fn a_light_linked_away_from_a_water_body_does_not_light_its_medium() {
    // everything the camera sees is light scattered in the water (the lamp is hidden from
    // the camera and the patch is behind it): the sum of the colour's RGB
    let total = |r: &Renderer| r.aov_pixels(Aov::Color).chunks_exact(4).map(|p| (p[0] + p[1] + p[2]) as f64).sum::<f64>();
    let lit = render(&tank(None), settings(W, W, 16));
    let linked_away = render(&tank(Some(vec!["/patch".into()])), settings(W, W, 16));
    let linked_in = render(&tank(Some(vec!["/tank".into()])), settings(W, W, 16));
    let (v_all, v_away, v_in) = (total(&lit), total(&linked_away), total(&linked_in));
    assert!(v_all > 1.0, "the unlinked lamp lights the water: {v_all}");
    // only light the patch reflects into the water could remain: the patch is 40 m away and
    // 0.4 m wide, far below 10⁻³ of the direct in-scattering
    assert!(v_away < 1e-3 * v_all, "a lamp linked to the patch alone still lights the water: {v_away} vs {v_all}");
    // a link naming the tank lights its medium as no link does (same samples: equal up to
    // the patch's negligible share)
    assert!((v_in - v_all).abs() < 1e-3 * v_all, "{v_in} vs {v_all}");
}

/// A glossy-and-diffuse floor (UsdPreviewSurface, specular workflow) under a sphere light with
/// the given multipliers, seen from above at an angle that catches the highlight.
fn glossy_floor(response: LightResponse, lambert: bool) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/floor", 3.0)));
    let surface = if lambert {
        SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }
    } else {
        SurfaceDesc::Preview(PreviewSurfaceDesc {
            diffuse_color: ColorInput::Const([0.4, 0.5, 0.6]),
            use_specular_workflow: true,
            specular_color: ColorInput::Const([0.6; 3]),
            roughness: FloatInput::Const(0.25),
            ..Default::default()
        })
    };
    s.materials.push(MaterialDesc { name: "/m".into(), surface, interior_medium: None });
    s.instances_mut().push(instance("/floor", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    let mut l = light("/lamp", LightShape::Sphere { radius: 0.3, treat_as_point: false }, Mat4::from_translation(Vec3::new(0.0, 1.5, -1.0)), 60.0, false);
    l.response = response;
    // seen directly the light is neither response: out of the comparison
    l.visible_to_camera = false;
    s.lights.push(l);
    s.camera = camera(Vec3::new(0.0, 1.5, 2.5), Vec3::new(0.0, 0.0, -0.3), 60.0);
    s
}

// UsdLux's diffuse and specular multipliers: the image is linear in them, lobe by lobe, through
// next-event estimation and BSDF-sampled rays alike (same seed, same samples: equal to f32
// rounding), both lobes show, and a Lambertian floor has no specular part at all.
#[test]
fn diffuse_and_specular_multipliers_scale_their_lobes() {
    let img = |d: f32, sp: f32, lambert: bool| {
        let r = render(&glossy_floor(LightResponse { diffuse: d, specular: sp }, lambert), settings(W, W, 16));
        r.aov_pixels(Aov::Color).chunks_exact(4).map(|p| [p[0] as f64, p[1] as f64, p[2] as f64]).collect::<Vec<_>>()
    };
    let (full, diffuse, specular, mixed) = (img(1.0, 1.0, false), img(1.0, 0.0, false), img(0.0, 1.0, false), img(0.5, 2.0, false));
    let total = |v: &[[f64; 3]]| v.iter().map(|p| p[0] + p[1] + p[2]).sum::<f64>();
    for i in 0..full.len() {
        for c in 0..3 {
            let (f, d, s, m) = (full[i][c], diffuse[i][c], specular[i][c], mixed[i][c]);
            assert!((f - (d + s)).abs() <= 1e-4 * f.abs() + 1e-6, "pixel {i}: {f} vs {d} + {s}");
            assert!((m - (0.5 * d + 2.0 * s)).abs() <= 1e-4 * m.abs() + 1e-6, "pixel {i}: {m} vs ½{d} + 2·{s}");
        }
    }
    let (t, td, ts) = (total(&full), total(&diffuse), total(&specular));
    assert!(td > 0.1 * t && ts > 0.1 * t, "lobes: diffuse {td}, specular {ts} of {t}");
    // the highlight is specular: the brightest pixel of the full image is mostly the specular part
    let peak = (0..full.len()).max_by(|&a, &b| full[a][1].total_cmp(&full[b][1])).unwrap();
    assert!(specular[peak][1] > 0.5 * full[peak][1]);
    // a Lambertian floor: no specular response, the diffuse multiplier scales everything
    let (lam, lam_s, lam_d) = (img(1.0, 1.0, true), img(0.0, 1.0, true), img(0.3, 7.0, true));
    assert_eq!(total(&lam_s), 0.0);
    assert!((total(&lam_d) - 0.3 * total(&lam)).abs() <= 1e-4 * total(&lam));
}
