//! Offsetting a ray's origin off the surface it leaves must hold at any scale and anywhere:
//! a scene shrunk to micrometres, or carried far from the origin, renders as it does at unit
//! scale about the origin (shadows in contact with their casters included), for meshes,
//! spheres, blobbies and bubbles alike.

mod common;
use common::*;
use glam::{Mat4, Vec3};
use tide_core::scene::*;
use tide_core::Aov;

/// A floor, a box standing on it, a ball, a blobby pair and a bubble resting on it, lit by a low sun only; everything
/// carried by `g` (a uniform scale and a translation).
fn contact_scene(g: Mat4, scale: f32) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/floor", 4.0)));
    s.meshes.push(std::sync::Arc::new(box_mesh("/box", Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 1.0, 0.5))));
    s.spheres.push(std::sync::Arc::new(SpheresDesc { name: "/balls".into(), centers: vec![Vec3::new(0.0, 0.35, 0.0)], radii: vec![0.35], ..Default::default() }));
    // a blobby pair and a bubble (their hits carry the normal the intersection found)
    let blobby = PointShape::Blobby { threshold: 0.5, orientations: None, scales: None };
    s.spheres.push(std::sync::Arc::new(SpheresDesc { name: "/blobs".into(), centers: vec![Vec3::new(-0.15, 0.2, 0.0), Vec3::new(0.15, 0.25, 0.05)], radii: vec![0.2, 0.2], shape: blobby, ..Default::default() }));
    let bubble = PointShape::Bubbles { top: vec![0.3], bottom: vec![0.1], orientations: None };
    s.spheres.push(std::sync::Arc::new(SpheresDesc { name: "/bubble".into(), centers: vec![Vec3::new(0.0, 0.1, 0.0)], radii: vec![0.3], shape: bubble, ..Default::default() }));
    s.materials.push(MaterialDesc { name: "/grey".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
    s.instances_mut().push(instance("/floor", GeometryRef::Mesh(0), g, 0));
    s.instances_mut().push(instance("/box", GeometryRef::Mesh(1), g * Mat4::from_rotation_y(0.4) * Mat4::from_translation(Vec3::new(-0.6, 0.0, 0.2)), 0));
    s.instances_mut().push(instance("/balls", GeometryRef::Spheres(0), g * Mat4::from_translation(Vec3::new(0.9, 0.0, 0.5)), 0));
    s.instances_mut().push(instance("/blobs", GeometryRef::Spheres(1), g * Mat4::from_translation(Vec3::new(0.2, 0.0, -1.2)), 0));
    s.instances_mut().push(instance("/bubble", GeometryRef::Spheres(2), g * Mat4::from_translation(Vec3::new(1.4, 0.0, -0.6)), 0));
    let to_sun = Vec3::new(-0.6, 0.45, -0.3).normalize();
    // directions from the unit scene (not from differences of far points, which would turn them)
    s.lights.push(light("/sun", LightShape::Distant { angle_deg: 0.53 }, look_at(Vec3::ZERO, -to_sun), 3.0, true));
    let mut cam = camera(Vec3::new(1.5, 2.5, 3.5), Vec3::new(0.0, 0.3, 0.0), 45.0);
    cam.transforms = vec![g * cam.transforms[0] * Mat4::from_scale(Vec3::splat(1.0 / scale))];
    cam.clipping_range = [1e-3 * scale, 1e3 * scale];
    s.camera = cam;
    s
}

fn luminance(g: Mat4, scale: f32) -> Vec<f32> {
    let (w, h) = (W as u32, 36);
    let r = render(&contact_scene(g, scale), settings(w, h, 4));
    r.aov_pixels(Aov::Color).chunks_exact(4).map(|p| p[0] + p[1] + p[2]).collect()
}

const W: usize = 48;

/// The pixels that differ from the reference by more than a fifth of the lit floor's value,
/// counting only those inside a region of the reference (all of the 3×3 pixels about them
/// within that fifth of each other): where the scene moves by a few of the floats' steps, an
/// edge may pass to the next sample, but nothing inside a shadow or a lit region may change.
fn differing(a: &[f32], reference: &[f32]) -> usize {
    let lit = 3.0 * 0.5 * 3.0 * Vec3::new(-0.6, 0.45, -0.3).normalize().y / std::f32::consts::PI;
    let h = reference.len() / W;
    let inside = |i: usize| {
        let (x, y) = (i % W, i / W);
        (x.saturating_sub(1)..(x + 2).min(W)).all(|u| (y.saturating_sub(1)..(y + 2).min(h)).all(|v| (reference[v * W + u] - reference[i]).abs() <= 0.2 * lit))
    };
    (0..a.len()).filter(|&i| (a[i] - reference[i]).abs() > 0.2 * lit && inside(i)).count()
}

#[test]
fn the_reference_scene_has_its_shadows() {
    // the reference itself: shadowed pixels (the casters' and the floor's own shade) and lit
    // floor at the analytic value, so that the comparisons below compare with a true image
    let l = luminance(Mat4::IDENTITY, 1.0);
    let lit = 3.0 * 0.5 * 3.0 * Vec3::new(-0.6, 0.45, -0.3).normalize().y / std::f32::consts::PI;
    let dark = l.iter().filter(|&&v| v < 0.05 * lit).count();
    let floor = l.iter().filter(|&&v| (v - lit).abs() < 0.02 * lit).count();
    assert!(dark > l.len() / 10 && floor > l.len() / 5, "{dark} dark, {floor} lit of {}", l.len());
}

#[test]
fn a_scene_shrunk_to_micrometres_keeps_its_shadows() {
    let reference = luminance(Mat4::IDENTITY, 1.0);
    for s in [1e-3f32, 1e-6] {
        let l = luminance(Mat4::from_scale(Vec3::splat(s)), s);
        let n = differing(&l, &reference);
        assert!(n == 0, "scale {s}: {n} pixels of {} differ", reference.len());
    }
}

#[test]
fn a_scene_far_from_the_origin_keeps_its_contact_shadows() {
    let reference = luminance(Mat4::IDENTITY, 1.0);
    for t in [Vec3::new(3e3, -5e3, 7e3), Vec3::new(3e4, 5e4, -7e4)] {
        let l = luminance(Mat4::from_translation(t), 1.0);
        let n = differing(&l, &reference);
        assert!(n == 0, "at {t}: {n} pixels of {} differ", reference.len());
    }
}
