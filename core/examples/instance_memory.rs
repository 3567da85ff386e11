//! Resident memory of a million still instances of one sphere: the scene description, then the
//! renderer built from it (its world and acceleration structure).
//!
//! `cargo run --release -p tide-core --example instance_memory [COUNT]`

use glam::{Mat4, Vec3};
use tide_core::scene::*;

fn status(key: &str) -> u64 {
    let s = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    s.lines().find(|l| l.starts_with(key)).and_then(|l| l.split_whitespace().nth(1)).and_then(|v| v.parse::<u64>().ok()).unwrap_or(0) / 1024
}

fn main() {
    let n: u32 = std::env::args().nth(1).and_then(|a| a.parse().ok()).unwrap_or(1_000_000);
    let mut s = SceneDesc::default();
    s.spheres.push(std::sync::Arc::new(SpheresDesc { name: "/s".into(), centers: vec![Vec3::ZERO], radii: vec![0.01], velocities: None, ..Default::default() }));
    s.materials.push(MaterialDesc { name: "/d".into(), surface: SurfaceDesc::Diffuse { color: ColorInput::Const([0.5; 3]) }, interior_medium: None });
    for i in 0..n {
        let m = Mat4::from_translation(Vec3::new((i % 1000) as f32 * 0.05, (i / 1000) as f32 * 0.05, 0.0));
        s.instances_mut().push(InstanceDesc { name: format!("/World/I{i}/S"), geometry: GeometryRef::Spheres(0), transforms: vec![m], times: vec![0.0], material: 0, id: i, visible_to_camera: true, casts_shadows: true, primvar_row: None, index: None });
    }
    let scene = status("VmRSS:");
    let settings = tide_core::RenderSettings { width: 32, height: 32, spp: 1, ..Default::default() };
    let r = tide_core::Renderer::new(&s, settings).expect("renderer");
    let with = status("VmRSS:");
    println!("{n} instances: scene description {scene} MiB; the renderer adds {} MiB (peak {} MiB)", with - scene, status("VmHWM:"));
    drop(r);
}
