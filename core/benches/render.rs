//! Samples per second of the path tracer on a small water scene built here: a closed body of
//! rough water (wavy top, absorbing and scattering interior) over a diffuse floor, lit by a
//! sun and a sky, seen from above at an angle; 320×180.
//!
//!     cargo bench -p tide-core --bench render [-- SPP [THREADS,...]]
//!
//! (SPP per timed pass, default 4; threads default `1,2`; each timing is the best of
//! `TIDE_BENCH_REPEATS` passes, default 1, after an untimed 1-spp pass.) Prints one JSON line.

use glam::{Mat4, Vec3};
use std::time::Instant;
use tide_core::scene::*;
use tide_core::{RenderSettings, Renderer};

const W: u32 = 320;
const H: u32 = 180;

fn height(x: f32, z: f32) -> f32 {
    0.04 * (3.1 * x + 0.7 * z).sin() + 0.025 * (5.3 * z - 2.2 * x + 1.0).sin() + 0.01 * (13.0 * x + 9.0 * z).sin()
}

/// A closed water body over [-2, 2]² from y = -1 up to a wavy top, triangles facing outwards.
fn water_body(n: u32) -> MeshDesc {
    let mut m = MeshDesc { name: "/water".into(), ..Default::default() };
    let tri = |m: &mut MeshDesc, p: [Vec3; 3], outward: Vec3| {
        let flip = (p[1] - p[0]).cross(p[2] - p[0]).dot(outward) < 0.0;
        let base = m.positions.len() as u32;
        m.positions.extend(if flip { [p[0], p[2], p[1]] } else { p });
        m.indices.extend([base, base + 1, base + 2]);
    };
    let top = |i: u32, j: u32| {
        let (x, z) = (-2.0 + 4.0 * i as f32 / n as f32, -2.0 + 4.0 * j as f32 / n as f32);
        Vec3::new(x, height(x, z), z)
    };
    let bottom = |p: Vec3| Vec3::new(p.x, -1.0, p.z);
    for i in 0..n {
        for j in 0..n {
            let (a, b, c, d) = (top(i, j), top(i + 1, j), top(i, j + 1), top(i + 1, j + 1));
            tri(&mut m, [a, b, c], Vec3::Y);
            tri(&mut m, [b, d, c], Vec3::Y);
        }
    }
    // side walls along the four edges, and the bottom
    for k in 0..n {
        for (p, q) in [(top(k, 0), top(k + 1, 0)), (top(k, n), top(k + 1, n)), (top(0, k), top(0, k + 1)), (top(n, k), top(n, k + 1))] {
            let out = Vec3::new((p.x + q.x) * 0.5, 0.0, (p.z + q.z) * 0.5);
            let out = if out.x.abs() > out.z.abs() { Vec3::X * out.x.signum() } else { Vec3::Z * out.z.signum() };
            tri(&mut m, [p, q, bottom(q)], out);
            tri(&mut m, [p, bottom(q), bottom(p)], out);
        }
    }
    let c = [Vec3::new(-2.0, -1.0, -2.0), Vec3::new(2.0, -1.0, -2.0), Vec3::new(2.0, -1.0, 2.0), Vec3::new(-2.0, -1.0, 2.0)];
    tri(&mut m, [c[0], c[1], c[2]], -Vec3::Y);
    tri(&mut m, [c[0], c[2], c[3]], -Vec3::Y);
    m
}

fn look_at(eye: Vec3, target: Vec3) -> Mat4 {
    let z = (eye - target).normalize();
    let x = Vec3::Y.cross(z).normalize();
    let y = z.cross(x);
    Mat4::from_cols(x.extend(0.0), y.extend(0.0), z.extend(0.0), eye.extend(1.0))
}

fn light(name: &str, shape: LightShape, transform: Mat4, intensity: f32) -> LightDesc {
    LightDesc { name: name.into(), shape, transform, color: [1.0; 3], intensity, exposure: 0.0, normalize: true, color_temperature: None, visible_to_camera: true, light_link: None, shadow_link: None, shadow: Default::default(), shaping: None, response: Default::default(), motion: Vec::new(), portals: Vec::new() }
}

fn scene() -> SceneDesc {
    let mut s = SceneDesc::default();
    s.meshes.push(std::sync::Arc::new(water_body(128)));
    // the floor, just above the water body's bottom: a diffuse sand seen through the water
    s.meshes.push(std::sync::Arc::new(MeshDesc {
        name: "/floor".into(),
        positions: vec![Vec3::new(-1.99, -0.99, -1.99), Vec3::new(1.99, -0.99, -1.99), Vec3::new(1.99, -0.99, 1.99), Vec3::new(-1.99, -0.99, 1.99)],
        indices: vec![0, 2, 1, 0, 3, 2],
        ..Default::default()
    }));
    s.media.push(MediumDesc {
        name: "/water/medium".into(),
        sigma_a: SpectrumDesc::Rgb([0.45, 0.06, 0.02]),
        sigma_s: SpectrumDesc::Rgb([0.05, 0.06, 0.08]),
        scale: 1.0,
        phase: PhaseDesc::HenyeyGreenstein { g: 0.9 },
        water: None,
        method: Default::default(),
    });
    s.materials.push(MaterialDesc { name: "/water".into(), surface: SurfaceDesc::Water(WaterDesc { roughness: 0.05, ..Default::default() }), interior_medium: Some(0) });
    s.materials.push(MaterialDesc { name: "/sand".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.7, 0.6, 0.45]) }, interior_medium: None });
    let inst = |name: &str, g, material| InstanceDesc { name: name.into(), geometry: g, transforms: vec![Mat4::IDENTITY], times: vec![0.0], material, id: 0, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None };
    s.instances_mut().push(inst("/water", GeometryRef::Mesh(0), 0));
    s.instances_mut().push(inst("/floor", GeometryRef::Mesh(1), 1));
    s.lights.push(light("/sky", LightShape::Dome { texture: None }, Mat4::IDENTITY, 0.4));
    s.lights.push(light("/sun", LightShape::Distant { angle_deg: 0.53 }, look_at(Vec3::ZERO, Vec3::new(-0.4, -1.0, -0.3)), 5.0));
    let eye = Vec3::new(0.0, 2.2, 3.2);
    let focal = 35.0;
    let ap = 2.0 * focal * (50f32.to_radians() * 0.5).tan();
    s.camera = CameraDesc {
        transforms: vec![look_at(eye, Vec3::new(0.0, -0.6, 0.0))],
        focal_length: focal,
        horizontal_aperture: ap,
        vertical_aperture: ap * H as f32 / W as f32,
        clipping_range: [1e-3, 1e6],
        ..Default::default()
    };
    s
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| !a.starts_with("--")).collect();
    let spp: u32 = args.first().map_or(4, |s| s.parse().expect("spp"));
    let threads: Vec<usize> = args.get(1).map_or("1,2", |s| s.as_str()).split(',').map(|s| s.parse().expect("thread count")).collect();
    let repeats: usize = std::env::var("TIDE_BENCH_REPEATS").ok().map_or(1, |s| s.parse().expect("TIDE_BENCH_REPEATS"));
    let s = scene();
    print!("{{\"width\": {W}, \"height\": {H}, \"spp\": {spp}, \"triangles\": {}", s.meshes.iter().map(|m| m.indices.len() / 3).sum::<usize>());
    let mut images: Vec<Vec<f32>> = Vec::new();
    for &t in &threads {
        let settings = RenderSettings { width: W, height: H, spp, max_depth: 64, seed: 7, threads: t, ..Default::default() };
        let mut best = f64::INFINITY;
        for _ in 0..repeats {
            let mut r = Renderer::new(&s, settings.clone()).expect("renderer");
            assert!(r.problems().is_empty(), "{:?}", r.problems());
            r.render_pass(1, None); // warm-up: page in, spin up the pool
            r.reset();
            let start = Instant::now();
            assert!(r.render_pass(spp, None));
            best = best.min(start.elapsed().as_secs_f64());
            if images.len() < threads.iter().position(|&x| x == t).unwrap() + 1 {
                images.push(r.aov_pixels(tide_core::Aov::Color));
            }
        }
        print!(", \"t{t}_s\": {best:.3}, \"t{t}_msamples_s\": {:.4}", (W * H * spp) as f64 / best / 1e6);
    }
    let same = images.windows(2).all(|w| w[0].iter().zip(&w[1]).all(|(a, b)| a.to_bits() == b.to_bits()));
    let img = &images[0];
    let mean = img.chunks(4).map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0).sum::<f64>() / (W * H) as f64;
    println!(", \"mean_color\": {mean:.5}, \"identical_across_threads\": {same}, \"repeats\": {repeats}}}");
    assert!(same, "images differ between thread counts");
}
