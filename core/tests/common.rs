//! Scene builders shared by the render-level tests.
#![allow(dead_code)]

use glam::{Mat4, Vec3};
use tide_core::scene::*;
use tide_core::{Aov, RenderSettings, Renderer};

pub fn uv_sphere(name: &str, r: f32, n: u32) -> MeshDesc {
    let mut m = MeshDesc { name: name.into(), ..Default::default() };
    let mut normals = Vec::new();
    for i in 0..=n {
        let th = std::f32::consts::PI * i as f32 / n as f32;
        for j in 0..=2 * n {
            let ph = std::f32::consts::PI * j as f32 / n as f32;
            let d = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
            m.positions.push(d * r);
            normals.push(d);
        }
    }
    let w = 2 * n + 1;
    for i in 0..n {
        for j in 0..2 * n {
            let a = i * w + j;
            let b = a + w;
            // counter-clockwise seen from outside
            m.indices.extend([a, a + 1, b, a + 1, b + 1, b]);
        }
    }
    m.normals = Some(normals);
    m
}

pub fn box_mesh(name: &str, lo: Vec3, hi: Vec3) -> MeshDesc {
    let p = |x: usize, y: usize, z: usize| Vec3::new([lo.x, hi.x][x], [lo.y, hi.y][y], [lo.z, hi.z][z]);
    let positions: Vec<Vec3> = (0..8).map(|i| p(i & 1, (i >> 1) & 1, (i >> 2) & 1)).collect();
    // faces CCW from outside
    let quads = [[0, 4, 6, 2], [1, 3, 7, 5], [0, 1, 5, 4], [2, 6, 7, 3], [0, 2, 3, 1], [4, 5, 7, 6]];
    let mut indices = Vec::new();
    for q in quads {
        indices.extend([q[0], q[1], q[2], q[0], q[2], q[3]]);
    }
    MeshDesc { name: name.into(), positions, indices, ..Default::default() }
}

pub fn quad_y(name: &str, half: f32) -> MeshDesc {
    MeshDesc {
        name: name.into(),
        positions: vec![Vec3::new(-half, 0.0, -half), Vec3::new(half, 0.0, -half), Vec3::new(half, 0.0, half), Vec3::new(-half, 0.0, half)],
        indices: vec![0, 2, 1, 0, 3, 2],
        ..Default::default()
    }
}

pub fn instance(name: &str, g: GeometryRef, m: Mat4, material: usize) -> InstanceDesc {
    InstanceDesc { name: name.into(), geometry: g, transforms: vec![m], times: vec![0.0], material, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None }
}

pub fn light(name: &str, shape: LightShape, transform: Mat4, intensity: f32, normalize: bool) -> LightDesc {
    LightDesc { name: name.into(), shape, transform, color: [1.0; 3], intensity, exposure: 0.0, normalize, color_temperature: None, visible_to_camera: true, light_link: None, shadow_link: None, shadow: Default::default(), shaping: None, response: Default::default(), motion: Vec::new(), portals: Vec::new() }
}

pub fn dome(radiance: f32) -> LightDesc {
    light("/dome", LightShape::Dome { texture: None }, Mat4::IDENTITY, radiance, false)
}

/// Camera-to-world of a camera at `eye` looking at `target` (+Y up, looking down −Z).
pub fn look_at(eye: Vec3, target: Vec3) -> Mat4 {
    let z = (eye - target).normalize();
    let up = if z.y.abs() > 0.999 { Vec3::Z } else { Vec3::Y };
    let x = up.cross(z).normalize();
    let y = z.cross(x);
    Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), eye.extend(1.0))
}

/// A camera at `eye` looking at `target` (+Y up), horizontal aperture for the given fov.
pub fn camera(eye: Vec3, target: Vec3, fov_deg: f32) -> CameraDesc {
    let m = look_at(eye, target);
    let focal = 50.0;
    let ap = 2.0 * focal * (fov_deg.to_radians() * 0.5).tan();
    CameraDesc { transforms: vec![m], focal_length: focal, horizontal_aperture: ap, vertical_aperture: ap, clipping_range: [1e-3, 1e6], ..Default::default() }
}

pub fn settings(w: u32, h: u32, spp: u32) -> RenderSettings {
    RenderSettings { width: w, height: h, spp, max_depth: 64, seed: 1, threads: 2, ..Default::default() }
}

pub fn render(scene: &SceneDesc, s: RenderSettings) -> Renderer {
    let spp = s.spp;
    let mut r = Renderer::new(scene, s).expect("renderer");
    assert!(r.render_pass(spp, None));
    r
}

/// Renders progressively in passes of 1, 2, 4, … samples up to `spp`.
pub fn render_progressive(scene: &SceneDesc, s: tide_core::RenderSettings) -> Renderer {
    let target = s.spp;
    let mut r = Renderer::new(scene, s).expect("renderer");
    let mut pass = 1;
    while r.samples_per_pixel() < target {
        let n = pass.min(target - r.samples_per_pixel());
        assert!(r.render_pass(n, None));
        pass *= 2;
    }
    r
}

/// Mean and standard error of the mean of one channel over the pixels selected by `keep`.
pub fn channel_stats(r: &Renderer, ch: usize, keep: impl Fn(u32, u32) -> bool, width: u32) -> (f64, f64, usize) {
    let px = r.aov_pixels(Aov::Color);
    let vals: Vec<f64> = px.chunks_exact(4).enumerate().filter(|(i, _)| keep(*i as u32 % width, *i as u32 / width)).map(|(_, p)| p[ch] as f64).collect();
    let n = vals.len() as f64;
    let mean = vals.iter().sum::<f64>() / n;
    let var = vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt(), vals.len())
}

/// A closed water body over [-h, h]² from y = `bottom` to a wavy top around y = 0.
pub fn wavy_water(h: f32, n: u32, amp: f32, bottom: f32) -> MeshDesc {
    let mut m = MeshDesc { name: "/water".into(), ..Default::default() };
    let height = |x: f32, z: f32| amp * ((2.1 * x + 0.3).sin() * (1.7 * z).cos() + 0.5 * (3.3 * x - 2.9 * z).sin());
    let w = n + 1;
    for j in 0..=n {
        for i in 0..=n {
            let x = -h + 2.0 * h * i as f32 / n as f32;
            let z = -h + 2.0 * h * j as f32 / n as f32;
            m.positions.push(Vec3::new(x, height(x, z), z));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = j * w + i;
            // counter-clockwise seen from above (+y outside)
            m.indices.extend([a, a + w, a + 1, a + 1, a + w, a + w + 1]);
        }
    }
    // bottom and sides: a ring of bottom vertices under the rim
    let base = m.positions.len() as u32;
    let rim: Vec<u32> = (0..n).chain((0..n).map(|j| j * w + n)).chain((0..n).map(|i| n * w + n - i)).chain((0..n).map(|j| (n - j) * w)).collect();
    for &r in &rim {
        let p = m.positions[r as usize];
        m.positions.push(Vec3::new(p.x, bottom, p.z));
    }
    let k = rim.len() as u32;
    for s in 0..k {
        let (a, b) = (rim[s as usize], rim[((s + 1) % k) as usize]);
        let (c, d) = (base + s, base + (s + 1) % k);
        // side quads facing outward
        m.indices.extend([a, b, c, b, d, c]);
    }
    // bottom fan (facing −y)
    let centre = m.positions.len() as u32;
    m.positions.push(Vec3::new(0.0, bottom, 0.0));
    for s in 0..k {
        m.indices.extend([centre, base + s, base + (s + 1) % k]);
    }
    m
}

/// A sun of `angle_deg` across at the given elevation and azimuth (degrees), 3 W/m² normal to it.
pub fn sun(angle_deg: f32, elevation_deg: f32, azimuth_deg: f32) -> LightDesc {
    let (e, a) = (elevation_deg.to_radians(), azimuth_deg.to_radians());
    let to_sun = Vec3::new(e.cos() * a.cos(), e.sin(), e.cos() * a.sin());
    let z = to_sun;
    let x = if z.y.abs() > 0.99 { Vec3::X } else { Vec3::Y.cross(z).normalize() };
    let y = z.cross(x);
    let m = Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), glam::Vec4::W);
    light("/sun", LightShape::Distant { angle_deg }, m, 3.0, true)
}

/// A camera 1.5 m under a wavy surface in scattering water, looking up towards the sun's side:
/// god rays (sun → surface → medium → camera) and surface caustics on a sand floor.
pub fn underwater(sun_angle: f32) -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(quad_y("/sand", 6.0)));
    s.meshes.push(std::sync::Arc::new(wavy_water(6.0, 64, 0.05, -3.01)));
    s.media.push(MediumDesc { name: "/sea".into(), sigma_a: SpectrumDesc::Rgb([0.12, 0.05, 0.03]), sigma_s: SpectrumDesc::Rgb([0.25, 0.25, 0.25]), scale: 1.0, phase: PhaseDesc::HenyeyGreenstein { g: 0.6 }, water: None, method: Default::default() });
    s.materials.push(MaterialDesc { name: "/sand".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5, 0.45, 0.35]) }, interior_medium: None });
    s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { ior: 1.333, ..Default::default() }), interior_medium: Some(0) });
    s.instances_mut().push(instance("/sand", GeometryRef::Mesh(0), Mat4::from_translation(Vec3::new(0.0, -3.0, 0.0)), 0));
    s.instances_mut().push(instance("/water", GeometryRef::Mesh(1), Mat4::IDENTITY, 1));
    s.lights.push(sun(sun_angle, 60.0, -90.0));
    s.lights.push(dome(0.05));
    s.camera = camera(Vec3::new(0.0, -1.5, 3.0), Vec3::new(0.0, -1.2, -2.0), 60.0);
    s
}
