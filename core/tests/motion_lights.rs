//! Emissive meshes that move over the shutter light the scene from where they are at each
//! path's time: a small emitter sweeping 2 m above a white floor, by a moving instance and by a
//! deforming mesh, against the floor's radiance integrated over time and the emitter's area by
//! quadrature.

mod common;

use common::*;
use glam::{Mat4, Vec3};
use tide_core::scene::*;

const HALF: f32 = 0.25;
const HEIGHT: f32 = 1.0;
const SWEEP: f32 = 1.0;
const ALBEDO: f32 = 0.5;

/// Radiance of a Lambertian floor of albedo ALBEDO at (rx, 0, rz) lit by a two-sided emitter
/// of radiance 1, a square of side 2·HALF at height HEIGHT centred at x = −SWEEP + 2·SWEEP·t,
/// averaged over t ∈ [0, 1]: (ρ/π) ∫∫ h² / |d|⁴ dA dt (midpoint rule, 256 times × 48² points;
/// error ~10⁻⁴ relative).
fn expected(rx: f64, rz: f64) -> f64 {
    let (nt, na) = (256, 48);
    let (h, half, sweep) = (HEIGHT as f64, HALF as f64, SWEEP as f64);
    let da = (2.0 * half / na as f64).powi(2);
    let mut e = 0.0;
    for it in 0..nt {
        let cx = -sweep + 2.0 * sweep * (it as f64 + 0.5) / nt as f64;
        for i in 0..na {
            for j in 0..na {
                let x = cx - half + 2.0 * half * (i as f64 + 0.5) / na as f64 - rx;
                let z = -half + 2.0 * half * (j as f64 + 0.5) / na as f64 - rz;
                let d2 = x * x + z * z + h * h;
                e += h * h / (d2 * d2) * da;
            }
        }
    }
    ALBEDO as f64 / std::f64::consts::PI * e / nt as f64
}

/// The floor and the camera looking straight down at its centre (a 0.2 m field); `emitter`
/// adds the moving light.
fn scene(emitter: impl Fn(&mut SceneDesc)) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/floor", 10.0)));
    s.materials.push(MaterialDesc { name: "/floor".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([ALBEDO; 3]) }, interior_medium: None });
    s.instances_mut().push(instance("/floor", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    s.materials.push(MaterialDesc { name: "/lamp".into(), surface: SurfaceDesc::Emissive { radiance: [1.0; 3], two_sided: true }, interior_medium: None });
    emitter(&mut s);
    s.camera = camera(Vec3::new(0.0, 3.0, 0.0), Vec3::ZERO, 2.0 * (0.1f32 / 3.0).atan().to_degrees());
    s.camera.shutter_open = 0.0;
    s.camera.shutter_close = 1.0;
    s
}

fn check(s: &SceneDesc, what: &str) {
    let (w, h) = (8, 8);
    let r = render(s, settings(w, h, 512));
    // the field is 0.2 m wide: the mean of the expectation over its pixels' centres
    let mut want = 0.0;
    for y in 0..h {
        for x in 0..w {
            want += expected(0.2 * ((x as f64 + 0.5) / w as f64 - 0.5), 0.2 * ((y as f64 + 0.5) / h as f64 - 0.5));
        }
    }
    want /= (w * h) as f64;
    for ch in 0..3 {
        let (m, se, _) = channel_stats(&r, ch, |_, _| true, w);
        // 4σ of the render, plus 1% for the white illuminant's uplift and the reflectance
        // round trip (each within 0.5%)
        assert!((m - want).abs() < 4.0 * se + 0.01 * want, "{what}, channel {ch}: {m} ± {se}, expected {want}");
    }
}

/// The emitter: a square facing down at height HEIGHT, hidden from the camera (it passes
/// between the camera and the floor).
fn lamp_mesh(dx: f32) -> MeshDesc {
    let mut m = quad_y("/lamp", HALF);
    for p in &mut m.positions {
        *p += Vec3::new(dx, HEIGHT, 0.0);
    }
    m
}

#[test]
fn a_moving_emissive_instance_lights_from_where_it_is_at_each_time() {
    let s = scene(|s| {
        s.meshes.push(std::sync::Arc::new(lamp_mesh(0.0)));
        let mut inst = instance("/lamp", GeometryRef::Mesh(1), Mat4::IDENTITY, 1);
        inst.transforms = vec![Mat4::from_translation(Vec3::new(-SWEEP, 0.0, 0.0)), Mat4::from_translation(Vec3::new(SWEEP, 0.0, 0.0))];
        inst.times = vec![0.0, 1.0];
        inst.visible_to_camera = false;
        s.instances_mut().push(inst);
    });
    check(&s, "moving instance");
}

#[test]
fn a_deforming_emissive_mesh_lights_from_where_it_is_at_each_time() {
    let s = scene(|s| {
        let mut m = lamp_mesh(0.0);
        let (a, b) = (lamp_mesh(-SWEEP), lamp_mesh(SWEEP));
        m.motion = Some(MeshMotion { times: vec![0.0, 1.0], positions: vec![a.positions, b.positions], normals: None });
        s.meshes.push(std::sync::Arc::new(m));
        let mut inst = instance("/lamp", GeometryRef::Mesh(1), Mat4::IDENTITY, 1);
        inst.visible_to_camera = false;
        s.instances_mut().push(inst);
    });
    check(&s, "deforming mesh");
}

/// A UsdLux light keyed to move over the shutter: a rect light of the emitter's size, facing
/// down, sweeping as the emitter does (its light-to-world keyed at the shutter's open and
/// close), and its static counterpart at the open, which must not pass for it. Hidden from the
/// camera, it is not there for camera rays (it passes between the camera and the floor).
fn moving_rect(moving: bool) -> SceneDesc {
    scene(|s| {
        let at = |x: f32| Mat4::from_translation(Vec3::new(x, HEIGHT, 0.0)) * Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2);
        let mut l = light("/rect", LightShape::Rect { width: 2.0 * HALF, height: 2.0 * HALF, texture: None }, at(-SWEEP), 1.0, false);
        l.visible_to_camera = false;
        if moving {
            l.motion = vec![(0.0, at(-SWEEP)), (1.0, at(SWEEP))];
        }
        s.lights.push(l);
    })
}

#[test]
fn a_moving_light_lights_from_where_it_is_at_each_time() {
    check(&moving_rect(true), "moving rect light");
    // the same light left at the open reads well apart (0.010 against 0.0245)
    let r = render(&moving_rect(false), settings(8, 8, 64));
    let (m, _, _) = channel_stats(&r, 1, |_, _| true, 8);
    assert!(m < 0.8 * expected(0.0, 0.0), "static light {m} vs moving {}", expected(0.0, 0.0));
}
