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

/// Mean and standard error of the mean of one channel over the pixels selected by `keep`.
pub fn channel_stats(r: &Renderer, ch: usize, keep: impl Fn(u32, u32) -> bool, width: u32) -> (f64, f64, usize) {
    let px = r.aov_pixels(Aov::Color);
    let vals: Vec<f64> = px.chunks_exact(4).enumerate().filter(|(i, _)| keep(*i as u32 % width, *i as u32 / width)).map(|(_, p)| p[ch] as f64).collect();
    let n = vals.len() as f64;
    let mean = vals.iter().sum::<f64>() / n;
    let var = vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt(), vals.len())
}
