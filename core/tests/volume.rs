//! Render-level tests of volumes (density grids in a box that paths cross unchanged):
//! Beer–Lambert through an absorbing grid seen against a white environment, `scale`
//! (densityScale) multiplying the grid, a camera inside a volume, a volume's medium replacing
//! water inside its box, shadow rays attenuated by a volume between a light and a plane, and a
//! volume moving across the view over the shutter.

mod common;
use common::*;
use glam::{Mat4, Quat, Vec3};
use tide_core::scene::*;
use tide_core::spectrum::{cie, color, uplift};

fn rgb_of(l: impl Fn(f32) -> f32) -> [f32; 3] {
    let xyz = cie::cie().integrate_xyz(|lam| l(lam as f32) as f64);
    color::xyz_to_rgb([xyz[0] as f32, xyz[1] as f32, xyz[2] as f32], ColorSpace::LinearRec709)
}

fn absorbing(name: &str, sigma: [f32; 3], scale: f32) -> MediumDesc {
    MediumDesc { name: name.into(), sigma_a: SpectrumDesc::Rgb(sigma), sigma_s: SpectrumDesc::Rgb([0.0; 3]), scale, phase: PhaseDesc::Isotropic, water: None, method: Default::default() }
}

/// A volume of `dims` voxels of density `value`, `voxel` wide, its grid point (0, 0, 0) at
/// `origin`. Along an axis through the interior, ∫ρ = value·(dims + 1 − 1)·voxel: full
/// density between the first and last grid point plus a half-voxel ramp at either end.
fn volume(name: &str, dims: [u32; 3], value: f32, voxel: f32, origin: Vec3, medium: usize) -> VolumeDesc {
    let n = (dims[0] * dims[1] * dims[2]) as usize;
    VolumeDesc {
        name: name.into(),
        density: GridDesc::dense(format!("{name}.vdb:density"), dims, &vec![value; n], Mat4::from_scale_rotation_translation(Vec3::splat(voxel), Quat::IDENTITY, origin)).unwrap(),
        motion: Vec::new(),
        medium,
        id: 0,
        visible_to_camera: true,
        casts_shadows: true,
    }
}

fn check_rgb(r: &tide_core::Renderer, w: u32, expect: [f32; 3], what: &str) {
    for (ch, e) in expect.into_iter().enumerate() {
        let (m, se, _) = channel_stats(r, ch, |_, _| true, w);
        // 3σ, plus 2e-3 for the quadrature and f32 accumulation
        assert!((m - e as f64).abs() < 3.0 * se + 2e-3, "{what}, channel {ch}: {m} ± {se} vs {e}");
    }
}

/// White environment seen through an absorbing volume whose optical thickness along the view
/// is σ·`d` (the camera looks down −Z with a 2° field, so path lengths differ by < 2e-4).
fn through_volume(sigma: [f32; 3], scale: f32, value: f32) -> (SceneDesc, f32) {
    let mut s = SceneDesc::default();
    s.media.push(absorbing("/fog", sigma, scale));
    // 40 × 40 × 3 voxels of 0.125: along z, ∫ρ = value·3·0.125
    s.volumes.push(volume("/Fog", [40, 40, 3], value, 0.125, Vec3::new(-2.5, -2.5, -0.2), 0));
    s.lights.push(dome(1.0));
    s.camera = camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 2.0);
    (s, 3.0 * 0.125)
}

#[test]
fn beer_lambert_through_an_absorbing_volume() {
    let sigma = [3.0f32, 0.6, 0.1];
    let (s, d) = through_volume(sigma, 1.0, 1.0);
    let (w, h) = (8, 8);
    let r = render(&s, settings(w, h, 64));
    let sig = uplift::unbounded(sigma, ColorSpace::LinearRec709);
    let white = color::white_illuminant(ColorSpace::LinearRec709);
    let expect = rgb_of(|l| (-sig.eval(l) * d).exp() * white.eval(l));
    check_rgb(&r, w, expect, "through the volume");
    // densityScale multiplies the grid: half the density at twice the scale looks the same,
    // twice the scale looks like twice the thickness
    let (s2, _) = through_volume(sigma, 2.0, 0.5);
    check_rgb(&render(&s2, settings(w, h, 64)), w, expect, "scale 2, density 0.5");
    let (s3, _) = through_volume(sigma, 2.0, 1.0);
    let expect2 = rgb_of(|l| (-sig.eval(l) * 2.0 * d).exp() * white.eval(l));
    check_rgb(&render(&s3, settings(w, h, 64)), w, expect2, "scale 2");
    assert!(expect2[1] < 0.8 * expect[1]);
}

#[test]
fn a_camera_inside_a_volume_sees_through_the_rest_of_it() {
    let sigma = [1.0f32, 1.0, 1.0];
    let mut s = SceneDesc::default();
    s.media.push(absorbing("/fog", sigma, 1.0));
    // z from grid point 0 at z = 0 to 8 at z = 1; the camera at z = 0.5 (grid z 4) looks
    // down −Z: ∫ρ = 4 voxels of full density plus the half-voxel ramp = 4.5·0.125
    s.volumes.push(volume("/Fog", [40, 40, 9], 1.0, 0.125, Vec3::new(-2.5, -2.5, 0.0), 0));
    s.lights.push(dome(1.0));
    s.camera = camera(Vec3::new(0.0, 0.0, 0.5), Vec3::new(0.0, 0.0, -1.0), 2.0);
    let (w, h) = (8, 8);
    let r = render(&s, settings(w, h, 64));
    let sig = uplift::unbounded(sigma, ColorSpace::LinearRec709);
    let white = color::white_illuminant(ColorSpace::LinearRec709);
    let expect = rgb_of(|l| (-sig.eval(l) * 4.5 * 0.125).exp() * white.eval(l));
    check_rgb(&r, w, expect, "camera inside the volume");
}

// A grid placed by a mirroring transform (x scaled by −1) is the same volume: its box keeps
// its outside out (the box's winding must not be turned over on top of the normal transform,
// which already keeps a mirrored mesh's front), so light crossing it from outside and a
// camera inside it see Beer–Lambert as for the unmirrored grid.
#[test]
fn a_mirrored_grid_is_the_same_volume() {
    let sigma = [1.0f32, 1.0, 1.0];
    let sig = uplift::unbounded(sigma, ColorSpace::LinearRec709);
    let white = color::white_illuminant(ColorSpace::LinearRec709);
    let (w, h) = (8, 8);
    let mirror = |v: &mut VolumeDesc| {
        // grid x 0 to 39 runs from +2.375 down to −2.5 (x ↦ −0.125 − x): the same box
        v.density.local_to_world = Mat4::from_translation(Vec3::new(-0.125, 0.0, 0.0)) * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)) * v.density.local_to_world;
    };
    // the camera outside, looking through 3 voxels of z
    let (mut s, d) = through_volume(sigma, 1.0, 1.0);
    mirror(&mut s.volumes[0]);
    let expect = rgb_of(|l| (-sig.eval(l) * d).exp() * white.eval(l));
    check_rgb(&render(&s, settings(w, h, 64)), w, expect, "through the mirrored volume");
    // the camera inside, looking down −Z through 4.5 voxels
    let mut s = SceneDesc::default();
    s.media.push(absorbing("/fog", sigma, 1.0));
    s.volumes.push(volume("/Fog", [40, 40, 9], 1.0, 0.125, Vec3::new(-2.5, -2.5, 0.0), 0));
    mirror(&mut s.volumes[0]);
    s.lights.push(dome(1.0));
    s.camera = camera(Vec3::new(0.0, 0.0, 0.5), Vec3::new(0.0, 0.0, -1.0), 2.0);
    let expect = rgb_of(|l| (-sig.eval(l) * 4.5 * 0.125).exp() * white.eval(l));
    check_rgb(&render(&s, settings(w, h, 64)), w, expect, "camera inside the mirrored volume");
}

#[test]
fn inside_its_box_a_volume_replaces_the_water_medium() {
    // an index-matched absorbing slab 1 thick with an empty volume box 0.5 thick inside it:
    // only the water outside the box absorbs
    let sigma_w = [2.0f32, 1.0, 0.5];
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(box_mesh("/slab", Vec3::new(-5.0, -5.0, -0.5), Vec3::new(5.0, 5.0, 0.5))));
    s.media.push(absorbing("/water", sigma_w, 1.0));
    s.media.push(absorbing("/fog", [0.0; 3], 1.0));
    s.materials.push(MaterialDesc { name: "/m".into(), surface: SurfaceDesc::Water(WaterDesc { ior: 1.0, ..Default::default() }), interior_medium: Some(0) });
    s.instances_mut().push(instance("/slab", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
    // 1 voxel of 0.25 in z: the box spans grid z ∈ [−1, 1], i.e. 0.5
    s.volumes.push(volume("/Empty", [20, 20, 1], 0.0, 0.25, Vec3::new(-2.5, -2.5, 0.0), 1));
    s.lights.push(dome(1.0));
    s.camera = camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 2.0);
    let (w, h) = (8, 8);
    let r = render(&s, settings(w, h, 64));
    let sig = uplift::unbounded(sigma_w, ColorSpace::LinearRec709);
    let white = color::white_illuminant(ColorSpace::LinearRec709);
    let expect = rgb_of(|l| (-sig.eval(l) * 0.5).exp() * white.eval(l));
    check_rgb(&r, w, expect, "water with an empty volume inside");
}

#[test]
fn shadow_rays_are_attenuated_by_a_volume_between_light_and_plane() {
    // a white diffuse plane under a distant light straight above; an absorbing grey volume
    // (σ = 1, ∫ρ = 0.5) hangs between them, away from the camera's view: the plane's radiance
    // drops by e^{−0.5}
    let scene = |with: bool| {
        let mut s = SceneDesc::default();
        s.meshes.push(std::sync::Arc::new(quad_y("/plane", 50.0)));
        s.materials.push(MaterialDesc { name: "/white".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.8; 3]) }, interior_medium: None });
        s.instances_mut().push(instance("/plane", GeometryRef::Mesh(0), Mat4::IDENTITY, 0));
        s.media.push(absorbing("/fog", [1.0; 3], 1.0));
        if with {
            // 4 voxels of 0.125 in y between y = 2 and 2.375: ∫ρ = 4·0.125 = 0.5
            s.volumes.push(volume("/Fog", [200, 4, 200], 1.0, 0.125, Vec3::new(-12.5, 2.0, -12.5), 0));
        }
        s.lights.push(light("/sun", LightShape::Distant { angle_deg: 0.0 }, Mat4::from_rotation_x(-std::f32::consts::FRAC_PI_2), 1.0, false));
        // the camera below the volume, looking down at the plane
        s.camera = camera(Vec3::new(0.0, 1.0, 0.3), Vec3::ZERO, 5.0);
        s
    };
    let (w, h) = (8, 8);
    let lit = render(&scene(false), settings(w, h, 16));
    let shaded = render(&scene(true), settings(w, h, 256));
    for ch in 0..3 {
        let (a, sa, _) = channel_stats(&lit, ch, |_, _| true, w);
        let (b, sb, _) = channel_stats(&shaded, ch, |_, _| true, w);
        assert!(a > 0.1, "the plane is lit: {a}");
        let ratio = b / a;
        let se = ratio * ((sa / a).powi(2) + (sb / b).powi(2)).sqrt();
        // grey σ uplifts to a flat spectrum within 1e-3: the ratio is e^{−0.5} in every
        // channel, within 3σ and that flatness
        let expect = (-0.5f64).exp();
        assert!((ratio - expect).abs() < 3.0 * se + 2e-3, "channel {ch}: {ratio} ± {se} vs {expect}");
    }
}

#[test]
fn a_volume_moving_across_the_view_blurs_over_the_shutter() {
    // an absorbing slab (8 × 40 × 3 voxels of 0.125 m) sweeps along x from −3 m to +3 m over
    // the shutter in front of a white environment; the camera sees x ∈ ±0.05 m. Trilinear
    // density is the product of tents along each axis, so along the view the optical depth is
    // σ·d·f(u), f the slab's profile across x at the offset u of the pixel from the slab: 0,
    // a one-voxel ramp up, 1 over 7 voxels, a ramp down. The time average of the transmittance
    // is then (1/6 m)·[(6 − 9v) + 7v·e^{−σd} + 2v·(1 − e^{−σd})/(σd)], v the voxel width
    let sigma = [2.0f32, 1.0, 0.5];
    let (voxel, d) = (0.125f32, 3.0 * 0.125f32);
    let place = |x: f32| Mat4::from_scale_rotation_translation(Vec3::splat(voxel), Quat::IDENTITY, Vec3::new(x, -2.5, -0.2));
    let mut s = SceneDesc::default();
    s.media.push(absorbing("/fog", sigma, 1.0));
    let mut v = volume("/Fog", [8, 40, 3], 1.0, voxel, Vec3::ZERO, 0);
    v.motion = vec![(0.0, place(-3.0)), (1.0, place(3.0))];
    s.volumes.push(v);
    s.lights.push(dome(1.0));
    s.camera = camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 2.0);
    s.camera.shutter_open = 0.0;
    s.camera.shutter_close = 1.0;
    let (w, h) = (8, 8);
    let r = render(&s, settings(w, h, 256));
    let sig = uplift::unbounded(sigma, ColorSpace::LinearRec709);
    let white = color::white_illuminant(ColorSpace::LinearRec709);
    let v = voxel;
    let mean_tr = |k: f32| ((6.0 - 9.0 * v) + 7.0 * v * (-k).exp() + 2.0 * v * (1.0 - (-k).exp()) / k) / 6.0;
    let expect = rgb_of(|l| mean_tr(sig.eval(l) * d) * white.eval(l));
    check_rgb(&r, w, expect, "moving volume");
    // a still slab out of view would leave the environment unattenuated
    assert!(expect[0] < 0.93, "the blur is visible: {expect:?}");
}
